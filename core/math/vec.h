/* vec.h -- three-component vector math, all static inline.
 *
 * The core works in double precision: the paper's camera and the quadric
 * solvers are exact formulas, and doubles keep far-away and huge objects
 * from cracking.  Colours reuse the same type (x, y, z = r, g, b).
 */
#ifndef VEC_H
#define VEC_H

#include <math.h>
#include <stdint.h>

typedef struct {
    double x, y, z;
} vec3;

#define DEG2RAD (3.14159265358979323846 / 180.0)

/* An axis-aligned box in doubles: an object's or a scene's bounds (for the
 * BVH's float boxes, see struct bbox in accel/bvh.h). */
struct aabb {
    vec3 lo, hi;
};

static inline vec3 v3(double x, double y, double z) {
    vec3 r = {x, y, z};
    return r;
}
static inline vec3 v3_add(vec3 a, vec3 b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline vec3 v3_sub(vec3 a, vec3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline vec3 v3_mul(vec3 a, vec3 b) { return v3(a.x * b.x, a.y * b.y, a.z * b.z); }
static inline vec3 v3_scale(vec3 a, double s) { return v3(a.x * s, a.y * s, a.z * s); }
static inline vec3 v3_neg(vec3 a) { return v3(-a.x, -a.y, -a.z); }
static inline double v3_dot(vec3 a, vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline vec3 v3_cross(vec3 a, vec3 b) {
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline double v3_len(vec3 a) { return sqrt(v3_dot(a, a)); }
static inline vec3 v3_norm(vec3 a) { return v3_scale(a, 1.0 / v3_len(a)); }
/* a + b * s */
/* fmax and fmin as x86-64 glibc computes them (maxsd / minsd: the second
 * argument on a tie of zeros; the other argument when one is NaN), inline:
 * without -ffinite-math-only the compiler calls libm for fmax, and the
 * tracer takes maxima several times a ray. */
static inline double v3_fmax(double a, double b) { return a > b ? a : b != b ? a : b; }
static inline double v3_fmin(double a, double b) { return a < b ? a : b != b ? a : b; }
static inline vec3 v3_madd(vec3 a, vec3 b, double s) {
    return v3(a.x + b.x * s, a.y + b.y * s, a.z + b.z * s);
}
static inline vec3 v3_min(vec3 a, vec3 b) {
    return v3(v3_fmin(a.x, b.x), v3_fmin(a.y, b.y), v3_fmin(a.z, b.z));
}
static inline vec3 v3_max(vec3 a, vec3 b) {
    return v3(v3_fmax(a.x, b.x), v3_fmax(a.y, b.y), v3_fmax(a.z, b.z));
}
static inline double v3_axis(vec3 a, int axis) { return axis == 0 ? a.x : axis == 1 ? a.y : a.z; }
static inline double v3_maxabs(vec3 a) { return v3_fmax(fabs(a.x), v3_fmax(fabs(a.y), fabs(a.z))); }
/* Mirror d about the normal n. */
static inline vec3 v3_reflect(vec3 d, vec3 n) { return v3_madd(d, n, -2.0 * v3_dot(d, n)); }

typedef struct {
    vec3 o; /* origin */
    vec3 d; /* unit direction */
} ray;

static inline vec3 ray_at(const ray *r, double t) { return v3_madd(r->o, r->d, t); }

/* Arrays of 16 lanes start on a cache line: an AVX-512 access to one
 * that does not is split in two, and a split store forwards to no load. */
#define LANES_ALIGN _Alignas(64)

/* 16 rays as structure of arrays, the packets' own form: coordinate k
 * (x, y, z) of ray i's origin is o[k][i]. */
struct ray16 {
    LANES_ALIGN double o[3][16];
    double d[3][16];
};

static inline ray ray16_get(const struct ray16 *p, int i) {
    ray r = {{p->o[0][i], p->o[1][i], p->o[2][i]}, {p->d[0][i], p->d[1][i], p->d[2][i]}};
    return r;
}

static inline void ray16_set(struct ray16 *p, int i, ray r) {
    p->o[0][i] = r.o.x, p->o[1][i] = r.o.y, p->o[2][i] = r.o.z;
    p->d[0][i] = r.d.x, p->d[1][i] = r.d.y, p->d[2][i] = r.d.z;
}

/* The lanes of p outside active (not empty) made copies of its first lane
 * in active: every lane then holds a ray, for code that loads them all. */
static inline void ray16_fill_rest(struct ray16 *p, uint32_t active) {
    ray first = ray16_get(p, __builtin_ctz(active));
    for (int i = 0; i < 16; i++)
        if (!(active >> i & 1)) ray16_set(p, i, first);
}

/* The rays of r in active into p, the other lanes copying the first. */
static inline void ray16_fill(struct ray16 *p, const ray r[16], uint32_t active) {
    for (uint32_t m = active; m; m &= m - 1) ray16_set(p, __builtin_ctz(m), r[__builtin_ctz(m)]);
    ray16_fill_rest(p, active);
}

/* An orthonormal frame (u, v, w) around unit w. */
static inline void v3_frame(vec3 w, vec3 *u, vec3 *v) {
    vec3 a = fabs(w.x) > 0.9 ? v3(0, 1, 0) : v3(1, 0, 0);
    *u = v3_norm(v3_cross(a, w));
    *v = v3_cross(w, *u);
}

#endif
