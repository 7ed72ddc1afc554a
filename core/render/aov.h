/* aov.h -- arbitrary output variables: what the first hit of each camera
 * ray is, beside the light it brings (aov.c). */
#ifndef AOV_H
#define AOV_H

#include <stdbool.h>
#include <stdint.h>

#include "math/vec.h"
#include "rayd/rayd.h"
#include "scene/scene.h"

/* The per-pixel sums an AOV accumulator keeps, in this order. */
enum aov_sum {
    AOV_ALBEDO_R,
    AOV_ALBEDO_G,
    AOV_ALBEDO_B,
    AOV_NORMAL_X,
    AOV_NORMAL_Y,
    AOV_NORMAL_Z,
    AOV_DEPTH,    /* camera distance, summed over the samples that hit */
    AOV_ALPHA,    /* samples that hit */
    AOV_OBJECT,   /* 1 + the object id, from the pixel's first sample only */
    AOV_MATERIAL, /* 1 + the material index, likewise */
    AOV_LUM2,     /* the samples' squared luminance (render.c), for the
                   * denoiser's variance; no AOV of its own */
    AOV_SUMS
};

/* Adds the terms of camera ray r, whose nearest hit is h (a packet's), to
 * sum (AOV_SUMS doubles): each a multiple of 2^-22, so that sums of any
 * grouping are exact (render.c); first says the ray is the pixel's first
 * sample, the one whose ids count.  A ray that hits nothing adds nothing
 * (every term 0), so its caller skips it. */
void aov_sample_hit(const rayd_scene *s, const ray *r, const struct hit *h, bool first,
                    double sum[AOV_SUMS]);

#endif

/* The floats of one pixel's AOVs, RAYD_AOV_FLOATS of them in rayd.h's
 * order, from its sums of n samples. */
void aov_resolve(const double sum[AOV_SUMS], int n, float out[RAYD_AOV_FLOATS]);

/* One pixel of the 8-bit picture of AOV `which` (one RAYD_AOV_ bit, or
 * RAYD_AOV_MATERIAL) from its resolved floats f: 3 bytes into px.  focus
 * is the distance the depth picture shows mid-grey. */
void aov_pixel8(const float f[RAYD_AOV_FLOATS], unsigned which, double focus, uint8_t px[3]);
