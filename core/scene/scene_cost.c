/* scene_cost.c -- how much work a camera sample of a scene will cost, told
 * before any ray is cast.
 *
 * A render server must know what a request costs before it gives it a
 * worker: to refuse what is over a budget, to size tiles so no tile holds a
 * worker for long, and to tell a balancer how much work is waiting.  The
 * estimate reads only what the frozen scene says -- the integrator, the
 * depth limit, the lights and their samples, the materials, the shape of
 * its BVHs -- so it is the same number on every node and every run, and a
 * test can count on it.  It is an upper bound in spirit: a client who
 * shapes a scene to cost more than its price (a tree of glass, thousands of
 * instances over one spot, hundreds of area lights) must pay that price up
 * front, because a server that prices the common case and trusts the rest
 * can be handed an hour of work for the price of a millisecond.  What the
 * bound overcounts on an honest scene, the server's per-scene rate absorbs
 * (server/work/cost.c measures seconds per estimated ray per scene).
 *
 * The unit is a plain ray: one ray through a scene whose BVH separates its
 * objects.  rays_per_sample = rays x per-ray cost factor, per camera sample:
 *
 *   Whitted (integrate.c): every ray that hits casts one shadow ray per
 *     point-like light and `samples` per area light (S in all), then, while
 *     depth < max_depth, a mirror ray (reflectivity) and, on glass, a
 *     refracted ray as well: the Fresnel split casts both.  So with glass
 *     in the scene a camera ray is the root of a binary tree of up to
 *     2^(D+1) - 1 rays (D = max_depth); with mirrors alone a chain of D + 1;
 *     else one.  Rays = tree x (1 + S).  The tree is a true bound, reached
 *     where glass sees glass (16 x 16 pixels of packed glass spheres cast
 *     280 rays a pixel at max_depth 8, 25,000 at 16 and 234,000 at 20
 *     against bounds of 1,022, 262,142 and 4.2 million with one light);
 *     a scene with one glass ball pays for the tree its pixels could cast.
 *   Path (integrate_path.c): each vertex casts a continuation ray and up to
 *     one shadow ray per light, one toward an emitter and one toward a
 *     sampled environment (next-event estimation).  Every path has up to 3
 *     vertices before Russian roulette (math/roulette.h: from bounce 2),
 *     then survives each bounce with chance 2 x its throughput beta,
 *     clamped to [0.05, 0.95], and beta is divided by that chance.  A
 *     bounce multiplies beta by at most a, the largest albedo any material
 *     can carry (1 for metals and mirrors, whose weights may pass their
 *     albedo), and a larger beta never shortens what is left of a path, so
 *     the chain with a at every bounce (beta = a^3 at bounce 2) bounds the
 *     expected vertices: 3 + q2 + q2 q3 + ... up to max_depth, plus one
 *     (path_vertices).
 *   The per-ray factor: a ray's work is the primitives it must test.  For
 *     a BVH node, a ray that enters it enters each child with the chance
 *     area(child) / area(node) (a random line through a convex box crosses
 *     a convex box inside it in proportion to their surface areas, the SAH
 *     model), so the expected tests of a ray entering a node are
 *     sum(area ratio x child's tests).  Separated objects give about one or
 *     two tests; N boxes over one spot give N, wherever they are hidden,
 *     because the cost is the worst node's, not the root's average.  An
 *     instance's leaf costs its group's (recursively), a mesh its own BVH's,
 *     a CSG tree of L operands L tests and, at each of the up to 4L + 1 runs
 *     of their crossings, a point test of every operand (scene_query.c:
 *     L^2 in all, the tree's whole cost, SCENE_CSG_TESTS_A_RAY point tests
 *     a ray's worth), and every unbounded object (a plane) one test for
 *     every ray.  Tests up to RAY_TESTS_FREE are what a plain ray
 *     already costs; past it the factor grows linearly.  It is computed once
 *     when the scene is frozen (scene_cost_freeze), in one walk of the BVHs.
 *
 * rayd-render --stats prints the estimate beside the rays really cast.  On
 * the example scenes without glass it is 1.2 to 4 times the rays cast (a
 * shadow ray for every light at every pixel, even where the camera sees the
 * background); with glass the tree bound overcounts more (whitted.json's
 * single glass sphere: about 70 times).  The server's seconds follow each
 * scene's measured rate, so only --max-work (in these units) sees it.
 */
#include <math.h>
#include <stdlib.h>

#include "math/roulette.h"
#include "scene/scene.h"

#define PATH_FREE_BOUNCES ((int)ROULETTE_FROM + 1) /* vertices before Russian roulette */
#define RAY_TESTS_FREE 4.0 /* primitive tests a plain ray makes, in the measured rate */
#define COST_DEPTH 64      /* nesting followed (groups, CSG), and BVH depth */
#define COST_MAX 1e30      /* a cap that keeps the products finite and printable */

/* ---- the per-ray factor ------------------------------------------------------------- */

struct cost_walk {
    const struct rayd_scene *s;
    double *group_cost; /* memo per group: < 0 not yet known */
    double *mesh_cost;  /* memo per mesh */
};

/* A tree of either width, as the cost walk reads it. */
struct cost_tree {
    const void *nodes;
    uint32_t nnodes;
    int width;
    struct bbox bounds;
};

static double bbox_area(const struct bbox *b) {
    double dx = (double)b->hi[0] - b->lo[0], dy = (double)b->hi[1] - b->lo[1],
           dz = (double)b->hi[2] - b->lo[2];
    return dx >= 0 && dy >= 0 && dz >= 0 ? 2 * (dx * dy + dy * dz + dz * dx) : 0;
}

static double object_tests(struct cost_walk *w, const struct object *o, int depth);

/* The leaf's primitives, for a BVH over objects (objs) or a mesh (NULL: a
 * leaf's one or two 4-triangle blocks, tested at once). */
static double leaf_tests(struct cost_walk *w, const struct object *objs, uint32_t first, int count,
                         int depth) {
    if (!objs) return 1;
    double t = 0;
    for (int k = 0; k < count; k++) t += object_tests(w, &objs[first + k], depth);
    return t;
}

/* Expected tests of a ray entering node n (of box area `area`); *worst
 * gets the largest over the subtree. */
static double node_tests(struct cost_walk *w, const struct cost_tree *b, const struct object *objs,
                         uint32_t n, double area, int depth, int bdepth, double *worst) {
    if (n >= b->nnodes || bdepth > COST_DEPTH) return 1;
    double sum = 0;
    for (int i = 0; i < b->width; i++) {
        struct bbox box;
        uint32_t child;
        uint8_t count;
        bvh_node_child(b->nodes, b->width, n, i, &box, &child, &count);
        if (!((double)box.hi[0] - box.lo[0] >= 0 && (double)box.hi[1] - box.lo[1] >= 0 &&
              (double)box.hi[2] - box.lo[2] >= 0))
            continue; /* an empty slot (inverted box) */
        double ca = bbox_area(&box);
        double p = area > 0 ? fmin(1, ca / area) : 1;
        double c = count ? leaf_tests(w, objs, child, count, depth)
                         : node_tests(w, b, objs, child, ca, depth, bdepth + 1, worst);
        sum = fmin(COST_MAX, sum + p * c);
    }
    if (sum > *worst) *worst = sum;
    return sum;
}

/* A BVH's cost: the expected tests of a ray in its worst node. */
static double bvh_tests(struct cost_walk *w, const struct cost_tree *b, const struct object *objs,
                        int depth) {
    if (!b->nodes || b->nnodes == 0) return 0;
    double worst = 0;
    node_tests(w, b, objs, 0, bbox_area(&b->bounds), depth, 0, &worst);
    return worst;
}

/* A CSG tree's operands: the shapes at its leaves, through its nested
 * nodes however deep (the query's own recursion goes as deep). */
static double csg_leaves(const struct rayd_scene *s, const struct object *o) {
    if (o->kind != SHAPE_CSG) return 1;
    double n = 0;
    int32_t side[2] = {o->u.csg.left, o->u.csg.right};
    for (int k = 0; k < 2; k++)
        if (side[k] >= 0 && side[k] < s->nparts) n += csg_leaves(s, &s->parts[side[k]]);
    return n;
}

static double object_tests(struct cost_walk *w, const struct object *o, int depth) {
    const struct rayd_scene *s = w->s;
    if (depth > COST_DEPTH) return 1;
    if (o->kind == SHAPE_INSTANCE && o->u.inst.group >= 0 && o->u.inst.group < s->ngroups) {
        double *memo = w->group_cost ? &w->group_cost[o->u.inst.group] : NULL;
        if (memo && *memo >= 0) return *memo;
        const struct group *g = &s->groups[o->u.inst.group];
        struct cost_tree t = {g->bvh.nodes, g->bvh.nnodes, 4, g->bvh.bounds};
        double c = fmax(1, bvh_tests(w, &t, g->objs, depth + 1));
        if (memo) *memo = c;
        return c;
    }
    if (o->kind == SHAPE_MESH && o->u.mesh.id < s->nmeshes) {
        double *memo = w->mesh_cost ? &w->mesh_cost[o->u.mesh.id] : NULL;
        if (memo && *memo >= 0) return *memo;
        const struct bvh8 *mb = &s->meshes[o->u.mesh.id].bvh;
        struct cost_tree t = {mb->nodes, mb->nnodes, 8, mb->bounds};
        double c = fmax(1, bvh_tests(w, &t, NULL, depth + 1));
        if (memo) *memo = c;
        return c;
    }
    if (o->kind == SHAPE_CSG) { /* its operands' tests, and at each run its point tests */
        double l = csg_leaves(s, o);
        double runs = SHAPE_MAX_XINGS * l + 1;
        double c = l + runs * l * (RAY_TESTS_FREE / SCENE_CSG_TESTS_A_RAY);
        return fmin(COST_MAX, fmax(1, c));
    }
    return 1;
}

static double *memo_new(long n) {
    double *m = n > 0 ? malloc(sizeof *m * (size_t)n) : NULL;
    for (long i = 0; m && i < n; i++) m[i] = -1;
    return m;
}

void scene_cost_freeze(struct rayd_scene *s) {
    struct cost_walk w = {s, memo_new(s->ngroups), memo_new((long)s->nmeshes)};
    /* Without memory for the memos each instance walks its group again: the
     * same answer, only slower. */
    struct cost_tree top = {s->tlas.nodes, s->tlas.nnodes, 4, s->tlas.bounds};
    s->ray_tests = bvh_tests(&w, &top, s->objs, 0);
    free(w.group_cost);
    free(w.mesh_cost);
}

/* One ray's work in plain rays. */
static double ray_factor(const struct rayd_scene *s) {
    double tests = s->ray_tests + s->nplanes;
    return tests > RAY_TESTS_FREE ? tests / RAY_TESTS_FREE : 1.0;
}

/* ---- the rays ---------------------------------------------------------------------- */

/* Shadow rays a shading point casts, over all lights. */
static double shadow_rays(const struct rayd_scene *s) {
    double n = 0;
    for (int i = 0; i < s->nlights; i++)
        n += s->lights[i].kind == LIGHT_AREA ? s->lights[i].samples : 1;
    return n;
}

/* Whitted: rays that hit (or may) per camera sample, the tree's nodes. */
static double whitted_tree(const struct rayd_scene *s) {
    bool mirror = false, glass = false;
    for (int i = 0; i < s->nmats; i++) {
        mirror |= s->mats[i].reflectivity > 0;
        glass |= s->mats[i].transparency > 0;
    }
    int d = s->rs.max_depth > 0 ? s->rs.max_depth : 0;
    if (glass) return fmin(COST_MAX, ldexp(1.0, d + 1 > 1000 ? 1000 : d + 1) - 1);
    return mirror ? d + 1.0 : 1.0;
}

static double vmax(vec3 v) { return fmax(v.x, fmax(v.y, v.z)); }

/* Path: the largest share of a path's weight a bounce can keep. */
static double path_albedo(const struct rayd_scene *s) {
    double a = 0;
    for (int i = 0; i < s->nmats; i++) {
        const struct material *m = &s->mats[i];
        double c = m->texture >= 0 ? 1 : vmax(m->color);
        if (m->transparency > 0) a = fmax(a, c);
        if (m->reflectivity > 0 || m->metallic > 0) a = fmax(a, fmax(1, c));
        a = fmax(a, m->diffuse * c);
    }
    return a;
}

/* Path: expected vertices of a path, at most (the chain above). */
static double path_vertices(const struct rayd_scene *s) {
    int d = s->rs.max_depth > 0 ? s->rs.max_depth : 0;
    double v = d + 1 < PATH_FREE_BOUNCES ? d + 1 : PATH_FREE_BOUNCES;
    double a = path_albedo(s), beta = 1, alive = 1;
    for (int b = 0; b < PATH_FREE_BOUNCES; b++) beta *= a; /* a^3 at bounce 2 */
    for (int b = PATH_FREE_BOUNCES; b <= d && alive > 1e-6; b++) {
        double q = roulette_chance(beta);
        alive *= q;
        v += alive;
        beta = fmin(1e6, beta / q * a); /* bounded: past 0.5 the chance is 0.95 anyway */
    }
    /* One vertex more: a room of albedo 0.95 reaches the chain's mean (every
     * chance 0.95 from bounce 2), and a render's paths wander above their
     * mean by a standard error or so (3% over test_scene_cost's 512). */
    return v + 1;
}

double scene_rays_per_sample(const struct rayd_scene *s) {
    double rays;
    if (s->rs.integrator == INTEGRATOR_WHITTED) {
        rays = whitted_tree(s) * (1.0 + shadow_rays(s));
    } else {
        double nee = s->nlights + (s->nemitters > 0 ? 1 : 0) + (env_can_sample(&s->rs.env) ? 1 : 0);
        rays = path_vertices(s) * (1.0 + nee);
    }
    return fmin(COST_MAX, rays * ray_factor(s));
}
