/* ch_alloc: allocation of large per-texel and per-vertex arrays. */
#ifndef CH_ALLOC_H
#define CH_ALLOC_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Allocates count * size bytes (NULL on overflow or failure), zero-filled
 * if zero is set; release with free(). Arrays of several megabytes are
 * aligned to 2 MiB and offered to the kernel for transparent huge pages:
 * first-touch page faults otherwise cost as much as a pass over the data. */
void *ch_alloc_large(size_t count, size_t size, int zero);

#ifdef __cplusplus
}
#endif
#endif
