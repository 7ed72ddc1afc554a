/* shape_quadric.c -- general quadric surfaces (POV-Ray's coefficients):
 * f(p) = a x^2 + b y^2 + c z^2 + d xy + e xz + f yz + g x + h y + i z + j = 0.
 * Ellipsoids, paraboloids, hyperboloids, cones and cylinders of any
 * orientation.  Along a ray f is a quadratic in t; the normal is the
 * gradient; the solid is f < 0.  Unbounded, so tested beside the BVH.
 */
#include "geom/shape.h"
#include "math/poly.h"

static double qf(const double *k, vec3 p) {
    return k[0] * p.x * p.x + k[1] * p.y * p.y + k[2] * p.z * p.z + k[3] * p.x * p.y +
           k[4] * p.x * p.z + k[5] * p.y * p.z + k[6] * p.x + k[7] * p.y + k[8] * p.z + k[9];
}

static int quadric_crossings(const struct object *o, const ray *r, struct xing out[4]) {
    const double *k = o->u.quadric.k;
    vec3 p = r->o, d = r->d;
    double A = k[0] * d.x * d.x + k[1] * d.y * d.y + k[2] * d.z * d.z + k[3] * d.x * d.y +
               k[4] * d.x * d.z + k[5] * d.y * d.z;
    double B = 2 * (k[0] * p.x * d.x + k[1] * p.y * d.y + k[2] * p.z * d.z) +
               k[3] * (p.x * d.y + p.y * d.x) + k[4] * (p.x * d.z + p.z * d.x) +
               k[5] * (p.y * d.z + p.z * d.y) + k[6] * d.x + k[7] * d.y + k[8] * d.z;
    double C = qf(k, p);
    double t[2];
    int n = poly_quadratic(A, B, C, t);
    for (int i = 0; i < n; i++) out[i] = (struct xing){t[i], 0};
    return n;
}

static vec3 quadric_normal(const struct object *o, vec3 p, int part) {
    (void)part;
    const double *k = o->u.quadric.k;
    vec3 g = v3(2 * k[0] * p.x + k[3] * p.y + k[4] * p.z + k[6],
                2 * k[1] * p.y + k[3] * p.x + k[5] * p.z + k[7],
                2 * k[2] * p.z + k[4] * p.x + k[5] * p.y + k[8]);
    double len = v3_len(g);
    return len > 0 ? v3_scale(g, 1 / len) : v3(0, 1, 0);
}

static bool quadric_inside(const struct object *o, vec3 p) { return qf(o->u.quadric.k, p) < 0; }

static void quadric_uv(const struct object *o, vec3 p, int part, double *u, double *v) {
    (void)o, (void)part;
    *u = p.x;
    *v = p.z;
}

const struct shape_ops quadric_ops = {"quadric", quadric_crossings, quadric_normal,
                                      NULL,      quadric_inside,    quadric_uv};
