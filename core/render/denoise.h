/* denoise.h -- the edge-avoiding a-trous denoiser (denoise.c). */
#ifndef DENOISE_H
#define DENOISE_H

#include <stdbool.h>

#include "base/meter.h"

/* What the filter knows of one pixel: its noisy linear radiance, its AOVs
 * (render/aov.c: albedo, normal, depth, coverage) and the variance of its
 * mean luminance estimated from its samples (negative: unknown, as for a
 * one-sample render; then the filter estimates it from the neighbours). */
struct denoise_px {
    float c[3];  /* radiance, the samples' mean */
    float a[3];  /* albedo */
    float n[3];  /* shading normal, averaged (zero where nothing was hit) */
    float z;     /* depth; +infinity where nothing was hit */
    float alpha; /* coverage, 0..1 */
    float var;   /* variance of the mean's luminance, or < 0: unknown */
};

/* The filter's settings; denoise_defaults gives the measured ones
 * (bench/denoise.c). */
struct denoise_params {
    int levels;          /* a-trous levels, 1..DENOISE_LEVELS_MAX; step 2^i at level i */
    float sigma_l;       /* luminance edge-stopping, in standard deviations */
    float sigma_n;       /* normal edge-stopping exponent */
    float sigma_z;       /* relative depth change tolerated per pixel of distance */
    float sigma_a;       /* albedo difference tolerated */
    float sigma_l_decay; /* sigma_l's factor per level: level i uses sigma_l * decay^i */
    bool lum_blur;       /* compare 3x3-blurred luminances (less dark bias) */
    float firefly_k;     /* a pixel brighter than its neighbours' mean + k sigma is clamped there */
    bool variance;       /* guide by variance (SVGF); false: a fixed luminance scale (a baseline) */
};

#define DENOISE_LEVELS_MAX 5

/* The pixels around a region the filter reads to give the region's pixels
 * the values they have in the whole frame: the firefly test's 1, and at
 * each level i the kernel's 2 * 2^i plus the 1 of the blurred luminance
 * it compares at its farthest taps (the variance blur's 1 lies inside the
 * kernel): 68.  tests/unit/test_denoise.c checks that one less is not
 * enough. */
#define DENOISE_APRON (1 + 2 * ((1 << DENOISE_LEVELS_MAX) - 1) + DENOISE_LEVELS_MAX)

void denoise_defaults(struct denoise_params *p);

/* Filters the w x h pixels in (rows packed) into out (w * h * 3 floats,
 * linear RGB) on up to threads threads.  Every output pixel is a function
 * of the inputs within DENOISE_APRON of it alone (pixels outside the
 * buffer are not read), computed in one fixed order: the bytes do not
 * depend on the thread count, and a window's inner pixels equal those of
 * the larger buffer it was cut from.  m (may be NULL) stops it: its
 * cancel flag and whether its budget is spent are looked at before every
 * few thousand pixels, and each level counts its share of
 * RAYD_DENOISE_RAYS a pixel on it as work.
 * RAYD_OK; RAYD_E_NOMEM; or the meter's stop (RAYD_E_CANCELED,
 * RAYD_E_LIMIT), out then unfinished. */
enum rayd_status denoise_run(const struct denoise_px *in, int w, int h,
                             const struct denoise_params *p, int threads, struct meter *m,
                             float *out);

#endif
