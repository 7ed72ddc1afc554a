/* fuzz_mesh.c -- libFuzzer target: the OBJ and PLY decoders and base64,
 * fed raw bytes (the first byte picks the decoder).  Each decoder runs in
 * order and on 3 threads, which must agree on the mesh or on the error
 * (abort otherwise, so the fuzzer and the replay both report it). */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "format/base64.h"
#include "format/mesh_io.h"

static bool same_array(const void *a, const void *b, size_t bytes) {
    return (!a && !b) || (a && b && !memcmp(a, b, bytes));
}

static bool same_mesh(const struct mesh_data *a, const struct mesh_data *b) {
    size_t v = a->nverts;
    return a->nverts == b->nverts && a->ntris == b->ntris &&
           same_array(a->pos, b->pos, v * 3 * sizeof(float)) &&
           same_array(a->normal, b->normal, v * 3 * sizeof(float)) &&
           same_array(a->uv, b->uv, v * 2 * sizeof(float)) &&
           same_array(a->index, b->index, (size_t)a->ntris * 3 * sizeof(uint32_t));
}

/* Decodes with 1 and 3 threads and compares; an OBJ also with its fast
 * path for plain lines off (mesh_obj_fast_path), on one thread. */
static void both(bool obj, const char *p, size_t n) {
    struct mesh_limits lim = {.max_vertices = 100000, .max_triangles = 100000};
    struct mesh_data m[3] = {{0}, {0}, {0}};
    struct rayd_error err[3];
    enum rayd_status st[3];
    int runs = obj ? 3 : 2;
    for (int k = 0; k < runs; k++) {
        memset(&err[k], 0, sizeof err[k]);
        if (k == 2) mesh_obj_fast_path(false);
        st[k] = obj ? mesh_parse_obj_threads(p, n, &lim, k == 1 ? 3 : 1, &m[k], &err[k])
                    : mesh_parse_ply_threads(p, n, &lim, k == 1 ? 3 : 1, &m[k], &err[k]);
        if (k == 2) mesh_obj_fast_path(true);
    }
    for (int k = 1; k < runs; k++) {
        if (st[0] != st[k]) abort();
        if (st[0] != RAYD_OK && strcmp(err[0].message, err[k].message)) abort();
        if (st[0] == RAYD_OK && !same_mesh(&m[0], &m[k])) abort();
    }
    for (int k = 0; k < runs; k++) mesh_data_free(&m[k]);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    if (size < 1) return 0;
    const char *p = (const char *)data + 1;
    size_t n = size - 1;
    switch (data[0] % 3) {
    case 0: both(true, p, n); break;
    case 1: both(false, p, n); break;
    default: {
        struct rayd_error err;
        unsigned char *out = NULL;
        size_t len;
        if (base64_decode(p, n, &out, &len, &err) == RAYD_OK) free(out);
    }
    }
    return 0;
}
