/* xform.c -- building and composing affine transforms.
 *
 * Objects are defined in their own space and placed by a transform.  Rays
 * are moved into object space by the inverse (so a scaled sphere is still
 * intersected by the exact sphere formula), and normals come back by the
 * inverse transpose, which keeps them perpendicular under non-uniform
 * scale.  Every constructor computes the inverse analytically or by the
 * 3x3 adjugate, once, when the scene is loaded.
 */
#include "math/xform.h"

#include <string.h>

static void mat_mul(const double a[3][4], const double b[3][4], double out[3][4]) {
    /* out = a * b for affine 3x4 matrices (implicit last row 0 0 0 1) */
    double r[3][4];
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 4; j++) {
            r[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
            if (j == 3) r[i][j] += a[i][3];
        }
    }
    memcpy(out, r, sizeof r);
}

/* Inverse of an affine 3x4; false when the 3x3 part is singular. */
static bool mat_inverse(const double m[3][4], double out[3][4]) {
    double a = m[0][0], b = m[0][1], c = m[0][2], d = m[1][0], e = m[1][1], f = m[1][2];
    double g = m[2][0], h = m[2][1], k = m[2][2];
    double A = e * k - f * h, B = f * g - d * k, C = d * h - e * g;
    double det = a * A + b * B + c * C;
    double scale =
        fabs(a) + fabs(b) + fabs(c) + fabs(d) + fabs(e) + fabs(f) + fabs(g) + fabs(h) + fabs(k);
    if (!(fabs(det) > 1e-12 * scale * scale * scale)) return false;
    double r[3][3] = {{A, c * h - b * k, b * f - c * e},
                      {B, a * k - c * g, c * d - a * f},
                      {C, b * g - a * h, a * e - b * d}};
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) out[i][j] = r[i][j] / det;
        out[i][3] = -(out[i][0] * m[0][3] + out[i][1] * m[1][3] + out[i][2] * m[2][3]);
    }
    return true;
}

struct xform xform_identity(void) {
    struct xform x = {{{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}},
                      {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}}};
    return x;
}

struct xform xform_then(const struct xform *a, const struct xform *b) {
    struct xform r = xform_identity(); /* every entry is overwritten */
    mat_mul(b->m, a->m, r.m);
    mat_mul(a->inv, b->inv, r.inv);
    return r;
}

struct xform xform_translate(vec3 t) {
    struct xform x = xform_identity();
    x.m[0][3] = t.x;
    x.m[1][3] = t.y;
    x.m[2][3] = t.z;
    x.inv[0][3] = -t.x;
    x.inv[1][3] = -t.y;
    x.inv[2][3] = -t.z;
    return x;
}

struct xform xform_scale(vec3 s) {
    struct xform x = xform_identity();
    x.m[0][0] = s.x;
    x.m[1][1] = s.y;
    x.m[2][2] = s.z;
    x.inv[0][0] = 1 / s.x;
    x.inv[1][1] = 1 / s.y;
    x.inv[2][2] = 1 / s.z;
    return x;
}

struct xform xform_rotate_axis(vec3 axis, double deg) {
    vec3 a = v3_norm(axis);
    double c = cos(deg * DEG2RAD), s = sin(deg * DEG2RAD), t = 1 - c;
    struct xform x = xform_identity();
    double r[3][3] = {{t * a.x * a.x + c, t * a.x * a.y - s * a.z, t * a.x * a.z + s * a.y},
                      {t * a.x * a.y + s * a.z, t * a.y * a.y + c, t * a.y * a.z - s * a.x},
                      {t * a.x * a.z - s * a.y, t * a.y * a.z + s * a.x, t * a.z * a.z + c}};
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            x.m[i][j] = r[i][j];
            x.inv[j][i] = r[i][j]; /* a rotation's inverse is its transpose */
        }
    return x;
}

struct xform xform_rotate_euler(vec3 deg) {
    struct xform rx = xform_rotate_axis(v3(1, 0, 0), deg.x);
    struct xform ry = xform_rotate_axis(v3(0, 1, 0), deg.y);
    struct xform rz = xform_rotate_axis(v3(0, 0, 1), deg.z);
    struct xform xy = xform_then(&rx, &ry);
    return xform_then(&xy, &rz);
}

bool xform_from_matrix(const double rows[16], struct xform *out) {
    if (rows[12] != 0 || rows[13] != 0 || rows[14] != 0 || rows[15] != 1) return false;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 4; j++) out->m[i][j] = rows[i * 4 + j];
    return mat_inverse(out->m, out->inv);
}

bool xform_sane(const struct xform *x) {
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 4; j++)
            if (!isfinite(x->m[i][j]) || !isfinite(x->inv[i][j])) return false;
    const double(*m)[4] = x->m;
    double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                 m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                 m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    return fabs(det) >= 1e-27 && fabs(det) <= 1e27;
}
