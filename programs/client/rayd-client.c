/* rayd-client.c -- the command line of rayd-client.
 *
 *   rayd-client render SCENE.json -o OUT.png --server URL [--server URL ...]
 *               [--tile 128 | --split-samples N] [--parallel N] [--retries N]
 *               [--timeout S] [--threads N] [--no-hedge]
 *               [--token-file F] [--quiet]
 *   rayd-client render --progressive SCENE.json -o OUT.png|OUT.exr --server URL
 *               [--pass-step K] [--time-budget S] [--noise-target E] [--detach]
 *   rayd-client job SCENE.json -o OUT.png|OUT.exr --server URL [--token-file F]
 *               [--frames A-B] [--video OUT.mp4] [--detach]
 *               (an animated scene: -o 'shot-%04d.png')
 *   rayd-client watch ID [-o OUT.png|OUT.exr|PATTERN] [--video OUT.mp4]
 *               --server URL
 *   rayd-client health --server URL [--server URL ...]
 *   rayd-client thumbnails DIR [-o OUTDIR] [--size N] [--view V] [--turntable N]
 *                          --server URL ...
 *
 * `render` splits one frame into tiles (or, --split-samples, its samples
 * into ranges) and spreads them over every server given (rayd nodes, or
 * one balancer in front of many: tiles.c); `job` uses
 * the asynchronous job API of one server (job.c); `render --progressive`
 * makes a progressive job of it, each pass written to -o as it arrives,
 * and `watch` follows an existing job by its id (watch.c); `health` asks each
 * server's /healthz and /readyz; `thumbnails` renders every model of a
 * folder in a studio scene, each as a render (thumbnails.c).  The scene is read, its files inlined
 * and validated locally before anything is sent (scenefile.c).  RAYD_SERVER gives a default server,
 * RAYD_TOKEN_FILE a default token file.
 *
 * The command line follows the convention of the three tools (rayd,
 * rayd-render, rayd-client): getopt_long, so "--tile 64" and "--tile=64"
 * are the same and options may come before or after the command; -h/--help
 * to stdout, --version; "-o -" is standard output; errors are one line
 * "rayd-client: error: ..." on stderr.
 *
 * Exit status: 0 success; 1 failure: the scene or job was refused (the
 * server's JSON error is printed), a server is unhealthy, an incomplete
 * image (nothing is written), a transport or write error; 2 a usage error;
 * 130 interrupted.
 */
#include "client.h"

#include <cjson/cJSON.h>
#include <curl/curl.h>
#include <errno.h>
#include <getopt.h>
#include <stdio.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include <rayd/rayd.h>

#define CLIENT_USAGE_EXIT 2

static void client_usage(FILE *f) {
    fprintf(
        f, "usage: rayd-client render SCENE.json -o OUT.png --server URL [--server URL ...]\n"
           "                          [--tile N | --split-samples N] [--parallel N] [--retries N]\n"
           "                          [--timeout S] [--threads N] [--no-hedge]\n"
           "                          [--token-file F] [--quiet]\n"
           "       rayd-client render --progressive SCENE.json -o OUT.png|OUT.exr --server URL\n"
           "                          [--pass-step K] [--time-budget S] [--noise-target E]\n"
           "                          [--detach] [--token-file F] [--quiet]\n"
           "       rayd-client job SCENE.json -o OUT.png|OUT.exr --server URL [--token-file F]\n"
           "                       [--frames A-B] [--video OUT.mp4] [--detach] [--quiet]\n"
           "       rayd-client watch ID [-o OUT.png|OUT.exr|PATTERN] [--video OUT.mp4]\n"
           "                         --server URL [--token-file F]\n"
           "       rayd-client health --server URL [--server URL ...] [--token-file F]\n"
           "       rayd-client thumbnails DIR [-o OUTDIR] [--size N] [--view V] [--turntable N]\n"
           "                              --server URL ...\n"
           "\n"
           "  --server URL      a rayd node or a balancer in front of many (repeatable;\n"
           "                    default $RAYD_SERVER or http://127.0.0.1:8080)\n"
           "  -o, --output F    the PNG to write (only when every tile arrived), '-' for\n"
           "                    standard output; with\n"
           "                    --split-samples or job, F.exr writes the linear OpenEXR\n"
           "  --tile N          tile edge in pixels (default 128); not with --split-samples\n"
           "  --split-samples N split the frame's samples, not its pixels, into N ranges:\n"
           "                    each server returns its range's exact sums, added here\n"
           "                    (the same bytes as one render)\n"
           "  --parallel N      requests in flight, all servers together\n"
           "                    (default 8 for one server, 4 per server for a list)\n"
           "  --retries N       further attempts of a failed tile, on another server (default 3)\n"
           "  --timeout S       seconds per request (default 120)\n"
           "  --no-hedge        never send a copy of a straggling tile to a second server\n"
           "                    (by default, once no tile is left to start, a tile in flight\n"
           "                    over 2x the median tile time and 1 s is copied once)\n"
           "  --token-file F    bearer token file (default $RAYD_TOKEN_FILE)\n"
           "  --threads N       threads encoding the stitched PNG (default 0: every core)\n"
           "  --frames A-B      job: frames A to B of an animated scene (K: frame K alone;\n"
           "                    default: all of them), one file a frame: -o 'shot-%%04d.png'\n"
           "                    (%%d, %%0Nd)\n"
           "  --video F.mp4     job, watch: also the frames as an H.264 MP4, once all are done\n"
           "  --progressive     render: one progressive job on one server, each pass\n"
           "                    written to -o as it arrives; Ctrl-C cancels the job\n"
           "  --pass-step K     render --progressive: a pass every K samples (default:\n"
           "                    1, 2, 4, 8, ... up to the scene's samples)\n"
           "  --time-budget S   render --progressive: end with the latest pass after S s\n"
           "  --noise-target E  render --progressive: end once a pass's noise is <= E\n"
           "  --detach          render --progressive, job of frames: print the job's id and\n"
           "                    leave it running (watch ID follows it, a frame range's\n"
           "                    frames to -o's pattern; Ctrl-C in watch leaves the job\n"
           "                    running too)\n"
           "  --size N          thumbnails: the PNGs' width and height (default 256)\n"
           "  --view V          thumbnails: three-quarter (default), front, side or top;\n"
           "                    -o is the output folder (default .)\n"
           "  --turntable N     thumbnails: N frames a model, NAME-000.png ..., the view\n"
           "                    turned about the vertical in steps of 360/N degrees (1-360)\n"
           "  -q, --quiet       no progress output\n"
           "  -h, --help        this text\n"
           "  --version         print 'rayd-client VERSION'\n"
           "\n"
           "-o - writes the image to standard output (status lines go to stderr).\n"
           "Options take their value as '--opt value' or '--opt=value'.\n"
           "Errors are one line on stderr: 'rayd-client: error: ...'.\n"
           "Exit status: 0 done, 1 failure (refused, unhealthy, incomplete image,\n"
           "transport or write error), 2 usage error, 130 interrupted.\n");
}

static char *client_read_token(const char *path) {
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "rayd-client: error: cannot read token file %s: %s\n", path,
                strerror(errno));
        return NULL;
    }
    char buf[4096];
    size_t n = fread(buf, 1, sizeof buf - 1, f);
    fclose(f);
    buf[n] = '\0';
    while (n &&
           (buf[n - 1] == '\n' || buf[n - 1] == '\r' || buf[n - 1] == ' ' || buf[n - 1] == '\t'))
        buf[--n] = '\0';
    if (!n || strpbrk(buf, "\r\n")) {
        fprintf(stderr, "rayd-client: error: token file %s is empty or has several lines\n", path);
        return NULL;
    }
    return strdup(buf);
}

static int client_number(const char *opt, const char *v, double lo, double hi, double *out) {
    if (args_double(v, lo, hi, out) == 0) return 0;
    return args_bad("%s needs a number in %g..%g, not '%s'", opt, lo, hi, v ? v : "");
}

/* ---- health ---------------------------------------------------------------- */

static long client_get(const struct client_opts *o, const char *url, struct net_buf *b, char *why,
                       size_t size) {
    void *hdrs = NULL;
    CURL *h = net_easy(o, url, b, NULL, 0, &hdrs);
    if (!h) {
        snprintf(why, size, "out of memory");
        return 0;
    }
    return net_perform(h, hdrs, why, size);
}

/* The "version" of a /healthz answer into v, escaped to be printed ("" when
 * it has none). */
static void client_live_version(const struct net_buf *b, char *v, size_t size) {
    cJSON *j = cJSON_ParseWithLength(b->data, b->len);
    const cJSON *ver = cJSON_GetObjectItemCaseSensitive(j, "version");
    net_safe(cJSON_IsString(ver) ? ver->valuestring : "", v, size);
    cJSON_Delete(j);
}

/* The cluster line of a rayd --redis node's /healthz ("SERVER: cluster: redis
 * up at ADDR, N nodes, Q items queued, F in flight"), if it has one; 1 when
 * its Redis is down (its job routes answer 503). */
static int client_cluster(const char *server, const struct net_buf *b) {
    cJSON *j = cJSON_ParseWithLength(b->data, b->len);
    const cJSON *c = cJSON_GetObjectItemCaseSensitive(j, "cluster");
    int bad = 0;
    if (cJSON_IsObject(c)) {
        char addr[200], why[300], other[300] = "";
        const cJSON *redis = cJSON_GetObjectItemCaseSensitive(c, "redis");
        const cJSON *a = cJSON_GetObjectItemCaseSensitive(c, "address");
        const cJSON *reason = cJSON_GetObjectItemCaseSensitive(c, "reason");
        const cJSON *n = cJSON_GetObjectItemCaseSensitive(c, "nodes");
        const cJSON *q = cJSON_GetObjectItemCaseSensitive(c, "queued");
        const cJSON *f = cJSON_GetObjectItemCaseSensitive(c, "in_flight");
        const cJSON *ov = cJSON_GetObjectItemCaseSensitive(c, "other_versions");
        bool up = cJSON_IsString(redis) && !strcmp(redis->valuestring, "up");
        net_safe(cJSON_IsString(a) ? a->valuestring : "?", addr, sizeof addr);
        net_safe(cJSON_IsString(reason) ? reason->valuestring : "no reason given", why, sizeof why);
        const cJSON *v;
        cJSON_ArrayForEach(v, ov) if (cJSON_IsString(v) && !other[0]) {
            char s[200];
            snprintf(other, sizeof other, "; %s", net_safe(v->valuestring, s, sizeof s));
        }
        if (up)
            printf(
                "%s: cluster: redis up at %s, %.0f node%s, %.0f items queued, %.0f in flight%s\n",
                server, addr, cJSON_IsNumber(n) ? n->valuedouble : -1,
                cJSON_IsNumber(n) && n->valuedouble == 1 ? "" : "s",
                cJSON_IsNumber(q) ? q->valuedouble : -1, cJSON_IsNumber(f) ? f->valuedouble : -1,
                other);
        else
            printf("%s: cluster: redis DOWN at %s (%s): its job routes answer 503\n", server, addr,
                   why);
        bad = !up;
    }
    cJSON_Delete(j);
    return bad;
}

/* The jobs part of a ready line: ", jobs 1/1024" (unfinished of --max-jobs),
 * and why new jobs are refused when /readyz says so ("" from a rayd that
 * counts no jobs). */
static void client_ready_jobs(const cJSON *j, char *buf, size_t size) {
    const cJSON *n = cJSON_GetObjectItemCaseSensitive(j, "jobs");
    const cJSON *max = cJSON_GetObjectItemCaseSensitive(j, "max_jobs");
    const cJSON *refused = cJSON_GetObjectItemCaseSensitive(j, "jobs_refused");
    buf[0] = 0;
    if (cJSON_IsNumber(n) && cJSON_IsNumber(max))
        snprintf(buf, size, ", jobs %.0f/%.0f", n->valuedouble, max->valuedouble);
    if (cJSON_IsString(refused)) {
        size_t used = strlen(buf);
        char why[300];
        snprintf(buf + used, size - used, "; jobs refused: %s",
                 net_safe(refused->valuestring, why, sizeof why));
    }
}

/* One line for a live server: its version and /readyz.  1 when not ready
 * (a server that refuses new jobs but takes renders is ready: it says so). */
static int client_ready(const struct client_opts *o, const char *server, const char *version) {
    char url[1024], why[600] = "", live[112], jobs[400];
    struct net_buf b = {0};
    snprintf(live, sizeof live, "live (%s%s)", *version ? "rayd " : "version not said", version);
    snprintf(url, sizeof url, "%s/readyz", server);
    long ready = client_get(o, url, &b, why, sizeof why);
    cJSON *j = ready == 200 ? cJSON_ParseWithLength(b.data, b.len) : NULL;
    int not_ready = !j;
    if (j) {
        const cJSON *q = cJSON_GetObjectItemCaseSensitive(j, "queued");
        const cJSON *c = cJSON_GetObjectItemCaseSensitive(j, "capacity");
        const cJSON *w = cJSON_GetObjectItemCaseSensitive(j, "workers");
        const cJSON *busy = cJSON_GetObjectItemCaseSensitive(j, "busy");
        client_ready_jobs(j, jobs, sizeof jobs);
        printf("%s: %s, ready (queue %d/%d, workers %d busy of %d%s)\n", server, live,
               cJSON_IsNumber(q) ? q->valueint : -1, cJSON_IsNumber(c) ? c->valueint : -1,
               cJSON_IsNumber(busy) ? busy->valueint : -1, cJSON_IsNumber(w) ? w->valueint : -1,
               jobs);
        cJSON_Delete(j);
    } else {
        if (ready) net_describe(ready, &b, why, sizeof why);
        printf("%s: %s, not ready (%s)\n", server, live, why);
    }
    net_buf_free(&b);
    return not_ready;
}

/* Every server live and ready, and all of one rayd version (a frame is
 * stitched from one version only, and render refuses a mix): 0, else 1. */
static int client_health(const struct client_opts *o) {
    int bad = 0, first = -1;
    bool mixed = false; /* said once */
    char version0[64] = "";
    for (int i = 0; i < o->nservers; i++) {
        char url[1024], why[600] = "", version[64];
        struct net_buf b = {0};
        snprintf(url, sizeof url, "%s/healthz", o->servers[i]);
        long live = client_get(o, url, &b, why, sizeof why);
        if (live != 200) {
            if (live) net_describe(live, &b, why, sizeof why);
            printf("%s: down (%s)\n", o->servers[i], why);
            bad = 1;
            net_buf_free(&b);
            continue;
        }
        client_live_version(&b, version, sizeof version);
        bad |= client_ready(o, o->servers[i], version);
        bad |= client_cluster(o->servers[i], &b);
        net_buf_free(&b);
        if (first < 0) {
            first = i;
            snprintf(version0, sizeof version0, "%s", version);
        } else if (strcmp(version, version0) && !mixed) {
            fprintf(stderr,
                    "rayd-client: error: %s runs %s%s and %s %s%s: a frame needs one rayd version "
                    "on every node\n",
                    o->servers[first], *version0 ? "rayd " : "a rayd that does not say its version",
                    version0, o->servers[i],
                    *version ? "rayd " : "a rayd that does not say its version", version);
            mixed = true;
        }
    }
    return bad || mixed ? 1 : 0;
}

/* ---- the command line ------------------------------------------------------ */

/* The long options; those without a short letter are numbered from 256. */
enum {
    OPT_TILE = 256,
    OPT_SPLIT,
    OPT_PARALLEL,
    OPT_RETRIES,
    OPT_TIMEOUT,
    OPT_TOKEN_FILE,
    OPT_THREADS,
    OPT_VERSION,
    OPT_SIZE,
    OPT_VIEW,
    OPT_TURNTABLE,
    OPT_NO_HEDGE,
    OPT_FRAMES,
    OPT_VIDEO,
    OPT_PROGRESSIVE,
    OPT_DETACH,
    OPT_PASS_STEP,
    OPT_TIME_BUDGET,
    OPT_NOISE_TARGET
};
static const struct option client_options[] = {
    {"server", required_argument, NULL, 's'},
    {"output", required_argument, NULL, 'o'},
    {"tile", required_argument, NULL, OPT_TILE},
    {"split-samples", required_argument, NULL, OPT_SPLIT},
    {"parallel", required_argument, NULL, OPT_PARALLEL},
    {"retries", required_argument, NULL, OPT_RETRIES},
    {"timeout", required_argument, NULL, OPT_TIMEOUT},
    {"token-file", required_argument, NULL, OPT_TOKEN_FILE},
    {"threads", required_argument, NULL, OPT_THREADS},
    {"size", required_argument, NULL, OPT_SIZE},
    {"view", required_argument, NULL, OPT_VIEW},
    {"turntable", required_argument, NULL, OPT_TURNTABLE},
    {"no-hedge", no_argument, NULL, OPT_NO_HEDGE},
    {"frames", required_argument, NULL, OPT_FRAMES},
    {"video", required_argument, NULL, OPT_VIDEO},
    {"progressive", no_argument, NULL, OPT_PROGRESSIVE},
    {"detach", no_argument, NULL, OPT_DETACH},
    {"pass-step", required_argument, NULL, OPT_PASS_STEP},
    {"time-budget", required_argument, NULL, OPT_TIME_BUDGET},
    {"noise-target", required_argument, NULL, OPT_NOISE_TARGET},
    {"quiet", no_argument, NULL, 'q'},
    {"help", no_argument, NULL, 'h'},
    {"version", no_argument, NULL, OPT_VERSION},
    {NULL, 0, NULL, 0},
};

struct client_args {
    struct client_opts o;
    const char *cmd, *scene, *token_file;
    int size;         /* thumbnails: --size */
    const char *view; /* thumbnails: --view */
    int turntable;    /* thumbnails: --turntable, 0 = none */
    unsigned given;   /* bit opt - OPT_TILE: that long option was given */
};

/* The long options only some commands use, and which: any other command
 * would drop them unsaid (a job renders whole on its server; only the
 * thumbnails pose a model). */
static const struct {
    int opt;
    const char *name, *cmds;
} client_only[] = {
    {OPT_TILE, "--tile", "render and thumbnails"},
    {OPT_SPLIT, "--split-samples", "render and thumbnails"},
    {OPT_PARALLEL, "--parallel", "render and thumbnails"},
    {OPT_RETRIES, "--retries", "render and thumbnails"},
    {OPT_THREADS, "--threads", "render and thumbnails"},
    {OPT_NO_HEDGE, "--no-hedge", "render and thumbnails"},
    {OPT_SIZE, "--size", "thumbnails"},
    {OPT_VIEW, "--view", "thumbnails"},
    {OPT_TURNTABLE, "--turntable", "thumbnails"},
    {OPT_FRAMES, "--frames", "job"},
    {OPT_VIDEO, "--video", "job and watch"},
    {OPT_PROGRESSIVE, "--progressive", "render"},
    {OPT_DETACH, "--detach", "render --progressive and job"},
    {OPT_PASS_STEP, "--pass-step", "render --progressive"},
    {OPT_TIME_BUDGET, "--time-budget", "render --progressive"},
    {OPT_NOISE_TARGET, "--noise-target", "render --progressive"},
};

/* 0, or -1 after saying which given option cmd does not take. */
static int client_for_cmd(const struct client_args *a) {
    for (size_t i = 0; i < sizeof client_only / sizeof client_only[0]; i++) {
        char word[32], list[64]; /* " cmd " among " render and thumbnails " */
        snprintf(word, sizeof word, " %s ", a->cmd);
        snprintf(list, sizeof list, " %s ", client_only[i].cmds);
        if ((a->given >> (client_only[i].opt - OPT_TILE) & 1) && !strstr(list, word))
            return args_bad("%s is not an option of %s (only of %s)", client_only[i].name, a->cmd,
                            client_only[i].cmds);
    }
    return 0;
}

/* A value of render --progressive's query: a plain decimal (digits, at
 * most one point, as the server takes them), whole when asked, in lo..hi
 * (above 0 when lo is 0, as rayd's rule for time_budget and noise_target
 * says it), kept as written into *out; -1 after saying why. */
static int client_decimal(const char *name, const char *v, double lo, double hi, bool whole,
                          const char **out) {
    double d;
    size_t digits = v ? strspn(v, "0123456789") : 0;
    bool plain = v && digits > 0 &&
                 (!v[digits] || (!whole && v[digits] == '.' &&
                                 strspn(v + digits + 1, "0123456789") == strlen(v + digits + 1)));
    if (!plain || args_double(v, lo, hi, &d) != 0 || (lo == 0 && d == 0)) {
        char range[80];
        if (lo == 0)
            snprintf(range, sizeof range, "above 0 and at most %.10g", hi);
        else
            snprintf(range, sizeof range, "in %.10g..%.10g", lo, hi);
        return args_bad("%s needs a %s %s (digits%s), not '%s'", name,
                        whole ? "whole number" : "number", range, whole ? "" : ", one point",
                        v ? v : "");
    }
    *out = v;
    return 0;
}

/* A whole number option's value into *out; -1 after saying why. */
static int client_int(int opt, const char *v, double lo, double hi, int *out) {
    const char *name = opt == OPT_TILE        ? "--tile"
                       : opt == OPT_SPLIT     ? "--split-samples"
                       : opt == OPT_PARALLEL  ? "--parallel"
                       : opt == OPT_RETRIES   ? "--retries"
                       : opt == OPT_SIZE      ? "--size"
                       : opt == OPT_TURNTABLE ? "--turntable"
                                              : "--threads";
    double d;
    if (client_number(name, v, lo, hi, &d)) return -1;
    if (d != (int)d) return args_bad("%s needs a whole number, not '%s'", name, v);
    *out = (int)d;
    return 0;
}

/* One option; v is its value (NULL when it was missing).  0, 1 when done
 * (--help, --version), -1 after saying why. */
static int client_option(int opt, const char *v, struct client_args *a) {
    struct client_opts *o = &a->o;
    if (opt >= OPT_TILE) a->given |= 1u << (opt - OPT_TILE);
    switch (opt) {
    case 'h': client_usage(stdout); return 1;
    case OPT_VERSION: printf("rayd-client %s\n", RAYD_VERSION); return 1;
    case 's':
        if (!v || o->nservers == CLIENT_MAX_SERVERS)
            return args_bad("--server needs a URL (at most %d)", CLIENT_MAX_SERVERS);
        o->servers[o->nservers++] = v;
        return 0;
    case 'o':
        if (!v) return args_bad("-o/--output needs a file name ('-': standard output)");
        o->out = v;
        return 0;
    case 'q': o->quiet = 1; return 0;
    case OPT_TOKEN_FILE:
        if (!v) return args_bad("--token-file needs a file");
        a->token_file = v;
        return 0;
    case OPT_TIMEOUT: return client_number("--timeout", v, 0.1, 86400, &o->timeout);
    case OPT_TILE: return client_int(opt, v, 8, 4096, &o->tile);
    case OPT_SPLIT: return client_int(opt, v, 1, 65536, &o->ranges);
    case OPT_PARALLEL: return client_int(opt, v, 1, 1024, &o->parallel);
    case OPT_RETRIES: return client_int(opt, v, 0, 100, &o->retries);
    case OPT_THREADS: return client_int(opt, v, 0, 1024, &o->threads);
    case OPT_SIZE: return client_int(opt, v, 8, 4096, &a->size);
    case OPT_TURNTABLE: return client_int(opt, v, 1, 360, &a->turntable);
    case OPT_NO_HEDGE: o->no_hedge = 1; return 0;
    case OPT_FRAMES:
        if (!v || frame_name_range(v, &o->frame_a, &o->frame_b) != 0)
            return args_bad(
                "--frames takes A-B or K: frame numbers in 0..1000000, A <= B, not '%s'",
                v ? v : "");
        o->frames_set = 1;
        return 0;
    case OPT_VIDEO: {
        const char *dot = v ? strrchr(v, '.') : NULL;
        if (!dot || strcasecmp(dot, ".mp4"))
            return args_bad("--video writes the job's H.264 MP4: a .mp4 file, not '%s'",
                            v ? v : "");
        o->video = v;
        return 0;
    }
    case OPT_PROGRESSIVE: o->progressive = 1; return 0;
    case OPT_DETACH: o->detach = 1; return 0;
    case OPT_PASS_STEP: return client_decimal("--pass-step", v, 1, 1048576, true, &o->pass_step);
    case OPT_TIME_BUDGET:
        return client_decimal("--time-budget", v, 0, 86400, false, &o->time_budget); /* rayd's */
    case OPT_NOISE_TARGET:
        return client_decimal("--noise-target", v, 0, 1, false, &o->noise_target);
    case OPT_VIEW:
        if (!v || (strcmp(v, "three-quarter") && strcmp(v, "front") && strcmp(v, "side") &&
                   strcmp(v, "top")))
            return args_bad("--view needs three-quarter, front, side or top, not '%s'", v ? v : "");
        a->view = v;
        return 0;
    }
    return args_bad("unknown option");
}

/* The words that are not options: the command, then the scene. */
static int client_words(int argc, char **argv, struct client_args *a) {
    if (optind >= argc)
        return args_bad("no command given (render, job, watch, health or thumbnails)");
    a->cmd = argv[optind++];
    if (strcmp(a->cmd, "render") && strcmp(a->cmd, "job") && strcmp(a->cmd, "health") &&
        strcmp(a->cmd, "thumbnails") && strcmp(a->cmd, "watch"))
        return args_bad("unknown command '%s' (render, job, watch, health or thumbnails)", a->cmd);
    if (optind < argc && strcmp(a->cmd, "health")) a->scene = argv[optind++];
    if (optind < argc) return args_bad("unexpected argument '%s'", argv[optind]);
    return 0;
}

/* render --progressive's own options and exclusions: 0, or -1 said. */
static int client_progressive(const struct client_args *a) {
    const struct client_opts *o = &a->o;
    unsigned tiles = 0; /* the options of tiles, which a job on one server has none of */
    for (int opt = OPT_TILE; opt <= OPT_NO_HEDGE; opt++)
        if (opt != OPT_TIMEOUT && opt != OPT_TOKEN_FILE && opt != OPT_VERSION && opt != OPT_SIZE &&
            opt != OPT_VIEW && opt != OPT_TURNTABLE)
            tiles |= 1u << (opt - OPT_TILE);
    if (!o->progressive && (o->pass_step || o->time_budget || o->noise_target))
        return args_bad("--pass-step, --time-budget and --noise-target go with "
                        "render --progressive");
    if (!o->progressive && o->detach && strcmp(a->cmd, "job"))
        return args_bad("--detach goes with render --progressive and with job of frames");
    if (o->progressive && (a->given & tiles))
        return args_bad("render --progressive renders as one job on one server: --tile, "
                        "--split-samples, --parallel, --retries, --threads and --no-hedge are "
                        "for tiles");
    bool job = o->progressive || !strcmp(a->cmd, "watch");
    if (job && o->out && !strcmp(o->out, "-"))
        return args_bad("%s writes each pass into -o as it comes: give a file, not '-'",
                        o->progressive ? "render --progressive" : "watch");
    if (!strcmp(a->cmd, "watch") && a->scene &&
        (strlen(a->scene) != 32 || strspn(a->scene, "0123456789abcdef") != 32))
        return args_bad("watch: '%s' is no job id (32 hex digits, as POST /v1/jobs answers)",
                        a->scene);
    return 0;
}

/* The command line into a: 0, 1 when done (--help, --version), -1 on a
 * usage error (said).  Options and words may come in any order. */
static int client_parse(int argc, char **argv, struct client_args *a) {
    opterr = 0;
    int opt, rc;
    while ((opt = getopt_long(argc, argv, ":s:o:qh", client_options, NULL)) != -1) {
        if (opt == '?') return args_unknown(client_options, argv[optind - 1], optopt);
        rc = opt == ':' ? client_option(optopt, NULL, a) : client_option(opt, optarg, a);
        if (rc != 0) return rc;
    }
    if (client_words(argc, argv, a) != 0 || client_for_cmd(a) != 0) return -1;
    /* a range is always the whole image: a --tile would be dropped unsaid */
    if (a->o.tile && a->o.ranges > 0)
        return args_bad("--tile and --split-samples exclude each other (--split-samples sends "
                        "whole-image sample ranges, not tiles)");
    if (!strcmp(a->cmd, "thumbnails"))
        return a->scene ? 0 : args_bad("thumbnails needs DIR, the folder of models");
    if (client_progressive(a) != 0) return -1;
    if (!strcmp(a->cmd, "watch") && !a->scene)
        return args_bad("watch needs ID, the job's 32 hex digits (-o OUT.png to write its image)");
    if (strcmp(a->cmd, "health") && strcmp(a->cmd, "watch") && (!a->scene || !a->o.out))
        return args_bad("%s needs SCENE.json and -o OUT.png", a->cmd);
    if ((!strcmp(a->cmd, "job") || !strcmp(a->cmd, "watch") || a->o.progressive) &&
        a->o.nservers > 1)
        return args_bad("%s: give exactly one --server (a job is followed on the server it is "
                        "posted to)",
                        a->o.progressive ? "render --progressive" : a->cmd);
    if (a->o.out && !output_kind(a->o.out))
        return args_bad("-o %s: rayd-client writes PNG (.png) and OpenEXR (.exr), not this format",
                        a->o.out);
    bool exr = a->o.out && output_kind_exr(a->o.out);
    if (exr && strcmp(a->cmd, "job") && strcmp(a->cmd, "watch") && !a->o.progressive &&
        a->o.ranges <= 0) /* else a PNG named .exr */
        return args_bad("-o %s: OpenEXR comes only from render --split-samples N or from job "
                        "(tiles arrive as 8-bit PNGs)",
                        a->o.out);
    return 0;
}

/* The defaults, then the command line. */
static int client_args(int argc, char **argv, struct client_args *a) {
    memset(a, 0, sizeof *a);
    a->o.retries = 3, a->o.timeout = 120, a->o.parallel = 0;
    a->token_file = getenv("RAYD_TOKEN_FILE");
    int rc = client_parse(argc, argv, a);
    if (rc != 0) return rc;
    struct client_opts *o = &a->o;
    if (!o->tile) o->tile = 128; /* after the parse, which tells a given --tile by its 0 */
    if (!o->nservers) {
        const char *env = getenv("RAYD_SERVER");
        o->servers[o->nservers++] = env && *env ? env : "http://127.0.0.1:8080";
    }
    if (!o->parallel) o->parallel = o->nservers == 1 ? 8 : 4 * o->nservers;
    return 0;
}

/* The server URLs are used as prefixes: copies without a trailing slash
 * into urls (freed by the caller).  -1 on a URL that is none (said). */
static int client_urls(struct client_opts *o, char **urls) {
    for (int i = 0; i < o->nservers; i++) {
        size_t n = strlen(o->servers[i]);
        urls[i] = strdup(o->servers[i]);
        if (!urls[i]) return args_bad("out of memory");
        while (n > 0 && urls[i][n - 1] == '/') urls[i][--n] = '\0';
        if (strncmp(urls[i], "http://", 7) && strncmp(urls[i], "https://", 8))
            return args_bad("--server wants an http:// or https:// URL such as "
                            "http://host:8080, not '%s'",
                            urls[i]);
        o->servers[i] = urls[i];
    }
    return 0;
}

/* Runs the command: 0, 1 on a failure, 2 on a usage error (said). */
static int client_run(const struct client_args *a) {
    if (!strcmp(a->cmd, "health")) return client_health(&a->o);
    if (!strcmp(a->cmd, "thumbnails"))
        return thumbnails_run(&a->o, a->scene, a->o.out ? a->o.out : ".", a->size ? a->size : 256,
                              a->view ? a->view : "three-quarter", a->turntable);
    if (!strcmp(a->cmd, "watch")) return watch_job(&a->o, a->scene);
    struct scenefile sf;
    if (scenefile_load(a->scene, &sf) != 0) return 1;
    if (a->o.progressive && sf.animated) {
        prog_error("render --progressive renders one image: %s has an /animation (its frames "
                   "are a job: rayd-client job)",
                   a->scene);
        fprintf(stderr, "Try 'rayd-client --help'.\n");
        scenefile_free(&sf);
        return CLIENT_USAGE_EXIT;
    }
    bool frames = a->o.frames_set || sf.animated; /* a frame-range job */
    if (a->o.detach && !strcmp(a->cmd, "job") && !frames) {
        prog_error("--detach: %s has no /animation: job --detach leaves a frame range running "
                   "(one image: render --progressive --detach)",
                   a->scene);
        fprintf(stderr, "Try 'rayd-client --help'.\n");
        scenefile_free(&sf);
        return CLIENT_USAGE_EXIT;
    }
    if (a->o.video && !frames) {
        prog_error("--video %s: the scene has no /animation, so it has no frames to make a video "
                   "of",
                   a->o.video);
        fprintf(stderr, "Try 'rayd-client --help'.\n");
        scenefile_free(&sf);
        return CLIENT_USAGE_EXIT;
    }
    int rc = a->o.progressive        ? watch_render(&a->o, &sf)
             : strcmp(a->cmd, "job") ? tiles_render(&a->o, &sf)
             : frames                ? job_frames_run(&a->o, &sf)
                                     : job_run(&a->o, &sf);
    scenefile_free(&sf);
    return rc;
}

int main(int argc, char **argv) {
    struct client_args a;
    prog_init("rayd-client");
    int rc = client_args(argc, argv, &a);
    if (rc != 0) {
        if (rc < 0) fprintf(stderr, "Try 'rayd-client --help'.\n");
        return rc < 0 ? CLIENT_USAGE_EXIT : 0;
    }
    if (!strcmp(a.o.out ? a.o.out : "", "-") && isatty(STDOUT_FILENO)) {
        prog_error("-o - writes the image to standard output, which is a terminal");
        fprintf(stderr, "Try 'rayd-client --help'.\n");
        return CLIENT_USAGE_EXIT;
    }
    char *urls[CLIENT_MAX_SERVERS] = {0};
    rc = CLIENT_USAGE_EXIT;
    if (client_urls(&a.o, urls) != 0) {
        fprintf(stderr, "Try 'rayd-client --help'.\n");
        goto out;
    }
    rc = 1;
    if (a.token_file && *a.token_file && !(a.o.token = client_read_token(a.token_file))) goto out;
    net_global_init();
    rc = client_run(&a);
    net_global_cleanup();
out:
    free(a.o.token);
    for (int i = 0; i < a.o.nservers; i++) free(urls[i]);
    return rc;
}
