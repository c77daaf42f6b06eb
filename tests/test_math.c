/* core's small shared helpers: ch_math.h (checked against hand-worked
 * values and against qsort's contract; ch_angle against libm),
 * ch_alloc_grow, the counting sort of ch_sort (against a serial stable sort, on 1 to 3 threads), its
 * selection (against qsort) and the clock of ch_progress. */
#define _POSIX_C_SOURCE 200809L /* nanosleep */
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <omp.h>
#ifdef __GLIBC__
#include <malloc.h>
#endif

#include "ch_alloc.h"
#include "ch_math.h"
#include "ch_progress.h"
#include "ch_sort.h"
#include "ch_test.h"

static void test_math(void) {
  CHECK(ch_clampi(-3, 0, 5) == 0 && ch_clampi(7, 0, 5) == 5 && ch_clampi(2, 0, 5) == 2);
  CHECK(ch_clamp(-0.5, 0.0, 1.0) == 0.0 && ch_clamp(0.25, 0.0, 1.0) == 0.25);
  const double t[6][3] = {{1, 2, 3}, {1, 3, 2}, {2, 1, 3}, {2, 3, 1}, {3, 1, 2}, {3, 2, 1}};
  for (int i = 0; i < 6; i++) {
    CHECK(ch_min3(t[i][0], t[i][1], t[i][2]) == 1.0);
    CHECK(ch_max3(t[i][0], t[i][1], t[i][2]) == 3.0);
  }
  double a[3] = {3, 4, 12}, b[3] = {1, 1, 1}, d[3], c[3];
  ch_sub3(a, b, d);
  CHECK(d[0] == 2 && d[1] == 3 && d[2] == 11);
  CHECK(ch_len3(a) == 13.0);
  ch_cross3((const double[3]){1, 0, 0}, (const double[3]){0, 1, 0}, c);
  CHECK(c[0] == 0 && c[1] == 0 && c[2] == 1);
  CHECK(ch_normalize3(a) == 1);
  CHECK_NEAR(a[0], 3.0 / 13.0, 1e-16);
  CHECK_NEAR(a[2], 12.0 / 13.0, 1e-16);
  double z[3] = {0, 0, 0}, inf[3] = {INFINITY, 0, 0};
  CHECK(ch_normalize3(z) == 0 && z[0] == 0.0);
  CHECK(ch_normalize3(inf) == 0 && isinf(inf[0]));
  double v[64];
  for (int i = 0; i < 64; i++) v[i] = ch_test_rnd() - 0.5;
  v[10] = v[20];
  qsort(v, 64, sizeof *v, ch_cmp_double);
  int sorted = 1;
  for (int i = 1; i < 64; i++) sorted &= v[i - 1] <= v[i];
  CHECK(sorted);
  double x = 1.0, y = 2.0;
  CHECK(ch_cmp_double(&x, &y) == -1 && ch_cmp_double(&y, &x) == 1 && ch_cmp_double(&x, &x) == 0);
}

/* ch_angle against libm's atan2 (which is within an ulp of the true
 * angle), over the cases that matter: tiny and huge ratios, both signs of
 * the cosine, and the exact ones. */
static void test_angle(void) {
  double worst = 0.0;
  for (int i = 0; i < 400000; i++) {
    double s = ch_test_rnd(), c = 2.0 * ch_test_rnd() - 1.0;
    if (i % 3 == 0) s *= 1e-9;
    if (i % 5 == 0) c *= 1e-9;
    if (i % 7 == 0) s *= 1e6;
    worst = fmax(worst, fabs(ch_angle(s, c) - atan2(s, c)));
  }
  CHECK_MSG(worst <= 4.5e-16, "ch_angle off by %.3g", worst);
  CHECK(ch_angle(1.0, 1.0) == atan2(1.0, 1.0) && ch_angle(1.0, 0.0) == atan2(1.0, 0.0));
  CHECK(ch_angle(2.0, -0.0) == atan2(2.0, -0.0) && ch_angle(0.0, -3.0) == atan2(0.0, -3.0));
  CHECK(ch_angle(0.0, 0.0) == 0.0 && ch_angle(0.0, -0.0) == atan2(0.0, -0.0));
  CHECK(ch_angle(1e-300, 1.0) == 1e-300 && fabs(ch_angle(1.0, 1e-300) - 0.5 * CH_PI) <= 2e-16);
}

static void test_grow(void) {
  int *p = NULL, cap = 0;
  CHECK(ch_alloc_grow((void **)&p, &cap, 0, sizeof *p, 8) == 0 && cap == 0 && !p);
  REQUIRE(ch_alloc_grow((void **)&p, &cap, 1, sizeof *p, 8) == 0);
  CHECK(cap == 8 && p);
  for (int i = 0; i < 8; i++) p[i] = i;
  REQUIRE(ch_alloc_grow((void **)&p, &cap, 9, sizeof *p, 8) == 0);
  CHECK(cap == 16);
  REQUIRE(ch_alloc_grow((void **)&p, &cap, 100, sizeof *p, 8) == 0);
  CHECK(cap == 128);
  int kept = 1;
  for (int i = 0; i < 8; i++) kept &= p[i] == i;
  CHECK(kept);
  int *q = p;
  CHECK(ch_alloc_grow((void **)&p, &cap, -1, sizeof *p, 8) == -1 && p == q && cap == 128);
  /* an element too large for any capacity: refused, the array kept */
  CHECK(ch_alloc_grow((void **)&p, &cap, 200, (size_t)-1 / 64, 8) == -1 && p == q && cap == 128);
  free(p);
}

/* ch_alloc_resize keeps the contents through every path: small to small,
 * small to large (the copy into huge pages), large to larger, shrinking;
 * and refuses an overflowing size with the array kept. */
static void test_resize(void) {
  int *p = NULL;
  REQUIRE(ch_alloc_resize((void **)&p, 0, 1000, sizeof *p) == 0 && p);
  for (int i = 0; i < 1000; i++) p[i] = 3 * i + 1;
  size_t sizes[] = {5000, 4u << 20, 9u << 20, 2000}; /* the last two: above 8 MB, then a shrink */
  size_t have = 1000;
  int kept = 1;
  for (int k = 0; k < 4; k++) {
    REQUIRE(ch_alloc_resize((void **)&p, have, sizes[k], sizeof *p) == 0 && p);
    size_t keep = have < sizes[k] ? have : sizes[k];
    for (size_t i = 0; i < keep; i++) kept &= p[i] == (int)(3 * i + 1);
    for (size_t i = keep; i < sizes[k]; i++) p[i] = (int)(3 * i + 1);
    have = sizes[k];
  }
  CHECK(kept);
  int *q = p;
  CHECK(ch_alloc_resize((void **)&p, have, (size_t)-1 / 2, sizeof *p) == -1 && p == q);
  free(p);
}

/* ch_alloc_large zeroes every byte of a large array, on 1 to 3 threads,
 * whatever its alignment to huge pages (the head before the first is
 * zeroed apart): memory filled and freed just before (from the heap, as
 * main() has glibc keep it) comes back as zeros. ch_alloc_prefault leaves
 * an array that can be filled. */
static void test_large_zero(void) {
#ifdef __GLIBC__
  mallopt(M_MMAP_MAX, 0);
#endif
  const size_t sizes[] = {(8u << 20) + 1, (8u << 20) + 4097, (21u << 20) + 123, 3u << 20};
  int zeros = 1, filled = 1, threads_before = omp_get_max_threads();
  for (int threads = 1; threads <= 3; threads++)
    for (int k = 0; k < 4; k++) {
      omp_set_num_threads(threads);
      unsigned char *old = malloc(sizes[k]);
      REQUIRE(old);
      memset(old, 0xab, sizes[k]);
      free(old);
      unsigned char *p = ch_alloc_large(sizes[k], 1, 1);
      REQUIRE(p);
      for (size_t i = 0; i < sizes[k]; i++) zeros &= p[i] == 0;
      free(p);
      p = ch_alloc_large(sizes[k], 1, 0);
      REQUIRE(p);
      ch_alloc_prefault(p, sizes[k]);
      for (size_t i = 0; i < sizes[k]; i++) p[i] = (unsigned char)(i * 7);
      for (size_t i = 0; i < sizes[k]; i++) filled &= p[i] == (unsigned char)(i * 7);
      free(p);
    }
  omp_set_num_threads(threads_before);
  CHECK(zeros);
  CHECK(filled);
}

/* The clock runs forward with wall time: a 30 ms sleep reads as 30 ms or
 * more (and, even on a loaded machine, well under 10 s). */
/* ch_sort_buckets against the serial stable counting sort: every bucket's
 * items in increasing order, whatever the thread count, with keys that
 * repeat, buckets left empty, and item counts below and above what one
 * thread takes alone. */
static void test_sort(void) {
  const size_t sizes[] = {0, 1, 1000, 300001};
  for (int si = 0; si < 4; si++) {
    size_t n = sizes[si];
    int nkeys = n > 1000 ? 50000 : 37;
    int *key = malloc((n ? n : 1) * sizeof *key), *ref_start = calloc((size_t)nkeys + 1, sizeof *ref_start);
    int *ref = malloc((n ? n : 1) * sizeof *ref), *fill = malloc((size_t)nkeys * sizeof *fill);
    int *start = malloc(((size_t)nkeys + 1) * sizeof *start), *order = malloc((n ? n : 1) * sizeof *order);
    REQUIRE(key && ref_start && ref && fill && start && order);
    for (size_t i = 0; i < n; i++) key[i] = (int)(ch_test_rnd() * (nkeys / 2)) * 2; /* odd keys: empty */
    for (size_t i = 0; i < n; i++) ref_start[key[i] + 1]++;
    for (int k = 0; k < nkeys; k++) ref_start[k + 1] += ref_start[k];
    memcpy(fill, ref_start, (size_t)nkeys * sizeof *fill);
    for (size_t i = 0; i < n; i++) ref[fill[key[i]]++] = (int)i;
    for (int threads = 1; threads <= 3; threads++) {
      omp_set_num_threads(threads);
      memset(order, 0xff, (n ? n : 1) * sizeof *order);
      CHECK(ch_sort_buckets(key, n, nkeys, start, order) == 0);
      CHECK(memcmp(start, ref_start, ((size_t)nkeys + 1) * sizeof *start) == 0);
      CHECK(n == 0 || memcmp(order, ref, n * sizeof *order) == 0);
    }
    free(key), free(ref_start), free(ref), free(fill), free(start), free(order);
  }
}

/* ch_sort_select against qsort: every rank of arrays with repeats,
 * sorted, reversed and random. */
static void test_select(void) {
  enum { N = 257 };
  double x[N], sorted[N], work[N];
  for (int shape = 0; shape < 3; shape++) {
    for (int i = 0; i < N; i++)
      x[i] = shape == 0 ? floor(ch_test_rnd() * 40.0) : shape == 1 ? (double)i : (double)(N - i);
    memcpy(sorted, x, sizeof x);
    qsort(sorted, N, sizeof *sorted, ch_cmp_double);
    int ok = 1;
    for (long k = 0; k < N; k++) {
      memcpy(work, x, sizeof x);
      ok &= ch_sort_select(work, N, k) == sorted[k];
    }
    CHECK(ok);
  }
  double one = 3.5;
  CHECK(ch_sort_select(&one, 1, 0) == 3.5);
}

static void test_clock(void) {
  double t0 = ch_progress_seconds();
  struct timespec ts = {0, 30 * 1000 * 1000};
  nanosleep(&ts, NULL);
  double t1 = ch_progress_seconds();
  CHECK_MSG(t1 - t0 >= 0.029 && t1 - t0 < 10.0, "%g s", t1 - t0);
}

int main(void) {
  RUN(test_math);
  RUN(test_angle);
  RUN(test_grow);
  RUN(test_resize);
  RUN(test_large_zero);
  RUN(test_sort);
  RUN(test_select);
  RUN(test_clock);
  TEST_MAIN_END();
}
