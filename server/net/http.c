/* http.c -- libmicrohttpd as the transport: sockets in, responses out.
 *
 * libmicrohttpd runs its own threads (an epoll loop per thread of a small
 * pool).  They parse HTTP, collect the body and run the request flow
 * (http_flow.c), and never render: a request that needs a render is handed
 * to the work layer and its connection is *suspended*; the worker that
 * finishes the render stores the response in the request and *resumes* the
 * connection, and libmicrohttpd calls the access handler once more, which
 * queues the stored response.  The suspension always happens before the
 * request is linked to its task, so a resume can never overtake it.
 *
 * This file is only the glue: the struct http_io that lets the layers below
 * read headers and suspend a connection without naming libmicrohttpd's
 * connection type, the access and completion callbacks that call the flow,
 * the daemon's options (connection limits, timeouts, TLS) from config, and
 * the connection notices that put each connection's headers under
 * --header-seconds' watch (http_deadline.c) and take it off.
 *
 * Requests libmicrohttpd refuses by itself, with an error page of its own,
 * are seen three ways.  Each refusal is one message to the external logger
 * ("Error processing request (HTTP response code is 431 ...)"): the only
 * hook that sees them all, so it counts them (rayd_rejections_total
 * {reason="http_parser"}), but it names no connection.  One whose target
 * was read (headers over --max-header-bytes, a bad Content-Length or chunk)
 * then reaches the completion callback, which asks libmicrohttpd for the
 * status it queued (MHD_CONNECTION_INFO_HTTP_STATUS).  One refused on its
 * request line (over --max-header-bytes: 414, a bad line: 400, an unknown
 * version: 505) never becomes a request: libmicrohttpd closes the
 * connection next, in the thread that logged, so the status is kept per
 * thread until that connection's close (MHD_OPTION_NOTIFY_CONNECTION) or a
 * completion takes it.  A line libmicrohttpd drops without a message (a
 * space inside the target, bytes that are not HTTP) is seen by no hook.
 *
 * The operator sees one line per refusal, rayd's access line, with the
 * status and the reason: the title of libmicrohttpd's error page as a code
 * ("Request too big": request_too_big) in its error field.  libmicrohttpd's
 * own message, and the one it writes just before some refusals ("Received
 * HTTP/1.1 request without `Host' header."), say nothing more and go to
 * debug; its other messages stay warnings.
 */
#include "net/transport.h"

#include <arpa/inet.h>
#include <errno.h>
#include <microhttpd.h>
#include <netinet/in.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

static struct MHD_Daemon *http_daemon;
static int http_bound_port;

int http_port(void) { return http_bound_port; }

/* ---- libmicrohttpd as the transport ---------------------------------------------- */

static const char *http_mhd_header(struct http_req *r, const char *name) {
    return MHD_lookup_connection_value(r->conn.io_ctx, MHD_HEADER_KIND, name);
}

struct http_each {
    void (*fn)(void *u, const char *k, const char *v);
    void *u;
};

static enum MHD_Result http_each_cb(void *cls, enum MHD_ValueKind kind, const char *key,
                                    const char *value) {
    (void)kind;
    struct http_each *e = cls;
    e->fn(e->u, key, value ? value : "");
    return MHD_YES;
}

/* Query arguments arrive percent-decoded, so "x=1%00junk" would read as "1"
 * through a C string: a key or value with a NUL byte inside is passed as the
 * text "\\0", which no parameter name or number matches. */
static enum MHD_Result http_each_n_cb(void *cls, enum MHD_ValueKind kind, const char *key,
                                      size_t key_size, const char *value, size_t value_size) {
    (void)kind;
    struct http_each *e = cls;
    if (!value) value = "";
    if (strlen(key) != key_size) key = "\\0";
    if (strlen(value) != value_size) value = "\\0";
    e->fn(e->u, key, value);
    return MHD_YES;
}

static void http_mhd_query_each(struct http_req *r,
                                void (*fn)(void *u, const char *k, const char *v), void *u) {
    struct http_each e = {fn, u};
    MHD_get_connection_values_n(r->conn.io_ctx, MHD_GET_ARGUMENT_KIND, http_each_n_cb, &e);
}

static void http_mhd_header_each(struct http_req *r,
                                 void (*fn)(void *u, const char *k, const char *v), void *u) {
    struct http_each e = {fn, u};
    MHD_get_connection_values(r->conn.io_ctx, MHD_HEADER_KIND, http_each_cb, &e);
}

static void http_mhd_suspend(struct http_req *r) { MHD_suspend_connection(r->conn.io_ctx); }
static void http_mhd_resume(struct http_req *r) { MHD_resume_connection(r->conn.io_ctx); }

static int http_mhd_fd(struct http_req *r) {
    const union MHD_ConnectionInfo *ci =
        MHD_get_connection_info(r->conn.io_ctx, MHD_CONNECTION_INFO_CONNECTION_FD);
    return ci ? ci->connect_fd : -1;
}

/* The peer's address as text ("127.0.0.1", "::1"), for the access log. */
static void http_client_address(struct MHD_Connection *c, char *buf, size_t size) {
    const union MHD_ConnectionInfo *ci =
        MHD_get_connection_info(c, MHD_CONNECTION_INFO_CLIENT_ADDRESS);
    const struct sockaddr *sa = ci ? ci->client_addr : NULL;
    buf[0] = 0;
    if (sa && sa->sa_family == AF_INET)
        inet_ntop(AF_INET, &((const struct sockaddr_in *)(const void *)sa)->sin_addr, buf,
                  (socklen_t)size);
    else if (sa && sa->sa_family == AF_INET6)
        inet_ntop(AF_INET6, &((const struct sockaddr_in6 *)(const void *)sa)->sin6_addr, buf,
                  (socklen_t)size);
}

static const struct http_io http_mhd_io = {http_mhd_header,     http_mhd_header_each,
                                           http_mhd_query_each, http_mhd_suspend,
                                           http_mhd_resume,     http_mhd_fd};

/* Set by http_drop in the thread that returns MHD_NO for a request whose
 * client left, or whose upload rayd stops (too slow, or ended short):
 * libmicrohttpd then says "Application reported internal error", which is
 * no error of rayd's (the access log has the request, a 499 with its
 * note), so that line goes to debug. */
static _Thread_local bool http_dropped;

/* The status of libmicrohttpd's last own error answer in this thread, and
 * its reason (http_mhd_refusal), until the refused request's completion or
 * its connection's close takes them. */
static _Thread_local unsigned http_refused;
static _Thread_local char http_refused_why[HTTP_REFUSED_WHY];

/* The error status libmicrohttpd queued on c by itself, 0 if none (or if
 * this libmicrohttpd cannot say: then the one its message named); its
 * reason into why ("" when this thread's message was not about it). */
static unsigned http_refused_status(struct MHD_Connection *c, char *why, size_t size) {
#if MHD_VERSION >= 0x00097400
    const union MHD_ConnectionInfo *ci =
        MHD_get_connection_info(c, MHD_CONNECTION_INFO_HTTP_STATUS);
    unsigned st = ci && ci->http_status >= 400 ? ci->http_status : 0;
#else
    (void)c;
    unsigned st = http_refused;
#endif
    snprintf(why, size, "%s", st && st == http_refused ? http_refused_why : "");
    if (st) {
        http_refused = 0;
        http_refused_why[0] = 0;
    }
    return st;
}

static enum MHD_Result http_drop(void) {
    http_dropped = true;
    return MHD_NO;
}

/* ---- replies: struct http_reply as libmicrohttpd's response ------------------- */

/* An image's body is handed to libmicrohttpd as it asks for it (a copy
 * of a block at a time, instead of the buffer whole), so the request knows
 * how much went out: the access line of an answer the client stopped
 * reading says so (r->log.body_taken).  The reader runs only while the answer
 * is sent, before the completion that frees r. */
struct http_blob_body {
    struct blob *img;
    struct http_req *r;
};

static ssize_t http_blob_read(void *cls, uint64_t pos, char *buf, size_t max) {
    struct http_blob_body *b = cls;
    if (pos >= b->img->len) return MHD_CONTENT_READER_END_OF_STREAM;
    size_t n = b->img->len - (size_t)pos < max ? b->img->len - (size_t)pos : max;
    memcpy(buf, (const char *)b->img->data + pos, n);
    if ((size_t)pos + n > b->r->log.body_taken) b->r->log.body_taken = (size_t)pos + n;
    return (ssize_t)n;
}

static void http_blob_free(void *cls) {
    struct http_blob_body *b = cls;
    blob_unref(b->img);
    free(b);
}

/* A stream's read and done, taken from its reply. */
struct http_stream_body {
    ssize_t (*read)(void *cls, char *buf, size_t max);
    void (*done)(void *cls);
    void *cls;
};

static ssize_t http_stream_read(void *cls, uint64_t pos, char *buf, size_t max) {
    (void)pos;
    struct http_stream_body *s = cls;
    ssize_t n = s->read(s->cls, buf, max);
    return n == HTTP_STREAM_END     ? MHD_CONTENT_READER_END_OF_STREAM
           : n == HTTP_STREAM_ERROR ? MHD_CONTENT_READER_END_WITH_ERROR
                                    : n;
}

static void http_stream_free(void *cls) {
    struct http_stream_body *s = cls;
    s->done(s->cls);
    free(s);
}

/* The body of a 304: none (never called for a 304, which sends no body). */
static ssize_t http_no_body(void *cls, uint64_t pos, char *buf, size_t max) {
    (void)cls;
    (void)pos;
    (void)buf;
    (void)max;
    return MHD_CONTENT_READER_END_OF_STREAM;
}

/* A response with no body and neither Content-Length nor chunking.
 * libmicrohttpd (0.9.75 as in Debian 12, and later) writes
 * "Content-Length: <size of the response's body>" on a 304, so an empty
 * buffer would say 0, and a body of unknown size would say
 * "Transfer-Encoding: chunked"; a body of unknown size under
 * MHD_RF_HTTP_1_0_COMPATIBLE_STRICT writes neither.  The price is that
 * libmicrohttpd then closes the connection after it ("Connection: close"),
 * one new connection per revalidation. */
static struct MHD_Response *http_bodiless(void) {
    struct MHD_Response *resp =
        MHD_create_response_from_callback(MHD_SIZE_UNKNOWN, 64, http_no_body, NULL, NULL);
    if (resp &&
        MHD_set_response_options(resp, MHD_RF_HTTP_1_0_COMPATIBLE_STRICT, MHD_RO_END) != MHD_YES) {
        MHD_destroy_response(resp);
        resp = NULL;
    }
    return resp;
}

/* p's body as libmicrohttpd's response, which takes what p held (its
 * bytes, blob or stream); NULL on no memory. */
static struct MHD_Response *http_body(struct http_req *r, struct http_reply *p) {
    struct MHD_Response *resp = NULL;
    if (p->kind == HTTP_BODY_BYTES) {
        resp = MHD_create_response_from_buffer_with_free_callback(p->len, p->data, free);
        if (resp) p->data = NULL;
    } else if (p->kind == HTTP_BODY_BLOB) {
        struct http_blob_body *b = malloc(sizeof *b);
        resp = b ? MHD_create_response_from_callback(p->blob->len, 64 * 1024, http_blob_read, b,
                                                     http_blob_free)
                 : NULL;
        if (resp) {
            *b = (struct http_blob_body){p->blob, r};
            p->blob = NULL;
        } else {
            free(b);
        }
    } else if (p->kind == HTTP_BODY_STREAM) {
        struct http_stream_body *s = malloc(sizeof *s);
        resp = s ? MHD_create_response_from_callback(MHD_SIZE_UNKNOWN, p->block, http_stream_read,
                                                     s, http_stream_free)
                 : NULL;
        if (resp) {
            *s = (struct http_stream_body){p->read, p->done, p->cls};
            p->done = NULL;
        } else {
            free(s);
        }
    } else {
        resp = http_bodiless();
    }
    return resp;
}

/* r's reply as libmicrohttpd's response: its body, then its headers in
 * the order they were added. */
static struct MHD_Response *http_response(struct http_req *r, struct http_reply *p) {
    struct MHD_Response *resp = http_body(r, p);
    for (size_t i = 0; resp && i < p->nheaders; i++)
        MHD_add_response_header(resp, p->headers[i].name, p->headers[i].value);
    return resp;
}

static enum MHD_Result http_flush(struct http_req *r) {
    if (r->gone) return http_drop();
    if (!r->conn.pending) return MHD_NO;
    struct http_reply *p = r->conn.pending;
    r->conn.pending = NULL;
    struct MHD_Response *resp = http_response(r, p);
    unsigned status = p->status;
    http_req_reply_free(p);
    if (!resp) {
        r->gone = true; /* out of memory: give up on the connection */
        return http_drop();
    }
    r->log.t_sent = clock_now();
    enum MHD_Result ret = MHD_queue_response(r->conn.io_ctx, status, resp);
    MHD_destroy_response(resp);
    return ret;
}

/* Called by libmicrohttpd with the raw request-target before it is parsed;
 * the request is born here (so its length is known: --max-url), and from
 * then on libmicrohttpd promises the completion callback, which frees it. */
static void *http_uri_log(void *cls, const char *uri, struct MHD_Connection *c) {
    (void)cls;
    struct http_req *r = http_req_new(&http_mhd_io, c, NULL, NULL, uri ? strlen(uri) : 0);
    if (r) {
        http_req_set_target(r, uri);
        http_client_address(c, r->log.client, sizeof r->log.client);
    }
    /* a refused target's query is cut before libmicrohttpd splits it (it
     * does so after this call, in the same buffer): parameters by the
     * hundred would fill the connection's pool and leave no room for the
     * 400 that says why */
    char *q = r && uri && r->conn.target_why ? strchr(uri, '?') : NULL;
    if (q) q[1] = '\0';
    return r;
}

/* c's --header-seconds watch (http_deadline.c), its socket context. */
static struct http_deadline *http_conn_deadline(struct MHD_Connection *c) {
    const union MHD_ConnectionInfo *ci =
        MHD_get_connection_info(c, MHD_CONNECTION_INFO_SOCKET_CONTEXT);
    return ci ? ci->socket_context : NULL;
}

/* A connection opening: its headers watched (--header-seconds).  One
 * closing: the access line of a cut one no request told of (its request
 * line never came); one with an error of libmicrohttpd's still untaken:
 * its request line was refused, so no request reached rayd; its line. */
static void http_connection(void *cls, struct MHD_Connection *c, void **socket_ctx,
                            enum MHD_ConnectionNotificationCode what) {
    (void)cls;
    char client[64];
    if (what == MHD_CONNECTION_NOTIFY_STARTED) {
        const union MHD_ConnectionInfo *ci =
            MHD_get_connection_info(c, MHD_CONNECTION_INFO_CONNECTION_FD);
        *socket_ctx = http_deadline_open(ci ? ci->connect_fd : -1);
        return;
    }
    double waited = 0;
    if (http_deadline_claim(*socket_ctx, &waited)) {
        http_client_address(c, client, sizeof client);
        http_flow_header_timeout(client, NULL, waited);
    }
    http_deadline_close(*socket_ctx);
    *socket_ctx = NULL;
    if (!http_refused) return;
    http_client_address(c, client, sizeof client);
    http_flow_refused(client, http_refused, http_refused_why);
    http_refused = 0;
    http_refused_why[0] = 0;
}

/* ---- the header block as libmicrohttpd 0.9.75 stored it ------------------------- */

#if MHD_VERSION <= 0x00097500
/* libmicrohttpd 0.9.75 parses a header block leniently and says nothing
 * about it: a line folded onto the next (obs-fold, a line starting with a
 * space or tab) is glued to the previous header's *name*, so a folded
 * "Transfer-Encoding:" or "Content-Length:" vanishes and the body is read as
 * the next request; a bare LF ends a line like CR LF; a NUL byte ends a
 * value early.  RFC 9112 asks a 400 for the first, and a front proxy may
 * read the others differently, which is how requests are smuggled.  Its
 * strict mode does not help (it checks whitespace before a colon only in
 * its *lenient* mode, and answers a missing Host twice), so rayd checks.
 *
 * What it parsed still lies in its read buffer, in order, with each CR and
 * LF of a line end replaced by a NUL, and the colon too:
 * "GET / HTTP/1.1\0\0Host\0 x\0\0Name\0value\0\0\0\0".  So the block is
 * walked as stored: each header name starts two bytes (a CR LF) past the
 * end of the line before, its value follows its name's colon and blanks,
 * and the empty line ends where libmicrohttpd says the block ended
 * (MHD_CONNECTION_INFO_REQUEST_HEADER_SIZE).  A request whose headers do
 * not lie so was not read the way its bytes say.  Later libmicrohttpd
 * versions parse strictly themselves and lay the block out differently, so
 * this walk is built for 0.9.75 and older only. */
struct http_layout {
    const char *at;          /* where the next line must start */
    const char *begin, *end; /* the header block */
    const char *why;
};

static bool http_layout_in(const struct http_layout *l, const char *p) {
    return p >= l->begin && p < l->end;
}

#define HTTP_LAYOUT_LF "a header line holds a NUL byte or ends in a bare LF (CR LF is required)"

/* A header line that should have started at l->at starts at line: why. */
static const char *http_layout_broken(const struct http_layout *l, const char *line) {
    if (!http_layout_in(l, line))
        return "obsolete line folding (a header line that starts with a space or tab)";
    return HTTP_LAYOUT_LF;
}

static enum MHD_Result http_layout_cb(void *cls, enum MHD_ValueKind kind, const char *key,
                                      size_t key_size, const char *value, size_t value_size) {
    (void)kind;
    struct http_layout *l = cls;
    if (key != l->at) {
        l->why = http_layout_broken(l, key);
        return MHD_NO;
    }
    const char *p = key + key_size + 1; /* past the colon */
    if (!value || value < p || value + value_size + 2 > l->end) {
        l->why = "a malformed header line";
        return MHD_NO;
    }
    while (p < value && (*p == ' ' || *p == '\t')) p++;
    if (p != value || value[value_size + 1]) {
        l->why = p != value ? "a malformed header line" : HTTP_LAYOUT_LF;
        return MHD_NO;
    }
    l->at = value + value_size + 2;
    return MHD_YES;
}

/* NULL when c's header block lies as its bytes say, else why not. */
static const char *http_mhd_layout(struct MHD_Connection *c, const char *method,
                                   const char *version) {
    const union MHD_ConnectionInfo *ci =
        MHD_get_connection_info(c, MHD_CONNECTION_INFO_REQUEST_HEADER_SIZE);
    if (!ci || !method || !version) return NULL;
    struct http_layout l = {.begin = method, .end = method + ci->header_size};
    if (!http_layout_in(&l, version))
        return NULL; /* no version on the request line: libmicrohttpd refuses it */
    l.at = version + strlen(version) + 2;
    MHD_get_connection_values_n(c, MHD_HEADER_KIND, http_layout_cb, &l);
    if (!l.why && l.at + 2 != l.end)
        l.why = l.at + 1 == l.end ? HTTP_LAYOUT_LF : "a malformed header block";
    return l.why;
}
#else
static const char *http_mhd_layout(struct MHD_Connection *c, const char *method,
                                   const char *version) {
    (void)c;
    (void)method;
    (void)version;
    return NULL;
}
#endif

static enum MHD_Result http_access(void *cls, struct MHD_Connection *c, const char *url,
                                   const char *method, const char *version, const char *upload,
                                   size_t *upload_size, void **con_cls) {
    (void)cls;
    struct http_req *r = *con_cls;
    if (!r) /* out of memory in http_uri_log */
        return MHD_NO;
    if (!r->method) {
        /* first call: headers only; a connection cut by --header-seconds
         * just now cannot be answered */
        if (http_deadline_done(http_conn_deadline(c))) {
            r->log.header_late = true;
            return http_drop();
        }
        r->method = method;
        r->url = url;
        r->conn.version = version;
        r->conn.framing = http_mhd_layout(c, method, version);
        return http_flow_begin(r) ? MHD_YES : http_flush(r);
    }
    if (r->gone) return http_drop();
    if (r->conn.pending) /* resumed with an answer, or replied during the upload */
        return http_flush(r);
    if (r->conn.replied) return MHD_YES;
    if (*upload_size) {
        size_t n = *upload_size;
        *upload_size = 0;
        return http_flow_body(r, upload, n) ? MHD_YES : http_drop();
    }
    /* the whole request is here */
    http_flow_handle(r);
    if (r->conn.parked) return MHD_YES;
    return http_flush(r);
}

static void http_completed(void *cls, struct MHD_Connection *c, void **con_cls,
                           enum MHD_RequestTerminationCode toe) {
    (void)cls;
    struct http_req *r = *con_cls;
    *con_cls = NULL;
    struct http_deadline *d = http_conn_deadline(c);
    if (r && !r->method && http_deadline_claim(d, NULL)) r->log.header_late = true;
    if (toe == MHD_REQUEST_TERMINATED_COMPLETED_OK) http_deadline_next(d); /* keep-alive */
    if (!r) return;
    if (!r->method || !r->conn.replied)
        r->log.refused_status =
            http_refused_status(c, r->log.refused_why, sizeof r->log.refused_why);
    const char *note = NULL;
    if (toe != MHD_REQUEST_TERMINATED_COMPLETED_OK)
        note = toe == MHD_REQUEST_TERMINATED_TIMEOUT_REACHED   ? "timeout"
               : toe == MHD_REQUEST_TERMINATED_DAEMON_SHUTDOWN ? "shutdown"
                                                               : "aborted";
    /* for an answer cut short, the finer reason */
    r->log.end_why = toe == MHD_REQUEST_TERMINATED_CLIENT_ABORT ? "client_closed"
                     : toe == MHD_REQUEST_TERMINATED_READ_ERROR ? "read_error"
                     : toe == MHD_REQUEST_TERMINATED_WITH_ERROR ? "send_error"
                                                                : note;
    http_flow_end(r, note);
}

/* While http_start starts libmicrohttpd its messages are kept, not logged:
 * a failure to listen is then one line that says why ("cannot listen ...:
 * Address already in use"), as every rayd error. */
static pthread_mutex_t http_start_lock = PTHREAD_MUTEX_INITIALIZER;
static bool http_starting;
static char http_start_why[512]; /* as long as http_mhd_log's line */

/* The title of the error page in a libmicrohttpd message as a code, into
 * why: "<title>&quot;Host:&quot; header required</title>" is
 * host_header_required (entities dropped; letters and digits kept, in
 * lower case; any run of other bytes one '_').  "" when there is none. */
static void http_page_title_code(const char *msg, char *why, size_t size) {
    const char *p = strstr(msg, "<title>");
    const char *end = p ? strstr(p, "</title>") : NULL;
    size_t n = 0;
    why[0] = 0;
    if (!end || size == 0) return;
    for (p += 7; p < end && n + 1 < size; p++) {
        if (*p == '&' && memchr(p, ';', (size_t)(end - p))) {
            p = memchr(p, ';', (size_t)(end - p)); /* an entity: &quot; */
            continue;
        }
        char ch = *p;
        if (ch >= 'A' && ch <= 'Z') ch = (char)(ch - 'A' + 'a');
        if ((ch >= 'a' && ch <= 'z') || (ch >= '0' && ch <= '9'))
            why[n++] = ch;
        else if (n > 0 && why[n - 1] != '_')
            why[n++] = '_';
    }
    while (n > 0 && why[n - 1] == '_') n--;
    why[n] = 0;
}

/* A message of libmicrohttpd's saying it answered a request with an error
 * page of its own: counted, and the status and the page's title kept for
 * the access line.  False for any other message. */
static bool http_mhd_refusal(const char *msg) {
    static const char said[] = "HTTP response code is ";
    const char *p = strstr(msg, said);
    if (!p || strncmp(msg, "Error processing request", 24)) return false;
    unsigned long st = strtoul(p + sizeof said - 1, NULL, 10);
    metrics_reject(MR_HTTP_PARSER);
    http_refused = st >= 400 && st <= 599 ? (unsigned)st : 400;
    http_page_title_code(msg, http_refused_why, sizeof http_refused_why);
    return true;
}

/* The messages libmicrohttpd (0.9.75) writes just before it refuses a
 * request with an error page: the refusal's access line tells as much
 * (its status, and the page's title as its reason). */
static bool http_mhd_before_refusal(const char *msg) {
    static const char *const lead[] = {
        "Received HTTP/1.1 request without `Host' header",
        "Not enough memory in pool to allocate header record",
        "Not enough memory in pool to parse cookies",
        "Too large value of 'Content-Length' header",
        "Failed to parse `Content-Length' header",
    };
    for (size_t i = 0; i < sizeof lead / sizeof lead[0]; i++)
        if (!strncmp(msg, lead[i], strlen(lead[i]))) return true;
    return false;
}

/* The messages libmicrohttpd (0.9.75) writes when a connection ends in the
 * middle of a request's headers, its client gone or cut by --header-seconds:
 * the request's access line (499, or 408 header_timeout) tells as much. */
static bool http_mhd_closed(const char *msg) {
    static const char *const lead[] = {
        "Connection was closed by remote side with incomplete request",
        "Connection socket is closed when reading request due to the error: detected connection "
        "closure",
    };
    for (size_t i = 0; i < sizeof lead / sizeof lead[0]; i++)
        if (!strncmp(msg, lead[i], strlen(lead[i]))) return true;
    return false;
}

/* libmicrohttpd's own messages (malformed requests, ...) go through log.c so
 * --log-format json keeps every stderr line JSON.  Those about a refusal
 * go to debug: rayd's access line is the refusal's one line. */
static void http_mhd_log(void *cls, const char *fmt, va_list ap)
    __attribute__((format(printf, 2, 0)));
static void http_mhd_log(void *cls, const char *fmt, va_list ap) {
    (void)cls;
    char msg[512];
    vsnprintf(msg, sizeof msg, fmt, ap);
    size_t n = strlen(msg);
    while (n > 0 && (msg[n - 1] == '\n' || msg[n - 1] == '\r')) msg[--n] = 0;
    pthread_mutex_lock(&http_start_lock);
    bool keep = http_starting;
    if (keep && !http_start_why[0]) snprintf(http_start_why, sizeof http_start_why, "%s", msg);
    pthread_mutex_unlock(&http_start_lock);
    if (keep) return;
    bool refusal = http_mhd_refusal(msg) || http_mhd_before_refusal(msg);
    bool dropped = http_dropped && !strncmp(msg, "Application reported internal error", 35);
    http_dropped = false;
    if (dropped || refusal || http_mhd_closed(msg))
        log_debug("http: %s", msg);
    else
        log_warn("http: %s", msg);
}

/* ---- start / stop --------------------------------------------------------------- */

/* Reads a whole (small) file: the TLS key and certificate. */
static char *http_read_pem(const char *path) {
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "rayd: error: %s: %s\n", path, strerror(errno));
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
        fprintf(stderr, "rayd: error: %s: empty or over 1 MiB\n", path);
        free(buf);
        return NULL;
    }
    return buf;
}

static char *http_tls_cert, *http_tls_key;

bool http_tls(void) { return http_tls_cert != NULL; }

/* The number of open files allowed, raised to the hard limit: every
 * connection is a descriptor, and --max-conns is capped to what fits. */
static long http_fd_budget(void) {
    struct rlimit rl;
    if (getrlimit(RLIMIT_NOFILE, &rl)) return 1024;
    if (rl.rlim_cur < rl.rlim_max) {
        struct rlimit want = {rl.rlim_max, rl.rlim_max};
        if (!setrlimit(RLIMIT_NOFILE, &want)) rl.rlim_cur = rl.rlim_max;
    }
    return rl.rlim_cur == RLIM_INFINITY || rl.rlim_cur > 100000000 ? 100000000 : (long)rl.rlim_cur;
}

/* The --bind address and --port into ss (MHD_USE_IPv6 into *flags for an
 * IPv6 one): 0, or -1 after saying why. */
static int http_address(struct sockaddr_storage *ss, unsigned *flags) {
    memset(ss, 0, sizeof *ss);
    struct sockaddr_in *s4 = (struct sockaddr_in *)ss;
    struct sockaddr_in6 *s6 = (struct sockaddr_in6 *)ss;
    if (inet_pton(AF_INET, config.bind, &s4->sin_addr) == 1) {
        s4->sin_family = AF_INET;
        s4->sin_port = htons((uint16_t)config.port);
    } else if (inet_pton(AF_INET6, config.bind, &s6->sin6_addr) == 1) {
        s6->sin6_family = AF_INET6;
        s6->sin6_port = htons((uint16_t)config.port);
        *flags |= MHD_USE_IPv6;
    } else {
        fprintf(stderr, "rayd: error: --bind %s: not an IPv4 or IPv6 address\n", config.bind);
        return -1;
    }
    return 0;
}

/* --max-conns, lowered to what the open-file limit allows: the
 * connections, plus the listener, epoll sets, inter-thread channels, stdio
 * and the odd file -- 64 is plenty for those. */
static long http_conn_limit(void) {
    long fds = http_fd_budget(), conns = config.max_conns;
    if (conns > fds - 64) {
        conns = fds - 64 > 16 ? fds - 64 : 16;
        log_warn("--max-conns %ld lowered to %ld: the open-file limit is %ld (ulimit -n)",
                 config.max_conns, conns, fds);
    }
    return conns;
}

/* libmicrohttpd's options, built one at a time. */
struct http_opts {
    struct MHD_OptionItem item[24];
    int n;
};

static void http_opt(struct http_opts *o, enum MHD_OPTION opt, intptr_t value, void *ptr) {
    o->item[o->n++] = (struct MHD_OptionItem){opt, value, ptr};
}

/* With --tls-cert: the certificate and key read and their options added
 * (MHD_USE_TLS into *flags).  0, or -1 after saying why. */
static int http_tls_options(struct http_opts *o, unsigned *flags) {
    if (!config.tls_cert) return 0;
    if (MHD_is_feature_supported(MHD_FEATURE_TLS) != MHD_YES) {
        fprintf(stderr, "rayd: error: this libmicrohttpd has no TLS support (--tls-cert)\n");
        return -1;
    }
    http_tls_cert = http_read_pem(config.tls_cert);
    http_tls_key = http_tls_cert ? http_read_pem(config.tls_key) : NULL;
    if (!http_tls_key) {
        free(http_tls_cert);
        http_tls_cert = NULL;
        return -1;
    }
    *flags |= MHD_USE_TLS;
    http_opt(o, MHD_OPTION_HTTPS_MEM_CERT, 0, http_tls_cert);
    http_opt(o, MHD_OPTION_HTTPS_MEM_KEY, 0, http_tls_key);
    return 0;
}

/* Starts libmicrohttpd with flags and o; what it logs while starting is
 * kept (http_start_why) to explain a failure in one line.  0, or -1 after
 * saying why. */
static int http_launch(unsigned flags, struct http_opts *o) {
    pthread_mutex_lock(&http_start_lock);
    http_starting = true;
    pthread_mutex_unlock(&http_start_lock);
    http_daemon = MHD_start_daemon(flags, (uint16_t)config.port, NULL, NULL, http_access, NULL,
                                   MHD_OPTION_ARRAY, o->item, MHD_OPTION_END);
    pthread_mutex_lock(&http_start_lock);
    http_starting = false;
    char why[sizeof http_start_why];
    memcpy(why, http_start_why, sizeof why);
    pthread_mutex_unlock(&http_start_lock);
    if (!http_daemon) {
        fprintf(stderr, "rayd: error: cannot listen on %s port %ld%s%s%s\n", config.bind,
                config.port, config.tls_cert ? " (or the TLS key/certificate was refused)" : "",
                why[0] ? ": " : "", why);
        return -1;
    }
    if (why[0]) log_warn("http: %s", why);
    return 0;
}

int http_start(void) {
    metrics_gauge(MG_HTTP_SUSPENDED, http_req_suspended);
    unsigned flags = MHD_USE_INTERNAL_POLLING_THREAD | MHD_USE_EPOLL | MHD_ALLOW_SUSPEND_RESUME |
                     MHD_USE_ERROR_LOG;
    struct sockaddr_storage ss;
    if (http_address(&ss, &flags) != 0) return -1;
    struct http_opts o = {.n = 0};
    http_opt(&o, MHD_OPTION_EXTERNAL_LOGGER, (intptr_t)http_mhd_log, NULL);
    http_opt(&o, MHD_OPTION_SOCK_ADDR, 0, &ss);
    http_opt(&o, MHD_OPTION_THREAD_POOL_SIZE, config.http_threads, NULL);
    http_opt(&o, MHD_OPTION_CONNECTION_TIMEOUT, config.timeout, NULL);
    http_opt(&o, MHD_OPTION_NOTIFY_COMPLETED, (intptr_t)http_completed, NULL);
    http_opt(&o, MHD_OPTION_URI_LOG_CALLBACK, (intptr_t)http_uri_log, NULL);
    http_opt(&o, MHD_OPTION_NOTIFY_CONNECTION, (intptr_t)http_connection, NULL);
    http_opt(&o, MHD_OPTION_CONNECTION_LIMIT, http_conn_limit(), NULL);
    http_opt(&o, MHD_OPTION_PER_IP_CONNECTION_LIMIT, config.max_conns_per_ip, NULL);
    http_opt(&o, MHD_OPTION_CONNECTION_MEMORY_LIMIT, config.max_header_bytes, NULL);
    http_opt(&o, MHD_OPTION_LISTEN_BACKLOG_SIZE, 1024, NULL);
    /* strict parsing (RFC 9112): libmicrohttpd 0.9.75's strict mode answers
     * a missing Host with its 400 written twice, and never checks for
     * whitespace before a colon; rayd checks those, spaces in the target
     * and the header block itself (http_mhd_layout, http_flow_begin).  Later
     * versions are strict by themselves. */
    http_opt(&o, MHD_OPTION_STRICT_FOR_CLIENT, MHD_VERSION <= 0x00097500 ? 0 : 1, NULL);
    if (http_tls_options(&o, &flags) != 0) return -1;
    http_opt(&o, MHD_OPTION_END, 0, NULL);
    if (http_deadline_start() != 0 || http_launch(flags, &o) != 0) {
        http_stop();
        return -1;
    }
    const union MHD_DaemonInfo *di = MHD_get_daemon_info(http_daemon, MHD_DAEMON_INFO_BIND_PORT);
    http_bound_port = di ? di->port : (int)config.port;
    return 0;
}

void http_stop(void) {
    if (http_daemon) MHD_stop_daemon(http_daemon);
    http_daemon = NULL;
    http_deadline_stop(); /* after libmicrohttpd: no connection is watched any more */
    if (http_tls_key) memset(http_tls_key, 0, strlen(http_tls_key));
    free(http_tls_key);
    free(http_tls_cert);
    http_tls_key = http_tls_cert = NULL;
}
