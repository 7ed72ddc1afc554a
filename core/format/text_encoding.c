/* text_encoding.c -- naming a text file's encoding when it is not UTF-8.
 *
 * Scenes, OBJ files and ASCII PLY headers are read as UTF-8 (ASCII being
 * part of it).  Windows tools often save text as UTF-16, and the parsers
 * then see a NUL after every letter: without a word about the encoding the
 * user reads "OBJ has no faces" or "malformed JSON" about a file that
 * looks fine in an editor.  So the readers ask here first and name the
 * encoding.  A byte order mark tells for sure; without one, UTF-16 text of
 * ASCII letters has a NUL in every other byte, which no UTF-8 text has.
 */
#include "format/text_encoding.h"

#include <string.h>

/* UTF-16 without a mark: NULs at every odd (LE) or even (BE) offset of
 * the first bytes, and none at the others. */
static const char *text_bare_utf16(const unsigned char *p, size_t len) {
    size_t n = len < 64 ? len & ~(size_t)1 : 64;
    if (n < 4) return NULL;
    int even = 0, odd = 0;
    for (size_t i = 0; i < n; i++)
        if (p[i] == 0 && i % 2)
            odd++;
        else if (p[i] == 0)
            even++;
    if (odd == (int)n / 2 && even == 0) return "UTF-16 (little-endian, no byte order mark)";
    if (even == (int)n / 2 && odd == 0) return "UTF-16 (big-endian, no byte order mark)";
    return NULL;
}

const char *text_foreign_encoding(const void *data, size_t len) {
    const unsigned char *p = data;
    if (len >= 4 && memcmp(p, "\xFF\xFE\0\0", 4) == 0) return "UTF-32 (little-endian)";
    if (len >= 4 && memcmp(p, "\0\0\xFE\xFF", 4) == 0) return "UTF-32 (big-endian)";
    if (len >= 2 && memcmp(p, "\xFF\xFE", 2) == 0) return "UTF-16 (little-endian)";
    if (len >= 2 && memcmp(p, "\xFE\xFF", 2) == 0) return "UTF-16 (big-endian)";
    return text_bare_utf16(p, len);
}

bool text_lone_cr(const char *text, size_t len) {
    const char *cr = memchr(text, '\r', len), *lf = memchr(text, '\n', len);
    return cr && (!lf || cr < lf) && (size_t)(cr - text) + 1 < len && cr[1] != '\n';
}
