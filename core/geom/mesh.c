/* mesh.c -- triangle meshes: build, and the ray queries.
 *
 * A mesh is geometry only: material and placement belong to the objects
 * that refer to it, so one mesh can be drawn many times (instances) for
 * the memory of one.  Vertices are float, like every fast ray tracer's,
 * and triangles are stored as vertex indices in BVH leaf order: 12 bytes a
 * triangle plus ~6 for vertices plus the BVH, no per-triangle copies.
 *
 * The ray/triangle test is the watertight one of Woop, Benthin and Wald
 * (JCGT 2013): the ray is sheared so it points along +z, and the three edge
 * functions are evaluated in that 2-D frame, falling back to double when
 * one is exactly zero.  A ray through a shared edge or vertex hits at least
 * one of the triangles meeting there: no cracks.
 *
 * The build asks for as little fresh memory as it can (see bvh.c on why
 * that counts): the triangles' boxes go straight into the builder, the
 * blocks are read through the BVH's order from the index as loaded, and
 * only a mesh that keeps its index (smooth normals, uvs) gets it sorted
 * into leaf order, after the builder has given its memory back.
 */
#include "base/hugemem.h"
#include "geom/mesh.h"

#include <stdlib.h>
#include <string.h>

#include "base/cpu.h"
#include "base/error.h"
#include "geom/mesh_ray.h"
#include "geom/mesh_walk.h"
#include "base/parallel.h"
#include "base/share.h"

#define MESH_CHUNK 16384 /* triangles a thread at least: fewer stay on one thread */
/* A mesh larger than this is walked with prefetches (mesh_walk.h): about
 * a core's L2 cache and its share of L3. */
#define MESH_CACHE_BYTES (4u << 20)

/* The one-ray walk from the root.  Always inlined into three pairs of
 * copies (below: nearest hit and any hit for each target): the
 * build's target (SSE2 on plain x86-64); where the CPU has it (cpu_avx2),
 * one for AVX2, whose 8-wide fused node test makes it 1.05-1.16x as fast
 * as SSE2's two halves (bench/README.md, "The kernels on an AVX2 host"); and
 * (cpu_avx512) one for AVX-512, whose 32 vector registers keep a ray's
 * constants in registers.  test_mesh checks that they agree. */
__attribute__((always_inline)) static inline bool mesh_walk_body(const struct mesh *m, const ray *r,
                                                                 double tmax, struct mesh_hit *h,
                                                                 bool any, bvh8_test_fn test) {
    if (m->bvh.nnodes == 0) return false;
    struct bvh_ray br;
    struct tri_ray tr;
    bvh_ray_init_with(&br, &r->o, &r->d, test != bvh8_test); /* fused: the wide tests' */
    float tm = any ? tri_tmax_any(tmax) : tri_tmax_nearest(tmax);
    bool found = false;
    struct bvh_entry root = {0, 0, 0};
    bool met = mesh_walk_from(m, &br, &tr, r, root, &tm, h, &found, any, test);
    return any ? met : found && (double)h->t < tmax;
}

/* Each target's walk compiled twice, nearest hit and any hit: with any a
 * constant, the any-hit copy drops the hit bookkeeping and the nearest
 * child's choice, and neither asks which it is at every node (shadow rays
 * 3-5% faster on the 5k mesh, bench/README.md). */
static bool mesh_nearest_base(const struct mesh *m, const ray *r, double tmax, struct mesh_hit *h) {
    return mesh_walk_body(m, r, tmax, h, false, bvh8_test);
}

static bool mesh_any_base(const struct mesh *m, const ray *r, double tmax) {
    struct mesh_hit h;
    return mesh_walk_body(m, r, tmax, &h, true, bvh8_test);
}

#ifdef CPU_AVX512
CPU_AVX512_EXTERN static bool mesh_nearest_avx512(const struct mesh *m, const ray *r, double tmax,
                                                  struct mesh_hit *h) {
    return mesh_walk_body(m, r, tmax, h, false, bvh8_test_fused);
}

CPU_AVX512_EXTERN static bool mesh_any_avx512(const struct mesh *m, const ray *r, double tmax) {
    struct mesh_hit h;
    return mesh_walk_body(m, r, tmax, &h, true, bvh8_test_fused);
}

CPU_AVX2_EXTERN static bool mesh_nearest_avx2(const struct mesh *m, const ray *r, double tmax,
                                              struct mesh_hit *h) {
    return mesh_walk_body(m, r, tmax, h, false, bvh8_test_fused);
}

CPU_AVX2_EXTERN static bool mesh_any_avx2(const struct mesh *m, const ray *r, double tmax) {
    struct mesh_hit h;
    return mesh_walk_body(m, r, tmax, &h, true, bvh8_test_fused);
}
#endif

bool mesh_intersect(const struct mesh *m, const ray *r, double tmax, struct mesh_hit *h) {
#ifdef CPU_AVX512
    if (cpu_avx512()) return mesh_nearest_avx512(m, r, tmax, h);
    if (cpu_avx2()) return mesh_nearest_avx2(m, r, tmax, h);
#endif
    return mesh_nearest_base(m, r, tmax, h);
}

bool mesh_occluded(const struct mesh *m, const ray *r, double tmax) {
#ifdef CPU_AVX512
    if (cpu_avx512()) return mesh_any_avx512(m, r, tmax);
    if (cpu_avx2()) return mesh_any_avx2(m, r, tmax);
#endif
    return mesh_any_base(m, r, tmax);
}

bool mesh_intersect_brute(const struct mesh *m, const ray *r, double tmax, struct mesh_hit *h) {
    struct tri_ray tr;
    tri_ray_init(&tr, r);
    float tm = tri_tmax_nearest(tmax);
    bool found = false;
    for (uint32_t i = 0; i < m->nblocks; i++) {
        float t[4], u[4], v[4];
        const struct tri4 *b = &m->blocks[i];
        int n = 0;
        while (n < 4 && b->id[n] != UINT32_MAX) n++;
        int mask = tri4_test(b, n, &tr, tm, t, u, v);
        if (mask) tri4_take(m, b, mask, t, u, v, &tm, h, &found);
    }
    return found && (double)h->t < tmax;
}

/* Vertex k of the hit triangle, from its block. */
static vec3 corner(const struct mesh *m, const struct mesh_hit *h, int k) {
    const struct tri4 *b = &m->blocks[h->blk];
    return v3(b->v[k][0][h->lane], b->v[k][1][h->lane], b->v[k][2][h->lane]);
}

vec3 mesh_point(const struct mesh *m, const struct mesh_hit *h) {
    double u = h->u, v = h->v;
    vec3 p = v3_scale(corner(m, h, 0), 1.0 - u - v);
    p = v3_madd(p, corner(m, h, 1), u);
    return v3_madd(p, corner(m, h, 2), v);
}

vec3 mesh_geometric_normal(const struct mesh *m, const struct mesh_hit *h) {
    vec3 a = corner(m, h, 0);
    vec3 n = v3_cross(v3_sub(corner(m, h, 1), a), v3_sub(corner(m, h, 2), a));
    double len = v3_len(n);
    return len > 0 ? v3_scale(n, 1.0 / len) : v3(0, 1, 0);
}

vec3 mesh_shading_normal(const struct mesh *m, const struct mesh_hit *h) {
    if (!m->normal) return mesh_geometric_normal(m, h);
    const uint32_t *ix = m->index + 3 * (size_t)h->tri;
    double u = h->u, v = h->v;
    vec3 n = v3(0, 0, 0);
    const double wgt[3] = {1.0 - u - v, u, v};
    for (int k = 0; k < 3; k++) {
        const float *nn = m->normal + 3 * (size_t)ix[k];
        n = v3_madd(n, v3(nn[0], nn[1], nn[2]), wgt[k]);
    }
    double len = v3_len(n);
    return len > 0 ? v3_scale(n, 1.0 / len) : mesh_geometric_normal(m, h);
}

void mesh_uv(const struct mesh *m, const struct mesh_hit *h, double *u, double *v) {
    *u = *v = 0;
    if (!m->uv) return;
    const uint32_t *ix = m->index + 3 * (size_t)h->tri;
    const double w[3] = {1.0 - h->u - h->v, h->u, h->v};
    for (int k = 0; k < 3; k++) {
        *u += w[k] * m->uv[2 * (size_t)ix[k]];
        *v += w[k] * m->uv[2 * (size_t)ix[k] + 1];
    }
}

/* Area-weighted vertex normals (the cross product's length is twice the
 * area, so summing unnormalised face normals weights by area). */
static float *smooth_normals(const float *pos, uint32_t nverts, const uint32_t *index,
                             uint32_t ntris) {
    float *n = huge_calloc((size_t)nverts * 3, sizeof *n);
    if (!n) return NULL;
    for (uint32_t t = 0; t < ntris; t++) {
        const uint32_t *ix = index + 3 * (size_t)t;
        const float *a = pos + 3 * (size_t)ix[0], *b = pos + 3 * (size_t)ix[1],
                    *c = pos + 3 * (size_t)ix[2];
        vec3 fn = v3_cross(v3(b[0] - a[0], b[1] - a[1], b[2] - a[2]),
                           v3(c[0] - a[0], c[1] - a[1], c[2] - a[2]));
        for (int k = 0; k < 3; k++) {
            float *d = n + 3 * (size_t)ix[k];
            d[0] += (float)fn.x;
            d[1] += (float)fn.y;
            d[2] += (float)fn.z;
        }
    }
    for (uint32_t i = 0; i < nverts; i++) {
        float *d = n + 3 * (size_t)i;
        double len = sqrt((double)d[0] * d[0] + (double)d[1] * d[1] + (double)d[2] * d[2]);
        if (len > 0)
            for (int k = 0; k < 3; k++) d[k] = (float)(d[k] / len);
    }
    return n;
}

/* The triangle's box.  Comparisons, not fminf/fmaxf: those must honour
 * NaN, so the compiler calls libm for them (4% of the 1.3M mesh's load),
 * and every position was checked finite when it was read. */
static struct bbox tri_box(const float *pos, const uint32_t *ix) {
    struct bbox b;
    for (int k = 0; k < 3; k++) {
        float a = pos[3 * (size_t)ix[0] + k], c = pos[3 * (size_t)ix[1] + k],
              d = pos[3 * (size_t)ix[2] + k];
        float lo = a < c ? a : c, hi = a < c ? c : a;
        b.lo[k] = d < lo ? d : lo;
        b.hi[k] = d > hi ? d : hi;
    }
    return b;
}

/* The steps of mesh_build that touch every triangle run as parallel_for
 * bodies over triangles or nodes; each writes only its own indices, so the
 * mesh is the same for any thread count. */
struct mesh_job {
    struct mesh *m;
    const float *pos;
    const uint32_t *index, *order;
    uint32_t *sorted, *first_block; /* a node's first block number */
};

/* The triangles' boxes as the BVH builder asks for them (bvh_boxes_fn). */
static void tri_boxes(const void *ctx, uint32_t first, uint32_t n, struct bbox *out) {
    const struct mesh_job *j = ctx;
    for (uint32_t i = 0; i < n; i++) out[i] = tri_box(j->pos, j->index + 3 * (size_t)(first + i));
}

static void sort_body(void *ctx, size_t lo, size_t hi) {
    struct mesh_job *j = ctx;
    for (size_t t = lo; t < hi; t++)
        memcpy(j->sorted + 3 * t, j->index + 3 * (size_t)j->order[t], sizeof *j->sorted * 3);
}

/* Lane of block b: triangle id (leaf order), its corners read through
 * order from the index as loaded; an unused lane is id UINT32_MAX and
 * zeros (the blocks are not cleared beforehand). */
static void block_lane(const struct mesh_job *j, struct tri4 *b, int lane, uint32_t id) {
    b->id[lane] = id;
    const uint32_t *ix = id == UINT32_MAX ? NULL : j->index + 3 * (size_t)j->order[id];
    for (int k = 0; k < 3; k++)
        for (int jj = 0; jj < 3; jj++) b->v[k][jj][lane] = ix ? j->pos[3 * (size_t)ix[k] + jj] : 0;
}

/* Packs every leaf's triangles into its tri4 blocks, consecutive (one, or
 * two for a leaf of five to eight), and points the leaf at the first;
 * unused lanes are masked off by the count. */
static void blocks_body(void *ctx, size_t lo, size_t hi) {
    struct mesh_job *j = ctx;
    struct mesh *m = j->m;
    for (size_t n = lo; n < hi; n++) {
        struct bvh8_node *nd = &m->bvh.nodes[n];
        uint32_t next = j->first_block[n];
        for (int i = 0; i < 8; i++) {
            int count = nd->count[i];
            for (int at = 0; at < count; at += 4) {
                struct tri4 *b = &m->blocks[next + (uint32_t)at / 4];
                for (int lane = 0; lane < 4; lane++)
                    block_lane(j, b, lane,
                               at + lane < count ? nd->child[i] + (uint32_t)(at + lane)
                                                 : UINT32_MAX);
            }
            if (!count) continue;
            nd->child[i] = next;
            next += (uint32_t)mesh_leaf_blocks(count);
        }
    }
}

/* Numbers the leaves' blocks in node order (a prefix sum over the
 * nodes), then fills the blocks on every thread. */
static enum rayd_status make_blocks(struct mesh *m, const uint32_t *index, const uint32_t *order,
                                    int threads, struct rayd_error *err) {
    uint32_t leaves = 0, nn = m->bvh.nnodes;
    uint32_t *first = huge_alloc(sizeof *first * ((size_t)nn + 1));
    if (!first) return err_set(err, RAYD_E_NOMEM, NULL, "out of memory for mesh leaves");
    for (uint32_t n = 0; n < nn; n++) {
        first[n] = leaves;
        for (int i = 0; i < 8; i++) leaves += (uint32_t)mesh_leaf_blocks(m->bvh.nodes[n].count[i]);
    }
    m->blocks = huge_alloc(sizeof *m->blocks * (leaves ? leaves : 1));
    if (!m->blocks) {
        free(first);
        return err_set(err, RAYD_E_NOMEM, NULL, "out of memory for mesh leaves");
    }
    struct mesh_job j = {
        .m = m, .pos = m->pos, .index = index, .order = order, .first_block = first};
    parallel_for(nn, threads, MESH_CHUNK / 4, blocks_body, &j);
    m->nblocks = leaves;
    free(first);
    return RAYD_OK;
}

/* The index in leaf order, for the meshes that keep it (smooth normals,
 * texture coordinates): made after the build, so its pages are ones the
 * build's records gave back. */
static enum rayd_status sort_index(struct mesh *m, const uint32_t *order, int threads,
                                   struct rayd_error *err) {
    uint32_t *sorted = huge_alloc(sizeof *sorted * 3 * ((size_t)m->ntris + 1));
    if (!sorted)
        return err_set(err, RAYD_E_NOMEM, NULL, "out of memory building a mesh of %u triangles",
                       m->ntris);
    struct mesh_job j = {.index = m->index, .order = order, .sorted = sorted};
    parallel_for(m->ntris, threads, MESH_CHUNK, sort_body, &j);
    free(m->index);
    m->index = sorted;
    return RAYD_OK;
}

/* The BVH over the triangles, then their blocks in leaf order; a flat mesh
 * without uvs then drops its vertices and index (the blocks hold all it
 * needs), the others get their index in leaf order. */
static enum rayd_status mesh_accel(struct mesh *m, int threads, struct rayd_error *err) {
    uint32_t *order = huge_alloc(sizeof *order * ((size_t)m->ntris + 1));
    if (!order)
        return err_set(err, RAYD_E_NOMEM, NULL, "out of memory building a mesh of %u triangles",
                       m->ntris);
    struct mesh_job j = {.pos = m->pos, .index = m->index};
    enum rayd_status st =
        bvh8_build_from(&m->bvh, tri_boxes, &j, m->ntris, BVH_MAX_LEAF, order, threads, err);
    if (st == RAYD_OK) {
        const struct bbox *b = &m->bvh.bounds;
        m->lo = v3(b->lo[0], b->lo[1], b->lo[2]);
        m->hi = v3(b->hi[0], b->hi[1], b->hi[2]);
        st = make_blocks(m, m->index, order, threads, err);
    }
    if (st == RAYD_OK && !m->normal && !m->uv) {
        free(m->pos);
        free(m->index);
        m->pos = NULL;
        m->index = NULL;
    } else if (st == RAYD_OK) {
        st = sort_index(m, order, threads, err);
    }
    free(order);
    m->prefetch = mesh_bytes(m) > MESH_CACHE_BYTES;
    return st;
}

enum rayd_status mesh_build(struct mesh *m, float *pos, uint32_t nverts, uint32_t *index,
                            uint32_t ntris, float *normal, float *uv, bool smooth, int threads,
                            struct rayd_error *err) {
    memset(m, 0, sizeof *m);
    m->pos = pos;
    m->nverts = nverts;
    m->index = index;
    m->ntris = ntris;
    m->normal = normal;
    m->uv = uv;
    if (smooth && !normal && !(m->normal = smooth_normals(pos, nverts, index, ntris)))
        return err_set(err, RAYD_E_NOMEM, NULL, "out of memory for mesh normals");
    if (!smooth && normal) {
        free(m->normal);
        m->normal = NULL;
    }
    return mesh_accel(m, threads, err);
}

void mesh_free(struct mesh *m) {
    if (!m) return;
    if (m->shared) { /* the arrays are the share's (mesh_share.c) */
        share_unref(m->shared);
        memset(m, 0, sizeof *m);
        return;
    }
    free(m->pos);
    free(m->normal);
    free(m->uv);
    free(m->index);
    free(m->blocks);
    bvh8_free(&m->bvh);
    memset(m, 0, sizeof *m);
}

size_t mesh_bytes(const struct mesh *m) {
    size_t b =
        (size_t)m->bvh.nnodes * sizeof(struct bvh8_node) + (size_t)m->nblocks * sizeof(struct tri4);
    if (m->pos) b += (size_t)m->nverts * 3 * sizeof(float);
    if (m->index) b += (size_t)m->ntris * 3 * sizeof(uint32_t);
    if (m->normal) b += (size_t)m->nverts * 3 * sizeof(float);
    if (m->uv) b += (size_t)m->nverts * 2 * sizeof(float);
    if (m->shared) b += m->shared->key_len; /* counted whole in each scene, as a shared image */
    return b;
}
