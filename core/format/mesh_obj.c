/* mesh_obj.c -- Wavefront OBJ text to an indexed triangle mesh.
 *
 * One pass over the buffer, a line at a time (lines end at '\n'; a '\r'
 * before it is whitespace, so CRLF files read the same).  Lines are never
 * copied: tokens are (pointer, length) slices of the caller's buffer, which
 * need not be NUL-terminated, so a line of any length is read whole.
 *
 * Statements used: `v x y z [w]` (up to 7 numbers, so the common "v x y z r
 * g b" colour extension reads too; only x y z are kept), `vt u [v [w]]`,
 * `vn x y z` and `f` with corners `v`, `v/vt`, `v//vn` or `v/vt/vn`.
 * Indices are 1-based; negative ones count back from the last element
 * defined so far, and both are resolved on the spot against what the file
 * has defined up to that line.  Faces with more than three corners become a
 * fan (0,1,2), (0,2,3), ...  Every other statement (o g s usemtl mtllib l p,
 * unknown ones) and `#` comments are ignored.  Numbers must be finite and
 * fit a float.
 *
 * OBJ indexes positions, texture coordinates and normals separately; a
 * renderer wants one index per corner.  Each distinct (v, vt, vn) triple
 * becomes one output vertex, found through an open-addressing hash table
 * keyed by the triple (linear probing, kept at most half full), so the
 * cost is linear in the number of corners.  The uv and normal arrays are
 * emitted only if every face corner has them; when some corner lacks one,
 * that attribute is dropped and the triples that then coincide are merged
 * again by a second, in-place pass over the distinct triples.
 *
 * Errors name the 1-based line.  Limits are checked as the counts grow:
 * positions, uvs and normals each against max_vertices, output vertices
 * against max_vertices, triangles against max_triangles.
 *
 * mesh_parse_obj_threads reads chunks of lines on several threads (see
 * "several threads" below) and gives the same mesh, or, by reading again
 * in order, the same error.
 *
 * Most files are made of two lines, "v x y z" with plain decimals and
 * "f a b c" with plain position indices.  Those are read by a fast path
 * (obj_fast_line) that parses the numbers in place and finds the line's
 * end as it goes; a line it does not take whole -- another keyword, a
 * comment, an exponent out of the fast range, a slash, a bad token -- is
 * read the general way (cut at its '\n', then into tokens), which also
 * words every error, so the fast path changes no mesh and no message
 * (the unit tests and the fuzz target compare the two on every input).
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

#define OBJ_PARALLEL_BYTES (1u << 20) /* text below which threads are not worth it */

struct obj_key {
    uint32_t v, t, n; /* 1-based into the file's v, vt, vn lists; 0 = absent */
};

/* A hash table slot: the triple itself, so a probe touches one cache line. */
struct obj_entry {
    struct obj_key k;
    uint32_t out; /* output vertex + 1, or 0 for an empty slot */
};

struct obj {
    size_t line; /* 1-based, of the statement being read */
    uint32_t max_verts, max_tris;
    float *v, *vt, *vn; /* 3, 2 and 3 floats per element */
    size_t nv, nt, nn, cap_v, cap_vt, cap_vn;
    struct obj_key *keys; /* output vertex -> its triple */
    size_t nkeys, cap_keys;
    struct obj_entry *table;   /* open addressing, size a power of two */
    size_t table_size, hashed; /* keys with a vt or vn (the table's) */
    uint32_t *vmap;            /* position-only corners: v -> output vertex + 1, 0 = none yet */
    size_t cap_vmap;
    uint32_t *tri; /* 3 output vertices per triangle */
    size_t ntri, cap_tri;
    bool all_t, all_n;
    bool some_tn;            /* some corner has a vt or a vn */
    struct obj_chunk *defer; /* a chunk read on its own thread: faces kept as triples */
    _Atomic uint32_t *first; /* with defer: v -> the first chunk using it (obj_number_positions) */
    const struct mesh_limits *lim; /* its charge hook: the mesh's arrays charged first */
    enum rayd_status refused;      /* the hook's refusal of them (obj_finish) */
    struct rayd_error *err;
};

/* A run of whole lines read by one thread (mesh_parse_obj_threads). */
struct obj_chunk {
    const char *text;
    size_t len;
    size_t nv, nt, nn; /* its v, vt, vn statements; then those before it */
    /* Its corners, 3 a triangle, resolved, in file order: position indices
     * alone (vcorners, 4 bytes a corner, a slice of one block for all the
     * chunks) while every corner is plain, as in most files; triples
     * (corners, 12 bytes) from the first with a vt or vn on.  Triples for
     * all made the decode the 1.3M-triangle OBJ's peak of fresh memory,
     * 154 MB against 124 now: after a pause, when fresh pages are dear
     * (hugemem.c), its decode took 0.37-0.48 s against 0.23-0.34 now and
     * the whole process 0.70-0.83 s against 0.60-0.71. */
    uint32_t *vcorners;
    struct obj_key *corners;
    size_t ncorners, cap_corners;
    bool own_v; /* vcorners outgrew its slice: its own block now */
    bool all_t, all_n, some_tn, failed;
    uint32_t index; /* its place among the chunks */
};

static void obj_say(struct obj *o, enum rayd_status code, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

static void obj_say(struct obj *o, enum rayd_status code, const char *fmt, ...) {
    char msg[224];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    err_set(o->err, code, NULL, "OBJ line %zu: %s", o->line, msg);
}

/* Sets the error at the current line, and is the code (a macro like
 * err_set, for the reason error.h gives). */
#define obj_fail(o, code, ...)                                                                     \
    __extension__({                                                                                \
        obj_say((o), (code), __VA_ARGS__);                                                         \
        (code);                                                                                    \
    })

static enum rayd_status obj_nomem(struct obj *o) {
    return obj_fail(o, RAYD_E_NOMEM, "out of memory");
}

static void obj_release(struct obj *o) {
    free(o->v);
    free(o->vt);
    free(o->vn);
    free(o->keys);
    free(o->table);
    free(o->vmap);
    free(o->tri);
    free(o->first);
}

static bool obj_space(char c) {
    return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

/* The next token of [*p, end) into (*tok, *n); false at the end of the
 * line or at a '#' comment. */
static bool obj_token(const char **p, const char *end, const char **tok, size_t *n) {
    const char *s = *p;
    while (s < end && obj_space(*s)) s++;
    if (s == end || *s == '#') {
        *p = end;
        return false;
    }
    const char *e = s;
    while (e < end && !obj_space(*e)) e++;
    *tok = s;
    *n = (size_t)(e - s);
    *p = e;
    return true;
}

/* Reads between min and max finite float numbers up to the end of the
 * line into vals; *count gets how many. */
static enum rayd_status obj_numbers(struct obj *o, const char *what, const char *p, const char *end,
                                    int min, int max, float *vals, int *count) {
    char q[MESH_QUOTE_SIZE];
    const char *tok;
    size_t n;
    int k = 0;
    while (obj_token(&p, end, &tok, &n)) {
        double d;
        if (k == max)
            return obj_fail(o, RAYD_E_INVALID, "'%s' takes at most %d numbers", what, max);
        if (!mesh_parse_number(tok, n, &d))
            return obj_fail(o, RAYD_E_INVALID, "bad number '%s' in '%s'", mesh_quote(q, tok, n),
                            what);
        if (!isfinite(d) || fabs(d) > FLT_MAX)
            return obj_fail(o, RAYD_E_INVALID, "number '%s' in '%s' is not a finite float",
                            mesh_quote(q, tok, n), what);
        vals[k++] = (float)d;
    }
    if (k < min)
        return obj_fail(o, RAYD_E_INVALID, "'%s' needs %d numbers, found %d", what, min, k);
    *count = k;
    return RAYD_OK;
}

/* Appends one element of `width` floats to a list, checking the limit. */
static enum rayd_status obj_push(struct obj *o, const char *what, float **arr, size_t *n,
                                 size_t *cap, const float *vals, size_t width) {
    if (*n >= o->max_verts)
        return obj_fail(o, RAYD_E_LIMIT, "%zu '%s' lines exceed the limit of %u vertices", *n + 1,
                        what, o->max_verts);
    if (!array_grow((void **)arr, cap, (*n + 1) * width, sizeof **arr)) return obj_nomem(o);
    memcpy(*arr + *n * width, vals, width * sizeof *vals);
    (*n)++;
    return RAYD_OK;
}

static enum rayd_status obj_v(struct obj *o, const char *p, const char *end) {
    float vals[7];
    int k;
    enum rayd_status st = obj_numbers(o, "v", p, end, 3, 7, vals, &k);
    if (st != RAYD_OK) return st;
    return obj_push(o, "v", &o->v, &o->nv, &o->cap_v, vals, 3);
}

static enum rayd_status obj_vt(struct obj *o, const char *p, const char *end) {
    float vals[3] = {0, 0, 0};
    int k;
    enum rayd_status st = obj_numbers(o, "vt", p, end, 1, 3, vals, &k);
    if (st != RAYD_OK) return st;
    return obj_push(o, "vt", &o->vt, &o->nt, &o->cap_vt, vals, 2);
}

static enum rayd_status obj_vn(struct obj *o, const char *p, const char *end) {
    float vals[3];
    int k;
    enum rayd_status st = obj_numbers(o, "vn", p, end, 3, 3, vals, &k);
    if (st != RAYD_OK) return st;
    return obj_push(o, "vn", &o->vn, &o->nn, &o->cap_vn, vals, 3);
}

/* Resolves one index field s[0..n) (1-based or negative) against count
 * elements defined so far; 0 in *out for an empty field. */
static enum rayd_status obj_index(struct obj *o, const char *what, const char *s, size_t n,
                                  size_t count, uint32_t *out) {
    char q[MESH_QUOTE_SIZE];
    *out = 0;
    if (n == 0) return RAYD_OK;
    size_t i = s[0] == '-' ? 1 : 0;
    long long v = 0;
    if (i == n) return obj_fail(o, RAYD_E_INVALID, "bad %s index '-'", what);
    for (; i < n; i++) {
        if (s[i] < '0' || s[i] > '9')
            return obj_fail(o, RAYD_E_INVALID, "bad %s index '%s'", what, mesh_quote(q, s, n));
        if (v < 10000000000LL) v = v * 10 + (s[i] - '0');
    }
    if (s[0] == '-') v = -v;
    if (v == 0)
        return obj_fail(o, RAYD_E_INVALID, "%s index 0 is invalid (OBJ counts from 1)", what);
    if (count == 0)
        return obj_fail(o, RAYD_E_INVALID, "%s index %lld is out of range (none defined yet)", what,
                        v);
    long long c = (long long)count;
    if (v > c)
        return obj_fail(o, RAYD_E_INVALID, "%s index %lld is out of range (1..%lld)", what, v, c);
    if (v < -c)
        return obj_fail(o, RAYD_E_INVALID, "%s index %lld is out of range (-%lld..-1)", what, v, c);
    *out = (uint32_t)(v > 0 ? v : c + v + 1);
    return RAYD_OK;
}

/* Splits a corner "v", "v/vt", "v//vn" or "v/vt/vn" and resolves it. */
static enum rayd_status obj_corner(struct obj *o, const char *s, size_t n, struct obj_key *k) {
    char q[MESH_QUOTE_SIZE];
    const char *part[3] = {s, NULL, NULL};
    size_t plen[3] = {n, 0, 0};
    int parts = 1;
    for (size_t i = 0; i < n; i++) {
        if (s[i] != '/') continue;
        if (parts == 3)
            return obj_fail(o, RAYD_E_INVALID, "bad face vertex '%s'", mesh_quote(q, s, n));
        plen[parts - 1] = (size_t)(s + i - part[parts - 1]);
        part[parts] = s + i + 1;
        plen[parts] = (size_t)(s + n - part[parts]);
        parts++;
    }
    if (plen[0] == 0)
        return obj_fail(o, RAYD_E_INVALID, "bad face vertex '%s' (no position index)",
                        mesh_quote(q, s, n));
    enum rayd_status st = obj_index(o, "face", part[0], plen[0], o->nv, &k->v);
    if (st == RAYD_OK) st = obj_index(o, "texture", part[1], plen[1], o->nt, &k->t);
    if (st == RAYD_OK) st = obj_index(o, "normal", part[2], plen[2], o->nn, &k->n);
    return st;
}

static size_t obj_hash(struct obj_key k, size_t mask) {
    uint64_t h = k.v * UINT64_C(0x9E3779B97F4A7C15) ^ k.t * UINT64_C(0xC2B2AE3D27D4EB4F) ^
                 k.n * UINT64_C(0x165667B19E3779F9);
    h ^= h >> 31;
    h *= UINT64_C(0xBF58476D1CE4E5B9);
    h ^= h >> 29;
    return (size_t)h & mask;
}

static bool obj_same(struct obj_key a, struct obj_key b) {
    return a.v == b.v && a.t == b.t && a.n == b.n;
}

/* The slot holding k, or the empty slot where it belongs. */
static size_t obj_slot(const struct obj *o, struct obj_key k) {
    size_t mask = o->table_size - 1, i = obj_hash(k, mask);
    while (o->table[i].out && !obj_same(o->table[i].k, k)) i = (i + 1) & mask;
    return i;
}

/* Makes the table at least twice the size of `entries`, rehashing the keys
 * it holds (those with a vt or vn). */
static bool obj_table_fit(struct obj *o, size_t entries) {
    if (entries * 2 < o->table_size) return true;
    size_t size = o->table_size ? o->table_size * 2 : 1024;
    while (entries * 2 >= size) size *= 2;
    struct obj_entry *t = calloc(size, sizeof *t);
    if (!t) return false;
    free(o->table);
    o->table = t;
    o->table_size = size;
    for (size_t j = 0; j < o->nkeys; j++)
        if (o->keys[j].t || o->keys[j].n)
            o->table[obj_slot(o, o->keys[j])] = (struct obj_entry){o->keys[j], (uint32_t)(j + 1)};
    return true;
}

/* A new output vertex for triple k (limit checked), numbered in order of
 * first appearance whichever way it was found. */
static enum rayd_status obj_new_vertex(struct obj *o, struct obj_key k, uint32_t *out) {
    if (o->nkeys >= o->max_verts)
        return obj_fail(o, RAYD_E_LIMIT, "%zu vertices exceed the limit of %u", o->nkeys + 1,
                        o->max_verts);
    if (!array_grow((void **)&o->keys, &o->cap_keys, o->nkeys + 1, sizeof *o->keys))
        return obj_nomem(o);
    o->keys[o->nkeys] = k;
    *out = (uint32_t)o->nkeys++;
    return RAYD_OK;
}

/* A corner with a position alone ("f 1 2 3", as most scanned meshes are):
 * its output vertex is kept by position index, no hashing. */
static enum rayd_status obj_vertex_pos(struct obj *o, struct obj_key k, uint32_t *out) {
    if (k.v >= o->cap_vmap) {
        size_t old = o->cap_vmap, need = k.v + 1 > o->nv + 1 ? (size_t)k.v + 1 : o->nv + 1;
        if (!array_grow((void **)&o->vmap, &o->cap_vmap, need, sizeof *o->vmap))
            return obj_nomem(o);
        memset(o->vmap + old, 0, (o->cap_vmap - old) * sizeof *o->vmap);
    }
    if (o->vmap[k.v]) {
        *out = o->vmap[k.v] - 1;
        return RAYD_OK;
    }
    enum rayd_status st = obj_new_vertex(o, k, out);
    if (st == RAYD_OK) o->vmap[k.v] = *out + 1;
    return st;
}

/* The output vertex of triple k, added if new. */
static enum rayd_status obj_vertex(struct obj *o, struct obj_key k, uint32_t *out) {
    if (!k.t && !k.n) return obj_vertex_pos(o, k, out);
    if (!obj_table_fit(o, o->hashed + 1)) return obj_nomem(o);
    size_t i = obj_slot(o, k);
    if (o->table[i].out) {
        *out = o->table[i].out - 1;
        return RAYD_OK;
    }
    enum rayd_status st = obj_new_vertex(o, k, out);
    if (st != RAYD_OK) return st;
    o->table[i] = (struct obj_entry){k, *out + 1};
    o->hashed++;
    return RAYD_OK;
}

static enum rayd_status obj_triangle(struct obj *o, uint32_t a, uint32_t b, uint32_t c) {
    if (o->ntri >= o->max_tris)
        return obj_fail(o, RAYD_E_LIMIT, "%zu triangles exceed the limit of %u", o->ntri + 1,
                        o->max_tris);
    if (!array_grow((void **)&o->tri, &o->cap_tri, (o->ntri + 1) * 3, sizeof *o->tri))
        return obj_nomem(o);
    uint32_t *t = o->tri + o->ntri * 3;
    t[0] = a;
    t[1] = b;
    t[2] = c;
    o->ntri++;
    return RAYD_OK;
}

/* Position v is used by o's chunk: the first chunk to use it is kept (an
 * atomic minimum), for obj_number_positions.  Noted here, while the
 * corner is at hand, rather than in a pass of its own over them all; a
 * file whose faces turn out to have a vt or vn then wasted this (a compare
 * and swap a corner, one word a position). */
static void obj_first_use(struct obj *o, uint32_t v) {
    uint32_t c = o->defer->index, cur = atomic_load_explicit(&o->first[v], memory_order_relaxed);
    while (cur > c && !atomic_compare_exchange_weak_explicit(
                          &o->first[v], &cur, c, memory_order_relaxed, memory_order_relaxed)) {
    }
}

/* Room in ch's plain corners for 3 more: past its slice of the shared
 * block (a polygon's fan makes more triangles than the face lines
 * counted), a block of its own, twice the size. */
static bool obj_room_v(struct obj_chunk *ch) {
    if (ch->ncorners + 3 <= ch->cap_corners) return true;
    size_t cap = ch->cap_corners * 2 + 3;
    uint32_t *v = malloc(sizeof *v * cap);
    if (!v) return false;
    if (ch->ncorners) memcpy(v, ch->vcorners, sizeof *v * ch->ncorners);
    if (ch->own_v) free(ch->vcorners);
    ch->vcorners = v, ch->cap_corners = cap, ch->own_v = true;
    return true;
}

/* ch's corners as triples from now on (the first corner with a vt or vn). */
static bool obj_to_triples(struct obj_chunk *ch) {
    size_t cap = ch->cap_corners > ch->ncorners + 3 ? ch->cap_corners : ch->ncorners + 3;
    struct obj_key *k = huge_alloc(sizeof *k * cap);
    if (!k) return false;
    for (size_t i = 0; i < ch->ncorners; i++) k[i] = (struct obj_key){ch->vcorners[i], 0, 0};
    if (ch->own_v) free(ch->vcorners);
    ch->vcorners = NULL, ch->own_v = false;
    ch->corners = k, ch->cap_corners = cap;
    return true;
}

/* Corner i of ch as a triple. */
static struct obj_key obj_corner_at(const struct obj_chunk *ch, size_t i) {
    return ch->corners ? ch->corners[i] : (struct obj_key){ch->vcorners[i], 0, 0};
}

/* A chunk's triangle as its three triples, numbered later in file order. */
static enum rayd_status obj_defer(struct obj *o, struct obj_key a, struct obj_key b,
                                  struct obj_key c) {
    struct obj_chunk *ch = o->defer;
    /* a chunk alone past the limit: stop before its corners grow without
     * bound (the reading in order then gives the message) */
    if (ch->ncorners / 3 >= o->max_tris)
        return obj_fail(o, RAYD_E_LIMIT, "triangles exceed the limit of %u", o->max_tris);
    if (!ch->corners && !(a.t | a.n | b.t | b.n | c.t | c.n)) {
        if (!obj_room_v(ch)) return obj_nomem(o);
        ch->vcorners[ch->ncorners++] = a.v;
        ch->vcorners[ch->ncorners++] = b.v;
        ch->vcorners[ch->ncorners++] = c.v;
    } else {
        if (!ch->corners && !obj_to_triples(ch)) return obj_nomem(o);
        if (!array_grow((void **)&ch->corners, &ch->cap_corners, ch->ncorners + 3,
                        sizeof *ch->corners))
            return obj_nomem(o);
        ch->corners[ch->ncorners++] = a;
        ch->corners[ch->ncorners++] = b;
        ch->corners[ch->ncorners++] = c;
    }
    obj_first_use(o, a.v), obj_first_use(o, b.v), obj_first_use(o, c.v);
    return RAYD_OK;
}

#define OBJ_PLAIN_MAX 8 /* corners a face may have for obj_plain_corners */

/* The corners of a face line of plain position indices ("f 1 2 3", the
 * faces of most scanned meshes), read in one pass into v: their number,
 * or 0 when the line has anything else (a slash, a sign, an index out of
 * range, more corners), which obj_f's general reading then takes and
 * words the error of.  Splitting every corner into fields instead, the
 * 1.3M-triangle OBJ decoded in 0.151 s against 0.136 (2 threads, median
 * of 15).  With eol, end is the text's end and the line ends at its '\n'
 * (*eol), and a comment leaves the line to the general reading. */
static int obj_plain_corners(const struct obj *o, const char *p, const char *end,
                             uint32_t v[OBJ_PLAIN_MAX], const char **eol) {
    int n = 0;
    for (;;) {
        while (p < end && obj_space(*p)) p++;
        if (p == end || *p == '\n') {
            if (eol) *eol = p;
            return n >= 3 ? n : 0;
        }
        if (*p == '#') return eol ? 0 : n >= 3 ? n : 0;
        const char *digits = p;
        uint64_t x = 0;
        while (p < end && p - digits < 10 && *p >= '0' && *p <= '9')
            x = x * 10 + (uint64_t)(*p++ - '0');
        if (n == OBJ_PLAIN_MAX || p == digits || x == 0 || x > o->nv ||
            (p < end && !obj_space(*p) && *p != '\n'))
            return 0;
        v[n++] = (uint32_t)x;
    }
}

/* A face being read: its corners so far, fanned into triangles as they
 * come. */
struct obj_fan {
    uint32_t first, prev;
    struct obj_key first_k, prev_k;
    int corners;
};

/* Corner k of the face: its output vertex (unless the chunk defers the
 * numbering) and the triangle it closes. */
static enum rayd_status obj_fan_add(struct obj *o, struct obj_fan *f, struct obj_key k) {
    uint32_t idx = 0;
    enum rayd_status st = RAYD_OK;
    if (!o->defer) st = obj_vertex(o, k, &idx);
    if (st == RAYD_OK && f->corners >= 2)
        st = o->defer ? obj_defer(o, f->first_k, f->prev_k, k)
                      : obj_triangle(o, f->first, f->prev, idx);
    if (st != RAYD_OK) return st;
    o->all_t = o->all_t && k.t;
    o->all_n = o->all_n && k.n;
    o->some_tn = o->some_tn || k.t || k.n;
    if (f->corners++ == 0) f->first = idx, f->first_k = k;
    f->prev = idx, f->prev_k = k;
    return RAYD_OK;
}

/* A face of n plain position indices (obj_plain_corners). */
static enum rayd_status obj_f_plain(struct obj *o, const uint32_t *v, int n) {
    struct obj_fan f = {0};
    for (int c = 0; c < n; c++) {
        enum rayd_status st = obj_fan_add(o, &f, (struct obj_key){v[c], 0, 0});
        if (st != RAYD_OK) return st;
    }
    return RAYD_OK;
}

static enum rayd_status obj_f(struct obj *o, const char *p, const char *end) {
    uint32_t plain[OBJ_PLAIN_MAX];
    int nplain = obj_plain_corners(o, p, end, plain, NULL);
    if (nplain) return obj_f_plain(o, plain, nplain);
    struct obj_fan f = {0};
    const char *tok;
    size_t n;
    while (obj_token(&p, end, &tok, &n)) {
        struct obj_key k = {0, 0, 0};
        enum rayd_status st = obj_corner(o, tok, n, &k);
        if (st == RAYD_OK) st = obj_fan_add(o, &f, k);
        if (st != RAYD_OK) return st;
    }
    if (f.corners < 3)
        return obj_fail(o, RAYD_E_INVALID, "face has %d vertices (at least 3 needed)", f.corners);
    return RAYD_OK;
}

/* The numbers of a "v" line after its keyword, from p up to the line's
 * '\n' (*eol) or end: 3 to 7 finite floats in their common form
 * (mesh_scan_number), each followed by a space or the line's end; false
 * for anything else, which obj_v's general reading then words. */
static bool obj_fast_numbers(const char *p, const char *end, float vals[7], int *count,
                             const char **eol) {
    int k = 0;
    for (;;) {
        while (p < end && obj_space(*p)) p++;
        if (p == end || *p == '\n') {
            *eol = p;
            *count = k;
            return k >= 3;
        }
        double d;
        size_t n = k < 7 ? mesh_scan_number(p, end, &d) : 0;
        p += n;
        if (n == 0 || (p < end && !obj_space(*p) && *p != '\n') || !isfinite(d) ||
            fabs(d) > FLT_MAX)
            return false;
        vals[k++] = (float)d;
    }
}

enum obj_kind { OBJ_OTHER, OBJ_V, OBJ_VT, OBJ_VN, OBJ_F };

/* The two common lines at a glance: OBJ_V for "v " and OBJ_F for "f "
 * (or a tab) at p, the keyword first on the line; OBJ_OTHER for anything
 * else, which obj_kind then reads token by token. */
static enum obj_kind obj_kind_glance(const char *p, const char *end) {
    if (end - p < 2 || (p[1] != ' ' && p[1] != '\t')) return OBJ_OTHER;
    return p[0] == 'v' ? OBJ_V : p[0] == 'f' ? OBJ_F : OBJ_OTHER;
}

static atomic_bool obj_fast_on = true;

void mesh_obj_fast_path(bool on) { atomic_store(&obj_fast_on, on); }

/* The two lines most files are made of, read without first finding the
 * line's end: "v" with plain numbers and "f" with plain position indices,
 * the keyword first on the line.  True when it took the line at p (before
 * end), *next then the next line's start and *st what reading it gave;
 * false when the line is anything else, for obj_statement.  Against
 * cutting each line at its '\n' and its numbers into tokens first, the
 * 1.3M-triangle OBJ decoded in 0.094-0.109 s against 0.133-0.160 (2
 * threads, mean of 7 decodes in one process, three alternate runs), and
 * its whole rayd-render process 0.484 -> 0.454 s (median of 11). */
static bool obj_fast_line(struct obj *o, const char *p, const char *end, const char **next,
                          enum rayd_status *st) {
    enum obj_kind kind = obj_kind_glance(p, end);
    if (!atomic_load_explicit(&obj_fast_on, memory_order_relaxed) || kind == OBJ_OTHER)
        return false;
    const char *eol;
    if (kind == OBJ_V) {
        float vals[7];
        int k;
        if (!obj_fast_numbers(p + 2, end, vals, &k, &eol)) return false;
        *st = obj_push(o, "v", &o->v, &o->nv, &o->cap_v, vals, 3);
    } else {
        uint32_t plain[OBJ_PLAIN_MAX];
        int n = obj_plain_corners(o, p + 2, end, plain, &eol);
        if (!n) return false;
        *st = obj_f_plain(o, plain, n);
    }
    *next = eol < end ? eol + 1 : end;
    return true;
}

/* What line [*p, end) states; *p is left after the keyword. */
static enum obj_kind obj_kind(const char **p, const char *end) {
    const char *tok;
    size_t n;
    if (!obj_token(p, end, &tok, &n) || n > 2) return OBJ_OTHER;
    if (tok[0] == 'v' && n == 1) return OBJ_V;
    if (tok[0] == 'v' && tok[1] == 't') return OBJ_VT;
    if (tok[0] == 'v' && tok[1] == 'n') return OBJ_VN;
    if (tok[0] == 'f' && n == 1) return OBJ_F;
    return OBJ_OTHER; /* o g s usemtl mtllib l p and anything unknown */
}

/* obj_kind of the line [p, end), the two common lines at a glance. */
static enum obj_kind obj_kind_quick(const char *p, const char *end) {
    enum obj_kind k = obj_kind_glance(p, end);
    return k != OBJ_OTHER ? k : obj_kind(&p, end);
}

static enum rayd_status obj_statement(struct obj *o, const char *p, const char *end) {
    switch (obj_kind(&p, end)) {
    case OBJ_V: return obj_v(o, p, end);
    case OBJ_VT: return obj_vt(o, p, end);
    case OBJ_VN: return obj_vn(o, p, end);
    case OBJ_F: return obj_f(o, p, end);
    default: return RAYD_OK;
    }
}

/* Reads the line that starts at p (before end): *next gets the next
 * line's start. */
static enum rayd_status obj_line(struct obj *o, const char *p, const char *end, const char **next) {
    enum rayd_status st;
    if (obj_fast_line(o, p, end, next, &st)) return st;
    const char *nl = memchr(p, '\n', (size_t)(end - p)), *eol = nl ? nl : end;
    *next = nl ? nl + 1 : end;
    return obj_statement(o, p, eol);
}

/* Drops the uv or normal part of every triple when some corner lacked it,
 * merges the triples that become equal (in place: the merged list is a
 * prefix of the old one) and renumbers the triangles. */
static enum rayd_status obj_merge(struct obj *o) {
    bool changed = false;
    for (size_t j = 0; j < o->nkeys; j++) {
        if (!o->all_t && o->keys[j].t) changed = true, o->keys[j].t = 0;
        if (!o->all_n && o->keys[j].n) changed = true, o->keys[j].n = 0;
    }
    if (!changed) return RAYD_OK;
    /* every key goes into the table now, not only those that had a vt or
     * vn: it must have room for all of them, or obj_slot finds no free slot */
    uint32_t *remap = malloc(o->nkeys * sizeof *remap);
    if (!remap || !obj_table_fit(o, o->nkeys)) {
        free(remap);
        return obj_nomem(o);
    }
    memset(o->table, 0, o->table_size * sizeof *o->table);
    size_t m = 0;
    for (size_t j = 0; j < o->nkeys; j++) {
        size_t i = obj_slot(o, o->keys[j]);
        if (!o->table[i].out) {
            o->keys[m] = o->keys[j];
            o->table[i] = (struct obj_entry){o->keys[j], (uint32_t)++m};
        }
        remap[j] = o->table[i].out - 1;
    }
    for (size_t j = 0; j < o->ntri * 3; j++) o->tri[j] = remap[o->tri[j]];
    free(remap);
    o->nkeys = m;
    return RAYD_OK;
}

/* Gathers per-vertex arrays from the triples into *out. */
static enum rayd_status obj_finish(struct obj *o, struct mesh_data *out) {
    if (o->ntri == 0) return err_set(o->err, RAYD_E_INVALID, NULL, "OBJ has no faces ('f' lines)");
    enum rayd_status st = obj_merge(o);
    if (st != RAYD_OK) return st;
    size_t nv = o->nkeys;
    if (nv == 0) /* never with faces (a corner is a vertex); no allocation of 0 bytes below */
        return err_set(o->err, RAYD_E_INVALID, NULL, "OBJ has no faces ('f' lines)");
    /* the mesh's arrays charged before the per-vertex ones are allocated
     * (the triangles' exists: it is charged here with them) */
    size_t per_vertex = (3 + (o->all_n ? 3 : 0) + (o->all_t ? 2 : 0)) * sizeof(float);
    struct mesh_data m = {0};
    char why[200];
    st = mesh_charge(o->lim, &m.charged, nv * per_vertex + o->ntri * 3 * sizeof *o->tri, why,
                     sizeof why);
    if ((o->refused = st) != RAYD_OK)
        return err_set(o->err, st, NULL, "OBJ of %zu vertices and %zu triangles: %s", nv, o->ntri,
                       why);
    m.pos = huge_alloc(nv * 3 * sizeof *m.pos);
    if (o->all_n) m.normal = huge_alloc(nv * 3 * sizeof *m.normal);
    if (o->all_t) m.uv = malloc(nv * 2 * sizeof *m.uv);
    if (!m.pos || (o->all_n && !m.normal) || (o->all_t && !m.uv)) {
        mesh_give_back(o->lim, &m.charged, m.charged);
        mesh_data_free(&m);
        return obj_nomem(o);
    }
    for (size_t j = 0; j < nv; j++) {
        struct obj_key k = o->keys[j];
        memcpy(m.pos + j * 3, o->v + (size_t)(k.v - 1) * 3, 3 * sizeof *m.pos);
        if (m.normal) memcpy(m.normal + j * 3, o->vn + (size_t)(k.n - 1) * 3, 3 * sizeof *m.pos);
        if (m.uv) memcpy(m.uv + j * 2, o->vt + (size_t)(k.t - 1) * 2, 2 * sizeof *m.pos);
    }
    uint32_t *tri = realloc(o->tri, o->ntri * 3 * sizeof *tri); /* shrink; may fail */
    if (tri) o->tri = tri;
    m.index = o->tri;
    o->tri = NULL;
    m.nverts = (uint32_t)nv;
    m.ntris = (uint32_t)o->ntri;
    *out = m; /* charged for exactly its arrays */
    return RAYD_OK;
}

/* Reads text[0..len) line by line in order: the decoder itself, and the
 * one that finds and words every error. */
static enum rayd_status obj_serial(const char *text, size_t len, const struct mesh_limits *lim,
                                   struct mesh_data *out, struct rayd_error *err) {
    struct obj o = {.max_verts = mesh_max_vertices(lim),
                    .max_tris = mesh_max_triangles(lim),
                    .all_t = true,
                    .all_n = true,
                    .lim = lim,
                    .err = err};
    enum rayd_status st = RAYD_OK;
    if (!obj_table_fit(&o, 0)) st = obj_nomem(&o);
    const char *p = text, *end = text + len;
    while (st == RAYD_OK && p < end) {
        o.line++;
        st = obj_line(&o, p, end, &p);
    }
    if (st == RAYD_OK) st = obj_finish(&o, out);
    obj_release(&o);
    return st;
}

/* ---- several threads ---------------------------------------------------------
 *
 * The text is cut at line ends into chunks.  A first pass counts each
 * chunk's v, vt and vn statements; their prefix sums tell each chunk how
 * many of each the file defines before it, so a second pass reads every
 * chunk on its own with indices resolved exactly as reading in order would
 * (positions straight into the shared arrays, each chunk at its offset).
 * Faces are kept as triples; numbering the output vertices by first
 * appearance is a last pass in file order, on one thread, or on every
 * thread when no corner has a vt or vn (obj_number_positions).  Any error, or
 * any limit reached, and the whole text is read again in order, so
 * messages and their line numbers are those of obj_serial. */

struct obj_par {
    struct obj_chunk *chunks;
    size_t nchunks;
    uint32_t *vblock;  /* the chunks' vcorners slices, one block on huge pages */
    struct obj shared; /* the v, vt, vn arrays, and the limits */
};

/* Both passes work on a copy of their chunk, written back at the end:
 * neighbouring chunks share cache lines, which the threads would
 * otherwise pass back and forth at every line. */
static void obj_count_body(void *ctx, size_t lo, size_t hi) {
    struct obj_par *j = ctx;
    for (size_t c = lo; c < hi; c++) {
        struct obj_chunk ch = j->chunks[c];
        const char *p = ch.text, *stop = ch.text + ch.len;
        size_t nf = 0;
        while (p < stop) {
            const char *nl = memchr(p, '\n', (size_t)(stop - p)), *end = nl ? nl : stop;
            enum obj_kind k = obj_kind_quick(p, end);
            ch.nv += k == OBJ_V, ch.nt += k == OBJ_VT, ch.nn += k == OBJ_VN, nf += k == OBJ_F;
            p = end + 1;
        }
        ch.cap_corners = 3 * nf; /* room for triangles; polygons grow it */
        j->chunks[c] = ch;
    }
}

static void obj_read_body(void *ctx, size_t lo, size_t hi) {
    struct obj_par *j = ctx;
    for (size_t c = lo; c < hi; c++) {
        struct obj_chunk ch = j->chunks[c];
        struct obj o = j->shared;
        o.nv = ch.nv, o.nt = ch.nt, o.nn = ch.nn;
        o.all_t = o.all_n = true;
        o.defer = &ch;
        const char *p = ch.text, *stop = ch.text + ch.len;
        while (p < stop && !ch.failed) ch.failed = obj_line(&o, p, stop, &p) != RAYD_OK;
        ch.all_t = o.all_t, ch.all_n = o.all_n, ch.some_tn = o.some_tn;
        j->chunks[c] = ch;
    }
}

/* Cuts text into n chunks of whole lines. */
static void obj_cut(struct obj_par *j, const char *text, size_t len) {
    size_t at = 0;
    for (size_t c = 0; c < j->nchunks; c++) {
        size_t end = c + 1 == j->nchunks ? len : len / j->nchunks * (c + 1);
        if (end < at) end = at;
        const char *nl = end < len ? memchr(text + end, '\n', len - end) : NULL;
        end = nl ? (size_t)(nl - text) + 1 : len;
        j->chunks[c] = (struct obj_chunk){.text = text + at, .len = end - at, .index = (uint32_t)c};
        at = end;
    }
}

/* The shared v, vt, vn arrays, each chunk told what comes before it. */
static bool obj_bases(struct obj_par *j) {
    struct obj *o = &j->shared;
    for (size_t c = 0; c < j->nchunks; c++) {
        struct obj_chunk *ch = &j->chunks[c];
        size_t v = ch->nv, t = ch->nt, n = ch->nn;
        ch->nv = o->nv, ch->nt = o->nt, ch->nn = o->nn;
        o->nv += v, o->nt += t, o->nn += n;
    }
    size_t faces = 0; /* each face line makes a triangle at least */
    for (size_t c = 0; c < j->nchunks; c++) faces += j->chunks[c].cap_corners / 3;
    if (o->nv > o->max_verts || o->nt > o->max_verts || o->nn > o->max_verts || faces > o->max_tris)
        return false;
    o->cap_v = o->nv * 3 + 3, o->cap_vt = o->nt * 2 + 2, o->cap_vn = o->nn * 3 + 3;
    o->v = huge_alloc(o->cap_v * sizeof *o->v);
    o->vt = malloc(o->cap_vt * sizeof *o->vt);
    o->vn = malloc(o->cap_vn * sizeof *o->vn);
    o->first = huge_alloc(sizeof *o->first * (o->nv + 1));
    if (o->first) memset(o->first, 0xff, sizeof *o->first * (o->nv + 1)); /* before the threads */
    /* one block for every chunk's plain corners: big enough for huge pages
     * (hugemem.c); a block for each chunk was too small for them and
     * faulted 4 KiB pages */
    j->vblock = huge_alloc(sizeof *j->vblock * (3 * faces + 1));
    for (size_t c = 0, at = 0; j->vblock && c < j->nchunks; c++) {
        j->chunks[c].vcorners = j->vblock + at;
        at += j->chunks[c].cap_corners;
    }
    return o->v && o->vt && o->vn && o->first && j->vblock;
}

/* Numbers the output vertices and makes the triangles, in file order. */
static bool obj_number(struct obj_par *j) {
    struct obj *o = &j->shared;
    size_t tris = 0;
    for (size_t c = 0; c < j->nchunks; c++) tris += j->chunks[c].ncorners / 3;
    o->cap_tri = tris * 3 + 3;
    o->tri = huge_alloc(o->cap_tri * sizeof *o->tri);
    if (tris > o->max_tris || !obj_table_fit(o, 0) || !o->tri) return false;
    for (size_t c = 0; c < j->nchunks; c++) {
        const struct obj_chunk *ch = &j->chunks[c];
        o->all_t = o->all_t && ch->all_t, o->all_n = o->all_n && ch->all_n;
        for (size_t i = 0; i < ch->ncorners; i += 3) {
            uint32_t x[3];
            for (int k = 0; k < 3; k++)
                if (obj_vertex(o, obj_corner_at(ch, i + (size_t)k), &x[k]) != RAYD_OK) return false;
            if (obj_triangle(o, x[0], x[1], x[2]) != RAYD_OK) return false;
        }
    }
    return true;
}

/* Numbering when no corner has a vt or a vn (most scanned meshes), on
 * every thread, to the same numbers as obj_number's first appearance in
 * file order: a vertex belongs to the first chunk that uses it (an atomic
 * minimum, first[v]); each chunk numbers its own vertices in its order;
 * a prefix sum over the chunks makes those numbers global; then every
 * chunk writes its triangles.  Done in file order on one thread, this pass
 * and the gather after it were a third of the 1.3M-triangle OBJ's decode. */
struct obj_num {
    struct obj_par *j;
    _Atomic uint32_t *first; /* the shared obj's: UINT32_MAX for a position no face uses */
    uint32_t *num;           /* v -> its number + 1 in its chunk, then in the mesh */
    size_t *base, *tri_base; /* a chunk's first vertex and first triangle */
};

static void num_local_body(void *ctx, size_t lo, size_t hi) {
    struct obj_num *u = ctx;
    for (size_t c = lo; c < hi; c++) {
        const struct obj_chunk *ch = &u->j->chunks[c];
        uint32_t n = 0;
        for (size_t i = 0; i < ch->ncorners; i++) {
            uint32_t v = ch->vcorners[i];
            if (atomic_load_explicit(&u->first[v], memory_order_relaxed) == c && !u->num[v])
                u->num[v] = ++n;
        }
        u->base[c] = n;
    }
}

static void num_global_body(void *ctx, size_t lo, size_t hi) {
    struct obj_num *u = ctx;
    struct obj *o = &u->j->shared;
    for (size_t v = lo + 1; v <= hi; v++) {
        uint32_t c = atomic_load_explicit(&u->first[v], memory_order_relaxed);
        if (c == UINT32_MAX) continue;
        u->num[v] += (uint32_t)u->base[c];
        o->keys[u->num[v] - 1] = (struct obj_key){(uint32_t)v, 0, 0};
    }
}

static void num_tris_body(void *ctx, size_t lo, size_t hi) {
    struct obj_num *u = ctx;
    for (size_t c = lo; c < hi; c++) {
        const struct obj_chunk *ch = &u->j->chunks[c];
        uint32_t *t = u->j->shared.tri + 3 * u->tri_base[c];
        for (size_t i = 0; i < ch->ncorners; i++) t[i] = u->num[ch->vcorners[i]] - 1;
    }
}

static bool obj_number_positions(struct obj_par *j, int threads) {
    if (j->nchunks == 0) return false; /* never (4 a thread); no calloc of 0 below */
    struct obj *o = &j->shared;
    struct obj_num u = {j, o->first, huge_calloc(o->nv + 1, sizeof *u.num),
                        calloc(j->nchunks, sizeof(size_t)), calloc(j->nchunks, sizeof(size_t))};
    size_t verts = 0, tris = 0;
    bool ok = u.first && u.num && u.base && u.tri_base;
    if (ok) {
        parallel_for(j->nchunks, threads, 1, num_local_body, &u);
        for (size_t c = 0; c < j->nchunks; c++) {
            size_t n = u.base[c];
            u.base[c] = verts, u.tri_base[c] = tris;
            verts += n, tris += j->chunks[c].ncorners / 3;
            o->all_t = o->all_t && j->chunks[c].all_t, o->all_n = o->all_n && j->chunks[c].all_n;
        }
        o->cap_keys = verts ? verts : 1, o->cap_tri = 3 * tris + 3;
        o->keys = huge_alloc(sizeof *o->keys * o->cap_keys);
        o->tri = huge_alloc(sizeof *o->tri * o->cap_tri);
        ok = verts <= o->max_verts && tris <= o->max_tris && o->keys && o->tri;
    }
    if (ok) {
        parallel_for(o->nv, threads, MESH_IO_CHUNK, num_global_body, &u);
        parallel_for(j->nchunks, threads, 1, num_tris_body, &u);
        o->nkeys = verts, o->ntri = tris;
    }
    free(u.num);
    free(u.base);
    free(u.tri_base);
    return ok;
}

static bool obj_positions_only(const struct obj_par *j) {
    for (size_t c = 0; c < j->nchunks; c++)
        if (j->chunks[c].some_tn) return false;
    return true;
}

/* The threaded decoder; false when it gives up (the caller then reads in
 * order, which finds the error, or decodes what this could not), except
 * that the caller's refusal of the mesh's charge is final (*refused, its
 * message in err: the file need not be read again to be refused). */
static bool obj_parallel(const char *text, size_t len, const struct mesh_limits *lim, int threads,
                         struct mesh_data *out, struct rayd_error *err, enum rayd_status *refused) {
    struct obj_par j = {.nchunks = 4 * (size_t)threads};
    j.shared = (struct obj){.max_verts = mesh_max_vertices(lim),
                            .max_tris = mesh_max_triangles(lim),
                            .all_t = true,
                            .all_n = true,
                            .lim = lim};
    j.chunks = calloc(j.nchunks, sizeof *j.chunks);
    bool ok = j.chunks != NULL;
    if (ok) {
        obj_cut(&j, text, len);
        parallel_for(j.nchunks, threads, 1, obj_count_body, &j);
        ok = obj_bases(&j);
    }
    if (ok) parallel_for(j.nchunks, threads, 1, obj_read_body, &j);
    for (size_t c = 0; ok && c < j.nchunks; c++) ok = !j.chunks[c].failed;
    ok = ok && (obj_positions_only(&j) ? obj_number_positions(&j, threads) : obj_number(&j));
    j.shared.err = err; /* obj_finish's message; the serial reader's replaces any but a refusal */
    ok = ok && obj_finish(&j.shared, out) == RAYD_OK;
    *refused = j.shared.refused;
    for (size_t c = 0; j.chunks && c < j.nchunks; c++) {
        free(j.chunks[c].corners);
        if (j.chunks[c].own_v) free(j.chunks[c].vcorners);
    }
    free(j.vblock);
    free(j.chunks);
    obj_release(&j.shared);
    return ok;
}

enum rayd_status mesh_parse_obj_threads(const char *text, size_t len, const struct mesh_limits *lim,
                                        int threads, struct mesh_data *out,
                                        struct rayd_error *err) {
    const char *enc = text_foreign_encoding(text, len);
    if (enc)
        return err_set(err, RAYD_E_INVALID, NULL,
                       "the OBJ file is %s text; save it as UTF-8 (or ASCII)", enc);
    if (text_lone_cr(text, len)) /* lines end at '\n' here */
        return err_set(err, RAYD_E_INVALID, NULL, "OBJ line 1: %s", TEXT_LONE_CR);
    if (threads <= 0) threads = len >= OBJ_PARALLEL_BYTES ? parallel_cores() : 1;
    enum rayd_status refused = RAYD_OK;
    if (threads > 1 && obj_parallel(text, len, lim, threads, out, err, &refused)) return RAYD_OK;
    if (refused != RAYD_OK) return refused;
    return obj_serial(text, len, lim, out, err);
}

enum rayd_status mesh_parse_obj(const char *text, size_t len, const struct mesh_limits *lim,
                                struct mesh_data *out, struct rayd_error *err) {
    return mesh_parse_obj_threads(text, len, lim, 1, out, err);
}
