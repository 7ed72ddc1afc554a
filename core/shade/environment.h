/* environment.h -- image-based lighting: the light arriving from infinitely
 * far away in every direction (render.environment). */
#ifndef ENVIRONMENT_H
#define ENVIRONMENT_H

#include <stdbool.h>
#include <stddef.h>

#include "math/vec.h"

enum env_kind { ENV_NONE, ENV_CONSTANT, ENV_IMAGE };

struct environment {
    enum env_kind kind;
    vec3 color;            /* constant: the radiance (times intensity already) */
    int w, h;              /* image: equirectangular, rows from the top (+Y) */
    float *rgb;            /* image: linear RGB, w * h * 3, times intensity already */
    struct texels *shared; /* rgb's owner when scenes share it (texels.c), else NULL */
    double cos_r, sin_r;   /* rotation about +Y */
    bool visible;          /* camera rays that miss see it (else render.background) */
    vec3 mean;             /* solid-angle average radiance (the Whitted ambient) */
    /* image sampling, by luminance x solid angle: cdf over rows (h + 1),
     * cdf over columns per row (h x (w + 1)), and the luminance integrated
     * over the sphere; cos(theta) at each row's top edge (h + 1), sin and
     * cos(phi) at each column's left edge (w + 1); guide tables into the
     * cdfs (h, h x w: environment.c, find_guided) */
    double *row_cdf, *col_cdf, integral, *row_cos, *col_sin, *col_cos;
    int *row_guide, *col_guide;
    bool sample; /* the path tracer samples it (tests turn it off) */
};

/* Radiance arriving from the unit direction d (world space). */
vec3 env_radiance(const struct environment *e, vec3 d);

/* Builds the mean and, for images, the sampling tables; false when out of
 * memory.  Call once the pixels, rotation and intensity are set. */
bool env_prepare(struct environment *e);

/* Whether env_sample can be used: an image with some light in it. */
bool env_can_sample(const struct environment *e);

/* A direction drawn in proportion to luminance over the sphere from
 * (u1, u2) in [0, 1)^2, with its solid-angle pdf and the radiance from it
 * (the texel drawn: no second lookup); false when the draw lands on a
 * texel of no light. */
bool env_sample(const struct environment *e, double u1, double u2, vec3 *d, double *pdf, vec3 *le);

/* env_radiance of an image's direction d, and the solid-angle pdf
 * env_sample draws d with, from one lookup (an escaped path's light and
 * its MIS weight). */
vec3 env_radiance_pdf(const struct environment *e, vec3 d, double *pdf);

void env_free(struct environment *e);
/* The memory its pixels and tables take (the server's scene cache counts it). */
size_t env_bytes(const struct environment *e);

#endif
