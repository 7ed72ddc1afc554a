/* light.c -- what each kind of light delivers to a point.
 *
 * Lights do not fall off with distance (as in the paper and in POV-Ray's
 * default), so a scene's brightness does not depend on its scale.  A spot
 * is a point light limited to a cone, with a smooth (smoothstep) edge
 * between the inner and outer half angles.
 */
#include "light.h"

bool light_at(const struct light *l, vec3 p, vec3 *to_light, double *dist, vec3 *radiance) {
    vec3 c = v3_scale(l->color, l->intensity);
    if (l->kind == LIGHT_DIRECTIONAL) {
        *to_light = v3_neg(l->direction);
        *dist = INFINITY;
        *radiance = c;
        return true;
    }
    vec3 d = v3_sub(l->position, p);
    double len = v3_len(d);
    if (!(len > 0)) return false;
    *to_light = v3_scale(d, 1.0 / len);
    *dist = len;
    if (l->kind == LIGHT_SPOT) {
        double cosang = -v3_dot(*to_light, l->direction);
        if (cosang <= l->cos_outer) return false;
        if (cosang < l->cos_inner) {
            double x = (cosang - l->cos_outer) / (l->cos_inner - l->cos_outer);
            c = v3_scale(c, x * x * (3 - 2 * x));
        }
    }
    *radiance = c;
    return true;
}
