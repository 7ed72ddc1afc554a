/* scene_util.h -- helpers shared by the unit tests that build scenes. */
#ifndef SCENE_UTIL_H
#define SCENE_UTIL_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rayd/rayd.h"

/* Parses JSON text; prints the error and returns NULL on failure. */
static inline rayd_scene *scene_from(const char *json) {
    rayd_scene *s = NULL;
    struct rayd_error err = {0};
    if (rayd_scene_parse(json, strlen(json), NULL, &s, &err) != RAYD_OK) {
        char buf[600];
        printf("  scene did not parse: %s\n", rayd_error_format(&err, buf, sizeof buf));
        return NULL;
    }
    return s;
}

/* The sRGB encoding of a linear value, written independently of render.c. */
static inline int srgb_ref(double c) {
    if (c <= 0) return 0;
    if (c >= 1) return 255;
    double e = c <= 0.0031308 ? 12.92 * c : 1.055 * pow(c, 1 / 2.4) - 0.055;
    return (int)floor(e * 255 + 0.5);
}

static inline rayd_image *render_all(const rayd_scene *s, int threads) {
    struct rayd_render_opts o = {.threads = threads};
    rayd_image *img = NULL;
    if (rayd_render(s, &o, &img, NULL) != RAYD_OK) return NULL;
    return img;
}

/* Reads a whole file (rayd_read_file); NULL if it cannot. */
static inline char *read_file(const char *path, size_t *len) {
    char *buf = NULL;
    return rayd_read_file(path, (size_t)1 << 30, &buf, len, NULL) == RAYD_OK ? buf : NULL;
}

#endif
