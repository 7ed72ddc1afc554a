/* prog.c -- which program is running, and how it says an error.
 *
 * Every error of rayd-render and rayd-client is one line on stderr,
 * "rayd-render: error: ..." (README "Command-line conventions"); the
 * helpers of this room say theirs the same way, so they need the name.
 * main sets it first thing; it is never changed after.
 */
#include "common/common.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

static const char *prog = "rayd";

void prog_init(const char *name) { prog = name; }

const char *prog_input_name(const char *path) { return strcmp(path, "-") ? path : "<stdin>"; }

void prog_error(const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "%s: error: ", prog);
    vfprintf(stderr, fmt, ap);
    fprintf(stderr, "\n");
    va_end(ap);
}
