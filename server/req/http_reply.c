/* http_reply.c -- the replies a handler can give, and what every reply
 * carries.
 *
 * A reply is data (struct http_reply: status, headers, body) parked on the
 * request (r->conn.pending); the transport turns it into a response and queues
 * it when the handler returns or when a suspended request is resumed, so a
 * worker thread never touches the connection, and no file below the
 * transport knows libmicrohttpd.  Headers every reply needs -- CORS for an
 * allowed Origin, nosniff -- are added here, once, so no handler can forget
 * them.  Every error body of the API comes from http_reply_error, written
 * by cJSON: {"error": {"status", "code", "message", "path"?, "line"?,
 * "column"?, "parameter"?}}.  Images are sent from the shared blob, which
 * the reply holds a reference to; the transport reads it a block at a time
 * (so the access log knows how much of one went out).  Every reply carries
 * the request's X-Request-Id.  Every image carries X-Rayd-Version: two
 * versions may draw the same scene differently, and a client stitching a
 * frame from many nodes (or a balancer's cache) must be able to tell.
 *
 * A 304 has no body, and RFC 9110 (section 8.6) forbids a Content-Length
 * other than the one the 200 would have had -- which rayd does not know
 * without rendering.  So http_reply_not_modified answers with
 * HTTP_BODY_NONE: no body and neither Content-Length nor chunking, which
 * the transport keeps (http.c says how, and what it costs).
 */
#include "req/request.h"

#include <cjson/cJSON.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

const char *http_reply_cors_origin(struct http_req *r) {
    if (!config.cors_origin || !*config.cors_origin) return NULL;
    const char *origin = http_req_header(r, "Origin");
    if (!origin) return NULL;
    if (!strcmp(config.cors_origin, "*")) return "*";
    size_t ol = strlen(origin), n;
    const char *p = config.cors_origin, *item;
    while (http_req_list_next(&p, &item, &n))
        if (n == ol && ol && !memcmp(item, origin, ol)) return origin;
    return NULL;
}

/* A reply of kind with no headers yet; NULL on no memory. */
static struct http_reply *http_reply_new(enum http_body kind) {
    struct http_reply *p = calloc(1, sizeof *p);
    if (p) p->kind = kind;
    return p;
}

/* Appends name: value to p; false on no memory. */
static bool http_reply_add(struct http_reply *p, const char *name, const char *value) {
    if (p->nheaders == p->cap) {
        size_t cap = p->cap ? 2 * p->cap : 8;
        struct http_header *h = realloc(p->headers, cap * sizeof *h);
        if (!h) return false;
        p->headers = h;
        p->cap = cap;
    }
    size_t nl = strlen(name), vl = strlen(value);
    char *n = malloc(nl + vl + 2);
    if (!n) return false;
    memcpy(n, name, nl + 1);
    memcpy(n + nl + 1, value, vl + 1);
    p->headers[p->nheaders++] = (struct http_header){n, n + nl + 1};
    // cppcheck-suppress memleak ; n is p's now, freed with the reply
    return true;
}

/* The index of p's header name (any case), or -1. */
static long http_reply_find(const struct http_reply *p, const char *name) {
    for (size_t i = 0; i < p->nheaders; i++)
        if (!strcasecmp(p->headers[i].name, name)) return (long)i;
    return -1;
}

/* Parks resp (NULL: out of memory) on r as its answer with status. */
static void http_reply_set(struct http_req *r, unsigned status, struct http_reply *resp,
                           const char *ctype) {
    if (!resp) {
        /* out of memory building a response: give up on the connection */
        r->gone = true;
        return;
    }
    if (ctype) http_reply_add(resp, "Content-Type", ctype);
    http_req_reply_free(r->conn.pending);
    r->log.body_counted = false;
    const char *origin = http_reply_cors_origin(r);
    if (origin) {
        http_reply_add(resp, "Access-Control-Allow-Origin", origin);
        http_reply_add(resp, "Access-Control-Expose-Headers",
                       "ETag, Location, Retry-After, Content-Length, X-Request-Id, "
                       "X-Rayd-Estimated-Rays, X-Rayd-Estimated-Seconds, X-Rayd-Version");
    }
    http_reply_add(resp, "X-Content-Type-Options", "nosniff");
    if (r->request_id[0]) http_reply_add(resp, "X-Request-Id", r->request_id);
    resp->status = status;
    r->conn.pending = resp;
    if (origin && strcmp(origin, "*")) http_reply_vary(r, "Origin");
    r->res.status = (int)status;
    r->conn.replied = true;
}

/* Takes header at out of p. */
static void http_reply_drop(struct http_reply *p, long at) {
    free(p->headers[at].name);
    memmove(p->headers + at, p->headers + at + 1,
            (p->nheaders - (size_t)at - 1) * sizeof *p->headers);
    p->nheaders--;
}

void http_reply_header(struct http_req *r, const char *name, const char *value) {
    struct http_reply *p = r->conn.pending;
    if (!p) return;
    long at = http_reply_find(p, name); /* the last layer to set it wins */
    if (http_reply_add(p, name, value) && at >= 0) http_reply_drop(p, at); /* else the old stays */
}

/* A reply whose body is data[0..len) (malloc'd; taken, freed on failure). */
static void http_reply_take(struct http_req *r, unsigned status, const char *ctype, char *data,
                            size_t len) {
    struct http_reply *resp = data ? http_reply_new(HTTP_BODY_BYTES) : NULL;
    if (!resp)
        free(data);
    else
        *resp = (struct http_reply){.kind = HTTP_BODY_BYTES, .data = data, .len = len};
    r->res.bytes = len;
    http_reply_set(r, status, resp, ctype);
}

void http_reply_data(struct http_req *r, unsigned status, const char *ctype, const void *data,
                     size_t len) {
    char *copy = malloc(len + 1);
    if (copy && len) memcpy(copy, data, len);
    http_reply_take(r, status, ctype, copy, len);
}

void http_reply_stream(struct http_req *r, unsigned status, const char *const *headers,
                       size_t block, ssize_t (*read)(void *cls, char *buf, size_t max),
                       void (*done)(void *cls), void *cls) {
    /* HEAD: the headers alone, no chunked body (not even its last chunk,
     * which a pipelining client would take for the next answer) */
    bool head = r->method && !strcmp(r->method, "HEAD");
    struct http_reply *resp = http_reply_new(head ? HTTP_BODY_NONE : HTTP_BODY_STREAM);
    if (!resp || head) done(cls);
    if (!resp) {
        r->gone = true;
        return;
    }
    if (!head) {
        resp->read = read;
        resp->done = done;
        resp->cls = cls;
        resp->block = block;
    }
    for (; headers && headers[0]; headers += 2) http_reply_add(resp, headers[0], headers[1]);
    http_reply_set(r, status, resp, NULL);
}

/* The text of o (deleted) as the body.  Printed into a stack buffer and
 * copied once by libmicrohttpd, as any small body: an error reply under load
 * (503 queue_full) costs no more than the hand-written one did. */
static void http_reply_text(struct http_req *r, unsigned status, cJSON *o) {
    char buf[4096];
    if (json_print_into(o, buf, sizeof buf - 1)) {
        cJSON_Delete(o);
        size_t len = strlen(buf);
        buf[len++] = '\n';
        http_reply_data(r, status, "application/json", buf, len);
        return;
    }
    size_t len = 0;
    char *text = json_print(o, true, &len); /* deletes o */
    if (!text) {
        r->gone = true;
        return;
    }
    http_reply_take(r, status, "application/json", text, len);
}

void http_reply_json(struct http_req *r, unsigned status, cJSON *o) {
    http_reply_text(r, status, o);
    if (status < 300) http_reply_header(r, "Cache-Control", "no-store");
}

void http_reply_image(struct http_req *r, unsigned status, struct blob *png, const char *type) {
    /* the reply holds one reference to the blob, dropped by the transport */
    struct http_reply *resp = http_reply_new(HTTP_BODY_BLOB);
    if (!resp) {
        r->gone = true;
        return;
    }
    resp->blob = blob_ref(png);
    http_reply_add(resp, "Content-Type", type);
    /* the renderer that made the pixels: a frame is stitched from one only */
    http_reply_add(resp, "X-Rayd-Version", RAYD_VERSION);
    r->res.bytes = png->len;
    r->res.is_image = true;
    http_reply_set(r, status, resp, NULL);
    r->log.body_taken = 0;
    r->log.body_counted = true;
}

void http_reply_error(struct http_req *r, unsigned status, const char *code, const char *message,
                      const char *path, int line, int column, const char *param) {
    cJSON *o = cJSON_CreateObject();
    cJSON *e = cJSON_AddObjectToObject(o, "error");
    cJSON_AddNumberToObject(e, "status", status);
    cJSON_AddStringToObject(e, "code", code);
    cJSON_AddStringToObject(e, "message", message ? message : "");
    if (path && *path) cJSON_AddStringToObject(e, "path", path);
    if (line > 0) {
        cJSON_AddNumberToObject(e, "line", line);
        cJSON_AddNumberToObject(e, "column", column);
    }
    if (param && *param) cJSON_AddStringToObject(e, "parameter", param);
    http_reply_text(r, status, o);
    r->res.err_code = code;
    snprintf(r->res.err_at, sizeof r->res.err_at, "%s", path && *path ? path : param ? param : "");
    http_reply_header(r, "Cache-Control", "no-store");
    if (status == 503) {
        char v[16];
        snprintf(v, sizeof v, "%d", r->res.retry_after > 0 ? r->res.retry_after : 1);
        http_reply_header(r, "Retry-After", v);
    }
    if (status == 401) http_reply_header(r, "WWW-Authenticate", "Bearer realm=\"rayd\"");
    if (status == 413 && !r->body && r->body_len == 0 && !strcmp(code, "body_too_large"))
        http_reply_header(r, "Connection", "close");
}

void http_reply_not_modified(struct http_req *r) {
    r->res.bytes = 0;
    http_reply_set(r, 304, http_reply_new(HTTP_BODY_NONE), NULL);
    http_reply_cache_headers(r);
}

void http_reply_head(struct http_req *r, unsigned status, const char *ctype) {
    r->res.bytes = 0;
    http_reply_set(r, status, http_reply_new(HTTP_BODY_NONE), ctype);
}

/* One Vary line for the reply: nginx up to 1.22 reads only the last Vary
 * header of an answer it caches, so every field goes into the same line. */
void http_reply_vary(struct http_req *r, const char *field) {
    struct http_reply *p = r->conn.pending;
    if (!p) return;
    long at = http_reply_find(p, "Vary");
    if (at < 0) {
        http_reply_add(p, "Vary", field);
        return;
    }
    /* the old line goes, the joined one is added last */
    char both[256];
    snprintf(both, sizeof both, "%s, %s", p->headers[at].value, field);
    http_reply_drop(p, at);
    http_reply_add(p, "Vary", both);
}

/* With a token, a shared cache (nginx's proxy_cache) must keep the answer
 * per Authorization value, or it would hand a tile fetched with the token to
 * a request without it: Vary: Authorization says so, and nginx keys such an
 * answer on a hash of the header, so the token is never written to its cache
 * files in clear (docs/operations.md). */
void http_reply_cache_headers(struct http_req *r) {
    if (r->res.etag[0]) {
        http_reply_header(r, "ETag", r->res.etag);
        http_reply_header(r, "Cache-Control",
                          r->res.etag_revalidate ? "public, no-cache"
                                                 : "public, max-age=31536000, immutable");
        if (config.token) http_reply_vary(r, "Authorization");
    } else {
        http_reply_header(r, "Cache-Control", "no-store");
    }
}
