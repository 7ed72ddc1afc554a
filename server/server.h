/* server.h -- the internal interfaces of the rayd daemon.
 *
 * One header for the whole server, as Redis has server.h: every file of
 * server/ is one idea and its public names start with the file's name
 * (config_, http_, router_, jobq_, cache_, metrics_, log_, api_).
 * Only include/rayd/rayd.h crosses from the core; nothing here knows about
 * the core's internals, and only http.c, api_*.c and main.c know about
 * libmicrohttpd.
 */
#ifndef RAYD_SERVER_H
#define RAYD_SERVER_H

#include <rayd/rayd.h>

#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <sys/types.h>

/* ---- config.c ---------------------------------------------------------- */

struct config {
    char *bind;          /* address to listen on */
    long port;           /* 0 picks a free port */
    long threads;        /* render workers; 0 = number of cores */
    long http_threads;   /* libmicrohttpd threads (validation, I/O) */
    long queue;          /* pending render tasks before 503 */
    long max_body;       /* bytes of a request body */
    long max_pixels;     /* width * height of a scene */
    char *token_file;    /* bearer token file, NULL = no auth */
    long cache_mb;       /* compiled scene cache budget */
    long result_cache_mb; /* finished PNG cache budget */
    char *log_format;    /* text | json */
    long drain_seconds;  /* grace period on SIGTERM */
    char *cors_origin;   /* comma-separated allow-list, "*" = any */
    long timeout;        /* connection idle timeout, seconds */
    long max_jobs;       /* jobs kept for GET /v1/jobs/{id} */
    long job_ttl;        /* seconds a finished job is kept */
    long png_level;      /* zlib level of the PNGs, -1 default */
    long max_conns;      /* open connections in all */
    long max_conns_per_ip; /* open connections from one address, 0 = no limit */
    long max_header_bytes; /* per-connection memory for request line + headers */
    long max_url;        /* bytes of the request-target (path + query) */
    long upload_seconds; /* longest time from the headers to the body's last byte, 0 = none */
    char *tls_cert, *tls_key; /* PEM files: serve HTTPS with libmicrohttpd's TLS */
    char *test_gate;     /* tests only: "open" or tiles allowed; NULL = off */
    /* derived */
    char *token;         /* contents of token_file, trimmed */
    size_t token_len;
    bool log_json;
    long test_gate_tiles; /* parsed --test-gate: -1 open, -2 off */
};

extern struct config config;

/* Parses environment then argv into config.  Returns 0 to run, 1 when the
 * program should exit 0 (--help, --version), -1 on a bad option (the message
 * is printed). */
int config_load(int argc, char **argv);
void config_usage(FILE *f);
bool config_loopback(const char *addr); /* 127.x, ::1 or localhost */
void config_free(void);

/* ---- log.c --------------------------------------------------------------- */

struct log_access {
    const char *method, *path;
    int status;
    size_t bytes;
    double queue_ms, render_ms, encode_ms, total_ms;
    const char *note; /* "client_gone", ... or NULL */
};

extern bool log_quiet; /* no output at all (the fuzz harness) */
void log_access(const struct log_access *a);
void log_info(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
void log_warn(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
double log_now(void); /* monotonic seconds */

/* ---- metrics.c ----------------------------------------------------------- */

enum metrics_reject { MR_QUEUE_FULL, MR_DRAINING, MR_BODY_TOO_LARGE, MR_UNAUTHORIZED, MR__COUNT };
enum metrics_cancel { MC_CLIENT_GONE, MC_DELETE, MC_DRAIN, MC__COUNT };
/* The stages of a request's wait, end to end: the body arriving, the scene
 * parsed, its mesh files decoded and its BVHs built (a cache miss), the
 * queue, the tiles, the PNG, the reply going out.  One histogram,
 * rayd_stage_seconds{stage=...}. */
enum metrics_stage {
    MS_UPLOAD,
    MS_PARSE,
    MS_DECODE,
    MS_BUILD,
    MS_QUEUE,
    MS_RENDER,
    MS_ENCODE,
    MS_SEND,
    MS__COUNT
};

void metrics_request(int route, int status);
void metrics_queue_wait(double seconds);
void metrics_render(double seconds);
void metrics_stage(enum metrics_stage stage, double seconds);
void metrics_cache(bool hit);
void metrics_result_cache(bool hit);
void metrics_reject(enum metrics_reject why);
void metrics_cancel(enum metrics_cancel why);
void metrics_rays(uint64_t n);
void metrics_coalesced(void);
/* The Prometheus text exposition; malloc'd, *len set. */
char *metrics_text(size_t *len);

/* ---- cache.c (not thread-safe: jobq.c calls it under its lock) ----------- */

/* lru.c: the index under both caches; entries embed a struct lru_node. */
struct lru_node {
    const char *key;
    size_t bytes; /* counted against the budget */
    struct lru_node *hnext, *prev, *next;
};
struct lru {
    struct lru_node **table;
    unsigned nbuckets;
    struct lru_node *head, *tail; /* most recent first */
    size_t budget, bytes, count;
    void (*evict)(struct lru_node *n); /* the owner lets go of an evicted entry */
};
void lru_init(struct lru *l, struct lru_node **table, unsigned nbuckets, size_t budget,
              void (*evict)(struct lru_node *n));
struct lru_node *lru_find(struct lru *l, const char *key); /* and makes it the most recent */
bool lru_insert(struct lru *l, struct lru_node *n);        /* false: bigger than the budget */
void lru_remove(struct lru *l, struct lru_node *n);
void lru_clear(struct lru *l); /* evicts everything */

struct cache_entry; /* a compiled scene and its id */

void cache_init(size_t budget_bytes);
/* SHA-256 of data as 64 lowercase hex digits (a scene id, an ETag); false
 * (and out = "") only if libcrypto fails.  Thread-safe. */
bool cache_hash(const void *data, size_t len, char out[65]);
struct cache_entry *cache_get(const char *id); /* refs the entry, bumps LRU */
/* Inserts (or returns the existing entry for id, freeing scene); refs it. */
struct cache_entry *cache_put(const char *id, rayd_scene *scene);
struct cache_entry *cache_ref(struct cache_entry *e);
void cache_release(struct cache_entry *e); /* drops a ref; frees when evicted */
const rayd_scene *cache_scene(const struct cache_entry *e);
const char *cache_id(const struct cache_entry *e);
void cache_stats(size_t *bytes, size_t *entries);
void cache_free_all(void);

/* ---- rcache.c (finished PNGs; not thread-safe: called under jobq's lock) --- */

struct blob;
void rcache_init(size_t budget_bytes);
struct blob *rcache_get(const char *key); /* refs the PNG */
void rcache_put(const char *key, struct blob *png);
void rcache_stats(size_t *bytes, size_t *entries);
void rcache_free_all(void);

/* ---- jobq.c -------------------------------------------------------------- */

/* A refcounted PNG shared by every request answered with it. */
struct blob {
    atomic_int refs;
    void *data;
    size_t len;
};
void blob_unref(struct blob *b);

struct jobq_result {
    enum rayd_status status; /* RAYD_OK and png, or an error */
    struct rayd_error err;
    struct blob *png;        /* owned by the waiter: unref it */
    bool gone;               /* the client disconnected */
    double queue_ms, render_ms, encode_ms;
};

/* Something waiting on a task or a job's events: a suspended connection.
 * jobq calls done() exactly once, from a worker or the watcher thread, after
 * removing the waiter from every list. */
struct jobq_waiter {
    void (*done)(struct jobq_waiter *w, struct jobq_result *res);
    int fd;                   /* socket polled for a client hang-up, -1 none */
    struct jobq_waiter *next;
};

enum jobq_submit { JOBQ_OK = 0, JOBQ_FULL, JOBQ_DRAINING, JOBQ_NOMEM, JOBQ_TOO_MANY_JOBS };

int jobq_start(int workers, int queue_cap, int max_jobs);
void jobq_stop(void);

/* Scenes: the compiled-scene cache, under the queue's lock.  get_or_parse
 * hashes the body, looks it up, parses on a miss (outside the lock). */
enum rayd_status jobq_scene_parse(const char *body, size_t len, struct cache_entry **out,
                                  bool *hit, struct rayd_error *err);
struct cache_entry *jobq_scene_find(const char *id);
/* Replaces the scene limits derived from the options (before any request). */
void jobq_set_limits(const struct rayd_limits *lim);
void jobq_scene_release(struct cache_entry *e);

/* Synchronous render: answers w->done once.  reg is absolute and checked.
 * When accepted, suspend(w) runs under the lock before any worker can answer. */
/* A finished PNG of (scene, reg) from the result cache, ref'd, or NULL. */
struct blob *jobq_result_find(const struct cache_entry *scene, const struct rayd_region *reg);
enum jobq_submit jobq_render(struct cache_entry *scene, const struct rayd_region *reg,
                             struct jobq_waiter *w, void (*suspend)(struct jobq_waiter *w));

/* Jobs (asynchronous renders). */
enum jobq_state { JS_QUEUED, JS_RUNNING, JS_SUCCEEDED, JS_FAILED, JS_CANCELED };
const char *jobq_state_name(enum jobq_state s);
struct jobq_job_info {
    enum jobq_state state;
    double progress;
    long tiles_done, tiles_total;
    struct rayd_region region;
    char scene_id[65];
    double created_age, queue_ms, render_ms, encode_ms;
    uint64_t rays;
    struct rayd_error err; /* when failed */
    struct blob *png;      /* when succeeded and asked for; unref it */
};
enum jobq_submit jobq_job_create(struct cache_entry *scene, const struct rayd_region *reg,
                                 char id[33]);
bool jobq_job_get(const char *id, struct jobq_job_info *info, bool want_png);
bool jobq_job_cancel(const char *id);

/* Server-Sent Events of a job: open, then read repeatedly.  read returns
 * bytes written, 0 after registering w (the caller must suspend inside
 * suspend(), which runs under the lock), -1 at the end of the stream. */
struct jobq_sse;
struct jobq_sse *jobq_sse_open(const char *id);
ssize_t jobq_sse_read(struct jobq_sse *s, char *buf, size_t max, struct jobq_waiter *w,
                      void (*suspend)(struct jobq_waiter *w));
void jobq_sse_close(struct jobq_sse *s);

/* The test gate (--test-gate): workers start a tile only while the gate
 * lets one through.  tiles: how many more may start, -1 = open. */
struct jobq_gate {
    long tiles, started, held, queued;
};
void jobq_gate_enable(long tiles);
bool jobq_gate_set(long tiles);          /* false when the gate is off */
bool jobq_gate_get(struct jobq_gate *g); /* false when the gate is off */

/* Lifecycle and numbers. */
void jobq_drain(void);         /* refuse new work from now on */
void jobq_cancel_all(void);    /* cancel every task (drain deadline) */
bool jobq_idle(void);          /* no task queued or running */
bool jobq_draining(void);
struct jobq_stats {
    long queued, running_tasks, busy_workers, workers, jobs, queue_cap;
    size_t cache_bytes, cache_entries, result_bytes, result_entries;
};
void jobq_stats(struct jobq_stats *st);

/* ---- http.c -------------------------------------------------------------- */

struct MHD_Connection;
struct MHD_Response;
struct http_req;

/* Where a request comes from: libmicrohttpd (http.c) or a test harness
 * (tests/fuzz/fuzz_http.c) -- the request flow and every handler reach the
 * connection only through these. */
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

/* One HTTP request from the first header to the last byte sent. */
struct http_req {
    const struct http_io *io;
    void *io_ctx;                /* the transport's own (an MHD_Connection) */
    const char *method, *url;
    size_t target_len;           /* bytes of the request-target, query included */
    const char *err_code;        /* code of the error reply sent, NULL for none */
    char *body;
    size_t body_len, body_cap;
    int route;                   /* router index for metrics, -1 none */
    int status;                  /* the status sent */
    size_t bytes;                /* response body size */
    double t0, queue_ms, render_ms, encode_ms;
    double t_sent;               /* when the response was handed to libmicrohttpd */
    bool is_png;                 /* the response is an image (its send is a stage) */
    struct MHD_Response *pending; /* to queue when the handler runs again */
    unsigned pending_status;
    bool suspended, gone, replied, too_large, no_memory;
    bool parked;                 /* suspended by the handler now running (its thread only) */
    struct jobq_waiter waiter;   /* while suspended on a render */
    struct jobq_sse *sse;        /* for an event stream */
    const char *note;
    char etag[72];               /* set for immutable GETs */
};

/* The request flow, independent of the transport (http.c drives it from
 * libmicrohttpd's callbacks; the fuzz harness calls it directly):
 *   http_req_new    a request with its method and path (strings kept by the caller);
 *   http_req_begin  headers only: refuses early (400 for an ambiguous body length,
 *                   413 by Content-Length, 414 over --max-url);
 *                   false when a reply is already pending;
 *   http_req_body   appends a body chunk (counted, not kept, past --max-body);
 *                   false when the transport should drop the connection;
 *   http_req_handle the whole request is here: auth, CORS, routing; the handler
 *                   replies (r->pending) or suspends (then r->parked is set and
 *                   r belongs to the worker until it resumes the request);
 *   http_req_end    access log, metrics, free. */
struct http_req *http_req_new(const struct http_io *io, void *io_ctx, const char *method,
                              const char *url, size_t target_len);
bool http_req_begin(struct http_req *r);
bool http_req_body(struct http_req *r, const char *data, size_t n);
void http_req_handle(struct http_req *r);
void http_req_end(struct http_req *r, const char *note);

int http_start(void);
bool http_tls(void);            /* serving HTTPS */
int http_port(void);
void http_stop(void);
long http_suspended(void);      /* connections suspended right now */
long http_in_flight(void);      /* requests not yet completed */
double http_last_request(void); /* when the latest request came (log_now() time) */

const char *http_header(struct http_req *r, const char *name);
const char *http_query(struct http_req *r, const char *name);
/* Calls fn for every query argument. */
void http_query_each(struct http_req *r, void (*fn)(void *u, const char *k, const char *v),
                     void *u);

/* Replies.  Each takes ownership of nothing; the response goes out when the
 * handler returns (or when a suspended request is resumed). */
void http_reply(struct http_req *r, unsigned status, struct MHD_Response *resp);
void http_reply_data(struct http_req *r, unsigned status, const char *ctype, const void *data,
                     size_t len);
void http_reply_json(struct http_req *r, unsigned status, const char *json);
void http_reply_png(struct http_req *r, unsigned status, struct blob *png);
/* The JSON error body of the API.  path NULL or "" leaves it out; line and
 * column are written when line > 0; param names a bad query parameter. */
void http_reply_error(struct http_req *r, unsigned status, const char *code, const char *message,
                      const char *path, int line, int column, const char *param);
/* The one place where a core status becomes an HTTP status and error code. */
void http_reply_rayd_error(struct http_req *r, const struct rayd_error *err);
unsigned http_status_of(enum rayd_status s);
/* Adds a header to the response queued last (call right after a reply). */
void http_add_header(struct http_req *r, const char *name, const char *value);

void http_suspend(struct http_req *r);
void http_resume(struct http_req *r);
int http_conn_fd(struct http_req *r);
/* ETag + immutable Cache-Control when r->etag is set, else no-store. */
void http_cache_headers(struct http_req *r);
/* The next item of a comma-separated header value (spaces trimmed): false
 * at the end; *p advances past it. */
bool http_list_next(const char **p, const char **item, size_t *len);
/* Submits a render of reg for r: suspends r until a worker answers (the
 * answer becomes the reply), or replies 503 when refused. */
void http_render(struct http_req *r, struct cache_entry *scene, const struct rayd_region *reg);
/* Reply for a refused submission (queue full, draining, ...). */
void http_reply_refused(struct http_req *r, enum jobq_submit why);
/* Body is JSON?  Otherwise replies 415 and returns false. */
bool http_require_json(struct http_req *r);
/* JSON string escaping into buf; returns buf. */
char *http_json_escape(const char *s, char *buf, size_t size);
bool http_is_draining(void);
void http_set_draining(void);

/* ---- router.c ------------------------------------------------------------ */

typedef void (*router_handler)(struct http_req *r, const char *id);
void router_dispatch(struct http_req *r);
const char *router_name(int route);
int router_count(void);
/* Allowed methods for a path ("GET, DELETE"), NULL when no route matches. */
const char *router_allow(const char *path, char *buf, size_t size);

/* ---- api_*.c ------------------------------------------------------------- */

/* Parses ?x=&y=&w=&h= strictly against scene; on error replies 400 and
 * returns false.  No parameters: the whole image. */
bool api_region(struct http_req *r, const rayd_scene *scene, struct rayd_region *out);

void api_render_post(struct http_req *r, const char *id);
void api_scenes_post(struct http_req *r, const char *id);
void api_scenes_image(struct http_req *r, const char *id);
void api_jobs_post(struct http_req *r, const char *id);
void api_jobs_get(struct http_req *r, const char *id);
void api_jobs_image(struct http_req *r, const char *id);
void api_jobs_events(struct http_req *r, const char *id);
void api_jobs_delete(struct http_req *r, const char *id);
void api_health_live(struct http_req *r, const char *id);
void api_health_ready(struct http_req *r, const char *id);
void api_health_metrics(struct http_req *r, const char *id);
void api_test_gate_get(struct http_req *r, const char *id);
void api_test_gate_post(struct http_req *r, const char *id);
void api_web_index(struct http_req *r, const char *id);
void api_web_asset(struct http_req *r, const char *id);
bool api_web_exists(const char *name);

#endif
