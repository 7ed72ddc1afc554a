/* cluster_private.h -- what the cluster files share: the Redis connection
 * (redis.c), the keys, the scripts and the counters.
 *
 * Layer: cluster, private.  Included only by the files of server/cluster/.
 * May include: cluster.h, hiredis.
 *
 * Each thread owns its connection: the request thread one, the puller one;
 * a connection is never shared, so redis.c has no lock.  The few values
 * the threads share (the status view, the counters) are under cluster_mu
 * or atomic.
 */
#ifndef RAYD_SERVER_CLUSTER_PRIVATE_H
#define RAYD_SERVER_CLUSTER_PRIVATE_H

#include "cluster/cluster.h"

#include <hiredis/hiredis.h>
#include <pthread.h>

/* ---- redis.c: one connection, one command at a time, with a timeout ------- */

struct redis_url {
    char host[256];
    int port;
    char unix_path[256]; /* unix:/path: host is "" */
    int db;
    char password[256];
    char display[300]; /* the address as logs and errors name it, no password */
};
/* url into *u (password from RAYD_REDIS_PASSWORD when the URL has none);
 * false with why naming the wrong part. */
bool redis_url_parse(const char *url, struct redis_url *u, char *why, size_t n);
struct redis;
struct redis *redis_new(const struct redis_url *u, double timeout_s);
void redis_free(struct redis *c);
/* Runs one command (connecting first when needed, with back-off after a
 * failure).  NULL: no connection (redis_why says why); an error reply is
 * returned as such (freeReplyObject it). */
redisReply *redis_argv(struct redis *c, int argc, const char **argv, const size_t *lens);
redisReply *redis_cmd(struct redis *c, const char *fmt, ...);
/* redis_argv of strings (NULL-ended). */
redisReply *redis_strs(struct redis *c, const char **argv);
bool redis_is_up(const struct redis *c);
const char *redis_why(const struct redis *c); /* the last failure, "" none */
/* A reply of an error kind also counts as a failure: its text becomes
 * redis_why and the connection is dropped when it may be broken. */
bool redis_failed(struct redis *c, const redisReply *rep);
/* A bulk string's value in a flat HGETALL-like array, or NULL. */
const redisReply *redis_field(const redisReply *arr, const char *name);
long long redis_ll(const redisReply *s, long long def); /* a string or integer reply */

/* ---- cluster_state.c: the names, the clock, the counters, the view ---------- */

extern struct redis_url cluster_url;
extern char cluster_node_id[200];
extern char cluster_stream[160]; /* rayd:items:VERSION */
extern char cluster_ver[64];     /* the version items are made and taken for */
extern atomic_bool cluster_stopping, cluster_draining;
extern atomic_long cluster_done_total, cluster_reclaimed_total, cluster_node_in_flight;
extern atomic_long cluster_deferred_total; /* assemblies put off for want of memory */
extern pthread_mutex_t cluster_mu;         /* the view */
extern struct cluster_status_view cluster_view_now;
long cluster_claim_ms(void);
/* The age past which a node's heartbeat says it is gone: 3 x
 * --redis-claim-ms, and a second for the heartbeat's clock (whole s). */
long cluster_gone_ms(void);
double cluster_now_ms(void); /* Redis's wall clock as this node sees it, ms since the epoch */
/* Measures the offset of Redis's clock (TIME) to this node's, at most once
 * a second (each thread that talks to Redis calls it before its work). */
void cluster_clock_sync(struct redis *c);
extern double cluster_skew_ms; /* tests: how far that clock is off */
/* The key rayd:{ID}:what into buf. */
void cluster_key(char *buf, size_t n, const char *id, const char *what);

/* ---- cluster_jobs.c: the records (the request thread) ------------------------- */

/* Seconds a job's tombstone (rayd:{ID}:gone) outlives its keys: its routes
 * answer 410 job_expired that long, then 404.  A string: rayd_end's Lua. */
#define CLUSTER_TOMB_S "86400"

/* The Lua function rayd_end(id, state, now_ms, ttl_s, error_json): a job
 * still queued or running ends (its event written, its tiles deleted, its
 * keys set to expire); 1 when it ended now, 0 when it had ended, -2 no
 * such job.  Scripts that may end a job run through cluster_jobs_eval:
 * EVAL of body after rayd_end's definition, with no keys and the n (at
 * most 12) values args (lens[i] bytes each; lens NULL: strings); the
 * reply, NULL when there is no memory or no connection. */
redisReply *cluster_jobs_eval(struct redis *c, const char *body, int n, const char **args,
                              const size_t *lens);

void cluster_jobs_run(struct redis *c, struct cluster_op *op);
/* The cluster's unfinished jobs (what --max-jobs counts), 0 when Redis
 * does not answer. */
long cluster_jobs_unfinished(struct redis *c);
/* A progressive job's plan as its record keeps it ("1,2,4,...": the
 * samples after each pass) into out: how many passes, -1 when it is not one. */
int cluster_jobs_plan(const char *s, int out[PASSES_MAX]);
/* Sets the job's end state (with error JSON, or NULL) if it is still
 * queued or running, its keys to expire after --job-ttl; the puller's too. */
bool cluster_jobs_end(struct redis *c, const char *id, const char *state, const char *error);
/* A tile (tile of frame) failed on a node's own limits once more: the
 * attempts so far (the job's record counts them, and names the nodes that
 * made them), 0 when the job has ended or is gone, -1 when Redis failed. */
long cluster_jobs_tried(struct redis *c, const char *id, long frame, long tile);
/* The live nodes of this version (their heartbeats in rayd:nodes) that
 * have not tried that tile: a node that failed it on its own limits leaves
 * it while there is one.  -1 when Redis failed. */
long cluster_jobs_untried(struct redis *c, const char *id, long frame, long tile);
/* Attempts at a tile that fails on a node's own limits (--max-work,
 * --max-memory, --max-render-seconds) before its job fails: each but the
 * last leaves it to another node, whose limits may let it through. */
#define CLUSTER_TRIES 3
/* Takes the jobs whose keys expired out of their clients' lists (the due
 * entries of rayd:ended, up to 5,120 a call); how many it read, -1 when
 * Redis failed. */
long cluster_jobs_sweep(struct redis *c);

/* ---- cluster_assemble.c: tiles in, frames out (the puller) ------------------- */

/* A tile rendered: tile `tile` of frame k of job id (of ntiles), where it
 * is, its PNG (and EXR, for a job that keeps one), what its render took
 * and cast. */
struct cluster_tile {
    const char *id;
    long k, tile, ntiles;
    struct rayd_region reg;
    const struct blob *png, *exr;
    double render_ms;
    uint64_t rays;
};
/* A job's geometry, as an assembly reads it: the frame's region and its
 * tile grid. */
struct cluster_geom {
    char state[16]; /* "" when the job is gone (or not one of ours) */
    int x, y, w, h;
    long tiles, cols, size;
    bool exr;     /* the job keeps an EXR too */
    unsigned aov; /* its AOVs */
};
/* Job id's geometry into *g; false: Redis failed. */
bool cluster_geom_read(struct redis *c, const char *id, struct cluster_geom *g);
/* Tile t of g as a region relative to the frame. */
struct rayd_region cluster_tile_reg(const struct cluster_geom *g, long t);
/* The test knob of the hostile cases (--test-gate and
 * RAYD_TEST_CLUSTER_TILE=corrupt or missing): the first tile (or pass's
 * sums) this node stores is kept corrupt or not at all; NULL otherwise. */
const char *cluster_test_tile(void);
/* The tile kept, and its frame's assembly queued by whoever completes it.
 * false: Redis failed. */
bool cluster_tile_store(struct redis *c, const struct cluster_tile *t);
/* The frame assembled from its tiles and stored (or, a tile missing or
 * corrupt, that tile queued again).  false: Redis failed, or the memory
 * budget has no room for it now (cluster_deferred_total counts those): the
 * item stays pending, to be taken over. */
bool cluster_assemble(struct redis *c, const char *id, long k);

/* The assembly of frame k of job id needs need bytes: true when no node's
 * budget can ever hold it and the job failed (after some tries). */
bool cluster_assemble_never(struct redis *c, const char *id, long k, size_t need);
/* need reserved in the memory budget; false (counted, said) when there is
 * no room now: the item is left for later. */
bool cluster_assemble_reserve(const char *id, long k, size_t need);

/* ---- cluster_passes.c: a progressive job's passes (the puller) --------------- */

/* The samples k0..k1-1 pass k (from 1) of plan samples renders: those it
 * adds, or (whole) all of them. */
void cluster_passes_range(const int *samples, long k, bool whole, int *k0, int *k1);
/* A tile's sums of pass `pass` kept (t->png: the sums' bytes), the pass's
 * assembly queued by whoever completes it.  false: Redis failed. */
bool cluster_passes_tile_store(struct redis *c, const struct cluster_tile *t, long pass);
/* A tile of pass `pass` failed (limit: over --max-work): the job ends with
 * its latest pass, or fails with error (JSON); false: Redis failed. */
bool cluster_passes_failed(struct redis *c, const char *id, long pass, bool limit,
                           const char *error);
/* Pass k of job id assembled: its PNG, its numbers, the next pass or the
 * job's end.  false: Redis failed or no room now (the item stays pending). */
bool cluster_passes_assemble(struct redis *c, const char *id, long k);

/* ---- cluster_video.c: a frame range's video (the puller) ---------------------- */

struct cluster_video; /* one video being made, on a thread of its own */
/* The video of job id started: its frames read and charged, ffmpeg run on
 * a thread that calls done(ctx) when it ends.  NULL when there is nothing
 * to run: *ack says whether the item is done (the video made or failed
 * already, a failure recorded now, the job gone) or waits (no memory now,
 * Redis failed). */
struct cluster_video *cluster_video_start(struct redis *c, const char *id, bool *ack,
                                          void (*done)(void *ctx), void *ctx);
/* After done(): the MP4 (or why there is none) recorded in Redis; false
 * when Redis failed (the item waits, to be made again). */
bool cluster_video_store(struct redis *c, struct cluster_video *v);
/* The item lets v go: freed now, or by its thread when the encode ends. */
void cluster_video_drop(struct cluster_video *v);

/* ---- cluster_items.c: the streams of work items, one per priority ----------- */

#define CLUSTER_LEVELS 3        /* enum jobs_priority: low, normal, high */
void cluster_items_names(void); /* from cluster_stream, at start */
/* The stream a job of that priority uses: cluster_stream for normal, it
 * with :high or :low for the others. */
const char *cluster_items_stream(int priority);
void cluster_items_groups(struct redis *c); /* the group `render` of each stream */
/* Takes stream entry e ([id, [field, value, ...]]) of stream `level`:
 * 1 when the node now holds it (or handled it), 0 when it was skipped. */
typedef long (*cluster_items_take_fn)(struct redis *c, const redisReply *e, int level,
                                      bool reclaimed);
/* The next new item, from the highest stream that has one (waits up to
 * block_ms in Redis when none has; 0: not at all); whether it took one. */
bool cluster_items_pull(struct redis *c, cluster_items_take_fn take, long block_ms);
/* Items idle past claim-ms (a dead or stalled node's), highest first, up to room. */
void cluster_items_reclaim(struct redis *c, long room, cluster_items_take_fn take);
/* The items sids[0..n) of stream `level` held here keep their claim. */
void cluster_items_refresh(struct redis *c, int level, const char **sids, int n);
/* XACK and XDEL of an item, both or neither (an item acked but left in the
 * stream would count as queued for ever). */
void cluster_items_ack(struct redis *c, int level, const char *sid);
/* The cluster-wide figures, summed over the streams; false: Redis failed. */
bool cluster_items_count(struct redis *c, long *queued, long *in_flight);
/* This node's consumer removed from each stream where it holds nothing
 * (a clean stop; what it still holds is taken over, then reaped). */
void cluster_items_leave(struct redis *c);
/* Consumers and heartbeats of gone nodes removed (how many). */
long cluster_items_reap(struct redis *c);
/* Other versions' streams that still hold items, into v->other_versions. */
void cluster_items_others(struct redis *c, struct cluster_status_view *v);

/* ---- cluster_node.c: the puller ------------------------------------------------ */

bool cluster_node_start(void);
void cluster_node_stop(void);

#endif
