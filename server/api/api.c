/* api.c -- what every handler shares: the region query, the JSON body
 * check, and the mapping of failures to HTTP.
 *
 * A core status becomes an HTTP status and error code in one place,
 * api_status_of, and a refusal of the work layer (queue full, draining, out
 * of memory) becomes its 503 in one place, api_refused; the handlers never
 * pick those numbers themselves, so one failure always reads the same.
 *
 * The region query is strict: all four parameters or none, decimal
 * integers only, inside the image, no unknown or repeated parameters.  Each
 * error names the offending parameter.  A parameter with an empty name
 * ("?=1") is an unknown one like any other: it is kept by a flag of its own,
 * since its name, "", cannot say it was seen.
 */
#include "api/api.h"

#include <stdlib.h>
#include <string.h>
#include <strings.h>

/* The first query parameter a route does not take. */
struct api_unknown {
    bool seen;
    char name[64]; /* "" for a parameter with an empty name */
};

struct api_q {
    const char *val[4];
    int count[4];
    struct api_unknown unknown;
    bool allow_format;       /* POST /v1/render: ?format= and ?samples= too */
    const char *const *also; /* names another parser of the route reads, NULL-ended */
    const char *format, *samples, *aov, *denoise;
    int format_count, samples_count, aov_count, denoise_count;
};

static const char *const api_q_names[4] = {"x", "y", "w", "h"};

/* Keeps k in u unless it is one of names (NULL-ended, or NULL) or a
 * parameter was kept already: the first parameter a route does not take. */
static void api_note_unknown(struct api_unknown *u, const char *const *names, const char *k) {
    for (const char *const *n = names; n && *n; n++)
        if (!strcmp(k, *n)) return;
    if (u->seen) return;
    u->seen = true;
    snprintf(u->name, sizeof u->name, "%s", k);
}

bool api_bad_param(struct http_req *r, const char *name, const char *why) {
    char msg[200];
    snprintf(msg, sizeof msg, "%s: %s", name, why);
    http_reply_error(r, 400, "bad_parameter", msg, NULL, 0, 0, name);
    return false;
}

/* 400 bad_parameter for the query parameter u, which the route does not
 * take, listing those it does: head (or NULL), then names (NULL-ended, or
 * NULL).  An empty name is said so: "unknown query parameter ''" would
 * read as a bug of the message. */
static void api_reply_unknown(struct http_req *r, const struct api_unknown *u, const char *head,
                              const char *const *names) {
    char takes[160] = "", what[100], msg[320];
    size_t used = head ? (size_t)snprintf(takes, sizeof takes, "%s", head) : 0;
    for (const char *const *n = names; n && *n && used < sizeof takes; n++)
        used += (size_t)snprintf(takes + used, sizeof takes - used, "%s%s", used ? ", " : "", *n);
    if (u->name[0])
        snprintf(what, sizeof what, "unknown query parameter '%s'", u->name);
    else
        snprintf(what, sizeof what, "a query parameter has an empty name");
    snprintf(msg, sizeof msg, "%s (%s%s)", what, used ? "only " : "this route takes none", takes);
    http_reply_error(r, 400, "bad_parameter", msg, NULL, 0, 0, u->name);
}

static void api_q_each(void *u, const char *k, const char *v) {
    struct api_q *q = u;
    for (int i = 0; i < 4; i++)
        if (!strcmp(k, api_q_names[i])) {
            q->val[i] = v;
            q->count[i]++;
            return;
        }
    if (q->allow_format && !strcmp(k, "format")) {
        q->format = v;
        q->format_count++;
        return;
    }
    if (q->allow_format && !strcmp(k, "samples")) {
        q->samples = v;
        q->samples_count++;
        return;
    }
    if (q->allow_format && !strcmp(k, "aov")) {
        q->aov = v;
        q->aov_count++;
        return;
    }
    if (q->allow_format && !strcmp(k, "denoise")) {
        q->denoise = v;
        q->denoise_count++;
        return;
    }
    api_note_unknown(&q->unknown, q->also, k);
}

/* A decimal integer (an optional '-', then digits only) in the n bytes at
 * s into *out.  Past nine significant digits the value is kept as +-1e9,
 * beyond any image or sample count, so the range checks name a huge number
 * as out of range, not as "not an integer" (w=4294967297 is a decimal
 * integer). */
static bool api_int_n(const char *s, size_t n, long *out) {
    bool neg = n > 0 && *s == '-';
    const char *p = s + neg;
    size_t len = n - neg;
    if (!len || strspn(p, "0123456789") < len) return false;
    for (; len > 1 && *p == '0'; len--) p++;
    long v = len > 9 ? 1000000000L : 0;
    for (size_t i = 0; len <= 9 && i < len; i++) v = v * 10 + (p[i] - '0');
    *out = neg ? -v : v;
    return true;
}

static bool api_int(const char *s, long *out) { return api_int_n(s, strlen(s), out); }

/* 400 bad_parameter for a query parameter the route does not take,
 * listing those it does. */
static void api_q_unknown(struct http_req *r, const struct api_q *q) {
    api_reply_unknown(r, &q->unknown,
                      q->allow_format ? "x, y, w, h, format, samples, aov, denoise" : "x, y, w, h",
                      q->also);
}

/* 400 bad_region naming the parameter name and what is wrong with it;
 * false, for the callers' return. */
static bool api_region_bad(struct http_req *r, const char *name, const char *why) {
    char msg[320];
    snprintf(msg, sizeof msg, "%s: %s", name, why);
    http_reply_error(r, 400, "bad_region", msg, NULL, 0, 0, name);
    return false;
}

/* x, y, w, h into v: 1, or 0 when none is given (the whole image), or -1
 * after a 400: one given twice (looked for first), missing, or not an
 * integer. */
static int api_region_values(struct http_req *r, const struct api_q *q, long v[4]) {
    int present = 0;
    for (int i = 0; i < 4; i++) {
        if (q->count[i] > 1) {
            api_region_bad(r, api_q_names[i], "given more than once");
            return -1;
        }
        present += q->count[i];
    }
    for (int i = 0; i < 4 && present > 0; i++) {
        const char *why = !q->count[i] ? "missing (a region needs all of x, y, w, h)"
                          : !api_int(q->val[i], &v[i]) ? "must be a decimal integer"
                                                       : NULL;
        if (why) {
            api_region_bad(r, api_q_names[i], why);
            return -1;
        }
    }
    return present > 0;
}

/* The region v inside an image of info's size; else a 400 naming the first
 * value out of it. */
static bool api_region_inside(struct http_req *r, const struct rayd_scene_info *info,
                              const long v[4]) {
    const char *bad = NULL, *why = "";
    if (v[0] < 0 || v[0] >= info->width)
        bad = "x", why = "must be in 0..width-1";
    else if (v[1] < 0 || v[1] >= info->height)
        bad = "y", why = "must be in 0..height-1";
    else if (v[2] < 1 || v[0] + v[2] > info->width)
        bad = "w", why = "must be >= 1 with x + w <= width";
    else if (v[3] < 1 || v[1] + v[3] > info->height)
        bad = "h", why = "must be >= 1 with y + h <= height";
    if (!bad) return true;
    char full[160];
    snprintf(full, sizeof full, "%s (the image is %dx%d)", why, info->width, info->height);
    return api_region_bad(r, bad, full);
}

static bool api_region_q(struct http_req *r, const rayd_scene *scene, struct rayd_region *out,
                         struct api_q *qp) {
    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    http_req_query_each(r, api_q_each, qp);
    if (qp->unknown.seen) {
        api_q_unknown(r, qp);
        return false;
    }
    long v[4];
    int given = api_region_values(r, qp, v);
    if (given <= 0) {
        *out = (struct rayd_region){0, 0, info.width, info.height};
        return given == 0;
    }
    if (!api_region_inside(r, &info, v)) return false;
    *out = (struct rayd_region){(int)v[0], (int)v[1], (int)v[2], (int)v[3]};
    struct rayd_error err = {0};
    if (rayd_region_check(scene, out, &err) != RAYD_OK) {
        err.code = RAYD_E_ARG;
        api_reply_rayd_error(r, &err, false);
        return false;
    }
    return true;
}

bool api_unlit(const rayd_scene *scene) {
    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    return info.unlit != 0;
}

void api_warn_unlit_json(cJSON *o) {
    cJSON *w = cJSON_AddArrayToObject(o, "warnings");
    if (w) cJSON_AddItemToArray(w, cJSON_CreateString(API_UNLIT_WARNING));
}

void api_warn_unlit_header(struct http_req *r) {
    http_reply_header(r, "X-Rayd-Warning", API_UNLIT_WARNING);
}

bool api_region(struct http_req *r, const rayd_scene *scene, struct rayd_region *out) {
    struct api_q q = {0};
    return api_region_q(r, scene, out, &q);
}

bool api_region_also(struct http_req *r, const rayd_scene *scene, struct rayd_region *out,
                     const char *const *also) {
    struct api_q q = {.also = also};
    return api_region_q(r, scene, out, &q);
}

/* The weight of one media range's parameters [p, end) (RFC 9110 12.4.2):
 * the value of its parameter named q, 1 without one, -1 when that value is
 * not a qvalue (0 to 1, three decimals at most: the range then counts as
 * not named).  Only a parameter whose name is q counts, not one that ends
 * in q ("xq=1"). */
static double api_accept_weight(const char *p, const char *end) {
    while ((p = memchr(p, ';', (size_t)(end - p))) != NULL) {
        p += 1 + strspn(p + 1, " \t");
        if ((*p != 'q' && *p != 'Q') || p[1] != '=') continue;
        const char *v = p + 2;
        size_t n = strspn(v, "0123456789.");
        char *stop;
        double q = strtod(v, &stop);
        bool digits =
            n >= 1 && n <= 5 && stop == v + n && (v[1] == '.' || n == 1) && strchr(" \t;,", v[n]);
        return digits && q >= 0 && q <= 1 ? q : -1;
    }
    return 1;
}

/* The q of media type type in an Accept header (RFC 9110 12.5.1): its
 * weight (api_accept_weight) where it is named, -1 when it is not named
 * (wildcards are not counted: they name no preference for EXR). */
static double api_accept_q(const char *accept, const char *type) {
    size_t tl = strlen(type);
    for (const char *p = accept; p; p = strchr(p, ',')) {
        p += strspn(p, ", \t"); /* the next media range */
        const char *end = p + strcspn(p, ",");
        if (strncasecmp(p, type, tl) || !strchr(" \t;,", p[tl])) /* '\0' is in it too */
            continue;
        return api_accept_weight(p + tl, end);
    }
    return -1;
}

/* ?format= first; else an Accept naming image/x-exr with a q above 0 and
 * not below image/png's; else the PNG.  An Accept without either is not
 * refused: PNG stays the answer, as before. */
static bool api_format_of(struct http_req *r, const struct api_q *q, enum work_format *format) {
    static const char *const names[] = {"png", "png16", "exr", "sums"};
    char why[120];
    if (q->format_count > 1) return api_bad_param(r, "format", "given more than once");
    if (q->format) {
        for (int i = 0; i < 4; i++)
            if (!strcmp(q->format, names[i])) {
                *format = (enum work_format)i;
                return true;
            }
        snprintf(why, sizeof why, "must be png, png16, exr or sums, not '%.40s'", q->format);
        return api_bad_param(r, "format", why);
    }
    const char *accept = http_req_header(r, "Accept");
    double exr = accept ? api_accept_q(accept, "image/x-exr") : -1;
    *format = exr > 0 && exr >= api_accept_q(accept, "image/png") ? WORK_EXR : WORK_PNG;
    return true;
}

/* ?samples=K0-K1 for format=sums: a range inside the scene's samples. */
static bool api_samples_of(struct http_req *r, const rayd_scene *scene, const struct api_q *q,
                           struct work_target *what) {
    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    char range[120];
    const char *why = NULL;
    long k0 = -1, k1 = -1;
    const char *dash = q->samples ? strchr(q->samples, '-') : NULL;
    if (q->samples_count > 1)
        why = "given more than once";
    else if (what->format != WORK_SUMS && q->samples)
        why = "only with format=sums";
    else if (what->format == WORK_SUMS && !q->samples)
        why = "format=sums needs a range samples=K0-K1";
    else if (q->samples && (!dash || !api_int_n(q->samples, (size_t)(dash - q->samples), &k0) ||
                            !api_int(dash + 1, &k1)))
        why = "must be K0-K1, two decimal sample numbers";
    if (!why && q->samples && (k0 < 0 || k1 <= k0 || k1 > info.samples)) {
        snprintf(range, sizeof range, "must be K0-K1 with 0 <= K0 < K1 <= %d (render.samples)",
                 info.samples);
        why = range;
    }
    if (why) return api_bad_param(r, "samples", why);
    what->k0 = (int)k0;
    what->k1 = (int)k1;
    return true;
}

bool api_aov_param(struct http_req *r, const rayd_scene *scene, const char *v, int count, bool exr,
                   unsigned *mask) {
    struct rayd_error err = {0};
    char why[150];
    if (count > 1) return api_bad_param(r, "aov", "given more than once");
    if (!v) {
        struct rayd_scene_info info;
        rayd_scene_info(scene, &info);
        *mask = exr ? info.aov : 0;
        return true;
    }
    if (rayd_aov_parse(v, mask, &err) != RAYD_OK) {
        snprintf(why, sizeof why, "%.149s", err.message);
        return api_bad_param(r, "aov", why);
    }
    if (!exr && (*mask & (*mask - 1)))
        return api_bad_param(r, "aov",
                             "a PNG is one AOV: albedo, normal, depth, alpha, object or material "
                             "(format=exr takes a list)");
    return true;
}

/* ?aov=: with format=exr a list of AOVs for channels (default: the
 * scene's render.aov), with format=png the one AOV answered as the image
 * (render/aov.c); no other format takes it. */
static bool api_aov_of(struct http_req *r, const rayd_scene *scene, const struct api_q *q,
                       struct work_target *what) {
    if (q->aov && q->aov_count < 2 && what->format != WORK_PNG && what->format != WORK_EXR)
        return api_bad_param(r, "aov", "only with format=png (one AOV as the image) or exr");
    return api_aov_param(r, scene, q->aov, q->aov_count, what->format == WORK_EXR, &what->aov);
}

bool api_denoise_param(struct http_req *r, const rayd_scene *scene, const char *v, int count,
                       bool *denoise) {
    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    if (count > 1) return api_bad_param(r, "denoise", "given more than once");
    if (v && strcmp(v, "0") && strcmp(v, "1")) return api_bad_param(r, "denoise", "must be 0 or 1");
    *denoise = v ? v[0] == '1' : info.denoise != 0;
    return true;
}

/* ?denoise=1 or 0 (default: the scene's render.denoise); sums are raw. */
static bool api_denoise_of(struct http_req *r, const rayd_scene *scene, const struct api_q *q,
                           struct work_target *what) {
    if (!api_denoise_param(r, scene, q->denoise, q->denoise_count, &what->denoise)) return false;
    if (what->denoise && what->format == WORK_SUMS) {
        if (q->denoise) return api_bad_param(r, "denoise", "sums are raw: not with format=sums");
        what->denoise = false; /* the scene's wish is for images */
    }
    return true;
}

bool api_target(struct http_req *r, const rayd_scene *scene, struct work_target *what) {
    struct api_q q = {.allow_format = true};
    memset(what, 0, sizeof *what);
    return api_region_q(r, scene, &what->reg, &q) && api_format_of(r, &q, &what->format) &&
           api_samples_of(r, scene, &q, what) && api_aov_of(r, scene, &q, what) &&
           api_denoise_of(r, scene, &q, what);
}

const char *api_format_type(enum work_format format) { return work_format_type(format); }

struct api_only {
    const char *const *names;
    struct api_unknown unknown;
};

static void api_only_each(void *u, const char *k, const char *v) {
    (void)v;
    struct api_only *o = u;
    api_note_unknown(&o->unknown, o->names, k);
}

bool api_only_params(struct http_req *r, const char *const *names) {
    struct api_only o = {.names = names};
    http_req_query_each(r, api_only_each, &o);
    if (!o.unknown.seen) return true;
    api_reply_unknown(r, &o.unknown, NULL, names);
    return false;
}

/* A Content-Encoding other than identity: 415 naming it (RFC 9110 15.5.16),
 * with Accept-Encoding: identity.  Read as it is, a gzip body would be
 * "malformed JSON at line 1" and a br one parsed as if it were plain. */
static bool api_encoded(struct http_req *r) {
    const char *ce = http_req_header(r, "Content-Encoding");
    if (!ce) return false;
    ce += strspn(ce, " \t");
    size_t n = strcspn(ce, " \t");
    if (n == strlen("identity") && !strncasecmp(ce, "identity", n) &&
        !ce[n + strspn(ce + n, " \t")])
        return false;
    char msg[200];
    snprintf(msg, sizeof msg,
             "the body is sent with Content-Encoding: %.60s; rayd reads it uncompressed only "
             "(no Content-Encoding, or identity)",
             ce);
    http_reply_error(r, 415, "unsupported_media_type", msg, NULL, 0, 0, NULL);
    http_reply_header(r, "Accept-Encoding", "identity");
    return true;
}

/* Body is JSON?  Otherwise replies 415 and returns false. */
static bool api_require_json(struct http_req *r) {
    if (api_encoded(r)) return false;
    const char *ct = http_req_header(r, "Content-Type");
    if (ct) {
        while (*ct == ' ') ct++;
        size_t n = strlen("application/json");
        if (!strncasecmp(ct, "application/json", n) && (ct[n] == 0 || ct[n] == ';' || ct[n] == ' '))
            return true;
    }
    http_reply_error(r, 415, "unsupported_media_type",
                     "the body must be a JSON scene sent with Content-Type: application/json", NULL,
                     0, 0, NULL);
    return false;
}

/* The one place where a core status becomes an HTTP status and code. */
static unsigned api_status_of(enum rayd_status s) {
    switch (s) {
    case RAYD_OK: return 200;
    case RAYD_E_PARSE: return 400;
    case RAYD_E_INVALID: return 422;
    case RAYD_E_LIMIT: return 413;
    case RAYD_E_ARG: return 400;
    case RAYD_E_NOMEM: return 503;
    case RAYD_E_CANCELED: return 503;
    case RAYD_E_IO:
    case RAYD_E_INTERNAL:
    default: return 500;
    }
}

void api_not_found(struct http_req *r) {
    http_reply_error(r, 404, "not_found",
                     "no such resource; rayd serves /v1/render, /v1/scenes and /v1/jobs "
                     "(docs/api.md), /healthz, /readyz, /metrics and the preview at /",
                     NULL, 0, 0, NULL);
}

void api_reply_rayd_error(struct http_req *r, const struct rayd_error *err, bool draining) {
    unsigned st = api_status_of(err->code);
    const char *code =
        err->code == RAYD_E_CANCELED && draining ? "draining" : rayd_status_name(err->code);
    const char *msg = err->message[0] ? err->message : code;
    char hint[sizeof err->message + 64];
    if (err->code == RAYD_E_LIMIT && !strcmp(err->path, "/render/samples")) {
        /* the one scene limit a server option raises says so, as rayd-render's does */
        snprintf(hint, sizeof hint, "%s; the server's --max-samples, set by its operator", msg);
        msg = hint;
    }
    http_reply_error(r, st, code, msg, err->path,
                     err->code == RAYD_E_PARSE ? (err->line > 0 ? err->line : 1) : 0, err->column,
                     NULL);
}

void api_refused(struct http_req *r, enum work_submit why) {
    struct sched_stats st;
    sched_stats(&st);
    /* A queue slot frees when a task ahead starts: about the backlog over
     * the tasks in it; a drain, when this server is gone and another one
     * answers. */
    if (why == WORK_FULL || why == WORK_FULL_SHARE || why == WORK_TOO_MANY_JOBS ||
        why == WORK_JOBS_SHARE || why == WORK_MEMORY)
        r->res.retry_after =
            api_cost_retry_after(st.backlog_s / (double)(st.queued > 0 ? st.queued : 1));
    switch (why) {
    case WORK_PARSE_FULL: /* a place frees when a queued parse starts */
        metrics_reject(MR_PARSE_QUEUE_FULL);
        r->res.retry_after = api_cost_retry_after(compile_retry_seconds());
        http_reply_error(r, 503, "queue_full", "the scene parse queue is full, retry later", NULL,
                         0, 0, NULL);
        break;
    case WORK_FULL:
        metrics_reject(MR_QUEUE_FULL);
        http_reply_error(r, 503, "queue_full", "the render queue is full, retry later", NULL, 0, 0,
                         NULL);
        break;
    case WORK_FULL_SHARE:
        metrics_reject(MR_QUEUE_FULL);
        http_reply_error(r, 503, "queue_full",
                         "the render queue's last places are kept for clients with few renders "
                         "queued, and this client has many (--queue): retry later",
                         NULL, 0, 0, NULL);
        break;
    case WORK_JOBS_SHARE:
        metrics_reject(MR_QUEUE_FULL);
        http_reply_error(r, 503, "queue_full",
                         "the last quarter of the unfinished jobs' places (--max-jobs) is kept for "
                         "clients with few jobs unfinished, and this client has many: retry later",
                         NULL, 0, 0, NULL);
        break;
    case WORK_DRAINING:
        metrics_reject(MR_DRAINING);
        http_reply_error(r, 503, "draining", "the server is shutting down", NULL, 0, 0, NULL);
        break;
    case WORK_TOO_MANY_JOBS:
        metrics_reject(MR_QUEUE_FULL);
        http_reply_error(r, 503, "queue_full", "too many unfinished jobs, retry later", NULL, 0, 0,
                         NULL);
        break;
    case WORK_MEMORY: /* counted by budget.c or compile.c */
        http_reply_error(r, 503, "memory_full",
                         "the memory budget (--max-memory) has no room for this scene's parse "
                         "or this render now; retry later",
                         NULL, 0, 0, NULL);
        break;
    case WORK_TOO_BIG: /* counted in rayd_rejected_total by budget.c */
        http_reply_error(r, 413, "over_memory",
                         "the render alone needs more than the memory budget (--max-memory); "
                         "ask for a smaller region or format",
                         NULL, 0, 0, NULL);
        break;
    case WORK_NOMEM:
    default: http_reply_error(r, 503, "out_of_memory", "out of memory", NULL, 0, 0, NULL); break;
    }
}

/* A request waiting on a parse thread for its scene (compile.c). */
struct api_scene_wait {
    struct compile_waiter w; /* first: the callbacks get it back */
    struct http_req *r;
    api_scene_then then;
};

/* r's answer for its scene: the error, or what the continuation does with
 * it; true when the continuation handed r on (a render will resume it). */
static bool api_scene_answer(struct http_req *r, struct compile_result *res, api_scene_then then) {
    if (res->draining) {
        api_refused(r, WORK_DRAINING);
        return false;
    }
    if (res->memory_full) { /* the budget, not an allocation that failed */
        r->res.retry_after = api_cost_retry_after(compile_retry_seconds());
        http_reply_error(r, 503, "memory_full", res->err.message, NULL, 0, 0, NULL);
        return false;
    }
    if (res->status != RAYD_OK) {
        res->err.code = res->status;
        api_reply_rayd_error(r, &res->err, res->draining);
        return false;
    }
    snprintf(r->res.scene, sizeof r->res.scene, "%s",
             cache_id(res->scene)); /* for the access log */
    bool handed = then(r, res->scene, res->hit);
    scenes_release(res->scene);
    return handed;
}

/* On a parse thread, r still suspended: the continuation runs here, and r
 * is resumed unless the continuation handed it on. */
static void api_scene_done(struct compile_waiter *w, struct compile_result *res) {
    struct api_scene_wait a = *(struct api_scene_wait *)w;
    free(w);
    if (!api_scene_answer(a.r, res, a.then)) http_req_resume(a.r);
}

/* From the HTTP thread or, r suspended already, from a parse thread (a
 * continuation asking for more: api_scene_check_frames). */
static void api_scene_suspend(struct compile_waiter *w) {
    api_suspend(((struct api_scene_wait *)w)->r);
}

/* r waits on the parse pool for its scene: compiled from its body, or
 * (check) the scene check once its frames first..last pass; then, in
 * every case, its continuation.  True when r was handed on. */
static bool api_scene_wait(struct http_req *r, api_scene_then then, struct cache_entry *check,
                           long first, long last) {
    struct api_scene_wait *a = calloc(1, sizeof *a);
    if (!a) {
        api_refused(r, WORK_NOMEM);
        return false;
    }
    a->r = r;
    a->then = then;
    a->w.done = api_scene_done;
    a->w.suspend = api_scene_suspend;
    a->w.client = api_cost_client(r); /* the parse pool's turns */
    struct compile_result res;
    const char *body = r->body ? r->body : "";
    enum work_submit s =
        check ? compile_check_frames(check, body, r->body_len, first, last, &a->w, &res)
              : compile_scene(body, r->body_len, &a->w, &res);
    if (s == WORK_OK) return true; /* a belongs to the parse pool until done() */
    free(a);
    if (s == WORK_CACHED) return api_scene_answer(r, &res, then);
    api_refused(r, s);
    return false;
}

void api_scene(struct http_req *r, api_scene_then then) {
    if (sched_draining()) {
        api_refused(r, WORK_DRAINING);
        return;
    }
    if (api_require_json(r)) api_scene_wait(r, then, NULL, 0, 0);
}

void api_suspend(struct http_req *r) {
    if (!r->conn.suspended) http_req_suspend(r);
}

bool api_scene_check_frames(struct http_req *r, struct cache_entry *e, long first, long last,
                            api_scene_then then) {
    return api_scene_wait(r, then, e, first, last);
}

bool api_is_decimal(const char *s, bool point) {
    size_t digits = strspn(s, "0123456789");
    const char *p = s + digits;
    if (point && *p == '.') {
        size_t frac = strspn(p + 1, "0123456789");
        digits += frac;
        p += 1 + frac;
    }
    return digits > 0 && !*p;
}

bool api_is_hex(const char *s, size_t n) {
    if (strlen(s) != n) return false;
    for (; *s; s++)
        if (!((*s >= '0' && *s <= '9') || (*s >= 'a' && *s <= 'f'))) return false;
    return true;
}
