/* api_jobs_image.c -- a job's image: GET /v1/jobs/{id}/image.png and
 * GET /v1/jobs/{id}/image.exr, each the final image or, with ?pass=K, a
 * progressive job's pass K.
 *
 * Both routes answer alike, from the same job: the image once the job
 * succeeded (a progressive job's latest pass while it runs), 202 with the
 * job's JSON while there is none yet, 409 when the job failed or was
 * cancelled, and pass K while it is kept (410 after); 410 too for a job
 * whose image was evicted or that was forgotten (api_jobs.c).  They differ in what
 * they hand out: image.png the 8-bit PNG every job keeps, image.exr the
 * OpenEXR (linear, 32-bit float) that only a job created with
 * POST /v1/jobs?format=exr keeps -- any other job answers 409 not_exr,
 * since its floats were never kept and never will be.  The EXR holds the
 * very floats POST /v1/render?format=exr gives for the same scene and
 * samples (resolve.c), so the route of a kept scene's image and the job's
 * agree byte for byte.  Fewer EXRs than PNGs are kept (PASSES_KEEP_EXR,
 * work.h): the memory a job's EXRs hold stays bounded however many passes
 * a client asks for.
 *
 * image.png?denoise=0 of a denoised progressive job is a pass as rendered,
 * before the filter (passes.c keeps each pass raw beside the denoised
 * one), so a viewer flips between the two without rendering again; a plain
 * denoised job kept no raw image (409 raw_not_kept), and ?denoise=1 of a
 * job that is not denoised names that (409 not_denoised).
 */
#include "api/api.h"
#include "cluster/cluster.h"

#include <stdlib.h>
#include <string.h>

/* 409 not_exr when the EXR is asked of a job that keeps none; true if so. */
static bool api_jobs_no_exr(struct http_req *r, const struct jobs_info *info, bool exr) {
    if (!exr || info->keep_exr) return false;
    http_reply_error(r, 409, "not_exr",
                     "this job keeps no EXR: create it with POST /v1/jobs?format=exr (its PNG is "
                     "image.png)",
                     NULL, 0, 0, NULL);
    return true;
}

/* The image's 200: its type, cache policy and, for a pass, which one. */
static void api_jobs_image_reply(struct http_req *r, struct blob *img, bool exr,
                                 const char *cache) {
    http_reply_image(r, 200, img, api_format_type(exr ? WORK_EXR : WORK_PNG));
    http_reply_header(r, "Cache-Control", cache);
}

/* 202 + Retry-After and the job's JSON: the image is not there yet. */
static void api_jobs_not_yet(struct http_req *r, const char *id, const struct jobs_info *info) {
    http_reply_json(r, 202, api_jobs_json(id, info));
    http_reply_header(r, "Retry-After", "1");
}

/* Why ?pass=q is refused for the job info, or NULL; range is a buffer for
 * the message naming the job's passes. */
static const char *api_jobs_pass_why(struct http_req *r, const char *q,
                                     const struct jobs_info *info, char *range, size_t size) {
    long k = strtol(q, NULL, 10);
    snprintf(range, size, "must be a pass number of this job, 1..%d", info->passes.total);
    if (http_req_query_count(r, "pass") > 1) return "given more than once";
    if (!info->progressive) return "only a progressive job has passes";
    if (!api_is_decimal(q, false) || k < 1 || k > info->passes.total) return range;
    return NULL;
}

/* Whether ?denoise=want can be answered for the job info: want 1 needs a
 * denoised job (409 not_denoised), want 0 of a denoised job its raw passes
 * (409 raw_not_kept for a plain one: it kept the denoised image alone);
 * *raw: the raw pass images are the answer.  false after replying. */
static bool api_jobs_denoise_ok(struct http_req *r, const struct jobs_info *info, int want,
                                bool *raw) {
    *raw = false;
    if (want < 0 || want == info->denoise) return true;
    if (want == 1) {
        http_reply_error(r, 409, "not_denoised",
                         "this job's image is not denoised: create it with POST "
                         "/v1/jobs?denoise=1",
                         NULL, 0, 0, "denoise");
        return false;
    }
    if (!api_jobs_keeps_raw(info)) { /* a progressive one: its PNG shows an AOV */
        http_reply_error(r, 409, "raw_not_kept",
                         info->progressive
                             ? "this job's PNG shows an AOV (aov=), so its passes are not kept "
                               "raw: create it without aov, or with format=exr, to keep them"
                             : "this job keeps its denoised image alone: a progressive job keeps "
                               "each pass raw too; else render with denoise=0",
                         NULL, 0, 0, "denoise");
        return false;
    }
    *raw = true;
    return true;
}

/* ?pass=K: that pass's image, while kept; want: ?denoise= (-1: none). */
static void api_jobs_pass_image(struct http_req *r, const char *id, const char *q, bool exr,
                                int want) {
    struct jobs_info info;
    if (!jobs_get(id, &info, JOBS_NUMBERS)) {
        api_jobs_missing(r, id);
        return;
    }
    if (api_jobs_evicted(r, id, &info)) return;
    api_jobs_scene(r, &info);
    char range[80];
    const char *why = api_jobs_pass_why(r, q, &info, range, sizeof range);
    if (why) {
        api_bad_param(r, "pass", why);
        return;
    }
    bool raw;
    if (api_jobs_no_exr(r, &info, exr) || !api_jobs_denoise_ok(r, &info, want, &raw)) return;
    int k = (int)strtol(q, NULL, 10), samples = 0;
    struct blob *img = NULL;
    jobs_pass_image(id, k, exr ? JI_EXR : raw ? JI_RAW : JI_PNG, &img, &samples);
    if (img) {
        api_jobs_image_reply(r, img, exr, "private, max-age=3600");
        api_jobs_pass_headers(r, k, info.passes.total, samples);
        blob_unref(img);
    } else if (k <= info.passes.done) {
        http_reply_error(r, 410, "pass_gone",
                         exr ? "that pass's EXR is no longer kept (only the latest passes' are)"
                             : "that pass's image is no longer kept (only the latest passes are)",
                         NULL, 0, 0, "pass");
    } else {
        api_jobs_not_yet(r, id, &info);
    }
}

/* The job's failure (409), or 202 while it has no image yet. */
static void api_jobs_no_image(struct http_req *r, const char *id, const struct jobs_info *info) {
    if (info->state == JS_FAILED) {
        char msg[400];
        snprintf(msg, sizeof msg, "the job failed: %s", info->err.message);
        http_reply_error(r, 409, "job_failed", msg, info->err.path, 0, 0, NULL);
    } else if (info->state == JS_CANCELED) {
        http_reply_error(r, 409, "job_canceled", "the job was cancelled", NULL, 0, 0, NULL);
    } else if (info->state == JS_EVICTED) {
        http_reply_error(r, 410, "result_evicted", JOBS_EVICTED_WHY, NULL, 0, 0, NULL);
    } else {
        api_jobs_not_yet(r, id, info);
    }
}

/* The final image of the job info (its PNG or EXR referenced in info, or
 * read from disk); raw: a denoised progressive job's latest raw pass. */
static void api_jobs_final_reply(struct http_req *r, const char *id, const struct jobs_info *info,
                                 bool exr, bool raw) {
    if (raw) {
        char k[16];
        snprintf(k, sizeof k, "%d", info->passes.done);
        if (info->passes.done > 0)
            api_jobs_pass_image(r, id, k, false, 0);
        else
            api_jobs_no_image(r, id, info);
        return;
    }
    struct blob *img = exr ? info->exr : info->png, *read = NULL;
    if (!img && info->on_disk && (!exr || info->keep_exr) && !(img = read = store_read(id, exr))) {
        http_reply_error(r, 410, "result_evicted",
                         "the job's image could not be read from disk: --max-disk evicted it, or "
                         "its bytes were found damaged (the server's log says which)",
                         NULL, 0, 0, NULL);
        return;
    }
    if (api_jobs_no_exr(r, info, exr)) {
        /* replied */
    } else if (img && (info->state == JS_SUCCEEDED || info->state == JS_RUNNING)) {
        api_jobs_image_reply(r, img, exr,
                             info->state == JS_SUCCEEDED ? "private, max-age=3600" : "no-store");
        if (info->progressive)
            api_jobs_pass_headers(r, info->passes.done, info->passes.total, info->passes.samples);
    } else {
        api_jobs_no_image(r, id, info);
    }
    blob_unref(read);
}

/* The final image (a progressive job's latest pass while it runs); want:
 * ?denoise= (-1: none), 0 of a denoised progressive job its latest raw
 * pass. */
static void api_jobs_final_image(struct http_req *r, const char *id, bool exr, int want) {
    struct jobs_info info;
    if (!jobs_get(id, &info, exr ? JOBS_EXR : JOBS_PNG)) {
        api_jobs_missing(r, id);
        return;
    }
    bool raw = false;
    if (!api_jobs_evicted(r, id, &info)) {
        api_jobs_scene(r, &info);
        if (api_jobs_denoise_ok(r, &info, want, &raw)) api_jobs_final_reply(r, id, &info, exr, raw);
    }
    blob_unref(exr ? info.exr : info.png);
}

/* ?denoise=0|1 of image.png into *want (-1 without it); 400 and false on
 * a bad one. */
static bool api_jobs_want_denoise(struct http_req *r, int *want) {
    const char *v = http_req_query(r, "denoise");
    *want = -1;
    if (http_req_query_count(r, "denoise") > 1)
        return api_bad_param(r, "denoise", "given more than once");
    if (v && strcmp(v, "0") && strcmp(v, "1")) return api_bad_param(r, "denoise", "must be 0 or 1");
    if (v) *want = v[0] == '1';
    return true;
}

static void api_jobs_image_as(struct http_req *r, const char *id, bool exr) {
    if (cluster_on()) {
        (exr ? api_cluster_exr : api_cluster_image)(r, id);
        return;
    }
    static const char *const takes[] = {"pass", NULL}, *const takes_png[] = {"pass", "denoise",
                                                                             NULL};
    const char *pass = http_req_query(r, "pass");
    int want = -1;
    if (!api_only_params(r, exr ? takes : takes_png) || !api_jobs_want_denoise(r, &want)) return;
    struct shots_info shot;
    if (!api_is_hex(id, 32))
        api_jobs_unknown(r);
    else if (shots_get(id, &shot))
        http_reply_error(r, 409, "frame_range_job",
                         "this job renders frames: GET /v1/jobs/{id}/frames/{k}.png (or .exr)",
                         NULL, 0, 0, NULL);
    else if (pass)
        api_jobs_pass_image(r, id, pass, exr, want);
    else
        api_jobs_final_image(r, id, exr, want);
}

void api_jobs_image(struct http_req *r, const char *id) { api_jobs_image_as(r, id, false); }

void api_jobs_exr(struct http_req *r, const char *id) { api_jobs_image_as(r, id, true); }
