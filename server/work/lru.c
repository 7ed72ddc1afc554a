/* lru.c -- the least-recently-used index both caches are built on.
 *
 * cache.c (compiled scenes) and rcache.c (finished PNGs) keep different
 * things with different lifetimes, but find, order and evict them the same
 * way: a chained hash table on a string key for lookup, a doubly linked
 * list for recency (most recent first), and a byte budget; inserting past
 * the budget evicts from the tail through the owner's callback.  Entries
 * embed a struct lru_node and the owner frees them, so this file never
 * allocates.  No lock: both callers run under work_lock.
 */
#include "work/work_private.h"

#include <string.h>

void lru_init(struct lru *l, struct lru_node **table, unsigned nbuckets, size_t budget,
              void (*evict)(struct lru_node *n)) {
    memset(table, 0, sizeof *table * nbuckets);
    memset(l, 0, sizeof *l);
    l->table = table;
    l->nbuckets = nbuckets;
    l->budget = budget;
    l->evict = evict;
}

static unsigned lru_bucket(const struct lru *l, const char *key) {
    unsigned h = 2166136261u; /* FNV-1a */
    for (; *key; key++) h = (h ^ (unsigned char)*key) * 16777619u;
    return h % l->nbuckets;
}

static void lru_list_unlink(struct lru *l, struct lru_node *n) {
    if (n->prev)
        n->prev->next = n->next;
    else
        l->head = n->next;
    if (n->next)
        n->next->prev = n->prev;
    else
        l->tail = n->prev;
    n->prev = n->next = NULL;
}

static void lru_list_front(struct lru *l, struct lru_node *n) {
    n->next = l->head;
    n->prev = NULL;
    if (l->head) l->head->prev = n;
    l->head = n;
    if (!l->tail) l->tail = n;
}

struct lru_node *lru_find(struct lru *l, const char *key) {
    for (struct lru_node *n = l->table[lru_bucket(l, key)]; n; n = n->hnext)
        if (!strcmp(n->key, key)) {
            lru_list_unlink(l, n);
            lru_list_front(l, n);
            return n;
        }
    return NULL;
}

void lru_remove(struct lru *l, struct lru_node *n) {
    struct lru_node **pp = &l->table[lru_bucket(l, n->key)];
    while (*pp && *pp != n) pp = &(*pp)->hnext;
    if (*pp) *pp = n->hnext;
    lru_list_unlink(l, n);
    l->bytes -= n->bytes;
    l->count--;
}

bool lru_insert(struct lru *l, struct lru_node *n) {
    if (n->bytes > l->budget) return false;
    while (l->tail && l->bytes + n->bytes > l->budget) {
        struct lru_node *old = l->tail;
        lru_remove(l, old);
        l->evict(old);
    }
    unsigned b = lru_bucket(l, n->key);
    n->hnext = l->table[b];
    l->table[b] = n;
    lru_list_front(l, n);
    l->bytes += n->bytes;
    l->count++;
    return true;
}

void lru_clear(struct lru *l) {
    while (l->head) {
        struct lru_node *n = l->head;
        lru_remove(l, n);
        l->evict(n);
    }
}
