/* denoise.c -- the denoiser's quality, measured (make bench-denoise).
 *
 *     build/bench/denoise SCENE.json REF_SAMPLES NAME
 *
 * Renders SCENE (at its own size) with REF_SAMPLES samples as the
 * reference (the last samples a pixel may have, so its noise is
 * independent of the others'), then samples 0..N-1 for N = 4, 16, 64 and
 * 256, and prints a markdown table of each image's distance to the
 * reference: RMSE of the displayed values (sRGB, 0..1, the 8-bit PNG's
 * curve before rounding) and SSIM (of their luminance, 8x8 windows every
 * 4 pixels), for
 *
 *   raw       the plain render of N samples;
 *   rayd      rayd's denoiser (core/render/denoise.c, its defaults);
 *   a-trous   the same five-level a-trous filter without variance guidance
 *             (Dammertz et al. 2010: a luminance scale that is a fixed
 *             fraction of the pixel's light, halved each level);
 *   bilateral a joint bilateral filter (11x11, spatial sigma 3, guided by
 *             albedo, normal and colour), written here alone, as a baseline.
 *
 * and the sample-count equivalence: the raw sample count of the same RMSE,
 * log-log between the raw points (past 256, the 1 / N law).  Then the
 * filter's time per megapixel on 1 and 2 threads, the median of
 * DENOISE_RUNS runs (default 5).  DENOISE_CACHE=DIR keeps the renders
 * (keyed by the scene's text and the samples; clear it when the renderer
 * changes); DENOISE_SWEEP=1 adds the parameter sweep at 16 samples.
 */
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "render/accum.h"
#include "render/aov.h"
#include "render/denoise.h"
#include "rayd/rayd.h"

static double now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

static rayd_accum *render(const rayd_scene *s, int k0, int n) {
    rayd_accum *a = NULL;
    struct rayd_error err = {0};
    struct rayd_render_opts o = {.threads = 2};
    if (rayd_accum_new(s, NULL, &a, &err) != RAYD_OK || rayd_accum_aov_enable(a, &err) != RAYD_OK ||
        rayd_render_sample_range(s, &o, a, k0, k0 + n, &err) != RAYD_OK) {
        fprintf(stderr, "denoise: %s\n", err.message);
        exit(1);
    }
    return a;
}

/* The filter's input, as accum_denoise.c makes it. */
static struct denoise_px *inputs(const rayd_accum *a) {
    size_t px = (size_t)a->r.w * (size_t)a->r.h;
    struct denoise_px *in = calloc(px, sizeof *in);
    double n = a->n;
    for (size_t i = 0; i < px; i++) {
        const double *s = a->sum + i * 3, *ao = a->aov + i * AOV_SUMS;
        float f[RAYD_AOV_FLOATS];
        aov_resolve(ao, a->n, f);
        for (int k = 0; k < 3; k++) {
            in[i].c[k] = (float)(s[k] / n);
            in[i].a[k] = f[AOV_ALBEDO_R + k];
            in[i].n[k] = f[AOV_NORMAL_X + k];
        }
        in[i].z = f[AOV_DEPTH];
        in[i].alpha = f[AOV_ALPHA];
        double l = (0.2126 * s[0] + 0.7152 * s[1] + 0.0722 * s[2]) / n;
        double v = n > 1 ? (ao[AOV_LUM2] / n - l * l) / (n - 1) : -1;
        in[i].var = (float)(n > 1 ? fmax(v, 0) : -1);
    }
    return in;
}

/* One render of n samples as the bench uses it: the raw image and the
 * filter's input. */
struct shot {
    int w, h;
    float *raw;
    struct denoise_px *in;
};

/* DENOISE_CACHE=DIR keeps each render in DIR, keyed by the scene's text
 * and n, so that a change of the filter is measured again in seconds
 * (the renders are the same bytes: the same seed, the same sums). */
static char *cache_path(const char *text, size_t len, int k0, int n) {
    const char *dir = getenv("DENOISE_CACHE");
    if (!dir || !*dir) return NULL;
    uint64_t hsh = 1469598103934665603u;
    for (size_t i = 0; i < len; i++) hsh = (hsh ^ (unsigned char)text[i]) * 1099511628211u;
    char *p = malloc(strlen(dir) + 64);
    sprintf(p, "%s/%016llx-%d-%d.bin", dir, (unsigned long long)hsh, k0, n);
    return p;
}

static bool shot_load(const char *path, struct shot *sh) {
    FILE *f = path ? fopen(path, "rb") : NULL;
    bool ok = f && fread(&sh->w, sizeof sh->w, 1, f) == 1 && fread(&sh->h, sizeof sh->h, 1, f) == 1;
    size_t px = ok ? (size_t)sh->w * (size_t)sh->h : 0;
    if (ok) {
        sh->raw = malloc(px * 3 * sizeof *sh->raw);
        sh->in = malloc(px * sizeof *sh->in);
        ok = fread(sh->raw, sizeof *sh->raw, px * 3, f) == px * 3 &&
             fread(sh->in, sizeof *sh->in, px, f) == px;
    }
    if (f) fclose(f);
    return ok;
}

static void shot_save(const char *path, const struct shot *sh) {
    FILE *f = path ? fopen(path, "wb") : NULL;
    if (!f) return;
    size_t px = (size_t)sh->w * (size_t)sh->h;
    fwrite(&sh->w, sizeof sh->w, 1, f);
    fwrite(&sh->h, sizeof sh->h, 1, f);
    fwrite(sh->raw, sizeof *sh->raw, px * 3, f);
    fwrite(sh->in, sizeof *sh->in, px, f);
    fclose(f);
}

static struct shot shoot(const rayd_scene *s, const char *text, size_t len, int k0, int n) {
    struct shot sh = {0};
    char *path = cache_path(text, len, k0, n);
    if (!shot_load(path, &sh)) {
        rayd_accum *a = render(s, k0, n);
        sh.w = a->r.w, sh.h = a->r.h;
        rayd_accum_linear(a, &sh.raw, NULL);
        sh.in = inputs(a);
        rayd_accum_free(a);
        shot_save(path, &sh);
    }
    free(path);
    return sh;
}

/* The joint bilateral baseline. */
static void bilateral(const struct denoise_px *in, int w, int h, float *out) {
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            const struct denoise_px *p = &in[y * w + x];
            double c[3] = {0, 0, 0}, ws = 0;
            for (int dy = -5; dy <= 5; dy++)
                for (int dx = -5; dx <= 5; dx++) {
                    int qx = x + dx, qy = y + dy;
                    if (qx < 0 || qy < 0 || qx >= w || qy >= h) continue;
                    const struct denoise_px *q = &in[qy * w + qx];
                    double e = (dx * dx + dy * dy) / (2.0 * 9), da = 0, dn = 0, dc = 0;
                    for (int k = 0; k < 3; k++) {
                        da += (p->a[k] - q->a[k]) * (p->a[k] - q->a[k]);
                        dn += (p->n[k] - q->n[k]) * (p->n[k] - q->n[k]);
                        double cp = p->c[k] / (p->c[k] + 1), cq = q->c[k] / (q->c[k] + 1);
                        dc += (cp - cq) * (cp - cq);
                    }
                    e += da / (2 * 0.01) + dn / (2 * 0.04) + dc / (2 * 0.04);
                    double wt = exp(-e);
                    for (int k = 0; k < 3; k++) c[k] += wt * q->c[k];
                    ws += wt;
                }
            for (int k = 0; k < 3; k++) out[(y * w + x) * 3 + k] = (float)(c[k] / ws);
        }
}

static double shown(double v) {
    if (!(v > 0)) return 0;
    if (v >= 1) return 1;
    return v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1 / 2.4) - 0.055;
}

struct score {
    double rmse, ssim;
};

static struct score score(const float *img, const float *ref, int w, int h) {
    double se = 0;
    size_t px = (size_t)w * (size_t)h;
    double *la = malloc(px * sizeof *la), *lb = malloc(px * sizeof *lb);
    for (size_t i = 0; i < px; i++) {
        double a[3], b[3];
        for (int k = 0; k < 3; k++) {
            a[k] = shown(img[i * 3 + k]);
            b[k] = shown(ref[i * 3 + k]);
            se += (a[k] - b[k]) * (a[k] - b[k]);
        }
        la[i] = 0.2126 * a[0] + 0.7152 * a[1] + 0.0722 * a[2];
        lb[i] = 0.2126 * b[0] + 0.7152 * b[1] + 0.0722 * b[2];
    }
    double ssim = 0, c1 = 1e-4, c2 = 9e-4;
    int windows = 0;
    for (int y = 0; y + 8 <= h; y += 4)
        for (int x = 0; x + 8 <= w; x += 4) {
            double ma = 0, mb = 0, va = 0, vb = 0, cov = 0;
            for (int j = 0; j < 8; j++)
                for (int i = 0; i < 8; i++) {
                    ma += la[(y + j) * w + x + i];
                    mb += lb[(y + j) * w + x + i];
                }
            ma /= 64, mb /= 64;
            for (int j = 0; j < 8; j++)
                for (int i = 0; i < 8; i++) {
                    double da = la[(y + j) * w + x + i] - ma, db = lb[(y + j) * w + x + i] - mb;
                    va += da * da, vb += db * db, cov += da * db;
                }
            va /= 63, vb /= 63, cov /= 63;
            ssim +=
                (2 * ma * mb + c1) * (2 * cov + c2) / ((ma * ma + mb * mb + c1) * (va + vb + c2));
            windows++;
        }
    free(la), free(lb);
    return (struct score){sqrt(se / (double)(px * 3)), windows ? ssim / windows : 0};
}

/* The raw sample count whose RMSE^2 is e2: log-log interpolation between
 * the raw points, past the last one the 1 / N law (the reference's own
 * noise ignored, so an upper bound). */
static double equivalent(const int *ns, const double *raw2, double e2) {
    if (e2 >= raw2[0]) return ns[0] * raw2[0] / e2;
    for (int i = 1; i < 4; i++)
        if (e2 >= raw2[i]) {
            double t = log(raw2[i - 1] / e2) / log(raw2[i - 1] / raw2[i]);
            return exp(log(ns[i - 1]) + t * log((double)ns[i] / ns[i - 1]));
        }
    return ns[3] * raw2[3] / e2;
}

/* The a-trous baseline: Dammertz et al.'s fixed luminance scale, on the
 * pixels' own luminances, the same scale at every level. */
static void baseline(struct denoise_params *p) {
    denoise_defaults(p);
    p->variance = false;
    p->sigma_l = 4;
    p->sigma_l_decay = 1;
    p->lum_blur = false;
}

/* DENOISE_SWEEP=1: the 16-sample RMSE over a grid of the parameters (how
 * denoise_defaults was chosen; with DENOISE_CACHE the renders are kept,
 * and a sweep takes seconds). */
static void sweep(const struct denoise_px *in, int w, int h, const float *ref, float *out) {
    static const float sl[] = {4, 6, 8}, dc[] = {0.6f, 0.7f, 1}, sz[] = {0.005f, 0.02f, 0.05f};
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            for (int k = 0; k < 3; k++)
                for (int b = 0; b < 2; b++) {
                    struct denoise_params p;
                    denoise_defaults(&p);
                    p.sigma_l = sl[i], p.sigma_l_decay = dc[j], p.sigma_z = sz[k];
                    p.lum_blur = b;
                    denoise_run(in, w, h, &p, 2, NULL, out);
                    struct score s = score(out, ref, w, h);
                    printf("sweep sigma_l %g decay %g sigma_z %g lum_blur %d: %.4f / %.3f\n", sl[i],
                           dc[j], sz[k], b, s.rmse, s.ssim);
                    fflush(stdout);
                }
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double cpu_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

/* The filter's time per megapixel on 1 and 2 threads: the median of
 * DENOISE_RUNS runs (default 5; at least 1), wall clock and the CPU time
 * of all its threads (on a loaded host the wall clock is mostly the
 * others' work). */
static void timing(const struct denoise_px *in, int w, int h, float *out) {
    const char *e = getenv("DENOISE_RUNS");
    int reps = e && atoi(e) > 0 ? atoi(e) : 5;
    if (reps > 99) reps = 99;
    double mp = (double)w * h / 1e6;
    for (int th = 1; th <= 2; th++) {
        struct denoise_params p;
        denoise_defaults(&p);
        double t[99], c[99];
        for (int k = 0; k < reps; k++) {
            double t1 = now(), c1 = cpu_now();
            denoise_run(in, w, h, &p, th, NULL, out);
            t[k] = (now() - t1) / mp;
            c[k] = (cpu_now() - c1) / mp;
        }
        qsort(t, (size_t)reps, sizeof *t, cmp_double);
        qsort(c, (size_t)reps, sizeof *c, cmp_double);
        printf("filter time: %.3f s per megapixel on %d thread%s (median of %d; %.3f to %.3f), "
               "CPU %.3f s\n",
               t[reps / 2], th, th > 1 ? "s" : "", reps, t[0], t[reps - 1], c[reps / 2]);
    }
}

/* The reference is the last samples of the range a pixel may have
 * (rayd.h: at most 65536), so its noise is independent of the N-sample
 * renders' (samples 0..N-1): it adds the same error to every figure. */
#define RAYD_REF_END 65536

int main(int argc, char **argv) {
    if (argc != 4) {
        fprintf(stderr, "usage: denoise SCENE.json REF_SAMPLES NAME\n");
        return 2;
    }
    size_t len = 0;
    char *text = NULL;
    struct rayd_error err = {0};
    rayd_scene *s = NULL;
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    char dir[4096];
    snprintf(dir, sizeof dir, "%s", argv[1]);
    char *slash = strrchr(dir, '/');
    if (slash) *slash = 0;
    lim.asset_dir = slash ? dir : ".";
    lim.asset_confine = 0;
    if (rayd_read_file(argv[1], 1 << 26, &text, &len, &err) != RAYD_OK ||
        rayd_scene_parse(text, len, &lim, &s, &err) != RAYD_OK) {
        fprintf(stderr, "denoise: %s: %s\n", argv[1], err.message);
        return 1;
    }
    int refn = atoi(argv[2]), w = 0, h = 0;
    if (refn < 256 || refn > RAYD_REF_END - 256) {
        fprintf(stderr, "denoise: REF_SAMPLES must be 256..%d\n", RAYD_REF_END - 256);
        return 2;
    }
    double t0 = now();
    struct shot ref = shoot(s, text, len, RAYD_REF_END - refn, refn);
    w = ref.w, h = ref.h;
    float *rf = ref.raw;
    fprintf(stderr, "%s: reference of %d samples at %dx%d in %.1f s\n", argv[3], refn, w, h,
            now() - t0);
    static const int ns[] = {4, 16, 64, 256};
    double raw2[4], den2[4];
    float *out = malloc((size_t)w * (size_t)h * 3 * sizeof *out);
    printf("\n%s, %dx%d, reference %d samples: RMSE (sRGB 0..1) / SSIM\n\n", argv[3], w, h, refn);
    printf("| samples | raw | rayd (denoised) | a-trous, no variance | joint bilateral |\n");
    printf("|---:|---|---|---|---|\n");
    struct denoise_px *in16 = NULL;
    for (int i = 0; i < 4; i++) {
        struct shot sh = shoot(s, text, len, 0, ns[i]);
        struct score r = score(sh.raw, rf, w, h), d = {0}, t = {0}, b = {0};
        struct denoise_params p;
        denoise_defaults(&p);
        denoise_run(sh.in, w, h, &p, 2, NULL, out);
        d = score(out, rf, w, h);
        baseline(&p);
        denoise_run(sh.in, w, h, &p, 2, NULL, out);
        t = score(out, rf, w, h);
        bilateral(sh.in, w, h, out);
        b = score(out, rf, w, h);
        raw2[i] = r.rmse * r.rmse;
        den2[i] = d.rmse * d.rmse;
        printf("| %d | %.4f / %.3f | %.4f / %.3f | %.4f / %.3f | %.4f / %.3f |\n", ns[i], r.rmse,
               r.ssim, d.rmse, d.ssim, t.rmse, t.ssim, b.rmse, b.ssim);
        fflush(stdout);
        if (ns[i] == 16)
            in16 = sh.in;
        else
            free(sh.in);
        free(sh.raw);
    }
    printf("\nsample-count equivalence (raw samples of the same RMSE):");
    for (int i = 0; i < 3; i++)
        printf(" denoised %d ~ raw %.0f;", ns[i], equivalent(ns, raw2, den2[i]));
    printf("\n");
    if (getenv("DENOISE_SWEEP")) sweep(in16, w, h, rf, out);
    timing(in16, w, h, out);
    free(in16), free(out);
    free(rf);
    free(ref.in);
    rayd_scene_free(s);
    rayd_free(text);
    return 0;
}
