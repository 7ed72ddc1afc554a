/* bvh.c -- build and traverse the bounding volume hierarchy.
 *
 * Build: top-down, binned surface-area heuristic (16 bins on the axis where
 * the object centroids spread most).  A node becomes a leaf when it holds
 * few objects and splitting would not be cheaper by the SAH, or when all
 * centroids coincide.  Past a depth of 40 the split falls back to the
 * median, which bounds the depth (and so the traversal stack) by
 * 40 + log2(n) whatever the input.  Nodes are stored depth-first in one
 * array: the left child of node i is i + 1, the right one is node.index.
 *
 * Traversal: a small fixed stack, slab tests with the precomputed inverse
 * direction, the nearer child first.  No allocation per ray.
 */
#include "bvh.h"

#include <stdlib.h>
#include <string.h>

#include "error.h"

#define BVH_BINS 16
#define BVH_MAX_LEAF 4
#define BVH_STACK 128
#define BVH_MEDIAN_DEPTH 40

static struct aabb box_empty(void) {
    struct aabb b = {v3(INFINITY, INFINITY, INFINITY), v3(-INFINITY, -INFINITY, -INFINITY)};
    return b;
}
static struct aabb box_join(struct aabb a, struct aabb b) {
    struct aabb r = {v3_min(a.lo, b.lo), v3_max(a.hi, b.hi)};
    return r;
}
static struct aabb box_grow(struct aabb a, vec3 p) {
    struct aabb r = {v3_min(a.lo, p), v3_max(a.hi, p)};
    return r;
}
static double box_area(struct aabb b) {
    vec3 d = v3_sub(b.hi, b.lo);
    if (d.x < 0) return 0;
    return 2.0 * (d.x * d.y + d.y * d.z + d.z * d.x);
}
static vec3 centroid(const struct object *o) {
    struct aabb b = shape_bounds(o);
    return v3_scale(v3_add(b.lo, b.hi), 0.5);
}

struct build {
    struct object *objs;
    struct bvh_node *nodes;
    int32_t used;
    int sort_axis;
};

static int cmp_axis(const void *a, const void *b, int axis) {
    double ca = v3_axis(centroid(a), axis), cb = v3_axis(centroid(b), axis);
    return (ca > cb) - (ca < cb);
}
static int cmp_x(const void *a, const void *b) { return cmp_axis(a, b, 0); }
static int cmp_y(const void *a, const void *b) { return cmp_axis(a, b, 1); }
static int cmp_z(const void *a, const void *b) { return cmp_axis(a, b, 2); }

static int32_t split_median(struct object *objs, int32_t n, int axis) {
    int (*cmp[3])(const void *, const void *) = {cmp_x, cmp_y, cmp_z};
    qsort(objs, (size_t)n, sizeof *objs, cmp[axis]);
    return n / 2;
}

/* Binned SAH: returns the split position in objs (objects reordered), or 0
 * when a leaf is cheaper. */
static int32_t split_sah(struct object *objs, int32_t n, int axis, struct aabb cb) {
    double lo = v3_axis(cb.lo, axis), ext = v3_axis(cb.hi, axis) - lo;
    double scale = BVH_BINS / ext * (1 - 1e-9);
    int count[BVH_BINS] = {0};
    struct aabb bin[BVH_BINS];
    for (int i = 0; i < BVH_BINS; i++) bin[i] = box_empty();
    for (int32_t i = 0; i < n; i++) {
        int k = (int)((v3_axis(centroid(&objs[i]), axis) - lo) * scale);
        k = k < 0 ? 0 : k >= BVH_BINS ? BVH_BINS - 1 : k;
        count[k]++;
        bin[k] = box_join(bin[k], shape_bounds(&objs[i]));
    }
    double left_area[BVH_BINS], best = INFINITY;
    int left_n[BVH_BINS], best_k = -1;
    struct aabb acc = box_empty();
    int acc_n = 0;
    for (int k = 0; k < BVH_BINS - 1; k++) {
        acc = box_join(acc, bin[k]);
        acc_n += count[k];
        left_area[k] = box_area(acc);
        left_n[k] = acc_n;
    }
    acc = box_empty();
    acc_n = 0;
    for (int k = BVH_BINS - 1; k > 0; k--) {
        acc = box_join(acc, bin[k]);
        acc_n += count[k];
        double cost = left_area[k - 1] * left_n[k - 1] + box_area(acc) * acc_n;
        if (left_n[k - 1] > 0 && acc_n > 0 && cost < best) {
            best = cost;
            best_k = k;
        }
    }
    struct aabb all = box_empty();
    for (int k = 0; k < BVH_BINS; k++) all = box_join(all, bin[k]);
    /* Leaf cost n * area (intersection cost 1, traversal cost 1 in area units). */
    if (best_k < 0 || (n <= BVH_MAX_LEAF && best + box_area(all) >= n * box_area(all))) return 0;
    int32_t i = 0, j = n - 1;
    while (i <= j) {
        int k = (int)((v3_axis(centroid(&objs[i]), axis) - lo) * scale);
        k = k < 0 ? 0 : k >= BVH_BINS ? BVH_BINS - 1 : k;
        if (k < best_k) {
            i++;
        } else {
            struct object t = objs[i];
            objs[i] = objs[j];
            objs[j--] = t;
        }
    }
    return i;
}

static void build_node(struct build *b, int32_t first, int32_t n, int depth) {
    int32_t self = b->used++;
    struct bvh_node *node = &b->nodes[self];
    struct aabb box = box_empty(), cb = box_empty();
    for (int32_t i = first; i < first + n; i++) {
        box = box_join(box, shape_bounds(&b->objs[i]));
        cb = box_grow(cb, centroid(&b->objs[i]));
    }
    node->box = box;
    vec3 ext = v3_sub(cb.hi, cb.lo);
    int axis = (ext.x >= ext.y && ext.x >= ext.z) ? 0 : (ext.y >= ext.z ? 1 : 2);
    int32_t mid = 0;
    if (n > 1 && v3_axis(ext, axis) > 0) {
        mid = depth >= BVH_MEDIAN_DEPTH ? split_median(b->objs + first, n, axis)
                                        : split_sah(b->objs + first, n, axis, cb);
    }
    if (mid <= 0 || mid >= n) {
        node->index = first;
        node->count = n;
        return;
    }
    node->count = 0;
    build_node(b, first, mid, depth + 1);
    b->nodes[self].index = b->used;
    build_node(b, first + mid, n - mid, depth + 1);
}

enum rayd_status bvh_build(struct bvh *bvh, struct object *objs, int32_t n, struct rayd_error *err) {
    bvh->nodes = NULL;
    bvh->nnodes = 0;
    if (n <= 0) return RAYD_OK;
    /* A binary tree with n leaves at most has 2n - 1 nodes. */
    struct bvh_node *nodes = malloc(sizeof *nodes * (size_t)(2 * n - 1));
    if (!nodes) return err_set(err, RAYD_E_NOMEM, NULL, "out of memory building the BVH");
    struct build b = {objs, nodes, 0, 0};
    build_node(&b, 0, n, 0);
    struct bvh_node *fit = realloc(nodes, sizeof *nodes * (size_t)b.used);
    bvh->nodes = fit ? fit : nodes;
    bvh->nnodes = b.used;
    return RAYD_OK;
}

void bvh_free(struct bvh *bvh) {
    if (!bvh) return;
    free(bvh->nodes);
    bvh->nodes = NULL;
    bvh->nnodes = 0;
}

/* Slab test: does the ray enter the box before tmax?  *tnear gets the entry. */
static inline bool box_hit(const struct aabb *b, vec3 o, vec3 inv, double tmin, double tmax,
                           double *tnear) {
    double t1 = (b->lo.x - o.x) * inv.x, t2 = (b->hi.x - o.x) * inv.x;
    double lo = fmin(t1, t2), hi = fmax(t1, t2);
    t1 = (b->lo.y - o.y) * inv.y;
    t2 = (b->hi.y - o.y) * inv.y;
    lo = fmax(lo, fmin(t1, t2));
    hi = fmin(hi, fmax(t1, t2));
    t1 = (b->lo.z - o.z) * inv.z;
    t2 = (b->hi.z - o.z) * inv.z;
    lo = fmax(lo, fmin(t1, t2));
    hi = fmin(hi, fmax(t1, t2));
    lo = fmax(lo, tmin);
    hi = fmin(hi, tmax);
    *tnear = lo;
    return lo <= hi;
}

int32_t bvh_nearest(const struct bvh *bvh, const struct object *objs, const ray *r, double tmin,
                    double *tmax) {
    if (bvh->nnodes == 0) return -1;
    vec3 inv = v3(1.0 / r->d.x, 1.0 / r->d.y, 1.0 / r->d.z);
    int32_t stack[BVH_STACK], sp = 0, best = -1;
    stack[sp++] = 0;
    while (sp > 0) {
        const struct bvh_node *node = &bvh->nodes[stack[--sp]];
        double tn;
        if (!box_hit(&node->box, r->o, inv, tmin, *tmax, &tn)) continue;
        if (node->count > 0) {
            for (int32_t i = node->index; i < node->index + node->count; i++) {
                double t;
                if (shape_hit(&objs[i], r, tmin, *tmax, &t)) {
                    *tmax = t;
                    best = i;
                }
            }
            continue;
        }
        int32_t left = (int32_t)(node - bvh->nodes) + 1, right = node->index;
        double tl, tr;
        bool hl = box_hit(&bvh->nodes[left].box, r->o, inv, tmin, *tmax, &tl);
        bool hr = box_hit(&bvh->nodes[right].box, r->o, inv, tmin, *tmax, &tr);
        if (hl && hr) {
            /* Push the farther child first so the nearer one is popped next. */
            stack[sp++] = tl <= tr ? right : left;
            stack[sp++] = tl <= tr ? left : right;
        } else if (hl) {
            stack[sp++] = left;
        } else if (hr) {
            stack[sp++] = right;
        }
    }
    return best;
}

bool bvh_each_hit(const struct bvh *bvh, const struct object *objs, const ray *r, double tmin,
                  double tmax, bvh_visit_fn visit, void *ctx) {
    if (bvh->nnodes == 0) return true;
    vec3 inv = v3(1.0 / r->d.x, 1.0 / r->d.y, 1.0 / r->d.z);
    int32_t stack[BVH_STACK], sp = 0;
    stack[sp++] = 0;
    while (sp > 0) {
        const struct bvh_node *node = &bvh->nodes[stack[--sp]];
        double tn;
        if (!box_hit(&node->box, r->o, inv, tmin, tmax, &tn)) continue;
        if (node->count > 0) {
            for (int32_t i = node->index; i < node->index + node->count; i++) {
                double t;
                if (shape_hit(&objs[i], r, tmin, tmax, &t) && !visit(ctx, i, t)) return false;
            }
            continue;
        }
        stack[sp++] = node->index;
        stack[sp++] = (int32_t)(node - bvh->nodes) + 1;
    }
    return true;
}
