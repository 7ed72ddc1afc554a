/* meter.c -- the meter's looks at its cancel flag and budget (meter.h).
 *
 * The budget is one signed counter shared by every meter of a render (a
 * server task's tiles, a render's threads): each look takes the rays cast
 * since the last one from it, and the meter that takes it below zero --
 * and every meter that looks after -- stops with RAYD_E_LIMIT.  A render
 * whose rays all fit never goes below zero, so whether a render is stopped
 * by its budget does not depend on the tiling or the thread count: only
 * when (how many rays past the budget) does.
 */
#include "base/meter.h"

_Thread_local struct meter *meter_here __attribute__((tls_model("initial-exec")));

static bool meter_halt(struct meter *m, enum rayd_status why) {
    if (m->stop == RAYD_OK) m->stop = why;
    m->next = 0; /* every count from now on comes here, and is refused */
    return false;
}

/* Takes the rays cast (and the work done) since the last take from the
 * budget. */
static bool meter_take(struct meter *m) {
    uint64_t spent = m->rays + m->work;
    if (!m->left || spent == m->taken) return true;
    int_least64_t n = (int_least64_t)(spent - m->taken);
    m->taken = spent;
    int_least64_t was = atomic_fetch_sub_explicit(m->left, n, memory_order_relaxed);
    return was - n >= 0;
}

bool meter_check(struct meter *m) {
    if (m->stop != RAYD_OK) return false;
    if (m->cancel && atomic_load_explicit(m->cancel, memory_order_relaxed))
        return meter_halt(m, RAYD_E_CANCELED);
    if (!meter_take(m)) return meter_halt(m, RAYD_E_LIMIT);
    m->next = m->rays + m->work + METER_EVERY;
    return true;
}

bool meter_poll_stop(struct meter *m) {
    if (m->stop != RAYD_OK) return false;
    if (m->cancel && atomic_load_explicit(m->cancel, memory_order_relaxed))
        return meter_halt(m, RAYD_E_CANCELED);
    if (m->left && atomic_load_explicit(m->left, memory_order_relaxed) < 0)
        return meter_halt(m, RAYD_E_LIMIT); /* another thread passed it */
    return true; /* the flag was lowered meanwhile (never, in practice) */
}

bool meter_close(struct meter *m) {
    if (m->stop != RAYD_OK) {
        meter_take(m); /* the count stays the rays cast */
        return false;
    }
    return meter_take(m) || meter_halt(m, RAYD_E_LIMIT);
}
