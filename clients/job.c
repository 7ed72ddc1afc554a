/* job.c -- `rayd-client job`: one asynchronous render on one server.
 *
 * POST /v1/jobs answers at once with the job id; the render then runs on
 * the server whether or not anyone watches.  We follow
 * GET /v1/jobs/{id}/events, a Server-Sent Events stream that replays what
 * already happened and then sends, as the render goes, a "tile" event per
 * finished tile (a progressive job: a "pass" event per finished pass),
 * "progress" events and a final "done".  The stream is parsed as it
 * arrives (lines, "event:" and "data:" fields, a blank line ends an event)
 * and drives the same progress display as the tile client.  If the stream
 * breaks before "done" (a proxy timeout, a restart), we fall back to polling
 * GET /v1/jobs/{id} once a second.  Then GET /v1/jobs/{id}/image.png gives
 * the PNG, written unchanged (it equals rayd-render's bytes), or 409 with
 * the job's error, printed as the server sent it.  For -o OUT.exr the job
 * is created with ?format=exr and GET /v1/jobs/{id}/image.exr gives the
 * linear OpenEXR (rayd-render -o OUT.exr's bytes).
 *
 * Ctrl-C cancels the job on the server (DELETE /v1/jobs/{id}) before
 * exiting, so an abandoned render does not keep the workers busy.
 */
#include "client.h"

#include <cjson/cJSON.h>
#include <curl/curl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <rayd/rayd.h>

static volatile sig_atomic_t job_interrupted;

static void job_on_signal(int sig)
{
    (void)sig;
    job_interrupted = 1;
}

struct job_sse {
    char line[4096];
    size_t len;
    char event[32];
    char data[4096];
    int done;
    char final_state[32];
    struct progress *prog;
    char (*label)[40];
};

/* The progress display at done of total tiles, numbers from the server's
 * JSON (an event's, or the job's when polled); nothing when either is
 * missing. */
static void job_progress(struct progress *p, char (*label)[40], const cJSON *done,
                         const cJSON *total) {
    if (!cJSON_IsNumber(done) || !cJSON_IsNumber(total)) return;
    long per = done->valueint;
    p->total = total->valueint;
    progress_update(p, done->valueint, 0, 1, &per, label, -1, 0);
}

static void job_sse_dispatch(struct job_sse *j)
{
    cJSON *d = cJSON_Parse(j->data);
    if (!strcmp(j->event, "progress")) {
        job_progress(j->prog, j->label, cJSON_GetObjectItemCaseSensitive(d, "done"),
                     cJSON_GetObjectItemCaseSensitive(d, "total"));
    } else if (!strcmp(j->event, "done")) {
        const cJSON *st = cJSON_GetObjectItemCaseSensitive(d, "state");
        snprintf(j->final_state, sizeof j->final_state, "%s",
                 cJSON_IsString(st) ? st->valuestring : "unknown");
        j->done = 1;
    }
    cJSON_Delete(d);
    j->event[0] = j->data[0] = '\0';
}

static void job_sse_line(struct job_sse *j)
{
    char *l = j->line;
    if (!*l) {
        if (j->event[0] || j->data[0])
            job_sse_dispatch(j);
        return;
    }
    if (*l == ':')
        return; /* a comment: keep-alive */
    char *v = strchr(l, ':');
    if (v) {
        *v++ = '\0';
        if (*v == ' ')
            v++;
    } else {
        v = l + strlen(l);
    }
    if (!strcmp(l, "event")) {
        snprintf(j->event, sizeof j->event, "%s", v);
    } else if (!strcmp(l, "data")) {
        size_t n = strlen(j->data);
        snprintf(j->data + n, sizeof j->data - n, "%s%s", n ? "\n" : "", v);
    }
}

static size_t job_sse_write(char *ptr, size_t size, size_t n, void *user)
{
    struct job_sse *j = user;
    size_t all = size * n;
    for (size_t i = 0; i < all; i++) {
        char c = ptr[i];
        if (c == '\n') {
            if (j->len && j->line[j->len - 1] == '\r')
                j->len--;
            j->line[j->len] = '\0';
            job_sse_line(j);
            j->len = 0;
        } else if (j->len + 1 < sizeof j->line) {
            j->line[j->len++] = c;
        }
    }
    return all;
}

static int job_xferinfo(void *u, curl_off_t a, curl_off_t b, curl_off_t c, curl_off_t d)
{
    (void)u, (void)a, (void)b, (void)c, (void)d;
    return job_interrupted ? 1 : 0;
}

/* One blocking request; returns the status (0 on a transport error, with
 * why set). */
static long job_request(const struct client_opts *o, const char *method, const char *url,
                        const struct scenefile *sf, struct net_buf *body, char *why, size_t size)
{
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

/* Follows the event stream; returns 1 when "done" arrived. */
static int job_follow(const struct client_opts *o, const char *base, const char *id,
                      struct progress *prog, char (*label)[40])
{
    char url[1024];
    snprintf(url, sizeof url, "%s/v1/jobs/%s/events", base, id);
    struct job_sse j;
    memset(&j, 0, sizeof j);
    j.prog = prog;
    j.label = label;
    struct net_buf unused = {0};
    void *hdrs = NULL;
    CURL *h = net_easy(o, url, &unused, NULL, 0, &hdrs);
    if (!h)
        return 0;
    curl_easy_setopt(h, CURLOPT_WRITEFUNCTION, job_sse_write);
    curl_easy_setopt(h, CURLOPT_WRITEDATA, &j);
    curl_easy_setopt(h, CURLOPT_TIMEOUT_MS, 0L); /* a render may take long */
    curl_easy_setopt(h, CURLOPT_LOW_SPEED_LIMIT, 1L);
    curl_easy_setopt(h, CURLOPT_LOW_SPEED_TIME, 60L); /* keep-alives come sooner */
    curl_easy_setopt(h, CURLOPT_NOPROGRESS, 0L);
    curl_easy_setopt(h, CURLOPT_XFERINFOFUNCTION, job_xferinfo);
    curl_easy_perform(h);
    curl_easy_cleanup(h);
    curl_slist_free_all(hdrs);
    net_buf_free(&unused);
    return j.done;
}

/* Polls GET /v1/jobs/{id} until the job is finished; 0, or -1. */
static int job_poll(const struct client_opts *o, const char *base, const char *id,
                    struct progress *prog, char (*label)[40])
{
    char url[1024], why[600];
    snprintf(url, sizeof url, "%s/v1/jobs/%s", base, id);
    struct net_buf b = {0};
    int rc = -1;
    for (int tries = 0; !job_interrupted; tries++) {
        net_buf_reset(&b);
        long st = job_request(o, "GET", url, NULL, &b, why, sizeof why);
        if (st != 200) {
            if (st)
                net_describe(st, &b, why, sizeof why);
            fprintf(stderr, "rayd-client: error: job %s: %s\n", id, why);
            break;
        }
        cJSON *j = cJSON_ParseWithLength(b.data, b.len);
        const char *state = net_json_str(j, "state");
        job_progress(prog, label, cJSON_GetObjectItemCaseSensitive(j, "tiles_done"),
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

/* The job's PNG, or EXR for an .exr path (checked to be one) into path: 0,
 * or -1 after saying why. */
static int job_write(const char *path, const struct net_buf *b)
{
    static const unsigned char exr_magic[4] = {0x76, 0x2f, 0x31, 0x01};
    if (output_is_exr(path)) {
        if (b->len < 4 || memcmp(b->data, exr_magic, 4)) {
            fprintf(stderr, "rayd-client: error: the job's image is not an OpenEXR\n");
            return -1;
        }
        return output_write(path, b->data, b->len);
    }
    rayd_image *img = NULL;
    struct rayd_error err = {0};
    if (rayd_png_decode(b->data, b->len, 0, &img, &err) != RAYD_OK) {
        fprintf(stderr, "rayd-client: error: the job's image is not a PNG: %s\n", err.message);
        return -1;
    }
    rayd_image_free(img);
    return output_write(path, b->data, b->len);
}

/* POSTs the scene; its job's id into id: 0, or 1 after saying why. */
static int job_post(const struct client_opts *o, const struct scenefile *sf, char *id,
                    size_t size) {
    const char *base = o->servers[0];
    char url[1024], why[600] = "";
    struct net_buf b = {0};
    snprintf(url, sizeof url, "%s/v1/jobs%s", base, output_is_exr(o->out) ? "?format=exr" : "");
    long st = job_request(o, "POST", url, sf, &b, why, sizeof why);
    int rc = 1;
    if (st != 202) {
        if (st)
            net_describe(st, &b, why, sizeof why);
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
static int job_cancel(const struct client_opts *o, const char *id) {
    char url[1024], why[600] = "";
    struct net_buf b = {0};
    job_interrupted = 0; /* let the DELETE through */
    snprintf(url, sizeof url, "%s/v1/jobs/%s", o->servers[0], id);
    job_request(o, "DELETE", url, NULL, &b, why, sizeof why);
    net_buf_free(&b);
    fprintf(stderr, "rayd-client: interrupted; job %s cancelled\n", id);
    return 130;
}

/* Follows job id to its end, showing progress: 0, 1 (said) or 130
 * (interrupted: cancelled). */
static int job_wait(const struct client_opts *o, const char *id) {
    const char *base = o->servers[0];
    struct progress prog;
    char label[1][40];
    net_label(base, label[0], sizeof label[0]);
    progress_init(&prog, 1, o->quiet);
    int done = job_follow(o, base, id, &prog, label);
    int failed = !done && !job_interrupted && job_poll(o, base, id, &prog, label) != 0;
    if (!failed && !job_interrupted)
        progress_update(&prog, prog.total, 0, 1, (long[]){prog.total}, label, -1, 1);
    progress_end(&prog);
    return job_interrupted ? job_cancel(o, id) : failed;
}

/* The finished job's image into o->out (202 while the server encodes
 * it): 0, or 1 after saying why. */
static int job_fetch(const struct client_opts *o, const char *id) {
    char url[1024], why[600] = "";
    struct net_buf b = {0};
    long st = 0;
    snprintf(url, sizeof url, "%s/v1/jobs/%s/image.%s", o->servers[0], id,
             output_is_exr(o->out) ? "exr" : "png");
    for (int tries = 0; tries < 600 && !job_interrupted; tries++) {
        net_buf_reset(&b);
        st = job_request(o, "GET", url, NULL, &b, why, sizeof why);
        if (st != 202)
            break;
        struct timespec ts = {0, 200 * 1000 * 1000}; /* encoding the PNG */
        nanosleep(&ts, NULL);
    }
    int rc = 1;
    if (st == 200) {
        rc = job_write(o->out, &b) == 0 ? 0 : 1;
        if (rc == 0 && !o->quiet)
            fprintf(stderr, "rayd-client: wrote %s\n", output_name(o->out));
    } else {
        if (st)
            net_describe(st, &b, why, sizeof why);
        fprintf(stderr, "rayd-client: error: job %s: %s\n", id, why);
    }
    net_buf_free(&b);
    return rc;
}

int job_run(const struct client_opts *o, const struct scenefile *sf) {
    struct sigaction sa, old_int, old_term;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = job_on_signal;
    sigaction(SIGINT, &sa, &old_int);
    sigaction(SIGTERM, &sa, &old_term);
    char id[64] = "";
    int rc = job_post(o, sf, id, sizeof id);
    if (rc == 0 && !o->quiet)
        fprintf(stderr, "rayd-client: job %s on %s (%dx%d)\n", id, o->servers[0], sf->width,
                sf->height);
    if (rc == 0) rc = job_wait(o, id);
    if (rc == 0) rc = job_fetch(o, id);
    sigaction(SIGINT, &old_int, NULL);
    sigaction(SIGTERM, &old_term, NULL);
    return rc;
}
