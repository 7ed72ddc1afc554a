/* log.c -- the access log and the few operational messages.
 *
 * Everything goes to stderr, one line per event, so stdout carries only the
 * "rayd listening on ..." line a supervisor or test reads.  An access line is
 * written when libmicrohttpd reports a request complete: method, path,
 * status, body bytes, milliseconds waiting in the queue, milliseconds
 * rendering, total milliseconds.  --log-format json writes the same fields
 * as one JSON object a line.  stdio's own per-stream lock keeps lines whole;
 * the server adds no lock of its own here.
 */
#include "server.h"

#include <stdarg.h>
#include <string.h>
#include <time.h>

double log_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec / 1e9;
}

static void log_stamp(char *buf, size_t size)
{
    struct timespec ts;
    struct tm tm;
    clock_gettime(CLOCK_REALTIME, &ts);
    gmtime_r(&ts.tv_sec, &tm);
    size_t n = strftime(buf, size, "%Y-%m-%dT%H:%M:%S", &tm);
    snprintf(buf + n, size - n, ".%03ldZ", ts.tv_nsec / 1000000);
}

bool log_quiet;

void log_access(const struct log_access *a)
{
    if (log_quiet)
        return;
    char ts[40], path[512];
    log_stamp(ts, sizeof ts);
    if (config.log_json) {
        char method[64];
        fprintf(stderr,
                "{\"time\":\"%s\",\"method\":\"%s\",\"path\":\"%s\",\"status\":%d,\"bytes\":%zu,"
                "\"queue_ms\":%.3f,\"render_ms\":%.3f,\"encode_ms\":%.3f,\"total_ms\":%.3f"
                "%s%s%s}\n",
                ts, http_json_escape(a->method, method, sizeof method),
                http_json_escape(a->path, path, sizeof path), a->status, a->bytes, a->queue_ms,
                a->render_ms, a->encode_ms, a->total_ms, a->note ? ",\"note\":\"" : "",
                a->note ? a->note : "", a->note ? "\"" : "");
    } else {
        /* keep the line one line whatever the client sent */
        snprintf(path, sizeof path, "%s", a->path);
        for (char *p = path; *p; p++)
            if ((unsigned char)*p < 0x20 || *p == ' ' || *p == 0x7f)
                *p = '?';
        fprintf(stderr,
                "%s %s %s %d %zu queue_ms=%.3f render_ms=%.3f encode_ms=%.3f total_ms=%.3f%s%s\n",
                ts, a->method, path, a->status, a->bytes, a->queue_ms, a->render_ms, a->encode_ms,
                a->total_ms, a->note ? " note=" : "", a->note ? a->note : "");
    }
}

static void log_msg(const char *level, const char *fmt, va_list ap)
{
    if (log_quiet)
        return;
    char ts[40], msg[1024];
    log_stamp(ts, sizeof ts);
    vsnprintf(msg, sizeof msg, fmt, ap);
    if (config.log_json) {
        char esc[2048];
        fprintf(stderr, "{\"time\":\"%s\",\"level\":\"%s\",\"message\":\"%s\"}\n", ts, level,
                http_json_escape(msg, esc, sizeof esc));
    } else {
        fprintf(stderr, "%s %s %s\n", ts, level, msg);
    }
}

void log_info(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    log_msg("info", fmt, ap);
    va_end(ap);
}

void log_warn(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    log_msg("warn", fmt, ap);
    va_end(ap);
}
