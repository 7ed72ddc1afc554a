/* scene.c -- the frozen scene and the queries the tracer makes of it.
 *
 * Levels, like Embree's and OptiX's: a top-level BVH over objects (spheres,
 * boxes, tori, mesh references, CSG trees, instances of groups) and, inside
 * each mesh and each group, a BVH of its own.  An object may carry a
 * transform; a ray meets it in object space (origin and direction by the
 * inverse transform, the direction renormalised and t rescaled), so a mesh
 * or a group drawn a thousand times is stored once.  Unbounded objects
 * (planes, quadrics) are tested one by one beside the BVH.
 *
 * CSG follows Roth (1982): every operand's crossings with the ray's line
 * are merged in order, and the tree's point-in-solid test, evaluated
 * between consecutive crossings, tells which of them are surfaces of the
 * result and whether the ray enters or leaves it there.  Transforms inside
 * a CSG tree are composed down to its leaves at load time.
 *
 * The loader (scene_json.c) fills a rayd_scene and freezes it once; after
 * that it is immutable and shared by every rendering thread through a const
 * pointer.
 */
#include "scene/scene.h"
#include "scene/scene_query.h"

#include <stdlib.h>
#include <string.h>

#include "base/clock.h"
#include "base/error.h"
#include "accel/light_buffer.h"
#include "shade/texture.h"

#define CSG_MAX_XINGS 128

enum rayd_status scene_alloc(rayd_scene **out, struct rayd_error *err) {
    rayd_scene *s = calloc(1, sizeof *s);
    if (!s) return err_set(err, RAYD_E_NOMEM, NULL, "out of memory");
    *out = s;
    return RAYD_OK;
}

void rayd_scene_free(rayd_scene *s) {
    if (!s) return;
    for (uint32_t i = 0; i < s->nmeshes; i++) mesh_free(&s->meshes[i]);
    for (int32_t i = 0; i < s->ngroups; i++) {
        free(s->groups[i].objs);
        bvh_free(&s->groups[i].bvh);
    }
    for (int i = 0; i < s->ntextures; i++) texture_free(&s->textures[i]);
    free(s->textures);
    env_free(&s->rs.env);
    free(s->groups);
    free(s->parts);
    free(s->meshes);
    free(s->xforms);
    free(s->mats);
    free(s->lights);
    free(s->objs);
    free(s->planes);
    free(s->emitters);
    bvh_free(&s->tlas);
    light_buffers_free(s->light_buffers, s->nlights);
    free(s);
}

/* ---- object space ---------------------------------------------------------- */

ray object_ray_xform(const rayd_scene *s, const struct object *o, const ray *r, double *scale) {
    const struct xform *x = &s->xforms[o->xform];
    vec3 d = xform_inv_dir(x, r->d);
    double len = v3_len(d);
    ray lr = {xform_inv_point(x, r->o), v3_scale(d, 1.0 / len)};
    *scale = len;
    return lr;
}

static struct aabb box_xform(const struct aabb *b, const struct xform *x) {
    if (!x) return *b;
    struct aabb w = {v3(INFINITY, INFINITY, INFINITY), v3(-INFINITY, -INFINITY, -INFINITY)};
    for (int c = 0; c < 8; c++) { /* the box around the transformed corners */
        vec3 p = v3(c & 1 ? b->hi.x : b->lo.x, c & 2 ? b->hi.y : b->lo.y, c & 4 ? b->hi.z : b->lo.z);
        p = xform_point(x, p);
        w.lo = v3_min(w.lo, p);
        w.hi = v3_max(w.hi, p);
    }
    return w;
}

/* World bounds of o; false when it is unbounded. */
bool scene_object_bounds(const rayd_scene *s, const struct object *o, struct aabb *out) {
    struct aabb b, l, r;
    switch (o->kind) {
    case SHAPE_MESH:
        b.lo = s->meshes[o->u.mesh.id].lo;
        b.hi = s->meshes[o->u.mesh.id].hi;
        break;
    case SHAPE_INSTANCE: b = s->groups[o->u.inst.group].bounds; break;
    case SHAPE_CSG: {
        bool bl = scene_object_bounds(s, &s->parts[o->u.csg.left], &l);
        bool br = scene_object_bounds(s, &s->parts[o->u.csg.right], &r);
        if (o->u.csg.op == CSG_DIFFERENCE) {
            if (!bl) return false;
            b = l;
        } else if (o->u.csg.op == CSG_UNION) {
            if (!bl || !br) return false;
            b.lo = v3_min(l.lo, r.lo);
            b.hi = v3_max(l.hi, r.hi);
        } else {
            if (!bl && !br) return false;
            b = !bl ? r : !br ? l : (struct aabb){v3_max(l.lo, r.lo), v3_min(l.hi, r.hi)};
            b.hi = v3_max(b.hi, b.lo); /* empty intersections stay valid boxes */
        }
        break;
    }
    default:
        if (!shape_ops[o->kind]->bounds) return false;
        b = shape_ops[o->kind]->bounds(o);
    }
    *out = box_xform(&b, o->xform >= 0 ? &s->xforms[o->xform] : NULL);
    return true;
}

/* ---- CSG ----------------------------------------------------------------------- */

struct cx {
    double t;
    const struct object *leaf;
    int part;
};

static bool csg_inside(const rayd_scene *s, const struct object *o, vec3 p) {
    if (o->kind == SHAPE_CSG) {
        bool a = csg_inside(s, &s->parts[o->u.csg.left], p);
        if (o->u.csg.op == CSG_UNION && a) return true;
        if (o->u.csg.op != CSG_UNION && !a) return false;
        bool b = csg_inside(s, &s->parts[o->u.csg.right], p);
        return o->u.csg.op == CSG_DIFFERENCE ? !b : b;
    }
    vec3 q = o->xform >= 0 ? xform_inv_point(&s->xforms[o->xform], p) : p;
    return shape_ops[o->kind]->inside(o, q);
}

static int csg_collect(const rayd_scene *s, const struct object *o, const ray *r, struct cx *out,
                       int n) {
    if (o->kind == SHAPE_CSG) {
        n = csg_collect(s, &s->parts[o->u.csg.left], r, out, n);
        return csg_collect(s, &s->parts[o->u.csg.right], r, out, n);
    }
    double scale;
    ray lr = object_ray(s, o, r, &scale);
    struct xing x[SHAPE_MAX_XINGS];
    int k = shape_ops[o->kind]->crossings(o, &lr, x);
    for (int i = 0; i < k && n < CSG_MAX_XINGS; i++) out[n++] = (struct cx){x[i].t / scale, o, x[i].part};
    return n;
}

static int cmp_cx(const void *a, const void *b) {
    double x = ((const struct cx *)a)->t, y = ((const struct cx *)b)->t;
    return (x > y) - (x < y);
}

static bool csg_hit(const rayd_scene *s, const struct object *o, const ray *r, double *tmax,
                    struct hit *h) {
    struct cx x[CSG_MAX_XINGS];
    int n = csg_collect(s, o, r, x, 0);
    if (n == 0) return false;
    qsort(x, (size_t)n, sizeof *x, cmp_cx);
    bool before = csg_inside(s, o, ray_at(r, x[0].t - (1 + fabs(x[0].t))));
    for (int i = 0; i < n && x[i].t < *tmax; i++) {
        double ta = i + 1 < n ? 0.5 * (x[i].t + x[i + 1].t) : x[i].t + (1 + fabs(x[i].t));
        bool after = csg_inside(s, o, ray_at(r, ta));
        if (after != before && x[i].t > 0) {
            *tmax = x[i].t;
            h->t = x[i].t;
            h->leaf = x[i].leaf;
            h->part = x[i].part;
            h->orient = after ? 1 : -1;
            return true;
        }
        before = after;
    }
    return false;
}

/* ---- hits ---------------------------------------------------------------------- */

static bool objects_hit(const rayd_scene *s, const struct object *objs, int32_t nobjs,
                        const struct bvh4 *bvh, const struct xform *outer, const ray *r,
                        double *tmax, struct hit *h);

bool object_mesh_hit(const struct object *o, const struct xform *outer,
                     const struct mesh_hit *mh, double scale, double *tmax, struct hit *h) {
    if (!((double)mh->t / scale < *tmax)) return false;
    h->mh = *mh;
    h->part = 0;
    *tmax = mh->t / scale;
    h->t = *tmax;
    h->leaf = o;
    h->outer = outer;
    h->orient = 0;
    return true;
}

/* Object space hit t_obj back in world units: kept if nearer than *tmax. */
static bool world_take(double t_obj, double scale, double *tmax) {
    double t = t_obj / scale;
    if (!(t < *tmax)) return false;
    *tmax = t;
    return true;
}

/* Nearest hit of one object closer than *tmax: updates *tmax and h. */
static bool object_hit(const rayd_scene *s, const struct object *o, const struct xform *outer,
                       const ray *r, double *tmax, struct hit *h) {
    double scale, t;
    ray lr = object_ray(s, o, r, &scale);
    double lmax = object_space_bound(*tmax, scale);
    switch (o->kind) {
    case SHAPE_MESH: {
        struct mesh_hit mh;
        const struct mesh *m = &s->meshes[o->u.mesh.id];
        bool hit = s->brute ? mesh_intersect_brute(m, &lr, lmax, &mh)
                            : mesh_intersect(m, &lr, lmax, &mh);
        return hit && object_mesh_hit(o, outer, &mh, scale, tmax, h);
    }
    case SHAPE_CSG:
        if (!csg_hit(s, o, &lr, &lmax, h) || !world_take(lmax, scale, tmax)) return false;
        h->t = *tmax;
        h->outer = outer;
        return true;
    case SHAPE_INSTANCE: {
        const struct group *g = &s->groups[o->u.inst.group];
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

static void objects_walk(const struct object *objs, int32_t n, const struct bvh4 *bvh, bool brute,
                         const ray *r, double *tmax, visit_fn visit, void *ctx) {
    if (brute || n <= 1) {
        for (int32_t i = 0; i < n; i++)
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
            if (bvh4_descend(bvh->nodes, &e, &br, tm, stack, &sp)) continue;
        } else {
            for (uint32_t i = e.node; i < e.node + e.count; i++)
                if (!visit(ctx, &objs[i], tmax)) return;
        }
        do { /* pop the nearest entry still in reach */
            if (sp == 0) return;
            e = stack[--sp];
        } while (e.tnear > *tmax * BVH_SLACK);
    }
}

void nearest_take(struct nearest *c, const struct object *o, double t, const struct hit *h,
                  double *tmax) {
    if (t > *tmax) return;
    *tmax = t;
    *c->h = *h;
    c->best = nearest_rank(c, o);
}

bool nearest_visit(void *ctx, const struct object *o, double *tmax) {
    struct nearest *c = ctx;
    double t = nearest_bound(c, o, *tmax);
    struct hit h;
    if (object_hit(c->s, o, c->outer, c->r, &t, &h)) nearest_take(c, o, t, &h, tmax);
    return true;
}

/* Nearest hit among objs (with their BVH) closer than *tmax. */
static bool objects_hit(const rayd_scene *s, const struct object *objs, int32_t nobjs,
                        const struct bvh4 *bvh, const struct xform *outer, const ray *r,
                        double *tmax, struct hit *h) {
    struct nearest c = {s, outer, r, h, objs, 0, -1};
    objects_walk(objs, nobjs, bvh, s->brute, r, tmax, nearest_visit, &c);
    return c.best >= 0;
}

bool scene_intersect(const rayd_scene *s, const ray *r, double tmax, struct hit *h) {
    /* h is written, never read, by the search: */
    // cppcheck-suppress ctuuninitvar
    struct nearest c = {s, NULL, r, h, s->planes, 0, -1};
    for (int32_t i = 0; i < s->nplanes; i++) nearest_visit(&c, &s->planes[i], &tmax);
    c.base = s->objs;
    c.rank0 = s->nplanes;
    objects_walk(s->objs, s->nobjs, &s->tlas, s->brute, r, &tmax, nearest_visit, &c);
    return c.best >= 0;
}

/* Multiplies *trans by what material m lets through; false (stop) when
 * nothing passes any more. */
static bool filter_light(const rayd_scene *s, int material, vec3 *trans) {
    const struct material *m = &s->mats[material];
    if (m->transparency <= 0) {
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
        ray lr = object_ray(s, o, r, &scale);
        if (!mesh_occluded(&s->meshes[o->u.mesh.id], &lr, tmax * scale)) return true;
        return filter_light(s, o->material, trans);
    }
    if (!object_hit(s, o, NULL, r, &t, &h)) return true;
    return filter_light(s, h.leaf->material, trans);
}

struct filter {
    const rayd_scene *s;
    const ray *r;
    vec3 trans;
};

static bool visit_filter(void *ctx, const struct object *o, double *tmax) {
    struct filter *c = ctx;
    return object_filter(c->s, o, c->r, *tmax, &c->trans);
}

vec3 scene_transmittance(const rayd_scene *s, const ray *r, double tmax) {
    struct filter c = {s, r, v3(1, 1, 1)};
    for (int32_t i = 0; i < s->nplanes; i++)
        if (!object_filter(s, &s->planes[i], r, tmax, &c.trans)) return c.trans;
    objects_walk(s->objs, s->nobjs, &s->tlas, s->brute, r, &tmax, visit_filter, &c);
    return c.trans;
}

/* ---- surfaces ------------------------------------------------------------------ */

void scene_surface(const rayd_scene *s, const ray *r, const struct hit *h, struct surface *sf) {
    const struct object *o = h->leaf;
    const struct xform *x = o->xform >= 0 ? &s->xforms[o->xform] : NULL;
    sf->m = &s->mats[o->material];
    sf->thin = o->kind == SHAPE_PLANE || (!shape_is_solid(o) && o->kind != SHAPE_MESH);
    sf->float_geom = o->kind == SHAPE_MESH;
    vec3 pw = ray_at(r, h->t);
    /* back to the leaf's own space: through the instance, then the leaf */
    vec3 p = h->outer ? xform_inv_point(h->outer, pw) : pw;
    if (x) p = xform_inv_point(x, p);
    vec3 n, ng;
    double u = 0, v = 0;
    bool textured = sf->m->texture >= 0; /* uv costs trigonometry: only when used */
    if (o->kind == SHAPE_MESH) {
        const struct mesh *m = &s->meshes[o->u.mesh.id];
        p = mesh_point(m, &h->mh);
        ng = mesh_geometric_normal(m, &h->mh);
        n = mesh_shading_normal(m, &h->mh);
        if (textured) mesh_uv(m, &h->mh, &u, &v);
    } else {
        n = ng = shape_ops[o->kind]->normal(o, p, h->part);
        if (textured) shape_ops[o->kind]->uv(o, p, h->part, &u, &v);
    }
    vec3 po = p; /* object space, for object-space textures */
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

/* ---- freeze ---------------------------------------------------------------------- */

/* Splits out unbounded objects; plane placements are baked in. */
static enum rayd_status split_unbounded(rayd_scene *s, struct rayd_error *err) {
    int32_t nb = 0, np = 0;
    struct aabb b;
    for (int32_t i = 0; i < s->nobjs; i++) np += !scene_object_bounds(s, &s->objs[i], &b);
    if (np == 0) return RAYD_OK;
    s->planes = malloc(sizeof *s->planes * (size_t)np);
    if (!s->planes) return err_set(err, RAYD_E_NOMEM, NULL, "out of memory");
    np = 0;
    for (int32_t i = 0; i < s->nobjs; i++) {
        struct object o = s->objs[i];
        if (scene_object_bounds(s, &o, &b)) {
            s->objs[nb++] = o;
            continue;
        }
        if (o.kind == SHAPE_PLANE && o.xform >= 0) {
            const struct xform *x = &s->xforms[o.xform];
            o.u.plane.point = xform_point(x, o.u.plane.point);
            o.u.plane.normal = xform_normal(x, o.u.plane.normal);
            o.xform = -1;
        }
        s->planes[np++] = o;
    }
    s->nobjs = nb;
    s->nplanes = np;
    return RAYD_OK;
}

enum rayd_status scene_build_bvh(const rayd_scene *s, struct object **objs, int32_t n,
                                 struct bvh4 *bvh, struct aabb *bounds, struct rayd_error *err) {
    /* zeroed: with no objects nothing is written to it, nor read, but gcc
     * cannot see the second and warns of the first */
    struct bbox *boxes = calloc((size_t)n + 1, sizeof *boxes);
    uint32_t *order = malloc(sizeof *order * ((size_t)n + 1));
    struct object *sorted = malloc(sizeof *sorted * ((size_t)n + 1));
    struct aabb all = {v3(INFINITY, INFINITY, INFINITY), v3(-INFINITY, -INFINITY, -INFINITY)};
    if (!boxes || !order || !sorted) {
        free(boxes);
        free(order);
        free(sorted);
        return err_set(err, RAYD_E_NOMEM, NULL, "out of memory building the scene");
    }
    for (int32_t i = 0; i < n; i++) {
        struct aabb b;
        scene_object_bounds(s, &(*objs)[i], &b);
        boxes[i] = bbox_from(b.lo, b.hi);
        all.lo = v3_min(all.lo, b.lo);
        all.hi = v3_max(all.hi, b.hi);
    }
    /* an object a leaf */
    enum rayd_status st = bvh_build(bvh, boxes, (uint32_t)n, 1, order, 1, err);
    if (st == RAYD_OK) {
        for (int32_t i = 0; i < n; i++) sorted[i] = (*objs)[order[i]];
        free(*objs);
        *objs = sorted;
        sorted = NULL;
        if (bounds) *bounds = all;
    }
    free(boxes);
    free(order);
    free(sorted);
    return st;
}

/* Emissive spheres, discs and quads without transforms: the path
 * tracer samples them directly. */
static enum rayd_status find_emitters(rayd_scene *s, struct rayd_error *err) {
    int n = 0;
    for (int pass = 0; pass < 2; pass++) {
        n = 0;
        for (int32_t i = 0; i < s->nobjs; i++) {
            const struct object *o = &s->objs[i];
            if (o->xform >= 0 || v3_maxabs(s->mats[o->material].emission) <= 0) continue;
            if (o->kind != SHAPE_SPHERE && o->kind != SHAPE_DISC && o->kind != SHAPE_QUAD) continue;
            if (pass) s->emitters[n] = i;
            n++;
        }
        if (pass == 0 && n > 0 && !(s->emitters = malloc(sizeof *s->emitters * (size_t)n)))
            return err_set(err, RAYD_E_NOMEM, NULL, "out of memory");
        if (n == 0) break;
    }
    s->nemitters = n;
    return RAYD_OK;
}

/* The point lights' buffers (light_buffer.c) over the top-level objects'
 * boxes; an object without bounds shows in every direction. */
static enum rayd_status build_light_buffers(rayd_scene *s, struct rayd_error *err) {
    struct light_buffer_light *lights = malloc(sizeof *lights * (size_t)(s->nlights + 1));
    if (!lights) return err_set(err, RAYD_E_NOMEM, NULL, "out of memory building the light buffers");
    for (int i = 0; i < s->nlights; i++)
        lights[i] = (struct light_buffer_light){s->lights[i].position,
                                                s->lights[i].kind == LIGHT_POINT};
    /* the objects' boxes only where some light can have a buffer */
    bool worth = light_buffers_worth(lights, s->nlights, s->nobjs);
    struct aabb *box = worth ? malloc(sizeof *box * (size_t)s->nobjs) : NULL;
    enum rayd_status st = RAYD_OK;
    if (worth && !box) {
        st = err_set(err, RAYD_E_NOMEM, NULL, "out of memory building the light buffers");
    } else if (worth) {
        for (int32_t k = 0; k < s->nobjs; k++)
            if (!scene_object_bounds(s, &s->objs[k], &box[k]))
                box[k] = (struct aabb){v3(-INFINITY, -INFINITY, -INFINITY),
                                       v3(INFINITY, INFINITY, INFINITY)};
        st = light_buffers_build(box, s->nobjs, lights, s->nlights, &s->light_buffers, err);
    }
    free(box);
    free(lights);
    return st;
}

enum rayd_status scene_freeze(rayd_scene *s, struct rayd_error *err) {
    s->opaque = true;
    for (int i = 0; i < s->nmats; i++) s->opaque &= !(s->mats[i].transparency > 0);
    s->simple_lights = true;
    for (int i = 0; i < s->nlights; i++) {
        enum light_kind k = s->lights[i].kind;
        s->simple_lights &= k == LIGHT_POINT || k == LIGHT_DIRECTIONAL;
    }
    enum rayd_status st = split_unbounded(s, err);
    if (st != RAYD_OK || s->nobjs <= 0) return st;
    double t0 = clock_now();
    st = scene_build_bvh(s, &s->objs, s->nobjs, &s->tlas, NULL, err);
    if (st == RAYD_OK) st = build_light_buffers(s, err);
    s->build_s += clock_now() - t0;
    return st == RAYD_OK ? find_emitters(s, err) : st;
}

void rayd_scene_info(const rayd_scene *s, struct rayd_scene_info *info) {
    info->width = s->rs.width;
    info->height = s->rs.height;
    info->samples = s->rs.samples;
    info->max_depth = s->rs.max_depth;
    info->objects = (long)s->nobjs + s->nplanes;
    info->lights = s->nlights;
    info->decode_seconds = s->decode_s;
    info->build_seconds = s->build_s;
    info->rays_per_sample = scene_rays_per_sample(s);
    size_t bytes = sizeof *s + sizeof *s->mats * (size_t)s->nmats +
                   sizeof *s->lights * (size_t)s->nlights +
                   sizeof *s->objs * (size_t)(s->nobjs + s->nplanes + s->nparts) +
                   sizeof *s->xforms * (size_t)s->nxforms +
                   sizeof *s->tlas.nodes * (size_t)s->tlas.nnodes;
    for (uint32_t i = 0; i < s->nmeshes; i++) bytes += mesh_bytes(&s->meshes[i]);
    for (int32_t i = 0; i < s->ngroups; i++)
        bytes += sizeof *s->objs * (size_t)s->groups[i].nobjs +
                 sizeof *s->tlas.nodes * (size_t)s->groups[i].bvh.nnodes;
    for (int i = 0; i < s->ntextures; i++) bytes += texture_bytes(&s->textures[i]);
    bytes += env_bytes(&s->rs.env);
    info->bytes = bytes + light_buffers_bytes(s->light_buffers, s->nlights);
}
