/* shape_cylinder.c -- cylinders and cones (frusta), capped or open.
 *
 * One formula serves both: the radius grows linearly from r0 at the base
 * to r1 at the top, r(h) = r0 + k h with k = (r1 - r0) / height.  With q the
 * point relative to the base, h = q.w its height along the axis w and
 * q_perp its distance from the axis, the side is |q_perp|^2 = r(h)^2: a
 * quadratic in t, solved stably.  Side roots count only between base and
 * top; caps are discs at both ends.  A capped one is a closed convex solid,
 * so its crossings come in pairs; an open one is a surface.
 * Parts: 0 side, 1 base cap, 2 top cap.
 */
#include "geom/shape.h"
#include "math/poly.h"

static void sort_xings(struct xing *x, int n) {
    for (int i = 1; i < n; i++)
        for (int j = i; j > 0 && x[j].t < x[j - 1].t; j--) {
            struct xing s = x[j];
            x[j] = x[j - 1];
            x[j - 1] = s;
        }
}

static int cyl_crossings(const struct object *o, const ray *r, struct xing out[4]) {
    vec3 w = o->u.cyl.axis, oq = v3_sub(r->o, o->u.cyl.base);
    double H = o->u.cyl.height, r0 = o->u.cyl.r0, k = (o->u.cyl.r1 - r0) / H;
    double dh = v3_dot(r->d, w), oh = v3_dot(oq, w);
    vec3 dp = v3_madd(r->d, w, -dh), op = v3_madd(oq, w, -oh);
    double ro = r0 + k * oh;
    double A = v3_dot(dp, dp) - k * k * dh * dh;
    double B = 2 * (v3_dot(op, dp) - k * ro * dh);
    double C = v3_dot(op, op) - ro * ro;
    double t[2];
    int n = 0, m = poly_quadratic(A, B, C, t);
    for (int i = 0; i < m; i++) {
        double h = oh + t[i] * dh;
        if (h >= 0 && h <= H && r0 + k * h >= 0) out[n++] = (struct xing){t[i], 0};
    }
    if (o->u.cyl.capped && dh != 0) {
        for (int cap = 0; cap < 2; cap++) {
            double tc = ((cap ? H : 0) - oh) / dh, rad = cap ? o->u.cyl.r1 : r0;
            vec3 q = v3_madd(oq, r->d, tc);
            vec3 qp = v3_madd(q, w, -v3_dot(q, w));
            if (v3_dot(qp, qp) <= rad * rad && n < SHAPE_MAX_XINGS)
                out[n++] = (struct xing){tc, 1 + cap};
        }
    }
    sort_xings(out, n);
    return n;
}

static vec3 cyl_normal(const struct object *o, vec3 p, int part) {
    vec3 w = o->u.cyl.axis;
    if (part == 1) return v3_neg(w);
    if (part == 2) return w;
    vec3 q = v3_sub(p, o->u.cyl.base);
    double h = v3_dot(q, w), k = (o->u.cyl.r1 - o->u.cyl.r0) / o->u.cyl.height;
    vec3 qp = v3_madd(q, w, -h);
    double len = v3_len(qp);
    if (!(len > 0)) return k > 0 ? v3_neg(w) : w; /* the apex of a cone: out of its tip */
    double rh = o->u.cyl.r0 + k * h;
    return v3_norm(v3_madd(v3_scale(qp, 1 / len), w, -k * (rh > 0 ? 1 : 0)));
}

static struct aabb cyl_bounds(const struct object *o) {
    vec3 w = o->u.cyl.axis, a = o->u.cyl.base, b = v3_madd(a, w, o->u.cyl.height);
    /* a disc of radius r around axis w extends r sqrt(1 - w_i^2) along axis i */
    vec3 e = v3(sqrt(fmax(0, 1 - w.x * w.x)), sqrt(fmax(0, 1 - w.y * w.y)),
                sqrt(fmax(0, 1 - w.z * w.z)));
    vec3 ea = v3_scale(e, o->u.cyl.r0), eb = v3_scale(e, o->u.cyl.r1);
    struct aabb box = {v3_min(v3_sub(a, ea), v3_sub(b, eb)), v3_max(v3_add(a, ea), v3_add(b, eb))};
    return box;
}

static bool cyl_inside(const struct object *o, vec3 p) {
    vec3 q = v3_sub(p, o->u.cyl.base), w = o->u.cyl.axis;
    double h = v3_dot(q, w);
    if (!(h > 0 && h < o->u.cyl.height)) return false;
    double rh = o->u.cyl.r0 + (o->u.cyl.r1 - o->u.cyl.r0) * h / o->u.cyl.height;
    vec3 qp = v3_madd(q, w, -h);
    return v3_dot(qp, qp) < rh * rh;
}

/* u around the axis, v along it (caps: v is 0 or 1). */
static void cyl_uv(const struct object *o, vec3 p, int part, double *u, double *v) {
    vec3 a, b, w = o->u.cyl.axis;
    v3_frame(w, &a, &b);
    vec3 q = v3_sub(p, o->u.cyl.base);
    *u = 0.5 + atan2(v3_dot(q, b), v3_dot(q, a)) / (2 * 3.14159265358979323846);
    *v = part == 1 ? 0 : part == 2 ? 1 : v3_dot(q, w) / o->u.cyl.height;
}

const struct shape_ops cylinder_ops = {"cylinder", cyl_crossings, cyl_normal,
                                       cyl_bounds, cyl_inside,    cyl_uv};
