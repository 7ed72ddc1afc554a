/* api_jobs.c -- asynchronous renders: POST /v1/jobs, GET /v1/jobs/{id},
 * GET /v1/jobs/{id}/image.png, GET /v1/jobs/{id}/events, DELETE.
 *
 * A job is a render nobody waits on: POST answers 202 with the job id at
 * once, the client polls the job or follows its Server-Sent Events, then
 * fetches the PNG.  The jobs themselves (table, states, progress, events)
 * live in jobq.c under its lock; this file only speaks HTTP.
 *
 * The event stream is a libmicrohttpd callback response.  When the reader
 * callback has nothing new to send it registers the connection with the job
 * and suspends it (inside jobq's lock, so a tile that finishes meanwhile
 * cannot be missed); the worker that finishes the next tile resumes it.  So
 * an open stream costs no thread and no polling.
 */
#include "server.h"

#include <microhttpd.h>
#include <stdlib.h>
#include <string.h>

#define API_CONTAINER(w) ((struct http_req *)((char *)(w) - offsetof(struct http_req, waiter)))

static bool api_job_id_ok(const char *id)
{
    if (strlen(id) != 32)
        return false;
    for (; *id; id++)
        if (!((*id >= '0' && *id <= '9') || (*id >= 'a' && *id <= 'f')))
            return false;
    return true;
}

static void api_job_unknown(struct http_req *r)
{
    http_reply_error(r, 404, "job_unknown", "no such job on this server (or it was forgotten)",
                     NULL, 0, 0, NULL);
}

void api_jobs_post(struct http_req *r, const char *unused)
{
    (void)unused;
    if (http_is_draining()) {
        http_reply_refused(r, JOBQ_DRAINING);
        return;
    }
    if (!http_require_json(r))
        return;
    struct cache_entry *e;
    bool hit;
    struct rayd_error err = {0};
    enum rayd_status st = jobq_scene_parse(r->body ? r->body : "", r->body_len, &e, &hit, &err);
    if (st != RAYD_OK) {
        err.code = st;
        http_reply_rayd_error(r, &err);
        return;
    }
    struct rayd_region reg;
    if (api_region(r, cache_scene(e), &reg)) {
        char id[33];
        enum jobq_submit s = jobq_job_create(e, &reg, id);
        if (s != JOBQ_OK) {
            http_reply_refused(r, s);
        } else {
            char json[700], loc[80];
            snprintf(json, sizeof json,
                     "{\"id\":\"%s\",\"state\":\"queued\",\"scene_id\":\"%s\","
                     "\"status_url\":\"/v1/jobs/%s\",\"image_url\":\"/v1/jobs/%s/image.png\","
                     "\"events_url\":\"/v1/jobs/%s/events\"}\n",
                     id, cache_id(e), id, id, id);
            snprintf(loc, sizeof loc, "/v1/jobs/%s", id);
            http_reply_json(r, 202, json);
            http_add_header(r, "Location", loc);
        }
    }
    jobq_scene_release(e);
}

static void api_job_json(const char *id, const struct jobq_job_info *in, char *json, size_t size)
{
    char err[900] = "";
    if (in->state == JS_FAILED) {
        char msg[560], path[560];
        snprintf(err, sizeof err, ",\"error\":{\"code\":\"%s\",\"message\":\"%s\",\"path\":\"%s\"}",
                 rayd_status_name(in->err.code),
                 http_json_escape(in->err.message, msg, sizeof msg),
                 http_json_escape(in->err.path, path, sizeof path));
    }
    char img[100] = "";
    if (in->state == JS_SUCCEEDED)
        snprintf(img, sizeof img, ",\"image_url\":\"/v1/jobs/%s/image.png\"", id);
    snprintf(json, size,
             "{\"id\":\"%s\",\"state\":\"%s\",\"progress\":%.4f,\"tiles_done\":%ld,"
             "\"tiles_total\":%ld,\"scene_id\":\"%s\",\"region\":{\"x\":%d,\"y\":%d,\"w\":%d,"
             "\"h\":%d},\"age_s\":%.3f,\"queue_ms\":%.3f,\"render_ms\":%.3f,"
             "\"encode_ms\":%.3f,\"rays\":%llu%s%s}\n",
             id, jobq_state_name(in->state), in->progress, in->tiles_done, in->tiles_total,
             in->scene_id, in->region.x, in->region.y, in->region.w, in->region.h,
             in->created_age, in->queue_ms, in->render_ms, in->encode_ms,
             (unsigned long long)in->rays, img, err);
}

void api_jobs_get(struct http_req *r, const char *id)
{
    struct jobq_job_info info;
    if (!api_job_id_ok(id) || !jobq_job_get(id, &info, false)) {
        api_job_unknown(r);
        return;
    }
    char json[2000];
    api_job_json(id, &info, json, sizeof json);
    http_reply_json(r, 200, json);
}

void api_jobs_delete(struct http_req *r, const char *id)
{
    struct jobq_job_info info;
    if (!api_job_id_ok(id) || !jobq_job_cancel(id) || !jobq_job_get(id, &info, false)) {
        api_job_unknown(r);
        return;
    }
    char json[2000];
    api_job_json(id, &info, json, sizeof json);
    http_reply_json(r, 200, json);
}

void api_jobs_image(struct http_req *r, const char *id)
{
    struct jobq_job_info info;
    if (!api_job_id_ok(id) || !jobq_job_get(id, &info, true)) {
        api_job_unknown(r);
        return;
    }
    if (info.state == JS_SUCCEEDED && info.png) {
        http_reply_png(r, 200, info.png);
        http_add_header(r, "Cache-Control", "private, max-age=3600");
        blob_unref(info.png);
        return;
    }
    blob_unref(info.png);
    if (info.state == JS_FAILED) {
        char msg[400];
        snprintf(msg, sizeof msg, "the job failed: %s", info.err.message);
        http_reply_error(r, 409, "job_failed", msg, info.err.path, 0, 0, NULL);
    } else if (info.state == JS_CANCELED) {
        http_reply_error(r, 409, "job_canceled", "the job was cancelled", NULL, 0, 0, NULL);
    } else {
        char json[2000];
        api_job_json(id, &info, json, sizeof json);
        http_reply_json(r, 202, json);
        http_add_header(r, MHD_HTTP_HEADER_RETRY_AFTER, "1");
    }
}

/* ---- Server-Sent Events ---------------------------------------------------------- */

static void api_sse_suspend(struct jobq_waiter *w) { http_suspend(API_CONTAINER(w)); }

/* Woken by news of the job, or by the watcher when the client hung up: then
 * the stream ends at once (the reader's next call), rather than waiting,
 * suspended, for an event that may be long in coming -- a queued job's. */
static void api_sse_wake(struct jobq_waiter *w, struct jobq_result *res)
{
    struct http_req *r = API_CONTAINER(w);
    if (res->gone) {
        r->gone = true;
        r->note = "client_gone";
    }
    blob_unref(res->png);
    http_resume(r);
}

static ssize_t api_sse_reader(void *cls, uint64_t pos, char *buf, size_t max)
{
    (void)pos;
    struct http_req *r = cls;
    if (r->gone)
        return MHD_CONTENT_READER_END_WITH_ERROR;
    ssize_t n = jobq_sse_read(r->sse, buf, max, &r->waiter, api_sse_suspend);
    if (n < 0)
        return MHD_CONTENT_READER_END_OF_STREAM;
    r->bytes += (size_t)n;
    return n;
}

void api_jobs_events(struct http_req *r, const char *id)
{
    if (!api_job_id_ok(id) || !(r->sse = jobq_sse_open(id))) {
        api_job_unknown(r);
        return;
    }
    r->waiter.done = api_sse_wake;
    r->waiter.fd = http_conn_fd(r);
    struct MHD_Response *resp =
        MHD_create_response_from_callback(MHD_SIZE_UNKNOWN, 4096, api_sse_reader, r, NULL);
    if (resp) {
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, "text/event-stream");
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL, "no-store");
        MHD_add_response_header(resp, "X-Accel-Buffering", "no");
    }
    http_reply(r, 200, resp);
}
