/* poly.h -- real roots of polynomials on an interval. */
#ifndef POLY_H
#define POLY_H

/* Real roots of c[0] + c[1] t + ... + c[deg] t^deg in [a, b], sorted;
 * deg <= 4.  Returns how many (at most deg). */
int poly_roots(const double *c, int deg, double a, double b, double *roots);

/* Roots of the quadratic a t^2 + b t + c, stable (Citardauq); returns the
 * count (0..2), sorted.  a == 0 degrades to the linear case. */
int poly_quadratic(double a, double b, double c, double t[2]);

#endif
