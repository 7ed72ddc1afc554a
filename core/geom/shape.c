/* shape.c -- what all analytic shapes share: the table of their
 * operations, the nearest-hit rule, the stable quadratic and frames.
 */
#include "geom/shape.h"

#include <stddef.h>

const struct shape_ops *const shape_ops[SHAPE_KINDS] = {
    [SHAPE_SPHERE] = &sphere_ops, [SHAPE_PLANE] = &plane_ops,       [SHAPE_BOX] = &box_ops,
    [SHAPE_CYLINDER] = &cylinder_ops, [SHAPE_DISC] = &disc_ops,     [SHAPE_TORUS] = &torus_ops,
    [SHAPE_TRIANGLE] = &triangle_ops, [SHAPE_QUAD] = &quad_ops,     [SHAPE_QUADRIC] = &quadric_ops,
};

bool shape_hit(const struct object *o, const ray *r, double tmin, double tmax, double *t,
               int *part) {
    struct xing x[SHAPE_MAX_XINGS];
    int n = shape_ops[o->kind]->crossings(o, r, x);
    for (int i = 0; i < n; i++) {
        if (x[i].t > tmin && x[i].t < tmax) {
            *t = x[i].t;
            *part = x[i].part;
            return true;
        }
    }
    return false;
}

bool shape_is_solid(const struct object *o) {
    if (o->kind >= SHAPE_MESH) return o->kind == SHAPE_CSG;
    if (o->kind == SHAPE_CYLINDER) return o->u.cyl.capped;
    return shape_ops[o->kind]->inside != NULL;
}

int shape_quadratic(double a, double b, double c, double t[2]) {
    if (a == 0) {
        if (b == 0) return 0;
        t[0] = -c / b;
        return 1;
    }
    double disc = b * b - 4 * a * c;
    if (disc < 0) return 0;
    double q = -0.5 * (b + copysign(sqrt(disc), b));
    double t0 = q / a, t1 = q != 0 ? c / q : t0;
    t[0] = fmin(t0, t1);
    t[1] = fmax(t0, t1);
    return 2;
}

void shape_frame(vec3 w, vec3 *u, vec3 *v) {
    vec3 a = fabs(w.x) > 0.9 ? v3(0, 1, 0) : v3(1, 0, 0);
    *u = v3_norm(v3_cross(a, w));
    *v = v3_cross(w, *u);
}
