/* api_jobs.c -- asynchronous renders: POST /v1/jobs, GET /v1/jobs/{id},
 * POST /v1/jobs/{id}/stop, DELETE.
 *
 * A job is a render nobody waits on: POST answers 202 with the job id at
 * once, the client polls the job or follows its Server-Sent Events, then
 * fetches the PNG (or, for a job created with ?format=exr, the EXR too).
 * The jobs themselves (table, states, progress, the event cursor) live in
 * the work layer (jobs.c, events.c); this file turns them into HTTP and
 * JSON.  The event stream, GET /v1/jobs/{id}/events, is api_events.c's;
 * the images, GET /v1/jobs/{id}/image.png and image.exr, api_jobs_image.c's.
 *
 * An id the server gave but no longer has answers 410 Gone with why: the
 * job expired (--job-ttl after it ended), was forgotten to make room
 * (--max-jobs), or its image was evicted (a memory budget) -- with how and
 * when it ended -- so a client that polled too late is told so, and a 404
 * job_unknown means an id this server never had (or forgot long ago, past
 * its tombstones: jobs.c).
 */
#include "api/api.h"

#include <cjson/cJSON.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

void api_jobs_unknown(struct http_req *r) {
    http_reply_error(r, 404, "job_unknown", "no such job on this server (or it was forgotten)",
                     NULL, 0, 0, NULL);
}

/* t, seconds since the epoch, as RFC 3339 UTC: 2026-12-02T00:38:53Z. */
static void api_jobs_time(char *buf, size_t size, double t) {
    time_t s = (time_t)t;
    struct tm tm;
    if (!gmtime_r(&s, &tm) || !strftime(buf, size, "%Y-%m-%dT%H:%M:%SZ", &tm))
        snprintf(buf, size, "unknown");
}

/* The sentence of a 410: how the job ended, when, and why it is gone. */
static void api_jobs_gone_message(char *msg, size_t size, const struct jobs_gone *g,
                                  const char *ended, const char *gone) {
    const char *how = g->state == JS_SUCCEEDED || g->state == JS_EVICTED ? "succeeded"
                      : g->state == JS_FAILED                            ? "failed"
                                                                         : "was cancelled";
    if (g->why == JG_EXPIRED)
        snprintf(msg, size,
                 "the job %s at %s and was forgotten at %s: an ended job is kept for --job-ttl "
                 "%ld s",
                 how, ended, gone, config.job_ttl);
    else if (g->why == JG_EVICTED)
        snprintf(msg, size,
                 "the job %s at %s and was forgotten at %s to make room for newer jobs "
                 "(--max-jobs %ld)",
                 how, ended, gone, config.max_jobs);
    else
        snprintf(msg, size, "the job %s at %s; its image was evicted at %s (%s)", how, ended, gone,
                 g->detail[0] ? g->detail : "no reason given");
}

/* 410 Gone for a job or its result: the error with the job's end and, when
 * the job is still known, its JSON (job, owned). */
static void api_jobs_gone(struct http_req *r, const struct jobs_gone *g, cJSON *job) {
    static const char *const codes[] = {"job_expired", "job_evicted", "result_evicted"};
    char msg[400], ended[40], gone[40];
    api_jobs_time(ended, sizeof ended, g->ended_wall);
    api_jobs_time(gone, sizeof gone, g->gone_wall);
    api_jobs_gone_message(msg, sizeof msg, g, ended, gone);
    cJSON *o = cJSON_CreateObject();
    cJSON *e = cJSON_AddObjectToObject(o, "error");
    cJSON_AddNumberToObject(e, "status", 410);
    cJSON_AddStringToObject(e, "code", codes[g->why]);
    cJSON_AddStringToObject(e, "message", msg);
    cJSON_AddStringToObject(e, "state", jobs_state_name(g->state));
    cJSON_AddStringToObject(e, "ended_at", ended);
    cJSON_AddStringToObject(e, g->why == JG_RESULT_EVICTED ? "evicted_at" : "forgotten_at", gone);
    if (job) cJSON_AddItemToObject(o, "job", job);
    http_reply_json(r, 410, o);
    http_reply_header(r, "Cache-Control", "no-store");
    r->res.err_code = codes[g->why];
}

void api_jobs_missing(struct http_req *r, const char *id) {
    struct jobs_gone g;
    if (api_is_hex(id, 32) && jobs_gone(id, &g))
        api_jobs_gone(r, &g, NULL);
    else
        api_jobs_unknown(r);
}

bool api_jobs_evicted(struct http_req *r, const char *id, const struct jobs_info *info) {
    if (!info->result_evicted) return false;
    api_jobs_scene(r, info);
    api_jobs_gone(r, &info->gone, api_jobs_json(id, info));
    return true;
}

static void api_job_url(char *buf, size_t size, const char *id, const char *tail) {
    snprintf(buf, size, "/v1/jobs/%s%s", id, tail);
}

/* ---- a progressive job's query ----------------------------------------------- */

static const char *const api_plan_names[] = {"progressive", "pass_step", "time_budget",
                                             "noise_target", NULL};
/* What POST /v1/jobs takes besides the region. */
static const char *const api_jobs_names[] = {
    "progressive", "pass_step", "time_budget", "noise_target", "format", "priority", NULL};

/* A decimal number in (0, max] from ?name=, if given: digits and a point
 * only (api_is_decimal), so 0x10, 1e3, inf and " 5" are refused. */
static bool api_plan_number(struct http_req *r, const char *name, double max, double *out) {
    const char *v = http_req_query(r, name);
    if (!v) return true;
    double x = strtod(v, NULL);
    if (!api_is_decimal(v, true) || !(x > 0 && x <= max)) {
        char why[100];
        snprintf(why, sizeof why, "must be a decimal number above 0 and at most %g", max);
        return api_bad_param(r, name, why);
    }
    *out = x;
    return true;
}

/* ?progressive=1 and its options into *plan; *progressive false without
 * it.  Replies 400 and returns false on a bad one. */
static bool api_plan(struct http_req *r, const rayd_scene *scene, struct jobs_plan *plan,
                     bool *progressive) {
    memset(plan, 0, sizeof *plan);
    for (int i = 0; api_plan_names[i]; i++)
        if (http_req_query_count(r, api_plan_names[i]) > 1)
            return api_bad_param(r, api_plan_names[i], "given more than once");
    const char *v = http_req_query(r, "progressive");
    *progressive = v && (!strcmp(v, "1") || !strcmp(v, "true"));
    if (v && !*progressive && strcmp(v, "0") && strcmp(v, "false"))
        return api_bad_param(r, "progressive", "must be 1, true, 0 or false");
    for (int i = 1; api_plan_names[i]; i++)
        if (!*progressive && http_req_query(r, api_plan_names[i]))
            return api_bad_param(r, api_plan_names[i], "needs progressive=1");
    double step = 0;
    if (!api_plan_number(r, "pass_step", 1e6, &step) ||
        !api_plan_number(r, "time_budget", 86400, &plan->time_budget) ||
        !api_plan_number(r, "noise_target", 1, &plan->noise_target))
        return false;
    if (step != (int)step)
        return api_bad_param(r, "pass_step", "must be a whole number of samples");
    plan->step = (int)step;
    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    int samples[PASSES_MAX];
    if (*progressive && passes_plan(plan, info.samples, samples) < 0) {
        char why[120];
        snprintf(why, sizeof why, "%d samples in steps of %d is more than %d passes", info.samples,
                 plan->step, PASSES_MAX);
        return api_bad_param(r, "pass_step", why);
    }
    return true;
}

/* ?format=png|exr into what (POST /v1/render's names; a job keeps its
 * 8-bit PNG always, and with exr the EXR of the same samples).  Replies
 * 400 naming format and returns false on a bad one. */
static bool api_jobs_format(struct http_req *r, struct work_target *what) {
    const char *v = http_req_query(r, "format");
    if (http_req_query_count(r, "format") > 1)
        return api_bad_param(r, "format", "given more than once");
    if (v && strcmp(v, "png") && strcmp(v, "exr")) {
        char why[120];
        snprintf(why, sizeof why, "must be png or exr for a job, not '%.40s'", v);
        return api_bad_param(r, "format", why);
    }
    what->keep_exr = v && !strcmp(v, "exr");
    return true;
}

/* "estimate": {"rays", "seconds"}: the job's price (api_cost.c). */
static void api_add_estimate(cJSON *o, const struct api_price *p) {
    cJSON *e = cJSON_AddObjectToObject(o, "estimate");
    json_add_fixed(e, "rays", p->rays, 0);
    json_add_fixed(e, "seconds", p->seconds, 3);
}

/* ?priority=low|normal|high into *p (normal without it); 400 and false on
 * a bad one. */
static bool api_jobs_priority(struct http_req *r, int *p) {
    const char *v = http_req_query(r, "priority");
    *p = JP_NORMAL;
    if (http_req_query_count(r, "priority") > 1)
        return api_bad_param(r, "priority", "given more than once");
    if (!v) return true;
    for (int i = JP_LOW; i <= JP_HIGH; i++)
        if (!strcmp(v, jobs_priority_name(i))) {
            *p = i;
            return true;
        }
    char why[120];
    snprintf(why, sizeof why, "must be low, normal or high, not '%.40s'", v);
    return api_bad_param(r, "priority", why);
}

/* What the 202 of a new job says, kept until it is sent (at once, or once
 * the job is on disk: --data-dir). */
struct api_jobs_wait {
    struct work_waiter w;
    struct http_req *r;
    char id[33], scene_id[65];
    bool keep_exr;
    struct api_price price;
};

/* 202: the job's id and where to follow it. */
static void api_jobs_accepted(struct api_jobs_wait *a) {
    struct http_req *r = a->r;
    char url[80];
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "id", a->id);
    cJSON_AddStringToObject(o, "state", "queued");
    cJSON_AddStringToObject(o, "scene_id", a->scene_id);
    api_job_url(url, sizeof url, a->id, "");
    cJSON_AddStringToObject(o, "status_url", url);
    api_job_url(url, sizeof url, a->id, "/image.png");
    cJSON_AddStringToObject(o, "image_url", url);
    if (a->keep_exr) {
        api_job_url(url, sizeof url, a->id, "/image.exr");
        cJSON_AddStringToObject(o, "exr_url", url);
    }
    api_job_url(url, sizeof url, a->id, "/events");
    cJSON_AddStringToObject(o, "events_url", url);
    api_add_estimate(o, &a->price);
    http_reply_json(r, 202, o);
    api_job_url(url, sizeof url, a->id, "");
    http_reply_header(r, "Location", url);
    api_cost_price_headers(r, &a->price);
}

/* The store thread's word (--data-dir): the job is on disk, or could not
 * be recorded (then it is cancelled: a job rayd cannot keep is not taken). */
static void api_jobs_recorded(struct work_waiter *w, struct work_result *res) {
    struct api_jobs_wait *a = (struct api_jobs_wait *)w;
    if (res->status == RAYD_OK) {
        api_jobs_accepted(a);
    } else {
        jobs_cancel(a->id);
        a->r->res.retry_after = 5;
        http_reply_error(a->r, 503, "store_failed", res->err.message, NULL, 0, 0, NULL);
    }
    http_req_resume(a->r);
    free(a);
}

static void api_jobs_recorded_suspend(struct work_waiter *w) {
    api_suspend(((struct api_jobs_wait *)w)->r);
}

/* POST /v1/jobs once its scene is compiled (api_scene's continuation);
 * true when the request waits for the store (it resumes it). */
static bool api_jobs_compiled(struct http_req *r, struct cache_entry *e, bool hit) {
    (void)hit;
    bool progressive = false;
    struct work_target what = {.format = WORK_PNG};
    struct jobs_plan plan;
    struct api_price price;
    struct jobs_new how = {.scene = r->body ? r->body : "", .scene_len = r->body_len};
    if (!api_region_also(r, cache_scene(e), &what.reg, api_jobs_names) ||
        !api_plan(r, cache_scene(e), &plan, &progressive) || !api_jobs_format(r, &what) ||
        !api_jobs_priority(r, &how.priority) || !api_cost_admit(r, e, &what, progressive, &price))
        return false; /* replied */
    struct api_jobs_wait *a = calloc(1, sizeof *a);
    if (!a) {
        api_refused(r, WORK_NOMEM);
        return false;
    }
    a->r = r;
    a->w.done = api_jobs_recorded;
    a->w.suspend = api_jobs_recorded_suspend;
    a->w.fd = -1;
    snprintf(a->scene_id, sizeof a->scene_id, "%s", cache_id(e));
    a->keep_exr = what.keep_exr;
    a->price = price;
    how.w = &a->w;
    enum work_submit s = jobs_submit(e, &what, progressive ? &plan : NULL, &how, a->id);
    if (how.waiting) return true; /* a is the store's until done() */
    if (s != WORK_OK)
        api_refused(r, s);
    else
        api_jobs_accepted(a);
    free(a);
    return false;
}

void api_jobs_post(struct http_req *r, const char *unused) {
    (void)unused;
    api_scene(r, api_jobs_compiled);
}

/* "noise": the estimate with 6 decimals, or null before there is one. */
void api_jobs_add_noise(cJSON *o, double noise) {
    if (noise >= 0)
        json_add_fixed(o, "noise", noise, 6);
    else
        cJSON_AddNullToObject(o, "noise");
}

/* "image_url" of pass k of job id. */
void api_jobs_add_pass_url(cJSON *o, const char *id, int k) {
    char url[100], tail[40];
    snprintf(tail, sizeof tail, "/image.png?pass=%d", k);
    api_job_url(url, sizeof url, id, tail);
    cJSON_AddStringToObject(o, "image_url", url);
}

/* "exr_url" of pass k of job id (a job with format=exr). */
static void api_jobs_add_pass_exr_url(cJSON *o, const char *id, int k) {
    char url[100], tail[40];
    snprintf(tail, sizeof tail, "/image.exr?pass=%d", k);
    api_job_url(url, sizeof url, id, tail);
    cJSON_AddStringToObject(o, "exr_url", url);
}

/* A progressive job's "passes" object. */
static void api_job_passes(cJSON *o, const char *id, const struct jobs_passes *p, bool exr) {
    cJSON *x = cJSON_AddObjectToObject(o, "passes");
    cJSON_AddNumberToObject(x, "done", p->done);
    cJSON_AddNumberToObject(x, "total", p->total);
    cJSON_AddNumberToObject(x, "samples", p->samples);
    cJSON_AddNumberToObject(x, "samples_target", p->samples_target);
    json_add_fixed(x, "time_s", p->time_s, 3);
    api_jobs_add_noise(x, p->noise);
    const char *why = passes_stop_name(p->stopped);
    if (why)
        cJSON_AddStringToObject(x, "stopped_by", why);
    else
        cJSON_AddNullToObject(x, "stopped_by");
    if (p->done) api_jobs_add_pass_url(x, id, p->done);
    if (p->done && exr) api_jobs_add_pass_exr_url(x, id, p->done);
}

cJSON *api_jobs_json(const char *id, const struct jobs_info *in) {
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
    cJSON_AddStringToObject(o, "priority", jobs_priority_name(in->priority));
    if (in->created_wall > 0) {
        char at[40];
        api_jobs_time(at, sizeof at, in->created_wall);
        cJSON_AddStringToObject(o, "created_at", at);
    }
    json_add_fixed(o, "age_s", in->created_age, 3);
    json_add_fixed(o, "queue_ms", in->queue_ms, 3);
    json_add_fixed(o, "render_ms", in->render_ms, 3);
    json_add_fixed(o, "encode_ms", in->encode_ms, 3);
    json_add_u64(o, "rays", in->rays);
    if (in->ended_age >= 0) { /* forgotten --job-ttl after it ended */
        double left = (double)config.job_ttl - in->ended_age;
        json_add_fixed(o, "expires_in_s", left > 0 ? left : 0, 3);
    }
    struct api_price price = {in->est_rays, cost_price_seconds(in->scene_id, in->est_rays)};
    api_add_estimate(o, &price);
    if (in->progressive) api_job_passes(o, id, &in->passes, in->keep_exr);
    if (in->state == JS_SUCCEEDED) {
        char url[80];
        api_job_url(url, sizeof url, id, "/image.png");
        cJSON_AddStringToObject(o, "image_url", url);
        if (in->keep_exr) {
            api_job_url(url, sizeof url, id, "/image.exr");
            cJSON_AddStringToObject(o, "exr_url", url);
        }
    }
    if (in->state == JS_EVICTED)
        cJSON_AddStringToObject(o, "evicted_reason",
                                in->result_evicted && in->gone.detail[0] ? in->gone.detail
                                                                         : JOBS_EVICTED_WHY);
    if (in->state == JS_FAILED) {
        cJSON *err = cJSON_AddObjectToObject(o, "error");
        cJSON_AddStringToObject(err, "code", rayd_status_name(in->err.code));
        cJSON_AddStringToObject(err, "message", in->err.message);
        if (in->err.path[0]) /* as every error: a path only when about one value */
            cJSON_AddStringToObject(err, "path", in->err.path);
    }
    return o;
}

void api_jobs_scene(struct http_req *r, const struct jobs_info *info) {
    snprintf(r->res.scene, sizeof r->res.scene, "%s", info->scene_id);
}

void api_jobs_get(struct http_req *r, const char *id) {
    struct jobs_info info;
    if (!api_only_params(r, NULL)) return;
    if (!api_is_hex(id, 32) || !jobs_get(id, &info, JOBS_NUMBERS)) {
        api_jobs_missing(r, id);
        return;
    }
    if (api_jobs_evicted(r, id, &info)) return;
    api_jobs_scene(r, &info);
    http_reply_json(r, 200, api_jobs_json(id, &info));
}

void api_jobs_delete(struct http_req *r, const char *id) {
    struct jobs_info info;
    if (!api_only_params(r, NULL)) return;
    if (!api_is_hex(id, 32) || !jobs_cancel(id) || !jobs_get(id, &info, JOBS_NUMBERS)) {
        api_jobs_missing(r, id);
        return;
    }
    if (api_jobs_evicted(r, id, &info)) return;
    api_jobs_scene(r, &info);
    http_reply_json(r, 200, api_jobs_json(id, &info));
}

void api_jobs_stop(struct http_req *r, const char *id) {
    struct jobs_info info;
    bool progressive = false;
    if (!api_only_params(r, NULL)) return;
    if (!api_is_hex(id, 32) || !jobs_end_early(id, &progressive) ||
        !jobs_get(id, &info, JOBS_NUMBERS)) {
        api_jobs_missing(r, id);
        return;
    }
    if (api_jobs_evicted(r, id, &info)) return;
    api_jobs_scene(r, &info);
    if (!progressive) {
        http_reply_error(r, 409, "not_progressive",
                         "only a progressive job can be stopped and kept; DELETE cancels a job",
                         NULL, 0, 0, NULL);
        return;
    }
    http_reply_json(r, 200, api_jobs_json(id, &info));
}

/* ---- GET /v1/jobs: the calling client's jobs --------------------------------- */

#define API_JOBS_PAGE 20 /* jobs a page holds without ?limit= */
#define API_JOBS_PAGE_MAX 100

/* ?name=, a whole number in 1..max, into *out (left as is without it). */
static bool api_jobs_count(struct http_req *r, const char *name, long long max, long long *out) {
    const char *v = http_req_query(r, name);
    if (http_req_query_count(r, name) > 1) return api_bad_param(r, name, "given more than once");
    if (!v) return true;
    long long x = strtoll(v, NULL, 10);
    if (!api_is_decimal(v, false) || strlen(v) > 18 || x < 1 || x > max) {
        char why[100];
        snprintf(why, sizeof why, "must be a whole number from 1 to %lld", max);
        return api_bad_param(r, name, why);
    }
    *out = x;
    return true;
}

/* ?state=: a job state's name, or any (-1) without it. */
static bool api_jobs_state_param(struct http_req *r, int *state) {
    const char *v = http_req_query(r, "state");
    *state = -1;
    if (http_req_query_count(r, "state") > 1)
        return api_bad_param(r, "state", "given more than once");
    if (!v) return true;
    for (int i = JS_QUEUED; i <= JS_EVICTED; i++)
        if (!strcmp(v, jobs_state_name((enum jobs_state)i))) {
            *state = i;
            return true;
        }
    return api_bad_param(r, "state",
                         "must be queued, running, succeeded, failed, canceled or evicted");
}

void api_jobs_list(struct http_req *r, const char *unused) {
    (void)unused;
    static const char *const takes[] = {"limit", "after", "state", NULL};
    long long limit = API_JOBS_PAGE, after = 0;
    int state;
    if (!api_only_params(r, takes) || !api_jobs_count(r, "limit", API_JOBS_PAGE_MAX, &limit) ||
        !api_jobs_count(r, "after", (long long)1e18, &after) || !api_jobs_state_param(r, &state))
        return;
    struct jobs_info *rows = calloc((size_t)limit, sizeof *rows);
    if (!rows) {
        api_refused(r, WORK_NOMEM);
        return;
    }
    bool more = false;
    int n = jobs_list(api_cost_client(r), state, after, rows, (int)limit, &more);
    cJSON *o = cJSON_CreateObject();
    cJSON *list = cJSON_AddArrayToObject(o, "jobs");
    for (int i = 0; i < n; i++) {
        cJSON_AddItemToArray(list, api_jobs_json(rows[i].id, &rows[i]));
    }
    if (more && n > 0) {
        char cursor[24], url[200];
        snprintf(cursor, sizeof cursor, "%lld", rows[n - 1].seq);
        cJSON_AddStringToObject(o, "next_after", cursor);
        int k = snprintf(url, sizeof url, "/v1/jobs?limit=%lld&after=%s", limit, cursor);
        if (state >= 0 && k > 0 && (size_t)k < sizeof url)
            snprintf(url + k, sizeof url - (size_t)k, "&state=%s",
                     jobs_state_name((enum jobs_state)state));
        cJSON_AddStringToObject(o, "next_url", url);
    } else {
        cJSON_AddNullToObject(o, "next_after");
        cJSON_AddNullToObject(o, "next_url");
    }
    free(rows);
    http_reply_json(r, 200, o);
    http_reply_header(r, "Cache-Control", "no-store");
}
