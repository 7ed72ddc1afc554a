/* parallel.h -- a parallel for over an index range, for the stages around
 * the tracer (mesh preparation, PNG bands): the range is cut into one
 * contiguous chunk a thread, so each thread reads and writes memory in
 * order, and a chunk's result never depends on the thread count when the
 * body writes only its own indices. */
#ifndef RAYD_PARALLEL_H
#define RAYD_PARALLEL_H

#include <stddef.h>

/* Calls fn(ctx, lo, hi) over [0, n) cut into chunks, on up to threads
 * threads (<= 0: every core), the calling thread included; returns when
 * every chunk is done.  Ranges under min_chunk indices a thread stay on
 * fewer threads.  A thread that cannot be started leaves its chunk to the
 * caller. */
void parallel_for(size_t n, int threads, size_t min_chunk,
                  void (*fn)(void *ctx, size_t lo, size_t hi), void *ctx);

/* The number of online cores, at least 1. */
int parallel_cores(void);

#endif
