/* keyframe.h -- values between keyframes (keyframe.c): step, linear and
 * smooth (Catmull-Rom) curves of numbers and vectors, quaternions
 * (slerp) and cubic Hermite segments (glTF's CUBICSPLINE). */
#ifndef KEYFRAME_H
#define KEYFRAME_H

#include "math/xform.h"

enum kf_interp { KF_STEP, KF_LINEAR, KF_SMOOTH };

/* The value at time f of a curve through n >= 1 keys: key i at time t[i]
 * (strictly increasing) holds dim numbers at v + i * dim.  Before the first
 * key the first value, after the last the last; at a key's time exactly
 * that key's value, bit for bit.  Writes dim numbers to out. */
void kf_eval(const double *t, const double *v, int n, int dim, enum kf_interp how, double f,
             double *out);

/* kf_eval for unit quaternions (x, y, z, w at q + 4 i): linear is slerp,
 * smooth a Catmull-Rom curve through the keys (each turned to the
 * hemisphere of the one before), normalised; the result is unit length. */
void kf_eval_quat(const double *t, const double *q, int n, enum kf_interp how, double f,
                  double *out);

/* Spherical linear interpolation from a (u = 0) to b (u = 1) the short way
 * round; a and b unit quaternions.  u = 0 gives a and u = 1 b exactly. */
void kf_slerp(const double *a, const double *b, double u, double *out);

/* The cubic Hermite curve from p0 (u = 0) to p1 (u = 1) with tangents m0,
 * m1 already multiplied by the segment's length: dim numbers into out. */
void kf_hermite(const double *p0, const double *m0, const double *p1, const double *m1, int dim,
                double u, double *out);

/* Quaternions (x, y, z, w) of rayd's rotations: "rotate": [rx, ry, rz]
 * (degrees about x, then y, then z) and {"axis", "angle"}. */
void kf_quat_euler(vec3 deg, double *q);
void kf_quat_axis(vec3 axis, double deg, double *q);
/* The rotation of a unit quaternion. */
struct xform kf_quat_xform(const double *q);

#endif
