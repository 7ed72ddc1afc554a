/* bvh.h -- bounding volume hierarchy over the scene's bounded objects. */
#ifndef BVH_H
#define BVH_H

#include <stddef.h>
#include <stdint.h>

#include "rayd/rayd.h"
#include "shape.h"

struct bvh_node {
    struct aabb box;
    int32_t index; /* leaf: first object; inner: index of the right child */
    int32_t count; /* leaf: number of objects (> 0); inner: 0 */
};

struct bvh {
    struct bvh_node *nodes; /* depth-first: a left child follows its parent */
    int32_t nnodes;
};

/* Builds the hierarchy over objs[0..n), reordering objs in place.  The bvh
 * owns its nodes; free them with bvh_free. */
enum rayd_status bvh_build(struct bvh *bvh, struct object *objs, int32_t n, struct rayd_error *err);
void bvh_free(struct bvh *bvh);

/* Nearest hit in (tmin, *tmax): returns the object index or -1; on a hit
 * *tmax becomes its t. */
int32_t bvh_nearest(const struct bvh *bvh, const struct object *objs, const ray *r, double tmin,
                    double *tmax);

/* Calls visit(ctx, object index, t) for every object hit in (tmin, tmax),
 * in no particular order, until visit returns false.  Returns false if a
 * visit stopped the walk. */
typedef bool (*bvh_visit_fn)(void *ctx, int32_t obj, double t);
bool bvh_each_hit(const struct bvh *bvh, const struct object *objs, const ray *r, double tmin,
                  double tmax, bvh_visit_fn visit, void *ctx);

#endif
