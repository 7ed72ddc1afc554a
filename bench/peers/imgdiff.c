/* imgdiff -- how far apart two same-sized PNGs are, for bench-peers.
 *
 *   imgdiff A.png B.png
 *
 * Prints "mean_abs_diff M" (mean |a - b| over every 8-bit channel, 0..255),
 * "max_abs_diff X", "pixels_differ_pct P" (percent of pixels with any
 * channel different) and "pixels_over_16_pct Q" (some channel off by more
 * than 16): evidence that rayd and POV-Ray rendered the same scene, not a
 * test (the two shade edges and highlights a little differently).
 */
#include <stdio.h>
#include <stdlib.h>

#include "rayd/rayd.h"

static rayd_image *load(const char *path) {
    rayd_image *img = NULL;
    struct rayd_error err;
    if (rayd_png_read_file(path, 0, &img, &err) != RAYD_OK)
        fprintf(stderr, "imgdiff: %s: %s\n", path, err.message);
    return img;
}

int main(int argc, char **argv) {
    if (argc != 3) {
        fprintf(stderr, "usage: imgdiff A.png B.png\n");
        return 2;
    }
    rayd_image *a = load(argv[1]), *b = load(argv[2]);
    int rc = 0;
    if (!a || !b || rayd_image_width(a) != rayd_image_width(b) ||
        rayd_image_height(a) != rayd_image_height(b)) {
        fprintf(stderr, "imgdiff: cannot compare %s and %s\n", argv[1], argv[2]);
        rc = 1;
    } else {
        const uint8_t *pa = rayd_image_pixels_const(a), *pb = rayd_image_pixels_const(b);
        size_t n = (size_t)rayd_image_width(a) * (size_t)rayd_image_height(a), over = 0, diff = 0;
        int max = 0;
        double sum = 0;
        for (size_t i = 0; i < n; i++) {
            int big = 0, any = 0;
            for (int c = 0; c < 3; c++) {
                int d = abs((int)pa[3 * i + c] - (int)pb[3 * i + c]);
                sum += d;
                big |= d > 16;
                any |= d > 0;
                if (d > max) max = d;
            }
            over += (size_t)big;
            diff += (size_t)any;
        }
        printf("mean_abs_diff %.3f\nmax_abs_diff %d\npixels_differ_pct %.2f\n"
               "pixels_over_16_pct %.3f\n",
               sum / (3.0 * (double)n), max, 100.0 * (double)diff / (double)n,
               100.0 * (double)over / (double)n);
    }
    rayd_image_free(a);
    rayd_image_free(b);
    return rc;
}
