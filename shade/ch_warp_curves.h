/* ch_warp_curves: the curves registered on the warp's cage and warped
 * through its cage map C (diffusion-curves-on-surfaces §3.2; the warp and C
 * are ch_warp.h). */
#ifndef CH_WARP_CURVES_H
#define CH_WARP_CURVES_H
#include "ch_curves.h"
#include "ch_error.h"
#include "ch_warp.h"
#ifdef __cplusplus
extern "C" {
#endif

typedef struct ch_warp_curve_stats {
  int registered_pieces;    /* pieces after cutting at triangle boundaries */
  double seconds;
} ch_warp_curve_stats;

/* Registers the curves on the cage and warps them through it: every
 * segment is cut where it crosses a cage triangle's edge (the triangles
 * near it come from the grid over UV, so the cost follows the curves, not
 * curves x triangles), each piece is registered to the triangle holding
 * its middle and its control points are mapped by that triangle's affine
 * map (so a quadratic piece stays exactly the quadratic image of the
 * original, lines stay lines); pieces outside the cage have their control
 * points mapped by W (not cut at the knot lines: no exact image there).
 * Consecutive pieces share their end points exactly (the start of a piece
 * is set to the end of the one before, across segments where the original
 * ones meet exactly; a closed subpath ends on its first point). out is a complete curve set (same
 * curves, attributes, subpaths, closedness; prev/next, counts and boxes
 * recomputed) in warped UV. Widths and blur radii stay in UV units (the
 * consumers scale them by the slopes). stats may be NULL. Parallel over
 * segments; the same bytes on any thread count. CH_ERR_NOMEM
 * (CH_ERR_INPUT past INT_MAX pieces); out zeroed on failure. */
ch_status ch_warp_curves(const ch_warp *w, const ch_curve_set *in, ch_curve_set *out,
                         ch_warp_curve_stats *stats, ch_error *err);

#ifdef __cplusplus
}
#endif
#endif
