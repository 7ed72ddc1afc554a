/* scene_json.c -- scene format v1: JSON text to a frozen rayd_scene.
 *
 * The entry point of the loader (scene_json_util.h lists its other files and
 * the order they call each other in).  Loading is three passes:
 *
 *   1. json_check.c walks the bytes once before cJSON sees them: syntax,
 *      UTF-8 and nesting depth, each failure with a line, a column and what
 *      was expected.  cJSON parses recursively, so the depth is bounded
 *      there, not by its stack.
 *   2. cJSON parse.  cJSON writes a global error slot on every parse, so
 *      parses are serialised by one mutex (json_parse.c), cheap next to
 *      building the scene.
 *   3. A strict walk of the tree.  Every object accepts a fixed set of keys;
 *      unknown and duplicate keys, wrong types, non-finite or out-of-range
 *      numbers and zero-length vectors are refused with the JSON Pointer of
 *      the value ("/objects/1/radius") and what is wrong ("must be > 0").
 *      Omitted keys take the defaults in docs/scene-format.md.
 *
 * The walk fills a rayd_scene and freezes it (scene.c builds the BVH).
 *
 * Large inline mesh arrays skip cJSON: pass 1 notes where their numbers
 * are, cJSON parses the text without them, and the mesh loader reads them
 * from the text (scene_json_inline.c says how and why it is the same).
 */
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include "base/meter.h"
#include "format/json_check.h"
#include "format/json_parse.h"
#include "load/scene_json_anim.h"
#include "load/scene_json_env.h"
#include "load/scene_json_frame.h"
#include "load/scene_json.h"
#include "load/scene_json_inline.h"
#include "load/scene_json_material.h"
#include "load/scene_json_objects.h"
#include "render/render.h"
#include "shade/texture.h"

void rayd_limits_default(struct rayd_limits *lim) {
    lim->max_width = 16384;
    lim->max_height = 16384;
    lim->max_pixels = 40L * 1000 * 1000;
    lim->max_samples = 1024;
    lim->max_depth = 32;
    lim->max_objects = 1000000;
    lim->max_lights = 1024;
    lim->max_materials = 10000;
    lim->max_nesting = 64;
    lim->max_bytes = 256u << 20;
    lim->max_triangles = 5000000;
    lim->max_vertices = 5000000;
    lim->asset_dir = NULL;
    lim->asset_confine = 1;
    lim->max_texels = TEXTURE_MAX_SCENE_PIXELS;
    lim->charge = NULL;
    lim->charge_arg = NULL;
    lim->assets = NULL;
    lim->cancel = NULL;
}
/* ---- camera and render --------------------------------------------------- */

/* The top-level object named key, or *empty (an empty object) when the
 * scene leaves it out, so defaults apply through the same getters. */
static const cJSON *section(const cJSON *root, const char *key, cJSON *empty) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(root, key);
    if (v) return v;
    memset(empty, 0, sizeof *empty);
    empty->type = cJSON_Object;
    return empty;
}

/* The element of list before e whose AOVs overlap one's: a repeat, refused
 * as rayd_aov_parse refuses one in ?aov= (a typo for another name, most
 * likely), naming both. */
static enum rayd_status aov_again(struct loader *ld, const cJSON *list, const cJSON *e,
                                  const struct jp *pe, unsigned one) {
    int k = 0;
    const cJSON *q = list->child;
    for (; q != e; q = q->next, k++) {
        unsigned m = 0;
        struct rayd_error e2 = {0};
        if (rayd_aov_parse(q->valuestring, &m, &e2) == RAYD_OK && (m & one)) break;
    }
    if (q != e && !strcmp(q->valuestring, e->valuestring))
        return sj_fail(ld, RAYD_E_INVALID, pe, "names \"%.32s\" again (element %d named it)",
                       e->valuestring, k);
    return sj_fail(ld, RAYD_E_INVALID, pe, "names an AOV that element %d (\"%.32s\") named already",
                   k, q != e ? q->valuestring : "");
}

/* "aov": the AOVs the scene asks for, an array of names (render/aov.c):
 * what an EXR of it carries and rayd-render writes beside its image
 * unless told otherwise. */
static enum rayd_status load_aov(struct loader *ld, const cJSON *r, const struct jp *at,
                                 unsigned *mask) {
    const cJSON *list = cJSON_GetObjectItemCaseSensitive(r, "aov");
    struct jp p = jp_key(at, "aov");
    *mask = 0;
    if (!list) return RAYD_OK;
    if (!cJSON_IsArray(list))
        return sj_fail(ld, RAYD_E_INVALID, &p, "must be an array of AOV names, not %s",
                       sj_type_name(list));
    int i = 0;
    for (const cJSON *e = list->child; e; e = e->next, i++) {
        struct jp pe = jp_index(&p, i);
        if (!cJSON_IsString(e))
            return sj_fail(ld, RAYD_E_INVALID, &pe, "must be an AOV name, not %s", sj_type_name(e));
        unsigned one = 0;
        struct rayd_error e2 = {0};
        if (strchr(e->valuestring, ',') || rayd_aov_parse(e->valuestring, &one, &e2) != RAYD_OK)
            return sj_fail(ld, RAYD_E_INVALID, &pe,
                           "is no AOV; the AOVs are albedo, normal, depth, alpha, object, "
                           "material, id and all");
        if (one & *mask) return aov_again(ld, list, e, &pe, one);
        *mask |= one;
    }
    return RAYD_OK;
}

static enum rayd_status load_render(struct loader *ld, const cJSON *root) {
    static const char *const keys[] = {
        "width",       "height", "samples", "max_depth",      "background",    "seed", "integrator",
        "environment", "aov",    "denoise", "clamp_indirect", "filter_glossy", NULL};
    static const char *const integrators[] = {"whitted", "path", NULL};
    struct jp at = {.s = "/render"};
    cJSON empty;
    const cJSON *r = section(root, "render", &empty);
    TRY(sj_check_keys(ld, r, &at, keys));
    const struct rayd_limits *lim = ld->lim;
    struct render_settings *rs = &ld->s->rs;
    long w, h, spp, depth, seed;
    TRY(sj_int(ld, r, &at, "width", 640, 1, lim->max_width, true, &w));
    TRY(sj_int(ld, r, &at, "height", 480, 1, lim->max_height, true, &h));
    if (w * h > lim->max_pixels)
        return sj_fail(ld, RAYD_E_LIMIT, &at,
                       "width x height = %ld pixels is over the limit of %ld pixels", w * h,
                       lim->max_pixels);
    int max_spp = lim->max_samples < RENDER_SUM_SAMPLES ? lim->max_samples : RENDER_SUM_SAMPLES;
    TRY(sj_int(ld, r, &at, "samples", 1, 1, max_spp, true, &spp));
    TRY(sj_int(ld, r, &at, "max_depth", 5, 0, lim->max_depth, true, &depth));
    TRY(sj_int(ld, r, &at, "seed", 0, 0, 9007199254740991L, false, &seed));
    TRY(sj_vec(ld, r, &at, "background", v3(0, 0, 0), VEC_COLOR, &rs->background));
    int integ;
    TRY(sj_enum(ld, r, &at, "integrator", integrators, &integ));
    rs->integrator = integ == 1 ? INTEGRATOR_PATH : INTEGRATOR_WHITTED;
    rs->width = (int)w;
    rs->height = (int)h;
    rs->samples = (int)spp;
    rs->max_depth = (int)depth;
    rs->seed = (uint64_t)seed;
    TRY(load_aov(ld, r, &at, &rs->aov));
    TRY(sj_bool(ld, r, &at, "denoise", false, &rs->denoise));
    TRY(sj_num(ld, r, &at, "clamp_indirect", 0, 0, false, RENDER_SUM_CAP, &rs->clamp_indirect));
    TRY(sj_num(ld, r, &at, "filter_glossy", 0, 0, false, 1, &rs->filter_glossy));
    return ld->values_only ? RAYD_OK : sj_environment(ld, r, &at);
}

static enum rayd_status load_camera(struct loader *ld, const cJSON *root) {
    static const char *const keys[] = {
        "position", "look_at",        "up",    "fov_x", "fov_y",   "projection", "view_width",
        "aperture", "focus_distance", "frame", "view",  "azimuth", "elevation",  NULL};
    static const char *const projections[] = {"perspective", "orthographic", NULL};
    struct jp at = {.s = "/camera"};
    cJSON empty;
    const cJSON *c = section(root, "camera", &empty);
    ld->camera = cJSON_GetObjectItemCaseSensitive(root, "camera");
    TRY(sj_check_keys(ld, c, &at, keys));
    vec3 pos, look, up;
    double fx, fy;
    TRY(sj_vec(ld, c, &at, "position", v3(0, 0, 0), VEC_ANY, &pos));
    TRY(sj_vec(ld, c, &at, "look_at", v3(0, 0, -1), VEC_ANY, &look));
    TRY(sj_vec(ld, c, &at, "up", v3(0, 1, 0), VEC_NONZERO, &up));
    TRY(sj_num(ld, c, &at, "fov_x", 0, 0, true, 179, &fx));
    TRY(sj_num(ld, c, &at, "fov_y", 0, 0, true, 179, &fy));
    bool framed;
    TRY(sj_frame_read(ld, c, &at, &framed));
    ld->frame_fx = fx;
    ld->frame_fy = fy;
    const struct render_settings *rs = &ld->s->rs;
    struct camera *cam = &ld->s->cam;
    TRY(cam_init(cam, pos, look, up, fx, fy, rs->width, rs->height, ld->err));
    int proj;
    double view_w, aperture, focus;
    TRY(sj_enum(ld, c, &at, "projection", projections, &proj));
    TRY(sj_num(ld, c, &at, "view_width", 2, 0, true, NUM_MAX, &view_w));
    TRY(sj_num(ld, c, &at, "aperture", 0, 0, false, NUM_MAX, &aperture));
    TRY(sj_num(ld, c, &at, "focus_distance", cam->focus, 0, true, NUM_MAX, &focus));
    struct jp pa = jp_key(&at, "aperture");
    if (proj == 1) {
        if (aperture > 0)
            return sj_fail(ld, RAYD_E_INVALID, &pa, "must be 0 with an orthographic projection");
        cam->ortho = true;
        cam->tan_x = view_w / 2; /* half extents of the view, in scene units */
        cam->tan_y = cam->tan_x * rs->height / rs->width;
    }
    cam->aperture = aperture / 2; /* the key is the lens diameter */
    cam->focus = focus;
    return RAYD_OK;
}

/* ---- lights ------------------------------------------------------------------ */

/* Area lights: "shape" rectangle (position = a corner, edge1, edge2), disc
 * (position = centre, normal, radius) or sphere (position, radius), with
 * "samples" shadow rays per shading point (default 16). */
static enum rayd_status load_area_light(struct loader *ld, const cJSON *lj, const struct jp *at,
                                        struct light *l) {
    static const char *const shapes[] = {"rectangle", "disc", "sphere", NULL};
    int shape;
    long samples;
    TRY(sj_enum(ld, lj, at, "shape", shapes, &shape));
    l->shape = shape == 1 ? AREA_DISC : shape == 2 ? AREA_SPHERE : AREA_RECT;
    TRY(sj_int(ld, lj, at, "samples", 16, 1, 1024, true, &samples));
    l->samples = (int)samples;
    TRY(sj_num(ld, lj, at, "radius", 0.5, 0, true, NUM_MAX, &l->radius));
    TRY(sj_vec(ld, lj, at, "edge1", v3(1, 0, 0), VEC_NONZERO, &l->e1));
    TRY(sj_vec(ld, lj, at, "edge2", v3(0, 0, 1), VEC_NONZERO, &l->e2));
    vec3 n;
    TRY(sj_vec(ld, lj, at, "normal", v3(0, -1, 0), VEC_NONZERO, &n));
    struct jp p = jp_key(at, "edge2");
    if (l->shape == AREA_RECT && !(v3_len(v3_cross(l->e1, l->e2)) > 0))
        return sj_fail(ld, RAYD_E_INVALID, &p, "must not be parallel to edge1");
    if (l->shape == AREA_DISC) {
        l->direction = v3_norm(n);
        v3_frame(l->direction, &l->e1, &l->e2);
    }
    return RAYD_OK;
}

static enum rayd_status load_light(struct loader *ld, const cJSON *lj, const struct jp *at,
                                   struct light *l) {
    static const char *const types[] = {"point", "directional", "spot", "area", NULL};
    static const char *const point_keys[] = {"type", "position", "color", "intensity", NULL};
    static const char *const dir_keys[] = {"type", "direction", "color", "intensity", NULL};
    static const char *const spot_keys[] = {"type",      "position", "direction", "color",
                                            "intensity", "angle",    "falloff",   NULL};
    static const char *const area_keys[] = {"type",      "shape",   "position", "edge1",
                                            "edge2",     "normal",  "radius",   "color",
                                            "intensity", "samples", NULL};
    static const char *const *const keys[] = {point_keys, dir_keys, spot_keys, area_keys};
    if (!cJSON_IsObject(lj))
        return sj_fail(ld, RAYD_E_INVALID, at, "must be an object, not %s", sj_type_name(lj));
    int kind;
    TRY(sj_type(ld, lj, at, types, &kind));
    TRY(sj_check_keys(ld, lj, at, keys[kind]));
    l->kind = (enum light_kind)kind;
    TRY(sj_vec(ld, lj, at, "color", v3(1, 1, 1), VEC_COLOR, &l->color));
    TRY(sj_num(ld, lj, at, "intensity", 1, 0, false, 1e6, &l->intensity));
    TRY(sj_vec(ld, lj, at, "position", v3(0, 10, 0), VEC_ANY, &l->position));
    vec3 dir;
    TRY(sj_vec(ld, lj, at, "direction", v3(0, -1, 0), VEC_NONZERO, &dir));
    l->direction = v3_norm(dir);
    double angle, falloff;
    TRY(sj_num(ld, lj, at, "angle", 30, 0, true, 90, &angle));
    TRY(sj_num(ld, lj, at, "falloff", fmin(5, angle / 2), 0, false, angle, &falloff));
    l->cos_outer = cos(angle * DEG2RAD);
    l->cos_inner = cos((angle - falloff) * DEG2RAD);
    if (l->cos_inner <= l->cos_outer) l->cos_inner = nextafter(l->cos_outer, 2.0);
    return kind == LIGHT_AREA ? load_area_light(ld, lj, at, l) : RAYD_OK;
}

static enum rayd_status load_lights(struct loader *ld, const cJSON *root) {
    const cJSON *ls = cJSON_GetObjectItemCaseSensitive(root, "lights");
    if (!ls) return RAYD_OK;
    struct jp at = {.s = "/lights"};
    if (!cJSON_IsArray(ls))
        return sj_fail(ld, RAYD_E_INVALID, &at, "must be an array, not %s", sj_type_name(ls));
    int n = cJSON_GetArraySize(ls);
    if (n > ld->lim->max_lights)
        return sj_fail(ld, RAYD_E_LIMIT, &at, "has %d lights; the limit is %d", n,
                       ld->lim->max_lights);
    if (n == 0) return RAYD_OK;
    ld->s->lights = calloc((size_t)n, sizeof *ld->s->lights);
    if (!ld->s->lights) return err_set(ld->err, RAYD_E_NOMEM, NULL, "out of memory");
    int i = 0;
    for (const cJSON *l = ls->child; l; l = l->next, i++) {
        struct jp p = jp_index(&at, i);
        TRY(load_light(ld, l, &p, &ld->s->lights[i]));
        ld->s->nlights = i + 1;
    }
    return RAYD_OK;
}

/* ---- text checks and parse ----------------------------------------------------- */

/* The text has passed json_check, so a failure here is out of memory. */
static enum rayd_status parse_json(const char *json, size_t len, cJSON **out,
                                   struct rayd_error *err) {
    cJSON *root = json_parse_locked(json, len);
    if (!root) return err_set(err, RAYD_E_NOMEM, NULL, "out of memory parsing the scene");
    *out = root;
    return RAYD_OK;
}

static enum rayd_status load_root(struct loader *ld, cJSON *root, long frame) {
    static const char *const keys[] = {"version", "camera",  "render",    "materials", "lights",
                                       "groups",  "objects", "animation", NULL};
    struct jp at = {.s = ""};
    if (!cJSON_IsObject(root))
        return err_set(ld->err, RAYD_E_INVALID, "", "the scene must be a JSON object, not %s",
                       sj_type_name(root));
    TRY(sj_check_keys(ld, root, &at, keys));
    long version;
    TRY(sj_int(ld, root, &at, "version", 1, 1, 1, false, &version));
    TRY(sj_anim_load(ld, root, frame)); /* the tree at the frame, before it is read */
    TRY(load_render(ld, root));
    TRY(load_camera(ld, root));
    TRY(sj_materials(ld, root));
    TRY(load_lights(ld, root));
    TRY(sj_groups(ld, root));
    TRY(sj_objects(ld, root));
    return sj_frame_apply(ld); /* camera.frame needs the objects' bounds */
}

/* Check, and note the large inline mesh arrays; parse the rest with cJSON. */
static enum rayd_status check_and_parse(const char *json, size_t len, const struct rayd_limits *lim,
                                        struct sj_inline *in, cJSON **root,
                                        struct rayd_error *err) {
    struct json_spans *spans = in->spans.min_count > 0 ? &in->spans : NULL;
    TRY(json_check_spans(json, len, lim->max_nesting, spans, err));
    char *copy;
    size_t copy_len = 0;
    sj_inline_elide(in, json, len, &copy, &copy_len);
    enum rayd_status st = parse_json(copy ? copy : json, copy ? copy_len : len, root, err);
    free(copy);
    if (st == RAYD_OK) st = sj_inline_match(in, *root, err);
    return st;
}

/* The frame's facts for rayd_scene_animation. */
static void note_frames(rayd_scene *s, const struct sj_anim *a) {
    s->anim = (struct rayd_animation){.animated = a->on,
                                      .start = a->start,
                                      .end = a->end,
                                      .fps = a->on ? a->fps : 0,
                                      .frame = a->frame};
}

/* *lim, or the defaults into *def when it is NULL; a text over its bytes
 * refused. */
static enum rayd_status text_limits(const struct rayd_limits **lim, struct rayd_limits *def,
                                    size_t len, struct rayd_error *err) {
    if (!*lim) {
        rayd_limits_default(def);
        *lim = def;
    }
    if (len > (*lim)->max_bytes)
        return err_set(err, RAYD_E_LIMIT, NULL, "the scene is %zu bytes; the limit is %zu", len,
                       (*lim)->max_bytes);
    return RAYD_OK;
}

/* scene_json_parse at frame `frame` (< 0: the first; rayd_scene_parse_frame). */
static enum rayd_status scene_json_parse_frame(const char *json, size_t len,
                                               const struct rayd_limits *lim, long inline_min,
                                               long frame, rayd_scene **out,
                                               struct rayd_error *err) {
    struct rayd_limits deflim;
    TRY(text_limits(&lim, &deflim, len, err));
    if (lim->cancel && atomic_load(lim->cancel))
        return err_set(err, RAYD_E_CANCELED, NULL, "the parse was canceled");
    /* the flag is looked at through this thread's meter (meter_live): by
     * the decoders at each charge, and by the BVH builds */
    struct meter m = meter_make(lim->cancel, NULL), *was = meter_here;
    if (lim->cancel) meter_bind(&m);
    struct sj_inline in = {.spans.min_count = inline_min > 0 ? inline_min : 0};
    cJSON *root = NULL;
    rayd_scene *s = NULL;
    enum rayd_status st = check_and_parse(json, len, lim, &in, &root, err);
    if (st == RAYD_OK) st = scene_alloc(&s, err);
    if (st == RAYD_OK) {
        struct sj_anim anim = {0};
        struct loader ld = {.lim = lim, .s = s, .err = err, .inl = &in, .anim = &anim};
        st = load_root(&ld, root, frame);
        if (st != RAYD_OK) sj_anim_error(&anim, err);
        if (anim.on) /* what each frame's parse makes again (rayd_scene_info.frame_work) */
            s->frame_work = ld.frame_work + (double)len / SJ_WORK_TEXT_BYTES +
                            (double)ld.objects * SJ_WORK_OBJECT +
                            (double)anim.keyed * SJ_WORK_KEYED;
        note_frames(s, &anim);
        sj_anim_free(&anim);
        free(ld.mat_names);
        free(ld.group_names);
        if (st == RAYD_OK) st = scene_freeze(s, err);
        if (st == RAYD_OK && !meter_live()) /* raised after the last look */
            st = err_set(err, RAYD_E_CANCELED, NULL, "the parse was canceled");
        if (st != RAYD_OK) rayd_scene_free(s);
    }
    cJSON_Delete(root);
    sj_inline_free(&in);
    meter_bind(was);
    if (st == RAYD_OK) *out = s;
    return st;
}

enum rayd_status scene_json_parse(const char *json, size_t len, const struct rayd_limits *lim,
                                  long inline_min, rayd_scene **out, struct rayd_error *err) {
    return scene_json_parse_frame(json, len, lim, inline_min, -1, out, err);
}

enum rayd_status rayd_scene_parse(const char *json, size_t len, const struct rayd_limits *lim,
                                  rayd_scene **out, struct rayd_error *err) {
    return scene_json_parse_frame(json, len, lim, SJ_INLINE_MIN, -1, out, err);
}

enum rayd_status rayd_scene_parse_frame(const char *json, size_t len, const struct rayd_limits *lim,
                                        long frame, rayd_scene **out, struct rayd_error *err) {
    if (frame < 0)
        return err_set(err, RAYD_E_ARG, "/animation", "frame %ld: frames are numbered from 0",
                       frame);
    return scene_json_parse_frame(json, len, lim, SJ_INLINE_MIN, frame, out, err);
}

/* ---- every frame's values (rayd_scene_check_frames) ------------------------- */

/* Frame k's camera, lights and keyframed transforms through the loader's
 * own checks, on copies of the camera and the lights (the keyframes' pass
 * writes their values into them), with no object built and no file read.
 * cam and lights are the scene's, taken out of root. */
static enum rayd_status check_frame(const struct rayd_limits *lim, const struct sj_inline *in,
                                    cJSON *root, const cJSON *cam, const cJSON *lights, long k,
                                    struct rayd_error *err) {
    rayd_scene *s = NULL;
    TRY(scene_alloc(&s, err));
    cJSON *c = cam ? cJSON_Duplicate(cam, true) : NULL;
    cJSON *l = lights ? cJSON_Duplicate(lights, true) : NULL;
    enum rayd_status st = RAYD_OK;
    if ((cam && !c) || (lights && !l)) st = err_set(err, RAYD_E_NOMEM, NULL, "out of memory");
    if (c) cJSON_AddItemToObject(root, "camera", c);
    if (l) cJSON_AddItemToObject(root, "lights", l);
    struct sj_anim anim = {.keep = true};
    struct loader ld = {
        .lim = lim, .s = s, .err = err, .inl = in, .anim = &anim, .values_only = true};
    if (st == RAYD_OK) st = sj_anim_load(&ld, root, k);
    if (st == RAYD_OK) st = load_render(&ld, root);
    if (st == RAYD_OK) st = load_camera(&ld, root);
    if (st == RAYD_OK) st = load_lights(&ld, root);
    if (st != RAYD_OK) sj_anim_error(&anim, err);
    sj_anim_free(&anim);
    cJSON_DeleteItemFromObjectCaseSensitive(root, "camera");
    cJSON_DeleteItemFromObjectCaseSensitive(root, "lights");
    rayd_scene_free(s);
    return st;
}

/* Every frame of first..last within the scene's, in order, until one fails. */
static enum rayd_status check_frames(const struct rayd_limits *lim, const struct sj_inline *in,
                                     cJSON *root, long first, long last, struct rayd_error *err) {
    bool on = false;
    long start = 0, end = 0;
    struct loader ld = {.lim = lim, .err = err, .values_only = true};
    TRY(sj_anim_range(&ld, root, &on, &start, &end));
    if (!on) return RAYD_OK;
    cJSON *cam = cJSON_DetachItemFromObjectCaseSensitive(root, "camera");
    cJSON *lights = cJSON_DetachItemFromObjectCaseSensitive(root, "lights");
    enum rayd_status st = RAYD_OK;
    for (long k = first > start ? first : start; k <= last && k <= end && st == RAYD_OK; k++) {
        if (lim->cancel && atomic_load(lim->cancel))
            st = err_set(err, RAYD_E_CANCELED, NULL, "the check of the frames was canceled");
        else
            st = check_frame(lim, in, root, cam, lights, k, err);
    }
    cJSON_Delete(cam);
    cJSON_Delete(lights);
    return st;
}

enum rayd_status rayd_scene_check_frames(const char *json, size_t len,
                                         const struct rayd_limits *lim, long first, long last,
                                         struct rayd_error *err) {
    struct rayd_limits deflim;
    TRY(text_limits(&lim, &deflim, len, err));
    struct sj_inline in = {.spans.min_count = SJ_INLINE_MIN};
    cJSON *root = NULL;
    enum rayd_status st = check_and_parse(json, len, lim, &in, &root, err);
    if (st == RAYD_OK && !cJSON_IsObject(root))
        st = err_set(err, RAYD_E_INVALID, "", "the scene must be a JSON object, not %s",
                     sj_type_name(root));
    if (st == RAYD_OK) st = check_frames(lim, &in, root, first, last, err);
    cJSON_Delete(root);
    sj_inline_free(&in);
    return st;
}

void rayd_scene_animation(const rayd_scene *scene, struct rayd_animation *out) {
    *out = scene->anim;
}
