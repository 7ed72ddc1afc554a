/* denoise.c -- an edge-avoiding a-trous wavelet filter guided by AOVs and
 * per-pixel variance, in the manner of SVGF.
 *
 * A path-traced pixel of few samples is its true value plus noise whose
 * variance the samples themselves tell (the accumulator keeps the sum of
 * each sample's squared luminance beside the sums: render.c).  The filter
 * averages each pixel with neighbours that see the same surface, and how
 * far it trusts a neighbour's light depends on how noisy the light is:
 *
 *   - Demodulation.  The radiance is divided by the albedo of the first
 *     diffuse hit (render/aov.c), so that a texture's detail is not
 *     blurred: only the lighting, which is smooth, is filtered; the
 *     albedo multiplies it back at the end.
 *   - Fireflies out first.  A pixel whose luminance is above its eight
 *     neighbours' mean + k standard deviations (neighbours only, so the
 *     outlier does not widen its own bound) is scaled down to that bound
 *     before any averaging: a firefly is removed where it is, never spread
 *     over the wavelet's footprint.  Its variance stays high, so the
 *     filter then fills it from its neighbours.
 *   - Five a-trous levels (Dammertz et al. 2010): at level i a 5x5 B3
 *     spline kernel with taps 2^i pixels apart, so 5 levels reach a 125 px
 *     footprint with 25 taps a pixel each.  Each tap's weight is the
 *     kernel's times exp(-e), e the sum of the edge-stopping terms of
 *     Schied et al. 2017 (SVGF): normals (cos^128), depth (relative
 *     change per pixel of distance), albedo (an edge in the textures or
 *     materials) and luminance, |l_p - l_q| / (sigma_l * sqrt(var_p)),
 *     var_p the 3x3 blur of the variance.  Each level also filters the
 *     variance (weights squared), so that later, wider levels trust the
 *     smoother signal more.
 *
 * Determinism.  Each stage writes every pixel from the previous stage's
 * buffer alone, its taps in one fixed order and skipping those outside
 * the buffer; rows are split over threads with nothing shared.  So the
 * bytes do not depend on the thread count, and a tile rendered with
 * DENOISE_APRON pixels around it (clipped at the image's edges) gives the
 * very pixels of the whole frame's filter: errors at a window's cut edge
 * travel inward by each stage's radius at most, and the apron is their
 * sum.  The image's own edges are edges of both buffers alike.
 *
 * Parameters were chosen by measurement (bench/denoise.c's DENOISE_SWEEP,
 * 16 samples of the Cornell box against a 1024-sample reference):
 * sigma_l 4 (2: 0.0320 RMSE, 8: 0.0339, 16: 0.0383), depth 0.02 (0.05:
 * +1%, 0.2: +2%), fireflies at 3 sigma (5: -0.6%, none: -0.3% RMSE but
 * SSIM 0.872 against 0.876: the specks matter to the eye more).
 */
#include "render/denoise.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#include "base/parallel.h"

void denoise_defaults(struct denoise_params *p) {
    *p = (struct denoise_params){.levels = DENOISE_LEVELS_MAX,
                                 .sigma_l = 4.0f,
                                 .sigma_n = 128.0f,
                                 .sigma_z = 0.02f,
                                 .sigma_a = 0.1f,
                                 .firefly_k = 3.0f,
                                 .variance = true};
}

/* A pixel's working values between stages: demodulated radiance, its
 * luminance's variance, the unit normal (zero: no hit). */
struct dn_work {
    float c[3], var;
};

struct dn_job {
    const struct denoise_px *in;
    int w, h, step;
    const struct denoise_params *p;
    float *un;                 /* unit normals, 3 a pixel */
    float *lum;                /* demodulated luminance (stage 1) */
    struct dn_work *src, *dst; /* the level's input and output */
    float *out;
};

static inline float dn_lum(const float c[3]) {
    return 0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2];
}

static inline bool dn_hit(const struct denoise_px *q) { return q->alpha > 0; }

/* The divisor of channel k of pixel q's radiance: its albedo, kept away
 * from 0; 1 where nothing was hit (the background is no surface). */
static inline float dn_div(const struct denoise_px *q, int k) {
    if (!dn_hit(q)) return 1.0f;
    return q->a[k] > 0.01f ? q->a[k] : 0.01f;
}

/* Stage 1: demodulate, unit normals, luminance. */
static void dn_prepare(void *ctx, size_t lo, size_t hi) {
    struct dn_job *j = ctx;
    for (size_t i = lo * (size_t)j->w; i < hi * (size_t)j->w; i++) {
        const struct denoise_px *q = &j->in[i];
        float d[3];
        for (int k = 0; k < 3; k++) {
            d[k] = dn_div(q, k);
            j->src[i].c[k] = q->c[k] / d[k];
        }
        float dl = dn_lum(d);
        j->src[i].var = q->var < 0 ? -1.0f : q->var / (dl * dl);
        j->lum[i] = dn_lum(j->src[i].c);
        float nn = q->n[0] * q->n[0] + q->n[1] * q->n[1] + q->n[2] * q->n[2];
        float s = dn_hit(q) && nn > 1e-8f ? 1.0f / sqrtf(nn) : 0.0f;
        for (int k = 0; k < 3; k++) j->un[i * 3 + (size_t)k] = q->n[k] * s;
    }
}

/* Stage 2: fireflies clamped to their neighbours' mean + k sigma; the
 * unknown variance of a one-sample pixel taken from its neighbourhood. */
static void dn_firefly(void *ctx, size_t lo, size_t hi) {
    struct dn_job *j = ctx;
    int w = j->w, h = j->h;
    for (int y = (int)lo; y < (int)hi; y++)
        for (int x = 0; x < w; x++) {
            size_t i = (size_t)y * (size_t)w + (size_t)x;
            double s = 0, s2 = 0;
            int m = 0;
            for (int dy = -1; dy <= 1; dy++)
                for (int dx = -1; dx <= 1; dx++) {
                    int qx = x + dx, qy = y + dy;
                    if ((dx == 0 && dy == 0) || qx < 0 || qy < 0 || qx >= w || qy >= h) continue;
                    double l = j->lum[(size_t)qy * (size_t)w + (size_t)qx];
                    s += l;
                    s2 += l * l;
                    m++;
                }
            struct dn_work o = j->src[i];
            double mean = m ? s / m : j->lum[i], sd = m ? sqrt(fmax(0, s2 / m - mean * mean)) : 0;
            double bound = mean + j->p->firefly_k * sd, l = j->lum[i];
            if (m && l > bound && l > 0) {
                float f = (float)(bound / l);
                for (int k = 0; k < 3; k++) o.c[k] *= f;
            }
            if (o.var < 0) o.var = (float)(sd * sd); /* one sample: the neighbours' spread */
            j->dst[i] = o;
        }
}

/* The 3x3 Gaussian of the variance around (x, y), over the taps inside. */
static float dn_var_blur(const struct dn_job *j, int x, int y) {
    static const float g[3] = {0.25f, 0.5f, 0.25f};
    float s = 0, ws = 0;
    for (int dy = -1; dy <= 1; dy++)
        for (int dx = -1; dx <= 1; dx++) {
            int qx = x + dx, qy = y + dy;
            if (qx < 0 || qy < 0 || qx >= j->w || qy >= j->h) continue;
            float wt = g[dx + 1] * g[dy + 1];
            s += wt * j->src[(size_t)qy * (size_t)j->w + (size_t)qx].var;
            ws += wt;
        }
    return s / ws;
}

/* Past this exponent a tap's weight (e^-20, 2e-9) is taken as 0: it
 * changes no output, and skips the exp and its denormals. */
#define DN_E_MAX 20.0f

/* x^sigma_n: by squarings when sigma_n is 128 (the default), no logf. */
static inline float dn_pow_n(float x, float sigma_n) {
    if (sigma_n != 128.0f) return powf(x, sigma_n);
    for (int i = 0; i < 7; i++) x *= x;
    return x;
}

/* The edge-stopping exponent between p and q, dist pixels apart, and in
 * *wn the normals' factor; < 0 when q must not count at all (a surface
 * against the background, normals facing apart, or a weight below
 * e^-DN_E_MAX). */
static float dn_edge(const struct dn_job *j, size_t p, size_t q, float lp, float lq, float lscale,
                     float dist, float *wn) {
    const struct denoise_px *a = &j->in[p], *b = &j->in[q];
    const struct denoise_params *pr = j->p;
    float e = fabsf(lp - lq) / lscale;
    if (dn_hit(a) != dn_hit(b) || e > DN_E_MAX) return -1;
    if (!dn_hit(a)) return e;
    const float *na = j->un + p * 3, *nb = j->un + q * 3;
    float dot = na[0] * nb[0] + na[1] * nb[1] + na[2] * nb[2];
    if (dot <= 1e-4f) return -1;
    *wn = dot < 1 ? dn_pow_n(dot, pr->sigma_n) : 1;
    if (*wn < 1e-9f) return -1;
    e += fabsf(a->z - b->z) / (pr->sigma_z * a->z * dist + 1e-6f);
    e += (fabsf(a->a[0] - b->a[0]) + fabsf(a->a[1] - b->a[1]) + fabsf(a->a[2] - b->a[2])) /
         pr->sigma_a;
    return e > DN_E_MAX ? -1 : e;
}

/* One a-trous level over rows lo..hi-1: src to dst. */
static void dn_level(void *ctx, size_t lo, size_t hi) {
    static const float kern[5] = {1.0f / 16, 1.0f / 4, 3.0f / 8, 1.0f / 4, 1.0f / 16};
    struct dn_job *j = ctx;
    int w = j->w, h = j->h, st = j->step;
    for (int y = (int)lo; y < (int)hi; y++)
        for (int x = 0; x < w; x++) {
            size_t p = (size_t)y * (size_t)w + (size_t)x;
            const struct dn_work *sp = &j->src[p];
            float lp = dn_lum(sp->c), lscale;
            if (j->p->variance)
                lscale = j->p->sigma_l * sqrtf(dn_var_blur(j, x, y)) + 1e-4f;
            else /* the baseline: a fixed scale, relative to the pixel's light */
                lscale = j->p->sigma_l * 0.05f * (lp + 1e-3f) / (float)st;
            float c[3] = {0, 0, 0}, ws = 0, v = 0;
            for (int dy = -2; dy <= 2; dy++)
                for (int dx = -2; dx <= 2; dx++) {
                    int qx = x + dx * st, qy = y + dy * st;
                    if (qx < 0 || qy < 0 || qx >= w || qy >= h) continue;
                    size_t q = (size_t)qy * (size_t)w + (size_t)qx;
                    const struct dn_work *sq = &j->src[q];
                    float e = 0, wn = 1;
                    if (q != p) {
                        e = dn_edge(j, p, q, lp, dn_lum(sq->c), lscale,
                                    (float)(st * (abs(dx) + abs(dy))), &wn);
                        if (e < 0) continue;
                    }
                    float wt = kern[dx + 2] * kern[dy + 2] * wn * expf(-e);
                    for (int k = 0; k < 3; k++) c[k] += wt * sq->c[k];
                    v += wt * wt * sq->var;
                    ws += wt;
                }
            struct dn_work *o = &j->dst[p];
            for (int k = 0; k < 3; k++) o->c[k] = c[k] / ws;
            o->var = v / (ws * ws);
        }
}

/* The last stage: the albedo multiplied back. */
static void dn_finish(void *ctx, size_t lo, size_t hi) {
    struct dn_job *j = ctx;
    for (size_t i = lo * (size_t)j->w; i < hi * (size_t)j->w; i++)
        for (int k = 0; k < 3; k++)
            j->out[i * 3 + (size_t)k] = j->src[i].c[k] * dn_div(&j->in[i], k);
}

static void dn_swap(struct dn_job *j) {
    struct dn_work *t = j->src;
    j->src = j->dst;
    j->dst = t;
}

bool denoise_run(const struct denoise_px *in, int w, int h, const struct denoise_params *p,
                 int threads, float *out) {
    size_t n = (size_t)w * (size_t)h;
    struct dn_job j = {.in = in, .w = w, .h = h, .p = p, .out = out};
    j.un = malloc(n * 3 * sizeof *j.un);
    j.lum = malloc(n * sizeof *j.lum);
    j.src = malloc(n * sizeof *j.src);
    j.dst = malloc(n * sizeof *j.dst);
    bool ok = j.un && j.lum && j.src && j.dst;
    if (ok) {
        size_t rows = (size_t)h, chunk = (size_t)(4096 / w + 1);
        parallel_for(rows, threads, chunk, dn_prepare, &j);
        parallel_for(rows, threads, chunk, dn_firefly, &j);
        dn_swap(&j);
        int levels = p->levels < 0                    ? 0
                     : p->levels > DENOISE_LEVELS_MAX ? DENOISE_LEVELS_MAX
                                                      : p->levels;
        for (int i = 0; i < levels; i++) {
            j.step = 1 << i;
            parallel_for(rows, threads, chunk, dn_level, &j);
            dn_swap(&j);
        }
        parallel_for(rows, threads, chunk, dn_finish, &j);
    }
    free(j.un);
    free(j.lum);
    free(j.src);
    free(j.dst);
    return ok;
}
