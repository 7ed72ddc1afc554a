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

/* base64 of n bytes (for png_base64), malloc'd, NUL-terminated. */
static inline char *b64_encode(const unsigned char *in, size_t n) {
    static const char al[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    char *out = malloc(4 * ((n + 2) / 3) + 1), *o = out;
    for (size_t i = 0; i < n; i += 3) {
        unsigned v = (unsigned)in[i] << 16 | (i + 1 < n ? (unsigned)in[i + 1] << 8 : 0) |
                     (i + 2 < n ? in[i + 2] : 0);
        *o++ = al[v >> 18 & 63];
        *o++ = al[v >> 12 & 63];
        *o++ = i + 1 < n ? al[v >> 6 & 63] : '=';
        *o++ = i + 2 < n ? al[v & 63] : '=';
    }
    *o = 0;
    return out;
}

/* img as a PNG in base64 (for png_base64), malloc'd; img is freed. */
static inline char *png_base64(rayd_image *img) {
    void *png;
    size_t len;
    rayd_png_encode(img, -1, &png, &len, NULL);
    rayd_image_free(img);
    char *enc = b64_encode(png, len);
    rayd_free(png);
    return enc;
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

/* scenes/whitted.json (640 x 480) at w x h, w and h below 10000; prints why
 * and returns NULL when it cannot (run from the repository root). */
static inline rayd_scene *whitted_sized(int w, int h) {
    size_t len;
    char *text = read_file("scenes/whitted.json", &len);
    char *pw = text ? strstr(text, "\"width\": 640") : NULL;
    char *ph = text ? strstr(text, "\"height\": 480") : NULL;
    rayd_scene *s = NULL;
    if (pw && ph) {
        char num[8];
        snprintf(num, sizeof num, "%4d", w); /* over " 640" or " 480": the same length */
        memcpy(pw + 8, num, 4);
        snprintf(num, sizeof num, "%4d", h);
        memcpy(ph + 9, num, 4);
        s = scene_from(text);
    } else {
        printf("  scenes/whitted.json unreadable or without its 640 x 480 size\n");
    }
    free(text);
    return s;
}

#endif
