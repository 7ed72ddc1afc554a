/* test_png.c -- the band encoder (png_encode.c): what it writes, libpng reads
 * back to the same pixels, for odd sizes and many bands; the bytes are the
 * same for every thread count; every zlib level gives a valid stream; the
 * chunks and their CRCs are well formed; rayd_png_whole takes both
 * encoders' files and refuses one byte changed, cut or added. */
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "check.h"
#include "render/image.h"
#include "rayd/rayd.h"

/* A w x h image with smooth gradients, hard edges and noise, so every PNG
 * filter wins somewhere. */
static rayd_image *pattern(int w, int h, unsigned seed) {
    rayd_image *img = NULL;
    if (rayd_image_new(w, h, &img, NULL) != RAYD_OK) return NULL;
    uint32_t s = seed * 2654435761u + 1;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            uint8_t *p = img->px + ((size_t)y * (size_t)w + (size_t)x) * 3;
            s = s * 1664525u + 1013904223u;
            p[0] = (uint8_t)(x * 255 / (w > 1 ? w - 1 : 1));
            p[1] = (uint8_t)((x / 7 + y / 5) % 2 ? 200 : 30);
            p[2] = (uint8_t)(y % 64 < 32 ? (s >> 24) : (uint32_t)(x + y));
        }
    return img;
}

/* Encodes on threads threads at level and checks libpng reads back img. */
static void *roundtrip(const rayd_image *img, int level, int threads, size_t *len) {
    void *buf = NULL;
    struct rayd_error err;
    enum rayd_status st = rayd_png_encode_threads(img, level, threads, &buf, len, &err);
    CHECK(st == RAYD_OK, "%dx%d level %d threads %d: %s", img->w, img->h, level, threads,
          err.message);
    if (st != RAYD_OK) return NULL;
    rayd_image *back = NULL;
    st = rayd_png_decode(buf, *len, 0, &back, &err);
    CHECK(st == RAYD_OK, "%dx%d level %d threads %d: libpng: %s", img->w, img->h, level, threads,
          err.message);
    if (st == RAYD_OK) {
        CHECK(back->w == img->w && back->h == img->h, "size %dx%d", back->w, back->h);
        CHECK(!memcmp(back->px, img->px, (size_t)img->w * (size_t)img->h * 3),
              "%dx%d level %d threads %d: pixels differ", img->w, img->h, level, threads);
        rayd_image_free(back);
    }
    return buf;
}

static void test_odd_sizes_every_thread_count(void) {
    static const int sizes[][2] = {{1, 1},    {1, 10000},   {4097, 3}, {10000, 1},
                                   {3, 4097}, {1000, 1000}, {641, 479}};
    static const int threads[] = {1, 2, 3, 7, 64, 0};
    for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++) {
        rayd_image *img = pattern(sizes[s][0], sizes[s][1], (unsigned)s);
        CHECK(img != NULL, "no image");
        if (!img) continue;
        size_t len0 = 0;
        void *first = roundtrip(img, -1, 1, &len0);
        for (size_t t = 1; t < sizeof threads / sizeof threads[0]; t++) {
            size_t len = 0;
            void *buf = roundtrip(img, -1, threads[t], &len);
            CHECK(first && buf && len == len0 && !memcmp(buf, first, len),
                  "%dx%d: %d threads give other bytes than 1", img->w, img->h, threads[t]);
            rayd_free(buf);
        }
        rayd_free(first);
        rayd_image_free(img);
    }
}

static void test_every_level(void) {
    rayd_image *img = pattern(700, 900, 7); /* 8 bands */
    CHECK(img != NULL, "no image");
    if (!img) return;
    size_t prev = 0;
    for (int level = -1; level <= 9; level++) {
        size_t len = 0;
        void *buf = roundtrip(img, level, 2, &len);
        if (level == 0) CHECK(len > (size_t)700 * 900 * 3, "level 0 stores: %zu bytes", len);
        if (level == 9) CHECK(len <= prev, "level 9 (%zu) larger than level 8 (%zu)", len, prev);
        prev = len;
        rayd_free(buf);
    }
    rayd_image_free(img);
}

/* A big image stored (level 0): its deflated bands fill more than one of
 * the encoder's huge-page blocks, and come back whole on every thread
 * count, the same bytes. */
static void test_big_image_many_blocks(void) {
    rayd_image *img = pattern(1200, 1000, 11); /* 3.6 MB of rows */
    CHECK(img != NULL, "no image");
    if (!img) return;
    size_t len0 = 0;
    void *first = roundtrip(img, 0, 1, &len0);
    CHECK(len0 > (size_t)3 << 20, "level 0 of 3.6 MB of rows: %zu bytes", len0);
    for (int threads = 2; threads <= 7; threads += 5) {
        size_t len = 0;
        void *buf = roundtrip(img, 0, threads, &len);
        CHECK(first && buf && len == len0 && !memcmp(buf, first, len),
              "1200x1000 level 0: %d threads give other bytes than 1", threads);
        rayd_free(buf);
    }
    rayd_free(first);
    rayd_image_free(img);
}

static uint32_t be32(const unsigned char *p) {
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}

/* Walks the chunks: signature, IHDR first, IEND last, every CRC right, the
 * IDATs together one zlib stream that inflates to the filtered rows. */
static void test_chunks_well_formed(void) {
    rayd_image *img = pattern(1500, 400, 3);
    size_t len = 0;
    unsigned char *buf = NULL;
    if (!img || rayd_png_encode_threads(img, -1, 2, (void **)&buf, &len, NULL) != RAYD_OK) {
        CHECK(0, "encode failed");
        rayd_image_free(img);
        return;
    }
    static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    CHECK(len > 8 && !memcmp(buf, sig, 8), "no PNG signature");
    size_t at = 8, zlen = 0;
    unsigned char *z = malloc(len);
    char first[5] = "", last[5] = "";
    while (z && at + 12 <= len) {
        uint32_t n = be32(buf + at);
        CHECK(at + 12 + n <= len, "chunk at %zu runs past the end", at);
        if (at + 12 + n > len) break;
        uint32_t crc = (uint32_t)crc32(0, buf + at + 4, n + 4);
        CHECK(crc == be32(buf + at + 8 + n), "bad CRC of chunk %.4s", (const char *)buf + at + 4);
        if (!first[0]) memcpy(first, buf + at + 4, 4);
        memcpy(last, buf + at + 4, 4);
        if (!memcmp(buf + at + 4, "IDAT", 4)) {
            memcpy(z + zlen, buf + at + 8, n);
            zlen += n;
        }
        at += 12 + n;
    }
    CHECK(at == len, "trailing bytes after IEND");
    CHECK(!strcmp(first, "IHDR") && !strcmp(last, "IEND"), "first %s, last %s", first, last);
    size_t raw = (size_t)400 * (1500 * 3 + 1);
    unsigned char *out = malloc(raw + 1);
    uLongf outlen = (uLongf)raw + 1;
    int rc = z && out ? uncompress(out, &outlen, z, (uLong)zlen) : Z_MEM_ERROR;
    CHECK(rc == Z_OK && outlen == raw, "zlib: %d, %lu bytes of %zu", rc, (unsigned long)outlen,
          raw);
    free(out);
    free(z);
    rayd_free(buf);
    rayd_image_free(img);
}

/* The IDAT chunks of PNG buf: their data into at[], their sizes into n[];
 * how many (at most max). */
static int idats(const unsigned char *buf, size_t len, const unsigned char **at, uint32_t *n,
                 int max) {
    int k = 0;
    for (size_t p = 8; p + 12 <= len && k < max; p += 12 + be32(buf + p))
        if (!memcmp(buf + p + 4, "IDAT", 4)) at[k] = buf + p + 8, n[k++] = be32(buf + p);
    return k;
}

/* The default deflates every fourth band (3, 7, ...) with ISA-L, the rest
 * with libdeflate: an IDAT a band, the fourth is the very bytes
 * --png-level 1 (ISA-L alone) writes for it, the first three are not. */
static void test_default_blends_isal(void) {
    rayd_image *img = pattern(1500, 400, 3); /* bands of 58 rows: 7 */
    unsigned char *dflt = NULL, *isal = NULL;
    size_t dlen = 0, ilen = 0;
    bool ok = img && rayd_png_encode_threads(img, -1, 2, (void **)&dflt, &dlen, NULL) == RAYD_OK &&
              rayd_png_encode_threads(img, 1, 2, (void **)&isal, &ilen, NULL) == RAYD_OK;
    CHECK(ok, "encode failed");
    const unsigned char *d[16], *i[16];
    uint32_t dn[16], in[16];
    int nd = ok ? idats(dflt, dlen, d, dn, 16) : 0, ni = ok ? idats(isal, ilen, i, in, 16) : 0;
    CHECK(nd == 7 && ni == 7, "%d and %d IDATs, not a band each", nd, ni);
    if (nd == 7 && ni == 7) {
        CHECK(dn[3] == in[3] && !memcmp(d[3], i[3], dn[3]), "band 3 is not ISA-L's");
        for (int b = 0; b < 3; b++)
            CHECK(dn[b] != in[b] || memcmp(d[b], i[b], dn[b]), "band %d is ISA-L's", b);
    }
    rayd_free(dflt);
    rayd_free(isal);
    rayd_image_free(img);
}

/* ---- image data past the rows (png.c: png_data_past) -------------------------- */

static void put32(unsigned char *p, uint32_t v) {
    p[0] = (unsigned char)(v >> 24), p[1] = (unsigned char)(v >> 16);
    p[2] = (unsigned char)(v >> 8), p[3] = (unsigned char)v;
}

/* Appends chunk type with n bytes of data at *end, its CRC made. */
static void chunk(unsigned char *out, size_t *end, const char *type, const void *data, size_t n) {
    unsigned char *c = out + *end;
    put32(c, (uint32_t)n);
    memcpy(c + 4, type, 4);
    if (n) memcpy(c + 8, data, n);
    put32(c + 8 + n, (uint32_t)crc32(0, c + 4, (uInt)(n + 4)));
    *end += 12 + n;
}

/* The bytes the rows of a w x h image of bits a pixel inflate to, pixel by
 * pixel over Adam7's passes (png.c counts them pass by pass). */
static size_t rows_counted(int w, int h, int bits, bool interlaced) {
    static const int x0[7] = {0, 4, 0, 2, 0, 1, 0}, dx[7] = {8, 8, 4, 4, 2, 2, 1};
    static const int y0[7] = {0, 0, 4, 0, 2, 0, 1}, dy[7] = {8, 8, 8, 4, 4, 2, 2};
    size_t all = 0;
    for (int p = 0; p < (interlaced ? 7 : 1); p++) {
        int pw = 0, ph = 0;
        for (int x = interlaced ? x0[p] : 0; x < w; x += interlaced ? dx[p] : 1) pw++;
        for (int y = interlaced ? y0[p] : 0; y < h; y += interlaced ? dy[p] : 1) ph++;
        if (pw && ph) all += (size_t)ph * (1 + ((size_t)pw * (size_t)bits + 7) / 8);
    }
    return all;
}

/* A PNG whose IDAT inflates to its rows of zeros and extra zero bytes
 * after them: the decode's message ("" when it decodes). */
static void decode_with_extra(int w, int h, int depth, int type, bool interlaced, size_t extra,
                              char msg[256]) {
    static const int channels[7] = {1, 0, 3, 1, 2, 0, 4};
    size_t raw = rows_counted(w, h, depth * channels[type], interlaced) + extra;
    unsigned char *zeros = calloc(raw, 1);
    uLong zcap = compressBound((uLong)raw);
    unsigned char *out = malloc(zcap + 200), *z = malloc(zcap);
    uLongf zn = zcap;
    compress(z, &zn, zeros, (uLong)raw);
    size_t end = 8;
    memcpy(out, "\x89PNG\r\n\x1a\n", 8);
    unsigned char ihdr[13] = {0};
    put32(ihdr, (uint32_t)w), put32(ihdr + 4, (uint32_t)h);
    ihdr[8] = (unsigned char)depth, ihdr[9] = (unsigned char)type, ihdr[12] = interlaced;
    chunk(out, &end, "IHDR", ihdr, 13);
    unsigned char plte[48] = {0};
    if (type == 3) chunk(out, &end, "PLTE", plte, 48);
    chunk(out, &end, "IDAT", z, zn);
    chunk(out, &end, "IEND", NULL, 0);
    rayd_image *img = NULL;
    struct rayd_error err = {0};
    msg[0] = 0;
    if (rayd_png_decode(out, end, 0, &img, &err) != RAYD_OK) snprintf(msg, 256, "%s", err.message);
    rayd_image_free(img);
    free(zeros), free(out), free(z);
}

static void test_data_past_rows_refused(void) {
    /* the rows' bytes counted exactly for every colour type, depth and
     * Adam7 pass: data up to the margin (an eighth and 64 KB) decodes as
     * libpng takes it, a byte more is refused before libpng inflates it */
    static const int kinds[][2] = {{1, 0}, {16, 0}, {8, 2}, {4, 3}, {8, 4}, {16, 6}};
    static const int sizes[][2] = {{1, 1}, {3, 5}, {17, 9}, {33, 64}, {300, 7}};
    char msg[256];
    for (int k = 0; k < 6; k++)
        for (int z = 0; z < 5; z++)
            for (int il = 0; il < 2; il++) {
                int w = sizes[z][0], h = sizes[z][1], d = kinds[k][0], t = kinds[k][1];
                static const int channels[7] = {1, 0, 3, 1, 2, 0, 4};
                size_t rows = rows_counted(w, h, d * channels[t], il);
                size_t margin = rows / 8 + 65536;
                decode_with_extra(w, h, d, t, il, 0, msg);
                CHECK(!msg[0], "%dx%d depth %d type %d interlace %d: %s", w, h, d, t, il, msg);
                decode_with_extra(w, h, d, t, il, margin, msg);
                CHECK(!strstr(msg, "past its rows"),
                      "%dx%d depth %d type %d interlace %d refused at the margin: %s", w, h, d, t,
                      il, msg);
                decode_with_extra(w, h, d, t, il, margin + 1, msg);
                CHECK(strstr(msg, "goes on past its rows"),
                      "%dx%d depth %d type %d interlace %d: a byte past the margin taken: '%s'", w,
                      h, d, t, il, msg);
            }
    /* the attack's size: 16 x 16 RGB with 200 MB of zeros after its rows */
    decode_with_extra(16, 16, 8, 2, false, (size_t)200 << 20, msg);
    CHECK(strstr(msg, "PNG of 16 x 16 pixels whose image data goes on past its rows (more than "
                      "the 784 bytes they take)"),
          "got '%s'", msg);
}

/* rayd_png_whole on the band encoder's PNG and libpng's 16-bit one, each
 * whole, then with every 997th byte flipped in turn, cut short, or
 * followed by one more byte. */
static void check_whole(const unsigned char *png, size_t len, const char *what) {
    const char *why = "";
    CHECK(rayd_png_whole(png, len, &why), "%s: %s", what, why);
    unsigned char *b = malloc(len + 1);
    if (!b) return;
    int passed = 0, tried = 0;
    for (size_t i = 0; i < len; i += 997, tried++) {
        memcpy(b, png, len);
        b[i] ^= 0x04;
        passed += rayd_png_whole(b, len, &why);
    }
    CHECK(passed == 0, "%s: %d of %d one-byte changes pass", what, passed, tried);
    memcpy(b, png, len);
    b[len] = 0;
    CHECK(!rayd_png_whole(b, len - 1, &why) && strstr(why, "past the end"), "%s cut: %s", what,
          why);
    CHECK(!rayd_png_whole(b, len + 1, &why) && strstr(why, "after IEND"), "%s + 1: %s", what, why);
    b[len / 2] ^= 0x80;
    CHECK(!rayd_png_whole(b, len, &why) && strstr(why, "CRC"), "%s flipped: %s", what, why);
    CHECK(!rayd_png_whole("GIF89a", 6, &why), "a GIF taken for a PNG");
    free(b);
}

/* rayd_crc32 is the CRC-32 of gzip and zlib: the standard check value
 * of "123456789", 0 for nothing, and a changed byte changes it. */
static void test_crc32(void) {
    CHECK(rayd_crc32("123456789", 9) == 0xCBF43926u, "CRC-32 of 123456789: %08x",
          (unsigned)rayd_crc32("123456789", 9));
    CHECK(rayd_crc32("", 0) == 0, "CRC-32 of nothing: %08x", (unsigned)rayd_crc32("", 0));
    CHECK(rayd_crc32("123456788", 9) != rayd_crc32("123456789", 9), "one byte changed, same CRC");
}

static void test_whole_and_damaged(void) {
    rayd_image *img = pattern(300, 200, 5);
    size_t len = 0;
    void *buf = img ? roundtrip(img, -1, 2, &len) : NULL;
    if (buf) check_whole(buf, len, "band encoder");
    rayd_free(buf);
    float *rgb = malloc(sizeof(float) * 3 * 64 * 48);
    for (int i = 0; rgb && i < 3 * 64 * 48; i++) rgb[i] = (float)(i % 97) / 96.0f;
    buf = NULL;
    if (rgb && rayd_png16_encode(rgb, 64, 48, 6, &buf, &len, NULL) == RAYD_OK)
        check_whole(buf, len, "libpng 16-bit");
    else
        CHECK(0, "rayd_png16_encode failed");
    rayd_free(buf);
    free(rgb);
    rayd_image_free(img);
}

int main(void) {
    RUN(test_odd_sizes_every_thread_count);
    RUN(test_every_level);
    RUN(test_big_image_many_blocks);
    RUN(test_chunks_well_formed);
    RUN(test_default_blends_isal);
    RUN(test_data_past_rows_refused);
    RUN(test_whole_and_damaged);
    RUN(test_crc32);
    CHECK_EXIT();
}
