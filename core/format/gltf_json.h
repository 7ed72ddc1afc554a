/* gltf_json.h -- what every glTF reader shares of the glTF's JSON
 * (internal: mesh_gltf.c, gltf_material.c, scene_json_gltf.c): a key's
 * lookup and the early return on an error.  An error inside a glTF file
 * names the value by its JSON Pointer in the glTF's own document
 * (json_pointer.h). */
#ifndef GLTF_JSON_H
#define GLTF_JSON_H

#include <cjson/cJSON.h>

#include "base/error.h"
#include "format/json_pointer.h"

#define TRY_GL(expr)                                                                               \
    do {                                                                                           \
        enum rayd_status st_ = (expr);                                                             \
        if (st_ != RAYD_OK) return st_;                                                            \
    } while (0)

/* o[key], or NULL when o is no object or has no such key. */
static inline const cJSON *gl_get(const cJSON *o, const char *key) {
    return cJSON_IsObject(o) ? cJSON_GetObjectItemCaseSensitive(o, key) : NULL;
}

#endif
