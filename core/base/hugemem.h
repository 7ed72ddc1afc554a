/* hugemem.h -- allocations of many megabytes on transparent huge pages. */
#ifndef RAYD_HUGEMEM_H
#define RAYD_HUGEMEM_H

#include <stdbool.h>
#include <stddef.h>

/* malloc and calloc for arrays that grow with a scene (a mesh's vertices
 * and triangles, the BVH builder's records): from HUGEMEM_MIN bytes on, on
 * 2 MiB transparent huge pages where the kernel allows them.  Free with
 * free(); realloc works on them as on any block. */
void *huge_alloc(size_t bytes);
void *huge_calloc(size_t n, size_t size);

/* The bytes huge_alloc(bytes) makes resident once they are touched: whole
 * huge pages from HUGEMEM_MIN on (a fault maps 2 MiB), so a budget that
 * charges this is not short by up to a page an array. */
size_t huge_alloc_room(size_t bytes);

/* Work buffers that live for one render (a frame, the PNG encoder's) on
 * huge pages whatever their size, rounded up to whole 2 MiB pages: one
 * fault each, where a fault is dear, rather than one per 4 KiB they touch.
 * Not zeroed.  Give them back with huge_free_pages and the same bytes,
 * which keeps a few for the next call of their size (warm: no fault, no
 * zeroing by the kernel). */
void *huge_alloc_pages(size_t bytes);
void huge_free_pages(void *p, size_t bytes);

/* huge_alloc_pages, all zeros: a fresh mapping is, and is left for its
 * writers to touch; only a kept block is cleared here. */
void *huge_calloc_pages(size_t bytes);

/* The bytes huge_alloc_pages(bytes) gives: whole huge pages; 0 when that
 * many cannot be. */
size_t huge_pages_room(size_t bytes);

/* huge_alloc_pages when huge, else malloc; and the free that matches, for
 * a buffer whose owner decided which by its size and keeps that flag. */
void *huge_alloc_if(bool huge, size_t bytes);
void huge_free_if(bool huge, void *p, size_t bytes);

#endif
