/* test_base64.c -- the base64 decoder (glTF data: URIs, inline textures
 * and meshes): round trips, padding and whitespace, errors, and every
 * truncation and corruption of a sample (mesh_check.h: the shared harness).
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "format/base64.h"
#include "mesh_check.h"

/* ---- base64 -------------------------------------------------------------- */

static size_t b64_encode(const unsigned char *in, size_t n, char *out, bool pad) {
    static const char A[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    size_t o = 0;
    for (size_t i = 0; i < n; i += 3) {
        uint32_t v = (uint32_t)in[i] << 16;
        if (i + 1 < n) v |= (uint32_t)in[i + 1] << 8;
        if (i + 2 < n) v |= in[i + 2];
        out[o++] = A[v >> 18 & 63];
        out[o++] = A[v >> 12 & 63];
        if (i + 1 < n)
            out[o++] = A[v >> 6 & 63];
        else if (pad)
            out[o++] = '=';
        if (i + 2 < n)
            out[o++] = A[v & 63];
        else if (pad)
            out[o++] = '=';
    }
    return o;
}

static enum rayd_status b64(const char *s, size_t n, unsigned char **out, size_t *len,
                            struct rayd_error *e) {
    char *copy = malloc(n ? n : 1);
    memcpy(copy, s, n);
    enum rayd_status st = base64_decode(copy, n, out, len, e);
    free(copy);
    return st;
}

static void test_base64_round_trip(void) {
    unsigned char all[256];
    char text[400];
    for (int i = 0; i < 256; i++) all[i] = (unsigned char)i;
    for (int pad = 0; pad <= 1; pad++)
        for (size_t n = 0; n <= 256; n += (n < 8 ? 1 : 31)) {
            size_t tn = b64_encode(all + 256 - n, n, text, pad);
            unsigned char *out = NULL;
            size_t len = 99;
            struct rayd_error e = {0};
            CHECK(b64(text, tn, &out, &len, &e) == RAYD_OK, "n=%zu pad=%d: %s", n, pad, e.message);
            CHECK(out != NULL && len == n && memcmp(out, all + 256 - n, n) == 0, "n=%zu pad=%d", n,
                  pad);
            free(out);
        }
    size_t tn = b64_encode(all, 256, text, true);
    CHECK(tn == 344 && memcmp(text, "AAECAwQFBgcICQoL", 16) == 0, "encoder sanity");
}

static void test_base64_padding_and_whitespace(void) {
    static const struct {
        const char *in, *out;
    } ok[] = {
        {"TWFu", "Man"},   {"TWE=", "Ma"},  {"TWE", "Ma"},           {"TQ==", "M"},
        {"TQ", "M"},       {"", ""},        {" \r\n\t", ""},         {"TW\nFu\r\n  ZA==\n", "Mand"},
        {"T W E =", "Ma"}, {"TQ=\n=", "M"}, {"TWFuTWFu\n", "ManMan"}};
    for (size_t i = 0; i < sizeof ok / sizeof ok[0]; i++) {
        unsigned char *out = NULL;
        size_t len = 99;
        struct rayd_error e = {0};
        CHECK(b64(ok[i].in, strlen(ok[i].in), &out, &len, &e) == RAYD_OK, "'%s': %s", ok[i].in,
              e.message);
        CHECK(out && len == strlen(ok[i].out) && memcmp(out, ok[i].out, len) == 0, "'%s'",
              ok[i].in);
        free(out);
    }
}

static void test_base64_errors(void) {
    static const struct {
        const char *in, *msg;
    } bad[] = {{"TW*u", "base64: invalid character '*' at offset 2"},
               {"TWF-", "invalid character '-' at offset 3"},
               {"TWF_", "invalid character '_' at offset 3"},
               {"TW\x80u", "invalid character (byte 0x80) at offset 2"},
               {"TQ=", "incomplete padding"},
               {"TQ===", "unexpected padding '=' at offset 4"},
               {"TWFu=", "unexpected padding '=' at offset 4"},
               {"TWFuT=", "unexpected padding '=' at offset 5"},
               {"T", "truncated input (a lone final character at offset 0)"},
               {"TWFuT \n", "lone final character at offset 4"},
               {"TQ==TQ==", "character after the padding 'T' at offset 4"},
               {"=", "unexpected padding '=' at offset 0"}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        unsigned char *out = (unsigned char *)&i;
        size_t len = 99;
        struct rayd_error e = {0};
        CHECK(b64(bad[i].in, strlen(bad[i].in), &out, &len, &e) == RAYD_E_INVALID, "'%s' accepted",
              bad[i].in);
        CHECK(strstr(e.message, bad[i].msg) != NULL, "'%s': '%s' lacks '%s'", bad[i].in, e.message,
              bad[i].msg);
        CHECK(out == (unsigned char *)&i && len == 99, "out written on error");
    }
    /* A NUL inside the given length is a bad character, not an end. */
    unsigned char *out = NULL;
    size_t len = 0;
    struct rayd_error e = {0};
    CHECK(b64("TW\0u", 4, &out, &len, &e) == RAYD_E_INVALID && strstr(e.message, "byte 0x00"), "%s",
          e.message);
}

static int fuzz_b64(const unsigned char *buf, size_t n) {
    unsigned char *out = NULL;
    size_t len = 0;
    struct rayd_error e = {0};
    enum rayd_status st = b64((const char *)buf, n, &out, &len, &e);
    free(out);
    return st == RAYD_OK || st == RAYD_E_INVALID;
}

static void test_fuzz_truncate_and_corrupt(void) {
    const char *b = "TWFuIGlzIGRpc3Rpbmd1aXNoZWQs\r\nIG5vdCBvbmx5IGJ5IGhpcyByZWFzb24=\n";
    fuzz_one(fuzz_b64, (const unsigned char *)b, strlen(b), "base64");
}

int main(void) {
    RUN(test_base64_round_trip);
    RUN(test_base64_padding_and_whitespace);
    RUN(test_base64_errors);
    RUN(test_fuzz_truncate_and_corrupt);
    CHECK_EXIT();
}
