/* parallel.c -- parallel_for: one contiguous chunk of the range a thread.
 *
 * Threads are started per call (tens of microseconds each), which is why
 * callers pass a min_chunk: a loop of a few thousand cheap iterations runs
 * on the calling thread alone.  Chunk k is [k * n / t, (k + 1) * n / t). */
#include "base/parallel.h"

#include <pthread.h>
#include <unistd.h>

#define PARALLEL_MAX 64

struct chunk {
    void (*fn)(void *ctx, size_t lo, size_t hi);
    void *ctx;
    size_t lo, hi;
};

static void *chunk_run(void *arg) {
    struct chunk *c = arg;
    c->fn(c->ctx, c->lo, c->hi);
    return NULL;
}

int parallel_cores(void) {
    long c = sysconf(_SC_NPROCESSORS_ONLN);
    return c > 0 ? (int)c : 1;
}

void parallel_for(size_t n, int threads, size_t min_chunk,
                  void (*fn)(void *ctx, size_t lo, size_t hi), void *ctx) {
    if (threads <= 0) threads = parallel_cores();
    if (threads > PARALLEL_MAX) threads = PARALLEL_MAX;
    if (min_chunk < 1) min_chunk = 1;
    if ((size_t)threads > n / min_chunk) threads = (int)(n / min_chunk);
    if (threads <= 1) {
        if (n) fn(ctx, 0, n);
        return;
    }
    struct chunk c[PARALLEL_MAX];
    pthread_t th[PARALLEL_MAX];
    int started[PARALLEL_MAX] = {0};
    for (int k = 0; k < threads; k++)
        c[k] = (struct chunk){fn, ctx, n * (size_t)k / (size_t)threads,
                              n * (size_t)(k + 1) / (size_t)threads};
    for (int k = 1; k < threads; k++)
        started[k] = pthread_create(&th[k], NULL, chunk_run, &c[k]) == 0;
    chunk_run(&c[0]);
    for (int k = 1; k < threads; k++) {
        if (started[k])
            pthread_join(th[k], NULL);
        else
            chunk_run(&c[k]);
    }
}
