/* cluster_state.c -- what the cluster's files share: the names (the node,
 * the version, the items' stream, the keys), the wall clock of the
 * records, this node's counters and the view /healthz and /metrics read.
 *
 * The lowest file of server/cluster/ but redis.c: the others use it, it
 * uses none of them.  The names are set once at start (cluster.c) before
 * any thread reads them; the counters are atomic; the view is written by
 * the puller and read by the HTTP threads under cluster_mu, so a probe
 * never waits for Redis.
 *
 * The clock of the records is Redis's, not the node's: the times a job
 * keeps (created, started, ended, a pass's) and the ages its JSON shows are
 * read on this node's clock plus the offset to Redis's TIME, measured at
 * most once a second by each thread that talks to Redis (the midpoint of
 * the call, so off by half a round trip at most).  Nodes whose clocks
 * disagree then write and show the same times, as liveness already used
 * Redis's clock (cluster_node.c).
 */
#include "cluster/cluster_private.h"

#include <stdio.h>
#include <stdlib.h>
#include <sys/time.h>

struct redis_url cluster_url;
char cluster_node_id[200];
char cluster_stream[160];
char cluster_ver[64];
atomic_bool cluster_stopping, cluster_draining;
atomic_long cluster_done_total, cluster_reclaimed_total, cluster_node_in_flight;
atomic_long cluster_deferred_total; /* assemblies put off: no room in the memory budget */
pthread_mutex_t cluster_mu = PTHREAD_MUTEX_INITIALIZER;
struct cluster_status_view cluster_view_now;

const char *cluster_version(void) { return cluster_ver; }

long cluster_claim_ms(void) { return config.redis_claim_ms; }

long cluster_gone_ms(void) { return 3 * cluster_claim_ms() + 1000; }

double cluster_skew_ms;

static atomic_llong clock_offset_ms; /* Redis's TIME minus this node's clock */
static atomic_llong clock_synced_ms; /* this node's clock when it was measured, 0: never */

/* This node's wall clock, ms since the epoch (off by cluster_skew_ms in tests). */
static double clock_local_ms(void) {
    struct timeval tv;
    gettimeofday(&tv, NULL);
    return (double)tv.tv_sec * 1e3 + (double)tv.tv_usec / 1e3 + cluster_skew_ms;
}

double cluster_now_ms(void) { return clock_local_ms() + (double)atomic_load(&clock_offset_ms); }

void cluster_clock_sync(struct redis *c) {
    double l0 = clock_local_ms();
    if (l0 - (double)atomic_load(&clock_synced_ms) < 1000) return;
    const char *argv[] = {"TIME", NULL};
    redisReply *rep = redis_strs(c, argv);
    double l1 = clock_local_ms();
    if (rep && rep->type == REDIS_REPLY_ARRAY && rep->elements == 2 &&
        rep->element[0]->type == REDIS_REPLY_STRING &&
        rep->element[1]->type == REDIS_REPLY_STRING) {
        double r =
            strtod(rep->element[0]->str, NULL) * 1e3 + strtod(rep->element[1]->str, NULL) / 1e3;
        atomic_store(&clock_offset_ms, (long long)(r - (l0 + l1) / 2));
        atomic_store(&clock_synced_ms, (long long)l1);
    }
    if (rep) freeReplyObject(rep);
}

void cluster_key(char *buf, size_t n, const char *id, const char *what) {
    snprintf(buf, n, "rayd:{%s}:%s", id, what);
}

void cluster_view(struct cluster_status_view *v) {
    pthread_mutex_lock(&cluster_mu);
    *v = cluster_view_now;
    pthread_mutex_unlock(&cluster_mu);
    v->node_in_flight = atomic_load(&cluster_node_in_flight);
    v->done_total = atomic_load(&cluster_done_total);
    v->reclaimed_total = atomic_load(&cluster_reclaimed_total);
    v->deferred_total = atomic_load(&cluster_deferred_total);
}
