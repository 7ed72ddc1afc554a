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
#include "geom/shape.h"

static int sphere_crossings(const struct object *o, const ray *r, struct xing out[4]) {
    if (!sphere_roots(o, r, &out[0].t, &out[1].t)) return 0;
    out[0].part = out[1].part = 0;
    return 2;
}

/* shape_hit's rule (the first crossing inside (tmin, tmax)) on the two
 * roots, without a call back up through the table of shapes. */
bool sphere_hit(const struct object *o, const ray *r, double tmin, double tmax, double *t) {
    double t0, t1;
    if (!sphere_roots(o, r, &t0, &t1)) return false;
    *t = t0 > tmin && t0 < tmax ? t0 : t1;
    return *t > tmin && *t < tmax;
}

vec3 sphere_normal(const struct object *o, vec3 p) {
    return v3_scale(v3_sub(p, o->u.sphere.center), 1.0 / o->u.sphere.radius);
}

static vec3 sphere_normal_part(const struct object *o, vec3 p, int part) {
    (void)part;
    return v3_norm(v3_sub(p, o->u.sphere.center));
}

static struct aabb sphere_bounds(const struct object *o) {
    vec3 c = o->u.sphere.center;
    double r = o->u.sphere.radius;
    struct aabb b = {v3(c.x - r, c.y - r, c.z - r), v3(c.x + r, c.y + r, c.z + r)};
    return b;
}

static bool sphere_inside(const struct object *o, vec3 p) {
    vec3 d = v3_sub(p, o->u.sphere.center);
    return v3_dot(d, d) < o->u.sphere.radius * o->u.sphere.radius;
}

/* Longitude u from +x toward -z (0..1), latitude v from the south pole. */
static void sphere_uv(const struct object *o, vec3 p, int part, double *u, double *v) {
    (void)part;
    vec3 d = v3_norm(v3_sub(p, o->u.sphere.center));
    *u = 0.5 + atan2(-d.z, d.x) / (2 * 3.14159265358979323846);
    *v = 1 - acos(fmax(-1, fmin(1, d.y))) / 3.14159265358979323846;
}

const struct shape_ops sphere_ops = {"sphere",      sphere_crossings, sphere_normal_part,
                                     sphere_bounds, sphere_inside,    sphere_uv};
