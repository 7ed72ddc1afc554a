/* integrate.h -- turning a ray into a colour. */
#ifndef INTEGRATE_H
#define INTEGRATE_H

#include <stdint.h>

#include "base/meter.h"
#include "scene/scene.h"

#include "math/rng.h"

/* Whitted ray tracing: the radiance arriving along r after `depth` bounces
 * so far.  key names the pixel sample (area lights draw from it).  Counts
 * every ray it casts (this one included) on mt; once mt stops, returns
 * at once with a colour that must be thrown away (every integrator here
 * does the same). */
vec3 whitted_radiance(const rayd_scene *s, const ray *r, int depth, const struct rng_key *key,
                      struct meter *mt);

/* The same for 16 camera rays (ray i, bit i of active set) at once, as
 * packets: out[i] is exactly whitted_radiance(s, &ray i, 0, &key[i], ..). */
void whitted_radiance16(const rayd_scene *s, const struct ray16 *r, uint32_t active,
                        const struct rng_key key[16], vec3 out[16], struct meter *mt);

/* Path tracing (integrate_path.c): an unbiased estimate of the radiance
 * arriving along r. */
vec3 path_radiance(const rayd_scene *s, const ray *r, const struct rng_key *key, struct meter *mt);
/* The same with r's nearest hit already found: *h when hit, else r escapes
 * (a camera ray of a packet, scene_intersect16). */
vec3 path_radiance_from(const rayd_scene *s, const ray *r, const struct hit *h, bool hit,
                        const struct rng_key *key, struct meter *mt);

/* What a ray along d that escapes the scene after `depth` bounces sees:
 * the environment, or the background (no environment, or a camera ray and
 * the environment is not visible). */
vec3 integrate_escape(const rayd_scene *s, vec3 d, int depth);

/* The shadow ray test from origin toward a light: what gets through.
 * Whitted's shadows let light through transparent objects (tinted); with
 * opaque (the path tracer's) any surface blocks, 1 or 0.  leave: the
 * top-level object the ray leaves and cannot meet again, not tested
 * (scene_intersect_from), or SCENE_NO_LEAVE. */
vec3 integrate_visible(const rayd_scene *s, vec3 origin, vec3 to_light, double dist, bool opaque,
                       uint32_t leave, struct meter *mt);

/* Radiance arriving at p (shading normal nf facing the viewer, shadow rays
 * from origin, leaving object leave as for integrate_visible) from light l:
 * one sample (su, sv) for area lights.  False when none arrives; *wi the
 * direction toward it. */
bool integrate_light_sample(const rayd_scene *s, const struct light *l, vec3 p, vec3 nf,
                            vec3 origin, uint32_t leave, double su, double sv, bool opaque,
                            vec3 *wi, vec3 *radiance, struct meter *mt);

/* How far to lift a secondary ray's origin off the surface at p so that it
 * cannot hit the surface it leaves (no shadow acne): relative to the size of
 * the coordinates, because that is what rounding error scales with.  Float
 * geometry (meshes, tested in single precision) needs about 2^8 float ulps,
 * as in Wachter and Binder (Ray Tracing Gems, ch. 6). */
static inline double integrate_offset(vec3 p, bool float_geom) {
    return float_geom ? 1.5e-5 * v3_maxabs(p) + 1e-6 : 1e-9 * (1.0 + v3_maxabs(p));
}

#endif
