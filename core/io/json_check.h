/* json_check.h -- strict JSON syntax check with line and column. */
#ifndef JSON_CHECK_H
#define JSON_CHECK_H

#include <stdbool.h>
#include <stddef.h>

#include "rayd/rayd.h"

/* RAYD_OK when text[0..len) is one well-formed JSON value in valid UTF-8
 * nested at most max_depth deep; else RAYD_E_PARSE with err's line, column
 * and message ("malformed JSON: expected ',' or '}', found 'x'"). */
enum rayd_status json_check(const char *text, size_t len, int max_depth, struct rayd_error *err);

/* 1-based line and column (in characters) of byte offset off. */
void json_position(const char *text, size_t off, int *line, int *col);

#endif
