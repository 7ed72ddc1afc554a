/* fuzz_http.c -- libFuzzer target: whole HTTP requests through the server's
 * request flow (limits, auth, CORS, router, every handler, the job queue and
 * a real worker), without sockets or libmicrohttpd's parser.
 *
 * Input: a request in HTTP/1.1 form -- "METHOD TARGET[ VERSION]\n", header
 * lines "Name: value\n" up to an empty line, then the body (CR before LF is
 * dropped).  The token is "fuzz-token", so "Authorization: Bearer fuzz-token"
 * reaches the handlers.  Scene limits are lowered (64 x 64 pixels, 4
 * samples, ...) so a render takes milliseconds.  A status rayd never sends
 * (a 500 above all), an error status without the JSON error, or a handler
 * that neither replies nor suspends aborts: the fuzzer reports it.
 */
#include "fuzz_http_common.h"

#include <stdio.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void fh_init(void) {
    static int done;
    if (done) return;
    done = 1;
    char *argv[] = {"fuzz_http", NULL};
    if (config_load(1, argv)) abort();
    config.threads = 1;
    config.queue = 8;
    config.max_jobs = 32;
    config.max_body = 65536;
    config.max_pixels = 4096;
    config.max_url = 4096;
    config.cache_mb = 4;
    config.result_cache_mb = 1;
    config.png_level = 1;
    config.cors_origin = strdup("http://a.example");
    config.token = strdup("fuzz-token");
    config.token_len = strlen(config.token);
    log_quiet = true;
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    lim.max_width = lim.max_height = 64;
    lim.max_pixels = 4096;
    lim.max_objects = 500;
    lim.max_triangles = lim.max_vertices = 5000;
    lim.max_samples = 4;
    lim.max_depth = 4;
    lim.max_bytes = 65536;
    scenes_set_limits(&lim);
    router_start();
    if (sched_start(1, (int)config.queue, (int)config.max_jobs)) abort();
}

/* One line of data[*pos..size) without its CR LF; NULL at the end. */
static char *fh_line(const uint8_t *data, size_t size, size_t *pos) {
    if (*pos >= size) return NULL;
    size_t s = *pos, e = s;
    while (e < size && data[e] != '\n') e++;
    *pos = e < size ? e + 1 : e;
    size_t n = e - s;
    if (n && data[s + n - 1] == '\r') n--;
    char *l = malloc(n + 1);
    memcpy(l, data + s, n);
    l[n] = 0;
    return l;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    fh_init();
    size_t pos = 0;
    char *first = fh_line(data, size, &pos);
    if (!first) return 0;
    /* the request line: method, target (NUL bytes end them, as in C) */
    char *sp = strchr(first, ' ');
    if (!sp || sp == first) {
        free(first);
        return 0;
    }
    *sp = 0;
    char *target = sp + 1, *sp2 = strchr(target, ' ');
    if (sp2) *sp2 = 0;
    const char *version = sp2 ? sp2 + 1 : NULL;
    static struct fh_req q; /* static: the worker may touch it until resumed */
    memset(&q, 0, sizeof q);
    pthread_mutex_init(&q.mu, NULL);
    pthread_cond_init(&q.cv, NULL);
    char *qm = strchr(target, '?');
    char *path = fh_unescape(target, qm ? (size_t)(qm - target) : strlen(target));
    if (qm) fh_parse_query(&q, qm + 1, strlen(qm + 1));
    char *line;
    while ((line = fh_line(data, size, &pos)) && *line) {
        char *colon = strchr(line, ':');
        if (colon && colon != line && q.nhdr < FH_MAX_ARGS) {
            *colon = 0;
            char *v = colon + 1;
            while (*v == ' ' || *v == '\t') v++;
            q.hdr[q.nhdr].k = strdup(line);
            q.hdr[q.nhdr].v = strdup(v);
            q.nhdr++;
        }
        free(line);
    }
    free(line);
    const char *body = (const char *)data + pos;
    size_t blen = size - pos;

    struct http_req *r = http_req_new(&fh_io, &q, first, path, strlen(target));
    if (!r) abort();
    http_req_set_target(r, target); /* as libmicrohttpd's URI log callback does */
    r->conn.version = version;
    bool drop = false;
    if (http_flow_begin(r)) {
        /* the body in pieces, as libmicrohttpd delivers it */
        for (size_t off = 0; off < blen && !drop;) {
            size_t n = blen - off < 1000 ? blen - off : 1000;
            drop = !http_flow_body(r, body + off, n);
            off += n;
        }
        if (!drop) {
            http_flow_handle(r);
            if (r->conn.parked) {
                pthread_mutex_lock(&q.mu);
                while (!q.resumed) pthread_cond_wait(&q.cv, &q.mu);
                pthread_mutex_unlock(&q.mu);
            }
        }
    }
    if (!drop) {
        if (r->conn.suspended || (!r->conn.pending && !r->gone) || !fh_status_ok(r->res.status)) {
            fprintf(stderr, "fuzz_http: %s %s: status %d, pending %d, suspended %d\n", r->method,
                    r->url, r->res.status, r->conn.pending != NULL, r->conn.suspended);
            abort();
        }
        if (r->res.status >= 400 && r->res.status != 499 && !r->res.err_code) {
            fprintf(stderr, "fuzz_http: status %d without an error code\n", r->res.status);
            abort();
        }
    }
    if (getenv("FUZZ_HTTP_VERBOSE"))
        fprintf(stderr, "%s %s -> %d %s\n", r->method, r->url, r->res.status,
                r->res.err_code ? r->res.err_code : "");
    http_flow_end(r, drop ? "aborted" : NULL);
    fh_free(&q);
    pthread_mutex_destroy(&q.mu);
    pthread_cond_destroy(&q.cv);
    free(path);
    free(first);
    return 0;
}
