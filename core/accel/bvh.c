/* bvh.c -- building the wide BVHs (4-wide over objects, 8-wide over a
 * mesh's triangles).
 *
 * Two steps.  First a binary tree, top-down with the binned surface-area
 * heuristic: 16 bins along the axis where the primitive centroids spread
 * most; a node of at most max_leaf primitives is a leaf: 4 (BVH_MAX_LEAF)
 * for triangles, which one SIMD test takes at once, 1 for the scene's
 * objects, whose tests cost more than a node's.  Past depth 48 the split
 * falls back to the median, which bounds the depth (and so the traversal
 * stack) whatever the input.
 *
 * Nodes of 5..8 primitives skip the bins: an exact SAH over the few cuts
 * that make two leaves.
 *
 * The builder works on its own copy of the boxes, 32-byte records it
 * partitions in place, so every pass over a node reads memory in order
 * (not through an index).  The caller's function writes the boxes a run
 * at a time straight into those records (bvh8_build_from): a mesh keeps no
 * array of boxes of its own, 24 bytes a triangle of fresh memory less.  A node costs two passes:
 * binning, which also gives both children's boxes and centroid boxes (the unions of their bins),
 * and the partition.  The subtrees of the top levels are built by separate threads -- four per
 * thread asked for, so that a lopsided split leaves no core idle; binary nodes come from one
 * array, a subtree built on one thread taking its slots in chunks (take_children), so threads
 * never lock and rarely touch a shared counter.
 *
 * The top splits themselves run on one thread (bench/README.md, "The
 * block-parallel top split").  The copy of the boxes in, the order array
 * out and the collapse do run on every thread, in blocks fixed by the size
 * alone.  Invariant: the tree is the same bytes on any number of threads,
 * which the unit tests check.
 *
 * Then bvh_collapse.c turns the binary tree into the wide nodes the walks
 * read (in an 8-wide tree, a subtree of at most BVH8_LEAF_MAX triangles
 * left whole becomes one leaf); each binary node counts, as it is built,
 * the wide nodes its subtree becomes (bvh_wide_count), so the collapse
 * can place subtrees before writing them.  The binary tree is freed; only the wide one is
 * kept (bytes per primitive are what the benchmark reports).
 *
 * Memory is part of the cost: the first touch of a page the kernel has not
 * handed out lately is slow (clear_page under the fault), pages a process
 * has just freed come back fast.  So the records are freed as soon as the
 * order is read out of them, and only then is the wide array allocated,
 * exactly the root's wide count: it lands on the records' pages (and the
 * peak resident memory is the larger of the two, not their sum).
 */
#include "base/hugemem.h"
#include "accel/bvh.h"
#include "accel/bvh_collapse.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>

#include "base/error.h"
#include "base/meter.h"
#include "base/parallel.h"

#define BINS 16
#define MEDIAN_DEPTH 48
#define PARALLEL_MIN 50000 /* primitives below which a thread is not worth it */
#define BLOCK (1u << 14)   /* primitives a block */

/* A primitive's box with its id, 32 bytes: the builder moves these (not
 * indices into the caller's boxes), so every pass reads memory in order. */
struct prim {
    float lo[3];
    uint32_t id;
    float hi[3];
    int32_t bin; /* set by the binning pass, read by the partition after it */
};

/* A box of primitives and the box of their centroids (times 2), which the
 * partition that made a node measured on the way. */
struct span {
    struct bbox box, cent;
};

struct build {
    struct prim *prims;
    struct bnode *nodes;
    atomic_uint used;
    uint32_t max_leaf; /* primitives a leaf may hold, 1..BVH_MAX_LEAF */
    int width;         /* children a wide node: 4 or 8 */
    /* the parse's cancel flag (meter_here's, taken on the building thread:
     * the build's own threads have none), and whether the build saw it */
    const atomic_int *cancel;
    atomic_bool canceled;
};

/* Nodes of fewer primitives are built without a look at the cancel flag:
 * a look per node of a few thousand is a few milliseconds apart at most. */
#define CANCEL_MIN 4096

/* True when the parse was canceled: the node is then made a leaf, and the
 * whole build is thrown away. */
static bool build_canceled(struct build *b, uint32_t n) {
    if (!b->cancel || n < CANCEL_MIN) return false;
    if (atomic_load_explicit(&b->canceled, memory_order_relaxed)) return true;
    if (!atomic_load_explicit(b->cancel, memory_order_relaxed)) return false;
    atomic_store(&b->canceled, true);
    return true;
}

struct bbox bbox_from(vec3 lo, vec3 hi) {
    double l[3] = {lo.x, lo.y, lo.z}, h[3] = {hi.x, hi.y, hi.z};
    struct bbox b;
    for (int k = 0; k < 3; k++) {
        b.lo[k] = (float)l[k];
        if ((double)b.lo[k] > l[k]) b.lo[k] = nextafterf(b.lo[k], -INFINITY);
        b.hi[k] = (float)h[k];
        if ((double)b.hi[k] < h[k]) b.hi[k] = nextafterf(b.hi[k], INFINITY);
    }
    return b;
}

static inline int bin_of(const struct prim *p, int axis, float lo, float scale) {
    int k = (int)((p->lo[axis] + p->hi[axis] - lo) * scale);
    return k < 0 ? 0 : k >= BINS ? BINS - 1 : k;
}

/* Moves the primitives of bin < plane (the bins sah_plane left in them)
 * to the front; returns their number.  Hoare's two scans: a record
 * already on its side is not moved, and each swap puts two in place.
 * (Swapping every right-side record to the back, as before, moved twice
 * the records and took a branch miss on each: the 1.3M mesh's build on
 * one thread 0.447 -> 0.426 s, best of 5.) */
static uint32_t partition(struct prim *p, uint32_t n, int plane) {
    uint32_t i = 0, j = n;
    for (;;) {
        while (i < j && p[i].bin < plane) i++;
        while (i < j && p[j - 1].bin >= plane) j--;
        if (i >= j) return i;
        struct prim t = p[i];
        p[i++] = p[--j];
        p[j] = t;
    }
}

#ifdef BVH_SSE
/* Binning and spans with SSE: a primitive's lo and hi are one load each
 * (lane 3, the id and the bin, masked off where it is summed); binning
 * rotates over four sets of bins so that neighbours falling in the same
 * bin (a mesh's triangles come in spatial order) do not wait on each
 * other. */
static inline __m128 xyz(__m128 v) {
    return _mm_and_ps(v, _mm_castsi128_ps(_mm_set_epi32(0, -1, -1, -1)));
}

struct acc4 {
    __m128 lo, hi, clo, chi;
};

static inline void acc4_init(struct acc4 *a) {
    a->lo = a->clo = _mm_set1_ps(INFINITY);
    a->hi = a->chi = _mm_set1_ps(-INFINITY);
}

static inline void acc4_grow(struct acc4 *a, __m128 lo, __m128 hi) {
    __m128 c = _mm_add_ps(xyz(lo), xyz(hi));
    a->lo = _mm_min_ps(a->lo, lo), a->hi = _mm_max_ps(a->hi, hi);
    a->clo = _mm_min_ps(a->clo, c), a->chi = _mm_max_ps(a->chi, c);
}

static inline void acc4_add(struct acc4 *a, const struct prim *p) {
    acc4_grow(a, _mm_loadu_ps(p->lo), _mm_loadu_ps(p->hi));
}

static inline void acc4_merge(struct acc4 *a, const struct acc4 *b) {
    a->lo = _mm_min_ps(a->lo, b->lo), a->hi = _mm_max_ps(a->hi, b->hi);
    a->clo = _mm_min_ps(a->clo, b->clo), a->chi = _mm_max_ps(a->chi, b->chi);
}

static inline void acc4_store(const struct acc4 *a, struct span *s) {
    float v[4][4];
    _mm_storeu_ps(v[0], a->lo), _mm_storeu_ps(v[1], a->hi);
    _mm_storeu_ps(v[2], a->clo), _mm_storeu_ps(v[3], a->chi);
    memcpy(s->box.lo, v[0], sizeof s->box.lo), memcpy(s->box.hi, v[1], sizeof s->box.hi);
    memcpy(s->cent.lo, v[2], sizeof s->cent.lo), memcpy(s->cent.hi, v[3], sizeof s->cent.hi);
}

/* Half the surface area of box [lo, hi] (only the order of costs matters). */
static inline float area4(__m128 lo, __m128 hi) {
    __m128 d = _mm_sub_ps(hi, lo);
    __m128 r = _mm_shuffle_ps(d, d, _MM_SHUFFLE(3, 0, 2, 1)); /* dy dz dx */
    __m128 m = _mm_mul_ps(d, r);                              /* dx*dy dy*dz dz*dx */
    float v[4];
    _mm_storeu_ps(v, m);
    return v[0] + v[1] + v[2];
}

/* sah_best on SSE bins (the same costs, in the same order). */
static int sah_best4(const struct acc4 bin[BINS], const uint32_t count[BINS], struct span *left,
                     struct span *right) {
    float left_area[BINS];
    uint32_t left_n[BINS], acc_n = 0;
    struct acc4 a;
    acc4_init(&a);
    for (int k = 0; k < BINS - 1; k++) {
        acc4_merge(&a, &bin[k]);
        acc_n += count[k];
        left_area[k] = area4(a.lo, a.hi);
        left_n[k] = acc_n;
    }
    float best = INFINITY;
    int best_k = -1;
    acc4_init(&a);
    acc_n = 0;
    for (int k = BINS - 1; k > 0; k--) {
        acc4_merge(&a, &bin[k]);
        acc_n += count[k];
        float cost = left_area[k - 1] * (float)left_n[k - 1] + area4(a.lo, a.hi) * (float)acc_n;
        if (left_n[k - 1] > 0 && acc_n > 0 && cost < best) {
            best = cost;
            best_k = k;
        }
    }
    if (best_k < 0) return -1;
    struct acc4 l, r;
    acc4_init(&l);
    acc4_init(&r);
    for (int k = 0; k < BINS; k++) acc4_merge(k < best_k ? &l : &r, &bin[k]);
    acc4_store(&l, left);
    acc4_store(&r, right);
    return best_k;
}

/* The bins of one node. */
struct bins {
    struct acc4 acc[BINS];
    uint32_t count[BINS];
};

/* Bins p[0..n) on axis into *b, leaving each primitive's bin in it. */
static void bins_fill(struct bins *b, struct prim *p, uint32_t n, int axis, float clo,
                      float scale) {
    enum { SETS = 4 };
    uint32_t cnt[SETS][BINS], sets = n >= 256 ? SETS : 1; /* small nodes: one set is enough */
    struct acc4 acc[SETS][BINS];
    for (uint32_t h = 0; h < sets; h++)
        for (int k = 0; k < BINS; k++) {
            acc4_init(&acc[h][k]);
            cnt[h][k] = 0;
        }
    for (uint32_t i = 0; i < n; i++) {
        /* load before storing the bin: a store into the 16 bytes about to
         * be loaded would stall the load until the store is done */
        __m128 lo = _mm_loadu_ps(p[i].lo), hi = _mm_loadu_ps(p[i].hi);
        uint32_t h = i & (sets - 1);
        int k = bin_of(&p[i], axis, clo, scale);
        cnt[h][k]++;
        acc4_grow(&acc[h][k], lo, hi);
        p[i].bin = k;
    }
    for (int k = 0; k < BINS; k++) {
        b->acc[k] = acc[0][k];
        b->count[k] = cnt[0][k];
        for (uint32_t h = 1; h < sets; h++) {
            acc4_merge(&b->acc[k], &acc[h][k]);
            b->count[k] += cnt[h][k];
        }
    }
}

static int bins_best(const struct bins *b, struct span *left, struct span *right) {
    return sah_best4(b->acc, b->count, left, right);
}

static void span_of(const struct prim *p, uint32_t n, struct span *s) {
    struct acc4 a;
    acc4_init(&a);
    for (uint32_t i = 0; i < n; i++) acc4_add(&a, &p[i]);
    acc4_store(&a, s);
}
#else
static inline void bb_grow(struct bbox *b, const float lo[3], const float hi[3]) {
    for (int k = 0; k < 3; k++) {
        b->lo[k] = lo[k] < b->lo[k] ? lo[k] : b->lo[k];
        b->hi[k] = hi[k] > b->hi[k] ? hi[k] : b->hi[k];
    }
}

static inline void span_add(struct span *s, const struct prim *p) {
    float c[3] = {p->lo[0] + p->hi[0], p->lo[1] + p->hi[1], p->lo[2] + p->hi[2]};
    bb_grow(&s->box, p->lo, p->hi);
    bb_grow(&s->cent, c, c);
}

/* One bin of the SAH sweep: its primitives' box, their centroids' box. */
struct bin {
    struct span sp;
    uint32_t n;
};

/* The best binned-SAH plane over the bins: the first bin of the right
 * side, or -1 when no plane separates anything.  left and right get the
 * two sides' spans, the unions of their bins. */
static int sah_best(const struct bin bin[BINS], struct span *left, struct span *right) {
    float left_area[BINS];
    uint32_t left_n[BINS];
    struct bbox acc = bb_empty();
    uint32_t acc_n = 0;
    for (int k = 0; k < BINS - 1; k++) {
        bb_grow(&acc, bin[k].sp.box.lo, bin[k].sp.box.hi);
        acc_n += bin[k].n;
        left_area[k] = bb_area(&acc);
        left_n[k] = acc_n;
    }
    float best = INFINITY;
    int best_k = -1;
    acc = bb_empty();
    acc_n = 0;
    for (int k = BINS - 1; k > 0; k--) {
        bb_grow(&acc, bin[k].sp.box.lo, bin[k].sp.box.hi);
        acc_n += bin[k].n;
        float cost = left_area[k - 1] * (float)left_n[k - 1] + bb_area(&acc) * (float)acc_n;
        if (left_n[k - 1] > 0 && acc_n > 0 && cost < best) {
            best = cost;
            best_k = k;
        }
    }
    *left = *right = (struct span){bb_empty(), bb_empty()};
    for (int k = 0; k < BINS && best_k > 0; k++) {
        struct span *side = k < best_k ? left : right;
        bb_grow(&side->box, bin[k].sp.box.lo, bin[k].sp.box.hi);
        bb_grow(&side->cent, bin[k].sp.cent.lo, bin[k].sp.cent.hi);
    }
    return best_k;
}

/* The bins of one node. */
struct bins {
    struct bin bin[BINS];
};

/* Bins p[0..n) on axis into *b, leaving each primitive's bin in it. */
static void bins_fill(struct bins *b, struct prim *p, uint32_t n, int axis, float clo,
                      float scale) {
    for (int k = 0; k < BINS; k++) b->bin[k] = (struct bin){{bb_empty(), bb_empty()}, 0};
    for (uint32_t i = 0; i < n; i++) {
        int k = p[i].bin = bin_of(&p[i], axis, clo, scale);
        b->bin[k].n++;
        span_add(&b->bin[k].sp, &p[i]);
    }
}

static int bins_best(const struct bins *b, struct span *left, struct span *right) {
    return sah_best(b->bin, left, right);
}

static void span_of(const struct prim *p, uint32_t n, struct span *s) {
    s->box = s->cent = bb_empty();
    for (uint32_t i = 0; i < n; i++) span_add(s, &p[i]);
}
#endif

/* The best binned-SAH plane on axis (bins_best), with the two sides' spans. */
static int sah_plane(struct prim *p, uint32_t n, int axis, float clo, float scale,
                     struct span *left, struct span *right) {
    struct bins b;
    bins_fill(&b, p, n, axis, clo, scale);
    return bins_best(&b, left, right);
}

/* nth_element by centroid on axis (quickselect): the median split. */
static void select_nth(struct prim *p, uint32_t n, uint32_t nth, int axis) {
    uint32_t lo = 0, hi = n - 1;
    while (lo < hi) {
        uint32_t m = lo + (hi - lo) / 2, s = lo;
        struct prim t = p[m];
        p[m] = p[hi];
        p[hi] = t;
        float pivot = p[hi].lo[axis] + p[hi].hi[axis];
        for (uint32_t i = lo; i < hi; i++) {
            if (p[i].lo[axis] + p[i].hi[axis] < pivot) {
                t = p[i];
                p[i] = p[s];
                p[s++] = t;
            }
        }
        t = p[s];
        p[s] = p[hi];
        p[hi] = t;
        if (s == nth) return;
        if (nth < s)
            hi = s - 1;
        else
            lo = s + 1;
    }
}

/* A node of up to twice L = max_leaf primitives becomes two leaves: sorted
 * by centroid on axis, the exact SAH picks among the cuts that leave at
 * most L a side.
 * Cheaper than binning (whose fixed cost dominates at this size) and
 * better. */
static uint32_t split_small(struct prim *p, uint32_t n, uint32_t L, int axis, struct span *left,
                            struct span *right) {
    for (uint32_t i = 1; i < n; i++) { /* insertion sort of <= 8 records */
        struct prim t = p[i];
        float c = t.lo[axis] + t.hi[axis];
        uint32_t j = i;
        for (; j > 0 && p[j - 1].lo[axis] + p[j - 1].hi[axis] > c; j--) p[j] = p[j - 1];
        p[j] = t;
    }
    uint32_t best_k = n / 2;
    float best = INFINITY;
    for (uint32_t k = n - L; k <= L; k++) {
        span_of(p, k, left);
        span_of(p + k, n - k, right);
        float cost = bb_area(&left->box) * (float)k + bb_area(&right->box) * (float)(n - k);
        if (cost < best) best = cost, best_k = k;
    }
    span_of(p, best_k, left);
    span_of(p + best_k, n - best_k, right);
    return best_k;
}

/* Splits node prims p[0..n) (measured by sp) into left and right: binned
 * SAH, the median past MEDIAN_DEPTH, halves by count when the centroids
 * coincide.  Returns the left count; 0 makes a leaf. */
static uint32_t split(struct build *b, struct prim *p, uint32_t n, const struct span *sp, int depth,
                      struct span *left, struct span *right) {
    uint32_t L = b->max_leaf;
    const struct bbox *cb = &sp->cent;
    float ext[3] = {cb->hi[0] - cb->lo[0], cb->hi[1] - cb->lo[1], cb->hi[2] - cb->lo[2]};
    int axis = ext[0] >= ext[1] && ext[0] >= ext[2] ? 0 : ext[1] >= ext[2] ? 1 : 2;
    *left = *right = (struct span){bb_empty(), bb_empty()};
    uint32_t mid = 0;
    if (n > L && n <= 2 * L) return split_small(p, n, L, axis, left, right);
    /* a subnormal extent would make the scale infinite: the median then */
    float scale = ext[axis] > 0 ? BINS / ext[axis] * 0.99999f : 0;
    if (n > L && ext[axis] > 0 && isfinite(scale) && depth < MEDIAN_DEPTH) {
        int plane = sah_plane(p, n, axis, cb->lo[axis], scale, left, right);
        if (plane > 0) return partition(p, n, plane);
    } else if (n > L && ext[axis] > 0) {
        select_nth(p, n, mid = n / 2, axis);
    }
    if (n <= L) return 0;
    if (mid == 0) mid = n / 2; /* coincident centroids: split by count */
    span_of(p, mid, left);
    span_of(p + mid, n - mid, right);
    return mid;
}

/* Node slots a subtree built on one thread takes at once (take_children),
 * and the most subtrees a build hands to threads (build_tasks). */
#define CHUNK 1024u /* nodes: 40 KiB */
#define SUBTREES_MAX 64

struct chunk {
    uint32_t next, end; /* the slots left in the subtree's chunk */
};

struct task {
    struct build *b;
    uint32_t node, first, n;
    struct span sp;
    int depth, threads;
};

static void build_node(struct build *b, uint32_t self, uint32_t first, uint32_t n,
                       const struct span *sp, int depth, int threads, struct chunk *next);

static void *build_task(void *arg) {
    struct task *t = arg;
    build_node(t->b, t->node, t->first, t->n, &t->sp, t->depth, t->threads, NULL);
    return NULL;
}

/* Two node slots for the children of a node.  Where the subtrees are
 * still handed to threads (next is NULL) they come from the shared
 * counter; a subtree built on one thread takes them from the counter
 * CHUNK at a time and then counts in its own chunk alone.  An atomic add
 * per node made the counter's cache line (and the build's pointers beside
 * it) bounce between the cores: 8% of build_node's samples on the 1.3M
 * mesh.  Taking at once the most a subtree could need (2k - 2 nodes for k
 * primitives) instead left each subtree's unused tail between the ranges
 * the others filled, and the 2 MiB pages the array is faulted in mapped
 * most of them: the 328k-triangle build's peak went from 69 to 114 bytes a
 * triangle on two threads (tests/unit/test_build_peak.c).  Chunks are
 * handed out in order, so what is touched is the counter's prefix, less at
 * most a chunk a subtree. */
static uint32_t take_children(struct build *b, bool serial, struct chunk **next,
                              struct chunk *local) {
    if (!*next) {
        if (!serial) return atomic_fetch_add(&b->used, 2);
        *local = (struct chunk){0, 0};
        *next = local;
    }
    struct chunk *c = *next;
    if (c->next == c->end) {
        c->next = atomic_fetch_add(&b->used, CHUNK);
        c->end = c->next + CHUNK;
    }
    uint32_t left = c->next;
    c->next += 2;
    return left;
}

static void build_node(struct build *b, uint32_t self, uint32_t first, uint32_t n,
                       const struct span *sp, int depth, int threads, struct chunk *next) {
    struct bnode *nd = &b->nodes[self];
    nd->box = sp->box;
    struct span ls, rs;
    uint32_t mid = build_canceled(b, n) ? 0 : split(b, b->prims + first, n, sp, depth, &ls, &rs);
    if (mid == 0 || mid >= n) {
        nd->leaf = true;
        nd->a = first;
        nd->b = n;
        nd->wide = 0;
        nd->size = (uint8_t)n;
        return;
    }
    bool parallel = threads > 1 && n >= PARALLEL_MIN;
    struct chunk local;
    uint32_t left = take_children(b, !parallel, &next, &local);
    nd->leaf = false;
    nd->a = left;
    nd->b = left + 1;
    nd->size = n > 255 ? 255 : (uint8_t)n;
    if (parallel) {
        /* threads counts subtrees still to hand out: four per thread asked
         * for, so that an uneven split leaves no core idle for long */
        pthread_t th;
        struct task t = {b, left, first, mid, ls, depth + 1, threads / 2};
        if (pthread_create(&th, NULL, build_task, &t) == 0) {
            build_node(b, left + 1, first + mid, n - mid, &rs, depth + 1, threads - threads / 2,
                       NULL);
            pthread_join(th, NULL);
            nd->wide = bvh_wide_count(b->nodes, self, b->width);
            return;
        }
    }
    build_node(b, left, first, mid, &ls, depth + 1, 1, next);
    build_node(b, left + 1, first + mid, n - mid, &rs, depth + 1, 1, next);
    nd->wide = bvh_wide_count(b->nodes, self, b->width);
}

/* Primitives in block k of n (BLOCK each, the last fewer). */
static uint32_t block_len(uint32_t n, size_t k) {
    uint32_t first = (uint32_t)k * BLOCK;
    return n - first < BLOCK ? n - first : BLOCK;
}

/* The primitives' boxes, made by the caller's function, copied into the
 * builder's records block by block, with each block's span. */
struct fill {
    bvh_boxes_fn fn;
    const void *ctx;
    struct prim *prims;
    struct span *spans; /* one a block */
    uint32_t *order;
    uint32_t n;
};

#define FILL_RUN 256 /* boxes asked of the caller at once (6 KiB of stack) */

static void fill_body(void *ctx, size_t lo, size_t hi) {
    struct fill *f = ctx;
    struct bbox box[FILL_RUN];
    for (size_t k = lo; k < hi; k++) {
        uint32_t first = (uint32_t)k * BLOCK, n = block_len(f->n, k);
        for (uint32_t r = first; r < first + n; r += FILL_RUN) {
            uint32_t m = first + n - r < FILL_RUN ? first + n - r : FILL_RUN;
            f->fn(f->ctx, r, m, box);
            for (uint32_t i = 0; i < m; i++) {
                struct prim *p = &f->prims[r + i];
                memcpy(p->lo, box[i].lo, sizeof p->lo);
                memcpy(p->hi, box[i].hi, sizeof p->hi);
                p->id = r + i;
                p->bin = 0;
            }
        }
        span_of(f->prims + first, n, &f->spans[k]);
    }
}

static void order_body(void *ctx, size_t lo, size_t hi) {
    struct fill *f = ctx;
    for (size_t i = lo; i < hi; i++) f->order[i] = f->prims[i].id;
}

static void bb_merge(struct bbox *a, const struct bbox *b) {
    for (int k = 0; k < 3; k++) {
        a->lo[k] = b->lo[k] < a->lo[k] ? b->lo[k] : a->lo[k];
        a->hi[k] = b->hi[k] > a->hi[k] ? b->hi[k] : a->hi[k];
    }
}

/* Fills b->prims by fn on every thread; *all gets their span (the blocks'
 * spans merged in order). */
static bool fill_prims(struct build *b, bvh_boxes_fn fn, const void *ctx, uint32_t n, int threads,
                       struct span *all) {
    size_t nb = (n + (size_t)BLOCK - 1) / BLOCK;
    struct fill f = {fn, ctx, b->prims, malloc(sizeof *f.spans * nb), NULL, n};
    if (!f.spans) return false;
    parallel_for(nb, threads, 1, fill_body, &f);
    *all = f.spans[0];
    for (size_t k = 1; k < nb; k++) {
        bb_merge(&all->box, &f.spans[k].box);
        bb_merge(&all->cent, &f.spans[k].cent);
    }
    free(f.spans);
    return true;
}

/* Subtrees the binary tree of n primitives is built in: four a thread,
 * SUBTREES_MAX at most, one where a thread is not worth it. */
static int build_tasks(uint32_t n, int threads) {
    if (threads <= 1 || n < PARALLEL_MIN) return 1;
    return threads > SUBTREES_MAX / 4 ? SUBTREES_MAX : 4 * threads;
}

/* The binary tree over b->prims, from the root's span. */
static void build_tree(struct build *b, uint32_t n, const struct span *all, int threads) {
    atomic_init(&b->used, 1);
    build_node(b, 0, 0, n, all, 0, build_tasks(n, threads), NULL);
}

/* The order out, then the records freed before the wide nodes are
 * allocated (exactly as many as the tree counted): the wide array reuses
 * the pages the records leave rather than fresh ones. */
static void *finish(struct build *b, uint32_t n, uint32_t *order, int threads, uint32_t *used) {
    struct fill f = {.prims = b->prims, .order = order};
    parallel_for(n, threads, BLOCK, order_body, &f);
    free(b->prims);
    b->prims = NULL;
    *used = b->nodes[0].leaf ? 1 : b->nodes[0].wide;
    void *wide = huge_alloc(BVH_NODE_SIZE(b->width) * *used);
    int tasks = threads > 1 ? 4 * threads : 1;
    if (wide) bvh_collapse(b->nodes, wide, b->width, tasks > 64 ? 64 : tasks);
    return wide;
}

/* Builds the wide nodes (width 4 or 8) into *nodes, their number into
 * *nnodes and the root's box into *bounds. */
static enum rayd_status build_wide(int width, void **nodes, uint32_t *nnodes, struct bbox *bounds,
                                   bvh_boxes_fn fn, const void *ctx, uint32_t n, uint32_t max_leaf,
                                   uint32_t *order, int threads, struct rayd_error *err) {
    *nodes = NULL;
    *nnodes = 0;
    *bounds = bb_empty();
    if (n == 0) return RAYD_OK;
    struct build b = {0};
    b.max_leaf = max_leaf < 1 ? 1 : max_leaf > BVH_MAX_LEAF ? BVH_MAX_LEAF : max_leaf;
    b.width = width;
    b.cancel = meter_here ? meter_here->cancel : NULL;
    b.prims = huge_alloc(sizeof *b.prims * n);
    /* at most 2n - 1 nodes, and a chunk's unused tail in each subtree */
    size_t room = 2 * (size_t)n + (size_t)build_tasks(n, threads) * CHUNK;
    b.nodes = huge_alloc(sizeof *b.nodes * room);
    struct span all;
    void *wide = NULL;
    uint32_t used = 0;
    struct bbox box = bb_empty();
    bool canceled = false;
    if (b.prims && b.nodes && fill_prims(&b, fn, ctx, n, threads, &all)) {
        build_tree(&b, n, &all, threads);
        box = b.nodes[0].box;
        canceled = atomic_load(&b.canceled);
        if (!canceled) wide = finish(&b, n, order, threads, &used);
    }
    free(b.prims);
    free(b.nodes);
    if (canceled) return err_set(err, RAYD_E_CANCELED, NULL, "the parse was canceled");
    if (!wide) return err_set(err, RAYD_E_NOMEM, NULL, "out of memory building the BVH");
    *nodes = wide;
    *nnodes = used;
    *bounds = box;
    return RAYD_OK;
}

enum rayd_status bvh8_build_from(struct bvh8 *bvh, bvh_boxes_fn fn, const void *ctx, uint32_t n,
                                 uint32_t max_leaf, uint32_t *order, int threads,
                                 struct rayd_error *err) {
    void *nodes;
    enum rayd_status st = build_wide(8, &nodes, &bvh->nnodes, &bvh->bounds, fn, ctx, n, max_leaf,
                                     order, threads, err);
    bvh->nodes = nodes;
    return st;
}

void bvh_boxes_copy(const void *ctx, uint32_t first, uint32_t n, struct bbox *out) {
    memcpy(out, (const struct bbox *)ctx + first, sizeof *out * n);
}

enum rayd_status bvh_build(struct bvh4 *bvh, const struct bbox *boxes, uint32_t n,
                           uint32_t max_leaf, uint32_t *order, int threads,
                           struct rayd_error *err) {
    void *nodes;
    enum rayd_status st = build_wide(4, &nodes, &bvh->nnodes, &bvh->bounds, bvh_boxes_copy, boxes,
                                     n, max_leaf, order, threads, err);
    bvh->nodes = nodes;
    return st;
}

void bvh_free(struct bvh4 *bvh) {
    if (!bvh) return;
    free(bvh->nodes);
    bvh->nodes = NULL;
    bvh->nnodes = 0;
}

void bvh8_free(struct bvh8 *bvh) {
    if (!bvh) return;
    free(bvh->nodes);
    bvh->nodes = NULL;
    bvh->nnodes = 0;
}
