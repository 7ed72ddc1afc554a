/* hdr_scan.c -- is a Radiance .hdr's pixel data whole and decodable?
 *
 * stb_image decodes .hdr files from memory and reads a zero byte for every
 * byte past the end, so it never says a file is short: a flat file cut off
 * decodes with black rows, and an RLE file cut off inside a scanline meets
 * an endless row of zero counts, each a no-op, and loops forever (a hung
 * render, or a server thread spinning on one request).  So before stb sees
 * the bytes, this walks them exactly as stb's decoder will (the header, then
 * each scanline flat or new-style RLE, and stb's fall back to flat data for
 * the whole image once a scanline does not start 2 2) and refuses a file
 * that ends early, naming the row.  Counts that overrun a scanline and bad
 * scanline lengths are left to stb, which reports them.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "format/hdr_scan.h"

/* The offset of the pixel data, as stb_image reads the header: the first
 * line, the lines up to an empty one, then the resolution line. */
static size_t hdr_scan_data_start(const unsigned char *b, size_t len) {
    size_t i = 0;
    bool empty_seen = false;
    for (int line = 0; i < len; line++) {
        size_t start = i;
        while (i < len && b[i] != '\n') i++;
        if (i < len) i++; /* the '\n' */
        if (empty_seen) return i;
        empty_seen = line > 0 && b[start] == '\n';
    }
    return len;
}

/* Writes why the data is short, stopping in row j of h; false. */
static bool hdr_scan_short(int j, int h, char *why, size_t n) {
    snprintf(why, n, "the .hdr image's data ends early (it stops in row %d of %d)", j, h);
    return false;
}

/* Flat RGBE pixels from byte at to the end of the image: 4 bytes each. */
static bool hdr_scan_flat(size_t at, size_t len, int w, int h, char *why, size_t n) {
    uint64_t have = (len - at) / 4;
    if (have >= (uint64_t)w * (uint64_t)h) return true;
    return hdr_scan_short((int)(have / (uint64_t)w), h, why, n);
}

/* What hdr_scan_row found. */
enum hdr_row { HDR_ROW_WHOLE, HDR_ROW_SHORT, HDR_ROW_STB_REFUSES };

/* One new-style RLE scanline of width w from *at: four components, each a
 * sequence of runs (count > 128: count - 128 copies of one byte) and dumps
 * (count bytes). */
static enum hdr_row hdr_scan_row(const unsigned char *b, size_t len, size_t *at, int w) {
    for (int k = 0; k < 4; k++) {
        for (int i = 0; i < w;) {
            if (*at >= len) return HDR_ROW_SHORT;
            int count = b[(*at)++]; /* 0 is a no-op, as in Radiance's own reader */
            bool run = count > 128;
            if (run) count -= 128;
            if (count > w - i) return HDR_ROW_STB_REFUSES; /* with its own words */
            *at += run ? 1 : (size_t)count;
            i += count;
        }
    }
    return *at <= len ? HDR_ROW_WHOLE : HDR_ROW_SHORT;
}

bool hdr_scan(const unsigned char *b, size_t len, int w, int h, char *why, size_t n) {
    size_t at = hdr_scan_data_start(b, len);
    if (w < 8 || w >= 32768) return hdr_scan_flat(at, len, w, h, why, n);
    for (int j = 0; j < h; j++) {
        if (len - at < 4) return hdr_scan_short(j, h, why, n);
        if (b[at] != 2 || b[at + 1] != 2 || (b[at + 2] & 0x80)) /* stb: flat, from pixel 0 */
            return hdr_scan_flat(at, len, w, h, why, n);
        if ((b[at + 2] << 8 | b[at + 3]) != w) return true; /* stb refuses it */
        at += 4;
        enum hdr_row r = hdr_scan_row(b, len, &at, w);
        if (r == HDR_ROW_SHORT) return hdr_scan_short(j, h, why, n);
        if (r == HDR_ROW_STB_REFUSES) return true;
    }
    return true;
}

/* The next line from *at as stb_image reads it (up to '\n'): at most 40
 * of its bytes into out, any but printable ASCII as '?'; its length. */
static size_t hdr_line(const unsigned char *b, size_t len, size_t *at, char out[41]) {
    size_t start = *at, k = 0;
    while (*at < len && b[*at] != '\n') {
        if (k < 40) out[k++] = b[*at] >= 0x20 && b[*at] < 0x7f ? (char)b[*at] : '?';
        (*at)++;
    }
    out[k] = 0;
    size_t n = *at - start;
    if (*at < len) (*at)++; /* the '\n' */
    return n;
}

bool hdr_header_why(const unsigned char *b, size_t len, char *why, size_t n) {
    static const char magic[] = "it must start with \"#?RADIANCE\" or \"#?RGBE\"";
    char l[41], other[41] = "";
    size_t at = 0, k;
    bool rgbe = false;
    if (len == 0) return snprintf(why, n, "%s", magic), true;
    k = hdr_line(b, len, &at, l);
    bool cr = k > 0 && b[k - 1] == '\r'; /* the first line starts at b[0] */
    if (cr && k <= 40) l[k - 1] = 0;
    if (strcmp(l, "#?RADIANCE") && strcmp(l, "#?RGBE")) return snprintf(why, n, "%s", magic), true;
    if (cr)
        return snprintf(why, n, "its lines end in CR LF; a .hdr header's lines end in LF"), true;
    for (;;) {
        if (at >= len)
            return snprintf(why, n, "its header has no empty line before the resolution line"),
                   true;
        if (hdr_line(b, len, &at, l) == 0) break;
        if (!strcmp(l, "FORMAT=32-bit_rle_rgbe")) rgbe = true;
        if (!strncmp(l, "FORMAT=", 7) && !other[0]) snprintf(other, sizeof other, "%s", l + 7);
    }
    if (!rgbe && other[0])
        return snprintf(why, n, "its format is '%s'; only 32-bit_rle_rgbe is read", other), true;
    if (!rgbe)
        return snprintf(why, n,
                        "its header has no FORMAT=32-bit_rle_rgbe line (stb_image reads only "
                        "that format)"),
               true;
    hdr_line(b, len, &at, l);
    char *end = l;
    if (!strncmp(l, "-Y ", 3)) strtol(l + 3, &end, 10);
    while (end != l && *end == ' ') end++;
    if (end == l || strncmp(end, "+X ", 3))
        return snprintf(why, n,
                        "its resolution line is '%s'; only '-Y H +X W' (rows from the top, "
                        "each from the left) is read",
                        l),
               true;
    return false;
}
