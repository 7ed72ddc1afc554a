/* sched.c -- the worker pool: who renders which tile next, and the pool's
 * life from start to drain to stop.
 *
 * Scheduling is per tile, not per task: each time a worker is free it takes
 * the next tile of the task task_pick() puts first (task.c explains the
 * order), so a small interactive request overtakes a big frame at the next
 * tile boundary.  The task's state is task.c's: a worker takes a tile
 * (task_take), books it (task_tile_done) and, when it was the last, makes
 * the answer without the lock and hands it back (task_encoded,
 * task_pass_closed).  Every lock a function here releases is one it took.  A plain PNG task is
 * encoded as it is drawn: the worker that finishes a row of its tiles deflates the PNG bands that
 * row completes (rayd_png_stream, lock released, the task still counted as running so it cannot
 * finish meanwhile), so the encoding overlaps the other tiles' rendering.  The worker that finishes
 * a task's last tile encodes what is left of its PNG (or, for a 16-bit PNG or EXR task, its linear
 * floats) -- with the lock released, like the tiles -- and answers everyone interested in it.
 *
 * Back-pressure: at most queue_cap tasks may wait for a worker (have tiles
 * nobody has started); beyond that a submission is refused with WORK_FULL and
 * the handler answers 503 + Retry-After.  Joining an identical task is free,
 * and a finished identical render is answered from the result cache
 * (rcache.c) without a task at all.
 *
 * The spare worker: one thread beyond --threads, for quick interactive
 * tiles only.  A tile is the unit of scheduling, and one tile can still run
 * for as long as the limits let it: a pixel of a 28-deep stack of glass is
 * 2^29 rays, more than any tile size can split, and with every worker on
 * such a tile an 8x8 preview of another client waited for
 * --max-render-seconds (an hour by default).  The spare takes a tile only
 * of an interactive plain render whose tiles are priced within a tile's
 * size (task_pick_quick), and only while every worker has been on its tile
 * for over SCHED_SPARE_AFTER_S: renders of ordinary tiles (about 100 ms)
 * never wake it, and it never holds a long tile itself.
 *
 * Drain: task.c's flag refuses new work while what is queued finishes; the
 * deadline cancels the rest (sched_cancel_all).
 *
 * This file is the top of the work layer: it starts and stops the others
 * (caches, jobs, the watcher) and no other work file calls it.
 */
#include "work/work_private.h"

#include <stdlib.h>
#include <string.h>

static pthread_t *sched_threads, sched_spare_thread;
static int sched_nworkers, sched_busy;
static bool sched_stopping, sched_spare_on; /* lock held: the workers end */
static double *sched_since; /* when each worker's tile started, 0 when it has none */

#define SCHED_SPARE_AFTER_S 0.5 /* five ordinary tiles */
#define SCHED_SPARE_POLL_S 0.1

/* ---- workers --------------------------------------------------------------- */

/* The next task a worker should take a tile of, lock held; waits for one.
 * NULL when the pool stops.  A worker held by the test gate counts as held
 * while it waits. */
static struct task *sched_next_task(void) {
    work_assert_locked();
    while (!sched_stopping) {
        struct task *t = task_pick();
        if (t && gate_pass()) {
            gate_count(1, 0);
            return t;
        }
        gate_count(0, t != NULL);
        work_wait(&work_cond);
        gate_count(0, -(long)(t != NULL));
    }
    return NULL;
}

/* An encoder's bytes (buf, len bytes, when *st is RAYD_OK) kept as a
 * blob; NULL when *st was not RAYD_OK, or when there is no memory for the
 * blob: then *st and err say so (what names the bytes).  Lock not held. */
static struct blob *sched_keep(enum rayd_status *st, void *buf, size_t len, struct rayd_error *err,
                               const char *what) {
    work_assert_unlocked();
    struct blob *b = *st == RAYD_OK ? blob_new(buf, len) : NULL;
    if (*st == RAYD_OK && !b) {
        rayd_free(buf);
        *st = RAYD_E_NOMEM;
        snprintf(err->message, sizeof err->message, "out of memory keeping %s", what);
    }
    return b;
}

/* The EXR of t's linear floats when t keeps one (keep_exr), after *st was
 * RAYD_OK; else NULL.  A failure sets *st and err.  Lock not held. */
static struct blob *sched_exr(const struct task *t, enum rayd_status *st, struct rayd_error *err) {
    work_assert_unlocked();
    if (!t->keep_exr || *st != RAYD_OK) return NULL;
    void *buf = NULL;
    size_t len = 0;
    *st = rayd_exr_encode_aov(t->lin, t->aov, t->aov ? t->aov_mask : 0, t->reg.w, t->reg.h, &buf,
                              &len, err);
    return sched_keep(st, buf, len, err, "the EXR");
}

/* Encodes t's answer in its format (every core: png_encode.c's bands, or
 * the rest of its PNG stream), and its EXR when it keeps one, into o; no
 * lock.  The tiles' and the encoding's times go to the stage metrics. */
static void sched_encode(struct task *t, struct task_out *o) {
    work_assert_unlocked();
    void *buf = NULL;
    size_t len = 0;
    double t0 = clock_now();
    metrics_stage(MS_RENDER, t0 - t->t_start);
    o->st = task_format(t->format)->encode(t, &buf, &len, &o->err);
    o->png = sched_keep(&o->st, buf, len, &o->err, "the PNG");
    o->exr = sched_exr(t, &o->st, &o->err);
    o->encode_s = clock_now() - t0;
    metrics_stage(MS_ENCODE, o->encode_s);
}

/* The pass whose last tile just finished, into o: its noise estimate, its
 * PNG (and EXR), the image for the next pass; no lock. */
static void sched_pass(struct task *t, struct task_out *o) {
    work_assert_unlocked();
    struct passes *p = t->passes;
    o->noise = passes_noise(p, t->img, p->pass);
    if (!p->prev && p->pass + 1 < p->n) rayd_image_new(t->reg.w, t->reg.h, &o->spare, NULL);
    void *buf = NULL;
    size_t len = 0;
    o->st = rayd_png_encode(t->img, (int)config.png_level, &buf, &len, &o->err);
    o->png = sched_keep(&o->st, buf, len, &o->err, "the pass's PNG");
    o->exr = sched_exr(t, &o->st, &o->err);
    if (p->raw && o->st == RAYD_OK) { /* a denoised pass: its raw image too */
        buf = NULL;
        o->st = rayd_png_encode(p->raw, (int)config.png_level, &buf, &len, &o->err);
        o->raw = sched_keep(&o->st, buf, len, &o->err, "the pass's raw PNG");
        passes_raw_done(p);
    }
}

/* Tile `tile` of t is drawn: when that completes rows at the top, the
 * stream encodes the bands they finish, on this worker, without the lock
 * (t cannot finish meanwhile: this worker still counts as running it).
 * A stream's call deflates only the bands its rows complete, a band or
 * two, so the worker is soon back for tiles. */
static void sched_stream_tile(struct task *t, int tile) {
    work_assert_unlocked();
    int rows = task_rows_done(t, tile);
    if (rows > 0) rayd_png_stream_rows(t->stream, rows);
}

/* Finishes t when its last tile (of a pass) was drawn: its answer (or
 * pass) made without the lock, then kept under it.  Called and returns
 * without the lock; t's waiters onto n and sse. */
static void sched_finalize(struct task *t, enum task_next next, struct task_notify *n,
                           struct task_notify *sse) {
    struct task_out o = {0};
    if (next == TASK_ENCODE)
        sched_encode(t, &o);
    else
        sched_pass(t, &o);
    work_lock_take();
    if (next == TASK_ENCODE)
        task_encoded(t, &o, n, sse);
    else
        task_pass_closed(t, &o, n, sse);
    work_lock_give();
}

/* t's ray budget (--max-work), or NULL when there is none. */
static atomic_int_least64_t *sched_budget(struct task *t) {
    return t->work > 0 ? &t->rays_left : NULL;
}

/* A WORK_SUMS tile: its samples k0..k1-1 summed, into t's sums. */
static enum rayd_status sched_sums_tile(struct task *t, const struct rayd_region *tr,
                                        uint64_t *rays, struct rayd_error *err) {
    rayd_accum *acc = NULL;
    struct rayd_render_stats stats = {0};
    struct rayd_render_opts o = {.threads = 1,
                                 .tile = tr->w > tr->h ? tr->w : tr->h,
                                 .cancel = &t->cancel,
                                 .stats = &stats,
                                 .rays_left = sched_budget(t)};
    enum rayd_status st = rayd_accum_new(cache_scene(t->scene), tr, &acc, err);
    if (st == RAYD_OK)
        st = t->centre
                 ? rayd_render_pass(cache_scene(t->scene), &o, acc, 0, 1, err)
                 : rayd_render_sample_range(cache_scene(t->scene), &o, acc, t->k0, t->k1, err);
    *rays += stats.rays;
    const double *in = st == RAYD_OK ? rayd_accum_sums(acc) : NULL;
    for (int row = 0; in && row < tr->h; row++)
        memcpy(t->sums + ((size_t)(tr->y - t->reg.y + row) * (size_t)t->reg.w +
                          (size_t)(tr->x - t->reg.x)) *
                             3,
               in + (size_t)row * (size_t)tr->w * 3, (size_t)tr->w * 3 * sizeof *in);
    rayd_accum_free(acc);
    return st;
}

/* Renders tile `tile` of t (of pass `pass` if progressive), no lock.  The
 * core looks at t's cancel flag and ray budget every thousand rays or so,
 * so a cancel, a deadline or a spent budget stops the tile within
 * milliseconds whatever one pixel costs. */
static enum rayd_status sched_tile(struct task *t, int tile, int pass, uint64_t *rays,
                                   struct rayd_error *err) {
    work_assert_unlocked();
    struct rayd_region tr = task_tile(t, tile);
    const rayd_scene *scene = cache_scene(t->scene);
    int dx = tr.x - t->reg.x, dy = tr.y - t->reg.y;
    struct resolve_dst dst = {t->img, t->lin,      t->reg.w, dx,        dy,
                              t->aov, t->aov_mask, scene,    t->denoise};
    atomic_int_least64_t *left = sched_budget(t);
    if (t->passes)
        return passes_tile(t->passes, scene, tile, pass, &dst, &t->cancel, left, rays, err);
    if (t->sums) return sched_sums_tile(t, &tr, rays, err);
    if (t->keep_exr || t->aov_mask || t->denoise)
        return resolve_render(scene, &tr, &dst, &t->cancel, left, rays, err);
    struct rayd_render_stats stats = {0};
    struct rayd_render_opts o = {
        .region = tr, .cancel = &t->cancel, .stats = &stats, .rays_left = left};
    enum rayd_status st = t->lin ? rayd_render_linear_tile(scene, &o, t->lin, t->reg.w, dx, dy, err)
                                 : rayd_render_tile(scene, &o, t->img, dx, dy, err);
    *rays += stats.rays;
    return st;
}

/* Renders the next tile of t and books it; called and returns with the
 * lock held.  *since (the worker's clock) is set while the tile runs. */
static void sched_run(struct task *t, double *since) {
    int pass, tile = task_take(t, &pass);
    sched_busy++;
    double t0 = clock_now();
    *since = t0;
    work_lock_give();

    uint64_t rays = 0;
    struct rayd_error err = {0};
    enum rayd_status st = sched_tile(t, tile, pass, &rays, &err);
    double took = clock_now() - t0;
    metrics_rays(rays);
    if (st == RAYD_OK) sched_stream_tile(t, tile);

    struct task_notify n = {0}, sse = {0};
    work_lock_take();
    *since = 0;
    struct rayd_region tr = task_tile(t, tile);
    cost_observe(t->scene_id, t->client, task_tile_rays(t, &tr, pass), took, st == RAYD_OK);
    sched_busy--;
    enum task_next next = task_tile_done(t, tile, st, &err, rays, &n, &sse);
    work_lock_give();
    if (next != TASK_GOING) sched_finalize(t, next, &n, &sse);
    task_notify_run(&n);
    task_notify_run(&sse);
    work_lock_take();
}

static void *sched_worker(void *arg) {
    double *since = arg;
    work_lock_take();
    for (;;) {
        struct task *t = sched_next_task();
        if (!t) break;
        sched_run(t, since);
    }
    work_lock_give();
    return NULL;
}

/* Whether every worker has been on its tile for over SCHED_SPARE_AFTER_S;
 * lock held. */
static bool sched_spare_due(void) {
    double before = clock_now() - SCHED_SPARE_AFTER_S;
    for (int i = 0; i < sched_nworkers; i++)
        if (!(sched_since[i] > 0 && sched_since[i] < before)) return false;
    return sched_nworkers > 0;
}

/* The spare worker (see the top): it looks every SCHED_SPARE_POLL_S while
 * it has nothing, for the workers' tiles grow old without a signal. */
static void *sched_spare(void *arg) {
    double *since = arg;
    work_lock_take();
    while (!sched_stopping) {
        struct task *t = sched_spare_due() ? task_pick_quick() : NULL;
        if (t && gate_pass()) {
            gate_count(1, 0);
            sched_run(t, since);
            continue;
        }
        struct timespec until = clock_after(SCHED_SPARE_POLL_S);
        work_timedwait(&work_cond, &until);
    }
    work_lock_give();
    return NULL;
}

/* ---- gauges (registered with metrics.c at start-up) ------------------------ */

static long sched_gauge_queued(void) {
    work_lock_take();
    long x = task_queued;
    work_lock_give();
    return x;
}

static long sched_gauge_cap(void) { return task_queue_cap; }
static long sched_gauge_workers(void) { return sched_nworkers; }
static long sched_gauge_draining(void) { return sched_draining(); }

static long sched_gauge_busy(void) {
    work_lock_take();
    long x = sched_busy;
    work_lock_give();
    return x;
}

static long sched_gauge_running(void) {
    long n = 0;
    work_lock_take();
    for (struct task *t = task_active; t; t = t->next) n += t->next_tile > 0;
    work_lock_give();
    return n;
}

/* Estimated seconds of the work queued and running, for the whole pool. */
static double sched_backlog(void);
static long sched_gauge_backlog_ms(void) { return (long)(sched_backlog() * 1e3); }

static void sched_register_gauges(void) {
    metrics_gauge(MG_BACKLOG_MS, sched_gauge_backlog_ms);
    metrics_gauge(MG_QUEUE_DEPTH, sched_gauge_queued);
    metrics_gauge(MG_QUEUE_CAPACITY, sched_gauge_cap);
    metrics_gauge(MG_TASKS_RUNNING, sched_gauge_running);
    metrics_gauge(MG_WORKERS_BUSY, sched_gauge_busy);
    metrics_gauge(MG_WORKERS, sched_gauge_workers);
    metrics_gauge(MG_DRAINING, sched_gauge_draining);
}

/* ---- start / stop ---------------------------------------------------------- */

int sched_start(int workers, int queue_cap, int max_jobs) {
    task_queue_cap = queue_cap;
    cost_set_workers(workers);
    sched_threads = calloc((size_t)workers, sizeof *sched_threads);
    sched_since = calloc((size_t)workers + 1, sizeof *sched_since); /* the spare's last */
    if (!sched_threads || !sched_since || jobs_start(max_jobs)) return -1;
    scenes_start();
    sched_register_gauges();
    for (int i = 0; i < workers; i++) {
        if (pthread_create(&sched_threads[i], NULL, sched_worker, &sched_since[i])) return -1;
        sched_nworkers++;
    }
    if (pthread_create(&sched_spare_thread, NULL, sched_spare, &sched_since[workers])) return -1;
    sched_spare_on = true;
    return watch_start();
}

void sched_stop(void) {
    work_lock_take();
    sched_stopping = true;
    pthread_cond_broadcast(&work_cond);
    work_lock_give();
    for (int i = 0; i < sched_nworkers; i++) pthread_join(sched_threads[i], NULL);
    if (sched_spare_on) pthread_join(sched_spare_thread, NULL);
    sched_spare_on = false;
    watch_stop();
    free(sched_threads);
    sched_threads = NULL;
    free(sched_since);
    sched_since = NULL;
    /* Anything left was cancelled by the drain; answer and free it. */
    struct task_notify n = {0}, sse = {0};
    work_lock_take();
    while (task_active) {
        task_abandon(task_active, &n, &sse);
        work_lock_give();
        task_notify_run(&n);
        task_notify_run(&sse);
        work_lock_take();
    }
    work_lock_give();
    jobs_stop();
    scenes_stop();
}

/* ---- synchronous renders ------------------------------------------------------ */

/* The finished PNG of (scene, what) from the result cache, referenced,
 * and the rays its render cast, or NULL.  A hit or miss is counted only
 * while the cache is on: with --result-cache-mb 0 there is nothing to look
 * in, and a miss counted for every render would read as a cache that
 * never helps. */
static struct blob *sched_result_rays(const struct cache_entry *scene,
                                      const struct work_target *what, uint64_t *rays) {
    char key[160];
    task_key(key, sizeof key, cache_version(scene), what);
    work_lock_take();
    struct blob *b = rcache_get(key, rays);
    bool on = rcache_on();
    work_lock_give();
    if (on) metrics_result_cache(b != NULL);
    return b;
}

struct blob *sched_result_find(const struct cache_entry *scene, const struct work_target *what) {
    return sched_result_rays(scene, what, NULL);
}

/* Links w to an unfinished task of the same scene, region and format, if
 * there is one.  Such a waiter costs no memory, so it joins before the
 * budget is asked: a reservation it would release at once could still
 * evict other clients' results to make room. */
static bool sched_join(struct cache_entry *scene, const struct work_target *what,
                       struct work_waiter *w) {
    char key[160];
    task_key(key, sizeof key, cache_version(scene), what);
    work_lock_take();
    struct task *t = task_draining() ? NULL : task_find(key);
    if (t) {
        metrics_coalesced();
        task_wait(t, w);
    }
    work_lock_give();
    return t != NULL;
}

enum work_submit sched_render(struct cache_entry *scene, const struct work_target *what,
                              struct work_waiter *w, struct blob **png, uint64_t *rays) {
    if ((*png = sched_result_rays(scene, what, rays))) return WORK_CACHED;
    if (sched_join(scene, what, w)) return WORK_OK;
    enum work_submit why;
    struct task *fresh = budget_task(scene, what, false, &why);
    if (!fresh) return why;
    work_lock_take();
    struct task *t = NULL;
    enum work_submit r = task_submit(scene, &fresh, &t);
    if (r == WORK_OK) task_wait(t, w);
    work_lock_give();
    if (fresh) task_unref(fresh);
    return r;
}

/* ---- lifecycle ------------------------------------------------------------------ */

void sched_drain(void) { task_drain(); }
bool sched_draining(void) { return task_draining(); }

void sched_cancel_all(void) {
    work_lock_take();
    for (;;) {
        struct task *t = task_active;
        while (t && (atomic_load(&t->cancel) || t->finished)) t = t->next;
        if (!t) break;
        struct task_notify n = {0}, sse = {0};
        task_cancel(t, MC_DRAIN, &n, &sse);
        work_lock_give();
        task_notify_run(&n);
        task_notify_run(&sse);
        work_lock_take();
    }
    work_lock_give();
}

bool sched_idle(void) {
    work_lock_take();
    bool idle = task_active == NULL;
    work_lock_give();
    return idle;
}

static double sched_backlog(void) {
    work_lock_take();
    double s = cost_seconds(task_backlog_rays());
    work_lock_give();
    return s;
}

void sched_stats(struct sched_stats *st) {
    work_lock_take();
    st->backlog_s = cost_seconds(task_backlog_rays());
    st->queued = task_queued;
    st->queue_cap = task_queue_cap;
    st->workers = sched_nworkers;
    st->busy_workers = sched_busy;
    jobs_count(&st->jobs_unfinished, &st->jobs_cap);
    work_lock_give();
}
