/* scene_query.c -- the one-ray queries the tracer makes of a frozen scene:
 * nearest hit, what a shadow ray lets through, and the surface at a hit.
 *
 * Levels, like Embree's and OptiX's: a top-level BVH over objects (spheres,
 * boxes, tori, mesh references, CSG trees, instances of groups) and, inside
 * each mesh and each group, a BVH of its own.  An object may carry a
 * transform; a ray meets it in object space (origin and direction by the
 * inverse transform, the direction renormalised and t rescaled), so a mesh
 * or a group drawn a thousand times is stored once.  Unbounded objects
 * (planes, quadrics) are tested one by one beside the BVH.  A scene of a
 * few objects (a room, a box and a sphere) has no top-level walk: its
 * objects' boxes are tested all at once (flat_walk), since nearly every
 * ray would descend into most of a small tree's nodes anyway.
 *
 * CSG follows Roth (1982): every operand's crossings with the ray's line
 * are merged in order, and the tree's point-in-solid test, evaluated
 * between consecutive crossings, tells which of them are surfaces of the
 * result and whether the ray enters or leaves it there.  Crossings at one
 * point of the line (a face two operands share) are crossed together, so a
 * union of boxes that touch has no face inside it.  Transforms inside
 * a CSG tree are composed down to its leaves at load time.  A CSG node's
 * operands are objects like any other, so CSG and the hits call each other
 * and live together here.
 *
 * The nearest-hit search is order-free (scene_query.h), so the 16-ray
 * packets of scene_packet.c give every ray this file's answer.
 *
 * A ray's cost is bounded by the scene's size but can still be seconds (a
 * ray through 20,000 instances of a 20,000-object group that all overlap
 * it): so the walks look at the render's meter (base/meter.h) at every
 * instance, every CSG hit and every few thousand objects met, and once it
 * is stopped they return at once, with no hit -- the render is being
 * thrown away.
 */
#include "scene/scene_query.h"

#include <stdlib.h>
#include <string.h>

#include "base/meter.h"
#include "scene/scene.h"
#include "shade/texture.h"

/* Crossings a CSG hit keeps on the stack: those of 64 solids.  A tree with
 * more (nesting has no limit) whose solids a ray crosses more often takes a
 * buffer of the size it needs from the heap for that ray: a crossing
 * dropped could be the nearest surface. */
#define CSG_STACK_XINGS (64 * SHAPE_MAX_XINGS)

/* How often a ray's own work looks at the render's meter (meter.h): every
 * so many objects met in one BVH walk (thousands of objects overlapping
 * where the ray goes, or a row it threads), when the visits past the
 * walk's free ones are counted too (meter_visits); every so many runs of
 * CSG crossings (each one evaluates the whole tree).  Every instance and
 * every CSG hit looks too. */
#define SCENE_LOOK_VISITS 4096
#define SCENE_LOOK_RUNS 16

/* ---- object space ---------------------------------------------------------- */

ray object_ray_xform(const rayd_scene *s, const struct object *o, const ray *r, double *scale) {
    const struct xform *x = &s->xforms[o->xform];
    vec3 d = xform_inv_dir(x, r->d);
    double len = v3_len(d);
    ray lr = {xform_inv_point(x, r->o), v3_scale(d, 1.0 / len)};
    *scale = len;
    return lr;
}

/* ---- CSG ----------------------------------------------------------------------- */

struct cx {
    double t;
    const struct object *leaf;
    int part;
};

/* Whether p is inside the tree at o; *tests counts the operands tested. */
static bool csg_inside(const rayd_scene *s, const struct object *o, vec3 p, uint64_t *tests) {
    if (o->kind == SHAPE_CSG) {
        bool a = csg_inside(s, &s->parts[o->u.csg.left], p, tests);
        if (o->u.csg.op == CSG_UNION && a) return true;
        if (o->u.csg.op != CSG_UNION && !a) return false;
        bool b = csg_inside(s, &s->parts[o->u.csg.right], p, tests);
        return o->u.csg.op == CSG_DIFFERENCE ? !b : b;
    }
    ++*tests;
    vec3 q = o->xform >= 0 ? xform_inv_point(&s->xforms[o->xform], p) : p;
    return shape_ops[o->kind]->inside(o, q);
}

/* Appends o's crossings with r to out[n..cap) and returns the count they
 * make; past cap they are counted, not kept, so the caller learns the
 * room it needs. */
static int csg_collect(const rayd_scene *s, const struct object *o, const ray *r, struct cx *out,
                       int n, int cap) {
    if (o->kind == SHAPE_CSG) {
        n = csg_collect(s, &s->parts[o->u.csg.left], r, out, n, cap);
        return csg_collect(s, &s->parts[o->u.csg.right], r, out, n, cap);
    }
    double scale;
    ray lr = object_ray(s, o, r, &scale);
    struct xing x[SHAPE_MAX_XINGS];
    int k = shape_ops[o->kind]->crossings(o, &lr, x);
    for (int i = 0; i < k; i++, n++)
        if (n < cap) out[n] = (struct cx){x[i].t / scale, o, x[i].part};
    return n;
}

static int cmp_cx(const void *a, const void *b) {
    double x = ((const struct cx *)a)->t, y = ((const struct cx *)b)->t;
    return (x > y) - (x < y);
}

/* The end of the run of crossings from i on that lie at one point of the
 * line (within rounding): the faces two operands share, or an operand's
 * face lying in another's.  The state between them says nothing, so the
 * run is crossed as one. */
static int csg_run_end(const struct cx *x, int n, int i) {
    int j = i + 1;
    while (j < n && x[j].t - x[i].t <= 1e-9 * (1 + fabs(x[i].t))) j++;
    return j;
}

/* Point tests between two counts on the meter: a few rays' worth. */
#define CSG_COUNT_TESTS (64 * SCENE_CSG_TESTS_A_RAY)

/* Counts a CSG hit's point tests on the render's meter, in whole rays'
 * worth (the rest stays in *tests for the next count); false when the
 * render stopped. */
static bool csg_count(uint64_t *tests) {
    uint64_t rays = *tests / SCENE_CSG_TESTS_A_RAY;
    *tests %= SCENE_CSG_TESTS_A_RAY;
    return meter_work(rays) && meter_live();
}

/* The surface of the result nearest along r within *tmax, from the
 * sorted crossings x[0..n).  Each run of crossings evaluates the whole
 * tree: n runs of an n-operand tree cost n^2 point tests, counted on the
 * render's meter as they go, so a budget sees them (meter.h). */
static bool csg_nearest(const rayd_scene *s, const struct object *o, const ray *r, struct cx *x,
                        int n, double *tmax, struct hit *h) {
    qsort(x, (size_t)n, sizeof *x, cmp_cx);
    uint64_t tests = 0;
    bool before = csg_inside(s, o, ray_at(r, x[0].t - (1 + fabs(x[0].t))), &tests);
    for (int i = 0, j, runs = 0; i < n && x[i].t < *tmax; i = j) {
        if ((++runs % SCENE_LOOK_RUNS == 0 || tests >= CSG_COUNT_TESTS) && !csg_count(&tests))
            return false;
        j = csg_run_end(x, n, i);
        double ta = j < n ? 0.5 * (x[i].t + x[j].t) : x[i].t + (1 + fabs(x[i].t));
        bool after = csg_inside(s, o, ray_at(r, ta), &tests);
        if (after != before && x[i].t > 0) {
            *tmax = x[i].t;
            h->t = x[i].t;
            h->leaf = x[i].leaf;
            h->part = x[i].part;
            h->orient = after ? 1 : -1;
            csg_count(&tests); /* a stop is seen at the meter's next look */
            return true;
        }
        before = after;
    }
    csg_count(&tests);
    return false;
}

static bool csg_hit(const rayd_scene *s, const struct object *o, const ray *r, double *tmax,
                    struct hit *h) {
    struct cx stack[CSG_STACK_XINGS], *x = stack;
    if (!meter_live()) return false; /* the render stopped: no more work */
    int n = csg_collect(s, o, r, x, 0, CSG_STACK_XINGS);
    if (n == 0) return false;
    if (n > CSG_STACK_XINGS) {
        x = malloc((size_t)n * sizeof *x);
        if (!x) return false; /* out of memory: this ray misses the object */
        csg_collect(s, o, r, x, 0, n);
    }
    bool hit = csg_nearest(s, o, r, x, n, tmax, h);
    if (x != stack) free(x);
    return hit;
}

/* ---- hits ---------------------------------------------------------------------- */

static bool objects_hit(const rayd_scene *s, const struct object *objs, int32_t nobjs,
                        const struct bvh4 *bvh, const struct xform *outer, const ray *r,
                        double *tmax, struct hit *h);

/* Object space hit t_obj back in world units: kept if nearer than *tmax. */
static bool world_take(double t_obj, double scale, double *tmax) {
    double t = t_obj / scale;
    if (!(t < *tmax)) return false;
    *tmax = t;
    return true;
}

/* object_hit of a mesh. */
__attribute__((always_inline)) static inline bool
mesh_object_hit(const rayd_scene *s, const struct object *o, const struct xform *outer,
                const ray *r, double *tmax, struct hit *h) {
    double scale;
    ray buf;
    const ray *lr = object_ray_at(s, o, r, &buf, &scale);
    double lmax = object_space_bound(*tmax, scale);
    struct mesh_hit mh;
    const struct mesh *m = &s->meshes[o->u.mesh.id];
    bool hit = s->brute ? mesh_intersect_brute(m, lr, lmax, &mh) : mesh_intersect(m, lr, lmax, &mh);
    return hit && object_mesh_hit(o, outer, &mh, scale, tmax, h);
}

/* Nearest hit of one object closer than *tmax: updates *tmax and h. */
__attribute__((always_inline)) static inline bool
object_hit(const rayd_scene *s, const struct object *o, const struct xform *outer, const ray *r,
           double *tmax, struct hit *h) {
    if (o->kind == SHAPE_MESH) return mesh_object_hit(s, o, outer, r, tmax, h);
    double scale, t;
    ray lr = object_ray(s, o, r, &scale); /* by value: the shapes' tests keep it in registers */
    double lmax = object_space_bound(*tmax, scale);
    switch (o->kind) {
    case SHAPE_CSG:
        if (!csg_hit(s, o, &lr, &lmax, h) || !world_take(lmax, scale, tmax)) return false;
        h->t = *tmax;
        h->outer = outer;
        return true;
    case SHAPE_INSTANCE: {
        const struct group *g = &s->groups[o->u.inst.group];
        /* the rays through many instances that overlap walk a BVH each:
         * unbounded but for this look (meter.h) */
        if (!meter_live()) return false;
        if (!objects_hit(s, g->objs, g->nobjs, &g->bvh, &s->xforms[o->xform], &lr, &lmax, h) ||
            !world_take(lmax, scale, tmax))
            return false;
        h->t = *tmax;
        return true;
    }
    case SHAPE_SPHERE: /* the commonest kinds without the crossing list */
        if (!sphere_nearest(o, &lr, lmax, &t)) return false;
        h->part = 0;
        break;
    case SHAPE_PLANE:
        if (!plane_nearest(o, &lr, lmax, &t)) return false;
        h->part = 0;
        break;
    case SHAPE_QUAD:
        if (!quad_nearest(o, &lr, lmax, &t)) return false;
        h->part = 0;
        break;
    case SHAPE_BOX:
        if (!box_nearest(o, &lr, lmax, &t, &h->part)) return false;
        break;
    default:
        if (!shape_hit(o, &lr, 0, lmax, &t, &h->part)) return false;
    }
    if (!world_take(t, scale, tmax)) return false;
    h->t = *tmax;
    h->leaf = o;
    h->outer = outer;
    h->orient = 0;
    return true;
}

/* Calls visit for every object of objs whose BVH box the ray enters before
 * *tmax, nearest boxes first, until visit returns false.  visit may shrink
 * *tmax (a nearest-hit search) and so prune the rest of the walk.  With
 * brute (tests) or a single object, every object is visited in order. */
typedef bool (*visit_fn)(void *ctx, const struct object *o, double *tmax);

/* The objects one walk visited, and of those past METER_VISITS_FREE how
 * many are on the render's meter already. */
struct walk_tally {
    uint32_t visits, charged;
};

/* Charges the walk's visits past METER_VISITS_FREE not charged yet, a ray
 * each (meter.h), then looks at the meter; false when the render stopped. */
static bool walk_charge(struct walk_tally *w) {
    uint32_t over = w->visits > METER_VISITS_FREE ? w->visits - METER_VISITS_FREE : 0;
    bool going = meter_work(over - w->charged) && meter_live();
    w->charged = over;
    return going;
}

/* Always inlined: each caller passes a constant visit, so the compiler
 * makes one walk per visitor with the visitor's body in the leaf loop, not
 * an indirect call per object (the walk is a hot path: every ray).  The
 * visits are counted in *w, and charged every SCENE_LOOK_VISITS. */
__attribute__((always_inline)) static inline void
objects_walk_tally(const struct object *objs, int32_t n, const struct bvh4 *bvh, bool brute,
                   const ray *r, double *tmax, visit_fn visit, void *ctx, struct walk_tally *w) {
    if (brute || n <= 1) {
        for (int32_t i = 0; i < n; i++, w->visits++)
            if (!visit(ctx, &objs[i], tmax)) return;
        return;
    }
    struct bvh_ray br;
    bvh_ray_init(&br, r->o, r->d);
    struct bvh_entry stack[BVH_STACK], e = {0, 0, 0};
    int sp = 0;
    for (;;) {
        float tm = *tmax > 3e38 ? 3e38f : (float)*tmax * BVH_SLACK;
        if (e.count == 0) {
            if (bvh4_descend(bvh->nodes, &e, &br, tm, stack, &sp, BVH_SORTED)) continue;
        } else {
            for (uint32_t i = e.node; i < e.node + e.count; i++) {
                if (++w->visits % SCENE_LOOK_VISITS == 0 && !walk_charge(w)) return;
                if (!visit(ctx, &objs[i], tmax)) return;
            }
        }
        do { /* pop the next entry still in reach */
            if (sp == 0) return;
            e = stack[--sp];
        } while (e.tnear > *tmax * BVH_SLACK);
    }
}

/* The walk, its visits past METER_VISITS_FREE charged as a ray each: the
 * count of one walk, whatever the order of the render's rays.  Only a walk
 * past the free ones touches the meter. */
__attribute__((always_inline)) static inline void objects_walk(const struct object *objs, int32_t n,
                                                               const struct bvh4 *bvh, bool brute,
                                                               const ray *r, double *tmax,
                                                               visit_fn visit, void *ctx) {
    struct walk_tally w = {0, 0};
    objects_walk_tally(objs, n, bvh, brute, r, tmax, visit, ctx, &w);
    if (w.visits > METER_VISITS_FREE) walk_charge(&w);
}

/* objects_walk over s->flat (a scene of few objects, scene.c): every box
 * tested at once, then the objects whose box the ray enters visited
 * nearest first, as long as they are within reach (the walk's pruning
 * rule).  The order differs from the walk's, so only for visitors whose
 * answer does not depend on it: the nearest hit, and a shadow that any
 * surface blocks. */
__attribute__((always_inline)) static inline void flat_walk(const rayd_scene *s, const ray *r,
                                                            double *tmax, uint32_t skip,
                                                            visit_fn visit, void *ctx) {
    struct bvh_ray br;
    bvh_ray_init(&br, r->o, r->d);
    float tm = *tmax > 3e38 ? 3e38f : (float)*tmax * BVH_SLACK;
    struct bvh_entry in[SCENE_FLAT_MAX];
    int n = 0;
    for (uint32_t k = 0; k < s->nflat; k++) {
        float tn[4];
        int mask = bvh4_test(&s->flat[k], &br, 0, tm, tn);
        if (skip >> 2 == k) mask &= ~(1 << (skip & 3));
        while (mask) { /* insertion, nearest first */
            int c = __builtin_ctz((unsigned)mask), j = n++;
            mask &= mask - 1;
            for (; j > 0 && in[j - 1].tnear > tn[c]; j--) in[j] = in[j - 1];
            in[j].node = 4 * k + (uint32_t)c;
            in[j].tnear = tn[c];
        }
    }
    for (int j = 0; j < n && !(in[j].tnear > *tmax * BVH_SLACK); j++)
        if (!visit(ctx, &s->objs[in[j].node], tmax)) return;
}

/* A scene whose one bounded object is a mesh in world space, which the
 * query does not leave: its walk's root test is the flat walk's box test,
 * so the mesh is walked at once, one level as such a scene has in Embree
 * (5-20% faster rays on bench/'s meshes, bench/README.md). */
static bool lone_mesh(const rayd_scene *s, uint32_t skip) {
    return s->nobjs == 1 && skip != 0 && s->objs[0].kind == SHAPE_MESH && s->objs[0].xform < 0;
}

/* flat_walk for a shadow that any surface blocks: the objects in their
 * order, no sorting (a blocker found first or last blocks the same). */
static void flat_any(const rayd_scene *s, const ray *r, double tmax, uint32_t skip, visit_fn visit,
                     void *ctx) {
    struct bvh_ray br;
    bvh_ray_init(&br, r->o, r->d);
    float tm = tmax > 3e38 ? 3e38f : (float)tmax * BVH_SLACK;
    for (uint32_t k = 0; k < s->nflat; k++) {
        float tn[4];
        int mask = bvh4_test(&s->flat[k], &br, 0, tm, tn);
        if (skip >> 2 == k) mask &= ~(1 << (skip & 3));
        for (; mask; mask &= mask - 1) {
            int c = __builtin_ctz((unsigned)mask);
            if (!(tn[c] > tmax * BVH_SLACK) && !visit(ctx, &s->objs[4 * k + (uint32_t)c], &tmax))
                return;
        }
    }
}

void nearest_take(struct nearest *c, const struct object *o, double t, const struct hit *h,
                  double *tmax) {
    if (t > *tmax) return;
    *tmax = t;
    *c->h = *h;
    c->best = nearest_rank(c, o);
}

/* nearest_visit, inlined into the top level's walks. */
__attribute__((always_inline)) static inline bool visit_nearest(void *ctx, const struct object *o,
                                                                double *tmax) {
    struct nearest *c = ctx;
    double t = nearest_bound(c, o, *tmax);
    struct hit h;
    if (object_hit(c->s, o, c->outer, c->r, &t, &h)) nearest_take(c, o, t, &h, tmax);
    return true;
}

bool nearest_visit(void *ctx, const struct object *o, double *tmax) {
    return visit_nearest(ctx, o, tmax);
}

/* Nearest hit among objs (with their BVH) closer than *tmax. */
static bool objects_hit(const rayd_scene *s, const struct object *objs, int32_t nobjs,
                        const struct bvh4 *bvh, const struct xform *outer, const ray *r,
                        double *tmax, struct hit *h) {
    struct nearest c = {s, outer, r, h, objs, 0, -1};
    objects_walk(objs, nobjs, bvh, s->brute, r, tmax, nearest_visit, &c);
    return c.best >= 0;
}

/* The top level's search, passing over objs[skip] (none: skip out of
 * range, SCENE_NO_LEAVE). */
struct nearest_top {
    struct nearest c;
    const struct object *skip;
};

__attribute__((always_inline)) static inline bool
visit_nearest_top(void *ctx, const struct object *o, double *tmax) {
    struct nearest_top *t = ctx;
    return o == t->skip || visit_nearest(&t->c, o, tmax);
}

__attribute__((always_inline)) static inline bool
intersect_top(const rayd_scene *s, const ray *r, double tmax, uint32_t skip, struct hit *h) {
    /* h is written, never read, by the search: */
    // cppcheck-suppress ctuuninitvar
    struct nearest c = {s, NULL, r, h, s->planes, 0, -1};
    for (int32_t i = 0; i < s->nplanes; i++) visit_nearest(&c, &s->planes[i], &tmax);
    c.base = s->objs;
    c.rank0 = s->nplanes;
    if (lone_mesh(s, skip)) {
        visit_nearest(&c, &s->objs[0], &tmax);
        return c.best >= 0;
    }
    if (s->flat && !s->brute) {
        flat_walk(s, r, &tmax, skip, visit_nearest, &c);
        return c.best >= 0;
    }
    if (skip >= (uint32_t)s->nobjs) {
        objects_walk(s->objs, s->nobjs, &s->tlas, s->brute, r, &tmax, visit_nearest, &c);
        return c.best >= 0;
    }
    struct nearest_top t = {c, &s->objs[skip]};
    objects_walk(s->objs, s->nobjs, &s->tlas, s->brute, r, &tmax, visit_nearest_top, &t);
    return t.c.best >= 0;
}

bool scene_intersect(const rayd_scene *s, const ray *r, double tmax, struct hit *h) {
    return intersect_top(s, r, tmax, SCENE_NO_LEAVE, h);
}

bool scene_intersect_from(const rayd_scene *s, const ray *r, double tmax, uint32_t leave,
                          struct hit *h) {
    return intersect_top(s, r, tmax, leave, h);
}

/* Multiplies *trans by what material m lets through; false (stop) when
 * nothing passes any more.  A negative material: every surface blocks
 * (scene_occluded_from's test). */
static bool filter_light(const rayd_scene *s, int material, vec3 *trans) {
    const struct material *m = material >= 0 ? &s->mats[material] : NULL;
    if (!m || m->transparency <= 0) {
        *trans = v3(0, 0, 0);
        return false;
    }
    *trans = v3_mul(*trans, v3_scale(m->color, m->transparency));
    return v3_maxabs(*trans) > 0;
}

/* Any hit of object o closer than tmax, through its material's filter. */
bool object_filter(const rayd_scene *s, const struct object *o, const ray *r, double tmax,
                   vec3 *trans) {
    struct hit h;
    double t = tmax;
    if (o->kind == SHAPE_MESH && !s->brute) {
        double scale;
        ray buf;
        const ray *lr = object_ray_at(s, o, r, &buf, &scale);
        if (!mesh_occluded(&s->meshes[o->u.mesh.id], lr, tmax * scale)) return true;
        return filter_light(s, o->material, trans);
    }
    if (!object_hit(s, o, NULL, r, &t, &h)) return true;
    return filter_light(s, h.leaf->material, trans);
}

struct filter {
    const rayd_scene *s;
    const ray *r;
    vec3 trans;
    bool opaque;               /* every surface blocks, whatever its material */
    const struct object *skip; /* an object the ray cannot meet, or NULL */
};

/* Any hit of o closer than tmax blocks: false (stop), else true. */
static bool object_blocks_not(const rayd_scene *s, const struct object *o, const ray *r,
                              double tmax, vec3 *trans) {
    struct hit h;
    double t = tmax, scale;
    bool hit;
    if (o->kind == SHAPE_MESH && !s->brute) {
        ray buf;
        const ray *lr = object_ray_at(s, o, r, &buf, &scale);
        hit = mesh_occluded(&s->meshes[o->u.mesh.id], lr, tmax * scale);
    } else {
        hit = object_hit(s, o, NULL, r, &t, &h);
    }
    return hit ? filter_light(s, -1, trans) : true;
}

static bool visit_filter(void *ctx, const struct object *o, double *tmax) {
    struct filter *c = ctx;
    if (o == c->skip) return true;
    return c->opaque ? object_blocks_not(c->s, o, c->r, *tmax, &c->trans)
                     : object_filter(c->s, o, c->r, *tmax, &c->trans);
}

static vec3 scene_filter(const rayd_scene *s, const ray *r, double tmax, bool opaque,
                         uint32_t skip) {
    struct filter c = {s, r, v3(1, 1, 1), opaque, NULL};
    for (int32_t i = 0; i < s->nplanes; i++)
        if (!visit_filter(&c, &s->planes[i], &tmax)) return c.trans;
    if (lone_mesh(s, skip)) {
        visit_filter(&c, &s->objs[0], &tmax);
        return c.trans;
    }
    if (s->flat && !s->brute && (opaque || s->opaque)) { /* every hit blocks: any order */
        flat_any(s, r, tmax, skip, visit_filter, &c);
        return c.trans;
    }
    if (skip < (uint32_t)s->nobjs) c.skip = &s->objs[skip];
    objects_walk(s->objs, s->nobjs, &s->tlas, s->brute, r, &tmax, visit_filter, &c);
    return c.trans;
}

vec3 scene_transmittance(const rayd_scene *s, const ray *r, double tmax) {
    return scene_filter(s, r, tmax, false, SCENE_NO_LEAVE);
}

vec3 scene_transmittance_from(const rayd_scene *s, const ray *r, double tmax, uint32_t leave) {
    return scene_filter(s, r, tmax, false, leave);
}

bool scene_occluded_from(const rayd_scene *s, const ray *r, double tmax, uint32_t leave) {
    return v3_maxabs(scene_filter(s, r, tmax, true, leave)) == 0;
}

/* ---- surfaces ------------------------------------------------------------------ */

/* A baked plane's texture point and (u, v) in its own space, from the plane
 * as loaded: its placement is baked into the one hit, not the pattern. */
static void plane_texture_space(const rayd_scene *s, const struct object *o, vec3 pw, vec3 *po,
                                double *u, double *v) {
    const struct object *src = &s->planes_src[o - s->planes];
    const struct xform *x = src->xform >= 0 && s->xforms ? &s->xforms[src->xform] : NULL;
    *po = x ? xform_inv_point(x, pw) : pw;
    plane_ops.uv(src, *po, 0, u, v);
}

void scene_surface(const rayd_scene *s, const ray *r, const struct hit *h, struct surface *sf) {
    const struct object *o = h->leaf;
    const struct xform *x = o->xform >= 0 ? &s->xforms[o->xform] : NULL;
    sf->m = &s->mats[o->material];
    sf->thin = o->kind == SHAPE_PLANE || (!shape_is_solid(o) && o->kind != SHAPE_MESH);
    sf->float_geom = o->kind == SHAPE_MESH;
    vec3 pw = ray_at(r, h->t);
    /* back to the leaf's own space: through the instance, then the leaf */
    vec3 p = h->outer ? xform_inv_point(h->outer, pw) : pw, pm = p;
    if (x) p = xform_inv_point(x, p);
    vec3 n, ng;
    double u = 0, v = 0;
    bool textured = sf->m->texture >= 0; /* uv costs trigonometry: only when used */
    if (o->kind == SHAPE_MESH) {
        const struct mesh *m = &s->meshes[o->u.mesh.id];
        p = mesh_point(m, &h->mh);
        ng = mesh_geometric_normal(m, &h->mh);
        n = m->normal ? mesh_shading_normal(m, &h->mh) : ng; /* not its square root twice */
        if (textured) mesh_uv(m, &h->mh, &u, &v);
    } else {
        /* a quad's without the call through the table */
        n = ng = o->kind == SHAPE_QUAD ? o->u.quad.n : shape_ops[o->kind]->normal(o, p, h->part);
        if (textured) shape_ops[o->kind]->uv(o, p, h->part, &u, &v);
    }
    vec3 po = p; /* object space, for object-space textures */
    if (textured && o->kind == SHAPE_PLANE && o->u.plane.baked)
        plane_texture_space(s, o, pw, &po, &u, &v);
    const struct xform *tx = o->tex_xform > 0 && s->xforms ? &s->xforms[o->tex_xform - 1] : NULL;
    if (tx) po = xform_inv_point(tx, pm); /* the space of the csg node whose material it is */
    if (x) {
        p = xform_point(x, p);
        n = xform_normal(x, n);
        ng = xform_normal(x, ng);
    }
    if (h->outer) {
        p = xform_point(h->outer, p);
        n = xform_normal(h->outer, n);
        ng = xform_normal(h->outer, ng);
    }
    if (h->orient && (v3_dot(ng, r->d) < 0) != (h->orient > 0)) { /* CSG: point out of the result */
        n = v3_neg(n);
        ng = v3_neg(ng);
    }
    sf->p = o->kind == SHAPE_MESH ? p : pw;
    sf->n = n;
    sf->ng = ng;
    sf->color = sf->m->texture >= 0 ? texture_color(&s->textures[sf->m->texture], po, sf->p, u, v)
                                    : sf->m->color;
}
