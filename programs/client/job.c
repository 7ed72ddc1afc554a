/* job.c -- `rayd-client job`: one asynchronous render on one server.
 *
 * POST /v1/jobs answers at once with the job id; the render then runs on
 * the server whether or not anyone watches.  We follow
 * GET /v1/jobs/{id}/events, a Server-Sent Events stream that replays what
 * already happened and then sends, as the render goes, a "tile" event per
 * finished tile (a progressive job: a "pass" event per finished pass),
 * "progress" events and a final "done".  The stream is parsed as it
 * arrives (sse.c) and drives the same progress display as the tile client.  If the stream
 * breaks before "done" (a proxy timeout, a restart), we fall back to polling
 * GET /v1/jobs/{id} once a second.  Then GET /v1/jobs/{id}/image.png gives
 * the PNG, written unchanged (it equals rayd-render's bytes), or 409 with
 * the job's error, printed as the server sent it.  For -o OUT.exr the job
 * is created with ?format=exr and GET /v1/jobs/{id}/image.exr gives the
 * linear OpenEXR (rayd-render -o OUT.exr's bytes).
 *
 * An animated scene (or --frames) is a frame-range job, which
 * job_frames.c follows with the requests, the image checks, the signals
 * and the cancel of this file.
 *
 * Ctrl-C cancels the job on the server (DELETE /v1/jobs/{id}) before
 * exiting, so an abandoned render does not keep the workers busy.
 *
 * What the server says is checked, not trusted: progress figures must be
 * whole numbers with 0 <= done <= total and 0 < total <= the image's
 * pixels (others are ignored, with one warning); the image must be the
 * size of the scene (the PNG's IHDR, the EXR's dataWindow, read before
 * anything is decoded), else nothing is written; its words are printed
 * escaped (net_safe).
 */
#include "client.h"

#include <cjson/cJSON.h>
#include <curl/curl.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <rayd/rayd.h>

static volatile sig_atomic_t job_interrupted;
/* While the DELETE of job_cancel goes: only an interrupt a second or more
 * after the first stops it.  `timeout` and a terminal both may deliver one
 * Ctrl-C twice (to the process and to its group), and the second used to
 * cut the DELETE off before it was sent: the job went on. */
static volatile sig_atomic_t job_cancelling, job_insisted;
static struct timespec job_first_signal;

int job_stopped(void) { return job_interrupted; }

static void job_on_signal(int sig) {
    (void)sig;
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now); /* async-signal-safe */
    if (!job_interrupted && !job_cancelling) job_first_signal = now;
    if (job_cancelling && (now.tv_sec - job_first_signal.tv_sec) * 1000000000L + now.tv_nsec -
                                  job_first_signal.tv_nsec >=
                              1000000000L)
        job_insisted = 1;
    job_interrupted = 1;
}

/* Where the job's progress is shown, and what the figures may be. */
struct job_show {
    struct progress prog;
    char label[1][40];
    double max_total; /* the image's pixels: no more tiles than that */
    int warned;       /* bad figures were said once */
};

/* Whether done of total tiles can be true of this job: whole numbers,
 * 0 <= done <= total, 0 < total <= the image's pixels. */
static bool job_figures_ok(const struct job_show *s, double done, double total) {
    return isfinite(done) && isfinite(total) && done == floor(done) && total == floor(total) &&
           done >= 0 && done <= total && total > 0 && total <= s->max_total;
}

/* The progress display at done of total tiles, numbers from the server's
 * JSON (an event's, or the job's when polled); nothing when either is
 * missing, and nothing but one warning when they make no sense. */
static void job_progress(struct job_show *s, const cJSON *done, const cJSON *total) {
    if (!cJSON_IsNumber(done) || !cJSON_IsNumber(total)) return;
    if (!job_figures_ok(s, done->valuedouble, total->valuedouble)) {
        if (!s->warned++ && !s->prog.quiet) {
            progress_end(&s->prog);
            fprintf(stderr,
                    "rayd-client: warning: the server's progress figures make no sense (%.6g of "
                    "%.6g tiles, for a %.0f-pixel image): ignored\n",
                    done->valuedouble, total->valuedouble, s->max_total);
        }
        return;
    }
    long per = (long)done->valuedouble;
    s->prog.total = (int)total->valuedouble;
    progress_update(&s->prog, (int)per, 0, 1, &per, s->label, -1, 0);
}

/* An event of the job's stream: progress shown; 1 at "done". */
static int job_on_event(void *user, const char *event, const char *data) {
    struct job_show *show = user;
    cJSON *d = cJSON_Parse(data);
    if (!strcmp(event, "progress"))
        job_progress(show, cJSON_GetObjectItemCaseSensitive(d, "done"),
                     cJSON_GetObjectItemCaseSensitive(d, "total"));
    cJSON_Delete(d);
    return !strcmp(event, "done");
}

static int job_idle(void *user) {
    (void)user;
    return job_interrupted ? 1 : 0;
}

static int job_xferinfo(void *u, curl_off_t a, curl_off_t b, curl_off_t c, curl_off_t d) {
    (void)u, (void)a, (void)b, (void)c, (void)d;
    return (job_cancelling ? job_insisted : job_interrupted) ? 1 : 0;
}

/* One blocking request; returns the status (0 on a transport error, with
 * why set). */
long job_request(const struct client_opts *o, const char *method, const char *url,
                 const struct scenefile *sf, struct net_buf *body, char *why, size_t size) {
    void *hdrs = NULL;
    CURL *h = net_easy(o, url, body, sf ? sf->bytes : NULL, sf ? sf->len : 0, &hdrs);
    if (!h) {
        snprintf(why, size, "out of memory");
        return 0;
    }
    if (strcmp(method, "GET") && strcmp(method, "POST"))
        curl_easy_setopt(h, CURLOPT_CUSTOMREQUEST, method);
    curl_easy_setopt(h, CURLOPT_NOPROGRESS, 0L);
    curl_easy_setopt(h, CURLOPT_XFERINFOFUNCTION, job_xferinfo);
    char err[256] = "";
    long status = net_perform(h, hdrs, err, sizeof err);
    if (err[0]) snprintf(why, size, "%s: %s", url, err);
    return status;
}

/* Follows the event stream (sse.c); returns 1 when "done" arrived. */
static int job_follow(const struct client_opts *o, const char *base, const char *id,
                      struct job_show *show) {
    char url[1024];
    snprintf(url, sizeof url, "%s/v1/jobs/%s/events", base, id);
    struct sse s = {.o = o, .on_event = job_on_event, .idle = job_idle, .user = show};
    int rc = sse_run(&s, url);
    net_buf_free(&s.error_body);
    return rc == SSE_DONE;
}

bool job_poll_again(const struct client_opts *o, const char *id, long st, const struct net_buf *b,
                    char *why, size_t size, double *down) {
    if (st) net_describe(st, b, why, size);
    bool transient = st == 0 || st == 502 || st == 503 || st == 504;
    if (transient && (!*down || net_now() - *down < o->timeout)) {
        if (!*down && !o->quiet)
            fprintf(stderr, "rayd-client: warning: job %s: %s; asking again for %.0f s\n", id, why,
                    o->timeout);
        if (!*down) *down = net_now();
        return true;
    }
    fprintf(stderr, "rayd-client: error: job %s: %s%s\n", id, why,
            transient ? " (the job itself may still be running on the server)" : "");
    return false;
}

/* Polls GET /v1/jobs/{id} until the job is finished; 0, or -1. */
static int job_poll(const struct client_opts *o, const char *base, const char *id,
                    struct job_show *show) {
    char url[1024], why[600];
    snprintf(url, sizeof url, "%s/v1/jobs/%s", base, id);
    struct net_buf b = {0};
    int rc = -1;
    double down = 0; /* since when the server has not answered (a restart) */
    for (int tries = 0; !job_interrupted; tries++) {
        net_buf_reset(&b);
        long st = job_request(o, "GET", url, NULL, &b, why, sizeof why);
        if (st != 200 && !job_interrupted) {
            if (!job_poll_again(o, id, st, &b, why, sizeof why, &down)) break;
            nanosleep(&(struct timespec){1, 0}, NULL);
            continue;
        }
        if (st != 200) break;
        down = 0;
        cJSON *j = cJSON_ParseWithLength(b.data, b.len);
        const char *state = net_json_str(j, "state");
        job_progress(show, cJSON_GetObjectItemCaseSensitive(j, "tiles_done"),
                     cJSON_GetObjectItemCaseSensitive(j, "tiles_total"));
        int fin = state && (!strcmp(state, "succeeded") || !strcmp(state, "failed") ||
                            !strcmp(state, "canceled"));
        cJSON_Delete(j);
        if (fin) {
            rc = 0;
            break;
        }
        struct timespec ts = {1, 0};
        nanosleep(&ts, NULL);
    }
    net_buf_free(&b);
    return rc;
}

/* A big-endian (PNG) or little-endian (EXR) 32-bit number at p. */
static uint32_t job_be32(const unsigned char *p) {
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}
static int32_t job_le32(const unsigned char *p) {
    return (int32_t)((uint32_t)p[3] << 24 | (uint32_t)p[2] << 16 | (uint32_t)p[1] << 8 | p[0]);
}

/* The size of a PNG from its IHDR (the first chunk): 0, or -1. */
static int job_png_size(const struct net_buf *b, long *w, long *h) {
    static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    const unsigned char *p = (const unsigned char *)b->data;
    if (b->len < 24 || memcmp(p, sig, 8) || memcmp(p + 12, "IHDR", 4)) return -1;
    *w = (long)job_be32(p + 16), *h = (long)job_be32(p + 20);
    return 0;
}

/* The size of an OpenEXR from its header's dataWindow (box2i): 0, or -1
 * when it has none or the header runs past the bytes.  The header is a
 * list of attributes (name NUL, type NUL, int32 size, value) ended by an
 * empty name, after the magic and the version. */
static int job_exr_size(const struct net_buf *b, long *w, long *h) {
    static const unsigned char magic[4] = {0x76, 0x2f, 0x31, 0x01};
    const unsigned char *p = (const unsigned char *)b->data, *end = p + b->len;
    if (b->len < 8 || memcmp(p, magic, 4)) return -1;
    for (p += 8; p < end && *p;) {
        const unsigned char *name = p, *type = memchr(p, 0, (size_t)(end - p));
        if (!type++) return -1;
        const unsigned char *sz = memchr(type, 0, (size_t)(end - type));
        if (!sz++ || end - sz < 4) return -1;
        int32_t n = job_le32(sz);
        const unsigned char *v = sz + 4;
        if (n < 0 || end - v < n) return -1;
        if (!strcmp((const char *)name, "dataWindow") && !strcmp((const char *)type, "box2i") &&
            n == 16) {
            *w = (long)job_le32(v + 8) - job_le32(v) + 1;
            *h = (long)job_le32(v + 12) - job_le32(v + 4) + 1;
            return 0;
        }
        p = v + n;
    }
    return -1;
}

/* The size of b, a PNG or (for an .exr path) an OpenEXR, from its header:
 * 0, or -1 when it is none. */
int job_image_size(const char *path, const struct net_buf *b, long *w, long *h) {
    return output_kind_exr(path) ? job_exr_size(b, w, h) : job_png_size(b, w, h);
}

/* The job's PNG, or EXR for an .exr path, into path once it is one of the
 * size asked for (w x h: the scene's): 0, or -1 after saying why (nothing
 * written).  The size is read from the header before anything is decoded,
 * so a huge image costs nothing. */
int job_write(const char *path, const struct net_buf *b, int w, int h) {
    bool exr = output_kind_exr(path);
    long iw = 0, ih = 0;
    if (job_image_size(path, b, &iw, &ih) != 0) {
        fprintf(stderr, "rayd-client: error: the job's image is not %s; nothing written to %s\n",
                exr ? "an OpenEXR" : "a PNG", output_name(path));
        return -1;
    }
    if (iw != w || ih != h) {
        fprintf(stderr,
                "rayd-client: error: the job's image is %ldx%ld, not the %dx%d asked for; nothing "
                "written to %s\n",
                iw, ih, w, h, output_name(path));
        return -1;
    }
    if (exr) return output_write(path, b->data, b->len);
    rayd_image *img = NULL;
    struct rayd_error err = {0};
    if (rayd_png_decode(b->data, b->len, (long)w * h, &img, &err) != RAYD_OK) {
        char why[300];
        fprintf(stderr,
                "rayd-client: error: the job's image is not a PNG: %s; nothing written to %s\n",
                net_safe(err.message, why, sizeof why), output_name(path));
        return -1;
    }
    rayd_image_free(img);
    return output_write(path, b->data, b->len);
}

/* POSTs the scene; its job's id into id: 0, or 1 after saying why. */
int job_post(const struct client_opts *o, const struct scenefile *sf, const char *query, char *id,
             size_t size) {
    const char *base = o->servers[0];
    char url[1024], why[600] = "";
    struct net_buf b = {0};
    snprintf(url, sizeof url, "%s/v1/jobs%s", base, query);
    long st = job_request(o, "POST", url, sf, &b, why, sizeof why);
    int rc = 1;
    if (st != 202) {
        if (st) net_describe(st, &b, why, sizeof why);
        fprintf(stderr, "rayd-client: error: %s refused the job: %s\n", base, why);
    } else {
        cJSON *j = cJSON_ParseWithLength(b.data, b.len);
        const char *jid = net_json_str(j, "id");
        if (jid && strlen(jid) < size && strspn(jid, "0123456789abcdef") == strlen(jid)) {
            snprintf(id, size, "%s", jid);
            rc = 0;
        } else {
            fprintf(stderr, "rayd-client: error: %s: no job id in the answer\n", base);
        }
        cJSON_Delete(j);
    }
    net_buf_free(&b);
    return rc;
}

/* Ctrl-C or SIGTERM came: the job is cancelled on the server (DELETE).
 * Returns 130, the exit status of an interrupted command. */
int job_cancel(const struct client_opts *o, const char *id) {
    job_cancelling = 1; /* let the DELETE through: only a later Ctrl-C stops it */
    char state[16];
    bool canceled = job_delete(o, id, state, sizeof state);
    if (job_insisted)
        fprintf(stderr,
                "rayd-client: interrupted again; job %s may go on: its DELETE was stopped\n", id);
    else if (canceled)
        fprintf(stderr, "rayd-client: interrupted; job %s cancelled\n", id);
    else if (state[0]) /* it ended before the DELETE: nothing was cancelled */
        fprintf(stderr, "rayd-client: interrupted; job %s had already %s\n", id, state);
    else
        fprintf(stderr, "rayd-client: interrupted; job %s may go on: its DELETE was not answered\n",
                id);
    return 130;
}

bool job_delete(const struct client_opts *o, const char *id, char *state, size_t size) {
    char url[1024], why[600] = "", safe[16] = "";
    struct net_buf b = {0};
    snprintf(url, sizeof url, "%s/v1/jobs/%s", o->servers[0], id);
    long st = job_request(o, "DELETE", url, NULL, &b, why, sizeof why);
    cJSON *j = st == 200 ? cJSON_ParseWithLength(b.data, b.len) : NULL;
    const char *s = net_json_str(j, "state");
    if (s && strlen(s) < sizeof safe) net_safe(s, safe, sizeof safe);
    snprintf(state, size, "%s", safe);
    cJSON_Delete(j);
    net_buf_free(&b);
    return !strcmp(safe, "canceled");
}

/* Follows job id to its end, showing progress: 0, 1 (said) or 130
 * (interrupted: cancelled). */
static int job_wait(const struct client_opts *o, const char *id, const struct scenefile *sf) {
    const char *base = o->servers[0];
    struct job_show show = {.max_total = (double)sf->width * sf->height};
    net_label(base, show.label[0], sizeof show.label[0]);
    progress_init(&show.prog, 1, o->quiet);
    int done = job_follow(o, base, id, &show);
    int failed = !done && !job_interrupted && job_poll(o, base, id, &show) != 0;
    if (!failed && !job_interrupted)
        progress_update(&show.prog, show.prog.total, 0, 1, (long[]){show.prog.total}, show.label,
                        -1, 1);
    progress_end(&show.prog);
    return job_interrupted ? job_cancel(o, id) : failed;
}

/* The finished job's image into o->out (202 while the server encodes
 * it): 0, or 1 after saying why. */
static int job_fetch(const struct client_opts *o, const char *id, const struct scenefile *sf) {
    char url[1024], why[600] = "";
    struct net_buf b = {0};
    long st = 0;
    snprintf(url, sizeof url, "%s/v1/jobs/%s/image.%s", o->servers[0], id,
             output_kind_exr(o->out) ? "exr" : "png");
    for (int tries = 0; tries < 600 && !job_interrupted; tries++) {
        net_buf_reset(&b);
        st = job_request(o, "GET", url, NULL, &b, why, sizeof why);
        if (st != 202) break;
        struct timespec ts = {0, 200 * 1000 * 1000}; /* encoding the PNG */
        nanosleep(&ts, NULL);
    }
    int rc = 1;
    if (st == 200) {
        rc = job_write(o->out, &b, sf->width, sf->height) == 0 ? 0 : 1;
        if (rc == 0 && !o->quiet) fprintf(stderr, "rayd-client: wrote %s\n", output_name(o->out));
    } else {
        if (st) net_describe(st, &b, why, sizeof why);
        fprintf(stderr, "rayd-client: error: job %s: %s\n", id, why);
    }
    net_buf_free(&b);
    return rc;
}

static struct sigaction job_old_int, job_old_term;

void job_signals(int catch) {
    if (!catch) {
        sigaction(SIGINT, &job_old_int, NULL);
        sigaction(SIGTERM, &job_old_term, NULL);
        return;
    }
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = job_on_signal;
    sigaction(SIGINT, &sa, &job_old_int);
    sigaction(SIGTERM, &sa, &job_old_term);
}

int job_run(const struct client_opts *o, const struct scenefile *sf) {
    if (o->out && output_writable(o->out) != 0) return 1; /* said before the render, not after */
    job_signals(1);
    char id[64] = "";
    int rc = job_post(o, sf, output_kind_exr(o->out) ? "?format=exr" : "", id, sizeof id);
    if (rc == 0 && !o->quiet)
        fprintf(stderr, "rayd-client: job %s on %s (%dx%d)\n", id, o->servers[0], sf->width,
                sf->height);
    if (rc == 0) rc = job_wait(o, id, sf);
    if (rc == 0) rc = job_fetch(o, id, sf);
    job_signals(0);
    return rc;
}
