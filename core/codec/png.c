/* png.c -- PNG in, 16-bit PNG out (both libpng), and PNG files; the only
 * file that includes libpng.
 *
 * The everyday 8-bit encoding is png_encode.c's (parallel bands of one
 * zlib stream); this file writes its buffer to a file.  Decoding uses
 * libpng's simplified png_image API, which converts any PNG to 8-bit RGB
 * for us, and refuses images over a pixel limit before allocating them.
 * The 16-bit encoder for linear images is at the bottom, and the 8-bit
 * RGBA one (a beauty with its alpha AOV as coverage), one band, libpng.
 * rayd_png_whole checks a PNG's chunks without decoding it.
 */
#include <math.h>
#include <png.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <isa-l.h>

#include "base/error.h"
#include "math/srgb_curve.h"
#include "render/image.h"

#define PNG_DEFAULT_MAX_PIXELS (1L << 26)

enum rayd_status rayd_png_encode(const rayd_image *img, int level, void **buf, size_t *len,
                                 struct rayd_error *err) {
    return rayd_png_encode_threads(img, level, 0, buf, len, err);
}

enum rayd_status rayd_png_write_file(const rayd_image *img, const char *path,
                                     struct rayd_error *err) {
    void *buf = NULL;
    size_t len = 0;
    enum rayd_status st = rayd_png_encode(img, -1, &buf, &len, err);
    if (st != RAYD_OK) return st;
    FILE *f = fopen(path, "wb");
    int ok = f && fwrite(buf, 1, len, f) == len;
    if (f && fclose(f) != 0) ok = 0;
    free(buf);
    if (!ok) return err_set(err, RAYD_E_IO, NULL, "cannot write %s", path);
    return RAYD_OK;
}

/* ---- image data past the pixels ---------------------------------------------
 *
 * libpng inflates a PNG's image data to the end of its zlib stream, also
 * past the last row, to find that end: a 16 x 16 image whose IDAT holds
 * 3 GB of zeros after its rows (3.9 MB compressed, deflate's 1032 to 1)
 * took 7 s of a parse thread.  Before libpng reads the image, its data is
 * inflated here into a small buffer and counted, stopping at what the
 * header's rows can take (and a margin): more is refused.  That inflate
 * is bounded by the pixels the caller allows, as libpng's own is, and
 * takes ISA-L's inflate, some three times zlib's speed, so a texture's
 * decode pays a fraction more, not twice its inflate. */

static uint32_t png_be32(const unsigned char *p) {
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}

/* The bytes the rows of an image of IHDR h inflate to: each row's filter
 * byte and pixels, over Adam7's seven passes when interlaced; 0 when the
 * header is not one (libpng then says why). */
static double png_rows_bytes(const unsigned char *h) {
    static const int bits[7] = {1, 4, 3, 1, 2, 4, 4}; /* channels by colour type (1, 5: none) */
    double w = png_be32(h), n = png_be32(h + 4);
    int depth = h[8], type = h[9] < 7 ? h[9] : 1;
    double px_bits = (double)depth * bits[type];
    if (!h[12]) return n * (1 + ceil(w * px_bits / 8));
    static const int x0[7] = {0, 4, 0, 2, 0, 1, 0}, dx[7] = {8, 8, 4, 4, 2, 2, 1};
    static const int y0[7] = {0, 0, 4, 0, 2, 0, 1}, dy[7] = {8, 8, 8, 4, 4, 2, 2};
    double all = 0;
    for (int p = 0; p < 7; p++) {
        double pw = ceil((w - x0[p]) / dx[p]), ph = ceil((n - y0[p]) / dy[p]);
        if (pw > 0 && ph > 0) all += ph * (1 + ceil(pw * px_bits / 8));
    }
    return all;
}

/* Whether the IDAT chunks of the PNG in b (len bytes) inflate to more
 * than limit bytes.  A stream that is cut short or corrupt is not: libpng
 * says what is wrong with it. */
static bool png_data_past(const unsigned char *b, size_t len, double limit) {
    struct inflate_state *z = malloc(sizeof *z); /* some 20 KB of tables */
    if (!z) return false;
    isal_inflate_init(z);
    z->crc_flag = ISAL_ZLIB;
    unsigned char out[16384];
    double made = 0;
    bool going = true;
    for (size_t at = 8; going && at + 12 <= len;) {
        uint32_t n = png_be32(b + at);
        if (n > len - at - 12) break;
        if (!memcmp(b + at + 4, "IDAT", 4)) {
            z->next_in = (uint8_t *)(uintptr_t)(b + at + 8); /* ISA-L's API is not const */
            z->avail_in = n;
            do { /* ISA-L takes its input ahead: on while it fills the buffer */
                z->next_out = out;
                z->avail_out = sizeof out;
                going = isal_inflate(z) == ISAL_DECOMP_OK && z->block_state != ISAL_BLOCK_FINISH;
                made += (double)(sizeof out - z->avail_out);
                going = going && made <= limit;
            } while (going && (z->avail_in > 0 || z->avail_out == 0));
        }
        at += 12 + (size_t)n;
    }
    free(z);
    return made > limit;
}

uint32_t rayd_crc32(const void *buf, size_t len) { return crc32_gzip_refl(0, buf, len); }

/* Every chunk carries a CRC-32 of its type and data (ISA-L's gzip CRC is
 * PNG's), so bytes changed in place, a file's size kept, fail here. */
int rayd_png_whole(const void *buf, size_t len, const char **why) {
    static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    const unsigned char *b = buf;
    *why = "no PNG signature";
    if (len < sizeof sig || memcmp(b, sig, sizeof sig)) return 0;
    for (size_t at = sizeof sig; at < len;) {
        *why = "a chunk runs past the end";
        if (len - at < 12 || png_be32(b + at) > len - at - 12) return 0;
        size_t n = png_be32(b + at);
        *why = "a chunk's CRC does not match its bytes";
        if (crc32_gzip_refl(0, b + at + 4, n + 4) != png_be32(b + at + 8 + n)) return 0;
        if (!memcmp(b + at + 4, "IEND", 4)) {
            *why = "bytes after IEND";
            return at + 12 + n == len;
        }
        at += 12 + n;
    }
    *why = "no IEND chunk";
    return 0;
}

enum rayd_status rayd_png_decode(const void *buf, size_t len, long max_pixels, rayd_image **out,
                                 struct rayd_error *err) {
    png_image pi;
    memset(&pi, 0, sizeof pi);
    pi.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_memory(&pi, buf, len))
        return err_set(err, RAYD_E_INVALID, NULL, "not a readable PNG: %s", pi.message);
    long limit = max_pixels > 0 ? max_pixels : PNG_DEFAULT_MAX_PIXELS;
    if ((double)pi.width * pi.height > (double)limit) {
        png_image_free(&pi);
        return err_set(err, RAYD_E_LIMIT, NULL, "PNG of %u x %u pixels is over the limit of %ld",
                       pi.width, pi.height, limit);
    }
    const unsigned char *b = buf; /* the IHDR is the first chunk: libpng checked it */
    double rows = png_rows_bytes(b + 16);
    if (rows > 0 && png_data_past(b, len, rows + rows / 8 + 65536)) {
        png_image_free(&pi);
        return err_set(err, RAYD_E_INVALID, NULL,
                       "PNG of %u x %u pixels whose image data goes on past its rows (more "
                       "than the %.0f bytes they take): the extra data is not read",
                       pi.width, pi.height, rows);
    }
    pi.format = PNG_FORMAT_RGB;
    rayd_image *img;
    enum rayd_status st = rayd_image_new((int)pi.width, (int)pi.height, &img, err);
    if (st != RAYD_OK) {
        png_image_free(&pi);
        return st;
    }
    if (!png_image_finish_read(&pi, NULL, img->px, 0, NULL)) {
        rayd_image_free(img);
        return err_set(err, RAYD_E_INVALID, NULL, "corrupt PNG: %s", pi.message);
    }
    *out = img;
    return RAYD_OK;
}

enum rayd_status rayd_png_read_file(const char *path, long max_pixels, rayd_image **out,
                                    struct rayd_error *err) {
    char *buf = NULL;
    size_t len = 0;
    enum rayd_status st = rayd_read_file(path, (size_t)1 << 30, &buf, &len, err);
    if (st == RAYD_OK) st = rayd_png_decode(buf, len, max_pixels, out, err);
    free(buf);
    return st;
}

/* ---- 16-bit PNG of linear float RGB ----------------------------------------
 *
 * For a deeper sRGB image than 8 bits without leaving PNG: each linear
 * value is sRGB-encoded by the formula (clamped to [0, 1]; NaN as 0) and
 * rounded to 16 bits, so v16 / 257 is within one step of the 8-bit image's
 * byte.  Written by libpng (one thread, its adaptive filters) with the
 * sRGB, gAMA and cHRM chunks the 8-bit PNG has; fixed settings, so the same
 * image gives the same bytes.  zlib level 4 by default: on a 1080p frame
 * 415 ms against 705 ms at level 6, for 3% more bytes.
 * Slower than the 8-bit band encoder (one thread, twice the bytes), which
 * is the everyday path; 16-bit is for the rarer export. */

struct png_mem {
    unsigned char *buf;
    size_t len, cap;
    int failed;
};

static void mem_write(png_structp png, png_bytep data, size_t n) {
    struct png_mem *m = png_get_io_ptr(png);
    if (m->len + n > m->cap) {
        size_t cap = m->cap ? m->cap * 2 : 65536;
        while (cap < m->len + n) cap *= 2;
        unsigned char *p = realloc(m->buf, cap);
        if (!p) {
            m->failed = 1;
            png_error(png, "out of memory");
        }
        m->buf = p;
        m->cap = cap;
    }
    memcpy(m->buf + m->len, data, n);
    m->len += n;
}

static void mem_flush(png_structp png) { (void)png; }

static uint16_t srgb16(float v) {
    double c = v;
    if (!(c > 0)) return 0; /* also NaN */
    if (c >= 1) return 65535;
    return (uint16_t)(srgb_encode(c) * 65535.0 + 0.5);
}

/* Row y of rgb as big-endian 16-bit sRGB into row. */
static void row16(const float *rgb, int w, int y, unsigned char *row) {
    const float *p = rgb + (size_t)y * (size_t)w * 3;
    for (size_t k = 0; k < (size_t)w * 3; k++) {
        uint16_t v = srgb16(p[k]);
        row[2 * k] = (unsigned char)(v >> 8);
        row[2 * k + 1] = (unsigned char)(v & 0xff);
    }
}

/* The libpng part, apart so that setjmp's longjmp leaves only m (through
 * its pointer) and row to look at. */
static int png16_write(png_structp png, png_infop info, const float *rgb, int w, int h, int level,
                       struct png_mem *m, unsigned char *row) {
    if (setjmp(png_jmpbuf(png))) return -1;
    png_set_write_fn(png, m, mem_write, mem_flush);
    png_set_compression_level(png, level < 0 ? 4 : level); /* 4: see above */
    png_set_IHDR(png, info, (png_uint_32)w, (png_uint_32)h, 16, PNG_COLOR_TYPE_RGB,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    png_write_info(png, info);
    for (int y = 0; y < h; y++) {
        row16(rgb, w, y, row);
        png_write_row(png, row);
    }
    png_write_end(png, NULL);
    return 0;
}

enum rayd_status rayd_png16_encode(const float *rgb, int w, int h, int level, void **buf,
                                   size_t *len, struct rayd_error *err) {
    if (w <= 0 || h <= 0) return err_set(err, RAYD_E_ARG, NULL, "a PNG needs w, h > 0");
    struct png_mem m = {0};
    unsigned char *row = malloc((size_t)w * 6);
    png_structp png = row ? png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL) : NULL;
    png_infop info = png ? png_create_info_struct(png) : NULL;
    int made = info != NULL; /* png_destroy_write_struct clears info */
    int rc = made ? png16_write(png, info, rgb, w, h, level, &m, row) : -1;
    png_destroy_write_struct(png ? &png : NULL, info ? &info : NULL);
    free(row);
    if (rc != 0 || m.failed || !made) {
        free(m.buf);
        return err_set(err, m.failed || !made ? RAYD_E_NOMEM : RAYD_E_INTERNAL, NULL,
                       "16-bit PNG encoding failed");
    }
    *buf = m.buf;
    *len = m.len;
    return RAYD_OK;
}

/* The RGBA image's libpng part, as png16_write's. */
static int rgba_write(png_structp png, png_infop info, const uint8_t *rgba, int w, int h,
                      struct png_mem *m) {
    if (setjmp(png_jmpbuf(png))) return -1;
    png_set_write_fn(png, m, mem_write, mem_flush);
    png_set_compression_level(png, 6);
    png_set_IHDR(png, info, (png_uint_32)w, (png_uint_32)h, 8, PNG_COLOR_TYPE_RGB_ALPHA,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    png_write_info(png, info);
    for (int y = 0; y < h; y++) png_write_row(png, rgba + (size_t)y * (size_t)w * 4);
    png_write_end(png, NULL);
    return 0;
}

enum rayd_status rayd_png_encode_rgba(const uint8_t *rgba, int w, int h, void **buf, size_t *len,
                                      struct rayd_error *err) {
    if (w <= 0 || h <= 0) return err_set(err, RAYD_E_ARG, NULL, "a PNG needs w, h > 0");
    struct png_mem m = {0};
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    int made = info != NULL;
    int rc = made ? rgba_write(png, info, rgba, w, h, &m) : -1;
    png_destroy_write_struct(png ? &png : NULL, info ? &info : NULL);
    if (rc != 0 || m.failed || !made) {
        free(m.buf);
        return err_set(err, m.failed || !made ? RAYD_E_NOMEM : RAYD_E_INTERNAL, NULL,
                       "RGBA PNG encoding failed");
    }
    *buf = m.buf;
    *len = m.len;
    return RAYD_OK;
}
