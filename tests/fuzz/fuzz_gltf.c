/* fuzz_gltf.c -- libFuzzer target: the glTF 2.0 reader (.glb or .gltf
 * bytes), with small limits so that no input may allocate much, and an
 * opener that answers every external buffer file with the same 96 bytes
 * (an odd-sized buffer of positions and indices), so the paths through
 * file buffers are reached too.  A mesh that comes back must hold indices
 * below its vertex count and finite positions (abort otherwise, so the
 * fuzzer and the replay both report it). */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "io/mesh_gltf.h"

static enum rayd_status open_any(void *ctx, const char *name, char **data, size_t *len,
                                 struct rayd_error *err) {
    (void)ctx;
    (void)err;
    if (!strcmp(name, "missing.bin")) return RAYD_E_INVALID;
    *data = malloc(96);
    if (!*data) return RAYD_E_NOMEM;
    for (int i = 0; i < 96; i++) (*data)[i] = (char)(i % 4 == 3 ? 0x3f : i % 5);
    *len = 96;
    return RAYD_OK;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    struct mesh_limits lim = {100000, 100000};
    struct mesh_gltf_opts o = {.max_bytes = 1 << 20, .max_nesting = 64, .open = open_any};
    struct mesh_data m = {0};
    struct rayd_error err;
    if (mesh_parse_gltf(data, size, &lim, &o, &m, &err) != RAYD_OK) return 0;
    if (m.ntris == 0) abort();
    for (size_t i = 0; i < (size_t)m.ntris * 3; i++)
        if (m.index[i] >= m.nverts) abort();
    for (size_t i = 0; i < (size_t)m.nverts * 3; i++)
        if (!isfinite(m.pos[i])) abort();
    mesh_data_free(&m);
    return 0;
}
