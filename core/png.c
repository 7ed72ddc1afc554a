/* png.c -- PNG in and out; the only file that includes libpng.
 *
 * Encoding uses libpng's classic API because it lets us choose the zlib
 * level and write straight into a growing memory buffer (the server sends
 * that buffer as the HTTP body; the CLI writes it to a file).  libpng
 * reports errors by longjmp, so everything that must be freed on that path
 * lives in a struct the handler can reach.  Decoding uses the simplified
 * png_image API, which converts any PNG to 8-bit RGB for us, and refuses
 * images over a pixel limit before allocating them.
 */
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "error.h"
#include "image.h"

#define PNG_DEFAULT_MAX_PIXELS (1L << 26)

struct membuf {
    unsigned char *data;
    size_t len, cap;
    int failed;
};

static void mem_write(png_structp png, png_bytep bytes, png_size_t n) {
    struct membuf *mb = png_get_io_ptr(png);
    if (mb->failed) return;
    if (mb->len + n > mb->cap) {
        size_t cap = mb->cap ? mb->cap : 4096;
        while (cap < mb->len + n) cap *= 2;
        unsigned char *p = realloc(mb->data, cap);
        if (!p) {
            mb->failed = 1;
            return;
        }
        mb->data = p;
        mb->cap = cap;
    }
    memcpy(mb->data + mb->len, bytes, n);
    mb->len += n;
}

static void mem_flush(png_structp png) { (void)png; }

static void png_err(png_structp png, png_const_charp msg) {
    (void)msg;
    png_longjmp(png, 1);
}

static void png_warn(png_structp png, png_const_charp msg) {
    (void)png;
    (void)msg;
}

static enum rayd_status encode(const rayd_image *img, int level, struct membuf *mb) {
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, png_err, png_warn);
    if (!png) return RAYD_E_NOMEM;
    png_infop info = png_create_info_struct(png);
    if (!info || setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, info ? &info : NULL);
        return RAYD_E_NOMEM;
    }
    png_set_write_fn(png, mb, mem_write, mem_flush);
    png_set_compression_level(png, level < 0 || level > 9 ? 6 : level);
    png_set_IHDR(png, info, (png_uint_32)img->w, (png_uint_32)img->h, 8, PNG_COLOR_TYPE_RGB,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    png_write_info(png, info);
    for (int y = 0; y < img->h; y++) png_write_row(png, img->px + (size_t)y * (size_t)img->w * 3);
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    return mb->failed ? RAYD_E_NOMEM : RAYD_OK;
}

enum rayd_status rayd_png_encode(const rayd_image *img, int level, void **buf, size_t *len,
                                 struct rayd_error *err) {
    struct membuf mb = {0};
    if (encode(img, level, &mb) != RAYD_OK) {
        free(mb.data);
        return err_set(err, RAYD_E_NOMEM, NULL, "out of memory encoding the PNG");
    }
    *buf = mb.data;
    *len = mb.len;
    return RAYD_OK;
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
