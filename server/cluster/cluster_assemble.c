/* cluster_assemble.c -- tiles into Redis, frames out of them (the puller's).
 *
 * A tile rendered is kept as its PNG (rayd:{ID}:tile:K:T, the bytes POST
 * /v1/render?x=&y=&w=&h= gives), for a job that keeps an EXR (format=exr)
 * with its EXR beside it (rayd:{ID}:tile:K:T:exr, what ?format=exr gives
 * for the tile), and its number added to the frame's done
 * set, in one script with the job's counters and its event, so a tile is
 * either counted and kept or neither.  The node whose tile completes the
 * set queues the frame's assembly item (tile -1) in that same script, on
 * the high stream whatever the job's priority: a short item, taken before
 * the tiles of the job's later frames, so a frame range's frames come one
 * by one rather than all at its end (and the frame that completes a frame
 * range queues its video's, cluster_video.c): a
 * node that dies right after leaves a complete set and its assembly
 * queued, and a duplicate of a tile (an item reclaimed from a stalled node
 * that finished after all) finds its number in the set and queues nothing.
 *
 * Assembling decodes every tile (rayd_png_decode), pastes it into the
 * frame and encodes the frame with the node's --png-level: the PNG bytes of
 * one node's render of the same region, since a pixel's value does not
 * depend on the tile it was drawn in nor the PNG's on who encodes it.  The
 * EXR likewise: the tiles' floats decoded (lossless either way, so bit
 * for bit), pasted, and the frame encoded as one node encodes it.  A tile
 * missing from Redis (evicted, deleted) or not a PNG (or EXR) of its size
 * (corrupt) is taken out of the done set and queued again, so the frame
 * re-renders what it lacks; past CLUSTER_RERENDERS a frame's tiles the job
 * fails, naming the tile, rather than loop.
 *
 * An assembly holds the decoded frame, one decoded tile and the frame's
 * PNG, and the EXR's floats and file when it makes one
 * (cluster_assemble_bytes), so it is charged to the node's one memory
 * budget (--max-memory) as a render's pixels are: reserved before the
 * tiles are read, released once the frame is stored.  When the budget has
 * no room the job does not fail: the item is left unacknowledged and is
 * taken over after --redis-claim-ms by a node with room (this one too,
 * later), and rayd_cluster_assemblies_deferred_total counts it.  A frame
 * whose assembly alone is over a node's whole budget is refused at POST
 * (413 over_memory, as one node refuses such a render), so some node --
 * one with that budget at least -- can always assemble it.
 */
#include "cluster/cluster_private.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define CLUSTER_RERENDERS 3 /* times a frame's tile count it may re-render */

/* Floats a pixel of the EXR of a job of AOVs aov: RGB, and the AOVs. */
static size_t cluster_exr_floats(unsigned aov) { return 3 + (aov ? RAYD_AOV_FLOATS : 0); }

size_t cluster_assemble_bytes(long w, long h, long tile, bool exr, unsigned aov) {
    /* the frame's pixels and its PNG (at worst as large), as a render of
     * it reserves, and one tile decoded; with the EXR, its floats three
     * times (the frame's, the tiles' files and the frame's, at worst as
     * large) and a tile's */
    size_t px = (size_t)w * (size_t)h, tpx = (size_t)tile * (size_t)tile;
    size_t fl = exr ? cluster_exr_floats(aov) * sizeof(float) : 0;
    return px * (6 + 3 * fl) + tpx * (3 + fl) + 4096 + (exr ? 65536 : 0);
}

static const char cluster_lua_tile[] =
    "local id, k, t, n = ARGV[1], ARGV[2], ARGV[3], tonumber(ARGV[5])\n"
    "local p = 'rayd:{' .. id .. '}:'\n"
    "local st = redis.call('HGET', p .. 'job', 'state')\n"
    "if not st then return -2 end\n"
    "if st ~= 'queued' and st ~= 'running' then return -1 end\n"
    "if st == 'queued' then\n"
    "  redis.call('HSET', p .. 'job', 'state', 'running', 'started', ARGV[6])\n"
    "  redis.call('XADD', p .. 'events', 'MAXLEN', '~', 1000, '*', 'kind', 'state', 'state', "
    "'running')\n"
    "end\n"
    "if ARGV[10] ~= 'skip' then redis.call('SET', p .. 'tile:' .. k .. ':' .. t, ARGV[4]) end\n"
    "if ARGV[10] ~= 'skip' and ARGV[12] ~= '' then redis.call('SET', p .. 'tile:' .. k .. ':' .. t "
    ".. ':exr', ARGV[12]) "
    "end\n"
    "local added = redis.call('SADD', p .. 'done:' .. k, t)\n"
    "if added == 1 then\n"
    "  local d = redis.call('HINCRBY', p .. 'job', 'tiles_done', 1)\n"
    "  redis.call('HINCRBY', p .. 'job', 'rays', ARGV[7])\n"
    "  redis.call('HINCRBYFLOAT', p .. 'job', 'render_ms', ARGV[8])\n"
    "  local f = redis.call('HMGET', p .. 'job', 'first', 'last')\n"
    "  local total = (tonumber(f[2]) - tonumber(f[1]) + 1) * n\n"
    "  redis.call('XADD', p .. 'events', 'MAXLEN', '~', 1000, '*', 'kind', 'tile', 'frame', k, "
    "'tile', t, 'done', d, 'total', total, 'where', ARGV[11])\n"
    "end\n"
    "local c = redis.call('SCARD', p .. 'done:' .. k)\n"
    "if added == 1 and c == n then\n"
    "  redis.call('XADD', ARGV[9], '*', 'job', id, 'frame', k, 'tile', -1)\n"
    "end\n"
    "return c\n";

/* The test knob of the hostile cases: with --test-gate and
 * RAYD_TEST_CLUSTER_TILE=corrupt (or missing) the first tile this node
 * stores is kept as bytes that are not a PNG (or not kept at all, though
 * counted done), so a test sees the frame re-render it. */
const char *cluster_test_tile(void) {
    static atomic_bool used;
    const char *v = getenv("RAYD_TEST_CLUSTER_TILE");
    if (config.test_gate_tiles < -1 || !v || atomic_exchange(&used, true)) return NULL;
    log_warn("RAYD_TEST_CLUSTER_TILE=%s: this tile is stored %s", v,
             strcmp(v, "missing") ? "corrupt" : "not at all");
    return v;
}

bool cluster_tile_store(struct redis *c, const struct cluster_tile *t) {
    char sk[24], st[24], sn[24], now[32], sr[32], sm[32], where[64];
    snprintf(where, sizeof where, "%d %d %d %d", t->reg.x, t->reg.y, t->reg.w, t->reg.h);
    snprintf(sk, sizeof sk, "%ld", t->k);
    snprintf(st, sizeof st, "%ld", t->tile);
    snprintf(sn, sizeof sn, "%ld", t->ntiles);
    snprintf(now, sizeof now, "%.0f", cluster_now_ms());
    snprintf(sr, sizeof sr, "%llu", (unsigned long long)t->rays);
    snprintf(sm, sizeof sm, "%.3f", t->render_ms);
    const char *test = cluster_test_tile();
    const char *data = t->png->data, *exr = t->exr ? t->exr->data : "";
    size_t len = t->png->len, exr_len = t->exr ? t->exr->len : 0;
    if (test && strcmp(test, "missing")) {
        data = "this is not a PNG";
        len = strlen(data);
        if (t->exr) exr = "nor an EXR", exr_len = strlen(exr);
    }
    const char *argv[] = {"EVAL", cluster_lua_tile, "0", t->id, sk, st, data, sn, now, sr, sm,
                          /* the assembly: first in line, not behind every tile queued */
                          cluster_items_stream(JP_HIGH),
                          test && !strcmp(test, "missing") ? "skip" : "keep", where, exr};
    size_t lens[15];
    for (int i = 0; i < 15; i++) lens[i] = i == 6 ? len : i == 14 ? exr_len : strlen(argv[i]);
    redisReply *rep = redis_argv(c, 15, argv, lens);
    bool ok = !redis_failed(c, rep);
    if (rep) freeReplyObject(rep);
    return ok;
}

/* ---- assembly --------------------------------------------------------------- */

static const char cluster_lua_frame[] =
    "local id, k = ARGV[1], ARGV[2]\n"
    "local p = 'rayd:{' .. id .. '}:'\n"
    "local st = redis.call('HGET', p .. 'job', 'state')\n"
    "if not st then return -2 end\n"
    "if st ~= 'queued' and st ~= 'running' then return -1 end\n"
    "redis.call('SET', p .. 'frame:' .. k, ARGV[3])\n"
    "if ARGV[7] ~= '' then redis.call('SET', p .. 'frame:' .. k .. ':exr', ARGV[7]) end\n"
    "local added = redis.call('SADD', p .. 'frames', k)\n"
    "local n = redis.call('SCARD', p .. 'frames')\n"
    "local f = redis.call('HMGET', p .. 'job', 'first', 'last', 'tiles')\n"
    "local total = tonumber(f[2]) - tonumber(f[1]) + 1\n"
    "redis.call('HSET', p .. 'job', 'frames_done', n)\n"
    "if added == 1 then\n"
    "  redis.call('HSET', p .. 'job', 'latest', k)\n"
    "  redis.call('HINCRBYFLOAT', p .. 'job', 'encode_ms', ARGV[6])\n"
    "  redis.call('XADD', p .. 'events', 'MAXLEN', '~', 1000, '*', 'kind', 'frame', 'frame', k, "
    "'done', n, 'total', total)\n"
    "end\n"
    "for t = 0, tonumber(f[3]) - 1 do\n"
    "  redis.call('DEL', p .. 'tile:' .. k .. ':' .. t, p .. 'tile:' .. k .. ':' .. t .. ':exr')\n"
    "end\n"
    "if n == total and redis.call('HGET', p .. 'job', 'animated') == '1' then\n"
    "  redis.call('HSET', p .. 'job', 'video', 'making')\n"
    "  redis.call('XADD', redis.call('HGET', p .. 'job', 'items') or ARGV[8], '*', 'job', id, "
    "'frame', f[1], 'tile', -2)\n"
    "end\n"
    "if n == total then return rayd_end(id, 'succeeded', ARGV[4], ARGV[5], '') + 10 end\n"
    "return 0\n";

/* Tiles bad[0..nbad) of frame k out of the done set and queued again (a
 * job that re-rendered too many fails instead). */
static const char cluster_lua_redo[] =
    "local id, k = ARGV[1], ARGV[2]\n"
    "local p = 'rayd:{' .. id .. '}:'\n"
    "local st = redis.call('HGET', p .. 'job', 'state')\n"
    "if st ~= 'queued' and st ~= 'running' then return -1 end\n"
    "local r = redis.call('HINCRBY', p .. 'job', 'rerenders', #ARGV - 3)\n"
    "if r > tonumber(ARGV[3]) then return -3 end\n"
    "for i = 4, #ARGV do\n"
    "  if redis.call('SREM', p .. 'done:' .. k, ARGV[i]) == 1 then\n"
    "    redis.call('HINCRBY', p .. 'job', 'tiles_done', -1)\n"
    "  end\n"
    "  redis.call('XADD', redis.call('HGET', p .. 'job', 'items') or KEYS[1], '*', 'job', id, "
    "'frame', k, 'tile', ARGV[i])\n"
    "end\n"
    "return 1\n";

bool cluster_geom_read(struct redis *c, const char *id, struct cluster_geom *g) {
    char key[120];
    memset(g, 0, sizeof *g);
    cluster_key(key, sizeof key, id, "job");
    const char *argv[] = {"HMGET", key,    "state",     "x",   "y",   "w", "h",
                          "tiles", "cols", "tile_size", "exr", "aov", NULL};
    redisReply *rep = redis_strs(c, argv);
    if (redis_failed(c, rep) || rep->type != REDIS_REPLY_ARRAY || rep->elements != 10) {
        bool down = !rep || rep->type == REDIS_REPLY_ERROR;
        if (rep) freeReplyObject(rep);
        if (down) return false;
        g->state[0] = 0;
        return true;
    }
    if (rep->element[0]->type == REDIS_REPLY_STRING)
        snprintf(g->state, sizeof g->state, "%s", rep->element[0]->str);
    long v[9];
    for (int i = 0; i < 9; i++) v[i] = (long)redis_ll(rep->element[i + 1], 0);
    freeReplyObject(rep);
    g->x = (int)v[0], g->y = (int)v[1], g->w = (int)v[2], g->h = (int)v[3];
    g->tiles = v[4], g->cols = v[5], g->size = v[6];
    g->exr = v[7] == 1;
    g->aov = (unsigned)v[8] & RAYD_AOV_ALL;
    if (g->w <= 0 || g->h <= 0 || g->tiles <= 0 || g->cols <= 0 || g->size <= 0)
        g->state[0] = 0; /* not a job of ours: treated as gone */
    return true;
}

struct rayd_region cluster_tile_reg(const struct cluster_geom *g, long t) {
    int tx = (int)((t % g->cols) * g->size), ty = (int)((t / g->cols) * g->size);
    int w = g->w - tx < g->size ? g->w - tx : (int)g->size;
    int h = g->h - ty < g->size ? g->h - ty : (int)g->size;
    return (struct rayd_region){tx, ty, w, h};
}

/* A frame being assembled: its PNG's pixels and, for a job that keeps an
 * EXR, its floats (RGB and AOVs, laid out as rayd_exr_encode_aov reads
 * them) and one tile's, reused tile after tile. */
struct cluster_frame {
    rayd_image *img;
    float *rgb, *aov, *tile_rgb, *tile_aov; /* NULL without the EXR (aov: without AOVs) */
};

static void cluster_frame_free(struct cluster_frame *f) {
    rayd_image_free(f->img);
    free(f->rgb);
    free(f->aov);
    free(f->tile_rgb);
    free(f->tile_aov);
}

static bool cluster_frame_new(const struct cluster_geom *g, struct cluster_frame *f) {
    memset(f, 0, sizeof *f);
    struct rayd_error err;
    if (rayd_image_new(g->w, g->h, &f->img, &err) != RAYD_OK) return false;
    if (!g->exr) return true;
    size_t px = (size_t)g->w * (size_t)g->h, tpx = (size_t)g->size * (size_t)g->size;
    f->rgb = malloc(px * 3 * sizeof *f->rgb);
    f->tile_rgb = malloc(tpx * 3 * sizeof *f->tile_rgb);
    if (g->aov) {
        f->aov = malloc(px * RAYD_AOV_FLOATS * sizeof *f->aov);
        f->tile_aov = malloc(tpx * RAYD_AOV_FLOATS * sizeof *f->tile_aov);
    }
    return f->rgb && f->tile_rgb && (!g->aov || (f->aov && f->tile_aov));
}

/* Rows of n floats a pixel of a tile at r into a frame w pixels wide. */
static void cluster_rows(float *dst, const float *src, const struct rayd_region *r, int w,
                         size_t n) {
    for (int y = 0; y < r->h; y++)
        memcpy(dst + ((size_t)(r->y + y) * (size_t)w + (size_t)r->x) * n,
               src + (size_t)y * (size_t)r->w * n, (size_t)r->w * n * sizeof *src);
}

/* One tile's EXR (e) into f's floats; false when it is not that tile's. */
static bool cluster_paste_exr(const struct cluster_geom *g, const redisReply *e,
                              const struct rayd_region *r, struct cluster_frame *f) {
    struct rayd_error err;
    if (e->type != REDIS_REPLY_STRING ||
        rayd_exr_decode_aov(e->str, e->len, g->aov, r->w, r->h, f->tile_rgb, f->tile_aov, &err) !=
            RAYD_OK)
        return false;
    cluster_rows(f->rgb, f->tile_rgb, r, g->w, 3);
    if (g->aov) cluster_rows(f->aov, f->tile_aov, r, g->w, RAYD_AOV_FLOATS);
    return true;
}

/* One tile's PNG (e) into f's image; false when it is not that tile's. */
static bool cluster_paste_png(const redisReply *e, const struct rayd_region *r,
                              struct cluster_frame *f) {
    rayd_image *tile = NULL;
    struct rayd_error err;
    bool ok = e->type == REDIS_REPLY_STRING &&
              rayd_png_decode(e->str, e->len, (long)r->w * r->h, &tile, &err) == RAYD_OK &&
              rayd_image_width(tile) == r->w && rayd_image_height(tile) == r->h &&
              rayd_image_blit(f->img, tile, r->x, r->y, &err) == RAYD_OK;
    rayd_image_free(tile);
    return ok;
}

/* Pastes the tiles of png (and exr: MGET's) into f; the bad ones' numbers
 * into bad. */
static long cluster_paste(const struct cluster_geom *g, const redisReply *png,
                          const redisReply *exr, struct cluster_frame *f, long *bad) {
    long nbad = 0;
    for (long t = 0; t < g->tiles; t++) {
        struct rayd_region r = cluster_tile_reg(g, t);
        if (!cluster_paste_png(png->element[t], &r, f) ||
            (exr && !cluster_paste_exr(g, exr->element[t], &r, f)))
            bad[nbad++] = t;
    }
    return nbad;
}

/* The bad tiles queued again; false when Redis failed. */
static bool cluster_redo(struct redis *c, const char *id, long k, const struct cluster_geom *g,
                         const long *bad, long nbad) {
    char sk[24], lim[24], *nums = calloc((size_t)nbad, 24);
    const char **argv = calloc((size_t)nbad + 8, sizeof *argv);
    if (!nums || !argv) {
        free(nums);
        free(argv);
        return false;
    }
    snprintf(sk, sizeof sk, "%ld", k);
    snprintf(lim, sizeof lim, "%ld", CLUSTER_RERENDERS * g->tiles);
    int n = 0;
    argv[n++] = "EVAL";
    argv[n++] = cluster_lua_redo;
    argv[n++] = "1";
    argv[n++] = cluster_stream;
    argv[n++] = id;
    argv[n++] = sk;
    argv[n++] = lim;
    for (long i = 0; i < nbad; i++) {
        snprintf(nums + 24 * i, 24, "%ld", bad[i]);
        argv[n++] = nums + 24 * i;
    }
    redisReply *rep = redis_argv(c, n, argv, NULL);
    bool ok = !redis_failed(c, rep);
    long long r = ok ? redis_ll(rep, 0) : 0;
    if (rep) freeReplyObject(rep);
    if (ok && r == -3) {
        char why[300];
        snprintf(why, sizeof why,
                 "{\"code\":\"internal\",\"message\":\"frame %ld: tile %ld was missing or "
                 "corrupt in Redis %d times over\"}",
                 k, bad[0], CLUSTER_RERENDERS);
        ok = cluster_jobs_end(c, id, "failed", why);
    } else if (ok) {
        log_warn("cluster: job %s frame %ld: %ld tile(s) missing or corrupt in Redis (first: "
                 "%ld), rendered again",
                 id, k, nbad, bad[0]);
    }
    free(nums);
    free(argv);
    return ok;
}

/* The frame's PNG (and EXR, exr_len 0: none) stored (the job ends with its
 * last frame). */
static bool cluster_frame_store(struct redis *c, const char *id, long k, const void *png,
                                size_t len, const void *exr, size_t exr_len, double encode_ms) {
    char sk[24], now[32], ttl[24], enc[32];
    snprintf(sk, sizeof sk, "%ld", k);
    snprintf(now, sizeof now, "%.0f", cluster_now_ms());
    snprintf(ttl, sizeof ttl, "%ld", config.job_ttl);
    snprintf(enc, sizeof enc, "%.3f", encode_ms);
    const char *args[] = {id, sk, png, now, ttl, enc, exr_len ? exr : "", cluster_stream};
    size_t lens[8];
    for (int i = 0; i < 8; i++) lens[i] = i == 2 ? len : i == 6 ? exr_len : strlen(args[i]);
    redisReply *rep = cluster_jobs_eval(c, cluster_lua_frame, 8, args, lens);
    bool ok = !redis_failed(c, rep);
    if (ok && redis_ll(rep, 0) >= 10) log_info("cluster: job %s succeeded", id);
    if (rep) freeReplyObject(rep);
    return ok;
}

/* A node whose whole --max-memory is under an assembly's need can never
 * do it; past CLUSTER_ASSEMBLY_MISSES such tries (on any nodes, counted in
 * the job's record) the job fails, rather than waiting for ever for a
 * node with a larger budget that may not exist (too_large, the code a
 * render over a limit has).  True when it ended. */
#define CLUSTER_ASSEMBLY_MISSES 20
bool cluster_assemble_never(struct redis *c, const char *id, long k, size_t need) {
    if (need <= mem_limit()) return false;
    char key[80];
    cluster_key(key, sizeof key, id, "job");
    const char *argv[] = {"HINCRBY", key, "assembly_misses", "1", NULL};
    redisReply *rep = redis_strs(c, argv);
    long long n = redis_failed(c, rep) ? 0 : redis_ll(rep, 0);
    if (rep) freeReplyObject(rep);
    if (n < CLUSTER_ASSEMBLY_MISSES) return false;
    char why[400];
    snprintf(why, sizeof why,
             "{\"code\":\"%s\",\"message\":\"frame %ld: its assembly needs %zu bytes, more "
             "than the --max-memory of the nodes that tried it %d times; raise --max-memory or "
             "render a smaller region\"}",
             rayd_status_name(RAYD_E_LIMIT), k, need, CLUSTER_ASSEMBLY_MISSES);
    log_warn("cluster: job %s failed: %s", id, why);
    return cluster_jobs_end(c, id, "failed", why);
}

/* The assembly's bytes reserved in the memory budget; false (counted,
 * said) when there is no room. */
bool cluster_assemble_reserve(const char *id, long k, size_t need) {
    if (mem_reserve(MEM_RESULTS, need)) return true;
    atomic_fetch_add(&cluster_deferred_total, 1);
    log_warn("cluster: job %s frame %ld: its assembly needs %zu bytes and this node's memory "
             "budget (--max-memory %zu bytes) has no room now; left for a node with room (taken "
             "over after --redis-claim-ms)",
             id, k, need, mem_limit());
    return false;
}

/* The tiles of frame k of job id (their EXRs: exr) with one MGET; NULL
 * when Redis failed. */
static redisReply *cluster_tiles_get(struct redis *c, const char *id, long k,
                                     const struct cluster_geom *g, bool exr) {
    const char **argv = calloc((size_t)g->tiles + 1, sizeof *argv);
    char *keys = calloc((size_t)g->tiles, 120);
    redisReply *rep = NULL;
    if (argv && keys) {
        argv[0] = "MGET";
        for (long t = 0; t < g->tiles; t++) {
            char what[60];
            snprintf(what, sizeof what, "tile:%ld:%ld%s", k, t, exr ? ":exr" : "");
            cluster_key(keys + 120 * t, 120, id, what);
            argv[t + 1] = keys + 120 * t;
        }
        rep = redis_argv(c, (int)g->tiles + 1, argv, NULL);
    }
    free(argv);
    free(keys);
    if (rep && (redis_failed(c, rep) || rep->type != REDIS_REPLY_ARRAY ||
                rep->elements != (size_t)g->tiles)) {
        freeReplyObject(rep);
        rep = NULL;
    }
    return rep;
}

/* f encoded (its PNG, its EXR) and stored as frame k; false when that
 * failed (left to try again). */
static bool cluster_encode(struct redis *c, const char *id, long k, const struct cluster_geom *g,
                           const struct cluster_frame *f) {
    void *png = NULL, *exr = NULL;
    size_t len = 0, exr_len = 0;
    struct rayd_error err;
    double t0 = clock_now();
    enum rayd_status st = rayd_png_encode(f->img, (int)config.png_level, &png, &len, &err);
    if (st == RAYD_OK && g->exr)
        st = rayd_exr_encode_aov(f->rgb, f->aov, g->aov, g->w, g->h, &exr, &exr_len, &err);
    bool ok = st == RAYD_OK &&
              cluster_frame_store(c, id, k, png, len, exr, exr_len, (clock_now() - t0) * 1e3);
    if (st != RAYD_OK)
        log_error("cluster: job %s frame %ld: cannot encode: %s", id, k, err.message);
    rayd_free(png);
    rayd_free(exr);
    return ok;
}

bool cluster_assemble(struct redis *c, const char *id, long k) {
    struct cluster_geom g;
    if (!cluster_geom_read(c, id, &g)) return false;
    if (strcmp(g.state, "queued") && strcmp(g.state, "running")) return true; /* ended: drop */
    size_t need = cluster_assemble_bytes(g.w, g.h, g.size, g.exr, g.aov);
    if (cluster_assemble_never(c, id, k, need)) return true;  /* failed: the item is done */
    if (!cluster_assemble_reserve(id, k, need)) return false; /* the item stays pending */
    struct cluster_frame f = {0};
    long *bad = calloc((size_t)g.tiles, sizeof *bad);
    redisReply *png = NULL, *exr = NULL;
    bool ok = false;
    if (bad && cluster_frame_new(&g, &f) && (png = cluster_tiles_get(c, id, k, &g, false)) &&
        (!g.exr || (exr = cluster_tiles_get(c, id, k, &g, true)))) {
        long nbad = cluster_paste(&g, png, exr, &f, bad);
        ok = nbad > 0 ? cluster_redo(c, id, k, &g, bad, nbad) : cluster_encode(c, id, k, &g, &f);
    }
    if (png) freeReplyObject(png);
    if (exr) freeReplyObject(exr);
    mem_release(MEM_RESULTS, need);
    cluster_frame_free(&f);
    free(bad);
    return ok;
}
