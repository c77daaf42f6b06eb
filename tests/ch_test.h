/* A tiny test harness: CHECK keeps going and counts failures; REQUIRE stops
 * the current test. Both stay on in Release builds (they are not assert). */
#ifndef CH_TEST_H
#define CH_TEST_H

#include <math.h>
#include <stdio.h>
#include <stdint.h>
#include <stdlib.h>

/* Uniform in [0, 1), xorshift64*: the same sequence in every test file
 * (each has its own state). */
static inline double ch_test_rnd(void) {
  static uint64_t state = 0x9e3779b97f4a7c15ull;
  state ^= state >> 12;
  state ^= state << 25;
  state ^= state >> 27;
  return (double)((state * 0x2545f4914f6cdd1dull) >> 11) * (1.0 / 9007199254740992.0);
}

static int ch_test_failures = 0;
static int ch_test_checks = 0;

#define CHECK(cond)                                                                  \
  do {                                                                               \
    ch_test_checks++;                                                                \
    if (!(cond)) {                                                                   \
      ch_test_failures++;                                                            \
      fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond);        \
    }                                                                                \
  } while (0)

#define CHECK_MSG(cond, ...)                                                         \
  do {                                                                               \
    ch_test_checks++;                                                                \
    if (!(cond)) {                                                                   \
      ch_test_failures++;                                                            \
      fprintf(stderr, "%s:%d: CHECK failed: %s: ", __FILE__, __LINE__, #cond);        \
      fprintf(stderr, __VA_ARGS__);                                                  \
      fputc('\n', stderr);                                                           \
    }                                                                                \
  } while (0)

#define CHECK_NEAR(a, b, tol)                                                        \
  do {                                                                               \
    double ch_a_ = (a), ch_b_ = (b);                                                 \
    ch_test_checks++;                                                                \
    if (!(fabs(ch_a_ - ch_b_) <= (tol))) {                                           \
      ch_test_failures++;                                                            \
      fprintf(stderr, "%s:%d: CHECK_NEAR failed: %s = %.17g, %s = %.17g (tol %g)\n",  \
              __FILE__, __LINE__, #a, ch_a_, #b, ch_b_, (double)(tol));              \
    }                                                                                \
  } while (0)

#define REQUIRE(cond)                                                                \
  do {                                                                               \
    ch_test_checks++;                                                                \
    if (!(cond)) {                                                                   \
      ch_test_failures++;                                                            \
      fprintf(stderr, "%s:%d: REQUIRE failed: %s\n", __FILE__, __LINE__, #cond);      \
      return;                                                                        \
    }                                                                                \
  } while (0)

#define RUN(test)                                                                    \
  do {                                                                               \
    int before_ = ch_test_failures;                                                  \
    test();                                                                          \
    fprintf(stderr, "%-40s %s\n", #test, ch_test_failures == before_ ? "ok" : "FAILED"); \
  } while (0)

#define TEST_MAIN_END()                                                              \
  do {                                                                               \
    fprintf(stderr, "%d checks, %d failures\n", ch_test_checks, ch_test_failures);    \
    return ch_test_failures ? 1 : 0;                                                 \
  } while (0)

#endif
