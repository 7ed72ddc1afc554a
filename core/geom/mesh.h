/* mesh.h -- triangle meshes: shared geometry with its own BVH. */
#ifndef MESH_H
#define MESH_H

#include <stdbool.h>
#include <stdint.h>

#include "accel/bvh.h"
#include "math/vec.h"

/* Four triangles side by side for the SIMD test: vertex k's axis j of
 * lane i is v[k][j][i]; id[i] is the triangle's index in mesh.index. */
struct tri4 {
    float v[3][3][4];
    uint32_t id[4];
};

/* The blocks of a leaf of count triangles (0 for an inner node's count):
 * one for up to four, two for up to BVH8_LEAF_MAX, consecutive. */
static inline int mesh_leaf_blocks(int count) { return (count + 3) / 4; }

struct mesh {
    struct tri4 *blocks; /* the BVH's leaves point here, one or two blocks a leaf */
    uint32_t nblocks;
    /* Vertex data, kept only for smooth normals and texture coordinates:
     * a flat mesh without uvs needs nothing but its blocks (pos and index
     * are then freed after the build and NULL). */
    float *pos;      /* 3 per vertex, object space */
    float *normal;   /* 3 per vertex (unit), or NULL: flat shading */
    float *uv;       /* 2 per vertex, or NULL */
    uint32_t *index; /* 3 per triangle, in BVH leaf order */
    uint32_t nverts, ntris;
    struct bvh8 bvh;
    vec3 lo, hi;   /* bounds */
    bool prefetch; /* the tree and blocks outgrow a core's cache (mesh_walk.h) */
    /* The arrays' owner when scenes share them (mesh_share.c), else NULL:
     * then the arrays are this mesh's own. */
    struct share *shared;
};

struct mesh_hit {
    float t;
    float u, v;   /* barycentric weights of the 2nd and 3rd vertex */
    uint32_t tri; /* triangle, in leaf order */
    uint32_t blk; /* its block and lane: where its vertices are */
    uint32_t lane;
};

/* Takes over pos, normal, uv and index (malloc'd; freed by mesh_free even
 * on failure), validates nothing (the loader did), builds the BVH.  With
 * smooth and no normals given, computes area-weighted vertex normals. */
enum rayd_status mesh_build(struct mesh *m, float *pos, uint32_t nverts, uint32_t *index,
                            uint32_t ntris, float *normal, float *uv, bool smooth, int threads,
                            struct rayd_error *err);
/* Frees m's arrays, or lets go of its reference to shared ones. */
void mesh_free(struct mesh *m);

/* Nearest hit along r (object space, unit direction) with t in (0, tmax). */
bool mesh_intersect(const struct mesh *m, const ray *r, double tmax, struct mesh_hit *h);
/* Any hit with t in (0, tmax). */
bool mesh_occluded(const struct mesh *m, const ray *r, double tmax);
/* The same for the rays of r whose bit is set in active (at most 16), at
 * once: bit i of the result says ray i hit (is blocked), exactly as the
 * one-ray query would say.  In mesh_packet.c. */
uint32_t mesh_intersect16(const struct mesh *m, const ray r[16], const double tmax[16],
                          uint32_t active, struct mesh_hit h[16]);
uint32_t mesh_occluded16(const struct mesh *m, const ray r[16], const double tmax[16],
                         uint32_t active);
/* The same for rays already loaded as structure of arrays, with AVX-512:
 * the caller checked cpu_avx512 (bvh16.h; mesh_packet.c). */
uint32_t mesh16_intersect(const struct mesh *m, const struct ray16 *rd, const double tmax[16],
                          uint32_t active, struct mesh_hit h[16]);
uint32_t mesh16_occluded(const struct mesh *m, const struct ray16 *rd, const double tmax[16],
                         uint32_t active);
/* The same with AVX2 for rays 8h..8h+7 of rd (h 0 or 1), the masks and
 * arrays still those of the 16: the caller checked cpu_avx2 (bvh_rays8.h;
 * mesh_packet8.c). */
uint32_t mesh8_intersect(const struct mesh *m, const struct ray16 *rd, int h, const double tmax[16],
                         uint32_t active, struct mesh_hit hit[16]);
uint32_t mesh8_occluded(const struct mesh *m, const struct ray16 *rd, int h, const double tmax[16],
                        uint32_t active);
/* The same queries testing every triangle: the reference for tests. */
bool mesh_intersect_brute(const struct mesh *m, const ray *r, double tmax, struct mesh_hit *h);

/* The hit point from barycentrics, in double: it lies on the triangle's
 * plane to double precision, whatever the float error of t. */
vec3 mesh_point(const struct mesh *m, const struct mesh_hit *h);
vec3 mesh_geometric_normal(const struct mesh *m, const struct mesh_hit *h); /* unit, by winding */
vec3 mesh_shading_normal(const struct mesh *m, const struct mesh_hit *h);

/* Interpolated texture coordinates (0, 0 without uvs). */
void mesh_uv(const struct mesh *m, const struct mesh_hit *h, double *u, double *v);

/* Memory held by the mesh, for the scene's size and bytes per triangle. */
size_t mesh_bytes(const struct mesh *m);

#endif
