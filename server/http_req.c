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
 * at any time; r->parked tells the thread that ran the handler that r is no
 * longer its own.  The counts of requests in flight and suspended are what
 * main.c's drain waits on, and the suspended count is a gauge.
 */
#include "request.h"

#include <microhttpd.h>
#include <stdlib.h>
#include <string.h>

static atomic_long http_req_nsuspended, http_req_ninflight;
static atomic_long http_req_last_ms; /* when the latest request came, log_now() in ms */

long http_req_suspended(void) { return atomic_load(&http_req_nsuspended); }
long http_req_in_flight(void) { return atomic_load(&http_req_ninflight); }
double http_req_last(void) { return (double)atomic_load(&http_req_last_ms) / 1000.0; }

struct http_req *http_req_new(const struct http_io *io, void *io_ctx, const char *method,
                              const char *url, size_t target_len)
{
    struct http_req *r = calloc(1, sizeof *r);
    if (!r)
        return NULL;
    r->io = io;
    r->io_ctx = io_ctx;
    r->method = method;
    r->url = url;
    r->target_len = target_len;
    r->t0 = log_now();
    r->route = -1;
    atomic_fetch_add(&http_req_ninflight, 1);
    atomic_store(&http_req_last_ms, (long)(r->t0 * 1000.0));
    return r;
}

void http_req_free(struct http_req *r)
{
    if (r->pending)
        MHD_destroy_response(r->pending);
    free(r->body);
    free(r);
    atomic_fetch_sub(&http_req_ninflight, 1);
}

const char *http_req_header(struct http_req *r, const char *name)
{
    return r->io->header(r, name);
}

struct http_req_first {
    const char *name, *value;
};

static void http_req_first_cb(void *u, const char *k, const char *v)
{
    struct http_req_first *f = u;
    if (!f->value && !strcmp(k, f->name))
        f->value = v;
}

const char *http_req_query(struct http_req *r, const char *name)
{
    struct http_req_first f = {name, NULL};
    r->io->query_each(r, http_req_first_cb, &f);
    return f.value;
}

void http_req_query_each(struct http_req *r, void (*fn)(void *u, const char *k, const char *v),
                         void *u)
{
    r->io->query_each(r, fn, u);
}

int http_req_fd(struct http_req *r) { return r->io->fd(r); }

void http_req_suspend(struct http_req *r)
{
    r->parked = true;
    r->suspended = true;
    atomic_fetch_add(&http_req_nsuspended, 1);
    r->io->suspend(r);
}

void http_req_resume(struct http_req *r)
{
    r->suspended = false;
    r->io->resume(r); /* for the harness, r may be gone after this */
    atomic_fetch_sub(&http_req_nsuspended, 1);
}

bool http_req_list_next(const char **p, const char **item, size_t *len)
{
    const char *s = *p;
    while (*s == ' ' || *s == ',')
        s++;
    if (!*s)
        return false;
    const char *e = s;
    while (*e && *e != ',')
        e++;
    const char *end = e;
    while (end > s && end[-1] == ' ')
        end--;
    *item = s;
    *len = (size_t)(end - s);
    *p = e;
    return true;
}
