/* shape_plane.c -- the infinite plane, paper formulas (7)-(8).
 *
 * n . (P - Q) = 0 and P = O + tD give t = n . (Q - O) / (n . D).  A ray
 * parallel to the plane (n . D = 0) never hits it; a plane behind the ray
 * gives t < 0 and no hit.  The plane is two-sided: the tracer turns the
 * normal toward the viewer, so a ray from either side sees it lit
 * correctly.  Planes have no bounds and live outside the BVH.
 */
#include "shape.h"

bool plane_hit(const struct object *o, const ray *r, double tmin, double tmax, double *t) {
    double denom = v3_dot(o->u.plane.normal, r->d);
    if (denom == 0) return false;
    double tt = v3_dot(o->u.plane.normal, v3_sub(o->u.plane.point, r->o)) / denom;
    if (!(tt > tmin && tt < tmax)) return false;
    *t = tt;
    return true;
}
