/* test_hdr.c -- the HDR encoders through the public API: the 16-bit PNG
 * decodes (libpng) to the sRGB formula's 16-bit values, clamped; the EXR
 * starts as OpenEXR says and holds the floats (the reading by OpenEXR's own
 * library is tests/tools/hdrcheck.cc's, in the integration tests), PIZ
 * where its floats repeat and uncompressed where they are noise; both give
 * the same bytes every time; bad sizes are refused. */
#include <math.h>
#include <openexr.h>
#include <png.h>
#include <setjmp.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "rayd/rayd.h"

/* w x h linear values over -0.5 .. 3.5, NaN and infinity among them. */
static float *ramp(int w, int h) {
    float *f = malloc((size_t)w * h * 3 * sizeof *f);
    for (int i = 0; i < w * h * 3; i++) f[i] = (float)(i % 97) / 24.0f - 0.5f;
    f[5] = NAN;
    f[7] = INFINITY;
    return f;
}

static int srgb16_ref(double c) {
    if (!(c > 0)) return 0;
    if (c >= 1) return 65535;
    double e = c <= 0.0031308 ? 12.92 * c : 1.055 * pow(c, 1 / 2.4) - 0.055;
    return (int)floor(e * 65535 + 0.5);
}

struct reader {
    const unsigned char *p;
    size_t left;
};

static void read_mem(png_structp png, png_bytep out, size_t n) {
    struct reader *r = png_get_io_ptr(png);
    if (n > r->left) png_error(png, "short");
    memcpy(out, r->p, n);
    r->p += n;
    r->left -= n;
}

/* The 16-bit samples of a PNG in memory (classic libpng reader), or NULL. */
static unsigned *decode16(const void *buf, size_t len, int w, int h) {
    struct reader rd = {buf, len};
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png_create_info_struct(png);
    unsigned *out = calloc((size_t)w * h * 3, sizeof *out);
    unsigned char *row = malloc((size_t)w * 6);
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, NULL);
        free(row);
        free(out);
        return NULL;
    }
    png_set_read_fn(png, &rd, read_mem);
    png_read_info(png, info);
    if (png_get_bit_depth(png, info) != 16 || png_get_image_width(png, info) != (unsigned)w ||
        png_get_image_height(png, info) != (unsigned)h)
        png_error(png, "not the expected 16-bit image");
    for (int y = 0; y < h; y++) {
        png_read_row(png, row, NULL);
        for (int k = 0; k < w * 3; k++)
            out[(size_t)y * w * 3 + k] = (unsigned)row[2 * k] << 8 | row[2 * k + 1];
    }
    png_destroy_read_struct(&png, &info, NULL);
    free(row);
    return out;
}

static void test_png16_values(void) {
    int w = 37, h = 11;
    float *f = ramp(w, h);
    void *a = NULL, *b = NULL;
    size_t alen = 0, blen = 0;
    CHECK(rayd_png16_encode(f, w, h, -1, &a, &alen, NULL) == RAYD_OK, "encode");
    CHECK(rayd_png16_encode(f, w, h, -1, &b, &blen, NULL) == RAYD_OK, "encode again");
    CHECK(a && b && alen == blen && !memcmp(a, b, alen), "the same bytes twice");
    unsigned *v = a ? decode16(a, alen, w, h) : NULL;
    CHECK(v != NULL, "libpng decodes a %dx%d 16-bit PNG", w, h);
    int bad = 0;
    for (int i = 0; v && i < w * h * 3; i++) bad += (int)v[i] != srgb16_ref(f[i]);
    CHECK(v && bad == 0, "%d samples differ from the sRGB formula at 16 bits", bad);
    free(v);
    rayd_free(a);
    rayd_free(b);
    free(f);
}

static void test_exr_bytes(void) {
    int w = 19, h = 70; /* more than one 32-row chunk, a short last one */
    float *f = ramp(w, h);
    void *a = NULL, *b = NULL;
    size_t alen = 0, blen = 0;
    CHECK(rayd_exr_encode(f, w, h, &a, &alen, NULL) == RAYD_OK, "encode");
    CHECK(rayd_exr_encode(f, w, h, &b, &blen, NULL) == RAYD_OK, "encode again");
    CHECK(a && b && alen == blen && !memcmp(a, b, alen), "the same bytes twice");
    static const unsigned char magic[4] = {0x76, 0x2f, 0x31, 0x01};
    CHECK(a && alen > 100 && !memcmp(a, magic, 4), "OpenEXR's magic number");
    rayd_free(a);
    rayd_free(b);
    free(f);
}

/* The compression OpenEXR's reader finds in the file buf; -1 when it
 * cannot read it. */
static int compression_of(const void *buf, size_t len) {
    char path[] = "/tmp/rayd-hdr-XXXXXX";
    int fd = mkstemp(path);
    if (fd < 0) return -1;
    bool whole = write(fd, buf, len) == (ssize_t)len;
    close(fd);
    exr_context_t ctx = NULL;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    exr_compression_t c = EXR_COMPRESSION_LAST_TYPE;
    if (whole && exr_start_read(&ctx, path, &init) == EXR_ERR_SUCCESS)
        exr_get_compression(ctx, 0, &c);
    if (ctx) exr_finish(&ctx);
    unlink(path);
    return c == EXR_COMPRESSION_LAST_TYPE ? -1 : (int)c;
}

/* Noise (every float its own), except that in rows y % every == 0
 * pixel 1 repeats pixel 0, in every channel (the AOVs' too). */
static void noise(float *f, size_t floats, int w, int h, int every) {
    uint32_t x = 12345;
    for (size_t i = 0; i < (size_t)w * h * floats; i++) {
        x = x * 1664525u + 1013904223u;
        f[i] = (float)(x >> 8) / 16777216.0f;
    }
    for (int y = 0; w > 1 && y < h; y += every)
        memcpy(&f[((size_t)y * w + 1) * floats], &f[(size_t)y * w * floats], floats * sizeof *f);
}

/* w x h pixels of noise (with the AOVs of mask, repeats in rows y % every
 * == 0) are written with compression want, and decode to the very
 * floats. */
static void check_compression(int w, int h, int every, unsigned mask, exr_compression_t want) {
    size_t n = (size_t)w * h;
    float *f = malloc(n * 3 * sizeof *f), *aov = malloc(n * RAYD_AOV_FLOATS * sizeof *aov);
    noise(f, 3, w, h, every);
    noise(aov, RAYD_AOV_FLOATS, w, h, every);
    float *back = calloc(n * 3, sizeof *back),
          *aov_back = calloc(n * RAYD_AOV_FLOATS, sizeof *aov_back);
    void *buf = NULL;
    size_t len = 0;
    struct rayd_error err = {0};
    CHECK(rayd_exr_encode_aov(f, aov, mask, w, h, &buf, &len, &err) == RAYD_OK, "%s", err.message);
    CHECK(compression_of(buf, len) == (int)want,
          "%d x %d, repeats every %d rows, AOVs %#x: "
          "compression %d, not %d",
          w, h, every, mask, compression_of(buf, len), (int)want);
    CHECK(rayd_exr_decode_aov(buf, len, mask, w, h, back, aov_back, &err) == RAYD_OK, "%s",
          err.message);
    CHECK(!memcmp(f, back, n * 3 * sizeof *f), "%d x %d: the floats came back changed", w, h);
    rayd_free(buf);
    free(f), free(aov), free(back), free(aov_back);
}

/* PIZ where one float in 20 repeats its left neighbour's (a Whitted
 * frame's flat regions), else none (a path-traced frame's noise, which PIZ
 * cannot shrink but takes 4-9 times as long over). */
static void test_exr_compression(void) {
    float flat[5 * 4 * 3];
    for (size_t i = 0; i < sizeof flat / sizeof *flat; i++) flat[i] = 0.25f;
    void *buf = NULL;
    size_t len = 0;
    CHECK(rayd_exr_encode(flat, 5, 4, &buf, &len, NULL) == RAYD_OK, "flat");
    CHECK(compression_of(buf, len) == EXR_COMPRESSION_PIZ, "a flat image is not PIZ");
    rayd_free(buf);
    /* 21 wide: 20 neighbours a row, so a repeat in every row is 1 in 20 */
    check_compression(21, 70, 1, 0, EXR_COMPRESSION_PIZ);
    check_compression(21, 70, 2, 0, EXR_COMPRESSION_NONE);
    check_compression(21, 70, 1, RAYD_AOV_ALL, EXR_COMPRESSION_PIZ);
    check_compression(21, 70, 2, RAYD_AOV_ALL, EXR_COMPRESSION_NONE);
    check_compression(420, 300, 1000, 0, EXR_COMPRESSION_NONE); /* larger, more than a chunk */
    check_compression(1, 3, 1, 0, EXR_COMPRESSION_NONE);        /* no neighbours at all */
}

static void test_bad_sizes_refused(void) {
    float f[3] = {0};
    void *buf = NULL;
    size_t len = 0;
    struct rayd_error err = {0};
    CHECK(rayd_exr_encode(f, 0, 1, &buf, &len, &err) == RAYD_E_ARG, "EXR 0 wide refused");
    CHECK(rayd_png16_encode(f, 1, -1, -1, &buf, &len, &err) == RAYD_E_ARG,
          "PNG 16 -1 high refused");
    CHECK(buf == NULL, "nothing written");
}

int main(void) {
    RUN(test_png16_values);
    RUN(test_exr_bytes);
    RUN(test_exr_compression);
    RUN(test_bad_sizes_refused);
    CHECK_EXIT();
}
