/* test_hugemem.c -- huge-page buffers (hugemem.c): aligned to 2 MiB,
 * huge_free_pages keeps a few for the next call of their size, within its
 * bounds, huge_alloc_room says what a big array makes resident, from any thread, and
 * huge_calloc_pages gives zeros either way. */
#include <pthread.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "base/hugemem.h"
#include "check.h"

#define MIB ((size_t)1 << 20)

static void test_aligned_and_usable(void) {
    static const size_t sizes[] = {1, 300000, 2 * MIB, 2 * MIB + 1, 7 * MIB};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) {
        unsigned char *p = huge_alloc_pages(sizes[i]);
        CHECK(p != NULL, "%zu bytes", sizes[i]);
        if (!p) continue;
        CHECK((uintptr_t)p % (2 * MIB) == 0, "%zu bytes at %p: not on a 2 MiB boundary", sizes[i],
              (void *)p);
        memset(p, 0xab, sizes[i]);
        CHECK(p[sizes[i] - 1] == 0xab, "the last byte of %zu", sizes[i]);
        huge_free_pages(p, sizes[i]);
    }
    CHECK(huge_alloc_pages(SIZE_MAX - 1) == NULL, "SIZE_MAX - 1 bytes allocated");
    huge_free_pages(NULL, 123); /* nothing to do */
}

/* huge_alloc's room: a small array's own bytes (malloc's); a big one's
 * whole huge pages, aligned to them, what a fault makes resident. */
static void test_alloc_room(void) {
    static const size_t sizes[] = {1, 300000, 4 * MIB - 1, 4 * MIB, 4 * MIB + 1, 7 * MIB};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) {
        size_t n = sizes[i], room = huge_alloc_room(n);
        unsigned char *p = huge_alloc(n);
        CHECK(p != NULL, "%zu bytes", n);
        bool big = (uintptr_t)p % (2 * MIB) == 0;
        if (n < 4 * MIB)
            CHECK(room == n, "%zu bytes: room %zu", n, room);
        else
            CHECK(big && room % (2 * MIB) == 0 && room >= n && room < n + 2 * MIB,
                  "%zu bytes: room %zu, block %p", n, room, (void *)p);
        free(p);
    }
    CHECK(huge_alloc_room(SIZE_MAX - 1) == SIZE_MAX - 1, "SIZE_MAX - 1 wrapped");
}

/* A block given back comes again for the next call whose size rounds to
 * the same huge pages, with its bytes as they were left; not for another
 * size. */
static void test_kept_for_its_size(void) {
    unsigned char *a = huge_alloc_pages(3 * MIB); /* 4 MiB of pages */
    CHECK(a != NULL, "3 MiB");
    if (!a) return;
    a[12345] = 77;
    huge_free_pages(a, 3 * MIB);
    unsigned char *b = huge_alloc_pages(2 * MIB); /* other pages: not a */
    unsigned char *c = huge_alloc_pages(4 * MIB - 5);
    CHECK(b != a, "a 2 MiB call took the 4 MiB block");
    CHECK(c == a, "the 4 MiB block was not kept for the next 4 MiB call");
    if (c == a) CHECK(c[12345] == 77, "the kept block's bytes changed: %d", c[12345]);
    huge_free_pages(b, 2 * MIB);
    huge_free_pages(c, 4 * MIB - 5);
}

/* Far more given back than is kept: the rest is freed, and what is kept
 * still comes back whole. */
static void test_bounded(void) {
    enum { N = 40 };
    unsigned char *p[N];
    for (int i = 0; i < N; i++) {
        p[i] = huge_alloc_pages(2 * MIB);
        CHECK(p[i] != NULL, "block %d", i);
        if (p[i]) memset(p[i], i, 2 * MIB);
    }
    for (int i = 0; i < N; i++) huge_free_pages(p[i], 2 * MIB);
    for (int i = 0; i < N; i++) {
        p[i] = huge_alloc_pages(2 * MIB);
        CHECK(p[i] != NULL, "again, block %d", i);
        if (p[i]) memset(p[i], 0xff, 2 * MIB); /* every byte writable */
    }
    for (int i = 0; i < N; i++) huge_free_pages(p[i], 2 * MIB);
}

/* huge_calloc_pages reads as zeros, fresh or kept: a block left dirty and
 * given back is cleared before it comes again; every byte is checked. */
static int all_zero(const unsigned char *p, size_t n) {
    for (size_t i = 0; i < n; i++)
        if (p[i]) return 0;
    return 1;
}

static void test_calloc_zeros(void) {
    const size_t n = 5 * MIB + 3;
    unsigned char *a = huge_calloc_pages(n);
    CHECK(a != NULL, "%zu bytes", n);
    if (!a) return;
    CHECK(all_zero(a, n), "a fresh block is not all zeros");
    memset(a, 0x5a, n);
    huge_free_pages(a, n);
    unsigned char *b = huge_calloc_pages(n);
    CHECK(b == a, "the dirty block was not kept for the next call");
    if (b) CHECK(all_zero(b, n), "a kept block came back dirty");
    huge_free_pages(b, n);
}

static void *churn(void *arg) {
    size_t size = (size_t)(uintptr_t)arg;
    for (int k = 0; k < 200; k++) {
        unsigned char *q = huge_alloc_pages(size);
        if (!q) return (void *)1;
        q[0] = q[size - 1] = (unsigned char)k;
        if (q[0] != (unsigned char)k) return (void *)1;
        huge_free_pages(q, size);
    }
    return NULL;
}

static void test_threads(void) {
    pthread_t t[4];
    for (int i = 0; i < 4; i++)
        CHECK(pthread_create(&t[i], NULL, churn, (void *)(uintptr_t)((size_t)(i + 1) * MIB)) == 0,
              "thread %d", i);
    for (int i = 0; i < 4; i++) {
        void *r = NULL;
        pthread_join(t[i], &r);
        CHECK(r == NULL, "thread %d saw a block go wrong", i);
    }
}

int main(void) {
    RUN(test_calloc_zeros); /* first: nothing kept yet, so its block is kept */
    RUN(test_aligned_and_usable);
    RUN(test_alloc_room);
    RUN(test_kept_for_its_size);
    RUN(test_bounded);
    RUN(test_threads);
    CHECK_EXIT();
}
