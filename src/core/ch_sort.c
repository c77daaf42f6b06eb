#include "ch_sort.h"

#include <omp.h>
#include <stdlib.h>

/* Below this many items per thread the threads' counts cost more than
 * they save. */
enum { ITEMS_PER_THREAD = 1 << 16 };

int ch_sort_buckets(const int *key, size_t n, int nkeys, int *start, int *order) {
  size_t nk = (size_t)(nkeys > 0 ? nkeys : 0);
  size_t nb = (size_t)omp_get_max_threads();
  if (nb > n / ITEMS_PER_THREAD) nb = n / ITEMS_PER_THREAD;
  if (nb < 1) nb = 1;
  /* count[b * nk + k]: range b's items of key k, then where range b puts
   * its first one. Without atomics: with them two threads fought over the
   * same counters' cache lines. */
  int *count = calloc(nb * nk + 1, sizeof *count);
  if (!count) return -1;
#pragma omp parallel for schedule(static, 1) num_threads((int)nb)
  for (size_t b = 0; b < nb; b++) {
    int *c = &count[b * nk];
    for (size_t i = b * n / nb, i1 = (b + 1) * n / nb; i < i1; i++) c[key[i]]++;
  }
  int at = 0;
  for (size_t k = 0; k < nk; k++) {
    start[k] = at;
    for (size_t b = 0; b < nb; b++) {
      int c = count[b * nk + k];
      count[b * nk + k] = at;
      at += c;
    }
  }
  start[nk] = at;
#pragma omp parallel for schedule(static, 1) num_threads((int)nb)
  for (size_t b = 0; b < nb; b++) {
    int *c = &count[b * nk];
    for (size_t i = b * n / nb, i1 = (b + 1) * n / nb; i < i1; i++) order[c[key[i]]++] = (int)i;
  }
  free(count);
  return 0;
}

static void swap_double(double *a, double *b) {
  double t = *a;
  *a = *b;
  *b = t;
}

double ch_sort_select(double *x, long n, long k) {
  long lo = 0, hi = n - 1;
  while (hi > lo) {
    long mid = lo + (hi - lo) / 2;
    if (x[mid] < x[lo]) swap_double(&x[mid], &x[lo]);
    if (x[hi] < x[lo]) swap_double(&x[hi], &x[lo]);
    if (x[hi] < x[mid]) swap_double(&x[hi], &x[mid]);
    double pivot = x[mid];
    long i = lo, j = hi;
    while (i <= j) {
      while (x[i] < pivot) i++;
      while (x[j] > pivot) j--;
      if (i <= j) swap_double(&x[i++], &x[j--]);
    }
    if (k <= j)
      hi = j;
    else if (k >= i)
      lo = i;
    else
      return x[k];
  }
  return x[k];
}
