/* array.c -- amortised (doubling) array growth with overflow checks, shared
 * by the mesh decoders and the scene loader. */
#include "base/array.h"

#include "base/hugemem.h"

#include <stdint.h>
#include <stdlib.h>

bool array_grow(void **arr, size_t *cap, size_t need, size_t elem) {
    if (need <= *cap) return true;
    size_t n = *cap ? *cap : 16;
    while (n < need) {
        if (n > SIZE_MAX / 2) {
            n = need;
            break;
        }
        n *= 2;
    }
    if (elem == 0 || n > SIZE_MAX / elem) return false;
    void *p =
        *arr ? realloc(*arr, n * elem) : huge_alloc(n * elem); /* a big first block: huge pages */
    if (!p) return false;
    *arr = p;
    *cap = n;
    return true;
}
