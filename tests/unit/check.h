/* check.h -- the tiny harness every unit test uses.
 *
 * A test file defines `static void test_x(void)` functions and a main that
 * RUNs them.  Each RUN prints "PASS test_x" or "FAIL test_x" on its own line;
 * tests/run.sh counts those lines.  A failed CHECK prints where and why but
 * lets the test go on, so one run shows every broken expectation.
 */
#ifndef CHECK_H
#define CHECK_H

#include <math.h>
#include <stdint.h>
#include <stdio.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static int check_failures_;

/* The tests' random numbers: the next of s's LCG as a double in [0, 1),
 * from its top 24 bits (exact in float too). */
static inline double lcg_unit(uint32_t *s) {
    *s = *s * 1664525u + 1013904223u;
    return (double)(*s >> 8) / 16777216.0;
}

#define CHECK(cond, ...)                                                                           \
    do {                                                                                           \
        if (!(cond)) {                                                                             \
            printf("  %s:%d: check failed: %s: ", __FILE__, __LINE__, #cond);                      \
            printf(__VA_ARGS__);                                                                   \
            printf("\n");                                                                          \
            check_failures_++;                                                                     \
        }                                                                                          \
    } while (0)

#define CHECK_NEAR(a, b, eps)                                                                      \
    do {                                                                                           \
        double a_ = (a), b_ = (b);                                                                 \
        CHECK(fabs(a_ - b_) <= (eps), "%s = %.17g, %s = %.17g, tolerance %g", #a, a_, #b, b_,      \
              (double)(eps));                                                                      \
    } while (0)

#define RUN(fn)                                                                                    \
    do {                                                                                           \
        int before_ = check_failures_;                                                             \
        fn();                                                                                      \
        printf("%s %s\n", check_failures_ == before_ ? "PASS" : "FAIL", #fn);                      \
        fflush(stdout);                                                                            \
    } while (0)

#define CHECK_EXIT() return check_failures_ ? 1 : 0

#endif
