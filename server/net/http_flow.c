/* http_flow.c -- a request's life from its first header to its last byte,
 * whatever the transport.
 *
 *   begin   headers only.  The request gets its id (X-Request-Id) and its
 *           route label for the metrics.  Framing first (RFC 9112): a
 *           header block the transport found unsound (a folded line, a
 *           bare LF), a method or a header name that is no token
 *           (whitespace before its colon), a control character in a
 *           value, HTTP/1.1 without Host, a target with a space, a NUL or
 *           an encoded '/' are 400,
 *           an ambiguous body length 400, an Expect other than
 *           100-continue 417 -- each closing the connection, so what a
 *           proxy might have read as the body is never run as a request.
 *           An absolute-form target is served as its path.  Then a
 *           request-target over --max-url is 414,
 *           a Content-Length over --max-body 413, and for a
 *           request with a body, a missing token 401 and a path or method
 *           no route serves 404 / 405 -- all before a byte of the body is
 *           read (a request without a body meets those in handle, and its
 *           connection stays open).
 *   body    chunks appended up to --max-body; past it they are counted, not
 *           kept, and the request is answered 413; the whole upload gets
 *           --upload-seconds.  A body's bytes are counted in the one
 *           memory budget (--max-memory, mem.c): a Content-Length is
 *           reserved whole in begin (503 with Retry-After when it does not
 *           fit, 413 when it is over the whole budget), a chunked body as
 *           it grows (503 when it outgrows the room left), so many slow
 *           uploads cannot hold more than the budget between them.
 *   handle  the CORS preflight (OPTIONS), the token again (for a transport
 *           that reads the body anyway), then the router.  Decided here,
 *           before routing, so no handler can forget them.  The handler
 *           replies, or suspends the request.
 *   end     the access log line (client, method, target with its query,
 *           status, bytes, times, scene, request id) and the request
 *           metrics (route pattern, method, code, duration), then free.
 *           An answer that went out only in part (the transport ended it:
 *           the client closed, a send failed) is logged with the bytes
 *           that went out and why (cut_short).
 *           A request libmicrohttpd answered itself (headers over
 *           --max-header-bytes: 431, a bad Content-Length or chunk: 400)
 *           is logged and counted with the status it sent, as the
 *           transport learnt it (r->log.refused_status), and its reason
 *           (r->log.refused_why) as the error, note
 *           refused_by_http_parser; one refused before its target was read
 *           (a request line over the limit: 414) reaches http_flow_refused
 *           only, with no method, path or id to name.
 *           A connection --header-seconds cut before its headers were all in
 *           (http_deadline.c) is logged and counted as 408 with note
 *           header_timeout, with its target if its request line came,
 *           though nothing was sent (http_flow_header_timeout).
 *
 * libmicrohttpd (http.c) and the fuzz harness drive the same four calls, so
 * the fuzzer exercises exactly the code that serves.  Handlers are reached
 * only through the router: this file is the transport's top half.
 */
#include "net/transport.h"
#include "route/router.h"

#include <microhttpd.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/socket.h>

/* Constant-time check of "Authorization: Bearer <token>": every byte of
 * the token is compared whatever the header holds (config.c refuses a
 * token with a NUL, so config.token_len is its whole length). */
static bool http_flow_authorized(struct http_req *r) {
    if (!config.token) return true;
    const char *h = http_req_header(r, MHD_HTTP_HEADER_AUTHORIZATION);
    if (!h || strncasecmp(h, "Bearer ", 7)) return false;
    h += 7;
    while (*h == ' ') h++;
    size_t hl = strlen(h);
    unsigned char diff = hl != config.token_len;
    for (size_t i = 0; i < config.token_len; i++)
        diff |= (unsigned char)(config.token[i] ^ (i < hl ? h[i] : 0));
    return diff == 0;
}

/* The 401 of a request that needs the token and lacks it (OPTIONS and the
 * public paths need none); false when the request may go on.  Asked with
 * the headers, before a byte of the body is read: else a client without
 * the token could make rayd read and keep --max-body on every connection
 * it opens, and one sending Expect: 100-continue would be told to send its
 * body only to be refused. */
static bool http_flow_unauthorized(struct http_req *r) {
    if (!strcmp(r->method, "OPTIONS") || router_public(r->method, r->url) ||
        http_flow_authorized(r))
        return false;
    metrics_reject(MR_UNAUTHORIZED);
    http_reply_error(r, 401, "unauthorized", "missing or wrong bearer token", NULL, 0, 0, NULL);
    return true;
}

/* OPTIONS: CORS preflight or a plain Allow listing. */
static void http_flow_options(struct http_req *r) {
    char allow[128];
    if (!router_allow(r->url, allow, sizeof allow)) {
        http_reply_error(r, 404, "not_found", "no such resource", NULL, 0, 0, NULL);
        return;
    }
    http_reply_data(r, 204, NULL, NULL, 0);
    http_reply_header(r, MHD_HTTP_HEADER_ALLOW, allow);
    if (http_reply_cors_origin(r)) {
        http_reply_header(r, "Access-Control-Allow-Methods", allow);
        http_reply_header(r, "Access-Control-Allow-Headers",
                          "Authorization, Content-Type, If-None-Match, X-Request-Id");
        http_reply_header(r, "Access-Control-Max-Age", "600");
    }
}

/* Content-Length: digits only.  -1 absent, -2 malformed. */
static long long http_flow_length(const char *cl) {
    while (*cl == ' ' || *cl == '\t') cl++;
    unsigned long long n = 0;
    const char *p = cl;
    for (; *p >= '0' && *p <= '9'; p++)
        if (n <= 1000000000000000ULL)
            n = n * 10 + (unsigned)(*p - '0'); /* past 10^15 it is over any limit anyway */
    while (*p == ' ' || *p == '\t') p++;
    if (p == cl || *p) return -2;
    return (long long)n;
}

struct http_flow_framing {
    int nlength, nte, nhost;
    int ntype, ncoding;               /* Content-Type, Content-Encoding: one each at most */
    long long length;                 /* the first Content-Length, -2 malformed */
    bool differ;                      /* two Content-Length headers that disagree */
    const char *te;                   /* the first Transfer-Encoding */
    const char *expect;               /* an Expect other than 100-continue */
    const char *bad_name, *bad_value; /* the first header whose name, or value, is malformed */
};

/* A header name is a token (RFC 9110 section 5.6.2): a space or tab in it
 * is whitespace before the colon, which RFC 9112 section 5.1 asks a 400
 * for -- libmicrohttpd keeps "Transfer-Encoding " as an unknown header and
 * would read the body as the next request.  A method is a token too
 * (section 9.1); libmicrohttpd passes any bytes up to the first space. */
static bool http_flow_token(const char *k) {
    if (!*k) return false;
    for (; *k; k++)
        if (!((*k >= 'a' && *k <= 'z') || (*k >= 'A' && *k <= 'Z') || (*k >= '0' && *k <= '9') ||
              strchr("!#$%&'*+-.^_`|~", *k)))
            return false;
    return true;
}

/* A field value holds no control character but tab (a bare CR above all). */
static bool http_flow_value_ok(const char *v) {
    for (; *v; v++)
        if (((unsigned char)*v < 0x20 && *v != '\t') || *v == 0x7f) return false;
    return true;
}

/* Expect: 100-continue is the only expectation there is (RFC 9110
 * section 10.1.1); libmicrohttpd answers it. */
static bool http_flow_continue(const char *v) {
    v += strspn(v, " \t");
    size_t n = strlen("100-continue");
    return !strncasecmp(v, "100-continue", n) && !v[n + strspn(v + n, " \t")];
}

static void http_flow_framing_cb(void *u, const char *k, const char *v) {
    struct http_flow_framing *f = u;
    if (!f->bad_name && !http_flow_token(k)) f->bad_name = k;
    if (!f->bad_value && !http_flow_value_ok(v)) f->bad_value = k;
    if (!strcasecmp(k, "Expect") && !f->expect && !http_flow_continue(v)) f->expect = v;
    if (!strcasecmp(k, MHD_HTTP_HEADER_CONTENT_LENGTH)) {
        long long n = http_flow_length(v);
        if (f->nlength++ == 0)
            f->length = n;
        else if (n != f->length)
            f->differ = true;
    } else if (!strcasecmp(k, MHD_HTTP_HEADER_TRANSFER_ENCODING)) {
        if (f->nte++ == 0) f->te = v;
    } else if (!strcasecmp(k, MHD_HTTP_HEADER_HOST)) {
        f->nhost++;
    } else if (!strcasecmp(k, MHD_HTTP_HEADER_CONTENT_TYPE)) {
        f->ntype++;
    } else if (!strcasecmp(k, MHD_HTTP_HEADER_CONTENT_ENCODING)) {
        f->ncoding++;
    }
}

/* Whether te from offset at to its end is the word "chunked", with spaces
 * or tabs around it. */
static bool http_flow_chunked_at(const char *te, size_t at) {
    const char *p = te + at + strspn(te + at, " \t");
    size_t n = strlen("chunked");
    return !strncasecmp(p, "chunked", n) && !p[n + strspn(p + n, " \t")];
}

/* The refusal of a Transfer-Encoding libmicrohttpd does not decode: it
 * knows the value "chunked" alone, and on any other would wait for
 * --timeout, then drop the connection unanswered.  0 for none or
 * "chunked"; else the status, with the message in msg: 501 for a coding
 * before a final chunked (RFC 9112 section 6.1), 400 otherwise (chunked is
 * not the last coding: the body's length is unknown, section 6.3). */
static unsigned http_flow_te_refusal(const char *te, char *msg, size_t size) {
    if (!te || !strcasecmp(te, "chunked")) return 0;
    const char *comma = strrchr(te, ',');
    bool coded = comma && http_flow_chunked_at(te, (size_t)(comma + 1 - te));
    snprintf(msg, size, "Transfer-Encoding '%.40s': %s", te,
             coded ? "no transfer coding but chunked is implemented"
                   : "only the value chunked is understood (the body's length is unknown)");
    return coded ? 501 : 400;
}

/* An absolute-form target ("GET http://host/healthz", RFC 9112 section
 * 3.2.2, what a client talking to a proxy sends) is served as its path; its
 * host stands in for Host, which rayd does not use.  False when the target
 * has a scheme but no host. */
static bool http_flow_absolute_form(struct http_req *r) {
    const char *u = r->url;
    size_t skip = !strncasecmp(u, "http://", 7) ? 7 : !strncasecmp(u, "https://", 8) ? 8 : 0;
    if (!skip) return true;
    const char *path = strchr(u + skip, '/');
    if ((path ? (size_t)(path - u) : strlen(u)) == skip) return false;
    r->url = path ? path : "/";
    return true;
}

/* The refusal of a request whose framing cannot be trusted: the
 * connection closes after it, so no byte after its headers is ever read
 * as a request. */
static void http_flow_refuse_framing(struct http_req *r, unsigned status, const char *code,
                                     const char *why) {
    http_reply_error(r, status, code, why, NULL, 0, 0, NULL);
    http_reply_header(r, MHD_HTTP_HEADER_CONNECTION, "close");
}

/* Why the header block is refused (400), into msg; false when it is sound:
 * what the transport found, a method that is no token (not echoed: its
 * bytes are anything a client sent), a header name that is no token
 * (whitespace before its colon), a control character in a value, a missing
 * Host in HTTP/1.1, a target with a space, control, NUL or encoded '/'. */
static bool http_flow_malformed(struct http_req *r, const struct http_flow_framing *f, char *msg,
                                size_t size) {
    if (r->conn.framing)
        snprintf(msg, size, "%s", r->conn.framing);
    else if (!http_flow_token(r->method))
        snprintf(msg, size,
                 "the method is not a token (letters, digits and !#$%%&'*+-.^_`|~ only, "
                 "RFC 9110 section 9.1)");
    else if (f->bad_name)
        snprintf(msg, size, "the header name '%.40s' is not a token (whitespace before the colon?)",
                 f->bad_name);
    else if (f->bad_value)
        snprintf(msg, size, "the value of the header '%.40s' holds a control character",
                 f->bad_value);
    else if (f->nhost == 0 && r->conn.version && !strcmp(r->conn.version, "HTTP/1.1"))
        snprintf(msg, size, "an HTTP/1.1 request needs a Host header");
    else if (r->conn.target_why)
        snprintf(msg, size, "%s", r->conn.target_why);
    else if (!http_flow_absolute_form(r))
        snprintf(msg, size, "an absolute-form target without a host");
    else
        return false;
    return true;
}

/* The 503 (or 413) of a body the memory budget has no room for. */
static void http_flow_no_memory(struct http_req *r, size_t need) {
    char msg[200];
    metrics_reject(MR_MEMORY);
    if (need > mem_limit()) {
        snprintf(msg, sizeof msg,
                 "the body alone is over the memory budget of %zu bytes (--max-memory)",
                 mem_limit());
        http_reply_error(r, 413, "over_memory", msg, NULL, 0, 0, NULL);
    } else {
        snprintf(msg, sizeof msg,
                 "the memory budget (--max-memory, %zu bytes) has no room for this body now; "
                 "retry later",
                 mem_limit());
        r->res.retry_after = 2;
        http_reply_error(r, 503, "memory_full", msg, NULL, 0, 0, NULL);
    }
    http_reply_header(r, MHD_HTTP_HEADER_CONNECTION, "close");
}

/* Whether a declared body fits the budget now, before a byte of it is
 * read; false when refused (replied).  Only looked at, not held: the body
 * is counted as it arrives (http_flow_keep).  Held whole from the headers,
 * 3,900 connections that each declared 4 MB and sent a byte every 5 s
 * held 12.6 GB of a 12.6 GB budget, and every other client's body and
 * parse was refused 503 memory_full. */
static bool http_flow_fits(struct http_req *r, size_t need) {
    if (mem_reserve(MEM_BODIES, need)) {
        mem_release(MEM_BODIES, need);
        return true;
    }
    http_flow_no_memory(r, need);
    return false;
}

/* 413 for a body over --max-body: the limit is the operator's, so the
 * message also names the ways a client gets big geometry in without it. */
static void http_flow_too_large(struct http_req *r) {
    metrics_reject(MR_BODY_TOO_LARGE);
    char msg[360];
    snprintf(msg, sizeof msg,
             "the body is over the server's limit of %ld bytes (--max-body, set by its "
             "operator); send big meshes another way: as a file under the server's --asset-dir "
             "(\"file\" in the scene), or as binary PLY or .glb instead of OBJ text",
             config.max_body);
    http_reply_error(r, 413, "body_too_large", msg, NULL, 0, 0, NULL);
}

bool http_flow_begin(struct http_req *r) {
    http_req_take_id(r);
    struct http_flow_framing f = {.length = -1};
    r->conn.io->header_each(r, http_flow_framing_cb, &f);
    char bad[200];
    if (http_flow_malformed(r, &f, bad, sizeof bad)) {
        r->route.label = router_find(r->url);
        http_flow_refuse_framing(r, 400, "bad_request", bad);
        return false;
    }
    r->route.label = router_find(r->url);
    if (r->conn.target_len > (size_t)config.max_url) {
        char msg[128];
        snprintf(msg, sizeof msg, "the request target is over the limit of %ld bytes (--max-url)",
                 config.max_url);
        http_reply_error(r, 414, "uri_too_long", msg, NULL, 0, 0, NULL);
        return false;
    }
    /* an ambiguous body length is how requests are smuggled past proxies:
     * refuse it rather than guess (RFC 9112 section 6.3) */
    char te_why[160];
    unsigned te = f.nte == 1 ? http_flow_te_refusal(f.te, te_why, sizeof te_why) : 0;
    /* the handlers read the first Content-Type and Content-Encoding; a
     * proxy that joins repeated ones would read "identity, gzip" */
    if (f.differ || f.length == -2 || (f.nlength && f.nte) || f.nte > 1 || f.nhost > 1 || te ||
        f.ntype > 1 || f.ncoding > 1) {
        const char *why = f.nte && f.nlength ? "both Transfer-Encoding and Content-Length"
                          : f.nte > 1        ? "more than one Transfer-Encoding header"
                          : f.nhost > 1      ? "more than one Host header"
                          : f.ntype > 1      ? "more than one Content-Type header"
                          : f.ncoding > 1    ? "more than one Content-Encoding header"
                          : te               ? te_why
                                             : "malformed or conflicting Content-Length";
        bool coding = why == te_why && te == 501;
        http_flow_refuse_framing(r, coding ? 501 : 400, coding ? "not_implemented" : "bad_request",
                                 why);
        return false;
    }
    if (f.expect) {
        char msg[120];
        snprintf(msg, sizeof msg, "Expect '%.40s': only 100-continue is understood", f.expect);
        http_flow_refuse_framing(r, 417, "expectation_failed", msg);
        return false;
    }
    r->conn.body_declared = f.nlength ? f.length : -1;
    /* a request with a body that will be refused anyway is refused now,
     * before the body (libmicrohttpd then closes the connection); one
     * without a body goes on, and its connection stays open */
    bool body = f.nte || (f.nlength && f.length > 0);
    if (body && (http_flow_unauthorized(r) || (strcmp(r->method, "OPTIONS") && router_refuse(r))))
        return false;
    if (f.nlength && f.length > config.max_body) {
        http_flow_too_large(r);
        return false;
    }
    return !(f.nlength && f.length > 0) || http_flow_fits(r, (size_t)f.length + 1);
}

/* Forgets the body kept so far; the rest is counted only. */
static void http_flow_drop_body(struct http_req *r, size_t n) {
    free(r->body);
    r->body = NULL;
    r->conn.body_cap = 0;
    r->body_len += n;
    mem_release(MEM_BODIES, r->conn.body_mem);
    r->conn.body_mem = 0;
}

/* A client that shuts its side of the connection before the body it
 * declared is all sent can never send the rest.  A full close is seen by
 * libmicrohttpd, but its epoll loop is edge-triggered: when the shutdown
 * (FIN) arrives together with the body's last bytes, it reads the bytes and
 * never the end, and the connection would wait for --timeout.  So after a
 * chunk that leaves the body short, a peek at the socket says whether the
 * peer has ended; a half-close after a whole body is a client waiting for
 * its answer, and is left alone.  Not under TLS: there the TLS library may
 * hold body bytes it already read from the socket, so the socket's end is
 * not the body's. */
static bool http_flow_upload_ended(struct http_req *r) {
    if (config.tls_cert || r->conn.body_declared < 0 ||
        (long long)r->body_len >= r->conn.body_declared)
        return false;
    int fd = r->conn.io->fd ? r->conn.io->fd(r) : -1;
    char c;
    return fd >= 0 && recv(fd, &c, 1, MSG_PEEK | MSG_DONTWAIT) == 0;
}

/* Appends a chunk, or counts it past --max-body; false to drop the
 * connection. */
static bool http_flow_keep(struct http_req *r, const char *data, size_t n) {
    /* --timeout drops an idle connection, but a client that sends a byte now
     * and then is never idle: the whole body gets --upload-seconds */
    if (config.upload_seconds > 0 && clock_now() - r->log.t0 > (double)config.upload_seconds) {
        r->res.note = "upload_too_slow";
        return false;
    }
    if (r->conn.too_large || r->conn.no_memory || r->conn.over_memory) {
        r->body_len += n; /* counted, not kept */
        return r->body_len <= 4 * (size_t)config.max_body;
    }
    if (r->body_len + n > (size_t)config.max_body) {
        r->conn.too_large = true;
        http_flow_drop_body(r, n);
        return true;
    }
    if (r->body_len + n + 1 > r->conn.body_cap) {
        size_t cap = r->conn.body_cap ? r->conn.body_cap : 4096;
        while (cap < r->body_len + n + 1) cap *= 2;
        size_t whole = (size_t)r->conn.body_declared + 1; /* the declared length */
        if (r->conn.body_declared >= 0 && cap > whole && whole >= r->body_len + n + 1) cap = whole;
        if (cap > r->conn.body_mem && !mem_reserve(MEM_BODIES, cap - r->conn.body_mem)) {
            r->conn.over_memory = true; /* read the rest without keeping it, then 503 */
            http_flow_drop_body(r, n);
            return true;
        }
        if (cap > r->conn.body_mem) r->conn.body_mem = cap;
        char *b = realloc(r->body, cap);
        if (!b) {
            /* read the rest without keeping it, then answer 503 */
            r->conn.no_memory = true;
            http_flow_drop_body(r, n);
            return true;
        }
        r->body = b;
        r->conn.body_cap = cap;
    }
    memcpy(r->body + r->body_len, data, n);
    r->body_len += n;
    r->body[r->body_len] = 0;
    return true;
}

bool http_flow_body(struct http_req *r, const char *data, size_t n) {
    bool ok = http_flow_keep(r, data, n);
    if (ok && http_flow_upload_ended(r)) {
        r->res.note = "upload_incomplete";
        return false;
    }
    return ok;
}

void http_flow_handle(struct http_req *r) {
    if (r->body_len > 0) metrics_stage(MS_UPLOAD, clock_now() - r->log.t0);
    if (r->conn.too_large) {
        http_flow_too_large(r);
        return;
    }
    if (r->conn.no_memory) {
        http_reply_error(r, 503, "out_of_memory", "out of memory reading the body", NULL, 0, 0,
                         NULL);
        return;
    }
    if (r->conn.over_memory) {
        http_flow_no_memory(r, r->body_len + 1);
        return;
    }
    if (!strcmp(r->method, "OPTIONS")) {
        http_flow_options(r);
    } else if (http_flow_unauthorized(r)) {
        /* begin refused it already over libmicrohttpd; a transport that
         * goes on to the body is refused here */
    } else {
        r->conn.parked = false;
        router_dispatch(r);
        if (r->conn.parked) return; /* r now belongs to the worker until it resumes */
    }
    if (!r->conn.pending && !r->gone)
        http_reply_error(r, 500, "internal", "the handler gave no answer", NULL, 0, 0, NULL);
}

void http_flow_end(struct http_req *r, const char *note) {
    double total = clock_now() - r->log.t0;
    int refused = (int)r->log.refused_status;
    if (r->log.header_late) {
        http_flow_header_timeout(r->log.client, r->log.target, total);
        http_req_free(r);
        return;
    }
    if (!r->method) {
        /* refused by libmicrohttpd before the handler saw it (bad headers,
         * headers over --max-header-bytes): it answered by itself, with
         * refused (0 when the client left before it could) */
        struct log_access a = {.client = r->log.client,
                               .path = r->log.target,
                               .status = refused,
                               .total_ms = total * 1e3,
                               .error = r->log.refused_why[0] ? r->log.refused_why : NULL,
                               .note = refused || !note ? "refused_by_http_parser" : note};
        log_access(&a);
        if (refused) metrics_request(r->route.label, NULL, refused, total);
        http_req_free(r);
        return;
    }
    int status = r->res.status;
    /* a reply that went out but not to its end (the transport's note):
     * how much did, and why */
    bool head = !strcmp(r->method, "HEAD"); /* no body goes out */
    bool cut = note && r->conn.replied && !r->gone && r->log.t_sent > 0 && !head;
    const char *cut_why = r->log.end_why ? r->log.end_why : note;
    if (r->res.note) note = r->res.note;
    if ((r->gone || !r->conn.replied) && refused) {
        status = refused; /* libmicrohttpd answered the body (a malformed chunk) */
        note = "refused_by_http_parser";
        if (r->log.refused_why[0]) {
            r->res.err_code = r->log.refused_why;
            r->res.err_at[0] = 0;
        }
    } else if (r->gone || !r->conn.replied) {
        status = 499;
        if (!note) note = "client_gone";
    }
    metrics_request(r->route.label, r->method, status, total);
    if (r->res.is_image && r->log.t_sent > 0 && status == 200)
        metrics_stage(MS_SEND, clock_now() - r->log.t_sent);
    size_t bytes = head ? 0 : cut && r->log.body_counted ? r->log.body_taken : r->res.bytes;
    struct log_access a = {
        .client = r->log.client,
        .method = r->method,
        .path = r->log.target ? r->log.target : r->url,
        .status = status,
        .bytes = bytes,
        .cut = cut ? cut_why : NULL,
        .size = cut ? r->res.bytes : 0,
        .total_ms = total * 1e3,
        .times = r->res.times,
        .scene = r->res.scene,
        .request_id = r->request_id,
        .note = cut ? r->res.note : note, /* the transport's note is cut_short */
        .error = r->res.err_code,
        .error_at = r->res.err_at,
    };
    log_access(&a);
    http_req_free(r); /* the watcher gives freed heap back (mem_trim) */
}

void http_flow_refused(const char *client, unsigned status, const char *why) {
    struct log_access a = {.client = client,
                           .status = (int)status,
                           .error = why && *why ? why : NULL,
                           .note = "refused_by_http_parser"};
    log_access(&a);
    metrics_request(-1, NULL, (int)status, 0);
}

void http_flow_header_timeout(const char *client, const char *target, double waited) {
    struct log_access a = {.client = client,
                           .path = target,
                           .status = 408,
                           .total_ms = waited * 1e3,
                           .note = "header_timeout"};
    log_access(&a);
    metrics_request(-1, NULL, 408, waited);
}
