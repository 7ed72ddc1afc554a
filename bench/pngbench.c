/* pngbench.c -- PNG encoding: libpng (one thread, as rayd encoded before,
 * adaptive filters) against rayd's band encoder at each deflate level and
 * thread count (-1: the default, libdeflate level 1 with ISA-L every
 * fourth band; 1: ISA-L).  Prints the median time of RUNS
 * encodes and the size.
 *
 *   build/bench/pngbench IMAGE.png... (`make bench` runs it on renders)
 */
#include <png.h>
#include <rayd/rayd.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define RUNS 7

static double now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

static int cmp(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

struct mem {
    size_t len;
};
static void mem_write(png_structp p, png_bytep b, png_size_t n) {
    (void)b;
    ((struct mem *)png_get_io_ptr(p))->len += n;
}
static void mem_flush(png_structp p) { (void)p; }

/* libpng's classic writer at level 6 with its default (adaptive) filters:
 * the bytes counted, not kept. */
static size_t libpng_encode(rayd_image *img) {
    struct mem m = {0};
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png_create_info_struct(png);
    if (setjmp(png_jmpbuf(png))) return 0;
    png_set_write_fn(png, &m, mem_write, mem_flush);
    png_set_compression_level(png, 6);
    int w = rayd_image_width(img), h = rayd_image_height(img);
    png_set_IHDR(png, info, (png_uint_32)w, (png_uint_32)h, 8, PNG_COLOR_TYPE_RGB,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    const uint8_t *px = rayd_image_pixels_const(img);
    for (int y = 0; y < h; y++) png_write_row(png, px + (size_t)y * (size_t)w * 3);
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    return m.len;
}

static double median_ms(rayd_image *img, int level, int threads, size_t *size) {
    double t[RUNS];
    for (int r = 0; r < RUNS; r++) {
        double t0 = now();
        if (level < -1) {
            *size = libpng_encode(img);
        } else {
            void *buf = NULL;
            rayd_png_encode_threads(img, level, threads, &buf, size, NULL);
            rayd_free(buf);
        }
        t[r] = (now() - t0) * 1e3;
    }
    qsort(t, RUNS, sizeof t[0], cmp);
    return t[RUNS / 2];
}

int main(int argc, char **argv) {
    for (int a = 1; a < argc; a++) {
        rayd_image *img;
        struct rayd_error err;
        if (rayd_png_read_file(argv[a], 0, &img, &err) != RAYD_OK) {
            fprintf(stderr, "pngbench: %s: %s\n", argv[a], err.message);
            return 1;
        }
        size_t base;
        double tb = median_ms(img, -2, 1, &base);
        printf("%s (%dx%d): libpng level 6, 1 thread: %.1f ms, %zu bytes\n", argv[a],
               rayd_image_width(img), rayd_image_height(img), tb, base);
        static const int levels[] = {-1, 1, 2, 6}; /* -1: the default (libdeflate 1), 1: ISA-L */
        for (size_t l = 0; l < sizeof levels / sizeof levels[0]; l++)
            for (int th = 1; th <= 2; th++) {
                size_t n;
                double t = median_ms(img, levels[l], th, &n);
                printf("  bands level %2d, %d thread%s: %6.1f ms (%.2fx libpng), %zu "
                       "bytes (%+.1f%%)\n",
                       levels[l], th, th > 1 ? "s" : " ", t, tb / t, n,
                       100.0 * ((double)n - (double)base) / (double)base);
            }
        rayd_image_free(img);
    }
    return 0;
}
