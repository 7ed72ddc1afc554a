/* http_deadline.c -- --header-seconds: a total deadline for a request's
 * line and header block, as nginx's client_header_timeout.
 *
 * libmicrohttpd's --timeout is an idle timeout only: a client that sends
 * one header line every few seconds is never idle, and a few thousand such
 * connections hold every --max-conns slot (slowloris).  So each connection
 * waiting for its headers has a deadline here, and a sweeper thread cuts
 * the ones past it with shutdown(fd, SHUT_RDWR): libmicrohttpd then reads
 * the end of the stream and closes the connection itself, in its own
 * thread (the fd is never closed here, and the HTTP threads do nothing
 * but HTTP).
 *
 * A connection is tracked from its accept (http_deadline_open) until its
 * headers are in (http_deadline_done), and again from the end of each
 * request (http_deadline_next) on a keep-alive connection.  A fresh
 * connection must have its headers in --header-seconds after the accept,
 * or it is cut.  A keep-alive connection may stay idle between requests
 * (its idleness is --timeout's): the sweeper asks the kernel how many bytes
 * came since the last request (TCP_INFO), and only once the next request
 * has begun does it give the header block one more --header-seconds, so a
 * request that began just before a check is never cut at once.
 *
 * Invariants: the list holds the connections being watched, in the order
 * they were armed; every deadline is "armed + --header-seconds", so the
 * list is also in deadline order and the sweeper looks at its head only.
 * Everything is under http_deadline_mu, and shutdown() is called with it
 * held: a connection is unlinked (http_deadline_close, from libmicrohttpd's
 * "closed" notice) before libmicrohttpd closes its fd, so the fd the
 * sweeper shuts down is still that connection's.
 */
#include "net/transport.h"

#include <linux/tcp.h>
#include <netinet/in.h>
#include <pthread.h>
#include <stdlib.h>
#include <sys/socket.h>

enum http_deadline_phase {
    HD_HEADERS, /* a fresh connection, or a request begun: cut at due */
    HD_IDLE,    /* between requests: cut at due only if a request began */
    HD_OFF,     /* headers in, or cut: not in the list */
};

struct http_deadline {
    struct http_deadline *prev, *next;
    int fd;
    enum http_deadline_phase phase;
    double armed, due;
    unsigned long long seen; /* bytes received when armed idle (HD_IDLE) */
    bool cut, claimed;       /* cut by the sweeper; its access line taken */
};

static pthread_mutex_t http_deadline_mu = PTHREAD_MUTEX_INITIALIZER;
static pthread_cond_t http_deadline_cv = PTHREAD_COND_INITIALIZER;
static struct http_deadline *http_deadline_head, *http_deadline_tail;
static pthread_t http_deadline_thread;
static bool http_deadline_running, http_deadline_stopping;

/* Bytes received on fd so far; ~0 when the kernel cannot say (then a
 * request is taken to have begun: better cut than held). */
static unsigned long long http_deadline_bytes(int fd) {
    struct tcp_info ti;
    socklen_t len = sizeof ti;
    if (getsockopt(fd, IPPROTO_TCP, TCP_INFO, &ti, &len) != 0 ||
        len < offsetof(struct tcp_info, tcpi_bytes_received) + sizeof ti.tcpi_bytes_received)
        return ~0ULL;
    return ti.tcpi_bytes_received;
}

static void http_deadline_unlink(struct http_deadline *d) {
    if (d->phase == HD_OFF) return;
    if (d->prev)
        d->prev->next = d->next;
    else
        http_deadline_head = d->next;
    if (d->next)
        d->next->prev = d->prev;
    else
        http_deadline_tail = d->prev;
    d->prev = d->next = NULL;
    d->phase = HD_OFF;
}

/* d at the tail (the latest deadline), due --header-seconds from now. */
static void http_deadline_link(struct http_deadline *d, enum http_deadline_phase phase) {
    http_deadline_unlink(d);
    d->phase = phase;
    d->armed = clock_now();
    d->due = d->armed + (double)config.header_seconds;
    d->prev = http_deadline_tail;
    if (http_deadline_tail)
        http_deadline_tail->next = d;
    else
        http_deadline_head = d;
    http_deadline_tail = d;
    if (http_deadline_head == d) pthread_cond_signal(&http_deadline_cv);
}

/* The head d is due: idle, watched again; begun, one more period; else cut. */
static void http_deadline_due(struct http_deadline *d) {
    if (d->phase == HD_IDLE) {
        unsigned long long now_seen = http_deadline_bytes(d->fd); /* ~0: cannot say, begun */
        bool idle = now_seen != ~0ULL && d->seen != ~0ULL && now_seen == d->seen;
        http_deadline_link(d, idle ? HD_IDLE : HD_HEADERS);
        return;
    }
    http_deadline_unlink(d);
    d->cut = true;
    metrics_reject(MR_HEADER_TIMEOUT);
    shutdown(d->fd, SHUT_RDWR);
}

static void *http_deadline_sweep(void *arg) {
    (void)arg;
    pthread_mutex_lock(&http_deadline_mu);
    while (!http_deadline_stopping) {
        struct http_deadline *d = http_deadline_head;
        double now = clock_now();
        if (!d) {
            pthread_cond_wait(&http_deadline_cv, &http_deadline_mu);
        } else if (d->due > now) {
            struct timespec at = clock_after(d->due - now);
            pthread_cond_timedwait(&http_deadline_cv, &http_deadline_mu, &at);
        } else {
            http_deadline_due(d);
        }
    }
    pthread_mutex_unlock(&http_deadline_mu);
    return NULL;
}

int http_deadline_start(void) {
    if (config.header_seconds <= 0) return 0;
    http_deadline_stopping = false;
    /* a small stack: it only walks a list, and a default one is 8 MiB of
     * address space, which a ulimit -v counts (faults.sh) */
    pthread_attr_t at;
    pthread_attr_init(&at);
    pthread_attr_setstacksize(&at, (size_t)256 << 10);
    int e = pthread_create(&http_deadline_thread, &at, http_deadline_sweep, NULL);
    pthread_attr_destroy(&at);
    if (e != 0) {
        log_error("cannot start the --header-seconds thread");
        return -1;
    }
    http_deadline_running = true;
    return 0;
}

void http_deadline_stop(void) {
    if (!http_deadline_running) return;
    pthread_mutex_lock(&http_deadline_mu);
    http_deadline_stopping = true;
    pthread_cond_signal(&http_deadline_cv);
    pthread_mutex_unlock(&http_deadline_mu);
    pthread_join(http_deadline_thread, NULL);
    http_deadline_running = false;
}

struct http_deadline *http_deadline_open(int fd) {
    if (!http_deadline_running || fd < 0) return NULL;
    struct http_deadline *d = calloc(1, sizeof *d);
    if (!d) return NULL; /* no deadline for this one: --timeout still holds */
    d->fd = fd;
    d->phase = HD_OFF;
    pthread_mutex_lock(&http_deadline_mu);
    http_deadline_link(d, HD_HEADERS);
    pthread_mutex_unlock(&http_deadline_mu);
    return d;
}

bool http_deadline_claim(struct http_deadline *d, double *waited) {
    if (!d) return false;
    pthread_mutex_lock(&http_deadline_mu);
    bool mine = d->cut && !d->claimed;
    d->claimed = d->claimed || d->cut;
    if (waited) *waited = clock_now() - d->armed;
    pthread_mutex_unlock(&http_deadline_mu);
    return mine;
}

bool http_deadline_done(struct http_deadline *d) {
    if (!d) return false;
    pthread_mutex_lock(&http_deadline_mu);
    http_deadline_unlink(d);
    pthread_mutex_unlock(&http_deadline_mu);
    return http_deadline_claim(d, NULL);
}

void http_deadline_next(struct http_deadline *d) {
    if (!d) return;
    pthread_mutex_lock(&http_deadline_mu);
    if (!d->cut) {
        d->seen = http_deadline_bytes(d->fd);
        http_deadline_link(d, HD_IDLE);
    }
    pthread_mutex_unlock(&http_deadline_mu);
}

void http_deadline_close(struct http_deadline *d) {
    if (!d) return;
    pthread_mutex_lock(&http_deadline_mu);
    http_deadline_unlink(d);
    pthread_mutex_unlock(&http_deadline_mu);
    free(d);
}
