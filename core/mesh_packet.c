/* mesh_packet.c -- a mesh's nearest-hit and any-hit queries for 16 rays.
 *
 * The packet walk of bvh16.h with the triangle test of mesh.c done for 16
 * rays at once: each of a leaf's (up to) four triangles is broadcast and
 * tested against the packet.  Every float operation is the one the
 * one-ray test does, in the same order, and the nearest hit is chosen by
 * the same order-free rule (nearest t, then lower triangle id), so each ray
 * gets bit for bit what mesh_intersect or mesh_occluded gives it alone.
 * The rays of a packet need not share their dominant axis: the sheared
 * frame is picked per lane with mask blends.
 *
 * Without AVX-512 (another CPU, a build without SIMD, valgrind's CPU) the
 * same entry points loop over the rays one at a time.
 */
#include <stdatomic.h>

#include "bvh16.h"
#include "mesh.h"
#include "mesh_ray.h"

static atomic_bool force_scalar;

void packet_force_scalar(bool on) {
    atomic_store(&force_scalar, on);
}

#ifdef BVH16

bool bvh16_available(void) {
    return !atomic_load_explicit(&force_scalar, memory_order_relaxed) &&
           __builtin_cpu_supports("avx512f");
}

struct mesh16 {
    const struct mesh *m;
    struct bvh16_ray br;
    __m512 org[3], sx, sy, sz;
    __mmask16 kx0, kx1, ky0, ky1, kz0, kz1; /* k == 0, k == 1, per lane */
    __m512 t, u, v;                         /* the nearest hit so far */
    __m512i id, blk, lane;
    __mmask16 found;
};

/* m0 ? x : m1 ? y : z, lane by lane: axis k of a vector per lane's k. */
BVH16_FN __m512 pick(__mmask16 m0, __mmask16 m1, const __m512 d[3]) {
    return _mm512_mask_blend_ps(m0, _mm512_mask_blend_ps(m1, d[2], d[1]), d[0]);
}

BVH16_FN __mmask16 cmp(__m512 a, __m512 b, int op) {
    return _mm512_cmp_ps_mask(a, b, op);
}

/* Lane j of block b against the rays in lanes with bounds tm: tri4_test's
 * operations, 16 rays wide.  Returns the rays that hit, with t, u, v. */
BVH16_FN __mmask16 tri16(const struct mesh16 *q, const struct tri4 *b, int j, __mmask16 lanes,
                         __m512 tm, __m512 *t_out, __m512 *u_out, __m512 *v_out) {
    __m512 d[3][3];
    for (int k = 0; k < 3; k++)
        for (int a = 0; a < 3; a++) d[k][a] = _mm512_sub_ps(_mm512_set1_ps(b->v[k][a][j]), q->org[a]);
    __m512 az = pick(q->kz0, q->kz1, d[0]), bz = pick(q->kz0, q->kz1, d[1]),
           cz = pick(q->kz0, q->kz1, d[2]);
    __m512 ax = _mm512_sub_ps(pick(q->kx0, q->kx1, d[0]), _mm512_mul_ps(q->sx, az));
    __m512 ay = _mm512_sub_ps(pick(q->ky0, q->ky1, d[0]), _mm512_mul_ps(q->sy, az));
    __m512 bx = _mm512_sub_ps(pick(q->kx0, q->kx1, d[1]), _mm512_mul_ps(q->sx, bz));
    __m512 by = _mm512_sub_ps(pick(q->ky0, q->ky1, d[1]), _mm512_mul_ps(q->sy, bz));
    __m512 cx = _mm512_sub_ps(pick(q->kx0, q->kx1, d[2]), _mm512_mul_ps(q->sx, cz));
    __m512 cy = _mm512_sub_ps(pick(q->ky0, q->ky1, d[2]), _mm512_mul_ps(q->sy, cz));
    __m512 u = _mm512_sub_ps(_mm512_mul_ps(cx, by), _mm512_mul_ps(cy, bx));
    __m512 v = _mm512_sub_ps(_mm512_mul_ps(ax, cy), _mm512_mul_ps(ay, cx));
    __m512 w = _mm512_sub_ps(_mm512_mul_ps(bx, ay), _mm512_mul_ps(by, ax));
    __m512 zero = _mm512_setzero_ps();
    __mmask16 edge = (cmp(u, zero, _CMP_EQ_OQ) | cmp(v, zero, _CMP_EQ_OQ) | cmp(w, zero, _CMP_EQ_OQ)) & lanes;
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
    __mmask16 neg = cmp(u, zero, _CMP_LT_OQ) | cmp(v, zero, _CMP_LT_OQ) | cmp(w, zero, _CMP_LT_OQ);
    __mmask16 pos = cmp(u, zero, _CMP_GT_OQ) | cmp(v, zero, _CMP_GT_OQ) | cmp(w, zero, _CMP_GT_OQ);
    __m512 det = _mm512_add_ps(_mm512_add_ps(u, v), w);
    __m512 t = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(_mm512_mul_ps(u, q->sz), az),
                                           _mm512_mul_ps(_mm512_mul_ps(v, q->sz), bz)),
                             _mm512_mul_ps(_mm512_mul_ps(w, q->sz), cz));
    __m512i sign = _mm512_and_si512(_mm512_castps_si512(det), _mm512_set1_epi32(INT32_MIN));
    __m512 ts = _mm512_castsi512_ps(_mm512_xor_si512(_mm512_castps_si512(t), sign));
    __m512 ds = _mm512_castsi512_ps(_mm512_xor_si512(_mm512_castps_si512(det), sign));
    __mmask16 ok = lanes & (__mmask16) ~(neg & pos) & cmp(det, zero, _CMP_NEQ_UQ) &
                   cmp(ts, zero, _CMP_GT_OQ) &
                   cmp(ts, _mm512_mul_ps(_mm512_mul_ps(tm, _mm512_set1_ps(TRI_SLACK)), ds), _CMP_LE_OQ);
    if (!ok) return 0;
    __m512 rcp = _mm512_div_ps(_mm512_set1_ps(1.0f), det);
    *t_out = _mm512_mul_ps(t, rcp);
    *u_out = _mm512_mul_ps(v, rcp);
    *v_out = _mm512_mul_ps(w, rcp);
    return ok;
}

/* A leaf for the nearest-hit walk: all its triangles tested with the
 * bounds on entry, then taken in lane order, as tri4_take does. */
BVH16_FN __mmask16 leaf_nearest(void *ctx, uint32_t first, uint32_t count, __mmask16 lanes,
                                __m512 *tm) {
    struct mesh16 *q = ctx;
    const struct tri4 *b = &q->m->blocks[first];
    __m512 T[4], U[4], V[4];
    __mmask16 ok[4];
    for (uint32_t j = 0; j < count; j++) ok[j] = tri16(q, b, (int)j, lanes, *tm, &T[j], &U[j], &V[j]);
    for (uint32_t j = 0; j < count; j++) {
        if (!ok[j]) continue;
        __m512i id = _mm512_set1_epi32((int)b->id[j]);
        __mmask16 tie = _mm512_mask_cmp_ps_mask(q->found, T[j], *tm, _CMP_EQ_OQ) &
                        _mm512_cmp_epu32_mask(id, q->id, _MM_CMPINT_NLT);
        __mmask16 take = ok[j] & (__mmask16) ~(cmp(T[j], *tm, _CMP_GT_OQ) | tie);
        if (!take) continue;
        q->t = *tm = _mm512_mask_mov_ps(*tm, take, T[j]);
        q->u = _mm512_mask_mov_ps(q->u, take, U[j]);
        q->v = _mm512_mask_mov_ps(q->v, take, V[j]);
        q->id = _mm512_mask_mov_epi32(q->id, take, id);
        q->blk = _mm512_mask_mov_epi32(q->blk, take, _mm512_set1_epi32((int)first));
        q->lane = _mm512_mask_mov_epi32(q->lane, take, _mm512_set1_epi32((int)j));
        q->found |= take;
    }
    return 0;
}

/* A leaf for the any-hit walk: the rays that hit any of its triangles. */
BVH16_FN __mmask16 leaf_any(void *ctx, uint32_t first, uint32_t count, __mmask16 lanes, __m512 *tm) {
    const struct mesh16 *q = ctx;
    const struct tri4 *b = &q->m->blocks[first];
    __mmask16 hit = 0;
    for (uint32_t j = 0; j < count && hit != lanes; j++) {
        __m512 t, u, v;
        hit |= tri16(q, b, (int)j, lanes & (__mmask16)~hit, *tm, &t, &u, &v);
    }
    return hit;
}

/* Loads the packet: each lane's rays set up as the one-ray code does;
 * inactive lanes copy an active one (they are masked off throughout). */
BVH16_FN void mesh16_init(struct mesh16 *q, const struct mesh *m, const ray r[16],
                          const double tmax[16], uint32_t active, bool any, __m512 *tm) {
    struct bvh_ray br[16];
    float org[3][16], sx[16], sy[16], sz[16], tb[16];
    unsigned kmask[3][2] = {{0, 0}, {0, 0}, {0, 0}};
    int first = __builtin_ctz(active);
    for (int i = 0; i < 16; i++) {
        int l = active >> i & 1 ? i : first;
        struct tri_ray tr;
        bvh_ray_init(&br[i], r[l].o, r[l].d);
        tri_ray_init(&tr, &r[l]);
        for (int k = 0; k < 3; k++) org[k][i] = tr.org[k];
        sx[i] = tr.sx, sy[i] = tr.sy, sz[i] = tr.sz;
        int ks[3] = {tr.kx, tr.ky, tr.kz};
        for (int a = 0; a < 3; a++)
            for (int v = 0; v < 2; v++) kmask[a][v] |= (unsigned)(ks[a] == v) << i;
        tb[i] = any ? tri_tmax_any(tmax[l]) : tri_tmax_nearest(tmax[l]);
    }
    q->m = m;
    bvh16_ray_init(&q->br, br);
    for (int k = 0; k < 3; k++) q->org[k] = _mm512_loadu_ps(org[k]);
    q->sx = _mm512_loadu_ps(sx), q->sy = _mm512_loadu_ps(sy), q->sz = _mm512_loadu_ps(sz);
    q->kx0 = (__mmask16)kmask[0][0], q->kx1 = (__mmask16)kmask[0][1];
    q->ky0 = (__mmask16)kmask[1][0], q->ky1 = (__mmask16)kmask[1][1];
    q->kz0 = (__mmask16)kmask[2][0], q->kz1 = (__mmask16)kmask[2][1];
    *tm = _mm512_loadu_ps(tb);
    q->t = q->u = q->v = _mm512_setzero_ps();
    q->id = q->blk = q->lane = _mm512_setzero_si512();
    q->found = 0;
}

BVH16_FN uint32_t mesh_intersect16_avx512(const struct mesh *m, const ray r[16],
                                          const double tmax[16], uint32_t active,
                                          struct mesh_hit h[16]) {
    struct mesh16 q;
    __m512 tm;
    mesh16_init(&q, m, r, tmax, active, false, &tm);
    bvh16_walk(&m->bvh, &q.br, &tm, (__mmask16)active, leaf_nearest, &q);
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

BVH16_FN uint32_t mesh_occluded16_avx512(const struct mesh *m, const ray r[16],
                                         const double tmax[16], uint32_t active) {
    struct mesh16 q;
    __m512 tm;
    mesh16_init(&q, m, r, tmax, active, true, &tm);
    return bvh16_walk(&m->bvh, &q.br, &tm, (__mmask16)active, leaf_any, &q);
}

#else

bool bvh16_available(void) {
    return false;
}

#endif

uint32_t mesh_intersect16(const struct mesh *m, const ray r[16], const double tmax[16],
                          uint32_t active, struct mesh_hit h[16]) {
    if (!active || m->bvh.nnodes == 0) return 0;
#ifdef BVH16
    if (bvh16_available()) return mesh_intersect16_avx512(m, r, tmax, active, h);
#endif
    uint32_t hit = 0;
    for (int i = 0; i < 16; i++)
        if (active >> i & 1 && mesh_intersect(m, &r[i], tmax[i], &h[i])) hit |= 1u << i;
    return hit;
}

uint32_t mesh_occluded16(const struct mesh *m, const ray r[16], const double tmax[16],
                         uint32_t active) {
    if (!active || m->bvh.nnodes == 0) return 0;
#ifdef BVH16
    if (bvh16_available()) return mesh_occluded16_avx512(m, r, tmax, active);
#endif
    uint32_t hit = 0;
    for (int i = 0; i < 16; i++)
        if (active >> i & 1 && mesh_occluded(m, &r[i], tmax[i])) hit |= 1u << i;
    return hit;
}
