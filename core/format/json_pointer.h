/* json_pointer.h -- where a value is in a JSON document, for messages
 * (json_pointer.c): JSON Pointers (RFC 6901) built one key or index at a
 * time, and user text quoted the same way.  The scene loader and the glTF
 * readers name every bad value so. */
#ifndef JSON_POINTER_H
#define JSON_POINTER_H

#include <stdbool.h>
#include <stddef.h>

/* A JSON Pointer; "" is the document itself.  A key longer than a
 * message should hold is shown cut, with "...", and the pointer goes on
 * past it; a pointer that would not fit at all ends in "..." (cut), and
 * what is appended after that is dropped.  Never overrun. */
struct jp {
    char s[256];
    bool cut;
};

/* parent/key, with "~" and "/" in key escaped as "~0" and "~1" and
 * control characters as in JSON, so the message stays one line. */
struct jp jp_key(const struct jp *parent, const char *key);
struct jp jp_index(const struct jp *parent, long i);

/* User text fit for a one-line message: control characters, quotes and
 * backslashes escaped, cut at a character boundary with "..." to fit cap.
 * Returns dst. */
const char *jp_quote(char *dst, size_t cap, const char *src);

#endif
