/* rcache.c -- an LRU of finished PNGs keyed by scene id and region.
 *
 * Rendering is deterministic: the same scene bytes and the same region give
 * the same PNG on any node, at any time.  So a finished PNG can answer every
 * later identical request -- a tile client re-fetching tiles, many browsers
 * opening the same immutable scene URL -- without a worker.  The budget is
 * --result-cache-mb (0 turns the cache off); the least recently used PNGs
 * are dropped first.  PNGs are shared blobs with an atomic reference count,
 * so a PNG being sent while it is evicted stays alive until sent.
 *
 * Like cache.c, this file has no lock: jobq.c calls it under its mutex.
 */
#include "server.h"

#include <stdlib.h>
#include <string.h>

#define RCACHE_BUCKETS 4096

struct rcache_item {
    char key[160];
    struct blob *png;
    struct rcache_item *hnext, *prev, *next;
};

static struct rcache_item *rcache_table[RCACHE_BUCKETS];
static struct rcache_item *rcache_head, *rcache_tail;
static size_t rcache_budget, rcache_bytes, rcache_count;

void rcache_init(size_t budget_bytes) { rcache_budget = budget_bytes; }

static unsigned rcache_bucket(const char *key)
{
    unsigned h = 2166136261u;
    for (; *key; key++)
        h = (h ^ (unsigned char)*key) * 16777619u;
    return h % RCACHE_BUCKETS;
}

static void rcache_lru_unlink(struct rcache_item *it)
{
    if (it->prev)
        it->prev->next = it->next;
    else
        rcache_head = it->next;
    if (it->next)
        it->next->prev = it->prev;
    else
        rcache_tail = it->prev;
    it->prev = it->next = NULL;
}

static void rcache_lru_front(struct rcache_item *it)
{
    it->next = rcache_head;
    it->prev = NULL;
    if (rcache_head)
        rcache_head->prev = it;
    rcache_head = it;
    if (!rcache_tail)
        rcache_tail = it;
}

static void rcache_drop(struct rcache_item *it)
{
    struct rcache_item **pp = &rcache_table[rcache_bucket(it->key)];
    while (*pp && *pp != it)
        pp = &(*pp)->hnext;
    if (*pp)
        *pp = it->hnext;
    rcache_lru_unlink(it);
    rcache_bytes -= it->png->len + sizeof *it;
    rcache_count--;
    blob_unref(it->png);
    free(it);
}

struct blob *rcache_get(const char *key)
{
    for (struct rcache_item *it = rcache_table[rcache_bucket(key)]; it; it = it->hnext)
        if (!strcmp(it->key, key)) {
            rcache_lru_unlink(it);
            rcache_lru_front(it);
            atomic_fetch_add(&it->png->refs, 1);
            return it->png;
        }
    return NULL;
}

void rcache_put(const char *key, struct blob *png)
{
    size_t need = png->len + sizeof(struct rcache_item);
    if (need > rcache_budget)
        return;
    for (struct rcache_item *it = rcache_table[rcache_bucket(key)]; it; it = it->hnext)
        if (!strcmp(it->key, key))
            return;
    struct rcache_item *it = calloc(1, sizeof *it);
    if (!it)
        return;
    while (rcache_tail && rcache_bytes + need > rcache_budget)
        rcache_drop(rcache_tail);
    snprintf(it->key, sizeof it->key, "%s", key);
    it->png = png;
    atomic_fetch_add(&png->refs, 1);
    unsigned b = rcache_bucket(key);
    it->hnext = rcache_table[b];
    rcache_table[b] = it;
    rcache_lru_front(it);
    rcache_bytes += need;
    rcache_count++;
}

void rcache_stats(size_t *bytes, size_t *entries)
{
    *bytes = rcache_bytes;
    *entries = rcache_count;
}

void rcache_free_all(void)
{
    while (rcache_head)
        rcache_drop(rcache_head);
}
