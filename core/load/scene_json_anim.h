/* scene_json_anim.h -- time in a scene (scene_json_anim.c): the /animation
 * block and the keyframes of the camera, lights and objects, evaluated at
 * one frame.  Private to the scene loader. */
#ifndef SCENE_JSON_ANIM_H
#define SCENE_JSON_ANIM_H

#include "load/scene_json_util.h"

/* An object's keyframed transform at the frame. */
struct sj_anim_xf {
    const cJSON *obj;
    struct xform x;
};

/* A value the keyframes put in the tree: its pointer, and the keyframes'. */
struct sj_anim_sub {
    char at[256], keys[256];
};

struct sj_anim {
    bool on;         /* the scene has an /animation block */
    long start, end; /* its frames, inclusive */
    double fps;
    long frame;            /* the frame being built */
    long keyed;            /* owners with keyframes: the camera, lights, objects */
    bool keep;             /* values only (rayd_scene_check_frames): the objects'
                              keyframes stay in the tree, no transform is kept */
    struct sj_anim_xf *xf; /* sorted by obj once the walk is done */
    size_t nxf, xf_cap;
    struct sj_anim_sub *sub;
    size_t nsub, sub_cap;
};

/* Reads /animation and every keyframes block, checks them, and sets up
 * frame `frame` (< 0: the first): the camera's and lights' keyframed
 * values are written into the tree in place of their keyframes, the
 * objects' transforms kept for sj_anim_xform.  A frame outside the range
 * is RAYD_E_ARG. */
enum rayd_status sj_anim_load(struct loader *ld, cJSON *root, long frame);
/* The scene's frames, from /animation (*on false: a still scene). */
enum rayd_status sj_anim_range(struct loader *ld, const cJSON *root, bool *on, long *start,
                               long *end);
/* The keyframed transform of object obj at the frame: true and *x, or false. */
bool sj_anim_xform(const struct sj_anim *a, const cJSON *obj, struct xform *x);
/* An error the loader found in a value the keyframes wrote is named by the
 * keyframes' pointer, with the frame and the key. */
void sj_anim_error(const struct sj_anim *a, struct rayd_error *err);
/* Seconds since the first frame (glTF animations run on seconds). */
double sj_anim_seconds(const struct sj_anim *a);
void sj_anim_free(struct sj_anim *a);

#endif
