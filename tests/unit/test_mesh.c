/* test_mesh.c -- triangle meshes, the two-level BVH and transforms:
 * watertightness, BVH == brute force, exact projections under transforms. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "geom/mesh.h"
#include "scene/scene.h"
#include "scene_util.h"

/* Appends printf output to a growing buffer. */
struct buf {
    char *s;
    size_t len, cap;
};

/* How this host runs a packet of mesh rays, for the tests' lines. */
static const char *packets_here(void) {
    return cpu_avx512() ? "with AVX-512, and with AVX2 and one by one"
           : cpu_avx2() ? "with AVX2 (no AVX-512 here), and one by one"
                        : "one ray at a time (no AVX2 here)";
}

static void put(struct buf *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
#include <stdarg.h>
static void put(struct buf *b, const char *fmt, ...) {
    va_list ap;
    for (;;) {
        va_start(ap, fmt);
        int n = vsnprintf(b->s + b->len, b->cap - b->len, fmt, ap);
        va_end(ap);
        if (b->len + (size_t)n < b->cap) {
            b->len += (size_t)n;
            return;
        }
        b->cap = b->cap * 2 + (size_t)n + 1024;
        b->s = realloc(b->s, b->cap);
    }
}

/* A UV sphere mesh of radius r at c, as an objects entry. */
static void uv_sphere(struct buf *b, double cx, double cy, double cz, double r, int nu, int nv,
                      const char *extra) {
    put(b, "{\"type\": \"mesh\", %s \"vertices\": [", extra);
    for (int j = 0; j <= nv; j++)
        for (int i = 0; i <= nu; i++) {
            double th = M_PI * j / nv, ph = 2 * M_PI * i / nu;
            put(b, "%s%.9g,%.9g,%.9g", (i || j) ? "," : "", cx + r * sin(th) * cos(ph),
                cy + r * cos(th), cz + r * sin(th) * sin(ph));
        }
    put(b, "], \"indices\": [");
    int first = 1;
    for (int j = 0; j < nv; j++)
        for (int i = 0; i < nu; i++) {
            int a = j * (nu + 1) + i, c = a + nu + 1;
            put(b, "%s%d,%d,%d,%d,%d,%d", first ? "" : ",", a, a + 1, c, a + 1, c + 1, c);
            first = 0;
        }
    put(b, "]}");
}

/* The test scenes' start: a 96x72 camera (render: the rest of the render
 * object), one point light and a reflecting plane, the objects list left
 * open for the caller's. */
static void scene_open(struct buf *b, const char *render) {
    put(b,
        "{\"camera\": {\"position\": [0, 1.5, 6], \"look_at\": [0, 0.8, 0]},"
        " \"render\": {\"width\": 96, \"height\": 72, %s},"
        " \"lights\": [{\"type\": \"point\", \"position\": [4, 6, 5]}],"
        " \"objects\": [{\"type\": \"plane\", \"material\": {\"reflectivity\": 0.3}},",
        render);
}

/* Closes the objects list and loads the scene. */
static rayd_scene *scene_close(struct buf *b) {
    put(b, "]}");
    rayd_scene *s = scene_from(b->s);
    free(b->s);
    return s;
}

static rayd_scene *mesh_scene(int brute) {
    struct buf b = {0};
    scene_open(&b, "\"samples\": 2, \"max_depth\": 3");
    uv_sphere(&b, -1.2, 1, 0, 1, 24, 12,
              "\"material\": {\"color\": [0.9,0.3,0.2], \"specular\": 0.5},");
    put(&b, ",");
    uv_sphere(&b, 0, 0, 0, 0.6, 16, 8,
              "\"smooth\": false, \"transform\": {\"scale\": [1, 2, 1], \"rotate\": [0, 0, 20], "
              "\"translate\": [1.4, 1.2, 0.5]},"
              " \"material\": {\"transparency\": 0.8, \"ior\": 1.3},");
    put(&b, ", {\"type\": \"sphere\", \"center\": [0, 0.4, 1.5], \"radius\": 0.4,"
            "   \"transform\": [{\"scale\": [2, 1, 1]}, {\"rotate\": {\"axis\": [0, 1, 0], "
            "\"angle\": 30}}]}");
    for (int i = 0; i < 40; i++)
        put(&b, ", {\"type\": \"sphere\", \"center\": [%g, 0.15, %g], \"radius\": 0.15}",
            -3 + 0.37 * (i % 16), -2 + 0.5 * (i / 16));
    rayd_scene *s = scene_close(&b);
    if (s) s->brute = brute;
    return s;
}

/* Renders scenes a and b on 2 threads and checks they give the same bytes
 * (what: the check's name).  Returns how many of a's pixels have channel
 * ch above level: the caller's check that the image is not empty. */
static int same_render(const rayd_scene *a, const rayd_scene *b, const char *what, int ch,
                       int level) {
    rayd_image *ia = render_all(a, 2), *ib = render_all(b, 2);
    size_t n = ia ? (size_t)rayd_image_width(ia) * rayd_image_height(ia) : 0;
    CHECK(ia && ib && rayd_image_width(ib) == rayd_image_width(ia) &&
              rayd_image_height(ib) == rayd_image_height(ia) &&
              memcmp(rayd_image_pixels_const(ia), rayd_image_pixels_const(ib), 3 * n) == 0,
          "%s", what);
    int lit = 0;
    for (size_t k = 0; ia && ib && k < n; k++)
        lit += rayd_image_pixels_const(ia)[3 * k + (size_t)ch] > level;
    rayd_image_free(ia);
    rayd_image_free(ib);
    return lit;
}

static void test_bvh_equals_brute_force(void) {
    rayd_scene *fast = mesh_scene(0), *slow = mesh_scene(1);
    CHECK(fast && slow, "scenes parse");
    if (!fast || !slow) return;
    int lit = same_render(fast, slow, "the BVH and brute force give the same image", 0, 100);
    CHECK(lit > 500, "%d bright pixels", lit); /* the image is not empty: the meshes are there */
    rayd_scene_free(fast);
    rayd_scene_free(slow);
}

static void test_examples_bvh_equals_brute_force(void) {
    const char *names[] = {"tests/scenes/spheres.json", "tests/scenes/whitted.json"};
    for (int i = 0; i < 2; i++) {
        size_t len;
        char *text = read_file(names[i], &len);
        CHECK(text != NULL, "%s readable", names[i]);
        if (!text) continue;
        rayd_scene *f = NULL, *g = NULL;
        rayd_scene_parse(text, len, NULL, &f, NULL);
        rayd_scene_parse(text, len, NULL, &g, NULL);
        free(text);
        CHECK(f && g, "parse %s", names[i]);
        if (!f || !g) continue;
        g->brute = true;
        char what[128];
        snprintf(what, sizeof what, "%s: BVH image equals brute force", names[i]);
        same_render(f, g, what, 0, 0);
        rayd_scene_free(f);
        rayd_scene_free(g);
    }
}

/* A glassy mesh alone over a plane; with hidden, also a sphere under the
 * plane that no ray reaches. */
static rayd_scene *lone_mesh_scene(bool hidden) {
    struct buf b = {0};
    scene_open(&b, "\"max_depth\": 4");
    uv_sphere(&b, 0, 1, 0, 1, 24, 12,
              "\"material\": {\"transparency\": 0.6, \"ior\": 1.4, \"reflectivity\": 0.2},");
    if (hidden) put(&b, ", {\"type\": \"sphere\", \"center\": [0, -1000, 0], \"radius\": 1}");
    return scene_close(&b);
}

/* A scene of one mesh in world space skips the top level's box test
 * (scene_query.c, lone_mesh): every ray, shadow ray and refraction finds
 * what it finds with a second object beside it. */
static void test_lone_mesh_equals_flat_walk(void) {
    rayd_scene *lone = lone_mesh_scene(false), *two = lone_mesh_scene(true);
    CHECK(lone && two && lone->nobjs == 1 && two->nobjs == 2, "scenes parse");
    if (!lone || !two) return;
    int lit = same_render(lone, two,
                          "one mesh alone and beside a hidden sphere give the same image", 1, 60);
    CHECK(lit > 500, "%d bright pixels", lit);
    rayd_scene_free(lone);
    rayd_scene_free(two);
}

/* A closed octahedron |x| + |y| + |z| <= 1, flat, as a scene. */
static rayd_scene *octahedron(void) {
    rayd_scene *s =
        scene_from("{\"objects\": [{\"type\": \"mesh\", \"smooth\": false,"
                   " \"vertices\": [1,0,0, -1,0,0, 0,1,0, 0,-1,0, 0,0,1, 0,0,-1],"
                   " \"indices\": [0,2,4, 2,1,4, 1,3,4, 3,0,4, 2,0,5, 1,2,5, 3,1,5, 0,3,5]}]}");
    CHECK(s != NULL, "parse");
    return s;
}

static void test_watertight_edges_and_vertices(void) {
    /* Rays aimed exactly at every vertex and at every edge's midpoint of the
     * octahedron, from many directions, must all hit. */
    rayd_scene *s = octahedron();
    if (!s) return;
    const struct mesh *m = &s->meshes[0];
    vec3 targets[18];
    int nt = 0;
    double vx[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (int i = 0; i < 6; i++) targets[nt++] = v3(vx[i][0], vx[i][1], vx[i][2]);
    for (int i = 0; i < 6; i++)
        for (int j = i + 1; j < 6; j++)
            if (vx[i][0] != -vx[j][0] || vx[i][1] != -vx[j][1] || vx[i][2] != -vx[j][2])
                if (nt < 18)
                    targets[nt++] = v3((vx[i][0] + vx[j][0]) / 2, (vx[i][1] + vx[j][1]) / 2,
                                       (vx[i][2] + vx[j][2]) / 2);
    int misses = 0, total = 0;
    for (int k = 0; k < nt; k++) {
        for (int a = 0; a < 200; a++) {
            /* from a point on a big sphere around, through the target, toward the inside */
            double th = 0.05 + 3.0 * a / 200.0, ph = 0.7 * a;
            vec3 from = v3(5 * sin(th) * cos(ph), 5 * cos(th), 5 * sin(th) * sin(ph));
            vec3 d = v3_sub(targets[k], from);
            if (v3_dot(d, v3_sub(v3(0, 0, 0), from)) <= 0) continue;
            ray r = {from, v3_norm(d)};
            struct mesh_hit h;
            /* only rays that enter the solid |x| + |y| + |z| <= 1 at the target */
            vec3 in = v3_madd(targets[k], r.d, 1e-3);
            if (fabs(in.x) + fabs(in.y) + fabs(in.z) >= 1 - 1e-6) continue;
            total++;
            misses += !mesh_intersect(m, &r, INFINITY, &h);
        }
    }
    CHECK(total > 500, "%d rays", total);
    CHECK(misses == 0, "%d of %d rays through edges and vertices slipped through", misses, total);
    rayd_scene_free(s);
}

/* Packets of 16 mesh rays give every ray exactly its one-ray answer:
 * rays through the octahedron's vertices and edges from all sides (so the
 * lanes of a packet have different sheared frames), odd bounds (0, < 0,
 * NaN, tiny, huge) and partial masks. */
static void test_packets_equal_single_rays(void) {
    rayd_scene *s = octahedron();
    if (!s) return;
    const struct mesh *m = &s->meshes[0];
    const double bounds[8] = {INFINITY, 0, -1, NAN, 1e-3, 4.0, 3.1e38, 5.0};
    int differ = 0, total = 0, hits = 0;
    for (int p = 0; p < 400; p++) {
        ray r[16];
        double tmax[16];
        for (int i = 0; i < 16; i++) {
            int a = p * 16 + i;
            double th = 0.05 + 3.0 * (a % 211) / 211.0, ph = 0.7 * a;
            vec3 from = v3(5 * sin(th) * cos(ph), 5 * cos(th), 5 * sin(th) * sin(ph));
            vec3 target =
                a % 3 ? v3(a % 2 ? 0.5 : 0, 0.5, a % 5 ? 0 : -0.5) : v3(0, 0, a % 2 ? 1 : -1);
            r[i] = (ray){from, v3_norm(v3_sub(target, from))};
            tmax[i] = p % 4 == 3 ? bounds[(a / 7) % 8] : INFINITY;
        }
        uint32_t active = p % 5 == 4 ? 0x9f35u ^ (uint32_t)p : 0xffffu;
        for (int way = CPU_WAY_BEST; way <= CPU_WAY_BASE; way++) {
            cpu_force((enum cpu_way)way);
            struct mesh_hit h[16];
            uint32_t hit = mesh_intersect16(m, r, tmax, active, h);
            uint32_t blocked = mesh_occluded16(m, r, tmax, active);
            for (int i = 0; i < 16; i++) {
                struct mesh_hit one;
                bool got = active >> i & 1 && mesh_intersect(m, &r[i], tmax[i], &one);
                bool occ = active >> i & 1 && mesh_occluded(m, &r[i], tmax[i]);
                total++;
                hits += got;
                bool same = got == (bool)(hit >> i & 1) && occ == (bool)(blocked >> i & 1);
                if (same && got)
                    same = one.t == h[i].t && one.u == h[i].u && one.v == h[i].v &&
                           one.tri == h[i].tri && one.blk == h[i].blk && one.lane == h[i].lane;
                differ += !same;
            }
        }
    }
    cpu_force(CPU_WAY_BEST);
    printf("  %d rays (%d hits), packets %s\n", total, hits, packets_here());
    CHECK(hits > total / 3, "%d hits of %d", hits, total);
    CHECK(differ == 0, "%d of %d packet answers differ from the one-ray ones", differ, total);
    rayd_scene_free(s);
}

static void test_transformed_sphere_exact_projection(void) {
    /* A unit sphere scaled to an ellipsoid with semi-axes (2, 1, 1) at
     * z = -8, emissive, no lights: the pixels covered are exactly those
     * whose centre ray meets x^2/4 + y^2 + (z+8)^2 = 1. */
    const char *json = "{\"camera\": {\"position\": [0,0,0], \"look_at\": [0,0,-1], \"fov_x\": 60},"
                       " \"render\": {\"width\": 81, \"height\": 41},"
                       " \"objects\": [{\"type\": \"sphere\", \"transform\": {\"scale\": [2, 1, "
                       "1], \"translate\": [0.3, 0, -8]},"
                       "   \"material\": {\"emission\": [1, 1, 1]}}]}";
    rayd_scene *s = scene_from(json);
    CHECK(s != NULL, "parse");
    if (!s) return;
    rayd_image *img = render_all(s, 2);
    const uint8_t *px = rayd_image_pixels_const(img);
    double tx = tan(M_PI / 6), ty = tx * 41 / 81;
    int bad = 0, inside = 0;
    for (int j = 0; j < 41; j++)
        for (int i = 0; i < 81; i++) {
            double a = tx * ((i + 0.5) - 40.5) / 40.5, b = ty * (20.5 - (j + 0.5)) / 20.5;
            /* ray (a, b, -1) t; ellipsoid ((x-0.3)/2)^2 + y^2 + (z+8)^2 = 1 */
            double A = a * a / 4 + b * b + 1, B = 2 * (-0.3 * a / 4 - 8), C = 0.09 / 4 + 64 - 1;
            double disc = B * B - 4 * A * C;
            if (fabs(disc) < 1e-9) continue;
            int hit = disc > 0;
            inside += hit;
            bad += (px[(j * 81 + i) * 3] == 255) != hit;
        }
    CHECK(inside > 100, "covers %d pixels", inside);
    CHECK(bad == 0, "%d pixels differ from the exact ellipse", bad);
    /* The normal of the ellipsoid is the gradient (x/4, y, z+8), not the
     * scaled sphere normal. */
    struct hit h;
    ray r = {v3(0, 0, 0), v3_norm(v3(0.9, 0.3, -8))};
    CHECK(scene_intersect(s, &r, INFINITY, &h), "hit");
    struct surface sf;
    scene_surface(s, &r, &h, &sf);
    vec3 g = v3_norm(v3((sf.p.x - 0.3) / 4, sf.p.y, sf.p.z + 8));
    CHECK_NEAR(v3_dot(sf.n, g), 1, 1e-9);
    CHECK_NEAR((sf.p.x - 0.3) * (sf.p.x - 0.3) / 4 + sf.p.y * sf.p.y + (sf.p.z + 8) * (sf.p.z + 8),
               1, 1e-9);
    rayd_image_free(img);
    rayd_scene_free(s);
}

static void test_smooth_normals_follow_the_sphere(void) {
    struct buf b = {0};
    put(&b, "{\"objects\": [");
    uv_sphere(&b, 0, 0, -5, 1, 64, 32, "");
    put(&b, "]}");
    rayd_scene *s = scene_from(b.s);
    free(b.s);
    CHECK(s != NULL, "parse");
    if (!s) return;
    double worst = 1;
    for (int k = 0; k < 50; k++) {
        ray r = {v3(0, 0, 0), v3_norm(v3(0.15 * sin(k), 0.15 * cos(k * 1.3), -1))};
        struct hit h;
        if (!scene_intersect(s, &r, INFINITY, &h)) continue;
        struct surface sf;
        scene_surface(s, &r, &h, &sf);
        vec3 exact = v3_norm(v3_sub(sf.p, v3(0, 0, -5)));
        double c = v3_dot(sf.n, exact);
        worst = c < worst ? c : worst;
        CHECK(v3_dot(sf.ng, exact) > 0.99, "geometric normal faces out");
    }
    CHECK(worst > 0.9999, "interpolated normals within 1 degree: cos %g", worst);
    rayd_scene_free(s);
}

static void test_mesh_errors(void) {
    struct rayd_error err;
    rayd_scene *s = NULL;
    const char *bad_index = "{\"objects\": [{\"type\": \"mesh\", \"vertices\": [0,0,0, 1,0,0, "
                            "0,1,0], \"indices\": [0, 1, 3]}]}";
    CHECK(rayd_scene_parse(bad_index, strlen(bad_index), NULL, &s, &err) == RAYD_E_INVALID &&
              strcmp(err.path, "/objects/0/indices/2") == 0 && strstr(err.message, "0..2"),
          "%s: %s", err.path, err.message);
    const char *short_v =
        "{\"objects\": [{\"type\": \"mesh\", \"vertices\": [0,0,0, 1,0], \"indices\": [0, 1, 2]}]}";
    CHECK(rayd_scene_parse(short_v, strlen(short_v), NULL, &s, &err) == RAYD_E_INVALID &&
              strcmp(err.path, "/objects/0/vertices") == 0 && strstr(err.message, "multiple of 3"),
          "%s: %s", err.path, err.message);
    const char *bad_n = "{\"objects\": [{\"type\": \"mesh\", \"vertices\": [0,0,0, 1,0,0, 0,1,0], "
                        "\"indices\": [0, 1, 2], \"normals\": [0,0,1]}]}";
    CHECK(rayd_scene_parse(bad_n, strlen(bad_n), NULL, &s, &err) == RAYD_E_INVALID &&
              strcmp(err.path, "/objects/0/normals") == 0,
          "%s: %s", err.path, err.message);
    const char *sing =
        "{\"objects\": [{\"type\": \"sphere\", \"transform\": {\"scale\": [1, 0, 1]}}]}";
    CHECK(rayd_scene_parse(sing, strlen(sing), NULL, &s, &err) == RAYD_E_INVALID &&
              strcmp(err.path, "/objects/0/transform/scale") == 0,
          "%s: %s", err.path, err.message);
    const char *mat = "{\"objects\": [{\"type\": \"sphere\", \"transform\": {\"matrix\": [1,0,0,0, "
                      "0,1,0,0, 0,0,1,0, 0,0,1,1]}}]}";
    CHECK(rayd_scene_parse(mat, strlen(mat), NULL, &s, &err) == RAYD_E_INVALID &&
              strcmp(err.path, "/objects/0/transform/matrix") == 0,
          "%s: %s", err.path, err.message);
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    lim.max_triangles = 1;
    const char *two = "{\"objects\": [{\"type\": \"mesh\", \"vertices\": [0,0,0, 1,0,0, 0,1,0], "
                      "\"indices\": [0,1,2, 0,2,1]}]}";
    CHECK(rayd_scene_parse(two, strlen(two), &lim, &s, &err) == RAYD_E_LIMIT &&
              strcmp(err.path, "/objects/0/indices") == 0,
          "%s: %s", err.path, err.message);
    CHECK(s == NULL, "no scene");
}

/* The one-ray walk has copies compiled for AVX-512 and AVX2 (mesh.c, used
 * where cpu_avx512 and cpu_avx2 say so) beside the build's own: for
 * random rays through a soup of triangles and the octahedron's edges and
 * vertices, with odd bounds, all must give the very same hit (t, u, v,
 * triangle, block, lane) and the same shadow answer, and the nearest hit
 * brute force's. */
static void soup(uint32_t n, float **pos, uint32_t **index);

static bool same_hit(bool a, const struct mesh_hit *x, bool b, const struct mesh_hit *y) {
    if (a != b) return false;
    return !a || (!memcmp(&x->t, &y->t, sizeof x->t) && !memcmp(&x->u, &y->u, sizeof x->u) &&
                  !memcmp(&x->v, &y->v, sizeof x->v) && x->tri == y->tri && x->blk == y->blk &&
                  x->lane == y->lane);
}

/* The 20,000-triangle soup as a mesh, built on two threads. */
static void soup_mesh(struct mesh *m) {
    const uint32_t n = 20000;
    float *pos;
    uint32_t *index;
    soup(n, &pos, &index);
    CHECK(mesh_build(m, pos, 3 * n, index, n, NULL, NULL, false, 2, NULL) == RAYD_OK, "build");
}

static void test_single_ray_paths_agree(void) {
    struct mesh soupm;
    soup_mesh(&soupm);
    rayd_scene *oct = octahedron();
    if (!oct) return;
    const struct mesh *ms[2] = {&soupm, &oct->meshes[0]};
    const double bounds[8] = {INFINITY, 0, -1, NAN, 1e-3, 4.0, 3.1e38, 5.0};
    uint32_t s = 777, differ = 0, brute = 0, total = 0, hits = 0, blocked = 0;
    for (int a = 0; a < 40000; a++) {
        const struct mesh *m = ms[a & 1];
        double u[6];
        for (int k = 0; k < 6; k++) u[k] = lcg_unit(&s);
        ray r;
        if (m == &soupm) { /* from inside or outside the soup's cube, any direction */
            r.o = v3(u[0] * 14 - 2, u[1] * 14 - 2, u[2] * 14 - 2);
            r.d = v3_norm(v3(u[3] - 0.5, u[4] - 0.5, u[5] - 0.5 + (a % 7 == 0 ? 0 : 1e-9)));
            if (a % 11 == 0) r.d = v3_norm(v3(u[3] - 0.5, 0, 0)); /* axis-aligned */
        } else { /* at the octahedron's vertices and edge midpoints */
            double th = 0.05 + 3.0 * u[0], ph = 6.3 * u[1];
            vec3 from = v3(5 * sin(th) * cos(ph), 5 * cos(th), 5 * sin(th) * sin(ph));
            vec3 target =
                a % 3 ? v3(a % 2 ? 0.5 : 0, 0.5, a % 5 ? 0 : -0.5) : v3(0, 0, a % 4 ? 1 : -1);
            r = (ray){from, v3_norm(v3_sub(target, from))};
        }
        double tmax = a % 4 == 3 ? bounds[(a / 4) % 8] : INFINITY;
        struct mesh_hit h[3], hb;
        bool got[3], occ[3];
        for (int way = CPU_WAY_BEST; way <= CPU_WAY_BASE; way++) {
            cpu_force((enum cpu_way)way);
            got[way] = mesh_intersect(m, &r, tmax, &h[way]);
            occ[way] = mesh_occluded(m, &r, tmax);
        }
        cpu_force(CPU_WAY_BEST);
        bool gb = mesh_intersect_brute(m, &r, tmax, &hb);
        total++;
        hits += got[0];
        blocked += occ[0];
        for (int way = 1; way < 3; way++)
            differ += !same_hit(got[0], &h[0], got[way], &h[way]) || occ[0] != occ[way];
        differ += occ[0] != got[0];
        brute += !same_hit(got[0], &h[0], gb, &hb);
    }
    printf("  %u rays (%u hits, %u blocked), one-ray walk %s\n", total, hits, blocked,
           cpu_avx512() ? "with AVX-512 and AVX2 against the build's"
           : cpu_avx2() ? "with AVX2 against the build's (no AVX-512 here)"
                        : "the build's only (no AVX2 here)");
    CHECK(hits > total / 5 && hits < total, "%u hits of %u", hits, total);
    CHECK(differ == 0, "%u of %u rays differ between the walks", differ, total);
    CHECK(brute == 0, "%u of %u rays differ from brute force", brute, total);
    mesh_free(&soupm);
    rayd_scene_free(oct);
}

/* Packets through a 20,000-triangle soup give every ray its one-ray
 * answer, also where the packet's walk hands its last rays to the one-ray
 * walk part way down (BVH16_LONE_MAX): coherent packets (16 rays from one
 * point through a small square, as a 4x4 block of pixels; or from a small
 * patch toward one point in each of the eight octants, as shadow rays,
 * which the culling test of bvh16_cull takes with a spread of origins),
 * incoherent ones (each ray from its own point, any direction, as bounce
 * rays), half and half, with odd bounds and partial masks. */
static void soup_packets(const struct mesh *m, uint32_t *total, uint32_t *hits, uint32_t *differ) {
    const double bounds[8] = {INFINITY, 0, -1, NAN, 1e-3, 4.0, 3.1e38, 5.0};
    uint32_t s = 4242;
    for (int p = 0; p < 3000; p++) {
        ray r[16];
        double tmax[16];
        vec3 eye = v3(-3, 5, -4);
        for (int i = 0; i < 16; i++) {
            double u[6];
            for (int k = 0; k < 6; k++) u[k] = lcg_unit(&s);
            bool coherent = p % 3 == 0 || (p % 3 == 2 && i < 8);
            if (p % 6 == 3) { /* as shadow rays: from a small patch toward a point */
                vec3 light = v3(p & 1 ? 12 : -2, p & 2 ? 12 : -2, p & 4 ? 12 : -2);
                r[i].o = v3(3 + (p % 50) * 0.08 + (i % 4) * 0.02 + u[0] * 0.01,
                            4 + (i / 4) * 0.02 + u[1] * 0.01, 5 + (p % 7) * 0.3 + u[2] * 0.01);
                r[i].d = v3_norm(v3_sub(light, r[i].o));
            } else if (coherent) { /* toward a small square inside the soup's cube */
                vec3 at = v3(4 + (p % 40) * 0.1 + (i % 4) * 0.01,
                             5 + (p / 40) * 0.05 + (i / 4) * 0.01, 5);
                r[i] = (ray){eye, v3_norm(v3_sub(at, eye))};
            } else {
                r[i].o = v3(u[0] * 10, u[1] * 10, u[2] * 10);
                r[i].d = v3_norm(v3(u[3] - 0.5, u[4] - 0.5, u[5] - 0.5));
            }
            tmax[i] = p % 4 == 3 ? bounds[(p + i) % 8] : INFINITY;
        }
        uint32_t active = p % 5 == 4 ? 0xb3c5u ^ (uint32_t)(p * 37) : 0xffffu;
        active &= 0xffffu;
        if (!active) active = 1;
        struct mesh_hit h[16];
        uint32_t hit = mesh_intersect16(m, r, tmax, active, h);
        uint32_t blocked = mesh_occluded16(m, r, tmax, active);
        for (int i = 0; i < 16; i++) {
            struct mesh_hit one;
            bool got = active >> i & 1 && mesh_intersect(m, &r[i], tmax[i], &one);
            bool occ = active >> i & 1 && mesh_occluded(m, &r[i], tmax[i]);
            ++*total;
            *hits += got;
            *differ += !same_hit(got, &one, hit >> i & 1, &h[i]) || occ != (bool)(blocked >> i & 1);
        }
    }
}

/* The same packets again as through a mesh that outgrows the cache
 * (prefetch set): there the 8-ray packets' incoherent ones go ray by ray
 * from the root (mesh_packet8.c, parts8) and every walk prefetches. */
static void test_packets_in_a_soup_equal_single_rays(void) {
    struct mesh m;
    soup_mesh(&m);
    for (int big = 0; big <= 1; big++) {
        uint32_t differ = 0, total = 0, hits = 0;
        m.prefetch = big;
        for (int way = CPU_WAY_BEST; way <= CPU_WAY_AVX2; way++) {
            cpu_force((enum cpu_way)way);
            soup_packets(&m, &total, &hits, &differ);
        }
        cpu_force(CPU_WAY_BEST);
        printf("  %u rays (%u hits), packets %s%s\n", total, hits, packets_here(),
               big ? ", as a mesh outgrowing the cache" : "");
        CHECK(hits > total / 20 && hits < total, "%u hits of %u", hits, total);
        CHECK(differ == 0, "%u of %u packet answers differ from the one-ray ones", differ, total);
    }
    mesh_free(&m);
}

/* A soup of n small random triangles (a fixed generator), pos and index
 * malloc'd for mesh_build to own. */
static void soup(uint32_t n, float **pos, uint32_t **index) {
    *pos = malloc(sizeof **pos * 9 * n);
    *index = malloc(sizeof **index * 3 * n);
    uint32_t s = 12345;
    for (uint32_t t = 0; t < n; t++) {
        float c[3];
        for (int k = 0; k < 3; k++) c[k] = (float)lcg_unit(&s) * 10.0f;
        for (int v = 0; v < 3; v++) {
            for (int k = 0; k < 3; k++)
                (*pos)[9 * t + 3 * v + k] = c[k] + (float)lcg_unit(&s) * 0.1f;
            (*index)[3 * t + v] = 3 * t + (uint32_t)v;
        }
    }
}

/* mesh_build's steps run on every thread (parallel_for, the BVH's
 * subtrees): the nodes and blocks must be the same bytes for any count. */
static void test_mesh_build_same_for_any_thread_count(void) {
    const uint32_t n = 200000;
    struct mesh ref;
    float *pos;
    uint32_t *index;
    soup(n, &pos, &index);
    CHECK(mesh_build(&ref, pos, 3 * n, index, n, NULL, NULL, false, 1, NULL) == RAYD_OK, "build");
    static const int threads[] = {2, 3, 8};
    for (size_t k = 0; k < sizeof threads / sizeof threads[0]; k++) {
        struct mesh m;
        soup(n, &pos, &index);
        CHECK(mesh_build(&m, pos, 3 * n, index, n, NULL, NULL, false, threads[k], NULL) == RAYD_OK,
              "build on %d threads", threads[k]);
        CHECK(m.bvh.nnodes == ref.bvh.nnodes && m.nblocks == ref.nblocks,
              "%d threads: %u nodes, %u blocks; 1 thread: %u, %u", threads[k], m.bvh.nnodes,
              m.nblocks, ref.bvh.nnodes, ref.nblocks);
        if (m.bvh.nnodes == ref.bvh.nnodes && m.nblocks == ref.nblocks) {
            CHECK(!memcmp(m.bvh.nodes, ref.bvh.nodes, sizeof *m.bvh.nodes * m.bvh.nnodes),
                  "%d threads: other nodes", threads[k]);
            CHECK(!memcmp(m.blocks, ref.blocks, sizeof *m.blocks * m.nblocks),
                  "%d threads: other blocks", threads[k]);
        }
        mesh_free(&m);
    }
    mesh_free(&ref);
}

/* The BVH alone on more boxes: subtrees built, boxes copied in and the
 * 4-wide collapse written on several threads, so the order and the
 * nodes must be the same bytes for 1, 2, 3 and 8 threads;
 * and every primitive in exactly one leaf, inside its leaf's box. */
static void test_bvh_same_for_any_thread_count(void) {
    const uint32_t n = 700000;
    float *pos;
    uint32_t *index;
    soup(n, &pos, &index);
    struct bbox *boxes = malloc(sizeof *boxes * n);
    uint32_t *order[4], *seen = calloc(n, sizeof *seen);
    for (uint32_t t = 0; t < n; t++)
        for (int k = 0; k < 3; k++) {
            const float *v = pos + 9 * (size_t)t + k;
            boxes[t].lo[k] = fminf(v[0], fminf(v[3], v[6]));
            boxes[t].hi[k] = fmaxf(v[0], fmaxf(v[3], v[6]));
        }
    static const int threads[] = {1, 2, 3, 8};
    struct bvh4 bvh[4];
    for (int k = 0; k < 4; k++) {
        order[k] = malloc(sizeof *order[k] * n);
        CHECK(bvh_build(&bvh[k], boxes, n, BVH_MAX_LEAF, order[k], threads[k], NULL) == RAYD_OK,
              "build on %d threads", threads[k]);
    }
    for (int k = 1; k < 4; k++) {
        CHECK(!memcmp(order[k], order[0], sizeof *order[0] * n), "%d threads: other order",
              threads[k]);
        CHECK(bvh[k].nnodes == bvh[0].nnodes &&
                  !memcmp(bvh[k].nodes, bvh[0].nodes, sizeof *bvh[0].nodes * bvh[0].nnodes),
              "%d threads: other nodes (%u, 1 thread %u)", threads[k], bvh[k].nnodes,
              bvh[0].nnodes);
    }
    uint32_t bad = 0;
    for (uint32_t i = 0; i < bvh[0].nnodes; i++) {
        const struct bvh4_node *nd = &bvh[0].nodes[i];
        for (int c = 0; c < 4; c++)
            for (uint32_t j = 0; j < nd->count[c]; j++) {
                uint32_t id = order[0][nd->child[c] + j];
                seen[id]++;
                for (int a = 0; a < 3; a++)
                    bad += boxes[id].lo[a] < nd->lo[a][c] || boxes[id].hi[a] > nd->hi[a][c];
            }
    }
    for (uint32_t t = 0; t < n; t++) bad += seen[t] != 1;
    CHECK(bad == 0, "%u primitives not in exactly one leaf inside its box", bad);
    for (int k = 0; k < 4; k++) {
        bvh_free(&bvh[k]);
        free(order[k]);
    }
    free(boxes);
    free(seen);
    free(pos);
    free(index);
}

/* Triangles under node n of m (a leaf's count, an inner node's sum). */
static uint32_t subtree_tris(const struct mesh *m, uint32_t n) {
    uint32_t t = 0;
    const struct bvh8_node *nd = &m->bvh.nodes[n];
    for (int i = 0; i < 8; i++) {
        if (!(nd->lo[0][i] <= nd->hi[0][i])) continue; /* an empty slot */
        t += nd->count[i] ? nd->count[i] : subtree_tris(m, nd->child[i]);
    }
    return t;
}

/* A subtree of at most BVH8_LEAF_MAX triangles is one leaf of two blocks
 * (bvh_collapse.h), not an inner node: no node below the root holds so
 * few, every leaf at most that many, its blocks consecutive with its
 * triangles in their first lanes, and every triangle in one lane. */
static void test_small_subtrees_are_leaves(void) {
    const uint32_t n = 20000;
    float *pos;
    uint32_t *index;
    soup(n, &pos, &index);
    struct mesh m;
    CHECK(mesh_build(&m, pos, 3 * n, index, n, NULL, NULL, false, 2, NULL) == RAYD_OK, "mesh");
    uint32_t small = 0, big = 0, bad_lanes = 0, two = 0;
    uint8_t *seen = calloc(n, 1);
    for (uint32_t k = 0; k < m.bvh.nnodes; k++) {
        small += k > 0 && subtree_tris(&m, k) <= BVH8_LEAF_MAX;
        const struct bvh8_node *nd = &m.bvh.nodes[k];
        for (int i = 0; i < 8; i++) {
            int c = nd->count[i];
            big += c > BVH8_LEAF_MAX;
            two += c > 4;
            for (int j = 0; j < 4 * mesh_leaf_blocks(c); j++) {
                uint32_t id = m.blocks[nd->child[i] + (uint32_t)j / 4].id[j % 4];
                if (j < c && id < n) seen[id]++;
                bad_lanes += j < c ? id >= n : id != UINT32_MAX;
            }
        }
    }
    uint32_t once = 0;
    for (uint32_t t = 0; t < n; t++) once += seen[t] == 1;
    CHECK(small == 0 && big == 0, "%u inner nodes of at most %d triangles, %u leaves over", small,
          BVH8_LEAF_MAX, big);
    CHECK(two > 0, "no leaf of two blocks");
    CHECK(bad_lanes == 0 && once == n, "%u bad lanes, %u of %u triangles in one lane", bad_lanes,
          once, n);
    free(seen);
    mesh_free(&m);
}

/* The mesh's triangles' boxes go straight into the builder
 * (bvh8_build_from), its blocks and its index in leaf order are read
 * through the order: the same tree as bvh_build over the boxes, each
 * block lane the corners of the triangle the order names, unused lanes
 * zero, and the kept index (a smooth mesh) that order's. */
static void test_mesh_tree_is_bvh_of_boxes(void) {
    const uint32_t n = 100000;
    float *pos, *pos0;
    uint32_t *index, *index0, *order = malloc(sizeof *order * n);
    struct bbox *boxes = malloc(sizeof *boxes * n);
    soup(n, &pos0, &index0);
    soup(n, &pos, &index);
    for (uint32_t t = 0; t < n; t++)
        for (int k = 0; k < 3; k++) {
            const float *v = pos0 + 9 * (size_t)t + k;
            boxes[t].lo[k] = fminf(v[0], fminf(v[3], v[6]));
            boxes[t].hi[k] = fmaxf(v[0], fmaxf(v[3], v[6]));
        }
    struct bvh8 bvh;
    struct mesh m;
    CHECK(bvh8_build_from(&bvh, bvh_boxes_copy, boxes, n, BVH_MAX_LEAF, order, 2, NULL) == RAYD_OK,
          "bvh8_build_from");
    CHECK(mesh_build(&m, pos, 3 * n, index, n, NULL, NULL, true, 2, NULL) == RAYD_OK, "mesh");
    CHECK(m.bvh.nnodes == bvh.nnodes, "%u nodes, bvh_build %u", m.bvh.nnodes, bvh.nnodes);
    uint32_t bad = 0, lanes = 0;
    for (uint32_t i = 0; i < bvh.nnodes && m.bvh.nnodes == bvh.nnodes; i++) {
        const struct bvh8_node *a = &m.bvh.nodes[i], *b = &bvh.nodes[i];
        bad += memcmp(a->lo, b->lo, sizeof a->lo) || memcmp(a->hi, b->hi, sizeof a->hi) ||
               memcmp(a->count, b->count, sizeof a->count);
    }
    for (uint32_t t = 0; t < n; t++) bad += memcmp(m.index + 3 * t, index0 + 3 * order[t], 12) != 0;
    for (uint32_t i = 0; i < m.nblocks; i++)
        for (int lane = 0; lane < 4; lane++) {
            uint32_t id = m.blocks[i].id[lane];
            lanes += id != UINT32_MAX;
            for (int k = 0; k < 3; k++)
                for (int j = 0; j < 3; j++) {
                    float want = id == UINT32_MAX ? 0 : pos0[3 * index0[3 * order[id] + k] + j];
                    bad += memcmp(&m.blocks[i].v[k][j][lane], &want, sizeof want) != 0;
                }
        }
    CHECK(bad == 0 && lanes == n, "%u differences, %u lanes of %u triangles", bad, lanes, n);
    mesh_free(&m);
    bvh8_free(&bvh);
    free(boxes);
    free(order);
    free(pos0);
    free(index0);
}

/* A flat n x n grid of unit squares, two triangles each, in the plane
 * z = 0 (every triangle's box flat in z), its corner at the origin. */
static void grid_mesh(struct mesh *m, uint32_t n) {
    uint32_t nv = (n + 1) * (n + 1), nt = 2 * n * n;
    float *pos = malloc(sizeof *pos * 3 * nv);
    uint32_t *index = malloc(sizeof *index * 3 * nt), *ix = index;
    for (uint32_t j = 0; j <= n; j++)
        for (uint32_t i = 0; i <= n; i++) {
            float *p = pos + 3 * (j * (n + 1) + i);
            p[0] = (float)i, p[1] = (float)j, p[2] = 0;
        }
    for (uint32_t j = 0; j < n; j++)
        for (uint32_t i = 0; i < n; i++) {
            uint32_t a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
            const uint32_t tri[6] = {a, b, d, a, d, c};
            memcpy(ix, tri, sizeof tri);
            ix += 6;
        }
    CHECK(mesh_build(m, pos, nv, index, nt, NULL, NULL, false, 1, NULL) == RAYD_OK, "build");
}

/* Coherent packets (the leaf's triangles culled by their boxes, as the
 * nodes are) through a flat grid's vertices, edges and diagonals, from one
 * eye or from a small patch, from above and below: each ray gets its
 * one-ray answer, and none slips between two triangles. */
static void test_packets_through_grid_edges(void) {
    struct mesh m;
    grid_mesh(&m, 14);
    uint32_t differ = 0, total = 0, hits = 0;
    for (int p = 0; p < 800; p++) {
        cpu_force(p < 400 ? CPU_WAY_BEST : CPU_WAY_AVX2); /* as the CPU has it, then AVX2 at most */
        ray r[16];
        double tmax[16];
        double side = p & 1 ? 1 : -1, spread = p & 2 ? 0.003 : 0;
        vec3 eye = v3(1 + (p % 9) * 0.7, 2 + (p % 7) * 0.9, side * (3 + p % 5));
        for (int i = 0; i < 16; i++) { /* at a vertex, an edge or a diagonal */
            double x = 1 + (p / 4 % 9) + (i % 4) * (p & 4 ? 0.5 : 1);
            double y = 1 + (p / 36 % 9) + (i / 4) * (p & 8 ? 0.5 : 1);
            vec3 o = v3_add(eye, v3(spread * (i % 4), spread * (i / 4), 0));
            r[i] = (ray){o, v3_norm(v3_sub(v3(x, y, 0), o))};
            tmax[i] = INFINITY;
        }
        struct mesh_hit h[16];
        uint32_t hit = mesh_intersect16(&m, r, tmax, 0xffffu, h);
        uint32_t blocked = mesh_occluded16(&m, r, tmax, 0xffffu);
        for (int i = 0; i < 16; i++) {
            struct mesh_hit one;
            bool got = mesh_intersect(&m, &r[i], tmax[i], &one);
            total++;
            hits += got;
            differ += !same_hit(got, &one, hit >> i & 1, &h[i]) || got != (bool)(blocked >> i & 1);
        }
    }
    cpu_force(CPU_WAY_BEST);
    printf("  %u rays through the grid's edges and vertices, %u hits\n", total, hits);
    CHECK(hits == total, "%u of %u rays slipped through the grid", total - hits, total);
    CHECK(differ == 0, "%u of %u packet answers differ from the one-ray ones", differ, total);
    mesh_free(&m);
}

int main(void) {
    RUN(test_mesh_tree_is_bvh_of_boxes);
    RUN(test_small_subtrees_are_leaves);
    RUN(test_mesh_build_same_for_any_thread_count);
    RUN(test_bvh_same_for_any_thread_count);
    RUN(test_bvh_equals_brute_force);
    RUN(test_examples_bvh_equals_brute_force);
    RUN(test_lone_mesh_equals_flat_walk);
    RUN(test_watertight_edges_and_vertices);
    RUN(test_packets_equal_single_rays);
    RUN(test_single_ray_paths_agree);
    RUN(test_packets_in_a_soup_equal_single_rays);
    RUN(test_packets_through_grid_edges);
    RUN(test_transformed_sphere_exact_projection);
    RUN(test_smooth_normals_follow_the_sphere);
    RUN(test_mesh_errors);
    CHECK_EXIT();
}
