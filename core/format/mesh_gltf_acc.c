/* mesh_gltf_acc.c -- what the glTF reader reads a document's values with:
 * JSON Pointers of its items, checked integers and references, buffers
 * and their views, and accessors.
 *
 * The lowest floor of the glTF reader: mesh_gltf.c (the container, the node
 * walk, the bake) and mesh_gltf_anim.c (node animations) call it, and it
 * calls neither, so the three files use each other one way.  Every size is
 * computed in 64-bit arithmetic from values checked to be integers in
 * range before anything is read; a buffer is loaded on its first use (the
 * GLB's BIN chunk, a base64 "data:" URI, or a relative file name handed to
 * the caller's opener, which confines it) and counted against max_bytes,
 * and an accessor without a bufferView counts its zeros as bytes read.
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/error.h"
#include "base/hugemem.h"
#include "format/base64.h"
#include "format/gltf_json.h"
#include "format/json_check.h"
#include "format/json_parse.h"
#include "format/mesh_gltf.h"
#include "format/mesh_gltf_private.h"

/* ---- errors and pointers ----------------------------------------------- */

struct jp gl_item(const char *top, long i) {
    struct jp r = {.s = ""};
    snprintf(r.s, sizeof r.s, "/%s/%ld", top, i);
    return r;
}

/* ---- typed getters ------------------------------------------------------ */

/* An integer o[key] in [lo, hi], def when absent (-1 def: required). */
enum rayd_status gl_int(struct gl *G, const cJSON *o, const struct jp *at, const char *key,
                        double def, double lo, double hi, double *out) {
    const cJSON *v = gl_get(o, key);
    struct jp p = jp_key(at, key);
    if (!v) {
        if (def < 0) return gl_fail(G, RAYD_E_INVALID, &p, "is required");
        *out = def;
        return RAYD_OK;
    }
    if (!cJSON_IsNumber(v) || floor(v->valuedouble) != v->valuedouble)
        return gl_fail(G, RAYD_E_INVALID, &p, "must be an integer");
    if (v->valuedouble < lo || v->valuedouble > hi)
        return gl_fail(G, RAYD_E_INVALID, &p, "must be in %.0f..%.0f", lo, hi);
    *out = v->valuedouble;
    return RAYD_OK;
}

/* o[key] as the index of an item of the top-level array top: *item. */
enum rayd_status gl_ref(struct gl *G, const cJSON *o, const struct jp *at, const char *key,
                        const char *top, int *id, const cJSON **item) {
    const cJSON *arr = gl_get(G->root, top);
    int n = cJSON_IsArray(arr) ? cJSON_GetArraySize(arr) : 0;
    double v;
    TRY_GL(gl_int(G, o, at, key, -1, 0, 2147483647.0, &v));
    struct jp p = jp_key(at, key);
    if (v >= n)
        return gl_fail(G, RAYD_E_INVALID, &p, "%.0f is not an index into /%s (the file has %d)", v,
                       top, n);
    *id = (int)v;
    *item = cJSON_GetArrayItem(arr, *id);
    struct jp pi = gl_item(top, *id);
    if (!cJSON_IsObject(*item)) return gl_fail(G, RAYD_E_INVALID, &pi, "must be an object");
    return RAYD_OK;
}

/* n numbers at o[key] into out; def when absent. */
enum rayd_status gl_nums(struct gl *G, const cJSON *o, const struct jp *at, const char *key, int n,
                         const double *def, double *out) {
    const cJSON *v = gl_get(o, key);
    struct jp p = jp_key(at, key);
    if (!v) {
        memcpy(out, def, sizeof *out * (size_t)n);
        return RAYD_OK;
    }
    if (!cJSON_IsArray(v) || cJSON_GetArraySize(v) != n)
        return gl_fail(G, RAYD_E_INVALID, &p, "must be an array of %d numbers", n);
    /* n entries, each written or refused (a NULL e is no number) */
    const cJSON *e = v->child;
    for (int i = 0; i < n; i++, e = e ? e->next : NULL) {
        struct jp pe = jp_index(&p, i);
        if (!cJSON_IsNumber(e) || !isfinite(e->valuedouble) || fabs(e->valuedouble) > 1e30)
            return gl_fail(G, RAYD_E_INVALID, &pe, "must be a finite number");
        out[i] = e->valuedouble;
    }
    return RAYD_OK;
}

/* ---- the container ------------------------------------------------------ */

/* ---- buffers ------------------------------------------------------------ */

static int gl_hex(char c) {
    return c >= '0' && c <= '9'   ? c - '0'
           : c >= 'a' && c <= 'f' ? c - 'a' + 10
           : c >= 'A' && c <= 'F' ? c - 'A' + 10
                                  : -1;
}

/* A relative URI's file name, %XX decoded; false when it cannot be one. */
static bool gl_uri_name(const char *uri, char *out, size_t cap) {
    size_t n = 0;
    if (strstr(uri, "://") || uri[0] == '\0') return false;
    for (const char *c = uri; *c; c++) {
        int ch = (unsigned char)*c;
        if (*c == '%' && gl_hex(c[1]) >= 0 && gl_hex(c[2]) >= 0)
            ch = gl_hex(c[1]) * 16 + gl_hex(c[2]), c += 2;
        if (ch == 0 || n + 1 >= cap) return false;
        out[n++] = (char)ch;
    }
    out[n] = '\0';
    return true;
}

/* A "data:...;base64," URI's bytes. */
enum rayd_status gl_data_uri(struct gl *G, const char *uri, const struct jp *p, struct gl_buf *b) {
    const char *comma = strchr(uri, ',');
    if (!comma || comma - uri < 12 || memcmp(comma - 7, ";base64", 7) != 0)
        return gl_fail(G, RAYD_E_INVALID, p, "a data: URI must be base64 (\"data:...;base64,\")");
    struct rayd_error e = {0};
    enum rayd_status st = base64_decode(comma + 1, strlen(comma + 1), &b->data, &b->len, &e);
    if (st != RAYD_OK) return gl_fail(G, st, p, "%s", e.message);
    b->owned = true;
    return RAYD_OK;
}

enum rayd_status gl_file_uri(struct gl *G, const char *uri, const struct jp *p, struct gl_buf *b) {
    char name[1024];
    if (!gl_uri_name(uri, name, sizeof name))
        return gl_fail(G, RAYD_E_INVALID, p, "only data: URIs and relative file names are read");
    if (!G->o->open)
        return gl_fail(G, RAYD_E_INVALID, p,
                       "names a file, but no files are read here; embed the file as a data: URI or "
                       "use a .glb");
    char *data = NULL;
    enum rayd_status st = G->o->open(G->o->ctx, name, &data, &b->len, G->err);
    if (st != RAYD_OK) {
        if (G->err) snprintf(G->err->path, sizeof G->err->path, "%s", p->s);
        return st;
    }
    b->data = (unsigned char *)data;
    b->owned = true;
    return RAYD_OK;
}

/* Buffer i, loaded on first use: the BIN chunk, a data: URI or a file. */
static enum rayd_status gl_buffer(struct gl *G, int i, const struct gl_buf **out) {
    struct gl_buf *b = &G->bufs[i];
    struct jp p = gl_item("buffers", i);
    const cJSON *bj = cJSON_GetArrayItem(gl_get(G->root, "buffers"), i);
    double blen;
    *out = b;
    if (b->data) return RAYD_OK;
    TRY_GL(gl_int(G, bj, &p, "byteLength", -1, 1, 9007199254740991.0, &blen));
    const cJSON *uri = gl_get(bj, "uri");
    struct jp pu = jp_key(&p, "uri");
    if (uri && !cJSON_IsString(uri)) return gl_fail(G, RAYD_E_INVALID, &pu, "must be a string");
    if (!uri && (i != 0 || !G->bin))
        return gl_fail(G, RAYD_E_INVALID, &pu,
                       "is required (only buffer 0 of a .glb may use its BIN chunk)");
    if (!uri) {
        b->data = (unsigned char *)(uintptr_t)G->bin, b->len = G->bin_len;
    } else if (!strncmp(uri->valuestring, "data:", 5)) {
        TRY_GL(gl_data_uri(G, uri->valuestring, &pu, b));
    } else {
        TRY_GL(gl_file_uri(G, uri->valuestring, &pu, b));
    }
    struct jp pl = jp_key(&p, "byteLength");
    if ((double)b->len < blen)
        return gl_fail(G, RAYD_E_INVALID, &pl, "is %.0f but the data has %zu bytes", blen, b->len);
    b->len = (size_t)blen;
    if (b->owned && (G->loaded += b->len) > G->o->max_bytes)
        return gl_fail(G, RAYD_E_LIMIT, &pl, "the buffers come to %zu bytes; the limit is %zu",
                       G->loaded, G->o->max_bytes);
    return RAYD_OK;
}

/* ---- accessors ---------------------------------------------------------- */

static int gl_csize(int ctype) {
    switch (ctype) {
    case 5120:
    case 5121: return 1; /* BYTE, UNSIGNED_BYTE */
    case 5122:
    case 5123: return 2; /* SHORT, UNSIGNED_SHORT */
    case 5125:
    case 5126: return 4; /* UNSIGNED_INT, FLOAT */
    default: return 0;
    }
}

static int gl_ncomp(const char *type) {
    static const char *const names[] = {"SCALAR", "VEC2", "VEC3", "VEC4", "MAT2", "MAT3", "MAT4"};
    static const int n[] = {1, 2, 3, 4, 4, 9, 16};
    for (int i = 0; i < 7; i++)
        if (!strcmp(type, names[i])) return n[i];
    return 0;
}

enum rayd_status gl_view_span(struct gl *G, const cJSON *vj, const struct jp *pv,
                              struct gl_span *s) {
    const cJSON *bj;
    TRY_GL(gl_ref(G, vj, pv, "buffer", "buffers", &s->buffer, &bj));
    TRY_GL(gl_int(G, vj, pv, "byteOffset", 0, 0, 9007199254740991.0, &s->offset));
    return gl_int(G, vj, pv, "byteLength", -1, 1, 9007199254740991.0, &s->len);
}

enum rayd_status gl_view_bytes(struct gl *G, const struct jp *pv, const struct gl_span *s,
                               const unsigned char **p) {
    const struct gl_buf *b;
    TRY_GL(gl_buffer(G, s->buffer, &b));
    struct jp pvl = jp_key(pv, "byteLength");
    if (s->offset + s->len > (double)b->len)
        return gl_fail(G, RAYD_E_INVALID, &pvl,
                       "runs past the end of buffer %d (offset %.0f + %.0f > %zu bytes)", s->buffer,
                       s->offset, s->len, b->len);
    *p = b->data + (size_t)s->offset;
    return RAYD_OK;
}

/* The accessor's bufferView, checked to hold count elements of esize bytes. */
static enum rayd_status gl_view(struct gl *G, const cJSON *aj, const struct jp *pa, double offset,
                                size_t esize, struct gl_acc *a) {
    const cJSON *vj;
    int vid;
    double stride;
    TRY_GL(gl_ref(G, aj, pa, "bufferView", "bufferViews", &vid, &vj));
    struct jp pv = gl_item("bufferViews", vid);
    struct gl_span v;
    const unsigned char *base;
    TRY_GL(gl_view_span(G, vj, &pv, &v));
    TRY_GL(gl_int(G, vj, &pv, "byteStride", 0, 4, 252, &stride));
    TRY_GL(gl_view_bytes(G, &pv, &v, &base));
    struct jp pst = jp_key(&pv, "byteStride");
    if (stride && stride < (double)esize)
        return gl_fail(G, RAYD_E_INVALID, &pst,
                       "%.0f is less than the accessor's element (%zu bytes)", stride, esize);
    a->stride = stride ? (size_t)stride : esize;
    /* every term is below 2^53 and exact in a double */
    double need = offset + (double)(a->count - 1) * (double)a->stride + (double)esize;
    struct jp pc = jp_key(pa, "count");
    if (need > v.len)
        return gl_fail(G, RAYD_E_INVALID, &pc,
                       "exceeds the buffer view (offset %.0f + %u elements of stride %zu need %.0f "
                       "bytes; bufferView %d has %.0f)",
                       offset, a->count, a->stride, need, vid, v.len);
    a->p = base + (size_t)offset;
    return RAYD_OK;
}

/* Accessor o[key] (index into /accessors), of ncomp components. */
enum rayd_status gl_accessor(struct gl *G, const cJSON *o, const struct jp *at, const char *key,
                             int ncomp, bool index, struct gl_acc *a) {
    const cJSON *aj;
    double ct, count, offset;
    memset(a, 0, sizeof *a);
    TRY_GL(gl_ref(G, o, at, key, "accessors", &a->id, &aj));
    struct jp pa = gl_item("accessors", a->id);
    struct jp pct = jp_key(&pa, "componentType"), pt = jp_key(&pa, "type"),
              ps = jp_key(&pa, "sparse");
    TRY_GL(gl_int(G, aj, &pa, "componentType", -1, 5120, 5126, &ct));
    TRY_GL(gl_int(G, aj, &pa, "count", -1, 1, 4294967295.0, &count));
    TRY_GL(gl_int(G, aj, &pa, "byteOffset", 0, 0, 9007199254740991.0, &offset));
    const cJSON *type = gl_get(aj, "type"), *norm = gl_get(aj, "normalized");
    a->ctype = (int)ct;
    a->count = (uint32_t)count;
    a->norm = cJSON_IsTrue(norm);
    a->ncomp = cJSON_IsString(type) ? gl_ncomp(type->valuestring) : 0;
    if (!gl_csize(a->ctype))
        return gl_fail(G, RAYD_E_INVALID, &pct, "%d is not a glTF component type", a->ctype);
    if (a->ncomp != ncomp || (ncomp == 4 && strcmp(type->valuestring, "VEC4") != 0))
        return gl_fail(G, RAYD_E_INVALID, &pt, "must be \"%s\" here",
                       ncomp == 1   ? "SCALAR"
                       : ncomp == 2 ? "VEC2"
                       : ncomp == 3 ? "VEC3"
                                    : "VEC4");
    if (index && a->ctype != 5121 && a->ctype != 5123 && a->ctype != 5125)
        return gl_fail(G, RAYD_E_INVALID, &pct,
                       "indices must be UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT (5121, 5123, "
                       "5125), not %d",
                       a->ctype);
    if (!index && a->ctype == 5125)
        return gl_fail(G, RAYD_E_INVALID, &pct, "UNSIGNED_INT is not a vertex attribute type");
    if (gl_get(aj, "sparse"))
        return gl_fail(G, RAYD_E_INVALID, &ps, "sparse accessors are not supported");
    size_t esize = (size_t)gl_csize(a->ctype) * (size_t)ncomp;
    if (!gl_get(aj, "bufferView")) {
        /* all zeros, as the spec says: a few bytes of JSON that stand for
         * count elements, so they count against max_bytes as if read */
        struct jp pc = jp_key(&pa, "count");
        if (!G->counted && (G->loaded += (size_t)a->count * esize) > G->o->max_bytes)
            return gl_fail(G, RAYD_E_LIMIT, &pc,
                           "has no bufferView: its %u elements of zeros count as %zu bytes, "
                           "bringing the buffers to %zu; the limit is %zu",
                           a->count, (size_t)a->count * esize, G->loaded, G->o->max_bytes);
        return RAYD_OK;
    }
    struct jp po = jp_key(&pa, "byteOffset");
    if ((size_t)offset % (size_t)gl_csize(a->ctype) != 0)
        return gl_fail(G, RAYD_E_INVALID, &po, "must be a multiple of the component size");
    return gl_view(G, aj, &pa, offset, esize, a);
}

/* Component c of element i, as a number (normalised integers mapped to [-1, 1] or [0, 1]). */
double gl_value(const struct gl_acc *a, uint32_t i, int c) {
    if (!a->p) return 0;
    const unsigned char *b = a->p + (size_t)i * a->stride + (size_t)c * (size_t)gl_csize(a->ctype);
    uint32_t u = a->ctype == 5120 || a->ctype == 5121   ? b[0]
                 : a->ctype == 5122 || a->ctype == 5123 ? (uint32_t)b[0] | (uint32_t)b[1] << 8
                                                        : bytes_le32(b);
    float f;
    switch (a->ctype) {
    case 5120: return a->norm ? fmax((int8_t)u / 127.0, -1.0) : (int8_t)u;
    case 5121: return a->norm ? u / 255.0 : u;
    case 5122: return a->norm ? fmax((int16_t)u / 32767.0, -1.0) : (int16_t)u;
    case 5123: return a->norm ? u / 65535.0 : u;
    case 5126: memcpy(&f, &u, sizeof f); return f;
    default: return u;
    }
}
