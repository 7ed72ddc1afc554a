/* api_cluster_events.c -- GET /v1/jobs/{id}/events with --redis: a cluster
 * job's progress as Server-Sent Events, from any node.
 *
 * A cluster job's events live in its stream in Redis (rayd:{ID}:events,
 * written by whichever node did the work), so any node replays them from
 * the start and follows them.  The reply is a stream (http_reply_stream)
 * whose reader formats what the last read brought; with nothing left it
 * hands one CO_EVENTS op to the cluster's request thread (which suspends
 * the request first, as every cluster op does) and returns nothing; the
 * op's answer resumes the request with the next events.  A read that
 * brought none waits API_CLUSTER_POLL before the next (op->at): the
 * request thread holds it meanwhile, so an open stream costs no thread.
 * The events and their data are those of the single node (state, tile +
 * progress, pass, frame, done; "frame" for frame-range jobs only, as there: a
 * still job's frame is its image.png); the stream ends after "done".
 */
#include "api/api.h"
#include "cluster/cluster.h"

#include <cjson/cJSON.h>
#include <poll.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>

#define API_CLUSTER_POLL 0.25 /* seconds between reads of a stream with no news */
#define API_CLUSTER_PING 15.0 /* seconds of silence before a keep-alive, as the single node's */

struct api_cev {
    struct cluster_op op; /* first: the callbacks get it back */
    struct http_req *r;
    char cursor[48];
    int next;                   /* op.events[next..op.nevents) not yet sent */
    bool ended;                 /* "done" was sent */
    bool failed;                /* the read failed: the stream ends */
    struct api_sse_carry carry; /* text formatted, not yet sent */
    double last_write;          /* clock_now() of the last bytes handed out */
};

static void api_cev_suspend(struct cluster_op *op) { http_req_suspend(((struct api_cev *)op)->r); }

static void api_cev_done(struct cluster_op *op) {
    struct api_cev *a = (struct api_cev *)op;
    a->next = 0;
    if (op->status != CS_OK) {
        a->failed = true;
        op->nevents = 0;
    }
    if (op->nevents > 0)
        snprintf(a->cursor, sizeof a->cursor, "%s", op->events[op->nevents - 1].cursor);
    http_req_resume(a->r);
}

/* One event as SSE text. */
static size_t api_cev_format(struct api_cev *a, const struct cluster_event *e, char *out,
                             size_t size) {
    cJSON *o = cJSON_CreateObject();
    const struct shots_info *in = &a->op.info;
    if (!strcmp(e->kind, "state")) {
        size_t n = (size_t)snprintf(out, size, "retry: 1000\n");
        cJSON_AddStringToObject(o, "id", a->op.id);
        cJSON_AddStringToObject(o, "state", e->state);
        return n + api_sse_event(out + n, size - n, "state", o);
    }
    if (!strcmp(e->kind, "tile") && a->op.is_animated) { /* a frame range's: frames, as one node */
        cJSON_Delete(o);
        return 0;
    }
    if (!strcmp(e->kind, "tile")) {
        cJSON_AddNumberToObject(o, "x", e->reg.x);
        cJSON_AddNumberToObject(o, "y", e->reg.y);
        cJSON_AddNumberToObject(o, "w", e->reg.w);
        cJSON_AddNumberToObject(o, "h", e->reg.h);
        size_t n = api_sse_event(out, size, "tile", o);
        o = cJSON_CreateObject();
        json_add_fixed(o, "progress", e->total > 0 ? (double)e->done / (double)e->total : 0, 4);
        cJSON_AddNumberToObject(o, "done", (double)e->done);
        cJSON_AddNumberToObject(o, "total", (double)e->total);
        return n + api_sse_event(out + n, size - n, "progress", o);
    }
    if (!strcmp(e->kind, "frame")) {
        char url[120];
        if (!a->op.is_animated) { /* a still job's one frame is image.png, as on one node */
            cJSON_Delete(o);
            return 0;
        }
        cJSON_AddNumberToObject(o, "k", (double)e->frame);
        cJSON_AddStringToObject(o, "state", "done");
        cJSON_AddNumberToObject(o, "frames_done", (double)e->done);
        cJSON_AddNumberToObject(o, "frames_total", (double)e->total);
        snprintf(url, sizeof url, "/v1/jobs/%s/frames/%ld.png", a->op.id, e->frame);
        cJSON_AddStringToObject(o, "url", url);
        return api_sse_event(out, size, "frame", o);
    }
    if (!strcmp(e->kind, "pass")) { /* the single node's, key for key (api_events.c) */
        cJSON_AddNumberToObject(o, "pass", (double)e->done);
        cJSON_AddNumberToObject(o, "passes", (double)e->total);
        cJSON_AddNumberToObject(o, "samples", (double)e->samples);
        json_add_fixed(o, "time_s", e->time_s, 3);
        api_jobs_add_noise(o, e->noise);
        json_add_fixed(o, "progress", e->progress, 4);
        api_jobs_add_pass_url(o, a->op.id, (int)e->done);
        return api_sse_event(out, size, "pass", o);
    }
    a->ended = true; /* "done" */
    cJSON_AddStringToObject(o, "state", e->state);
    json_add_fixed(o, "progress", in->job.progress, 4);
    if (in->job.progressive && in->job.passes.samples > 0) /* as one node's */
        cJSON_AddNumberToObject(o, "samples", in->job.passes.samples);
    if (!strcmp(e->state, "failed")) cJSON_AddStringToObject(o, "error", in->job.err.message);
    return api_sse_event(out, size, "done", o);
}

/* Whether the client hung up (a stream with no news is never written to,
 * so the transport would not see it): as the single node's watcher asks. */
static bool api_cev_gone(struct http_req *r) {
    struct pollfd p = {.fd = http_req_fd(r), .events = POLLIN};
    char c;
    if (p.fd < 0 || poll(&p, 1, 0) <= 0) return false;
    return (p.revents & (POLLHUP | POLLERR)) ||
           ((p.revents & POLLIN) && recv(p.fd, &c, 1, MSG_PEEK | MSG_DONTWAIT) == 0);
}

static ssize_t api_cev_reader(void *cls, char *buf, size_t max) {
    struct api_cev *a = cls;
    if (a->r->gone) return HTTP_STREAM_ERROR;
    if (sched_draining()) return HTTP_STREAM_END; /* a drain waits for no stream */
    size_t used = 0;
    if (a->carry.text && !api_sse_flush(&a->carry, buf, max, &used)) goto out;
    while (a->next < a->op.nevents && !a->ended) {
        char text[2560];
        size_t len = api_cev_format(a, &a->op.events[a->next++], text, sizeof text);
        if (!api_sse_put(&a->carry, buf, max, &used, text, len)) return HTTP_STREAM_ERROR;
    }
    if (!used && !a->ended && !a->failed && clock_now() - a->last_write > API_CLUSTER_PING) {
        static const char ping[] = ": keep-alive\n\n"; /* a balancer keeps an idle stream */
        if (!api_sse_put(&a->carry, buf, max, &used, ping, sizeof ping - 1))
            return HTTP_STREAM_ERROR;
    }
    if (used) goto out;
    if (a->ended || a->failed) return HTTP_STREAM_END;
    if (api_cev_gone(a->r)) {
        a->r->res.note = "client_gone";
        return HTTP_STREAM_ERROR;
    }
    bool news = a->op.nevents > 0;
    a->op.nevents = 0;
    snprintf(a->op.cursor, sizeof a->op.cursor, "%s", a->cursor);
    a->op.at = news ? 0 : clock_now() + API_CLUSTER_POLL;
    if (!cluster_submit(&a->op)) return HTTP_STREAM_END;
out:
    if (used) a->last_write = clock_now();
    a->r->res.bytes += used;
    return (ssize_t)used;
}

static void api_cev_free(void *cls) {
    struct api_cev *a = cls;
    free(a->carry.text);
    free(a);
}

/* The first read: 404 or 503 as any job route, else the stream. */
static void api_cev_first(struct cluster_op *op) {
    struct api_cev *a = (struct api_cev *)op;
    struct http_req *r = a->r;
    op->suspend = api_cev_suspend;
    op->done = api_cev_done;
    if (op->status == CS_DOWN) {
        r->res.retry_after = 5;
        http_reply_error(r, 503, "cluster_unavailable", op->why, NULL, 0, 0, NULL);
    } else if (op->status == CS_NOMEM) {
        api_refused(r, WORK_NOMEM);
    } else if (op->status == CS_GONE) {
        api_jobs_gone(r, &op->gone, NULL);
    } else if (op->status != CS_OK) {
        http_reply_error(r, 404, "job_unknown", "no such job in the cluster (or it was forgotten)",
                         NULL, 0, 0, NULL);
    } else {
        if (op->nevents > 0)
            snprintf(a->cursor, sizeof a->cursor, "%s", op->events[op->nevents - 1].cursor);
        a->last_write = clock_now();
        api_sse_reply(r, api_cev_reader, api_cev_free, a);
        http_req_resume(r);
        return;
    }
    free(a);
    http_req_resume(r);
}

static void api_cev_first_suspend(struct cluster_op *op) { api_suspend(((struct api_cev *)op)->r); }

void api_cluster_events(struct http_req *r, const char *id) {
    if (!api_is_hex(id, 32)) {
        api_jobs_unknown(r);
        return;
    }
    struct api_cev *a = calloc(1, sizeof *a);
    if (!a) {
        api_refused(r, WORK_NOMEM);
        return;
    }
    a->r = r;
    a->op.kind = CO_EVENTS;
    snprintf(a->op.id, sizeof a->op.id, "%s", id);
    snprintf(a->op.cursor, sizeof a->op.cursor, "0");
    snprintf(a->cursor, sizeof a->cursor, "0");
    a->op.suspend = api_cev_first_suspend;
    a->op.done = api_cev_first;
    if (!cluster_submit(&a->op)) {
        free(a);
        api_refused(r, WORK_DRAINING);
    }
}
