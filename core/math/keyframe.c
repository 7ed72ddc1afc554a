/* keyframe.c -- values between keyframes.
 *
 * An animated value is a curve through keys (time, value).  Three ways to
 * go from key to key, as animation packages offer them:
 *
 *   step    the value of the last key at or before the time;
 *   linear  a straight line, (1 - u) a + u b, written so that u = 0 and
 *           u = 1 give the keys' values bit for bit;
 *   smooth  a Catmull-Rom spline: a cubic Hermite segment whose tangent at
 *           each key is the slope between its two neighbours (one-sided at
 *           the ends), scaled for keys at uneven times.  It passes through
 *           every key, and its value and slope are continuous across keys.
 *
 * Rotations are unit quaternions: linear is slerp (the short way round, at
 * a steady angular speed); smooth is the Catmull-Rom curve of the four
 * components, each key first turned to the hemisphere of the key before
 * it, then normalised -- continuous in value and slope, unit length, and
 * exact at the keys.  glTF's CUBICSPLINE is the Hermite segment with the
 * file's own tangents (kf_hermite).
 *
 * Every function is pure arithmetic in a fixed order: the same inputs give
 * the same bits on every machine the build targets (no FMA contraction,
 * -ffp-contract=off), so a frame is a pure function of the scene.
 */
#include <math.h>
#include <string.h>

#include "math/keyframe.h"

/* The segment [i, i + 1] holding f, with t[0] <= f < t[n - 1]. */
static int kf_segment(const double *t, int n, double f) {
    int lo = 0, hi = n - 1; /* t[lo] <= f < t[hi] */
    while (hi - lo > 1) {
        int mid = lo + (hi - lo) / 2;
        if (t[mid] <= f)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

/* f outside the keys, or on one: that key's index; else -1. */
static int kf_key_at(const double *t, int n, double f) {
    if (f <= t[0]) return 0;
    if (f >= t[n - 1]) return n - 1;
    int i = kf_segment(t, n, f);
    return t[i] == f ? i : -1;
}

void kf_hermite(const double *p0, const double *m0, const double *p1, const double *m1, int dim,
                double u, double *out) {
    double u2 = u * u, u3 = u2 * u;
    double h00 = 2 * u3 - 3 * u2 + 1, h10 = u3 - 2 * u2 + u, h01 = -2 * u3 + 3 * u2, h11 = u3 - u2;
    for (int c = 0; c < dim; c++) out[c] = h00 * p0[c] + h10 * m0[c] + h01 * p1[c] + h11 * m1[c];
}

/* The Catmull-Rom tangent at key i, per unit of time, of component c. */
static double kf_slope(const double *t, const double *v, int n, int dim, int i, int c) {
    int a = i > 0 ? i - 1 : i, b = i < n - 1 ? i + 1 : i;
    return (v[b * dim + c] - v[a * dim + c]) / (t[b] - t[a]);
}

static void kf_smooth(const double *t, const double *v, int n, int dim, int i, double u,
                      double *out) {
    double h = t[i + 1] - t[i], m0[4], m1[4];
    for (int c = 0; c < dim; c++) {
        m0[c] = kf_slope(t, v, n, dim, i, c) * h;
        m1[c] = kf_slope(t, v, n, dim, i + 1, c) * h;
    }
    kf_hermite(v + i * dim, m0, v + (i + 1) * dim, m1, dim, u, out);
}

void kf_eval(const double *t, const double *v, int n, int dim, enum kf_interp how, double f,
             double *out) {
    int k = kf_key_at(t, n, f);
    if (k >= 0) {
        memcpy(out, v + k * dim, sizeof *out * (size_t)dim);
        return;
    }
    int i = kf_segment(t, n, f);
    double u = (f - t[i]) / (t[i + 1] - t[i]);
    const double *a = v + i * dim, *b = a + dim;
    if (how == KF_STEP) {
        memcpy(out, a, sizeof *out * (size_t)dim);
    } else if (how == KF_LINEAR || dim > 4) {
        for (int c = 0; c < dim; c++) out[c] = (1 - u) * a[c] + u * b[c];
    } else {
        kf_smooth(t, v, n, dim, i, u, out);
    }
}

static double kf_dot4(const double *a, const double *b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
}

static void kf_norm4(double *q) {
    double l = sqrt(kf_dot4(q, q));
    if (!(l > 0)) {
        q[0] = q[1] = q[2] = 0, q[3] = 1;
        return;
    }
    for (int c = 0; c < 4; c++) q[c] /= l;
}

void kf_slerp(const double *a, const double *b, double u, double *out) {
    double bb[4], d = kf_dot4(a, b);
    double s = d < 0 ? -1 : 1; /* the short way round */
    for (int c = 0; c < 4; c++) bb[c] = s * b[c];
    d = fabs(d);
    if (u == 0) {
        memcpy(out, a, sizeof *out * 4);
        return;
    }
    if (u == 1) {
        memcpy(out, bb, sizeof *out * 4);
        return;
    }
    double wa, wb;
    if (d > 0.9995) { /* nearly equal: sin(theta) is too small to divide by */
        wa = 1 - u;
        wb = u;
    } else {
        double th = acos(d), st = sin(th);
        wa = sin((1 - u) * th) / st;
        wb = sin(u * th) / st;
    }
    for (int c = 0; c < 4; c++) out[c] = wa * a[c] + wb * bb[c];
    kf_norm4(out);
}

void kf_eval_quat(const double *t, const double *q, int n, enum kf_interp how, double f,
                  double *out) {
    int k = kf_key_at(t, n, f);
    if (k >= 0) {
        memcpy(out, q + k * 4, sizeof *out * 4);
        return;
    }
    int i = kf_segment(t, n, f);
    double u = (f - t[i]) / (t[i + 1] - t[i]);
    if (how == KF_STEP) {
        memcpy(out, q + i * 4, sizeof *out * 4);
        return;
    }
    if (how == KF_LINEAR) {
        kf_slerp(q + i * 4, q + (i + 1) * 4, u, out);
        return;
    }
    /* the four keys around the segment, each on the hemisphere of the one
     * before it, as a little curve of its own */
    double tt[4] = {0}, qq[16] = {0}; /* zeroed: an analyser cannot see lo <= hi */
    int lo = i > 0 ? i - 1 : i, hi = i + 2 < n ? i + 2 : i + 1, m = 0;
    for (int j = lo; j <= hi; j++, m++) {
        tt[m] = t[j];
        double s = m > 0 && kf_dot4(qq + (m - 1) * 4, q + j * 4) < 0 ? -1 : 1;
        for (int c = 0; c < 4; c++) qq[m * 4 + c] = s * q[j * 4 + c];
    }
    kf_smooth(tt, qq, m, 4, i - lo, u, out);
    kf_norm4(out);
}

/* a then b as rotations: the quaternion b * a. */
static void kf_quat_then(const double *a, const double *b, double *out) {
    double r[4] = {b[3] * a[0] + b[0] * a[3] + b[1] * a[2] - b[2] * a[1],
                   b[3] * a[1] - b[0] * a[2] + b[1] * a[3] + b[2] * a[0],
                   b[3] * a[2] + b[0] * a[1] - b[1] * a[0] + b[2] * a[3],
                   b[3] * a[3] - b[0] * a[0] - b[1] * a[1] - b[2] * a[2]};
    memcpy(out, r, sizeof r);
}

void kf_quat_axis(vec3 axis, double deg, double *q) {
    vec3 a = v3_norm(axis);
    double h = deg * DEG2RAD / 2, s = sin(h);
    q[0] = a.x * s, q[1] = a.y * s, q[2] = a.z * s, q[3] = cos(h);
}

void kf_quat_euler(vec3 deg, double *q) {
    double qx[4], qy[4], qz[4], xy[4];
    kf_quat_axis(v3(1, 0, 0), deg.x, qx);
    kf_quat_axis(v3(0, 1, 0), deg.y, qy);
    kf_quat_axis(v3(0, 0, 1), deg.z, qz);
    kf_quat_then(qx, qy, xy);
    kf_quat_then(xy, qz, q);
}

struct xform kf_quat_xform(const double *q) {
    double x = q[0], y = q[1], z = q[2], w = q[3];
    double r[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
                      {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
                      {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}};
    struct xform t = xform_identity();
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            t.m[i][j] = r[i][j];
            t.inv[j][i] = r[i][j]; /* a rotation's inverse is its transpose */
        }
    return t;
}
