/* render.h -- internal entry points of render.c, for tests and benches. */
#ifndef RENDER_H
#define RENDER_H

#include <stdint.h>

#include "render/srgb.h"
#include "scene/scene.h"

/* Exact sums (render.c): a sample's radiance is a multiple of
 * 1 / RENDER_SUM_SCALE (2^-22) at most RENDER_SUM_CAP, and a sum holds at
 * most RENDER_SUM_SAMPLES of them: 2^22 * 2^15 * 2^16 = 2^53. */
#define RENDER_SUM_SCALE 4194304.0          /* 2^22 */
#define RENDER_SUM_CAP 32768.0              /* 2^15 */
#define RENDER_SUM_SAMPLES RAYD_SAMPLES_MAX /* 2^16 */

/* The pixel's linear radiance, averaged over its samples. */
vec3 render_pixel(const rayd_scene *s, int i, int j, uint64_t *rays);

/* Adds the radiance of samples k0..k1-1 of every pixel of region r
 * (checked by the caller) to sum, 3 doubles a pixel, rows r->w pixels,
 * and, when aov is not NULL, their AOV terms to aov (AOV_SUMS doubles a
 * pixel, render/aov.h),
 * each pixel's samples in index order, in tiles on opts->threads threads.
 * n is 1 for the pixel-centre sample of a one-sample render, else 0.
 * On a cancel the sums are partly added. */
enum rayd_status render_sums(const rayd_scene *s, const struct rayd_render_opts *opts,
                             const struct rayd_region *r, double *sum, double *aov, int k0, int k1,
                             int n, struct rayd_error *err);

#endif
