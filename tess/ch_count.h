/* ch_count: the count model. Decides the base triangle counts at which a
 * tessellation plus a feature embedding (ch_embed_to_target) land near a
 * target output count, knowing only what each run returns: the base count
 * the tessellation gave, the output count the embedding made, and what it
 * added at each refinement level of its edges.
 *
 * Why levels: the cut adds about two triangles per boundary point on an
 * edge and the refinement two per split edge. On the base's own edges
 * (level 0) their number grows like the feature lines' length over the
 * edge length, so like sqrt(base); on edges the refinement made, d
 * halvings below the base (level d), they serve features of a fixed size
 * (junctions, ends, lines closer than an edge), whose refinement stays
 * while the base is coarser than that size and grows with the base once
 * it is finer: by max(1, sqrt(k) / 2^d) where the base grows by k. One
 * cheap count-only "pilot" run at 1/16 of the target measures those; the
 * next run uses the base count they predict, and more follow the secant
 * through the last two runs. Where the model says the u lines would take
 * more than 7/8 of the target, their angle step is coarsened (by 1.5, up
 * to 4 times) and the pilot reruns. A pilot that lands within 4% is
 * finished from its cut, not run again (unless its count was estimated
 * from a sample of the surface: ch_count_reply.estimated).
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
  double aim;      /* FULL: the count its base was chosen for (the target
                      and the caller's margin); 0 where none was */
} ch_count_request;

enum { CH_COUNT_LEVELS = 16 };
typedef struct ch_count_reply {
  double base;  /* PILOT, FULL: the base triangle count the tessellation gave */
  double count; /* PILOT, FINISH, FULL: the output triangle count */
  int over_cap; /* PILOT, FULL: the run stopped at the embedding's cap on
                   triangles (no mesh; the error is in the caller's hands) */
  /* PILOT, FULL: the triangles the run added at each refinement level
   * (level 0: in the base's own triangles, growing like sqrt(base); the
   * last level takes the finer ones too); all 0 says that what the
   * features add does not grow with the base. */
  double level_added[CH_COUNT_LEVELS];
  int estimated; /* PILOT: count and level_added were estimated from a
                    sample of the surface: no cut to FINISH */
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
  double take_back;      /* the caller brings a full run within this share
                            of the target back to it (where h is smooth);
                            0: it does not */
  double feature_margin; /* full runs aim this share of what the features
                            add above the target (0: at it), for a caller
                            that takes runs back */
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

/* The output count a run at `base` would give by the level model of
 * `run` (see above): base + what run added, each level's part grown by
 * its factor; rises with base. Pure. */
double ch_count_level_predict(const ch_count_reply *run, double base);
/* The base count b at which ch_count_level_predict(run, b) = target
 * (bisection over [1, target]; 1 if no b above 1 gives less). Pure. */
double ch_count_level_base(double target, const ch_count_reply *run);
#ifdef __cplusplus
}
#endif
#endif
