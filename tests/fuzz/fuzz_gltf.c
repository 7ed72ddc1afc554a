/* fuzz_gltf.c -- libFuzzer target: the glTF 2.0 reader (.glb or .gltf
 * bytes), with small limits so that no input may allocate much, and an
 * opener that answers every external buffer file with the same 96 bytes
 * (an odd-sized buffer of positions and indices), so the paths through
 * file buffers are reached too.  A mesh that comes back must hold indices
 * below its vertex count and finite positions (abort otherwise, so the
 * fuzzer and the replay both report it).
 *
 * The same bytes then go through the whole-scene import twice: the doc
 * steps directly (walk, materials and their images, bake with material
 * indices and uvs, which must be in range and finite), and as a scene with
 * a "gltf" object (base64), which adds lights and, for inputs of odd
 * length, the file's camera 0. */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "load/gltf_material.h"
#include "format/mesh_gltf.h"
#include "rayd/rayd.h"

static enum rayd_status open_any(void *ctx, const char *name, char **data, size_t *len,
                                 struct rayd_error *err) {
    (void)ctx;
    (void)err;
    if (!strcmp(name, "missing.bin")) return RAYD_E_INVALID;
    *data = malloc(96);
    if (!*data) return RAYD_E_NOMEM;
    for (int i = 0; i < 96; i++) (*data)[i] = (char)(i % 4 == 3 ? 0x3f : i % 5);
    *len = 96;
    return RAYD_OK;
}

/* The doc steps: every triangle's material in range, every uv finite. */
static void doc_path(const uint8_t *data, size_t size, const struct mesh_gltf_opts *o) {
    struct mesh_limits lim = {.max_vertices = 100000, .max_triangles = 100000};
    struct rayd_error err;
    struct gltf_doc *d = NULL;
    if (gltf_doc_open(data, size, o, &err, &d) != RAYD_OK) return;
    struct gltf_mats g = {0};
    struct mesh_data m = {0};
    int32_t *tm = NULL;
    if (gltf_doc_walk(d, -1, &lim) == RAYD_OK &&
        gltf_mats_read(d, 64, TEXTURE_MAX_SCENE_PIXELS, NULL, NULL, &g, &err) == RAYD_OK &&
        gltf_doc_bake(d, g.uv_set, g.n + 1, &m, &tm) == RAYD_OK) {
        for (uint32_t t = 0; t < m.ntris; t++)
            if (tm[t] < -1 || tm[t] >= g.n) abort();
        for (size_t i = 0; m.uv && i < (size_t)m.nverts * 2; i++)
            if (!isfinite(m.uv[i])) abort();
        for (size_t i = 0; i < (size_t)m.ntris * 3; i++)
            if (m.index[i] >= m.nverts) abort();
    }
    free(tm);
    mesh_data_free(&m);
    gltf_mats_free(&g);
    gltf_doc_free(d);
}

/* The bytes as a gltf object of a scene. */
static void scene_path(const uint8_t *data, size_t size) {
    static const char t[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    size_t cap = (size + 2) / 3 * 4 + 300;
    char *json = malloc(cap);
    if (!json) return;
    int n = snprintf(json, cap,
                     "{\"render\": {\"width\": 4, \"height\": 4}, \"objects\": [{\"type\": "
                     "\"gltf\", %s\"source\": {\"format\": \"%s\", \"base64\": \"",
                     size % 2 ? "\"camera\": 0, " : "",
                     size >= 4 && !memcmp(data, "glTF", 4) ? "glb" : "gltf");
    char *p = json + n;
    for (size_t i = 0; i < size; i += 3) {
        uint32_t v = (uint32_t)data[i] << 16 | (i + 1 < size ? (uint32_t)data[i + 1] << 8 : 0) |
                     (i + 2 < size ? data[i + 2] : 0);
        *p++ = t[v >> 18 & 63];
        *p++ = t[v >> 12 & 63];
        *p++ = i + 1 < size ? t[v >> 6 & 63] : '=';
        *p++ = i + 2 < size ? t[v & 63] : '=';
    }
    strcpy(p, "\"}}]}");
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    lim.max_triangles = lim.max_vertices = 100000;
    lim.max_bytes = 1 << 22;
    rayd_scene *s = NULL;
    struct rayd_error err;
    if (rayd_scene_parse(json, strlen(json), &lim, &s, &err) == RAYD_OK) rayd_scene_free(s);
    free(json);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    struct mesh_limits lim = {.max_vertices = 100000, .max_triangles = 100000};
    struct mesh_gltf_opts o = {.max_bytes = 1 << 20, .max_nesting = 64, .open = open_any};
    struct mesh_data m = {0};
    struct rayd_error err;
    doc_path(data, size, &o);
    scene_path(data, size);
    if (mesh_parse_gltf(data, size, &lim, &o, &m, &err) != RAYD_OK) return 0;
    if (m.ntris == 0) abort();
    for (size_t i = 0; i < (size_t)m.ntris * 3; i++)
        if (m.index[i] >= m.nverts) abort();
    for (size_t i = 0; i < (size_t)m.nverts * 3; i++)
        if (!isfinite(m.pos[i])) abort();
    mesh_data_free(&m);
    return 0;
}
