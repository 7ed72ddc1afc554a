/* test_passes.c -- progressive passes are exact prefixes.
 *
 * The rule (docs/scene-format.md): the image after a pass that brings a
 * pixel's samples to n equals, byte for byte, the plain render with
 * "samples": n -- for both integrators, any tiling, thread count and pass
 * schedule, and for regions as crops.  A one-sample pass shows the
 * pixel-centre image of "samples": 1.  Through the public API only. */
#include <stdatomic.h>
#include <stdlib.h>

#include "check.h"
#include "scene_util.h"

/* text with the number after "key": replaced by value (a new string). */
static char *set_key(const char *text, const char *key, int value) {
    char pat[64];
    snprintf(pat, sizeof pat, "\"%s\":", key);
    const char *at = strstr(text, pat);
    if (!at) return NULL;
    const char *num = at + strlen(pat);
    while (*num == ' ') num++;
    const char *end = num;
    while ((*end >= '0' && *end <= '9') || *end == '.') end++;
    size_t len = strlen(text) + 32;
    char *out = malloc(len);
    snprintf(out, len, "%.*s%d%s", (int)(num - text), text, value, end);
    return out;
}

/* The scene file at w x h with the given samples. */
static rayd_scene *scene_sized(const char *path, int w, int h, int samples) {
    size_t len;
    char *text = read_file(path, &len);
    CHECK(text != NULL, "%s readable (run from the repository root)", path);
    if (!text) return NULL;
    char *a = set_key(text, "width", w), *b = a ? set_key(a, "height", h) : NULL;
    char *c = b ? set_key(b, "samples", samples) : NULL;
    rayd_scene *s = c ? scene_from(c) : NULL;
    free(text);
    free(a);
    free(b);
    free(c);
    return s;
}

static int same_image(const rayd_image *a, const rayd_image *b) {
    int w = rayd_image_width(a), h = rayd_image_height(a);
    return w == rayd_image_width(b) && h == rayd_image_height(b) &&
           memcmp(rayd_image_pixels_const(a), rayd_image_pixels_const(b), (size_t)w * h * 3) == 0;
}

/* Runs the passes ends[0..count) on an accumulator with threads and tile,
 * and checks each pass's image against a plain one-thread render. */
static void check_passes(const char *path, int w, int h, const int *ends, int count, int threads,
                         int tile) {
    rayd_scene *s = scene_sized(path, w, h, 1);
    if (!s) return;
    rayd_accum *acc = NULL;
    CHECK(rayd_accum_new(s, NULL, &acc, NULL) == RAYD_OK, "accumulator");
    struct rayd_render_opts o = {.threads = threads, .tile = tile};
    int from = 0;
    for (int p = 0; acc && p < count; p++) {
        struct rayd_error err = {0};
        CHECK(rayd_render_pass(s, &o, acc, from, ends[p], &err) == RAYD_OK, "pass %d..%d: %s", from,
              ends[p], err.message);
        from = ends[p];
        rayd_image *got = NULL, *want = NULL;
        rayd_scene *plain = scene_sized(path, w, h, from);
        CHECK(rayd_accum_image(acc, &got, NULL) == RAYD_OK, "resolve");
        want = plain ? render_all(plain, 1) : NULL;
        CHECK(got && want && same_image(got, want),
              "%s: pass to %d samples (%d threads, tile %d) equals the plain render", path, from,
              threads, tile);
        CHECK(rayd_accum_samples(acc) == from, "samples %d", rayd_accum_samples(acc));
        rayd_image_free(got);
        rayd_image_free(want);
        rayd_scene_free(plain);
    }
    rayd_accum_free(acc);
    rayd_scene_free(s);
}

static void test_path_passes_are_prefixes(void) {
    static const int doubling[] = {1, 2, 4, 8};
    static const int every3[] = {3, 6, 9};
    check_passes("scenes/cornell.json", 23, 19, doubling, 4, 1, 32);
    check_passes("scenes/cornell.json", 23, 19, doubling, 4, 3, 5);
    check_passes("scenes/cornell.json", 23, 19, every3, 3, 2, 7);
}

static void test_whitted_passes_are_prefixes(void) {
    static const int doubling[] = {1, 2, 4};
    static const int odd[] = {1, 3, 4, 5};
    check_passes("scenes/whitted.json", 37, 21, doubling, 3, 2, 6);
    check_passes("scenes/whitted.json", 37, 21, odd, 4, 5, 1000);
}

/* An accumulator over a region gives the crop of the whole one. */
static void test_region_pass_is_a_crop(void) {
    rayd_scene *s = scene_sized("scenes/cornell.json", 30, 30, 1);
    if (!s) return;
    struct rayd_region r = {7, 5, 13, 17};
    rayd_accum *whole = NULL, *part = NULL;
    struct rayd_render_opts o = {.threads = 2, .tile = 4};
    CHECK(rayd_accum_new(s, NULL, &whole, NULL) == RAYD_OK, "whole");
    CHECK(rayd_accum_new(s, &r, &part, NULL) == RAYD_OK, "part");
    CHECK(rayd_render_pass(s, &o, whole, 0, 3, NULL) == RAYD_OK, "whole pass");
    CHECK(rayd_render_pass(s, &o, part, 0, 2, NULL) == RAYD_OK, "part pass 1");
    CHECK(rayd_render_pass(s, &o, part, 2, 3, NULL) == RAYD_OK, "part pass 2");
    rayd_image *a = NULL, *b = NULL;
    CHECK(rayd_accum_image(whole, &a, NULL) == RAYD_OK &&
              rayd_accum_image(part, &b, NULL) == RAYD_OK,
          "resolve");
    int ok = a && b;
    for (int row = 0; ok && row < r.h; row++)
        ok = memcmp(rayd_image_pixels_const(a) + ((size_t)(r.y + row) * 30 + r.x) * 3,
                    rayd_image_pixels_const(b) + (size_t)row * r.w * 3, (size_t)r.w * 3) == 0;
    CHECK(ok, "the region's passes equal the crop of the whole image's");
    rayd_image_free(a);
    rayd_image_free(b);
    rayd_accum_free(whole);
    rayd_accum_free(part);
    rayd_scene_free(s);
}

/* The linear image, sRGB-encoded by an independent formula, gives the
 * 8-bit image (within one step: the float rounding of the average). */
static void test_linear_matches_bytes(void) {
    rayd_scene *s = scene_sized("scenes/cornell.json", 16, 16, 1);
    if (!s) return;
    rayd_accum *acc = NULL;
    CHECK(rayd_accum_new(s, NULL, &acc, NULL) == RAYD_OK, "accumulator");
    CHECK(acc && rayd_render_pass(s, NULL, acc, 0, 4, NULL) == RAYD_OK, "pass");
    rayd_image *img = NULL;
    float *lin = NULL;
    CHECK(acc && rayd_accum_image(acc, &img, NULL) == RAYD_OK, "image");
    CHECK(acc && rayd_accum_linear(acc, &lin, NULL) == RAYD_OK, "linear");
    int worst = 0;
    for (int i = 0; img && lin && i < 16 * 16 * 3; i++) {
        int d = abs(srgb_ref(lin[i]) - rayd_image_pixels_const(img)[i]);
        worst = d > worst ? d : worst;
    }
    CHECK(img && lin && worst <= 1, "linear -> sRGB within 1 of the bytes (worst %d)", worst);
    rayd_free(lin);
    rayd_image_free(img);
    rayd_accum_free(acc);
    rayd_scene_free(s);
}

/* The tone curve: none is today's image; exposure and Reinhard follow the
 * documented formula on the linear values (within one step). */
static void test_tone_curves(void) {
    rayd_scene *s = scene_sized("scenes/cornell.json", 12, 12, 1);
    if (!s) return;
    rayd_accum *acc = NULL;
    CHECK(rayd_accum_new(s, NULL, &acc, NULL) == RAYD_OK, "accumulator");
    if (!acc) return;
    CHECK(rayd_render_pass(s, NULL, acc, 0, 3, NULL) == RAYD_OK, "pass");
    rayd_image *plain = NULL, *same = NULL, *up = NULL, *rh = NULL;
    float *lin = NULL;
    struct rayd_tone none = {0}, bright = {1.0, RAYD_TONE_CLAMP}, soft = {-0.5, RAYD_TONE_REINHARD};
    rayd_accum_image(acc, &plain, NULL);
    rayd_accum_image_tone(acc, &none, &same, NULL);
    rayd_accum_image_tone(acc, &bright, &up, NULL);
    rayd_accum_image_tone(acc, &soft, &rh, NULL);
    rayd_accum_linear(acc, &lin, NULL);
    CHECK(plain && same && up && rh && lin, "every image made");
    if (plain && same && up && rh && lin) {
        CHECK(!memcmp(rayd_image_pixels_const(plain), rayd_image_pixels_const(same), 12 * 12 * 3),
              "no tone: the same bytes");
        int worst = 0;
        for (int i = 0; i < 12 * 12 * 3; i++) {
            double v = lin[i], r = v * pow(2, -0.5);
            int a = abs(srgb_ref(2 * v) - rayd_image_pixels_const(up)[i]);
            int b = abs(srgb_ref(r > 0 ? r / (1 + r) : r) - rayd_image_pixels_const(rh)[i]);
            worst = a > worst ? a : b > worst ? b : worst;
        }
        CHECK(worst <= 1, "exposure and Reinhard by the formula (worst %d)", worst);
    }
    struct rayd_tone bad = {100, RAYD_TONE_CLAMP};
    struct rayd_error err = {0};
    rayd_image *x = NULL;
    CHECK(rayd_accum_image_tone(acc, &bad, &x, &err) == RAYD_E_ARG && !strcmp(err.path, "exposure"),
          "exposure out of range refused");
    rayd_free(lin);
    rayd_image_free(plain);
    rayd_image_free(same);
    rayd_image_free(up);
    rayd_image_free(rh);
    rayd_accum_free(acc);
    rayd_scene_free(s);
}

static void test_bad_passes_are_refused(void) {
    rayd_scene *s = scene_sized("scenes/cornell.json", 8, 8, 1);
    if (!s) return;
    rayd_accum *acc = NULL;
    struct rayd_error err = {0};
    CHECK(rayd_accum_new(s, NULL, &acc, NULL) == RAYD_OK, "accumulator");
    if (!acc) return;
    rayd_image *img = NULL;
    CHECK(rayd_accum_image(acc, &img, &err) == RAYD_E_ARG, "no samples yet: refused");
    CHECK(rayd_render_pass(s, NULL, acc, 1, 2, &err) == RAYD_E_ARG &&
              strstr(err.message, "must be 0"),
          "a gap refused: %s", err.message);
    CHECK(rayd_render_pass(s, NULL, acc, 0, 0, &err) == RAYD_E_ARG &&
              !strcmp(err.path, "samples_to"),
          "an empty pass refused: %s", err.path);
    atomic_int stop = 1;
    struct rayd_render_opts o = {.cancel = &stop};
    CHECK(rayd_render_pass(s, &o, acc, 0, 2, &err) == RAYD_E_CANCELED, "canceled");
    CHECK(rayd_render_pass(s, NULL, acc, 0, 2, &err) == RAYD_E_ARG &&
              strstr(err.message, "canceled"),
          "after a cancel, refused: %s", err.message);
    struct rayd_region bad = {7, 0, 5, 5};
    rayd_accum *b = NULL;
    CHECK(rayd_accum_new(s, &bad, &b, &err) == RAYD_E_ARG && b == NULL, "a bad region refused");
    rayd_accum_free(acc);
    rayd_scene_free(s);
}

/* Sample ranges rendered apart (threads and tiles differing), sent through
 * their bytes, added in another order: the very image and linear values of
 * one render of all the samples. */
static void check_ranges(const char *path, int samples, const int *cuts, int ncuts) {
    rayd_scene *s = scene_sized(path, 23, 19, samples);
    rayd_accum *sum = NULL, *whole = NULL;
    if (!s || rayd_accum_new(s, NULL, &sum, NULL) != RAYD_OK) return;
    for (int i = ncuts - 2; i >= 0; i--) { /* last range first */
        rayd_accum *part = NULL;
        struct rayd_render_opts o = {.threads = 1 + i % 3, .tile = 3 + 4 * i};
        struct rayd_error err = {0};
        void *bytes = NULL;
        size_t len = 0;
        struct rayd_sums_header hdr;
        double *back = NULL;
        CHECK(rayd_accum_new(s, NULL, &part, NULL) == RAYD_OK &&
                  rayd_render_sample_range(s, &o, part, cuts[i], cuts[i + 1], &err) == RAYD_OK &&
                  rayd_sums_encode(23, 19, cuts[i], cuts[i + 1], rayd_accum_sums(part), &bytes,
                                   &len, &err) == RAYD_OK &&
                  rayd_sums_decode(bytes, len, &hdr, &back, &err) == RAYD_OK,
              "range %d..%d rendered and sent: %s", cuts[i], cuts[i + 1], err.message);
        CHECK(back && hdr.k0 == cuts[i] && hdr.k1 == cuts[i + 1] && hdr.width == 23 &&
                  !memcmp(back, rayd_accum_sums(part), 23 * 19 * 3 * sizeof *back),
              "the sums survive their bytes");
        CHECK(back && rayd_accum_add_sums(sum, back, cuts[i + 1] - cuts[i], &err) == RAYD_OK,
              "added: %s", err.message);
        rayd_accum_free(part);
        rayd_free(bytes);
        rayd_free(back);
    }
    rayd_image *got = NULL, *want = render_all(s, 2);
    CHECK(rayd_accum_image(sum, &got, NULL) == RAYD_OK && want && same_image(got, want),
          "%s: ranges merged equal the one render of %d samples", path, samples);
    float *lin_got = NULL, *lin_want = NULL;
    CHECK(rayd_accum_new(s, NULL, &whole, NULL) == RAYD_OK &&
              rayd_render_pass(s, NULL, whole, 0, samples, NULL) == RAYD_OK &&
              rayd_accum_linear(whole, &lin_want, NULL) == RAYD_OK &&
              rayd_accum_linear(sum, &lin_got, NULL) == RAYD_OK &&
              !memcmp(lin_got, lin_want, 23 * 19 * 3 * sizeof(float)),
          "%s: merged linear values equal the one render's (the EXR's)", path);
    rayd_free(lin_got);
    rayd_free(lin_want);
    rayd_image_free(got);
    rayd_image_free(want);
    rayd_accum_free(sum);
    rayd_accum_free(whole);
    rayd_scene_free(s);
}

/* The one-sample (centre) image is no rounded sum: as a pass and as a
 * range sent through its bytes, it is the plain one-sample render. */
static void test_centre_image_is_not_rounded(void) {
    rayd_scene *s = scene_sized("scenes/cornell.json", 96, 72, 1);
    rayd_accum *a = NULL, *b = NULL, *sum = NULL;
    if (!s) return;
    rayd_image *want = render_all(s, 2), *got = NULL, *got2 = NULL;
    void *bytes = NULL;
    size_t len = 0;
    struct rayd_sums_header hdr;
    double *back = NULL;
    CHECK(rayd_accum_new(s, NULL, &a, NULL) == RAYD_OK &&
              rayd_render_pass(s, NULL, a, 0, 1, NULL) == RAYD_OK &&
              rayd_accum_image(a, &got, NULL) == RAYD_OK && same_image(got, want),
          "a one-sample pass is the plain one-sample render");
    CHECK(rayd_accum_new(s, NULL, &b, NULL) == RAYD_OK &&
              rayd_render_sample_range(s, NULL, b, 0, 1, NULL) == RAYD_OK &&
              rayd_sums_encode(96, 72, 0, 1, rayd_accum_sums(b), &bytes, &len, NULL) == RAYD_OK &&
              rayd_sums_decode(bytes, len, &hdr, &back, NULL) == RAYD_OK &&
              rayd_accum_new_sized(96, 72, &sum, NULL) == RAYD_OK &&
              rayd_accum_add_sums(sum, back, 1, NULL) == RAYD_OK &&
              rayd_accum_image(sum, &got2, NULL) == RAYD_OK && same_image(got2, want),
          "the one-sample range through its bytes is the plain one-sample render");
    rayd_image_free(want);
    rayd_image_free(got);
    rayd_image_free(got2);
    rayd_accum_free(a);
    rayd_accum_free(b);
    rayd_accum_free(sum);
    rayd_free(bytes);
    rayd_free(back);
    rayd_scene_free(s);
}

static void test_sample_ranges_merge_exactly(void) {
    static const int three[] = {0, 3, 5, 8}, ones[] = {0, 1, 2, 3, 4}, odd[] = {0, 7, 13};
    check_ranges("scenes/cornell.json", 8, three, 4);
    check_ranges("scenes/cornell.json", 4, ones, 5);
    check_ranges("scenes/whitted.json", 13, odd, 3);
}

static void test_bad_sums_are_refused(void) {
    double sums[3] = {1.0, 0.5, 0.25};
    void *b = NULL;
    size_t len = 0;
    struct rayd_sums_header hdr;
    double *out = NULL;
    struct rayd_error err = {0};
    CHECK(rayd_sums_encode(1, 1, 0, 2, sums, &b, &len, NULL) == RAYD_OK && len == 48, "encoded");
    if (!b) return;
    /* the wire's layout, whatever the host: header, then each double's
     * IEEE 754 bits, least significant byte first (1.0 is 3ff0...0) */
    static const unsigned char want[48] = {
        'R', 'A', 'Y', 'D', 'S', 'U', 'M',  '1',  1, 0, 0, 0, 1, 0, 0,    0,
        0,   0,   0,   0,   2,   0,   0,    0,    0, 0, 0, 0, 0, 0, 0xf0, 0x3f,
        0,   0,   0,   0,   0,   0,   0xe0, 0x3f, 0, 0, 0, 0, 0, 0, 0xd0, 0x3f};
    CHECK(len == 48 && !memcmp(b, want, 48), "the sums' bytes are little-endian doubles");
    CHECK(rayd_sums_decode(b, len, &hdr, &out, &err) == RAYD_OK && out[0] == 1.0 && out[1] == 0.5 &&
              out[2] == 0.25,
          "and read back: %s", err.message);
    rayd_free(out);
    out = NULL;
    CHECK(rayd_sums_decode(b, len - 1, &hdr, &out, &err) == RAYD_E_PARSE, "truncated refused");
    unsigned char *p = b;
    p[47] = 0x80; /* a negative sum */
    CHECK(rayd_sums_decode(b, len, &hdr, &out, &err) == RAYD_E_PARSE &&
              strstr(err.message, "out of range"),
          "a negative sum refused: %s", err.message);
    p[0] = 'X';
    CHECK(rayd_sums_decode(b, len, &hdr, &out, &err) == RAYD_E_PARSE, "no magic refused");
    CHECK(out == NULL, "nothing handed out");
    rayd_free(b);
}

int main(void) {
    RUN(test_path_passes_are_prefixes);
    RUN(test_whitted_passes_are_prefixes);
    RUN(test_region_pass_is_a_crop);
    RUN(test_linear_matches_bytes);
    RUN(test_tone_curves);
    RUN(test_bad_passes_are_refused);
    RUN(test_sample_ranges_merge_exactly);
    RUN(test_centre_image_is_not_rounded);
    RUN(test_bad_sums_are_refused);
    return check_failures_ != 0;
}
