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
 * huge_alloc_pages does the same for any size, for buffers that live for
 * one render and fill most of their pages -- the frame, the PNG encoder's
 * blocks (image.c; png_encode.c, "Memory") -- so that a 2 MiB page costs
 * one fault instead of 512.  A fresh huge page is zeroed whole by the
 * kernel, so one that would hold a few hundred KB costs more than their
 * faults when the host must back it anew (bench/README.md, "Page faults").
 * These blocks are mapped with mmap, so a fresh one is known to be zeros
 * and huge_calloc_pages leaves its first touch to its writers.
 */
#define _DEFAULT_SOURCE /* madvise */
#include "base/hugemem.h"
#include "rayd/rayd.h"

#include <pthread.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

#define HUGEMEM_PAGE ((size_t)2 << 20)
#define HUGEMEM_MIN ((size_t)4 << 20) /* smaller arrays: plain malloc */

/* Blocks huge_free_pages keeps for the next huge_alloc_pages of their size:
 * a server asks for the same buffers (a frame, the PNG encoder's) request
 * after request, and on the virtual machines rayd runs on, fresh huge pages
 * cost the kernel's zeroing of them on every fault (clear_page: 12% of the
 * server's CPU on the 1080p sphere scene, POST after POST), where kept ones
 * are warm.  At most HUGEMEM_KEEP bytes in HUGEMEM_KEEP_N blocks, until
 * rayd_memory_trim gives them back (rayd, once it goes idle). */
#define HUGEMEM_KEEP ((size_t)32 << 20)
#define HUGEMEM_KEEP_N 16
static struct {
    void *p;
    size_t whole;
} kept[HUGEMEM_KEEP_N];
static int nkept;
static size_t kept_bytes;
static pthread_mutex_t kept_lock = PTHREAD_MUTEX_INITIALIZER;

/* bytes rounded up to whole huge pages (one at least); 0 past SIZE_MAX. */
static size_t huge_whole(size_t bytes) {
    if (bytes > SIZE_MAX - HUGEMEM_PAGE) return 0;
    return bytes ? (bytes + HUGEMEM_PAGE - 1) / HUGEMEM_PAGE * HUGEMEM_PAGE : HUGEMEM_PAGE;
}

/* A kept block of whole bytes, or NULL. */
static void *kept_take(size_t whole) {
    void *p = NULL;
    pthread_mutex_lock(&kept_lock);
    for (int i = nkept - 1; i >= 0 && !p; i--)
        if (kept[i].whole == whole) {
            p = kept[i].p;
            kept[i] = kept[--nkept];
            kept_bytes -= whole;
        }
    pthread_mutex_unlock(&kept_lock);
    return p;
}

/* Asks the kernel for huge pages over p's whole bytes (a huge page's
 * boundary); where it says no, they stay ordinary pages. */
static void advise_huge(void *p, size_t whole) {
#ifdef MADV_HUGEPAGE
    if (p) madvise(p, whole, MADV_HUGEPAGE);
#else
    (void)p, (void)whole;
#endif
}

/* whole bytes (a multiple of HUGEMEM_PAGE) mapped fresh at a huge page's
 * boundary, or NULL.  Straight from mmap, not aligned_alloc: a fresh
 * mapping is known to read as zeros (huge_calloc_pages then need not touch
 * it), and its pages are first touched by whoever writes them -- the
 * render's threads, each its own tiles -- not by one thread zeroing them
 * all before the work starts. */
static void *map_pages(size_t whole) {
    if (whole > SIZE_MAX - HUGEMEM_PAGE) return NULL;
    size_t len = whole + HUGEMEM_PAGE;
    char *m = mmap(NULL, len, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (m == MAP_FAILED) return NULL;
    size_t head = (HUGEMEM_PAGE - (uintptr_t)m % HUGEMEM_PAGE) % HUGEMEM_PAGE;
    if (head) munmap(m, head);
    if (len - head > whole) munmap(m + head + whole, len - head - whole);
    advise_huge(m + head, whole);
    return m + head;
}

/* A block for bytes (whole huge pages), kept or mapped anew, and in *fresh
 * whether it is new (all zeros). */
static void *pages_get(size_t bytes, bool *fresh) {
    size_t whole = huge_whole(bytes);
    *fresh = false;
    if (!whole) return NULL;
    void *p = kept_take(whole);
    if (p) return p;
    *fresh = true;
    return map_pages(whole);
}

size_t huge_pages_room(size_t bytes) { return huge_whole(bytes); }

void *huge_alloc_pages(size_t bytes) {
    bool fresh;
    return pages_get(bytes, &fresh);
}

void *huge_calloc_pages(size_t bytes) {
    bool fresh;
    void *p = pages_get(bytes, &fresh);
    if (p && !fresh) memset(p, 0, bytes); /* a kept block: warm, and quick to clear */
    return p;
}

void huge_free_pages(void *p, size_t bytes) {
    if (!p) return;
    size_t whole = huge_whole(bytes);
    pthread_mutex_lock(&kept_lock);
    bool keep = nkept < HUGEMEM_KEEP_N && kept_bytes + whole <= HUGEMEM_KEEP;
    if (keep) {
        kept[nkept].p = p, kept[nkept].whole = whole;
        nkept++;
        kept_bytes += whole;
    }
    pthread_mutex_unlock(&kept_lock);
    if (!keep) munmap(p, whole);
}

void rayd_memory_trim(void) {
    pthread_mutex_lock(&kept_lock);
    int n = nkept;
    struct {
        void *p;
        size_t whole;
    } drop[HUGEMEM_KEEP_N];
    for (int i = 0; i < n; i++) drop[i].p = kept[i].p, drop[i].whole = kept[i].whole;
    nkept = 0;
    kept_bytes = 0;
    pthread_mutex_unlock(&kept_lock);
    for (int i = 0; i < n; i++) munmap(drop[i].p, drop[i].whole);
}

void *huge_alloc_if(bool huge, size_t bytes) {
    return huge ? huge_alloc_pages(bytes) : malloc(bytes);
}

void huge_free_if(bool huge, void *p, size_t bytes) {
    if (huge)
        huge_free_pages(p, bytes);
    else
        free(p);
}

/* For huge_alloc: from malloc's heap (freed with free, grown with
 * realloc), aligned and advised like map_pages. */
static void *heap_pages(size_t bytes) {
    size_t whole = huge_whole(bytes);
    void *p = whole ? aligned_alloc(HUGEMEM_PAGE, whole) : NULL;
    advise_huge(p, whole);
    return p;
}

void *huge_alloc(size_t bytes) { return bytes < HUGEMEM_MIN ? malloc(bytes) : heap_pages(bytes); }

size_t huge_alloc_room(size_t bytes) {
    size_t whole = bytes < HUGEMEM_MIN ? bytes : huge_whole(bytes);
    return whole ? whole : bytes;
}

void *huge_calloc(size_t n, size_t size) {
    if (size && n > SIZE_MAX / size) return NULL;
    size_t bytes = n * size;
    if (bytes < HUGEMEM_MIN) return calloc(n ? n : 1, size ? size : 1);
    void *p = huge_alloc(bytes);
    if (p) memset(p, 0, bytes);
    return p;
}
