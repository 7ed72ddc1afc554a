/* hugemem.h -- allocations of many megabytes on transparent huge pages. */
#ifndef RAYD_HUGEMEM_H
#define RAYD_HUGEMEM_H

#include <stddef.h>

/* malloc and calloc for arrays that grow with a scene (a mesh's vertices
 * and triangles, the BVH builder's records): from HUGEMEM_MIN bytes on, on
 * 2 MiB transparent huge pages where the kernel allows them.  Free with
 * free(); realloc works on them as on any block. */
void *huge_alloc(size_t bytes);
void *huge_calloc(size_t n, size_t size);

#endif
