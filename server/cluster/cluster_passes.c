/* cluster_passes.c -- a progressive job on a cluster: each pass's tiles
 * rendered by any node as exact sums, each pass assembled once.
 *
 * One node renders a progressive job by adding each pass's samples to a
 * tile's sums (passes.c).  A cluster cannot keep sums in one node's
 * memory, so it keeps them in Redis, and relies on what makes sums exact
 * (rayd_render_sample_range): the sums of disjoint sample ranges, added in
 * any order, are bit for bit one render's.  So the item of pass K of tile
 * T renders only the samples that pass adds (k0..k1-1, POST
 * /v1/render?format=sums's bytes) and stores them as rayd:{ID}:sums:K:T;
 * the node whose tile completes the pass queues its assembly (tile -1,
 * pass K), as a frame's.  The assembly adds each tile's new sums to its
 * running sums of the pass before (rayd:{ID}:run:K-1:T), keeps the
 * result as run:K:T for the next pass, resolves it into the pass's image
 * and encodes the PNG: the bytes one node's pass K gives, and those of a
 * plain render of that many samples.  Pass 1 of one sample is the centre
 * image (work_target.centre), and the pass after it starts again from
 * sample 0, as on one node.
 *
 * The pass's end is one script: the PNG kept (rayd:{ID}:pass:K, the
 * latest PASSES_KEEP of them), the pass's numbers and event, the sums it
 * used deleted, and then either the next pass's items queued or the job
 * ended succeeded.  The stop rules are the single node's: the plan's last
 * pass, a time budget (from the first tile; checked after each tile too,
 * so a pass in flight is dropped and the latest complete one kept), a
 * noise target (passes_noise_of, against the previous pass's PNG), and
 * POST /v1/jobs/{id}/stop (cluster_jobs.c sets the flag stop_asked, or
 * ends the job at once when a pass is complete; the first pass ends it).
 *
 * Everything is keyed by pass and idempotent.  Every script checks that
 * the job is still at pass K (the record's `pass`), so a late duplicate --
 * a tile or an assembly taken over from a stalled node -- stores and
 * queues nothing.  An assembly that finds a tile's sums missing or not
 * that tile's queues the tile again (and the whole range 0..k1-1, marked
 * `whole`, when its running sums are what is missing), up to
 * CLUSTER_PASS_REDO times a tile count per job.  The sums keys expire
 * after a week in any case, so a stale writer never leaks one.
 */
#include "cluster/cluster_private.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define CLUSTER_SUMS_KEEP "604800" /* s: a pass's sums outlive any pass */
#define CLUSTER_PASS_REDO 3        /* times a job's tile count it may render again */
#define CLUSTER_PASSES_KEEP_S "4"  /* PASSES_KEEP, for the scripts */
_Static_assert(PASSES_KEEP == 4, "CLUSTER_PASSES_KEEP_S is PASSES_KEEP");

void cluster_passes_range(const int *samples, long k, bool whole, int *k0, int *k1) {
    int prev = k > 1 ? samples[k - 2] : 0;
    *k1 = samples[k - 1];
    *k0 = whole || prev <= 1 ? 0 : prev; /* after the centre image: from sample 0 again */
}

size_t cluster_passes_bytes(long w, long h, long tile) {
    /* the pass's image, its PNG and the previous pass's, decoded and as
     * read; a tile's new and running sums as read, decoded, added and
     * encoded, and its image */
    size_t px = (size_t)w * (size_t)h, tpx = (size_t)tile * (size_t)tile;
    return px * 12 + tpx * (24 * 6 + 3) + 8192;
}

/* ---- a tile of a pass --------------------------------------------------------- */

static const char cluster_lua_pass_tile[] =
    "local id, K, t, n = ARGV[1], ARGV[2], ARGV[3], tonumber(ARGV[5])\n"
    "local p = 'rayd:{' .. id .. '}:'\n"
    "local j = redis.call('HMGET', p .. 'job', 'state', 'pass', 'started', 'time_budget', "
    "'passes_done')\n"
    "if not j[1] then return -2 end\n"
    "if (j[1] ~= 'queued' and j[1] ~= 'running') or j[2] ~= K then return -1 end\n"
    "local now = tonumber(ARGV[6])\n"
    "if j[1] == 'queued' then\n"
    "  redis.call('HSET', p .. 'job', 'state', 'running', 'started', ARGV[6])\n"
    "  redis.call('XADD', p .. 'events', 'MAXLEN', '~', 1000, '*', 'kind', 'state', 'state', "
    "'running')\n"
    "  j[3] = ARGV[6]\n"
    "end\n"
    "redis.call('SET', p .. 'sums:' .. K .. ':' .. t, ARGV[4], 'EX', " CLUSTER_SUMS_KEEP ")\n"
    "local added = redis.call('SADD', p .. 'pdone:' .. K, t)\n"
    "local c = redis.call('SCARD', p .. 'pdone:' .. K)\n"
    "if added == 1 then\n"
    "  redis.call('HSET', p .. 'job', 'tiles_done', c)\n"
    "  redis.call('HINCRBY', p .. 'job', 'rays', ARGV[7])\n"
    "  redis.call('HINCRBYFLOAT', p .. 'job', 'render_ms', ARGV[8])\n"
    "end\n"
    "local budget = tonumber(j[4]) or 0\n"
    "local started = tonumber(j[3]) or now\n"
    "if c < n and budget > 0 and (tonumber(j[5]) or 0) > 0 and now - started >= budget * 1000 "
    "then\n"
    "  redis.call('HSET', p .. 'job', 'stopped', 'time_budget')\n"
    "  return rayd_end(id, 'succeeded', ARGV[6], ARGV[9], '') + 10\n"
    "end\n"
    "if added == 1 and c == n then\n"
    "  redis.call('XADD', redis.call('HGET', p .. 'job', 'items'), '*', 'job', id, 'frame', 0, "
    "'tile', -1, 'pass', K)\n"
    "end\n"
    "return c\n";

bool cluster_passes_tile_store(struct redis *c, const struct cluster_tile *t, long pass) {
    char sk[24], st[24], sn[24], now[32], sr[32], sm[32], ttl[24];
    snprintf(sk, sizeof sk, "%ld", pass);
    snprintf(st, sizeof st, "%ld", t->tile);
    snprintf(sn, sizeof sn, "%ld", t->ntiles);
    snprintf(now, sizeof now, "%.0f", cluster_now_ms());
    snprintf(sr, sizeof sr, "%llu", (unsigned long long)t->rays);
    snprintf(sm, sizeof sm, "%.3f", t->render_ms);
    snprintf(ttl, sizeof ttl, "%ld", config.job_ttl);
    const char *test = cluster_test_tile(), *data = t->png->data;
    size_t len = t->png->len;
    if (test) /* "missing" keeps it as nothing at all, "corrupt" as bytes that are no sums */
        data = strcmp(test, "missing") ? "these are not sums" : "", len = strlen(data);
    const char *args[] = {t->id, sk, st, data, sn, now, sr, sm, ttl};
    size_t lens[9];
    for (int i = 0; i < 9; i++) lens[i] = i == 3 ? len : strlen(args[i]);
    redisReply *rep = cluster_jobs_eval(c, cluster_lua_pass_tile, 9, args, lens);
    bool ok = !redis_failed(c, rep);
    if (ok && redis_ll(rep, 0) >= 10) log_info("cluster: job %s stopped by its time budget", t->id);
    if (rep) freeReplyObject(rep);
    return ok;
}

/* A tile of pass K failed (ARGV[3] '1': over a limit, --max-work): the job
 * ends with its latest pass when it has one, as one node keeps it
 * (stopped_by max_work), else fails (ARGV[4], the error); a tile of a pass
 * that is over changes nothing. */
static const char cluster_lua_pass_failed[] =
    "local id = ARGV[1]\n"
    "local p = 'rayd:{' .. id .. '}:'\n"
    "local j = redis.call('HMGET', p .. 'job', 'state', 'pass', 'passes_done')\n"
    "if not j[1] then return -2 end\n"
    "if (j[1] ~= 'queued' and j[1] ~= 'running') or j[2] ~= ARGV[2] then return -1 end\n"
    "if ARGV[3] == '1' and (tonumber(j[3]) or 0) > 0 then\n"
    "  redis.call('HSET', p .. 'job', 'stopped', 'max_work')\n"
    "  return rayd_end(id, 'succeeded', ARGV[5], ARGV[6], '')\n"
    "end\n"
    "return rayd_end(id, 'failed', ARGV[5], ARGV[6], ARGV[4])\n";

bool cluster_passes_failed(struct redis *c, const char *id, long pass, bool limit,
                           const char *error) {
    char sk[24], now[32], ttl[24];
    snprintf(sk, sizeof sk, "%ld", pass);
    snprintf(now, sizeof now, "%.0f", cluster_now_ms());
    snprintf(ttl, sizeof ttl, "%ld", config.job_ttl);
    const char *args[] = {id, sk, limit ? "1" : "0", error, now, ttl};
    redisReply *rep = cluster_jobs_eval(c, cluster_lua_pass_failed, 6, args, NULL);
    bool ok = !redis_failed(c, rep);
    if (rep) freeReplyObject(rep);
    return ok;
}

/* ---- a pass's assembly ------------------------------------------------------- */

/* What an assembly reads of its job. */
struct pass_job {
    struct cluster_geom g;
    int samples[PASSES_MAX], n;
    long pass, done; /* the pass being rendered, the passes complete */
    double started, budget, target;
};

static double pass_num(const redisReply *v) {
    return v->type == REDIS_REPLY_STRING ? strtod(v->str, NULL) : 0;
}

static bool pass_job_read(struct redis *c, const char *id, struct pass_job *j) {
    char key[120];
    memset(j, 0, sizeof *j);
    if (!cluster_geom_read(c, id, &j->g)) return false;
    if (!j->g.state[0]) return true;
    cluster_key(key, sizeof key, id, "job");
    const char *argv[] = {"HMGET",   key,           "plan",         "pass", "passes_done",
                          "started", "time_budget", "noise_target", NULL};
    redisReply *rep = redis_strs(c, argv);
    if (redis_failed(c, rep) || rep->type != REDIS_REPLY_ARRAY || rep->elements != 6) {
        if (rep) freeReplyObject(rep);
        return false;
    }
    redisReply **e = rep->element;
    j->n = e[0]->type == REDIS_REPLY_STRING ? cluster_jobs_plan(e[0]->str, j->samples) : -1;
    j->pass = (long)redis_ll(e[1], 0);
    j->done = (long)redis_ll(e[2], 0);
    j->started = pass_num(e[3]);
    j->budget = pass_num(e[4]);
    j->target = pass_num(e[5]);
    freeReplyObject(rep);
    if (j->n < 1 || j->pass < 1 || j->pass > j->n) j->g.state[0] = 0; /* not ours: gone */
    return true;
}

/* A tile's checked sums: its header says region r and samples k0..k1-1 (k0
 * < 0: any start); NULL when they are not. */
static double *pass_sums(const redisReply *v, const struct rayd_region *r, int k0, int k1,
                         int *from) {
    struct rayd_sums_header h;
    struct rayd_error err;
    double *sums = NULL;
    if (v->type != REDIS_REPLY_STRING ||
        rayd_sums_decode(v->str, v->len, &h, &sums, &err) != RAYD_OK)
        return NULL;
    if (h.width != r->w || h.height != r->h || h.k1 != k1 || (k0 >= 0 && h.k0 != k0) ||
        (h.k0 != 0 && h.k0 != *from)) {
        rayd_free(sums);
        return NULL;
    }
    *from = h.k0;
    return sums;
}

enum pass_tile { PT_OK, PT_BAD, PT_WHOLE, PT_DOWN };

/* Tile t's running sums after pass K kept, while the job is at pass K: an
 * assembly that outlived its pass (the job stopped, cancelled, or the pass
 * assembled by a node that took it over) writes nothing rayd_end would not
 * delete. */
static const char cluster_lua_pass_run[] =
    "local p = 'rayd:{' .. ARGV[1] .. '}:'\n"
    "local j = redis.call('HMGET', p .. 'job', 'state', 'pass')\n"
    "if (j[1] ~= 'queued' and j[1] ~= 'running') or j[2] ~= ARGV[2] then return 0 end\n"
    "redis.call('SET', p .. 'run:' .. ARGV[2] .. ':' .. ARGV[3], ARGV[4], 'EX', " CLUSTER_SUMS_KEEP
    ")\n"
    "return 1\n";

static bool pass_run_store(struct redis *c, const char *id, long k, long t, const void *buf,
                           size_t len) {
    char sk[24], st[24];
    snprintf(sk, sizeof sk, "%ld", k);
    snprintf(st, sizeof st, "%ld", t);
    const char *argv[] = {"EVAL", cluster_lua_pass_run, "0", id, sk, st, buf};
    size_t lens[7];
    for (int i = 0; i < 7; i++) lens[i] = i == 6 ? len : strlen(argv[i]);
    redisReply *rep = redis_argv(c, 7, argv, lens);
    bool ok = !redis_failed(c, rep);
    if (rep) freeReplyObject(rep);
    return ok;
}

/* Tile t of pass k: its new sums added to its running sums, kept as the
 * next pass's running sums (keep), resolved into img. */
static enum pass_tile pass_tile(struct redis *c, const char *id, const struct pass_job *j, long k,
                                long t, bool keep, rayd_image *img) {
    struct rayd_region r = cluster_tile_reg(&j->g, t);
    char keys[2][120], what[60];
    int k0, k1;
    cluster_passes_range(j->samples, k, false, &k0, &k1);
    snprintf(what, sizeof what, "sums:%ld:%ld", k, t);
    cluster_key(keys[0], sizeof keys[0], id, what);
    snprintf(what, sizeof what, "run:%ld:%ld", k - 1, t);
    cluster_key(keys[1], sizeof keys[1], id, what);
    const char *argv[] = {"MGET", keys[0], keys[1], NULL};
    redisReply *rep = redis_strs(c, argv);
    if (redis_failed(c, rep) || rep->type != REDIS_REPLY_ARRAY || rep->elements != 2) {
        if (rep) freeReplyObject(rep);
        return PT_DOWN;
    }
    int from = k0;
    double *add = pass_sums(rep->element[0], &r, -1, k1, &from), *run = NULL;
    enum pass_tile out = add ? PT_OK : PT_BAD;
    int start = 0;
    if (add && from > 0 && !(run = pass_sums(rep->element[1], &r, 0, from, &start)))
        out = PT_WHOLE; /* the running sums are gone: the tile renders 0..k1-1 */
    freeReplyObject(rep);
    rayd_accum *acc = NULL;
    rayd_image *tile = NULL;
    void *buf = NULL;
    size_t len = 0;
    struct rayd_error err;
    if (out == PT_OK && (rayd_accum_new_sized(r.w, r.h, &acc, &err) != RAYD_OK ||
                         (run && rayd_accum_add_sums(acc, run, from, &err) != RAYD_OK) ||
                         rayd_accum_add_sums(acc, add, k1 - from, &err) != RAYD_OK ||
                         rayd_accum_image(acc, &tile, &err) != RAYD_OK ||
                         rayd_image_blit(img, tile, r.x, r.y, &err) != RAYD_OK))
        out = PT_BAD;
    if (out == PT_OK && keep &&
        rayd_sums_encode(r.w, r.h, 0, k1, rayd_accum_sums(acc), &buf, &len, &err) == RAYD_OK) {
        if (!pass_run_store(c, id, k, t, buf, len)) out = PT_DOWN;
    } else if (out == PT_OK && keep) {
        out = PT_DOWN; /* out of memory: the item waits */
    }
    rayd_free(buf);
    rayd_image_free(tile);
    rayd_accum_free(acc);
    rayd_free(add);
    rayd_free(run);
    return out;
}

/* Tiles bad[0..nbad) of pass K out of its done set and queued again
 * (whole[i]: from sample 0); -3 when the job rendered too many again. */
static const char cluster_lua_pass_redo[] =
    "local id, K = ARGV[1], ARGV[2]\n"
    "local p = 'rayd:{' .. id .. '}:'\n"
    "local j = redis.call('HMGET', p .. 'job', 'state', 'pass', 'items')\n"
    "if (j[1] ~= 'queued' and j[1] ~= 'running') or j[2] ~= K then return -1 end\n"
    "local r = redis.call('HINCRBY', p .. 'job', 'rerenders', (#ARGV - 3) / 2)\n"
    "if r > tonumber(ARGV[3]) then return -3 end\n"
    "for i = 4, #ARGV, 2 do\n"
    "  redis.call('SREM', p .. 'pdone:' .. K, ARGV[i])\n"
    "  redis.call('XADD', j[3], '*', 'job', id, 'frame', 0, 'tile', ARGV[i], 'pass', K, "
    "'whole', ARGV[i + 1])\n"
    "end\n"
    "redis.call('HSET', p .. 'job', 'tiles_done', redis.call('SCARD', p .. 'pdone:' .. K))\n"
    "return 1\n";

static bool pass_redo(struct redis *c, const char *id, long k, const struct pass_job *j,
                      const long *bad, const bool *whole, long nbad) {
    char sk[24], lim[24], *nums = calloc((size_t)nbad, 24);
    const char **argv = calloc(2 * (size_t)nbad + 8, sizeof *argv);
    bool ok = false;
    if (nums && argv) {
        snprintf(sk, sizeof sk, "%ld", k);
        snprintf(lim, sizeof lim, "%ld", CLUSTER_PASS_REDO * j->g.tiles);
        int n = 0;
        argv[n++] = "EVAL", argv[n++] = cluster_lua_pass_redo, argv[n++] = "0";
        argv[n++] = id, argv[n++] = sk, argv[n++] = lim;
        for (long i = 0; i < nbad; i++) {
            snprintf(nums + 24 * i, 24, "%ld", bad[i]);
            argv[n++] = nums + 24 * i;
            argv[n++] = whole[i] ? "1" : "0";
        }
        redisReply *rep = redis_argv(c, n, argv, NULL);
        ok = !redis_failed(c, rep);
        long long rc = ok ? redis_ll(rep, 0) : 0;
        if (rep) freeReplyObject(rep);
        char why[300];
        snprintf(why, sizeof why,
                 "{\"code\":\"internal\",\"message\":\"pass %ld: the sums of tile %ld were "
                 "missing or corrupt in Redis %d times over\"}",
                 k, bad[0], CLUSTER_PASS_REDO);
        if (ok && rc == -3) ok = cluster_jobs_end(c, id, "failed", why);
        long lost = 0;
        for (long i = 0; i < nbad; i++) lost += whole[i];
        if (ok && rc == 1)
            log_warn("cluster: job %s pass %ld: %ld tile(s)' sums missing or corrupt in Redis "
                     "(first: %ld), rendered again; %ld of them lost their running sums: all "
                     "their samples",
                     id, k, nbad, bad[0], lost);
    }
    free(nums);
    free(argv);
    return ok;
}

/* The pass's end: its PNG and numbers kept, its event, the sums it used
 * deleted; then the next pass's items, or the job's end (ARGV[9]: why it
 * stops early, "" when it may go on). */
static const char cluster_lua_pass_end[] =
    "local id, K = ARGV[1], tonumber(ARGV[2])\n"
    "local p = 'rayd:{' .. id .. '}:'\n"
    "local j = redis.call('HMGET', p .. 'job', 'state', 'pass', 'passes', 'tiles', 'items', "
    "'stop_asked')\n"
    "if (j[1] ~= 'queued' and j[1] ~= 'running') or tonumber(j[2]) ~= K then return -1 end\n"
    "local n, tiles = tonumber(j[3]), tonumber(j[4])\n"
    "redis.call('SET', p .. 'pass:' .. K, ARGV[3])\n"
    "if K > " CLUSTER_PASSES_KEEP_S " then redis.call('DEL', p .. 'pass:' .. (K - "
    "" CLUSTER_PASSES_KEEP_S ")) end\n"
    "redis.call('HSET', p .. 'job', 'passes_done', K, 'pass_samples', ARGV[4], 'pass_time', "
    "ARGV[5], 'noise', ARGV[6], 'encode_ms', ARGV[7])\n"
    "redis.call('XADD', p .. 'events', 'MAXLEN', '~', 1000, '*', 'kind', 'pass', 'done', K, "
    "'total', n, 'samples', ARGV[4], 'time_s', ARGV[5], 'noise', ARGV[6], 'progress', ARGV[8])\n"
    "for t = 0, tiles - 1 do\n"
    "  redis.call('DEL', p .. 'sums:' .. K .. ':' .. t, p .. 'run:' .. (K - 1) .. ':' .. t)\n"
    "end\n"
    "redis.call('DEL', p .. 'pdone:' .. K)\n"
    "local why = ARGV[9]\n"
    "if j[6] == '1' then why = 'client' end\n"
    "if why ~= '' or K >= n then\n"
    "  if why ~= '' and (K < n or why == 'client') then\n"
    "    redis.call('HSET', p .. 'job', 'stopped', why)\n"
    "  end\n"
    "  return rayd_end(id, 'succeeded', ARGV[10], ARGV[11], '') + 10\n"
    "end\n"
    "redis.call('HSET', p .. 'job', 'pass', K + 1, 'tiles_done', 0)\n"
    "for t = 0, tiles - 1 do\n"
    "  redis.call('XADD', j[5], '*', 'job', id, 'frame', 0, 'tile', t, 'pass', K + 1)\n"
    "end\n"
    "return 0\n";

/* Why the job stops after pass k (time_s after its first tile, noise its
 * estimate), or "" when it may go on (the client's stop is the script's). */
static const char *pass_stop(const struct pass_job *j, double time_s, double noise) {
    if (j->budget > 0 && time_s >= j->budget) return "time_budget";
    if (j->target > 0 && noise >= 0 && noise <= j->target) return "noise_target";
    return "";
}

/* Pass k's noise estimate from its image and the previous pass's PNG (< 0:
 * none: the first pass, or that PNG gone). */
static double pass_noise(struct redis *c, const char *id, const struct pass_job *j, long k,
                         const rayd_image *img) {
    if (k < 2) return -1;
    char key[120], what[40];
    snprintf(what, sizeof what, "pass:%ld", k - 1);
    cluster_key(key, sizeof key, id, what);
    const char *argv[] = {"GET", key, NULL};
    redisReply *rep = redis_strs(c, argv);
    rayd_image *prev = NULL;
    struct rayd_error err;
    double noise = -1;
    if (rep && rep->type == REDIS_REPLY_STRING &&
        rayd_png_decode(rep->str, rep->len, (long)j->g.w * j->g.h, &prev, &err) == RAYD_OK &&
        rayd_image_width(prev) == j->g.w && rayd_image_height(prev) == j->g.h)
        noise = passes_noise_of(img, prev, j->samples[k - 1], j->samples[k - 2]);
    if (rep) freeReplyObject(rep);
    rayd_image_free(prev);
    return noise;
}

/* Pass k's image encoded and its end stored; false: left to try again. */
static bool pass_end(struct redis *c, const char *id, const struct pass_job *j, long k,
                     const rayd_image *img) {
    void *png = NULL;
    size_t len = 0;
    struct rayd_error err;
    double t0 = clock_now();
    if (rayd_png_encode(img, (int)config.png_level, &png, &len, &err) != RAYD_OK) {
        log_error("cluster: job %s pass %ld: cannot encode: %s", id, k, err.message);
        return false;
    }
    double now = cluster_now_ms(), time_s = (now - j->started) / 1e3;
    double noise = pass_noise(c, id, j, k, img);
    char sk[24], ss[24], st[32], sn[32], se[32], sp[32], snow[32], ttl[24];
    snprintf(sk, sizeof sk, "%ld", k);
    snprintf(ss, sizeof ss, "%d", j->samples[k - 1]);
    snprintf(st, sizeof st, "%.3f", time_s > 0 ? time_s : 0);
    snprintf(sn, sizeof sn, "%.6f", noise);
    snprintf(se, sizeof se, "%.3f", (clock_now() - t0) * 1e3);
    snprintf(sp, sizeof sp, "%.6f", passes_share(j->samples, j->n, (int)k, 0));
    snprintf(snow, sizeof snow, "%.0f", now);
    snprintf(ttl, sizeof ttl, "%ld", config.job_ttl);
    const char *args[] = {id, sk, png, ss, st, sn, se, sp, pass_stop(j, time_s, noise), snow, ttl};
    size_t lens[11];
    for (int i = 0; i < 11; i++) lens[i] = i == 2 ? len : strlen(args[i]);
    redisReply *rep = cluster_jobs_eval(c, cluster_lua_pass_end, 11, args, lens);
    bool ok = !redis_failed(c, rep);
    if (ok && redis_ll(rep, 0) >= 10) log_info("cluster: job %s succeeded (pass %ld)", id, k);
    if (rep) freeReplyObject(rep);
    rayd_free(png);
    return ok;
}

/* Every tile of pass k into img (the bad ones' numbers into bad); false
 * when Redis failed. */
static bool pass_tiles(struct redis *c, const char *id, const struct pass_job *j, long k,
                       rayd_image *img, long *bad, bool *whole, long *nbad) {
    for (long t = 0; t < j->g.tiles; t++) {
        /* the next pass adds to these sums, unless it starts again after the centre image */
        bool keep = k < j->n && j->samples[k - 1] > 1;
        enum pass_tile pt = pass_tile(c, id, j, k, t, keep, img);
        if (pt == PT_DOWN) return false;
        if (pt != PT_OK) whole[*nbad] = pt == PT_WHOLE, bad[(*nbad)++] = t;
    }
    return true;
}

bool cluster_passes_assemble(struct redis *c, const char *id, long k) {
    struct pass_job j;
    if (!pass_job_read(c, id, &j)) return false;
    if ((strcmp(j.g.state, "queued") && strcmp(j.g.state, "running")) || j.pass != k)
        return true; /* ended, or a duplicate of a pass assembled already: dropped */
    size_t need = cluster_passes_bytes(j.g.w, j.g.h, j.g.size);
    if (cluster_assemble_never(c, id, 0, need)) return true;  /* failed: the item is done */
    if (!cluster_assemble_reserve(id, 0, need)) return false; /* the item stays pending */
    rayd_image *img = NULL;
    long *bad = calloc((size_t)j.g.tiles, sizeof *bad), nbad = 0;
    bool *whole = calloc((size_t)j.g.tiles, sizeof *whole), ok = false;
    struct rayd_error err;
    if (bad && whole && rayd_image_new(j.g.w, j.g.h, &img, &err) == RAYD_OK &&
        pass_tiles(c, id, &j, k, img, bad, whole, &nbad))
        ok = nbad > 0 ? pass_redo(c, id, k, &j, bad, whole, nbad) : pass_end(c, id, &j, k, img);
    mem_release(MEM_RESULTS, need);
    rayd_image_free(img);
    free(bad);
    free(whole);
    return ok;
}
