/* config.c -- every option of rayd in one table.
 *
 * Each row names a long flag, its environment variable, its type, default,
 * range and one line of help.  Defaults are applied first, then the
 * environment (RAYD_PORT=0 ...), then the command line, so a flag always
 * wins.  `rayd --help` prints the table itself, so the help can never drift
 * from what the parser accepts (the shape of Redis's config.c standardConfig
 * table, much smaller).
 *
 * Numbers are parsed strictly (the whole string, in range); a bad value is a
 * start-up error naming the option, never a silent default.
 *
 * The command line follows the convention of the three tools (rayd,
 * rayd-render, rayd-client): getopt_long, so "--port 0" and "--port=0" are
 * the same; -h/--help to stdout, --version; errors are one line
 * "rayd: error: ..." on stderr; exit 0 done, 1 failure, 2 usage error.
 * getopt_long's table is made from config_table at start-up: row i is the
 * option numbered CONFIG_OPT0 + i, so a new row needs nothing else.
 */
#include "base/base.h"

#include <arpa/inet.h>
#include <errno.h>
#include <getopt.h>
#include <limits.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

struct config config;

enum config_type { CT_LONG, CT_STRING };

struct config_option {
    const char *name; /* flag without the dashes */
    const char *env;
    enum config_type type;
    void *ptr;
    const char *def;
    long min, max;
    const char *help;
};

static const struct config_option config_table[] = {
    {"bind", "RAYD_BIND", CT_STRING, &config.bind, "127.0.0.1", 0, 0,
     "address to listen on (IPv4 or IPv6 literal, or localhost)"},
    {"port", "RAYD_PORT", CT_LONG, &config.port, "8080", 0, 65535,
     "TCP port; 0 picks a free one (printed on the first line)"},
    {"threads", "RAYD_THREADS", CT_LONG, &config.threads, "0", 0, 1024,
     "render worker threads (and one spare for quick previews); 0 = number of cores"},
    {"http-threads", "RAYD_HTTP_THREADS", CT_LONG, &config.http_threads, "2", 1, 256,
     "libmicrohttpd threads (requests, bodies, answers; scenes are parsed on --parse-threads, "
     "rendered on --threads)"},
    {"queue", "RAYD_QUEUE", CT_LONG, &config.queue, "64", 1, 1000000,
     "renders not yet started (requests, jobs, next passes) before 503 queue_full"},
    {"parse-threads", "RAYD_PARSE_THREADS", CT_LONG, &config.parse_threads, "2", 1, 256,
     "threads that parse scenes and build their meshes and BVHs (off the HTTP threads)"},
    {"parse-queue", "RAYD_PARSE_QUEUE", CT_LONG, &config.parse_queue, "64", 1, 1000000,
     "scenes waiting for a parse thread before 503 queue_full"},
    {"max-body", "RAYD_MAX_BODY", CT_LONG, &config.max_body, "4194304", 1, LONG_MAX,
     "largest request body in bytes (413 before reading it)"},
    {"max-pixels", "RAYD_MAX_PIXELS", CT_LONG, &config.max_pixels, "16777216", 1, LONG_MAX,
     "largest image (width * height) a scene may ask for (413)"},
    {"max-samples", "RAYD_MAX_SAMPLES", CT_LONG, &config.max_samples, "1024", 1, RAYD_SAMPLES_MAX,
     "most samples a pixel a scene may ask for (render.samples; 413)"},
    {"token-file", "RAYD_TOKEN_FILE", CT_STRING, &config.token_file, NULL, 0, 0,
     "file holding a bearer token; then all but /healthz, /readyz, the preview page and OPTIONS "
     "need it"},
    {"cache-mb", "RAYD_CACHE_MB", CT_LONG, &config.cache_mb, "256", 0, 1048576,
     "memory budget of the compiled-scene cache in MiB"},
    {"result-cache-mb", "RAYD_RESULT_CACHE_MB", CT_LONG, &config.result_cache_mb, "64", 0, 1048576,
     "memory for finished PNGs served again without rendering (0 = off)"},
    {"max-memory", "RAYD_MAX_MEMORY", CT_STRING, &config.max_memory, NULL, 0, 0,
     "one budget for bodies, scenes, results, sums and caches, in bytes or with K, M, G "
     "(default: half the machine's memory); past it 503 with Retry-After"},
    {"log-format", "RAYD_LOG_FORMAT", CT_STRING, &config.log_format, "text", 0, 0,
     "access log format on stderr: text or json"},
    {"log-level", "RAYD_LOG_LEVEL", CT_STRING, &config.log_level, "info", 0, 0,
     "least severe log line written: debug, info, warn or error (4xx is warn, 5xx error)"},
    {"drain-seconds", "RAYD_DRAIN_SECONDS", CT_LONG, &config.drain_seconds, "30", 0, 86400,
     "on SIGTERM/SIGINT, time running renders get before they are cancelled"},
    {"cors-origin", "RAYD_CORS_ORIGIN", CT_STRING, &config.cors_origin, NULL, 0, 0,
     "comma-separated origins allowed by CORS, or * (default: none)"},
    {"timeout", "RAYD_TIMEOUT", CT_LONG, &config.timeout, "30", 1, 86400,
     "seconds an idle or stalled connection is kept (slow uploads are dropped)"},
    {"max-jobs", "RAYD_MAX_JOBS", CT_LONG, &config.max_jobs, "1024", 1, 1000000,
     "asynchronous jobs remembered; the oldest finished ones are forgotten first"},
    {"max-frames", "RAYD_MAX_FRAMES", CT_LONG, &config.max_frames, "1000", 1, 100000,
     "frames one frame-range job may render (POST /v1/jobs of an animated scene; 400 over it)"},
    {"max-render-seconds", "RAYD_MAX_RENDER_SECONDS", CT_LONG, &config.max_render_seconds, "3600",
     0, 31536000,
     "a render running longer (from its first tile) is stopped and fails; 0 = no limit"},
    {"max-work", "RAYD_MAX_WORK", CT_LONG, &config.max_work, "0", 0, LONG_MAX,
     "largest render in estimated rays (pixels x samples x rays a sample; 413 over_budget); "
     "0 = no limit"},
    {"max-backlog", "RAYD_MAX_BACKLOG", CT_LONG, &config.max_backlog, "300", 0, 31536000,
     "/readyz answers 503 while the estimated work queued exceeds this many seconds; 0 = never"},
    {"client-header", "RAYD_CLIENT_HEADER", CT_STRING, &config.client_header, NULL, 0, 0,
     "request header naming the client for fair shares, set by a trusted balancer "
     "(default: the peer address)"},
    {"job-ttl", "RAYD_JOB_TTL", CT_LONG, &config.job_ttl, "600", 1, 31536000,
     "seconds a job (and its PNG) is kept after it ended (succeeded, failed or cancelled)"},
    {"png-level", "RAYD_PNG_LEVEL", CT_LONG, &config.png_level, "-1", -1, 9,
     "deflate level of the PNGs, as rayd-render --png-level (-1 = the default, libdeflate's 1 "
     "with ISA-L every fourth band; 1 = the fastest)"},
    {"max-conns", "RAYD_MAX_CONNS", CT_LONG, &config.max_conns, "4096", 1, 1000000,
     "open connections in all; more wait unaccepted (open-file limit raised to fit)"},
    {"max-conns-per-ip", "RAYD_MAX_CONNS_PER_IP", CT_LONG, &config.max_conns_per_ip, "0", 0,
     1000000, "open connections from one client address; more are closed at accept (0 = no limit)"},
    {"max-header-bytes", "RAYD_MAX_HEADER_BYTES", CT_LONG, &config.max_header_bytes, "32768", 4096,
     16777216, "memory per connection for the request line and headers (larger: 431 or 414)"},
    {"max-url", "RAYD_MAX_URL", CT_LONG, &config.max_url, "8192", 64, 16777216,
     "longest request target, path and query (414 uri_too_long)"},
    {"upload-seconds", "RAYD_UPLOAD_SECONDS", CT_LONG, &config.upload_seconds, "120", 0, 86400,
     "longest time a request body may take to arrive; slower uploads are dropped (0 = no limit)"},
    {"header-seconds", "RAYD_HEADER_SECONDS", CT_LONG, &config.header_seconds, "10", 0, 86400,
     "longest time the request line and headers may take, from the accept (keep-alive: from "
     "the next request's first bytes); slower connections are closed (0 = no limit)"},
    {"tls-cert", "RAYD_TLS_CERT", CT_STRING, &config.tls_cert, NULL, 0, 0,
     "PEM certificate (chain): serve HTTPS with libmicrohttpd's TLS (needs --tls-key)"},
    {"tls-key", "RAYD_TLS_KEY", CT_STRING, &config.tls_key, NULL, 0, 0,
     "PEM private key for --tls-cert"},
    {"asset-dir", "RAYD_ASSET_DIR", CT_STRING, &config.asset_dir, NULL, 0, 0,
     "folder a scene's mesh and texture \"file\" names are read from (inside it only)"},
    {"data-dir", "RAYD_DATA_DIR", CT_STRING, &config.data_dir, NULL, 0, 0,
     "folder where jobs (SQLite) and their images are kept across restarts (default: memory "
     "only)"},
    {"max-disk", "RAYD_MAX_DISK", CT_STRING, &config.max_disk, NULL, 0, 0,
     "disk budget of the finished images under --data-dir, in bytes or with K, M, G; the "
     "oldest are evicted first (410 result_evicted); default: no budget"},
    {"redis", "RAYD_REDIS", CT_STRING, &config.redis, NULL, 0, 0,
     "redis://[:PASSWORD@]HOST[:PORT][/DB] or unix:/path: every node with the same URL shares "
     "jobs, frames and tiles (password also from RAYD_REDIS_PASSWORD; no TLS: use a tunnel)"},
    {"redis-claim-ms", "RAYD_REDIS_CLAIM_MS", CT_LONG, &config.redis_claim_ms, "30000", 100,
     86400000,
     "with --redis: a work item a node took and has not refreshed for this long is "
     "taken over by another node"},
    {"cluster-tile", "RAYD_CLUSTER_TILE", CT_LONG, &config.cluster_tile, "256", 16, 16384,
     "with --redis: the edge in pixels of the tiles a frame is split into, one work item each"},
    {"test-gate", "RAYD_TEST_GATE", CT_STRING, &config.test_gate, NULL, 0, 0,
     "tests only: workers start tiles only as POST /v1/test/gate allows (N tiles, or open)"},
};

#define CONFIG_N (sizeof config_table / sizeof config_table[0])

/* Where each option's value came from: its environment variable's name,
 * or NULL (the default or the command line), so an error names what the
 * user set. */
static const char *config_from[CONFIG_N];

/* The option name as the user gave it: "RAYD_LOG_LEVEL" when the value
 * came from the environment, else "--log-level". */
static const char *config_said(const char *name) {
    static char flag[4][64];
    static int next;
    for (size_t i = 0; i < CONFIG_N; i++)
        if (!strcmp(config_table[i].name, name) && config_from[i]) return config_from[i];
    char *f = flag[next++ % 4]; /* a few in one message */
    snprintf(f, sizeof flag[0], "--%s", name);
    return f;
}

/* Sets o from val; a bad value is reported under from (an environment
 * variable's name) or, NULL, the option's own --name. */
static int config_set(const struct config_option *o, const char *val, const char *from) {
    config_from[o - config_table] = from;
    if (o->type == CT_STRING) {
        char **p = o->ptr;
        free(*p);
        *p = val ? strdup(val) : NULL;
        return 0;
    }
    char *end;
    errno = 0;
    long v = strtol(val, &end, 10);
    if (errno || end == val || *end || v < o->min || v > o->max) {
        char flag[64];
        snprintf(flag, sizeof flag, "--%s", o->name);
        fprintf(stderr, "rayd: error: %s takes an integer in %ld..%ld, not '%s'\n",
                from ? from : flag, o->min, o->max, val);
        return -1;
    }
    *(long *)o->ptr = v;
    return 0;
}

static void config_usage(FILE *f) {
    fprintf(f, "usage: rayd [options]\n\n"
               "The rayd render server: POST a JSON scene, get a PNG (HTTP API v1, docs/api.md).\n"
               "Every option can also be set from the environment variable shown;\n"
               "a flag wins over the environment.\n\n");
    for (size_t i = 0; i < CONFIG_N; i++) {
        const struct config_option *o = &config_table[i];
        char flag[64];
        snprintf(flag, sizeof flag, "--%s %s", o->name, o->type == CT_LONG ? "N" : "VALUE");
        fprintf(f, "  %-22s %s\n  %-22s env %s, default %s\n", flag, o->help, "", o->env,
                o->def ? o->def : "(none)");
    }
    fprintf(f, "  %-22s this help\n  %-22s print 'rayd VERSION'\n\n", "-h, --help", "--version");
    fprintf(f, "Signals: SIGTERM or SIGINT drain (readyz 503, new work refused, running\n"
               "renders finish or are cancelled after --drain-seconds) and exit 0.\n"
               "SIGHUP, SIGUSR1 and SIGUSR2 are logged and ignored (nothing to reload).\n"
               "The first line on stdout is 'rayd listening on http://HOST:PORT'.\n\n"
               "Options take their value as '--opt value' or '--opt=value'.\n"
               "Errors are one line on stderr: 'rayd: error: ...'.\n"
               "Exit status: 0 stopped by a signal after draining (or --help, --version),\n"
               "1 failure (cannot listen, a file an option names), 2 usage error.\n");
}

/* getopt_long's numbers: rows of config_table from CONFIG_OPT0, then the
 * two options outside it. */
enum { CONFIG_HELP = 'h', CONFIG_VERSION = 256, CONFIG_OPT0 = 257 };

/* getopt_long's table for config_table, plus --help and --version. */
static void config_longopts(struct option *lo) {
    for (size_t i = 0; i < CONFIG_N; i++)
        lo[i] =
            (struct option){config_table[i].name, required_argument, NULL, CONFIG_OPT0 + (int)i};
    lo[CONFIG_N] = (struct option){"help", no_argument, NULL, CONFIG_HELP};
    lo[CONFIG_N + 1] = (struct option){"version", no_argument, NULL, CONFIG_VERSION};
    lo[CONFIG_N + 2] = (struct option){NULL, 0, NULL, 0};
}

/* The long options of lo that word ("--na" or "--na=value") is a prefix of,
 * as "--name, --namesake" into out: getopt_long refuses a prefix of more
 * than one, which is no unknown option and is said so. */
static int config_prefix_of(const struct option *lo, const char *word, char *out, size_t size) {
    size_t len = strcspn(word + 2, "="), used = 0;
    int n = 0;
    out[0] = '\0';
    for (const struct option *o = lo; o->name; o++) {
        if (strncmp(o->name, word + 2, len) != 0) continue;
        int k = snprintf(out + used, size - used, "%s--%s", n ? ", " : "", o->name);
        if (k > 0 && (size_t)k < size - used) used += (size_t)k;
        n++;
    }
    return n;
}

/* getopt_long's '?' or ':' at arg (the word it stopped at), which its optopt
 * (a short option, or the number of a long one): the message. */
static int config_bad_option(const struct option *lo, int opt, int which, const char *arg) {
    char names[1024];
    if (opt == ':' && which >= CONFIG_OPT0)
        fprintf(stderr, "rayd: error: option --%s needs a value\n",
                config_table[which - CONFIG_OPT0].name);
    else if (!strncmp(arg, "--", 2) && which)
        fprintf(stderr, "rayd: error: option '%.*s' takes no value\n", (int)strcspn(arg, "="), arg);
    else if (!strncmp(arg, "--", 2) && config_prefix_of(lo, arg, names, sizeof names) > 1)
        fprintf(stderr, "rayd: error: ambiguous option '%s' (%s)\n", arg, names);
    else if (!strncmp(arg, "--", 2) || !which)
        fprintf(stderr, "rayd: error: unknown option '%s'\n", arg);
    else
        fprintf(stderr, "rayd: error: unknown option '-%c'\n", which);
    return CONFIG_USAGE;
}

/* The command line over the defaults and the environment. */
static int config_args(int argc, char **argv) {
    struct option lo[CONFIG_N + 3];
    config_longopts(lo);
    opterr = 0;
    optind = 1;
    int opt;
    while ((opt = getopt_long(argc, argv, ":h", lo, NULL)) != -1) {
        if (opt == '?' || opt == ':') return config_bad_option(lo, opt, optopt, argv[optind - 1]);
        if (opt == CONFIG_HELP) {
            config_usage(stdout);
            return CONFIG_DONE;
        }
        if (opt == CONFIG_VERSION) {
            printf("rayd %s\n", RAYD_VERSION);
            return CONFIG_DONE;
        }
        if (config_set(&config_table[opt - CONFIG_OPT0], optarg, NULL)) return CONFIG_USAGE;
    }
    if (optind < argc) {
        fprintf(stderr, "rayd: error: unexpected argument '%s'\n", argv[optind]);
        return CONFIG_USAGE;
    }
    return CONFIG_RUN;
}

/* The longest token --token-file may hold (bytes, blanks around it aside). */
#define CONFIG_TOKEN_MAX 4096

/* Why the token t[0..n) cannot be used, or NULL; the byte at fault (from
 * 1) into *at, 0 for none.  It is compared with the Authorization header
 * as a C string, so a NUL inside would cut it (and was once copied short,
 * then cleared and compared at its full length); a control character
 * cannot be sent in a header at all. */
static const char *config_token_why(const char *t, size_t n, size_t *at) {
    *at = 0;
    if (n == 0) return "is empty";
    if (n > CONFIG_TOKEN_MAX) return "holds a token over 4096 bytes";
    for (size_t i = 0; i < n; i++) {
        unsigned char c = (unsigned char)t[i];
        *at = i + 1;
        if (c == 0) return "holds a NUL byte";
        if (c < 0x20 || c == 0x7f) return "holds a control character";
    }
    *at = 0;
    return NULL;
}

/* Reads --token-file: the token is the file's text without the blanks and
 * line ends around it, checked whole (config_token_why).  -1 after naming
 * the file and the problem. */
static int config_read_token(void) {
    FILE *f = fopen(config.token_file, "rb");
    if (!f) {
        fprintf(stderr, "rayd: error: %s %s: %s\n", config_said("token-file"), config.token_file,
                strerror(errno));
        return -1;
    }
    /* a little more than the longest token, so that a longer one is seen */
    char buf[CONFIG_TOKEN_MAX + 64];
    size_t n = fread(buf, 1, sizeof buf, f);
    bool more = n == sizeof buf && fgetc(f) != EOF;
    fclose(f);
    const char *t = buf;
    while (n > 0 && (t[0] == ' ' || t[0] == '\t' || t[0] == '\r' || t[0] == '\n')) t++, n--;
    while (n > 0 && (t[n - 1] == ' ' || t[n - 1] == '\t' || t[n - 1] == '\r' || t[n - 1] == '\n'))
        n--;
    size_t at = 0;
    const char *why = more ? "holds a token over 4096 bytes" : config_token_why(t, n, &at);
    if (why) {
        memset(buf, 0, sizeof buf);
        if (at)
            fprintf(stderr, "rayd: error: %s %s %s (byte %zu of the token)\n",
                    config_said("token-file"), config.token_file, why, at);
        else
            fprintf(stderr, "rayd: error: %s %s %s\n", config_said("token-file"), config.token_file,
                    why);
        return -1;
    }
    config.token = malloc(n + 1);
    if (!config.token) {
        fprintf(stderr, "rayd: error: %s %s: out of memory\n", config_said("token-file"),
                config.token_file);
        return -1;
    }
    memcpy(config.token, t, n);
    config.token[n] = 0;
    config.token_len = n;
    memset(buf, 0, sizeof buf);
    return 0;
}

bool config_loopback(const char *addr) {
    return !strncmp(addr, "127.", 4) || !strcmp(addr, "::1") || !strcmp(addr, "localhost");
}

/* --bind: an IPv4 or IPv6 address, or localhost (127.0.0.1), checked here
 * as any option's value is, so a wrong one is a usage error (2) and not a
 * failure to listen (1). */
static int config_bind(void) {
    unsigned char addr[sizeof(struct in6_addr)];
    if (!strcmp(config.bind, "localhost")) {
        char *lo = strdup("127.0.0.1");
        if (!lo) return -1;
        free(config.bind);
        config.bind = lo;
    }
    if (inet_pton(AF_INET, config.bind, addr) == 1 || inet_pton(AF_INET6, config.bind, addr) == 1)
        return 0;
    fprintf(stderr, "rayd: error: %s must be an IPv4 or IPv6 address or localhost, not '%s'\n",
            config_said("bind"), config.bind);
    return -1;
}

/* --asset-dir: an existing folder, kept as its real path, so the loader's
 * confinement (openat2 RESOLVE_BENEATH, core/load/scene_json_util.c) starts
 * from a fixed place.  Unset, a scene's "file" is refused. */
static int config_asset_dir(void) {
    if (!config.asset_dir) return 0;
    char *real = realpath(config.asset_dir, NULL);
    struct stat st;
    if (!real || stat(real, &st) != 0 || !S_ISDIR(st.st_mode)) {
        fprintf(stderr, "rayd: error: %s %s: %s\n", config_said("asset-dir"), config.asset_dir,
                real ? "not a directory" : strerror(errno));
        free(real);
        return -1;
    }
    free(config.asset_dir);
    config.asset_dir = real;
    return 0;
}

/* --test-gate lets any client hold every worker, so it is refused unless
 * rayd listens on loopback only. */
static int config_test_gate(void) {
    config.test_gate_tiles = -2;
    if (!config.test_gate) return 0;
    char *end;
    errno = 0;
    long n = strtol(config.test_gate, &end, 10);
    if (!strcmp(config.test_gate, "open")) {
        n = -1;
    } else if (errno || end == config.test_gate || *end || n < 0) {
        fprintf(stderr, "rayd: error: %s must be 'open' or a number of tiles >= 0, not '%s'\n",
                config_said("test-gate"), config.test_gate);
        return -1;
    }
    if (!config_loopback(config.bind)) {
        fprintf(stderr, "rayd: error: %s is for tests and needs a loopback --bind (not %s)\n",
                config_said("test-gate"), config.bind);
        return -1;
    }
    config.test_gate_tiles = n;
    return 0;
}

/* --data-dir: a folder that exists (or can be made, one level) and that
 * rayd may write in, kept as its real path; --max-disk, which needs it:
 * bytes, K, M, G or T as --max-memory. */
static int config_data_dir(void) {
    size_t v = 0;
    if (config.max_disk && (!mem_parse(config.max_disk, &v) || v == 0)) {
        fprintf(stderr,
                "rayd: error: %s takes bytes above 0 (a number with an optional K, M, G "
                "or T suffix), not '%s'\n",
                config_said("max-disk"), config.max_disk);
        return CONFIG_USAGE;
    }
    config.max_disk_bytes = v;
    if (!config.data_dir)
        return config.max_disk ? (fprintf(stderr, "rayd: error: %s needs --data-dir\n",
                                          config_said("max-disk")),
                                  CONFIG_USAGE)
                               : 0;
    struct stat st;
    if (!*config.data_dir) {
        fprintf(stderr, "rayd: error: %s is empty\n", config_said("data-dir"));
        return CONFIG_USAGE;
    }
    if (stat(config.data_dir, &st) != 0 && (errno != ENOENT || mkdir(config.data_dir, 0700) != 0)) {
        fprintf(stderr, "rayd: error: %s %s: cannot use or create it: %s\n",
                config_said("data-dir"), config.data_dir, strerror(errno));
        return CONFIG_FAILED;
    }
    char *real = realpath(config.data_dir, NULL);
    if (!real || stat(real, &st) != 0 || !S_ISDIR(st.st_mode) || access(real, W_OK | X_OK) != 0) {
        fprintf(stderr, "rayd: error: %s %s: %s\n", config_said("data-dir"), config.data_dir,
                !real                  ? strerror(errno)
                : !S_ISDIR(st.st_mode) ? "not a directory"
                                       : "not writable by rayd");
        free(real);
        return CONFIG_FAILED;
    }
    free(config.data_dir);
    config.data_dir = real;
    return 0;
}

/* --log-level as enum log_level (log.c writes the same words). */
static int config_log_level(void) {
    static const char *const names[] = {"debug", "info", "warn", "error"};
    for (int i = 0; i <= LOG_ERROR; i++)
        if (!strcmp(config.log_level, names[i])) {
            config.log_min = i;
            return 0;
        }
    fprintf(stderr, "rayd: error: %s must be debug, info, warn or error, not '%s'\n",
            config_said("log-level"), config.log_level);
    return -1;
}

/* --max-memory: bytes, or with a K, M, G or T suffix (KiB, MiB, ...);
 * unset, half of the machine's memory (or of its cgroup's limit).  The
 * budget starts here, before any thread (mem.c). */
static int config_max_memory(void) {
    size_t v = 0;
    if (config.max_memory && (!mem_parse(config.max_memory, &v) || v < ((size_t)1 << 20))) {
        fprintf(stderr,
                "rayd: error: %s takes bytes of at least 1M (a number with an optional "
                "K, M, G or T suffix), not '%s'\n",
                config_said("max-memory"), config.max_memory);
        return -1;
    }
    config.max_memory_bytes = config.max_memory ? v : mem_default_limit();
    mem_start(config.max_memory_bytes);
    return 0;
}

/* Defaults, then the environment, then the command line (a flag wins);
 * then the checks that need every option.  An enum config_result. */
int config_load(int argc, char **argv) {
    for (size_t i = 0; i < CONFIG_N; i++)
        if (config_table[i].def && config_set(&config_table[i], config_table[i].def, NULL))
            return CONFIG_USAGE;
    for (size_t i = 0; i < CONFIG_N; i++) {
        const char *v = getenv(config_table[i].env);
        if (v && config_set(&config_table[i], v, config_table[i].env)) return CONFIG_USAGE;
    }
    int rc = config_args(argc, argv);
    if (rc != CONFIG_RUN) return rc;
    if (strcmp(config.log_format, "text") && strcmp(config.log_format, "json")) {
        fprintf(stderr, "rayd: error: %s must be text or json, not '%s'\n",
                config_said("log-format"), config.log_format);
        return CONFIG_USAGE;
    }
    config.log_json = !strcmp(config.log_format, "json");
    if (config_log_level() || config_bind()) return CONFIG_USAGE;
    if (config.threads == 0) {
        long n = sysconf(_SC_NPROCESSORS_ONLN);
        config.threads = n > 0 ? n : 1;
    }
    if (config.token_file && *config.token_file && config_read_token()) return CONFIG_FAILED;
    if (config_test_gate()) return CONFIG_USAGE;
    if (config_asset_dir()) return CONFIG_FAILED;
    if (config_max_memory()) return CONFIG_USAGE;
    if ((rc = config_data_dir()) != 0) return rc;
    if (config.redis && config.data_dir) {
        fprintf(stderr, "rayd: error: %s and --data-dir: choose one: both keep jobs\n",
                config_said("redis"));
        return CONFIG_USAGE;
    }
    if (!config.tls_cert != !config.tls_key) {
        fprintf(stderr, "rayd: error: %s and --tls-key go together\n", config_said("tls-cert"));
        return CONFIG_USAGE;
    }
    return CONFIG_RUN;
}

void config_free(void) {
    for (size_t i = 0; i < CONFIG_N; i++)
        if (config_table[i].type == CT_STRING) {
            char **p = config_table[i].ptr;
            free(*p);
            *p = NULL;
        }
    if (config.token) {
        memset(config.token, 0, config.token_len);
        free(config.token);
        config.token = NULL;
    }
}
