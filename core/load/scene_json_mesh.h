/* scene_json_mesh.h -- mesh objects (scene_json_mesh.c). */
#ifndef SCENE_JSON_MESH_H
#define SCENE_JSON_MESH_H

#include "format/mesh_gltf.h"
#include "load/scene_json_util.h"

/* A mesh object's data, inline or from a source: *id its index in the
 * scene's meshes. */
enum rayd_status sj_mesh(struct loader *ld, const cJSON *oj, const struct jp *at, uint32_t *id);
/* Baked arrays md (a gltf object's, scene_json_gltf.c; malloc'd, their
 * bytes and the build charged by the caller) as the scene's mesh *id,
 * smoothed: taken built from a live scene whose baked arrays were the same
 * bytes (lim->assets), else built and offered to the others.  md's arrays
 * are taken either way. */
enum rayd_status sj_mesh_baked(struct loader *ld, struct mesh_data *md, uint32_t *id);
/* About the bytes md and the mesh built from it hold (sj_charge's). */
size_t sj_mesh_bytes(const struct mesh_data *md);

/* What is left of the scene's vertex and triangle limits, for the next
 * mesh a source decodes. */
struct mesh_limits sj_mesh_budget(const struct loader *ld);

/* A "source" object's bytes (text, base64 or a file): *format 0 obj, 1 ply,
 * 2 gltf, 3 glb; *out the bytes, *owned (malloc'd, for the caller to free)
 * when they are not the scene text's. */
enum rayd_status sj_source_read(struct loader *ld, const cJSON *src, const struct jp *at,
                                int *format, char **owned, const char **out, size_t *nbytes);

/* The folder a .gltf's relative buffer files are read from: the source
 * file's own folder (as a name under the asset rules), or the asset
 * folder itself for text and base64. */
struct gltf_files {
    struct loader *ld;
    char dir[1024];
};

/* The glTF reader's options for a source at `at` (file: its "file" or
 * NULL); o->ctx is f, which must outlive the reading. */
enum rayd_status sj_gltf_opts(struct loader *ld, const struct jp *at, const cJSON *file,
                              struct gltf_files *f, struct mesh_gltf_opts *o);

/* A failure st of the glTF reader: the error's path (a pointer inside the
 * glTF document) is put after the source's, at, and "/gltf". */
enum rayd_status sj_gltf_error(struct loader *ld, const struct jp *at, enum rayd_status st);

#endif
