/* sse.c -- one connection to a Server-Sent Events stream, read with libcurl
 * so that its reader may make blocking requests between events.
 *
 * The stream runs on a multi handle of its own: libcurl's write callback
 * only appends the bytes to a buffer, and the loop (sse_run) cuts them into
 * lines and events and hands each event to the caller's on_event outside
 * any libcurl callback, then calls the caller's idle between reads (at
 * least five times a second), where it may fetch an image, check for
 * Ctrl-C or stop.  A request made there runs while the stream waits: the
 * server's bytes wait in the socket, and a burst beyond 1 MiB pauses the
 * transfer (CURL_WRITEFUNC_PAUSE) until the events read so far are handed
 * on, so memory stays bounded whatever the server sends.
 *
 * The lines are parsed as the SSE format says: "event:" names the event,
 * "data:" lines are joined with newlines, "retry:" sets the reconnection
 * delay, a line starting with ':' is a comment (rayd's keep-alive), a blank
 * line ends the event.  A line longer than 64 KiB is cut (its event's data
 * is then no JSON, which the caller ignores).  The answer's status is read
 * before its body: a stream that is no 200 keeps its first bytes, to be
 * described as an API error (net_describe).
 *
 * Whether to reconnect, or to poll instead, is the caller's choice: this
 * file follows one connection and says how it ended.
 */
#include "client.h"

#include <curl/curl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SSE_LINE_MAX (64 * 1024)
#define SSE_PENDING_MAX (1024 * 1024)

/* The state of one connection. */
struct sse_conn {
    struct sse *s;
    CURL *h;
    char *pending; /* bytes not parsed yet */
    size_t len, cap, off;
    int paused;
    int status_read;
    char line[SSE_LINE_MAX];
    size_t line_len;
    char event[64];
    char *data; /* SSE_LINE_MAX bytes */
    size_t data_len;
};

static size_t sse_write(char *ptr, size_t size, size_t n, void *user) {
    struct sse_conn *c = user;
    size_t all = size * n;
    if (!c->status_read) {
        curl_easy_getinfo(c->h, CURLINFO_RESPONSE_CODE, &c->s->status);
        c->status_read = 1;
    }
    if (c->s->status != 200) { /* an error's body: its first bytes, to describe it */
        struct net_buf *b = &c->s->error_body;
        size_t room = b->cap > b->len + 1 ? b->cap - b->len - 1 : 0;
        if (!b->data && (b->data = malloc(8192))) room = (b->cap = 8192) - 1;
        size_t k = all < room ? all : room;
        if (k && b->data) {
            memcpy(b->data + b->len, ptr, k);
            b->len += k;
            b->data[b->len] = '\0';
        }
        return all;
    }
    if (c->len - c->off + all > SSE_PENDING_MAX) {
        c->paused = 1;
        return CURL_WRITEFUNC_PAUSE; /* handed on again once the loop read the events */
    }
    if (c->off) { /* the parsed bytes out first */
        memmove(c->pending, c->pending + c->off, c->len - c->off);
        c->len -= c->off, c->off = 0;
    }
    if (c->len + all > c->cap) {
        size_t cap = c->cap ? c->cap : 16384;
        while (cap < c->len + all) cap *= 2;
        char *p = realloc(c->pending, cap);
        if (!p) return 0; /* fails the transfer: a dropped stream */
        c->pending = p, c->cap = cap;
    }
    memcpy(c->pending + c->len, ptr, all);
    c->len += all;
    return all;
}

/* One whole line (no end of line): 1 when on_event ended the stream, -1
 * when it failed, else 0. */
static int sse_line(struct sse_conn *c, char *l) {
    struct sse *s = c->s;
    if (!*l) { /* the end of an event */
        int rc = 0;
        if (c->event[0] || c->data_len) {
            s->events++;
            rc = s->on_event(s->user, c->event[0] ? c->event : "message", c->data);
        }
        c->event[0] = '\0', c->data_len = 0, c->data[0] = '\0';
        return rc;
    }
    if (*l == ':') return 0; /* a comment: rayd's keep-alive */
    char *v = strchr(l, ':');
    if (v) {
        *v++ = '\0';
        if (*v == ' ') v++;
    } else {
        v = l + strlen(l);
    }
    if (!strcmp(l, "event")) {
        snprintf(c->event, sizeof c->event, "%s", v);
    } else if (!strcmp(l, "data")) {
        c->data_len += (size_t)snprintf(c->data + c->data_len, SSE_LINE_MAX - c->data_len, "%s%s",
                                        c->data_len ? "\n" : "", v);
        if (c->data_len >= SSE_LINE_MAX) c->data_len = SSE_LINE_MAX - 1;
    } else if (!strcmp(l, "retry") && strspn(v, "0123456789") == strlen(v) && *v && strlen(v) < 9) {
        long ms = atol(v);
        s->retry_ms = ms < 100 ? 100 : ms > 10000 ? 10000 : ms;
    }
    return 0;
}

/* The whole lines of the pending bytes: as sse_line. */
static int sse_parse(struct sse_conn *c) {
    while (c->off < c->len) {
        char ch = c->pending[c->off++];
        if (ch != '\n') {
            if (c->line_len + 1 < sizeof c->line) c->line[c->line_len++] = ch;
            continue;
        }
        if (c->line_len && c->line[c->line_len - 1] == '\r') c->line_len--;
        c->line[c->line_len] = '\0';
        c->line_len = 0;
        int rc = sse_line(c, c->line);
        if (rc) return rc;
    }
    return 0;
}

/* The loop of one connection, its handle on multi handle m: an SSE_ code. */
static int sse_loop(struct sse_conn *c, CURLM *m) {
    struct sse *s = c->s;
    for (;;) {
        int running = 0, rc;
        curl_multi_perform(m, &running);
        if ((rc = sse_parse(c)) != 0) return rc > 0 ? SSE_DONE : SSE_FAILED;
        if (c->paused) {
            c->paused = 0;
            curl_easy_pause(c->h, CURLPAUSE_CONT);
            continue;
        }
        if ((rc = s->idle(s->user)) != 0) return rc > 0 ? SSE_STOPPED : SSE_FAILED;
        if (!running) break;
        curl_multi_poll(m, NULL, 0, 200, NULL);
    }
    int left;
    CURLMsg *msg = curl_multi_info_read(m, &left);
    if (msg && msg->msg == CURLMSG_DONE && msg->data.result != CURLE_OK)
        snprintf(s->why, sizeof s->why, "%s", curl_easy_strerror(msg->data.result));
    else
        snprintf(s->why, sizeof s->why, "the server ended the stream");
    return s->status && s->status != 200 ? SSE_REFUSED : SSE_DROPPED;
}

int sse_run(struct sse *s, const char *url) {
    struct sse_conn c = {.s = s};
    s->status = 0, s->events = 0, s->why[0] = '\0';
    net_buf_free(&s->error_body);
    struct net_buf unused = {0};
    void *hdrs = NULL;
    CURLM *m = curl_multi_init();
    c.data = calloc(1, SSE_LINE_MAX);
    c.h = m && c.data ? net_easy(s->o, url, &unused, NULL, 0, &hdrs) : NULL;
    int rc = SSE_DROPPED;
    if (!c.h) {
        snprintf(s->why, sizeof s->why, "out of memory");
    } else {
        curl_easy_setopt(c.h, CURLOPT_WRITEFUNCTION, sse_write);
        curl_easy_setopt(c.h, CURLOPT_WRITEDATA, &c);
        curl_easy_setopt(c.h, CURLOPT_TIMEOUT_MS, 0L); /* a render may take long */
        curl_easy_setopt(c.h, CURLOPT_LOW_SPEED_LIMIT, 1L);
        curl_easy_setopt(c.h, CURLOPT_LOW_SPEED_TIME, 60L); /* rayd's keep-alives come sooner */
        curl_multi_add_handle(m, c.h);
        rc = sse_loop(&c, m);
        curl_multi_remove_handle(m, c.h);
        curl_easy_cleanup(c.h);
    }
    curl_slist_free_all(hdrs);
    if (m) curl_multi_cleanup(m);
    net_buf_free(&unused);
    free(c.pending);
    free(c.data);
    return rc;
}
