/* ch_count: the count model. Decides the base triangle counts at which a
 * tessellation plus a feature embedding (ch_embed_to_target) land near a
 * target output count, knowing only what each run returns: the base count
 * the tessellation gave and the output count the embedding made.
 *
 * Why a model: what the cut adds grows like the number of edges the feature
 * lines cross, so like sqrt(base), plus what does not grow with the base
 * (refinement at junctions and ends, the rims' slices of u grooves):
 * out = base + c0 + c1 sqrt(base). Cheap count-only "pilot" runs at 1/64
 * and 1/16 of the target measure c0 and c1; the next run uses the base
 * count that model predicts, and more follow the secant through the last
 * two runs (or a power model where thinning makes the count bumpy). Where
 * the model says the u lines would take more than 7/8 of the target, their
 * angle step is coarsened (by 1.5, up to 4 times) and the pilots rerun. A
 * pilot that lands within 4% is finished from its cut, not run again.
 *
 * The model runs nothing itself: it calls back, so it can be driven by
 * analytic count functions in a test as well as by the real embedding. */
#ifndef CH_COUNT_H
#define CH_COUNT_H

#include "ch_error.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum ch_count_kind {
  CH_COUNT_PILOT,  /* count only at rq->base (cheap; the count is before the
                      cleanup); keep the cut in case a FINISH follows */
  CH_COUNT_FINISH, /* finish the last pilot's cut into a full run: reply the
                      count after the cleanup (rp->base is not read) */
  CH_COUNT_FULL,   /* a full run at rq->base */
  CH_COUNT_KEEP    /* the last FULL or FINISH run is the closest yet: keep it
                      (dropping the one kept before); runs not kept may be
                      dropped when the next run starts */
} ch_count_kind;

typedef struct ch_count_request {
  ch_count_kind kind;
  long base;       /* PILOT, FULL: the base triangle count to ask for */
  int coarsenings; /* PILOT, FULL: the u lines' angle step is the default
                      one times 1.5 this many times (0..4) */
  int run;         /* PILOT, FULL: 1, 2, ...: the number of this run */
} ch_count_request;

typedef struct ch_count_reply {
  double base;  /* PILOT, FULL: the base triangle count the tessellation gave */
  double count; /* PILOT, FINISH, FULL: the output triangle count */
  int over_cap; /* PILOT, FULL: the run stopped at the embedding's cap on
                   triangles (no mesh; the error is in the caller's hands) */
} ch_count_reply;

/* One run (or a FINISH/KEEP) as the request says; returns CH_OK, or an
 * error that stops the search (and is returned by it). */
typedef ch_status (*ch_count_fn)(void *ctx, const ch_count_request *rq, ch_count_reply *rp);

typedef struct ch_count_desc {
  long target;     /* output triangles wanted */
  long fewest;     /* the fewest base triangles the base mesh gives (no run
                      asks for fewer; a target below it is raised to it) */
  int can_coarsen; /* the angle step may be coarsened: it is the default
                      one and there are grooves it shapes */
  int has_u;       /* some groove has a u profile (its lines follow the
                      angle step; without them, a first pilot well over the
                      target goes to the coarsest step at once) */
} ch_count_desc;

typedef struct ch_count_result {
  int runs;        /* PILOT and FULL calls (FINISH and KEEP not counted) */
  long base;       /* the base count asked for by the kept run */
  int coarsenings; /* the angle coarsenings of the kept run */
  double count;    /* the kept run's output count */
} ch_count_result;

/* Searches for the base count whose full run lands within 5% of
 * desc->target (see below). A run over the cap (rp->over_cap): no base
 * above it is asked for again, and the search starts over below it (at a
 * quarter, twice at most); after that, one run at the fewest base
 * triangles, kept if it is the closest; CH_ERR_INPUT if that run is over
 * the cap too (or was the one over it).
 *
 * In full: searches for the base count whose full run lands within 5% of
 * desc->target, calling fn for each run; at most 8 runs per angle step
 * (and one full run after them if only pilots ran), so at most 41 in all.
 * The closest full run is the last one fn was asked to KEEP; where the
 * target is out of reach (the features alone exceed it), that is the run
 * at (about) the fewest base triangles. Returns CH_OK or fn's first error;
 * result (may be NULL) is filled on success and its runs on failure too.
 * Allocates nothing; reentrant (state lives on the stack and in ctx). */
ch_status ch_count_search(const ch_count_desc *desc, ch_count_fn fn, void *ctx, ch_count_result *result);

/* The base count b with b + c0 + c1 sqrt(b) = target (bisection over
 * [1, target]; 1 if no b above 1 gives less). Pure. */
double ch_count_model_base(double target, double c0, double c1);

/* The base count b with b + f2 (b / b2)^p = target, p the power through
 * (b1, f1) and (b2, f2) clamped to [0, 1]: what the features add at two
 * runs taken as a power of the base. Pure. */
double ch_count_power_base(double target, double b1, double f1, double b2, double f2);

#ifdef __cplusplus
}
#endif
#endif
