/* clock.h -- the monotonic clock in seconds, for the stage times the core
 * reports (a render's wall time, a scene's decode and build times). */
#ifndef RAYD_CLOCK_H
#define RAYD_CLOCK_H

#include <time.h>

static inline double clock_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

#endif
