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
#include <microhttpd.h>
#include <netinet/in.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

#define HTTP_CONTAINER(w) ((struct http_req *)((char *)(w) - offsetof(struct http_req, waiter)))

static struct MHD_Daemon *http_daemon;
static atomic_long http_nsuspended, http_ninflight;
static atomic_bool http_drain_flag;
static int http_bound_port;

long http_suspended(void) { return atomic_load(&http_nsuspended); }
long http_in_flight(void) { return atomic_load(&http_ninflight); }
bool http_is_draining(void) { return atomic_load(&http_drain_flag); }
void http_set_draining(void) { atomic_store(&http_drain_flag, true); }
int http_port(void) { return http_bound_port; }

const char *http_header(struct http_req *r, const char *name)
{
    return MHD_lookup_connection_value(r->conn, MHD_HEADER_KIND, name);
}

const char *http_query(struct http_req *r, const char *name)
{
    return MHD_lookup_connection_value(r->conn, MHD_GET_ARGUMENT_KIND, name);
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

void http_query_each(struct http_req *r, void (*fn)(void *u, const char *k, const char *v),
                     void *u)
{
    struct http_each e = {fn, u};
    MHD_get_connection_values(r->conn, MHD_GET_ARGUMENT_KIND, http_each_cb, &e);
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
    size_t ol = strlen(origin);
    for (const char *p = config.cors_origin; *p;) {
        while (*p == ' ' || *p == ',')
            p++;
        const char *e = p;
        while (*e && *e != ',')
            e++;
        const char *end = e;
        while (end > p && end[-1] == ' ')
            end--;
        if ((size_t)(end - p) == ol && ol && !memcmp(p, origin, ol))
            return origin;
        p = e;
    }
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

void http_suspend(struct http_req *r)
{
    r->suspended = true;
    atomic_fetch_add(&http_nsuspended, 1);
    MHD_suspend_connection(r->conn);
}

void http_resume(struct http_req *r)
{
    r->suspended = false;
    MHD_resume_connection(r->conn);
    atomic_fetch_sub(&http_nsuspended, 1);
}

int http_conn_fd(struct http_req *r)
{
    const union MHD_ConnectionInfo *ci =
        MHD_get_connection_info(r->conn, MHD_CONNECTION_INFO_CONNECTION_FD);
    return ci ? ci->connect_fd : -1;
}

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

/* ---- the access handler ------------------------------------------------------ */

static enum MHD_Result http_flush(struct http_req *r)
{
    if (r->gone || !r->pending)
        return MHD_NO;
    enum MHD_Result ret = MHD_queue_response(r->conn, r->pending_status, r->pending);
    MHD_destroy_response(r->pending);
    r->pending = NULL;
    return ret;
}

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

static bool http_public_path(const char *url)
{
    return !strcmp(url, "/healthz") || !strcmp(url, "/readyz");
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

static enum MHD_Result http_access(void *cls, struct MHD_Connection *c, const char *url,
                                   const char *method, const char *version, const char *upload,
                                   size_t *upload_size, void **con_cls)
{
    (void)cls;
    (void)version;
    struct http_req *r = *con_cls;
    if (!r) {
        r = calloc(1, sizeof *r);
        if (!r)
            return MHD_NO;
        r->conn = c;
        r->method = method;
        r->url = url;
        r->t0 = log_now();
        r->route = -1;
        r->waiter.fd = -1;
        *con_cls = r;
        atomic_fetch_add(&http_ninflight, 1);
        const char *cl = MHD_lookup_connection_value(c, MHD_HEADER_KIND,
                                                     MHD_HTTP_HEADER_CONTENT_LENGTH);
        if (cl) {
            char *end;
            unsigned long long n = strtoull(cl, &end, 10);
            if (end != cl && n > (unsigned long long)config.max_body) {
                metrics_reject(MR_BODY_TOO_LARGE);
                char msg[128];
                snprintf(msg, sizeof msg, "the body is over the limit of %ld bytes (--max-body)",
                         config.max_body);
                http_reply_error(r, 413, "body_too_large", msg, NULL, 0, 0, NULL);
                return http_flush(r);
            }
        }
        return MHD_YES;
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
        if (r->too_large) {
            r->body_len += n; /* counted, not kept */
            return r->body_len > 4 * (size_t)config.max_body ? MHD_NO : MHD_YES;
        }
        if (r->body_len + n > (size_t)config.max_body) {
            r->too_large = true;
            free(r->body);
            r->body = NULL;
            r->body_len += n;
            return MHD_YES;
        }
        if (r->body_len + n + 1 > r->body_cap) {
            size_t cap = r->body_cap ? r->body_cap : 4096;
            while (cap < r->body_len + n + 1)
                cap *= 2;
            char *b = realloc(r->body, cap);
            if (!b)
                return MHD_NO;
            r->body = b;
            r->body_cap = cap;
        }
        memcpy(r->body + r->body_len, upload, n);
        r->body_len += n;
        r->body[r->body_len] = 0;
        return MHD_YES;
    }
    /* the whole request is here */
    if (r->too_large) {
        metrics_reject(MR_BODY_TOO_LARGE);
        http_reply_error(r, 413, "body_too_large", "the body is over the limit (--max-body)", NULL,
                         0, 0, NULL);
        return http_flush(r);
    }
    if (!strcmp(method, "OPTIONS")) {
        http_options(r);
    } else if (!http_public_path(url) && !http_authorized(r)) {
        metrics_reject(MR_UNAUTHORIZED);
        http_reply_error(r, 401, "unauthorized", "missing or wrong bearer token", NULL, 0, 0,
                         NULL);
    } else {
        router_dispatch(r);
    }
    if (r->suspended)
        return MHD_YES;
    if (!r->pending && !r->gone)
        http_reply_error(r, 500, "internal", "the handler gave no answer", NULL, 0, 0, NULL);
    return http_flush(r);
}

static void http_completed(void *cls, struct MHD_Connection *c, void **con_cls,
                           enum MHD_RequestTerminationCode toe)
{
    (void)cls;
    (void)c;
    struct http_req *r = *con_cls;
    if (!r)
        return;
    *con_cls = NULL;
    int status = r->status;
    const char *note = r->note;
    if (r->gone || !r->replied) {
        status = 499;
        if (!note)
            note = "client_gone";
    } else if (toe != MHD_REQUEST_TERMINATED_COMPLETED_OK && !note) {
        note = toe == MHD_REQUEST_TERMINATED_TIMEOUT_REACHED ? "timeout"
               : toe == MHD_REQUEST_TERMINATED_DAEMON_SHUTDOWN ? "shutdown"
                                                                : "aborted";
    }
    metrics_request(r->route, status);
    struct log_access a = {r->method, r->url, status, r->bytes, r->queue_ms, r->render_ms,
                           (log_now() - r->t0) * 1e3, note};
    log_access(&a);
    if (r->sse)
        jobq_sse_close(r->sse);
    if (r->pending)
        MHD_destroy_response(r->pending);
    free(r->body);
    free(r);
    atomic_fetch_sub(&http_ninflight, 1);
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
    http_daemon = MHD_start_daemon(
        flags, (uint16_t)config.port, NULL, NULL, http_access, NULL, MHD_OPTION_EXTERNAL_LOGGER,
        http_mhd_log, NULL, MHD_OPTION_SOCK_ADDR,
        (struct sockaddr *)&ss, MHD_OPTION_THREAD_POOL_SIZE, (unsigned)config.http_threads,
        MHD_OPTION_CONNECTION_TIMEOUT, (unsigned)config.timeout, MHD_OPTION_NOTIFY_COMPLETED,
        http_completed, NULL, MHD_OPTION_CONNECTION_LIMIT, 4096u, MHD_OPTION_LISTEN_BACKLOG_SIZE,
        1024u, MHD_OPTION_END);
    if (!http_daemon) {
        fprintf(stderr, "rayd: cannot listen on %s port %ld\n", config.bind, config.port);
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
}
