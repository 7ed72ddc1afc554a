/* router.c -- method + path pattern -> handler, in one table.
 *
 * Patterns are literal paths in which one segment may be "{id}": it matches
 * one non-empty path segment of at most 64 characters and is passed to the
 * handler (the handlers check its form: an unknown id is their 404).  The
 * table is scanned in order; the first row whose pattern matches the path
 * and whose method matches the request wins.  A path matched only under
 * other methods is a 405 with an Allow header listing them; a path matched
 * by no row is a 404.  HEAD is served as GET (libmicrohttpd drops the body).
 * The route label of the request metrics and the access log's route is the
 * pattern ("/v1/scenes/{id}/image.png"), never the path with its ids, so
 * the number of series stays fixed; the method is a label of its own.  A
 * request is labelled by its first row with that pattern (router_find, also
 * for the 401, 405, 413 and OPTIONS answers given before or instead of a
 * handler), and the labels are handed to metrics.c once at start-up
 * (router_start), so the metrics module never reads this table.
 *
 * Which paths are open without a token is routing knowledge too
 * (router_public): the transport asks before it checks the token.
 */
#include "route/router.h"
#include "api/api.h"

#include <string.h>

typedef void (*router_handler)(struct http_req *r, const char *id);

struct route {
    const char *method;
    const char *pattern;
    router_handler fn;
    const char *name;
    /* NULL, or whether the {id} names something the row serves: a row of
     * files matches only the files that exist, so another row (or a 404)
     * answers the rest */
    bool (*exists)(const char *id);
};

static const struct route router_table[] = {
    {"POST", "/v1/render", api_render_post, "/v1/render", NULL},
    {"POST", "/v1/scenes", api_scenes_post, "/v1/scenes", NULL},
    {"GET", "/v1/scenes/{id}", api_scenes_get, "/v1/scenes/{id}", NULL},
    {"GET", "/v1/scenes/{id}/image.png", api_scenes_image, "/v1/scenes/{id}/image.png", NULL},
    {"POST", "/v1/jobs", api_jobs_post, "/v1/jobs", NULL},
    {"GET", "/v1/jobs", api_jobs_list, "/v1/jobs", NULL},
    {"GET", "/v1/jobs/{id}", api_jobs_get, "/v1/jobs/{id}", NULL},
    {"DELETE", "/v1/jobs/{id}", api_jobs_delete, "/v1/jobs/{id}", NULL},
    {"POST", "/v1/jobs/{id}/stop", api_jobs_stop, "/v1/jobs/{id}/stop", NULL},
    {"GET", "/v1/jobs/{id}/image.png", api_jobs_image, "/v1/jobs/{id}/image.png", NULL},
    {"GET", "/v1/jobs/{id}/image.exr", api_jobs_exr, "/v1/jobs/{id}/image.exr", NULL},
    {"GET", "/v1/jobs/{id}/events", api_events_get, "/v1/jobs/{id}/events", NULL},
    {"GET", "/v1/jobs/{id}/frames/{id}", api_cluster_frame, "/v1/jobs/{id}/frames/{k}", NULL},
    {"GET", "/v1/jobs/{id}/video.mp4", api_cluster_video, "/v1/jobs/{id}/video.mp4", NULL},
    {"GET", "/healthz", api_health_live, "/healthz", NULL},
    {"GET", "/readyz", api_health_ready, "/readyz", NULL},
    {"GET", "/metrics", api_health_metrics, "/metrics", NULL},
    {"GET", "/v1/test/gate", api_test_gate_get, "/v1/test/gate", NULL},
    {"POST", "/v1/test/gate", api_test_gate_post, "/v1/test/gate", NULL},
    {"GET", "/", api_web_index, "/", NULL},
    {"GET", "/{id}", api_web_asset, "/{asset}", api_web_exists},
};

#define ROUTER_N ((int)(sizeof router_table / sizeof router_table[0]))

/* The label index of row i: the first row with the same pattern. */
static int router_label(int i) {
    for (int j = 0; j < i; j++)
        if (!strcmp(router_table[j].pattern, router_table[i].pattern)) return j;
    return i;
}

void router_start(void) {
    for (int i = 0; i < ROUTER_N; i++)
        if (router_label(i) == i) metrics_route_name(i, router_table[i].name);
}

/* The probes, and the preview's own static files (a browser cannot send a
 * bearer token to open a page; the page then sends the token it is given
 * with every API call). */
bool router_public(const char *method, const char *url) {
    if (!strcmp(url, "/healthz") || !strcmp(url, "/readyz")) return true;
    if (strcmp(method, "GET") && strcmp(method, "HEAD")) return false;
    return !strcmp(url, "/") || (url[0] == '/' && !strchr(url + 1, '/') && api_web_exists(url + 1));
}

/* Matches path against pattern; the {id} segment is copied to id.  A
 * second {id} (a job's frame: /v1/jobs/{id}/frames/{id}) is appended to the
 * first after a '/', so the handler gets "JOB/7.png". */
static bool router_match(const char *pattern, const char *path, char *id, size_t idsize) {
    size_t used = 0;
    while (*pattern) {
        if (!strncmp(pattern, "{id}", 4)) {
            const char *e = path;
            while (*e && *e != '/') e++;
            size_t n = (size_t)(e - path);
            if (used) id[used++] = '/';
            if (n == 0 || used + n >= idsize) return false;
            memcpy(id + used, path, n);
            used += n;
            id[used] = 0;
            path = e;
            pattern += 4;
            continue;
        }
        if (*pattern != *path) return false;
        pattern++;
        path++;
    }
    return *path == 0;
}

/* Whether row i serves path (a row of files only a file that exists); the
 * id in the path, if any, into id. */
static bool router_row_matches(int i, const char *path, char *id, size_t size) {
    return router_match(router_table[i].pattern, path, id, size) &&
           (!router_table[i].exists || router_table[i].exists(id));
}

int router_find(const char *url) {
    char id[80];
    for (int i = 0; i < ROUTER_N; i++)
        if (router_row_matches(i, url, id, sizeof id)) return router_label(i);
    return -1;
}

const char *router_allow(const char *path, char *buf, size_t size) {
    char id[80];
    size_t n = 0;
    buf[0] = 0;
    for (int i = 0; i < ROUTER_N; i++) {
        if (!router_row_matches(i, path, id, sizeof id)) continue;
        const char *m = router_table[i].method;
        if (strstr(buf, m)) continue;
        n += (size_t)snprintf(buf + n, size > n ? size - n : 0, "%s%s", n ? ", " : "", m);
        if (!strcmp(m, "GET")) n += (size_t)snprintf(buf + n, size > n ? size - n : 0, ", HEAD");
    }
    if (n == 0) return NULL;
    snprintf(buf + n, size > n ? size - n : 0, ", OPTIONS");
    return buf;
}

/* The row that serves r's method and path, or -1; its {id} segment into
 * r->route.id, and r->route.path_known tells whether some row has the path
 * (then a 405).  Looked up once per request: router_refuse (at the headers)
 * and router_dispatch (with the body) read the same answer from r. */
static int router_row_of(struct http_req *r) {
    if (r->route.done) return r->route.row;
    const char *method = strcmp(r->method, "HEAD") ? r->method : "GET";
    char id[sizeof r->route.id];
    r->route.done = true;
    r->route.row = -1;
    r->route.path_known = false;
    r->route.id[0] = 0;
    for (int i = 0; i < ROUTER_N; i++) {
        if (!router_row_matches(i, r->url, id, sizeof id)) continue;
        if (!strcmp(router_table[i].method, method)) {
            r->route.label = router_label(i);
            r->route.row = i;
            memcpy(r->route.id, id, sizeof id);
            return i;
        }
        if (!r->route.path_known) r->route.label = router_label(i);
        r->route.path_known = true;
    }
    return -1;
}

/* 404, or 405 with Allow when the path is known. */
static void router_refuse_reply(struct http_req *r) {
    if (r->route.path_known) {
        char allow[128], msg[240];
        router_allow(r->url, allow, sizeof allow);
        /* the method is a token (http_flow.c), but of any length: cut */
        snprintf(msg, sizeof msg, "method %.40s not allowed here; allowed: %s", r->method, allow);
        http_reply_error(r, 405, "method_not_allowed", msg, NULL, 0, 0, NULL);
        http_reply_header(r, "Allow", allow);
        return;
    }
    api_not_found(r);
}

bool router_refuse(struct http_req *r) {
    if (router_row_of(r) >= 0) return false;
    router_refuse_reply(r);
    return true;
}

void router_dispatch(struct http_req *r) {
    int i = router_row_of(r);
    if (i >= 0)
        router_table[i].fn(r, r->route.id);
    else
        router_refuse_reply(r);
}
