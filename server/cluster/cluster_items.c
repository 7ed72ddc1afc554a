/* cluster_items.c -- the streams of work items, one per priority, and the
 * consumers that read them (the puller's Redis calls).
 *
 * A job's items go to the stream of its priority (POST /v1/jobs?priority=):
 * rayd:items:VERSION for normal, rayd:items:VERSION:high and
 * rayd:items:VERSION:low for the others, each with the consumer group
 * `render`.  The job's record names its stream (field `items`), so the
 * scripts that queue more of its items later -- a tile queued again, a
 * pass -- put them beside the others; a frame's assembly goes to the high
 * stream (cluster_assemble.c).  A node takes its next item
 * from the highest stream that has one (one script, so a node never holds
 * a low item it took while a high one waited); when all are empty it
 * blocks on all three at once.  Take-overs (XAUTOCLAIM), refreshes (XCLAIM)
 * and the figures of /metrics cover the three.
 *
 * Gone nodes leave their consumer in the group and their line in
 * rayd:nodes for ever unless someone removes them.  Every node, at every
 * figures turn, runs one script that removes each consumer of the three
 * groups that has been idle for longer than the "gone" rule (3 x
 * --redis-claim-ms), holds nothing (XINFO CONSUMERS: no item pending, its
 * items were taken over by XAUTOCLAIM first) and whose node has not written
 * its heartbeat within the rule either, and the heartbeat lines of such
 * nodes.  DELCONSUMER drops a
 * consumer's pending entries, so the script checks and deletes in one
 * atomic step; two nodes reaping at once find the second run has nothing
 * left to do.  A live node is never removed: its blocking reads and
 * refreshes keep its idle time short and its heartbeat keeps its line, and
 * a node that was only stalled simply comes back as a new consumer when it
 * reads again.
 */
#include "cluster/cluster_private.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static char cluster_streams[CLUSTER_LEVELS][176]; /* by enum jobs_priority */

void cluster_items_names(void) {
    snprintf(cluster_streams[JP_LOW], sizeof cluster_streams[0], "%s:low", cluster_stream);
    snprintf(cluster_streams[JP_NORMAL], sizeof cluster_streams[0], "%s", cluster_stream);
    snprintf(cluster_streams[JP_HIGH], sizeof cluster_streams[0], "%s:high", cluster_stream);
}

const char *cluster_items_stream(int priority) {
    return cluster_streams[priority < JP_LOW ? JP_LOW : priority > JP_HIGH ? JP_HIGH : priority];
}

/* The level of stream key, or -1. */
static int items_level(const char *key) {
    for (int l = 0; l < CLUSTER_LEVELS; l++)
        if (key && !strcmp(key, cluster_streams[l])) return l;
    return -1;
}

void cluster_items_groups(struct redis *c) {
    for (int l = 0; l < CLUSTER_LEVELS; l++) {
        const char *argv[] = {"XGROUP",   "CREATE", cluster_streams[l], "render", "0",
                              "MKSTREAM", NULL};
        redisReply *rep = redis_strs(c, argv);
        if (rep) freeReplyObject(rep); /* BUSYGROUP: it exists */
    }
}

void cluster_items_ack(struct redis *c, int level, const char *sid) {
    static const char script[] = "redis.call('XACK', KEYS[1], 'render', ARGV[1])\n"
                                 "return redis.call('XDEL', KEYS[1], ARGV[1])\n";
    const char *argv[] = {"EVAL", script, "1", cluster_streams[level], sid, NULL};
    redisReply *rep = redis_strs(c, argv);
    if (rep) freeReplyObject(rep);
}

/* Each entry of list (XREADGROUP's or XAUTOCLAIM's) to take(). */
static long items_each(struct redis *c, const redisReply *list, int level, bool reclaimed,
                       cluster_items_take_fn take) {
    long n = 0;
    for (size_t i = 0; list && list->type == REDIS_REPLY_ARRAY && i < list->elements; i++) {
        const redisReply *e = list->element[i];
        if (!e || e->type != REDIS_REPLY_ARRAY || e->elements < 2 ||
            e->element[0]->type != REDIS_REPLY_STRING)
            continue; /* an entry deleted while pending: nothing to take */
        n += take(c, e, level, reclaimed);
    }
    return n;
}

/* The first new item of the highest stream that has one: {level, entries}. */
static const char items_lua_take[] =
    "for i = 1, #KEYS do\n"
    "  local r = redis.call('XREADGROUP', 'GROUP', 'render', ARGV[1], 'COUNT', 1, 'STREAMS', "
    "KEYS[i], '>')\n"
    "  if r then return {tostring(i - 1), r[1][2]} end\n"
    "end\n"
    "return false\n";

/* A reply that says a group is missing (a Redis that lost its data). */
static bool items_nogroup(const redisReply *rep) {
    return rep && rep->type == REDIS_REPLY_ERROR && strstr(rep->str, "NOGROUP");
}

/* script run over the three streams (KEYS, highest first) for this node
 * (ARGV[1]). */
static redisReply *items_eval(struct redis *c, const char *script) {
    const char *argv[] = {"EVAL",
                          script,
                          "3",
                          cluster_streams[JP_HIGH],
                          cluster_streams[JP_NORMAL],
                          cluster_streams[JP_LOW],
                          cluster_node_id,
                          NULL};
    return redis_strs(c, argv);
}

bool cluster_items_pull(struct redis *c, cluster_items_take_fn take, long block_ms) {
    redisReply *rep = items_eval(c, items_lua_take);
    if (items_nogroup(rep)) {
        freeReplyObject(rep);
        cluster_items_groups(c);
        return false;
    }
    bool got = rep && !redis_failed(c, rep) && rep->type == REDIS_REPLY_ARRAY &&
               rep->elements == 2 && rep->element[0]->type == REDIS_REPLY_STRING;
    if (got) items_each(c, rep->element[1], JP_HIGH - atoi(rep->element[0]->str), false, take);
    if (rep) freeReplyObject(rep);
    if (got || !redis_is_up(c) || block_ms <= 0) return got;
    /* nothing anywhere: wait on all three for the next one */
    char block[24];
    snprintf(block, sizeof block, "%ld", block_ms);
    const char *bv[] = {"XREADGROUP",
                        "GROUP",
                        "render",
                        cluster_node_id,
                        "COUNT",
                        "1",
                        "BLOCK",
                        block,
                        "STREAMS",
                        cluster_streams[JP_HIGH],
                        cluster_streams[JP_NORMAL],
                        cluster_streams[JP_LOW],
                        ">",
                        ">",
                        ">",
                        NULL};
    rep = redis_strs(c, bv);
    if (items_nogroup(rep)) {
        cluster_items_groups(c);
    } else if (rep && !redis_failed(c, rep) && rep->type == REDIS_REPLY_ARRAY) {
        for (size_t i = 0; i < rep->elements; i++) { /* one stream's [key, entries] each */
            const redisReply *s = rep->element[i];
            if (s->type != REDIS_REPLY_ARRAY || s->elements != 2) continue;
            int l = items_level(s->element[0]->str);
            if (l >= 0 && items_each(c, s->element[1], l, false, take) > 0) got = true;
        }
    }
    if (rep) freeReplyObject(rep);
    return got;
}

void cluster_items_reclaim(struct redis *c, long room, cluster_items_take_fn take) {
    static char cursor[CLUSTER_LEVELS][48] = {"0-0", "0-0", "0-0"};
    for (int l = JP_HIGH; l >= JP_LOW && room > 0; l--) {
        char idle[24], count[24];
        snprintf(idle, sizeof idle, "%ld", cluster_claim_ms());
        snprintf(count, sizeof count, "%ld", room);
        const char *argv[] = {"XAUTOCLAIM", cluster_streams[l], "render", cluster_node_id,
                              idle,         cursor[l],          "COUNT",  count,
                              NULL};
        redisReply *rep = redis_strs(c, argv);
        if (rep && !redis_failed(c, rep) && rep->type == REDIS_REPLY_ARRAY && rep->elements >= 2) {
            if (rep->element[0]->type == REDIS_REPLY_STRING)
                snprintf(cursor[l], sizeof cursor[l], "%s", rep->element[0]->str);
            room -= items_each(c, rep->element[1], l, true, take);
        }
        if (rep) freeReplyObject(rep);
    }
}

void cluster_items_refresh(struct redis *c, int level, const char **sids, int n) {
    if (n <= 0) return;
    const char **argv = calloc((size_t)n + 8, sizeof *argv);
    if (!argv) return;
    int k = 0;
    argv[k++] = "XCLAIM";
    argv[k++] = cluster_streams[level];
    argv[k++] = "render";
    argv[k++] = cluster_node_id;
    argv[k++] = "0";
    for (int i = 0; i < n; i++) argv[k++] = sids[i];
    argv[k++] = "JUSTID";
    redisReply *rep = redis_argv(c, k, argv, NULL);
    if (rep) freeReplyObject(rep);
    free(argv);
}

bool cluster_items_count(struct redis *c, long *queued, long *in_flight) {
    bool ok = true;
    *queued = *in_flight = 0;
    for (int l = 0; l < CLUSTER_LEVELS; l++) {
        redisReply *len = redis_cmd(c, "XLEN %s", cluster_streams[l]);
        const char *argv[] = {"XPENDING", cluster_streams[l], "render", NULL};
        redisReply *pend = redis_strs(c, argv);
        long long n = redis_ll(len, 0), pending = 0;
        if (pend && pend->type == REDIS_REPLY_ARRAY && pend->elements >= 1)
            pending = redis_ll(pend->element[0], 0);
        ok = ok && len && len->type == REDIS_REPLY_INTEGER;
        if (len) freeReplyObject(len);
        if (pend) freeReplyObject(pend);
        *in_flight += (long)pending;
        *queued += n > pending ? (long)(n - pending) : 0;
    }
    return ok;
}

/* ---- gone nodes -------------------------------------------------------------------- */

/* KEYS: the streams, then rayd:nodes; ARGV: this node, the idle time (ms)
 * and heartbeat age (s, by Redis's clock as the heartbeats) past which a
 * node counts as gone.  Returns the consumers and lines removed. */
static const char items_lua_reap[] =
    "local me, idle_min, gone = ARGV[1], tonumber(ARGV[2]), tonumber(ARGV[3])\n"
    "local now = tonumber(redis.call('TIME')[1])\n"
    "local n, nodes = #KEYS - 1, KEYS[#KEYS]\n"
    "local live, keep, cand, out = {}, {}, {}, {}\n"
    "local hs = redis.call('HGETALL', nodes)\n"
    "for j = 1, #hs, 2 do\n"
    "  local seen = tonumber(string.match(hs[j + 1], '\"seen\":(%d+)')) or 0\n"
    "  if now - seen <= gone then live[hs[j]] = true end\n"
    "end\n"
    "for i = 1, n do\n"
    "  local cs = redis.pcall('XINFO', 'CONSUMERS', KEYS[i], 'render')\n"
    "  if type(cs) == 'table' and not cs.err then\n"
    "    for _, c in ipairs(cs) do\n"
    "      local f = {}\n"
    "      for j = 1, #c, 2 do f[c[j]] = c[j + 1] end\n"
    "      if f.pending > 0 or f.idle <= idle_min or live[f.name] then keep[f.name] = true\n"
    "      else cand[f.name] = true end\n"
    "    end\n"
    "  end\n"
    "end\n"
    "for name in pairs(cand) do\n"
    "  if not keep[name] and name ~= me then\n"
    "    for i = 1, n do redis.pcall('XGROUP', 'DELCONSUMER', KEYS[i], 'render', name) end\n"
    "    table.insert(out, 'consumer ' .. name)\n"
    "  end\n"
    "end\n"
    "for j = 1, #hs, 2 do\n"
    "  if not live[hs[j]] and not keep[hs[j]] and hs[j] ~= me then\n"
    "    redis.call('HDEL', nodes, hs[j])\n"
    "    table.insert(out, 'heartbeat ' .. hs[j])\n"
    "  end\n"
    "end\n"
    "return out\n";

long cluster_items_reap(struct redis *c) {
    char idle[24], gone[24];
    long rule = 3 * cluster_claim_ms();
    snprintf(idle, sizeof idle, "%ld", rule);
    snprintf(gone, sizeof gone, "%ld", (rule + 999) / 1000 + 1); /* the heartbeat's is in s */
    const char *argv[] = {"EVAL",
                          items_lua_reap,
                          "4",
                          cluster_streams[JP_HIGH],
                          cluster_streams[JP_NORMAL],
                          cluster_streams[JP_LOW],
                          "rayd:nodes",
                          cluster_node_id,
                          idle,
                          gone,
                          NULL};
    redisReply *rep = redis_strs(c, argv);
    long n = 0;
    if (rep && !redis_failed(c, rep) && rep->type == REDIS_REPLY_ARRAY) {
        for (size_t i = 0; i < rep->elements; i++, n++)
            log_info("cluster: a gone node's %s removed (not seen for over %ld ms, holding "
                     "nothing)",
                     rep->element[i]->str ? rep->element[i]->str : "?", rule);
    }
    if (rep) freeReplyObject(rep);
    return n;
}

void cluster_items_leave(struct redis *c) {
    static const char script[] =
        "for i = 1, #KEYS do\n"
        "  local p = redis.pcall('XPENDING', KEYS[i], 'render', '-', '+', 1, ARGV[1])\n"
        "  if type(p) == 'table' and not p.err and #p == 0 then\n"
        "    redis.call('XGROUP', 'DELCONSUMER', KEYS[i], 'render', ARGV[1])\n"
        "  end\n"
        "end\n"
        "return 0\n";
    redisReply *rep = items_eval(c, script);
    if (rep) freeReplyObject(rep);
}

/* ---- other versions ---------------------------------------------------------------- */

/* Adds len items of the version of stream key k (rayd:items:V[:high|:low]). */
static void items_other(struct cluster_status_view *v, long long *counts, const char *k,
                        long long len) {
    char ver[120];
    snprintf(ver, sizeof ver, "%s", k + strlen("rayd:items:"));
    size_t n = strlen(ver);
    if (n > 5 && !strcmp(ver + n - 5, ":high")) ver[n - 5] = 0;
    if (n > 4 && !strcmp(ver + n - 4, ":low")) ver[n - 4] = 0;
    int i = 0;
    while (i < v->nother && strcmp(v->other_versions[i], ver)) i++;
    if (i == v->nother) {
        if (v->nother == 4) return;
        snprintf(v->other_versions[v->nother++], sizeof v->other_versions[0], "%s", ver);
        counts[i] = 0;
    }
    counts[i] += len;
}

void cluster_items_others(struct redis *c, struct cluster_status_view *v) {
    char cursor[32] = "0";
    long long counts[4] = {0};
    for (int round = 0; round < 20; round++) {
        const char *argv[] = {"SCAN", cursor, "MATCH", "rayd:items:*", "COUNT", "1000", NULL};
        redisReply *rep = redis_strs(c, argv);
        if (redis_failed(c, rep) || rep->type != REDIS_REPLY_ARRAY || rep->elements != 2) {
            if (rep) freeReplyObject(rep);
            break;
        }
        snprintf(cursor, sizeof cursor, "%s", rep->element[0]->str ? rep->element[0]->str : "0");
        const redisReply *keys = rep->element[1];
        for (size_t i = 0; i < keys->elements; i++) {
            const char *k = keys->element[i]->str;
            if (!k || items_level(k) >= 0) continue;
            redisReply *n = redis_cmd(c, "XLEN %s", k);
            long long len = redis_ll(n, 0);
            if (n) freeReplyObject(n);
            if (len > 0) items_other(v, counts, k, len);
        }
        freeReplyObject(rep);
        if (!strcmp(cursor, "0")) break;
    }
    for (int i = 0; i < v->nother; i++) {
        char ver[60];
        snprintf(ver, sizeof ver, "%.30s", v->other_versions[i]);
        snprintf(v->other_versions[i], sizeof v->other_versions[0],
                 "rayd %s: %lld items wait for nodes of that version", ver, counts[i]);
    }
}
