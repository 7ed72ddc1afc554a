/* mesh_share.c -- built meshes shared by the scenes whose mesh sources are
 * the same bytes.
 *
 * The frames of an animation parse the same mesh sources each frame: a
 * 1.3M-triangle PLY took 0.25 s a frame to decode and build, nearly all of
 * a 640x360 frame's time.  A scene's mesh from an OBJ or PLY source, or
 * from large inline arrays (read from the scene's text), is offered in the
 * asset cache under the source's bytes (the arrays' text), its format and
 * its smoothing (all the build depends on), and the next parse of the same
 * bytes takes it: the same triangles, tree and normals, so the same
 * pixels.  Each scene holds a copy of struct mesh that points at the
 * shared arrays, and counts them whole (mesh_bytes), as a shared image is.
 */
#include "geom/mesh_share.h"

#include <stdlib.h>

struct mesh_share {
    struct share sh; /* first: its key is the source's bytes */
    struct mesh m;   /* the arrays' owner (its shared NULL) */
    struct mesh_terms t;
};

static bool mesh_share_fits(const struct share *s, const void *arg) {
    const struct mesh_terms *was = &((const struct mesh_share *)s)->t, *now = arg;
    return now->max_verts >= was->max_verts && now->max_tris >= was->max_tris;
}

static void mesh_share_drop(struct share *s) {
    struct mesh_share *x = (struct mesh_share *)s;
    mesh_free(&x->m);
    free(x);
}

bool mesh_share_find(struct rayd_asset_cache *c, unsigned variant, const void *key, size_t len,
                     const struct mesh_terms *now, struct mesh *m, struct mesh_terms *was) {
    struct share *s = share_find(c, SHARE_MESH, variant, key, len, mesh_share_fits, now);
    if (!s) return false;
    struct mesh_share *x = (struct mesh_share *)s;
    *m = x->m;
    m->shared = s;
    *was = x->t;
    return true;
}

bool mesh_share_add(struct rayd_asset_cache *c, struct mesh *m, unsigned variant,
                    unsigned char *key, size_t len, const struct mesh_terms *t, bool hold) {
    struct mesh_share *x = malloc(sizeof *x);
    if (!x) {
        free(key);
        return false;
    }
    *x = (struct mesh_share){.sh.drop = mesh_share_drop, .m = *m, .t = *t};
    share_add(c, &x->sh, SHARE_MESH, variant, key, len, hold);
    m->shared = &x->sh;
    return true;
}
