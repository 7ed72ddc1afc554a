/* bvh16.h -- walking a wide BVH with 16 rays at once (AVX-512).
 *
 * The packet walk of Wald et al. (2001) on a 4- or 8-wide tree (bvh.h's
 * shared node layout, the width a constant each caller passes): every node
 * is tested against all 16 rays of the packet at once, one child at a
 * time, and the packet goes down into each child that at least one of its
 * rays enters, carrying the mask of those rays.  On 8-wide nodes an
 * interval test of the whole packet against all eight children first
 * (bvh16_cull) spares the per-ray tests of the children no ray enters, and
 * a packet whose rays leave one point (camera rays) takes the children by
 * that test alone, each with the box's bound on its rays' entry, as
 * bvh_rays8.h does.  The nearest child (by the entry distance of the
 * first ray entering it) is taken first, the others as they come; a stack
 * entry keeps each ray's entry distance, so a ray that found a nearer hit
 * meanwhile drops out of it when it is popped.
 * The nodes and leaves about to be visited are prefetched.  For coherent
 * rays (a 4x4 block of pixels, the shadow rays from it to a light) the
 * node data is loaded once for 16 rays.
 *
 * The walk visits nodes in another order than the one-ray walk of bvh.h,
 * and culls with the same slack (BVH_SLACK), so with order-free leaf rules
 * (mesh_ray.h, scene_query.h) every ray finds exactly its one-ray hit.
 *
 * Only the AVX-512 code lives here, compiled for that target whatever the
 * build's -march (functions carry base/cpu.h's target attribute), and
 * used when the CPU has it (cpu_avx512).  The leaf test is the caller's:
 * it comes in as an always-inlined function, so each walk is specialised.
 */
#ifndef BVH16_H
#define BVH16_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "accel/bvh.h"
#include "base/cpu.h"
#include "base/meter.h"

#ifdef CPU_AVX512

/* A packet's rays as struct ray16 (vec.h), 8 lanes to a register half,
 * from an array of rays; lanes not in the packet copy its first ray (they
 * are masked off). */
CPU_AVX512_FN void ray16_from_rays(struct ray16 *q, const ray r[16], uint32_t active) {
    int first = __builtin_ctz(active);
    for (int i = 0; i < 16; i++) {
        const ray *ri = &r[active >> i & 1 ? i : first];
        q->o[0][i] = ri->o.x, q->o[1][i] = ri->o.y, q->o[2][i] = ri->o.z;
        q->d[0][i] = ri->d.x, q->d[1][i] = ri->d.y, q->d[2][i] = ri->d.z;
    }
}

/* The same from rays already in structure of arrays (o[k][i], d[k][i]),
 * whatever the lanes outside active hold. */
CPU_AVX512_FN void ray16_from_arrays(struct ray16 *q, const double o[3][16], const double d[3][16],
                                     uint32_t active) {
    int first = __builtin_ctz(active);
    for (int k = 0; k < 3; k++)
        for (int h = 0; h < 16; h += 8) {
            __mmask8 in = (__mmask8)(active >> h);
            __m512d os = _mm512_set1_pd(o[k][first]), ds = _mm512_set1_pd(d[k][first]);
            _mm512_storeu_pd(q->o[k] + h, _mm512_mask_blend_pd(in, os, _mm512_loadu_pd(o[k] + h)));
            _mm512_storeu_pd(q->d[k] + h, _mm512_mask_blend_pd(in, ds, _mm512_loadu_pd(d[k] + h)));
        }
}

/* Two halves of 8 floats as one register of 16. */
CPU_AVX512_FN __m512 join16(__m256 lo, __m256 hi) {
    return _mm512_castpd_ps(
        _mm512_insertf64x4(_mm512_castps_pd(_mm512_castps256_ps512(lo)), _mm256_castps_pd(hi), 1));
}

/* 16 rays, one per lane, for the node test: each lane the same floats as
 * bvh_ray_init gives its ray (the same operations). */
struct bvh16_ray {
    __m512 org[3], inv[3];
    __mmask16 neg[3];
    bool uniform;            /* each axis's sign one for the packet: its near side is one too */
    uint8_t near[3], far[3]; /* then the byte offsets in a node of those sides' floats */
    /* The packet's origins and inverse directions as intervals, for the
     * culling test of bvh16_cull (ia: uniform and fused, so every lane's
     * org and inv finite; else they are not set). */
    bool ia;
    bool one_origin; /* ia, and every lane's origin the same */
    struct bvh_cull cull;
    /* For the fused child test: bvh_ray_fused's constants lane by lane,
     * and whether every lane's org * inv is finite. */
    __m512 oi_hi[3], oi_lo[3], inv_far[3];
    bool fused;
};

/* bvh_ray_fused's bounds of org * inv for the 16 lanes of p. */
CPU_AVX512_FN void bvh16_ray_fused(struct bvh16_ray *p) {
    __mmask16 finite = 0xffff;
    for (int k = 0; k < 3; k++) {
        __m512 oi = _mm512_mul_ps(p->org[k], p->inv[k]), a = _mm512_abs_ps(oi);
        __m512 slack = _mm512_add_ps(_mm512_mul_ps(a, _mm512_set1_ps(BVH_FUSED_REL)),
                                     _mm512_set1_ps(BVH_FUSED_ABS));
        p->oi_hi[k] = _mm512_add_ps(oi, slack);
        p->oi_lo[k] = _mm512_mul_ps(_mm512_sub_ps(oi, _mm512_add_ps(slack, slack)),
                                    _mm512_set1_ps(BVH_FAR_SCALE));
        p->inv_far[k] = _mm512_mul_ps(p->inv[k], _mm512_set1_ps(BVH_FAR_SCALE));
        finite &= _mm512_cmp_ps_mask(a, _mm512_set1_ps(BVH_FUSED_MAX), _CMP_LT_OQ);
    }
    p->fused = finite == 0xffff;
}

/* The least of each of a, b, c and d into out[0..3] (max: the greatest),
 * four reductions sharing their shuffles: halves, then quarters of all
 * four at once, then within each 128-bit lane.  No NaN comes here (the
 * caller's values are finite), so the order of the mins is free. */
CPU_AVX512_INLINE void bvh16_reduce4(__m512 a, __m512 b, __m512 c, __m512 d, bool max,
                                     float out[4]) {
#define BVH16_PICK(x, y) (max ? _mm512_max_ps(x, y) : _mm512_min_ps(x, y))
    __m512 ab = BVH16_PICK(_mm512_shuffle_f32x4(a, b, 0x44), _mm512_shuffle_f32x4(a, b, 0xee));
    __m512 cd = BVH16_PICK(_mm512_shuffle_f32x4(c, d, 0x44), _mm512_shuffle_f32x4(c, d, 0xee));
    __m512 r = BVH16_PICK(_mm512_shuffle_f32x4(ab, cd, 0x88), _mm512_shuffle_f32x4(ab, cd, 0xdd));
    r = BVH16_PICK(r, _mm512_permute_ps(r, 0x4e));
    r = BVH16_PICK(r, _mm512_permute_ps(r, 0xb1));
#undef BVH16_PICK
    float t[16];
    _mm512_storeu_ps(t, r);
    for (int i = 0; i < 4; i++) out[i] = t[4 * i];
}

/* bvh16_ray_intervals for a packet whose rays leave one point o: the
 * origin's intervals are that point, and the largest |org inv| on an axis
 * is |o| times the largest |inv| (rounding is monotone), so two
 * reductions of the inverse directions do. */
CPU_AVX512_FN void bvh16_one_origin(struct bvh16_ray *p, const float o[3]) {
    __m512 sign = _mm512_set1_ps(-0.0f);
    float lo[4], hi[4]; /* hi: minus the greatest */
    bvh16_reduce4(p->inv[0], p->inv[1], p->inv[2], _mm512_xor_ps(p->inv[0], sign), false, lo);
    bvh16_reduce4(_mm512_xor_ps(p->inv[1], sign), _mm512_xor_ps(p->inv[2], sign),
                  _mm512_xor_ps(p->inv[1], sign), _mm512_xor_ps(p->inv[2], sign), false, hi);
    float imax[3] = {-lo[3], -hi[0], -hi[1]};
    for (int k = 0; k < 3; k++) {
        p->cull.onear[k] = p->cull.ofar[k] = o[k];
        p->cull.imin[k] = lo[k], p->cull.imax[k] = imax[k];
        float most = fabsf(o[k]) * (fabsf(lo[k]) > fabsf(imax[k]) ? fabsf(lo[k]) : fabsf(imax[k]));
        p->cull.cslack[k] = most * 0x1p-20f + 0x1p-100f;
    }
    p->one_origin = true;
}

/* The culling test's intervals (bvh16_cull) of a uniform, fused packet:
 * its every org and inv finite.  The greatest of x is minus the least of
 * -x, exactly: the last four reductions share one pass that way. */
CPU_AVX512_FN void bvh16_ray_intervals(struct bvh16_ray *p) {
    float o[3];
    __mmask16 same = 0xffff;
    for (int k = 0; k < 3; k++) {
        o[k] = _mm512_cvtss_f32(p->org[k]);
        same &= _mm512_cmp_ps_mask(p->org[k], _mm512_set1_ps(o[k]), _CMP_EQ_OQ);
    }
    if (same == 0xffff) {
        bvh16_one_origin(p, o);
        return;
    }
    float lo[4], hi[4], rest[4];
    bvh16_reduce4(p->org[0], p->org[1], p->org[2], p->inv[0], false, lo);
    bvh16_reduce4(p->org[0], p->org[1], p->org[2], p->inv[0], true, hi);
    __m512 sign = _mm512_set1_ps(-0.0f);
    bvh16_reduce4(p->inv[1], p->inv[2], _mm512_xor_ps(p->inv[1], sign),
                  _mm512_xor_ps(p->inv[2], sign), false, rest);
    for (int k = 0; k < 3; k++) {
        bool neg = p->neg[k] != 0; /* uniform: every lane's sign */
        p->cull.onear[k] = neg ? lo[k] : hi[k], p->cull.ofar[k] = neg ? hi[k] : lo[k];
    }
    p->cull.imin[0] = lo[3], p->cull.imax[0] = hi[3];
    p->cull.imin[1] = rest[0], p->cull.imin[2] = rest[1];
    p->cull.imax[1] = -rest[2], p->cull.imax[2] = -rest[3];
    __m512 oi[3]; /* |org * inv|, at least, from the fused test's bounds of it */
    for (int k = 0; k < 3; k++)
        oi[k] = _mm512_max_ps(_mm512_abs_ps(p->oi_hi[k]), _mm512_abs_ps(p->oi_lo[k]));
    float most[4];
    bvh16_reduce4(oi[0], oi[1], oi[2], oi[2], true, most);
    for (int k = 0; k < 3; k++) p->cull.cslack[k] = most[k] * 0x1p-20f + 0x1p-100f;
    p->one_origin = false;
}

CPU_AVX512_FN void bvh16_ray_init(struct bvh16_ray *p, const struct ray16 *q, int width) {
    p->uniform = true;
    for (int k = 0; k < 3; k++) {
        __m512 c = join16(_mm512_cvtpd_ps(_mm512_loadu_pd(q->d[k])),
                          _mm512_cvtpd_ps(_mm512_loadu_pd(q->d[k] + 8)));
        __mmask16 tiny = _mm512_cmp_ps_mask(_mm512_abs_ps(c), _mm512_set1_ps(1e-30f), _CMP_LT_OQ);
        __m512i sign = _mm512_and_si512(_mm512_castps_si512(c), _mm512_set1_epi32(INT32_MIN));
        __m512 tiny_c =
            _mm512_castsi512_ps(_mm512_or_si512(sign, _mm512_castps_si512(_mm512_set1_ps(1e-30f))));
        c = _mm512_mask_blend_ps(tiny, c, tiny_c); /* copysignf(1e-30f, c) */
        p->inv[k] = _mm512_div_ps(_mm512_set1_ps(1.0f), c);
        p->org[k] = join16(_mm512_cvtpd_ps(_mm512_loadu_pd(q->o[k])),
                           _mm512_cvtpd_ps(_mm512_loadu_pd(q->o[k] + 8)));
        p->neg[k] = _mm512_cmp_ps_mask(c, _mm512_setzero_ps(), _CMP_LT_OQ);
        bool neg = p->neg[k] == 0xffff; /* every ray's direction negative on the axis */
        size_t lo = BVH_NODE_LO(width, k), hi = BVH_NODE_HI(width, k);
        p->near[k] = (uint8_t)(neg ? hi : lo);
        p->far[k] = (uint8_t)(neg ? lo : hi);
        p->uniform &= neg || p->neg[k] == 0;
    }
    bvh16_ray_fused(p);
    p->ia = p->uniform && p->fused; /* finite org * inv: finite org and inv */
    p->one_origin = false;
    if (p->ia) bvh16_ray_intervals(p);
}

/* Plane (k, c) of a node at nd, lower or upper. */
CPU_AVX512_INLINE float bvh16_plane(const char *nd, size_t row, int c) {
    float f;
    memcpy(&f, nd + row + sizeof(float) * (size_t)c, sizeof f);
    return f;
}

struct bvh16_entry {
    __m512 tnear; /* each ray's entry distance */
    uint32_t node;
    uint8_t count; /* as in bvh4_node: 0 inner node, else a leaf */
    __mmask16 lanes;
};

/* Child c of nd against the rays in lanes, for t in [0, tmax]: the mask of
 * rays that enter it and their entry distances.  The float operations of
 * bvh8_test_fused lane by lane (each plane one fused multiply-add) when
 * the packet has them (its tmax unscaled, as there), else those of
 * bvh4_test: either test is conservative, and neither decides a hit. */
CPU_AVX512_INLINE __mmask16 bvh16_child(const char *nd, int width, int c, const struct bvh16_ray *r,
                                        __m512 tmax, __mmask16 lanes, __m512 *tnear) {
    __m512 tn = _mm512_setzero_ps(), tf = tmax;
    const char *at = nd + sizeof(float) * (size_t)c;
    for (int k = 0; k < 3; k++) {
        __m512 near, far;
        if (r->uniform) { /* the common case: each axis one sign for the whole packet */
            float nv, fv; /* the floats at those byte offsets into the node */
            memcpy(&nv, at + r->near[k], sizeof nv);
            memcpy(&fv, at + r->far[k], sizeof fv);
            near = _mm512_set1_ps(nv), far = _mm512_set1_ps(fv);
        } else {
            __m512 lo = _mm512_set1_ps(bvh16_plane(nd, BVH_NODE_LO(width, k), c));
            __m512 hi = _mm512_set1_ps(bvh16_plane(nd, BVH_NODE_HI(width, k), c));
            near = _mm512_mask_blend_ps(r->neg[k], lo, hi);
            far = _mm512_mask_blend_ps(r->neg[k], hi, lo);
        }
        if (r->fused) {
            tn = _mm512_max_ps(tn, _mm512_fmsub_ps(near, r->inv[k], r->oi_hi[k]));
            tf = _mm512_min_ps(tf, _mm512_fmsub_ps(far, r->inv_far[k], r->oi_lo[k]));
        } else {
            tn = _mm512_max_ps(tn, _mm512_mul_ps(_mm512_sub_ps(near, r->org[k]), r->inv[k]));
            tf = _mm512_min_ps(tf, _mm512_mul_ps(_mm512_sub_ps(far, r->org[k]), r->inv[k]));
        }
    }
    if (!r->fused) tf = _mm512_mul_ps(tf, _mm512_set1_ps(BVH_FAR_SCALE)); /* fused: in inv_far */
    *tnear = tn;
    return _mm512_mask_cmp_ps_mask(lanes, tn, tf, _CMP_LE_OQ);
}

/* The greatest of the reaches tmax of the rays in lanes, infinity when one
 * is NaN: bvh_cull_boxes's far_most. */
CPU_AVX512_INLINE float bvh16_far_most(__m512 tmax, __mmask16 lanes) {
    __mmask16 nan = _mm512_mask_cmp_ps_mask(lanes, tmax, tmax, _CMP_UNORD_Q);
    return nan ? INFINITY : _mm512_mask_reduce_max_ps(lanes, tmax);
}

/* The same of the bounds tm, each reaching tm times BVH_SLACK. */
CPU_AVX512_INLINE float bvh16_reach_most(__m512 tm, __mmask16 lanes) {
    return bvh16_far_most(_mm512_mul_ps(tm, _mm512_set1_ps(BVH_SLACK)), lanes);
}

/* After a leaf or lone walk that blocked the rays got and may have
 * lowered the bounds from before to tm: the rays still walking in *lanes
 * and blocked in *blocked, and, where the walk culls, far_most renewed
 * when something changed.  True when no ray is left. */
CPU_AVX512_INLINE bool bvh16_after_leaf(__mmask16 got, __m512 before, __m512 tm, bool culled,
                                        __mmask16 *lanes, __mmask16 *blocked, float *far_most) {
    *blocked |= got, *lanes &= (__mmask16)~got;
    if (!*lanes) return true;
    if (culled && (got || _mm512_cmp_ps_mask(before, tm, _CMP_NEQ_UQ)))
        *far_most = bvh16_reach_most(tm, *lanes);
    return false;
}

/* bvh_cull_boxes (bvh.h) on the eight children of node nd, for rays whose
 * reach is at most far_most. */
CPU_AVX512_INLINE __mmask8 bvh16_cull(const char *nd, const struct bvh16_ray *r, float far_most,
                                      __m256 *tnear) {
    __m256 near[3], far[3];
    for (int k = 0; k < 3; k++) {
        near[k] = _mm256_loadu_ps((const float *)(const void *)(nd + r->near[k]));
        far[k] = _mm256_loadu_ps((const float *)(const void *)(nd + r->far[k]));
    }
    return (__mmask8)bvh_cull_boxes(&r->cull, near, far, far_most, tnear);
}

/* The leaf test: rays in lanes against leaf (first, count), far_most at
 * least the greatest of their reaches (bvh16_reach_most) for a culling
 * test.  A nearest-hit leaf lowers the rays' bounds in *tm and returns 0;
 * an any-hit leaf returns the rays it found blocked, which then leave the
 * walk. */
typedef __mmask16 (*bvh16_leaf_fn)(void *ctx, uint32_t first, uint32_t count, __mmask16 lanes,
                                   __m512 *tm, float far_most);

/* Pushes the children of inner node cur that rays in lanes enter (bounds
 * tm, their reach at most far_most) onto the stack, and pops the nearest
 * into *cur when ordered (else the last: an any-hit walk needs no order),
 * prefetching each (see bvh16_walk for leaves).  False when no ray enters
 * any child. */
CPU_AVX512_INLINE bool bvh16_descend(const char *nodes, int width, const char *leaves,
                                     size_t leaf_size, const struct bvh16_ray *r, __m512 tm,
                                     float far_most, struct bvh16_entry *cur,
                                     struct bvh16_entry *stack, int *sp, bool ordered) {
    size_t node_size = BVH_NODE_SIZE(width);
    const char *nd = nodes + node_size * cur->node;
    uint32_t child[8];
    uint8_t count[8];
    memcpy(child, nd + BVH_NODE_CHILD(width), sizeof *child * (size_t)width);
    memcpy(count, nd + BVH_NODE_COUNT(width), (size_t)width);
    __m512 tmax = _mm512_mul_ps(tm, _mm512_set1_ps(BVH_SLACK));
    int hit[8], n = 0;
    __m512 tn[8];
    __mmask16 m[8];
    float key[8];
    if (width == 8 && r->one_origin) { /* coherent: the interval test alone */
        __m256 box_tn;
        unsigned maybe = bvh16_cull(nd, r, far_most, &box_tn);
        _mm256_storeu_ps(key, box_tn);
        for (int c = 0; c < width; c++) {
            if (!(maybe >> c & 1)) continue;
            if (bvh16_plane(nd, BVH_NODE_LO(width, 0), c) >
                bvh16_plane(nd, BVH_NODE_HI(width, 0), c))
                continue; /* an empty slot */
            m[c] = cur->lanes, tn[c] = _mm512_set1_ps(key[c]);
            hit[n++] = c;
        }
    } else {
        unsigned maybe = 0xffu;
        if (width == 8 && r->ia) {
            __m256 box_tn;
            maybe = bvh16_cull(nd, r, far_most, &box_tn);
        }
        for (int c = 0; c < width; c++) {
            if (!(maybe >> c & 1)) continue; /* no ray of the packet enters it */
            if (bvh16_plane(nd, BVH_NODE_LO(width, 0), c) >
                bvh16_plane(nd, BVH_NODE_HI(width, 0), c))
                continue; /* an empty slot */
            m[c] = bvh16_child(nd, width, c, r, tmax, cur->lanes, &tn[c]);
            if (!m[c]) continue;
            /* the first ray's entry: cheaper than the packet's nearest */
            key[c] = _mm512_cvtss_f32(_mm512_maskz_compress_ps(m[c], tn[c]));
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
        /* start loading what comes next: an inner node, or a leaf's data */
        const char *next = !count[c] ? nodes + node_size * child[c]
                           : leaves  ? leaves + leaf_size * child[c]
                                     : NULL;
        size_t size = count[c] ? leaf_size * (size_t)((count[c] + 3) / 4) : node_size;
        for (size_t at = 0; next && at < size; at += 64) _mm_prefetch(next + at, _MM_HINT_T0);
        struct bvh16_entry *e = j == n - 1 ? cur : &stack[(*sp)++];
        if (e != cur) e->tnear = tn[c]; /* the walk goes into cur now */
        e->node = child[c];
        e->count = count[c];
        e->lanes = m[c];
    }
    return true;
}

/* Leaf entries met in one walk between two looks at the render's meter
 * (meter_live), as the one-ray walks of the scene look (objects_walk in
 * scene/scene_query.c): thousands of triangles or instances overlapping
 * where the packet goes cost no rays, and nothing else would stop them. */
#define BVH16_LOOK_VISITS 4096

/* When at most this many rays of a packet still need an entry, the walk
 * hands them to lone (when given) to go on one by one, as Embree's hybrid
 * walk does: a node test costs the same for 1 lane as for 16, and the few
 * rays left deep in a tree mostly part ways.  2 measured best for bounce
 * packets, with no loss on coherent ones (bench/README.md).  Their walks
 * are not counted in the visits below: each costs what the ray would cast
 * alone, which every one-ray walk of a mesh costs unmetered. */
#define BVH16_LONE_MAX 2

/* Walks the tree with the rays in lanes; *tm holds their bounds (lowered
 * by a nearest-hit leaf), and ordered asks for the nearest child first (a
 * nearest-hit walk; an any-hit one can do without).  Returns the rays an
 * any-hit leaf blocked.  lone, NULL or a function with the leaf's
 * contract, takes an entry (inner node or leaf) that at most
 * BVH16_LONE_MAX rays still need, and walks it ray by ray.  A stopped
 * meter ends the walk with what it found so far (the render is thrown
 * away).
 * leaves (records of leaf_size bytes of up to four primitives each, a
 * leaf's first index into them) is only prefetched from; NULL when the
 * leaves are not such an array. */
CPU_AVX512_INLINE __mmask16 bvh16_walk(const void *nodes, int width, const char *leaves,
                                       size_t leaf_size, const struct bvh16_ray *r, __m512 *tm,
                                       __mmask16 lanes, bvh16_leaf_fn leaf, bvh16_leaf_fn lone,
                                       void *ctx, bool ordered) {
    struct bvh16_entry stack[BVH8_STACK], cur;
    int sp = 0;
    uint32_t visits = 0;
    __mmask16 blocked = 0;
    /* the culling test's bound: of every ray still in the walk, a bound
     * on the bounds of the rays of any entry, kept as leaves lower them */
    bool culled = width == 8 && r->ia;
    float far_most = culled ? bvh16_reach_most(*tm, lanes) : INFINITY;
    cur.node = 0;
    cur.count = 0;
    cur.lanes = lanes;
    for (;;) {
        if (lone && __builtin_popcount(cur.lanes) <= BVH16_LONE_MAX) {
            __m512 before = *tm;
            __mmask16 got = lone(ctx, cur.node, cur.count, cur.lanes, tm, far_most);
            if (bvh16_after_leaf(got, before, *tm, culled, &lanes, &blocked, &far_most))
                return blocked;
        } else if (cur.count == 0) {
            if (bvh16_descend(nodes, width, leaves, leaf_size, r, *tm, far_most, &cur, stack, &sp,
                              ordered))
                continue;
        } else {
            visits += cur.count;
            if (visits >= BVH16_LOOK_VISITS) { /* overlaps: look at the meter */
                visits = 0;
                if (!meter_live()) return blocked;
            }
            __m512 before = *tm;
            __mmask16 got = leaf(ctx, cur.node, cur.count, cur.lanes, tm, far_most);
            if (bvh16_after_leaf(got, before, *tm, culled, &lanes, &blocked, &far_most))
                return blocked;
        }
        for (;;) { /* pop an entry some ray still needs (its fields, not a copy of it) */
            if (sp == 0) return blocked;
            const struct bvh16_entry *e = &stack[--sp];
            __m512 reach = _mm512_mul_ps(*tm, _mm512_set1_ps(BVH_SLACK));
            /* !(tnear > reach), as the one-ray walk has it (NaN included) */
            __mmask16 in = _mm512_mask_cmp_ps_mask(e->lanes & lanes, e->tnear, reach, _CMP_NGT_UQ);
            if (!in) continue;
            cur.node = e->node, cur.count = e->count, cur.lanes = in;
            break;
        }
    }
}

#endif /* CPU_AVX512 */
#endif
