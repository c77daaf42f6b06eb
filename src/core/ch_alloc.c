#define _GNU_SOURCE
#include "ch_alloc.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

enum { HUGE_PAGE = 2 << 20 };

void *ch_alloc_large(size_t count, size_t size, int zero) {
  if (size && count > SIZE_MAX / size) return NULL;
  size_t bytes = count * size;
  if (bytes < 4 * (size_t)HUGE_PAGE) return zero ? calloc(count ? count : 1, size ? size : 1) : malloc(bytes ? bytes : 1);
  void *p = NULL;
  size_t rounded = (bytes + HUGE_PAGE - 1) / HUGE_PAGE * HUGE_PAGE;
  if (posix_memalign(&p, HUGE_PAGE, rounded) != 0) return NULL;
#ifdef MADV_HUGEPAGE
  madvise(p, rounded, MADV_HUGEPAGE);
#endif
  if (zero) memset(p, 0, bytes);
  return p;
}

int ch_alloc_grow(void **array, int *cap, int need, size_t elem, int first_cap) {
  if (need < 0) return -1;
  if (need <= *cap) return 0;
  int n = *cap > 0 ? *cap : (first_cap > 0 ? first_cap : 1);
  while (n < need) n = n > (1 << 29) ? need : 2 * n;
  if (elem && (size_t)n > SIZE_MAX / elem) return -1;
  void *p = realloc(*array, (size_t)n * elem);
  if (!p) return -1;
  *array = p;
  *cap = n;
  return 0;
}
