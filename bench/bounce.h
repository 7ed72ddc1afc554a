/* bounce.h -- the diffuse-bounce ray of a pixel, shared by raybench and
 * embree_bench so that both cast exactly the same incoherent rays.
 *
 * For a pixel's primary hit, one cosine-weighted direction about the
 * geometric normal (turned toward the viewer), drawn from two numbers that
 * are a hash of the pixel's index alone: no random state, so the same
 * pixel gets the same direction in both programs, on any thread, in any
 * order.  Everything is in double precision from the caller's normal; the
 * caller lifts the origin off the surface as core/render/integrate.h does
 * (integrate_offset) and keeps the nearest hit.
 *
 * Header-only and free of rayd's and Embree's types (plain double[3]),
 * because embree_bench is built against Embree and raybench against the
 * core.
 */
#ifndef RAYD_BENCH_BOUNCE_H
#define RAYD_BENCH_BOUNCE_H

#include <math.h>
#include <stdint.h>

/* A 32-bit integer mixer (Wellons' "lowbias32"): every input bit moves
 * about half of the output bits, enough for well-spread directions. */
static inline uint32_t bounce_hash(uint32_t x) {
    x ^= x >> 16;
    x *= 0x7feb352dU;
    x ^= x >> 15;
    x *= 0x846ca68bU;
    x ^= x >> 16;
    return x;
}

/* The unit cosine-weighted direction d about the unit normal n for pixel
 * index `pixel` (j * width + i).  The tangent frame is Duff et al.'s
 * (2017), continuous except across n.z = 0's sign. */
static inline void bounce_dir(uint32_t pixel, const double n[3], double d[3]) {
    double u1 = bounce_hash(2 * pixel) * (1.0 / 4294967296.0);
    double u2 = bounce_hash(2 * pixel + 1) * (1.0 / 4294967296.0);
    double sign = n[2] >= 0 ? 1.0 : -1.0;
    double a = -1.0 / (sign + n[2]), b = n[0] * n[1] * a;
    double t[3] = {1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]};
    double bt[3] = {b, sign + n[1] * n[1] * a, -n[1]};
    double r = sqrt(u1), phi = 6.283185307179586 * u2;
    double x = r * cos(phi), y = r * sin(phi), z = sqrt(fmax(0.0, 1.0 - u1));
    double len = 0;
    for (int k = 0; k < 3; k++) {
        d[k] = t[k] * x + bt[k] * y + n[k] * z;
        len += d[k] * d[k];
    }
    len = sqrt(len);
    for (int k = 0; k < 3; k++) d[k] /= len;
}

#endif
