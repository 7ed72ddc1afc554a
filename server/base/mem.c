/* mem.c -- one memory budget (--max-memory) for everything a request can
 * make rayd hold.
 *
 * Each kind of memory a client can cause is counted here while it exists:
 * request bodies in flight, compiled scenes (cached, queued or in use: their
 * textures, meshes and BVHs, as rayd_scene_info says), the pixels and sums of
 * renders in progress and of progressive jobs (the sums kind), finished
 * results (PNG, 16-bit PNG, EXR and sums answers: every blob) and the result
 * cache.  The one limit covers their total.  A reservation that does not fit
 * first asks the work layer to free what it may (its reclaimer: the caches'
 * least recently used entries, then finished jobs' images, oldest first); if
 * it still does not fit the caller refuses the request (503 with
 * Retry-After, or 413 when the request alone is over the whole budget)
 * instead of growing past the limit.  Bytes that already exist (a PNG just
 * encoded for a render that was admitted) are forced in: counted even past
 * the limit, which admission keeps rare by reserving a render's output up
 * front.
 *
 * Counters are atomics, so any thread reserves and releases without a
 * lock.  The reclaimer takes work_lock: mem_reserve is never called with it
 * held (mem_try is the lock-held form, which never reclaims).
 *
 * Freed memory goes back to the allocator, which keeps small freed blocks
 * in its arenas: after many megabytes are released, mem_trim hands them back
 * to the kernel (malloc_trim), so the process's resident size follows the
 * count down rather than staying at its peak.  malloc_trim walks every
 * arena under its lock (milliseconds with a large heap, and every malloc of
 * that arena waits), so the watcher calls it, once a second at most, off
 * every request's and worker's path (but for the one exception below).
 * The core also keeps the blocks of its last frames for the next render
 * (up to 32 MB, hugemem.c): once no render is left, those go back too
 * (rayd_memory_trim), so an idle rayd's resident size comes back to about
 * its size at start.
 *
 * One exception to the watcher's pace: a reservation that had to evict
 * (the budget full) trims at once, before the memory it made room for is
 * allocated, when the eviction released MEM_TRIM_RECLAIM or more.  glibc
 * raises its mmap threshold to the largest block freed (up to 32 MB), so
 * an evicted scene's textures go back to the arena of the thread that
 * made them, and stay resident there while the new scene, parsed on
 * another thread, takes fresh pages: the count said the budget had room,
 * and resident memory went past it by the evicted scene (3.9 MB over in
 * tests/integration/memory_budget.sh, one run in six beside other tests).
 * Fixing the threshold instead (every big block its own mapping) cost a
 * denoised render 17% in fresh pages' faults, request after request; the
 * trim costs milliseconds, and only when the budget is full.
 */
#define _GNU_SOURCE
#include "base/base.h"

#include <malloc.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define MEM_TRIM_AFTER ((size_t)16 << 20)  /* released bytes that warrant a malloc_trim */
#define MEM_TRIM_RECLAIM ((size_t)1 << 20) /* evicted bytes a reservation trims after */

static size_t mem_limit_bytes = SIZE_MAX;
static atomic_size_t mem_total_bytes;
static atomic_size_t mem_kind_bytes[MEM__COUNT];
static atomic_size_t mem_released;   /* since the last trim */
static atomic_size_t mem_peak_bytes; /* the highest mem_total_bytes has been */
static bool (*mem_reclaimer)(enum mem_kind k, size_t need);

const char *mem_kind_name(enum mem_kind k) {
    static const char *const names[] = {"bodies", "scenes", "results", "sums",
                                        "caches", "parses", "frames"};
    return names[k];
}

/* The machine's memory, or the cgroup's limit when lower (a container). */
static size_t mem_machine(void) {
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    size_t total = pages > 0 && page > 0 ? (size_t)pages * (size_t)page : (size_t)1 << 32;
    FILE *f = fopen("/sys/fs/cgroup/memory.max", "r");
    if (f) {
        unsigned long long cg = 0;
        if (fscanf(f, "%llu", &cg) == 1 && cg > 0 && cg < total) total = (size_t)cg;
        fclose(f);
    }
    return total;
}

size_t mem_default_limit(void) { return mem_machine() / 2; }

void mem_start(size_t limit) { mem_limit_bytes = limit ? limit : mem_default_limit(); }

size_t mem_limit(void) { return mem_limit_bytes; }

void mem_set_reclaim(bool (*reclaim)(enum mem_kind k, size_t need)) { mem_reclaimer = reclaim; }

/* Raises the peak to total if it is higher. */
static void mem_note_peak(size_t total) {
    size_t peak = atomic_load(&mem_peak_bytes);
    while (total > peak && !atomic_compare_exchange_weak(&mem_peak_bytes, &peak, total))
        ;
}

/* mem_reserve without reclaiming: callable with any lock held. */
static bool mem_try(enum mem_kind k, size_t n) {
    size_t cur = atomic_load(&mem_total_bytes);
    do {
        if (n > mem_limit_bytes || cur > mem_limit_bytes - n) return false;
    } while (!atomic_compare_exchange_weak(&mem_total_bytes, &cur, cur + n));
    atomic_fetch_add(&mem_kind_bytes[k], n);
    mem_note_peak(cur + n);
    return true;
}

bool mem_reserve(enum mem_kind k, size_t n) {
    if (n > mem_limit_bytes) return false;
    size_t before = atomic_load(&mem_released);
    bool evicted = false;
    while (!mem_try(k, n)) {
        if (!mem_reclaimer || !mem_reclaimer(k, n)) return false;
        evicted = true;
    }
    /* what was evicted goes back to the kernel before the room is used
     * (the file's comment: another thread's arena would keep it); a trim
     * by the watcher meanwhile zeroes mem_released, and the difference
     * wraps to a huge one: one trim more, never one less */
    if (evicted && atomic_load(&mem_released) - before >= MEM_TRIM_RECLAIM) malloc_trim(0);
    return true;
}

void mem_force(enum mem_kind k, size_t n) {
    size_t total = atomic_fetch_add(&mem_total_bytes, n) + n;
    atomic_fetch_add(&mem_kind_bytes[k], n);
    mem_note_peak(total);
}

void mem_release(enum mem_kind k, size_t n) {
    if (!n) return;
    atomic_fetch_sub(&mem_kind_bytes[k], n);
    atomic_fetch_sub(&mem_total_bytes, n);
    atomic_fetch_add(&mem_released, n);
}

void mem_freed(size_t n) { atomic_fetch_add(&mem_released, n); }

void mem_move(enum mem_kind from, enum mem_kind to, size_t n) {
    atomic_fetch_sub(&mem_kind_bytes[from], n);
    atomic_fetch_add(&mem_kind_bytes[to], n);
}

size_t mem_used(enum mem_kind k) { return atomic_load(&mem_kind_bytes[k]); }

size_t mem_peak(void) { return atomic_load(&mem_peak_bytes); }

void mem_trim(bool idle) {
    static bool kept; /* the core may keep freed frames: give them back once idle */
    if (atomic_load(&mem_released) >= MEM_TRIM_AFTER) {
        atomic_store(&mem_released, 0);
        kept = true;
        malloc_trim(0);
    }
    if (kept && idle) {
        kept = false;
        rayd_memory_trim();
        malloc_trim(0);
    }
}

bool mem_parse(const char *s, size_t *out) {
    char *end;
    if (!s || *s < '0' || *s > '9') return false;
    unsigned long long v = strtoull(s, &end, 10);
    unsigned long long mul = 1;
    if (*end && !strchr("kKmMgGtT", *end)) return false;
    switch (*end) {
    case 'k':
    case 'K': mul = 1ULL << 10; break;
    case 'm':
    case 'M': mul = 1ULL << 20; break;
    case 'g':
    case 'G': mul = 1ULL << 30; break;
    case 't':
    case 'T': mul = 1ULL << 40; break;
    default: break;
    }
    if (*end) {
        end++;
        if (*end == 'i') end++;
        if (*end == 'B') end++;
    }
    if (*end || v > SIZE_MAX / mul) return false;
    *out = (size_t)(v * mul);
    return true;
}
