/* render.h -- internal entry points of render.c, for tests and benches. */
#ifndef RENDER_H
#define RENDER_H

#include <stdint.h>

#include "scene.h"

/* The pixel's linear radiance, averaged over its samples. */
vec3 render_pixel(const rayd_scene *s, int i, int j, uint64_t *rays);

#endif
