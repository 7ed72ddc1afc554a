/* base.h -- the bottom layer of the daemon: options, logging, metrics, the
 * shared PNG blob and the few JSON helpers every upper layer writes with.
 *
 * Layer: base (config.c, log.c, clock.c, mem.c, metrics.c, procstat.c, blob.c,
 * json.c).
 * May include: the C library, <rayd/rayd.h> and cJSON -- nothing of
 * server/.  Everything above (work, the HTTP request and reply, handlers,
 * router, transport, main) may include this header.  A base file never
 * calls a function of an upper layer by name: what metrics.c reports about
 * the layers above, it reads through callbacks they registered at start-up.
 *
 * Every file of server/ is one idea and its public names start with the
 * file's name (config_, log_, clock_, metrics_, blob_, json_).  The server's layers,
 * bottom to top, are drawn in docs/architecture.md and kept by
 * tools/check_layers.py.
 */
#ifndef RAYD_SERVER_BASE_H
#define RAYD_SERVER_BASE_H

#include <rayd/rayd.h>

#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <sys/types.h>

/* ---- config.c ---------------------------------------------------------- */

struct config {
    char *bind;               /* address to listen on */
    long port;                /* 0 picks a free port */
    long threads;             /* render workers; 0 = number of cores */
    long http_threads;        /* libmicrohttpd threads (validation, I/O) */
    long queue;               /* pending render tasks before 503 */
    long parse_threads;       /* threads that parse and build scenes (compile.c) */
    long parse_queue;         /* scenes waiting for a parse thread before 503 */
    long max_body;            /* bytes of a request body */
    long max_pixels;          /* width * height of a scene */
    long max_samples;         /* render.samples of a scene */
    char *token_file;         /* bearer token file, NULL = no auth */
    long cache_mb;            /* compiled scene cache budget */
    long result_cache_mb;     /* finished PNG cache budget */
    char *max_memory;         /* --max-memory as given (bytes, K/M/G/T suffixes); NULL: default */
    char *log_format;         /* text | json */
    char *log_level;          /* debug | info | warn | error: the least severe line written */
    long drain_seconds;       /* grace period on SIGTERM */
    char *cors_origin;        /* comma-separated allow-list, "*" = any */
    long timeout;             /* connection idle timeout, seconds */
    long max_jobs;            /* jobs kept for GET /v1/jobs/{id} */
    long job_ttl;             /* seconds a finished job is kept */
    long max_frames;          /* frames of one frame-range job */
    long max_render_seconds;  /* a render running longer is stopped; 0: no limit */
    long png_level;           /* zlib level of the PNGs, -1 default */
    long max_work;            /* largest render in estimated rays, 0 = no limit */
    long max_backlog;         /* /readyz 503 past this many estimated seconds, 0 = never */
    char *client_header;      /* header naming the client for fair shares, NULL = peer address */
    long max_conns;           /* open connections in all */
    long max_conns_per_ip;    /* open connections from one address, 0 = no limit */
    long max_header_bytes;    /* per-connection memory for request line + headers */
    long max_url;             /* bytes of the request-target (path + query) */
    long upload_seconds;      /* longest time from the headers to the body's last byte, 0 = none */
    long header_seconds;      /* longest time for the request line and headers, 0 = none */
    char *tls_cert, *tls_key; /* PEM files: serve HTTPS with libmicrohttpd's TLS */
    char *asset_dir;          /* folder of scene "file" references (real path), NULL = refused */
    char *test_gate;          /* tests only: "open" or tiles allowed; NULL = off */
    char *data_dir;           /* jobs kept on disk here (store.c), NULL = in memory only */
    char *max_disk;           /* --max-disk as given (bytes, K/M/G/T suffixes); NULL: no budget */
    char *redis;         /* --redis URL: jobs shared by the nodes (server/cluster/), NULL off */
    long redis_claim_ms; /* an item untouched this long is taken by another node */
    long cluster_tile;   /* the edge of a cluster work item's tile, pixels */
    /* derived */
    char *token; /* contents of token_file, trimmed */
    size_t token_len;
    bool log_json;
    int log_min;             /* enum log_level of --log-level */
    long test_gate_tiles;    /* parsed --test-gate: -1 open, -2 off */
    size_t max_memory_bytes; /* parsed --max-memory: the one budget (mem.c) */
    size_t max_disk_bytes;   /* parsed --max-disk, 0 = no budget */
};

extern struct config config;

/* What config_load found: run, or exit with the status in the comment (the
 * three tools' convention; the message is printed). */
enum config_result {
    CONFIG_RUN = 0,
    CONFIG_DONE = 1,    /* --help or --version printed: exit 0 */
    CONFIG_FAILED = -2, /* a file an option names cannot be read: exit 1 */
    CONFIG_USAGE = -1,  /* a bad option or value: exit 2 */
};
/* Parses environment then argv into config: an enum config_result. */
int config_load(int argc, char **argv);
bool config_loopback(const char *addr); /* 127.x, ::1 or localhost */
void config_free(void);

/* ---- log.c --------------------------------------------------------------- */

enum log_level { LOG_DEBUG, LOG_INFO, LOG_WARN, LOG_ERROR };

/* How long a request's render waited in the queue, rendered and encoded,
 * in milliseconds.  The work layer measures them; they travel up whole, in
 * the work result (work.h), the request's result (request.h) and the
 * access log line, never copied field by field.  All zero: nothing was
 * rendered for the request (a cached answer, a refusal). */
struct log_times {
    double queue_ms, render_ms, encode_ms;
};

/* One finished request.  Strings may be NULL (written "-" or left out);
 * path is the request-target as the client sent it, query included. */
struct log_access {
    const char *client, *method, *path;
    int status;   /* 0: refused by the HTTP parser before a status was known */
    size_t bytes; /* body bytes sent */
    /* An answer cut short (the client closed, a send failed, the timeout):
     * why ("client_closed"), and the whole body's size; NULL and 0 else. */
    const char *cut;
    size_t size;
    double total_ms;
    struct log_times times; /* all zero: left out of the line */
    const char *scene;      /* the scene's id, or NULL */
    const char *request_id; /* X-Request-Id sent back, or NULL */
    const char *note;       /* "client_gone", ... or NULL */
    const char *error;      /* the error reply's code ("invalid_scene"), or NULL */
    const char *error_at;   /* its JSON Pointer or query parameter, or NULL / "" */
};

extern bool log_quiet; /* no output at all (the fuzz harness) */
void log_access(const struct log_access *a);
void log_debug(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
void log_info(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
void log_warn(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
void log_error(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

/* server_assert(e): an invariant the code relies on -- a "lock held"
 * contract, a count that cannot go below zero, a state a function needs.
 * When e is false, the file, line, function and the expression go to
 * stderr and the process aborts: a broken invariant is a bug, and going on
 * would serve wrong answers or corrupt shared state.  Checked in every
 * build the Makefile makes (the default one, ASan and TSan: the tests run
 * them all); -DNDEBUG leaves the checks out, as it does assert()'s. */
#ifdef NDEBUG
#define server_assert(e) ((void)sizeof(e))
#else
#define server_assert(e) ((e) ? (void)0 : log_assert_fail(#e, __FILE__, __LINE__, __func__))
#endif
_Noreturn void log_assert_fail(const char *expr, const char *file, int line, const char *func);

/* ---- clock.c ------------------------------------------------------------- */

double clock_now(void); /* monotonic seconds: every duration the server measures */
/* The test gate's jump (?clock=S): clock_now() is SECONDS later from now on;
 * returns the seconds skipped in all. */
double clock_skip(long seconds);
/* The wall-clock moment SECONDS from now, as pthread_cond_timedwait takes it. */
struct timespec clock_after(double seconds);

/* ---- mem.c: the one memory budget (--max-memory) ------------------------ */

/* What the budget's bytes are: rayd_memory_bytes{kind=...}. */
enum mem_kind {
    MEM_BODIES,  /* request bodies in flight */
    MEM_SCENES,  /* compiled scenes: cached, queued or in use */
    MEM_RESULTS, /* finished images (PNG, EXR, sums answers) and renders' pixels */
    MEM_SUMS,    /* renders' per-pixel sums: sums answers, progressive jobs */
    MEM_CACHES,  /* finished images kept by the result cache */
    MEM_PARSES,  /* scenes being parsed: each parse's cap, reserved before it starts */
    MEM_FRAMES,  /* finished frames of frame-range jobs kept in memory (no --data-dir) */
    MEM__COUNT
};
const char *mem_kind_name(enum mem_kind k);
size_t mem_default_limit(void); /* half the machine's (or the cgroup's) memory */
void mem_start(size_t limit);   /* once, before the first thread; 0: the default */
size_t mem_limit(void);
/* Called by a reservation of need bytes of k that does not fit, with no
 * lock held: frees one thing it may let go for k (evicts); false when
 * nothing is left to free. */
void mem_set_reclaim(bool (*reclaim)(enum mem_kind k, size_t need));
/* Counts n bytes of k if they fit under the limit, after the reclaimer freed
 * room; false (nothing counted) if they do not.  Never with work_lock held. */
bool mem_reserve(enum mem_kind k, size_t n);
void mem_force(enum mem_kind k, size_t n); /* bytes that exist: counted past the limit */
void mem_release(enum mem_kind k, size_t n);
void mem_move(enum mem_kind from, enum mem_kind to, size_t n);
void mem_freed(size_t n); /* bytes freed that were never counted: for mem_trim */
size_t mem_used(enum mem_kind k);
size_t mem_peak(void); /* the highest total counted since the start */
/* Gives freed heap back to the kernel once enough was released since the
 * last time (malloc_trim), and, once idle (no render left), the frames the
 * core keeps for reuse.  Called by the watcher only, one thread (it takes
 * milliseconds with a large heap): never on a request's path. */
void mem_trim(bool idle);
/* "64M", "1G", "1048576", "512KiB": bytes; false if malformed. */
bool mem_parse(const char *s, size_t *out);

/* ---- metrics.c ----------------------------------------------------------- */

enum metrics_reject {
    MR_QUEUE_FULL,
    MR_DRAINING,
    MR_BODY_TOO_LARGE,
    MR_UNAUTHORIZED,
    MR_OVER_BUDGET,      /* --max-work */
    MR_HTTP_PARSER,      /* answered with an error by libmicrohttpd itself */
    MR_MEMORY,           /* --max-memory: no room (503) or too big alone (413) */
    MR_PARSE_QUEUE_FULL, /* --parse-queue scenes already wait for a parse thread */
    MR_HEADER_TIMEOUT,   /* --header-seconds: a connection's headers came too slowly */
    MR__COUNT
};
enum metrics_cancel { MC_CLIENT_GONE, MC_DELETE, MC_DRAIN, MC_DEADLINE, MC__COUNT };
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
/* Gauges: values owned by a layer above, read when /metrics is scraped
 * through the function that layer registered (metrics_gauge) at start-up.
 * A gauge nobody registered reads 0. */
enum metrics_gauge {
    MG_QUEUE_DEPTH,
    MG_QUEUE_CAPACITY,
    MG_TASKS_RUNNING,
    MG_WORKERS_BUSY,
    MG_WORKERS,
    MG_JOBS,
    MG_HTTP_SUSPENDED,
    MG_DRAINING,
    MG_CACHE_BYTES,
    MG_CACHE_ENTRIES,
    MG_RESULT_CACHE_BYTES,
    MG_RESULT_CACHE_ENTRIES,
    MG_BACKLOG_MS,     /* estimated work waiting or running, in milliseconds of the pool */
    MG_IMAGES_SHARED,  /* image textures a parse found decoded (a counter) */
    MG_IMAGES_DECODED, /* image textures a parse decoded (a counter) */
    MG_MESHES_SHARED,  /* meshes a parse found built (a counter) */
    MG_MESHES_BUILT,   /* meshes a parse built for others to take (a counter) */
    MG__COUNT
};

/* Sets the duration buckets: the standard ladder from 1 ms, cut at the
 * longest render allowed (--max-render-seconds; 0 = no limit, up to 3600 s)
 * and ending exactly at it.  Called once before the first thread starts;
 * without it the ladder ends at 3600 s. */
void metrics_start(long max_render_seconds);
void metrics_free(void); /* at exit: the per-series histograms */
/* Counters and histograms: pushed by the layer that sees the event. */
/* A finished request: route label index (-1 none), its method as sent, the
 * status and the seconds from its first byte to its last. */
void metrics_request(int route, const char *method, int status, double seconds);
void metrics_queue_wait(bool interactive, double seconds); /* by class */
void metrics_render(double seconds);
void metrics_stage(enum metrics_stage stage, double seconds);
void metrics_cache(bool hit);
void metrics_result_cache(bool hit);
void metrics_reject(enum metrics_reject why);
void metrics_cancel(enum metrics_cancel why);
void metrics_rays(uint64_t n);
void metrics_coalesced(void);
void metrics_scene_parse(void);            /* a scene body parsed and built (compile.c) */
void metrics_scene_parse_canceled(void);   /* one stopped by its cancel flag (scenes.c) */
void metrics_file_checks(unsigned long n); /* stats of a cached scene's files */
/* Registration, once at start-up, before the first scrape. */
void metrics_gauge(enum metrics_gauge g, long (*read)(void));
void metrics_route_name(int route, const char *name); /* label of a route index */
/* The Prometheus text exposition; malloc'd, *len set. */
char *metrics_text(size_t *len);

/* ---- procstat.c: the process_* metrics ------------------------------------ */

struct procstat {
    double cpu_seconds; /* user + system */
    double start_time;  /* seconds since the epoch */
    double resident_bytes, virtual_bytes;
    double open_fds, max_fds;
};
/* Reads /proc; false when some field could not be read (then it is 0). */
bool procstat_read(struct procstat *p);

/* ---- blob.c -------------------------------------------------------------- */

/* A refcounted PNG shared by every request answered with it: the workers
 * make it, the caches keep it, the transport sends it. */
struct blob {
    atomic_int refs;
    void *data; /* rayd_free()d with the last reference */
    size_t len;
    atomic_int kind; /* enum mem_kind its len is counted as (mem.c) */
};
/* A blob owning data (from the core's allocator), one reference, its len
 * counted in the memory budget as MEM_RESULTS until the last reference
 * goes; NULL on no memory (data is then left to the caller). */
struct blob *blob_new(void *data, size_t len);
struct blob *blob_ref(struct blob *b); /* returns b; NULL allowed */
void blob_unref(struct blob *b);       /* NULL allowed */
/* The blob's bytes are counted as kind from now on (the result cache). */
void blob_kind(struct blob *b, enum mem_kind kind);

/* ---- json.c -------------------------------------------------------------- */

/* cJSON writes every JSON document of the server; these keep the number
 * formats docs/api.md shows (progress 0.4167, milliseconds 380.100). */
typedef struct cJSON cJSON;
/* Adds key: v with exactly decimals digits after the point. */
void json_add_fixed(cJSON *o, const char *key, double v, int decimals);
void json_add_u64(cJSON *o, const char *key, uint64_t v);
/* o unformatted, with a final newline when nl; malloc'd (free()), NULL on no
 * memory.  Deletes o (NULL allowed: then NULL). */
char *json_print(cJSON *o, bool nl, size_t *len);
/* o unformatted into buf (a line for a log or an event); false when it does
 * not fit.  Does not delete o. */
bool json_print_into(cJSON *o, char *buf, size_t size);

/* ---- video.c: frames as an H.264 MP4, by the ffmpeg program ------------ */

enum video_status { VIDEO_OK, VIDEO_FAILED, VIDEO_NO_FFMPEG };
/* n PNG frames at fps as an MP4 (*out, one reference), ffmpeg killed past
 * limit seconds; else err says why.  Blocks: never on an HTTP thread. */
enum video_status video_encode(struct blob *const *frames, int n, double fps, double limit,
                               struct blob **out, char *err, size_t size);
/* From now on video_encode begins nothing and kills the ffmpeg running
 * (its folder removed): the server stops. */
void video_stop(void);
/* Removes the frame folders that rayd processes no longer running left in
 * $TMPDIR (killed mid-video); how many. */
int video_sweep(void);

#endif
