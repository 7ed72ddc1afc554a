/* texture.h -- colours that vary over a surface. */
#ifndef TEXTURE_H
#define TEXTURE_H

#include <stddef.h>

#include "math/vec.h"

/* The most pixels an image a scene brings may have: image textures and
 * environment maps. */
#define TEXTURE_MAX_PIXELS (4096L * 4096L)
/* The most pixels all of a scene's image textures may have together (as
 * linear float RGB, 768 MiB): a client cannot multiply the per-image limit
 * by naming many images. */
#define TEXTURE_MAX_SCENE_PIXELS (4 * TEXTURE_MAX_PIXELS)

enum texture_kind { TEX_CHECKER, TEX_STRIPES, TEX_GRADIENT, TEX_IMAGE };
enum texture_space { TEX_OBJECT, TEX_WORLD, TEX_UV };

struct texture {
    enum texture_kind kind;
    enum texture_space space;
    vec3 a, b;    /* the two colours (linear RGB) */
    double scale; /* pattern cells per scene unit (per uv unit for TEX_UV) */
    vec3 axis;    /* stripes and gradient: unit direction */
    int w, h;     /* image size */
    float *rgb;   /* image pixels, linear RGB, rows from the top */
    /* rgb's owner when it is shared with other scenes (texels.c), else
     * NULL: rgb is the texture's own. */
    struct texels *shared;
};

/* Colour at a point: object-space po, world-space pw, surface (u, v). */
vec3 texture_color(const struct texture *t, vec3 po, vec3 pw, double u, double v);

/* Linear float RGB from 8-bit sRGB pixels (malloc'd), for image textures. */
float *texture_linear_from_srgb8(const unsigned char *px, int w, int h);

void texture_free(struct texture *t);
size_t texture_bytes(const struct texture *t);

#endif
