/* mesh_gltf.h -- a glTF 2.0 file (.gltf or .glb) baked into one mesh (internal). */
#ifndef MESH_GLTF_H
#define MESH_GLTF_H

#include "io/mesh_io.h"

/* Reads the file a .gltf's buffer names by a relative uri (already
 * %-decoded): on RAYD_OK *data is malloc'd (*len bytes, freed by the
 * reader); otherwise err holds the message (its path is replaced). */
typedef enum rayd_status (*mesh_gltf_open_fn)(void *ctx, const char *name, char **data,
                                              size_t *len, struct rayd_error *err);

struct mesh_gltf_opts {
    size_t max_bytes;      /* the buffers read (data: URIs and files) together */
    int max_nesting;       /* of the JSON document */
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

#endif
