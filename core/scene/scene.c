/* scene.c -- the frozen scene: made, bounded, frozen, described, freed.
 *
 * The loader (scene_json.c) fills a rayd_scene and freezes it once
 * (scene_freeze: the unbounded objects split out, the top-level BVH, the
 * point lights' buffers, the emitters the path tracer samples); after that
 * it is immutable and shared by every rendering thread through a const
 * pointer.  The queries the tracer makes of it are scene_query.c's (one
 * ray) and scene_packet.c's (16 rays).
 */
#include "scene/scene.h"

#include <stdlib.h>
#include <string.h>

#include "base/clock.h"
#include "base/error.h"
#include "accel/light_buffer.h"
#include "shade/texture.h"
#include "scene/scene_files.h"

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
    scene_files_free(s);
    free(s->groups);
    free(s->parts);
    free(s->meshes);
    free(s->xforms);
    free(s->mats);
    free(s->lights);
    free(s->objs);
    free(s->planes);
    free(s->planes_src);
    free(s->emitters);
    free(s->leave);
    free(s->inst_ids);
    bvh_free(&s->tlas);
    free(s->flat);
    light_buffers_free(s->light_buffers, s->nlights);
    free(s);
}

/* ---- bounds -------------------------------------------------------------------- */

static struct aabb box_xform(const struct aabb *b, const struct xform *x) {
    if (!x) return *b;
    struct aabb w = {v3(INFINITY, INFINITY, INFINITY), v3(-INFINITY, -INFINITY, -INFINITY)};
    for (int c = 0; c < 8; c++) { /* the box around the transformed corners */
        vec3 p =
            v3(c & 1 ? b->hi.x : b->lo.x, c & 2 ? b->hi.y : b->lo.y, c & 4 ? b->hi.z : b->lo.z);
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

/* ---- freeze ---------------------------------------------------------------------- */

/* Splits out unbounded objects; plane placements are baked in (the planes
 * as loaded are kept beside them: a texture in object space follows the
 * transform). */
static enum rayd_status split_unbounded(rayd_scene *s, struct rayd_error *err) {
    int32_t nb = 0, np = 0;
    struct aabb b;
    for (int32_t i = 0; i < s->nobjs; i++) np += !scene_object_bounds(s, &s->objs[i], &b);
    if (np == 0) return RAYD_OK;
    s->planes = malloc(sizeof *s->planes * (size_t)np);
    s->planes_src = malloc(sizeof *s->planes_src * (size_t)np);
    if (!s->planes || !s->planes_src) return err_set(err, RAYD_E_NOMEM, NULL, "out of memory");
    np = 0;
    for (int32_t i = 0; i < s->nobjs; i++) {
        struct object o = s->objs[i];
        if (scene_object_bounds(s, &o, &b)) {
            s->objs[nb++] = o;
            continue;
        }
        s->planes_src[np] = o;
        if (o.kind == SHAPE_PLANE && o.xform >= 0) {
            const struct xform *x = &s->xforms[o.xform];
            o.u.plane.point = xform_point(x, o.u.plane.point);
            o.u.plane.normal = xform_normal(x, o.u.plane.normal);
            o.u.plane.baked = true;
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
    if (!lights)
        return err_set(err, RAYD_E_NOMEM, NULL, "out of memory building the light buffers");
    for (int i = 0; i < s->nlights; i++)
        lights[i] =
            (struct light_buffer_light){s->lights[i].position, s->lights[i].kind == LIGHT_POINT};
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

/* The object id of each instance's placement (render/aov.c): a hit inside
 * a group knows its instance only by that. */
static enum rayd_status map_instances(rayd_scene *s, struct rayd_error *err) {
    if (s->nxforms <= 0) return RAYD_OK;
    s->inst_ids = malloc(sizeof *s->inst_ids * (size_t)s->nxforms);
    if (!s->inst_ids) return err_set(err, RAYD_E_NOMEM, NULL, "out of memory");
    for (int32_t i = 0; i < s->nxforms; i++) s->inst_ids[i] = -1;
    for (int32_t i = 0; i < s->nobjs; i++)
        if (s->objs[i].kind == SHAPE_INSTANCE && s->objs[i].xform >= 0)
            s->inst_ids[s->objs[i].xform] = s->objs[i].id;
    return RAYD_OK;
}

/* s->flat for a scene of few objects: the root of a small tlas has few
 * children, so nearly every ray descends into most of its inner nodes,
 * one test of four boxes each; testing every object's box at once takes
 * fewer tests and no stack.  The boxes are the tlas's own (bbox_from of
 * the object's bounds). */
static enum rayd_status build_flat(rayd_scene *s, struct rayd_error *err) {
    if (s->nobjs > SCENE_FLAT_MAX) return RAYD_OK;
    uint32_t n = ((uint32_t)s->nobjs + 3) / 4;
    s->flat = malloc(sizeof *s->flat * n);
    if (!s->flat) return err_set(err, RAYD_E_NOMEM, NULL, "out of memory");
    s->nflat = n;
    for (uint32_t i = 0; i < 4 * n; i++) {
        struct bvh4_node *nd = &s->flat[i / 4];
        struct aabb b = {v3(INFINITY, INFINITY, INFINITY), v3(-INFINITY, -INFINITY, -INFINITY)};
        if (i < (uint32_t)s->nobjs) scene_object_bounds(s, &s->objs[i], &b);
        /* an empty slot keeps its inverted box: no ray enters it */
        struct bbox f = i < (uint32_t)s->nobjs ? bbox_from(b.lo, b.hi)
                                               : (struct bbox){{INFINITY, INFINITY, INFINITY},
                                                               {-INFINITY, -INFINITY, -INFINITY}};
        for (int k = 0; k < 3; k++) {
            nd->lo[k][i % 4] = f.lo[k];
            nd->hi[k][i % 4] = f.hi[k];
        }
        nd->child[i % 4] = i;
        nd->count[i % 4] = 1;
    }
    return RAYD_OK;
}

enum rayd_status scene_freeze(rayd_scene *s, struct rayd_error *err) {
    if (!scene_files_dedupe(s)) return err_set(err, RAYD_E_NOMEM, NULL, "out of memory");
    s->opaque = true;
    for (int i = 0; i < s->nmats; i++) s->opaque &= !(s->mats[i].transparency > 0);
    s->simple_lights = true;
    for (int i = 0; i < s->nlights; i++) {
        enum light_kind k = s->lights[i].kind;
        s->simple_lights &= k == LIGHT_POINT || k == LIGHT_DIRECTIONAL;
    }
    enum rayd_status st = split_unbounded(s, err);
    if (st == RAYD_OK) st = map_instances(s, err);
    if (st != RAYD_OK || s->nobjs <= 0) return st;
    double t0 = clock_now();
    st = scene_build_bvh(s, &s->objs, s->nobjs, &s->tlas, NULL, err);
    if (st == RAYD_OK) st = build_flat(s, err);
    if (st == RAYD_OK) st = scene_leave_freeze(s, err);
    if (st == RAYD_OK) st = build_light_buffers(s, err);
    if (st == RAYD_OK) scene_cost_freeze(s);
    s->build_s += clock_now() - t0;
    return st == RAYD_OK ? find_emitters(s, err) : st;
}

/* Whether nothing gives light: no light, no emission, a black background
 * and environment (the Whitted ambient term needs a light too). */
static bool scene_unlit(const rayd_scene *s) {
    if (s->nlights > 0 || v3_dot(s->rs.background, s->rs.background) > 0) return false;
    const struct environment *e = &s->rs.env;
    if (e->kind == ENV_CONSTANT && v3_dot(e->color, e->color) > 0) return false;
    if (e->kind == ENV_IMAGE && v3_dot(e->mean, e->mean) > 0) return false;
    for (int i = 0; i < s->nmats; i++)
        if (v3_dot(s->mats[i].emission, s->mats[i].emission) > 0) return false;
    return true;
}

enum rayd_status rayd_scene_set_bias(rayd_scene *s, double clamp_indirect, double filter_glossy,
                                     struct rayd_error *err) {
    if (clamp_indirect != clamp_indirect || clamp_indirect > 32768)
        return err_set(err, RAYD_E_ARG, "clamp_indirect", "must be in 0..32768");
    if (filter_glossy != filter_glossy || filter_glossy > 1)
        return err_set(err, RAYD_E_ARG, "filter_glossy", "must be in 0..1");
    if (clamp_indirect >= 0) s->rs.clamp_indirect = clamp_indirect;
    if (filter_glossy >= 0) s->rs.filter_glossy = filter_glossy;
    return RAYD_OK;
}

void rayd_scene_info(const rayd_scene *s, struct rayd_scene_info *info) {
    info->unlit = scene_unlit(s);
    info->width = s->rs.width;
    info->height = s->rs.height;
    info->samples = s->rs.samples;
    info->max_depth = s->rs.max_depth;
    info->objects = (long)s->nobjs + s->nplanes;
    info->lights = s->nlights;
    info->decode_seconds = s->decode_s;
    info->build_seconds = s->build_s;
    info->frame_work = s->frame_work;
    info->aov = s->rs.aov;
    info->denoise = s->rs.denoise;
    info->clamp_indirect = s->rs.clamp_indirect;
    info->filter_glossy = s->rs.filter_glossy;
    info->rays_per_sample = scene_rays_per_sample(s);
    size_t bytes =
        sizeof *s + sizeof *s->mats * (size_t)s->nmats + sizeof *s->lights * (size_t)s->nlights +
        sizeof *s->objs * (size_t)(s->nobjs + 2 * s->nplanes + s->nparts) + /* planes_src */
        sizeof *s->xforms * (size_t)s->nxforms + sizeof *s->tlas.nodes * (size_t)s->tlas.nnodes;
    for (uint32_t i = 0; i < s->nmeshes; i++) bytes += mesh_bytes(&s->meshes[i]);
    for (int32_t i = 0; i < s->ngroups; i++)
        bytes += sizeof *s->objs * (size_t)s->groups[i].nobjs +
                 sizeof *s->tlas.nodes * (size_t)s->groups[i].bvh.nnodes;
    for (int i = 0; i < s->ntextures; i++) bytes += texture_bytes(&s->textures[i]);
    bytes += env_bytes(&s->rs.env);
    info->bytes = bytes + light_buffers_bytes(s->light_buffers, s->nlights);
}
