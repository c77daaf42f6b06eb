/* ch_count: the count model of ch_embed_to_target (see ch_count.h). */
#include "ch_count.h"

#include <math.h>
#include <string.h>

double ch_count_level_predict(const ch_count_reply *run, double base) {
  double k = run->base > 0.0 ? base / run->base : 1.0, grow = sqrt(k), out = base + (run->count - run->base);
  for (int d = 0; d < CH_COUNT_LEVELS; d++) {
    double g = d == 0 ? grow : fmax(1.0, ldexp(grow, -d));
    out += run->level_added[d] * (g - 1.0);
  }
  return out;
}

double ch_count_level_base(double target, const ch_count_reply *run) {
  double lo = 1.0, hi = target;
  for (int it = 0; it < 80; it++) {
    double mid = 0.5 * (lo + hi);
    if (ch_count_level_predict(run, mid) < target)
      lo = mid;
    else
      hi = mid;
  }
  return lo;
}

ch_status ch_count_search(const ch_count_desc *desc, ch_count_fn fn, void *ctx, ch_count_result *result) {
  long target = desc->target, fewest = desc->fewest;
  double best_miss = INFINITY, best_count = 0.0;
  long best_base = 0;
  int best_coarsenings = 0;
  double xs[8], ys[8]; /* base triangles, output triangles of each run */
  int runs = 0;
  ch_status st = CH_OK;
  if (target < fewest) target = fewest;
  /* One cheap pilot first, at 1/16 of the target (none for small targets):
   * its count and what it added at each refinement level predict the base
   * for the target (ch_count_level_predict). On the bundled sets that
   * prediction is within 4.3% of the full runs that followed on average
   * and 15% at worst, where a model out = base + c0 + c1 sqrt(base) through
   * two pilots (at 1/64 and 1/16) was within 6.0% and 21%, for a pilot
   * more. */
  int pilots = target / 16 >= 2000 && target / 16 >= fewest;
  long first_base = pilots ? target / 16 : target, base = first_base;
  int auto_angle = desc->can_coarsen, coarsenings = 0, has_u = desc->has_u;
  long ceiling = 0; /* > 0: a base whose run went over the cap */
  int restarts = 0;
  double margin = desc->feature_margin;
  double base_aim = 0.0; /* what the next base was chosen for */
  for (int pass = 0; pass < 8; pass++) {
    /* The pilot only counts; if it lands it is finished from its cut. */
    int count_only = pass < pilots;
    ch_count_request rq = {count_only ? CH_COUNT_PILOT : CH_COUNT_FULL, base, coarsenings, runs + 1, base_aim};
    ch_count_reply rp = {0};
    if ((st = fn(ctx, &rq, &rp))) break;
    runs++;
    if (rp.over_cap) {
      /* The cap bounds every run's work (thousands of curves crossing in
       * a small place). Past it at this base, the count at any base above
       * is past it too: the search starts again below, at a quarter of it
       * without the pilot (twice at most), and then takes the fewest base's
       * run if that one fits. */
      if (base <= fewest) {
        st = CH_ERR_INPUT;
        break;
      }
      ceiling = base;
      if (restarts++ < 2 && base / 4 > fewest) {
        base = base / 4;
        pilots = 0;
        auto_angle = 0;
        pass = -1;
        base_aim = 0.0;
        continue;
      }
      ch_count_request last = {CH_COUNT_FULL, fewest, coarsenings, runs + 1, 0.0};
      ch_count_reply lr = {0};
      if ((st = fn(ctx, &last, &lr))) break;
      runs++;
      if (lr.over_cap) {
        st = CH_ERR_INPUT;
        break;
      }
      double lmiss = fabs(lr.count - (double)target);
      if (lmiss < best_miss) {
        ch_count_request keep = {CH_COUNT_KEEP, fewest, coarsenings, runs, 0.0};
        ch_count_reply none = {0};
        if ((st = fn(ctx, &keep, &none))) break;
        best_miss = lmiss;
        best_count = lr.count;
        best_base = fewest;
        best_coarsenings = coarsenings;
      }
      break;
    }
    const ch_count_reply measured = rp; /* (a FINISH below replies its count in rp) */
    /* A full run over the target by less than the caller takes back that
     * still missed: the caller could not take it back (few smooth parts:
     * ornament on the tablet at 520k), so no margin from here on (aimed
     * over again, the secants went round the aim: 9 runs). */
    if (!count_only && rp.count > 1.05 * (double)target && rp.count <= (1.0 + desc->take_back) * (double)target)
      margin = 0.0;
    /* (what the features add at the base for the target, by this run's model) */
    double aim = (double)target + margin * fmax(0.0, (double)target - ch_count_level_base((double)target, &measured));
    double nb = rp.base, no = rp.count, miss = fabs(no - (double)target);
    xs[pass] = nb;
    ys[pass] = no;
    if (count_only && !rp.estimated && miss <= 0.04 * (double)target) {
      count_only = 0;
      rq.kind = CH_COUNT_FINISH;
      if ((st = fn(ctx, &rq, &rp))) break;
      no = ys[pass] = rp.count; /* the cleanup's count */
      miss = fabs(no - (double)target);
    }
    if (count_only && no > 1.25 * (double)target && !has_u && auto_angle) {
      /* The pilot alone is well over the target. Without u lines the angle
       * step shapes only the caps of open ends: the coarsest step at once
       * (one rerun of the pilot, not four: bricks at 60k needs it), and no
       * coarsening after that (500 grooves through a point: 7 runs to
       * reach the same base). */
      auto_angle = 0;
      if (coarsenings < 4) {
        coarsenings = 4;
        pass = -1;
        base_aim = 0.0;
        base = first_base;
        continue;
      }
    }
    if (!count_only && miss < best_miss) { /* keep the closest full run */
      ch_count_request keep = {CH_COUNT_KEEP, base, coarsenings, runs, 0.0};
      ch_count_reply none = {0};
      if ((st = fn(ctx, &keep, &none))) break;
      best_miss = miss;
      best_count = no;
      best_base = base;
      best_coarsenings = coarsenings;
    }
    /* A full run's count is exact: docs/spec.md §5's 5% is enough (a pilot's is
     * before the cleanup, hence 4% above). */
    if (best_miss <= 0.05 * (double)target) break;
    /* Next base count, for the aim (the target plus the caller's margin):
     * after the pilot and after the first full run, the level model of
     * that run; then the secant through the last two runs, or the level
     * model of the last where their counts fall as the base grows
     * (thinning makes the count bumpy: bricks at 130k). */
    double next;
    /* (a pilot finished from its cut, which then missed, has no full run
     * before it for a secant) */
    if (count_only || pass <= pilots) {
      next = ch_count_level_base(aim, &measured);
      if (count_only && next < (double)target / 8.0 && auto_angle && coarsenings < 4) {
        /* The u lines would take more than 7/8 of the triangles and starve
         * everything else (crossings, CSG seams, the flat parts): a coarser
         * angle step, and the pilot again. Without u lines, the coarsest at
         * once, as above: one step at a time took the pilot five times for
         * the same full run (tablet + bricks at 60k: 67418, 67418, 66640,
         * 66610, 65860 triangles). */
        coarsenings = has_u ? coarsenings + 1 : 4;
        pass = -1;
        base_aim = 0.0;
        base = first_base;
        best_miss = INFINITY; /* a run at the finer step is no answer */
        continue;
      }
    } else {
      double dx = xs[pass] - xs[pass - 1], dy = ys[pass] - ys[pass - 1];
      next = dy * dx > 0.0 ? xs[pass] + (aim - ys[pass]) * dx / dy : ch_count_level_base(aim, &measured);
      int fell = !(next > 0.0);
      if (fell) next = xs[pass] * 0.5;
      /* Where full runs bracket the aim (one under it, one over) and the
       * secant through the last two leaves that bracket or falls below 0:
       * false position between the bracket's ends in log(base), kept to
       * its middle 80%. Features whose refinement grows fast at small bases
       * (8000 filled stars: 825k triangles at the fewest 512 base
       * triangles, 3.2M at 7.6k, 7.8M at 560k) bend the count so much
       * that the search halved its way down from above and ran out of
       * runs first (8 runs, 40 s, 3.2M triangles for a target of 2.1M). */
      int under = -1, over = -1;
      for (int i = pilots; i <= pass; i++) {
        if (ys[i] < aim && (under < 0 || xs[i] > xs[under])) under = i;
        if (ys[i] > aim && (over < 0 || xs[i] < xs[over])) over = i;
      }
      if (under >= 0 && over >= 0 && xs[under] < xs[over] && (fell || !(next > xs[under] && next < xs[over]))) {
        double f = (aim - ys[under]) / (ys[over] - ys[under]);
        f = f < 0.1 ? 0.1 : f > 0.9 ? 0.9 : f;
        next = xs[under] * pow(xs[over] / xs[under], f);
      }
    }
    long nl = (long)llround(fmin(next, 4.0 * (double)target));
    if (ceiling > 0 && nl >= ceiling) nl = (base + ceiling) / 2; /* (below a run over the cap) */
    if (nl < fewest) nl = fewest;
    if (nl == base) break;
    base = nl;
    base_aim = aim;
  }
  if (!st && best_miss == INFINITY) { /* only pilots ran (the next base was a pilot's): that one in full */
    ch_count_request rq = {CH_COUNT_FULL, base, coarsenings, runs + 1, base_aim};
    ch_count_reply rp = {0};
    st = fn(ctx, &rq, &rp);
    runs++;
    if (!st) {
      ch_count_reply none = {0};
      rq.kind = CH_COUNT_KEEP;
      st = fn(ctx, &rq, &none);
      best_count = rp.count;
      best_base = base;
      best_coarsenings = coarsenings;
    }
  }
  if (result) {
    memset(result, 0, sizeof *result);
    result->runs = runs;
    if (!st) {
      result->base = best_base;
      result->count = best_count;
      result->coarsenings = best_coarsenings;
    }
  }
  return st;
}
