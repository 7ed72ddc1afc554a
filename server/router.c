/* router.c -- method + path pattern -> handler, in one table.
 *
 * Patterns are literal paths in which one segment may be "{id}": it matches
 * one non-empty path segment of at most 64 characters and is passed to the
 * handler (the handlers check its form: an unknown id is their 404).  The
 * table is scanned in order; the first row whose pattern matches the path
 * and whose method matches the request wins.  A path matched only under
 * other methods is a 405 with an Allow header listing them; a path matched
 * by no row is a 404.  HEAD is served as GET (libmicrohttpd drops the body).
 * The row index doubles as the route label of the request metrics; the
 * labels are handed to metrics.c once at start-up (router_start), so the
 * metrics module never reads this table.
 *
 * Which paths are open without a token is routing knowledge too
 * (router_public): the transport asks before it checks the token.
 */
#include "router.h"
#include "api.h"

#include <string.h>

typedef void (*router_handler)(struct http_req *r, const char *id);

struct route {
    const char *method;
    const char *pattern;
    router_handler fn;
    const char *name;
};

static const struct route router_table[] = {
    {"POST", "/v1/render", api_render_post, "POST /v1/render"},
    {"POST", "/v1/scenes", api_scenes_post, "POST /v1/scenes"},
    {"GET", "/v1/scenes/{id}/image.png", api_scenes_image, "GET /v1/scenes/{id}/image.png"},
    {"POST", "/v1/jobs", api_jobs_post, "POST /v1/jobs"},
    {"GET", "/v1/jobs/{id}", api_jobs_get, "GET /v1/jobs/{id}"},
    {"DELETE", "/v1/jobs/{id}", api_jobs_delete, "DELETE /v1/jobs/{id}"},
    {"POST", "/v1/jobs/{id}/stop", api_jobs_stop, "POST /v1/jobs/{id}/stop"},
    {"GET", "/v1/jobs/{id}/image.png", api_jobs_image, "GET /v1/jobs/{id}/image.png"},
    {"GET", "/v1/jobs/{id}/events", api_jobs_events, "GET /v1/jobs/{id}/events"},
    {"GET", "/healthz", api_health_live, "GET /healthz"},
    {"GET", "/readyz", api_health_ready, "GET /readyz"},
    {"GET", "/metrics", api_health_metrics, "GET /metrics"},
    {"GET", "/v1/test/gate", api_test_gate_get, "GET /v1/test/gate"},
    {"POST", "/v1/test/gate", api_test_gate_post, "POST /v1/test/gate"},
    {"GET", "/", api_web_index, "GET /"},
    {"GET", "/{id}", api_web_asset, "GET /{asset}"},
};

#define ROUTER_N ((int)(sizeof router_table / sizeof router_table[0]))

void router_start(void)
{
    for (int i = 0; i < ROUTER_N; i++)
        metrics_route_name(i, router_table[i].name);
}

/* The probes, and the preview's own static files (a browser cannot send a
 * bearer token to open a page; the page then sends the token it is given
 * with every API call). */
bool router_public(const char *method, const char *url)
{
    if (!strcmp(url, "/healthz") || !strcmp(url, "/readyz"))
        return true;
    if (strcmp(method, "GET") && strcmp(method, "HEAD"))
        return false;
    return !strcmp(url, "/") || (url[0] == '/' && !strchr(url + 1, '/') && api_web_exists(url + 1));
}

/* Matches path against pattern; the {id} segment is copied to id. */
static bool router_match(const char *pattern, const char *path, char *id, size_t idsize)
{
    while (*pattern) {
        if (!strncmp(pattern, "{id}", 4)) {
            const char *e = path;
            while (*e && *e != '/')
                e++;
            size_t n = (size_t)(e - path);
            if (n == 0 || n >= idsize)
                return false;
            memcpy(id, path, n);
            id[n] = 0;
            path = e;
            pattern += 4;
            continue;
        }
        if (*pattern != *path)
            return false;
        pattern++;
        path++;
    }
    return *path == 0;
}

const char *router_allow(const char *path, char *buf, size_t size)
{
    char id[80];
    size_t n = 0;
    buf[0] = 0;
    for (int i = 0; i < ROUTER_N; i++) {
        if (!router_match(router_table[i].pattern, path, id, sizeof id) ||
            (router_table[i].fn == api_web_asset && !api_web_exists(id)))
            continue;
        const char *m = router_table[i].method;
        if (strstr(buf, m))
            continue;
        n += (size_t)snprintf(buf + n, size > n ? size - n : 0, "%s%s", n ? ", " : "", m);
        if (!strcmp(m, "GET"))
            n += (size_t)snprintf(buf + n, size > n ? size - n : 0, ", HEAD");
    }
    if (n == 0)
        return NULL;
    n += (size_t)snprintf(buf + n, size > n ? size - n : 0, ", OPTIONS");
    return buf;
}

void router_dispatch(struct http_req *r)
{
    const char *method = strcmp(r->method, "HEAD") ? r->method : "GET";
    char id[80];
    bool path_known = false;
    for (int i = 0; i < ROUTER_N; i++) {
        if (!router_match(router_table[i].pattern, r->url, id, sizeof id) ||
            (router_table[i].fn == api_web_asset && !api_web_exists(id)))
            continue;
        if (!strcmp(router_table[i].method, method)) {
            r->route = i;
            router_table[i].fn(r, id);
            return;
        }
        if (!path_known)
            r->route = i;
        path_known = true;
    }
    if (path_known) {
        char allow[128], msg[200];
        router_allow(r->url, allow, sizeof allow);
        snprintf(msg, sizeof msg, "method %s not allowed here; allowed: %s", r->method, allow);
        http_reply_error(r, 405, "method_not_allowed", msg, NULL, 0, 0, NULL);
        http_reply_header(r, "Allow", allow);
        return;
    }
    http_reply_error(r, 404, "not_found", "no such resource", NULL, 0, 0, NULL);
}
