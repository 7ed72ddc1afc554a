/* bvh_rays8.h -- walking a wide BVH with 8 rays at once (AVX2).
 *
 * bvh16.h's packet walk for CPUs that stop at AVX2 (AMD's before Zen 4,
 * Intel's client parts), where a register holds 8 floats: every node is
 * tested against the 8 rays of a packet at once, one child at a time, and
 * the packet goes down into each child that at least one of its rays
 * enters, carrying the mask of those rays; an 8-wide node is first culled
 * for the whole packet by interval arithmetic.  A 16-ray packet goes as
 * two of 8, as Embree's AVX2 kernels take it.  The rules are bvh16.h's
 * (nearest child first, a stack entry keeping each ray's entry distance,
 * the same slack), so with order-free leaf rules every ray finds exactly
 * its one-ray hit.
 *
 * Lane masks are plain bit masks (bit i for lane i): AVX2 has no mask
 * registers, and the walk mostly asks whether a mask is empty.  The set-up
 * does the one-ray walk's operations (bvh_ray_init_with) lane by lane, so
 * a ray left alone deep in the tree goes on through the one-ray walk from
 * the floats the packet holds for it (rays8_one).  A packet whose rays
 * leave one point (camera rays) takes an 8-wide node's children by the
 * interval test alone, each with the box's bound on its rays' entry: the
 * per-ray tests it spares cost more than the few extra leaves they would
 * keep it out of, whose triangle tests are per ray and exact anyway.
 * Rays from spread points (shadow rays from a block of surface) keep the
 * per-ray tests, which cut the leaves a third of the time on a fine mesh
 * (bench/README.md).  The leaf test is the caller's, an always-inlined
 * function, as in bvh16.h.
 */
#ifndef BVH_RAYS8_H
#define BVH_RAYS8_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "accel/bvh.h"
#include "base/cpu.h"
#include "base/meter.h"

#ifdef CPU_AVX512

/* A packet of 8 rays for the node tests. */
struct rays8_ray {
    __m256 org[3], inv[3];
    __m256 oi_hi[3], oi_lo[3], inv_far[3]; /* bvh_ray_fused's constants */
    __m256 negv[3];                        /* all ones in the lanes whose direction is negative */
    unsigned neg[3];                       /* ... and as a bit mask */
    bool uniform;                          /* each axis's sign one for the packet */
    bool fused;                            /* every lane's org * inv finite */
    uint8_t near[3], far[3]; /* uniform: byte offsets in a node of the near, far planes */
    /* uniform and fused: the packet's origins and inverse directions as
     * intervals, for rays8_cull (bvh.h's bvh_cull_boxes tells why) */
    bool ia;
    bool one_origin; /* ia, and every lane's origin the same */
    struct bvh_cull cull;
};

/* The vector mask of the lanes in bit mask m. */
CPU_AVX2_INLINE __m256 rays8_lanes(unsigned m) {
    __m256i bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    __m256i in = _mm256_and_si256(_mm256_set1_epi32((int)m), bits);
    return _mm256_castsi256_ps(_mm256_cmpeq_epi32(in, bits));
}

/* The bit mask of the lanes where cmp holds. */
CPU_AVX2_INLINE unsigned rays8_bits(__m256 cmp) { return (unsigned)_mm256_movemask_ps(cmp); }

/* The least and the greatest of v's lanes (finite: no order changes them). */
CPU_AVX2_INLINE void rays8_range(__m256 v, float *lo, float *hi) {
    __m256 a = _mm256_min_ps(v, _mm256_permute2f128_ps(v, v, 1)); /* halves */
    __m256 b = _mm256_max_ps(v, _mm256_permute2f128_ps(v, v, 1));
    a = _mm256_min_ps(a, _mm256_permute_ps(a, 0x4e)); /* pairs */
    b = _mm256_max_ps(b, _mm256_permute_ps(b, 0x4e));
    a = _mm256_min_ps(a, _mm256_permute_ps(a, 0xb1)); /* neighbours */
    b = _mm256_max_ps(b, _mm256_permute_ps(b, 0xb1));
    *lo = _mm256_cvtss_f32(a);
    *hi = _mm256_cvtss_f32(b);
}

/* The packet's intervals for the culling test (uniform and fused), as
 * bvh16_ray_intervals makes them. */
CPU_AVX2_FN void rays8_intervals(struct rays8_ray *p) {
    __m256 sign = _mm256_set1_ps(-0.0f);
    for (int k = 0; k < 3; k++) {
        float olo, ohi, lo, most;
        rays8_range(p->org[k], &olo, &ohi);
        rays8_range(p->inv[k], &p->cull.imin[k], &p->cull.imax[k]);
        __m256 oi =
            _mm256_max_ps(_mm256_andnot_ps(sign, p->oi_hi[k]), _mm256_andnot_ps(sign, p->oi_lo[k]));
        rays8_range(oi, &lo, &most);
        bool neg = p->neg[k] != 0;
        p->cull.onear[k] = neg ? olo : ohi, p->cull.ofar[k] = neg ? ohi : olo;
        p->cull.cslack[k] = most * 0x1p-20f + 0x1p-100f;
    }
}

/* Lanes 8h..8h+7 of the doubles x as floats, those outside in (a vector
 * mask) taking lane first's value. */
CPU_AVX2_INLINE __m256 rays8_floats(const double x[16], int h, __m256 in, int first) {
    __m128 lo = _mm256_cvtpd_ps(_mm256_loadu_pd(x + 8 * h));
    __m128 hi = _mm256_cvtpd_ps(_mm256_loadu_pd(x + 8 * h + 4));
    return _mm256_blendv_ps(_mm256_set1_ps((float)x[first]), _mm256_set_m128(hi, lo), in);
}

/* The packet of rays 8h..8h+7 of q (those outside active, a mask of q's
 * 16, copy the first ray in it, and are masked off), for nodes of width:
 * in each lane the floats bvh_ray_init_with gives its ray, by the same
 * operations (a float conversion, a division, the fused test's bounds). */
CPU_AVX2_FN void rays8_init(struct rays8_ray *p, const struct ray16 *q, int h, unsigned active,
                            int width) {
    int first = __builtin_ctz(active);
    __m256 in = rays8_lanes(active >> 8 * h & 0xffu);
    __m256 sign = _mm256_set1_ps(-0.0f), tiny = _mm256_set1_ps(1e-30f);
    unsigned finite = 0xffu;
    p->uniform = true;
    for (int k = 0; k < 3; k++) {
        __m256 c = rays8_floats(q->d[k], h, in, first);
        __m256 small = _mm256_cmp_ps(_mm256_andnot_ps(sign, c), tiny, _CMP_LT_OQ);
        c = _mm256_blendv_ps(c, _mm256_or_ps(_mm256_and_ps(c, sign), tiny), small);
        p->inv[k] = _mm256_div_ps(_mm256_set1_ps(1.0f), c);
        p->org[k] = rays8_floats(q->o[k], h, in, first);
        p->negv[k] = _mm256_cmp_ps(c, _mm256_setzero_ps(), _CMP_LT_OQ);
        p->neg[k] = rays8_bits(p->negv[k]);
        __m256 oi = _mm256_mul_ps(p->org[k], p->inv[k]), a = _mm256_andnot_ps(sign, oi);
        __m256 slack = _mm256_add_ps(_mm256_mul_ps(a, _mm256_set1_ps(BVH_FUSED_REL)),
                                     _mm256_set1_ps(BVH_FUSED_ABS));
        __m256 scale = _mm256_set1_ps(BVH_FAR_SCALE);
        p->oi_hi[k] = _mm256_add_ps(oi, slack);
        p->oi_lo[k] = _mm256_mul_ps(_mm256_sub_ps(oi, _mm256_add_ps(slack, slack)), scale);
        p->inv_far[k] = _mm256_mul_ps(p->inv[k], scale);
        finite &= rays8_bits(_mm256_cmp_ps(a, _mm256_set1_ps(BVH_FUSED_MAX), _CMP_LT_OQ));
        bool down = p->neg[k] == 0xffu;
        size_t lo = BVH_NODE_LO(width, k), hi = BVH_NODE_HI(width, k);
        p->near[k] = (uint8_t)(down ? hi : lo), p->far[k] = (uint8_t)(down ? lo : hi);
        p->uniform &= down || p->neg[k] == 0;
    }
    p->fused = finite == 0xffu;
    p->ia = p->uniform && p->fused;
    p->one_origin = false;
    if (!p->ia) return;
    rays8_intervals(p);
    p->one_origin = true;
    for (int k = 0; k < 3; k++) p->one_origin &= p->cull.onear[k] == p->cull.ofar[k];
}

/* Lane i of p as the one-ray walk's ray (bvh_ray_init_with's floats). */
CPU_AVX2_FN void rays8_one(const struct rays8_ray *p, int i, struct bvh_ray *br) {
    float v[2][3][8];
    for (int k = 0; k < 3; k++) {
        _mm256_storeu_ps(v[0][k], p->org[k]);
        _mm256_storeu_ps(v[1][k], p->inv[k]);
    }
    for (int k = 0; k < 3; k++) {
        br->org[k] = v[0][k][i], br->inv[k] = v[1][k][i];
        br->neg[k] = p->neg[k] >> i & 1;
    }
    bvh_ray_fused(br);
}

/* Plane (k, c) of a node at nd, lower or upper. */
static inline float rays8_plane(const char *nd, size_t row, int c) {
    float f;
    memcpy(&f, nd + row + sizeof(float) * (size_t)c, sizeof f);
    return f;
}

struct rays8_entry {
    __m256 tnear; /* each ray's entry distance (kept for the stack's entries only) */
    uint32_t node;
    uint8_t count; /* as in bvh4_node: 0 inner node, else a leaf */
    uint8_t lanes;
};

/* Child c of nd against the rays in lanes, for t in [0, tmax]: bvh16_child
 * with 8 lanes (the same float operations lane by lane). */
CPU_AVX2_INLINE unsigned rays8_child(const char *nd, int width, int c, const struct rays8_ray *r,
                                     __m256 tmax, unsigned lanes, __m256 *tnear) {
    __m256 tn = _mm256_setzero_ps(), tf = tmax;
    const char *at = nd + sizeof(float) * (size_t)c;
    for (int k = 0; k < 3; k++) {
        __m256 near, far;
        if (r->uniform) {
            float nv, fv;
            memcpy(&nv, at + r->near[k], sizeof nv);
            memcpy(&fv, at + r->far[k], sizeof fv);
            near = _mm256_set1_ps(nv), far = _mm256_set1_ps(fv);
        } else {
            __m256 lo = _mm256_set1_ps(rays8_plane(nd, BVH_NODE_LO(width, k), c));
            __m256 hi = _mm256_set1_ps(rays8_plane(nd, BVH_NODE_HI(width, k), c));
            near = _mm256_blendv_ps(lo, hi, r->negv[k]);
            far = _mm256_blendv_ps(hi, lo, r->negv[k]);
        }
        if (r->fused) {
            tn = _mm256_max_ps(tn, _mm256_fmsub_ps(near, r->inv[k], r->oi_hi[k]));
            tf = _mm256_min_ps(tf, _mm256_fmsub_ps(far, r->inv_far[k], r->oi_lo[k]));
        } else {
            tn = _mm256_max_ps(tn, _mm256_mul_ps(_mm256_sub_ps(near, r->org[k]), r->inv[k]));
            tf = _mm256_min_ps(tf, _mm256_mul_ps(_mm256_sub_ps(far, r->org[k]), r->inv[k]));
        }
    }
    if (!r->fused) tf = _mm256_mul_ps(tf, _mm256_set1_ps(BVH_FAR_SCALE)); /* fused: in inv_far */
    *tnear = tn;
    return lanes & rays8_bits(_mm256_cmp_ps(tn, tf, _CMP_LE_OQ));
}

/* The greatest bound of the rays in lanes, or infinity when one is NaN
 * (bvh_cull_boxes's far_most). */
CPU_AVX2_INLINE float rays8_far_most(__m256 tmax, unsigned lanes) {
    if (rays8_bits(_mm256_cmp_ps(tmax, tmax, _CMP_UNORD_Q)) & lanes) return INFINITY;
    float lo, hi;
    rays8_range(_mm256_blendv_ps(_mm256_set1_ps(-INFINITY), tmax, rays8_lanes(lanes)), &lo, &hi);
    return hi;
}

/* bvh_cull_boxes (bvh.h) on the eight children of node nd. */
CPU_AVX2_INLINE unsigned rays8_cull(const char *nd, const struct rays8_ray *r, __m256 tmax,
                                    unsigned lanes, __m256 *tnear) {
    __m256 near[3], far[3];
    for (int k = 0; k < 3; k++) {
        near[k] = _mm256_loadu_ps((const float *)(const void *)(nd + r->near[k]));
        far[k] = _mm256_loadu_ps((const float *)(const void *)(nd + r->far[k]));
    }
    return bvh_cull_boxes(&r->cull, near, far, rays8_far_most(tmax, lanes), tnear);
}

/* The leaf test, as bvh16_leaf_fn: rays in lanes against leaf (first,
 * count); a nearest-hit leaf lowers the bounds in *tm and returns 0, an
 * any-hit one returns the rays it found blocked. */
typedef unsigned (*rays8_leaf_fn)(void *ctx, uint32_t first, uint32_t count, unsigned lanes,
                                  __m256 *tm);

/* The entry distance of the first ray in mask m. */
CPU_AVX2_INLINE float rays8_first(__m256 tn, unsigned m) {
    float t[8];
    _mm256_storeu_ps(t, tn);
    return t[__builtin_ctz(m)];
}

/* Sorts the children hit[0..n) farthest first by key[c], each child's
 * entry (its first ray's, or the packet's bound), as bvh16_descend
 * orders them. */
CPU_AVX2_INLINE void rays8_order(int hit[8], int n, const float key[8]) {
    for (int j = 1; j < n; j++)
        for (int i = j; i > 0 && key[hit[i - 1]] < key[hit[i]]; i--) {
            int ht = hit[i];
            hit[i] = hit[i - 1], hit[i - 1] = ht;
        }
}

/* bvh16_descend for 8 lanes: pushes the children of inner node cur that
 * rays enter, pops the nearest into *cur, prefetching each. */
CPU_AVX2_INLINE bool rays8_descend(const char *nodes, int width, const char *leaves,
                                   size_t leaf_size, const struct rays8_ray *r, __m256 tm,
                                   struct rays8_entry *cur, struct rays8_entry *stack, int *sp,
                                   bool ordered) {
    size_t node_size = BVH_NODE_SIZE(width);
    const char *nd = nodes + node_size * cur->node;
    uint32_t child[8];
    uint8_t count[8];
    memcpy(child, nd + BVH_NODE_CHILD(width), sizeof *child * (size_t)width);
    memcpy(count, nd + BVH_NODE_COUNT(width), (size_t)width);
    __m256 tmax = _mm256_mul_ps(tm, _mm256_set1_ps(BVH_SLACK));
    int hit[8], n = 0;
    __m256 tn[8];
    unsigned m[8];
    float key[8];
    if (width == 8 && r->ia && r->one_origin) { /* coherent: the interval test alone */
        __m256 box_tn;
        unsigned maybe = rays8_cull(nd, r, tmax, cur->lanes, &box_tn);
        _mm256_storeu_ps(key, box_tn);
        for (int c = 0; c < width; c++) {
            if (!(maybe >> c & 1)) continue;
            if (rays8_plane(nd, BVH_NODE_LO(width, 0), c) >
                rays8_plane(nd, BVH_NODE_HI(width, 0), c))
                continue; /* an empty slot */
            m[c] = cur->lanes, tn[c] = _mm256_set1_ps(key[c]);
            hit[n++] = c;
        }
    } else {
        unsigned maybe = 0xffu;
        if (width == 8 && r->ia) {
            __m256 box_tn;
            maybe = rays8_cull(nd, r, tmax, cur->lanes, &box_tn);
        }
        for (int c = 0; c < width; c++) {
            if (!(maybe >> c & 1)) continue;
            if (rays8_plane(nd, BVH_NODE_LO(width, 0), c) >
                rays8_plane(nd, BVH_NODE_HI(width, 0), c))
                continue; /* an empty slot */
            m[c] = rays8_child(nd, width, c, r, tmax, cur->lanes, &tn[c]);
            if (!m[c]) continue;
            key[c] = rays8_first(tn[c], m[c]);
            hit[n++] = c;
        }
    }
    if (n == 0) return false;
    if (ordered && n > 1) { /* the nearest last (into cur), the others as they come */
        int go = 0;
        for (int j = 1; j < n; j++) go = key[hit[j]] < key[hit[go]] ? j : go;
        int c = hit[go];
        hit[go] = hit[n - 1], hit[n - 1] = c;
    }
    for (int j = 0; j < n; j++) {
        int c = hit[j];
        const char *next = !count[c] ? nodes + node_size * child[c]
                           : leaves  ? leaves + leaf_size * child[c]
                                     : NULL;
        size_t size = count[c] ? leaf_size * (size_t)((count[c] + 3) / 4) : node_size;
        for (size_t at = 0; next && at < size; at += 64) _mm_prefetch(next + at, _MM_HINT_T0);
        struct rays8_entry *e = j == n - 1 ? cur : &stack[(*sp)++];
        if (e != cur) e->tnear = tn[c]; /* the walk goes into cur now */
        e->node = child[c];
        e->count = count[c];
        e->lanes = (uint8_t)m[c];
    }
    return true;
}

/* Leaf entries met between two looks at the meter (bvh16.h's
 * BVH16_LOOK_VISITS). */
#define RAYS8_LOOK_VISITS 4096

/* When at most this many rays of a packet still need an entry, they go
 * on alone (bvh16.h's BVH16_LONE_MAX, for a packet half as wide). */
#define RAYS8_LONE_MAX 1

/* bvh16_walk for 8 lanes: walks the tree with the rays in lanes, their
 * bounds in *tm; returns the rays an any-hit leaf blocked.  lone, NULL or
 * a leaf-like function, takes an entry at most RAYS8_LONE_MAX rays still
 * need and walks it ray by ray.  A stopped meter ends the walk. */
CPU_AVX2_INLINE unsigned rays8_walk(const void *nodes, int width, const char *leaves,
                                    size_t leaf_size, const struct rays8_ray *r, __m256 *tm,
                                    unsigned lanes, rays8_leaf_fn leaf, rays8_leaf_fn lone,
                                    void *ctx, bool ordered) {
    struct rays8_entry stack[BVH8_STACK], cur;
    int sp = 0;
    uint32_t visits = 0;
    unsigned blocked = 0;
    cur.node = 0;
    cur.count = 0;
    cur.lanes = (uint8_t)lanes;
    for (;;) {
        if (lone && __builtin_popcount(cur.lanes) <= RAYS8_LONE_MAX) {
            blocked |= lone(ctx, cur.node, cur.count, cur.lanes, tm);
            lanes &= ~blocked;
            if (!lanes) return blocked;
        } else if (cur.count == 0) {
            if (rays8_descend(nodes, width, leaves, leaf_size, r, *tm, &cur, stack, &sp, ordered))
                continue;
        } else {
            visits += cur.count;
            if (visits >= RAYS8_LOOK_VISITS) { /* overlaps: look at the meter */
                visits = 0;
                if (!meter_live()) return blocked;
            }
            blocked |= leaf(ctx, cur.node, cur.count, cur.lanes, tm);
            lanes &= ~blocked;
            if (!lanes) return blocked;
        }
        for (;;) { /* pop an entry some ray still needs (its fields, not a copy of it) */
            if (sp == 0) return blocked;
            const struct rays8_entry *e = &stack[--sp];
            __m256 reach = _mm256_mul_ps(*tm, _mm256_set1_ps(BVH_SLACK));
            /* !(tnear > reach), as the one-ray walk has it (NaN included) */
            unsigned in =
                e->lanes & lanes & rays8_bits(_mm256_cmp_ps(e->tnear, reach, _CMP_NGT_UQ));
            if (!in) continue;
            cur.node = e->node, cur.count = e->count, cur.lanes = (uint8_t)in;
            break;
        }
    }
}

#endif /* CPU_AVX512 */
#endif
