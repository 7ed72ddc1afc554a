/* job_frames.c -- `rayd-client job` of an animated scene: a frame-range job.
 *
 * POST /v1/jobs?frames=A-B (--frames; without it the scene's whole
 * animation) makes one job of many frames, each rendered on the server as
 * a still of its own.  We check the range and the -o pattern before
 * anything is sent: frames outside the scene's animation, a still scene,
 * or a range of several frames written to an -o without %d (every frame
 * would overwrite the last) are usage errors, exit 2, as rayd-render says
 * them, and frame k's file is named by the same code (programs/common/
 * frame_name.c), so shot-%04d.png is shot-0007.png from either program.
 *
 * Then we follow the job's event stream (sse.c): each "frame" event of a
 * frame done makes us GET /v1/jobs/{id}/frames/{k}.png (.exr for -o
 * *.exr) between events.  A stream that breaks is opened again (it
 * replays the job; frames we hold are skipped); one that ends three times
 * without news gives way to polling.  Once the stream said "done" (or
 * failed), we poll GET /v1/jobs/{id} twice a second, which then ends at
 * once: the job's JSON says how many frames are done and how the job
 * ended, and nothing is lost when a connection breaks.  Each time more
 * frames are done than we hold, we ask for the lowest frames we lack
 * until we hold as many as are done: frames start in order, so the "409
 * frame_not_ready" answers met on the way are at most the frames in
 * flight.  A frame is checked as job.c checks an image (a PNG or OpenEXR
 * of the scene's size) and written through a temporary file renamed when
 * whole (output.c); a frame refused so stops the following and cancels
 * the job (DELETE), whose other frames would be of no use.
 *
 * The progress: on a terminal the bar of progress.c, in frames; else one
 * line per frame written, "frame K -> FILE (frames D/N, ETA 1m05s)", with the
 * server's eta_s when polled, else the pace of the frames so far.  A failed job's frames done are
 * still written; then its error, which names the failed frames (and the value at fault by its
 * JSON Pointer, when it has one), is printed and we exit 1.
 *
 * --video: once every frame is written, GET /v1/jobs/{id}/video.mp4,
 * which answers 202 while ffmpeg makes it; we ask again each second, for
 * at most the server's own bound (60 s plus 2 s a frame) and a minute
 * more.  Ctrl-C at any point cancels the job (job_cancel) and exits 130.
 * --detach prints the job's id and leaves it: `rayd-client watch ID -o
 * PATTERN` (job_frames_watch) follows it then, or again after the client
 * or the node it followed died, writing every frame done (and the video);
 * its Ctrl-C and a frame refused leave the job running, as watch's do.
 */
#include "client.h"

#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* One frame-range job being followed. */
struct job_frames {
    const struct client_opts *o;
    const struct scenefile *sf;
    char id[64];
    long first, last;     /* its frames, inclusive */
    unsigned char *got;   /* got[k - first]: frame k written */
    unsigned char *ready; /* ready[k - first]: the stream said frame k is done */
    int refused;          /* a frame was no image of the scene's size */
    int leaves;           /* watch: Ctrl-C and a refused frame leave the job running */
    int news;             /* frames announced and the end, as the stream said them */
    long ngot, next;      /* frames written; the lowest not written */
    double eta;           /* the server's eta_s, -1 when unknown */
    struct progress prog;
    char label[1][40];
};

static void job_frames_sleep(long ms) {
    struct timespec ts = {ms / 1000, (ms % 1000) * 1000000L};
    nanosleep(&ts, NULL);
}

/* Whether -o's pattern names frames from..to a file each: true, or false
 * said (the usage line left to the caller). */
static bool job_frames_pattern(const char *out, long from, long to) {
    char path[4096];
    int numbered = frame_name_path(out, from, path, sizeof path);
    if (numbered < 0)
        prog_error("-o %s: " FRAME_NAME_RULE, out);
    else if (numbered == 0 && to > from)
        prog_error("-o %s: a job of frames %ld-%ld writes a file a frame: give -o a %%d, e.g. "
                   "-o 'shot-%%04d.png'",
                   out, from, to);
    return numbered > 0 || (numbered == 0 && to == from);
}

/* The range asked for, checked against the scene's and -o: 0, or 2 said. */
static int job_frames_check(const struct client_opts *o, const struct scenefile *sf, long *from,
                            long *to) {
    *from = o->frames_set ? o->frame_a : sf->anim_start;
    *to = o->frames_set ? o->frame_b : sf->anim_end;
    if (!sf->animated)
        prog_error("--frames %ld-%ld: the scene has no /animation, so it has no frames to range "
                   "over",
                   *from, *to);
    else if (*from < sf->anim_start || *to > sf->anim_end)
        prog_error("%s: /animation: frame %ld is outside the animation's frames %ld-%ld", sf->name,
                   *to > sf->anim_end ? *to : *from, sf->anim_start, sf->anim_end);
    else if (job_frames_pattern(o->out, *from, *to))
        return 0;
    fprintf(stderr, "Try 'rayd-client --help'.\n");
    return 2;
}

/* Frame k, if it is done, into its file: 1 written, 0 not done yet, -1
 * said (an answer that is no frame, a write error). */
static int job_frames_get(struct job_frames *j, long k) {
    const struct client_opts *o = j->o;
    char url[1024], why[600] = "", path[4096];
    bool exr = output_kind_exr(o->out);
    snprintf(url, sizeof url, "%s/v1/jobs/%s/frames/%ld.%s", o->servers[0], j->id, k,
             exr ? "exr" : "png");
    frame_name_path(o->out, k, path, sizeof path);
    struct net_buf b = {0};
    long st = job_request(o, "GET", url, NULL, &b, why, sizeof why);
    char code[64];
    int rc =
        st == 409 && !strcmp(net_error_code(&b, code, sizeof code), "frame_not_ready") ? 0 : -1;
    if (st == 200) {
        progress_end(&j->prog);
        rc = job_write(path, &b, j->sf->width, j->sf->height) == 0 ? 1 : -1;
        j->refused |= rc < 0;
    } else if (rc < 0 && !job_stopped()) {
        if (st) net_describe(st, &b, why, sizeof why);
        progress_end(&j->prog);
        fprintf(stderr, "rayd-client: error: job %s: frame %ld: %s\n", j->id, k, why);
    }
    net_buf_free(&b);
    if (rc == 1) {
        j->got[k - j->first] = 1;
        j->ngot++;
        long total = j->last - j->first + 1, per = j->ngot;
        double eta = j->eta >= 0
                         ? j->eta /* the server's, when polled; else the pace so far */
                         : (net_now() - j->prog.t0) / (double)j->ngot * (double)(total - j->ngot);
        char left[32];
        progress_eta(j->ngot == total ? 0 : eta, left, sizeof left);
        if (j->prog.tty)
            progress_update(&j->prog, (int)j->ngot, 0, 1, &per, j->label, -1, 1);
        else if (!o->quiet)
            fprintf(stderr, "rayd-client: frame %ld -> %s (frames %ld/%ld, ETA %s)\n", k, path,
                    j->ngot, total, left);
    }
    return rc;
}

/* Writes the lowest frames not written yet until as many are written as
 * the server says are done: 0, or -1 said. */
static int job_frames_collect(struct job_frames *j, long done) {
    for (long k = j->next; k <= j->last && j->ngot < done && !job_stopped(); k++) {
        if (j->got[k - j->first]) continue;
        if (job_frames_get(j, k) < 0) return -1;
    }
    while (j->next <= j->last && j->got[j->next - j->first]) j->next++;
    return 0;
}

/* A number of the job's JSON at o[k1][k2] (k2 NULL: o[k1]), or def. */
static double job_frames_num(const cJSON *o, const char *k1, const char *k2, double def) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, k1);
    if (k2) v = cJSON_GetObjectItemCaseSensitive(v, k2);
    return cJSON_IsNumber(v) ? v->valuedouble : def;
}

/* The job's end when it is not "succeeded": said, with the error's JSON
 * Pointer when it has one (" at /objects/0/source/file", as net_describe
 * says an answer's); 1. */
static int job_frames_ended(struct job_frames *j, const cJSON *job, const char *state) {
    const cJSON *e = cJSON_GetObjectItemCaseSensitive(job, "error");
    const char *msg = cJSON_IsString(e) ? e->valuestring : net_json_str(e, "message");
    const char *path = net_json_str(e, "path");
    char safe[600], st[64], where[300] = "", sp[240];
    if (path && *path) snprintf(where, sizeof where, " at %s", net_safe(path, sp, sizeof sp));
    progress_end(&j->prog);
    fprintf(stderr, "rayd-client: error: job %s %s%s%s%s (%ld of %ld frames written)\n", j->id,
            net_safe(state, st, sizeof st), where, msg ? ": " : "",
            msg ? net_safe(msg, safe, sizeof safe) : "", j->ngot, j->last - j->first + 1);
    return 1;
}

/* A job that says it succeeded but serves not every frame: said; 1. */
static int job_frames_missing(struct job_frames *j) {
    progress_end(&j->prog);
    fprintf(stderr,
            "rayd-client: error: job %s succeeded but serves %ld of its %ld frames (frame %ld is "
            "not done)\n",
            j->id, j->ngot, j->last - j->first + 1, j->next);
    return 1;
}

/* A frame event: frame k done is marked ready; "done" ends the stream. */
static int job_frames_event(void *user, const char *event, const char *data) {
    struct job_frames *j = user;
    if (!strcmp(event, "done")) {
        j->news++;
        return 1;
    }
    if (strcmp(event, "frame")) return 0;
    cJSON *d = cJSON_Parse(data);
    double k = job_frames_num(d, "k", NULL, -1);
    const char *state = net_json_str(d, "state");
    if (k >= (double)j->first && k <= (double)j->last && k == (double)(long)k && state &&
        !strcmp(state, "done") && !j->got[(long)k - j->first]) {
        j->ready[(long)k - j->first] = 1; /* checked, not trusted: a frame of ours */
        j->news++;
    }
    cJSON_Delete(d);
    return 0;
}

/* Between events: the frames announced, fetched. */
static int job_frames_idle(void *user) {
    struct job_frames *j = user;
    if (job_stopped()) return 1;
    for (long k = j->next; k <= j->last && !job_stopped(); k++) {
        if (!j->ready[k - j->first] || j->got[k - j->first]) continue;
        j->ready[k - j->first] = 0;
        if (job_frames_get(j, k) < 0) return -1;
    }
    while (j->next <= j->last && j->got[j->next - j->first]) j->next++;
    return 0;
}

/* Follows the event stream until the job ended: 0 (then the poll below
 * ends it), -1 when a frame failed (said). */
static int job_frames_stream(struct job_frames *j) {
    char url[1024];
    snprintf(url, sizeof url, "%s/v1/jobs/%s/events", j->o->servers[0], j->id);
    struct sse s = {.o = j->o, .on_event = job_frames_event, .idle = job_frames_idle, .user = j};
    for (int strikes = 0; strikes < 3 && !job_stopped();) {
        int news = j->news, rc = sse_run(&s, url);
        net_buf_free(&s.error_body);
        if (rc == SSE_DONE) job_frames_idle(j);
        if (rc == SSE_DONE || rc == SSE_STOPPED || rc == SSE_REFUSED) break;
        if (rc == SSE_FAILED) return -1;
        strikes = j->news > news ? 0 : strikes + 1;
        if (strikes < 3) job_frames_sleep(s.retry_ms ? s.retry_ms : 1000);
    }
    return j->refused ? -1 : 0;
}

/* Follows the job, writing frames as they are done, until it ended: 0 when
 * it succeeded and every frame is written, 1 said, 130 interrupted. */
static int job_frames_follow(struct job_frames *j) {
    const struct client_opts *o = j->o;
    char url[1024], why[600] = "";
    snprintf(url, sizeof url, "%s/v1/jobs/%s", o->servers[0], j->id);
    struct net_buf b = {0};
    int rc = job_frames_stream(j) < 0 ? 1 : -1;
    double down = 0; /* since when the server has not answered (a restart) */
    while (rc < 0 && !job_stopped()) {
        net_buf_reset(&b);
        long st = job_request(o, "GET", url, NULL, &b, why, sizeof why);
        if (job_stopped()) break;
        if (st != 200) {
            progress_end(&j->prog); /* the bar's line ends before the warning or the error */
            if (!job_poll_again(o, j->id, st, &b, why, sizeof why, &down)) {
                rc = 1;
                break;
            }
            job_frames_sleep(1000);
            continue;
        }
        down = 0;
        cJSON *job = cJSON_ParseWithLength(b.data, b.len);
        const char *state = net_json_str(job, "state");
        long total = j->last - j->first + 1;
        double done = job_frames_num(job, "frames", "done", 0);
        done = done < 0               ? 0
               : done > (double)total ? (double)total
                                      : done; /* checked, not trusted */
        j->eta = job_frames_num(job, "eta_s", NULL, -1);
        if (!(j->eta >= 0 && j->eta <= 1e7)) j->eta = -1; /* checked, not trusted: unknown */
        bool succeeded = state && !strcmp(state, "succeeded");
        if (job_frames_collect(j, succeeded ? total : (long)done) < 0)
            rc = 1;
        else if (succeeded)
            rc = j->ngot == total ? 0 : job_frames_missing(j);
        else if (state && (!strcmp(state, "failed") || !strcmp(state, "canceled") ||
                           !strcmp(state, "evicted")))
            rc = job_frames_ended(j, job, state);
        cJSON_Delete(job);
        if (rc < 0) job_frames_sleep(500);
    }
    net_buf_free(&b);
    progress_end(&j->prog);
    char state[16];
    if (j->refused && !j->leaves && !job_stopped() && job_delete(o, j->id, state, sizeof state))
        fprintf(stderr, "rayd-client: job %s cancelled: a frame could not be written\n", j->id);
    if (job_stopped() && j->leaves) {
        fprintf(stderr,
                "rayd-client: interrupted; job %s goes on (%ld of %ld frames written); to follow "
                "it again: rayd-client watch %s -o '%s' --server %s\n",
                j->id, j->ngot, j->last - j->first + 1, j->id, o->out, o->servers[0]);
        return 130;
    }
    return job_stopped() ? job_cancel(o, j->id) : rc;
}

/* Whether b looks like an MP4: an "ftyp" box first. */
static bool job_frames_is_mp4(const struct net_buf *b) {
    return b->len >= 12 && !memcmp(b->data + 4, "ftyp", 4);
}

/* The job's video into o->video once the server made it: 0, or 1 said. */
static int job_frames_video(struct job_frames *j) {
    const struct client_opts *o = j->o;
    char url[1024], why[600] = "";
    snprintf(url, sizeof url, "%s/v1/jobs/%s/video.mp4", o->servers[0], j->id);
    struct net_buf b = {.max = (size_t)1 << 31};
    long st = 0, bound = 120 + 2 * (j->last - j->first + 1); /* seconds */
    for (long t = 0; t < bound && !job_stopped(); t++) {
        net_buf_reset(&b);
        st = job_request(o, "GET", url, NULL, &b, why, sizeof why);
        if (st != 202) break;
        job_frames_sleep(1000); /* ffmpeg at work; Retry-After says 1 */
    }
    int rc = 1;
    if (job_stopped() && j->leaves) {
        fprintf(stderr, "rayd-client: interrupted; job %s goes on; its video: GET %s\n", j->id,
                url);
        rc = 130;
    } else if (job_stopped()) {
        rc = job_cancel(o, j->id);
    } else if (st == 200 && !job_frames_is_mp4(&b)) {
        fprintf(stderr,
                "rayd-client: error: the job's video is not an MP4; nothing written to %s\n",
                o->video);
    } else if (st == 200) {
        rc = output_write(o->video, b.data, b.len) == 0 ? 0 : 1;
        if (rc == 0 && !o->quiet) fprintf(stderr, "rayd-client: wrote %s\n", o->video);
    } else {
        if (st == 202)
            snprintf(why, sizeof why, "still being made after %ld s", bound);
        else if (st)
            net_describe(st, &b, why, sizeof why);
        fprintf(stderr, "rayd-client: error: job %s: video: %s\n", j->id, why);
    }
    net_buf_free(&b);
    return rc;
}

/* Whether -o and --video can be written, the first frame's name made
 * from the pattern: 0, or 1 said. */
static int job_frames_writable(const struct job_frames *j) {
    char first[4096];
    frame_name_path(j->o->out, j->first, first, sizeof first);
    return output_writable(first) != 0 || (j->o->video && output_writable(j->o->video) != 0);
}

/* Follows job j->id (posted, or watched) to its end, each frame into its
 * file, then the video: the exit status.  Signals are caught by the
 * caller. */
static int job_frames_go(struct job_frames *j) {
    const struct client_opts *o = j->o;
    long total = j->last - j->first + 1;
    j->ready = calloc((size_t)total, 1);
    if (!(j->got = calloc((size_t)total, 1)) || !j->ready) {
        free(j->got);
        free(j->ready);
        prog_error("out of memory");
        return 1;
    }
    j->next = j->first;
    net_label(o->servers[0], j->label[0], sizeof j->label[0]);
    progress_init(&j->prog, (int)total, o->quiet);
    j->prog.unit = "frames";
    int rc = job_frames_follow(j);
    if (rc == 0 && !o->quiet)
        fprintf(stderr, "rayd-client: wrote %ld frame%s to %s\n", total, total > 1 ? "s" : "",
                o->out);
    if (rc == 0 && o->video) rc = job_frames_video(j);
    free(j->got);
    free(j->ready);
    return rc;
}

int job_frames_run(const struct client_opts *o, const struct scenefile *sf) {
    struct job_frames j = {.o = o, .sf = sf, .eta = -1};
    int rc = job_frames_check(o, sf, &j.first, &j.last);
    if (rc != 0) return rc;
    if (job_frames_writable(&j) != 0) return 1;
    char query[96];
    snprintf(query, sizeof query, "?frames=%ld-%ld%s", j.first, j.last,
             output_kind_exr(o->out) ? "&format=exr" : "");
    job_signals(1);
    if (job_post(o, sf, query, j.id, sizeof j.id) != 0) {
        job_signals(0);
        return 1;
    }
    if (o->detach) {
        printf("%s\n", j.id);
        if (!o->quiet)
            fprintf(stderr,
                    "rayd-client: job %s on %s runs on: frames %ld-%ld; follow it with: "
                    "rayd-client watch %s -o '%s'%s%s --server %s\n",
                    j.id, o->servers[0], j.first, j.last, j.id, o->out, o->video ? " --video " : "",
                    o->video ? o->video : "", o->servers[0]);
        job_signals(0);
        return 0;
    }
    if (!o->quiet)
        fprintf(stderr, "rayd-client: job %s on %s: frames %ld-%ld (%dx%d)\n", j.id, o->servers[0],
                j.first, j.last, sf->width, sf->height);
    rc = job_frames_go(&j);
    job_signals(0);
    return rc;
}

int job_frames_watch(const struct client_opts *o, const char *id, long first, long last, int w,
                     int h) {
    struct scenefile sf = {.name = id, .width = w, .height = h};
    struct job_frames j = {.o = o, .sf = &sf, .eta = -1, .leaves = 1, .first = first, .last = last};
    snprintf(j.id, sizeof j.id, "%s", id);
    if (!o->out)
        prog_error("watch: job %s renders frames %ld-%ld: give -o a pattern for their files, e.g. "
                   "-o 'shot-%%04d.png'",
                   id, first, last);
    if (!o->out || !job_frames_pattern(o->out, first, last)) {
        fprintf(stderr, "Try 'rayd-client --help'.\n");
        return 2;
    }
    if (job_frames_writable(&j) != 0) return 1;
    if (!o->quiet)
        fprintf(stderr, "rayd-client: job %s on %s: frames %ld-%ld (%dx%d); Ctrl-C leaves it\n", id,
                o->servers[0], first, last, w, h);
    return job_frames_go(&j);
}
