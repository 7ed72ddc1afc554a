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
 * a byte: every block header is read and every Huffman code decoded, to
 * learn where the final block's header is and where its end-of-block code
 * ends.  The final bit is then cleared and an empty stored block
 * appended: three zero bits, zeros to the byte boundary, LEN 0 and NLEN
 * 0xFFFF -- the bytes of zlib's sync flush.
 *
 * The walk is a decoder's inner loop with nothing written.  The tables are
 * two-level, as zlib's and libdeflate's: 10 bits first for literal/length
 * codes, 8 for distances, and a subtable under a prefix whose codes are
 * longer; an entry holds the code's length plus its extra bits, so a length
 * or a distance and its extra bits are skipped in one step; one 64-bit peek
 * serves several codes.  The tables stay in the first-level cache
 * (bench/README.md, "Design records").
 *
 * The input is our encoder's own output, but the walk checks every bound
 * and every code as a decoder must, and refuses anything that is not one
 * well-formed stream, so a bug elsewhere shows as an error, never as a
 * read out of bounds or a corrupt PNG.
 */
#include "format/deflate_chain.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define DC_MAXBITS 15  /* the longest Huffman code deflate allows */
#define DC_LIT_ROOT 10 /* bits of the first lookup, literal/length codes */
#define DC_DIST_ROOT 8 /* and distance codes (as zlib's) */
#define DC_SUB 0x100u  /* an entry that points to a subtable */

/* Entries of a table of root bits: room for the first lookup and, at the
 * worst, a subtable of 1 << (DC_MAXBITS - root) for each of n symbols. */
#define DC_ROOM(root, n)                                                                           \
    (((size_t)1 << (root)) + (size_t)(n) * ((size_t)1 << (DC_MAXBITS - (root))))
#define DC_LIT_ROOM DC_ROOM(DC_LIT_ROOT, 288)
#define DC_DIST_ROOM DC_ROOM(DC_DIST_ROOT, 32)

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

/* A two-level decoding table.  Indexed by the next root bits of the
 * stream, an entry is symbol << 16 | bits to skip (the code's length and
 * its extra bits), or 0 where no code begins so; or, for codes longer than
 * root, offset << 16 | DC_SUB | b, a subtable indexed by the b bits after
 * the root ones, whose entries are as above. */
struct dc_huff {
    uint32_t *t;
    int root;
};

static unsigned dc_reverse(unsigned c, int l) {
    unsigned r = 0;
    for (int k = 0; k < l; k++) r |= ((c >> k) & 1u) << (l - 1 - k);
    return r;
}

/* Canonical Huffman codes of lens[0..n) into h, whose table has room for
 * DC_ROOM(h->root, n) entries; extra[s] is added to symbol s's length, and
 * symbols from valid on are left 0 (they take their code but may not be
 * used).  -1 for an over-subscribed set of lengths.  An incomplete set is
 * allowed (RFC 1951 allows one distance code), its gaps left 0. */
static int dc_build(struct dc_huff *h, const uint8_t *lens, int n, const uint8_t *extra,
                    int valid) {
    int count[DC_MAXBITS + 1] = {0};
    for (int s = 0; s < n; s++) count[lens[s]]++;
    int left = 1;
    for (int l = 1; l <= DC_MAXBITS; l++) {
        left = 2 * left - count[l];
        if (left < 0) return -1;
    }
    int root = h->root;
    size_t rsize = (size_t)1 << root;
    uint8_t deep[1 << DC_LIT_ROOT] = {0}; /* longest code under each root prefix */
    unsigned next[DC_MAXBITS + 2], code = 0;
    count[0] = 0;
    for (int l = 1; l <= DC_MAXBITS; l++) next[l] = code = (code + (unsigned)count[l - 1]) << 1;
    unsigned rev[288];
    for (int s = 0; s < n; s++) {
        int l = lens[s];
        if (!l) continue;
        rev[s] = dc_reverse(next[l]++, l);
        unsigned p = rev[s] & (unsigned)(rsize - 1);
        if (l > root && l > deep[p]) deep[p] = (uint8_t)l;
    }
    if (left) memset(h->t, 0, rsize * sizeof *h->t);
    size_t used = rsize;
    for (size_t p = 0; p < rsize; p++) {
        if (!deep[p]) continue;
        int b = deep[p] - root;
        h->t[p] = (uint32_t)used << 16 | DC_SUB | (uint32_t)b;
        if (left) memset(h->t + used, 0, ((size_t)1 << b) * sizeof *h->t);
        used += (size_t)1 << b;
    }
    for (int s = 0; s < n; s++) {
        int l = lens[s];
        if (!l) continue;
        uint32_t e = s < valid ? (uint32_t)s << 16 | (uint32_t)(l + (extra ? extra[s] : 0)) : 0;
        if (l <= root) {
            for (size_t i = rev[s]; i < rsize; i += (size_t)1 << l) h->t[i] = e;
        } else {
            uint32_t sub = h->t[rev[s] & (rsize - 1)];
            uint32_t *t = h->t + (sub >> 16);
            size_t size = (size_t)1 << (sub & 0xff);
            for (size_t i = rev[s] >> root; i < size; i += (size_t)1 << (l - root)) t[i] = e;
        }
    }
    return 0;
}

/* The entry of the code at the start of v. */
static inline uint32_t dc_entry(const struct dc_huff *h, uint64_t v) {
    uint32_t e = h->t[v & ((1u << h->root) - 1)];
    if (e & DC_SUB) e = h->t[(e >> 16) + ((v >> h->root) & ((1u << (e & 0xff)) - 1))];
    return e;
}

static inline int dc_decode(struct dc_bits *b, const struct dc_huff *h) {
    uint32_t e = dc_entry(h, dc_peek(b));
    if (!e) return -1;
    b->pos += e & 0xff;
    return (int)(e >> 16);
}

/* The codes of one Huffman block, up to and through its end-of-block.  One
 * peek gives 57 bits: codes are decoded from it while a literal/length
 * code and its extra bits (at most 20) surely fit, and a distance code and
 * its extra bits (at most 28) are peeked afresh when they might not.  A
 * walk past the end reads zeros, and is caught here at every peek. */
static int dc_codes(struct dc_bits *b, const struct dc_huff *lit, const struct dc_huff *dist) {
    size_t end = b->len * 8;
    for (;;) {
        if (b->pos > end) return -1;
        uint64_t v = dc_peek(b);
        unsigned used = 0;
        do {
            uint32_t e = dc_entry(lit, v);
            if (!e) return -1;
            unsigned n = e & 0xff, s = e >> 16;
            v >>= n;
            used += n;
            if (s < 256) continue;
            if (s == 256) {
                b->pos += used;
                return 0;
            }
            if (used > 57 - 28) {
                b->pos += used;
                if (b->pos > end) return -1;
                used = 0;
                v = dc_peek(b);
            }
            e = dc_entry(dist, v);
            if (!e) return -1;
            v >>= e & 0xff;
            used += e & 0xff;
        } while (used <= 57 - 20);
        b->pos += used;
    }
}

static const uint8_t dc_len_extra[288] = {
    [265] = 1, [266] = 1, [267] = 1, [268] = 1, [269] = 2, [270] = 2, [271] = 2,
    [272] = 2, [273] = 3, [274] = 3, [275] = 3, [276] = 3, [277] = 4, [278] = 4,
    [279] = 4, [280] = 4, [281] = 5, [282] = 5, [283] = 5, [284] = 5};
static const uint8_t dc_dist_extra[32] = {0, 0, 0, 0, 1, 1, 2, 2,  3,  3,  4,  4,  5,  5,  6,
                                          6, 7, 7, 8, 8, 9, 9, 10, 10, 11, 11, 12, 12, 13, 13};

static int dc_fixed(struct dc_bits *b, struct dc_huff *lit, struct dc_huff *dist) {
    uint8_t lens[288];
    memset(lens, 8, 144);
    memset(lens + 144, 9, 112);
    memset(lens + 256, 7, 24);
    memset(lens + 280, 8, 8);
    if (dc_build(lit, lens, 288, dc_len_extra, 286) < 0) return -1;
    memset(lens, 5, 32);
    if (dc_build(dist, lens, 32, dc_dist_extra, 30) < 0) return -1;
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
    uint32_t ct[1 << 7]; /* code length codes are at most 7 bits: no subtables */
    struct dc_huff clh = {ct, 7};
    if (dc_build(&clh, cl, 19, NULL, 19) < 0) return -1;
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
    if (!lens[256] || dc_build(lit, lens, hlit, dc_len_extra, hlit) < 0 ||
        dc_build(dist, lens + hlit, hdist, dc_dist_extra, hdist) < 0)
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
    uint32_t *tables = malloc((DC_LIT_ROOM + DC_DIST_ROOM) * sizeof *tables);
    if (!tables) return -1;
    struct dc_huff lit = {tables, DC_LIT_ROOT}, dist = {tables + DC_LIT_ROOM, DC_DIST_ROOT};
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
