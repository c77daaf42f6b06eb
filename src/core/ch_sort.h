/* ch_sort: a stable counting sort of integer keys, in parallel (the
 * vertex -> corner and face -> bucket tables the embedding and the mesh
 * cleanup build over millions of items), and the selection of a k-th
 * smallest value (shares and percentiles without a full sort). */
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

/* The k-th smallest (0-based) of x[0 .. n - 1], reordering x: Hoare's
 * selection with a median-of-three pivot, in expected linear time. n > 0,
 * 0 <= k < n, no NaN. */
double ch_sort_select(double *x, long n, long k);

#ifdef __cplusplus
}
#endif

#endif
