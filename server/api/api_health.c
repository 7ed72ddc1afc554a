/* api_health.c -- /healthz, /readyz and /metrics.
 *
 * /healthz answers 200 while the process can answer at all (liveness), with
 * rayd's version and its --max-body: a client that embeds a model in a
 * scene (the preview's Open and drop) checks the body's size before it
 * sends megabytes to be refused.
 * /readyz answers 503 while draining, while the render queue is full, or
 * while the estimated backlog is over --max-backlog seconds (cost.c), so a
 * load balancer stops sending work before requests are refused or wait for
 * long; 200 otherwise, with the backlog.  Both stay open without a token so probes need no secret.
 * A table of --max-jobs jobs all unfinished refuses POST /v1/jobs (503
 * queue_full) but not renders, which a balancer should still send here:
 * /readyz stays 200 and says so in "jobs_refused", beside the jobs counted
 * ("jobs" unfinished of "max_jobs"), so an operator or a job client sees
 * why; likewise while a cluster node's Redis is down (its renders go on).
 * /metrics is the Prometheus text of metrics.c.
 */
#include "api/api.h"
#include "cluster/cluster.h"

#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>

/* "cluster" (rayd --redis): the puller's latest view, no Redis call here. */
static void api_health_cluster(cJSON *o) {
    if (!cluster_on()) return;
    struct cluster_status_view v;
    cluster_view(&v);
    cJSON *c = cJSON_AddObjectToObject(o, "cluster");
    cJSON_AddStringToObject(c, "redis", v.redis_up ? "up" : "down");
    cJSON_AddStringToObject(c, "address", v.address);
    if (!v.redis_up && v.reason[0]) cJSON_AddStringToObject(c, "reason", v.reason);
    cJSON_AddStringToObject(c, "version", cluster_version());
    cJSON_AddNumberToObject(c, "nodes", (double)v.nodes);
    cJSON_AddNumberToObject(c, "queued", (double)v.queued);
    cJSON_AddNumberToObject(c, "in_flight", (double)v.in_flight);
    cJSON_AddNumberToObject(c, "node_in_flight", (double)v.node_in_flight);
    cJSON *other = cJSON_AddArrayToObject(c, "other_versions");
    for (int i = 0; i < v.nother; i++)
        cJSON_AddItemToArray(other, cJSON_CreateString(v.other_versions[i]));
}

void api_health_live(struct http_req *r, const char *id) {
    (void)id;
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "status", "ok");
    /* a frame is stitched from one version only: rayd-client health says so */
    cJSON_AddStringToObject(o, "version", RAYD_VERSION);
    cJSON_AddNumberToObject(o, "max_body", (double)config.max_body);
    api_health_cluster(o);
    http_reply_json(r, 200, o);
}

/* "jobs", "max_jobs", and "jobs_refused" while POST /v1/jobs is refused
 * because every job kept is unfinished (jobs.c evicts finished ones only);
 * with --redis the cluster's unfinished jobs, as the puller last read them. */
static void api_health_jobs(cJSON *o, const struct sched_stats *st) {
    long jobs = st->jobs_unfinished;
    struct cluster_status_view v = {.checked = true, .redis_up = true};
    if (cluster_on()) {
        cluster_view(&v);
        jobs = v.jobs_unfinished;
    }
    cJSON_AddNumberToObject(o, "jobs", (double)jobs);
    cJSON_AddNumberToObject(o, "max_jobs", (double)st->jobs_cap);
    char msg[600];
    if (v.checked && !v.redis_up) {
        snprintf(msg, sizeof msg,
                 "the cluster's Redis at %.100s is down (%.200s): POST /v1/jobs answers 503 "
                 "cluster_unavailable until it is back; renders are accepted",
                 v.address, v.reason);
        cJSON_AddStringToObject(o, "jobs_refused", msg);
        return;
    }
    if (jobs < st->jobs_cap) return;
    snprintf(msg, sizeof msg,
             "all %ld jobs kept (--max-jobs) are unfinished%s: POST /v1/jobs answers 503 "
             "queue_full until one ends; renders are accepted",
             st->jobs_cap, cluster_on() ? " in the cluster" : "");
    cJSON_AddStringToObject(o, "jobs_refused", msg);
}

void api_health_ready(struct http_req *r, const char *id) {
    (void)id;
    struct sched_stats st;
    sched_stats(&st);
    if (sched_draining()) {
        http_reply_error(r, 503, "draining", "the server is shutting down", NULL, 0, 0, NULL);
        return;
    }
    if (st.queued >= st.queue_cap) {
        r->res.retry_after = api_cost_retry_after(st.backlog_s / (double)st.queued);
        http_reply_error(r, 503, "queue_full", "the render queue is full", NULL, 0, 0, NULL);
        return;
    }
    if (config.max_backlog > 0 && st.backlog_s > (double)config.max_backlog) {
        char msg[200];
        snprintf(msg, sizeof msg,
                 "about %.0f s of work is queued, more than --max-backlog %ld s; send new work "
                 "elsewhere",
                 st.backlog_s, config.max_backlog);
        r->res.retry_after = api_cost_retry_after(st.backlog_s - (double)config.max_backlog);
        http_reply_error(r, 503, "backlog", msg, NULL, 0, 0, NULL);
        return;
    }
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "status", "ready");
    cJSON_AddNumberToObject(o, "queued", (double)st.queued);
    cJSON_AddNumberToObject(o, "capacity", (double)st.queue_cap);
    cJSON_AddNumberToObject(o, "workers", (double)st.workers);
    cJSON_AddNumberToObject(o, "busy", (double)st.busy_workers);
    json_add_fixed(o, "backlog_s", st.backlog_s, 3);
    api_health_jobs(o, &st);
    http_reply_json(r, 200, o);
}

void api_health_metrics(struct http_req *r, const char *id) {
    (void)id;
    size_t len = 0;
    char *text = metrics_text(&len);
    if (text) text = cluster_metrics(text, &len);
    if (!text) {
        http_reply_error(r, 503, "out_of_memory", "out of memory", NULL, 0, 0, NULL);
        return;
    }
    http_reply_data(r, 200, "text/plain; version=0.0.4; charset=utf-8", text, len);
    http_reply_header(r, "Cache-Control", "no-store");
    free(text);
}
