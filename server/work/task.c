/* task.c -- one render: a compiled scene, a region, its tiles and who waits.
 *
 * A task is split into square tiles (sized by cost.c: 64 pixels, fewer for
 * costly scenes) rendered straight into one shared rayd_image (or, for the
 * HDR formats, one float RGB buffer): tiles are disjoint rectangles, so any
 * number of workers may fill tiles of one task at once without a lock on the
 * pixels.  Identical requests in flight -- same scene id, same region --
 * join the same task (its key), so a burst of equal tile requests renders
 * once and is answered together; joining costs no queue slot.
 *
 * Who waits: synchronous requests (t->waiters), event streams wanting news
 * (t->sse_waiters) and jobs (t->njobs, counted).  A task is cancelled when
 * its last interested party goes away, and finished -- unlinked, its PNG
 * handed to the result cache, its waiters collected on a task_notify -- when
 * the last tile is done or cancelled.  The waiters are answered by
 * task_notify_run after the lock is released (work_private.h's rule).
 *
 * Back-pressure and drain are decided here too, at the one place work is
 * admitted (task_submit): at most --queue tasks may wait for a worker, and
 * nothing new is admitted once the drain began.
 *
 * Every function here but task_new, task_drain(ing), task_notify_run and
 * the two a worker calls between tiles (task_rows_done, task_stream_take)
 * runs with work_lock held, and asserts it; this file owns the active
 * list, the queued count, the capacity, the drain flag and every field of
 * a task: the workers (sched.c) take tiles, book them and hand back what
 * they encoded through task_take, task_tile_done, task_encoded and
 * task_pass_closed, and write none of them.  What differs between the
 * output formats -- key, pixels, memory, encoder, media type -- is one row
 * of task_formats each.
 */
#include "work/work_private.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Used in this file only (task.c owns the task's state). */
static void task_unqueue(struct task *t);
static void task_taken(const struct task *t); /* a tile of t was taken (for the bulk share) */
/* t fails with st and err's message and place (the first failure stands:
 * the caller checks t->status).  task_failf: with a message of its own. */
static void task_fail(struct task *t, enum rayd_status st, const struct rayd_error *err);
static void task_failf(struct task *t, enum rayd_status st, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
/* t cast more rays than --max-work: it fails with RAYD_E_LIMIT and a
 * message naming the budget (unless it failed already). */
static void task_over_work(struct task *t);
/* The PNG stream of t, taken from it for its finish (no lock: by the
 * worker encoding t, when no tile runs), or NULL. */
static rayd_png_stream *task_stream_take(struct task *t);

/* The advice of a render stopped by a limit: the admission refusal's
 * (api_cost.c), so a client sees one message however it was stopped. */
#define TASK_ASK "ask for fewer pixels, samples, bounces or light samples"

struct task *task_active;
long task_queued;
int task_queue_cap;
static atomic_bool task_drain_flag;
static void (*task_finish_hook)(struct task *t); /* jobs.c's: a job's end to record */

void task_on_finish(void (*fn)(struct task *t)) { task_finish_hook = fn; }

/* Set under the lock, so no submission slips past it; read without. */
void task_drain(void) {
    work_lock_take();
    atomic_store(&task_drain_flag, true);
    work_lock_give();
}

bool task_draining(void) { return atomic_load(&task_drain_flag); }

/* ---- the output formats ---------------------------------------------------- */

/* A plain PNG task's stream holds the bands deflated while it was drawn. */
static enum rayd_status task_encode_png(struct task *t, void **buf, size_t *len,
                                        struct rayd_error *err) {
    rayd_png_stream *s = task_stream_take(t);
    if (s) return rayd_png_stream_finish(s, 0, buf, len, NULL, err);
    return rayd_png_encode(t->img, (int)config.png_level, buf, len, err);
}

static enum rayd_status task_encode_png16(struct task *t, void **buf, size_t *len,
                                          struct rayd_error *err) {
    return rayd_png16_encode(t->lin, t->reg.w, t->reg.h, (int)config.png_level, buf, len, err);
}

static enum rayd_status task_encode_exr(struct task *t, void **buf, size_t *len,
                                        struct rayd_error *err) {
    return rayd_exr_encode_aov(t->lin, t->aov, t->aov_mask, t->reg.w, t->reg.h, buf, len, err);
}

static enum rayd_status task_encode_sums(struct task *t, void **buf, size_t *len,
                                         struct rayd_error *err) {
    return rayd_sums_encode(t->reg.w, t->reg.h, t->k0, t->k1, t->sums, buf, len, err);
}

/* A new format is a row here (and a value of enum work_format).  Memory a
 * pixel: PNG 3 bytes and the PNG, PNG16 12 bytes of floats and 6 of PNG,
 * EXR floats and the EXR, sums 24 bytes and their 24 bytes of answer. */
static const struct task_format task_formats[] = {
    [WORK_PNG] = {"", "image/png", TASK_STORE_IMAGE, 6, 0, MEM_RESULTS, task_encode_png},
    [WORK_PNG16] = {".png16", "image/png", TASK_STORE_FLOATS, 18, 0, MEM_RESULTS,
                    task_encode_png16},
    [WORK_EXR] = {".exr", "image/x-exr", TASK_STORE_FLOATS, 24, 0, MEM_RESULTS, task_encode_exr},
    [WORK_SUMS] = {".sums", "application/x-rayd-sums", TASK_STORE_SUMS, 48, 64, MEM_SUMS,
                   task_encode_sums},
};

const struct task_format *task_format(enum work_format format) {
    server_assert((size_t)format < sizeof task_formats / sizeof task_formats[0]);
    return &task_formats[format];
}

const char *work_format_type(enum work_format format) { return task_format(format)->type; }

/* The PNG's key is the one it always had; the other formats add a suffix,
 * so an EXR never answers a PNG request from the caches, nor the reverse.
 * A job's PNG with its EXR (keep_exr) adds "+exr": a PNG-only task has no
 * floats for it to join. */
void task_key(char *key, size_t size, const char *id, const struct work_target *what) {
    const struct rayd_region *reg = &what->reg;
    int n = snprintf(key, size, "%s@%d,%d,%d,%d%s%s", id, reg->x, reg->y, reg->w, reg->h,
                     task_format(what->format)->key_suffix, what->keep_exr ? "+exr" : "");
    if (what->format == WORK_SUMS && n > 0 && (size_t)n < size)
        snprintf(key + n, size - (size_t)n, "%d-%d%s", what->k0, what->k1, what->centre ? "c" : "");
    else if (what->aov && n > 0 && (size_t)n < size) /* render/aov.c: other pixels */
        n += snprintf(key + n, size - (size_t)n, "+aov%u", what->aov);
    if (what->denoise && n > 0 && (size_t)n < size) snprintf(key + n, size - (size_t)n, "+dn");
}

/* The task's pixel store: bytes for the PNG (and linear floats beside
 * them for keep_exr), linear floats for the HDR formats, sums for
 * WORK_SUMS. */
static bool task_pixels(struct task *t) {
    size_t values = (size_t)t->reg.w * (size_t)t->reg.h * 3;
    if ((t->format == WORK_EXR || t->keep_exr) && t->aov_mask &&
        !(t->aov = malloc(values / 3 * RAYD_AOV_FLOATS * sizeof *t->aov)))
        return false;
    switch (task_format(t->format)->store) {
    case TASK_STORE_IMAGE:
        if (t->keep_exr && !(t->lin = malloc(values * sizeof *t->lin))) return false;
        return rayd_image_new(t->reg.w, t->reg.h, &t->img, NULL) == RAYD_OK;
    case TASK_STORE_SUMS: return (t->sums = malloc(values * sizeof *t->sums)) != NULL;
    case TASK_STORE_FLOATS:
    default: t->lin = malloc(values * sizeof *t->lin); return t->lin != NULL;
    }
}

/* The test gate's ray budget for new tasks (task_gate_work), -1: none. */
static atomic_long task_test_work = -1;

void task_gate_work(long rays) { atomic_store(&task_test_work, rays); }

/* The rays a new task may cast: --max-work, or the test gate's; 0: no limit. */
static long task_work_budget(void) {
    long w = atomic_load(&task_test_work);
    if (w >= 0) return w > 0 ? w : 1;
    return config.max_work > 0 ? config.max_work : 0;
}

struct task *task_new(struct cache_entry *scene, const struct work_target *what) {
    struct task *t = calloc(1, sizeof *t);
    if (!t) return NULL;
    const struct rayd_region *reg = &what->reg;
    t->reg = *reg;
    t->format = what->format;
    t->keep_exr = what->format == WORK_PNG && what->keep_exr;
    t->aov_mask = what->aov;
    t->denoise = what->denoise;
    t->k0 = what->k0;
    t->k1 = what->k1;
    t->centre = what->centre && what->k0 == 0 && what->k1 == 1;
    const rayd_scene *rs = cache_scene(scene);
    struct rayd_scene_info info;
    rayd_scene_info(rs, &info);
    t->rays_per_sample = info.rays_per_sample;
    t->est_rays = cost_rays(rs, what);
    t->tile = cost_task_tile(rs, what);
    t->client = what->client;
    t->ntx = (reg->w + t->tile - 1) / t->tile;
    t->nty = (reg->h + t->tile - 1) / t->tile;
    t->ntiles = t->ntx * t->nty;
    t->order = calloc((size_t)t->ntiles, sizeof *t->order);
    if (!t->order || !task_pixels(t)) {
        free(t->order);
        free(t->lin);
        free(t->aov);
        free(t);
        return NULL;
    }
    snprintf(t->scene_id, sizeof t->scene_id, "%s", cache_id(scene));
    task_key(t->key, sizeof t->key, cache_version(scene), what);
    atomic_init(&t->cancel, 0);
    t->work = task_work_budget();
    atomic_init(&t->rays_left, (int_least64_t)t->work);
    t->interactive = (long)reg->w * reg->h <= TASK_INTERACTIVE;
    t->status = RAYD_OK;
    t->refs = 1;
    return t;
}

/* The pixels and their encoder: freed when the task finishes, since
 * nobody reads them after (a job keeps only the PNG and its counts). */
static void task_free_pixels(struct task *t) {
    rayd_png_stream_free(t->stream); /* before its image */
    t->stream = NULL;
    rayd_rows_free(t->rows);
    t->rows = NULL;
    rayd_image_free(t->img);
    t->img = NULL;
    free(t->lin);
    t->lin = NULL;
    free(t->aov);
    t->aov = NULL;
    free(t->sums);
    t->sums = NULL;
    mem_release(t->mem_kind, t->mem); /* budget.c's reservation */
    t->mem = 0;
}

void task_unref(struct task *t) {
    server_assert(t->refs > 0);
    if (--t->refs > 0) return;
    blob_unref(t->png);
    blob_unref(t->exr);
    task_free_pixels(t);
    passes_free(t->passes);
    cache_release(t->scene);
    free(t->order);
    free(t);
}

void task_times(const struct task *t, double now, double *queue_ms, double *render_ms) {
    bool started = t->t_start > 0;
    *queue_ms = ((started ? t->t_start : now) - t->t_enq) * 1e3;
    *render_ms = started ? ((t->finished ? t->t_end : now) - t->t_start) * 1e3 : 0;
}

static void task_unqueue(struct task *t) {
    work_assert_locked();
    if (t->queued) {
        server_assert(task_queued > 0);
        t->queued = false;
        task_queued--;
    }
}

struct task *task_find(const char *key) {
    work_assert_locked();
    for (struct task *t = task_active; t; t = t->next)
        if (!t->finalizing && !atomic_load(&t->cancel) && !strcmp(t->key, key)) return t;
    return NULL;
}

/* Two classes, each served client by client (fair.c: the client served
 * least recently first, then that client's oldest task): interactive
 * tasks (previews, tiles, small regions) and bulk ones.  An interactive
 * task gets the next free worker whatever the age of the bulk backlog -- so
 * a small request waits at most one bulk tile -- except that when both
 * classes wait, every TASK_BULK_EVERY-th tile goes to bulk work, so a
 * stream of small requests cannot starve a frame either.  (An older rule
 * let a bulk task queued 2 s before a small one win every tile until it
 * finished, which with big path-traced jobs meant hours.) */
static int task_interactive_streak; /* interactive tiles taken while bulk waited */

static bool task_waiting(const struct task *t) {
    return t->next_tile < t->ntiles && !atomic_load(&t->cancel) && !t->finalizing;
}

/* Does t's turn come before u's (u may be NULL)? */
static bool task_before(const struct task *t, uint64_t t_last, const struct task *u,
                        uint64_t u_last) {
    if (!u) return true;
    if (t_last != u_last) return t_last < u_last;
    return t->t_enq < u->t_enq;
}

/* The task of t's client and class that goes first by the client's own
 * order: the highest priority (POST /v1/jobs?priority=), then the oldest.
 * The client and class were chosen by the fair rule before, so a priority
 * orders a client's own work and never moves it ahead of another client. */
static struct task *task_own_first(struct task *t) {
    struct task *best = t;
    for (struct task *u = task_active; u; u = u->next)
        if (u->client == t->client && u->interactive == t->interactive && task_waiting(u) &&
            (u->priority > best->priority ||
             (u->priority == best->priority && u->t_enq < best->t_enq)))
            best = u;
    return best;
}

struct task *task_pick(void) {
    work_assert_locked();
    struct task *first[2] = {NULL, NULL}; /* [interactive] */
    uint64_t last[2] = {0, 0};
    for (struct task *t = task_active; t; t = t->next) {
        if (!task_waiting(t)) continue;
        uint64_t l = fair_last(t->client);
        int c = t->interactive;
        if (task_before(t, l, first[c], last[c])) {
            first[c] = t;
            last[c] = l;
        }
    }
    if (first[1] && first[0] && task_interactive_streak >= TASK_BULK_EVERY - 1)
        return task_own_first(first[0]);
    return first[1] ? task_own_first(first[1]) : first[0] ? task_own_first(first[0]) : NULL;
}

struct task *task_pick_quick(void) {
    work_assert_locked();
    struct task *first = NULL;
    uint64_t last = 0;
    for (struct task *t = task_active; t; t = t->next) {
        if (!t->interactive || t->passes || !task_waiting(t) ||
            !cost_tile_quick(t->scene_id, t->est_rays / t->ntiles))
            continue;
        uint64_t l = fair_last(t->client);
        if (task_before(t, l, first, last)) first = t, last = l;
    }
    return first;
}

static void task_taken(const struct task *t) {
    work_assert_locked();
    fair_served(t->client);
    bool bulk_waits = false;
    for (const struct task *u = task_active; u && !bulk_waits; u = u->next)
        bulk_waits = !u->interactive && task_waiting(u);
    if (!t->interactive || !bulk_waits)
        task_interactive_streak = 0;
    else
        task_interactive_streak++;
}

/* Whether client may not take a place in the queue now: the last quarter
 * of it (TASK_QUEUE_KEPT) is kept for the clients with few renders queued
 * (under an eighth of the queue), so that one client's flood of jobs
 * cannot fill it and turn every other client away with 503.  One client
 * alone may queue three quarters of --queue. */
#define TASK_QUEUE_KEPT(cap) ((cap) / 4)
static bool task_queue_kept(uint64_t client) {
    long kept = TASK_QUEUE_KEPT(task_queue_cap), own = 0, few = kept / 2 > 1 ? kept / 2 : 1;
    if (task_queued < task_queue_cap - kept) return false;
    for (const struct task *t = task_active; t && own < few; t = t->next)
        own += t->queued && t->client == client;
    return own >= few;
}

enum work_submit task_submit(struct cache_entry *scene, struct task **fresh, struct task **out) {
    work_assert_locked();
    if (task_draining()) return WORK_DRAINING;
    struct task *t = task_find((*fresh)->key); /* scene, region and format */
    if (t) {
        metrics_coalesced();
        *out = t;
        return WORK_OK;
    }
    if (task_queued >= task_queue_cap && !(*fresh)->restored) return WORK_FULL;
    if (!(*fresh)->restored && task_queue_kept((*fresh)->client)) return WORK_FULL_SHARE;
    t = *fresh;
    *fresh = NULL;
    t->scene = cache_ref(scene);
    t->t_enq = clock_now();
    t->queued = true;
    task_queued++;
    t->next = task_active;
    task_active = t;
    pthread_cond_broadcast(&work_cond);
    *out = t;
    return WORK_OK;
}

struct rayd_region task_tile(const struct task *t, int tile) {
    int tx = tile % t->ntx, ty = tile / t->ntx;
    struct rayd_region r = {t->reg.x + tx * t->tile, t->reg.y + ty * t->tile, t->tile, t->tile};
    if (r.x + r.w > t->reg.x + t->reg.w) r.w = t->reg.x + t->reg.w - r.x;
    if (r.y + r.h > t->reg.y + t->reg.h) r.h = t->reg.y + t->reg.h - r.y;
    return r;
}

double task_tile_rays(const struct task *t, const struct rayd_region *r, int pass) {
    double samples = t->format == WORK_SUMS ? t->k1 - t->k0 : 0;
    if (t->passes) {
        samples = passes_added(t->passes, pass);
    } else if (t->format != WORK_SUMS) {
        double pixels = (double)t->reg.w * t->reg.h;
        return pixels > 0 ? t->est_rays * ((double)r->w * r->h) / pixels : 0;
    }
    return (double)r->w * r->h * samples * t->rays_per_sample;
}

/* What is left of t, as a fraction of its estimate: its tiles not done;
 * a progressive task's passes to come too. */
static double task_left(const struct task *t) {
    double frac = t->ntiles ? (double)t->done / t->ntiles : 1;
    if (t->passes) frac = passes_progress(t->passes, t->passes->done, frac);
    return frac < 1 ? 1 - frac : 0;
}

double task_backlog_rays(void) {
    work_assert_locked();
    double rays = 0;
    for (const struct task *t = task_active; t; t = t->next)
        if (!t->finished && !atomic_load(&t->cancel))
            rays += t->est_rays * task_left(t) * cost_scene_weight(t->scene_id);
    return rays;
}

/* ---- a worker's tiles ------------------------------------------------------- */

void task_wait_news(struct task *t, struct work_waiter *w) {
    work_assert_locked();
    w->suspend(w); /* before the waiter is linked (work_private.h) */
    w->next = t->sse_waiters;
    t->sse_waiters = w;
}

void task_job_ref(struct task *t) {
    work_assert_locked();
    t->refs++;
    t->njobs++;
}

void task_raise_priority(struct task *t, int priority) {
    if (priority > t->priority) t->priority = priority;
}

void task_admitted(struct task *t, int priority) {
    t->restored = true;
    t->priority = priority;
}

void task_job_drop(struct task *t) {
    work_assert_locked();
    server_assert(t->njobs > 0);
    t->njobs--;
}

void task_progressive(struct task *t, struct passes *p, const char *id) {
    t->passes = p;
    size_t n = strlen(t->key);
    snprintf(t->key + n, sizeof t->key - n, "~%s", id);
}

size_t task_let_go_images(struct task *t) {
    work_assert_locked();
    size_t bytes = (t->png ? t->png->len : 0) + (t->exr ? t->exr->len : 0);
    blob_unref(t->png);
    blob_unref(t->exr);
    t->png = t->exr = NULL;
    return bytes;
}

void task_evicted(struct task *t) {
    work_assert_locked();
    if (t->passes) passes_let_go(t->passes);
    t->evicted = true;
}

void task_hold(struct task *t, size_t bytes, enum mem_kind kind) {
    t->mem = bytes;
    t->mem_kind = kind;
}

void task_wait(struct task *t, struct work_waiter *w) {
    work_assert_locked();
    w->suspend(w);
    w->next = t->waiters;
    t->waiters = w;
}

/* t's PNG stream and row tracker, when t is a plain PNG task, lock held;
 * without memory, t is encoded whole at the end. */
static void task_stream_open(struct task *t) {
    work_assert_locked();
    if (t->format != WORK_PNG || t->passes || t->stream_tried) return;
    t->stream_tried = true;
    t->rows = rayd_rows_new(t->ntx, t->nty, t->tile, t->reg.h);
    if (!t->rows ||
        rayd_png_stream_new(t->img, (int)config.png_level, &t->stream, NULL) != RAYD_OK) {
        rayd_rows_free(t->rows);
        t->rows = NULL;
    }
}

int task_take(struct task *t, int *pass) {
    work_assert_locked();
    server_assert(t->next_tile < t->ntiles);
    int tile = t->next_tile++;
    *pass = t->passes ? t->passes->pass : 0;
    task_stream_open(t);
    if (t->t_start == 0) {
        t->t_start = clock_now();
        metrics_queue_wait(t->interactive, t->t_start - t->t_enq);
        metrics_stage(MS_QUEUE, t->t_start - t->t_enq);
    }
    if (t->next_tile == t->ntiles) task_unqueue(t);
    task_taken(t);
    t->running++;
    return tile;
}

int task_rows_done(struct task *t, int tile) {
    if (!t->stream || atomic_load(&t->cancel)) return 0;
    return rayd_rows_tile_done(t->rows, tile / t->ntx);
}

static rayd_png_stream *task_stream_take(struct task *t) {
    server_assert(t->running == 0);
    rayd_png_stream *s = t->stream;
    t->stream = NULL; /* finish frees it */
    return s;
}

enum task_next task_tile_done(struct task *t, int tile, enum rayd_status st,
                              const struct rayd_error *err, uint64_t rays, struct task_notify *n,
                              struct task_notify *sse) {
    work_assert_locked();
    server_assert(t->running > 0);
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
        if (st == RAYD_E_LIMIT && t->passes && t->passes->done > 0)
            task_end_early(t, PASSES_BY_WORK); /* keep the latest pass, as the deadline does */
        else if (st == RAYD_E_LIMIT) /* the core's meter: the task's ray budget is spent */
            task_over_work(t);
        else
            task_fail(t, st, err);
        atomic_store(&t->cancel, 1);
        task_unqueue(t);
    }
    if (t->running > 0 || t->finalizing) return TASK_GOING;
    if (t->done == t->ntiles && t->status == RAYD_OK) {
        t->finalizing = true; /* no other worker finishes it meanwhile */
        return t->passes ? TASK_PASS_END : TASK_ENCODE;
    }
    if (atomic_load(&t->cancel) || t->status != RAYD_OK) task_finish(t, n, sse);
    return TASK_GOING;
}

void task_encoded(struct task *t, const struct task_out *o, struct task_notify *n,
                  struct task_notify *sse) {
    work_assert_locked();
    server_assert(t->finalizing);
    t->encode_s = o->encode_s;
    t->png = o->png;
    t->exr = o->exr;
    if (o->st != RAYD_OK) task_fail(t, o->st, &o->err);
    task_finish(t, n, sse);
}

/* Opens t's next pass, lock held: its tiles queue again.  img is the
 * image the pass's tiles draw into. */
static void task_pass_open(struct task *t, rayd_image *img) {
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

/* The pass closed, recorded; true when the next one is open. */
static bool task_pass_next(struct task *t, const struct task_out *o, struct task_notify *sse) {
    struct passes *p = t->passes;
    if (o->st != RAYD_OK) {
        task_fail(t, o->st, &o->err);
        blob_unref(o->png);
        blob_unref(o->exr);
        blob_unref(o->raw);
        rayd_image_free(o->spare);
        return false;
    }
    passes_complete(p, o->png, o->exr, o->raw, clock_now() - t->t_start, o->noise);
    task_notify_add(sse, &t->sse_waiters);
    if (!passes_more(p, clock_now() - t->t_start) || atomic_load(&t->cancel)) {
        rayd_image_free(o->spare);
        return false;
    }
    if (!p->prev && !o->spare) {
        task_failf(t, RAYD_E_NOMEM, "out of memory for the next pass");
        return false;
    }
    rayd_image *next = passes_swap(p, t->img);
    task_pass_open(t, next ? next : o->spare);
    if (next) rayd_image_free(o->spare);
    return true;
}

bool task_pass_closed(struct task *t, const struct task_out *o, struct task_notify *n,
                      struct task_notify *sse) {
    work_assert_locked();
    server_assert(t->finalizing && t->passes);
    if (task_pass_next(t, o, sse)) return true;
    task_finish(t, n, sse);
    return false;
}

/* ---- answering ------------------------------------------------------------- */

void task_notify_add(struct task_notify *n, struct work_waiter **from) {
    while (*from) {
        struct work_waiter *w = *from;
        *from = w->next;
        w->next = n->list;
        n->list = w;
    }
}

bool task_unwait(struct task *t, struct work_waiter *w, struct task_notify *gone,
                 struct task_notify *n, struct task_notify *sse) {
    work_assert_locked();
    struct work_waiter **lists[2] = {&t->waiters, &t->sse_waiters};
    for (int i = 0; i < 2; i++)
        for (struct work_waiter **pp = lists[i]; *pp; pp = &(*pp)->next)
            if (*pp == w) {
                *pp = w->next;
                w->next = gone->list;
                gone->list = w;
                if (!t->waiters && t->njobs == 0) task_cancel(t, MC_CLIENT_GONE, n, sse);
                return true;
            }
    return false;
}

void task_notify_run(struct task_notify *n) {
    work_assert_unlocked();
    struct work_waiter *w = n->list;
    n->list = NULL;
    while (w) {
        struct work_waiter *next = w->next;
        struct work_result r = n->res;
        blob_ref(r.png);
        w->next = NULL;
        w->done(w, &r);
        w = next;
    }
    blob_unref(n->res.png);
    blob_unref(n->res.exr); /* lent to each done() */
    n->res.png = n->res.exr = NULL;
}

static void task_result(const struct task *t, struct work_result *res) {
    memset(res, 0, sizeof *res);
    res->status = t->status;
    res->err = t->err;
    /* the reason travels with the answer: the layers above need not ask */
    res->draining = t->status == RAYD_E_CANCELED && task_draining();
    if (t->status == RAYD_OK && t->png) res->png = blob_ref(t->png);
    if (t->status == RAYD_OK && t->png && t->exr) res->exr = blob_ref(t->exr);
    res->times.queue_ms = t->t_start > 0 ? (t->t_start - t->t_enq) * 1e3 : 0;
    res->times.render_ms = t->t_start > 0 && t->t_end > 0 ? (t->t_end - t->t_start) * 1e3 : 0;
    res->times.encode_ms = t->encode_s * 1e3;
    res->rays = t->rays;
}

/* A progressive task ends with its latest complete pass as its image: after
 * its last pass, or stopped early (a budget, the client) once it has one. */
static void task_keep_pass(struct task *t) {
    const struct passes *p = t->passes;
    if (!p || t->png || t->status != RAYD_OK || p->done == 0 ||
        (p->done < p->n && p->stop == PASSES_GOING))
        return;
    t->png = blob_ref(passes_png(p, p->done));
    t->exr = blob_ref(passes_exr(p, p->done));
}

/* Takes t off the active list. */
static void task_unlink(struct task *t) {
    for (struct task **pp = &task_active; *pp; pp = &(*pp)->next)
        if (*pp == t) {
            *pp = t->next;
            return;
        }
}

bool task_end_early(struct task *t, enum passes_stop why) {
    work_assert_locked();
    struct passes *p = t->passes;
    if (!p || t->finished) return false;
    if (p->stop == PASSES_GOING) p->stop = why;
    if (p->done == 0) /* the first pass ends it */
        return false;
    atomic_store(&t->cancel, 1); /* the pass in flight stops within a tile */
    task_unqueue(t);
    return t->running == 0 && !t->finalizing;
}

static void task_over_work(struct task *t) {
    work_assert_locked();
    if (t->status != RAYD_OK) return;
    task_failf(t, RAYD_E_LIMIT,
               "the render cast more than the server's budget of %ld rays (--max-work) and was "
               "stopped (its estimate was %.3g rays; objects tested past 64 a ray and CSG point "
               "tests count as rays); " TASK_ASK,
               t->work, t->est_rays);
}

bool task_past_deadline(struct task *t, double now, long limit, struct task_notify *n,
                        struct task_notify *sse) {
    work_assert_locked();
    if (limit <= 0 || t->t_start <= 0 || t->finished || t->finalizing || atomic_load(&t->cancel) ||
        now - t->t_start < (double)limit)
        return false;
    if (t->passes && t->passes->done > 0) { /* keep the latest pass, as a time budget */
        if (task_end_early(t, PASSES_BY_TIME)) task_finish(t, n, sse);
        return true;
    }
    task_failf(t, RAYD_E_LIMIT,
               "the render ran past the server's limit of %ld s (--max-render-seconds) and was "
               "stopped (its estimate was %.3g rays); " TASK_ASK,
               limit, t->est_rays);
    task_cancel(t, MC_DEADLINE, n, sse);
    return true;
}

static void task_fail(struct task *t, enum rayd_status st, const struct rayd_error *err) {
    work_assert_locked();
    t->status = st;
    t->err = *err;
    t->err.code = st;
}

static void task_failf(struct task *t, enum rayd_status st, const char *fmt, ...) {
    struct rayd_error err = {0};
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err.message, sizeof err.message, fmt, ap);
    va_end(ap);
    task_fail(t, st, &err);
}

void task_finish(struct task *t, struct task_notify *n, struct task_notify *sse) {
    work_assert_locked();
    t->finished = true;
    t->t_end = clock_now();
    task_keep_pass(t);
    if (t->status == RAYD_OK && !t->png) t->status = RAYD_E_CANCELED;
    if (t->status == RAYD_E_CANCELED && !t->err.message[0])
        task_failf(t, RAYD_E_CANCELED, "the render was cancelled");
    if (t->status == RAYD_OK && t->t_start > 0) metrics_render(t->t_end - t->t_start);
    double queue_ms, render_ms;
    task_times(t, t->t_end, &queue_ms, &render_ms);
    /* --log-level debug only: written under work_lock, so never on by default */
    log_debug("render %s finished: %s, queued %.3f ms, rendered %.3f ms", t->key,
              t->status == RAYD_OK ? "ok" : t->err.message, queue_ms, render_ms);
    if (t->status == RAYD_OK && t->png && !t->passes && !t->keep_exr) /* a job's: no one asks */
        rcache_put(t->key, t->png, t->rays);
    task_unqueue(t);
    task_free_pixels(t); /* NULL once finished: a job's reads see none */
    /* the sums too: a kept job holds its images only */
    if (t->passes) passes_release(t->passes);
    cache_release(t->scene);
    t->scene = NULL;
    if (t->njobs > 0 && task_finish_hook) task_finish_hook(t);
    task_result(t, &n->res);
    task_notify_add(n, &t->waiters);
    task_notify_add(sse, &t->sse_waiters);
    task_unlink(t);
    task_unref(t);
}

void task_abandon(struct task *t, struct task_notify *n, struct task_notify *sse) {
    work_assert_locked();
    atomic_store(&t->cancel, 1);
    task_finish(t, n, sse);
}

/* Raises the atomic flag the core's meters look at, so a cancelled task
 * stops within milliseconds, inside its tile; finishes it now if no worker
 * is inside it. */
void task_cancel(struct task *t, enum metrics_cancel why, struct task_notify *n,
                 struct task_notify *sse) {
    work_assert_locked();
    if (t->finished || atomic_load(&t->cancel)) return;
    atomic_store(&t->cancel, 1);
    metrics_cancel(why);
    static const char *const whys[MC__COUNT] = {"client gone", "job deleted", "drain",
                                                "past --max-render-seconds"};
    log_info("render %s cancelled (%s)", t->key, whys[why]);
    task_unqueue(t);
    if (t->running == 0 && !t->finalizing) task_finish(t, n, sse);
}
