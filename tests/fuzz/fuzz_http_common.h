/* fuzz_http_common.h -- a socket-free transport for the server's request
 * flow, shared by the HTTP fuzz targets (fuzz_http.c, fuzz_query.c).
 *
 * A request is parsed from the fuzz input the way libmicrohttpd hands it to
 * rayd: the path and the query arguments percent-decoded, a key or value
 * with a NUL inside passed as "\0" (as http.c does), header names compared
 * without case.  Suspend and resume are a flag and a condition variable, so
 * a render queued by a handler is waited for like a suspended connection.
 */
#ifndef FUZZ_HTTP_COMMON_H
#define FUZZ_HTTP_COMMON_H

#include "api/api.h"
#include "route/router.h"
#include "net/transport.h"

#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#define FH_MAX_ARGS 64

struct fh_kv {
    char *k, *v;
};

struct fh_req {
    struct fh_kv hdr[FH_MAX_ARGS], arg[FH_MAX_ARGS];
    int nhdr, narg;
    pthread_mutex_t mu;
    pthread_cond_t cv;
    int resumed;
};

static inline const char *fh_header(struct http_req *r, const char *name) {
    struct fh_req *q = r->conn.io_ctx;
    for (int i = 0; i < q->nhdr; i++)
        if (!strcasecmp(q->hdr[i].k, name)) return q->hdr[i].v;
    return NULL;
}

static inline void fh_header_each(struct http_req *r,
                                  void (*fn)(void *u, const char *k, const char *v), void *u) {
    struct fh_req *q = r->conn.io_ctx;
    for (int i = 0; i < q->nhdr; i++) fn(u, q->hdr[i].k, q->hdr[i].v);
}

static inline void fh_query_each(struct http_req *r,
                                 void (*fn)(void *u, const char *k, const char *v), void *u) {
    struct fh_req *q = r->conn.io_ctx;
    for (int i = 0; i < q->narg; i++) fn(u, q->arg[i].k, q->arg[i].v);
}

static inline void fh_suspend(struct http_req *r) { (void)r; }

static inline void fh_resume(struct http_req *r) {
    struct fh_req *q = r->conn.io_ctx;
    pthread_mutex_lock(&q->mu);
    q->resumed = 1;
    pthread_cond_signal(&q->cv);
    pthread_mutex_unlock(&q->mu);
}

static inline int fh_fd(struct http_req *r) {
    (void)r;
    return -1;
}

static const struct http_io fh_io = {fh_header,  fh_header_each, fh_query_each,
                                     fh_suspend, fh_resume,      fh_fd};

static inline int fh_hex(int c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

/* Percent-decodes s[0..n) into a new string; NUL inside -> "\0". */
static inline char *fh_unescape(const char *s, size_t n) {
    char *o = malloc(n + 3);
    size_t k = 0;
    int nul = 0;
    for (size_t i = 0; i < n; i++) {
        if (s[i] == '%' && i + 2 < n && fh_hex(s[i + 1]) >= 0 && fh_hex(s[i + 2]) >= 0) {
            o[k] = (char)(fh_hex(s[i + 1]) * 16 + fh_hex(s[i + 2]));
            i += 2;
        } else {
            o[k] = s[i];
        }
        if (o[k] == 0) nul = 1;
        k++;
    }
    o[k] = 0;
    if (nul) strcpy(o, "\\0");
    return o;
}

static inline void fh_parse_query(struct fh_req *q, const char *s, size_t n) {
    size_t i = 0;
    while (i <= n && q->narg < FH_MAX_ARGS) {
        size_t e = i;
        while (e < n && s[e] != '&') e++;
        if (e > i) {
            size_t eq = i;
            while (eq < e && s[eq] != '=') eq++;
            q->arg[q->narg].k = fh_unescape(s + i, eq - i);
            q->arg[q->narg].v = eq < e ? fh_unescape(s + eq + 1, e - eq - 1) : strdup("");
            q->narg++;
        }
        i = e + 1;
    }
}

static inline void fh_free(struct fh_req *q) {
    for (int i = 0; i < q->nhdr; i++) {
        free(q->hdr[i].k);
        free(q->hdr[i].v);
    }
    for (int i = 0; i < q->narg; i++) {
        free(q->arg[i].k);
        free(q->arg[i].v);
    }
}

/* The statuses rayd may answer with; anything else (a 500 above all) is a
 * bug the fuzzer should report. */
static inline int fh_status_ok(int st) {
    static const int ok[] = {200, 201, 202, 204, 304, 400, 401, 404, 405, 409,
                             410, 413, 414, 415, 417, 422, 499, 501, 503};
    for (size_t i = 0; i < sizeof ok / sizeof ok[0]; i++)
        if (ok[i] == st) return 1;
    return 0;
}

#endif
