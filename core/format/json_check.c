/* json_check.c -- a strict JSON syntax check that says exactly where.
 *
 * cJSON parses well but reports a failure only as a rough pointer, and it
 * accepts invalid UTF-8 and recurses as deep as the input nests.  Scene text
 * comes from the network, so before cJSON sees it this pass walks the bytes
 * once (RFC 8259 grammar) and refuses, with a line, a column and what was
 * expected there:
 *   - any syntax error, including truncated input and data after the value;
 *   - invalid UTF-8 (overlong forms, surrogates, past U+10FFFF), NUL bytes,
 *     raw control characters in strings, bad escapes and lone \u surrogates;
 *   - nesting deeper than the limit, before recursing into it;
 *   - more values than cJSON could hold in reasonable memory (it spends
 *     ~60 bytes on each, ~40 times the text), and \u0000, which cJSON would
 *     silently take as the end of the string.
 * The walk is recursive, bounded by that limit.  Text that passes is parsed
 * by cJSON, whose own failure can then only be running out of memory.
 *
 * The same walk notes the large inline mesh arrays (json_check_spans): the
 * value of "vertices", "indices", "normals" or "uvs" in an object that is an
 * array element with "type": "mesh", when it is an array of at least
 * min_count plain numbers.  cJSON would spend a node (~60 bytes and a
 * malloc) on each number; the loader instead hands cJSON the text without
 * those numbers and reads them from here (load/scene_json_inline.c).  Such an
 * array is walked by one flat loop; anything else at those keys, and any
 * error inside, is walked again by the general path, so the verdict and the
 * message are the same either way.  Keys and "mesh" are compared as raw
 * bytes: an escaped spelling only misses the fast path.  Numbers longer than
 * 63 characters are left to cJSON too, which reads at most 63 (1.7.15).
 */
#include "format/json_check.h"
#include "format/text_encoding.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/error.h"

/* cJSON spends ~60 bytes a value: 10M values is ~600 MB, the most a scene
 * may cost before validation even starts. */
#define JC_MAX_VALUES 10000000L

struct jc {
    const unsigned char *p;
    size_t len, i;
    int max_depth;
    long values;
    const char *msg;          /* set on failure; i is where */
    struct json_spans *spans; /* NULL: not noting mesh arrays */
    long arrays;              /* arrays opened so far, in document order */
};

static bool jc_fail(struct jc *c, const char *msg) {
    c->msg = msg;
    return false;
}

static void jc_ws(struct jc *c) {
    while (c->i < c->len) {
        unsigned char ch = c->p[c->i];
        if (ch != ' ' && ch != '\t' && ch != '\r' && ch != '\n') return;
        c->i++;
    }
}

static int hexval(unsigned char h) {
    if (h >= '0' && h <= '9') return h - '0';
    if (h >= 'a' && h <= 'f') return h - 'a' + 10;
    if (h >= 'A' && h <= 'F') return h - 'A' + 10;
    return -1;
}

/* Reads 4 hex digits after "\u" at c->i; -1 if malformed. */
static long jc_hex4(struct jc *c) {
    if (c->len - c->i < 4) return -1;
    long v = 0;
    for (int k = 0; k < 4; k++) {
        int h = hexval(c->p[c->i + (size_t)k]);
        if (h < 0) return -1;
        v = v * 16 + h;
    }
    c->i += 4;
    return v;
}

/* Length of the valid UTF-8 sequence at p, 0 if invalid. */
static size_t utf8_len(const unsigned char *p, size_t avail) {
    unsigned v = p[0], min;
    size_t n;
    if (v < 0x80) return 1;
    if ((v & 0xE0) == 0xC0)
        n = 2, min = 0x80, v &= 0x1F;
    else if ((v & 0xF0) == 0xE0)
        n = 3, min = 0x800, v &= 0x0F;
    else if ((v & 0xF8) == 0xF0)
        n = 4, min = 0x10000, v &= 0x07;
    else
        return 0;
    if (n > avail) return 0;
    for (size_t k = 1; k < n; k++) {
        if ((p[k] & 0xC0) != 0x80) return 0;
        v = (v << 6) | (p[k] & 0x3F);
    }
    if (v < min || v > 0x10FFFF || (v >= 0xD800 && v <= 0xDFFF)) return 0;
    return n;
}

static bool jc_escape(struct jc *c) {
    size_t at = c->i;
    c->i++; /* the backslash */
    if (c->i >= c->len) return jc_fail(c, "unterminated string");
    unsigned char e = c->p[c->i++];
    if (strchr("\"\\/bfnrt", e) && e) return true;
    if (e != 'u') {
        c->i = at;
        return jc_fail(c, "invalid escape in string");
    }
    long u = jc_hex4(c);
    if (u < 0) {
        c->i = at;
        return jc_fail(c, "\\u must be followed by 4 hex digits");
    }
    if (u == 0) {
        c->i = at;
        return jc_fail(c, "\\u0000 (NUL) is not allowed in strings");
    }
    if (u >= 0xDC00 && u <= 0xDFFF) {
        c->i = at;
        return jc_fail(c, "lone low surrogate in \\u escape");
    }
    if (u >= 0xD800 && u <= 0xDBFF) {
        long lo = -1;
        if (c->len - c->i >= 2 && c->p[c->i] == '\\' && c->p[c->i + 1] == 'u') {
            c->i += 2;
            lo = jc_hex4(c);
        }
        if (lo < 0xDC00 || lo > 0xDFFF) {
            c->i = at;
            return jc_fail(c, "high surrogate in \\u escape without its low surrogate");
        }
    }
    return true;
}

static bool jc_string(struct jc *c) {
    c->i++; /* opening quote */
    while (c->i < c->len) {
        unsigned char ch = c->p[c->i];
        if (ch == '"') {
            c->i++;
            return true;
        }
        if (ch == '\\') {
            if (!jc_escape(c)) return false;
            continue;
        }
        if (ch < 0x20) return jc_fail(c, "control character in string (escape it)");
        size_t n = utf8_len(c->p + c->i, c->len - c->i);
        if (n == 0) return jc_fail(c, "invalid UTF-8");
        c->i += n;
    }
    return jc_fail(c, "unterminated string");
}

static bool jc_digits(struct jc *c) {
    size_t start = c->i;
    while (c->i < c->len && c->p[c->i] >= '0' && c->p[c->i] <= '9') c->i++;
    return c->i > start;
}

static bool jc_number(struct jc *c) {
    size_t start = c->i;
    if (c->p[c->i] == '-') c->i++;
    if (c->i < c->len && c->p[c->i] == '0') {
        c->i++;
    } else if (!jc_digits(c)) {
        c->i = start;
        return jc_fail(c, "invalid number");
    }
    if (c->i < c->len && c->p[c->i] == '.') {
        c->i++;
        if (!jc_digits(c)) return jc_fail(c, "invalid number: digits must follow '.'");
    }
    if (c->i < c->len && (c->p[c->i] == 'e' || c->p[c->i] == 'E')) {
        c->i++;
        if (c->i < c->len && (c->p[c->i] == '+' || c->p[c->i] == '-')) c->i++;
        if (!jc_digits(c)) return jc_fail(c, "invalid number: digits must follow the exponent");
    }
    if (c->i < c->len && strchr("0123456789.eE+-", c->p[c->i]) && c->p[c->i]) {
        bool lead0 = c->p[start] == '0' || (c->p[start] == '-' && c->p[start + 1] == '0');
        return jc_fail(c, lead0 && c->p[c->i] >= '0' && c->p[c->i] <= '9'
                              ? "invalid number (leading zeros are not allowed)"
                              : "invalid number");
    }
    return true;
}

static bool jc_literal(struct jc *c, const char *word) {
    size_t n = strlen(word);
    if (c->len - c->i < n || memcmp(c->p + c->i, word, n) != 0)
        return jc_fail(c, "expected a value");
    c->i += n;
    return true;
}

static bool jc_value(struct jc *c, int depth, bool elem);

/* Which mesh key the raw key bytes are: 1..4, or 0 for "type", or -1. */
static int mesh_key(const unsigned char *k, size_t n) {
    static const char *const names[] = {"type", "vertices", "indices", "normals", "uvs"};
    for (int i = 0; i < 5; i++)
        if (strlen(names[i]) == n && memcmp(k, names[i], n) == 0) return i;
    return -1;
}

static void note_span(struct jc *c, struct json_span sp) {
    struct json_spans *ss = c->spans;
    if (ss->n == ss->cap) {
        size_t cap = ss->cap ? 2 * ss->cap : 16;
        struct json_span *v = realloc(ss->v, cap * sizeof *v);
        if (!v) { /* note nothing then: every array goes through cJSON */
            free(ss->v);
            ss->v = NULL;
            ss->n = ss->cap = 0;
            ss->min_count = LONG_MAX;
            return;
        }
        ss->v = v;
        ss->cap = cap;
    }
    ss->v[ss->n++] = sp;
}

/* An array of plain numbers at c->i, walked flat and noted when large;
 * false on anything else or any error (the caller walks it again). */
static bool jc_numbers(struct jc *c, size_t owner) {
    struct json_span sp = {c->i, 0, 0, c->arrays++, owner};
    size_t longest = 0;
    if (++c->values > JC_MAX_VALUES) return false;
    c->i++;
    for (;;) {
        jc_ws(c);
        if (c->i >= c->len || (c->p[c->i] != '-' && (c->p[c->i] < '0' || c->p[c->i] > '9')))
            return false;
        size_t n0 = c->i;
        if (++c->values > JC_MAX_VALUES || !jc_number(c)) return false;
        if (c->i - n0 > longest) longest = c->i - n0;
        sp.count++;
        jc_ws(c);
        if (c->i >= c->len || (c->p[c->i] != ',' && c->p[c->i] != ']')) return false;
        if (c->p[c->i++] == ']') break;
    }
    sp.close = c->i - 1;
    if (sp.count >= c->spans->min_count && longest <= 63) note_span(c, sp);
    return true;
}

/* The value of a mesh key in an array element's object. */
static bool jc_mesh_value(struct jc *c, int depth, size_t owner) {
    size_t at = c->i;
    long values = c->values, arrays = c->arrays;
    if (at < c->len && c->p[at] == '[' && depth < c->max_depth && jc_numbers(c, owner)) return true;
    c->i = at;
    c->values = values;
    c->arrays = arrays;
    c->msg = NULL;
    return jc_value(c, depth, false);
}

/* Drops the spans an object noted for its own keys: it is not a mesh. */
static void drop_spans(struct json_spans *ss, size_t first, size_t owner) {
    size_t k = first;
    for (size_t i = first; i < ss->n; i++)
        if (ss->v[i].owner != owner) ss->v[k++] = ss->v[i];
    ss->n = k;
}

/* One "key": value of an object; *kind is the key's mesh_key. */
static bool jc_member(struct jc *c, int depth, bool elem, size_t open, bool *mesh) {
    if (c->i >= c->len || c->p[c->i] != '"')
        return jc_fail(c, c->i >= c->len ? "unexpected end of input"
                                         : "expected a string key in quotes");
    size_t k0 = c->i;
    if (!jc_string(c)) return false;
    int kind = c->spans ? mesh_key(c->p + k0 + 1, c->i - k0 - 2) : -1;
    jc_ws(c);
    if (c->i >= c->len || c->p[c->i] != ':') return jc_fail(c, "expected ':' after the key");
    c->i++;
    jc_ws(c);
    size_t v0 = c->i;
    if (kind > 0 && elem) return jc_mesh_value(c, depth + 1, open);
    if (!jc_value(c, depth + 1, false)) return false;
    if (kind == 0 && c->i - v0 == 6 && memcmp(c->p + v0, "\"mesh\"", 6) == 0) *mesh = true;
    return true;
}

/* An object or array at c->i; elem: it is an element of an array. */
static bool jc_container(struct jc *c, int depth, bool object, bool elem) {
    unsigned char close = object ? '}' : ']';
    size_t open = c->i, first = c->spans ? c->spans->n : 0;
    bool mesh = false;
    if (depth >= c->max_depth) return jc_fail(c, "nesting deeper than the limit");
    if (!object) c->arrays++;
    c->i++;
    jc_ws(c);
    if (c->i < c->len && c->p[c->i] == close) {
        c->i++;
        return true;
    }
    for (;;) {
        if (!(object ? jc_member(c, depth, elem, open, &mesh) : jc_value(c, depth + 1, true)))
            return false;
        jc_ws(c);
        if (c->i >= c->len) return jc_fail(c, "unexpected end of input");
        if (c->p[c->i] == close) {
            c->i++;
            if (object && c->spans && !mesh) drop_spans(c->spans, first, open);
            return true;
        }
        if (c->p[c->i] != ',')
            return jc_fail(c, object ? "expected ',' or '}'" : "expected ',' or ']'");
        size_t comma = c->i++;
        jc_ws(c);
        if (c->i < c->len && c->p[c->i] == close) { /* said at the comma, the thing to delete */
            c->i = comma;
            return jc_fail(c, object ? "trailing comma before '}' is not allowed"
                                     : "trailing comma before ']' is not allowed");
        }
    }
}

static bool jc_value(struct jc *c, int depth, bool elem) {
    jc_ws(c);
    if (c->i >= c->len) return jc_fail(c, "unexpected end of input");
    if (++c->values > JC_MAX_VALUES) return jc_fail(c, "more than 10,000,000 values");
    switch (c->p[c->i]) {
    case '{': return jc_container(c, depth, true, elem);
    case '[': return jc_container(c, depth, false, elem);
    case '"': return jc_string(c);
    case 't': return jc_literal(c, "true");
    case 'f': return jc_literal(c, "false");
    case 'n': return jc_literal(c, "null");
    default:
        if (c->p[c->i] == '-' || (c->p[c->i] >= '0' && c->p[c->i] <= '9')) return jc_number(c);
        return jc_fail(c, "expected a value");
    }
}

/* 1-based line and column (in characters) of byte offset off.  A line
 * ends at LF, CR LF or a lone CR, as editors count them. */
static void json_position(const char *text, size_t off, int *line, int *col) {
    int l = 1, k = 1;
    for (size_t i = 0; i < off; i++) {
        if (text[i] == '\n' || (text[i] == '\r' && (i + 1 == off || text[i + 1] != '\n'))) {
            l++;
            k = 1;
        } else if (((unsigned char)text[i] & 0xC0) != 0x80) {
            k++; /* columns count characters, not UTF-8 continuation bytes */
        }
    }
    *line = l;
    *col = k;
}

enum rayd_status json_check(const char *text, size_t len, int max_depth, struct rayd_error *err) {
    return json_check_spans(text, len, max_depth, NULL, err);
}

enum rayd_status json_check_spans(const char *text, size_t len, int max_depth,
                                  struct json_spans *spans, struct rayd_error *err) {
    struct jc c = {(const unsigned char *)text, len, 0, max_depth, 0, NULL, spans, 0};
    if (jc_value(&c, 0, false)) {
        jc_ws(&c);
        if (c.i == len) return RAYD_OK;
        c.msg = c.p[c.i] == 0 ? "NUL byte after the value" : "unexpected data after the value";
    }
    char msg[160];
    if (c.msg == NULL) c.msg = "malformed JSON";
    unsigned char at = c.i < len ? c.p[c.i] : 0;
    if (strcmp(c.msg, "nesting deeper than the limit") == 0)
        snprintf(msg, sizeof msg, "malformed JSON: nesting deeper than %d levels", max_depth);
    else if (text_foreign_encoding(text, len))
        snprintf(msg, sizeof msg, "malformed JSON: the text is %s; save it as UTF-8",
                 text_foreign_encoding(text, len));
    else if (c.i == 0 && len >= 3 && memcmp(c.p, "\xEF\xBB\xBF", 3) == 0)
        snprintf(msg, sizeof msg,
                 "malformed JSON: a byte order mark (BOM) is not allowed; save the file as UTF-8 "
                 "without BOM");
    else if (c.i < len && at >= 0x21 && at <= 0x7e && strstr(c.msg, "expected"))
        snprintf(msg, sizeof msg, "malformed JSON: %s, found '%c'", c.msg, at);
    else if (c.i < len && at < 0x20 && strstr(c.msg, "expected"))
        snprintf(msg, sizeof msg, "malformed JSON: %s, found byte 0x%02x%s", c.msg, at,
                 at == 0 ? " (NUL)" : " (a control character)");
    else
        snprintf(msg, sizeof msg, "malformed JSON: %s", c.msg);
    enum rayd_status code = strstr(c.msg, "10,000,000") ? RAYD_E_LIMIT : RAYD_E_PARSE;
    err_set(err, code, NULL, "%s", msg);
    if (err) json_position(text, c.i, &err->line, &err->column);
    return code;
}
