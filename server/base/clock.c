/* clock.c -- the daemon's one clock for durations: monotonic seconds.
 *
 * Every time the server measures -- a request's total, a render's stages,
 * a job's age, the deadline watch, the metrics' histograms -- is a
 * difference of two clock_now() readings, so no step of the wall clock
 * (NTP, a changed date) can make one negative.  Log lines carry the wall
 * clock's time of day separately (log.c).
 */
#include "base/base.h"

#include <time.h>

double clock_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec / 1e9;
}
