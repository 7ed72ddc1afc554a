/* passes.c -- a progressive job's passes: the plan, the per-tile sums, the
 * images kept, the noise estimate and when to stop.
 *
 * A progressive task renders its whole region once per pass, each pass
 * adding samples to the same per-pixel sums, so the user sees the whole
 * frame after the first (one-sample) pass and watches it refine.  The core
 * guarantees the image after a pass of n samples is byte for byte the plain
 * render of n samples (rayd_render_pass, docs/scene-format.md's pass rule);
 * here each task tile keeps its own rayd_accum, so tiles of one pass run on
 * any worker in any order and the result still does not depend on timing.
 * A tile's sums (24 bytes a pixel) are made when the tile is first
 * rendered, so a queued progressive job holds no more memory than a plain
 * one, and freed when the task finishes (passes_release), so a finished job
 * kept for --job-ttl holds only its kept PNGs and EXRs.  The sums are
 * reserved in the memory budget at the job's admission (budget.c), and a
 * finished job's kept images may be let go to make room (passes_let_go).
 *
 * Passes follow one another with a barrier: the worker that completes a
 * pass's last tile encodes the pass (sched.c), records it here and only then
 * opens the next pass.  A tile of the next pass therefore never sees sums of
 * a pass being resolved, and the PNG of pass k is exactly what a plain
 * render of samples[k] gives.
 *
 * The noise estimate after a pass of n samples compares it with the
 * previous pass of m samples, on the 8-bit values shown (0..1): if the two
 * images were independent estimates of the pixel (the pass after the
 * one-sample centre image starts again from sample 0), the variance of
 * their difference is s2/n + s2/m, otherwise (the later pass contains the
 * earlier) it is s2 (n - m) / (n m); the image's own variance is s2 / n.
 * So the estimate is RMS(difference) * sqrt(m / (n + m)) or
 * RMS(difference) * sqrt(m / (n - m)): the standard error of a shown
 * value, averaged over the pixels and channels.  It depends on the images
 * only, so a noise budget stops at the same pass on every run.
 *
 * A denoised job's tiles keep denoised accumulators (the tile plus the
 * filter's apron, with the AOV sums), so pass k's image is the denoised
 * render of samples[k], and each pass is kept raw too: the tile's sums
 * unfiltered (rayd_accum_raw) go into a second image, encoded beside the
 * denoised one.  Its noise estimate is the raw images': the formula above
 * holds for independent samples, not for what the filter left of them,
 * and a noise budget then stops at the same pass with or without it.
 *
 * Everything here works on a struct passes alone; the task (task.c), the
 * scheduler (sched.c) and the jobs (jobs.c) decide when to call it.  The
 * functions marked "lock held" are called with work_lock held; the others
 * touch only what the caller owns at that moment.
 */
#include "work/work_private.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The sample count of the pass after one of s samples. */
static long passes_next(long s, int step) { return step > 0 ? s + step : 2 * s; }

int passes_plan(const struct jobs_plan *plan, int samples, int out[PASSES_MAX]) {
    int n = 0;
    if (samples < 1) samples = 1;
    for (long s = plan->step > 0 ? plan->step : 1; s < samples; s = passes_next(s, plan->step)) {
        if (n == PASSES_MAX - 1) return -1;
        out[n++] = (int)s;
    }
    out[n++] = samples;
    return n;
}

const char *passes_stop_name(enum passes_stop s) {
    static const char *const names[] = {NULL, "time_budget", "noise_target", "client", "max_work"};
    return names[s];
}

struct passes *passes_new(const rayd_scene *scene, const struct jobs_plan *plan,
                          struct rayd_region *tiles, int ntiles, bool raw, int w, int h) {
    struct passes *p = calloc(1, sizeof *p);
    if (!p) {
        free(tiles);
        return NULL;
    }
    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    p->plan = *plan;
    p->n = passes_plan(plan, info.samples, p->samples);
    p->ntiles = ntiles;
    p->tiles = tiles;
    p->acc = calloc((size_t)ntiles, sizeof *p->acc);
    if (raw && (rayd_image_new(w, h, &p->raw, NULL) != RAYD_OK ||
                rayd_image_new(w, h, &p->raw_prev, NULL) != RAYD_OK)) {
        passes_free(p);
        return NULL;
    }
    if (p->n < 1 || !p->acc) {
        passes_free(p);
        return NULL;
    }
    return p;
}

void passes_free(struct passes *p) {
    if (!p) return;
    for (int i = 0; p->acc && i < p->ntiles; i++) rayd_accum_free(p->acc[i]);
    free(p->acc);
    free(p->tiles);
    for (int i = 0; i < PASSES_KEEP; i++) {
        blob_unref(p->png[i]);
        blob_unref(p->raw_png[i]);
    }
    for (int i = 0; i < PASSES_KEEP_EXR; i++) blob_unref(p->exr[i]);
    rayd_image_free(p->prev);
    rayd_image_free(p->raw);
    rayd_image_free(p->raw_prev);
    free(p);
}

/* Lock held. */
void passes_release(struct passes *p) {
    work_assert_locked();
    for (int i = 0; p->acc && i < p->ntiles; i++) {
        rayd_accum_free(p->acc[i]);
        p->acc[i] = NULL;
    }
    rayd_image_free(p->prev);
    p->prev = NULL;
    rayd_image_free(p->raw);
    rayd_image_free(p->raw_prev);
    p->raw = p->raw_prev = NULL;
}

void passes_let_go(struct passes *p) {
    p->let_go = true; /* a pass being encoded now (sched_pass_close) is dropped too */
    for (int i = 0; i < PASSES_KEEP; i++) {
        blob_unref(p->png[i]);
        blob_unref(p->raw_png[i]);
        p->png[i] = p->raw_png[i] = NULL;
    }
    for (int i = 0; i < PASSES_KEEP_EXR; i++) {
        blob_unref(p->exr[i]);
        p->exr[i] = NULL;
    }
}

/* A tile's accumulator, made at its first pass: denoised (the tile plus
 * the filter's apron, with the AOVs) for a denoised job, keeping the AOVs
 * when the job asks for them. */
static enum rayd_status passes_accum(const rayd_scene *scene, const struct rayd_region *tile,
                                     const struct resolve_dst *dst, rayd_accum **out,
                                     struct rayd_error *err) {
    enum rayd_status st = dst->denoise ? rayd_accum_new_denoised(scene, tile, out, err)
                                       : rayd_accum_new(scene, tile, out, err);
    if (st == RAYD_OK && dst->aov_mask && !rayd_accum_has_aov(*out))
        st = rayd_accum_aov_enable(*out, err);
    if (st != RAYD_OK) {
        rayd_accum_free(*out);
        *out = NULL;
    }
    return st;
}

/* A denoised tile's raw pixels (its sums unfiltered) into p->raw, at the
 * tile's place in the task's image. */
static enum rayd_status passes_raw_tile(struct passes *p, const rayd_accum *acc,
                                        const struct resolve_dst *dst, struct rayd_error *err) {
    rayd_accum *plain = NULL;
    rayd_image *img = NULL;
    enum rayd_status st = rayd_accum_raw(acc, &plain, err);
    if (st == RAYD_OK) st = rayd_accum_image(plain, &img, err);
    if (st == RAYD_OK) st = rayd_image_blit(p->raw, img, dst->x, dst->y, err);
    rayd_image_free(img);
    rayd_accum_free(plain);
    return st;
}

enum rayd_status passes_tile(struct passes *p, const rayd_scene *scene, int tile, int pass,
                             const struct resolve_dst *dst, const atomic_int *cancel,
                             atomic_int_least64_t *rays_left, uint64_t *rays,
                             struct rayd_error *err) {
    if (!p->acc[tile]) { /* its first pass: only this worker holds the tile */
        enum rayd_status st = passes_accum(scene, &p->tiles[tile], dst, &p->acc[tile], err);
        if (st != RAYD_OK) return st;
        /* the task's flag and budget: they live as long as its tiles */
        rayd_accum_watch(p->acc[tile], cancel, rays_left);
    }
    rayd_accum *acc = p->acc[tile];
    struct rayd_region r = rayd_accum_region(acc);
    struct rayd_render_stats stats = {0};
    struct rayd_render_opts o = {.threads = 1,
                                 .tile = r.w > r.h ? r.w : r.h,
                                 .cancel = cancel,
                                 .stats = &stats,
                                 .rays_left = rays_left};
    enum rayd_status st =
        rayd_render_pass(scene, &o, acc, rayd_accum_samples(acc), p->samples[pass], err);
    *rays += stats.rays;
    if (st == RAYD_OK) st = resolve_into(acc, dst, err);
    if (st == RAYD_OK && p->raw) st = passes_raw_tile(p, acc, dst, err);
    return st;
}

/* The root mean square difference of two equal-sized images, in 0..1. */
static double passes_rms(const rayd_image *a, const rayd_image *b) {
    size_t n = (size_t)rayd_image_width(a) * (size_t)rayd_image_height(a) * 3;
    const uint8_t *x = rayd_image_pixels_const(a), *y = rayd_image_pixels_const(b);
    double sum = 0;
    for (size_t i = 0; i < n; i++) {
        double d = (double)x[i] - (double)y[i];
        sum += d * d;
    }
    return sqrt(sum / (double)n) / 255.0;
}

double passes_noise_of(const rayd_image *img, const rayd_image *prev, int n, int m) {
    bool restarted = m == 1; /* the centre image is not sample 0 of the next */
    return passes_rms(img, prev) * sqrt((double)m / (restarted ? n + m : n - m));
}

double passes_noise(const struct passes *p, const rayd_image *img, int pass) {
    const rayd_image *prev = p->raw ? p->raw_prev : p->prev;
    if (p->raw) img = p->raw; /* the samples' noise, not what the filter left of it */
    if (pass == 0 || !prev) return -1;
    return passes_noise_of(img, prev, p->samples[pass], p->samples[pass - 1]);
}

void passes_raw_done(struct passes *p) {
    rayd_image *t = p->raw;
    p->raw = p->raw_prev;
    p->raw_prev = t;
}

/* Lock held. */
void passes_complete(struct passes *p, struct blob *png, struct blob *exr, struct blob *raw,
                     double time_s, double noise) {
    work_assert_locked();
    int k = p->done++;
    if (p->let_go) { /* cancelled or evicted while this pass was encoded */
        blob_unref(png);
        blob_unref(exr);
        blob_unref(raw);
        png = exr = raw = NULL;
    }
    blob_unref(p->png[k % PASSES_KEEP]);
    p->png[k % PASSES_KEEP] = png;
    blob_unref(p->raw_png[k % PASSES_KEEP]);
    p->raw_png[k % PASSES_KEEP] = raw;
    blob_unref(p->exr[k % PASSES_KEEP_EXR]);
    p->exr[k % PASSES_KEEP_EXR] = exr;
    p->time_s[k] = time_s;
    p->noise[k] = noise;
}

/* Lock held. */
bool passes_more(struct passes *p, double elapsed) {
    work_assert_locked();
    if (p->done >= p->n) return false;
    if (p->stop == PASSES_GOING && p->plan.time_budget > 0 && elapsed >= p->plan.time_budget)
        p->stop = PASSES_BY_TIME;
    double noise = p->noise[p->done - 1];
    if (p->stop == PASSES_GOING && p->plan.noise_target > 0 && noise >= 0 &&
        noise <= p->plan.noise_target)
        p->stop = PASSES_BY_NOISE;
    return p->stop == PASSES_GOING;
}

rayd_image *passes_swap(struct passes *p, rayd_image *img) {
    rayd_image *old = p->prev;
    p->prev = img;
    return old;
}

/* Lock held. */
struct blob *passes_png(const struct passes *p, int pass) {
    work_assert_locked();
    if (pass < 1 || pass > p->done || pass <= p->done - PASSES_KEEP) return NULL;
    return p->png[(pass - 1) % PASSES_KEEP];
}

/* Lock held. */
struct blob *passes_exr(const struct passes *p, int pass) {
    work_assert_locked();
    if (pass < 1 || pass > p->done || pass <= p->done - PASSES_KEEP_EXR) return NULL;
    return p->exr[(pass - 1) % PASSES_KEEP_EXR];
}

/* Lock held. */
struct blob *passes_raw(const struct passes *p, int pass) {
    work_assert_locked();
    if (pass < 1 || pass > p->done || pass <= p->done - PASSES_KEEP) return NULL;
    return p->raw_png[(pass - 1) % PASSES_KEEP];
}

/* The samples pass k (from 0) of a plan renders. */
static int passes_added_of(const int *samples, int k) {
    return samples[k] - (k == 0 || samples[k - 1] == 1 ? 0 : samples[k - 1]);
}

int passes_added(const struct passes *p, int k) { return passes_added_of(p->samples, k); }

double passes_share(const int *samples, int n, int done, double frac) {
    double total = 0, work = 0;
    for (int k = 0; k < n; k++) {
        double cost = passes_added_of(samples, k);
        total += cost;
        if (k < done)
            work += cost;
        else if (k == done)
            work += cost * frac;
    }
    return total > 0 ? work / total : 0;
}

/* The share of the samples' work done after `done` passes and frac of the
 * next pass's tiles (a pass's work: the samples it adds or restarts). */
double passes_progress(const struct passes *p, int done, double frac) {
    return passes_share(p->samples, p->n, done, frac);
}

/* Lock held. */
void passes_info(const struct passes *p, struct jobs_passes *out) {
    work_assert_locked();
    out->done = p->done;
    out->total = p->n;
    out->samples = p->done ? p->samples[p->done - 1] : 0;
    out->samples_target = p->samples[p->n - 1];
    out->time_s = p->done ? p->time_s[p->done - 1] : 0;
    out->noise = p->done ? p->noise[p->done - 1] : -1;
    out->stopped = p->stop;
}
