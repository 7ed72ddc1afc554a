/* http_reply.c -- the replies a handler can give, and what every reply
 * carries.
 *
 * A reply is built as a libmicrohttpd response and parked on the request
 * (r->pending); the transport queues it when the handler returns or when a
 * suspended request is resumed, so a worker thread never touches the
 * connection itself.  Headers every reply needs -- CORS for an allowed
 * Origin, nosniff -- are added here, once, so no handler can forget them.
 * Every error body of the API comes from http_reply_error, written by cJSON:
 * {"error": {"status", "code", "message", "path"?, "line"?, "column"?,
 * "parameter"?}}.  PNGs are sent from the shared blob, a block at a time as
 * libmicrohttpd asks (so the access log knows how much of one went out);
 * the response holds a reference, dropped by libmicrohttpd when it is done.
 * Every reply carries the request's X-Request-Id.  Every image carries
 * X-Rayd-Version: two versions may draw the same scene differently, and a
 * client stitching a frame from many nodes (or a balancer's cache) must be
 * able to tell.
 *
 * A 304 has no body, and RFC 9110 (section 8.6) forbids a Content-Length
 * other than the one the 200 would have had -- which rayd does not know
 * without rendering.  libmicrohttpd (0.9.75 as in Debian 12, and later)
 * writes "Content-Length: <size of the response's body>" on a 304, so an
 * empty buffer would say 0, and a body of unknown size would say
 * "Transfer-Encoding: chunked".  http_reply_not_modified therefore answers
 * with a body of unknown size under MHD_RF_HTTP_1_0_COMPATIBLE_STRICT: no
 * chunking, so neither header is written; the price is that libmicrohttpd
 * then closes the connection after the 304 ("Connection: close"), one new
 * connection per revalidation.
 */
#include "request.h"

#include <cjson/cJSON.h>
#include <microhttpd.h>
#include <stdlib.h>
#include <string.h>

const char *http_reply_cors_origin(struct http_req *r)
{
    if (!config.cors_origin || !*config.cors_origin)
        return NULL;
    const char *origin = http_req_header(r, "Origin");
    if (!origin)
        return NULL;
    if (!strcmp(config.cors_origin, "*"))
        return "*";
    size_t ol = strlen(origin), n;
    const char *p = config.cors_origin, *item;
    while (http_req_list_next(&p, &item, &n))
        if (n == ol && ol && !memcmp(item, origin, ol))
            return origin;
    return NULL;
}

void http_reply(struct http_req *r, unsigned status, struct MHD_Response *resp)
{
    if (!resp) {
        /* out of memory building a response: give up on the connection */
        r->gone = true;
        return;
    }
    if (r->pending)
        MHD_destroy_response(r->pending);
    r->body_counted = false;
    const char *origin = http_reply_cors_origin(r);
    if (origin) {
        MHD_add_response_header(resp, "Access-Control-Allow-Origin", origin);
        MHD_add_response_header(resp, "Access-Control-Expose-Headers",
                                "ETag, Location, Retry-After, Content-Length, X-Request-Id, "
                                "X-Rayd-Estimated-Rays, X-Rayd-Estimated-Seconds, X-Rayd-Version");
    }
    MHD_add_response_header(resp, "X-Content-Type-Options", "nosniff");
    if (r->request_id[0])
        MHD_add_response_header(resp, "X-Request-Id", r->request_id);
    r->pending = resp;
    if (origin && strcmp(origin, "*"))
        http_reply_vary(r, "Origin");
    r->pending_status = status;
    r->status = (int)status;
    r->replied = true;
}

void http_reply_header(struct http_req *r, const char *name, const char *value)
{
    if (r->pending)
        MHD_add_response_header(r->pending, name, value);
}

void http_reply_data(struct http_req *r, unsigned status, const char *ctype, const void *data,
                     size_t len)
{
    struct MHD_Response *resp =
        MHD_create_response_from_buffer(len, (void *)(uintptr_t)data, MHD_RESPMEM_MUST_COPY);
    if (resp && ctype)
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, ctype);
    r->bytes = len;
    http_reply(r, status, resp);
}

/* The text of o (deleted) as the body.  Printed into a stack buffer and
 * copied once by libmicrohttpd, as any small body: an error reply under load
 * (503 queue_full) costs no more than the hand-written one did. */
static void http_reply_text(struct http_req *r, unsigned status, cJSON *o)
{
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
    struct MHD_Response *resp =
        text ? MHD_create_response_from_buffer_with_free_callback(len, text, free) : NULL;
    if (!resp) {
        free(text);
        r->gone = true;
        return;
    }
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, "application/json");
    r->bytes = len;
    http_reply(r, status, resp);
}

void http_reply_json(struct http_req *r, unsigned status, cJSON *o)
{
    http_reply_text(r, status, o);
    if (status < 300)
        http_reply_header(r, "Cache-Control", "no-store");
}

/* An image's body is handed to libmicrohttpd as it asks for it (a copy
 * of a block at a time, instead of the buffer whole), so the request knows
 * how much went out: the access line of an answer the client stopped
 * reading says so (r->body_taken).  The reader runs only while the answer
 * is sent, before the completion that frees r. */
struct http_reply_body {
    struct blob *img;
    struct http_req *r;
};

static ssize_t http_reply_body_read(void *cls, uint64_t pos, char *buf, size_t max)
{
    struct http_reply_body *b = cls;
    if (pos >= b->img->len)
        return MHD_CONTENT_READER_END_OF_STREAM;
    size_t n = b->img->len - (size_t)pos < max ? b->img->len - (size_t)pos : max;
    memcpy(buf, (const char *)b->img->data + pos, n);
    if ((size_t)pos + n > b->r->body_taken)
        b->r->body_taken = (size_t)pos + n;
    return (ssize_t)n;
}

static void http_reply_body_free(void *cls)
{
    struct http_reply_body *b = cls;
    blob_unref(b->img);
    free(b);
}

void http_reply_image(struct http_req *r, unsigned status, struct blob *png, const char *type)
{
    /* the response holds one reference to the blob, dropped by libmicrohttpd */
    struct http_reply_body *b = malloc(sizeof *b);
    struct MHD_Response *resp =
        b ? MHD_create_response_from_callback(png->len, 64 * 1024, http_reply_body_read, b,
                                              http_reply_body_free)
          : NULL;
    if (!resp) {
        free(b);
        r->gone = true;
        return;
    }
    blob_ref(png);
    *b = (struct http_reply_body){png, r};
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, type);
    /* the renderer that made the pixels: a frame is stitched from one only */
    MHD_add_response_header(resp, "X-Rayd-Version", RAYD_VERSION);
    r->bytes = png->len;
    r->is_image = true;
    http_reply(r, status, resp);
    r->body_taken = 0;
    r->body_counted = true;
}

void http_reply_error(struct http_req *r, unsigned status, const char *code, const char *message,
                      const char *path, int line, int column, const char *param)
{
    cJSON *o = cJSON_CreateObject();
    cJSON *e = cJSON_AddObjectToObject(o, "error");
    cJSON_AddNumberToObject(e, "status", status);
    cJSON_AddStringToObject(e, "code", code);
    cJSON_AddStringToObject(e, "message", message ? message : "");
    if (path && *path)
        cJSON_AddStringToObject(e, "path", path);
    if (line > 0) {
        cJSON_AddNumberToObject(e, "line", line);
        cJSON_AddNumberToObject(e, "column", column);
    }
    if (param && *param)
        cJSON_AddStringToObject(e, "parameter", param);
    http_reply_text(r, status, o);
    r->err_code = code;
    snprintf(r->err_at, sizeof r->err_at, "%s", path && *path ? path : param ? param : "");
    http_reply_header(r, "Cache-Control", "no-store");
    if (status == 503) {
        char v[16];
        snprintf(v, sizeof v, "%d", r->retry_after > 0 ? r->retry_after : 1);
        http_reply_header(r, MHD_HTTP_HEADER_RETRY_AFTER, v);
    }
    if (status == 401)
        http_reply_header(r, MHD_HTTP_HEADER_WWW_AUTHENTICATE, "Bearer realm=\"rayd\"");
    if (status == 413 && !r->body && r->body_len == 0 && !strcmp(code, "body_too_large"))
        http_reply_header(r, MHD_HTTP_HEADER_CONNECTION, "close");
}

/* The body of a 304: none (never called for a 304, which sends no body). */
static ssize_t http_reply_no_body(void *cls, uint64_t pos, char *buf, size_t max)
{
    (void)cls;
    (void)pos;
    (void)buf;
    (void)max;
    return MHD_CONTENT_READER_END_OF_STREAM;
}

/* A response with no body and neither Content-Length nor chunking. */
static struct MHD_Response *http_reply_bodiless(void)
{
    struct MHD_Response *resp =
        MHD_create_response_from_callback(MHD_SIZE_UNKNOWN, 64, http_reply_no_body, NULL, NULL);
    if (resp &&
        MHD_set_response_options(resp, MHD_RF_HTTP_1_0_COMPATIBLE_STRICT, MHD_RO_END) != MHD_YES) {
        MHD_destroy_response(resp);
        resp = NULL;
    }
    return resp;
}

void http_reply_not_modified(struct http_req *r)
{
    r->bytes = 0;
    http_reply(r, 304, http_reply_bodiless());
    http_reply_cache_headers(r);
}

void http_reply_head(struct http_req *r, unsigned status, const char *ctype)
{
    struct MHD_Response *resp = http_reply_bodiless();
    if (resp)
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, ctype);
    r->bytes = 0;
    http_reply(r, status, resp);
}

/* One Vary line for the reply: nginx up to 1.22 reads only the last Vary
 * header of an answer it caches, so every field goes into the same line. */
void http_reply_vary(struct http_req *r, const char *field)
{
    if (!r->pending)
        return;
    const char *old = MHD_get_response_header(r->pending, "Vary");
    if (!old) {
        MHD_add_response_header(r->pending, "Vary", field);
        return;
    }
    char both[256];
    snprintf(both, sizeof both, "%s, %s", old, field);
    MHD_del_response_header(r->pending, "Vary", old);
    MHD_add_response_header(r->pending, "Vary", both);
}

/* With a token, a shared cache (nginx's proxy_cache) must keep the answer
 * per Authorization value, or it would hand a tile fetched with the token to
 * a request without it: Vary: Authorization says so, and nginx keys such an
 * answer on a hash of the header, so the token is never written to its cache
 * files in clear (docs/operations.md). */
void http_reply_cache_headers(struct http_req *r)
{
    if (r->etag[0]) {
        http_reply_header(r, MHD_HTTP_HEADER_ETAG, r->etag);
        http_reply_header(r, MHD_HTTP_HEADER_CACHE_CONTROL,
                          r->etag_revalidate ? "public, no-cache"
                                             : "public, max-age=31536000, immutable");
        if (config.token)
            http_reply_vary(r, "Authorization");
    } else {
        http_reply_header(r, MHD_HTTP_HEADER_CACHE_CONTROL, "no-store");
    }
}
