/* ch_embed: feature embedding. Cuts a tessellation of the base surface
 * along every wall and crease of h (docs/spec.md §3-4) so that chains of mesh edges
 * follow them, splits the vertices of walls in two (one per side, joined by
 * vertical wall triangles, so the mesh stays closed), displaces, and gives
 * per-corner normals split at creases and walls.
 *
 * How (and why not by moving vertices, as the paper's §3.5 snapping does):
 * h is smooth inside "pieces": regions where the same groove decides h on
 * the same segment of its profile (between two break points), on the same
 * side of the nearest step curve. Every wall and crease is a boundary
 * between pieces, so the piece label of a point is all the embedding needs.
 * Each mesh edge whose ends lie in different pieces gets one vertex exactly
 * on the boundary (found by bisection on the exact label, to about 1e-15
 * UV), and each triangle is cut by the chords between the boundary points
 * of its edges (three pieces meet at a junction vertex inside). Cutting
 * never moves a vertex, so nothing folds over; crossings, T-junctions of
 * curves and open ends are pieces meeting like any others. Where an edge
 * crosses more than one boundary (a feature thinner than the edges) or a
 * piece hides inside a triangle, the edges are split at their midpoints
 * (conforming red/green refinement) until they do not, or are shorter than
 * 1e-5 UV. A curved profile (u) is made of pieces too: extra break lines,
 * dense near its rims, split it where the chord would leave P by more than
 * a tolerance, so the mesh follows it with thin slices along the groove
 * rather than with isotropic refinement. The cut and the refinement add
 * triangles: callers tessellate for fewer to land on a target count.
 * Boundaries where h has neither a jump nor a kink (the medial
 * line between two step curves, the line beyond an open end) become edges
 * too; they cost a few triangles and change nothing else. */
#ifndef CH_EMBED_H
#define CH_EMBED_H

#include "ch_error.h"
#include "ch_height.h"
#include "ch_progress.h"
#include "ch_mesh.h"
#include "ch_surface.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ch_embed_desc {
  int max_refine_rounds;   /* local refinement rounds; 0 -> 8 (12 with a warp) */
  double step_radius;      /* UV distance within which the side of a step
                              curve is part of the label; 0 -> 4 mean edges */
  double curve_tolerance;  /* curved profiles (u) are cut along extra lines
                              so that h between two stays within this
                              fraction of the depth of the profile; 0 ->
                              0.5 (e/w)^2 within [1e-4, 0.01], e the mean
                              edge, w the groove's width */
  double normal_tolerance_deg; /* curved profiles (u) are also cut so that the
                              slope angle of the displaced cross-section
                              changes by at most this between two lines
                              (object units), and the rounded caps of other
                              profiles are refined until an edge spans at
                              most 4 times this around the end point; 0 ->
                              1800 e degrees within [1, 10], e the reference
                              edge in UV: the tessellation's mean UV edge
                              (ch_embed_to_target uses the target's, so the
                              lines do not change between its runs) */
  int no_thinning;         /* keep every vertex the cut makes inside a groove
                              (by default its layers are thinned, ch_thin.h,
                              where the reference edge above is at least
                              1/360 UV: coarse targets, where it pays) */
  const struct ch_warp *warp; /* NULL, or the warp the tessellation follows
                              (ch_embed_to_target passes it to ch_tess_build):
                              a groove's lines and chords are then as fine as
                              the mesh where the warp is densest over the
                              curve (e / sqrt(slope_u slope_v), e the
                              reference edge) */
  long max_triangles;      /* the refinement stops with CH_ERR_INPUT ("the
                              curves need more than N triangles") before its
                              working mesh would exceed this; 0 -> 8 per base
                              triangle plus 8M */
  const ch_progress *progress; /* NULL, or where the runs, refinement rounds
                              and their stages are reported (from the
                              calling thread) */
  int keep_far;                /* refine and cut every base triangle, those far
                              from the features too (by default they are
                              copied without entering the refinement: the
                              same mesh, which this checks) */
} ch_embed_desc;

enum { CH_EMBED_LEVELS = 16 };
typedef struct ch_embed_stats {
  int refine_rounds, refined_edges;
  int crossings;           /* boundary points on edges */
  int wall_points;         /* of them, where h jumps (split in two) */
  int junctions;           /* triangles where three pieces meet */
  int wall_triangles;
  int unresolved;          /* triangles left uncut after refinement (0 expected) */
  double unresolved_uv[2]; /* with unresolved > 0: the centre of the first
                              (in the tessellation's order), UV */
  double unresolved_box[4];/* and the UV box of all their centres */
  int unresolved_at_seams; /* of them, triangles with a corner on a UV seam
                              whose other chart has other features there:
                              h jumps across the seam, which the shared
                              vertex cannot follow */
  int thinned;             /* vertices the thinning of the grooves' layers removed */
  long densified;          /* triangles ch_embed_to_target added after the cut
                              where h is smooth, to reach its target
                              (negative: removed there) */
  long merged;             /* of those removed, the ones the merges of flat
                              blocks of the base's grid took (the rest:
                              collapses) */
  double angle_deg;        /* the angle step of the u lines the run used */
  int base_triangles;      /* of the tessellation the run embedded into */
  int far_triangles;       /* of them, those far from every feature, copied
                              without entering the refinement */
  long triangles;          /* output triangles (a pilot of ch_embed_to_target
                              counts before the cleanup, which removes a
                              fraction of a percent) */
  double min_h, max_h;
  double seconds_refine, seconds_cut, seconds_normals;
  /* parts of seconds_refine: */
  double seconds_setup, seconds_labels, seconds_edges, seconds_crossings, seconds_classify, seconds_split;
  double seconds_thin;     /* part of seconds_cut */
  /* Boundary points and split edges by the refinement level of their edge
   * (0: the tessellation's own edges; d: about 2^-d of its mean edge, the
   * last level taking the finer ones too): what ch_embed_to_target's count
   * model grows (ch_count.h). */
  int crossings_at_level[CH_EMBED_LEVELS], splits_at_level[CH_EMBED_LEVELS];
} ch_embed_stats;

/* The default normal_tolerance_deg for a reference edge e (UV). */
double ch_embed_angle_deg(double reference_edge);

/* Embeds the features of height into tess (a ch_tess_build result over
 * surface; with corner_st, or each corner whose vertex another face
 * evaluated is located in its own face by a search) and writes the
 * displaced mesh to out: triangles counter-clockwise
 * as the base faces are, positions B + h N, face-varying UVs in the
 * original UV, per-corner normals. Parallel where it matters; the same bytes
 * for any number of threads. Errors: CH_ERR_NOMEM, CH_ERR_INTERNAL. out is
 * zeroed on failure. */
ch_status ch_embed_build(const ch_surface *surface, const ch_tess_result *tess, const ch_height *height,
                         const ch_embed_desc *desc, ch_mesh *out, ch_embed_stats *stats, ch_error *err);

/* Tessellates surface and embeds the features so that the output lands
 * within 5% of target_triangles where the base mesh allows: a pilot run at
 * 1/16 of the target counts what the features add at each refinement
 * level, the next run uses the base count that predicts, and more follow
 * the secant through the last two runs (ch_count.h). Where the model says
 * the u lines would take more than 7/8 of the target, their angle step is
 * coarsened (by 1.5, up to 4 times) and the pilot reruns. A pilot that
 * lands is finished from its cut (not run again); a full run within 15%
 * adds or removes triangles where h is smooth. The run closest to the
 * target is kept: tess receives its tessellation (free it with
 * ch_tess_free; NULL: each run lets its tessellation go as soon as it has
 * read it, before the run's peak), out its embedded mesh; passes the
 * number of embedding runs, pilots and reruns after a coarsening
 * included. */
ch_status ch_embed_to_target(const ch_surface *surface, const ch_height *height, const ch_embed_desc *desc,
                             long target_triangles, ch_tess_result *tess, ch_mesh *out, ch_embed_stats *stats,
                             int *passes, ch_error *err);

#ifdef __cplusplus
}
#endif
#endif
