/* render.h -- internal entry points of render.c, for tests and benches. */
#ifndef RENDER_H
#define RENDER_H

#include <stdint.h>

#include "scene.h"

/* The pixel's linear radiance, averaged over its samples. */
vec3 render_pixel(const rayd_scene *s, int i, int j, uint64_t *rays);

/* The sRGB byte of a linear value (0 for NaN and below 0, 255 from 1). */
uint8_t render_srgb8(double c);

#endif
