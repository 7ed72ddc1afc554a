/* bvh_collapse.h -- what the BVH builder (bvh.c) shares with its collapse
 * into wide nodes (bvh_collapse.c): the binary nodes and two box helpers.
 * Private to those two files.
 */
#ifndef BVH_COLLAPSE_H
#define BVH_COLLAPSE_H

#include <math.h>
#include <stdbool.h>
#include <stdint.h>

#include "accel/bvh.h"

struct bnode {
    struct bbox box;
    uint32_t a, b; /* inner: left and right node; leaf: first, count */
    uint32_t wide; /* wide nodes its subtree collapses to (0 for a leaf) */
    bool leaf;
    uint8_t size; /* primitives in its subtree, at most 255 */
};

/* Whether binary node k becomes a leaf of a width-wide node: a leaf, or
 * in 8-wide trees (a mesh's) a subtree of at most BVH8_LEAF_MAX
 * triangles, whose range of primitives is contiguous (the builder splits
 * ranges).  Two blocks of four tested at once cost a ray about what one
 * does, where the inner node they would otherwise be costs a node test
 * and its four cache lines. */
static inline bool bnode_wide_leaf(const struct bnode *k, int width) {
    return k->leaf || (width == 8 && k->size <= BVH8_LEAF_MAX);
}

static inline struct bbox bb_empty(void) {
    struct bbox b = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
    return b;
}

static inline float bb_area(const struct bbox *b) {
    float dx = b->hi[0] - b->lo[0], dy = b->hi[1] - b->lo[1], dz = b->hi[2] - b->lo[2];
    if (!(dx >= 0)) return 0;
    return 2 * (dx * dy + dy * dz + dz * dx);
}

/* The width-wide nodes inner node bi collapses to, from its wide children's
 * counts (built already): what lets the collapse place every subtree
 * before it is written, and so write subtrees on several threads. */
uint32_t bvh_wide_count(const struct bnode *bn, uint32_t bi, int width);

/* The binary tree nodes (root at 0) as width-wide nodes
 * (4: struct bvh4_node, 8: struct bvh8_node) into wide (room for the
 * root's wide count, 1 for a leaf root), large subtrees on up to tasks
 * threads; returns how many. */
uint32_t bvh_collapse(const struct bnode *nodes, void *wide, int width, int tasks);

#endif
