/* mesh_gltf.h -- a glTF 2.0 file (.gltf or .glb) baked into one mesh (internal). */
#ifndef MESH_GLTF_H
#define MESH_GLTF_H

#include <cjson/cJSON.h>

#include "format/mesh_io.h"

/* Reads the file a .gltf's buffer names by a relative uri (already
 * %-decoded): on RAYD_OK *data is malloc'd (*len bytes, freed by the
 * reader); otherwise err holds the message (its path is replaced). */
typedef enum rayd_status (*mesh_gltf_open_fn)(void *ctx, const char *name, char **data, size_t *len,
                                              struct rayd_error *err);

struct mesh_gltf_opts {
    size_t max_bytes;       /* the buffers read (data: URIs and files) together */
    int max_nesting;        /* of the JSON document */
    mesh_gltf_open_fn open; /* NULL: a buffer naming a file is refused */
    void *ctx;
};

/* Decodes data[0..len), a .glb (it starts "glTF") or a .gltf's JSON text,
 * into *out: every triangle primitive of the default scene's nodes,
 * transformed into the file's world space.  Same contract as
 * mesh_parse_obj, but err->path is a JSON Pointer inside the glTF document
 * ("/accessors/3/count"; "" for the file as a whole).  o may be NULL (256
 * MiB of buffers, nesting 64, no files). */
enum rayd_status mesh_parse_gltf(const void *data, size_t len, const struct mesh_limits *lim,
                                 const struct mesh_gltf_opts *o, struct mesh_data *out,
                                 struct rayd_error *err);

/* ---- the whole-scene import (scene_json_gltf.c) ---------------------------
 *
 * The same reader in steps, for the "gltf" object, which needs more of the
 * file than one baked mesh: open (container, JSON, asset, extensions
 * required), walk one scene's node tree (world matrices), bake its
 * triangles with a glTF material index per triangle and texture
 * coordinates, and read the bytes of bufferViews and URIs for images.
 * Every error's path is a JSON Pointer inside the glTF document, and
 * mesh_parse_gltf's checks and messages are the same ones.  data and o
 * (with its ctx) must outlive the doc. */
struct gltf_doc;

enum rayd_status gltf_doc_open(const void *data, size_t len, const struct mesh_gltf_opts *o,
                               struct rayd_error *err, struct gltf_doc **out);
const cJSON *gltf_doc_root(const struct gltf_doc *d);
/* Walks scenes[scene], or with scene < 0 what mesh_parse_gltf walks;
 * lim bounds the primitives drawn (here) and the bake's mesh. */
enum rayd_status gltf_doc_walk(struct gltf_doc *d, int scene, const struct mesh_limits *lim);
/* Before the walk: play node animation `animation` (an index into
 * /animations, checked by the walk) at `seconds`: its translation,
 * rotation and scale channels replace the nodes' own values. */
void gltf_doc_animate(struct gltf_doc *d, int animation, double seconds);
/* Node's world matrix (16 numbers, column-major); NULL when the walk did
 * not reach the node. */
const double *gltf_doc_world(const struct gltf_doc *d, int node);
/* The walked scene as one mesh (as mesh_parse_gltf's) whose out->uv holds,
 * when nuv_set > 0, each vertex's TEXCOORD_<uv_set[m]> (m its primitive's
 * material; 0, 0 when the set is -1 or absent) with v flipped to rayd's
 * (v = 0 at the image's bottom), and *tri_mat (malloc'd) each triangle's
 * material index, -1 for a primitive without one. */
enum rayd_status gltf_doc_bake(struct gltf_doc *d, const int *uv_set, int nuv_set,
                               struct mesh_data *out, int32_t **tri_mat);
/* The bytes of the bufferView o[key] (o at JSON Pointer at), in the doc's buffers. */
enum rayd_status gltf_doc_view(struct gltf_doc *d, const cJSON *o, const char *at, const char *key,
                               const unsigned char **p, size_t *len);
/* The bytes of a data: URI or a relative file (the opener), malloc'd,
 * counted against max_bytes with the buffers. */
enum rayd_status gltf_doc_uri(struct gltf_doc *d, const char *uri, const char *at,
                              unsigned char **p, size_t *len);
void gltf_doc_free(struct gltf_doc *d);

#endif
