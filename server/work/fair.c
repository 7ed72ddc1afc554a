/* fair.c -- whose turn it is: the clients with work waiting, served in turn.
 *
 * Oldest-first within a class lets one client who queued 64 jobs hold
 * every worker until they are done, while another client's first small
 * render waits behind them all.  So a tile goes to the client served least
 * recently, and only among that client's tasks to the oldest: with two
 * clients waiting they alternate tile by tile, however much each queued.
 *
 * A client is a 64-bit name the handlers derive from who asks (the peer
 * address, or a header a trusted balancer sets: --client-header).  This
 * file remembers, for the FAIR_SLOTS clients seen most recently, the tick
 * of the tile each was last given; a client it has forgotten counts as
 * never served, which only moves it forward.  Lock held throughout.
 */
#include "work/work_private.h"

#define FAIR_SLOTS 512 /* a power of two */
#define FAIR_PROBE 8   /* slots looked at for a client */

struct fair_slot {
    uint64_t client;
    uint64_t last; /* tick when last served; 0: empty */
};

static struct fair_slot fair_slots[FAIR_SLOTS];
static uint64_t fair_tick;

static size_t fair_home(uint64_t client) {
    return (size_t)((client * 0x9E3779B97F4A7C15ull) >> 32) & (FAIR_SLOTS - 1);
}

uint64_t fair_last(uint64_t client) {
    work_assert_locked();
    size_t h = fair_home(client);
    for (int i = 0; i < FAIR_PROBE; i++) {
        const struct fair_slot *s = &fair_slots[(h + (size_t)i) & (FAIR_SLOTS - 1)];
        if (s->last && s->client == client) return s->last;
    }
    return 0;
}

/* The client's slot, or the least recently served of its probe window. */
void fair_served(uint64_t client) {
    work_assert_locked();
    size_t h = fair_home(client);
    struct fair_slot *victim = NULL;
    for (int i = 0; i < FAIR_PROBE; i++) {
        struct fair_slot *s = &fair_slots[(h + (size_t)i) & (FAIR_SLOTS - 1)];
        if (s->last && s->client == client) {
            victim = s;
            break;
        }
        if (!victim || s->last < victim->last) victim = s;
    }
    victim->client = client;
    victim->last = ++fair_tick;
}
