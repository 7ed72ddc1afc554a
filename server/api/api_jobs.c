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
#include "cluster/cluster.h"

#include <cjson/cJSON.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* ---- a progressive job's query ----------------------------------------------- */

static const char *const api_plan_names[] = {"progressive", "pass_step", "time_budget",
                                             "noise_target", NULL};
/* What POST /v1/jobs takes besides the region. */
static const char *const api_jobs_names[] = {
    "progressive", "pass_step", "time_budget", "noise_target", "format", "priority",
    "frames",      "frame",     "denoise",     "aov",          NULL};

/* A decimal number in (0, max] from ?name=, if given: digits and a point
 * only (api_is_decimal), so 0x10, 1e3, inf and " 5" are refused. */
static bool api_plan_number(struct http_req *r, const char *name, double max, double *out) {
    const char *v = http_req_query(r, name);
    if (!v) return true;
    double x = strtod(v, NULL);
    if (!api_is_decimal(v, true) || !(x > 0 && x <= max)) {
        char why[100];
        snprintf(why, sizeof why, "must be a decimal number above 0 and at most %.10g", max);
        return api_bad_param(r, name, why);
    }
    *out = x;
    return true;
}

/* ?progressive=1 and its options into *plan, its pass count into
 * *passes; *progressive false (and *passes 0) without it.  Replies 400 and
 * returns false on a bad one. */
static bool api_plan(struct http_req *r, const rayd_scene *scene, struct jobs_plan *plan,
                     bool *progressive, int *passes) {
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
    if (!api_plan_number(r, "pass_step", 1048576, &step) || /* rayd-render's --pass-step too */
        !api_plan_number(r, "time_budget", 86400, &plan->time_budget) ||
        !api_plan_number(r, "noise_target", 1, &plan->noise_target))
        return false;
    if (step != (int)step)
        return api_bad_param(r, "pass_step", "must be a whole number of samples");
    plan->step = (int)step;
    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    int samples[PASSES_MAX];
    *passes = *progressive ? passes_plan(plan, info.samples, samples) : 0;
    if (*passes < 0) {
        char why[120];
        snprintf(why, sizeof why, "%d samples in steps of %d is more than %d passes", info.samples,
                 plan->step, PASSES_MAX);
        return api_bad_param(r, "pass_step", why);
    }
    return true;
}

/* An animated scene's job is a frame-range job, never progressive: each
 * of the progressive options is refused, naming it, rather than ignored
 * (pass_step=2 on its own used to be taken and dropped). */
static bool api_plan_none(struct http_req *r) {
    for (int i = 0; api_plan_names[i]; i++)
        if (http_req_query(r, api_plan_names[i]))
            return api_bad_param(r, api_plan_names[i], "a frame-range job is not progressive");
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

/* ?denoise=0|1 (default: the scene's render.denoise) and ?aov= into what
 * (format already read): with format=exr the EXR's AOV channels (the
 * scene's render.aov without it) beside the PNG of the light, else the
 * one AOV the PNG shows, as POST /v1/render takes them. */
static bool api_jobs_denoise_aov(struct http_req *r, const rayd_scene *scene,
                                 struct work_target *what) {
    return api_denoise_param(r, scene, http_req_query(r, "denoise"),
                             http_req_query_count(r, "denoise"), &what->denoise) &&
           api_aov_param(r, scene, http_req_query(r, "aov"), http_req_query_count(r, "aov"),
                         what->keep_exr, &what->aov);
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
    bool denoise; /* ?denoise=1 or the scene's: the 202 says so */
    bool unlit;   /* its scene gives no light: the 202 warns */
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
    api_jobs_url(url, sizeof url, a->id, "");
    cJSON_AddStringToObject(o, "status_url", url);
    api_jobs_url(url, sizeof url, a->id, "/image.png");
    cJSON_AddStringToObject(o, "image_url", url);
    if (a->keep_exr) {
        api_jobs_url(url, sizeof url, a->id, "/image.exr");
        cJSON_AddStringToObject(o, "exr_url", url);
    }
    api_jobs_url(url, sizeof url, a->id, "/events");
    cJSON_AddStringToObject(o, "events_url", url);
    if (a->denoise) cJSON_AddTrueToObject(o, "denoise");
    api_jobs_add_estimate(o, &a->price);
    api_jobs_reply_accepted(r, o, a->id, a->unlit, &a->price);
}

/* The store thread's word (--data-dir): the job is on disk, or could not
 * be recorded (then it is cancelled: a job rayd cannot keep is not taken). */
static void api_jobs_recorded(struct work_waiter *w, struct work_result *res) {
    struct api_jobs_wait *a = (struct api_jobs_wait *)w;
    if (res->status == RAYD_OK) {
        api_jobs_accepted(a);
    } else {
        jobs_cancel(a->id, NULL, NULL);
        api_jobs_reply_store_failed(a->r, res->err.message);
    }
    http_req_resume(a->r);
    free(a);
}

static void api_jobs_recorded_suspend(struct work_waiter *w) {
    api_suspend(((struct api_jobs_wait *)w)->r);
}

static bool api_jobs_checked(struct http_req *r, struct cache_entry *e, bool hit);

/* The check of every frame's keyframed values costs about what the
 * frames' parses spend on them (rayd_scene_info.frame_work): a range
 * whose frames' parse work is over this many rays' worth (about 2 s on a
 * parse thread) is not checked first, but frame by frame as it renders,
 * as before the check: 1000 frames of a 4 MB scene took 85 s. */
#define API_JOBS_CHECK_WORK 2e7

/* The frames' check (api_scene_check_frames), after the refusals that
 * cost nothing (a full table, the client's share, a drain); true when r
 * was handed on. */
static bool api_jobs_check_frames(struct http_req *r, struct cache_entry *e, uint64_t client) {
    long first, last;
    if (!api_shots_frames(r, cache_scene(e), &first, &last)) return false;
    enum work_submit room = jobs_room(client);
    if (room != WORK_OK) {
        api_refused(r, room);
        return false;
    }
    struct rayd_scene_info info;
    rayd_scene_info(cache_scene(e), &info);
    if ((double)(last - first + 1) * info.frame_work > API_JOBS_CHECK_WORK)
        return api_jobs_checked(r, e, false);
    return api_scene_check_frames(r, e, first, last, api_jobs_checked);
}

/* POST /v1/jobs once its scene is compiled (api_scene's continuation) and,
 * for a frame-range job, its frames checked (checked); true when the
 * request waits for the check or the store (which resume it). */
static bool api_jobs_admit(struct http_req *r, struct cache_entry *e, bool checked) {
    bool progressive = false;
    struct work_target what = {.format = WORK_PNG};
    struct jobs_plan plan;
    struct api_price price;
    struct jobs_new how = {.scene = r->body ? r->body : "", .scene_len = r->body_len};
    int shot = api_shots_wanted(r, cache_scene(e));
    what.frame = shot == 1;
    if (shot < 0 || !api_region_also(r, cache_scene(e), &what.reg, api_jobs_names) ||
        !(shot ? api_plan_none(r)
               : api_plan(r, cache_scene(e), &plan, &progressive, &what.passes)) ||
        !api_jobs_format(r, &what) || !api_jobs_denoise_aov(r, cache_scene(e), &what) ||
        !api_jobs_priority(r, &how.priority) || !api_cost_admit(r, e, &what, progressive, &price))
        return false;     /* replied */
    if (shot && !checked) /* a frame that would fail later fails the POST, before any renders */
        return api_jobs_check_frames(r, e, what.client);
    if (cluster_on()) /* rayd --redis: the job is the cluster's (api_cluster.c) */
        return api_cluster_submit(r, e, &what, how.priority, &price, shot == 1,
                                  progressive ? &plan : NULL);
    if (shot) /* an animated scene: a frame-range job (api_shots.c) */
        return api_shots_submit(r, e, &what, how.priority, &price);
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
    a->denoise = what.denoise;
    a->unlit = api_unlit(cache_scene(e));
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

static bool api_jobs_compiled(struct http_req *r, struct cache_entry *e, bool hit) {
    (void)hit;
    return api_jobs_admit(r, e, false);
}

static bool api_jobs_checked(struct http_req *r, struct cache_entry *e, bool hit) {
    (void)hit;
    return api_jobs_admit(r, e, true);
}

void api_jobs_post(struct http_req *r, const char *unused) {
    (void)unused;
    api_scene(r, api_jobs_compiled);
}

/* A frame-range job's JSON (200), if id is one; true when it replied. */
static bool api_jobs_shot(struct http_req *r, const char *id) {
    struct shots_info s;
    if (!api_is_hex(id, 32) || !shots_get(id, &s)) return false;
    api_jobs_scene(r, &s.job);
    http_reply_json(r, 200, api_shots_json(id, &s));
    return true;
}

void api_jobs_get(struct http_req *r, const char *id) {
    struct jobs_info info;
    if (cluster_on()) {
        api_cluster_get(r, id);
        return;
    }
    if (!api_only_params(r, NULL) || api_jobs_shot(r, id)) return;
    if (!api_is_hex(id, 32) || !jobs_get(id, &info, JOBS_NUMBERS)) {
        api_jobs_missing(r, id);
        return;
    }
    if (api_jobs_evicted(r, id, &info)) return;
    api_jobs_scene(r, &info);
    http_reply_json(r, 200, api_jobs_json(id, &info));
}

/* DELETE's answer: the job as it is now (a frame-range job's, or one's). */
static void api_jobs_delete_reply(struct http_req *r, const char *id) {
    struct jobs_info info;
    if (api_jobs_shot(r, id)) return;
    if (!api_is_hex(id, 32) || !jobs_get(id, &info, JOBS_NUMBERS)) {
        api_jobs_missing(r, id);
        return;
    }
    if (api_jobs_evicted(r, id, &info)) return;
    api_jobs_scene(r, &info);
    http_reply_json(r, 200, api_jobs_json(id, &info));
}

/* A DELETE waiting for its job's end to be on disk (--data-dir): a 200
 * that a kill just after could undo -- the job back, queued, after the
 * restart -- is not given. */
struct api_jobs_del {
    struct work_waiter w; /* first: the store's handle on it */
    struct http_req *r;
    char id[33];
};

static void api_jobs_deleted(struct work_waiter *w, struct work_result *res) {
    struct api_jobs_del *g = (struct api_jobs_del *)w;
    if (res->status == RAYD_OK) /* else cancelled here, but a restart could bring it back */
        api_jobs_delete_reply(g->r, g->id);
    else
        api_jobs_reply_store_failed(g->r, res->err.message);
    http_req_resume(g->r);
    free(g);
}

static void api_jobs_deleted_suspend(struct work_waiter *w) {
    api_suspend(((struct api_jobs_del *)w)->r);
}

void api_jobs_delete(struct http_req *r, const char *id) {
    if (cluster_on()) {
        api_cluster_delete(r, id);
        return;
    }
    if (!api_only_params(r, NULL)) return;
    /* not while rayd drains: its listener stops with no request suspended
     * (the drain writes the end before it exits) */
    bool waits = api_is_hex(id, 32) && store_on() && !sched_draining();
    struct api_jobs_del *g = waits ? calloc(1, sizeof *g) : NULL;
    if (g) {
        g->r = r;
        g->w = (struct work_waiter){
            .done = api_jobs_deleted, .suspend = api_jobs_deleted_suspend, .fd = -1};
        snprintf(g->id, sizeof g->id, "%s", id);
    }
    bool waiting = false;
    if (api_is_hex(id, 32) && !shots_cancel(id, g ? &g->w : NULL, &waiting))
        jobs_cancel(id, g ? &g->w : NULL, &waiting);
    if (waiting) return; /* g is the store's until done() */
    free(g);
    api_jobs_delete_reply(r, id);
}

void api_jobs_stop(struct http_req *r, const char *id) {
    struct jobs_info info;
    bool progressive = false;
    struct shots_info s;
    if (cluster_on()) {
        api_cluster_stop(r, id);
        return;
    }
    if (!api_only_params(r, NULL)) return;
    if (api_is_hex(id, 32) && shots_get(id, &s)) {
        http_reply_error(r, 409, "not_progressive",
                         "a frame-range job cannot be stopped and kept; DELETE cancels it", NULL, 0,
                         0, NULL);
        return;
    }
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
    if (cluster_on()) {
        api_cluster_list(r, limit, after, state);
        return;
    }
    struct jobs_info *rows = calloc((size_t)limit, sizeof *rows);
    struct shots_info *shots = calloc((size_t)limit, sizeof *shots);
    if (!rows || !shots) {
        free(rows);
        free(shots);
        api_refused(r, WORK_NOMEM);
        return;
    }
    bool more = false, more_shots = false;
    uint64_t client = api_cost_client(r);
    int nj = jobs_list(client, state, after, rows, (int)limit, &more);
    int ns = shots_list(client, state, after, shots, (int)limit, &more_shots);
    cJSON *o = cJSON_CreateObject();
    cJSON *list = cJSON_AddArrayToObject(o, "jobs");
    int n = 0, a = 0, b = 0; /* both newest first: merged by creation number */
    long long last = 0;
    while (n < limit && (a < nj || b < ns)) {
        bool job = b >= ns || (a < nj && rows[a].seq > shots[b].job.seq);
        cJSON_AddItemToArray(list, job ? api_jobs_json(rows[a].id, &rows[a])
                                       : api_shots_json(shots[b].job.id, &shots[b]));
        last = job ? rows[a++].seq : shots[b++].job.seq;
        n++;
    }
    more = more || more_shots || a < nj || b < ns;
    if (more && n > 0) {
        char cursor[24], url[200];
        snprintf(cursor, sizeof cursor, "%lld", last);
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
    free(shots);
    http_reply_json(r, 200, o);
}
