/* fuzz_envmap.c -- libFuzzer target: environment maps (a scene's
 * "environment": {"base64": ...}), the Radiance .hdr and OpenEXR decoders
 * behind them.  A client sends these bytes; a .hdr cut short once made the
 * decoder spin for ever, which -timeout catches. */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "rayd/rayd.h"

/* data in base64 at out (4 * ceil(n / 3) bytes). */
static size_t envmap_base64(const uint8_t *data, size_t n, char *out) {
    static const char a[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    size_t o = 0;
    for (size_t i = 0; i < n; i += 3) {
        uint32_t v = (uint32_t)data[i] << 16;
        if (i + 1 < n) v |= (uint32_t)data[i + 1] << 8;
        if (i + 2 < n) v |= data[i + 2];
        out[o++] = a[v >> 18 & 63];
        out[o++] = a[v >> 12 & 63];
        out[o++] = i + 1 < n ? a[v >> 6 & 63] : '=';
        out[o++] = i + 2 < n ? a[v & 63] : '=';
    }
    return o;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    static const char head[] =
        "{\"render\": {\"width\": 4, \"height\": 4, \"environment\": {\"base64\": \"";
    static const char tail[] = "\"}}}";
    char *json = malloc(sizeof head + 4 * (size / 3 + 1) + sizeof tail);
    if (!json) return 0;
    size_t n = sizeof head - 1;
    memcpy(json, head, n);
    n += envmap_base64(data, size, json + n);
    memcpy(json + n, tail, sizeof tail);
    n += sizeof tail - 1;
    rayd_scene *scene = NULL;
    struct rayd_error err;
    if (rayd_scene_parse(json, n, NULL, &scene, &err) == RAYD_OK) rayd_scene_free(scene);
    free(json);
    return 0;
}
