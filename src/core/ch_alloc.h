/* ch_alloc: allocation of large per-texel and per-vertex arrays, and the
 * growth of arrays built one item at a time. */
#ifndef CH_ALLOC_H
#define CH_ALLOC_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Allocates count * size bytes (NULL on overflow or failure), zero-filled
 * if zero is set; release with free(). The 2 MiB pages inside arrays of
 * several megabytes are offered to the kernel for transparent huge pages:
 * first-touch page faults otherwise cost as much as a pass over the data. */
void *ch_alloc_large(size_t count, size_t size, int zero);

/* Touches each page of [p, p + bytes) of a large array (as from
 * ch_alloc_large) on all threads before a pass fills it, so that the page
 * faults are shared evenly, whatever order the pass writes in; the
 * contents are then undefined. Below a few megabytes, nothing. */
void ch_alloc_prefault(void *p, size_t bytes);

/* Resizes *array, which holds old_count elements of size bytes, to
 * new_count, keeping the first min(old, new) (0 on success; -1 on overflow
 * or when out of memory, *array then untouched). Growth to a large size
 * moves the contents into memory from ch_alloc_large: realloc's new pages
 * would be faulted in 4 KiB at a time (growing a 118 MB array of triangles
 * by a quarter took 0.34 s that way on a virtual machine). */
int ch_alloc_resize(void **array, size_t old_count, size_t new_count, size_t size);

/* Grows the realloc'ed array *array of *cap elements of elem bytes so that
 * it holds at least need: capacity first_cap when empty, then doubled (or
 * need itself past 2^29, so int capacities do not overflow). 0 on success
 * (*array and *cap updated, the contents kept), -1 when out of memory or
 * need is negative (*array and *cap untouched, still valid). Not thread
 * safe for the same array. */
int ch_alloc_grow(void **array, int *cap, int need, size_t elem, int first_cap);

#ifdef __cplusplus
}
#endif
#endif
