/* scene_json_anim.c -- time in a scene: /animation and keyframes.
 *
 *   "animation": {"start": 0, "end": 47, "fps": 24}
 *   "camera": {"look_at": [0, 1, 0], "interpolation": "smooth",
 *              "keyframes": [{"frame": 0, "position": [6, 2, 0]},
 *                            {"frame": 47, "position": [0, 2, 6], "fov_x": 40}]}
 *
 * A scene is loaded at one frame.  This file runs first, before the rest of
 * the loader reads the tree: it checks the /animation block and every
 * "keyframes" array (on the camera, on lights, on any object, group member
 * or CSG operand), evaluates each animated key at the frame, and leaves a
 * tree the still loader reads as it always has:
 *
 *   - the camera's and the lights' keyframed keys are written into their
 *     objects as plain values ("position": [x, y, z]); the keyframes and
 *     interpolation keys are taken out;
 *   - an object's keyframed translate, rotate and scale make one transform
 *     step, kept here by the object's node and applied after the object's
 *     own "transform" (sj_anim_xform, called by load_transform).
 *
 * So frame k of a scene is a pure function of its bytes and k, through the
 * very code a still scene goes through.  A value the keyframes wrote is
 * checked again by that code; an error there is renamed (sj_anim_error) to
 * the keyframes' pointer, with the frame and the key, since the key is not
 * in the file.  Each key of a keyframe is a channel of its own: a key
 * given in some keyframes only is interpolated between those; a key given
 * in the owner and in its keyframes is refused, so nothing is ambiguous.
 * Rotations are quaternions (keyframe.c: slerp, or a smooth curve).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "load/scene_json_anim.h"
#include "math/keyframe.h"

#define ANIM_MAX_FRAME 1000000L /* frame numbers: 0 .. this */
/* The slowest rate: ffmpeg refuses a frame rate much below 1e-5 (its
 * timestamps overflow: "Invalid argument"), so a video job would fail only
 * once every frame is rendered.  0.001 is well clear of that and still a
 * frame every 16 minutes. */
#define ANIM_MIN_FPS 0.001

enum ch_kind { CH_VEC, CH_NUM, CH_ROT, CH_SCALE };

/* A key that keyframes may animate, with the rule of its still value. */
struct channel {
    const char *key;
    enum ch_kind kind;
    enum vec_rule rule;
    double lo, hi;
    bool lo_open;
};

#define VEC(k, r)                                                                                  \
    { k, CH_VEC, r, 0, 0, false }
#define NUM(k, lo, open, hi)                                                                       \
    { k, CH_NUM, VEC_ANY, lo, hi, open }

static const struct channel camera_ch[] = {VEC("position", VEC_ANY),
                                           VEC("look_at", VEC_ANY),
                                           VEC("up", VEC_NONZERO),
                                           NUM("fov_x", 0, true, 179),
                                           NUM("fov_y", 0, true, 179),
                                           NUM("focus_distance", 0, true, NUM_MAX),
                                           NUM("aperture", 0, false, NUM_MAX),
                                           NUM("azimuth", -360, false, 360),
                                           NUM("elevation", -90, false, 90),
                                           {NULL, CH_NUM, VEC_ANY, 0, 0, false}};
static const struct channel light_ch[] = {VEC("position", VEC_ANY),
                                          VEC("direction", VEC_NONZERO),
                                          VEC("color", VEC_COLOR),
                                          NUM("intensity", 0, false, 1e6),
                                          {NULL, CH_NUM, VEC_ANY, 0, 0, false}};
static const struct channel object_ch[] = {VEC("translate", VEC_ANY),
                                           {"rotate", CH_ROT, VEC_ANY, 0, 0, false},
                                           {"scale", CH_SCALE, VEC_ANY, 0, 0, false},
                                           {NULL, CH_NUM, VEC_ANY, 0, 0, false}};

/* Which light channels each light type has (the keys of its still form). */
static bool light_has(const cJSON *lj, const char *key) {
    const cJSON *t = cJSON_GetObjectItemCaseSensitive(lj, "type");
    const char *type = cJSON_IsString(t) ? t->valuestring : "";
    if (!strcmp(key, "direction"))
        return strcmp(type, "directional") == 0 || strcmp(type, "spot") == 0;
    if (!strcmp(key, "position")) return strcmp(type, "directional") != 0;
    return true;
}

/* One owner's keyframes: the times and the keyframe objects. */
struct track_set {
    const cJSON *owner, *keys;
    struct jp at, kat; /* the owner's pointer and its keyframes' */
    int n;
    double *t;
    const cJSON **k;
    enum kf_interp how;
};

/* ---- the animation block ------------------------------------------------ */

static enum rayd_status anim_block(struct loader *ld, const cJSON *root, struct sj_anim *a) {
    static const char *const keys[] = {"start", "end", "fps", NULL};
    const cJSON *b = cJSON_GetObjectItemCaseSensitive(root, "animation");
    if (!b) return RAYD_OK;
    struct jp at = {.s = "/animation"};
    TRY(sj_check_keys(ld, b, &at, keys));
    struct jp pe = jp_key(&at, "end");
    if (!cJSON_GetObjectItemCaseSensitive(b, "end"))
        return sj_fail(ld, RAYD_E_INVALID, &pe, "is required (the last frame)");
    TRY(sj_int(ld, b, &at, "start", 0, 0, ANIM_MAX_FRAME, false, &a->start));
    TRY(sj_int(ld, b, &at, "end", 0, 0, ANIM_MAX_FRAME, false, &a->end));
    TRY(sj_num(ld, b, &at, "fps", 24, ANIM_MIN_FPS, false, 1000, &a->fps));
    if (a->end < a->start)
        return sj_fail(ld, RAYD_E_INVALID, &pe, "must be >= /animation/start (%ld)", a->start);
    a->on = true;
    return RAYD_OK;
}

/* ---- one owner's keyframes --------------------------------------------- */

/* The keyframes array: objects, each with a frame in range, in order. */
static enum rayd_status read_keys(struct loader *ld, const struct sj_anim *a,
                                  const struct channel *ch, const cJSON *lj, struct track_set *ts) {
    const char *allowed[16] = {"frame"};
    int na = 1;
    for (const struct channel *c = ch; c->key; c++)
        if (!lj || light_has(lj, c->key)) allowed[na++] = c->key;
    allowed[na] = NULL;
    if (!cJSON_IsArray(ts->keys) || cJSON_GetArraySize(ts->keys) == 0)
        return sj_fail(ld, RAYD_E_INVALID, &ts->kat, "must be a non-empty array of keyframes");
    ts->n = cJSON_GetArraySize(ts->keys);
    ts->t = calloc((size_t)ts->n, sizeof *ts->t);
    ts->k = calloc((size_t)ts->n, sizeof *ts->k);
    if (!ts->t || !ts->k) return err_set(ld->err, RAYD_E_NOMEM, NULL, "out of memory");
    int i = 0;
    for (const cJSON *k = ts->keys->child; k; k = k->next, i++) {
        struct jp pk = jp_index(&ts->kat, i), pf = jp_key(&pk, "frame");
        TRY(sj_check_keys(ld, k, &pk, allowed));
        if (!cJSON_GetObjectItemCaseSensitive(k, "frame"))
            return sj_fail(ld, RAYD_E_INVALID, &pf, "is required (the keyframe's frame number)");
        double f;
        TRY(sj_num(ld, k, &pk, "frame", 0, -NUM_MAX, false, NUM_MAX, &f));
        if (f < (double)a->start || f > (double)a->end)
            return sj_fail(ld, RAYD_E_INVALID, &pf, "%g is outside the animation's frames %ld-%ld",
                           f, a->start, a->end);
        if (i > 0 && f == ts->t[i - 1])
            return sj_fail(ld, RAYD_E_INVALID, &pf,
                           "%g is the frame of keyframe %d too (one keyframe a frame)", f, i - 1);
        if (i > 0 && f < ts->t[i - 1])
            return sj_fail(ld, RAYD_E_INVALID, &pf,
                           "%g comes before keyframe %d's frame %g (keyframes go in frame order)",
                           f, i - 1, ts->t[i - 1]);
        if (k->child && !k->child->next)
            return sj_fail(ld, RAYD_E_INVALID, &pk, "has a frame and nothing to animate");
        ts->t[i] = f;
        ts->k[i] = k;
    }
    return RAYD_OK;
}

/* A rotation as a quaternion: [rx, ry, rz] degrees, or {"axis", "angle"}. */
static enum rayd_status read_rot(struct loader *ld, const cJSON *k, const struct jp *pk,
                                 double *q) {
    const cJSON *ro = cJSON_GetObjectItemCaseSensitive(k, "rotate");
    struct jp p = jp_key(pk, "rotate");
    if (cJSON_IsObject(ro)) {
        static const char *const rkeys[] = {"axis", "angle", NULL};
        vec3 axis;
        double angle;
        TRY(sj_check_keys(ld, ro, &p, rkeys));
        TRY(sj_vec(ld, ro, &p, "axis", v3(0, 1, 0), VEC_NONZERO, &axis));
        TRY(sj_num(ld, ro, &p, "angle", 0, -1e6, false, 1e6, &angle));
        kf_quat_axis(axis, angle, q);
        return RAYD_OK;
    }
    vec3 e;
    TRY(sj_vec_value(ld, ro, &p, VEC_ANY, &e));
    kf_quat_euler(e, q);
    return RAYD_OK;
}

static enum rayd_status read_scale(struct loader *ld, const cJSON *k, const struct jp *pk,
                                   double *s) {
    const cJSON *sc = cJSON_GetObjectItemCaseSensitive(k, "scale");
    struct jp p = jp_key(pk, "scale");
    vec3 v;
    if (cJSON_IsNumber(sc)) {
        double x;
        TRY(sj_num(ld, k, pk, "scale", 1, -NUM_MAX, false, NUM_MAX, &x));
        v = v3(x, x, x);
    } else {
        TRY(sj_vec_value(ld, sc, &p, VEC_ANY, &v));
    }
    if (fabs(v.x) < 1e-9 || fabs(v.y) < 1e-9 || fabs(v.z) < 1e-9)
        return sj_fail(ld, RAYD_E_INVALID, &p,
                       "must not be zero (or smaller than 1e-9) in any axis");
    s[0] = v.x, s[1] = v.y, s[2] = v.z;
    return RAYD_OK;
}

/* Channel c of every keyframe that has it, evaluated at the frame: *n keys
 * (0: no keyframe has it), the value in out (dim 1, 3 or 4). */
static enum rayd_status eval_channel(struct loader *ld, const struct sj_anim *a,
                                     const struct track_set *ts, const struct channel *c, int *n,
                                     double *out) {
    int dim = c->kind == CH_NUM ? 1 : c->kind == CH_ROT ? 4 : 3;
    double *t = malloc(sizeof *t * (size_t)ts->n), *v = malloc(sizeof *v * 4 * (size_t)ts->n);
    if (!t || !v) {
        free(t);
        free(v);
        return err_set(ld->err, RAYD_E_NOMEM, NULL, "out of memory");
    }
    enum rayd_status st = RAYD_OK;
    int m = 0;
    for (int i = 0; i < ts->n && st == RAYD_OK; i++) {
        const cJSON *k = ts->k[i];
        if (!cJSON_GetObjectItemCaseSensitive(k, c->key)) continue;
        struct jp pk = jp_index(&ts->kat, i), p = jp_key(&pk, c->key);
        double *o = v + m * dim;
        vec3 x;
        switch (c->kind) {
        case CH_NUM: st = sj_num(ld, k, &pk, c->key, 0, c->lo, c->lo_open, c->hi, o); break;
        case CH_ROT: st = read_rot(ld, k, &pk, o); break;
        case CH_SCALE: st = read_scale(ld, k, &pk, o); break;
        case CH_VEC:
            st = sj_vec_value(ld, cJSON_GetObjectItemCaseSensitive(k, c->key), &p, c->rule, &x);
            o[0] = x.x, o[1] = x.y, o[2] = x.z;
            break;
        }
        t[m++] = ts->t[i];
    }
    if (st == RAYD_OK && m > 0) {
        if (c->kind == CH_ROT)
            kf_eval_quat(t, v, m, ts->how, (double)a->frame, out);
        else
            kf_eval(t, v, m, dim, ts->how, (double)a->frame, out);
    }
    *n = m;
    free(t);
    free(v);
    return st;
}

/* "keyframes" and "interpolation" of owner o: each at most once, the
 * interpolation only beside keyframes, keyframes only with /animation. */
static enum rayd_status find_keys(struct loader *ld, const struct sj_anim *a, const cJSON *o,
                                  const struct jp *at, struct track_set *ts) {
    static const char *const how[] = {"linear", "smooth", "step", NULL};
    const cJSON *keys = NULL, *interp = NULL;
    for (const cJSON *c = o->child; c; c = c->next) {
        const cJSON **slot = !strcmp(c->string, "keyframes")       ? &keys
                             : !strcmp(c->string, "interpolation") ? &interp
                                                                   : NULL;
        if (!slot) continue;
        struct jp p = jp_key(at, c->string);
        if (*slot) return sj_fail(ld, RAYD_E_INVALID, &p, "duplicate key");
        *slot = c;
    }
    *ts = (struct track_set){
        .owner = o, .keys = keys, .at = *at, .kat = jp_key(at, "keyframes"), .how = KF_LINEAR};
    struct jp pi = jp_key(at, "interpolation");
    if (interp && !keys) return sj_fail(ld, RAYD_E_INVALID, &pi, "needs keyframes beside it");
    if (keys && !a->on)
        return sj_fail(ld, RAYD_E_INVALID, &ts->kat, "needs /animation (the scene's frame range)");
    int h;
    TRY(sj_enum(ld, o, at, "interpolation", how, &h));
    ts->how = h == 1 ? KF_SMOOTH : h == 2 ? KF_STEP : KF_LINEAR;
    return RAYD_OK;
}

static void drop_keys(cJSON *o) {
    cJSON_DeleteItemFromObjectCaseSensitive(o, "keyframes");
    cJSON_DeleteItemFromObjectCaseSensitive(o, "interpolation");
}

/* ---- owners: camera and lights (values into the tree) -------------------- */

static enum rayd_status note_sub(struct loader *ld, const struct jp *p, const struct jp *keys) {
    struct sj_anim *a = ld->anim;
    if (!array_grow((void **)&a->sub, &a->sub_cap, a->nsub + 1, sizeof *a->sub))
        return err_set(ld->err, RAYD_E_NOMEM, NULL, "out of memory");
    snprintf(a->sub[a->nsub].at, sizeof a->sub[a->nsub].at, "%s", p->s);
    snprintf(a->sub[a->nsub].keys, sizeof a->sub[a->nsub].keys, "%s", keys->s);
    a->nsub++;
    return RAYD_OK;
}

static enum rayd_status put_value(struct loader *ld, cJSON *o, const struct channel *c,
                                  const double *v) {
    cJSON *item = c->kind == CH_NUM ? cJSON_CreateNumber(v[0]) : cJSON_CreateDoubleArray(v, 3);
    if (!item || !cJSON_AddItemToObject(o, c->key, item)) {
        cJSON_Delete(item);
        return err_set(ld->err, RAYD_E_NOMEM, NULL, "out of memory");
    }
    return RAYD_OK;
}

static enum rayd_status anim_values(struct loader *ld, cJSON *o, const struct jp *at,
                                    const struct channel *ch, bool light) {
    struct track_set ts = {0};
    TRY(find_keys(ld, ld->anim, o, at, &ts));
    if (!ts.keys) return RAYD_OK;
    ld->anim->keyed++;
    enum rayd_status st = read_keys(ld, ld->anim, ch, light ? o : NULL, &ts);
    for (const struct channel *c = ch; c->key && st == RAYD_OK; c++) {
        double v[4];
        int n = 0;
        if (light && !light_has(o, c->key)) continue;
        st = eval_channel(ld, ld->anim, &ts, c, &n, v);
        if (st != RAYD_OK || n == 0) continue;
        struct jp p = jp_key(at, c->key);
        if (cJSON_GetObjectItemCaseSensitive(o, c->key))
            st = sj_fail(ld, RAYD_E_INVALID, &p, "is animated by %s too: give it in one place",
                         ts.kat.s);
        if (st == RAYD_OK) st = note_sub(ld, &p, &ts.kat);
        if (st == RAYD_OK) st = put_value(ld, o, c, v);
    }
    free(ts.t);
    free(ts.k);
    if (st == RAYD_OK) drop_keys(o);
    return st;
}

static enum rayd_status anim_lights(struct loader *ld, cJSON *root) {
    cJSON *ls = cJSON_GetObjectItemCaseSensitive(root, "lights");
    if (!cJSON_IsArray(ls)) return RAYD_OK; /* the lights' loader says what is wrong */
    struct jp at = {.s = "/lights"};
    int i = 0;
    for (cJSON *l = ls->child; l; l = l->next, i++) {
        struct jp p = jp_index(&at, i);
        if (cJSON_IsObject(l)) TRY(anim_values(ld, l, &p, light_ch, true));
    }
    return RAYD_OK;
}

/* ---- owners: objects (a transform step) ----------------------------------- */

static enum rayd_status anim_object(struct loader *ld, cJSON *o, const struct jp *at) {
    struct sj_anim *a = ld->anim;
    struct track_set ts = {0};
    TRY(find_keys(ld, a, o, at, &ts));
    if (!ts.keys) return RAYD_OK;
    a->keyed++;
    double tr[4] = {0, 0, 0, 0}, q[4] = {0, 0, 0, 1}, s[4] = {1, 1, 1, 0};
    int n;
    enum rayd_status st = read_keys(ld, a, object_ch, NULL, &ts);
    if (st == RAYD_OK) st = eval_channel(ld, a, &ts, &object_ch[2], &n, s);
    if (st == RAYD_OK) st = eval_channel(ld, a, &ts, &object_ch[1], &n, q);
    if (st == RAYD_OK) st = eval_channel(ld, a, &ts, &object_ch[0], &n, tr);
    free(ts.t);
    free(ts.k);
    TRY(st);
    struct xform sx = xform_scale(v3(s[0], s[1], s[2])), rx = kf_quat_xform(q),
                 tx = xform_translate(v3(tr[0], tr[1], tr[2]));
    struct xform x = xform_then(&sx, &rx);
    x = xform_then(&x, &tx);
    if (fabs(s[0]) < 1e-9 || fabs(s[1]) < 1e-9 || fabs(s[2]) < 1e-9 || !xform_sane(&x))
        return sj_fail(
            ld, RAYD_E_INVALID, &ts.kat,
            "at frame %ld the keyframed scale is zero (or within 1e-9 of it) in some axis",
            a->frame);
    if (a->keep) return RAYD_OK; /* the next frame's check reads the keyframes again */
    if (!array_grow((void **)&a->xf, &a->xf_cap, a->nxf + 1, sizeof *a->xf))
        return err_set(ld->err, RAYD_E_NOMEM, NULL, "out of memory");
    a->xf[a->nxf++] = (struct sj_anim_xf){.obj = o, .x = x};
    drop_keys(o);
    return RAYD_OK;
}

/* Every object of the array list (at), and the operands of its CSG objects. */
static enum rayd_status anim_objects(struct loader *ld, cJSON *list, const struct jp *at,
                                     int depth) {
    if (!cJSON_IsArray(list) || depth > 64) return RAYD_OK; /* the loader refuses these */
    int i = 0;
    for (cJSON *o = list->child; o; o = o->next, i++) {
        if (!cJSON_IsObject(o)) continue;
        struct jp p = jp_index(at, i);
        TRY(anim_object(ld, o, &p));
        const cJSON *type = cJSON_GetObjectItemCaseSensitive(o, "type");
        if (cJSON_IsString(type) && !strcmp(type->valuestring, "csg")) {
            struct jp po = jp_key(&p, "operands");
            TRY(anim_objects(ld, cJSON_GetObjectItemCaseSensitive(o, "operands"), &po, depth + 1));
        }
    }
    return RAYD_OK;
}

static int cmp_xf(const void *pa, const void *pb) {
    const struct sj_anim_xf *a = pa, *b = pb;
    return a->obj < b->obj ? -1 : a->obj > b->obj;
}

/* ---- the entry points ----------------------------------------------------- */

enum rayd_status sj_anim_load(struct loader *ld, cJSON *root, long frame) {
    struct sj_anim *a = ld->anim;
    TRY(anim_block(ld, root, a));
    struct jp top = {.s = "/animation"};
    a->frame = frame < 0 ? a->start : frame;
    if (a->frame < a->start || a->frame > a->end) {
        if (!a->on)
            return err_set(ld->err, RAYD_E_ARG, "",
                           "frame %ld: the scene has no /animation, so its one frame is 0", frame);
        return err_set(ld->err, RAYD_E_ARG, top.s,
                       "frame %ld is outside the animation's frames %ld-%ld", frame, a->start,
                       a->end);
    }
    cJSON *cam = cJSON_GetObjectItemCaseSensitive(root, "camera");
    struct jp pc = {.s = "/camera"};
    if (cJSON_IsObject(cam)) TRY(anim_values(ld, cam, &pc, camera_ch, false));
    TRY(anim_lights(ld, root));
    struct jp po = {.s = "/objects"}, pg = {.s = "/groups"};
    TRY(anim_objects(ld, cJSON_GetObjectItemCaseSensitive(root, "objects"), &po, 0));
    cJSON *gs = cJSON_GetObjectItemCaseSensitive(root, "groups");
    for (cJSON *g = cJSON_IsObject(gs) ? gs->child : NULL; g; g = g->next) {
        struct jp p = jp_key(&pg, g->string);
        TRY(anim_objects(ld, g, &p, 0));
    }
    if (a->nxf > 1) qsort(a->xf, a->nxf, sizeof *a->xf, cmp_xf);
    return RAYD_OK;
}

enum rayd_status sj_anim_range(struct loader *ld, const cJSON *root, bool *on, long *start,
                               long *end) {
    struct sj_anim a = {0};
    TRY(anim_block(ld, root, &a));
    *on = a.on;
    *start = a.start;
    *end = a.end;
    return RAYD_OK;
}

bool sj_anim_xform(const struct sj_anim *a, const cJSON *obj, struct xform *x) {
    if (!a || a->nxf == 0) return false;
    struct sj_anim_xf key = {.obj = obj};
    const struct sj_anim_xf *f = bsearch(&key, a->xf, a->nxf, sizeof *a->xf, cmp_xf);
    if (f) *x = f->x;
    return f != NULL;
}

/* Whether path is at (or under) the pointer of n bytes at at. */
static bool anim_under(const char *path, const char *at, size_t n) {
    return strncmp(path, at, n) == 0 && (path[n] == 0 || path[n] == '/');
}

/* err renamed to sub's keyframes, with the frame and what of the owner
 * (from byte `from` of its path) was wrong. */
static void anim_rename(const struct sj_anim *a, const struct sj_anim_sub *sub,
                        struct rayd_error *err, size_t from) {
    char msg[sizeof err->message];
    snprintf(msg, sizeof msg, "at frame %ld, %.100s: %.140s", a->frame, err->path + from,
             err->message);
    memcpy(err->message, msg, sizeof msg);
    snprintf(err->path, sizeof err->path, "%s", sub->keys);
}

void sj_anim_error(const struct sj_anim *a, struct rayd_error *err) {
    if (!err || err->code == RAYD_OK) return;
    for (size_t i = 0; i < a->nsub; i++) /* a value the keyframes wrote */
        if (anim_under(err->path, a->sub[i].at, strlen(a->sub[i].at))) {
            anim_rename(a, &a->sub[i], err,
                        (size_t)(strrchr(a->sub[i].at, '/') - a->sub[i].at + 1));
            return;
        }
    for (size_t i = 0; i < a->nsub; i++) { /* a still value checked against a keyframed one
                                               (the camera's look_at that its moving position
                                               met): the message names the keyframed one */
        size_t n = (size_t)(strrchr(a->sub[i].at, '/') - a->sub[i].at);
        if (n > 0 && anim_under(err->path, a->sub[i].at, n) && err->path[n] == '/' &&
            strstr(err->message, a->sub[i].at)) {
            anim_rename(a, &a->sub[i], err, n + 1);
            return;
        }
    }
}

double sj_anim_seconds(const struct sj_anim *a) {
    return a->on ? (double)(a->frame - a->start) / a->fps : 0;
}

void sj_anim_free(struct sj_anim *a) {
    free(a->xf);
    free(a->sub);
    memset(a, 0, sizeof *a);
}
