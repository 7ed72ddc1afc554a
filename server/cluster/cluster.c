/* cluster.c -- rayd --redis: the cluster's start and stop, its request
 * thread, and what /healthz and /metrics show of it.
 *
 * With --redis URL a node keeps no job of its own: the job records, their
 * work items, tiles and frames live in Redis (the keys are drawn in
 * docs/architecture.md), so any node answers any job and a node's death
 * loses no work.  Two kinds of thread talk to Redis, each with its own
 * connection (redis.c):
 *   - the request thread answers the job routes.  A handler never calls
 *     Redis: it fills a struct cluster_op, cluster_submit suspends the
 *     request and links the op under cluster_mu, and this thread runs it
 *     (cluster_jobs.c) and calls op->done, which replies and resumes the
 *     connection -- as compile.c does for scenes.  One thread answers in
 *     order; each op is a few round trips of well under a millisecond.
 *   - the puller (cluster_node.c) takes work items while the node has
 *     room and renders them through the work layer.
 * While Redis is unreachable every op answers CS_DOWN at once (the
 * connection's back-off), so a job route says 503 cluster_unavailable and
 * names the address; renders, which need no Redis, go on as always.
 *
 * The version: a node takes only items of its own version (the stream's
 * name holds it), since another version's bytes could differ.  Tests of
 * that run one binary as two versions: with --test-gate, and only then,
 * RAYD_TEST_VERSION replaces the version the node claims, and
 * RAYD_TEST_CLUSTER_SKEW_S sets its wall clock that many seconds off (a
 * cluster must not care: liveness is judged by Redis's clock).
 */
#include "cluster/cluster_private.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/time.h>
#include <time.h>
#include <unistd.h>

static bool cluster_running;
static pthread_t cluster_req_thread;
static pthread_cond_t cluster_req_cond = PTHREAD_COND_INITIALIZER;
static struct cluster_op *cluster_head, **cluster_tail = &cluster_head; /* cluster_mu */

bool cluster_on(void) { return config.redis != NULL; }

int cluster_configure(void) {
    char why[300];
    if (!config.redis) return 0;
    if (!redis_url_parse(config.redis, &cluster_url, why, sizeof why)) {
        fprintf(stderr, "rayd: error: --redis '%s': %s\n",
                strchr(config.redis, '@') ? "(hidden: it holds a password)" : config.redis, why);
        return -1;
    }
    const char *v = getenv("RAYD_TEST_VERSION");
    snprintf(cluster_ver, sizeof cluster_ver, "%s",
             config.test_gate_tiles >= -1 && v && *v ? v : RAYD_VERSION);
    const char *skew = getenv("RAYD_TEST_CLUSTER_SKEW_S");
    if (config.test_gate_tiles >= -1 && skew) cluster_skew_ms = strtod(skew, NULL) * 1e3;
    snprintf(cluster_stream, sizeof cluster_stream, "rayd:items:%s", cluster_ver);
    cluster_items_names();
    snprintf(cluster_view_now.address, sizeof cluster_view_now.address, "%s", cluster_url.display);
    return 0;
}

/* ---- the request thread ----------------------------------------------------------- */

bool cluster_submit(struct cluster_op *op) {
    pthread_mutex_lock(&cluster_mu);
    if (!cluster_running || atomic_load(&cluster_stopping)) {
        pthread_mutex_unlock(&cluster_mu);
        return false;
    }
    if (op->suspend) op->suspend(op);
    op->next = NULL;
    *cluster_tail = op;
    cluster_tail = &op->next;
    pthread_cond_signal(&cluster_req_cond);
    pthread_mutex_unlock(&cluster_mu);
    return true;
}

/* The first op that is due, unlinked, or NULL; *wait the seconds until
 * the next one is (cluster_mu held). */
static struct cluster_op *cluster_due(double *wait) {
    double now = clock_now();
    *wait = 1.0;
    for (struct cluster_op **p = &cluster_head; *p; p = &(*p)->next) {
        struct cluster_op *op = *p;
        if (op->at <= now || atomic_load(&cluster_stopping)) {
            *p = op->next;
            if (!*p) cluster_tail = p;
            return op;
        }
        if (op->at - now < *wait) *wait = op->at - now;
    }
    return NULL;
}

static void cluster_timedwait(double seconds) {
    struct timespec ts = clock_after(seconds);
    pthread_cond_timedwait(&cluster_req_cond, &cluster_mu, &ts);
}

static void *cluster_req_main(void *arg) {
    (void)arg;
    struct redis *c = redis_new(&cluster_url, 2.0);
    for (;;) {
        double wait;
        pthread_mutex_lock(&cluster_mu);
        struct cluster_op *op;
        while (!(op = cluster_due(&wait)) && !atomic_load(&cluster_stopping)) {
            if (cluster_head)
                cluster_timedwait(wait);
            else
                pthread_cond_wait(&cluster_req_cond, &cluster_mu);
        }
        pthread_mutex_unlock(&cluster_mu);
        if (!op) break; /* stopping, and nothing left to answer */
        if (!c) {
            op->status = CS_NOMEM;
        } else {
            cluster_clock_sync(c);
            cluster_jobs_run(c, op);
            if (op->status == CS_DOWN && !op->why[0])
                snprintf(op->why, sizeof op->why, "the cluster's Redis at %s: %s",
                         cluster_url.display, redis_why(c)[0] ? redis_why(c) : "no answer");
        }
        op->done(op);
    }
    redis_free(c);
    return NULL;
}

bool cluster_start(int port) {
    if (!cluster_on()) return true;
    char host[100] = "localhost";
    gethostname(host, sizeof host - 1);
    snprintf(cluster_node_id, sizeof cluster_node_id, "%s:%d:%ld", host, port, (long)getpid());
    pthread_mutex_lock(&cluster_mu);
    cluster_running = pthread_create(&cluster_req_thread, NULL, cluster_req_main, NULL) == 0;
    pthread_mutex_unlock(&cluster_mu);
    if (!cluster_running) return false;
    log_info("cluster: node %s, Redis at %s, items of version %s (%s), claim %ld ms, tiles of %ld",
             cluster_node_id, cluster_url.display, cluster_ver, cluster_stream,
             config.redis_claim_ms, config.cluster_tile);
    return cluster_node_start();
}

void cluster_drain(void) { atomic_store(&cluster_draining, true); }

void cluster_stop(void) {
    if (!cluster_on() || !cluster_running) return;
    atomic_store(&cluster_draining, true);
    cluster_node_stop();
    pthread_mutex_lock(&cluster_mu);
    atomic_store(&cluster_stopping, true);
    pthread_cond_broadcast(&cluster_req_cond);
    pthread_mutex_unlock(&cluster_mu);
    pthread_join(cluster_req_thread, NULL);
    cluster_running = false;
}

/* ---- what is shown ---------------------------------------------------------------- */

char *cluster_metrics(char *text, size_t *len) {
    if (!cluster_on()) return text;
    struct cluster_status_view v;
    cluster_view(&v);
    char buf[2800];
    int n = snprintf(
        buf, sizeof buf,
        "# HELP rayd_cluster_redis_up 1 while this node reaches the cluster's Redis.\n"
        "# TYPE rayd_cluster_redis_up gauge\nrayd_cluster_redis_up %d\n"
        "# HELP rayd_cluster_nodes Nodes of this cluster seen lately (3 x --redis-claim-ms).\n"
        "# TYPE rayd_cluster_nodes gauge\nrayd_cluster_nodes %ld\n"
        "# HELP rayd_cluster_items_queued Work items of this version no node has taken yet.\n"
        "# TYPE rayd_cluster_items_queued gauge\nrayd_cluster_items_queued %ld\n"
        "# HELP rayd_cluster_items_in_flight Work items taken by some node, not yet done.\n"
        "# TYPE rayd_cluster_items_in_flight gauge\nrayd_cluster_items_in_flight %ld\n"
        "# HELP rayd_cluster_node_items_in_flight Work items this node is working on.\n"
        "# TYPE rayd_cluster_node_items_in_flight gauge\nrayd_cluster_node_items_in_flight %ld\n"
        "# HELP rayd_cluster_items_done_total Work items this node finished (tiles and "
        "assemblies).\n"
        "# TYPE rayd_cluster_items_done_total counter\nrayd_cluster_items_done_total %ld\n"
        "# HELP rayd_cluster_items_reclaimed_total Work items this node took over from a node "
        "that did not refresh them within --redis-claim-ms.\n"
        "# TYPE rayd_cluster_items_reclaimed_total counter\n"
        "rayd_cluster_items_reclaimed_total %ld\n"
        "# HELP rayd_cluster_assemblies_deferred_total Frame assemblies this node left for later "
        "because its memory budget (--max-memory) had no room (the item is taken over after "
        "--redis-claim-ms).\n"
        "# TYPE rayd_cluster_assemblies_deferred_total counter\n"
        "rayd_cluster_assemblies_deferred_total %ld\n",
        v.redis_up ? 1 : 0, v.nodes, v.queued, v.in_flight, v.node_in_flight, v.done_total,
        v.reclaimed_total, v.deferred_total);
    if (n < 0 || (size_t)n >= sizeof buf) return text;
    char *out = realloc(text, *len + (size_t)n + 1);
    if (!out) return text;
    memcpy(out + *len, buf, (size_t)n + 1);
    *len += (size_t)n;
    return out;
}
