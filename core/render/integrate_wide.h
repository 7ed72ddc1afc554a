/* integrate_wide.h -- Whitted shading of 16 hits at once (integrate_wide.c). */
#ifndef INTEGRATE_WIDE_H
#define INTEGRATE_WIDE_H

#include <stdint.h>

#include "render/integrate.h"

/* Of the lanes in hs (hits on untransformed spheres and planes), those
 * whitted_wide shades: an untextured opaque material, in a scene whose
 * lights are all point or directional lights. */
uint32_t whitted_wide_lanes(const rayd_scene *s, const struct hit16 *hs);

/* The local shading of those lanes after `depth` bounces, shadow rays
 * included, exactly as whitted_radiance computes it: out[i] gets the colour
 * before the mirror ray.  Returns the lanes that need one (depth below
 * render.max_depth, reflectivity above 0), with the ray in lane i of rr
 * (other lanes of rr are overwritten too) and its weight in kr[i]. */
uint32_t whitted_wide(const rayd_scene *s, const struct ray16 *r, const struct hit16 *hs,
                      uint32_t lanes, int depth, vec3 out[16], struct ray16 *rr, double kr[16],
                      struct meter *mt);

#endif
