/* scene_json_objects.c -- the objects of a scene: shapes, CSG, groups
 * and instances, and their transforms.
 *
 * Every object has a type, an optional material (a name, an inline object,
 * or inherited from the CSG node above it) and an optional transform.
 * Objects are loaded into one of three homes: the scene's top level, a
 * group's list (drawn by instances), or the CSG operand pool.  Transforms
 * inside a CSG tree are composed down to its leaves here, so at render time
 * a CSG node has none of its own (scene.c relies on that).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "load/scene_json_objects.h"
#include "load/scene_json_anim.h"

#include "base/clock.h"
#include "base/meter.h"
#include "load/scene_json_gltf.h"
#include "load/scene_json_material.h"
#include "load/scene_json_mesh.h"

/* Where an object is being loaded and what it inherits. */
struct ctx {
    int material;            /* inherited material index */
    const struct xform *acc; /* CSG: the composed transform of the nodes above, or NULL */
    bool in_csg;             /* must be a closed solid */
    bool in_group;           /* may not be an instance */
    int32_t tex_xform;       /* CSG: 1 + the transform of the node the material is from */
    int32_t id;              /* the object id (index in its list) its objects take */
};

static enum rayd_status load_object(struct loader *ld, const cJSON *oj, const struct jp *at,
                                    const struct ctx *cx, struct object *o);

/* ---- transforms --------------------------------------------------------------- */

static enum rayd_status transform_step(struct loader *ld, const cJSON *t, const struct jp *at,
                                       struct xform *out) {
    static const char *const keys[] = {"translate", "rotate", "scale", "matrix", NULL};
    TRY(sj_check_keys(ld, t, at, keys));
    struct xform x = xform_identity();
    const cJSON *mj = cJSON_GetObjectItemCaseSensitive(t, "matrix");
    if (mj) {
        struct jp p = jp_key(at, "matrix");
        if (cJSON_GetArraySize(t) > 1)
            return sj_fail(ld, RAYD_E_INVALID, &p,
                           "cannot be combined with translate, rotate or scale");
        double rows[16];
        if (!cJSON_IsArray(mj) || cJSON_GetArraySize(mj) != 16)
            return sj_fail(ld, RAYD_E_INVALID, &p,
                           "must be an array of 16 numbers (a 4x4 matrix, row by row)");
        int i = 0;
        for (const cJSON *e = mj->child; e; e = e->next, i++)
            TRY(sj_item_num(ld, e, &p, i, NUM_MAX, NUM_RANGE, &rows[i]));
        if (!xform_from_matrix(rows, out))
            return sj_fail(ld, RAYD_E_INVALID, &p, "must be invertible with last row [0, 0, 0, 1]");
        return RAYD_OK;
    }
    const cJSON *sc = cJSON_GetObjectItemCaseSensitive(t, "scale");
    if (sc) {
        vec3 v;
        struct jp p = jp_key(at, "scale");
        if (cJSON_IsNumber(sc)) {
            double k;
            TRY(sj_num(ld, t, at, "scale", 1, -NUM_MAX, false, NUM_MAX, &k));
            v = v3(k, k, k);
        } else {
            TRY(sj_vec(ld, t, at, "scale", v3(1, 1, 1), VEC_ANY, &v));
        }
        if (fabs(v.x) < 1e-9 || fabs(v.y) < 1e-9 || fabs(v.z) < 1e-9)
            return sj_fail(ld, RAYD_E_INVALID, &p,
                           "must not be zero (or smaller than 1e-9) in any axis");
        struct xform k = xform_scale(v);
        x = xform_then(&x, &k);
    }
    const cJSON *ro = cJSON_GetObjectItemCaseSensitive(t, "rotate");
    if (ro) {
        struct jp p = jp_key(at, "rotate");
        struct xform k;
        if (cJSON_IsObject(ro)) {
            static const char *const rkeys[] = {"axis", "angle", NULL};
            TRY(sj_check_keys(ld, ro, &p, rkeys));
            vec3 axis;
            double angle;
            TRY(sj_vec(ld, ro, &p, "axis", v3(0, 1, 0), VEC_NONZERO, &axis));
            TRY(sj_num(ld, ro, &p, "angle", 0, -1e6, false, 1e6, &angle));
            k = xform_rotate_axis(axis, angle);
        } else {
            vec3 e;
            TRY(sj_vec(ld, t, at, "rotate", v3(0, 0, 0), VEC_ANY, &e));
            k = xform_rotate_euler(e);
        }
        x = xform_then(&x, &k);
    }
    vec3 tr;
    TRY(sj_vec(ld, t, at, "translate", v3(0, 0, 0), VEC_ANY, &tr));
    struct xform k = xform_translate(tr);
    *out = xform_then(&x, &k);
    return RAYD_OK;
}

/* "transform": one step {scale, rotate, translate} applied in that order,
 * or an array of steps applied first to last.  *present is false (and *out
 * the identity) without one. */
static enum rayd_status load_transform(struct loader *ld, const cJSON *obj, const struct jp *at,
                                       struct xform *out, bool *present) {
    *out = xform_identity();
    *present = false;
    const cJSON *t = cJSON_GetObjectItemCaseSensitive(obj, "transform");
    struct xform kx;
    bool keyed = sj_anim_xform(ld->anim, obj, &kx); /* keyframes move it after its transform */
    if (!t && !keyed) return RAYD_OK;
    struct jp p = jp_key(at, t ? "transform" : "keyframes");
    if (t && cJSON_IsArray(t)) {
        int i = 0;
        for (const cJSON *e = t->child; e; e = e->next, i++) {
            struct jp pe = jp_index(&p, i);
            struct xform step;
            TRY(transform_step(ld, e, &pe, &step));
            *out = xform_then(out, &step);
        }
    } else if (t) {
        TRY(transform_step(ld, t, &p, out));
    }
    if (keyed) *out = xform_then(out, &kx);
    if (!xform_sane(out))
        return sj_fail(
            ld, RAYD_E_INVALID, &p,
            "must not scale the object by more than 1e9 or less than 1e-9 (all steps together)");
    *present = true;
    return RAYD_OK;
}

static enum rayd_status add_xform(struct loader *ld, const struct xform *x, int32_t *index) {
    rayd_scene *s = ld->s;
    if (!array_grow((void **)&s->xforms, &ld->xform_cap, (size_t)s->nxforms + 1, sizeof *s->xforms))
        return err_set(ld->err, RAYD_E_NOMEM, NULL, "out of memory");
    s->xforms[s->nxforms] = *x;
    *index = s->nxforms++;
    return RAYD_OK;
}

/* ---- shapes ---------------------------------------------------------------------- */

static enum rayd_status positive(struct loader *ld, const cJSON *oj, const struct jp *at,
                                 const char *key, double def, double *out) {
    return sj_num(ld, oj, at, key, def, 0, true, NUM_MAX, out);
}

static enum rayd_status load_box(struct loader *ld, const cJSON *oj, const struct jp *at,
                                 struct object *o) {
    bool corners =
        cJSON_GetObjectItemCaseSensitive(oj, "min") || cJSON_GetObjectItemCaseSensitive(oj, "max");
    bool sized = cJSON_GetObjectItemCaseSensitive(oj, "center") ||
                 cJSON_GetObjectItemCaseSensitive(oj, "size");
    if (corners && sized)
        return sj_fail(ld, RAYD_E_INVALID, at, "give either min and max, or center and size");
    if (corners) {
        TRY(sj_vec(ld, oj, at, "min", v3(-1, -1, -1), VEC_ANY, &o->u.box.lo));
        TRY(sj_vec(ld, oj, at, "max", v3(1, 1, 1), VEC_ANY, &o->u.box.hi));
        vec3 d = v3_sub(o->u.box.hi, o->u.box.lo);
        struct jp p = jp_key(at, "max");
        if (!(d.x > 0 && d.y > 0 && d.z > 0))
            return sj_fail(ld, RAYD_E_INVALID, &p, "must be greater than min in every axis");
        return RAYD_OK;
    }
    vec3 c, size;
    TRY(sj_vec(ld, oj, at, "center", v3(0, 0, 0), VEC_ANY, &c));
    TRY(sj_vec(ld, oj, at, "size", v3(1, 1, 1), VEC_ANY, &size));
    struct jp p = jp_key(at, "size");
    if (!(size.x > 0 && size.y > 0 && size.z > 0))
        return sj_fail(ld, RAYD_E_INVALID, &p, "must be > 0 in every axis");
    o->u.box.lo = v3_madd(c, size, -0.5);
    o->u.box.hi = v3_madd(c, size, 0.5);
    return RAYD_OK;
}

static enum rayd_status load_cylinder(struct loader *ld, const cJSON *oj, const struct jp *at,
                                      bool cone, struct object *o) {
    vec3 base, top;
    TRY(sj_vec(ld, oj, at, "base", v3(0, 0, 0), VEC_ANY, &base));
    TRY(sj_vec(ld, oj, at, "top", v3(0, 1, 0), VEC_ANY, &top));
    double h = v3_len(v3_sub(top, base));
    struct jp p = jp_key(at, "top");
    if (!(h > 1e-12 * (1 + v3_maxabs(base))))
        return sj_fail(ld, RAYD_E_INVALID, &p, "must differ from base");
    o->u.cyl.base = base;
    o->u.cyl.axis = v3_scale(v3_sub(top, base), 1 / h);
    o->u.cyl.height = h;
    if (cone) {
        TRY(sj_num(ld, oj, at, "base_radius", 1, 0, false, NUM_MAX, &o->u.cyl.r0));
        TRY(sj_num(ld, oj, at, "top_radius", 0, 0, false, NUM_MAX, &o->u.cyl.r1));
        struct jp pr = jp_key(at, "base_radius");
        if (!(o->u.cyl.r0 > 0 || o->u.cyl.r1 > 0))
            return sj_fail(ld, RAYD_E_INVALID, &pr, "base_radius or top_radius must be > 0");
    } else {
        TRY(positive(ld, oj, at, "radius", 1, &o->u.cyl.r0));
        o->u.cyl.r1 = o->u.cyl.r0;
    }
    return sj_bool(ld, oj, at, "capped", true, &o->u.cyl.capped);
}

static enum rayd_status load_torus(struct loader *ld, const cJSON *oj, const struct jp *at,
                                   struct object *o) {
    vec3 axis;
    TRY(sj_vec(ld, oj, at, "center", v3(0, 0, 0), VEC_ANY, &o->u.torus.center));
    TRY(sj_vec(ld, oj, at, "axis", v3(0, 1, 0), VEC_NONZERO, &axis));
    TRY(positive(ld, oj, at, "major_radius", 1, &o->u.torus.major));
    TRY(positive(ld, oj, at, "minor_radius", 0.25, &o->u.torus.minor));
    struct jp p = jp_key(at, "minor_radius");
    if (o->u.torus.minor > o->u.torus.major)
        return sj_fail(ld, RAYD_E_INVALID, &p, "must be <= major_radius");
    o->u.torus.w = v3_norm(axis);
    v3_frame(o->u.torus.w, &o->u.torus.u, &o->u.torus.v);
    return RAYD_OK;
}

static enum rayd_status load_triangle(struct loader *ld, const cJSON *oj, const struct jp *at,
                                      struct object *o) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(oj, "vertices");
    struct jp p = jp_key(at, "vertices");
    if (!v) return sj_fail(ld, RAYD_E_INVALID, &p, "is required (three [x, y, z] points)");
    if (!cJSON_IsArray(v) || cJSON_GetArraySize(v) != 3)
        return sj_fail(ld, RAYD_E_INVALID, &p, "must be an array of 3 points");
    vec3 pts[3];
    int i = 0;
    for (const cJSON *e = v->child; e; e = e->next, i++) {
        struct jp pe = jp_index(&p, i);
        TRY(sj_vec_value(ld, e, &pe, VEC_ANY, &pts[i]));
    }
    if (!(v3_len(v3_cross(v3_sub(pts[1], pts[0]), v3_sub(pts[2], pts[0]))) > 0))
        return sj_fail(ld, RAYD_E_INVALID, &p, "must not be collinear (the triangle has no area)");
    o->u.tri.a = pts[0];
    o->u.tri.b = pts[1];
    o->u.tri.c = pts[2];
    return RAYD_OK;
}

static enum rayd_status load_quad(struct loader *ld, const cJSON *oj, const struct jp *at,
                                  struct object *o) {
    TRY(sj_vec(ld, oj, at, "corner", v3(-0.5, 0, -0.5), VEC_ANY, &o->u.quad.corner));
    TRY(sj_vec(ld, oj, at, "edge1", v3(1, 0, 0), VEC_NONZERO, &o->u.quad.e1));
    TRY(sj_vec(ld, oj, at, "edge2", v3(0, 0, 1), VEC_NONZERO, &o->u.quad.e2));
    struct jp p = jp_key(at, "edge2");
    if (!(v3_len(v3_cross(o->u.quad.e1, o->u.quad.e2)) >
          1e-12 * v3_len(o->u.quad.e1) * v3_len(o->u.quad.e2)))
        return sj_fail(ld, RAYD_E_INVALID, &p, "must not be parallel to edge1");
    quad_derive(o);
    return RAYD_OK;
}

static enum rayd_status load_quadric(struct loader *ld, const cJSON *oj, const struct jp *at,
                                     struct object *o) {
    const cJSON *k = cJSON_GetObjectItemCaseSensitive(oj, "coefficients");
    struct jp p = jp_key(at, "coefficients");
    if (!k || !cJSON_IsArray(k) || cJSON_GetArraySize(k) != 10)
        return sj_fail(ld, RAYD_E_INVALID, &p,
                       "is required: 10 numbers a..j of a x^2 + b y^2 + c z^2 + d xy + e xz + f yz "
                       "+ g x + h y + i z + j");
    int i = 0;
    double any = 0;
    for (const cJSON *e = k->child; e; e = e->next, i++) {
        TRY(sj_item_num(ld, e, &p, i, NUM_MAX, NUM_RANGE, &o->u.quadric.k[i]));
        if (i < 9) any += fabs(o->u.quadric.k[i]);
    }
    if (!(any > 0)) return sj_fail(ld, RAYD_E_INVALID, &p, "must not all be zero (but j)");
    return RAYD_OK;
}

/* ---- CSG, groups, instances ------------------------------------------------------- */

static enum rayd_status add_part(struct loader *ld, const struct object *o, int32_t *index) {
    rayd_scene *s = ld->s;
    if (!array_grow((void **)&s->parts, &ld->part_cap, (size_t)s->nparts + 1, sizeof *s->parts))
        return err_set(ld->err, RAYD_E_NOMEM, NULL, "out of memory");
    s->parts[s->nparts] = *o;
    *index = s->nparts++;
    return RAYD_OK;
}

static enum rayd_status load_csg(struct loader *ld, const cJSON *oj, const struct jp *at,
                                 const struct ctx *cx, struct object *o) {
    static const char *const ops[] = {"union", "intersection", "difference", NULL};
    int op;
    TRY(sj_enum(ld, oj, at, "op", ops, &op));
    struct jp pop = jp_key(at, "op");
    if (op < 0)
        return sj_fail(ld, RAYD_E_INVALID, &pop, "is required (union, intersection or difference)");
    const cJSON *list = cJSON_GetObjectItemCaseSensitive(oj, "operands");
    struct jp pl = jp_key(at, "operands");
    if (!list || !cJSON_IsArray(list) || cJSON_GetArraySize(list) < 2)
        return sj_fail(ld, RAYD_E_INVALID, &pl, "must be an array of at least 2 objects");
    if (cJSON_GetArraySize(list) > 32)
        return sj_fail(ld, RAYD_E_LIMIT, &pl, "has %d operands; the limit is 32",
                       cJSON_GetArraySize(list));
    struct ctx sub = {o->material, cx->acc, true, cx->in_group, cx->tex_xform, cx->id};
    /* left-deep tree: ((a op b) op c) ...; difference: a minus all the rest */
    int32_t left = -1;
    int i = 0;
    for (const cJSON *e = list->child; e; e = e->next, i++) {
        struct jp pe = jp_index(&pl, i);
        struct object child;
        int32_t idx;
        TRY(load_object(ld, e, &pe, &sub, &child));
        TRY(add_part(ld, &child, &idx));
        if (left < 0) {
            left = idx;
            continue;
        }
        struct object node;
        memset(&node, 0, sizeof node);
        node.kind = SHAPE_CSG;
        node.material = o->material;
        node.xform = -1;
        node.u.csg.op = op == 0 ? CSG_UNION : op == 1 ? CSG_INTERSECTION : CSG_DIFFERENCE;
        node.u.csg.left = left;
        node.u.csg.right = idx;
        if (e->next) {
            TRY(add_part(ld, &node, &left));
        } else {
            o->kind = SHAPE_CSG;
            o->xform = -1;
            o->u = node.u;
        }
    }
    return RAYD_OK;
}

static enum rayd_status load_instance(struct loader *ld, const cJSON *oj, const struct jp *at,
                                      struct object *o) {
    const cJSON *g = cJSON_GetObjectItemCaseSensitive(oj, "group");
    struct jp p = jp_key(at, "group");
    if (!g || !cJSON_IsString(g))
        return sj_fail(ld, RAYD_E_INVALID, &p, "is required: the name of a group in /groups");
    const struct named *hit = sj_name_find(ld->group_names, ld->ngroup_names, g->valuestring);
    if (hit) {
        o->u.inst.group = hit->index;
        return RAYD_OK;
    }
    char q[96];
    return sj_fail(ld, RAYD_E_INVALID, &p, "unknown group \"%s\" (not a key of /groups)",
                   jp_quote(q, sizeof q, g->valuestring));
}

/* ---- objects ----------------------------------------------------------------------- */

enum kind_index {
    K_SPHERE,
    K_PLANE,
    K_BOX,
    K_CYLINDER,
    K_CONE,
    K_DISC,
    K_TORUS,
    K_TRIANGLE,
    K_QUAD,
    K_QUADRIC,
    K_MESH,
    K_CSG,
    K_INSTANCE,
    K_GLTF
};

static const char *const kind_names[] = {"sphere", "plane", "box",      "cylinder", "cone",
                                         "disc",   "torus", "triangle", "quad",     "quadric",
                                         "mesh",   "csg",   "instance", "gltf",     NULL};

#define COMMON "type", "name", "material", "transform"
static const char *const *const kind_keys[] = {
    (const char *const[]){COMMON, "center", "radius", NULL},
    (const char *const[]){COMMON, "point", "normal", NULL},
    (const char *const[]){COMMON, "min", "max", "center", "size", NULL},
    (const char *const[]){COMMON, "base", "top", "radius", "capped", NULL},
    (const char *const[]){COMMON, "base", "top", "base_radius", "top_radius", "capped", NULL},
    (const char *const[]){COMMON, "center", "normal", "radius", "inner_radius", NULL},
    (const char *const[]){COMMON, "center", "axis", "major_radius", "minor_radius", NULL},
    (const char *const[]){COMMON, "vertices", NULL},
    (const char *const[]){COMMON, "corner", "edge1", "edge2", NULL},
    (const char *const[]){COMMON, "coefficients", NULL},
    (const char *const[]){COMMON, "source", "vertices", "indices", "normals", "uvs", "smooth",
                          NULL},
    (const char *const[]){COMMON, "op", "operands", NULL},
    (const char *const[]){"type", "name", "transform", "group", NULL},
    (const char *const[]){COMMON, "source", "scene", "lights", "light_scale", "camera", "animation",
                          NULL},
};

static enum rayd_status load_shape(struct loader *ld, const cJSON *oj, const struct jp *at,
                                   int kind, const struct ctx *cx, struct object *o) {
    switch (kind) {
    case K_SPHERE:
        o->kind = SHAPE_SPHERE;
        TRY(sj_vec(ld, oj, at, "center", v3(0, 0, 0), VEC_ANY, &o->u.sphere.center));
        return positive(ld, oj, at, "radius", 1, &o->u.sphere.radius);
    case K_PLANE: {
        vec3 n;
        o->kind = SHAPE_PLANE;
        TRY(sj_vec(ld, oj, at, "point", v3(0, 0, 0), VEC_ANY, &o->u.plane.point));
        TRY(sj_vec(ld, oj, at, "normal", v3(0, 1, 0), VEC_NONZERO, &n));
        o->u.plane.normal = v3_norm(n);
        return RAYD_OK;
    }
    case K_BOX: o->kind = SHAPE_BOX; return load_box(ld, oj, at, o);
    case K_CYLINDER:
    case K_CONE: o->kind = SHAPE_CYLINDER; return load_cylinder(ld, oj, at, kind == K_CONE, o);
    case K_DISC: {
        vec3 n;
        o->kind = SHAPE_DISC;
        TRY(sj_vec(ld, oj, at, "center", v3(0, 0, 0), VEC_ANY, &o->u.disc.center));
        TRY(sj_vec(ld, oj, at, "normal", v3(0, 1, 0), VEC_NONZERO, &n));
        o->u.disc.normal = v3_norm(n);
        TRY(positive(ld, oj, at, "radius", 1, &o->u.disc.radius));
        TRY(sj_num(ld, oj, at, "inner_radius", 0, 0, false, o->u.disc.radius, &o->u.disc.inner));
        return RAYD_OK;
    }
    case K_TORUS: o->kind = SHAPE_TORUS; return load_torus(ld, oj, at, o);
    case K_TRIANGLE: o->kind = SHAPE_TRIANGLE; return load_triangle(ld, oj, at, o);
    case K_QUAD: o->kind = SHAPE_QUAD; return load_quad(ld, oj, at, o);
    case K_QUADRIC: o->kind = SHAPE_QUADRIC; return load_quadric(ld, oj, at, o);
    case K_MESH: o->kind = SHAPE_MESH; return sj_mesh(ld, oj, at, &o->u.mesh.id);
    case K_CSG: return load_csg(ld, oj, at, cx, o);
    default: o->kind = SHAPE_INSTANCE; return load_instance(ld, oj, at, o);
    }
}

static enum rayd_status load_object(struct loader *ld, const cJSON *oj, const struct jp *at,
                                    const struct ctx *cx, struct object *o) {
    if (!cJSON_IsObject(oj))
        return sj_fail(ld, RAYD_E_INVALID, at, "must be an object, not %s", sj_type_name(oj));
    if (++ld->objects > ld->lim->max_objects)
        return sj_fail(ld, RAYD_E_LIMIT, at,
                       "is past the limit of %ld objects (counting CSG operands and group members)",
                       ld->lim->max_objects);
    int kind;
    TRY(sj_type(ld, oj, at, kind_names, &kind));
    TRY(sj_check_keys(ld, oj, at, kind_keys[kind]));
    const cJSON *name = cJSON_GetObjectItemCaseSensitive(oj, "name");
    if (name && !cJSON_IsString(name)) {
        struct jp p = jp_key(at, "name");
        return sj_fail(ld, RAYD_E_INVALID, &p, "must be a string, not %s", sj_type_name(name));
    }
    struct jp pt = jp_key(at, "type");
    if (kind == K_INSTANCE && cx->in_group)
        return sj_fail(ld, RAYD_E_INVALID, &pt,
                       "an instance cannot be inside a group (groups do not nest)");
    if (kind == K_GLTF && (cx->in_group || cx->in_csg))
        return sj_fail(ld, RAYD_E_INVALID, &pt,
                       "a gltf object cannot be inside a group or a CSG object (its meshes are a "
                       "group of their own)");
    memset(o, 0, sizeof *o);
    o->xform = -1;
    o->id = cx->id;
    TRY(sj_object_material(ld, oj, at, cx->material, &o->material));
    struct xform x;
    bool has_x;
    TRY(load_transform(ld, oj, at, &x, &has_x));
    if ((kind == K_INSTANCE || kind == K_GLTF) && !has_x) x = xform_identity(), has_x = true;
    /* inside CSG every transform is composed down to the leaves */
    struct xform acc = cx->acc ? xform_then(&x, cx->acc) : x;
    struct jp ptr = jp_key(at, "transform");
    if (cx->acc && !xform_sane(&acc))
        return sj_fail(ld, RAYD_E_INVALID, &ptr,
                       "must not scale the object by more than 1e9 or less than 1e-9 (with the CSG "
                       "nodes above it)");
    struct ctx sub = *cx;
    sub.acc = (cx->in_csg || kind == K_CSG) ? &acc : NULL;
    bool own_mat = cJSON_GetObjectItemCaseSensitive(oj, "material") != NULL;
    if (kind == K_CSG && (own_mat || !cx->in_csg)) { /* its leaves' texture space: added once */
        TRY(add_xform(ld, &acc, &sub.tex_xform));
        sub.tex_xform++;
    }
    if (kind == K_GLTF) {
        TRY(sj_gltf(ld, oj, at, &x, o));
    } else {
        TRY(load_shape(ld, oj, at, kind, &sub, o));
    }
    if (cx->in_csg && !shape_is_solid(o)) {
        bool open = o->kind == SHAPE_CYLINDER; /* capped: false */
        struct jp pc = jp_key(at, "capped");
        return sj_fail(ld, RAYD_E_INVALID, open ? &pc : &pt,
                       "%s %s%s cannot be a CSG operand: CSG needs closed solids (sphere, box, "
                       "capped cylinder or cone, torus, plane, quadric, csg)",
                       open || kind == K_INSTANCE ? "an" : "a", open ? "open " : "",
                       kind_names[kind]);
    }
    if (o->kind != SHAPE_CSG && (has_x || cx->acc)) {
        struct xform leaf = cx->acc && cx->in_csg ? acc : x;
        TRY(add_xform(ld, &leaf, &o->xform));
    }
    if (cx->in_csg && o->kind != SHAPE_CSG && !own_mat) o->tex_xform = cx->tex_xform;
    return RAYD_OK;
}

static enum rayd_status load_list(struct loader *ld, const cJSON *list, const struct jp *at,
                                  bool in_group, struct object **out, int32_t *count) {
    if (!cJSON_IsArray(list))
        return sj_fail(ld, RAYD_E_INVALID, at, "must be an array, not %s", sj_type_name(list));
    int n = cJSON_GetArraySize(list);
    if (n > ld->lim->max_objects)
        return sj_fail(ld, RAYD_E_LIMIT, at, "has %d objects; the limit is %ld", n,
                       ld->lim->max_objects);
    *out = calloc((size_t)n + 1, sizeof **out);
    if (!*out) return err_set(ld->err, RAYD_E_NOMEM, NULL, "out of memory");
    struct ctx cx = {0, NULL, false, in_group, 0, 0};
    int i = 0;
    for (const cJSON *o = list->child; o; o = o->next, i++) {
        struct jp p = jp_index(at, i);
        if ((i & 1023) == 1023 && !meter_live()) /* the parse's cancel flag */
            return sj_fail(ld, RAYD_E_CANCELED, &p, "the parse was canceled");
        cx.id = i;
        TRY(load_object(ld, o, &p, &cx, &(*out)[i]));
        *count = i + 1;
    }
    return RAYD_OK;
}

/* "groups": {"name": [objects...]}: loaded before the objects, each with
 * a BVH of its own, drawn by "instance" objects. */
enum rayd_status sj_groups(struct loader *ld, const cJSON *root) {
    const cJSON *gs = cJSON_GetObjectItemCaseSensitive(root, "groups");
    if (!gs) return RAYD_OK;
    struct jp at = {.s = "/groups"};
    TRY(sj_check_keys(ld, gs, &at, NULL));
    int n = cJSON_GetArraySize(gs);
    rayd_scene *s = ld->s;
    s->groups = calloc((size_t)n + 1, sizeof *s->groups);
    if (!s->groups) return err_set(ld->err, RAYD_E_NOMEM, NULL, "out of memory");
    TRY(sj_names_sorted(ld, gs, 0, &ld->group_names, &ld->ngroup_names));
    for (const cJSON *g = gs->child; g; g = g->next) {
        struct jp p = jp_key(&at, g->string);
        struct group *gr = &s->groups[s->ngroups++];
        TRY(load_list(ld, g, &p, true, &gr->objs, &gr->nobjs));
        if (gr->nobjs == 0) return sj_fail(ld, RAYD_E_INVALID, &p, "must not be empty");
        for (int32_t i = 0; i < gr->nobjs; i++) {
            struct aabb b;
            struct jp pi = jp_index(&p, i);
            if (!scene_object_bounds(s, &gr->objs[i], &b))
                return sj_fail(ld, RAYD_E_INVALID, &pi,
                               "unbounded objects (planes, quadrics) cannot be in a group");
        }
        double t0 = clock_now();
        enum rayd_status st =
            scene_build_bvh(s, &gr->objs, gr->nobjs, &gr->bvh, &gr->bounds, ld->err);
        s->build_s += clock_now() - t0;
        TRY(st);
    }
    return RAYD_OK;
}

enum rayd_status sj_objects(struct loader *ld, const cJSON *root) {
    const cJSON *os = cJSON_GetObjectItemCaseSensitive(root, "objects");
    if (!os) return RAYD_OK;
    struct jp at = {.s = "/objects"};
    return load_list(ld, os, &at, false, &ld->s->objs, &ld->s->nobjs);
}
