/* clock.c -- the daemon's one clock for durations: monotonic seconds.
 *
 * Every time the server measures -- a request's total, a render's stages,
 * a job's age, the deadline watch, the metrics' histograms -- is a
 * difference of two clock_now() readings, so no step of the wall clock
 * (NTP, a changed date) can make one negative.  Log lines carry the wall
 * clock's time of day separately (log.c).
 *
 * Tests move it forward (clock_skip, POST /v1/test/gate?clock=S, only with
 * --test-gate): what waits on a duration -- a job's --job-ttl above all --
 * then sees it pass at once, so a test checks the TTL without waiting it
 * out.  Only forward, as the monotonic clock itself: no difference of two
 * readings turns negative.
 */
#include "base/base.h"

#include <stdatomic.h>
#include <time.h>

static atomic_llong clock_skipped_ms; /* the tests' jumps, in all */

double clock_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec / 1e9 +
           (double)atomic_load_explicit(&clock_skipped_ms, memory_order_relaxed) / 1e3;
}

struct timespec clock_after(double seconds) {
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    long ns = ts.tv_nsec + (long)(seconds * 1e9);
    ts.tv_sec += ns / 1000000000L;
    ts.tv_nsec = ns % 1000000000L;
    return ts;
}

double clock_skip(long seconds) {
    long long ms =
        atomic_fetch_add(&clock_skipped_ms, (long long)seconds * 1000) + (long long)seconds * 1000;
    return (double)ms / 1e3;
}
