/* mesh_gltf.c -- glTF 2.0 (.gltf JSON or .glb binary) to one baked triangle mesh.
 *
 * Why cJSON and not assimp: the bytes come from the network, so the reader
 * must be small enough to audit and fuzz, must stop at our limits (bytes,
 * vertices, triangles, nesting) before it allocates, and must say where a
 * file is wrong as a JSON Pointer into the glTF document, the way every
 * other scene error does.  assimp is a large C++ library that reads dozens
 * of formats, allocates as the file says, reports in free text and has had
 * its share of memory-safety bugs on hostile input; what a renderer needs
 * from glTF -- positions, normals, indices and the node transforms -- is a
 * few hundred lines on top of the JSON parser the scene loader already
 * uses, and it reads a million-triangle .glb as fast as binary PLY.
 *
 * What is read: the container (a .glb's JSON and BIN chunks, or the JSON
 * text of a .gltf), buffers (the GLB's BIN chunk, base64 "data:" URIs, or
 * relative file names handed to the caller's opener, which confines them),
 * buffer views and accessors (byteOffset, byteStride, every component
 * type; normalised integers as the spec maps them), and from the default
 * scene (or scene 0, or every root node when there are no scenes) each
 * node's mesh with the node's TRS or matrix composed down the hierarchy.
 * Every primitive of mode 4 (triangles), 5 (strip) or 6 (fan), indexed or
 * not, adds its POSITION (and NORMAL when every primitive drawn has one);
 * a mesh drawn by several nodes is baked once per node.  Positions are
 * transformed by the node's matrix, normals by its inverse transpose, and
 * a mirroring matrix (negative determinant) turns the winding back, as the
 * spec says.  Points and lines are skipped; materials, textures, cameras,
 * lights, skins and morph targets are ignored, and so are animations but
 * for the "gltf" object, which may play one (mesh_gltf_anim.c).
 *
 * Refused, each with the JSON Pointer of the value: any extensionsRequired
 * but the few that change nothing here (Draco and meshopt compression by
 * name), sparse accessors, a node that is its own ancestor or has two
 * parents, nodes nested deeper than GL_MAX_DEPTH, out-of-range indices,
 * counts that run past their buffer view or buffer (all sizes in 64-bit
 * arithmetic from values checked to be integers in range), positions or
 * indices without a bufferView (gl_stored), buffers that together exceed
 * max_bytes (any other accessor without a bufferView counting its zeros as
 * bytes read), non-finite positions, and more vertices or
 * triangles than the limits -- counted over every draw before the output
 * is allocated.  Each node is walked once, so the walk is as long as the
 * file; a mesh's primitives drawn by many nodes multiply, so the primitives
 * drawn (points and lines skipped) are bounded by the triangle limit too.  A file whose primitives
 * are all points or lines has "no triangles".
 *
 * The "gltf" object (scene_json_gltf.c) takes the same reader in steps
 * (gltf_doc_*): open, walk a chosen scene, then bake with each triangle's
 * material index and the TEXCOORD_n its material's texture asks for (v
 * flipped to rayd's), and read bufferViews and URIs for images.  Only that
 * path looks at a primitive's "material" and texture coordinates, so a
 * mesh source reads, refuses and bakes exactly as before.
 *
 * Two passes: the first walks the node tree and checks every primitive it
 * draws (loading the buffers they use, and only those), summing vertices
 * and triangles; the second allocates the mesh once and fills it.
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "format/mesh_gltf.h"

#include "base/error.h"
#include "base/hugemem.h"
#include "format/base64.h"
#include "format/gltf_json.h"
#include "format/json_check.h"
#include "format/json_parse.h"
#include "format/mesh_gltf_private.h"

#define GL_MAX_DEPTH 128 /* nodes nested deeper are refused (the walk recurses) */
#define GLB_JSON 0x4E4F534Au
#define GLB_BIN 0x004E4942u

/* A .glb: 12-byte header, a JSON chunk, then an optional BIN chunk. */
static enum rayd_status gl_glb(struct gl *G, const unsigned char *b, size_t len, const char **json,
                               size_t *jlen) {
    struct jp top = {.s = ""};
    if (len < 20) return gl_fail(G, RAYD_E_INVALID, &top, "GLB file ends early (%zu bytes)", len);
    if (bytes_le32(b + 4) != 2)
        return gl_fail(G, RAYD_E_INVALID, &top, "GLB version %u is not supported (2 is)",
                       bytes_le32(b + 4));
    if (bytes_le32(b + 8) > len)
        return gl_fail(G, RAYD_E_INVALID, &top, "GLB header says %u bytes but there are %zu",
                       bytes_le32(b + 8), len);
    len = bytes_le32(b + 8);
    size_t at = 12;
    for (int k = 0; at + 8 <= len; k++) {
        uint32_t clen = bytes_le32(b + at), type = bytes_le32(b + at + 4);
        if (clen > len - at - 8)
            return gl_fail(G, RAYD_E_INVALID, &top, "GLB chunk %d runs past the end of the file",
                           k);
        if (k == 0 && type != GLB_JSON)
            return gl_fail(G, RAYD_E_INVALID, &top, "GLB's first chunk is not JSON");
        if (k == 0) *json = (const char *)b + at + 8, *jlen = clen;
        if (k == 1 && type == GLB_BIN) G->bin = b + at + 8, G->bin_len = clen;
        at += 8 + (size_t)clen;
    }
    if (!*json) return gl_fail(G, RAYD_E_INVALID, &top, "GLB has no JSON chunk");
    return RAYD_OK;
}

/* Syntax (line and column, nesting), then cJSON. */
static enum rayd_status gl_parse_json(struct gl *G, const char *json, size_t len, cJSON **root) {
    struct rayd_error e = {0};
    struct jp top = {.s = ""};
    if (json_check(json, len, G->o->max_nesting, &e) != RAYD_OK)
        return gl_fail(G, RAYD_E_INVALID, &top, "glTF JSON line %d, column %d: %s", e.line,
                       e.column, e.message);
    *root = json_parse_locked(json, len);
    if (!*root) return gl_fail(G, RAYD_E_NOMEM, &top, "out of memory parsing the glTF JSON");
    if (!cJSON_IsObject(*root))
        return gl_fail(G, RAYD_E_INVALID, &top, "the glTF document must be a JSON object");
    return RAYD_OK;
}

/* asset.version 2.x, and no extension required that would change the geometry. */
static enum rayd_status gl_check_asset(struct gl *G) {
    static const char *const harmless[] = {"KHR_mesh_quantization",
                                           "KHR_texture_transform",
                                           "KHR_lights_punctual",
                                           "KHR_texture_basisu",
                                           "KHR_materials_",
                                           "EXT_texture_webp",
                                           NULL};
    struct jp pa = {.s = "/asset"}, pv = {.s = "/asset/version"}, pe = {.s = "/extensionsRequired"};
    const cJSON *v = gl_get(gl_get(G->root, "asset"), "version");
    if (!cJSON_IsObject(gl_get(G->root, "asset")))
        return gl_fail(G, RAYD_E_INVALID, &pa, "is required (an object with \"version\")");
    if (cJSON_IsNumber(v) && v->valuedouble < 2) /* glTF 1.0 files were written with "version": 1 */
        return gl_fail(G, RAYD_E_INVALID, &pv, "glTF %g is not supported (2.x is)", v->valuedouble);
    if (!cJSON_IsString(v))
        return gl_fail(G, RAYD_E_INVALID, &pv, "must be a string such as \"2.0\"");
    if (strncmp(v->valuestring, "2.", 2) != 0)
        return gl_fail(G, RAYD_E_INVALID, &pv, "glTF %.20s is not supported (2.x is)",
                       v->valuestring);
    const cJSON *req = gl_get(G->root, "extensionsRequired");
    if (req && !cJSON_IsArray(req))
        return gl_fail(G, RAYD_E_INVALID, &pe, "must be an array of strings");
    int i = 0;
    for (const cJSON *e = req ? req->child : NULL; e; e = e->next, i++) {
        struct jp p = jp_index(&pe, i);
        if (!cJSON_IsString(e)) return gl_fail(G, RAYD_E_INVALID, &p, "must be a string");
        const char *const *h = harmless;
        while (*h && strncmp(e->valuestring, *h, strlen(*h)) != 0) h++;
        if (*h) continue;
        if (!strcmp(e->valuestring, "KHR_draco_mesh_compression") ||
            !strcmp(e->valuestring, "EXT_meshopt_compression"))
            return gl_fail(
                G, RAYD_E_INVALID, &p,
                "%s: compressed meshes are not supported; export the file without compression",
                e->valuestring);
        return gl_fail(G, RAYD_E_INVALID, &p, "required extension \"%.60s\" is not supported",
                       e->valuestring);
    }
    return RAYD_OK;
}

/* ---- primitives --------------------------------------------------------- */

/* Triangles of n vertices in a mode (4 list, 5 strip, 6 fan; others none). */
static uint64_t gl_tris(int mode, uint32_t n) {
    if (mode == 4) return n / 3;
    if (mode == 5 || mode == 6) return n >= 3 ? n - 2 : 0;
    return 0;
}

/* Vertex k of triangle t, as an entry of the index list (or the vertex list). */
static uint32_t gl_corner(int mode, uint64_t t, int k) {
    static const int strip[2][3] = {{0, 1, 2}, {1, 0, 2}};
    if (mode == 4) return (uint32_t)(t * 3 + (uint64_t)k);
    if (mode == 5) return (uint32_t)(t + (uint64_t)strip[t % 2][k]);
    return k == 0 ? 0 : (uint32_t)(t + (uint64_t)k); /* fan: (0, t+1, t+2) */
}

struct gl_prim {
    int mode;
    struct gl_acc pos, nrm, ix, uv;
    bool has_nrm, has_ix, has_uv;
    uint64_t ntris;
    int material; /* -1: none (glTF's default material) */
};

/* The whole-scene import's part of a primitive: its material and, when the
 * material's texture wants one, its TEXCOORD_n. */
static enum rayd_status gl_prim_parts(struct gl *G, const struct gl_draw *d, const struct jp *pp,
                                      const cJSON *attr, const struct jp *pat, struct gl_prim *P) {
    const cJSON *mj;
    if (gl_get(d->prim, "material"))
        TRY_GL(gl_ref(G, d->prim, pp, "material", "materials", &P->material, &mj));
    int set = P->material >= 0 && P->material < G->nuv_set ? G->uv_set[P->material] : -1;
    char key[32];
    snprintf(key, sizeof key, "TEXCOORD_%d", set);
    if (set < 0 || !gl_get(attr, key)) return RAYD_OK;
    TRY_GL(gl_accessor(G, attr, pat, key, 2, false, &P->uv));
    P->has_uv = true;
    struct jp pa = gl_item("accessors", P->uv.id);
    if (P->uv.count != P->pos.count)
        return gl_fail(G, RAYD_E_INVALID, &pa, "%s has %u entries but POSITION has %u", key,
                       P->uv.count, P->pos.count);
    return RAYD_OK;
}

/* Positions and indices must be stored in the file.  The spec lets an
 * accessor without a bufferView stand for count zeros, but as positions or
 * indices those are triangles of no area that draw nothing, and a 300-byte
 * file of them would buy seconds of decoding and building a frame (millions
 * of triangles, within max_bytes as zeros count).  What is stored is as
 * long as the file, so the work stays in proportion to the bytes sent. */
static enum rayd_status gl_stored(struct gl *G, const struct gl_acc *a, const char *what) {
    if (a->p) return RAYD_OK;
    struct jp pa = gl_item("accessors", a->id), pv = jp_key(&pa, "bufferView");
    return gl_fail(G, RAYD_E_INVALID, &pv,
                   "is required for %s: without one its %u elements are all zeros, triangles "
                   "of no area",
                   what, a->count);
}

static enum rayd_status gl_prim(struct gl *G, const struct gl_draw *d, struct gl_prim *P) {
    struct jp pm = gl_item("meshes", d->mesh), pl = jp_key(&pm, "primitives"),
              pp = jp_index(&pl, d->index);
    double mode;
    memset(P, 0, sizeof *P);
    P->material = -1;
    TRY_GL(gl_int(G, d->prim, &pp, "mode", 4, 0, 6, &mode));
    P->mode = (int)mode;
    if (mode < 4) return RAYD_OK; /* points and lines: nothing to draw */
    const cJSON *attr = gl_get(d->prim, "attributes");
    struct jp pat = jp_key(&pp, "attributes");
    if (!cJSON_IsObject(attr)) return gl_fail(G, RAYD_E_INVALID, &pat, "is required (an object)");
    TRY_GL(gl_accessor(G, attr, &pat, "POSITION", 3, false, &P->pos));
    TRY_GL(gl_stored(G, &P->pos, "POSITION"));
    P->has_nrm = gl_get(attr, "NORMAL") != NULL;
    if (P->has_nrm) TRY_GL(gl_accessor(G, attr, &pat, "NORMAL", 3, false, &P->nrm));
    struct jp pn = gl_item("accessors", P->nrm.id);
    if (P->has_nrm && P->nrm.count != P->pos.count)
        return gl_fail(G, RAYD_E_INVALID, &pn, "NORMAL has %u entries but POSITION has %u",
                       P->nrm.count, P->pos.count);
    P->has_ix = gl_get(d->prim, "indices") != NULL;
    if (P->has_ix) TRY_GL(gl_accessor(G, d->prim, &pp, "indices", 1, true, &P->ix));
    if (P->has_ix) TRY_GL(gl_stored(G, &P->ix, "indices"));
    P->ntris = gl_tris(P->mode, P->has_ix ? P->ix.count : P->pos.count);
    return G->want_parts ? gl_prim_parts(G, d, &pp, attr, &pat, P) : RAYD_OK;
}

/* ---- the node tree ------------------------------------------------------ */

static void mat_mul(const double *a, const double *b, double *out) {
    double r[16];
    for (int c = 0; c < 4; c++)
        for (int row = 0; row < 4; row++) {
            double s = 0;
            for (int k = 0; k < 4; k++) s += a[k * 4 + row] * b[c * 4 + k];
            r[c * 4 + row] = s;
        }
    memcpy(out, r, sizeof r);
}

/* The node's local matrix: "matrix", or T * R * S. */
static enum rayd_status gl_local(struct gl *G, const cJSON *n, const struct jp *pn, int node,
                                 double *m) {
    static const double id[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    static const double zero[3] = {0, 0, 0}, one[3] = {1, 1, 1}, q0[4] = {0, 0, 0, 1};
    double t[3], q[4], s[3];
    const struct gl_pose *po = G->pose ? &G->pose[node] : NULL;
    bool posed = po && (po->has_t || po->has_r || po->has_s);
    struct jp pm = jp_key(pn, "matrix");
    if (gl_get(n, "matrix") && posed)
        return gl_fail(G, RAYD_E_INVALID, &pm,
                       "an animated node must have translation, rotation and scale, not a matrix");
    if (gl_get(n, "matrix")) return gl_nums(G, n, pn, "matrix", 16, id, m);
    TRY_GL(gl_nums(G, n, pn, "translation", 3, zero, t));
    TRY_GL(gl_nums(G, n, pn, "rotation", 4, q0, q));
    TRY_GL(gl_nums(G, n, pn, "scale", 3, one, s));
    if (po && po->has_t) memcpy(t, po->t, sizeof t);
    if (po && po->has_r) memcpy(q, po->r, sizeof q);
    if (po && po->has_s) memcpy(s, po->s, sizeof s);
    double len = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    struct jp pr = jp_key(pn, "rotation");
    if (!(len > 0)) return gl_fail(G, RAYD_E_INVALID, &pr, "must not be a zero quaternion");
    double x = q[0] / len, y = q[1] / len, z = q[2] / len, w = q[3] / len;
    double r[9] = {1 - 2 * (y * y + z * z), 2 * (x * y + z * w),     2 * (x * z - y * w),
                   2 * (x * y - z * w),     1 - 2 * (x * x + z * z), 2 * (y * z + x * w),
                   2 * (x * z + y * w),     2 * (y * z - x * w),     1 - 2 * (x * x + y * y)};
    for (int c = 0; c < 3; c++) {
        for (int row = 0; row < 3; row++) m[c * 4 + row] = r[c * 3 + row] * s[c];
        m[c * 4 + 3] = 0;
    }
    m[12] = t[0], m[13] = t[1], m[14] = t[2], m[15] = 1;
    return RAYD_OK;
}

static enum rayd_status gl_add_draws(struct gl *G, const cJSON *n, const struct jp *pn, int node) {
    const cJSON *mj;
    int mid;
    if (!gl_get(n, "mesh")) return RAYD_OK;
    TRY_GL(gl_ref(G, n, pn, "mesh", "meshes", &mid, &mj));
    const cJSON *prims = gl_get(mj, "primitives");
    struct jp pm = gl_item("meshes", mid), pp = jp_key(&pm, "primitives");
    if (!prims) return gl_fail(G, RAYD_E_INVALID, &pp, "is required (an array)");
    if (!cJSON_IsArray(prims)) return gl_fail(G, RAYD_E_INVALID, &pp, "must be an array");
    int i = 0;
    for (const cJSON *p = prims->child; p; p = p->next, i++) {
        struct jp pi = jp_index(&pp, i);
        if (!cJSON_IsObject(p)) return gl_fail(G, RAYD_E_INVALID, &pi, "must be an object");
        const cJSON *mode = gl_get(p, "mode");
        if (cJSON_IsNumber(mode) && mode->valuedouble >= 0 && mode->valuedouble < 4) continue;
        /* a mesh's primitives times the nodes drawing it could be far more
         * than the file's size: each counts as a triangle at least */
        if (G->ndraws >= G->max_tris)
            return gl_fail(G, RAYD_E_LIMIT, &pi,
                           "the nodes draw more than %u triangle primitives (the triangle limit)",
                           G->max_tris);
        if (!array_grow((void **)&G->draws, &G->cap_draws, G->ndraws + 1, sizeof *G->draws))
            return gl_fail(G, RAYD_E_NOMEM, pn, "out of memory");
        G->draws[G->ndraws++] = (struct gl_draw){.prim = p, .mesh = mid, .index = i, .node = node};
    }
    return RAYD_OK;
}

/* Node id under the parent matrix pm, its children after it. */
static enum rayd_status gl_node(struct gl *G, int id, const struct jp *from, const double *pm,
                                int depth) {
    const cJSON *nodes = gl_get(G->root, "nodes");
    const cJSON *n = cJSON_GetArrayItem(nodes, id);
    struct jp pn = gl_item("nodes", id);
    if (G->seen[id] == 1)
        return gl_fail(G, RAYD_E_INVALID, from,
                       "node %d is its own ancestor (the node hierarchy has a cycle)", id);
    if (G->seen[id] == 2)
        return gl_fail(G, RAYD_E_INVALID, from,
                       "node %d is reached twice (a node has one parent at most)", id);
    if (depth > GL_MAX_DEPTH)
        return gl_fail(G, RAYD_E_LIMIT, from, "nodes nest more than %d deep", GL_MAX_DEPTH);
    if (!cJSON_IsObject(n)) return gl_fail(G, RAYD_E_INVALID, &pn, "must be an object");
    G->seen[id] = 1;
    double local[16], *m = G->world + (size_t)id * 16;
    TRY_GL(gl_local(G, n, &pn, id, local));
    mat_mul(pm, local, m);
    TRY_GL(gl_add_draws(G, n, &pn, id));
    const cJSON *kids = gl_get(n, "children");
    struct jp pc = jp_key(&pn, "children");
    if (kids && !cJSON_IsArray(kids))
        return gl_fail(G, RAYD_E_INVALID, &pc, "must be an array of node indices");
    int i = 0;
    for (const cJSON *k = kids ? kids->child : NULL; k; k = k->next, i++) {
        struct jp pk = jp_index(&pc, i);
        if (!cJSON_IsNumber(k) || floor(k->valuedouble) != k->valuedouble || k->valuedouble < 0 ||
            k->valuedouble >= G->nnodes)
            return gl_fail(G, RAYD_E_INVALID, &pk, "must be a node index in 0..%d", G->nnodes - 1);
        TRY_GL(gl_node(G, (int)k->valuedouble, &pk, m, depth + 1));
    }
    G->seen[id] = 2;
    return RAYD_OK;
}

/* The roots: scene `scene` when >= 0, else "scene" (or 0), or, without
 * scenes, every node no node names as a child. */
static enum rayd_status gl_walk(struct gl *G, int scene) {
    static const double id[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    const cJSON *nodes = gl_get(G->root, "nodes"), *scenes = gl_get(G->root, "scenes");
    struct jp pnodes = {.s = "/nodes"}, pscenes = {.s = "/scenes"}, top = {.s = ""};
    if (nodes && !cJSON_IsArray(nodes))
        return gl_fail(G, RAYD_E_INVALID, &pnodes, "must be an array");
    if (scenes && !cJSON_IsArray(scenes))
        return gl_fail(G, RAYD_E_INVALID, &pscenes, "must be an array");
    G->nnodes = nodes ? cJSON_GetArraySize(nodes) : 0;
    G->seen = calloc((size_t)G->nnodes + 1, 1);
    G->world = malloc(((size_t)G->nnodes + 1) * 16 * sizeof *G->world);
    if (!G->seen || !G->world) return gl_fail(G, RAYD_E_NOMEM, &top, "out of memory");
    if (G->anim_id >= 0) TRY_GL(G->animate(G));
    if (scene >= 0 && scene >= (scenes ? cJSON_GetArraySize(scenes) : 0))
        return gl_fail(G, RAYD_E_INVALID, &pscenes, "scene %d does not exist (there are %d)", scene,
                       scenes ? cJSON_GetArraySize(scenes) : 0);
    if (scenes && cJSON_GetArraySize(scenes) > 0) {
        const cJSON *sj = cJSON_GetArrayItem(scenes, scene >= 0 ? scene : 0);
        int sid = scene >= 0 ? scene : 0;
        if (scene < 0 && gl_get(G->root, "scene"))
            TRY_GL(gl_ref(G, G->root, &top, "scene", "scenes", &sid, &sj));
        struct jp ps0 = gl_item("scenes", sid);
        if (!cJSON_IsObject(sj)) return gl_fail(G, RAYD_E_INVALID, &ps0, "must be an object");
        const cJSON *roots = gl_get(sj, "nodes");
        struct jp ps = gl_item("scenes", sid), pr = jp_key(&ps, "nodes");
        if (roots && !cJSON_IsArray(roots))
            return gl_fail(G, RAYD_E_INVALID, &pr, "must be an array of node indices");
        int i = 0;
        for (const cJSON *r = roots ? roots->child : NULL; r; r = r->next, i++) {
            struct jp pi = jp_index(&pr, i);
            if (!cJSON_IsNumber(r) || floor(r->valuedouble) != r->valuedouble ||
                r->valuedouble < 0 || r->valuedouble >= G->nnodes)
                return gl_fail(G, RAYD_E_INVALID, &pi, "must be a node index in 0..%d",
                               G->nnodes - 1);
            TRY_GL(gl_node(G, (int)r->valuedouble, &pi, id, 0));
        }
        return RAYD_OK;
    }
    unsigned char *child = calloc((size_t)G->nnodes + 1, 1);
    if (!child) return gl_fail(G, RAYD_E_NOMEM, &top, "out of memory");
    for (const cJSON *n = nodes ? nodes->child : NULL; n; n = n->next) {
        const cJSON *kids = gl_get(n, "children");
        for (const cJSON *k = cJSON_IsArray(kids) ? kids->child : NULL; k; k = k->next)
            if (cJSON_IsNumber(k) && k->valuedouble >= 0 && k->valuedouble < G->nnodes)
                child[(int)k->valuedouble] = 1;
    }
    enum rayd_status st = RAYD_OK;
    for (int i = 0; i < G->nnodes && st == RAYD_OK; i++) {
        struct jp pi = gl_item("nodes", i);
        if (!child[i] && !G->seen[i]) st = gl_node(G, i, &pi, id, 0);
    }
    free(child);
    return st;
}

/* ---- counting, then baking ---------------------------------------------- */

/* Checks every draw, sums vertices and triangles against the limits. */
static enum rayd_status gl_count(struct gl *G) {
    struct jp top = {.s = ""};
    G->normals = true;
    for (size_t i = 0; i < G->ndraws; i++) {
        struct gl_prim P;
        TRY_GL(gl_prim(G, &G->draws[i], &P));
        if (P.ntris == 0) continue;
        G->normals = G->normals && P.has_nrm;
        G->nverts += P.pos.count;
        G->ntris += P.ntris;
        struct jp pm = gl_item("meshes", G->draws[i].mesh), pl = jp_key(&pm, "primitives");
        struct jp pp = jp_index(&pl, G->draws[i].index);
        if (G->nverts > G->max_verts)
            return gl_fail(G, RAYD_E_LIMIT, &pp,
                           "brings the mesh to %llu vertices; the limit is %u",
                           (unsigned long long)G->nverts, G->max_verts);
        if (G->ntris > G->max_tris)
            return gl_fail(G, RAYD_E_LIMIT, &pp,
                           "brings the mesh to %llu triangles; the limit is %u",
                           (unsigned long long)G->ntris, G->max_tris);
    }
    if (G->ntris == 0)
        return gl_fail(
            G, RAYD_E_INVALID, &top,
            "no triangles (the scene's primitives are points or lines, or there are none)");
    G->counted = true;
    return RAYD_OK;
}

static double mat_det3(const double *m) {
    return m[0] * (m[5] * m[10] - m[9] * m[6]) - m[4] * (m[1] * m[10] - m[9] * m[2]) +
           m[8] * (m[1] * m[6] - m[5] * m[2]);
}

/* The normal matrix: the inverse transpose of m's 3x3 part, up to a scale
 * (the cofactors); normals are normalised after. */
static void mat_normal(const double *m, double *n) {
    const double a = m[0], b = m[4], c = m[8], d = m[1], e = m[5], f = m[9], g = m[2], h = m[6],
                 k = m[10];
    double r[9] = {e * k - f * h,    -(d * k - f * g), d * h - e * g,
                   -(b * k - c * h), a * k - c * g,    -(a * h - b * g),
                   b * f - c * e,    -(a * f - c * d), a * e - b * d};
    memcpy(n, r, sizeof r); /* n[row * 3 + col] */
}

/* Texture coordinates of vertex i: glTF's v = 0 is the image's top,
 * rayd's its bottom, so v becomes 1 - v. */
static enum rayd_status gl_uv(struct gl *G, const struct gl_prim *P, uint32_t i, float *o) {
    if (!P->has_uv) {
        o[0] = o[1] = 0;
        return RAYD_OK;
    }
    double u = gl_value(&P->uv, i, 0), v = gl_value(&P->uv, i, 1);
    struct jp pa = gl_item("accessors", P->uv.id);
    if (!isfinite(u) || !isfinite(v) || fabs(u) > 1e6 || fabs(v) > 1e6)
        return gl_fail(G, RAYD_E_INVALID, &pa, "TEXCOORD %u is not finite (or beyond 1e6)", i);
    o[0] = (float)u;
    o[1] = (float)(1 - v);
    return RAYD_OK;
}

static enum rayd_status gl_vertices(struct gl *G, const struct gl_draw *d,
                                    const struct gl_prim *P) {
    double nm[9];
    const double *m = G->world + (size_t)d->node * 16;
    mat_normal(m, nm);
    for (uint32_t i = 0; i < P->pos.count; i++) {
        double p[3] = {gl_value(&P->pos, i, 0), gl_value(&P->pos, i, 1), gl_value(&P->pos, i, 2)};
        float *o = G->pos + (size_t)(G->vat + i) * 3;
        for (int r = 0; r < 3; r++) {
            double v = m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r];
            if (!isfinite(v) || fabs(v) > 1e30) {
                struct jp pa = gl_item("accessors", P->pos.id);
                return gl_fail(G, RAYD_E_INVALID, &pa,
                               "POSITION %u is not finite (or beyond 1e30 once placed)", i);
            }
            o[r] = (float)v;
        }
        if (G->uv) TRY_GL(gl_uv(G, P, i, G->uv + (size_t)(G->vat + i) * 2));
        if (!G->normals) continue;
        double n[3] = {gl_value(&P->nrm, i, 0), gl_value(&P->nrm, i, 1), gl_value(&P->nrm, i, 2)},
               w[3];
        for (int r = 0; r < 3; r++)
            w[r] = nm[r * 3] * n[0] + nm[r * 3 + 1] * n[1] + nm[r * 3 + 2] * n[2];
        double len = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
        float *on = G->nrm + (size_t)(G->vat + i) * 3;
        for (int r = 0; r < 3; r++)
            on[r] = len > 0 && isfinite(len) ? (float)(w[r] / len) : (r == 1 ? 1.0f : 0.0f);
    }
    return RAYD_OK;
}

static enum rayd_status gl_triangles(struct gl *G, const struct gl_draw *d,
                                     const struct gl_prim *P) {
    bool flip = mat_det3(G->world + (size_t)d->node * 16) < 0;
    for (uint64_t t = 0; t < P->ntris; t++) {
        uint32_t v[3];
        for (int k = 0; k < 3; k++) {
            uint32_t c = gl_corner(P->mode, t, k);
            v[k] = P->has_ix ? (uint32_t)gl_value(&P->ix, c, 0) : c;
            if (v[k] >= P->pos.count) {
                struct jp pa = gl_item("accessors", P->ix.id);
                return gl_fail(
                    G, RAYD_E_INVALID, &pa,
                    "element %u is %u, out of range (the primitive's POSITION has %u vertices)", c,
                    v[k], P->pos.count);
            }
        }
        uint32_t *o = G->idx + (size_t)G->tat * 3;
        o[0] = G->vat + v[0];
        o[1] = G->vat + v[flip ? 2 : 1];
        o[2] = G->vat + v[flip ? 1 : 2];
        if (G->tmat) G->tmat[G->tat] = P->material;
        G->tat++;
    }
    G->vat += P->pos.count;
    return RAYD_OK;
}

/* The bake's mesh arrays (positions, normals, texture coordinates,
 * indices) charged to the caller's hook before they are allocated, from
 * the counts the walk found; a refusal's path is the document's ("").
 * The per-triangle materials (4 bytes a triangle) are not mesh_data's,
 * and are left to the caller. */
static enum rayd_status gl_charge(struct gl *G, const struct jp *top) {
    size_t per_vertex =
        (3 + (G->normals ? 3 : 0) + (G->want_parts && G->nuv_set > 0 ? 2 : 0)) * sizeof(float);
    size_t bytes = (size_t)G->nverts * per_vertex + (size_t)G->ntris * 3 * sizeof(uint32_t);
    char why[200];
    enum rayd_status st = mesh_charge(G->lim, &G->charged, bytes, why, sizeof why);
    if (st != RAYD_OK)
        return gl_fail(G, st, top, "%llu vertices and %llu triangles: %s",
                       (unsigned long long)G->nverts, (unsigned long long)G->ntris, why);
    return RAYD_OK;
}

static enum rayd_status gl_bake(struct gl *G) {
    struct jp top = {.s = ""};
    TRY_GL(gl_charge(G, &top));
    /* huge pages, as the PLY reader's: a million triangles fault far fewer pages */
    G->pos = huge_alloc((size_t)G->nverts * 3 * sizeof *G->pos);
    G->nrm = G->normals ? huge_alloc((size_t)G->nverts * 3 * sizeof *G->nrm) : NULL;
    G->idx = huge_alloc((size_t)G->ntris * 3 * sizeof *G->idx);
    if (G->want_parts) {
        G->tmat = malloc((size_t)G->ntris * sizeof *G->tmat);
        G->uv = G->nuv_set > 0 ? malloc((size_t)G->nverts * 2 * sizeof *G->uv) : NULL;
        if (!G->tmat || (G->nuv_set > 0 && !G->uv))
            return gl_fail(G, RAYD_E_NOMEM, &top, "out of memory for %llu vertices",
                           (unsigned long long)G->nverts);
    }
    if (!G->pos || !G->idx || (G->normals && !G->nrm))
        return gl_fail(G, RAYD_E_NOMEM, &top, "out of memory for %llu vertices",
                       (unsigned long long)G->nverts);
    for (size_t i = 0; i < G->ndraws; i++) {
        struct gl_prim P;
        TRY_GL(gl_prim(G, &G->draws[i], &P));
        if (P.ntris == 0) continue;
        TRY_GL(gl_vertices(G, &G->draws[i], &P));
        TRY_GL(gl_triangles(G, &G->draws[i], &P));
    }
    return RAYD_OK;
}

/* ---- entry -------------------------------------------------------------- */

static void gl_release(struct gl *G, cJSON *root) {
    for (int i = 0; G->bufs && i < G->nbufs; i++) /* no table: its calloc failed */
        if (G->bufs[i].owned) free(G->bufs[i].data);
    free(G->bufs);
    free(G->draws);
    free(G->seen);
    free(G->world);
    free(G->pos);
    free(G->nrm);
    free(G->idx);
    free(G->tmat);
    free(G->uv);
    free(G->pose);
    mesh_give_back(G->lim, &G->charged, G->charged); /* what the bake did not hand over */
    cJSON_Delete(root);
}

/* The container, the JSON, asset and extensions, and the buffer table. */
static enum rayd_status gl_open(struct gl *G, const unsigned char *b, size_t len, cJSON **root) {
    const char *json = (const char *)b;
    size_t jlen = len;
    struct jp pb = {.s = "/buffers"};
    if (len >= 4 && !memcmp(b, "glTF", 4)) {
        json = NULL;
        TRY_GL(gl_glb(G, b, len, &json, &jlen));
    }
    TRY_GL(gl_parse_json(G, json, jlen, root));
    G->root = *root;
    TRY_GL(gl_check_asset(G));
    const cJSON *bufs = gl_get(G->root, "buffers");
    if (bufs && !cJSON_IsArray(bufs)) return gl_fail(G, RAYD_E_INVALID, &pb, "must be an array");
    G->nbufs = bufs ? cJSON_GetArraySize(bufs) : 0;
    G->bufs = calloc((size_t)G->nbufs + 1, sizeof *G->bufs);
    if (!G->bufs) return gl_fail(G, RAYD_E_NOMEM, &pb, "out of memory");
    return RAYD_OK;
}

static enum rayd_status gl_read(struct gl *G, const unsigned char *b, size_t len, cJSON **root) {
    TRY_GL(gl_open(G, b, len, root));
    TRY_GL(gl_walk(G, -1));
    TRY_GL(gl_count(G));
    return gl_bake(G);
}

enum rayd_status mesh_parse_gltf(const void *data, size_t len, const struct mesh_limits *lim,
                                 const struct mesh_gltf_opts *o, struct mesh_data *out,
                                 struct rayd_error *err) {
    struct mesh_gltf_opts def = {.max_bytes = (size_t)256 << 20, .max_nesting = 64};
    struct gl G = {.o = o ? o : &def,
                   .err = err,
                   .max_verts = mesh_max_vertices(lim),
                   .max_tris = mesh_max_triangles(lim),
                   .lim = lim,
                   .anim_id = -1};
    cJSON *root = NULL;
    enum rayd_status st = gl_read(&G, data, len, &root);
    if (st == RAYD_OK) {
        *out = (struct mesh_data){.pos = G.pos,
                                  .normal = G.nrm,
                                  .index = G.idx,
                                  .nverts = (uint32_t)G.nverts,
                                  .ntris = (uint32_t)G.ntris,
                                  .charged = G.charged};
        G.pos = G.nrm = NULL;
        G.idx = NULL;
        G.charged = 0; /* the mesh's now */
    }
    gl_release(&G, root);
    return st;
}

/* ---- the whole-scene import (scene_json_gltf.c) ------------------------- */

enum rayd_status gltf_doc_open(const void *data, size_t len, const struct mesh_gltf_opts *o,
                               struct rayd_error *err, struct gltf_doc **out) {
    struct gltf_doc *d = calloc(1, sizeof *d);
    if (!d) return err_set(err, RAYD_E_NOMEM, "", "out of memory");
    d->o = *o;
    d->G.o = &d->o;
    d->G.err = err;
    d->G.anim_id = -1;
    enum rayd_status st = gl_open(&d->G, data, len, &d->root);
    if (st != RAYD_OK) {
        gltf_doc_free(d);
        return st;
    }
    *out = d;
    return RAYD_OK;
}

const cJSON *gltf_doc_root(const struct gltf_doc *d) { return d->root; }

enum rayd_status gltf_doc_walk(struct gltf_doc *d, int scene, const struct mesh_limits *lim) {
    struct jp top = {.s = ""};
    if (d->walked) return gl_fail(&d->G, RAYD_E_INVALID, &top, "the scene is walked once");
    d->walked = true;
    d->G.max_verts = mesh_max_vertices(lim);
    d->G.max_tris = mesh_max_triangles(lim);
    d->lim = lim ? *lim : (struct mesh_limits){0}; /* the bake charges through its hook */
    d->G.lim = &d->lim;
    return gl_walk(&d->G, scene);
}

const double *gltf_doc_world(const struct gltf_doc *d, int node) {
    if (!d->walked || node < 0 || node >= d->G.nnodes || d->G.seen[node] != 2) return NULL;
    return d->G.world + (size_t)node * 16;
}

enum rayd_status gltf_doc_bake(struct gltf_doc *d, const int *uv_set, int nuv_set,
                               struct mesh_data *out, int32_t **tri_mat) {
    struct gl *G = &d->G;
    struct jp top = {.s = ""};
    if (!d->walked || d->baked)
        return gl_fail(G, RAYD_E_INVALID, &top, "walk the scene once, then bake once");
    d->baked = true;
    G->want_parts = true;
    G->uv_set = uv_set;
    G->nuv_set = nuv_set;
    TRY_GL(gl_count(G));
    TRY_GL(gl_bake(G));
    *out = (struct mesh_data){.pos = G->pos,
                              .normal = G->nrm,
                              .uv = G->uv,
                              .index = G->idx,
                              .nverts = (uint32_t)G->nverts,
                              .ntris = (uint32_t)G->ntris,
                              .charged = G->charged};
    G->charged = 0; /* the mesh's now */
    *tri_mat = G->tmat;
    G->pos = G->nrm = G->uv = NULL;
    G->idx = NULL;
    G->tmat = NULL;
    return RAYD_OK;
}

enum rayd_status gltf_doc_view(struct gltf_doc *d, const cJSON *o, const char *at, const char *key,
                               const unsigned char **p, size_t *len) {
    struct gl *G = &d->G;
    struct jp pa = {.s = ""};
    snprintf(pa.s, sizeof pa.s, "%s", at);
    const cJSON *vj;
    int vid;
    TRY_GL(gl_ref(G, o, &pa, key, "bufferViews", &vid, &vj));
    struct jp pv = gl_item("bufferViews", vid);
    struct gl_span v;
    TRY_GL(gl_view_span(G, vj, &pv, &v));
    TRY_GL(gl_view_bytes(G, &pv, &v, p));
    *len = (size_t)v.len;
    return RAYD_OK;
}

enum rayd_status gltf_doc_uri(struct gltf_doc *d, const char *uri, const char *at,
                              unsigned char **p, size_t *len) {
    struct gl *G = &d->G;
    struct jp pu = {.s = ""};
    struct gl_buf b = {0};
    snprintf(pu.s, sizeof pu.s, "%s", at);
    if (!strncmp(uri, "data:", 5)) {
        TRY_GL(gl_data_uri(G, uri, &pu, &b));
    } else {
        TRY_GL(gl_file_uri(G, uri, &pu, &b));
    }
    if ((G->loaded += b.len) > G->o->max_bytes) {
        free(b.data);
        return gl_fail(G, RAYD_E_LIMIT, &pu,
                       "the buffers and images come to %zu bytes; the limit is %zu", G->loaded,
                       G->o->max_bytes);
    }
    *p = b.data;
    *len = b.len;
    return RAYD_OK;
}

void gltf_doc_free(struct gltf_doc *d) {
    if (!d) return;
    gl_release(&d->G, d->root);
    free(d);
}
