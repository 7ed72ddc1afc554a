/* test_mesh_cache.c -- mesh sources (OBJ, PLY) shared between scenes
 * through a rayd_asset_cache (core/geom/mesh_share.c): decoded and built
 * once while a scene holds them, the same pixels as building them, the
 * same limits and memory charged, told apart by every byte, and nothing
 * kept once no scene holds them. */
#include <stdint.h>
#include <stdlib.h>
#include <unistd.h>

#include "check.h"
#include "scene/scene.h"
#include "scene_util.h"

/* An OBJ of a wavy n x n grid of quads (2 n^2 triangles); malloc'd. */
static char *grid_obj(int n) {
    size_t cap = (size_t)(n + 1) * (n + 1) * 48 + (size_t)n * n * 48 + 64;
    char *t = malloc(cap), *p = t;
    for (int j = 0; j <= n; j++)
        for (int i = 0; i <= n; i++)
            p += sprintf(p, "v %.5f %.5f %.5f\n", 2.0 * i / n - 1, 2.0 * j / n - 1,
                         0.2 * sin(7.0 * i / n) * cos(5.0 * j / n));
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            int a = j * (n + 1) + i + 1, b = a + 1, c = a + n + 1, d = c + 1;
            p += sprintf(p, "f %d %d %d\nf %d %d %d\n", a, b, d, a, d, c);
        }
    return t;
}

/* A scene of the mesh given as source (a JSON object's text); malloc'd. */
static char *mesh_scene(const char *source, bool smooth) {
    size_t cap = strlen(source) + 512;
    char *json = malloc(cap);
    snprintf(json, cap,
             "{\"render\": {\"width\": 48, \"height\": 32},"
             " \"camera\": {\"position\": [0, -1.5, 3], \"look_at\": [0, 0, 0]},"
             " \"lights\": [{\"type\": \"point\", \"position\": [1, -2, 4]}],"
             " \"objects\": [{\"type\": \"mesh\", \"smooth\": %s, \"source\": %s}]}",
             smooth ? "true" : "false", source);
    return json;
}

/* The grid as an OBJ "text" source's JSON. */
static char *obj_source(const char *obj) {
    size_t cap = strlen(obj) * 2 + 64;
    char *s = malloc(cap), *p = s;
    p += sprintf(p, "{\"format\": \"obj\", \"text\": \"");
    for (const char *c = obj; *c; c++) p += *c == '\n' ? sprintf(p, "\\n") : sprintf(p, "%c", *c);
    sprintf(p, "\"}");
    return s;
}

/* A memory account that refuses past left bytes, as rayd's budget does,
 * and keeps its low-water mark: cap - low is the parse's peak charge. */
struct account {
    long long left, low;
};

static enum rayd_status cap_charge(void *arg, long long bytes, char *why, size_t why_len) {
    struct account *a = arg;
    if (bytes > a->left) {
        snprintf(why, why_len, "over the cap by %lld bytes", bytes - a->left);
        return RAYD_E_LIMIT;
    }
    a->left -= bytes;
    if (a->left < a->low) a->low = a->left;
    return RAYD_OK;
}

/* json parsed with cache c, a vertex and triangle limit (0: the default),
 * asset folder dir (or NULL) and memory account acct (NULL: none); NULL
 * with err on failure. */
static rayd_scene *parse_in(const char *json, rayd_asset_cache *c, long max_verts, long max_tris,
                            const char *dir, struct account *acct, struct rayd_error *err) {
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    lim.assets = c;
    lim.asset_dir = dir;
    if (max_verts) lim.max_vertices = max_verts;
    if (max_tris) lim.max_triangles = max_tris;
    if (acct) {
        acct->low = acct->left;
        lim.charge = cap_charge;
        lim.charge_arg = acct;
    }
    rayd_scene *s = NULL;
    memset(err, 0, sizeof *err);
    return rayd_scene_parse(json, strlen(json), &lim, &s, err) == RAYD_OK ? s : NULL;
}

static rayd_scene *parse(const char *json, rayd_asset_cache *c, long max_tris, long long *left,
                         struct rayd_error *err) {
    struct account a = {left ? *left : 0, 0};
    rayd_scene *s = parse_in(json, c, 0, max_tris, NULL, left ? &a : NULL, err);
    if (left) *left = a.left;
    return s;
}

static bool same_pixels(const rayd_image *a, const rayd_image *b) {
    return a && b &&
           !memcmp(rayd_image_pixels((rayd_image *)(uintptr_t)a),
                   rayd_image_pixels((rayd_image *)(uintptr_t)b), 48 * 32 * 3);
}

static int lit_pixels(rayd_image *img) {
    const uint8_t *p = rayd_image_pixels(img);
    int n = 0;
    for (int i = 0; i < 48 * 32; i++) n += p[3 * i] > 20;
    return n;
}

static void hits_misses(rayd_asset_cache *c, long *hits, long *misses) {
    rayd_asset_cache_stats(c, RAYD_ASSET_MESH, hits, misses);
}

static void test_built_once_same_pixels(void) {
    char *obj = grid_obj(24), *src = obj_source(obj), *json = mesh_scene(src, true);
    struct rayd_error err;
    long long left_plain = 1LL << 40, left1 = 1LL << 40, left2 = 1LL << 40;
    rayd_scene *plain = parse(json, NULL, 0, &left_plain, &err);
    rayd_asset_cache *c = rayd_asset_cache_new(0);
    rayd_scene *s1 = parse(json, c, 0, &left1, &err), *s2 = parse(json, c, 0, &left2, &err);
    CHECK(plain && s1 && s2, "parse: %s", err.message);
    long hits, misses;
    hits_misses(c, &hits, &misses);
    CHECK(misses == 1 && hits == 1, "hits %ld, misses %ld; want 1 and 1", hits, misses);
    if (s1 && s2)
        CHECK(s1->meshes[0].blocks == s2->meshes[0].blocks &&
                  s1->meshes[0].normal == s2->meshes[0].normal && s1->meshes[0].normal,
              "the mesh is not shared");
    /* the same charge left whether built or taken: the limits see no difference */
    CHECK(left1 == left2, "charged %lld building, %lld taking", (1LL << 40) - left1,
          (1LL << 40) - left2);
    /* what a scene holds counts the shared source bytes too, as a shared image does */
    CHECK(left1 < left_plain, "the shared bytes are not counted (%lld, plain %lld)", left1,
          left_plain);
    rayd_asset_cache_free(c); /* the scenes keep their mesh */
    rayd_image *want = plain ? render_all(plain, 2) : NULL;
    rayd_image *got1 = s1 ? render_all(s1, 2) : NULL;
    rayd_scene_free(s1); /* s2's mesh outlives s1's reference (ASan: no use after free) */
    rayd_image *got2 = s2 ? render_all(s2, 1) : NULL;
    CHECK(same_pixels(want, got1) && same_pixels(want, got2), "a shared mesh renders differently");
    CHECK(want && lit_pixels(want) > 200, "the mesh does not show: the check proves little");
    rayd_image_free(want);
    rayd_image_free(got1);
    rayd_image_free(got2);
    rayd_scene_free(s2);
    rayd_scene_free(plain);
    free(json), free(src), free(obj);
}

/* The first digit 1-8 of text from its middle on. */
static size_t middle_digit(const char *text, size_t len) {
    for (size_t at = len / 2; at < len; at++)
        if (text[at] >= '1' && text[at] <= '8') return at;
    return 0;
}

static void test_every_byte_tells(void) {
    /* a source that differs from another in one byte, or in its
     * smoothing, is another mesh */
    char *obj = grid_obj(24), *src = obj_source(obj);
    char *json = mesh_scene(src, true), *flat = mesh_scene(src, false);
    size_t at = middle_digit(obj, strlen(obj));
    CHECK(at > 0, "no digit: the check proves nothing");
    obj[at]++;
    char *src2 = obj_source(obj), *json2 = mesh_scene(src2, true);
    struct rayd_error err;
    rayd_asset_cache *c = rayd_asset_cache_new(0);
    rayd_scene *a = parse(json, c, 0, NULL, &err), *b = parse(json2, c, 0, NULL, &err);
    rayd_scene *f = parse(flat, c, 0, NULL, &err);
    CHECK(a && b && f, "parse: %s", err.message);
    long hits, misses;
    hits_misses(c, &hits, &misses);
    CHECK(hits == 0 && misses == 3, "hits %ld, misses %ld; want 0 and 3", hits, misses);
    if (a && b && f)
        CHECK(a->meshes[0].blocks != b->meshes[0].blocks && !f->meshes[0].normal,
              "another source took this one's mesh");
    rayd_scene_free(a), rayd_scene_free(b), rayd_scene_free(f);
    rayd_asset_cache_free(c);
    free(json), free(json2), free(flat), free(src), free(src2), free(obj);
}

static void test_limits_hold_the_same(void) {
    /* room for fewer triangles than the mesh has: refused whether a live
     * scene holds it or not, with the decoder's path and words; and a
     * memory account with no room for its build likewise */
    char *obj = grid_obj(24), *src = obj_source(obj), *json = mesh_scene(src, true);
    struct rayd_error plain_err, err;
    rayd_asset_cache *c = rayd_asset_cache_new(0);
    rayd_scene *keep = parse(json, c, 0, NULL, &err);
    rayd_scene *a = parse(json, NULL, 1000, NULL, &plain_err);
    rayd_scene *b = parse(json, c, 1000, NULL, &err);
    CHECK(keep && !a && !b, "a scene over its triangle limit was taken");
    CHECK(!strcmp(plain_err.path, err.path) && !strcmp(plain_err.message, err.message) &&
              *err.message,
          "'%s: %s' against '%s: %s'", err.path, err.message, plain_err.path, plain_err.message);
    long long need = 1LL << 40, room;
    rayd_scene_free(parse(json, NULL, 0, &need, &err));
    need = (1LL << 40) - need; /* what a plain parse keeps charged */
    room = need;               /* its decode's peak is more than that */
    a = parse(json, NULL, 0, &room, &plain_err);
    room = need;
    b = parse(json, c, 0, &room, &err);
    CHECK(!a && !b, "a scene over its memory account was taken (%s, %s)", a ? "plain" : "-",
          b ? "shared" : "-");
    CHECK(!strcmp(plain_err.path, err.path) && !strcmp(plain_err.message, err.message),
          "'%s: %s' against '%s: %s'", err.path, err.message, plain_err.path, plain_err.message);
    rayd_scene_free(a), rayd_scene_free(b), rayd_scene_free(keep);
    rayd_asset_cache_free(c);
    free(json), free(src), free(obj);
}

static void test_holding_cache_and_files(void) {
    /* rayd-render's cache: a file's mesh outlives each scene until the
     * cache goes; with no scene left the cache goes with its last mesh */
    char dir[] = "/tmp/rayd-mesh-cache-XXXXXX";
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    char path[96];
    snprintf(path, sizeof path, "%s/grid.obj", dir);
    char *obj = grid_obj(16);
    FILE *fp = fopen(path, "w");
    fputs(obj, fp);
    fclose(fp);
    char *json = mesh_scene("{\"file\": \"grid.obj\"}", true);
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    lim.asset_dir = dir;
    rayd_asset_cache *c = rayd_asset_cache_new(1);
    lim.assets = c;
    struct rayd_error err;
    rayd_scene *s = NULL, *t = NULL;
    CHECK(rayd_scene_parse(json, strlen(json), &lim, &s, &err) == RAYD_OK, "%s", err.message);
    rayd_scene_free(s);
    CHECK(rayd_scene_parse(json, strlen(json), &lim, &t, &err) == RAYD_OK, "%s", err.message);
    long hits, misses;
    hits_misses(c, &hits, &misses);
    CHECK(hits == 1 && misses == 1, "hits %ld, misses %ld; want 1 and 1", hits, misses);
    rayd_asset_cache_free(c); /* t keeps its mesh; freed with t (ASan: no leak) */
    rayd_image *img = t ? render_all(t, 1) : NULL;
    CHECK(img && lit_pixels(img) > 200, "the scene lost its mesh");
    rayd_image_free(img);
    rayd_scene_free(t);
    c = rayd_asset_cache_new(0); /* a server's: nothing kept without a scene */
    lim.assets = c;
    for (int k = 0; k < 2; k++) {
        s = NULL;
        CHECK(rayd_scene_parse(json, strlen(json), &lim, &s, &err) == RAYD_OK, "%s", err.message);
        rayd_scene_free(s);
    }
    hits_misses(c, &hits, &misses);
    CHECK(hits == 0 && misses == 2, "hits %ld, misses %ld; want 0 and 2", hits, misses);
    rayd_asset_cache_free(c);
    unlink(path);
    rmdir(dir);
    free(json), free(obj);
}

/* The grid as inline arrays' JSON (the object's keys after "type"). */
static char *grid_inline(int n, double lift) {
    size_t cap = (size_t)(n + 1) * (n + 1) * 40 + (size_t)n * n * 48 + 64;
    char *t = malloc(cap), *p = t;
    p += sprintf(p, "\"vertices\": [");
    for (int j = 0; j <= n; j++)
        for (int i = 0; i <= n; i++)
            p += sprintf(p, "%s%.5f, %.5f, %.5f", i + j ? ", " : "", 2.0 * i / n - 1,
                         2.0 * j / n - 1, (i == n && j == n ? lift : 0) + 0.1 * sin(3.0 * i / n));
    p += sprintf(p, "], \"indices\": [");
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            int a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
            p += sprintf(p, "%s%d, %d, %d, %d, %d, %d", i + j ? ", " : "", a, b, d, a, d, c);
        }
    sprintf(p, "]");
    return t;
}

static char *inline_scene(const char *arrays) {
    size_t cap = strlen(arrays) + 512;
    char *json = malloc(cap);
    snprintf(json, cap,
             "{\"render\": {\"width\": 48, \"height\": 32},"
             " \"camera\": {\"position\": [0, -1.5, 3], \"look_at\": [0, 0, 0]},"
             " \"lights\": [{\"type\": \"point\", \"position\": [1, -2, 4]}],"
             " \"objects\": [{\"type\": \"mesh\", %s}]}",
             arrays);
    return json;
}

static void test_inline_arrays_shared(void) {
    /* large inline arrays are read from the text (scene_json_inline.c):
     * their text is the key; one number changed is another mesh; a small
     * mesh is read again, not offered */
    char *a = grid_inline(24, 0), *b = grid_inline(24, 0.5), *small = grid_inline(3, 0);
    char *ja = inline_scene(a), *jb = inline_scene(b), *js = inline_scene(small);
    struct rayd_error err;
    long long left_plain = 1LL << 40, left1 = 1LL << 40, left2 = 1LL << 40;
    rayd_scene *plain = parse(ja, NULL, 0, &left_plain, &err);
    rayd_asset_cache *c = rayd_asset_cache_new(0);
    rayd_scene *s1 = parse(ja, c, 0, &left1, &err), *s2 = parse(ja, c, 0, &left2, &err);
    rayd_scene *s3 = parse(jb, c, 0, NULL, &err), *s4 = parse(js, c, 0, NULL, &err);
    CHECK(plain && s1 && s2 && s3 && s4, "parse: %s", err.message);
    long hits, misses;
    hits_misses(c, &hits, &misses);
    CHECK(hits == 1 && misses == 2, "hits %ld, misses %ld; want 1 and 2", hits, misses);
    if (s1 && s2 && s3)
        CHECK(s1->meshes[0].blocks == s2->meshes[0].blocks &&
                  s3->meshes[0].blocks != s1->meshes[0].blocks,
              "the inline mesh is not shared as it should be");
    CHECK(left1 == left2, "charged %lld building, %lld taking", (1LL << 40) - left1,
          (1LL << 40) - left2);
    rayd_asset_cache_free(c);
    rayd_image *want = plain ? render_all(plain, 2) : NULL;
    rayd_scene_free(s1);
    rayd_image *got = s2 ? render_all(s2, 2) : NULL;
    rayd_image *other = s3 ? render_all(s3, 2) : NULL;
    CHECK(same_pixels(want, got), "a shared inline mesh renders differently");
    CHECK(want && lit_pixels(want) > 200 && !same_pixels(want, other),
          "the meshes do not show apart: the check proves little");
    rayd_image_free(want), rayd_image_free(got), rayd_image_free(other);
    rayd_scene_free(s2), rayd_scene_free(s3), rayd_scene_free(s4), rayd_scene_free(plain);
    free(ja), free(jb), free(js), free(a), free(b), free(small);
}

/* dir/name holds text; false when it cannot be written. */
static bool write_file(const char *dir, const char *name, const char *text) {
    char path[160];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *fp = fopen(path, "w");
    if (!fp) return false;
    fputs(text, fp);
    return fclose(fp) == 0;
}

static void remove_file(const char *dir, const char *name) {
    char path[160];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    unlink(path);
}

/* The peak and the final charge of json parsed with cache c (a parse
 * with all the room it wants); false when it failed. */
static bool charges(const char *json, rayd_asset_cache *c, const char *dir, long long *peak,
                    long long *kept, rayd_scene **keep) {
    struct account a = {1LL << 40, 0};
    struct rayd_error err;
    rayd_scene *s = parse_in(json, c, 0, 0, dir, &a, &err);
    *peak = (1LL << 40) - a.low;
    *kept = (1LL << 40) - a.left;
    if (keep)
        *keep = s;
    else
        rayd_scene_free(s);
    return s != NULL;
}

static void test_charged_as_built_from_any_source(void) {
    /* a mesh taken from a file's, or a text's, is charged at its peak and
     * in the end as the same source built here would be: no more (the
     * file's read counted once, not again as the key) and no less */
    char dir[] = "/tmp/rayd-mesh-charge-XXXXXX";
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    char *obj = grid_obj(8);
    size_t pad = 200000; /* a long comment: the source's bytes outweigh the mesh */
    char *big = malloc(strlen(obj) + pad + 8);
    memset(big, 'x', pad);
    big[0] = '#', big[pad - 1] = '\n';
    strcpy(big + pad, obj);
    CHECK(write_file(dir, "big.obj", big), "write big.obj");
    char *src = obj_source(big);
    char *file_json = mesh_scene("{\"file\": \"big.obj\"}", true),
         *text_json = mesh_scene(src, true);
    const char *jsons[2] = {file_json, text_json}, *names[2] = {"file", "text"};
    long long peak[2], kept[2];
    for (int k = 0; k < 2; k++) { /* each built here, offered to a cache */
        rayd_asset_cache *c = rayd_asset_cache_new(0);
        CHECK(charges(jsons[k], c, dir, &peak[k], &kept[k], NULL), "%s parse", names[k]);
        rayd_asset_cache_free(c);
    }
    for (int first = 0; first < 2; first++)
        for (int k = 0; k < 2; k++) {
            rayd_asset_cache *c = rayd_asset_cache_new(0);
            rayd_scene *holder = NULL;
            long long p0, k0, p, kk;
            charges(jsons[first], c, dir, &p0, &k0, &holder);
            bool ok = charges(jsons[k], c, dir, &p, &kk, NULL);
            long hits, misses;
            hits_misses(c, &hits, &misses);
            CHECK(ok && hits == 1, "%s taken from %s: parse %d, hits %ld", names[k], names[first],
                  ok, hits);
            CHECK(p <= peak[k] && kk == kept[k] && k0 == kept[first],
                  "%s taken from %s: peak %lld, kept %lld; built here: peak %lld, kept %lld",
                  names[k], names[first], p, kk, peak[k], kept[k]);
            rayd_scene_free(holder);
            rayd_asset_cache_free(c);
        }
    remove_file(dir, "big.obj");
    rmdir(dir);
    free(file_json), free(text_json), free(src), free(big), free(obj);
}

static void test_decoder_limits_answer(void) {
    /* an OBJ of 1000 'v' lines and one face builds a 3-vertex mesh; with
     * room for 100 vertices its decoder refuses it, and so it must be
     * when a live scene holds the mesh */
    size_t cap = 1000 * 16 + 64;
    char *obj = malloc(cap), *p = obj;
    for (int i = 0; i < 1000; i++) p += sprintf(p, "v %d 0 -%d\n", i % 7, 3 + i % 5);
    sprintf(p, "f 1 2 8\n");
    char *src = obj_source(obj), *json = mesh_scene(src, false);
    struct rayd_error plain_err, err;
    rayd_asset_cache *c = rayd_asset_cache_new(0);
    rayd_scene *keep = parse_in(json, c, 0, 0, NULL, NULL, &err);
    rayd_scene *a = parse_in(json, NULL, 100, 0, NULL, NULL, &plain_err);
    rayd_scene *b = parse_in(json, c, 100, 0, NULL, NULL, &err);
    CHECK(keep && !a && !b, "a scene over its vertex limit was taken (%s)", b ? "shared" : "-");
    CHECK(!strcmp(plain_err.path, err.path) && !strcmp(plain_err.message, err.message) &&
              *err.message,
          "'%s: %s' against '%s: %s'", err.path, err.message, plain_err.path, plain_err.message);
    rayd_scene_free(a), rayd_scene_free(b), rayd_scene_free(keep);
    rayd_asset_cache_free(c);
    free(json), free(src), free(obj);
}

/* The peak and final charge of json parsed with cache c and a cap of
 * room bytes (0: none); *ok whether it parsed. */
static void capped(const char *json, rayd_asset_cache *c, long long room, bool *ok) {
    struct account a = {room ? room : 1LL << 40, 0};
    struct rayd_error err;
    rayd_scene *s = parse_in(json, c, 0, 0, NULL, &a, &err);
    *ok = s != NULL;
    rayd_scene_free(s);
}

static void test_room_answers_alike(void) {
    /* (a) with room for the mesh but not its key, a build keeps its mesh
     * unshared and the scene is taken; so it is when a live scene holds
     * the mesh.  (b) a PLY decoder charges a guess of the triangles
     * (tristrips: up to two a vertex) and gives the spare back: with room
     * for less than that guess, decoding refuses the scene, and so must
     * taking the mesh */
    char *obj = grid_obj(8);
    size_t pad = 200000;
    char *big = malloc(strlen(obj) + pad + 8);
    memset(big, 'x', pad);
    big[0] = '#', big[pad - 1] = '\n';
    strcpy(big + pad, obj);
    char *src = obj_source(big), *json = mesh_scene(src, true);
    rayd_asset_cache *c = rayd_asset_cache_new(0);
    long long peak, kept;
    rayd_scene *holder = NULL;
    charges(json, c, NULL, &peak, &kept, &holder);
    bool built, taken;
    rayd_asset_cache *fresh = rayd_asset_cache_new(0);
    capped(json, fresh, kept - 1, &built);
    capped(json, c, kept - 1, &taken);
    CHECK(built && taken, "no room for the key: built %d, taken %d", built, taken);
    rayd_scene_free(holder);
    rayd_asset_cache_free(fresh);
    rayd_asset_cache_free(c);
    free(json), free(src), free(big), free(obj);

    size_t cap = 20000 * 24 + 256;
    char *ply = malloc(cap), *p = ply;
    p += sprintf(p, "ply\nformat ascii 1.0\nelement vertex 20000\nproperty float x\n"
                    "property float y\nproperty float z\nelement tristrips 1\n"
                    "property list int int vertex_indices\nend_header\n");
    for (int i = 0; i < 20000; i++) p += sprintf(p, "%d %d -%d\n", i % 3, i % 2, 3 + i % 5);
    sprintf(p, "3 0 1 2\n");
    size_t jn = 2 * strlen(ply) + 64;
    char *psrc = malloc(jn);
    char *q = psrc + sprintf(psrc, "{\"format\": \"ply\", \"text\": \"");
    for (const char *ch = ply; *ch; ch++)
        q += *ch == '\n' ? sprintf(q, "\\n") : sprintf(q, "%c", *ch);
    sprintf(q, "\"}");
    char *pjson = mesh_scene(psrc, false);
    c = rayd_asset_cache_new(0);
    fresh = rayd_asset_cache_new(0);
    charges(pjson, c, NULL, &peak, &kept, &holder);
    capped(pjson, fresh, peak - 1, &built);
    capped(pjson, c, peak - 1, &taken);
    CHECK(holder && !built && !taken, "under the decoder's peak: built %d, taken %d", built, taken);
    capped(pjson, c, peak, &taken);
    CHECK(taken, "with room for the decoder's peak the mesh is not taken");
    rayd_scene_free(holder);
    /* the same when the scene that built it was parsed with no account */
    struct rayd_error err;
    holder = parse_in(pjson, c, 0, 0, NULL, NULL, &err);
    capped(pjson, c, peak - 1, &taken);
    CHECK(holder && !taken, "under the decoder's peak, taken from a parse with no account");
    rayd_scene_free(holder);
    rayd_asset_cache_free(fresh);
    rayd_asset_cache_free(c);
    free(pjson), free(psrc), free(ply);
}

int main(void) {
    RUN(test_built_once_same_pixels);
    RUN(test_every_byte_tells);
    RUN(test_limits_hold_the_same);
    RUN(test_holding_cache_and_files);
    RUN(test_inline_arrays_shared);
    RUN(test_charged_as_built_from_any_source);
    RUN(test_decoder_limits_answer);
    RUN(test_room_answers_alike);
    CHECK_EXIT();
}
