/* scene_json_material.h -- named and inline materials (scene_json_material.c). */
#ifndef SCENE_JSON_MATERIAL_H
#define SCENE_JSON_MATERIAL_H

#include "load/scene_json_util.h"

/* /materials: the default material as index 0, then the named ones. */
enum rayd_status sj_materials(struct loader *ld, const cJSON *root);
/* The "material" key of an object: absent (inherit), a name, or inline. */
enum rayd_status sj_object_material(struct loader *ld, const cJSON *obj, const struct jp *at,
                                    int inherit, int *index);
/* Appends m (finished) to the scene's materials: *index. */
enum rayd_status sj_add_material(struct loader *ld, const struct material *m, int *index);

#endif
