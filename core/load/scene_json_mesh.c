/* scene_json_mesh.c -- mesh objects: flat inline arrays ("vertices",
 * "indices", "normals", "uvs") or a "source" in OBJ, PLY or glTF, given as text,
 * base64 or a file.  Files are read only when the limits name an asset
 * folder (rayd-render: the scene's folder; rayd: --asset-dir, confined).
 * Totals of vertices and triangles are checked against the limits before
 * anything large is allocated.  Large inline arrays come not as cJSON items
 * but as spans of the text (scene_json_inline.c), read by json_numbers.c
 * with the same checks, values and messages.  Built meshes are shared
 * between live scenes (geom/mesh_share.c) under their source's bytes, their
 * inline arrays' text, or, for a gltf object's meshes (sj_mesh_baked), the
 * arrays its bake made.
 */
#define _XOPEN_SOURCE 700 /* realpath */
#include <errno.h>
#include <sys/stat.h>
#include <strings.h>
#include <unistd.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "load/scene_json_mesh.h"

#include "format/base64.h"
#include "format/json_numbers.h"
#include "load/scene_json_anim.h"
#include "load/scene_json_inline.h"
#include "base/clock.h"
#include "format/mesh_gltf.h"
#include "format/mesh_io.h"
#include "base/parallel.h"
#include "geom/mesh_share.h"

/* ---- meshes ------------------------------------------------------------------- */

/* The numbers in array a: its items, or those of its span in the text. */
static long count_items(const cJSON *a, const struct json_span *sp) {
    long n = 0;
    if (sp) return sp->count;
    for (const cJSON *e = a->child; e; e = e->next) n++;
    return n;
}

/* The numbers of an array left out of the tree, read from the text into v:
 * the same checks and messages as the loop over cJSON's items in get_flat. */
static enum rayd_status flat_text(struct loader *ld, const struct json_span *sp, const struct jp *p,
                                  float *v) {
    double bad = 0;
    long i = json_floats(ld->inl->text, sp, 1e30, 0, v, &bad);
    if (i == -1) return RAYD_OK;
    if (i == JSON_NUMBERS_NOMEM) return err_set(ld->err, RAYD_E_NOMEM, p->s, "out of memory");
    struct jp pe = jp_index(p, (int)i);
    if (!isfinite(bad)) return sj_fail(ld, RAYD_E_INVALID, &pe, "must be a finite number");
    return sj_fail(ld, RAYD_E_INVALID, &pe, "must be in [-1e30, 1e30]");
}

/* A flat array of numbers, count a multiple of per (and at least min). */
static enum rayd_status get_flat(struct loader *ld, const cJSON *obj, const struct jp *at,
                                 const char *key, int per, long min, float **out, long *count) {
    const cJSON *a = cJSON_GetObjectItemCaseSensitive(obj, key);
    *out = NULL;
    *count = 0;
    if (!a) return RAYD_OK;
    struct jp p = jp_key(at, key);
    if (!cJSON_IsArray(a))
        return sj_fail(ld, RAYD_E_INVALID, &p, "must be an array of numbers, not %s",
                       sj_type_name(a));
    const struct json_span *sp = sj_inline_span(ld->inl, a);
    long n = count_items(a, sp);
    if (n % per != 0 || n < min)
        return sj_fail(ld, RAYD_E_INVALID, &p,
                       "must hold a multiple of %d numbers (at least %ld); it has %ld", per, min,
                       n);
    if (n / per > ld->lim->max_vertices)
        return sj_fail(ld, RAYD_E_LIMIT, &p, "has %ld vertices; the limit is %ld", n / per,
                       ld->lim->max_vertices);
    float *v = malloc(sizeof *v * (size_t)(n ? n : 1));
    if (!v) return err_set(ld->err, RAYD_E_NOMEM, p.s, "out of memory");
    if (sp) {
        enum rayd_status st = flat_text(ld, sp, &p, v);
        if (st != RAYD_OK) {
            free(v);
            return st;
        }
        *out = v;
        *count = n / per;
        return RAYD_OK;
    }
    long i = 0;
    for (const cJSON *e = a->child; e; e = e->next, i++) {
        double x;
        enum rayd_status st = sj_item_num(ld, e, &p, (int)i, 1e30, "[-1e30, 1e30]", &x);
        if (st != RAYD_OK) {
            free(v);
            return st;
        }
        v[i] = (float)x;
    }
    *out = v;
    *count = n / per;
    return RAYD_OK;
}

static enum rayd_status get_indices(struct loader *ld, const cJSON *obj, const struct jp *at,
                                    long nverts, uint32_t **out, long *ntris) {
    const cJSON *a = cJSON_GetObjectItemCaseSensitive(obj, "indices");
    struct jp p = jp_key(at, "indices");
    if (!a) return sj_fail(ld, RAYD_E_INVALID, &p, "is required (3 vertex indices per triangle)");
    if (!cJSON_IsArray(a))
        return sj_fail(ld, RAYD_E_INVALID, &p, "must be an array of integers, not %s",
                       sj_type_name(a));
    const struct json_span *sp = sj_inline_span(ld->inl, a);
    long n = count_items(a, sp);
    if (n % 3 != 0 || n == 0)
        return sj_fail(ld, RAYD_E_INVALID, &p,
                       "must hold a multiple of 3 indices (at least 3); it has %ld", n);
    if (ld->triangles + n / 3 > ld->lim->max_triangles)
        return sj_fail(ld, RAYD_E_LIMIT, &p, "brings the scene to %ld triangles; the limit is %ld",
                       ld->triangles + n / 3, ld->lim->max_triangles);
    uint32_t *ix = malloc(sizeof *ix * (size_t)n);
    if (!ix) return err_set(ld->err, RAYD_E_NOMEM, p.s, "out of memory");
    long i = sp ? json_indices(ld->inl->text, sp, nverts, 0, ix) : -1;
    if (i != -1) {
        free(ix);
        if (i == JSON_NUMBERS_NOMEM) return err_set(ld->err, RAYD_E_NOMEM, p.s, "out of memory");
        struct jp pe = jp_index(&p, (int)i);
        return sj_fail(ld, RAYD_E_INVALID, &pe, "must be an integer in 0..%ld (a vertex index)",
                       nverts - 1);
    }
    i = 0;
    for (const cJSON *e = sp ? NULL : a->child; e; e = e->next, i++) {
        double v = cJSON_IsNumber(e) ? e->valuedouble : -1;
        if (!(v >= 0 && v < (double)nverts && floor(v) == v)) {
            free(ix);
            struct jp pe = jp_index(&p, (int)i);
            return sj_fail(ld, RAYD_E_INVALID, &pe, "must be an integer in 0..%ld (a vertex index)",
                           nverts - 1);
        }
        ix[i] = (uint32_t)v;
    }
    *out = ix;
    *ntris = n / 3;
    return RAYD_OK;
}

/* A mesh's arrays, then about what its build holds at once: the 4-wide
 * leaf blocks (40 bytes a triangle when full), the BVH nodes and the
 * builder's own arrays.  An estimate charged before the build; the built
 * scene's measured bytes (rayd_scene_info) replace it. */
#define SJ_BUILD_BYTES_PER_TRIANGLE 96

size_t sj_mesh_bytes(const struct mesh_data *md) {
    size_t per_vertex =
        3 * sizeof(float) + (md->normal ? 3 * sizeof(float) : 0) + (md->uv ? 2 * sizeof(float) : 0);
    return (size_t)md->nverts * per_vertex +
           (size_t)md->ntris * (3 * sizeof(uint32_t) + SJ_BUILD_BYTES_PER_TRIANGLE);
}

/* Appends an empty mesh to the scene's: *id. */
static enum rayd_status add_mesh(struct loader *ld, uint32_t *id) {
    rayd_scene *s = ld->s;
    if (!array_grow((void **)&s->meshes, &ld->mesh_cap, (size_t)s->nmeshes + 1, sizeof *s->meshes))
        return err_set(ld->err, RAYD_E_NOMEM, NULL, "out of memory");
    memset(&s->meshes[s->nmeshes], 0, sizeof s->meshes[0]);
    *id = s->nmeshes++;
    return RAYD_OK;
}

/* ---- glTF ------------------------------------------------------------------------ */

static enum rayd_status gltf_open(void *ctx, const char *name, char **data, size_t *len,
                                  struct rayd_error *err) {
    struct gltf_files *f = ctx;
    char path[2048];
    (void)err; /* sj_read_asset fills the loader's error, the same one */
    if ((size_t)snprintf(path, sizeof path, "%s%s", f->dir, name) >= sizeof path)
        return sj_fail(f->ld, RAYD_E_INVALID, &(struct jp){.s = ""}, "path is too long");
    cJSON v = {0};
    v.type = cJSON_String;
    v.valuestring = path;
    struct jp at = {.s = ""};
    return sj_read_asset(f->ld, &v, &at, data, len);
}

enum rayd_status sj_gltf_opts(struct loader *ld, const struct jp *at, const cJSON *file,
                              struct gltf_files *f, struct mesh_gltf_opts *o) {
    f->ld = ld;
    f->dir[0] = '\0';
    if (file) {
        const char *name = file->valuestring, *slash = strrchr(name, '/');
        size_t dn = slash ? (size_t)(slash - name) + 1 : 0;
        if (dn >= sizeof f->dir) return sj_fail(ld, RAYD_E_INVALID, at, "file name is too long");
        memcpy(f->dir, name, dn);
        f->dir[dn] = '\0';
    }
    *o = (struct mesh_gltf_opts){.max_bytes = ld->lim->max_bytes,
                                 .max_nesting = ld->lim->max_nesting,
                                 .open = ld->lim->asset_dir ? gltf_open : NULL,
                                 .ctx = f};
    return RAYD_OK;
}

enum rayd_status sj_gltf_error(struct loader *ld, const struct jp *at, enum rayd_status st) {
    if (st != RAYD_OK && ld->err) {
        char inner[sizeof ld->err->path];
        snprintf(inner, sizeof inner, "%s", ld->err->path);
        struct jp pg = jp_key(at, "gltf");
        size_t n1 = strlen(pg.s) < 120 ? strlen(pg.s) : 120; /* both fit the 256 bytes */
        snprintf(ld->err->path, sizeof ld->err->path, "%.*s%.*s", (int)n1, pg.s, 130, inner);
    }
    return st;
}

/* A glTF or GLB source; errors get the source's pointer, then "/gltf" and
 * the pointer inside the glTF document. */
static enum rayd_status load_gltf(struct loader *ld, const struct jp *at, const cJSON *file,
                                  const char *bytes, size_t n, const struct mesh_limits *ml,
                                  struct mesh_data *md) {
    struct gltf_files f;
    struct mesh_gltf_opts o;
    TRY(sj_gltf_opts(ld, at, file, &f, &o));
    return sj_gltf_error(ld, at, mesh_parse_gltf(bytes, n, ml, &o, md, ld->err));
}

enum rayd_status sj_source_read(struct loader *ld, const cJSON *src, const struct jp *at,
                                int *fmt_out, char **owned, const char **out, size_t *nbytes) {
    static const char *const keys[] = {"format", "text", "base64", "file", NULL};
    static const char *const formats[] = {"obj", "ply", "gltf", "glb", NULL};
    TRY(sj_check_keys(ld, src, at, keys));
    const cJSON *text = cJSON_GetObjectItemCaseSensitive(src, "text");
    const cJSON *b64 = cJSON_GetObjectItemCaseSensitive(src, "base64");
    const cJSON *file = cJSON_GetObjectItemCaseSensitive(src, "file");
    if (!!text + !!b64 + !!file != 1)
        return sj_fail(ld, RAYD_E_INVALID, at,
                       "needs exactly one of \"text\", \"base64\" or \"file\"");
    const cJSON *fmt = cJSON_GetObjectItemCaseSensitive(src, "format");
    int format = -1;
    if (fmt) {
        TRY(sj_enum(ld, src, at, "format", formats, &format));
    } else if (file && cJSON_IsString(file)) {
        size_t n = strlen(file->valuestring);
        if (n > 4 && !strcasecmp(file->valuestring + n - 4, ".obj")) format = 0;
        if (n > 4 && !strcasecmp(file->valuestring + n - 4, ".ply")) format = 1;
        if (n > 5 && !strcasecmp(file->valuestring + n - 5, ".gltf")) format = 2;
        if (n > 4 && !strcasecmp(file->valuestring + n - 4, ".glb")) format = 3;
    }
    struct jp pf = jp_key(at, "format");
    if (format < 0 && file && cJSON_IsString(file)) /* the name's ending said nothing */
        return sj_fail(ld, RAYD_E_INVALID, &pf,
                       "is required (\"obj\", \"ply\", \"gltf\" or \"glb\"): \"%.120s\" "
                       "does not end in .obj, .ply, .gltf or .glb",
                       file->valuestring);
    if (format < 0)
        return sj_fail(ld, RAYD_E_INVALID, &pf,
                       "is required (\"obj\", \"ply\", \"gltf\" or \"glb\")");
    const cJSON *v = text ? text : b64 ? b64 : file;
    struct jp pv = jp_key(at, text ? "text" : b64 ? "base64" : "file");
    char *data = NULL;
    size_t len = 0;
    *fmt_out = format;
    if (file) {
        TRY(sj_read_asset(ld, file, &pv, &data, &len));
    } else if (!cJSON_IsString(v)) {
        return sj_fail(ld, RAYD_E_INVALID, &pv, "must be a string, not %s", sj_type_name(v));
    } else if (b64) {
        unsigned char *bytes;
        enum rayd_status st =
            base64_decode(v->valuestring, strlen(v->valuestring), &bytes, &len, ld->err);
        if (st != RAYD_OK) {
            snprintf(ld->err->path, sizeof ld->err->path, "%s", pv.s);
            return st;
        }
        data = (char *)bytes;
    }
    *owned = data;
    *out = data ? data : v->valuestring;
    *nbytes = data ? len : strlen(v->valuestring);
    return RAYD_OK;
}

/* "source": {"format": "obj"|"ply"|"gltf"|"glb", and one of "text", "base64", "file"}.
 * The decoders charge their arrays through the caller's hook as they
 * allocate them, so a refusal comes before the memory is used. */
struct mesh_limits sj_mesh_budget(const struct loader *ld) {
    long v = ld->lim->max_vertices - ld->vertices, t = ld->lim->max_triangles - ld->triangles;
    return (struct mesh_limits){.max_vertices = (uint32_t)(v > (long)UINT32_MAX ? UINT32_MAX
                                                           : v < 0              ? 0
                                                                                : v),
                                .max_triangles = (uint32_t)(t > (long)UINT32_MAX ? UINT32_MAX
                                                            : t < 0              ? 0
                                                                                 : t),
                                .charge = ld->lim->charge,
                                .charge_arg = ld->lim->charge_arg};
}

/* Frees a decoded mesh's arrays, giving back what its decoder charged. */
static void mesh_drop(struct loader *ld, struct mesh_data *md) {
    sj_give_back(ld, md->charged);
    mesh_data_free(md);
}

/* A mesh source's bytes as sj_source_read gives them, kept past the decode
 * while the mesh may be shared under them (source_shares). */
struct source {
    int format;        /* as sj_source_read numbers them: obj, ply, gltf, glb; or SOURCE_INLINE */
    char *owned;       /* malloc'd (a file's bytes or base64's), else NULL */
    const char *bytes; /* owned, or the scene's own text */
    size_t n;
    bool file; /* read from a file: n + 1 bytes charged while owned */
};

/* The format of an inline mesh's arrays' text (inline_source). */
#define SOURCE_INLINE 4

/* Frees the source's bytes, giving back a file's charge. */
static void source_done(struct loader *ld, struct source *sc) {
    if (sc->file && sc->owned) sj_give_back(ld, sc->n + 1);
    free(sc->owned);
    sc->owned = NULL;
}

/* Whether the mesh built from sc is offered to the other scenes (and
 * looked for among theirs): an OBJ or PLY source, or inline arrays' text,
 * all its build depends on, with an asset cache to share it in.  A glTF source
 * may name other files, and bakes an animation at the scene's frame. */
static bool source_shares(const struct loader *ld, const struct source *sc) {
    return ld->lim->assets && (sc->format < 2 || sc->format == SOURCE_INLINE);
}

/* What a mesh of sc is shared under besides its bytes: its format (or
 * SOURCE_INLINE) and whether its normals are smoothed. */
static unsigned source_variant(const struct source *sc, bool smooth) {
    return (unsigned)sc->format | (smooth ? 8u : 0u);
}

/* A decoder's charges passed on to the loader's hook, their high point
 * kept: a scene that takes the mesh is charged that much, as decoding it
 * would be (a decoder charges a guess and gives the spare back). */
struct charge_peak {
    enum rayd_status (*charge)(void *arg, long long bytes, char *why, size_t why_len);
    void *arg;
    long long now, top;
};

static enum rayd_status peak_charge(void *arg, long long bytes, char *why, size_t why_len) {
    struct charge_peak *p = arg;
    enum rayd_status st = p->charge ? p->charge(p->arg, bytes, why, why_len) : RAYD_OK;
    if (st == RAYD_OK && (p->now += bytes) > p->top) p->top = p->now;
    return st;
}

/* The source's bytes decoded into md, within what is left of the scene's
 * vertex and triangle budget; *peak: the most the decoder had charged.
 * On failure the bytes are freed. */
static enum rayd_status source_decode(struct loader *ld, const cJSON *src, const struct jp *at,
                                      struct source *sc, struct mesh_data *md, size_t *peak) {
    const cJSON *file = cJSON_GetObjectItemCaseSensitive(src, "file");
    struct jp pv = jp_key(at, sc->file                                        ? "file"
                              : cJSON_GetObjectItemCaseSensitive(src, "text") ? "text"
                                                                              : "base64");
    double t0 = clock_now();
    struct mesh_limits ml = sj_mesh_budget(ld);
    struct charge_peak cp = {ml.charge, ml.charge_arg, 0, 0};
    ml.charge = peak_charge, ml.charge_arg = &cp; /* with no hook too: a share keeps the peak */
    enum rayd_status st =
        sc->format == 0   ? mesh_parse_obj_threads(sc->bytes, sc->n, &ml, 0, md, ld->err)
        : sc->format == 1 ? mesh_parse_ply_threads(sc->bytes, sc->n, &ml, 0, md, ld->err)
                          : load_gltf(ld, at, file, sc->bytes, sc->n, &ml, md);
    ld->s->decode_s += clock_now() - t0;
    *peak = (size_t)cp.top;
    if (st != RAYD_OK && ld->err && sc->format < 2)
        snprintf(ld->err->path, sizeof ld->err->path, "%s", pv.s);
    if (st == RAYD_OK && md->ntris == 0) {
        mesh_drop(ld, md);
        st = sj_fail(ld, RAYD_E_INVALID, &pv, "holds no triangles");
    }
    if (st != RAYD_OK || !source_shares(ld, sc)) source_done(ld, sc);
    return st;
}

/* "source": its bytes read; the inline keys may not come beside it. */
static enum rayd_status source_read(struct loader *ld, const cJSON *oj, const cJSON *src,
                                    const struct jp *at, struct source *sc) {
    static const char *const inline_keys[] = {"vertices", "indices", "normals", "uvs"};
    for (int k = 0; k < 4; k++) {
        if (!cJSON_GetObjectItemCaseSensitive(oj, inline_keys[k])) continue;
        struct jp p = jp_key(at, inline_keys[k]);
        return sj_fail(ld, RAYD_E_INVALID, &p, "cannot be combined with \"source\"");
    }
    struct jp p = jp_key(at, "source");
    TRY(sj_source_read(ld, src, &p, &sc->format, &sc->owned, &sc->bytes, &sc->n));
    sc->file = cJSON_GetObjectItemCaseSensitive(src, "file") != NULL;
    return RAYD_OK;
}

/* Each normal of n made a unit vector; a zero-length one is an error at
 * its first number. */
static enum rayd_status unit_normals(struct loader *ld, const struct jp *at, float *nrm, long n) {
    for (long i = 0; i < n; i++) {
        float *v = nrm + 3 * i;
        double len = sqrt((double)v[0] * v[0] + (double)v[1] * v[1] + (double)v[2] * v[2]);
        if (!(len > 0)) {
            struct jp p = jp_key(at, "normals");
            struct jp pe = jp_index(&p, (int)(3 * i));
            return sj_fail(ld, RAYD_E_INVALID, &pe, "normal %ld must not be a zero-length vector",
                           i);
        }
        for (int k = 0; k < 3; k++) v[k] = (float)(v[k] / len);
    }
    return RAYD_OK;
}

/* An inline mesh's arrays: "vertices" (within the scene's vertex budget),
 * "indices", and "normals" (made unit) and "uvs", one per vertex.  On an
 * error nothing is kept. */
static enum rayd_status mesh_from_inline(struct loader *ld, const cJSON *oj, const struct jp *at,
                                         struct mesh_data *md) {
    float *pos = NULL, *nrm = NULL, *uv = NULL;
    uint32_t *ix = NULL;
    long nv = 0, nn = 0, nuv = 0, nt = 0;
    struct jp p = jp_key(at, "vertices");
    enum rayd_status st = get_flat(ld, oj, at, "vertices", 3, 3, &pos, &nv);
    if (st == RAYD_OK && !pos)
        st = sj_fail(ld, RAYD_E_INVALID, &p, "is required (x, y, z of each vertex, flat)");
    if (st == RAYD_OK && ld->vertices + nv > ld->lim->max_vertices)
        st = sj_fail(ld, RAYD_E_LIMIT, &p, "brings the scene to %ld vertices; the limit is %ld",
                     ld->vertices + nv, ld->lim->max_vertices);
    if (st == RAYD_OK) st = get_indices(ld, oj, at, nv, &ix, &nt);
    if (st == RAYD_OK) st = get_flat(ld, oj, at, "normals", 3, 0, &nrm, &nn);
    if (st == RAYD_OK) st = get_flat(ld, oj, at, "uvs", 2, 0, &uv, &nuv);
    if (st == RAYD_OK && ((nrm && nn != nv) || (uv && nuv != nv))) {
        p = jp_key(at, nrm && nn != nv ? "normals" : "uvs");
        st = sj_fail(ld, RAYD_E_INVALID, &p, "must have one entry per vertex (%ld)", nv);
    }
    if (st == RAYD_OK && nrm) st = unit_normals(ld, at, nrm, nn);
    if (st != RAYD_OK) {
        free(pos);
        free(nrm);
        free(uv);
        free(ix);
        return st;
    }
    *md = (struct mesh_data){pos, nrm, uv, ix, (uint32_t)nv, (uint32_t)nt, 0};
    return RAYD_OK;
}

/* The budget a mesh decoded now has: what is left of the scene's. */
static struct mesh_terms mesh_terms_now(const struct loader *ld) {
    struct mesh_limits ml = sj_mesh_budget(ld);
    return (struct mesh_terms){.max_verts = ml.max_vertices, .max_tris = ml.max_triangles};
}

/* Charges bytes if there is room, setting no error: false when not. */
static bool charge_quiet(struct loader *ld, size_t bytes) {
    struct mesh_limits hook = sj_mesh_budget(ld);
    size_t charged = 0;
    char why[200];
    return mesh_charge(&hook, &charged, bytes, why, sizeof why) == RAYD_OK;
}

/* The mesh another scene built from sc's bytes (lim->assets), taken when
 * it was decoded within a budget no larger than this scene has left (else
 * decoding it here answers, in the decoder's words): *took then says so.
 * Charged as its decode and build were at their peak, then down to what
 * the build kept and its key, so the limits answer as if it were built
 * here; a file's read is settled with it.  Without room for the key (a
 * build here keeps its mesh unshared then) it is not taken. */
static enum rayd_status mesh_taken(struct loader *ld, struct source *sc, unsigned variant,
                                   const struct jp *at, uint32_t *id, bool *took) {
    struct mesh m;
    struct mesh_terms now = mesh_terms_now(ld), was;
    *took = mesh_share_find(ld->lim->assets, variant, sc->bytes, sc->n, &now, &m, &was);
    if (!*took) return RAYD_OK;
    size_t held = sc->file ? sc->n + 1 : 0, top = held + was.peak, want = was.kept + sc->n;
    enum rayd_status st = sj_charge(ld, at, was.peak);
    if (st == RAYD_OK && want > top && !charge_quiet(ld, want - top)) {
        sj_give_back(ld, was.peak);
        mesh_free(&m);
        *took = false;
        return RAYD_OK;
    }
    if (want > top) top = want;
    if (st == RAYD_OK && (st = add_mesh(ld, id)) != RAYD_OK) sj_give_back(ld, top - held);
    if (st != RAYD_OK) {
        mesh_free(&m);
        return st;
    }
    sc->file = false; /* the read's charge is settled here, with the mesh's */
    ld->s->meshes[*id] = m;
    ld->vertices += m.nverts;
    ld->triangles += m.ntris;
    sj_give_back(ld, top - want);
    return RAYD_OK;
}

/* md's arrays built as the scene's mesh id (which owns them after, even
 * on failure), on every core for a large one, its time in build_s. */
static enum rayd_status mesh_build_timed(struct loader *ld, uint32_t id, const struct mesh_data *md,
                                         bool smooth) {
    double t0 = clock_now();
    enum rayd_status st =
        mesh_build(&ld->s->meshes[id], md->pos, md->nverts, md->index, md->ntris, md->normal,
                   md->uv, smooth, md->ntris >= 50000 ? parallel_cores() : 1, ld->err);
    ld->s->build_s += clock_now() - t0;
    return st;
}

/* Mesh md (its arrays taken, charged md->charged) built as the scene's
 * mesh *id, charged its arrays and the build's estimate, then what the
 * build holds; t->kept says how much, t->peak (the decoder's high point
 * on entry) the most. */
static enum rayd_status mesh_make(struct loader *ld, struct mesh_data *md, const struct jp *at,
                                  bool smooth, uint32_t *id, struct mesh_terms *t) {
    /* the arrays and the build's estimate, less what the decoder charged
     * for the arrays already (it charged them as it allocated them) */
    size_t charged = sj_mesh_bytes(md), top = charged > md->charged ? charged : md->charged;
    if (top > t->peak) t->peak = top; /* else the decoder's own high point */
    enum rayd_status st = RAYD_OK;
    if (charged > md->charged) {
        st = sj_charge(ld, at, charged - md->charged);
        if (st == RAYD_OK) md->charged = charged;
    } else {
        sj_give_back(ld, md->charged - charged);
        md->charged = charged;
    }
    if (st == RAYD_OK) st = add_mesh(ld, id);
    if (st != RAYD_OK) {
        mesh_drop(ld, md);
        return st;
    }
    ld->vertices += md->nverts;
    ld->triangles += md->ntris;
    st = mesh_build_timed(ld, *id, md, smooth);
    size_t built = mesh_bytes(&ld->s->meshes[*id]); /* the estimate's excess given back */
    if (st == RAYD_OK && built < charged) sj_give_back(ld, charged - built);
    t->kept = built < charged ? built : charged;
    return st; /* the mesh owns the arrays now, even on failure */
}

/* The built mesh m offered to the scenes of the same source on terms t,
 * its bytes the key: a file's keep their read's charge, others are
 * charged now (and the mesh stays unshared when there is no room). */
static void mesh_offer(struct loader *ld, struct source *sc, unsigned variant, struct mesh *m,
                       const struct mesh_terms *t) {
    unsigned char *key = (unsigned char *)sc->owned;
    if (!key && sc->bytes && (key = malloc(sc->n ? sc->n : 1))) memcpy(key, sc->bytes, sc->n);
    if (!key || (!sc->file && !charge_quiet(ld, sc->n))) {
        if (key != (unsigned char *)sc->owned) free(key);
        return; /* source_done frees the bytes */
    }
    if (sc->file) sj_give_back(ld, 1); /* the read's n + 1: the key's n */
    sc->owned = NULL;
    sc->file = false;
    if (!mesh_share_add(ld->lim->assets, m, variant, key, sc->n, t, true)) sj_give_back(ld, sc->n);
}

/* A "source" mesh: taken built from another scene of the same bytes, or
 * decoded and built, then offered to the others. */
static enum rayd_status mesh_source(struct loader *ld, const cJSON *oj, const cJSON *src,
                                    const struct jp *at, bool smooth, uint32_t *id) {
    struct source sc = {0};
    double t0 = clock_now(); /* the decode's time counts reading the file or base64 */
    TRY(source_read(ld, oj, src, at, &sc));
    ld->s->decode_s += clock_now() - t0;
    struct jp pm = jp_key(at, "source");
    unsigned variant = source_variant(&sc, smooth);
    bool took = false;
    enum rayd_status st = RAYD_OK;
    if (source_shares(ld, &sc)) st = mesh_taken(ld, &sc, variant, &pm, id, &took);
    if (st != RAYD_OK || took) {
        source_done(ld, &sc);
        return st;
    }
    struct mesh_terms t = mesh_terms_now(ld);
    struct mesh_data md = {0};
    TRY(source_decode(ld, src, &pm, &sc, &md, &t.peak));
    /* a glTF source is not shared: each frame decodes and builds it again
     * (a 1000-triangle primitive drawn by 5000 nodes: 2 s a frame) */
    if (ld->anim && ld->anim->on && !source_shares(ld, &sc))
        ld->frame_work += md.ntris * (double)SJ_WORK_BUILD_TRI;
    st = mesh_make(ld, &md, &pm, smooth, id, &t);
    if (st == RAYD_OK && source_shares(ld, &sc))
        mesh_offer(ld, &sc, variant, &ld->s->meshes[*id], &t);
    source_done(ld, &sc);
    return st;
}

/* An inline mesh's arrays as a source to share under: their text, when
 * each one given is a span of the scene text (scene_json_inline.c: large
 * arrays; a small mesh costs little to read again).  Each span runs from
 * its '[' to its ']' and holds numbers alone, so the texts joined in key
 * order, each after its key's letter, tell every array apart.  False
 * (sc untouched) when not, or no memory for the key. */
static bool inline_source(const struct loader *ld, const cJSON *oj, struct source *sc) {
    static const char *const keys[] = {"vertices", "indices", "normals", "uvs"};
    const struct json_span *sp[4] = {NULL};
    size_t n = 0;
    for (int k = 0; ld->lim->assets && k < 4; k++) {
        const cJSON *a = cJSON_GetObjectItemCaseSensitive(oj, keys[k]);
        if (a && !(sp[k] = sj_inline_span(ld->inl, a))) return false;
        if (sp[k]) n += 1 + sp[k]->close - sp[k]->open + 1;
    }
    char *key = sp[0] && sp[1] ? malloc(n) : NULL, *at = key;
    for (int k = 0; key && k < 4; k++) {
        if (!sp[k]) continue;
        *at++ = keys[k][0];
        memcpy(at, ld->inl->text + sp[k]->open, sp[k]->close - sp[k]->open + 1);
        at += sp[k]->close - sp[k]->open + 1;
    }
    if (!key) return false;
    *sc = (struct source){.format = SOURCE_INLINE, .owned = key, .bytes = key, .n = n};
    return true;
}

/* An inline mesh: taken built from another scene of the same arrays'
 * text, or read and built, then offered to the others. */
static enum rayd_status mesh_inline(struct loader *ld, const cJSON *oj, const struct jp *at,
                                    bool smooth, uint32_t *id) {
    struct jp pm = jp_key(at, "indices");
    struct source sc = {0};
    bool shares = inline_source(ld, oj, &sc), took = false;
    unsigned variant = source_variant(&sc, smooth);
    enum rayd_status st = shares ? mesh_taken(ld, &sc, variant, &pm, id, &took) : RAYD_OK;
    struct mesh_terms t = mesh_terms_now(ld);
    struct mesh_data md = {0};
    if (st == RAYD_OK && !took) st = mesh_from_inline(ld, oj, at, &md);
    if (st == RAYD_OK && !took) st = mesh_make(ld, &md, &pm, smooth, id, &t);
    if (st == RAYD_OK && !took && shares) mesh_offer(ld, &sc, variant, &ld->s->meshes[*id], &t);
    source_done(ld, &sc);
    return st;
}

/* ---- baked meshes: a gltf object's, shared under their arrays ---------- */

/* A gltf object's meshes are baked from its document at the scene's frame
 * (its node transforms, their animation), so their source is not one file
 * to key them on: the baked arrays are.  A frame range of a still glTF
 * bakes the same arrays frame after frame, and the build they then skip is
 * most of a frame (a 1.3M-triangle .glb: 0.48 s a frame, three quarters of
 * it the BVH). */
#define SOURCE_BAKED 5
#define BAKED_SHARE_MIN 1000 /* triangles: a smaller mesh builds in no time */

/* A run of bytes of a baked mesh's key. */
struct baked_part {
    const void *p;
    size_t n;
};

/* The key of baked arrays md in parts: their counts (head, with which
 * arrays are given), then every array's bytes, all the build depends on.
 * Returns the key's length. */
static size_t baked_parts(const struct mesh_data *md, uint32_t head[3], struct baked_part part[5]) {
    size_t v = md->nverts;
    head[0] = md->nverts, head[1] = md->ntris;
    head[2] = (md->normal ? 1u : 0u) | (md->uv ? 2u : 0u);
    part[0] = (struct baked_part){head, 3 * sizeof *head};
    part[1] = (struct baked_part){md->pos, v * 3 * sizeof(float)};
    part[2] = (struct baked_part){md->index, (size_t)md->ntris * 3 * sizeof(uint32_t)};
    part[3] = (struct baked_part){md->normal, md->normal ? v * 3 * sizeof(float) : 0};
    part[4] = (struct baked_part){md->uv, md->uv ? v * 2 * sizeof(float) : 0};
    size_t len = 0;
    for (int k = 0; k < 5; k++) len += part[k].n;
    return len;
}

/* A baked mesh's key, charged (a scene holding the shared mesh counts it,
 * mesh_bytes): NULL when there is no cache, the mesh is small, or no room
 * (then it is built unshared). */
static unsigned char *baked_key_charged(struct loader *ld, const struct mesh_data *md,
                                        size_t *len) {
    uint32_t head[3];
    struct baked_part part[5];
    *len = baked_parts(md, head, part);
    if (!ld->lim->assets || md->ntris < BAKED_SHARE_MIN || !charge_quiet(ld, *len)) return NULL;
    unsigned char *key = malloc(*len), *at = key;
    if (!key) {
        sj_give_back(ld, *len);
        return NULL;
    }
    for (int k = 0; k < 5; at += part[k++].n)
        if (part[k].n) memcpy(at, part[k].p, part[k].n);
    return key;
}

enum rayd_status sj_mesh_baked(struct loader *ld, struct mesh_data *md, uint32_t *id) {
    if (ld->anim && ld->anim->on) /* baked again each frame; built again when animated */
        ld->frame_work +=
            md->ntris * (double)(ld->gltf_animated ? SJ_WORK_BUILD_TRI : SJ_WORK_BAKE_TRI);
    size_t len;
    unsigned char *key = baked_key_charged(ld, md, &len);
    const unsigned variant = SOURCE_BAKED | 8u; /* smoothed, as built below */
    /* the bake kept within this scene's budget: any entry's terms serve */
    struct mesh_terms any = {UINT32_MAX, UINT32_MAX, 0, 0}, none = {0, 0, 0, 0}, was;
    struct mesh m;
    bool took = key && mesh_share_find(ld->lim->assets, variant, key, len, &any, &m, &was);
    enum rayd_status st = add_mesh(ld, id);
    if (st != RAYD_OK) { /* nothing kept: the key's charge given back */
        if (took) mesh_free(&m);
        if (key) sj_give_back(ld, len);
    } else if (took) { /* the entry holds the same bytes: their charge stays, the scene counts it */
        ld->s->meshes[*id] = m;
    }
    if (st != RAYD_OK || took) {
        free(key);
        mesh_data_free(md);
        return st;
    }
    st = mesh_build_timed(ld, *id, md, true);
    *md = (struct mesh_data){0}; /* the mesh owns the arrays now */
    if (!key) return st;
    if (st != RAYD_OK) {
        free(key);
        sj_give_back(ld, len);
        return st;
    }
    /* found by baked keys alone (the variant), on no terms */
    if (!mesh_share_add(ld->lim->assets, &ld->s->meshes[*id], variant, key, len, &none, false))
        sj_give_back(ld, len);
    return RAYD_OK;
}

enum rayd_status sj_mesh(struct loader *ld, const cJSON *oj, const struct jp *at, uint32_t *id) {
    const cJSON *sm = cJSON_GetObjectItemCaseSensitive(oj, "smooth");
    if (sm && !cJSON_IsBool(sm)) {
        struct jp p = jp_key(at, "smooth");
        return sj_fail(ld, RAYD_E_INVALID, &p, "must be true or false, not %s", sj_type_name(sm));
    }
    bool smooth = !sm || cJSON_IsTrue(sm);
    const cJSON *src = cJSON_GetObjectItemCaseSensitive(oj, "source");
    return src ? mesh_source(ld, oj, src, at, smooth, id) : mesh_inline(ld, oj, at, smooth, id);
}
