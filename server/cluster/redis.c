/* redis.c -- one connection to Redis: the URL, connecting with timeouts,
 * reconnecting with back-off, and one command at a time.
 *
 * hiredis 0.14 (Debian 12's libhiredis) is synchronous and has no TLS:
 * each command waits for its reply up to a timeout (redisSetTimeout), so a
 * Redis that stops answering costs a thread at most that long, never
 * forever.  A connection that failed is dropped; the next command connects
 * again, but not before a back-off that doubles from 100 ms to 2 s, so a
 * Redis that is down costs a refused connect now and then, not one per
 * request.  Every caller is a cluster thread (never an HTTP thread), and
 * each owns its connection, so there is no lock here.
 *
 * The URL is redis://[:PASSWORD@]HOST[:PORT][/DB] or unix:/path; the
 * password may come from RAYD_REDIS_PASSWORD instead (kept out of ps).  A
 * bad URL is refused naming the part that is wrong.
 */
#include "cluster/cluster_private.h"

#include <ctype.h>
#include <errno.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/time.h>

struct redis {
    struct redis_url url;
    redisContext *ctx;
    double timeout_s;
    double next_try; /* clock_now() before which no connect is tried */
    double backoff;
    char why[200];
};

/* [:PASSWORD@] of a redis:// URL into u; s advanced past it. */
static bool redis_url_auth(const char **s, struct redis_url *u, char *why, size_t n) {
    const char *at = strchr(*s, '@');
    if (!at) return true;
    const char *colon = memchr(*s, ':', (size_t)(at - *s));
    if (!colon) {
        snprintf(why, n, "the part before '@' must be :PASSWORD (a user is not supported)");
        return false;
    }
    size_t len = (size_t)(at - colon - 1);
    if (len == 0 || len >= sizeof u->password) {
        snprintf(why, n, "the password is empty or longer than %zu bytes", sizeof u->password - 1);
        return false;
    }
    memcpy(u->password, colon + 1, len);
    u->password[len] = 0;
    *s = at + 1;
    return true;
}

/* HOST[:PORT][/DB] into u. */
static bool redis_url_host(const char *s, struct redis_url *u, char *why, size_t n) {
    size_t hl = strcspn(s, ":/");
    if (hl == 0 || hl >= sizeof u->host) {
        snprintf(why, n, "the host is missing or too long");
        return false;
    }
    memcpy(u->host, s, hl);
    u->host[hl] = 0;
    for (size_t i = 0; i < hl; i++)
        if (!isalnum((unsigned char)u->host[i]) && !strchr(".-_", u->host[i])) {
            snprintf(why, n, "the host '%s' has a character a host name cannot have", u->host);
            return false;
        }
    s += hl;
    u->port = 6379;
    if (*s == ':') {
        char *end;
        errno = 0;
        long p = strtol(s + 1, &end, 10);
        if (errno || end == s + 1 || p < 1 || p > 65535 || (*end && *end != '/')) {
            snprintf(why, n, "the port must be a number from 1 to 65535");
            return false;
        }
        u->port = (int)p;
        s = end;
    }
    if (*s == '/' && s[1]) {
        char *end;
        long db = strtol(s + 1, &end, 10);
        if (*end || db < 0 || db > 65535 || !isdigit((unsigned char)s[1])) {
            snprintf(why, n, "the database after '/' must be a number (redis://host:6379/0)");
            return false;
        }
        u->db = (int)db;
    }
    return true;
}

bool redis_url_parse(const char *url, struct redis_url *u, char *why, size_t n) {
    memset(u, 0, sizeof *u);
    if (!strncmp(url, "unix:", 5)) {
        const char *p = url + 5;
        if (p[0] != '/' || strlen(p) >= sizeof u->unix_path) {
            snprintf(why, n, "a unix socket is unix:/absolute/path");
            return false;
        }
        snprintf(u->unix_path, sizeof u->unix_path, "%s", p);
        snprintf(u->display, sizeof u->display, "unix:%s", p);
    } else if (!strncmp(url, "redis://", 8)) {
        const char *s = url + 8;
        if (!redis_url_auth(&s, u, why, n) || !redis_url_host(s, u, why, n)) return false;
        snprintf(u->display, sizeof u->display, "%s:%d", u->host, u->port);
    } else if (!strncmp(url, "rediss://", 9)) {
        snprintf(why, n,
                 "the scheme rediss:// (TLS) is not supported by this build's hiredis: "
                 "use redis:// through a TLS tunnel (docs/operations.md)");
        return false;
    } else {
        snprintf(why, n, "the scheme must be redis:// or unix:");
        return false;
    }
    const char *env = getenv("RAYD_REDIS_PASSWORD");
    if (!u->password[0] && env && *env) snprintf(u->password, sizeof u->password, "%s", env);
    return true;
}

struct redis *redis_new(const struct redis_url *u, double timeout_s) {
    struct redis *c = calloc(1, sizeof *c);
    if (!c) return NULL;
    c->url = *u;
    c->timeout_s = timeout_s;
    c->backoff = 0.1;
    return c;
}

static void redis_drop(struct redis *c) {
    if (c->ctx) redisFree(c->ctx);
    c->ctx = NULL;
    c->next_try = clock_now() + c->backoff;
    c->backoff = c->backoff * 2 > 2.0 ? 2.0 : c->backoff * 2;
}

void redis_free(struct redis *c) {
    if (!c) return;
    if (c->ctx) redisFree(c->ctx);
    free(c);
}

static struct timeval redis_tv(double s) {
    struct timeval tv = {(time_t)s, (suseconds_t)((s - (double)(time_t)s) * 1e6)};
    return tv;
}

/* AUTH and SELECT on a new connection; false with why set. */
static bool redis_hello(struct redis *c) {
    char db[16];
    redisReply *rep = NULL;
    if (c->url.password[0]) {
        const char *argv[] = {"AUTH", c->url.password};
        rep = redisCommandArgv(c->ctx, 2, argv, NULL);
        if (!rep || rep->type == REDIS_REPLY_ERROR) {
            snprintf(c->why, sizeof c->why, "AUTH refused: %s", rep ? rep->str : c->ctx->errstr);
            if (rep) freeReplyObject(rep);
            return false;
        }
        freeReplyObject(rep);
    }
    if (c->url.db) {
        snprintf(db, sizeof db, "%d", c->url.db);
        const char *argv[] = {"SELECT", db};
        rep = redisCommandArgv(c->ctx, 2, argv, NULL);
        if (!rep || rep->type == REDIS_REPLY_ERROR) {
            snprintf(c->why, sizeof c->why, "SELECT %s refused: %s", db,
                     rep ? rep->str : c->ctx->errstr);
            if (rep) freeReplyObject(rep);
            return false;
        }
        freeReplyObject(rep);
    }
    return true;
}

/* Whether the peer closed connection fd (it sent its FIN: Redis was
 * restarted or killed while the connection was idle).  Seen before a
 * command is sent, such a connection is replaced at once, and the command
 * goes to the Redis that is there now: the first request after a restart
 * does not fail on the dead socket, and nothing is sent twice. */
static bool redis_peer_closed(int fd) {
    char b;
    ssize_t n = recv(fd, &b, 1, MSG_PEEK | MSG_DONTWAIT);
    return n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR);
}

/* A live connection, or false (why set) -- at most one try per back-off. */
static bool redis_connect(struct redis *c) {
    if (c->ctx && redis_peer_closed(c->ctx->fd)) {
        redis_drop(c);
        c->next_try = 0; /* connect again now, as after a broken command */
    }
    if (c->ctx) return true;
    if (clock_now() < c->next_try) return false;
    struct timeval tv = redis_tv(c->timeout_s);
    c->ctx = c->url.unix_path[0] ? redisConnectUnixWithTimeout(c->url.unix_path, tv)
                                 : redisConnectWithTimeout(c->url.host, c->url.port, tv);
    if (!c->ctx || c->ctx->err) {
        snprintf(c->why, sizeof c->why, "cannot connect: %s",
                 c->ctx ? c->ctx->errstr : "out of memory");
        redis_drop(c);
        return false;
    }
    if (redisSetTimeout(c->ctx, tv) != REDIS_OK || !redis_hello(c)) {
        if (!c->why[0]) snprintf(c->why, sizeof c->why, "cannot set the timeout");
        redis_drop(c);
        return false;
    }
    c->backoff = 0.1;
    c->why[0] = 0;
    return true;
}

redisReply *redis_argv(struct redis *c, int argc, const char **argv, const size_t *lens) {
    if (!redis_connect(c)) return NULL;
    redisReply *rep = redisCommandArgv(c->ctx, argc, argv, lens);
    if (!rep) {
        snprintf(c->why, sizeof c->why, "%s", c->ctx->errstr[0] ? c->ctx->errstr : "no reply");
        redis_drop(c);
        c->next_try = 0; /* one broken connection: the next command tries at once */
    }
    return rep;
}

redisReply *redis_strs(struct redis *c, const char **argv) {
    int n = 0;
    while (argv[n]) n++;
    return redis_argv(c, n, argv, NULL);
}

redisReply *redis_cmd(struct redis *c, const char *fmt, ...) {
    if (!redis_connect(c)) return NULL;
    va_list ap;
    va_start(ap, fmt);
    redisReply *rep = redisvCommand(c->ctx, fmt, ap);
    va_end(ap);
    if (!rep) {
        snprintf(c->why, sizeof c->why, "%s", c->ctx->errstr[0] ? c->ctx->errstr : "no reply");
        redis_drop(c);
        c->next_try = 0;
    }
    return rep;
}

bool redis_is_up(const struct redis *c) { return c->ctx != NULL; }

const char *redis_why(const struct redis *c) { return c->why; }

bool redis_failed(struct redis *c, const redisReply *rep) {
    if (!rep) return true;
    if (rep->type != REDIS_REPLY_ERROR) return false;
    snprintf(c->why, sizeof c->why, "Redis answered: %s", rep->str);
    /* LOADING (a restart reading its AOF), READONLY (a replica): not ours to fix */
    return true;
}

const redisReply *redis_field(const redisReply *arr, const char *name) {
    if (!arr || arr->type != REDIS_REPLY_ARRAY) return NULL;
    for (size_t i = 0; i + 1 < arr->elements; i += 2) {
        const redisReply *k = arr->element[i];
        if (k->type == REDIS_REPLY_STRING && !strcmp(k->str, name)) return arr->element[i + 1];
    }
    return NULL;
}

long long redis_ll(const redisReply *s, long long def) {
    if (!s) return def;
    if (s->type == REDIS_REPLY_INTEGER) return s->integer;
    if (s->type != REDIS_REPLY_STRING) return def;
    char *end;
    long long v = strtoll(s->str, &end, 10);
    return end == s->str ? def : v;
}
