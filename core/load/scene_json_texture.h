/* scene_json_texture.h -- material textures (scene_json_texture.c). */
#ifndef SCENE_JSON_TEXTURE_H
#define SCENE_JSON_TEXTURE_H

#include "load/scene_json_util.h"

/* "texture": a pattern or image; *index into the scene's textures. */
enum rayd_status sj_texture(struct loader *ld, const cJSON *t, const struct jp *at, int *index);
/* Appends t to the scene's textures (which then own its texels): *index. */
struct texture;
enum rayd_status sj_add_texture(struct loader *ld, const struct texture *t, int *index);

#endif
