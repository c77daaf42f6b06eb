/* ch_label: the piece labels of the feature embedding (see ch_embed.h): which
 * side of which feature a point of the UV square is on. h is smooth inside
 * a piece; every wall and crease of h lies on a boundary between two. The
 * labeler is built once per embedding run (read-only afterwards: every
 * function below may be called from many threads at once). */
#ifndef CH_LABEL_INTERNAL_H
#define CH_LABEL_INTERNAL_H

#include <stdint.h>

#include "ch_embed_internal.h"
#include "ch_error.h"
#include "ch_grid.h"
#include "ch_height.h"
#include "ch_segtree.h"
#include "ch_warp.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The labeler: what the labels of one embedding run are read from (built
 * by ch_label_init, freed by ch_label_free; owns its arrays).
 * label = groove part << 32 | step part. Groove part: (line set << 20 |
 * (active curve + 1)) << 8 | index of the profile segment (break points
 * below t = s / w), 0 where no groove decides h; the line set is 0 but
 * for u grooves under a warp (level_at). Step part: (nearest step curve within the radius + 1)
 * << 1 | (side is left), 0 when none is that near or the side is the one
 * facing out of a closed loop (step_outer). */
typedef struct ch_label_ctx {
  const ch_height *height;
  const ch_curve_set *set;
  int *crease_start; /* per curve, into crease_t */
  double *crease_t;
  ch_grid step_grid; /* step segments, boxes grown by radius */
  double (*step_boxes)[4];
  ch_grid groove_grid; /* groove segments, boxes grown by half their width */
  ch_segtree tree;     /* every segment: a curve's closest, the nearest step curve */
  /* Per cell of a step_res^2 grid over the step segments' bounding box
   * (from step_origin, cells step_cell wide): the step segment nearest the
   * cell's centre, the first bound of a nearest-step walk (NULL: none). */
  int *step_hint;
  int step_res;
  double step_origin[2], step_cell[2], step_slack;
  /* Per hint cell (where step_has_list[cell]): the step segments that can
   * be nearest to a point of the cell, ascending, from step_list_start. */
  int *step_list, *step_list_start;
  unsigned char *step_has_list;
  /* Sharp corners of step curves (joints turning by more than 30 degrees,
   * coarse_at_step_corner): the segments leaving them, bucketed by the
   * corner's cell of a corner_res^2 grid over the unit square (clamped). */
  int *corner_seg, *corner_start, corner_res;
  /* Open ends of grooves but u ones (coarse_at_cap): 2 * segment + end,
   * bucketed so by their point; the largest half width among them. */
  int *end_item, *end_start, end_res;
  double end_reach;
  /* Per segment of a free closed step loop (find_step_outer), the side of
   * it that faces out of the loop: 1 right, 2 left (0: any other step
   * segment; NULL when no loop is free). The step part of a label is 0
   * there (see ch_label_at). */
  unsigned char *step_outer;
  double radius;
  int has_steps;
  /* Quiet cells: no point within reach of a cell's points is in a groove's
   * support or within `radius` of a step curve, reach = the longest mesh
   * edge; so an edge or triangle whose corners all lie in quiet cells has
   * label 0 throughout. Cells cover [0,1]^2; outside is never quiet. */
  unsigned char *busy;
  int mask_res;
  double *chord_tol;    /* per curve: how far h along a chord may leave the
                          mesh's (a groove's line curves away from its chords) */
  /* Per u groove, what bounds how far its lines curve away from a chord
   * (ch_label_chord_within): the largest curvature of its path and the
   * largest turn at a joint of two segments (curvature INFINITY: no
   * bound, where the path comes within its width of itself away from a
   * joint or turns sharply); and its open ends (2 doubles each, from
   * chord_end_start[c]), whose caps curve the lines round them. */
  double *chord_curvature, *chord_kink, *chord_ends;
  int *chord_end_start;
  double wall_tol;      /* a jump of h above this is a wall */
  double junction_size; /* triangles holding a junction are refined to this */
  double cap_angle;     /* around an open end, edges span at most this angle */
  const ch_warp *warp;  /* or NULL: then caps and junctions are sized by the
                           warped density there over the grooves' mean */
  double mean_density;
  /* With a warp, u grooves have a finer line set (level 1: the angle step
   * halved) where the warped mesh is at least twice as dense as along the
   * groove on average: a groove's lines run its whole length, so one step
   * for all of it serves only its mean. Where the level changes the labels
   * change across the groove: the cut runs there too (h is continuous),
   * the lines of one side ending on it. level_start[c * LEVELS + L] into
   * level_t. (Three levels measured worse: the junctions where lines end
   * took the triangles.) */
  int *level_start;
  double *level_t;
  double *curve_density; /* per curve: the mean warped density along it */
  double *curve_angle;   /* per curve: the angle step of its lines (radians) */
  double object_scale;   /* object units per UV unit */
} ch_label_ctx;

enum { LEVELS = 2 };
/* The groove part g of a label: (level << 20 | (curve + 1)) << 8 | k. */
#define GROOVE_CURVE(g) ((int)(((g) >> 8) & 0xfffff) - 1)
#define GROOVE_LEVEL(g) ((int)(((g) >> 28) & 3))

/* The piece label at uv: which groove decides h there and on which segment
 * of its profile (between which two break lines), and on which side of
 * which step curve within the radius; equal labels, the same smooth piece
 * of h. Pure: the same uv gives the same label from any thread. */
uint64_t ch_label_at(const ch_label_ctx *lb, const double uv[2]);

/* Curve c's signed distance at uv from closest_in_cell over grid and
 * boxes (4 per segment, grown by reach); over all of c's segments where the cell has none
 * of them, or (without `beyond`) none within reach. *segment and *param
 * (either may be NULL) get the closest point's segment and parameter. */
double ch_label_signed_distance_in(const ch_label_ctx *lb, const ch_grid *grid, const double *boxes, int c,
                                   const double uv[2], double reach, int beyond, int *segment, double *param);

/* Signed distance s from uv to groove curve c: over c's segments in the
 * grooves' grid cell (boxes grown by w/2); beyond w/2, over all of c's
 * segments, or with `cell_beyond` the closest of those in the cell if
 * there are any (enough to bracket a level inside the groove, and a scan
 * of a long curve less). */
double ch_label_groove_distance_in(const ch_label_ctx *lb, int c, const double uv[2], int *segment, double *param,
                                   int cell_beyond);

/* ch_label_groove_distance_in without the segment, over all of c's
 * segments beyond w/2. */
double ch_label_groove_distance(const ch_label_ctx *lb, int c, const double uv[2]);

/* The break lines of groove c at level L (the finer sets of u grooves). */
const double *ch_label_lines_of(const ch_label_ctx *lb, int c, int L, int *nb);

/* Whether a chord from p to q between two points of u groove c's line at
 * level t = line is proven to keep within err_max of h at its middle mid
 * (|t(mid) - line| |depth|, the chord test of the refinement), from the
 * path's curvature and turns alone (the sagitta of the line's curve,
 * which is the offset of the path at line w, over the chord); 0 where
 * there is no such bound and the test must read t at mid. */
int ch_label_chord_within(const ch_label_ctx *lb, int c, double line, const double p[2], const double q[2],
                          const double mid[2], double err_max);

/* Whether uv lies in a quiet cell (label 0 within the longest mesh edge
 * around it: see the labeler's busy mask). */
int ch_label_quiet(const ch_label_ctx *lb, const double uv[2]);
/* Whether every cell meeting the box [lo, hi] is quiet (so is every point
 * in it). */
int ch_label_box_quiet(const ch_label_ctx *lb, const double lo[2], const double hi[2]);

/* h in a given piece at a point on its boundary: h_step read at `inside`
 * (a point of the piece within rounding of `at`), plus the groove of the
 * label evaluated by its own profile segment, continued to `at`. Reading
 * the groove at a point could land on the wrong side of a wall: a label
 * sits a hair (1e-13 in t) off where h changes, and along an edge that
 * meets the line at a grazing angle no offset is safe. */
double ch_label_piece_height(const ch_label_ctx *lb, uint64_t label, const double inside[2], const double at[2]);

/* The density the warped mesh has at uv: sqrt(slope_u slope_v) of the
 * mesh's metric (ch_warp_mesh_slopes; the mesh's edge is e / that). */
double ch_label_mesh_density(const ch_warp *w, const double uv[2]);

/* Builds the labeler of height: the step curves' side within radius (UV),
 * the grooves' break lines (curve_tolerance: chord error as a fraction of
 * the depth, 0 -> by mean_edge; angle: the u lines' angle step, radians;
 * object_scale: object units per UV unit), warp-dependent line sets (warp
 * may be NULL), quiet cells for edges up to `reach` long. lb is zeroed
 * first; on failure the error is set (CH_ERR_NOMEM, CH_ERR_INPUT for too
 * many curves) and the caller still frees lb with ch_label_free. Not
 * thread-safe on lb. */
ch_status ch_label_init(ch_label_ctx *lb, const ch_height *height, const ch_warp *warp, double radius,
                        double curve_tolerance, double angle, double object_scale, double mean_edge, double reach,
                        ch_error *err);

/* Frees what ch_label_init allocated and zeroes lb (a zeroed lb is fine). */
void ch_label_free(ch_label_ctx *lb);

/* Whether end (0: start, 1: end) of segment s is an open end of a groove
 * whose cap coarse_at_cap sizes (all profiles but u). */
int ch_label_capped_end(const ch_curve_set *set, int s, int end);

/* The cell of coordinate x on res cells over [0, 1], clamped (far
 * outside, or not a number: the border's). */
int ch_label_corner_cell(int res, double x);

/* How much finer than the mean the warped mesh is at uv (relative to the
 * grooves' mean density, within [1/8, 4]); 1 without a warp. */
double ch_label_local_factor(const ch_label_ctx *lb, const double uv[2]);

/* The factor of a groove's chord tolerance at uv. Where the warped mesh is
 * coarser than the grooves' mean (away from the view) a chord's sagitta
 * grows as the square of its length, so the tolerance does too, or the
 * chords would refine the coarse parts back towards the mean; where it is
 * finer, linear (see ch_label_init). */
double ch_label_chord_factor(const ch_label_ctx *lb, const double uv[2]);

#ifdef __cplusplus
}
#endif
#endif
