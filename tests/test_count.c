/* The count model (tess/ch_count) driven by analytic count functions in
 * place of the embedding, so that what it should find can be worked out by
 * hand:
 *
 * - out = b + c0 + c1 sqrt(b), with c1 sqrt(b) added on the base's own
 *   edges (level 0) and c0 on finer ones: the level model exactly, so the
 *   pilot measures it and the first full run lands (2 runs), at the base
 *   the equation gives; a small target (no pilot) lands too.
 * - the level model's growth, by hand: what level d added grows by
 *   max(1, sqrt(k) / 2^d) where the base grows by k; and a margin: the
 *   run aims that share of what the features add above the target.
 * - a bumpy, non-monotonic count (features growing like b^0.8 with a
 *   ripple, as the thinning gives): within 5% in at most 8 runs.
 * - a count steep at small bases and flat at large ones (out = b + c
 *   log(b / 100), all of it refinement below the base's edges): full runs
 *   bracket the target and the search lands between them in 8 runs.
 * - features alone over the target (out = b + 200000 for 60000): out of
 *   reach, the answer kept is the one at the fewest base triangles.
 * - u lines that would take more than 7/8 of the target at the default
 *   angle step (out = b + A/1.5^k sqrt(b)): coarsened exactly as often as
 *   the 1/8 rule says (twice for A = 1500 at 100000), then within 5%.
 * - a cap on a run's triangles: past it, the fewest base, or an error.
 *
 * The fake tessellation gives a base a little off what is asked (as a real
 * one does), a pilot counts 0.3% more than its finished cut (the cleanup),
 * and the callback checks the protocol: FINISH only right after a PILOT,
 * KEEP only after a FULL or FINISH, never a base below the fewest. */
#include <math.h>
#include <stdio.h>

#include "ch_count.h"
#include "ch_test.h"

typedef enum { SQRT_MODEL, BUMPY, OVER, U_LINES, CAPS, STEEP } count_kind;

typedef struct fake {
  count_kind kind;
  double c0, c1;
  long fewest;
  ch_count_kind last; /* the last call's kind */
  double last_full;   /* the count of the last PILOT (finished), FULL or FINISH */
  double kept;        /* the count of the run kept */
  int kept_coarsenings;
  int calls, bad;
  double min_full; /* the fewest output triangles of any full run */
  double cap;      /* > 0: a run whose count would pass it stops there */
  int estimated;   /* pilots reply estimated counts (a sampled pilot: no cut to finish) */
  int pilots;      /* PILOT requests */
  double finish_shift;        /* a FINISH's count is the cut's times 1 + this (the cleanup, the thinning) */
  ch_count_reply pilot_reply; /* the last PILOT's */
  long full_base[8];          /* the bases FULL runs asked for */
  int fulls;
} fake;

static double fake_base(long b) { return (double)b * (1.0 + 0.004 * sin((double)b)); }

static double fake_count(const fake *f, double b, int coarsenings) {
  switch (f->kind) {
    case SQRT_MODEL:
      return b + f->c0 + f->c1 * sqrt(b);
    case BUMPY:
      return b + f->c1 * pow(b, 0.8) * (1.0 + 0.06 * sin(b / 700.0));
    case OVER:
      return b + 200000.0;
    case U_LINES:
      return b + f->c1 / pow(1.5, coarsenings) * sqrt(b);
    case CAPS: /* the angle step shapes only the caps of open ends: a little */
      return b + f->c1 * (1.0 - 0.005 * coarsenings) * sqrt(b);
    case STEEP: /* refinement at many small features, growing like log(b) */
      return b + f->c1 * log(b / 100.0);
  }
  return 0.0;
}

static ch_status fake_run(void *ctx, const ch_count_request *rq, ch_count_reply *rp) {
  fake *f = ctx;
  f->calls++;
  f->pilots += rq->kind == CH_COUNT_PILOT;
  switch (rq->kind) {
    case CH_COUNT_PILOT:
    case CH_COUNT_FULL:
      if (rq->base < f->fewest || rq->coarsenings < 0 || rq->coarsenings > 4) f->bad++;
      rp->base = fake_base(rq->base);
      f->last_full = fake_count(f, rp->base, rq->coarsenings);
      rp->count = rq->kind == CH_COUNT_PILOT ? floor(f->last_full * 1.003) : f->last_full;
      rp->estimated = rq->kind == CH_COUNT_PILOT && f->estimated;
      /* what grows with the base is added on its own edges (level 0); the
       * rest, at junctions and ends, on finer ones */
      rp->level_added[0] = fake_count(f, rp->base, rq->coarsenings) - rp->base - (f->kind == SQRT_MODEL ? f->c0 : 0.0);
      if (f->kind == OVER) rp->level_added[0] = 0.0;
      rp->level_added[5] = f->kind == SQRT_MODEL ? f->c0 : 0.0;
      if (f->kind == STEEP) { /* all of it on edges four halvings below the base's */
        rp->level_added[4] = rp->level_added[0];
        rp->level_added[0] = 0.0;
      }
      if (f->cap > 0.0 && rp->count > f->cap) { /* stopped: no mesh, nothing to keep */
        rp->count = 0.0;
        rp->over_cap = 1;
        f->last = CH_COUNT_KEEP; /* (no FINISH or KEEP may follow it) */
        return CH_OK;
      }
      if (rq->kind == CH_COUNT_FULL) f->min_full = fmin(f->min_full, rp->count);
      if (rq->kind == CH_COUNT_PILOT) f->pilot_reply = *rp;
      if (rq->kind == CH_COUNT_FULL && f->fulls < 8) f->full_base[f->fulls++] = rq->base;
      break;
    case CH_COUNT_FINISH:
      if (f->last != CH_COUNT_PILOT || f->estimated) f->bad++;
      f->last_full *= 1.0 + f->finish_shift;
      rp->count = f->last_full;
      f->min_full = fmin(f->min_full, rp->count);
      break;
    case CH_COUNT_KEEP:
      if (f->last != CH_COUNT_FULL && f->last != CH_COUNT_FINISH) f->bad++;
      f->kept = f->last_full;
      f->kept_coarsenings = rq->coarsenings;
      break;
  }
  f->last = rq->kind;
  return CH_OK;
}

static ch_count_result search(fake *f, long target, int can_coarsen, int has_u) {
  f->fewest = 200;
  f->kept = -1.0;
  f->min_full = INFINITY;
  f->last = CH_COUNT_KEEP;
  ch_count_desc d = {.target = target, .fewest = f->fewest, .can_coarsen = can_coarsen, .has_u = has_u};
  ch_count_result r;
  CHECK(ch_count_search(&d, fake_run, f, &r) == CH_OK);
  CHECK(f->bad == 0);
  CHECK(r.runs >= 1 && r.runs <= 41);
  CHECK(f->kept >= 0.0 && r.count == f->kept); /* the result is the run kept */
  CHECK(r.coarsenings == f->kept_coarsenings);
  static const char *names[] = {"sqrt model", "bumpy", "over", "u lines", "caps", "steep"};
  fprintf(stderr, "  %-10s target %7ld: %2d runs, kept %9.0f (%+.2f%%), base %7ld, %d coarsenings\n", names[f->kind],
          target, r.runs, r.count, 100.0 * (r.count - (double)target) / (double)target, r.base, r.coarsenings);
  return r;
}

static void test_sqrt_model(void) {
  long targets[] = {60000, 130000, 520000, 5000};
  for (int i = 0; i < 4; i++) {
    fake f = {.kind = SQRT_MODEL, .c0 = 3000.0, .c1 = 40.0};
    long t = targets[i];
    ch_count_result r = search(&f, t, 1, 1);
    CHECK_MSG(fabs(r.count - (double)t) <= 0.05 * (double)t, "target %ld: %.0f", t, r.count);
    /* with the pilot the first full run lands; without (a small target)
     * the level model of a run at the target itself, then secant steps */
    CHECK_MSG(r.runs <= (t >= 60000 ? 2 : 6), "target %ld: %d runs", t, r.runs);
    CHECK(r.coarsenings == 0);
    if (t >= 60000) { /* the base solves b + 3000 + 40 sqrt(b) = t, to the pilot's 0.3% and the base's 0.4% */
      double lo = 1.0, hi = (double)t;
      while (hi - lo > 1e-3) {
        double mid = 0.5 * (lo + hi);
        *(mid + 3000.0 + 40.0 * sqrt(mid) < (double)t ? &lo : &hi) = mid;
      }
      double b = lo;
      CHECK_MSG(fabs((double)r.base - b) <= 0.02 * b, "target %ld: base %ld, model %.0f", t, r.base, b);
    }
  }
}

static void test_level_model(void) {
  /* a pilot at base 10000 that counted 30000: 8000 added on the base's
   * edges, 4000 at level 1, 2000 at level 3, the other 6000 at no level */
  ch_count_reply r = {.base = 10000.0, .count = 30000.0};
  r.level_added[0] = 8000.0;
  r.level_added[1] = 4000.0;
  r.level_added[3] = 2000.0;
  CHECK_NEAR(ch_count_level_predict(&r, 10000.0), 30000.0, 1e-9);
  /* k = 16: sqrt(k) = 4; level 0 x4, level 1 x2, level 3 x1 */
  CHECK_NEAR(ch_count_level_predict(&r, 160000.0), 160000.0 + 20000.0 + 8000.0 * 3.0 + 4000.0 * 1.0, 1e-6);
  /* k = 256: sqrt(k) = 16; level 3 x2 */
  CHECK_NEAR(ch_count_level_predict(&r, 2560000.0), 2560000.0 + 20000.0 + 8000.0 * 15.0 + 4000.0 * 7.0 + 2000.0 * 1.0,
             1e-6);
  /* k = 1/4: level 0 x1/2, the finer levels stay */
  CHECK_NEAR(ch_count_level_predict(&r, 2500.0), 2500.0 + 20000.0 - 4000.0, 1e-9);
  /* and back: the base for a target */
  double b = ch_count_level_base(208000.0, &r);
  CHECK_NEAR(ch_count_level_predict(&r, b), 208000.0, 1e-6 * 208000.0);
  CHECK_NEAR(b, 160000.0, 1.0);
}

/* A margin: the full run aims above the target by that share of what the
 * features add (b + 3000 + 40 sqrt(b) at 520000: 30972 at b = 489028,
 * so 12% of it is 3716 above). */
static void test_margin(void) {
  fake f = {.kind = SQRT_MODEL,
            .c0 = 3000.0,
            .c1 = 40.0,
            .fewest = 200,
            .kept = -1.0,
            .min_full = INFINITY,
            .last = CH_COUNT_KEEP};
  ch_count_desc d = {.target = 520000, .fewest = 200, .take_back = 0.15, .feature_margin = 0.12};
  ch_count_result r;
  CHECK(ch_count_search(&d, fake_run, &f, &r) == CH_OK);
  CHECK(f.bad == 0 && r.runs == 2);
  CHECK_MSG(fabs(r.count - 523716.0) <= 0.005 * 520000.0, "kept %.0f", r.count);
  /* A caller that cannot take the margin back (this one never does): with
   * features at 43% of the target (b + 3000 + 400 sqrt(b): 222k at b =
   * 298k) a margin of 0.2 puts the first full run 8.5% over; then the
   * search aims at the target itself and lands, in 3 runs. */
  fake g = {.kind = SQRT_MODEL,
            .c0 = 3000.0,
            .c1 = 400.0,
            .fewest = 200,
            .kept = -1.0,
            .min_full = INFINITY,
            .last = CH_COUNT_KEEP};
  d.feature_margin = 0.2;
  CHECK(ch_count_search(&d, fake_run, &g, &r) == CH_OK);
  CHECK_MSG(g.bad == 0 && r.runs == 3, "%d runs", r.runs);
  CHECK_MSG(fabs(r.count - 520000.0) <= 0.05 * 520000.0, "kept %.0f", r.count);
}

/* Features alone about the target (out = b + 93750 at 100000): the pilot
 * at 1/16 lands within 4% and is finished from its cut (1 run); a pilot
 * whose count was estimated has no cut, so a full run at about its base
 * follows (2 runs), and lands. */
static void test_estimated_pilot(void) {
  fake f = {.kind = SQRT_MODEL, .c0 = 93750.0, .c1 = 0.0};
  ch_count_result r = search(&f, 100000, 0, 0);
  CHECK(r.runs == 1 && fabs(r.count - 100000.0) <= 5000.0);
  fake g = {.kind = SQRT_MODEL, .c0 = 93750.0, .c1 = 0.0, .estimated = 1};
  r = search(&g, 100000, 0, 0);
  CHECK(r.runs == 2 && fabs(r.count - 100000.0) <= 5000.0);
}

/* A pilot that lands within 4% (93750 + 3600 at the pilot's base of
 * 6250, for 100000) is finished from its cut, but the finish comes out
 * 8% over (the cleanup, the thinning): no full run before it, so the
 * next base is the level model's of that pilot (there is no secant yet),
 * and its full run lands. */
static void test_finished_pilot_misses(void) {
  fake f = {.kind = SQRT_MODEL, .c0 = 93750.0 + 3600.0, .c1 = 0.0, .finish_shift = 0.08};
  ch_count_result r = search(&f, 100000, 0, 0);
  CHECK_MSG(f.fulls == 1, "%d full runs", f.fulls);
  long want = (long)llround(ch_count_level_base(100000.0, &f.pilot_reply));
  CHECK_MSG(f.full_base[0] == want, "base %ld, the level model's %ld", f.full_base[0], want);
  CHECK_MSG(r.runs == 2 && fabs(r.count - 100000.0) <= 5000.0, "%d runs, %.0f", r.runs, r.count);
}

static void test_bumpy(void) {
  long targets[] = {60000, 130000, 520000};
  for (int i = 0; i < 3; i++)
    for (int k = 0; k < 2; k++) {
      fake f = {.kind = BUMPY, .c1 = k ? 8.0 : 3.0};
      long t = targets[i];
      ch_count_result r = search(&f, t, 0, 0);
      CHECK_MSG(fabs(r.count - (double)t) <= 0.05 * (double)t, "target %ld c1 %g: %.0f", t, f.c1, r.count);
      CHECK_MSG(r.runs <= 8, "target %ld c1 %g: %d runs", t, f.c1, r.runs);
    }
}

/* A count that grows steeply at small bases and slowly at large ones
 * (8000 filled stars at 2.1M: 825k triangles at the fewest 512 base
 * triangles, 3.2M at 7.6k, 7.8M at 560k), all of it below the base's
 * edges, where the level model sees no growth: the search brackets the
 * target between full runs and lands (it halved its way down from above
 * before, out of runs at 3.2M). */
static void test_steep(void) {
  fake f = {.kind = STEEP, .c1 = 506000.0};
  ch_count_result r = search(&f, 2100000, 0, 0);
  CHECK_MSG(fabs(r.count - 2100000.0) <= 0.05 * 2100000.0, "%.0f triangles at base %ld", r.count, r.base);
  CHECK_MSG(r.runs <= 8, "%d runs", r.runs);
}

static void test_out_of_reach(void) {
  for (int coarsen = 0; coarsen < 2; coarsen++) {
    fake f = {.kind = OVER};
    ch_count_result r = search(&f, 60000, coarsen, 0);
    /* the fewest base triangles, so the fewest output ones of any run */
    CHECK_MSG(r.base == f.fewest, "base %ld", r.base);
    CHECK(r.count == f.min_full);
    CHECK_NEAR(r.count, fake_base(f.fewest) + 200000.0, 1e-9);
    CHECK_MSG(r.runs <= 4, "%d runs", r.runs);
  }
}

static void test_u_lines(void) {
  /* b + 1500/1.5^k sqrt(b) = 100000 at b = 3.6k, 8.7k, 15.9k for k = 0, 1,
   * 2: below 1/8 of the target (12.5k) twice. */
  fake f = {.kind = U_LINES, .c1 = 1500.0};
  ch_count_result r = search(&f, 100000, 1, 1);
  CHECK_MSG(r.coarsenings == 2, "%d coarsenings", r.coarsenings);
  CHECK_MSG(fabs(r.count - 100000.0) <= 5000.0, "%.0f", r.count);
  CHECK_MSG(r.runs <= 10, "%d runs", r.runs);
  /* the same without leave to coarsen: the finest step, still within 5% */
  fake g = {.kind = U_LINES, .c1 = 1500.0};
  r = search(&g, 100000, 0, 1);
  CHECK(r.coarsenings == 0);
  CHECK_MSG(fabs(r.count - 100000.0) <= 5000.0, "%.0f", r.count);
}

/* Without u lines a coarser angle step changes little (the caps of open
 * ends): b + 1033 (1 - 0.005 k) sqrt(b) is 67000 at the pilot's 3750 for a
 * target of 60000, whose base (2770) is below 1/8 of it. The coarsest step
 * at once: two pilots (steps 0 and 4), not five. */
static void test_caps_only(void) {
  fake f = {.kind = CAPS, .c1 = 1033.0};
  ch_count_result r = search(&f, 60000, 1, 0);
  CHECK_MSG(f.pilots == 2, "%d pilots", f.pilots);
  CHECK(r.coarsenings == 4);
  CHECK_MSG(fabs(r.count - 60000.0) <= 3000.0, "%.0f", r.count);
}

/* A cap on the runs' triangles: features alone at 200000 for a target of
 * 60000 pass a cap of 202000 at the first run (the pilot at base 3750):
 * the search starts again at a quarter of it (937, no pilot: 200937,
 * under the cap), goes down by the level model of that run (all of the
 * features' count at no level: it does not shrink with the base) to the
 * fewest base and keeps its run (200200), three runs in all, none above
 * 3750 again; under a cap of
 * 150000 every run is over it, down to the fewest base: CH_ERR_INPUT,
 * after 3750, 937, 234 and 200. A cap no run reaches changes nothing. */
static void test_cap(void) {
  fake f = {.kind = OVER, .fewest = 200, .kept = -1.0, .min_full = INFINITY, .last = CH_COUNT_KEEP, .cap = 202000.0};
  ch_count_desc d = {.target = 60000, .fewest = 200};
  ch_count_result r;
  CHECK(ch_count_search(&d, fake_run, &f, &r) == CH_OK);
  CHECK(f.bad == 0);
  CHECK_MSG(r.runs == 3, "%d runs", r.runs);
  CHECK_MSG(r.base == 200, "base %ld", r.base);
  CHECK_NEAR(f.kept, fake_base(200) + 200000.0, 1e-9);
  fake g = {.kind = OVER, .fewest = 200, .kept = -1.0, .min_full = INFINITY, .last = CH_COUNT_KEEP, .cap = 150000.0};
  CHECK(ch_count_search(&d, fake_run, &g, &r) == CH_ERR_INPUT);
  CHECK(g.bad == 0 && g.kept == -1.0);
  CHECK_MSG(r.runs == 4, "%d runs", r.runs);
  /* the sqrt model's search, with a cap above every run, as without one */
  fake h = {.kind = SQRT_MODEL, .c0 = 3000.0, .c1 = 40.0};
  ch_count_result plain = search(&h, 130000, 1, 0);
  fake k = {.kind = SQRT_MODEL, .c0 = 3000.0, .c1 = 40.0, .cap = 1e9};
  ch_count_result capped = search(&k, 130000, 1, 0);
  CHECK(plain.runs == capped.runs && plain.base == capped.base && plain.count == capped.count);
}

static ch_status failing_run(void *ctx, const ch_count_request *rq, ch_count_reply *rp) {
  int *n = ctx;
  rp->base = (double)rq->base;
  rp->count = 2.0 * (double)rq->base;
  return ++*n == 2 ? CH_ERR_NOMEM : CH_OK;
}

static void test_error_stops(void) {
  int n = 0;
  ch_count_desc d = {.target = 60000, .fewest = 200};
  ch_count_result r;
  CHECK(ch_count_search(&d, failing_run, &n, &r) == CH_ERR_NOMEM);
  CHECK(n == 2); /* nothing after the failing call */
  CHECK(r.runs == 1);
}

int main(void) {
  RUN(test_level_model);
  RUN(test_sqrt_model);
  RUN(test_margin);
  RUN(test_estimated_pilot);
  RUN(test_finished_pilot_misses);
  RUN(test_bumpy);
  RUN(test_steep);
  RUN(test_out_of_reach);
  RUN(test_u_lines);
  RUN(test_caps_only);
  RUN(test_error_stops);
  RUN(test_cap);
  TEST_MAIN_END();
}
