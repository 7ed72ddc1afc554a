/* test_shading.c -- the Whitted integrator against analytic expectations:
 * exact projections of emissive objects, shadows without acne, mirror
 * reflection, Fresnel and Snell. */
#include <stdlib.h>

#include "accel/bvh16.h"
#include "check.h"
#include "render/integrate.h"
#include "shade/material.h"
#include "scene_util.h"

/* Camera at the origin looking down -z, fov_x 60, fov_y from the aspect. */
static void ref_dir(int i, int j, int n, int m, double out[3]) {
    double tx = tan(M_PI / 6), ty = tx * m / n;
    double a = tx * ((i + 0.5) - n / 2.0) / (n / 2.0);
    double b = ty * (m / 2.0 - (j + 0.5)) / (m / 2.0);
    double l = sqrt(a * a + b * b + 1);
    out[0] = a / l;
    out[1] = b / l;
    out[2] = -1 / l;
}

static void test_emissive_sphere_exact_projection(void) {
    /* No lights: an emissive object shows exactly its emission colour and
     * covers exactly the pixels whose centre ray hits it (paper (3)-(6)). */
    const char *json =
        "{\"camera\": {\"position\": [0,0,0], \"look_at\": [0,0,-1], \"fov_x\": 60},"
        " \"render\": {\"width\": 61, \"height\": 41, \"background\": [0.2, 0, 0.05]},"
        " \"objects\": [{\"type\": \"sphere\", \"center\": [0.7, -0.3, -6], \"radius\": 1.3,"
        "   \"material\": {\"color\": [0,0,0], \"emission\": [0.5, 1.0, 0.0]}}]}";
    rayd_scene *s = scene_from(json);
    CHECK(s != NULL, "parse");
    if (!s) return;
    rayd_image *img = render_all(s, 2);
    CHECK(img != NULL, "render");
    const uint8_t *px = rayd_image_pixels_const(img);
    int inside = 0, bad = 0;
    for (int j = 0; j < 41; j++) {
        for (int i = 0; i < 61; i++) {
            double d[3];
            ref_dir(i, j, 61, 41, d);
            double c[3] = {0.7, -0.3, -6}, b = d[0] * c[0] + d[1] * c[1] + d[2] * c[2];
            double dist2 = c[0] * c[0] + c[1] * c[1] + c[2] * c[2] - b * b;
            if (fabs(dist2 - 1.69) < 1e-9) continue; /* tangent to the pixel centre */
            int hit = dist2 < 1.69;
            inside += hit;
            int e[3] = {hit ? 188 : srgb_ref(0.2), hit ? 255 : 0, hit ? 0 : srgb_ref(0.05)};
            const uint8_t *p = px + (j * 61 + i) * 3;
            if (p[0] != e[0] || p[1] != e[1] || p[2] != e[2]) bad++;
        }
    }
    CHECK(inside > 50, "the sphere covers %d pixels", inside);
    CHECK(bad == 0, "%d pixels differ from the exact projection", bad);
    rayd_image_free(img);
    rayd_scene_free(s);
}

/* Every pixel that sees the (tilted) floor must have the same colour: a
 * directional light makes n.l constant over a plane, so any darker pixel is
 * acne.  A tilted plane puts rounding error in every hit point. */
static void check_flat_floor(double height) {
    char json[1024];
    snprintf(
        json, sizeof json,
        "{\"camera\": {\"position\": [0,%.17g,0], \"look_at\": [0,%.17g,-4], \"fov_x\": 70},"
        " \"render\": {\"width\": 80, \"height\": 60, \"background\": [0,0,1]},"
        " \"lights\": [{\"type\": \"directional\", \"direction\": [0.3,-1,-0.2]}],"
        " \"objects\": [{\"type\": \"plane\", \"point\": [0,%.17g,0], \"normal\": [0.31,1,0.17],"
        "   \"material\": {\"color\": [0.6,0.6,0.6], \"ambient\": 0.1, \"diffuse\": 0.8}}]}",
        height + 2, height, height);
    rayd_scene *s = scene_from(json);
    CHECK(s != NULL, "parse");
    if (!s) return;
    rayd_image *img = render_all(s, 1);
    const uint8_t *px = rayd_image_pixels_const(img);
    /* n.l with n = normalize(0.31, 1, 0.17), l = -normalize(0.3, -1, -0.2) */
    double ndl = (0.31 * -0.3 + 1 + 0.17 * 0.2) / sqrt(0.31 * 0.31 + 1 + 0.17 * 0.17) /
                 sqrt(0.09 + 1 + 0.04);
    int expect = srgb_ref(0.6 * 0.1 + 0.6 * 0.8 * ndl), floor_px = 0, bad = 0;
    for (int k = 0; k < 80 * 60; k++) {
        if (px[3 * k + 2] == 255 && px[3 * k] == 0) continue; /* sky */
        floor_px++;
        if (px[3 * k] != expect) bad++;
    }
    CHECK(floor_px > 1000, "floor pixels %d", floor_px);
    CHECK(bad == 0, "at height %g, %d of %d floor pixels are not %d (acne)", height, bad, floor_px,
          expect);
    rayd_image_free(img);
    rayd_scene_free(s);
}

static void test_no_shadow_acne(void) {
    check_flat_floor(0);
    check_flat_floor(1e5);
    check_flat_floor(-3e6);
}

static void test_hard_shadow_under_sphere(void) {
    /* Looking straight down at a floor with a sphere between it and a light
     * straight above: the shadow is a disc of the sphere's radius. */
    const char *json = "{\"camera\": {\"position\": [0,10,0], \"look_at\": [0,0,0], \"up\": "
                       "[0,0,-1], \"fov_x\": 60},"
                       " \"render\": {\"width\": 64, \"height\": 64, \"background\": [0,0,0]},"
                       " \"lights\": [{\"type\": \"directional\", \"direction\": [0,-1,0]}],"
                       " \"objects\": [{\"type\": \"plane\", \"material\": {\"color\": [1,1,1], "
                       "\"ambient\": 0.1, \"diffuse\": 0.9}},"
                       "   {\"type\": \"sphere\", \"center\": [2,5,0], \"radius\": 1, "
                       "\"material\": {\"color\": [0,0,0], \"ambient\": 0, \"diffuse\": 0}}]}";
    rayd_scene *s = scene_from(json);
    CHECK(s != NULL, "parse");
    if (!s) return;
    rayd_image *img = render_all(s, 2);
    const uint8_t *px = rayd_image_pixels_const(img);
    /* Image centre column 32 sees x = 0 on the floor; x = 2 is at column
     * 32 + 2 / tan(30deg) / 10 * 32 ~ 43.  Row 32 is z = 0. */
    double tx = tan(M_PI / 6);
    int shadow_col = (int)(32 + 2.0 / (10 * tx) * 32);
    int lit_col = 10;
    CHECK(px[(32 * 64 + lit_col) * 3] == srgb_ref(1.0), "lit floor %d",
          px[(32 * 64 + lit_col) * 3]);
    /* The sphere itself blocks the view of the floor below it from the
     * camera too, so check a shadow pixel just outside the sphere's image
     * but inside the shadow: none exists for a light along the view axis.
     * Instead move along x: the shadow (ambient only) sits under the black
     * sphere, so the sphere pixel is 0 and the ring beyond the sphere is lit. */
    CHECK(px[(32 * 64 + shadow_col) * 3] == 0, "black sphere over its shadow %d",
          px[(32 * 64 + shadow_col) * 3]);
    rayd_image_free(img);
    rayd_scene_free(s);

    /* Slanted light: the shadow moves out from under the sphere. */
    const char *slant = "{\"camera\": {\"position\": [0,10,0], \"look_at\": [0,0,0], \"up\": "
                        "[0,0,-1], \"fov_x\": 60},"
                        " \"render\": {\"width\": 64, \"height\": 64, \"background\": [0,0,0]},"
                        " \"lights\": [{\"type\": \"directional\", \"direction\": [-1,-1,0]}],"
                        " \"objects\": [{\"type\": \"plane\", \"material\": {\"color\": [1,1,1], "
                        "\"ambient\": 0.1, \"diffuse\": 0.9}},"
                        "   {\"type\": \"sphere\", \"center\": [2,2,0], \"radius\": 0.5, "
                        "\"material\": {\"color\": [0,0,0], \"ambient\": 0, \"diffuse\": 0}}]}";
    s = scene_from(slant);
    CHECK(s != NULL, "parse slant");
    if (!s) return;
    img = render_all(s, 1);
    px = rayd_image_pixels_const(img);
    /* Light travels along (-1,-1,0): the shadow centre is at x = 0 on the floor. */
    int ambient = srgb_ref(0.1), lit = srgb_ref(0.1 + 0.9 / sqrt(2));
    CHECK(px[(32 * 64 + 32) * 3] == ambient, "shadow centre %d, want %d", px[(32 * 64 + 32) * 3],
          ambient);
    CHECK(px[(32 * 64 + 5) * 3] == lit, "lit floor %d, want %d", px[(32 * 64 + 5) * 3], lit);
    rayd_image_free(img);
    rayd_scene_free(s);
}

static void test_mirror_reflection_depth(void) {
    /* An emissive sphere seen only in a perfect mirror floor: invisible with
     * max_depth 0, exactly emission x reflectivity with max_depth 1. */
#define MIRROR_FMT                                                                                 \
    "{\"camera\": {\"position\": [0,3,0], \"look_at\": [0,0,0], \"up\": [0,0,-1], \"fov_x\": 40}," \
    " \"render\": {\"width\": 9, \"height\": 9, \"max_depth\": %d},"                               \
    " \"objects\": [{\"type\": \"plane\", \"material\": {\"color\": [1,1,1], \"diffuse\": 0, "     \
    "\"reflectivity\": 0.5}},"                                                                     \
    "   {\"type\": \"sphere\", \"center\": [0,5,0], \"radius\": 1.5, \"material\": "               \
    "{\"emission\": [0.8,0.8,0.8]}}]}"
    char json[1024];
    for (int depth = 0; depth <= 1; depth++) {
        snprintf(json, sizeof json, MIRROR_FMT, depth);
        rayd_scene *s = scene_from(json);
        CHECK(s != NULL, "parse");
        if (!s) return;
        rayd_image *img = render_all(s, 1);
        const uint8_t *p = rayd_image_pixels_const(img) + (4 * 9 + 4) * 3;
        int want = depth ? srgb_ref(0.4) : 0;
        CHECK(p[0] == want, "depth %d: centre %d, want %d", depth, p[0], want);
        rayd_image_free(img);
        rayd_scene_free(s);
    }
}

static void test_clear_glass_shows_background(void) {
    /* transparency 1 with ior 1: no reflection (Fresnel 0), no bending, so a
     * glass sphere over the background is invisible -- only if refracted
     * rays leave and re-enter the surface correctly. */
    const char *json =
        "{\"camera\": {\"position\": [0,0,5], \"look_at\": [0,0,0]},"
        " \"render\": {\"width\": 32, \"height\": 24, \"max_depth\": 4, \"background\": "
        "[0.3,0.6,0.9]},"
        " \"lights\": [{\"type\": \"point\", \"position\": [0, 10, 10]}],"
        " \"objects\": [{\"type\": \"sphere\", \"radius\": 1.5, \"material\": {\"color\": [1,1,1],"
        "   \"transparency\": 1, \"ior\": 1, \"ambient\": 0.5, \"diffuse\": 0.5}}]}";
    rayd_scene *s = scene_from(json);
    CHECK(s != NULL, "parse");
    if (!s) return;
    rayd_image *img = render_all(s, 2);
    const uint8_t *px = rayd_image_pixels_const(img);
    int bad = 0;
    for (int k = 0; k < 32 * 24; k++)
        bad += px[3 * k] != srgb_ref(0.3) || px[3 * k + 1] != srgb_ref(0.6) ||
               px[3 * k + 2] != srgb_ref(0.9);
    CHECK(bad == 0, "%d pixels differ from the background", bad);
    rayd_image_free(img);
    rayd_scene_free(s);
}

static void test_fresnel_and_snell(void) {
    double ct = 0;
    CHECK_NEAR(material_fresnel(1, 1.5, 1, &ct), 0.04, 1e-12);
    CHECK_NEAR(ct, 1, 1e-12);
    CHECK_NEAR(material_fresnel(1.5, 1, 1, &ct), 0.04, 1e-12);
    /* Beyond the critical angle asin(1/1.5) = 41.8 deg: total internal reflection. */
    CHECK(material_fresnel(1.5, 1, cos(45 * M_PI / 180), &ct) == 1.0, "TIR at 45 deg");
    CHECK(material_fresnel(1.5, 1, cos(40 * M_PI / 180), &ct) < 1.0, "no TIR at 40 deg");
    CHECK(material_fresnel(1, 1.5, 1e-6, &ct) > 0.99, "grazing reflects nearly all");
    /* Snell: n1 sin(i) = n2 sin(t). */
    double ang = 35 * M_PI / 180, n1 = 1, n2 = 1.33;
    vec3 d = v3(sin(ang), -cos(ang), 0), n = v3(0, 1, 0);
    double cos_i = -v3_dot(d, n);
    material_fresnel(n1, n2, cos_i, &ct);
    vec3 t = material_refract(d, n, n1 / n2, cos_i, ct);
    CHECK_NEAR(v3_len(t), 1, 1e-12);
    CHECK_NEAR(n1 * sin(ang), n2 * t.x, 1e-12);
    CHECK(t.y < 0, "goes through the surface");
}

/* A scene for the packet shading test: every kind of hit integrate_wide.c
 * shades (spheres and a plane, whole and fractional exponents, no
 * highlight, emission, mirrors, lights brighter than 1) beside hits it
 * leaves to the one-ray code (glass, a texture, a transformed sphere).
 * LIGHTS is spliced in. */
#define WIDE_SCENE(LIGHTS)                                                                         \
    "{\"camera\": {\"position\": [0,2,6], \"look_at\": [0,0.5,0]},"                                \
    " \"render\": {\"width\": 32, \"height\": 32, \"max_depth\": 4,"                               \
    "  \"background\": [0.1,0.2,0.3]},"                                                            \
    " \"lights\": [" LIGHTS "],"                                                                   \
    " \"materials\": {\"m\": {\"color\": [0.9,0.9,0.9], \"specular\": 0.8, \"shininess\": 200,"    \
    "   \"reflectivity\": 0.8, \"ambient\": 0.05, \"diffuse\": 0.1}},"                             \
    " \"objects\": ["                                                                              \
    "  {\"type\": \"plane\", \"point\": [0,0,0], \"normal\": [0,1,0],"                             \
    "   \"material\": {\"color\": [0.7,0.7,0.6], \"reflectivity\": 0.3}},"                         \
    "  {\"type\": \"sphere\", \"center\": [-1.5,0.5,0], \"radius\": 0.5, \"material\": \"m\"},"    \
    "  {\"type\": \"sphere\", \"center\": [0,0.5,0], \"radius\": 0.5, \"material\": \"m\"},"       \
    "  {\"type\": \"sphere\", \"center\": [1.5,0.5,0], \"radius\": 0.5,"                           \
    "   \"material\": {\"color\": [0.8,0.2,0.1], \"specular\": 0.5, \"shininess\": 33.5}},"        \
    "  {\"type\": \"sphere\", \"center\": [0,0.5,-1.5], \"radius\": 0.5,"                          \
    "   \"material\": {\"color\": [0.2,0.8,0.1], \"emission\": [0.2,0,0.1]}},"                     \
    "  {\"type\": \"sphere\", \"center\": [-1.5,0.5,-1.5], \"radius\": 0.5,"                       \
    "   \"material\": {\"color\": [0.9,0.9,1], \"transparency\": 0.9, \"ior\": 1.5}},"             \
    "  {\"type\": \"sphere\", \"center\": [1.5,0.5,-1.5], \"radius\": 0.5, \"material\": "         \
    "   {\"texture\": {\"type\": \"checker\", \"colors\": [[0.9,0.9,0.9],[0.1,0.1,0.1]]}}},"       \
    "  {\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": 0.5, \"material\": \"m\","          \
    "   \"transform\": {\"scale\": [1,0.6,1], \"translate\": [0,0.3,1.5]}}]}"

/* Splits the unit interval's [0, 1) bits for the test's random numbers. */
static double unit_rand(uint64_t *x) {
    *x = *x * 6364136223846793005ULL + 1442695040888963407ULL;
    return (double)(*x >> 11) * 0x1p-53;
}

/* 16 rays: from one point in coherent or scattered directions, or from
 * scattered points (some inside spheres, some below the floor). */
static void wide_rays(uint64_t *x, int kind, ray r[16]) {
    vec3 o = v3(6 * unit_rand(x) - 3, 4 * unit_rand(x) - 0.5, 4 * unit_rand(x) - 1);
    vec3 d0 = v3_norm(v3(2 * unit_rand(x) - 1, 2 * unit_rand(x) - 1, 2 * unit_rand(x) - 1));
    for (int i = 0; i < 16; i++) {
        vec3 jit = v3(unit_rand(x) - 0.5, unit_rand(x) - 0.5, unit_rand(x) - 0.5);
        r[i].o = kind == 2 ? v3_add(o, v3_scale(jit, 3)) : o;
        r[i].d = v3_norm(kind == 0 ? v3_add(d0, v3_scale(jit, 0.2)) : jit);
    }
}

/* whitted_radiance16 shades the common hits 16 at a time
 * (integrate_wide.c): each lane must still be bit for bit the one-ray
 * colour, with the same number of rays cast, with and without AVX-512,
 * for every mix of lights and of hits. */
static void test_packets_shade_as_one_ray(void) {
    static const char *lights[] = {
        "{\"type\": \"point\", \"position\": [-3,5,4], \"intensity\": 0.7},"
        "{\"type\": \"directional\", \"direction\": [1,-2,-1], \"intensity\": 0.4}",
        "{\"type\": \"point\", \"position\": [2,4,3], \"intensity\": 3}",
        "", /* no lights: emission only */
        "{\"type\": \"spot\", \"position\": [0,5,0], \"direction\": [0,-1,0], \"angle\": 40}"};
    char json[4096];
    for (int l = 0; l < 4; l++) {
        snprintf(json, sizeof json, WIDE_SCENE("%s"), lights[l]);
        rayd_scene *s = scene_from(json);
        CHECK(s != NULL, "scene %d parses", l);
        if (!s) continue;
        int differ = 0, count_differ = 0;
        uint64_t x = 12345 + (uint64_t)l;
        for (int way = CPU_WAY_BEST; way <= CPU_WAY_BASE; way++) {
            cpu_force((enum cpu_way)way);
            for (int n = 0; n < 300; n++) {
                ray r[16];
                struct rng_key key[16];
                vec3 out[16];
                wide_rays(&x, n % 3, r);
                uint32_t active = n % 5 ? 0xffffu : (uint32_t)(unit_rand(&x) * 65535) + 1;
                for (int i = 0; i < 16; i++) key[i] = rng_key_at(1, (uint32_t)n, (uint32_t)i, 0);
                struct meter rays16 = meter_make(NULL, NULL), rays1 = meter_make(NULL, NULL);
                struct ray16 rs;
                for (int i = 0; i < 16; i++) ray16_set(&rs, i, r[i]);
                whitted_radiance16(s, &rs, active, key, out, &rays16);
                for (int i = 0; i < 16; i++) {
                    if (!(active >> i & 1)) continue;
                    vec3 c = whitted_radiance(s, &r[i], 0, &key[i], &rays1);
                    differ += memcmp(&c, &out[i], sizeof c) != 0;
                }
                count_differ += rays16.rays != rays1.rays;
            }
        }
        cpu_force(CPU_WAY_BEST);
        CHECK(differ == 0, "lights %d: %d packet colours differ from the one-ray colour", l,
              differ);
        CHECK(count_differ == 0, "lights %d: %d packets counted other rays", l, count_differ);
        rayd_scene_free(s);
    }
}

int main(void) {
    RUN(test_emissive_sphere_exact_projection);
    RUN(test_no_shadow_acne);
    RUN(test_hard_shadow_under_sphere);
    RUN(test_mirror_reflection_depth);
    RUN(test_clear_glass_shows_background);
    RUN(test_fresnel_and_snell);
    RUN(test_packets_shade_as_one_ray);
    CHECK_EXIT();
}
