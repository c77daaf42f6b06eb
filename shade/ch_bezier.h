/* ch_bezier: exact geometry of the curve segments: evaluation, tangents,
 * closest points on lines and quadratic Beziers, and the conversion of
 * cubics and elliptical arcs into quadratics within a tolerance. */
#ifndef CH_BEZIER_H
#define CH_BEZIER_H

#ifdef __cplusplus
extern "C" {
#endif

/* The real roots of a t^2 + b t + c (0, 1 or 2 of them, unordered), by
 * the form that does not cancel; nearly linear (|a| < 1e-14 |b|) as
 * linear. For where a line meets a quadratic segment. */
int ch_quadratic_roots(double a, double b, double c, double roots[2]);

/* Point of the quadratic p at parameter t. */
void ch_bezier_eval(const double p[3][2], double t, double out[2]);

/* Unit tangent of the quadratic at t. Where the derivative vanishes (a
 * control point on an end point, or the turning point of a folded
 * quadratic) the limit direction is used; a segment that is a single point
 * gives (0, 0). */
void ch_bezier_tangent(const double p[3][2], double t, double out[2]);

/* ch_bezier_tangent before it is made unit (the same direction, so the
 * same sides; for sign tests that need no sqrt). */
void ch_bezier_direction(const double p[3][2], double t, double out[2]);

/* ch_bezier_tangent at 0 and at 1 (the same values), sharing the work. */
void ch_bezier_end_tangents(const double p[3][2], double t0[2], double t1[2]);

/* Arc length of the quadratic (16-point Gauss-Legendre on its speed:
 * relative error below 1e-9 unless the segment folds back on itself). */
double ch_bezier_length(const double p[3][2]);

/* Closest point of the segment to q: returns the squared distance and the
 * parameter in [0, 1] (the smallest one on ties). For quadratics the
 * stationary points are the real roots of a cubic, found per monotone
 * interval by safeguarded Halley iteration stopped by a bound on its error
 * (t within 1e-17 of the root, beside the rounding), so nearly straight,
 * folded and degenerate segments are handled without special cases.
 * is_line selects the exact projection onto p[0]..p[2]. */
double ch_bezier_closest(const double p[3][2], int is_line, const double q[2], double *t);

/* The box of the control points (which holds the quadratic): umin vmin
 * umax vmax. By comparisons, not fmin and fmax: those were library calls,
 * a sixth of finding the crossings of 16000 filled stars (the points are
 * finite). */
static inline void ch_bezier_box(const double p[3][2], double b[4]) {
  b[0] = b[2] = p[0][0], b[1] = b[3] = p[0][1];
  for (int k = 1; k < 3; k++) {
    if (p[k][0] < b[0]) b[0] = p[k][0];
    if (p[k][0] > b[2]) b[2] = p[k][0];
    if (p[k][1] < b[1]) b[1] = p[k][1];
    if (p[k][1] > b[3]) b[3] = p[k][1];
  }
}

/* The crossings of the quadratics a and b: parameters s on a and t on b
 * where a(s) = b(t) with the two not tangent there (a tangency or an
 * overlap gives none), ends included (within 1e-9), at most
 * CH_BEZIER_MAX_CROSSINGS, found by halving both until their boxes are
 * 1e-4 wide and then Newton's method. Returns the count. */
enum { CH_BEZIER_MAX_CROSSINGS = 16 };
int ch_bezier_crossings(const double a[3][2], const double b[3][2], double s[CH_BEZIER_MAX_CROSSINGS],
                        double t[CH_BEZIER_MAX_CROSSINGS]);

/* Callback receiving quadratic pieces (control points in output space). */
typedef int (*ch_quad_sink)(void *user, const double q[3][2]);

/* Splits the cubic c into the fewest equal-parameter pieces whose midpoint
 * quadratics are within tol of it (bound sqrt(3)/36 |c3 - 3c2 + 3c1 - c0| /
 * n^3) and emits them. Returns the sink's first nonzero result, else 0. */
int ch_cubic_to_quads(const double c[4][2], double tol, ch_quad_sink sink, void *user);

/* Emits quadratics for the arc of the unit circle from angle a0 by sweep
 * (radians, signed), mapped through the affine map m (x' = m0 x + m2 y + m4,
 * y' = m1 x + m3 y + m5), within tol in output space. */
int ch_arc_to_quads(double a0, double sweep, const double m[6], double tol,
                    ch_quad_sink sink, void *user);

#ifdef __cplusplus
}
#endif
#endif
