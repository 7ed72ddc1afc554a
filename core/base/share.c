/* share.c -- what scenes decode from bytes, shared by the scenes that name
 * the same bytes.
 *
 * A render farm parses one scene once per frame (a frame is a pure function
 * of the scene's bytes and its number), and most of what a parse makes from
 * bytes is the same every frame: four 4096x4096 PNG textures cost about
 * 1.2 s of decoding, a 1.3M-triangle PLY mesh 0.25 s of decoding and BVH
 * building, a thousand times over for a thousand frames, though no frame
 * changes a texel or a triangle.  An asset cache (rayd_asset_cache, handed
 * to the parses in rayd_limits) lets a parse take what another scene made
 * from the same bytes instead of making it again.  This file is the cache;
 * each kind's entry (shade/texels.c's images, geom/mesh_share.c's meshes)
 * begins with its struct share and says how it is freed.
 *
 * The cache holds no entry of its own: the scenes hold them, each a
 * reference, and the last scene to let go frees the entry and takes it out
 * of the cache.  So it keeps nothing alive that no scene needs, and a
 * program's memory accounting of its scenes stays whole (a shared entry is
 * counted in each scene that holds it: more, never less, than is used).
 * A program that keeps recent scenes (rayd's compile cache) keeps their
 * entries findable with them.  A program that has no scene alive between
 * two parses (rayd-render, frame after frame, one scene in memory) makes
 * a holding cache instead: it keeps a reference to every entry until it
 * is freed, which costs nothing more while each frame uses them all.
 *
 * Entries are matched on their kind and their whole bytes (a seeded 64-bit
 * hash first, then memcmp), never on a hash alone: a crafted collision cannot
 * give one scene another's pixels or triangles.  What is made from bytes is
 * a pure function of them, so a hit gives what making it would; the limits
 * that depend on the scene are checked by the loader either way.  One mutex
 * guards the list and every entry's count; the list is as long as the
 * distinct entries live scenes hold.
 */
#include "base/share.h"

#include <pthread.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/random.h>
#include <time.h>

#include "rayd/rayd.h"

struct rayd_asset_cache {
    pthread_mutex_t lock;
    struct share *list;
    bool released; /* rayd_asset_cache_free was called: the last entry frees it */
    bool hold;     /* each entry keeps a reference of the cache's until it is freed */
    uint64_t seed; /* share_hash's */
    long hits[SHARE_KINDS], misses[SHARE_KINDS];
};

/* A 64-bit hash of all the bytes, seeded per cache with random bits: four
 * lanes of multiply-rotate rounds (xxHash64's shape) read 32 bytes a
 * step, so a 25 MB mesh file hashes in a few milliseconds.  It is only a
 * sieve, as every match is confirmed by memcmp; the seed keeps a client
 * from making many entries of one hash, each then compared in full under
 * the lock whenever its hash is looked up. */
#define SHARE_P1 0x9e3779b185ebca87ull
#define SHARE_P2 0xc2b2ae3d27d4eb4full

static uint64_t share_round(uint64_t h, uint64_t w) {
    h += w * SHARE_P2;
    h = h << 31 | h >> 33;
    return h * SHARE_P1;
}

static uint64_t share_hash(uint64_t seed, const void *key, size_t len) {
    const unsigned char *b = key;
    uint64_t v[4] = {seed + SHARE_P1, seed ^ SHARE_P2, seed, seed - SHARE_P1}, w;
    size_t i = 0;
    for (; i + 32 <= len; i += 32)
        for (int k = 0; k < 4; k++) {
            memcpy(&w, b + i + 8 * k, 8);
            v[k] = share_round(v[k], w);
        }
    uint64_t h = (uint64_t)len * SHARE_P1;
    for (int k = 0; k < 4; k++) h = share_round(h ^ v[k], (uint64_t)k);
    for (; i < len; i++) h = share_round(h, b[i]);
    h ^= h >> 29;
    return h * SHARE_P2 ^ (h >> 32);
}

rayd_asset_cache *rayd_asset_cache_new(int hold) {
    rayd_asset_cache *c = calloc(1, sizeof *c);
    if (c && pthread_mutex_init(&c->lock, NULL) != 0) {
        free(c);
        return NULL;
    }
    if (!c) return NULL;
    c->hold = hold != 0;
    if (getrandom(&c->seed, sizeof c->seed, GRND_NONBLOCK) != (ssize_t)sizeof c->seed)
        c->seed = (uint64_t)(uintptr_t)c ^ (uint64_t)time(NULL) * SHARE_P1; /* no entropy yet */
    return c;
}

static void share_cache_destroy(struct rayd_asset_cache *c) {
    pthread_mutex_destroy(&c->lock);
    free(c);
}

void rayd_asset_cache_free(rayd_asset_cache *c) {
    if (!c) return;
    pthread_mutex_lock(&c->lock);
    c->released = true;
    bool empty = c->list == NULL, hold = c->hold;
    pthread_mutex_unlock(&c->lock);
    if (empty) {
        share_cache_destroy(c);
        return;
    }
    if (!hold) return;
    /* let go of the cache's own references: the last one (possibly this
     * call's) unlists an entry, and the last entry frees the cache */
    for (bool more = true; more;) {
        pthread_mutex_lock(&c->lock);
        struct share *s = c->list;
        while (s && s->dropped) s = s->next;
        if (s) s->dropped = true;
        struct share *u = s ? s->next : NULL;
        while (u && u->dropped) u = u->next;
        more = u != NULL; /* then u's reference keeps c alive past s's unref */
        pthread_mutex_unlock(&c->lock);
        if (s) share_unref(s); /* may free c: not touched after the last */
    }
}

void rayd_asset_cache_stats(const rayd_asset_cache *cache, enum rayd_asset_kind kind, long *hits,
                            long *misses) {
    rayd_asset_cache *c = (rayd_asset_cache *)(uintptr_t)cache; /* its lock changes */
    int k = kind == RAYD_ASSET_MESH ? SHARE_MESH : SHARE_IMAGE;
    pthread_mutex_lock(&c->lock);
    *hits = c->hits[k];
    *misses = c->misses[k];
    pthread_mutex_unlock(&c->lock);
}

struct share *share_find(struct rayd_asset_cache *c, int kind, unsigned variant, const void *key,
                         size_t len, bool (*fits)(const struct share *s, const void *arg),
                         const void *arg) {
    if (!c) return NULL;
    uint64_t h = share_hash(c->seed, key, len);
    pthread_mutex_lock(&c->lock);
    struct share *s = c->list;
    /* one that does not fit (the loader then refuses it, in its words)
     * may have a twin that does */
    while (s && !(s->kind == kind && s->variant == variant && s->hash == h && s->key_len == len &&
                  !memcmp(s->key, key, len) && (!fits || fits(s, arg))))
        s = s->next;
    if (s) {
        s->refs++; /* every listed entry has a reference: the last one unlists it */
        c->hits[kind]++;
    }
    pthread_mutex_unlock(&c->lock);
    return s;
}

void share_add(struct rayd_asset_cache *c, struct share *s, int kind, unsigned variant,
               unsigned char *key, size_t len, bool hold) {
    s->cache = c;
    s->refs = 1;
    s->kind = kind;
    s->variant = variant;
    s->key = key;
    s->key_len = len;
    s->hash = share_hash(c->seed, key, len);
    pthread_mutex_lock(&c->lock);
    s->next = c->list;
    c->list = s;
    c->misses[kind]++;
    s->dropped = !(c->hold && hold); /* no reference of the cache's to let go of */
    if (!s->dropped) s->refs++;      /* the cache's own, until it is freed */
    pthread_mutex_unlock(&c->lock);
}

void share_unref(struct share *s) {
    if (!s) return;
    struct rayd_asset_cache *c = s->cache;
    pthread_mutex_lock(&c->lock);
    bool last = --s->refs == 0;
    if (last) {
        struct share **pp = &c->list;
        while (*pp != s) pp = &(*pp)->next;
        *pp = s->next;
    }
    bool destroy = last && c->released && !c->list;
    pthread_mutex_unlock(&c->lock);
    if (!last) return;
    free(s->key);
    s->drop(s);
    if (destroy) share_cache_destroy(c);
}
