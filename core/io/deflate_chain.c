/* deflate_chain.c -- a whole raw deflate stream made into one that another
 * stream may follow.
 *
 * The PNG encoder deflates bands of rows on every thread and joins them into
 * the one zlib stream a PNG holds.  A band that is not the last must not end
 * with a final block, and must end on a byte boundary so that the next
 * band's bytes can simply follow.  zlib and ISA-L can be told to end so (a
 * sync flush); libdeflate, which deflates to zlib's sizes three times as
 * fast, cannot: it always writes a whole stream, whose last block is marked
 * final and ends wherever its end-of-block code ends.
 *
 * So the stream is walked as a decoder would read it, but without producing
 * a byte: every block header is read and every Huffman code decoded (table
 * lookups on the next 15 bits, extra bits skipped), to learn where the final
 * block's header is and where its end-of-block code ends.  The final bit is
 * then cleared and an empty stored block appended: three zero bits, zeros to
 * the byte boundary, LEN 0 and NLEN 0xFFFF -- the bytes of zlib's sync
 * flush.  The walk costs about a tenth of the deflate (png_encode.c).
 *
 * The input is our encoder's own output, but the walk checks every bound
 * and every code as a decoder must, and refuses anything that is not one
 * well-formed stream, so a bug elsewhere shows as an error, never as a
 * read out of bounds or a corrupt PNG.
 */
#include "io/deflate_chain.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define DC_MAXBITS 15 /* the longest Huffman code deflate allows */

/* A bit reader over buf[0..len), least significant bit first. */
struct dc_bits {
    const unsigned char *p;
    size_t len; /* bytes */
    size_t pos; /* bits read */
};

/* At least 57 bits from pos on (zeros past the end: a walk that reads them
 * is caught by the callers' position checks). */
static inline uint64_t dc_peek(const struct dc_bits *b) {
    size_t i = b->pos >> 3;
    uint64_t v = 0;
    if (i + 8 <= b->len) {
        memcpy(&v, b->p + i, 8);
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
        v = __builtin_bswap64(v);
#endif
    } else {
        for (size_t k = 0; i + k < b->len; k++) v |= (uint64_t)b->p[i + k] << (8 * k);
    }
    return v >> (b->pos & 7);
}

static unsigned dc_take(struct dc_bits *b, int n) {
    unsigned v = (unsigned)(dc_peek(b) & ((1u << n) - 1));
    b->pos += (size_t)n;
    return v;
}

/* A decoding table: indexed by the next bits bits of the stream, an entry
 * is symbol << 4 | code length, or 0 where no code begins so. */
struct dc_huff {
    uint16_t *t;
    int bits;
};

/* Canonical Huffman codes of lens[0..n) into h (room for 1 << DC_MAXBITS
 * entries); -1 for an over-subscribed set of lengths.  An incomplete set
 * is allowed (RFC 1951 allows one distance code), its gaps left 0. */
static int dc_build(struct dc_huff *h, const uint8_t *lens, int n) {
    int count[DC_MAXBITS + 1] = {0}, maxl = 0;
    for (int s = 0; s < n; s++) {
        count[lens[s]]++;
        if (lens[s] > maxl) maxl = lens[s];
    }
    int left = 1;
    for (int l = 1; l <= DC_MAXBITS; l++) {
        left = 2 * left - count[l];
        if (left < 0) return -1;
    }
    h->bits = maxl > 0 ? maxl : 1;
    size_t size = (size_t)1 << h->bits;
    memset(h->t, 0, size * sizeof *h->t);
    unsigned next[DC_MAXBITS + 2], code = 0;
    count[0] = 0;
    for (int l = 1; l <= DC_MAXBITS; l++) next[l] = code = (code + (unsigned)count[l - 1]) << 1;
    for (int s = 0; s < n; s++) {
        int l = lens[s];
        if (!l) continue;
        unsigned c = next[l]++, r = 0;
        for (int k = 0; k < l; k++) r |= ((c >> k) & 1u) << (l - 1 - k);
        for (size_t e = r; e < size; e += (size_t)1 << l) h->t[e] = (uint16_t)(s << 4 | l);
    }
    return 0;
}

static inline int dc_decode(struct dc_bits *b, const struct dc_huff *h) {
    uint16_t e = h->t[dc_peek(b) & (((uint64_t)1 << h->bits) - 1)];
    if (!e) return -1;
    b->pos += e & 15u;
    return e >> 4;
}

/* The codes of one Huffman block, up to and through its end-of-block. */
static int dc_codes(struct dc_bits *b, const struct dc_huff *lit, const struct dc_huff *dist) {
    static const uint8_t len_extra[29] = {0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2,
                                          2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0};
    static const uint8_t dist_extra[30] = {0, 0, 0, 0, 1, 1, 2, 2,  3,  3,  4,  4,  5,  5,  6,
                                           6, 7, 7, 8, 8, 9, 9, 10, 10, 11, 11, 12, 12, 13, 13};
    size_t end = b->len * 8;
    for (;;) {
        if (b->pos > end) return -1;
        int s = dc_decode(b, lit);
        if (s < 0 || s > 285) return -1;
        if (s < 256) continue;
        if (s == 256) return 0;
        b->pos += len_extra[s - 257];
        int d = dc_decode(b, dist);
        if (d < 0 || d > 29) return -1;
        b->pos += dist_extra[d];
    }
}

static int dc_fixed(struct dc_bits *b, struct dc_huff *lit, struct dc_huff *dist) {
    uint8_t lens[288];
    memset(lens, 8, 144);
    memset(lens + 144, 9, 112);
    memset(lens + 256, 7, 24);
    memset(lens + 280, 8, 8);
    if (dc_build(lit, lens, 288) < 0) return -1;
    memset(lens, 5, 30);
    if (dc_build(dist, lens, 30) < 0) return -1;
    return dc_codes(b, lit, dist);
}

/* A dynamic block's code lengths (RFC 1951 3.2.7), then its codes. */
static int dc_dynamic(struct dc_bits *b, struct dc_huff *lit, struct dc_huff *dist) {
    static const uint8_t order[19] = {16, 17, 18, 0, 8,  7, 9,  6, 10, 5,
                                      11, 4,  12, 3, 13, 2, 14, 1, 15};
    int hlit = (int)dc_take(b, 5) + 257, hdist = (int)dc_take(b, 5) + 1;
    int hclen = (int)dc_take(b, 4) + 4;
    if (hlit > 286 || hdist > 30) return -1;
    uint8_t cl[19] = {0}, lens[286 + 30];
    for (int i = 0; i < hclen; i++) cl[order[i]] = (uint8_t)dc_take(b, 3);
    uint16_t ct[1 << 7];
    struct dc_huff clh = {ct, 0};
    if (dc_build(&clh, cl, 19) < 0) return -1;
    int n = 0, total = hlit + hdist;
    while (n < total) {
        int s = dc_decode(b, &clh);
        if (s < 0 || b->pos > b->len * 8) return -1;
        if (s < 16) {
            lens[n++] = (uint8_t)s;
            continue;
        }
        if (s == 16 && n == 0) return -1;
        uint8_t val = s == 16 ? lens[n - 1] : 0;
        int rep = s == 16   ? 3 + (int)dc_take(b, 2)
                  : s == 17 ? 3 + (int)dc_take(b, 3)
                            : 11 + (int)dc_take(b, 7);
        if (n + rep > total) return -1;
        while (rep--) lens[n++] = val;
    }
    if (!lens[256] || dc_build(lit, lens, hlit) < 0 || dc_build(dist, lens + hlit, hdist) < 0)
        return -1;
    return dc_codes(b, lit, dist);
}

static int dc_stored(struct dc_bits *b) {
    b->pos = (b->pos + 7) & ~(size_t)7;
    size_t i = b->pos >> 3;
    if (i + 4 > b->len) return -1;
    unsigned n = b->p[i] | (unsigned)b->p[i + 1] << 8;
    unsigned nn = b->p[i + 2] | (unsigned)b->p[i + 3] << 8;
    if ((n ^ 0xffffu) != nn) return -1;
    b->pos += 32 + 8 * (size_t)n;
    return 0;
}

/* Walks the blocks up to the final one: its header's bit position into
 * *final and the bit after its end into *end; -1 if malformed. */
static int dc_walk(struct dc_bits *b, size_t *final, size_t *end) {
    uint16_t *tables = malloc(2 * ((size_t)1 << DC_MAXBITS) * sizeof *tables);
    if (!tables) return -1;
    struct dc_huff lit = {tables, 0}, dist = {tables + ((size_t)1 << DC_MAXBITS), 0};
    int rc = -1;
    for (;;) {
        size_t hdr = b->pos;
        if (hdr + 3 > b->len * 8) break;
        unsigned last = dc_take(b, 1), type = dc_take(b, 2);
        int r = type == 0   ? dc_stored(b)
                : type == 1 ? dc_fixed(b, &lit, &dist)
                : type == 2 ? dc_dynamic(b, &lit, &dist)
                            : -1;
        if (r < 0 || b->pos > b->len * 8) break;
        if (last) {
            *final = hdr;
            *end = b->pos;
            rc = 0;
            break;
        }
    }
    free(tables);
    return rc;
}

size_t deflate_chain(unsigned char *buf, size_t len, size_t cap) {
    struct dc_bits b = {buf, len, 0};
    size_t final, e;
    if (dc_walk(&b, &final, &e) < 0 || (e + 7) / 8 != len) return 0;
    size_t start = (e + 3 + 7) / 8; /* the stored block's LEN, byte-aligned */
    if (start + 4 > cap) return 0;
    for (size_t i = len; i < start; i++) buf[i] = 0;
    buf[final >> 3] &= (unsigned char)~(1u << (final & 7));
    if (e & 7) buf[e >> 3] &= (unsigned char)((1u << (e & 7)) - 1); /* BFINAL 0, BTYPE 00 */
    buf[start] = 0;
    buf[start + 1] = 0;
    buf[start + 2] = 0xff;
    buf[start + 3] = 0xff;
    return start + 4;
}
