/* json_parse.h -- cJSON's parse, serialised (internal). */
#ifndef JSON_PARSE_H
#define JSON_PARSE_H

#include <stddef.h>

#include <cjson/cJSON.h>

/* cJSON_ParseWithLength under the core's one lock; NULL on failure (for
 * text that passed json_check: out of memory).  Free with cJSON_Delete. */
cJSON *json_parse_locked(const char *text, size_t len);

#endif
