/* scene_json_frame.h -- camera.frame, automatic framing (scene_json_frame.c). */
#ifndef SCENE_JSON_FRAME_H
#define SCENE_JSON_FRAME_H

#include "io/scene_json_util.h"

/* Reads /camera/frame and /camera/view from c; *framed is false when the
 * camera has no "frame" (then nothing else is read or checked). */
enum rayd_status sj_frame_read(struct loader *ld, const cJSON *c, const struct jp *at,
                               bool *framed);

/* After the objects are loaded: places the camera to frame them all. */
enum rayd_status sj_frame_apply(struct loader *ld);

#endif
