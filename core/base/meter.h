/* meter.h -- what one rendering thread has cast, and whether it must stop.
 *
 * A render hands each of its threads a struct meter.  The integrators count
 * every ray they cast on it (meter_ray, meter_rays) in place of the plain
 * counter they had, so the count a render reports is the meter's.  Every
 * METER_EVERY rays the meter looks out (meter_check, meter.c): at the
 * caller's cancel flag, and at the ray budget the caller may share between
 * many renders (the tiles of one server task), which it takes its rays
 * from.  When either says stop, the meter is stopped for good: meter_ray
 * answers false from then on, and the integrators return at once with
 * whatever colour they have -- the render is thrown away, so those colours
 * never reach an image.  A render that is not stopped casts exactly the
 * rays it did before and computes exactly the same colours: the bytes do
 * not change.
 *
 * Rays are not the only cost a scene controls: a ray through many
 * instances that overlap each other walks one group's BVH per instance, and
 * a CSG tree of many operands evaluates the whole tree at every crossing.
 * Those loops ask meter_live at each instance or every few crossings:
 * through the meter bound to the thread (meter_bind), since the scene's
 * queries sit below the integrators and take no meter of their own.  A
 * relaxed load of the flag is cheap next to the BVH walk it guards.  The
 * CSG loop also counts its work (meter_work, in rays' worth) against the
 * budget, beside the rays: one ray through thousands of nested operands
 * costs millions of point tests, which a budget of rays alone would never
 * see.  So do the walks over objects (meter_visits): a ray threading a row
 * of a million instanced tori visits every one and hits none.  The work is
 * not counted as rays (the count a render reports).
 *
 * The stop is in the meter, not only in the flag: a meter stopped by its
 * budget stays stopped while the other threads' meters see it at their
 * next look (their budget is the same counter).
 */
#ifndef RAYD_METER_H
#define RAYD_METER_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

#include "rayd/rayd.h"

/* Rays between two looks at the flag and the budget: about a millisecond
 * of ordinary rays, and never more than a few milliseconds of the costly
 * ones (area lights, glass), whose cost is all rays. */
#define METER_EVERY 1024

struct meter {
    uint64_t rays;              /* cast so far */
    uint64_t work;              /* other work so far, in rays' worth (meter_work) */
    uint64_t next;              /* rays + work at the next look; 0 once stopped */
    uint64_t taken;             /* of rays + work, already taken from *left */
    const atomic_int *cancel;   /* may be NULL */
    atomic_int_least64_t *left; /* the shared budget, may be NULL */
    enum rayd_status stop;      /* RAYD_OK while it goes */
};

/* Objects one walk's price covers, a ray: a walk of the scene's BVH (a
 * ray's, or an instance's inside it) visits the first METER_VISITS_FREE
 * free, and each one past them is a ray's worth of work (meter_visits) --
 * the price of a ray through a row of a million tori that it threads
 * without a hit.  Counted walk by walk, so what a render is charged does
 * not depend on the order its rays come in, its tiling or its threads. */
#define METER_VISITS_FREE 64

/* A meter for a render with that cancel flag and budget (either NULL). */
static inline struct meter meter_make(const atomic_int *cancel, atomic_int_least64_t *left) {
    struct meter m = {0, 0, METER_EVERY, 0, cancel, left, RAYD_OK};
    return m;
}

/* Looks at the flag and the budget; false when the meter is (now) stopped. */
bool meter_check(struct meter *m);

/* Counts n rays cast; false when the render must stop. */
static inline bool meter_rays(struct meter *m, uint64_t n) {
    m->rays += n;
    return m->rays + m->work < m->next || meter_check(m);
}

static inline bool meter_ray(struct meter *m) { return meter_rays(m, 1); }

/* False once the meter stopped (no look at the flag: a plain load). */
static inline bool meter_going(const struct meter *m) { return m->stop == RAYD_OK; }

/* Stops m for what meter_poll saw (out of line: the rare case). */
bool meter_poll_stop(struct meter *m);

/* True while the meter goes: the cancel flag (and whether another thread
 * spent the budget) is looked at now, not only every METER_EVERY rays
 * (for the per-sample checks and the scene's walks).  Inline: two relaxed
 * loads on the way that goes on. */
static inline bool meter_poll(struct meter *m) {
    if (m->stop == RAYD_OK &&
        !(m->cancel && atomic_load_explicit(m->cancel, memory_order_relaxed)) &&
        !(m->left && atomic_load_explicit(m->left, memory_order_relaxed) < 0))
        return true;
    return meter_poll_stop(m);
}

/* Takes what is left of the rays from the budget, at the end of the
 * meter's render; false when the budget is passed (the meter then stops
 * with RAYD_E_LIMIT). */
bool meter_close(struct meter *m);

/* The meter the scene's queries of this thread look at (NULL: none):
 * bound by the render around its work (meter_bind), unbound (NULL) after.
 * initial-exec: one load off the thread pointer, in librayd.so too (the
 * general model would be a call). */
extern _Thread_local struct meter *meter_here __attribute__((tls_model("initial-exec")));

static inline void meter_bind(struct meter *m) { meter_here = m; }

/* For the scene's costly inner loops: false when this thread's meter is
 * stopped or its cancel flag raised (then stopped).  True with none bound. */
static inline bool meter_live(void) {
    struct meter *m = meter_here;
    return !m || meter_poll(m);
}

/* Counts n rays' worth of a scene's own work on this thread's meter (none
 * bound: nothing); false when the render must stop. */
static inline bool meter_work(uint64_t n) {
    struct meter *m = meter_here;
    if (!m) return true;
    m->work += n;
    return m->rays + m->work < m->next || meter_check(m);
}

/* Counts a walk for rays rays (a packet's lanes) that visited n objects:
 * those past METER_VISITS_FREE a ray, a ray's worth each; false when the
 * render must stop. */
static inline bool meter_visits(uint64_t n, uint64_t rays) {
    uint64_t free = rays * METER_VISITS_FREE;
    return n <= free || meter_work(n - free);
}

#endif
