/* scene_json.c -- scene format v1: JSON text to a frozen rayd_scene.
 *
 * The only file that includes cJSON.  Loading is three passes:
 *
 *   1. json_check.c walks the bytes once before cJSON sees them: syntax,
 *      UTF-8 and nesting depth, each failure with a line, a column and what
 *      was expected.  cJSON parses recursively, so the depth is bounded
 *      there, not by its stack.
 *   2. cJSON parse.  cJSON writes a global error slot on every parse, so
 *      parses are serialised by one mutex -- the only lock in the core, and
 *      cheap next to building the scene.
 *   3. A strict walk of the tree.  Every object accepts a fixed set of keys;
 *      unknown and duplicate keys, wrong types, non-finite or out-of-range
 *      numbers and zero-length vectors are refused with the JSON Pointer of
 *      the value ("/objects/1/radius") and what is wrong ("must be > 0").
 *      Omitted keys take the defaults in docs/scene-format.md.
 *
 * The walk fills a rayd_scene and freezes it (scene.c builds the BVH).
 */
#include <errno.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include <cjson/cJSON.h>

#include "error.h"
#include "base64.h"
#include "json_check.h"
#include "mesh_io.h"
#include "scene.h"

#define DEG2RAD (3.14159265358979323846 / 180.0)
#define NUM_MAX 1e9 /* coordinates and sizes: generous but far from overflow */

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
}

/* ---- JSON Pointers ----------------------------------------------------- */

struct jp {
    char s[256];
};

static struct jp jp_key(const struct jp *parent, const char *key) {
    struct jp r;
    size_t n = (size_t)snprintf(r.s, sizeof r.s, "%.200s/", parent->s);
    for (const char *k = key; *k && n + 3 < sizeof r.s; k++) {
        if (*k == '~' || *k == '/') { /* RFC 6901 escapes */
            r.s[n++] = '~';
            r.s[n++] = *k == '~' ? '0' : '1';
        } else {
            r.s[n++] = *k;
        }
    }
    r.s[n < sizeof r.s ? n : sizeof r.s - 1] = '\0';
    return r;
}

static struct jp jp_index(const struct jp *parent, int i) {
    struct jp r;
    snprintf(r.s, sizeof r.s, "%.200s/%d", parent->s, i);
    return r;
}

/* ---- the loader ---------------------------------------------------------- */

struct loader {
    const struct rayd_limits *lim;
    rayd_scene *s;
    struct rayd_error *err;
    const cJSON *materials; /* the /materials object, for names */
    int mat_cap;
    uint32_t mesh_cap;
    int32_t xform_cap;
    long triangles, vertices; /* totals so far, against the limits */
};

static const char *type_name(const cJSON *v) {
    if (cJSON_IsNumber(v)) return "a number";
    if (cJSON_IsString(v)) return "a string";
    if (cJSON_IsBool(v)) return "a boolean";
    if (cJSON_IsNull(v)) return "null";
    if (cJSON_IsArray(v)) return "an array";
    return "an object";
}

static enum rayd_status fail(struct loader *ld, enum rayd_status code, const struct jp *at,
                             const char *fmt, ...) __attribute__((format(printf, 4, 5)));
static enum rayd_status fail(struct loader *ld, enum rayd_status code, const struct jp *at,
                             const char *fmt, ...) {
    char msg[256];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return err_set(ld->err, code, at->s, "%s", msg);
}

static int cmp_names(const void *a, const void *b) {
    return strcmp(*(const char *const *)a, *(const char *const *)b);
}

/* Every key of obj must be in allowed (NULL-terminated; NULL = any key) and
 * appear once. */
static enum rayd_status check_keys(struct loader *ld, const cJSON *obj, const struct jp *at,
                                   const char *const *allowed) {
    if (!cJSON_IsObject(obj))
        return fail(ld, RAYD_E_INVALID, at, "must be an object, not %s", type_name(obj));
    int n = 0;
    for (const cJSON *c = obj->child; c; c = c->next) {
        n++;
        if (!allowed) continue;
        const char *const *a = allowed;
        while (*a && strcmp(*a, c->string) != 0) a++;
        if (*a) continue;
        char list[200] = "";
        for (a = allowed; *a; a++) {
            strncat(list, *a, sizeof list - strlen(list) - 1);
            if (a[1]) strncat(list, ", ", sizeof list - strlen(list) - 1);
        }
        struct jp p = jp_key(at, c->string);
        return fail(ld, RAYD_E_INVALID, &p, "unknown key (allowed here: %s)", list);
    }
    if (n < 2) return RAYD_OK;
    const char **names = malloc(sizeof *names * (size_t)n);
    if (!names) return err_set(ld->err, RAYD_E_NOMEM, at->s, "out of memory");
    int i = 0;
    for (const cJSON *c = obj->child; c; c = c->next) names[i++] = c->string;
    qsort(names, (size_t)n, sizeof *names, cmp_names);
    for (i = 1; i < n && strcmp(names[i - 1], names[i]) != 0; i++) continue;
    enum rayd_status st = RAYD_OK;
    if (i < n) {
        struct jp p = jp_key(at, names[i]);
        st = fail(ld, RAYD_E_INVALID, &p, "duplicate key");
    }
    free(names);
    return st;
}

/* A number in [lo, hi] (lo excluded when lo_open). */
static enum rayd_status get_num(struct loader *ld, const cJSON *obj, const struct jp *at,
                                const char *key, double def, double lo, bool lo_open, double hi,
                                double *out) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!v) {
        *out = def;
        return RAYD_OK;
    }
    struct jp p = jp_key(at, key);
    if (!cJSON_IsNumber(v))
        return fail(ld, RAYD_E_INVALID, &p, "must be a number, not %s", type_name(v));
    double x = v->valuedouble;
    if (!isfinite(x)) return fail(ld, RAYD_E_INVALID, &p, "must be a finite number");
    if (lo_open && !(x > lo)) return fail(ld, RAYD_E_INVALID, &p, "must be > %g", lo);
    if (!lo_open && x < lo) return fail(ld, RAYD_E_INVALID, &p, "must be >= %g", lo);
    if (x > hi) return fail(ld, RAYD_E_INVALID, &p, "must be <= %g", hi);
    *out = x;
    return RAYD_OK;
}

/* A whole number in [lo, hi]; above hi is a limit (RAYD_E_LIMIT) when
 * hi_is_limit, else invalid. */
static enum rayd_status get_int(struct loader *ld, const cJSON *obj, const struct jp *at,
                                const char *key, long def, long lo, long hi, bool hi_is_limit,
                                long *out) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!v) {
        *out = def;
        return RAYD_OK;
    }
    struct jp p = jp_key(at, key);
    if (!cJSON_IsNumber(v))
        return fail(ld, RAYD_E_INVALID, &p, "must be an integer, not %s", type_name(v));
    double x = v->valuedouble;
    if (!isfinite(x) || floor(x) != x)
        return fail(ld, RAYD_E_INVALID, &p, "must be an integer");
    if (x < (double)lo) return fail(ld, RAYD_E_INVALID, &p, "must be >= %ld", lo);
    if (x > (double)hi)
        return fail(ld, hi_is_limit ? RAYD_E_LIMIT : RAYD_E_INVALID, &p,
                    hi_is_limit ? "must be <= %ld (the server's limit)" : "must be <= %ld", hi);
    *out = (long)x;
    return RAYD_OK;
}

enum vec_rule { VEC_ANY, VEC_NONZERO, VEC_COLOR };

static enum rayd_status get_vec(struct loader *ld, const cJSON *obj, const struct jp *at,
                                const char *key, vec3 def, enum vec_rule rule, vec3 *out) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!v) {
        *out = def;
        return RAYD_OK;
    }
    struct jp p = jp_key(at, key);
    if (!cJSON_IsArray(v) || cJSON_GetArraySize(v) != 3)
        return fail(ld, RAYD_E_INVALID, &p, "must be an array of 3 numbers");
    double c[3];
    int i = 0;
    for (const cJSON *e = v->child; e; e = e->next, i++) {
        struct jp pe = jp_index(&p, i);
        if (!cJSON_IsNumber(e))
            return fail(ld, RAYD_E_INVALID, &pe, "must be a number, not %s", type_name(e));
        c[i] = e->valuedouble;
        if (!isfinite(c[i])) return fail(ld, RAYD_E_INVALID, &pe, "must be a finite number");
        if (fabs(c[i]) > NUM_MAX) return fail(ld, RAYD_E_INVALID, &pe, "must be in [-1e9, 1e9]");
        if (rule == VEC_COLOR && c[i] < 0) return fail(ld, RAYD_E_INVALID, &pe, "must be >= 0");
    }
    *out = v3(c[0], c[1], c[2]);
    if (rule == VEC_NONZERO && !(v3_len(*out) > 0))
        return fail(ld, RAYD_E_INVALID, &p, "must not be a zero-length vector");
    return RAYD_OK;
}

#define TRY(expr)                                                                        \
    do {                                                                                 \
        enum rayd_status st_ = (expr);                                                   \
        if (st_ != RAYD_OK) return st_;                                                  \
    } while (0)

/* ---- camera and render --------------------------------------------------- */

static enum rayd_status load_render(struct loader *ld, const cJSON *root) {
    static const char *const keys[] = {"width",      "height", "samples", "max_depth",
                                       "background", "seed",   NULL};
    struct jp at = {"/render"};
    const cJSON *r = cJSON_GetObjectItemCaseSensitive(root, "render");
    cJSON empty = {0};
    empty.type = cJSON_Object;
    if (!r) r = &empty;
    TRY(check_keys(ld, r, &at, keys));
    const struct rayd_limits *lim = ld->lim;
    struct render_settings *rs = &ld->s->rs;
    long w, h, spp, depth, seed;
    TRY(get_int(ld, r, &at, "width", 640, 1, lim->max_width, true, &w));
    TRY(get_int(ld, r, &at, "height", 480, 1, lim->max_height, true, &h));
    if (w * h > lim->max_pixels)
        return fail(ld, RAYD_E_LIMIT, &at,
                    "width x height = %ld pixels is over the limit of %ld pixels", w * h,
                    lim->max_pixels);
    TRY(get_int(ld, r, &at, "samples", 1, 1, lim->max_samples, true, &spp));
    TRY(get_int(ld, r, &at, "max_depth", 5, 0, lim->max_depth, true, &depth));
    TRY(get_int(ld, r, &at, "seed", 0, 0, 9007199254740991L, false, &seed));
    TRY(get_vec(ld, r, &at, "background", v3(0, 0, 0), VEC_COLOR, &rs->background));
    rs->width = (int)w;
    rs->height = (int)h;
    rs->samples = (int)spp;
    rs->max_depth = (int)depth;
    rs->seed = (uint64_t)seed;
    return RAYD_OK;
}

static enum rayd_status load_camera(struct loader *ld, const cJSON *root) {
    static const char *const keys[] = {"position", "look_at", "up", "fov_x", "fov_y", NULL};
    struct jp at = {"/camera"};
    const cJSON *c = cJSON_GetObjectItemCaseSensitive(root, "camera");
    cJSON empty = {0};
    empty.type = cJSON_Object;
    if (!c) c = &empty;
    TRY(check_keys(ld, c, &at, keys));
    vec3 pos, look, up;
    double fx, fy;
    TRY(get_vec(ld, c, &at, "position", v3(0, 0, 0), VEC_ANY, &pos));
    TRY(get_vec(ld, c, &at, "look_at", v3(0, 0, -1), VEC_ANY, &look));
    TRY(get_vec(ld, c, &at, "up", v3(0, 1, 0), VEC_NONZERO, &up));
    TRY(get_num(ld, c, &at, "fov_x", 0, 0, true, 179, &fx));
    TRY(get_num(ld, c, &at, "fov_y", 0, 0, true, 179, &fy));
    const struct render_settings *rs = &ld->s->rs;
    return cam_init(&ld->s->cam, pos, look, up, fx, fy, rs->width, rs->height, ld->err);
}

/* ---- materials ------------------------------------------------------------ */

static enum rayd_status parse_material(struct loader *ld, const cJSON *m, const struct jp *at,
                                       struct material *out) {
    static const char *const keys[] = {"color",        "ambient",      "diffuse",
                                       "specular",     "shininess",    "reflectivity",
                                       "transparency", "ior",          "emission",
                                       NULL};
    TRY(check_keys(ld, m, at, keys));
    struct material d = material_default();
    *out = d;
    TRY(get_vec(ld, m, at, "color", d.color, VEC_COLOR, &out->color));
    TRY(get_vec(ld, m, at, "emission", d.emission, VEC_COLOR, &out->emission));
    TRY(get_num(ld, m, at, "ambient", d.ambient, 0, false, 1, &out->ambient));
    TRY(get_num(ld, m, at, "diffuse", d.diffuse, 0, false, 1, &out->diffuse));
    TRY(get_num(ld, m, at, "specular", d.specular, 0, false, 1, &out->specular));
    TRY(get_num(ld, m, at, "shininess", d.shininess, 0, false, 10000, &out->shininess));
    TRY(get_num(ld, m, at, "reflectivity", d.reflectivity, 0, false, 1, &out->reflectivity));
    TRY(get_num(ld, m, at, "transparency", d.transparency, 0, false, 1, &out->transparency));
    TRY(get_num(ld, m, at, "ior", d.ior, 0, true, 10, &out->ior));
    return RAYD_OK;
}

static enum rayd_status add_material(struct loader *ld, const struct material *m, int *index) {
    rayd_scene *s = ld->s;
    if (s->nmats == ld->mat_cap) {
        int cap = ld->mat_cap ? ld->mat_cap * 2 : 16;
        struct material *p = realloc(s->mats, sizeof *p * (size_t)cap);
        if (!p) return err_set(ld->err, RAYD_E_NOMEM, NULL, "out of memory");
        s->mats = p;
        ld->mat_cap = cap;
    }
    s->mats[s->nmats] = *m;
    *index = s->nmats++;
    return RAYD_OK;
}

/* Named materials take indices 1..n in the order of /materials; index 0 is
 * the default material. */
static enum rayd_status load_materials(struct loader *ld, const cJSON *root) {
    struct material def = material_default();
    int idx;
    TRY(add_material(ld, &def, &idx));
    const cJSON *ms = cJSON_GetObjectItemCaseSensitive(root, "materials");
    if (!ms) return RAYD_OK;
    struct jp at = {"/materials"};
    TRY(check_keys(ld, ms, &at, NULL));
    if (cJSON_GetArraySize(ms) > ld->lim->max_materials)
        return fail(ld, RAYD_E_LIMIT, &at, "has %d materials; the limit is %d",
                    cJSON_GetArraySize(ms), ld->lim->max_materials);
    for (const cJSON *m = ms->child; m; m = m->next) {
        struct jp p = jp_key(&at, m->string);
        if (m->string[0] == '\0') return fail(ld, RAYD_E_INVALID, &p, "a material name may not be empty");
        struct material mat;
        TRY(parse_material(ld, m, &p, &mat));
        TRY(add_material(ld, &mat, &idx));
    }
    ld->materials = ms;
    return RAYD_OK;
}

/* The "material" key of an object: absent (default), a name, or inline. */
static enum rayd_status object_material(struct loader *ld, const cJSON *obj, const struct jp *at,
                                        int *index) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, "material");
    *index = 0;
    if (!v) return RAYD_OK;
    struct jp p = jp_key(at, "material");
    if (cJSON_IsObject(v)) {
        struct material mat;
        TRY(parse_material(ld, v, &p, &mat));
        return add_material(ld, &mat, index);
    }
    if (!cJSON_IsString(v))
        return fail(ld, RAYD_E_INVALID, &p,
                    "must be a material name or a material object, not %s", type_name(v));
    int i = 1;
    for (const cJSON *m = ld->materials ? ld->materials->child : NULL; m; m = m->next, i++) {
        if (strcmp(m->string, v->valuestring) == 0) {
            *index = i;
            return RAYD_OK;
        }
    }
    return fail(ld, RAYD_E_INVALID, &p, "unknown material \"%.80s\" (not a key of /materials)",
                v->valuestring);
}

/* ---- lights ----------------------------------------------------------------- */

/* A string key that must be one of the names in types: *out its index. */
static enum rayd_status get_type_key(struct loader *ld, const cJSON *obj, const struct jp *at,
                                     const char *key, const char *const *types, int *out) {
    const cJSON *t = cJSON_GetObjectItemCaseSensitive(obj, key);
    struct jp p = jp_key(at, key);
    if (!t) return fail(ld, RAYD_E_INVALID, &p, "is required");
    if (!cJSON_IsString(t))
        return fail(ld, RAYD_E_INVALID, &p, "must be a string, not %s", type_name(t));
    char list[160] = "";
    for (int i = 0; types[i]; i++) {
        if (strcmp(types[i], t->valuestring) == 0) {
            *out = i;
            return RAYD_OK;
        }
        strncat(list, types[i], sizeof list - strlen(list) - 1);
        if (types[i + 1]) strncat(list, ", ", sizeof list - strlen(list) - 1);
    }
    return fail(ld, RAYD_E_INVALID, &p, "unknown %s \"%.60s\" (supported: %s)",
                strcmp(key, "type") == 0 ? "type" : "value", t->valuestring, list);
}

static enum rayd_status get_type(struct loader *ld, const cJSON *obj, const struct jp *at,
                                 const char *const *types, int *out) {
    return get_type_key(ld, obj, at, "type", types, out);
}

static enum rayd_status load_light(struct loader *ld, const cJSON *lj, const struct jp *at,
                                   struct light *l) {
    static const char *const types[] = {"point", "directional", "spot", NULL};
    static const char *const point_keys[] = {"type", "position", "color", "intensity", NULL};
    static const char *const dir_keys[] = {"type", "direction", "color", "intensity", NULL};
    static const char *const spot_keys[] = {"type",      "position", "direction", "color",
                                            "intensity", "angle",    "falloff",   NULL};
    static const char *const *const keys[] = {point_keys, dir_keys, spot_keys};
    if (!cJSON_IsObject(lj))
        return fail(ld, RAYD_E_INVALID, at, "must be an object, not %s", type_name(lj));
    int kind;
    TRY(get_type(ld, lj, at, types, &kind));
    TRY(check_keys(ld, lj, at, keys[kind]));
    l->kind = (enum light_kind)kind;
    TRY(get_vec(ld, lj, at, "color", v3(1, 1, 1), VEC_COLOR, &l->color));
    TRY(get_num(ld, lj, at, "intensity", 1, 0, false, 1e6, &l->intensity));
    TRY(get_vec(ld, lj, at, "position", v3(0, 10, 0), VEC_ANY, &l->position));
    vec3 dir;
    TRY(get_vec(ld, lj, at, "direction", v3(0, -1, 0), VEC_NONZERO, &dir));
    l->direction = v3_norm(dir);
    double angle, falloff;
    TRY(get_num(ld, lj, at, "angle", 30, 0, true, 90, &angle));
    TRY(get_num(ld, lj, at, "falloff", 5, 0, false, angle, &falloff));
    l->cos_outer = cos(angle * DEG2RAD);
    l->cos_inner = cos((angle - falloff) * DEG2RAD);
    if (l->cos_inner <= l->cos_outer) l->cos_inner = nextafter(l->cos_outer, 2.0);
    return RAYD_OK;
}

static enum rayd_status load_lights(struct loader *ld, const cJSON *root) {
    const cJSON *ls = cJSON_GetObjectItemCaseSensitive(root, "lights");
    if (!ls) return RAYD_OK;
    struct jp at = {"/lights"};
    if (!cJSON_IsArray(ls)) return fail(ld, RAYD_E_INVALID, &at, "must be an array, not %s", type_name(ls));
    int n = cJSON_GetArraySize(ls);
    if (n > ld->lim->max_lights)
        return fail(ld, RAYD_E_LIMIT, &at, "has %d lights; the limit is %d", n, ld->lim->max_lights);
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

/* ---- objects ----------------------------------------------------------------- */

/* ---- transforms --------------------------------------------------------------- */

static enum rayd_status transform_step(struct loader *ld, const cJSON *t, const struct jp *at,
                                       struct xform *out) {
    static const char *const keys[] = {"translate", "rotate", "scale", "matrix", NULL};
    TRY(check_keys(ld, t, at, keys));
    struct xform x = xform_identity();
    const cJSON *mj = cJSON_GetObjectItemCaseSensitive(t, "matrix");
    if (mj) {
        struct jp p = jp_key(at, "matrix");
        if (cJSON_GetArraySize(t) > 1)
            return fail(ld, RAYD_E_INVALID, &p, "cannot be combined with translate, rotate or scale");
        double rows[16];
        if (!cJSON_IsArray(mj) || cJSON_GetArraySize(mj) != 16)
            return fail(ld, RAYD_E_INVALID, &p, "must be an array of 16 numbers (a 4x4 matrix, row by row)");
        int i = 0;
        for (const cJSON *e = mj->child; e; e = e->next, i++) {
            struct jp pe = jp_index(&p, i);
            if (!cJSON_IsNumber(e) || !isfinite(e->valuedouble))
                return fail(ld, RAYD_E_INVALID, &pe, "must be a finite number");
            rows[i] = e->valuedouble;
        }
        if (!xform_from_matrix(rows, out))
            return fail(ld, RAYD_E_INVALID, &p, "must be invertible with last row [0, 0, 0, 1]");
        return RAYD_OK;
    }
    const cJSON *sc = cJSON_GetObjectItemCaseSensitive(t, "scale");
    if (sc) {
        vec3 v;
        struct jp p = jp_key(at, "scale");
        if (cJSON_IsNumber(sc)) {
            double k;
            TRY(get_num(ld, t, at, "scale", 1, -NUM_MAX, false, NUM_MAX, &k));
            v = v3(k, k, k);
        } else {
            TRY(get_vec(ld, t, at, "scale", v3(1, 1, 1), VEC_ANY, &v));
        }
        if (fabs(v.x) < 1e-9 || fabs(v.y) < 1e-9 || fabs(v.z) < 1e-9)
            return fail(ld, RAYD_E_INVALID, &p, "must not be zero (or smaller than 1e-9) in any axis");
        struct xform k = xform_scale(v);
        x = xform_then(&x, &k);
    }
    const cJSON *ro = cJSON_GetObjectItemCaseSensitive(t, "rotate");
    if (ro) {
        struct jp p = jp_key(at, "rotate");
        struct xform k;
        if (cJSON_IsObject(ro)) {
            static const char *const rkeys[] = {"axis", "angle", NULL};
            TRY(check_keys(ld, ro, &p, rkeys));
            vec3 axis;
            double angle;
            TRY(get_vec(ld, ro, &p, "axis", v3(0, 1, 0), VEC_NONZERO, &axis));
            TRY(get_num(ld, ro, &p, "angle", 0, -1e6, false, 1e6, &angle));
            k = xform_rotate_axis(axis, angle);
        } else {
            vec3 e;
            TRY(get_vec(ld, t, at, "rotate", v3(0, 0, 0), VEC_ANY, &e));
            k = xform_rotate_euler(e);
        }
        x = xform_then(&x, &k);
    }
    vec3 tr;
    TRY(get_vec(ld, t, at, "translate", v3(0, 0, 0), VEC_ANY, &tr));
    struct xform k = xform_translate(tr);
    *out = xform_then(&x, &k);
    return RAYD_OK;
}

/* "transform": one step {scale, rotate, translate} applied in that order,
 * or an array of steps applied first to last. */
static enum rayd_status load_transform(struct loader *ld, const cJSON *obj, const struct jp *at,
                                       int32_t *index) {
    *index = -1;
    const cJSON *t = cJSON_GetObjectItemCaseSensitive(obj, "transform");
    if (!t) return RAYD_OK;
    struct jp p = jp_key(at, "transform");
    struct xform x = xform_identity();
    if (cJSON_IsArray(t)) {
        int i = 0;
        for (const cJSON *e = t->child; e; e = e->next, i++) {
            struct jp pe = jp_index(&p, i);
            struct xform step;
            TRY(transform_step(ld, e, &pe, &step));
            x = xform_then(&x, &step);
        }
    } else {
        TRY(transform_step(ld, t, &p, &x));
    }
    rayd_scene *s = ld->s;
    if (s->nxforms == ld->xform_cap) {
        int32_t cap = ld->xform_cap ? ld->xform_cap * 2 : 16;
        struct xform *n = realloc(s->xforms, sizeof *n * (size_t)cap);
        if (!n) return err_set(ld->err, RAYD_E_NOMEM, NULL, "out of memory");
        s->xforms = n;
        ld->xform_cap = cap;
    }
    s->xforms[s->nxforms] = x;
    *index = s->nxforms++;
    return RAYD_OK;
}

/* ---- meshes ------------------------------------------------------------------- */

/* A flat array of numbers, count a multiple of per (and at least min). */
static enum rayd_status get_flat(struct loader *ld, const cJSON *obj, const struct jp *at,
                                 const char *key, int per, long min, float **out, long *count) {
    const cJSON *a = cJSON_GetObjectItemCaseSensitive(obj, key);
    *out = NULL;
    *count = 0;
    if (!a) return RAYD_OK;
    struct jp p = jp_key(at, key);
    if (!cJSON_IsArray(a)) return fail(ld, RAYD_E_INVALID, &p, "must be an array of numbers, not %s", type_name(a));
    long n = 0;
    for (const cJSON *e = a->child; e; e = e->next) n++;
    if (n % per != 0 || n < min)
        return fail(ld, RAYD_E_INVALID, &p, "must hold a multiple of %d numbers (at least %ld); it has %ld", per, min, n);
    if (n / per > ld->lim->max_vertices)
        return fail(ld, RAYD_E_LIMIT, &p, "has %ld vertices; the limit is %ld", n / per, ld->lim->max_vertices);
    float *v = malloc(sizeof *v * (size_t)(n ? n : 1));
    if (!v) return err_set(ld->err, RAYD_E_NOMEM, p.s, "out of memory");
    long i = 0;
    for (const cJSON *e = a->child; e; e = e->next, i++) {
        if (!cJSON_IsNumber(e) || !isfinite(e->valuedouble) || fabs(e->valuedouble) > 1e30) {
            free(v);
            struct jp pe = jp_index(&p, (int)i);
            return fail(ld, RAYD_E_INVALID, &pe, "must be a finite number");
        }
        v[i] = (float)e->valuedouble;
    }
    *out = v;
    *count = n / per;
    return RAYD_OK;
}

static enum rayd_status get_indices(struct loader *ld, const cJSON *obj, const struct jp *at,
                                    long nverts, uint32_t **out, long *ntris) {
    const cJSON *a = cJSON_GetObjectItemCaseSensitive(obj, "indices");
    struct jp p = jp_key(at, "indices");
    if (!a) return fail(ld, RAYD_E_INVALID, &p, "is required (3 vertex indices per triangle)");
    if (!cJSON_IsArray(a)) return fail(ld, RAYD_E_INVALID, &p, "must be an array of integers, not %s", type_name(a));
    long n = 0;
    for (const cJSON *e = a->child; e; e = e->next) n++;
    if (n % 3 != 0 || n == 0)
        return fail(ld, RAYD_E_INVALID, &p, "must hold a multiple of 3 indices (at least 3); it has %ld", n);
    if (ld->triangles + n / 3 > ld->lim->max_triangles)
        return fail(ld, RAYD_E_LIMIT, &p, "brings the scene to %ld triangles; the limit is %ld", ld->triangles + n / 3, ld->lim->max_triangles);
    uint32_t *ix = malloc(sizeof *ix * (size_t)n);
    if (!ix) return err_set(ld->err, RAYD_E_NOMEM, p.s, "out of memory");
    long i = 0;
    for (const cJSON *e = a->child; e; e = e->next, i++) {
        double v = cJSON_IsNumber(e) ? e->valuedouble : -1;
        if (!(v >= 0 && v < (double)nverts && floor(v) == v)) {
            free(ix);
            struct jp pe = jp_index(&p, (int)i);
            return fail(ld, RAYD_E_INVALID, &pe, "must be an integer in 0..%ld (a vertex index)", nverts - 1);
        }
        ix[i] = (uint32_t)v;
    }
    *out = ix;
    *ntris = n / 3;
    return RAYD_OK;
}

static enum rayd_status add_mesh(struct loader *ld, uint32_t *id) {
    rayd_scene *s = ld->s;
    if (s->nmeshes == ld->mesh_cap) {
        uint32_t cap = ld->mesh_cap ? ld->mesh_cap * 2 : 8;
        struct mesh *n = realloc(s->meshes, sizeof *n * cap);
        if (!n) return err_set(ld->err, RAYD_E_NOMEM, NULL, "out of memory");
        s->meshes = n;
        ld->mesh_cap = cap;
    }
    memset(&s->meshes[s->nmeshes], 0, sizeof s->meshes[0]);
    *id = s->nmeshes++;
    return RAYD_OK;
}

/* Reads a file named by a scene, under the limits' asset rules. */
static enum rayd_status read_asset(struct loader *ld, const cJSON *f, const struct jp *at,
                                   char **out, size_t *len) {
    const struct rayd_limits *lim = ld->lim;
    if (!cJSON_IsString(f)) return fail(ld, RAYD_E_INVALID, at, "must be a string, not %s", type_name(f));
    const char *name = f->valuestring;
    if (!lim->asset_dir)
        return fail(ld, RAYD_E_INVALID, at, "files are not allowed here (embed the data as \"text\" or \"base64\"; rayd reads files only with --asset-dir)");
    if (lim->asset_confine && (name[0] == '/' || strstr(name, "..") || name[0] == '\0'))
        return fail(ld, RAYD_E_INVALID, at, "must be a relative path inside the asset directory, without '..'");
    char path[4096];
    if (name[0] == '/')
        snprintf(path, sizeof path, "%s", name);
    else if ((size_t)snprintf(path, sizeof path, "%s/%s", lim->asset_dir, name) >= sizeof path)
        return fail(ld, RAYD_E_INVALID, at, "path is too long");
    FILE *fp = fopen(path, "rb");
    if (!fp) return fail(ld, RAYD_E_INVALID, at, "cannot open \"%.200s\": %s", name, strerror(errno));
    size_t cap = 1 << 16, n = 0;
    char *buf = malloc(cap);
    while (buf) {
        n += fread(buf + n, 1, cap - n, fp);
        if (n < cap) break;
        if (cap > lim->max_bytes) {
            free(buf);
            fclose(fp);
            return fail(ld, RAYD_E_LIMIT, at, "file is over the limit of %zu bytes", lim->max_bytes);
        }
        char *nb = realloc(buf, cap * 2);
        if (!nb) free(buf);
        buf = nb;
        cap *= 2;
    }
    bool bad = ferror(fp);
    fclose(fp);
    if (!buf) return err_set(ld->err, RAYD_E_NOMEM, at->s, "out of memory reading a file");
    if (bad) {
        free(buf);
        return fail(ld, RAYD_E_INVALID, at, "cannot read \"%.200s\"", name);
    }
    *out = buf;
    *len = n;
    return RAYD_OK;
}

/* "source": {"format": "obj"|"ply", and one of "text", "base64", "file"}. */
static enum rayd_status load_source(struct loader *ld, const cJSON *src, const struct jp *at,
                                    struct mesh_data *md) {
    static const char *const keys[] = {"format", "text", "base64", "file", NULL};
    static const char *const formats[] = {"obj", "ply", NULL};
    TRY(check_keys(ld, src, at, keys));
    const cJSON *text = cJSON_GetObjectItemCaseSensitive(src, "text");
    const cJSON *b64 = cJSON_GetObjectItemCaseSensitive(src, "base64");
    const cJSON *file = cJSON_GetObjectItemCaseSensitive(src, "file");
    if (!!text + !!b64 + !!file != 1)
        return fail(ld, RAYD_E_INVALID, at, "needs exactly one of \"text\", \"base64\" or \"file\"");
    const cJSON *fmt = cJSON_GetObjectItemCaseSensitive(src, "format");
    int format = -1;
    if (fmt) {
        TRY(get_type_key(ld, src, at, "format", formats, &format));
    } else if (file && cJSON_IsString(file)) {
        size_t n = strlen(file->valuestring);
        if (n > 4 && !strcasecmp(file->valuestring + n - 4, ".obj")) format = 0;
        if (n > 4 && !strcasecmp(file->valuestring + n - 4, ".ply")) format = 1;
    }
    struct jp pf = jp_key(at, "format");
    if (format < 0) return fail(ld, RAYD_E_INVALID, &pf, "is required (\"obj\" or \"ply\")");
    const cJSON *v = text ? text : b64 ? b64 : file;
    struct jp pv = jp_key(at, text ? "text" : b64 ? "base64" : "file");
    char *data = NULL;
    size_t len = 0;
    if (file) {
        TRY(read_asset(ld, file, &pv, &data, &len));
    } else if (!cJSON_IsString(v)) {
        return fail(ld, RAYD_E_INVALID, &pv, "must be a string, not %s", type_name(v));
    } else if (b64) {
        unsigned char *bytes;
        enum rayd_status st = base64_decode(v->valuestring, strlen(v->valuestring), &bytes, &len, ld->err);
        if (st != RAYD_OK) {
            snprintf(ld->err->path, sizeof ld->err->path, "%s", pv.s);
            return st;
        }
        data = (char *)bytes;
    }
    struct mesh_limits ml = {
        (uint32_t)(ld->lim->max_vertices - ld->vertices > UINT32_MAX ? UINT32_MAX : ld->lim->max_vertices - ld->vertices),
        (uint32_t)(ld->lim->max_triangles - ld->triangles > UINT32_MAX ? UINT32_MAX : ld->lim->max_triangles - ld->triangles)};
    const char *bytes = data ? data : v->valuestring;
    size_t nbytes = data ? len : strlen(v->valuestring);
    enum rayd_status st = format == 0 ? mesh_parse_obj(bytes, nbytes, &ml, md, ld->err)
                                      : mesh_parse_ply(bytes, nbytes, &ml, md, ld->err);
    free(data);
    if (st != RAYD_OK && ld->err) snprintf(ld->err->path, sizeof ld->err->path, "%s", pv.s);
    if (st == RAYD_OK && md->ntris == 0) {
        mesh_data_free(md);
        return fail(ld, RAYD_E_INVALID, &pv, "holds no triangles");
    }
    return st;
}

static int cpu_count(void) {
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n > 0 ? (int)n : 1;
}

static enum rayd_status load_mesh(struct loader *ld, const cJSON *oj, const struct jp *at,
                                  uint32_t *id) {
    float *pos = NULL, *nrm = NULL, *uv = NULL;
    uint32_t *ix = NULL;
    long nv = 0, nn = 0, nuv = 0, nt = 0;
    bool smooth = true;
    const cJSON *sm = cJSON_GetObjectItemCaseSensitive(oj, "smooth");
    struct jp p;
    enum rayd_status st = RAYD_OK;
    if (sm && !cJSON_IsBool(sm)) {
        p = jp_key(at, "smooth");
        return fail(ld, RAYD_E_INVALID, &p, "must be true or false, not %s", type_name(sm));
    }
    if (sm) smooth = cJSON_IsTrue(sm);
    const cJSON *src = cJSON_GetObjectItemCaseSensitive(oj, "source");
    if (src) {
        static const char *const inline_keys[] = {"vertices", "indices", "normals", "uvs"};
        for (int k = 0; k < 4; k++) {
            if (!cJSON_GetObjectItemCaseSensitive(oj, inline_keys[k])) continue;
            p = jp_key(at, inline_keys[k]);
            return fail(ld, RAYD_E_INVALID, &p, "cannot be combined with \"source\"");
        }
        struct mesh_data md = {0};
        p = jp_key(at, "source");
        TRY(load_source(ld, src, &p, &md));
        pos = md.pos;
        nrm = md.normal;
        uv = md.uv;
        ix = md.index;
        nv = md.nverts;
        nt = md.ntris;
        goto build;
    }
    if ((st = get_flat(ld, oj, at, "vertices", 3, 3, &pos, &nv)) != RAYD_OK) goto out;
    if (!pos) {
        p = jp_key(at, "vertices");
        st = fail(ld, RAYD_E_INVALID, &p, "is required (x, y, z of each vertex, flat)");
        goto out;
    }
    if (ld->vertices + nv > ld->lim->max_vertices) {
        p = jp_key(at, "vertices");
        st = fail(ld, RAYD_E_LIMIT, &p, "brings the scene to %ld vertices; the limit is %ld", ld->vertices + nv, ld->lim->max_vertices);
        goto out;
    }
    if ((st = get_indices(ld, oj, at, nv, &ix, &nt)) != RAYD_OK) goto out;
    if ((st = get_flat(ld, oj, at, "normals", 3, 0, &nrm, &nn)) != RAYD_OK) goto out;
    if ((st = get_flat(ld, oj, at, "uvs", 2, 0, &uv, &nuv)) != RAYD_OK) goto out;
    if ((nrm && nn != nv) || (uv && nuv != nv)) {
        p = jp_key(at, nrm && nn != nv ? "normals" : "uvs");
        st = fail(ld, RAYD_E_INVALID, &p, "must have one entry per vertex (%ld)", nv);
        goto out;
    }
    for (long i = 0; nrm && i < nn; i++) {
        float *n = nrm + 3 * i;
        double len = sqrt((double)n[0] * n[0] + (double)n[1] * n[1] + (double)n[2] * n[2]);
        if (!(len > 0)) {
            p = jp_key(at, "normals");
            struct jp pe = jp_index(&p, (int)(3 * i));
            st = fail(ld, RAYD_E_INVALID, &pe, "normal %ld must not be a zero-length vector", i);
            goto out;
        }
        for (int k = 0; k < 3; k++) n[k] = (float)(n[k] / len);
    }
build:
    if ((st = add_mesh(ld, id)) != RAYD_OK) goto out;
    ld->vertices += nv;
    ld->triangles += nt;
    st = mesh_build(&ld->s->meshes[*id], pos, (uint32_t)nv, ix, (uint32_t)nt, nrm, uv, smooth,
                    nt >= 50000 ? cpu_count() : 1, ld->err);
    return st; /* the mesh owns the arrays now, even on failure */
out:
    free(pos);
    free(nrm);
    free(uv);
    free(ix);
    return st;
}

/* ---- objects ---------------------------------------------------------------- */

static enum rayd_status load_object(struct loader *ld, const cJSON *oj, const struct jp *at,
                                    struct object *o) {
    static const char *const types[] = {"sphere", "plane", "mesh", NULL};
    static const char *const sphere_keys[] = {"type", "name", "material", "transform",
                                              "center", "radius", NULL};
    static const char *const plane_keys[] = {"type", "name", "material", "transform",
                                             "point", "normal", NULL};
    static const char *const mesh_keys[] = {"type",    "name",    "material", "transform",
                                            "source",  "vertices", "indices", "normals",
                                            "uvs",     "smooth",   NULL};
    static const char *const *const keys[] = {sphere_keys, plane_keys, mesh_keys};
    if (!cJSON_IsObject(oj))
        return fail(ld, RAYD_E_INVALID, at, "must be an object, not %s", type_name(oj));
    int kind;
    TRY(get_type(ld, oj, at, types, &kind));
    TRY(check_keys(ld, oj, at, keys[kind]));
    const cJSON *name = cJSON_GetObjectItemCaseSensitive(oj, "name");
    if (name && !cJSON_IsString(name)) {
        struct jp p = jp_key(at, "name");
        return fail(ld, RAYD_E_INVALID, &p, "must be a string, not %s", type_name(name));
    }
    memset(o, 0, sizeof *o);
    TRY(object_material(ld, oj, at, &o->material));
    TRY(load_transform(ld, oj, at, &o->xform));
    if (kind == 0) {
        o->kind = SHAPE_SPHERE;
        TRY(get_vec(ld, oj, at, "center", v3(0, 0, 0), VEC_ANY, &o->u.sphere.center));
        TRY(get_num(ld, oj, at, "radius", 1, 0, true, NUM_MAX, &o->u.sphere.radius));
    } else if (kind == 1) {
        o->kind = SHAPE_PLANE;
        vec3 n;
        TRY(get_vec(ld, oj, at, "point", v3(0, 0, 0), VEC_ANY, &o->u.plane.point));
        TRY(get_vec(ld, oj, at, "normal", v3(0, 1, 0), VEC_NONZERO, &n));
        o->u.plane.normal = v3_norm(n);
    } else {
        o->kind = SHAPE_MESH;
        TRY(load_mesh(ld, oj, at, &o->u.mesh.id));
    }
    return RAYD_OK;
}

static enum rayd_status load_objects(struct loader *ld, const cJSON *root) {
    const cJSON *os = cJSON_GetObjectItemCaseSensitive(root, "objects");
    if (!os) return RAYD_OK;
    struct jp at = {"/objects"};
    if (!cJSON_IsArray(os)) return fail(ld, RAYD_E_INVALID, &at, "must be an array, not %s", type_name(os));
    int n = cJSON_GetArraySize(os);
    if (n > ld->lim->max_objects)
        return fail(ld, RAYD_E_LIMIT, &at, "has %d objects; the limit is %ld", n, ld->lim->max_objects);
    if (n == 0) return RAYD_OK;
    ld->s->objs = calloc((size_t)n, sizeof *ld->s->objs);
    if (!ld->s->objs) return err_set(ld->err, RAYD_E_NOMEM, NULL, "out of memory");
    int i = 0;
    for (const cJSON *o = os->child; o; o = o->next, i++) {
        struct jp p = jp_index(&at, i);
        TRY(load_object(ld, o, &p, &ld->s->objs[i]));
        ld->s->nobjs = i + 1;
    }
    return RAYD_OK;
}

/* ---- text checks and parse ----------------------------------------------------- */

/* cJSON writes a global error slot on every parse, so parses are serialised;
 * the text has passed json_check, so a failure here is out of memory. */
static pthread_mutex_t cjson_lock = PTHREAD_MUTEX_INITIALIZER;

static enum rayd_status parse_json(const char *json, size_t len, cJSON **out,
                                   struct rayd_error *err) {
    pthread_mutex_lock(&cjson_lock);
    cJSON *root = cJSON_ParseWithLength(json, len);
    pthread_mutex_unlock(&cjson_lock);
    if (!root) return err_set(err, RAYD_E_NOMEM, NULL, "out of memory parsing the scene");
    *out = root;
    return RAYD_OK;
}

static enum rayd_status load_root(struct loader *ld, const cJSON *root) {
    static const char *const keys[] = {"version", "camera", "render", "materials",
                                       "lights",  "objects", NULL};
    struct jp at = {""};
    if (!cJSON_IsObject(root))
        return err_set(ld->err, RAYD_E_INVALID, "", "the scene must be a JSON object, not %s",
                       type_name(root));
    TRY(check_keys(ld, root, &at, keys));
    long version;
    TRY(get_int(ld, root, &at, "version", 1, 1, 1, false, &version));
    TRY(load_render(ld, root));
    TRY(load_camera(ld, root));
    TRY(load_materials(ld, root));
    TRY(load_lights(ld, root));
    return load_objects(ld, root);
}

enum rayd_status rayd_scene_parse(const char *json, size_t len, const struct rayd_limits *lim,
                                  rayd_scene **out, struct rayd_error *err) {
    struct rayd_limits deflim;
    if (!lim) {
        rayd_limits_default(&deflim);
        lim = &deflim;
    }
    if (len > lim->max_bytes)
        return err_set(err, RAYD_E_LIMIT, NULL, "the scene is %zu bytes; the limit is %zu", len,
                       lim->max_bytes);
    TRY(json_check(json, len, lim->max_nesting, err));
    cJSON *root = NULL;
    TRY(parse_json(json, len, &root, err));
    rayd_scene *s;
    enum rayd_status st = scene_alloc(&s, err);
    if (st == RAYD_OK) {
        struct loader ld = {.lim = lim, .s = s, .err = err};
        st = load_root(&ld, root);
        if (st == RAYD_OK) st = scene_freeze(s, err);
        if (st != RAYD_OK) rayd_scene_free(s);
    }
    cJSON_Delete(root);
    if (st == RAYD_OK) *out = s;
    return st;
}
