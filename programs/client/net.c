/* net.c -- the libcurl glue every rayd-client command shares.
 *
 * Each request is one easy handle made by net_easy: the same timeouts,
 * keep-alive, bearer token and user agent everywhere, the body collected
 * into a net_buf with a size cap (a PNG tile or a JSON answer, never
 * unbounded).  The tile scheduler adds these handles to one multi handle,
 * whose connection cache keeps the TCP connections to every server alive
 * between tiles; the job command runs them one at a time.
 *
 * Answers that are not a success are described from the API's JSON error
 * ({"error": {"status", "code", "message", "path"}}) so the user sees the
 * code, the JSON Pointer and the message the server gave; anything else
 * (a proxy's HTML page) is shown as its first bytes.
 *
 * A server is not trusted with the user's terminal: every string that came
 * from one (an error's code, message and path, a version, a reason) goes
 * through net_safe before it is printed, which writes control characters
 * (C0 with ESC, CR and LF; DEL; C1, raw or UTF-8 encoded) and bytes that
 * are no UTF-8 as \xNN.  A message cannot then move the cursor, retitle
 * the window, hide what came before it or fake a second line.
 */
#include "client.h"

#include <cjson/cJSON.h>
#include <curl/curl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <rayd/rayd.h>

void net_buf_reset(struct net_buf *b) {
    b->len = 0;
    b->overflow = 0;
}

void net_buf_free(struct net_buf *b) {
    free(b->data);
    b->data = NULL;
    b->len = b->cap = 0;
}

static size_t net_buf_write(char *ptr, size_t size, size_t n, void *user) {
    struct net_buf *b = user;
    size_t add = size * n;
    size_t max = b->max ? b->max : (size_t)64 << 20;
    if (b->len + add > max) {
        b->overflow = 1;
        return 0; /* makes curl fail the transfer */
    }
    if (b->len + add + 1 > b->cap) {
        size_t cap = b->cap ? b->cap : 4096;
        while (cap < b->len + add + 1) cap *= 2;
        char *d = realloc(b->data, cap);
        if (!d) return 0;
        b->data = d;
        b->cap = cap;
    }
    memcpy(b->data + b->len, ptr, add);
    b->len += add;
    b->data[b->len] = '\0';
    return add;
}

void net_global_init(void) { curl_global_init(CURL_GLOBAL_DEFAULT); }

void net_global_cleanup(void) { curl_global_cleanup(); }

void *net_easy(const struct client_opts *o, const char *url, struct net_buf *body,
               const char *json_body, size_t json_len, void **hdrs) {
    CURL *h = curl_easy_init();
    if (!h) return NULL;
    struct curl_slist *hl = NULL;
    if (o->token) {
        size_t n = strlen(o->token) + 32;
        char *auth = malloc(n);
        if (auth) {
            snprintf(auth, n, "Authorization: Bearer %s", o->token);
            hl = curl_slist_append(hl, auth);
            free(auth);
        }
    }
    if (json_body) {
        hl = curl_slist_append(hl, "Content-Type: application/json");
        hl = curl_slist_append(hl, "Expect:"); /* no 100-continue round trip */
        curl_easy_setopt(h, CURLOPT_POST, 1L);
        curl_easy_setopt(h, CURLOPT_POSTFIELDS, json_body);
        curl_easy_setopt(h, CURLOPT_POSTFIELDSIZE_LARGE, (curl_off_t)json_len);
    }
    curl_easy_setopt(h, CURLOPT_URL, url);
    curl_easy_setopt(h, CURLOPT_HTTPHEADER, hl);
    curl_easy_setopt(h, CURLOPT_USERAGENT, "rayd-client/" RAYD_VERSION);
    curl_easy_setopt(h, CURLOPT_WRITEFUNCTION, net_buf_write);
    curl_easy_setopt(h, CURLOPT_WRITEDATA, body);
    curl_easy_setopt(h, CURLOPT_NOSIGNAL, 1L);
    curl_easy_setopt(h, CURLOPT_TCP_KEEPALIVE, 1L);
    curl_easy_setopt(h, CURLOPT_PROTOCOLS_STR, "http,https");
    double conn = o->timeout < 5 ? o->timeout : 5;
    curl_easy_setopt(h, CURLOPT_CONNECTTIMEOUT_MS, (long)(conn * 1000));
    if (o->timeout > 0) curl_easy_setopt(h, CURLOPT_TIMEOUT_MS, (long)(o->timeout * 1000));
    *hdrs = hl;
    return h;
}

/* Parses the API error object out of body; NULL if it is not one. */
static cJSON *net_error_obj(const struct net_buf *body, cJSON **root) {
    *root = NULL;
    if (!body->data || !body->len) return NULL;
    *root = cJSON_ParseWithLength(body->data, body->len);
    cJSON *e = cJSON_GetObjectItemCaseSensitive(*root, "error");
    return cJSON_IsObject(e) ? e : NULL;
}

const char *net_json_str(const void *o, const char *k) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive((const cJSON *)o, k);
    return cJSON_IsString(v) ? v->valuestring : NULL;
}

char *net_error_code(const struct net_buf *body, char *buf, size_t size) {
    cJSON *root;
    cJSON *e = net_error_obj(body, &root);
    const char *code = e ? net_json_str(e, "code") : NULL;
    snprintf(buf, size, "%s", code ? code : "");
    cJSON_Delete(root);
    return buf;
}

/* The length of the UTF-8 character at s (n bytes left) when it is a
 * printable one: well formed, shortest form, no surrogate, not C1
 * (U+0080..U+009F); 0 when not. */
static size_t net_utf8_len(const unsigned char *s, size_t n) {
    size_t len = s[0] >= 0xf0 ? 4 : s[0] >= 0xe0 ? 3 : s[0] >= 0xc0 ? 2 : 0;
    if (!len || s[0] > 0xf4 || len > n) return 0;
    unsigned cp = s[0] & (0x7f >> len);
    for (size_t i = 1; i < len; i++) {
        if ((s[i] & 0xc0) != 0x80) return 0;
        cp = cp << 6 | (s[i] & 0x3f);
    }
    static const unsigned least[5] = {0, 0, 0x80, 0x800, 0x10000};
    if (cp < least[len] || cp > 0x10ffff || (cp >= 0xd800 && cp <= 0xdfff) ||
        (cp >= 0x80 && cp <= 0x9f))
        return 0;
    return len;
}

char *net_safe_n(const char *s, size_t n, char *buf, size_t size) {
    size_t o = 0;
    if (!size) return buf;
    const unsigned char *u = (const unsigned char *)(s ? s : "");
    for (size_t i = 0; i < n && u[i];) {
        size_t len = u[i] >= 0x20 && u[i] < 0x7f ? 1
                     : u[i] >= 0x80              ? net_utf8_len(u + i, n - i)
                                                 : 0;
        size_t need = len ? len : 4;
        if (o + need + 4 > size) { /* room for "..." and the NUL */
            snprintf(buf + o, size - o, "...");
            return buf;
        }
        if (len)
            memcpy(buf + o, u + i, len);
        else
            snprintf(buf + o, size - o, "\\x%02x", u[i]);
        o += need;
        i += len ? len : 1;
    }
    buf[o] = '\0';
    return buf;
}

char *net_safe(const char *s, char *buf, size_t size) {
    return net_safe_n(s, s ? strlen(s) : 0, buf, size);
}

char *net_describe(long status, const struct net_buf *body, char *buf, size_t size) {
    cJSON *root;
    cJSON *e = net_error_obj(body, &root);
    if (e) {
        const char *code = net_json_str(e, "code"), *msg = net_json_str(e, "message");
        const char *path = net_json_str(e, "path"), *param = net_json_str(e, "parameter");
        const cJSON *line = cJSON_GetObjectItemCaseSensitive(e, "line");
        const cJSON *col = cJSON_GetObjectItemCaseSensitive(e, "column");
        char where[300] = "", safe[240], scode[80], smsg[600];
        if (path && *path)
            snprintf(where, sizeof where, " at %s", net_safe(path, safe, sizeof safe));
        else if (cJSON_IsNumber(line) && cJSON_IsNumber(col))
            snprintf(where, sizeof where, " at line %.0f, column %.0f", line->valuedouble,
                     col->valuedouble);
        else if (param && *param)
            snprintf(where, sizeof where, " (parameter %s)", net_safe(param, safe, sizeof safe));
        snprintf(buf, size, "HTTP %ld %s%s: %s", status,
                 code ? net_safe(code, scode, sizeof scode) : "error", where,
                 msg ? net_safe(msg, smsg, sizeof smsg) : "(no message)");
    } else {
        char snippet[160];
        size_t n = body->data ? body->len : 0;
        net_safe_n(body->data, n < 100 ? n : 100, snippet, sizeof snippet);
        snprintf(buf, size, "HTTP %ld%s%s", status, n ? ": " : "", snippet);
    }
    cJSON_Delete(root);
    return buf;
}

double net_retry_after(void *h, double def) {
    struct curl_header *hd = NULL;
    if (curl_easy_header(h, "Retry-After", 0, CURLH_HEADER, -1, &hd) != CURLHE_OK || !hd)
        return def;
    char *end;
    double v = strtod(hd->value, &end);
    if (end == hd->value || v < 0) return def; /* an HTTP date: not sent by rayd; use the default */
    return v > 60 ? 60 : v;
}

double net_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec / 1e9;
}

void net_label(const char *url, char *buf, size_t size) {
    const char *p = strstr(url, "://");
    p = p ? p + 3 : url;
    size_t n = strcspn(p, "/");
    if (n >= size) n = size - 1;
    memcpy(buf, p, n);
    buf[n] = '\0';
}

long net_perform(void *h, void *hdrs, char *why, size_t size) {
    CURLcode cc = curl_easy_perform(h);
    long status = 0;
    if (cc == CURLE_OK)
        curl_easy_getinfo(h, CURLINFO_RESPONSE_CODE, &status);
    else
        snprintf(why, size, "%s", curl_easy_strerror(cc));
    curl_easy_cleanup(h);
    curl_slist_free_all(hdrs);
    return status;
}
