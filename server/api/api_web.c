/* api_web.c -- the browser preview: GET / and the files beside it.
 *
 * The files of server/web/ are compiled into the binary by tools/embed.sh
 * (build/server/web_assets.h), so rayd serves its preview with nothing on
 * disk.  GET / is index.html; GET /NAME serves another embedded file.  The
 * content type follows the file extension.
 *
 * The page holds the user's bearer token (typed once, kept in the browser's
 * local storage) and sends it with every request it makes, so it must never
 * act for another site.  A page elsewhere that framed the preview with a
 * #scene= link used to make it render that scene with the token, with no
 * click.  The page itself now waits for the user's Render on a linked scene
 * (app.js); here every file of the preview carries the headers that keep
 * other sites out: frame-ancestors 'none' and X-Frame-Options: DENY (no
 * frame, so no clickjacking either), a Content-Security-Policy that allows
 * only the page's own files and requests to this server (the page has no
 * inline script or style, and talks to no other host: every URL it fetches
 * is relative), no Referer (a link's scene is in the fragment, which is
 * never sent, but the path may name things), and its own browsing context
 * group (Cross-Origin-Opener-Policy), so a window that opened it cannot
 * reach it or change its #scene.  The files are only for this page:
 * Cross-Origin-Resource-Policy keeps other sites from loading them.
 */
#include "api/api.h"

#include <string.h>

#include "web_assets.h"

static const struct web_asset *api_web_find(const char *name) {
    for (const struct web_asset *a = web_assets; a->name; a++)
        if (!strcmp(a->name, name)) return a;
    return NULL;
}

bool api_web_exists(const char *name) { return api_web_find(name) != NULL; }

static const char *api_web_type(const char *name) {
    const char *dot = strrchr(name, '.');
    if (!dot) return "application/octet-stream";
    if (!strcmp(dot, ".html")) return "text/html; charset=utf-8";
    if (!strcmp(dot, ".js")) return "text/javascript; charset=utf-8";
    if (!strcmp(dot, ".css")) return "text/css; charset=utf-8";
    if (!strcmp(dot, ".json")) return "application/json";
    if (!strcmp(dot, ".png")) return "image/png";
    if (!strcmp(dot, ".svg")) return "image/svg+xml";
    if (!strcmp(dot, ".ico")) return "image/x-icon";
    return "application/octet-stream";
}

/* The page's policy: its own files, requests to this origin only.  The
 * canvas draws tiles from fetched bytes (createImageBitmap), not from <img>
 * URLs.  The Jobs tab's thumbnails are <img>s of blob: URLs: the page
 * fetches them itself, since an <img src> could not send the token, and a
 * blob: URL is made only by the page's own script from bytes it fetched
 * from this origin.  No data:. */
#define API_WEB_CSP                                                                                \
    "default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' blob:; "              \
    "connect-src 'self'; object-src 'none'; frame-src 'none'; worker-src 'none'; "                 \
    "frame-ancestors 'none'; base-uri 'none'; form-action 'none'"

static void api_web_headers(struct http_req *r) {
    http_reply_header(r, "Content-Security-Policy", API_WEB_CSP);
    http_reply_header(r, "X-Frame-Options", "DENY");
    http_reply_header(r, "Referrer-Policy", "no-referrer");
    http_reply_header(r, "Cross-Origin-Opener-Policy", "same-origin");
    http_reply_header(r, "Cross-Origin-Resource-Policy", "same-origin");
}

static void api_web_send(struct http_req *r, const char *name) {
    const struct web_asset *a = api_web_find(name);
    if (!a) {
        api_not_found(r);
        return;
    }
    http_reply_data(r, 200, api_web_type(name), a->data, a->len);
    http_reply_header(r, "Cache-Control", "no-cache");
    api_web_headers(r);
}

void api_web_index(struct http_req *r, const char *id) {
    (void)id;
    api_web_send(r, "index.html");
}

void api_web_asset(struct http_req *r, const char *id) { api_web_send(r, id); }
