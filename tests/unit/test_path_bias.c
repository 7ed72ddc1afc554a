/* test_path_bias.c -- the path tracer's next-event estimation (NEE) is
 * unbiased: it must agree with the plain estimator that finds light only
 * by the sampled paths (render_settings.no_nee, a tests-only switch).  The
 * scene is the case that once differed: a large emitter over a white floor
 * with a clear glass sphere between.  NEE used to test its shadow rays
 * with Whitted's transparent shadows, so light straight through the glass
 * was added on top of the refracted caustic that the paths already carry:
 * the image came out 15% too bright here, the caustic under the sphere 58%.
 * Now NEE's shadow rays stop at every surface, and the image's mean and
 * the caustic's both agree with the plain estimator within 1.5% (three
 * standard errors of the plain estimator at these sample counts, and the
 * bias was many times that). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "rayd/rayd.h"
#include "scene/scene.h"

static const char *SCENE =
    "{\"camera\": {\"position\": [0, 3, 2.2], \"look_at\": [0, 0, 0.2], \"fov_x\": 50},"
    " \"render\": {\"width\": 32, \"height\": 32, \"samples\": 1, \"max_depth\": 6,"
    "  \"integrator\": \"path\", \"background\": [0, 0, 0]},"
    " \"materials\": {\"white\": {\"color\": [0.8, 0.8, 0.8], \"diffuse\": 1},"
    "  \"lamp\": {\"color\": [0, 0, 0], \"emission\": [3, 3, 3]},"
    "  \"glass\": {\"color\": [1, 1, 1], \"transparency\": 1, \"ior\": 1.5}},"
    " \"objects\": ["
    "  {\"type\": \"quad\", \"corner\": [-3, 0, -3], \"edge1\": [0, 0, 6], \"edge2\": [6, 0, 0],"
    "   \"material\": \"white\"},"
    "  {\"type\": \"quad\", \"corner\": [-1.5, 4, -1.5], \"edge1\": [3, 0, 0],"
    "   \"edge2\": [0, 0, 3], \"material\": \"lamp\"},"
    "  {\"type\": \"sphere\", \"center\": [0, 1, 0], \"radius\": 0.6, \"material\": \"glass\"}]}";

/* The mean linear radiance (R+G+B)/3 of the region of scene s rendered
 * at spp samples, with or without NEE. */
static double mean_of(rayd_scene *s, bool nee, int spp, struct rayd_region reg) {
    s->rs.no_nee = !nee;
    struct rayd_error err = {0};
    rayd_accum *a = NULL;
    float *rgb = NULL;
    struct rayd_render_opts opts = {.threads = 0};
    double sum = 0;
    if (rayd_accum_new(s, &reg, &a, &err) != RAYD_OK ||
        rayd_render_pass(s, &opts, a, 0, spp, &err) != RAYD_OK ||
        rayd_accum_linear(a, &rgb, &err) != RAYD_OK) {
        CHECK(0, "render: %s", err.message);
    } else {
        for (int i = 0; i < reg.w * reg.h * 3; i++) sum += rgb[i];
    }
    free(rgb);
    rayd_accum_free(a);
    return sum / (reg.w * reg.h * 3);
}

static rayd_scene *parse(void) {
    rayd_scene *s = NULL;
    struct rayd_error err = {0};
    CHECK(rayd_scene_parse(SCENE, strlen(SCENE), NULL, &s, &err) == RAYD_OK, "%s", err.message);
    return s;
}

static void agree(const char *what, double nee, double plain) {
    double rel = (nee - plain) / plain;
    printf("  %s: NEE %.5f, paths alone %.5f, difference %+.2f%%\n", what, nee, plain, 100 * rel);
    CHECK(fabs(rel) < 0.015, "%s: NEE %.5f against the paths' %.5f (%+.2f%%)", what, nee, plain,
          100 * rel);
}

static void test_whole_image(void) {
    rayd_scene *s = parse();
    if (!s) return;
    struct rayd_region all = {0, 0, 32, 32};
    agree("image mean", mean_of(s, true, 256, all), mean_of(s, false, 1024, all));
    rayd_scene_free(s);
}

/* The floor under the sphere, where the caustic is (rows and columns
 * found from the geometry: the sphere's shadow on the floor). */
static void test_caustic(void) {
    rayd_scene *s = parse();
    if (!s) return;
    struct rayd_region under = {12, 14, 8, 6};
    agree("caustic", mean_of(s, true, 1024, under), mean_of(s, false, 4096, under));
    rayd_scene_free(s);
}

int main(void) {
    RUN(test_whole_image);
    RUN(test_caustic);
    CHECK_EXIT();
}
