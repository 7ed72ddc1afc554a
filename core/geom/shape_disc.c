/* shape_disc.c -- flat discs and rings (inner radius > 0): one plane
 * crossing kept when it falls between the two radii.  A surface, not a
 * solid.
 */
#include "geom/shape.h"

static int disc_crossings(const struct object *o, const ray *r, struct xing out[4]) {
    double denom = v3_dot(o->u.disc.normal, r->d);
    if (denom == 0) return 0;
    double t = v3_dot(o->u.disc.normal, v3_sub(o->u.disc.center, r->o)) / denom;
    vec3 q = v3_sub(v3_madd(r->o, r->d, t), o->u.disc.center);
    double d2 = v3_dot(q, q);
    if (d2 > o->u.disc.radius * o->u.disc.radius || d2 < o->u.disc.inner * o->u.disc.inner)
        return 0;
    out[0].t = t;
    out[0].part = 0;
    return 1;
}

static vec3 disc_normal(const struct object *o, vec3 p, int part) {
    (void)p, (void)part;
    return o->u.disc.normal;
}

static struct aabb disc_bounds(const struct object *o) {
    vec3 n = o->u.disc.normal, c = o->u.disc.center;
    vec3 e = v3_scale(v3(sqrt(fmax(0, 1 - n.x * n.x)), sqrt(fmax(0, 1 - n.y * n.y)),
                         sqrt(fmax(0, 1 - n.z * n.z))),
                      o->u.disc.radius);
    struct aabb b = {v3_sub(c, e), v3_add(c, e)};
    return b;
}

/* u, v in [0, 1] across the disc's square. */
static void disc_uv(const struct object *o, vec3 p, int part, double *u, double *v) {
    (void)part;
    vec3 a, b;
    v3_frame(o->u.disc.normal, &a, &b);
    vec3 q = v3_sub(p, o->u.disc.center);
    *u = 0.5 + 0.5 * v3_dot(q, a) / o->u.disc.radius;
    *v = 0.5 + 0.5 * v3_dot(q, b) / o->u.disc.radius;
}

const struct shape_ops disc_ops = {"disc", disc_crossings, disc_normal, disc_bounds, NULL, disc_uv};
