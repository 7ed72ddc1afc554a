/* fuzz_sums.c -- libFuzzer target: a sample range's sums as they arrive
 * from a node (rayd-client --split-samples reads them from the network).
 * Accepted bytes must describe a sane range and encode back to the very
 * same bytes (the format has one spelling of each value); anything else
 * aborts. */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "rayd/rayd.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    struct rayd_sums_header h;
    double *sums = NULL;
    struct rayd_error err;
    if (rayd_sums_decode(data, size, &h, &sums, &err) != RAYD_OK) return 0;
    if (h.width < 1 || h.height < 1 || h.k0 < 0 || h.k1 <= h.k0) abort();
    void *back = NULL;
    size_t len = 0;
    if (rayd_sums_encode(h.width, h.height, h.k0, h.k1, sums, &back, &len, &err) != RAYD_OK ||
        len != size || memcmp(back, data, size))
        abort();
    rayd_free(back);
    rayd_free(sums);
    return 0;
}
