/* http_req.c -- one request as the handlers see it: headers, query,
 * suspension.
 *
 * The handlers must not know whether a request came from libmicrohttpd or
 * from the fuzz harness, and they must not call up into the transport that
 * drives them.  So a request carries its transport's struct http_io, and
 * this file, below the handlers, reaches the connection only through it.
 *
 * Suspension is the one delicate part.  A handler that queues a render
 * suspends the request from inside the work layer's lock (the waiter's
 * suspend callback), and from that moment a worker may answer and resume it
 * at any time; r->conn.parked tells the thread that ran the handler that r is no
 * longer its own.  The counts of requests in flight and suspended are what
 * main.c's drain waits on, and the suspended count is a gauge.
 *
 * Every request gets an id, sent back as X-Request-Id and written in its
 * access line, so a client's report, a proxy's log and rayd's line can be
 * matched.  A sane id the client (or a proxy in front) sent is kept; else
 * one is made: a random 64-bit prefix drawn once per process, then a
 * bijective mix of a counter, so no two requests of a process share an id
 * and ids of two processes differ with overwhelming likelihood.
 */
#include "req/request.h"

#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/random.h>
#include <time.h>
#include <unistd.h>

static atomic_long http_req_nsuspended, http_req_ninflight;
static atomic_long http_req_last_ms; /* when the latest request came, clock_now() in ms */

long http_req_suspended(void) { return atomic_load(&http_req_nsuspended); }
long http_req_in_flight(void) { return atomic_load(&http_req_ninflight); }
double http_req_last(void) { return (double)atomic_load(&http_req_last_ms) / 1000.0; }

struct http_req *http_req_new(const struct http_io *io, void *io_ctx, const char *method,
                              const char *url, size_t target_len) {
    struct http_req *r = calloc(1, sizeof *r);
    if (!r) return NULL;
    r->conn.io = io;
    r->conn.io_ctx = io_ctx;
    r->method = method;
    r->url = url;
    r->conn.target_len = target_len;
    r->log.t0 = clock_now();
    r->route.label = -1;
    atomic_fetch_add(&http_req_ninflight, 1);
    atomic_store(&http_req_last_ms, (long)(r->log.t0 * 1000.0));
    return r;
}

void http_req_reply_free(struct http_reply *p) {
    if (!p) return;
    for (size_t i = 0; i < p->nheaders; i++) free(p->headers[i].name);
    free(p->headers);
    free(p->data);
    blob_unref(p->blob);
    if (p->done) p->done(p->cls);
    free(p);
}

void http_req_free(struct http_req *r) {
    http_req_reply_free(r->conn.pending);
    free(r->log.target);
    free(r->body);
    mem_release(MEM_BODIES, r->conn.body_mem);
    free(r);
    atomic_fetch_sub(&http_req_ninflight, 1);
}

static int http_req_hex(char c) {
    return c >= '0' && c <= '9'   ? c - '0'
           : c >= 'a' && c <= 'f' ? c - 'a' + 10
           : c >= 'A' && c <= 'F' ? c - 'A' + 10
                                  : -1;
}

/* Why the raw target t is refused, or NULL. */
static const char *http_req_target_why(const char *t) {
    size_t params = 0;
    for (const char *p = t; *p; p++) {
        if ((unsigned char)*p <= 0x20 || *p == 0x7f)
            return "a space or control character in the request target";
        params += *p == '&';
    }
    if (params >= HTTP_QUERY_PARAMS_MAX) return HTTP_QUERY_TOO_MANY;
    /* the path: after an absolute form's scheme and host, up to the query */
    const char *p = t;
    if (!strncasecmp(p, "http://", 7) || !strncasecmp(p, "https://", 8)) {
        p = strchr(p + 7 + (p[4] != ':'), '/');
        if (!p) return NULL;
    }
    for (; *p && *p != '?'; p++) {
        if (*p != '%' || http_req_hex(p[1]) < 0 || http_req_hex(p[2]) < 0) continue;
        int c = http_req_hex(p[1]) * 16 + http_req_hex(p[2]);
        if (c == 0) return "a NUL byte (%00) in the path";
        if (c == '/') return "an encoded / (%2F) in the path";
        if (c < 0x20 || c == 0x7f) return "an encoded control character in the path";
    }
    return NULL;
}

void http_req_set_target(struct http_req *r, const char *target) {
    free(r->log.target);
    r->log.target = target ? strndup(target, 2048) : NULL;
    r->conn.target_why = target ? http_req_target_why(target) : NULL;
}

/* ---- request ids ---------------------------------------------------------- */

static uint64_t http_req_seed[2];
static pthread_once_t http_req_seed_once = PTHREAD_ONCE_INIT;
static atomic_ullong http_req_counter;

static void http_req_seed_init(void) {
    if (getrandom(http_req_seed, sizeof http_req_seed, 0) != (ssize_t)sizeof http_req_seed) {
        /* no entropy source: time and pid still tell processes apart */
        struct timespec ts;
        clock_gettime(CLOCK_REALTIME, &ts);
        http_req_seed[0] = (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
        http_req_seed[1] = (uint64_t)getpid() << 32 ^ http_req_seed[0];
    }
}

/* splitmix64's finaliser: a bijection, so distinct counters give distinct ids. */
static uint64_t http_req_mix(uint64_t z) {
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

static bool http_req_id_sane(const char *id) {
    size_t n = 0;
    for (; id[n]; n++) {
        char c = id[n];
        if (n >= 64 || !((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
                         (c >= '0' && c <= '9') || strchr("-_.:+/=@", c)))
            return false;
    }
    return n > 0;
}

void http_req_take_id(struct http_req *r) {
    const char *id = http_req_header(r, "X-Request-Id");
    if (id && http_req_id_sane(id)) {
        snprintf(r->request_id, sizeof r->request_id, "%s", id);
        return;
    }
    pthread_once(&http_req_seed_once, http_req_seed_init);
    uint64_t n = atomic_fetch_add(&http_req_counter, 1);
    snprintf(r->request_id, sizeof r->request_id, "%016llx%016llx",
             (unsigned long long)http_req_seed[0],
             (unsigned long long)http_req_mix(http_req_seed[1] + n));
}

/* ---- headers and query ------------------------------------------------------ */

const char *http_req_header(struct http_req *r, const char *name) {
    return r->conn.io->header(r, name);
}

struct http_req_first {
    const char *name, *value;
};

static void http_req_first_cb(void *u, const char *k, const char *v) {
    struct http_req_first *f = u;
    if (!f->value && !strcmp(k, f->name)) f->value = v;
}

const char *http_req_query(struct http_req *r, const char *name) {
    struct http_req_first f = {name, NULL};
    r->conn.io->query_each(r, http_req_first_cb, &f);
    return f.value;
}

struct http_req_count {
    const char *name;
    int n;
};

static void http_req_count_cb(void *u, const char *k, const char *v) {
    struct http_req_count *c = u;
    (void)v;
    c->n += !strcmp(k, c->name);
}

int http_req_query_count(struct http_req *r, const char *name) {
    struct http_req_count c = {name, 0};
    r->conn.io->query_each(r, http_req_count_cb, &c);
    return c.n;
}

void http_req_query_each(struct http_req *r, void (*fn)(void *u, const char *k, const char *v),
                         void *u) {
    r->conn.io->query_each(r, fn, u);
}

int http_req_fd(struct http_req *r) { return r->conn.io->fd(r); }

void http_req_suspend(struct http_req *r) {
    server_assert(!r->conn.suspended); /* one resume answers one suspend */
    r->conn.parked = true;
    r->conn.suspended = true;
    atomic_fetch_add(&http_req_nsuspended, 1);
    r->conn.io->suspend(r);
}

void http_req_resume(struct http_req *r) {
    server_assert(r->conn.suspended);
    r->conn.suspended = false;
    r->conn.io->resume(r); /* for the harness, r may be gone after this */
    atomic_fetch_sub(&http_req_nsuspended, 1);
}

bool http_req_list_next(const char **p, const char **item, size_t *len) {
    const char *s = *p;
    while (*s == ' ' || *s == ',') s++;
    if (!*s) return false;
    const char *e = s;
    while (*e && *e != ',') e++;
    const char *end = e;
    while (end > s && end[-1] == ' ') end--;
    *item = s;
    *len = (size_t)(end - s);
    *p = e;
    return true;
}
