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

/* A large array of plain numbers that the scene loader reads from the text
 * itself instead of through cJSON (load/scene_json_inline.c): the value of
 * "vertices", "indices", "normals" or "uvs" in an object that is an element
 * of an array and has "type": "mesh". */
struct json_span {
    size_t open, close; /* offsets of its '[' and ']' */
    long count;         /* the numbers in it */
    long ordinal;       /* the arrays that open before it, in document order */
    size_t owner;       /* the walk's own: the offset of its object's '{' */
};

struct json_spans {
    long min_count; /* note arrays of at least this many numbers (and >= 1) */
    struct json_span *v;
    size_t n, cap;
};

/* json_check, noting such spans in *spans (NULL: none); spans->v is
 * malloc'd (free it); if it cannot grow, no span is noted. */
enum rayd_status json_check_spans(const char *text, size_t len, int max_depth,
                                  struct json_spans *spans, struct rayd_error *err);

#endif
