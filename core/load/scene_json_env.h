/* scene_json_env.h -- render.environment (scene_json_env.c). */
#ifndef SCENE_JSON_ENV_H
#define SCENE_JSON_ENV_H

#include "load/scene_json_util.h"

/* Reads /render/environment, when r has one, into the scene's rs.env. */
enum rayd_status sj_environment(struct loader *ld, const cJSON *r, const struct jp *render_at);

#endif
