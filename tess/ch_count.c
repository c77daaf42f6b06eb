/* ch_count: the count model of ch_embed_to_target (see ch_count.h). */
#include "ch_count.h"

#include <math.h>
#include <string.h>

double ch_count_model_base(double target, double c0, double c1) {
  double lo = 1.0, hi = target;
  for (int it = 0; it < 80; it++) {
    double mid = 0.5 * (lo + hi);
    if (mid + c0 + c1 * sqrt(mid) < target)
      lo = mid;
    else
      hi = mid;
  }
  return lo;
}

double ch_count_power_base(double target, double b1, double f1, double b2, double f2) {
  double pw = fmin(1.0, fmax(0.0, log(f2 / f1) / log(b2 / b1)));
  double lo = 1.0, hi = target;
  for (int it = 0; it < 80; it++) {
    double mid = 0.5 * (lo + hi);
    if (mid + f2 * pow(mid / b2, pw) < target)
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
  /* Cheap pilots first: at 1/64 and 1/16 of the target (fewer for small
   * targets). Where the base mesh allows only the second, another at twice
   * it, below a quarter of the target: one pilot gives no model of what
   * does not grow with the base, and taken as growing all (c0 = 0) it
   * coarsened the u lines twice over the vase at 130k (ornament: 6 runs). */
  long pilot[2];
  int pilots = 0;
  for (int k = 0; k < 2; k++) {
    long b = target / (k == 0 ? 64 : 16);
    if (b >= 2000 && b >= fewest) pilot[pilots++] = b;
  }
  if (pilots == 1 && pilot[0] == target / 16 && 2 * pilot[0] <= target / 4) pilot[pilots++] = 2 * pilot[0];
  long first_base = pilots > 0 ? pilot[0] : target, base = first_base;
  double model_c1 = 0.0;                     /* the pilots' sqrt term, kept for the first correction */
  double rescale_f0 = 0.0, rescale_f1 = 0.0; /* what the features added to the pilots before a coarsening */
  int auto_angle = desc->can_coarsen, coarsenings = 0, has_u = desc->has_u;
  long ceiling = 0; /* > 0: a base whose run went over the cap */
  int restarts = 0;
  for (int pass = 0; pass < 8; pass++) {
    /* Pilots only count; one that lands is finished from its cut. */
    int count_only = pass < pilots;
    ch_count_request rq = {count_only ? CH_COUNT_PILOT : CH_COUNT_FULL, base, coarsenings, runs + 1};
    ch_count_reply rp = {0, 0, 0};
    if ((st = fn(ctx, &rq, &rp))) break;
    runs++;
    if (rp.over_cap) {
      /* The cap bounds every run's work (thousands of curves crossing in
       * a small place). Past it at this base, the count at any base above
       * is past it too: the search starts again below, at a quarter of it
       * without pilots (twice at most), and then takes the fewest base's
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
        rescale_f0 = 0.0;
        pass = -1;
        continue;
      }
      ch_count_request last = {CH_COUNT_FULL, fewest, coarsenings, runs + 1};
      ch_count_reply lr = {0, 0, 0};
      if ((st = fn(ctx, &last, &lr))) break;
      runs++;
      if (lr.over_cap) {
        st = CH_ERR_INPUT;
        break;
      }
      double lmiss = fabs(lr.count - (double)target);
      if (lmiss < best_miss) {
        ch_count_request keep = {CH_COUNT_KEEP, fewest, coarsenings, runs};
        ch_count_reply none = {0, 0, 0};
        if ((st = fn(ctx, &keep, &none))) break;
        best_miss = lmiss;
        best_count = lr.count;
        best_base = fewest;
        best_coarsenings = coarsenings;
      }
      break;
    }
    double nb = rp.base, no = rp.count, miss = fabs(no - (double)target);
    xs[pass] = nb;
    ys[pass] = no;
    if (count_only && miss <= 0.04 * (double)target) {
      count_only = 0;
      rq.kind = CH_COUNT_FINISH;
      if ((st = fn(ctx, &rq, &rp))) break;
      no = ys[pass] = rp.count; /* the cleanup's count */
      miss = fabs(no - (double)target);
    }
    if (count_only && pass == 0 && no > 1.25 * (double)target && !has_u) {
      /* The first pilot alone is well over the target. Without u lines the
       * angle step shapes only the caps of open ends: the coarsest step at
       * once (one rerun of the first pilot, not four: bricks at 60k needs
       * it), and if the features still need more than the target, the
       * fewest triangles the base gives (by the model), without the second
       * pilot (500 grooves through a point: 7 runs to reach the same base). */
      if (auto_angle && coarsenings < 4) {
        coarsenings = 4;
        pass = -1;
        base = first_base;
        continue;
      }
      pilots = 1;
      auto_angle = 0;
    }
    if (count_only && pass == 0 && rescale_f0 > 0.0) {
      /* After a coarsening only the first pilot runs again: what the
       * features add to the second is taken to change as they did at the
       * first (glyphs over the tablet at 130k: 0.4% off its rerun). */
      ys[1] = xs[1] + rescale_f1 * (no - nb) / rescale_f0;
      rescale_f0 = 0.0;
      pass = 1;
    }
    if (!count_only && miss < best_miss) { /* keep the closest full run */
      ch_count_request keep = {CH_COUNT_KEEP, base, coarsenings, runs};
      ch_count_reply none = {0, 0, 0};
      if ((st = fn(ctx, &keep, &none))) break;
      best_miss = miss;
      best_count = no;
      best_base = base;
      best_coarsenings = coarsenings;
    }
    /* A full run's count is exact: docs/spec.md §5's 5% is enough (a pilot's is
     * before the cleanup, hence 4% above). */
    if (best_miss <= 0.05 * (double)target) break;
    /* Next base count: after the pilots, the model out = base + c0 + c1
     * sqrt(base) through them (what the cut adds grows like the length of
     * the feature lines over the edge length, plus what does not grow: the
     * refinement at junctions and ends, the rims' last slices; on the
     * bundled sets it predicts a 16x larger run within about 1%), then the
     * secant through the last two runs. One pilot: c0 = 0. */
    double next;
    if (pass + 1 < pilots) {
      next = (double)pilot[pass + 1];
    } else if (pass + 1 == pilots) {
      double c0 = 0.0, c1 = no > nb ? (no - nb) / sqrt(nb) : 0.0;
      if (pilots >= 2) {
        int i0 = pass - 1, i1 = pass; /* the two pilots */
        double s0 = sqrt(xs[i0]), s1 = sqrt(xs[i1]);
        c1 = fmax(0.0, ((ys[i1] - xs[i1]) - (ys[i0] - xs[i0])) / (s1 - s0));
        c0 = (ys[i1] - xs[i1]) - c1 * s1;
      }
      model_c1 = c1;
      next = ch_count_model_base((double)target, c0, c1);
      if (next < (double)target / 8.0 && auto_angle && coarsenings < 4) {
        /* The u lines would take more than 7/8 of the triangles and starve
         * everything else (crossings, CSG seams, the flat parts): coarser
         * angle steps, and the pilots again (the first only, below). */
        coarsenings++;
        if (pilots >= 2 && ys[0] > xs[0] && ys[1] > xs[1]) {
          rescale_f0 = ys[0] - xs[0];
          rescale_f1 = ys[1] - xs[1];
        }
        pass = -1;
        base = first_base;
        best_miss = INFINITY; /* a run at the finer step is no answer */
        continue;
      }
    } else if (pass == 0) {
      next = xs[0] * (double)target / no; /* no pilot (a small target) */
    } else if (pilots >= 2 && pass > pilots && (ys[pass] - ys[pass - 1]) * (xs[pass] - xs[pass - 1]) <= 0.0 &&
               no > nb && ys[1] > xs[1] && nb != xs[1]) {
      /* Two full runs whose counts fall as the base grows (thinning
       * makes the count bumpy: bricks at 130k): no secant, the power
       * model through the last run and the second pilot again. */
      next = ch_count_power_base((double)target, xs[1], ys[1] - xs[1], nb, no - nb);
    } else if (pass == pilots && pilots > 0) {
      /* The first full run missed: what the features add taken as a power
       * of the base through it and the second pilot (thinning makes it
       * grow faster than the pilots' sqrt model says: bricks at 130k, 6 ->
       * 5 runs); without two pilots, the model through it, its slope kept
       * (a secant to a pilot far below runs too flat or too steep). */
      if (pilots >= 2 && no > nb && ys[pass - 1] > xs[pass - 1] && nb != xs[pass - 1]) {
        next = ch_count_power_base((double)target, xs[pass - 1], ys[pass - 1] - xs[pass - 1], nb, no - nb);
      } else {
        next = ch_count_model_base((double)target, (no - nb) - model_c1 * sqrt(nb), model_c1);
      }
    } else {
      double dx = xs[pass] - xs[pass - 1], dy = ys[pass] - ys[pass - 1];
      next = dy != 0.0 ? xs[pass] + ((double)target - ys[pass]) * dx / dy : xs[pass] * (double)target / no;
      if (!(next > 0.0)) next = xs[pass] * 0.5;
    }
    long nl = (long)llround(fmin(next, 4.0 * (double)target));
    if (ceiling > 0 && nl >= ceiling) nl = (base + ceiling) / 2; /* (below a run over the cap) */
    if (nl < fewest) nl = fewest;
    if (nl == base) break;
    base = nl;
  }
  if (!st && best_miss == INFINITY) { /* only pilots ran (the next base was a pilot's): that one in full */
    ch_count_request rq = {CH_COUNT_FULL, base, coarsenings, runs + 1};
    ch_count_reply rp = {0, 0, 0};
    st = fn(ctx, &rq, &rp);
    runs++;
    if (!st) {
      ch_count_reply none = {0, 0, 0};
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
