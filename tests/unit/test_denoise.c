/* test_denoise.c -- the a-trous denoiser (core/render/denoise.c) on
 * synthetic images with known answers, its determinism (threads, windows
 * cut with the apron), and the denoised accumulator (accum_denoise.c):
 * regions equal the crop of the frame, the squared-luminance sums stay
 * exact over merged ranges, the scene keys and their errors; a resolve's
 * filter stopped by its cancel flag and ray budget (rayd_accum_watch). */
#include <pthread.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "check.h"
#include "render/accum.h"
#include "render/aov.h"
#include "render/denoise.h"
#include "scene_util.h"

/* A deterministic uniform number in [-1, 1) (an LCG; no libc rand). */
static float noise(uint32_t *st) {
    *st = *st * 1664525u + 1013904223u;
    return (float)((*st >> 8) / 8388608.0 - 1.0);
}

/* A w x h image of one flat surface: albedo a, lighting l (so radiance
 * a * l), normal +z, depth 1, per-pixel variance var. */
static struct denoise_px *flat(int w, int h, float a, float l, float var) {
    struct denoise_px *p = calloc((size_t)w * (size_t)h, sizeof *p);
    for (int i = 0; p && i < w * h; i++) {
        for (int k = 0; k < 3; k++) {
            p[i].a[k] = a;
            p[i].c[k] = a * l;
        }
        p[i].n[2] = 1;
        p[i].z = 1;
        p[i].alpha = 1;
        p[i].var = var;
    }
    return p;
}

static float *run(const struct denoise_px *in, int w, int h, int threads) {
    struct denoise_params p;
    denoise_defaults(&p);
    float *out = malloc((size_t)w * (size_t)h * 3 * sizeof *out);
    if (out && denoise_run(in, w, h, &p, threads, NULL, out) != RAYD_OK) {
        free(out);
        return NULL;
    }
    return out;
}

/* A constant image stays that constant. */
static void test_constant(void) {
    int w = 40, h = 30;
    struct denoise_px *in = flat(w, h, 0.6f, 0.5f, 0.01f);
    float *out = run(in, w, h, 2);
    double worst = 0;
    for (int i = 0; out && i < w * h * 3; i++) worst = fmax(worst, fabs(out[i] - 0.3));
    CHECK(out && worst < 1e-6, "a constant 0.3 came out off by %g", worst);
    free(in), free(out);
}

/* A noisy flat region converges to its mean: the error shrinks more than
 * fourfold and the mean is kept. */
static void test_flat_noise(void) {
    int w = 64, h = 64;
    struct denoise_px *in = flat(w, h, 0.5f, 1.0f, 0.2f * 0.2f / 3);
    uint32_t st = 7;
    for (int i = 0; i < w * h; i++) {
        float d = 0.2f * noise(&st);
        for (int k = 0; k < 3; k++) in[i].c[k] += d;
    }
    float *out = run(in, w, h, 1);
    double e_in = 0, e_out = 0, mean = 0;
    for (int i = 0; out && i < w * h; i++) {
        e_in += (in[i].c[0] - 0.5) * (in[i].c[0] - 0.5);
        e_out += (out[i * 3] - 0.5) * (out[i * 3] - 0.5);
        mean += out[i * 3];
    }
    mean /= w * h;
    CHECK(out && sqrt(e_out) < sqrt(e_in) / 4, "rmse %g from %g", sqrt(e_out / (w * h)),
          sqrt(e_in / (w * h)));
    CHECK_NEAR(mean, 0.5, 0.01);
    free(in), free(out);
}

/* Edges in the albedo and in the normals stay sharp under noise: the
 * pixels on each side keep their side's value. */
static void test_edges(void) {
    int w = 64, h = 32;
    struct denoise_px *in = flat(w, h, 0.8f, 1.0f, 0.05f * 0.05f / 3);
    uint32_t st = 11;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            struct denoise_px *p = &in[y * w + x];
            float a = x < w / 2 ? 0.8f : 0.2f, l = 1.0f;
            if (y >= h / 2 && x >= w / 2) { /* the lower right: a normal edge instead */
                a = 0.8f;
                l = 0.25f;
                p->n[0] = 1, p->n[2] = 0;
            }
            float d = 0.05f * noise(&st);
            for (int k = 0; k < 3; k++) {
                p->a[k] = a;
                p->c[k] = a * l * (1 + d);
            }
        }
    float *out = run(in, w, h, 2);
    for (int y = 2; out && y < h - 2; y++) {
        bool lower = y >= h / 2;
        CHECK_NEAR(out[(y * w + w / 2 - 1) * 3], 0.8, 0.04);
        CHECK_NEAR(out[(y * w + w / 2) * 3], lower ? 0.2 : 0.2, 0.02);
        CHECK_NEAR(out[(y * w + w / 2 - 2) * 3], 0.8, 0.04);
        CHECK_NEAR(out[(y * w + w / 2 + 1) * 3], 0.2, 0.02);
    }
    free(in), free(out);
}

/* One firefly is removed where it is, not spread over its neighbours. */
static void test_firefly(void) {
    int w = 48, h = 48;
    struct denoise_px *in = flat(w, h, 0.5f, 1.0f, 0.001f);
    struct denoise_px *f = &in[20 * w + 25];
    for (int k = 0; k < 3; k++) f->c[k] = 200;
    f->var = 2500;
    float *out = run(in, w, h, 1);
    double top = 0;
    for (int i = 0; out && i < w * h * 3; i++) top = fmax(top, out[i]);
    CHECK(out && top < 0.5 * 1.02, "the brightest pixel is %g, the flat 0.5", top);
    CHECK(out && fabs(out[(20 * w + 25) * 3] - 0.5) < 0.01, "the firefly's pixel is %g",
          out ? out[(20 * w + 25) * 3] : 0);
    free(in), free(out);
}

/* A flat surface of albedo 0.5 lit by light l(x, y) as n samples see it
 * when a quarter of their paths find 4 l and the rest nothing (or, with
 * rare, a tenth find 10 l): skewed noise, as of light found by few paths;
 * each pixel's variance from its own samples, as render.c keeps it. */
static struct denoise_px *skewed(int w, int h, int n, bool rare, double (*l)(int, int, int)) {
    struct denoise_px *in = flat(w, h, 0.5f, 1.0f, 0);
    uint32_t st = 9;
    for (int y = 0; in && y < h; y++)
        for (int x = 0; x < w; x++) {
            double s = 0, s2 = 0, lx = l(x, y, w);
            for (int k = 0; k < n; k++) {
                double u = (noise(&st) + 1) / 2, v = rare ? (u < 0.1 ? 10 : 0) : (u < 0.25 ? 4 : 0);
                s += v * lx;
                s2 += v * lx * v * lx;
            }
            double m = s / n, var = (s2 / n - m * m) / (n - 1);
            struct denoise_px *p = &in[y * w + x];
            for (int k = 0; k < 3; k++) p->c[k] = (float)(0.5 * m);
            p->var = (float)(0.25 * var);
        }
    return in;
}

static double light_flat(int x, int y, int w) {
    (void)x, (void)y, (void)w;
    return 1;
}

/* A tent: light rising from 0.1 at the left edge to 1 in the middle and
 * falling again, as towards a room's corners. */
static double light_tent(int x, int y, int w) {
    (void)y;
    double t = x < w / 2 ? (double)x / (w / 2) : (double)(w - x) / (w / 2);
    return 0.1 + 0.9 * t;
}

/* Skewed noise keeps its mean: weights that fall with a sample's own
 * brightness would darken it (the first filter lost 5%). */
static void test_skewed_mean(void) {
    int w = 64, h = 64;
    struct denoise_px *in = skewed(w, h, 16, true, light_flat);
    float *out = in ? run(in, w, h, 1) : NULL;
    double a = 0, b = 0;
    for (int i = 0; out && i < w * h; i++) a += in[i].c[0], b += out[i * 3];
    CHECK(out && fabs(b / a - 1) < 0.04, "the mean came out %.4f of the input's", out ? b / a : 0);
    free(in), free(out);
}

/* A gradient of light under that noise keeps its peak: the wide levels
 * must not average the middle with the darker sides (the first filter
 * kept 94%). */
static void test_light_gradient(void) {
    int w = 128, h = 64;
    struct denoise_px *in = skewed(w, h, 16, false, light_tent);
    float *out = in ? run(in, w, h, 1) : NULL;
    double peak = 0;
    for (int y = 8; out && y < h - 8; y++) peak += out[(y * w + w / 2) * 3] / (h - 16);
    CHECK(out && peak > 0.5 * 0.95, "the peak came out %.4f, the light's 0.5", peak);
    free(in), free(out);
}

/* A noisy image with edges, depth steps, background and a one-sample
 * (unknown variance) stripe: what the determinism tests filter. */
static struct denoise_px *busy(int w, int h) {
    struct denoise_px *in = flat(w, h, 0.5f, 1.0f, 0.01f);
    uint32_t st = 3;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            struct denoise_px *p = &in[y * w + x];
            for (int k = 0; k < 3; k++) p->a[k] = (x / 17 + y / 13 + k) % 3 ? 0.7f : 0.1f;
            p->n[0] = x > w / 2 ? 0.6f : 0;
            p->n[2] = x > w / 2 ? 0.8f : 1;
            p->z = 1 + (float)(y / 40);
            p->var = x % 50 == 7 ? -1 : 0.02f * (1 + noise(&st));
            for (int k = 0; k < 3; k++) p->c[k] = p->a[k] * (1 + 0.5f * noise(&st));
            if ((x - 30) * (x - 30) + (y - 20) * (y - 20) < 64) { /* a hole: nothing hit */
                memset(p, 0, sizeof *p);
                p->z = INFINITY;
                p->c[0] = p->c[1] = p->c[2] = 0.2f;
            }
        }
    in[50 * w + 60].c[1] = 500; /* a firefly */
    return in;
}

/* The same bits on 1, 2 and 3 threads. */
static void test_threads(void) {
    int w = 150, h = 110;
    struct denoise_px *in = busy(w, h);
    float *a = run(in, w, h, 1), *b = run(in, w, h, 2), *c = run(in, w, h, 3);
    size_t n = (size_t)w * (size_t)h * 3 * sizeof *a;
    CHECK(a && b && c && !memcmp(a, b, n) && !memcmp(a, c, n), "thread counts differ");
    free(in), free(a), free(b), free(c);
}

/* A window cut from the image with DENOISE_APRON pixels around region
 * (clipped at the image's edges) filters to the very pixels of the
 * whole image's region. */
static void window_case(const struct denoise_px *in, const float *whole, int w, int h, int rx,
                        int ry, int rw, int rh) {
    int x0 = rx - DENOISE_APRON < 0 ? 0 : rx - DENOISE_APRON;
    int y0 = ry - DENOISE_APRON < 0 ? 0 : ry - DENOISE_APRON;
    int x1 = rx + rw + DENOISE_APRON > w ? w : rx + rw + DENOISE_APRON;
    int y1 = ry + rh + DENOISE_APRON > h ? h : ry + rh + DENOISE_APRON;
    int ww = x1 - x0, wh = y1 - y0;
    struct denoise_px *win = malloc((size_t)ww * (size_t)wh * sizeof *win);
    for (int y = 0; y < wh; y++)
        memcpy(win + y * ww, in + (y0 + y) * w + x0, (size_t)ww * sizeof *win);
    float *out = run(win, ww, wh, 2);
    int bad = 0;
    for (int y = 0; out && y < rh; y++)
        bad += memcmp(out + ((size_t)(ry - y0 + y) * (size_t)ww + (size_t)(rx - x0)) * 3,
                      whole + ((size_t)(ry + y) * (size_t)w + (size_t)rx) * 3,
                      (size_t)rw * 3 * sizeof *out) != 0;
    CHECK(out && bad == 0, "region %d,%d,%d,%d: %d rows differ from the whole's", rx, ry, rw, rh,
          bad);
    free(win), free(out);
}

static void test_window(void) {
    int w = 260, h = 230;
    struct denoise_px *in = busy(w, h);
    float *whole = run(in, w, h, 1);
    if (!whole) return;
    window_case(in, whole, w, h, 100, 90, 32, 32);  /* inside: the apron all round */
    window_case(in, whole, w, h, 0, 5, 40, 20);     /* at the left edge */
    window_case(in, whole, w, h, 230, 200, 30, 30); /* the bottom right corner */
    window_case(in, whole, w, h, 55, 60, 1, 1);
    free(in), free(whole);
}

/* The apron is what a window needs: with one pixel less some region's
 * pixels differ (so the test above can fail).  Several regions: the
 * longest chain of dependence (a neighbour's firefly clamp, then each
 * level's farthest tap and its blurred luminance) is realised only where
 * the noise clamps a pixel at the chain's end. */
static void test_apron_needed(void) {
    int w = 260, h = 230;
    struct denoise_px *in = flat(w, h, 0.5f, 1.0f, 0.01f);
    uint32_t st = 5;
    for (int i = 0; i < w * h; i++) in[i].c[i % 3] *= 1 + 0.3f * noise(&st);
    float *whole = run(in, w, h, 1);
    int a = DENOISE_APRON - 1, rs = 32, ww = rs + 2 * a, differ = 0;
    struct denoise_px *win = malloc((size_t)ww * (size_t)ww * sizeof *win);
    for (int ry = 70; win && whole && ry <= 110; ry += 20)
        for (int rx = 70; rx <= 110; rx += 20) {
            for (int y = 0; y < ww; y++)
                memcpy(win + y * ww, in + (ry - a + y) * w + rx - a, (size_t)ww * sizeof *win);
            float *out = run(win, ww, ww, 1);
            for (int y = 0; out && y < rs; y++)
                differ += memcmp(out + ((size_t)(a + y) * (size_t)ww + (size_t)a) * 3,
                                 whole + ((size_t)(ry + y) * (size_t)w + (size_t)rx) * 3,
                                 (size_t)rs * 3 * sizeof *out) != 0;
            free(out);
        }
    CHECK(differ > 0, "an apron of %d pixels was enough for all nine regions", a);
    free(in), free(whole), free(win);
}

static const char *box_scene =
    "{\"render\": {\"width\": 96, \"height\": 80, \"samples\": 6, \"integrator\": \"path\"},"
    " \"camera\": {\"position\": [0, 1, 3.5], \"look_at\": [0, 0.8, 0], \"fov_y\": 50},"
    " \"materials\": {\"w\": {\"color\": [0.7, 0.7, 0.7]}, \"r\": {\"color\": [0.7, 0.1, 0.1]},"
    "   \"l\": {\"color\": [0, 0, 0], \"emission\": [8, 8, 8]}},"
    " \"objects\": [{\"type\": \"plane\", \"point\": [0, 0, 0], \"normal\": [0, 1, 0],"
    "   \"material\": \"w\"}, {\"type\": \"sphere\", \"center\": [0.3, 0.5, 0], \"radius\": 0.5,"
    "   \"material\": \"r\"}, {\"type\": \"sphere\", \"center\": [-1, 2, 0.5], \"radius\": 0.2,"
    "   \"material\": \"l\"}]}";

static rayd_image *denoised(const rayd_scene *s, struct rayd_region r, int threads) {
    rayd_accum *a = NULL;
    rayd_image *img = NULL;
    struct rayd_error err = {0};
    struct rayd_render_opts o = {.threads = threads, .tile = 16};
    if (rayd_accum_new_denoised(s, &r, &a, &err) == RAYD_OK &&
        rayd_render_pass(s, &o, a, 0, 6, &err) == RAYD_OK)
        rayd_accum_image(a, &img, &err);
    if (!img) printf("  %s\n", err.message);
    rayd_accum_free(a);
    return img;
}

/* A denoised region is the crop of the denoised frame, on any threads. */
static void test_accum_region(void) {
    rayd_scene *s = scene_from(box_scene);
    if (!s) return;
    rayd_image *whole = denoised(s, (struct rayd_region){0, 0, 0, 0}, 1);
    rayd_image *whole2 = denoised(s, (struct rayd_region){0, 0, 0, 0}, 2);
    rayd_image *part = denoised(s, (struct rayd_region){37, 21, 30, 25}, 2);
    CHECK(whole && whole2 &&
              !memcmp(rayd_image_pixels_const(whole), rayd_image_pixels_const(whole2), 96 * 80 * 3),
          "threads differ");
    int bad = 0;
    for (int y = 0; whole && part && y < 25; y++)
        bad += memcmp(rayd_image_pixels_const(part) + y * 30 * 3,
                      rayd_image_pixels_const(whole) + ((21 + y) * 96 + 37) * 3, 30 * 3) != 0;
    CHECK(whole && part && bad == 0, "%d rows of the region differ from the frame's", bad);
    rayd_accum *a = NULL, *b = NULL;
    struct rayd_error err = {0};
    rayd_accum_new_denoised(s, NULL, &a, NULL);
    rayd_accum_new_denoised(s, NULL, &b, NULL);
    rayd_render_sample_range(s, NULL, a, 0, 2, NULL);
    rayd_render_sample_range(s, NULL, b, 2, 4, NULL);
    CHECK(rayd_accum_denoised(a) && rayd_accum_merge(a, b, &err) == RAYD_E_ARG,
          "denoised accumulators merged");
    rayd_accum_free(a), rayd_accum_free(b);
    rayd_image_free(whole), rayd_image_free(whole2), rayd_image_free(part);
    rayd_scene_free(s);
}

/* rayd_accum_raw: a denoised region's raw sums resolve to the plain
 * render of the region; a plain accumulator is refused.  The memory a
 * denoised region holds counts its apron, clipped at the image's edges. */
static void test_accum_raw(void) {
    rayd_scene *s = scene_from(box_scene);
    if (!s) return;
    struct rayd_region r = {37, 21, 30, 25};
    rayd_accum *a = NULL, *raw = NULL, *plain = NULL;
    rayd_image *ri = NULL, *pi = NULL;
    struct rayd_error err = {0};
    rayd_accum_new_denoised(s, &r, &a, NULL);
    rayd_accum_new(s, &r, &plain, NULL);
    rayd_render_pass(s, NULL, a, 0, 6, NULL);
    rayd_render_pass(s, NULL, plain, 0, 6, NULL);
    CHECK(rayd_accum_raw(a, &raw, &err) == RAYD_OK && !rayd_accum_denoised(raw), "%s", err.message);
    rayd_accum_image(raw, &ri, NULL);
    rayd_accum_image(plain, &pi, NULL);
    CHECK(ri && pi && rayd_image_width(ri) == 30 &&
              !memcmp(rayd_image_pixels_const(ri), rayd_image_pixels_const(pi), 30 * 25 * 3),
          "the raw region is not the plain render");
    rayd_accum *none = a;
    CHECK(rayd_accum_raw(plain, &none, &err) == RAYD_E_ARG && !none, "a plain one taken");
    size_t held, peak, held_corner, peak_corner;
    rayd_accum_denoised_bytes(s, &r, &held, &peak);
    rayd_accum_denoised_bytes(s, &(struct rayd_region){0, 0, 30, 25}, &held_corner, &peak_corner);
    /* 96 x 80, the whole image (the apron reaches every edge); the corner's
     * apron is clipped at the left and top */
    size_t corner_w = 30 + DENOISE_APRON < 96 ? 30 + DENOISE_APRON : 96;
    size_t corner_h = 25 + DENOISE_APRON < 80 ? 25 + DENOISE_APRON : 80;
    CHECK(held == (size_t)96 * 80 * (3 + AOV_SUMS) * 8 &&
              held_corner == corner_w * corner_h * (3 + AOV_SUMS) * 8 && peak > held / 2,
          "held %zu, corner %zu, peak %zu", held, held_corner, peak);
    rayd_image_free(ri), rayd_image_free(pi);
    rayd_accum_free(a), rayd_accum_free(raw), rayd_accum_free(plain);
    rayd_scene_free(s);
}

/* The squared-luminance sums are exact: two merged ranges hold the very
 * bits of one render. */
static void test_moment_exact(void) {
    rayd_scene *s = scene_from(box_scene);
    if (!s) return;
    rayd_accum *one = NULL, *lo = NULL, *hi = NULL;
    rayd_accum_new(s, NULL, &one, NULL), rayd_accum_new(s, NULL, &lo, NULL);
    rayd_accum_new(s, NULL, &hi, NULL);
    rayd_accum_aov_enable(one, NULL), rayd_accum_aov_enable(lo, NULL);
    rayd_accum_aov_enable(hi, NULL);
    rayd_render_sample_range(s, NULL, one, 0, 7, NULL);
    rayd_render_sample_range(s, NULL, lo, 0, 3, NULL);
    rayd_render_sample_range(s, NULL, hi, 3, 7, NULL);
    CHECK(rayd_accum_merge(lo, hi, NULL) == RAYD_OK, "merge");
    int bad = 0, lit = 0;
    for (int i = 0; i < 96 * 80; i++) {
        bad += one->aov[i * AOV_SUMS + AOV_LUM2] != lo->aov[i * AOV_SUMS + AOV_LUM2];
        lit += one->aov[i * AOV_SUMS + AOV_LUM2] > 0;
    }
    CHECK(bad == 0 && lit > 1000, "%d pixels' moments differ, %d lit", bad, lit);
    rayd_accum_free(one), rayd_accum_free(lo), rayd_accum_free(hi);
    rayd_scene_free(s);
}

/* render.denoise, clamp_indirect, filter_glossy: kept, and bad values
 * named by their JSON Pointer. */
static void test_scene_keys(void) {
    rayd_scene *s = scene_from("{\"render\": {\"denoise\": true, \"clamp_indirect\": 10,"
                               " \"filter_glossy\": 0.5}}");
    struct rayd_scene_info info;
    if (s) rayd_scene_info(s, &info);
    CHECK(s && info.denoise == 1 && info.clamp_indirect == 10 && info.filter_glossy == 0.5,
          "the keys were not kept");
    struct rayd_error err = {0};
    CHECK(s && rayd_scene_set_bias(s, 2, -1, &err) == RAYD_OK, "set");
    if (s) rayd_scene_info(s, &info);
    CHECK(s && info.clamp_indirect == 2 && info.filter_glossy == 0.5, "set_bias");
    CHECK(s && rayd_scene_set_bias(s, -1, 2, &err) == RAYD_E_ARG, "filter_glossy 2 taken");
    rayd_scene_free(s);
    static const struct {
        const char *json, *path;
    } bad[] = {{"{\"render\": {\"denoise\": 1}}", "/render/denoise"},
               {"{\"render\": {\"clamp_indirect\": -1}}", "/render/clamp_indirect"},
               {"{\"render\": {\"clamp_indirect\": \"x\"}}", "/render/clamp_indirect"},
               {"{\"render\": {\"filter_glossy\": 1.5}}", "/render/filter_glossy"}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        rayd_scene *b = NULL;
        struct rayd_error e = {0};
        CHECK(rayd_scene_parse(bad[i].json, strlen(bad[i].json), NULL, &b, &e) != RAYD_OK &&
                  !strcmp(e.path, bad[i].path),
              "%s: path '%s' (%s)", bad[i].json, e.path, e.message);
        rayd_scene_free(b);
    }
}

/* render.clamp_indirect darkens nothing direct and caps the rest: the
 * clamped image is never brighter, and is darker somewhere. */
static void test_clamp(void) {
    rayd_scene *s = scene_from(box_scene), *c = scene_from(box_scene);
    if (!s || !c) return;
    rayd_scene_set_bias(c, 0.002, -1, NULL);
    rayd_image *a = render_all(s, 2), *b = render_all(c, 2);
    int brighter = 0, darker = 0;
    for (int i = 0; a && b && i < 96 * 80 * 3; i++) {
        brighter += rayd_image_pixels_const(b)[i] > rayd_image_pixels_const(a)[i];
        darker += rayd_image_pixels_const(b)[i] < rayd_image_pixels_const(a)[i];
    }
    CHECK(a && b && brighter == 0 && darker > 100, "%d brighter, %d darker", brighter, darker);
    rayd_image_free(a), rayd_image_free(b);
    rayd_scene_free(s), rayd_scene_free(c);
}

/* rayd_accum_filtered: its resolves give the denoised acc's very bytes and
 * floats; a plain accumulator is refused. */
static void test_accum_filtered(void) {
    rayd_scene *s = scene_from(box_scene);
    if (!s) return;
    struct rayd_region r = {37, 21, 30, 25};
    rayd_accum *a = NULL, *f = NULL, *plain = NULL;
    rayd_image *ai = NULL, *fi = NULL;
    float *al = NULL, *fl = NULL;
    struct rayd_error err = {0};
    rayd_accum_new_denoised(s, &r, &a, NULL);
    rayd_render_pass(s, NULL, a, 0, 6, NULL);
    CHECK(rayd_accum_filtered(a, &f, &err) == RAYD_OK && !rayd_accum_denoised(f), "%s",
          err.message);
    rayd_accum_image(a, &ai, NULL), rayd_accum_image(f, &fi, NULL);
    rayd_accum_linear(a, &al, NULL), rayd_accum_linear(f, &fl, NULL);
    CHECK(ai && fi && rayd_image_width(fi) == 30 &&
              !memcmp(rayd_image_pixels_const(ai), rayd_image_pixels_const(fi), 30 * 25 * 3),
          "the filtered accumulator's image differs");
    CHECK(al && fl && !memcmp(al, fl, 30 * 25 * 3 * sizeof *al), "its floats differ");
    rayd_accum_new(s, &r, &plain, NULL);
    rayd_accum *none = a;
    CHECK(rayd_accum_filtered(plain, &none, &err) == RAYD_E_ARG && !none, "a plain one taken");
    rayd_free(al), rayd_free(fl);
    rayd_image_free(ai), rayd_image_free(fi);
    rayd_accum_free(a), rayd_accum_free(f), rayd_accum_free(plain);
    rayd_scene_free(s);
}

/* The box's denoised frame (6 samples) resolved with acc watched by cancel
 * and a budget of left rays (-2: none); its image in *img when it resolves. */
static enum rayd_status watched(const rayd_scene *s, atomic_int *cancel, long left,
                                rayd_image **img) {
    rayd_accum *a = NULL;
    atomic_int_least64_t budget;
    atomic_init(&budget, left);
    struct rayd_error err = {0};
    *img = NULL;
    enum rayd_status st = rayd_accum_new_denoised(s, NULL, &a, &err);
    if (st == RAYD_OK) st = rayd_render_pass(s, NULL, a, 0, 6, &err);
    if (st == RAYD_OK) {
        rayd_accum_watch(a, cancel, left == -2 ? NULL : &budget);
        st = rayd_accum_image(a, img, &err);
    }
    rayd_accum_free(a);
    return st;
}

static void *cancel_soon(void *flag) {
    nanosleep(&(struct timespec){0, 20 * 1000 * 1000}, NULL);
    atomic_store((atomic_int *)flag, 1);
    return NULL;
}

/* A watched resolve: its filter takes exactly RAYD_DENOISE_RAYS a pixel
 * from the budget (one ray fewer stops it, RAYD_E_LIMIT), stops at once
 * for a raised flag and within a chunk of rows for one raised while it
 * runs (RAYD_E_CANCELED), and gives the unwatched bytes when not stopped. */
static void test_accum_watch(void) {
    rayd_scene *s = scene_from(box_scene);
    if (!s) return;
    atomic_int flag;
    atomic_init(&flag, 0);
    long work = 96L * 80 * RAYD_DENOISE_RAYS;
    rayd_image *plain = denoised(s, (struct rayd_region){0, 0, 0, 0}, 1), *img = NULL;
    enum rayd_status st = watched(s, &flag, work, &img);
    CHECK(st == RAYD_OK && plain && img &&
              !memcmp(rayd_image_pixels_const(plain), rayd_image_pixels_const(img), 96 * 80 * 3),
          "a budget of exactly the filter's work: status %d or other bytes", st);
    rayd_image_free(img);
    st = watched(s, &flag, work - 1, &img);
    CHECK(st == RAYD_E_LIMIT && !img, "one ray short of the filter's work: status %d", st);
    st = watched(s, &flag, -1, &img); /* spent by the render's other tiles */
    CHECK(st == RAYD_E_LIMIT && !img, "a budget spent before: status %d", st);
    atomic_store(&flag, 1);
    st = watched(s, &flag, -2, &img);
    CHECK(st == RAYD_E_CANCELED && !img, "the flag raised before: status %d", st);
    rayd_image_free(plain);
    rayd_scene_free(s);
    /* 768x768, one sample of nothing: about a second of filtering on one
     * thread, canceled 20 ms in */
    s = scene_from("{\"render\": {\"width\": 768, \"height\": 768, \"samples\": 1},"
                   " \"objects\": []}");
    if (!s) return;
    rayd_accum *a = NULL;
    atomic_store(&flag, 0);
    pthread_t th;
    st = rayd_accum_new_denoised(s, NULL, &a, NULL);
    if (st == RAYD_OK) st = rayd_render_pass(s, NULL, a, 0, 1, NULL);
    rayd_accum_watch(a, &flag, NULL);
    bool started = st == RAYD_OK && pthread_create(&th, NULL, cancel_soon, &flag) == 0;
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    if (started) st = rayd_accum_image(a, &img, NULL);
    clock_gettime(CLOCK_MONOTONIC, &t1);
    if (started) pthread_join(th, NULL);
    CHECK(started && st == RAYD_E_CANCELED && !img,
          "canceled while it filtered: status %d after %.3f s", st,
          (double)(t1.tv_sec - t0.tv_sec) + (t1.tv_nsec - t0.tv_nsec) * 1e-9);
    rayd_image_free(img);
    rayd_accum_free(a);
    rayd_scene_free(s);
}

int main(void) {
    RUN(test_constant);
    RUN(test_flat_noise);
    RUN(test_edges);
    RUN(test_firefly);
    RUN(test_skewed_mean);
    RUN(test_light_gradient);
    RUN(test_threads);
    RUN(test_window);
    RUN(test_apron_needed);
    RUN(test_accum_region);
    RUN(test_accum_raw);
    RUN(test_moment_exact);
    RUN(test_scene_keys);
    RUN(test_clamp);
    RUN(test_accum_watch);
    RUN(test_accum_filtered);
    CHECK_EXIT();
}
