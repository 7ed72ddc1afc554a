/* work.h -- the work layer as the handlers see it: compiled scenes, renders
 * queued and answered, asynchronous jobs and their event streams.
 *
 * Layer: work (work.c, lru.c, cache.c, rcache.c, scenes.c, cost.c, fair.c,
 * resolve.c, passes.c, task.c, gate.c, store.c, sched.c, jobs.c, events.c,
 * watch.c, compile.c, durable.c).  May
 * include: base.h and <rayd/rayd.h> -- never an HTTP header, never
 * libmicrohttpd.  Included by the handlers
 * (api_*.c) and main.c.
 *
 * The work layer knows nothing about connections.  Whoever waits on a render
 * or on a job's events hands in a struct work_waiter: a done() callback, the
 * socket to watch for a hang-up, and a suspend() callback run under the lock
 * just before the waiter is linked, so the wake-up can never overtake the
 * suspension.  That is the only way work talks back up.
 */
#ifndef RAYD_SERVER_WORK_H
#define RAYD_SERVER_WORK_H

#include "base/base.h"

/* ---- what a waiter is told --------------------------------------------- */

struct work_result {
    enum rayd_status status; /* RAYD_OK and png, or an error */
    struct rayd_error err;
    struct blob *png;       /* a reference owned by the waiter: unref it */
    struct blob *exr;       /* what.keep_exr: the EXR of the same samples, borrowed for done()'s
                               length (blob_ref it to keep it); else NULL */
    bool gone;              /* the client disconnected */
    bool draining;          /* cancelled because the server drains (503 "draining") */
    struct log_times times; /* the render's times, handed up whole */
    uint64_t rays;          /* the rays its render cast (every tile of it) */
};

/* Something waiting on a task or a job's events.  done() is called exactly
 * once per registration -- from a worker, the watcher thread, a DELETE of
 * the job or the drain's cancel of everything -- after the waiter is
 * removed from every list and with no lock held. */
struct work_waiter {
    void (*done)(struct work_waiter *w, struct work_result *res);
    void (*suspend)(struct work_waiter *w); /* under the lock, before linking */
    int fd;                                 /* socket polled for a hang-up, -1 none */
    struct work_waiter *next;               /* the work layer's list link */
};

enum work_submit {
    WORK_OK = 0,
    WORK_CACHED, /* answered at once from the result cache */
    WORK_FULL,
    WORK_DRAINING,
    WORK_NOMEM,
    WORK_TOO_MANY_JOBS,
    WORK_MEMORY,     /* the memory budget (--max-memory) has no room now: 503 */
    WORK_TOO_BIG,    /* the render alone is over the memory budget: 413 */
    WORK_PARSE_FULL, /* --parse-queue scenes wait for a parse thread (compile.c) */
    WORK_FULL_SHARE, /* the queue's last places are kept for clients with few renders queued */
    WORK_JOBS_SHARE  /* --max-jobs's last places are kept for clients with few jobs unfinished */
};

/* ---- cache.c: the parts any thread may call ----------------------------- */

struct cache_entry; /* a compiled scene and its id, reference counted */
/* SHA-256 of data as 64 lowercase hex digits (a scene id, an ETag); false
 * (and out = "") only if libcrypto fails. */
bool cache_hash(const void *data, size_t len, char out[65]);
const rayd_scene *cache_scene(const struct cache_entry *e); /* immutable */
const char *cache_id(const struct cache_entry *e);          /* immutable */
/* Whether e fits the cache at all: not when it alone is over --cache-mb
 * (it is used once and freed).  Takes the lock. */
bool cache_fits(const struct cache_entry *e);
size_t cache_bytes(const struct cache_entry *e); /* counted in the memory budget (immutable) */
/* The id, or for a scene that read files a hash of it and the files'
 * identities: the key of its results and ETags (scenefiles.c). */
const char *cache_version(const struct cache_entry *e);

/* ---- scenes.c: the compiled-scene cache behind the lock ------------------- */

void scenes_release(struct cache_entry *e); /* NULL allowed */
/* Replaces the scene limits derived from the options (before any request). */
void scenes_set_limits(const struct rayd_limits *lim);

/* ---- what a render makes --------------------------------------------------- */

/* What a render's bytes are: the 8-bit PNG (every route), or from the
 * linear float image a 16-bit PNG or an OpenEXR (POST /v1/render's
 * ?format= or Accept).  Part of the task and result-cache key. */
enum work_format { WORK_PNG, WORK_PNG16, WORK_EXR, WORK_SUMS };
const char *work_format_type(enum work_format format); /* its media type ("image/png") */

/* What a render makes: a region, in a format; WORK_SUMS is the exact
 * per-pixel sums of samples k0..k1-1 (rayd_sums_encode), a part of a frame
 * whose samples are spread over many nodes. */
struct work_target {
    struct rayd_region reg; /* absolute, checked */
    enum work_format format;
    int k0, k1;      /* WORK_SUMS only */
    bool centre;     /* WORK_SUMS of [0, 1) only: the one-sample centre image a progressive
                        job's first pass shows (rayd_render_pass), not sample 0; part of the key */
    bool keep_exr;   /* a job's (POST /v1/jobs?format=exr): with the WORK_PNG, the EXR of
                        the same sums; part of the key */
    unsigned aov;    /* enum rayd_aov bits: WORK_EXR's channels, or the one AOV a WORK_PNG
                        shows instead of the light (POST /v1/render?aov=); part of the key */
    bool denoise;    /* POST /v1/render?denoise=1: each tile rendered with the filter's
                        apron and denoised (rayd_accum_new_denoised); part of the key */
    uint64_t client; /* who asks (fair.c's turns); not part of the key */
    int passes;      /* a progressive job's pass count (each pass is filtered when denoised:
                        cost.c), else 0; not part of the key */
    bool frame;      /* a frame of a frame-range job, whose scene is parsed again for it
                        (rayd_scene_info.frame_work, priced); not part of the key */
};

/* ---- cost.c: what a render costs, before it starts -------------------------- */

/* Estimated rays of rendering what of scene (rayd_scene_info's
 * rays_per_sample x pixels x samples); any thread. */
double cost_rays(const rayd_scene *scene, const struct work_target *what);
/* Estimated rays of scene scene_id (its id, cache_id) as seconds of the
 * whole pool at that scene's measured rate, or the node's for a scene not
 * yet measured; any thread (takes the lock). */
double cost_price_seconds(const char *scene_id, double rays);

/* ---- sched.c: the pool, synchronous renders, lifecycle ------------------- */

int sched_start(int workers, int queue_cap, int max_jobs);
void sched_stop(void);
/* Renders what of scene for w.
 * WORK_CACHED: *png is the finished image (a reference) and *rays (if
 * rays is not NULL) the rays its render cast; w is not used.
 * WORK_OK: w->suspend(w) ran and w->done will be called once.  Anything
 * else: refused, w not used. */
enum work_submit sched_render(struct cache_entry *scene, const struct work_target *what,
                              struct work_waiter *w, struct blob **png, uint64_t *rays);
/* The finished image of what of scene from the result cache (referenced),
 * or NULL; any thread. */
struct blob *sched_result_find(const struct cache_entry *scene, const struct work_target *what);
void sched_drain(void);      /* refuse new work from now on */
bool sched_draining(void);   /* lock-free */
void sched_cancel_all(void); /* cancel every task (drain deadline) */
bool sched_idle(void);       /* no task queued or running */
struct sched_stats {
    long queued, queue_cap, workers, busy_workers;
    long jobs_unfinished, jobs_cap; /* POST /v1/jobs is refused when they are equal */
    double backlog_s;               /* sched_backlog() */
};
void sched_stats(struct sched_stats *st);

/* ---- jobs.c: asynchronous renders ------------------------------------------ */

/* JS_EVICTED: succeeded, but its images were let go to keep rayd within
 * --max-memory (the oldest finished first); its numbers stay. */
enum jobs_state { JS_QUEUED, JS_RUNNING, JS_SUCCEEDED, JS_FAILED, JS_CANCELED, JS_EVICTED };
#define JOBS_EVICTED_WHY                                                                           \
    "the job's image was let go to keep rayd within its memory budget (--max-memory; the "         \
    "oldest finished results go first): render it again"

const char *jobs_state_name(enum jobs_state s);

/* A progressive job (POST /v1/jobs?progressive=1): the frame in passes of
 * growing sample counts, each pass's image kept as it completes
 * (passes.c). */
#define PASSES_MAX 64 /* passes a job may plan */
#define PASSES_KEEP 4 /* the latest passes whose PNGs are kept */
/* The latest passes whose EXRs are kept (a job with format=exr): an EXR is
 * up to 12 bytes a pixel, so two hold at most the 24 bytes a pixel of the
 * sums the job renders into, however many passes the client asks for. */
#define PASSES_KEEP_EXR 2
struct jobs_plan {
    int step;            /* 0: passes of 1, 2, 4, 8, ... samples; k: k, 2k, 3k, ... */
    double time_budget;  /* seconds after the first tile; 0: none */
    double noise_target; /* stop once the noise estimate is at most this; 0: none */
};
/* The samples after each pass of plan for a scene of `samples` samples, the
 * last pass always all of them: how many passes, or -1 if more than
 * PASSES_MAX. */
int passes_plan(const struct jobs_plan *plan, int samples, int out[PASSES_MAX]);
/* Why a progressive job stopped before its last pass. */
enum passes_stop {
    PASSES_GOING,
    PASSES_BY_TIME,
    PASSES_BY_NOISE,
    PASSES_BY_CLIENT,
    PASSES_BY_WORK /* --max-work spent: the latest complete pass is kept */
};
const char *passes_stop_name(enum passes_stop s); /* NULL for PASSES_GOING */
/* The noise estimate of a pass of n samples whose image is img, from the
 * image prev of the pass before, of m samples (passes.c explains it); the
 * two images of one size.  A cluster's pass assembly uses it too. */
double passes_noise_of(const rayd_image *img, const rayd_image *prev, int n, int m);
/* The share of a plan's work (samples[0..n)) done after `done` passes and
 * frac of the next pass. */
double passes_share(const int *samples, int n, int done, double frac);
struct jobs_passes {
    int done, total;    /* passes complete, planned */
    int samples;        /* samples of the latest complete pass (0: none yet) */
    int samples_target; /* of the last planned pass */
    double time_s;      /* when the latest pass completed, after the first tile */
    double noise;       /* its noise estimate (passes.c); < 0: none */
    enum passes_stop stopped;
};
/* Why the server no longer has a job it once created, or its image:
 * forgotten --job-ttl seconds after it ended, forgotten to make room in a
 * full table (--max-jobs), or its result evicted (a memory budget).  The
 * routes of such a job answer 410 with this, never the 404 of an id that
 * never was. */
enum jobs_gone_why { JG_EXPIRED, JG_EVICTED, JG_RESULT_EVICTED };
struct jobs_gone {
    enum jobs_gone_why why;
    enum jobs_state state; /* how it ended */
    double ended_wall;     /* when it ended, seconds since the epoch */
    double gone_wall;      /* when it (or its result) was dropped, likewise */
    char detail[160];      /* JG_RESULT_EVICTED: the reason given */
};
/* The tombstones of forgotten jobs: the last JOBS_TOMBSTONES ids, the
 * oldest dropped first (160 bytes each: 640 KiB in all). */
#define JOBS_TOMBSTONES 4096
/* true when id was a job of this server that was forgotten (filled in g);
 * false for an id it never had, or whose tombstone is gone too. */
bool jobs_gone(const char *id, struct jobs_gone *g);
struct jobs_info {
    enum jobs_state state;
    double progress;
    long tiles_done, tiles_total;
    struct rayd_region region;
    char scene_id[65];
    double created_age, queue_ms, render_ms, encode_ms;
    uint64_t rays;
    double est_rays;       /* cost_rays at admission */
    struct rayd_error err; /* when failed */
    struct blob *png;      /* when asked for: the image if succeeded, else a progressive
                              job's latest pass (or NULL); unref it */
    struct blob *exr;      /* when asked for, likewise its EXR (keep_exr only); unref it */
    bool keep_exr;         /* created with format=exr */
    bool denoise;          /* created denoised (?denoise=1, or the scene's render.denoise) */
    unsigned aov;          /* ?aov=: the EXR's AOV channels, or the one AOV the PNG shows */
    bool progressive;
    struct jobs_passes passes; /* progressive only */
    double ended_age;          /* seconds since it ended; < 0 while it runs */
    bool result_evicted;       /* its images were evicted: gone says why */
    struct jobs_gone gone;     /* result_evicted only */
    char id[33];
    int priority;        /* enum jobs_priority */
    long long seq;       /* creation order (GET /v1/jobs's cursor) */
    double created_wall; /* seconds since the epoch */
    bool on_disk;        /* its image is not in memory but on disk: store_read */
};
/* GET /v1/jobs: client's jobs made before the one numbered before (0: from
 * the newest), newest first, in state (< 0: any), up to n of them into out;
 * how many, and *more whether older ones follow. */
int jobs_list(uint64_t client, int state, long long before, struct jobs_info *out, int n,
              bool *more);
/* POST /v1/jobs?priority=: orders a client's own jobs, never another's. */
enum jobs_priority { JP_LOW, JP_NORMAL, JP_HIGH };
const char *jobs_priority_name(int p);
/* What jobs_submit needs besides the scene, the target and the plan. */
struct jobs_new {
    int priority;      /* enum jobs_priority */
    const char *scene; /* the scene as sent, recorded with --data-dir */
    size_t scene_len;
    struct work_waiter *w; /* --data-dir: told once the job is on disk */
    bool waiting;          /* out: w->suspend ran and w->done will be called once */
};
/* A job rendering what->reg of scene (as a PNG, and an EXR with
 * what->keep_exr) for what->client: plain with plan NULL, else progressive;
 * with how->priority and, with --data-dir, the job recorded on disk before
 * anyone is told of it (how->waiting). */
enum work_submit jobs_submit(struct cache_entry *scene, const struct work_target *what,
                             const struct jobs_plan *plan, struct jobs_new *how, char id[33]);
/* What jobs_get copies besides the numbers: the PNG, the EXR. */
enum jobs_want { JOBS_NUMBERS = 0, JOBS_PNG = 1, JOBS_EXR = 2 };
bool jobs_get(const char *id, struct jobs_info *info, enum jobs_want want);
/* Whether client's new job would be taken now as far as the table goes
 * (--max-jobs, a client's share of it, a drain): WORK_OK, or the refusal
 * a submit would give.  For work to spare before a job is submitted. */
enum work_submit jobs_room(uint64_t client);
/* Which image of a pass: its PNG, its EXR, or a denoised job's raw PNG. */
enum jobs_image { JI_PNG, JI_EXR, JI_RAW };
/* Pass `pass` (1-based) of a progressive job, its image of that kind, if
 * still kept: *img referenced, *samples its count.  false: no such job. */
bool jobs_pass_image(const char *id, int pass, enum jobs_image kind, struct blob **img,
                     int *samples);
/* Cancels job id; false: no such job.  With --data-dir its end is
 * recorded, and w (NULL: none) suspended now and told once that is on
 * disk: *waiting (NULL: not asked) says whether it will be. */
bool jobs_cancel(const char *id, struct work_waiter *w, bool *waiting);
/* Ends a progressive job after the latest complete pass (or after the
 * first, if none is complete yet), keeping it as the job's image.  false:
 * no such job; *progressive false: the job is not progressive. */
bool jobs_end_early(const char *id, bool *progressive);

/* ---- store.c and durable.c: jobs on disk (--data-dir) ----------------------- */

bool store_on(void); /* --data-dir is in use */
/* A finished job's image from its file (PNG, or the EXR), or NULL when it
 * is gone; a plain read (no SQLite), so any thread. */
struct blob *store_read(const char *id, bool exr);
/* Main thread, after sched_start: opens --data-dir, puts every job it
 * holds back (the finished with their results, the others queued again,
 * their scenes parsed again) and starts the store thread.  -1 after
 * saying why. */
int durable_start(void);
void durable_stop(void); /* after sched_stop: what is queued is written */

/* ---- events.c: a job's progress as a stream ------------------------------- */

/* EVENTS_DRAIN: the server stops and the job goes on after its restart
 * (--data-dir): the stream's last event, in place of EVENTS_DONE. */
enum events_kind {
    EVENTS_STATE,
    EVENTS_TILE,
    EVENTS_PASS,
    EVENTS_FRAME,
    EVENTS_DONE,
    EVENTS_DRAIN,
    EVENTS_PING
};
struct events_item {
    enum events_kind kind;
    enum jobs_state state;   /* STATE, DONE */
    struct rayd_region tile; /* TILE */
    int done, total;         /* TILE: tiles reported with this one, of total; PASS: passes */
    double progress;         /* TILE, PASS, DONE */
    int samples;             /* PASS: samples of the pass; DONE: of the image (progressive) */
    double time_s, noise;    /* PASS: as struct jobs_passes */
    long frame;              /* FRAME: the frame that ended (shots.c), done or failed */
    bool frame_failed;       /* FRAME: out of attempts; done, total: frames done, of all */
};
struct events_stream;
struct events_stream *events_open(const char *id); /* NULL: no such job */
/* Up to n items: returns how many; 0 after registering w (its suspend ran),
 * -1 at the end of the stream.  A failed job's error is copied to *err with
 * its DONE item. */
int events_read(struct events_stream *s, struct events_item *items, int n, struct rayd_error *err,
                struct work_waiter *w);
void events_close(struct events_stream *s); /* NULL allowed */

/* ---- shots.c: frame-range jobs --------------------------------------------- */

/* POST /v1/jobs of an animated scene: frames first..last, each rendered as
 * a render of its own (the scene parsed at that frame), fair-shared with
 * everything else.  Its id is a job id: the job routes look here first. */
struct shots_new {
    const char *text; /* the scene as sent (copied) */
    size_t len;
    char scene_id[65];
    struct work_target what; /* the region, keep_exr, the client */
    int priority;
    long first, last; /* within the animation's frames */
    double fps;
    double est_rays;           /* of every frame */
    struct cache_entry *scene; /* the scene as admitted, or NULL: its first frame's parse
                                  takes its image textures decoded */
    struct work_waiter *w;     /* --data-dir: told once the job is on disk */
    bool waiting;              /* out: w->suspend ran and w->done will be called once */
};
/* A new shot; with --data-dir recorded on disk before anyone is told of it
 * (n->waiting, as jobs_submit's). */
enum work_submit shots_submit(struct shots_new *n, char id[33]);
/* SV_EVICTED: a frame was let go (--max-memory, --max-disk) before the
 * video was made; video_error names it. */
enum shots_video { SV_NONE, SV_MAKING, SV_READY, SV_FAILED, SV_NO_FFMPEG, SV_EVICTED };
struct shots_info {
    struct jobs_info job; /* as a job's: state, progress (of frames), error, ... */
    long first, last, total, done, running, queued, failed;
    long latest;  /* the frame that ended last, -1: none yet */
    double eta_s; /* < 0: none */
    double fps;
    int video; /* enum shots_video */
    char video_error[200];
    const char *evicted_why; /* shots_frame of an evicted frame: why it went */
};
bool shots_get(const char *id, struct shots_info *info);
/* As jobs_list, for the frame-range jobs (their seq from the same count). */
int shots_list(uint64_t client, int state, long long before, struct shots_info *out, int n,
               bool *more);
enum shots_frame_state {
    SHOTS_NO_JOB,
    SHOTS_OUTSIDE, /* k outside first..last */
    SHOTS_QUEUED,
    SHOTS_RUNNING,
    SHOTS_DONE,
    SHOTS_FAILED,
    SHOTS_EVICTED /* done, its images let go: info->evicted_why says why */
};
/* Frame k of shot id: its image (referenced; NULL unless done) and info. */
enum shots_frame_state shots_frame(const char *id, long k, bool exr, struct blob **img,
                                   struct shots_info *info);
/* As jobs_cancel, for frame-range job id; false: no such shot. */
bool shots_cancel(const char *id, struct work_waiter *w, bool *waiting);
/* The shot's video once made (referenced), else NULL with info->video. */
struct blob *shots_video(const char *id, struct shots_info *info);
bool shots_start(int max_jobs);
void shots_stop(void);
/* An event stream of a shot: its state, one FRAME item per frame that
 * ended, then DONE; read as events_read. */
struct shot;
struct shots_cursor {
    int cursor, done;
    bool started, sent_done;
    double last_write; /* for the keep-alive (EVENTS_PING_SECONDS) */
};
struct shot *shots_open(const char *id); /* NULL: no such shot */
int shots_events_read(struct shot *s, struct shots_cursor *c, struct events_item *items, int n,
                      struct rayd_error *err, struct work_waiter *w);
void shots_close(struct shot *s); /* NULL allowed */

/* ---- compile.c: scenes parsed off the HTTP threads ------------------------- */

/* What a compile waiter is told. */
struct compile_result {
    enum rayd_status status; /* RAYD_OK and scene, or an error */
    struct rayd_error err;
    struct cache_entry *scene; /* a reference owned by the waiter: scenes_release it */
    bool hit;                  /* found compiled (and its files as read), not parsed */
    bool draining;             /* refused: the server drains (no parse was made for it) */
    bool memory_full;          /* refused: the memory budget has no room now (503 memory_full) */
};

/* A request waiting for its scene: done() is called exactly once, from a
 * parse thread with no lock held; suspend() under the lock before it is
 * linked, as struct work_waiter's. */
struct compile_waiter {
    void (*done)(struct compile_waiter *w, struct compile_result *res);
    void (*suspend)(struct compile_waiter *w);
    struct compile_waiter *next; /* the pool's list link */
    bool dropped;                /* compile_drop'ed: the answer is not wanted */
    uint64_t client;             /* who asks (fair.c's key; 0: the server's own) */
};

/* The compiled scene of body (len bytes, which stay valid and unchanged
 * until w->done when WORK_OK is returned).  WORK_CACHED: *res is the answer
 * now (found compiled, or an error), w is not used.  WORK_OK: w->suspend
 * ran and w->done will be called once; the same body already being parsed
 * is waited for, not parsed again.  WORK_PARSE_FULL, WORK_MEMORY (no room
 * in --max-memory for the parse's first cap) or WORK_DRAINING: refused, w
 * not used. */
enum work_submit compile_scene(const char *body, size_t len, struct compile_waiter *w,
                               struct compile_result *res);
/* compile_scene of body at frame `frame` of its animation (a frame-range
 * job's, shots.c): cached under an id of its own (the body's id and the
 * frame), so each frame is parsed once and frame k is the bytes
 * rayd_scene_parse_frame gives. */
enum work_submit compile_scene_frame(const char *body, size_t len, long frame,
                                     struct compile_waiter *w, struct compile_result *res);
/* Scene e (compiled from body) once its keyframed values are checked at
 * every frame first..last (rayd_scene_check_frames), on the pool: a
 * frame-range job's, before it is taken.  Answers as compile_scene does,
 * with e (a reference of the waiter's) or the first failing frame's error;
 * e is the caller's still. */
enum work_submit compile_check_frames(struct cache_entry *e, const char *body, size_t len,
                                      long first, long last, struct compile_waiter *w,
                                      struct compile_result *res);
/* The cached scene of id for a request that names only its id (GET
 * /v1/scenes/{id}/image.png), its files checked (scenefiles.c): on this
 * thread when it has few, else on the pool (WORK_OK, as above).  res->scene
 * NULL: not held here, or a file changed. */
enum work_submit compile_find_scene(const char *id, struct compile_waiter *w,
                                    struct compile_result *res);
/* w's answer is not wanted (its frame-range job was canceled), lock held:
 * w->done is still called; a parse that no waiter wants any more is
 * stopped within milliseconds (rayd_limits.cancel), and answers
 * RAYD_E_CANCELED. */
void compile_drop(struct compile_waiter *w);
/* About how long a refused request should wait for a place (Retry-After). */
double compile_retry_seconds(void);
/* Starts the parse threads (--parse-threads); false if any could not be
 * made (compile_stop then ends those that were). */
bool compile_start(void);
/* Ends the pool: the scenes still queued are answered draining, the threads
 * joined (each parse running finishes first, waited for up to a bound). */
void compile_stop(void);
/* The test gate's parse knob (--test-gate, POST /v1/test/gate?parses=N):
 * how many more parses may start, -1 open; and what the pool is doing. */
struct compile_gate_state {
    long parses, started, queued, running;
    long waiting; /* requests waiting for a parse queued or running */
};
void compile_gate_set(long parses);
/* The test gate's work knob (?work=N): the rays each render made from now
 * on may cast, as --max-work at run time but not priced at the door (a
 * render that passes it while it runs, which the estimate would refuse);
 * -1: --max-work again. */
void task_gate_work(long rays);
void compile_gate_get(struct compile_gate_state *g);

/* ---- gate.c: the test gate (--test-gate) ----------------------------------- */

/* Workers start a tile only while the gate lets one through.  tiles: how
 * many more may start, -1 = open. */
struct gate_state {
    long tiles, started, held, queued;
};
void gate_enable(long tiles);
bool gate_set(long tiles);           /* false when the gate is off */
bool gate_get(struct gate_state *g); /* false when the gate is off */

#endif
