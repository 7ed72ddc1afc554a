/* api_jobs.c -- asynchronous renders: POST /v1/jobs, GET /v1/jobs/{id},
 * GET /v1/jobs/{id}/image.png, GET /v1/jobs/{id}/events, DELETE.
 *
 * A job is a render nobody waits on: POST answers 202 with the job id at
 * once, the client polls the job or follows its Server-Sent Events, then
 * fetches the PNG.  The jobs themselves (table, states, progress, the event
 * cursor) live in the work layer (jobs.c, events.c); this file turns them
 * into HTTP and JSON.
 *
 * The event stream is a libmicrohttpd callback response.  The reader asks
 * events.c for news; when there is none, events.c links the stream's waiter
 * to the job's task and calls its suspend callback (inside the work lock,
 * so a tile that finishes meanwhile cannot be missed), and the worker that
 * finishes the next tile calls its done callback, which resumes the
 * connection.  So an open stream costs no thread and no polling.  The
 * records are written as SSE here, each data line by cJSON; text that does
 * not fit libmicrohttpd's buffer waits in the stream's carry for the next
 * call.
 */
#include "api.h"

#include <cjson/cJSON.h>
#include <microhttpd.h>
#include <stdlib.h>
#include <string.h>

static void api_job_unknown(struct http_req *r)
{
    http_reply_error(r, 404, "job_unknown", "no such job on this server (or it was forgotten)",
                     NULL, 0, 0, NULL);
}

static void api_job_url(char *buf, size_t size, const char *id, const char *tail)
{
    snprintf(buf, size, "/v1/jobs/%s%s", id, tail);
}

/* ---- a progressive job's query ----------------------------------------------- */

static const char *const api_plan_names[] = {"progressive", "pass_step", "time_budget",
                                             "noise_target", NULL};

static bool api_plan_bad(struct http_req *r, const char *name, const char *why)
{
    char msg[200];
    snprintf(msg, sizeof msg, "%s: %s", name, why);
    http_reply_error(r, 400, "bad_parameter", msg, NULL, 0, 0, name);
    return false;
}

/* A decimal number in (0, max] from ?name=, if given. */
static bool api_plan_number(struct http_req *r, const char *name, double max, double *out)
{
    const char *v = http_req_query(r, name);
    if (!v)
        return true;
    char *end = NULL;
    double x = strtod(v, &end);
    if (!*v || *end || !(x > 0 && x <= max)) {
        char why[80];
        snprintf(why, sizeof why, "must be a number above 0 and at most %g", max);
        return api_plan_bad(r, name, why);
    }
    *out = x;
    return true;
}

/* ?progressive=1 and its options into *plan; *progressive false without
 * it.  Replies 400 and returns false on a bad one. */
static bool api_plan(struct http_req *r, const rayd_scene *scene, struct jobs_plan *plan,
                     bool *progressive)
{
    memset(plan, 0, sizeof *plan);
    for (int i = 0; api_plan_names[i]; i++)
        if (http_req_query_count(r, api_plan_names[i]) > 1)
            return api_plan_bad(r, api_plan_names[i], "given more than once");
    const char *v = http_req_query(r, "progressive");
    *progressive = v && (!strcmp(v, "1") || !strcmp(v, "true"));
    if (v && !*progressive && strcmp(v, "0") && strcmp(v, "false"))
        return api_plan_bad(r, "progressive", "must be 1, true, 0 or false");
    for (int i = 1; api_plan_names[i]; i++)
        if (!*progressive && http_req_query(r, api_plan_names[i]))
            return api_plan_bad(r, api_plan_names[i], "needs progressive=1");
    double step = 0;
    if (!api_plan_number(r, "pass_step", 1e6, &step) ||
        !api_plan_number(r, "time_budget", 86400, &plan->time_budget) ||
        !api_plan_number(r, "noise_target", 1, &plan->noise_target))
        return false;
    if (step != (int)step)
        return api_plan_bad(r, "pass_step", "must be a whole number of samples");
    plan->step = (int)step;
    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    int samples[PASSES_MAX];
    if (*progressive && passes_plan(plan, info.samples, samples) < 0) {
        char why[120];
        snprintf(why, sizeof why, "%d samples in steps of %d is more than %d passes",
                 info.samples, plan->step, PASSES_MAX);
        return api_plan_bad(r, "pass_step", why);
    }
    return true;
}

/* "estimate": {"rays", "seconds"}: the job's price (api_cost.c). */
static void api_add_estimate(cJSON *o, const struct api_price *p)
{
    cJSON *e = cJSON_AddObjectToObject(o, "estimate");
    json_add_fixed(e, "rays", p->rays, 0);
    json_add_fixed(e, "seconds", p->seconds, 3);
}

void api_jobs_post(struct http_req *r, const char *unused)
{
    (void)unused;
    struct cache_entry *e;
    bool hit, progressive = false;
    if (!api_scene(r, &e, &hit))
        return;
    struct work_target what = {.format = WORK_PNG};
    struct jobs_plan plan;
    struct api_price price;
    char id[33], url[80];
    enum work_submit s;
    if (!api_region_also(r, cache_scene(e), &what.reg, api_plan_names) ||
        !api_plan(r, cache_scene(e), &plan, &progressive) ||
        !api_cost_admit(r, cache_scene(e), &what, progressive, &price)) {
        /* replied */
    } else if ((s = jobs_create(e, &what, progressive ? &plan : NULL, id)) != WORK_OK) {
        api_refused(r, s);
    } else {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "id", id);
        cJSON_AddStringToObject(o, "state", "queued");
        cJSON_AddStringToObject(o, "scene_id", cache_id(e));
        api_job_url(url, sizeof url, id, "");
        cJSON_AddStringToObject(o, "status_url", url);
        api_job_url(url, sizeof url, id, "/image.png");
        cJSON_AddStringToObject(o, "image_url", url);
        api_job_url(url, sizeof url, id, "/events");
        cJSON_AddStringToObject(o, "events_url", url);
        api_add_estimate(o, &price);
        http_reply_json(r, 202, o);
        api_job_url(url, sizeof url, id, "");
        http_reply_header(r, "Location", url);
        api_cost_price_headers(r, &price);
    }
    scenes_release(e);
}

/* "noise": the estimate with 6 decimals, or null before there is one. */
static void api_add_noise(cJSON *o, double noise)
{
    if (noise >= 0)
        json_add_fixed(o, "noise", noise, 6);
    else
        cJSON_AddNullToObject(o, "noise");
}

/* "image_url" of pass k of job id. */
static void api_add_pass_url(cJSON *o, const char *id, int k)
{
    char url[100], tail[40];
    snprintf(tail, sizeof tail, "/image.png?pass=%d", k);
    api_job_url(url, sizeof url, id, tail);
    cJSON_AddStringToObject(o, "image_url", url);
}

/* A progressive job's "passes" object. */
static void api_job_passes(cJSON *o, const char *id, const struct jobs_passes *p)
{
    cJSON *x = cJSON_AddObjectToObject(o, "passes");
    cJSON_AddNumberToObject(x, "done", p->done);
    cJSON_AddNumberToObject(x, "total", p->total);
    cJSON_AddNumberToObject(x, "samples", p->samples);
    cJSON_AddNumberToObject(x, "samples_target", p->samples_target);
    json_add_fixed(x, "time_s", p->time_s, 3);
    api_add_noise(x, p->noise);
    const char *why = passes_stop_name(p->stopped);
    if (why)
        cJSON_AddStringToObject(x, "stopped_by", why);
    else
        cJSON_AddNullToObject(x, "stopped_by");
    if (p->done)
        api_add_pass_url(x, id, p->done);
}

/* The job's status document (docs/api.md: key order and decimals). */
static cJSON *api_job_json(const char *id, const struct jobs_info *in)
{
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "id", id);
    cJSON_AddStringToObject(o, "state", jobs_state_name(in->state));
    json_add_fixed(o, "progress", in->progress, 4);
    cJSON_AddNumberToObject(o, "tiles_done", (double)in->tiles_done);
    cJSON_AddNumberToObject(o, "tiles_total", (double)in->tiles_total);
    cJSON_AddStringToObject(o, "scene_id", in->scene_id);
    cJSON *reg = cJSON_AddObjectToObject(o, "region");
    cJSON_AddNumberToObject(reg, "x", in->region.x);
    cJSON_AddNumberToObject(reg, "y", in->region.y);
    cJSON_AddNumberToObject(reg, "w", in->region.w);
    cJSON_AddNumberToObject(reg, "h", in->region.h);
    json_add_fixed(o, "age_s", in->created_age, 3);
    json_add_fixed(o, "queue_ms", in->queue_ms, 3);
    json_add_fixed(o, "render_ms", in->render_ms, 3);
    json_add_fixed(o, "encode_ms", in->encode_ms, 3);
    json_add_u64(o, "rays", in->rays);
    struct api_price price = {in->est_rays, sched_seconds(in->est_rays)};
    api_add_estimate(o, &price);
    if (in->progressive)
        api_job_passes(o, id, &in->passes);
    if (in->state == JS_SUCCEEDED) {
        char url[80];
        api_job_url(url, sizeof url, id, "/image.png");
        cJSON_AddStringToObject(o, "image_url", url);
    }
    if (in->state == JS_FAILED) {
        cJSON *err = cJSON_AddObjectToObject(o, "error");
        cJSON_AddStringToObject(err, "code", rayd_status_name(in->err.code));
        cJSON_AddStringToObject(err, "message", in->err.message);
        if (in->err.path[0]) /* as every error: a path only when about one value */
            cJSON_AddStringToObject(err, "path", in->err.path);
    }
    return o;
}

/* The job's scene, for the access log. */
static void api_job_scene(struct http_req *r, const struct jobs_info *info)
{
    snprintf(r->scene, sizeof r->scene, "%s", info->scene_id);
}

void api_jobs_get(struct http_req *r, const char *id)
{
    struct jobs_info info;
    if (!api_is_hex(id, 32) || !jobs_get(id, &info, false)) {
        api_job_unknown(r);
        return;
    }
    api_job_scene(r, &info);
    http_reply_json(r, 200, api_job_json(id, &info));
}

void api_jobs_delete(struct http_req *r, const char *id)
{
    struct jobs_info info;
    if (!api_is_hex(id, 32) || !jobs_cancel(id) || !jobs_get(id, &info, false)) {
        api_job_unknown(r);
        return;
    }
    api_job_scene(r, &info);
    http_reply_json(r, 200, api_job_json(id, &info));
}

/* Which pass an image is: X-Rayd-Pass "k/total", X-Rayd-Samples n. */
static void api_pass_headers(struct http_req *r, int pass, int total, int samples)
{
    char v[32];
    snprintf(v, sizeof v, "%d/%d", pass, total);
    http_reply_header(r, "X-Rayd-Pass", v);
    snprintf(v, sizeof v, "%d", samples);
    http_reply_header(r, "X-Rayd-Samples", v);
}

/* GET /v1/jobs/{id}/image.png?pass=K: that pass's image, while kept. */
static void api_jobs_pass_image(struct http_req *r, const char *id, const char *q)
{
    char *end = NULL;
    long k = strtol(q, &end, 10);
    struct jobs_info info;
    if (!jobs_get(id, &info, false)) {
        api_job_unknown(r);
        return;
    }
    api_job_scene(r, &info);
    if (http_req_query_count(r, "pass") > 1 || !*q || *end || k < 1 || !info.progressive ||
        k > info.passes.total) {
        char msg[120];
        if (http_req_query_count(r, "pass") > 1)
            snprintf(msg, sizeof msg, "pass: given more than once");
        else if (!info.progressive)
            snprintf(msg, sizeof msg, "pass: only a progressive job has passes");
        else
            snprintf(msg, sizeof msg, "pass: must be a pass number of this job, 1..%d",
                     info.passes.total);
        http_reply_error(r, 400, "bad_parameter", msg, NULL, 0, 0, "pass");
        return;
    }
    struct blob *png = NULL;
    int samples = 0;
    jobs_pass_png(id, (int)k, &png, &samples);
    if (png) {
        http_reply_png(r, 200, png);
        http_reply_header(r, "Cache-Control", "private, max-age=3600");
        api_pass_headers(r, (int)k, info.passes.total, samples);
        blob_unref(png);
    } else if (k <= info.passes.done) {
        http_reply_error(r, 410, "pass_gone",
                         "that pass's image is no longer kept (only the latest passes are)",
                         NULL, 0, 0, "pass");
    } else {
        http_reply_json(r, 202, api_job_json(id, &info));
        http_reply_header(r, MHD_HTTP_HEADER_RETRY_AFTER, "1");
    }
}

void api_jobs_stop(struct http_req *r, const char *id)
{
    struct jobs_info info;
    bool progressive = false;
    if (!api_is_hex(id, 32) || !jobs_end_early(id, &progressive) || !jobs_get(id, &info, false)) {
        api_job_unknown(r);
        return;
    }
    api_job_scene(r, &info);
    if (!progressive) {
        http_reply_error(r, 409, "not_progressive",
                         "only a progressive job can be stopped and kept; DELETE cancels a job",
                         NULL, 0, 0, NULL);
        return;
    }
    http_reply_json(r, 200, api_job_json(id, &info));
}

void api_jobs_image(struct http_req *r, const char *id)
{
    struct jobs_info info;
    const char *pass = http_req_query(r, "pass");
    if (!api_is_hex(id, 32)) {
        api_job_unknown(r);
        return;
    }
    if (pass) {
        api_jobs_pass_image(r, id, pass);
        return;
    }
    if (!jobs_get(id, &info, true)) {
        api_job_unknown(r);
        return;
    }
    api_job_scene(r, &info);
    if (info.png && (info.state == JS_SUCCEEDED || info.state == JS_RUNNING)) {
        http_reply_png(r, 200, info.png);
        http_reply_header(r, "Cache-Control",
                          info.state == JS_SUCCEEDED ? "private, max-age=3600" : "no-store");
        if (info.progressive)
            api_pass_headers(r, info.passes.done, info.passes.total, info.passes.samples);
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
        http_reply_json(r, 202, api_job_json(id, &info));
        http_reply_header(r, MHD_HTTP_HEADER_RETRY_AFTER, "1");
    }
}

/* ---- Server-Sent Events ---------------------------------------------------------- */

#define API_SSE_ITEMS 32

/* One open stream: freed with its response (libmicrohttpd's free callback). */
struct api_sse {
    struct work_waiter w; /* first: the callbacks get it back */
    struct http_req *r;
    struct events_stream *s;
    char id[33];
    char *carry; /* text formatted but not yet sent */
    size_t carry_len, carry_off;
};

static void api_sse_suspend(struct work_waiter *w)
{
    http_req_suspend(((struct api_sse *)w)->r);
}

/* Woken by news of the job, or by the watcher when the client hung up: then
 * the stream ends at once (the reader's next call), rather than waiting,
 * suspended, for an event that may be long in coming -- a queued job's. */
static void api_sse_wake(struct work_waiter *w, struct work_result *res)
{
    struct http_req *r = ((struct api_sse *)w)->r;
    if (res->gone) {
        r->gone = true;
        r->note = "client_gone";
    }
    blob_unref(res->png);
    http_req_resume(r);
}

/* "event: NAME\ndata: JSON\n\n" appended to out (o deleted). */
static size_t api_sse_event(char *out, size_t size, const char *name, cJSON *o)
{
    char data[2048];
    bool ok = json_print_into(o, data, sizeof data);
    cJSON_Delete(o);
    int n = snprintf(out, size, "event: %s\ndata: %s\n\n", name, ok ? data : "{}");
    return n < 0 || (size_t)n >= size ? 0 : (size_t)n;
}

/* "event: pass": a progressive job's pass is complete (o deleted). */
static size_t api_sse_pass(struct api_sse *a, const struct events_item *it, cJSON *o, char *out,
                           size_t size)
{
    cJSON_AddNumberToObject(o, "pass", it->done);
    cJSON_AddNumberToObject(o, "passes", it->total);
    cJSON_AddNumberToObject(o, "samples", it->samples);
    json_add_fixed(o, "time_s", it->time_s, 3);
    api_add_noise(o, it->noise);
    json_add_fixed(o, "progress", it->progress, 4);
    api_add_pass_url(o, a->id, it->done);
    return api_sse_event(out, size, "pass", o);
}

/* One item as SSE text into out (2.5 KiB is enough for any). */
static size_t api_sse_format(struct api_sse *a, const struct events_item *it,
                             const struct rayd_error *err, char *out, size_t size)
{
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
    case EVENTS_PASS:
        return api_sse_pass(a, it, o, out, size);
    case EVENTS_DONE:
        cJSON_AddStringToObject(o, "state", jobs_state_name(it->state));
        json_add_fixed(o, "progress", it->progress, 4);
        if (it->samples > 0)
            cJSON_AddNumberToObject(o, "samples", it->samples);
        if (it->state == JS_FAILED)
            cJSON_AddStringToObject(o, "error", err->message);
        return api_sse_event(out, size, "done", o);
    case EVENTS_PING:
    default:
        cJSON_Delete(o);
        return (size_t)snprintf(out, size, ": keep-alive\n\n");
    }
}

/* Copies what fits of text to buf; the rest goes to the carry.  false when
 * the carry cannot be had (out of memory). */
static bool api_sse_put(struct api_sse *a, char *buf, size_t max, size_t *used, const char *text,
                        size_t len)
{
    size_t k = len < max - *used ? len : max - *used;
    memcpy(buf + *used, text, k);
    *used += k;
    if (k == len)
        return true;
    char *c = realloc(a->carry, a->carry_len + len - k);
    if (!c)
        return false;
    memcpy(c + a->carry_len, text + k, len - k);
    a->carry = c;
    a->carry_len += len - k;
    return true;
}

/* Sends what is left of the carry; true when it is empty. */
static bool api_sse_flush(struct api_sse *a, char *buf, size_t max, size_t *used)
{
    size_t left = a->carry_len - a->carry_off;
    size_t k = left < max - *used ? left : max - *used;
    memcpy(buf + *used, a->carry + a->carry_off, k);
    *used += k;
    a->carry_off += k;
    if (a->carry_off < a->carry_len)
        return false;
    free(a->carry);
    a->carry = NULL;
    a->carry_len = a->carry_off = 0;
    return true;
}

static ssize_t api_sse_reader(void *cls, uint64_t pos, char *buf, size_t max)
{
    (void)pos;
    struct api_sse *a = cls;
    struct http_req *r = a->r;
    if (r->gone)
        return MHD_CONTENT_READER_END_WITH_ERROR;
    size_t used = 0;
    if (a->carry && !api_sse_flush(a, buf, max, &used))
        goto out;
    struct events_item items[API_SSE_ITEMS];
    struct rayd_error err = {0};
    int n = used ? 0 : events_read(a->s, items, API_SSE_ITEMS, &err, &a->w);
    if (n < 0)
        return MHD_CONTENT_READER_END_OF_STREAM;
    for (int i = 0; i < n; i++) {
        char text[2560];
        size_t len = api_sse_format(a, &items[i], &err, text, sizeof text);
        if (!api_sse_put(a, buf, max, &used, text, len))
            return MHD_CONTENT_READER_END_WITH_ERROR;
    }
out:
    r->bytes += used;
    return (ssize_t)used;
}

static void api_sse_free(void *cls)
{
    struct api_sse *a = cls;
    events_close(a->s);
    free(a->carry);
    free(a);
}

void api_jobs_events(struct http_req *r, const char *id)
{
    struct api_sse *a = calloc(1, sizeof *a);
    if (!a) {
        api_refused(r, WORK_NOMEM);
        return;
    }
    if (!api_is_hex(id, 32) || !(a->s = events_open(id))) {
        free(a);
        api_job_unknown(r);
        return;
    }
    a->r = r;
    snprintf(a->id, sizeof a->id, "%s", id);
    a->w.done = api_sse_wake;
    a->w.suspend = api_sse_suspend;
    a->w.fd = http_req_fd(r);
    struct MHD_Response *resp =
        MHD_create_response_from_callback(MHD_SIZE_UNKNOWN, 4096, api_sse_reader, a, api_sse_free);
    if (!resp) {
        api_sse_free(a);
        r->gone = true;
        return;
    }
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, "text/event-stream");
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL, "no-store");
    MHD_add_response_header(resp, "X-Accel-Buffering", "no");
    http_reply(r, 200, resp);
}
