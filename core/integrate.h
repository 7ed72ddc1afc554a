/* integrate.h -- turning a ray into a colour. */
#ifndef INTEGRATE_H
#define INTEGRATE_H

#include <stdint.h>

#include "scene.h"

/* Whitted ray tracing: the radiance arriving along r after `depth` bounces
 * so far.  Adds every ray it casts (this one included) to *rays. */
vec3 whitted_radiance(const rayd_scene *s, const ray *r, int depth, uint64_t *rays);

/* How far to lift a secondary ray's origin off the surface at p so that it
 * cannot hit the surface it leaves (no shadow acne): relative to the size of
 * the coordinates, because that is what rounding error scales with.  Float
 * geometry (meshes, tested in single precision) needs about 2^8 float ulps,
 * as in Wachter and Binder (Ray Tracing Gems, ch. 6). */
static inline double integrate_offset(vec3 p, bool float_geom) {
    return float_geom ? 1.5e-5 * v3_maxabs(p) + 1e-6 : 1e-9 * (1.0 + v3_maxabs(p));
}

#endif
