/* api.h -- the handlers: one function per route, and what they share.
 *
 * Layer: handlers (api.c, api_cost.c and api_sse.c, shared; api_render.c,
 * api_jobs.c, api_events.c, api_cluster.c, api_health.c, api_test.c,
 * api_web.c).  A handler validates
 * the request, submits work and shapes the reply; it never renders and
 * never blocks.
 * May include: request.h (read the request, reply), work.h (scenes,
 * renders, jobs, events), base.h, cJSON and libmicrohttpd's response API.
 * Included by router.c (the table) and the fuzz harnesses.
 */
#ifndef RAYD_SERVER_API_H
#define RAYD_SERVER_API_H

#include <cjson/cJSON.h>

#include "req/request.h"
#include "work/work.h"

/* ---- api.c: helpers of every handler ----------------------------------------- */

/* Parses ?x=&y=&w=&h= strictly against scene; on error replies 400 and
 * returns false.  No parameters: the whole image. */
bool api_region(struct http_req *r, const rayd_scene *scene, struct rayd_region *out);
/* Whether nothing in the scene gives light (rayd_scene_info's unlit): its
 * image is black, and the answer warns with API_UNLIT_WARNING (the
 * X-Rayd-Warning header of an image, a job's "warnings"). */
bool api_unlit(const rayd_scene *scene);
/* A new job's 202 when its scene is unlit: "warnings" in its JSON o
 * (before the reply) and the header (after it). */
void api_warn_unlit_json(cJSON *o);
void api_warn_unlit_header(struct http_req *r);
#define API_UNLIT_WARNING                                                                          \
    "unlit: nothing in the scene gives light (no light, no emissive material, a black "            \
    "background and environment); the image is black"
/* api_region, letting the names in also (NULL-ended) through for the
 * route's own parser. */
bool api_region_also(struct http_req *r, const rayd_scene *scene, struct rayd_region *out,
                     const char *const *also);
/* api_region, also taking ?format=png|png16|exr|sums (or Accept:
 * image/x-exr) and, for sums, ?samples=K0-K1, into *what; a bad one is
 * answered 400 naming it. */
bool api_target(struct http_req *r, const rayd_scene *scene, struct work_target *what);
/* ?aov= of value v (NULL: not given), given count times: with exr a list
 * of the EXR's AOV channels (default: the scene's render.aov), else the
 * one AOV a PNG shows (default: none), into *mask; 400 naming aov and
 * false on a bad one.  POST /v1/render's and POST /v1/jobs'. */
bool api_aov_param(struct http_req *r, const rayd_scene *scene, const char *v, int count, bool exr,
                   unsigned *mask);
/* ?denoise=0|1 of value v likewise (default: the scene's render.denoise). */
bool api_denoise_param(struct http_req *r, const rayd_scene *scene, const char *v, int count,
                       bool *denoise);
/* The Content-Type of a format's bytes. */
const char *api_format_type(enum work_format format);
/* For a route that takes no query parameters but names (NULL-ended; NULL
 * for none): false after a 400 bad_parameter naming the first other one,
 * so a typo (?pas=2) is told, not ignored. */
bool api_only_params(struct http_req *r, const char *const *names);
/* 400 bad_parameter "NAME: WHY" pointing at the query parameter name;
 * returns false, for a parser's `return api_bad_param(...)`. */
bool api_bad_param(struct http_req *r, const char *name, const char *why);
/* s is exactly n lowercase hex digits (a scene id is 64, a job id 32). */
bool api_is_hex(const char *s, size_t n);
/* Whether s is a plain decimal number as a query parameter takes it: digits
 * with at most one '.', at least one digit; no sign, exponent, space, hex,
 * "inf" or "nan" (which strtod would take).  Integers too when !point. */
bool api_is_decimal(const char *s, bool point);
/* err's error reply; draining: the result says the server drains (a
 * cancelled render is then 503 "draining"), as the work layer reported. */
void api_reply_rayd_error(struct http_req *r, const struct rayd_error *err, bool draining);
/* 404 for a path rayd does not serve, naming the ones it does (a user who
 * tried /health finds /healthz). */
void api_not_found(struct http_req *r);
/* Reply for a refused submission (queue full, draining, ...). */
void api_refused(struct http_req *r, enum work_submit why);
/* What a handler does with r's scene once it is compiled: e is referenced
 * for the call only (api_scene releases it after), hit when it was found
 * compiled.  It may run on a parse thread with r suspended; it returns true
 * when it handed r on to something that will resume it (a render's waiter,
 * suspended with api_suspend), false when it answered r. */
typedef bool (*api_scene_then)(struct http_req *r, struct cache_entry *e, bool hit);
/* Compiles r's body as a scene (refusing while draining, or 503 queue_full
 * with Retry-After when --parse-queue scenes wait), then calls then: at once
 * when the scene is cached, else from a parse thread while r is suspended
 * (compile.c).  A bad scene is answered with its error, then not called. */
void api_scene(struct http_req *r, api_scene_then then);
/* From a continuation of api_scene: then(r, e) once the keyframed values
 * of r's body pass at every frame first..last, on the parse pool
 * (compile_check_frames); else the first failing frame's 400.  Returns as
 * a continuation does: true when r was handed on. */
bool api_scene_check_frames(struct http_req *r, struct cache_entry *e, long first, long last,
                            api_scene_then then);
/* A waiter's suspend(): suspends r unless it is already, waiting for its
 * scene (a continuation of api_scene's on a parse thread). */
void api_suspend(struct http_req *r);

/* ---- api_cost.c: who asks, and what it costs ------------------------------------ */

struct api_price {
    double rays, seconds; /* estimated (cost.c) */
};
/* The client r comes from (--client-header, else the peer address), hashed. */
uint64_t api_cost_client(struct http_req *r);
/* Sets what->client and prices what of scene; false when over --max-work,
 * or (unless progressive) far past --max-render-seconds, with the limit
 * passed written to limit. */
bool api_cost_price(struct http_req *r, const struct cache_entry *scene, struct work_target *what,
                    bool progressive, struct api_price *out, char *limit, size_t n);
/* The 413 over_budget of a render priced at p, over limit. */
void api_cost_over_budget(struct http_req *r, const struct api_price *p, const char *limit);
/* api_cost_price, then the 413 when over a budget (false). */
bool api_cost_admit(struct http_req *r, const struct cache_entry *scene, struct work_target *what,
                    bool progressive, struct api_price *out);
/* X-Rayd-Estimated-Rays and X-Rayd-Estimated-Seconds on r's reply. */
void api_cost_price_headers(struct http_req *r, const struct api_price *p);
/* A Retry-After for a wait of about `seconds`: 1 to 600. */
int api_cost_retry_after(double seconds);

/* ---- the routes ----------------------------------------------------------------- */

void api_render_post(struct http_req *r, const char *id);
void api_scenes_post(struct http_req *r, const char *id);
void api_scenes_get(struct http_req *r, const char *id); /* GET /v1/scenes/{id}: its JSON */
void api_scenes_image(struct http_req *r, const char *id);
void api_jobs_post(struct http_req *r, const char *id);
void api_jobs_list(struct http_req *r, const char *id); /* GET /v1/jobs: the client's own */
void api_jobs_get(struct http_req *r, const char *id);
void api_jobs_delete(struct http_req *r, const char *id);
void api_jobs_stop(struct http_req *r, const char *id);
/* api_jobs_json.c: the pieces every job route shares: 404
 * job_unknown, a pass's noise and image URL in a JSON object, the job's
 * status document (docs/api.md: key order and decimals), and the job's
 * scene for the access log. */
void api_jobs_unknown(struct http_req *r);
/* A job id the table does not have: 410 job_expired or job_evicted (how
 * and when it ended, when it went) for one this server forgot, else 404
 * job_unknown. */
void api_jobs_missing(struct http_req *r, const char *id);
/* 410 Gone for a forgotten job (g: how and when it ended, why and when it
 * went), with the job's JSON when it is still known (job, owned; or NULL):
 * the single node's tombstones and a cluster's (rayd:{ID}:gone). */
void api_jobs_gone(struct http_req *r, const struct jobs_gone *g, cJSON *job);
/* 410 result_evicted with the job's JSON when info's images were evicted
 * (a memory budget); true when it replied. */
bool api_jobs_evicted(struct http_req *r, const char *id, const struct jobs_info *info);
void api_jobs_add_noise(cJSON *o, double noise);
void api_jobs_add_pass_url(cJSON *o, const char *id, int k);
/* "raw_url": pass k of job id as rendered, before the denoiser. */
void api_jobs_add_raw_url(cJSON *o, const char *id, int k);
/* Whether the job in keeps its passes raw: progressive, denoised, its PNG
 * the light's (not one AOV). */
bool api_jobs_keeps_raw(const struct jobs_info *in);
/* A new job's 202 (a still's or a frame range's): o (taken) with the
 * unlit warning when asked, then Location and the price headers. */
void api_jobs_reply_accepted(struct http_req *r, cJSON *o, const char *id, bool unlit,
                             const struct api_price *price);
/* The store could not record a new job (--data-dir): 503 store_failed. */
void api_jobs_reply_store_failed(struct http_req *r, const char *message);
cJSON *api_jobs_json(const char *id, const struct jobs_info *in);
void api_jobs_url(char *buf, size_t size, const char *id, const char *tail); /* /v1/jobs/ID+tail */
void api_jobs_add_estimate(cJSON *o, const struct api_price *p);             /* "estimate" */
void api_jobs_scene(struct http_req *r, const struct jobs_info *info);

/* api_jobs_image.c: GET /v1/jobs/{id}/image.png and image.exr */
void api_jobs_image(struct http_req *r, const char *id);
void api_jobs_exr(struct http_req *r, const char *id);

/* api_shots.c: frame-range jobs.  api_shots_wanted: 1 for an animated
 * scene (a frame-range job), 0 a still one, -1 after a 400 (?frames= of a
 * still scene).  api_shots_submit: the job made and its 202 sent (or
 * an error): true when the request waits for the store (--data-dir), which
 * resumes it.  api_shots_json: the job's JSON with its
 * "frames", "eta_s" and "video_url". */
int api_shots_wanted(struct http_req *r, const rayd_scene *scene);
bool api_shots_submit(struct http_req *r, struct cache_entry *e, struct work_target *what,
                      int priority, const struct api_price *one);
cJSON *api_shots_json(const char *id, const struct shots_info *in);
void api_shots_frame(struct http_req *r, const char *path);
/* 409 frame_not_ready for frame k in state st, of a single node's job or a
 * cluster's.  A frame its job will never render (the job failed or was
 * cancelled first) says so, with no Retry-After: a client polling for its
 * 200 would poll for ever. */
void api_shots_not_ready(struct http_req *r, long k, enum shots_frame_state st,
                         const struct shots_info *info);
/* 409 frames_not_done for the video of a job with frames still to come
 * (Retry-After: 1), or that will have none (its job failed or was
 * cancelled first: final). */
void api_shots_no_video(struct http_req *r, const struct shots_info *info);
void api_shots_video(struct http_req *r, const char *id);

/* api_shots.c: ?frames=A-B or ?frame=K of an animated scene into first..last
 * (the whole animation without them); false after a 400 naming it. */
bool api_shots_frames(struct http_req *r, const rayd_scene *scene, long *first, long *last);
/* "JOB/K.png" (the frame route's two segments) into the job id, k and
 * whether the EXR is asked; false after replying (404, 400). */
bool api_shots_frame_path(struct http_req *r, const char *path, char id[33], long *k, bool *exr);

/* Which pass an image is: X-Rayd-Pass "k/total", X-Rayd-Samples n
 * (api_jobs_json.c). */
void api_jobs_pass_headers(struct http_req *r, int pass, int total, int samples);

/* api_cluster.c: the job routes with --redis (cluster_on()), answered from
 * the cluster's request thread.  api_cluster_submit: POST /v1/jobs once its
 * scene is checked (what, priority and the price of one frame); true when
 * the request was handed on. */
bool api_cluster_submit(struct http_req *r, struct cache_entry *e, const struct work_target *what,
                        int priority, const struct api_price *one, bool animated,
                        const struct jobs_plan *plan);
void api_cluster_get(struct http_req *r, const char *id);
void api_cluster_delete(struct http_req *r, const char *id);
void api_cluster_stop(struct http_req *r, const char *id);
void api_cluster_image(struct http_req *r, const char *id);
void api_cluster_exr(struct http_req *r, const char *id);
/* The routes of a frame-range job's frames and video: the cluster's with
 * --redis, else api_shots_frame and api_shots_video. */
void api_cluster_frame(struct http_req *r, const char *path);
void api_cluster_video(struct http_req *r, const char *id);
void api_cluster_list(struct http_req *r, long long limit, long long after, int state);
void api_cluster_events(struct http_req *r, const char *id); /* api_cluster_events.c */

/* api_events.c */
void api_events_get(struct http_req *r, const char *id);
void api_health_live(struct http_req *r, const char *id);
void api_health_ready(struct http_req *r, const char *id);
void api_health_metrics(struct http_req *r, const char *id);
void api_test_gate_get(struct http_req *r, const char *id);
void api_test_gate_post(struct http_req *r, const char *id);
void api_web_index(struct http_req *r, const char *id);
void api_web_asset(struct http_req *r, const char *id);
bool api_web_exists(const char *name);

/* api_sse.c */
/* Answers r 200 with an event stream that read fills (done(cls) once, as
 * http_reply_stream). */
void api_sse_reply(struct http_req *r, ssize_t (*read)(void *cls, char *buf, size_t max),
                   void (*done)(void *cls), void *cls);
/* "event: NAME\ndata: JSON\n\n" into out (o deleted); its length, 0 when
 * it does not fit. */
size_t api_sse_event(char *out, size_t size, const char *name, cJSON *o);
/* An event stream's text formatted but not yet sent (the transport's
 * buffer was full): both event streams, one node's and a cluster's. */
struct api_sse_carry {
    char *text;
    size_t len, off;
};
/* Copies what fits of text to buf (max bytes, *used of them taken); the
 * rest goes to the carry.  false when the carry cannot be had. */
bool api_sse_put(struct api_sse_carry *c, char *buf, size_t max, size_t *used, const char *text,
                 size_t len);
/* Sends what is left of the carry into buf; true when it is empty. */
bool api_sse_flush(struct api_sse_carry *c, char *buf, size_t max, size_t *used);

#endif
