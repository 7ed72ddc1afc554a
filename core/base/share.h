/* share.h -- what scenes decode from bytes, shared by the scenes that name
 * the same bytes: image textures (shade/texels.c) and built meshes
 * (geom/mesh_share.c) in one rayd_asset_cache. */
#ifndef SHARE_H
#define SHARE_H

#include <stdbool.h>
#include <stddef.h>

struct rayd_asset_cache; /* rayd.h's opaque handle, defined in share.c */

/* The kinds of entry; rayd_asset_cache_stats counts each apart. */
enum share_kind { SHARE_IMAGE, SHARE_MESH, SHARE_KINDS };

/* One entry, held by every scene that uses it: the head of a larger
 * struct of its kind's (struct texels, struct mesh_share), which drop
 * frees whole once the last reference is gone. */
struct share {
    void (*drop)(struct share *s);
    /* the cache's: */
    struct rayd_asset_cache *cache;
    long refs;
    int kind;
    unsigned variant;        /* what else the entry was made with (a mesh's format, smoothing) */
    unsigned long long hash; /* share.c's share_hash of the key */
    size_t key_len;
    unsigned char *key; /* the bytes it was made from */
    struct share *next;
    bool dropped; /* a holding cache let go of its reference */
};

/* The entry of kind and variant made from the len bytes at key,
 * referenced, when a live scene holds one and fits (fits NULL: any), else
 * NULL.  c may be NULL (then NULL).  A find counts as shared. */
struct share *share_find(struct rayd_asset_cache *c, int kind, unsigned variant, const void *key,
                         size_t len, bool (*fits)(const struct share *s, const void *arg),
                         const void *arg);
/* s (its drop set) listed in c as the entry of kind and variant made from
 * the len bytes at key (malloc'd, taken: freed with s), referenced.
 * Another thread may add the same bytes meanwhile: both live.  An add
 * counts as made.  hold: a holding cache keeps it too (bytes every frame
 * names: a file's, the scene text's); else only the scenes do (a gltf
 * object's baked meshes, which an animation makes anew each frame: held,
 * a long job would keep every frame's). */
void share_add(struct rayd_asset_cache *c, struct share *s, int kind, unsigned variant,
               unsigned char *key, size_t len, bool hold);
/* Lets go of one reference: the last one takes s out of its cache and
 * drops it. */
void share_unref(struct share *s);

#endif
