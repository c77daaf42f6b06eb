#define _GNU_SOURCE
#include "ch_alloc.h"

#include <omp.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

enum { HUGE_PAGE = 2 << 20 };

/* Offers the 2 MiB pages inside [p, p + bytes) for transparent huge
 * pages (the kernel's own choice where they are off). */
static void advise_huge(void *p, size_t bytes) {
#ifdef MADV_HUGEPAGE
  uintptr_t a = ((uintptr_t)p + HUGE_PAGE - 1) / HUGE_PAGE * HUGE_PAGE;
  uintptr_t b = ((uintptr_t)p + bytes) / HUGE_PAGE * HUGE_PAGE;
  if (b > a) madvise((void *)a, b - a, MADV_HUGEPAGE);
#else
  (void)p;
  (void)bytes;
#endif
}

/* Zeroes [p, p + bytes) (zero set), or writes a 0 into each of its 4 KiB
 * pages, on all threads, one huge page at a time: where the pages are
 * first touched. Their faults cost more than the writes (a third of the
 * page clearing of a 2.1M-triangle run was the tessellation's arrays,
 * zeroed on one thread), and vary twentyfold on a virtual machine between
 * pages the kernel recycles and pages it has not touched yet: in halves,
 * one thread took 0.43 s over 400 MB while the other took 0.02 s. So the
 * huge pages are handed out one by one, and none is shared by two threads
 * (the second would wait for the first's fault). */
static void by_huge_page(void *p, size_t bytes, int zero) {
  char *c = p;
  uintptr_t first = ((uintptr_t)c + HUGE_PAGE - 1) / HUGE_PAGE * HUGE_PAGE;
  size_t head = first - (uintptr_t)c < bytes ? first - (uintptr_t)c : bytes, rest = bytes - head;
  size_t pages = (rest + HUGE_PAGE - 1) / HUGE_PAGE;
  if (zero) memset(c, 0, head);
  for (size_t k = 0; !zero && k < head; k += 4096) c[k] = 0;
#pragma omp parallel for schedule(dynamic, 1)
  for (size_t i = 0; i < pages; i++) {
    char *from = c + head + i * HUGE_PAGE;
    size_t n = rest - i * HUGE_PAGE < HUGE_PAGE ? rest - i * HUGE_PAGE : HUGE_PAGE;
    if (zero)
      memset(from, 0, n);
    else
      for (size_t k = 0; k < n; k += 4096) from[k] = 0;
  }
}

void *ch_alloc_large(size_t count, size_t size, int zero) {
  if (size && count > SIZE_MAX / size) return NULL;
  size_t bytes = count * size;
  if (bytes < 4 * (size_t)HUGE_PAGE) return zero ? calloc(count ? count : 1, size ? size : 1) : malloc(bytes ? bytes : 1);
  /* Not aligned to a huge page: an aligned block needs a free chunk up to
   * 2 MiB larger than itself, and after the cut the heap's free chunks are
   * about the size of the arrays that follow (aligned, the output mesh's
   * arrays missed them and grew the heap: 56 MB more at the peak on plane +
   * ornament at 2.1M, each page first touched there). Only the head and
   * the tail of the block miss the huge pages. */
  void *p = malloc(bytes);
  if (!p) return NULL;
  advise_huge(p, bytes);
  if (zero) by_huge_page(p, bytes, 1);
  return p;
}

void ch_alloc_prefault(void *p, size_t bytes) {
  if (p && bytes >= 4 * (size_t)HUGE_PAGE) by_huge_page(p, bytes, 0);
}

int ch_alloc_resize(void **array, size_t old_count, size_t new_count, size_t size) {
  if (size && new_count > SIZE_MAX / size) return -1;
  size_t bytes = new_count * size;
  if (*array && (new_count <= old_count || bytes < 4 * (size_t)HUGE_PAGE)) {
    void *p = realloc(*array, bytes ? bytes : 1);
    if (!p) return -1;
    *array = p;
    return 0;
  }
  /* Growth to a large size: copied into huge pages. realloc would copy
   * too where the block came from the heap (after a large free, glibc
   * serves even 100 MB from the heap's top), into pages faulted 4 KiB at
   * a time. */
  void *p = ch_alloc_large(new_count, size, 0);
  if (!p) return -1;
  if (*array) memcpy(p, *array, old_count * size);
  free(*array);
  *array = p;
  return 0;
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
