/* png.c -- PNG in (libpng) and PNG files; the only file that includes libpng.
 *
 * Encoding is png_encode.c's (parallel bands of one zlib stream); this file
 * writes its buffer to a file.  Decoding uses libpng's simplified png_image
 * API, which converts any PNG to 8-bit RGB for us, and refuses images over
 * a pixel limit before allocating them.
 */
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/error.h"
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
