/* api_sse.c -- the text of a server-sent event stream, and what waits of it.
 *
 * Both event streams, one node's jobs (api_events.c) and a cluster's
 * (api_cluster_events.c), hand libmicrohttpd text from a reader callback
 * that gets a buffer of the transport's size.  An event is formatted whole
 * ("event: NAME\ndata: JSON\n\n"); what does not fit that buffer waits in
 * the stream's carry and goes first at the next call, so no event is ever
 * cut or reordered.
 */
#include "api/api.h"

#include <stdlib.h>
#include <string.h>

size_t api_sse_event(char *out, size_t size, const char *name, cJSON *o) {
    char data[2048];
    bool ok = json_print_into(o, data, sizeof data);
    cJSON_Delete(o);
    int n = snprintf(out, size, "event: %s\ndata: %s\n\n", name, ok ? data : "{}");
    return n < 0 || (size_t)n >= size ? 0 : (size_t)n;
}

bool api_sse_put(struct api_sse_carry *c, char *buf, size_t max, size_t *used, const char *text,
                 size_t len) {
    size_t k = len < max - *used ? len : max - *used;
    memcpy(buf + *used, text, k);
    *used += k;
    if (k == len) return true;
    char *t = realloc(c->text, c->len + len - k);
    if (!t) return false;
    memcpy(t + c->len, text + k, len - k);
    c->text = t;
    c->len += len - k;
    return true;
}

bool api_sse_flush(struct api_sse_carry *c, char *buf, size_t max, size_t *used) {
    size_t left = c->len - c->off;
    size_t k = left < max - *used ? left : max - *used;
    memcpy(buf + *used, c->text + c->off, k);
    *used += k;
    c->off += k;
    if (c->off < c->len) return false;
    free(c->text);
    *c = (struct api_sse_carry){0};
    return true;
}

void api_sse_reply(struct http_req *r, ssize_t (*read)(void *cls, char *buf, size_t max),
                   void (*done)(void *cls), void *cls) {
    /* no-store: each event is news; X-Accel-Buffering: nginx passes it on at once */
    static const char *const headers[] = {"Content-Type",
                                          "text/event-stream",
                                          "Cache-Control",
                                          "no-store",
                                          "X-Accel-Buffering",
                                          "no",
                                          NULL};
    http_reply_stream(r, 200, headers, 4096, read, done, cls);
}
