/* test_scene_cost.c -- the admission estimate (core/scene/scene_cost.c)
 * against the rays really cast, on scenes shaped to cost more than they
 * look: a tree of glass, instances over one spot, many area light samples,
 * long paths.  The estimate may err high within a stated factor, never low.
 */
#include "check.h"
#include "scene_util.h"

/* A 7 x 7 x 3 grid of touching glass spheres filling the view, 16 x 16
 * pixels: the Whitted tree branches at nearly every hit. */
static rayd_scene *glass_grid(int depth) {
    char objs[16384] = "";
    size_t n = 0;
    for (int i = -3; i <= 3; i++)
        for (int j = -3; j <= 3; j++)
            for (int k = 0; k < 3; k++)
                n += (size_t)snprintf(objs + n, sizeof objs - n,
                                      "%s{\"type\": \"sphere\", \"center\": [%d, %d, %d], "
                                      "\"radius\": 0.55, \"material\": \"glass\"}",
                                      n ? ", " : "", i, j, -k);
    char *json = malloc(n + 1024);
    sprintf(json,
            "{\"camera\": {\"position\": [0, 0, 4], \"look_at\": [0, 0, 0], \"fov_x\": 40},"
            " \"render\": {\"width\": 16, \"height\": 16, \"samples\": 1, \"max_depth\": %d},"
            " \"materials\": {\"glass\": {\"color\": [1, 1, 1], \"diffuse\": 0,"
            " \"transparency\": 0.9, \"ior\": 1.5}},"
            " \"lights\": [{\"type\": \"point\", \"position\": [3, 5, 8], \"intensity\": 1}],"
            " \"objects\": [%s]}",
            depth, objs);
    rayd_scene *s = scene_from(json);
    free(json);
    return s;
}

/* Rays cast rendering region of s. */
static uint64_t rays_cast(const rayd_scene *s, struct rayd_region region) {
    uint64_t rays = 0;
    rayd_image *img = NULL;
    if (rayd_image_new(region.w, region.h, &img, NULL) != RAYD_OK) return 0;
    rayd_render_into(s, &region, img, 0, 0, NULL, &rays, NULL);
    rayd_image_free(img);
    return rays;
}

static double priced(const rayd_scene *s, struct rayd_region region) {
    struct rayd_scene_info info;
    rayd_scene_info(s, &info);
    return (double)region.w * region.h * info.samples * info.rays_per_sample;
}

/* The glass tree at max_depth 8 (the whole 16 x 16), 16 (the middle 2 x 2)
 * and 20 (the middle pixel): priced at or above the rays cast, and within
 * GLASS_FACTOR of them (the bound 2^(D+1) - 1 counts a full binary tree;
 * the grid reaches about 1.75 per level). */
#define GLASS_FACTOR 64.0
static void test_glass_tree(void) {
    const struct {
        int depth;
        struct rayd_region reg;
    } cases[] = {{8, {0, 0, 16, 16}}, {16, {7, 7, 2, 2}}, {20, {8, 8, 1, 1}}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        rayd_scene *s = glass_grid(cases[i].depth);
        CHECK(s != NULL, "depth %d", cases[i].depth);
        if (!s) continue;
        double est = priced(s, cases[i].reg);
        uint64_t rays = rays_cast(s, cases[i].reg);
        printf("  max_depth %d: %llu rays cast, %.0f priced (%.1fx)\n", cases[i].depth,
               (unsigned long long)rays, est, est / (double)rays);
        CHECK(rays > 0 && est >= (double)rays, "depth %d: priced %.0f < %llu cast", cases[i].depth,
              est, (unsigned long long)rays);
        CHECK(est <= GLASS_FACTOR * (double)rays, "depth %d: priced %.0f > %g x %llu",
              cases[i].depth, est, GLASS_FACTOR, (unsigned long long)rays);
        rayd_scene_free(s);
    }
}

/* n instances of one sphere, each moved by `step` along x; with a ground
 * sphere of radius `ground` far below when ground > 0 (a large box around
 * everything, which must not hide a cluster). */
static rayd_scene *instances(int n, double step, double ground) {
    size_t cap = (size_t)n * 96 + 2048, len = 0;
    char *objs = malloc(cap);
    objs[0] = 0;
    for (int k = 0; k < n; k++)
        len += (size_t)snprintf(objs + len, cap - len,
                                "%s{\"type\": \"instance\", \"group\": \"g\", \"transform\":"
                                " {\"translate\": [%.6f, 0, 0]}}",
                                k ? ", " : "", k * step);
    if (ground > 0)
        snprintf(objs + len, cap - len,
                 ", {\"type\": \"sphere\", \"center\": [0, %.1f, 0], \"radius\": %.1f,"
                 " \"material\": \"m\"}",
                 -ground - 2, ground);
    char *json = malloc(cap + 1024);
    sprintf(json,
            "{\"camera\": {\"position\": [0, 0, 5], \"look_at\": [0, 0, 0], \"fov_x\": 40},"
            " \"render\": {\"width\": 4, \"height\": 4, \"samples\": 1, \"max_depth\": 1},"
            " \"materials\": {\"m\": {\"color\": [0.8, 0.8, 0.8]}},"
            " \"lights\": [{\"type\": \"point\", \"position\": [3, 5, 8], \"intensity\": 1}],"
            " \"groups\": {\"g\": [{\"type\": \"sphere\", \"center\": [0, 0, 0], \"radius\": 1,"
            " \"material\": \"m\"}]},"
            " \"objects\": [%s]}",
            objs);
    rayd_scene *s = scene_from(json);
    free(objs);
    free(json);
    return s;
}

static double rays_per_sample(const rayd_scene *s) {
    struct rayd_scene_info info;
    rayd_scene_info(s, &info);
    return info.rays_per_sample;
}

/* 2,000 instances over one spot cost a ray about 2,000 tests: priced at
 * least 100 times the same instances side by side, which cost a plain
 * ray's (1 camera + 1 shadow ray a sample); a huge ground sphere around the
 * cluster does not hide it. */
static void test_instances_overlap(void) {
    rayd_scene *apart = instances(2000, 3.0, 0), *over = instances(2000, 1e-4, 0),
               *hidden = instances(2000, 1e-4, 1000);
    CHECK(apart && over && hidden, "parse");
    if (apart && over && hidden) {
        double a = rays_per_sample(apart), o = rays_per_sample(over), h = rays_per_sample(hidden);
        printf("  per sample: apart %.1f, over one spot %.1f, hidden by a ground sphere %.1f\n", a,
               o, h);
        CHECK(a == 2.0, "apart: %g, want 2 (a camera and a shadow ray, plain)", a);
        CHECK(o >= 100 * a, "over one spot: %g, apart %g", o, a);
        CHECK(h >= 100 * a, "hidden: %g, apart %g", h, a);
    }
    rayd_scene_free(apart);
    rayd_scene_free(over);
    rayd_scene_free(hidden);
}

/* 4 area lights of 64 samples, a wall filling the view: every pixel casts
 * 256 shadow rays; the price is at least that, and not twice it. */
static void test_light_samples(void) {
    char lights[4096] = "";
    size_t n = 0;
    for (int i = 0; i < 4; i++)
        n += (size_t)snprintf(
            lights + n, sizeof lights - n,
            "%s{\"type\": \"area\", \"position\": [%d, 3, 2], \"edge1\": [1, 0, 0],"
            " \"edge2\": [0, 0, 1], \"samples\": 64, \"intensity\": 0.3}",
            n ? ", " : "", i - 2);
    char json[8192];
    snprintf(json, sizeof json,
             "{\"camera\": {\"position\": [0, 0, 5], \"look_at\": [0, 0, 0], \"fov_x\": 30},"
             " \"render\": {\"width\": 8, \"height\": 8, \"samples\": 2, \"max_depth\": 0},"
             " \"lights\": [%s],"
             " \"objects\": [{\"type\": \"box\", \"min\": [-20, -20, -1], \"max\": [20, 20, 0]}]}",
             lights);
    rayd_scene *s = scene_from(json);
    CHECK(s != NULL, "parse");
    if (!s) return;
    struct rayd_region all = {0, 0, 8, 8};
    double est = priced(s, all);
    uint64_t rays = rays_cast(s, all);
    printf("  %llu rays cast, %.0f priced\n", (unsigned long long)rays, est);
    CHECK(est >= (double)rays && est < 2.0 * (double)rays, "priced %.0f, cast %llu", est,
          (unsigned long long)rays);
    CHECK(rays_per_sample(s) >= 257, "%g a sample", rays_per_sample(s));
    rayd_scene_free(s);
}

/* A closed white room, path traced: the price counts the bounces past
 * Russian roulette, so it grows with max_depth and stays above the rays
 * cast (within 8 times). */
static rayd_scene *white_room(int depth) {
    char json[2048];
    snprintf(json, sizeof json,
             "{\"camera\": {\"position\": [0, 0, 0], \"look_at\": [0, 0, -1], \"fov_x\": 60},"
             " \"render\": {\"width\": 8, \"height\": 8, \"samples\": 8, \"max_depth\": %d,"
             " \"integrator\": \"path\"},"
             " \"materials\": {\"white\": {\"color\": [0.95, 0.95, 0.95], \"diffuse\": 1}},"
             " \"lights\": [{\"type\": \"point\", \"position\": [0, 1, -1], \"intensity\": 1}],"
             " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, 0], \"radius\": 3,"
             " \"material\": \"white\"}]}",
             depth);
    return scene_from(json);
}

static void test_path_depth(void) {
    rayd_scene *shallow = white_room(4), *deep = white_room(32);
    CHECK(shallow && deep, "parse");
    if (shallow && deep) {
        struct rayd_region all = {0, 0, 8, 8};
        double es = priced(shallow, all), ed = priced(deep, all);
        uint64_t rd = rays_cast(deep, all);
        printf("  max_depth 4: %.0f priced; 32: %.0f priced, %llu cast\n", es, ed,
               (unsigned long long)rd);
        CHECK(ed > 2 * es, "deep %.0f, shallow %.0f", ed, es);
        CHECK(ed >= (double)rd && ed <= 8.0 * (double)rd, "priced %.0f, cast %llu", ed,
              (unsigned long long)rd);
    }
    rayd_scene_free(shallow);
    rayd_scene_free(deep);
}

int main(void) {
    RUN(test_glass_tree);
    RUN(test_instances_overlap);
    RUN(test_light_samples);
    RUN(test_path_depth);
    CHECK_EXIT();
}
