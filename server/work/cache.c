/* cache.c -- an LRU of compiled scenes keyed by the SHA-256 of their bytes.
 *
 * Parsing a scene and building its acceleration structure is the costly
 * part of a small render, and tile clients send the same scene many times,
 * so each distinct body is compiled once and kept while it is used.  The
 * budget is --cache-mb, counted with rayd_scene_info().bytes, inside the
 * one memory budget (--max-memory): every entry's scene is counted there
 * from cache_put to its free (scenes.c reserved it), cached or not, and
 * an entry nobody uses is evicted when a reservation needs room
 * (cache_evict_one).  Entries are
 * reference counted: a render in progress holds its scene, so an eviction
 * only unlinks the entry (it can no longer be found) and the last release
 * frees it.  A scene larger than the whole budget is used and never kept.
 *
 * The cache has no lock of its own: every call is made under work_lock, the
 * one lock of the server (work_private.h); scenes.c and task.c are the
 * callers.  cache_hash() is a pure function and cache_scene(), cache_id()
 * and cache_version() read what never changes, so any thread may call
 * those four.  Lookup is a chained hash table on
 * the id, recency a doubly linked list: the shared index in lru.c.
 *
 * A scene that read files (meshes, textures, environment maps under
 * --asset-dir) is more than its text: each entry also keeps a version, the
 * key of its results and ETags (scenefiles.c), which names the files'
 * identities too.  Putting a scene whose id is cached under another version
 * replaces that entry: the files changed and it was compiled anew.  Renders
 * holding the old entry keep it until they release it.
 *
 * The ids themselves are computed by OpenSSL's libcrypto (EVP_Digest with
 * EVP_sha256), a maintained and audited implementation, rather than by
 * hand-written code; `sha256sum` of a body gives the same id.
 */
#include "work/work_private.h"

#include <openssl/evp.h>
#include <stdlib.h>
#include <string.h>

#define CACHE_BUCKETS 1024

struct cache_entry {
    struct lru_node node; /* first: the index finds entries through it */
    char id[65];
    char version[65]; /* id, or with the files' identities (scenefiles.c) */
    rayd_scene *scene;
    size_t mem; /* its bytes counted in --max-memory, released when freed */
    int refs;   /* holders, the cache itself counting one while linked */
    bool linked;
};

static struct lru_node *cache_table[CACHE_BUCKETS];
static struct lru cache_lru;

static void cache_evicted(struct lru_node *n) {
    struct cache_entry *e = (struct cache_entry *)n;
    e->linked = false;
    cache_release(e); /* the cache's own reference */
}

void cache_init(size_t budget_bytes) {
    lru_init(&cache_lru, cache_table, CACHE_BUCKETS, budget_bytes, cache_evicted);
}

bool cache_hash(const void *data, size_t len, char out[65]) {
    static const char hex[] = "0123456789abcdef";
    unsigned char d[EVP_MAX_MD_SIZE];
    unsigned int n = 0;
    if (!EVP_Digest(data, len, d, &n, EVP_sha256(), NULL) || n != 32) {
        out[0] = 0;
        return false;
    }
    for (unsigned i = 0; i < 32; i++) {
        out[2 * i] = hex[d[i] >> 4];
        out[2 * i + 1] = hex[d[i] & 15];
    }
    out[64] = 0;
    return true;
}

struct cache_entry *cache_get(const char *id) {
    work_assert_locked();
    struct cache_entry *e = (struct cache_entry *)lru_find(&cache_lru, id);
    if (e) e->refs++;
    return e;
}

struct cache_entry *cache_put(const char *id, const char *version, rayd_scene *scene) {
    work_assert_locked();
    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    struct cache_entry *e = (struct cache_entry *)lru_find(&cache_lru, id);
    if (e && !strcmp(e->version, version)) {
        mem_release(MEM_SCENES, info.bytes);
        rayd_scene_free(scene);
        return cache_ref(e);
    }
    if (e) { /* a version whose files have changed since: unlinked */
        lru_remove(&cache_lru, &e->node);
        cache_evicted(&e->node);
    }
    e = calloc(1, sizeof *e);
    if (!e) return NULL;
    snprintf(e->id, sizeof e->id, "%s", id);
    snprintf(e->version, sizeof e->version, "%s", version);
    e->node.key = e->id;
    e->scene = scene;
    e->node.bytes = info.bytes + sizeof *e;
    e->mem = info.bytes; /* reserved by the caller (scenes.c) */
    e->refs = 1;         /* the caller's */
    if (!lru_insert(&cache_lru, &e->node))
        return e; /* too big to keep: used once, freed on release */
    e->linked = true;
    e->refs++;
    return e;
}

struct cache_entry *cache_ref(struct cache_entry *e) {
    work_assert_locked();
    e->refs++;
    return e;
}

void cache_release(struct cache_entry *e) {
    if (!e || --e->refs > 0) return;
    mem_release(MEM_SCENES, e->mem);
    rayd_scene_free(e->scene);
    free(e);
}

bool cache_evict_one(void) {
    work_assert_locked();
    /* the least recently used entry no render holds: its memory comes back */
    for (struct lru_node *n = cache_lru.tail; n; n = n->prev) {
        struct cache_entry *e = (struct cache_entry *)n;
        if (e->refs == 1) {
            lru_remove(&cache_lru, n);
            cache_evicted(n);
            return true;
        }
    }
    return false;
}

const rayd_scene *cache_scene(const struct cache_entry *e) { return e->scene; }
const char *cache_id(const struct cache_entry *e) { return e->id; }

bool cache_fits(const struct cache_entry *e) {
    work_lock_take();
    bool fits = e->node.bytes <= cache_lru.budget;
    work_lock_give();
    return fits;
}
size_t cache_bytes(const struct cache_entry *e) { return e->mem; }
const char *cache_version(const struct cache_entry *e) { return e->version; }

void cache_stats(size_t *bytes, size_t *entries) {
    *bytes = cache_lru.bytes;
    *entries = cache_lru.count;
}

void cache_free_all(void) { lru_clear(&cache_lru); }
