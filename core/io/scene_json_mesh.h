/* scene_json_mesh.h -- mesh objects (scene_json_mesh.c). */
#ifndef SCENE_JSON_MESH_H
#define SCENE_JSON_MESH_H

#include "io/scene_json_util.h"

/* A mesh object's data, inline or from a source: *id its index in the
 * scene's meshes. */
enum rayd_status sj_mesh(struct loader *ld, const cJSON *oj, const struct jp *at, uint32_t *id);

#endif
