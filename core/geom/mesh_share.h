/* mesh_share.h -- built meshes shared by the scenes whose mesh sources are
 * the same bytes (base/share.c has the cache and why). */
#ifndef MESH_SHARE_H
#define MESH_SHARE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "base/share.h"
#include "geom/mesh.h"

/* The mesh built from the len bytes at key with variant (the source's
 * format and smoothing), when a live scene holds one of at most max_verts
 * vertices and max_tris triangles: m becomes a reference to it, *peak
 * what its decode and build charged at most.  False (m untouched) when
 * none, or c is NULL. */
bool mesh_share_find(struct rayd_asset_cache *c, unsigned variant, const void *key, size_t len,
                     uint32_t max_verts, uint32_t max_tris, struct mesh *m, size_t *peak);
/* The built mesh m offered in c as the one of key's len bytes (malloc'd,
 * taken) and variant, peak its decode's and build's most charged: m keeps
 * its arrays through a reference.  False when out of memory: then key is
 * freed and m stays its own. */
bool mesh_share_add(struct rayd_asset_cache *c, struct mesh *m, unsigned variant,
                    unsigned char *key, size_t len, size_t peak);

#endif
