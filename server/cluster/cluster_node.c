/* cluster_node.c -- the puller: a node takes work items while it has room,
 * renders them through its own work layer, and keeps what it holds alive.
 *
 * One thread with its own Redis connection.  Each turn it
 *   - stores what finished: a tile's PNG (cluster_assemble.c), then XACK
 *     and XDEL of its item; a render that failed fails its job (the error
 *     JSON in the record), one cancelled by a drain is left to others, and
 *     one that failed on this node's own limits is left pending for
 *     another node, CLUSTER_TRIES attempts in all (node_failed);
 *   - every --redis-claim-ms / 3: refreshes the items it holds (XCLAIM to
 *     itself, JUSTID: their idle time restarts), writes its heartbeat in
 *     rayd:nodes, takes over items idle for longer than claim-ms
 *     (XAUTOCLAIM: a dead or stalled node's), removes gone nodes' consumers
 *     and heartbeats, and reads the cluster's figures for /healthz and
 *     /metrics;
 *   - while its items in flight are fewer than its workers, takes one, from
 *     the stream of the highest priority that has one (cluster_items.c), so
 *     a busy node takes less.
 * A tile item renders as any request does: compile_scene (or
 * compile_scene_frame, a frame of an animated scene) on the parse threads,
 * then sched_render of the tile's region as a PNG for the job's client, so
 * the node's fair shares and budgets hold for cluster work too.  Those
 * callbacks run on the work layer's threads and only mark the item and
 * wake this thread: Redis is called from here alone.  An assembly item
 * (tile -1) runs here, on this thread; a video item (tile -2) on a thread
 * of its own (cluster_video.c), held here as a tile is until it ends.
 *
 * Everything is idempotent (cluster_assemble.c), so an item is acked only
 * after its result is stored, and an item whose result could not be
 * stored (Redis went away) is simply forgotten here: its idle time grows
 * and some node -- this one too -- takes it over later and renders the same
 * bytes again.
 */
#include "cluster/cluster_private.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#define NODE_RETRY_S 0.5 /* a render the node refused (queue full) is tried again after */
/* How long an idle puller waits in Redis for a new item.  While it holds
 * items it never blocks in Redis (a render that finishes meanwhile would
 * wait for the read to end, and Redis ends a short BLOCK only at its next
 * tick, some 100 ms: a progressive job's next pass waits for its last
 * tile); it asks without waiting, then waits on its own condition, which a
 * finished render signals, for at most NODE_BUSY_WAIT_S. */
#define NODE_BLOCK_MS 100
#define NODE_BUSY_WAIT_S 0.01

enum node_phase { NP_START, NP_BUSY, NP_DONE, NP_FAILED, NP_RETRY, NP_DROP };

struct node_item {
    char sid[48], job[33];
    long frame, tile, ntiles;
    long pass;  /* a progressive job's pass (from 1), 0 for any other item */
    bool whole; /* a pass's tile whose running sums were lost: all its samples */
    int level;  /* the stream it came from (its job's priority) */
    bool animated;
    enum node_phase phase; /* NP_BUSY items belong to the work layer's callbacks */
    bool own_limit;        /* failed on this node's own limits (node_failed) */
    double retry_at;
    char *body;
    size_t len;
    struct work_target what;
    struct compile_waiter cw;
    struct work_waiter ww;
    struct blob *png, *exr;      /* exr: the tile's EXR too, for a job that keeps one */
    struct cluster_video *video; /* a video item's, while it is held */
    struct rayd_error err;
    double render_ms;
    uint64_t rays; /* what the tile's render cast: the job counts them */
    struct node_item *next;
};

static pthread_t node_thread;
static bool node_running;
static pthread_mutex_t node_mu = PTHREAD_MUTEX_INITIALIZER; /* the items' phases */
static pthread_cond_t node_cond = PTHREAD_COND_INITIALIZER;
static struct node_item *node_items; /* the puller's own list */
static long node_count;

/* ---- the work layer's callbacks (its threads) ---------------------------------- */

static void node_mark(struct node_item *it, enum node_phase ph) {
    pthread_mutex_lock(&node_mu);
    it->phase = ph;
    pthread_cond_signal(&node_cond);
    pthread_mutex_unlock(&node_mu);
}

static void node_rendered(struct work_waiter *w, struct work_result *res) {
    struct node_item *it = (struct node_item *)((char *)w - offsetof(struct node_item, ww));
    it->render_ms = res->times.render_ms;
    it->rays = res->rays;
    if (res->status == RAYD_OK && res->png && (res->exr || !it->what.keep_exr)) {
        it->png = res->png;
        it->exr = blob_ref(res->exr); /* lent for this call */
        node_mark(it, NP_DONE);
    } else {
        blob_unref(res->png);
        it->err = res->err;
        it->err.code = res->status;
        it->own_limit = res->status == RAYD_E_LIMIT; /* --max-work, --max-render-seconds */
        bool lost =
            res->gone || res->draining || res->status == RAYD_E_CANCELED || res->status == RAYD_OK;
        node_mark(it, lost ? NP_DROP : NP_FAILED);
    }
}

static void node_nothing(struct work_waiter *w) { (void)w; }
static void node_nothing_c(struct compile_waiter *w) { (void)w; }

/* The compiled scene: the tile's render queued (or its answer now). */
static void node_compiled(struct node_item *it, struct compile_result *res) {
    if (res->draining || res->memory_full) {
        it->retry_at = clock_now() + NODE_RETRY_S;
        node_mark(it, res->draining ? NP_DROP : NP_RETRY);
        return;
    }
    if (res->status != RAYD_OK) {
        it->err = res->err;
        it->err.code = res->status;
        node_mark(it, NP_FAILED);
        return;
    }
    it->ww = (struct work_waiter){.done = node_rendered, .suspend = node_nothing, .fd = -1};
    struct blob *png = NULL;
    enum work_submit s = sched_render(res->scene, &it->what, &it->ww, &png, &it->rays);
    scenes_release(res->scene);
    if (s == WORK_OK) return;                    /* node_rendered will say */
    if (s == WORK_CACHED && it->what.keep_exr) { /* never: an EXR's render is not cached */
        blob_unref(png);
        memset(&it->err, 0, sizeof it->err);
        it->err.code = RAYD_E_INTERNAL;
        snprintf(it->err.message, sizeof it->err.message, "a tile's EXR was not made");
        node_mark(it, NP_FAILED);
    } else if (s == WORK_CACHED) {
        it->png = png;
        node_mark(it, NP_DONE);
    } else if (s == WORK_TOO_BIG) {
        memset(&it->err, 0, sizeof it->err);
        it->err.code = RAYD_E_LIMIT;
        it->own_limit = true;
        snprintf(it->err.message, sizeof it->err.message,
                 "a tile of this job alone is over this node's --max-memory");
        node_mark(it, NP_FAILED);
    } else {
        it->retry_at = clock_now() + NODE_RETRY_S;
        node_mark(it, s == WORK_DRAINING ? NP_DROP : NP_RETRY);
    }
}

static void node_compile_done(struct compile_waiter *w, struct compile_result *res) {
    node_compiled((struct node_item *)((char *)w - offsetof(struct node_item, cw)), res);
}

/* Starts the item's render: it is NP_BUSY until a callback marks it. */
static void node_render(struct node_item *it) {
    struct compile_result res;
    it->phase = NP_BUSY;
    it->cw = (struct compile_waiter){.done = node_compile_done, .suspend = node_nothing_c};
    enum work_submit s = it->animated
                             ? compile_scene_frame(it->body, it->len, it->frame, &it->cw, &res)
                             : compile_scene(it->body, it->len, &it->cw, &res);
    if (s == WORK_OK) return;
    if (s == WORK_CACHED) {
        node_compiled(it, &res);
        return;
    }
    it->retry_at = clock_now() + NODE_RETRY_S;
    node_mark(it, s == WORK_DRAINING ? NP_DROP : NP_RETRY);
}

/* ---- Redis, on this thread ----------------------------------------------------- */

static void node_free(struct node_item *it) {
    blob_unref(it->png);
    blob_unref(it->exr);
    cluster_video_drop(it->video);
    free(it->body);
    free(it);
}

/* A pass's tile item (the record's plan, and the pass it is at): the
 * samples it adds, as exact sums.  1: render it; 0: its pass is over (a
 * late duplicate) or the plan is not one. */
static int node_pass(struct node_item *it, const redisReply *plan, long long at) {
    int samples[PASSES_MAX],
        n = plan->type == REDIS_REPLY_STRING ? cluster_jobs_plan(plan->str, samples) : -1;
    if (n < 1 || it->pass > n || it->pass != at) return 0;
    int k0, k1;
    cluster_passes_range(samples, it->pass, it->whole, &k0, &k1);
    it->what.format = WORK_SUMS;
    it->what.k0 = k0;
    it->what.k1 = k1;
    it->what.centre = k1 == 1;
    return 1;
}

/* The job's record for a tile item: its geometry, client and scene.
 * 1: render it; 0: the job ended or is gone (ack and drop); -1: Redis failed. */
static int node_job(struct redis *c, struct node_item *it) {
    char key[120];
    cluster_key(key, sizeof key, it->job, "job");
    const char *argv[] = {"HMGET", key,   "state", "animated", "tiles",  "cols",  "tile_size",
                          "x",     "y",   "w",     "h",        "client", "scene", "denoise",
                          "aov",   "exr", "plan",  "pass",     NULL};
    redisReply *rep = redis_strs(c, argv);
    if (redis_failed(c, rep) || rep->type != REDIS_REPLY_ARRAY || rep->elements != 16) {
        if (rep) freeReplyObject(rep);
        return -1;
    }
    redisReply **e = rep->element;
    const char *st = e[0]->type == REDIS_REPLY_STRING ? e[0]->str : "";
    /* animated tiles cols tile_size x y w h */
    long v[8];
    for (int i = 0; i < 8; i++) v[i] = (long)redis_ll(e[i + 1], -1);
    long cols = v[2], size = v[3];
    int rc = 0;
    if ((!strcmp(st, "queued") || !strcmp(st, "running")) && e[10]->type == REDIS_REPLY_STRING &&
        v[1] > 0 && cols > 0 && size > 0 && v[6] > 0 && v[7] > 0 && it->tile < v[1] &&
        (it->body = malloc(e[10]->len + 1))) {
        memcpy(it->body, e[10]->str, e[10]->len);
        it->body[e[10]->len] = 0;
        it->len = e[10]->len;
        it->animated = v[0] == 1;
        it->ntiles = v[1];
        long tx = (it->tile % cols) * size, ty = (it->tile / cols) * size;
        long w = v[6] - tx < size ? v[6] - tx : size, h = v[7] - ty < size ? v[7] - ty : size;
        it->what = (struct work_target){
            .reg = {(int)(v[4] + tx), (int)(v[5] + ty), (int)w, (int)h},
            .format = WORK_PNG,
            .aov = (unsigned)redis_ll(e[12], 0),
            .denoise = redis_ll(e[11], 0) == 1, /* a record made before: raw */
            .keep_exr = redis_ll(e[13], 0) == 1,
            .client = strtoull(e[9]->type == REDIS_REPLY_STRING ? e[9]->str : "0", NULL, 10)};
        rc = it->pass > 0 ? node_pass(it, e[14], redis_ll(e[15], 0)) : 1;
    } else if (!strcmp(st, "queued") || !strcmp(st, "running")) {
        log_warn("cluster: item %s of job %s: the job's record is malformed; dropped", it->sid,
                 it->job);
    }
    freeReplyObject(rep);
    return rc;
}

/* A new item from the stream entry e ([id, [field, value, ...]]), or NULL. */
static struct node_item *node_item_new(const redisReply *e, int level) {
    if (!e || e->type != REDIS_REPLY_ARRAY || e->elements < 2) return NULL;
    struct node_item *it = calloc(1, sizeof *it);
    if (!it) return NULL;
    const redisReply *job = redis_field(e->element[1], "job");
    snprintf(it->sid, sizeof it->sid, "%s", e->element[0]->str ? e->element[0]->str : "");
    snprintf(it->job, sizeof it->job, "%s", job && job->type == REDIS_REPLY_STRING ? job->str : "");
    it->frame = (long)redis_ll(redis_field(e->element[1], "frame"), -1);
    it->tile = (long)redis_ll(redis_field(e->element[1], "tile"), -2);
    it->pass = (long)redis_ll(redis_field(e->element[1], "pass"), 0);
    it->whole = redis_ll(redis_field(e->element[1], "whole"), 0) == 1;
    it->level = level;
    return it;
}

/* The items this node left pending itself (an assembly or a video with no
 * room in its budget now, or Redis failing): when it takes one back after
 * --redis-claim-ms, that is no take-over from a stalled node. */
#define NODE_LEFT 32
static struct {
    int level;
    char sid[48];
} node_left[NODE_LEFT];
static int node_left_next;

static void node_leave(const struct node_item *it) {
    node_left[node_left_next].level = it->level;
    snprintf(node_left[node_left_next].sid, sizeof node_left[0].sid, "%s", it->sid);
    node_left_next = (node_left_next + 1) % NODE_LEFT;
}

/* Whether sid of stream `level` was left here (forgotten once asked). */
static bool node_left_mine(const char *sid, int level) {
    for (int i = 0; i < NODE_LEFT; i++)
        if (node_left[i].level == level && !strcmp(node_left[i].sid, sid)) {
            node_left[i].sid[0] = 0;
            return true;
        }
    return false;
}

/* The tiles that failed on this node's own limits and were left pending
 * for another node: their idle time grows until some node's XAUTOCLAIM
 * takes one.  This node may be the one (every node reclaims alike); it
 * then leaves it again, at least NODE_SHUN_LEAVES times and for as long as
 * a live node of its version has not tried the tile (it is busy: it takes
 * the tile once it has room), before it tries the tile itself: the others
 * tried and failed, or are gone, and its own budget may have room now. */
#define NODE_SHUN 64
#define NODE_SHUN_LEAVES 2
static struct {
    int level, leaves;
    char sid[48];
} node_shun[NODE_SHUN];
static int node_shun_next;
/* After leaving an item again this node reclaims nothing for two claim
 * periods (clock_now() time).  Both nodes reclaim at each tick, and the
 * item's idle time restarts at this node's reclaim, so it came due again
 * at this node's own tick, a hair before the other node's: this node took
 * it back every time, and the busy node, free at last, never got it (a
 * job queued for 30 s and more).  The hold leaves it the others' for a
 * claim period, and it still comes back here if no other node takes it. */
static double node_shun_hold;

static void node_shun_add(const struct node_item *it) {
    node_shun[node_shun_next].level = it->level;
    node_shun[node_shun_next].leaves = 0;
    snprintf(node_shun[node_shun_next].sid, sizeof node_shun[0].sid, "%s", it->sid);
    node_shun_next = (node_shun_next + 1) % NODE_SHUN;
}

/* Item it, taken back: 1 when it is left again (counted), 0 when this node
 * now tries it (forgotten), -1 when it never failed here. */
static int node_shun_again(struct redis *c, const struct node_item *it) {
    for (int i = 0; i < NODE_SHUN; i++) {
        if (node_shun[i].level != it->level || strcmp(node_shun[i].sid, it->sid)) continue;
        if (node_shun[i].leaves++ < NODE_SHUN_LEAVES) return 1;
        /* Redis failing (-1): left, taken back later */
        if (cluster_jobs_untried(c, it->job, it->frame, it->tile) != 0) return 1;
        node_shun[i].sid[0] = 0;
        return 0;
    }
    return -1;
}

/* Whether the item with id sid in stream `level` is held here (ids are
 * per stream: two streams may use the same one). */
static bool node_holds(const char *sid, int level) {
    for (struct node_item *it = node_items; it; it = it->next)
        if (it->level == level && !strcmp(it->sid, sid)) return true;
    return false;
}

static void node_video_done(void *ctx) { node_mark(ctx, NP_DONE); }

/* A video item: held while its thread encodes, else acked or left. */
static void node_video(struct redis *c, struct node_item *it) {
    bool ack = false;
    it->phase = NP_BUSY; /* before the thread can mark it */
    it->video = cluster_video_start(c, it->job, &ack, node_video_done, it);
    if (!it->video) {
        if (ack)
            cluster_items_ack(c, it->level, it->sid);
        else
            node_leave(it);
        node_free(it);
        return;
    }
    it->next = node_items;
    node_items = it;
    node_count++;
}

/* Starts what an item asks: an assembly here and now, a tile's render, a
 * video on its thread. */
static void node_take(struct redis *c, struct node_item *it) {
    if (!it->job[0] || it->frame < 0 || it->tile < -2) { /* not ours to read: dropped */
        log_warn("cluster: item %s is malformed; dropped", it->sid);
        cluster_items_ack(c, it->level, it->sid);
        node_free(it);
        return;
    }
    if (it->tile == -1) {
        if (it->pass > 0 ? cluster_passes_assemble(c, it->job, it->pass)
                         : cluster_assemble(c, it->job, it->frame)) {
            cluster_items_ack(c, it->level, it->sid);
            atomic_fetch_add(&cluster_done_total, 1);
        } else {
            node_leave(it);
        }
        node_free(it);
        return;
    }
    if (it->tile == -2) {
        node_video(c, it);
        return;
    }
    int rc = node_job(c, it);
    if (rc <= 0) {
        if (rc == 0) /* its job ended (cancelled, failed) or is gone */
            cluster_items_ack(c, it->level, it->sid);
        node_free(it);
        return;
    }
    it->next = node_items;
    node_items = it;
    node_count++;
    node_render(it);
}

/* One entry of stream `level`, taken (cluster_items_take_fn). */
static long node_take_entry(struct redis *c, const redisReply *e, int level, bool reclaimed) {
    if (node_holds(e->element[0]->str, level)) return 0;
    struct node_item *it = node_item_new(e, level);
    if (!it) return 0;
    int shun = reclaimed ? node_shun_again(c, it) : -1;
    if (shun == 1) {
        log_info("cluster: item %s failed here before; left again for another node", it->sid);
        node_shun_hold = clock_now() + 2e-3 * (double)cluster_claim_ms();
        node_free(it);
        return 0;
    }
    if (shun == 0 || (reclaimed && node_left_mine(it->sid, level))) { /* not a take-over */
        log_info("cluster: took back item %s (job %s frame %ld tile %ld), which it had left "
                 "pending",
                 it->sid, it->job, it->frame, it->tile);
    } else if (reclaimed) {
        atomic_fetch_add(&cluster_reclaimed_total, 1);
        log_info("cluster: took over item %s (job %s frame %ld tile %ld) from a node that "
                 "stopped refreshing it",
                 it->sid, it->job, it->frame, it->tile);
    }
    node_take(c, it);
    return 1;
}

/* The items held here keep their claim (their idle time restarts). */
static void node_refresh(struct redis *c) {
    if (!node_count) return;
    const char **sids = calloc((size_t)node_count, sizeof *sids);
    if (!sids) return;
    for (int l = 0; l < CLUSTER_LEVELS; l++) {
        int n = 0;
        for (struct node_item *it = node_items; it; it = it->next)
            if (it->level == l && n < node_count) sids[n++] = it->sid;
        cluster_items_refresh(c, l, sids, n);
    }
    free(sids);
}

/* ---- what finished --------------------------------------------------------------- */

/* The error JSON of a failed tile, after `tries` attempts (0: its first,
 * which is not retried). */
static void node_error_json(const struct node_item *it, long tries, char *buf, size_t n) {
    char msg[300] = "", path[300] = "";
    size_t j = 0;
    for (const char *s = it->err.message; *s && j + 2 < sizeof msg; s++) {
        if (*s == '"' || *s == '\\') msg[j++] = '\\';
        msg[j++] = (char)((unsigned char)*s < 0x20 ? ' ' : *s);
    }
    msg[j] = 0;
    j = 0;
    for (const char *s = it->err.path; *s && j + 2 < sizeof path; s++) {
        if (*s == '"' || *s == '\\') path[j++] = '\\';
        path[j++] = (char)((unsigned char)*s < 0x20 ? ' ' : *s);
    }
    path[j] = 0;
    char after[48] = "";
    if (tries > 0) snprintf(after, sizeof after, " failed after %ld attempts", tries);
    snprintf(buf, n, "{\"code\":\"%s\",\"message\":\"frame %ld, tile %ld%s: %s\"%s%s%s}",
             rayd_status_name(it->err.code), it->frame, it->tile, after, msg,
             path[0] ? ",\"path\":\"" : "", path, path[0] ? "\"" : "");
}

/* The test knob of the kill -9 matrix: with --test-gate and
 * RAYD_TEST_CLUSTER_STALL=1 the puller stops for good after it stored its
 * first tile and before it acknowledged the item, so a test can kill the
 * node there (its tile kept, its item still pending). */
static void node_test_stall(void) {
    const char *v = getenv("RAYD_TEST_CLUSTER_STALL");
    if (config.test_gate_tiles < -1 || !v || strcmp(v, "1")) return;
    log_warn("RAYD_TEST_CLUSTER_STALL: the puller stops after a tile's write, before its ack");
    for (;;) pause();
}

/* A tile that failed here.  On this node's own limits (own_limit: its
 * render stopped by --max-work or --max-render-seconds, or over its
 * --max-memory) another node's may let it through: the item is left
 * pending, unacked and no longer refreshed, for some node's XAUTOCLAIM,
 * until the job's record counts CLUSTER_TRIES attempts.  Then, or for any
 * other failure (the scene's parse refused by the loader's fixed limits is
 * the same on every node), the job fails with the tile's error.  A pass's
 * tile ends its pass instead (cluster_passes.c). */
static void node_failed(struct redis *c, struct node_item *it) {
    char err[800];
    if (it->pass > 0) {
        node_error_json(it, 0, err, sizeof err);
        log_warn("cluster: job %s: a tile failed: %s", it->job, err);
        if (cluster_passes_failed(c, it->job, it->pass, it->err.code == RAYD_E_LIMIT, err))
            cluster_items_ack(c, it->level, it->sid);
        return;
    }
    long tries = 0;
    if (it->own_limit) {
        tries = cluster_jobs_tried(c, it->job, it->frame, it->tile);
        if (tries < 0) return; /* Redis failed: taken over later */
        if (tries == 0) {      /* the job ended */
            cluster_items_ack(c, it->level, it->sid);
            return;
        }
        if (tries < CLUSTER_TRIES) {
            log_warn("cluster: job %s frame %ld tile %ld failed here (attempt %ld of %d), left "
                     "for another node: %s",
                     it->job, it->frame, it->tile, tries, CLUSTER_TRIES, it->err.message);
            node_shun_add(it);
            return;
        }
    }
    node_error_json(it, tries, err, sizeof err);
    log_warn("cluster: job %s: a tile failed: %s", it->job, err);
    if (cluster_jobs_end(c, it->job, "failed", err)) cluster_items_ack(c, it->level, it->sid);
}

/* Stores, fails or forgets each item that finished; true if any did. */
static bool node_finish(struct redis *c) {
    bool any = false;
    double now = clock_now();
    for (struct node_item **p = &node_items; *p;) {
        struct node_item *it = *p;
        pthread_mutex_lock(&node_mu);
        enum node_phase ph = it->phase;
        pthread_mutex_unlock(&node_mu);
        if (ph == NP_RETRY && now >= it->retry_at && !atomic_load(&cluster_draining)) {
            node_render(it);
            p = &it->next;
            continue;
        }
        if (ph != NP_DONE && ph != NP_FAILED && ph != NP_DROP) {
            p = &it->next;
            continue;
        }
        struct cluster_tile done = {it->job, it->frame, it->tile,      it->ntiles, it->what.reg,
                                    it->png, it->exr,   it->render_ms, it->rays};
        if (ph == NP_DONE && it->video) {
            if (cluster_video_store(c, it->video)) {
                cluster_items_ack(c, it->level, it->sid);
                atomic_fetch_add(&cluster_done_total, 1);
            }
        } else if (ph == NP_DONE && (it->pass > 0 ? cluster_passes_tile_store(c, &done, it->pass)
                                                  : cluster_tile_store(c, &done))) {
            node_test_stall();
            cluster_items_ack(c, it->level, it->sid);
            atomic_fetch_add(&cluster_done_total, 1);
        } else if (ph == NP_FAILED) {
            node_failed(c, it);
        }
        *p = it->next;
        node_count--;
        node_free(it);
        any = true;
    }
    atomic_store(&cluster_node_in_flight, node_count);
    return any;
}

/* ---- the figures ------------------------------------------------------------------ */

/* This node's heartbeat written (ARGV: its name, its JSON around the
 * time, the age in ms past which a node is gone) and the live nodes
 * counted.  "seen" is Redis's clock (TIME), not the nodes': a node whose
 * clock is off is neither counted gone nor makes others look gone. */
static const char node_lua_heartbeat[] =
    "local now = tonumber(redis.call('TIME')[1])\n"
    "redis.call('HSET', 'rayd:nodes', ARGV[1], ARGV[2] .. now .. ARGV[3])\n"
    "local live, hs = 0, redis.call('HGETALL', 'rayd:nodes')\n"
    "for j = 2, #hs, 2 do\n"
    "  local seen = tonumber(string.match(hs[j], '\"seen\":(%d+)')) or 0\n"
    "  if (now - seen) * 1000 <= tonumber(ARGV[4]) then live = live + 1 end\n"
    "end\n"
    "return live\n";

/* The live nodes of rayd:nodes (and this node's heartbeat written); the
 * gone ones are reaped (cluster_items.c). */
static long node_heartbeat(struct redis *c) {
    char head[200], tail[120], gone[24];
    snprintf(head, sizeof head, "{\"version\":\"%s\",\"seen\":", cluster_version());
    snprintf(tail, sizeof tail, ",\"workers\":%ld,\"in_flight\":%ld}", config.threads, node_count);
    snprintf(gone, sizeof gone, "%ld", cluster_gone_ms());
    const char *argv[] = {"EVAL", node_lua_heartbeat, "0", cluster_node_id, head, tail, gone, NULL};
    redisReply *rep = redis_strs(c, argv);
    long live = rep && !redis_failed(c, rep) ? (long)redis_ll(rep, 0) : 0;
    if (rep) freeReplyObject(rep);
    return live;
}

/* Refreshes the view /healthz and /metrics read. */
static void node_figures(struct redis *c) {
    struct cluster_status_view v;
    memset(&v, 0, sizeof v);
    v.checked = true;
    cluster_clock_sync(c);
    snprintf(v.address, sizeof v.address, "%s", cluster_url.display);
    v.nodes = node_heartbeat(c);
    v.redis_up = cluster_items_count(c, &v.queued, &v.in_flight) && redis_is_up(c);
    v.jobs_unfinished = v.redis_up ? cluster_jobs_unfinished(c) : 0;
    if (v.redis_up) cluster_items_others(c, &v);
    if (!v.redis_up)
        snprintf(v.reason, sizeof v.reason, "%s", redis_why(c)[0] ? redis_why(c) : "no answer");
    static bool figured; /* this thread's alone: a first look has no "was" */
    pthread_mutex_lock(&cluster_mu);
    bool was_up = cluster_view_now.redis_up;
    int had = cluster_view_now.nother;
    cluster_view_now = v;
    pthread_mutex_unlock(&cluster_mu);
    /* down is a warning, from the first look on: a mistyped --redis was
     * said nowhere but in /healthz until the first job's 503 */
    if (!v.redis_up && (was_up || !figured))
        log_warn("cluster: Redis at %s is down: %s; POST /v1/jobs answers 503 "
                 "cluster_unavailable until it is back",
                 v.address, v.reason);
    else if (v.redis_up && !was_up && figured)
        log_info("cluster: Redis at %s is up", v.address);
    figured = true;
    for (int i = had; i < v.nother; i++)
        log_warn("cluster: this node (rayd %s) takes no item of another version: %s",
                 cluster_version(), v.other_versions[i]);
}

/* ---- the thread ------------------------------------------------------------------- */

static void node_wait(double seconds) {
    struct timespec ts = clock_after(seconds);
    pthread_mutex_lock(&node_mu);
    pthread_cond_timedwait(&node_cond, &node_mu, &ts);
    pthread_mutex_unlock(&node_mu);
}

static void *node_main(void *arg) {
    (void)arg;
    struct redis *c = redis_new(&cluster_url, 2.0);
    double every = (double)cluster_claim_ms() / 3e3, last = -1e9;
    if (every > 1.0) every = 1.0; /* the figures at least once a second */
    bool group = false;
    /* a reclaim is due each tick, and runs once the node has room: a busy
     * node, whose freed slot the next pull filled at once, took a dead
     * node's items only when the farm's queue ran dry */
    bool reclaim_due = false;
    while (c && !atomic_load(&cluster_stopping)) {
        if (!group && redis_is_up(c)) cluster_items_groups(c), group = true;
        if (!redis_is_up(c)) group = false;
        bool any = node_finish(c);
        double now = clock_now();
        long room = config.threads - node_count;
        if (now - last >= every) {
            last = now;
            node_refresh(c);
            node_figures(c);
            reclaim_due = true;
            if (redis_is_up(c)) {
                cluster_items_reap(c);
                cluster_jobs_sweep(c);
            }
        }
        if (reclaim_due && room > 0 && !atomic_load(&cluster_draining) && now >= node_shun_hold) {
            cluster_items_reclaim(c, room, node_take_entry);
            reclaim_due = false;
            room = config.threads - node_count;
        }
        if (room > 0 && !atomic_load(&cluster_draining) && redis_is_up(c)) {
            bool busy = node_count > 0;
            if (!cluster_items_pull(c, node_take_entry, busy ? 0 : NODE_BLOCK_MS) && busy && !any)
                node_wait(NODE_BUSY_WAIT_S);
        } else if (!redis_is_up(c))
            node_figures(c), node_wait(0.2);
        else if (!any)
            node_wait(0.05);
    }
    /* the renders still running answer into their items: wait for them */
    for (int i = 0; i < 200 && node_count > 0; i++) {
        node_finish(c);
        if (node_count) node_wait(0.02);
    }
    if (c && redis_is_up(c)) { /* a clean stop: no longer counted */
        const char *del[] = {"HDEL", "rayd:nodes", cluster_node_id, NULL};
        redisReply *d = redis_strs(c, del);
        if (d) freeReplyObject(d);
        cluster_items_leave(c);
    }
    redis_free(c);
    return NULL;
}

bool cluster_node_start(void) {
    node_running = pthread_create(&node_thread, NULL, node_main, NULL) == 0;
    return node_running;
}

void cluster_node_stop(void) {
    if (!node_running) return;
    atomic_store(&cluster_stopping, true);
    pthread_mutex_lock(&node_mu);
    pthread_cond_broadcast(&node_cond);
    pthread_mutex_unlock(&node_mu);
    pthread_join(node_thread, NULL);
    node_running = false;
}
