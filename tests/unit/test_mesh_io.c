/* test_mesh_io.c -- OBJ and PLY mesh decoders, base64.
 *
 * Every input is copied into a malloc'd buffer of exactly its length (no
 * NUL after it), so under ASan a decoder reading one byte too far fails.
 * Binary PLY files are built byte by byte here, in both byte orders.
 */
#include <dirent.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "format/base64.h"
#include "check.h"
#include "format/mesh_io.h"

/* ---- helpers ----------------------------------------------------------- */

static bool same_floats(const float *a, const float *b, size_t n) {
    return (!a && !b) || (a && b && !memcmp(a, b, n * sizeof *a));
}

/* Decodes data with 2, 3 and 8 threads too and checks that every count
 * gives what one thread gave: the same status and message, or the same
 * mesh (the threaded decoders must be invisible).  An OBJ is read once
 * more with the fast path for plain lines off (mesh_obj_fast_path), which
 * must be invisible too: threads 0 below. */
static void same_on_threads(bool is_obj, const void *data, size_t len,
                            const struct mesh_limits *lim, enum rayd_status st,
                            const struct mesh_data *m, const struct rayd_error *e) {
    static const int threads[] = {2, 3, 8, 0};
    for (size_t k = 0; k < sizeof threads / sizeof threads[0] - !is_obj; k++) {
        struct mesh_data t = {0};
        struct rayd_error te = {0};
        mesh_obj_fast_path(threads[k] != 0);
        enum rayd_status ts =
            is_obj ? mesh_parse_obj_threads(data, len, lim, threads[k] ? threads[k] : 1, &t, &te)
                   : mesh_parse_ply_threads(data, len, lim, threads[k], &t, &te);
        mesh_obj_fast_path(true);
        bool same = ts == st;
        if (same && st != RAYD_OK) same = e && !strcmp(te.message, e->message);
        if (same && st == RAYD_OK)
            same = t.nverts == m->nverts && t.ntris == m->ntris &&
                   same_floats(t.pos, m->pos, 3 * (size_t)m->nverts) &&
                   same_floats(t.normal, m->normal, 3 * (size_t)m->nverts) &&
                   same_floats(t.uv, m->uv, 2 * (size_t)m->nverts) &&
                   !memcmp(t.index, m->index, sizeof *t.index * 3 * m->ntris);
        CHECK(same, "%s on %d threads: status %d '%s', one thread: %d '%s'", is_obj ? "OBJ" : "PLY",
              threads[k], (int)ts, te.message, (int)st, e ? e->message : "");
        if (ts == RAYD_OK) mesh_data_free(&t);
    }
}

static enum rayd_status obj_n(const char *text, size_t len, const struct mesh_limits *lim,
                              struct mesh_data *m, struct rayd_error *e) {
    char *copy = malloc(len ? len : 1);
    memcpy(copy, text, len);
    enum rayd_status st = mesh_parse_obj(copy, len, lim, m, e);
    same_on_threads(true, copy, len, lim, st, m, e);
    free(copy);
    return st;
}

static enum rayd_status obj(const char *text, struct mesh_data *m, struct rayd_error *e) {
    return obj_n(text, strlen(text), NULL, m, e);
}

static enum rayd_status ply_n(const void *data, size_t len, const struct mesh_limits *lim,
                              struct mesh_data *m, struct rayd_error *e) {
    void *copy = malloc(len ? len : 1);
    memcpy(copy, data, len);
    enum rayd_status st = mesh_parse_ply(copy, len, lim, m, e);
    same_on_threads(false, copy, len, lim, st, m, e);
    free(copy);
    return st;
}

static enum rayd_status ply(const char *text, struct mesh_data *m, struct rayd_error *e) {
    return ply_n(text, strlen(text), NULL, m, e);
}

/* Expects failure with `code` and a message containing `want`; checks
 * that *m was not written. */
#define CHECK_FAILS(call, code, want)                                                              \
    do {                                                                                           \
        struct mesh_data m_ = {0};                                                                 \
        struct rayd_error e_ = {0};                                                                \
        enum rayd_status st_ = call(&m_, &e_);                                                     \
        CHECK(st_ == (code), "status %d, want %d (%s)", (int)st_, (int)(code), e_.message);        \
        CHECK(strstr(e_.message, want) != NULL, "message '%s' lacks '%s'", e_.message, want);      \
        CHECK(m_.pos == NULL && m_.index == NULL && m_.nverts == 0, "out written on error");       \
        mesh_data_free(&m_);                                                                       \
    } while (0)

static bool tri_is(const struct mesh_data *m, uint32_t t, uint32_t a, uint32_t b, uint32_t c) {
    return m->index && t < m->ntris && m->index[t * 3] == a && m->index[t * 3 + 1] == b &&
           m->index[t * 3 + 2] == c;
}

static bool pos_is(const struct mesh_data *m, uint32_t v, float x, float y, float z) {
    return m->pos && v < m->nverts && m->pos[v * 3] == x && m->pos[v * 3 + 1] == y &&
           m->pos[v * 3 + 2] == z;
}

/* The position of corner k of triangle t. */
static const float *corner_pos(const struct mesh_data *m, uint32_t t, int k) {
    return m->pos + (size_t)m->index[t * 3 + (uint32_t)k] * 3;
}

static void check_indices_in_range(const struct mesh_data *m) {
    for (uint32_t i = 0; i < m->ntris * 3; i++)
        if (m->index[i] >= m->nverts) {
            CHECK(0, "index %u = %u >= nverts %u", i, m->index[i], m->nverts);
            return;
        }
}

/* ---- numbers ----------------------------------------------------------- */

static double num(const char *s, bool *ok) {
    double d = -12345;
    *ok = mesh_parse_number(s, strlen(s), &d);
    return d;
}

static void test_number_parser(void) {
    static const char *good[] = {"0",
                                 "-0",
                                 "1",
                                 "+7",
                                 "0.1",
                                 "-2.5",
                                 ".5",
                                 "5.",
                                 "1e3",
                                 "1E-3",
                                 "-2.5E+2",
                                 "3.14159265358979",
                                 "123456789012345678901234",
                                 "1e-300",
                                 "0.000000000000000000000000001",
                                 "1.7976931348623157e308",
                                 "0x1p3",
                                 "nan",
                                 "inf",
                                 "-infinity"};
    for (size_t i = 0; i < sizeof good / sizeof good[0]; i++) {
        bool ok;
        double d = num(good[i], &ok);
        double want = strtod(good[i], NULL);
        CHECK(ok, "'%s' rejected", good[i]);
        CHECK((isnan(d) && isnan(want)) || d == want, "'%s' -> %.17g, strtod %.17g", good[i], d,
              want);
    }
    static const char *bad[] = {"",      "-",  "+",   ".",  "e5", "1e", "1e+",
                                "1.2.3", "1x", "--1", " 1", "1 ", "1,5"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        bool ok;
        num(bad[i], &ok);
        CHECK(!ok, "'%s' accepted", bad[i]);
    }
    /* Bounded: "12" inside "123" parses as 12, never reading the 3. */
    double d = 0;
    CHECK(mesh_parse_number("123", 2, &d) && d == 12, "prefix: %g", d);
    /* Correctly rounded over many fast-path values. */
    char buf[64];
    int wrong = 0;
    for (int i = 0; i < 20000; i++) {
        snprintf(buf, sizeof buf, "%d.%06d", i * 37 - 5000, (i * 7919) % 1000000);
        if (!mesh_parse_number(buf, strlen(buf), &d) || d != strtod(buf, NULL)) wrong++;
    }
    CHECK(wrong == 0, "%d numbers differ from strtod", wrong);
}

/* ---- OBJ --------------------------------------------------------------- */

static const char *obj_square_v = "v 0 0 0\n"
                                  "v 1 0 0\n"
                                  "v 1 1 0\n"
                                  "v 0 1 0\n";

static void test_obj_plain_faces(void) {
    struct mesh_data m = {0};
    struct rayd_error e = {0};
    char text[512];
    snprintf(text, sizeof text, "%sf 1 2 3\nf 1 3 4\n", obj_square_v);
    CHECK(obj(text, &m, &e) == RAYD_OK, "%s", e.message);
    CHECK(m.nverts == 4 && m.ntris == 2, "%u verts %u tris", m.nverts, m.ntris);
    CHECK(m.normal == NULL && m.uv == NULL, "no attributes");
    CHECK(tri_is(&m, 0, 0, 1, 2) && tri_is(&m, 1, 0, 2, 3), "indices");
    CHECK(pos_is(&m, 0, 0, 0, 0) && pos_is(&m, 2, 1, 1, 0) && pos_is(&m, 3, 0, 1, 0), "positions");
    mesh_data_free(&m);
    CHECK(m.pos == NULL && m.ntris == 0, "free zeroes");
    mesh_data_free(&m);
    mesh_data_free(NULL);
}

/* Faces of plain indices take a shorter road (obj_plain_corners); at its
 * edges -- leading zeros, a comment, CR, tabs, more corners than it takes,
 * an index glued to a comment or out of range -- the mesh or the error is
 * the general reading's. */
static void test_obj_plain_face_edges(void) {
    struct mesh_data m = {0};
    struct rayd_error e = {0};
    char text[1024];
    snprintf(text, sizeof text,
             "%sv 2 0 0\nv 2 1 0\nv 3 0 0\nv 3 1 0\nv 4 0 0\n"
             "f 001 2 3 # a comment\nf\t1 3\t4\r\nf 1 2 3 4 5 6 7 8 9\n",
             obj_square_v);
    CHECK(obj(text, &m, &e) == RAYD_OK && m.ntris == 1 + 1 + 7 && m.nverts == 9, "%s (%u tris)",
          e.message, m.ntris);
    CHECK(tri_is(&m, 0, 0, 1, 2) && tri_is(&m, 1, 0, 2, 3) && tri_is(&m, 8, 0, 7, 8),
          "fan indices");
    mesh_data_free(&m);
    snprintf(text, sizeof text, "%sf 1 2 3#x\n", obj_square_v);
    CHECK(obj(text, &m, &e) == RAYD_E_INVALID && strstr(e.message, "line 5: bad face index '3#x'"),
          "%s", e.message);
    snprintf(text, sizeof text, "%sf 1 2 5\n", obj_square_v);
    CHECK(obj(text, &m, &e) == RAYD_E_INVALID &&
              strstr(e.message, "line 5: face index 5 is out of range (1..4)"),
          "%s", e.message);
    snprintf(text, sizeof text, "%sf 1 2 99999999999\n", obj_square_v);
    CHECK(obj(text, &m, &e) == RAYD_E_INVALID &&
              strstr(e.message, "face index 99999999999 is out of range"),
          "%s", e.message);
}

static void test_obj_face_forms(void) {
    struct mesh_data m = {0};
    struct rayd_error e = {0};
    char text[512];
    /* v/vt */
    snprintf(text, sizeof text, "%svt 0 0\nvt 1 0\nvt 1 1\nf 1/1 2/2 3/3\n", obj_square_v);
    CHECK(obj(text, &m, &e) == RAYD_OK, "%s", e.message);
    CHECK(m.uv && !m.normal && m.nverts == 3, "v/vt: uv %p normal %p", (void *)m.uv,
          (void *)m.normal);
    if (m.uv) CHECK(m.uv[2] == 1 && m.uv[3] == 0 && m.uv[4] == 1 && m.uv[5] == 1, "uv values");
    mesh_data_free(&m);
    /* v//vn */
    snprintf(text, sizeof text, "%svn 0 0 1\nf 1//1 2//1 3//1\n", obj_square_v);
    CHECK(obj(text, &m, &e) == RAYD_OK, "%s", e.message);
    CHECK(m.normal && !m.uv, "v//vn");
    if (m.normal) CHECK(m.normal[0] == 0 && m.normal[2] == 1 && m.normal[8] == 1, "normal values");
    mesh_data_free(&m);
    /* v/vt/vn, and vt with one or three numbers */
    snprintf(text, sizeof text, "%svt 0.5\nvt 0.25 0.75 0\nvn 0 1 0\nf 1/1/1 2/2/1 3/1/1\n",
             obj_square_v);
    CHECK(obj(text, &m, &e) == RAYD_OK, "%s", e.message);
    CHECK(m.normal && m.uv && m.nverts == 3, "v/vt/vn");
    if (m.uv) CHECK(m.uv[0] == 0.5f && m.uv[1] == 0 && m.uv[2] == 0.25f && m.uv[3] == 0.75f, "uv");
    if (m.normal) CHECK(m.normal[1] == 1 && m.normal[7] == 1, "normal");
    mesh_data_free(&m);
    /* v with w, and with vertex colours */
    CHECK(obj("v 0 0 0 1\nv 1 0 0 0.5 0.5 0.5\nv 0 1 0 1 1 1 1\nf 1 2 3\n", &m, &e) == RAYD_OK,
          "%s", e.message);
    CHECK(m.nverts == 3 && pos_is(&m, 1, 1, 0, 0), "v x y z w / colours");
    mesh_data_free(&m);
}

static void test_obj_negative_indices(void) {
    struct mesh_data m = {0};
    struct rayd_error e = {0};
    const char *text = "v 9 9 9\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf -3//-1 -2//-1 -1//-1\n"
                       "v 5 5 5\nf -4 -3 -1\n";
    CHECK(obj(text, &m, &e) == RAYD_OK, "%s", e.message);
    CHECK(m.ntris == 2, "%u tris", m.ntris);
    if (m.ntris == 2) {
        const float *a = corner_pos(&m, 0, 0), *c = corner_pos(&m, 0, 2);
        CHECK(a[0] == 0 && a[1] == 0 && c[0] == 0 && c[1] == 1, "first face = v2 v3 v4");
        const float *d = corner_pos(&m, 1, 2);
        CHECK(d[0] == 5 && d[1] == 5, "relative to the count at that line");
    }
    CHECK(m.normal == NULL, "second face has no normals");
    mesh_data_free(&m);
}

static void test_obj_polygons_fan(void) {
    struct mesh_data m = {0};
    struct rayd_error e = {0};
    char text[512];
    snprintf(text, sizeof text, "%sv 0.5 2 0\nf 1 2 3 4 5\n", obj_square_v);
    CHECK(obj(text, &m, &e) == RAYD_OK, "%s", e.message);
    CHECK(m.ntris == 3 && m.nverts == 5, "pentagon: %u tris", m.ntris);
    CHECK(tri_is(&m, 0, 0, 1, 2) && tri_is(&m, 1, 0, 2, 3) && tri_is(&m, 2, 0, 3, 4), "fan");
    mesh_data_free(&m);
    snprintf(text, sizeof text, "%sf 1 2 3 4\n", obj_square_v);
    CHECK(obj(text, &m, &e) == RAYD_OK && m.ntris == 2, "quad");
    mesh_data_free(&m);
    /* A polygon of 2000 corners on one long line. */
    size_t cap = 2000 * 40;
    char *big = malloc(cap);
    size_t n = 0;
    for (int i = 0; i < 2000; i++) n += (size_t)snprintf(big + n, cap - n, "v %d %d 0\n", i, i % 7);
    n += (size_t)snprintf(big + n, cap - n, "f");
    for (int i = 1; i <= 2000; i++) n += (size_t)snprintf(big + n, cap - n, " %d", i);
    CHECK(obj_n(big, n, NULL, &m, &e) == RAYD_OK, "%s", e.message); /* no final newline */
    CHECK(m.ntris == 1998 && m.nverts == 2000, "%u tris", m.ntris);
    CHECK(tri_is(&m, 1997, 0, 1998, 1999), "last fan triangle");
    mesh_data_free(&m);
    free(big);
}

static void test_obj_dedup(void) {
    struct mesh_data m = {0};
    struct rayd_error e = {0};
    char text[1024];
    /* Same triples shared between faces: one vertex each. */
    snprintf(text, sizeof text, "%svt 0 0\nf 1/1 2/1 3/1\nf 1/1 3/1 4/1\nf 3/1 1/1 4/1\n",
             obj_square_v);
    CHECK(obj(text, &m, &e) == RAYD_OK, "%s", e.message);
    CHECK(m.nverts == 4 && m.ntris == 3, "%u verts", m.nverts);
    mesh_data_free(&m);
    /* One position with two normals: two vertices. */
    snprintf(text, sizeof text, "%svn 0 0 1\nvn 0 0 -1\nf 1//1 2//1 3//1\nf 1//2 3//2 4//2\n",
             obj_square_v);
    CHECK(obj(text, &m, &e) == RAYD_OK, "%s", e.message);
    CHECK(m.nverts == 6 && m.normal, "%u verts", m.nverts);
    if (m.normal && m.nverts == 6) {
        CHECK(m.normal[m.index[0] * 3 + 2] == 1 && m.normal[m.index[3] * 3 + 2] == -1,
              "split normals");
        CHECK(m.index[0] != m.index[3], "distinct vertices");
    }
    mesh_data_free(&m);
    /* A 150 x 150 grid of quads: the table grows several times. */
    int g = 150;
    size_t cap = (size_t)(g + 1) * (g + 1) * 32 + (size_t)g * g * 64;
    char *big = malloc(cap);
    size_t n = 0;
    for (int y = 0; y <= g; y++)
        for (int x = 0; x <= g; x++) n += (size_t)snprintf(big + n, cap - n, "v %d %d 0\n", x, y);
    n += (size_t)snprintf(big + n, cap - n, "vn 0 0 1\n");
    for (int y = 0; y < g; y++)
        for (int x = 0; x < g; x++) {
            int a = y * (g + 1) + x + 1;
            n += (size_t)snprintf(big + n, cap - n, "f %d//1 %d//1 %d//1 %d//1\r\n", a, a + 1,
                                  a + g + 2, a + g + 1);
        }
    CHECK(obj_n(big, n, NULL, &m, &e) == RAYD_OK, "%s", e.message);
    CHECK(m.nverts == (uint32_t)((g + 1) * (g + 1)) && m.ntris == (uint32_t)(2 * g * g),
          "grid: %u verts %u tris", m.nverts, m.ntris);
    check_indices_in_range(&m);
    int bad = 0;
    for (uint32_t t = 0; t < m.ntris; t++) {
        const float *a = corner_pos(&m, t, 0), *b = corner_pos(&m, t, 1);
        if (!(b[0] == a[0] + 1 || b[1] == a[1] + 1)) bad++;
    }
    CHECK(bad == 0, "%d triangles with wrong corners", bad);
    mesh_data_free(&m);
    free(big);
}

static void test_obj_missing_attributes_dropped(void) {
    struct mesh_data m = {0};
    struct rayd_error e = {0};
    char text[512];
    /* Normals on the first face only: none in the output, and vertex 1 and
     * 3 (used with and without a normal) merge into one vertex each. */
    snprintf(text, sizeof text, "%svn 0 0 1\nvt 0 0\nf 1/1/1 2/1/1 3/1/1\nf 1/1 3/1 4/1\n",
             obj_square_v);
    CHECK(obj(text, &m, &e) == RAYD_OK, "%s", e.message);
    CHECK(m.normal == NULL && m.uv != NULL, "normals dropped, uvs kept");
    CHECK(m.nverts == 4 && m.ntris == 2, "merged to %u verts", m.nverts);
    CHECK(m.index[0] == m.index[3] && m.index[2] == m.index[4], "shared corners merged");
    check_indices_in_range(&m);
    CHECK(pos_is(&m, m.index[5], 0, 1, 0), "positions follow the merge");
    mesh_data_free(&m);
}

/* One corner with a uv among thousands with a position alone: dropping the
 * uv puts every corner into the merge's hash table, which must grow for
 * them (it was sized for the corners with a uv, and the merge looped
 * forever looking for a free slot). */
static void test_obj_merge_grows_the_table(void) {
    enum { NV = 3000 };
    size_t cap = NV * 48 + 64, len = 0;
    char *text = malloc(cap);
    struct mesh_data m = {0};
    struct rayd_error e = {0};
    for (int i = 0; i < NV; i++)
        len += (size_t)snprintf(text + len, cap - len, "v %d %d 0\n", i, i % 7);
    len += (size_t)snprintf(text + len, cap - len, "vt 0 0\nf 1/1 2/1 3/1\n");
    for (int i = 1; i + 2 <= NV; i++)
        len += (size_t)snprintf(text + len, cap - len, "f %d %d %d\n", i, i + 1, i + 2);
    CHECK(obj(text, &m, &e) == RAYD_OK, "%s", e.message);
    CHECK(m.uv == NULL && m.nverts == NV && m.ntris == NV - 1, "%u verts, %u tris", m.nverts,
          m.ntris);
    check_indices_in_range(&m);
    mesh_data_free(&m);
    free(text);
}

static void test_obj_ignored_statements(void) {
    struct mesh_data m = {0};
    struct rayd_error e = {0};
    const char *text = "# a comment\r\n"
                       "mtllib scene.mtl\r\n"
                       "o thing\r\n"
                       "g group1 group2\r\n"
                       "s off\r\n"
                       "\r\n"
                       "   \t \r\n"
                       "v 0 0 0 # trailing comment\r\n"
                       "v 1 0 0\r\n"
                       "v 0 1 0\r\n"
                       "usemtl red\r\n"
                       "l 1 2\r\n"
                       "p 1\r\n"
                       "curv2 1 2 3\r\n"
                       "vp 0.5\r\n"
                       "  f  1   2\t3  \r\n";
    CHECK(obj(text, &m, &e) == RAYD_OK, "%s", e.message);
    CHECK(m.nverts == 3 && m.ntris == 1 && pos_is(&m, 1, 1, 0, 0), "%u verts", m.nverts);
    mesh_data_free(&m);
}

static enum rayd_status obj_bad_index(struct mesh_data *m, struct rayd_error *e) {
    char text[4096] = "";
    size_t n = 0;
    for (int i = 0; i < 38; i++) n += (size_t)snprintf(text + n, sizeof text - n, "v %d 0 0\n", i);
    snprintf(text + n, sizeof text - n, "# x\n# y\n# z\nf 1 2 40\n");
    return obj(text, m, e);
}

#define OBJ_CASE(name, text)                                                                       \
    static enum rayd_status name(struct mesh_data *m, struct rayd_error *e) {                      \
        return obj(text, m, e);                                                                    \
    }

OBJ_CASE(obj_index_zero, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n")
OBJ_CASE(obj_negative_out, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 1 2\n")
OBJ_CASE(obj_forward_ref, "f 1 2 3\nv 0 0 0\n")
OBJ_CASE(obj_texture_out, "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/2 2/1 3/1\n")
OBJ_CASE(obj_normal_out, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//1 2 3\n")
OBJ_CASE(obj_bad_corner, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1/1/1 2 3\n")
OBJ_CASE(obj_letters, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 three\n")
OBJ_CASE(obj_nan, "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n")
OBJ_CASE(obj_inf, "v 0 0 0\nv 1 0 0\nv 0 -inf 0\nf 1 2 3\n")
OBJ_CASE(obj_huge, "v 0 0 0\nv 1 0 0\nv 0 1e39 0\nf 1 2 3\n")
OBJ_CASE(obj_short_v, "v 0 0 0\nv 1 0\n")
OBJ_CASE(obj_long_v, "v 0 0 0 1 2 3 4 5\n")
OBJ_CASE(obj_short_f, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n")
OBJ_CASE(obj_bad_number, "v 0 0 0\nv 1.2.3 0 0\n")
OBJ_CASE(obj_no_faces, "v 0 0 0\nv 1 0 0\nv 0 1 0\n")
OBJ_CASE(obj_empty, "")
OBJ_CASE(obj_vn_short, "vn 0 1\n")
OBJ_CASE(obj_binary_token, "v 0 \xff\x01x 0\n")
OBJ_CASE(obj_long_token,
         "v 0 0 0123456789012345678901234567890123456789012345678901234567890123456789z\n")

static void test_obj_errors(void) {
    CHECK_FAILS(obj_bad_index, RAYD_E_INVALID,
                "OBJ line 42: face index 40 is out of range (1..38)");
    CHECK_FAILS(obj_index_zero, RAYD_E_INVALID, "OBJ line 4: face index 0 is invalid");
    CHECK_FAILS(obj_negative_out, RAYD_E_INVALID,
                "OBJ line 4: face index -4 is out of range (-3..-1)");
    CHECK_FAILS(obj_forward_ref, RAYD_E_INVALID,
                "OBJ line 1: face index 1 is out of range (none defined yet)");
    CHECK_FAILS(obj_texture_out, RAYD_E_INVALID,
                "OBJ line 5: texture index 2 is out of range (1..1)");
    CHECK_FAILS(obj_normal_out, RAYD_E_INVALID, "OBJ line 4: normal index 1 is out of range");
    CHECK_FAILS(obj_bad_corner, RAYD_E_INVALID, "OBJ line 4: bad face vertex '1/1/1/1'");
    CHECK_FAILS(obj_letters, RAYD_E_INVALID, "OBJ line 4: bad face index 'three'");
    CHECK_FAILS(obj_nan, RAYD_E_INVALID, "OBJ line 2: number 'nan' in 'v' is not a finite float");
    CHECK_FAILS(obj_inf, RAYD_E_INVALID, "OBJ line 3: number '-inf' in 'v' is not a finite float");
    CHECK_FAILS(obj_huge, RAYD_E_INVALID, "OBJ line 3: number '1e39'");
    CHECK_FAILS(obj_short_v, RAYD_E_INVALID, "OBJ line 2: 'v' needs 3 numbers, found 2");
    CHECK_FAILS(obj_long_v, RAYD_E_INVALID, "OBJ line 1: 'v' takes at most 7 numbers");
    CHECK_FAILS(obj_short_f, RAYD_E_INVALID, "OBJ line 4: face has 2 vertices (at least 3 needed)");
    CHECK_FAILS(obj_bad_number, RAYD_E_INVALID, "OBJ line 2: bad number '1.2.3' in 'v'");
    CHECK_FAILS(obj_no_faces, RAYD_E_INVALID, "OBJ has no faces");
    CHECK_FAILS(obj_empty, RAYD_E_INVALID, "OBJ has no faces");
    CHECK_FAILS(obj_vn_short, RAYD_E_INVALID, "OBJ line 1: 'vn' needs 3 numbers, found 2");
    /* Quoted tokens are printable ASCII and cut short. */
    CHECK_FAILS(obj_binary_token, RAYD_E_INVALID, "OBJ line 1: bad number '??x' in 'v'");
    CHECK_FAILS(obj_long_token, RAYD_E_INVALID,
                "OBJ line 1: bad number '0123456789012345678901234567890123456789...' in 'v'");
}

static enum rayd_status obj_lim(const char *text, uint32_t mv, uint32_t mt, struct mesh_data *m,
                                struct rayd_error *e) {
    struct mesh_limits lim = {mv, mt};
    return obj_n(text, strlen(text), &lim, m, e);
}

static const char *obj_two_quads = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 2 1 0\n"
                                   "f 1 2 3 4\nf 2 5 6 3\n";

static enum rayd_status obj_over_tris(struct mesh_data *m, struct rayd_error *e) {
    return obj_lim(obj_two_quads, 100, 3, m, e);
}
static enum rayd_status obj_over_positions(struct mesh_data *m, struct rayd_error *e) {
    return obj_lim(obj_two_quads, 5, 100, m, e);
}
static enum rayd_status obj_over_output_verts(struct mesh_data *m, struct rayd_error *e) {
    /* 3 positions, 2 normals: 6 distinct corners, limit 5. */
    return obj_lim("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 -1\nf 1//1 2//1 3//1\n"
                   "f 1//2 3//2 2//2\n",
                   5, 100, m, e);
}

static void test_obj_limits(void) {
    CHECK_FAILS(obj_over_tris, RAYD_E_LIMIT, "OBJ line 8: 4 triangles exceed the limit of 3");
    CHECK_FAILS(obj_over_positions, RAYD_E_LIMIT,
                "OBJ line 6: 6 'v' lines exceed the limit of 5 vertices");
    CHECK_FAILS(obj_over_output_verts, RAYD_E_LIMIT,
                "OBJ line 7: 6 vertices exceed the limit of 5");
    struct mesh_data m = {0};
    struct rayd_error e = {0};
    CHECK(obj_lim(obj_two_quads, 6, 4, &m, &e) == RAYD_OK, "exactly at the limits: %s", e.message);
    mesh_data_free(&m);
}

/* ---- PLY: ascii -------------------------------------------------------- */

static const char *ply_ascii_cube = "ply\r\n"
                                    "format ascii 1.0\r\n"
                                    "comment made by hand\r\n"
                                    "obj_info nothing\r\n"
                                    "element vertex 4\r\n"
                                    "property float x\r\n"
                                    "property float y\r\n"
                                    "property float z\r\n"
                                    "property uchar red\r\n"
                                    "property list uchar int extra_list\r\n"
                                    "property float nx\r\n"
                                    "property float ny\r\n"
                                    "property float nz\r\n"
                                    "property float s\r\n"
                                    "property float t\r\n"
                                    "element edge 2\r\n"
                                    "property int vertex1\r\n"
                                    "property list int int stuff\r\n"
                                    "element face 2\r\n"
                                    "property uchar flags\r\n"
                                    "property list uchar int vertex_indices\r\n"
                                    "property list int float texcoord\r\n"
                                    "end_header\r\n"
                                    "0 0 0 255 2 7 8 0 0 1 0 0\r\n"
                                    "1 0 0 128 0 0 0 1 1 0\r\n"
                                    "1 1 0 0 1 -5 0 0 1 1 1\r\n"
                                    "0 1 0 1 0 0 0 1 0 1\r\n"
                                    "0 3 1 2 3\r\n"
                                    "1 0\r\n"
                                    "0 4 0 1 2 3 0\r\n"
                                    "9 3 0 2 3 2 0.5 0.5\r\n";

static void test_ply_ascii(void) {
    struct mesh_data m = {0};
    struct rayd_error e = {0};
    CHECK(ply(ply_ascii_cube, &m, &e) == RAYD_OK, "%s", e.message);
    CHECK(m.nverts == 4 && m.ntris == 3, "%u verts %u tris", m.nverts, m.ntris);
    CHECK(m.normal && m.uv, "normals and s/t");
    CHECK(tri_is(&m, 0, 0, 1, 2) && tri_is(&m, 1, 0, 2, 3), "fan of the quad");
    CHECK(tri_is(&m, 2, 0, 2, 3), "the triangle after the quad");
    CHECK(pos_is(&m, 2, 1, 1, 0) && pos_is(&m, 3, 0, 1, 0), "positions");
    if (m.normal && m.uv) {
        CHECK(m.normal[2] == 1 && m.normal[11] == 1, "normals");
        CHECK(m.uv[2] == 1 && m.uv[3] == 0 && m.uv[4] == 1 && m.uv[5] == 1, "uvs");
    }
    mesh_data_free(&m);
}

static void test_ply_ascii_faces_first_and_types(void) {
    struct mesh_data m = {0};
    struct rayd_error e = {0};
    const char *text = "ply\nformat ascii 1.0\n"
                       "element face 1\nproperty list uint8 uint32 vertex_index\n"
                       "element vertex 3\nproperty int16 x\nproperty float64 y\nproperty int8 z\n"
                       "property double texture_u\nproperty double texture_v\n"
                       "end_header\n"
                       "3 2 1 0\n"
                       "-1 0.5 3 0 0\n2 1e2 -4 1 0\n3 0 0 0 1";
    CHECK(ply(text, &m, &e) == RAYD_OK, "%s", e.message);
    CHECK(m.ntris == 1 && tri_is(&m, 0, 2, 1, 0), "face before vertices");
    CHECK(pos_is(&m, 0, -1, 0.5f, 3) && pos_is(&m, 1, 2, 100, -4), "typed values");
    CHECK(m.uv && !m.normal, "texture_u/v, no normals");
    mesh_data_free(&m);
}

/* ---- PLY: binary ------------------------------------------------------- */

struct bb {
    unsigned char b[4096];
    size_t n;
    bool be;
};

static void bb_raw(struct bb *w, uint64_t u, size_t size) {
    for (size_t k = 0; k < size; k++) {
        size_t shift = 8 * (w->be ? size - 1 - k : k);
        w->b[w->n++] = (unsigned char)(u >> shift);
    }
}

static void bb_text(struct bb *w, const char *s) {
    memcpy(w->b + w->n, s, strlen(s));
    w->n += strlen(s);
}

static void bb_f32(struct bb *w, float f) {
    uint32_t u;
    memcpy(&u, &f, 4);
    bb_raw(w, u, 4);
}

static void bb_f64(struct bb *w, double d) {
    uint64_t u;
    memcpy(&u, &d, 8);
    bb_raw(w, u, 8);
}

/* A quad and a triangle over 5 vertices, with every kind of extra. */
static void build_binary(struct bb *w, bool be) {
    w->n = 0;
    w->be = be;
    bb_text(w, "ply\n");
    bb_text(w, be ? "format binary_big_endian 1.0\n" : "format binary_little_endian 1.0\n");
    bb_text(w, "comment binary test\n"
               "element material 2\nproperty uchar r\nproperty double shine\n"
               "element vertex 5\n"
               "property float x\nproperty double y\nproperty int z\n"
               "property short extra_s\nproperty list ushort float extra_list\n"
               "property float nx\nproperty float ny\nproperty float nz\n"
               "property float u\nproperty float v\n"
               "element face 2\n"
               "property list uchar int vertex_indices\n"
               "property uint flags\n"
               "property list int uchar tags\n"
               "element tail 1\nproperty list uint int junk\n"
               "end_header\n");
    /* material */
    bb_raw(w, 7, 1);
    bb_f64(w, 0.5);
    bb_raw(w, 9, 1);
    bb_f64(w, 1.5);
    /* vertices */
    static const float P[5][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {2, 0.5f, -3}};
    for (int i = 0; i < 5; i++) {
        bb_f32(w, P[i][0]);
        bb_f64(w, P[i][1]);
        bb_raw(w, (uint32_t)(int32_t)P[i][2], 4);
        bb_raw(w, (uint16_t)(int16_t)-i, 2);
        int extra = i == 1 ? 9 : i % 3;
        bb_raw(w, (uint64_t)extra, 2);
        for (int k = 0; k < extra; k++) bb_f32(w, 42.0f);
        bb_f32(w, 0);
        bb_f32(w, 0);
        bb_f32(w, 1);
        bb_f32(w, (float)i / 4);
        bb_f32(w, 1 - (float)i / 4);
    }
    /* faces */
    bb_raw(w, 4, 1);
    for (int k = 0; k < 4; k++) bb_raw(w, (uint64_t)k, 4);
    bb_raw(w, 0xdeadbeef, 4);
    bb_raw(w, 2, 4);
    bb_raw(w, 1, 1);
    bb_raw(w, 2, 1);
    bb_raw(w, 3, 1);
    bb_raw(w, 1, 4);
    bb_raw(w, 4, 4);
    bb_raw(w, 2, 4);
    bb_raw(w, 0, 4);
    bb_raw(w, 0, 4);
    /* tail */
    bb_raw(w, 3, 4);
    for (int k = 0; k < 3; k++) bb_raw(w, 5, 4);
}

static void check_binary_mesh(const struct mesh_data *m) {
    CHECK(m->nverts == 5 && m->ntris == 3, "%u verts %u tris", m->nverts, m->ntris);
    if (m->nverts != 5 || m->ntris != 3) return;
    CHECK(tri_is(m, 0, 0, 1, 2) && tri_is(m, 1, 0, 2, 3) && tri_is(m, 2, 1, 4, 2), "indices");
    CHECK(pos_is(m, 2, 1, 1, 0) && pos_is(m, 4, 2, 0.5f, -3), "positions");
    CHECK(m->normal && m->normal[14] == 1 && m->normal[12] == 0, "normals");
    CHECK(m->uv && m->uv[8] == 1 && m->uv[9] == 0 && m->uv[2] == 0.25f, "uvs");
}

static void test_ply_binary_both_orders(void) {
    static struct bb w;
    for (int be = 0; be <= 1; be++) {
        struct mesh_data m = {0};
        struct rayd_error e = {0};
        build_binary(&w, be);
        CHECK(ply_n(w.b, w.n, NULL, &m, &e) == RAYD_OK, "%s: %s", be ? "BE" : "LE", e.message);
        check_binary_mesh(&m);
        mesh_data_free(&m);
    }
}

static void test_ply_binary_truncated(void) {
    static struct bb w;
    build_binary(&w, false);
    size_t header = (size_t)(strstr((const char *)w.b, "end_header\n") - (const char *)w.b) + 11;
    int ok = 0, in_header = 0, in_vertex = 0, in_face = 0, other = 0;
    for (size_t n = 0; n < w.n; n++) {
        struct mesh_data m = {0};
        struct rayd_error e = {0};
        if (ply_n(w.b, n, NULL, &m, &e) == RAYD_OK) ok++;
        mesh_data_free(&m);
        if (n < header)
            in_header += strstr(e.message, "PLY header") != NULL;
        else if (strstr(e.message, "claims"))
            in_header++;
        else if (!strncmp(e.message, "PLY vertex ", 11) && strstr(e.message, "file ends early"))
            in_vertex++;
        else if (!strncmp(e.message, "PLY face ", 9) && strstr(e.message, "file ends early"))
            in_face++;
        else if (!strstr(e.message, "PLY tail 0: file ends early"))
            other++;
    }
    CHECK(ok == 0, "%d truncated files accepted", ok);
    CHECK(other == 0, "%d cuts with an unexpected message", other);
    /* Cuts that leave too few bytes for the declared records fail before
     * the body is read; the rest (variable-size lists) while reading it. */
    CHECK(in_header > 0 && in_vertex > 0 && in_face > 0, "header %d vertex %d face %d", in_header,
          in_vertex, in_face);
    struct mesh_data m = {0};
    struct rayd_error e = {0};
    CHECK(ply_n(w.b, header + 20, NULL, &m, &e) == RAYD_E_INVALID &&
              strstr(e.message, "PLY header line 7: element 'vertex' claims 5 records but the body "
                                "has only 20 bytes"),
          "%s", e.message);
    CHECK(ply_n(w.b, w.n - 2, NULL, &m, &e) == RAYD_E_INVALID, "cut in tail");
    CHECK(strstr(e.message, "PLY tail 0: file ends early (truncated binary body)"), "%s",
          e.message);
}

static void test_ply_binary_int_counts_and_big_list(void) {
    static struct bb w;
    w.n = 0;
    w.be = true;
    bb_text(&w, "ply\nformat binary_big_endian 1.0\nelement vertex 4\n"
                "property uint8 x\nproperty int8 y\nproperty uint16 z\n"
                "element face 1\nproperty list int32 uint16 vertex_indices\nend_header\n");
    static const int V[4][3] = {{0, -1, 0}, {200, 0, 65535}, {1, 127, 0}, {0, -128, 3}};
    for (int i = 0; i < 4; i++) {
        bb_raw(&w, (uint64_t)V[i][0], 1);
        bb_raw(&w, (uint8_t)(int8_t)V[i][1], 1);
        bb_raw(&w, (uint64_t)V[i][2], 2);
    }
    bb_raw(&w, 4, 4);
    for (int k = 3; k >= 0; k--) bb_raw(&w, (uint64_t)k, 2);
    struct mesh_data m = {0};
    struct rayd_error e = {0};
    CHECK(ply_n(w.b, w.n, NULL, &m, &e) == RAYD_OK, "%s", e.message);
    CHECK(m.ntris == 2 && tri_is(&m, 0, 3, 2, 1) && tri_is(&m, 1, 3, 1, 0), "int32 count");
    CHECK(pos_is(&m, 1, 200, 0, 65535) && pos_is(&m, 3, 0, -128, 3), "int8/uint8/uint16");
    mesh_data_free(&m);
    /* A list count of 0x7fffffff items in an 8-byte body. */
    w.n -= 12;
    bb_raw(&w, 0x7fffffff, 4);
    bb_raw(&w, 0, 4);
    CHECK(ply_n(w.b, w.n, NULL, &m, &e) == RAYD_E_INVALID &&
              strstr(e.message, "PLY face 0: file ends early"),
          "%s", e.message);
}

/* ---- PLY: errors -------------------------------------------------------- */

#define PLY_CASE(name, text)                                                                       \
    static enum rayd_status name(struct mesh_data *m, struct rayd_error *e) {                      \
        return ply(text, m, e);                                                                    \
    }

#define PLY_XYZ "property float x\nproperty float y\nproperty float z\n"
#define PLY_FACE "element face 1\nproperty list uchar int vertex_indices\n"

PLY_CASE(ply_bad_format, "ply\nformat binary_middle_endian 1.0\nend_header\n")
PLY_CASE(ply_bad_version, "ply\nformat ascii 2.0\nend_header\n")
PLY_CASE(ply_not_ply, "plyx\nformat ascii 1.0\nend_header\n")
PLY_CASE(ply_no_end, "ply\nformat ascii 1.0\nelement vertex 3\n" PLY_XYZ)
PLY_CASE(ply_absurd,
         "ply\nformat binary_little_endian 1.0\nelement vertex 4294967295\n" PLY_XYZ PLY_FACE
         "end_header\n0123456789012345678901234567890123456789")
PLY_CASE(ply_absurd_ascii,
         "ply\nformat ascii 1.0\nelement vertex 3\n" PLY_XYZ
         "element face 18446744073709551615\nproperty list uchar int vertex_indices\n"
         "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
PLY_CASE(ply_count_overflow, "ply\nformat ascii 1.0\nelement vertex 99999999999999999999999\n")
PLY_CASE(ply_index_out, "ply\nformat ascii 1.0\nelement vertex 4\n" PLY_XYZ PLY_FACE
                        "end_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 5\n")
PLY_CASE(ply_index_negative, "ply\nformat ascii 1.0\nelement vertex 3\n" PLY_XYZ PLY_FACE
                             "end_header\n0 0 0\n1 0 0\n1 1 0\n3 0 -1 2\n")
PLY_CASE(ply_no_z,
         "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n" PLY_FACE
         "end_header\n")
PLY_CASE(ply_no_face, "ply\nformat ascii 1.0\nelement vertex 1\n" PLY_XYZ "end_header\n0 0 0\n")
PLY_CASE(ply_no_faces,
         "ply\nformat ascii 1.0\nelement vertex 1\n" PLY_XYZ
         "element face 0\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n")
PLY_CASE(ply_no_indices, "ply\nformat ascii 1.0\nelement vertex 1\n" PLY_XYZ
                         "element face 1\nproperty int vertex_indices\nend_header\n0 0 0\n3\n")
PLY_CASE(ply_two_corners, "ply\nformat ascii 1.0\nelement vertex 3\n" PLY_XYZ PLY_FACE
                          "end_header\n0 0 0\n1 0 0\n1 1 0\n2 0 1\n")
PLY_CASE(ply_nan, "ply\nformat ascii 1.0\nelement vertex 3\n" PLY_XYZ PLY_FACE
                  "end_header\n0 0 0\n1 nan 0\n1 1 0\n3 0 1 2\n")
PLY_CASE(ply_bad_token, "ply\nformat ascii 1.0\nelement vertex 3\n" PLY_XYZ PLY_FACE
                        "end_header\n0 0 0\n1 0 0\n1 1 zero\n3 0 1 2\n")
PLY_CASE(ply_ascii_short, "ply\nformat ascii 1.0\nelement vertex 3\n" PLY_XYZ PLY_FACE
                          "end_header\n0 0 0\n1 0 0\n1 1 0\n3 0 1")
PLY_CASE(ply_bad_type,
         "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty half y\n")
PLY_CASE(ply_float_count, "ply\nformat ascii 1.0\nelement vertex 3\n" PLY_XYZ
                          "element face 1\nproperty list float int vertex_indices\n")
PLY_CASE(ply_orphan_prop, "ply\nformat ascii 1.0\nproperty float x\n")
PLY_CASE(ply_unknown_kw, "ply\nformat ascii 1.0\nelement vertex 1\nfoo bar\n")
PLY_CASE(ply_created_by, "ply\nformat ascii 1.0\nCreated by Blender3D 247\n")
PLY_CASE(ply_no_format, "ply\nelement vertex 1\n" PLY_XYZ PLY_FACE "end_header\n")
PLY_CASE(ply_fraction_index, "ply\nformat ascii 1.0\nelement vertex 3\n" PLY_XYZ PLY_FACE
                             "end_header\n0 0 0\n1 0 0\n1 1 0\n3 0 1.5 2\n")

PLY_CASE(ply_strip_index_out, "ply\nformat ascii 1.0\nelement vertex 5\n" PLY_XYZ
                              "element tristrips 1\nproperty list int int vertex_indices\n"
                              "end_header\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n2 1 0\n4 0 1 2 7\n")
PLY_CASE(ply_strip_no_indices,
         "ply\nformat ascii 1.0\nelement vertex 1\n" PLY_XYZ
         "element tristrips 1\nproperty int vertex_indices\nend_header\n0 0 0\n3\n")

/* Triangle strips (element tristrips, as in Stanford scans): alternate
 * triangles turned to keep the winding, -1 ending a strip, the joining
 * triangles (two equal corners) dropped; in ascii and binary alike. */
static void test_ply_tristrips(void) {
    /* 6 vertices: strip 0 1 2 3 (two triangles), -1, strip 3 2 4 4 5 (a
     * repeated index: the degenerate ones dropped) */
    static const char *text = "ply\nformat ascii 1.0\nelement vertex 6\n" PLY_XYZ
                              "element tristrips 1\nproperty list int int vertex_indices\n"
                              "end_header\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n2 0 0\n2 1 0\n"
                              "10 0 1 2 3 -1 3 2 4 4 5\n";
    struct mesh_data m = {0};
    struct rayd_error e = {0};
    CHECK(ply(text, &m, &e) == RAYD_OK, "%s", e.message);
    CHECK(m.ntris == 3 && tri_is(&m, 0, 0, 1, 2) && tri_is(&m, 1, 2, 1, 3) &&
              tri_is(&m, 2, 3, 2, 4),
          "strips: %u triangles", m.ntris);
    mesh_data_free(&m);
    static struct bb w;
    w.n = 0;
    w.be = false;
    bb_text(&w, "ply\nformat binary_little_endian 1.0\nelement vertex 4\n" PLY_XYZ
                "element tristrips 1\nproperty list int int vertex_indices\nend_header\n");
    static const float V[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
    for (int i = 0; i < 4; i++)
        for (int k = 0; k < 3; k++) {
            uint32_t u;
            memcpy(&u, &V[i][k], 4);
            bb_raw(&w, u, 4);
        }
    bb_raw(&w, 4, 4);
    for (int k = 0; k < 4; k++) bb_raw(&w, (uint64_t)k, 4);
    CHECK(ply_n(w.b, w.n, NULL, &m, &e) == RAYD_OK, "%s", e.message);
    CHECK(m.ntris == 2 && tri_is(&m, 0, 0, 1, 2) && tri_is(&m, 1, 2, 1, 3), "binary strip");
    mesh_data_free(&m);
}

static void test_ply_errors(void) {
    CHECK_FAILS(ply_bad_format, RAYD_E_INVALID,
                "PLY header line 2: unknown format 'binary_middle_endian'");
    CHECK_FAILS(ply_bad_version, RAYD_E_INVALID, "PLY header line 2: unsupported version '2.0'");
    CHECK_FAILS(ply_not_ply, RAYD_E_INVALID, "PLY header line 1: not a PLY file");
    CHECK_FAILS(ply_no_end, RAYD_E_INVALID, "PLY header: no 'end_header' line");
    CHECK_FAILS(ply_absurd, RAYD_E_INVALID,
                "PLY header line 3: element 'vertex' claims 4294967295 records but the body has "
                "only 40 bytes");
    CHECK_FAILS(ply_absurd_ascii, RAYD_E_INVALID,
                "element 'face' claims 18446744073709551615 records");
    CHECK_FAILS(ply_count_overflow, RAYD_E_INVALID, "PLY header line 3: bad element count");
    CHECK_FAILS(ply_index_out, RAYD_E_INVALID, "PLY face 0: vertex index 5 is out of range (0..3)");
    CHECK_FAILS(ply_index_negative, RAYD_E_INVALID,
                "PLY face 0: vertex index -1 is out of range (0..2)");
    CHECK_FAILS(ply_fraction_index, RAYD_E_INVALID,
                "PLY face 0: vertex index 1.5 is not an integer");
    CHECK_FAILS(ply_no_z, RAYD_E_INVALID, "PLY header: element 'vertex' has no property 'z'");
    CHECK_FAILS(ply_no_face, RAYD_E_INVALID,
                "PLY header: no 'face' or 'tristrips' element (a point cloud, not a mesh)");
    CHECK_FAILS(ply_strip_index_out, RAYD_E_INVALID,
                "PLY tristrips 0: vertex index 7 is out of range (0..4)");
    CHECK_FAILS(ply_strip_no_indices, RAYD_E_INVALID,
                "element 'tristrips' has no list 'vertex_indices'");
    CHECK_FAILS(ply_no_faces, RAYD_E_INVALID, "PLY file has no faces");
    CHECK_FAILS(ply_no_indices, RAYD_E_INVALID, "element 'face' has no list 'vertex_indices'");
    CHECK_FAILS(ply_two_corners, RAYD_E_INVALID, "PLY face 0: polygon has 2 vertices");
    CHECK_FAILS(ply_nan, RAYD_E_INVALID, "PLY vertex 1: y is not a finite float");
    CHECK_FAILS(ply_bad_token, RAYD_E_INVALID, "PLY vertex 2: bad number 'zero'");
    CHECK_FAILS(ply_ascii_short, RAYD_E_INVALID,
                "PLY face 0: file ends early (truncated ascii body)");
    CHECK_FAILS(ply_bad_type, RAYD_E_INVALID, "PLY header line 5: unknown property type 'half'");
    CHECK_FAILS(ply_float_count, RAYD_E_INVALID, "PLY header line 8: bad list count type 'float'");
    CHECK_FAILS(ply_orphan_prop, RAYD_E_INVALID,
                "PLY header line 3: 'property' before any 'element'");
    CHECK_FAILS(ply_unknown_kw, RAYD_E_INVALID, "PLY header line 4: unknown keyword 'foo'");
    /* before any element, a line of no keyword is a comment (Blender 2.4x) */
    CHECK_FAILS(ply_created_by, RAYD_E_INVALID, "PLY header: no 'end_header' line");
    CHECK_FAILS(ply_no_format, RAYD_E_INVALID, "PLY header: no 'format' line");
}

static enum rayd_status ply_lim(const char *text, uint32_t mv, uint32_t mt, struct mesh_data *m,
                                struct rayd_error *e) {
    struct mesh_limits lim = {mv, mt};
    return ply_n(text, strlen(text), &lim, m, e);
}

static const char *ply_quads =
    "ply\nformat ascii 1.0\nelement vertex 6\n" PLY_XYZ
    "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
    "0 0 0\n1 0 0\n1 1 0\n0 1 0\n2 0 0\n2 1 0\n4 0 1 2 3\n4 1 4 5 2\n";

static enum rayd_status ply_over_verts(struct mesh_data *m, struct rayd_error *e) {
    return ply_lim(ply_quads, 5, 100, m, e);
}
static enum rayd_status ply_over_faces(struct mesh_data *m, struct rayd_error *e) {
    return ply_lim(ply_quads, 100, 1, m, e);
}
static enum rayd_status ply_over_tris(struct mesh_data *m, struct rayd_error *e) {
    return ply_lim(ply_quads, 100, 3, m, e);
}
static enum rayd_status ply_absurd_limited(struct mesh_data *m, struct rayd_error *e) {
    struct mesh_limits lim = {1000000, 2000000};
    const char *t =
        "ply\nformat binary_little_endian 1.0\nelement vertex 4294967295\n" PLY_XYZ PLY_FACE
        "end_header\n0123456789";
    return ply_n(t, strlen(t), &lim, m, e);
}

static void test_ply_limits(void) {
    CHECK_FAILS(ply_over_verts, RAYD_E_LIMIT, "PLY header: 6 vertices exceed the limit of 5");
    CHECK_FAILS(ply_over_faces, RAYD_E_LIMIT,
                "PLY header: 2 faces exceed the limit of 1 triangles");
    CHECK_FAILS(ply_over_tris, RAYD_E_LIMIT, "PLY face 1: 4 triangles exceed the limit of 3");
    /* A corrupt header is reported as such even when it is also over the limits. */
    CHECK_FAILS(ply_absurd_limited, RAYD_E_INVALID,
                "claims 4294967295 records but the body has only 10 bytes");
    struct mesh_data m = {0};
    struct rayd_error e = {0};
    CHECK(ply_lim(ply_quads, 6, 4, &m, &e) == RAYD_OK, "at the limits: %s", e.message);
    CHECK(m.ntris == 4 && tri_is(&m, 3, 1, 5, 2), "%u tris", m.ntris);
    mesh_data_free(&m);
}

/* ---- base64 -------------------------------------------------------------- */

static size_t b64_encode(const unsigned char *in, size_t n, char *out, bool pad) {
    static const char A[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    size_t o = 0;
    for (size_t i = 0; i < n; i += 3) {
        uint32_t v = (uint32_t)in[i] << 16;
        if (i + 1 < n) v |= (uint32_t)in[i + 1] << 8;
        if (i + 2 < n) v |= in[i + 2];
        out[o++] = A[v >> 18 & 63];
        out[o++] = A[v >> 12 & 63];
        if (i + 1 < n)
            out[o++] = A[v >> 6 & 63];
        else if (pad)
            out[o++] = '=';
        if (i + 2 < n)
            out[o++] = A[v & 63];
        else if (pad)
            out[o++] = '=';
    }
    return o;
}

static enum rayd_status b64(const char *s, size_t n, unsigned char **out, size_t *len,
                            struct rayd_error *e) {
    char *copy = malloc(n ? n : 1);
    memcpy(copy, s, n);
    enum rayd_status st = base64_decode(copy, n, out, len, e);
    free(copy);
    return st;
}

static void test_base64_round_trip(void) {
    unsigned char all[256];
    char text[400];
    for (int i = 0; i < 256; i++) all[i] = (unsigned char)i;
    for (int pad = 0; pad <= 1; pad++)
        for (size_t n = 0; n <= 256; n += (n < 8 ? 1 : 31)) {
            size_t tn = b64_encode(all + 256 - n, n, text, pad);
            unsigned char *out = NULL;
            size_t len = 99;
            struct rayd_error e = {0};
            CHECK(b64(text, tn, &out, &len, &e) == RAYD_OK, "n=%zu pad=%d: %s", n, pad, e.message);
            CHECK(out != NULL && len == n && memcmp(out, all + 256 - n, n) == 0, "n=%zu pad=%d", n,
                  pad);
            free(out);
        }
    size_t tn = b64_encode(all, 256, text, true);
    CHECK(tn == 344 && memcmp(text, "AAECAwQFBgcICQoL", 16) == 0, "encoder sanity");
}

static void test_base64_padding_and_whitespace(void) {
    static const struct {
        const char *in, *out;
    } ok[] = {
        {"TWFu", "Man"},   {"TWE=", "Ma"},  {"TWE", "Ma"},           {"TQ==", "M"},
        {"TQ", "M"},       {"", ""},        {" \r\n\t", ""},         {"TW\nFu\r\n  ZA==\n", "Mand"},
        {"T W E =", "Ma"}, {"TQ=\n=", "M"}, {"TWFuTWFu\n", "ManMan"}};
    for (size_t i = 0; i < sizeof ok / sizeof ok[0]; i++) {
        unsigned char *out = NULL;
        size_t len = 99;
        struct rayd_error e = {0};
        CHECK(b64(ok[i].in, strlen(ok[i].in), &out, &len, &e) == RAYD_OK, "'%s': %s", ok[i].in,
              e.message);
        CHECK(out && len == strlen(ok[i].out) && memcmp(out, ok[i].out, len) == 0, "'%s'",
              ok[i].in);
        free(out);
    }
}

static void test_base64_errors(void) {
    static const struct {
        const char *in, *msg;
    } bad[] = {{"TW*u", "base64: invalid character '*' at offset 2"},
               {"TWF-", "invalid character '-' at offset 3"},
               {"TWF_", "invalid character '_' at offset 3"},
               {"TW\x80u", "invalid character (byte 0x80) at offset 2"},
               {"TQ=", "incomplete padding"},
               {"TQ===", "unexpected padding '=' at offset 4"},
               {"TWFu=", "unexpected padding '=' at offset 4"},
               {"TWFuT=", "unexpected padding '=' at offset 5"},
               {"T", "truncated input (a lone final character at offset 0)"},
               {"TWFuT \n", "lone final character at offset 4"},
               {"TQ==TQ==", "character after the padding 'T' at offset 4"},
               {"=", "unexpected padding '=' at offset 0"}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        unsigned char *out = (unsigned char *)&i;
        size_t len = 99;
        struct rayd_error e = {0};
        CHECK(b64(bad[i].in, strlen(bad[i].in), &out, &len, &e) == RAYD_E_INVALID, "'%s' accepted",
              bad[i].in);
        CHECK(strstr(e.message, bad[i].msg) != NULL, "'%s': '%s' lacks '%s'", bad[i].in, e.message,
              bad[i].msg);
        CHECK(out == (unsigned char *)&i && len == 99, "out written on error");
    }
    /* A NUL inside the given length is a bad character, not an end. */
    unsigned char *out = NULL;
    size_t len = 0;
    struct rayd_error e = {0};
    CHECK(b64("TW\0u", 4, &out, &len, &e) == RAYD_E_INVALID && strstr(e.message, "byte 0x00"), "%s",
          e.message);
}

/* ---- large inputs: the threaded decoders' own paths ---------------------- */

/* Odd records of big_ply: NONE for none. */
struct ply_odd {
    uint32_t quad, bad; /* face with four corners; face with an index out of range */
    uint32_t nan, neg;  /* vertex whose y is NaN; face whose first index is -1 */
};
#define NONE UINT32_MAX

/* A binary PLY of nv vertices (x y z float, then a uchar tag if tag) and
 * nf triangles (uchar count, int indices), with the odd records of o. */
static unsigned char *big_ply_odd(bool be, bool tag, uint32_t nv, uint32_t nf, struct ply_odd o,
                                  size_t *len) {
    char head[256];
    int h = snprintf(head, sizeof head,
                     "ply\nformat %s 1.0\nelement vertex %u\nproperty float x\nproperty float y\n"
                     "property float z\n%selement face %u\n"
                     "property list uchar int vertex_indices\nend_header\n",
                     be ? "binary_big_endian" : "binary_little_endian", nv,
                     tag ? "property uchar tag\n" : "", nf);
    struct bb *w = malloc(sizeof *w); /* one record at a time */
    unsigned char *out = malloc((size_t)h + 13 * (size_t)nv + 17 * (size_t)nf + 4);
    memcpy(out, head, (size_t)h);
    size_t n = (size_t)h;
    for (uint32_t i = 0; i < nv + nf; i++) {
        w->n = 0;
        w->be = be;
        if (i < nv) {
            for (int k = 0; k < 3; k++)
                bb_f32(w, i == o.nan && k == 1 ? NAN : (float)((i * (k + 3)) % 101) * 0.25f);
            if (tag) bb_raw(w, i & 0xff, 1);
        } else {
            uint32_t f = i - nv, c = f == o.quad ? 4 : 3;
            bb_raw(w, c, 1);
            for (uint32_t k = 0; k < c; k++)
                bb_raw(w,
                       f == o.neg && k == 0 ? 0xffffffffu
                       : f == o.bad         ? nv + k
                                            : (f + k * 7) % nv,
                       4);
        }
        memcpy(out + n, w->b, w->n);
        n += w->n;
    }
    free(w);
    *len = n;
    return out;
}

/* big_ply_odd with the tag, face quad with four corners, face bad out of
 * range. */
static unsigned char *big_ply(bool be, uint32_t nv, uint32_t nf, uint32_t quad, uint32_t bad,
                              size_t *len) {
    return big_ply_odd(be, true, nv, nf, (struct ply_odd){quad, bad, NONE, NONE}, len);
}

/* Vertices of only float x y z and faces of a uchar count and int indices
 * take the threaded reader's fast path in little-endian files: the same
 * mesh and, for each bad record, the same message as one thread's reader
 * (ply_n compares them on 2, 3 and 8 threads). */
static void test_ply_binary_fast_layout(void) {
    const uint32_t nv = 20000, nf = 30000;
    static const struct {
        struct ply_odd o;
        uint32_t max_tris;
        const char *msg; /* NULL: decodes */
    } cases[] = {
        {{NONE, NONE, NONE, NONE}, 0, NULL},
        {{17777, NONE, NONE, NONE}, 0, NULL},
        {{NONE, 23456, NONE, NONE}, 0, "PLY face 23456: vertex index 20000 is out of range"},
        {{NONE, NONE, 12345, NONE}, 0, "PLY vertex 12345: y is not a finite float"},
        {{NONE, NONE, NONE, 20001}, 0, "PLY face 20001: vertex index -1 is out of range"},
        {{17777, NONE, NONE, NONE}, 30000, "30001 triangles exceed the limit of 30000"},
    };
    for (int be = 0; be <= 1; be++)
        for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
            size_t len;
            struct mesh_data m = {0};
            struct rayd_error e = {0};
            struct mesh_limits lim = {UINT32_MAX,
                                      cases[i].max_tris ? cases[i].max_tris : UINT32_MAX};
            unsigned char *b = big_ply_odd(be, false, nv, nf, cases[i].o, &len);
            enum rayd_status st = ply_n(b, len, &lim, &m, &e);
            if (!cases[i].msg)
                CHECK(st == RAYD_OK && m.ntris == nf + (cases[i].o.quad != NONE) &&
                          m.pos[3 * 7 + 1] == (float)((7 * 4) % 101) * 0.25f,
                      "case %zu: %s", i, e.message);
            else
                CHECK(st != RAYD_OK && strstr(e.message, cases[i].msg), "case %zu: '%s'", i,
                      e.message);
            if (st == RAYD_OK) mesh_data_free(&m);
            free(b);
        }
}

static void test_ply_binary_large_on_threads(void) {
    const uint32_t nv = 20000, nf = 30000, none = NONE;
    for (int be = 0; be <= 1; be++) {
        size_t len;
        struct mesh_data m = {0};
        struct rayd_error e = {0};
        unsigned char *b = big_ply(be, nv, nf, none, none, &len);
        CHECK(ply_n(b, len, NULL, &m, &e) == RAYD_OK && m.ntris == nf, "%s", e.message);
        mesh_data_free(&m);
        free(b);
        b = big_ply(be, nv, nf, 17777, none, &len); /* a quad: read in order */
        CHECK(ply_n(b, len, NULL, &m, &e) == RAYD_OK && m.ntris == nf + 1, "%s", e.message);
        mesh_data_free(&m);
        free(b);
        b = big_ply(be, nv, nf, none, 23456, &len);
        CHECK(ply_n(b, len, NULL, &m, &e) == RAYD_E_INVALID &&
                  strstr(e.message, "PLY face 23456: vertex index 20000 is out of range"),
              "%s", e.message);
        free(b);
        b = big_ply(be, nv, nf, 23456, 23000, &len); /* the first error wins */
        CHECK(ply_n(b, len, NULL, &m, &e) == RAYD_E_INVALID && strstr(e.message, "face 23000:"),
              "%s", e.message);
        free(b);
    }
}

/* OBJ text of n faces over positions, uvs and normals, every form of
 * corner and negative indices, with the statement `inject` put in near line
 * inject_at (0: none); obj_n checks the threads' message, line included,
 * against the one of a single thread. */
static char *big_obj(uint32_t n, const char *inject, uint32_t inject_at, size_t *len) {
    size_t cap = (size_t)n * 160 + 256, at = 0;
    char *s = malloc(cap);
    uint32_t line = 0;
    for (uint32_t i = 0; i < n; i++) {
        if (++line == inject_at) at += (size_t)sprintf(s + at, "%s\n", inject);
        at += (size_t)sprintf(s + at, "v %u.5 %u -%u\nvt 0.%u 0.5\nvn 0 %u 1\n# c\n", i % 97,
                              i % 13, i % 7, i % 10, i % 3);
        line += 4;
        if (i < 2) continue;
        switch (i % 4) {
        case 0:
            at += (size_t)sprintf(s + at, "f %u %u %u\n", i + 1, i, i - 1);
            break;
        case 1:
            at += (size_t)sprintf(s + at, "f -1/-1 -2/-2 -3/-3 %u/1\n", i / 2 + 1);
            break;
        case 2:
            at += (size_t)sprintf(s + at, "f %u//%u -2//-1 1//1\n", i % 50 + 1, i);
            break;
        default:
            at += (size_t)sprintf(s + at, "g x\r\nf %u/%u/%u -2/-2/-2 -3/1/-1\n", i, i, i);
        }
    }
    *len = at;
    return s;
}

static void test_obj_large_on_threads(void) {
    size_t len;
    struct mesh_data m = {0};
    struct rayd_error e = {0};
    char *s = big_obj(6000, NULL, 0, &len);
    CHECK(obj_n(s, len, NULL, &m, &e) == RAYD_OK && m.ntris > 6000, "%s", e.message);
    mesh_data_free(&m);
    free(s);
    s = big_obj(6000, "f 1 2 999999", 15001, &len);
    CHECK(obj_n(s, len, NULL, &m, &e) == RAYD_E_INVALID &&
              strstr(e.message, "face index 999999 is out"),
          "%s", e.message);
    free(s);
    s = big_obj(6000, "v 1 2 nan", 20001, &len);
    CHECK(obj_n(s, len, NULL, &m, &e) == RAYD_E_INVALID && strstr(e.message, "number 'nan' in 'v'"),
          "%s", e.message);
    free(s);
    struct mesh_limits lim = {100000, 5000};
    s = big_obj(6000, NULL, 0, &len);
    CHECK(obj_n(s, len, &lim, &m, &e) == RAYD_E_LIMIT, "%s", e.message);
    free(s);
}

/* Faces of positions alone ("f a b c", as scanned meshes are) number their
 * vertices on every thread (obj_number_positions): corners drawn at random
 * from all the positions defined so far, some negative, some polygons, so
 * that the order of first use is far from the order of definition and
 * crosses the chunks; every tenth position is never used. */
static char *positions_obj(uint32_t n, size_t *len) {
    size_t cap = (size_t)n * 96 + 256, at = 0;
    char *s = malloc(cap);
    uint64_t x = 0x2545F4914F6CDD1Dull;
    for (uint32_t i = 1; i <= n; i++) {
        at += (size_t)sprintf(s + at, "v %u %u.25 -%u\n", i % 89, i % 11, i % 5);
        if (i < 12) continue;
        uint32_t c[4];
        for (int k = 0; k < 4; k++) {
            x ^= x << 13, x ^= x >> 7, x ^= x << 17;
            c[k] = 1 + (uint32_t)(x % i);
            if (c[k] % 10 == 0) c[k]--; /* positions 10, 20, ... stay unused */
        }
        if (i % 5 == 0)
            at += (size_t)sprintf(s + at, "f %u %u %u %u\n", c[0], c[1], c[2], c[3]);
        else if (i % 7 == 0)
            at += (size_t)sprintf(s + at, "f -%u %u -1\n", i - c[0] + 1, c[1]);
        else
            at += (size_t)sprintf(s + at, "f %u %u %u\n", c[0], c[1], c[2]);
    }
    *len = at;
    return s;
}

static void test_obj_positions_only_on_threads(void) {
    size_t len;
    struct mesh_data m = {0};
    struct rayd_error e = {0};
    char *s = positions_obj(20000, &len);
    CHECK(obj_n(s, len, NULL, &m, &e) == RAYD_OK && m.ntris > 20000 && m.nverts < 20000 &&
              !m.normal && !m.uv,
          "%s (%u vertices, %u triangles)", e.message, m.nverts, m.ntris);
    mesh_data_free(&m);
    struct mesh_limits lim = {100000, 20000};
    CHECK(obj_n(s, len, &lim, &m, &e) == RAYD_E_LIMIT, "%s", e.message);
    /* one face with a vt at the end: numbered in order on one thread (its
     * chunk alone has one), the uv dropped since the other corners lack it */
    const char *tail = "vt 0 0\nf 1/1 2/1 3/1\n";
    s = realloc(s, len + strlen(tail) + 1);
    memcpy(s + len, tail, strlen(tail) + 1);
    CHECK(obj_n(s, len + strlen(tail), NULL, &m, &e) == RAYD_OK && m.ntris > 20000 && !m.uv, "%s",
          e.message);
    mesh_data_free(&m);
    free(s);
}

/* ---- OBJ files others made --------------------------------------------- */

/* Every OBJ of Debian's assimp-testmodels (make test-deps installs it):
 * decoded on one thread, on 2, 3 and 8, and with the fast path for plain
 * lines off (obj_n), all alike.  Among them: number forms, many spaces,
 * a missing last line end, a long line, UTF-16, lines and points. */
static void test_obj_files_others_made(void) {
    static const char *dir = "/usr/share/assimp/models/OBJ";
    DIR *d = opendir(dir);
    CHECK(d != NULL, "%s is missing (make test-deps installs assimp-testmodels)", dir);
    if (!d) return;
    int files = 0, meshes = 0;
    for (struct dirent *f; (f = readdir(d));) {
        size_t n = strlen(f->d_name);
        if (n < 5 || strcmp(f->d_name + n - 4, ".obj")) continue;
        char path[512];
        snprintf(path, sizeof path, "%s/%s", dir, f->d_name);
        char *text;
        size_t len;
        struct rayd_error e = {0};
        if (rayd_read_file(path, (size_t)1 << 26, &text, &len, &e) != RAYD_OK) {
            CHECK(0, "%s: %s", path, e.message);
            continue;
        }
        struct mesh_data m = {0};
        if (obj_n(text, len, NULL, &m, &e) == RAYD_OK) meshes++;
        mesh_data_free(&m);
        free(text);
        files++;
    }
    closedir(d);
    CHECK(files >= 20 && meshes >= 10, "%d files, %d meshes", files, meshes);
}

/* ---- fuzz-style: truncate and corrupt at every offset ------------------- */

static int fuzz_run(int kind, const unsigned char *buf, size_t n) {
    struct mesh_data m = {0};
    struct rayd_error e = {0};
    enum rayd_status st;
    if (kind == 0) {
        st = obj_n((const char *)buf, n, NULL, &m, &e);
    } else if (kind == 1) {
        struct mesh_limits lim = {1000, 1000};
        st = ply_n(buf, n, &lim, &m, &e);
    } else {
        unsigned char *out = NULL;
        size_t len = 0;
        st = b64((const char *)buf, n, &out, &len, &e);
        free(out);
        return st == RAYD_OK || st == RAYD_E_INVALID;
    }
    if (st == RAYD_OK) {
        for (uint32_t i = 0; i < m.ntris * 3; i++)
            if (m.index[i] >= m.nverts) st = RAYD_E_INTERNAL;
    } else if (m.pos || e.message[0] == 0) {
        st = RAYD_E_INTERNAL; /* out written, or no message */
    }
    mesh_data_free(&m);
    return st == RAYD_OK || st == RAYD_E_INVALID || st == RAYD_E_LIMIT;
}

static void fuzz_one(int kind, const unsigned char *src, size_t n, const char *name) {
    static const unsigned char vals[] = {0, 0xff, '\n', ' ', '/', '-', '9', '0', '=', 'e', 0x80};
    unsigned char *buf = malloc(n);
    int bad = 0, runs = 0;
    for (size_t cut = 0; cut <= n; cut++, runs++) bad += !fuzz_run(kind, src, cut);
    for (size_t i = 0; i < n; i++)
        for (size_t k = 0; k < sizeof vals; k++) {
            memcpy(buf, src, n);
            buf[i] = vals[k];
            bad += !fuzz_run(kind, buf, n);
            runs++;
        }
    /* Bit flips at a stride, to reach into binary counts. */
    for (size_t i = 0; i < n; i += 3)
        for (int bit = 0; bit < 8; bit++) {
            memcpy(buf, src, n);
            buf[i] ^= (unsigned char)(1u << bit);
            bad += !fuzz_run(kind, buf, n);
            runs++;
        }
    free(buf);
    CHECK(bad == 0, "%s: %d of %d runs gave an unexpected status", name, bad, runs);
}

static void test_fuzz_truncate_and_corrupt(void) {
    const char *o = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 1\nvn 0 0 1\n"
                    "f 1/1/1 2/2/1 3/1/1 4/2/1\nf -1//1 -2//1 -3//1\nf 1/2 2/1 4/1\n";
    fuzz_one(0, (const unsigned char *)o, strlen(o), "OBJ");
    fuzz_one(1, (const unsigned char *)ply_ascii_cube, strlen(ply_ascii_cube), "PLY ascii");
    static struct bb w;
    build_binary(&w, false);
    fuzz_one(1, w.b, w.n, "PLY little endian");
    build_binary(&w, true);
    fuzz_one(1, w.b, w.n, "PLY big endian");
    const char *b = "TWFuIGlzIGRpc3Rpbmd1aXNoZWQs\r\nIG5vdCBvbmx5IGJ5IGhpcyByZWFzb24=\n";
    fuzz_one(2, (const unsigned char *)b, strlen(b), "base64");
}

int main(void) {
    RUN(test_number_parser);
    RUN(test_obj_plain_faces);
    RUN(test_obj_plain_face_edges);
    RUN(test_obj_face_forms);
    RUN(test_obj_negative_indices);
    RUN(test_obj_polygons_fan);
    RUN(test_obj_dedup);
    RUN(test_obj_missing_attributes_dropped);
    RUN(test_obj_merge_grows_the_table);
    RUN(test_obj_ignored_statements);
    RUN(test_obj_errors);
    RUN(test_obj_limits);
    RUN(test_ply_ascii);
    RUN(test_ply_ascii_faces_first_and_types);
    RUN(test_ply_binary_both_orders);
    RUN(test_ply_binary_truncated);
    RUN(test_ply_binary_int_counts_and_big_list);
    RUN(test_ply_tristrips);
    RUN(test_ply_errors);
    RUN(test_ply_limits);
    RUN(test_ply_binary_large_on_threads);
    RUN(test_ply_binary_fast_layout);
    RUN(test_obj_large_on_threads);
    RUN(test_obj_positions_only_on_threads);
    RUN(test_obj_files_others_made);
    RUN(test_base64_round_trip);
    RUN(test_base64_padding_and_whitespace);
    RUN(test_base64_errors);
    RUN(test_fuzz_truncate_and_corrupt);
    CHECK_EXIT();
}
