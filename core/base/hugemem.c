/* hugemem.c -- big arrays on transparent huge pages.
 *
 * Loading a 1.3M-triangle mesh touches some 150 MB of fresh memory, and on
 * 4 KiB pages a third of the load was the kernel's page faults (perf, on a
 * virtual machine, where a fault is dear).  Debian's kernel gives
 * transparent huge pages only to memory that asks (madvise mode), so a big
 * array is allocated aligned to 2 MiB, rounded up to whole huge pages, and
 * marked MADV_HUGEPAGE: one fault maps 2 MiB.  Measured on the 1.3M mesh:
 * its load 2-3x faster (make bench, bench/whole.sh).  Where the kernel
 * says no, the memory is ordinary and only the advice is lost.
 *
 * huge_alloc_pages does the same for any size: the PNG encoder's work
 * buffers, a few hundred KB each, live for one image and are touched
 * nearly whole, so a 2 MiB page a buffer costs one fault instead of a
 * hundred (png_encode.c, "Memory").
 */
#define _DEFAULT_SOURCE /* madvise */
#include "base/hugemem.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

#define HUGEMEM_PAGE ((size_t)2 << 20)
#define HUGEMEM_MIN ((size_t)4 << 20) /* smaller arrays: plain malloc */

void *huge_alloc_pages(size_t bytes) {
    if (bytes > SIZE_MAX - HUGEMEM_PAGE) return NULL;
    size_t whole = bytes ? (bytes + HUGEMEM_PAGE - 1) / HUGEMEM_PAGE * HUGEMEM_PAGE : HUGEMEM_PAGE;
    void *p = aligned_alloc(HUGEMEM_PAGE, whole);
#ifdef MADV_HUGEPAGE
    if (p) madvise(p, whole, MADV_HUGEPAGE);
#endif
    return p;
}

void *huge_alloc(size_t bytes) {
    return bytes < HUGEMEM_MIN ? malloc(bytes) : huge_alloc_pages(bytes);
}

void *huge_calloc(size_t n, size_t size) {
    if (size && n > SIZE_MAX / size) return NULL;
    size_t bytes = n * size;
    if (bytes < HUGEMEM_MIN) return calloc(n ? n : 1, size ? size : 1);
    void *p = huge_alloc(bytes);
    if (p) memset(p, 0, bytes);
    return p;
}
