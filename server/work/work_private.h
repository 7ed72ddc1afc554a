/* work_private.h -- what the files of the work layer share, and its one rule.
 *
 * Layer: work, private.  Included only by the work layer's own files
 * (work.c, lru.c, cache.c, rcache.c, scenes.c, cost.c, fair.c, resolve.c,
 * passes.c, task.c, budget.c, gate.c, sched.c, jobs.c, events.c, watch.c, compile.c); the layers
 * above see work.h alone.
 * May include: work.h (and through it base.h, <rayd/rayd.h>).
 *
 * THE ONE LOCK.  work_lock is the only mutex of the server.  It guards every
 * task, the active list and queue counters, the jobs table, every event
 * stream's cursor, the test gate, the compiled-scene cache (cache.c) and the
 * result cache (rcache.c) -- those two have no lock of their own.  Rules:
 *   - a function whose comment says "lock held" is called with it held
 *     (and says so with work_assert_locked()), any other public function of
 *     the layer takes it itself; it is taken and released only through
 *     work_lock_take / work_lock_give / work_wait, which know its owner;
 *   - rendering, PNG encoding, scene parsing and hashing run without it;
 *   - a waiter's done() is never called with it held: waiters are unlinked
 *     onto a struct task_notify under the lock and answered after releasing
 *     it (task_notify_run);
 *   - a waiter's suspend() is called with it held, before the waiter is
 *     linked, so a done() can never overtake its suspend();
 *   - work_cond (with work_lock) wakes workers (new tiles, the gate, stop)
 *     and the watcher's periodic wait.
 * Calls inside the layer go one way too, in this order (a file calls only
 * files before it): work (the lock), lru, cache, rcache, scenes, cost, fair,
 * resolve, passes, task, budget, gate, jobs, events, watch, sched, compile.
 * Ownership: a task is referenced by the active list and by each job of it
 * (task.refs, lock held); it holds its scene until it finishes.  A job is
 * referenced by the table and by each open event stream (job.refs).
 */
#ifndef RAYD_SERVER_WORK_PRIVATE_H
#define RAYD_SERVER_WORK_PRIVATE_H

#include "work/work.h"

#include <pthread.h>

#define TASK_INTERACTIVE (256L * 256L) /* pixels of a preview or a tile */
#define TASK_BULK_EVERY 4              /* when both classes wait, bulk gets 1 tile in 4 */
#define EVENTS_PING_SECONDS 15.0       /* seconds of silence before a keep-alive */

extern pthread_cond_t work_cond;

/* ---- work.c: the lock, with its owner known ------------------------------ */

void work_lock_take(void);
void work_lock_give(void); /* asserts the caller holds it */
bool work_locked(void);    /* held by the calling thread */
/* pthread_cond_wait / timedwait on c with work_lock (held; held again after). */
void work_wait(pthread_cond_t *c);
int work_timedwait(pthread_cond_t *c, const struct timespec *until);
/* The contract "lock held" (or "called without the lock"), checked. */
#define work_assert_locked() server_assert(work_locked())
#define work_assert_unlocked() server_assert(!work_locked())

/* ---- lru.c: the index under both caches; entries embed a struct lru_node -- */

struct lru_node {
    const char *key;
    size_t bytes; /* counted against the budget */
    struct lru_node *hnext, *prev, *next;
};
struct lru {
    struct lru_node **table;
    unsigned nbuckets;
    struct lru_node *head, *tail; /* most recent first */
    size_t budget, bytes, count;
    void (*evict)(struct lru_node *n); /* the owner lets go of an evicted entry */
};
void lru_init(struct lru *l, struct lru_node **table, unsigned nbuckets, size_t budget,
              void (*evict)(struct lru_node *n));
struct lru_node *lru_find(struct lru *l, const char *key); /* and makes it the most recent */
bool lru_insert(struct lru *l, struct lru_node *n);        /* false: bigger than the budget */
void lru_remove(struct lru *l, struct lru_node *n);
void lru_clear(struct lru *l); /* evicts everything */

/* ---- cache.c (lock held) ----------------------------------------------------- */

void cache_init(size_t budget_bytes);
struct cache_entry *cache_get(const char *id); /* refs the entry, bumps LRU */
/* Inserts (or returns the existing entry for id of that version, freeing
 * scene; one of another version is replaced); refs it.  The scene's bytes
 * were reserved in the memory budget by the caller: the entry releases them
 * when it frees the scene (at once when it was a duplicate). */
struct cache_entry *cache_put(const char *id, const char *version, rayd_scene *scene);
struct cache_entry *cache_ref(struct cache_entry *e);
void cache_release(struct cache_entry *e); /* drops a ref; frees when evicted */
void cache_stats(size_t *bytes, size_t *entries);
void cache_free_all(void);
/* Evicts the least recently used entry no render holds (its scene freed);
 * false when there is none. */
bool cache_evict_one(void);

/* ---- scenes.c: the pieces compile.c runs where it chooses (any thread) ---- */

/* The scene id of body (its SHA-256); false after an out_of_memory error. */
bool scenes_id(const char *body, size_t len, char id[65], struct rayd_error *err);
struct cache_entry *scenes_peek(const char *id);            /* referenced, files not checked */
bool scenes_current(struct cache_entry *e, bool have_text); /* scenefiles_usable */
/* The bytes a parse of a len-byte body reserves (kind parses) before it
 * starts: its first cap, grown by scenes_build as the core charges what it
 * decodes and builds. */
size_t scenes_parse_cap(size_t len);
/* The same for the check of a frame range's values (compile_check_frames),
 * which builds no object: the JSON tree alone. */
size_t scenes_check_cap(size_t len);
/* Parses and builds body (of that id) at frame `frame` (-1: as
 * rayd_scene_parse, the first) and caches it; *out referenced.  held:
 * the bytes of kind parses reserved for it (scenes_parse_cap), which this
 * releases or turns into the scene's own on every path.  *full: refused
 * because the memory budget has no room now (503 memory_full).  cancel:
 * the parse's flag (rayd_limits.cancel), or NULL. */
enum rayd_status scenes_build(const char *id, const char *body, size_t len, long frame, size_t held,
                              const atomic_int *cancel, struct cache_entry **out,
                              struct rayd_error *err, bool *full);
/* rayd_scene_check_frames of body under the options' limits. */
enum rayd_status scenes_check_frames(const char *body, size_t len, long first, long last,
                                     const atomic_int *cancel, struct rayd_error *err);

/* ---- scenefiles.c: the files a cached scene read (any thread, no lock) ---- */

/* Whether a cached scene may answer: it read no file, or each is as it was
 * read (a stat each) and, when the request brings the text to compile
 * again (have_text), was settled then. */
bool scenefiles_usable(const rayd_scene *scene, bool have_text);
/* The version of the scene of id just compiled: id when it read no file,
 * else the SHA-256 of id and the files' identities (unique to this compile
 * when they were not settled); false only if out of memory. */
bool scenefiles_version(const char *id, const rayd_scene *scene, char out[65]);

/* ---- rcache.c (lock held) ------------------------------------------------------ */

void rcache_init(size_t budget_bytes);
bool rcache_on(void); /* --result-cache-mb above 0 */
/* The PNG (referenced) and, if rays is not NULL, the rays its render cast. */
struct blob *rcache_get(const char *key, uint64_t *rays);
void rcache_put(const char *key, struct blob *png, uint64_t rays);
void rcache_stats(size_t *bytes, size_t *entries);
void rcache_free_all(void);
bool rcache_evict_one(void); /* the least recently used result; false: empty */

/* ---- scenes.c ---------------------------------------------------------------- */

void scenes_start(void); /* sizes both caches, registers their gauges */
void scenes_stop(void);  /* empties both caches, lets go of the image cache */

/* ---- cost.c (lock held but for cost_rays, cost_task_tile) ----------------------- */

/* The tile edge of a task rendering what of scene: the side of a square
 * tile whose estimated rays stay under the tile budget, at least
 * COST_DENOISE_TILE for a denoised one (each tile renders the filter's
 * apron around it).  Any lock. */
int cost_task_tile(const rayd_scene *scene, const struct work_target *what);
void cost_set_workers(int workers); /* before the workers start */
int cost_worker_count(void);        /* the workers; any lock */
/* A tile of scene_id for client: its estimated rays and the seconds it
 * took; complete false: it was stopped part way. */
void cost_observe(const char *scene_id, uint64_t client, double rays, double seconds,
                  bool complete);
double cost_seconds(double rays); /* of the whole pool, at the node's rate */
/* Whether a tile of scene_id of this many estimated rays is quick: no
 * dearer than a tile's size allows (cost_tile), and a quarter second at
 * most at the scene's measured rate (a scene whose rays are dear, a
 * thousand planes every ray tests, is priced by its rays alone). */
bool cost_tile_quick(const char *scene_id, double rays);
/* scene_id's rate over the node's: times a task's rays, node-rate rays. */
double cost_scene_weight(const char *scene_id);

/* ---- fair.c (lock held) ------------------------------------------------------- */

uint64_t fair_last(uint64_t client); /* the tick it was last served, 0: never */
void fair_served(uint64_t client);

/* ---- resolve.c: a tile's sums into a task's pixels (no lock) ----------------- */

/* Where a tile's pixels go: its 8-bit image at (x, y) of img and, when lin
 * is not NULL, its linear floats at (x, y) of lin (lin_w pixels a row). */
struct resolve_dst {
    rayd_image *img; /* NULL: no 8-bit image (an EXR task) */
    float *lin;
    int lin_w, x, y;
    float *aov;              /* NULL, or the AOVs' floats (RAYD_AOV_FLOATS a pixel, rows lin_w) */
    unsigned aov_mask;       /* AOVs asked; with img, the one AOV img shows */
    const rayd_scene *scene; /* with aov_mask: the scene (its camera's focus) */
    bool denoise;            /* render the tile denoised, with its apron */
};
/* acc's pixels (as a plain render of its samples gives them) into d. */
enum rayd_status resolve_into(const rayd_accum *acc, const struct resolve_dst *d,
                              struct rayd_error *err);
/* Renders tile (absolute) of scene with all its samples into d, through one
 * set of sums: the bytes of rayd_render_into and the floats of
 * rayd_render_linear_into.  rays_left: the task's ray budget, or NULL. */
enum rayd_status resolve_render(const rayd_scene *scene, const struct rayd_region *tile,
                                const struct resolve_dst *d, const atomic_int *cancel,
                                atomic_int_least64_t *rays_left, uint64_t *rays,
                                struct rayd_error *err);

/* ---- passes.c: a progressive task's passes ------------------------------------ */

struct passes {
    struct jobs_plan plan;
    int n, samples[PASSES_MAX]; /* passes planned, samples after each */
    int pass;                   /* the pass being rendered, 0-based (lock held) */
    int done;                   /* passes complete (lock held) */
    int ntiles;
    rayd_accum **acc;                  /* a tile's sums, one a task tile, made at its first pass */
    struct rayd_region *tiles;         /* the task tiles (absolute) */
    rayd_image *prev;                  /* the latest complete pass's image */
    rayd_image *raw, *raw_prev;        /* a denoised job's: the pass's raw image, the last one's */
    struct blob *png[PASSES_KEEP];     /* pass k's PNG (1-based) at (k - 1) % PASSES_KEEP */
    struct blob *raw_png[PASSES_KEEP]; /* a denoised job's: pass k's raw PNG, likewise */
    struct blob *exr[PASSES_KEEP_EXR]; /* a job's with format=exr: pass k's EXR, likewise */
    double time_s[PASSES_MAX], noise[PASSES_MAX];
    enum passes_stop stop; /* asked (client, time) or decided (noise) */
    bool let_go;           /* passes_let_go ran: a pass completed later is not kept */
};
/* The passes of a task whose tiles are tiles[0..ntiles-1] (absolute; the
 * malloc'd array is the passes' from now on, freed with them even on
 * failure); raw: the task's passes are denoised and each is kept raw too
 * (a w x h image); NULL on no memory. */
struct passes *passes_new(const rayd_scene *scene, const struct jobs_plan *plan,
                          struct rayd_region *tiles, int ntiles, bool raw, int w, int h);
void passes_free(struct passes *p); /* NULL allowed */
/* Renders pass `pass` of tile `tile` (its sums) and resolves the tile's
 * pixels into dst; no lock.  rays_left: the task's ray budget, or NULL. */
enum rayd_status passes_tile(struct passes *p, const rayd_scene *scene, int tile, int pass,
                             const struct resolve_dst *dst, const atomic_int *cancel,
                             atomic_int_least64_t *rays_left, uint64_t *rays,
                             struct rayd_error *err);
/* Pass `pass`'s noise estimate from its image img (a denoised job's: from
 * its raw image, p->raw, img unused) (< 0: none); no lock. */
double passes_noise(const struct passes *p, const rayd_image *img, int pass);
/* A denoised job's raw image of the pass just drawn becomes the previous
 * one, for the next pass's noise estimate; no lock (the pass barrier). */
void passes_raw_done(struct passes *p);
/* Lock held: the pass is complete, png its PNG, exr its EXR and raw its raw
 * PNG (NULL when the job keeps none); the references become the passes'. */
void passes_complete(struct passes *p, struct blob *png, struct blob *exr, struct blob *raw,
                     double time_s, double noise);
/* Lock held: a finished task lets go of its sums and last image (it renders
 * no more); its PNGs, EXRs and counts stay for the job. */
void passes_release(struct passes *p);
/* Lock held: a finished job's kept pass images are let go (the memory
 * budget evicted them); its counts stay. */
void passes_let_go(struct passes *p);
/* Lock held: is there a next pass to render?  false also when a budget or
 * a stop ended the job (p->stop says which). */
bool passes_more(struct passes *p, double elapsed);
/* img becomes the latest pass image; the one before it is returned for reuse. */
rayd_image *passes_swap(struct passes *p, rayd_image *img);
struct blob *passes_png(const struct passes *p, int pass); /* not referenced; NULL: gone */
struct blob *passes_exr(const struct passes *p, int pass); /* likewise; NULL: gone or none */
struct blob *passes_raw(const struct passes *p, int pass); /* likewise, the raw PNG */
double passes_progress(const struct passes *p, int done, double frac);
/* The samples pass k (from 0) renders: what it adds to the pass before, or
 * all of its own after the one-sample image, which is not added to. */
int passes_added(const struct passes *p, int k);
void passes_info(const struct passes *p, struct jobs_passes *out);

/* ---- task.c: one render, its tiles and its waiters (lock held) --------------- */

struct task {
    struct task *next; /* active list */
    char key[160];     /* scene id + region: identical requests share a task */
    char scene_id[65];
    struct cache_entry *scene; /* held until the task finishes */
    struct rayd_region reg;    /* absolute */
    int tile;                  /* tiles are tile x tile pixels (cost.c sizes them) */
    int ntx, nty, ntiles;
    int next_tile, running, done;
    uint64_t client; /* who asked first (fair.c) */
    double est_rays; /* cost_rays of the whole task */
    double rays_per_sample;
    int *order;            /* tiles in completion order, for event streams */
    struct passes *passes; /* a progressive job's task, else NULL */
    rayd_image *img;       /* WORK_PNG: the tiles' bytes */
    /* a plain WORK_PNG task: the PNG encoded band by band as rows of tiles
     * are drawn (sched.c), made when the first tile is taken (NULL if out
     * of memory, stream_tried then set: encoded whole at the end), and
     * which of its rows at the top are all drawn (the core's tracker) */
    rayd_png_stream *stream;
    rayd_rows *rows;
    bool stream_tried;
    float *lin;   /* WORK_PNG16, WORK_EXR, keep_exr: the tiles' linear RGB,
                     reg.w * reg.h * 3 */
    double *sums; /* WORK_SUMS: the tiles' sums of samples k0..k1-1 */
    enum work_format format;
    bool keep_exr;          /* a job's: its EXR too (work_target's keep_exr) */
    unsigned aov_mask;      /* work_target's aov */
    bool denoise;           /* work_target's denoise */
    float *aov;             /* WORK_EXR with AOVs: their floats, RAYD_AOV_FLOATS a pixel */
    size_t mem;             /* reserved in --max-memory (budget.c), released with the pixels */
    enum mem_kind mem_kind; /* as what */
    struct blob *exr;       /* keep_exr: the EXR, made with the PNG */
    int k0, k1;
    bool centre; /* WORK_SUMS of [0, 1): the centre image (struct work_target) */
    atomic_int cancel;
    /* --max-work: rays the task may still cast, shared by its tiles and
     * passes (the core's meters take from it; RAYD_E_LIMIT below zero) */
    atomic_int_least64_t rays_left;
    long work; /* that budget whole (--max-work, or the test gate's); 0: none */
    bool interactive, queued, finalizing, finished;
    bool restored; /* re-queued at start-up from --data-dir: admitted past --queue */
    bool evicted;  /* finished, its images let go for the memory budget (jobs.c) */
    double t_enq, t_start, t_end;
    double encode_s; /* of t_end - t_start, the PNG's encoding */
    enum rayd_status status;
    struct rayd_error err;
    struct blob *png;
    uint64_t rays;
    struct work_waiter *waiters;     /* synchronous requests */
    struct work_waiter *sse_waiters; /* event streams waiting for news */
    int njobs;                       /* jobs still interested */
    int priority; /* enum jobs_priority: orders its client's own tasks (task_pick) */
    int refs;     /* active list + jobs */
};

/* An output format (enum work_format): one row of task.c's table each,
 * read where a format makes a difference -- the key, the pixels a task
 * draws into, the memory it holds, its encoder, the answer's media type. */
enum task_store { TASK_STORE_IMAGE, TASK_STORE_FLOATS, TASK_STORE_SUMS };
struct task_format {
    const char *key_suffix; /* of the task's key: an EXR never answers a PNG request */
    const char *type;       /* the answer's media type */
    enum task_store store;  /* what the tiles draw into */
    /* budget.c: bytes a pixel holds (its store, then its answer), bytes
     * besides, and as what they count */
    size_t px_bytes, extra;
    enum mem_kind mem_kind;
    /* t's pixels in this format into *buf (rayd_free), by the worker that
     * drew the last tile, without the lock (no tile runs) */
    enum rayd_status (*encode)(struct task *t, void **buf, size_t *len, struct rayd_error *err);
};
const struct task_format *task_format(enum work_format format); /* any lock */

/* What the worker that finished a task (or a pass of it) made without the
 * lock, for task_encoded / task_pass_closed to keep. */
struct task_out {
    enum rayd_status st;
    struct rayd_error err;
    struct blob *png, *exr; /* references handed over */
    struct blob *raw;       /* a denoised pass's raw PNG, likewise */
    double encode_s;        /* the encoding's seconds */
    double noise;           /* a pass's noise estimate */
    rayd_image *spare;      /* a pass's: the image for the next one, or NULL */
};

/* What a worker does after task_tile_done. */
enum task_next {
    TASK_GOING,    /* nothing: other tiles are in flight, or t was finished */
    TASK_ENCODE,   /* encode t's answer without the lock, then task_encoded */
    TASK_PASS_END, /* close t's pass without the lock, then task_pass_closed */
};

/* Waiters to answer once the lock is released. */
struct task_notify {
    struct work_waiter *list;
    struct work_result res;
};

extern struct task *task_active; /* every unfinished task */
extern long task_queued;         /* tasks with tiles nobody has started */
extern int task_queue_cap;       /* --queue, set once before the workers start */
void task_drain(void);           /* takes the lock */
bool task_draining(void);        /* lock-free */

void task_key(char *key, size_t size, const char *id, const struct work_target *what);
/* A new task for (scene, reg) in format, with its pixels (an image, or
 * linear floats for the HDR formats); NULL on no memory.  Any lock. */
struct task *task_new(struct cache_entry *scene, const struct work_target *what);
void task_unref(struct task *t);
struct task *task_find(const char *key); /* an unfinished, uncancelled task */
struct task *task_pick(void);            /* the task whose next tile comes first */
/* The same among the interactive plain renders whose tiles are quick
 * (cost_tile_quick): what the spare worker may take (sched.c). */
struct task *task_pick_quick(void);
/* Joins the unfinished task with *fresh's key (scene, region, format) or
 * activates *fresh (then NULL); WORK_DRAINING or WORK_FULL when it cannot. */
enum work_submit task_submit(struct cache_entry *scene, struct task **fresh, struct task **out);
/* The tile's absolute rectangle. */
struct rayd_region task_tile(const struct task *t, int tile);
/* Estimated rays of tile r of t in pass `pass` (0 for a plain task). */
double task_tile_rays(const struct task *t, const struct rayd_region *r, int pass);
double task_backlog_rays(void); /* of every unfinished task, what is left */
void task_finish(struct task *t, struct task_notify *n, struct task_notify *sse);
/* Milliseconds t waited in the queue and has rendered, up to now (or to
 * its end, when finished). */
void task_times(const struct task *t, double now, double *queue_ms, double *render_ms);
/* Ends a progressive task after its latest complete pass (or its first, if
 * none is complete yet), why being the reason; true when nothing is in
 * flight and the caller should task_finish it now. */
bool task_end_early(struct task *t, enum passes_stop why);
/* Stops t when it has run (since its first tile) for limit seconds or more
 * (--max-render-seconds; 0: never): it fails with a message naming the
 * limit, or a progressive task ends with its latest pass.  true when it
 * was stopped. */
bool task_past_deadline(struct task *t, double now, long limit, struct task_notify *n,
                        struct task_notify *sse);
void task_cancel(struct task *t, enum metrics_cancel why, struct task_notify *n,
                 struct task_notify *sse);
/* The pool stopped with t unfinished (the drain's deadline cancelled it):
 * t finished now, cancelled, whoever still runs nothing of it. */
void task_abandon(struct task *t, struct task_notify *n, struct task_notify *sse);
/* A worker takes t's next tile, lock held: its index, the pass it is of
 * into *pass; t's start, its PNG stream (a plain PNG task), the queue. */
int task_take(struct task *t, int *pass);
/* Rows of t's PNG stream that tile `tile`, just drawn, completes (0: none
 * new, or no stream).  No lock: the stream and its row tracker were made,
 * under the lock, before this worker took its tile, and are freed only once
 * no tile runs. */
int task_rows_done(struct task *t, int tile);
/* A worker is done with tile `tile` of t (st, err, rays cast), lock held:
 * the tile booked, t failed or stopped early as it says, t finished when
 * nothing is left in flight (its waiters onto n and sse).  What the worker
 * does next: see enum task_next. */
enum task_next task_tile_done(struct task *t, int tile, enum rayd_status st,
                              const struct rayd_error *err, uint64_t rays, struct task_notify *n,
                              struct task_notify *sse);
/* t's answer made (TASK_ENCODE): kept, t finished.  Lock held. */
void task_encoded(struct task *t, const struct task_out *o, struct task_notify *n,
                  struct task_notify *sse);
/* t's pass made (TASK_PASS_END): recorded, the streams told, and the next
 * pass opened -- true -- unless it was the last or a budget or stop ends
 * the job (t finished).  Lock held. */
bool task_pass_closed(struct task *t, const struct task_out *o, struct task_notify *n,
                      struct task_notify *sse);
/* w waits for t: suspended (w->suspend), then linked.  Lock held. */
void task_wait(struct task *t, struct work_waiter *w);
/* An event stream w waits for t's news: suspended, then linked.  Lock held. */
void task_wait_news(struct task *t, struct work_waiter *w);
/* A job holds t (a reference, and one more party interested), or lets go
 * of its interest (cancelled; its reference stays until the job goes).
 * Lock held. */
void task_job_ref(struct task *t);
/* t, not yet submitted, renders for a job already admitted (a frame of a
 * frame-range job, a job put back at start-up): past --queue, at that
 * priority.  Any lock: t is the caller's own still. */
void task_admitted(struct task *t, int priority);
/* t's priority (enum jobs_priority) at least priority: a job of t's own
 * client joined it, or a new task is made for a job.  Lock held once t is
 * submitted. */
void task_raise_priority(struct task *t, int priority);
void task_job_drop(struct task *t);
/* t, not yet submitted, renders in progressive passes p for job id alone
 * (its key gets the id).  Any lock: t is the caller's own still. */
void task_progressive(struct task *t, struct passes *p, const char *id);
/* A finished task's images let go for the memory budget: their bytes.
 * task_evicted: and its kept passes too, for good.  Lock held. */
size_t task_let_go_images(struct task *t);
void task_evicted(struct task *t);
/* The memory budget.c reserved for t, released with its pixels. */
void task_hold(struct task *t, size_t bytes, enum mem_kind kind);
void task_notify_add(struct task_notify *n, struct work_waiter **from);
/* Takes w off t's waiters or event streams onto gone, and cancels t when
 * nobody else wants it (onto n and sse); false when w is not t's.  Lock
 * held.  The watcher's, for a client that hung up. */
bool task_unwait(struct task *t, struct work_waiter *w, struct task_notify *gone,
                 struct task_notify *n, struct task_notify *sse);
/* Called by task_finish, lock held, for a task jobs follow (jobs.c's). */
void task_on_finish(void (*fn)(struct task *t));
void task_notify_run(struct task_notify *n); /* lock NOT held */

/* ---- budget.c: a render's admission into the memory budget (no lock) ---- */

/* task_new with what it will hold reserved in the memory budget; NULL with
 * *why WORK_TOO_BIG (over the whole budget), WORK_MEMORY (no room now) or
 * WORK_NOMEM. */
struct task *budget_task(struct cache_entry *scene, const struct work_target *what,
                         bool progressive, enum work_submit *why);
/* Binds this thread's reservations to client until budget_unbind: a
 * render's admission (budget_task), a parse (compile.c) and a frame-range
 * job's (shots.c) are a client's, and the reclaimer lets go of its images
 * first, then only as struct jobs_whose's rule allows (jobs.c). */
void budget_bind(uint64_t client);
void budget_unbind(void);
/* mem_reserve of n bytes of kind, bound to client. */
bool budget_reserve(uint64_t client, enum mem_kind kind, size_t n);
/* True while this thread is bound, with the client. */
bool budget_admitting(uint64_t *client);
/* The bytes budget_task reserves for what of scene. */
size_t budget_need(const struct cache_entry *scene, const struct work_target *what,
                   bool progressive);

/* ---- gate.c (lock held) -------------------------------------------------------- */

bool gate_pass(void);                     /* may a worker start a tile now? takes one */
void gate_count(long started, long held); /* adds to the started / held counters */

/* ---- store.c: jobs on disk (--data-dir) ------------------------------------------ */

/* One job's record: what it was asked (to render it again after a restart)
 * and, once it ended, how. */
struct store_job {
    char id[33];
    long long seq; /* creation order: GET /v1/jobs pages by it */
    uint64_t client;
    int priority;                    /* enum jobs_priority */
    double created_wall, ended_wall; /* seconds since the epoch; ended 0: unfinished */
    enum jobs_state state;           /* JS_QUEUED (unfinished), or how it ended */
    char *scene;                     /* the scene as sent (malloc'd, NUL-terminated) */
    size_t scene_len;
    char scene_id[65];
    struct rayd_region reg;
    bool keep_exr, progressive;
    bool denoise; /* POST /v1/jobs?denoise=1 (or the scene's) */
    unsigned aov; /* ?aov= (work_target's aov) */
    struct jobs_plan plan;
    long tiles;
    uint64_t rays;
    double est_rays, queue_ms, render_ms, encode_ms;
    struct rayd_error err; /* JS_FAILED */
    double evicted_wall;   /* > 0: its images were evicted (--max-disk) */
    char evicted_why[96];
    int attempts;   /* starts of rayd that found it unfinished */
    bool result_ok; /* store_load: its files are there, whole */
    bool frames;    /* a frame-range job (shots.c) of frames first..last at fps */
    long first, last;
    double fps;
};
/* Opens DIR's store (before any thread but main's): -1 after saying why. */
int store_open(const char *dir);
/* store_dir.c: DIR's lock taken (its fd, kept open while rayd runs), or -1
 * after saying why (another rayd has it: its PID). */
int store_dir_lock(const char *dir);
/* DIR's results/ made a folder if missing; -1 after saying why, and when a
 * missing or empty jobs.db sits beside images (store_dir.c). */
int store_dir_check(const char *dir);
int store_start(void); /* the store thread (none without a store) */
void store_stop(void); /* runs what is queued, joins, closes */
/* Every job's record, oldest first (main thread, at start-up). */
int store_load(struct store_job **rows, int *n);
void store_rows_free(struct store_job *rows, int n);
/* jobs.c's hooks, called on the store thread with no lock held: an image
 * is on disk; an image was evicted by --max-disk. */
void store_hooks(void (*written)(const char *id),
                 void (*evicted)(const char *id, const char *why, double wall));
/* shots.c's, likewise: frame k of a frame-range job is on disk; it was
 * evicted by --max-disk. */
void store_frame_hooks(void (*written)(const char *id, long k),
                       void (*evicted)(const char *id, long k, const char *why));
/* Lock held: queue a new job's record (row->scene becomes the store's),
 * w->suspend runs now and w->done once it is committed (status RAYD_OK or
 * RAYD_E_IO); a job's end, with its images (referenced); a job forgotten. */
bool store_insert(struct store_job *row, struct work_waiter *w);
/* store_end's w (NULL: none) is suspended now and told once the end is
 * committed (a DELETE answers then, so a kill cannot undo it): true when
 * it will be. */
bool store_end(const struct store_job *row, struct blob *png, struct blob *exr,
               struct work_waiter *w);
void store_forget(const char *id);
/* Frame k of frame-range job row->id is done: its images written whole (a
 * temporary name, fsync, rename), then its row says so, and in the same
 * commit the job's figures so far (row's frames done, rays and times), so
 * a restart goes on counting from them.  Lock held. */
void store_frame(const struct store_job *row, long k, struct blob *png, struct blob *exr);

/* store_file.c: the images' files under DIR/results/ (DIR: store_dir,
 * set by store_open, read by any thread until store_stop). */
extern char *store_dir;
/* The bytes b's file takes (an EXR's: the image and the CRC after it),
 * as a row records them. */
size_t store_file_bytes(const struct blob *b, bool exr);
/* DIR/results/ID.png (or .exr, or with .tmp): a plain job's image's path;
 * DIR/results/ID-K.png frame K's of a frame-range job (k >= 0). */
void store_path(char *buf, size_t size, const char *id, long k, bool exr, bool tmp);
int store_fsync_dir(const char *path);
/* b's bytes (an EXR's with its tail) to the image's path, whole or not at
 * all (NAME.tmp, fsync, rename): 0, or -1 with errno. */
int store_write_file(const char *id, long k, bool exr, const struct blob *b);
/* Frame k's image from its file, or NULL (missing, or its bytes changed
 * since they were written: logged); any thread (a plain read). */
struct blob *store_read_frame(const char *id, long k, bool exr);
/* A frame-range job's frames at start-up (main thread): states[k - first]
 * STORE_FRAME_DONE for each frame done with its files whole, else
 * STORE_FRAME_QUEUED (STORE_FRAME_EVICTED: done, then evicted by --max-disk);
 * how many are done, -1 on an error. */
enum { STORE_FRAME_QUEUED, STORE_FRAME_DONE, STORE_FRAME_EVICTED };
int store_load_frames(const struct store_job *j, unsigned char *states);

/* ---- jobs.c (lock held) -------------------------------------------------------- */

struct job {
    char id[33];
    struct task *task;
    bool canceled;
    double created;
    double canceled_at;    /* when DELETE cancelled it (clock_now) */
    double evicted_at;     /* when its result was evicted (jobs_evict_result); 0: kept */
    char evicted_why[160]; /* why, as jobs_evict_result was told */
    int refs;              /* the table + open event streams */
    uint64_t client;       /* who created it (GET /v1/jobs lists a client's own) */
    int priority;          /* enum jobs_priority */
    long long seq;         /* creation order, kept across restarts */
    double created_wall;   /* seconds since the epoch */
    bool stored;           /* --data-dir: its images are on disk (store.c) */
    bool recorded;         /* --data-dir: its end is queued to the store */
    bool restored;         /* ended before this process started: its times are these */
    double queue_ms, render_ms, encode_ms;
};
/* Start-up (durable.c): a job of the store put back, finished as it
 * ended, or (scene not NULL) queued again; false: no room or memory. */
bool jobs_restore(const struct store_job *row, struct cache_entry *scene);
int jobs_start(int max_jobs); /* any lock */
/* The jobs not finished and the --max-jobs the table holds; lock held. */
void jobs_count(long *unfinished, long *cap);
/* Whether client may add no unfinished job now (lock held): the last
 * quarter of --max-jobs is kept for clients with fewer than a quarter of
 * the jobs unfinished. */
bool jobs_over_share(uint64_t client);
void jobs_stop(void); /* after the workers and the watcher have stopped */
struct job *jobs_find(const char *id);
enum jobs_state jobs_state(const struct job *j);
double jobs_progress(const struct job *j); /* 0..1, as the job's JSON says it */
void jobs_unref(struct job *j);
/* Forgets the jobs that ended (finished, failed or were cancelled) more
 * than --job-ttl seconds ago, each leaving a tombstone (jobs_gone). */
void jobs_expire(double now);
/* shots.c's part in the jobs' limits, handed down by shots_start (jobs.c
 * is below it), all lock held: when the finished frame-range job that
 * ended first and keeps a frame in memory ended (clock_now's clock; -1:
 * none), and its oldest frame let go (410 result_evicted; false: none) for
 * the memory budget; how many are unfinished (--max-jobs). */
/* Whose kept images the budget may let go of (jobs.c decides, lock held). */
struct jobs_whose;
bool jobs_whose_may(const struct jobs_whose *w, uint64_t owner);
/* oldest_end and evict_oldest: of the owners w allows; each: fn called
 * with every frame-range job's owner, whether it keeps an image the budget
 * may let go of, and whether it is unfinished (live). */
struct jobs_shots {
    double (*oldest_end)(const struct jobs_whose *w);
    bool (*evict_oldest)(const struct jobs_whose *w);
    void (*each)(void (*fn)(void *u, uint64_t owner, bool keeps, bool live), void *u);
    long (*unfinished)(void);
    long (*unfinished_of)(uint64_t client);
};
void jobs_shots_hooks(const struct jobs_shots *h);
/* The next creation number (GET /v1/jobs's order), shared by the
 * frame-range jobs (shots.c); lock held. */
long long jobs_next_seq(void);
void jobs_seen_seq(long long seq); /* a restored job's number: the next ones come after */
/* Start-up (durable.c): a frame-range job of the store put back, its done
 * frames (states, store_load_frames) served from their files, the others
 * queued again unless it ended; false: no room or memory. */
bool shots_restore(const struct store_job *row, const unsigned char *states);

/* ---- videoq.c ------------------------------------------------------------------ */

/* Queues make(arg) for the video thread, after the videos asked for before
 * (lock held; make runs without it); false: no thread or memory. */
bool videoq_add(void (*make)(void *arg), void *arg);
/* Gives up the video being made and those queued (video_stop), waiting up
 * to seconds for the thread to let go of them (lock not held). */
void videoq_stop(double seconds);

/* ---- watch.c ------------------------------------------------------------------- */

/* shots.c's, handed down by shots_start, lock held: the event streams
 * waiting on the i-th frame-range job (NULL past the last), polled for a
 * hang-up and woken for keep-alives; w taken off whichever holds it.  And,
 * called once a second without the lock, kick: the frame-range jobs whose
 * frames were refused for room start again. */
void watch_streams_hooks(struct work_waiter **(*streams)(int i),
                         bool (*unwait)(struct work_waiter *w, struct task_notify *gone),
                         void (*kick)(void));
int watch_start(void);
void watch_stop(void); /* stops and joins the thread */

#endif
