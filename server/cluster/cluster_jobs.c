/* cluster_jobs.c -- the job records in Redis, read and written for the job
 * routes (on the request thread, cluster.c).
 *
 * A job is the hash rayd:{ID}:job, a member of its client's ZSET
 * rayd:jobs:CLIENT (scored by its creation time in ms: the client's list,
 * newest first, so a list reads its own client's jobs only), its event stream
 * rayd:{ID}:events, and, while it runs, one work item per tile of each of
 * its frames in the stream of its priority (cluster_items.c).  The record and all its items
 * are written by one Lua script, so a job is never seen without its items
 * nor items without their job; a node that dies mid-POST wrote all or
 * nothing, and the client, told nothing, posts again.
 *
 * Reads fill the very structs the single node's routes read (struct
 * shots_info, its struct jobs_info), so the JSON a cluster answers is made
 * by the same code and has the same shape.  A job ends by rayd_end (Lua):
 * its state, its last event, its tiles deleted and every key of it set to
 * expire after --job-ttl.  Redis cannot expire a ZSET's member, so rayd_end
 * also files "ID CLIENT" in the ZSET rayd:ended, scored by when the job's
 * keys expire (and ID in its client's rayd:ended:CLIENT, the same score),
 * and every node sweeps it once a second (cluster_jobs_sweep):
 * a due entry leaves its client's list, whose key goes once it is empty.
 * So a list holds only jobs that are kept, listed or not (the list alone
 * dropped an expired job when it met one, and a client that never paged to
 * its end left every job it ever had in Redis for good).  It also leaves a
 * tombstone, rayd:{ID}:gone ("state
 * ended_ms ttl", some 100 bytes), that outlives the job's keys by
 * CLUSTER_TOMB_S, so any node answers an expired job's routes 410
 * job_expired, how and when it ended, as a single node does from its ring
 * of tombstones, and 404 only an id the cluster never had (or forgot a day
 * ago).
 *
 * --max-jobs counts the cluster's unfinished jobs: the set rayd:unfinished
 * holds their ids (added by the submit script, removed by rayd_end), and
 * the submit script refuses (-3: 503 queue_full, as a single node's full
 * table) when it holds the POSTing node's --max-jobs already.  Counted and
 * added in one script, two nodes cannot both pass the last place.  An id
 * whose job is no longer unfinished (its keys deleted by hand, evicted by
 * Redis) is pruned when the set looks full, so a stale id never blocks.
 */
#include "cluster/cluster_private.h"

#include <cjson/cJSON.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Every key a job keeps after its end, handed to fn a few at a time: its
 * frames' images and done sets, its passes' records (at most 64, as the
 * passes cap), the record, its events, its frame set and its video.
 * rayd_end sets them to expire and rayd_forget deletes them (one DEL a
 * frame), so the two cannot disagree on what a job leaves behind. */
#define CLUSTER_LUA_KEPT                                                                           \
    "local function rayd_kept(p, first, last, passes, fn)\n"                                       \
    "  for k = first, last do\n"                                                                   \
    "    fn(p .. 'frame:' .. k, p .. 'frame:' .. k .. ':exr', p .. 'done:' .. k)\n"                \
    "  end\n"                                                                                      \
    "  for q = 1, math.min(passes, 64) do fn(p .. 'pass:' .. q) end\n"                             \
    "  fn(p .. 'job', p .. 'events', p .. 'frames', p .. 'video')\n"                               \
    "end\n"

static const char cluster_lua_end[] = CLUSTER_LUA_KEPT
    "local function rayd_end(id, state, now, ttl, err)\n"
    "  local p = 'rayd:{' .. id .. '}:'\n"
    "  local st = redis.call('HGET', p .. 'job', 'state')\n"
    "  if not st then return -2 end\n"
    "  if st ~= 'queued' and st ~= 'running' then return 0 end\n"
    "  redis.call('HSET', p .. 'job', 'state', state, 'ended', now)\n"
    "  if err ~= '' then redis.call('HSET', p .. 'job', 'error', err) end\n"
    "  redis.call('XADD', p .. 'events', 'MAXLEN', '~', 1000, '*', 'kind', 'done', 'state', "
    "state)\n"
    "  local first = tonumber(redis.call('HGET', p .. 'job', 'first')) or 0\n"
    "  local last = tonumber(redis.call('HGET', p .. 'job', 'last')) or -1\n"
    "  local tiles = tonumber(redis.call('HGET', p .. 'job', 'tiles')) or 0\n"
    "  for k = first, last do\n"
    "    for t = 0, tiles - 1 do\n"
    "      redis.call('DEL', p .. 'tile:' .. k .. ':' .. t, p .. 'tile:' .. k .. ':' .. t .. "
    "':exr')\n"
    "    end\n"
    "  end\n"
    "  local pr = redis.call('HMGET', p .. 'job', 'pass', 'passes', 'progressive')\n"
    "  if pr[3] == '1' then\n"
    "    local K = tonumber(pr[1]) or 0\n"
    "    for t = 0, tiles - 1 do\n"
    "      redis.call('DEL', p .. 'sums:' .. K .. ':' .. t, p .. 'run:' .. K .. ':' .. t, p .. "
    "'run:' .. (K - 1) .. ':' .. t)\n"
    "    end\n"
    "    redis.call('DEL', p .. 'pdone:' .. K)\n"
    "  end\n"
    "  local passes = pr[3] == '1' and tonumber(pr[2]) or 0\n"
    "  rayd_kept(p, first, last, passes, function(...)\n"
    "    for _, k in ipairs({...}) do redis.call('EXPIRE', k, ttl) end\n"
    "  end)\n"
    "  redis.call('SREM', 'rayd:unfinished', id)\n"
    "  local cl = redis.call('HGET', p .. 'job', 'client') or ''\n"
    "  local due = tonumber(now) + 1000 * tonumber(ttl)\n"
    "  redis.call('ZADD', 'rayd:ended', due, id .. ' ' .. cl)\n"
    "  if cl ~= '' then redis.call('ZADD', 'rayd:ended:' .. cl, due, id) end\n"
    "  local tomb = tonumber(ttl) + " CLUSTER_TOMB_S "\n"
    "  redis.call('SET', p .. 'gone', state .. ' ' .. now .. ' ' .. ttl, 'EX', tomb)\n"
    "  return 1\n"
    "end\n";

/* KEYS: the job, rayd:jobs:CLIENT, the items' stream, the events, rayd:unfinished;
 * ARGV: id, created (ms), first, last, tiles, --max-jobs, the items' pass
 * ("0": no passes; a progressive job's start at 1), then the hash's fields
 * and values.  -3: the cluster's unfinished jobs are --max-jobs.
 * A full set is pruned of ended ids 64 at a time (SRANDMEMBER), so a
 * refused POST costs Redis a bounded moment however large --max-jobs is.
 * As on one node, --max-jobs counts ended jobs too: while unfinished and
 * ended (rayd:ended) together reach it, the POSTing client's own job that
 * ended first is forgotten (rayd:ended:CLIENT, KEYS[6]), or when it has
 * none ended, anyone's -- so one client's flood of jobs forgets its own
 * results, not another's finished a moment ago -- up to 64 a POST
 * (rayd_forget: its keys deleted, its list
 * entry gone, its tombstone marked evicted so its routes answer 410
 * job_evicted).  Without it the ended jobs a cluster keeps grew with the
 * POST rate times --job-ttl, unbounded by any count. */
static const char cluster_lua_submit[] = CLUSTER_LUA_KEPT
    "local function rayd_forget(m, now)\n"
    "  local id, cl = string.match(m, '^(%x+) (%d*)$')\n"
    "  if not id then return end\n"
    "  local p = 'rayd:{' .. id .. '}:'\n"
    "  local j = redis.call('HMGET', p .. 'job', 'state', 'first', 'last', 'passes')\n"
    "  rayd_kept(p, tonumber(j[2]) or 0, tonumber(j[3]) or -1, tonumber(j[4]) or 0,\n"
    "            function(...) redis.call('DEL', ...) end)\n"
    "  if cl ~= '' then\n"
    "    redis.call('ZREM', 'rayd:jobs:' .. cl, id)\n"
    "    redis.call('ZREM', 'rayd:ended:' .. cl, id)\n"
    "  end\n"
    "  local g = j[1] and redis.call('GET', p .. 'gone')\n"
    "  if g then redis.call('SET', p .. 'gone', g .. ' ' .. now, 'KEEPTTL') end\n"
    "end\n"
    "local max = tonumber(ARGV[6])\n"
    "if redis.call('SCARD', KEYS[5]) >= max then\n"
    "  for _, j in ipairs(redis.call('SRANDMEMBER', KEYS[5], 64)) do\n"
    "    local st = redis.call('HGET', 'rayd:{' .. j .. '}:job', 'state')\n"
    "    if st ~= 'queued' and st ~= 'running' then redis.call('SREM', KEYS[5], j) end\n"
    "  end\n"
    "  if redis.call('SCARD', KEYS[5]) >= max then return -3 end\n"
    "end\n"
    "local kept = redis.call('ZCARD', 'rayd:ended') + redis.call('SCARD', KEYS[5])\n"
    "local cl = string.match(KEYS[6], '^rayd:ended:(%d+)$')\n"
    "for _ = 1, 64 do\n"
    "  if kept < max then break end\n"
    "  local m = redis.call('ZPOPMIN', KEYS[6])\n"
    "  local kept_one = true\n"
    "  if m[1] then\n"
    "    m[1] = m[1] .. ' ' .. cl\n"
    "    kept_one = redis.call('ZREM', 'rayd:ended', m[1]) == 1\n"
    "  else\n"
    "    m = redis.call('ZPOPMIN', 'rayd:ended')\n"
    "  end\n"
    "  if not m[1] then break end\n"
    "  if kept_one then\n" /* else a stale id (swept by a node of before): dropped */
    "    rayd_forget(m[1], ARGV[2])\n"
    "    kept = kept - 1\n"
    "  end\n"
    "end\n"
    "redis.call('SADD', KEYS[5], ARGV[1])\n"
    "redis.call('HSET', KEYS[1], unpack(ARGV, 8))\n"
    "redis.call('ZADD', KEYS[2], ARGV[2], ARGV[1])\n"
    "redis.call('XADD', KEYS[4], 'MAXLEN', '~', 1000, '*', 'kind', 'state', 'state', 'queued')\n"
    "for k = tonumber(ARGV[3]), tonumber(ARGV[4]) do\n"
    "  for t = 0, tonumber(ARGV[5]) - 1 do\n"
    "    if ARGV[7] == '0' then\n"
    "      redis.call('XADD', KEYS[3], '*', 'job', ARGV[1], 'frame', k, 'tile', t)\n"
    "    else\n"
    "      redis.call('XADD', KEYS[3], '*', 'job', ARGV[1], 'frame', k, 'tile', t, 'pass', "
    "ARGV[7])\n"
    "    end\n"
    "  end\n"
    "end\n"
    "return 1\n";

/* The fields a status read takes (never the scene: it can be megabytes). */
static const char *const cluster_fields[] = {
    "state",       "created",      "started",    "ended",       "client",
    "priority",    "scene_id",     "x",          "y",           "w",
    "h",           "first",        "last",       "animated",    "tiles",
    "fps",         "est_rays",     "tiles_done", "frames_done", "rays",
    "render_ms",   "error",        "latest",     "version",     "denoise",
    "encode_ms",   "exr",          "video",      "progressive", "plan",
    "passes_done", "pass_samples", "pass_time",  "noise",       "stopped",
    NULL};
enum {
    F_STATE,
    F_CREATED,
    F_STARTED,
    F_ENDED,
    F_CLIENT,
    F_PRIORITY,
    F_SCENE_ID,
    F_X,
    F_Y,
    F_W,
    F_H,
    F_FIRST,
    F_LAST,
    F_ANIMATED,
    F_TILES,
    F_FPS,
    F_EST_RAYS,
    F_TILES_DONE,
    F_FRAMES_DONE,
    F_RAYS,
    F_RENDER_MS,
    F_ERROR,
    F_LATEST,
    F_VERSION,
    F_DENOISE,
    F_ENCODE_MS,
    F_EXR,
    F_VIDEO,
    F_PROGRESSIVE,
    F_PLAN,
    F_PASSES_DONE,
    F_PASS_SAMPLES,
    F_PASS_TIME,
    F_NOISE,
    F_STOPPED,
    F__COUNT
};

/* A status read: the fields, then the frames being assembled or rendered;
 * for a job that expired, its tombstone (a string), or nil. */
static const char cluster_lua_status[] =
    "local p = 'rayd:{' .. ARGV[1] .. '}:'\n"
    "local v = redis.call('HMGET', p .. 'job', unpack(ARGV, 2))\n"
    "if not v[1] then return redis.call('GET', p .. 'gone') end\n"
    "local running = 0\n"
    "local first, last = tonumber(v[12]), tonumber(v[13])\n"
    "if v[1] == 'running' and first and last and last - first < 100000 then\n"
    "  for k = first, last do\n"
    "    if redis.call('EXISTS', p .. 'done:' .. k) == 1 and\n"
    "       redis.call('SISMEMBER', p .. 'frames', k) == 0 then running = running + 1 end\n"
    "  end\n"
    "end\n"
    "table.insert(v, tostring(running))\n"
    "return v\n";

#define CLUSTER_EVAL_MAX 12 /* values a script after rayd_end takes */

redisReply *cluster_jobs_eval(struct redis *c, const char *body, int n, const char **args,
                              const size_t *lens) {
    size_t size = strlen(cluster_lua_end) + strlen(body) + 1;
    char *script = n <= CLUSTER_EVAL_MAX ? malloc(size) : NULL;
    if (!script) return NULL;
    snprintf(script, size, "%s%s", cluster_lua_end, body);
    const char *argv[CLUSTER_EVAL_MAX + 3] = {"EVAL", script, "0"};
    size_t alen[CLUSTER_EVAL_MAX + 3] = {4, size - 1, 1};
    for (int i = 0; i < n; i++) {
        argv[3 + i] = args[i];
        alen[3 + i] = lens ? lens[i] : strlen(args[i]);
    }
    redisReply *rep = redis_argv(c, n + 3, argv, alen);
    free(script);
    return rep;
}

bool cluster_jobs_end(struct redis *c, const char *id, const char *state, const char *error) {
    char now[32], ttl[24];
    snprintf(now, sizeof now, "%.0f", cluster_now_ms());
    snprintf(ttl, sizeof ttl, "%ld", config.job_ttl);
    const char *args[] = {id, state, now, ttl, error ? error : ""};
    redisReply *rep = cluster_jobs_eval(
        c, "return rayd_end(ARGV[1], ARGV[2], ARGV[3], ARGV[4], ARGV[5])", 5, args, NULL);
    bool ok = !redis_failed(c, rep);
    if (rep) freeReplyObject(rep);
    return ok;
}

/* A script about one tile of job id, ARGV the job, frame, tile, then a and
 * b (NULL: none): its integer answer, -1 when Redis failed. */
static long jobs_tile_eval(struct redis *c, const char *script, const char *id, long frame,
                           long tile, const char *a, const char *b) {
    char k[24], t[24];
    snprintf(k, sizeof k, "%ld", frame);
    snprintf(t, sizeof t, "%ld", tile);
    const char *argv[] = {"EVAL", script, "0", id, k, t, a, b, NULL};
    redisReply *rep = redis_strs(c, argv);
    long n = redis_failed(c, rep) ? -1 : (long)redis_ll(rep, -1);
    if (rep) freeReplyObject(rep);
    return n;
}

/* The start of jobs_tile_eval's scripts: the job's record (key), the
 * tile's fields' suffix (f), and the nodes that tried the tile (by: one
 * after each space, as node ids have none) with tried(name). */
#define JOBS_LUA_TILE                                                                              \
    "local key, f = 'rayd:{' .. ARGV[1] .. '}:job', ARGV[2] .. ':' .. ARGV[3]\n"                   \
    "local by = redis.call('HGET', key, 'triedby:' .. f) or ''\n"                                  \
    "local function tried(name)\n"                                                                 \
    "  return string.find(by .. ' ', ' ' .. name .. ' ', 1, true) ~= nil\n"                        \
    "end\n"

long cluster_jobs_tried(struct redis *c, const char *id, long frame, long tile) {
    static const char script[] =
        JOBS_LUA_TILE "local st = redis.call('HGET', key, 'state')\n"
                      "if st ~= 'queued' and st ~= 'running' then return 0 end\n"
                      "if not tried(ARGV[4]) then\n"
                      "  redis.call('HSET', key, 'triedby:' .. f, by .. ' ' .. ARGV[4])\n"
                      "end\n"
                      "return redis.call('HINCRBY', key, 'tries:' .. f, 1)\n";
    return jobs_tile_eval(c, script, id, frame, tile, cluster_node_id, NULL);
}

long cluster_jobs_untried(struct redis *c, const char *id, long frame, long tile) {
    /* ARGV after the tile's: this node's version, and the age (ms) past
     * which a heartbeat is gone (cluster_gone_ms).  A node of this version
     * reads its streams and takes the item once it has room; its heartbeat
     * (rayd:nodes, Redis's clock) says it is live, busy or idle.  Not its
     * consumer's idle time: a busy node refreshes only the streams it holds
     * items of, and before Redis 7.2 a read that finds nothing refreshes
     * none (an idle node looked gone after 3 x --redis-claim-ms). */
    static const char script[] =
        JOBS_LUA_TILE "local now = tonumber(redis.call('TIME')[1])\n"
                      "local hs, n = redis.call('HGETALL', 'rayd:nodes'), 0\n"
                      "for j = 1, #hs, 2 do\n"
                      "  local seen = tonumber(string.match(hs[j + 1], '\"seen\":(%d+)')) or 0\n"
                      "  if string.match(hs[j + 1], '\"version\":\"([^\"]*)\"') == ARGV[4] and\n"
                      "     (now - seen) * 1000 <= tonumber(ARGV[5]) and not tried(hs[j]) then\n"
                      "    n = n + 1\n"
                      "  end\n"
                      "end\n"
                      "return n\n";
    char gone[24];
    snprintf(gone, sizeof gone, "%ld", cluster_gone_ms());
    return jobs_tile_eval(c, script, id, frame, tile, cluster_version(), gone);
}

long cluster_jobs_unfinished(struct redis *c) {
    const char *argv[] = {"SCARD", "rayd:unfinished", NULL};
    redisReply *rep = redis_strs(c, argv);
    long n = rep && rep->type == REDIS_REPLY_INTEGER ? (long)rep->integer : 0;
    if (rep) freeReplyObject(rep);
    return n;
}

int cluster_jobs_plan(const char *s, int out[PASSES_MAX]) {
    int n = 0;
    for (const char *p = s; p && *p; n++) {
        char *end;
        long v = strtol(p, &end, 10);
        if (n == PASSES_MAX || end == p || v < 1 || v > 65536 || (n && v <= out[n - 1])) return -1;
        out[n] = (int)v;
        p = *end == ',' ? end + 1 : end;
        if (*end && *end != ',') return -1;
    }
    return n;
}

/* The key of the client's list of jobs, rayd:jobs:CLIENT, into buf. */
static void cluster_jobs_list_key(char *buf, size_t n, uint64_t client) {
    snprintf(buf, n, "rayd:jobs:%llu", (unsigned long long)client);
}

/* 32 random hex digits. */
static bool cluster_new_id(char id[33]) {
    unsigned char b[16];
    int fd = open("/dev/urandom", O_RDONLY | O_CLOEXEC);
    if (fd < 0) return false;
    bool ok = read(fd, b, sizeof b) == (ssize_t)sizeof b;
    close(fd);
    for (int i = 0; i < 16; i++) snprintf(id + 2 * i, 3, "%02x", b[i]);
    return ok;
}

static void cluster_submit_job(struct redis *c, struct cluster_op *op) {
    if (!cluster_new_id(op->id)) {
        op->status = CS_NOMEM;
        return;
    }
    long n = config.cluster_tile;
    long cols = (op->reg.w + n - 1) / n, rows = (op->reg.h + n - 1) / n;
    char v[24][40], keys[3][80], max[24], plan[PASSES_MAX * 8] = "", list[48], ended[48];
    double now = cluster_now_ms();
    op->created_ms = now;
    snprintf(v[0], 40, "%.0f", now);
    snprintf(v[1], 40, "%ld", op->first);
    snprintf(v[2], 40, "%ld", op->last);
    snprintf(v[3], 40, "%ld", cols * rows);
    snprintf(v[4], 40, "%llu", (unsigned long long)op->client);
    snprintf(v[5], 40, "%d", op->priority);
    snprintf(v[6], 40, "%d", op->reg.x);
    snprintf(v[7], 40, "%d", op->reg.y);
    snprintf(v[8], 40, "%d", op->reg.w);
    snprintf(v[9], 40, "%d", op->reg.h);
    snprintf(v[10], 40, "%ld", cols);
    snprintf(v[11], 40, "%ld", n);
    snprintf(v[12], 40, "%.17g", op->fps);
    snprintf(v[13], 40, "%.0f", op->est_rays);
    snprintf(v[14], 40, "%u", op->aov);
    snprintf(max, sizeof max, "%ld", config.max_jobs);
    snprintf(v[15], 40, "%d", op->npasses);
    snprintf(v[16], 40, "%.17g", op->plan.time_budget);
    snprintf(v[17], 40, "%.17g", op->plan.noise_target);
    for (int i = 0; i < op->npasses; i++) {
        size_t used = strlen(plan);
        snprintf(plan + used, sizeof plan - used, "%s%d", i ? "," : "", op->samples[i]);
    }
    cluster_key(keys[0], sizeof keys[0], op->id, "job");
    cluster_key(keys[2], sizeof keys[2], op->id, "events");
    cluster_jobs_list_key(list, sizeof list, op->client);
    snprintf(ended, sizeof ended, "rayd:ended:%llu", (unsigned long long)op->client);
    const char *argv[] = {"EVAL",
                          cluster_lua_submit,
                          "6",
                          keys[0],
                          list,
                          cluster_items_stream(op->priority),
                          keys[2],
                          "rayd:unfinished",
                          ended,
                          op->id,
                          v[0],
                          v[1],
                          v[2],
                          v[3],
                          max,
                          op->progressive ? "1" : "0",
                          "id",
                          op->id,
                          "version",
                          cluster_version(),
                          "state",
                          "queued",
                          "created",
                          v[0],
                          "client",
                          v[4],
                          "priority",
                          v[5],
                          "scene_id",
                          op->scene_id,
                          "query",
                          op->query ? op->query : "",
                          "x",
                          v[6],
                          "y",
                          v[7],
                          "w",
                          v[8],
                          "h",
                          v[9],
                          "width",
                          v[8],
                          "height",
                          v[9],
                          "first",
                          v[1],
                          "last",
                          v[2],
                          "animated",
                          op->animated ? "1" : "0",
                          "tiles",
                          v[3],
                          "cols",
                          v[10],
                          "tile_size",
                          v[11],
                          "fps",
                          v[12],
                          "est_rays",
                          v[13],
                          "denoise",
                          op->denoise ? "1" : "0",
                          "exr",
                          op->exr ? "1" : "0",
                          "aov",
                          v[14],
                          "tiles_done",
                          "0",
                          "frames_done",
                          "0",
                          "rays",
                          "0",
                          "render_ms",
                          "0",
                          "node",
                          cluster_node_id,
                          "items",
                          cluster_items_stream(op->priority),
                          "progressive",
                          op->progressive ? "1" : "0",
                          "plan",
                          plan,
                          "passes",
                          v[15],
                          "pass",
                          "1",
                          "passes_done",
                          "0",
                          "time_budget",
                          v[16],
                          "noise_target",
                          v[17],
                          "scene",
                          op->scene};
    int argc = (int)(sizeof argv / sizeof argv[0]);
    size_t lens[sizeof argv / sizeof argv[0]];
    for (int i = 0; i < argc; i++) lens[i] = strlen(argv[i]);
    lens[argc - 1] = op->scene_len;
    redisReply *rep = redis_argv(c, argc, argv, lens);
    op->status = redis_failed(c, rep) ? CS_DOWN : redis_ll(rep, 1) == -3 ? CS_FULL : CS_OK;
    if (rep) freeReplyObject(rep);
    if (op->status == CS_OK && op->progressive)
        log_info("cluster: job %s: pass 1 of %d, %ld tile(s), queued", op->id, op->npasses,
                 cols * rows);
    else if (op->status == CS_OK)
        log_info("cluster: job %s: %ld frame(s) of %ld tile(s) queued", op->id,
                 op->last - op->first + 1, cols * rows);
}

static const char *cluster_str(const redisReply *r) {
    return r && r->type == REDIS_REPLY_STRING ? r->str : "";
}
static double cluster_num(const redisReply *r) {
    const char *s = cluster_str(r);
    return *s ? strtod(s, NULL) : 0;
}

/* The error JSON of a failed job into err. */
static void cluster_error_read(const char *json, struct rayd_error *err) {
    memset(err, 0, sizeof *err);
    err->code = RAYD_E_INTERNAL;
    cJSON *o = cJSON_Parse(json);
    const cJSON *code = cJSON_GetObjectItemCaseSensitive(o, "code");
    const cJSON *msg = cJSON_GetObjectItemCaseSensitive(o, "message");
    const cJSON *path = cJSON_GetObjectItemCaseSensitive(o, "path");
    for (int s = RAYD_OK; cJSON_IsString(code) && s <= RAYD_E_INTERNAL; s++)
        if (!strcmp(code->valuestring, rayd_status_name((enum rayd_status)s)))
            err->code = (enum rayd_status)s;
    snprintf(err->message, sizeof err->message, "%s",
             cJSON_IsString(msg) ? msg->valuestring : "the job failed");
    if (cJSON_IsString(path)) snprintf(err->path, sizeof err->path, "%s", path->valuestring);
    cJSON_Delete(o);
}

static enum jobs_state cluster_state(const char *s) {
    for (int i = JS_QUEUED; i <= JS_EVICTED; i++)
        if (!strcmp(s, jobs_state_name((enum jobs_state)i))) return (enum jobs_state)i;
    return JS_FAILED;
}

/* The video's field ("making", "ready", "failed: why", "no_ffmpeg: why",
 * cluster_video.c's) into out. */
static void cluster_video_state(const char *s, struct shots_info *out) {
    const char *why = strchr(s, ':');
    out->video = !strcmp(s, "making")            ? SV_MAKING
                 : !strcmp(s, "ready")           ? SV_READY
                 : !strncmp(s, "no_ffmpeg:", 10) ? SV_NO_FFMPEG
                 : !strncmp(s, "failed:", 7)     ? SV_FAILED
                                                 : SV_NONE;
    snprintf(out->video_error, sizeof out->video_error, "%s", why ? why + 1 + (why[1] == ' ') : "");
}

/* A progressive job's passes (its tiles: those of the pass being rendered). */
static void cluster_fill_passes(redisReply **v, struct jobs_info *j, long tiles) {
    int samples[PASSES_MAX];
    int n = cluster_jobs_plan(cluster_str(v[F_PLAN]), samples);
    struct jobs_passes *p = &j->passes;
    const char *why = cluster_str(v[F_STOPPED]);
    j->progressive = true;
    j->tiles_total = tiles;
    p->total = n > 0 ? n : 0;
    p->done = (int)cluster_num(v[F_PASSES_DONE]);
    if (p->done > p->total) p->done = p->total;
    p->samples = p->done > 0 ? (int)cluster_num(v[F_PASS_SAMPLES]) : 0;
    p->samples_target = n > 0 ? samples[n - 1] : 0;
    p->time_s = p->done > 0 ? cluster_num(v[F_PASS_TIME]) : 0;
    p->noise = p->done > 0 && *cluster_str(v[F_NOISE]) ? cluster_num(v[F_NOISE]) : -1;
    p->stopped = PASSES_GOING;
    for (int s = PASSES_BY_TIME; s <= PASSES_BY_WORK; s++)
        if (!strcmp(why, passes_stop_name((enum passes_stop)s))) p->stopped = (enum passes_stop)s;
    double frac = (double)j->tiles_done / (double)(tiles > 0 ? tiles : 1);
    if (n > 0) j->progress = passes_share(samples, n, p->done, frac);
}

/* The status read's values v (F__COUNT + 1) into *out. */
static void cluster_fill(const char *id, redisReply **v, struct shots_info *out, bool *animated) {
    struct jobs_info *j = &out->job;
    memset(out, 0, sizeof *out);
    double now = cluster_now_ms();
    snprintf(j->id, sizeof j->id, "%s", id);
    j->state = cluster_state(cluster_str(v[F_STATE]));
    snprintf(j->scene_id, sizeof j->scene_id, "%s", cluster_str(v[F_SCENE_ID]));
    j->region = (struct rayd_region){(int)cluster_num(v[F_X]), (int)cluster_num(v[F_Y]),
                                     (int)cluster_num(v[F_W]), (int)cluster_num(v[F_H])};
    double created = cluster_num(v[F_CREATED]), started = cluster_num(v[F_STARTED]);
    double ended = cluster_num(v[F_ENDED]);
    j->created_wall = created / 1e3;
    j->seq = (long long)created;
    j->created_age = (now - created) / 1e3;
    j->queue_ms = started > 0 ? started - created : (ended > 0 ? 0 : now - created);
    j->render_ms = cluster_num(v[F_RENDER_MS]);
    j->encode_ms = cluster_num(v[F_ENCODE_MS]);
    j->rays = (uint64_t)cluster_num(v[F_RAYS]);
    j->est_rays = cluster_num(v[F_EST_RAYS]);
    j->priority = (int)cluster_num(v[F_PRIORITY]);
    j->denoise = !strcmp(cluster_str(v[F_DENOISE]), "1");
    j->keep_exr = !strcmp(cluster_str(v[F_EXR]), "1");
    j->ended_age = ended > 0 ? (now - ended) / 1e3 : -1;
    if (j->state == JS_FAILED) cluster_error_read(cluster_str(v[F_ERROR]), &j->err);
    long first = (long)cluster_num(v[F_FIRST]), last = (long)cluster_num(v[F_LAST]);
    long tiles = (long)cluster_num(v[F_TILES]), frames = last - first + 1;
    j->tiles_total = tiles * frames;
    j->tiles_done = (long)cluster_num(v[F_TILES_DONE]);
    *animated = !strcmp(cluster_str(v[F_ANIMATED]), "1");
    out->first = first;
    out->last = last;
    out->total = frames;
    out->done = (long)cluster_num(v[F_FRAMES_DONE]);
    out->running = (long)cluster_num(v[F__COUNT]);
    out->queued =
        j->state == JS_QUEUED || j->state == JS_RUNNING ? frames - out->done - out->running : 0;
    out->latest = *cluster_str(v[F_LATEST]) ? (long)cluster_num(v[F_LATEST]) : -1;
    out->eta_s = -1; /* as shots.c: 0 once done, else the pace of the frames done so far */
    if (j->state == JS_SUCCEEDED)
        out->eta_s = 0;
    else if ((j->state == JS_QUEUED || j->state == JS_RUNNING) && out->done > 0 &&
             out->done < frames)
        out->eta_s = (now - created) / 1e3 / (double)out->done * (double)(frames - out->done);
    out->fps = cluster_num(v[F_FPS]);
    if (*animated) { /* a frame range counts frames, as one node's (api.md) */
        j->tiles_total = frames;
        j->tiles_done = out->done;
    }
    cluster_video_state(cluster_str(v[F_VIDEO]), out);
    j->progress = *animated ? (double)out->done / (double)(frames > 0 ? frames : 1)
                            : (double)j->tiles_done / (double)(tiles > 0 ? tiles : 1);
    if (!strcmp(cluster_str(v[F_PROGRESSIVE]), "1")) cluster_fill_passes(v, j, tiles);
    if (j->state == JS_SUCCEEDED) j->progress = 1;
}

/* A tombstone's "state ended_ms ttl" into g: the job expired ttl s after
 * it ended; or, with a fourth number, was forgotten then (ms) for
 * --max-jobs (rayd_forget). */
static void cluster_tomb_read(const char *s, struct jobs_gone *g) {
    char state[16] = "";
    double ended = 0, ttl = 0, evicted = 0;
    memset(g, 0, sizeof *g);
    int n = sscanf(s, "%15s %lf %lf %lf", state, &ended, &ttl, &evicted);
    if (n < 3) ended = ttl = 0;
    g->why = n == 4 ? JG_EVICTED : JG_EXPIRED;
    g->state = cluster_state(state);
    g->ended_wall = ended / 1e3;
    g->gone_wall = n == 4 ? evicted / 1e3 : ended / 1e3 + ttl;
}

/* Reads job id into op->info; CS_UNKNOWN when there is none, CS_GONE
 * (op->gone) when it expired. */
static void cluster_read(struct redis *c, const char *id, struct cluster_op *op,
                         struct shots_info *out, bool *animated) {
    const char *argv[F__COUNT + 6] = {"EVAL", cluster_lua_status, "0", id};
    for (int i = 0; i < F__COUNT; i++) argv[4 + i] = cluster_fields[i];
    argv[4 + F__COUNT] = NULL;
    redisReply *rep = redis_strs(c, argv);
    if (redis_failed(c, rep)) {
        op->status = CS_DOWN;
    } else if (rep->type == REDIS_REPLY_STRING) {
        cluster_tomb_read(rep->str, &op->gone);
        op->status = CS_GONE;
    } else if (rep->type != REDIS_REPLY_ARRAY || rep->elements != F__COUNT + 1) {
        op->status = CS_UNKNOWN;
    } else {
        cluster_fill(id, rep->element, out, animated);
        op->status = CS_OK;
    }
    if (rep) freeReplyObject(rep);
}

/* The samples of pass k of op's job into op->pass_samples; false when
 * Redis failed (op->status says). */
static bool cluster_pass_samples(struct redis *c, struct cluster_op *op, long k) {
    char key[120];
    int samples[PASSES_MAX];
    cluster_key(key, sizeof key, op->id, "job");
    const char *argv[] = {"HGET", key, "plan", NULL};
    redisReply *rep = redis_strs(c, argv);
    if (redis_failed(c, rep)) {
        op->status = CS_DOWN;
        if (rep) freeReplyObject(rep);
        return false;
    }
    int n = cluster_jobs_plan(cluster_str(rep), samples);
    op->pass_samples = k >= 1 && k <= n ? samples[k - 1] : 0;
    freeReplyObject(rep);
    return true;
}

/* The frame's PNG (its EXR when op->exr; the job's video for CO_VIDEO),
 * when it is there. */
static void cluster_image(struct redis *c, struct cluster_op *op) {
    cluster_read(c, op->id, op, &op->info, &op->is_animated);
    if (op->status != CS_OK) return;
    char key[120], what[40];
    if (op->kind == CO_VIDEO && op->info.video != SV_READY) return;
    if (op->kind != CO_VIDEO && (op->frame < op->info.first || op->frame > op->info.last)) return;
    long pass = op->pass ? op->pass : op->info.job.passes.done;
    enum jobs_state st = op->info.job.state;
    if (op->info.job.progressive && (op->exr || pass < 1 || pass > op->info.job.passes.done ||
                                     st == JS_FAILED || st == JS_CANCELED))
        return; /* no such pass yet (or none kept, or the job's end says: the answer does) */
    if (op->info.job.progressive && !cluster_pass_samples(c, op, pass)) return;
    if (op->kind == CO_VIDEO)
        snprintf(what, sizeof what, "video");
    else if (op->info.job.progressive)
        snprintf(what, sizeof what, "pass:%ld", pass);
    else
        snprintf(what, sizeof what, "frame:%ld%s", op->frame, op->exr ? ":exr" : "");
    cluster_key(key, sizeof key, op->id, what);
    const char *argv[] = {"GET", key, NULL};
    redisReply *rep = redis_strs(c, argv);
    if (redis_failed(c, rep)) {
        op->status = CS_DOWN;
    } else if (rep->type == REDIS_REPLY_STRING && rep->len > 0) {
        void *data = malloc(rep->len);
        if (data) memcpy(data, rep->str, rep->len);
        op->png = data ? blob_new(data, rep->len) : NULL;
        if (!op->png) {
            free(data);
            op->status = CS_NOMEM;
        }
    }
    if (rep) freeReplyObject(rep);
}

static void cluster_cancel(struct redis *c, struct cluster_op *op) {
    cluster_read(c, op->id, op, &op->info, &op->is_animated);
    if (op->status != CS_OK) return;
    if (op->info.job.state == JS_QUEUED || op->info.job.state == JS_RUNNING) {
        if (!cluster_jobs_end(c, op->id, "canceled", NULL)) {
            op->status = CS_DOWN;
            return;
        }
        op->canceled_now = true;
        cluster_read(c, op->id, op, &op->info, &op->is_animated);
    }
}

/* -4: not a progressive job; 0: it had ended; 1: ended now (a pass is
 * kept); 2: it stops after its first pass; -2: no such job. */
static const char cluster_lua_stop[] =
    "local id = ARGV[1]\n"
    "local p = 'rayd:{' .. id .. '}:'\n"
    "local j = redis.call('HMGET', p .. 'job', 'state', 'progressive', 'passes_done')\n"
    "if not j[1] then return -2 end\n"
    "if j[2] ~= '1' then return -4 end\n"
    "if j[1] ~= 'queued' and j[1] ~= 'running' then return 0 end\n"
    "redis.call('HSET', p .. 'job', 'stop_asked', 1, 'stopped', 'client')\n"
    "if (tonumber(j[3]) or 0) == 0 then return 2 end\n"
    "return rayd_end(id, 'succeeded', ARGV[2], ARGV[3], '')\n";

static int cluster_stop_script(struct redis *c, const char *id) {
    char now[32], ttl[24];
    snprintf(now, sizeof now, "%.0f", cluster_now_ms());
    snprintf(ttl, sizeof ttl, "%ld", config.job_ttl);
    const char *args[] = {id, now, ttl};
    redisReply *rep = cluster_jobs_eval(c, cluster_lua_stop, 3, args, NULL);
    int rc = redis_failed(c, rep) ? -1 : (int)redis_ll(rep, -1);
    if (rep) freeReplyObject(rep);
    return rc;
}

/* A progressive job ends with its latest pass (or after its first). */
static void cluster_stop_job(struct redis *c, struct cluster_op *op) {
    int rc = cluster_stop_script(c, op->id);
    if (rc == -1) {
        op->status = CS_DOWN;
        return;
    }
    op->not_progressive = rc == -4;
    cluster_read(c, op->id, op, &op->info, &op->is_animated);
}

/* Due entries of rayd:ended, at most SWEEP_BATCH a call (some 1 ms of
 * Redis): each leaves its client's list once its job's keys are gone; one
 * whose keys are still there (a clock a few ms apart) is filed again for
 * when they expire -- PTTL 0 too, a key in its last millisecond (taking
 * that for gone left one job in 600 listed for good, under load).  Returns
 * how many it read. */
#define SWEEP_BATCH "256"
/* Batches a call of cluster_jobs_sweep: 5,120 jobs, more than a node takes a second. */
#define SWEEP_ROUNDS 20
static const char cluster_lua_sweep[] =
    "local due = redis.call('ZRANGEBYSCORE', 'rayd:ended', '-inf', ARGV[1], 'LIMIT', "
    "0, " SWEEP_BATCH ")\n"
    "for _, m in ipairs(due) do\n"
    "  local id, cl = string.match(m, '^(%x+) (%d*)$')\n"
    "  local left = id and redis.call('PTTL', 'rayd:{' .. id .. '}:job') or -2\n"
    "  local mine = cl and cl ~= '' and 'rayd:ended:' .. cl\n"
    "  if left >= 0 then\n"
    "    redis.call('ZADD', 'rayd:ended', tonumber(ARGV[1]) + left + 1, m)\n"
    "    if mine then redis.call('ZADD', mine, tonumber(ARGV[1]) + left + 1, id) end\n"
    "  else\n"
    "    if left == -2 and mine then redis.call('ZREM', 'rayd:jobs:' .. cl, id) end\n"
    "    if mine then redis.call('ZREM', mine, id) end\n"
    "    redis.call('ZREM', 'rayd:ended', m)\n"
    "  end\n"
    "end\n"
    "return #due\n";

long cluster_jobs_sweep(struct redis *c) {
    char now[32];
    snprintf(now, sizeof now, "%.0f", cluster_now_ms());
    const char *argv[] = {"EVAL", cluster_lua_sweep, "0", now, NULL};
    long total = 0, n = atol(SWEEP_BATCH);
    for (int round = 0; round < SWEEP_ROUNDS && n == atol(SWEEP_BATCH); round++) {
        redisReply *rep = redis_strs(c, argv);
        n = redis_failed(c, rep) ? -1 : (long)redis_ll(rep, -1);
        if (rep) freeReplyObject(rep);
        if (n < 0) return -1;
        total += n;
    }
    return total;
}

/* One page of the client's jobs, newest first, before op->after. */
static void cluster_list(struct redis *c, struct cluster_op *op) {
    char max[40], list[48];
    snprintf(max, sizeof max, op->after > 0 ? "(%lld" : "+inf", op->after);
    cluster_jobs_list_key(list, sizeof list, op->client);
    op->status = CS_OK;
    for (int scanned = 0; op->nrows <= op->limit && scanned < 5000; scanned += 200) {
        const char *argv[] = {
            "ZREVRANGEBYSCORE", list, max, "-inf", "WITHSCORES", "LIMIT", "0", "200", NULL};
        redisReply *rep = redis_strs(c, argv);
        if (redis_failed(c, rep) || rep->type != REDIS_REPLY_ARRAY) {
            op->status = CS_DOWN;
            if (rep) freeReplyObject(rep);
            return;
        }
        size_t n = rep->elements / 2;
        for (size_t i = 0; i < n && op->nrows <= op->limit; i++) {
            const char *id = rep->element[2 * i]->str;
            snprintf(max, sizeof max, "(%s", rep->element[2 * i + 1]->str);
            struct shots_info row;
            bool anim = false;
            struct cluster_op tmp = {0};
            cluster_read(c, id, &tmp, &row, &anim);
            if (tmp.status == CS_UNKNOWN || tmp.status == CS_GONE) { /* the list forgets it */
                redisReply *z = redis_cmd(c, "ZREM %s %s", list, id);
                if (z) freeReplyObject(z);
                continue;
            }
            if (tmp.status != CS_OK) {
                op->status = tmp.status;
                break;
            }
            if (op->state >= 0 && (int)row.job.state != op->state) continue;
            if (op->nrows == op->limit) {
                op->more = true;
                op->nrows++;
                break;
            }
            op->rows[op->nrows] = row;
            op->row_animated[op->nrows++] = anim;
        }
        freeReplyObject(rep);
        if (n < 200 || op->status != CS_OK) break;
    }
    if (op->nrows > op->limit) op->nrows = op->limit;
}

/* The job's events after op->cursor, up to CLUSTER_EVENTS_MAX. */
static void cluster_events(struct redis *c, struct cluster_op *op) {
    cluster_read(c, op->id, op, &op->info, &op->is_animated);
    if (op->status != CS_OK) return;
    char key[120], start[60], count[8];
    cluster_key(key, sizeof key, op->id, "events");
    snprintf(start, sizeof start, strcmp(op->cursor, "0") ? "(%s" : "-", op->cursor);
    snprintf(count, sizeof count, "%d", CLUSTER_EVENTS_MAX);
    const char *argv[] = {"XRANGE", key, start, "+", "COUNT", count, NULL};
    redisReply *rep = redis_strs(c, argv);
    if (redis_failed(c, rep) || rep->type != REDIS_REPLY_ARRAY) {
        op->status = CS_DOWN;
        if (rep) freeReplyObject(rep);
        return;
    }
    for (size_t i = 0; i < rep->elements && op->nevents < CLUSTER_EVENTS_MAX; i++) {
        const redisReply *e = rep->element[i];
        if (e->type != REDIS_REPLY_ARRAY || e->elements < 2) continue;
        struct cluster_event *ev = &op->events[op->nevents++];
        memset(ev, 0, sizeof *ev);
        snprintf(ev->cursor, sizeof ev->cursor, "%s", cluster_str(e->element[0]));
        snprintf(ev->kind, sizeof ev->kind, "%s", cluster_str(redis_field(e->element[1], "kind")));
        snprintf(ev->state, sizeof ev->state, "%s",
                 cluster_str(redis_field(e->element[1], "state")));
        ev->frame = (long)redis_ll(redis_field(e->element[1], "frame"), -1);
        ev->tile = (long)redis_ll(redis_field(e->element[1], "tile"), -1);
        ev->done = (long)redis_ll(redis_field(e->element[1], "done"), 0);
        ev->total = (long)redis_ll(redis_field(e->element[1], "total"), 0);
        const char *pr = cluster_str(redis_field(e->element[1], "progress"));
        ev->progress = *pr ? strtod(pr, NULL) : -1;
        ev->samples = (long)redis_ll(redis_field(e->element[1], "samples"), 0);
        ev->time_s = cluster_num(redis_field(e->element[1], "time_s"));
        const char *noise = cluster_str(redis_field(e->element[1], "noise"));
        ev->noise = *noise ? strtod(noise, NULL) : -1;
        const char *where = cluster_str(redis_field(e->element[1], "where"));
        if (sscanf(where, "%d %d %d %d", &ev->reg.x, &ev->reg.y, &ev->reg.w, &ev->reg.h) != 4)
            ev->reg = (struct rayd_region){0, 0, 0, 0};
    }
    freeReplyObject(rep);
}

void cluster_jobs_run(struct redis *c, struct cluster_op *op) {
    op->status = CS_OK;
    switch (op->kind) {
    case CO_SUBMIT: cluster_submit_job(c, op); break;
    case CO_GET: cluster_read(c, op->id, op, &op->info, &op->is_animated); break;
    case CO_CANCEL: cluster_cancel(c, op); break;
    case CO_IMAGE:
    case CO_VIDEO: cluster_image(c, op); break;
    case CO_LIST: cluster_list(c, op); break;
    case CO_EVENTS: cluster_events(c, op); break;
    case CO_STOP: cluster_stop_job(c, op); break;
    }
}
