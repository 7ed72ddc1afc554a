/* mesh_ray.h -- the per-ray setup of the watertight triangle test.
 *
 * Shared by the one-ray traversal (mesh.c) and the 16-ray packets
 * (mesh_packet.c): both must compute the same floats from the same double
 * ray, so that a ray finds the same triangle, t, u and v whichever way it
 * is traced.
 */
#ifndef MESH_RAY_H
#define MESH_RAY_H

#include <stdint.h>
#include <string.h>

#include "math/vec.h"

/* Slack on the acceptance test t <= tmax before the division (1 + 2^-20):
 * a triangle whose divided t equals the best t so far must not be turned
 * away by the rounding of t * det, or which of two equally near triangles
 * wins would depend on the order they were visited.  The exact rule
 * (nearest t, then lower triangle id) is applied after the division. */
#define TRI_SLACK 1.00000095f

/* Woop, Benthin and Wald's ray in its sheared frame: kz is the dominant
 * axis of the direction, kx and ky the others (swapped so that winding is
 * kept), s the shear. */
struct tri_ray {
    float org[3];
    int kx, ky, kz;
    float sx, sy, sz;
};

static inline void tri_ray_init(struct tri_ray *tr, const ray *r) {
    double d[3] = {r->d.x, r->d.y, r->d.z};
    tr->org[0] = (float)r->o.x;
    tr->org[1] = (float)r->o.y;
    tr->org[2] = (float)r->o.z;
    int kz = fabs(d[0]) > fabs(d[1]) ? (fabs(d[0]) > fabs(d[2]) ? 0 : 2)
                                     : (fabs(d[1]) > fabs(d[2]) ? 1 : 2);
    int kx = (kz + 1) % 3, ky = (kx + 1) % 3;
    if (d[kz] < 0) {
        int t = kx;
        kx = ky;
        ky = t;
    }
    tr->kx = kx;
    tr->ky = ky;
    tr->kz = kz;
    double inv = 1.0 / d[kz]; /* one division: a packet does 8 of these at once */
    tr->sx = (float)(d[kx] * inv);
    tr->sy = (float)(d[ky] * inv);
    tr->sz = (float)inv;
}

/* Exactly Woop et al.'s edge functions for one lane, in double: used when
 * a float one comes out zero (the ray passes through an edge or vertex). */
static inline void tri_edges_double(float ax, float ay, float bx, float by, float cx, float cy,
                                    float *u, float *v, float *w) {
    *u = (float)((double)cx * by - (double)cy * bx);
    *v = (float)((double)ax * cy - (double)ay * cx);
    *w = (float)((double)bx * ay - (double)by * ax);
}

/* The float bound of a mesh query for the double bound tmax.  A nearest-hit
 * search rounds up and leaves the exact test t < tmax to the end, so that
 * its answer, the nearest hit below tmax, is the same whatever tmax the
 * search started from; an any-hit query rounds down (a blocker within a
 * float step of the light is no blocker). */
static inline float tri_tmax_nearest(double tmax) {
    if (tmax > 3e38) return 3e38f;
    float f = (float)tmax; /* then nextafterf(f, INFINITY), without a call */
    if (f != f) return f;
    if (f == 0) return 0x1p-149f;
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    u += f > 0 ? 1 : (uint32_t)-1;
    memcpy(&f, &u, sizeof f);
    return f;
}

static inline float tri_tmax_any(double tmax) {
    if (tmax > 3e38) return 3e38f;
    float f = (float)tmax; /* then nextafterf(f, 0) */
    if (f != f) return f;
    if (f == 0) return 0;
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    u--;
    memcpy(&f, &u, sizeof f);
    return f;
}

#endif
