/* fuzz_png.c -- libFuzzer target: PNG decoding (image textures and the
 * client's tile stitching read untrusted PNGs), and the chunk check of a
 * PNG read back from disk (rayd_png_whole). */
#include <stddef.h>
#include <stdint.h>

#include "rayd/rayd.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    rayd_image *img = NULL;
    struct rayd_error err;
    const char *why;
    (void)rayd_png_whole(data, size, &why);
    if (rayd_png_decode(data, size, 1 << 20, &img, &err) == RAYD_OK) rayd_image_free(img);
    return 0;
}
