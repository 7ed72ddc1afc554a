/* shape_torus.c -- the torus, by a robust quartic solve.
 *
 * In the torus's frame (axis w, centre at the origin) the surface is
 * (|p|^2 + R^2 - r^2)^2 = 4 R^2 (x^2 + y^2).  Along the ray this is a
 * quartic in t.  Its coefficients grow with the distance to the origin, so
 * the ray is first moved to where it enters the bounding sphere (radius
 * R + r): the quartic is then solved on a short interval near zero, with
 * the isolating solver in poly.c, which is accurate for grazing rays where
 * closed forms fail.  Inside: the left side is below the right.
 */
#include "math/poly.h"
#include "geom/shape.h"

static vec3 to_local(const struct object *o, vec3 v) {
    return v3(v3_dot(v, o->u.torus.u), v3_dot(v, o->u.torus.v), v3_dot(v, o->u.torus.w));
}

static int torus_crossings(const struct object *o, const ray *r, struct xing out[4]) {
    double R = o->u.torus.major, rr = o->u.torus.minor, big = R + rr;
    vec3 oc = to_local(o, v3_sub(r->o, o->u.torus.center)), d = to_local(o, r->d);
    /* the bounding sphere: |oc + t d| = R + r */
    double b = v3_dot(oc, d), c = v3_dot(oc, oc) - big * big;
    vec3 h = v3_madd(oc, d, -b);
    double disc = big * big - v3_dot(h, h);
    if (disc < 0) return 0;
    double sq = sqrt(disc), t0 = -b - sq, t1 = -b + sq;
    (void)c;
    vec3 p = v3_madd(oc, d, t0); /* shift: solve for s = t - t0 in [0, t1 - t0] */
    double bb = 2 * v3_dot(p, d), cc = v3_dot(p, p) + R * R - rr * rr;
    double e = d.x * d.x + d.y * d.y, f = 2 * (p.x * d.x + p.y * d.y), g = p.x * p.x + p.y * p.y;
    double k[5] = {cc * cc - 4 * R * R * g, 2 * bb * cc - 4 * R * R * f,
                   bb * bb + 2 * cc - 4 * R * R * e, 2 * bb, 1};
    double s[4];
    int n = poly_roots(k, 4, 0, t1 - t0, s);
    for (int i = 0; i < n; i++) out[i] = (struct xing){t0 + s[i], 0};
    return n;
}

static vec3 torus_normal(const struct object *o, vec3 p, int part) {
    (void)part;
    vec3 q = to_local(o, v3_sub(p, o->u.torus.center));
    double R = o->u.torus.major;
    /* from the nearest point of the centre circle to q */
    double len = sqrt(q.x * q.x + q.y * q.y);
    vec3 c = len > 0 ? v3(q.x * R / len, q.y * R / len, 0) : v3(R, 0, 0);
    vec3 n = v3_norm(v3_sub(q, c));
    return v3_add(v3_add(v3_scale(o->u.torus.u, n.x), v3_scale(o->u.torus.v, n.y)),
                  v3_scale(o->u.torus.w, n.z));
}

static struct aabb torus_bounds(const struct object *o) {
    double R = o->u.torus.major, r = o->u.torus.minor;
    vec3 w = o->u.torus.w, c = o->u.torus.center;
    vec3 e = v3(R * sqrt(fmax(0, 1 - w.x * w.x)) + r, R * sqrt(fmax(0, 1 - w.y * w.y)) + r,
                R * sqrt(fmax(0, 1 - w.z * w.z)) + r);
    struct aabb b = {v3_sub(c, e), v3_add(c, e)};
    return b;
}

static bool torus_inside(const struct object *o, vec3 p) {
    vec3 q = to_local(o, v3_sub(p, o->u.torus.center));
    double R = o->u.torus.major, len = sqrt(q.x * q.x + q.y * q.y) - R;
    return len * len + q.z * q.z < o->u.torus.minor * o->u.torus.minor;
}

/* u around the axis, v around the tube. */
static void torus_uv(const struct object *o, vec3 p, int part, double *u, double *v) {
    (void)part;
    const double pi = 3.14159265358979323846;
    vec3 q = to_local(o, v3_sub(p, o->u.torus.center));
    *u = 0.5 + atan2(q.y, q.x) / (2 * pi);
    *v = 0.5 + atan2(q.z, sqrt(q.x * q.x + q.y * q.y) - o->u.torus.major) / (2 * pi);
}

const struct shape_ops torus_ops = {"torus",      torus_crossings, torus_normal,
                                    torus_bounds, torus_inside,    torus_uv};
