/* gltf_material.h -- glTF 2.0 materials as rayd materials (internal). */
#ifndef GLTF_MATERIAL_H
#define GLTF_MATERIAL_H

#include "format/mesh_gltf.h"
#include "shade/material.h"
#include "shade/texture.h"

/* The most materials and base colour textures a glTF may bring, and the
 * texels of all its textures together (one 4096 x 4096 image's worth). */
#define GLTF_MAX_MATERIALS 1024
#define GLTF_MAX_TEXTURES 64
#define GLTF_MAX_TEXELS TEXTURE_MAX_PIXELS

/* Material i of the file (and, at index n, glTF's default material for
 * primitives without one).  m.texture is -1 or an index into tex. */
struct gltf_mats {
    struct material *m; /* n + 1 */
    int *uv_set;        /* n + 1: the base colour texture's texCoord, -1 without */
    int n;
    struct texture *tex;
    int ntex;
    long texels;                     /* pixels of all the decoded textures */
    long budget;                     /* the most pixels they may have (gltf_mats_read's texels) */
    const struct mesh_limits *lim;   /* its charge hook: each image charged before it is decoded */
    size_t charged;                  /* bytes charged through it, given back by gltf_mats_free */
    struct rayd_asset_cache *assets; /* base colour textures shared with other scenes, or NULL */
    /* Images decoded so far, by /images index: materials that share an
     * image (with other factors) decode it once; freed, and their charge
     * given back, when gltf_mats_read returns. */
    struct gltf_decoded {
        int image;
        rayd_image *img;
    } decoded[GLTF_MAX_TEXTURES];
    int ndecoded;
    long decodes; /* images decoded by gltf_mats_read */
};

/* Reads /materials of the doc's file (at most max, and GLTF_MAX_MATERIALS)
 * and decodes their base colour images (PNG or JPEG) with the factor
 * baked in, at most texels pixels of them in all (and GLTF_MAX_TEXELS).
 * Each image is charged to lim's hook (lim may be NULL) from its header's
 * size before it is decoded, 15 bytes a pixel, and the 8-bit pixels given
 * back once they are linear: out->charged is then 12 bytes a texel.
 * Errors name the JSON Pointer inside the glTF document. */
enum rayd_status gltf_mats_read(struct gltf_doc *d, int max, long texels,
                                const struct mesh_limits *lim, struct rayd_asset_cache *assets,
                                struct gltf_mats *out, struct rayd_error *err);

/* The mapping of one PBR material, without its texture: exposed for tests. */
struct gltf_pbr {
    double base[4]; /* baseColorFactor */
    double metallic, roughness;
    double emissive[3]; /* emissiveFactor times KHR_materials_emissive_strength */
    int alpha_mode;     /* 0 OPAQUE, 1 MASK, 2 BLEND */
    double cutoff, ior;
    bool double_sided; /* doubleSided: else emission from the front only */
};
struct material gltf_pbr_material(const struct gltf_pbr *p);

/* Frees the arrays and the textures' texels (those not handed on), and
 * gives back what is still charged (0 it once the caller owns it). */
void gltf_mats_free(struct gltf_mats *g);

#endif
