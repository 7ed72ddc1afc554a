/* accum_denoise.c -- a denoised accumulator's pixels: its sums and AOV
 * sums turned into the filter's input, filtered, and cut to the region
 * asked.
 *
 * A denoised accumulator (rayd_accum_new_denoised, accum.c) keeps the
 * sums of the region asked plus DENOISE_APRON pixels around it (clipped
 * at the image's edges), with the AOV sums, among them each pixel's sum
 * of squared sample luminance (render.c).  From those the variance of the
 * pixel's mean luminance is the unbiased sample variance over n:
 *
 *     var = (sum(L^2) / n - mean(L)^2) * n / (n - 1) / n
 *
 * (unknown for one sample: the filter then takes the neighbours').  Then
 * denoise.c filters the whole apron'd buffer and the region asked is cut
 * out, which is the very crop of the whole frame's filtered image: the
 * same sums, the same filter, and an apron wide enough (denoise.h).
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "base/error.h"
#include "render/accum.h"
#include "render/aov.h"
#include "render/denoise.h"

_Static_assert(RAYD_DENOISE_APRON == DENOISE_APRON, "rayd.h's apron is the filter's");

/* Pixel i of a's sums as the filter's input. */
static void accum_denoise_px(const rayd_accum *a, size_t i, struct denoise_px *px) {
    const double *s = a->sum + i * 3, *ao = a->aov + i * AOV_SUMS;
    double n = a->n, scale = 1.0 / n;
    float f[RAYD_AOV_FLOATS];
    aov_resolve(ao, a->n, f);
    for (int k = 0; k < 3; k++) {
        px->c[k] = (float)(s[k] * scale);
        px->a[k] = f[AOV_ALBEDO_R + k];
        px->n[k] = f[AOV_NORMAL_X + k];
    }
    px->z = f[AOV_DEPTH];
    px->alpha = f[AOV_ALPHA];
    if (a->n < 2 || a->centre) {
        px->var = -1;
        return;
    }
    double l = (0.2126 * s[0] + 0.7152 * s[1] + 0.0722 * s[2]) * scale;
    double v = (ao[AOV_LUM2] * scale - l * l) * n / (n - 1) / n;
    px->var = (float)(v > 0 ? v : 0);
}

/* The filtered radiance of a's whole buffer, w * h * 3 floats. */
static enum rayd_status accum_denoise_filter(const rayd_accum *a, float **out,
                                             struct rayd_error *err) {
    size_t px = (size_t)a->r.w * (size_t)a->r.h;
    struct denoise_px *in = malloc(px * sizeof *in);
    float *f = malloc(px * 3 * sizeof *f);
    struct denoise_params p;
    denoise_defaults(&p);
    enum rayd_status st = in && f ? RAYD_OK : RAYD_E_NOMEM;
    for (size_t i = 0; st == RAYD_OK && i < px; i++) accum_denoise_px(a, i, &in[i]);
    struct meter m = meter_make(a->cancel, a->rays_left);
    if (st == RAYD_OK)
        st = denoise_run(in, a->r.w, a->r.h, &p, a->threads > 1 ? a->threads : 1, &m, f);
    free(in);
    if (st != RAYD_OK) {
        free(f);
        return err_set(err, st, NULL, "%s",
                       st == RAYD_E_CANCELED ? "the denoiser was canceled"
                       : st == RAYD_E_LIMIT  ? "the denoiser's work is over the ray budget"
                                             : "out of memory for the denoiser");
    }
    *out = f;
    return RAYD_OK;
}

enum rayd_status accum_denoise_view(const rayd_accum *a, bool filter, rayd_accum *v,
                                    struct rayd_error *err) {
    float *f = NULL;
    if (filter) {
        enum rayd_status st = accum_denoise_filter(a, &f, err);
        if (st != RAYD_OK) return st;
    }
    int ox = a->view.x - a->r.x, oy = a->view.y - a->r.y, w = a->view.w;
    for (int y = 0; y < a->view.h; y++) {
        size_t src = (size_t)(oy + y) * (size_t)a->r.w + (size_t)ox, dst = (size_t)y * (size_t)w;
        for (size_t k = 0; f && k < (size_t)w * 3; k++)
            v->sum[dst * 3 + k] = (double)f[src * 3 + k] * a->n;
        if (!f) memcpy(v->sum + dst * 3, a->sum + src * 3, (size_t)w * 3 * sizeof *v->sum);
        if (a->aov)
            memcpy(v->aov + dst * AOV_SUMS, a->aov + src * AOV_SUMS,
                   (size_t)w * AOV_SUMS * sizeof *v->aov);
    }
    free(f);
    v->r = a->view;
    v->n = a->n;
    v->centre = a->centre;
    return RAYD_OK;
}
