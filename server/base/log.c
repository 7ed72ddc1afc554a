/* log.c -- the access log and the few operational messages.
 *
 * Everything goes to stderr, one line per event, so stdout carries only the
 * "rayd listening on ..." line a supervisor or test reads.  An access line is
 * written when a request is complete, with what an operator greps for:
 *
 *   time (RFC 3339, UTC, milliseconds), level, client address, method, the
 *   request-target as sent (path and query: a tile's region is in it),
 *   status, body bytes, [queue_ms render_ms encode_ms when it rendered],
 *   total_ms, [scene=<id>], request_id=<X-Request-Id>, [note=<why>],
 *   [cut_short=<why> size=<the whole body's bytes>]
 *
 * An answer cut short (the client stopped reading and closed, a send
 * failed, --timeout) keeps the status it was sent with; its bytes are those
 * that went out, and cut_short says why it ended.
 *
 * The level follows the status: info up to 3xx, warn for 4xx (499, a client
 * that left, included), error for 5xx, so --log-level warn keeps the
 * refusals and failures and drops the traffic.  --log-format json writes
 * the same fields as one JSON object a line, built by cJSON.  A client's
 * bytes never break a line: in the path and the method, controls, spaces,
 * DEL and every byte over 0x7e are written %XX (a request-target is ASCII
 * by RFC 9112, so what a client sent right reads unchanged), which keeps a
 * text line one line of space-separated fields and a JSON line valid UTF-8;
 * cJSON escapes the quotes and backslashes.  stdio's own per-stream lock
 * keeps lines whole; the server adds no lock of its own.
 *
 * Layer: base.  Every layer logs; log.c calls nothing above it (config is
 * base too), so it can never be part of a call cycle.
 */
#include "base/base.h"

#include <cjson/cJSON.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static void log_stamp(char *buf, size_t size) {
    struct timespec ts;
    struct tm tm;
    clock_gettime(CLOCK_REALTIME, &ts);
    gmtime_r(&ts.tv_sec, &tm);
    size_t n = strftime(buf, size, "%Y-%m-%dT%H:%M:%S", &tm);
    snprintf(buf + n, size - n, ".%03ldZ", ts.tv_nsec / 1000000);
}

bool log_quiet;

/* The words of --log-level (config.c parses them), in enum log_level order. */
static const char *const log_names[] = {"debug", "info", "warn", "error"};

/* config.log_min is set once before the first thread starts. */
static bool log_on(enum log_level level) { return !log_quiet && (int)level >= config.log_min; }

/* The level of an access line: info for 1xx-3xx, warn for 4xx (and for
 * 499, and 0), error for 5xx. */
static enum log_level log_access_level(int status) {
    if (status >= 500) return LOG_ERROR;
    if (status >= 400 || status < 100) return LOG_WARN;
    return LOG_INFO;
}

/* s as one field: controls, space, DEL and non-ASCII bytes as %XX; "-" for
 * none; cut with "..." to fit size. */
static const char *log_field(const char *s, char *buf, size_t size) {
    static const char hex[] = "0123456789ABCDEF";
    if (!s || !*s) return "-";
    size_t n = 0;
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        bool plain = c > 0x20 && c < 0x7f;
        if (n + (plain ? 1 : 3) + 4 > size) {
            memcpy(buf + n, "...", 4);
            return buf;
        }
        if (plain) {
            buf[n++] = (char)c;
        } else {
            buf[n++] = '%';
            buf[n++] = hex[c >> 4];
            buf[n++] = hex[c & 15];
        }
    }
    buf[n] = 0;
    return buf;
}

static const char *log_or_dash(const char *s) { return s && *s ? s : "-"; }

/* Writes o as one line and deletes it.  The line is printed into a stack
 * buffer first: no allocation for the text on the way out. */
static void log_json_line(cJSON *o) {
    char line[4096];
    if (json_print_into(o, line, sizeof line)) {
        fprintf(stderr, "%s\n", line);
    } else {
        char *text = json_print(o, false, NULL);
        o = NULL;
        if (text) fprintf(stderr, "%s\n", text);
        free(text);
    }
    cJSON_Delete(o);
}

/* Whether the request rendered something: its times go in the line. */
static bool log_rendered(const struct log_times *t) {
    return t->queue_ms > 0 || t->render_ms > 0 || t->encode_ms > 0;
}

static void log_access_json(const char *ts, const struct log_access *a, const char *method,
                            const char *path, const char *error_at) {
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "time", ts);
    cJSON_AddStringToObject(o, "level", log_names[log_access_level(a->status)]);
    cJSON_AddStringToObject(o, "client", log_or_dash(a->client));
    cJSON_AddStringToObject(o, "method", method);
    cJSON_AddStringToObject(o, "path", path);
    cJSON_AddNumberToObject(o, "status", a->status);
    json_add_u64(o, "bytes", a->bytes);
    if (log_rendered(&a->times)) {
        json_add_fixed(o, "queue_ms", a->times.queue_ms, 3);
        json_add_fixed(o, "render_ms", a->times.render_ms, 3);
        json_add_fixed(o, "encode_ms", a->times.encode_ms, 3);
    }
    json_add_fixed(o, "total_ms", a->total_ms, 3);
    if (a->scene && *a->scene) cJSON_AddStringToObject(o, "scene", a->scene);
    cJSON_AddStringToObject(o, "request_id", log_or_dash(a->request_id));
    if (a->error) cJSON_AddStringToObject(o, "error", a->error);
    if (a->error && a->error_at && *a->error_at) cJSON_AddStringToObject(o, "error_at", error_at);
    if (a->note) cJSON_AddStringToObject(o, "note", a->note);
    if (a->cut) {
        cJSON_AddStringToObject(o, "cut_short", a->cut);
        json_add_u64(o, "size", a->size);
    }
    log_json_line(o);
}

void log_access(const struct log_access *a) {
    enum log_level level = log_access_level(a->status);
    if (!log_on(level)) return;
    char ts[40], mbuf[64], pbuf[6144], ebuf[400], error[480] = "";
    log_stamp(ts, sizeof ts);
    const char *method = log_field(a->method, mbuf, sizeof mbuf);
    const char *path = log_field(a->path, pbuf, sizeof pbuf);
    const char *error_at = log_field(a->error_at, ebuf, sizeof ebuf);
    if (config.log_json) {
        log_access_json(ts, a, method, path, error_at);
        return;
    }
    if (a->error)
        snprintf(error, sizeof error, " error=%s%s%s", a->error,
                 a->error_at && *a->error_at ? " error_at=" : "",
                 a->error_at && *a->error_at ? error_at : "");
    char rendered[128] = "";
    if (log_rendered(&a->times))
        snprintf(rendered, sizeof rendered, "queue_ms=%.3f render_ms=%.3f encode_ms=%.3f ",
                 a->times.queue_ms, a->times.render_ms, a->times.encode_ms);
    bool scene = a->scene && *a->scene;
    char cut[96] = "";
    if (a->cut) snprintf(cut, sizeof cut, " cut_short=%s size=%zu", a->cut, a->size);
    fprintf(stderr, "%s %s %s %s %s %d %zu %stotal_ms=%.3f%s%s request_id=%s%s%s%s%s\n", ts,
            log_names[level], log_or_dash(a->client), method, path, a->status, a->bytes, rendered,
            a->total_ms, scene ? " scene=" : "", scene ? a->scene : "", log_or_dash(a->request_id),
            error, a->note ? " note=" : "", a->note ? a->note : "", cut);
}

static void log_msg(enum log_level level, const char *fmt, va_list ap)
    __attribute__((format(printf, 2, 0)));

static void log_msg(enum log_level level, const char *fmt, va_list ap) {
    if (!log_on(level)) return;
    char ts[40], msg[1024];
    log_stamp(ts, sizeof ts);
    vsnprintf(msg, sizeof msg, fmt, ap);
    if (config.log_json) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "time", ts);
        cJSON_AddStringToObject(o, "level", log_names[level]);
        cJSON_AddStringToObject(o, "message", msg);
        log_json_line(o);
    } else {
        fprintf(stderr, "%s %s %s\n", ts, log_names[level], msg);
    }
}

#define LOG_AT(name, level)                                                                        \
    void name(const char *fmt, ...) {                                                              \
        va_list ap;                                                                                \
        va_start(ap, fmt);                                                                         \
        log_msg(level, fmt, ap);                                                                   \
        va_end(ap);                                                                                \
    }
LOG_AT(log_debug, LOG_DEBUG)
LOG_AT(log_info, LOG_INFO)
LOG_AT(log_warn, LOG_WARN)
LOG_AT(log_error, LOG_ERROR)
/* Whatever the log's format and level: the line is for whoever reads the
 * crash, and abort leaves a core and the signal. */
void log_assert_fail(const char *expr, const char *file, int line, const char *func) {
    fprintf(stderr, "rayd: %s:%d: %s: assertion failed: %s\n", file, line, func, expr);
    fflush(stderr);
    abort();
}
