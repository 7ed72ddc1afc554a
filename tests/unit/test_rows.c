/* test_rows.c -- the one row tracker (rayd_rows, core/base/rows.c) that the
 * render's threads and the server's workers both stream a PNG with: in any
 * order of tiles, the rows it names are complete, only grow, are each
 * named once, end at the image's height (a short last row of tiles
 * included), and several threads reporting at once see the same. */
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>

#include "check.h"
#include "rayd/rayd.h"

/* Tiles reported in a fixed shuffled order, one thread. */
static void test_any_order(void) {
    enum { TX = 3, TY = 4, TILE = 10, H = 35 };
    rayd_rows *r = rayd_rows_new(TX, TY, TILE, H);
    CHECK(r != NULL, "no tracker");
    if (!r) return;
    int order[TX * TY], done[TY] = {0};
    for (int i = 0; i < TX * TY; i++) order[i] = (i * 7 + 5) % (TX * TY);
    int last = 0, calls = 0;
    for (int i = 0; i < TX * TY; i++) {
        int ty = order[i] / TX;
        done[ty]++;
        int rows = rayd_rows_tile_done(r, ty);
        int top = 0; /* rows of tiles at the top all drawn */
        while (top < TY && done[top] == TX) top++;
        int want = top * TILE < H ? top * TILE : H;
        if (rows) {
            calls++;
            CHECK(rows > last, "rows %d after %d", rows, last);
            CHECK(rows == want, "rows %d, complete %d", rows, want);
            last = rows;
        } else {
            CHECK(want == last, "complete %d, last named %d", want, last);
        }
    }
    CHECK(last == H, "ended at %d of %d", last, H);
    CHECK(calls <= TY, "%d calls for %d rows of tiles", calls, TY);
    rayd_rows_free(r);
}

static void test_bad_sizes(void) {
    CHECK(rayd_rows_new(0, 1, 1, 1) == NULL, "no tiles");
    CHECK(rayd_rows_new(1, 1, 1, 0) == NULL, "no height");
    rayd_rows_free(NULL);
}

enum { MT_TX = 16, MT_TY = 40, MT_TILE = 8, MT_H = 317, MT_THREADS = 4 };

struct mt {
    rayd_rows *r;
    atomic_int next, max, calls, bad;
};

static void *mt_worker(void *arg) {
    struct mt *m = arg;
    for (;;) {
        int t = atomic_fetch_add(&m->next, 1);
        if (t >= MT_TX * MT_TY) return NULL;
        int rows = rayd_rows_tile_done(m->r, t / MT_TX);
        if (!rows) continue;
        atomic_fetch_add(&m->calls, 1);
        int old = atomic_load(&m->max);
        while (rows > old && !atomic_compare_exchange_weak(&m->max, &old, rows)) {
        }
        if (rows <= 0 || rows > MT_H) atomic_fetch_add(&m->bad, 1);
    }
}

/* Many threads: the last rows named are the height, and no advance is
 * named twice (at most one call a row of tiles). */
static void test_threads(void) {
    struct mt m = {.r = rayd_rows_new(MT_TX, MT_TY, MT_TILE, MT_H)};
    CHECK(m.r != NULL, "no tracker");
    if (!m.r) return;
    atomic_init(&m.next, 0);
    atomic_init(&m.max, 0);
    atomic_init(&m.calls, 0);
    atomic_init(&m.bad, 0);
    pthread_t th[MT_THREADS];
    for (int i = 0; i < MT_THREADS; i++) pthread_create(&th[i], NULL, mt_worker, &m);
    for (int i = 0; i < MT_THREADS; i++) pthread_join(th[i], NULL);
    CHECK(atomic_load(&m.max) == MT_H, "ended at %d of %d", atomic_load(&m.max), MT_H);
    CHECK(atomic_load(&m.calls) <= MT_TY, "%d calls", atomic_load(&m.calls));
    CHECK(atomic_load(&m.bad) == 0, "%d bad counts", atomic_load(&m.bad));
    rayd_rows_free(m.r);
}

int main(void) {
    RUN(test_any_order);
    RUN(test_bad_sizes);
    RUN(test_threads);
    CHECK_EXIT();
}
