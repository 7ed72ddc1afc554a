/* metrics.c -- counters and histograms, exposed as Prometheus text.
 *
 * Every number is a C11 atomic, bumped by whichever thread sees the event,
 * so metrics take no lock and cost a few nanoseconds.  Requests are counted
 * by route (the router's table index) and status (a fixed set of the codes
 * rayd sends).  Queue wait and render time are separate histograms with the
 * same buckets, so a slow response can be told apart as "waited" or
 * "rendered".
 *
 * Layer: base.  Counters are pushed here by the layer that sees the event;
 * gauges (queue depth, busy workers, cache size, suspended connections) and
 * the routes' labels belong to the layers above, which register a reader
 * function or a name at start-up (metrics_gauge, metrics_route_name).  So
 * metrics.c names no function of any other server file, and a scrape reads
 * each gauge through the pointer its owner handed in.
 */
#include "base.h"

#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

#define METRICS_ROUTES 32

static const int metrics_codes[] = {200, 201, 202, 204, 304, 400, 401, 404, 405, 409,
                                    413, 415, 422, 499, 500, 503, 0 /* other */};
#define METRICS_NCODES (sizeof metrics_codes / sizeof metrics_codes[0])

static const double metrics_buckets[] = {0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1,
                                         0.25,  0.5,    1,     2.5,  5,     10,   30};
#define METRICS_NB (sizeof metrics_buckets / sizeof metrics_buckets[0])

struct metrics_hist {
    atomic_ulong bucket[METRICS_NB + 1]; /* last = +Inf */
    atomic_ulong count;
    atomic_ulong sum_us;
};

static atomic_ulong metrics_req[METRICS_ROUTES + 1][METRICS_NCODES];
static struct metrics_hist metrics_wait[2], metrics_rend, metrics_stages[MS__COUNT]; /* wait: [interactive] */
static const char *const metrics_stage_names[MS__COUNT] = {
    "upload", "parse", "decode", "build", "queue", "render", "encode", "send"};
static atomic_ulong metrics_hits, metrics_misses, metrics_rhits, metrics_rmisses, metrics_rays_n, metrics_coalesced_n;
static atomic_ulong metrics_rejects[MR__COUNT], metrics_cancels[MC__COUNT];

static const char *const metrics_reject_names[MR__COUNT] = {
    "queue_full", "draining", "body_too_large", "unauthorized", "over_budget"};
static const char *const metrics_cancel_names[MC__COUNT] = {"client_gone", "delete", "drain",
                                                                        "deadline"};

/* Written once at start-up (before the listener), read by scrapes. */
static long (*metrics_gauges[MG__COUNT])(void);
static const char *metrics_routes[METRICS_ROUTES];

void metrics_gauge(enum metrics_gauge g, long (*read)(void)) { metrics_gauges[g] = read; }

void metrics_route_name(int route, const char *name)
{
    if (route >= 0 && route < METRICS_ROUTES)
        metrics_routes[route] = name;
}

static long metrics_read(enum metrics_gauge g)
{
    return metrics_gauges[g] ? metrics_gauges[g]() : 0;
}

void metrics_request(int route, int status)
{
    if (route < 0 || route >= METRICS_ROUTES)
        route = METRICS_ROUTES;
    size_t i = 0;
    while (i < METRICS_NCODES - 1 && metrics_codes[i] != status)
        i++;
    atomic_fetch_add_explicit(&metrics_req[route][i], 1, memory_order_relaxed);
}

static void metrics_observe(struct metrics_hist *h, double s)
{
    size_t i = 0;
    while (i < METRICS_NB && s > metrics_buckets[i])
        i++;
    atomic_fetch_add_explicit(&h->bucket[i], 1, memory_order_relaxed);
    atomic_fetch_add_explicit(&h->count, 1, memory_order_relaxed);
    atomic_fetch_add_explicit(&h->sum_us, (unsigned long)(s * 1e6), memory_order_relaxed);
}

void metrics_queue_wait(bool interactive, double s) { metrics_observe(&metrics_wait[interactive], s); }
void metrics_render(double s) { metrics_observe(&metrics_rend, s); }
void metrics_stage(enum metrics_stage stage, double s)
{
    metrics_observe(&metrics_stages[stage], s);
}
void metrics_cache(bool hit) { atomic_fetch_add(hit ? &metrics_hits : &metrics_misses, 1); }
void metrics_result_cache(bool hit)
{
    atomic_fetch_add(hit ? &metrics_rhits : &metrics_rmisses, 1);
}
void metrics_reject(enum metrics_reject why) { atomic_fetch_add(&metrics_rejects[why], 1); }
void metrics_cancel(enum metrics_cancel why) { atomic_fetch_add(&metrics_cancels[why], 1); }
void metrics_rays(uint64_t n) { atomic_fetch_add(&metrics_rays_n, (unsigned long)n); }
void metrics_coalesced(void) { atomic_fetch_add(&metrics_coalesced_n, 1); }

/* A growable string for the exposition. */
struct metrics_buf {
    char *p;
    size_t len, cap;
};

static void metrics_printf(struct metrics_buf *b, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));

static void metrics_printf(struct metrics_buf *b, const char *fmt, ...)
{
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
        if (!q)
            return;
        b->p = q;
        b->cap = cap;
    }
}

/* One histogram's series; label is "" or a label pair and a comma
 * ("stage=\"parse\","). */
static void metrics_hist_series(struct metrics_buf *b, const char *name, const char *label,
                                struct metrics_hist *h)
{
    unsigned long cum = 0;
    for (size_t i = 0; i <= METRICS_NB; i++) {
        cum += atomic_load(&h->bucket[i]);
        if (i < METRICS_NB)
            metrics_printf(b, "%s_bucket{%sle=\"%g\"} %lu\n", name, label, metrics_buckets[i],
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
                              struct metrics_hist *h)
{
    metrics_printf(b, "# HELP %s %s\n# TYPE %s histogram\n", name, help, name);
    metrics_hist_series(b, name, "", h);
}

static void metrics_stage_text(struct metrics_buf *b)
{
    metrics_printf(b, "# HELP rayd_stage_seconds Time of each stage of a request's wait: upload "
                      "(the body), parse (the JSON), decode (mesh files), build (BVHs), queue, "
                      "render (the tiles), encode (the PNG), send (the reply).\n"
                      "# TYPE rayd_stage_seconds histogram\n");
    for (int s = 0; s < MS__COUNT; s++) {
        char label[32];
        snprintf(label, sizeof label, "stage=\"%s\",", metrics_stage_names[s]);
        metrics_hist_series(b, "rayd_stage_seconds", label, &metrics_stages[s]);
    }
}

char *metrics_text(size_t *len)
{
    struct metrics_buf b = {0};
    metrics_printf(&b, "# HELP rayd_requests_total HTTP requests answered, by route and status.\n"
                       "# TYPE rayd_requests_total counter\n");
    for (int r = 0; r <= METRICS_ROUTES; r++) {
        if (r < METRICS_ROUTES && !metrics_routes[r])
            continue;
        for (size_t c = 0; c < METRICS_NCODES; c++) {
            unsigned long v = atomic_load(&metrics_req[r][c]);
            if (!v)
                continue;
            char code[16];
            if (metrics_codes[c])
                snprintf(code, sizeof code, "%d", metrics_codes[c]);
            else
                snprintf(code, sizeof code, "other");
            metrics_printf(&b, "rayd_requests_total{route=\"%s\",status=\"%s\"} %lu\n",
                           r < METRICS_ROUTES ? metrics_routes[r] : "none", code, v);
        }
    }
    metrics_printf(&b,
                   "# HELP rayd_queue_depth Render tasks waiting for a worker.\n"
                   "# TYPE rayd_queue_depth gauge\nrayd_queue_depth %ld\n"
                   "# HELP rayd_queue_capacity Tasks the queue holds before 503.\n"
                   "# TYPE rayd_queue_capacity gauge\nrayd_queue_capacity %ld\n"
                   "# HELP rayd_tasks_running Render tasks with at least one tile started.\n"
                   "# TYPE rayd_tasks_running gauge\nrayd_tasks_running %ld\n"
                   "# HELP rayd_workers_busy Workers rendering a tile right now.\n"
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
    metrics_printf(&b,
                   "# HELP rayd_result_cache_hits_total Renders answered from finished PNGs.\n"
                   "# TYPE rayd_result_cache_hits_total counter\nrayd_result_cache_hits_total %lu\n"
                   "# HELP rayd_result_cache_misses_total Renders not found finished.\n"
                   "# TYPE rayd_result_cache_misses_total counter\n"
                   "rayd_result_cache_misses_total %lu\n"
                   "# HELP rayd_result_cache_bytes Memory held by finished PNGs.\n"
                   "# TYPE rayd_result_cache_bytes gauge\nrayd_result_cache_bytes %ld\n"
                   "# HELP rayd_result_cache_entries Finished PNGs kept.\n"
                   "# TYPE rayd_result_cache_entries gauge\nrayd_result_cache_entries %ld\n",
                   atomic_load(&metrics_rhits), atomic_load(&metrics_rmisses),
                   metrics_read(MG_RESULT_CACHE_BYTES), metrics_read(MG_RESULT_CACHE_ENTRIES));
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
    *len = b.len;
    return b.p;
}
