/* json_numbers.h -- the numbers of a large JSON array, read from the text
 * itself (the inline mesh arrays json_check_spans notes). */
#ifndef JSON_NUMBERS_H
#define JSON_NUMBERS_H

#include <stddef.h>
#include <stdint.h>

#include "format/json_check.h"

#define JSON_NUMBERS_NOMEM (-2L) /* what they return when out of memory */

/* Reads the sp->count numbers of sp into out, each as the double cJSON
 * would read (strtod) cast to float, on up to threads threads (<= 0: every
 * core).  Returns -1, or the index of the first number that is not finite
 * or is past +-limit, its double in *bad. */
long json_floats(const char *text, const struct json_span *sp, double limit, int threads,
                 float *out, double *bad);

/* The same for vertex indices: -1, or the index of the first number that is
 * not a whole number in [0, nverts). */
long json_indices(const char *text, const struct json_span *sp, long nverts, int threads,
                  uint32_t *out);

/* The double strtod reads for the JSON number at *s (at most 63
 * characters); *s moves past it. */
double json_number(const char **s, char point);

#endif
