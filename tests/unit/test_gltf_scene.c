/* test_gltf_scene.c -- "gltf" objects: a glTF file as a whole scene
 * (core/load/scene_json_gltf.c, gltf_material.c, mesh_gltf.c's gltf_doc_*).
 *
 * One glTF is built here as a cJSON tree: a unit quad (positions, uvs and
 * indices in one data: URI buffer, which also holds a 2 x 1 PNG made with
 * rayd's encoder), drawn by primitives in five materials (two primitives
 * share one, one has none), a PNG texture from a bufferView and a JPEG
 * (made with stb_image_write) from a data: URI, a spot and a directional
 * light, a perspective and an orthographic camera.  The scene that comes
 * out must hold the values worked out here by hand: materials, one mesh
 * per material, uvs flipped to rayd's v, texels with the factor baked in,
 * lights and cameras where their nodes and the object's transform put
 * them.  Then hostile variants of the tree must be refused with the JSON
 * Pointer into the glTF document.
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cjson/cJSON.h>
#include <stb/stb_image_write.h>

#include "check.h"
#include "scene_util.h"
#include "load/gltf_material.h"
#include "render/image.h"
#include "scene/scene.h"
#include "shade/texture.h"

/* ---- the bytes ---------------------------------------------------------------- */

static unsigned char buf[4096];
static size_t buf_len, png_len;
static char *jpeg_uri;

static char *base64(const unsigned char *b, size_t n, const char *prefix) {
    static const char t[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    size_t pn = strlen(prefix);
    char *o = malloc(pn + (n + 2) / 3 * 4 + 1), *p = o + pn;
    memcpy(o, prefix, pn);
    for (size_t i = 0; i < n; i += 3) {
        uint32_t v = (uint32_t)b[i] << 16 | (i + 1 < n ? (uint32_t)b[i + 1] << 8 : 0) |
                     (i + 2 < n ? b[i + 2] : 0);
        *p++ = t[v >> 18 & 63];
        *p++ = t[v >> 12 & 63];
        *p++ = i + 1 < n ? t[v >> 6 & 63] : '=';
        *p++ = i + 2 < n ? t[v & 63] : '=';
    }
    *p = '\0';
    return o;
}

static void jpeg_out(void *ctx, void *data, int size) {
    size_t *n = ctx;
    memcpy(buf + 2048 + *n, data, (size_t)size);
    *n += (size_t)size;
}

/* positions 0..47, uvs 48..79 (glTF's: u = x, v = y), u16 indices 80..91, PNG from 92 */
static void make_bytes(void) {
    static const float q[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    static const float uv[8] = {0, 0, 1, 0, 1, 1, 0, 1};
    static const uint16_t ix[6] = {0, 1, 2, 0, 2, 3};
    memcpy(buf, q, sizeof q);
    memcpy(buf + 48, uv, sizeof uv);
    memcpy(buf + 80, ix, sizeof ix);
    unsigned char px[6] = {255, 0, 0, 0, 128, 255};
    rayd_image img = {.w = 2, .h = 1, .px = px};
    void *png;
    rayd_png_encode(&img, 6, &png, &png_len, NULL);
    memcpy(buf + 92, png, png_len);
    free(png);
    buf_len = 92 + png_len;
    unsigned char solid[8 * 8 * 3];
    for (int i = 0; i < 64; i++) solid[3 * i] = 200, solid[3 * i + 1] = 100, solid[3 * i + 2] = 50;
    size_t jn = 0;
    stbi_write_jpg_to_func(jpeg_out, &jn, 8, 8, 3, solid, 100);
    jpeg_uri = base64(buf + 2048, jn, "data:image/jpeg;base64,");
}

/* ---- the document --------------------------------------------------------------- */

static const char *doc_text =
    "{\"asset\": {\"version\": \"2.0\"}, \"scene\": 0,"
    " \"scenes\": [{\"name\": \"main\", \"nodes\": [0, 1, 2, 3, 4, 5, 6]},"
    "              {\"name\": \"second\", \"nodes\": [1]}],"
    " \"bufferViews\": [{\"buffer\": 0, \"byteLength\": 48}, {\"buffer\": 0, \"byteOffset\": 48, "
    "\"byteLength\": 32},"
    "                   {\"buffer\": 0, \"byteOffset\": 80, \"byteLength\": 12}],"
    " \"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": 4, \"type\": "
    "\"VEC3\"},"
    "                 {\"bufferView\": 1, \"componentType\": 5126, \"count\": 4, \"type\": "
    "\"VEC2\"},"
    "                 {\"bufferView\": 2, \"componentType\": 5123, \"count\": 6, \"type\": "
    "\"SCALAR\"}],"
    " \"textures\": [{\"source\": 0, \"sampler\": 0}, {\"source\": 1}],"
    " \"samplers\": [{\"wrapS\": 33071}],"
    " \"materials\": ["
    "   {\"pbrMetallicRoughness\": {\"baseColorFactor\": [0.5, 0.25, 1, 1], \"metallicFactor\": 1,"
    "     \"roughnessFactor\": 0}},"
    "   {\"pbrMetallicRoughness\": {\"baseColorFactor\": [1, 1, 1, 0.4], \"metallicFactor\": 0,"
    "     \"roughnessFactor\": 0.5}, \"alphaMode\": \"BLEND\", \"emissiveFactor\": [1, 0.5, 0],"
    "    \"extensions\": {\"KHR_materials_emissive_strength\": {\"emissiveStrength\": 2},"
    "                   \"KHR_materials_ior\": {\"ior\": 1.33}}},"
    "   {\"pbrMetallicRoughness\": {\"baseColorFactor\": [0.5, 1, 1, 1], \"baseColorTexture\": "
    "{\"index\": 0}}},"
    "   {\"pbrMetallicRoughness\": {\"baseColorTexture\": {\"index\": 1}}},"
    "   {\"alphaMode\": \"MASK\"}],"
    " \"meshes\": ["
    "   {\"primitives\": [{\"attributes\": {\"POSITION\": 0}, \"indices\": 2, \"material\": 0},"
    "                     {\"attributes\": {\"POSITION\": 0}, \"indices\": 2, \"material\": 1},"
    "                     {\"attributes\": {\"POSITION\": 0}, \"indices\": 2, \"material\": 0},"
    "                     {\"attributes\": {\"POSITION\": 0}, \"indices\": 2}]},"
    "   {\"primitives\": [{\"attributes\": {\"POSITION\": 0, \"TEXCOORD_0\": 1}, \"indices\": 2, "
    "\"material\": 2}]},"
    "   {\"primitives\": [{\"attributes\": {\"POSITION\": 0, \"TEXCOORD_0\": 1}, \"indices\": 2, "
    "\"material\": 3}]}],"
    " \"nodes\": [{\"mesh\": 0}, {\"mesh\": 1, \"translation\": [0, 0, -2]},"
    "   {\"mesh\": 2, \"translation\": [0, 0, -4]},"
    "   {\"translation\": [1, 2, 3], \"rotation\": [0.7071067811865476, 0, 0, "
    "0.7071067811865476],"
    "    \"extensions\": {\"KHR_lights_punctual\": {\"light\": 0}}},"
    "   {\"translation\": [0, 0, 5], \"camera\": 0},"
    "   {\"translation\": [0, 1, 0], \"extensions\": {\"KHR_lights_punctual\": {\"light\": 1}}},"
    "   {\"translation\": [0, 3, 7], \"camera\": 1}],"
    " \"cameras\": [{\"type\": \"perspective\", \"perspective\": {\"yfov\": 0.5, \"znear\": 0.1}},"
    "   {\"type\": \"orthographic\", \"name\": \"top\", \"orthographic\": {\"xmag\": 2, \"ymag\": "
    "1.5, \"znear\": 0.1, \"zfar\": 10}}],"
    " \"extensions\": {\"KHR_lights_punctual\": {\"lights\": ["
    "   {\"type\": \"spot\", \"color\": [1, 0.5, 0.25], \"intensity\": 5,"
    "    \"spot\": {\"innerConeAngle\": 0.2, \"outerConeAngle\": 0.5}},"
    "   {\"type\": \"directional\", \"intensity\": 3}]}}}";

/* The document as a tree, with its buffer and images filled in. */
static cJSON *doc_tree(void) {
    cJSON *d = cJSON_Parse(doc_text);
    char *uri = base64(buf, buf_len, "data:application/octet-stream;base64,");
    cJSON *b = cJSON_CreateObject();
    cJSON_AddNumberToObject(b, "byteLength", (double)buf_len);
    cJSON_AddStringToObject(b, "uri", uri);
    cJSON *bufs = cJSON_AddArrayToObject(d, "buffers");
    cJSON_AddItemToArray(bufs, b);
    cJSON *v = cJSON_CreateObject();
    cJSON_AddNumberToObject(v, "buffer", 0);
    cJSON_AddNumberToObject(v, "byteOffset", 92);
    cJSON_AddNumberToObject(v, "byteLength", (double)png_len);
    cJSON_AddItemToArray(cJSON_GetObjectItem(d, "bufferViews"), v);
    cJSON *imgs = cJSON_AddArrayToObject(d, "images"), *i0 = cJSON_CreateObject();
    cJSON *i1 = cJSON_CreateObject();
    cJSON_AddNumberToObject(i0, "bufferView", 3);
    cJSON_AddStringToObject(i0, "mimeType", "image/png");
    cJSON_AddStringToObject(i1, "uri", jpeg_uri);
    cJSON_AddItemToArray(imgs, i0);
    cJSON_AddItemToArray(imgs, i1);
    free(uri);
    return d;
}

/* A scene of one gltf object: the document d (consumed) and the object's
 * extra keys (JSON members, may be ""), with a top-level head ("" or
 * members ending in a comma). */
static rayd_scene *parse_lim(cJSON *d, const char *head, const char *extra,
                             const struct rayd_limits *lim, struct rayd_error *err) {
    char *text = cJSON_PrintUnformatted(d);
    cJSON_Delete(d);
    cJSON *src = cJSON_CreateObject();
    cJSON_AddStringToObject(src, "format", "gltf");
    cJSON_AddStringToObject(src, "text", text);
    char *stext = cJSON_PrintUnformatted(src);
    cJSON_Delete(src);
    size_t n = strlen(stext) + strlen(head) + strlen(extra) + 200;
    char *json = malloc(n);
    snprintf(json, n,
             "{%s \"render\": {\"width\": 40, \"height\": 20},"
             " \"objects\": [{\"type\": \"gltf\", \"source\": %s%s%s}]}",
             head, stext, *extra ? ", " : "", extra);
    rayd_scene *s = NULL;
    memset(err, 0, sizeof *err);
    if (rayd_scene_parse(json, strlen(json), lim, &s, err) != RAYD_OK) s = NULL;
    free(text), free(stext), free(json);
    return s;
}

static rayd_scene *parse(cJSON *d, const char *head, const char *extra, struct rayd_error *err) {
    return parse_lim(d, head, extra, NULL, err);
}

static const struct group *the_group(const rayd_scene *s) {
    if (s->nobjs != 1 || s->objs[0].kind != SHAPE_INSTANCE) return NULL;
    return &s->groups[s->objs[0].u.inst.group];
}

/* The member mesh object whose material has colour c (NULL: none). */
static const struct object *by_color(const rayd_scene *s, double r, double g, double b) {
    const struct group *gr = the_group(s);
    for (int32_t i = 0; gr && i < gr->nobjs; i++) {
        vec3 c = s->mats[gr->objs[i].material].color;
        if (fabs(c.x - r) < 1e-12 && fabs(c.y - g) < 1e-12 && fabs(c.z - b) < 1e-12)
            return &gr->objs[i];
    }
    return NULL;
}

static double lin(int c) {
    double x = c / 255.0;
    return x <= 0.04045 ? x / 12.92 : pow((x + 0.055) / 1.055, 2.4);
}

/* ---- materials, meshes, textures ------------------------------------------------ */

static void test_materials_and_groups(void) {
    struct rayd_error err;
    rayd_scene *s = parse(doc_tree(), "", "", &err);
    CHECK(s, "parse: %s at %s", err.message, err.path);
    if (!s) return;
    const struct group *gr = the_group(s);
    CHECK(gr && gr->nobjs == 5, "one mesh per material drawn: %d", gr ? gr->nobjs : -1);
    const struct object *m0 = by_color(s, 0.5, 0.25, 1), *m1 = by_color(s, 1, 1, 1);
    CHECK(m0 && s->meshes[m0->u.mesh.id].ntris == 4, "material 0's two primitives: one mesh");
    if (m0) {
        const struct material *m = &s->mats[m0->material];
        CHECK_NEAR(m->metallic, 1, 0);
        CHECK_NEAR(m->roughness, 0, 0);
        CHECK_NEAR(m->specular, 1, 1e-12);
        CHECK_NEAR(m->shininess, 10000, 0);
        CHECK_NEAR(m->reflectivity, 1, 1e-12);
        CHECK_NEAR(m->diffuse, 0, 1e-12);
        CHECK_NEAR(m->transparency, 0, 0);
    }
    /* material 1 (white, BLEND) and the default material (white, metallic 1,
     * roughness 1) share a colour: told apart by transparency */
    const struct object *blend = NULL, *dflt = NULL;
    for (int32_t i = 0; gr && i < gr->nobjs; i++) {
        const struct material *m = &s->mats[gr->objs[i].material];
        if (m->transparency > 0) blend = &gr->objs[i];
        if (m->metallic == 1 && m->roughness == 1) dflt = &gr->objs[i];
    }
    CHECK(m1 && blend && dflt, "the blended and the default material");
    if (blend) {
        const struct material *m = &s->mats[blend->material];
        CHECK_NEAR(m->transparency, 0.6, 1e-12);
        CHECK_NEAR(m->ior, 1.33, 1e-12);
        CHECK_NEAR(m->emission.x, 2, 1e-12);
        CHECK_NEAR(m->emission.y, 1, 1e-12);
        CHECK_NEAR(m->emission.z, 0, 0);
        CHECK_NEAR(m->roughness, 0.5, 0);
        CHECK_NEAR(m->shininess, 30, 1e-9); /* 2 / 0.5^4 - 2 */
        CHECK_NEAR(m->specular, 0.125, 1e-12);
        CHECK_NEAR(m->reflectivity, 0, 0);
    }
    if (dflt) {
        const struct material *m = &s->mats[dflt->material];
        CHECK_NEAR(m->color.x, 1, 0);
        CHECK_NEAR(m->specular, 0, 1e-12);
        CHECK_NEAR(m->transparency, 0, 0);
        CHECK_NEAR(s->meshes[dflt->u.mesh.id].ntris, 2, 0);
    }
    CHECK(s->nmats == 1 + 5, "the default rayd material and the five used: %d", s->nmats);
    CHECK(s->ntextures == 2, "two textures: %d", s->ntextures);
    rayd_scene_free(s);
}

static void test_uvs_and_textures(void) {
    struct rayd_error err;
    rayd_scene *s = parse(doc_tree(), "", "", &err);
    CHECK(s, "parse: %s", err.message);
    if (!s) return;
    const struct object *o = by_color(s, 0.5, 1, 1);
    CHECK(o, "the PNG-textured material");
    if (o) {
        const struct mesh *m = &s->meshes[o->u.mesh.id];
        CHECK(m->uv && m->pos && m->nverts == 4, "uvs kept");
        for (uint32_t i = 0; m->uv && m->pos && i < m->nverts; i++) {
            CHECK_NEAR(m->uv[2 * i], m->pos[3 * i], 0);
            CHECK_NEAR(m->uv[2 * i + 1], 1 - m->pos[3 * i + 1], 0); /* v flipped */
            CHECK_NEAR(m->pos[3 * i + 2], -2, 0);
        }
        const struct material *mt = &s->mats[o->material];
        CHECK(mt->texture >= 0, "textured");
        if (mt->texture >= 0) {
            const struct texture *t = &s->textures[mt->texture];
            CHECK(t->kind == TEX_IMAGE && t->space == TEX_UV && t->w == 2 && t->h == 1, "2 x 1");
            CHECK_NEAR(t->rgb[0], 0.5, 1e-6); /* 255 red times the factor's 0.5 */
            CHECK_NEAR(t->rgb[1], 0, 0);
            CHECK_NEAR(t->rgb[4], lin(128), 1e-6);
            CHECK_NEAR(t->rgb[5], 1, 1e-6);
        }
    }
    const struct object *j = NULL;
    const struct group *gr = the_group(s);
    for (int32_t i = 0; gr && i < gr->nobjs; i++)
        if (s->mats[gr->objs[i].material].texture >= 0 && &gr->objs[i] != o) j = &gr->objs[i];
    CHECK(j, "the JPEG-textured material");
    if (j) {
        const struct texture *t = &s->textures[s->mats[j->material].texture];
        CHECK(t->w == 8 && t->h == 8, "8 x 8: %d x %d", t->w, t->h);
        CHECK_NEAR(t->rgb[0], lin(200), 0.02);
        CHECK_NEAR(t->rgb[1], lin(100), 0.02);
        CHECK_NEAR(t->rgb[2], lin(50), 0.02);
    }
    rayd_scene_free(s);
}

/* The texels of the texture of the material with base colour r, g, b. */
static const float *texels_of(const rayd_scene *s, double r, double g, double b) {
    const struct object *o = by_color(s, r, g, b);
    int t = o ? s->mats[o->material].texture : -1;
    return t >= 0 ? s->textures[t].rgb : NULL;
}

static void test_textures_shared(void) {
    /* a frame's parse takes the base colour textures a live scene of the
     * same image bytes and factor decoded (rayd_asset_cache); another
     * factor is another image */
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    lim.assets = rayd_asset_cache_new(0);
    struct rayd_error err;
    rayd_scene *a = parse_lim(doc_tree(), "", "", &lim, &err);
    rayd_scene *b = parse_lim(doc_tree(), "", "", &lim, &err);
    cJSON *d = doc_tree(); /* material 2's factor changed: its texture is another */
    cJSON *f = cJSON_GetObjectItem(
        cJSON_GetObjectItem(cJSON_GetArrayItem(cJSON_GetObjectItem(d, "materials"), 2),
                            "pbrMetallicRoughness"),
        "baseColorFactor");
    cJSON_ReplaceItemInArray(f, 1, cJSON_CreateNumber(0.5));
    rayd_scene *c = parse_lim(d, "", "", &lim, &err);
    CHECK(a && b && c, "parse: %s", err.message);
    long hits, misses;
    rayd_asset_cache_stats(lim.assets, RAYD_ASSET_IMAGE, &hits, &misses);
    CHECK(hits == 3 && misses == 3, "hits %ld, misses %ld; want 3 and 3", hits, misses);
    if (a && b && c) {
        const float *pa = texels_of(a, 0.5, 1, 1), *pb = texels_of(b, 0.5, 1, 1);
        const float *pc = texels_of(c, 0.5, 0.5, 1);
        CHECK(pa && pa == pb && pc && pc != pa, "the PNG's texels are not shared as they should");
        CHECK(pc && pa && pc[0] == pa[0] && pc[4] == 0.5f * pa[4],
              "the other factor is not in its texels");
    }
    rayd_asset_cache_free(lim.assets);
    rayd_scene_free(a); /* b's textures outlive a's reference (ASan: no use after free) */
    if (b) {
        const float *pb = texels_of(b, 0.5, 1, 1);
        CHECK(pb && fabsf(pb[0] - 0.5f) < 1e-6f, "b lost its texture");
    }
    rayd_scene_free(b);
    rayd_scene_free(c);
}

/* A glTF document of one wavy n x n grid (2 n^2 triangles, u32 indices)
 * under a node lifted by lift along z, its buffer a data: URI. */
static cJSON *grid_doc(int n, double lift) {
    size_t nv = (size_t)(n + 1) * (n + 1), nt = 2 * (size_t)n * n;
    size_t pbytes = nv * 12, len = pbytes + nt * 12;
    unsigned char *b = malloc(len);
    float *p = (float *)(void *)b;
    uint32_t *ix = (uint32_t *)(void *)(b + pbytes);
    for (int j = 0; j <= n; j++)
        for (int i = 0; i <= n; i++, p += 3) {
            p[0] = 2.0f * (float)i / (float)n - 1, p[1] = 2.0f * (float)j / (float)n - 1;
            p[2] = (float)(0.2 * sin(7.0 * i / n) * cos(5.0 * j / n));
        }
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++, ix += 6) {
            uint32_t a = (uint32_t)(j * (n + 1) + i), c = a + (uint32_t)n + 1;
            ix[0] = a, ix[1] = a + 1, ix[2] = c + 1, ix[3] = a, ix[4] = c + 1, ix[5] = c;
        }
    char *uri = base64(b, len, "data:application/octet-stream;base64,");
    free(b);
    size_t cap = strlen(uri) + 1024;
    char *text = malloc(cap);
    snprintf(
        text, cap,
        "{\"asset\": {\"version\": \"2.0\"}, \"scene\": 0, \"scenes\": [{\"nodes\": [0]}],"
        " \"nodes\": [{\"mesh\": 0, \"translation\": [0, 0, %g]}],"
        " \"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0}, \"indices\": 1}]}],"
        " \"buffers\": [{\"byteLength\": %zu, \"uri\": \"%s\"}],"
        " \"bufferViews\": [{\"buffer\": 0, \"byteLength\": %zu},"
        "   {\"buffer\": 0, \"byteOffset\": %zu, \"byteLength\": %zu}],"
        " \"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": %zu,"
        "   \"type\": \"VEC3\", \"min\": [-1, -1, -1], \"max\": [1, 1, 1]},"
        "   {\"bufferView\": 1, \"componentType\": 5125, \"count\": %zu, \"type\": \"SCALAR\"}]}",
        lift, len, uri, pbytes, pbytes, nt * 12, nv, nt * 3);
    cJSON *d = cJSON_Parse(text);
    free(uri), free(text);
    return d;
}

/* A charge hook that keeps the net bytes charged. */
static enum rayd_status net_charge(void *arg, long long bytes, char *why, size_t why_len) {
    (void)why, (void)why_len;
    *(long long *)arg += bytes;
    return RAYD_OK;
}

/* The one member mesh of s's gltf object (NULL: none). */
static const struct mesh *grid_mesh(const rayd_scene *s) {
    const struct group *gr = s ? the_group(s) : NULL;
    return gr && gr->nobjs == 1 ? &s->meshes[gr->objs[0].u.mesh.id] : NULL;
}

static bool same_image(const rayd_image *a, const rayd_image *b) {
    return a && b &&
           !memcmp(rayd_image_pixels((rayd_image *)(uintptr_t)a),
                   rayd_image_pixels((rayd_image *)(uintptr_t)b), 40 * 20 * 3);
}

static void test_baked_meshes_shared(void) {
    /* a frame's parse takes the meshes a live scene baked to the same
     * arrays (rayd_asset_cache), charged alike, the same pixels; a node
     * moved bakes other arrays, and a small mesh is not looked up */
    const char *head = "\"camera\": {\"position\": [0, -1.5, 3], \"look_at\": [0, 0, 0]},"
                       " \"lights\": [{\"type\": \"point\", \"position\": [1, -2, 4]}],";
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    lim.assets = rayd_asset_cache_new(0);
    lim.charge = net_charge;
    long long net[3] = {0, 0, 0};
    struct rayd_error err;
    rayd_scene *plain = parse(grid_doc(24, 0), head, "", &err), *s[3];
    for (int k = 0; k < 3; k++) {
        lim.charge_arg = &net[k];
        s[k] = parse_lim(grid_doc(24, k == 2 ? 0.25 : 0), head, "", &lim, &err);
    }
    rayd_scene *small = parse_lim(grid_doc(8, 0), head, "", &lim, &err);
    CHECK(plain && s[0] && s[1] && s[2] && small, "parse: %s", err.message);
    long hits, misses;
    rayd_asset_cache_stats(lim.assets, RAYD_ASSET_MESH, &hits, &misses);
    CHECK(hits == 1 && misses == 2, "hits %ld, misses %ld; want 1 and 2", hits, misses);
    const struct mesh *m0 = grid_mesh(s[0]), *m1 = grid_mesh(s[1]), *m2 = grid_mesh(s[2]);
    CHECK(m0 && m1 && m2 && m0->blocks == m1->blocks && m2->blocks != m0->blocks,
          "the same baked arrays are not shared, or other arrays are");
    CHECK(net[0] == net[1] && net[0] > 0, "charged %lld building, %lld taking", net[0], net[1]);
    rayd_asset_cache_free(lim.assets); /* the scenes keep their meshes */
    rayd_image *want = plain ? render_all(plain, 2) : NULL;
    rayd_image *got0 = s[0] ? render_all(s[0], 2) : NULL;
    rayd_scene_free(s[0]); /* s[1]'s mesh outlives s[0]'s reference (ASan: no use after free) */
    rayd_image *got1 = s[1] ? render_all(s[1], 1) : NULL;
    CHECK(same_image(want, got0) && same_image(want, got1),
          "a shared baked mesh renders differently");
    int lit = 0;
    for (size_t i = 0; want && i < 40 * 20 * 3; i += 3) lit += rayd_image_pixels(want)[i] > 20;
    CHECK(lit > 100, "the grid does not show (%d lit pixels): the check proves little", lit);
    rayd_image_free(want), rayd_image_free(got0), rayd_image_free(got1);
    rayd_scene_free(s[1]), rayd_scene_free(s[2]), rayd_scene_free(small), rayd_scene_free(plain);
}

static void test_holding_cache_lets_baked_go(void) {
    /* a holding cache (rayd-render's frames) keeps no baked mesh: an
     * animated glTF bakes new ones every frame, which it would keep all
     * job long; a mesh baked the same is taken while the frame before's
     * scene is alive */
    const char *head = "\"camera\": {\"position\": [0, -1.5, 3], \"look_at\": [0, 0, 0]},";
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    lim.assets = rayd_asset_cache_new(1);
    struct rayd_error err;
    rayd_scene *a = parse_lim(grid_doc(24, 0), head, "", &lim, &err);
    rayd_scene_free(a);
    rayd_scene *b = parse_lim(grid_doc(24, 0), head, "", &lim, &err);
    rayd_scene *c = parse_lim(grid_doc(24, 0), head, "", &lim, &err);
    CHECK(a && b && c, "parse: %s", err.message);
    long hits, misses;
    rayd_asset_cache_stats(lim.assets, RAYD_ASSET_MESH, &hits, &misses);
    CHECK(hits == 1 && misses == 2, "hits %ld, misses %ld; want 1 and 2", hits, misses);
    rayd_scene_free(b);
    rayd_asset_cache_free(lim.assets); /* c's mesh outlives the cache (ASan) */
    const struct mesh *m = grid_mesh(c);
    CHECK(m && m->ntris == 1152, "c lost its mesh");
    rayd_scene_free(c);
}

/* Item i of d's array a, or that item's member b. */
static cJSON *at(cJSON *d, const char *a, int i, const char *b) {
    cJSON *x = cJSON_GetArrayItem(cJSON_GetObjectItem(d, a), i);
    return b ? cJSON_GetObjectItem(x, b) : x;
}

/* The JPEG material's mesh (2 triangles at z = -4) when its texture reads
 * texCoord set `set` and its primitive has only TEXCOORD_<has>: the uvs of
 * that set, or (0, 0) when the set is missing. */
static void texcoord_case(int set, int has) {
    cJSON *d = doc_tree();
    cJSON *ti =
        cJSON_GetObjectItem(at(d, "materials", 3, "pbrMetallicRoughness"), "baseColorTexture");
    cJSON_AddNumberToObject(ti, "texCoord", set);
    cJSON *attr = cJSON_GetObjectItem(at(d, "meshes", 2, "primitives")->child, "attributes");
    char key[16];
    snprintf(key, sizeof key, "TEXCOORD_%d", has);
    cJSON_DeleteItemFromObject(attr, "TEXCOORD_0");
    cJSON_AddNumberToObject(attr, key, 1);
    struct rayd_error err;
    rayd_scene *s = parse(d, "", "", &err);
    CHECK(s, "parse: %s", err.message);
    const struct group *gr = s ? the_group(s) : NULL;
    const struct mesh *m = NULL;
    for (int32_t i = 0; gr && i < gr->nobjs; i++) {
        const struct mesh *x = &s->meshes[gr->objs[i].u.mesh.id];
        if (x->pos && x->pos[2] == -4) m = x;
    }
    CHECK(m && m->uv, "the JPEG material's mesh, with uvs");
    for (uint32_t i = 0; m && m->uv && i < m->nverts; i++) {
        CHECK_NEAR(m->uv[2 * i], set == has ? m->pos[3 * i] : 0, 0);
        CHECK_NEAR(m->uv[2 * i + 1], set == has ? 1 - m->pos[3 * i + 1] : 0, 0);
    }
    if (s) rayd_scene_free(s);
}

static void test_image_decoded_once(void) {
    /* two more materials take the PNG of material 2 with other factors:
     * the PNG is decoded once for the three (a file naming one image from
     * many materials must not cost a decode each), the JPEG once, and each
     * material's texels carry its own factor */
    cJSON *d = doc_tree();
    cJSON *mats = cJSON_GetObjectItem(d, "materials");
    for (int k = 0; k < 2; k++) {
        cJSON *m = cJSON_Duplicate(cJSON_GetArrayItem(mats, 2), 1);
        cJSON *f =
            cJSON_GetObjectItem(cJSON_GetObjectItem(m, "pbrMetallicRoughness"), "baseColorFactor");
        cJSON_ReplaceItemInArray(f, 2, cJSON_CreateNumber(k ? 0.25 : 0.75));
        cJSON_AddItemToArray(mats, m);
        cJSON *prim = cJSON_Duplicate(
            cJSON_GetArrayItem(cJSON_GetObjectItem(at(d, "meshes", 1, NULL), "primitives"), 0), 1);
        cJSON_ReplaceItemInObject(prim, "material", cJSON_CreateNumber(5 + k));
        cJSON_AddItemToArray(cJSON_GetObjectItem(at(d, "meshes", 1, NULL), "primitives"), prim);
    }
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    struct rayd_error err;
    rayd_scene *s = parse_lim(d, "", "", &lim, &err);
    CHECK(s, "parse: %s", err.message);
    if (!s) return;
    CHECK(s->images_decoded == 2, "%ld images decoded; want 2 (the PNG once, the JPEG once)",
          s->images_decoded);
    const float *p = texels_of(s, 0.5, 1, 1), *q = texels_of(s, 0.5, 1, 0.75),
                *r = texels_of(s, 0.5, 1, 0.25);
    CHECK(p && q && r && q != p && r != p, "the three materials' textures are not there");
    if (p && q && r)
        CHECK(q[0] == p[0] && q[2] == 0.75f * p[2] && r[2] == 0.25f * p[2],
              "a material's texels do not carry its factor: %g %g %g", (double)p[2], (double)q[2],
              (double)r[2]);
    rayd_scene_free(s);
}

static void test_shared_image_over_budget(void) {
    /* the texel budget runs out at the third material of the 2 x 1 PNG
     * (after it twice and the 8 x 8 JPEG): said as a decode says it, with
     * what is left of the budget */
    cJSON *d = doc_tree();
    cJSON *mats = cJSON_GetObjectItem(d, "materials");
    for (int k = 0; k < 2; k++) {
        cJSON *m = cJSON_Duplicate(cJSON_GetArrayItem(mats, 2), 1);
        cJSON_AddItemToArray(mats, m);
        cJSON *prims = cJSON_GetObjectItem(at(d, "meshes", 1, NULL), "primitives");
        cJSON *prim = cJSON_Duplicate(cJSON_GetArrayItem(prims, 0), 1);
        cJSON_ReplaceItemInObject(prim, "material", cJSON_CreateNumber(5 + k));
        cJSON_AddItemToArray(prims, prim);
    }
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    lim.max_texels = 2 + 64 + 2 + 1;
    struct rayd_error err;
    rayd_scene *s = parse_lim(d, "", "", &lim, &err);
    CHECK(!s && strstr(err.message, "the image is 2 x 1 pixels; the limit is 16777216 pixels (1 "
                                    "left of the file's textures)"),
          "got '%s' at %s", s ? "a scene" : err.message, err.path);
    rayd_scene_free(s);
}

static void test_texcoord_sets(void) {
    texcoord_case(1, 1);
    texcoord_case(1, 0);
    texcoord_case(0, 0);
}

static void test_pbr_mapping(void) {
    struct gltf_pbr mask = {{1, 1, 1, 0.3}, 0, 1, {0, 0, 0}, 1, 0.5, 1, false};
    struct material m = gltf_pbr_material(&mask);
    CHECK_NEAR(m.transparency, 1, 0); /* MASK below the cutoff: cut away */
    CHECK_NEAR(m.ior, 1, 0);
    mask.base[3] = 0.6;
    m = gltf_pbr_material(&mask);
    CHECK_NEAR(m.transparency, 0, 0);
    CHECK(m.emit_front_only, "a single-sided glTF material emits from its front only");
    struct gltf_pbr opaque = {{0.2, 0.3, 0.4, 0.1}, 0.5, 1, {0, 0, 0}, 0, 0.5, 1.5, true};
    m = gltf_pbr_material(&opaque);
    CHECK(!m.emit_front_only, "a doubleSided glTF material emits both ways");
    CHECK_NEAR(m.transparency, 0, 0); /* OPAQUE ignores alpha */
    CHECK_NEAR(m.specular, 0, 1e-12);
    CHECK_NEAR(m.shininess, 1, 0);
    CHECK_NEAR(m.metallic, 0.5, 0);
}

static void test_override_and_scene(void) {
    struct rayd_error err;
    rayd_scene *s =
        parse(doc_tree(), "", "\"material\": {\"color\": [1, 0, 0]}, \"lights\": false", &err);
    CHECK(s, "parse: %s", err.message);
    if (s) {
        const struct group *gr = the_group(s);
        CHECK(gr && gr->nobjs == 1, "one mesh under an override: %d", gr ? gr->nobjs : -1);
        CHECK(gr && s->meshes[gr->objs[0].u.mesh.id].ntris == 12, "every triangle");
        CHECK(gr && s->mats[gr->objs[0].material].color.y == 0, "the override's colour");
        CHECK(s->nlights == 0 && s->ntextures == 0, "no lights, no textures");
        rayd_scene_free(s);
    }
    s = parse(doc_tree(), "", "\"scene\": \"second\"", &err);
    CHECK(s, "parse: %s", err.message);
    if (s) {
        const struct group *gr = the_group(s);
        CHECK(gr && gr->nobjs == 1, "scene 1 draws one mesh: %d", gr ? gr->nobjs : -1);
        CHECK(s->nlights == 0, "scene 1 has no lights");
        rayd_scene_free(s);
    }
}

/* ---- lights and cameras ------------------------------------------------------------ */

static void test_lights(void) {
    struct rayd_error err;
    rayd_scene *s = parse(doc_tree(), "\"lights\": [{\"type\": \"point\"}],",
                          "\"transform\": {\"translate\": [10, 0, 0]}, \"light_scale\": 2", &err);
    CHECK(s, "parse: %s", err.message);
    if (!s) return;
    CHECK(s->nlights == 3, "the scene's light and the file's two: %d", s->nlights);
    if (s->nlights == 3) {
        const struct light *l = &s->lights[1];
        CHECK(l->kind == LIGHT_SPOT, "spot");
        CHECK_NEAR(l->position.x, 11, 1e-12);
        CHECK_NEAR(l->position.y, 2, 1e-12);
        CHECK_NEAR(l->position.z, 3, 1e-12);
        CHECK_NEAR(l->direction.x, 0, 1e-12); /* -Z turned 90 degrees about X */
        CHECK_NEAR(l->direction.y, 1, 1e-12);
        CHECK_NEAR(l->direction.z, 0, 1e-12);
        CHECK_NEAR(l->color.y, 0.5, 0);
        CHECK_NEAR(l->intensity, 10, 1e-12);
        CHECK_NEAR(l->cos_outer, cos(0.5), 1e-15);
        CHECK_NEAR(l->cos_inner, cos(0.2), 1e-15);
        const struct light *d = &s->lights[2];
        CHECK(d->kind == LIGHT_DIRECTIONAL, "directional");
        CHECK_NEAR(d->direction.z, -1, 1e-12);
        CHECK_NEAR(d->intensity, 6, 1e-12);
    }
    rayd_scene_free(s);
}

static void test_cameras(void) {
    struct rayd_error err;
    rayd_scene *s = parse(doc_tree(), "\"camera\": {\"aperture\": 0.1, \"focus_distance\": 4},",
                          "\"transform\": {\"translate\": [10, 0, 0]}, \"camera\": 0", &err);
    CHECK(s, "parse: %s", err.message);
    if (s) {
        const struct camera *c = &s->cam;
        CHECK_NEAR(c->pos.x, 10, 1e-12);
        CHECK_NEAR(c->pos.z, 5, 1e-12);
        CHECK_NEAR(c->w.z, -1, 1e-12);
        CHECK_NEAR(c->v.y, 1, 1e-12);
        CHECK_NEAR(c->u.x, 1, 1e-12);
        CHECK_NEAR(c->tan_y, tan(0.25), 1e-12);
        CHECK_NEAR(c->tan_x, 2 * tan(0.25), 1e-12); /* the image's aspect, 40 x 20 */
        CHECK_NEAR(c->aperture, 0.05, 1e-12);
        CHECK_NEAR(c->focus, 4, 0);
        CHECK(!c->ortho, "perspective");
        rayd_scene_free(s);
    }
    s = parse(doc_tree(), "", "\"transform\": {\"scale\": 2}, \"camera\": \"top\"", &err);
    CHECK(s, "parse: %s", err.message);
    if (s) {
        const struct camera *c = &s->cam;
        CHECK(c->ortho, "orthographic");
        CHECK_NEAR(c->pos.y, 6, 1e-12);
        CHECK_NEAR(c->pos.z, 14, 1e-12);
        CHECK_NEAR(c->tan_y, 3, 1e-12); /* ymag 1.5, scaled by 2 */
        CHECK_NEAR(c->tan_x, 6, 1e-12);
        rayd_scene_free(s);
    }
}

/* ---- errors ------------------------------------------------------------------------ */

static void expect(rayd_scene *s, const struct rayd_error *err, const char *path,
                   const char *words) {
    CHECK(!s, "refused (%s)", path);
    if (s) rayd_scene_free(s);
    CHECK(!strcmp(err->path, path), "path %s, expected %s (%s)", err->path, path, err->message);
    CHECK(strstr(err->message, words), "message \"%s\" lacks \"%s\"", err->message, words);
}

static void test_errors(void) {
    struct rayd_error err;
    cJSON *d = doc_tree();
    cJSON_ReplaceItemInArray(at(d, "materials", 0, "pbrMetallicRoughness")->child, 0,
                             cJSON_CreateNumber(2));
    expect(parse(d, "", "", &err), &err,
           "/objects/0/source/gltf/materials/0/pbrMetallicRoughness/baseColorFactor", "[0, 1]");
    d = doc_tree();
    cJSON_ReplaceItemInObject(at(d, "meshes", 0, "primitives")->child, "material",
                              cJSON_CreateNumber(9));
    expect(parse(d, "", "", &err), &err, "/objects/0/source/gltf/meshes/0/primitives/0/material",
           "is not an index into /materials");
    d = doc_tree();
    cJSON_ReplaceItemInObject(at(d, "images", 1, NULL), "uri",
                              cJSON_CreateString("data:image/png;base64,aGVsbG8="));
    expect(parse(d, "", "", &err), &err, "/objects/0/source/gltf/images/1/uri",
           "neither a PNG nor a JPEG");
    d = doc_tree();
    cJSON_ReplaceItemInObject(
        cJSON_GetObjectItem(at(d, "nodes", 3, "extensions"), "KHR_lights_punctual"), "light",
        cJSON_CreateNumber(7));
    expect(parse(d, "", "", &err), &err,
           "/objects/0/source/gltf/nodes/3/extensions/KHR_lights_punctual/light", "0..1");
    d = doc_tree();
    cJSON_ReplaceItemInObject(at(d, "cameras", 0, "perspective"), "yfov", cJSON_CreateNumber(-1));
    expect(parse(d, "", "\"camera\": 0", &err), &err,
           "/objects/0/source/gltf/cameras/0/perspective/yfov", "");
    expect(parse(doc_tree(), "", "\"scene\": \"nope\"", &err), &err, "/objects/0/scene",
           "no scenes named \"nope\"");
    expect(parse(doc_tree(), "", "\"camera\": 5", &err), &err, "/objects/0/camera", "0..1");
    expect(parse(doc_tree(), "\"camera\": {\"position\": [0, 0, 1]},", "\"camera\": 0", &err), &err,
           "/objects/0/camera", "/camera/position");
    d = doc_tree();
    cJSON_AddItemToArray(cJSON_AddArrayToObject(d, "extensionsRequired"),
                         cJSON_CreateString("KHR_materials_volume_x"));
    cJSON_ReplaceItemInArray(cJSON_GetObjectItem(d, "extensionsRequired"), 0,
                             cJSON_CreateString("EXT_unknown"));
    expect(parse(d, "", "", &err), &err, "/objects/0/source/gltf/extensionsRequired/0",
           "not supported");
    /* required values missing or wrong in a material's extensions and an
     * image's bufferView: refused where they are, never read */
    d = doc_tree();
    cJSON_ReplaceItemInObject(
        cJSON_GetObjectItem(at(d, "materials", 1, "extensions"), "KHR_materials_emissive_strength"),
        "emissiveStrength", cJSON_CreateString("x"));
    expect(parse(d, "", "", &err), &err,
           "/objects/0/source/gltf/materials/1/extensions/KHR_materials_emissive_strength/"
           "emissiveStrength",
           "must be a number");
    d = doc_tree();
    cJSON_ReplaceItemInObject(
        cJSON_GetObjectItem(at(d, "materials", 1, "extensions"), "KHR_materials_ior"), "ior",
        cJSON_CreateNumber(20));
    expect(parse(d, "", "", &err), &err,
           "/objects/0/source/gltf/materials/1/extensions/KHR_materials_ior/ior", "[0, 10]");
    d = doc_tree();
    cJSON_AddItemToObject(at(d, "materials", 1, NULL), "doubleSided", cJSON_CreateString("yes"));
    expect(parse(d, "", "", &err), &err, "/objects/0/source/gltf/materials/1/doubleSided",
           "true or false");
    d = doc_tree();
    cJSON_ReplaceItemInObject(at(d, "images", 0, NULL), "bufferView", cJSON_CreateNumber(9));
    expect(parse(d, "", "", &err), &err, "/objects/0/source/gltf/images/0/bufferView",
           "9 is not an index into /bufferViews");
    d = doc_tree();
    cJSON_DeleteItemFromObject(at(d, "bufferViews", 3, NULL), "buffer");
    expect(parse(d, "", "", &err), &err, "/objects/0/source/gltf/bufferViews/3/buffer",
           "is required");
    d = doc_tree();
    cJSON_DeleteItemFromObject(at(d, "bufferViews", 3, NULL), "byteLength");
    expect(parse(d, "", "", &err), &err, "/objects/0/source/gltf/bufferViews/3/byteLength",
           "is required");
    d = doc_tree();
    cJSON_ReplaceItemInObject(at(d, "bufferViews", 3, NULL), "byteLength",
                              cJSON_CreateNumber((double)png_len + 1));
    expect(parse(d, "", "", &err), &err, "/objects/0/source/gltf/bufferViews/3/byteLength",
           "runs past the end of buffer 0");
    d = doc_tree();
    cJSON_DeleteItemFromObject(at(d, "buffers", 0, NULL), "byteLength");
    expect(parse(d, "", "", &err), &err, "/objects/0/source/gltf/buffers/0/byteLength",
           "is required");
    const char *grouped = "{\"groups\": {\"g\": [{\"type\": \"gltf\", \"source\": {\"format\": "
                          "\"gltf\", \"text\": \"{}\"}}]}}";
    rayd_scene *s = NULL;
    memset(&err, 0, sizeof err);
    rayd_scene_parse(grouped, strlen(grouped), NULL, &s, &err);
    expect(s, &err, "/groups/g/0/type", "cannot be inside a group");
    const char *obj = "{\"objects\": [{\"type\": \"gltf\", \"source\": {\"format\": \"obj\", "
                      "\"text\": \"v 0 0 0\"}}]}";
    s = NULL;
    rayd_scene_parse(obj, strlen(obj), NULL, &s, &err);
    expect(s, &err, "/objects/0/source/format", "\"gltf\" or \"glb\"");
}

int main(void) {
    make_bytes();
    RUN(test_materials_and_groups);
    RUN(test_uvs_and_textures);
    RUN(test_textures_shared);
    RUN(test_image_decoded_once);
    RUN(test_shared_image_over_budget);
    RUN(test_baked_meshes_shared);
    RUN(test_holding_cache_lets_baked_go);
    RUN(test_pbr_mapping);
    RUN(test_texcoord_sets);
    RUN(test_override_and_scene);
    RUN(test_lights);
    RUN(test_cameras);
    RUN(test_errors);
    free(jpeg_uri);
    CHECK_EXIT();
}
