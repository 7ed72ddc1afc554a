/* test_features.c -- scene features checked against analytic expectations:
 * CSG, transforms of groups (instances), textures, the orthographic and
 * thin-lens cameras, spot and area lights, and the path tracer's
 * convergence. */
#include <stdarg.h>
#include <stdlib.h>

#include "check.h"
#include "render/render.h"
#include "scene/scene.h"
#include "scene_util.h"

static const uint8_t *px_at(const rayd_image *img, int i, int j) {
    return rayd_image_pixels_const(img) + ((size_t)j * rayd_image_width(img) + i) * 3;
}

static void test_csg_sphere_minus_box_along_an_axis(void) {
    /* Orthographic view down -z of a unit sphere minus the box z > 0.3:
     * inside radius sqrt(1 - 0.09) the cut face (the box's green) shows,
     * in the ring out to 1 the sphere (red), outside the background. */
    const char *json = "{\"camera\": {\"position\": [0,0,5], \"look_at\": [0,0,0], \"projection\": "
                       "\"orthographic\", \"view_width\": 2.4},"
                       " \"render\": {\"width\": 97, \"height\": 97},"
                       " \"objects\": [{\"type\": \"csg\", \"op\": \"difference\", \"operands\": ["
                       "   {\"type\": \"sphere\", \"radius\": 1, \"material\": {\"color\": "
                       "[0,0,0], \"emission\": [1,0,0]}},"
                       "   {\"type\": \"box\", \"min\": [-2,-2,0.3], \"max\": [2,2,2], "
                       "\"material\": {\"color\": [0,0,0], \"emission\": [0,1,0]}}]}]}";
    rayd_scene *s = scene_from(json);
    CHECK(s != NULL, "parse");
    if (!s) return;
    rayd_image *img = render_all(s, 2);
    int bad = 0, green = 0, red = 0;
    for (int j = 0; j < 97; j++)
        for (int i = 0; i < 97; i++) {
            double x = 1.2 * ((i + 0.5) - 48.5) / 48.5, y = 1.2 * (48.5 - (j + 0.5)) / 48.5;
            double r2 = x * x + y * y;
            if (fabs(r2 - 0.91) < 2e-3 || fabs(r2 - 1) < 2e-3) continue; /* edges */
            const uint8_t *p = px_at(img, i, j);
            int want = r2 < 0.91 ? 1 : r2 < 1 ? 0 : 2; /* green, red, black */
            green += want == 1;
            red += want == 0;
            int got = p[1] == 255 && p[0] == 0   ? 1
                      : p[0] == 255 && p[1] == 0 ? 0
                      : p[0] == 0 && p[1] == 0   ? 2
                                                 : 3;
            bad += got != want;
        }
    CHECK(green > 1000 && red > 20, "regions %d %d", green, red);
    CHECK(bad == 0, "%d pixels differ from the analytic CSG", bad);
    rayd_image_free(img);
    rayd_scene_free(s);
}

static void test_csg_operations_on_the_line(void) {
    /* two unit spheres at x = 0 and x = 1 on the x axis */
    const char *fmt_ops[] = {"union", "intersection", "difference"};
    double from_left[] = {-1, 0, -1}, from_right[] = {2, 1, 0};
    for (int k = 0; k < 3; k++) {
        char json[512];
        snprintf(json, sizeof json,
                 "{\"objects\": [{\"type\": \"csg\", \"op\": \"%s\", \"operands\": ["
                 "{\"type\": \"sphere\"}, {\"type\": \"sphere\", \"center\": [1,0,0]}]}]}",
                 fmt_ops[k]);
        rayd_scene *s = scene_from(json);
        CHECK(s != NULL, "parse %s", fmt_ops[k]);
        if (!s) continue;
        struct hit h;
        struct surface sf;
        ray a = {v3(-10, 0, 0), v3(1, 0, 0)}, b = {v3(10, 0, 0), v3(-1, 0, 0)};
        CHECK(scene_intersect(s, &a, INFINITY, &h) && fabs(ray_at(&a, h.t).x - from_left[k]) < 1e-9,
              "%s from the left at x = %g", fmt_ops[k], from_left[k]);
        scene_surface(s, &a, &h, &sf);
        CHECK(v3_dot(sf.ng, a.d) < 0, "%s: the outward normal faces the incoming ray", fmt_ops[k]);
        CHECK(scene_intersect(s, &b, INFINITY, &h) &&
                  fabs(ray_at(&b, h.t).x - from_right[k]) < 1e-9,
              "%s from the right at x = %g (got %g)", fmt_ops[k], from_right[k], ray_at(&b, h.t).x);
        scene_surface(s, &b, &h, &sf);
        CHECK(v3_dot(sf.ng, b.d) < 0, "%s from the right: normal out of the result", fmt_ops[k]);
        rayd_scene_free(s);
    }
}

static void test_csg_touching_operands_have_no_inner_face(void) {
    /* Two boxes that share the face x = 0.  Seen from inside, a union has
     * no surface there (the ray leaves at x = 1); an intersection of a box
     * with one sharing its face x = -1 starts there. */
    rayd_scene *s =
        scene_from("{\"objects\": [{\"type\": \"csg\", \"op\": \"union\", \"operands\": ["
                   "{\"type\": \"box\", \"min\": [-1,-1,-1], \"max\": [0,1,1]},"
                   " {\"type\": \"box\", \"min\": [0,-1,-1], \"max\": [1,1,1]}]}]}");
    CHECK(s != NULL, "parse");
    if (!s) return;
    struct hit h;
    struct surface sf;
    ray in = {v3(-0.5, 0.1, 0.2), v3(1, 0, 0)}, back = {v3(0.5, 0.1, 0.2), v3(-1, 0, 0)};
    CHECK(scene_intersect(s, &in, INFINITY, &h) && fabs(ray_at(&in, h.t).x - 1) < 1e-12,
          "from inside the union the ray leaves at x = 1 (got x = %g)", ray_at(&in, h.t).x);
    scene_surface(s, &in, &h, &sf);
    CHECK(sf.ng.x > 0.999, "and the normal there points out, along +x");
    CHECK(scene_intersect(s, &back, INFINITY, &h) && fabs(ray_at(&back, h.t).x + 1) < 1e-12,
          "backwards it leaves at x = -1 (got x = %g)", ray_at(&back, h.t).x);
    rayd_scene_free(s);
    s = scene_from("{\"objects\": [{\"type\": \"csg\", \"op\": \"intersection\", \"operands\": ["
                   "{\"type\": \"box\", \"min\": [-1,-1,-1], \"max\": [1,1,1]},"
                   " {\"type\": \"box\", \"min\": [-1,-1,-1], \"max\": [0.5,1,1]}]}]}");
    CHECK(s != NULL, "parse the intersection");
    if (!s) return;
    ray out = {v3(-5, 0.1, 0.2), v3(1, 0, 0)};
    CHECK(scene_intersect(s, &out, INFINITY, &h) && fabs(ray_at(&out, h.t).x + 1) < 1e-12,
          "the intersection starts at the shared face x = -1");
    rayd_scene_free(s);
}

static void test_csg_keeps_every_crossing(void) {
    /* 96 tori in three nested unions of 32, each crossed 4 times by the z
     * axis: 384 crossings, more than a CSG hit keeps on the stack, listed
     * far to near: the nearest, at z = 0, is hit at z = 1.25, though all
     * the others' crossings come first. */
    size_t cap = 32768, n = 0;
    char *b = malloc(cap);
    n += (size_t)snprintf(b + n, cap - n,
                          "{\"objects\": [{\"type\": \"csg\", \"op\": \"union\", \"operands\": [");
    for (int g = 0; g < 3; g++) {
        n += (size_t)snprintf(b + n, cap - n,
                              "%s{\"type\": \"csg\", \"op\": \"union\", \"operands\": [",
                              g ? ", " : "");
        for (int k = 0; k < 32; k++)
            n += (size_t)snprintf(
                b + n, cap - n, "%s{\"type\": \"torus\", \"axis\": [1,0,0], \"center\": [0,0,%d]}",
                k ? ", " : "", -3 * (95 - (g * 32 + k)));
        n += (size_t)snprintf(b + n, cap - n, "]}");
    }
    snprintf(b + n, cap - n, "]}]}");
    rayd_scene *s = scene_from(b);
    free(b);
    CHECK(s != NULL, "parse");
    if (!s) return;
    struct hit h;
    ray r = {v3(0, 0, 10), v3(0, 0, -1)};
    CHECK(scene_intersect(s, &r, INFINITY, &h) && fabs(ray_at(&r, h.t).z - 1.25) < 1e-9,
          "the nearest torus is hit at z = 1.25 (got z = %g)", ray_at(&r, h.t).z);
    /* from inside the nearest torus's tube, toward the far ones: the
     * ray leaves it at z = 0.75, whatever lies beyond */
    ray in = {v3(0, 0, 1.1), v3(0, 0, -1)};
    CHECK(scene_intersect(s, &in, INFINITY, &h) && fabs(ray_at(&in, h.t).z - 0.75) < 1e-9,
          "from inside, the ray leaves at z = 0.75 (got z = %g)", ray_at(&in, h.t).z);
    rayd_scene_free(s);
}

static char *big_instances_scene(int tris_side, int instances) {
    /* a grid mesh of 2 * side^2 triangles, in a group, drawn `instances` times */
    size_t cap = (size_t)tris_side * tris_side * 64 + (size_t)instances * 128 + 4096, n = 0;
    char *b = malloc(cap);
    int v = tris_side + 1;
    n += (size_t)snprintf(
        b + n, cap - n,
        "{\"render\": {\"width\": 32, \"height\": 24}, \"camera\": {\"position\": [0, 50, 120], "
        "\"look_at\": [0,0,0]},"
        " \"lights\": [{\"type\": \"directional\", \"direction\": [0,-1,-1]}],"
        " \"groups\": {\"tile\": [{\"type\": \"mesh\", \"smooth\": false, \"vertices\": [");
    for (int j = 0; j < v; j++)
        for (int i = 0; i < v; i++)
            n += (size_t)snprintf(b + n, cap - n, "%s%d,%g,%d", i || j ? "," : "", i,
                                  0.1 * ((i * 7 + j * 3) % 5), j);
    n += (size_t)snprintf(b + n, cap - n, "], \"indices\": [");
    for (int j = 0; j < tris_side; j++)
        for (int i = 0; i < tris_side; i++) {
            int a = j * v + i;
            n += (size_t)snprintf(b + n, cap - n, "%s%d,%d,%d,%d,%d,%d", i || j ? "," : "", a,
                                  a + v, a + 1, a + 1, a + v, a + v + 1);
        }
    n += (size_t)snprintf(b + n, cap - n, "]}]}, \"objects\": [");
    for (int k = 0; k < instances; k++)
        n += (size_t)snprintf(b + n, cap - n,
                              "%s{\"type\": \"instance\", \"group\": \"tile\", \"transform\": "
                              "{\"scale\": 0.01, \"translate\": [%d, 0, %d]}}",
                              k ? "," : "", (k % 100) * 2 - 100, (k / 100) * 2 - 100);
    snprintf(b + n, cap - n, "]}");
    return b;
}

static void test_instances_share_geometry(void) {
    /* 10,000 instances of a 100k-triangle mesh in the memory of one copy
     * plus a small per-instance cost */
    char *one = big_instances_scene(224, 1), *many = big_instances_scene(224, 10000);
    rayd_scene *a = scene_from(one), *b = scene_from(many);
    free(one);
    free(many);
    CHECK(a && b, "parse");
    if (!a || !b) return;
    struct rayd_scene_info ia, ib;
    rayd_scene_info(a, &ia);
    rayd_scene_info(b, &ib);
    CHECK(b->meshes[0].ntris >= 100000, "%u triangles", b->meshes[0].ntris);
    double per = (double)(ib.bytes - ia.bytes) / 9999;
    CHECK(per < 600, "%.0f bytes per extra instance (one copy: %zu bytes)", per, ia.bytes);
    CHECK(ib.bytes < ia.bytes + 10000 * 600, "total %zu bytes", ib.bytes);
    rayd_image *img = render_all(b, 2);
    int lit = 0;
    for (int k = 0; img && k < 32 * 24; k++) lit += rayd_image_pixels_const(img)[3 * k] > 0;
    CHECK(lit > 50, "instances are drawn: %d pixels", lit);
    rayd_image_free(img);
    rayd_scene_free(a);
    rayd_scene_free(b);
}

/* The surface a ray straight down from (x, 5, z) meets: false if none. */
static bool surface_below(const rayd_scene *s, double x, double z, struct surface *sf) {
    ray r = {v3(x, 5, z), v3(0, -1, 0)};
    struct hit h;
    if (!scene_intersect(s, &r, INFINITY, &h)) return false;
    scene_surface(s, &r, &h, sf);
    return true;
}

static void test_checker_texture_in_world_space(void) {
    /* looking straight down at a checkered plane: cells of 1/scale = 0.5 */
    const char *json = "{\"camera\": {\"position\": [0,5,0], \"look_at\": [0,0,0], \"up\": "
                       "[0,0,-1], \"projection\": \"orthographic\", \"view_width\": 4},"
                       " \"render\": {\"width\": 64, \"height\": 64},"
                       " \"objects\": [{\"type\": \"plane\", \"material\": {\"color\": [0,0,0], "
                       "\"emission\": [1,1,1], \"diffuse\": 0,"
                       "   \"texture\": {\"type\": \"checker\", \"colors\": [[1,0,0],[0,0,1]], "
                       "\"scale\": 2, \"space\": \"world\"}}}]}";
    rayd_scene *s = scene_from(json);
    CHECK(s != NULL, "parse");
    if (!s) return;
    /* Emission is not textured, so render with the texture as colour via ambient: check surface
     * colour directly. */
    int bad = 0;
    for (int j = 0; j < 64; j += 3)
        for (int i = 0; i < 64; i += 3) {
            double x = 2.0 * ((i + 0.5) - 32) / 32, z = -2.0 * (32 - (j + 0.5)) / 32;
            struct surface sf;
            if (!surface_below(s, x, z, &sf)) {
                bad++;
                continue;
            }
            long k = (long)floor(2 * x + 1e-9) + (long)floor(2 * z + 1e-9);
            if (fabs(fmod(2 * x, 1)) < 1e-6 || fabs(fmod(2 * z, 1)) < 1e-6) continue;
            bad += (k & 1) ? sf.color.z != 1 : sf.color.x != 1;
        }
    CHECK(bad == 0, "%d sample points with the wrong checker colour", bad);
    rayd_scene_free(s);
}

static void test_object_space_texture_follows_a_plane_transform(void) {
    /* Stripes across the plane's own x, the plane scaled by 2 in x, turned
     * 90 degrees about y (its x goes to world -z) and moved: in the world
     * the stripes run across z, 2 units wide: object x = -z / 2.  (A
     * plane's placement is baked in for the hit; its texture must not.) */
    rayd_scene *s = scene_from("{\"objects\": [{\"type\": \"plane\", \"transform\": {\"scale\": "
                               "[2,1,1], \"rotate\": [0,90,0], \"translate\": [0.25,0,0]},"
                               " \"material\": {\"texture\": {\"type\": \"stripes\", \"axis\": "
                               "[1,0,0], \"colors\": [[1,0,0],[0,0,1]]}}}]}");
    CHECK(s != NULL, "parse");
    if (!s) return;
    int bad = 0, n = 0;
    for (double x = -2.95; x < 3; x += 0.3)
        for (double z = -2.95; z < 3; z += 0.3) {
            struct surface sf;
            if (!surface_below(s, x, z, &sf)) {
                bad++;
                continue;
            }
            long k = (long)floor(-z / 2);
            bad += (k & 1) ? sf.color.z != 1 : sf.color.x != 1;
            n++;
        }
    CHECK(n > 300 && bad == 0, "%d of %d points have the wrong stripe", bad, n);
    rayd_scene_free(s);
}

static void test_csg_texture_is_in_the_space_of_its_node(void) {
    /* A union of two spheres moved apart, striped across x by the union's
     * material, the union moved by 0.1: one pattern runs across both, in
     * the union's space (stripe = floor(2 (x - 0.1))), not restarted at
     * each sphere's centre.  A third operand with its own material keeps
     * its own space (moved by 3.05 + 0.1: stripe = floor(2 (x - 3.15))). */
    rayd_scene *s = scene_from(
        "{\"objects\": [{\"type\": \"csg\", \"op\": \"union\", \"transform\": {\"translate\": "
        "[0.1,0,0]},"
        " \"material\": {\"texture\": {\"type\": \"stripes\", \"scale\": 2, \"colors\": "
        "[[1,0,0],[0,0,1]]}},"
        " \"operands\": [{\"type\": \"sphere\", \"transform\": {\"translate\": [-0.8,0,0]}},"
        "              {\"type\": \"sphere\", \"center\": [0.65,0,0]},"
        "              {\"type\": \"sphere\", \"radius\": 0.5, \"transform\": {\"translate\": "
        "[3.05,0,0]},"
        "               \"material\": {\"texture\": {\"type\": \"stripes\", \"scale\": 2, "
        "\"colors\": [[0,1,0],[1,1,1]]}}}]}]}");
    CHECK(s != NULL, "parse");
    if (!s) return;
    int bad = 0, n = 0;
    for (double x = -1.63; x < 3.6; x += 0.1)
        for (double y = -0.45; y < 0.5; y += 0.3) {
            ray r = {v3(x, y, 5), v3(0, 0, -1)};
            struct hit h;
            struct surface sf;
            if (!scene_intersect(s, &r, INFINITY, &h)) continue;
            scene_surface(s, &r, &h, &sf);
            bool own = x > 2.5;
            long k = (long)floor(2 * (x - (own ? 3.15 : 0.1)));
            vec3 want =
                own ? ((k & 1) ? v3(1, 1, 1) : v3(0, 1, 0)) : ((k & 1) ? v3(0, 0, 1) : v3(1, 0, 0));
            bad += v3_len(v3_sub(sf.color, want)) != 0;
            n++;
        }
    CHECK(n > 100 && bad == 0, "%d of %d points have the wrong stripe", bad, n);
    rayd_scene_free(s);
}

static void test_image_texture_uv_bilinear(void) {
    /* a 2x1 PNG, black and white, on a quad: u = 0.5 is halfway between the texel centres */
    rayd_image *tex;
    rayd_image_new(2, 1, &tex, NULL);
    uint8_t *p = rayd_image_pixels(tex);
    p[3] = p[4] = p[5] = 255;
    char *enc = png_base64(tex);
    size_t cap = strlen(enc) + 1024;
    char *json = malloc(cap);
    snprintf(json, cap,
             "{\"objects\": [{\"type\": \"quad\", \"corner\": [0,0,-5], \"edge1\": [1,0,0], "
             "\"edge2\": [0,1,0],"
             " \"material\": {\"texture\": {\"type\": \"image\", \"png_base64\": \"%s\"}}}]}",
             enc);
    free(enc);
    rayd_scene *s = scene_from(json);
    free(json);
    CHECK(s != NULL, "parse");
    if (!s) return;
    double us[] = {0.25, 0.5, 0.75}, want[] = {0.0, 0.5, 1.0};
    for (int k = 0; k < 3; k++) {
        ray r = {v3(us[k], 0.5, 0), v3(0, 0, -1)};
        struct hit h;
        struct surface sf;
        CHECK(scene_intersect(s, &r, INFINITY, &h), "hit");
        scene_surface(s, &r, &h, &sf);
        CHECK_NEAR(sf.color.x, want[k], 1e-6);
    }
    rayd_scene_free(s);
    /* a corrupt PNG is refused with the path of the data */
    struct rayd_error err;
    const char *badpng = "{\"materials\": {\"m\": {\"texture\": {\"type\": \"image\", "
                         "\"png_base64\": \"aGVsbG8=\"}}}}";
    rayd_scene *none = NULL;
    CHECK(rayd_scene_parse(badpng, strlen(badpng), NULL, &none, &err) == RAYD_E_INVALID &&
              strcmp(err.path, "/materials/m/texture/png_base64") == 0,
          "%s: %s", err.path, err.message);
}

static void test_orthographic_exact_projection(void) {
    const char *json = "{\"camera\": {\"position\": [0,0,10], \"look_at\": [0,0,0], "
                       "\"projection\": \"orthographic\", \"view_width\": 4},"
                       " \"render\": {\"width\": 80, \"height\": 40},"
                       " \"objects\": [{\"type\": \"sphere\", \"center\": [0.5,0.2,-3], "
                       "\"radius\": 0.8, \"material\": {\"emission\": [1,1,1]}}]}";
    rayd_scene *s = scene_from(json);
    CHECK(s != NULL, "parse");
    if (!s) return;
    rayd_image *img = render_all(s, 2);
    int bad = 0;
    for (int j = 0; j < 40; j++)
        for (int i = 0; i < 80; i++) {
            double x = 2.0 * ((i + 0.5) - 40) / 40, y = 1.0 * (20 - (j + 0.5)) / 20;
            double d2 = (x - 0.5) * (x - 0.5) + (y - 0.2) * (y - 0.2);
            if (fabs(d2 - 0.64) < 1e-9) continue;
            bad += (px_at(img, i, j)[0] == 255) != (d2 < 0.64);
        }
    CHECK(bad == 0, "%d pixels off the parallel projection", bad);
    rayd_image_free(img);
    rayd_scene_free(s);
}

static void test_depth_of_field(void) {
    /* Two emissive spheres: one at the focus distance stays as sharp as
     * with a pinhole, one far behind it blurs (more partial pixels). */
#define DOF_FMT                                                                                    \
    "{\"camera\": {\"position\": [0,0,0], \"look_at\": [0,0,-1], \"fov_x\": 30, \"aperture\": "    \
    "%g, \"focus_distance\": 5},"                                                                  \
    " \"render\": {\"width\": 64, \"height\": 32, \"samples\": 64},"                               \
    " \"objects\": [{\"type\": \"sphere\", \"center\": [-0.7,0,-5], \"radius\": 0.5, "             \
    "\"material\": {\"emission\": [1,1,1]}},"                                                      \
    "   {\"type\": \"sphere\", \"center\": [4,0,-25], \"radius\": 2.5, \"material\": "             \
    "{\"emission\": [1,1,1]}}]}"
    int partial_near[2] = {0}, partial_far[2] = {0};
    for (int k = 0; k < 2; k++) {
        char json[1024];
        snprintf(json, sizeof json, DOF_FMT, k ? 0.6 : 0.0);
        rayd_scene *s = scene_from(json);
        CHECK(s != NULL, "parse");
        if (!s) return;
        rayd_image *img = render_all(s, 2);
        for (int j = 0; j < 32; j++)
            for (int i = 0; i < 64; i++) {
                int v = px_at(img, i, j)[0];
                if (v > 0 && v < 255) (i < 32 ? partial_near : partial_far)[k]++;
            }
        rayd_image_free(img);
        rayd_scene_free(s);
    }
    CHECK(partial_near[1] <= partial_near[0] + 6, "in focus stays sharp: %d vs %d", partial_near[1],
          partial_near[0]);
    CHECK(partial_far[1] > 2 * partial_far[0] + 10, "out of focus blurs: %d vs %d", partial_far[1],
          partial_far[0]);
}

static void test_spot_and_area_lights(void) {
    const char *spot = "{\"camera\": {\"position\": [0,10,0], \"look_at\": [0,0,0], \"up\": "
                       "[0,0,-1], \"projection\": \"orthographic\", \"view_width\": 10},"
                       " \"render\": {\"width\": 50, \"height\": 50},"
                       " \"lights\": [{\"type\": \"spot\", \"position\": [0,4,0], \"direction\": "
                       "[0,-1,0], \"angle\": 30, \"falloff\": 0.001}],"
                       " \"objects\": [{\"type\": \"plane\", \"material\": {\"color\": [1,1,1], "
                       "\"ambient\": 0, \"diffuse\": 1}}]}";
    rayd_scene *s = scene_from(spot);
    CHECK(s != NULL, "parse spot");
    if (!s) return;
    rayd_image *img = render_all(s, 1);
    /* the lit disc has radius 4 tan(30 deg) = 2.31 */
    int bad = 0;
    for (int j = 0; j < 50; j++)
        for (int i = 0; i < 50; i++) {
            double x = 5.0 * ((i + 0.5) - 25) / 25, z = -5.0 * (25 - (j + 0.5)) / 25,
                   r = sqrt(x * x + z * z);
            if (fabs(r - 4 * tan(M_PI / 6)) < 0.05) continue;
            bad += (px_at(img, i, j)[0] > 0) != (r < 4 * tan(M_PI / 6));
        }
    CHECK(bad == 0, "%d pixels outside/inside the spot cone wrongly lit", bad);
    rayd_image_free(img);
    rayd_scene_free(s);

    /* an area light over a blocker: umbra dark, penumbra between, far lit */
    const char *area =
        "{\"camera\": {\"position\": [0,10,0], \"look_at\": [0,0,0], \"up\": [0,0,-1], "
        "\"projection\": \"orthographic\", \"view_width\": 8},"
        " \"render\": {\"width\": 81, \"height\": 9},"
        " \"lights\": [{\"type\": \"area\", \"shape\": \"rectangle\", \"position\": [-1,6,-1], "
        "\"edge1\": [2,0,0], \"edge2\": [0,0,2], \"samples\": 64}],"
        " \"objects\": [{\"type\": \"plane\", \"material\": {\"color\": [1,1,1], \"ambient\": 0, "
        "\"diffuse\": 1}},"
        "   {\"type\": \"disc\", \"center\": [0,3,0], \"radius\": 0.5, \"normal\": [0,1,0], "
        "\"material\": {\"color\": [0,0,0], \"ambient\": 0, \"diffuse\": 0}}]}";
    s = scene_from(area);
    CHECK(s != NULL, "parse area");
    if (!s) return;
    img = render_all(s, 2);
    /* row 4 is z = 0; the disc hides the floor under it, so look beside it:
     * x = 0.75 lies in the penumbra, x = 3.5 in full light */
    int pen = px_at(img, (int)(40.5 + 0.75 * 10), 4)[0],
        lit = px_at(img, (int)(40.5 + 3.5 * 10), 4)[0];
    CHECK(pen > 10 && pen < lit - 10, "penumbra %d between 0 and lit %d", pen, lit);
    rayd_image_free(img);
    rayd_scene_free(s);
}

/* ---- path tracing converges ---------------------------------------------------------- */

#define CB_FMT                                                                                     \
    "{\"camera\": {\"position\": [0,1,3.4], \"look_at\": [0,1,0], \"fov_x\": 40},"                 \
    " \"render\": {\"width\": 12, \"height\": 12, \"samples\": %d, \"seed\": %d, \"max_depth\": "  \
    "6, \"integrator\": \"path\"},"                                                                \
    " \"materials\": {\"w\": {\"color\": [0.73,0.73,0.73], \"diffuse\": 1}, \"r\": {\"color\": "   \
    "[0.65,0.05,0.05], \"diffuse\": 1},"                                                           \
    "   \"g\": {\"color\": [0.12,0.45,0.15], \"diffuse\": 1}, \"m\": {\"color\": [0.9,0.8,0.5], "  \
    "\"metallic\": 1, \"roughness\": 0.4},"                                                        \
    "   \"l\": {\"color\": [0,0,0], \"emission\": [12,12,12]}},"                                   \
    " \"objects\": [{\"type\": \"quad\", \"corner\": [-1,0,-1], \"edge1\": [2,0,0], \"edge2\": "   \
    "[0,0,2], \"material\": \"w\"},"                                                               \
    "  {\"type\": \"quad\", \"corner\": [-1,2,-1], \"edge1\": [2,0,0], \"edge2\": [0,0,2], "       \
    "\"material\": \"w\"},"                                                                        \
    "  {\"type\": \"quad\", \"corner\": [-1,0,-1], \"edge1\": [2,0,0], \"edge2\": [0,2,0], "       \
    "\"material\": \"w\"},"                                                                        \
    "  {\"type\": \"quad\", \"corner\": [-1,0,-1], \"edge1\": [0,0,2], \"edge2\": [0,2,0], "       \
    "\"material\": \"r\"},"                                                                        \
    "  {\"type\": \"quad\", \"corner\": [1,0,-1], \"edge1\": [0,0,2], \"edge2\": [0,2,0], "        \
    "\"material\": \"g\"},"                                                                        \
    "  {\"type\": \"quad\", \"corner\": [-0.3,1.99,-0.3], \"edge1\": [0.6,0,0], \"edge2\": "       \
    "[0,0,0.6], \"material\": \"l\"},"                                                             \
    "  {\"type\": \"sphere\", \"center\": [0.3,0.4,0], \"radius\": 0.4, \"material\": \"m\"},"     \
    "  {\"type\": \"box\", \"min\": [-0.7,0,-0.5], \"max\": [-0.2,0.9,0]}]}"

static double *cornell(int spp, int seed) {
    char json[4096];
    snprintf(json, sizeof json, CB_FMT, spp, seed);
    rayd_scene *s = scene_from(json);
    if (!s) return NULL;
    double *v = malloc(sizeof *v * 12 * 12 * 3);
    uint64_t rays = 0;
    for (int j = 0; j < 12; j++)
        for (int i = 0; i < 12; i++) {
            vec3 c = render_pixel(s, i, j, &rays);
            v[(j * 12 + i) * 3] = c.x;
            v[(j * 12 + i) * 3 + 1] = c.y;
            v[(j * 12 + i) * 3 + 2] = c.z;
        }
    rayd_scene_free(s);
    return v;
}

static double rmse(const double *a, const double *b) {
    double e = 0;
    for (int k = 0; k < 12 * 12 * 3; k++) e += (a[k] - b[k]) * (a[k] - b[k]);
    return sqrt(e / (12 * 12 * 3));
}

static void test_path_tracer_converges(void) {
    /* Mean squared error against a 1024-sample reference, for 8, 32 and
     * 128 samples, averaged over 3 seeds: on a log-log plot the RMSE must
     * fall with slope -1/2 (1/sqrt(N)), within a tolerance for the noise of
     * the estimate and the reference (the pixel positions are
     * low-discrepancy, which makes edges converge a little faster). */
    double *ref = cornell(1024, 1);
    CHECK(ref != NULL, "reference");
    if (!ref) return;
    const int spp[3] = {8, 32, 128};
    double e[3] = {0};
    for (int k = 0; k < 3; k++)
        for (int seed = 2; seed < 5; seed++) {
            double *v = cornell(spp[k], seed + 10 * k);
            if (!v) continue;
            double r = rmse(v, ref);
            e[k] += r * r / 3;
            free(v);
        }
    double slope = (log(sqrt(e[2])) - log(sqrt(e[0]))) / (log(128.0) - log(8.0));
    printf("  rmse %.4f %.4f %.4f slope %.3f\n", sqrt(e[0]), sqrt(e[1]), sqrt(e[2]), slope);
    CHECK(slope < -0.40 && slope > -0.75, "rmse %.4f %.4f %.4f: slope %.3f, want -0.5", sqrt(e[0]),
          sqrt(e[1]), sqrt(e[2]), slope);
    double *hi = cornell(256, 99);
    double m_ref = 0, m_hi = 0;
    for (int k = 0; hi && k < 12 * 12 * 3; k++) m_ref += ref[k], m_hi += hi[k];
    CHECK(fabs(m_hi / m_ref - 1) < 0.03, "unbiased: mean %.4f vs %.4f", m_hi, m_ref);
    CHECK(m_ref / (12 * 12 * 3) > 0.05, "the box is lit: %.3f", m_ref / (12 * 12 * 3));
    free(ref);
    free(hi);
}

static void test_path_tiles_are_exact(void) {
    char json[4096];
    snprintf(json, sizeof json, CB_FMT, 8, 7);
    rayd_scene *s = scene_from(json);
    if (!s) return;
    rayd_image *full = render_all(s, 2);
    struct rayd_region reg = {3, 4, 5, 6};
    struct rayd_render_opts o = {.region = reg, .threads = 1, .tile = 2};
    rayd_image *crop = NULL;
    CHECK(rayd_render(s, &o, &crop, NULL) == RAYD_OK, "region");
    int bad = 0;
    for (int j = 0; crop && j < 6; j++)
        bad += memcmp(px_at(full, 3, 4 + j), px_at(crop, 0, j), 15) != 0;
    CHECK(bad == 0, "path-traced region equals the crop of the full render");
    rayd_image_free(full);
    rayd_image_free(crop);
    rayd_scene_free(s);
}

int main(void) {
    RUN(test_csg_sphere_minus_box_along_an_axis);
    RUN(test_csg_operations_on_the_line);
    RUN(test_csg_touching_operands_have_no_inner_face);
    RUN(test_csg_keeps_every_crossing);
    RUN(test_instances_share_geometry);
    RUN(test_checker_texture_in_world_space);
    RUN(test_object_space_texture_follows_a_plane_transform);
    RUN(test_csg_texture_is_in_the_space_of_its_node);
    RUN(test_image_texture_uv_bilinear);
    RUN(test_orthographic_exact_projection);
    RUN(test_depth_of_field);
    RUN(test_spot_and_area_lights);
    RUN(test_path_tracer_converges);
    RUN(test_path_tiles_are_exact);
    CHECK_EXIT();
}
