/* shape_plane.c -- the infinite plane, paper formulas (7)-(8).
 *
 * n . (P - Q) = 0 and P = O + tD give t = n . (Q - O) / (n . D).  A ray
 * parallel to the plane (n . D = 0) never hits it; a plane behind the ray
 * gives t < 0 and no hit.  The tracer turns the normal toward the viewer, so
 * a ray from either side sees it lit correctly.  In CSG a plane is the
 * half-space below it (against its normal), as in POV-Ray.  Planes have no
 * bounds and live outside the BVH.
 */
#include "geom/shape.h"

static int plane_crossings(const struct object *o, const ray *r, struct xing out[4]) {
    if (!plane_cross(o, r, &out[0].t)) return 0;
    out[0].part = 0;
    return 1;
}

bool plane_hit(const struct object *o, const ray *r, double tmin, double tmax, double *t) {
    struct xing x[4];
    if (!plane_crossings(o, r, x) || !(x[0].t > tmin && x[0].t < tmax)) return false;
    *t = x[0].t;
    return true;
}

static vec3 plane_normal(const struct object *o, vec3 p, int part) {
    (void)p, (void)part;
    return o->u.plane.normal;
}

static bool plane_inside(const struct object *o, vec3 p) {
    return v3_dot(o->u.plane.normal, v3_sub(p, o->u.plane.point)) < 0;
}

/* Planar mapping: coordinates along two axes of the plane, in scene units. */
static void plane_uv(const struct object *o, vec3 p, int part, double *u, double *v) {
    (void)part;
    vec3 a, b;
    v3_frame(o->u.plane.normal, &a, &b);
    vec3 d = v3_sub(p, o->u.plane.point);
    *u = v3_dot(d, a);
    *v = v3_dot(d, b);
}

const struct shape_ops plane_ops = {"plane", plane_crossings, plane_normal,
                                    NULL,    plane_inside,    plane_uv};
