/* shape.c -- what all analytic shapes share: the table of their
 * operations and the nearest-hit rule.  The shapes' own files
 * (shape_*.c) sit below it: they take the stable quadratic (poly.h) and
 * frames (vec.h) from math/, never from here.
 */
#include "geom/shape.h"

#include <stddef.h>

const struct shape_ops *const shape_ops[SHAPE_KINDS] = {
    [SHAPE_SPHERE] = &sphere_ops,     [SHAPE_PLANE] = &plane_ops, [SHAPE_BOX] = &box_ops,
    [SHAPE_CYLINDER] = &cylinder_ops, [SHAPE_DISC] = &disc_ops,   [SHAPE_TORUS] = &torus_ops,
    [SHAPE_TRIANGLE] = &triangle_ops, [SHAPE_QUAD] = &quad_ops,   [SHAPE_QUADRIC] = &quadric_ops,
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
