/* fuzz_scene.c -- libFuzzer target: scene JSON text through the whole
 * loader (syntax check, cJSON, validation, mesh decoding, BVH builds).
 * Limits are lowered so the fuzzer explores errors rather than spending its
 * time building huge scenes; files are refused (no asset folder).  Each
 * input is loaded both ways, inline mesh arrays read from the text (every
 * one, however short) and all through cJSON: they must agree on the scene
 * or on the error (tests/unit/scene_compare.h), else the target aborts. */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

#include "rayd/rayd.h"
#include "../unit/scene_compare.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    lim.max_width = lim.max_height = 64;
    lim.max_pixels = 4096;
    lim.max_objects = 2000;
    lim.max_triangles = lim.max_vertices = 20000;
    lim.max_samples = 4;
    lim.max_depth = 4;
    char why[1024];
    bool loaded;
    if (scene_compare((const char *)data, size, &lim, why, sizeof why, &loaded)) {
        fprintf(stderr, "fuzz_scene: the inline path differs from cJSON's: %s\n", why);
        abort();
    }
    rayd_scene *s = NULL;
    if (loaded && scene_json_parse((const char *)data, size, &lim, 1, &s, NULL) == RAYD_OK) {
        /* render a few pixels: every loaded scene must trace */
        struct rayd_render_opts o = {.region = {0, 0, 2, 2}};
        rayd_image *img = NULL;
        rayd_render(s, &o, &img, NULL);
        rayd_image_free(img);
    }
    rayd_scene_free(s);
    return 0;
}
