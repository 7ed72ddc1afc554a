/* scene_json_inline.h -- the large inline mesh arrays, read from the scene
 * text instead of through cJSON (see scene_json_inline.c). */
#ifndef SCENE_JSON_INLINE_H
#define SCENE_JSON_INLINE_H

#include <stddef.h>

#include <cjson/cJSON.h>

#include "format/json_check.h"

/* Arrays of at least this many numbers take the fast path by default. */
#define SJ_INLINE_MIN 1000

struct sj_node {
    const cJSON *node;            /* the empty array cJSON built in its place */
    const struct json_span *span; /* where its numbers are in the text */
};

struct sj_inline {
    const char *text;        /* the scene text the spans point into */
    struct json_spans spans; /* from json_check_spans */
    struct sj_node *nodes;   /* one a span, sorted by node once matched */
};

/* The text for cJSON: the scene text without the numbers of the spans (each
 * array left as "[]"), in *copy (malloc'd), or NULL when there are no spans
 * (or no memory for the copy: then the spans are dropped and every array
 * goes through cJSON). */
void sj_inline_elide(struct sj_inline *in, const char *text, size_t len, char **copy,
                     size_t *copy_len);

/* Pairs each span with its node in the tree cJSON parsed from the copy. */
enum rayd_status sj_inline_match(struct sj_inline *in, const cJSON *root, struct rayd_error *err);

/* The span an array node stands for, or NULL: an ordinary array. */
const struct json_span *sj_inline_span(const struct sj_inline *in, const cJSON *array);

void sj_inline_free(struct sj_inline *in);

#endif
