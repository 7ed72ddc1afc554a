/* sums.c -- a sample range's per-pixel sums as bytes, and back.
 *
 * When one frame's samples are spread over many nodes, each node answers
 * the exact sums of its range (render.c explains why they are exact) and
 * the client adds them up.  The bytes must carry those sums without a
 * single bit lost, on any machine: each travels as its IEEE 754 double,
 * 64 bits little-endian, after a 24-byte header ("RAYDSUM1", width,
 * height, k0, k1 as 32-bit little-endian integers).  (A sum of several
 * samples is an exact multiple of 2^-22; the one-sample centre image is
 * not rounded at all, so the bits themselves are sent.)  Decoding checks
 * the header, the size and that every value is a sum a render could give:
 * finite, not negative, at most the cap times the samples.
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "base/bytes.h"
#include "base/error.h"
#include "render/render.h"

#define SUMS_MAGIC "RAYDSUM1"
#define SUMS_HEADER 24

/* Hosts that keep doubles little-endian (every one rayd runs on) copy the
 * values as they are: a 4096x4096 frame's 400 MB byte by byte took 1.1 s
 * of a worker. */
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__ &&                        \
    defined(__FLOAT_WORD_ORDER__) && __FLOAT_WORD_ORDER__ == __ORDER_LITTLE_ENDIAN__
#define SUMS_NATIVE 1
#else
#define SUMS_NATIVE 0
#endif

enum rayd_status rayd_sums_encode(int w, int h, int k0, int k1, const double *sums, void **buf,
                                  size_t *len, struct rayd_error *err) {
    size_t count = (size_t)w * (size_t)h * 3, n = SUMS_HEADER + count * 8;
    unsigned char *p = malloc(n);
    if (!p) return err_set(err, RAYD_E_NOMEM, NULL, "out of memory for %dx%d sums", w, h);
    memcpy(p, SUMS_MAGIC, 8);
    bytes_put_le32(p + 8, (uint32_t)w);
    bytes_put_le32(p + 12, (uint32_t)h);
    bytes_put_le32(p + 16, (uint32_t)k0);
    bytes_put_le32(p + 20, (uint32_t)k1);
    if (SUMS_NATIVE) memcpy(p + SUMS_HEADER, sums, count * 8);
    for (size_t i = 0; !SUMS_NATIVE && i < count; i++) {
        uint64_t v;
        memcpy(&v, &sums[i], 8);
        for (int b = 0; b < 8; b++)
            p[SUMS_HEADER + 8 * i + (size_t)b] = (unsigned char)(v >> (8 * b));
    }
    *buf = p;
    *len = n;
    return RAYD_OK;
}

/* The header's fields, checked. */
static enum rayd_status sums_header(const unsigned char *p, size_t len,
                                    struct rayd_sums_header *hdr, struct rayd_error *err) {
    if (len < SUMS_HEADER || memcmp(p, SUMS_MAGIC, 8))
        return err_set(err, RAYD_E_PARSE, NULL, "not rayd sums (no RAYDSUM1 header)");
    uint32_t w = bytes_le32(p + 8), h = bytes_le32(p + 12), k0 = bytes_le32(p + 16),
             k1 = bytes_le32(p + 20);
    if (w < 1 || h < 1 || w > 65536 || h > 65536)
        return err_set(err, RAYD_E_PARSE, NULL, "sums of a %ux%u image", w, h);
    if (k1 <= k0 || k1 > RENDER_SUM_SAMPLES)
        return err_set(err, RAYD_E_PARSE, NULL, "sums of samples %u..%u", k0, k1);
    if (len - SUMS_HEADER != (size_t)w * h * 24)
        return err_set(err, RAYD_E_PARSE, NULL, "%zu bytes of sums for a %ux%u image", len, w, h);
    *hdr = (struct rayd_sums_header){(int)w, (int)h, (int)k0, (int)k1};
    return RAYD_OK;
}

enum rayd_status rayd_sums_decode(const void *buf, size_t len, struct rayd_sums_header *hdr,
                                  double **sums, struct rayd_error *err) {
    const unsigned char *p = buf;
    enum rayd_status st = sums_header(p, len, hdr, err);
    if (st != RAYD_OK) return st;
    size_t count = (size_t)hdr->width * (size_t)hdr->height * 3;
    double *out = malloc(count * sizeof *out);
    if (!out) return err_set(err, RAYD_E_NOMEM, NULL, "out of memory for sums");
    /* the largest sum a render gives: every sample at the cap */
    double max = RENDER_SUM_CAP * (hdr->k1 - hdr->k0);
    if (SUMS_NATIVE) memcpy(out, p + SUMS_HEADER, count * 8);
    for (size_t i = 0; i < count; i++) {
        uint64_t v = 0;
        for (int b = 0; !SUMS_NATIVE && b < 8; b++)
            v |= (uint64_t)p[SUMS_HEADER + 8 * i + (size_t)b] << (8 * b);
        if (!SUMS_NATIVE) memcpy(&out[i], &v, 8);
        if (!(out[i] >= 0 && out[i] <= max)) { /* NaN fails too */
            free(out);
            return err_set(err, RAYD_E_PARSE, NULL, "sum %zu is out of range", i);
        }
    }
    *sums = out;
    return RAYD_OK;
}
