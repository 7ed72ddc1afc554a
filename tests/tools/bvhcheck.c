/* bvhcheck -- renders a scene twice, through the acceleration structures
 * and by brute force (every primitive tested by every ray), and compares.
 *
 *   bvhcheck SCENE.json [W H]
 *
 * W x H (default 96 x 64) replaces the scene's image size and samples are
 * capped at 4, so a benchmark scene renders small.  Prints "PASS bvh-equals-brute NAME" or a FAIL line
 * with the first differing pixel.  A test tool: it links the core's
 * internals to flip the brute-force switch.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "scene.h"


static rayd_scene *load(const char *path, const char *text, size_t len, int w, int h) {
    char dir[4096];
    const char *slash = strrchr(path, '/');
    snprintf(dir, sizeof dir, "%.*s", slash ? (int)(slash - path) : 1, slash ? path : ".");
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    lim.asset_dir = dir;
    lim.asset_confine = 0;
    rayd_scene *s = NULL;
    struct rayd_error err;
    if (rayd_scene_parse(text, len, &lim, &s, &err) != RAYD_OK) {
        printf("FAIL bvh-equals-brute %s: %s %s\n", path, err.path, err.message);
        return NULL;
    }
    /* a smaller image through the same camera (keep fov, change size), at
     * most 4 samples a pixel: the check is about geometry, not noise */
    if (s->rs.samples > 4) s->rs.samples = 4;
    double tx = s->cam.tan_x;
    s->rs.width = s->cam.n = w;
    s->rs.height = s->cam.m = h;
    if (!s->cam.ortho) s->cam.tan_y = tx * h / w;
    return s;
}

int main(int argc, char **argv) {
    if (argc != 2 && argc != 4) {
        fprintf(stderr, "usage: bvhcheck SCENE.json [W H]\n");
        return 2;
    }
    int w = argc == 4 ? atoi(argv[2]) : 96, h = argc == 4 ? atoi(argv[3]) : 64;
    size_t len;
    char *text = NULL;
    if (rayd_read_file(argv[1], (size_t)1 << 30, &text, &len, NULL) != RAYD_OK) text = NULL;
    if (!text) {
        printf("FAIL bvh-equals-brute %s: cannot read\n", argv[1]);
        return 1;
    }
    rayd_scene *fast = load(argv[1], text, len, w, h), *slow = load(argv[1], text, len, w, h);
    free(text);
    if (!fast || !slow) return 1;
    slow->brute = true;
    struct rayd_render_opts o = {.threads = 2};
    rayd_image *a = NULL, *b = NULL;
    rayd_render(fast, &o, &a, NULL);
    rayd_render(slow, &o, &b, NULL);
    int rc = 0;
    if (!a || !b) {
        printf("FAIL bvh-equals-brute %s: render failed\n", argv[1]);
        rc = 1;
    } else {
        const uint8_t *pa = rayd_image_pixels_const(a), *pb = rayd_image_pixels_const(b);
        size_t n = (size_t)w * h * 3, i = 0;
        while (i < n && pa[i] == pb[i]) i++;
        if (i < n) {
            printf("FAIL bvh-equals-brute %s: pixel (%zu, %zu) differs\n", argv[1], i / 3 % w, i / 3 / w);
            rc = 1;
        } else {
            printf("PASS bvh-equals-brute %s (%u meshes, %ld objects)\n", argv[1], fast->nmeshes,
                   (long)fast->nobjs + fast->nplanes);
        }
    }
    rayd_image_free(a);
    rayd_image_free(b);
    rayd_scene_free(fast);
    rayd_scene_free(slow);
    return rc;
}
