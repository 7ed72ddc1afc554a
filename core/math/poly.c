/* poly.c -- real polynomial roots on an interval, robustly.
 *
 * Closed forms for cubics and quartics (Cardano, Ferrari) lose whole digits
 * when roots nearly coincide -- exactly the grazing rays on a torus.  So
 * this solver isolates roots instead: the roots of the derivative (found
 * the same way, recursively) split [a, b] into pieces on which the
 * polynomial is monotonic; a piece whose ends differ in sign holds exactly
 * one root, found by Newton steps guarded by bisection, to full double
 * precision.  A double root at a critical point (a ray tangent to the
 * surface) is caught by checking the polynomial's value there.
 */
#include "math/poly.h"

#include <math.h>

static double eval(const double *c, int deg, double t) {
    double v = c[deg];
    for (int i = deg - 1; i >= 0; i--) v = v * t + c[i];
    return v;
}

static double refine(const double *c, const double *dc, int deg, double lo, double hi, double flo) {
    double t = 0.5 * (lo + hi);
    for (int it = 0; it < 100; it++) {
        double f = eval(c, deg, t), df = eval(dc, deg - 1, t);
        if (f == 0) return t;
        if ((f < 0) == (flo < 0))
            lo = t;
        else
            hi = t;
        double nt = df != 0 ? t - f / df : 0.5 * (lo + hi);
        if (!(nt > lo && nt < hi)) nt = 0.5 * (lo + hi); /* Newton left the bracket */
        if (fabs(nt - t) <= 1e-15 * fmax(1, fabs(t)) || hi - lo <= 1e-15 * fmax(1, fabs(t)))
            return nt;
        t = nt;
    }
    return t;
}

int poly_roots(const double *c, int deg, double a, double b, double *roots) {
    while (deg > 0 && c[deg] == 0) deg--;
    if (deg <= 0) return 0;
    if (deg == 1) {
        double t = -c[0] / c[1];
        if (!(t >= a && t <= b)) return 0;
        roots[0] = t;
        return 1;
    }
    double dc[4], crit[4];
    for (int i = 1; i <= deg; i++) dc[i - 1] = i * c[i];
    int nc = poly_roots(dc, deg - 1, a, b, crit);
    double pts[6];
    int np = 0;
    pts[np++] = a;
    for (int i = 0; i < nc; i++) pts[np++] = crit[i];
    pts[np++] = b;
    int n = 0;
    double scale = 0;
    for (int i = 0; i <= deg; i++) scale = fmax(scale, fabs(c[i]));
    for (int i = 0; i + 1 < np; i++) {
        double lo = pts[i], hi = pts[i + 1];
        double flo = eval(c, deg, lo), fhi = eval(c, deg, hi);
        if (i > 0 && fabs(flo) <= 1e-13 * scale && (n == 0 || roots[n - 1] != lo)) {
            roots[n++] = lo; /* touches zero at a critical point: tangent */
            continue;
        }
        if (flo == 0 && i == 0) {
            roots[n++] = lo;
            continue;
        }
        if ((flo < 0) != (fhi < 0) && fhi != 0)
            roots[n++] = refine(c, dc, deg, lo, hi, flo);
        else if (fhi == 0 && i + 2 == np)
            roots[n++] = hi;
        if (n == deg) break;
    }
    return n;
}

int poly_quadratic(double a, double b, double c, double t[2]) {
    if (a == 0) {
        if (b == 0) return 0;
        t[0] = -c / b;
        return 1;
    }
    double disc = b * b - 4 * a * c;
    if (disc < 0) return 0;
    double q = -0.5 * (b + copysign(sqrt(disc), b));
    double t0 = q / a, t1 = q != 0 ? c / q : t0;
    t[0] = fmin(t0, t1);
    t[1] = fmax(t0, t1);
    return 2;
}
