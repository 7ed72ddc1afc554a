/* test_rng.c -- the path tracer's stratified samples (rng_pair and
 * rng_stratified, core/math/rng.h): any power-of-two run of a pixel's
 * samples from 0 fills every elementary interval of a (0,2)-net exactly
 * once, whatever the pixel, bounce or dimension; the numbers lie in
 * [0, 1); and different pixels and pairs do not repeat or mirror one
 * another (they would if a pair's or a pixel's scramble were lost). */
#include <math.h>
#include <string.h>

#include "check.h"
#include "math/rng.h"

static struct rng_key key_at(uint32_t px, uint32_t py, uint32_t sample) {
    return rng_key_at(12345, px, py, sample);
}

/* n = 2^m samples of the pair (bounce, dim) at pixel (px, py): one point
 * in each cell of every 2^a x 2^(m-a) grid. */
static int net_errors(uint32_t px, uint32_t py, uint32_t bounce, uint32_t dim, int m) {
    int n = 1 << m, bad = 0;
    double u[256], v[256];
    for (int k = 0; k < n; k++) {
        struct rng_key key = key_at(px, py, (uint32_t)k);
        rng_pair(&key, bounce, dim, &u[k], &v[k]);
        if (!(u[k] >= 0 && u[k] < 1 && v[k] >= 0 && v[k] < 1)) bad++;
    }
    for (int a = 0; a <= m; a++) {
        int cols = 1 << a, rows = n / cols;
        unsigned char seen[256];
        memset(seen, 0, sizeof seen);
        for (int k = 0; k < n; k++) {
            int c = (int)(u[k] * cols), r = (int)(v[k] * rows);
            if (c < cols && r < rows && seen[r * cols + c]++) bad++;
        }
    }
    return bad;
}

static void test_pairs_are_nets(void) {
    int bad = 0;
    for (uint32_t p = 0; p < 40; p++)
        for (int m = 0; m <= 8; m++) bad += net_errors(p * 7, p * 3 + 1, p % 5, 2 * p, m);
    CHECK(bad == 0, "%d points out of [0,1) or sharing a cell", bad);
}

/* One dimension alone: 2^m samples, one in each 1/2^m of [0, 1). */
static void test_single_is_stratified(void) {
    int bad = 0;
    for (uint32_t p = 0; p < 40; p++) {
        unsigned char seen[64] = {0};
        for (uint32_t k = 0; k < 64; k++) {
            struct rng_key key = key_at(p, 2 * p, k);
            double x = rng_stratified(&key, p % 3, 9 + p);
            if (!(x >= 0 && x < 1) || seen[(int)(x * 64)]++) bad++;
        }
    }
    CHECK(bad == 0, "%d samples out of [0,1) or in a taken 1/64", bad);
}

/* Across many pixels, sample 0 of two pairs of one pixel, and of one pair
 * at neighbouring pixels, are uncorrelated: the mean of u1 x u2 is 1/4 and
 * the two seldom agree to 1/16 (a shared scramble or index would). */
static void test_no_mirroring(void) {
    enum { N = 20000 };
    double sum_pairs = 0, sum_pixels = 0;
    int close_pairs = 0, close_pixels = 0;
    for (uint32_t i = 0; i < N; i++) {
        struct rng_key k0 = key_at(i % 200, i / 200, i % 7),
                       k1 = key_at(i % 200 + 1, i / 200, i % 7);
        double a, b, c, d, e, f;
        rng_pair(&k0, 1, 10, &a, &b);
        rng_pair(&k0, 1, 12, &c, &d);
        rng_pair(&k1, 1, 10, &e, &f);
        sum_pairs += a * c;
        sum_pixels += a * e;
        close_pairs += fabs(a - c) < 1.0 / 32;
        close_pixels += fabs(a - e) < 1.0 / 32;
    }
    CHECK(fabs(sum_pairs / N - 0.25) < 0.01, "pairs: mean u1 u2 %.4f", sum_pairs / N);
    CHECK(fabs(sum_pixels / N - 0.25) < 0.01, "pixels: mean u1 u2 %.4f", sum_pixels / N);
    /* independent: P(|a - c| < 1/32) = 1/16 - 1/1024, about 1230 of 20000 */
    CHECK(close_pairs > 1000 && close_pairs < 1500, "pairs agree %d times", close_pairs);
    CHECK(close_pixels > 1000 && close_pixels < 1500, "pixels agree %d times", close_pixels);
}

/* The same key gives the same numbers; the seed changes them. */
static void test_pure_function(void) {
    struct rng_key k = key_at(3, 4, 5), k2 = k;
    double a, b, c, d;
    rng_pair(&k, 2, 6, &a, &b);
    rng_pair(&k2, 2, 6, &c, &d);
    CHECK(a == c && b == d, "same key, different numbers");
    k2 = rng_key_at(k.seed + 1, 3, 4, 5);
    rng_pair(&k2, 2, 6, &c, &d);
    CHECK(a != c && b != d, "the seed changes nothing");
}

int main(void) {
    RUN(test_pairs_are_nets);
    RUN(test_single_is_stratified);
    RUN(test_no_mirroring);
    RUN(test_pure_function);
    CHECK_EXIT();
}
