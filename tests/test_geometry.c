/* Exact curve geometry against independent brute force: closest points on
 * lines and quadratics, signed distance with joints and rounded caps, cubic
 * and arc splitting, and the grid-accelerated groove field against a scan of
 * every curve. */
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bezier_reference.h"
#include "ch_bezier.h"
#include "ch_curves.h"
#include "ch_groove.h"
#include "ch_segtree.h"
#include "ch_test.h"

/* Independent closest point: 4096 samples, then bisection on the sign of
 * the derivative of the squared distance around the best sample (both
 * neighbours' intervals). Shares no code with ch_bezier. */
static void eval_q(const double p[3][2], double t, double out[2]) {
  double s = 1 - t;
  for (int k = 0; k < 2; k++) out[k] = s * s * p[0][k] + 2 * s * t * p[1][k] + t * t * p[2][k];
}
static double brute_d2(const double p[3][2], const double q[2], double *t_best) {
  enum { N = 4096 };
  double best = INFINITY;
  int bi = 0;
  for (int i = 0; i <= N; i++) {
    double x[2];
    eval_q(p, (double)i / N, x);
    double d = (x[0] - q[0]) * (x[0] - q[0]) + (x[1] - q[1]) * (x[1] - q[1]);
    if (d < best) best = d, bi = i;
  }
  double tb = (double)bi / N;
  for (int side = -1; side <= 1; side += 2) {
    double lo = (double)bi / N, hi = (double)(bi + side) / N;
    if (hi < 0 || hi > 1) continue;
    if (lo > hi) { double tmp = lo; lo = hi; hi = tmp; }
    for (int it = 0; it < 200; it++) {
      double m = 0.5 * (lo + hi), x[2];
      eval_q(p, m, x);
      double s = 1 - m;
      double d[2] = {2 * s * (p[1][0] - p[0][0]) + 2 * m * (p[2][0] - p[1][0]),
                     2 * s * (p[1][1] - p[0][1]) + 2 * m * (p[2][1] - p[1][1])};
      double g = (x[0] - q[0]) * d[0] + (x[1] - q[1]) * d[1];
      if (g > 0) hi = m; else lo = m;
    }
    double x[2];
    eval_q(p, 0.5 * (lo + hi), x);
    double dd = (x[0] - q[0]) * (x[0] - q[0]) + (x[1] - q[1]) * (x[1] - q[1]);
    if (dd < best) best = dd, tb = 0.5 * (lo + hi);
  }
  *t_best = tb;
  return best;
}

static void random_quad(double p[3][2], int kind) {
  for (int i = 0; i < 3; i++) p[i][0] = ch_test_rnd(), p[i][1] = ch_test_rnd();
  switch (kind) {
  case 1: /* nearly straight: control point 1e-9 off the chord's middle */
    p[1][0] = 0.5 * (p[0][0] + p[2][0]) + 1e-9 * (ch_test_rnd() - 0.5);
    p[1][1] = 0.5 * (p[0][1] + p[2][1]) + 1e-9 * (ch_test_rnd() - 0.5);
    break;
  case 2: /* control point on an end */
    memcpy(p[1], p[ch_test_rnd() < 0.5 ? 0 : 2], sizeof p[1]);
    break;
  case 3: /* folded: collinear, control point beyond the end */
    p[1][0] = p[0][0] + 1.7 * (p[2][0] - p[0][0]);
    p[1][1] = p[0][1] + 1.7 * (p[2][1] - p[0][1]);
    break;
  case 4: /* closed loop: ends coincide */
    memcpy(p[2], p[0], sizeof p[2]);
    break;
  case 5: /* tiny segment */
    for (int i = 1; i < 3; i++) p[i][0] = p[0][0] + 1e-7 * ch_test_rnd(), p[i][1] = p[0][1] + 1e-7 * ch_test_rnd();
    break;
  default: break;
  }
}

static void test_closest_vs_brute_force(void) {
  double max_err = 0.0;
  int n = 100000;
  for (int i = 0; i < n; i++) {
    double p[3][2], q[2] = {ch_test_rnd() * 1.4 - 0.2, ch_test_rnd() * 1.4 - 0.2};
    random_quad(p, i % 6);
    double t, tb;
    double d = sqrt(ch_bezier_closest(p, 0, q, &t));
    double db = sqrt(brute_d2(p, q, &tb));
    /* The returned t must give the returned distance. */
    double x[2];
    eval_q(p, t, x);
    double dt = hypot(x[0] - q[0], x[1] - q[1]);
    double err = fmax(fabs(d - db), fabs(dt - d));
    if (d > db + 1e-9) CHECK_MSG(0, "point %d kind %d: %.17g vs brute %.17g", i, i % 6, d, db);
    if (err > max_err) max_err = err;
  }
  fprintf(stderr, "  quadratic closest point: max |d - brute| over %d points = %.3g\n", n, max_err);
  CHECK(max_err <= 1e-9);
}

/* A second, stricter reference for the closest point on a quadratic, in
 * long double and sharing nothing with ch_bezier: f(t) = (B(t) - q).B'(t)
 * from the control points; [0, 1] cut at 64 even steps and at the roots
 * of f' (so that f is monotone between cuts); every cut pair where f goes
 * from <= 0 to >= 0 bisected to the end of long double; the ends where
 * they are local minima.
 * g2 is the next best local minimum's distance squared (is the minimum
 * unique?), cond f' at the root over |B'/2|^2 (0 at the centre of
 * curvature, where t is only known to about the cube root of the
 * rounding). */
/* ch_bezier_closest against ref_closest_ld (bezier_reference.h) on random and adversarial
 * quadratics (nearly straight, p1 far away as at a cusp, p0 == p2,
 * tiny, p1 off the chord's middle along it) and queries (near the curve,
 * on it, at and near the centre of curvature, far away, anywhere):
 * never another minimum than the global one, the distance to within the
 * coordinates' rounding, t to within what that rounding allows where the
 * minimum is unique and not flat, and t giving the distance returned. */
static void test_closest_vs_long_double(void) {
  int n = 120000, misses = 0, flat = 0;
  double max_derr = 0.0, max_perr = 0.0, max_self = 0.0;
  for (int i = 0; i < n; i++) {
    double p[3][2];
    for (int j = 0; j < 3; j++) p[j][0] = ch_test_rnd(), p[j][1] = ch_test_rnd();
    switch (i % 6) {
      case 1: /* nearly straight */
        for (int k = 0; k < 2; k++) p[1][k] = 0.5 * (p[0][k] + p[2][k]) + 1e-9 * (ch_test_rnd() - 0.5);
        break;
      case 2: /* cusp-like: p1 far away */
        for (int k = 0; k < 2; k++) p[1][k] = p[0][k] + 1e3 * (ch_test_rnd() - 0.5);
        break;
      case 3:
        memcpy(p[2], p[0], sizeof p[2]);
        break; /* folded onto itself */
      case 4:  /* tiny */
        for (int j = 1; j < 3; j++)
          for (int k = 0; k < 2; k++) p[j][k] = p[0][k] + 1e-6 * ch_test_rnd();
        break;
      case 5: /* straight but unevenly parametrised */
        for (int k = 0; k < 2; k++) p[1][k] = p[0][k] + (0.05 + 0.9 * ch_test_rnd()) * (p[2][k] - p[0][k]);
        break;
      default:
        break;
    }
    double t0 = ch_test_rnd(), s0 = 1.0 - t0, x0[2], d0[2], q[2];
    for (int k = 0; k < 2; k++) {
      x0[k] = s0 * s0 * p[0][k] + 2 * s0 * t0 * p[1][k] + t0 * t0 * p[2][k];
      d0[k] = s0 * (p[1][k] - p[0][k]) + t0 * (p[2][k] - p[1][k]);
    }
    double bb[2] = {p[2][0] - 2 * p[1][0] + p[0][0], p[2][1] - 2 * p[1][1] + p[0][1]};
    double cross = d0[0] * bb[1] - d0[1] * bb[0], r = cross != 0.0 ? (d0[0] * d0[0] + d0[1] * d0[1]) / cross : 0.0;
    switch ((i / 6) % 6) {
      case 0:
        q[0] = x0[0] + 0.02 * (ch_test_rnd() - 0.5), q[1] = x0[1] + 0.02 * (ch_test_rnd() - 0.5);
        break;
      case 1:
        q[0] = x0[0], q[1] = x0[1];
        break;
      case 2:
        q[0] = x0[0] - d0[1] * r, q[1] = x0[1] + d0[0] * r;
        break; /* the centre of curvature */
      case 3:  /* near it */
        q[0] = x0[0] - d0[1] * r * (1.0 + 1e-3 * (ch_test_rnd() - 0.5));
        q[1] = x0[1] + d0[0] * r * (1.0 + 1e-3 * (ch_test_rnd() - 0.5));
        break;
      case 4:
        q[0] = 200.0 * (ch_test_rnd() - 0.5), q[1] = 200.0 * (ch_test_rnd() - 0.5);
        break;
      default:
        q[0] = 1.4 * ch_test_rnd() - 0.2, q[1] = 1.4 * ch_test_rnd() - 0.2;
        break;
    }
    double t, d2 = ch_bezier_closest(p, 0, q, &t);
    ref_closest_t ref = ref_closest_ld(p, 0, q);
    double size = 0.0, big = fmax(fabs(q[0]), fabs(q[1]));
    for (int j = 0; j < 3; j++) {
      size = fmax(size, hypot(p[j][0] - p[0][0], p[j][1] - p[0][1]));
      big = fmax(big, fmax(fabs(p[j][0]), fabs(p[j][1])));
    }
    double dist = sqrt((double)ref.g1), u = DBL_EPSILON * big; /* the coordinates' rounding */
    double seg = fmax(size, DBL_MIN);
    size = fmax(size, dist);
    CHECK_MSG(t >= 0.0 && t <= 1.0, "point %d: t %.17g", i, t);
    /* t gives the distance returned */
    double self = fabs(sqrt((double)ref_g(p, q, t)) - sqrt(d2)) / u;
    max_self = fmax(max_self, self);
    double derr = (sqrt(d2) - dist) / u;
    if (derr > 1e-12 * size / u + 64.0) {
      /* at the reference's point: a flat minimum's imprecision (q at a
       * folded segment's turning point), else another minimum */
      ld x[2], xr[2], dummy[2];
      ref_point(p, q, t, x, dummy);
      ref_point(p, q, ref.t, xr, dummy);
      if (hypotl(x[0] - xr[0], x[1] - xr[1]) < 1e-4L * size) {
        flat++;
        CHECK_MSG(derr * u <= 1e-9 * size, "point %d: flat minimum %.3g off", i, derr * u);
      } else {
        misses++;
        CHECK_MSG(0, "point %d kind %d/%d: d2 %.17g at t %.17g, reference %.17Lg at %.17Lg", i, i % 6, (i / 6) % 6, d2,
                  t, ref.g1, ref.t);
      }
    } else {
      max_derr = fmax(max_derr, fabs(derr));
    }
    /* t where it is well defined (the minimum unique, f' at it not
     * small): the point it gives within what the rounding of the
     * coordinates allows, which is about u / (f' / |B'/2|^2), u times the
     * distance over the size where the rounding turns the segment. */
    if (ref.g2 - ref.g1 > 1e-9L * size * size && ref.cond > 1e-6L) {
      ld x[2], xr[2], dummy[2];
      ref_point(p, q, t, x, dummy);
      ref_point(p, q, ref.t, xr, dummy);
      double perr = (double)hypotl(x[0] - xr[0], x[1] - xr[1]) * fmin((double)ref.cond, 1.0) / (u * (1.0 + dist / seg));
      max_perr = fmax(max_perr, perr);
      CHECK_MSG(perr <= 1e4, "point %d kind %d/%d: t %.17g, reference %.17Lg", i, i % 6, (i / 6) % 6, t, ref.t);
    }
  }
  fprintf(stderr,
          "  quadratic closest point against long double: %d misses, %d flat minima off by more than 64 u; max"
          " |distance error| %.3g u, point at t off by %.3g u (scaled), |B(t) - q| to the distance returned %.3g u\n",
          misses, flat, max_derr, max_perr, max_self);
  CHECK(misses == 0);
  CHECK(max_self <= 64.0);
}

/* Arc length against closed forms: a line, and the parabola y = x^2 on
 * [0, 1] (control points (0,0) (1/2,0) (1,1)): sqrt(5)/2 + asinh(2)/4. */
static void test_length(void) {
  const double line[3][2] = {{0, 0}, {1.5, 2}, {3, 4}};
  CHECK(fabs(ch_bezier_length(line) - 5.0) <= 1e-12);
  const double parabola[3][2] = {{0, 0}, {0.5, 0}, {1, 1}};
  double want = sqrt(5.0) / 2.0 + asinh(2.0) / 4.0;
  CHECK_MSG(fabs(ch_bezier_length(parabola) - want) <= 1e-9 * want, "parabola length %.12g, want %.12g",
            ch_bezier_length(parabola), want);
  const double point[3][2] = {{0.3, 0.3}, {0.3, 0.3}, {0.3, 0.3}};
  CHECK(ch_bezier_length(point) == 0.0);
}

static void test_line_closest(void) {
  double max_err = 0.0;
  for (int i = 0; i < 100000; i++) {
    double p[3][2], q[2] = {ch_test_rnd(), ch_test_rnd()}, t, tb;
    random_quad(p, 0);
    p[1][0] = 0.5 * (p[0][0] + p[2][0]);
    p[1][1] = 0.5 * (p[0][1] + p[2][1]);
    double d = sqrt(ch_bezier_closest(p, 1, q, &t));
    double db = sqrt(brute_d2(p, q, &tb));
    if (fabs(d - db) > max_err) max_err = fabs(d - db);
  }
  fprintf(stderr, "  line closest point: max |d - brute| = %.3g\n", max_err);
  CHECK(max_err <= 1e-9);
}

/* Builds a one-curve set from segments given as polylines/quads. */
static ch_curve_set make_set(const double (*pts)[3][2], int n, int closed, int is_line) {
  static ch_curve curve;
  static ch_segment segs[64];
  static ch_subpath sub;
  memset(&curve, 0, sizeof curve);
  for (int i = 0; i < n; i++) {
    memcpy(segs[i].p, pts[i], sizeof segs[i].p);
    segs[i].curve = 0;
    segs[i].is_line = is_line;
    segs[i].prev = i > 0 ? i - 1 : closed ? n - 1 : -1;
    segs[i].next = i + 1 < n ? i + 1 : closed ? 0 : -1;
  }
  curve.num_segments = n;
  curve.num_subpaths = 1;
  curve.width = 0.1;
  curve.depth = 0.01;
  sub.num_segments = n;
  sub.closed = closed;
  ch_curve_set set = {.num_curves = 1, .curves = &curve, .num_segments = n, .segments = segs,
                      .num_subpaths = 1, .subpaths = &sub};
  return set;
}

static void test_signed_distance_and_caps(void) {
  /* A straight path from (0.2, 0.5) to (0.8, 0.5), heading +u: v up is left. */
  double line[1][3][2] = {{{0.2, 0.5}, {0.5, 0.5}, {0.8, 0.5}}};
  ch_curve_set set = make_set(line, 1, 0, 1);
  ch_curve_point cp;
  ch_curve_closest(&set, 0, (double[2]){0.5, 0.6}, &cp);
  CHECK_NEAR(cp.signed_distance, 0.1, 1e-15);
  ch_curve_closest(&set, 0, (double[2]){0.5, 0.47}, &cp);
  CHECK_NEAR(cp.signed_distance, -0.03, 1e-15);
  /* Rounded cap beyond the end: distance to the end point, sign from the
   * tangent line there. */
  ch_curve_closest(&set, 0, (double[2]){0.9, 0.55}, &cp);
  CHECK_NEAR(cp.signed_distance, hypot(0.1, 0.05), 1e-15);
  ch_curve_closest(&set, 0, (double[2]){0.9, 0.45}, &cp);
  CHECK_NEAR(cp.signed_distance, -hypot(0.1, 0.05), 1e-15);
  ch_curve_closest(&set, 0, (double[2]){0.1, 0.46}, &cp);
  CHECK_NEAR(cp.signed_distance, -hypot(0.1, 0.04), 1e-15);
  /* On the tangent line beyond the end: counted as left. */
  ch_curve_closest(&set, 0, (double[2]){0.95, 0.5}, &cp);
  CHECK_NEAR(cp.signed_distance, 0.15, 1e-15);

  /* A left turn: east then north, corner at (0.5, 0.5). The outer wedge
   * (south-east of the corner) is on the right; the inside on the left. */
  double turn[2][3][2] = {{{0.2, 0.5}, {0.35, 0.5}, {0.5, 0.5}}, {{0.5, 0.5}, {0.5, 0.65}, {0.5, 0.8}}};
  set = make_set(turn, 2, 0, 1);
  ch_curve_closest(&set, 0, (double[2]){0.6, 0.4}, &cp);
  CHECK_NEAR(cp.signed_distance, -hypot(0.1, 0.1), 1e-15);
  ch_curve_closest(&set, 0, (double[2]){0.45, 0.55}, &cp);
  CHECK_NEAR(cp.signed_distance, 0.05, 1e-15);
  /* A right turn: east then south; the outer wedge (north-east) is left. */
  double rturn[2][3][2] = {{{0.2, 0.5}, {0.35, 0.5}, {0.5, 0.5}}, {{0.5, 0.5}, {0.5, 0.35}, {0.5, 0.2}}};
  set = make_set(rturn, 2, 0, 1);
  ch_curve_closest(&set, 0, (double[2]){0.6, 0.6}, &cp);
  CHECK_NEAR(cp.signed_distance, hypot(0.1, 0.1), 1e-15);
  ch_curve_closest(&set, 0, (double[2]){0.45, 0.45}, &cp);
  CHECK_NEAR(cp.signed_distance, -0.05, 1e-15);

  /* A turn sharper than a right angle (170 degrees to the right): the
   * joint's region reaches round to the right of the incoming tangent, yet
   * all of it is on the left (outside the narrow inner sector). */
  {
    double a0 = -65.0 * 3.14159265358979 / 180, a1 = 125.0 * 3.14159265358979 / 180;
    double c[2] = {0.5, 0.5};
    double sharp[2][3][2] = {{{c[0] - 0.3 * cos(a0), c[1] - 0.3 * sin(a0)}, {0}, {c[0], c[1]}},
                             {{c[0], c[1]}, {0}, {c[0] + 0.3 * cos(a1), c[1] + 0.3 * sin(a1)}}};
    for (int k = 0; k < 2; k++)
      for (int j = 0; j < 2; j++) sharp[k][1][j] = 0.5 * (sharp[k][0][j] + sharp[k][2][j]);
    set = make_set(sharp, 2, 0, 1);
    double ang = -89.0 * 3.14159265358979 / 180;
    ch_curve_closest(&set, 0, (double[2]){0.5 + 0.01 * cos(ang), 0.5 + 0.01 * sin(ang)}, &cp);
    CHECK_NEAR(cp.signed_distance, 0.01, 1e-12);
    /* Inside the 10-degree inner sector: right. */
    ang = 120.0 * 3.14159265358979 / 180;
    ch_curve_closest(&set, 0, (double[2]){0.5 + 0.01 * cos(ang), 0.5 + 0.01 * sin(ang)}, &cp);
    CHECK(cp.signed_distance < 0);
  }

  /* A closed counter-clockwise square: the inside is on the left. */
  double sq[4][3][2] = {{{0.2, 0.2}, {0.5, 0.2}, {0.8, 0.2}}, {{0.8, 0.2}, {0.8, 0.5}, {0.8, 0.8}},
                        {{0.8, 0.8}, {0.5, 0.8}, {0.2, 0.8}}, {{0.2, 0.8}, {0.2, 0.5}, {0.2, 0.2}}};
  set = make_set(sq, 4, 1, 1);
  int inside_ok = 1, outside_ok = 1;
  for (int i = 0; i < 2000; i++) {
    double q[2] = {ch_test_rnd(), ch_test_rnd()};
    ch_curve_closest(&set, 0, q, &cp);
    int inside = q[0] > 0.2 && q[0] < 0.8 && q[1] > 0.2 && q[1] < 0.8;
    if (inside && cp.signed_distance <= 0) inside_ok = 0;
    if (!inside && cp.signed_distance > 0) outside_ok = 0;
  }
  CHECK(inside_ok);
  CHECK(outside_ok);
}

static void test_profiles(void) {
  ch_profile p;
  char why[200];
  CHECK(ch_profile_parse("v", &p, why, sizeof why) == 0 && p.kind == CH_PROFILE_V);
  CHECK_NEAR(ch_profile_eval(&p, 0.0), -1.0, 0);
  CHECK_NEAR(ch_profile_eval(&p, 0.25), -0.5, 1e-15);
  CHECK_NEAR(ch_profile_eval(&p, -0.5), 0.0, 0);
  CHECK_NEAR(ch_profile_eval(&p, 0.7), 0.0, 0);
  CHECK(ch_profile_parse(" u ", &p, why, sizeof why) == 0 && p.kind == CH_PROFILE_U);
  CHECK_NEAR(ch_profile_eval(&p, 0.3), -sqrt(1 - 4 * 0.09), 1e-15);
  CHECK(ch_profile_parse("box", &p, why, sizeof why) == 0);
  CHECK_NEAR(ch_profile_eval(&p, 0.4999), -1.0, 0);
  CHECK_NEAR(ch_profile_eval(&p, 0.5), 0.0, 0);
  CHECK(ch_profile_parse("ridge", &p, why, sizeof why) == 0);
  CHECK_NEAR(ch_profile_eval(&p, -0.1), 0.8, 1e-15);
  CHECK(ch_profile_parse("bevel", &p, why, sizeof why) == 0);
  CHECK_NEAR(ch_profile_eval(&p, 0.1), -0.8, 1e-15);
  CHECK_NEAR(ch_profile_eval(&p, -0.1), 0.0, 0);
  CHECK(ch_profile_parse("-0.5,0 -0.25,-0.6 0,-0.6 0.25,-1 0.5,0", &p, why, sizeof why) == 0);
  CHECK(p.kind == CH_PROFILE_CUSTOM && p.num_points == 5);
  CHECK_NEAR(ch_profile_eval(&p, -0.375), -0.3, 1e-15);
  CHECK_NEAR(ch_profile_eval(&p, 0.125), -0.8, 1e-15);
  /* A custom box: at the walls the smaller magnitude. */
  CHECK(ch_profile_parse("-0.3,0 -0.3,-1 0.3,-1 0.3,0", &p, why, sizeof why) == 0);
  CHECK_NEAR(ch_profile_eval(&p, -0.3), 0.0, 0);
  CHECK_NEAR(ch_profile_eval(&p, 0.0), -1.0, 0);
  double t[8];
  CHECK(ch_profile_creases(&p, t, 8) == 2);
  CHECK(ch_profile_parse("w", &p, why, sizeof why) != 0);
  CHECK(ch_profile_parse("0.1,0 0,1", &p, why, sizeof why) != 0);    /* decreasing t */
  CHECK(ch_profile_parse("0.1,0 0.6,1", &p, why, sizeof why) != 0);  /* outside [-1/2,1/2] */
  CHECK(ch_profile_parse("0.1,0 0.2", &p, why, sizeof why) != 0);    /* odd count */
  CHECK(ch_profile_parse("0,0 0,1 0,2", &p, why, sizeof why) != 0);  /* three at one t */
}

/* Cubic splitting: every quadratic piece is within the tolerance of the
 * cubic (checked at 2000 points against the cubic itself). */
static int collect_quads(void *user, const double q[3][2]) {
  double (*arr)[3][2] = ((double(**)[3][2])user)[0];
  int *count = ((int **)user)[1];
  memcpy(arr[*count], q, sizeof arr[0]);
  (*count)++;
  return 0;
}

static void test_cubic_split(void) {
  static double quads[5000][3][2];
  double max_dev = 0.0;
  for (int trial = 0; trial < 50; trial++) {
    double c[4][2];
    for (int i = 0; i < 4; i++) c[i][0] = ch_test_rnd(), c[i][1] = ch_test_rnd();
    int count = 0;
    void *user[2] = {quads, &count};
    ch_cubic_to_quads(c, 1e-6, collect_quads, user);
    REQUIRE(count > 0 && count < 5000);
    CHECK(quads[0][0][0] == c[0][0] && quads[count - 1][2][1] == c[3][1]);
    for (int i = 0; i <= 2000; i++) {
      double t = i / 2000.0, s = 1 - t, x[2];
      for (int k = 0; k < 2; k++)
        x[k] = s * s * s * c[0][k] + 3 * s * s * t * c[1][k] + 3 * s * t * t * c[2][k] + t * t * t * c[3][k];
      double best = INFINITY;
      for (int j = 0; j < count; j++) {
        double tt;
        double d = ch_bezier_closest(quads[j], 0, x, &tt);
        if (d < best) best = d;
      }
      if (sqrt(best) > max_dev) max_dev = sqrt(best);
    }
  }
  fprintf(stderr, "  cubic -> quadratics: max deviation %.3g (tolerance 1e-6)\n", max_dev);
  CHECK(max_dev <= 1e-6);
}

static void test_arc_split(void) {
  static double quads[5000][3][2];
  int count = 0;
  void *user[2] = {quads, &count};
  /* A full circle of radius 0.3 about (0.5, 0.5). */
  double m[6] = {0.3, 0, 0, 0.3, 0.5, 0.5};
  ch_arc_to_quads(0.0, 2 * 3.14159265358979323846, m, 1e-6, collect_quads, user);
  double max_dev = 0.0;
  for (int j = 0; j < count; j++)
    for (int i = 0; i <= 50; i++) {
      double x[2];
      eval_q(quads[j], i / 50.0, x);
      double r = hypot(x[0] - 0.5, x[1] - 0.5);
      if (fabs(r - 0.3) > max_dev) max_dev = fabs(r - 0.3);
    }
  fprintf(stderr, "  circle -> %d quadratics: max radial deviation %.3g\n", count, max_dev);
  CHECK(max_dev <= 1e-6);
  CHECK(count <= 48); /* h^4/8 <= tol/r: 44 pieces for r = 0.3 */
}

/* The grid-accelerated field equals a scan of every curve. */
static void test_field_vs_scan(void) {
  ch_curve_set set;
  ch_error err = {0};
  REQUIRE(ch_curves_read_svg(CHISEL_TEST_DATA "/svg/mixed.svg", &set, &err) == CH_OK);
  ch_groove_field field;
  REQUIRE(ch_groove_field_init(&field, &set, &err) == CH_OK);
  int mismatches = 0;
  for (int i = 0; i < 20000; i++) {
    double q[2] = {ch_test_rnd() * 1.2 - 0.1, ch_test_rnd() * 1.2 - 0.1};
    double min_carve = 0, max_raise = 0;
    for (int c = 0; c < set.num_curves; c++) {
      if (set.curves[c].kind != CH_CURVE_GROOVE) continue;
      ch_curve_point cp;
      ch_curve_closest(&set, c, q, &cp);
      double g = set.curves[c].depth * ch_profile_eval(&set.curves[c].profile, cp.signed_distance / set.curves[c].width);
      if (g < min_carve) min_carve = g;
      if (g > max_raise) max_raise = g;
    }
    double want = min_carve < 0 ? min_carve : max_raise;
    double got = ch_groove_field_eval(&field, q[0], q[1], NULL);
    if (fabs(got - want) > 1e-12) mismatches++;
  }
  CHECK_MSG(mismatches == 0, "%d of 20000 points differ", mismatches);
  ch_groove_field_free(&field);
  ch_curves_free(&set);
}

/* The curve queries tess/ and validate/ use: the closest point of a groove
 * by the field's grid agrees with a scan of the whole curve wherever it is
 * within half the width (where it matters: inside the groove), and is a
 * point of the curve farther than that elsewhere; the profile's slope is
 * the derivative of its value (central differences away from its breaks,
 * and u's 4t / sqrt(1 - 4t^2) = 1.5 at t = 0.3 by hand). */
static void test_curve_queries(void) {
  ch_curve_set set;
  ch_error err = {0};
  REQUIRE(ch_curves_read_svg(CHISEL_TEST_DATA "/svg/mixed.svg", &set, &err) == CH_OK);
  ch_groove_field field;
  REQUIRE(ch_groove_field_init(&field, &set, &err) == CH_OK);
  int mismatches = 0, inside = 0, bad_far = 0, bad_cell = 0;
  for (int i = 0; i < 20000; i++) {
    double q[2] = {ch_test_rnd() * 1.2 - 0.1, ch_test_rnd() * 1.2 - 0.1};
    for (int c = 0; c < set.num_curves; c++) {
      if (set.curves[c].kind != CH_CURVE_GROOVE) continue;
      ch_curve_point scan, near;
      ch_curve_closest(&set, c, q, &scan);
      ch_groove_field_closest(&field, c, q, &near);
      double half = 0.5 * set.curves[c].width;
      if (scan.distance <= half) {
        inside++;
        mismatches += fabs(near.signed_distance - scan.signed_distance) > 1e-12 || near.segment != scan.segment;
      } else {
        double p[2];
        ch_segment_point(&set.segments[near.segment], near.t, p);
        bad_far += near.distance < scan.distance - 1e-12 || near.distance <= half ||
                   fabs(hypot(q[0] - p[0], q[1] - p[1]) - near.distance) > 1e-12;
      }
      /* without `beyond`: only segments whose box holds q */
      double d2, t;
      int s = ch_curve_closest_in_cell(&set, &field.grid, ch_groove_field_boxes(&field), c, q, half, 0, &d2, &t);
      if (s >= 0) {
        const double *b = ch_groove_field_boxes(&field) + 4 * (size_t)s;
        bad_cell += set.segments[s].curve != c || q[0] < b[0] || q[0] > b[2] || q[1] < b[1] || q[1] > b[3];
      } else {
        bad_cell += scan.distance <= half; /* inside the groove its segment's box holds q */
      }
    }
  }
  CHECK_MSG(inside > 100, "%d points inside grooves", inside);
  CHECK_MSG(mismatches == 0, "%d of %d points inside grooves differ from the scan", mismatches, inside);
  CHECK_MSG(bad_far == 0, "%d answers beyond the half width are wrong", bad_far);
  CHECK_MSG(bad_cell == 0, "%d in-cell answers are wrong", bad_cell);
  ch_groove_field_free(&field);
  ch_curves_free(&set);

  const char *names[] = {"v", "u", "box", "ridge", "bevel", "-0.5,0 -0.25,-0.6 0,-0.6 0.25,-1 0.5,0"};
  char why[200];
  ch_profile p;
  REQUIRE(ch_profile_parse("u", &p, why, sizeof why) == 0);
  CHECK_NEAR(ch_profile_slope(&p, 0.3), 1.5, 1e-15);
  CHECK_NEAR(ch_profile_slope(&p, -0.3), -1.5, 1e-15);
  CHECK(ch_profile_slope(&p, 0.6) == 0.0);
  for (int k = 0; k < 6; k++) {
    REQUIRE(ch_profile_parse(names[k], &p, why, sizeof why) == 0);
    int bad = 0;
    for (int i = 0; i < 1000; i++) {
      double t = ch_test_rnd() * 1.2 - 0.6, e = 1e-7;
      /* away from the breaks (-1/2, -1/4, 0, 1/4, 1/2) and u's rims */
      if (fabs(t * 4.0 - round(t * 4.0)) < 0.02 || fabs(fabs(t) - 0.5) < 0.05) continue;
      double fd = (ch_profile_eval(&p, t + e) - ch_profile_eval(&p, t - e)) / (2.0 * e);
      bad += fabs(fd - ch_profile_slope(&p, t)) > 1e-6 * (1.0 + fabs(fd));
    }
    CHECK_MSG(bad == 0, "profile %s: %d slopes differ from the value's differences", names[k], bad);
  }
}

/* A few grooves far wider than the square among many thin ones (a fuzzed
 * file took 6 s and 1.3 GB here): the grid stays within its budget of
 * items, and the field still agrees with a scan of every curve. */
static void test_mixed_box_sizes(void) {
  enum { THIN = 4000 };
  size_t cap = 200 + THIN * 80, len = 0;
  char *svg = malloc(cap);
  REQUIRE(svg != NULL);
  len += (size_t)snprintf(svg + len, cap - len, "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>");
  for (int i = 0; i < THIN; i++)
    len += (size_t)snprintf(svg + len, cap - len, "<path d='M %.3f 10 L %.3f 90' data-width='0.01'/>",
                            5 + 90.0 * i / THIN, 5.01 + 90.0 * i / THIN);
  for (int i = 0; i < 4; i++)
    len += (size_t)snprintf(svg + len, cap - len, "<path d='M 20 %d L 80 %d' data-width='1e9' data-depth='1e-9'/>",
                            20 + 20 * i, 20 + 20 * i);
  len += (size_t)snprintf(svg + len, cap - len, "</svg>");
  ch_curve_set set;
  ch_error err = {0};
  REQUIRE(ch_curves_parse_svg(svg, len, "mixed_sizes.svg", &set, &err) == CH_OK);
  free(svg);
  ch_groove_field field;
  REQUIRE(ch_groove_field_init(&field, &set, &err) == CH_OK);
  size_t items = (size_t)field.grid.cell_start[(size_t)field.grid.nx * field.grid.ny];
  CHECK_MSG(items <= 16 * (size_t)set.num_segments + ((size_t)1 << 22), "%zu items for %d segments", items,
            set.num_segments);
  int mismatches = 0;
  for (int i = 0; i < 2000; i++) {
    double q[2] = {ch_test_rnd(), ch_test_rnd()};
    double min_carve = 0, max_raise = 0;
    for (int c = 0; c < set.num_curves; c++) {
      ch_curve_point cp;
      ch_curve_closest(&set, c, q, &cp);
      double g = set.curves[c].depth * ch_profile_eval(&set.curves[c].profile, cp.signed_distance / set.curves[c].width);
      if (g < min_carve) min_carve = g;
      if (g > max_raise) max_raise = g;
    }
    if (fabs(ch_groove_field_eval(&field, q[0], q[1], NULL) - (min_carve < 0 ? min_carve : max_raise)) > 1e-12)
      mismatches++;
  }
  CHECK_MSG(mismatches == 0, "%d of 2000 points differ", mismatches);
  ch_groove_field_free(&field);
  ch_curves_free(&set);
}

/* The segment tree against a scan in index order (strictly smaller
 * distances kept: the lowest index wins ties): per curve without a bound,
 * over the step curves within a radius; on the mixed set, on a long path,
 * and on curves that share segments' geometry exactly (ties). */
static void test_segtree_vs_scan(void) {
  static const char *files[] = {CHISEL_TEST_DATA "/svg/mixed.svg", CHISEL_MODELS "/curves/relief.svg",
                                CHISEL_MODELS "/curves/spiral.svg", CHISEL_MODELS "/curves/steps_simple.svg"};
  /* and twin curves: every segment twice, so every answer is a tie */
  static const char twins[] = "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
                              "<path data-kind='step' d='M 10 10 L 90 20 Q 50 90 10 10 Z'/>"
                              "<path data-kind='step' d='M 10 10 L 90 20 Q 50 90 10 10 Z'/>"
                              "<path d='M 20 80 C 40 10 60 150 80 20'/><path d='M 20 80 C 40 10 60 150 80 20'/></svg>";
  for (int f = 0; f < 5; f++) {
    ch_curve_set set;
    ch_error err = {0};
    if (f < 4)
      REQUIRE(ch_curves_read_svg(files[f], &set, &err) == CH_OK);
    else
      REQUIRE(ch_curves_parse_svg(twins, sizeof twins - 1, "twins.svg", &set, &err) == CH_OK);
    ch_segtree tree;
    REQUIRE(ch_segtree_build(&tree, &set, &err) == CH_OK);
    int bad = 0, found = 0;
    for (int i = 0; i < 3000; i++) {
      double q[2] = {ch_test_rnd() * 1.4 - 0.2, ch_test_rnd() * 1.4 - 0.2};
      int c = (int)(ch_test_rnd() * set.num_curves);
      ch_curve_point cp;
      ch_curve_closest(&set, c, q, &cp);
      int first, last, seg;
      double d2 = -1, t = -1;
      ch_segtree_curve(&tree, &set, c, &first, &last);
      seg = ch_segtree_closest(&tree, &set, first, last, q, INFINITY, &d2, &t);
      bad += seg != cp.segment || t != cp.t || sqrt(d2) != cp.distance;
      /* the nearest step segment within r */
      double r2 = 0.01 * (1 + i % 10), best = r2, best_t = 0;
      int want = -1;
      for (int s = 0; s < set.num_segments; s++) {
        if (set.curves[set.segments[s].curve].kind != CH_CURVE_STEP) continue;
        double ts, d = ch_bezier_closest(set.segments[s].p, set.segments[s].is_line, q, &ts);
        if (d < best) best = d, best_t = ts, want = s;
      }
      seg = ch_segtree_closest(&tree, &set, 0, tree.num_step_leaves, q, r2, &d2, &t);
      found += want >= 0;
      bad += seg != want || (want >= 0 && (d2 != best || t != best_t));
    }
    CHECK_MSG(bad == 0, "set %d: %d of 6000 answers differ from the scan", f, bad);
    CHECK(f == 2 || found > 0);
    ch_segtree_free(&tree);
    ch_curves_free(&set);
  }
}

/* h_groove at hand-computed points. */
static void test_groove_values(void) {
  static const char svg[] =
      "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
      "<path id='a' d='M 10 50 L 90 50' data-width='10' data-depth='0.02'/>"          /* v along v=0.5 */
      "<path id='b' d='M 50 10 L 50 90' data-profile='box' data-width='4' data-depth='0.01'/>"
      "<path id='c' d='M 10 20 L 90 20' data-profile='ridge' data-width='10' data-depth='-0.03'/>"
      "<path id='d' d='M 10 80 L 90 80' data-profile='bevel' data-width='10' data-depth='0.01'/>"
      "</svg>";
  ch_curve_set set;
  ch_error err = {0};
  REQUIRE(ch_curves_parse_svg(svg, sizeof svg - 1, "inline.svg", &set, &err) == CH_OK);
  ch_groove_field f;
  REQUIRE(ch_groove_field_init(&f, &set, &err) == CH_OK);
  /* v groove: width 0.1, at s = 0.025: P = -(1 - 2*0.25) = -0.5, h = -0.01. */
  CHECK_NEAR(ch_groove_field_eval(&f, 0.3, 0.525, NULL), -0.01, 1e-15);
  CHECK_NEAR(ch_groove_field_eval(&f, 0.3, 0.5, NULL), -0.02, 1e-15);
  CHECK_NEAR(ch_groove_field_eval(&f, 0.3, 0.56, NULL), 0.0, 0);
  /* Rounded cap: 0.03 beyond the start (0.1, 0.5): t = 0.3, P = -0.4. */
  CHECK_NEAR(ch_groove_field_eval(&f, 0.07, 0.5, NULL), -0.008, 1e-15);
  /* Crossing of v (-0.02 at its centre) and box (-0.01): the minimum. */
  CHECK_NEAR(ch_groove_field_eval(&f, 0.5, 0.5, NULL), -0.02, 1e-15);
  /* Beside the v centre but inside the box: v gives -0.02*(1-2*0.05) = -0.018. */
  CHECK_NEAR(ch_groove_field_eval(&f, 0.5, 0.505, NULL), -0.018, 1e-15);
  CHECK_NEAR(ch_groove_field_eval(&f, 0.51, 0.3, NULL), -0.01, 0);
  /* SVG y = 20 is v = 0.8. A ridge with negative depth carves:
   * -0.03 * (1 - 2 * 0.1) at 0.01 from its centre. */
  CHECK_NEAR(ch_groove_field_eval(&f, 0.3, 0.81, NULL), -0.024, 1e-15);
  CHECK_NEAR(ch_groove_field_eval(&f, 0.3, 0.79, NULL), -0.024, 1e-15);
  /* Bevel at v = 0.2: the left of a path heading +u is above it. */
  CHECK_NEAR(ch_groove_field_eval(&f, 0.3, 0.21, NULL), -0.01 * 0.8, 1e-15);
  CHECK_NEAR(ch_groove_field_eval(&f, 0.3, 0.19, NULL), 0.0, 0);
  ch_groove_field_free(&f);
  ch_curves_free(&set);

  /* Raised ridges combine by max, and any carve wins over them. */
  static const char svg2[] =
      "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
      "<path d='M 10 50 L 90 50' data-profile='ridge' data-width='10' data-depth='0.02'/>"
      "<path d='M 10 52 L 90 52' data-profile='ridge' data-width='10' data-depth='0.02'/>"
      "<path d='M 70 10 L 70 90' data-profile='v' data-width='4' data-depth='0.001'/>"
      "</svg>";
  REQUIRE(ch_curves_parse_svg(svg2, sizeof svg2 - 1, "inline2.svg", &set, &err) == CH_OK);
  REQUIRE(ch_groove_field_init(&f, &set, &err) == CH_OK);
  /* At v = 0.51: both ridges at s = 0.01 -> 0.02 * 0.8 = 0.016. */
  CHECK_NEAR(ch_groove_field_eval(&f, 0.3, 0.51, NULL), 0.016, 1e-15);
  /* At v = 0.5: first ridge 0.02, second 0.02*(1-0.4) = 0.012 -> max 0.02. */
  CHECK_NEAR(ch_groove_field_eval(&f, 0.3, 0.5, NULL), 0.02, 1e-15);
  /* The v groove carves through the ridges: -0.001. */
  CHECK_NEAR(ch_groove_field_eval(&f, 0.7, 0.5, NULL), -0.001, 1e-15);
  ch_groove_field_free(&f);
  ch_curves_free(&set);
}

/* A closed polygon as a curve set of straight segments. */
static void polygon_set(ch_curve_set *set, ch_curve *curve, ch_segment *segs, const double (*p)[2], int n) {
  memset(set, 0, sizeof *set);
  memset(curve, 0, sizeof *curve);
  for (int i = 0; i < n; i++) {
    const double *a = p[i], *b = p[(i + 1) % n];
    segs[i] = (ch_segment){
        {{a[0], a[1]}, {0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])}, {b[0], b[1]}}, 0, (i + n - 1) % n, (i + 1) % n, 1};
  }
  curve->num_segments = n;
  set->num_curves = 1, set->curves = curve, set->num_segments = n, set->segments = segs;
}

/* The classic crossing test (Franklin's pnpoly, a vertex on the ray's line
 * counting as below it), signed: the reference for polygons. */
static int pnpoly_winding(const double (*p)[2], int n, const double q[2]) {
  int w = 0;
  for (int i = 0; i < n; i++) {
    const double *a = p[i], *b = p[(i + 1) % n];
    if ((a[1] <= q[1]) == (b[1] <= q[1])) continue;
    double x = a[0] + (q[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
    if (x > q[0]) w += b[1] > a[1] ? 1 : -1;
  }
  return w;
}

/* Winding numbers where the ray from q runs through vertices, along edges
 * or touches a curve: a diamond's corners, a square's edges, a lens's top;
 * then random polygons on a coarse lattice, probed at lattice points,
 * against pnpoly. */
static void test_winding_degenerate(void) {
  ch_curve_set set;
  ch_curve curve;
  ch_segment segs[64];
  static const double diamond[4][2] = {{0.5, 0.1}, {0.9, 0.5}, {0.5, 0.9}, {0.1, 0.5}};
  polygon_set(&set, &curve, segs, diamond, 4);
  static const struct {
    double q[2];
    int w;
  } dq[] = {{{0.2, 0.9}, 0}, {{0.3, 0.5}, 1}, {{0.05, 0.5}, 0}, {{0.95, 0.5}, 0}, {{0.2, 0.1}, 0}, {{0.5, 0.5}, 1}};
  for (size_t i = 0; i < sizeof dq / sizeof dq[0]; i++)
    CHECK_MSG(ch_segments_winding(&set, 0, 4, dq[i].q) == dq[i].w, "diamond at (%g, %g): %d, want %d", dq[i].q[0],
              dq[i].q[1], ch_segments_winding(&set, 0, 4, dq[i].q), dq[i].w);
  static const double square[4][2] = {{0.2, 0.2}, {0.8, 0.2}, {0.8, 0.8}, {0.2, 0.8}};
  polygon_set(&set, &curve, segs, square, 4);
  static const double sq[4][2] = {{0.0, 0.8}, {0.0, 0.2}, {0.5, 0.2}, {0.5, 0.8}};
  static const int sw[4] = {0, 0, 1, 0};
  for (int i = 0; i < 4; i++) CHECK(ch_segments_winding(&set, 0, 4, sq[i]) == sw[i]);
  /* a lens of two quadratics, clockwise, its top at v = 0.7 */
  ch_segment lens[2] = {{{{0.2, 0.5}, {0.5, 0.9}, {0.8, 0.5}}, 0, 1, 1, 0},
                        {{{0.8, 0.5}, {0.5, 0.1}, {0.2, 0.5}}, 0, 0, 0, 0}};
  set.segments = lens, set.num_segments = 2;
  static const double lq[4][2] = {{0.0, 0.7}, {0.0, 0.6999}, {0.5, 0.6999}, {0.5, 0.7}};
  static const int lw[4] = {0, 0, -1, 0};
  for (int i = 0; i < 4; i++)
    CHECK_MSG(ch_segments_winding(&set, 0, 2, lq[i]) == lw[i], "lens at (%g, %g): %d", lq[i][0], lq[i][1],
              ch_segments_winding(&set, 0, 2, lq[i]));
  /* random lattice polygons, probed at lattice points */
  uint64_t rng = 12345;
  int wrong = 0;
  for (int trial = 0; trial < 200; trial++) {
    double p[12][2];
    int n = 3 + trial % 10;
    for (int i = 0; i < n; i++)
      for (int k = 0; k < 2; k++) {
        rng = rng * 6364136223846793005ull + 1442695040888963407ull;
        p[i][k] = (double)((rng >> 33) % 9) / 8.0;
      }
    polygon_set(&set, &curve, segs, (const double(*)[2])p, n);
    for (int y = 0; y <= 8; y++)
      for (int x = 0; x <= 8; x++) {
        double q[2] = {x / 8.0 + 1.0 / 64, y / 8.0};
        wrong += ch_segments_winding(&set, 0, n, q) != pnpoly_winding((const double(*)[2])p, n, q);
      }
  }
  CHECK_MSG(wrong == 0, "%d lattice probes differ from pnpoly", wrong);
}

int main(void) {
  RUN(test_closest_vs_brute_force);
  RUN(test_winding_degenerate);
  RUN(test_closest_vs_long_double);
  RUN(test_line_closest);
  RUN(test_length);
  RUN(test_signed_distance_and_caps);
  RUN(test_profiles);
  RUN(test_cubic_split);
  RUN(test_arc_split);
  RUN(test_groove_values);
  RUN(test_field_vs_scan);
  RUN(test_curve_queries);
  RUN(test_mixed_box_sizes);
  RUN(test_segtree_vs_scan);
  TEST_MAIN_END();
}
