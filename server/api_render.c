/* api_render.c -- POST /v1/render and the region query shared by the
 * image routes.
 *
 * POST /v1/render takes a JSON scene and answers the PNG of the whole image
 * or of the region ?x=&y=&w=&h=.  The scene is looked up in the compiled
 * cache by the SHA-256 of the body (parsed and built only on a miss), the
 * render is queued, and the connection waits suspended; the bytes equal
 * `rayd-render scene.json --region X,Y,W,H` because both encode with
 * rayd_png_encode at the same level.
 *
 * The region query is strict: all four parameters or none, decimal
 * integers only, inside the image, no unknown or repeated parameters.  Each
 * error names the offending parameter.
 */
#include "server.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

struct api_q {
    const char *val[4];
    int count[4];
    char unknown[64];
};

static const char *const api_q_names[4] = {"x", "y", "w", "h"};

static void api_q_each(void *u, const char *k, const char *v)
{
    struct api_q *q = u;
    for (int i = 0; i < 4; i++)
        if (!strcmp(k, api_q_names[i])) {
            q->val[i] = v;
            q->count[i]++;
            return;
        }
    if (!q->unknown[0])
        snprintf(q->unknown, sizeof q->unknown, "%s", k);
}

static bool api_int(const char *s, long *out)
{
    const char *p = s;
    if (*p == '-')
        p++;
    if (!*p || strlen(p) > 9)
        return false;
    for (; *p; p++)
        if (*p < '0' || *p > '9')
            return false;
    *out = strtol(s, NULL, 10);
    return true;
}

bool api_region(struct http_req *r, const rayd_scene *scene, struct rayd_region *out)
{
    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    struct api_q q = {0};
    http_query_each(r, api_q_each, &q);
    char msg[200];
    if (q.unknown[0]) {
        snprintf(msg, sizeof msg, "unknown query parameter '%s' (only x, y, w, h)", q.unknown);
        http_reply_error(r, 400, "bad_parameter", msg, NULL, 0, 0, q.unknown);
        return false;
    }
    int present = 0;
    for (int i = 0; i < 4; i++) {
        if (q.count[i] > 1) {
            snprintf(msg, sizeof msg, "%s: given more than once", api_q_names[i]);
            http_reply_error(r, 400, "bad_region", msg, NULL, 0, 0, api_q_names[i]);
            return false;
        }
        present += q.count[i];
    }
    if (present == 0) {
        *out = (struct rayd_region){0, 0, info.width, info.height};
        return true;
    }
    long v[4];
    for (int i = 0; i < 4; i++) {
        if (!q.count[i]) {
            snprintf(msg, sizeof msg, "%s: missing (a region needs all of x, y, w, h)",
                     api_q_names[i]);
            http_reply_error(r, 400, "bad_region", msg, NULL, 0, 0, api_q_names[i]);
            return false;
        }
        if (!api_int(q.val[i], &v[i])) {
            snprintf(msg, sizeof msg, "%s: must be a decimal integer", api_q_names[i]);
            http_reply_error(r, 400, "bad_region", msg, NULL, 0, 0, api_q_names[i]);
            return false;
        }
    }
    const char *bad = NULL;
    const char *why = "";
    if (v[0] < 0 || v[0] >= info.width)
        bad = "x", why = "must be in 0..width-1";
    else if (v[1] < 0 || v[1] >= info.height)
        bad = "y", why = "must be in 0..height-1";
    else if (v[2] < 1 || v[0] + v[2] > info.width)
        bad = "w", why = "must be >= 1 with x + w <= width";
    else if (v[3] < 1 || v[1] + v[3] > info.height)
        bad = "h", why = "must be >= 1 with y + h <= height";
    if (bad) {
        snprintf(msg, sizeof msg, "%s: %s (the image is %dx%d)", bad, why, info.width,
                 info.height);
        http_reply_error(r, 400, "bad_region", msg, NULL, 0, 0, bad);
        return false;
    }
    *out = (struct rayd_region){(int)v[0], (int)v[1], (int)v[2], (int)v[3]};
    struct rayd_error err = {0};
    if (rayd_region_check(scene, out, &err) != RAYD_OK) {
        err.code = RAYD_E_ARG;
        http_reply_rayd_error(r, &err);
        return false;
    }
    return true;
}

/* Parses the body as a scene: false after replying with the error. */
static bool api_render_scene(struct http_req *r, struct cache_entry **out, bool *hit)
{
    if (http_is_draining()) {
        http_reply_refused(r, JOBQ_DRAINING);
        return false;
    }
    if (!http_require_json(r))
        return false;
    struct rayd_error err = {0};
    enum rayd_status st = jobq_scene_parse(r->body ? r->body : "", r->body_len, out, hit, &err);
    if (st != RAYD_OK) {
        err.code = st;
        http_reply_rayd_error(r, &err);
        return false;
    }
    return true;
}

void api_render_post(struct http_req *r, const char *id)
{
    (void)id;
    struct cache_entry *e;
    bool hit;
    if (!api_render_scene(r, &e, &hit))
        return;
    struct rayd_region reg;
    if (api_region(r, cache_scene(e), &reg))
        http_render(r, e, &reg);
    jobq_scene_release(e);
}

void api_scenes_post(struct http_req *r, const char *id)
{
    (void)id;
    struct cache_entry *e;
    bool hit;
    if (!api_render_scene(r, &e, &hit))
        return;
    struct rayd_scene_info info;
    rayd_scene_info(cache_scene(e), &info);
    char json[256], loc[128];
    snprintf(json, sizeof json,
             "{\"id\":\"%s\",\"width\":%d,\"height\":%d,\"objects\":%ld,\"cached\":%s}\n",
             cache_id(e), info.width, info.height, info.objects, hit ? "true" : "false");
    snprintf(loc, sizeof loc, "/v1/scenes/%s", cache_id(e));
    http_reply_json(r, 201, json);
    http_add_header(r, "Location", loc);
    jobq_scene_release(e);
}

static bool api_is_hex(const char *s, size_t n)
{
    if (strlen(s) != n)
        return false;
    for (; *s; s++)
        if (!((*s >= '0' && *s <= '9') || (*s >= 'a' && *s <= 'f')))
            return false;
    return true;
}

/* If-None-Match: a list of entity tags or "*"; weak comparison. */
static bool api_etag_match(const char *inm, const char *etag)
{
    size_t el = strlen(etag), n;
    const char *p = inm, *item;
    while (p && http_list_next(&p, &item, &n)) {
        if (item[0] == '*')
            return true;
        if (n >= 2 && !strncmp(item, "W/", 2))
            item += 2, n -= 2;
        if (n == el && !memcmp(item, etag, el))
            return true;
    }
    return false;
}

void api_scenes_image(struct http_req *r, const char *id)
{
    struct cache_entry *e = api_is_hex(id, 64) ? jobq_scene_find(id) : NULL;
    if (!e) {
        http_reply_error(r, 404, "scene_unknown",
                         "this server does not hold that scene; POST it to /v1/scenes", NULL, 0, 0,
                         NULL);
        return;
    }
    struct rayd_region reg;
    if (!api_region(r, cache_scene(e), &reg)) {
        jobq_scene_release(e);
        return;
    }
    char key[160], hex[65];
    snprintf(key, sizeof key, "%s@%d,%d,%d,%d", id, reg.x, reg.y, reg.w, reg.h);
    if (cache_hash(key, strlen(key), hex))
        snprintf(r->etag, sizeof r->etag, "\"%s\"", hex);
    const char *inm = http_header(r, "If-None-Match");
    if (inm && api_etag_match(inm, r->etag)) {
        http_reply_data(r, 304, NULL, "", 0);
        http_cache_headers(r);
    } else if (http_is_draining()) {
        http_reply_refused(r, JOBQ_DRAINING);
    } else {
        http_render(r, e, &reg);
    }
    jobq_scene_release(e);
}
