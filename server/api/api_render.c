/* api_render.c -- synchronous renders: POST /v1/render, POST /v1/scenes
 * and GET /v1/scenes/{id}/image.png.
 *
 * POST /v1/render takes a JSON scene and answers the PNG of the whole image
 * or of the region ?x=&y=&w=&h=.  The scene is looked up in the compiled
 * cache by the SHA-256 of the body (parsed and built only on a miss), the
 * render is submitted, and the connection waits suspended; the bytes equal
 * `rayd-render scene.json --region X,Y,W,H` because both encode with
 * rayd_png_encode at the same level.  ?format=png16|exr (or Accept:
 * image/x-exr) answers a 16-bit PNG or an OpenEXR instead, equal to
 * rayd-render --format's; only this route takes it, so the immutable image
 * URL of a kept scene stays a PNG.  ?format=sums&samples=K0-K1 answers the
 * exact sums of that sample range (application/x-rayd-sums), for a client
 * that spreads one frame's samples over many nodes and adds them up.  POST /v1/scenes compiles and
 * keeps a scene; its image URL is immutable (strong ETag, 304 on If-None-Match), unless the scene
 * read files: then it is revalidated (no-cache), and a file changed since the scene was compiled
 * makes the id unknown here until the text is sent again (scenefiles.c).
 *
 * The wait: a small struct ties the work layer's waiter to the request.
 * Its suspend callback suspends the connection (called by the work layer
 * under its lock, before any worker can answer); its done callback turns
 * the result into the reply and resumes the connection.  So the work layer
 * answers a connection without knowing what one is, and the request flows
 * one way: handler -> work, then back only through those two callbacks.
 */
#include "api/api.h"

#include <cjson/cJSON.h>
#include <stdlib.h>
#include <string.h>

struct api_render_wait {
    struct work_waiter w; /* first: the callbacks get it back */
    struct http_req *r;
    enum work_format format;
    struct api_price price;
    bool unlit; /* the scene gives no light: the reply says so */
};

/* The image reply: its type, the cache headers, the price, Vary: Accept
 * where the Accept header can choose the format, and a warning when the
 * image is black for want of light (the user sees why). */
static void api_render_reply(struct http_req *r, struct blob *img, enum work_format format,
                             const struct api_price *price, bool unlit) {
    http_reply_image(r, 200, img, api_format_type(format));
    if (unlit) http_reply_header(r, "X-Rayd-Warning", API_UNLIT_WARNING);
    http_reply_cache_headers(r);
    api_cost_price_headers(r, price);
    if (r->route.negotiates) http_reply_vary(r, "Accept");
}

/* The worker's answer (or the watcher's "gone"): the reply, then resume. */
static void api_render_done(struct work_waiter *w, struct work_result *res) {
    struct api_render_wait a = *(struct api_render_wait *)w;
    struct http_req *r = a.r;
    free(w);
    r->res.times = res->times;
    if (res->gone) {
        r->gone = true;
        r->res.note = "client_gone";
    } else if (res->status == RAYD_OK && res->png) {
        api_render_reply(r, res->png, a.format, &a.price, a.unlit);
    } else {
        struct rayd_error e = res->err;
        e.code = res->status;
        api_reply_rayd_error(r, &e, res->draining);
    }
    blob_unref(res->png);
    http_req_resume(r);
}

static void api_render_suspend(struct work_waiter *w) {
    api_suspend(((struct api_render_wait *)w)->r);
}

/* Renders what of scene for r: priced (and refused if over budget and not
 * in the result cache), answered at once from the result cache, or
 * suspended until a worker answers (true: r is the worker's now), or
 * refused with a 503. */
static bool api_render_submit(struct http_req *r, struct cache_entry *scene,
                              struct work_target *what) {
    enum work_format format = what->format;
    struct api_price price;
    char limit[160];
    struct blob *png = NULL;
    if (!api_cost_price(r, scene, what, false, &price, limit, sizeof limit)) {
        /* over a budget, unless it costs nothing: already in the result cache */
        if ((png = sched_result_find(scene, what))) {
            api_render_reply(r, png, format, &price, api_unlit(cache_scene(scene)));
            blob_unref(png);
            r->res.note = "result_cache";
        } else {
            api_cost_over_budget(r, &price, limit);
        }
        return false;
    }
    struct api_render_wait *a = calloc(1, sizeof *a);
    if (!a) {
        api_refused(r, WORK_NOMEM);
        return false;
    }
    a->r = r;
    a->format = format;
    a->price = price;
    a->unlit = api_unlit(cache_scene(scene));
    a->w.done = api_render_done;
    a->w.suspend = api_render_suspend;
    a->w.fd = http_req_fd(r);
    enum work_submit s = sched_render(scene, what, &a->w, &png, NULL);
    if (s == WORK_OK) return true; /* a belongs to the work layer until done() */
    free(a);
    if (s == WORK_CACHED) {
        api_render_reply(r, png, format, &price, api_unlit(cache_scene(scene)));
        blob_unref(png);
        r->res.note = "result_cache";
    } else {
        api_refused(r, s);
    }
    return false;
}

/* POST /v1/render once its scene is compiled (api_scene's continuation). */
static bool api_render_scene(struct http_req *r, struct cache_entry *e, bool hit) {
    (void)hit;
    struct work_target what;
    return api_target(r, cache_scene(e), &what) && api_render_submit(r, e, &what);
}

void api_render_post(struct http_req *r, const char *id) {
    (void)id;
    r->route.negotiates = true;
    api_scene(r, api_render_scene);
}

/* What a kept scene is: its id, size and objects. */
static cJSON *api_scene_json(struct cache_entry *e) {
    struct rayd_scene_info info;
    rayd_scene_info(cache_scene(e), &info);
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "id", cache_id(e));
    cJSON_AddNumberToObject(o, "width", info.width);
    cJSON_AddNumberToObject(o, "height", info.height);
    cJSON_AddNumberToObject(o, "objects", (double)info.objects);
    return o;
}

/* POST /v1/scenes once its scene is compiled: 201 and what it is; 413
 * when it is too big for the cache to keep (a 201 whose id then answered
 * 404 scene_unknown at once). */
static bool api_scenes_created(struct http_req *r, struct cache_entry *e, bool hit) {
    if (!cache_fits(e)) {
        char msg[300];
        snprintf(msg, sizeof msg,
                 "the compiled scene is %zu bytes, more than the scene cache keeps (--cache-mb "
                 "%ld), so it cannot be kept for GET /v1/scenes/{id}; POST it to /v1/render or "
                 "/v1/jobs instead",
                 cache_bytes(e), config.cache_mb);
        http_reply_error(r, 413, "too_large", msg, NULL, 0, 0, NULL);
        return false;
    }
    cJSON *o = api_scene_json(e);
    cJSON_AddBoolToObject(o, "cached", hit);
    char loc[128];
    snprintf(loc, sizeof loc, "/v1/scenes/%s", cache_id(e));
    http_reply_json(r, 201, o);
    http_reply_header(r, "Location", loc);
    return false;
}

void api_scenes_post(struct http_req *r, const char *id) {
    (void)id;
    if (api_only_params(r, NULL)) api_scene(r, api_scenes_created);
}

/* If-None-Match: a list of entity tags or "*"; weak comparison. */
static bool api_etag_match(const char *inm, const char *etag) {
    size_t el = strlen(etag), n;
    const char *p = inm, *item;
    while (p && http_req_list_next(&p, &item, &n)) {
        if (item[0] == '*') return true;
        if (n >= 2 && !strncmp(item, "W/", 2)) item += 2, n -= 2;
        if (n == el && !memcmp(item, etag, el)) return true;
    }
    return false;
}

/* GET /v1/scenes/{id}/image.png with the scene found (e referenced for
 * the call, or NULL): the image, 304, or a 404; true when a render took r. */
static bool api_scenes_image_of(struct http_req *r, struct cache_entry *e) {
    if (!e) {
        http_reply_error(r, 404, "scene_unknown",
                         "this server does not hold that scene; POST it to /v1/scenes", NULL, 0, 0,
                         NULL);
        return false;
    }
    struct rayd_region reg;
    if (!api_region(r, cache_scene(e), &reg)) return false;
    /* the bytes depend on the version that draws them and the deflate
     * that encodes them (library, version, level), not only on the scene
     * (its text and the files it read: cache_version) and region: a strong
     * ETag names bytes.  The image of a scene that read files changes when
     * they do, so a cache must ask again (revalidate) before each use. */
    char key[240], hex[65];
    snprintf(key, sizeof key, "%s@%d,%d,%d,%d@%s,%s", cache_version(e), reg.x, reg.y, reg.w, reg.h,
             RAYD_VERSION, rayd_png_encoder((int)config.png_level));
    if (cache_hash(key, strlen(key), hex)) snprintf(r->res.etag, sizeof r->res.etag, "\"%s\"", hex);
    r->res.etag_revalidate = rayd_scene_files(cache_scene(e)) > 0;
    const char *inm = http_req_header(r, "If-None-Match");
    if (inm && api_etag_match(inm, r->res.etag)) {
        http_reply_not_modified(r);
    } else if (sched_draining()) {
        api_refused(r, WORK_DRAINING);
    } else if (!strcmp(r->method, "HEAD")) {
        /* the headers without the render (RFC 9110 section 9.3.2): the
         * PNG's size is known only once drawn, so no Content-Length */
        http_reply_head(r, 200, "image/png");
        http_reply_cache_headers(r);
    } else {
        struct rayd_scene_info info; /* the scene's own render.denoise */
        rayd_scene_info(cache_scene(e), &info);
        struct work_target what = {.reg = reg, .format = WORK_PNG, .denoise = info.denoise != 0};
        return api_render_submit(r, e, &what);
    }
    return false;
}

/* What a GET of a kept scene answers once the scene is found (e, or NULL:
 * not held): true when a render took r. */
typedef bool (*api_scene_answer)(struct http_req *r, struct cache_entry *e);

/* A GET waiting on a parse thread for the check of its scene's files. */
struct api_find_wait {
    struct compile_waiter w; /* first: the callbacks get it back */
    struct http_req *r;
    api_scene_answer answer;
};

static void api_find_done(struct compile_waiter *w, struct compile_result *res) {
    struct api_find_wait *a = (struct api_find_wait *)w;
    struct http_req *r = a->r;
    api_scene_answer answer = a->answer;
    free(w);
    bool handed = false;
    if (res->draining)
        api_refused(r, WORK_DRAINING);
    else
        handed = answer(r, res->scene);
    scenes_release(res->scene);
    if (!handed) http_req_resume(r);
}

static void api_find_suspend(struct compile_waiter *w) {
    http_req_suspend(((struct api_find_wait *)w)->r);
}

/* GET of the kept scene id: answer once it is found (its files checked on a
 * parse thread when it read any). */
static void api_scenes_find(struct http_req *r, const char *id, api_scene_answer answer) {
    if (!api_is_hex(id, 64)) {
        answer(r, NULL);
        return;
    }
    snprintf(r->res.scene, sizeof r->res.scene, "%s",
             id); /* for the access log, known here or not */
    struct api_find_wait *a = calloc(1, sizeof *a);
    if (!a) {
        api_refused(r, WORK_NOMEM);
        return;
    }
    a->r = r;
    a->answer = answer;
    a->w.done = api_find_done;
    a->w.suspend = api_find_suspend;
    a->w.client = api_cost_client(r);
    struct compile_result res;
    enum work_submit s = compile_find_scene(id, &a->w, &res);
    if (s == WORK_OK) return; /* a belongs to the parse pool until done() */
    free(a);
    if (s == WORK_CACHED) {
        answer(r, res.scene);
        scenes_release(res.scene);
    } else {
        api_refused(r, s);
    }
}

void api_scenes_image(struct http_req *r, const char *id) {
    api_scenes_find(r, id, api_scenes_image_of);
}

/* GET /v1/scenes/{id}: what POST /v1/scenes answered, with the image's URL. */
static bool api_scenes_about(struct http_req *r, struct cache_entry *e) {
    if (!e) return api_scenes_image_of(r, NULL); /* its 404 */
    char url[128];
    snprintf(url, sizeof url, "/v1/scenes/%s/image.png", cache_id(e));
    cJSON *o = api_scene_json(e);
    cJSON_AddStringToObject(o, "image_url", url);
    http_reply_json(r, 200, o);
    return false;
}

void api_scenes_get(struct http_req *r, const char *id) {
    if (api_only_params(r, NULL)) api_scenes_find(r, id, api_scenes_about);
}
