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
    uint32_t px, py;     /* the pixel, in whole-image coordinates */
    uint32_t sample;     /* sample index inside the pixel (set by rng_key_sample) */
    uint32_t sample_rev; /* rng_reverse(sample): every stratified number's first step */
    uint64_t pixel;      /* rng_pixel_hash(seed, px, py): the stratified samples' */
};

/* The part of the stratified samples' hash that is the same for all of a
 * pixel's numbers, made once per sample rather than once per number. */
static inline uint64_t rng_pixel_hash(uint64_t seed, uint32_t px, uint32_t py) {
    return rng_mix(rng_mix(seed ^ 0x5851f42d4c957f2dULL) ^ (((uint64_t)px << 32) | py));
}

static inline uint32_t rng_reverse(uint32_t x);

static inline struct rng_key rng_key_at(uint64_t seed, uint32_t px, uint32_t py, uint32_t sample) {
    return (struct rng_key){
        seed, px, py, sample, rng_reverse(sample), rng_pixel_hash(seed, px, py)};
}

/* Makes k name sample `sample` of its pixel. */
static inline void rng_key_sample(struct rng_key *k, uint32_t sample) {
    k->sample = sample;
    k->sample_rev = rng_reverse(sample);
}

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

/* Stratified samples: Owen-scrambled Sobol points (Burley, "Practical
 * Hash-based Owen Scrambling", JCGT 2020).  A pixel's samples of one pair
 * of dimensions are the first two Sobol dimensions, a (0,2)-sequence, so
 * any 2^k of them put one point in each of 2^k equal cells of every
 * dyadic shape (1 x 2^k, 2 x 2^(k-1), ...): less error than independent
 * numbers at equal samples.  Each pair, pixel and bounce gets its own
 * nested uniform scramble and its own shuffle of the sample index, so
 * pairs do not align with one another nor pixels with their neighbours.
 * Still a pure function of (seed, pixel, sample, bounce, dimension), with
 * integer arithmetic alone: the same bits on every machine. */
static inline uint32_t rng_reverse(uint32_t x) {
    x = __builtin_bswap32(x);
    x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    return ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
}

/* A random permutation in which each bit flips as a function of the bits
 * below it (every step carries only upward): Laine and Karras's form, with
 * Vegdahl's constants. */
static inline uint32_t rng_lk(uint32_t x, uint32_t seed) {
    x ^= x * 0x3d20adeau;
    x += seed;
    x *= (seed >> 16) | 1u;
    x ^= x * 0x05526c56u;
    x ^= x * 0x53a22864u;
    return x;
}

/* Sobol's second dimension with its bits reversed.  Its direction numbers
 * are the rows of Pascal's triangle mod 2, and C(j, k) is odd when k's
 * bits are a subset of j's (Lucas), so bit k of the result is the parity
 * of the set bits j of i whose positions contain k's: five steps of a
 * superset sum instead of a loop over i's 32 bits. */
static inline uint32_t rng_sobol1_reversed(uint32_t i) {
    i ^= (i >> 1) & 0x55555555u;
    i ^= (i >> 2) & 0x33333333u;
    i ^= (i >> 4) & 0x0f0f0f0fu;
    i ^= (i >> 8) & 0x00ff00ffu;
    return i ^ (i >> 16);
}

static inline uint64_t rng_dim_hash(const struct rng_key *k, uint32_t bounce, uint32_t dim) {
    return rng_mix(k->pixel ^ (((uint64_t)bounce << 32) | dim));
}

static inline double rng_unit32(uint32_t x) { return (double)x * (1.0 / 4294967296.0); }

/* Sample k->sample's place in the pair's own shuffled order: Owen's
 * nested uniform scramble of the index (each bit flips as a function of
 * the bits above it), which keeps every aligned run of 2^m indices a run
 * of 2^m, so any power-of-two prefix is still a whole net. */
static inline uint32_t rng_shuffled(const struct rng_key *k, uint32_t seed) {
    return rng_reverse(rng_lk(k->sample_rev, seed));
}

/* Dimensions (dim, dim + 1) of sample k->sample as one stratified pair.
 * Each coordinate is Owen-scrambled: reversed, permuted by rng_lk,
 * reversed back (Sobol's first dimension is the index reversed). */
static inline void rng_pair(const struct rng_key *k, uint32_t bounce, uint32_t dim, double *u,
                            double *v) {
    uint64_t h = rng_dim_hash(k, bounce, dim);
    uint32_t i = rng_shuffled(k, (uint32_t)h);
    *u = rng_unit32(rng_reverse(rng_lk(i, (uint32_t)(h >> 32))));
    *v = rng_unit32(
        rng_reverse(rng_lk(rng_sobol1_reversed(i), (uint32_t)((h * 0x9e3779b97f4a7c15ULL) >> 32))));
}

/* Dimension dim of sample k->sample, stratified on its own. */
static inline double rng_stratified(const struct rng_key *k, uint32_t bounce, uint32_t dim) {
    uint64_t h = rng_dim_hash(k, bounce, dim);
    uint32_t i = rng_shuffled(k, (uint32_t)h);
    return rng_unit32(rng_reverse(rng_lk(i, (uint32_t)(h >> 32))));
}

#endif
