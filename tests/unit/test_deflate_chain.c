/* test_deflate_chain.c -- deflate_chain.c: whole libdeflate streams, each
 * made to let the next follow, join into one stream that zlib inflates to
 * the pieces' bytes in order; at every libdeflate level (stored, fixed and
 * dynamic blocks, one block or many), for pieces from 1 byte to 1 MiB, and
 * whichever bit the last code ends on; anything but one well-formed stream
 * is refused and left unchanged. */
#include <libdeflate.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "check.h"
#include "format/deflate_chain.h"

/* Bytes of piece k: runs, gradients and noise in turns, so that the
 * compressor picks every kind of block somewhere. */
static void fill(unsigned char *p, size_t n, unsigned k) {
    uint32_t s = k * 2654435761u + 7;
    for (size_t i = 0; i < n; i++) {
        s = s * 1664525u + 1013904223u;
        switch ((i / 4096 + k) % 3) {
        case 0: p[i] = (unsigned char)(i / 100); break;
        case 1: p[i] = (unsigned char)(s >> 24); break;
        default: p[i] = (unsigned char)("rayd band "[i % 10] + (i / 3000) % 3); break;
        }
    }
}

/* Deflates pieces of the given sizes at level, chains all but the last,
 * joins them and checks that raw inflate gives the pieces back. */
static void join_and_inflate(int level, const size_t *sizes, int npieces) {
    struct libdeflate_compressor *c = libdeflate_alloc_compressor(level);
    size_t total = 0, zcap = 0;
    for (int i = 0; i < npieces; i++) {
        total += sizes[i];
        zcap += libdeflate_deflate_compress_bound(c, sizes[i]) + DEFLATE_CHAIN_EXTRA;
    }
    unsigned char *raw = malloc(total + 1), *z = malloc(zcap), *back = malloc(total + 1);
    size_t at = 0, zlen = 0;
    for (int i = 0; i < npieces; i++) {
        fill(raw + at, sizes[i], (unsigned)(i + level * 31));
        size_t cap = libdeflate_deflate_compress_bound(c, sizes[i]) + DEFLATE_CHAIN_EXTRA;
        size_t len = libdeflate_deflate_compress(c, raw + at, sizes[i], z + zlen, cap);
        CHECK(len > 0, "level %d piece %d: compress", level, i);
        if (i < npieces - 1) {
            size_t chained = deflate_chain(z + zlen, len, cap);
            CHECK(chained >= len + 4 && chained <= len + DEFLATE_CHAIN_EXTRA,
                  "level %d piece %d (%zu bytes): chained to %zu from %zu", level, i, sizes[i],
                  chained, len);
            len = chained;
        }
        at += sizes[i];
        zlen += len;
    }
    z_stream s;
    memset(&s, 0, sizeof s);
    int rc = inflateInit2(&s, -15);
    s.next_in = z;
    s.avail_in = (uInt)zlen;
    s.next_out = back;
    s.avail_out = (uInt)total + 1;
    if (rc == Z_OK) rc = inflate(&s, Z_FINISH);
    CHECK(rc == Z_STREAM_END && s.avail_in == 0 && s.total_out == total,
          "level %d, %d pieces: inflate %d, %u bytes left, %lu of %zu out", level, npieces, rc,
          s.avail_in, (unsigned long)s.total_out, total);
    CHECK(!memcmp(raw, back, total), "level %d: the bytes differ", level);
    inflateEnd(&s);
    libdeflate_free_compressor(c);
    free(raw);
    free(z);
    free(back);
}

static void test_every_level(void) {
    static const size_t sizes[] = {1, 2, 17, 300, 5000, 70000, 1 << 20, 999, 3};
    for (int level = 0; level <= 12; level++)
        join_and_inflate(level, sizes, (int)(sizeof sizes / sizeof *sizes));
}

/* Many small pieces end their last code on every bit of a byte. */
static void test_every_end_bit(void) {
    size_t sizes[64];
    for (int i = 0; i < 64; i++) sizes[i] = 1 + (size_t)i * 7;
    join_and_inflate(1, sizes, 64);
    join_and_inflate(6, sizes, 64);
}

/* Truncated, padded with junk or bit-flipped streams are refused and left
 * as they were; cap too small too. */
static void test_malformed(void) {
    struct libdeflate_compressor *c = libdeflate_alloc_compressor(6);
    unsigned char raw[20000], z[30000], copy[30000];
    fill(raw, sizeof raw, 5);
    size_t len = libdeflate_deflate_compress(c, raw, sizeof raw, z, sizeof z - 16);
    CHECK(len > 10, "compress");
    memcpy(copy, z, len);
    CHECK(deflate_chain(z, len - 1, sizeof z) == 0, "a truncated stream was chained");
    z[len] = 0x55;
    CHECK(deflate_chain(z, len + 1, sizeof z) == 0, "a stream with a byte after it was chained");
    CHECK(deflate_chain(z, len, len + 2) == 0, "chained without room for the stored block");
    CHECK(!memcmp(z, copy, len), "a refused stream was changed");
    unsigned char bad[3] = {0x07, 0, 0}; /* BTYPE 11, reserved */
    CHECK(deflate_chain(bad, 3, 16) == 0, "a reserved block type was chained");
    unsigned char stored[16] = {0x01, 0x01, 0x00, 0xfe, 0xff, 'x'}; /* final, LEN 1, "x" */
    /* ends on a byte boundary: the new block's 3 bits take a byte of their own */
    static const unsigned char want[11] = {0x00, 0x01, 0x00, 0xfe, 0xff, 'x', 0, 0, 0, 0xff, 0xff};
    CHECK(deflate_chain(stored, 6, 16) == 11 && !memcmp(stored, want, 11),
          "a stored final block: not chained as expected");
    unsigned char badlen[6] = {0x01, 0x01, 0x00, 0xfe, 0xfe, 'x'}; /* NLEN wrong */
    CHECK(deflate_chain(badlen, 6, 6) == 0, "a stored block with a bad NLEN was chained");
    /* Bit flips anywhere never read out of bounds (ASan watches) and a
     * stream that still walks is still a stream zlib reads. */
    for (size_t i = 0; i < len * 8; i += 13) {
        memcpy(z, copy, len);
        z[i / 8] ^= (unsigned char)(1u << (i % 8));
        (void)deflate_chain(z, len, sizeof z);
    }
    libdeflate_free_compressor(c);
}

int main(void) {
    RUN(test_every_level);
    RUN(test_every_end_bit);
    RUN(test_malformed);
    CHECK_EXIT();
}
