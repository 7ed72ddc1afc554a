/* test_environment.c -- render.environment, image-based lighting.
 *
 * The white furnace: a convex Lambert sphere of albedo a under a uniform
 * environment L reflects exactly a L (every bounce escapes), so the path
 * tracer's pixels must average a L and the Whitted ambient rule give it
 * exactly; the background pixels are L itself, or render.background when
 * the environment is not visible (exactly L: a sum of equal values; the
 * background within float rounding of the sums).  Rotation: turning the image by 90
 * degrees about +Y moves every texel's direction by the same turn.
 * Sampling: against a high-sample reference, sampling the sky by its
 * luminance gives a lower error at equal samples than BSDF sampling alone,
 * and both estimates agree with the reference on average (no bias), and
 * every sample's pdf is the luminance in its direction over the map's
 * integral (env_sample drawn from directly).  Bad
 * environments are refused with the JSON Pointer of what is wrong.
 *
 * The .hdr images are written here, flat RGBE scanlines, into a temporary
 * folder given to the loader as its asset directory.
 */
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "scene/scene.h"
#include "scene_util.h"

static char dir[64];

/* One RGBE pixel of (r, g, b), as Radiance writes it. */
static void rgbe(const float *c, unsigned char out[4]) {
    double v = fmax(c[0], fmax(c[1], c[2]));
    if (v < 1e-32) {
        memset(out, 0, 4);
        return;
    }
    int e;
    double m = frexp(v, &e) * 256.0 / v;
    for (int i = 0; i < 3; i++) out[i] = (unsigned char)(c[i] * m);
    out[3] = (unsigned char)(e + 128);
}

/* Writes a w x h .hdr of rgb (rows from the top) as dir/name. */
static void write_hdr(const char *name, int w, int h, const float *rgb) {
    char path[128];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "wb");
    if (!f) return;
    fprintf(f, "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n", h, w);
    for (int i = 0; i < w * h; i++) {
        unsigned char b[4];
        rgbe(rgb + 3 * i, b);
        fwrite(b, 1, 4, f);
    }
    fclose(f);
}

static void write_text(const char *name, const char *text) {
    char path[128];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "wb");
    if (!f) return;
    fputs(text, f);
    fclose(f);
}

/* Parses json with dir as the confined asset directory; err gets why not. */
static rayd_scene *parse(const char *json, struct rayd_error *err) {
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    lim.asset_dir = dir;
    lim.max_samples = 4096;
    rayd_scene *s = NULL;
    memset(err, 0, sizeof *err);
    if (rayd_scene_parse(json, strlen(json), &lim, &s, err) != RAYD_OK) return NULL;
    return s;
}

/* The whole image as linear floats (malloc'd). */
static float *render_linear(const rayd_scene *s, int w, int h) {
    float *px = calloc((size_t)w * h * 3, sizeof *px);
    struct rayd_region all = {0, 0, w, h};
    uint64_t rays = 0;
    struct rayd_error err = {0};
    if (rayd_render_linear_into(s, &all, px, w, 0, 0, NULL, &rays, &err) != RAYD_OK) {
        free(px);
        return NULL;
    }
    return px;
}

/* ---- the white furnace ----------------------------------------------------------- */

/* Camera at the origin down -z, 40 degrees wide; sphere of radius 1 at z = -3
 * (19.5 degrees of angular radius). */
#define FURNACE_FMT                                                                                \
    "{\"camera\": {\"position\": [0,0,0], \"look_at\": [0,0,-1], \"fov_x\": 60},"                  \
    " \"render\": {\"width\": 32, \"height\": 32, \"samples\": %d, \"max_depth\": 8,"              \
    "   \"integrator\": \"%s\", \"background\": [0.1, 0.2, 0.3],"                                  \
    "   \"environment\": {\"color\": [0.5, 0.5, 0.5], \"intensity\": 1.5, \"visible\": %s}},"      \
    " \"objects\": [{\"type\": \"sphere\", \"center\": [0,0,-3], \"radius\": 1,"                   \
    "   \"material\": {\"color\": [0.6, 0.6, 0.6], \"diffuse\": 1}}]}"

/* The angle between pixel (i, j)'s centre ray and -z, in degrees. */
static double off_axis(int i, int j) {
    double t = tan(30 * M_PI / 180), a = t * (i + 0.5 - 16) / 16, b = t * (16 - j - 0.5) / 16;
    return atan(sqrt(a * a + b * b)) * 180 / M_PI;
}

static void furnace(const char *integrator, int samples, bool visible, double tol) {
    char json[1024];
    snprintf(json, sizeof json, FURNACE_FMT, samples, integrator, visible ? "true" : "false");
    struct rayd_error err;
    rayd_scene *s = parse(json, &err);
    CHECK(s != NULL, "%s at %s", err.message, err.path);
    float *px = s ? render_linear(s, 32, 32) : NULL;
    CHECK(px != NULL, "render failed");
    if (!px) {
        rayd_scene_free(s);
        return;
    }
    double L = 0.75, a = 0.6, sum = 0;
    int n = 0, bg_bad = 0, bg = 0;
    float want[3] = {(float)L, (float)L, (float)L};
    if (!visible) want[0] = 0.1f, want[1] = 0.2f, want[2] = 0.3f;
    for (int j = 0; j < 32; j++)
        for (int i = 0; i < 32; i++) {
            const float *p = px + 3 * (j * 32 + i);
            double ang = off_axis(i, j);
            if (ang < 16) {
                sum += (p[0] + p[1] + p[2]) / 3;
                n++;
            } else if (ang > 23) {
                bg++;
                double d =
                    fmax(fabs(p[0] - want[0]), fmax(fabs(p[1] - want[1]), fabs(p[2] - want[2])));
                bg_bad += visible ? d != 0 : d > 1e-6; /* 0.1 x n / n is not exact in the sums */
            }
        }
    CHECK(n > 50 && bg > 50, "%d sphere and %d background pixels", n, bg);
    CHECK_NEAR(sum / n, a * L, tol * a * L);
    CHECK(bg_bad == 0, "%d of %d background pixels are not exactly the %s", bg_bad, bg,
          visible ? "environment" : "background");
    free(px);
    rayd_scene_free(s);
}

static void test_white_furnace_path(void) { furnace("path", 256, true, 0.01); }
static void test_white_furnace_whitted_exact(void) { furnace("whitted", 1, true, 1e-6); }
static void test_invisible_environment_shows_background(void) { furnace("path", 16, false, 0.05); }

/* ---- rotation ----------------------------------------------------------------------- */

/* An 8 x 4 image whose every texel is different. */
static void write_ramp(void) {
    float rgb[8 * 4 * 3];
    for (int k = 0; k < 32; k++) {
        rgb[3 * k] = (float)(k % 8 + 1) / 8;
        rgb[3 * k + 1] = (float)(k / 8 + 1) / 4;
        rgb[3 * k + 2] = 0.5f;
    }
    write_hdr("ramp.hdr", 8, 4, rgb);
}

static rayd_scene *ramp_scene(double rotation) {
    char json[256];
    snprintf(json, sizeof json,
             "{\"render\": {\"environment\": {\"file\": \"ramp.hdr\", \"rotation\": %g}}}",
             rotation);
    struct rayd_error err;
    rayd_scene *s = parse(json, &err);
    CHECK(s != NULL, "%s at %s", err.message, err.path);
    return s;
}

/* The direction of texel (i, j)'s centre in an 8 x 4 map, unrotated. */
static vec3 texel_dir(int i, int j) {
    double th = M_PI * (j + 0.5) / 4, ph = 2 * M_PI * ((i + 0.5) / 8 - 0.5);
    return v3(sin(th) * sin(ph), cos(th), -sin(th) * cos(ph));
}

static void test_rotation_turns_the_map(void) {
    write_ramp();
    rayd_scene *s0 = ramp_scene(0), *s90 = ramp_scene(90);
    if (!s0 || !s90) goto out;
    /* the image's centre column (4) is seen looking down -z, row 0 looking up */
    vec3 c = env_radiance(&s0->rs.env, v3(0, -0.2, -1));
    CHECK(fabs(c.x - 5.0 / 8) < 0.01 && fabs(c.y - 3.0 / 4) < 0.01, "-z sees (%g, %g)", c.x, c.y);
    c = env_radiance(&s0->rs.env, v3(0, 1, 0));
    CHECK(fabs(c.y - 1.0 / 4) < 0.01, "+y sees row %g", c.y * 4 - 1);
    int bad = 0;
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 8; i++) {
            vec3 d = texel_dir(i, j), turned = v3(d.z, d.y, -d.x); /* 90 degrees about +y */
            vec3 a = env_radiance(&s0->rs.env, d), b = env_radiance(&s90->rs.env, turned);
            bad += a.x != b.x || a.y != b.y || a.z != b.z;
        }
    CHECK(bad == 0, "%d of 32 texels moved elsewhere", bad);
out:
    rayd_scene_free(s0);
    rayd_scene_free(s90);
}

/* The same map as OpenEXR (rayd's own writer) gives the same radiance. */
static void test_exr_equals_hdr(void) {
    float rgb[8 * 4 * 3];
    for (int k = 0; k < 32; k++) {
        rgb[3 * k] = (float)(k % 8 + 1) / 8;
        rgb[3 * k + 1] = (float)(k / 8 + 1) / 4;
        rgb[3 * k + 2] = 0.5f;
    }
    void *buf = NULL;
    size_t len = 0;
    struct rayd_error err = {0};
    CHECK(rayd_exr_encode(rgb, 8, 4, &buf, &len, &err) == RAYD_OK, "%s", err.message);
    char path[128];
    snprintf(path, sizeof path, "%s/ramp.exr", dir);
    FILE *f = fopen(path, "wb");
    if (f && buf) fwrite(buf, 1, len, f);
    if (f) fclose(f);
    snprintf(path, sizeof path, "%s/cut.exr", dir);
    f = fopen(path, "wb");
    if (f && buf) fwrite(buf, 1, len / 2, f);
    if (f) fclose(f);
    rayd_free(buf);
    write_ramp();
    rayd_scene *a = ramp_scene(30);
    rayd_scene *b =
        parse("{\"render\": {\"environment\": {\"file\": \"ramp.exr\", \"rotation\": 30}}}", &err);
    CHECK(b != NULL, "%s at %s", err.message, err.path);
    rayd_scene *c = parse(
        "{\"render\": {\"environment\": {\"file\": \"ramp.exr\", \"format\": \"exr\"}}}", &err);
    CHECK(c != NULL, "%s at %s", err.message, err.path);
    if (a && b) {
        int bad = 0;
        for (int j = 0; j < 4; j++)
            for (int i = 0; i < 8; i++) {
                vec3 d = texel_dir(i, j);
                vec3 x = env_radiance(&a->rs.env, d), y = env_radiance(&b->rs.env, d);
                bad += x.x != y.x || x.y != y.y || x.z != y.z;
            }
        CHECK(bad == 0, "%d of 32 texels differ between the .hdr and the .exr", bad);
    }
    rayd_scene_free(a);
    rayd_scene_free(b);
    rayd_scene_free(c);
}

/* ---- importance sampling ------------------------------------------------------------ */

/* A dark sky with a small bright sun: 64 x 32, the sun 2 x 2 texels. */
static void write_sun(void) {
    static float rgb[64 * 32 * 3];
    for (int j = 0; j < 32; j++)
        for (int i = 0; i < 64; i++) {
            float *p = rgb + 3 * (j * 64 + i);
            bool sun = (i == 40 || i == 41) && (j == 9 || j == 10);
            p[0] = sun ? 400.0f : 0.05f;
            p[1] = sun ? 380.0f : 0.08f;
            p[2] = sun ? 350.0f : 0.15f;
        }
    write_hdr("sun.hdr", 64, 32, rgb);
}

#define SUN_FMT                                                                                    \
    "{\"camera\": {\"position\": [0,2,4], \"look_at\": [0,0,0], \"fov_x\": 50},"                   \
    " \"render\": {\"width\": 24, \"height\": 24, \"samples\": %d, \"max_depth\": 4, \"seed\": "   \
    "%d,"                                                                                          \
    "   \"integrator\": \"path\", \"environment\": {\"file\": \"sun.hdr\", \"rotation\": 30}},"    \
    " \"objects\": [{\"type\": \"sphere\", \"center\": [0,0.7,0], \"radius\": 0.7,"                \
    "   \"material\": {\"color\": [0.8, 0.5, 0.3]}},"                                              \
    "  {\"type\": \"plane\", \"point\": [0,0,0], \"normal\": [0,1,0],"                             \
    "   \"material\": {\"color\": [0.7, 0.7, 0.7], \"metallic\": 0.3, \"roughness\": 0.5}}]}"

static float *sun_render(int samples, int seed, bool sampled) {
    char json[1024];
    snprintf(json, sizeof json, SUN_FMT, samples, seed);
    struct rayd_error err;
    rayd_scene *s = parse(json, &err);
    CHECK(s != NULL, "%s at %s", err.message, err.path);
    if (!s) return NULL;
    s->rs.env.sample = sampled; /* the tests' switch */
    float *px = render_linear(s, 24, 24);
    rayd_scene_free(s);
    return px;
}

static double rmse(const float *a, const float *b) {
    double e = 0;
    for (int i = 0; i < 24 * 24 * 3; i++) e += (a[i] - b[i]) * (double)(a[i] - b[i]);
    return sqrt(e / (24 * 24 * 3));
}

static double mean(const float *a) {
    double m = 0;
    for (int i = 0; i < 24 * 24 * 3; i++) m += a[i];
    return m / (24 * 24 * 3);
}

static void test_sampling_the_sky_pays(void) {
    write_sun();
    float *ref = sun_render(2048, 7, true), *on = sun_render(16, 1, true);
    float *off = sun_render(16, 1, false), *off_many = sun_render(512, 3, false);
    if (ref && on && off && off_many) {
        double e_on = rmse(on, ref), e_off = rmse(off, ref), m = mean(ref);
        printf("  16 samples: RMSE %.4f sampled, %.4f not; means %.4f %.4f, reference %.4f\n", e_on,
               e_off, mean(on), mean(off), m);
        CHECK(e_on < 0.5 * e_off, "RMSE %g sampled against %g not", e_on, e_off);
        CHECK_NEAR(mean(on), m, 0.03 * m);
        CHECK_NEAR(mean(off_many), m, 0.05 * m); /* BSDF sampling alone agrees: no bias */
    }
    free(ref);
    free(on);
    free(off);
    free(off_many);
}

/* The map's sampling, drawn from directly: every direction env_sample
 * gives comes with env_radiance_pdf's pdf and env_radiance's radiance, and
 * that pdf is the luminance there over
 * the luminance integrated over the sphere (a cell's luminance times its
 * solid angle, summed here on its own), so luminance / pdf is that
 * integral for every sample: no variance left for a map lighting alone.
 * A point drawn uniform in theta within a row, not in cos(theta), fails
 * this in every row (most near the poles, where the bright top row is).
 * A black row and black texels make empty runs in the CDFs, which the
 * guide tables' search must step over as the binary search did: a sample
 * in a cell the CDF does not give would have another cell's pdf. */
static double lum(vec3 c) { return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z; }

static void test_sampling_pdf_follows_the_radiance(void) {
    struct environment e = {
        .kind = ENV_IMAGE, .w = 8, .h = 4, .cos_r = cos(0.7), .sin_r = sin(0.7)};
    e.rgb = malloc(sizeof *e.rgb * 8 * 4 * 3);
    if (!e.rgb) return;
    double want = 0, pi = 3.14159265358979323846;
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 8; i++) {
            float *p = e.rgb + 3 * (j * 8 + i);
            p[0] = j == 0 ? 5.0f : 0.1f * (float)(i + 1), p[1] = 0.05f * (float)(j + 1),
            p[2] = 0.3f;
            if (j == 2 || (j == 1 && i % 3 == 0)) p[0] = p[1] = p[2] = 0; /* empty runs */
            want +=
                lum(v3(p[0], p[1], p[2])) * 2 * pi / 8 * (cos(pi * j / 4) - cos(pi * (j + 1) / 4));
        }
    CHECK(env_prepare(&e), "env_prepare");
    CHECK_NEAR(e.integral, want, 1e-12 * want);
    int bad_pdf = 0, bad_ratio = 0, bad_le = 0;
    int drawn = 0;
    for (int a = 0; a < 64; a++)
        for (int b = 0; b < 64; b++) {
            vec3 d, le;
            double pdf, pdf2;
            if (!env_sample(&e, (a + 0.5) / 64, (b + 0.5) / 64, &d, &pdf, &le)) continue;
            drawn++;
            vec3 look = env_radiance_pdf(&e, d, &pdf2), r = env_radiance(&e, d);
            bad_pdf += fabs(pdf2 / pdf - 1) > 1e-9;
            bad_ratio += fabs(lum(r) / pdf / want - 1) > 1e-9;
            bad_le += v3_maxabs(v3_sub(le, r)) > 0 || v3_maxabs(v3_sub(look, r)) > 0 || pdf2 != pdf;
        }
    CHECK(bad_pdf == 0, "%d of 4096 samples' pdf is not env_radiance_pdf's", bad_pdf);
    CHECK(bad_ratio == 0, "%d of 4096 samples' luminance / pdf is not the integral", bad_ratio);
    CHECK(bad_le == 0, "%d of 4096 samples' radiance or pdf differ from the lookups'", bad_le);
    CHECK(drawn == 4096, "%d of 4096 draws gave a direction", drawn);
    env_free(&e);
}

/* The lookup finds a direction's texel without acos or atan2 (a guess,
 * then the cells' edges): over 200,000 random directions of a 96 x 48 map
 * turned by 0.3 radians, each texel its own value, the texel is the one
 * acos and atan2 name, but for directions within 1e-9 radians of an edge
 * (rounding may put those either side).  The poles and the seam at -Z
 * are met on purpose. */
static void test_lookup_finds_the_cell(void) {
    int w = 96, h = 48;
    struct environment e = {
        .kind = ENV_IMAGE, .w = w, .h = h, .cos_r = cos(0.3), .sin_r = sin(0.3)};
    e.rgb = malloc(sizeof *e.rgb * (size_t)(w * h * 3));
    if (!e.rgb) return;
    for (int k = 0; k < w * h; k++)
        e.rgb[3 * k] = (float)k, e.rgb[3 * k + 1] = e.rgb[3 * k + 2] = 1;
    CHECK(env_prepare(&e), "env_prepare");
    double pi = 3.14159265358979323846;
    uint32_t seed = 5;
    int bad = 0, checked = 0;
    for (int n = 0; n < 200000; n++) {
        vec3 l = v3(2 * lcg_unit(&seed) - 1, 2 * lcg_unit(&seed) - 1, 2 * lcg_unit(&seed) - 1);
        if (n % 1000 == 0) l = v3(0, n % 2000 ? 1 : -1, 0);                    /* a pole */
        if (n % 1000 == 1) l = v3(1e-12 * (n % 4 - 1.5), lcg_unit(&seed), -1); /* the seam */
        if (v3_dot(l, l) > 1 || v3_dot(l, l) < 1e-6) continue;
        l = v3_norm(l);
        double theta = acos(l.y), phi = atan2(l.x, -l.z);
        double v = theta / pi * h, u = (phi / (2 * pi) + 0.5) * w;
        double edge = fmin(fmin(fabs(v - round(v)) * pi / h,
                                fabs(u - round(u)) * 2 * pi / w * sqrt(fmax(0, 1 - l.y * l.y))),
                           1);
        if (edge < 1e-9 && fabs(l.y) < 1) continue;
        int j = v >= h ? h - 1 : (int)v, i = u >= w ? w - 1 : (int)u;
        /* the world direction that is l once the map's rotation is undone */
        vec3 d = v3(cos(0.3) * l.x + sin(0.3) * l.z, l.y, -sin(0.3) * l.x + cos(0.3) * l.z);
        double got = env_radiance(&e, d).x, pdf;
        bool pole = fabs(l.y) == 1; /* any column of the top or bottom row */
        bad += pole ? (int)got / w != j : (int)got != j * w + i;
        bad += env_radiance_pdf(&e, d, &pdf).x != got;
        checked++;
    }
    CHECK(bad == 0, "%d of %d directions looked up in another texel", bad, checked);
    CHECK(checked > 100000, "only %d directions checked", checked);
    env_free(&e);
}

static void test_same_bytes_any_threads_and_tiles(void) {
    char json[1024];
    snprintf(json, sizeof json, SUN_FMT, 4, 0);
    struct rayd_error err;
    rayd_scene *s = parse(json, &err);
    if (!s) return;
    rayd_image *a = render_all(s, 1), *b = render_all(s, 2);
    CHECK(a && b && memcmp(rayd_image_pixels(a), rayd_image_pixels(b), 24 * 24 * 3) == 0,
          "1 and 2 threads differ");
    rayd_image_free(a);
    rayd_image_free(b);
    /* a tile is the same pixels as the whole image's */
    float *full = render_linear(s, 24, 24), tile[7 * 5 * 3];
    struct rayd_region r = {9, 11, 7, 5};
    uint64_t rays = 0;
    CHECK(rayd_render_linear_into(s, &r, tile, 7, 0, 0, NULL, &rays, &err) == RAYD_OK, "tile");
    int differ = 0;
    for (int y = 0; y < 5 && full; y++)
        differ +=
            memcmp(tile + 3 * 7 * y, full + 3 * (24 * (11 + y) + 9), 7 * 3 * sizeof(float)) != 0;
    CHECK(full && differ == 0, "%d rows of the tile differ from the whole image", differ);
    free(full);
    rayd_scene_free(s);
}

/* ---- bad input -------------------------------------------------------------------- */

static void refused(const char *env, const char *path, const char *words) {
    char json[1024];
    snprintf(json, sizeof json, "{\"render\": {\"environment\": %s}}", env);
    struct rayd_error err;
    rayd_scene *s = parse(json, &err);
    CHECK(s == NULL, "%s was accepted", env);
    rayd_scene_free(s);
    CHECK(strcmp(err.path, path) == 0, "%s: pointer %s, not %s (%s)", env, err.path, path,
          err.message);
    CHECK(strstr(err.message, words) != NULL, "%s: \"%s\" does not say \"%s\"", env, err.message,
          words);
}

static void test_bad_environments_refused(void) {
    write_text("text.hdr", "this is not an image\n");
    write_text("huge.hdr", "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 5000 +X 5000\n");
    refused("{\"file\": \"nowhere.hdr\"}", "/render/environment/file", "nowhere.hdr");
    refused("{\"file\": \"text.hdr\"}", "/render/environment/file", "not a Radiance .hdr");
    refused("{\"file\": \"huge.hdr\"}", "/render/environment/file", "limit");
    refused("{\"base64\": \"aGVsbG8=\", \"format\": \"hdr\"}", "/render/environment/base64",
            "not a Radiance");
    refused("{\"base64\": \"aGVsbG8=\", \"format\": \"png\"}", "/render/environment/format",
            "hdr, exr");
    refused("{\"base64\": \"aGVsbG8=\", \"format\": \"exr\"}", "/render/environment/base64",
            "not an OpenEXR");
    refused("{\"file\": \"cut.exr\"}", "/render/environment/file", "OpenEXR");
    /* a 64 x 64 tiled EXR whose tiles are 16 x 9,764,880 pixels: found by
     * fuzz_envmap, it made OpenEXR's C++ library ask for 2.5 GB */
    refused("{\"base64\": "
            "\"di8xAQICAABjaGFubmVscwBjaGxpc3QANwAAAEIAAQAAAAAAAAABAAAAAQAAAEcAAQAAAAAAAAABAAAAAQAA"
            "AFIAAQAAAAAAAAABAAAAAQAAAABjb21wcmVzc2lvbmJhbnRlcgB2MmYACAAAAAAAAAAAAAAAc2NyZWVuV2luZG"
            "93V2lkdGgAZmxvYXQABAAAAAAAgD90aWxlcwB0aWxlZGVzYwAJAAAAEAAAABAAlQAAABBdAQAAAAAAAAAAAAAA"
            "AAAAAAAAAAAAAAAMAAAAeF5jaBjaAADSzV+B\"}",
            "/render/environment/base64", "tiles of 16 x 9764880 pixels");
    /* a DWAA file whose string attribute claims 1.9 GB, which the C++
     * library asked for before reading: found by fuzz_envmap */
    refused("{\"base64\": \""
            "di8xAQIAAABjaGFubmVscwBjaGxpc3QANwAAAEIAAQAAAAAAAAABAAAAAQAAAEcAAQAAAAAAAAABAAAAAQAA"
            "AFIAAQAAAAAAAAABAAAAAQAAAABjb21wcmVzc2lvbgBjb21wcmVzc2lvbgABAAAACGRhdGFXaW5kb3cAYm94"
            "MmkAEAAAAAAAAAAAAAAABwAAAAMAAABkaXNwbGF5V2lnZW5hbWUAc3RyaW5nAAMAYXRpbwBmbG9hdAAEAAAA"
            "AACAP3NjcmVlbldpbmRvd0NlbnRlcgB2MmYACAAAAAAAAAAAAAAAc2NyZWVuV2luZG93V2lkdGgAZmxvYXQA"
            "BAAAAAAAgD9jaGFubmVscwBjaGxpc3QANwAAAEIAAgAAAAAAAAABAAAAAQAAAEcAAgAAAAAAAAABAAAAAQAA"
            "AFIAAgAAAAAAAAABAAAAAQAAAAAAcQEAAAAAAAAAAAAAIIGAQCCBgEAggWZsb2F0AAQAAAAAAIA/AEEBAAAA"
            "AAAAAAAAAAAAAAAAAAAAAwAAAAAAAAADAAAAAAAAAAAAAAAAAAAADgBSABQBRwAkAUIANAEA/wAAAf8AAAIA"
            "AAADAAAAAAAAAAQQAHheY2gAAQAHhgKB"
            "\"}",
            "/render/environment/base64", "claims 1952514051 bytes");
    refused("{\"file\": \"ramp.hdr\", \"format\": \"exr\"}", "/render/environment/file",
            "not an OpenEXR");
    refused("{\"color\": [1,1,1], \"intensity\": -1}", "/render/environment/intensity", ">= 0");
    refused("{\"color\": [1,1,1], \"brightness\": 2}", "/render/environment/brightness",
            "unknown key");
    refused("{\"color\": [1,1,1], \"file\": \"a.hdr\"}", "/render/environment", "exactly one");
    refused("{}", "/render/environment", "exactly one");
    refused("{\"color\": [1,-1,1]}", "/render/environment/color/1", "");
    refused("[1, 2, 3]", "/render/environment", "object");
    refused("{\"color\": [1,1,1], \"visible\": 1}", "/render/environment/visible", "");
}

int main(void) {
    snprintf(dir, sizeof dir, "/tmp/rayd-env-XXXXXX");
    if (!mkdtemp(dir)) return 1;
    RUN(test_white_furnace_path);
    RUN(test_white_furnace_whitted_exact);
    RUN(test_invisible_environment_shows_background);
    RUN(test_rotation_turns_the_map);
    RUN(test_exr_equals_hdr);
    RUN(test_sampling_the_sky_pays);
    RUN(test_sampling_pdf_follows_the_radiance);
    RUN(test_lookup_finds_the_cell);
    RUN(test_same_bytes_any_threads_and_tiles);
    RUN(test_bad_environments_refused);
    const char *files[] = {"ramp.hdr", "sun.hdr", "text.hdr", "huge.hdr", "ramp.exr", "cut.exr"};
    for (int i = 0; i < 6; i++) {
        char p[128];
        snprintf(p, sizeof p, "%s/%s", dir, files[i]);
        unlink(p);
    }
    rmdir(dir);
    CHECK_EXIT();
}
