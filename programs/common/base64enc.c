/* base64enc.c -- standard base64, for the bytes rayd-client embeds.
 *
 * A scene carries a mesh, texture or environment file as base64
 * (programs/client/scenefile.c, thumbnails.c), and a .gltf its buffers and
 * images as data: URIs (gltf_bundle.c); all of them encode here.  The core
 * only decodes (core/io/base64.c, inside the scene loader, not in its
 * public API), so the programs keep their own encoder: RFC 4648's
 * alphabet with '=' padding, what the core reads.
 */
#include "common/common.h"

#include <stdint.h>
#include <stdlib.h>

char *base64enc(const unsigned char *data, size_t len) {
    static const char tab[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    char *out = malloc((len + 2) / 3 * 4 + 1);
    if (!out) return NULL;
    size_t o = 0, i = 0;
    for (; i + 2 < len; i += 3) {
        uint32_t v = (uint32_t)data[i] << 16 | (uint32_t)data[i + 1] << 8 | data[i + 2];
        out[o++] = tab[v >> 18];
        out[o++] = tab[(v >> 12) & 63];
        out[o++] = tab[(v >> 6) & 63];
        out[o++] = tab[v & 63];
    }
    if (i < len) {
        uint32_t v = (uint32_t)data[i] << 16 | (i + 1 < len ? (uint32_t)data[i + 1] << 8 : 0);
        out[o++] = tab[v >> 18];
        out[o++] = tab[(v >> 12) & 63];
        out[o++] = i + 1 < len ? tab[(v >> 6) & 63] : '=';
        out[o++] = '=';
    }
    out[o] = '\0';
    return out;
}
