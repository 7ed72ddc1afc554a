/* base64.c -- base64 text back to bytes, saying where it is wrong.
 *
 * Mesh files may arrive inside a JSON scene as base64 strings, often
 * wrapped at 76 columns, sometimes without their '=' padding.  The decoder
 * therefore skips ASCII whitespace anywhere, accepts the padding or its
 * absence, and refuses everything else with the byte offset of the first
 * offending character: a character outside the alphabet, data after the
 * padding, padding in the wrong place or of the wrong length, and a lone
 * final character (which carries only 6 of the 8 bits of a byte).  Unused
 * low bits of the last group are not checked, as most decoders don't.
 *
 * One pass, four characters to three bytes; the output is sized from the
 * input length before the loop, so nothing is reallocated.
 */
#include "format/base64.h"

#include <stdint.h>
#include <stdlib.h>

#include "base/error.h"

/* 0..63 for an alphabet character, -1 for whitespace, -2 for '=', -3 else. */
static int b64_value(unsigned char c) {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+') return 62;
    if (c == '/') return 63;
    if (c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v') return -1;
    if (c == '=') return -2;
    return -3;
}

static enum rayd_status b64_bad_char(struct rayd_error *err, unsigned char c, size_t at,
                                     const char *why) {
    if (c >= 0x21 && c <= 0x7e)
        return err_set(err, RAYD_E_INVALID, NULL, "base64: %s '%c' at offset %zu", why, c, at);
    return err_set(err, RAYD_E_INVALID, NULL, "base64: %s (byte 0x%02x) at offset %zu", why, c, at);
}

/* Checks what follows the first '=' at in[at]: only '=' and whitespace,
 * and exactly as many '=' as the group of q data characters needs. */
static enum rayd_status b64_padding(const char *in, size_t len, size_t at, size_t q,
                                    struct rayd_error *err) {
    size_t need = q % 4 == 2 ? 2 : q % 4 == 3 ? 1 : 0, pads = 0;
    for (size_t i = at; i < len; i++) {
        int v = b64_value((unsigned char)in[i]);
        if (v == -1) continue;
        if (v != -2)
            return b64_bad_char(err, (unsigned char)in[i], i, "character after the padding");
        if (++pads > need) return b64_bad_char(err, '=', i, "unexpected padding");
    }
    if (pads != need)
        return err_set(err, RAYD_E_INVALID, NULL,
                       "base64: incomplete padding at offset %zu (expected %zu '=')", len, need);
    return RAYD_OK;
}

enum rayd_status base64_decode(const char *in, size_t len, unsigned char **out, size_t *out_len,
                               struct rayd_error *err) {
    unsigned char *buf = malloc(len / 4 * 3 + 3);
    if (!buf) return err_set(err, RAYD_E_NOMEM, NULL, "base64: out of memory (%zu bytes)", len);
    size_t q = 0, n = 0, last = 0;
    uint32_t acc = 0;
    for (size_t i = 0; i < len; i++) {
        unsigned char c = (unsigned char)in[i];
        int v = b64_value(c);
        if (v == -1) continue;
        if (v == -2) {
            enum rayd_status st = q % 4 == 1 ? b64_bad_char(err, c, i, "unexpected padding")
                                             : b64_padding(in, len, i, q, err);
            if (st != RAYD_OK) {
                free(buf);
                return st;
            }
            break;
        }
        if (v < 0) {
            free(buf);
            return b64_bad_char(err, c, i, "invalid character");
        }
        acc = acc << 6 | (uint32_t)v;
        last = i;
        if (++q % 4 == 0) {
            buf[n++] = (unsigned char)(acc >> 16);
            buf[n++] = (unsigned char)(acc >> 8);
            buf[n++] = (unsigned char)acc;
            acc = 0;
        }
    }
    if (q % 4 == 1) {
        free(buf);
        return err_set(err, RAYD_E_INVALID, NULL,
                       "base64: truncated input (a lone final character at offset %zu)", last);
    }
    if (q % 4 == 2) {
        buf[n++] = (unsigned char)(acc >> 4);
    } else if (q % 4 == 3) {
        buf[n++] = (unsigned char)(acc >> 10);
        buf[n++] = (unsigned char)(acc >> 2);
    }
    *out = buf;
    *out_len = n;
    return RAYD_OK;
}
