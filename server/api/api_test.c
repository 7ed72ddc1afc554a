/* api_test.c -- GET and POST /v1/test/gate: the test gate, for tests only.
 *
 * A test that needs work in flight -- a render to cancel, to drain, to fill
 * the queue with, to join -- starts rayd with --test-gate (on loopback only)
 * and sets how many more tiles the workers may start:
 *
 *   POST /v1/test/gate?tiles=N     N more tiles, then the workers wait
 *   POST /v1/test/gate?tiles=open  no limit (the gate stays, open)
 *   POST /v1/test/gate?work=N      the renders made from now on stop
 *                                  after N rays, as --max-work at run time,
 *                                  with no price at the door; work=open:
 *                                  --max-work again
 *   POST /v1/test/gate?parses=N    N more scene parses, then the parse
 *                                  threads wait (compile.c); parses=open
 *   POST /v1/test/gate?clock=S     the server's clock jumps S seconds ahead
 *                                  (clock.c): a job's --job-ttl passes
 *                                  without the test waiting it out
 *   GET  /v1/test/gate             the gate as it is
 *
 * Both answer {"tiles": N or "open", "started": tiles let through so far,
 * "held": workers waiting at the gate with a tile to start, "queued": tasks
 * waiting for a worker, "parses": N or "open", "parses_started",
 * "parses_queued": scenes waiting for a parse thread, "parses_running",
 * "parses_waiting": requests waiting for those parses (a body posted again
 * while its parse is queued joins it), "clock_skipped_s": the clock's jumps
 * in all}.  Without --test-gate the
 * route is a 404 like any unknown path.  The gate itself is in gate.c, asked by the workers
 * (sched.c).
 */
#include "api/api.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <stdlib.h>
#include <string.h>

static void api_test_gate_reply(struct http_req *r, const struct gate_state *g) {
    cJSON *o = cJSON_CreateObject();
    if (g->tiles < 0)
        cJSON_AddStringToObject(o, "tiles", "open");
    else
        cJSON_AddNumberToObject(o, "tiles", (double)g->tiles);
    cJSON_AddNumberToObject(o, "started", (double)g->started);
    cJSON_AddNumberToObject(o, "held", (double)g->held);
    cJSON_AddNumberToObject(o, "queued", (double)g->queued);
    struct compile_gate_state c;
    compile_gate_get(&c);
    if (c.parses < 0)
        cJSON_AddStringToObject(o, "parses", "open");
    else
        cJSON_AddNumberToObject(o, "parses", (double)c.parses);
    cJSON_AddNumberToObject(o, "parses_started", (double)c.started);
    cJSON_AddNumberToObject(o, "parses_queued", (double)c.queued);
    cJSON_AddNumberToObject(o, "parses_running", (double)c.running);
    cJSON_AddNumberToObject(o, "parses_waiting", (double)c.waiting);
    cJSON_AddNumberToObject(o, "clock_skipped_s", clock_skip(0));
    http_reply_json(r, 200, o);
}

static void api_test_gate_off(struct http_req *r) {
    http_reply_error(r, 404, "not_found", "no such resource (rayd runs without --test-gate)", NULL,
                     0, 0, NULL);
}

/* "open" (-1) or a decimal count into *n. */
static bool api_test_count(const char *v, long *n) {
    if (!strcmp(v, "open")) {
        *n = -1;
        return true;
    }
    errno = 0;
    *n = strtol(v, NULL, 10);
    return api_is_decimal(v, false) && !errno && *n <= 1000000000L;
}

void api_test_gate_get(struct http_req *r, const char *id) {
    (void)id;
    struct gate_state g;
    if (!gate_get(&g)) {
        api_test_gate_off(r);
        return;
    }
    api_test_gate_reply(r, &g);
}

void api_test_gate_post(struct http_req *r, const char *id) {
    (void)id;
    struct gate_state g;
    if (!gate_get(&g)) {
        api_test_gate_off(r);
        return;
    }
    const char *v = http_req_query(r, "tiles"), *pv = http_req_query(r, "parses");
    const char *wv = http_req_query(r, "work"), *cv = http_req_query(r, "clock");
    long n = 0, parses = 0, work = 0, skip = 0;
    if (cv && (!api_test_count(cv, &skip) || skip < 0 || skip > 86400)) {
        http_reply_error(r, 400, "bad_parameter", "clock must be an integer from 0 to 86400", NULL,
                         0, 0, "clock");
        return;
    }
    if (wv && !api_test_count(wv, &work)) {
        http_reply_error(r, 400, "bad_parameter", "work must be 'open' or an integer >= 0", NULL, 0,
                         0, "work");
        return;
    }
    if (pv && !api_test_count(pv, &parses)) {
        http_reply_error(r, 400, "bad_parameter", "parses must be 'open' or an integer >= 0", NULL,
                         0, 0, "parses");
        return;
    }
    if ((v || (!pv && !wv && !cv)) && (!v || !api_test_count(v, &n))) {
        http_reply_error(r, 400, "bad_parameter", "tiles must be 'open' or an integer >= 0", NULL,
                         0, 0, "tiles");
        return;
    }
    if (cv) clock_skip(skip);
    if (wv) task_gate_work(work);
    if (pv) compile_gate_set(parses);
    if (v) gate_set(n);
    gate_get(&g);
    api_test_gate_reply(r, &g);
}
