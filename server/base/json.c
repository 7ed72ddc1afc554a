/* json.c -- the server's JSON goes out through cJSON.
 *
 * Escaping strings is easy to get subtly wrong (control characters, quotes
 * in a client's path, a message cut in the middle of an escape), and cJSON,
 * already the core's parser, does it right.  Two things it does not do the
 * way the API documents: a fixed number of decimals (progress 0.4167,
 * milliseconds 1.204) and 64-bit counters past 2^53.  Those numbers are
 * formatted here and handed to cJSON as raw number tokens, so cJSON still
 * writes the document and only the digits are ours.
 */
#include "base/base.h"

#include <cjson/cJSON.h>
#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

void json_add_fixed(cJSON *o, const char *key, double v, int decimals) {
    char num[64];
    if (!isfinite(v)) v = 0;
    snprintf(num, sizeof num, "%.*f", decimals, v);
    cJSON_AddRawToObject(o, key, num);
}

void json_add_u64(cJSON *o, const char *key, uint64_t v) {
    char num[32];
    snprintf(num, sizeof num, "%" PRIu64, v);
    cJSON_AddRawToObject(o, key, num);
}

char *json_print(cJSON *o, bool nl, size_t *len) {
    char *text = o ? cJSON_PrintUnformatted(o) : NULL;
    cJSON_Delete(o);
    if (!text) return NULL;
    size_t n = strlen(text);
    char *out = malloc(n + 2);
    if (out) {
        memcpy(out, text, n);
        if (nl) out[n++] = '\n';
        out[n] = 0;
        if (len) *len = n;
    }
    cJSON_free(text);
    return out;
}

bool json_print_into(cJSON *o, char *buf, size_t size) {
    /* cJSON_PrintPreallocated wants 5 bytes of slack past the text */
    return o && size > 5 && size < (size_t)INT32_MAX &&
           cJSON_PrintPreallocated(o, buf, (int)size - 5, false);
}
