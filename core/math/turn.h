/* turn.h -- the sine and cosine of a fraction of a turn, sin(2 pi u) and
 * cos(2 pi u), for the samplers' angles (a direction about a normal, a
 * point on a disc or a sphere).
 *
 * Why not libm's sincos: it was 8-13% of a path-traced glass box, most of
 * it the general argument reduction that a number u in [0, 1) does not
 * need, and its bits may differ between libm's variants for different
 * CPUs (FMA or not), where rayd promises the same bytes on every node.
 * Here the reduction is exact: 4u is u scaled by a power of two and its
 * nearest integer k the quarter turn, so f = 4u - k in [-1/2, 1/2] loses
 * nothing; x = f pi / 2 lies in [-pi/4, pi/4], where the Taylor series of
 * sin to x^15 and of cos to x^16 are exact to 2e-16 (their first terms
 * left out are under 1e-16 there), then the quarter turn rotates (s, c).
 * Plain multiplies and adds in a fixed order (the build never contracts
 * them into FMAs): the same bits on any x86-64 or other IEEE machine.
 * Accuracy: within 2.7e-16 of libm's long double sinl and cosl over ten
 * million points (test_turn holds it under 4e-16 over a million), far
 * below what a sampled direction needs.
 */
#ifndef TURN_H
#define TURN_H

/* sin(2 pi u) and cos(2 pi u), for any u under 2^50 in magnitude (the
 * samplers' are within a turn of 0). */
static inline void turn_sincos(double u, double *s, double *c) {
    double t = 4 * u;
    long k = (long)(t < 0 ? t - 0.5 : t + 0.5); /* the nearest quarter turn */
    double f = t - (double)k;
    double x = f * 1.57079632679489661923, x2 = x * x, x4 = x2 * x2, x8 = x4 * x4;
    /* sin x = x (1 - x2/3! + x4/5! - ...); cos x = 1 - x2/2! + x4/4! - ...,
     * in Estrin's order: pairs of terms first, so the chain is short. */
    double sp = (1 - x2 * (1.0 / 6)) + x4 * ((1.0 / 120) - x2 * (1.0 / 5040)) +
                x8 * (((1.0 / 362880) - x2 * (1.0 / 39916800)) +
                      x4 * ((1.0 / 6227020800.0) - x2 * (1.0 / 1307674368000.0)));
    double cp = (1 - x2 * 0.5) + x4 * ((1.0 / 24) - x2 * (1.0 / 720)) +
                x8 * (((1.0 / 40320) - x2 * (1.0 / 3628800)) +
                      x4 * ((1.0 / 479001600) - x2 * (1.0 / 87178291200.0)) +
                      x8 * (1.0 / 20922789888000.0));
    double sn = x * sp;
    k &= 3; /* the quadrant, also for k < 0 (two's complement: -1 is 3) */
    double ss = k & 1 ? cp : sn, cc = k & 1 ? sn : cp;
    *s = k & 2 ? -ss : ss;
    *c = (k + 1) & 2 ? -cc : cc;
}

#endif
