/* api_shots.c -- frame-range jobs over HTTP: POST /v1/jobs of an animated
 * scene (?frames=A-B, ?frame=K, else every frame), their JSON, GET
 * /v1/jobs/{id}/frames/{k}.png (and .exr), GET /v1/jobs/{id}/video.mp4.
 *
 * A frame-range job is a job to the client: the same id form, the same
 * routes (status, list, events, DELETE), the job's JSON with a "frames"
 * object, "eta_s" and, once every frame is done, "video_url".  The work is
 * shots.c's; this file only reads the query and writes JSON and images.  A
 * scene without an animation block never gets here: its job is the
 * single-image job of api_jobs.c, unchanged.
 */
#include "api/api.h"

#include <cjson/cJSON.h>
#include <stdlib.h>
#include <string.h>

/* One frame number, digits only (a leading '-' for negatives), into *k. */
static bool api_shots_number(const char *s, size_t n, long *k) {
    if (n == 0 || n > 18) return false; /* any long: a frame past the range is 404 */
    size_t i = s[0] == '-' ? 1 : 0;
    if (i == n) return false;
    for (size_t j = i; j < n; j++)
        if (s[j] < '0' || s[j] > '9') return false;
    char buf[24];
    memcpy(buf, s, n);
    buf[n] = 0;
    *k = strtol(buf, NULL, 10);
    return true;
}

/* ?frames=A-B or ?frame=K into first..last, within the animation's frames
 * and at most --max-frames of them; the whole animation without either.
 * 400 naming the parameter and false on a bad one. */
static bool api_shots_range(struct http_req *r, const struct rayd_animation *an, long *first,
                            long *last) {
    const char *range = http_req_query(r, "frames"), *one = http_req_query(r, "frame");
    const char *name = range ? "frames" : "frame";
    char why[200];
    if (http_req_query_count(r, "frames") > 1 || http_req_query_count(r, "frame") > 1)
        return api_bad_param(r, name, "given more than once");
    if (range && one) return api_bad_param(r, "frame", "give frames=A-B or frame=K, not both");
    *first = an->start;
    *last = an->end;
    if (range) { /* A-B, or K alone as rayd-render's --frames takes it */
        const char *dash = range[0] ? strchr(range + 1, '-') : NULL;
        size_t n = dash ? (size_t)(dash - range) : strlen(range);
        if (!api_shots_number(range, n, first) ||
            (dash && !api_shots_number(dash + 1, strlen(dash + 1), last)))
            return api_bad_param(r, "frames",
                                 "must be A-B, two frame numbers (frames=0-47), or one (frames=5)");
        if (!dash) *last = *first;
        if (*first > *last) return api_bad_param(r, "frames", "the first frame is after the last");
    } else if (one) {
        if (!api_shots_number(one, strlen(one), first))
            return api_bad_param(r, "frame", "must be a frame number (frame=12)");
        *last = *first;
    }
    if (*first < an->start || *last > an->end) {
        snprintf(why, sizeof why, "outside the scene's frames %ld-%ld", an->start, an->end);
        return api_bad_param(r, name, why);
    }
    if (*last - *first + 1 > config.max_frames && !range && !one) { /* the whole animation */
        snprintf(why, sizeof why,
                 "the animation has %ld frames, more than the %ld a job may render "
                 "(--max-frames): ask for some of them with frames=A-B",
                 *last - *first + 1, config.max_frames);
        http_reply_error(r, 400, "bad_parameter", why, "/animation", 0, 0, NULL);
        return false;
    }
    if (*last - *first + 1 > config.max_frames) {
        snprintf(why, sizeof why, "%ld frames is more than the %ld a job may render (--max-frames)",
                 *last - *first + 1, config.max_frames);
        return api_bad_param(r, name, why);
    }
    return true;
}

bool api_shots_frames(struct http_req *r, const rayd_scene *scene, long *first, long *last) {
    struct rayd_animation an;
    rayd_scene_animation(scene, &an);
    return api_shots_range(r, &an, first, last);
}

int api_shots_wanted(struct http_req *r, const rayd_scene *scene) {
    struct rayd_animation an;
    rayd_scene_animation(scene, &an);
    if (an.animated) return 1;
    const char *name = http_req_query(r, "frames") ? "frames" : "frame";
    if (!http_req_query(r, name)) return 0;
    api_bad_param(r, name, "the scene has no animation block: it is one frame, a plain job");
    return -1;
}

/* The "frames" object, "eta_s" and "video_url" added to a job's JSON. */
static void api_shots_add(cJSON *o, const char *id, const struct shots_info *in) {
    char url[120];
    cJSON_DeleteItemFromObject(o, "image_url");
    cJSON_DeleteItemFromObject(o, "exr_url");
    cJSON *f = cJSON_AddObjectToObject(o, "frames");
    cJSON_AddNumberToObject(f, "first", (double)in->first);
    cJSON_AddNumberToObject(f, "last", (double)in->last);
    cJSON_AddNumberToObject(f, "total", (double)in->total);
    cJSON_AddNumberToObject(f, "done", (double)in->done);
    cJSON_AddNumberToObject(f, "running", (double)in->running);
    cJSON_AddNumberToObject(f, "queued", (double)in->queued);
    cJSON_AddNumberToObject(f, "failed", (double)in->failed);
    if (in->latest >= 0)
        cJSON_AddNumberToObject(f, "latest", (double)in->latest);
    else
        cJSON_AddNullToObject(f, "latest");
    api_jobs_url(url, sizeof url, id, "/frames/{k}.png");
    cJSON_AddStringToObject(f, "url", url);
    if (in->job.keep_exr) {
        api_jobs_url(url, sizeof url, id, "/frames/{k}.exr");
        cJSON_AddStringToObject(f, "exr_url", url);
    }
    if (in->eta_s >= 0)
        json_add_fixed(o, "eta_s", in->eta_s, 3);
    else
        cJSON_AddNullToObject(o, "eta_s");
    if (in->done == in->total && in->video != SV_EVICTED) {
        api_jobs_url(url, sizeof url, id, "/video.mp4");
        cJSON_AddStringToObject(o, "video_url", url);
    }
}

cJSON *api_shots_json(const char *id, const struct shots_info *in) {
    cJSON *o = api_jobs_json(id, &in->job);
    api_shots_add(o, id, in);
    return o;
}

/* What the 202 of a new frame-range job needs, kept until it is sent (at
 * once, or once the job is on disk: --data-dir). */
struct api_shots_wait {
    struct work_waiter w;
    struct http_req *r;
    char id[33];
    bool unlit; /* its scene gives no light: the 202 warns */
    struct api_price price;
};

/* 202: the job's JSON and where to follow it. */
static void api_shots_accepted(struct api_shots_wait *a) {
    struct http_req *r = a->r;
    struct shots_info info;
    if (!shots_get(a->id, &info)) {
        api_refused(r, WORK_NOMEM);
        return;
    }
    cJSON *o = api_shots_json(a->id, &info);
    char url[80];
    api_jobs_url(url, sizeof url, a->id, "");
    cJSON_AddStringToObject(o, "status_url", url);
    api_jobs_url(url, sizeof url, a->id, "/events");
    cJSON_AddStringToObject(o, "events_url", url);
    api_jobs_reply_accepted(r, o, a->id, a->unlit, &a->price);
}

/* The store thread's word (--data-dir): the job is on disk, or could not
 * be recorded (then it is cancelled: a job rayd cannot keep is not taken). */
static void api_shots_recorded(struct work_waiter *w, struct work_result *res) {
    struct api_shots_wait *a = (struct api_shots_wait *)w;
    if (res->status == RAYD_OK) {
        api_shots_accepted(a);
    } else {
        shots_cancel(a->id, NULL, NULL);
        api_jobs_reply_store_failed(a->r, res->err.message);
    }
    http_req_resume(a->r);
    free(a);
}

static void api_shots_recorded_suspend(struct work_waiter *w) {
    api_suspend(((struct api_shots_wait *)w)->r);
}

bool api_shots_submit(struct http_req *r, struct cache_entry *e, struct work_target *what,
                      int priority, const struct api_price *one) {
    struct rayd_animation an;
    rayd_scene_animation(cache_scene(e), &an);
    struct shots_new n = {.text = r->body ? r->body : "",
                          .len = r->body_len,
                          .what = *what,
                          .priority = priority,
                          .fps = an.fps};
    if (http_req_query(r, "progressive")) {
        api_bad_param(r, "progressive", "a frame-range job is not progressive");
        return false;
    }
    if (!api_shots_range(r, &an, &n.first, &n.last)) return false;
    long count = n.last - n.first + 1;
    struct api_shots_wait *a = calloc(1, sizeof *a);
    if (!a) {
        api_refused(r, WORK_NOMEM);
        return false;
    }
    a->r = r;
    a->w.done = api_shots_recorded;
    a->w.suspend = api_shots_recorded_suspend;
    a->w.fd = -1;
    a->price = (struct api_price){one->rays * (double)count, one->seconds * (double)count};
    a->unlit = api_unlit(cache_scene(e));
    n.est_rays = a->price.rays;
    n.scene = e;
    n.w = &a->w;
    snprintf(n.scene_id, sizeof n.scene_id, "%s", cache_id(e));
    enum work_submit s = shots_submit(&n, a->id);
    if (n.waiting) return true; /* a is the store's until done() */
    if (s != WORK_OK)
        api_refused(r, s);
    else
        api_shots_accepted(a);
    free(a);
    return false;
}

/* ---- GET /v1/jobs/{id}/frames/{k}.png and .exr ------------------------------------ */

/* Whether the n bytes at s are k as %ld writes it: one name a frame, so
 * that 7.png, 007.png and -0.png are not three URLs of one image for the
 * caches between rayd and its clients. */
static bool api_shots_canonical(const char *s, size_t n, long k) {
    char buf[24];
    int len = snprintf(buf, sizeof buf, "%ld", k);
    return len > 0 && (size_t)len == n && !memcmp(buf, s, n);
}

/* "JOB/K.png" (the router's two segments) into the job id, k and whether
 * the EXR is asked; false after replying (404 for a malformed job id, 400
 * when K or the suffix is malformed, or K not written as the job's URLs
 * write it). */
bool api_shots_frame_path(struct http_req *r, const char *path, char id[33], long *k, bool *exr) {
    const char *slash = strchr(path, '/');
    size_t n = slash ? (size_t)(slash - path) : 0;
    snprintf(id, 33, "%.*s", (int)(n < 32 ? n : 32), path);
    if (!slash || n != 32 || !api_is_hex(id, 32)) {
        api_jobs_unknown(r);
        return false;
    }
    const char *name = slash + 1, *dot = strrchr(name, '.');
    *exr = dot && !strcmp(dot, ".exr");
    if (!dot || (strcmp(dot, ".png") && !*exr) ||
        !api_shots_number(name, (size_t)(dot - name), k) ||
        !api_shots_canonical(name, (size_t)(dot - name), *k)) {
        http_reply_error(r, 400, "bad_frame",
                         "a frame is /v1/jobs/{id}/frames/{k}.png (or .exr), k a frame number "
                         "in at most 18 digits, without leading zeros",
                         NULL, 0, 0, NULL);
        return false;
    }
    return true;
}

void api_shots_no_video(struct http_req *r, const struct shots_info *info) {
    char msg[300];
    bool ended = info->job.state == JS_FAILED || info->job.state == JS_CANCELED;
    if (ended)
        snprintf(msg, sizeof msg, "the job %s with %ld of %ld frames done: it has no video",
                 info->job.state == JS_CANCELED ? "was cancelled" : "failed", info->done,
                 info->total);
    else
        snprintf(msg, sizeof msg, "the video is made once every frame is done (%ld of %ld)",
                 info->done, info->total);
    http_reply_error(r, 409, "frames_not_done", msg, NULL, 0, 0, NULL);
    if (!ended) http_reply_header(r, "Retry-After", "1");
}

void api_shots_not_ready(struct http_req *r, long k, enum shots_frame_state st,
                         const struct shots_info *info) {
    static const char *const names[] = {"", "", "queued", "running", "done", "failed"};
    bool ended = info->job.state == JS_FAILED || info->job.state == JS_CANCELED;
    /* a frame still rendering may end done though its job was cancelled (a
     * task another waiter shares goes on): it keeps its Retry-After */
    bool never = st == SHOTS_QUEUED && ended;
    char msg[400];
    if (never)
        snprintf(msg, sizeof msg, "frame %ld was not rendered: its job %s%s%.300s", k,
                 info->job.state == JS_CANCELED ? "was cancelled" : "failed",
                 info->job.err.message[0] ? ": " : "", info->job.err.message);
    else
        snprintf(msg, sizeof msg, "frame %ld is %s, not done%s", k, names[st],
                 st == SHOTS_FAILED ? "" : ": retry later");
    cJSON *o = cJSON_CreateObject();
    cJSON *e = cJSON_AddObjectToObject(o, "error");
    cJSON_AddNumberToObject(e, "status", 409);
    cJSON_AddStringToObject(e, "code", "frame_not_ready");
    cJSON_AddStringToObject(e, "message", msg);
    cJSON_AddStringToObject(e, "state", never ? "canceled" : names[st]);
    http_reply_json(r, 409, o);
    if (st != SHOTS_FAILED && !never) http_reply_header(r, "Retry-After", "1");
    r->res.err_code = "frame_not_ready";
}

void api_shots_frame(struct http_req *r, const char *path) {
    char id[33];
    long k = 0;
    bool exr = false;
    if (!api_only_params(r, NULL)) return;
    if (!api_shots_frame_path(r, path, id, &k, &exr)) return;
    struct shots_info info;
    struct blob *img = NULL;
    enum shots_frame_state st = shots_frame(id, k, exr, &img, &info);
    if (st == SHOTS_DONE && !img) /* --max-disk may have let it go since: asked again */
        st = shots_frame(id, k, exr, &img, &info);
    char msg[320];
    if (st == SHOTS_NO_JOB) {
        struct jobs_info j;
        if (jobs_get(id, &j, JOBS_NUMBERS))
            http_reply_error(r, 404, "frame_unknown",
                             "this job renders one image (image.png), not a frame range", NULL, 0,
                             0, NULL);
        else
            api_jobs_missing(r, id);
    } else if (st == SHOTS_OUTSIDE) {
        snprintf(msg, sizeof msg, "frame %ld is not one of this job's frames %ld-%ld", k,
                 info.first, info.last);
        http_reply_error(r, 404, "frame_unknown", msg, NULL, 0, 0, NULL);
    } else if (exr && !info.job.keep_exr) {
        http_reply_error(r, 409, "not_exr",
                         "this job keeps no EXR: create it with POST /v1/jobs?format=exr", NULL, 0,
                         0, NULL);
    } else if (st == SHOTS_EVICTED) {
        snprintf(msg, sizeof msg, "frame %ld: %s", k, info.evicted_why);
        http_reply_error(r, 410, "result_evicted", msg, NULL, 0, 0, NULL);
    } else if (st == SHOTS_DONE && img) {
        http_reply_image(r, 200, img, api_format_type(exr ? WORK_EXR : WORK_PNG));
        http_reply_header(r, "Cache-Control", "private, max-age=3600");
    } else if (st == SHOTS_DONE) { /* its file could not be read: no retry makes it */
        snprintf(msg, sizeof msg,
                 "frame %ld is done, but its file under --data-dir could not be read (the "
                 "server's log says why)",
                 k);
        http_reply_error(r, 500, "internal", msg, NULL, 0, 0, NULL);
    } else {
        api_shots_not_ready(r, k, st, &info);
    }
    blob_unref(img);
}

/* ---- GET /v1/jobs/{id}/video.mp4 ----------------------------------------------------- */

void api_shots_video(struct http_req *r, const char *id) {
    if (!api_only_params(r, NULL)) return;
    if (!api_is_hex(id, 32)) {
        api_jobs_missing(r, id);
        return;
    }
    struct shots_info info;
    struct blob *mp4 = shots_video(id, &info);
    if (!info.job.id[0]) {
        struct jobs_info j; /* a job of one image has no frames to make a video of */
        if (jobs_get(id, &j, JOBS_NUMBERS))
            http_reply_error(r, 404, "frame_unknown",
                             "this job renders one image (image.png), not a frame range: it has "
                             "no video",
                             NULL, 0, 0, NULL);
        else
            api_jobs_missing(r, id);
        return;
    }
    if (mp4) {
        http_reply_image(r, 200, mp4, "video/mp4");
        http_reply_header(r, "Cache-Control", "private, max-age=3600");
        blob_unref(mp4);
    } else if (info.done < info.total) {
        api_shots_no_video(r, &info);
    } else if (info.video == SV_NO_FFMPEG) {
        http_reply_error(r, 503, "no_ffmpeg", info.video_error, NULL, 0, 0, NULL);
    } else if (info.video == SV_EVICTED) {
        http_reply_error(r, 410, "result_evicted", info.video_error, NULL, 0, 0, NULL);
    } else if (info.video == SV_FAILED) {
        http_reply_error(r, 500, "video_failed", info.video_error, NULL, 0, 0, NULL);
    } else {
        http_reply_json(r, 202, api_shots_json(id, &info));
        http_reply_header(r, "Retry-After", "1");
    }
}
