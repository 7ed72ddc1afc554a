/* scene_json_gltf.c -- "gltf" objects: a glTF 2.0 file as a whole scene.
 *
 *   {"type": "gltf", "source": {...as a mesh source...}, "scene": 0 | "name",
 *    "material": ..., "lights": true, "light_scale": 1, "camera": 0 | "name",
 *    "name": ..., "transform": ..., "animation": 0 | "name"}
 *
 * A mesh source bakes a glTF into one mesh with the object's material; this
 * object keeps the file's own materials instead.  mesh_gltf.c walks the
 * chosen scene and bakes its triangles with a glTF material index each;
 * gltf_material.c maps the materials (and base colour textures) onto
 * rayd's; here the triangles are split into one mesh per material -- not
 * one per primitive: a file of a thousand primitives in three materials is
 * three meshes -- and the meshes become a group of their own, drawn by
 * the object as an instance, so the object's transform places them all at
 * once and costs nothing per triangle.  That is also why a gltf object may
 * be neither a CSG operand nor a group member (groups do not nest).  A
 * "material" on the object overrides every glTF material: one mesh, as a
 * mesh source gives.
 *
 * The nodes the walk reached also bring KHR_lights_punctual lights
 * (appended to /lights, under the same limit) and, when "camera" names one
 * of the file's cameras, the scene's camera, placed by their node's world
 * matrix and then by the object's transform.  Errors name the glTF
 * document's JSON Pointer after the source's: /objects/0/source/gltf/...
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "load/scene_json_gltf.h"

#include "base/clock.h"
#include "base/parallel.h"
#include "load/gltf_material.h"
#include "load/scene_json_anim.h"
#include "format/gltf_json.h"
#include "load/scene_json_material.h"
#include "load/scene_json_texture.h"
#include "load/scene_json_mesh.h"
#include "shade/texture.h"

#define GLTF_PI 3.14159265358979323846

/* One object's import: the doc and where its errors go. */
struct imp {
    struct loader *ld;
    struct gltf_doc *doc;
    struct jp src; /* the object's "source": errors inside the file go under it */
    const struct xform *x;
};

/* A failure inside the glTF document, with its pointer there. */
static enum rayd_status imp_fail(struct imp *im, enum rayd_status st) {
    return sj_gltf_error(im->ld, &im->src, st);
}

/* oj[key]: an index into the glTF's array top, or the name of one of its
 * items; -1 when absent. */
static enum rayd_status item_ref(struct imp *im, const cJSON *oj, const struct jp *at,
                                 const char *key, const cJSON *arr, const char *top, int *out) {
    const cJSON *v = gl_get(oj, key);
    struct jp p = jp_key(at, key);
    int n = cJSON_IsArray(arr) ? cJSON_GetArraySize(arr) : 0;
    *out = -1;
    if (!v) return RAYD_OK;
    if (cJSON_IsNumber(v)) {
        if (!(v->valuedouble >= 0 && v->valuedouble < n && floor(v->valuedouble) == v->valuedouble))
            return n == 0 ? sj_fail(im->ld, RAYD_E_INVALID, &p, "the glTF has no %s", top)
                          : sj_fail(im->ld, RAYD_E_INVALID, &p,
                                    "must be an index in 0..%d of the glTF's %s", n - 1, top);
        *out = (int)v->valuedouble;
        return RAYD_OK;
    }
    if (!cJSON_IsString(v))
        return sj_fail(im->ld, RAYD_E_INVALID, &p, "must be an index or a name, not %s",
                       sj_type_name(v));
    int i = 0;
    for (const cJSON *e = arr ? arr->child : NULL; e; e = e->next, i++) {
        const cJSON *name = gl_get(e, "name");
        if (cJSON_IsString(name) && !strcmp(name->valuestring, v->valuestring)) {
            *out = i;
            return RAYD_OK;
        }
    }
    char q[96];
    return sj_fail(im->ld, RAYD_E_INVALID, &p, "the glTF has no %s named \"%s\"", top,
                   jp_quote(q, sizeof q, v->valuestring));
}

/* ---- meshes, one per material ------------------------------------------- */

/* A vertex of md copied to slot w of pos, nrm, uv. */
static void copy_vertex(const struct mesh_data *md, uint32_t v, uint32_t w, float *pos, float *nrm,
                        float *uv) {
    memcpy(pos + (size_t)w * 3, md->pos + (size_t)v * 3, 3 * sizeof *pos);
    if (nrm) memcpy(nrm + (size_t)w * 3, md->normal + (size_t)v * 3, 3 * sizeof *nrm);
    if (uv) memcpy(uv + (size_t)w * 2, md->uv + (size_t)v * 2, 2 * sizeof *uv);
}

/* Triangles tris[0..n) of md as a new mesh of the scene, their vertices
 * renumbered in order of first use.  remap (one entry per vertex of md,
 * all UINT32_MAX) is left as it was found, so each material costs its own
 * triangles only. */
static enum rayd_status split_one(struct imp *im, const struct mesh_data *md, const uint32_t *tris,
                                  uint32_t n, uint32_t *remap, uint32_t *id) {
    struct loader *ld = im->ld;
    size_t cap = (size_t)n * 3 < md->nverts ? (size_t)n * 3 : md->nverts;
    uint32_t *ix = malloc((size_t)n * 3 * sizeof *ix), nv = 0;
    float *pos = malloc(cap * 3 * sizeof *pos);
    float *nrm = md->normal ? malloc(cap * 3 * sizeof *nrm) : NULL;
    float *uv = md->uv ? malloc(cap * 2 * sizeof *uv) : NULL;
    if (!ix || !pos || (md->normal && !nrm) || (md->uv && !uv)) {
        free(ix), free(pos), free(nrm), free(uv);
        return err_set(ld->err, RAYD_E_NOMEM, im->src.s, "out of memory");
    }
    for (size_t k = 0; k < (size_t)n * 3; k++) {
        uint32_t v = md->index[(size_t)tris[k / 3] * 3 + k % 3];
        if (remap[v] == UINT32_MAX) copy_vertex(md, v, remap[v] = nv++, pos, nrm, uv);
        ix[k] = remap[v];
    }
    for (size_t k = 0; k < (size_t)n * 3; k++)
        remap[md->index[(size_t)tris[k / 3] * 3 + k % 3]] = UINT32_MAX;
    struct mesh_data part = {pos, nrm, uv, ix, nv, n, 0};
    return sj_mesh_baked(ld, &part, id);
}

/* The scene's material for glTF material m (n: the default one), added on
 * first use; *map caches it. */
static enum rayd_status use_material(struct imp *im, const struct gltf_mats *g, int m, int *map) {
    struct loader *ld = im->ld;
    if (map[m] >= 0) return RAYD_OK;
    struct material mat = g->m[m];
    if (mat.texture >= 0) {
        int t;
        TRY(sj_add_texture(ld, &g->tex[mat.texture], &t));
        g->tex[mat.texture].rgb = NULL; /* the scene owns the texels now */
        g->tex[mat.texture].shared = NULL;
        mat.texture = t;
    }
    struct jp pm = jp_key(&im->src, "gltf");
    if (ld->s->nmats > ld->lim->max_materials)
        return sj_fail(ld, RAYD_E_LIMIT, &pm, "brings the scene past the limit of %d materials",
                       ld->lim->max_materials);
    return sj_add_material(ld, &mat, &map[m]);
}

/* Triangle t's material slot: tm[t], or g->n (glTF's default material). */
static int slot(const struct gltf_mats *g, int32_t m) { return m < 0 || m >= g->n ? g->n : m; }

/* md split by tm into one mesh object per material, in objs (n objects):
 * the triangles sorted by material (a counting sort), then each run a mesh. */
static enum rayd_status split(struct imp *im, const struct mesh_data *md, const int32_t *tm,
                              const struct gltf_mats *g, int override, struct object **objs,
                              int32_t *n) {
    struct loader *ld = im->ld;
    int nm = g->n + 1;
    uint32_t *start = calloc((size_t)nm + 1, sizeof *start);
    uint32_t *order = malloc(((size_t)md->ntris + 1) * sizeof *order);
    uint32_t *remap = malloc(((size_t)md->nverts + 1) * sizeof *remap);
    int *map = malloc((size_t)nm * sizeof *map);
    *objs = calloc((size_t)nm, sizeof **objs);
    enum rayd_status st = RAYD_OK;
    if (!start || !order || !remap || !map || !*objs) {
        free(start), free(order), free(remap), free(map);
        return err_set(ld->err, RAYD_E_NOMEM, im->src.s, "out of memory");
    }
    memset(remap, 0xff, ((size_t)md->nverts + 1) * sizeof *remap);
    for (int m = 0; m < nm; m++) map[m] = -1;
    for (uint32_t t = 0; t < md->ntris; t++) start[slot(g, tm[t]) + 1]++;
    for (int m = 0; m < nm; m++) start[m + 1] += start[m];
    for (uint32_t t = 0; t < md->ntris; t++) order[start[slot(g, tm[t])]++] = t;
    for (int m = nm; m > 0; m--) start[m] = start[m - 1]; /* back to each run's start */
    start[0] = 0;
    for (int m = 0; st == RAYD_OK && m < nm; m++) {
        if (start[m + 1] == start[m]) continue;
        struct object *o = &(*objs)[*n];
        memset(o, 0, sizeof *o);
        o->kind = SHAPE_MESH;
        o->xform = -1;
        o->material = override;
        if (override < 0) st = use_material(im, g, m, map);
        if (st == RAYD_OK && override < 0) o->material = map[m];
        if (st == RAYD_OK)
            st = split_one(im, md, order + start[m], start[m + 1] - start[m], remap, &o->u.mesh.id);
        if (st == RAYD_OK) (*n)++;
    }
    free(start), free(order), free(remap), free(map);
    return st;
}

/* The meshes as a group of their own, which o draws as an instance. */
static enum rayd_status add_group(struct imp *im, struct object *objs, int32_t n,
                                  struct object *o) {
    rayd_scene *s = im->ld->s;
    struct group *gs = realloc(s->groups, ((size_t)s->ngroups + 1) * sizeof *gs);
    if (!gs) {
        free(objs);
        return err_set(im->ld->err, RAYD_E_NOMEM, im->src.s, "out of memory");
    }
    s->groups = gs;
    struct group *gr = &s->groups[s->ngroups];
    memset(gr, 0, sizeof *gr);
    gr->objs = objs;
    gr->nobjs = n;
    o->kind = SHAPE_INSTANCE;
    o->u.inst.group = s->ngroups++;
    double t0 = clock_now();
    enum rayd_status st =
        scene_build_bvh(s, &gr->objs, gr->nobjs, &gr->bvh, &gr->bounds, im->ld->err);
    s->build_s += clock_now() - t0;
    return st;
}

/* No glTF materials (an override): the default one alone, untextured. */
static bool mats_none(struct gltf_mats *g) {
    g->m = calloc(1, sizeof *g->m);
    g->uv_set = malloc(sizeof *g->uv_set);
    if (!g->m || !g->uv_set) return false;
    g->m[0] = material_default();
    g->uv_set[0] = -1;
    return true;
}

/* The walked scene's triangles (the glTF's materials, or override >= 0)
 * as o, an instance of a new group. */
static enum rayd_status load_meshes(struct imp *im, int override, struct object *o) {
    struct loader *ld = im->ld;
    struct gltf_mats g = {0};
    struct mesh_data md = {0};
    int32_t *tm = NULL, n = 0;
    struct object *objs = NULL;
    long room = ld->lim->max_materials - ld->s->nmats;
    struct mesh_limits ml = sj_mesh_budget(ld); /* its charge hook, for the image decodes */
    enum rayd_status st = override >= 0 ? RAYD_OK
                                        : gltf_mats_read(im->doc, (int)(room > 0 ? room : 0),
                                                         sj_max_texels(ld) - ld->texels, &ml,
                                                         ld->lim->assets, &g, ld->err);
    ld->texels += g.texels; /* the scene's image textures together */
    ld->s->images_decoded += g.decodes;
    if (override >= 0 && !mats_none(&g))
        st = err_set(ld->err, RAYD_E_NOMEM, im->src.s, "out of memory");
    bool any_uv = false;
    for (int m = 0; m <= g.n && st == RAYD_OK; m++) any_uv = any_uv || g.uv_set[m] >= 0;
    double t0 = clock_now();
    if (st == RAYD_OK) st = gltf_doc_bake(im->doc, g.uv_set, any_uv ? g.n + 1 : 0, &md, &tm);
    ld->s->decode_s += clock_now() - t0;
    if (st != RAYD_OK) {
        gltf_mats_free(&g);
        return imp_fail(im, st);
    }
    /* the glTF's textures and its meshes before they are built, less what
     * the image decodes and the bake charged already */
    size_t all = (size_t)g.texels * 3 * sizeof(float) + sj_mesh_bytes(&md),
           pre = md.charged + g.charged;
    st = all > pre ? sj_charge(ld, &im->src, all - pre) : RAYD_OK;
    if (all < pre) sj_give_back(ld, pre - all);
    if (st != RAYD_OK) {
        sj_give_back(ld, md.charged);
        mesh_data_free(&md);
        free(tm);
        gltf_mats_free(&g);
        return st;
    }
    g.charged = 0; /* the textures' floats stay charged: the scene holds them */
    if (override >= 0)
        for (uint32_t t = 0; t < md.ntris; t++) tm[t] = -1;
    ld->vertices += md.nverts;
    ld->triangles += md.ntris;
    st = split(im, &md, tm, &g, override, &objs, &n);
    mesh_data_free(&md);
    free(tm);
    gltf_mats_free(&g);
    if (st == RAYD_OK && (ld->objects += n) > ld->lim->max_objects)
        st = sj_fail(ld, RAYD_E_LIMIT, &im->src, "brings the scene past the limit of %ld objects",
                     ld->lim->max_objects);
    if (st != RAYD_OK) {
        free(objs);
        return st;
    }
    return add_group(im, objs, n, o);
}

/* ---- lights and camera ---------------------------------------------------- */

/* w * (x, y, z, h): a point (h = 1) or a direction (h = 0) of the glTF's world. */
static vec3 gworld(const double *w, double x, double y, double z, double h) {
    return v3(w[0] * x + w[4] * y + w[8] * z + w[12] * h,
              w[1] * x + w[5] * y + w[9] * z + w[13] * h,
              w[2] * x + w[6] * y + w[10] * z + w[14] * h);
}

/* The same, placed by the object's transform. */
static vec3 place(const struct imp *im, const double *w, double x, double y, double z, double h) {
    vec3 p = gworld(w, x, y, z, h);
    return h != 0 ? xform_point(im->x, p) : xform_dir(im->x, p);
}

static enum rayd_status light_of(struct imp *im, const cJSON *lj, const struct jp *pl,
                                 const double *w, double scale, struct light *l) {
    static const char *const keys[] = {"type", "color",      "intensity", "range", "spot",
                                       "name", "extensions", "extras",    NULL};
    static const char *const types[] = {"point", "directional", "spot", NULL};
    struct loader *ld = im->ld;
    int type;
    double k, inner, outer;
    if (!cJSON_IsObject(lj)) return sj_fail(ld, RAYD_E_INVALID, pl, "must be an object");
    TRY(sj_check_keys(ld, lj, pl, keys));
    TRY(sj_enum(ld, lj, pl, "type", types, &type));
    struct jp pt = jp_key(pl, "type"), pi = jp_key(pl, "intensity"), ps = jp_key(pl, "spot");
    if (type < 0)
        return sj_fail(ld, RAYD_E_INVALID, &pt, "is required (point, directional or spot)");
    memset(l, 0, sizeof *l);
    l->kind = type == 0 ? LIGHT_POINT : type == 1 ? LIGHT_DIRECTIONAL : LIGHT_SPOT;
    TRY(sj_vec(ld, lj, pl, "color", v3(1, 1, 1), VEC_COLOR, &l->color));
    TRY(sj_num(ld, lj, pl, "intensity", 1, 0, false, 1e9, &k));
    if (k * scale > 1e6)
        return sj_fail(ld, RAYD_E_LIMIT, &pi, "%g times light_scale %g is over rayd's limit of 1e6",
                       k, scale);
    l->intensity = k * scale;
    const cJSON *sp = gl_get(lj, "spot");
    if (sp && !cJSON_IsObject(sp)) return sj_fail(ld, RAYD_E_INVALID, &ps, "must be an object");
    TRY(sj_num(ld, sp, &ps, "innerConeAngle", 0, 0, false, GLTF_PI / 2, &inner));
    TRY(sj_num(ld, sp, &ps, "outerConeAngle", GLTF_PI / 4, 0, true, GLTF_PI / 2, &outer));
    struct jp pin = jp_key(&ps, "innerConeAngle");
    if (inner >= outer)
        return sj_fail(ld, RAYD_E_INVALID, &pin, "must be less than outerConeAngle");
    l->cos_outer = cos(outer);
    l->cos_inner = cos(inner);
    l->position = place(im, w, 0, 0, 0, 1);
    vec3 d = place(im, w, 0, 0, -1, 0); /* glTF lights shine along their node's -Z */
    if (!(v3_len(d) > 0))
        return sj_fail(ld, RAYD_E_INVALID, pl, "its node's matrix flattens the light's direction");
    l->direction = v3_norm(d);
    return RAYD_OK;
}

static enum rayd_status add_light(struct loader *ld, const struct light *l, const struct jp *at) {
    rayd_scene *s = ld->s;
    if (s->nlights >= ld->lim->max_lights)
        return sj_fail(ld, RAYD_E_LIMIT, at, "brings the scene past the limit of %d lights",
                       ld->lim->max_lights);
    struct light *ls = realloc(s->lights, ((size_t)s->nlights + 1) * sizeof *ls);
    if (!ls) return err_set(ld->err, RAYD_E_NOMEM, at->s, "out of memory");
    s->lights = ls;
    s->lights[s->nlights++] = *l;
    return RAYD_OK;
}

/* Every walked node's KHR_lights_punctual light. */
static enum rayd_status load_lights(struct imp *im, double scale) {
    const cJSON *root = gltf_doc_root(im->doc), *nodes = gl_get(root, "nodes");
    const cJSON *lights =
        gl_get(gl_get(gl_get(root, "extensions"), "KHR_lights_punctual"), "lights");
    int nl = cJSON_IsArray(lights) ? cJSON_GetArraySize(lights) : 0, i = 0;
    struct jp pg = jp_key(&im->src, "gltf"), pn = jp_key(&pg, "nodes");
    for (const cJSON *n = cJSON_IsArray(nodes) ? nodes->child : NULL; n; n = n->next, i++) {
        const cJSON *ext = gl_get(gl_get(n, "extensions"), "KHR_lights_punctual");
        const double *w = gltf_doc_world(im->doc, i);
        if (!ext || !w) continue;
        struct jp pi = jp_index(&pn, i), pe = jp_key(&pi, "extensions");
        struct jp pk = jp_key(&pe, "KHR_lights_punctual"), pl = jp_key(&pk, "light");
        const cJSON *lv = gl_get(ext, "light");
        if (!cJSON_IsNumber(lv) || !(lv->valuedouble >= 0 && lv->valuedouble < nl) ||
            floor(lv->valuedouble) != lv->valuedouble) {
            if (nl == 0)
                return sj_fail(im->ld, RAYD_E_INVALID, &pl,
                               "names a light, but the file has no "
                               "/extensions/KHR_lights_punctual/lights");
            return sj_fail(im->ld, RAYD_E_INVALID, &pl,
                           "must be an index in 0..%d of /extensions/KHR_lights_punctual/lights",
                           nl - 1);
        }
        int li = (int)lv->valuedouble;
        struct jp pe2 = jp_key(&pg, "extensions"), pk2 = jp_key(&pe2, "KHR_lights_punctual");
        struct jp pls = jp_key(&pk2, "lights"), plj = jp_index(&pls, li);
        struct light l;
        TRY(light_of(im, cJSON_GetArrayItem(lights, li), &plj, w, scale, &l));
        TRY(add_light(im->ld, &l, &pl));
    }
    return RAYD_OK;
}

/* The top-level camera's keys that a glTF camera sets: refused together. */
static enum rayd_status camera_clash(struct imp *im, const struct jp *at) {
    static const char *const set[] = {"position",   "look_at",    "up",    "fov_x", "fov_y",
                                      "projection", "view_width", "frame", "view",  NULL};
    for (int k = 0; set[k]; k++)
        if (gl_get(im->ld->camera, set[k]))
            return sj_fail(
                im->ld, RAYD_E_INVALID, at,
                "the glTF camera sets the scene's camera: /camera/%s cannot be given too "
                "(only aperture and focus_distance can)",
                set[k]);
    if (im->ld->gltf_camera)
        return sj_fail(im->ld, RAYD_E_INVALID, at, "another gltf object already sets the camera");
    return RAYD_OK;
}

/* Camera c of the glTF (at pc), seen from node n (world w), as the scene's. */
static enum rayd_status set_camera(struct imp *im, const cJSON *cj, const struct jp *pc,
                                   const double *w) {
    struct loader *ld = im->ld;
    static const char *const types[] = {"perspective", "orthographic", NULL};
    int type;
    if (!cJSON_IsObject(cj)) return sj_fail(ld, RAYD_E_INVALID, pc, "must be an object");
    TRY(sj_enum(ld, cj, pc, "type", types, &type));
    struct jp pt = jp_key(pc, "type"), pp = jp_key(pc, type == 1 ? "orthographic" : "perspective");
    if (type < 0)
        return sj_fail(ld, RAYD_E_INVALID, &pt, "is required (perspective or orthographic)");
    const cJSON *pj = gl_get(cj, type == 1 ? "orthographic" : "perspective");
    if (!cJSON_IsObject(pj)) return sj_fail(ld, RAYD_E_INVALID, &pp, "is required (an object)");
    vec3 pos = place(im, w, 0, 0, 0, 1), dir = place(im, w, 0, 0, -1, 0),
         up = place(im, w, 0, 1, 0, 0);
    if (!(v3_len(dir) > 0) || !(v3_len(up) > 0) ||
        !(v3_len(v3_cross(dir, up)) > 1e-12 * v3_len(dir) * v3_len(up)))
        return sj_fail(ld, RAYD_E_INVALID, pc, "its node's matrix flattens the camera's view");
    struct camera *cam = &ld->s->cam;
    double aperture = cam->aperture, focus = cam->focus, yfov = 0, ymag = 1;
    if (type == 0) TRY(sj_num(ld, pj, &pp, "yfov", -1, 0, true, 179 * GLTF_PI / 180, &yfov));
    if (type == 1) TRY(sj_num(ld, pj, &pp, "ymag", -1, 0, true, NUM_MAX, &ymag));
    struct jp py = jp_key(&pp, type == 0 ? "yfov" : "ymag");
    if (yfov < 0 || ymag < 0) return sj_fail(ld, RAYD_E_INVALID, &py, "is required");
    const struct render_settings *rs = &ld->s->rs;
    enum rayd_status st =
        cam_init(cam, pos, v3_add(pos, v3_norm(dir)), up, 0, type == 0 ? yfov * 180 / GLTF_PI : 60,
                 rs->width, rs->height, ld->err);
    if (st != RAYD_OK) return sj_fail(ld, st, pc, "%s", ld->err->message);
    if (type == 1 && aperture > 0) { /* as a hand-written orthographic camera */
        struct jp root = {.s = ""}, pa = jp_key(&root, "camera"), pap = jp_key(&pa, "aperture");
        return sj_fail(
            ld, RAYD_E_INVALID, &pap,
            "must be 0 with the glTF's orthographic camera (a lens needs a perspective)");
    }
    if (type == 1) { /* ymag is the half height in the file's units: scaled as up is */
        cam->ortho = true;
        cam->tan_y = ymag * v3_len(xform_dir(im->x, v3_norm(gworld(w, 0, 1, 0, 0))));
        cam->tan_x = cam->tan_y * rs->width / rs->height;
    }
    cam->aperture = aperture;
    if (gl_get(ld->camera, "focus_distance")) cam->focus = focus;
    ld->gltf_camera = true;
    return RAYD_OK;
}

static enum rayd_status load_camera(struct imp *im, const cJSON *oj, const struct jp *at) {
    const cJSON *root = gltf_doc_root(im->doc), *cams = gl_get(root, "cameras"),
                *nodes = gl_get(root, "nodes");
    int c, i = 0;
    TRY(item_ref(im, oj, at, "camera", cams, "cameras", &c));
    if (c < 0) return RAYD_OK;
    struct jp pc = jp_key(at, "camera");
    TRY(camera_clash(im, &pc));
    for (const cJSON *n = cJSON_IsArray(nodes) ? nodes->child : NULL; n; n = n->next, i++) {
        const cJSON *v = gl_get(n, "camera");
        const double *w = gltf_doc_world(im->doc, i);
        if (!w || !cJSON_IsNumber(v) || v->valuedouble != c) continue;
        struct jp pg = jp_key(&im->src, "gltf"), pcs = jp_key(&pg, "cameras"),
                  pci = jp_index(&pcs, c);
        return set_camera(im, cJSON_GetArrayItem(cams, c), &pci, w);
    }
    return sj_fail(im->ld, RAYD_E_INVALID, &pc, "no node of the glTF scene shows camera %d", c);
}

/* ---- the object ------------------------------------------------------------ */

/* "animation": the glTF animation played (an index or a name; the first
 * by default), at the scene's frame: seconds from /animation/start at its
 * fps.  A still scene plays none, so it shows the file's rest pose as it
 * always did. */
static enum rayd_status animate(struct imp *im, const cJSON *oj, const struct jp *at) {
    struct loader *ld = im->ld;
    const cJSON *anims = gl_get(gltf_doc_root(im->doc), "animations");
    int a;
    TRY(item_ref(im, oj, at, "animation", anims, "animations", &a));
    struct jp pa = jp_key(at, "animation");
    if (a >= 0 && !ld->anim->on)
        return sj_fail(ld, RAYD_E_INVALID, &pa, "needs /animation (the scene's frame range)");
    if (!ld->anim->on || !cJSON_IsArray(anims) || cJSON_GetArraySize(anims) == 0) return RAYD_OK;
    gltf_doc_animate(im->doc, a < 0 ? 0 : a, sj_anim_seconds(ld->anim));
    ld->gltf_animated = true; /* its meshes bake to other arrays each frame */
    return RAYD_OK;
}

static enum rayd_status load(struct imp *im, const cJSON *oj, const struct jp *at, int override,
                             struct object *o) {
    struct loader *ld = im->ld;
    const cJSON *root = gltf_doc_root(im->doc);
    int scene;
    bool lights;
    double scale;
    TRY(item_ref(im, oj, at, "scene", gl_get(root, "scenes"), "scenes", &scene));
    TRY(sj_bool(ld, oj, at, "lights", true, &lights));
    TRY(sj_num(ld, oj, at, "light_scale", 1, 0, true, 1e6, &scale));
    ld->gltf_animated = false;
    TRY(animate(im, oj, at));
    struct mesh_limits ml = sj_mesh_budget(ld);
    TRY(imp_fail(im, gltf_doc_walk(im->doc, scene, &ml)));
    TRY(load_meshes(im, override, o));
    if (lights) TRY(load_lights(im, scale));
    return load_camera(im, oj, at);
}

enum rayd_status sj_gltf(struct loader *ld, const cJSON *oj, const struct jp *at,
                         const struct xform *x, struct object *o) {
    const cJSON *src = cJSON_GetObjectItemCaseSensitive(oj, "source");
    struct imp im = {.ld = ld, .src = jp_key(at, "source"), .x = x};
    if (!src)
        return sj_fail(ld, RAYD_E_INVALID, &im.src,
                       "is required (a glTF or GLB file, as a mesh source)");
    if (!cJSON_IsObject(src))
        return sj_fail(ld, RAYD_E_INVALID, &im.src, "must be an object, not %s", sj_type_name(src));
    int format;
    char *owned = NULL;
    const char *bytes;
    size_t n;
    double t0 = clock_now();
    TRY(sj_source_read(ld, src, &im.src, &format, &owned, &bytes, &n));
    struct jp pf = jp_key(&im.src, "format");
    if (format < 2) {
        free(owned);
        return sj_fail(ld, RAYD_E_INVALID, &pf, "must be \"gltf\" or \"glb\" for a gltf object");
    }
    struct gltf_files f;
    struct mesh_gltf_opts opts;
    enum rayd_status st =
        sj_gltf_opts(ld, &im.src, cJSON_GetObjectItemCaseSensitive(src, "file"), &f, &opts);
    if (st == RAYD_OK) st = imp_fail(&im, gltf_doc_open(bytes, n, &opts, ld->err, &im.doc));
    ld->s->decode_s += clock_now() - t0;
    int override = cJSON_GetObjectItemCaseSensitive(oj, "material") ? o->material : -1;
    if (st == RAYD_OK) st = load(&im, oj, at, override, o);
    gltf_doc_free(im.doc);
    free(owned);
    return st;
}
