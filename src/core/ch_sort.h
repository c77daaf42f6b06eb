/* ch_sort: a stable counting sort of integer keys, in parallel (the
 * vertex -> corner and face -> bucket tables the embedding and the mesh
 * cleanup build over millions of items). */
#ifndef CH_SORT_H
#define CH_SORT_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Buckets items 0 .. n - 1 by key[i] in [0, nkeys): on return the items of
 * key k are order[start[k] .. start[k + 1] - 1], in increasing order
 * (start holds nkeys + 1 entries, order n). The result is the serial
 * stable sort's whatever the thread count: each thread counts and then
 * places one contiguous range of the items, after the ranges before it.
 * 0 on success, -1 out of memory (start and order then undefined). */
int ch_sort_buckets(const int *key, size_t n, int nkeys, int *start, int *order);

#ifdef __cplusplus
}
#endif

#endif
