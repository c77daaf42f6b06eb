/* ch_stepsing: the singular points of h_step (docs/spec.md §3 "Steps") and
 * its leading term there.
 *
 * Where a step curve ends, or step curves cross or meet, the solution of
 * Laplace's equation with the curves' Dirichlet values is, in each sector
 * between the arms the curves leave the point by, to first order linear
 * in the angle: the wedge's Dirichlet problem has h = a + b theta plus
 * terms r^(k pi / alpha) sin(k pi theta / alpha), so around an end (the
 * wedge is the whole turn, alpha = 2 pi) the next term is r^(1/2)
 * sin(theta / 2), and at a crossing of two curves at right angles r^2.
 * The gradient of the first term, b / r across the radius, is what no
 * lattice of samples follows near the point: the feature maps store
 * h_step's gradient less this term and add it back per pixel. */
#ifndef CH_STEPSING_H
#define CH_STEPSING_H

#include "ch_curves.h"
#include "ch_error.h"

#ifdef __cplusplus
extern "C" {
#endif

enum { CH_STEPSING_MAX_ARMS = 8 };

/* A point where step curves end, cross or meet, with the arms they leave
 * it by (counter-clockwise) and h on either side of each. The sector k
 * runs counter-clockwise from arm k to arm k + 1 (an end: from its one arm
 * round to itself); in it the term is value[k] + slope[k] (theta -
 * angle[k]). */
typedef struct ch_stepsing_point {
  double p[2];                        /* UV */
  int num_arms;                       /* 1 .. CH_STEPSING_MAX_ARMS */
  double angle[CH_STEPSING_MAX_ARMS]; /* directions, radians, increasing in [0, 2 pi) */
  double value[CH_STEPSING_MAX_ARMS]; /* h on arm k's counter-clockwise side */
  double slope[CH_STEPSING_MAX_ARMS]; /* dh / dtheta in sector k */
  int arm_curve[CH_STEPSING_MAX_ARMS]; /* the curve arm k runs along (-1: not known, as in a maps file) */
  signed char arm_left_ccw[CH_STEPSING_MAX_ARMS]; /* 1: that curve's left is arm k's ccw side */
  double radius;                      /* how far from p its user takes the term (UV; 0 until set) */
} ch_stepsing_point;

typedef struct ch_stepsing {
  int num_points;
  ch_stepsing_point *points;
} ch_stepsing;

/* Finds the singular points of the step curves the maps encode (sharp,
 * with left != right) inside rect (u0 v0 u1 v1: the domain of h_step):
 * open ends, crossings of two curves (or of a curve with itself), a curve
 * ending on another; points where every sector's slope is zero are left
 * out, and so are points on rect's border or beyond it (there the
 * zero-flux border takes the place of the angle term: a wedge between a
 * Dirichlet curve and a Neumann border has no term linear in the
 * angle). Points with more than CH_STEPSING_MAX_ARMS arms keep the first
 * ones. Blurred step curves make h_step smooth there and are not looked
 * at. */
ch_status ch_stepsing_find(const ch_curve_set *set, const double rect[4], ch_stepsing *out, ch_error *err);

void ch_stepsing_free(ch_stepsing *s);

/* Sets each point's radius: at most `most` (UV), and half the distance
 * to the nearest other point (so no two radii overlap). CH_ERR_NOMEM
 * only. */
ch_status ch_stepsing_limit_radii(ch_stepsing_point *pts, int n, double most, ch_error *err);

/* The term of pt at q (its sector by q's direction from pt): the value,
 * and its gradient in grad (NULL: not asked). Shader-shaped. */
double ch_stepsing_term(const ch_stepsing_point *pt, const double q[2], double grad[2]);

/* The side of step curve c on which every region is bounded by c alone
 * with one value all round, so that h_step is constant there
 * (docs/spec.md §3): +1 its left, -1 its right, 0 none. Needs every
 * subpath of c closed (at most 64), no other step curve meeting c's box, and each nested subpath showing its parent's
 * inside value (a ring of two circles: its band). Thin slabs and rings,
 * whose insides no lattice point samples, are then known flat. */
int ch_stepsing_flat_side(const ch_curve_set *set, int c);
/* ch_stepsing_flat_side of every curve into side[num_curves], the other
 * step segments near each found by a grid (each curve scanned them all:
 * 8000 filled stars took 13 s). CH_ERR_NOMEM only. */
ch_status ch_stepsing_flat_sides(const ch_curve_set *set, int *side, ch_error *err);

/* The arm of curve `curve` that leaves pt towards dir (the one nearest
 * in angle), or -1 if no arm runs along that curve. */
int ch_stepsing_arm_toward(const ch_stepsing_point *pt, int curve, const double dir[2]);

/* The term at q where q is known to lie beside arm `arm`, on its
 * counter-clockwise side if ccw_side, else its clockwise one: the sector
 * and the branch of the angle follow that, not q's direction. A curved arm
 * leaves its tangent ray, and points between the two would otherwise take
 * the sector across the curve (a jump of the whole step). */
double ch_stepsing_term_beside(const ch_stepsing_point *pt, const double q[2], int arm, int ccw_side,
                               double grad[2]);

/* A window of the term: 1 up to r0, 0 from r1, a C1 cubic between. */
double ch_stepsing_window(double r, double r0, double r1);

#ifdef __cplusplus
}
#endif
#endif
