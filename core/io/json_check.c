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
 */
#include "io/json_check.h"

#include <stdio.h>
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
    const char *msg; /* set on failure; i is where */
};

static bool jc_fail(struct jc *c, const char *msg) {
    c->msg = msg;
    return false;
}

static void jc_ws(struct jc *c) {
    while (c->i < c->len && strchr(" \t\r\n", c->p[c->i]) && c->p[c->i]) c->i++;
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
    if ((v & 0xE0) == 0xC0) n = 2, min = 0x80, v &= 0x1F;
    else if ((v & 0xF0) == 0xE0) n = 3, min = 0x800, v &= 0x0F;
    else if ((v & 0xF8) == 0xF0) n = 4, min = 0x10000, v &= 0x07;
    else return 0;
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
    if (c->len - c->i < n || memcmp(c->p + c->i, word, n) != 0) return jc_fail(c, "expected a value");
    c->i += n;
    return true;
}

static bool jc_value(struct jc *c, int depth);

static bool jc_container(struct jc *c, int depth, bool object) {
    unsigned char close = object ? '}' : ']';
    if (depth >= c->max_depth) return jc_fail(c, "nesting deeper than the limit");
    c->i++;
    jc_ws(c);
    if (c->i < c->len && c->p[c->i] == close) {
        c->i++;
        return true;
    }
    for (;;) {
        if (object) {
            if (c->i >= c->len || c->p[c->i] != '"')
                return jc_fail(c, c->i >= c->len ? "unexpected end of input"
                                                 : "expected a string key in quotes");
            if (!jc_string(c)) return false;
            jc_ws(c);
            if (c->i >= c->len || c->p[c->i] != ':') return jc_fail(c, "expected ':' after the key");
            c->i++;
        }
        if (!jc_value(c, depth + 1)) return false;
        jc_ws(c);
        if (c->i >= c->len) return jc_fail(c, "unexpected end of input");
        if (c->p[c->i] == close) {
            c->i++;
            return true;
        }
        if (c->p[c->i] != ',')
            return jc_fail(c, object ? "expected ',' or '}'" : "expected ',' or ']'");
        c->i++;
        jc_ws(c);
        if (c->i < c->len && c->p[c->i] == close)
            return jc_fail(c, "trailing comma is not allowed");
    }
}

static bool jc_value(struct jc *c, int depth) {
    jc_ws(c);
    if (c->i >= c->len) return jc_fail(c, "unexpected end of input");
    if (++c->values > JC_MAX_VALUES) return jc_fail(c, "more than 10,000,000 values");
    switch (c->p[c->i]) {
    case '{': return jc_container(c, depth, true);
    case '[': return jc_container(c, depth, false);
    case '"': return jc_string(c);
    case 't': return jc_literal(c, "true");
    case 'f': return jc_literal(c, "false");
    case 'n': return jc_literal(c, "null");
    default:
        if (c->p[c->i] == '-' || (c->p[c->i] >= '0' && c->p[c->i] <= '9')) return jc_number(c);
        return jc_fail(c, "expected a value");
    }
}

void json_position(const char *text, size_t off, int *line, int *col) {
    int l = 1, k = 1;
    for (size_t i = 0; i < off; i++) {
        if (text[i] == '\n') {
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
    struct jc c = {(const unsigned char *)text, len, 0, max_depth, 0, NULL};
    if (jc_value(&c, 0)) {
        jc_ws(&c);
        if (c.i == len) return RAYD_OK;
        c.msg = c.p[c.i] == 0 ? "NUL byte after the value" : "unexpected data after the value";
    }
    char msg[160];
    if (c.msg == NULL) c.msg = "malformed JSON";
    unsigned char at = c.i < len ? c.p[c.i] : 0;
    if (strcmp(c.msg, "nesting deeper than the limit") == 0)
        snprintf(msg, sizeof msg, "malformed JSON: nesting deeper than %d levels", max_depth);
    else if (c.i == 0 && len >= 3 && memcmp(c.p, "\xEF\xBB\xBF", 3) == 0)
        snprintf(msg, sizeof msg, "malformed JSON: a byte order mark (BOM) is not allowed; save the file as UTF-8 without BOM");
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
