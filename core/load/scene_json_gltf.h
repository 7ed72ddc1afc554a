/* scene_json_gltf.h -- "gltf" objects: a glTF file as a whole scene (scene_json_gltf.c). */
#ifndef SCENE_JSON_GLTF_H
#define SCENE_JSON_GLTF_H

#include "load/scene_json_util.h"

/* The gltf object oj at `at`, placed by x: its meshes become a group that o
 * draws as an instance (o->material, when the object has a "material",
 * overrides the file's); its lights join the scene's, its camera (when
 * named) becomes the scene's. */
enum rayd_status sj_gltf(struct loader *ld, const cJSON *oj, const struct jp *at,
                         const struct xform *x, struct object *o);

#endif
