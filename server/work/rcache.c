/* rcache.c -- an LRU of finished results (PNG, 16-bit PNG, EXR, sample
 * sums) keyed by scene id, region, format and sample range (task_key).
 *
 * Rendering is deterministic: the same scene bytes and the same region give
 * the same PNG on any node, at any time.  So a finished PNG can answer every
 * later identical request -- a tile client re-fetching tiles, many browsers
 * opening the same immutable scene URL -- without a worker.  The budget is
 * --result-cache-mb (0 turns the cache off); the least recently used PNGs
 * are dropped first.  PNGs are shared blobs with an atomic reference count,
 * so a PNG being sent while it is evicted stays alive until sent.
 *
 * The PNGs are counted in the one memory budget (--max-memory, mem.c) as
 * kind "caches" while the cache keeps them (a blob is counted once, whoever
 * holds it), and the least recently used is evicted when a reservation
 * needs room (rcache_evict_one), so the cache lives inside that budget as
 * well as inside its own.
 *
 * Like cache.c, this file has no lock: it is called under work_lock; the
 * hash table, recency list and budget are the shared index of lru.c.
 */
#include "work/work_private.h"

#include <stdlib.h>
#include <string.h>

#define RCACHE_BUCKETS 4096

struct rcache_item {
    struct lru_node node; /* first: the index finds items through it */
    char key[160];
    struct blob *png;
    uint64_t rays; /* what its render cast: a hit costs the same, for a job's count */
};

static struct lru_node *rcache_table[RCACHE_BUCKETS];
static struct lru rcache_lru;

/* An item leaves the cache: its PNG, if a job or a reply still holds it,
 * is counted as a result again (kind caches only while cached), so the two
 * kinds in /metrics follow what the cache holds. */
static void rcache_evicted(struct lru_node *n) {
    struct rcache_item *it = (struct rcache_item *)n;
    blob_kind(it->png, MEM_RESULTS);
    blob_unref(it->png);
    free(it);
}

void rcache_init(size_t budget_bytes) {
    lru_init(&rcache_lru, rcache_table, RCACHE_BUCKETS, budget_bytes, rcache_evicted);
}

bool rcache_on(void) { return rcache_lru.budget > 0; }

struct blob *rcache_get(const char *key, uint64_t *rays) {
    work_assert_locked();
    struct rcache_item *it = (struct rcache_item *)lru_find(&rcache_lru, key);
    if (!it) return NULL;
    if (rays) *rays = it->rays;
    return blob_ref(it->png);
}

void rcache_put(const char *key, struct blob *png, uint64_t rays) {
    work_assert_locked();
    size_t need = png->len + sizeof(struct rcache_item);
    if (need > rcache_lru.budget || lru_find(&rcache_lru, key)) return;
    struct rcache_item *it = calloc(1, sizeof *it);
    if (!it) return;
    snprintf(it->key, sizeof it->key, "%s", key);
    it->node.key = it->key;
    it->node.bytes = need;
    it->png = blob_ref(png);
    it->rays = rays;
    if (lru_insert(&rcache_lru, &it->node)) blob_kind(png, MEM_CACHES);
}

bool rcache_evict_one(void) {
    work_assert_locked();
    struct lru_node *n = rcache_lru.tail;
    if (!n) return false;
    lru_remove(&rcache_lru, n);
    rcache_evicted(n);
    return true;
}

void rcache_stats(size_t *bytes, size_t *entries) {
    *bytes = rcache_lru.bytes;
    *entries = rcache_lru.count;
}

void rcache_free_all(void) { lru_clear(&rcache_lru); }
