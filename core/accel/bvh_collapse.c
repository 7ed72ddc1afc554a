/* bvh_collapse.c -- the builder's binary tree (bvh.c) as wide nodes, 4
 * (the scene's objects) or 8 (a mesh's triangles) children a node.
 *
 * Each wide node takes the binary node's two children and keeps opening
 * the inner child with the largest area until it has its width; an inner
 * child of an 8-wide node left with at most BVH8_LEAF_MAX triangles is
 * then a leaf (bnode_wide_leaf), not a node of its own.  Wide
 * nodes are laid out depth-first in one array, in float, the child boxes
 * side by side for the SIMD tests.  Each binary node counts, as the
 * builder makes it (bvh_wide_count), the wide nodes its subtree becomes,
 * so every wide subtree's place is known before it is written and large
 * ones are written by threads of their own: the same nodes in the same
 * places whatever the number of threads.
 */
#include "accel/bvh_collapse.h"

#include <pthread.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#define COLLAPSE_MIN 4096 /* 4-wide nodes below which a collapse thread is not worth it */

/* The children of the wide node made from inner binary node bi: its two
 * children, then the inner child with the largest area opened until there
 * are width of them.  Returns how many. */
static int collapse_kids(const struct bnode *bn, uint32_t bi, int width, uint32_t kids[8]) {
    kids[0] = bn[bi].a, kids[1] = bn[bi].b;
    int nk = 2;
    while (nk < width) {
        int best = -1;
        float area = -1;
        for (int i = 0; i < nk; i++) {
            const struct bnode *k = &bn[kids[i]];
            if (!k->leaf && bb_area(&k->box) > area) { /* small subtrees too, while room */
                area = bb_area(&k->box);
                best = i;
            }
        }
        if (best < 0) break;
        uint32_t open = kids[best];
        kids[best] = bn[open].a;
        kids[nk++] = bn[open].b;
    }
    return nk;
}

/* The wide nodes binary node k's subtree takes under its parent: none
 * when it is folded into the parent as a leaf. */
static uint32_t kid_nodes(const struct bnode *k, int width) {
    return bnode_wide_leaf(k, width) ? 0 : k->wide;
}

uint32_t bvh_wide_count(const struct bnode *bn, uint32_t bi, int width) {
    uint32_t kids[8], w = 1;
    int nk = collapse_kids(bn, bi, width, kids);
    for (int i = 0; i < nk; i++) w += kid_nodes(&bn[kids[i]], width);
    return w;
}

struct collapse {
    const struct bnode *bn;
    char *out;
    int width;
};

/* The node layout both widths share (bvh.h). */
_Static_assert(sizeof(struct bvh4_node) == BVH_NODE_SIZE(4) &&
                   offsetof(struct bvh4_node, hi) == BVH_NODE_HI(4, 0) &&
                   offsetof(struct bvh4_node, child) == BVH_NODE_CHILD(4) &&
                   offsetof(struct bvh4_node, count) == BVH_NODE_COUNT(4),
               "bvh4_node layout");
_Static_assert(sizeof(struct bvh8_node) == BVH_NODE_SIZE(8) &&
                   offsetof(struct bvh8_node, hi) == BVH_NODE_HI(8, 0) &&
                   offsetof(struct bvh8_node, child) == BVH_NODE_CHILD(8) &&
                   offsetof(struct bvh8_node, count) == BVH_NODE_COUNT(8),
               "bvh8_node layout");

/* The first primitive of binary node bi's range: its leftmost leaf's. */
static uint32_t bnode_first(const struct bnode *bn, uint32_t bi) {
    while (!bn[bi].leaf) bi = bn[bi].a;
    return bn[bi].a;
}

/* Writes wide node self: child i the binary node kids[i] (i < nk; the
 * other slots empty boxes), its child index or leaf range from slot[i]. */
static void put_node(const struct collapse *c, uint32_t self, const uint32_t *kids, int nk,
                     const uint32_t *slot) {
    int w = c->width;
    char *at = c->out + BVH_NODE_SIZE(w) * self;
    float box[6][8];
    uint32_t child[8] = {0};
    uint8_t count[8] = {0};
    for (int i = 0; i < w; i++) {
        struct bbox b = i < nk ? c->bn[kids[i]].box : bb_empty();
        for (int k = 0; k < 3; k++) box[k][i] = b.lo[k], box[3 + k][i] = b.hi[k];
        if (i >= nk) continue;
        const struct bnode *k = &c->bn[kids[i]];
        bool leaf = bnode_wide_leaf(k, w);
        child[i] = leaf ? bnode_first(c->bn, kids[i]) : slot[i];
        count[i] = leaf ? k->size : 0;
    }
    memset(at, 0, BVH_NODE_SIZE(w));
    for (int k = 0; k < 3; k++) {
        memcpy(at + BVH_NODE_LO(w, k), box[k], sizeof(float) * (size_t)w);
        memcpy(at + BVH_NODE_HI(w, k), box[3 + k], sizeof(float) * (size_t)w);
    }
    memcpy(at + BVH_NODE_CHILD(w), child, sizeof(uint32_t) * (size_t)w);
    memcpy(at + BVH_NODE_COUNT(w), count, (size_t)w);
}

struct collapse_task {
    const struct collapse *c;
    uint32_t bi, self;
    int tasks;
};

static void collapse_node(const struct collapse *c, uint32_t bi, uint32_t self, int tasks);

static void *collapse_run(void *arg) {
    struct collapse_task *t = arg;
    collapse_node(t->c, t->bi, t->self, t->tasks);
    return NULL;
}

/* Writes the wide node of binary node bi at out[self], its subtrees
 * depth-first after it (each child at self + 1 + the sizes of the children
 * before it).  tasks > 1: large subtrees are written by threads of their
 * own, each with a share of tasks. */
static void collapse_node(const struct collapse *c, uint32_t bi, uint32_t self, int tasks) {
    uint32_t kids[8], slot[8] = {0}, next = self + 1;
    int nk = collapse_kids(c->bn, bi, c->width, kids);
    for (int i = 0; i < nk; i++) {
        slot[i] = next;
        next += kid_nodes(&c->bn[kids[i]], c->width);
    }
    put_node(c, self, kids, nk, slot);
    struct collapse_task t[8];
    pthread_t th[8];
    bool started[8] = {false};
    for (int i = 0; i < nk; i++) {
        const struct bnode *k = &c->bn[kids[i]];
        if (bnode_wide_leaf(k, c->width)) continue;
        t[i] = (struct collapse_task){c, kids[i], slot[i], tasks / nk};
        if (tasks > 1 && k->wide >= COLLAPSE_MIN)
            started[i] = pthread_create(&th[i], NULL, collapse_run, &t[i]) == 0;
        if (!started[i]) collapse_node(c, kids[i], slot[i], 1);
    }
    for (int i = 0; i < nk; i++)
        if (started[i]) pthread_join(th[i], NULL);
}

uint32_t bvh_collapse(const struct bnode *nodes, void *wide, int width, int tasks) {
    struct collapse c = {nodes, wide, width};
    const struct bnode *root = &nodes[0];
    if (!root->leaf) {
        collapse_node(&c, 0, 0, tasks);
        return root->wide;
    }
    uint32_t kids[1] = {0}, slot[1] = {0}; /* one leaf: a wide root with one child */
    put_node(&c, 0, kids, 1, slot);
    return 1;
}
