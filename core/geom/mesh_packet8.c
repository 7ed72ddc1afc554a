/* mesh_packet8.c -- a mesh's packet queries where the CPU stops at AVX2.
 *
 * mesh_packet.c's packet queries with 8 rays to a register: the walk of
 * bvh_rays8.h with the watertight triangle test done for 8 rays at once,
 * a 16-ray packet taken as two of 8.  As there, every float operation is
 * the one the one-ray test does, in the same order, and the nearest hit
 * is chosen by the same order-free rule, so each ray gets bit for bit
 * what mesh_intersect or mesh_occluded gives it alone; the sheared frame
 * is picked per lane with blends where the rays do not share their
 * dominant axis; a ray left alone deep in the tree, and an incoherent
 * packet through a mesh that outgrows the cache, go on through the one-ray
 * walk (mesh_walk.h).
 *
 * Each lane's ray set-up does the operations of the one-ray code's
 * (bvh_ray_init_with, tri_ray_init) 8 or 4 lanes at once, so a lane left
 * to go on alone has the same floats as the ray alone would.
 * Called by mesh_packet.c's entry points, and by the scene's packets,
 * where cpu_avx2 holds and cpu_avx512 does not.
 */
#include <string.h>

#include "accel/bvh_rays8.h"
#include "geom/mesh.h"
#include "geom/mesh_ray.h"
#include "geom/mesh_walk.h"

#ifdef CPU_AVX512

/* One packet of 8 rays on its way through a mesh. */
/* NOLINTNEXTLINE(clang-analyzer-optin.performance.Padding) */
struct mesh8 {
    const struct mesh *m;
    struct rays8_ray br;
    __m256 sx, sy, sz;
    __m256 kx0, kx1, ky0, ky1, kz0, kz1; /* all ones where k == 0, k == 1 */
    unsigned axes[3][2];                 /* the same as bit masks */
    int kx, ky, kz;                      /* >= 0: the same axes in every lane */
    __m256 t, u, v;                      /* the nearest hit so far */
    __m256i id, blk, lane;
    unsigned found;
};

/* m0 ? d[0] : m1 ? d[1] : d[2], lane by lane. */
CPU_AVX2_INLINE __m256 pick8(__m256 m0, __m256 m1, const __m256 d[3]) {
    return _mm256_blendv_ps(_mm256_blendv_ps(d[2], d[1], m1), d[0], m0);
}

/* The lanes where u, v or w compares with zero as cmp (a constant) says. */
#define ANY3(u, v, w, cmp)                                                                         \
    rays8_bits(_mm256_or_ps(_mm256_or_ps(_mm256_cmp_ps(u, _mm256_setzero_ps(), cmp),               \
                                         _mm256_cmp_ps(v, _mm256_setzero_ps(), cmp)),              \
                            _mm256_cmp_ps(w, _mm256_setzero_ps(), cmp)))

/* Through an edge or a vertex: the lanes in edge redone in double. */
CPU_AVX2_FN void edges8(unsigned edge, __m256 ax, __m256 ay, __m256 bx, __m256 by, __m256 cx,
                        __m256 cy, __m256 *u, __m256 *v, __m256 *w) {
    float U[8], V[8], W[8], AX[8], AY[8], BX[8], BY[8], CX[8], CY[8];
    _mm256_storeu_ps(U, *u), _mm256_storeu_ps(V, *v), _mm256_storeu_ps(W, *w);
    _mm256_storeu_ps(AX, ax), _mm256_storeu_ps(AY, ay), _mm256_storeu_ps(BX, bx);
    _mm256_storeu_ps(BY, by), _mm256_storeu_ps(CX, cx), _mm256_storeu_ps(CY, cy);
    for (unsigned m = edge; m; m &= m - 1) {
        int i = __builtin_ctz(m);
        tri_edges_double(AX[i], AY[i], BX[i], BY[i], CX[i], CY[i], &U[i], &V[i], &W[i]);
    }
    *u = _mm256_loadu_ps(U), *v = _mm256_loadu_ps(V), *w = _mm256_loadu_ps(W);
}

/* Lane j of block b against the rays in lanes with bounds tm: tri16's
 * operations, 8 rays wide.  Returns the rays that hit, with t, u, v. */
CPU_AVX2_FN unsigned tri8(const struct mesh8 *q, const struct tri4 *b, int j, unsigned lanes,
                          __m256 tm, __m256 *t_out, __m256 *u_out, __m256 *v_out) {
    __m256 d[3][3];
    for (int k = 0; k < 3; k++)
        for (int a = 0; a < 3; a++)
            d[k][a] = _mm256_sub_ps(_mm256_set1_ps(b->v[k][a][j]), q->br.org[a]);
    __m256 a[3][3]; /* vertex k's coordinates in each lane's frame: x, y, z */
    for (int k = 0; k < 3; k++) {
        if (q->kz >= 0) {
            a[k][0] = d[k][q->kx], a[k][1] = d[k][q->ky], a[k][2] = d[k][q->kz];
        } else {
            a[k][0] = pick8(q->kx0, q->kx1, d[k]);
            a[k][1] = pick8(q->ky0, q->ky1, d[k]);
            a[k][2] = pick8(q->kz0, q->kz1, d[k]);
        }
    }
    __m256 az = a[0][2], bz = a[1][2], cz = a[2][2];
    __m256 ax = _mm256_sub_ps(a[0][0], _mm256_mul_ps(q->sx, az));
    __m256 ay = _mm256_sub_ps(a[0][1], _mm256_mul_ps(q->sy, az));
    __m256 bx = _mm256_sub_ps(a[1][0], _mm256_mul_ps(q->sx, bz));
    __m256 by = _mm256_sub_ps(a[1][1], _mm256_mul_ps(q->sy, bz));
    __m256 cx = _mm256_sub_ps(a[2][0], _mm256_mul_ps(q->sx, cz));
    __m256 cy = _mm256_sub_ps(a[2][1], _mm256_mul_ps(q->sy, cz));
    __m256 u = _mm256_sub_ps(_mm256_mul_ps(cx, by), _mm256_mul_ps(cy, bx));
    __m256 v = _mm256_sub_ps(_mm256_mul_ps(ax, cy), _mm256_mul_ps(ay, cx));
    __m256 w = _mm256_sub_ps(_mm256_mul_ps(bx, ay), _mm256_mul_ps(by, ax));
    unsigned edge = ANY3(u, v, w, _CMP_EQ_OQ) & lanes;
    if (edge) edges8(edge, ax, ay, bx, by, cx, cy, &u, &v, &w);
    unsigned neg = ANY3(u, v, w, _CMP_LT_OQ), pos = ANY3(u, v, w, _CMP_GT_OQ);
    __m256 det = _mm256_add_ps(_mm256_add_ps(u, v), w);
    __m256 t = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(u, q->sz), az),
                                           _mm256_mul_ps(_mm256_mul_ps(v, q->sz), bz)),
                             _mm256_mul_ps(_mm256_mul_ps(w, q->sz), cz));
    __m256 sign = _mm256_and_ps(det, _mm256_set1_ps(-0.0f));
    __m256 ts = _mm256_xor_ps(t, sign), ds = _mm256_xor_ps(det, sign);
    __m256 zero = _mm256_setzero_ps();
    __m256 reach = _mm256_mul_ps(_mm256_mul_ps(tm, _mm256_set1_ps(TRI_SLACK)), ds);
    unsigned ok = lanes & ~(neg & pos) & rays8_bits(_mm256_cmp_ps(det, zero, _CMP_NEQ_UQ)) &
                  rays8_bits(_mm256_cmp_ps(ts, zero, _CMP_GT_OQ)) &
                  rays8_bits(_mm256_cmp_ps(ts, reach, _CMP_LE_OQ));
    if (!ok) return 0;
    __m256 rcp = _mm256_div_ps(_mm256_set1_ps(1.0f), det);
    *t_out = _mm256_mul_ps(t, rcp);
    *u_out = _mm256_mul_ps(v, rcp);
    *v_out = _mm256_mul_ps(w, rcp);
    return ok;
}

/* The triangles of the count in blocks b whose bounding box some ray of
 * the packet may enter (tri_cull in mesh_packet.c). */
CPU_AVX2_FN unsigned tri_cull8(const struct mesh8 *q, const struct tri4 *b, uint32_t count,
                               unsigned lanes, __m256 tm) {
    if (!q->br.ia) return 0xffu;
    __m256 near[3], far[3], tn; /* uniform signs: every lane's the same */
    unsigned down = (q->br.neg[0] != 0) | (q->br.neg[1] != 0) << 1 | (q->br.neg[2] != 0) << 2;
    tri_leaf_boxes(b, count, down, near, far);
    __m256 reach = _mm256_mul_ps(tm, _mm256_set1_ps(BVH_SLACK));
    return bvh_cull_boxes(&q->br.cull, near, far, rays8_far_most(reach, lanes), &tn);
}

/* A leaf for the nearest-hit walk: its triangles that tri_cull8 keeps
 * tested with the bounds on entry, then taken in lane order (tri4_take's
 * rule: nearest t, then the lower triangle id). */
CPU_AVX2_FN unsigned leaf_nearest8(void *ctx, uint32_t first, uint32_t count, unsigned lanes,
                                   __m256 *tm) {
    struct mesh8 *q = ctx;
    const struct tri4 *b = &q->m->blocks[first];
    __m256 T[BVH8_LEAF_MAX], U[BVH8_LEAF_MAX], V[BVH8_LEAF_MAX];
    unsigned ok[BVH8_LEAF_MAX];
    unsigned live = tri_cull8(q, b, count, lanes, *tm);
    for (uint32_t j = 0; j < count; j++)
        ok[j] =
            live >> j & 1 ? tri8(q, &b[j / 4], (int)(j % 4), lanes, *tm, &T[j], &U[j], &V[j]) : 0;
    for (uint32_t j = 0; j < count; j++) {
        if (!ok[j]) continue;
        __m256i id = _mm256_set1_epi32((int)b[j / 4].id[j % 4]);
        __m256i not_lower = _mm256_cmpeq_epi32(_mm256_max_epu32(id, q->id), id); /* id >= q->id */
        unsigned tie = q->found & rays8_bits(_mm256_cmp_ps(T[j], *tm, _CMP_EQ_OQ)) &
                       rays8_bits(_mm256_castsi256_ps(not_lower));
        unsigned take = ok[j] & ~(rays8_bits(_mm256_cmp_ps(T[j], *tm, _CMP_GT_OQ)) | tie);
        if (!take) continue;
        __m256 tv = rays8_lanes(take);
        __m256i ti = _mm256_castps_si256(tv);
        q->t = *tm = _mm256_blendv_ps(*tm, T[j], tv);
        q->u = _mm256_blendv_ps(q->u, U[j], tv);
        q->v = _mm256_blendv_ps(q->v, V[j], tv);
        q->id = _mm256_blendv_epi8(q->id, id, ti);
        q->blk = _mm256_blendv_epi8(q->blk, _mm256_set1_epi32((int)(first + j / 4)), ti);
        q->lane = _mm256_blendv_epi8(q->lane, _mm256_set1_epi32((int)(j % 4)), ti);
        q->found |= take;
    }
    return 0;
}

/* A leaf for the any-hit walk: the rays that hit any of its triangles. */
CPU_AVX2_FN unsigned leaf_any8(void *ctx, uint32_t first, uint32_t count, unsigned lanes,
                               __m256 *tm) {
    const struct mesh8 *q = ctx;
    const struct tri4 *b = &q->m->blocks[first];
    unsigned hit = 0;
    unsigned live = tri_cull8(q, b, count, lanes, *tm);
    for (uint32_t j = 0; j < count && hit != lanes; j++) {
        if (!(live >> j & 1)) continue;
        __m256 t = _mm256_setzero_ps(), u = t, v = t; /* unused here */
        hit |= tri8(q, &b[j / 4], (int)(j % 4), lanes & ~hit, *tm, &t, &u, &v);
    }
    return hit;
}

/* A packet's nearest hits as arrays, for the lone walk and the answer. */
struct hits8 {
    float t[8], u[8], v[8], bound[8];
    uint32_t id[8], blk[8], lane[8];
};

CPU_AVX2_FN void hits8_store(struct hits8 *s, const struct mesh8 *q, __m256 tm) {
    _mm256_storeu_ps(s->t, q->t), _mm256_storeu_ps(s->u, q->u), _mm256_storeu_ps(s->v, q->v);
    _mm256_storeu_ps(s->bound, tm);
    _mm256_storeu_si256((__m256i *)(void *)s->id, q->id);
    _mm256_storeu_si256((__m256i *)(void *)s->blk, q->blk);
    _mm256_storeu_si256((__m256i *)(void *)s->lane, q->lane);
}

CPU_AVX2_FN void hits8_load(const struct hits8 *s, struct mesh8 *q, __m256 *tm) {
    q->t = _mm256_loadu_ps(s->t), q->u = _mm256_loadu_ps(s->u), q->v = _mm256_loadu_ps(s->v);
    *tm = _mm256_loadu_ps(s->bound);
    q->id = _mm256_loadu_si256((const __m256i *)(const void *)s->id);
    q->blk = _mm256_loadu_si256((const __m256i *)(const void *)s->blk);
    q->lane = _mm256_loadu_si256((const __m256i *)(const void *)s->lane);
}

/* Lane i of q as the one-ray walk's ray: the floats the packet holds for
 * it are those bvh_ray_init_with and tri_ray_init give the ray. */
CPU_AVX2_FN void lane_ray8(const struct mesh8 *q, int i, struct bvh_ray *br, struct tri_ray *tr) {
    rays8_one(&q->br, i, br);
    float s[3][8];
    _mm256_storeu_ps(s[0], q->sx), _mm256_storeu_ps(s[1], q->sy), _mm256_storeu_ps(s[2], q->sz);
    int axis[3];
    for (int a = 0; a < 3; a++)
        axis[a] = q->axes[a][0] >> i & 1 ? 0 : q->axes[a][1] >> i & 1 ? 1 : 2;
    for (int k = 0; k < 3; k++) tr->org[k] = br->org[k];
    tr->kx = axis[0], tr->ky = axis[1], tr->kz = axis[2];
    tr->sx = s[0][i], tr->sy = s[1][i], tr->sz = s[2][i];
}

/* The lone walk of a nearest-hit packet: each ray in lanes goes on
 * through node (count: as in bvh8_node) alone, from its best hit so far,
 * and what it finds goes back into its lane. */
CPU_AVX2_FN unsigned lone_nearest8(void *ctx, uint32_t node, uint32_t count, unsigned lanes,
                                   __m256 *tm) {
    struct mesh8 *q = ctx;
    struct hits8 s;
    hits8_store(&s, q, *tm);
    struct bvh_entry e = {node, (uint8_t)count, 0};
    for (unsigned m = lanes; m; m &= m - 1) {
        int i = __builtin_ctz(m);
        struct bvh_ray br;
        struct tri_ray tr;
        lane_ray8(q, i, &br, &tr);
        struct mesh_hit h = {s.t[i], s.u[i], s.v[i], s.id[i], s.blk[i], s.lane[i]};
        bool found = q->found >> i & 1;
        if (!mesh_walk_from(q->m, &br, &tr, NULL, e, &s.bound[i], &h, &found, false,
                            bvh8_test_fused))
            continue;
        s.t[i] = h.t, s.u[i] = h.u, s.v[i] = h.v;
        s.id[i] = h.tri, s.blk[i] = h.blk, s.lane[i] = h.lane;
        q->found |= 1u << i;
    }
    hits8_load(&s, q, tm);
    return 0;
}

/* The lone walk of an any-hit packet: the rays in lanes that meet a
 * triangle under node. */
CPU_AVX2_FN unsigned lone_any8(void *ctx, uint32_t node, uint32_t count, unsigned lanes,
                               __m256 *tm) {
    const struct mesh8 *q = ctx;
    float bound[8];
    _mm256_storeu_ps(bound, *tm);
    struct bvh_entry e = {node, (uint8_t)count, 0};
    unsigned hit = 0;
    for (unsigned m = lanes; m; m &= m - 1) {
        int i = __builtin_ctz(m);
        struct bvh_ray br;
        struct tri_ray tr;
        lane_ray8(q, i, &br, &tr);
        struct mesh_hit h;
        bool found = false;
        if (mesh_walk_from(q->m, &br, &tr, NULL, e, &bound[i], &h, &found, true, bvh8_test_fused))
            hit |= 1u << i;
    }
    return hit;
}

/* pick8 in double: m0 ? d[0] : m1 ? d[1] : d[2]. */
CPU_AVX2_INLINE __m256d pick4d(__m256d m0, __m256d m1, const __m256d d[3]) {
    return _mm256_blendv_pd(_mm256_blendv_pd(d[2], d[1], m1), d[0], m0);
}

/* tri_ray_init for lanes 4c..4c+3 of the packet (rays 8h + 4c on of rd,
 * those outside in copying ray first), in double as it does (mesh_packet.c's
 * shear8 with AVX2): the dominant axis kz, kx and ky after it (swapped
 * when d[kz] < 0), and the shear s, into s[a] (x, y, z) and the axis
 * masks m[a][v] (the lanes whose axis a is v). */
CPU_AVX2_FN void shear4(const struct ray16 *rd, int h, int c, __m256d in, int first, __m128 s[3],
                        unsigned m[3][2]) {
    __m256d d[3], ad[3], sign = _mm256_set1_pd(-0.0);
    for (int k = 0; k < 3; k++) {
        d[k] = _mm256_blendv_pd(_mm256_set1_pd(rd->d[k][first]),
                                _mm256_loadu_pd(rd->d[k] + 8 * h + 4 * c), in);
        ad[k] = _mm256_andnot_pd(sign, d[k]);
    }
    __m256d xy = _mm256_cmp_pd(ad[0], ad[1], _CMP_GT_OQ);
    __m256d xz = _mm256_cmp_pd(ad[0], ad[2], _CMP_GT_OQ);
    __m256d yz = _mm256_cmp_pd(ad[1], ad[2], _CMP_GT_OQ);
    __m256d z0 = _mm256_and_pd(xy, xz), z1 = _mm256_andnot_pd(xy, yz);
    __m256d z2 =
        _mm256_andnot_pd(_mm256_or_pd(z0, z1), _mm256_castsi256_pd(_mm256_set1_epi64x(-1)));
    __m256d dz = pick4d(z0, z1, d);
    __m256d sw = _mm256_cmp_pd(dz, _mm256_setzero_pd(), _CMP_LT_OQ); /* swap kx, ky */
    /* without the swap kz 0, 1, 2 has kx 1, 2, 0 and ky 2, 0, 1 */
    __m256d x0 = _mm256_or_pd(_mm256_andnot_pd(sw, z2), _mm256_and_pd(sw, z1));
    __m256d x1 = _mm256_or_pd(_mm256_andnot_pd(sw, z0), _mm256_and_pd(sw, z2));
    __m256d y0 = _mm256_or_pd(_mm256_andnot_pd(sw, z1), _mm256_and_pd(sw, z2));
    __m256d y1 = _mm256_or_pd(_mm256_andnot_pd(sw, z2), _mm256_and_pd(sw, z0));
    __m256d inv = _mm256_div_pd(_mm256_set1_pd(1.0), dz);
    s[0] = _mm256_cvtpd_ps(_mm256_mul_pd(pick4d(x0, x1, d), inv));
    s[1] = _mm256_cvtpd_ps(_mm256_mul_pd(pick4d(y0, y1, d), inv));
    s[2] = _mm256_cvtpd_ps(inv);
    const __m256d w[3][2] = {{x0, x1}, {y0, y1}, {z0, z1}};
    for (int a = 0; a < 3; a++)
        for (int v = 0; v < 2; v++) m[a][v] |= (unsigned)_mm256_movemask_pd(w[a][v]) << 4 * c;
}

/* The sheared frames of the packet's lanes as registers: the shear, the
 * axis masks and, when every lane has the same axes, those. */
CPU_AVX2_FN void mesh8_frames(struct mesh8 *q, const struct ray16 *rd, int h, uint32_t active) {
    int first = __builtin_ctz(active);
    __m128 s[2][3];
    memset(q->axes, 0, sizeof q->axes);
    for (int c = 0; c < 2; c++) {
        unsigned bits = active >> (8 * h + 4 * c) & 0xfu;
        __m256i lane = _mm256_setr_epi64x(1, 2, 4, 8);
        __m256i on = _mm256_and_si256(_mm256_set1_epi64x((long long)bits), lane);
        __m256d in = _mm256_castsi256_pd(_mm256_cmpeq_epi64(on, lane));
        shear4(rd, h, c, in, first, s[c], q->axes);
    }
    q->sx = _mm256_set_m128(s[1][0], s[0][0]);
    q->sy = _mm256_set_m128(s[1][1], s[0][1]);
    q->sz = _mm256_set_m128(s[1][2], s[0][2]);
    q->kx0 = rays8_lanes(q->axes[0][0]), q->kx1 = rays8_lanes(q->axes[0][1]);
    q->ky0 = rays8_lanes(q->axes[1][0]), q->ky1 = rays8_lanes(q->axes[1][1]);
    q->kz0 = rays8_lanes(q->axes[2][0]), q->kz1 = rays8_lanes(q->axes[2][1]);
    q->kx = q->ky = q->kz = -1;
    bool same = true;
    int axis[3];
    for (int a = 0; a < 3; a++) {
        unsigned m0 = q->axes[a][0], m1 = q->axes[a][1];
        same &= (m0 == 0 || m0 == 0xffu) && (m1 == 0 || m1 == 0xffu);
        axis[a] = m0 ? 0 : m1 ? 1 : 2;
    }
    if (same) q->kx = axis[0], q->ky = axis[1], q->kz = axis[2];
}

/* Loads rays 8h..8h+7 of rd (active: a mask of its 16), each set up as
 * the one-ray code does, and their float bounds into *tm. */
CPU_AVX2_FN void mesh8_init(struct mesh8 *q, const struct mesh *m, const struct ray16 *rd, int h,
                            const double tmax[16], uint32_t active, bool any, __m256 *tm) {
    rays8_init(&q->br, rd, h, active, 8);
    mesh8_frames(q, rd, h, active);
    int first = __builtin_ctz(active);
    float bound[8];
    for (int i = 0; i < 8; i++) {
        int at = active >> (8 * h + i) & 1 ? 8 * h + i : first;
        bound[i] = any ? tri_tmax_any(tmax[at]) : tri_tmax_nearest(tmax[at]);
    }
    *tm = _mm256_loadu_ps(bound);
    q->m = m;
    q->t = q->u = q->v = _mm256_setzero_ps();
    q->id = q->blk = q->lane = _mm256_setzero_si256();
    q->found = 0;
}

/* Whether the packet goes ray by ray from the root (the lone walk): rays
 * going every way through a mesh that outgrows the cache, where they part
 * ways near the root.  On the AMD EPYC with AVX-512 that the 16-ray
 * packets now keep their walk on, these 8-ray ones still ran 1.03-1.16x
 * as fast this way (bench/README.md, "The kernels on an AMD EPYC with
 * AVX-512"). */
CPU_AVX2_FN bool parts8(const struct mesh8 *q) { return !q->br.uniform && q->m->prefetch; }

CPU_AVX2_EXTERN uint32_t mesh8_intersect(const struct mesh *m, const struct ray16 *rd, int h,
                                         const double tmax[16], uint32_t active,
                                         struct mesh_hit hit[16]) {
    unsigned lanes = active >> 8 * h & 0xffu;
    if (!lanes || m->bvh.nnodes == 0) return 0;
    struct mesh8 q;
    __m256 tm;
    mesh8_init(&q, m, rd, h, tmax, active, false, &tm);
    if (parts8(&q))
        lone_nearest8(&q, 0, 0, lanes, &tm);
    else
        rays8_walk(m->bvh.nodes, 8, (const char *)m->blocks, sizeof *m->blocks, &q.br, &tm, lanes,
                   leaf_nearest8, lone_nearest8, &q, true);
    struct hits8 s;
    hits8_store(&s, &q, tm);
    uint32_t got = 0;
    for (unsigned f = q.found & lanes; f; f &= f - 1) {
        int i = __builtin_ctz(f), at = 8 * h + i;
        if (!((double)s.t[i] < tmax[at])) continue;
        hit[at] = (struct mesh_hit){s.t[i], s.u[i], s.v[i], s.id[i], s.blk[i], s.lane[i]};
        got |= 1u << at;
    }
    return got;
}

CPU_AVX2_EXTERN uint32_t mesh8_occluded(const struct mesh *m, const struct ray16 *rd, int h,
                                        const double tmax[16], uint32_t active) {
    unsigned lanes = active >> 8 * h & 0xffu;
    if (!lanes || m->bvh.nnodes == 0) return 0;
    struct mesh8 q;
    __m256 tm;
    mesh8_init(&q, m, rd, h, tmax, active, true, &tm);
    unsigned hit = parts8(&q)
                       ? lone_any8(&q, 0, 0, lanes, &tm)
                       : rays8_walk(m->bvh.nodes, 8, (const char *)m->blocks, sizeof *m->blocks,
                                    &q.br, &tm, lanes, leaf_any8, lone_any8, &q, false);
    return (uint32_t)hit << 8 * h;
}

#endif
