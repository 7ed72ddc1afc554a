/* api_jobs_json.c -- what every job route writes: the job's JSON (a
 * plain, progressive or frame-range job's common part), the 404 of an
 * unknown id and the 410 of a forgotten one, the job's URLs, and a new
 * job's 202 (and its 503 when the store cannot keep it).
 *
 * api_jobs.c (the job routes), api_jobs_image.c (its images),
 * api_events.c (its stream) and api_shots.c (a frame-range job's "frames")
 * all answer through these, so a job reads the same on every route.
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

void api_jobs_gone(struct http_req *r, const struct jobs_gone *g, cJSON *job) {
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

void api_jobs_url(char *buf, size_t size, const char *id, const char *tail) {
    snprintf(buf, size, "/v1/jobs/%s%s", id, tail);
}

/* "estimate": {"rays", "seconds"}: the job's price (api_cost.c). */
void api_jobs_add_estimate(cJSON *o, const struct api_price *p) {
    cJSON *e = cJSON_AddObjectToObject(o, "estimate");
    json_add_fixed(e, "rays", p->rays, 0);
    json_add_fixed(e, "seconds", p->seconds, 3);
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
    api_jobs_url(url, sizeof url, id, tail);
    cJSON_AddStringToObject(o, "image_url", url);
}

void api_jobs_add_raw_url(cJSON *o, const char *id, int k) {
    char url[100], tail[48];
    snprintf(tail, sizeof tail, "/image.png?pass=%d&denoise=0", k);
    api_jobs_url(url, sizeof url, id, tail);
    cJSON_AddStringToObject(o, "raw_url", url);
}

bool api_jobs_keeps_raw(const struct jobs_info *in) {
    return in->progressive && in->denoise && (!in->aov || in->keep_exr);
}

/* "exr_url" of pass k of job id (a job with format=exr). */
static void api_jobs_add_pass_exr_url(cJSON *o, const char *id, int k) {
    char url[100], tail[40];
    snprintf(tail, sizeof tail, "/image.exr?pass=%d", k);
    api_jobs_url(url, sizeof url, id, tail);
    cJSON_AddStringToObject(o, "exr_url", url);
}

void api_jobs_pass_headers(struct http_req *r, int pass, int total, int samples) {
    char v[32];
    snprintf(v, sizeof v, "%d/%d", pass, total);
    http_reply_header(r, "X-Rayd-Pass", v);
    snprintf(v, sizeof v, "%d", samples);
    http_reply_header(r, "X-Rayd-Samples", v);
}

/* A progressive job's "passes" object. */
static void api_job_passes(cJSON *o, const char *id, const struct jobs_passes *p, bool exr,
                           bool raw) {
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
    if (p->done && raw) api_jobs_add_raw_url(x, id, p->done);
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
    api_jobs_add_estimate(o, &price);
    if (in->denoise) cJSON_AddTrueToObject(o, "denoise");
    if (in->progressive) api_job_passes(o, id, &in->passes, in->keep_exr, api_jobs_keeps_raw(in));
    if (in->state == JS_SUCCEEDED) {
        char url[80];
        api_jobs_url(url, sizeof url, id, "/image.png");
        cJSON_AddStringToObject(o, "image_url", url);
        if (in->keep_exr) {
            api_jobs_url(url, sizeof url, id, "/image.exr");
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

void api_jobs_reply_accepted(struct http_req *r, cJSON *o, const char *id, bool unlit,
                             const struct api_price *price) {
    char url[80];
    if (unlit) api_warn_unlit_json(o);
    http_reply_json(r, 202, o);
    if (unlit) api_warn_unlit_header(r);
    api_jobs_url(url, sizeof url, id, "");
    http_reply_header(r, "Location", url);
    api_cost_price_headers(r, price);
}

void api_jobs_reply_store_failed(struct http_req *r, const char *message) {
    r->res.retry_after = 5;
    http_reply_error(r, 503, "store_failed", message, NULL, 0, 0, NULL);
}
