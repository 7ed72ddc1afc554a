/* json_pointer.c -- JSON Pointers and quoted user text for messages.
 *
 * An error names the bad value by its pointer, and the pointer quotes the
 * user's own keys (material names, glTF extension names): so a key's "~"
 * and "/" are escaped as RFC 6901 says, and control characters and broken
 * UTF-8 sequences cannot split the message's line.  Both the pointer and a
 * quoted string are cut at a character boundary, with "...", rather than
 * overrun their buffer.
 */
#include "format/json_pointer.h"

#include <stdbool.h>
#include <stdio.h>
#include <string.h>

#define JP_KEY_MAX 64 /* bytes of a key shown; a longer key is shown cut, with "..." */

/* Appends the UTF-8 character at *src to dst (capacity cap, length *n)
 * with control characters (and, with quotes, '"' and '\\') escaped as in
 * JSON, so a message stays one line of valid UTF-8.  False (nothing written) when it does not
 * fit. */
static bool put_char(char *dst, size_t cap, size_t *n, const char **src, bool quotes) {
    unsigned char c = (unsigned char)**src;
    char esc[8];
    size_t len = 1;
    const char *from = *src;
    if (c < 0x20 || c == 0x7f) {
        snprintf(esc, sizeof esc, "\\u%04x", c);
        from = esc;
        len = 6;
    } else if (quotes && (c == '"' || c == '\\')) {
        esc[0] = '\\';
        esc[1] = (char)c;
        from = esc;
        len = 2;
    } else if (c >= 0x80) {
        while ((((unsigned char)(*src)[len]) & 0xC0) == 0x80) len++;
    }
    if (*n + len + 4 >= cap) return false; /* keep room for "..." and NUL */
    memcpy(dst + *n, from, len);
    *n += len;
    *src += c >= 0x80 ? len : 1;
    return true;
}

const char *jp_quote(char *dst, size_t cap, const char *src) {
    size_t n = 0;
    while (*src && put_char(dst, cap, &n, &src, true)) continue;
    if (*src) memcpy(dst + n, "...", 3), n += 3;
    dst[n] = '\0';
    return dst;
}

/* r ends in "..." at n or, with no room there, a character or two before:
 * the pointer is cut, and nothing more is appended to it. */
static struct jp jp_cut(struct jp r, size_t n) {
    while (n > sizeof r.s - 4 || (n > 0 && ((unsigned char)r.s[n] & 0xC0) == 0x80)) n--;
    memcpy(r.s + n, "...", 4);
    r.cut = true;
    return r;
}

struct jp jp_key(const struct jp *parent, const char *key) {
    struct jp r = *parent;
    size_t n = strlen(r.s);
    if (r.cut || n + 6 >= sizeof r.s) return r.cut ? r : jp_cut(r, n);
    r.s[n++] = '/';
    /* the key's bytes end before cap, with room for "..." and NUL */
    size_t cap = n + JP_KEY_MAX + 5 < sizeof r.s ? n + JP_KEY_MAX + 5 : sizeof r.s;
    const char *k = key;
    while (*k) {
        if (*k == '~' || *k == '/') { /* RFC 6901 escapes */
            if (n + 6 >= cap) break;
            r.s[n++] = '~';
            r.s[n++] = *k++ == '~' ? '0' : '1';
        } else if (!put_char(r.s, cap, &n, &k, false)) {
            break;
        }
    }
    if (*k && cap == sizeof r.s) return jp_cut(r, n);
    if (*k) memcpy(r.s + n, "...", 3), n += 3; /* a long key, shown cut */
    r.s[n] = '\0';
    return r;
}

struct jp jp_index(const struct jp *parent, long i) {
    struct jp r = *parent;
    size_t n = strlen(r.s);
    char num[24];
    int len = snprintf(num, sizeof num, "/%ld", i);
    if (r.cut || n + (size_t)len + 4 >= sizeof r.s) return r.cut ? r : jp_cut(r, n);
    memcpy(r.s + n, num, (size_t)len + 1);
    return r;
}
