/* budget.c -- a render's admission into the one memory budget.
 *
 * A render holds memory from its admission to its end that no scene text
 * shows: its pixels (8-bit, or linear floats for the HDR formats), the
 * per-pixel sums of a sums answer or of a progressive job (24 bytes a
 * pixel), and then the encoded answer (a 4096 x 4096 sums answer is a 402 MB
 * blob); a denoised render's tiles also hold the filter's apron and buffers.  So before a task is
 * made, what it will hold is reserved whole in the memory budget (--max-memory, mem.c): a render
 * alone over the budget is refused 413 (WORK_TOO_BIG), one with no room now 503 with Retry-After
 * (WORK_MEMORY), after the reclaimer evicted what it could.  The
 * reservation is the task's (t->mem) and is released when its pixels are
 * freed (task.c, when it finishes); the encoded blobs are counted on their
 * own from their making (blob.c) for as long as a job or a cache keeps them.
 *
 * Called with no lock held (the reclaimer takes work_lock).
 */
#include "work/work_private.h"

/* The client whose memory this thread reserves (a render's, a parse's):
 * the reclaimer (jobs.c) lets go of that client's own finished images
 * first, and of another's only as its rule allows.  Unbound, a
 * reservation is no client's (an image's blob, a cluster's assembly) and
 * may let go of any image. */
static _Thread_local uint64_t budget_client;
static _Thread_local bool budget_bound;

void budget_bind(uint64_t client) {
    budget_client = client;
    budget_bound = true;
}

void budget_unbind(void) { budget_bound = false; }

bool budget_reserve(uint64_t client, enum mem_kind kind, size_t n) {
    budget_bind(client);
    bool room = mem_reserve(kind, n);
    budget_unbind();
    return room;
}

bool budget_admitting(uint64_t *client) {
    *client = budget_client;
    return budget_bound;
}

/* What the denoiser adds to a task rendering what of scene: each tile in
 * flight (one a worker at most) holds its sums with the filter's apron
 * around it and, while it resolves, the filter's buffers (the core's
 * rayd_accum_denoised_bytes, for a tile where the apron fits whole); a
 * progressive job keeps every tile's apron'd sums from pass to pass, and
 * each pass raw too (two images, the kept raw PNGs). */
static size_t budget_denoise(const rayd_scene *scene, const struct work_target *what,
                             bool progressive) {
    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    int side = cost_task_tile(scene, what), w = what->reg.w, h = what->reg.h;
    struct rayd_region tile = {0, 0, side < w ? side : w, side < h ? side : h};
    tile.x = (info.width - tile.w) / 2; /* the apron is clipped at the image's edges */
    tile.y = (info.height - tile.h) / 2;
    size_t held, peak;
    rayd_accum_denoised_bytes(scene, &tile, &held, &peak);
    size_t ntiles = (size_t)((w + side - 1) / side) * (size_t)((h + side - 1) / side);
    size_t flying = (size_t)cost_worker_count() + 1; /* the spare worker's too (sched.c) */
    if (flying > ntiles) flying = ntiles;
    size_t n = flying * (held + peak);
    if (progressive) n += (ntiles - flying) * held + (size_t)w * (size_t)h * 3 * (2 + PASSES_KEEP);
    return n;
}

/* An EXR of px pixels in h rows at its largest: uncompressed (noise,
 * core/codec/exr.c), 12 bytes a pixel, an 8-byte offset a row, its
 * header. */
static size_t budget_exr(size_t px, size_t h) { return px * 12 + h * 8 + 1024; }

/* The bytes a task rendering what of scene will hold (its pixels or sums,
 * its answer; a progressive job's sums and passes; the denoiser's) and
 * their kind. */
static size_t budget_bytes(const rayd_scene *scene, const struct work_target *what,
                           bool progressive, enum mem_kind *kind) {
    size_t px = (size_t)what->reg.w * (size_t)what->reg.h;
    /* the store (8-bit pixels, linear floats or sums), then the answer
     * (a PNG at worst about as large as its pixels) */
    const struct task_format *f = task_format(what->format);
    size_t n = px * f->px_bytes + f->extra;
    size_t rows = (size_t)what->reg.h;
    if (f->store == TASK_STORE_IMAGE && what->keep_exr)
        n += px * 12 + budget_exr(px, rows); /* linear floats, then the EXR */
    if (what->aov) /* AOV floats and channels (an EXR), a tile's AOV sums */
        n += px * 2 * RAYD_AOV_FLOATS * sizeof(float);
    if (progressive) /* the passes' sums, the last pass's image, the passes kept */
        n += px * (24 + 3 + 3 * PASSES_KEEP) +
             (what->keep_exr ? budget_exr(px, rows) * PASSES_KEEP_EXR : 0);
    if (what->denoise) n += budget_denoise(scene, what, progressive);
    *kind = progressive ? MEM_SUMS : f->mem_kind;
    return n + 4096;
}

size_t budget_need(const struct cache_entry *scene, const struct work_target *what,
                   bool progressive) {
    enum mem_kind kind;
    return budget_bytes(cache_scene(scene), what, progressive, &kind);
}

struct task *budget_task(struct cache_entry *scene, const struct work_target *what,
                         bool progressive, enum work_submit *why) {
    work_assert_unlocked();
    enum mem_kind kind;
    size_t n = budget_bytes(cache_scene(scene), what, progressive, &kind);
    if (!budget_reserve(what->client, kind, n)) {
        metrics_reject(MR_MEMORY);
        *why = n > mem_limit() ? WORK_TOO_BIG : WORK_MEMORY;
        return NULL;
    }
    struct task *t = task_new(scene, what);
    if (!t) {
        mem_release(kind, n);
        *why = WORK_NOMEM;
        return NULL;
    }
    task_hold(t, n, kind);
    *why = WORK_OK;
    return t;
}
