/* shape_triangle.c -- single triangles and quads (parallelograms), in
 * double precision, two-sided surfaces.  Both use the Moller-Trumbore
 * solve for (t, s, u) of O + tD = corner + s e1 + u e2; a triangle keeps
 * s, u >= 0 with s + u <= 1, a quad s, u in [0, 1].  (Meshes, where
 * neighbouring triangles must not leave cracks, use the watertight test in
 * mesh.c.)
 */
#include "geom/shape.h"

static int para_cross(vec3 corner, vec3 e1, vec3 e2, bool tri, const ray *r, struct xing out[4]) {
    if (!para_solve(corner, e1, e2, tri, r, &out[0].t)) return 0;
    out[0].part = 0;
    return 1;
}

static int tri_crossings(const struct object *o, const ray *r, struct xing out[4]) {
    return para_cross(o->u.tri.a, v3_sub(o->u.tri.b, o->u.tri.a), v3_sub(o->u.tri.c, o->u.tri.a),
                      true, r, out);
}

static int quad_crossings(const struct object *o, const ray *r, struct xing out[4]) {
    return para_cross(o->u.quad.corner, o->u.quad.e1, o->u.quad.e2, false, r, out);
}

static vec3 tri_normal(const struct object *o, vec3 p, int part) {
    (void)p, (void)part;
    return v3_norm(v3_cross(v3_sub(o->u.tri.b, o->u.tri.a), v3_sub(o->u.tri.c, o->u.tri.a)));
}

void quad_derive(struct object *o) {
    vec3 c = v3_cross(o->u.quad.e1, o->u.quad.e2);
    o->u.quad.n = v3_norm(c);
    o->u.quad.area = v3_len(c);
}

static vec3 quad_normal(const struct object *o, vec3 p, int part) {
    (void)p, (void)part;
    return o->u.quad.n;
}

static struct aabb tri_bounds(const struct object *o) {
    struct aabb b = {v3_min(o->u.tri.a, v3_min(o->u.tri.b, o->u.tri.c)),
                     v3_max(o->u.tri.a, v3_max(o->u.tri.b, o->u.tri.c))};
    return b;
}

static struct aabb quad_bounds(const struct object *o) {
    vec3 c = o->u.quad.corner, a = v3_add(c, o->u.quad.e1), b = v3_add(c, o->u.quad.e2);
    vec3 d = v3_add(a, o->u.quad.e2);
    struct aabb box = {v3_min(v3_min(c, a), v3_min(b, d)), v3_max(v3_max(c, a), v3_max(b, d))};
    return box;
}

/* Barycentric (s, u) of the point: the parameters along e1 and e2. */
static void para_uv(vec3 corner, vec3 e1, vec3 e2, vec3 p, double *u, double *v) {
    vec3 q = v3_sub(p, corner);
    double a = v3_dot(e1, e1), b = v3_dot(e1, e2), c = v3_dot(e2, e2);
    double d1 = v3_dot(q, e1), d2 = v3_dot(q, e2), den = a * c - b * b;
    *u = den != 0 ? (c * d1 - b * d2) / den : 0;
    *v = den != 0 ? (a * d2 - b * d1) / den : 0;
}

static void tri_uv(const struct object *o, vec3 p, int part, double *u, double *v) {
    (void)part;
    para_uv(o->u.tri.a, v3_sub(o->u.tri.b, o->u.tri.a), v3_sub(o->u.tri.c, o->u.tri.a), p, u, v);
}

static void quad_uv(const struct object *o, vec3 p, int part, double *u, double *v) {
    (void)part;
    para_uv(o->u.quad.corner, o->u.quad.e1, o->u.quad.e2, p, u, v);
}

const struct shape_ops triangle_ops = {"triangle", tri_crossings, tri_normal,
                                       tri_bounds, NULL,          tri_uv};
const struct shape_ops quad_ops = {"quad", quad_crossings, quad_normal, quad_bounds, NULL, quad_uv};
