/* cluster_state.c -- what the cluster's files share: the names (the node,
 * the version, the items' stream, the keys), the wall clock of the
 * records, this node's counters and the view /healthz and /metrics read.
 *
 * The lowest file of server/cluster/: the others use it, it uses none of
 * them.  The names are set once at start (cluster.c) before any thread
 * reads them; the counters are atomic; the view is written by the puller
 * and read by the HTTP threads under cluster_mu, so a probe never waits
 * for Redis.
 */
#include "cluster/cluster_private.h"

#include <stdio.h>
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

double cluster_skew_ms;

double cluster_now_ms(void) {
    struct timeval tv;
    gettimeofday(&tv, NULL);
    return (double)tv.tv_sec * 1e3 + (double)tv.tv_usec / 1e3 + cluster_skew_ms;
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
