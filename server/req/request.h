/* request.h -- one HTTP request as the router and the handlers see it: its
 * method, path, headers and query, and the replies they can give.
 *
 * Layer: request (http_req.c, http_reply.c) -- the lower half of the
 * transport.  It sits below the handlers so that they can read a request and
 * shape a reply without calling up into the libmicrohttpd glue: the glue
 * (http.c) and the request flow (http_flow.c) are above the router and
 * reach a request through struct http_io, the table of functions the
 * transport fills in (libmicrohttpd, or the fuzz harness's own).
 * May include: base.h -- never libmicrohttpd (a reply is data, struct
 * http_reply, which the transport alone turns into a response), never
 * work.h: a reply carries a PNG as a struct blob (base), not a task.
 * Included by http_req.c, http_reply.c, api_*.c, router.c, http_flow.c,
 * http.c and the fuzz harnesses.
 */
#ifndef RAYD_SERVER_REQUEST_H
#define RAYD_SERVER_REQUEST_H

#include "base/base.h"

struct http_req;

/* A reply as data: status, headers in the order they were added, and a
 * body.  Handlers shape it through http_reply_* (below) and never see the
 * transport's response type; the transport turns it into one when the
 * handler returns or a suspended request is resumed (http.c), and frees it
 * with http_req_reply_free. */
enum http_body {
    HTTP_BODY_BYTES,  /* data[0..len), malloc'd, owned by the reply */
    HTTP_BODY_BLOB,   /* an image: one reference to blob, read a block at a time */
    HTTP_BODY_STREAM, /* of unknown length: the transport calls read until its end */
    HTTP_BODY_NONE,   /* no body, and neither Content-Length nor chunking (304, HEAD) */
};
/* What a stream's read returns instead of a byte count: its end, or an
 * error that ends the connection. */
#define HTTP_STREAM_END ((ssize_t)-1)
#define HTTP_STREAM_ERROR ((ssize_t)-2)
struct http_header {
    char *name, *value; /* one malloc'd block: name, NUL, value */
};
struct http_reply {
    unsigned status;
    enum http_body kind;
    struct http_header *headers;
    size_t nheaders, cap;
    char *data; /* HTTP_BODY_BYTES */
    size_t len;
    struct blob *blob; /* HTTP_BODY_BLOB */
    /* HTTP_BODY_STREAM: read fills up to max bytes of buf (or says
     * HTTP_STREAM_END / HTTP_STREAM_ERROR), called by the transport's
     * threads while the answer is sent, block bytes at most; done is called
     * once when the transport, or a reply dropped unsent, lets go of cls. */
    ssize_t (*read)(void *cls, char *buf, size_t max);
    void (*done)(void *cls);
    void *cls;
    size_t block;
};

/* Room for the reason of a refusal of libmicrohttpd's (a code made of its
 * error page's title: "requested_http_version_is_not_supported"). */
#define HTTP_REFUSED_WHY 48

/* Where a request comes from: libmicrohttpd (http.c) or a test harness
 * (tests/fuzz/fuzz_http_common.h).  Everything reaches the connection only
 * through these. */
struct http_io {
    const char *(*header)(struct http_req *r, const char *name); /* first match, any case */
    void (*header_each)(struct http_req *r, void (*fn)(void *u, const char *k, const char *v),
                        void *u);
    void (*query_each)(struct http_req *r, void (*fn)(void *u, const char *k, const char *v),
                       void *u);
    void (*suspend)(struct http_req *r);
    void (*resume)(struct http_req *r);
    int (*fd)(struct http_req *r); /* socket to watch for a hang-up, -1 none */
};

/* One HTTP request from the first header to the last byte sent, in the
 * parts each layer owns.  At the top what every layer reads: the request as
 * sent.  Then the transport's (conn: the connection, the body as it is
 * read, the reply waiting to be queued, suspension), the access log's
 * (log: where it came from and how the answer went out), the router's
 * (route), and the result (res): what climbs back from the handler and
 * the work below it -- status, size, timings, reason, cache tag -- for the
 * transport to send and log.  A layer writes only its own part and res. */
struct http_conn {
    const struct http_io *io;
    void *io_ctx;        /* the transport's own (libmicrohttpd's connection) */
    const char *version; /* "HTTP/1.1", "HTTP/1.0"; NULL: the transport does not say */
    /* Why the transport refuses the header block it parsed ("obsolete line
     * folding ..."), or NULL: http_flow_begin answers it 400 and closes. */
    const char *framing;
    size_t target_len;      /* bytes of the request-target, query included */
    const char *target_why; /* why the target is refused (400), or NULL */
    size_t body_cap;
    long long body_declared; /* Content-Length, -1 when none was sent */
    size_t body_mem;         /* bytes of the body counted in --max-memory (mem.c) */
    bool over_memory;        /* a chunked body outgrew the memory budget: 503 */
    bool too_large, no_memory;
    struct http_reply *pending; /* to queue when the handler runs again */
    bool suspended, replied;
    bool parked; /* suspended by the handler now running (its thread only) */
};

struct http_log {
    char client[48]; /* the peer's address, "" when unknown */
    char *target;    /* the request-target as sent (malloc'd, cut), or NULL */
    double t0;       /* when the request came */
    double t_sent;   /* when the response was handed to the transport */
    /* An image's body is handed to the transport as it is read (http.c):
     * body_taken is how much was, so the access log of an answer cut short
     * says how much went out (body_counted: this reply is counted). */
    size_t body_taken;
    bool body_counted;
    const char *end_why;     /* why the transport ended the answer early, NULL none */
    unsigned refused_status; /* the error libmicrohttpd answered by itself (431, ...), 0 none */
    char refused_why[HTTP_REFUSED_WHY]; /* its reason, a code ("request_too_big"), "" none */
    bool header_late;                   /* cut by --header-seconds before its headers were all in */
};

/* The router's row for the method and path, looked up once (router.c):
 * begin asks it of a request with a body, dispatch uses what it found. */
struct http_route {
    int label;       /* router index for metrics, -1 none */
    bool done;       /* row, path_known and id are set */
    int row;         /* the table row that serves them, -1 none */
    bool path_known; /* with row -1: the path is served to other methods */
    char id[80];     /* the path's {id} segment, "" for none */
    bool negotiates; /* POST /v1/render: Accept may pick the format (Vary) */
};

/* What travels back up: set by the reply functions (status, bytes,
 * err_code, err_at, is_image) and by the handler from what the work layer
 * answered (the times, whole; scene, the ETag, retry_after, note). */
struct http_result {
    int status;             /* the status sent */
    size_t bytes;           /* response body size */
    const char *err_code;   /* code of the error reply sent, NULL for none */
    char err_at[128];       /* its JSON Pointer or query parameter, "" for none */
    struct log_times times; /* the render's, as the work layer answered them */
    bool is_image;          /* the response is an image (its send is a stage) */
    const char *note;       /* why, for the access log ("client_gone") */
    int retry_after;        /* seconds in a 503's Retry-After; 0: 1 */
    char etag[72];          /* set for immutable GETs */
    bool etag_revalidate;   /* the ETag's bytes may change: no-cache, not immutable */
    char scene[65];         /* the scene's id when the request named or sent one */
};

struct http_req {
    const char *method, *url;
    char request_id[65]; /* X-Request-Id: the client's, or one made up */
    char *body;
    size_t body_len;
    bool gone; /* the client left, or no memory: drop the connection */
    struct http_conn conn;
    struct http_log log;
    struct http_route route;
    struct http_result res;
};

/* ---- http_req.c: the request ------------------------------------------------ */

/* A request with its method and path (strings kept by the caller); freed by
 * http_req_free.  NULL on no memory. */
struct http_req *http_req_new(const struct http_io *io, void *io_ctx, const char *method,
                              const char *url, size_t target_len);
void http_req_free(struct http_req *r); /* the pending reply too */
/* Frees a reply: its bytes, its blob reference, its stream's done. */
void http_req_reply_free(struct http_reply *p);
/* Keeps a copy of the raw request-target for the access log (the first
 * 2 KiB: a log line is no place for a 16 MiB query), and checks all of it:
 * r->conn.target_why says why it is refused -- a space or control character, or
 * in its path a %00 (a NUL that would end the path early: /app.js%00.png
 * read as /app.js), a %2F (an encoded '/', which the router would see as a
 * separator once decoded) or another encoded control character. */
void http_req_set_target(struct http_req *r, const char *target);
/* At most this many query parameters (a request of rayd's takes a few):
 * libmicrohttpd 0.9.75 keeps each in the connection's memory pool, and a
 * 1.2 KB query of 600 left it no room even to answer (a 30 s hang). */
#define HTTP_QUERY_PARAMS_MAX 256
#define HTTP_QUERY_TOO_MANY "the query has more than 256 parameters"
/* Sets r->request_id: the client's X-Request-Id when it is 1-64 characters
 * of [A-Za-z0-9._:+/=@-], else 32 hex digits unique to this request. */
void http_req_take_id(struct http_req *r);
long http_req_in_flight(void); /* requests not yet freed */
long http_req_suspended(void); /* requests suspended right now */
double http_req_last(void);    /* when the latest came (clock_now() time) */

const char *http_req_header(struct http_req *r, const char *name);
const char *http_req_query(struct http_req *r, const char *name); /* the first, or NULL */
int http_req_query_count(struct http_req *r, const char *name);   /* how many times given */
void http_req_query_each(struct http_req *r, void (*fn)(void *u, const char *k, const char *v),
                         void *u);
int http_req_fd(struct http_req *r);
/* Suspends r: from now on only whoever resumes it may touch it (r->conn.parked
 * tells the thread that ran the handler). */
void http_req_suspend(struct http_req *r);
void http_req_resume(struct http_req *r); /* r may be gone after this */
/* The next item of a comma-separated header value (spaces trimmed): false
 * at the end; *p advances past it. */
bool http_req_list_next(const char **p, const char **item, size_t *len);

/* ---- http_reply.c: the reply ------------------------------------------------- */

/* Each takes ownership of nothing; the reply goes out when the handler
 * returns, or when a suspended request is resumed.  CORS and nosniff
 * headers are added to every reply here.  A reply replaces the one before.
 * Out of memory, r->gone is set: the transport drops the connection. */
void http_reply_data(struct http_req *r, unsigned status, const char *ctype, const void *data,
                     size_t len);
/* o as the JSON body, deleted; Cache-Control: no-store on a success. */
void http_reply_json(struct http_req *r, unsigned status, cJSON *o);
/* An image as the body (refs img), of Content-Type type (image/png, image/x-exr). */
void http_reply_image(struct http_req *r, unsigned status, struct blob *img, const char *type);
/* The JSON error body of the API.  path NULL or "" leaves it out; line and
 * column are written when line > 0; param names a bad query parameter. */
void http_reply_error(struct http_req *r, unsigned status, const char *code, const char *message,
                      const char *path, int line, int column, const char *param);
/* A body of unknown length, read by the transport as it sends (an event
 * stream): see struct http_reply.  headers: name, value, ..., NULL, put
 * before those every reply carries.  done(cls) is called once whatever
 * happens, even when this fails. */
void http_reply_stream(struct http_req *r, unsigned status, const char *const *headers,
                       size_t block, ssize_t (*read)(void *cls, char *buf, size_t max),
                       void (*done)(void *cls), void *cls);
/* Sets a header of the response queued last (call right after a reply):
 * one of a name, the last value set replacing any before it, since the
 * layers a reply passes (http_reply_json, http_reply_error, a route) may
 * each set Cache-Control. */
void http_reply_header(struct http_req *r, const char *name, const char *value);
/* 304 Not Modified: no body, no Content-Length, the cache headers of the
 * 200 (http_reply_cache_headers).  The connection closes after it. */
void http_reply_not_modified(struct http_req *r);
/* The headers of an answer whose body is not made (HEAD of an image that
 * would have to be rendered): Content-Type, no body, no Content-Length; the
 * connection closes after it, as after a 304. */
void http_reply_head(struct http_req *r, unsigned status, const char *ctype);
/* Adds field to the reply's one Vary header (Vary: Accept, Authorization). */
void http_reply_vary(struct http_req *r, const char *field);
/* ETag + immutable Cache-Control when r->res.etag is set (no-cache when
 * r->res.etag_revalidate; and Vary: Authorization with a token), else no-store. */
void http_reply_cache_headers(struct http_req *r);
/* The Access-Control-Allow-Origin value for r under --cors-origin, or NULL. */
const char *http_reply_cors_origin(struct http_req *r);

#endif
