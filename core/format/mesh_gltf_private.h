/* mesh_gltf_private.h -- what the glTF reader's two files share (internal
 * to mesh_gltf.c and mesh_gltf_anim.c): the reader's state (struct gl, and
 * struct gltf_doc around it), its error macro, and the few getters of
 * mesh_gltf.c that the animation channels read their samplers with.  The
 * files use each other one way: mesh_gltf_anim.c calls these, and the walk
 * reaches the animation only through the callback G->animate. */
#ifndef MESH_GLTF_PRIVATE_H
#define MESH_GLTF_PRIVATE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include <cjson/cJSON.h>

#include "base/bytes.h"
#include "base/error.h"
#include "format/gltf_json.h"
#include "format/json_pointer.h"
#include "format/mesh_gltf.h"

struct gl_buf {
    unsigned char *data; /* NULL until loaded */
    size_t len;
    bool owned;
};

/* A node's animated translation, rotation and scale, where a channel set them. */
struct gl_pose {
    bool has_t, has_r, has_s;
    double t[3], r[4], s[3];
};

/* One primitive drawn by one node (whose world matrix is world[node]). */
struct gl_draw {
    const cJSON *prim;
    int mesh, index; /* /meshes/mesh/primitives/index */
    int node;
};

/* An accessor's data: element i, component c is at p + i * stride + c * size. */
struct gl_acc {
    const unsigned char *p; /* NULL: every value 0 (no bufferView) */
    size_t stride;
    int ctype, ncomp;
    bool norm;
    uint32_t count;
    int id;
};

struct gl {
    const cJSON *root;
    const struct mesh_gltf_opts *o;
    struct rayd_error *err;
    const unsigned char *bin; /* the GLB's BIN chunk, or NULL */
    size_t bin_len;
    struct gl_buf *bufs;
    int nbufs;
    size_t loaded;
    bool counted; /* gl_count is done: the bake reads the same accessors again */
    uint32_t max_verts, max_tris;
    const struct mesh_limits *lim; /* its charge hook: the bake's arrays charged first */
    size_t charged;                /* bytes charged through it for pos, nrm, uv and idx */
    struct gl_draw *draws;
    size_t ndraws, cap_draws;
    unsigned char *seen; /* per node: 1 on the walk's path, 2 done */
    double *world;       /* per node: 16 numbers, column-major as glTF writes them */
    int nnodes;
    uint64_t nverts, ntris;
    bool normals;
    float *pos, *nrm;
    uint32_t *idx;
    uint32_t vat, tat;
    /* the whole-scene import (gltf_doc_bake): a material per triangle, and
     * texture coordinates of the set uv_set[material] (-1 or past nuv_set:
     * none, so 0) */
    bool want_parts;
    const int *uv_set;
    int nuv_set;
    int32_t *tmat;
    float *uv;
    /* a node animation played (gltf_doc_animate): animation anim_id at
     * anim_t seconds, its channels' values per node in pose */
    int anim_id; /* -1: none */
    double anim_t;
    struct gl_pose *pose;
    /* the walk's call into mesh_gltf_anim.c, set with anim_id (a callback,
     * so that mesh_gltf.c names nothing of the animation file) */
    enum rayd_status (*animate)(struct gl *G);
};

struct gltf_doc {
    struct gl G;
    struct mesh_gltf_opts o;
    struct mesh_limits lim; /* the walk's, kept for the bake's charge */
    cJSON *root;
    bool walked, baked;
};

/* Sets G's error at the JSON Pointer at, and is the code (a macro like
 * err_set, for the reason error.h gives). */
#define gl_fail(G, code, at, ...) err_set((G)->err, (code), (at)->s, __VA_ARGS__)

/* "/top/i", the JSON Pointer of an item of a top-level array. */
struct jp gl_item(const char *top, long i);
/* An integer o[key] in [lo, hi], def when absent (-1 def: required). */
enum rayd_status gl_int(struct gl *G, const cJSON *o, const struct jp *at, const char *key,
                        double def, double lo, double hi, double *out);
/* o[key] as the index of an item of the top-level array top: *item. */
enum rayd_status gl_ref(struct gl *G, const cJSON *o, const struct jp *at, const char *key,
                        const char *top, int *id, const cJSON **item);
/* n numbers at o[key] into out; def when absent. */
enum rayd_status gl_nums(struct gl *G, const cJSON *o, const struct jp *at, const char *key, int n,
                         const double *def, double *out);
/* A bufferView's place in its buffer, read in two steps so that a caller
 * may check keys of its own in between (the error a document with several
 * faults gets names the first in the same order): gl_view_span reads
 * buffer, byteOffset and byteLength of view vj (at pv); gl_view_bytes loads
 * the buffer and checks that the view lies inside it, *p its first byte. */
struct gl_span {
    int buffer;
    double offset, len;
};
enum rayd_status gl_view_span(struct gl *G, const cJSON *vj, const struct jp *pv,
                              struct gl_span *s);
enum rayd_status gl_view_bytes(struct gl *G, const struct jp *pv, const struct gl_span *s,
                               const unsigned char **p);
/* A "data:...;base64," URI's bytes; a relative file's, through the opener. */
enum rayd_status gl_data_uri(struct gl *G, const char *uri, const struct jp *p, struct gl_buf *b);
enum rayd_status gl_file_uri(struct gl *G, const char *uri, const struct jp *p, struct gl_buf *b);
/* Accessor o[key] (index into /accessors), of ncomp components, checked
 * against its bufferView and buffer (loaded on first use). */
enum rayd_status gl_accessor(struct gl *G, const cJSON *o, const struct jp *at, const char *key,
                             int ncomp, bool index, struct gl_acc *a);
/* Component c of element i, as a number (normalised integers mapped to [-1, 1] or [0, 1]). */
double gl_value(const struct gl_acc *a, uint32_t i, int c);

#endif
