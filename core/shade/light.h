/* light.h -- light sources. */
#ifndef LIGHT_H
#define LIGHT_H

#include <stdbool.h>

#include "math/vec.h"

enum light_kind { LIGHT_POINT, LIGHT_DIRECTIONAL, LIGHT_SPOT, LIGHT_AREA };
enum area_shape { AREA_RECT, AREA_DISC, AREA_SPHERE };

struct light {
    enum light_kind kind;
    vec3 position;  /* point, spot */
    vec3 direction; /* unit; the way the light travels (directional, spot) */
    vec3 color;
    double intensity;
    double cos_outer; /* spot: cos of the cone's half angle */
    double cos_inner; /* spot: full intensity inside this cone */
    /* area lights: a rectangle (position = corner, edges e1 e2), a disc
     * (position = centre, normal = direction, radius) or a sphere */
    enum area_shape shape;
    vec3 e1, e2;
    double radius;
    int samples; /* shadow rays per shading point */
};

/* For the surface point p: the unit vector toward the light, the distance to
 * it (INFINITY for directional) and the radiance arriving; false when p gets
 * no light from it (outside a spot's cone). */
bool light_at(const struct light *l, vec3 p, vec3 *to_light, double *dist, vec3 *radiance);

/* Area lights: the point of sample (su, sv) in [0, 1)^2 on the light, as
 * seen from p (spheres: on the half facing p).  The light's power is spread
 * over its samples by the caller. */
vec3 light_area_point(const struct light *l, vec3 p, double su, double sv);

#endif
