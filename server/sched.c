/* sched.c -- the worker pool: who renders which tile next, and the pool's
 * life from start to drain to stop.
 *
 * Scheduling is per tile, not per task: each time a worker is free it takes
 * the next tile of the task task_pick() puts first (task.c explains the
 * order), so a small interactive request overtakes a big frame at the next
 * tile boundary.  A plain PNG task is encoded as it is drawn: the worker
 * that finishes a row of its tiles deflates the PNG bands that row
 * completes (rayd_png_stream, lock released, the task still counted as
 * running so it cannot finish meanwhile), so the encoding overlaps the
 * other tiles' rendering.  The worker that finishes a task's last tile
 * encodes what is left of its PNG (or, for a 16-bit PNG or EXR task, its
 * linear floats) -- with the lock released, like the tiles -- and answers
 * everyone interested in it.
 *
 * Back-pressure: at most queue_cap tasks may wait for a worker (have tiles
 * nobody has started); beyond that a submission is refused with WORK_FULL and
 * the handler answers 503 + Retry-After.  Joining an identical task is free,
 * and a finished identical render is answered from the result cache
 * (rcache.c) without a task at all.
 *
 * Drain: task.c's flag refuses new work while what is queued finishes; the
 * deadline cancels the rest (sched_cancel_all).
 *
 * This file is the top of the work layer: it starts and stops the others
 * (caches, jobs, the watcher) and no other work file calls it.
 */
#include "work_private.h"

#include <stdlib.h>
#include <string.h>


static pthread_t *sched_threads;
static int sched_nworkers, sched_busy;
static bool sched_stopping; /* lock held: the workers end */

/* ---- workers --------------------------------------------------------------- */

/* The next task a worker should take a tile of, lock held; waits for one.
 * NULL when the pool stops.  A worker held by the test gate counts as held
 * while it waits. */
static struct task *sched_next_task(void)
{
    while (!sched_stopping) {
        struct task *t = task_pick();
        if (t && gate_pass()) {
            gate_count(1, 0);
            return t;
        }
        gate_count(0, t != NULL);
        pthread_cond_wait(&work_cond, &work_lock);
        gate_count(0, -(long)(t != NULL));
    }
    return NULL;
}

/* t's pixels in its format into *buf (a PNG stream: the bands not yet
 * deflated, and the file joined). */
static enum rayd_status sched_encode_as(struct task *t, void **buf, size_t *len,
                                        struct rayd_error *err)
{
    if (t->format == WORK_SUMS)
        return rayd_sums_encode(t->reg.w, t->reg.h, t->k0, t->k1, t->sums, buf, len, err);
    if (t->format == WORK_EXR)
        return rayd_exr_encode(t->lin, t->reg.w, t->reg.h, buf, len, err);
    if (t->format == WORK_PNG16)
        return rayd_png16_encode(t->lin, t->reg.w, t->reg.h, (int)config.png_level, buf, len,
                                 err);
    if (t->stream) {
        rayd_png_stream *s = t->stream;
        t->stream = NULL; /* finish frees it; no tile runs (running == 0), so unlocked */
        return rayd_png_stream_finish(s, 0, buf, len, NULL, err);
    }
    return rayd_png_encode(t->img, (int)config.png_level, buf, len, err);
}

/* An encoder's bytes (buf, len bytes, when *st is RAYD_OK) kept as a
 * blob; NULL when *st was not RAYD_OK, or when there is no memory for the
 * blob: then *st and err say so (what names the bytes).  Lock not held. */
static struct blob *sched_keep(enum rayd_status *st, void *buf, size_t len, struct rayd_error *err,
                               const char *what)
{
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
static struct blob *sched_exr(const struct task *t, enum rayd_status *st, struct rayd_error *err)
{
    if (!t->keep_exr || *st != RAYD_OK)
        return NULL;
    void *buf = NULL;
    size_t len = 0;
    *st = rayd_exr_encode(t->lin, t->reg.w, t->reg.h, &buf, &len, err);
    return sched_keep(st, buf, len, err, "the EXR");
}

/* Encodes t's PNG (every core: png_encode.c's bands), and its EXR when it
 * keeps one, lock released; returns with the lock held.  The tiles' and
 * the encoding's times go to the stage metrics. */
static void sched_encode(struct task *t)
{
    void *buf = NULL;
    size_t len = 0;
    struct rayd_error err = {0};
    double t0 = clock_now();
    metrics_stage(MS_RENDER, t0 - t->t_start);
    enum rayd_status st = sched_encode_as(t, &buf, &len, &err);
    struct blob *png = sched_keep(&st, buf, len, &err, "the PNG");
    struct blob *exr = sched_exr(t, &st, &err);
    double enc = clock_now() - t0;
    metrics_stage(MS_ENCODE, enc);
    pthread_mutex_lock(&work_lock);
    t->encode_s = enc;
    t->png = png;
    t->exr = exr;
    if (st != RAYD_OK)
        task_fail(t, st, &err);
}

/* Opens t's next pass, lock held: its tiles queue again.  img is the
 * image the pass's tiles draw into. */
static void sched_pass_open(struct task *t, rayd_image *img)
{
    t->img = img;
    t->passes->pass++;
    t->next_tile = 0;
    t->done = 0;
    t->finalizing = false;
    if (!t->queued) {
        t->queued = true;
        task_queued++;
    }
    pthread_cond_broadcast(&work_cond);
}

/* The pass whose last tile just finished, lock released: its noise
 * estimate and PNG, recorded (passes.c), the streams told; then the next
 * pass opened, unless it was the last or a budget or stop ends the job.
 * Returns with the lock held: true when the next pass is open. */
static bool sched_pass_close(struct task *t, struct task_notify *sse)
{
    struct passes *p = t->passes;
    double noise = passes_noise(p, t->img, p->pass);
    rayd_image *spare = NULL;
    if (!p->prev && p->pass + 1 < p->n)
        rayd_image_new(t->reg.w, t->reg.h, &spare, NULL);
    void *buf = NULL;
    size_t len = 0;
    struct rayd_error err = {0};
    enum rayd_status st = rayd_png_encode(t->img, (int)config.png_level, &buf, &len, &err);
    struct blob *png = sched_keep(&st, buf, len, &err, "the pass's PNG");
    struct blob *exr = sched_exr(t, &st, &err);
    pthread_mutex_lock(&work_lock);
    if (st != RAYD_OK) {
        task_fail(t, st, &err);
        blob_unref(png);
        rayd_image_free(spare);
        return false;
    }
    passes_complete(p, png, exr, clock_now() - t->t_start, noise);
    task_notify_add(sse, &t->sse_waiters);
    if (!passes_more(p, clock_now() - t->t_start) || atomic_load(&t->cancel)) {
        rayd_image_free(spare);
        return false;
    }
    if (!p->prev && !spare) {
        task_failf(t, RAYD_E_NOMEM, "out of memory for the next pass");
        return false;
    }
    rayd_image *next = passes_swap(p, t->img);
    sched_pass_open(t, next ? next : spare);
    if (next)
        rayd_image_free(spare);
    return true;
}

/* t's PNG stream and row counts, when t is a plain PNG task, lock held;
 * without memory, t is encoded whole at the end. */
static void sched_stream_open(struct task *t)
{
    if (t->format != WORK_PNG || t->passes || t->stream_tried)
        return;
    t->stream_tried = true;
    t->row_left = malloc((size_t)t->nty * sizeof *t->row_left);
    if (!t->row_left || rayd_png_stream_new(t->img, (int)config.png_level, &t->stream, NULL) !=
                            RAYD_OK) {
        free(t->row_left);
        t->row_left = NULL;
        return;
    }
    for (int i = 0; i < t->nty; i++)
        t->row_left[i] = t->ntx;
}

/* Tile `tile` of t is drawn: when that completes rows at the top, the
 * stream encodes the bands they finish, on this worker, lock released (t
 * cannot finish meanwhile: this worker still counts as running it).  The
 * stream is read without the lock: it was set, under the lock, before
 * this worker took its tile, and is only cleared once no tile runs.  A
 * stream's call deflates only the bands its rows complete, a band or two,
 * so the worker is soon back for tiles.  Called and returns without the
 * lock. */
static void sched_stream_tile(struct task *t, int tile)
{
    rayd_png_stream *s = t->stream;
    if (!s || atomic_load(&t->cancel))
        return;
    pthread_mutex_lock(&work_lock);
    int rows = 0, top = t->rows_top;
    if (--t->row_left[tile / t->ntx] == 0) {
        while (t->rows_top < t->nty && t->row_left[t->rows_top] == 0)
            t->rows_top++;
        if (t->rows_top > top)
            rows = t->rows_top * t->tile < t->reg.h ? t->rows_top * t->tile : t->reg.h;
    }
    pthread_mutex_unlock(&work_lock);
    if (rows > 0)
        rayd_png_stream_rows(s, rows);
}

/* Takes a tile of t, lock held. */
static void sched_take(struct task *t)
{
    sched_stream_open(t);
    if (t->t_start == 0) {
        t->t_start = clock_now();
        metrics_queue_wait(t->interactive, t->t_start - t->t_enq);
        metrics_stage(MS_QUEUE, t->t_start - t->t_enq);
    }
    if (t->next_tile == t->ntiles)
        task_unqueue(t);
    task_taken(t);
    t->running++;
    sched_busy++;
}

/* Books a rendered (or failed) tile, lock held; finishes the task when it
 * was the last one in flight.  Returns with the lock held. */
static void sched_done(struct task *t, int tile, enum rayd_status st,
                       const struct rayd_error *err, uint64_t rays, struct task_notify *n,
                       struct task_notify *sse)
{
    sched_busy--;
    t->running--;
    t->rays += rays;
    if (st == RAYD_OK) {
        t->order[t->done++] = tile;
        if (!t->passes) /* a progressive task's streams hear of passes only */
            task_notify_add(sse, &t->sse_waiters);
        if (t->passes && t->passes->plan.time_budget > 0 &&
            clock_now() - t->t_start >= t->passes->plan.time_budget)
            task_end_early(t, PASSES_BY_TIME);
    } else if (st != RAYD_E_CANCELED && t->status == RAYD_OK) {
        if (st == RAYD_E_LIMIT) /* the core's meter: the task's ray budget is spent */
            task_over_work(t);
        else
            task_fail(t, st, err);
        atomic_store(&t->cancel, 1);
        task_unqueue(t);
    }
    if (t->running > 0 || t->finalizing)
        return;
    if (t->done == t->ntiles && t->status == RAYD_OK) {
        t->finalizing = true;
        pthread_mutex_unlock(&work_lock);
        if (t->passes) {
            if (sched_pass_close(t, sse)) /* returns with the lock held */
                return;
        } else {
            sched_encode(t); /* returns with the lock held */
        }
        task_finish(t, n, sse);
    } else if (atomic_load(&t->cancel) || t->status != RAYD_OK) {
        task_finish(t, n, sse);
    }
}

/* t's ray budget (--max-work), or NULL when there is none. */
static atomic_int_least64_t *sched_budget(struct task *t)
{
    return config.max_work > 0 ? &t->rays_left : NULL;
}

/* A WORK_SUMS tile: its samples k0..k1-1 summed, into t's sums. */
static enum rayd_status sched_sums_tile(struct task *t, const struct rayd_region *tr,
                                        uint64_t *rays, struct rayd_error *err)
{
    rayd_accum *acc = NULL;
    struct rayd_render_stats stats = {0};
    struct rayd_render_opts o = {.threads = 1,
                                 .tile = tr->w > tr->h ? tr->w : tr->h,
                                 .cancel = &t->cancel,
                                 .stats = &stats,
                                 .rays_left = sched_budget(t)};
    enum rayd_status st = rayd_accum_new(cache_scene(t->scene), tr, &acc, err);
    if (st == RAYD_OK)
        st = rayd_render_sample_range(cache_scene(t->scene), &o, acc, t->k0, t->k1, err);
    *rays += stats.rays;
    const double *in = st == RAYD_OK ? rayd_accum_sums(acc) : NULL;
    for (int row = 0; in && row < tr->h; row++)
        memcpy(t->sums + ((size_t)(tr->y - t->reg.y + row) * (size_t)t->reg.w +
                          (size_t)(tr->x - t->reg.x)) * 3,
               in + (size_t)row * (size_t)tr->w * 3, (size_t)tr->w * 3 * sizeof *in);
    rayd_accum_free(acc);
    return st;
}

/* Renders tile `tile` of t (of pass `pass` if progressive), no lock.  The
 * core looks at t's cancel flag and ray budget every thousand rays or so,
 * so a cancel, a deadline or a spent budget stops the tile within
 * milliseconds whatever one pixel costs. */
static enum rayd_status sched_tile(struct task *t, int tile, int pass, uint64_t *rays,
                                   struct rayd_error *err)
{
    struct rayd_region tr = task_tile(t, tile);
    const rayd_scene *scene = cache_scene(t->scene);
    int dx = tr.x - t->reg.x, dy = tr.y - t->reg.y;
    struct resolve_dst dst = {t->img, t->keep_exr ? t->lin : NULL, t->reg.w, dx, dy};
    atomic_int_least64_t *left = sched_budget(t);
    if (t->passes)
        return passes_tile(t->passes, scene, tile, pass, &dst, &t->cancel, left, rays, err);
    if (t->sums)
        return sched_sums_tile(t, &tr, rays, err);
    if (t->keep_exr)
        return resolve_render(scene, &tr, &dst, &t->cancel, left, rays, err);
    struct rayd_render_stats stats = {0};
    struct rayd_render_opts o = {
        .region = tr, .cancel = &t->cancel, .stats = &stats, .rays_left = left};
    enum rayd_status st = t->lin
                              ? rayd_render_linear_tile(scene, &o, t->lin, t->reg.w, dx, dy, err)
                              : rayd_render_tile(scene, &o, t->img, dx, dy, err);
    *rays += stats.rays;
    return st;
}

static void *sched_worker(void *arg)
{
    (void)arg;
    pthread_mutex_lock(&work_lock);
    for (;;) {
        struct task *t = sched_next_task();
        if (!t)
            break;
        int tile = t->next_tile++, pass = t->passes ? t->passes->pass : 0;
        sched_take(t);
        pthread_mutex_unlock(&work_lock);

        uint64_t rays = 0;
        struct rayd_error err = {0};
        double t0 = clock_now();
        enum rayd_status st = sched_tile(t, tile, pass, &rays, &err);
        double took = clock_now() - t0;
        metrics_rays(rays);
        if (st == RAYD_OK)
            sched_stream_tile(t, tile);

        struct task_notify n = {0}, sse = {0};
        pthread_mutex_lock(&work_lock);
        struct rayd_region tr = task_tile(t, tile);
        cost_observe(t->scene_id, t->client, task_tile_rays(t, &tr, pass), took, st == RAYD_OK);
        sched_done(t, tile, st, &err, rays, &n, &sse);
        pthread_mutex_unlock(&work_lock);
        task_notify_run(&n);
        task_notify_run(&sse);
        pthread_mutex_lock(&work_lock);
    }
    pthread_mutex_unlock(&work_lock);
    return NULL;
}

/* ---- gauges (registered with metrics.c at start-up) ------------------------ */

static long sched_gauge_queued(void)
{
    pthread_mutex_lock(&work_lock);
    long x = task_queued;
    pthread_mutex_unlock(&work_lock);
    return x;
}

static long sched_gauge_cap(void) { return task_queue_cap; }
static long sched_gauge_workers(void) { return sched_nworkers; }
static long sched_gauge_draining(void) { return sched_draining(); }

static long sched_gauge_busy(void)
{
    pthread_mutex_lock(&work_lock);
    long x = sched_busy;
    pthread_mutex_unlock(&work_lock);
    return x;
}

static long sched_gauge_running(void)
{
    long n = 0;
    pthread_mutex_lock(&work_lock);
    for (struct task *t = task_active; t; t = t->next)
        n += t->next_tile > 0;
    pthread_mutex_unlock(&work_lock);
    return n;
}

/* Estimated seconds of the work queued and running, for the whole pool. */
static double sched_backlog(void);
static long sched_gauge_backlog_ms(void) { return (long)(sched_backlog() * 1e3); }

static void sched_register_gauges(void)
{
    metrics_gauge(MG_BACKLOG_MS, sched_gauge_backlog_ms);
    metrics_gauge(MG_QUEUE_DEPTH, sched_gauge_queued);
    metrics_gauge(MG_QUEUE_CAPACITY, sched_gauge_cap);
    metrics_gauge(MG_TASKS_RUNNING, sched_gauge_running);
    metrics_gauge(MG_WORKERS_BUSY, sched_gauge_busy);
    metrics_gauge(MG_WORKERS, sched_gauge_workers);
    metrics_gauge(MG_DRAINING, sched_gauge_draining);
}

/* ---- start / stop ---------------------------------------------------------- */

int sched_start(int workers, int queue_cap, int max_jobs)
{
    task_queue_cap = queue_cap;
    cost_set_workers(workers);
    sched_threads = calloc((size_t)workers, sizeof *sched_threads);
    if (!sched_threads || jobs_start(max_jobs))
        return -1;
    scenes_start();
    sched_register_gauges();
    for (int i = 0; i < workers; i++) {
        if (pthread_create(&sched_threads[i], NULL, sched_worker, NULL))
            return -1;
        sched_nworkers++;
    }
    return watch_start();
}

void sched_stop(void)
{
    pthread_mutex_lock(&work_lock);
    sched_stopping = true;
    pthread_cond_broadcast(&work_cond);
    pthread_mutex_unlock(&work_lock);
    for (int i = 0; i < sched_nworkers; i++)
        pthread_join(sched_threads[i], NULL);
    watch_stop();
    free(sched_threads);
    sched_threads = NULL;
    /* Anything left was cancelled by the drain; answer and free it. */
    struct task_notify n = {0}, sse = {0};
    while (task_active) {
        struct task *t = task_active;
        atomic_store(&t->cancel, 1);
        task_finish(t, &n, &sse);
        task_notify_run(&n);
        task_notify_run(&sse);
    }
    jobs_stop();
    cache_free_all();
    rcache_free_all();
}

/* ---- synchronous renders ------------------------------------------------------ */

/* The finished PNG of (scene, reg) from the result cache, referenced, or
 * NULL.  A hit or miss is counted only while the cache is on: with
 * --result-cache-mb 0 there is nothing to look in, and a miss counted for
 * every render would read as a cache that never helps. */
struct blob *sched_result_find(const struct cache_entry *scene, const struct work_target *what)
{
    char key[160];
    task_key(key, sizeof key, cache_version(scene), what);
    pthread_mutex_lock(&work_lock);
    struct blob *b = rcache_get(key);
    bool on = rcache_on();
    pthread_mutex_unlock(&work_lock);
    if (on)
        metrics_result_cache(b != NULL);
    return b;
}

/* Links w to an unfinished task of the same scene, region and format, if
 * there is one.  Such a waiter costs no memory, so it joins before the
 * budget is asked: a reservation it would release at once could still
 * evict other clients' results to make room. */
static bool sched_join(struct cache_entry *scene, const struct work_target *what,
                       struct work_waiter *w)
{
    char key[160];
    task_key(key, sizeof key, cache_version(scene), what);
    pthread_mutex_lock(&work_lock);
    struct task *t = task_draining() ? NULL : task_find(key);
    if (t) {
        metrics_coalesced();
        w->suspend(w);
        w->next = t->waiters;
        t->waiters = w;
    }
    pthread_mutex_unlock(&work_lock);
    return t != NULL;
}

enum work_submit sched_render(struct cache_entry *scene, const struct work_target *what,
                              struct work_waiter *w, struct blob **png)
{
    if ((*png = sched_result_find(scene, what)))
        return WORK_CACHED;
    if (sched_join(scene, what, w))
        return WORK_OK;
    enum work_submit why;
    struct task *fresh = budget_task(scene, what, false, &why);
    if (!fresh)
        return why;
    pthread_mutex_lock(&work_lock);
    struct task *t = NULL;
    enum work_submit r = task_submit(scene, &fresh, &t);
    if (r == WORK_OK) {
        w->suspend(w);
        w->next = t->waiters;
        t->waiters = w;
    }
    pthread_mutex_unlock(&work_lock);
    if (fresh)
        task_unref(fresh);
    return r;
}


/* ---- lifecycle ------------------------------------------------------------------ */

void sched_drain(void) { task_drain(); }
bool sched_draining(void) { return task_draining(); }

void sched_cancel_all(void)
{
    pthread_mutex_lock(&work_lock);
    for (;;) {
        struct task *t = task_active;
        while (t && (atomic_load(&t->cancel) || t->finished))
            t = t->next;
        if (!t)
            break;
        struct task_notify n = {0}, sse = {0};
        task_cancel(t, MC_DRAIN, &n, &sse);
        pthread_mutex_unlock(&work_lock);
        task_notify_run(&n);
        task_notify_run(&sse);
        pthread_mutex_lock(&work_lock);
    }
    pthread_mutex_unlock(&work_lock);
}

bool sched_idle(void)
{
    pthread_mutex_lock(&work_lock);
    bool idle = task_active == NULL;
    pthread_mutex_unlock(&work_lock);
    return idle;
}

static double sched_backlog(void)
{
    pthread_mutex_lock(&work_lock);
    double s = cost_seconds(task_backlog_rays());
    pthread_mutex_unlock(&work_lock);
    return s;
}

void sched_stats(struct sched_stats *st)
{
    pthread_mutex_lock(&work_lock);
    st->backlog_s = cost_seconds(task_backlog_rays());
    st->queued = task_queued;
    st->queue_cap = task_queue_cap;
    st->workers = sched_nworkers;
    st->busy_workers = sched_busy;
    jobs_count(&st->jobs_unfinished, &st->jobs_cap);
    pthread_mutex_unlock(&work_lock);
}
