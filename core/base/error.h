/* error.h -- filling struct rayd_error (internal). */
#ifndef ERROR_H
#define ERROR_H

#include "rayd/rayd.h"

/* Sets code, path (may be NULL) and a printf-style message; err may be NULL.
 * Returns code so callers can write `return err_set(err, ...)`. */
enum rayd_status err_set(struct rayd_error *err, enum rayd_status code, const char *path,
                         const char *fmt, ...) __attribute__((format(printf, 4, 5)));

#endif
