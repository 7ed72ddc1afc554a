/* scene_json.h -- the scene loader's entry with its inner switch, for the
 * tests: rayd_scene_parse is scene_json_parse(..., SJ_INLINE_MIN, ...). */
#ifndef SCENE_JSON_H
#define SCENE_JSON_H

#include <stddef.h>

#include "rayd/rayd.h"

/* rayd_scene_parse, where inline mesh arrays of at least inline_min numbers
 * are read from the text rather than through cJSON (<= 0: none are).  The
 * result is the same for any inline_min. */
enum rayd_status scene_json_parse(const char *json, size_t len, const struct rayd_limits *lim,
                                  long inline_min, rayd_scene **out, struct rayd_error *err);

#endif
