/* fuzz_mesh.c -- libFuzzer target: the OBJ and PLY decoders and base64,
 * fed raw bytes (the first byte picks the decoder). */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

#include "io/base64.h"
#include "io/mesh_io.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    if (size < 1) return 0;
    struct mesh_limits lim = {100000, 100000};
    struct mesh_data m = {0};
    struct rayd_error err;
    const char *p = (const char *)data + 1;
    size_t n = size - 1;
    switch (data[0] % 3) {
    case 0:
        if (mesh_parse_obj(p, n, &lim, &m, &err) == RAYD_OK) mesh_data_free(&m);
        break;
    case 1:
        if (mesh_parse_ply(p, n, &lim, &m, &err) == RAYD_OK) mesh_data_free(&m);
        break;
    default: {
        unsigned char *out = NULL;
        size_t len;
        if (base64_decode(p, n, &out, &len, &err) == RAYD_OK) free(out);
    }
    }
    return 0;
}
