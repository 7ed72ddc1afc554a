/* cluster_queue.c -- what the cluster's Redis costs per work item (make bench-cluster).
 *
 *     build/bench/cluster_queue HOST PORT DIR [ITEMS RUNS]
 *
 * rayd --redis shares its jobs through Redis (docs/operations.md, "The
 * cluster over Redis"): a job's tiles are entries of a Stream that every
 * node's puller takes one at a time through a consumer group, and each
 * tile's PNG goes back as a string.  This program times those Redis calls
 * alone, with nothing rendered, against the Redis at HOST:PORT (which
 * bench/cluster_queue.sh starts, AOF on as in production), so the fixed
 * cost of one item can be set against a tile's render time:
 *
 *   enqueue  XADD of one item, one call each, and ITEMS of them in one
 *            MULTI/EXEC (POST /v1/jobs writes a job's items in one Lua
 *            script: one round trip too);
 *   claim    XREADGROUP ... COUNT 1 STREAMS key > by N consumers at once
 *            (N = 1, 2, 4, 8 threads, one connection each: N nodes'
 *            pullers) until the stream has nothing new; then rayd's take
 *            (server/cluster/cluster_items.c: one script that tries the
 *            priorities' streams from the highest down) with every item
 *            in the lowest of three, its worst case;
 *   ack      XACK + XDEL of each claimed item (one round trip, pipelined),
 *            by the same N consumers;
 *   result   SET and GET of a tile-sized PNG (20 KB and 200 KB of random
 *            bytes: PNG data does not compress further), and the same
 *            bytes as a file in DIR (write, fsync, rename; then open and
 *            read), the shared-volume alternative; last, the Redis SET and
 *            GET again with the AOF turned off (CONFIG SET appendonly no),
 *            which is what the append-only file costs a result.
 *
 * Each figure is the median of RUNS runs.  "us/item" is the time a
 * caller waits per item (with N consumers, the sum of their loops' times
 * over all the items: the round trip one node sees); "items/s" is all the
 * items over the wall time of the phase (what the cluster gets).  Everything runs on loopback on
 * the same machine as Redis, so with more consumers than cores the figures show contention for the
 * CPU as much as Redis's own limit.
 */
#include <errno.h>
#include <stdarg.h>
#include <stdbool.h>
#include <fcntl.h>
#include <hiredis/hiredis.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#define STREAM "rayd:items:bench"
#define STREAM_HIGH STREAM ":high"
#define STREAM_NORMAL STREAM ":normal"
#define GROUP "render"
#define MAX_RUNS 32
#define MAX_CONSUMERS 8

static const char *cq_host;
static int cq_port;

static double cq_now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + t.tv_nsec * 1e-9;
}

static void cq_die(const char *what, const char *why) {
    fprintf(stderr, "cluster_queue: %s: %s\n", what, why);
    exit(1);
}

static redisContext *cq_connect(void) {
    redisContext *c = redisConnect(cq_host, cq_port);
    if (!c || c->err) cq_die("connect", c ? c->errstr : "out of memory");
    return c;
}

/* One command; its reply, or the program stops naming the command. */
static redisReply *cq_cmd(redisContext *c, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    redisReply *r = redisvCommand(c, fmt, ap);
    va_end(ap);
    if (!r) cq_die(fmt, c->errstr);
    if (r->type == REDIS_REPLY_ERROR) cq_die(fmt, r->str);
    return r;
}

static void cq_do(redisContext *c, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    redisReply *r = redisvCommand(c, fmt, ap);
    va_end(ap);
    if (!r) cq_die(fmt, c->errstr);
    if (r->type == REDIS_REPLY_ERROR) cq_die(fmt, r->str);
    freeReplyObject(r);
}

/* An empty stream with its consumer group, as a node makes it. */
static void cq_reset(redisContext *c) {
    cq_do(c, "DEL " STREAM " " STREAM_HIGH " " STREAM_NORMAL);
    cq_do(c, "XGROUP CREATE " STREAM " " GROUP " 0 MKSTREAM");
    cq_do(c, "XGROUP CREATE " STREAM_HIGH " " GROUP " 0 MKSTREAM");
    cq_do(c, "XGROUP CREATE " STREAM_NORMAL " " GROUP " 0 MKSTREAM");
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double cq_median(double *v, int n) {
    qsort(v, n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : (v[n / 2 - 1] + v[n / 2]) / 2;
}

static void cq_row(const char *op, int callers, double *us, double *rate, int runs) {
    printf("%-44s %7d %10.1f %12.0f\n", op, callers, cq_median(us, runs), cq_median(rate, runs));
    fflush(stdout);
}

/* --- enqueue ---------------------------------------------------------- */

static void cq_enqueue_one(redisContext *c, int items, double *us, double *rate) {
    cq_reset(c);
    double t0 = cq_now();
    for (int i = 0; i < items; i++)
        cq_do(c, "XADD " STREAM " * job %s frame 0 tile %d", "0123456789abcdef0123456789abcdef", i);
    double dt = cq_now() - t0;
    *us = dt * 1e6 / items;
    *rate = items / dt;
}

static void cq_enqueue_multi(redisContext *c, int items, double *us, double *rate) {
    cq_reset(c);
    double t0 = cq_now();
    redisAppendCommand(c, "MULTI");
    for (int i = 0; i < items; i++)
        redisAppendCommand(c, "XADD " STREAM " * job %s frame 0 tile %d",
                           "0123456789abcdef0123456789abcdef", i);
    redisAppendCommand(c, "EXEC");
    for (int i = 0; i < items + 2; i++) {
        redisReply *r;
        if (redisGetReply(c, (void **)&r) != REDIS_OK) cq_die("MULTI XADD", c->errstr);
        if (r->type == REDIS_REPLY_ERROR) cq_die("MULTI XADD", r->str);
        freeReplyObject(r);
    }
    double dt = cq_now() - t0;
    *us = dt * 1e6 / items;
    *rate = items / dt;
}

/* --- claim and ack by N consumers -------------------------------------- */

struct cq_consumer {
    int id;
    pthread_barrier_t *start;
    char **ids; /* the entry ids it claimed */
    int n, cap;
    double claim_s, ack_s;
};

/* rayd's take script (cluster_items.c), with every item in its last stream. */
static bool cq_take;
static const char cq_take_lua[] =
    "for i = 1, #KEYS do\n"
    "  local r = redis.call('XREADGROUP', 'GROUP', 'render', ARGV[1], 'COUNT', 1, 'STREAMS', "
    "KEYS[i], '>')\n"
    "  if r then return {tostring(i - 1), r[1][2]} end\n"
    "end\n"
    "return false\n";

/* XREADGROUP COUNT 1 (or the take) until nothing new: the entry id, or NULL. */
static char *cq_claim(redisContext *c, const char *name) {
    char *id = NULL;
    if (cq_take) {
        redisReply *r = cq_cmd(c, "EVAL %s 3 " STREAM_HIGH " " STREAM_NORMAL " " STREAM " %s",
                               cq_take_lua, name);
        if (r->type == REDIS_REPLY_ARRAY && r->elements == 2 && r->element[1]->elements == 1)
            id = strdup(r->element[1]->element[0]->element[0]->str);
        freeReplyObject(r);
        return id;
    }
    redisReply *r = cq_cmd(c, "XREADGROUP GROUP " GROUP " %s COUNT 1 STREAMS " STREAM " >", name);
    if (r->type == REDIS_REPLY_ARRAY && r->elements == 1) {
        redisReply *entries = r->element[0]->element[1];
        if (entries->elements == 1) id = strdup(entries->element[0]->element[0]->str);
    }
    freeReplyObject(r);
    return id;
}

static void *cq_consumer_main(void *arg) {
    struct cq_consumer *w = arg;
    redisContext *c = cq_connect();
    char name[32];
    snprintf(name, sizeof name, "node%d", w->id);
    pthread_barrier_wait(w->start);
    double t0 = cq_now();
    for (char *id; (id = cq_claim(c, name));) {
        if (w->n == w->cap) {
            w->cap = w->cap ? 2 * w->cap : 1024;
            w->ids = realloc(w->ids, w->cap * sizeof *w->ids);
            if (!w->ids) cq_die("claim", "out of memory");
        }
        w->ids[w->n++] = id;
    }
    w->claim_s = cq_now() - t0;
    pthread_barrier_wait(w->start);
    t0 = cq_now();
    for (int i = 0; i < w->n; i++) { /* XACK and XDEL in one round trip */
        redisAppendCommand(c, "XACK " STREAM " " GROUP " %s", w->ids[i]);
        redisAppendCommand(c, "XDEL " STREAM " %s", w->ids[i]);
        for (int k = 0; k < 2; k++) {
            redisReply *r;
            if (redisGetReply(c, (void **)&r) != REDIS_OK) cq_die("XACK/XDEL", c->errstr);
            if (r->type != REDIS_REPLY_INTEGER || r->integer != 1) cq_die("XACK/XDEL", "not 1");
            freeReplyObject(r);
        }
        free(w->ids[i]);
    }
    w->ack_s = cq_now() - t0;
    redisFree(c);
    return NULL;
}

/* N consumers claim then ack ITEMS items; the phases' figures. */
static void cq_claim_ack(redisContext *c, int items, int n, double *claim_us, double *claim_rate,
                         double *ack_us, double *ack_rate) {
    cq_reset(c);
    cq_do(c, "MULTI");
    for (int i = 0; i < items; i++) cq_do(c, "XADD " STREAM " * job x frame 0 tile %d", i);
    cq_do(c, "EXEC");
    pthread_barrier_t start;
    pthread_barrier_init(&start, NULL, n);
    struct cq_consumer w[MAX_CONSUMERS];
    pthread_t th[MAX_CONSUMERS];
    for (int k = 0; k < n; k++) {
        w[k] = (struct cq_consumer){.id = k, .start = &start};
        if (pthread_create(&th[k], NULL, cq_consumer_main, &w[k]))
            cq_die("thread", strerror(errno));
    }
    double claim_wall = 0, ack_wall = 0, claim_sum = 0, ack_sum = 0;
    int total = 0;
    for (int k = 0; k < n; k++) {
        pthread_join(th[k], NULL);
        free(w[k].ids);
        total += w[k].n;
        claim_wall = w[k].claim_s > claim_wall ? w[k].claim_s : claim_wall;
        ack_wall = w[k].ack_s > ack_wall ? w[k].ack_s : ack_wall;
        claim_sum += w[k].claim_s;
        ack_sum += w[k].ack_s;
    }
    pthread_barrier_destroy(&start);
    if (total != items) cq_die("claim", "items lost or claimed twice");
    *claim_us = claim_sum * 1e6 / items; /* every caller's waiting over every item */
    *ack_us = ack_sum * 1e6 / items;
    *claim_rate = items / claim_wall;
    *ack_rate = items / ack_wall;
}

/* --- results: Redis strings against files on a volume ------------------- */

static void cq_redis_result(redisContext *c, const char *blob, size_t size, int items,
                            double *set_us, double *get_us) {
    double t0 = cq_now();
    for (int i = 0; i < items; i++) cq_do(c, "SET rayd:{bench}:tile:0:%d %b", i, blob, size);
    double t1 = cq_now();
    for (int i = 0; i < items; i++) {
        redisReply *r = cq_cmd(c, "GET rayd:{bench}:tile:0:%d", i);
        if (r->type != REDIS_REPLY_STRING || r->len != size) cq_die("GET", "wrong size");
        freeReplyObject(r);
    }
    double t2 = cq_now();
    for (int i = 0; i < items; i++) cq_do(c, "DEL rayd:{bench}:tile:0:%d", i);
    *set_us = (t1 - t0) * 1e6 / items;
    *get_us = (t2 - t1) * 1e6 / items;
}

static void cq_write_file(const char *dir, int i, const char *blob, size_t size) {
    char tmp[4096], path[4096];
    snprintf(tmp, sizeof tmp, "%s/tile-0-%d.png.tmp", dir, i);
    snprintf(path, sizeof path, "%s/tile-0-%d.png", dir, i);
    int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd < 0) cq_die(tmp, strerror(errno));
    if (write(fd, blob, size) != (ssize_t)size || fsync(fd)) cq_die(tmp, strerror(errno));
    close(fd);
    if (rename(tmp, path)) cq_die(path, strerror(errno));
}

static void cq_read_file(const char *dir, int i, char *buf, size_t size) {
    char path[4096];
    snprintf(path, sizeof path, "%s/tile-0-%d.png", dir, i);
    int fd = open(path, O_RDONLY);
    if (fd < 0) cq_die(path, strerror(errno));
    if (read(fd, buf, size + 1) != (ssize_t)size) cq_die(path, "short read");
    close(fd);
}

static void cq_file_result(const char *dir, const char *blob, size_t size, int items,
                           double *put_us, double *get_us) {
    char *buf = malloc(size + 1);
    if (!buf) cq_die("read", "out of memory");
    double t0 = cq_now();
    for (int i = 0; i < items; i++) cq_write_file(dir, i, blob, size);
    double t1 = cq_now();
    for (int i = 0; i < items; i++) cq_read_file(dir, i, buf, size);
    double t2 = cq_now();
    for (int i = 0; i < items; i++) {
        char path[4096];
        snprintf(path, sizeof path, "%s/tile-0-%d.png", dir, i);
        unlink(path);
    }
    free(buf);
    *put_us = (t1 - t0) * 1e6 / items;
    *get_us = (t2 - t1) * 1e6 / items;
}

static char *cq_blob(size_t size) {
    char *blob = malloc(size);
    if (!blob) cq_die("blob", "out of memory");
    for (size_t i = 0; i < size; i++) blob[i] = (char)(rand() >> 7);
    return blob;
}

static void cq_results(redisContext *c, const char *dir, size_t kb, int items, int runs) {
    size_t size = kb * 1024;
    char *blob = cq_blob(size);
    double su[MAX_RUNS], sr[MAX_RUNS], gu[MAX_RUNS], gr[MAX_RUNS];
    double fu[MAX_RUNS], fr[MAX_RUNS], ru[MAX_RUNS], rr[MAX_RUNS];
    for (int r = 0; r < runs; r++) {
        cq_redis_result(c, blob, size, items, &su[r], &gu[r]);
        cq_file_result(dir, blob, size, items, &fu[r], &ru[r]);
        sr[r] = 1e6 / su[r], gr[r] = 1e6 / gu[r], fr[r] = 1e6 / fu[r], rr[r] = 1e6 / ru[r];
    }
    char op[64];
    snprintf(op, sizeof op, "result %zu KB: Redis SET", kb);
    cq_row(op, 1, su, sr, runs);
    snprintf(op, sizeof op, "result %zu KB: Redis GET", kb);
    cq_row(op, 1, gu, gr, runs);
    snprintf(op, sizeof op, "result %zu KB: file write+fsync+rename", kb);
    cq_row(op, 1, fu, fr, runs);
    snprintf(op, sizeof op, "result %zu KB: file open+read", kb);
    cq_row(op, 1, ru, rr, runs);
    free(blob);
}

/* The same SET and GET with the AOF off: what durability costs a result. */
static void cq_results_no_aof(redisContext *c, size_t kb, int items, int runs) {
    size_t size = kb * 1024;
    char *blob = cq_blob(size);
    double su[MAX_RUNS], sr[MAX_RUNS], gu[MAX_RUNS], gr[MAX_RUNS];
    for (int r = 0; r < runs; r++) {
        cq_redis_result(c, blob, size, items, &su[r], &gu[r]);
        sr[r] = 1e6 / su[r], gr[r] = 1e6 / gu[r];
    }
    char op[64];
    snprintf(op, sizeof op, "result %zu KB: Redis SET, AOF off", kb);
    cq_row(op, 1, su, sr, runs);
    snprintf(op, sizeof op, "result %zu KB: Redis GET, AOF off", kb);
    cq_row(op, 1, gu, gr, runs);
    free(blob);
}

int main(int argc, char **argv) {
    if (argc < 4) {
        fprintf(stderr, "usage: cluster_queue HOST PORT DIR [ITEMS RUNS]\n");
        return 2;
    }
    cq_host = argv[1];
    cq_port = atoi(argv[2]);
    const char *dir = argv[3];
    int items = argc > 4 ? atoi(argv[4]) : 5000;
    int runs = argc > 5 ? atoi(argv[5]) : 5;
    if (items < 1 || runs < 1 || runs > MAX_RUNS) cq_die("usage", "ITEMS >= 1, RUNS 1..32");
    redisContext *c = cq_connect();
    printf("-- %d items, median of %d runs\n", items, runs);
    printf("%-44s %7s %10s %12s\n", "operation", "callers", "us/item", "items/s");
    double us[MAX_RUNS], rate[MAX_RUNS], us2[MAX_RUNS], rate2[MAX_RUNS];
    for (int r = 0; r < runs; r++) cq_enqueue_one(c, items, &us[r], &rate[r]);
    cq_row("enqueue: XADD, one call each", 1, us, rate, runs);
    for (int r = 0; r < runs; r++) cq_enqueue_multi(c, items, &us[r], &rate[r]);
    cq_row("enqueue: XADD, all in one MULTI", 1, us, rate, runs);
    for (int n = 1; n <= MAX_CONSUMERS; n *= 2) {
        for (int r = 0; r < runs; r++)
            cq_claim_ack(c, items, n, &us[r], &rate[r], &us2[r], &rate2[r]);
        cq_row("claim: XREADGROUP COUNT 1", n, us, rate, runs);
        cq_row("ack: XACK + XDEL (one round trip)", n, us2, rate2, runs);
    }
    cq_take = true;
    for (int n = 1; n <= MAX_CONSUMERS; n *= 2) {
        for (int r = 0; r < runs; r++)
            cq_claim_ack(c, items, n, &us[r], &rate[r], &us2[r], &rate2[r]);
        cq_row("claim: take script, 3rd of 3 streams", n, us, rate, runs);
    }
    cq_take = false;
    cq_do(c, "DEL " STREAM " " STREAM_HIGH " " STREAM_NORMAL);
    int n20 = items / 5 > 0 ? items / 5 : 1, n200 = items / 50 > 0 ? items / 50 : 1;
    cq_results(c, dir, 20, n20, runs);
    cq_results(c, dir, 200, n200, runs);
    cq_do(c, "CONFIG SET appendonly no");
    cq_results_no_aof(c, 20, n20, runs);
    cq_results_no_aof(c, 200, n200, runs);
    redisFree(c);
    return 0;
}
