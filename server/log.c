/* log.c -- the access log and the few operational messages.
 *
 * Everything goes to stderr, one line per event, so stdout carries only the
 * "rayd listening on ..." line a supervisor or test reads.  An access line is
 * written when a request is complete: method, path, status, body bytes,
 * milliseconds waiting in the queue, rendering, encoding, in all.
 * --log-format json writes the same fields as one JSON object a line, built
 * by cJSON so a client's path can never break the line.  stdio's own
 * per-stream lock keeps lines whole; the server adds no lock of its own.
 *
 * Layer: base.  Every layer logs; log.c calls nothing above it (config is
 * base too), so it can never be part of a call cycle.
 */
#include "base.h"

#include <cjson/cJSON.h>
#include <stdarg.h>
#include <stdlib.h>
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

/* Writes o as one line and deletes it.  The line is printed into a stack
 * buffer first: no allocation for the text on the way out. */
static void log_json_line(cJSON *o)
{
    char line[4096];
    if (json_print_into(o, line, sizeof line)) {
        fprintf(stderr, "%s\n", line);
    } else {
        char *text = json_print(o, false, NULL);
        o = NULL;
        if (text)
            fprintf(stderr, "%s\n", text);
        free(text);
    }
    cJSON_Delete(o);
}

static void log_access_json(const char *ts, const struct log_access *a)
{
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "time", ts);
    cJSON_AddStringToObject(o, "method", a->method);
    cJSON_AddStringToObject(o, "path", a->path);
    cJSON_AddNumberToObject(o, "status", a->status);
    json_add_u64(o, "bytes", a->bytes);
    json_add_fixed(o, "queue_ms", a->queue_ms, 3);
    json_add_fixed(o, "render_ms", a->render_ms, 3);
    json_add_fixed(o, "encode_ms", a->encode_ms, 3);
    json_add_fixed(o, "total_ms", a->total_ms, 3);
    if (a->note)
        cJSON_AddStringToObject(o, "note", a->note);
    log_json_line(o);
}

void log_access(const struct log_access *a)
{
    if (log_quiet)
        return;
    char ts[40], path[512];
    log_stamp(ts, sizeof ts);
    if (config.log_json) {
        log_access_json(ts, a);
        return;
    }
    /* keep the line one line whatever the client sent */
    snprintf(path, sizeof path, "%s", a->path);
    for (char *p = path; *p; p++)
        if ((unsigned char)*p < 0x20 || *p == ' ' || *p == 0x7f)
            *p = '?';
    fprintf(stderr,
            "%s %s %s %d %zu queue_ms=%.3f render_ms=%.3f encode_ms=%.3f total_ms=%.3f%s%s\n", ts,
            a->method, path, a->status, a->bytes, a->queue_ms, a->render_ms, a->encode_ms,
            a->total_ms, a->note ? " note=" : "", a->note ? a->note : "");
}

static void log_msg(const char *level, const char *fmt, va_list ap)
{
    if (log_quiet)
        return;
    char ts[40], msg[1024];
    log_stamp(ts, sizeof ts);
    vsnprintf(msg, sizeof msg, fmt, ap);
    if (config.log_json) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "time", ts);
        cJSON_AddStringToObject(o, "level", level);
        cJSON_AddStringToObject(o, "message", msg);
        log_json_line(o);
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
