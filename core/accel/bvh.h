/* bvh.h -- a 4-wide bounding volume hierarchy over boxes.
 *
 * One builder serves both levels of the scene: the top level over objects
 * and the bottom level over a mesh's triangles.  It sees only boxes; the
 * caller reorders its primitives by the returned order so that every leaf
 * is a contiguous range, and writes its own traversal loop around the
 * inline node test below (the leaf test is where the levels differ).
 */
#ifndef BVH_H
#define BVH_H

#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include "rayd/rayd.h"
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

#define BVH_MAX_LEAF 4
#define BVH_STACK 256

/* Traversal visits a box while its entry distance is within this factor of
 * the best hit so far: the box and primitive tests round differently, and
 * a box holding a hit exactly as near as the best must still be visited so
 * that ties are settled by rule, not by visiting order. */
#define BVH_SLACK 1.000004f

/* Builds the hierarchy over n boxes, leaves of at most max_leaf (1 to
 * BVH_MAX_LEAF) of them.  order[0..n) receives the primitive order the
 * leaves refer to.  threads > 1 builds the top subtrees in
 * parallel (worth it from ~100k primitives).  n == 0 gives an empty tree. */
enum rayd_status bvh_build(struct bvh4 *bvh, const struct bbox *boxes, uint32_t n,
                           uint32_t max_leaf, uint32_t *order, int threads, struct rayd_error *err);

/* Writes the boxes of primitives [first, first + n) to out (n is at most
 * a few hundred); called from several threads at once. */
typedef void (*bvh_boxes_fn)(const void *ctx, uint32_t first, uint32_t n, struct bbox *out);

/* bvh_build with the boxes made on the way in by fn, straight into the
 * builder's records: no array of boxes for the caller to fill first. */
enum rayd_status bvh_build_from(struct bvh4 *bvh, bvh_boxes_fn fn, const void *ctx, uint32_t n,
                                uint32_t max_leaf, uint32_t *order, int threads,
                                struct rayd_error *err);
void bvh_free(struct bvh4 *bvh);

/* A box that surely contains the double-precision box [lo, hi]. */
struct bbox bbox_from(vec3 lo, vec3 hi);

/* The per-ray data the node test needs, in float. */
struct bvh_ray {
    float org[3];
    float inv[3]; /* 1 / direction, with zero components nudged to tiny */
    int neg[3];   /* direction component < 0: swap near and far planes */
};

static inline void bvh_ray_init(struct bvh_ray *br, vec3 o, vec3 d) {
    double dd[3] = {d.x, d.y, d.z}, oo[3] = {o.x, o.y, o.z};
    for (int k = 0; k < 3; k++) {
        float c = (float)dd[k]; /* in float: 16 rays of a packet divide at once */
        c = fabsf(c) < 1e-30f ? copysignf(1e-30f, c) : c;
        br->org[k] = (float)oo[k];
        br->inv[k] = 1.0f / c;
        br->neg[k] = c < 0;
    }
}

/* Tests the ray against the four children of node for t in [tmin, tmax];
 * returns a bit mask of the children hit and their entry distances.  The
 * far distance is scaled by 1 + 2 gamma(3) so that float rounding can
 * never make a box that the ray touches look missed (Ize 2013). */
static inline int bvh4_test(const struct bvh4_node *nd, const struct bvh_ray *r, float tmin,
                            float tmax, float tnear[4]) {
#ifdef BVH_SSE
    __m128 tn = _mm_set1_ps(tmin), tf = _mm_set1_ps(tmax);
    for (int k = 0; k < 3; k++) {
        __m128 o = _mm_set1_ps(r->org[k]), inv = _mm_set1_ps(r->inv[k]);
        __m128 lo = _mm_loadu_ps(r->neg[k] ? nd->hi[k] : nd->lo[k]);
        __m128 hi = _mm_loadu_ps(r->neg[k] ? nd->lo[k] : nd->hi[k]);
        tn = _mm_max_ps(tn, _mm_mul_ps(_mm_sub_ps(lo, o), inv));
        tf = _mm_min_ps(tf, _mm_mul_ps(_mm_sub_ps(hi, o), inv));
    }
    tf = _mm_mul_ps(tf, _mm_set1_ps(1.0000004f));
    _mm_storeu_ps(tnear, tn);
    return _mm_movemask_ps(_mm_cmple_ps(tn, tf));
#else
    int mask = 0;
    for (int i = 0; i < 4; i++) {
        float tn = tmin, tf = tmax;
        for (int k = 0; k < 3; k++) {
            float lo = r->neg[k] ? nd->hi[k][i] : nd->lo[k][i];
            float hi = r->neg[k] ? nd->lo[k][i] : nd->hi[k][i];
            float a = (lo - r->org[k]) * r->inv[k], b = (hi - r->org[k]) * r->inv[k];
            tn = tn > a ? tn : a; /* exactly _mm_max_ps(tn, a) and _mm_min_ps(tf, b) */
            tf = tf < b ? tf : b;
        }
        tf *= 1.0000004f;
        tnear[i] = tn;
        mask |= (tn <= tf) << i;
    }
    return mask;
#endif
}

/* A traversal stack entry: a node to visit and where the ray enters it. */
struct bvh_entry {
    uint32_t node;
    uint8_t count; /* as in bvh4_node: 0 inner node, else a leaf */
    float tnear;
};

/* The entry for child c of nd, entered at tnear. */
static inline struct bvh_entry bvh4_entry(const struct bvh4_node *nd, int c, float tnear) {
    struct bvh_entry e = {nd->child[c], nd->count[c], tnear};
    return e;
}

/* Pushes the children in mask onto stack, farthest first, so the nearest
 * is visited next.  Returns the new stack size.  Insertion into the stack
 * itself: most masks have one or two bits. */
static inline int bvh4_push_sorted(const struct bvh4_node *nd, int mask, const float tnear[4],
                                   struct bvh_entry *stack, int sp) {
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
        stack[j].node = nd->child[i];
        stack[j].count = nd->count[i];
        stack[j].tnear = t;
    }
    return sp;
}

/* One step down from inner node *e: tests its children, pushes all but the
 * nearest hit onto the stack (farthest deepest) and makes *e the nearest.
 * Unordered (an any-hit walk, whose answer no order changes), *e is the
 * first child hit and the others go on the stack as they come: no sort,
 * 3-7% faster one-ray shadow rays (bench/README.md).  False when no child is hit
 * (the caller pops the next entry).  A single hit child -- the common
 * case -- never touches the stack. */
static inline bool bvh4_descend(const struct bvh4_node *nodes, struct bvh_entry *e,
                                const struct bvh_ray *br, float tmax, struct bvh_entry *stack,
                                int *sp, bool ordered) {
    const struct bvh4_node *nd = &nodes[e->node];
    float tn[4];
    int mask = bvh4_test(nd, br, 0, tmax, tn);
    if (!mask) return false;
    int i = __builtin_ctz((unsigned)mask);
    if (!(mask & (mask - 1))) {
        e->node = nd->child[i];
        e->count = nd->count[i];
        e->tnear = tn[i];
        return true;
    }
    if (!ordered) {
        *e = bvh4_entry(nd, i, tn[i]);
        for (mask &= mask - 1; mask; mask &= mask - 1) {
            int c = __builtin_ctz((unsigned)mask);
            stack[(*sp)++] = bvh4_entry(nd, c, tn[c]);
        }
        return true;
    }
    *sp = bvh4_push_sorted(nd, mask, tn, stack, *sp);
    *e = stack[--*sp];
    return true;
}

#endif
