/* xform.h -- affine transforms of objects (object space -> world space). */
#ifndef XFORM_H
#define XFORM_H

#include <stdbool.h>

#include "math/vec.h"

/* Row-major 3x4: world = m * [p, 1].  inv is the inverse. */
struct xform {
    double m[3][4];
    double inv[3][4];
};

/* The identity. */
struct xform xform_identity(void);

/* a then b: the transform that applies a first, then b. */
struct xform xform_then(const struct xform *a, const struct xform *b);

struct xform xform_translate(vec3 t);
struct xform xform_scale(vec3 s);                      /* each component non-zero */
struct xform xform_rotate_axis(vec3 axis, double deg); /* axis non-zero */
struct xform xform_rotate_euler(vec3 deg);             /* about x, then y, then z */

/* From a row-major 4x4 matrix (last row must be 0 0 0 1); false when it is
 * singular or not affine. */
bool xform_from_matrix(const double rows[16], struct xform *out);

/* Every entry finite and the scale within [1e-9, 1e9] (|det| within
 * [1e-27, 1e27]): objects stay representable. */
bool xform_sane(const struct xform *x);

static inline vec3 xf_apply(const double m[3][4], vec3 p, double w) {
    return v3(m[0][0] * p.x + m[0][1] * p.y + m[0][2] * p.z + m[0][3] * w,
              m[1][0] * p.x + m[1][1] * p.y + m[1][2] * p.z + m[1][3] * w,
              m[2][0] * p.x + m[2][1] * p.y + m[2][2] * p.z + m[2][3] * w);
}
static inline vec3 xform_point(const struct xform *x, vec3 p) { return xf_apply(x->m, p, 1); }
static inline vec3 xform_dir(const struct xform *x, vec3 d) { return xf_apply(x->m, d, 0); }
static inline vec3 xform_inv_point(const struct xform *x, vec3 p) { return xf_apply(x->inv, p, 1); }
static inline vec3 xform_inv_dir(const struct xform *x, vec3 d) { return xf_apply(x->inv, d, 0); }
/* Normals transform by the inverse transpose; the result is unit length. */
static inline vec3 xform_normal(const struct xform *x, vec3 n) {
    const double(*i)[4] = x->inv;
    return v3_norm(v3(i[0][0] * n.x + i[1][0] * n.y + i[2][0] * n.z,
                      i[0][1] * n.x + i[1][1] * n.y + i[2][1] * n.z,
                      i[0][2] * n.x + i[1][2] * n.y + i[2][2] * n.z));
}

#endif
