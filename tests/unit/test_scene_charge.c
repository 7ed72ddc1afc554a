/* test_scene_charge.c -- rayd_limits.charge: the loader tells its caller
 * the bytes each texture and mesh will hold before it decodes or builds
 * them, gives back what it frees, and stops where the caller refuses, with
 * the caller's status and message at the value's JSON Pointer (rayd counts
 * a parse in its memory budget this way, server/work/scenes.c). */
#include "check.h"

#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rayd/rayd.h"
#include "scene_util.h"

/* The account a test keeps: what was charged and given back, and the
 * gross charge past which it refuses (0: never). */
struct account {
    long long net, gross, refuse_past, peak;
    int calls;
};

static enum rayd_status charge(void *arg, long long bytes, char *why, size_t why_len) {
    struct account *a = arg;
    a->calls++;
    if (bytes > 0 && a->refuse_past && a->gross + bytes > a->refuse_past) {
        snprintf(why, why_len, "no room for %lld bytes", bytes);
        return RAYD_E_NOMEM;
    }
    a->net += bytes;
    if (a->net > a->peak) a->peak = a->net;
    if (bytes > 0) a->gross += bytes;
    return RAYD_OK;
}

/* A scene of a side x side PNG texture on a sphere and an inline mesh of
 * two triangles. */
static char *textured_scene(int side) {
    rayd_image *tex;
    rayd_image_new(side, side, &tex, NULL);
    char *enc = png_base64(tex);
    size_t cap = strlen(enc) + 1024;
    char *json = malloc(cap);
    snprintf(
        json, cap,
        "{\"materials\": {\"t\": {\"texture\": {\"type\": \"image\", \"png_base64\": \"%s\"}}},"
        " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, -5], \"material\": \"t\"},"
        " {\"type\": \"mesh\", \"vertices\": [0,0,-4, 1,0,-4, 0,1,-4, 1,1,-4],"
        " \"indices\": [0,1,2, 1,3,2]}]}",
        enc);
    free(enc);
    return json;
}

static rayd_scene *parse(const char *json, struct account *a, struct rayd_error *err,
                         enum rayd_status *st) {
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    CHECK(lim.charge == NULL, "no charge by default");
    lim.charge = charge;
    lim.charge_arg = a;
    rayd_scene *s = NULL;
    *st = rayd_scene_parse(json, strlen(json), &lim, &s, err);
    return s;
}

/* The texture is charged before it is decoded (its floats and 8-bit
 * pixels), the 8-bit pixels given back; the mesh charged before its build. */
static void test_charged_and_given_back(void) {
    char *json = textured_scene(256);
    struct account a = {0};
    struct rayd_error err = {0};
    enum rayd_status st;
    rayd_scene *s = parse(json, &a, &err, &st);
    CHECK(st == RAYD_OK && s, "parse: %s", err.message);
    CHECK(a.gross >= 256 * 256 * 16, "gross %lld: the texture's floats and 8-bit pixels", a.gross);
    CHECK(a.net < a.gross && a.net >= 256 * 256 * 12, "net %lld of gross %lld", a.net, a.gross);
    CHECK(a.calls >= 3, "%d calls: texture, its give-back, the mesh", a.calls);
    rayd_scene_free(s);
    free(json);
}

/* A refusal ends the parse with the caller's status and message, at the
 * value charged: the texture, or (with room for the texture) the mesh. */
static void test_refusal_stops_parse(void) {
    char *json = textured_scene(256);
    struct account a = {.refuse_past = 1000};
    struct rayd_error err = {0};
    enum rayd_status st;
    rayd_scene *s = parse(json, &a, &err, &st);
    CHECK(st == RAYD_E_NOMEM && !s, "status %d", st);
    CHECK(strcmp(err.path, "/materials/t/texture/png_base64") == 0, "path %s", err.path);
    CHECK(strstr(err.message, "no room for") != NULL, "message %s", err.message);
    struct account b = {.refuse_past = 256 * 256 * 16 + 16};
    s = parse(json, &b, &err, &st);
    CHECK(st == RAYD_E_NOMEM && !s, "status %d", st);
    CHECK(strcmp(err.path, "/objects/1/indices") == 0, "path %s", err.path);
    free(json);
}

/* A scene of one PLY mesh source (base64) of nv vertices in a row, nf
 * triangles over them; the header sizes its arrays. */
static char *ply_scene(int nv, int nf) {
    size_t cap = (size_t)(nv + nf) * 32 + 512;
    char *ply = malloc(cap), *json = malloc(2 * cap);
    int n = snprintf(ply, cap,
                     "ply\nformat ascii 1.0\nelement vertex %d\nproperty float x\n"
                     "property float y\nproperty float z\nelement face %d\n"
                     "property list uchar int vertex_indices\nend_header\n",
                     nv, nf);
    for (int i = 0; i < nv; i++) n += snprintf(ply + n, cap - (size_t)n, "%d %d -4\n", i, i % 2);
    for (int i = 0; i < nf; i++)
        n += snprintf(ply + n, cap - (size_t)n, "3 %d %d %d\n", i, i + 1, i + 2);
    char *enc = b64_encode((const unsigned char *)ply, (size_t)n);
    snprintf(json, 2 * cap,
             "{\"objects\": [{\"type\": \"mesh\", \"source\": {\"format\": \"ply\","
             " \"base64\": \"%s\"}}]}",
             enc);
    free(enc);
    free(ply);
    return json;
}

/* A PLY's arrays are charged as its header sizes them, before they are
 * allocated: a refusal there names the mesh source, and what was charged
 * is given back.  A parse that succeeds charges the arrays once (the
 * loader adds the build's share, not the arrays again). */
static void test_ply_charged_before_decode(void) {
    enum { NV = 20000, NF = NV - 2 };
    char *json = ply_scene(NV, NF);
    struct account a = {.refuse_past = NV * 12 - 1}; /* not even the positions */
    struct rayd_error err = {0};
    enum rayd_status st;
    rayd_scene *s = parse(json, &a, &err, &st);
    CHECK(st == RAYD_E_NOMEM && !s, "status %d", st);
    CHECK(strcmp(err.path, "/objects/0/source/base64") == 0, "path %s", err.path);
    CHECK(strstr(err.message, "no room for 240000 bytes") != NULL, "message %s", err.message);
    CHECK(a.net == 0, "net %lld after the refusal: all given back", a.net);
    /* room for the positions, not the triangles' first guess */
    struct account b = {.refuse_past = NV * 12 + 1000};
    s = parse(json, &b, &err, &st);
    CHECK(st == RAYD_E_NOMEM && !s, "status %d", st);
    CHECK(strcmp(err.path, "/objects/0/source/base64") == 0, "path %s", err.path);
    CHECK(strstr(err.message, "triangles") != NULL, "message %s", err.message);
    CHECK(b.net == 0 && b.gross == NV * 12, "net %lld gross %lld", b.net, b.gross);
    struct account c = {0};
    s = parse(json, &c, &err, &st);
    CHECK(st == RAYD_OK && s, "parse: %s", err.message);
    /* arrays 12 a vertex, 12 a triangle; the build's estimate 96 a
     * triangle, less its excess over the built size */
    CHECK(c.gross >= NV * 12LL + NF * 108LL && c.gross < NV * 24LL + NF * 108LL,
          "gross %lld: the arrays charged once, the build's share besides", c.gross);
    CHECK(c.net > 0 && c.net <= NV * 12LL + NF * 108LL, "net %lld", c.net);
    rayd_scene_free(s);
    free(json);
}

/* A glTF's buffer, view and accessor of nv zero vertices, stored in a
 * data: URI (positions must be: without a bufferView they are refused). */
static char *zero_positions(int nv) {
    size_t nb = (size_t)nv * 12, n64 = nb / 3 * 4, cap = n64 + 512;
    char *a = malloc(n64 + 1), *out = malloc(cap);
    memset(a, 'A', n64); /* base64 of zero bytes, nb a multiple of 3 */
    a[n64] = '\0';
    snprintf(out, cap,
             "\"buffers\": [{\"byteLength\": %zu, \"uri\": \"data:application/octet-stream;base64,"
             "%s\"}], \"bufferViews\": [{\"buffer\": 0, \"byteLength\": %zu}],"
             " \"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": %d,"
             " \"type\": \"VEC3\", \"min\": [0, 0, 0], \"max\": [0, 0, 0]}]",
             nb, a, nb, nv);
    free(a);
    return out;
}

/* A scene of a glTF of nv zero vertices, nv / 3 triangles: a mesh source,
 * or a "gltf" object. */
static char *gltf_scene(int nv, bool object) {
    char *pos = zero_positions(nv);
    size_t cap = strlen(pos) + 512;
    char *doc = malloc(cap), *json = malloc(2 * cap);
    snprintf(doc, cap,
             "{\"asset\": {\"version\": \"2.0\"}, \"scene\": 0, \"scenes\": [{\"nodes\": [0]}],"
             " \"nodes\": [{\"mesh\": 0}], \"meshes\": [{\"primitives\": [{\"attributes\":"
             " {\"POSITION\": 0}}]}], %s}",
             pos);
    char *enc = b64_encode((const unsigned char *)doc, strlen(doc));
    snprintf(json, 2 * cap,
             "{\"objects\": [{\"type\": \"%s\", \"source\": {\"format\": \"gltf\","
             " \"base64\": \"%s\"}}]}",
             object ? "gltf" : "mesh", enc);
    free(enc);
    free(doc);
    free(pos);
    return json;
}

/* A glTF's baked arrays are charged from the walk's counts before they
 * are allocated, as a mesh source and as a "gltf" object: the refusal
 * names the source, all is given back, and a parse that succeeds charges
 * the arrays once. */
static void test_gltf_charged_before_bake(void) {
    enum { NV = 30000, ARRAYS = NV * 12 + NV / 3 * 12 };
    for (int object = 0; object < 2; object++) {
        char *json = gltf_scene(NV, object);
        struct account a = {.refuse_past = ARRAYS - 1};
        struct rayd_error err = {0};
        enum rayd_status st;
        rayd_scene *s = parse(json, &a, &err, &st);
        CHECK(st == RAYD_E_NOMEM && !s, "status %d", st);
        CHECK(strcmp(err.path, "/objects/0/source/gltf") == 0, "path %s", err.path);
        CHECK(strstr(err.message, "no room for 480000 bytes") != NULL, "message %s", err.message);
        CHECK(a.net == 0, "net %lld after the refusal: all given back", a.net);
        struct account c = {0};
        s = parse(json, &c, &err, &st);
        CHECK(st == RAYD_OK && s, "parse: %s", err.message);
        /* the arrays once, the build's estimate (96 a triangle) besides */
        CHECK(c.gross >= ARRAYS + NV / 3 * 96LL && c.gross < 2LL * ARRAYS + NV / 3 * 96LL,
              "gross %lld", c.gross);
        rayd_scene_free(s);
        free(json);
    }
}

/* A scene of one OBJ mesh source (base64) of nv vertices in a row, nv - 2
 * triangles over them. */
static char *obj_scene(int nv) {
    size_t cap = (size_t)nv * 48 + 64;
    char *obj = malloc(cap), *json = malloc(2 * cap);
    size_t n = 0;
    for (int i = 0; i < nv; i++) n += (size_t)snprintf(obj + n, cap - n, "v %d %d -4\n", i, i % 2);
    for (int i = 1; i + 2 <= nv; i++)
        n += (size_t)snprintf(obj + n, cap - n, "f %d %d %d\n", i, i + 1, i + 2);
    char *enc = b64_encode((const unsigned char *)obj, n);
    snprintf(json, 2 * cap,
             "{\"objects\": [{\"type\": \"mesh\", \"source\": {\"format\": \"obj\","
             " \"base64\": \"%s\"}}]}",
             enc);
    free(enc);
    free(obj);
    return json;
}

/* An OBJ's mesh arrays are charged before its per-vertex arrays are
 * allocated, read in order (a small file) or on threads (past 1 MiB): the
 * refusal names the source, all is given back, and a parse that succeeds
 * charges the arrays once. */
static void test_obj_charged_before_arrays(void) {
    static const int sizes[] = {2000, 80000};
    for (int k = 0; k < 2; k++) {
        int nv = sizes[k];
        long long arrays = nv * 12LL + (nv - 2) * 12LL;
        char *json = obj_scene(nv);
        struct account a = {.refuse_past = arrays - 1};
        struct rayd_error err = {0};
        enum rayd_status st;
        rayd_scene *s = parse(json, &a, &err, &st);
        CHECK(st == RAYD_E_NOMEM && !s, "%d vertices: status %d", nv, st);
        CHECK(strcmp(err.path, "/objects/0/source/base64") == 0, "path %s", err.path);
        char want[64];
        snprintf(want, sizeof want, "no room for %lld bytes", arrays);
        CHECK(strstr(err.message, want) != NULL, "message %s", err.message);
        CHECK(a.net == 0 && a.calls == 1, "net %lld, %d calls", a.net, a.calls);
        struct account c = {0};
        s = parse(json, &c, &err, &st);
        CHECK(st == RAYD_OK && s, "parse: %s", err.message);
        CHECK(c.gross >= arrays + (nv - 2) * 96LL && c.gross < 2 * arrays + (nv - 2) * 96LL,
              "gross %lld", c.gross);
        rayd_scene_free(s);
        free(json);
    }
}

/* A "gltf" object of a few zero triangles whose materials (one, or two
 * of other factors) take a side x side PNG base colour texture (a data:
 * URI). */
static char *gltf_textured_scene_n(int side, int nmats) {
    rayd_image *tex;
    rayd_image_new(side, side, &tex, NULL);
    char *img = png_base64(tex);
    char *pos = zero_positions(30);
    size_t cap = strlen(img) * 2 + strlen(pos) + 2048;
    char *doc = malloc(cap), *json = malloc(2 * cap);
    snprintf(
        doc, cap,
        "{\"asset\": {\"version\": \"2.0\"}, \"scene\": 0, \"scenes\": [{\"nodes\": [0]}],"
        " \"nodes\": [{\"mesh\": 0}], \"meshes\": [{\"primitives\": [{\"attributes\":"
        " {\"POSITION\": 0}, \"material\": 0}]}], %s,"
        " \"materials\": [{\"pbrMetallicRoughness\": {\"baseColorTexture\": {\"index\": 0}}}%s],"
        " \"textures\": [{\"source\": 0}],"
        " \"images\": [{\"uri\": \"data:image/png;base64,%s\"}]}",
        pos,
        nmats > 1 ? ", {\"pbrMetallicRoughness\": {\"baseColorFactor\": [0.5, 1, 1, 1],"
                    " \"baseColorTexture\": {\"index\": 0}}}"
                  : "",
        img);
    free(pos);
    char *enc = b64_encode((const unsigned char *)doc, strlen(doc));
    snprintf(json, 2 * cap,
             "{\"objects\": [{\"type\": \"gltf\", \"source\": {\"format\": \"gltf\","
             " \"base64\": \"%s\"}}]}",
             enc);
    free(enc);
    free(doc);
    free(img);
    return json;
}

static char *gltf_textured_scene(int side) { return gltf_textured_scene_n(side, 1); }

/* A glTF's image is charged from its PNG header's size before it is
 * decoded (15 bytes a pixel: 8-bit, then floats), the 8-bit pixels given
 * back once linear; a refusal names the image, and all is given back. */
static void test_gltf_image_charged_before_decode(void) {
    char *json = gltf_textured_scene(512);
    struct account a = {.refuse_past = 1000};
    struct rayd_error err = {0};
    enum rayd_status st;
    rayd_scene *s = parse(json, &a, &err, &st);
    CHECK(st == RAYD_E_NOMEM && !s, "status %d", st);
    CHECK(strcmp(err.path, "/objects/0/source/gltf/images/0/uri") == 0, "path %s", err.path);
    CHECK(strstr(err.message, "512 x 512 pixels: no room for 3932160 bytes") != NULL, "message %s",
          err.message);
    CHECK(a.net == 0, "net %lld after the refusal: all given back", a.net);
    struct account c = {0};
    s = parse(json, &c, &err, &st);
    CHECK(st == RAYD_OK && s, "parse: %s", err.message);
    /* the texture's floats stay charged, its 8-bit pixels given back */
    CHECK(c.gross >= 512 * 512 * 15 && c.gross < 2 * 512 * 512 * 15, "gross %lld", c.gross);
    CHECK(c.net >= 512 * 512 * 12 && c.net < 512 * 512 * 15, "net %lld", c.net);
    /* at its peak the 8-bit pixels and the floats, once: 15 bytes a pixel */
    CHECK(c.peak < 512 * 512 * 16, "peak %lld: the 8-bit pixels charged twice?", c.peak);
    rayd_scene_free(s);
    free(json);
    /* two materials of one image: one decode, the 8-bit pixels charged
     * once, each material's floats; a budget under that is refused in
     * words that name the image, never a size read from freed memory */
    json = gltf_textured_scene_n(512, 2);
    struct account d = {0};
    s = parse(json, &d, &err, &st);
    CHECK(st == RAYD_OK && s, "parse: %s", err.message);
    CHECK(d.peak < 512 * 512 * 28, "peak %lld: 15 + 12 bytes a pixel, and a little", d.peak);
    CHECK(d.net >= 512 * 512 * 24 && d.net < 512 * 512 * 25, "net %lld: two materials' floats",
          d.net);
    rayd_scene_free(s);
    struct account e = {.refuse_past = 512 * 512 * 20};
    s = parse(json, &e, &err, &st);
    CHECK(st == RAYD_E_NOMEM && !s, "status %d", st);
    CHECK(strstr(err.message, "512 x 512 pixels: no room for") != NULL, "message %s", err.message);
    CHECK(e.net == 0, "net %lld after the refusal: all given back", e.net);
    free(json);
}

/* An OpenEXR environment map is charged from its header's data window
 * (its floats and sampling tables, 24 bytes a pixel) and its decoder's
 * buffers (twice a chunk: here at most the image's 12 bytes a pixel,
 * twice) before a pixel is decoded; a refusal names its "base64". */
static void test_exr_environment_charged_before_decode(void) {
    enum { W = 256, H = 128 };
    float *rgb = calloc((size_t)W * H * 3, sizeof *rgb);
    void *exr;
    size_t len;
    CHECK(rayd_exr_encode(rgb, W, H, &exr, &len, NULL) == RAYD_OK, "encode");
    free(rgb);
    char *enc = b64_encode(exr, len),
         *cut = b64_encode(exr, len / 2); /* its header whole, half its pixels */
    rayd_free(exr);
    size_t cap = strlen(enc) + 256;
    char *json = malloc(cap);
    snprintf(json, cap,
             "{\"render\": {\"environment\": {\"format\": \"exr\", \"base64\": \"%s\"}},"
             " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, -5]}]}",
             enc);
    free(enc);
    struct account a = {.refuse_past = W * H * 24 - 1};
    struct rayd_error err = {0};
    enum rayd_status st;
    rayd_scene *s = parse(json, &a, &err, &st);
    CHECK(st == RAYD_E_NOMEM && !s, "status %d", st);
    CHECK(strcmp(err.path, "/render/environment/base64") == 0, "path %s", err.path);
    const char *room = strstr(err.message, "no room for ");
    long long asked = room ? atoll(room + strlen("no room for ")) : 0;
    CHECK(asked >= W * H * 24 && asked <= W * H * (24 + 2 * 12), "message %s", err.message);
    struct account c = {0};
    s = parse(json, &c, &err, &st);
    CHECK(st == RAYD_OK && s, "parse: %s", err.message);
    CHECK(c.gross >= W * H * 24, "gross %lld", c.gross);
    rayd_scene_free(s);
    /* cut short: refused before the decode would find it so; with room,
     * the decode's error, and the charge given back */
    snprintf(json, cap,
             "{\"render\": {\"environment\": {\"format\": \"exr\", \"base64\": \"%s\"}},"
             " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, -5]}]}",
             cut);
    struct account d = {.refuse_past = W * H * 24 - 1}, f = {0};
    s = parse(json, &d, &err, &st);
    CHECK(st == RAYD_E_NOMEM && !s, "cut short, no room: status %d (%s)", st, err.message);
    s = parse(json, &f, &err, &st);
    CHECK(st == RAYD_E_INVALID && !s, "cut short: status %d (%s)", st, err.message);
    CHECK(f.net == 0, "net %lld after the decode failed", f.net);
    free(cut);
    free(json);
}

int main(void) {
    RUN(test_charged_and_given_back);
    RUN(test_refusal_stops_parse);
    RUN(test_ply_charged_before_decode);
    RUN(test_gltf_charged_before_bake);
    RUN(test_obj_charged_before_arrays);
    RUN(test_gltf_image_charged_before_decode);
    RUN(test_exr_environment_charged_before_decode);
    CHECK_EXIT();
}
