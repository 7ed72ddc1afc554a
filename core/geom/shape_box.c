/* shape_box.c -- axis-aligned boxes (oriented ones through a transform).
 *
 * Slabs: the ray enters the box at the largest of the three near-plane
 * distances and leaves at the smallest far one; the axis that decided each
 * is the part, which gives the face normal without looking at the point.
 */
#include "geom/shape.h"

static int box_crossings(const struct object *o, const ray *r, struct xing out[4]) {
    if (!box_slabs(o, r, &out[0].t, &out[0].part, &out[1].t, &out[1].part)) return 0;
    return 2;
}

static vec3 box_normal(const struct object *o, vec3 p, int part) {
    (void)o, (void)p;
    double s = part & 1 ? 1 : -1;
    int axis = part / 2;
    return v3(axis == 0 ? s : 0, axis == 1 ? s : 0, axis == 2 ? s : 0);
}

static struct aabb box_bounds(const struct object *o) {
    struct aabb b = {o->u.box.lo, o->u.box.hi};
    return b;
}

static bool box_inside(const struct object *o, vec3 p) {
    return p.x > o->u.box.lo.x && p.x < o->u.box.hi.x && p.y > o->u.box.lo.y &&
           p.y < o->u.box.hi.y && p.z > o->u.box.lo.z && p.z < o->u.box.hi.z;
}

/* Each face mapped to [0, 1]^2 across its two other axes. */
static void box_uv(const struct object *o, vec3 p, int part, double *u, double *v) {
    vec3 q = v3_sub(p, o->u.box.lo), e = v3_sub(o->u.box.hi, o->u.box.lo);
    int axis = part / 2;
    double c[3] = {q.x / e.x, q.y / e.y, q.z / e.z};
    *u = c[(axis + 1) % 3];
    *v = c[(axis + 2) % 3];
}

const struct shape_ops box_ops = {"box", box_crossings, box_normal, box_bounds, box_inside, box_uv};
