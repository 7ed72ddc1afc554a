/* bvh_collapse.c -- the builder's binary tree (bvh.c) as 4-wide nodes.
 *
 * Each wide node takes the binary node's two children and keeps opening
 * the inner child with the largest area until it has four.  Wide nodes are
 * laid out depth-first in one array, in float, four child boxes side by
 * side for the SIMD test in bvh.h.  Each binary node counts, as the
 * builder makes it (bvh_wide_count), the wide nodes its subtree becomes,
 * so every wide subtree's place is known before it is written and large
 * ones are written by threads of their own: the same nodes in the same
 * places whatever the number of threads.
 */
#include "accel/bvh_collapse.h"

#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#define COLLAPSE_MIN 4096 /* 4-wide nodes below which a collapse thread is not worth it */

/* The children of the 4-wide node made from inner binary node bi: its two
 * children, then the inner child with the largest area opened until there
 * are four.  Returns how many. */
static int collapse_kids(const struct bnode *bn, uint32_t bi, uint32_t kids[4]) {
    kids[0] = bn[bi].a, kids[1] = bn[bi].b;
    int nk = 2;
    while (nk < 4) {
        int best = -1;
        float area = -1;
        for (int i = 0; i < nk; i++) {
            const struct bnode *k = &bn[kids[i]];
            if (!k->leaf && bb_area(&k->box) > area) {
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

uint32_t bvh_wide_count(const struct bnode *bn, uint32_t bi) {
    uint32_t kids[4], w = 1;
    int nk = collapse_kids(bn, bi, kids);
    for (int i = 0; i < nk; i++) w += bn[kids[i]].wide;
    return w;
}

struct collapse {
    const struct bnode *bn;
    struct bvh4_node *out;
};

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
    uint32_t kids[4], next = self + 1;
    int nk = collapse_kids(c->bn, bi, kids);
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
        nd.child[i] = k->leaf ? k->a : next;
        nd.count[i] = k->leaf ? (uint8_t)k->b : 0;
        next += k->wide;
    }
    c->out[self] = nd;
    struct collapse_task t[4];
    pthread_t th[4];
    bool started[4] = {false};
    for (int i = 0; i < nk; i++) {
        const struct bnode *k = &c->bn[kids[i]];
        if (k->leaf) continue;
        t[i] = (struct collapse_task){c, kids[i], nd.child[i], tasks / nk};
        if (tasks > 1 && k->wide >= COLLAPSE_MIN)
            started[i] = pthread_create(&th[i], NULL, collapse_run, &t[i]) == 0;
        if (!started[i]) collapse_node(c, kids[i], nd.child[i], 1);
    }
    for (int i = 0; i < nk; i++)
        if (started[i]) pthread_join(th[i], NULL);
}

uint32_t bvh_collapse(const struct bnode *nodes, struct bvh4_node *wide, uint32_t n, int tasks) {
    const struct bnode *root = &nodes[0];
    if (!root->leaf) {
        struct collapse c = {nodes, wide};
        collapse_node(&c, 0, 0, tasks);
        return root->wide;
    }
    memset(wide, 0, sizeof *wide); /* one leaf: a wide root with one child */
    for (int i = 0; i < 4; i++)
        for (int k = 0; k < 3; k++) {
            wide->lo[k][i] = i ? INFINITY : root->box.lo[k];
            wide->hi[k][i] = i ? -INFINITY : root->box.hi[k];
        }
    wide->child[0] = 0;
    wide->count[0] = (uint8_t)n;
    return 1;
}
