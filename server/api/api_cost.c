/* api_cost.c -- who asks, and what their render will cost: the handlers'
 * side of fair shares and work budgets.
 *
 * Every render is priced before it is queued (cost.c: estimated rays from
 * the scene's description, seconds at this node's measured rate).  Two
 * budgets refuse it there, with 413 over_budget and a message naming the
 * estimate and the limit, instead of letting it hold workers until
 * --max-render-seconds stops it:
 *   - --max-work N, in estimated rays: the operator's budget, the same
 *     answer on every node;
 *   - a plain render whose estimated time is more than API_DEADLINE_SLACK
 *     times --max-render-seconds: it would be stopped anyway.  (The slack
 *     covers the estimate's error, which errs high.  A progressive job is
 *     not refused this way: the deadline ends it with its latest pass.)
 * The seconds are at the scene's own measured rate (cost.c), so another
 * client's heavy scene does not change them.  A render the result cache
 * can answer is never refused for its cost (api_render.c looks there
 * before it refuses): it costs nothing.  The price goes back with the
 * answer (X-Rayd-Estimated-Rays and X-Rayd-Estimated-Seconds, and the
 * job's status), so a client can see what it asked for.
 *
 * Who asks: fair.c serves clients in turn, and a client is named here, by
 * the peer's address (an IPv6 peer by its /64), or by the header --client-header names when a
 * balancer in front of rayd sets it (X-Real-IP, or a tenant id); rayd
 * cannot tell a forged header, so only a trusted balancer should set it.
 * The name is hashed to 64 bits (FNV-1a): only equality matters.
 */
#include "api/api.h"

#include <arpa/inet.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>

#define API_DEADLINE_SLACK 4.0

static uint64_t api_cost_fnv(const void *p, size_t n) {
    const unsigned char *b = p;
    uint64_t h = 0xcbf29ce484222325ull;
    for (size_t i = 0; i < n; i++) h = (h ^ b[i]) * 0x100000001b3ull;
    return h;
}

/* The client r comes from (--client-header, else the peer address), hashed. */
uint64_t api_cost_client(struct http_req *r) {
    const char *v = config.client_header ? http_req_header(r, config.client_header) : NULL;
    if (v && *v) return api_cost_fnv(v, strlen(v));
    struct sockaddr_storage ss;
    socklen_t len = sizeof ss;
    int fd = http_req_fd(r);
    if (fd < 0 || getpeername(fd, (struct sockaddr *)&ss, &len) != 0) return 0;
    if (ss.ss_family == AF_INET)
        return api_cost_fnv(&((struct sockaddr_in *)&ss)->sin_addr, sizeof(struct in_addr));
    if (ss.ss_family == AF_INET6) /* a /64 is one host's: it could mint addresses */
        return api_cost_fnv(&((struct sockaddr_in6 *)&ss)->sin6_addr, 8);
    return 0;
}

void api_cost_over_budget(struct http_req *r, const struct api_price *p, const char *limit) {
    char msg[320];
    snprintf(msg, sizeof msg,
             "the render's estimated cost is %.3g rays (about %.3g s on this server), over %s; "
             "ask for fewer pixels, samples, bounces or light samples",
             p->rays, p->seconds, limit);
    metrics_reject(MR_OVER_BUDGET);
    http_reply_error(r, 413, "over_budget", msg, NULL, 0, 0, NULL);
}

bool api_cost_price(struct http_req *r, const struct cache_entry *scene, struct work_target *what,
                    bool progressive, struct api_price *out, char *limit, size_t n) {
    what->client = api_cost_client(r);
    out->rays = cost_rays(cache_scene(scene), what);
    out->seconds = cost_price_seconds(cache_id(scene), out->rays);
    if (config.max_work > 0 && out->rays > (double)config.max_work) {
        struct rayd_scene_info info;
        rayd_scene_info(cache_scene(scene), &info);
        if (what->frame) /* a frame-range job's frame parses its scene again */
            snprintf(limit, n,
                     "the server's budget of %ld rays (--max-work) a frame; of it the frame's "
                     "parse of the scene is %.3g",
                     config.max_work, info.frame_work);
        else
            snprintf(limit, n, "the server's budget of %ld rays (--max-work)", config.max_work);
        return false;
    }
    double deadline = (double)config.max_render_seconds;
    if (!progressive && deadline > 0 && out->seconds > API_DEADLINE_SLACK * deadline) {
        snprintf(limit, n, "%.0f times the server's limit of %ld s a render (--max-render-seconds)",
                 API_DEADLINE_SLACK, config.max_render_seconds);
        return false;
    }
    return true;
}

bool api_cost_admit(struct http_req *r, const struct cache_entry *scene, struct work_target *what,
                    bool progressive, struct api_price *out) {
    char limit[160];
    if (api_cost_price(r, scene, what, progressive, out, limit, sizeof limit)) return true;
    api_cost_over_budget(r, out, limit);
    return false;
}

void api_cost_price_headers(struct http_req *r, const struct api_price *p) {
    char v[64];
    snprintf(v, sizeof v, "%.0f", p->rays);
    http_reply_header(r, "X-Rayd-Estimated-Rays", v);
    snprintf(v, sizeof v, "%.3f", p->seconds);
    http_reply_header(r, "X-Rayd-Estimated-Seconds", v);
}

int api_cost_retry_after(double seconds) {
    if (!(seconds >= 1)) return 1;
    return seconds > 600 ? 600 : (int)ceil(seconds);
}
