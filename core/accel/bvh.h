/* bvh.h -- wide bounding volume hierarchies over boxes.
 *
 * One builder serves both levels of the scene: the top level over objects
 * (4-wide nodes, struct bvh4) and the bottom level over a mesh's triangles
 * (8-wide nodes, struct bvh8: half the levels for the many rays a mesh
 * takes, as Embree has it, with one 8-lane test a node where the CPU has
 * AVX-512).  It sees only boxes; the caller reorders its primitives by the
 * returned order so that every leaf is a contiguous range, and writes its
 * own traversal loop around the inline node tests below (the leaf test is
 * where the levels differ).
 */
#ifndef BVH_H
#define BVH_H

#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include "rayd/rayd.h"
#include "base/cpu.h"
#include "math/vec.h"

#if defined(__SSE2__) && !defined(RAYD_NO_SIMD)
#include <emmintrin.h>
#define BVH_SSE 1
#endif

/* A box in floats, as the BVH's nodes keep them: rounded outward from an
 * object's struct aabb (math/vec.h), half the memory for the walk. */
struct bbox {
    float lo[3], hi[3];
};

/* Four child boxes side by side (structure of arrays) so one SIMD
 * instruction tests a ray against all four.  count[i] > 0: child i is a
 * leaf of count[i] primitives from index child[i]; count[i] == 0: child i
 * is the inner node child[i]; an empty slot has an inverted box. */
struct bvh4_node {
    float lo[3][4];
    float hi[3][4];
    uint32_t child[4];
    uint8_t count[4];
    uint8_t pad[12];
};

struct bvh4 {
    struct bvh4_node *nodes; /* nodes[0] is the root */
    uint32_t nnodes;
    struct bbox bounds;
};

/* The same layout eight children wide, for meshes (a leaf's count up to
 * BVH8_LEAF_MAX): a node of W children
 * is lo[3][W], hi[3][W], child[W], count[W], padded to 32 W bytes, so one
 * writer (bvh_collapse.c) and one packet walk (bvh16.h) serve both.  Byte
 * offsets in such a node: axis k's lower and upper planes, the child
 * indices and the counts (bvh_collapse.c asserts them for both structs). */
struct bvh8_node {
    float lo[3][8];
    float hi[3][8];
    uint32_t child[8];
    uint8_t count[8];
    uint8_t pad[24];
};

struct bvh8 {
    struct bvh8_node *nodes; /* nodes[0] is the root */
    uint32_t nnodes;
    struct bbox bounds;
};

#define BVH_NODE_SIZE(w) ((size_t)(32 * (w)))
#define BVH_NODE_LO(w, k) ((size_t)(4 * (w) * (k)))
#define BVH_NODE_HI(w, k) ((size_t)(4 * (w) * (3 + (k))))
#define BVH_NODE_CHILD(w) ((size_t)(24 * (w)))
#define BVH_NODE_COUNT(w) ((size_t)(28 * (w)))

#define BVH_MAX_LEAF 4
/* A leaf of an 8-wide node holds up to this many primitives: the builder's
 * leaves hold at most BVH_MAX_LEAF, but its small subtrees become one leaf
 * (bvh_collapse.h), which a mesh stores as two blocks of four. */
#define BVH8_LEAF_MAX 8
/* Traversal stack entries: a wide level pushes at most width - 1, and the
 * binary tree is at most 48 + 32 levels deep (bvh.c): 3 x 80 for 4-wide
 * nodes, 7 x 80 for 8-wide ones. */
#define BVH_STACK 256
#define BVH8_STACK 576

/* Traversal visits a box while its entry distance is within this factor of
 * the best hit so far: the box and primitive tests round differently, and
 * a box holding a hit exactly as near as the best must still be visited so
 * that ties are settled by rule, not by visiting order. */
#define BVH_SLACK 1.000004f

/* Child i of node n in an array of width-wide nodes (4: struct bvh4_node,
 * 8: struct bvh8_node), read through the layout both share: its box, its
 * child index and its count (0: an inner node). */
static inline void bvh_node_child(const void *nodes, int width, uint32_t n, int i, struct bbox *box,
                                  uint32_t *child, uint8_t *count) {
    const char *nd = (const char *)nodes + BVH_NODE_SIZE(width) * n;
    size_t at = sizeof(float) * (size_t)i;
    for (int k = 0; k < 3; k++) {
        memcpy(&box->lo[k], nd + BVH_NODE_LO(width, k) + at, sizeof(float));
        memcpy(&box->hi[k], nd + BVH_NODE_HI(width, k) + at, sizeof(float));
    }
    memcpy(child, nd + BVH_NODE_CHILD(width) + sizeof(uint32_t) * (size_t)i, sizeof *child);
    *count = (uint8_t)nd[BVH_NODE_COUNT(width) + (size_t)i];
}

/* Builds the hierarchy over n boxes, leaves of at most max_leaf (1 to
 * BVH_MAX_LEAF) of them.  order[0..n) receives the primitive order the
 * leaves refer to.  threads > 1 builds the top subtrees in
 * parallel (worth it from ~100k primitives).  n == 0 gives an empty tree. */
enum rayd_status bvh_build(struct bvh4 *bvh, const struct bbox *boxes, uint32_t n,
                           uint32_t max_leaf, uint32_t *order, int threads, struct rayd_error *err);

/* Writes the boxes of primitives [first, first + n) to out (n is at most
 * a few hundred); called from several threads at once. */
typedef void (*bvh_boxes_fn)(const void *ctx, uint32_t first, uint32_t n, struct bbox *out);

/* The bvh_boxes_fn of an array of boxes (ctx: const struct bbox *). */
void bvh_boxes_copy(const void *ctx, uint32_t first, uint32_t n, struct bbox *out);

void bvh_free(struct bvh4 *bvh);

/* bvh_build with 8-wide nodes (a mesh's), and the boxes made on the way in
 * by fn, straight into the builder's records: no array of boxes for the
 * caller to fill first. */
enum rayd_status bvh8_build_from(struct bvh8 *bvh, bvh_boxes_fn fn, const void *ctx, uint32_t n,
                                 uint32_t max_leaf, uint32_t *order, int threads,
                                 struct rayd_error *err);
void bvh8_free(struct bvh8 *bvh);

/* A box that surely contains the double-precision box [lo, hi]. */
struct bbox bbox_from(vec3 lo, vec3 hi);

/* The per-ray data the node test needs, in float. */
struct bvh_ray {
    /* x, y, z and a fourth lane that only the SSE set-up writes: its
     * whole-register stores are ones the walk's loads can forward from */
    float org[4];
    float inv[4]; /* 1 / direction, with zero components nudged to tiny */
    /* For the fused test of 8-wide nodes (bvh8_test_fused): org * inv
     * bounded above for the near planes, the far planes' constants (both
     * from bvh_ray_fused), the byte offsets in a node of each axis's near
     * and far planes, and whether every org * inv is finite. */
    float oi_hi[4], oi_lo[4];
    float inv_far[4];
    int neg[3]; /* direction component < 0: swap near and far planes */
    uint32_t near8[3], far8[3];
    bool fused;
};

/* The near and far plane offsets of bvh_ray_fused from neg. */
static inline void bvh_ray_planes(struct bvh_ray *br) {
    for (int k = 0; k < 3; k++) {
        br->near8[k] = (uint32_t)(br->neg[k] ? BVH_NODE_HI(8, k) : BVH_NODE_LO(8, k));
        br->far8[k] = (uint32_t)(br->neg[k] ? BVH_NODE_LO(8, k) : BVH_NODE_HI(8, k));
    }
}

/* The fused test's fields from org, inv and neg.  The product org * inv
 * is rounded to nearest, so it is within |p| 2^-23 of the float p; p moved
 * up by |p| 2^-22 (and a tiny bit for underflow) is surely above it.  A
 * near plane's t = plane * inv - oi_hi, one fused multiply-add, is then at
 * most its exact value: no entry comes out late.
 *
 * The far distances must come out at least their exact values along the
 * ray's own direction, which inv is rounded from (each axis its own way),
 * scaled by BVH_FAR_SCALE as the unfused test scales its own.  That scale
 * is folded into the far planes' constants instead of multiplying every
 * node's distances on the walk's chain (bench/README.md, "The far planes'
 * scale in the ray's constants": rays up to 5% faster): inv_far is
 * inv (1 + 2^-20), rounded once, and oi_lo is p moved down by twice the
 * slack and scaled by 1 + 2^-20, rounded twice, so that far * inv_far -
 * oi_lo is (1 + a)(far * inv - (p - 2 slack)) + (a - b)(p - 2 slack), with
 * a and b within 2^-23 of 2^-20: the first term's factor more than the
 * roundings from the ray's direction to the distance ask, the second less
 * than the extra slack.  test_node_tests checks every test against the
 * ray's own direction (with the scale left out it finds boxes missed).
 * The packets' bvh16_ray_fused and rays8_init make the same constants. */
#define BVH_FUSED_REL 0x1p-22f  /* the slack per unit of |p| */
#define BVH_FUSED_ABS 0x1p-120f /* ... and for underflow */
#define BVH_FUSED_MAX 1e37f     /* |p| from which the unfused test is taken */
/* The far distances' scale, 1 + 16 u (u = 2^-24), in both tests: more
 * than the roundings between the ray's double direction and a far
 * distance (four in the unfused test: the direction to float, 1 / d, the
 * difference, the product) and the scale's own. */
#define BVH_FAR_SCALE (1.0f + 0x1p-20f)
static inline void bvh_ray_fused(struct bvh_ray *br) {
    br->fused = true;
    for (int k = 0; k < 3; k++) {
        float p = br->org[k] * br->inv[k], slack = fabsf(p) * BVH_FUSED_REL + BVH_FUSED_ABS;
        br->oi_hi[k] = p + slack;
        br->oi_lo[k] = (p - 2 * slack) * BVH_FAR_SCALE;
        br->inv_far[k] = br->inv[k] * BVH_FAR_SCALE;
        br->fused &= fabsf(p) < BVH_FUSED_MAX;
    }
    bvh_ray_planes(br);
}

/* The ray's fields for the tests of bvh_test_rows (bvh_ray_fused adds
 * the fused test's), one axis at a time: the top level's walks' set-up
 * (bvh_ray_init_with is the mesh walk's, measured there). */
static inline void bvh_ray_init(struct bvh_ray *br, vec3 o, vec3 d) {
    double dd[3] = {d.x, d.y, d.z}, oo[3] = {o.x, o.y, o.z};
    for (int k = 0; k < 3; k++) {
        float c = (float)dd[k]; /* in float: 16 rays of a packet divide at once */
        c = fabsf(c) < 1e-30f ? copysignf(1e-30f, c) : c;
        br->org[k] = (float)oo[k];
        br->inv[k] = 1.0f / c;
        br->neg[k] = c < 0;
    }
    br->fused = false; /* bvh_ray_fused, where the fused test runs */
}

#ifdef BVH_SSE
/* The ray's three components in one register, in float (lane 3: pad).
 * Each double is read on its own: a ray just written component by
 * component cannot be forwarded to a 16-byte load, which would wait for
 * the stores to reach the cache. */
static inline __m128 bvh_float3(const vec3 *v, float pad) {
    return _mm_set_ps(pad, (float)v->z, (float)v->y, (float)v->x);
}
#endif

/* bvh_ray_init, then with fused bvh_ray_fused, for a mesh's one-ray walk.
 * The SSE code gives the same bits (the same correctly rounded
 * operations, lane by lane) in a few instructions and one division
 * instead of three: every ray pays this set-up, and a ray that misses
 * the mesh little else. */
static inline void bvh_ray_init_with(struct bvh_ray *br, const vec3 *o, const vec3 *d, bool fused) {
#ifdef BVH_SSE
    __m128 sign = _mm_set1_ps(-0.0f), tiny = _mm_set1_ps(1e-30f);
    __m128 org = bvh_float3(o, 0), c = bvh_float3(d, 1);
    __m128 small = _mm_cmplt_ps(_mm_andnot_ps(sign, c), tiny);
    c = _mm_or_ps(_mm_andnot_ps(small, c), _mm_and_ps(small, _mm_or_ps(_mm_and_ps(c, sign), tiny)));
    __m128 inv = _mm_div_ps(_mm_set1_ps(1.0f), c);
    _mm_storeu_ps(br->org, org);
    _mm_storeu_ps(br->inv, inv);
    int neg = _mm_movemask_ps(_mm_cmplt_ps(c, _mm_setzero_ps()));
    for (int k = 0; k < 3; k++) br->neg[k] = neg >> k & 1;
    br->fused = false;
    if (!fused) return;
    __m128 p = _mm_mul_ps(org, inv), a = _mm_andnot_ps(sign, p);
    __m128 slack =
        _mm_add_ps(_mm_mul_ps(a, _mm_set1_ps(BVH_FUSED_REL)), _mm_set1_ps(BVH_FUSED_ABS));
    _mm_storeu_ps(br->oi_hi, _mm_add_ps(p, slack));
    __m128 scale = _mm_set1_ps(BVH_FAR_SCALE);
    _mm_storeu_ps(br->oi_lo, _mm_mul_ps(_mm_sub_ps(p, _mm_add_ps(slack, slack)), scale));
    _mm_storeu_ps(br->inv_far, _mm_mul_ps(inv, scale));
    br->fused = (_mm_movemask_ps(_mm_cmplt_ps(a, _mm_set1_ps(BVH_FUSED_MAX))) & 7) == 7;
    bvh_ray_planes(br);
#else
    bvh_ray_init(br, *o, *d);
    if (fused) bvh_ray_fused(br);
#endif
}

/* Tests the ray against four boxes for t in [tmin, tmax]: lo and hi point
 * at the first box's x planes, axis k's planes w floats further each (the
 * node layouts of both widths); returns a bit mask of the boxes hit and
 * their entry distances.  The far distance is scaled by BVH_FAR_SCALE so
 * that float rounding can never make a box that the ray touches look
 * missed (Ize 2013, with the direction's own rounding to float). */
static inline int bvh_test_rows(const float *lo_row, const float *hi_row, int w,
                                const struct bvh_ray *r, float tmin, float tmax, float tnear[4]) {
#ifdef BVH_SSE
    __m128 tn = _mm_set1_ps(tmin), tf = _mm_set1_ps(tmax);
    for (int k = 0; k < 3; k++) {
        __m128 o = _mm_set1_ps(r->org[k]), inv = _mm_set1_ps(r->inv[k]);
        const float *l = lo_row + k * w, *h = hi_row + k * w;
        __m128 lo = _mm_loadu_ps(r->neg[k] ? h : l);
        __m128 hi = _mm_loadu_ps(r->neg[k] ? l : h);
        tn = _mm_max_ps(tn, _mm_mul_ps(_mm_sub_ps(lo, o), inv));
        tf = _mm_min_ps(tf, _mm_mul_ps(_mm_sub_ps(hi, o), inv));
    }
    tf = _mm_mul_ps(tf, _mm_set1_ps(BVH_FAR_SCALE));
    _mm_storeu_ps(tnear, tn);
    return _mm_movemask_ps(_mm_cmple_ps(tn, tf));
#else
    int mask = 0;
    for (int i = 0; i < 4; i++) {
        float tn = tmin, tf = tmax;
        for (int k = 0; k < 3; k++) {
            float l = lo_row[k * w + i], h = hi_row[k * w + i];
            float lo = r->neg[k] ? h : l, hi = r->neg[k] ? l : h;
            float a = (lo - r->org[k]) * r->inv[k], b = (hi - r->org[k]) * r->inv[k];
            tn = tn > a ? tn : a; /* exactly _mm_max_ps(tn, a) and _mm_min_ps(tf, b) */
            tf = tf < b ? tf : b;
        }
        tf *= BVH_FAR_SCALE;
        tnear[i] = tn;
        mask |= (tn <= tf) << i;
    }
    return mask;
#endif
}

/* The four children of nd. */
static inline int bvh4_test(const struct bvh4_node *nd, const struct bvh_ray *r, float tmin,
                            float tmax, float tnear[4]) {
    return bvh_test_rows(nd->lo[0], nd->hi[0], 4, r, tmin, tmax, tnear);
}

/* A test of the eight children of a node (bvh8_test, or where the CPU
 * has it bvh8_test_fused), as the one-ray walks take it. */
typedef int (*bvh8_test_fn)(const struct bvh8_node *nd, const struct bvh_ray *r, float tmin,
                            float tmax, float tnear[8]);

/* The eight children of nd, four at a time. */
static inline int bvh8_test(const struct bvh8_node *nd, const struct bvh_ray *r, float tmin,
                            float tmax, float tnear[8]) {
    int lo = bvh_test_rows(nd->lo[0], nd->hi[0], 8, r, tmin, tmax, tnear);
    int hi = bvh_test_rows(nd->lo[0] + 4, nd->hi[0] + 4, 8, r, tmin, tmax, tnear + 4);
    return lo | hi << 4;
}

#ifdef CPU_AVX512
/* bvh8_test in one 8-lane register, each plane's distance one fused
 * multiply-add (bvh_ray_fused): fewer operations and a shorter chain from
 * a node's load to the next, as Embree does it, but other bits, so the
 * entry distances differ from bvh8_test's.  Neither test decides a hit
 * (the triangles do, by an order-free rule), so both walks find the same.
 * Unlike bvh8_test's, its tmax is not scaled: an entry may come out a few
 * u (2^-24) past its exact value, so a box entered right at tmax can be
 * missed; the walks pass their bound times BVH_SLACK, far more than that.
 * AVX2 and FMA suffice; the AVX-512 walks inline it too. */
CPU_AVX2_INLINE int bvh8_test_fused(const struct bvh8_node *nd, const struct bvh_ray *r, float tmin,
                                    float tmax, float tnear[8]) {
    if (!r->fused) return bvh8_test(nd, r, tmin, tmax, tnear);
    __m256 tn = _mm256_set1_ps(tmin), tf = _mm256_set1_ps(tmax);
    const char *at = (const char *)nd;
    for (int k = 0; k < 3; k++) {
        __m256 inv = _mm256_set1_ps(r->inv[k]), inv_far = _mm256_set1_ps(r->inv_far[k]);
        __m256 near = _mm256_loadu_ps((const float *)(const void *)(at + r->near8[k]));
        __m256 far = _mm256_loadu_ps((const float *)(const void *)(at + r->far8[k]));
        tn = _mm256_max_ps(tn, _mm256_fmsub_ps(near, inv, _mm256_set1_ps(r->oi_hi[k])));
        tf = _mm256_min_ps(tf, _mm256_fmsub_ps(far, inv_far, _mm256_set1_ps(r->oi_lo[k])));
    }
    _mm256_storeu_ps(tnear, tn);
    return _mm256_movemask_ps(_mm256_cmp_ps(tn, tf, _CMP_LE_OS));
}
/* A packet's origins and inverse directions as intervals, for the packet
 * walks' culling test (bvh16.h, bvh_rays8.h): set where each axis's sign
 * is one for the packet and every org and inv is finite. */
struct bvh_cull {
    float onear[3], ofar[3], imin[3], imax[3];
    float cslack[3]; /* the test's widening on each axis */
};

/* Which of eight boxes (an 8-wide node's children, or the bounding boxes
 * of a leaf's triangles) some ray of a packet may enter before far_most,
 * the greatest of its rays' bounds: interval arithmetic over the packet's origins and inverse
 * directions (Boulos et al. 2006), all eight boxes at once.
 * Conservative: each ray's unfused test (bvh4_test's operations) does the
 * same float operations on values inside these intervals, and rounding is
 * monotone, so a box culled here is one every ray's unfused test misses,
 * and so one it truly misses.  A NaN keeps the box.
 * The signs are uniform (a packet's ia), so (plane - org) * inv is monotone in org:
 * its least value over the packet is at the origin bound onear (the
 * greatest origin on an axis the rays go up, the least on one they go
 * down), its greatest at ofar; and for that one difference x the product
 * is least (greatest) at one end of [imin, imax], whichever x's sign says.
 * Half the operations of the product of two intervals.  The boxes come as
 * their near and far planes on each axis (near[k]: the lower planes where
 * the rays go up the axis, the upper ones where they go down).
 * But the walk's own test of each ray is the fused one (bvh_ray_fused),
 * which moves org * inv out by up to |org inv| 2^-21 (far planes) and
 * scales the far distances by BVH_FAR_SCALE: a
 * box it enters can lie a hair outside what the unfused operations bound,
 * as where a ray meets a box exactly at its corner (a vertex of flat
 * triangles).  So each axis's bounds move out by cslack, 2^-20 of the
 * packet's largest |org inv|, and the far one is scaled by 1.000002: more
 * than the two tests can differ by, and still a tight cull. */
CPU_AVX2_INLINE unsigned bvh_cull_boxes(const struct bvh_cull *c, const __m256 near[3],
                                        const __m256 far[3], float far_most, __m256 *tnear) {
    __m256 tn = _mm256_setzero_ps(), tf = _mm256_set1_ps(far_most);
    for (int k = 0; k < 3; k++) {
        __m256 ilo = _mm256_set1_ps(c->imin[k]), ihi = _mm256_set1_ps(c->imax[k]);
        __m256 a = _mm256_sub_ps(near[k], _mm256_set1_ps(c->onear[k]));
        __m256 b = _mm256_sub_ps(far[k], _mm256_set1_ps(c->ofar[k]));
        __m256 lower = _mm256_min_ps(_mm256_mul_ps(a, ilo), _mm256_mul_ps(a, ihi));
        __m256 upper = _mm256_max_ps(_mm256_mul_ps(b, ilo), _mm256_mul_ps(b, ihi));
        __m256 slack = _mm256_set1_ps(c->cslack[k]);
        tn = _mm256_max_ps(tn, _mm256_sub_ps(lower, slack));
        tf = _mm256_min_ps(tf, _mm256_add_ps(upper, slack));
    }
    tf = _mm256_mul_ps(tf, _mm256_set1_ps(1.000002f));
    *tnear = tn; /* each box's lower bound on its rays' entries */
    return (unsigned)_mm256_movemask_ps(_mm256_cmp_ps(tn, tf, _CMP_NGT_UQ));
}
#endif

/* A traversal stack entry: a node to visit and where the ray enters it. */
struct bvh_entry {
    uint32_t node;
    uint8_t count; /* as in bvh4_node: 0 inner node, else a leaf */
    float tnear;
};

/* The order a walk takes the children a ray enters. */
enum bvh_order {
    BVH_AS_COME, /* any-hit walks, whose answer no order changes: the first
                  * child, the others pushed as they come */
    BVH_NEAREST, /* the nearest, the others as they come: a mesh's walk,
                  * whose leaves cost less than sorting would save */
    BVH_SORTED   /* all by distance: the scene's walk over objects, each of
                  * which costs more to test than sorting */
};

/* Pushes the children in mask (child and count arrays of a node) onto
 * stack, farthest first, so the nearest is visited next.  Returns the new
 * stack size.  Insertion into the stack itself: most masks have one or
 * two bits. */
static inline int bvh_push_sorted(const uint32_t *child, const uint8_t *count, int mask,
                                  const float *tnear, struct bvh_entry *stack, int sp) {
    int base = sp;
    while (mask) {
        int i = __builtin_ctz((unsigned)mask);
        mask &= mask - 1;
        float t = tnear[i];
        int j = sp++;
        while (j > base && stack[j - 1].tnear < t) { /* keep descending order */
            stack[j] = stack[j - 1];
            j--;
        }
        stack[j].node = child[i];
        stack[j].count = count[i];
        stack[j].tnear = t;
    }
    return sp;
}

/* The step down of both widths, given the node's test: see bvh4_descend. */
static inline bool bvh_descend_mask(const uint32_t *child, const uint8_t *count, int mask,
                                    const float *tn, struct bvh_entry *e, struct bvh_entry *stack,
                                    int *sp, enum bvh_order order) {
    if (!mask) return false;
    if (order == BVH_SORTED && (mask & (mask - 1))) {
        *sp = bvh_push_sorted(child, count, mask, tn, stack, *sp);
        *e = stack[--*sp];
        return true;
    }
    int go = __builtin_ctz((unsigned)mask);
    for (int m = mask & (mask - 1); order == BVH_NEAREST && m; m &= m - 1) {
        int c = __builtin_ctz((unsigned)m);
        go = tn[c] < tn[go] ? c : go;
    }
    *e = (struct bvh_entry){child[go], count[go], tn[go]};
    for (int m = mask & ~(1 << go); m; m &= m - 1) {
        int c = __builtin_ctz((unsigned)m);
        stack[(*sp)++] = (struct bvh_entry){child[c], count[c], tn[c]};
    }
    return true;
}

/* One step down from inner node *e: tests its children, makes *e the one
 * to go into first as order has it and pushes the others.  A popped entry
 * beyond the best hit so far is dropped whatever the order, so every
 * order gives the same answer; in a mesh the nearest child taken first and
 * the rest unsorted make walks 2-7% faster than sorting them
 * (bench/README.md).  False when no child is hit (the caller pops the
 * next entry).  A single hit child -- the common case -- never touches
 * the stack. */
static inline bool bvh4_descend(const struct bvh4_node *nodes, struct bvh_entry *e,
                                const struct bvh_ray *br, float tmax, struct bvh_entry *stack,
                                int *sp, enum bvh_order order) {
    const struct bvh4_node *nd = &nodes[e->node];
    float tn[4];
    int mask = bvh4_test(nd, br, 0, tmax, tn);
    return bvh_descend_mask(nd->child, nd->count, mask, tn, e, stack, sp, order);
}

#endif
