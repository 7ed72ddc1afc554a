/* scene_json_frame.h -- camera.frame, automatic framing (scene_json_frame.c). */
#ifndef SCENE_JSON_FRAME_H
#define SCENE_JSON_FRAME_H

#include "load/scene_json_util.h"

/* Reads /camera/frame, view, azimuth and elevation from c; *framed is
 * false when the camera has no "frame" (then view, azimuth and elevation
 * are refused). */
enum rayd_status sj_frame_read(struct loader *ld, const cJSON *c, const struct jp *at,
                               bool *framed);

/* After the objects are loaded: places the camera to frame them all. */
enum rayd_status sj_frame_apply(struct loader *ld);

#endif
