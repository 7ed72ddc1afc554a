/* jobq.c -- the bounded render queue, the worker pool, jobs, and every lock
 * of the server.
 *
 * A *task* is one render: a compiled scene (a cache entry) and an absolute
 * region of its image.  It is split into tiles of JOBQ_TILE x JOBQ_TILE
 * pixels, rendered with rayd_render_into() straight into one shared
 * rayd_image: tiles are disjoint rectangles, so any number of workers may
 * render tiles of the same task at once without further locking.  The
 * worker that finishes the last tile encodes the PNG and answers everyone
 * interested in the task.
 *
 * Who waits on a task: synchronous requests (a suspended HTTP connection,
 * seen here only as a struct jobq_waiter with a done() callback and the
 * socket to watch) and asynchronous jobs.  Identical requests in flight --
 * same scene id, same region -- join the same task, so a burst of equal
 * tile requests renders once and is answered together.
 *
 * Scheduling is per tile, not per task: each time a worker is free it takes
 * the next tile of the best task.  "Best" is the smallest enqueue time, where
 * an interactive task (at most JOBQ_INTERACTIVE pixels: a preview or a tile)
 * counts as JOBQ_AGING seconds older than it is.  A small request therefore
 * overtakes a large frame at the next tile boundary, while a bulk task that
 * has waited longer than JOBQ_AGING is served before newer small ones, so
 * nothing starves.
 *
 * Back-pressure: at most queue_cap tasks may wait for a worker (have tiles
 * nobody has started); beyond that submissions fail with JOBQ_FULL and the
 * HTTP layer answers 503 + Retry-After.  Joining an identical task is free.
 *
 * Cancelling raises the task's atomic flag; rayd_render_into() checks it, so
 * a cancelled task stops within one tile.  A task is cancelled when its last
 * interested party goes away: a DELETE of its only job, or every waiting
 * client disconnecting.  libmicrohttpd does not watch suspended connections,
 * so a watcher thread polls their sockets for a hang-up (EOF on peek) every
 * JOBQ_WATCH_MS and answers such a waiter with "gone".
 *
 * The same watcher forgets finished jobs past --job-ttl (and --max-jobs
 * bounds the table: the oldest finished job makes room), and every
 * JOBQ_SSE_PING seconds wakes idle event streams so they send a keep-alive
 * comment through proxies.  A finished PNG also goes to the result cache
 * (rcache.c), which answers later identical requests without a task.
 *
 * Locking: one mutex (jobq_lock) guards tasks, jobs, event streams, the
 * scene cache and the result cache (cache.c and rcache.c have no lock of
 * their own).  Rendering and PNG encoding run outside it.  Callbacks into
 * the HTTP layer (waiter->done, which resumes a connection) are made after
 * the waiter has been unlinked and the lock released; the suspend callbacks
 * (of a synchronous render and of an event stream) run under the lock,
 * before the waiter is linked, so a resume can never overtake its suspend.
 */
#include "server.h"

#include <errno.h>
#include <stdarg.h>
#include <poll.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <sys/random.h>
#include <sys/socket.h>
#include <unistd.h>

#define JOBQ_TILE 64
#define JOBQ_INTERACTIVE (256L * 256L)
#define JOBQ_AGING 2.0
#define JOBQ_WATCH_MS 50
#define JOBQ_SSE_PING 15.0 /* seconds of silence before a keep-alive comment */

struct task {
    struct task *next; /* active list */
    char key[160];     /* scene id + region: identical requests share a task */
    char scene_id[65];
    struct cache_entry *scene; /* held until the task finishes */
    struct rayd_region reg;    /* absolute */
    int ntx, nty, ntiles;
    int next_tile, running, done;
    int *order; /* tiles in completion order, for event streams */
    rayd_image *img;
    atomic_int cancel;
    bool interactive, queued, finalizing, finished;
    double t_enq, t_start, t_end;
    double encode_s; /* of t_end - t_start, the PNG's encoding */
    enum rayd_status status;
    struct rayd_error err;
    struct blob *png;
    uint64_t rays;
    struct jobq_waiter *waiters;     /* synchronous requests */
    struct jobq_waiter *sse_waiters; /* event streams waiting for news */
    int njobs;                       /* jobs still interested */
    int refs;                        /* active list + jobs */
};

struct job {
    char id[33];
    struct task *task;
    bool canceled;
    double created;
    int refs; /* the table + open event streams */
};

struct jobq_sse {
    struct job *job;
    int cursor; /* tiles already reported */
    bool started, sent_done;
    double last_write; /* for the keep-alive comment */
};

static pthread_mutex_t jobq_lock = PTHREAD_MUTEX_INITIALIZER;
static pthread_cond_t jobq_cond = PTHREAD_COND_INITIALIZER;
static pthread_t *jobq_threads;
static pthread_t jobq_watcher;
static int jobq_nworkers, jobq_cap, jobq_busy;
static long jobq_queued;
static bool jobq_stopping, jobq_drain_flag;
static struct task *jobq_active;
static struct job **jobq_jobs;
static int jobq_njobs, jobq_max_jobs;

/* ---- helpers (lock held) --------------------------------------------------- */

void blob_unref(struct blob *b)
{
    if (b && atomic_fetch_sub(&b->refs, 1) == 1) {
        rayd_free(b->data);
        free(b);
    }
}

static void task_unref(struct task *t)
{
    if (--t->refs > 0)
        return;
    blob_unref(t->png);
    rayd_image_free(t->img);
    cache_release(t->scene);
    free(t->order);
    free(t);
}

static void task_unqueue(struct task *t)
{
    if (t->queued) {
        t->queued = false;
        jobq_queued--;
    }
}

/* A list of waiters to answer once the lock is released. */
struct jobq_notify {
    struct jobq_waiter *list;
    struct jobq_result res;
};

static void jobq_notify_add(struct jobq_notify *n, struct jobq_waiter **from)
{
    while (*from) {
        struct jobq_waiter *w = *from;
        *from = w->next;
        w->next = n->list;
        n->list = w;
    }
}

static void jobq_notify_run(struct jobq_notify *n)
{
    struct jobq_waiter *w = n->list;
    n->list = NULL;
    while (w) {
        struct jobq_waiter *next = w->next;
        struct jobq_result r = n->res;
        if (r.png)
            atomic_fetch_add(&r.png->refs, 1);
        w->next = NULL;
        w->done(w, &r);
        w = next;
    }
    blob_unref(n->res.png);
    n->res.png = NULL;
}

static void task_result(const struct task *t, struct jobq_result *res)
{
    memset(res, 0, sizeof *res);
    res->status = t->status;
    res->err = t->err;
    if (t->status == RAYD_OK && t->png) {
        res->png = t->png;
        atomic_fetch_add(&t->png->refs, 1);
    }
    res->queue_ms = t->t_start > 0 ? (t->t_start - t->t_enq) * 1e3 : 0;
    res->render_ms = t->t_start > 0 && t->t_end > 0 ? (t->t_end - t->t_start) * 1e3 : 0;
    res->encode_ms = t->encode_s * 1e3;
}

/* Finishes t: unlinks it, fills res for its waiters (moved to n). */
static void task_finish(struct task *t, struct jobq_notify *n, struct jobq_notify *sse)
{
    t->finished = true;
    t->t_end = log_now();
    if (t->status == RAYD_OK && !t->png)
        t->status = RAYD_E_CANCELED;
    if (t->status == RAYD_E_CANCELED && !t->err.message[0]) {
        t->err.code = RAYD_E_CANCELED;
        snprintf(t->err.message, sizeof t->err.message, "the render was cancelled");
    }
    if (t->status == RAYD_OK && t->t_start > 0)
        metrics_render(t->t_end - t->t_start);
    if (t->status == RAYD_OK && t->png)
        rcache_put(t->key, t->png);
    task_unqueue(t);
    rayd_image_free(t->img);
    t->img = NULL;
    cache_release(t->scene);
    t->scene = NULL;
    task_result(t, &n->res);
    jobq_notify_add(n, &t->waiters);
    jobq_notify_add(sse, &t->sse_waiters);
    for (struct task **pp = &jobq_active; *pp; pp = &(*pp)->next)
        if (*pp == t) {
            *pp = t->next;
            break;
        }
    task_unref(t);
}

static void task_cancel(struct task *t, enum metrics_cancel why, struct jobq_notify *n,
                        struct jobq_notify *sse)
{
    if (t->finished || atomic_load(&t->cancel))
        return;
    atomic_store(&t->cancel, 1);
    metrics_cancel(why);
    log_info("render %s cancelled (%s)", t->key,
             why == MC_CLIENT_GONE ? "client gone" : why == MC_DELETE ? "job deleted" : "drain");
    task_unqueue(t);
    if (t->running == 0 && !t->finalizing)
        task_finish(t, n, sse);
}

static struct task *task_pick(void)
{
    struct task *best = NULL;
    double best_score = 0;
    for (struct task *t = jobq_active; t; t = t->next) {
        if (t->next_tile >= t->ntiles || atomic_load(&t->cancel) || t->finalizing)
            continue;
        double score = t->t_enq - (t->interactive ? JOBQ_AGING : 0);
        if (!best || score < best_score) {
            best = t;
            best_score = score;
        }
    }
    return best;
}

static struct task *task_find(const char *key)
{
    for (struct task *t = jobq_active; t; t = t->next)
        if (!t->finalizing && !atomic_load(&t->cancel) && !strcmp(t->key, key))
            return t;
    return NULL;
}

/* ---- the test gate (--test-gate) ------------------------------------------ */

/* Tests that need work in flight (a render running while they cancel it,
 * drain the server or fill the queue) must not hope that a render is slow
 * enough: on a fast idle machine it is not.  With --test-gate a worker stops
 * at a tile boundary until the test lets tiles through (POST /v1/test/gate),
 * so "in flight" is a state the test sets, not a race it runs.  Off unless
 * the option is given; the gate's counters are under jobq_lock. */
static bool jobq_gate_on;
static long jobq_gate_tiles = -1; /* tiles that may still start, -1 = open */
static long jobq_gate_started, jobq_gate_held;

/* May a worker start a tile now?  Takes one from the allowance. */
static bool jobq_gate_pass(void)
{
    if (!jobq_gate_on || jobq_gate_tiles < 0)
        return true;
    if (jobq_gate_tiles == 0)
        return false;
    jobq_gate_tiles--;
    return true;
}

void jobq_gate_enable(long tiles)
{
    pthread_mutex_lock(&jobq_lock);
    jobq_gate_on = true;
    jobq_gate_tiles = tiles;
    pthread_cond_broadcast(&jobq_cond);
    pthread_mutex_unlock(&jobq_lock);
}

bool jobq_gate_set(long tiles)
{
    pthread_mutex_lock(&jobq_lock);
    bool on = jobq_gate_on;
    if (on) {
        jobq_gate_tiles = tiles;
        pthread_cond_broadcast(&jobq_cond);
    }
    pthread_mutex_unlock(&jobq_lock);
    return on;
}

bool jobq_gate_get(struct jobq_gate *g)
{
    pthread_mutex_lock(&jobq_lock);
    g->tiles = jobq_gate_tiles;
    g->started = jobq_gate_started;
    g->held = jobq_gate_held;
    g->queued = jobq_queued;
    bool on = jobq_gate_on;
    pthread_mutex_unlock(&jobq_lock);
    return on;
}

/* ---- workers ------------------------------------------------------------- */

/* The next task a worker should take a tile of, lock held; waits for one.
 * NULL when the pool stops.  A worker held by the test gate counts as held
 * while it waits. */
static struct task *jobq_next_task(void)
{
    while (!jobq_stopping) {
        struct task *t = task_pick();
        if (t && jobq_gate_pass()) {
            jobq_gate_started++;
            return t;
        }
        jobq_gate_held += t != NULL;
        pthread_cond_wait(&jobq_cond, &jobq_lock);
        jobq_gate_held -= t != NULL;
    }
    return NULL;
}

/* Encodes t's PNG (every core: png_encode.c's bands), lock released;
 * returns with the lock held.  The tiles' and the encoding's times go to
 * the stage metrics. */
static void jobq_encode(struct task *t)
{
    void *buf = NULL;
    size_t len = 0;
    struct rayd_error err = {0};
    double t0 = log_now();
    metrics_stage(MS_RENDER, t0 - t->t_start);
    enum rayd_status st = rayd_png_encode(t->img, (int)config.png_level, &buf, &len, &err);
    double enc = log_now() - t0;
    metrics_stage(MS_ENCODE, enc);
    pthread_mutex_lock(&jobq_lock);
    t->encode_s = enc;
    if (st == RAYD_OK) {
        struct blob *b = malloc(sizeof *b);
        if (b) {
            atomic_init(&b->refs, 1);
            b->data = buf;
            b->len = len;
            t->png = b;
        } else {
            rayd_free(buf);
            st = RAYD_E_NOMEM;
        }
    }
    if (st != RAYD_OK) {
        t->status = st;
        t->err = err;
        t->err.code = st;
    }
}

static void *jobq_worker(void *arg)
{
    (void)arg;
    pthread_mutex_lock(&jobq_lock);
    for (;;) {
        struct task *t = jobq_next_task();
        if (!t)
            break;
        int tile = t->next_tile++;
        if (tile == 0) {
            t->t_start = log_now();
            metrics_queue_wait(t->t_start - t->t_enq);
            metrics_stage(MS_QUEUE, t->t_start - t->t_enq);
        }
        if (t->next_tile == t->ntiles)
            task_unqueue(t);
        t->running++;
        jobq_busy++;
        pthread_mutex_unlock(&jobq_lock);

        int tx = tile % t->ntx, ty = tile / t->ntx;
        struct rayd_region tr = {t->reg.x + tx * JOBQ_TILE, t->reg.y + ty * JOBQ_TILE, JOBQ_TILE,
                                 JOBQ_TILE};
        if (tr.x + tr.w > t->reg.x + t->reg.w)
            tr.w = t->reg.x + t->reg.w - tr.x;
        if (tr.y + tr.h > t->reg.y + t->reg.h)
            tr.h = t->reg.y + t->reg.h - tr.y;
        uint64_t rays = 0;
        struct rayd_error err = {0};
        enum rayd_status st = rayd_render_into(cache_scene(t->scene), &tr, t->img, tr.x - t->reg.x,
                                               tr.y - t->reg.y, &t->cancel, &rays, &err);
        metrics_rays(rays);

        struct jobq_notify n = {0}, sse = {0};
        pthread_mutex_lock(&jobq_lock);
        jobq_busy--;
        t->running--;
        t->rays += rays;
        if (st == RAYD_OK) {
            t->order[t->done++] = tile;
            jobq_notify_add(&sse, &t->sse_waiters);
        } else if (st != RAYD_E_CANCELED && t->status == RAYD_OK) {
            t->status = st;
            t->err = err;
            t->err.code = st;
            atomic_store(&t->cancel, 1);
            task_unqueue(t);
        }
        if (t->running == 0 && !t->finalizing) {
            if (t->done == t->ntiles && t->status == RAYD_OK) {
                t->finalizing = true;
                pthread_mutex_unlock(&jobq_lock);
                jobq_encode(t); /* returns with the lock held */
                task_finish(t, &n, &sse);
            } else if (atomic_load(&t->cancel) || t->status != RAYD_OK) {
                task_finish(t, &n, &sse);
            }
        }
        pthread_mutex_unlock(&jobq_lock);
        jobq_notify_run(&n);
        jobq_notify_run(&sse);
        pthread_mutex_lock(&jobq_lock);
    }
    pthread_mutex_unlock(&jobq_lock);
    return NULL;
}

static enum jobq_state job_state(const struct job *j);
static void job_unref(struct job *j);

/* ---- the hang-up watcher --------------------------------------------------- */

static void *jobq_watch(void *arg)
{
    (void)arg;
    struct pollfd *fds = NULL;
    struct jobq_waiter **ws = NULL;
    size_t cap = 0;
    double last_ping = log_now(), last_expire = log_now();
    pthread_mutex_lock(&jobq_lock);
    while (!jobq_stopping) {
        size_t nfd = 0;
        for (struct task *t = jobq_active; t; t = t->next)
            for (int pass = 0; pass < 2; pass++)
                for (struct jobq_waiter *w = pass ? t->sse_waiters : t->waiters; w; w = w->next) {
                    if (w->fd < 0)
                        continue;
                    if (nfd == cap) {
                        size_t nc = cap ? cap * 2 : 64;
                        struct pollfd *f2 = realloc(fds, nc * sizeof *fds);
                        if (f2)
                            fds = f2;
                        struct jobq_waiter **w2 = realloc(ws, nc * sizeof *ws);
                        if (w2)
                            ws = w2;
                        if (!f2 || !w2)
                            goto polled;
                        cap = nc;
                    }
                    fds[nfd].fd = w->fd;
                    fds[nfd].events = POLLIN;
                    fds[nfd].revents = 0;
                    ws[nfd++] = w;
                }
    polled:
        if (log_now() - last_expire >= 1.0) {
            /* forget finished jobs past --job-ttl */
            last_expire = log_now();
            for (int i = 0; i < jobq_njobs;) {
                struct job *j = jobq_jobs[i];
                enum jobq_state s = job_state(j);
                if ((s == JS_SUCCEEDED || s == JS_FAILED || s == JS_CANCELED) &&
                    last_expire - j->created > (double)config.job_ttl) {
                    jobq_jobs[i] = jobq_jobs[--jobq_njobs];
                    job_unref(j);
                } else {
                    i++;
                }
            }
        }
        if (log_now() - last_ping >= JOBQ_SSE_PING) {
            /* wake idle event streams so they send a keep-alive comment */
            last_ping = log_now();
            struct jobq_notify ping = {0};
            for (struct task *t = jobq_active; t; t = t->next)
                jobq_notify_add(&ping, &t->sse_waiters);
            if (ping.list) {
                pthread_mutex_unlock(&jobq_lock);
                jobq_notify_run(&ping);
                pthread_mutex_lock(&jobq_lock);
                continue;
            }
        }
        if (nfd > 0 && poll(fds, nfd, 0) > 0) {
            struct jobq_notify gone = {0}, n = {0}, sse = {0};
            gone.res.gone = true;
            gone.res.status = RAYD_E_CANCELED;
            for (size_t i = 0; i < nfd; i++) {
                char c;
                if (!(fds[i].revents & (POLLHUP | POLLERR | POLLNVAL)) &&
                    !((fds[i].revents & POLLIN) &&
                      recv(fds[i].fd, &c, 1, MSG_PEEK | MSG_DONTWAIT) == 0))
                    continue;
                /* unlink ws[i] from whichever list holds it */
                for (struct task *t = jobq_active; t; t = t->next) {
                    bool found = false;
                    for (int pass = 0; pass < 2 && !found; pass++)
                        for (struct jobq_waiter **pp = pass ? &t->sse_waiters : &t->waiters; *pp;
                             pp = &(*pp)->next)
                            if (*pp == ws[i]) {
                                *pp = ws[i]->next;
                                ws[i]->next = gone.list;
                                gone.list = ws[i];
                                found = true;
                                break;
                            }
                    if (found) {
                        if (!t->waiters && t->njobs == 0)
                            task_cancel(t, MC_CLIENT_GONE, &n, &sse);
                        break;
                    }
                }
            }
            pthread_mutex_unlock(&jobq_lock);
            jobq_notify_run(&gone);
            jobq_notify_run(&n);
            jobq_notify_run(&sse);
            pthread_mutex_lock(&jobq_lock);
        }
        struct timespec ts;
        clock_gettime(CLOCK_REALTIME, &ts);
        ts.tv_nsec += JOBQ_WATCH_MS * 1000000L;
        if (ts.tv_nsec >= 1000000000L) {
            ts.tv_sec++;
            ts.tv_nsec -= 1000000000L;
        }
        pthread_cond_timedwait(&jobq_cond, &jobq_lock, &ts);
    }
    pthread_mutex_unlock(&jobq_lock);
    free(fds);
    free(ws);
    return NULL;
}

/* ---- start / stop ---------------------------------------------------------- */

int jobq_start(int workers, int queue_cap, int max_jobs)
{
    jobq_cap = queue_cap;
    jobq_max_jobs = max_jobs;
    jobq_jobs = calloc((size_t)max_jobs, sizeof *jobq_jobs);
    jobq_threads = calloc((size_t)workers, sizeof *jobq_threads);
    if (!jobq_jobs || !jobq_threads)
        return -1;
    cache_init((size_t)config.cache_mb * 1024 * 1024);
    rcache_init((size_t)config.result_cache_mb * 1024 * 1024);
    for (int i = 0; i < workers; i++) {
        if (pthread_create(&jobq_threads[i], NULL, jobq_worker, NULL))
            return -1;
        jobq_nworkers++;
    }
    if (pthread_create(&jobq_watcher, NULL, jobq_watch, NULL))
        return -1;
    return 0;
}

void jobq_stop(void)
{
    pthread_mutex_lock(&jobq_lock);
    jobq_stopping = true;
    pthread_cond_broadcast(&jobq_cond);
    pthread_mutex_unlock(&jobq_lock);
    for (int i = 0; i < jobq_nworkers; i++)
        pthread_join(jobq_threads[i], NULL);
    pthread_join(jobq_watcher, NULL);
    free(jobq_threads);
    jobq_threads = NULL;
    /* Anything left was cancelled by the drain; answer and free it. */
    struct jobq_notify n = {0}, sse = {0};
    while (jobq_active) {
        struct task *t = jobq_active;
        atomic_store(&t->cancel, 1);
        task_finish(t, &n, &sse);
        jobq_notify_run(&n);
        jobq_notify_run(&sse);
    }
    for (int i = 0; i < jobq_njobs; i++) {
        struct job *j = jobq_jobs[i];
        if (--j->refs == 0) {
            if (j->task)
                task_unref(j->task);
            free(j);
        }
    }
    jobq_njobs = 0;
    free(jobq_jobs);
    jobq_jobs = NULL;
    cache_free_all();
    rcache_free_all();
}

/* ---- scenes ---------------------------------------------------------------- */

/* The scene limits: the core's defaults with --max-pixels and --max-body,
 * unless set here (the fuzz harness lowers them so it explores errors rather
 * than rendering big scenes). */
static struct rayd_limits jobq_limits;
static bool jobq_limits_set;

void jobq_set_limits(const struct rayd_limits *lim)
{
    jobq_limits = *lim;
    jobq_limits_set = true;
}

enum rayd_status jobq_scene_parse(const char *body, size_t len, struct cache_entry **out,
                                  bool *hit, struct rayd_error *err)
{
    char id[65];
    if (!cache_hash(body, len, id)) {
        if (err) {
            memset(err, 0, sizeof *err);
            err->code = RAYD_E_NOMEM;
            snprintf(err->message, sizeof err->message, "cannot hash the scene (libcrypto)");
        }
        return RAYD_E_NOMEM;
    }
    pthread_mutex_lock(&jobq_lock);
    struct cache_entry *e = cache_get(id);
    pthread_mutex_unlock(&jobq_lock);
    metrics_cache(e != NULL);
    *hit = e != NULL;
    if (e) {
        *out = e;
        return RAYD_OK;
    }
    struct rayd_limits lim;
    if (jobq_limits_set) {
        lim = jobq_limits;
    } else {
        rayd_limits_default(&lim);
        lim.max_pixels = config.max_pixels;
        if (lim.max_bytes < (size_t)config.max_body)
            lim.max_bytes = (size_t)config.max_body;
    }
    rayd_scene *scene = NULL;
    double t0 = log_now();
    enum rayd_status st = rayd_scene_parse(body, len, &lim, &scene, err);
    double parsed = log_now() - t0;
    if (st != RAYD_OK) {
        metrics_stage(MS_PARSE, parsed);
        return st;
    }
    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    metrics_stage(MS_PARSE, parsed - info.decode_seconds - info.build_seconds);
    metrics_stage(MS_DECODE, info.decode_seconds);
    metrics_stage(MS_BUILD, info.build_seconds);
    pthread_mutex_lock(&jobq_lock);
    e = cache_put(id, scene);
    pthread_mutex_unlock(&jobq_lock);
    if (!e) {
        rayd_scene_free(scene);
        if (err) {
            memset(err, 0, sizeof *err);
            err->code = RAYD_E_NOMEM;
            snprintf(err->message, sizeof err->message, "out of memory");
        }
        return RAYD_E_NOMEM;
    }
    *out = e;
    return RAYD_OK;
}

struct cache_entry *jobq_scene_find(const char *id)
{
    pthread_mutex_lock(&jobq_lock);
    struct cache_entry *e = cache_get(id);
    pthread_mutex_unlock(&jobq_lock);
    return e;
}

void jobq_scene_release(struct cache_entry *e)
{
    if (!e)
        return;
    pthread_mutex_lock(&jobq_lock);
    cache_release(e);
    pthread_mutex_unlock(&jobq_lock);
}

/* ---- submitting -------------------------------------------------------------- */

static void task_key(char *key, size_t size, const char *id, const struct rayd_region *reg)
{
    snprintf(key, size, "%s@%d,%d,%d,%d", id, reg->x, reg->y, reg->w, reg->h);
}

/* A new task for (scene, reg), with the image allocated; NULL on no memory. */
static struct task *task_new(struct cache_entry *scene, const struct rayd_region *reg)
{
    struct task *t = calloc(1, sizeof *t);
    if (!t)
        return NULL;
    t->reg = *reg;
    t->ntx = (reg->w + JOBQ_TILE - 1) / JOBQ_TILE;
    t->nty = (reg->h + JOBQ_TILE - 1) / JOBQ_TILE;
    t->ntiles = t->ntx * t->nty;
    t->order = calloc((size_t)t->ntiles, sizeof *t->order);
    if (!t->order || rayd_image_new(reg->w, reg->h, &t->img, NULL) != RAYD_OK) {
        free(t->order);
        free(t);
        return NULL;
    }
    snprintf(t->scene_id, sizeof t->scene_id, "%s", cache_id(scene));
    task_key(t->key, sizeof t->key, t->scene_id, reg);
    atomic_init(&t->cancel, 0);
    t->interactive = (long)reg->w * reg->h <= JOBQ_INTERACTIVE;
    t->status = RAYD_OK;
    t->refs = 1;
    return t;
}

/* Joins or creates the task for (scene, reg), lock held.  *fresh is the
 * preallocated task, consumed when used. */
static enum jobq_submit jobq_task_for(struct cache_entry *scene, const struct rayd_region *reg,
                                      struct task **fresh, struct task **out)
{
    char key[160];
    task_key(key, sizeof key, cache_id(scene), reg);
    struct task *t = task_find(key);
    if (t) {
        metrics_coalesced();
        *out = t;
        return JOBQ_OK;
    }
    if (jobq_queued >= jobq_cap)
        return JOBQ_FULL;
    t = *fresh;
    *fresh = NULL;
    t->scene = cache_ref(scene);
    t->t_enq = log_now();
    t->queued = true;
    jobq_queued++;
    t->next = jobq_active;
    jobq_active = t;
    pthread_cond_broadcast(&jobq_cond);
    *out = t;
    return JOBQ_OK;
}

struct blob *jobq_result_find(const struct cache_entry *scene, const struct rayd_region *reg)
{
    char key[160];
    task_key(key, sizeof key, cache_id(scene), reg);
    pthread_mutex_lock(&jobq_lock);
    struct blob *b = rcache_get(key);
    pthread_mutex_unlock(&jobq_lock);
    metrics_result_cache(b != NULL);
    return b;
}

enum jobq_submit jobq_render(struct cache_entry *scene, const struct rayd_region *reg,
                             struct jobq_waiter *w, void (*suspend)(struct jobq_waiter *w))
{
    struct task *fresh = task_new(scene, reg);
    if (!fresh)
        return JOBQ_NOMEM;
    pthread_mutex_lock(&jobq_lock);
    struct task *t = NULL;
    enum jobq_submit r = jobq_drain_flag ? JOBQ_DRAINING : jobq_task_for(scene, reg, &fresh, &t);
    if (r == JOBQ_OK) {
        suspend(w);
        w->next = t->waiters;
        t->waiters = w;
    }
    pthread_mutex_unlock(&jobq_lock);
    if (fresh)
        task_unref(fresh);
    return r;
}

/* ---- jobs ---------------------------------------------------------------------- */

const char *jobq_state_name(enum jobq_state s)
{
    static const char *const names[] = {"queued", "running", "succeeded", "failed", "canceled"};
    return names[s];
}

static enum jobq_state job_state(const struct job *j)
{
    const struct task *t = j->task;
    if (j->canceled)
        return JS_CANCELED;
    if (t->finished)
        return t->status == RAYD_OK            ? JS_SUCCEEDED
               : t->status == RAYD_E_CANCELED ? JS_CANCELED
                                               : JS_FAILED;
    return t->next_tile == 0 && !t->finalizing ? JS_QUEUED : JS_RUNNING;
}

static struct job *job_find(const char *id)
{
    for (int i = 0; i < jobq_njobs; i++)
        if (!strcmp(jobq_jobs[i]->id, id))
            return jobq_jobs[i];
    return NULL;
}

static void job_unref(struct job *j)
{
    if (--j->refs > 0)
        return;
    task_unref(j->task);
    free(j);
}

/* Makes room in the table by forgetting the oldest finished job. */
static bool job_evict(void)
{
    int victim = -1;
    for (int i = 0; i < jobq_njobs; i++) {
        enum jobq_state s = job_state(jobq_jobs[i]);
        if (s == JS_SUCCEEDED || s == JS_FAILED || s == JS_CANCELED) {
            if (victim < 0 || jobq_jobs[i]->created < jobq_jobs[victim]->created)
                victim = i;
        }
    }
    if (victim < 0)
        return false;
    struct job *j = jobq_jobs[victim];
    jobq_jobs[victim] = jobq_jobs[--jobq_njobs];
    job_unref(j);
    return true;
}

enum jobq_submit jobq_job_create(struct cache_entry *scene, const struct rayd_region *reg,
                                 char id[33])
{
    uint8_t rnd[16];
    if (getrandom(rnd, sizeof rnd, 0) != (ssize_t)sizeof rnd)
        return JOBQ_NOMEM;
    for (int i = 0; i < 16; i++)
        snprintf(id + 2 * i, 3, "%02x", rnd[i]);
    struct job *j = calloc(1, sizeof *j);
    struct task *fresh = task_new(scene, reg);
    if (!j || !fresh) {
        free(j);
        if (fresh)
            task_unref(fresh);
        return JOBQ_NOMEM;
    }
    snprintf(j->id, sizeof j->id, "%s", id);
    j->created = log_now();
    j->refs = 1;
    pthread_mutex_lock(&jobq_lock);
    enum jobq_submit r = JOBQ_OK;
    struct task *t = NULL;
    if (jobq_drain_flag)
        r = JOBQ_DRAINING;
    else if (jobq_njobs == jobq_max_jobs && !job_evict())
        r = JOBQ_TOO_MANY_JOBS;
    else
        r = jobq_task_for(scene, reg, &fresh, &t);
    if (r == JOBQ_OK) {
        j->task = t;
        t->refs++;
        t->njobs++;
        jobq_jobs[jobq_njobs++] = j;
        j = NULL;
    }
    pthread_mutex_unlock(&jobq_lock);
    free(j);
    if (fresh)
        task_unref(fresh);
    return r;
}

bool jobq_job_get(const char *id, struct jobq_job_info *info, bool want_png)
{
    memset(info, 0, sizeof *info);
    pthread_mutex_lock(&jobq_lock);
    struct job *j = job_find(id);
    if (j) {
        const struct task *t = j->task;
        info->state = job_state(j);
        info->tiles_done = t->done;
        info->tiles_total = t->ntiles;
        info->progress = t->ntiles ? (double)t->done / t->ntiles : 0;
        if (info->state == JS_SUCCEEDED)
            info->progress = 1;
        info->region = t->reg;
        snprintf(info->scene_id, sizeof info->scene_id, "%s", t->scene_id);
        double now = log_now();
        info->created_age = now - j->created;
        info->queue_ms = t->t_start > 0 ? (t->t_start - t->t_enq) * 1e3 : (now - t->t_enq) * 1e3;
        info->render_ms = t->t_start > 0 ? ((t->finished ? t->t_end : now) - t->t_start) * 1e3 : 0;
        info->encode_ms = t->encode_s * 1e3;
        info->rays = t->rays;
        if (info->state == JS_FAILED)
            info->err = t->err;
        if (want_png && info->state == JS_SUCCEEDED && t->png) {
            info->png = t->png;
            atomic_fetch_add(&t->png->refs, 1);
        }
    }
    pthread_mutex_unlock(&jobq_lock);
    return j != NULL;
}

bool jobq_job_cancel(const char *id)
{
    struct jobq_notify n = {0}, sse = {0};
    pthread_mutex_lock(&jobq_lock);
    struct job *j = job_find(id);
    if (j && !j->canceled && !j->task->finished) {
        struct task *t = j->task;
        j->canceled = true;
        t->njobs--;
        if (t->njobs == 0 && !t->waiters)
            task_cancel(t, MC_DELETE, &n, &sse);
        jobq_notify_add(&sse, &t->sse_waiters);
    }
    pthread_mutex_unlock(&jobq_lock);
    jobq_notify_run(&n);
    jobq_notify_run(&sse);
    return j != NULL;
}

/* ---- event streams --------------------------------------------------------------- */

struct jobq_sse *jobq_sse_open(const char *id)
{
    struct jobq_sse *s = calloc(1, sizeof *s);
    if (!s)
        return NULL;
    pthread_mutex_lock(&jobq_lock);
    struct job *j = job_find(id);
    if (j) {
        j->refs++;
        s->job = j;
    }
    pthread_mutex_unlock(&jobq_lock);
    if (!j) {
        free(s);
        return NULL;
    }
    return s;
}

static size_t sse_event(char *buf, size_t max, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

static size_t sse_event(char *buf, size_t max, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(buf, max, fmt, ap);
    va_end(ap);
    return n < 0 || (size_t)n >= max ? 0 : (size_t)n;
}

ssize_t jobq_sse_read(struct jobq_sse *s, char *buf, size_t max, struct jobq_waiter *w,
                      void (*suspend)(struct jobq_waiter *w))
{
    size_t n = 0;
    pthread_mutex_lock(&jobq_lock);
    struct job *j = s->job;
    struct task *t = j->task;
    if (!s->started) {
        size_t k = sse_event(buf, max, "retry: 1000\nevent: state\ndata: {\"id\":\"%s\",\"state\":\"%s\"}\n\n",
                             j->id, jobq_state_name(job_state(j)));
        if (k) {
            n += k;
            s->started = true;
        }
    }
    while (s->cursor < t->done && !j->canceled) {
        int tile = t->order[s->cursor];
        int tx = tile % t->ntx, ty = tile / t->ntx;
        int x = t->reg.x + tx * JOBQ_TILE, y = t->reg.y + ty * JOBQ_TILE;
        int tw = JOBQ_TILE, th = JOBQ_TILE;
        if (x + tw > t->reg.x + t->reg.w)
            tw = t->reg.x + t->reg.w - x;
        if (y + th > t->reg.y + t->reg.h)
            th = t->reg.y + t->reg.h - y;
        size_t k = sse_event(buf + n, max - n,
                             "event: tile\ndata: {\"x\":%d,\"y\":%d,\"w\":%d,\"h\":%d}\n\n"
                             "event: progress\ndata: {\"progress\":%.4f,\"done\":%d,\"total\":%d}\n\n",
                             x, y, tw, th, (double)(s->cursor + 1) / t->ntiles, s->cursor + 1,
                             t->ntiles);
        if (!k)
            break;
        n += k;
        s->cursor++;
    }
    enum jobq_state st = job_state(j);
    bool final = st == JS_SUCCEEDED || st == JS_FAILED || st == JS_CANCELED;
    if (n == 0 && final && !s->sent_done) {
        char msg[600] = "";
        if (st == JS_FAILED) {
            char esc[560];
            snprintf(msg, sizeof msg, ",\"error\":\"%s\"",
                     http_json_escape(t->err.message, esc, sizeof esc));
        }
        n = sse_event(buf, max, "event: done\ndata: {\"state\":\"%s\",\"progress\":%.4f%s}\n\n",
                      jobq_state_name(st), st == JS_SUCCEEDED ? 1.0 : (double)t->done / t->ntiles,
                      msg);
        s->sent_done = true;
    }
    double now = log_now();
    if (n == 0 && !final && s->last_write > 0 && now - s->last_write >= JOBQ_SSE_PING)
        n = sse_event(buf, max, ": keep-alive\n\n");
    if (n > 0)
        s->last_write = now;
    ssize_t ret;
    if (n > 0)
        ret = (ssize_t)n;
    else if (s->sent_done)
        ret = -1;
    else {
        w->next = t->sse_waiters;
        t->sse_waiters = w;
        suspend(w);
        ret = 0;
    }
    pthread_mutex_unlock(&jobq_lock);
    return ret;
}

void jobq_sse_close(struct jobq_sse *s)
{
    if (!s)
        return;
    pthread_mutex_lock(&jobq_lock);
    job_unref(s->job);
    pthread_mutex_unlock(&jobq_lock);
    free(s);
}

/* ---- lifecycle --------------------------------------------------------------------- */

void jobq_drain(void)
{
    pthread_mutex_lock(&jobq_lock);
    jobq_drain_flag = true;
    pthread_mutex_unlock(&jobq_lock);
}

bool jobq_draining(void)
{
    pthread_mutex_lock(&jobq_lock);
    bool d = jobq_drain_flag;
    pthread_mutex_unlock(&jobq_lock);
    return d;
}

void jobq_cancel_all(void)
{
    pthread_mutex_lock(&jobq_lock);
    for (;;) {
        struct task *t = jobq_active;
        while (t && (atomic_load(&t->cancel) || t->finished))
            t = t->next;
        if (!t)
            break;
        struct jobq_notify n = {0}, sse = {0};
        task_cancel(t, MC_DRAIN, &n, &sse);
        pthread_mutex_unlock(&jobq_lock);
        jobq_notify_run(&n);
        jobq_notify_run(&sse);
        pthread_mutex_lock(&jobq_lock);
    }
    pthread_mutex_unlock(&jobq_lock);
}

bool jobq_idle(void)
{
    pthread_mutex_lock(&jobq_lock);
    bool idle = jobq_active == NULL;
    pthread_mutex_unlock(&jobq_lock);
    return idle;
}

void jobq_stats(struct jobq_stats *st)
{
    pthread_mutex_lock(&jobq_lock);
    st->queued = jobq_queued;
    st->running_tasks = 0;
    for (struct task *t = jobq_active; t; t = t->next)
        if (t->next_tile > 0)
            st->running_tasks++;
    st->busy_workers = jobq_busy;
    st->workers = jobq_nworkers;
    st->jobs = jobq_njobs;
    st->queue_cap = jobq_cap;
    cache_stats(&st->cache_bytes, &st->cache_entries);
    rcache_stats(&st->result_bytes, &st->result_entries);
    pthread_mutex_unlock(&jobq_lock);
}
