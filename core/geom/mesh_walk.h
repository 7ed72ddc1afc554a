/* mesh_walk.h -- the one-ray walk through a mesh's BVH.
 *
 * Shared by mesh.c, whose one-ray queries walk from the root, and
 * mesh_packet.c, whose packets hand the rays that few lanes still follow
 * to this walk from the node they reached.  Always inlined, so each
 * includer compiles it for its own target (the build's, or AVX-512); the
 * float operations are the same in the same order (no fused multiply-add:
 * -ffp-contract=off), so every copy gives the same bits.
 */
#ifndef MESH_WALK_H
#define MESH_WALK_H

#include <stdbool.h>
#include <stdint.h>

#include "accel/bvh.h"
#include "geom/mesh.h"
#include "geom/mesh_ray.h"

/* Tests the first n lanes of block b.  A lane hits when 0 < t <= tmax;
 * returns the mask of hits with t, u, v in out.  The SIMD and the scalar
 * code do the same float operations in the same order, so both give the
 * same bits. */
static inline int tri4_test(const struct tri4 *b, int n, const struct tri_ray *tr, float tmax,
                            float t_out[4], float u_out[4], float v_out[4]) {
    int kx = tr->kx, ky = tr->ky, kz = tr->kz;
    float U[4], V[4], W[4], AZ[4], BZ[4], CZ[4], AX[4], AY[4], BX[4], BY[4], CX[4], CY[4];
#ifdef BVH_SSE
    __m128 ox = _mm_set1_ps(tr->org[kx]), oy = _mm_set1_ps(tr->org[ky]),
           oz = _mm_set1_ps(tr->org[kz]), sx = _mm_set1_ps(tr->sx), sy = _mm_set1_ps(tr->sy);
    __m128 az = _mm_sub_ps(_mm_loadu_ps(b->v[0][kz]), oz);
    __m128 bz = _mm_sub_ps(_mm_loadu_ps(b->v[1][kz]), oz);
    __m128 cz = _mm_sub_ps(_mm_loadu_ps(b->v[2][kz]), oz);
    __m128 ax = _mm_sub_ps(_mm_sub_ps(_mm_loadu_ps(b->v[0][kx]), ox), _mm_mul_ps(sx, az));
    __m128 ay = _mm_sub_ps(_mm_sub_ps(_mm_loadu_ps(b->v[0][ky]), oy), _mm_mul_ps(sy, az));
    __m128 bx = _mm_sub_ps(_mm_sub_ps(_mm_loadu_ps(b->v[1][kx]), ox), _mm_mul_ps(sx, bz));
    __m128 by = _mm_sub_ps(_mm_sub_ps(_mm_loadu_ps(b->v[1][ky]), oy), _mm_mul_ps(sy, bz));
    __m128 cx = _mm_sub_ps(_mm_sub_ps(_mm_loadu_ps(b->v[2][kx]), ox), _mm_mul_ps(sx, cz));
    __m128 cy = _mm_sub_ps(_mm_sub_ps(_mm_loadu_ps(b->v[2][ky]), oy), _mm_mul_ps(sy, cz));
    __m128 u = _mm_sub_ps(_mm_mul_ps(cx, by), _mm_mul_ps(cy, bx));
    __m128 v = _mm_sub_ps(_mm_mul_ps(ax, cy), _mm_mul_ps(ay, cx));
    __m128 w = _mm_sub_ps(_mm_mul_ps(bx, ay), _mm_mul_ps(by, ax));
    __m128 zero = _mm_setzero_ps();
    int lanes = (1 << n) - 1;
    int on_edge = _mm_movemask_ps(_mm_or_ps(_mm_or_ps(_mm_cmpeq_ps(u, zero), _mm_cmpeq_ps(v, zero)),
                                            _mm_cmpeq_ps(w, zero))) &
                  lanes;
    if (on_edge) {
        _mm_storeu_ps(U, u), _mm_storeu_ps(V, v), _mm_storeu_ps(W, w);
        _mm_storeu_ps(AX, ax), _mm_storeu_ps(AY, ay), _mm_storeu_ps(BX, bx);
        _mm_storeu_ps(BY, by), _mm_storeu_ps(CX, cx), _mm_storeu_ps(CY, cy);
        for (int i = 0; i < 4; i++)
            if (on_edge & (1 << i))
                tri_edges_double(AX[i], AY[i], BX[i], BY[i], CX[i], CY[i], &U[i], &V[i], &W[i]);
        u = _mm_loadu_ps(U), v = _mm_loadu_ps(V), w = _mm_loadu_ps(W);
    }
    __m128 neg =
        _mm_or_ps(_mm_or_ps(_mm_cmplt_ps(u, zero), _mm_cmplt_ps(v, zero)), _mm_cmplt_ps(w, zero));
    __m128 pos =
        _mm_or_ps(_mm_or_ps(_mm_cmpgt_ps(u, zero), _mm_cmpgt_ps(v, zero)), _mm_cmpgt_ps(w, zero));
    __m128 det = _mm_add_ps(_mm_add_ps(u, v), w);
    __m128 sz = _mm_set1_ps(tr->sz);
    __m128 t =
        _mm_add_ps(_mm_add_ps(_mm_mul_ps(_mm_mul_ps(u, sz), az), _mm_mul_ps(_mm_mul_ps(v, sz), bz)),
                   _mm_mul_ps(_mm_mul_ps(w, sz), cz));
    /* t / det in (0, tmax]: compare with the signs folded into det's */
    __m128 sign = _mm_and_ps(det, _mm_set1_ps(-0.0f));
    __m128 ts = _mm_xor_ps(t, sign), ds = _mm_xor_ps(det, sign);
    __m128 ok = _mm_andnot_ps(_mm_and_ps(neg, pos), _mm_cmpneq_ps(det, zero));
    ok = _mm_and_ps(ok, _mm_cmpgt_ps(ts, zero));
    ok = _mm_and_ps(ok, _mm_cmple_ps(ts, _mm_mul_ps(_mm_set1_ps(tmax * TRI_SLACK), ds)));
    int mask = _mm_movemask_ps(ok) & lanes;
    if (!mask) return 0;
    __m128 rcp = _mm_div_ps(_mm_set1_ps(1.0f), det);
    _mm_storeu_ps(t_out, _mm_mul_ps(t, rcp));
    _mm_storeu_ps(u_out, _mm_mul_ps(v, rcp));
    _mm_storeu_ps(v_out, _mm_mul_ps(w, rcp));
    (void)AZ, (void)BZ, (void)CZ;
    return mask;
#else
    int mask = 0;
    for (int i = 0; i < n; i++) {
        AZ[i] = b->v[0][kz][i] - tr->org[kz];
        BZ[i] = b->v[1][kz][i] - tr->org[kz];
        CZ[i] = b->v[2][kz][i] - tr->org[kz];
        AX[i] = (b->v[0][kx][i] - tr->org[kx]) - tr->sx * AZ[i];
        AY[i] = (b->v[0][ky][i] - tr->org[ky]) - tr->sy * AZ[i];
        BX[i] = (b->v[1][kx][i] - tr->org[kx]) - tr->sx * BZ[i];
        BY[i] = (b->v[1][ky][i] - tr->org[ky]) - tr->sy * BZ[i];
        CX[i] = (b->v[2][kx][i] - tr->org[kx]) - tr->sx * CZ[i];
        CY[i] = (b->v[2][ky][i] - tr->org[ky]) - tr->sy * CZ[i];
        U[i] = CX[i] * BY[i] - CY[i] * BX[i];
        V[i] = AX[i] * CY[i] - AY[i] * CX[i];
        W[i] = BX[i] * AY[i] - BY[i] * AX[i];
        if (U[i] == 0 || V[i] == 0 || W[i] == 0)
            tri_edges_double(AX[i], AY[i], BX[i], BY[i], CX[i], CY[i], &U[i], &V[i], &W[i]);
        if ((U[i] < 0 || V[i] < 0 || W[i] < 0) && (U[i] > 0 || V[i] > 0 || W[i] > 0)) continue;
        float det = (U[i] + V[i]) + W[i];
        if (det == 0) continue;
        float t = ((U[i] * tr->sz) * AZ[i] + (V[i] * tr->sz) * BZ[i]) + (W[i] * tr->sz) * CZ[i];
        float ts = det < 0 ? -t : t, ds = det < 0 ? -det : det;
        if (!(ts > 0 && ts <= (tmax * TRI_SLACK) * ds)) continue;
        float rcp = 1.0f / det;
        t_out[i] = t * rcp;
        u_out[i] = V[i] * rcp;
        v_out[i] = W[i] * rcp;
        mask |= 1 << i;
    }
    return mask;
#endif
}

/* A leaf's count triangles (one block, or two for five to eight), lane i
 * of the mask and of t, u, v being block i / 4's lane i % 4.  Four lanes
 * at a time: one 8-lane test for a two-block leaf was no faster on
 * AVX-512 (bench/README.md). */
static inline int tri_leaf(const struct tri4 *b, int count, const struct tri_ray *tr, float tmax,
                           float t[BVH8_LEAF_MAX], float u[BVH8_LEAF_MAX], float v[BVH8_LEAF_MAX]) {
    int mask = tri4_test(b, count < 4 ? count : 4, tr, tmax, t, u, v);
    if (count > 4) mask |= tri4_test(b + 1, count - 4, tr, tmax, t + 4, u + 4, v + 4) << 4;
    return mask;
}

#ifdef CPU_AVX512
/* The bounding boxes of a leaf's count triangles (blocks b, numbered as
 * tri_leaf numbers them; a one-block leaf's box repeated) as the packets'
 * interval cull takes them (bvh_cull_boxes): each axis's near and far
 * planes, the upper ones near on an axis whose bit is set in down (the
 * rays go down it). */
CPU_AVX2_INLINE void tri_leaf_boxes(const struct tri4 *b, uint32_t count, unsigned down,
                                    __m256 near[3], __m256 far[3]) {
    for (int k = 0; k < 3; k++) {
        __m128 lo[2], hi[2];
        for (int h = 0; h < 2; h++) {
            const struct tri4 *bh = &b[count > 4 ? h : 0];
            __m128 v0 = _mm_loadu_ps(bh->v[0][k]), v1 = _mm_loadu_ps(bh->v[1][k]);
            __m128 v2 = _mm_loadu_ps(bh->v[2][k]);
            lo[h] = _mm_min_ps(_mm_min_ps(v0, v1), v2);
            hi[h] = _mm_max_ps(_mm_max_ps(v0, v1), v2);
        }
        __m256 l = _mm256_set_m128(lo[1], lo[0]), u = _mm256_set_m128(hi[1], hi[0]);
        near[k] = down >> k & 1 ? u : l, far[k] = down >> k & 1 ? l : u;
    }
}
#endif

/* Keeps the nearest of the lanes in mask (of a block, or of a leaf's
 * blocks as tri_leaf numbers them); on equal t the lower triangle
 * id wins, so the result does not depend on the order blocks are visited
 * (BVH or brute force, any tiling). */
static inline bool tri4_take(const struct mesh *m, const struct tri4 *b, int mask, const float t[],
                             const float u[], const float v[], float *tmax, struct mesh_hit *h,
                             bool *found) {
    bool took = false;
    while (mask) { /* lane i: block i / 4's lane i % 4 (tri_leaf) */
        int i = __builtin_ctz((unsigned)mask);
        mask &= mask - 1;
        uint32_t id = b[i / 4].id[i % 4];
        if (t[i] > *tmax || (*found && t[i] == *tmax && id > h->tri)) continue;
        if (*found && t[i] == *tmax && id == h->tri) continue;
        *tmax = t[i];
        h->t = t[i];
        h->u = u[i];
        h->v = v[i];
        h->tri = id;
        h->blk = (uint32_t)(b + i / 4 - m->blocks);
        h->lane = (uint32_t)(i % 4);
        *found = true;
        took = true;
    }
    return took;
}

/* Starts loading the children in mask of node nd (inner nodes' boxes and
 * child rows, leaves' blocks), when the ray enters more than one: the
 * walk goes into the nearest and comes back to the others, whose loads
 * then overlap its.  Only where the mesh outgrows a core's cache, whose
 * walks wait on memory (6-13% faster bounce rays on the 1.3M mesh); a
 * mesh in cache would pay the instructions for nothing. */
static inline void mesh_prefetch(const struct mesh *m, const struct bvh8_node *nd, int mask) {
    if (!m->prefetch || !(mask & (mask - 1))) return;
    for (; mask; mask &= mask - 1) {
        int i = __builtin_ctz((unsigned)mask);
        const char *p = nd->count[i] ? (const char *)&m->blocks[nd->child[i]]
                                     : (const char *)&m->bvh.nodes[nd->child[i]];
        size_t size = nd->count[i] ? sizeof(struct tri4) * (size_t)mesh_leaf_blocks(nd->count[i])
                                   : sizeof(struct bvh8_node);
        for (size_t at = 0; at < size; at += 64) __builtin_prefetch(p + at);
    }
}

/* Walks the subtree at e for the ray (br, tr) within the bound *tm
 * (tr made from lazy at the first leaf when lazy is not NULL),
 * lowered to each hit taken.  A nearest-hit walk (any false) keeps the
 * nearest in *h and *found, which may already hold a hit (a packet's lane
 * goes on from where it was), and returns whether it took one; an any-hit
 * walk returns whether it met a triangle.  test is the node test, a
 * constant each caller passes (bvh.h: the AVX-512 one where compiled for
 * it), so each copy of the walk has its own inlined. */
__attribute__((always_inline)) static inline bool
mesh_walk_from(const struct mesh *m, const struct bvh_ray *br, struct tri_ray *tr, const ray *lazy,
               struct bvh_entry e, float *tm, struct mesh_hit *h, bool *found, bool any,
               bvh8_test_fn test) {
    struct bvh_entry stack[BVH8_STACK];
    int sp = 0;
    float bound = *tm;
    bool took = false;
    for (;;) {
        if (e.count == 0) {
            const struct bvh8_node *nd = &m->bvh.nodes[e.node];
            float tn[8];
            int hit = test(nd, br, 0, bound * BVH_SLACK, tn);
            mesh_prefetch(m, nd, hit);
            if (bvh_descend_mask(nd->child, nd->count, hit, tn, &e, stack, &sp,
                                 any ? BVH_AS_COME : BVH_NEAREST))
                continue;
        } else {
            float t[BVH8_LEAF_MAX], u[BVH8_LEAF_MAX], v[BVH8_LEAF_MAX];
            const struct tri4 *b = &m->blocks[e.node];
            if (lazy) { /* at the first leaf: many rays reach none */
                tri_ray_init(tr, lazy);
                lazy = NULL;
            }
            int mask = tri_leaf(b, e.count, tr, bound, t, u, v);
            if (mask) {
                if (any) return true;
                took |= tri4_take(m, b, mask, t, u, v, &bound, h, found);
            }
        }
        do { /* pop the next entry still in reach */
            if (sp == 0) {
                *tm = bound;
                return took;
            }
            e = stack[--sp];
        } while (e.tnear > bound * BVH_SLACK);
    }
}

#endif
