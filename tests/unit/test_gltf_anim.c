/* test_gltf_anim.c -- glTF node animations (mesh_gltf_anim.c gl_animate): the
 * translation, rotation and scale channels with LINEAR, STEP and
 * CUBICSPLINE samplers, on a small file made here and on Debian's
 * assimp-testmodels file that has node animation (simple_skin.gltf), and
 * the "gltf" object's "animation" key at a scene's frames. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "format/mesh_gltf.h"
#include "scene/scene.h"
#include "scene_util.h"

static const char B64[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

static void b64(const unsigned char *in, size_t n, char *out) {
    size_t o = 0;
    for (size_t i = 0; i < n; i += 3) {
        uint32_t v = (uint32_t)in[i] << 16 | (i + 1 < n ? (uint32_t)in[i + 1] << 8 : 0) |
                     (i + 2 < n ? in[i + 2] : 0);
        out[o++] = B64[v >> 18 & 63];
        out[o++] = B64[v >> 12 & 63];
        out[o++] = i + 1 < n ? B64[v >> 6 & 63] : '=';
        out[o++] = i + 2 < n ? B64[v & 63] : '=';
    }
    out[o] = 0;
}

/* A triangle at node 0, animated: translation LINEAR, rotation STEP, scale
 * CUBICSPLINE, keys at 0, 1 and 2 seconds. */
static char *anim_gltf(void) {
    float f[60] = {0, 0, 0, 1, 0, 0, 0,           1,           0,          /* positions, 0 */
                   0, 1, 2,                                                /* times, 36 */
                   0, 0, 0, 2, 0, 0, 2,           4,           0,          /* translation, 48 */
                   0, 0, 0, 1, 0, 0, 0.70710678f, 0.70710678f, 0, 0, 1, 0, /* rotation, 84 */
                   0, 0, 0, 1, 1, 1, 1,           0,           0,          /* scale: key 0, 132 */
                   0, 0, 0, 2, 2, 2, 0,           0,           0,          /* key 1 */
                   0, 0, 0, 3, 3, 3, 0,           0,           0};         /* key 2 */
    char enc[400];
    b64((const unsigned char *)f, 240, enc);
    char *j = malloc(4096);
    snprintf(j, 4096,
             "{\"asset\": {\"version\": \"2.0\"}, \"scenes\": [{\"nodes\": [0]}],"
             " \"nodes\": [{\"mesh\": 0}],"
             " \"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0}}]}],"
             " \"buffers\": [{\"byteLength\": 240, \"uri\": "
             "\"data:application/octet-stream;base64,%s\"}],"
             " \"bufferViews\": [{\"buffer\": 0, \"byteLength\": 240}],"
             " \"accessors\": ["
             "  {\"bufferView\": 0, \"componentType\": 5126, \"count\": 3, \"type\": \"VEC3\"},"
             "  {\"bufferView\": 0, \"byteOffset\": 36, \"componentType\": 5126, \"count\": 3, "
             "\"type\": \"SCALAR\"},"
             "  {\"bufferView\": 0, \"byteOffset\": 48, \"componentType\": 5126, \"count\": 3, "
             "\"type\": \"VEC3\"},"
             "  {\"bufferView\": 0, \"byteOffset\": 84, \"componentType\": 5126, \"count\": 3, "
             "\"type\": \"VEC4\"},"
             "  {\"bufferView\": 0, \"byteOffset\": 132, \"componentType\": 5126, \"count\": 9, "
             "\"type\": \"VEC3\"}],"
             " \"animations\": [{\"name\": \"move\", \"channels\": ["
             "   {\"sampler\": 0, \"target\": {\"node\": 0, \"path\": \"translation\"}},"
             "   {\"sampler\": 1, \"target\": {\"node\": 0, \"path\": \"rotation\"}},"
             "   {\"sampler\": 2, \"target\": {\"node\": 0, \"path\": \"scale\"}},"
             "   {\"sampler\": 0, \"target\": {\"node\": 0, \"path\": \"weights\"}}],"
             "  \"samplers\": [{\"input\": 1, \"output\": 2},"
             "   {\"input\": 1, \"output\": 3, \"interpolation\": \"STEP\"},"
             "   {\"input\": 1, \"output\": 4, \"interpolation\": \"CUBICSPLINE\"}]}]}",
             enc);
    return j;
}

/* Node's world matrix (column-major) with animation 0 at t seconds. */
static int world_at(const char *text, size_t len, int node, double t, double *m,
                    struct rayd_error *err) {
    struct mesh_gltf_opts o = {.max_bytes = 1 << 24, .max_nesting = 64};
    struct gltf_doc *d = NULL;
    memset(err, 0, sizeof *err);
    if (gltf_doc_open(text, len, &o, err, &d) != RAYD_OK) return -1;
    gltf_doc_animate(d, 0, t);
    int rc = -1;
    if (gltf_doc_walk(d, -1, NULL) == RAYD_OK && gltf_doc_world(d, node)) {
        memcpy(m, gltf_doc_world(d, node), 16 * sizeof *m);
        rc = 0;
    }
    gltf_doc_free(d);
    return rc;
}

static void test_channels(void) {
    char *j = anim_gltf();
    double m[16];
    struct rayd_error err;
    /* t = 0.5: translation halfway (1, 0, 0); rotation holds key 0 (STEP);
     * scale on the Hermite curve from 1 (out-tangent 1 in x) to 2:
     * x = 0.5 + 0.125 + 1 = 1.625, y = z = 1.5 */
    CHECK(world_at(j, strlen(j), 0, 0.5, m, &err) == 0, "%s %s", err.path, err.message);
    CHECK_NEAR(m[12], 1, 1e-6);
    CHECK_NEAR(m[13], 0, 1e-6);
    CHECK_NEAR(m[0], 1.625, 1e-6);
    CHECK_NEAR(m[5], 1.5, 1e-6);
    CHECK_NEAR(m[10], 1.5, 1e-6);
    CHECK_NEAR(m[1], 0, 1e-6);
    /* t = 1.5: translation (2, 2, 0); rotation key 1, a quarter turn about
     * z; scale 2.5: the x axis goes to (0, 2.5, 0) */
    CHECK(world_at(j, strlen(j), 0, 1.5, m, &err) == 0, "%s", err.message);
    CHECK_NEAR(m[12], 2, 1e-6);
    CHECK_NEAR(m[13], 2, 1e-6);
    CHECK_NEAR(m[0], 0, 1e-6);
    CHECK_NEAR(m[1], 2.5, 1e-6);
    CHECK_NEAR(m[4], -2.5, 1e-6);
    /* at a key exactly, and after the last key: the key's values */
    CHECK(world_at(j, strlen(j), 0, 1, m, &err) == 0, "%s", err.message);
    CHECK_NEAR(m[12], 2, 1e-6);
    CHECK_NEAR(m[1], 2, 1e-6);
    CHECK(world_at(j, strlen(j), 0, 9, m, &err) == 0, "%s", err.message);
    CHECK_NEAR(m[12], 2, 1e-6);
    CHECK_NEAR(m[13], 4, 1e-6);
    CHECK_NEAR(m[0], -3, 1e-6); /* half a turn, scale 3 */
    free(j);
}

/* Broken animations are named by their pointer in the glTF. */
static void test_bad_channels(void) {
    char *j = anim_gltf();
    double m[16];
    struct rayd_error err;
    char *p = strstr(j, "\"STEP\"");
    memcpy(p, "\"STOP\"", 6);
    CHECK(world_at(j, strlen(j), 0, 0.5, m, &err) != 0 &&
              !strcmp(err.path, "/animations/0/samplers/1/interpolation"),
          "%s: %s", err.path, err.message);
    memcpy(p, "\"STEP\"", 6);
    p = strstr(j, "\"count\": 9");
    p[9] = '8';
    CHECK(world_at(j, strlen(j), 0, 0.5, m, &err) != 0 && !strcmp(err.path, "/accessors/4/count"),
          "%s: %s", err.path, err.message);
    p[9] = '9';
    p = strstr(j, "\"node\": 0, \"path\": \"scale\"");
    p[8] = '7';
    CHECK(world_at(j, strlen(j), 0, 0.5, m, &err) != 0 &&
              !strcmp(err.path, "/animations/0/channels/2/target/node"),
          "%s: %s", err.path, err.message);
    free(j);
}

/* simple_skin.gltf (assimp-testmodels): node 2 turns about z, LINEAR,
 * keys every 0.5 s: 0, 45, 90, 90, 45, 0, ... degrees (quaternions with
 * three decimals).  Its world matrix is node 1's translation (0, 1, 0)
 * times the turn; slerp turns at a steady speed between keys. */
static void test_simple_skin(void) {
    const char *path = "/usr/share/assimp/models/glTF2/simple_skin/simple_skin.gltf";
    size_t len = 0;
    char *text = read_file(path, &len);
    CHECK(text != NULL, "missing %s (make test-deps installs assimp-testmodels)", path);
    if (!text) return;
    const double ts[] = {0, 0.25, 0.75, 1.25, 5.5, 9};
    const double deg[] = {0, 22.5, 67.5, 90, 0, 0};
    for (int i = 0; i < 6; i++) {
        double m[16];
        struct rayd_error err;
        CHECK(world_at(text, len, 2, ts[i], m, &err) == 0, "%s: %s", err.path, err.message);
        double a = atan2(m[1], m[0]) * 180 / M_PI;
        CHECK_NEAR(a, deg[i], 0.05);
        CHECK_NEAR(m[13], 1, 1e-9);
        CHECK_NEAR(hypot(m[0], m[1]), 1, 1e-9); /* slerp keeps it a rotation */
    }
    free(text);
}

#define SCENE_FMT                                                                                  \
    "{%s \"render\": {\"width\": 24, \"height\": 24},"                                             \
    " \"camera\": {\"position\": [1, 2, 12], \"look_at\": [1, 2, 0]},"                             \
    " \"lights\": [{\"type\": \"directional\", \"direction\": [0, 0, -1]}],"                       \
    " \"objects\": [{\"type\": \"gltf\", %s \"source\": {\"base64\": \"%s\", \"format\": "         \
    "\"gltf\"}}]}"

/* The scene: a gltf object plays its animation at the scene's frames. */
static void test_scene(void) {
    char *g = anim_gltf();
    char enc[8192], *scene = malloc(16384);
    b64((const unsigned char *)g, strlen(g), enc);
    snprintf(scene, 16384, SCENE_FMT, "\"animation\": {\"end\": 4, \"fps\": 2},", "", enc);
    rayd_scene *s[5] = {0};
    struct rayd_error err = {0};
    for (int f = 0; f < 5; f++) {
        CHECK(rayd_scene_parse_frame(scene, strlen(scene), NULL, f, &s[f], &err) == RAYD_OK,
              "frame %d: %s %s", f, err.path, err.message);
    }
    /* frame 1 is 0.5 s: the triangle has moved and grown; frame 0 is the rest pose */
    rayd_image *a = s[0] ? render_all(s[0], 1) : NULL, *b = s[1] ? render_all(s[1], 1) : NULL;
    CHECK(a && b && memcmp(rayd_image_pixels(a), rayd_image_pixels(b), 24 * 24 * 3) != 0,
          "frame 1 differs from frame 0");
    rayd_image_free(a);
    rayd_image_free(b);
    for (int f = 0; f < 5; f++) rayd_scene_free(s[f]);
    /* by name; a still scene plays nothing and refuses the key */
    snprintf(scene, 16384, SCENE_FMT, "\"animation\": {\"end\": 4},", "\"animation\": \"move\",",
             enc);
    rayd_scene *x = scene_from(scene);
    CHECK(x != NULL, "by name");
    rayd_scene_free(x);
    snprintf(scene, 16384, SCENE_FMT, "\"animation\": {\"end\": 4},", "\"animation\": 3,", enc);
    x = NULL;
    CHECK(rayd_scene_parse(scene, strlen(scene), NULL, &x, &err) != RAYD_OK &&
              !strcmp(err.path, "/objects/0/animation"),
          "%s: %s", err.path, err.message);
    snprintf(scene, 16384, SCENE_FMT, "", "\"animation\": 0,", enc);
    CHECK(rayd_scene_parse(scene, strlen(scene), NULL, &x, &err) != RAYD_OK &&
              !strcmp(err.path, "/objects/0/animation") && strstr(err.message, "needs /animation"),
          "%s: %s", err.path, err.message);
    free(scene);
    free(g);
}

int main(void) {
    RUN(test_channels);
    RUN(test_bad_channels);
    RUN(test_simple_skin);
    RUN(test_scene);
    CHECK_EXIT();
}
