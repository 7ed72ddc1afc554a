/* test_gltf.c -- the glTF 2.0 mesh reader (core/format/mesh_gltf.c).
 *
 * One small glTF is built here: a unit quad's four positions and its two
 * triangles as UNSIGNED_BYTE, UNSIGNED_SHORT and UNSIGNED_INT indices, a
 * strip and a fan of the same quad, a points primitive, and nodes that
 * place them -- none, a matrix, a TRS, a parent with a child, and a
 * second node drawing the first mesh.  The triangles that come out must be
 * the ones worked out here by hand, corner by corner, whether the file is
 * a .glb, a .gltf with a data: URI or a .gltf whose buffer is a file.
 * Then each hostile variant of the document (made by editing the cJSON tree
 * before it is written) must be refused with its JSON Pointer and message.
 * Every input is copied into a buffer of exactly its length, so under ASan
 * a read past the end fails.
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cjson/cJSON.h>

#include "check.h"
#include "format/mesh_gltf.h"

/* ---- the buffer and the document -------------------------------------- */

/* positions 0..47, u8 indices 48..53, u16 56..67, u32 68..91, u16 strip 92..99 */
#define BIN_LEN 100
static unsigned char bin[BIN_LEN];

static void put32(unsigned char *b, uint32_t v) {
    for (int k = 0; k < 4; k++) b[k] = (unsigned char)(v >> (8 * k));
}

static void make_bin(void) {
    static const float q[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    static const int tri[6] = {0, 1, 2, 0, 2, 3}, strip[4] = {0, 1, 3, 2};
    memset(bin, 0, sizeof bin);
    memcpy(bin, q, sizeof q); /* little-endian machines only, as rayd */
    for (int i = 0; i < 6; i++) {
        bin[48 + i] = (unsigned char)tri[i];
        bin[56 + 2 * i] = (unsigned char)tri[i];
        put32(bin + 68 + 4 * i, (uint32_t)tri[i]);
    }
    for (int i = 0; i < 4; i++) bin[92 + 2 * i] = (unsigned char)strip[i];
}

static const char *doc_text =
    "{\"asset\": {\"version\": \"2.0\"},"
    " \"scene\": 0, \"scenes\": [{\"nodes\": [0, 1, 2, 3, 5]}],"
    " \"buffers\": [{\"byteLength\": 100}],"
    " \"bufferViews\": [{\"buffer\": 0, \"byteOffset\": 0, \"byteLength\": 48},"
    "                   {\"buffer\": 0, \"byteOffset\": 48, \"byteLength\": 52}],"
    " \"accessors\": ["
    "   {\"bufferView\": 0, \"componentType\": 5126, \"count\": 4, \"type\": \"VEC3\"},"
    "   {\"bufferView\": 1, \"byteOffset\": 0, \"componentType\": 5121, \"count\": 6, \"type\": "
    "\"SCALAR\"},"
    "   {\"bufferView\": 1, \"byteOffset\": 8, \"componentType\": 5123, \"count\": 6, \"type\": "
    "\"SCALAR\"},"
    "   {\"bufferView\": 1, \"byteOffset\": 20, \"componentType\": 5125, \"count\": 6, \"type\": "
    "\"SCALAR\"},"
    "   {\"bufferView\": 1, \"byteOffset\": 44, \"componentType\": 5123, \"count\": 4, \"type\": "
    "\"SCALAR\"}],"
    " \"meshes\": ["
    "   {\"primitives\": [{\"attributes\": {\"POSITION\": 0}, \"indices\": 1}]},"
    "   {\"primitives\": [{\"attributes\": {\"POSITION\": 0}, \"indices\": 2},"
    "                     {\"attributes\": {\"POSITION\": 0}, \"indices\": 3, \"mode\": 4},"
    "                     {\"attributes\": {\"POSITION\": 0}, \"mode\": 0}]},"
    "   {\"primitives\": [{\"attributes\": {\"POSITION\": 0}, \"indices\": 4, \"mode\": 5}]},"
    "   {\"primitives\": [{\"attributes\": {\"POSITION\": 0}, \"mode\": 6}]}],"
    " \"nodes\": ["
    "   {\"mesh\": 0},"
    "   {\"mesh\": 1, \"matrix\": [1,0,0,0, 0,1,0,0, 0,0,1,0, 10,0,0,1]},"
    "   {\"mesh\": 2, \"translation\": [0, 10, 0], \"scale\": [2, 2, 2],"
    "    \"rotation\": [0, 0, 0.70710678118654752, 0.70710678118654752]},"
    "   {\"translation\": [0, 0, 5], \"children\": [4]},"
    "   {\"mesh\": 3},"
    "   {\"mesh\": 0, \"translation\": [0, 0, -5]}]}";

/* A .glb of the document's text and bin. */
static unsigned char *glb_of(const char *json, size_t *len) {
    size_t jn = strlen(json), jp = (jn + 3) & ~(size_t)3, n = 12 + 8 + jp + 8 + BIN_LEN;
    unsigned char *b = calloc(1, n);
    memcpy(b, "glTF", 4);
    put32(b + 4, 2);
    put32(b + 8, (uint32_t)n);
    put32(b + 12, (uint32_t)jp);
    put32(b + 16, 0x4E4F534Au);
    memset(b + 20, ' ', jp);
    memcpy(b + 20, json, jn);
    put32(b + 20 + jp, BIN_LEN);
    put32(b + 24 + jp, 0x004E4942u);
    memcpy(b + 28 + jp, bin, BIN_LEN);
    *len = n;
    return b;
}

static char *b64(const unsigned char *p, size_t n) {
    static const char *a = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    char *o = malloc(4 * (n / 3 + 1) + 1), *w = o;
    for (size_t i = 0; i < n; i += 3) {
        uint32_t v = (uint32_t)p[i] << 16 | (i + 1 < n ? (uint32_t)p[i + 1] << 8 : 0) |
                     (i + 2 < n ? p[i + 2] : 0);
        *w++ = a[v >> 18 & 63];
        *w++ = a[v >> 12 & 63];
        *w++ = i + 1 < n ? a[v >> 6 & 63] : '=';
        *w++ = i + 2 < n ? a[v & 63] : '=';
    }
    *w = '\0';
    return o;
}

/* ---- decoding ---------------------------------------------------------- */

static enum rayd_status gltf_open_bin(void *ctx, const char *name, char **data, size_t *len,
                                      struct rayd_error *err) {
    (void)ctx;
    if (strcmp(name, "quad data.bin") != 0) {
        snprintf(err->message, sizeof err->message, "cannot open \"%s\"", name);
        return RAYD_E_INVALID;
    }
    *data = malloc(BIN_LEN);
    memcpy(*data, bin, BIN_LEN);
    *len = BIN_LEN;
    return RAYD_OK;
}

/* Decodes an exact-length copy of p[0..n). */
static enum rayd_status decode(const void *p, size_t n, const struct mesh_limits *lim,
                               struct mesh_data *m, struct rayd_error *e) {
    void *copy = malloc(n ? n : 1);
    memcpy(copy, p, n);
    struct mesh_gltf_opts o = {.max_bytes = 1 << 20, .max_nesting = 64, .open = gltf_open_bin};
    memset(e, 0, sizeof *e);
    enum rayd_status st = mesh_parse_gltf(copy, n, lim, &o, m, e);
    free(copy);
    return st;
}

static enum rayd_status decode_glb(const char *json, const struct mesh_limits *lim,
                                   struct mesh_data *m, struct rayd_error *e) {
    size_t n;
    unsigned char *g = glb_of(json, &n);
    enum rayd_status st = decode(g, n, lim, m, e);
    free(g);
    return st;
}

/* ---- the expected triangles ------------------------------------------- */

struct tri {
    double v[3][3];
};

static const double Q[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};

/* The quad's triangles (a, b, c) of Q moved by f. */
static void add_tri(struct tri *t, int *n, int a, int b, int c,
                    void (*f)(const double *, double *)) {
    int k[3] = {a, b, c};
    for (int i = 0; i < 3; i++) f(Q[k[i]], t[*n].v[i]);
    (*n)++;
}

static void id(const double *p, double *o) { memcpy(o, p, 3 * sizeof *o); }
static void plus_x10(const double *p, double *o) { o[0] = p[0] + 10, o[1] = p[1], o[2] = p[2]; }
static void plus_z5(const double *p, double *o) { o[0] = p[0], o[1] = p[1], o[2] = p[2] + 5; }
static void minus_z5(const double *p, double *o) { o[0] = p[0], o[1] = p[1], o[2] = p[2] - 5; }
/* scale 2, turn 90 degrees about z, then up 10 */
static void trs(const double *p, double *o) {
    o[0] = -2 * p[1], o[1] = 2 * p[0] + 10, o[2] = 2 * p[2];
}

static int expected(struct tri *t) {
    int n = 0;
    add_tri(t, &n, 0, 1, 2, id), add_tri(t, &n, 0, 2, 3, id);             /* node 0, u8 */
    add_tri(t, &n, 0, 1, 2, plus_x10), add_tri(t, &n, 0, 2, 3, plus_x10); /* node 1, u16 */
    add_tri(t, &n, 0, 1, 2, plus_x10), add_tri(t, &n, 0, 2, 3, plus_x10); /* u32 */
    add_tri(t, &n, 0, 1, 3, trs), add_tri(t, &n, 1, 2, 3, trs);           /* strip 0 1 3 2 */
    add_tri(t, &n, 0, 1, 2, plus_z5), add_tri(t, &n, 0, 2, 3, plus_z5);   /* fan, node 3 > 4 */
    add_tri(t, &n, 0, 1, 2, minus_z5), add_tri(t, &n, 0, 2, 3, minus_z5); /* node 5, mesh 0 again */
    return n;
}

/* Triangle t of m has the corners of want, in the same turn (any rotation). */
static bool tri_matches(const struct mesh_data *m, uint32_t t, const struct tri *want) {
    for (int r = 0; r < 3; r++) {
        bool ok = true;
        for (int k = 0; k < 3 && ok; k++) {
            const float *p = m->pos + (size_t)m->index[t * 3 + (uint32_t)((k + r) % 3)] * 3;
            for (int c = 0; c < 3; c++) ok = ok && fabs(p[c] - want->v[k][c]) < 1e-5;
        }
        if (ok) return true;
    }
    return false;
}

static void check_quads(const struct mesh_data *m, const char *what) {
    struct tri want[16];
    int n = expected(want);
    CHECK(m->ntris == (uint32_t)n, "%s: %u triangles, want %d", what, m->ntris, n);
    for (int t = 0; t < n && (uint32_t)t < m->ntris; t++)
        CHECK(tri_matches(m, (uint32_t)t, &want[t]),
              "%s: triangle %d is not (%g %g %g) (%g %g %g) (%g %g %g)", what, t, want[t].v[0][0],
              want[t].v[0][1], want[t].v[0][2], want[t].v[1][0], want[t].v[1][1], want[t].v[1][2],
              want[t].v[2][0], want[t].v[2][1], want[t].v[2][2]);
    for (uint32_t i = 0; i < m->ntris * 3; i++)
        if (m->index[i] >= m->nverts) {
            CHECK(0, "%s: index %u out of range", what, i);
            break;
        }
}

/* ---- tests --------------------------------------------------------------- */

static void test_glb(void) {
    struct mesh_data m = {0};
    struct rayd_error e;
    enum rayd_status st = decode_glb(doc_text, NULL, &m, &e);
    CHECK(st == RAYD_OK, "status %d: %s: %s", (int)st, e.path, e.message);
    if (st == RAYD_OK) check_quads(&m, "glb");
    CHECK(m.normal == NULL, "normals without NORMAL");
    mesh_data_free(&m);
}

/* The document with buffer 0's uri set to uri. */
static char *with_uri(const char *uri) {
    cJSON *d = cJSON_Parse(doc_text);
    cJSON_AddStringToObject(cJSON_GetArrayItem(cJSON_GetObjectItem(d, "buffers"), 0), "uri", uri);
    char *s = cJSON_PrintUnformatted(d);
    cJSON_Delete(d);
    return s;
}

static void test_gltf_data_uri_and_file(void) {
    char *enc = b64(bin, BIN_LEN), uri[400];
    snprintf(uri, sizeof uri, "data:application/octet-stream;base64,%s", enc);
    const char *uris[] = {uri, "quad%20data.bin"};
    for (int k = 0; k < 2; k++) {
        char *s = with_uri(uris[k]);
        struct mesh_data m = {0};
        struct rayd_error e;
        enum rayd_status st = decode(s, strlen(s), NULL, &m, &e);
        CHECK(st == RAYD_OK, "%s: status %d: %s: %s", k ? "file" : "data uri", (int)st, e.path,
              e.message);
        if (st == RAYD_OK) check_quads(&m, k ? "file" : "data uri");
        mesh_data_free(&m);
        free(s);
    }
    free(enc);
}

static void test_normals_transformed(void) {
    /* The strip's node alone, with its positions as normals too. */
    cJSON *d = cJSON_Parse(doc_text);
    cJSON *prim = cJSON_GetArrayItem(
        cJSON_GetObjectItem(cJSON_GetArrayItem(cJSON_GetObjectItem(d, "meshes"), 2), "primitives"),
        0);
    cJSON_AddNumberToObject(cJSON_GetObjectItem(prim, "attributes"), "NORMAL",
                            0); /* positions as normals */
    cJSON *nodes =
        cJSON_GetObjectItem(cJSON_GetArrayItem(cJSON_GetObjectItem(d, "scenes"), 0), "nodes");
    while (cJSON_GetArraySize(nodes) > 0) cJSON_DeleteItemFromArray(nodes, 0);
    cJSON_AddItemToArray(nodes, cJSON_CreateNumber(2));
    char *s = cJSON_PrintUnformatted(d);
    struct mesh_data m = {0};
    struct rayd_error e;
    enum rayd_status st = decode_glb(s, NULL, &m, &e);
    CHECK(st == RAYD_OK && m.normal, "status %d: %s: %s", (int)st, e.path, e.message);
    /* vertex 1 = (1, 0, 0) as a normal: turned 90 degrees about z -> (0, 1, 0) */
    if (st == RAYD_OK && m.normal) {
        CHECK_NEAR(m.normal[3], 0, 1e-6);
        CHECK_NEAR(m.normal[4], 1, 1e-6);
        CHECK_NEAR(m.normal[5], 0, 1e-6);
    }
    mesh_data_free(&m);
    free(s);
    cJSON_Delete(d);
}

/* ---- hostile variants ------------------------------------------------------ */

static cJSON *item(cJSON *d, const char *top, int i) {
    return cJSON_GetArrayItem(cJSON_GetObjectItem(d, top), i);
}

static void set_num(cJSON *o, const char *key, double v) {
    cJSON_DeleteItemFromObject(o, key);
    cJSON_AddNumberToObject(o, key, v);
}

static void v_count(cJSON *d) { set_num(item(d, "accessors", 0), "count", 100); }
static void v_offset_huge(cJSON *d) {
    set_num(item(d, "accessors", 0), "byteOffset", 9007199254740988.0);
}
static void v_index_range(cJSON *d) { set_num(item(d, "accessors", 1), "count", 60); }
static void v_cycle(cJSON *d) {
    cJSON_AddItemToObject(item(d, "nodes", 4), "children", cJSON_CreateIntArray((int[]){3}, 1));
}
static void v_two_parents(cJSON *d) {
    cJSON_AddItemToObject(item(d, "nodes", 5), "children", cJSON_CreateIntArray((int[]){4}, 1));
}
static void v_draco(cJSON *d) {
    cJSON_AddItemToObject(
        d, "extensionsRequired",
        cJSON_CreateStringArray((const char *[]){"KHR_draco_mesh_compression"}, 1));
}
static void v_unknown_ext(cJSON *d) {
    cJSON_AddItemToObject(
        d, "extensionsRequired",
        cJSON_CreateStringArray((const char *[]){"KHR_materials_unlit", "EXT_future"}, 2));
}
static void v_sparse(cJSON *d) {
    cJSON_AddItemToObject(item(d, "accessors", 0), "sparse", cJSON_CreateObject());
}
static void v_pos_no_view(cJSON *d) {
    cJSON_DeleteItemFromObject(item(d, "accessors", 0), "bufferView");
}
static void v_ix_no_view(cJSON *d) {
    cJSON_DeleteItemFromObject(item(d, "accessors", 1), "bufferView");
}
static void v_view_past(cJSON *d) { set_num(item(d, "bufferViews", 1), "byteLength", 60); }
static void v_mesh_ref(cJSON *d) { set_num(item(d, "nodes", 0), "mesh", 99); }
static void v_version(cJSON *d) {
    cJSON_ReplaceItemInObject(cJSON_GetObjectItem(d, "asset"), "version",
                              cJSON_CreateString("1.0"));
}
static void v_no_uri(cJSON *d) {
    cJSON_AddStringToObject(item(d, "buffers", 0), "uri", "../elsewhere.bin");
}
static void v_http_uri(cJSON *d) {
    cJSON_AddStringToObject(item(d, "buffers", 0), "uri", "https://example.com/x.bin");
}
static void v_bad_type(cJSON *d) {
    cJSON_ReplaceItemInObject(item(d, "accessors", 0), "type", cJSON_CreateString("VEC2"));
}
static void v_float_index(cJSON *d) { set_num(item(d, "accessors", 1), "componentType", 5126); }
static void v_stride(cJSON *d) { set_num(item(d, "bufferViews", 0), "byteStride", 8); }
static void v_mode(cJSON *d) {
    set_num(cJSON_GetArrayItem(cJSON_GetObjectItem(item(d, "meshes", 0), "primitives"), 0), "mode",
            7);
}
static void v_points_only(cJSON *d) {
    cJSON *nodes = cJSON_GetObjectItem(item(d, "scenes", 0), "nodes");
    while (cJSON_GetArraySize(nodes) > 0) cJSON_DeleteItemFromArray(nodes, 0);
    cJSON_AddItemToArray(nodes, cJSON_CreateNumber(6));
    cJSON *n = cJSON_CreateObject();
    cJSON_AddNumberToObject(n, "mesh", 4);
    cJSON_AddItemToArray(cJSON_GetObjectItem(d, "nodes"), n);
    cJSON *m = cJSON_Parse("{\"primitives\": [{\"attributes\": {\"POSITION\": 0}, \"mode\": 1}]}");
    cJSON_AddItemToArray(cJSON_GetObjectItem(d, "meshes"), m);
}
static void v_deep(cJSON *d) {
    cJSON *nodes = cJSON_GetObjectItem(d, "nodes");
    for (int i = 6; i < 6 + 300; i++) {
        cJSON *n = cJSON_CreateObject();
        if (i + 1 < 6 + 300)
            cJSON_AddItemToObject(n, "children", cJSON_CreateIntArray((int[]){i + 1}, 1));
        cJSON_AddItemToArray(nodes, n);
    }
    cJSON_AddItemToArray(cJSON_GetObjectItem(item(d, "scenes", 0), "nodes"), cJSON_CreateNumber(6));
}
static void v_nan_matrix(cJSON *d) {
    cJSON_ReplaceItemInObject(item(d, "nodes", 1), "matrix", cJSON_CreateString("x"));
}
/* Required values missing and arrays cut short: each refused where it is,
 * never read (clang's analyzer followed these paths on into values never
 * written; ASan and the messages here say they stop). */
static void v_no_buffer_len(cJSON *d) {
    cJSON_DeleteItemFromObject(item(d, "buffers", 0), "byteLength");
}
static void v_no_view_buffer(cJSON *d) {
    cJSON_DeleteItemFromObject(item(d, "bufferViews", 0), "buffer");
}
static void v_no_view_len(cJSON *d) {
    cJSON_DeleteItemFromObject(item(d, "bufferViews", 0), "byteLength");
}
static void v_no_count(cJSON *d) { cJSON_DeleteItemFromObject(item(d, "accessors", 0), "count"); }
static void v_no_ctype(cJSON *d) {
    cJSON_DeleteItemFromObject(item(d, "accessors", 0), "componentType");
}
static void v_no_position(cJSON *d) {
    cJSON *p = cJSON_GetArrayItem(cJSON_GetObjectItem(item(d, "meshes", 0), "primitives"), 0);
    cJSON_DeleteItemFromObject(cJSON_GetObjectItem(p, "attributes"), "POSITION");
}
static void v_short_rotation(cJSON *d) {
    cJSON_ReplaceItemInObject(item(d, "nodes", 2), "rotation",
                              cJSON_CreateIntArray((int[]){0, 0, 1}, 3));
}
static void v_short_matrix(cJSON *d) {
    cJSON *m = cJSON_GetObjectItem(item(d, "nodes", 1), "matrix");
    cJSON_DeleteItemFromArray(m, 15);
}
static void v_translation_str(cJSON *d) {
    cJSON_ReplaceItemInArray(cJSON_GetObjectItem(item(d, "nodes", 2), "translation"), 1,
                             cJSON_CreateString("x"));
}

struct hostile {
    const char *name;
    void (*edit)(cJSON *);
    enum rayd_status code;
    const char *path, *msg;
};

static void test_hostile(void) {
    static const struct hostile h[] = {
        {"count", v_count, RAYD_E_INVALID, "/accessors/0/count", "exceeds the buffer view"},
        {"offset_huge", v_offset_huge, RAYD_E_INVALID, "/accessors/0/count",
         "exceeds the buffer view"},
        {"index_range", v_index_range, RAYD_E_INVALID, "/accessors/1/count", "exceeds"},
        {"cycle", v_cycle, RAYD_E_INVALID, "/nodes/4/children/0", "its own ancestor"},
        {"two_parents", v_two_parents, RAYD_E_INVALID, "/nodes/5/children/0", "reached twice"},
        {"draco", v_draco, RAYD_E_INVALID, "/extensionsRequired/0",
         "compressed meshes are not supported"},
        {"unknown_ext", v_unknown_ext, RAYD_E_INVALID, "/extensionsRequired/1",
         "\"EXT_future\" is not supported"},
        {"sparse", v_sparse, RAYD_E_INVALID, "/accessors/0/sparse", "not supported"},
        {"pos_no_view", v_pos_no_view, RAYD_E_INVALID, "/accessors/0/bufferView",
         "is required for POSITION"},
        {"ix_no_view", v_ix_no_view, RAYD_E_INVALID, "/accessors/1/bufferView",
         "is required for indices"},
        {"view_past", v_view_past, RAYD_E_INVALID, "/bufferViews/1/byteLength",
         "runs past the end of buffer 0"},
        {"mesh_ref", v_mesh_ref, RAYD_E_INVALID, "/nodes/0/mesh",
         "99 is not an index into /meshes"},
        {"version", v_version, RAYD_E_INVALID, "/asset/version", "not supported"},
        {"file_missing", v_no_uri, RAYD_E_INVALID, "/buffers/0/uri",
         "cannot open \"../elsewhere.bin\""},
        {"http_uri", v_http_uri, RAYD_E_INVALID, "/buffers/0/uri", "only data: URIs"},
        {"bad_type", v_bad_type, RAYD_E_INVALID, "/accessors/0/type", "must be \"VEC3\""},
        {"float_index", v_float_index, RAYD_E_INVALID, "/accessors/1/componentType",
         "indices must be"},
        {"stride", v_stride, RAYD_E_INVALID, "/bufferViews/0/byteStride", "less than"},
        {"mode", v_mode, RAYD_E_INVALID, "/meshes/0/primitives/0/mode", "must be in 0..6"},
        {"points_only", v_points_only, RAYD_E_INVALID, "", "no triangles"},
        {"deep", v_deep, RAYD_E_LIMIT, "/nodes/", "nest more than"},
        {"matrix_type", v_nan_matrix, RAYD_E_INVALID, "/nodes/1/matrix", "array of 16 numbers"},
        {"no_buffer_len", v_no_buffer_len, RAYD_E_INVALID, "/buffers/0/byteLength", "is required"},
        {"no_view_buffer", v_no_view_buffer, RAYD_E_INVALID, "/bufferViews/0/buffer",
         "is required"},
        {"no_view_len", v_no_view_len, RAYD_E_INVALID, "/bufferViews/0/byteLength", "is required"},
        {"no_count", v_no_count, RAYD_E_INVALID, "/accessors/0/count", "is required"},
        {"no_ctype", v_no_ctype, RAYD_E_INVALID, "/accessors/0/componentType", "is required"},
        {"no_position", v_no_position, RAYD_E_INVALID, "/meshes/0/primitives/0/attributes/POSITION",
         "is required"},
        {"short_rotation", v_short_rotation, RAYD_E_INVALID, "/nodes/2/rotation",
         "array of 4 numbers"},
        {"short_matrix", v_short_matrix, RAYD_E_INVALID, "/nodes/1/matrix", "array of 16 numbers"},
        {"translation_str", v_translation_str, RAYD_E_INVALID, "/nodes/2/translation/1",
         "must be a finite number"},
    };
    for (size_t i = 0; i < sizeof h / sizeof h[0]; i++) {
        cJSON *d = cJSON_Parse(doc_text);
        h[i].edit(d);
        char *s = cJSON_PrintUnformatted(d);
        struct mesh_data m = {0};
        struct rayd_error e;
        enum rayd_status st = decode_glb(s, NULL, &m, &e);
        CHECK(st == h[i].code, "%s: status %d, want %d (%s: %s)", h[i].name, (int)st,
              (int)h[i].code, e.path, e.message);
        CHECK(!strncmp(e.path, h[i].path, strlen(h[i].path)) && (h[i].path[0] || !e.path[0]),
              "%s: path '%s', want '%s'", h[i].name, e.path, h[i].path);
        CHECK(strstr(e.message, h[i].msg) != NULL, "%s: message '%s' lacks '%s'", h[i].name,
              e.message, h[i].msg);
        CHECK(m.pos == NULL && m.index == NULL, "%s: out written on error", h[i].name);
        mesh_data_free(&m);
        free(s);
        cJSON_Delete(d);
    }
}

/* An index out of range, found while baking (the u8 list's last index 3 -> 9). */
static void test_index_value(void) {
    struct mesh_data m = {0};
    struct rayd_error e;
    bin[53] = 9;
    enum rayd_status st = decode_glb(doc_text, NULL, &m, &e);
    make_bin();
    CHECK(st == RAYD_E_INVALID && !strcmp(e.path, "/accessors/1"), "status %d at '%s'", (int)st,
          e.path);
    CHECK(strstr(e.message, "element 5 is 9, out of range") != NULL, "message '%s'", e.message);
    float inf = INFINITY;
    memcpy(bin + 16, &inf, 4); /* y of vertex 1 */
    st = decode_glb(doc_text, NULL, &m, &e);
    make_bin();
    CHECK(st == RAYD_E_INVALID && !strcmp(e.path, "/accessors/0") &&
              strstr(e.message, "POSITION 1 is not finite"),
          "status %d at '%s': %s", (int)st, e.path, e.message);
}

static void test_limits_and_container(void) {
    struct mesh_data m = {0};
    struct rayd_error e;
    struct mesh_limits lim = {.max_vertices = 1000, .max_triangles = 7};
    enum rayd_status st = decode_glb(doc_text, &lim, &m, &e);
    CHECK(st == RAYD_E_LIMIT && !strcmp(e.path, "/meshes/2/primitives/0") &&
              strstr(e.message, "8 triangles; the limit is 7"),
          "triangles: status %d at '%s': %s", (int)st, e.path, e.message);
    struct mesh_limits dlim = {.max_vertices = 1000,
                               .max_triangles = 5}; /* the 6th primitive drawn: node 5's mesh 0 */
    st = decode_glb(doc_text, &dlim, &m, &e);
    CHECK(st == RAYD_E_LIMIT && !strcmp(e.path, "/meshes/0/primitives/0") &&
              strstr(e.message, "more than 5 triangle primitives"),
          "draws: status %d at '%s': %s", (int)st, e.path, e.message);
    struct mesh_limits vlim = {.max_vertices = 15, .max_triangles = 1000};
    st = decode_glb(doc_text, &vlim, &m, &e);
    CHECK(st == RAYD_E_LIMIT && strstr(e.message, "16 vertices; the limit is 15"),
          "vertices: %d %s", (int)st, e.message);
    size_t n;
    unsigned char *g = glb_of(doc_text, &n);
    put32(g + 12, 1u << 30); /* the JSON chunk's length */
    st = decode(g, n, NULL, &m, &e);
    CHECK(st == RAYD_E_INVALID && strstr(e.message, "GLB chunk 0 runs past the end"),
          "chunk: %d %s", (int)st, e.message);
    for (size_t cut = 0; cut < n; cut += 7) { /* every truncation is refused, none crashes */
        st = decode(g, cut, NULL, &m, &e);
        CHECK(st != RAYD_OK, "a .glb cut to %zu bytes was read", cut);
    }
    free(g);
    const char *bad = "{\"asset\": {\"version\": \"2.0\"},\n \"nodes\": [}";
    st = decode(bad, strlen(bad), NULL, &m, &e);
    CHECK(st == RAYD_E_INVALID && !strcmp(e.path, "") &&
              strstr(e.message, "glTF JSON line 2, column"),
          "syntax: %d '%s'", (int)st, e.message);
    struct mesh_gltf_opts o = {.max_bytes = 99, .max_nesting = 64, .open = gltf_open_bin};
    char *s = with_uri("quad%20data.bin");
    st = mesh_parse_gltf(s, strlen(s), NULL, &o, &m, &e);
    CHECK(st == RAYD_E_LIMIT && !strcmp(e.path, "/buffers/0/byteLength"), "bytes: %d '%s' %s",
          (int)st, e.path, e.message);
    o.open = NULL;
    st = mesh_parse_gltf(s, strlen(s), NULL, &o, &m, &e);
    CHECK(st == RAYD_E_INVALID && strstr(e.message, "no files are read here"), "no opener: %d %s",
          (int)st, e.message);
    free(s);
}

/* An accessor without a bufferView is all zeros: a few bytes of JSON that
 * stand for count elements.  As positions or indices that would be
 * triangles of no area (refused: test_hostile's pos_no_view, ix_no_view);
 * as anything else they count against max_bytes as if read, so a few
 * bytes cannot stand for more than the limit; at the limit they decode.
 * Here a NORMAL of 4 zeros (48 bytes) on mesh 0, which two nodes draw: 96. */
static void test_accessor_without_view(void) {
    cJSON *d = cJSON_Parse(doc_text);
    cJSON *acc = cJSON_CreateObject();
    cJSON_AddNumberToObject(acc, "componentType", 5126);
    cJSON_AddNumberToObject(acc, "count", 4);
    cJSON_AddStringToObject(acc, "type", "VEC3");
    cJSON_AddItemToArray(cJSON_GetObjectItem(d, "accessors"), acc); /* accessor 5 */
    cJSON *p = cJSON_GetArrayItem(cJSON_GetObjectItem(item(d, "meshes", 0), "primitives"), 0);
    cJSON_AddNumberToObject(cJSON_GetObjectItem(p, "attributes"), "NORMAL", 5);
    char *s = cJSON_PrintUnformatted(d);
    size_t n;
    unsigned char *g = glb_of(s, &n);
    struct mesh_data m = {0};
    struct rayd_error e = {0};
    struct mesh_gltf_opts o = {.max_bytes = 95, .max_nesting = 64};
    enum rayd_status st = mesh_parse_gltf((const char *)g, n, NULL, &o, &m, &e);
    CHECK(st == RAYD_E_LIMIT && !strcmp(e.path, "/accessors/5/count") &&
              strstr(e.message, "no bufferView") && strstr(e.message, "to 96;"),
          "zeros over max_bytes: %d '%s' %s", (int)st, e.path, e.message);
    o.max_bytes = 96;
    memset(&e, 0, sizeof e);
    st = mesh_parse_gltf((const char *)g, n, NULL, &o, &m, &e);
    CHECK(st == RAYD_OK && m.ntris > 0, "zeros at max_bytes: %d %s, %u triangles", (int)st,
          e.message, m.ntris);
    mesh_data_free(&m);
    free(g);
    free(s);
    cJSON_Delete(d);
}

int main(void) {
    make_bin();
    RUN(test_accessor_without_view);
    RUN(test_glb);
    RUN(test_gltf_data_uri_and_file);
    RUN(test_normals_transformed);
    RUN(test_hostile);
    RUN(test_index_value);
    RUN(test_limits_and_container);
    CHECK_EXIT();
}
