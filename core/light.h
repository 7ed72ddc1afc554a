/* light.h -- light sources. */
#ifndef LIGHT_H
#define LIGHT_H

#include <stdbool.h>

#include "vec.h"

enum light_kind { LIGHT_POINT, LIGHT_DIRECTIONAL, LIGHT_SPOT };

struct light {
    enum light_kind kind;
    vec3 position;  /* point, spot */
    vec3 direction; /* unit; the way the light travels (directional, spot) */
    vec3 color;
    double intensity;
    double cos_outer; /* spot: cos of the cone's half angle */
    double cos_inner; /* spot: full intensity inside this cone */
};

/* For the surface point p: the unit vector toward the light, the distance to
 * it (INFINITY for directional) and the radiance arriving; false when p gets
 * no light from it (outside a spot's cone). */
bool light_at(const struct light *l, vec3 p, vec3 *to_light, double *dist, vec3 *radiance);

#endif
