/* gate.c -- the test gate (--test-gate): tiles start only when a test says.
 *
 * Tests that need work in flight (a render running while they cancel it,
 * drain the server or fill the queue) must not hope that a render is slow
 * enough: on a fast idle machine it is not.  With --test-gate a worker stops
 * at a tile boundary until the test lets tiles through (POST /v1/test/gate,
 * api_test.c), so "in flight" is a state the test sets, not a race it runs.
 * Off unless the option is given.  The counters are under work_lock; the
 * workers (sched.c) ask gate_pass() before each tile.
 */
#include "work/work_private.h"

static bool gate_on;
static long gate_tiles = -1; /* tiles that may still start, -1 = open */
static long gate_started, gate_held;

bool gate_pass(void) {
    work_assert_locked();
    if (!gate_on || gate_tiles < 0) return true;
    if (gate_tiles == 0) return false;
    gate_tiles--;
    return true;
}

void gate_count(long started, long held) {
    work_assert_locked();
    gate_started += started;
    gate_held += held;
}

void gate_enable(long tiles) {
    work_lock_take();
    gate_on = true;
    gate_tiles = tiles;
    pthread_cond_broadcast(&work_cond);
    work_lock_give();
}

bool gate_set(long tiles) {
    work_lock_take();
    bool on = gate_on;
    if (on) {
        gate_tiles = tiles;
        pthread_cond_broadcast(&work_cond);
    }
    work_lock_give();
    return on;
}

bool gate_get(struct gate_state *g) {
    work_lock_take();
    g->tiles = gate_tiles;
    g->started = gate_started;
    g->held = gate_held;
    g->queued = task_queued;
    bool on = gate_on;
    work_lock_give();
    return on;
}
