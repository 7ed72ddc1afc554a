/* error.c -- the error struct every fallible core call fills.
 *
 * Modelled on SQLite (code + message + location) and Redis anet.c (the
 * caller owns the buffer, NULL is allowed).  The struct has fixed-size
 * buffers, so setting an error never allocates and never fails, which
 * matters on the out-of-memory path.
 */
#include "base/error.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

enum rayd_status err_setf(struct rayd_error *err, enum rayd_status code, const char *path,
                          const char *fmt, ...) {
    if (!err) return code;
    err->code = code;
    err->line = 0;
    err->column = 0;
    snprintf(err->path, sizeof err->path, "%s", path ? path : "");
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err->message, sizeof err->message, fmt, ap);
    va_end(ap);
    return code;
}

const char *rayd_status_name(enum rayd_status s) {
    switch (s) {
    case RAYD_OK: return "ok";
    case RAYD_E_PARSE: return "invalid_json";
    case RAYD_E_INVALID: return "invalid_scene";
    case RAYD_E_LIMIT: return "too_large";
    case RAYD_E_ARG: return "bad_argument";
    case RAYD_E_NOMEM: return "out_of_memory";
    case RAYD_E_IO: return "io_error";
    case RAYD_E_CANCELED: return "canceled";
    case RAYD_E_INTERNAL: return "internal";
    }
    return "internal";
}

char *rayd_error_format(const struct rayd_error *err, char *buf, size_t size) {
    if (!buf || size == 0) return buf;
    if (!err) {
        snprintf(buf, size, "unknown error");
    } else if (err->line > 0) {
        snprintf(buf, size, "line %d, column %d: %s", err->line, err->column, err->message);
    } else if (err->path[0]) {
        snprintf(buf, size, "%s: %s", err->path, err->message);
    } else {
        snprintf(buf, size, "%s", err->message);
    }
    return buf;
}
