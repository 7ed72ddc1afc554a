/* bvh.c -- building the 4-wide BVH.
 *
 * Two steps.  First a binary tree, top-down with the binned surface-area
 * heuristic: 16 bins along the axis where the primitive centroids spread
 * most; a node of at most BVH_MAX_LEAF (4) primitives is a leaf, because
 * the four are tested at once by one SIMD test.  Past depth 48 the split falls back to the median, which bounds
 * the depth (and so the traversal stack) whatever the input.  The two
 * halves of the top levels are built by separate threads when asked; binary
 * nodes come from one atomically bumped array, so threads never lock.
 *
 * Then the binary tree is collapsed into 4-wide nodes: each wide node takes
 * the binary node's two children and keeps opening the largest inner child
 * until it has four.  Wide nodes are laid out depth-first in one array, in
 * float, four child boxes side by side for the SIMD test in bvh.h.  The
 * binary tree is freed; only the wide one is kept (bytes per primitive are
 * what the benchmark reports).
 */
#include "bvh.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>

#include "error.h"

#define BINS 16
#define MEDIAN_DEPTH 48
#define PARALLEL_MIN 50000 /* primitives below which a thread is not worth it */

struct bnode {
    struct bbox box;
    uint32_t a, b; /* inner: left and right node; leaf: first, count */
    bool leaf;
};

struct build {
    const struct bbox *boxes;
    float (*cent)[3];   /* centroid of each primitive (times 2) */
    uint32_t *ids;      /* primitive order, partitioned in place */
    struct bnode *nodes;
    atomic_uint used;
};

static struct bbox bb_empty(void) {
    struct bbox b = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
    return b;
}

static void bb_grow(struct bbox *b, const struct bbox *o) {
    for (int k = 0; k < 3; k++) {
        b->lo[k] = o->lo[k] < b->lo[k] ? o->lo[k] : b->lo[k];
        b->hi[k] = o->hi[k] > b->hi[k] ? o->hi[k] : b->hi[k];
    }
}

static float bb_area(const struct bbox *b) {
    float dx = b->hi[0] - b->lo[0], dy = b->hi[1] - b->lo[1], dz = b->hi[2] - b->lo[2];
    if (!(dx >= 0)) return 0;
    return 2 * (dx * dy + dy * dz + dz * dx);
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

static int bin_of(float c, float lo, float scale) {
    int k = (int)((c - lo) * scale);
    return k < 0 ? 0 : k >= BINS ? BINS - 1 : k;
}

/* Binned SAH split of ids[0..n) on axis; returns the number going left, or
 * 0 when a leaf is cheaper. */
static uint32_t split_sah(struct build *b, uint32_t *ids, uint32_t n, int axis, float clo,
                          float chi, const struct bbox *box) {
    float scale = BINS / (chi - clo) * 0.99999f;
    uint32_t count[BINS] = {0};
    struct bbox bin[BINS];
    for (int i = 0; i < BINS; i++) bin[i] = bb_empty();
    for (uint32_t i = 0; i < n; i++) {
        int k = bin_of(b->cent[ids[i]][axis], clo, scale);
        count[k]++;
        bb_grow(&bin[k], &b->boxes[ids[i]]);
    }
    float left_area[BINS];
    uint32_t left_n[BINS];
    struct bbox acc = bb_empty();
    uint32_t acc_n = 0;
    for (int k = 0; k < BINS - 1; k++) {
        bb_grow(&acc, &bin[k]);
        acc_n += count[k];
        left_area[k] = bb_area(&acc);
        left_n[k] = acc_n;
    }
    float best = INFINITY;
    int best_k = -1;
    acc = bb_empty();
    acc_n = 0;
    for (int k = BINS - 1; k > 0; k--) {
        bb_grow(&acc, &bin[k]);
        acc_n += count[k];
        float cost = left_area[k - 1] * (float)left_n[k - 1] + bb_area(&acc) * (float)acc_n;
        if (left_n[k - 1] > 0 && acc_n > 0 && cost < best) {
            best = cost;
            best_k = k;
        }
    }
    /* Costs in units of the parent's area: traversal 1, primitive 1. */
    float parent = bb_area(box);
    (void)parent;
    if (best_k < 0 || n <= BVH_MAX_LEAF) return 0; /* a leaf's 4 primitives cost one SIMD test */
    uint32_t i = 0, j = n;
    while (i < j) {
        if (bin_of(b->cent[ids[i]][axis], clo, scale) < best_k) {
            i++;
        } else {
            uint32_t t = ids[i];
            ids[i] = ids[--j];
            ids[j] = t;
        }
    }
    return i;
}

/* nth_element by centroid on axis (quickselect): the median split. */
static void select_nth(struct build *b, uint32_t *ids, uint32_t n, uint32_t nth, int axis) {
    uint32_t lo = 0, hi = n - 1;
    while (lo < hi) {
        uint32_t m = lo + (hi - lo) / 2, t = ids[m];
        ids[m] = ids[hi];
        ids[hi] = t;
        float pivot = b->cent[ids[hi]][axis];
        uint32_t s = lo;
        for (uint32_t i = lo; i < hi; i++) {
            if (b->cent[ids[i]][axis] < pivot) {
                t = ids[i];
                ids[i] = ids[s];
                ids[s++] = t;
            }
        }
        t = ids[s];
        ids[s] = ids[hi];
        ids[hi] = t;
        if (s == nth) return;
        if (nth < s) hi = s - 1;
        else lo = s + 1;
    }
}

struct task {
    struct build *b;
    uint32_t node, first, n;
    int depth, threads;
};

static void build_node(struct build *b, uint32_t self, uint32_t first, uint32_t n, int depth,
                       int threads);

static void *build_task(void *arg) {
    struct task *t = arg;
    build_node(t->b, t->node, t->first, t->n, t->depth, t->threads);
    return NULL;
}

static void build_node(struct build *b, uint32_t self, uint32_t first, uint32_t n, int depth,
                       int threads) {
    uint32_t *ids = b->ids + first;
    struct bbox box = bb_empty(), cb = bb_empty();
    for (uint32_t i = 0; i < n; i++) {
        bb_grow(&box, &b->boxes[ids[i]]);
        struct bbox c = {{b->cent[ids[i]][0], b->cent[ids[i]][1], b->cent[ids[i]][2]},
                         {b->cent[ids[i]][0], b->cent[ids[i]][1], b->cent[ids[i]][2]}};
        bb_grow(&cb, &c);
    }
    struct bnode *nd = &b->nodes[self];
    nd->box = box;
    float ext[3] = {cb.hi[0] - cb.lo[0], cb.hi[1] - cb.lo[1], cb.hi[2] - cb.lo[2]};
    int axis = ext[0] >= ext[1] && ext[0] >= ext[2] ? 0 : ext[1] >= ext[2] ? 1 : 2;
    uint32_t mid = 0;
    if (n > 1 && ext[axis] > 0) {
        if (depth < MEDIAN_DEPTH) mid = split_sah(b, ids, n, axis, cb.lo[axis], cb.hi[axis], &box);
        else select_nth(b, ids, n, mid = n / 2, axis);
    }
    if ((mid == 0 || mid >= n) && n > BVH_MAX_LEAF) {
        mid = n / 2; /* coincident centroids, or too many for one leaf: split by count */
    }
    if (mid == 0 || mid >= n) {
        nd->leaf = true;
        nd->a = first;
        nd->b = n;
        return;
    }
    uint32_t left = atomic_fetch_add(&b->used, 2);
    nd->leaf = false;
    nd->a = left;
    nd->b = left + 1;
    if (threads > 1 && n >= PARALLEL_MIN) {
        pthread_t th;
        struct task t = {b, left, first, mid, depth + 1, threads / 2};
        if (pthread_create(&th, NULL, build_task, &t) == 0) {
            build_node(b, left + 1, first + mid, n - mid, depth + 1, threads - threads / 2);
            pthread_join(th, NULL);
            return;
        }
    }
    build_node(b, left, first, mid, depth + 1, 1);
    build_node(b, left + 1, first + mid, n - mid, depth + 1, 1);
}

/* ---- collapse to 4-wide --------------------------------------------------- */

struct collapse {
    const struct bnode *bn;
    struct bvh4_node *out;
    uint32_t used;
};

static uint32_t collapse_node(struct collapse *c, uint32_t bi) {
    uint32_t kids[4] = {c->bn[bi].a, c->bn[bi].b, 0, 0};
    int nk = 2;
    while (nk < 4) { /* open the inner child with the largest area */
        int best = -1;
        float area = -1;
        for (int i = 0; i < nk; i++) {
            const struct bnode *k = &c->bn[kids[i]];
            if (!k->leaf && bb_area(&k->box) > area) {
                area = bb_area(&k->box);
                best = i;
            }
        }
        if (best < 0) break;
        uint32_t open = kids[best];
        kids[best] = c->bn[open].a;
        kids[nk++] = c->bn[open].b;
    }
    uint32_t self = c->used++;
    struct bvh4_node nd;
    memset(&nd, 0, sizeof nd);
    for (int i = 0; i < 4; i++) {
        struct bbox box = i < nk ? c->bn[kids[i]].box : bb_empty();
        for (int k = 0; k < 3; k++) {
            nd.lo[k][i] = box.lo[k];
            nd.hi[k][i] = box.hi[k];
        }
    }
    for (int i = 0; i < nk; i++) {
        const struct bnode *k = &c->bn[kids[i]];
        if (k->leaf) {
            nd.child[i] = k->a;
            nd.count[i] = (uint8_t)k->b;
        } else {
            nd.child[i] = collapse_node(c, kids[i]);
        }
    }
    c->out[self] = nd;
    return self;
}

enum rayd_status bvh_build(struct bvh4 *bvh, const struct bbox *boxes, uint32_t n,
                           uint32_t *order, int threads, struct rayd_error *err) {
    memset(bvh, 0, sizeof *bvh);
    bvh->bounds = bb_empty();
    if (n == 0) return RAYD_OK;
    struct build b = {.boxes = boxes, .ids = order};
    b.cent = malloc(sizeof *b.cent * n);
    b.nodes = malloc(sizeof *b.nodes * (2 * (size_t)n));
    struct bvh4_node *wide = malloc(sizeof *wide * ((size_t)n + 1));
    if (!b.cent || !b.nodes || !wide) {
        free(b.cent);
        free(b.nodes);
        free(wide);
        return err_set(err, RAYD_E_NOMEM, NULL, "out of memory building the BVH");
    }
    for (uint32_t i = 0; i < n; i++) {
        order[i] = i;
        for (int k = 0; k < 3; k++) b.cent[i][k] = boxes[i].lo[k] + boxes[i].hi[k];
    }
    atomic_init(&b.used, 1);
    build_node(&b, 0, 0, n, 0, threads);
    bvh->bounds = b.nodes[0].box;
    struct collapse c = {b.nodes, wide, 0};
    if (b.nodes[0].leaf) { /* one leaf: a wide root with one child */
        memset(wide, 0, sizeof *wide);
        for (int i = 0; i < 4; i++)
            for (int k = 0; k < 3; k++) {
                wide->lo[k][i] = i ? INFINITY : b.nodes[0].box.lo[k];
                wide->hi[k][i] = i ? -INFINITY : b.nodes[0].box.hi[k];
            }
        wide->child[0] = 0;
        wide->count[0] = (uint8_t)n;
        c.used = 1;
    } else {
        collapse_node(&c, 0);
    }
    free(b.cent);
    free(b.nodes);
    struct bvh4_node *fit = realloc(wide, sizeof *wide * c.used);
    bvh->nodes = fit ? fit : wide;
    bvh->nnodes = c.used;
    return RAYD_OK;
}

void bvh_free(struct bvh4 *bvh) {
    if (!bvh) return;
    free(bvh->nodes);
    bvh->nodes = NULL;
    bvh->nnodes = 0;
}
