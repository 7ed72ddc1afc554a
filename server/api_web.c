/* api_web.c -- the browser preview: GET / and the files beside it.
 *
 * The files of server/web/ are compiled into the binary by tools/embed.sh
 * (build/server/web_assets.h), so rayd serves its preview with nothing on
 * disk.  GET / is index.html; GET /NAME serves another embedded file.  The
 * content type follows the file extension.
 */
#include "api.h"

#include <string.h>

#include "web_assets.h"

static const struct web_asset *api_web_find(const char *name)
{
    for (const struct web_asset *a = web_assets; a->name; a++)
        if (!strcmp(a->name, name))
            return a;
    return NULL;
}

bool api_web_exists(const char *name) { return api_web_find(name) != NULL; }

static const char *api_web_type(const char *name)
{
    const char *dot = strrchr(name, '.');
    if (!dot)
        return "application/octet-stream";
    if (!strcmp(dot, ".html"))
        return "text/html; charset=utf-8";
    if (!strcmp(dot, ".js"))
        return "text/javascript; charset=utf-8";
    if (!strcmp(dot, ".css"))
        return "text/css; charset=utf-8";
    if (!strcmp(dot, ".json"))
        return "application/json";
    if (!strcmp(dot, ".png"))
        return "image/png";
    if (!strcmp(dot, ".svg"))
        return "image/svg+xml";
    if (!strcmp(dot, ".ico"))
        return "image/x-icon";
    return "application/octet-stream";
}

static void api_web_send(struct http_req *r, const char *name)
{
    const struct web_asset *a = api_web_find(name);
    if (!a) {
        api_not_found(r);
        return;
    }
    http_reply_data(r, 200, api_web_type(name), a->data, a->len);
    http_reply_header(r, "Cache-Control", "no-cache");
}

void api_web_index(struct http_req *r, const char *id)
{
    (void)id;
    api_web_send(r, "index.html");
}

void api_web_asset(struct http_req *r, const char *id) { api_web_send(r, id); }
