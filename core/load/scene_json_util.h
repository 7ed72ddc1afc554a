/* scene_json_util.h -- the scene loader's state and the typed getters
 * every part of it uses (scene_json_util.c owns them).  Private to the
 * scene_json*.c files (cJSON's tree is read by them, by the glTF readers
 * mesh_gltf.c and gltf_material.c, and parsed in json_parse.c).  The
 * loader's files call one way, each only those below it:
 *
 *   scene_json.c           the entry point: render, camera, lights, the order
 *   scene_json_frame.c     camera.frame: the camera placed round the objects
 *   scene_json_env.c       render.environment: a colour or an .hdr image
 *   scene_json_objects.c   objects: shapes, CSG, groups and instances, transforms
 *   scene_json_gltf.c      gltf objects: a glTF file's meshes, materials, lights, camera
 *   scene_json_material.c  named and inline materials
 *   scene_json_texture.c   material textures
 *   scene_json_mesh.c      meshes: inline arrays, OBJ/PLY sources
 *   scene_json_inline.c    large inline arrays kept out of cJSON's tree
 *   scene_json_anim.c      /animation and keyframes: the tree at one frame
 *   scene_json_util.c      JSON Pointers, the typed getters, files a scene names
 *
 * Every getter checks one value and, when it is wrong, fills the error with
 * the value's JSON Pointer and what is wrong, and returns the status; TRY
 * returns it up the call chain.
 */
#ifndef SCENE_JSON_UTIL_H
#define SCENE_JSON_UTIL_H

#include <stdbool.h>

#include <cjson/cJSON.h>

#include "base/array.h"
#include "base/error.h"
#include "geom/camera_frame.h"
#include "format/json_pointer.h"
#include "scene/scene.h"

#define NUM_MAX 1e9             /* coordinates and sizes: generous but far from overflow */
#define NUM_RANGE "[-1e9, 1e9]" /* the same, for messages */

/* ---- the loader ---------------------------------------------------------- */

struct sj_anim;

struct named {
    const char *name;
    int index;
};

struct loader;

/* The keys of the object obj sorted, each with first + its place, into
 * *out (malloc'd; NULL when none) and *n: looked up by binary search
 * (sj_name_find), since a million objects naming ten thousand materials or
 * groups must not scan them. */
enum rayd_status sj_names_sorted(struct loader *ld, const cJSON *obj, int first, struct named **out,
                                 int *n);
/* The entry of name among the n sorted names, or NULL. */
const struct named *sj_name_find(const struct named *names, int n, const char *name);

struct loader {
    const struct rayd_limits *lim;
    rayd_scene *s;
    struct rayd_error *err;
    struct named *group_names; /* /groups keys, sorted (sj_names_sorted) */
    int ngroup_names;
    struct named *mat_names; /* /materials keys, sorted */
    int nmat_names;
    size_t mat_cap, tex_cap, mesh_cap, xform_cap, part_cap; /* array capacities */
    long objects;                /* objects, operands and group members so far */
    long triangles, vertices;    /* totals so far, against the limits */
    long texels;                 /* pixels of the image textures so far (sj_max_texels) */
    const struct sj_inline *inl; /* inline mesh arrays left out of the tree */
    bool frame;                  /* camera.frame: placed after the objects load */
    double frame_azimuth;        /* degrees about +Y: the view's, or camera.azimuth */
    double frame_elevation;      /* degrees above the horizon: the view's, or camera.elevation */
    double frame_fx, frame_fy;   /* the camera's fov_x, fov_y as given (0 = absent) */
    bool frame_focus;            /* focus_distance given: kept when framing */
    const cJSON *camera;         /* /camera, or NULL */
    bool gltf_camera;            /* a gltf object has set the camera */
    bool values_only;            /* rayd_scene_check_frames: no file is read */
    bool gltf_animated;          /* the gltf object being read plays an animation */
    double frame_work;           /* rayd_scene_info.frame_work, of the gltf objects so far */
    struct sj_anim *anim;        /* the frame being loaded (scene_json_anim.h) */
};

/* A frame's parse in rays' worth (rayd_scene_info.frame_work), measured
 * roughly on one core and rounded up: a ray takes about 0.1 us. */
#define SJ_WORK_TEXT_BYTES 16 /* bytes of scene text parsed in a ray's time */
#define SJ_WORK_OBJECT 10     /* an object loaded and placed in the scene's BVH */
#define SJ_WORK_KEYED 100     /* an owner's keyframes read and evaluated (9 us measured) */
#define SJ_WORK_BAKE_TRI 1    /* a gltf triangle baked (0.66 measured: bench/README.md) */
#define SJ_WORK_BUILD_TRI 6   /* ... and built into a BVH (animated: never shared) */

enum vec_rule { VEC_ANY, VEC_NONZERO, VEC_COLOR };

#define TRY(expr)                                                                                  \
    do {                                                                                           \
        enum rayd_status st_ = (expr);                                                             \
        if (st_ != RAYD_OK) return st_;                                                            \
    } while (0)

const char *sj_type_name(const cJSON *v);
/* The pixels all of the scene's image textures may have together: the
 * limits' max_texels, or the default (TEXTURE_MAX_SCENE_PIXELS). */
long sj_max_texels(const struct loader *ld);
enum rayd_status sj_fail(struct loader *ld, enum rayd_status code, const struct jp *at,
                         const char *fmt, ...) __attribute__((format(printf, 4, 5)));
/* Every key of obj must be in allowed (NULL-terminated; NULL = any) and
 * appear once. */
enum rayd_status sj_check_keys(struct loader *ld, const cJSON *obj, const struct jp *at,
                               const char *const *allowed);
/* A number in [lo, hi] (lo excluded when lo_open); def when absent. */
enum rayd_status sj_num(struct loader *ld, const cJSON *obj, const struct jp *at, const char *key,
                        double def, double lo, bool lo_open, double hi, double *out);
/* A whole number in [lo, hi]; over hi is RAYD_E_LIMIT when hi_is_limit. */
enum rayd_status sj_int(struct loader *ld, const cJSON *obj, const struct jp *at, const char *key,
                        long def, long lo, long hi, bool hi_is_limit, long *out);
/* Item i (e) of the array at p: a number in [-max, max], range naming that
 * interval for the message ("[-1e9, 1e9]"); the error is at the item. */
enum rayd_status sj_item_num(struct loader *ld, const cJSON *e, const struct jp *p, int i,
                             double max, const char *range, double *out);
/* An array of 3 numbers (v itself, named p). */
enum rayd_status sj_vec_value(struct loader *ld, const cJSON *v, const struct jp *p,
                              enum vec_rule rule, vec3 *out);
enum rayd_status sj_vec(struct loader *ld, const cJSON *obj, const struct jp *at, const char *key,
                        vec3 def, enum vec_rule rule, vec3 *out);
/* A string that must be one of names (NULL-terminated): *out its index;
 * -1 and no error when absent and def_absent. */
enum rayd_status sj_enum(struct loader *ld, const cJSON *obj, const struct jp *at, const char *key,
                         const char *const *names, int *out);
enum rayd_status sj_type(struct loader *ld, const cJSON *obj, const struct jp *at,
                         const char *const *types, int *out);
enum rayd_status sj_bool(struct loader *ld, const cJSON *obj, const struct jp *at, const char *key,
                         bool def, bool *out);

/* Tells the limits' charge (if any) that the value at *at is about to
 * take bytes; its refusal is the error at *at. */
enum rayd_status sj_charge(struct loader *ld, const struct jp *at, size_t bytes);
/* Gives back bytes charged that are freed before the parse ends. */
void sj_give_back(struct loader *ld, size_t bytes);

/* Reads a file a scene names, under the limits' asset rules. */
enum rayd_status sj_read_asset(struct loader *ld, const cJSON *f, const struct jp *at, char **out,
                               size_t *len);

#endif
