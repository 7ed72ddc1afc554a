/* pngcmp -- compares the pixels of two PNGs, for the shell tests.
 *
 *   pngcmp FULL.png PART.png [X Y]
 *
 * Exit 0 when PART's pixels equal the crop of FULL at (X, Y) (default 0 0,
 * and then the sizes must match too); 1 when they differ, with the first
 * differing pixel on stderr; 2 when a file cannot be read.  Decoded pixels
 * are compared, not bytes, so two encoders may differ.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rayd/rayd.h"

static rayd_image *load(const char *path) {
    rayd_image *img = NULL;
    struct rayd_error err;
    if (rayd_png_read_file(path, 0, &img, &err) != RAYD_OK)
        fprintf(stderr, "pngcmp: %s: %s\n", path, err.message);
    return img;
}

int main(int argc, char **argv) {
    if (argc != 3 && argc != 5) {
        fprintf(stderr, "usage: pngcmp FULL.png PART.png [X Y]\n");
        return 2;
    }
    rayd_image *a = load(argv[1]), *b = load(argv[2]);
    int x = argc == 5 ? atoi(argv[3]) : 0, y = argc == 5 ? atoi(argv[4]) : 0, rc = 0;
    if (!a || !b) {
        rc = 2;
    } else if ((argc == 3 && (rayd_image_width(a) != rayd_image_width(b) ||
                              rayd_image_height(a) != rayd_image_height(b))) ||
               x < 0 || y < 0 || x + rayd_image_width(b) > rayd_image_width(a) ||
               y + rayd_image_height(b) > rayd_image_height(a)) {
        fprintf(stderr, "pngcmp: %dx%d at (%d, %d) does not match %dx%d\n", rayd_image_width(b),
                rayd_image_height(b), x, y, rayd_image_width(a), rayd_image_height(a));
        rc = 1;
    } else {
        int aw = rayd_image_width(a), bw = rayd_image_width(b);
        for (int r = 0; r < rayd_image_height(b) && !rc; r++) {
            const uint8_t *pa = rayd_image_pixels_const(a) + ((size_t)(y + r) * aw + x) * 3;
            const uint8_t *pb = rayd_image_pixels_const(b) + (size_t)r * bw * 3;
            for (int c = 0; c < bw * 3 && !rc; c++) {
                if (pa[c] != pb[c]) {
                    fprintf(stderr, "pngcmp: pixel (%d, %d) of %s differs\n", c / 3, r, argv[2]);
                    rc = 1;
                }
            }
        }
    }
    rayd_image_free(a);
    rayd_image_free(b);
    return rc;
}
