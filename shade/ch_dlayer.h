/* ch_dlayer: the double layer of an open curve with a constant jump.
 *
 * W(q) = J Omega(q) / 2 pi, Omega the angle the curve sweeps as seen from
 * q (counter-clockwise positive), is harmonic off the curve and jumps by
 * exactly J across it (left minus right, for the curve's direction), all
 * along it; at its ends it is the wedge a + b theta of a step curve's end
 * (ch_stepsing). A diffusion-curve image takes it out of h_step for every
 * open step curve (ch_dci.h): h - W is then continuous across the curve,
 * and its ends no longer singular at first order.
 *
 * Omega is the angle between the ends seen from q plus 2 pi times the
 * winding number round q of the curve closed by its chord; both are
 * per-point and bounded, so a shader can evaluate it. Pieces are
 * quadratic Beziers in any frame the caller chooses (the DCI's texels). */
#ifndef CH_DLAYER_H
#define CH_DLAYER_H

#include "ch_error.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ch_dlayer {
  int curve;          /* the curve's index in its set (the caller's) */
  int first_segment;  /* the first piece's index there (the rest follow) */
  double jump;        /* J: the value on the left less that on the right */
  int num_pieces;
  double (*p)[3][2];  /* quadratic pieces, end to end, from start to end */
  double box[4];      /* of the control points */
} ch_dlayer;

/* The swept angle Omega at q (radians). On the curve itself (or its chord)
 * one side's value or the other's. */
double ch_dlayer_angle(const ch_dlayer *l, const double q[2]);

/* W = jump Omega / 2 pi at q, and its gradient in grad if not NULL (which
 * depends on the ends alone: the layer's density is constant). */
double ch_dlayer_value(const ch_dlayer *l, const double q[2], double grad[2]);

/* W on one side of the curve at its point c: at c moved a hair along n
 * (any vector pointing to that side, not 0). */
double ch_dlayer_value_beside(const ch_dlayer *l, const double c[2], const double n[2]);

void ch_dlayer_free(ch_dlayer *l);

#ifdef __cplusplus
}
#endif
#endif
