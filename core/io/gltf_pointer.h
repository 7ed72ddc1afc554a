/* gltf_pointer.h -- JSON Pointers inside a glTF document and the lookup
 * every glTF reader shares (internal: mesh_gltf.c, gltf_material.c,
 * scene_json_gltf.c).  An error inside a glTF file names the value by its
 * pointer in the glTF's own JSON, built here one key or index at a time. */
#ifndef GLTF_POINTER_H
#define GLTF_POINTER_H

#include <cjson/cJSON.h>
#include <stdio.h>

#include "base/error.h"

#define TRY_GL(expr)                                                                               \
    do {                                                                                           \
        enum rayd_status st_ = (expr);                                                             \
        if (st_ != RAYD_OK) return st_;                                                            \
    } while (0)

/* A JSON Pointer inside the glTF document (cut short, never overrun). */
struct gp {
    char s[200];
};

static inline struct gp gp_key(const struct gp *p, const char *key) {
    struct gp r;
    snprintf(r.s, sizeof r.s, "%.*s/%s", (int)(sizeof r.s - 40), p->s, key);
    return r;
}

static inline struct gp gp_index(const struct gp *p, long i) {
    struct gp r;
    snprintf(r.s, sizeof r.s, "%.*s/%ld", (int)(sizeof r.s - 24), p->s, i);
    return r;
}

/* o[key], or NULL when o is no object or has no such key. */
static inline const cJSON *gl_get(const cJSON *o, const char *key) {
    return cJSON_IsObject(o) ? cJSON_GetObjectItemCaseSensitive(o, key) : NULL;
}

#endif
