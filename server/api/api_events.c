/* api_events.c -- GET /v1/jobs/{id}/events: a job's progress as
 * Server-Sent Events.
 *
 * The stream is a reply whose body the transport reads through a
 * callback (http_reply_stream) as it sends.  The reader asks
 * events.c for news; when there is none, events.c links the stream's waiter
 * to the job's task and calls its suspend callback (inside the work lock,
 * so a tile that finishes meanwhile cannot be missed), and the worker that
 * finishes the next tile calls its done callback, which resumes the
 * connection.  So an open stream costs no thread and no polling.  The
 * records are written as SSE here, each data line by cJSON; text that does
 * not fit the transport's buffer waits in the stream's carry for the next
 * call.
 */
#include "api/api.h"
#include "cluster/cluster.h"

#include <cjson/cJSON.h>
#include <stdlib.h>
#include <string.h>

#define API_EVENTS_ITEMS 32

/* One open stream: freed with its reply (the stream's done callback). */
struct api_events {
    struct work_waiter w; /* first: the callbacks get it back */
    struct http_req *r;
    struct events_stream *s;
    struct shot *shot; /* a frame-range job's stream instead (shots.c) */
    struct shots_cursor cursor;
    char id[33];
    bool raw; /* a denoised progressive job's: each pass has a raw_url too */
    struct api_sse_carry carry;
};

static void api_events_suspend(struct work_waiter *w) {
    http_req_suspend(((struct api_events *)w)->r);
}

/* Woken by news of the job, or by the watcher when the client hung up: then
 * the stream ends at once (the reader's next call), rather than waiting,
 * suspended, for an event that may be long in coming -- a queued job's. */
static void api_events_wake(struct work_waiter *w, struct work_result *res) {
    struct http_req *r = ((struct api_events *)w)->r;
    if (res->gone) {
        r->gone = true;
        r->res.note = "client_gone";
    }
    blob_unref(res->png);
    http_req_resume(r);
}

/* "event: pass": a progressive job's pass is complete (o deleted). */
static size_t api_events_pass(struct api_events *a, const struct events_item *it, cJSON *o,
                              char *out, size_t size) {
    cJSON_AddNumberToObject(o, "pass", it->done);
    cJSON_AddNumberToObject(o, "passes", it->total);
    cJSON_AddNumberToObject(o, "samples", it->samples);
    json_add_fixed(o, "time_s", it->time_s, 3);
    api_jobs_add_noise(o, it->noise);
    json_add_fixed(o, "progress", it->progress, 4);
    api_jobs_add_pass_url(o, a->id, it->done);
    if (a->raw) api_jobs_add_raw_url(o, a->id, it->done);
    return api_sse_event(out, size, "pass", o);
}

/* One item as SSE text into out (2.5 KiB is enough for any). */
static size_t api_events_format(struct api_events *a, const struct events_item *it,
                                const struct rayd_error *err, char *out, size_t size) {
    cJSON *o = cJSON_CreateObject();
    size_t n = 0;
    switch (it->kind) {
    case EVENTS_STATE:
        n = (size_t)snprintf(out, size, "retry: 1000\n");
        cJSON_AddStringToObject(o, "id", a->id);
        cJSON_AddStringToObject(o, "state", jobs_state_name(it->state));
        return n + api_sse_event(out + n, size - n, "state", o);
    case EVENTS_TILE:
        cJSON_AddNumberToObject(o, "x", it->tile.x);
        cJSON_AddNumberToObject(o, "y", it->tile.y);
        cJSON_AddNumberToObject(o, "w", it->tile.w);
        cJSON_AddNumberToObject(o, "h", it->tile.h);
        n = api_sse_event(out, size, "tile", o);
        o = cJSON_CreateObject();
        json_add_fixed(o, "progress", it->progress, 4);
        cJSON_AddNumberToObject(o, "done", it->done);
        cJSON_AddNumberToObject(o, "total", it->total);
        return n + api_sse_event(out + n, size - n, "progress", o);
    case EVENTS_PASS: return api_events_pass(a, it, o, out, size);
    case EVENTS_FRAME: {
        char url[120];
        cJSON_AddNumberToObject(o, "k", (double)it->frame);
        cJSON_AddStringToObject(o, "state", it->frame_failed ? "failed" : "done");
        cJSON_AddNumberToObject(o, "frames_done", it->done);
        cJSON_AddNumberToObject(o, "frames_total", it->total);
        snprintf(url, sizeof url, "/v1/jobs/%s/frames/%ld.png", a->id, it->frame);
        if (!it->frame_failed) cJSON_AddStringToObject(o, "url", url);
        return api_sse_event(out, size, "frame", o);
    }
    case EVENTS_DONE:
        cJSON_AddStringToObject(o, "state", jobs_state_name(it->state));
        json_add_fixed(o, "progress", it->progress, 4);
        if (it->samples > 0) cJSON_AddNumberToObject(o, "samples", it->samples);
        if (it->state == JS_FAILED) cJSON_AddStringToObject(o, "error", err->message);
        if (it->state == JS_FAILED && err->path[0]) /* the value it is about */
            cJSON_AddStringToObject(o, "error_path", err->path);
        return api_sse_event(out, size, "done", o);
    case EVENTS_DRAIN:
        cJSON_AddStringToObject(o, "state", "queued");
        json_add_fixed(o, "progress", it->progress, 4);
        cJSON_AddStringToObject(o, "message",
                                "the server is stopping; the job is kept (--data-dir) and goes on "
                                "when it starts again");
        return api_sse_event(out, size, "draining", o);
    case EVENTS_PING:
    default: cJSON_Delete(o); return (size_t)snprintf(out, size, ": keep-alive\n\n");
    }
}

static ssize_t api_events_reader(void *cls, char *buf, size_t max) {
    struct api_events *a = cls;
    struct http_req *r = a->r;
    if (r->gone) return HTTP_STREAM_ERROR;
    size_t used = 0;
    if (a->carry.text && !api_sse_flush(&a->carry, buf, max, &used)) goto out;
    struct events_item items[API_EVENTS_ITEMS];
    struct rayd_error err = {0};
    int n = used      ? 0
            : a->shot ? shots_events_read(a->shot, &a->cursor, items, API_EVENTS_ITEMS, &err, &a->w)
                      : events_read(a->s, items, API_EVENTS_ITEMS, &err, &a->w);
    if (n < 0) return HTTP_STREAM_END;
    for (int i = 0; i < n; i++) {
        char text[2560];
        size_t len = api_events_format(a, &items[i], &err, text, sizeof text);
        if (!api_sse_put(&a->carry, buf, max, &used, text, len)) return HTTP_STREAM_ERROR;
    }
out:
    r->res.bytes += used;
    return (ssize_t)used;
}

static void api_events_free(void *cls) {
    struct api_events *a = cls;
    events_close(a->s);
    shots_close(a->shot);
    free(a->carry.text);
    free(a);
}

void api_events_get(struct http_req *r, const char *id) {
    if (!api_only_params(r, NULL)) return;
    if (cluster_on()) { /* rayd --redis: the job's events are in Redis */
        api_cluster_events(r, id);
        return;
    }
    struct api_events *a = calloc(1, sizeof *a);
    if (!a) {
        api_refused(r, WORK_NOMEM);
        return;
    }
    if (!api_is_hex(id, 32) || (!(a->shot = shots_open(id)) && !(a->s = events_open(id)))) {
        free(a);
        api_jobs_missing(r, id);
        return;
    }
    a->r = r;
    snprintf(a->id, sizeof a->id, "%s", id);
    struct jobs_info info;
    a->raw = a->s && jobs_get(id, &info, JOBS_NUMBERS) && api_jobs_keeps_raw(&info);
    a->w.done = api_events_wake;
    a->w.suspend = api_events_suspend;
    a->w.fd = http_req_fd(r);
    api_sse_reply(r, api_events_reader, api_events_free, a);
}
