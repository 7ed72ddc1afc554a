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
 *   - a function whose comment says "lock held" is called with it held, any
 *     other public function of the layer takes it itself;
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

#include "work.h"

#include <pthread.h>

#define TASK_INTERACTIVE (256L * 256L) /* pixels of a preview or a tile */
#define TASK_BULK_EVERY 4             /* when both classes wait, bulk gets 1 tile in 4 */
#define EVENTS_PING_SECONDS 15.0      /* seconds of silence before a keep-alive */

extern pthread_mutex_t work_lock; /* work.c */
extern pthread_cond_t work_cond;

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
/* Parses and builds body (of that id) and caches it; *out referenced. */
enum rayd_status scenes_build(const char *id, const char *body, size_t len,
                              struct cache_entry **out, struct rayd_error *err);

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
bool rcache_on(void);                     /* --result-cache-mb above 0 */
struct blob *rcache_get(const char *key); /* refs the PNG */
void rcache_put(const char *key, struct blob *png);
void rcache_stats(size_t *bytes, size_t *entries);
void rcache_free_all(void);
bool rcache_evict_one(void); /* the least recently used result; false: empty */

/* ---- scenes.c ---------------------------------------------------------------- */

void scenes_start(void); /* sizes both caches, registers their gauges */

/* ---- cost.c (lock held but for cost_rays, cost_tile, cost_samples) --------- */

/* The samples a pixel of what takes: a sample range's, else the scene's. */
int cost_samples(const struct work_target *what, int scene_samples);

/* The side of a square tile whose estimated rays stay under the tile
 * budget, given a pixel's estimated rays. */
int cost_tile(double rays_per_pixel);
void cost_set_workers(int workers);          /* before the workers start */
/* A tile of scene_id for client: its estimated rays and the seconds it
 * took; complete false: it was stopped part way. */
void cost_observe(const char *scene_id, uint64_t client, double rays, double seconds,
                  bool complete);
double cost_seconds(double rays); /* of the whole pool, at the node's rate */
/* scene_id's rate over the node's: times a task's rays, node-rate rays. */
double cost_scene_weight(const char *scene_id);

/* ---- fair.c (lock held) ------------------------------------------------------- */

uint64_t fair_last(uint64_t client); /* the tick it was last served, 0: never */
void fair_served(uint64_t client);

/* ---- resolve.c: a tile's sums into a task's pixels (no lock) ----------------- */

/* Where a tile's pixels go: its 8-bit image at (x, y) of img and, when lin
 * is not NULL, its linear floats at (x, y) of lin (lin_w pixels a row). */
struct resolve_dst {
    rayd_image *img;
    float *lin;
    int lin_w, x, y;
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
    rayd_accum **acc;              /* a tile's sums, one a task tile, made at its first pass */
    struct rayd_region *tiles;     /* the task tiles (absolute) */
    rayd_image *prev;              /* the latest complete pass's image */
    struct blob *png[PASSES_KEEP]; /* pass k's PNG (1-based) at (k - 1) % PASSES_KEEP */
    struct blob *exr[PASSES_KEEP_EXR]; /* a job's with format=exr: pass k's EXR, likewise */
    double time_s[PASSES_MAX], noise[PASSES_MAX];
    enum passes_stop stop; /* asked (client, time) or decided (noise) */
    bool let_go;           /* passes_let_go ran: a pass completed later is not kept */
};
/* The passes of a task whose tiles are tiles[0..ntiles-1] (absolute; the
 * malloc'd array is the passes' from now on, freed with them even on
 * failure); NULL on no memory. */
struct passes *passes_new(const rayd_scene *scene, const struct jobs_plan *plan,
                          struct rayd_region *tiles, int ntiles);
void passes_free(struct passes *p); /* NULL allowed */
/* Renders pass `pass` of tile `tile` (its sums) and resolves the tile's
 * pixels into dst; no lock.  rays_left: the task's ray budget, or NULL. */
enum rayd_status passes_tile(struct passes *p, const rayd_scene *scene, int tile, int pass,
                             const struct resolve_dst *dst, const atomic_int *cancel,
                             atomic_int_least64_t *rays_left, uint64_t *rays,
                             struct rayd_error *err);
/* Pass `pass`'s noise estimate from its image (< 0: none); no lock. */
double passes_noise(const struct passes *p, const rayd_image *img, int pass);
/* Lock held: the pass is complete, png its PNG and exr its EXR (NULL when
 * the job keeps none); both references become the passes'. */
void passes_complete(struct passes *p, struct blob *png, struct blob *exr, double time_s,
                     double noise);
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
    int tile;          /* tiles are tile x tile pixels (cost.c sizes them) */
    int ntx, nty, ntiles;
    int next_tile, running, done;
    uint64_t client;   /* who asked first (fair.c) */
    double est_rays;   /* cost_rays of the whole task */
    double rays_per_sample;
    int *order; /* tiles in completion order, for event streams */
    struct passes *passes;     /* a progressive job's task, else NULL */
    rayd_image *img;           /* WORK_PNG: the tiles' bytes */
    /* a plain WORK_PNG task: the PNG encoded band by band as rows of tiles
     * are drawn (sched.c), made when the first tile is taken (NULL if out
     * of memory, stream_tried then set: encoded whole at the end); tiles
     * left to draw in each row of tiles, and how many rows of tiles at the
     * top are all drawn */
    rayd_png_stream *stream;
    int *row_left, rows_top;
    bool stream_tried;
    float *lin;                /* WORK_PNG16, WORK_EXR, keep_exr: the tiles' linear RGB,
                                  reg.w * reg.h * 3 */
    double *sums;              /* WORK_SUMS: the tiles' sums of samples k0..k1-1 */
    enum work_format format;
    bool keep_exr;    /* a job's: its EXR too (work_target's keep_exr) */
    size_t mem;             /* reserved in --max-memory (budget.c), released with the pixels */
    enum mem_kind mem_kind; /* as what */
    struct blob *exr; /* keep_exr: the EXR, made with the PNG */
    int k0, k1;
    atomic_int cancel;
    /* --max-work: rays the task may still cast, shared by its tiles and
     * passes (the core's meters take from it; RAYD_E_LIMIT below zero) */
    atomic_int_least64_t rays_left;
    bool interactive, queued, finalizing, finished;
    bool evicted; /* finished, its images let go for the memory budget (jobs.c) */
    double t_enq, t_start, t_end;
    double encode_s; /* of t_end - t_start, the PNG's encoding */
    enum rayd_status status;
    struct rayd_error err;
    struct blob *png;
    uint64_t rays;
    struct work_waiter *waiters;     /* synchronous requests */
    struct work_waiter *sse_waiters; /* event streams waiting for news */
    int njobs;                       /* jobs still interested */
    int refs;                        /* active list + jobs */
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
void task_unqueue(struct task *t);
struct task *task_find(const char *key); /* an unfinished, uncancelled task */
struct task *task_pick(void);            /* the task whose next tile comes first */
void task_taken(const struct task *t);   /* a tile of t was taken (for the bulk share) */
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
/* t fails with st and err's message and place (the first failure stands:
 * the caller checks t->status).  task_failf: with a message of its own. */
void task_fail(struct task *t, enum rayd_status st, const struct rayd_error *err);
/* t cast more rays than --max-work: it fails with RAYD_E_LIMIT and a
 * message naming the budget (unless it failed already). */
void task_over_work(struct task *t);
void task_failf(struct task *t, enum rayd_status st, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
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
void task_notify_add(struct task_notify *n, struct work_waiter **from);
void task_notify_run(struct task_notify *n); /* lock NOT held */

/* ---- budget.c: a render's admission into the memory budget (no lock) ---- */

/* task_new with what it will hold reserved in the memory budget; NULL with
 * *why WORK_TOO_BIG (over the whole budget), WORK_MEMORY (no room now) or
 * WORK_NOMEM. */
struct task *budget_task(struct cache_entry *scene, const struct work_target *what,
                         bool progressive, enum work_submit *why);

/* ---- gate.c (lock held) -------------------------------------------------------- */

bool gate_pass(void);     /* may a worker start a tile now? takes one */
void gate_count(long started, long held); /* adds to the started / held counters */

/* ---- jobs.c (lock held) -------------------------------------------------------- */

struct job {
    char id[33];
    struct task *task;
    bool canceled;
    double created;
    double canceled_at;   /* when DELETE cancelled it (clock_now) */
    double evicted_at;    /* when its result was evicted (jobs_evict_result); 0: kept */
    char evicted_why[160]; /* why, as jobs_evict_result was told */
    int refs; /* the table + open event streams */
};
int jobs_start(int max_jobs); /* any lock */
/* The jobs not finished and the --max-jobs the table holds; lock held. */
void jobs_count(long *unfinished, long *cap);
void jobs_stop(void);         /* after the workers and the watcher have stopped */
struct job *jobs_find(const char *id);
enum jobs_state jobs_state(const struct job *j);
double jobs_progress(const struct job *j); /* 0..1, as the job's JSON says it */
void jobs_unref(struct job *j);
/* Forgets the jobs that ended (finished, failed or were cancelled) more
 * than --job-ttl seconds ago, each leaving a tombstone (jobs_gone). */
void jobs_expire(double now);

/* ---- watch.c ------------------------------------------------------------------- */

int watch_start(void);
void watch_stop(void); /* stops and joins the thread */

#endif
