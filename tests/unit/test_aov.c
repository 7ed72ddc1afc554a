/* test_aov.c -- AOVs (render/aov.c): their values on analytic scenes, for
 * both integrators; exact over merged sample ranges, tilings and threads;
 * the EXR's channels, read back by OpenEXR's reader and bit for bit by
 * rayd_exr_decode_aov (and its refusals); the names' checks. */
#include <openexr.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "scene_util.h"

/* A red sphere of radius 1 at distance 5 straight ahead of a camera at the
 * origin; object 0 is a blue sphere out of sight; 33 x 33 pixels, so the
 * centre pixel's centre ray meets the sphere's front at distance 4. */
static rayd_scene *sphere_scene(const char *integrator, int samples) {
    char t[1024];
    snprintf(t, sizeof t,
             "{\"camera\": {\"position\": [0, 0, 0], \"look_at\": [0, 0, -5], \"fov_x\": 40},"
             " \"render\": {\"width\": 33, \"height\": 33, \"samples\": %d, \"integrator\": \"%s\","
             " \"background\": [0.2, 0.3, 0.4]},"
             " \"materials\": {\"blue\": {\"color\": [0.1, 0.2, 0.9]},"
             "                \"red\": {\"color\": [0.8, 0.3, 0.1], \"diffuse\": 0.7}},"
             " \"lights\": [{\"type\": \"point\", \"position\": [2, 3, 0]}],"
             " \"objects\": [{\"type\": \"sphere\", \"center\": [100, 0, -5], \"radius\": 1,"
             "                \"material\": \"blue\"},"
             "               {\"type\": \"sphere\", \"center\": [0, 0, -5], \"radius\": 1,"
             "                \"material\": \"red\"}]}",
             samples, integrator);
    return scene_from(t);
}

/* The AOV floats of a whole render of s in samples [k0, k1) (k1 == 0: a
 * plain pass of all the scene's samples) on threads threads, tile tile. */
static rayd_accum *aov_render(const rayd_scene *s, int k0, int k1, int threads, int tile) {
    rayd_accum *a = NULL;
    struct rayd_error err = {0};
    CHECK(rayd_accum_new(s, NULL, &a, &err) == RAYD_OK, "%s", err.message);
    CHECK(rayd_accum_aov_enable(a, &err) == RAYD_OK, "%s", err.message);
    struct rayd_render_opts o = {.threads = threads, .tile = tile};
    struct rayd_scene_info info;
    rayd_scene_info(s, &info);
    enum rayd_status st = k1 ? rayd_render_sample_range(s, &o, a, k0, k1, &err)
                             : rayd_render_pass(s, &o, a, 0, info.samples, &err);
    CHECK(st == RAYD_OK, "%s", err.message);
    return a;
}

static float *aov_floats(const rayd_accum *a) {
    float *f = NULL;
    struct rayd_error err = {0};
    CHECK(rayd_accum_aov_linear(a, &f, &err) == RAYD_OK, "%s", err.message);
    return f;
}

/* The sphere's AOVs at the centre pixel and a corner, exact for the
 * one-sample centre ray and within the pixel's spread for more samples. */
static void check_sphere(const char *integrator, int samples) {
    rayd_scene *s = sphere_scene(integrator, samples);
    if (!s) return;
    rayd_accum *a = aov_render(s, 0, 0, 2, 8);
    float *f = aov_floats(a);
    if (!f) return;
    const float *c = f + (16 * 33 + 16) * RAYD_AOV_FLOATS, *k = f;
    double tol = samples == 1 ? 1e-6 : 3e-3; /* jittered rays: the sphere's curve */
    CHECK_NEAR(c[6], 4.0, tol);              /* Z: the exact distance to the front */
    CHECK_NEAR(c[5], 1.0, tol);              /* N faces the camera (+z) */
    CHECK_NEAR(c[3], 0.0, 0.05);
    CHECK_NEAR(c[4], 0.0, 0.05);
    CHECK_NEAR(c[0], 0.8, 1e-6); /* albedo: the material's colour */
    CHECK_NEAR(c[1], 0.3, 1e-6);
    CHECK_NEAR(c[2], 0.1, 1e-6);
    CHECK(c[7] == 1.0f, "alpha %g on the sphere", c[7]);
    CHECK(c[8] == 1.0f, "object id %g: the sphere is /objects/1", c[8]);
    CHECK(c[9] == 2.0f, "material id %g: red is the second of /materials", c[9]);
    CHECK(k[7] == 0.0f, "alpha %g on the background", k[7]);
    CHECK(isinf(k[6]) && k[6] > 0, "Z %g where nothing is hit", k[6]);
    CHECK(k[8] == -1.0f && k[9] == -1.0f, "ids %g, %g where nothing is hit", k[8], k[9]);
    CHECK(k[0] == 0 && k[1] == 0 && k[2] == 0, "no albedo on the background");
    free(f);
    rayd_accum_free(a);
    rayd_scene_free(s);
}

static void test_sphere_values(void) {
    check_sphere("whitted", 1);
    check_sphere("whitted", 4);
    check_sphere("path", 1);
    check_sphere("path", 4);
}

/* Both integrators give the very same AOVs. */
static void test_integrators_agree(void) {
    rayd_scene *w = sphere_scene("whitted", 3), *p = sphere_scene("path", 3);
    if (!w || !p) return;
    rayd_accum *aw = aov_render(w, 0, 0, 1, 32), *ap = aov_render(p, 0, 0, 1, 32);
    float *fw = aov_floats(aw), *fp = aov_floats(ap);
    CHECK(fw && fp && !memcmp(fw, fp, 33 * 33 * RAYD_AOV_FLOATS * sizeof *fw), "AOVs differ");
    free(fw), free(fp);
    rayd_accum_free(aw), rayd_accum_free(ap);
    rayd_scene_free(w), rayd_scene_free(p);
}

/* A pixel whose edge crosses the sphere's silhouette: partial coverage. */
static void test_partial_alpha(void) {
    rayd_scene *s = sphere_scene("whitted", 64);
    if (!s) return;
    rayd_accum *a = aov_render(s, 0, 0, 2, 16);
    float *f = aov_floats(a);
    int partial = 0;
    for (int i = 0; f && i < 33 * 33; i++) {
        float al = f[i * RAYD_AOV_FLOATS + 7];
        CHECK(al >= 0 && al <= 1, "alpha %g", al);
        partial += al > 0 && al < 1;
    }
    CHECK(partial > 0, "no pixel on the silhouette is partly covered");
    free(f);
    rayd_accum_free(a);
    rayd_scene_free(s);
}

/* Samples [0, 3) and [3, 8) rendered apart and merged are one render of
 * [0, 8): the same AOV bits and the same beauty bytes, on other threads
 * and tiles too. */
static void check_ranges(const char *integrator) {
    rayd_scene *s = sphere_scene(integrator, 8);
    if (!s) return;
    rayd_accum *whole = aov_render(s, 0, 0, 1, 32);
    rayd_accum *lo = aov_render(s, 0, 3, 2, 7), *hi = aov_render(s, 3, 8, 3, 5);
    struct rayd_error err = {0};
    CHECK(rayd_accum_merge(lo, hi, &err) == RAYD_OK, "%s", err.message);
    CHECK(rayd_accum_samples(lo) == 8, "merged samples %d", rayd_accum_samples(lo));
    float *fw = aov_floats(whole), *fm = aov_floats(lo);
    CHECK(fw && fm && !memcmp(fw, fm, 33 * 33 * RAYD_AOV_FLOATS * sizeof *fw),
          "merged AOVs differ (%s)", integrator);
    rayd_image *iw = NULL, *im = NULL;
    CHECK(rayd_accum_image(whole, &iw, NULL) == RAYD_OK &&
              rayd_accum_image(lo, &im, NULL) == RAYD_OK,
          "images");
    CHECK(iw && im &&
              !memcmp(rayd_image_pixels_const(iw), rayd_image_pixels_const(im), 33 * 33 * 3),
          "merged beauty differs");
    /* the plain render's bytes are the accumulator's */
    rayd_image *plain = render_all(s, 2);
    CHECK(plain && iw &&
              !memcmp(rayd_image_pixels_const(plain), rayd_image_pixels_const(iw), 33 * 33 * 3),
          "AOVs changed the beauty");
    rayd_image_free(plain), rayd_image_free(iw), rayd_image_free(im);
    free(fw), free(fm);
    rayd_accum_free(whole), rayd_accum_free(lo), rayd_accum_free(hi);
    rayd_scene_free(s);
}

static void test_ranges_merge(void) {
    check_ranges("whitted");
    check_ranges("path");
}

/* Passes 1, 2, 4 resolve to the AOVs of plain 4-sample renders; a region
 * is the crop of the whole; threads and tiles change nothing. */
static void test_passes_and_regions(void) {
    rayd_scene *s = sphere_scene("path", 4);
    if (!s) return;
    rayd_accum *plain = aov_render(s, 0, 0, 1, 32), *prog = NULL, *crop = NULL;
    struct rayd_error err = {0};
    CHECK(rayd_accum_new(s, NULL, &prog, &err) == RAYD_OK, "%s", err.message);
    CHECK(rayd_accum_aov_enable(prog, &err) == RAYD_OK, "%s", err.message);
    struct rayd_render_opts o = {.threads = 3, .tile = 6};
    int ends[] = {1, 2, 4};
    for (int i = 0, from = 0; i < 3; from = ends[i++])
        CHECK(rayd_render_pass(s, &o, prog, from, ends[i], &err) == RAYD_OK, "%s", err.message);
    float *fp = aov_floats(plain), *fg = aov_floats(prog);
    CHECK(fp && fg && !memcmp(fp, fg, 33 * 33 * RAYD_AOV_FLOATS * sizeof *fp),
          "passes' AOVs differ from the plain render's");
    struct rayd_region r = {5, 9, 20, 11};
    CHECK(rayd_accum_new(s, &r, &crop, &err) == RAYD_OK, "%s", err.message);
    CHECK(rayd_accum_aov_enable(crop, &err) == RAYD_OK, "%s", err.message);
    CHECK(rayd_render_pass(s, &o, crop, 0, 4, &err) == RAYD_OK, "%s", err.message);
    float *fc = aov_floats(crop);
    int bad = 0;
    for (int y = 0; fc && fp && y < r.h; y++)
        bad += memcmp(fc + (size_t)y * r.w * RAYD_AOV_FLOATS,
                      fp + ((size_t)(y + r.y) * 33 + r.x) * RAYD_AOV_FLOATS,
                      (size_t)r.w * RAYD_AOV_FLOATS * sizeof *fc) != 0;
    CHECK(bad == 0, "%d rows of the region differ from the crop", bad);
    free(fp), free(fg), free(fc);
    rayd_accum_free(plain), rayd_accum_free(prog), rayd_accum_free(crop);
    rayd_scene_free(s);
}

/* A mirror's albedo is that of what it shows; ids of instances and CSG. */
static void test_mirror_and_ids(void) {
    const char *t =
        "{\"camera\": {\"position\": [0, 0, 0], \"look_at\": [0, 0, -5], \"fov_x\": 40},"
        " \"render\": {\"width\": 33, \"height\": 33, \"samples\": 1},"
        " \"materials\": {\"mirror\": {\"reflectivity\": 1}, \"green\": {\"color\": [0.1, 0.7, "
        "0.2]}},"
        " \"groups\": {\"g\": [{\"type\": \"sphere\", \"radius\": 1, \"material\": \"mirror\"}]},"
        " \"objects\": [{\"type\": \"plane\", \"point\": [0, 0, 5], \"normal\": [0, 0, -1],"
        "                \"material\": \"green\"},"
        "               {\"type\": \"csg\", \"op\": \"union\", \"operands\": ["
        "                 {\"type\": \"sphere\", \"center\": [3, 0, -8], \"radius\": 1},"
        "                 {\"type\": \"sphere\", \"center\": [3, 1, -8], \"radius\": 1}]},"
        "               {\"type\": \"instance\", \"group\": \"g\","
        "                \"transform\": [{\"translate\": [0, 0, -5]}]}]}";
    rayd_scene *s = scene_from(t);
    if (!s) return;
    rayd_accum *a = aov_render(s, 0, 0, 1, 32);
    float *f = aov_floats(a);
    if (f) {
        const float *c = f + (16 * 33 + 16) * RAYD_AOV_FLOATS;
        CHECK_NEAR(c[0], 0.1, 1e-6); /* the green plane behind the camera, in the mirror */
        CHECK_NEAR(c[1], 0.7, 1e-6);
        CHECK_NEAR(c[6], 4.0, 1e-6); /* Z, N and ids stay the mirror's */
        CHECK(c[8] == 2.0f, "object id %g: the instance is /objects/2", c[8]);
        CHECK(c[9] == 1.0f, "material id %g: mirror is the first of /materials", c[9]);
        int csg = 0;
        for (int i = 0; i < 33 * 33; i++) csg += f[i * RAYD_AOV_FLOATS + 8] == 1.0f;
        CHECK(csg > 0, "no pixel names the CSG object /objects/1");
    }
    free(f);
    rayd_accum_free(a);
    rayd_scene_free(s);
}

/* A whitted sphere's 33 x 33 render: its light (*rgb) and AOVs (*f), for
 * the EXR cases; NULL scene when it could not be made. */
static rayd_scene *exr_render(rayd_accum **a, float **rgb, float **f) {
    rayd_scene *s = sphere_scene("whitted", 1);
    if (!s) return NULL;
    *a = aov_render(s, 0, 0, 1, 32);
    *f = aov_floats(*a);
    struct rayd_error err = {0};
    *rgb = NULL;
    CHECK(rayd_accum_linear(*a, rgb, &err) == RAYD_OK, "%s", err.message);
    return s;
}

/* The EXR has every channel under its compositing name, and the values. */
static void test_exr_channels(void) {
    rayd_accum *a;
    float *rgb, *f;
    rayd_scene *s = exr_render(&a, &rgb, &f);
    if (!s) return;
    struct rayd_error err = {0};
    void *buf = NULL;
    size_t len = 0;
    CHECK(rayd_exr_encode_aov(rgb, f, RAYD_AOV_ALL, 33, 33, &buf, &len, &err) == RAYD_OK, "%s",
          err.message);
    char path[] = "/tmp/rayd-aov-XXXXXX";
    int fd = mkstemp(path);
    CHECK(fd >= 0 && write(fd, buf, len) == (ssize_t)len, "temp file");
    if (fd >= 0) close(fd);
    exr_context_t ctx = NULL;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    CHECK(exr_start_read(&ctx, path, &init) == EXR_ERR_SUCCESS, "OpenEXR reads it back");
    const exr_attr_chlist_t *ch = NULL;
    if (ctx) exr_get_channels(ctx, 0, &ch);
    const char *want[] = {"A", "B",        "G",        "N.X",      "N.Y",        "N.Z",     "R",
                          "Z", "albedo.B", "albedo.G", "albedo.R", "materialId", "objectId"};
    CHECK(ch && ch->num_channels == 13, "%d channels", ch ? ch->num_channels : -1);
    for (int i = 0; ch && i < ch->num_channels && i < 13; i++)
        CHECK(!strcmp(ch->entries[i].name.str, want[i]), "channel %d is %s, not %s", i,
              ch->entries[i].name.str, want[i]);
    if (ctx) exr_finish(&ctx);
    unlink(path);
    rayd_free(buf);
    /* without AOVs, the bytes of rayd_exr_encode */
    void *b1 = NULL, *b2 = NULL;
    size_t l1 = 0, l2 = 0;
    rayd_exr_encode(rgb, 33, 33, &b1, &l1, NULL);
    rayd_exr_encode_aov(rgb, NULL, 0, 33, 33, &b2, &l2, NULL);
    CHECK(b1 && b2 && l1 == l2 && !memcmp(b1, b2, l1), "an EXR without AOVs changed");
    rayd_free(b1), rayd_free(b2);
    rayd_free(rgb), free(f);
    rayd_accum_free(a);
    rayd_scene_free(s);
}

/* rayd_exr_decode_aov gives back the very floats, every channel (the
 * cluster joins tiles with it), and refuses what it was not written as. */
static void test_exr_decode(void) {
    rayd_accum *a;
    float *rgb, *f;
    rayd_scene *s = exr_render(&a, &rgb, &f);
    if (!s) return;
    struct rayd_error err = {0};
    unsigned mask = RAYD_AOV_NORMAL | RAYD_AOV_DEPTH;
    void *buf = NULL;
    size_t len = 0;
    CHECK(rayd_exr_encode_aov(rgb, f, mask, 33, 33, &buf, &len, &err) == RAYD_OK, "%s",
          err.message);
    size_t n = 33 * 33;
    float *r2 = calloc(n * 3, sizeof *r2), *f2 = calloc(n * RAYD_AOV_FLOATS, sizeof *f2);
    CHECK(rayd_exr_decode_aov(buf, len, mask, 33, 33, r2, f2, &err) == RAYD_OK, "%s", err.message);
    CHECK(!memcmp(rgb, r2, n * 3 * sizeof *r2), "the RGB floats differ");
    bool same = true;
    for (size_t i = 0; i < n; i++)
        for (int c = 3; c < 7; c++) /* N.X/Y/Z and Z: bit for bit (Z is +inf off the sphere) */
            same &= !memcmp(&f[i * RAYD_AOV_FLOATS + c], &f2[i * RAYD_AOV_FLOATS + c], 4);
    CHECK(same, "the normal or depth floats differ");
    CHECK(rayd_exr_decode_aov(buf, len, mask, 32, 33, r2, f2, &err) == RAYD_E_INVALID &&
              strstr(err.message, "size"),
          "another size: %s", err.message);
    CHECK(rayd_exr_decode_aov(buf, len, RAYD_AOV_NORMAL, 33, 33, r2, f2, &err) == RAYD_E_INVALID &&
              strstr(err.message, "channels"),
          "other channels: %s", err.message);
    CHECK(rayd_exr_decode_aov(buf, len, 0, 33, 33, r2, NULL, &err) == RAYD_E_INVALID,
          "RGB alone asked of a file with AOVs");
    CHECK(rayd_exr_decode_aov("not an EXR", 10, mask, 33, 33, r2, f2, &err) == RAYD_E_INVALID,
          "garbage read as an EXR");
    CHECK(rayd_exr_decode_aov(buf, len / 2, mask, 33, 33, r2, f2, &err) == RAYD_E_INVALID,
          "a truncated EXR read");
    unsigned char *bent = malloc(len);
    memcpy(bent, buf, len);
    for (size_t i = len / 2; i < len; i += 7) bent[i] ^= 0x5a; /* the pixel chunks damaged */
    enum rayd_status st = rayd_exr_decode_aov(bent, len, mask, 33, 33, r2, f2, &err);
    CHECK(st == RAYD_E_INVALID || (st == RAYD_OK && memcmp(rgb, r2, n * 3 * sizeof *r2)),
          "a damaged EXR read back as the image");
    CHECK(rayd_exr_decode_aov(buf, len, mask, 33, 33, r2, NULL, &err) == RAYD_E_ARG,
          "AOVs asked without a buffer");
    free(bent);
    free(r2), free(f2);
    rayd_free(buf), rayd_free(rgb), free(f);
    rayd_accum_free(a);
    rayd_scene_free(s);
}

/* The 8-bit pictures and the RGBA image: alpha 255 on the sphere, 0 off. */
static void test_pictures(void) {
    rayd_scene *s = sphere_scene("whitted", 1);
    if (!s) return;
    rayd_accum *a = aov_render(s, 0, 0, 1, 32);
    struct rayd_error err = {0};
    uint8_t *rgba = NULL;
    CHECK(rayd_accum_rgba(a, &rgba, &err) == RAYD_OK, "%s", err.message);
    rayd_image *beauty = NULL, *al = NULL, *nm = NULL;
    rayd_accum_image(a, &beauty, NULL);
    int c = 16 * 33 + 16;
    if (rgba && beauty) {
        CHECK(rgba[c * 4 + 3] == 255 && rgba[3] == 0, "alpha %d, %d", rgba[c * 4 + 3], rgba[3]);
        CHECK(!memcmp(rgba + c * 4, rayd_image_pixels_const(beauty) + c * 3, 3), "RGB of RGBA");
    }
    CHECK(rayd_accum_aov_image(a, s, RAYD_AOV_ALPHA, &al, &err) == RAYD_OK, "%s", err.message);
    CHECK(rayd_accum_aov_image(a, s, RAYD_AOV_NORMAL, &nm, &err) == RAYD_OK, "%s", err.message);
    if (al) CHECK(rayd_image_pixels(al)[c * 3] == 255 && rayd_image_pixels(al)[0] == 0, "alpha");
    if (nm)
        CHECK(rayd_image_pixels(nm)[c * 3 + 2] == 255, "normal z byte %d",
              rayd_image_pixels(nm)[c * 3 + 2]);
    CHECK(rayd_accum_aov_image(a, s, RAYD_AOV_ALPHA | RAYD_AOV_DEPTH, &al, &err) == RAYD_E_ARG,
          "two AOVs in one picture");
    void *png = NULL;
    size_t len = 0;
    CHECK(rgba && rayd_png_encode_rgba(rgba, 33, 33, &png, &len, &err) == RAYD_OK, "%s",
          err.message);
    rayd_image *back = NULL;
    CHECK(png && rayd_png_decode(png, len, 0, &back, &err) == RAYD_OK, "the RGBA PNG decodes");
    rayd_free(png), rayd_free(rgba);
    rayd_image_free(back), rayd_image_free(beauty), rayd_image_free(al), rayd_image_free(nm);
    rayd_accum_free(a);
    rayd_scene_free(s);
}

/* Names: good lists, and each bad one refused with what is wrong. */
static void test_names(void) {
    unsigned m = 0;
    struct rayd_error err = {0};
    CHECK(rayd_aov_parse("albedo,normal,depth,alpha,id", &m, &err) == RAYD_OK && m == RAYD_AOV_ALL,
          "all five: %u", m);
    CHECK(rayd_aov_parse("depth", &m, &err) == RAYD_OK && m == RAYD_AOV_DEPTH, "depth");
    CHECK(rayd_aov_parse("all", &m, &err) == RAYD_OK && m == RAYD_AOV_ALL, "all");
    const char *bad[] = {"",
                         "albedo,",
                         ",depth",
                         "albedo,,depth",
                         "Albedo",
                         "zdepth",
                         "depth ",
                         "normal,normal",
                         "id,object",
                         "all,depth",
                         "depth,albedo,depth"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        m = 12345;
        CHECK(rayd_aov_parse(bad[i], &m, &err) == RAYD_E_ARG && m == 12345, "'%s' accepted",
              bad[i]);
        CHECK(!strcmp(err.path, "aov") && err.message[0], "'%s': %s", bad[i], err.message);
    }
    CHECK(rayd_aov_parse(NULL, &m, &err) == RAYD_E_ARG, "NULL");
    /* a repeat names itself, and the earlier name it repeats */
    CHECK(rayd_aov_parse("depth,normal,normal", &m, &err) == RAYD_E_ARG &&
              !strcmp(err.message, "'normal' is named more than once"),
          "repeat: %s", err.message);
    CHECK(rayd_aov_parse("albedo,id,object", &m, &err) == RAYD_E_ARG &&
              !strcmp(err.message, "'object' names an AOV that 'id' named already"),
          "overlap: %s", err.message);
    CHECK(!strcmp(rayd_aov_name(RAYD_AOV_NORMAL), "normal") && !rayd_aov_name(3), "names");
    /* an accumulator with samples cannot start keeping AOVs; merging needs both */
    rayd_scene *s = sphere_scene("whitted", 2);
    rayd_accum *a = NULL, *b = NULL;
    if (!s) return;
    rayd_accum_new(s, NULL, &a, NULL);
    rayd_accum_new(s, NULL, &b, NULL);
    rayd_render_sample_range(s, NULL, a, 0, 1, NULL);
    CHECK(rayd_accum_aov_enable(a, &err) == RAYD_E_ARG, "enabled after samples");
    CHECK(rayd_accum_aov_enable(b, &err) == RAYD_OK, "%s", err.message);
    rayd_render_sample_range(s, NULL, b, 1, 2, NULL);
    CHECK(rayd_accum_merge(a, b, &err) == RAYD_E_ARG, "merged AOVs into none");
    float *f = NULL;
    CHECK(rayd_accum_aov_linear(a, &f, &err) == RAYD_E_ARG && !f, "AOVs of none");
    rayd_accum_free(a), rayd_accum_free(b);
    rayd_scene_free(s);
}

/* "render": {"aov": [...]}: kept in the scene's info; bad values named by
 * their JSON Pointer. */
static void test_scene_key(void) {
    const char *good = "{\"render\": {\"aov\": [\"albedo\", \"id\"]}}";
    rayd_scene *s = scene_from(good);
    struct rayd_scene_info info = {0};
    if (s) rayd_scene_info(s, &info);
    CHECK(info.aov == (RAYD_AOV_ALBEDO | RAYD_AOV_OBJECT | RAYD_AOV_MATERIAL), "aov %u", info.aov);
    rayd_scene_free(s);
    s = scene_from("{}");
    if (s) rayd_scene_info(s, &info);
    CHECK(s && info.aov == 0, "no render.aov: %u", info.aov);
    rayd_scene_free(s);
    static const struct {
        const char *aov, *path;
    } bad[] = {{"3", "/render/aov"},
               {"\"albedo\"", "/render/aov"},
               {"{}", "/render/aov"},
               {"[\"albedo\", 7]", "/render/aov/1"},
               {"[\"zdepth\"]", "/render/aov/0"},
               {"[\"depth\", \"albedo,normal\"]", "/render/aov/1"},
               {"[\"\"]", "/render/aov/0"},
               {"[null]", "/render/aov/0"}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        char t[200];
        snprintf(t, sizeof t, "{\"render\": {\"aov\": %s}}", bad[i].aov);
        rayd_scene *b = NULL;
        struct rayd_error err = {0};
        CHECK(rayd_scene_parse(t, strlen(t), NULL, &b, &err) == RAYD_E_INVALID, "%s accepted",
              bad[i].aov);
        CHECK(!strcmp(err.path, bad[i].path), "%s: path %s, not %s (%s)", bad[i].aov, err.path,
              bad[i].path, err.message);
        rayd_scene_free(b);
    }
}

int main(void) {
    RUN(test_scene_key);
    RUN(test_sphere_values);
    RUN(test_integrators_agree);
    RUN(test_partial_alpha);
    RUN(test_ranges_merge);
    RUN(test_passes_and_regions);
    RUN(test_mirror_and_ids);
    RUN(test_exr_channels);
    RUN(test_exr_decode);
    RUN(test_pictures);
    RUN(test_names);
    CHECK_EXIT();
}
