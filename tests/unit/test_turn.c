/* test_turn.c -- turn_sincos (core/math/turn.h), the samplers' sine and
 * cosine of 2 pi u: within 4e-16 of libm's long double sinl and cosl over a million u in [0, 1) and
 * at the quarter turns and their neighbours, where the quadrant changes;
 * negative u (the disc light's and the environment's angles) the same;
 * sin^2 + cos^2 = 1 to rounding, so a sampled direction stays a unit. */
#include <float.h>

#include "check.h"
#include "math/turn.h"

/* The largest difference from libm's long double sinl and cosl over the u
 * given (2 pi u in long double: its rounding, 5e-19 in angle, is far below
 * what is checked; in double it would be up to 4.4e-16). */
static double worst(const double *u, int n) {
    double w = 0;
    for (int i = 0; i < n; i++) {
        double s, c;
        long double a = 2 * 3.14159265358979323846264338327950288L * u[i];
        turn_sincos(u[i], &s, &c);
        double e = fmax(fabs((double)(s - sinl(a))), fabs((double)(c - cosl(a))));
        if (!(e <= w)) w = e; /* a NaN is the worst */
    }
    return w;
}

static void test_random_points(void) {
    static double u[1000000];
    uint32_t seed = 7;
    for (int i = 0; i < 1000000; i++) u[i] = lcg_unit(&seed) + lcg_unit(&seed) / 16777216.0;
    CHECK(worst(u, 1000000) < 4e-16, "worst %g", worst(u, 1000000));
    for (int i = 0; i < 1000000; i++) u[i] = -u[i];
    CHECK(worst(u, 1000000) < 4e-16, "negative: worst %g", worst(u, 1000000));
}

static void test_quadrant_edges(void) {
    double u[64];
    int n = 0;
    for (int q = -4; q <= 4; q++) { /* each eighth of a turn, and an ulp either side */
        double e = q / 8.0;
        u[n++] = e;
        u[n++] = nextafter(e, 1);
        u[n++] = nextafter(e, -1);
    }
    u[n++] = 0x1.fffffffffffffp-1; /* the largest u under 1 */
    u[n++] = 1e-300;
    CHECK(worst(u, n) < 4e-16, "worst %g", worst(u, n));
    double s, c;
    turn_sincos(0.25, &s, &c);
    CHECK(s == 1 && fabs(c) < 1e-16, "a quarter turn: %.17g %.17g", s, c);
    turn_sincos(0.5, &s, &c);
    CHECK(fabs(s) < 1e-16 && c == -1, "a half turn: %.17g %.17g", s, c);
    turn_sincos(0, &s, &c);
    CHECK(s == 0 && c == 1, "no turn: %.17g %.17g", s, c);
}

static void test_unit_length(void) {
    uint32_t seed = 99;
    double w = 0;
    for (int i = 0; i < 100000; i++) {
        double s, c;
        turn_sincos(lcg_unit(&seed), &s, &c);
        w = fmax(w, fabs(s * s + c * c - 1));
    }
    CHECK(w < 4 * DBL_EPSILON, "sin^2 + cos^2 - 1 up to %g", w);
}

int main(void) {
    RUN(test_random_points);
    RUN(test_quadrant_edges);
    RUN(test_unit_length);
    CHECK_EXIT();
}
