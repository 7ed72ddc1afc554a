/* rng.h -- counter-based random numbers.
 *
 * There is no generator state: every number is a hash of (seed, pixel x,
 * pixel y, sample, bounce, dimension).  That is what makes a tile rendered
 * on one machine equal the same pixels rendered anywhere else: no thread,
 * tile order or previous pixel can change what a pixel draws.
 */
#ifndef RNG_H
#define RNG_H

#include <stdint.h>

/* splitmix64's finaliser: a strong 64-bit mix. */
static inline uint64_t rng_mix(uint64_t z) {
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

struct rng_key {
    uint64_t seed;
    uint32_t px, py; /* the pixel, in whole-image coordinates */
    uint32_t sample; /* sample index inside the pixel */
};

/* A uniform double in [0, 1) for (key, bounce, dim).  Dimensions in use:
 * bounce RNG_CAMERA: 0-1 position in the pixel, 2-3 lens; path bounces:
 * see integrate_path.c; Whitted area lights: RNG_AREA_DIM(light, sample). */
#define RNG_CAMERA 0xffffu
#define RNG_AREA_DIM(light, k) (0x10000u + ((uint32_t)(light) << 11) + 2u * (uint32_t)(k))
static inline double rng_uniform(const struct rng_key *k, uint32_t bounce, uint32_t dim) {
    uint64_t h = rng_mix(k->seed ^ 0x9e3779b97f4a7c15ULL);
    h = rng_mix(h ^ (((uint64_t)k->px << 32) | k->py));
    h = rng_mix(h ^ (((uint64_t)k->sample << 32) | bounce));
    h = rng_mix(h ^ dim);
    return (double)(h >> 11) * (1.0 / 9007199254740992.0);
}

#endif
