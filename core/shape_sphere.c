/* shape_sphere.c -- exact ray/sphere intersection.
 *
 * |O + tD - C|^2 = r^2 with |D| = 1 gives t^2 + 2bt + c = 0, b = D.(O-C),
 * c = |O-C|^2 - r^2.  The textbook discriminant b^2 - c cancels badly for
 * small spheres far from the ray origin, so it is computed as
 * r^2 - |(O-C) - bD|^2 (the squared distance from the centre to the ray
 * subtracted from r^2), and the two roots come from the stable pair
 * q = -b - sign(b) sqrt(disc), t0 = q, t1 = c / q (Ray Tracing Gems, ch. 7).
 * Works for origins inside the sphere (one root behind, one ahead) and
 * returns nothing when both roots are behind.
 */
#include "shape.h"

bool sphere_hit(const struct object *o, const ray *r, double tmin, double tmax, double *t) {
    vec3 oc = v3_sub(r->o, o->u.sphere.center);
    double rad = o->u.sphere.radius;
    double b = v3_dot(oc, r->d);
    double c = v3_dot(oc, oc) - rad * rad;
    vec3 h = v3_madd(oc, r->d, -b);
    double disc = rad * rad - v3_dot(h, h);
    if (disc < 0) return false;
    double q = -b - copysign(sqrt(disc), b);
    double t0 = q, t1 = (q != 0) ? c / q : q;
    if (t0 > t1) {
        double s = t0;
        t0 = t1;
        t1 = s;
    }
    if (t0 > tmin && t0 < tmax) {
        *t = t0;
        return true;
    }
    if (t1 > tmin && t1 < tmax) {
        *t = t1;
        return true;
    }
    return false;
}

vec3 sphere_normal(const struct object *o, vec3 p) {
    return v3_scale(v3_sub(p, o->u.sphere.center), 1.0 / o->u.sphere.radius);
}

struct aabb sphere_bounds(const struct object *o) {
    vec3 c = o->u.sphere.center;
    double r = o->u.sphere.radius;
    struct aabb b = {v3(c.x - r, c.y - r, c.z - r), v3(c.x + r, c.y + r, c.z + r)};
    return b;
}
