/* api_cluster.c -- the job routes with --redis: answered from the cluster.
 *
 * With --redis every job route of every node reads and writes the job in
 * Redis (server/cluster/), so a job posted to one node is polled, fetched
 * and cancelled on any other with the same answers.  The handlers here
 * check the request as the single node's do, then hand a struct
 * cluster_op to the cluster's request thread: the request is suspended
 * (before the op is linked) and answered from that thread by the op's
 * done callback, so no Redis call runs on an HTTP thread.  The JSON is
 * made by the single node's own functions (api_jobs_json, api_shots_json)
 * from the same structs, so it has the same shape.
 *
 * What a cluster job does not do yet is refused at the door, naming the
 * parameter, never answered wrongly: a progressive job's passes are PNGs
 * of the light alone (no EXR, AOV or denoised passes).  While Redis is unreachable
 * every job route answers 503 cluster_unavailable with a Retry-After and
 * a message naming the Redis address and the reason; renders, which need
 * no Redis, are served as always.
 */
#include "api/api.h"
#include "cluster/cluster.h"

#include <cjson/cJSON.h>
#include <stdlib.h>
#include <string.h>

#define API_CLUSTER_RETRY 5 /* seconds a 503 cluster_unavailable asks to wait */

/* One op and what its answer needs. */
struct api_cluster {
    struct cluster_op op; /* first: the callbacks get it back */
    struct http_req *r;
    bool unlit, exr;
    const char *pass; /* image.png?pass= as given, or NULL */
    struct api_price price;
    char *query;
    void (*answer)(struct api_cluster *a);
};

static void api_cluster_suspend(struct cluster_op *op) {
    api_suspend(((struct api_cluster *)op)->r);
}

/* The answer, on the cluster's request thread; r resumed, a freed. */
static void api_cluster_done(struct cluster_op *op) {
    struct api_cluster *a = (struct api_cluster *)op;
    struct http_req *r = a->r;
    if (op->status == CS_DOWN) {
        r->res.retry_after = API_CLUSTER_RETRY;
        http_reply_error(r, 503, "cluster_unavailable", op->why, NULL, 0, 0, NULL);
    } else if (op->status == CS_NOMEM) {
        api_refused(r, WORK_NOMEM);
    } else if (op->status == CS_FULL) { /* --max-jobs: as a single node's full table */
        api_refused(r, WORK_TOO_MANY_JOBS);
    } else if (op->status == CS_GONE) {
        api_jobs_gone(r, &op->gone, NULL);
    } else if (op->status == CS_UNKNOWN) {
        http_reply_error(r, 404, "job_unknown", "no such job in the cluster (or it was forgotten)",
                         NULL, 0, 0, NULL);
    } else {
        a->answer(a);
    }
    blob_unref(op->png);
    free(op->rows);
    free(op->row_animated);
    free(a->query);
    free(a);
    http_req_resume(r);
}

/* Hands a to the cluster; false after replying (stopping). */
static bool api_cluster_go(struct api_cluster *a) {
    a->op.suspend = api_cluster_suspend;
    a->op.done = api_cluster_done;
    if (cluster_submit(&a->op)) return true;
    api_refused(a->r, WORK_DRAINING);
    free(a->op.rows);
    free(a->op.row_animated);
    free(a->query);
    free(a);
    return false;
}

static struct api_cluster *api_cluster_new(struct http_req *r, enum cluster_op_kind kind,
                                           const char *id, void (*answer)(struct api_cluster *)) {
    struct api_cluster *a = calloc(1, sizeof *a);
    if (!a) {
        api_refused(r, WORK_NOMEM);
        return NULL;
    }
    a->r = r;
    a->op.kind = kind;
    a->answer = answer;
    if (id) snprintf(a->op.id, sizeof a->op.id, "%s", id);
    return a;
}

/* A job's JSON: a frame range's with its "frames" (and its video_url). */
static cJSON *api_cluster_json(const char *id, const struct shots_info *in, bool animated) {
    return animated ? api_shots_json(id, in) : api_jobs_json(id, &in->job);
}

/* ---- POST /v1/jobs ------------------------------------------------------------------ */

static void api_cluster_query_add(void *u, const char *k, const char *v) {
    char **q = u;
    size_t used = *q ? strlen(*q) : 0, n = used + strlen(k) + (v ? strlen(v) : 0) + 3;
    char *s = realloc(*q, n);
    if (!s) return;
    snprintf(s + used, n - used, "%s%s%s%s", used ? "&" : "", k, v ? "=" : "", v ? v : "");
    *q = s;
}

static void api_cluster_accepted(struct api_cluster *a) {
    struct cluster_op *op = &a->op;
    struct shots_info in = {.first = op->first,
                            .last = op->last,
                            .total = op->last - op->first + 1,
                            .latest = -1,
                            .eta_s = -1,
                            .queued = op->last - op->first + 1,
                            .fps = op->fps};
    in.job = (struct jobs_info){.state = JS_QUEUED,
                                .region = op->reg,
                                .priority = op->priority,
                                .est_rays = op->est_rays,
                                .denoise = op->denoise,
                                .keep_exr = op->exr,
                                .ended_age = -1,
                                .tiles_total = op->animated ? op->last - op->first + 1 : 0,
                                .created_wall = op->created_ms / 1e3};
    snprintf(in.job.scene_id, sizeof in.job.scene_id, "%s", op->scene_id);
    char url[80];
    cJSON *o;
    if (op->animated) {
        o = api_cluster_json(op->id, &in, true);
    } else {
        /* the single node's 202, key for key (api_jobs.c) */
        o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "id", op->id);
        cJSON_AddStringToObject(o, "state", "queued");
        cJSON_AddStringToObject(o, "scene_id", op->scene_id);
        api_jobs_url(url, sizeof url, op->id, "");
        cJSON_AddStringToObject(o, "status_url", url);
        api_jobs_url(url, sizeof url, op->id, "/image.png");
        cJSON_AddStringToObject(o, "image_url", url);
        if (op->exr) {
            api_jobs_url(url, sizeof url, op->id, "/image.exr");
            cJSON_AddStringToObject(o, "exr_url", url);
        }
        api_jobs_url(url, sizeof url, op->id, "/events");
        cJSON_AddStringToObject(o, "events_url", url);
        if (op->denoise) cJSON_AddTrueToObject(o, "denoise");
        api_jobs_add_estimate(o, &a->price);
        api_jobs_reply_accepted(a->r, o, op->id, a->unlit, &a->price);
        return;
    }
    api_jobs_url(url, sizeof url, op->id, "");
    cJSON_AddStringToObject(o, "status_url", url);
    api_jobs_url(url, sizeof url, op->id, "/events");
    cJSON_AddStringToObject(o, "events_url", url);
    api_jobs_reply_accepted(a->r, o, op->id, a->unlit, &a->price);
}

/* What a cluster's progressive job cannot keep (its passes are the
 * light's PNGs); true after a 400 naming it. */
static bool api_cluster_plan_refused(struct http_req *r, const struct work_target *what) {
    const char *name = what->keep_exr  ? "format"
                       : what->aov     ? "aov"
                       : what->denoise ? "denoise"
                                       : NULL;
    if (!name) return false;
    char why[300];
    snprintf(why, sizeof why,
             "a cluster (rayd --redis) keeps a progressive job's passes as PNGs of the light "
             "alone, so not with %s: leave progressive=1 out, or %s out (denoise=0 when the "
             "scene asks for it)",
             name, name);
    api_bad_param(r, "progressive", why); /* the page then posts it as a plain job */
    return true;
}

/* A progressive job's plan into op; false after replying. */
static bool api_cluster_plan(struct http_req *r, struct cache_entry *e,
                             const struct work_target *what, const struct jobs_plan *plan,
                             struct cluster_op *op) {
    if (!plan) return true;
    if (api_cluster_plan_refused(r, what)) return false;
    struct rayd_scene_info info;
    rayd_scene_info(cache_scene(e), &info);
    op->progressive = true;
    op->plan = *plan;
    op->npasses = passes_plan(plan, info.samples, op->samples); /* checked: api_plan */
    return op->npasses > 0;
}

bool api_cluster_submit(struct http_req *r, struct cache_entry *e, const struct work_target *what,
                        int priority, const struct api_price *one, bool animated,
                        const struct jobs_plan *plan) {
    struct api_cluster *a = api_cluster_new(r, CO_SUBMIT, NULL, api_cluster_accepted);
    if (!a) return false;
    struct cluster_op *op = &a->op;
    if (animated && http_req_query(r, "progressive")) { /* as one node refuses it */
        free(a);
        return api_bad_param(r, "progressive", "a frame-range job is not progressive");
    }
    if (!api_cluster_plan(r, e, what, plan, op)) {
        free(a);
        return false;
    }
    if (animated) {
        struct rayd_animation an;
        rayd_scene_animation(cache_scene(e), &an);
        if (!api_shots_frames(r, cache_scene(e), &op->first, &op->last)) {
            free(a);
            return false;
        }
        op->fps = an.fps;
    }
    long count = op->last - op->first + 1, n = config.cluster_tile;
    long items = count * ((what->reg.w + n - 1) / n) * ((what->reg.h + n - 1) / n);
    if (items > CLUSTER_MAX_ITEMS) {
        char msg[300];
        snprintf(msg, sizeof msg,
                 "%ld work items (%ld frame(s) in tiles of %ld px, --cluster-tile) is more than "
                 "the %ld a cluster job may make: ask fewer frames, a smaller region, or start "
                 "the nodes with a larger --cluster-tile",
                 items, count, n, CLUSTER_MAX_ITEMS);
        http_reply_error(r, 413, "too_large", msg, NULL, 0, 0, NULL);
        free(a);
        return false;
    }
    size_t need = cluster_assemble_bytes(what->reg.w, what->reg.h, n, what->keep_exr, what->aov);
    if (plan) need = cluster_passes_bytes(what->reg.w, what->reg.h, n);
    if (need > mem_limit()) {
        /* a frame this node could never assemble: as one node refuses a render over it */
        metrics_reject(MR_MEMORY);
        api_refused(r, WORK_TOO_BIG);
        free(a);
        return false;
    }
    a->price = (struct api_price){one->rays * (double)count, one->seconds * (double)count};
    a->unlit = api_unlit(cache_scene(e));
    http_req_query_each(r, api_cluster_query_add, &a->query);
    op->scene = r->body ? r->body : "";
    op->scene_len = r->body_len;
    snprintf(op->scene_id, sizeof op->scene_id, "%s", cache_id(e));
    op->query = a->query;
    op->reg = what->reg;
    op->priority = priority;
    op->client = what->client;
    op->animated = animated;
    op->denoise = what->denoise;
    op->exr = what->keep_exr;
    op->aov = what->aov;
    op->est_rays = a->price.rays;
    return api_cluster_go(a);
}

/* ---- GET and DELETE /v1/jobs/{id}, POST stop ----------------------------------------- */

static void api_cluster_status(struct api_cluster *a) {
    struct cluster_op *op = &a->op;
    snprintf(a->r->res.scene, sizeof a->r->res.scene, "%s", op->info.job.scene_id);
    if (op->not_progressive) { /* the single node's answers */
        http_reply_error(a->r, 409, "not_progressive",
                         op->is_animated
                             ? "a frame-range job cannot be stopped and kept; DELETE cancels it"
                             : "only a progressive job can be stopped and kept; DELETE cancels "
                               "a job",
                         NULL, 0, 0, NULL);
        return;
    }
    http_reply_json(a->r, 200, api_cluster_json(op->id, &op->info, op->is_animated));
}

/* The job route of id as kind; false when id is not a job id (404). */
static void api_cluster_job(struct http_req *r, const char *id, enum cluster_op_kind kind,
                            void (*answer)(struct api_cluster *)) {
    if (!api_only_params(r, NULL)) return;
    if (!api_is_hex(id, 32)) {
        api_jobs_unknown(r);
        return;
    }
    struct api_cluster *a = api_cluster_new(r, kind, id, answer);
    if (a) api_cluster_go(a);
}

void api_cluster_get(struct http_req *r, const char *id) {
    api_cluster_job(r, id, CO_GET, api_cluster_status);
}
void api_cluster_delete(struct http_req *r, const char *id) {
    api_cluster_job(r, id, CO_CANCEL, api_cluster_status);
}
void api_cluster_stop(struct http_req *r, const char *id) {
    api_cluster_job(r, id, CO_STOP, api_cluster_status);
}

/* ---- the images ---------------------------------------------------------------------- */

/* A frame's PNG, or its EXR. */
static void api_cluster_png(struct http_req *r, struct blob *png, bool exr) {
    http_reply_image(r, 200, png, api_format_type(exr ? WORK_EXR : WORK_PNG));
    http_reply_header(r, "Cache-Control", "private, max-age=3600");
}

/* ?pass= refused for this job, as one node refuses it; true after a 400. */
static bool api_cluster_pass_refused(struct api_cluster *a) {
    const struct jobs_info *j = &a->op.info.job;
    char range[80];
    snprintf(range, sizeof range, "must be a pass number of this job, 1..%d", j->passes.total);
    if (!j->progressive)
        return api_bad_param(a->r, "pass", "only a progressive job has passes"), true;
    if (a->op.pass < 1 || a->op.pass > j->passes.total)
        return api_bad_param(a->r, "pass", range), true;
    return false;
}

/* A progressive job's pass image: that pass's (?pass=K) or the latest,
 * while the job runs too. */
static void api_cluster_pass_answer(struct api_cluster *a) {
    struct cluster_op *op = &a->op;
    const struct jobs_info *j = &op->info.job;
    long k = op->pass ? op->pass : j->passes.done;
    if (op->png) {
        bool final = !op->pass && j->state != JS_SUCCEEDED;
        http_reply_image(a->r, 200, op->png, api_format_type(WORK_PNG));
        http_reply_header(a->r, "Cache-Control", final ? "no-store" : "private, max-age=3600");
        api_jobs_pass_headers(a->r, (int)k, j->passes.total, op->pass_samples);
    } else if (op->pass && k <= j->passes.done) {
        http_reply_error(a->r, 410, "pass_gone",
                         "that pass's image is no longer kept (only the latest passes are)", NULL,
                         0, 0, "pass");
    } else {
        http_reply_json(a->r, 202, api_cluster_json(op->id, &op->info, false));
        http_reply_header(a->r, "Retry-After", "1");
    }
}

/* image.png (or .exr) of a still job. */
static void api_cluster_image_answer(struct api_cluster *a) {
    struct cluster_op *op = &a->op;
    struct http_req *r = a->r;
    const struct jobs_info *j = &op->info.job;
    snprintf(r->res.scene, sizeof r->res.scene, "%s", j->scene_id);
    char msg[400];
    if (op->is_animated) {
        http_reply_error(r, 409, "frame_range_job",
                         "this job renders frames: GET /v1/jobs/{id}/frames/{k}.png", NULL, 0, 0,
                         NULL);
    } else if (a->pass && api_cluster_pass_refused(a)) {
        /* replied */
    } else if (a->exr && !j->keep_exr) {
        http_reply_error(r, 409, "not_exr",
                         "this job keeps no EXR: create it with POST /v1/jobs?format=exr (its "
                         "PNG is image.png)",
                         NULL, 0, 0, NULL);
    } else if (j->progressive &&
               (a->pass || op->png || j->state == JS_RUNNING || j->state == JS_QUEUED)) {
        api_cluster_pass_answer(a);
    } else if (j->state == JS_SUCCEEDED && op->png) {
        api_cluster_png(r, op->png, a->exr);
    } else if (j->state == JS_SUCCEEDED) {
        http_reply_error(r, 410, "result_evicted",
                         "the job succeeded but its image is no longer in Redis (evicted by "
                         "Redis's maxmemory, or deleted): render it again",
                         NULL, 0, 0, NULL);
    } else if (j->state == JS_FAILED) {
        snprintf(msg, sizeof msg, "the job failed: %s", j->err.message);
        http_reply_error(r, 409, "job_failed", msg, j->err.path, 0, 0, NULL);
    } else if (j->state == JS_CANCELED) {
        http_reply_error(r, 409, "job_canceled", "the job was cancelled", NULL, 0, 0, NULL);
    } else {
        http_reply_json(r, 202, api_cluster_json(op->id, &op->info, false));
        http_reply_header(r, "Retry-After", "1");
    }
}

static void api_cluster_image_as(struct http_req *r, const char *id, bool exr) {
    static const char *const takes[] = {"pass", NULL};
    const char *pass = http_req_query(r, "pass");
    if (!api_only_params(r, takes)) return;
    if (http_req_query_count(r, "pass") > 1) {
        api_bad_param(r, "pass", "given more than once");
        return;
    }
    if (!api_is_hex(id, 32)) {
        api_jobs_unknown(r);
        return;
    }
    struct api_cluster *a = api_cluster_new(r, CO_IMAGE, id, api_cluster_image_answer);
    if (!a) return;
    a->exr = a->op.exr = exr;
    a->pass = pass;
    if (pass) /* checked against the job's passes in the answer: -1 is none of them */
        a->op.pass = api_is_decimal(pass, false) && strlen(pass) < 6 ? strtol(pass, NULL, 10) : -1;
    api_cluster_go(a);
}

void api_cluster_image(struct http_req *r, const char *id) { api_cluster_image_as(r, id, false); }
void api_cluster_exr(struct http_req *r, const char *id) { api_cluster_image_as(r, id, true); }

/* frames/{k}.png of a frame-range job. */
static void api_cluster_frame_answer(struct api_cluster *a) {
    struct cluster_op *op = &a->op;
    struct http_req *r = a->r;
    const struct shots_info *in = &op->info;
    char msg[320];
    snprintf(r->res.scene, sizeof r->res.scene, "%s", in->job.scene_id);
    if (!op->is_animated) {
        http_reply_error(r, 404, "frame_unknown",
                         "this job renders one image (image.png), not a frame range", NULL, 0, 0,
                         NULL);
    } else if (op->frame < in->first || op->frame > in->last) {
        snprintf(msg, sizeof msg, "frame %ld is not one of this job's frames %ld-%ld", op->frame,
                 in->first, in->last);
        http_reply_error(r, 404, "frame_unknown", msg, NULL, 0, 0, NULL);
    } else if (a->exr && !in->job.keep_exr) {
        http_reply_error(r, 409, "not_exr",
                         "this job keeps no EXR: create it with POST /v1/jobs?format=exr", NULL, 0,
                         0, NULL);
    } else if (op->png) {
        api_cluster_png(r, op->png, a->exr);
    } else { /* as a single node says it (the cluster keeps no frame's state) */
        api_shots_not_ready(r, op->frame, SHOTS_QUEUED, in);
    }
}

void api_cluster_frame(struct http_req *r, const char *path) {
    char id[33];
    long k = 0;
    bool exr = false;
    if (!cluster_on()) {
        api_shots_frame(r, path);
        return;
    }
    if (!api_only_params(r, NULL) || !api_shots_frame_path(r, path, id, &k, &exr)) return;
    struct api_cluster *a = api_cluster_new(r, CO_IMAGE, id, api_cluster_frame_answer);
    if (!a) return;
    a->op.frame = k;
    a->exr = a->op.exr = exr;
    api_cluster_go(a);
}

/* video.mp4 of a frame-range job: the single node's answers. */
static void api_cluster_video_answer(struct api_cluster *a) {
    struct cluster_op *op = &a->op;
    struct http_req *r = a->r;
    const struct shots_info *in = &op->info;
    snprintf(r->res.scene, sizeof r->res.scene, "%s", in->job.scene_id);
    if (!op->is_animated) { /* as one node answers */
        http_reply_error(r, 404, "frame_unknown",
                         "this job renders one image (image.png), not a frame range: it has no "
                         "video",
                         NULL, 0, 0, NULL);
    } else if (op->png) {
        http_reply_image(r, 200, op->png, "video/mp4");
        http_reply_header(r, "Cache-Control", "private, max-age=3600");
    } else if (in->done < in->total) {
        api_shots_no_video(r, in);
    } else if (in->video == SV_NO_FFMPEG) {
        http_reply_error(r, 503, "no_ffmpeg", in->video_error, NULL, 0, 0, NULL);
    } else if (in->video == SV_FAILED) {
        http_reply_error(r, 500, "video_failed", in->video_error, NULL, 0, 0, NULL);
    } else if (in->video == SV_READY) {
        http_reply_error(r, 410, "result_evicted",
                         "the video was made but is no longer in Redis (evicted by Redis's "
                         "maxmemory, or deleted)",
                         NULL, 0, 0, NULL);
    } else {
        http_reply_json(r, 202, api_cluster_json(op->id, in, true));
        http_reply_header(r, "Retry-After", "1");
    }
}

void api_cluster_video(struct http_req *r, const char *id) {
    if (!cluster_on()) {
        api_shots_video(r, id);
        return;
    }
    if (!api_only_params(r, NULL)) return;
    if (!api_is_hex(id, 32)) {
        api_jobs_missing(r, id);
        return;
    }
    struct api_cluster *a = api_cluster_new(r, CO_VIDEO, id, api_cluster_video_answer);
    if (a) api_cluster_go(a);
}

/* ---- GET /v1/jobs ---------------------------------------------------------------------- */

static void api_cluster_list_answer(struct api_cluster *a) {
    struct cluster_op *op = &a->op;
    cJSON *o = cJSON_CreateObject();
    cJSON *list = cJSON_AddArrayToObject(o, "jobs");
    for (int i = 0; i < op->nrows; i++)
        cJSON_AddItemToArray(
            list, api_cluster_json(op->rows[i].job.id, &op->rows[i], op->row_animated[i]));
    if (op->more && op->nrows > 0) {
        char cursor[24], url[200];
        snprintf(cursor, sizeof cursor, "%lld", op->rows[op->nrows - 1].job.seq);
        cJSON_AddStringToObject(o, "next_after", cursor);
        int k = snprintf(url, sizeof url, "/v1/jobs?limit=%d&after=%s", op->limit, cursor);
        if (op->state >= 0 && k > 0 && (size_t)k < sizeof url)
            snprintf(url + k, sizeof url - (size_t)k, "&state=%s",
                     jobs_state_name((enum jobs_state)op->state));
        cJSON_AddStringToObject(o, "next_url", url);
    } else {
        cJSON_AddNullToObject(o, "next_after");
        cJSON_AddNullToObject(o, "next_url");
    }
    http_reply_json(a->r, 200, o);
    http_reply_header(a->r, "Cache-Control", "no-store");
}

void api_cluster_list(struct http_req *r, long long limit, long long after, int state) {
    struct api_cluster *a = api_cluster_new(r, CO_LIST, NULL, api_cluster_list_answer);
    if (!a) return;
    a->op.rows = calloc((size_t)limit, sizeof *a->op.rows);
    a->op.row_animated = calloc((size_t)limit, sizeof *a->op.row_animated);
    if (!a->op.rows || !a->op.row_animated) {
        free(a->op.rows);
        free(a->op.row_animated);
        free(a);
        api_refused(r, WORK_NOMEM);
        return;
    }
    a->op.limit = (int)limit;
    a->op.after = after;
    a->op.state = state;
    a->op.client = api_cost_client(r);
    api_cluster_go(a);
}
