/* http.c -- the libmicrohttpd glue: requests in, responses out.
 *
 * libmicrohttpd runs its own threads (an epoll loop per thread of a small
 * pool).  They parse HTTP, collect the body, validate and route, and never
 * render: a request that needs a render is handed to the job queue and its
 * connection is *suspended*; the worker that finishes the render stores the
 * response in the request and *resumes* the connection, and libmicrohttpd
 * calls the access handler once more, which queues the stored response.
 * The suspension always happens before the request is enqueued, so a resume
 * can never overtake it.
 *
 * A request's life:
 *   1st call   headers only.  Content-Length over --max-body is answered 413
 *              right here, before a byte of the body is read (no 100
 *              Continue is sent, the connection is closed after the reply).
 *   Nth call   body chunks, appended up to --max-body.  A chunked upload
 *              that grows past the limit is discarded and answered 413.
 *   last call  the router picks the handler, which replies or suspends.
 *   completed  the access log line and the request metrics are written.
 *
 * Authentication (--token-file), CORS (--cors-origin) and OPTIONS
 * preflights are decided here, before routing, so no handler can forget
 * them.  Every error body is built by http_reply_error(), and the mapping
 * from a core status to an HTTP status lives in http_status_of() alone.
 *
 * Drain: while draining, routes that would start work answer 503
 * "draining" (the handlers ask http_is_draining() through the job queue's
 * refusal); /readyz answers 503; everything else still works.
 */
#include "server.h"

#include <arpa/inet.h>
#include <errno.h>
#include <microhttpd.h>
#include <netinet/in.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

#define HTTP_CONTAINER(w) ((struct http_req *)((char *)(w) - offsetof(struct http_req, waiter)))

static struct MHD_Daemon *http_daemon;
static atomic_long http_nsuspended, http_ninflight;
static atomic_bool http_drain_flag;
static int http_bound_port;

long http_suspended(void) { return atomic_load(&http_nsuspended); }
long http_in_flight(void) { return atomic_load(&http_ninflight); }

static atomic_long http_last_ms; /* when the latest request came, log_now() in ms */
double http_last_request(void) { return (double)atomic_load(&http_last_ms) / 1000.0; }
bool http_is_draining(void) { return atomic_load(&http_drain_flag); }
void http_set_draining(void) { atomic_store(&http_drain_flag, true); }
int http_port(void) { return http_bound_port; }

const char *http_header(struct http_req *r, const char *name)
{
    return r->io->header(r, name);
}

struct http_first {
    const char *name, *value;
};

static void http_first_cb(void *u, const char *k, const char *v)
{
    struct http_first *f = u;
    if (!f->value && !strcmp(k, f->name))
        f->value = v;
}

const char *http_query(struct http_req *r, const char *name)
{
    struct http_first f = {name, NULL};
    r->io->query_each(r, http_first_cb, &f);
    return f.value;
}

void http_query_each(struct http_req *r, void (*fn)(void *u, const char *k, const char *v),
                     void *u)
{
    r->io->query_each(r, fn, u);
}

char *http_json_escape(const char *s, char *buf, size_t size)
{
    size_t n = 0;
    for (; s && *s && n + 7 < size; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\') {
            buf[n++] = '\\';
            buf[n++] = (char)c;
        } else if (c < 0x20 || c == 0x7f) {
            n += (size_t)snprintf(buf + n, size - n, "\\u%04x", c);
        } else {
            buf[n++] = (char)c;
        }
    }
    buf[n] = 0;
    return buf;
}

/* ---- replies ------------------------------------------------------------- */

bool http_list_next(const char **p, const char **item, size_t *len)
{
    const char *s = *p;
    while (*s == ' ' || *s == ',')
        s++;
    if (!*s)
        return false;
    const char *e = s;
    while (*e && *e != ',')
        e++;
    const char *end = e;
    while (end > s && end[-1] == ' ')
        end--;
    *item = s;
    *len = (size_t)(end - s);
    *p = e;
    return true;
}

/* Origin allowed by --cors-origin?  Returns the value for the header. */
static const char *http_cors_allowed(struct http_req *r)
{
    if (!config.cors_origin || !*config.cors_origin)
        return NULL;
    const char *origin = http_header(r, "Origin");
    if (!origin)
        return NULL;
    if (!strcmp(config.cors_origin, "*"))
        return "*";
    size_t ol = strlen(origin), n;
    const char *p = config.cors_origin, *item;
    while (http_list_next(&p, &item, &n))
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
    const char *origin = http_cors_allowed(r);
    if (origin) {
        MHD_add_response_header(resp, "Access-Control-Allow-Origin", origin);
        MHD_add_response_header(resp, "Access-Control-Expose-Headers",
                                "ETag, Location, Retry-After, Content-Length");
        if (strcmp(origin, "*"))
            MHD_add_response_header(resp, "Vary", "Origin");
    }
    MHD_add_response_header(resp, "X-Content-Type-Options", "nosniff");
    r->pending = resp;
    r->pending_status = status;
    r->status = (int)status;
    r->replied = true;
}

void http_add_header(struct http_req *r, const char *name, const char *value)
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

void http_reply_json(struct http_req *r, unsigned status, const char *json)
{
    http_reply_data(r, status, "application/json", json, strlen(json));
    if (status < 300)
        http_add_header(r, "Cache-Control", "no-store");
}

static void http_blob_free(void *cls) { blob_unref(cls); }

void http_reply_png(struct http_req *r, unsigned status, struct blob *png)
{
    /* the response holds one reference to the blob, dropped by libmicrohttpd */
    atomic_fetch_add(&png->refs, 1);
    struct MHD_Response *resp = MHD_create_response_from_buffer_with_free_callback_cls(
        png->len, png->data, http_blob_free, png);
    if (!resp) {
        blob_unref(png);
        r->gone = true;
        return;
    }
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, "image/png");
    r->bytes = png->len;
    r->is_png = true;
    http_reply(r, status, resp);
}

void http_reply_error(struct http_req *r, unsigned status, const char *code, const char *message,
                      const char *path, int line, int column, const char *param)
{
    char msg[600], pth[600], extra[700] = "", json[1600];
    http_json_escape(message, msg, sizeof msg);
    size_t n = 0;
    if (path && *path)
        n += (size_t)snprintf(extra + n, sizeof extra - n, ",\"path\":\"%s\"",
                              http_json_escape(path, pth, sizeof pth));
    if (line > 0 && n < sizeof extra)
        n += (size_t)snprintf(extra + n, sizeof extra - n, ",\"line\":%d,\"column\":%d", line,
                              column);
    if (param && *param && n < sizeof extra)
        snprintf(extra + n, sizeof extra - n, ",\"parameter\":\"%s\"",
                 http_json_escape(param, pth, sizeof pth));
    snprintf(json, sizeof json,
             "{\"error\":{\"status\":%u,\"code\":\"%s\",\"message\":\"%s\"%s}}\n", status, code,
             msg, extra);
    http_reply_data(r, status, "application/json", json, strlen(json));
    r->err_code = code;
    http_add_header(r, "Cache-Control", "no-store");
    if (status == 503)
        http_add_header(r, MHD_HTTP_HEADER_RETRY_AFTER, "1");
    if (status == 401)
        http_add_header(r, MHD_HTTP_HEADER_WWW_AUTHENTICATE, "Bearer realm=\"rayd\"");
    if (status == 413 && !r->body && r->body_len == 0)
        http_add_header(r, MHD_HTTP_HEADER_CONNECTION, "close");
}

/* The one mapping from a core status to HTTP. */
unsigned http_status_of(enum rayd_status s)
{
    switch (s) {
    case RAYD_OK: return 200;
    case RAYD_E_PARSE: return 400;
    case RAYD_E_INVALID: return 422;
    case RAYD_E_LIMIT: return 413;
    case RAYD_E_ARG: return 400;
    case RAYD_E_NOMEM: return 503;
    case RAYD_E_CANCELED: return 503;
    case RAYD_E_IO:
    case RAYD_E_INTERNAL:
    default: return 500;
    }
}

void http_reply_rayd_error(struct http_req *r, const struct rayd_error *err)
{
    unsigned st = http_status_of(err->code);
    const char *code = err->code == RAYD_E_CANCELED && http_is_draining()
                           ? "draining"
                           : rayd_status_name(err->code);
    http_reply_error(r, st, code, err->message[0] ? err->message : code, err->path,
                     err->code == RAYD_E_PARSE ? (err->line > 0 ? err->line : 1) : 0,
                     err->column, NULL);
}

void http_reply_refused(struct http_req *r, enum jobq_submit why)
{
    switch (why) {
    case JOBQ_FULL:
        metrics_reject(MR_QUEUE_FULL);
        http_reply_error(r, 503, "queue_full", "the render queue is full, retry later", NULL, 0, 0,
                         NULL);
        break;
    case JOBQ_DRAINING:
        metrics_reject(MR_DRAINING);
        http_reply_error(r, 503, "draining", "the server is shutting down", NULL, 0, 0, NULL);
        break;
    case JOBQ_TOO_MANY_JOBS:
        metrics_reject(MR_QUEUE_FULL);
        http_reply_error(r, 503, "queue_full", "too many unfinished jobs, retry later", NULL, 0,
                         0, NULL);
        break;
    case JOBQ_NOMEM:
    default:
        http_reply_error(r, 503, "out_of_memory", "out of memory", NULL, 0, 0, NULL);
        break;
    }
}

bool http_require_json(struct http_req *r)
{
    const char *ct = http_header(r, MHD_HTTP_HEADER_CONTENT_TYPE);
    if (ct) {
        while (*ct == ' ')
            ct++;
        size_t n = strlen("application/json");
        if (!strncasecmp(ct, "application/json", n) &&
            (ct[n] == 0 || ct[n] == ';' || ct[n] == ' '))
            return true;
    }
    http_reply_error(r, 415, "unsupported_media_type",
                     "the body must be a JSON scene sent with Content-Type: application/json",
                     NULL, 0, 0, NULL);
    return false;
}

/* ---- suspension ------------------------------------------------------------ */

/* r->parked is written and read only by the thread running the handler:
 * once a request is suspended and queued, a worker may answer and resume it
 * at any moment, so that thread must not look at anything else in r until
 * libmicrohttpd calls it again. */
void http_suspend(struct http_req *r)
{
    r->parked = true;
    r->suspended = true;
    atomic_fetch_add(&http_nsuspended, 1);
    r->io->suspend(r);
}

void http_resume(struct http_req *r)
{
    r->suspended = false;
    r->io->resume(r); /* for the harness, r may be gone after this */
    atomic_fetch_sub(&http_nsuspended, 1);
}

int http_conn_fd(struct http_req *r) { return r->io->fd(r); }

void http_cache_headers(struct http_req *r)
{
    if (r->etag[0]) {
        http_add_header(r, MHD_HTTP_HEADER_ETAG, r->etag);
        http_add_header(r, MHD_HTTP_HEADER_CACHE_CONTROL, "public, max-age=31536000, immutable");
    } else {
        http_add_header(r, MHD_HTTP_HEADER_CACHE_CONTROL, "no-store");
    }
}

/* The worker's answer to a suspended synchronous render. */
static void http_render_done(struct jobq_waiter *w, struct jobq_result *res)
{
    struct http_req *r = HTTP_CONTAINER(w);
    r->queue_ms = res->queue_ms;
    r->render_ms = res->render_ms;
    r->encode_ms = res->encode_ms;
    if (res->gone) {
        r->gone = true;
        r->note = "client_gone";
    } else if (res->status == RAYD_OK && res->png) {
        http_reply_png(r, 200, res->png);
        http_cache_headers(r);
    } else {
        struct rayd_error e = res->err;
        e.code = res->status;
        http_reply_rayd_error(r, &e);
    }
    blob_unref(res->png);
    http_resume(r);
}

static void http_render_suspend(struct jobq_waiter *w) { http_suspend(HTTP_CONTAINER(w)); }

void http_render(struct http_req *r, struct cache_entry *scene, const struct rayd_region *reg)
{
    struct blob *done = jobq_result_find(scene, reg);
    if (done) {
        http_reply_png(r, 200, done);
        http_cache_headers(r);
        blob_unref(done);
        r->note = "result_cache";
        return;
    }
    r->waiter.done = http_render_done;
    r->waiter.fd = http_conn_fd(r);
    enum jobq_submit s = jobq_render(scene, reg, &r->waiter, http_render_suspend);
    if (s != JOBQ_OK)
        http_reply_refused(r, s);
}

/* ---- the request flow (any transport) ------------------------------------------ */

/* Constant-time check of "Authorization: Bearer <token>". */
static bool http_authorized(struct http_req *r)
{
    if (!config.token)
        return true;
    const char *h = http_header(r, MHD_HTTP_HEADER_AUTHORIZATION);
    if (!h || strncasecmp(h, "Bearer ", 7))
        return false;
    h += 7;
    while (*h == ' ')
        h++;
    size_t hl = strlen(h);
    unsigned char diff = hl != config.token_len;
    for (size_t i = 0; i < config.token_len; i++)
        diff |= (unsigned char)(config.token[i] ^ (i < hl ? h[i] : 0));
    return diff == 0;
}

/* Routes open without a token: the probes, and the preview's own static
 * files (a browser cannot send a bearer token to open a page; the page then
 * sends the token it is given with every API call). */
static bool http_public_path(const char *method, const char *url)
{
    if (!strcmp(url, "/healthz") || !strcmp(url, "/readyz"))
        return true;
    if (strcmp(method, "GET") && strcmp(method, "HEAD"))
        return false;
    return !strcmp(url, "/") || (url[0] == '/' && !strchr(url + 1, '/') && api_web_exists(url + 1));
}

/* OPTIONS: CORS preflight or a plain Allow listing. */
static void http_options(struct http_req *r)
{
    char allow[128];
    if (!router_allow(r->url, allow, sizeof allow)) {
        http_reply_error(r, 404, "not_found", "no such resource", NULL, 0, 0, NULL);
        return;
    }
    struct MHD_Response *resp = MHD_create_response_from_buffer(0, NULL, MHD_RESPMEM_PERSISTENT);
    http_reply(r, 204, resp);
    http_add_header(r, MHD_HTTP_HEADER_ALLOW, allow);
    if (http_cors_allowed(r)) {
        http_add_header(r, "Access-Control-Allow-Methods", allow);
        http_add_header(r, "Access-Control-Allow-Headers", "Authorization, Content-Type, If-None-Match");
        http_add_header(r, "Access-Control-Max-Age", "600");
    }
}

struct http_req *http_req_new(const struct http_io *io, void *io_ctx, const char *method,
                              const char *url, size_t target_len)
{
    struct http_req *r = calloc(1, sizeof *r);
    if (!r)
        return NULL;
    r->io = io;
    r->io_ctx = io_ctx;
    r->method = method;
    r->url = url;
    r->target_len = target_len;
    r->t0 = log_now();
    r->route = -1;
    r->waiter.fd = -1;
    atomic_fetch_add(&http_ninflight, 1);
    atomic_store(&http_last_ms, (long)(r->t0 * 1000.0));
    return r;
}

/* Content-Length: digits only.  -1 absent, -2 malformed. */
static long long http_length_value(const char *cl)
{
    while (*cl == ' ' || *cl == '\t')
        cl++;
    unsigned long long n = 0;
    const char *p = cl;
    for (; *p >= '0' && *p <= '9'; p++)
        if (n <= 1000000000000000ULL)
            n = n * 10 + (unsigned)(*p - '0'); /* past 10^15 it is over any limit anyway */
    while (*p == ' ' || *p == '\t')
        p++;
    if (p == cl || *p)
        return -2;
    return (long long)n;
}

struct http_framing {
    int nlength, nte;
    long long length; /* the first Content-Length, -2 malformed */
    bool differ;      /* two Content-Length headers that disagree */
};

static void http_framing_cb(void *u, const char *k, const char *v)
{
    struct http_framing *f = u;
    if (!strcasecmp(k, MHD_HTTP_HEADER_CONTENT_LENGTH)) {
        long long n = http_length_value(v);
        if (f->nlength++ == 0)
            f->length = n;
        else if (n != f->length)
            f->differ = true;
    } else if (!strcasecmp(k, MHD_HTTP_HEADER_TRANSFER_ENCODING)) {
        f->nte++;
    }
}

bool http_req_begin(struct http_req *r)
{
    if (r->target_len > (size_t)config.max_url) {
        char msg[128];
        snprintf(msg, sizeof msg, "the request target is over the limit of %ld bytes (--max-url)",
                 config.max_url);
        http_reply_error(r, 414, "uri_too_long", msg, NULL, 0, 0, NULL);
        return false;
    }
    /* an ambiguous body length is how requests are smuggled past proxies:
     * refuse it rather than guess (RFC 9112 section 6.3) */
    struct http_framing f = {0, 0, -1, false};
    r->io->header_each(r, http_framing_cb, &f);
    if (f.differ || f.length == -2 || (f.nlength && f.nte) || f.nte > 1) {
        http_reply_error(r, 400, "bad_request",
                         f.nte && f.nlength ? "both Transfer-Encoding and Content-Length"
                         : f.nte > 1        ? "more than one Transfer-Encoding header"
                                            : "malformed or conflicting Content-Length",
                         NULL, 0, 0, NULL);
        http_add_header(r, MHD_HTTP_HEADER_CONNECTION, "close");
        return false;
    }
    if (f.nlength && f.length > config.max_body) {
        metrics_reject(MR_BODY_TOO_LARGE);
        char msg[128];
        snprintf(msg, sizeof msg, "the body is over the limit of %ld bytes (--max-body)",
                 config.max_body);
        http_reply_error(r, 413, "body_too_large", msg, NULL, 0, 0, NULL);
        return false;
    }
    return true;
}

bool http_req_body(struct http_req *r, const char *data, size_t n)
{
    /* --timeout drops an idle connection, but a client that sends a byte now
     * and then is never idle: the whole body gets --upload-seconds */
    if (config.upload_seconds > 0 && log_now() - r->t0 > (double)config.upload_seconds) {
        r->note = "upload_too_slow";
        return false;
    }
    if (r->too_large || r->no_memory) {
        r->body_len += n; /* counted, not kept */
        return r->body_len <= 4 * (size_t)config.max_body;
    }
    if (r->body_len + n > (size_t)config.max_body) {
        r->too_large = true;
        free(r->body);
        r->body = NULL;
        r->body_cap = 0;
        r->body_len += n;
        return true;
    }
    if (r->body_len + n + 1 > r->body_cap) {
        size_t cap = r->body_cap ? r->body_cap : 4096;
        while (cap < r->body_len + n + 1)
            cap *= 2;
        char *b = realloc(r->body, cap);
        if (!b) {
            /* read the rest without keeping it, then answer 503 */
            r->no_memory = true;
            free(r->body);
            r->body = NULL;
            r->body_cap = 0;
            r->body_len += n;
            return true;
        }
        r->body = b;
        r->body_cap = cap;
    }
    memcpy(r->body + r->body_len, data, n);
    r->body_len += n;
    r->body[r->body_len] = 0;
    return true;
}

void http_req_handle(struct http_req *r)
{
    if (r->body_len > 0)
        metrics_stage(MS_UPLOAD, log_now() - r->t0);
    if (r->too_large) {
        metrics_reject(MR_BODY_TOO_LARGE);
        http_reply_error(r, 413, "body_too_large", "the body is over the limit (--max-body)", NULL,
                         0, 0, NULL);
        return;
    }
    if (r->no_memory) {
        http_reply_error(r, 503, "out_of_memory", "out of memory reading the body", NULL, 0, 0,
                         NULL);
        return;
    }
    if (!strcmp(r->method, "OPTIONS")) {
        http_options(r);
    } else if (!http_public_path(r->method, r->url) && !http_authorized(r)) {
        metrics_reject(MR_UNAUTHORIZED);
        http_reply_error(r, 401, "unauthorized", "missing or wrong bearer token", NULL, 0, 0,
                         NULL);
    } else {
        r->parked = false;
        router_dispatch(r);
        if (r->parked)
            return; /* r now belongs to the worker until it resumes */
    }
    if (!r->pending && !r->gone)
        http_reply_error(r, 500, "internal", "the handler gave no answer", NULL, 0, 0, NULL);
}

void http_req_end(struct http_req *r, const char *note)
{
    if (!r->method) {
        /* refused by libmicrohttpd before the handler saw it (bad headers,
         * headers over --max-header-bytes): it answered by itself */
        struct log_access a = {"-", "-", 0, 0, 0, 0, 0, (log_now() - r->t0) * 1e3,
                               "refused_by_http_parser"};
        log_access(&a);
        free(r);
        atomic_fetch_sub(&http_ninflight, 1);
        return;
    }
    int status = r->status;
    if (r->note)
        note = r->note;
    if (r->gone || !r->replied) {
        status = 499;
        if (!note)
            note = "client_gone";
    }
    metrics_request(r->route, status);
    if (r->is_png && r->t_sent > 0 && status == 200)
        metrics_stage(MS_SEND, log_now() - r->t_sent);
    struct log_access a = {r->method,    r->url,       status,
                           r->bytes,     r->queue_ms,  r->render_ms,
                           r->encode_ms, (log_now() - r->t0) * 1e3, note};
    log_access(&a);
    if (r->sse)
        jobq_sse_close(r->sse);
    if (r->pending)
        MHD_destroy_response(r->pending);
    free(r->body);
    free(r);
    atomic_fetch_sub(&http_ninflight, 1);
}

/* ---- libmicrohttpd as the transport ---------------------------------------------- */

static const char *http_mhd_header(struct http_req *r, const char *name)
{
    return MHD_lookup_connection_value(r->io_ctx, MHD_HEADER_KIND, name);
}

struct http_each {
    void (*fn)(void *u, const char *k, const char *v);
    void *u;
};

static enum MHD_Result http_each_cb(void *cls, enum MHD_ValueKind kind, const char *key,
                                    const char *value)
{
    (void)kind;
    struct http_each *e = cls;
    e->fn(e->u, key, value ? value : "");
    return MHD_YES;
}

/* Query arguments arrive percent-decoded, so "x=1%00junk" would read as "1"
 * through a C string: a key or value with a NUL byte inside is passed as the
 * text "\\0", which no parameter name or number matches. */
static enum MHD_Result http_each_n_cb(void *cls, enum MHD_ValueKind kind, const char *key,
                                      size_t key_size, const char *value, size_t value_size)
{
    (void)kind;
    struct http_each *e = cls;
    if (!value)
        value = "";
    if (strlen(key) != key_size)
        key = "\\0";
    if (strlen(value) != value_size)
        value = "\\0";
    e->fn(e->u, key, value);
    return MHD_YES;
}

static void http_mhd_query_each(struct http_req *r,
                                void (*fn)(void *u, const char *k, const char *v), void *u)
{
    struct http_each e = {fn, u};
    MHD_get_connection_values_n(r->io_ctx, MHD_GET_ARGUMENT_KIND, http_each_n_cb, &e);
}

static void http_mhd_header_each(struct http_req *r,
                                 void (*fn)(void *u, const char *k, const char *v), void *u)
{
    struct http_each e = {fn, u};
    MHD_get_connection_values(r->io_ctx, MHD_HEADER_KIND, http_each_cb, &e);
}

static void http_mhd_suspend(struct http_req *r) { MHD_suspend_connection(r->io_ctx); }
static void http_mhd_resume(struct http_req *r) { MHD_resume_connection(r->io_ctx); }

static int http_mhd_fd(struct http_req *r)
{
    const union MHD_ConnectionInfo *ci =
        MHD_get_connection_info(r->io_ctx, MHD_CONNECTION_INFO_CONNECTION_FD);
    return ci ? ci->connect_fd : -1;
}

static const struct http_io http_mhd_io = {http_mhd_header,  http_mhd_header_each,
                                           http_mhd_query_each, http_mhd_suspend,
                                           http_mhd_resume, http_mhd_fd};

static enum MHD_Result http_flush(struct http_req *r)
{
    if (r->gone || !r->pending)
        return MHD_NO;
    r->t_sent = log_now();
    enum MHD_Result ret = MHD_queue_response(r->io_ctx, r->pending_status, r->pending);
    MHD_destroy_response(r->pending);
    r->pending = NULL;
    return ret;
}

/* Called by libmicrohttpd with the raw request-target before it is parsed;
 * the request is born here (so its length is known: --max-url), and from
 * then on libmicrohttpd promises the completion callback, which frees it. */
static void *http_uri_log(void *cls, const char *uri, struct MHD_Connection *c)
{
    (void)cls;
    return http_req_new(&http_mhd_io, c, NULL, NULL, uri ? strlen(uri) : 0);
}

static enum MHD_Result http_access(void *cls, struct MHD_Connection *c, const char *url,
                                   const char *method, const char *version, const char *upload,
                                   size_t *upload_size, void **con_cls)
{
    (void)cls;
    (void)c;
    (void)version;
    struct http_req *r = *con_cls;
    if (!r) /* out of memory in http_uri_log */
        return MHD_NO;
    if (!r->method) {
        /* first call: headers only */
        r->method = method;
        r->url = url;
        return http_req_begin(r) ? MHD_YES : http_flush(r);
    }
    if (r->gone)
        return MHD_NO;
    if (r->pending) /* resumed with an answer, or replied during the upload */
        return http_flush(r);
    if (r->replied)
        return MHD_YES;
    if (*upload_size) {
        size_t n = *upload_size;
        *upload_size = 0;
        return http_req_body(r, upload, n) ? MHD_YES : MHD_NO;
    }
    /* the whole request is here */
    http_req_handle(r);
    if (r->parked)
        return MHD_YES;
    return http_flush(r);
}

static void http_completed(void *cls, struct MHD_Connection *c, void **con_cls,
                           enum MHD_RequestTerminationCode toe)
{
    (void)cls;
    (void)c;
    struct http_req *r = *con_cls;
    *con_cls = NULL;
    if (!r)
        return;
    const char *note = NULL;
    if (toe != MHD_REQUEST_TERMINATED_COMPLETED_OK)
        note = toe == MHD_REQUEST_TERMINATED_TIMEOUT_REACHED ? "timeout"
               : toe == MHD_REQUEST_TERMINATED_DAEMON_SHUTDOWN ? "shutdown"
                                                                : "aborted";
    http_req_end(r, note);
}

/* libmicrohttpd's own messages (malformed requests, ...) go through log.c so
 * --log-format json keeps every stderr line JSON. */
static void http_mhd_log(void *cls, const char *fmt, va_list ap) __attribute__((format(printf, 2, 0)));
static void http_mhd_log(void *cls, const char *fmt, va_list ap)
{
    (void)cls;
    char msg[512];
    vsnprintf(msg, sizeof msg, fmt, ap);
    size_t n = strlen(msg);
    while (n > 0 && (msg[n - 1] == '\n' || msg[n - 1] == '\r'))
        msg[--n] = 0;
    log_warn("http: %s", msg);
}

/* ---- start / stop --------------------------------------------------------------- */

/* Reads a whole (small) file: the TLS key and certificate. */
static char *http_read_pem(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "rayd: %s: %s\n", path, strerror(errno));
        return NULL;
    }
    size_t cap = 1 << 20, n;
    char *buf = malloc(cap + 1);
    if (!buf) {
        fclose(f);
        return NULL;
    }
    n = fread(buf, 1, cap, f);
    fclose(f);
    buf[n] = 0;
    if (n == 0 || n == cap) {
        fprintf(stderr, "rayd: %s: empty or over 1 MiB\n", path);
        free(buf);
        return NULL;
    }
    return buf;
}

static char *http_tls_cert, *http_tls_key;

bool http_tls(void) { return http_tls_cert != NULL; }

/* The number of open files allowed, raised to the hard limit: every
 * connection is a descriptor, and --max-conns is capped to what fits. */
static long http_fd_budget(void)
{
    struct rlimit rl;
    if (getrlimit(RLIMIT_NOFILE, &rl))
        return 1024;
    if (rl.rlim_cur < rl.rlim_max) {
        struct rlimit want = {rl.rlim_max, rl.rlim_max};
        if (!setrlimit(RLIMIT_NOFILE, &want))
            rl.rlim_cur = rl.rlim_max;
    }
    return rl.rlim_cur == RLIM_INFINITY || rl.rlim_cur > 100000000 ? 100000000 : (long)rl.rlim_cur;
}

int http_start(void)
{
    struct sockaddr_storage ss;
    memset(&ss, 0, sizeof ss);
    unsigned flags = MHD_USE_INTERNAL_POLLING_THREAD | MHD_USE_EPOLL | MHD_ALLOW_SUSPEND_RESUME |
                     MHD_USE_ERROR_LOG;
    struct sockaddr_in *s4 = (struct sockaddr_in *)&ss;
    struct sockaddr_in6 *s6 = (struct sockaddr_in6 *)&ss;
    if (inet_pton(AF_INET, config.bind, &s4->sin_addr) == 1) {
        s4->sin_family = AF_INET;
        s4->sin_port = htons((uint16_t)config.port);
    } else if (inet_pton(AF_INET6, config.bind, &s6->sin6_addr) == 1) {
        s6->sin6_family = AF_INET6;
        s6->sin6_port = htons((uint16_t)config.port);
        flags |= MHD_USE_IPv6;
    } else {
        fprintf(stderr, "rayd: --bind %s: not an IPv4 or IPv6 address\n", config.bind);
        return -1;
    }
    /* descriptors: the connections, plus the listener, epoll sets, inter-thread
     * channels, stdio and the odd file -- 64 is plenty */
    long fds = http_fd_budget();
    long conns = config.max_conns;
    if (conns > fds - 64) {
        conns = fds - 64 > 16 ? fds - 64 : 16;
        log_warn("--max-conns %ld lowered to %ld: the open-file limit is %ld (ulimit -n)",
                 config.max_conns, conns, fds);
    }
    struct MHD_OptionItem opts[24];
    int n = 0;
#define HTTP_OPT(o, v, p) opts[n++] = (struct MHD_OptionItem){(o), (intptr_t)(v), (p)}
    HTTP_OPT(MHD_OPTION_EXTERNAL_LOGGER, (intptr_t)http_mhd_log, NULL);
    HTTP_OPT(MHD_OPTION_SOCK_ADDR, 0, &ss);
    HTTP_OPT(MHD_OPTION_THREAD_POOL_SIZE, config.http_threads, NULL);
    HTTP_OPT(MHD_OPTION_CONNECTION_TIMEOUT, config.timeout, NULL);
    HTTP_OPT(MHD_OPTION_NOTIFY_COMPLETED, (intptr_t)http_completed, NULL);
    HTTP_OPT(MHD_OPTION_URI_LOG_CALLBACK, (intptr_t)http_uri_log, NULL);
    HTTP_OPT(MHD_OPTION_CONNECTION_LIMIT, conns, NULL);
    HTTP_OPT(MHD_OPTION_PER_IP_CONNECTION_LIMIT, config.max_conns_per_ip, NULL);
    HTTP_OPT(MHD_OPTION_CONNECTION_MEMORY_LIMIT, config.max_header_bytes, NULL);
    HTTP_OPT(MHD_OPTION_LISTEN_BACKLOG_SIZE, 1024, NULL);
    /* strict parsing: HTTP/1.1 needs Host, no spaces inside the target, no
     * whitespace before a header's colon (RFC 9112) */
    HTTP_OPT(MHD_OPTION_STRICT_FOR_CLIENT, 1, NULL);
    if (config.tls_cert) {
        if (MHD_is_feature_supported(MHD_FEATURE_TLS) != MHD_YES) {
            fprintf(stderr, "rayd: this libmicrohttpd has no TLS support (--tls-cert)\n");
            return -1;
        }
        http_tls_cert = http_read_pem(config.tls_cert);
        http_tls_key = http_tls_cert ? http_read_pem(config.tls_key) : NULL;
        if (!http_tls_key) {
            free(http_tls_cert);
            http_tls_cert = NULL;
            return -1;
        }
        flags |= MHD_USE_TLS;
        HTTP_OPT(MHD_OPTION_HTTPS_MEM_CERT, 0, http_tls_cert);
        HTTP_OPT(MHD_OPTION_HTTPS_MEM_KEY, 0, http_tls_key);
    }
    HTTP_OPT(MHD_OPTION_END, 0, NULL);
#undef HTTP_OPT
    http_daemon = MHD_start_daemon(flags, (uint16_t)config.port, NULL, NULL, http_access, NULL,
                                   MHD_OPTION_ARRAY, opts, MHD_OPTION_END);
    if (!http_daemon) {
        fprintf(stderr, "rayd: cannot listen on %s port %ld%s\n", config.bind, config.port,
                config.tls_cert ? " (or the TLS key/certificate was refused)" : "");
        http_stop();
        return -1;
    }
    const union MHD_DaemonInfo *di = MHD_get_daemon_info(http_daemon, MHD_DAEMON_INFO_BIND_PORT);
    http_bound_port = di ? di->port : (int)config.port;
    return 0;
}

void http_stop(void)
{
    if (http_daemon)
        MHD_stop_daemon(http_daemon);
    http_daemon = NULL;
    if (http_tls_key)
        memset(http_tls_key, 0, strlen(http_tls_key));
    free(http_tls_key);
    free(http_tls_cert);
    http_tls_key = http_tls_cert = NULL;
}
