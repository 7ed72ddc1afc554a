/* error.h -- filling struct rayd_error (internal). */
#ifndef ERROR_H
#define ERROR_H

#include "rayd/rayd.h"

/* Sets code, path (may be NULL) and a printf-style message; err may be NULL.
 * Returns code so callers can write `return err_set(err, ...)`. */
enum rayd_status err_setf(struct rayd_error *err, enum rayd_status code, const char *path,
                          const char *fmt, ...) __attribute__((format(printf, 4, 5)));

/* err_setf as an expression whose value is code, seen at the call: clang's
 * analyzer does not follow calls into variadic functions, so after
 * `return err_setf(...)` it would take RAYD_OK for a possible result and
 * read on, in the caller, into outputs that a failure never set. */
#define err_set(err, code, ...)                                                                    \
    __extension__({                                                                                \
        enum rayd_status err_code_ = (code);                                                       \
        err_setf((err), err_code_, __VA_ARGS__);                                                   \
        err_code_;                                                                                 \
    })

#endif
