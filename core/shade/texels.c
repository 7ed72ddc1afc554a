/* texels.c -- decoded images shared by the scenes that name the same bytes.
 *
 * A render farm parses one scene once per frame (a frame is a pure function
 * of the scene's bytes and its number), and the scene's image textures are
 * the same bytes every frame: four 4096x4096 PNGs cost about 1.2 s of
 * decoding, a thousand times over for a thousand frames, though no frame
 * changes a texel.  A texel cache (rayd_image_cache, handed to the parses
 * in rayd_limits) lets a parse take the image another scene decoded from
 * the same bytes instead of decoding it again.
 *
 * The cache holds no image of its own: the scenes hold them, each a
 * reference, and the last scene to let go frees the image and takes it out
 * of the cache.  So it keeps nothing alive that no scene needs, and a
 * program's memory accounting of its scenes stays whole (a shared image is
 * counted in each scene that holds it: more, never less, than is used).
 * A program that keeps recent scenes (rayd's compile cache) keeps their
 * images findable with them.  A program that has no scene alive between
 * two parses (rayd-render, frame after frame, one scene in memory) makes
 * a holding cache instead: it keeps a reference to every image until it
 * is freed, which costs nothing more while each frame uses them all.
 *
 * Images are matched on their whole encoded bytes (a 64-bit FNV-1a first,
 * then memcmp), never on a hash alone: a crafted collision cannot give one
 * scene another's pixels.  A decoded image is a pure function of its bytes,
 * so a hit gives the same texels as decoding; the limits that depend on the
 * scene (its texel budget) are checked by the loader either way.  One
 * mutex guards the list and every entry's count; the list is as long as the
 * distinct images live scenes hold.
 */
#include "shade/texels.h"

#include <pthread.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "rayd/rayd.h"

struct rayd_image_cache {
    pthread_mutex_t lock;
    struct texels *list;
    bool released; /* rayd_image_cache_free was called: the last image frees it */
    bool hold;     /* each image keeps a reference of the cache's until it is freed */
    long hits, misses;
};

static unsigned long long texels_hash(const void *key, size_t len) {
    const unsigned char *b = key;
    unsigned long long h = 0xcbf29ce484222325ull;
    for (size_t i = 0; i < len; i++) h = (h ^ b[i]) * 0x100000001b3ull;
    return h;
}

rayd_image_cache *rayd_image_cache_new(int hold) {
    rayd_image_cache *c = calloc(1, sizeof *c);
    if (c && pthread_mutex_init(&c->lock, NULL) != 0) {
        free(c);
        return NULL;
    }
    if (c) c->hold = hold != 0;
    return c;
}

static void texels_cache_destroy(struct rayd_image_cache *c) {
    pthread_mutex_destroy(&c->lock);
    free(c);
}

void rayd_image_cache_free(rayd_image_cache *c) {
    if (!c) return;
    pthread_mutex_lock(&c->lock);
    c->released = true;
    bool empty = c->list == NULL, hold = c->hold;
    pthread_mutex_unlock(&c->lock);
    if (empty) {
        texels_cache_destroy(c);
        return;
    }
    if (!hold) return;
    /* let go of the cache's own references: the last one (possibly this
     * call's) unlists an image, and the last image frees the cache */
    for (bool more = true; more;) {
        pthread_mutex_lock(&c->lock);
        struct texels *t = c->list;
        while (t && t->dropped) t = t->next;
        if (t) t->dropped = true;
        struct texels *u = t ? t->next : NULL;
        while (u && u->dropped) u = u->next;
        more = u != NULL; /* then u's reference keeps c alive past t's unref */
        pthread_mutex_unlock(&c->lock);
        if (t) texels_unref(t); /* may free c: not touched after the last */
    }
}

void rayd_image_cache_stats(const rayd_image_cache *cache, long *hits, long *misses) {
    rayd_image_cache *c = (rayd_image_cache *)(uintptr_t)cache; /* its lock changes */
    pthread_mutex_lock(&c->lock);
    *hits = c->hits;
    *misses = c->misses;
    pthread_mutex_unlock(&c->lock);
}

struct texels *texels_find(struct rayd_image_cache *c, const void *key, size_t len,
                           long max_pixels) {
    if (!c) return NULL;
    unsigned long long h = texels_hash(key, len);
    pthread_mutex_lock(&c->lock);
    struct texels *t = c->list;
    while (t && !(t->hash == h && t->key_len == len && !memcmp(t->key, key, len))) t = t->next;
    if (t && (long)t->w * t->h > max_pixels) t = NULL; /* the decoder refuses it, in its words */
    if (t) {
        t->refs++; /* every listed image has a reference: the last one unlists it */
        c->hits++;
    }
    pthread_mutex_unlock(&c->lock);
    return t;
}

struct texels *texels_add(struct rayd_image_cache *c, const void *key, size_t len, int w, int h,
                          float *rgb) {
    struct texels *t = calloc(1, sizeof *t);
    unsigned char *copy = malloc(len ? len : 1);
    if (!t || !copy) {
        free(t);
        free(copy);
        free(rgb);
        return NULL;
    }
    memcpy(copy, key, len);
    *t = (struct texels){.w = w,
                         .h = h,
                         .rgb = rgb,
                         .cache = c,
                         .refs = 1,
                         .key = copy,
                         .key_len = len,
                         .hash = texels_hash(key, len)};
    pthread_mutex_lock(&c->lock);
    t->next = c->list;
    c->list = t;
    c->misses++;
    if (c->hold) t->refs++; /* the cache's own, until it is freed */
    pthread_mutex_unlock(&c->lock);
    return t;
}

void texels_unref(struct texels *t) {
    if (!t) return;
    struct rayd_image_cache *c = t->cache;
    pthread_mutex_lock(&c->lock);
    bool last = --t->refs == 0;
    if (last) {
        struct texels **pp = &c->list;
        while (*pp != t) pp = &(*pp)->next;
        *pp = t->next;
    }
    bool destroy = last && c->released && !c->list;
    pthread_mutex_unlock(&c->lock);
    if (!last) return;
    free(t->rgb);
    free(t->key);
    free(t);
    if (destroy) texels_cache_destroy(c);
}
