/* envbench.c -- what sampling the environment map buys the path tracer.
 *
 * Renders a region of SCENE (a path-traced scene with an image environment)
 * once at REF samples as the reference (seed 1), then at 16, 64 and 256
 * samples (seed 0) with the environment importance-sampled and without (the
 * tests' switch, rs.env.sample: BSDF sampling alone), and prints the RMSE
 * of each against the reference, over linear RGB, with the render times.
 *
 *   build/bench/envbench [SCENE.json [X,Y,W,H [REF]]]
 *       defaults: scenes/environment.json, its central 160 x 100, 4096
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "rayd/rayd.h"
#include "scene/scene.h"

static double now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + ts.tv_nsec * 1e-9;
}

static float *render(rayd_scene *s, struct rayd_region r, int samples, uint64_t seed, bool sampled,
                     double *secs) {
    s->rs.samples = samples;
    s->rs.seed = seed;
    s->rs.env.sample = sampled;
    float *px = calloc((size_t)r.w * r.h * 3, sizeof *px);
    uint64_t rays = 0;
    struct rayd_error err = {0};
    double t = now();
    if (!px || rayd_render_linear_into(s, &r, px, r.w, 0, 0, NULL, &rays, &err) != RAYD_OK) {
        fprintf(stderr, "envbench: render failed: %s\n", err.message);
        exit(1);
    }
    *secs = now() - t;
    return px;
}

static double rmse(const float *a, const float *b, size_t n) {
    double e = 0;
    for (size_t i = 0; i < n; i++) e += (a[i] - b[i]) * (double)(a[i] - b[i]);
    return sqrt(e / n);
}

int main(int argc, char **argv) {
    const char *path = argc > 1 ? argv[1] : "scenes/environment.json";
    struct rayd_region r = {80, 50, 160, 100};
    if (argc > 2 && sscanf(argv[2], "%d,%d,%d,%d", &r.x, &r.y, &r.w, &r.h) != 4) return 2;
    int ref_spp = argc > 3 ? atoi(argv[3]) : 4096;
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    lim.max_samples = 65536;
    lim.asset_dir = ".";
    lim.asset_confine = 0;
    char *text = NULL;
    size_t len = 0;
    struct rayd_error err = {0};
    rayd_scene *s = NULL;
    if (rayd_read_file(path, lim.max_bytes, &text, &len, &err) != RAYD_OK ||
        rayd_scene_parse(text, len, &lim, &s, &err) != RAYD_OK) {
        fprintf(stderr, "envbench: %s: %s %s\n", path, err.path, err.message);
        return 1;
    }
    free(text);
    if (s->rs.env.kind != ENV_IMAGE) {
        fprintf(stderr, "envbench: %s has no image environment\n", path);
        return 1;
    }
    size_t n = (size_t)r.w * r.h * 3;
    double secs;
    float *ref = render(s, r, ref_spp, 1, true, &secs);
    printf("%s, region %d,%d,%d,%d, reference %d samples (%.1f s)\n", path, r.x, r.y, r.w, r.h,
           ref_spp, secs);
    printf("samples  RMSE sampled  RMSE not sampled  ratio  time sampled  time not\n");
    for (int spp = 16; spp <= 256; spp *= 4) {
        double t_on, t_off;
        float *on = render(s, r, spp, 0, true, &t_on), *off = render(s, r, spp, 0, false, &t_off);
        double e_on = rmse(on, ref, n), e_off = rmse(off, ref, n);
        printf("%7d  %12.4f  %16.4f  %5.2f  %10.2f s  %6.2f s\n", spp, e_on, e_off, e_off / e_on,
               t_on, t_off);
        free(on);
        free(off);
    }
    free(ref);
    rayd_scene_free(s);
    return 0;
}
