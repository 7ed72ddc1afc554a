/* texture.c -- procedural patterns and image textures.
 *
 * A pattern is a function of a point: in object space (it moves with the
 * object, the default), world space, or the surface's (u, v).  Checker and
 * stripes alternate two colours over cells of 1/scale; gradient blends
 * from the first to the second colour along its axis and repeats.  Image
 * textures are PNGs decoded once at load time (core/codec/png.c), converted from
 * sRGB to linear, and sampled bilinearly in (u, v) with wrap-around, v = 0
 * at the bottom of the image.
 */
#include "shade/texture.h"

#include <stdlib.h>

#include "math/srgb_curve.h"
#include "shade/texels.h"

static double srgb_to_linear_u8(int c) { return srgb_decode(c / 255.0); }

static vec3 texel(const struct texture *t, int x, int y) {
    x = ((x % t->w) + t->w) % t->w;
    y = ((y % t->h) + t->h) % t->h;
    const float *p = t->rgb + 3 * ((size_t)y * (size_t)t->w + (size_t)x);
    return v3(p[0], p[1], p[2]);
}

static vec3 image_color(const struct texture *t, double u, double v) {
    double x = u * t->w - 0.5, y = (1 - v) * t->h - 0.5;
    double fx = floor(x), fy = floor(y), ax = x - fx, ay = y - fy;
    int ix = (int)fmod(fx, (double)t->w), iy = (int)fmod(fy, (double)t->h);
    vec3 c00 = texel(t, ix, iy), c10 = texel(t, ix + 1, iy);
    vec3 c01 = texel(t, ix, iy + 1), c11 = texel(t, ix + 1, iy + 1);
    vec3 top = v3_add(v3_scale(c00, 1 - ax), v3_scale(c10, ax));
    vec3 bot = v3_add(v3_scale(c01, 1 - ax), v3_scale(c11, ax));
    return v3_add(v3_scale(top, 1 - ay), v3_scale(bot, ay));
}

vec3 texture_color(const struct texture *t, vec3 po, vec3 pw, double u, double v) {
    vec3 p = t->space == TEX_WORLD ? pw : t->space == TEX_UV ? v3(u, v, 0) : po;
    p = v3_scale(p, t->scale);
    switch (t->kind) {
    case TEX_CHECKER: {
        /* a tiny nudge keeps faces lying exactly on cell borders stable */
        long k = (long)floor(p.x + 1e-9) + (long)floor(p.y + 1e-9) + (long)floor(p.z + 1e-9);
        return k & 1 ? t->b : t->a;
    }
    case TEX_STRIPES: return ((long)floor(v3_dot(p, t->axis) + 1e-9)) & 1 ? t->b : t->a;
    case TEX_GRADIENT: {
        double x = v3_dot(p, t->axis);
        x -= floor(x);
        return v3_add(v3_scale(t->a, 1 - x), v3_scale(t->b, x));
    }
    case TEX_IMAGE: return image_color(t, u * t->scale, v * t->scale);
    }
    return t->a;
}

void texture_free(struct texture *t) {
    if (!t) return;
    if (t->shared)
        texels_unref(t->shared);
    else
        free(t->rgb);
    t->rgb = NULL;
    t->shared = NULL;
}

/* A shared image counts whole in each scene that holds it (and its encoded
 * bytes, which the cache keeps to match it): more than is used, never less. */
size_t texture_bytes(const struct texture *t) {
    return sizeof *t + (t->rgb ? (size_t)t->w * (size_t)t->h * 3 * sizeof(float) : 0) +
           (t->shared ? t->shared->sh.key_len : 0);
}

float *texture_linear_from_srgb8(const unsigned char *px, int w, int h) {
    float lut[256];
    for (int i = 0; i < 256; i++) lut[i] = (float)srgb_to_linear_u8(i);
    size_t n = (size_t)w * (size_t)h * 3;
    float *out = malloc(sizeof *out * n);
    if (!out) return NULL;
    for (size_t i = 0; i < n; i++) out[i] = lut[px[i]];
    return out;
}
