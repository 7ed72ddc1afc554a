/* tiles.c -- one frame rendered as tiles over many rayd servers.
 *
 * The frame is cut into a grid of tiles (--tile, 128 pixels by default; the
 * last row and column are smaller).  Every tile is an independent HTTP
 * request, and every server can render every tile, because rendering is a
 * pure function of the scene bytes and the pixel: the stitched frame equals
 * a single-machine render byte for byte.  Distribution, retries and
 * stitching are all here; there is no cluster protocol.
 *
 * Requests.  A server first learns the scene once: POST /v1/scenes with the
 * body (the compiled scene is cached there under its SHA-256).  Tiles are
 * then cheap, cacheable GETs of /v1/scenes/{id}/image.png?x=&y=&w=&h=.  When
 * a GET answers 404 scene_unknown (the node evicted the scene, restarted, or
 * the URL is a balancer and the GET reached a node that never saw it), that
 * tile is sent again at once to the same URL as POST /v1/render?x=&y=&w=&h=
 * with the body; the node that renders it compiles and caches the scene, so
 * later GETs find it.  Behind a balancer a node may thus be taught by a few
 * tiles racing at the start; with a list of servers each learns exactly once.
 *
 * Scheduling.  One libcurl multi handle drives every transfer; its
 * connection cache keeps one keep-alive connection per concurrent request
 * and server.  At most --parallel tile requests are in flight; a pending
 * tile goes to the ready server with the fewest requests in flight (not the
 * server that just failed it, if another is ready), and no server takes
 * more than its share of the slots (--parallel over the servers not
 * resting), so a server still learning the scene finds slots left.
 *
 * Failures.  A transport error, a timeout, a 5xx other than 503, or a
 * response that is not the expected PNG counts against the tile (--retries
 * further attempts) and against the server, which then rests for an
 * exponential back-off (0.5 s doubling to 10 s) so its tiles move to the
 * other servers.  A 503 (queue full, draining) is back-pressure, not a
 * fault: the server rests for its Retry-After and the tile is free to go
 * elsewhere at once.  A 4xx other than scene_unknown means the scene or the
 * request is refused; every server would say the same, so the run stops and
 * prints the server's JSON error.  When every server has failed more than
 * --retries times in a row, the remaining tiles are given up.  An image with
 * a missing tile is never written: the exit status is 1 and the message
 * names the missing tiles and the last error.
 *
 * Stragglers.  Near the end of a frame (no piece left to start) a node that
 * is slow or stalled would hold its pieces until --timeout.  So, as with
 * MapReduce's backup tasks or hedged requests, a free slot takes a copy of
 * the piece in flight the longest, once that is over twice the median time
 * of the pieces drawn so far and 1 s, to another ready server; the first
 * answer is stitched and the other request is cancelled, which is no
 * failure of its server.  Any node of one version draws the same bytes, so
 * it does not matter which answer wins.  A piece is copied at most once,
 * and while its other copy is in flight a failed copy only waits for it.
 * The end line counts the copies sent and those that won; --no-hedge
 * turns it off.  A node that stalls while pieces are left to start still
 * waits for --timeout: every slot is then better spent on a new piece.
 *
 * One failure, one error line: a refusal is said by the first answer that
 * brings it (the others in flight, each the same 4xx, are not repeated),
 * and the missing tiles and the last error share a line.  With
 * client_opts.what set (thumbnails: the model) each line names it first.
 *
 * Sample ranges (--split-samples N).  The pieces may instead be N ranges
 * of the frame's samples, each the whole image: a range is POST
 * /v1/render?format=sums&samples=K0-K1 with the body, answered with the
 * range's exact per-pixel sums (application/x-rayd-sums), which are added
 * up here (rayd_accum_add_sums).  The sums are exact whatever their
 * grouping (include/rayd/rayd.h), so the frame resolved from them is the
 * single-node render byte for byte, as a PNG or, for an -o ending in .exr,
 * an OpenEXR.  Scheduling, retries and failures are the tiles' own.
 *
 * Rays per second for the progress bar come from polling each server's
 * /metrics (rayd_rays_total) once a second; it counts all the work of those
 * servers, not only this frame's.  Behind a balancer each poll may reach
 * another node: docker/nginx.conf names the node in an X-Upstream header,
 * and the rate is kept per node so counters of different nodes are never
 * subtracted from each other.
 */
#include "client.h"

#include <curl/curl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <rayd/rayd.h>

enum tiles_state { TS_PENDING, TS_RUNNING, TS_DONE, TS_FAILED };
enum tiles_scene { SS_UNKNOWN, SS_LEARNING, SS_KNOWN };
enum tiles_kind { X_LEARN, X_GET, X_POST, X_METRICS };

struct tiles_tile {
    int x, y, w, h;
    int k0, k1; /* a sample range's samples (--split-samples) */
    enum tiles_state st;
    int attempts; /* failures counted against --retries */
    int busy;     /* 503 answers */
    int last_server;
    double not_before;
    int copies;   /* its requests in flight: 2 while hedged */
    int hedged;   /* a copy went to a second server (at most once) */
    double since; /* when its requests in flight began */
    char err[240];
};

struct tiles_server {
    const char *url;
    char label[40];
    enum tiles_scene scene;
    int inflight;      /* learn + tile requests */
    long done;         /* tiles rendered */
    long uploads;      /* times the scene body was sent and answered */
    int fails_row;     /* consecutive failures */
    double down_until; /* resting until then */
    int metrics_busy;
    double metrics_next;
    struct tiles_rays { /* per node behind this address (X-Upstream) */
        char node[64];
        double t, last, rps;
    } rays[8];
};

struct tiles_xfer {
    CURL *h;
    struct curl_slist *hdrs;
    struct net_buf body;
    enum tiles_kind kind;
    int tile, server;
    double t0;                      /* when it started */
    int hedge;                      /* the copy of a straggler (tiles_hedge) */
    struct tiles_xfer *prev, *next; /* every transfer in flight */
};

struct tiles {
    const struct client_opts *o;
    const struct scenefile *sf;
    struct tiles_tile *t;
    int n;
    struct tiles_server *s;
    int ns;
    CURLM *multi;
    int running; /* tile requests in flight */
    int done, failed;
    int fatal;
    rayd_image *img;
    rayd_accum *acc; /* --split-samples: the ranges' sums added up */
    struct progress prog;
    char last_err[400];
    char version[48]; /* X-Rayd-Version of the first piece ("" none) */
    int version_from; /* its server; -1 before the first piece */
    long *per_server;
    char (*labels)[40];
    int busy_limit;
    struct tiles_xfer *xfers;
    double *took; /* the request times of the pieces drawn, ascending */
    int ntook;
    int hedged, hedge_won;
};

/* A straggler is copied once nothing is left to start and it has been in
 * flight over TILES_HEDGE_FACTOR times the median piece and TILES_HEDGE_FLOOR
 * seconds: a loaded node's ordinary spread stays under that, a stalled one
 * does not. */
#define TILES_HEDGE_FACTOR 2.0
#define TILES_HEDGE_FLOOR 1.0

/* ---- starting requests ------------------------------------------------------ */

static int tiles_start(struct tiles *T, enum tiles_kind kind, int ti, int si) {
    struct tiles_server *s = &T->s[si];
    char url[1024];
    const char *body = NULL;
    size_t blen = 0;
    /* a GET or POST is a tile's (a range's), the others the server's */
    const struct tiles_tile *t = kind == X_GET || kind == X_POST ? &T->t[ti] : NULL;
    switch (kind) {
    case X_LEARN:
        snprintf(url, sizeof url, "%s/v1/scenes", s->url);
        body = T->sf->bytes, blen = T->sf->len;
        break;
    case X_GET:
        snprintf(url, sizeof url, "%s/v1/scenes/%s/image.png?x=%d&y=%d&w=%d&h=%d", s->url,
                 T->sf->id, t->x, t->y, t->w, t->h);
        break;
    case X_POST:
        if (T->acc)
            snprintf(url, sizeof url, "%s/v1/render?format=sums&samples=%d-%d", s->url, t->k0,
                     t->k1);
        else
            snprintf(url, sizeof url, "%s/v1/render?x=%d&y=%d&w=%d&h=%d", s->url, t->x, t->y, t->w,
                     t->h);
        body = T->sf->bytes, blen = T->sf->len;
        break;
    case X_METRICS: snprintf(url, sizeof url, "%s/metrics", s->url); break;
    }
    struct tiles_xfer *x = calloc(1, sizeof *x);
    if (!x) return -1;
    x->kind = kind, x->tile = ti, x->server = si;
    x->t0 = net_now();
    if (T->acc && t) /* a range's sums: 24 bytes a pixel */
        x->body.max = 1024 + (size_t)t->w * (size_t)t->h * 24;
    void *hdrs = NULL;
    x->h = net_easy(T->o, url, &x->body, body, blen, &hdrs);
    x->hdrs = hdrs;
    if (!x->h) {
        free(x);
        return -1;
    }
    if (kind == X_METRICS) curl_easy_setopt(x->h, CURLOPT_TIMEOUT_MS, 2000L);
    curl_easy_setopt(x->h, CURLOPT_PRIVATE, (void *)x);
    if (curl_multi_add_handle(T->multi, x->h) != CURLM_OK) {
        curl_easy_cleanup(x->h);
        curl_slist_free_all(x->hdrs);
        free(x);
        return -1;
    }
    x->next = T->xfers;
    if (x->next) x->next->prev = x;
    T->xfers = x;
    if (kind == X_METRICS) {
        s->metrics_busy = 1;
    } else {
        s->inflight++;
    }
    if (kind == X_GET || kind == X_POST) { /* a piece's (by kind, as t was chosen) */
        T->t[ti].st = TS_RUNNING;
        T->running++;
        if (T->t[ti].copies++ == 0) T->t[ti].since = x->t0;
    }
    return 0;
}

static void tiles_xfer_free(struct tiles *T, struct tiles_xfer *x) {
    if (T->xfers == x)
        T->xfers = x->next;
    else
        x->prev->next = x->next;
    if (x->next) x->next->prev = x->prev;
    curl_multi_remove_handle(T->multi, x->h);
    curl_easy_cleanup(x->h);
    curl_slist_free_all(x->hdrs);
    net_buf_free(&x->body);
    free(x);
}

/* ---- outcomes --------------------------------------------------------------- */

/* A server that worked (or was new) has just failed: one line says so,
 * since a node lost mid-frame otherwise shows only as a slower frame.  The
 * next line about it comes only after it has answered again. */
static void tiles_warn_failing(struct tiles *T, int si, const char *why) {
    if (T->o->quiet) return;
    progress_end(&T->prog); /* the bar's line, when one is drawn */
    fprintf(stderr, "rayd-client: warning: %s failed: %.300s; %s\n", T->s[si].url, why,
            T->ns > 1 ? "its tiles go to the other servers" : "retrying it");
}

static void tiles_server_failed(struct tiles *T, int si, const char *why, double now) {
    struct tiles_server *s = &T->s[si];
    s->fails_row++;
    double backoff = 0.5;
    for (int i = 1; i < s->fails_row && backoff < 10; i++) backoff *= 2;
    s->down_until = now + (backoff > 10 ? 10 : backoff);
    if (s->scene == SS_LEARNING) s->scene = SS_UNKNOWN;
    snprintf(T->last_err, sizeof T->last_err, "%.150s: %.240s", s->url, why);
    if (s->fails_row == 1) tiles_warn_failing(T, si, why);
}

static void tiles_tile_failed(struct tiles *T, int ti, int si, const char *why, double now) {
    struct tiles_tile *t = &T->t[ti];
    snprintf(t->err, sizeof t->err, "%s: %s", T->s[si].url, why);
    if (t->copies > 0) return; /* its other copy, still in flight, may yet draw it */
    t->last_server = si;
    if (++t->attempts > T->o->retries) {
        t->st = TS_FAILED;
        T->failed++;
    } else {
        t->st = TS_PENDING;
        t->not_before = now;
    }
}

/* Starts an error line: the prefix, then what the frame is when the caller
 * named it (thumbnails: the model), since the server's words do not. */
static void tiles_error(const struct tiles *T) {
    fputs("rayd-client: error: ", stderr);
    if (T->o->what) fprintf(stderr, "%s: ", T->o->what);
}

static void tiles_fatal(struct tiles *T, int si, long status, const struct net_buf *b) {
    if (T->fatal) return; /* the same refusal again, from a request that was in flight */
    char why[600];
    net_describe(status, b, why, sizeof why);
    progress_end(&T->prog); /* the bar's line, when one is drawn */
    tiles_error(T);
    fprintf(stderr, "%s refused the scene: %s\n", T->s[si].url, why);
    T->fatal = 1;
}

/* A range's sums: decode, check they are this range's, add.  0 or -1
 * with why set. */
static int tiles_add_sums(struct tiles *T, const struct tiles_tile *t, const struct net_buf *b,
                          char *why, size_t size) {
    struct rayd_sums_header hdr;
    double *sums = NULL;
    struct rayd_error err = {0};
    if (rayd_sums_decode(b->data, b->len, &hdr, &sums, &err) != RAYD_OK) {
        snprintf(why, size, "answer is not the range's sums: %s", err.message);
        return -1;
    }
    int rc = 0;
    if (hdr.width != t->w || hdr.height != t->h || hdr.k0 != t->k0 || hdr.k1 != t->k1) {
        snprintf(why, size, "sums of %dx%d samples %d..%d, expected %dx%d samples %d..%d",
                 hdr.width, hdr.height, hdr.k0, hdr.k1, t->w, t->h, t->k0, t->k1);
        rc = -1;
    } else if (rayd_accum_add_sums(T->acc, sums, t->k1 - t->k0, &err) != RAYD_OK) {
        snprintf(why, size, "adding the sums failed: %s", err.message);
        rc = -1;
    }
    rayd_free(sums);
    return rc;
}

/* A tile PNG: decode, check its size, blit.  0 or -1 with why set. */
static int tiles_stitch(struct tiles *T, struct tiles_tile *t, const struct net_buf *b, char *why,
                        size_t size) {
    if (T->acc) return tiles_add_sums(T, t, b, why, size);
    rayd_image *img = NULL;
    struct rayd_error err = {0};
    if (rayd_png_decode(b->data, b->len, (long)t->w * t->h, &img, &err) != RAYD_OK) {
        snprintf(why, size, "answer is not a PNG tile: %s", err.message);
        return -1;
    }
    int rc = 0;
    if (rayd_image_width(img) != t->w || rayd_image_height(img) != t->h) {
        snprintf(why, size, "tile is %dx%d, expected %dx%d", rayd_image_width(img),
                 rayd_image_height(img), t->w, t->h);
        rc = -1;
    } else if (rayd_image_blit(T->img, img, t->x, t->y, &err) != RAYD_OK) {
        snprintf(why, size, "stitching failed: %s", err.message);
        rc = -1;
    }
    rayd_image_free(img);
    return rc;
}

static void tiles_metrics_done(struct tiles *T, struct tiles_xfer *x, long status, double now) {
    struct tiles_server *s = &T->s[x->server];
    s->metrics_busy = 0;
    s->metrics_next = now + 1;
    if (status != 200 || !x->body.data) return;
    const char *p = strstr(x->body.data, "\nrayd_rays_total ");
    if (!p) return;
    double v = strtod(p + 17, NULL);
    char node[64] = "";
    struct curl_header *hd = NULL;
    if (curl_easy_header(x->h, "X-Upstream", 0, CURLH_HEADER, -1, &hd) == CURLHE_OK && hd)
        snprintf(node, sizeof node, "%s", hd->value);
    struct tiles_rays *r = NULL, *oldest = &s->rays[0];
    for (int i = 0; i < 8 && !r; i++) {
        if (s->rays[i].t > 0 && !strcmp(s->rays[i].node, node))
            r = &s->rays[i];
        else if (s->rays[i].t < oldest->t)
            oldest = &s->rays[i];
    }
    if (!r) {
        r = oldest;
        memset(r, 0, sizeof *r);
        snprintf(r->node, sizeof r->node, "%s", node);
    } else if (v >= r->last && now > r->t) {
        r->rps = (v - r->last) / (now - r->t);
    }
    r->last = v;
    r->t = now;
}

/* A transport failure in words: too large, timed out, or curl's. */
static void tiles_transport_why(const struct tiles *T, const struct tiles_xfer *x, CURLcode cc,
                                char *why, size_t size) {
    if (x->body.overflow)
        snprintf(why, size, "answer too large");
    else if (cc == CURLE_OPERATION_TIMEDOUT)
        snprintf(why, size, "timed out after %.0f s (%s)", T->o->timeout, curl_easy_strerror(cc));
    else
        snprintf(why, size, "%s", curl_easy_strerror(cc));
}

/* 503 or 429: the server rests for its Retry-After, and the piece t (NULL
 * for the scene's POST) waits to be sent again, unless it was turned away
 * more than busy_limit times. */
static void tiles_busy(struct tiles *T, struct tiles_xfer *x, struct tiles_tile *t, long status,
                       double now) {
    struct tiles_server *s = &T->s[x->server];
    s->down_until = now + net_retry_after(x->h, 1);
    if (s->scene == SS_LEARNING) s->scene = SS_UNKNOWN;
    if (!t || t->copies > 0) return; /* a copy still in flight may draw it */
    t->st = TS_PENDING;
    t->not_before = now;
    t->last_server = x->server;
    if (++t->busy > T->busy_limit) {
        char why[600];
        net_describe(status, &x->body, why, sizeof why);
        snprintf(t->err, sizeof t->err, "%.80s: busy %d times, last: %.120s", s->url, t->busy, why);
        t->st = TS_FAILED;
        T->failed++;
    }
}

/* A 4xx but 408: a node that lacks the scene is taught it (the same
 * piece, with the body); anything else ends the render (tiles_fatal). */
static void tiles_refused(struct tiles *T, struct tiles_xfer *x, long status, double now) {
    char code[64];
    net_error_code(&x->body, code, sizeof code);
    if (x->kind == X_GET && status == 404 && !strcmp(code, "scene_unknown")) {
        T->s[x->server].scene = SS_KNOWN;
        if (tiles_start(T, X_POST, x->tile, x->server) != 0)
            tiles_tile_failed(T, x->tile, x->server, "out of memory", now);
        else
            T->xfers->hedge = x->hedge; /* the same copy, now with the body */
        return;
    }
    tiles_fatal(T, x->server, status, &x->body);
}

/* The version that drew x's piece: X-Rayd-Version, "" from a rayd too old
 * to send it.  Two versions may draw one scene differently, so a frame is
 * stitched from one version only: the first piece sets it, and a piece of
 * another ends the run before anything is written, naming both. */
static bool tiles_same_version(struct tiles *T, const struct tiles_xfer *x) {
    struct curl_header *hd = NULL;
    const char *v = "";
    if (curl_easy_header(x->h, "X-Rayd-Version", 0, CURLH_HEADER, -1, &hd) == CURLHE_OK && hd)
        v = hd->value;
    if (T->version_from < 0) {
        snprintf(T->version, sizeof T->version, "%.40s", v);
        T->version_from = x->server;
        return true;
    }
    if (!strncmp(T->version, v, 40) && strlen(v) <= 40) return true;
    if (T->fatal) return false;
    progress_end(&T->prog);
    tiles_error(T);
    char v1[64], v0[64]; /* the servers' words: escaped */
    net_safe_n(v, 40, v1, sizeof v1);
    net_safe(T->version, v0, sizeof v0);
    fprintf(stderr,
            "%s drew a tile with %s%s, %s with %s%s: one frame needs the same rayd version "
            "on every node (and no tiles of another in a balancer's cache)\n",
            T->s[x->server].url, *v ? "rayd " : "a rayd that does not say its version", v1,
            T->s[T->version_from].url,
            *T->version ? "rayd " : "a rayd that does not say its version", v0);
    T->fatal = 1;
    return false;
}

/* Any other answer: true when it is a success (the scene learnt, or the
 * piece t stitched in), else false with why. */
static bool tiles_answered(struct tiles *T, struct tiles_xfer *x, struct tiles_tile *t, long status,
                           char *why, size_t size) {
    struct tiles_server *s = &T->s[x->server];
    bool ok = x->kind == X_LEARN ? status == 200 || status == 201
                                 : status == 200 && tiles_stitch(T, t, &x->body, why, size) == 0;
    if (ok && x->kind == X_LEARN) {
        s->scene = SS_KNOWN;
    } else if (ok) {
        t->st = TS_DONE;
        T->done++;
        s->done++;
    } else if (x->kind == X_LEARN || status != 200) {
        net_describe(status, &x->body, why, size);
    }
    if (ok) s->fails_row = 0;
    return ok;
}

/* x drew its piece: its time joins the typical piece's, and the other
 * copy of a hedged piece is cancelled, which is no failure of its server
 * (it may be merely slow, and its answer would be the same bytes). */
static void tiles_settle(struct tiles *T, struct tiles_xfer *x, double now) {
    int k = T->ntook++;
    for (; k > 0 && T->took[k - 1] > now - x->t0; k--) T->took[k] = T->took[k - 1];
    T->took[k] = now - x->t0;
    if (x->hedge) T->hedge_won++;
    for (struct tiles_xfer *o = T->xfers, *next; o; o = next) {
        next = o->next;
        if (o == x || o->tile != x->tile || (o->kind != X_GET && o->kind != X_POST)) continue;
        T->s[o->server].inflight--;
        T->running--;
        T->t[o->tile].copies--;
        tiles_xfer_free(T, o);
    }
}

static void tiles_finish(struct tiles *T, struct tiles_xfer *x, CURLcode cc, double now) {
    long status = 0;
    curl_easy_getinfo(x->h, CURLINFO_RESPONSE_CODE, &status);
    if (x->kind == X_METRICS) {
        tiles_metrics_done(T, x, cc == CURLE_OK ? status : 0, now);
        return;
    }
    T->s[x->server].inflight--;
    /* the scene's body reached a server that answered: an attempt on a
     * server that could not be reached is no upload */
    if (cc == CURLE_OK && (x->kind == X_LEARN || x->kind == X_POST)) T->s[x->server].uploads++;
    /* the scene's POST, or a tile's (a range's) GET or POST */
    struct tiles_tile *t = x->kind == X_LEARN ? NULL : &T->t[x->tile];
    if (x->kind != X_LEARN) { /* by kind, as t was chosen */
        T->running--;
        T->t[x->tile].copies--;
    }
    char why[600] = "";
    if (cc != CURLE_OK) {
        tiles_transport_why(T, x, cc, why, sizeof why);
    } else if (status == 503 || status == 429) {
        tiles_busy(T, x, t, status, now);
        return;
    } else if (status >= 400 && status < 500 && status != 408) {
        tiles_refused(T, x, status, now);
        return;
    } else if (x->kind != X_LEARN && status == 200 && !tiles_same_version(T, x)) {
        return; /* the run ends, said: nothing to retry */
    } else if (tiles_answered(T, x, t, status, why, sizeof why)) {
        if (x->kind != X_LEARN) tiles_settle(T, x, now);
        return;
    }
    tiles_server_failed(T, x->server, why, now);
    if (t) tiles_tile_failed(T, x->tile, x->server, why, now);
}

/* ---- the loop ------------------------------------------------------------------ */

/* A server's share of the --parallel slots: the slots over the servers not
 * resting, rounded up.  Without it the first server to learn the scene
 * would take every slot while the others are still learning, and a node
 * that holds its requests (stalled, or slow) would then keep the frame
 * from the rest until --timeout. */
static int tiles_share(const struct tiles *T, double now) {
    int live = 0;
    for (int i = 0; i < T->ns; i++) live += T->s[i].down_until <= now;
    return live ? (T->o->parallel + live - 1) / live : T->o->parallel;
}

/* The ready server with the fewest requests in flight, below its share,
 * not t's last failing one if another is ready, never avoid (-1: none);
 * -1 if none. */
static int tiles_pick(struct tiles *T, const struct tiles_tile *t, int avoid, double now) {
    int best = -1, score = 0, share = tiles_share(T, now);
    for (int i = 0; i < T->ns; i++) {
        const struct tiles_server *s = &T->s[i];
        if ((s->scene != SS_KNOWN && !T->acc) || s->down_until > now || i == avoid) continue;
        if (s->inflight >= share) continue;
        int sc = s->inflight + (i == t->last_server && T->ns > 1 ? 1000 : 0);
        if (best < 0 || sc < score) best = i, score = sc;
    }
    return best;
}

/* The straggler to copy: in flight on one server for longer than the
 * median piece drawn so far times TILES_HEDGE_FACTOR (and at least
 * TILES_HEDGE_FLOOR), never copied before, the longest in flight of those.
 * -1: none, or no piece drawn yet to tell what is slow. */
static int tiles_straggler(const struct tiles *T, double now) {
    if (T->ntook == 0) return -1;
    double after = TILES_HEDGE_FACTOR * T->took[T->ntook / 2];
    if (after < TILES_HEDGE_FLOOR) after = TILES_HEDGE_FLOOR;
    int best = -1;
    for (int i = 0; i < T->n; i++) {
        const struct tiles_tile *t = &T->t[i];
        if (t->st != TS_RUNNING || t->copies != 1 || t->hedged || now - t->since < after) continue;
        if (best < 0 || t->since < T->t[best].since) best = i;
    }
    return best;
}

/* The server of piece ti's request in flight; -1 if none. */
static int tiles_running_on(const struct tiles *T, int ti) {
    for (const struct tiles_xfer *x = T->xfers; x; x = x->next)
        if (x->tile == ti && (x->kind == X_GET || x->kind == X_POST)) return x->server;
    return -1;
}

/* Hedged requests: near the end (no piece left to start, which the
 * caller has counted) a free slot takes a copy of a straggler to another
 * ready server, and the first answer wins (tiles_settle).  A stalled or overloaded node then holds
 * the frame up for about twice a typical piece, not for --timeout. */
static void tiles_hedge(struct tiles *T, double now) {
    if (T->o->no_hedge) return;
    while (T->running < T->o->parallel) {
        int ti = tiles_straggler(T, now);
        if (ti < 0) return;
        int si = tiles_pick(T, &T->t[ti], tiles_running_on(T, ti), now);
        if (si < 0 || tiles_start(T, T->acc ? X_POST : X_GET, ti, si) != 0) return;
        T->xfers->hedge = 1; /* tiles_start put the new request first */
        T->t[ti].hedged = 1;
        T->hedged++;
    }
}

static void tiles_dispatch(struct tiles *T, double now) {
    /* counted, not derived from T->running: a hedged piece has two requests */
    int pending = 0;
    for (int i = 0; i < T->n; i++) pending += T->t[i].st == TS_PENDING;
    for (int i = 0; i < T->ns && pending > 0 && !T->acc; i++) { /* ranges carry the body */
        struct tiles_server *s = &T->s[i];
        if (s->scene == SS_UNKNOWN && s->down_until <= now) {
            if (tiles_start(T, X_LEARN, -1, i) == 0) s->scene = SS_LEARNING;
        }
    }
    for (int i = 0; i < T->n && T->running < T->o->parallel; i++) {
        struct tiles_tile *t = &T->t[i];
        if (t->st != TS_PENDING || t->not_before > now) continue;
        int si = tiles_pick(T, t, -1, now);
        if (si < 0) break;
        if (tiles_start(T, T->acc ? X_POST : X_GET, i, si) != 0) break;
        pending--;
    }
    if (pending == 0) tiles_hedge(T, now);
    if (!T->prog.quiet)
        for (int i = 0; i < T->ns; i++) {
            struct tiles_server *s = &T->s[i];
            if (!s->metrics_busy && s->metrics_next <= now && s->down_until <= now)
                tiles_start(T, X_METRICS, -1, i);
        }
}

/* Every server failed more than --retries times in a row: give up. */
static int tiles_all_dead(const struct tiles *T) {
    for (int i = 0; i < T->ns; i++)
        if (T->s[i].fails_row <= T->o->retries) return 0;
    return 1;
}

/* The sum of the nodes' rates measured in the last 5 s; -1 if none. */
static double tiles_rps(const struct tiles *T) {
    double sum = 0, now = net_now();
    int any = 0;
    for (int i = 0; i < T->ns; i++)
        for (int k = 0; k < 8; k++) {
            const struct tiles_rays *r = &T->s[i].rays[k];
            if (r->t > 0 && now - r->t < 5 && r->rps > 0) sum += r->rps, any = 1;
        }
    return any ? sum : -1;
}

static void tiles_draw(struct tiles *T, int force) {
    for (int i = 0; i < T->ns; i++) T->per_server[i] = T->s[i].done;
    progress_update(&T->prog, T->done, T->failed, T->ns, T->per_server, T->labels, tiles_rps(T),
                    force);
}

/* One line: what is missing, then why (the last error: the cause a user
 * acts on, before the list that may be long), then which pieces. */
static void tiles_report_missing(struct tiles *T) {
    int missing = T->n - T->done;
    const char *why = T->last_err;
    for (int i = 0; i < T->n && !*why; i++)
        if (T->t[i].err[0]) why = T->t[i].err;
    tiles_error(T);
    fprintf(stderr, "incomplete image, nothing written to %s: %d of %d %s missing",
            output_name(T->o->out), missing, T->n, T->prog.unit);
    if (*why) fprintf(stderr, "; last error: %s", why);
    fputs("; missing:", stderr);
    int shown = 0;
    for (int i = 0; i < T->n; i++) {
        if (T->t[i].st == TS_DONE) continue;
        if (shown == 12) {
            fprintf(stderr, " ... and %d more", missing - shown);
            break;
        }
        if (T->acc)
            fprintf(stderr, "%s samples %d..%d", shown ? "," : "", T->t[i].k0, T->t[i].k1 - 1);
        else
            fprintf(stderr, "%s x=%d y=%d w=%d h=%d", shown ? "," : "", T->t[i].x, T->t[i].y,
                    T->t[i].w, T->t[i].h);
        shown++;
    }
    fputc('\n', stderr);
}

/* The pieces: a grid of tiles, or --split-samples ranges of the whole
 * image (as equal as can be; no more ranges than samples).  -1: no memory. */
static int tiles_pieces(struct tiles *T, const struct client_opts *o, const struct scenefile *sf) {
    int tile = o->tile, samples = sf->samples > 0 ? sf->samples : 1;
    int cols = (sf->width + tile - 1) / tile, rows = (sf->height + tile - 1) / tile;
    T->n = o->ranges > 0 ? (o->ranges < samples ? o->ranges : samples) : cols * rows;
    T->t = calloc((size_t)T->n, sizeof *T->t);
    T->took = calloc((size_t)T->n, sizeof *T->took);
    if (!T->t || !T->took) return -1;
    for (int k = 0; k < T->n; k++) {
        struct tiles_tile *t = &T->t[k];
        t->last_server = -1;
        if (o->ranges > 0) {
            *t = (struct tiles_tile){.w = sf->width, .h = sf->height, .last_server = -1};
            t->k0 = (int)((long)samples * k / T->n);
            t->k1 = (int)((long)samples * (k + 1) / T->n);
            continue;
        }
        t->x = k % cols * tile, t->y = k / cols * tile;
        t->w = t->x + tile > sf->width ? sf->width - t->x : tile;
        t->h = t->y + tile > sf->height ? sf->height - t->y : tile;
    }
    return 0;
}

/* The frame's bytes: the stitched PNG (on o->threads threads), or the image
 * of the summed ranges (an OpenEXR of their linear values when -o ends in
 * .exr).  *buf is freed with rayd_free. */
static enum rayd_status tiles_encode(const struct tiles *T, void **buf, size_t *len,
                                     struct rayd_error *err) {
    if (!T->acc) return rayd_png_encode_threads(T->img, -1, T->o->threads, buf, len, err);
    if (!output_kind_exr(T->o->out)) {
        rayd_image *img = NULL;
        enum rayd_status st = rayd_accum_image(T->acc, &img, err);
        if (st == RAYD_OK) st = rayd_png_encode_threads(img, -1, T->o->threads, buf, len, err);
        rayd_image_free(img);
        return st;
    }
    float *lin = NULL;
    enum rayd_status st = rayd_accum_linear(T->acc, &lin, err);
    if (st == RAYD_OK) st = rayd_exr_encode(lin, T->sf->width, T->sf->height, buf, len, err);
    rayd_free(lin);
    return st;
}

/* Encodes the frame and writes it to o->out: 0, or -1 after saying why. */
static int tiles_write(const struct tiles *T) {
    struct rayd_error err = {0};
    void *buf = NULL;
    size_t len = 0;
    if (tiles_encode(T, &buf, &len, &err) != RAYD_OK) {
        tiles_error(T);
        fprintf(stderr, "cannot encode the image: %s\n", err.message);
        return -1;
    }
    int rc = output_write(T->o->out, buf, len);
    rayd_free(buf);
    return rc;
}

/* T's servers, pieces and image (or sums), from o and sf: 0, or -1 after
 * saying so (out of memory); tiles_cleanup frees what was made. */
static int tiles_setup(struct tiles *T, const struct client_opts *o, const struct scenefile *sf) {
    memset(T, 0, sizeof *T);
    T->o = o, T->sf = sf, T->ns = o->nservers;
    T->version_from = -1;
    T->busy_limit = 20 + 10 * o->retries;
    T->s = calloc((size_t)T->ns, sizeof *T->s);
    T->per_server = calloc((size_t)T->ns, sizeof *T->per_server);
    T->labels = calloc((size_t)T->ns, sizeof *T->labels);
    T->multi = curl_multi_init();
    struct rayd_error err = {0};
    if (!T->s || !T->per_server || !T->labels || !T->multi || tiles_pieces(T, o, sf) != 0 ||
        (o->ranges > 0 ? rayd_accum_new_sized(sf->width, sf->height, &T->acc, &err)
                       : rayd_image_new(sf->width, sf->height, &T->img, &err)) != RAYD_OK) {
        tiles_error(T);
        fprintf(stderr, "out of memory\n");
        return -1;
    }
    for (int i = 0; i < T->ns; i++) {
        T->s[i].url = o->servers[i];
        net_label(o->servers[i], T->s[i].label, sizeof T->s[i].label);
        memcpy(T->labels[i], T->s[i].label, sizeof T->labels[i]);
    }
    /* one keep-alive connection per request in flight, a few spare */
    curl_multi_setopt(T->multi, CURLMOPT_MAXCONNECTS, (long)(o->parallel + 2 * T->ns + 4));
    return 0;
}

/* The one line that says what is about to be done, when no progress bar
 * is drawn (a pipe, a log) and not --quiet. */
static void tiles_banner(const struct tiles *T) {
    const struct scenefile *sf = T->sf;
    const char *servers = T->ns > 1 ? "s" : "";
    if (T->o->quiet || T->prog.tty) return;
    if (T->acc)
        fprintf(stderr,
                "rayd-client: %dx%d frame, %d samples in %d ranges over %d server%s, scene %.12s\n",
                sf->width, sf->height, sf->samples, T->n, T->ns, servers, sf->id);
    else
        fprintf(stderr,
                "rayd-client: %dx%d frame, %d tiles of %d px over %d server%s, scene %.12s\n",
                sf->width, sf->height, T->n, T->o->tile, T->ns, servers, sf->id);
}

/* Every pending piece failed, when no server is left alive. */
static void tiles_give_up(struct tiles *T) {
    for (int i = 0; i < T->n; i++)
        if (T->t[i].st == TS_PENDING) {
            T->t[i].st = TS_FAILED;
            T->failed++;
        }
}

/* Requests the pieces, as many in flight as allowed, until each is done
 * or failed, or a fatal answer ends the render. */
static void tiles_loop(struct tiles *T) {
    while (T->done + T->failed < T->n && !T->fatal) {
        tiles_dispatch(T, net_now());
        int still = 0;
        curl_multi_perform(T->multi, &still);
        CURLMsg *m;
        int left;
        while ((m = curl_multi_info_read(T->multi, &left))) {
            if (m->msg != CURLMSG_DONE) continue;
            struct tiles_xfer *x = NULL;
            curl_easy_getinfo(m->easy_handle, CURLINFO_PRIVATE, (char **)&x);
            tiles_finish(T, x, m->data.result, net_now());
            tiles_xfer_free(T, x);
        }
        if (tiles_all_dead(T)) tiles_give_up(T);
        if (T->done + T->failed == T->n) break;
        tiles_draw(T, 0);
        if (!T->fatal) curl_multi_poll(T->multi, NULL, 0, 50, NULL);
    }
}

/* After the loop: the image written (0), or why not said (1). */
static int tiles_conclude(struct tiles *T, double secs) {
    if (!T->fatal) tiles_draw(T, 1);
    progress_end(&T->prog);
    if (T->fatal) return 1;
    if (T->done < T->n) {
        tiles_report_missing(T);
        return 1;
    }
    if (tiles_write(T) != 0) return 1;
    if (!T->o->quiet) {
        long uploads = 0;
        for (int i = 0; i < T->ns; i++) uploads += T->s[i].uploads;
        fprintf(stderr,
                "rayd-client: wrote %s (%dx%d) from %d %s in %.2f s (%.1f/s), "
                "scene sent %ld time%s",
                output_name(T->o->out), T->sf->width, T->sf->height, T->n, T->prog.unit, secs,
                secs > 0 ? T->n / secs : 0.0, uploads, uploads == 1 ? "" : "s");
        if (!T->o->no_hedge)
            fprintf(stderr, ", %s hedged: %d, won: %d", T->prog.unit, T->hedged, T->hedge_won);
        fputc('\n', stderr);
    }
    return 0;
}

static void tiles_cleanup(struct tiles *T) {
    if (T->multi) {
        /* abandon what is still in flight (a fatal error or given-up tiles) */
        while (T->xfers) tiles_xfer_free(T, T->xfers);
        curl_multi_cleanup(T->multi);
    }
    rayd_image_free(T->img);
    rayd_accum_free(T->acc);
    free(T->t);
    free(T->s);
    free(T->per_server);
    free(T->labels);
    free(T->took);
}

int tiles_render(const struct client_opts *o, const struct scenefile *sf) {
    if (o->out && output_writable(o->out) != 0) return 1; /* said before the render, not after */
    struct tiles T;
    int rc = 1;
    if (tiles_setup(&T, o, sf) == 0) {
        progress_init(&T.prog, T.n, o->quiet);
        if (o->ranges > 0) T.prog.unit = "sample ranges";
        tiles_banner(&T);
        double t0 = net_now();
        tiles_loop(&T);
        rc = tiles_conclude(&T, net_now() - t0);
    }
    tiles_cleanup(&T);
    return rc;
}
