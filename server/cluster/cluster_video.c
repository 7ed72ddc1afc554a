/* cluster_video.c -- a frame range's video, made by whichever node takes
 * its item (the puller's).
 *
 * The script that stores a frame-range job's last frame (cluster_assemble.c)
 * marks the job's video "making" and queues its item (tile -2) in that same
 * script, so a job whose frames are all done always has its video made or
 * on the way, whatever node dies when.  The node that takes the item reads
 * every frame's PNG from Redis (one MGET), charges them and room for the
 * video to its memory budget (--max-memory), as an assembly is charged, and runs
 * video_encode (the ffmpeg program, as a single node's video) on a thread
 * of its own: an encode takes seconds, and the puller must go on refreshing
 * its claims and taking tiles meanwhile.  The thread only records what came
 * out and wakes the puller (its callback), which stores the MP4 as
 * rayd:{ID}:video, expiring with the job's other keys, and the job's
 * "video" field -- ready, or why not -- then acknowledges the item.
 *
 * Idempotent as the rest: an item taken again (its node stalled, or died
 * before the ack) finds the video ready or failed and is dropped, or, still
 * "making", makes the same MP4 again.  A video cannot be retried by a node
 * with the same budget, so a frame missing from Redis (expired, evicted)
 * or frames over the node's whole --max-memory fail the video, saying so;
 * a budget with no room now leaves the item for later, as an assembly.
 * When the puller stops while a video is still encoding, the thread is left
 * to finish and free what it holds (cluster_video_drop).
 */
#include "cluster/cluster_private.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Seconds ffmpeg may take for a video of n frames (a single node's). */
#define CLUSTER_VIDEO_SECONDS(n) (60.0 + 2.0 * (n))

struct cluster_video {
    pthread_mutex_t mu;
    int refs;                /* the item's and the thread's */
    void (*done)(void *ctx); /* the puller's wake-up, until dropped */
    void *ctx;               /* NULL once the item is dropped */
    char id[33];
    struct blob **frames; /* the PNGs, in order */
    long n;
    double fps;
    size_t charged;       /* the memory budget's bytes */
    enum video_status st; /* once done */
    struct blob *mp4;
    char err[200];
};

static void cluster_video_unref(struct cluster_video *v) {
    pthread_mutex_lock(&v->mu);
    bool last = --v->refs == 0;
    pthread_mutex_unlock(&v->mu);
    if (!last) return;
    for (long i = 0; v->frames && i < v->n; i++) blob_unref(v->frames[i]);
    free(v->frames);
    blob_unref(v->mp4);
    mem_release(MEM_RESULTS, v->charged);
    pthread_mutex_destroy(&v->mu);
    free(v);
}

static void *cluster_video_main(void *arg) {
    struct cluster_video *v = arg;
    struct blob *mp4 = NULL;
    char err[200] = "";
    enum video_status st = video_encode(v->frames, (int)v->n, v->fps > 0 ? v->fps : 24,
                                        CLUSTER_VIDEO_SECONDS(v->n), &mp4, err, sizeof err);
    pthread_mutex_lock(&v->mu);
    v->st = st;
    v->mp4 = mp4;
    snprintf(v->err, sizeof v->err, "%s", err);
    if (v->ctx) v->done(v->ctx);
    pthread_mutex_unlock(&v->mu);
    cluster_video_unref(v);
    return NULL;
}

/* The job's fields the video needs: false when Redis failed. */
static bool cluster_video_job(struct redis *c, const char *id, char state[16], char video[16],
                              long *first, long *last, double *fps) {
    char key[120];
    cluster_key(key, sizeof key, id, "job");
    const char *argv[] = {"HMGET", key, "state", "video", "first", "last", "fps", NULL};
    redisReply *rep = redis_strs(c, argv);
    if (redis_failed(c, rep) || rep->type != REDIS_REPLY_ARRAY || rep->elements != 5) {
        if (rep) freeReplyObject(rep);
        return false;
    }
    redisReply **e = rep->element;
    snprintf(state, 16, "%s", e[0]->type == REDIS_REPLY_STRING ? e[0]->str : "");
    snprintf(video, 16, "%s", e[1]->type == REDIS_REPLY_STRING ? e[1]->str : "");
    *first = (long)redis_ll(e[2], 0);
    *last = (long)redis_ll(e[3], -1);
    *fps = e[4]->type == REDIS_REPLY_STRING ? strtod(e[4]->str, NULL) : 0;
    freeReplyObject(rep);
    return true;
}

/* Records the video's end as the job's "video" field ("ready", or
 * "failed: why" / "no_ffmpeg: why") and the MP4 as rayd:{ID}:video,
 * expiring with the job; false when Redis failed. */
static const char cluster_lua_video[] =
    "local p = 'rayd:{' .. ARGV[1] .. '}:'\n"
    "if not redis.call('HGET', p .. 'job', 'state') then return -2 end\n"
    "if ARGV[2] == 'ready' then\n"
    "  local ttl = redis.call('PTTL', p .. 'job')\n"
    "  if ttl > 0 then redis.call('SET', p .. 'video', ARGV[3], 'PX', ttl)\n"
    "  else redis.call('SET', p .. 'video', ARGV[3]) end\n"
    "end\n"
    "redis.call('HSET', p .. 'job', 'video', ARGV[2])\n"
    "return 1\n";

static bool cluster_video_record(struct redis *c, const char *id, const char *state,
                                 const struct blob *mp4) {
    const char *argv[] = {"EVAL", cluster_lua_video, "0", id, state, mp4 ? mp4->data : ""};
    size_t lens[6];
    for (int i = 0; i < 6; i++) lens[i] = i == 5 ? (mp4 ? mp4->len : 0) : strlen(argv[i]);
    redisReply *rep = redis_argv(c, 6, argv, lens);
    bool ok = !redis_failed(c, rep);
    if (rep) freeReplyObject(rep);
    return ok;
}

/* The video failed before it started: recorded (the item is done). */
static bool cluster_video_fail(struct redis *c, const char *id, const char *why) {
    char state[240];
    snprintf(state, sizeof state, "failed: %s", why);
    log_warn("cluster: job %s: no video: %s", id, why);
    return cluster_video_record(c, id, state, NULL);
}

/* The frames' PNGs of v (v->n of them from first) read into v->frames; 0,
 * -1 when Redis failed, or the number + 1 of a frame Redis no longer has. */
static long cluster_video_frames(struct redis *c, struct cluster_video *v, long first) {
    const char **argv = calloc((size_t)v->n + 1, sizeof *argv);
    char *keys = calloc((size_t)v->n, 120);
    v->frames = calloc((size_t)v->n, sizeof *v->frames);
    if (!argv || !keys || !v->frames) {
        free(argv);
        free(keys);
        return -1;
    }
    argv[0] = "MGET";
    for (long i = 0; i < v->n; i++) {
        char what[40];
        snprintf(what, sizeof what, "frame:%ld", first + i);
        cluster_key(keys + 120 * i, 120, v->id, what);
        argv[i + 1] = keys + 120 * i;
    }
    redisReply *rep = redis_argv(c, (int)v->n + 1, argv, NULL);
    free(argv);
    free(keys);
    long rc = 0;
    if (redis_failed(c, rep) || rep->type != REDIS_REPLY_ARRAY || rep->elements != (size_t)v->n)
        rc = -1;
    for (long i = 0; rc == 0 && i < v->n; i++) {
        const redisReply *e = rep->element[i];
        void *data = e->type == REDIS_REPLY_STRING && e->len > 0 ? malloc(e->len) : NULL;
        if (data) memcpy(data, e->str, e->len);
        if (!data || !(v->frames[i] = blob_new(data, e->len))) {
            free(data);
            rc = e->type == REDIS_REPLY_STRING && e->len > 0 ? -1 : first + i + 1;
        }
    }
    if (rep) freeReplyObject(rep);
    return rc;
}

/* Room in the budget for the video (at worst as large as its frames,
 * which their blobs count already): reserved into v->charged.  When the
 * frames and the video could never fit, *fail (why says so); when there
 * is no room now, the item waits (counted). */
static bool cluster_video_reserve(struct cluster_video *v, bool *fail, char *why, size_t n) {
    size_t need = 65536;
    for (long i = 0; i < v->n; i++) need += v->frames[i]->len;
    *fail = 2 * need > mem_limit();
    if (*fail) {
        snprintf(why, n, "its %ld frames and video need %zu bytes, over this node's --max-memory",
                 v->n, 2 * need);
        return false;
    }
    if (!mem_reserve(MEM_RESULTS, need)) {
        atomic_fetch_add(&cluster_deferred_total, 1);
        log_warn("cluster: job %s: its video needs %zu bytes and this node's memory budget has "
                 "no room now; left for later",
                 v->id, need);
        return false;
    }
    v->charged = need;
    return true;
}

/* v's frames read and charged, its thread started: 1; 0 when the item is
 * done (a failure recorded), -1 when it waits or Redis failed. */
static int cluster_video_begin(struct redis *c, struct cluster_video *v, long first) {
    char why[200];
    bool fail = false;
    long rc = cluster_video_frames(c, v, first);
    if (rc > 0) {
        snprintf(why, sizeof why, "frame %ld is no longer in Redis (expired or evicted)", rc - 1);
        return cluster_video_fail(c, v->id, why) ? 0 : -1;
    }
    if (rc < 0) return -1;
    if (!cluster_video_reserve(v, &fail, why, sizeof why))
        return fail && cluster_video_fail(c, v->id, why) ? 0 : -1;
    pthread_t t;
    v->refs = 2; /* the thread's, before it can run */
    if (pthread_create(&t, NULL, cluster_video_main, v) != 0) {
        v->refs = 1;
        return -1;
    }
    pthread_detach(t);
    log_info("cluster: job %s: making its video of %ld frames", v->id, v->n);
    return 1;
}

struct cluster_video *cluster_video_start(struct redis *c, const char *id, bool *ack,
                                          void (*done)(void *ctx), void *ctx) {
    char state[16], video[16];
    long first = 0, last = -1;
    double fps = 0;
    *ack = false;
    if (!cluster_video_job(c, id, state, video, &first, &last, &fps)) return NULL;
    if (strcmp(state, "succeeded") || strcmp(video, "making") || last < first) {
        *ack = true; /* made already, failed, or the job is gone: nothing to do */
        return NULL;
    }
    struct cluster_video *v = calloc(1, sizeof *v);
    if (!v) return NULL;
    pthread_mutex_init(&v->mu, NULL);
    snprintf(v->id, sizeof v->id, "%s", id);
    v->n = last - first + 1;
    v->fps = fps;
    v->done = done;
    v->ctx = ctx;
    v->refs = 1;
    int rc = cluster_video_begin(c, v, first);
    if (rc == 1) return v;
    *ack = rc == 0;
    cluster_video_unref(v);
    return NULL;
}

bool cluster_video_store(struct redis *c, struct cluster_video *v) {
    char state[240] = "ready";
    pthread_mutex_lock(&v->mu);
    enum video_status st = v->st;
    struct blob *mp4 = blob_ref(v->mp4);
    if (st != VIDEO_OK)
        snprintf(state, sizeof state, "%s: %s", st == VIDEO_NO_FFMPEG ? "no_ffmpeg" : "failed",
                 v->err);
    pthread_mutex_unlock(&v->mu);
    if (st != VIDEO_OK) log_warn("cluster: job %s: no video: %s", v->id, state);
    bool ok = cluster_video_record(c, v->id, state, st == VIDEO_OK ? mp4 : NULL);
    if (ok && mp4 && st == VIDEO_OK)
        log_info("cluster: job %s: its video is made (%zu bytes)", v->id, mp4->len);
    blob_unref(mp4);
    return ok;
}

void cluster_video_drop(struct cluster_video *v) {
    if (!v) return;
    pthread_mutex_lock(&v->mu);
    v->ctx = NULL; /* the thread wakes no one any more */
    pthread_mutex_unlock(&v->mu);
    cluster_video_unref(v);
}
