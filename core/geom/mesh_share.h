/* mesh_share.h -- built meshes shared by the scenes whose mesh sources are
 * the same bytes (base/share.c has the cache and why). */
#ifndef MESH_SHARE_H
#define MESH_SHARE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "base/share.h"
#include "geom/mesh.h"

/* What a mesh's build was allowed and charged, so that a scene that takes
 * it is answered and charged as building it would have been. */
struct mesh_terms {
    uint32_t max_verts, max_tris; /* the vertex and triangle budget its decode had */
    size_t peak;                  /* the most its decode and build charged, a file's read apart */
    size_t kept;                  /* what stayed charged once built, its key apart */
};

/* The mesh built from the len bytes at key with variant (the source's
 * format and smoothing), when a live scene holds one decoded within a
 * budget no larger than now's (a decoder refuses past its budget, so it
 * would have built this one too): m becomes a reference to it, *was its
 * terms.  False (m untouched) when none, or c is NULL. */
bool mesh_share_find(struct rayd_asset_cache *c, unsigned variant, const void *key, size_t len,
                     const struct mesh_terms *now, struct mesh *m, struct mesh_terms *was);
/* The built mesh m offered in c as the one of key's len bytes (malloc'd,
 * taken) and variant, built on terms t: m keeps its arrays through a
 * reference; hold as share_add's.  False when out of memory: then key is
 * freed and m stays its own. */
bool mesh_share_add(struct rayd_asset_cache *c, struct mesh *m, unsigned variant,
                    unsigned char *key, size_t len, const struct mesh_terms *t, bool hold);

#endif
