/* mesh_ply.c -- PLY (Stanford polygon file) to an indexed triangle mesh.
 *
 * A PLY file is a text header that declares elements (a name, a record
 * count, and a list of typed properties) followed by a body holding the
 * records of each element in order, as ascii tokens or as packed binary in
 * either byte order.  The header is read line by line in place (tokens are
 * slices of the caller's buffer, so header lines may be any length); the
 * body is then read in one pass through a cursor that never goes past len.
 *
 * What is used:
 *   - element `vertex`: x y z (required), nx ny nz (all three, optional),
 *     u v / s t / texture_u texture_v / texture_s texture_t (optional);
 *   - element `face`: the list `vertex_indices` (or `vertex_index`), each
 *     polygon fan-triangulated (0,1,2), (0,2,3), ...;
 *   - element `tristrips` (several Stanford scans have it instead of
 *     faces): the list `vertex_indices` holds triangle strips, -1 ending
 *     one; strip a b c d e gives (a,b,c), (c,b,d), (c,d,e), ... -- every
 *     other triangle turned so all keep the strip's winding -- and the
 *     triangles that strips use to join (two equal corners) are dropped.
 * Every other element and property, lists included, is read past: a record
 * of fixed size in a binary file is skipped in one step, anything else value
 * by value.  All PLY scalar types (char/int8 ... double/float64) may hold
 * any property; list counts must have an integer type.
 *
 * The header is untrusted: before anything is allocated, the smallest body
 * the declared counts need (bytes per binary record; two characters per
 * ascii value) is compared with what follows the header, so a header that
 * claims four billion vertices in a 100-byte file fails at once, and the
 * vertex and face counts are checked against the limits.  Face indices are
 * checked against the declared vertex count, which is why faces may come
 * before vertices.  Values must be finite and fit a float.
 *
 * Errors name the 1-based header line, or the element and its 0-based
 * record number in the body ("PLY vertex 17: ..."), 0-based like the
 * indices that refer to those records.
 *
 * On several threads (mesh_parse_ply_threads), a binary vertex or face
 * element whose records all have one size -- no lists, but for the faces'
 * index list when every face is a triangle -- is cut into ranges of
 * records read at once, each by a copy of the reader placed on its first
 * record; every face's count is checked to be 3 before it is read.  Any
 * failure (a polygon, a bad value) and the element is read again in order,
 * so the message is the one-thread reader's.  Ascii records need not be
 * one a line, so ascii bodies stay in one pass.  The two layouts nearly
 * every binary mesh has (vertices of only float x y z, faces of a byte
 * count and 32-bit indices), little-endian, skip the value-by-value
 * reader in those ranges: a copy and the same checks (ply_fast_layout).
 */
#include "base/hugemem.h"
#include "format/mesh_io.h"
#include "format/text_encoding.h"

#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/error.h"
#include "base/parallel.h"

enum ply_type { PLY_NONE, PLY_I8, PLY_U8, PLY_I16, PLY_U16, PLY_I32, PLY_U32, PLY_F32, PLY_F64 };
enum ply_format { PLY_ASCII = 1, PLY_LE, PLY_BE };
enum ply_kind { PLY_ELEM_OTHER, PLY_ELEM_VERTEX, PLY_ELEM_FACE, PLY_ELEM_STRIPS };
enum ply_role { PLY_X, PLY_Y, PLY_Z, PLY_NX, PLY_NY, PLY_NZ, PLY_U, PLY_V, PLY_INDICES, PLY_OTHER };

#define PLY_NROLES PLY_OTHER

static const size_t ply_size[] = {0, 1, 1, 2, 2, 4, 4, 4, 8};
static const char *const ply_role_name[] = {"x", "y", "z", "nx", "ny", "nz", "u", "v"};

struct ply_prop {
    enum ply_type type;       /* of the value, or of a list's items */
    enum ply_type count_type; /* PLY_NONE for a scalar */
    enum ply_role role;
};

struct ply_elem {
    const char *name;
    size_t name_len;
    uint64_t count;
    size_t line; /* header line that declared it */
    enum ply_kind kind;
    struct ply_prop *props;
    size_t nprops, cap_props;
    bool role_seen[PLY_OTHER + 1];
};

struct ply {
    const unsigned char *p;
    size_t len, at; /* cursor: the header line being read, then the body */
    size_t line;    /* 1-based header line */
    enum ply_format format;
    struct ply_elem *elems;
    size_t nelems, cap_elems;
    size_t vertex, face, strips; /* index in elems + 1, 0 if absent */
    uint32_t max_verts, max_tris, nverts;
    const struct ply_elem *cur; /* element being read, for messages */
    uint64_t rec;
    float *pos, *normal, *uv;
    uint32_t *tri;
    size_t ntri, cap_tri;
    int threads;                   /* for the binary records (ply_records); 1: one pass, in order */
    size_t min_chunk;              /* records a thread at least */
    const struct mesh_limits *lim; /* its charge hook: each array charged first */
    size_t charged;                /* bytes charged through it, given back on failure */
    struct rayd_error *err;
};

/* ---- errors ------------------------------------------------------------- */

/* Sets err to msg, prefixed with where: the record being read (body) or
 * the header line (P->line, or the header as a whole when it is 0). */
static void ply_fail_at(struct ply *P, enum rayd_status code, bool body, const char *msg) {
    char q[MESH_QUOTE_SIZE];
    if (body)
        err_set(P->err, code, NULL, "PLY %s %llu: %s",
                mesh_quote(q, P->cur->name, P->cur->name_len), (unsigned long long)P->rec, msg);
    else if (P->line)
        err_set(P->err, code, NULL, "PLY header line %zu: %s", P->line, msg);
    else
        err_set(P->err, code, NULL, "PLY header: %s", msg);
}

/* An error in the header (body false) or in record P->rec of element
 * P->cur (body true). */
static void ply_say(struct ply *P, enum rayd_status code, bool body, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));

static void ply_say(struct ply *P, enum rayd_status code, bool body, const char *fmt, ...) {
    char msg[200];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    ply_fail_at(P, code, body, msg);
}

/* ply_say as expressions whose value is the code (a macro like err_set, for
 * the reason error.h gives): in the header, and in a record. */
#define ply_hfail(P, code, ...)                                                                    \
    __extension__({                                                                                \
        ply_say((P), (code), false, __VA_ARGS__);                                                  \
        (code);                                                                                    \
    })
#define ply_bfail(P, code, ...)                                                                    \
    __extension__({                                                                                \
        ply_say((P), (code), true, __VA_ARGS__);                                                   \
        (code);                                                                                    \
    })

static enum rayd_status ply_truncated(struct ply *P) {
    return ply_bfail(P, RAYD_E_INVALID, "file ends early (truncated %s body)",
                     P->format == PLY_ASCII ? "ascii" : "binary");
}

static void ply_release(struct ply *P) {
    for (size_t i = 0; i < P->nelems; i++) free(P->elems[i].props);
    free(P->elems);
    free(P->pos);
    free(P->normal);
    free(P->uv);
    free(P->tri);
    mesh_give_back(P->lim, &P->charged, P->charged);
}

/* ---- header ------------------------------------------------------------- */

struct ply_tok {
    const char *s;
    size_t n;
};

static bool ply_space(unsigned char c) {
    return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f';
}

/* The next token of [*p, end), false at the end. */
static bool ply_token(const char **p, const char *end, struct ply_tok *t) {
    const char *s = *p;
    while (s < end && ply_space((unsigned char)*s)) s++;
    const char *e = s;
    while (e < end && !ply_space((unsigned char)*e)) e++;
    *p = e;
    t->s = s;
    t->n = (size_t)(e - s);
    return t->n > 0;
}

static bool ply_is(struct ply_tok t, const char *word) {
    return strlen(word) == t.n && memcmp(t.s, word, t.n) == 0;
}

/* A token quoted for a message (buf has MESH_QUOTE_SIZE bytes). */
static const char *ply_q(char *buf, struct ply_tok t) { return mesh_quote(buf, t.s, t.n); }

static enum ply_type ply_type_of(struct ply_tok t) {
    static const char *const names[] = {"char",   "int8",    "uchar",  "uint8",  "short", "int16",
                                        "ushort", "uint16",  "int",    "int32",  "uint",  "uint32",
                                        "float",  "float32", "double", "float64"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (ply_is(t, names[i])) return (enum ply_type)(PLY_I8 + i / 2);
    return PLY_NONE;
}

static enum ply_role ply_role_of(enum ply_kind kind, bool list, struct ply_tok name) {
    static const struct {
        const char *name;
        enum ply_role role;
    } vertex[] = {{"x", PLY_X},         {"y", PLY_Y},         {"z", PLY_Z},
                  {"nx", PLY_NX},       {"ny", PLY_NY},       {"nz", PLY_NZ},
                  {"u", PLY_U},         {"v", PLY_V},         {"s", PLY_U},
                  {"t", PLY_V},         {"texture_u", PLY_U}, {"texture_v", PLY_V},
                  {"texture_s", PLY_U}, {"texture_t", PLY_V}};
    if ((kind == PLY_ELEM_FACE || kind == PLY_ELEM_STRIPS) && list &&
        (ply_is(name, "vertex_indices") || ply_is(name, "vertex_index")))
        return PLY_INDICES;
    if (kind != PLY_ELEM_VERTEX || list) return PLY_OTHER;
    for (size_t i = 0; i < sizeof vertex / sizeof vertex[0]; i++)
        if (ply_is(name, vertex[i].name)) return vertex[i].role;
    return PLY_OTHER;
}

static enum rayd_status ply_format_line(struct ply *P, const char *p, const char *end) {
    char q[MESH_QUOTE_SIZE];
    struct ply_tok f, v, extra;
    if (P->format) return ply_hfail(P, RAYD_E_INVALID, "a second 'format' line");
    if (!ply_token(&p, end, &f) || !ply_token(&p, end, &v) || ply_token(&p, end, &extra))
        return ply_hfail(P, RAYD_E_INVALID, "expected 'format TYPE 1.0'");
    if (ply_is(f, "ascii"))
        P->format = PLY_ASCII;
    else if (ply_is(f, "binary_little_endian"))
        P->format = PLY_LE;
    else if (ply_is(f, "binary_big_endian"))
        P->format = PLY_BE;
    else
        return ply_hfail(P, RAYD_E_INVALID, "unknown format '%s'", ply_q(q, f));
    if (!ply_is(v, "1.0"))
        return ply_hfail(P, RAYD_E_INVALID, "unsupported version '%s' (expected 1.0)", ply_q(q, v));
    return RAYD_OK;
}

static bool ply_uint(struct ply_tok t, uint64_t *out) {
    uint64_t v = 0;
    for (size_t i = 0; i < t.n; i++) {
        uint64_t d = (uint64_t)(t.s[i] - '0');
        if (t.s[i] < '0' || t.s[i] > '9' || v > (UINT64_MAX - d) / 10) return false;
        v = v * 10 + d;
    }
    *out = v;
    return t.n > 0;
}

static enum rayd_status ply_element_line(struct ply *P, const char *p, const char *end) {
    char q[MESH_QUOTE_SIZE];
    struct ply_tok name, count, extra;
    uint64_t n;
    if (!ply_token(&p, end, &name) || !ply_token(&p, end, &count) || ply_token(&p, end, &extra))
        return ply_hfail(P, RAYD_E_INVALID, "expected 'element NAME COUNT'");
    if (!ply_uint(count, &n))
        return ply_hfail(P, RAYD_E_INVALID, "bad element count '%s'", ply_q(q, count));
    enum ply_kind kind = ply_is(name, "vertex")      ? PLY_ELEM_VERTEX
                         : ply_is(name, "face")      ? PLY_ELEM_FACE
                         : ply_is(name, "tristrips") ? PLY_ELEM_STRIPS
                                                     : PLY_ELEM_OTHER;
    size_t *slot = kind == PLY_ELEM_VERTEX   ? &P->vertex
                   : kind == PLY_ELEM_FACE   ? &P->face
                   : kind == PLY_ELEM_STRIPS ? &P->strips
                                             : NULL;
    if (kind != PLY_ELEM_OTHER && *slot)
        return ply_hfail(P, RAYD_E_INVALID, "a second '%s' element", ply_q(q, name));
    if (!array_grow((void **)&P->elems, &P->cap_elems, P->nelems + 1, sizeof *P->elems))
        return ply_hfail(P, RAYD_E_NOMEM, "out of memory");
    struct ply_elem *e = &P->elems[P->nelems++];
    memset(e, 0, sizeof *e);
    e->name = name.s;
    e->name_len = name.n;
    e->count = n;
    e->line = P->line;
    e->kind = kind;
    if (slot) *slot = P->nelems;
    return RAYD_OK;
}

static enum rayd_status ply_property_line(struct ply *P, const char *p, const char *end) {
    char q[MESH_QUOTE_SIZE];
    struct ply_tok t, name, extra, ct = {NULL, 0};
    if (P->nelems == 0) return ply_hfail(P, RAYD_E_INVALID, "'property' before any 'element'");
    struct ply_elem *e = &P->elems[P->nelems - 1];
    if (!ply_token(&p, end, &t))
        return ply_hfail(P, RAYD_E_INVALID, "expected 'property TYPE NAME'");
    bool list = ply_is(t, "list");
    if (list && (!ply_token(&p, end, &ct) || !ply_token(&p, end, &t)))
        return ply_hfail(P, RAYD_E_INVALID, "expected 'property list COUNTTYPE ITEMTYPE NAME'");
    if (!ply_token(&p, end, &name) || ply_token(&p, end, &extra))
        return ply_hfail(P, RAYD_E_INVALID, "expected 'property %sTYPE NAME'",
                         list ? "list COUNTTYPE " : "");
    struct ply_prop prop = {ply_type_of(t), list ? ply_type_of(ct) : PLY_NONE, PLY_OTHER};
    if (list && (prop.count_type == PLY_NONE || prop.count_type >= PLY_F32))
        return ply_hfail(P, RAYD_E_INVALID, "bad list count type '%s' (an integer type needed)",
                         ply_q(q, ct));
    if (prop.type == PLY_NONE)
        return ply_hfail(P, RAYD_E_INVALID, "unknown property type '%s'", ply_q(q, t));
    prop.role = ply_role_of(e->kind, list, name);
    if (e->role_seen[prop.role]) prop.role = PLY_OTHER; /* e.g. both u and s: the first wins */
    e->role_seen[prop.role] = true;
    if (!array_grow((void **)&e->props, &e->cap_props, e->nprops + 1, sizeof *e->props))
        return ply_hfail(P, RAYD_E_NOMEM, "out of memory");
    e->props[e->nprops++] = prop;
    return RAYD_OK;
}

/* One header line [p, end); *done at end_header. */
static enum rayd_status ply_header_line(struct ply *P, const char *p, const char *end, bool *done) {
    char q[MESH_QUOTE_SIZE];
    struct ply_tok kw;
    if (!ply_token(&p, end, &kw)) return RAYD_OK;
    if (ply_is(kw, "format")) return ply_format_line(P, p, end);
    if (ply_is(kw, "element")) return ply_element_line(P, p, end);
    if (ply_is(kw, "property")) return ply_property_line(P, p, end);
    if (ply_is(kw, "comment") || ply_is(kw, "obj_info")) return RAYD_OK;
    if (ply_is(kw, "end_header")) {
        *done = true;
        return RAYD_OK;
    }
    /* Blender 2.4x wrote a "Created by ..." line without "comment": a line
     * of no known keyword before the first element is read as a comment;
     * among the elements it is most likely a typo, and refused. */
    if (P->nelems == 0) return RAYD_OK;
    return ply_hfail(P, RAYD_E_INVALID, "unknown keyword '%s'", ply_q(q, kw));
}

/* Reads the header lines; on success P->at is the first byte of the body. */
static enum rayd_status ply_header(struct ply *P) {
    const char *text = (const char *)P->p;
    bool done = false;
    while (!done) {
        if (P->at >= P->len) {
            P->line = 0;
            return ply_hfail(P, RAYD_E_INVALID, "no 'end_header' line (truncated header?)");
        }
        const char *line = text + P->at;
        const char *nl = memchr(line, '\n', P->len - P->at);
        const char *end = nl ? nl : text + P->len;
        P->line++;
        P->at = (size_t)(end - text) + (nl ? 1 : 0);
        if (P->line == 1) {
            struct ply_tok t, extra;
            const char *q = line;
            if (!ply_token(&q, end, &t) || !ply_is(t, "ply") || ply_token(&q, end, &extra))
                return ply_hfail(P, RAYD_E_INVALID, "not a PLY file (expected 'ply')");
            continue;
        }
        enum rayd_status st = ply_header_line(P, line, end, &done);
        if (st != RAYD_OK) return st;
    }
    P->line = 0;
    return RAYD_OK;
}

/* ---- checks between header and body ------------------------------------ */

static enum rayd_status ply_need_role(struct ply *P, const struct ply_elem *e, enum ply_role r) {
    if (e->role_seen[r]) return RAYD_OK;
    return ply_hfail(P, RAYD_E_INVALID, "element 'vertex' has no property '%s'", ply_role_name[r]);
}

/* The fewest body bytes one record of e can take. */
static uint64_t ply_min_record(const struct ply *P, const struct ply_elem *e) {
    uint64_t n = 0;
    for (size_t i = 0; i < e->nprops; i++) {
        const struct ply_prop *q = &e->props[i];
        if (P->format == PLY_ASCII)
            n += 2;
        else
            n += ply_size[q->count_type ? q->count_type : q->type];
    }
    return n;
}

/* Fails fast when the declared counts cannot fit in the body. */
static enum rayd_status ply_check_sizes(struct ply *P) {
    char q[MESH_QUOTE_SIZE];
    uint64_t avail = P->len - P->at, used = 0;
    if (P->format == PLY_ASCII) avail++; /* the last value needs no separator */
    for (size_t i = 0; i < P->nelems; i++) {
        const struct ply_elem *e = &P->elems[i];
        uint64_t rec = ply_min_record(P, e);
        if (rec && (e->count > (avail - used) / rec)) {
            P->line = e->line;
            return ply_hfail(P, RAYD_E_INVALID,
                             "element '%s' claims %llu records but the body has only %llu bytes",
                             mesh_quote(q, e->name, e->name_len), (unsigned long long)e->count,
                             (unsigned long long)(P->len - P->at));
        }
        used += e->count * rec;
    }
    return RAYD_OK;
}

static enum rayd_status ply_check_header(struct ply *P) {
    if (!P->format) return ply_hfail(P, RAYD_E_INVALID, "no 'format' line");
    if (!P->vertex) return ply_hfail(P, RAYD_E_INVALID, "no 'vertex' element");
    const struct ply_elem *v = &P->elems[P->vertex - 1];
    enum rayd_status st = ply_need_role(P, v, PLY_X);
    if (st == RAYD_OK) st = ply_need_role(P, v, PLY_Y);
    if (st == RAYD_OK) st = ply_need_role(P, v, PLY_Z);
    if (st != RAYD_OK) return st;
    if (!P->face && !P->strips)
        return ply_hfail(P, RAYD_E_INVALID,
                         "no 'face' or 'tristrips' element (a point cloud, not a mesh)");
    for (int k = 0; k < 2; k++) {
        size_t at = k ? P->strips : P->face;
        if (at && !P->elems[at - 1].role_seen[PLY_INDICES])
            return ply_hfail(P, RAYD_E_INVALID, "element '%s' has no list 'vertex_indices'",
                             k ? "tristrips" : "face");
    }
    st = ply_check_sizes(P);
    if (st != RAYD_OK) return st;
    if (v->count > P->max_verts)
        return ply_hfail(P, RAYD_E_LIMIT, "%llu vertices exceed the limit of %u",
                         (unsigned long long)v->count, P->max_verts);
    if (P->face && P->elems[P->face - 1].count > P->max_tris)
        return ply_hfail(P, RAYD_E_LIMIT, "%llu faces exceed the limit of %u triangles",
                         (unsigned long long)P->elems[P->face - 1].count, P->max_tris);
    return RAYD_OK;
}

/* ---- body values --------------------------------------------------------- */

static double ply_signed(uint64_t u, unsigned bits) {
    uint64_t half = UINT64_C(1) << (bits - 1);
    return u >= half ? (double)u - 2.0 * (double)half : (double)u;
}

static enum rayd_status ply_binary(struct ply *P, enum ply_type t, double *out) {
    size_t n = ply_size[t];
    if (P->len - P->at < n) return ply_truncated(P);
    const unsigned char *b = P->p + P->at;
    uint64_t u = 0;
    for (size_t k = 0; k < n; k++) u = u << 8 | b[P->format == PLY_LE ? n - 1 - k : k];
    P->at += n;
    switch (t) {
    case PLY_I8: *out = ply_signed(u, 8); break;
    case PLY_I16: *out = ply_signed(u, 16); break;
    case PLY_I32: *out = ply_signed(u, 32); break;
    case PLY_F32: {
        uint32_t w = (uint32_t)u;
        float f;
        memcpy(&f, &w, sizeof f);
        *out = f;
        break;
    }
    case PLY_F64: memcpy(out, &u, sizeof *out); break;
    default: *out = (double)u; break;
    }
    return RAYD_OK;
}

static enum rayd_status ply_ascii(struct ply *P, double *out) {
    char q[MESH_QUOTE_SIZE];
    const char *s = (const char *)P->p + P->at, *end = (const char *)P->p + P->len;
    struct ply_tok t;
    bool any = ply_token(&s, end, &t);
    P->at = (size_t)(s - (const char *)P->p);
    if (!any) return ply_truncated(P);
    if (!mesh_parse_number(t.s, t.n, out))
        return ply_bfail(P, RAYD_E_INVALID, "bad number '%s'", ply_q(q, t));
    return RAYD_OK;
}

static enum rayd_status ply_value(struct ply *P, enum ply_type t, double *out) {
    return P->format == PLY_ASCII ? ply_ascii(P, out) : ply_binary(P, t, out);
}

/* A list's item count. */
static enum rayd_status ply_count(struct ply *P, enum ply_type t, uint32_t *n) {
    double d = -1; /* set unless ply_value fails (which the analyzer cannot always follow) */
    enum rayd_status st = ply_value(P, t, &d);
    if (st != RAYD_OK) return st;
    if (!(d >= 0 && d <= 4294967295.0 && d == floor(d)))
        return ply_bfail(P, RAYD_E_INVALID, "bad list count %g", d);
    *n = (uint32_t)d;
    return RAYD_OK;
}

/* Reads past one property of the current record. */
static enum rayd_status ply_skip(struct ply *P, const struct ply_prop *q) {
    uint32_t n = 1;
    double d;
    if (q->count_type) {
        enum rayd_status st = ply_count(P, q->count_type, &n);
        if (st != RAYD_OK) return st;
    }
    if (P->format != PLY_ASCII) {
        if ((P->len - P->at) / ply_size[q->type] < n) return ply_truncated(P);
        P->at += (size_t)n * ply_size[q->type];
        return RAYD_OK;
    }
    for (uint32_t k = 0; k < n; k++) {
        enum rayd_status st = ply_ascii(P, &d);
        if (st != RAYD_OK) return st;
    }
    return RAYD_OK;
}

/* ---- records --------------------------------------------------------------- */

static enum rayd_status ply_vertex(struct ply *P, const struct ply_elem *e, uint32_t i) {
    double r[PLY_NROLES] = {0};
    for (size_t k = 0; k < e->nprops; k++) {
        const struct ply_prop *q = &e->props[k];
        enum rayd_status st =
            q->role < PLY_NROLES ? ply_value(P, q->type, &r[q->role]) : ply_skip(P, q);
        if (st != RAYD_OK) return st;
    }
    for (int k = 0; k < PLY_NROLES; k++)
        if (!isfinite(r[k]) || fabs(r[k]) > FLT_MAX)
            return ply_bfail(P, RAYD_E_INVALID, "%s is not a finite float", ply_role_name[k]);
    for (int k = 0; k < 3; k++) P->pos[(size_t)i * 3 + (size_t)k] = (float)r[PLY_X + k];
    if (P->normal)
        for (int k = 0; k < 3; k++) P->normal[(size_t)i * 3 + (size_t)k] = (float)r[PLY_NX + k];
    if (P->uv)
        for (int k = 0; k < 2; k++) P->uv[(size_t)i * 2 + (size_t)k] = (float)r[PLY_U + k];
    return RAYD_OK;
}

static enum rayd_status ply_index(struct ply *P, enum ply_type t, uint32_t *out) {
    double d = 0;
    enum rayd_status st = ply_value(P, t, &d);
    if (st != RAYD_OK) return st;
    if (d != floor(d)) return ply_bfail(P, RAYD_E_INVALID, "vertex index %g is not an integer", d);
    if (d >= 0 && d < (double)P->nverts) {
        *out = (uint32_t)d;
        return RAYD_OK;
    }
    if (P->nverts == 0)
        return ply_bfail(P, RAYD_E_INVALID, "vertex index %g but there are no vertices", d);
    return ply_bfail(P, RAYD_E_INVALID, "vertex index %g is out of range (0..%u)", d,
                     P->nverts - 1);
}

static enum rayd_status ply_triangle(struct ply *P, uint32_t a, uint32_t b, uint32_t c) {
    if (P->ntri >= P->max_tris)
        return ply_bfail(P, RAYD_E_LIMIT, "%zu triangles exceed the limit of %u", P->ntri + 1,
                         P->max_tris);
    char why[200];
    enum rayd_status st = mesh_grow(P->lim, &P->charged, (void **)&P->tri, &P->cap_tri,
                                    (P->ntri + 1) * 3, sizeof *P->tri, why, sizeof why);
    if (st != RAYD_OK) { /* ply_say, not ply_bfail: cppcheck misreads a variable code */
        ply_say(P, st, true, "%s", why);
        return st;
    }
    uint32_t *t = P->tri + P->ntri * 3;
    t[0] = a;
    t[1] = b;
    t[2] = c;
    P->ntri++;
    return RAYD_OK;
}

/* Reads one polygon and adds its fan of triangles. */
static enum rayd_status ply_polygon(struct ply *P, const struct ply_prop *q) {
    uint32_t n = 0, first = 0, prev = 0, idx = 0;
    enum rayd_status st = ply_count(P, q->count_type, &n);
    if (st != RAYD_OK) return st;
    if (n < 3)
        return ply_bfail(P, RAYD_E_INVALID, "polygon has %u vertices (at least 3 needed)", n);
    if (P->format != PLY_ASCII && (P->len - P->at) / ply_size[q->type] < n) return ply_truncated(P);
    for (uint32_t k = 0; k < n; k++) {
        st = ply_index(P, q->type, &idx);
        if (st == RAYD_OK && k >= 2) st = ply_triangle(P, first, prev, idx);
        if (st != RAYD_OK) return st;
        if (k == 0) first = idx;
        prev = idx;
    }
    return RAYD_OK;
}

/* One strip index: a vertex, or -1 (*restart) ending the strip. */
static enum rayd_status ply_strip_index(struct ply *P, enum ply_type t, uint32_t *out,
                                        bool *restart) {
    size_t at = P->at;
    double d = 0;
    enum rayd_status st = ply_value(P, t, &d);
    *restart = st == RAYD_OK && d == -1;
    if (st != RAYD_OK || *restart) return st;
    P->at = at; /* read again as an index, for its checks and messages */
    return ply_index(P, t, out);
}

/* Reads one list of triangle strips and adds their triangles. */
static enum rayd_status ply_strips(struct ply *P, const struct ply_prop *q) {
    uint32_t n = 0, v[3] = {0, 0, 0}, idx = 0, k = 0; /* k: indices in the strip so far */
    enum rayd_status st = ply_count(P, q->count_type, &n);
    if (st != RAYD_OK) return st;
    if (P->format != PLY_ASCII && (P->len - P->at) / ply_size[q->type] < n) return ply_truncated(P);
    for (uint32_t i = 0; i < n; i++) {
        bool restart = false;
        st = ply_strip_index(P, q->type, &idx, &restart);
        if (st != RAYD_OK) return st;
        if (restart) {
            k = 0;
            continue;
        }
        v[0] = v[1], v[1] = v[2], v[2] = idx;
        if (++k < 3 || v[0] == v[1] || v[1] == v[2] || v[0] == v[2]) continue;
        st = k % 2 ? ply_triangle(P, v[0], v[1], v[2]) : ply_triangle(P, v[1], v[0], v[2]);
        if (st != RAYD_OK) return st;
    }
    return RAYD_OK;
}

static enum rayd_status ply_face(struct ply *P, const struct ply_elem *e) {
    bool done = false;
    for (size_t k = 0; k < e->nprops; k++) {
        const struct ply_prop *q = &e->props[k];
        bool use = q->role == PLY_INDICES && !done;
        enum rayd_status st = !use                         ? ply_skip(P, q)
                              : e->kind == PLY_ELEM_STRIPS ? ply_strips(P, q)
                                                           : ply_polygon(P, q);
        if (st != RAYD_OK) return st;
        done = done || use;
    }
    return RAYD_OK;
}

/* Skips every record of an element the mesh does not use. */
static enum rayd_status ply_other(struct ply *P, const struct ply_elem *e) {
    bool fixed = P->format != PLY_ASCII;
    if (e->nprops == 0) return RAYD_OK; /* records of nothing take no bytes */
    for (size_t k = 0; k < e->nprops; k++) fixed = fixed && !e->props[k].count_type;
    if (fixed) {
        uint64_t rec = ply_min_record(P, e);
        P->rec = (P->len - P->at) / rec;
        if (P->rec < e->count) return ply_truncated(P);
        P->at += (size_t)(e->count * rec);
        return RAYD_OK;
    }
    for (P->rec = 0; P->rec < e->count; P->rec++)
        for (size_t k = 0; k < e->nprops; k++) {
            enum rayd_status st = ply_skip(P, &e->props[k]);
            if (st != RAYD_OK) return st;
        }
    return RAYD_OK;
}

/* ---- binary records on several threads -------------------------------- */

/* The bytes every record of e takes if its faces are all triangles, or 0
 * when records can differ in size (lists other than the face's indices).
 * *list_at gets where in a record the index list's count is. */
static size_t ply_fixed_record(const struct ply_elem *e, size_t *list_at) {
    size_t n = 0;
    *list_at = SIZE_MAX;
    for (size_t k = 0; k < e->nprops; k++) {
        const struct ply_prop *q = &e->props[k];
        if (q->count_type && q->role != PLY_INDICES) return 0;
        if (q->count_type) *list_at = n;
        n += q->count_type ? ply_size[q->count_type] + 3 * ply_size[q->type] : ply_size[q->type];
    }
    return e->kind == PLY_ELEM_FACE && *list_at == SIZE_MAX ? 0 : n;
}

/* Records [lo, hi) of the element at `at`, each `rec` bytes, read by a
 * copy of the reader positioned on each (err NULL: a failure only sets
 * `failed`, and the caller reads the element again in order for the
 * message).  A face must be a triangle, so that it makes triangle r. */
struct ply_job {
    const struct ply *P;
    const struct ply_elem *e;
    size_t at, rec, list_at;
    int fast; /* PLY_FAST_*: the layout ply_fast_range reads */
    atomic_bool failed;
};

/* The layouts nearly every binary PLY mesh has, read without the general
 * reader's value-by-value decoding: little-endian vertices of exactly
 * float x, y, z, and faces of exactly a list of 8-bit count and 32-bit
 * indices.  The same checks (finite values, three corners, indices in
 * range, the triangle limit); any failure sends the element to the
 * general reader, which gives the message. */
enum { PLY_FAST_NONE, PLY_FAST_XYZ, PLY_FAST_TRI };

static int ply_fast_layout(const struct ply *P, const struct ply_elem *e) {
    const struct ply_prop *q = e->props;
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
    if (P->format != PLY_LE) return PLY_FAST_NONE;
    if (e->kind == PLY_ELEM_VERTEX && e->nprops == 3) {
        for (int k = 0; k < 3; k++)
            if (q[k].type != PLY_F32 || q[k].count_type || q[k].role != (enum ply_role)(PLY_X + k))
                return PLY_FAST_NONE;
        return PLY_FAST_XYZ;
    }
    if (e->kind == PLY_ELEM_FACE && e->nprops == 1 && q->role == PLY_INDICES &&
        (q->count_type == PLY_U8 || q->count_type == PLY_I8) &&
        (q->type == PLY_U32 || (q->type == PLY_I32 && P->nverts <= INT32_MAX)))
        return PLY_FAST_TRI;
#else
    (void)P, (void)e, (void)q;
#endif
    return PLY_FAST_NONE;
}

static bool ply_fast_xyz(const struct ply_job *j, size_t lo, size_t hi) {
    const unsigned char *b = j->P->p + j->at;
    float *pos = j->P->pos;
    for (size_t r = lo; r < hi; r++) {
        float v[3];
        memcpy(v, b + r * j->rec, sizeof v);
        if (!isfinite(v[0]) || !isfinite(v[1]) || !isfinite(v[2])) return false;
        memcpy(pos + 3 * r, v, sizeof v);
    }
    return true;
}

static bool ply_fast_tri(const struct ply_job *j, size_t lo, size_t hi) {
    const unsigned char *b = j->P->p + j->at;
    uint32_t *tri = j->P->tri, nv = j->P->nverts;
    if (hi > j->P->max_tris) return false;
    for (size_t r = lo; r < hi; r++) {
        uint32_t ix[3];
        memcpy(ix, b + r * j->rec + 1, sizeof ix);
        /* an int32 below zero is 2^31 or more as uint32: out of range too
         * (int32 indices take this path only for up to 2^31 vertices) */
        if (b[r * j->rec] != 3 || ix[0] >= nv || ix[1] >= nv || ix[2] >= nv) return false;
        memcpy(tri + 3 * r, ix, sizeof ix);
    }
    return true;
}

static bool ply_record(struct ply *c, const struct ply_job *j, size_t r) {
    uint32_t n = 0;
    if (j->e->kind == PLY_ELEM_VERTEX) return ply_vertex(c, j->e, (uint32_t)r) == RAYD_OK;
    const struct ply_prop *q = j->e->props;
    while (!q->count_type) q++;
    c->at = j->at + r * j->rec + j->list_at;
    if (ply_count(c, q->count_type, &n) != RAYD_OK || n != 3) return false;
    c->at = j->at + r * j->rec;
    c->ntri = r;
    return ply_face(c, j->e) == RAYD_OK;
}

static void ply_records_body(void *ctx, size_t lo, size_t hi) {
    struct ply_job *j = ctx;
    if (j->fast != PLY_FAST_NONE) {
        bool ok = j->fast == PLY_FAST_XYZ ? ply_fast_xyz(j, lo, hi) : ply_fast_tri(j, lo, hi);
        if (!ok) atomic_store(&j->failed, true);
        return;
    }
    struct ply c = *j->P;
    c.err = NULL;
    c.lim = NULL; /* the hook is the loader thread's; the triangles' room is charged already */
    c.cur = j->e;
    for (size_t r = lo; r < hi && !atomic_load_explicit(&j->failed, memory_order_relaxed); r++) {
        c.at = j->at + r * j->rec;
        if (!ply_record(&c, j, r)) atomic_store(&j->failed, true);
    }
}

/* Reads the vertex or face records of e on P->threads threads when the
 * format allows (binary, every record the same size); true when done,
 * false to read them in order instead (any error among them, the serial
 * reader then finds the first and says where it is). */
static bool ply_records(struct ply *P, const struct ply_elem *e) {
    struct ply_job j = {.P = P, .e = e, .at = P->at};
    if (P->format == PLY_ASCII || P->threads == 1 || e->count < 2 || e->kind == PLY_ELEM_STRIPS ||
        (e->kind == PLY_ELEM_FACE && P->ntri != 0)) /* record r makes triangle r */
        return false;
    j.rec = ply_fixed_record(e, &j.list_at);
    if (!j.rec || (P->len - P->at) / j.rec < e->count) return false;
    char why[200]; /* a refusal: the serial reader meets it again and says where */
    if (e->kind == PLY_ELEM_FACE &&
        mesh_grow(P->lim, &P->charged, (void **)&P->tri, &P->cap_tri, (size_t)e->count * 3,
                  sizeof *P->tri, why, sizeof why) != RAYD_OK)
        return false;
    j.fast = ply_fast_layout(P, e);
    atomic_init(&j.failed, false);
    parallel_for((size_t)e->count, P->threads, P->min_chunk, ply_records_body, &j);
    if (atomic_load(&j.failed)) return false;
    P->at += (size_t)e->count * j.rec;
    if (e->kind == PLY_ELEM_FACE) P->ntri = (size_t)e->count;
    return true;
}

static enum rayd_status ply_body(struct ply *P) {
    for (size_t i = 0; i < P->nelems; i++) {
        const struct ply_elem *e = &P->elems[i];
        enum rayd_status st = RAYD_OK;
        P->cur = e;
        if (e->kind == PLY_ELEM_OTHER) {
            st = ply_other(P, e);
        } else if (!ply_records(P, e)) {
            for (P->rec = 0; st == RAYD_OK && P->rec < e->count; P->rec++)
                st = e->kind == PLY_ELEM_VERTEX ? ply_vertex(P, e, (uint32_t)P->rec)
                                                : ply_face(P, e);
        }
        if (st != RAYD_OK) return st;
    }
    return RAYD_OK;
}

/* ---- entry ----------------------------------------------------------------- */

/* Allocates the vertex arrays and a first guess of the triangle array,
 * each charged (sized from the header's counts) before it is allocated. */
static enum rayd_status ply_alloc(struct ply *P) {
    const struct ply_elem *v = &P->elems[P->vertex - 1];
    /* strips: about two triangles a vertex, the usual ratio of a surface */
    uint64_t faces = P->face ? P->elems[P->face - 1].count : 2 * v->count;
    size_t n = (size_t)v->count ? (size_t)v->count : 1;
    P->nverts = (uint32_t)v->count;
    bool normals = v->role_seen[PLY_NX] && v->role_seen[PLY_NY] && v->role_seen[PLY_NZ];
    bool uvs = v->role_seen[PLY_U] && v->role_seen[PLY_V];
    size_t per_vertex = (3 + (normals ? 3 : 0) + (uvs ? 2 : 0)) * sizeof(float);
    char why[200];
    enum rayd_status st = mesh_charge(P->lim, &P->charged, n * per_vertex, why, sizeof why);
    if (st != RAYD_OK) {
        ply_say(P, st, false, "%u vertices: %s", P->nverts, why);
        return st;
    }
    P->pos = huge_alloc(n * 3 * sizeof *P->pos);
    if (normals) P->normal = huge_alloc(n * 3 * sizeof *P->normal);
    if (uvs) P->uv = malloc(n * 2 * sizeof *P->uv);
    if (!P->pos || (normals && !P->normal) || (uvs && !P->uv))
        return ply_hfail(P, RAYD_E_NOMEM, "out of memory for %u vertices", P->nverts);
    /* Room for one triangle per face, up to a million: a face record can
     * be as short as two bytes, so the count alone is a weak bound. */
    size_t guess = faces < (1u << 20) ? (size_t)faces + 1 : (size_t)1 << 20;
    st = mesh_grow(P->lim, &P->charged, (void **)&P->tri, &P->cap_tri, guess * 3, sizeof *P->tri,
                   why, sizeof why);
    if (st != RAYD_OK) ply_say(P, st, false, "%zu triangles: %s", guess, why);
    return st;
}

enum rayd_status mesh_parse_ply(const void *data, size_t len, const struct mesh_limits *lim,
                                struct mesh_data *out, struct rayd_error *err) {
    return mesh_parse_ply_threads(data, len, lim, 1, out, err);
}

enum rayd_status mesh_parse_ply_threads(const void *data, size_t len, const struct mesh_limits *lim,
                                        int threads, struct mesh_data *out,
                                        struct rayd_error *err) {
    struct ply P = {.p = data,
                    .len = len,
                    .max_verts = mesh_max_vertices(lim),
                    .max_tris = mesh_max_triangles(lim),
                    .threads = threads,
                    .min_chunk = threads > 0 ? 1 : MESH_IO_CHUNK,
                    .lim = lim,
                    .err = err};
    const char *enc = text_foreign_encoding(data, len);
    if (enc) /* a PLY header is ASCII even in a binary file */
        return err_set(err, RAYD_E_INVALID, NULL,
                       "the PLY file is %s text; save it as ASCII or binary PLY", enc);
    enum rayd_status st = ply_header(&P);
    if (st == RAYD_OK) st = ply_check_header(&P);
    if (st == RAYD_OK) st = ply_alloc(&P);
    if (st == RAYD_OK) st = ply_body(&P);
    if (st == RAYD_OK && P.ntri == 0)
        st = err_set(err, RAYD_E_INVALID, NULL, "PLY file has no faces");
    if (st == RAYD_OK) {
        uint32_t *tri = realloc(P.tri, P.ntri * 3 * sizeof *tri); /* shrink; may fail */
        if (tri) {
            P.tri = tri;
            mesh_give_back(lim, &P.charged, (P.cap_tri - P.ntri * 3) * sizeof *tri);
        }
        *out = (struct mesh_data){.pos = P.pos,
                                  .normal = P.normal,
                                  .uv = P.uv,
                                  .index = P.tri,
                                  .nverts = P.nverts,
                                  .ntris = (uint32_t)P.ntri,
                                  .charged = P.charged};
        P.pos = P.normal = P.uv = NULL;
        P.tri = NULL;
        P.charged = 0; /* the mesh's now */
    }
    ply_release(&P);
    return st;
}
