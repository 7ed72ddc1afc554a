/* metrics.c -- counters and histograms, exposed as Prometheus text.
 *
 * Every number is a C11 atomic, bumped by whichever thread sees the event,
 * so metrics take no lock and cost a few nanoseconds.  The names follow
 * Prometheus's conventions, so the usual dashboards and alerts apply:
 *
 *   rayd_http_requests_total{route,method,code} and
 *   rayd_http_request_duration_seconds{route,method,code}: route is the
 *     router's pattern ("/v1/scenes/{id}/image.png", or "none"), never a
 *     path with its ids; method is the request's (or "other" past the seven
 *     standard ones: a client cannot mint series); code the status sent
 *     (499 when the client left first).  The counter is the histogram's
 *     count, so the two never disagree.
 *   rayd_build_info{version,compiler} 1, and the process_* family of every
 *     client library (procstat.c).
 *
 * A (route, method, code) histogram is allocated the first time it is seen
 * and published with a compare-and-swap, so a scrape prints only the series
 * that happened.  Codes take one of 24 slots in the order they are first
 * seen (rayd sends about 20); a 25th distinct code would be counted as
 * code="other".
 *
 * Every duration histogram shares one ladder of buckets, 1 ms up to the
 * longest render allowed (metrics_start): a queue wait, a render, an event
 * stream may all last that long, and a histogram whose last bucket is below
 * its slowest events cannot tell "slow" from "stuck".  Queue wait and render
 * time are separate histograms, so a slow response can be told apart as
 * "waited" or "rendered".
 *
 * Layer: base.  Counters are pushed here by the layer that sees the event;
 * gauges (queue depth, busy workers, cache size, suspended connections) and
 * the routes' labels belong to the layers above, which register a reader
 * function or a name at start-up (metrics_gauge, metrics_route_name).  So
 * metrics.c names no function of any other server file, and a scrape reads
 * each gauge through the pointer its owner handed in.
 */
#include "base/base.h"

#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

#define METRICS_ROUTES 32

static const char *const metrics_methods[] = {"GET",    "HEAD",    "POST",  "PUT",
                                              "DELETE", "OPTIONS", "PATCH", "other"};
#define METRICS_NMETHODS (sizeof metrics_methods / sizeof metrics_methods[0])
#define METRICS_NCODES 25 /* 24 codes as first seen, then "other" */

/* The standard ladder, cut and ended at --max-render-seconds. */
#define METRICS_LADDER                                                                             \
    0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30, 60, 120, 300, 600, \
        1800, 3600
static const double metrics_ladder[] = {METRICS_LADDER};
#define METRICS_NLADDER (sizeof metrics_ladder / sizeof metrics_ladder[0])
#define METRICS_NB_MAX (METRICS_NLADDER + 1)
/* Written once by metrics_start before any other thread, then only read. */
static double metrics_buckets[METRICS_NB_MAX] = {METRICS_LADDER};
static size_t metrics_nb = METRICS_NLADDER;

struct metrics_hist {
    atomic_ulong bucket[METRICS_NB_MAX + 1]; /* [metrics_nb] is +Inf */
    atomic_ulong count;
    atomic_ulong sum_us;
};

static _Atomic(struct metrics_hist *) metrics_http[METRICS_ROUTES + 1][METRICS_NMETHODS]
                                                  [METRICS_NCODES];
static atomic_int metrics_codes[METRICS_NCODES - 1]; /* 0: a free slot */
static struct metrics_hist metrics_wait[2], metrics_rend,
    metrics_stages[MS__COUNT]; /* wait: [interactive] */
static const char *const metrics_stage_names[MS__COUNT] = {"upload", "parse",  "decode", "build",
                                                           "queue",  "render", "encode", "send"};
static atomic_ulong metrics_hits, metrics_misses, metrics_rhits, metrics_rmisses, metrics_rays_n,
    metrics_coalesced_n;
static atomic_ulong metrics_parses_n, metrics_file_checks_n; /* compile.c, scenefiles.c */
static atomic_ulong metrics_parses_canceled_n;               /* scenes.c */
static atomic_ulong metrics_rejects[MR__COUNT], metrics_cancels[MC__COUNT];

static const char *const metrics_reject_names[MR__COUNT] = {
    "queue_full",  "draining", "body_too_large",   "unauthorized",  "over_budget",
    "http_parser", "memory",   "parse_queue_full", "header_timeout"};
static const char *const metrics_cancel_names[MC__COUNT] = {"client_gone", "delete", "drain",
                                                            "deadline"};

/* Written once at start-up (before the listener), read by scrapes. */
static long (*metrics_gauges[MG__COUNT])(void);
static const char *metrics_routes[METRICS_ROUTES];

void metrics_start(long max_render_seconds) {
    size_t n = 0;
    double max = (double)max_render_seconds;
    for (size_t i = 0; i < METRICS_NLADDER; i++)
        if (max <= 0 || metrics_ladder[i] < max) metrics_buckets[n++] = metrics_ladder[i];
    if (max > 0) metrics_buckets[n++] = max;
    metrics_nb = n;
}

void metrics_gauge(enum metrics_gauge g, long (*read)(void)) { metrics_gauges[g] = read; }

void metrics_route_name(int route, const char *name) {
    if (route >= 0 && route < METRICS_ROUTES) metrics_routes[route] = name;
}

static long metrics_read(enum metrics_gauge g) {
    return metrics_gauges[g] ? metrics_gauges[g]() : 0;
}

/* The slot of a status code: found, or taken on first sight. */
static size_t metrics_code_slot(int status) {
    for (size_t i = 0; i < METRICS_NCODES - 1; i++) {
        int c = atomic_load_explicit(&metrics_codes[i], memory_order_acquire);
        if (c == 0) {
            int free_slot = 0;
            if (atomic_compare_exchange_strong(&metrics_codes[i], &free_slot, status)) return i;
            c = free_slot; /* taken meanwhile by another thread: with which code? */
        }
        if (c == status) return i;
    }
    return METRICS_NCODES - 1;
}

static size_t metrics_method_slot(const char *method) {
    size_t i = 0;
    while (i < METRICS_NMETHODS - 1 && (!method || strcmp(metrics_methods[i], method))) i++;
    return i;
}

static void metrics_observe(struct metrics_hist *h, double s) {
    size_t i = 0;
    while (i < metrics_nb && s > metrics_buckets[i]) i++;
    atomic_fetch_add_explicit(&h->bucket[i], 1, memory_order_relaxed);
    atomic_fetch_add_explicit(&h->count, 1, memory_order_relaxed);
    atomic_fetch_add_explicit(&h->sum_us, (unsigned long)(s * 1e6), memory_order_relaxed);
}

void metrics_request(int route, const char *method, int status, double seconds) {
    if (route < 0 || route >= METRICS_ROUTES) route = METRICS_ROUTES;
    _Atomic(struct metrics_hist *) *slot =
        &metrics_http[route][metrics_method_slot(method)][metrics_code_slot(status)];
    struct metrics_hist *h = atomic_load_explicit(slot, memory_order_acquire);
    if (!h) {
        struct metrics_hist *fresh = calloc(1, sizeof *fresh);
        if (!fresh) return; /* out of memory: this request goes uncounted */
        if (atomic_compare_exchange_strong(slot, &h, fresh))
            h = fresh;
        else
            free(fresh); /* h is now the one another thread published */
    }
    metrics_observe(h, seconds);
}

void metrics_free(void) {
    for (size_t r = 0; r <= METRICS_ROUTES; r++)
        for (size_t m = 0; m < METRICS_NMETHODS; m++)
            for (size_t c = 0; c < METRICS_NCODES; c++)
                free(atomic_exchange(&metrics_http[r][m][c], NULL));
}

void metrics_queue_wait(bool interactive, double s) {
    metrics_observe(&metrics_wait[interactive], s);
}
void metrics_render(double s) { metrics_observe(&metrics_rend, s); }
void metrics_stage(enum metrics_stage stage, double s) {
    metrics_observe(&metrics_stages[stage], s);
}
void metrics_cache(bool hit) { atomic_fetch_add(hit ? &metrics_hits : &metrics_misses, 1); }
void metrics_result_cache(bool hit) {
    atomic_fetch_add(hit ? &metrics_rhits : &metrics_rmisses, 1);
}
void metrics_reject(enum metrics_reject why) { atomic_fetch_add(&metrics_rejects[why], 1); }
void metrics_cancel(enum metrics_cancel why) { atomic_fetch_add(&metrics_cancels[why], 1); }
void metrics_rays(uint64_t n) { atomic_fetch_add(&metrics_rays_n, (unsigned long)n); }
void metrics_coalesced(void) { atomic_fetch_add(&metrics_coalesced_n, 1); }
void metrics_scene_parse(void) { atomic_fetch_add(&metrics_parses_n, 1); }
void metrics_scene_parse_canceled(void) { atomic_fetch_add(&metrics_parses_canceled_n, 1); }
void metrics_file_checks(unsigned long n) { atomic_fetch_add(&metrics_file_checks_n, n); }

/* A growable string for the exposition. */
struct metrics_buf {
    char *p;
    size_t len, cap;
};

static void metrics_printf(struct metrics_buf *b, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));

static void metrics_printf(struct metrics_buf *b, const char *fmt, ...) {
    for (;;) {
        va_list ap;
        va_start(ap, fmt);
        int n = b->p ? vsnprintf(b->p + b->len, b->cap - b->len, fmt, ap) : -1;
        va_end(ap);
        if (n >= 0 && (size_t)n < b->cap - b->len) {
            b->len += (size_t)n;
            return;
        }
        size_t cap = b->cap ? b->cap * 2 : 8192;
        char *q = realloc(b->p, cap);
        if (!q) return;
        b->p = q;
        b->cap = cap;
    }
}

/* One histogram's series; label is "" or a label pair and a comma
 * ("stage=\"parse\","). */
static void metrics_hist_series(struct metrics_buf *b, const char *name, const char *label,
                                struct metrics_hist *h) {
    unsigned long cum = 0;
    for (size_t i = 0; i <= metrics_nb; i++) {
        cum += atomic_load(&h->bucket[i]);
        if (i < metrics_nb)
            metrics_printf(b, "%s_bucket{%sle=\"%.15g\"} %lu\n", name, label, metrics_buckets[i],
                           cum);
        else
            metrics_printf(b, "%s_bucket{%sle=\"+Inf\"} %lu\n", name, label, cum);
    }
    size_t n = strlen(label);
    metrics_printf(b, "%s_sum%s%.*s%s %.6f\n%s_count%s%.*s%s %lu\n", name, n ? "{" : "",
                   n ? (int)n - 1 : 0, label, n ? "}" : "", (double)atomic_load(&h->sum_us) / 1e6,
                   name, n ? "{" : "", n ? (int)n - 1 : 0, label, n ? "}" : "",
                   atomic_load(&h->count));
}

static void metrics_hist_text(struct metrics_buf *b, const char *name, const char *help,
                              struct metrics_hist *h) {
    metrics_printf(b, "# HELP %s %s\n# TYPE %s histogram\n", name, help, name);
    metrics_hist_series(b, name, "", h);
}

static void metrics_stage_text(struct metrics_buf *b) {
    metrics_printf(
        b, "# HELP rayd_stage_seconds Time of each stage of a request's wait: upload "
           "(the body), parse (the JSON), decode (mesh files), build (BVHs), queue, "
           "render (the tiles, the PNG's bands deflated as their rows finish), encode (the PNG "
           "after the last tile), send (the reply).\n"
           "# TYPE rayd_stage_seconds histogram\n");
    for (int s = 0; s < MS__COUNT; s++) {
        char label[32];
        snprintf(label, sizeof label, "stage=\"%s\",", metrics_stage_names[s]);
        metrics_hist_series(b, "rayd_stage_seconds", label, &metrics_stages[s]);
    }
}

/* The label pairs of a (route, method, code) series, with a final comma. */
static void metrics_http_label(char *buf, size_t size, size_t r, size_t m, size_t c) {
    int code = c < METRICS_NCODES - 1 ? atomic_load(&metrics_codes[c]) : 0;
    char num[16] = "other";
    if (code) snprintf(num, sizeof num, "%d", code);
    snprintf(buf, size, "route=\"%s\",method=\"%s\",code=\"%s\",",
             r < METRICS_ROUTES ? metrics_routes[r] : "none", metrics_methods[m], num);
}

/* Calls fn for every (route, method, code) series that has happened. */
static void metrics_http_each(struct metrics_buf *b,
                              void (*fn)(struct metrics_buf *b, const char *label,
                                         struct metrics_hist *h)) {
    for (size_t r = 0; r <= METRICS_ROUTES; r++) {
        if (r < METRICS_ROUTES && !metrics_routes[r]) continue;
        for (size_t m = 0; m < METRICS_NMETHODS; m++)
            for (size_t c = 0; c < METRICS_NCODES; c++) {
                struct metrics_hist *h =
                    atomic_load_explicit(&metrics_http[r][m][c], memory_order_acquire);
                if (!h) continue;
                char label[160];
                metrics_http_label(label, sizeof label, r, m, c);
                fn(b, label, h);
            }
    }
}

static void metrics_http_count(struct metrics_buf *b, const char *label, struct metrics_hist *h) {
    size_t n = strlen(label);
    metrics_printf(b, "rayd_http_requests_total{%.*s} %lu\n", (int)n - 1, label,
                   atomic_load(&h->count));
}

static void metrics_http_duration(struct metrics_buf *b, const char *label,
                                  struct metrics_hist *h) {
    metrics_hist_series(b, "rayd_http_request_duration_seconds", label, h);
}

static void metrics_http_text(struct metrics_buf *b) {
    metrics_printf(b, "# HELP rayd_http_requests_total HTTP requests answered, by route pattern, "
                      "method and status code (499: the client left first).\n"
                      "# TYPE rayd_http_requests_total counter\n");
    metrics_http_each(b, metrics_http_count);
    metrics_printf(b, "# HELP rayd_http_request_duration_seconds Time from a request's first "
                      "byte to its last, by route pattern, method and status code.\n"
                      "# TYPE rayd_http_request_duration_seconds histogram\n");
    metrics_http_each(b, metrics_http_duration);
}

/* The compiler that built rayd, for rayd_build_info (no quotes inside). */
static const char *metrics_compiler(void) {
#if defined(__clang__)
    return "clang " __clang_version__;
#elif defined(__GNUC__)
    return "gcc " __VERSION__;
#else
    return "unknown";
#endif
}

/* A label value with \, " and newline escaped, trailing spaces cut. */
static void metrics_label_value(char *buf, size_t size, const char *s) {
    size_t n = 0;
    for (; *s && n + 3 < size; s++) {
        if (*s == '\\' || *s == '"' || *s == '\n') buf[n++] = '\\';
        buf[n++] = *s == '\n' ? 'n' : *s;
    }
    while (n > 0 && buf[n - 1] == ' ') n--;
    buf[n] = 0;
}

/* rayd_build_info and the process_* family of the Prometheus clients. */
static void metrics_process_text(struct metrics_buf *b) {
    char compiler[128];
    metrics_label_value(compiler, sizeof compiler, metrics_compiler());
    metrics_printf(b,
                   "# HELP rayd_build_info The version of rayd and the compiler that built it; "
                   "always 1.\n# TYPE rayd_build_info gauge\n"
                   "rayd_build_info{version=\"%s\",compiler=\"%s\"} 1\n",
                   RAYD_VERSION, compiler);
    struct procstat p;
    procstat_read(&p);
    metrics_printf(b,
                   "# HELP process_cpu_seconds_total Total user and system CPU time spent in "
                   "seconds.\n# TYPE process_cpu_seconds_total counter\n"
                   "process_cpu_seconds_total %.2f\n"
                   "# HELP process_resident_memory_bytes Resident memory size in bytes.\n"
                   "# TYPE process_resident_memory_bytes gauge\n"
                   "process_resident_memory_bytes %.0f\n"
                   "# HELP process_virtual_memory_bytes Virtual memory size in bytes.\n"
                   "# TYPE process_virtual_memory_bytes gauge\n"
                   "process_virtual_memory_bytes %.0f\n"
                   "# HELP process_open_fds Number of open file descriptors.\n"
                   "# TYPE process_open_fds gauge\nprocess_open_fds %.0f\n"
                   "# HELP process_max_fds Maximum number of open file descriptors.\n"
                   "# TYPE process_max_fds gauge\nprocess_max_fds %.0f\n"
                   "# HELP process_start_time_seconds Start time of the process since unix "
                   "epoch in seconds.\n# TYPE process_start_time_seconds gauge\n"
                   "process_start_time_seconds %.2f\n",
                   p.cpu_seconds, p.resident_bytes, p.virtual_bytes, p.open_fds, p.max_fds,
                   p.start_time);
}

/* The one memory budget (mem.c): each kind's bytes and the limit. */
static void metrics_memory_text(struct metrics_buf *b) {
    metrics_printf(b, "# HELP rayd_memory_bytes Memory counted in the --max-memory budget, by "
                      "kind.\n# TYPE rayd_memory_bytes gauge\n");
    for (int k = 0; k < MEM__COUNT; k++)
        metrics_printf(b, "rayd_memory_bytes{kind=\"%s\"} %zu\n", mem_kind_name(k), mem_used(k));
    metrics_printf(b,
                   "# HELP rayd_memory_limit_bytes The memory budget (--max-memory).\n"
                   "# TYPE rayd_memory_limit_bytes gauge\nrayd_memory_limit_bytes %zu\n",
                   mem_limit());
    metrics_printf(b,
                   "# HELP rayd_memory_peak_bytes The highest the budget's count has been.\n"
                   "# TYPE rayd_memory_peak_bytes gauge\nrayd_memory_peak_bytes %zu\n",
                   mem_peak());
}

char *metrics_text(size_t *len) {
    struct metrics_buf b = {0};
    metrics_http_text(&b);
    metrics_process_text(&b);
    metrics_printf(&b,
                   "# HELP rayd_queue_depth Render tasks waiting for a worker.\n"
                   "# TYPE rayd_queue_depth gauge\nrayd_queue_depth %ld\n"
                   "# HELP rayd_queue_capacity Tasks the queue holds before 503.\n"
                   "# TYPE rayd_queue_capacity gauge\nrayd_queue_capacity %ld\n"
                   "# HELP rayd_tasks_running Render tasks with at least one tile started.\n"
                   "# TYPE rayd_tasks_running gauge\nrayd_tasks_running %ld\n"
                   "# HELP rayd_workers_busy Workers rendering a tile right now (the spare too).\n"
                   "# TYPE rayd_workers_busy gauge\nrayd_workers_busy %ld\n"
                   "# HELP rayd_workers Render worker threads.\n"
                   "# TYPE rayd_workers gauge\nrayd_workers %ld\n"
                   "# HELP rayd_jobs Asynchronous jobs remembered.\n"
                   "# TYPE rayd_jobs gauge\nrayd_jobs %ld\n",
                   metrics_read(MG_QUEUE_DEPTH), metrics_read(MG_QUEUE_CAPACITY),
                   metrics_read(MG_TASKS_RUNNING), metrics_read(MG_WORKERS_BUSY),
                   metrics_read(MG_WORKERS), metrics_read(MG_JOBS));
    metrics_printf(&b,
                   "# HELP rayd_http_suspended Connections waiting for a render.\n"
                   "# TYPE rayd_http_suspended gauge\nrayd_http_suspended %ld\n"
                   "# HELP rayd_draining 1 while the server drains after SIGTERM.\n"
                   "# TYPE rayd_draining gauge\nrayd_draining %ld\n",
                   metrics_read(MG_HTTP_SUSPENDED), metrics_read(MG_DRAINING));
    metrics_printf(&b, "# HELP rayd_queue_wait_seconds Time from enqueue to the first tile "
                       "starting, by class (interactive: at most 256x256 pixels; bulk).\n"
                       "# TYPE rayd_queue_wait_seconds histogram\n");
    metrics_hist_series(&b, "rayd_queue_wait_seconds", "class=\"interactive\",", &metrics_wait[1]);
    metrics_hist_series(&b, "rayd_queue_wait_seconds", "class=\"bulk\",", &metrics_wait[0]);
    metrics_printf(&b,
                   "# HELP rayd_backlog_seconds Estimated seconds of work queued or running, "
                   "for the whole pool (the render estimates at this node's measured rate).\n"
                   "# TYPE rayd_backlog_seconds gauge\nrayd_backlog_seconds %.3f\n",
                   (double)metrics_read(MG_BACKLOG_MS) / 1e3);
    metrics_hist_text(&b, "rayd_render_seconds",
                      "Time from the first tile starting to the PNG encoded.", &metrics_rend);
    metrics_stage_text(&b);
    metrics_printf(&b,
                   "# HELP rayd_cache_hits_total Scene bodies found compiled in the cache.\n"
                   "# TYPE rayd_cache_hits_total counter\nrayd_cache_hits_total %lu\n"
                   "# HELP rayd_cache_misses_total Scene bodies parsed and compiled.\n"
                   "# TYPE rayd_cache_misses_total counter\nrayd_cache_misses_total %lu\n"
                   "# HELP rayd_cache_bytes Memory held by cached compiled scenes.\n"
                   "# TYPE rayd_cache_bytes gauge\nrayd_cache_bytes %ld\n"
                   "# HELP rayd_cache_entries Compiled scenes in the cache.\n"
                   "# TYPE rayd_cache_entries gauge\nrayd_cache_entries %ld\n",
                   atomic_load(&metrics_hits), atomic_load(&metrics_misses),
                   metrics_read(MG_CACHE_BYTES), metrics_read(MG_CACHE_ENTRIES));
    metrics_printf(
        &b,
        "# HELP rayd_result_cache_hits_total Renders answered from finished PNGs.\n"
        "# TYPE rayd_result_cache_hits_total counter\nrayd_result_cache_hits_total %lu\n"
        "# HELP rayd_result_cache_misses_total Renders looked up in the result cache and not "
        "found (none while it is off).\n"
        "# TYPE rayd_result_cache_misses_total counter\n"
        "rayd_result_cache_misses_total %lu\n"
        "# HELP rayd_result_cache_bytes Memory held by finished PNGs.\n"
        "# TYPE rayd_result_cache_bytes gauge\nrayd_result_cache_bytes %ld\n"
        "# HELP rayd_result_cache_entries Finished PNGs kept.\n"
        "# TYPE rayd_result_cache_entries gauge\nrayd_result_cache_entries %ld\n",
        atomic_load(&metrics_rhits), atomic_load(&metrics_rmisses),
        metrics_read(MG_RESULT_CACHE_BYTES), metrics_read(MG_RESULT_CACHE_ENTRIES));
    metrics_memory_text(&b);
    metrics_printf(&b, "# HELP rayd_rejections_total Requests refused before any work.\n"
                       "# TYPE rayd_rejections_total counter\n");
    for (int i = 0; i < MR__COUNT; i++)
        metrics_printf(&b, "rayd_rejections_total{reason=\"%s\"} %lu\n", metrics_reject_names[i],
                       atomic_load(&metrics_rejects[i]));
    metrics_printf(&b, "# HELP rayd_canceled_total Renders cancelled, by cause.\n"
                       "# TYPE rayd_canceled_total counter\n");
    for (int i = 0; i < MC__COUNT; i++)
        metrics_printf(&b, "rayd_canceled_total{reason=\"%s\"} %lu\n", metrics_cancel_names[i],
                       atomic_load(&metrics_cancels[i]));
    metrics_printf(&b,
                   "# HELP rayd_coalesced_total Requests answered by an identical in-flight "
                   "render.\n# TYPE rayd_coalesced_total counter\nrayd_coalesced_total %lu\n"
                   "# HELP rayd_rays_total Rays cast by the renderer.\n"
                   "# TYPE rayd_rays_total counter\nrayd_rays_total %lu\n",
                   atomic_load(&metrics_coalesced_n), atomic_load(&metrics_rays_n));
    metrics_printf(&b,
                   "# HELP rayd_scene_parses_total Scene bodies parsed and built (identical "
                   "bodies posted at once are parsed once).\n"
                   "# TYPE rayd_scene_parses_total counter\nrayd_scene_parses_total %lu\n"
                   "# HELP rayd_scene_parses_canceled_total Parses stopped because no one "
                   "wanted their scene any more (a frame-range job deleted, the server "
                   "stopping).\n"
                   "# TYPE rayd_scene_parses_canceled_total counter\n"
                   "rayd_scene_parses_canceled_total %lu\n"
                   "# HELP rayd_scene_file_checks_total Files of cached scenes checked with a "
                   "stat before use (one per distinct file per use).\n"
                   "# TYPE rayd_scene_file_checks_total counter\n"
                   "rayd_scene_file_checks_total %lu\n",
                   atomic_load(&metrics_parses_n), atomic_load(&metrics_parses_canceled_n),
                   atomic_load(&metrics_file_checks_n));
    metrics_printf(&b,
                   "# HELP rayd_scene_images_shared_total Image textures a parse took already "
                   "decoded, from a live scene of the same bytes (the frames of an animation).\n"
                   "# TYPE rayd_scene_images_shared_total counter\n"
                   "rayd_scene_images_shared_total %ld\n"
                   "# HELP rayd_scene_images_decoded_total Image textures a parse decoded.\n"
                   "# TYPE rayd_scene_images_decoded_total counter\n"
                   "rayd_scene_images_decoded_total %ld\n",
                   metrics_read(MG_IMAGES_SHARED), metrics_read(MG_IMAGES_DECODED));
    metrics_printf(&b,
                   "# HELP rayd_scene_meshes_shared_total Meshes (OBJ and PLY sources, large "
                   "inline arrays, gltf objects' baked meshes) a parse took already decoded and "
                   "built, from a live scene of the same bytes.\n"
                   "# TYPE rayd_scene_meshes_shared_total counter\n"
                   "rayd_scene_meshes_shared_total %ld\n"
                   "# HELP rayd_scene_meshes_built_total Meshes a parse decoded and built where "
                   "another scene could take them.\n"
                   "# TYPE rayd_scene_meshes_built_total counter\n"
                   "rayd_scene_meshes_built_total %ld\n",
                   metrics_read(MG_MESHES_SHARED), metrics_read(MG_MESHES_BUILT));
    *len = b.len;
    return b.p;
}
