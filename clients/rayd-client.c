/* rayd-client.c -- the command line of rayd-client.
 *
 *   rayd-client render SCENE.json -o OUT.png --server URL [--server URL ...]
 *               [--tile 128 | --split-samples N] [--parallel N] [--retries N]
 *               [--timeout S]
 *               [--token-file F] [--quiet]
 *   rayd-client job SCENE.json -o OUT.png --server URL [--token-file F]
 *   rayd-client health --server URL [--server URL ...]
 *
 * `render` splits one frame into tiles (or, --split-samples, its samples
 * into ranges) and spreads them over every server given (rayd nodes, or
 * one balancer in front of many: tiles.c); `job` uses
 * the asynchronous job API of one server (job.c); `health` asks each
 * server's /healthz and /readyz.  The scene is read, its files inlined and
 * validated locally before anything is sent (scenefile.c).  RAYD_SERVER
 * gives a default server, RAYD_TOKEN_FILE a default token file.
 *
 * Exit status: 0 success; 1 the scene or job was refused (the server's JSON
 * error is printed), or a server is unhealthy; 2 an incomplete image or a
 * transport failure (nothing is written); 64 a usage error.
 */
#include "client.h"

#include <cjson/cJSON.h>
#include <curl/curl.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <rayd/rayd.h>

#define CLIENT_USAGE_EXIT 64

static void client_usage(FILE *f)
{
    fprintf(f,
            "usage: rayd-client render SCENE.json -o OUT.png --server URL [--server URL ...]\n"
            "                          [--tile N | --split-samples N] [--parallel N] [--retries N]\n"
            "                          [--timeout S]\n"
            "                          [--token-file F] [--quiet]\n"
            "       rayd-client job SCENE.json -o OUT.png --server URL [--token-file F] [--quiet]\n"
            "       rayd-client health --server URL [--server URL ...] [--token-file F]\n"
            "\n"
            "  --server URL      a rayd node or a balancer in front of many (repeatable;\n"
            "                    default $RAYD_SERVER or http://127.0.0.1:8080)\n"
            "  -o, --output F    the PNG to write (only when every tile arrived); with\n"
            "                    --split-samples, F.exr writes the linear OpenEXR\n"
            "  --tile N          tile edge in pixels (default 128)\n"
            "  --split-samples N split the frame's samples, not its pixels, into N ranges:\n"
            "                    each server returns its range's exact sums, added here\n"
            "                    (the same bytes as one render)\n"
            "  --parallel N      requests in flight, all servers together\n"
            "                    (default 8 for one server, 4 per server for a list)\n"
            "  --retries N       further attempts of a failed tile, on another server (default 3)\n"
            "  --timeout S       seconds per request (default 120)\n"
            "  --token-file F    bearer token file (default $RAYD_TOKEN_FILE)\n"
            "  -q, --quiet       no progress output\n"
            "\n"
            "exit: 0 ok, 1 refused or unhealthy, 2 incomplete image or transport error, 64 usage\n");
}

static char *client_read_token(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "rayd-client: cannot read token file %s: %s\n", path, strerror(errno));
        return NULL;
    }
    char buf[4096];
    size_t n = fread(buf, 1, sizeof buf - 1, f);
    fclose(f);
    buf[n] = '\0';
    while (n && (buf[n - 1] == '\n' || buf[n - 1] == '\r' || buf[n - 1] == ' ' ||
                 buf[n - 1] == '\t'))
        buf[--n] = '\0';
    if (!n || strpbrk(buf, "\r\n")) {
        fprintf(stderr, "rayd-client: token file %s is empty or has several lines\n", path);
        return NULL;
    }
    return strdup(buf);
}

static int client_number(const char *opt, const char *v, double lo, double hi, double *out)
{
    char *end;
    errno = 0;
    double d = v ? strtod(v, &end) : 0;
    if (!v || end == v || *end || errno || !(d >= lo && d <= hi)) {
        fprintf(stderr, "rayd-client: %s needs a number in %g..%g, not '%s'\n", opt, lo, hi,
                v ? v : "");
        return -1;
    }
    *out = d;
    return 0;
}

/* ---- health ---------------------------------------------------------------- */

static long client_get(const struct client_opts *o, const char *url, struct net_buf *b, char *why,
                       size_t size)
{
    void *hdrs = NULL;
    CURL *h = net_easy(o, url, b, NULL, 0, &hdrs);
    if (!h) {
        snprintf(why, size, "out of memory");
        return 0;
    }
    CURLcode cc = curl_easy_perform(h);
    long st = 0;
    if (cc == CURLE_OK)
        curl_easy_getinfo(h, CURLINFO_RESPONSE_CODE, &st);
    else
        snprintf(why, size, "%s", curl_easy_strerror(cc));
    curl_easy_cleanup(h);
    curl_slist_free_all(hdrs);
    return st;
}

static int client_health(const struct client_opts *o)
{
    int bad = 0;
    for (int i = 0; i < o->nservers; i++) {
        char url[1024], why[600] = "";
        struct net_buf b = {0};
        snprintf(url, sizeof url, "%s/healthz", o->servers[i]);
        long live = client_get(o, url, &b, why, sizeof why);
        if (live != 200) {
            if (live)
                net_describe(live, &b, why, sizeof why);
            printf("%s: down (%s)\n", o->servers[i], why);
            bad = 1;
            net_buf_free(&b);
            continue;
        }
        net_buf_reset(&b);
        snprintf(url, sizeof url, "%s/readyz", o->servers[i]);
        long ready = client_get(o, url, &b, why, sizeof why);
        cJSON *j = ready == 200 ? cJSON_ParseWithLength(b.data, b.len) : NULL;
        if (j) {
            const cJSON *q = cJSON_GetObjectItemCaseSensitive(j, "queued");
            const cJSON *c = cJSON_GetObjectItemCaseSensitive(j, "capacity");
            const cJSON *w = cJSON_GetObjectItemCaseSensitive(j, "workers");
            const cJSON *busy = cJSON_GetObjectItemCaseSensitive(j, "busy");
            printf("%s: live, ready (queue %d/%d, workers %d busy of %d)\n", o->servers[i],
                   cJSON_IsNumber(q) ? q->valueint : -1, cJSON_IsNumber(c) ? c->valueint : -1,
                   cJSON_IsNumber(busy) ? busy->valueint : -1,
                   cJSON_IsNumber(w) ? w->valueint : -1);
            cJSON_Delete(j);
        } else {
            if (ready)
                net_describe(ready, &b, why, sizeof why);
            printf("%s: live, not ready (%s)\n", o->servers[i], why);
            bad = 1;
        }
        net_buf_free(&b);
    }
    return bad;
}

/* ---- main ----------------------------------------------------------------------- */

int main(int argc, char **argv)
{
    if (argc < 2 || !strcmp(argv[1], "-h") || !strcmp(argv[1], "--help")) {
        client_usage(argc < 2 ? stderr : stdout);
        return argc < 2 ? CLIENT_USAGE_EXIT : 0;
    }
    if (!strcmp(argv[1], "--version")) {
        printf("rayd-client %s\n", RAYD_VERSION);
        return 0;
    }
    const char *cmd = argv[1];
    if (strcmp(cmd, "render") && strcmp(cmd, "job") && strcmp(cmd, "health")) {
        fprintf(stderr, "rayd-client: unknown command '%s'\n", cmd);
        client_usage(stderr);
        return CLIENT_USAGE_EXIT;
    }
    struct client_opts o;
    memset(&o, 0, sizeof o);
    o.tile = 128, o.retries = 3, o.timeout = 120, o.parallel = 0;
    const char *scene = NULL, *token_file = getenv("RAYD_TOKEN_FILE");
    for (int i = 2; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        double d;
        if (!strcmp(a, "--server") || !strcmp(a, "-s")) {
            if (!v || o.nservers == CLIENT_MAX_SERVERS) {
                fprintf(stderr, "rayd-client: --server needs a URL (at most %d)\n",
                        CLIENT_MAX_SERVERS);
                return CLIENT_USAGE_EXIT;
            }
            o.servers[o.nservers++] = v, i++;
        } else if (!strcmp(a, "-o") || !strcmp(a, "--output")) {
            if (!v) {
                fprintf(stderr, "rayd-client: %s needs a file name\n", a);
                return CLIENT_USAGE_EXIT;
            }
            o.out = v, i++;
        } else if (!strcmp(a, "--tile")) {
            if (client_number(a, v, 8, 4096, &d))
                return CLIENT_USAGE_EXIT;
            o.tile = (int)d, i++;
        } else if (!strcmp(a, "--split-samples")) {
            if (client_number(a, v, 1, 65536, &d))
                return CLIENT_USAGE_EXIT;
            o.ranges = (int)d, i++;
        } else if (!strcmp(a, "--parallel")) {
            if (client_number(a, v, 1, 1024, &d))
                return CLIENT_USAGE_EXIT;
            o.parallel = (int)d, i++;
        } else if (!strcmp(a, "--retries")) {
            if (client_number(a, v, 0, 100, &d))
                return CLIENT_USAGE_EXIT;
            o.retries = (int)d, i++;
        } else if (!strcmp(a, "--timeout")) {
            if (client_number(a, v, 0.1, 86400, &d))
                return CLIENT_USAGE_EXIT;
            o.timeout = d, i++;
        } else if (!strcmp(a, "--token-file")) {
            if (!v) {
                fprintf(stderr, "rayd-client: --token-file needs a file\n");
                return CLIENT_USAGE_EXIT;
            }
            token_file = v, i++;
        } else if (!strcmp(a, "-q") || !strcmp(a, "--quiet")) {
            o.quiet = 1;
        } else if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
            client_usage(stdout);
            return 0;
        } else if (a[0] == '-' && a[1]) {
            fprintf(stderr, "rayd-client: unknown option '%s'\n", a);
            return CLIENT_USAGE_EXIT;
        } else if (!scene && strcmp(cmd, "health")) {
            scene = a;
        } else {
            fprintf(stderr, "rayd-client: unexpected argument '%s'\n", a);
            return CLIENT_USAGE_EXIT;
        }
    }
    if (!o.nservers) {
        const char *env = getenv("RAYD_SERVER");
        o.servers[o.nservers++] = env && *env ? env : "http://127.0.0.1:8080";
    }
    /* the URLs are used as prefixes: strip one trailing slash (a copy) */
    char *urls[CLIENT_MAX_SERVERS] = {0};
    for (int i = 0; i < o.nservers; i++) {
        size_t n = strlen(o.servers[i]);
        urls[i] = strdup(o.servers[i]);
        if (!urls[i])
            return 2;
        while (n > 0 && urls[i][n - 1] == '/')
            urls[i][--n] = '\0';
        if (!strstr(urls[i], "://")) {
            fprintf(stderr, "rayd-client: --server wants a URL such as http://host:8080, not '%s'\n",
                    urls[i]);
            for (int k = 0; k <= i; k++)
                free(urls[k]);
            return CLIENT_USAGE_EXIT;
        }
        o.servers[i] = urls[i];
    }
    if (!o.parallel)
        o.parallel = o.nservers == 1 ? 8 : 4 * o.nservers;
    int rc = CLIENT_USAGE_EXIT;
    if (strcmp(cmd, "health") && (!scene || !o.out)) {
        fprintf(stderr, "rayd-client %s: needs SCENE.json and -o OUT.png\n", cmd);
        goto out;
    }
    if (!strcmp(cmd, "job") && o.nservers != 1) {
        fprintf(stderr, "rayd-client job: give exactly one --server (jobs live on one node)\n");
        goto out;
    }
    if (token_file && *token_file && !(o.token = client_read_token(token_file))) {
        rc = 2;
        goto out;
    }
    net_global_init();
    if (!strcmp(cmd, "health")) {
        rc = client_health(&o);
    } else {
        struct scenefile sf;
        if (scenefile_load(scene, &sf) != 0) {
            rc = 1;
        } else {
            rc = !strcmp(cmd, "job") ? job_run(&o, &sf) : tiles_render(&o, &sf);
            scenefile_free(&sf);
        }
    }
    net_global_cleanup();
out:
    free(o.token);
    for (int i = 0; i < o.nservers; i++)
        free(urls[i]);
    return rc;
}
