/* scene_json_objects.h -- the objects of a scene (scene_json_objects.c). */
#ifndef SCENE_JSON_OBJECTS_H
#define SCENE_JSON_OBJECTS_H

#include "load/scene_json_util.h"

/* /groups: named lists of objects that instances draw. */
enum rayd_status sj_groups(struct loader *ld, const cJSON *root);
/* /objects: the scene's top level. */
enum rayd_status sj_objects(struct loader *ld, const cJSON *root);

#endif
