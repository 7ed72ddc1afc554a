/* test_image_cache.c -- image textures shared between scenes through a
 * rayd_asset_cache (core/shade/texels.c), and environment images likewise:
 * decoded once while a scene holds them, the same pixels as decoding, the same limits, and nothing
 * kept once no scene holds them. */
#include <stdint.h>
#include <stdlib.h>

#include "check.h"
#include "scene/scene.h"
#include "scene_util.h"
#include "shade/texture.h"

/* A scene of two quads whose materials name the same 32x16 PNG (a colour
 * ramp), base64; malloc'd. */
static char *two_quads(void) {
    rayd_image *tex;
    rayd_image_new(32, 16, &tex, NULL);
    uint8_t *p = rayd_image_pixels(tex);
    for (int i = 0; i < 32 * 16; i++) {
        p[3 * i] = (uint8_t)(i * 7);
        p[3 * i + 1] = (uint8_t)(i / 2);
        p[3 * i + 2] = (uint8_t)(255 - i / 3);
    }
    char *enc = png_base64(tex);
    size_t cap = 2 * strlen(enc) + 1024;
    char *json = malloc(cap);
    snprintf(json, cap,
             "{\"render\": {\"width\": 48, \"height\": 32},"
             " \"lights\": [{\"type\": \"point\", \"position\": [0, 0, 5]}],"
             " \"objects\": [{\"type\": \"quad\", \"corner\": [-1,-1,-4], \"edge1\": [1,0,0],"
             " \"edge2\": [0,2,0], \"material\": {\"texture\": {\"type\": \"image\","
             " \"png_base64\": \"%s\"}}},"
             " {\"type\": \"quad\", \"corner\": [0,-1,-4], \"edge1\": [1,0,0], \"edge2\": [0,2,0],"
             " \"material\": {\"texture\": {\"type\": \"image\", \"png_base64\": \"%s\"}}}]}",
             enc, enc);
    free(enc);
    return json;
}

/* A memory account that refuses past *arg bytes, as rayd's budget does. */
static enum rayd_status cap_charge(void *arg, long long bytes, char *why, size_t why_len) {
    long long *left = arg;
    if (bytes > *left) {
        snprintf(why, why_len, "over the cap by %lld bytes", bytes - *left);
        return RAYD_E_LIMIT;
    }
    *left -= bytes;
    return RAYD_OK;
}

/* json parsed with cache c, a texel limit (0: the default) and a memory
 * cap (0: none); NULL with err on failure. */
static rayd_scene *parse_capped(const char *json, rayd_asset_cache *c, long max_texels,
                                long long cap, struct rayd_error *err) {
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    lim.assets = c;
    if (max_texels) lim.max_texels = max_texels;
    long long left = cap;
    if (cap) {
        lim.charge = cap_charge;
        lim.charge_arg = &left;
    }
    rayd_scene *s = NULL;
    memset(err, 0, sizeof *err);
    return rayd_scene_parse(json, strlen(json), &lim, &s, err) == RAYD_OK ? s : NULL;
}

static rayd_scene *parse_with(const char *json, rayd_asset_cache *c, long max_texels,
                              struct rayd_error *err) {
    return parse_capped(json, c, max_texels, 0, err);
}

static bool same_pixels(const rayd_image *a, const rayd_image *b) {
    return a && b &&
           !memcmp(rayd_image_pixels((rayd_image *)(uintptr_t)a),
                   rayd_image_pixels((rayd_image *)(uintptr_t)b), 48 * 32 * 3);
}

static int distinct_reds(rayd_image *img) {
    bool seen[256] = {false};
    int n = 0;
    const uint8_t *p = rayd_image_pixels(img);
    for (int i = 0; i < 48 * 32; i++) n += !seen[p[3 * i]], seen[p[3 * i]] = true;
    return n;
}

static void test_decoded_once_same_pixels(void) {
    char *json = two_quads();
    struct rayd_error err;
    rayd_scene *plain = parse_with(json, NULL, 0, &err);
    rayd_asset_cache *c = rayd_asset_cache_new(0);
    rayd_scene *s1 = parse_with(json, c, 0, &err), *s2 = parse_with(json, c, 0, &err);
    CHECK(plain && s1 && s2, "parse: %s", err.message);
    long hits, misses;
    rayd_asset_cache_stats(c, RAYD_ASSET_IMAGE, &hits, &misses);
    /* the second quad's texture is the first's, and so are the next scene's */
    CHECK(misses == 1 && hits == 3, "hits %ld, misses %ld; want 3 and 1", hits, misses);
    if (s1 && s2) {
        CHECK(s1->ntextures == 2 && s1->textures[1].rgb == s1->textures[0].rgb &&
                  s2->textures[0].rgb == s1->textures[0].rgb,
              "the texels are not shared");
    }
    rayd_asset_cache_free(c); /* the scenes keep their images */
    rayd_image *want = plain ? render_all(plain, 2) : NULL;
    rayd_image *got1 = s1 ? render_all(s1, 2) : NULL;
    rayd_scene_free(s1); /* s2's image outlives s1's reference */
    rayd_image *got2 = s2 ? render_all(s2, 1) : NULL;
    CHECK(same_pixels(want, got1) && same_pixels(want, got2), "shared texels render differently");
    CHECK(want && distinct_reds(want) > 8, "the texture does not show: the check proves little");
    rayd_image_free(want);
    rayd_image_free(got1);
    rayd_image_free(got2);
    rayd_scene_free(s2);
    rayd_scene_free(plain);
    free(json);
}

static void test_limits_hold_the_same(void) {
    /* room for one image of 32x16 and a texel: the second is refused,
     * found in the cache or not, with the same path and words; and a
     * memory account with room for one image's decode likewise */
    char *json = two_quads();
    struct rayd_error plain_err, err;
    rayd_asset_cache *c = rayd_asset_cache_new(0);
    rayd_scene *keep = parse_with(json, c, 0, &err); /* holds the image in the cache */
    rayd_scene *a = parse_with(json, NULL, 32 * 16 + 1, &plain_err);
    rayd_scene *b = parse_with(json, c, 32 * 16 + 1, &err);
    CHECK(keep && !a && !b, "a scene over its texel limit was taken");
    CHECK(!strcmp(plain_err.path, err.path) && !strcmp(plain_err.message, err.message) &&
              *err.message,
          "'%s: %s' against '%s: %s'", err.path, err.message, plain_err.path, plain_err.message);
    long long cap = 32 * 16 * 16 + 32 * 16 * 4; /* the first decode's peak, not the second's */
    a = parse_capped(json, NULL, 0, cap, &plain_err);
    b = parse_capped(json, c, 0, cap, &err);
    CHECK(!a && !b, "a scene over its memory account was taken (%s, %s)", a ? "plain" : "-",
          b ? "shared" : "-");
    CHECK(!strcmp(plain_err.path, err.path) && !strcmp(plain_err.message, err.message) &&
              *err.message,
          "'%s: %s' against '%s: %s'", err.path, err.message, plain_err.path, plain_err.message);
    rayd_scene_free(a);
    rayd_scene_free(b);
    rayd_scene_free(keep);
    rayd_asset_cache_free(c);
    free(json);
}

static char *env_scene(double k);

static void test_holding_cache_keeps_images(void) {
    /* a program with one scene at a time: the image outlives each */
    char *json = two_quads();
    struct rayd_error err;
    rayd_asset_cache *c = rayd_asset_cache_new(1);
    rayd_scene_free(parse_with(json, c, 0, &err));
    rayd_scene *s = parse_with(json, c, 0, &err);
    long hits, misses;
    rayd_asset_cache_stats(c, RAYD_ASSET_IMAGE, &hits, &misses);
    CHECK(s && misses == 1 && hits == 3, "hits %ld, misses %ld; want 3 and 1", hits, misses);
    rayd_asset_cache_free(c); /* s keeps its image; freed with s (ASan: no leak) */
    rayd_image *img = s ? render_all(s, 1) : NULL;
    CHECK(img && distinct_reds(img) > 8, "the scene lost its texture");
    rayd_image_free(img);
    rayd_scene_free(s);
    /* freed with no scene left: the cache goes with its last image (ASan
     * and valgrind see a use after free or a leak here) */
    c = rayd_asset_cache_new(1);
    rayd_scene_free(parse_with(json, c, 0, &err));
    char *env = env_scene(1);
    rayd_scene_free(parse_with(env, c, 0, &err));
    rayd_asset_cache_stats(c, RAYD_ASSET_IMAGE, &hits, &misses);
    CHECK(misses == 2, "%ld images decoded, want 2", misses);
    rayd_asset_cache_free(c);
    free(env);
    free(json);
}

static void test_nothing_kept_without_a_scene(void) {
    char *json = two_quads();
    struct rayd_error err;
    rayd_asset_cache *c = rayd_asset_cache_new(0);
    rayd_scene_free(parse_with(json, c, 0, &err));
    rayd_scene_free(parse_with(json, c, 0, &err));
    long hits, misses;
    rayd_asset_cache_stats(c, RAYD_ASSET_IMAGE, &hits, &misses);
    /* each parse decoded once (its second quad shares): the first scene's
     * image went with it */
    CHECK(misses == 2 && hits == 2, "hits %ld, misses %ld; want 2 and 2", hits, misses);
    rayd_asset_cache_free(c);
    free(json);
}

/* A scene seen against a 16x8 .hdr environment (flat RGBE: a ramp) at
 * intensity k, base64; malloc'd. */
static char *env_scene(double k) {
    char head[64];
    int hn = snprintf(head, sizeof head, "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8 +X 16\n");
    unsigned char hdr[64 + 16 * 8 * 4];
    memcpy(hdr, head, (size_t)hn);
    for (int i = 0; i < 16 * 8; i++) {
        unsigned char *q = hdr + hn + 4 * i;
        q[0] = (unsigned char)(i % 2 ? 40 : 240), q[1] = (unsigned char)(200 - i), q[2] = 150,
        q[3] = 128;
    }
    char *enc = b64_encode(hdr, (size_t)hn + 16 * 8 * 4);
    size_t cap = strlen(enc) + 512;
    char *json = malloc(cap);
    snprintf(json, cap,
             "{\"render\": {\"width\": 48, \"height\": 32, \"environment\": "
             "{\"base64\": \"%s\", \"intensity\": %g}},"
             " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, -5]}]}",
             enc, k);
    free(enc);
    return json;
}

static void test_environment_shared(void) {
    char *json = env_scene(1), *brighter = env_scene(2);
    struct rayd_error err;
    rayd_asset_cache *c = rayd_asset_cache_new(0);
    rayd_scene *plain = parse_with(json, NULL, 0, &err);
    rayd_scene *s1 = parse_with(json, c, 0, &err), *s2 = parse_with(json, c, 0, &err);
    rayd_scene *s3 = parse_with(brighter, c, 0, &err);
    CHECK(plain && s1 && s2 && s3, "parse: %s", err.message);
    long hits, misses;
    rayd_asset_cache_stats(c, RAYD_ASSET_IMAGE, &hits, &misses);
    /* the intensity is in the floats: another intensity is another image */
    CHECK(hits == 1 && misses == 2, "hits %ld, misses %ld; want 1 and 2", hits, misses);
    if (s1 && s2 && s3)
        CHECK(s2->rs.env.rgb == s1->rs.env.rgb && s3->rs.env.rgb != s1->rs.env.rgb,
              "the environment's floats are not shared as they should be");
    rayd_asset_cache_free(c);
    rayd_image *want = plain ? render_all(plain, 2) : NULL;
    rayd_scene_free(s1);
    rayd_image *got = s2 ? render_all(s2, 2) : NULL;
    CHECK(same_pixels(want, got), "a shared environment renders differently");
    CHECK(want && distinct_reds(want) > 2,
          "the environment does not show (%d reds): the check proves little",
          want ? distinct_reds(want) : 0);
    rayd_image_free(want);
    rayd_image_free(got);
    rayd_scene_free(s2);
    rayd_scene_free(s3);
    rayd_scene_free(plain);
    free(json);
    free(brighter);
}

int main(void) {
    RUN(test_decoded_once_same_pixels);
    RUN(test_limits_hold_the_same);
    RUN(test_nothing_kept_without_a_scene);
    RUN(test_holding_cache_keeps_images);
    RUN(test_environment_shared);
    CHECK_EXIT();
}
