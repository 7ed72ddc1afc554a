/* test_mesh_obj.c -- the OBJ mesh decoder, and the number parser it
 * shares with ASCII PLY (mesh_check.h: the shared harness).
 */
#include <dirent.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "format/mesh_io.h"
#include "mesh_check.h"

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
    struct mesh_limits lim = {.max_vertices = mv, .max_triangles = mt};
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
        case 0: at += (size_t)sprintf(s + at, "f %u %u %u\n", i + 1, i, i - 1); break;
        case 1: at += (size_t)sprintf(s + at, "f -1/-1 -2/-2 -3/-3 %u/1\n", i / 2 + 1); break;
        case 2: at += (size_t)sprintf(s + at, "f %u//%u -2//-1 1//1\n", i % 50 + 1, i); break;
        default: at += (size_t)sprintf(s + at, "g x\r\nf %u/%u/%u -2/-2/-2 -3/1/-1\n", i, i, i);
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
    struct mesh_limits lim = {.max_vertices = 100000, .max_triangles = 5000};
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
    struct mesh_limits lim = {.max_vertices = 100000, .max_triangles = 20000};
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

static int fuzz_obj(const unsigned char *buf, size_t n) {
    struct mesh_data m = {0};
    struct rayd_error e = {0};
    return mesh_answer_ok(obj_n((const char *)buf, n, NULL, &m, &e), &m, &e);
}

static void test_fuzz_truncate_and_corrupt(void) {
    const char *o = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 1\nvn 0 0 1\n"
                    "f 1/1/1 2/2/1 3/1/1 4/2/1\nf -1//1 -2//1 -3//1\nf 1/2 2/1 4/1\n";
    fuzz_one(fuzz_obj, (const unsigned char *)o, strlen(o), "OBJ");
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
    RUN(test_obj_large_on_threads);
    RUN(test_obj_positions_only_on_threads);
    RUN(test_obj_files_others_made);
    RUN(test_fuzz_truncate_and_corrupt);
    CHECK_EXIT();
}
