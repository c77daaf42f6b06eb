/* ch_embed internals shared by the embedding's modules (ch_label, ch_refine,
 * ch_cut, ch_embed) and its tests, not installed: their limits, and the
 * knobs ch_embed_to_target's count model sets on each run. */
#ifndef CH_EMBED_INTERNAL_H
#define CH_EMBED_INTERNAL_H

#include <stdint.h>

#include "ch_embed.h"

#ifdef __cplusplus
extern "C" {
#endif

enum {
  MAX_U_LINES = 60,
  MAX_LINES = 2 * MAX_U_LINES + 2,
  MAX_CURVES_LABELLED = 1 << 20,
  BISECTIONS = 46,
  JUNCTION_BISECTIONS = 30,
  MAX_EDGE_SAMPLES = 32
};
/* A triangle is cut from at most MAX_NODES boundary nodes (its corners and
 * its edges' crossings); one with more is refined, in the first
 * DENSE_ROUNDS rounds only: where crossings are spread along its edges
 * (a hatch of lines) halving resolves them, where they meet at a point
 * (grooves crossing there) it never does, and every round would quadruple
 * the triangles there (2000 grooves through a point: minutes). */
enum { MAX_NODES = 192, DENSE_ROUNDS = 4 };
/* Grooves crowd where a cell of the groove field's grid lists more than
 * this many segments (the bundled sets: 24 at most): ch_refine_crossings. */
enum { CROWDED_CELL = 48 };
/* The refinement's cap on working triangles (ch_embed_desc.max_triangles):
 * 8 per base triangle plus 8M (some GB of working mesh and crossings), far
 * above what the bundled sets need. */
#define MAX_REFINED_PER_BASE 8.0
#define MAX_REFINED_EXTRA 8388608.0
#define MIN_SPLIT_LENGTH 1e-5
#define WALL_GROUP (UINT64_C(1) << 62)

typedef struct ch_embed_pilot {
  int *over_cap;         /* NULL, or set to 1 where the run stops at
                            ch_embed_desc.max_triangles */
  int count_only;        /* only count the triangles the cut makes
                            (stats->triangles, before the cleanup; out stays
                            empty): the pilots of ch_embed_to_target */
  double reference_edge; /* e of the angle-step and thinning rules (see
                            ch_embed_desc); 0 -> the tessellation's mean UV
                            edge (ch_embed_to_target sets the target's, so
                            the lines do not change between its runs) */
  int run;               /* 1, 2, ...: the run number progress reports */
  int full;              /* with count_only: a full run whose cut the caller
                            finishes (progress does not call it a pilot) */
  int sampled;           /* with count_only and not full: only the triangles
                            in a sample of the UV tiles (sample_tile in
                            ch_embed.c) are refined and their cut counted, and the
                            count and the levels are scaled up from them by
                            the UV area; no cut is kept. For runs with no
                            thinning (ch_embed_to_target sets it where the
                            target is large enough) */
  double **release_corner_st; /* NULL, or the tessellation's corner_st
                                 (ch_tess_result), freed and set to NULL
                                 once the working mesh has read it, so
                                 it is gone before the run's peak */
  ch_tess_result *release_tess; /* NULL, or the tessellation itself (the
                                   run's): freed (ch_tess_free) once the
                                   run has read it, release_corner_st
                                   then unused */
  int takes_back;               /* with count_only: a run aimed far enough above
                            its target that the finish will take some back
                            (it then finds the grid's blocks: ch_blocks.c) */
} ch_embed_pilot;

/* ch_embed_build with the pilot knobs (NULL: as ch_embed_build). Same
 * contract otherwise. */
ch_status ch_embed_run(const ch_surface *surface, const ch_tess_result *tess, const ch_height *height,
                       const ch_embed_desc *desc, const ch_embed_pilot *pilot, ch_mesh *out, ch_embed_stats *stats,
                       ch_error *err);

#ifdef __cplusplus
}
#endif
#endif
