/* resolve.c -- a tile's sums into a task's pixels: the 8-bit image and,
 * for a job that keeps an EXR (POST /v1/jobs?format=exr), linear floats.
 *
 * A job asked for an EXR must answer both its 8-bit PNG (image.png, the
 * preview, a progressive job's noise estimate) and the EXR of the very
 * same samples.  Rendering twice would double the work, and the 8-bit
 * bytes cannot be made from the floats (a float's rounding of the average
 * may cross an sRGB step), so both come from one set of per-pixel sums
 * (rayd_accum): rayd_accum_image gives the bytes a plain render gives,
 * rayd_accum_linear the floats a plain render in EXR gives (both scale the
 * double sum by 1 / n, as render.c's plain renders do: the pass rule).  So
 * the job's EXR holds exactly what POST /v1/render?format=exr holds for
 * the same scene and sample count, whatever the tiling or threads.
 *
 * AOVs (POST /v1/render?aov=) come from the same sums: an EXR task keeps
 * their floats beside the linear RGB, a PNG task's 8-bit image shows the
 * one AOV asked instead of the light.
 *
 * A denoised task (?denoise=1) renders each tile into a denoised
 * accumulator: the tile plus the filter's apron, filtered, cut back to
 * the tile; so its tiles join into the denoised whole frame, whatever the
 * tiling (core/render/accum_denoise.c).
 *
 * The tiles of one task are disjoint, so workers resolve into the shared
 * image and float buffer without a lock; nothing here touches the lock.
 */
#include "work/work_private.h"

#include <string.h>

/* acc's linear values into rows of d->lin at (d->x, d->y). */
static enum rayd_status resolve_linear(const rayd_accum *acc, const struct resolve_dst *d,
                                       struct rayd_error *err) {
    float *f = NULL;
    enum rayd_status st = rayd_accum_linear(acc, &f, err);
    if (st != RAYD_OK) return st;
    struct rayd_region r = rayd_accum_region(acc);
    size_t row = (size_t)r.w * 3;
    for (int y = 0; y < r.h; y++)
        memcpy(d->lin + ((size_t)(d->y + y) * (size_t)d->lin_w + (size_t)d->x) * 3,
               f + (size_t)y * row, row * sizeof *f);
    rayd_free(f);
    return RAYD_OK;
}

/* acc's AOV floats into rows of d->aov at (d->x, d->y). */
static enum rayd_status resolve_aov(const rayd_accum *acc, const struct resolve_dst *d,
                                    struct rayd_error *err) {
    float *f = NULL;
    enum rayd_status st = rayd_accum_aov_linear(acc, &f, err);
    if (st != RAYD_OK) return st;
    struct rayd_region r = rayd_accum_region(acc);
    size_t row = (size_t)r.w * RAYD_AOV_FLOATS;
    for (int y = 0; y < r.h; y++)
        memcpy(d->aov + ((size_t)(d->y + y) * (size_t)d->lin_w + (size_t)d->x) * RAYD_AOV_FLOATS,
               f + (size_t)y * row, row * sizeof *f);
    rayd_free(f);
    return RAYD_OK;
}

enum rayd_status resolve_into(const rayd_accum *acc, const struct resolve_dst *d,
                              struct rayd_error *err) {
    bool shows_aov = d->aov_mask && !d->aov;
    if (rayd_accum_denoised(acc) && d->img && !shows_aov && d->lin) {
        /* the 8-bit image and the floats both resolve through the filter:
         * filter once, resolve both from that (the same bytes) */
        rayd_accum *filtered = NULL;
        enum rayd_status st = rayd_accum_filtered(acc, &filtered, err);
        if (st == RAYD_OK) st = resolve_into(filtered, d, err);
        rayd_accum_free(filtered);
        return st;
    }
    rayd_image *img = NULL;
    enum rayd_status st = RAYD_OK;
    if (d->img)
        st = d->aov_mask && !d->aov ? rayd_accum_aov_image(acc, d->scene, d->aov_mask, &img, err)
                                    : rayd_accum_image(acc, &img, err);
    if (st == RAYD_OK && img) st = rayd_image_blit(d->img, img, d->x, d->y, err);
    rayd_image_free(img);
    if (st == RAYD_OK && d->lin) st = resolve_linear(acc, d, err);
    if (st == RAYD_OK && d->aov) st = resolve_aov(acc, d, err);
    return st;
}

enum rayd_status resolve_render(const rayd_scene *scene, const struct rayd_region *tile,
                                const struct resolve_dst *d, const atomic_int *cancel,
                                atomic_int_least64_t *rays_left, uint64_t *rays,
                                struct rayd_error *err) {
    rayd_accum *acc = NULL;
    enum rayd_status st = d->denoise ? rayd_accum_new_denoised(scene, tile, &acc, err)
                                     : rayd_accum_new(scene, tile, &acc, err);
    if (st == RAYD_OK && d->aov_mask) st = rayd_accum_aov_enable(acc, err);
    if (st != RAYD_OK) {
        rayd_accum_free(acc);
        return st;
    }
    rayd_accum_watch(acc, cancel, rays_left); /* the filter stops as the render does */
    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    struct rayd_render_stats stats = {0};
    struct rayd_render_opts o = {.threads = 1,
                                 .tile = tile->w > tile->h ? tile->w : tile->h,
                                 .cancel = cancel,
                                 .stats = &stats,
                                 .rays_left = rays_left};
    st = rayd_render_pass(scene, &o, acc, 0, info.samples, err); /* the plain render's sums */
    *rays += stats.rays;
    if (st == RAYD_OK) st = resolve_into(acc, d, err);
    rayd_accum_free(acc);
    return st;
}
