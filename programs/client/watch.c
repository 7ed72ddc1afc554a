/* watch.c -- `rayd-client render --progressive` and `rayd-client watch ID`:
 * a job followed as it renders, each pass of a progressive job written to
 * -o as it arrives.
 *
 * render --progressive POSTs the scene to /v1/jobs?progressive=1 (with
 * pass_step, time_budget, noise_target and format=exr as asked) and then
 * follows the job as `watch` does; --detach only prints the job's id and
 * leaves it running.  watch ID follows a job that already exists: its
 * size, pass count and sample target come from GET /v1/jobs/{id}; a
 * frame-range job's frames and size too, and job_frames.c follows it.
 *
 * Following: GET /v1/jobs/{id}/events (sse.c).  A "pass" event names a
 * complete pass; between events we GET that pass's image
 * (/image.png?pass=K, .exr for -o *.exr: the URL is made here, never taken
 * from the server) and write it through a temporary file in -o's folder,
 * synced and renamed (output.c), so -o always holds one whole pass.  When
 * passes come faster than they are fetched, only the latest is fetched.
 * "done" ends the job: a succeeded job's final image is fetched and
 * written, as `job` does.  A stream that breaks is opened again after the
 * server's "retry:" delay; it replays the job from its start, and passes
 * already written are skipped.  A stream that ends three times in a row
 * without news, or that is refused (a proxy that does not stream), gives
 * way to polling GET /v1/jobs/{id} once a second, whose "passes" object
 * says the same.
 *
 * Ctrl-C or SIGTERM: render --progressive cancels the job (DELETE), as
 * `job` does; watch leaves it running (it may be someone else's, or
 * followed again later) and says how to follow it again.  Either way -o
 * keeps the last whole pass, and the exit status is 130.
 *
 * The server is not trusted: a pass's figures must be whole numbers with
 * 1 <= pass <= passes <= 64, 1 <= samples <= the target, growing pass by
 * pass, and a time that is finite and >= 0, or the event is ignored (one
 * warning); an image must be a PNG (or OpenEXR) of the job's size -- the
 * scene's, for render --progressive, where the job's own size must match
 * it too -- or nothing is written, the following stops (render
 * --progressive cancels the job) and the exit status is 1; every word of
 * the server's is printed escaped (net_safe).
 */
#include "client.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define WATCH_MAX_PIXELS (1L << 28) /* a job bigger than this is no rayd job */
#define WATCH_MAX_SAMPLES 1048576L
#define WATCH_STRIKES 3 /* streams ended without news before we poll */

/* One job being followed. */
struct watch {
    const struct client_opts *o;
    const char *id;
    int cancels;     /* render --progressive: Ctrl-C and a refused image cancel the job */
    long w, h;       /* the image's size */
    int progressive; /* the job renders in passes */
    long passes;     /* its pass count */
    long target;     /* its sample target (0: unknown, passes are then not shown) */
    long seen;       /* the latest pass the server announced (figures checked) */
    long seen_samples;
    double seen_time; /* its time_s */
    long tried;       /* the latest pass fetched, or tried */
    long written;     /* the pass -o holds (0: none) */
    long written_samples;
    char final[16];  /* how the job ended ("" while it runs) */
    int stopped;     /* why a progressive job ended early: watch_stops' index, 0 none */
    char error[600]; /* a failed job's message, escaped */
    char where[300]; /* " at " its JSON Pointer, escaped, when it has one */
    int news;        /* counts what was learned: passes, progress, the end */
    int refused;     /* an image was refused: stop */
    int warned;      /* bad figures were said once */
    int frames;      /* a frame-range job: frames first..last (job_frames.c follows it) */
    long first, last;
    struct progress prog;
    char label[1][40];
};

static void watch_sleep(long ms) {
    for (long t = 0; t < ms && !job_stopped(); t += 50) {
        struct timespec ts = {0, 50 * 1000 * 1000};
        nanosleep(&ts, NULL);
    }
}

/* o[k] (k2: o[k][k2]) when it is a number in lo..hi (whole when asked)
 * into *out: true, else false. */
static bool watch_num(const cJSON *o, const char *k, const char *k2, double lo, double hi,
                      bool whole, double *out) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, k);
    if (k2) v = cJSON_GetObjectItemCaseSensitive(v, k2);
    if (!cJSON_IsNumber(v)) return false;
    double d = v->valuedouble;
    if (!isfinite(d) || d < lo || d > hi || (whole && d != floor(d))) return false;
    *out = d;
    return true;
}

static void watch_warn(struct watch *w, const char *what) {
    if (w->warned++ || w->o->quiet) return;
    progress_end(&w->prog);
    fprintf(stderr, "rayd-client: warning: the server's %s make no sense: ignored\n", what);
}

/* A pass the server announced, from src (an event's data: keys pass and
 * passes; the job's "passes" object: done and total): taken when its
 * figures can be true of this job. */
static void watch_pass(struct watch *w, const cJSON *src, const char *kpass, const char *ktotal) {
    double k, n, samples, t;
    if (!cJSON_IsObject(src) || watch_num(src, kpass, NULL, 0, 0, true, &k))
        return; /* no pass done yet */
    bool ok = w->target > 0 && watch_num(src, kpass, NULL, 1, 64, true, &k) &&
              watch_num(src, ktotal, NULL, (double)w->passes, (double)w->passes, true, &n) &&
              k <= n && watch_num(src, "samples", NULL, 1, (double)w->target, true, &samples) &&
              watch_num(src, "time_s", NULL, 0, 1e7, false, &t);
    if (ok && (long)k <= w->seen) return; /* replayed: had already */
    if (!ok || samples <= (double)w->seen_samples || (k == n && (long)samples != w->target)) {
        watch_warn(w, "pass figures");
        return;
    }
    w->seen = (long)k, w->seen_samples = (long)samples, w->seen_time = t;
    w->news++;
}

/* A plain job's tiles done of total, shown as `job` shows them. */
static void watch_tiles(struct watch *w, const cJSON *o, const char *kdone, const char *ktotal) {
    double done, total;
    if (!cJSON_IsNumber(cJSON_GetObjectItemCaseSensitive(o, kdone))) return;
    if (!watch_num(o, ktotal, NULL, 1, (double)w->w * (double)w->h, true, &total) ||
        !watch_num(o, kdone, NULL, 0, total, true, &done)) {
        watch_warn(w, "progress figures");
        return;
    }
    long per = (long)done;
    w->prog.total = (int)total;
    progress_update(&w->prog, (int)done, 0, 1, &per, w->label, -1, 0);
    w->news++;
}

/* passes.stopped_by's values, and what the client says of each. */
static const char *const watch_stops[][2] = {
    {"", ""},
    {"time_budget", "its time budget (--time-budget)"},
    {"noise_target", "reaching its noise target (--noise-target)"},
    {"client", "a stop request (POST /v1/jobs/ID/stop)"},
    {"max_work", "the server's ray budget (--max-work)"},
};

/* Why the job's passes ended early, from its "passes" object. */
static void watch_stopped(struct watch *w, const cJSON *passes) {
    const char *by = net_json_str(passes, "stopped_by");
    for (int i = 1; by && i < (int)(sizeof watch_stops / sizeof watch_stops[0]); i++)
        if (!strcmp(by, watch_stops[i][0])) w->stopped = i;
}

/* The job's end, from a "done" event or its JSON's state. */
static void watch_end(struct watch *w, const char *state, const char *error, const char *path) {
    static const char *const known[] = {"succeeded", "failed", "canceled", "evicted"};
    snprintf(w->final, sizeof w->final, "unknown");
    for (size_t i = 0; i < sizeof known / sizeof known[0]; i++)
        if (state && !strcmp(state, known[i])) snprintf(w->final, sizeof w->final, "%s", state);
    if (error) net_safe(error, w->error, sizeof w->error);
    char safe[240];
    if (path && *path)
        snprintf(w->where, sizeof w->where, " at %s", net_safe(path, safe, sizeof safe));
    w->news++;
}

static int watch_on_event(void *user, const char *event, const char *data) {
    struct watch *w = user;
    cJSON *d = cJSON_Parse(data);
    if (!strcmp(event, "pass")) {
        watch_pass(w, d, "pass", "passes");
    } else if (!strcmp(event, "progress") && !w->progressive) {
        watch_tiles(w, d, "done", "total");
    } else if (!strcmp(event, "done")) {
        const cJSON *e = cJSON_GetObjectItemCaseSensitive(d, "error");
        watch_end(w, net_json_str(d, "state"), cJSON_IsString(e) ? e->valuestring : NULL,
                  net_json_str(d, "error_path"));
    }
    cJSON_Delete(d);
    return w->final[0] ? 1 : 0;
}

/* The pass just written, shown: a bar on a terminal, else a line. */
static void watch_show(struct watch *w) {
    const char *out = w->o->out;
    double t = w->seen_time, s = (double)w->written_samples;
    double eta = s >= (double)w->target ? 0 : t > 0 ? t * ((double)w->target - s) / s : -1;
    progress_pass(&w->prog, w->written, w->passes, w->written_samples, w->target, t, eta,
                  out ? output_name(out) : NULL);
}

/* The latest pass announced into -o, when not tried yet: 0, or -1 when
 * its image was refused (said). */
static int watch_fetch_pass(struct watch *w) {
    const struct client_opts *o = w->o;
    if (!o->out || w->seen <= w->tried) return 0;
    long k = w->seen;
    char url[1024], why[600] = "";
    snprintf(url, sizeof url, "%s/v1/jobs/%s/image.%s?pass=%ld", o->servers[0], w->id,
             output_kind_exr(o->out) ? "exr" : "png", k);
    struct net_buf b = {0};
    long st = job_request(o, "GET", url, NULL, &b, why, sizeof why);
    w->tried = k; /* 202, 410 pass_gone, a broken connection: the next pass will do */
    int rc = 0;
    long iw = 0, ih = 0;
    if (st == 200) {
        if (job_image_size(o->out, &b, &iw, &ih) != 0 || iw != w->w || ih != w->h)
            progress_end(&w->prog); /* the bar's line ended before job_write says why */
        if (job_write(o->out, &b, (int)w->w, (int)w->h) != 0) {
            w->refused = 1;
            rc = -1;
        } else {
            w->written = k, w->written_samples = w->seen_samples;
            watch_show(w);
        }
    }
    net_buf_free(&b);
    return rc;
}

static int watch_idle(void *user) {
    struct watch *w = user;
    if (job_stopped()) return 1;
    return watch_fetch_pass(w) < 0 ? -1 : 0;
}

/* A frame-range job's frames and size from its JSON into w (job_frames.c
 * follows it): 0, or -1 said. */
static int watch_frames(struct watch *w, const cJSON *j) {
    double a, b, rw, rh;
    if (watch_num(j, "frames", "first", 0, 1000000, true, &a) &&
        watch_num(j, "frames", "last", a, 1000000, true, &b) &&
        watch_num(j, "region", "w", 1, 65536, true, &rw) &&
        watch_num(j, "region", "h", 1, 65536, true, &rh) && rw * rh <= (double)WATCH_MAX_PIXELS) {
        w->frames = 1;
        w->first = (long)a, w->last = (long)b, w->w = (long)rw, w->h = (long)rh;
        return 0;
    }
    char f[160], safe[200];
    const cJSON *fr = cJSON_GetObjectItemCaseSensitive(j, "frames");
    char *text = cJSON_PrintUnformatted(fr);
    snprintf(f, sizeof f, "%s", text ? text : "?");
    cJSON_free(text);
    fprintf(stderr,
            "rayd-client: error: job %s: its frames %s and region are no frame-range job's "
            "(frames first <= last in 0..1000000, a region of 1..65536 a side)\n",
            w->id, net_safe(f, safe, sizeof safe));
    return -1;
}

/* The job's size, kind and passes from its JSON (first: the first time):
 * 0; -1 after saying why (an error answer, a job we cannot follow, or
 * the first time a transport error); 1 on a later transport error. */
static int watch_status(struct watch *w, bool first) {
    const struct client_opts *o = w->o;
    char url[1024], why[600] = "";
    snprintf(url, sizeof url, "%s/v1/jobs/%s", o->servers[0], w->id);
    struct net_buf b = {0};
    long st = job_request(o, "GET", url, NULL, &b, why, sizeof why);
    int rc = st ? -1 : 1;
    if (!st && first) { /* the server is not there: said, as any command says it */
        fprintf(stderr, "rayd-client: error: job %s: %s\n", w->id, why);
        rc = -1;
    }
    cJSON *j = st == 200 ? cJSON_ParseWithLength(b.data, b.len) : NULL;
    double rw, rh, n, target;
    if (st && st != 200) {
        net_describe(st, &b, why, sizeof why);
        fprintf(stderr, "rayd-client: error: job %s: %s\n", w->id, why);
    } else if (first && st == 200 && cJSON_GetObjectItemCaseSensitive(j, "frames")) {
        rc = watch_frames(w, j);
    } else if (first && st == 200 &&
               (!watch_num(j, "region", "w", 1, 65536, true, &rw) ||
                !watch_num(j, "region", "h", 1, 65536, true, &rh) ||
                rw * rh > (double)WATCH_MAX_PIXELS ||
                (w->w && (rw != (double)w->w || rh != (double)w->h)))) {
        w->refused = 1;
        fprintf(stderr,
                "rayd-client: error: job %s: its region is not the %ldx%ld image asked "
                "for\n",
                w->id, w->w, w->h);
    } else if (st == 200) {
        rc = 0;
        if (first) {
            w->w = (long)rw, w->h = (long)rh;
            w->progressive = cJSON_IsObject(cJSON_GetObjectItemCaseSensitive(j, "passes"));
            if (w->progressive && watch_num(j, "passes", "total", 1, 64, true, &n) &&
                watch_num(j, "passes", "samples_target", 1, WATCH_MAX_SAMPLES, true, &target))
                w->passes = (long)n, w->target = (long)target;
            else if (w->progressive)
                watch_warn(w, "pass figures");
        }
        if (w->progressive) {
            watch_pass(w, cJSON_GetObjectItemCaseSensitive(j, "passes"), "done", "total");
            watch_stopped(w, cJSON_GetObjectItemCaseSensitive(j, "passes"));
        } else
            watch_tiles(w, j, "tiles_done", "tiles_total");
        const char *state = net_json_str(j, "state");
        if (state && strcmp(state, "queued") && strcmp(state, "running")) {
            const cJSON *e = cJSON_GetObjectItemCaseSensitive(j, "error");
            watch_end(w, state, cJSON_IsString(e) ? e->valuestring : net_json_str(e, "message"),
                      net_json_str(e, "path"));
        }
    }
    cJSON_Delete(j);
    net_buf_free(&b);
    return rc;
}

/* Polls the job once a second until it ended: 0, or 1 said (it is gone,
 * or the server did not answer for --timeout seconds). */
static int watch_poll(struct watch *w) {
    double failing = -1;
    while (!w->final[0] && !job_stopped()) {
        int rc = watch_status(w, false);
        if (rc < 0) return 1;
        if (rc > 0 && failing < 0) failing = net_now();
        if (rc == 0) failing = -1;
        if (failing >= 0 && net_now() - failing > w->o->timeout) {
            progress_end(&w->prog);
            fprintf(stderr, "rayd-client: error: job %s: %s did not answer for %.0f s\n", w->id,
                    w->o->servers[0], w->o->timeout);
            return 1;
        }
        if (watch_fetch_pass(w) < 0) return 1;
        if (!w->final[0]) watch_sleep(1000);
    }
    return 0;
}

/* Follows the event stream, opened again when it breaks: 0 when the job
 * ended (or Ctrl-C came), 1 to poll instead, -1 when an image was
 * refused (said). */
static int watch_stream(struct watch *w) {
    char url[1024];
    snprintf(url, sizeof url, "%s/v1/jobs/%s/events", w->o->servers[0], w->id);
    struct sse s = {.o = w->o, .on_event = watch_on_event, .idle = watch_idle, .user = w};
    for (int strikes = 0;;) {
        int news = w->news;
        int rc = sse_run(&s, url);
        if (rc == SSE_DONE || rc == SSE_STOPPED || rc == SSE_FAILED) {
            net_buf_free(&s.error_body);
            return rc == SSE_FAILED ? -1 : 0;
        }
        char why[600];
        if (rc == SSE_REFUSED)
            net_describe(s.status, &s.error_body, why, sizeof why);
        else
            snprintf(why, sizeof why, "%s", s.why);
        net_buf_free(&s.error_body);
        strikes = w->news > news ? 0 : strikes + 1;
        if (rc == SSE_REFUSED || strikes >= WATCH_STRIKES) {
            if (!w->o->quiet) {
                progress_end(&w->prog);
                fprintf(stderr, "rayd-client: the job's event stream failed (%s): polling\n", why);
            }
            return 1;
        }
        watch_sleep(s.retry_ms ? s.retry_ms : 1000);
        if (job_stopped()) return 0;
    }
}

/* What -o holds, for the last words. */
static void watch_holds(const struct watch *w, char *buf, size_t size) {
    const char *out = w->o->out;
    if (!out)
        snprintf(buf, size, "nothing written (no -o)");
    else if (w->written)
        snprintf(buf, size, "%s holds pass %ld of %ld (%ld samples)", output_name(out), w->written,
                 w->passes, w->written_samples);
    else
        snprintf(buf, size, "nothing written to %s", output_name(out));
}

/* Why a progressive job that succeeded ended before its last pass, as
 * words for its last line ("" when it ran every pass): the job's JSON
 * read once more, since the "done" event does not say. */
static void watch_early(struct watch *w, char *buf, size_t size) {
    buf[0] = '\0';
    if (!w->progressive || w->seen >= w->passes) return;
    if (!w->stopped) watch_status(w, false);
    if (w->stopped)
        snprintf(buf, size, ", stopped at pass %ld of %ld (%ld of %ld samples) by %s", w->seen,
                 w->passes, w->seen_samples, w->target, watch_stops[w->stopped][1]);
}

/* The job's final image into -o (202 while it is encoded): 0, or 1 said. */
static int watch_final(struct watch *w) {
    const struct client_opts *o = w->o;
    char url[1024], why[600] = "";
    snprintf(url, sizeof url, "%s/v1/jobs/%s/image.%s", o->servers[0], w->id,
             output_kind_exr(o->out) ? "exr" : "png");
    struct net_buf b = {0};
    long st = 0;
    for (int tries = 0; tries < 600 && !job_stopped(); tries++) {
        net_buf_reset(&b);
        st = job_request(o, "GET", url, NULL, &b, why, sizeof why);
        if (st != 202) break;
        watch_sleep(200);
    }
    int rc = 1;
    if (st == 200 && job_write(o->out, &b, (int)w->w, (int)w->h) == 0) {
        rc = 0;
        char early[200];
        if (!o->quiet) {
            watch_early(w, early, sizeof early);
            fprintf(stderr, "rayd-client: job %s succeeded%s; wrote %s\n", w->id, early,
                    output_name(o->out));
        }
    } else if (st == 200) {
        w->refused = 1;
    } else if (!job_stopped()) {
        if (st) net_describe(st, &b, why, sizeof why);
        fprintf(stderr, "rayd-client: error: job %s: %s\n", w->id, why);
    }
    net_buf_free(&b);
    return rc;
}

/* The end of the following: the exit status, said. */
static int watch_finish(struct watch *w, int failed) {
    const struct client_opts *o = w->o;
    char holds[600];
    progress_end(&w->prog);
    if (!failed && !w->refused && !strcmp(w->final, "succeeded") && !job_stopped()) {
        if (!o->out) {
            char early[200];
            if (!o->quiet) {
                watch_early(w, early, sizeof early);
                fprintf(stderr, "rayd-client: job %s succeeded%s\n", w->id, early);
            }
            return 0;
        }
        if (watch_final(w) == 0) return 0;
        failed = 1;
    }
    watch_holds(w, holds, sizeof holds);
    if (job_stopped() && w->cancels) {
        job_cancel(o, w->id);
        fprintf(stderr, "rayd-client: %s\n", holds);
        return 130;
    }
    if (job_stopped()) {
        fprintf(stderr,
                "rayd-client: interrupted; job %s goes on (%s); to follow it again: rayd-client "
                "watch %s%s%s --server %s\n",
                w->id, holds, w->id, o->out ? " -o " : "", o->out ? o->out : "", o->servers[0]);
        return 130;
    }
    char state[16];
    if (w->refused && w->cancels && job_delete(o, w->id, state, sizeof state))
        fprintf(stderr, "rayd-client: job %s cancelled: its image was refused\n", w->id);
    if (!failed && !w->refused && w->final[0])
        fprintf(stderr, "rayd-client: error: job %s %s%s%s%s; %s\n", w->id, w->final, w->where,
                w->error[0] ? ": " : "", w->error, holds);
    else if (w->written || w->refused)
        fprintf(stderr, "rayd-client: %s\n", holds);
    return 1;
}

/* Follows w->id to its end: the exit status. */
static int watch_follow(struct watch *w) {
    net_label(w->o->servers[0], w->label[0], sizeof w->label[0]);
    progress_init(&w->prog, 1, w->o->quiet);
    if (watch_status(w, true) != 0) return watch_finish(w, 1);
    if (w->frames) { /* watch_job hands it to job_frames.c */
        progress_end(&w->prog);
        return 0;
    }
    if (w->o->video) {
        fprintf(stderr, "rayd-client: error: --video: job %s renders one image, not frames\n",
                w->id);
        return watch_finish(w, 1);
    }
    int failed = 0;
    if (!w->final[0] && !job_stopped()) {
        int rc = watch_stream(w);
        if (rc > 0 && !job_stopped()) failed = watch_poll(w);
        failed |= rc < 0;
    }
    if (!failed && !job_stopped() && watch_fetch_pass(w) < 0) failed = 1;
    return watch_finish(w, failed);
}

/* The query of render --progressive. */
static void watch_query(const struct client_opts *o, char *q, size_t size) {
    size_t n = (size_t)snprintf(q, size, "?progressive=1");
    if (o->pass_step) n += (size_t)snprintf(q + n, size - n, "&pass_step=%s", o->pass_step);
    if (o->time_budget) n += (size_t)snprintf(q + n, size - n, "&time_budget=%s", o->time_budget);
    if (o->noise_target)
        n += (size_t)snprintf(q + n, size - n, "&noise_target=%s", o->noise_target);
    if (output_kind_exr(o->out)) snprintf(q + n, size - n, "&format=exr");
}

int watch_render(const struct client_opts *o, const struct scenefile *sf) {
    char query[256], id[64] = "";
    watch_query(o, query, sizeof query);
    if (o->out && output_writable(o->out) != 0) return 1; /* said before the job, not after */
    job_signals(1);
    int rc = job_post(o, sf, query, id, sizeof id);
    if (rc == 0 && o->detach) {
        printf("%s\n", id);
        if (!o->quiet)
            fprintf(stderr,
                    "rayd-client: job %s on %s runs on; follow it with: rayd-client watch %s -o "
                    "%s --server %s\n",
                    id, o->servers[0], id, o->out, o->servers[0]);
    } else if (rc == 0) {
        if (!o->quiet)
            fprintf(stderr,
                    "rayd-client: job %s on %s (%dx%d, up to %d samples); Ctrl-C cancels it\n", id,
                    o->servers[0], sf->width, sf->height, sf->samples);
        struct watch w = {.o = o, .id = id, .cancels = 1, .w = sf->width, .h = sf->height};
        rc = watch_follow(&w);
    }
    job_signals(0);
    return rc;
}

int watch_job(const struct client_opts *o, const char *id) {
    job_signals(1);
    struct watch w = {.o = o, .id = id};
    int rc = watch_follow(&w);
    if (w.frames && !job_stopped())
        rc = job_frames_watch(o, id, w.first, w.last, (int)w.w, (int)w.h);
    else if (w.frames) { /* Ctrl-C before the frames were followed */
        fprintf(stderr, "rayd-client: interrupted; job %s goes on\n", id);
        rc = 130;
    }
    job_signals(0);
    return rc;
}
