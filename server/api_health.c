/* api_health.c -- /healthz, /readyz and /metrics.
 *
 * /healthz answers 200 while the process can answer at all (liveness).
 * /readyz answers 503 while draining or while the render queue is full, so a
 * load balancer stops sending work before requests are refused; 200
 * otherwise.  Both stay open without a token so probes need no secret.
 * /metrics is the Prometheus text of metrics.c.
 */
#include "api.h"

#include <cjson/cJSON.h>
#include <stdlib.h>

void api_health_live(struct http_req *r, const char *id)
{
    (void)id;
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "status", "ok");
    http_reply_json(r, 200, o);
}

void api_health_ready(struct http_req *r, const char *id)
{
    (void)id;
    struct sched_stats st;
    sched_stats(&st);
    if (sched_draining()) {
        http_reply_error(r, 503, "draining", "the server is shutting down", NULL, 0, 0, NULL);
        return;
    }
    if (st.queued >= st.queue_cap) {
        http_reply_error(r, 503, "queue_full", "the render queue is full", NULL, 0, 0, NULL);
        return;
    }
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "status", "ready");
    cJSON_AddNumberToObject(o, "queued", (double)st.queued);
    cJSON_AddNumberToObject(o, "capacity", (double)st.queue_cap);
    cJSON_AddNumberToObject(o, "workers", (double)st.workers);
    cJSON_AddNumberToObject(o, "busy", (double)st.busy_workers);
    http_reply_json(r, 200, o);
}

void api_health_metrics(struct http_req *r, const char *id)
{
    (void)id;
    size_t len = 0;
    char *text = metrics_text(&len);
    if (!text) {
        http_reply_error(r, 503, "out_of_memory", "out of memory", NULL, 0, 0, NULL);
        return;
    }
    http_reply_data(r, 200, "text/plain; version=0.0.4; charset=utf-8", text, len);
    http_reply_header(r, "Cache-Control", "no-store");
    free(text);
}
