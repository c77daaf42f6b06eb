/* Exact segment geometry. The closest point on a quadratic Bezier is the
 * classic cubic-root problem (see e.g. the GPU distance-field literature the
 * diffusion-curve papers build on); we solve it without the closed form,
 * which loses digits for nearly straight curves: the cubic's derivative
 * splits [0,1] into monotone intervals (most often there is one), and each
 * sign change is refined by Halley's method kept inside its bracket and
 * stopped by a bound on its error. */
#include "ch_bezier.h"

#include <math.h>

#include "ch_math.h"

void ch_bezier_eval(const double p[3][2], double t, double out[2]) {
  double s = 1.0 - t;
  double a = s * s, b = 2.0 * s * t, c = t * t;
  out[0] = a * p[0][0] + b * p[1][0] + c * p[2][0];
  out[1] = a * p[0][1] + b * p[1][1] + c * p[2][1];
}

/* The direction of B' = a + t b (a = p1 - p0, b = p2 - 2 p1 + p0), not
 * normalised; 0 when the curve has none (a point). */
static int direction_from(const double a[2], const double b[2], const double chord[2], double scale, double t,
                          double d[2]) {
  d[0] = a[0] + t * b[0], d[1] = a[1] + t * b[1];
  if (ch_dot2(d, d) > 1e-24 * scale) return 1;
  /* The derivative vanishes: at an end whose control point coincides with
   * it the curve leaves (or arrives) along the chord; at the turning point
   * of a folded, collinear quadratic the chord is one of the two equally
   * valid directions. */
  if (ch_dot2(chord, chord) > 0.0) {
    d[0] = chord[0], d[1] = chord[1];
    return 1;
  }
  if (ch_dot2(b, b) > 0.0) {
    d[0] = b[0], d[1] = b[1];
    return 1;
  }
  d[0] = d[1] = 0.0;
  return 0;
}

/* The unit tangent: direction_from's, normalised. */
static void tangent_from(const double a[2], const double b[2], const double chord[2], double scale, double t,
                         double out[2]) {
  double d[2];
  if (!direction_from(a, b, chord, scale, t, d)) {
    out[0] = out[1] = 0.0;
    return;
  }
  double inv = 1.0 / sqrt(ch_dot2(d, d));
  out[0] = d[0] * inv;
  out[1] = d[1] * inv;
}

/* a, b, the chord and the size tangent_from compares against. */
static double tangent_setup(const double p[3][2], double a[2], double b[2], double chord[2]) {
  a[0] = p[1][0] - p[0][0], a[1] = p[1][1] - p[0][1];
  b[0] = p[2][0] - 2.0 * p[1][0] + p[0][0], b[1] = p[2][1] - 2.0 * p[1][1] + p[0][1];
  chord[0] = p[2][0] - p[0][0], chord[1] = p[2][1] - p[0][1];
  return ch_dot2(a, a) + ch_dot2(b, b) + ch_dot2(chord, chord);
}

void ch_bezier_tangent(const double p[3][2], double t, double out[2]) {
  double a[2], b[2], chord[2], scale = tangent_setup(p, a, b, chord);
  tangent_from(a, b, chord, scale, t, out);
}

void ch_bezier_direction(const double p[3][2], double t, double out[2]) {
  double a[2], b[2], chord[2], scale = tangent_setup(p, a, b, chord);
  direction_from(a, b, chord, scale, t, out);
}

void ch_bezier_end_tangents(const double p[3][2], double t0[2], double t1[2]) {
  double a[2], b[2], chord[2], scale = tangent_setup(p, a, b, chord);
  tangent_from(a, b, chord, scale, 0.0, t0);
  tangent_from(a, b, chord, scale, 1.0, t1);
}

/* Real roots of a x^2 + b x + c in (0, 1), numerically stable form. */
int ch_quadratic_roots(double a, double b, double c, double roots[2]) {
  int n = 0;
  if (fabs(a) < 1e-14 * (fabs(b) + 1e-300)) {
    if (b != 0.0) roots[n++] = -c / b;
    return n;
  }
  double disc = b * b - 4.0 * a * c;
  if (disc < 0.0) return 0;
  double r = sqrt(disc), qq = -0.5 * (b + (b >= 0.0 ? r : -r));
  roots[n++] = qq / a;
  if (qq != 0.0) roots[n++] = c / qq;
  return n;
}

static int quadratic_roots_01(double a, double b, double c, double r[2]) {
  int n = 0;
  double scale = fabs(a) + fabs(b) + fabs(c);
  if (scale == 0.0) return 0;
  if (fabs(a) <= 1e-300 * scale || fabs(a) < 1e-15 * scale) {
    if (b != 0.0) {
      double x = -c / b;
      if (x > 0.0 && x < 1.0) r[n++] = x;
    }
    return n;
  }
  double disc = b * b - 4.0 * a * c;
  if (disc < 0.0) return 0;
  double sq = sqrt(disc);
  double qq = -0.5 * (b + (b >= 0.0 ? sq : -sq));
  double x0 = qq / a;
  double x1 = qq != 0.0 ? c / qq : x0;
  if (x0 > x1) {
    double tmp = x0;
    x0 = x1;
    x1 = tmp;
  }
  if (x0 > 0.0 && x0 < 1.0) r[n++] = x0;
  if (x1 > 0.0 && x1 < 1.0 && (n == 0 || x1 != r[0])) r[n++] = x1;
  return n;
}

/* How close to the root increasing_root's result is proven to be, in t
 * and beside the rounding of f itself: far below what any caller reads
 * (the crossing search reads t = s / w to about 1e-14), and below the
 * 1e-16 steps Newton's method here once had to see before it stopped. */
#define ROOT_TOL 1e-17

/* Root of the cubic f (coefficients k, highest first) in [lo, hi], where
 * f(lo) < 0 < f(hi) and f' >= 0: Halley's method from start, falling back
 * to bisection when a step leaves the bracket, and stopped by a bound on
 * the error of the step just taken rather than by a further step that
 * confirms it. Halley's cubic convergence (e.g. Traub, Iterative Methods
 * for the Solution of Equations, 1964) makes that bound small one step
 * earlier than Newton's: on the queries recorded on ornament a root takes
 * 2.0 evaluations of f (3.6 with Newton to a confirming step).
 *
 * The bound. At t, with h = r - t (r the root), f' = f'(t) > 0 and
 * f'' = f''(t), Taylor's expansion of the cubic is exact:
 * 0 = f + f' h + f'' h^2 / 2 + k0 h^3. Halley's step d = -2 f f' / D,
 * D = 2 f'^2 - f f'', then leaves
 *   h - d = h^3 (f''^2 / 2 - 2 k0 f' + k0 f'' h) / D.
 * Let M >= |f''| on the bracket, s = f / f' (Newton's step) and
 * K = M / (2 f'). From f' >= f'(t) - M |x - t| between t and r (f' >= 0
 * there), 4 K |s| <= 0.1 keeps |h| below 1 / (2K), and |h| <= |s| + K h^2
 * then gives |h| <= 1.027 |s|. If 21 M |d| <= f', then |s| <= 1.025 |d|
 * (d = s / (1 - x), |x| = |s f''| / (2 f') <= 0.0244), which implies the
 * former, and D >= 1.95 f'^2: the step lands within
 *   |d|^3 (0.3 M^2 + 1.23 k0 f') / f'^2
 * of r. The first step is never taken as the last: from the start the
 * bound would rarely hold. */
static inline __attribute__((always_inline)) double increasing_root(const double k[4], double lo, double hi,
                                                                    double start) {
  double d0 = 3.0 * k[0], d1 = 2.0 * k[1], e0 = 2.0 * d0; /* f' = (d0 t + d1) t + k2, f'' = e0 t + d1 */
  /* f'' is linear: its largest magnitude on the bracket is at an end. */
  double mlo = fabs(e0 * lo + d1), mhi = fabs(e0 * hi + d1), m = mlo > mhi ? mlo : mhi;
  double c_step = 21.0 * m, c_m = (0.3 / ROOT_TOL) * m * m, c_k = (1.23 / ROOT_TOL) * k[0];
  double t = start > lo && start < hi ? start : 0.5 * (lo + hi);
  for (int it = 0; it < 100; it++) {
    double f = ((k[0] * t + k[1]) * t + k[2]) * t + k[3];
    double df = (d0 * t + d1) * t + k[2];
    double f2 = e0 * t + d1;
    if (f < 0.0)
      lo = t;
    else if (f > 0.0)
      hi = t;
    else
      return t;
    double den = 2.0 * df * df - f * f2;
    double step = den > 0.0 ? 2.0 * f * df / den : 0.0, next = t - step, as = fabs(step);
    if (next > lo && next < hi) {
      if (it > 0 && c_step * as <= df && as * as * as * (c_m + c_k * df) <= df * df) return next;
      /* flat (f' vanishing at the root): stop where the steps do */
      if (as <= 1e-16 * (1.0 + t)) return next;
    } else {
      next = 0.5 * (lo + hi);
      if (fabs(next - t) <= 1e-16 * (1.0 + t) || hi - lo <= 1e-16) return next;
    }
    t = next;
  }
  return t;
}

/* B(t) - q = t^2 b + 2t a + m (a = p1 - p0, b = p2 - 2 p1 + p0,
 * m = p0 - q); the derivative of |B(t) - q|^2 / 2 is the cubic
 * f(t) = |b|^2 t^3 + 3 a.b t^2 + (2|a|^2 + m.b) t + m.a, coefficients k. */
static inline __attribute__((always_inline)) void cubic_setup(const double p[3][2], const double q[2], double a[2],
                                                              double b[2], double m[2], double k[4]) {
  a[0] = p[1][0] - p[0][0], a[1] = p[1][1] - p[0][1];
  b[0] = p[2][0] - 2.0 * p[1][0] + p[0][0], b[1] = p[2][1] - 2.0 * p[1][1] + p[0][1];
  m[0] = p[0][0] - q[0], m[1] = p[0][1] - q[1];
  k[0] = ch_dot2(b, b), k[1] = 3.0 * ch_dot2(a, b), k[2] = 2.0 * ch_dot2(a, a) + ch_dot2(m, b), k[3] = ch_dot2(m, a);
}

/* |B(t) - q|^2 from the same differences: m + t (2a + t b) keeps the
 * distance's digits where the points' coordinates are much larger (within
 * 0.7 of the coordinates' rounding of a long double reference on the
 * recorded queries, where ch_bezier_eval's point was 1.8). */
static inline double dist2_from(const double a[2], const double b[2], const double m[2], double t) {
  double x = m[0] + t * (2.0 * a[0] + t * b[0]), y = m[1] + t * (2.0 * a[1] + t * b[1]);
  return x * x + y * y;
}

/* ch_bezier_closest where f' has real roots, so that f may turn in
 * [0, 1]: cut there into monotone pieces, each a candidate where f goes
 * from negative to positive. Out of line, so that the common case keeps
 * its values in registers. */
static __attribute__((noinline)) double closest_turning(const double p[3][2], const double q[2], double *t_out) {
  double a[2], b[2], m[2], k[4];
  cubic_setup(p, q, a, b, m, k);
  double f0 = k[3], f1 = k[0] + k[1] + k[2] + k[3];
  double crit[2];
  int ncrit = quadratic_roots_01(3.0 * k[0], 2.0 * k[1], k[2], crit);

  /* The ends are candidates only where the distance does not fall going
   * in (f(0) >= 0, f(1) <= 0); the closest point is one of them or an
   * interior minimum. */
  double best_t = 0.0, best = INFINITY;
  if (f0 >= 0.0) best = ch_dot2(m, m);
  if (f1 <= 0.0) {
    double e[2] = {p[2][0] - q[0], p[2][1] - q[1]}, d1 = ch_dot2(e, e);
    if (d1 < best) {
      best = d1;
      best_t = 1.0;
    }
  }
  double lo = 0.0, flo = f0;
  for (int i = 0; i <= ncrit; i++) {
    double hi = i < ncrit ? crit[i] : 1.0;
    double fhi = i < ncrit ? ((k[0] * hi + k[1]) * hi + k[2]) * hi + k[3] : f1;
    /* A minimum of the distance is where f goes from negative to
     * positive. f' vanishes at a cut, so Halley starts from Newton's step
     * at the end where f' is larger (3.0 evaluations a root on glyphs'
     * queries, 3.9 from the chord of f's graph). */
    if (flo <= 0.0 && fhi >= 0.0 && !(flo == 0.0 && fhi == 0.0)) {
      double t;
      if (flo == 0.0) {
        t = lo;
      } else if (fhi == 0.0) {
        t = hi;
      } else {
        double dlo = (3.0 * k[0] * lo + 2.0 * k[1]) * lo + k[2], dhi = (3.0 * k[0] * hi + 2.0 * k[1]) * hi + k[2];
        t = increasing_root(k, lo, hi, dlo > dhi ? lo - flo / dlo : hi - fhi / dhi);
      }
      double d = dist2_from(a, b, m, t);
      if (d < best) {
        best = d;
        best_t = t;
      }
    }
    lo = hi;
    flo = fhi;
  }
  if (t_out) *t_out = best_t;
  return best;
}

/* Whether f keeps the sign of f(0) on [0, 1] (and does not end at 0 when
 * f(0) >= 0), so that the closest point is the end the distance falls
 * towards, without the roots of f': f's Bernstein coefficients on
 * [0, 1/2] and on [1/2, 1] (de Casteljau at 1/2) are all of that sign, and
 * the graph lies in their convex hulls (e.g. Farin, Curves and Surfaces
 * for CAGD). Where f dips by rounding only, the distance there is the
 * end's to rounding. In 15% of the queries recorded on tablet + glyphs f
 * turns without changing sign; this finds 94% of them. */
static int keeps_sign(const double k[4], double f0, double f1) {
  double b1 = f0 + k[2] * (1.0 / 3.0), b2 = f1 - (3.0 * k[0] + 2.0 * k[1] + k[2]) * (1.0 / 3.0);
  double l1 = 0.5 * (f0 + b1), mid = 0.5 * (b1 + b2), r2 = 0.5 * (b2 + f1);
  double l2 = 0.5 * (l1 + mid), r1 = 0.5 * (mid + r2);
  if (f0 >= 0.0) return f1 > 0.0 && l1 >= 0.0 && l2 >= 0.0 && r1 >= 0.0 && r2 >= 0.0;
  return f1 <= 0.0 && l1 <= 0.0 && l2 <= 0.0 && r1 <= 0.0 && r2 <= 0.0;
}

double ch_bezier_closest(const double p[3][2], int is_line, const double q[2], double *t_out) {
  if (is_line) {
    double d[2] = {p[2][0] - p[0][0], p[2][1] - p[0][1]};
    double w[2] = {q[0] - p[0][0], q[1] - p[0][1]};
    double len2 = ch_dot2(d, d);
    double t = len2 > 0.0 ? ch_dot2(w, d) / len2 : 0.0;
    t = t < 0.0 ? 0.0 : t > 1.0 ? 1.0 : t;
    /* Evaluate on the line itself, exact for the straight segment. */
    double x = p[0][0] + t * d[0] - q[0], y = p[0][1] + t * d[1] - q[1];
    if (t_out) *t_out = t;
    return x * x + y * y;
  }
  double a[2], b[2], m[2], k[4];
  cubic_setup(p, q, a, b, m, k);
  /* Mostly f' = 3 k0 t^2 + 2 k1 t + k2 has no real root (98% of the
   * queries recorded on ornament, 75% of the quadratic ones on glyphs; the
   * discriminant has the sign, to the bit, of the one quadratic_roots_01
   * would compute): f increases, and the closest point is the end where
   * the distance rises going in, or else f's one root. */
  double f0 = k[3], f1 = k[0] + k[1] + k[2] + k[3], t, d2;
  if (k[1] * k[1] - 3.0 * k[0] * k[2] >= 0.0 && !keeps_sign(k, f0, f1)) return closest_turning(p, q, t_out);
  if (f0 >= 0.0) {
    t = 0.0;
    d2 = ch_dot2(m, m);
  } else if (f1 <= 0.0) {
    double e[2] = {p[2][0] - q[0], p[2][1] - q[1]};
    t = 1.0;
    d2 = ch_dot2(e, e);
  } else {
    /* Halley starts where the chord of f's graph crosses 0: on the short,
     * gently bent segments of most queries f is nearly linear. */
    t = increasing_root(k, 0.0, 1.0, f0 / (f0 - f1));
    d2 = dist2_from(a, b, m, t);
  }
  if (t_out) *t_out = t;
  return d2;
}

int ch_cubic_to_quads(const double c[4][2], double tol, ch_quad_sink sink, void *user) {
  double third[2] = {c[3][0] - 3.0 * c[2][0] + 3.0 * c[1][0] - c[0][0],
                     c[3][1] - 3.0 * c[2][1] + 3.0 * c[1][1] - c[0][1]};
  double err = sqrt(3.0) / 36.0 * sqrt(ch_dot2(third, third));
  int n = 1;
  if (err > tol) {
    double pieces = ceil(cbrt(err / tol));
    n = pieces > 4096.0 ? 4096 : (int)pieces;
  }
  for (int i = 0; i < n; i++) {
    double t0 = (double)i / n, t1 = (double)(i + 1) / n;
    /* The sub-cubic on [t0, t1] by blossoming: control points are the
     * blossom values b(t0,t0,t0), b(t0,t0,t1), b(t0,t1,t1), b(t1,t1,t1). */
    double sub[4][2];
    for (int j = 0; j < 4; j++) {
      double u[3] = {j < 3 ? t0 : t1, j < 2 ? t0 : t1, j < 1 ? t0 : t1};
      for (int dim = 0; dim < 2; dim++) {
        double l0 = c[0][dim], l1 = c[1][dim], l2 = c[2][dim], l3 = c[3][dim];
        /* de Casteljau with different parameters per level = blossom. */
        double a0 = l0 + u[0] * (l1 - l0), a1 = l1 + u[0] * (l2 - l1), a2 = l2 + u[0] * (l3 - l2);
        double b0 = a0 + u[1] * (a1 - a0), b1 = a1 + u[1] * (a2 - a1);
        sub[j][dim] = b0 + u[2] * (b1 - b0);
      }
    }
    /* Keep the end points bit-exact so consecutive pieces join exactly. */
    if (i == 0) { sub[0][0] = c[0][0]; sub[0][1] = c[0][1]; }
    if (i == n - 1) { sub[3][0] = c[3][0]; sub[3][1] = c[3][1]; }
    double q[3][2] = {
        {sub[0][0], sub[0][1]},
        {(3.0 * (sub[1][0] + sub[2][0]) - sub[0][0] - sub[3][0]) * 0.25,
         (3.0 * (sub[1][1] + sub[2][1]) - sub[0][1] - sub[3][1]) * 0.25},
        {sub[3][0], sub[3][1]}};
    int r = sink(user, q);
    if (r) return r;
  }
  return 0;
}

static void apply_affine(const double m[6], double x, double y, double out[2]) {
  out[0] = m[0] * x + m[2] * y + m[4];
  out[1] = m[1] * x + m[3] * y + m[5];
}

int ch_arc_to_quads(double a0, double sweep, const double m[6], double tol,
                    ch_quad_sink sink, void *user) {
  /* A quadratic through the arc's ends with its control point where the end
   * tangents meet lies outside the unit circle by at most
   * (1 - cos(h))^2 / (2 cos h), h = half the piece's angle (at its middle).
   * The affine map stretches distances by at most its largest singular
   * value. */
  double sa = m[0] * m[0] + m[1] * m[1], sb = m[2] * m[2] + m[3] * m[3];
  double sc = m[0] * m[2] + m[1] * m[3];
  double smax = sqrt(0.5 * (sa + sb) + sqrt(0.25 * (sa - sb) * (sa - sb) + sc * sc));
  /* (1 - cos h)^2 / (2 cos h) ~ h^4 / 8: start there, then make sure. */
  double h0 = pow(8.0 * tol / (smax > 0.0 ? smax : 1.0), 0.25);
  if (h0 > CH_PI / 8.0) h0 = CH_PI / 8.0;
  double pieces = ceil(fabs(sweep) / (2.0 * h0));
  int n = pieces < 1.0 ? 1 : pieces > 65536.0 ? 65536 : (int)pieces;
  for (; n < 65536; n++) {
    double h = 0.5 * fabs(sweep) / n;
    double ch = cos(h);
    if ((1.0 - ch) * (1.0 - ch) / (2.0 * ch) * smax <= tol) break;
  }
  double step = sweep / n;
  double prev_end[2] = {0.0, 0.0};
  for (int i = 0; i < n; i++) {
    double t0 = a0 + step * i, t1 = a0 + step * (i + 1), tm = 0.5 * (t0 + t1);
    double k = 1.0 / cos(0.5 * step);
    double q[3][2];
    if (i == 0)
      apply_affine(m, cos(t0), sin(t0), q[0]);
    else {
      q[0][0] = prev_end[0];
      q[0][1] = prev_end[1];
    }
    apply_affine(m, k * cos(tm), k * sin(tm), q[1]);
    apply_affine(m, cos(t1), sin(t1), q[2]);
    prev_end[0] = q[2][0];
    prev_end[1] = q[2][1];
    int r = sink(user, q);
    if (r) return r;
  }
  return 0;
}

double ch_bezier_length(const double p[3][2]) {
  /* Nodes and weights of 8 Gauss-Legendre pairs on [-1, 1]. */
  static const double x[8] = {0.0950125098376374, 0.2816035507792589, 0.4580167776572274, 0.6178762444026438,
                              0.7554044083550030, 0.8656312023878318, 0.9445750230732326, 0.9894009349916499};
  static const double w[8] = {0.1894506104550685, 0.1826034150449236, 0.1691565193950025, 0.1495959888165767,
                              0.1246289712555339, 0.0951585116824928, 0.0622535239386479, 0.0271524594117541};
  double a[2] = {2.0 * (p[1][0] - p[0][0]), 2.0 * (p[1][1] - p[0][1])};
  double b[2] = {2.0 * (p[2][0] - 2.0 * p[1][0] + p[0][0]), 2.0 * (p[2][1] - 2.0 * p[1][1] + p[0][1])};
  double sum = 0.0;
  for (int i = 0; i < 8; i++)
    for (int sgn = -1; sgn <= 1; sgn += 2) {
      double t = 0.5 + 0.5 * sgn * x[i];
      sum += w[i] * hypot(a[0] + b[0] * t, a[1] + b[1] * t);
    }
  return 0.5 * sum;
}

/* ---- crossings of two quadratics ---- */

/* Parameters this close to a segment's end are its end; hits closer than
 * this (UV) are not a crossing. */
#define CROSS_AT_END 1e-9
#define CROSS_SAME_POINT 1e-9

static void split_half(const double p[3][2], double a[3][2], double b[3][2]) {
  for (int k = 0; k < 2; k++) {
    double m01 = 0.5 * (p[0][k] + p[1][k]), m12 = 0.5 * (p[1][k] + p[2][k]), m = 0.5 * (m01 + m12);
    a[0][k] = p[0][k], a[1][k] = m01, a[2][k] = m;
    b[0][k] = m, b[1][k] = m12, b[2][k] = p[2][k];
  }
}

static void derivative(const double p[3][2], double t, double d[2]) {
  for (int k = 0; k < 2; k++) d[k] = 2.0 * ((1.0 - t) * (p[1][k] - p[0][k]) + t * (p[2][k] - p[1][k]));
}

typedef struct hits {
  double s[CH_BEZIER_MAX_CROSSINGS], t[CH_BEZIER_MAX_CROSSINGS];
  int n;
} hits;

/* Newton on A(s) = B(t) from (s, t); keeps converged roots inside both. */
static void refine_hit(const double A[3][2], const double B[3][2], double s, double t, hits *h) {
  for (int it = 0; it < 30; it++) {
    double pa[2], pb[2], da[2], db[2];
    ch_bezier_eval(A, s, pa);
    ch_bezier_eval(B, t, pb);
    derivative(A, s, da);
    derivative(B, t, db);
    double f[2] = {pa[0] - pb[0], pa[1] - pb[1]};
    double det = -da[0] * db[1] + db[0] * da[1];
    if (!(fabs(det) > 1e-300)) return; /* tangent or parallel: no transversal crossing */
    double ds = (-f[0] * db[1] + db[0] * f[1]) / det, dt = (da[0] * f[1] - da[1] * f[0]) / det;
    s -= ds, t -= dt;
    if (fabs(ds) < 1e-15 && fabs(dt) < 1e-15) break;
  }
  double pa[2], pb[2];
  if (!(s >= -CROSS_AT_END && s <= 1.0 + CROSS_AT_END && t >= -CROSS_AT_END && t <= 1.0 + CROSS_AT_END)) return;
  s = ch_clamp(s, 0.0, 1.0), t = ch_clamp(t, 0.0, 1.0);
  ch_bezier_eval(A, s, pa);
  ch_bezier_eval(B, t, pb);
  if (hypot(pa[0] - pb[0], pa[1] - pb[1]) > CROSS_SAME_POINT) return;
  for (int k = 0; k < h->n; k++)
    if (fabs(h->s[k] - s) < 1e-7 && fabs(h->t[k] - t) < 1e-7) return;
  if (h->n < CH_BEZIER_MAX_CROSSINGS) h->s[h->n] = s, h->t[h->n] = t, h->n++;
}

static void crossings_rec(const double A[3][2], const double B[3][2], const double a[3][2], double a0, double a1,
                          const double b[3][2], double b0, double b1, int depth, hits *h) {
  double ba[4], bb[4];
  ch_bezier_box(a, ba);
  ch_bezier_box(b, bb);
  const double pad = 1e-12;
  if (ba[0] > bb[2] + pad || bb[0] > ba[2] + pad || ba[1] > bb[3] + pad || bb[1] > ba[3] + pad) return;
  double sa = ba[2] - ba[0] > ba[3] - ba[1] ? ba[2] - ba[0] : ba[3] - ba[1];
  double sb = bb[2] - bb[0] > bb[3] - bb[1] ? bb[2] - bb[0] : bb[3] - bb[1];
  if (depth >= 24 || (sa < 1e-4 && sb < 1e-4)) {
    refine_hit(A, B, 0.5 * (a0 + a1), 0.5 * (b0 + b1), h);
    return;
  }
  if (sa >= sb) {
    double l[3][2], r[3][2], m = 0.5 * (a0 + a1);
    split_half(a, l, r);
    crossings_rec(A, B, l, a0, m, b, b0, b1, depth + 1, h);
    crossings_rec(A, B, r, m, a1, b, b0, b1, depth + 1, h);
  } else {
    double l[3][2], r[3][2], m = 0.5 * (b0 + b1);
    split_half(b, l, r);
    crossings_rec(A, B, a, a0, a1, l, b0, m, depth + 1, h);
    crossings_rec(A, B, a, a0, a1, r, m, b1, depth + 1, h);
  }
}

int ch_bezier_crossings(const double a[3][2], const double b[3][2], double s[CH_BEZIER_MAX_CROSSINGS],
                        double t[CH_BEZIER_MAX_CROSSINGS]) {
  hits h = {.n = 0};
  crossings_rec(a, b, a, 0.0, 1.0, b, 0.0, 1.0, 0, &h);
  for (int k = 0; k < h.n; k++) s[k] = h.s[k], t[k] = h.t[k];
  return h.n;
}
