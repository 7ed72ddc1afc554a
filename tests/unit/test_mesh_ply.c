/* test_mesh_ply.c -- the PLY mesh decoder: ASCII, both binary byte orders
 * (built byte by byte here), errors, limits and the threaded paths of large
 * files (mesh_check.h: the shared harness).
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "format/mesh_io.h"
#include "mesh_check.h"

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
    struct mesh_limits lim = {.max_vertices = mv, .max_triangles = mt};
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
    struct mesh_limits lim = {.max_vertices = 1000000, .max_triangles = 2000000};
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
            struct mesh_limits lim = {.max_vertices = UINT32_MAX,
                                      .max_triangles =
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

static int fuzz_ply(const unsigned char *buf, size_t n) {
    struct mesh_data m = {0};
    struct rayd_error e = {0};
    struct mesh_limits lim = {.max_vertices = 1000, .max_triangles = 1000};
    return mesh_answer_ok(ply_n(buf, n, &lim, &m, &e), &m, &e);
}

static void test_fuzz_truncate_and_corrupt(void) {
    fuzz_one(fuzz_ply, (const unsigned char *)ply_ascii_cube, strlen(ply_ascii_cube), "PLY ascii");
    static struct bb w;
    build_binary(&w, false);
    fuzz_one(fuzz_ply, w.b, w.n, "PLY little endian");
    build_binary(&w, true);
    fuzz_one(fuzz_ply, w.b, w.n, "PLY big endian");
}

int main(void) {
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
    RUN(test_fuzz_truncate_and_corrupt);
    CHECK_EXIT();
}
