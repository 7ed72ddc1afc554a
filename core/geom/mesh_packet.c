/* mesh_packet.c -- a mesh's nearest-hit and any-hit queries for 16 rays.
 *
 * The packet walk of bvh16.h with the triangle test of mesh.c done for 16
 * rays at once: each of a leaf's (up to eight) triangles is broadcast and
 * tested against the packet, but for those whose bounding box no ray of a
 * coherent packet enters (tri_cull, the nodes' culling test).  Every float
 * operation is the one the one-ray test does, in the same order, and the
 * nearest hit is chosen by the same order-free rule (nearest t, then lower
 * triangle id), so each ray gets bit for bit what mesh_intersect or
 * mesh_occluded gives it alone.
 * The rays of a packet need not share their dominant axis: the sheared
 * frame is picked per lane with mask blends.  Where at most BVH16_LONE_MAX
 * of its rays still need a node, they go on alone through the one-ray walk
 * (mesh_walk.h), each from its best hit so far: the same answer, and the
 * rays of an incoherent packet (bounce rays) stop paying 16 lanes a node.
 * Such a packet takes the walk too through a mesh that outgrows the
 * cache, where its rays part ways near the root: 1.14x as fast as the
 * same rays one by one on an AMD EPYC with AVX-512, 0.95x on the Intel
 * Xeon measured before (bench/README.md, "The kernels on an AMD EPYC
 * with AVX-512").
 *
 * Where the CPU stops at AVX2 (valgrind's does too) the entry points take
 * mesh_packet8.c's packets of 8 instead.  Without either (another CPU, a
 * build without SIMD, or RAYD_NO_AVX2 in the environment) they loop over
 * the rays one at a time.
 */
#include <stdlib.h>

#include "accel/bvh16.h"
#include "geom/mesh.h"
#include "geom/mesh_ray.h"
#include "geom/mesh_walk.h"

#ifdef CPU_AVX512

/* One lives on the stack per packet traversal, its fields in the order the
 * code reads them: the padding that the 64-byte __m512 alignment leaves
 * (128 bytes over the best order) costs no memory that matters. */
/* NOLINTNEXTLINE(clang-analyzer-optin.performance.Padding) */
struct mesh16 {
    const struct mesh *m;
    struct bvh16_ray br;
    __m512 org[3], sx, sy, sz;
    __mmask16 kx0, kx1, ky0, ky1, kz0, kz1; /* k == 0, k == 1, per lane */
    int kx, ky, kz;                         /* >= 0: the same axes in every lane */
    __m512 t, u, v;                         /* the nearest hit so far */
    __m512i id, blk, lane;
    __mmask16 found;
};

/* m0 ? x : m1 ? y : z, lane by lane: axis k of a vector per lane's k. */
CPU_AVX512_FN __m512 pick(__mmask16 m0, __mmask16 m1, const __m512 d[3]) {
    return _mm512_mask_blend_ps(m0, _mm512_mask_blend_ps(m1, d[2], d[1]), d[0]);
}

/* Lane j of block b against the rays in lanes with bounds tm: tri4_test's
 * operations, 16 rays wide.  Returns the rays that hit, with t, u, v. */
CPU_AVX512_FN __mmask16 tri16(const struct mesh16 *q, const struct tri4 *b, int j, __mmask16 lanes,
                              __m512 tm, __m512 *t_out, __m512 *u_out, __m512 *v_out) {
    __m512 d[3][3];
    for (int k = 0; k < 3; k++)
        for (int a = 0; a < 3; a++)
            d[k][a] = _mm512_sub_ps(_mm512_set1_ps(b->v[k][a][j]), q->org[a]);
    __m512 a[3][3]; /* vertex k's coordinates in each lane's frame: x, y, z */
    for (int k = 0; k < 3; k++) {
        if (q->kz >= 0) { /* the common case: one frame for the whole packet */
            a[k][0] = d[k][q->kx], a[k][1] = d[k][q->ky], a[k][2] = d[k][q->kz];
        } else {
            a[k][0] = pick(q->kx0, q->kx1, d[k]);
            a[k][1] = pick(q->ky0, q->ky1, d[k]);
            a[k][2] = pick(q->kz0, q->kz1, d[k]);
        }
    }
    __m512 az = a[0][2], bz = a[1][2], cz = a[2][2];
    __m512 ax = _mm512_sub_ps(a[0][0], _mm512_mul_ps(q->sx, az));
    __m512 ay = _mm512_sub_ps(a[0][1], _mm512_mul_ps(q->sy, az));
    __m512 bx = _mm512_sub_ps(a[1][0], _mm512_mul_ps(q->sx, bz));
    __m512 by = _mm512_sub_ps(a[1][1], _mm512_mul_ps(q->sy, bz));
    __m512 cx = _mm512_sub_ps(a[2][0], _mm512_mul_ps(q->sx, cz));
    __m512 cy = _mm512_sub_ps(a[2][1], _mm512_mul_ps(q->sy, cz));
    __m512 u = _mm512_sub_ps(_mm512_mul_ps(cx, by), _mm512_mul_ps(cy, bx));
    __m512 v = _mm512_sub_ps(_mm512_mul_ps(ax, cy), _mm512_mul_ps(ay, cx));
    __m512 w = _mm512_sub_ps(_mm512_mul_ps(bx, ay), _mm512_mul_ps(by, ax));
    __m512 zero = _mm512_setzero_ps();
    __mmask16 edge =
        (_mm512_cmp_ps_mask(u, zero, _CMP_EQ_OQ) | _mm512_cmp_ps_mask(v, zero, _CMP_EQ_OQ) |
         _mm512_cmp_ps_mask(w, zero, _CMP_EQ_OQ)) &
        lanes;
    if (edge) { /* through an edge or a vertex: those lanes in double */
        float U[16], V[16], W[16], AX[16], AY[16], BX[16], BY[16], CX[16], CY[16];
        _mm512_storeu_ps(U, u), _mm512_storeu_ps(V, v), _mm512_storeu_ps(W, w);
        _mm512_storeu_ps(AX, ax), _mm512_storeu_ps(AY, ay), _mm512_storeu_ps(BX, bx);
        _mm512_storeu_ps(BY, by), _mm512_storeu_ps(CX, cx), _mm512_storeu_ps(CY, cy);
        for (int i = 0; i < 16; i++)
            if (edge >> i & 1)
                tri_edges_double(AX[i], AY[i], BX[i], BY[i], CX[i], CY[i], &U[i], &V[i], &W[i]);
        u = _mm512_loadu_ps(U), v = _mm512_loadu_ps(V), w = _mm512_loadu_ps(W);
    }
    __mmask16 neg = _mm512_cmp_ps_mask(u, zero, _CMP_LT_OQ) |
                    _mm512_cmp_ps_mask(v, zero, _CMP_LT_OQ) |
                    _mm512_cmp_ps_mask(w, zero, _CMP_LT_OQ);
    __mmask16 pos = _mm512_cmp_ps_mask(u, zero, _CMP_GT_OQ) |
                    _mm512_cmp_ps_mask(v, zero, _CMP_GT_OQ) |
                    _mm512_cmp_ps_mask(w, zero, _CMP_GT_OQ);
    __m512 det = _mm512_add_ps(_mm512_add_ps(u, v), w);
    __m512 t = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(_mm512_mul_ps(u, q->sz), az),
                                           _mm512_mul_ps(_mm512_mul_ps(v, q->sz), bz)),
                             _mm512_mul_ps(_mm512_mul_ps(w, q->sz), cz));
    __m512i sign = _mm512_and_si512(_mm512_castps_si512(det), _mm512_set1_epi32(INT32_MIN));
    __m512 ts = _mm512_castsi512_ps(_mm512_xor_si512(_mm512_castps_si512(t), sign));
    __m512 ds = _mm512_castsi512_ps(_mm512_xor_si512(_mm512_castps_si512(det), sign));
    __mmask16 ok =
        lanes & (__mmask16) ~(neg & pos) & _mm512_cmp_ps_mask(det, zero, _CMP_NEQ_UQ) &
        _mm512_cmp_ps_mask(ts, zero, _CMP_GT_OQ) &
        _mm512_cmp_ps_mask(ts, _mm512_mul_ps(_mm512_mul_ps(tm, _mm512_set1_ps(TRI_SLACK)), ds),
                           _CMP_LE_OQ);
    if (!ok) return 0;
    __m512 rcp = _mm512_div_ps(_mm512_set1_ps(1.0f), det);
    *t_out = _mm512_mul_ps(t, rcp);
    *u_out = _mm512_mul_ps(v, rcp);
    *v_out = _mm512_mul_ps(w, rcp);
    return ok;
}

/* The triangles of the count in blocks b that some ray of the packet,
 * reaching at most far_most, may meet: those whose bounding box
 * bvh_cull_boxes keeps, when the packet has its intervals (else all).  A
 * box is a triangle's own (the tree's boxes are unions of them), so what
 * holds for a node holds for it; and a coherent packet, a few pixels
 * wide, meets few of a leaf's triangles. */
CPU_AVX512_FN unsigned tri_cull(const struct mesh16 *q, const struct tri4 *b, uint32_t count,
                                float far_most) {
    if (!q->br.ia) return 0xffu;
    __m256 near[3], far[3]; /* uniform signs: every lane's the same */
    unsigned down = (q->br.neg[0] != 0) | (q->br.neg[1] != 0) << 1 | (q->br.neg[2] != 0) << 2;
    tri_leaf_boxes(b, count, down, near, far);
    __m256 tn;
    return bvh_cull_boxes(&q->br.cull, near, far, far_most, &tn);
}

/* A leaf for the nearest-hit walk: its triangles that tri_cull keeps
 * tested with the bounds on entry, then taken in lane order, as tri4_take
 * does. */
CPU_AVX512_FN __mmask16 leaf_nearest(void *ctx, uint32_t first, uint32_t count, __mmask16 lanes,
                                     __m512 *tm, float far_most) {
    struct mesh16 *q = ctx;
    const struct tri4 *b = &q->m->blocks[first];
    __m512 T[BVH8_LEAF_MAX], U[BVH8_LEAF_MAX], V[BVH8_LEAF_MAX];
    __mmask16 ok[BVH8_LEAF_MAX];
    unsigned live = tri_cull(q, b, count, far_most);
    for (uint32_t j = 0; j < count; j++)
        ok[j] =
            live >> j & 1 ? tri16(q, &b[j / 4], (int)(j % 4), lanes, *tm, &T[j], &U[j], &V[j]) : 0;
    for (uint32_t j = 0; j < count; j++) {
        if (!ok[j]) continue;
        __m512i id = _mm512_set1_epi32((int)b[j / 4].id[j % 4]);
        __mmask16 tie = _mm512_mask_cmp_ps_mask(q->found, T[j], *tm, _CMP_EQ_OQ) &
                        _mm512_cmp_epu32_mask(id, q->id, _MM_CMPINT_NLT);
        __mmask16 take = ok[j] & (__mmask16) ~(_mm512_cmp_ps_mask(T[j], *tm, _CMP_GT_OQ) | tie);
        if (!take) continue;
        q->t = *tm = _mm512_mask_mov_ps(*tm, take, T[j]);
        q->u = _mm512_mask_mov_ps(q->u, take, U[j]);
        q->v = _mm512_mask_mov_ps(q->v, take, V[j]);
        q->id = _mm512_mask_mov_epi32(q->id, take, id);
        q->blk = _mm512_mask_mov_epi32(q->blk, take, _mm512_set1_epi32((int)(first + j / 4)));
        q->lane = _mm512_mask_mov_epi32(q->lane, take, _mm512_set1_epi32((int)(j % 4)));
        q->found |= take;
    }
    return 0;
}

/* A leaf for the any-hit walk: the rays that hit any of its triangles. */
CPU_AVX512_FN __mmask16 leaf_any(void *ctx, uint32_t first, uint32_t count, __mmask16 lanes,
                                 __m512 *tm, float far_most) {
    const struct mesh16 *q = ctx;
    const struct tri4 *b = &q->m->blocks[first];
    __mmask16 hit = 0;
    unsigned live = tri_cull(q, b, count, far_most);
    for (uint32_t j = 0; j < count && hit != lanes; j++) {
        if (!(live >> j & 1)) continue;
        __m512 t = _mm512_setzero_ps(), u = t, v = t; /* unused here */
        hit |= tri16(q, &b[j / 4], (int)(j % 4), lanes & (__mmask16)~hit, *tm, &t, &u, &v);
    }
    return hit;
}

/* Lane i of q as the one-ray walk's ray: the floats the packet holds for
 * it are those bvh_ray_init and tri_ray_init give the ray. */
struct lane_rays {
    float org[3][16], inv[3][16], sx[16], sy[16], sz[16];
};

CPU_AVX512_FN void lane_rays_load(struct lane_rays *l, const struct mesh16 *q) {
    for (int k = 0; k < 3; k++) {
        _mm512_storeu_ps(l->org[k], q->br.org[k]);
        _mm512_storeu_ps(l->inv[k], q->br.inv[k]);
    }
    _mm512_storeu_ps(l->sx, q->sx), _mm512_storeu_ps(l->sy, q->sy), _mm512_storeu_ps(l->sz, q->sz);
}

/* The axis of lane i in the masks m0 (axis 0) and m1 (axis 1), as pick. */
static inline int lane_axis(__mmask16 m0, __mmask16 m1, int i) {
    return m0 >> i & 1 ? 0 : m1 >> i & 1 ? 1 : 2;
}

CPU_AVX512_FN void lane_ray(const struct mesh16 *q, const struct lane_rays *l, int i,
                            struct bvh_ray *br, struct tri_ray *tr) {
    for (int k = 0; k < 3; k++) {
        br->org[k] = tr->org[k] = l->org[k][i];
        br->inv[k] = l->inv[k][i];
        br->neg[k] = q->br.neg[k] >> i & 1;
    }
    bvh_ray_fused(br);
    tr->kx = lane_axis(q->kx0, q->kx1, i);
    tr->ky = lane_axis(q->ky0, q->ky1, i);
    tr->kz = lane_axis(q->kz0, q->kz1, i);
    tr->sx = l->sx[i], tr->sy = l->sy[i], tr->sz = l->sz[i];
}

/* The lone walk of a nearest-hit packet: each ray in lanes goes on
 * through node (count: as in bvh8_node) alone, from its best hit so far,
 * and what it finds goes back into its lane. */
CPU_AVX512_FN __mmask16 lone_nearest(void *ctx, uint32_t node, uint32_t count, __mmask16 lanes,
                                     __m512 *tm, float far_most) {
    (void)far_most; /* each ray's own walk has its own bounds */
    struct mesh16 *q = ctx;
    struct lane_rays l;
    lane_rays_load(&l, q);
    float bound[16], t[16], u[16], v[16];
    uint32_t id[16], blk[16], lane[16];
    _mm512_storeu_ps(bound, *tm);
    _mm512_storeu_ps(t, q->t), _mm512_storeu_ps(u, q->u), _mm512_storeu_ps(v, q->v);
    _mm512_storeu_si512(id, q->id), _mm512_storeu_si512(blk, q->blk);
    _mm512_storeu_si512(lane, q->lane);
    struct bvh_entry e = {node, (uint8_t)count, 0};
    for (unsigned m = lanes; m; m &= m - 1) {
        int i = __builtin_ctz(m);
        struct bvh_ray br;
        struct tri_ray tr;
        lane_ray(q, &l, i, &br, &tr);
        struct mesh_hit h = {t[i], u[i], v[i], id[i], blk[i], lane[i]};
        bool found = q->found >> i & 1;
        if (!mesh_walk_from(q->m, &br, &tr, NULL, e, &bound[i], &h, &found, false, bvh8_test_fused))
            continue;
        __mmask16 bit = (__mmask16)(1u << i);
        *tm = _mm512_mask_mov_ps(*tm, bit, _mm512_set1_ps(bound[i]));
        q->t = _mm512_mask_mov_ps(q->t, bit, _mm512_set1_ps(h.t));
        q->u = _mm512_mask_mov_ps(q->u, bit, _mm512_set1_ps(h.u));
        q->v = _mm512_mask_mov_ps(q->v, bit, _mm512_set1_ps(h.v));
        q->id = _mm512_mask_mov_epi32(q->id, bit, _mm512_set1_epi32((int)h.tri));
        q->blk = _mm512_mask_mov_epi32(q->blk, bit, _mm512_set1_epi32((int)h.blk));
        q->lane = _mm512_mask_mov_epi32(q->lane, bit, _mm512_set1_epi32((int)h.lane));
        q->found |= bit;
    }
    return 0;
}

/* The lone walk of an any-hit packet: the rays in lanes that meet a
 * triangle under node. */
CPU_AVX512_FN __mmask16 lone_any(void *ctx, uint32_t node, uint32_t count, __mmask16 lanes,
                                 __m512 *tm, float far_most) {
    (void)far_most; /* each ray's own walk has its own bounds */
    const struct mesh16 *q = ctx;
    struct lane_rays l;
    lane_rays_load(&l, q);
    float bound[16];
    _mm512_storeu_ps(bound, *tm);
    struct bvh_entry e = {node, (uint8_t)count, 0};
    __mmask16 hit = 0;
    for (unsigned m = lanes; m; m &= m - 1) {
        int i = __builtin_ctz(m);
        struct bvh_ray br;
        struct tri_ray tr;
        lane_ray(q, &l, i, &br, &tr);
        struct mesh_hit h;
        bool found = false;
        if (mesh_walk_from(q->m, &br, &tr, NULL, e, &bound[i], &h, &found, true, bvh8_test_fused))
            hit |= (__mmask16)(1u << i);
    }
    return hit;
}

/* tri_ray_init for 8 lanes of q from lane 8h on, in double as it does:
 * the dominant axis kz, kx and ky after it (swapped when d[kz] < 0), and
 * the shear s (x, y, z).  m[a][v]: the lanes whose axis a (x, y, z) is v
 * (0, 1). */
CPU_AVX512_FN void shear8(const struct ray16 *q, int h, __m256 s[3], unsigned m[3][2]) {
    __m512d d[3], ad[3];
    for (int k = 0; k < 3; k++) {
        d[k] = _mm512_loadu_pd(q->d[k] + 8 * h);
        ad[k] = _mm512_abs_pd(d[k]);
    }
    __mmask8 xy = _mm512_cmp_pd_mask(ad[0], ad[1], _CMP_GT_OQ);
    __mmask8 xz = _mm512_cmp_pd_mask(ad[0], ad[2], _CMP_GT_OQ);
    __mmask8 yz = _mm512_cmp_pd_mask(ad[1], ad[2], _CMP_GT_OQ);
    __mmask8 z0 = xy & xz, z1 = (__mmask8)(~xy & yz), z2 = (__mmask8) ~(z0 | z1);
    __m512d dz = _mm512_mask_blend_pd(z0, _mm512_mask_blend_pd(z1, d[2], d[1]), d[0]);
    __mmask8 sw = _mm512_cmp_pd_mask(dz, _mm512_setzero_pd(), _CMP_LT_OQ); /* swap kx, ky */
    __mmask8 ns = (__mmask8)~sw;
    /* without the swap kz 0, 1, 2 has kx 1, 2, 0 and ky 2, 0, 1 */
    __mmask8 x0 = (z2 & ns) | (z1 & sw), x1 = (z0 & ns) | (z2 & sw);
    __mmask8 y0 = (z1 & ns) | (z2 & sw), y1 = (z2 & ns) | (z0 & sw);
    __m512d dx = _mm512_mask_blend_pd(x0, _mm512_mask_blend_pd(x1, d[2], d[1]), d[0]);
    __m512d dy = _mm512_mask_blend_pd(y0, _mm512_mask_blend_pd(y1, d[2], d[1]), d[0]);
    __m512d inv = _mm512_div_pd(_mm512_set1_pd(1.0), dz);
    s[0] = _mm512_cvtpd_ps(_mm512_mul_pd(dx, inv));
    s[1] = _mm512_cvtpd_ps(_mm512_mul_pd(dy, inv));
    s[2] = _mm512_cvtpd_ps(inv);
    const __mmask8 w[3][2] = {{x0, x1}, {y0, y1}, {z0, z1}};
    for (int a = 0; a < 3; a++)
        for (int v = 0; v < 2; v++) m[a][v] |= (unsigned)w[a][v] << 8 * h;
}

/* tri_tmax_nearest (any: tri_tmax_any) of each lane's tmax, 16 at once. */
CPU_AVX512_FN __m512 bounds16(const double tmax[16], uint32_t active, bool any) {
    __m512d t0 = _mm512_set1_pd(tmax[__builtin_ctz(active)]); /* for the lanes not in it */
    __m512d lo = _mm512_mask_loadu_pd(t0, (__mmask8)active, tmax);
    __m512d hi = _mm512_mask_loadu_pd(t0, (__mmask8)(active >> 8), tmax + 8);
    __m512 f = join16(_mm512_cvtpd_ps(lo), _mm512_cvtpd_ps(hi));
    __m512d cap = _mm512_set1_pd(3e38);
    __mmask16 big = (__mmask16)(_mm512_cmp_pd_mask(lo, cap, _CMP_GT_OQ) |
                                (unsigned)_mm512_cmp_pd_mask(hi, cap, _CMP_GT_OQ) << 8);
    __m512 zero = _mm512_setzero_ps();
    __mmask16 nan = _mm512_cmp_ps_mask(f, f, _CMP_UNORD_Q);
    __mmask16 is0 = _mm512_cmp_ps_mask(f, zero, _CMP_EQ_OQ);
    __mmask16 down = any ? 0xffff : _mm512_cmp_ps_mask(f, zero, _CMP_LT_OQ); /* bits - 1 */
    __m512i bits = _mm512_castps_si512(f), one = _mm512_set1_epi32(1);
    bits = _mm512_mask_sub_epi32(_mm512_add_epi32(bits, one), down, bits, one);
    __m512 r = _mm512_castsi512_ps(bits);
    r = _mm512_mask_mov_ps(r, is0, any ? zero : _mm512_set1_ps(0x1p-149f));
    r = _mm512_mask_mov_ps(r, nan, f);
    return _mm512_mask_mov_ps(r, big, _mm512_set1_ps(3e38f));
}

/* Loads the packet: each lane's ray set up as the one-ray code does. */
CPU_AVX512_FN void mesh16_init(struct mesh16 *q, const struct mesh *m, const struct ray16 *rd,
                               const double tmax[16], uint32_t active, bool any, __m512 *tm) {
    bvh16_ray_init(&q->br, rd, 8);
    __m256 sh[2][3];
    unsigned kmask[3][2] = {{0, 0}, {0, 0}, {0, 0}};
    shear8(rd, 0, sh[0], kmask);
    shear8(rd, 1, sh[1], kmask);
    q->sx = join16(sh[0][0], sh[1][0]);
    q->sy = join16(sh[0][1], sh[1][1]);
    q->sz = join16(sh[0][2], sh[1][2]);
    for (int k = 0; k < 3; k++) q->org[k] = q->br.org[k]; /* the same (float) origin */
    *tm = bounds16(tmax, active, any);
    q->m = m;
    q->kx0 = (__mmask16)kmask[0][0], q->kx1 = (__mmask16)kmask[0][1];
    q->ky0 = (__mmask16)kmask[1][0], q->ky1 = (__mmask16)kmask[1][1];
    q->kz0 = (__mmask16)kmask[2][0], q->kz1 = (__mmask16)kmask[2][1];
    q->kx = q->ky = q->kz = -1;
    bool same = true;
    int axis[3];
    for (int k = 0; k < 3; k++) {
        unsigned m0 = kmask[k][0], m1 = kmask[k][1];
        same &= (m0 == 0 || m0 == 0xffffu) && (m1 == 0 || m1 == 0xffffu);
        axis[k] = m0 ? 0 : m1 ? 1 : 2;
    }
    if (same) q->kx = axis[0], q->ky = axis[1], q->kz = axis[2];
    q->t = q->u = q->v = _mm512_setzero_ps();
    q->id = q->blk = q->lane = _mm512_setzero_si512();
    q->found = 0;
}

CPU_AVX512_EXTERN uint32_t mesh16_intersect(const struct mesh *m, const struct ray16 *rd,
                                            const double tmax[16], uint32_t active,
                                            struct mesh_hit h[16]) {
    if (!active || m->bvh.nnodes == 0) return 0;
    struct mesh16 q;
    __m512 tm;
    mesh16_init(&q, m, rd, tmax, active, false, &tm);
    bvh16_walk(m->bvh.nodes, 8, (const char *)m->blocks, sizeof *m->blocks, &q.br, &tm,
               (__mmask16)active, leaf_nearest, lone_nearest, &q, true);
    float t[16], u[16], v[16];
    uint32_t id[16], blk[16], lane[16], hit = 0;
    _mm512_storeu_ps(t, q.t), _mm512_storeu_ps(u, q.u), _mm512_storeu_ps(v, q.v);
    _mm512_storeu_si512(id, q.id), _mm512_storeu_si512(blk, q.blk);
    _mm512_storeu_si512(lane, q.lane);
    for (int i = 0; i < 16; i++) {
        if (!(q.found >> i & 1) || !((double)t[i] < tmax[i])) continue;
        h[i] = (struct mesh_hit){t[i], u[i], v[i], id[i], blk[i], lane[i]};
        hit |= 1u << i;
    }
    return hit;
}

CPU_AVX512_EXTERN uint32_t mesh16_occluded(const struct mesh *m, const struct ray16 *rd,
                                           const double tmax[16], uint32_t active) {
    if (!active || m->bvh.nnodes == 0) return 0;
    struct mesh16 q;
    __m512 tm;
    mesh16_init(&q, m, rd, tmax, active, true, &tm);
    return bvh16_walk(m->bvh.nodes, 8, (const char *)m->blocks, sizeof *m->blocks, &q.br, &tm,
                      (__mmask16)active, leaf_any, lone_any, &q, false);
}

#endif

uint32_t mesh_intersect16(const struct mesh *m, const ray r[16], const double tmax[16],
                          uint32_t active, struct mesh_hit h[16]) {
    if (!active || m->bvh.nnodes == 0) return 0;
#ifdef CPU_AVX512
    if (cpu_avx512()) {
        struct ray16 rd;
        ray16_from_rays(&rd, r, active);
        return mesh16_intersect(m, &rd, tmax, active, h);
    }
    if (cpu_avx2()) {
        struct ray16 rd;
        ray16_fill(&rd, r, active);
        return mesh8_intersect(m, &rd, 0, tmax, active, h) |
               mesh8_intersect(m, &rd, 1, tmax, active, h);
    }
#endif
    uint32_t hit = 0;
    for (int i = 0; i < 16; i++)
        if (active >> i & 1 && mesh_intersect(m, &r[i], tmax[i], &h[i])) hit |= 1u << i;
    return hit;
}

uint32_t mesh_occluded16(const struct mesh *m, const ray r[16], const double tmax[16],
                         uint32_t active) {
    if (!active || m->bvh.nnodes == 0) return 0;
#ifdef CPU_AVX512
    if (cpu_avx512()) {
        struct ray16 rd;
        ray16_from_rays(&rd, r, active);
        return mesh16_occluded(m, &rd, tmax, active);
    }
    if (cpu_avx2()) {
        struct ray16 rd;
        ray16_fill(&rd, r, active);
        return mesh8_occluded(m, &rd, 0, tmax, active) | mesh8_occluded(m, &rd, 1, tmax, active);
    }
#endif
    uint32_t hit = 0;
    for (int i = 0; i < 16; i++)
        if (active >> i & 1 && mesh_occluded(m, &r[i], tmax[i])) hit |= 1u << i;
    return hit;
}
