/* light.c -- what each kind of light delivers to a point.
 *
 * Lights do not fall off with distance (as in the paper and in POV-Ray's
 * default), so a scene's brightness does not depend on its scale.  A spot
 * is a point light limited to a cone, with a smooth (smoothstep) edge
 * between the inner and outer half angles.
 */
#include "shade/light.h"

#include "math/turn.h"

bool light_at(const struct light *l, vec3 p, vec3 *to_light, double *dist, vec3 *radiance) {
    vec3 c = v3_scale(l->color, l->intensity);
    if (l->kind == LIGHT_AREA) { /* the centre; integrate.c samples the area */
        vec3 q = light_area_point(l, p, 0.5, 0.5), d = v3_sub(q, p);
        *dist = v3_len(d);
        if (!(*dist > 0)) return false;
        *to_light = v3_scale(d, 1 / *dist);
        *radiance = c;
        return true;
    }
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

vec3 light_area_point(const struct light *l, vec3 p, double su, double sv) {
    switch (l->shape) {
    case AREA_RECT: return v3_madd(v3_madd(l->position, l->e1, su), l->e2, sv);
    case AREA_DISC: { /* concentric mapping keeps strata compact */
        double a = 2 * su - 1, b = 2 * sv - 1, r, turns, sp, cp;
        if (a == 0 && b == 0) return l->position;
        if (fabs(a) > fabs(b))
            r = a, turns = (b / a) / 8; /* pi/4 (b / a) */
        else
            r = b, turns = 0.25 - (a / b) / 8; /* pi/2 - pi/4 (a / b) */
        turn_sincos(turns, &sp, &cp);
        return v3_madd(v3_madd(l->position, l->e1, r * cp * l->radius), l->e2, r * sp * l->radius);
    }
    case AREA_SPHERE: {
        /* uniform on the hemisphere facing p */
        vec3 w = v3_sub(p, l->position);
        double len = v3_len(w);
        w = len > 0 ? v3_scale(w, 1 / len) : v3(0, 1, 0);
        vec3 a = fabs(w.x) > 0.9 ? v3(0, 1, 0) : v3(1, 0, 0);
        vec3 u = v3_norm(v3_cross(a, w)), v = v3_cross(w, u);
        double z = su, r = sqrt(fmax(0, 1 - z * z)), sp, cp;
        turn_sincos(sv, &sp, &cp);
        vec3 d = v3_add(v3_add(v3_scale(u, r * cp), v3_scale(v, r * sp)), v3_scale(w, z));
        return v3_madd(l->position, d, l->radius);
    }
    }
    return l->position;
}
