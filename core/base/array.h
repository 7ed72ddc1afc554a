/* array.h -- growing arrays. */
#ifndef ARRAY_H
#define ARRAY_H

#include <stdbool.h>
#include <stddef.h>

/* Makes *arr (of *cap elements of elem bytes) hold at least need elements,
 * doubling; false on overflow or out of memory (then *arr is unchanged). */
bool array_grow(void **arr, size_t *cap, size_t need, size_t elem);

#endif
