/* accum.c -- progressive passes whose images are exact prefixes.
 *
 * A render of N samples may run as passes (1, 2, 4, ... N samples, or every
 * k), each showing the whole frame.  The promise is that the image after a
 * pass of n samples is byte for byte the plain render with "samples": n.
 * The plain render sums a pixel's samples in double and scales by 1 / n;
 * sample k's ray and random numbers depend on (seed, pixel, k) only, not on
 * n, and the sum is exact whatever its grouping (render.c: each term is
 * rounded to a multiple of 2^-22 first).  So the accumulator keeps that
 * very sum per pixel (3 doubles): a pass adds samples from..to-1 to it,
 * and the resolve does the plain render's last step (scale, then sRGB).
 * Floats would not do: 24 bits cannot hold the sum exactly.
 *
 * One sample is the exception, kept from the paper: a one-sample render's
 * ray goes through the pixel centre, while sample 0 of a longer render is
 * jittered.  A pass [0, 1) therefore traces the centre and marks the sums
 * as such; the next pass throws them away and traces from sample 0.  The
 * one-sample preview costs one extra sample of a whole progressive render.
 */
#include <limits.h>
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "base/error.h"
#include "render/accum.h"
#include "render/aov.h"
#include "render/denoise.h"
#include "render/image.h"
#include "render/render.h"
#include "render/srgb.h"
#include "scene/scene.h"

enum rayd_status rayd_accum_new(const rayd_scene *s, const struct rayd_region *region,
                                rayd_accum **out, struct rayd_error *err) {
    struct rayd_region r = {0, 0, s->rs.width, s->rs.height};
    if (region && (region->w || region->h)) r = *region;
    enum rayd_status st = rayd_region_check(s, &r, err);
    if (st != RAYD_OK) return st;
    rayd_accum *a = calloc(1, sizeof *a);
    double *sum = calloc((size_t)r.w * (size_t)r.h * 3, sizeof *sum);
    if (!a || !sum) {
        free(a);
        free(sum);
        return err_set(err, RAYD_E_NOMEM, NULL, "out of memory for a %dx%d accumulator", r.w, r.h);
    }
    a->r = r;
    a->sum = sum;
    *out = a;
    return RAYD_OK;
}

enum rayd_status rayd_accum_new_sized(int width, int height, rayd_accum **out,
                                      struct rayd_error *err) {
    if (width < 1 || height < 1 || (long long)width * height > (1LL << 31) / 3)
        return err_set(err, RAYD_E_ARG, NULL, "an accumulator of %dx%d pixels", width, height);
    rayd_accum *a = calloc(1, sizeof *a);
    double *sum = calloc((size_t)width * (size_t)height * 3, sizeof *sum);
    if (!a || !sum) {
        free(a);
        free(sum);
        return err_set(err, RAYD_E_NOMEM, NULL, "out of memory for a %dx%d accumulator", width,
                       height);
    }
    a->r = (struct rayd_region){0, 0, width, height};
    a->sum = sum;
    *out = a;
    return RAYD_OK;
}

void rayd_accum_free(rayd_accum *a) {
    if (!a) return;
    free(a->aov);
    free(a->sum);
    free(a);
}

static enum rayd_status accum_resolvable(const rayd_accum *a, struct rayd_error *err);

enum rayd_status rayd_accum_new_denoised(const rayd_scene *s, const struct rayd_region *region,
                                         rayd_accum **out, struct rayd_error *err) {
    struct rayd_region v = {0, 0, s->rs.width, s->rs.height};
    if (region && (region->w || region->h)) v = *region;
    enum rayd_status st = rayd_region_check(s, &v, err);
    if (st != RAYD_OK) return st;
    int x0 = v.x - DENOISE_APRON, y0 = v.y - DENOISE_APRON; /* the apron, inside the image */
    int x1 = v.x + v.w + DENOISE_APRON, y1 = v.y + v.h + DENOISE_APRON;
    x0 = x0 < 0 ? 0 : x0;
    y0 = y0 < 0 ? 0 : y0;
    x1 = x1 > s->rs.width ? s->rs.width : x1;
    y1 = y1 > s->rs.height ? s->rs.height : y1;
    struct rayd_region r = {x0, y0, x1 - x0, y1 - y0};
    rayd_accum *a = NULL;
    st = rayd_accum_new(s, &r, &a, err);
    if (st == RAYD_OK) st = rayd_accum_aov_enable(a, err);
    if (st != RAYD_OK) {
        rayd_accum_free(a);
        return st;
    }
    a->denoise = true;
    a->view = v;
    *out = a;
    return RAYD_OK;
}

int rayd_accum_denoised(const rayd_accum *a) { return a->denoise; }

void rayd_accum_watch(rayd_accum *a, const atomic_int *cancel, atomic_int_least64_t *rays_left) {
    a->cancel = cancel;
    a->rays_left = rays_left;
}

/* For a denoised accumulator, *tmp: a new plain one of its view, filtered
 * or not (accum_denoise.c), which the caller resolves and frees; else
 * *tmp is NULL and a is resolved as it is. */
static enum rayd_status accum_plain(const rayd_accum *a, bool filter, rayd_accum **tmp,
                                    struct rayd_error *err) {
    *tmp = NULL;
    if (!a->denoise) return RAYD_OK;
    enum rayd_status st = accum_resolvable(a, err);
    rayd_accum *v = NULL;
    if (st == RAYD_OK) st = rayd_accum_new_sized(a->view.w, a->view.h, &v, err);
    if (st == RAYD_OK && a->aov) st = rayd_accum_aov_enable(v, err);
    if (st == RAYD_OK) st = accum_denoise_view(a, filter, v, err);
    if (st != RAYD_OK) {
        rayd_accum_free(v);
        return st;
    }
    *tmp = v;
    return RAYD_OK;
}

enum rayd_status rayd_accum_raw(const rayd_accum *a, rayd_accum **out, struct rayd_error *err) {
    *out = NULL;
    if (!a->denoise) return err_set(err, RAYD_E_ARG, NULL, "the accumulator is not a denoised one");
    return accum_plain(a, false, out, err);
}

enum rayd_status rayd_accum_filtered(const rayd_accum *a, rayd_accum **out,
                                     struct rayd_error *err) {
    *out = NULL;
    if (!a->denoise) return err_set(err, RAYD_E_ARG, NULL, "the accumulator is not a denoised one");
    return accum_plain(a, true, out, err);
}

/* Bytes a pixel of a denoised accumulator's sums (beauty and AOVs), and
 * of its resolve's peak: the filter's input (denoise_px) and output, the
 * filter's own buffers (denoise.c: unit normals, luminance, two working
 * images). */
#define ACCUM_DN_SUMS ((3 + AOV_SUMS) * sizeof(double))
#define ACCUM_DN_FILTER (sizeof(struct denoise_px) + 3 * sizeof(float) + 12 * sizeof(float))

void rayd_accum_denoised_bytes(const rayd_scene *s, const struct rayd_region *region, size_t *held,
                               size_t *peak) {
    int x0 = region->x - DENOISE_APRON, y0 = region->y - DENOISE_APRON;
    int x1 = region->x + region->w + DENOISE_APRON, y1 = region->y + region->h + DENOISE_APRON;
    x0 = x0 < 0 ? 0 : x0;
    y0 = y0 < 0 ? 0 : y0;
    x1 = x1 > s->rs.width ? s->rs.width : x1;
    y1 = y1 > s->rs.height ? s->rs.height : y1;
    size_t px = x1 > x0 && y1 > y0 ? (size_t)(x1 - x0) * (size_t)(y1 - y0) : 0;
    size_t view = (size_t)region->w * (size_t)region->h;
    *held = px * ACCUM_DN_SUMS;
    /* the filter over the apron'd buffer, then the plain view it resolves
     * through (sums, AOV sums) and that view's floats */
    *peak = px * ACCUM_DN_FILTER + view * (ACCUM_DN_SUMS + RAYD_AOV_FLOATS * sizeof(float));
}

int rayd_accum_samples(const rayd_accum *a) { return a->n < 0 ? 0 : a->n; }

struct rayd_region rayd_accum_region(const rayd_accum *a) {
    return a->denoise ? a->view : a->r;
}

static enum rayd_status accum_usable(const rayd_accum *a, struct rayd_error *err) {
    if (a->n < 0)
        return err_set(err, RAYD_E_ARG, NULL,
                       "the accumulator's last pass was canceled; its sums are incomplete");
    return RAYD_OK;
}

/* Usable, and holding samples: what every resolve needs first. */
static enum rayd_status accum_resolvable(const rayd_accum *a, struct rayd_error *err) {
    enum rayd_status st = accum_usable(a, err);
    if (st != RAYD_OK) return st;
    if (a->n == 0) return err_set(err, RAYD_E_ARG, NULL, "the accumulator holds no samples yet");
    return RAYD_OK;
}

enum rayd_status rayd_render_pass(const rayd_scene *s, const struct rayd_render_opts *opts,
                                  rayd_accum *a, int from, int to, struct rayd_error *err) {
    static const struct rayd_render_opts none;
    if (!opts) opts = &none;
    enum rayd_status st = accum_usable(a, err);
    if (st == RAYD_OK) st = rayd_region_check(s, &a->r, err); /* a sized one may not fit */
    if (st != RAYD_OK) return st;
    if (from != a->n)
        return err_set(err, RAYD_E_ARG, "samples_from",
                       "must be %d (the samples summed so far), not %d", a->n, from);
    if (to <= from)
        return err_set(err, RAYD_E_ARG, "samples_to", "must be > samples_from (%d), not %d", from,
                       to);
    if (to > RENDER_SUM_SAMPLES)
        return err_set(err, RAYD_E_ARG, "samples_to", "must be at most %d, not %d",
                       RENDER_SUM_SAMPLES, to);
    bool centre = to == 1; /* the paper's one ray through the pixel centre */
    if (a->centre) {       /* the centre sample is no prefix of longer renders */
        memset(a->sum, 0, (size_t)a->r.w * (size_t)a->r.h * 3 * sizeof *a->sum);
        if (a->aov) memset(a->aov, 0, (size_t)a->r.w * (size_t)a->r.h * AOV_SUMS * sizeof *a->aov);
        from = 0;
    }
    st = render_sums(s, opts, &a->r, a->sum, a->aov, from, to, centre ? 1 : 0, err);
    if (st != RAYD_OK) {
        a->n = -1;
        return st;
    }
    a->threads = opts->threads;
    a->n = to;
    a->centre = centre;
    return RAYD_OK;
}

/* ---- samples over many nodes --------------------------------------------- */

enum rayd_status rayd_render_sample_range(const rayd_scene *s, const struct rayd_render_opts *opts,
                                          rayd_accum *a, int k0, int k1, struct rayd_error *err) {
    static const struct rayd_render_opts none;
    if (!opts) opts = &none;
    if (a->n != 0 || a->centre)
        return err_set(err, RAYD_E_ARG, NULL, "a sample range needs a new accumulator");
    enum rayd_status fit = rayd_region_check(s, &a->r, err);
    if (fit != RAYD_OK) return fit;
    if (k0 < 0 || k1 <= k0 || k1 > RENDER_SUM_SAMPLES)
        return err_set(err, RAYD_E_ARG, "samples", "must be a range k0..k1 with 0 <= k0 < k1 <= %d",
                       RENDER_SUM_SAMPLES);
    /* The one-sample render's centre ray is its whole image, never a range. */
    bool centre = k0 == 0 && k1 == 1 && s->rs.samples == 1;
    enum rayd_status st = render_sums(s, opts, &a->r, a->sum, a->aov, k0, k1, centre ? 1 : 0, err);
    if (st != RAYD_OK) {
        a->n = -1;
        return st;
    }
    a->threads = opts->threads;
    a->n = k1 - k0;
    a->centre = centre;
    return RAYD_OK;
}

const double *rayd_accum_sums(const rayd_accum *a) { return a->sum; }

enum rayd_status rayd_accum_add_sums(rayd_accum *a, const double *sums, int samples,
                                     struct rayd_error *err) {
    enum rayd_status st = accum_usable(a, err);
    if (st != RAYD_OK) return st;
    if (a->denoise)
        return err_set(err, RAYD_E_ARG, NULL,
                       "sums are added to a plain accumulator, not a denoised one");
    if (samples < 1 || samples > RENDER_SUM_SAMPLES - a->n)
        return err_set(err, RAYD_E_ARG, "samples", "must be 1..%d, not %d",
                       RENDER_SUM_SAMPLES - a->n, samples);
    size_t count = (size_t)a->r.w * (size_t)a->r.h * 3;
    for (size_t i = 0; i < count; i++) a->sum[i] += sums[i]; /* exact: see render.c */
    a->n += samples;
    return RAYD_OK;
}

/* ---- AOVs --------------------------------------------------------------------- */

enum rayd_status rayd_accum_aov_enable(rayd_accum *a, struct rayd_error *err) {
    if (a->n != 0 || a->centre)
        return err_set(err, RAYD_E_ARG, NULL, "AOVs are enabled before the first samples");
    if (a->aov) return RAYD_OK;
    a->aov = calloc((size_t)a->r.w * (size_t)a->r.h * AOV_SUMS, sizeof *a->aov);
    if (!a->aov)
        return err_set(err, RAYD_E_NOMEM, NULL, "out of memory for %dx%d AOVs", a->r.w, a->r.h);
    return RAYD_OK;
}

int rayd_accum_has_aov(const rayd_accum *a) { return a->aov != NULL; }

enum rayd_status rayd_accum_merge(rayd_accum *dst, const rayd_accum *src, struct rayd_error *err) {
    enum rayd_status st = accum_usable(dst, err);
    if (st == RAYD_OK) st = accum_resolvable(src, err);
    if (st != RAYD_OK) return st;
    if (dst->r.w != src->r.w || dst->r.h != src->r.h)
        return err_set(err, RAYD_E_ARG, NULL, "sums of %dx%d pixels into an accumulator of %dx%d",
                       src->r.w, src->r.h, dst->r.w, dst->r.h);
    if (!dst->aov != !src->aov)
        return err_set(err, RAYD_E_ARG, NULL, "AOVs in one accumulator and not the other");
    if (dst->centre || src->centre)
        return err_set(err, RAYD_E_ARG, NULL, "a one-sample centre image is no sample range");
    if (dst->denoise || src->denoise)
        return err_set(err, RAYD_E_ARG, NULL,
                       "denoised accumulators are not merged: merge "
                       "plain ones and denoise the image made of them");
    size_t px = (size_t)dst->r.w * (size_t)dst->r.h;
    if (dst->aov) /* before add_sums counts the samples in */
        for (size_t i = 0; i < px * AOV_SUMS; i++) dst->aov[i] += src->aov[i]; /* exact */
    return rayd_accum_add_sums(dst, src->sum, src->n, err);
}

/* The AOVs resolved: RAYD_AOV_FLOATS floats a pixel. */
static enum rayd_status accum_aov_floats(const rayd_accum *a, float **out, struct rayd_error *err) {
    enum rayd_status st = accum_resolvable(a, err);
    if (st != RAYD_OK) return st;
    if (!a->aov) return err_set(err, RAYD_E_ARG, NULL, "the accumulator keeps no AOVs");
    size_t px = (size_t)a->r.w * (size_t)a->r.h;
    float *f = malloc(px * RAYD_AOV_FLOATS * sizeof *f);
    if (!f) return err_set(err, RAYD_E_NOMEM, NULL, "out of memory for the AOVs");
    for (size_t i = 0; i < px; i++)
        aov_resolve(a->aov + i * AOV_SUMS, a->n, f + i * RAYD_AOV_FLOATS);
    *out = f;
    return RAYD_OK;
}

static enum rayd_status plain_aov_image(const rayd_accum *a, const rayd_scene *s, unsigned aov,
                                        rayd_image **out, struct rayd_error *err) {
    if (aov == 0 || (aov & (aov - 1)) || aov > RAYD_AOV_ALL)
        return err_set(err, RAYD_E_ARG, "aov", "must be one AOV, not the set %u", aov);
    float *f = NULL;
    enum rayd_status st = accum_aov_floats(a, &f, err);
    rayd_image *img = NULL;
    if (st == RAYD_OK) st = rayd_image_new(a->r.w, a->r.h, &img, err);
    if (st != RAYD_OK) {
        free(f);
        return st;
    }
    double focus = s->cam.focus > 0 ? s->cam.focus : 1;
    size_t px = (size_t)a->r.w * (size_t)a->r.h;
    for (size_t i = 0; i < px; i++)
        aov_pixel8(f + i * RAYD_AOV_FLOATS, aov, focus, img->px + i * 3);
    free(f);
    *out = img;
    return RAYD_OK;
}

static enum rayd_status plain_rgba(const rayd_accum *a, uint8_t **out, struct rayd_error *err) {
    float *f = NULL;
    enum rayd_status st = accum_aov_floats(a, &f, err);
    if (st != RAYD_OK) return st;
    size_t px = (size_t)a->r.w * (size_t)a->r.h;
    uint8_t *p = malloc(px * 4);
    if (!p) {
        free(f);
        return err_set(err, RAYD_E_NOMEM, NULL, "out of memory for an RGBA image");
    }
    double scale = 1.0 / a->n; /* the RGB as rayd_accum_image's */
    for (size_t i = 0; i < px; i++) {
        for (int c = 0; c < 3; c++)
            p[i * 4 + (size_t)c] = render_srgb8(a->sum[i * 3 + (size_t)c] * scale);
        double al = f[i * RAYD_AOV_FLOATS + AOV_ALPHA];
        p[i * 4 + 3] = (uint8_t)(al >= 1 ? 255 : (int)nearbyint(al * 255));
    }
    free(f);
    *out = p;
    return RAYD_OK;
}

static enum rayd_status plain_image(const rayd_accum *a, rayd_image **out, struct rayd_error *err) {
    enum rayd_status st = accum_resolvable(a, err);
    if (st != RAYD_OK) return st;
    rayd_image *img = NULL;
    st = rayd_image_new(a->r.w, a->r.h, &img, err);
    if (st != RAYD_OK) return st;
    size_t count = (size_t)a->r.w * (size_t)a->r.h * 3;
    double scale = 1.0 / a->n; /* as the plain render: v3_scale(acc, 1.0 / n) */
    for (size_t i = 0; i < count; i++) img->px[i] = render_srgb8(a->sum[i] * scale);
    *out = img;
    return RAYD_OK;
}

static enum rayd_status plain_linear(const rayd_accum *a, float **out, struct rayd_error *err) {
    enum rayd_status st = accum_resolvable(a, err);
    if (st != RAYD_OK) return st;
    size_t count = (size_t)a->r.w * (size_t)a->r.h * 3;
    float *f = malloc(count * sizeof *f);
    if (!f) return err_set(err, RAYD_E_NOMEM, NULL, "out of memory for a linear image");
    double scale = 1.0 / a->n;
    for (size_t i = 0; i < count; i++) f[i] = (float)(a->sum[i] * scale);
    *out = f;
    return RAYD_OK;
}

enum rayd_status rayd_render_linear_tile(const rayd_scene *s, const struct rayd_render_opts *opts,
                                         float *dst, int dst_w, int dst_x, int dst_y,
                                         struct rayd_error *err) {
    static const struct rayd_render_opts none;
    if (!opts) opts = &none;
    rayd_accum *a = NULL;
    enum rayd_status st = rayd_accum_new(s, &opts->region, &a, err);
    if (st != RAYD_OK) return st;
    struct rayd_region r = a->r;
    if (dst_x < 0 || dst_y < 0 || dst_x > dst_w - r.w) {
        rayd_accum_free(a);
        return err_set(err, RAYD_E_ARG, NULL, "the region does not fit the destination image");
    }
    struct rayd_render_opts o = {.threads = 1,
                                 .tile = r.w > r.h ? r.w : r.h,
                                 .cancel = opts->cancel,
                                 .stats = opts->stats,
                                 .rays_left = opts->rays_left};
    int n = s->rs.samples;
    st = rayd_render_pass(s, &o, a, 0, n, err); /* one pass: the plain render's sums */
    double scale = 1.0 / n;
    for (int row = 0; st == RAYD_OK && row < r.h; row++) {
        float *out = dst + ((size_t)(dst_y + row) * (size_t)dst_w + (size_t)dst_x) * 3;
        const double *in = a->sum + (size_t)row * (size_t)r.w * 3;
        for (size_t k = 0; k < (size_t)r.w * 3; k++) out[k] = (float)(in[k] * scale);
    }
    rayd_accum_free(a);
    return st;
}

enum rayd_status rayd_render_linear_into(const rayd_scene *s, const struct rayd_region *region,
                                         float *dst, int dst_w, int dst_x, int dst_y,
                                         const atomic_int *cancel, uint64_t *rays,
                                         struct rayd_error *err) {
    struct rayd_render_stats stats = {0};
    struct rayd_render_opts o = {.cancel = cancel, .stats = &stats};
    if (region) o.region = *region;
    enum rayd_status st = rayd_render_linear_tile(s, &o, dst, dst_w, dst_x, dst_y, err);
    if (rays) *rays += stats.rays;
    return st;
}

/* The tone curve of one exposed linear value; clamp leaves it to srgb8. */
static double tone_curve(double v, enum rayd_tone_curve curve) {
    if (curve == RAYD_TONE_REINHARD) return v > 0 ? v / (1.0 + v) : v; /* [0, inf) -> [0, 1) */
    return v;
}

static enum rayd_status plain_image_tone(const rayd_accum *a, const struct rayd_tone *tone,
                                         rayd_image **out, struct rayd_error *err) {
    if (!tone || (tone->exposure == 0 && tone->curve == RAYD_TONE_CLAMP))
        return plain_image(a, out, err); /* the default: today's bytes */
    if (!(tone->exposure >= -64 && tone->exposure <= 64))
        return err_set(err, RAYD_E_ARG, "exposure", "must be in -64..64 stops");
    if (tone->curve != RAYD_TONE_CLAMP && tone->curve != RAYD_TONE_REINHARD)
        return err_set(err, RAYD_E_ARG, "curve", "must be RAYD_TONE_CLAMP or RAYD_TONE_REINHARD");
    enum rayd_status st = accum_resolvable(a, err);
    if (st != RAYD_OK) return st;
    rayd_image *img = NULL;
    st = rayd_image_new(a->r.w, a->r.h, &img, err);
    if (st != RAYD_OK) return st;
    size_t count = (size_t)a->r.w * (size_t)a->r.h * 3;
    double scale = 1.0 / a->n, gain = exp2(tone->exposure);
    for (size_t i = 0; i < count; i++)
        img->px[i] = render_srgb8(tone_curve(a->sum[i] * scale * gain, tone->curve));
    *out = img;
    return RAYD_OK;
}

/* The resolves of rayd.h.  A denoised accumulator is resolved through
 * its plain view (accum_plain: filtered, or raw for the AOVs, which the
 * filter does not touch); a plain one as it is. */
enum rayd_status rayd_accum_aov_linear(const rayd_accum *a, float **out, struct rayd_error *err) {
    rayd_accum *tmp = NULL;
    enum rayd_status st = accum_plain(a, false, &tmp, err);
    if (st == RAYD_OK) st = accum_aov_floats(tmp ? tmp : a, out, err);
    rayd_accum_free(tmp);
    return st;
}

enum rayd_status rayd_accum_aov_image(const rayd_accum *a, const rayd_scene *s, unsigned aov,
                                      rayd_image **out, struct rayd_error *err) {
    rayd_accum *tmp = NULL;
    enum rayd_status st = accum_plain(a, false, &tmp, err);
    if (st == RAYD_OK) st = plain_aov_image(tmp ? tmp : a, s, aov, out, err);
    rayd_accum_free(tmp);
    return st;
}

enum rayd_status rayd_accum_rgba(const rayd_accum *a, uint8_t **out, struct rayd_error *err) {
    rayd_accum *tmp = NULL;
    enum rayd_status st = accum_plain(a, true, &tmp, err);
    if (st == RAYD_OK) st = plain_rgba(tmp ? tmp : a, out, err);
    rayd_accum_free(tmp);
    return st;
}

enum rayd_status rayd_accum_image(const rayd_accum *a, rayd_image **out, struct rayd_error *err) {
    rayd_accum *tmp = NULL;
    enum rayd_status st = accum_plain(a, true, &tmp, err);
    if (st == RAYD_OK) st = plain_image(tmp ? tmp : a, out, err);
    rayd_accum_free(tmp);
    return st;
}

enum rayd_status rayd_accum_linear(const rayd_accum *a, float **out, struct rayd_error *err) {
    rayd_accum *tmp = NULL;
    enum rayd_status st = accum_plain(a, true, &tmp, err);
    if (st == RAYD_OK) st = plain_linear(tmp ? tmp : a, out, err);
    rayd_accum_free(tmp);
    return st;
}

enum rayd_status rayd_accum_image_tone(const rayd_accum *a, const struct rayd_tone *tone,
                                       rayd_image **out, struct rayd_error *err) {
    rayd_accum *tmp = NULL;
    enum rayd_status st = accum_plain(a, true, &tmp, err);
    if (st == RAYD_OK) st = plain_image_tone(tmp ? tmp : a, tone, out, err);
    rayd_accum_free(tmp);
    return st;
}
