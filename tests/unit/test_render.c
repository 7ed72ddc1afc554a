/* test_render.c -- regions, tiles, threads, PNG, cancel and progress,
 * through the public API only.  The determinism rule: a region equals the
 * same crop of the full render byte for byte, whatever the thread count or
 * tile size. */
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <time.h>

#include "accel/bvh16.h"
#include "check.h"
#include "render/render.h"
#include "scene_util.h"

/* The Whitted example at a small size with several samples: reflection,
 * refraction, two lights and anti-aliasing all take part. */
static rayd_scene *small_whitted(void) {
    rayd_scene *s = whitted_sized(97, 61);
    CHECK(s != NULL, "scenes/whitted.json at 97 x 61");
    return s;
}

static int same_crop(const rayd_image *full, const rayd_image *crop, int x, int y) {
    int fw = rayd_image_width(full), cw = rayd_image_width(crop), ch = rayd_image_height(crop);
    for (int row = 0; row < ch; row++)
        if (memcmp(rayd_image_pixels_const(full) + ((size_t)(y + row) * fw + x) * 3,
                   rayd_image_pixels_const(crop) + (size_t)row * cw * 3, (size_t)cw * 3) != 0)
            return 0;
    return 1;
}

static void test_threads_and_tiles_give_same_bytes(void) {
    rayd_scene *s = small_whitted();
    if (!s) return;
    rayd_image *a = NULL, *b = NULL, *c = NULL;
    struct rayd_render_opts o1 = {.threads = 1};
    struct rayd_render_opts o2 = {.threads = 2, .tile = 7};
    struct rayd_render_opts o3 = {.threads = 5, .tile = 1000};
    CHECK(rayd_render(s, &o1, &a, NULL) == RAYD_OK, "1 thread");
    CHECK(rayd_render(s, &o2, &b, NULL) == RAYD_OK, "2 threads");
    CHECK(rayd_render(s, &o3, &c, NULL) == RAYD_OK, "5 threads");
    CHECK(a && b && c && same_crop(a, b, 0, 0) && same_crop(a, c, 0, 0),
          "identical bytes for 1, 2 and 5 threads");
    rayd_image_free(a);
    rayd_image_free(b);
    rayd_image_free(c);
    rayd_scene_free(s);
}

static void test_region_equals_crop_of_full(void) {
    rayd_scene *s = small_whitted();
    if (!s) return;
    rayd_image *full = render_all(s, 2);
    CHECK(full != NULL, "full render");
    struct rayd_region regions[] = {{13, 9, 37, 29}, {0, 0, 1, 1}, {96, 60, 1, 1}, {50, 0, 47, 61}};
    for (int i = 0; full && i < 4; i++) {
        struct rayd_render_opts o = {.region = regions[i], .threads = 2, .tile = 8};
        rayd_image *crop = NULL;
        CHECK(rayd_render(s, &o, &crop, NULL) == RAYD_OK, "region %d", i);
        CHECK(crop && rayd_image_width(crop) == regions[i].w &&
                  rayd_image_height(crop) == regions[i].h,
              "region %d size", i);
        CHECK(crop && same_crop(full, crop, regions[i].x, regions[i].y), "region %d bytes", i);
        rayd_image_free(crop);
    }
    /* rayd_render_into: tiles assembled by hand equal the full render too. */
    rayd_image *asm_img = NULL;
    CHECK(rayd_image_new(97, 61, &asm_img, NULL) == RAYD_OK, "new image");
    for (int y = 0; asm_img && y < 61; y += 20)
        for (int x = 0; x < 97; x += 30) {
            struct rayd_region r = {x, y, x + 30 > 97 ? 97 - x : 30, y + 20 > 61 ? 61 - y : 20};
            CHECK(rayd_render_into(s, &r, asm_img, x, y, NULL, NULL, NULL) == RAYD_OK, "tile");
        }
    CHECK(full && asm_img && same_crop(full, asm_img, 0, 0), "hand-tiled image equals full");
    rayd_image_free(asm_img);
    rayd_image_free(full);
    rayd_scene_free(s);
}

static void test_bad_regions_are_refused(void) {
    rayd_scene *s = scene_from("{\"render\": {\"width\": 20, \"height\": 10}}");
    if (!s) return;
    struct rayd_region bad[] = {{-1, 0, 5, 5}, {20, 0, 1, 1}, {0, 10, 1, 1},
                                {15, 0, 6, 1}, {0, 5, 1, 6},  {0, 0, 0, 5}};
    const char *field[] = {"x", "x", "y", "w", "h", "w"};
    for (int i = 0; i < 6; i++) {
        struct rayd_error err;
        struct rayd_render_opts o = {.region = bad[i]};
        rayd_image *img = NULL;
        CHECK(rayd_render(s, &o, &img, &err) == RAYD_E_ARG, "region %d refused", i);
        CHECK(img == NULL, "no image on error");
        CHECK(strcmp(err.path, field[i]) == 0, "region %d names %s, got %s", i, field[i], err.path);
    }
    rayd_scene_free(s);
}

static void test_png_round_trip(void) {
    rayd_scene *s = small_whitted();
    if (!s) return;
    rayd_image *img = render_all(s, 2), *back = NULL;
    void *buf = NULL;
    size_t len = 0;
    CHECK(rayd_png_encode(img, -1, &buf, &len, NULL) == RAYD_OK, "encode");
    CHECK(len > 8 && memcmp(buf, "\x89PNG\r\n\x1a\n", 8) == 0, "PNG signature");
    CHECK(rayd_png_decode(buf, len, 0, &back, NULL) == RAYD_OK, "decode");
    CHECK(back && same_crop(img, back, 0, 0), "pixels survive the round trip");
    struct rayd_error err;
    rayd_image *none = NULL;
    CHECK(rayd_png_decode(buf, len, 100, &none, &err) == RAYD_E_LIMIT, "pixel limit on decode");
    CHECK(rayd_png_decode(buf, len / 2, 0, &none, &err) != RAYD_OK, "truncated PNG refused");
    CHECK(none == NULL, "no image from a bad PNG");
    rayd_free(buf);
    rayd_image_free(back);
    rayd_image_free(img);
    rayd_scene_free(s);
}

struct progress {
    atomic_long last;
    atomic_int calls;
    long total;
};

static void on_progress(void *user, long done, long total) {
    struct progress *p = user;
    long prev = atomic_load(&p->last);
    while (done > prev && !atomic_compare_exchange_weak(&p->last, &prev, done)) continue;
    p->total = total;
    atomic_fetch_add(&p->calls, 1);
}

static void test_progress_and_cancel(void) {
    rayd_scene *s = small_whitted();
    if (!s) return;
    struct progress p = {0};
    struct rayd_render_stats st = {0};
    struct rayd_render_opts o = {
        .threads = 2, .tile = 16, .progress = on_progress, .progress_user = &p, .stats = &st};
    rayd_image *img = NULL;
    CHECK(rayd_render(s, &o, &img, NULL) == RAYD_OK, "render");
    CHECK(atomic_load(&p.calls) == 7 * 4, "one call per tile: %d", atomic_load(&p.calls));
    CHECK(atomic_load(&p.last) == 97 * 61 && p.total == 97 * 61, "progress reaches the total");
    CHECK(st.rays >= 97 * 61 * 4, "rays counted: %llu", (unsigned long long)st.rays);
    rayd_image_free(img);

    atomic_int cancel = 1;
    struct rayd_render_opts oc = {.threads = 2, .cancel = &cancel};
    struct rayd_error err;
    img = NULL;
    CHECK(rayd_render(s, &oc, &img, &err) == RAYD_E_CANCELED, "canceled");
    CHECK(img == NULL, "no image when canceled");
    rayd_scene_free(s);
}

static void test_seed_changes_samples_only(void) {
    const char *a = "{\"render\": {\"width\": 16, \"height\": 16, \"samples\": 8, \"seed\": 1},"
                    " \"objects\": [{\"type\": \"sphere\", \"center\": [0,0,-3],"
                    " \"material\": {\"emission\": [1,1,1]}}]}";
    const char *b = "{\"render\": {\"width\": 16, \"height\": 16, \"samples\": 8, \"seed\": 2},"
                    " \"objects\": [{\"type\": \"sphere\", \"center\": [0,0,-3],"
                    " \"material\": {\"emission\": [1,1,1]}}]}";
    rayd_scene *sa = scene_from(a), *sb = scene_from(b), *sa2 = scene_from(a);
    if (!sa || !sb || !sa2) return;
    rayd_image *ia = render_all(sa, 1), *ib = render_all(sb, 2), *ia2 = render_all(sa2, 2);
    CHECK(same_crop(ia, ia2, 0, 0), "same seed, same bytes");
    CHECK(!same_crop(ia, ib, 0, 0), "another seed moves the edge samples");
    /* anti-aliasing: edge pixels take intermediate values */
    int mid = 0;
    const uint8_t *px = rayd_image_pixels_const(ia);
    for (int k = 0; k < 16 * 16; k++) mid += px[3 * k] > 0 && px[3 * k] < 255;
    CHECK(mid > 4, "%d anti-aliased edge pixels", mid);
    rayd_image_free(ia);
    rayd_image_free(ib);
    rayd_image_free(ia2);
    rayd_scene_free(sa);
    rayd_scene_free(sb);
    rayd_scene_free(sa2);
}

/* Images are rendered in 4x4 blocks of packets (camera rays; with Whitted
 * also their shadow rays and mirror rays); every pixel must equal
 * render_pixel's, the one-ray integrators'.  A region of the 10x10-sphere
 * scene (a third of its spheres are mirrors) at its own size, the small
 * Whitted example (glass, several samples), and a corner of the Cornell
 * box (path tracing, 128 samples). */
static void test_blocks_equal_one_ray_pixels(void) {
    size_t len;
    char *text = read_file("bench/scenes/spheres10.json", &len);
    CHECK(text != NULL, "bench/scenes/spheres10.json readable");
    rayd_scene *scenes[3] = {NULL, small_whitted(), NULL};
    struct rayd_error err;
    if (text) CHECK(rayd_scene_parse(text, len, NULL, &scenes[0], &err) == RAYD_OK, "parse");
    free(text);
    text = read_file("scenes/cornell.json", &len); /* the path tracer: its camera rays too */
    CHECK(text != NULL, "scenes/cornell.json readable");
    if (text) CHECK(rayd_scene_parse(text, len, NULL, &scenes[2], &err) == RAYD_OK, "parse");
    free(text);
    const struct rayd_region regions[3] = {{900, 560, 90, 70}, {0, 0, 0, 0}, {150, 120, 10, 7}};
    for (int k = 0; k < 3; k++) {
        rayd_scene *sc = scenes[k];
        if (!sc) continue;
        struct rayd_render_opts o = {.threads = 2, .region = regions[k]};
        rayd_image *img = NULL;
        CHECK(rayd_render(sc, &o, &img, NULL) == RAYD_OK, "render");
        if (!img) continue;
        int w = rayd_image_width(img), h = rayd_image_height(img), differ = 0;
        const uint8_t *px = rayd_image_pixels_const(img);
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) {
                uint64_t rays = 0;
                vec3 c = render_pixel(sc, regions[k].x + x, regions[k].y + y, &rays);
                const uint8_t *p = px + ((size_t)y * w + x) * 3;
                differ += p[0] != render_srgb8(c.x) || p[1] != render_srgb8(c.y) ||
                          p[2] != render_srgb8(c.z);
            }
        CHECK(differ == 0, "scene %d: %d of %d pixels differ from render_pixel", k, differ, w * h);
        rayd_image_free(img);
        rayd_scene_free(sc);
    }
}

/* The table-driven sRGB encoding equals the formula (srgb_ref) everywhere:
 * a sweep, random values, and both sides of every step between bytes. */
static void test_srgb_bytes_equal_the_formula(void) {
    int bad = 0, n = 0;
    for (int i = -10; i <= 1100000; i++, n++) bad += render_srgb8(i / 1e6) != srgb_ref(i / 1e6);
    unsigned long long x = 88172645463325252ull;
    for (int i = 0; i < 1000000; i++, n++) {
        x ^= x << 13, x ^= x >> 7, x ^= x << 17;
        double c = ldexp((double)(x >> 11), -53) * (i % 3 ? 1.0 : 0.01);
        bad += render_srgb8(c) != srgb_ref(c);
    }
    for (int k = 1; k < 256; k++) { /* find the step into k by bisection on the formula */
        double lo = 0, hi = 1;
        for (int it = 0; it < 200 && nextafter(lo, 2) < hi; it++) {
            double mid = lo + (hi - lo) / 2;
            if (srgb_ref(mid) >= k)
                hi = mid;
            else
                lo = mid;
        }
        double around[4] = {nextafter(lo, 0), lo, hi, nextafter(hi, 2)};
        for (int j = 0; j < 4; j++, n++) bad += render_srgb8(around[j]) != srgb_ref(around[j]);
    }
    double odd[8] = {NAN, -NAN, -INFINITY, INFINITY, -0.0, 1.0, 0x1p-1074, 1.7e308};
    for (int j = 0; j < 8; j++, n++) bad += render_srgb8(odd[j]) != (odd[j] >= 1 ? 255 : 0);
    double edges[4] = {0x1p-13, nextafter(0x1p-13, 0), nextafter(1.0, 0), -1e-300};
    for (int j = 0; j < 4; j++, n++) bad += render_srgb8(edges[j]) != srgb_ref(edges[j]);
    CHECK(bad == 0, "%d of %d values encode differently", bad, n);
}

/* The block encoder (48 values at once, with AVX-512 where it runs) gives
 * render_srgb8's bytes: odd values, values either side of every step, and
 * random ones, in both modes. */
static void test_srgb_blocks_equal_one_value(void) {
    double v[48 * 64];
    int n = 0;
    const double odd[12] = {NAN, -NAN,      -INFINITY, INFINITY, -0.0, 0.0,
                            1.0, 0x1p-1074, 1.7e308,   0x1p-13,  -0.5, nextafter(1.0, 0)};
    for (int j = 0; j < 12; j++) v[n++] = odd[j];
    unsigned long long x = 0x9e3779b97f4a7c15ull;
    for (int k = 1; k < 256; k++) { /* each step's neighbourhood, from the scalar encoder */
        double lo = 0, hi = 1;
        for (int it = 0; it < 200 && nextafter(lo, 2) < hi; it++) {
            double mid = lo + (hi - lo) / 2;
            if (render_srgb8(mid) >= k)
                hi = mid;
            else
                lo = mid;
        }
        v[n++] = lo, v[n++] = hi;
    }
    while (n < 48 * 64) {
        x ^= x << 13, x ^= x >> 7, x ^= x << 17;
        v[n] = ldexp((double)(x >> 11), -53) * (n % 3 ? 1.2 : 0.01);
        n++;
    }
    int bad = 0;
    for (int way = CPU_WAY_BEST; way <= CPU_WAY_BASE; way++) {
        cpu_force((enum cpu_way)way);
        for (int b = 0; b < 64; b++) {
            uint8_t out[48];
            render_srgb48(v + 48 * b, out);
            for (int k = 0; k < 48; k++) bad += out[k] != render_srgb8(v[48 * b + k]);
        }
    }
    cpu_force(CPU_WAY_BEST);
    CHECK(bad == 0, "%d of %d block bytes differ from render_srgb8", bad, 3 * 48 * 64);
}

/* ---- run-time limits: the meter (base/meter.h) -------------------------------- */

static double now_s(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

/* A 1 x 1 scene whose one pixel is very costly: a 4 x 4 x 4 grid of glass
 * spheres seen from outside at max_depth depth, `samples` samples: every
 * hit casts a reflected and a refracted ray, so the rays grow about 1.7
 * times a bounce (some 1e9 at depth 32 and 16 samples). */
static rayd_scene *glass_pixel(int depth, int samples) {
    size_t cap = 16384, n = 0;
    char *t = malloc(cap);
    if (!t) return NULL;
    n += (size_t)snprintf(t + n, cap - n,
                          "{\"render\": {\"width\": 1, \"height\": 1, \"samples\": %d, "
                          "\"max_depth\": %d}, \"camera\": {\"position\": [0.3, 0.2, -12], "
                          "\"look_at\": [1.0, 1.2, 0], \"fov_x\": 20}, \"materials\": {\"glass\": "
                          "{\"transparency\": 0.9, \"reflectivity\": 0.1, \"ior\": 1.5}}, "
                          "\"lights\": [{\"type\": \"point\", \"position\": [0, 20, -20]}], "
                          "\"objects\": [",
                          samples, depth);
    for (int i = 0; i < 64; i++)
        n += (size_t)snprintf(t + n, cap - n,
                              "%s{\"type\": \"sphere\", \"center\": [%g, %g, %g], \"radius\": 1, "
                              "\"material\": \"glass\"}",
                              i ? ", " : "", (i % 4) * 2.2 - 3.3, (i / 4 % 4) * 2.2 - 3.3,
                              (i / 16) * 2.2 - 3.3);
    snprintf(t + n, cap - n, "]}");
    rayd_scene *s = scene_from(t);
    free(t);
    return s;
}

/* A 1 x 1 scene of m instances of a group of m spheres, all in one place,
 * the camera ray passing through every box and missing every sphere: one
 * ray meets m * m spheres (some 13 s at m = 10000 on one core). */
static rayd_scene *instances_pixel(int m) {
    size_t cap = (size_t)m * 120 + 512, n = 0;
    char *t = malloc(cap);
    if (!t) return NULL;
    n += (size_t)snprintf(t + n, cap - n,
                          "{\"render\": {\"width\": 1, \"height\": 1, \"max_depth\": 0}, "
                          "\"camera\": {\"position\": [0.9, 0.9, -10], \"look_at\": [0.9, 0.9, "
                          "0]}, \"groups\": {\"g\": [");
    for (int i = 0; i < m; i++)
        n += (size_t)snprintf(t + n, cap - n, "%s{\"type\": \"sphere\", \"radius\": 1}",
                              i ? ", " : "");
    n += (size_t)snprintf(t + n, cap - n, "]}, \"objects\": [");
    for (int i = 0; i < m; i++)
        n += (size_t)snprintf(t + n, cap - n, "%s{\"type\": \"instance\", \"group\": \"g\"}",
                              i ? ", " : "");
    snprintf(t + n, cap - n, "]}");
    struct rayd_limits lim = {0};
    rayd_limits_default(&lim);
    lim.max_bytes = cap;
    rayd_scene *s = NULL;
    struct rayd_error err = {0};
    if (rayd_scene_parse(t, strlen(t), &lim, &s, &err) != RAYD_OK)
        printf("  instances scene did not parse: %s\n", err.message);
    free(t);
    return s;
}

struct raiser {
    atomic_int *flag;
    double after; /* seconds */
};

static void *raise_later(void *arg) {
    struct raiser *r = arg;
    struct timespec ts = {0, (long)(r->after * 1e9)};
    nanosleep(&ts, NULL);
    atomic_store(r->flag, 1);
    return NULL;
}

/* Renders s's one pixel with the cancel flag raised 50 ms in: the seconds
 * the render took, *st its status. */
static double cancel_mid_pixel(const rayd_scene *s, int threads, enum rayd_status *st,
                               uint64_t *rays) {
    atomic_int cancel = 0;
    struct raiser r = {&cancel, 0.05};
    pthread_t th;
    struct rayd_render_stats stats = {0};
    struct rayd_render_opts o = {.threads = threads, .cancel = &cancel, .stats = &stats};
    rayd_image *img = NULL;
    double t0 = now_s();
    if (pthread_create(&th, NULL, raise_later, &r) != 0) return -1;
    *st = rayd_render(s, &o, &img, NULL);
    double took = now_s() - t0;
    pthread_join(th, NULL);
    rayd_image_free(img);
    *rays = stats.rays;
    return took;
}

/* A cancel raised while the one pixel is traced stops it within
 * milliseconds (the bound here is generous: a busy machine, ASan), where
 * the flag was looked at only between rows of blocks before: the glass
 * pixel would have run for minutes, the instances' one ray for tens of
 * seconds. */
static void test_cancel_mid_pixel(void) {
    rayd_scene *glass = glass_pixel(32, 16);
    CHECK(glass != NULL, "the glass scene");
    enum rayd_status st = RAYD_OK;
    uint64_t rays = 0;
    double took = glass ? cancel_mid_pixel(glass, 1, &st, &rays) : 0;
    CHECK(st == RAYD_E_CANCELED, "glass: canceled, not %s", rayd_status_name(st));
    CHECK(took < 3, "glass: stopped %.3f s after the start (cancel at 0.05 s)", took);
    CHECK(rays > 0, "glass: the rays cast up to the cancel are counted");
    rayd_scene_free(glass);

    rayd_scene *inst = instances_pixel(10000);
    CHECK(inst != NULL, "the instances scene");
    took = inst ? cancel_mid_pixel(inst, 2, &st, &rays) : 0;
    CHECK(st == RAYD_E_CANCELED, "instances: canceled, not %s", rayd_status_name(st));
    CHECK(took < 3, "instances: stopped %.3f s after the start (cancel at 0.05 s)", took);
    rayd_scene_free(inst);
}

/* The ray budget: a render whose rays fit it is the same bytes as one
 * without; one ray less stops it with RAYD_E_LIMIT; the rays counted are
 * the rays the render reports; a small budget stops a huge pixel soon. */
static void test_ray_budget(void) {
    rayd_scene *s = small_whitted();
    if (!s) return;
    struct rayd_render_stats st = {0};
    struct rayd_render_opts o = {.threads = 2, .tile = 16, .stats = &st};
    rayd_image *plain = NULL, *img = NULL;
    CHECK(rayd_render(s, &o, &plain, NULL) == RAYD_OK, "render");
    uint64_t total = st.rays, one_by_one = 0;
    for (int y = 0; y < 61; y++)
        for (int x = 0; x < 97; x++) render_pixel(s, x, y, &one_by_one);
    CHECK(total == one_by_one, "rays reported %llu, counted pixel by pixel %llu",
          (unsigned long long)total, (unsigned long long)one_by_one);

    atomic_int_least64_t left = (int_least64_t)total;
    struct rayd_render_opts ob = {.threads = 3, .tile = 8, .stats = &st, .rays_left = &left};
    CHECK(rayd_render(s, &ob, &img, NULL) == RAYD_OK, "a budget of exactly its rays");
    CHECK(img && plain && same_crop(plain, img, 0, 0), "the same bytes under a budget");
    CHECK(st.rays == total && atomic_load(&left) == 0, "rays %llu, left %lld",
          (unsigned long long)st.rays, (long long)atomic_load(&left));
    rayd_image_free(img);
    img = NULL;

    atomic_store(&left, (int_least64_t)total - 1);
    struct rayd_error err = {0};
    CHECK(rayd_render(s, &ob, &img, &err) == RAYD_E_LIMIT, "one ray over the budget");
    CHECK(img == NULL && err.code == RAYD_E_LIMIT && err.path[0] == 0, "no image, no path");
    rayd_image_free(plain);
    rayd_scene_free(s);

    rayd_scene *glass = glass_pixel(32, 16);
    if (!glass) return;
    atomic_store(&left, 100000);
    double t0 = now_s();
    CHECK(rayd_render(glass, &ob, &img, &err) == RAYD_E_LIMIT, "the glass pixel over 1e5 rays");
    CHECK(now_s() - t0 < 3, "stopped within %.3f s", now_s() - t0);
    CHECK(st.rays >= 100000 && st.rays <= 100000 + 3 * 1100,
          "rays %llu: the budget and at most "
          "a look's worth more a thread",
          (unsigned long long)st.rays);
    rayd_scene_free(glass);
}

int main(void) {
    RUN(test_threads_and_tiles_give_same_bytes);
    RUN(test_region_equals_crop_of_full);
    RUN(test_bad_regions_are_refused);
    RUN(test_png_round_trip);
    RUN(test_progress_and_cancel);
    RUN(test_seed_changes_samples_only);
    RUN(test_srgb_bytes_equal_the_formula);
    RUN(test_srgb_blocks_equal_one_value);
    RUN(test_blocks_equal_one_ray_pixels);
    RUN(test_cancel_mid_pixel);
    RUN(test_ray_budget);
    CHECK_EXIT();
}
