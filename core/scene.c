/* scene.c -- the frozen scene and the queries the tracer makes of it.
 *
 * Two levels, like Embree's and OptiX's: a top-level BVH over objects
 * (spheres, mesh instances, ...) and, inside each mesh, a BVH over its
 * triangles.  An object may carry a transform; a ray meets it in object
 * space (origin and direction by the inverse transform, the direction
 * renormalised and t rescaled), so a mesh drawn a thousand times is stored
 * once.  Planes have no bounds and are tested one by one beside the BVH,
 * their transform applied once at load time.
 *
 * The loader (scene_json.c) fills a rayd_scene and freezes it once; after
 * that it is immutable and shared by every rendering thread through a const
 * pointer.
 */
#include "scene.h"

#include <stdlib.h>
#include <string.h>

#include "error.h"

enum rayd_status scene_alloc(rayd_scene **out, struct rayd_error *err) {
    rayd_scene *s = calloc(1, sizeof *s);
    if (!s) return err_set(err, RAYD_E_NOMEM, NULL, "out of memory");
    *out = s;
    return RAYD_OK;
}

void rayd_scene_free(rayd_scene *s) {
    if (!s) return;
    for (uint32_t i = 0; i < s->nmeshes; i++) mesh_free(&s->meshes[i]);
    free(s->meshes);
    free(s->xforms);
    free(s->mats);
    free(s->lights);
    free(s->objs);
    free(s->planes);
    bvh_free(&s->tlas);
    free(s);
}

/* ---- object space ---------------------------------------------------------- */

/* The ray in object space; *scale converts distances: t_obj = t * scale. */
static inline ray to_object(const rayd_scene *s, const struct object *o, const ray *r,
                            double *scale) {
    if (o->xform < 0) {
        *scale = 1;
        return *r;
    }
    const struct xform *x = &s->xforms[o->xform];
    vec3 d = xform_inv_dir(x, r->d);
    double len = v3_len(d);
    ray lr = {xform_inv_point(x, r->o), v3_scale(d, 1.0 / len)};
    *scale = len;
    return lr;
}

static struct aabb object_bounds(const rayd_scene *s, const struct object *o) {
    struct aabb b;
    if (o->kind == SHAPE_MESH) {
        b.lo = s->meshes[o->u.mesh.id].lo;
        b.hi = s->meshes[o->u.mesh.id].hi;
    } else {
        b = sphere_bounds(o);
    }
    if (o->xform < 0) return b;
    const struct xform *x = &s->xforms[o->xform];
    struct aabb w = {v3(INFINITY, INFINITY, INFINITY), v3(-INFINITY, -INFINITY, -INFINITY)};
    for (int c = 0; c < 8; c++) { /* the box around the transformed corners */
        vec3 p = v3(c & 1 ? b.hi.x : b.lo.x, c & 2 ? b.hi.y : b.lo.y, c & 4 ? b.hi.z : b.lo.z);
        p = xform_point(x, p);
        w.lo = v3_min(w.lo, p);
        w.hi = v3_max(w.hi, p);
    }
    return w;
}

/* Nearest hit of one object closer than *tmax: updates *tmax and h. */
static inline bool object_hit(const rayd_scene *s, int32_t i, const ray *r, double *tmax,
                              struct hit *h) {
    const struct object *o = &s->objs[i];
    double scale;
    ray lr = to_object(s, o, r, &scale);
    double t;
    if (o->kind == SHAPE_MESH) {
        struct mesh_hit mh;
        const struct mesh *m = &s->meshes[o->u.mesh.id];
        bool hit = s->brute ? mesh_intersect_brute(m, &lr, *tmax * scale, &mh)
                            : mesh_intersect(m, &lr, *tmax * scale, &mh);
        if (!hit) return false;
        h->mh = mh;
        t = mh.t;
    } else if (!sphere_hit(o, &lr, 0, *tmax * scale, &t)) {
        return false;
    }
    *tmax = t / scale;
    h->t = *tmax;
    h->obj = i;
    h->plane = false;
    return true;
}

/* Any hit of one object closer than tmax. */
static bool object_any_hit(const rayd_scene *s, int32_t i, const ray *r, double tmax) {
    const struct object *o = &s->objs[i];
    double scale, t;
    ray lr = to_object(s, o, r, &scale);
    if (o->kind == SHAPE_MESH) {
        struct mesh_hit mh;
        const struct mesh *m = &s->meshes[o->u.mesh.id];
        return s->brute ? mesh_intersect_brute(m, &lr, tmax * scale, &mh)
                        : mesh_occluded(m, &lr, tmax * scale);
    }
    return sphere_hit(o, &lr, 0, tmax * scale, &t);
}

/* ---- freeze ----------------------------------------------------------------- */

static enum rayd_status split_planes(rayd_scene *s, struct rayd_error *err) {
    int32_t nb = 0, np = 0;
    for (int32_t i = 0; i < s->nobjs; i++) np += !shape_bounded(&s->objs[i]);
    if (np == 0) return RAYD_OK;
    s->planes = malloc(sizeof *s->planes * (size_t)np);
    if (!s->planes) return err_set(err, RAYD_E_NOMEM, NULL, "out of memory");
    np = 0;
    for (int32_t i = 0; i < s->nobjs; i++) {
        struct object o = s->objs[i];
        if (shape_bounded(&o)) {
            s->objs[nb++] = o;
            continue;
        }
        if (o.xform >= 0) { /* bake the placement into the plane */
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

enum rayd_status scene_freeze(rayd_scene *s, struct rayd_error *err) {
    enum rayd_status st = split_planes(s, err);
    if (st != RAYD_OK || s->nobjs == 0) return st;
    size_t n = (size_t)s->nobjs;
    struct bbox *boxes = malloc(sizeof *boxes * n);
    uint32_t *order = malloc(sizeof *order * n);
    struct object *sorted = malloc(sizeof *sorted * n);
    if (!boxes || !order || !sorted) {
        st = err_set(err, RAYD_E_NOMEM, NULL, "out of memory building the scene");
    } else {
        for (size_t i = 0; i < n; i++) {
            struct aabb b = object_bounds(s, &s->objs[i]);
            boxes[i] = bbox_from(b.lo, b.hi);
        }
        st = bvh_build(&s->tlas, boxes, (uint32_t)n, order, 1, err);
    }
    if (st == RAYD_OK) {
        for (size_t i = 0; i < n; i++) sorted[i] = s->objs[order[i]];
        free(s->objs);
        s->objs = sorted;
        sorted = NULL;
    }
    free(boxes);
    free(order);
    free(sorted);
    return st;
}

/* ---- queries ---------------------------------------------------------------- */

static bool planes_hit(const rayd_scene *s, const ray *r, double *tmax, struct hit *h) {
    bool found = false;
    for (int32_t i = 0; i < s->nplanes; i++) {
        double t;
        if (plane_hit(&s->planes[i], r, 0, *tmax, &t)) {
            *tmax = t;
            h->t = t;
            h->obj = i;
            h->plane = true;
            found = true;
        }
    }
    return found;
}

bool scene_intersect(const rayd_scene *s, const ray *r, double tmax, struct hit *h) {
    bool found = planes_hit(s, r, &tmax, h);
    if (s->nobjs == 0) return found;
    if (s->brute) {
        for (int32_t i = 0; i < s->nobjs; i++) found |= object_hit(s, i, r, &tmax, h);
        return found;
    }
    struct bvh_ray br;
    bvh_ray_init(&br, r->o, r->d);
    struct bvh_entry stack[BVH_STACK];
    int sp = 1;
    stack[0].node = 0;
    stack[0].count = 0;
    stack[0].tnear = 0;
    while (sp > 0) {
        struct bvh_entry e = stack[--sp];
        if (e.tnear > tmax * 1.0000004) continue;
        if (e.count) {
            for (uint32_t i = e.node; i < e.node + e.count; i++)
                found |= object_hit(s, (int32_t)i, r, &tmax, h);
            continue;
        }
        const struct bvh4_node *nd = &s->tlas.nodes[e.node];
        float tn[4];
        float tm = tmax > 3e38 ? 3e38f : (float)tmax;
        int mask = bvh4_test(nd, &br, 0, tm, tn);
        sp = bvh4_push_sorted(nd, mask, tn, stack, sp);
    }
    return found;
}

/* Multiplies *trans by what object material m lets through; false (stop)
 * when nothing passes any more. */
static bool filter_light(const rayd_scene *s, int material, vec3 *trans) {
    const struct material *m = &s->mats[material];
    if (m->transparency <= 0) {
        *trans = v3(0, 0, 0);
        return false;
    }
    *trans = v3_mul(*trans, v3_scale(m->color, m->transparency));
    return v3_maxabs(*trans) > 0;
}

vec3 scene_transmittance(const rayd_scene *s, const ray *r, double tmax) {
    vec3 trans = v3(1, 1, 1);
    for (int32_t i = 0; i < s->nplanes; i++) {
        double t;
        if (plane_hit(&s->planes[i], r, 0, tmax, &t) &&
            !filter_light(s, s->planes[i].material, &trans))
            return trans;
    }
    if (s->nobjs == 0) return trans;
    struct bvh_ray br;
    bvh_ray_init(&br, r->o, r->d);
    struct bvh_entry stack[BVH_STACK];
    int sp = 1;
    stack[0].node = 0;
    stack[0].count = 0;
    float tm = tmax > 3e38 ? 3e38f : (float)tmax;
    while (sp > 0) {
        struct bvh_entry e = stack[--sp];
        if (e.count) {
            for (uint32_t i = e.node; i < e.node + e.count; i++)
                if (object_any_hit(s, (int32_t)i, r, tmax) &&
                    !filter_light(s, s->objs[i].material, &trans))
                    return trans;
            continue;
        }
        const struct bvh4_node *nd = &s->tlas.nodes[e.node];
        float tn[4];
        int mask = bvh4_test(nd, &br, 0, tm, tn);
        for (int k = 0; k < 4; k++) {
            if (!(mask & (1 << k))) continue;
            stack[sp].node = nd->child[k];
            stack[sp].count = nd->count[k];
            sp++;
        }
    }
    return trans;
}

void scene_surface(const rayd_scene *s, const ray *r, const struct hit *h, struct surface *sf) {
    const struct object *o = h->plane ? &s->planes[h->obj] : &s->objs[h->obj];
    sf->m = &s->mats[o->material];
    sf->thin = o->kind == SHAPE_PLANE;
    sf->float_geom = o->kind == SHAPE_MESH;
    if (o->kind == SHAPE_PLANE) {
        sf->p = ray_at(r, h->t);
        sf->n = sf->ng = o->u.plane.normal;
        return;
    }
    vec3 p, n, ng;
    const struct xform *x = o->xform >= 0 ? &s->xforms[o->xform] : NULL;
    if (o->kind == SHAPE_MESH) {
        const struct mesh *m = &s->meshes[o->u.mesh.id];
        p = mesh_point(m, &h->mh);
        ng = mesh_geometric_normal(m, h->mh.tri);
        n = mesh_shading_normal(m, &h->mh);
    } else {
        p = x ? xform_inv_point(x, ray_at(r, h->t)) : ray_at(r, h->t);
        n = ng = sphere_normal(o, p);
    }
    if (x) {
        p = xform_point(x, p);
        n = xform_normal(x, n);
        ng = xform_normal(x, ng);
    }
    sf->p = p;
    sf->n = n;
    sf->ng = ng;
}

void rayd_scene_info(const rayd_scene *s, struct rayd_scene_info *info) {
    info->width = s->rs.width;
    info->height = s->rs.height;
    info->samples = s->rs.samples;
    info->max_depth = s->rs.max_depth;
    info->objects = (long)s->nobjs + s->nplanes;
    info->lights = s->nlights;
    size_t bytes = sizeof *s + sizeof *s->mats * (size_t)s->nmats +
                   sizeof *s->lights * (size_t)s->nlights +
                   sizeof *s->objs * (size_t)(s->nobjs + s->nplanes) +
                   sizeof *s->xforms * (size_t)s->nxforms +
                   sizeof *s->tlas.nodes * (size_t)s->tlas.nnodes;
    for (uint32_t i = 0; i < s->nmeshes; i++) bytes += mesh_bytes(&s->meshes[i]);
    info->bytes = bytes;
}
