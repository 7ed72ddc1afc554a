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
 *     footprint, with 21 taps a pixel each (its four corners, 1/256 each,
 *     left out: DN_CORNERS).  Each tap's weight is the
 *     kernel's times exp(-e), e the sum of the edge-stopping terms of
 *     Schied et al. 2017 (SVGF): normals (cos^128), depth (relative
 *     change per pixel of distance), albedo (an edge in the textures or
 *     materials) and luminance, |l_p - l_q| / (sigma_l_i * sqrt(var_p)),
 *     sigma_l_i = sigma_l 0.7^i at level i, var_p the 3x3 blur of the variance.  Each level also
 * filters the variance (weights squared), so that later, wider levels trust the smoother signal
 * more.
 *   - Two departures from SVGF, both measured (below).  The luminances
 *     compared are each pixel's 3x3 Gaussian (over pixels of its kind,
 *     surface or background), not its own: when a neighbour's weight
 *     falls with its own noise, the bright rare samples of skewed noise
 *     lose weight and the average darkens (2.8% on the Cornell box at 16
 *     samples; 2.4% so).  And sigma_l shrinks by 0.7 a level: the wide
 *     levels then blur less of the light's real gradients (a room's
 *     darker corners), which the variance of few samples hides.
 *
 * Speed.  The guides and the working image are planes (one float array a
 * quantity), and a level runs tap by tap along a row: for each of the 25
 * taps one branch-free loop over the row's pixels, which the compiler
 * vectorises (the Makefile gives this file -ftree-vectorize and
 * -fno-trapping-math; neither changes a value), with our own exp
 * (dn_exp_neg) in place of libm's.
 *
 * Determinism.  Each stage writes every pixel from the previous stage's
 * buffer alone, its taps in one fixed order (a row's accumulators take
 * the taps one after the other, so each pixel sums them in that order)
 * and with no weight for those outside the buffer; rows are split over
 * threads with nothing shared.  So the bytes do not depend on the thread
 * count, and a tile rendered with DENOISE_APRON pixels around it (clipped
 * at the image's edges) gives the very pixels of the whole frame's
 * filter: errors at a window's cut edge travel inward by each stage's
 * radius at most, and the apron is their sum.  The image's own edges are
 * edges of both buffers alike.
 *
 * Limits.  The filter over a 4096-pixel-square region takes seconds, so
 * a caller's meter stops it as it stops a render: every chunk of rows
 * (about 4096 pixels, a millisecond at most) first looks at the cancel
 * flag and whether the ray budget is spent, read by any thread; and after
 * each level the calling thread takes the level's share of
 * RAYD_DENOISE_RAYS a pixel from the budget (the meter, which only it
 * touches), so a budget the whole filter would pass stops it at a level's
 * end, and one spent elsewhere within a chunk.  The bytes of a filter
 * that is not stopped do not change.
 *
 * Parameters were chosen by measurement (bench/denoise.c, DENOISE_CACHE
 * and DENOISE_SWEEP: 4, 16 and 64 samples of the Cornell box and of the
 * bison under the studio light, against 4096 samples of their own):
 * RMSE at 16 samples, Cornell / bison, SVGF as it was (sigma_l 4, no
 * decay, own luminances) 0.0289 / 0.0104; luminances blurred 0.0278 /
 * 0.0095; with sigma_l 6 decaying by 0.7 0.0260 / 0.0092 (sigma_l 5 or 8
 * with it: 0.0257 / 0.0094, 0.0270 / 0.0092; decay 0.6 or 0.8: 0.0254 /
 * 0.0096, 0.0271 / 0.0092).  Fewer levels suit the box and not the bison
 * (4 levels, sigma_l 4: 0.0260 / 0.0097; 3, sigma_l 6: 0.0261 / 0.0103);
 * a 5x5 or 7x7 variance prefilter is worse (0.0296, 0.0306 on the box
 * against 0.0278); depth 0.02 per pixel of distance is the compromise
 * (0.005: 0.0253 / 0.0106, 0.05: 0.0266 / 0.0089), and a depth test
 * along the tangent plane (SVGF's depth gradient) was worse on the box
 * (0.0266).  Fireflies at 3 sigma: 5 sigma gives 0.0257 on the box, none
 * 0.0262 and the specks (SSIM 0.916 against 0.931).
 */
#include "render/denoise.h"

#include <math.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "base/parallel.h"

void denoise_defaults(struct denoise_params *p) {
    *p = (struct denoise_params){.levels = DENOISE_LEVELS_MAX,
                                 .sigma_l = 6.0f,
                                 .sigma_n = 128.0f,
                                 .sigma_z = 0.02f,
                                 .sigma_a = 0.1f,
                                 .sigma_l_decay = 0.7f,
                                 .lum_blur = true,
                                 .firefly_k = 3.0f,
                                 .variance = true};
}

/* The guides, one plane a quantity (rows packed), so that a level's
 * inner loop runs along a row over contiguous floats and vectorises:
 * unit normals (0 where nothing was hit), depth (0 there), albedo, and
 * hit (1 or 0). */
enum { DN_NX, DN_NY, DN_NZ, DN_Z, DN_A0, DN_A1, DN_A2, DN_HIT, DN_GUIDES };
/* A stage's working planes: demodulated radiance and its luminance's
 * variance. */
enum { DN_C0, DN_C1, DN_C2, DN_VAR, DN_WORK };

struct dn_job {
    const struct denoise_px *in;
    int w, h, step;
    float sigma_l; /* the level's */
    bool blur_lum; /* the level compares blurred luminances (dn_guide_lum) */
    const struct denoise_params *p;
    float *g[DN_GUIDES]; /* the guides */
    float *lum;          /* demodulated luminance (stage 1), then each level's guide luminance */
    float *src[DN_WORK], *dst[DN_WORK]; /* the level's input and output */
    float *out;
    atomic_int oom;                   /* a level's row buffers could not be allocated */
    const atomic_int *cancel;         /* the meter's flag, or NULL: looked at before every chunk */
    const atomic_int_least64_t *left; /* the meter's budget, or NULL: likewise */
    atomic_int skipped;               /* a chunk was skipped for either */
    void (*stage)(void *ctx, size_t lo, size_t hi); /* dn_stage's, run chunk by chunk */
};

static inline float dn_lum(float r, float g, float b) {
    return 0.2126f * r + 0.7152f * g + 0.0722f * b;
}

static inline bool dn_hit(const struct denoise_px *q) { return q->alpha > 0; }

/* The divisor of channel k of pixel q's radiance: its albedo, kept away
 * from 0; 1 where nothing was hit (the background is no surface). */
static inline float dn_div(const struct denoise_px *q, int k) {
    if (!dn_hit(q)) return 1.0f;
    return q->a[k] > 0.01f ? q->a[k] : 0.01f;
}

/* Stage 1: demodulate, the guides' planes, luminance. */
static void dn_prepare(void *ctx, size_t lo, size_t hi) {
    struct dn_job *j = ctx;
    for (size_t i = lo * (size_t)j->w; i < hi * (size_t)j->w; i++) {
        const struct denoise_px *q = &j->in[i];
        float d[3];
        for (int k = 0; k < 3; k++) {
            d[k] = dn_div(q, k);
            j->src[DN_C0 + k][i] = q->c[k] / d[k];
        }
        float dl = dn_lum(d[0], d[1], d[2]);
        j->src[DN_VAR][i] = q->var < 0 ? -1.0f : q->var / (dl * dl);
        j->lum[i] = dn_lum(j->src[DN_C0][i], j->src[DN_C1][i], j->src[DN_C2][i]);
        bool hit = dn_hit(q);
        float nn = q->n[0] * q->n[0] + q->n[1] * q->n[1] + q->n[2] * q->n[2];
        float s = hit && nn > 1e-8f ? 1.0f / sqrtf(nn) : 0.0f;
        for (int k = 0; k < 3; k++) {
            j->g[DN_NX + k][i] = q->n[k] * s;
            j->g[DN_A0 + k][i] = hit ? q->a[k] : 0.0f;
        }
        j->g[DN_Z][i] = hit && isfinite(q->z) ? q->z : 0.0f;
        j->g[DN_HIT][i] = hit ? 1.0f : 0.0f;
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
            double mean = m ? s / m : j->lum[i], sd = m ? sqrt(fmax(0, s2 / m - mean * mean)) : 0;
            double bound = mean + j->p->firefly_k * sd, l = j->lum[i];
            float f = m && l > bound && l > 0 ? (float)(bound / l) : 1.0f;
            for (int k = 0; k < 3; k++) j->dst[DN_C0 + k][i] = j->src[DN_C0 + k][i] * f;
            float v = j->src[DN_VAR][i];
            j->dst[DN_VAR][i] =
                v < 0 ? (float)(sd * sd) : v; /* one sample: the neighbours' spread */
        }
}

/* The planes a level reads and the row accumulators it writes never
 * overlap: GCC need not check (its run-time alias tests are too many for
 * the twenty-odd streams of a tap and would keep the loop scalar). */
#if defined(__GNUC__) && !defined(__clang__)
#define DN_IVDEP _Pragma("GCC ivdep")
#else
#define DN_IVDEP
#endif

/* Past this exponent a tap's weight (e^-20, 2e-9 of its kernel's) is
 * taken as 0. */
#define DN_E_MAX 20.0f

/* e^-e for 0 <= e <= DN_E_MAX: 2^-x, x = e log2(e), as 2^-i from the
 * exponent's bits, i the integer nearest x, times 2^-(x - i) by its
 * Taylor polynomial of degree 6 (relative error 1.1e-6 over the range,
 * most of it the rounding of x).  Ours rather than libm's expf so that
 * the loops around it vectorise, and its bits are the same with every
 * libm. */
static inline float dn_exp_neg(float e) {
    float x = e * 1.44269504f;
    int i = (int)(x + 0.5f);
    float t = (x - (float)i) * -0.693147181f; /* |t| <= ln(2) / 2 */
    float p =
        1.0f +
        t * (1.0f + t * (0.5f + t * (1.0f / 6 + t * (1.0f / 24 + t * (1.0f / 120 + t / 720.0f)))));
    int32_t bits = (127 - i) << 23;
    float sc;
    memcpy(&sc, &bits, sizeof sc);
    return p * sc;
}

/* x^sigma_n: by seven squarings when squared (sigma_n 128, the default;
 * no branch, so the loop around it vectorises), else powf. */
static inline float dn_pow_n(float x, float sigma_n, bool squared) {
    if (!squared) return powf(x, sigma_n);
    for (int i = 0; i < 7; i++) x *= x;
    return x;
}

/* The luminance a level compares: the src's, or (lum_blur) its 3x3
 * Gaussian over the pixels of p's kind (surface or
 * background), so that a neighbour's weight depends less on its own
 * noise: weights that fall with a bright sample's brightness darken the
 * average of skewed noise (the light of a few rare paths). */
static void dn_guide_lum(void *ctx, size_t lo, size_t hi) {
    static const float g[3] = {0.25f, 0.5f, 0.25f};
    struct dn_job *j = ctx;
    int w = j->w, h = j->h;
    const float *c0 = j->src[DN_C0], *c1 = j->src[DN_C1], *c2 = j->src[DN_C2];
    const float *hit = j->g[DN_HIT];
    for (int y = (int)lo; y < (int)hi; y++)
        for (int x = 0; x < w; x++) {
            size_t p = (size_t)y * (size_t)w + (size_t)x;
            if (!j->blur_lum) {
                j->lum[p] = dn_lum(c0[p], c1[p], c2[p]);
                continue;
            }
            float s = 0, ws = 0;
            for (int dy = -1; dy <= 1; dy++)
                for (int dx = -1; dx <= 1; dx++) {
                    int qx = x + dx, qy = y + dy;
                    if (qx < 0 || qy < 0 || qx >= w || qy >= h) continue;
                    size_t q = (size_t)qy * (size_t)w + (size_t)qx;
                    if (hit[q] != hit[p]) continue;
                    float wt = g[dx + 1] * g[dy + 1];
                    s += wt * dn_lum(c0[q], c1[q], c2[q]);
                    ws += wt;
                }
            j->lum[p] = s / ws;
        }
}

/* Per pixel of row y, what every tap of the level needs: its
 * luminance, 1 / its luminance scale (sigma_l times the standard
 * deviation from the 3x3 Gaussian of the variance, SVGF's prefilter), and
 * 1 / its depth scale. */
static void dn_row_scales(const struct dn_job *j, int y, float *lp, float *il, float *iz) {
    static const float g[3] = {0.25f, 0.5f, 0.25f};
    const struct denoise_params *pr = j->p;
    int w = j->w, h = j->h;
    const float *var = j->src[DN_VAR], *z = j->g[DN_Z];
    size_t row = (size_t)y * (size_t)w;
    for (int x = 0; x < w; x++) {
        size_t p = row + (size_t)x;
        lp[x] = j->lum[p];
        iz[x] = 1.0f / (pr->sigma_z * z[p] + 1e-6f);
    }
    if (!pr->variance) { /* the baseline: a fixed scale, relative to the pixel's light */
        for (int x = 0; x < w; x++)
            il[x] = (float)j->step / (pr->sigma_l * 0.05f * (lp[x] + 1e-3f));
        return;
    }
    for (int x = 0; x < w; x++) {
        float s = 0, ws = 0;
        for (int dy = -1; dy <= 1; dy++)
            for (int dx = -1; dx <= 1; dx++) {
                int qx = x + dx, qy = y + dy;
                if (qx < 0 || qy < 0 || qx >= w || qy >= h) continue;
                float wt = g[dx + 1] * g[dy + 1];
                s += wt * var[(size_t)qy * (size_t)w + (size_t)qx];
                ws += wt;
            }
        il[x] = 1.0f / (j->sigma_l * sqrtf(s / ws) + 1e-4f);
    }
}

/* A tap: its kernel weight and 1 / its distance in pixels. */
struct dn_geo {
    float k, inv_dist;
};

/* The accumulators of one output row: radiance, weight, variance. */
struct dn_acc {
    float *c[3], *ws, *v;
};

/* One tap of the level for n pixels p from index prow on, the tap's pixel
 * q of each at qrow on (lp, il, iz and acc from p's own column): the
 * weight of the tap's pixel q in each pixel p's average is the kernel's
 * times the edge-stopping terms of Schied et al. 2017: normals (cos^n),
 * depth (relative, per pixel of distance), albedo, luminance (in
 * standard deviations); none between a surface and the background.
 * Branch-free, so that it vectorises; a weight under e^-DN_E_MAX is 0. */
static inline __attribute__((always_inline)) void
dn_tap_with(const struct dn_job *j, size_t prow, size_t qrow, int n, const struct dn_geo *tg,
            const float *lp, const float *il, const float *iz, const struct dn_acc *acc,
            bool squared) {
    const float *const *g = (const float *const *)j->g;
    const float *restrict s0 = j->src[DN_C0] + qrow, *restrict s1 = j->src[DN_C1] + qrow;
    const float *restrict s2 = j->src[DN_C2] + qrow, *restrict sv = j->src[DN_VAR] + qrow;
    const float *restrict pnx = g[DN_NX] + prow, *restrict pny = g[DN_NY] + prow,
                          *restrict pnz = g[DN_NZ] + prow;
    const float *restrict qnx = g[DN_NX] + qrow, *restrict qny = g[DN_NY] + qrow,
                          *restrict qnz = g[DN_NZ] + qrow;
    const float *restrict pz = g[DN_Z] + prow, *restrict qz = g[DN_Z] + qrow,
                          *restrict ph = g[DN_HIT] + prow;
    float k = tg->k, inv_dist = tg->inv_dist;
    const float *restrict qh = g[DN_HIT] + qrow, *restrict ql = j->lum + qrow;
    const float *restrict pa0 = g[DN_A0] + prow, *restrict pa1 = g[DN_A1] + prow,
                          *restrict pa2 = g[DN_A2] + prow;
    const float *restrict qa0 = g[DN_A0] + qrow, *restrict qa1 = g[DN_A1] + qrow,
                          *restrict qa2 = g[DN_A2] + qrow;
    float ia = 1.0f / j->p->sigma_a, sn = j->p->sigma_n;
    float *restrict ac0 = acc->c[0], *restrict ac1 = acc->c[1], *restrict ac2 = acc->c[2],
                    *restrict aw = acc->ws, *restrict av = acc->v;
    DN_IVDEP
    for (int x = 0; x < n; x++) {
        float lq = ql[x];
        float dot = pnx[x] * qnx[x] + pny[x] * qny[x] + pnz[x] * qnz[x];
        float pw = dn_pow_n(dot, sn, squared); /* every value computed, then selected: */
        float wn = dot < 1.0f ? pw : 1.0f;     /* no branch (and no trap) to keep apart */
        wn = dot > 1e-4f ? wn : 0.0f;
        wn = wn >= 1e-9f ? wn : 0.0f;
        float e = fabsf(lp[x] - lq) * il[x];
        float es = e + fabsf(pz[x] - qz[x]) * iz[x] * inv_dist +
                   (fabsf(pa0[x] - qa0[x]) + fabsf(pa1[x] - qa1[x]) + fabsf(pa2[x] - qa2[x])) * ia;
        e = ph[x] > 0.5f ? es : e;
        wn = ph[x] > 0.5f ? wn : 1.0f;
        float wt = k * wn * dn_exp_neg(e < DN_E_MAX ? e : DN_E_MAX);
        wt = e <= DN_E_MAX ? wt : 0.0f;
        wt = ph[x] == qh[x] ? wt : 0.0f;
        ac0[x] += wt * s0[x];
        ac1[x] += wt * s1[x];
        ac2[x] += wt * s2[x];
        aw[x] += wt;
        av[x] += wt * wt * sv[x];
    }
}

static void dn_tap(const struct dn_job *j, size_t prow, size_t qrow, int n, const struct dn_geo *tg,
                   const float *lp, const float *il, const float *iz, const struct dn_acc *acc) {
    if (j->p->sigma_n == 128.0f)
        dn_tap_with(j, prow, qrow, n, tg, lp, il, iz, acc, true);
    else
        dn_tap_with(j, prow, qrow, n, tg, lp, il, iz, acc, false);
}

/* DN_CORNERS: the kernel's four corner taps (1/256 each) are left out:
 * 20 neighbours a pixel instead of 24, a sixth less work, and the same
 * figures (bench/denoise.c at 16 samples: 0.0260 / 0.0092 with or without
 * them). */

/* One a-trous level over rows lo..hi-1: src to dst.  Each output row
 * sums its taps in one fixed order (dy, then dx), pixel by pixel. */
static void dn_level(void *ctx, size_t lo, size_t hi) {
    static const float kern[5] = {1.0f / 16, 1.0f / 4, 3.0f / 8, 1.0f / 4, 1.0f / 16};
    struct dn_job *j = ctx;
    int w = j->w, h = j->h, st = j->step;
    float *buf = malloc((size_t)w * 8 * sizeof *buf);
    if (!buf) {
        atomic_store(&j->oom, 1);
        return;
    }
    float *lp = buf, *il = buf + w, *iz = buf + 2 * w;
    struct dn_acc acc = {{buf + 3 * w, buf + 4 * w, buf + 5 * w}, buf + 6 * w, buf + 7 * w};
    for (int y = (int)lo; y < (int)hi; y++) {
        size_t prow = (size_t)y * (size_t)w;
        dn_row_scales(j, y, lp, il, iz);
        memset(buf + 3 * w, 0, (size_t)w * 5 * sizeof *buf);
        for (int dy = -2; dy <= 2; dy++) {
            int qy = y + dy * st;
            if (qy < 0 || qy >= h) continue;
            for (int dx = -2; dx <= 2; dx++) {
                float k = kern[dx + 2] * kern[dy + 2];
                int off = dx * st;
                int x0 = off < 0 ? -off : 0, x1 = off > 0 ? w - off : w;
                if (abs(dx) == 2 && abs(dy) == 2) continue; /* corners: see DN_CORNERS */
                if (dx == 0 && dy == 0) { /* the pixel itself: the kernel's weight alone */
                    for (int x = 0; x < w; x++) {
                        acc.c[0][x] += k * j->src[DN_C0][prow + (size_t)x];
                        acc.c[1][x] += k * j->src[DN_C1][prow + (size_t)x];
                        acc.c[2][x] += k * j->src[DN_C2][prow + (size_t)x];
                        acc.ws[x] += k;
                        acc.v[x] += k * k * j->src[DN_VAR][prow + (size_t)x];
                    }
                    continue;
                }
                if (x0 >= x1) continue;
                struct dn_acc a = {
                    {acc.c[0] + x0, acc.c[1] + x0, acc.c[2] + x0}, acc.ws + x0, acc.v + x0};
                struct dn_geo tg = {k, 1.0f / (float)(st * (abs(dx) + abs(dy)))};
                dn_tap(j, prow + (size_t)x0, (size_t)qy * (size_t)w + (size_t)(x0 + off), x1 - x0,
                       &tg, lp + x0, il + x0, iz + x0, &a);
            }
        }
        for (int x = 0; x < w; x++) {
            float ws = acc.ws[x];
            j->dst[DN_C0][prow + (size_t)x] = acc.c[0][x] / ws;
            j->dst[DN_C1][prow + (size_t)x] = acc.c[1][x] / ws;
            j->dst[DN_C2][prow + (size_t)x] = acc.c[2][x] / ws;
            j->dst[DN_VAR][prow + (size_t)x] = acc.v[x] / (ws * ws);
        }
    }
    free(buf);
}

/* The last stage: the albedo multiplied back. */
static void dn_finish(void *ctx, size_t lo, size_t hi) {
    struct dn_job *j = ctx;
    for (size_t i = lo * (size_t)j->w; i < hi * (size_t)j->w; i++)
        for (int k = 0; k < 3; k++)
            j->out[i * 3 + (size_t)k] = j->src[DN_C0 + k][i] * dn_div(&j->in[i], k);
}

static void dn_swap(struct dn_job *j) {
    for (int k = 0; k < DN_WORK; k++) {
        float *t = j->src[k];
        j->src[k] = j->dst[k];
        j->dst[k] = t;
    }
}

/* A chunk of rows of j's stage, unless the meter's flag is up or its
 * budget spent (by this filter's levels or the render's other tiles). */
static void dn_chunk(void *ctx, size_t lo, size_t hi) {
    struct dn_job *j = ctx;
    if ((j->cancel && atomic_load_explicit(j->cancel, memory_order_relaxed)) ||
        (j->left && atomic_load_explicit(j->left, memory_order_relaxed) < 0)) {
        atomic_store_explicit(&j->skipped, 1, memory_order_relaxed);
        return;
    }
    j->stage(ctx, lo, hi);
}

/* Runs stage over j's rows on threads, then counts work (rays' worth) on
 * m: false when m says stop, or a chunk was skipped (then m stops too). */
static bool dn_stage(struct dn_job *j, int threads, void (*stage)(void *, size_t, size_t),
                     struct meter *m, uint64_t work) {
    j->stage = stage;
    parallel_for((size_t)j->h, threads, (size_t)(4096 / j->w + 1), dn_chunk, j);
    if (!m) return true;
    m->work += work;
    if (!meter_check(m)) return false;
    if (!atomic_load_explicit(&j->skipped, memory_order_relaxed)) return true;
    bool canceled = j->cancel && atomic_load_explicit(j->cancel, memory_order_relaxed);
    m->stop = canceled ? RAYD_E_CANCELED : RAYD_E_LIMIT; /* the budget, spent elsewhere */
    m->next = 0;
    return false;
}

enum rayd_status denoise_run(const struct denoise_px *in, int w, int h,
                             const struct denoise_params *p, int threads, struct meter *m,
                             float *out) {
    size_t n = (size_t)w * (size_t)h;
    struct dn_job j = {.in = in,
                       .w = w,
                       .h = h,
                       .p = p,
                       .out = out,
                       .cancel = m ? m->cancel : NULL,
                       .left = m ? m->left : NULL};
    atomic_init(&j.oom, 0);
    atomic_init(&j.skipped, 0);
    /* one block: the guides, the luminance, the two stages' planes */
    float *mem = malloc(n * (DN_GUIDES + 1 + 2 * DN_WORK) * sizeof *mem);
    if (!mem) return RAYD_E_NOMEM;
    for (int k = 0; k < DN_GUIDES; k++) j.g[k] = mem + n * (size_t)k;
    j.lum = mem + n * DN_GUIDES;
    for (int k = 0; k < DN_WORK; k++) {
        j.src[k] = mem + n * (size_t)(DN_GUIDES + 1 + k);
        j.dst[k] = mem + n * (size_t)(DN_GUIDES + 1 + DN_WORK + k);
    }
    int levels = p->levels < 0                    ? 0
                 : p->levels > DENOISE_LEVELS_MAX ? DENOISE_LEVELS_MAX
                                                  : p->levels;
    /* the levels are the work (21 taps a pixel each): RAYD_DENOISE_RAYS a
     * pixel over the whole filter, shared among them */
    uint64_t level_work = (uint64_t)n * RAYD_DENOISE_RAYS / (uint64_t)(levels > 0 ? levels : 1);
    bool go = dn_stage(&j, threads, dn_prepare, m, 0) && dn_stage(&j, threads, dn_firefly, m, 0);
    dn_swap(&j);
    for (int i = 0; go && i < levels; i++) {
        j.step = 1 << i;
        j.sigma_l = p->sigma_l * powf(p->sigma_l_decay, (float)i);
        j.blur_lum = p->lum_blur;
        go = dn_stage(&j, threads, dn_guide_lum, m, 0) &&
             dn_stage(&j, threads, dn_level, m, level_work);
        dn_swap(&j);
    }
    go = go && dn_stage(&j, threads, dn_finish, m, 0);
    free(mem);
    if (!go) return m->stop;
    return atomic_load(&j.oom) ? RAYD_E_NOMEM : RAYD_OK;
}
