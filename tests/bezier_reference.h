/* A long double reference for ch_bezier_closest, shared by test_geometry
 * and bench_bezier: f (the derivative of |B(t) - q|^2 / 2) is cut at 64
 * steps and at the roots of f', each sign change from - to + bisected to
 * the end of long double, the ends taken where the distance rises going
 * in; the best of those, the best local minimum apart from it (g2: how
 * close a second minimum comes) and how well t is conditioned there. */
#ifndef CHISEL_BEZIER_REFERENCE_H
#define CHISEL_BEZIER_REFERENCE_H

#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef long double ld;

/* B(t) - q and B'(t) / 2, the former from p0 - q and the differences
 * (from the points themselves, their rounding would swamp distances far
 * below the coordinates). */
static void ref_point(const double p[3][2], const double q[2], ld t, ld x[2], ld d[2]) {
  for (int k = 0; k < 2; k++) {
    ld a = (ld)p[1][k] - p[0][k], b = (ld)p[2][k] - 2.0L * p[1][k] + p[0][k];
    x[k] = ((ld)p[0][k] - q[k]) + t * (2.0L * a + t * b);
    d[k] = a + t * b;
  }
}

static ld ref_f(const double p[3][2], const double q[2], ld t) {
  ld x[2], d[2];
  ref_point(p, q, t, x, d);
  return x[0] * d[0] + x[1] * d[1];
}

static ld ref_g(const double p[3][2], const double q[2], ld t) {
  ld x[2], d[2];
  ref_point(p, q, t, x, d);
  return x[0] * x[0] + x[1] * x[1];
}

static int ref_cmp_ld(const void *a, const void *b) {
  ld x = *(const ld *)a, y = *(const ld *)b;
  return x < y ? -1 : x > y;
}

typedef struct ref_closest_t {
  ld t, g1, g2; /* the closest point's t and squared distance; the next local minimum's */
  ld cond;      /* f' there over |B'/2|^2: 0 at the centre of curvature */
} ref_closest_t;

static ref_closest_t ref_closest_ld(const double p[3][2], int is_line, const double q[2]) {
  enum { STEPS = 64 };
  ld cuts[STEPS + 4];
  int n = 0;
  for (int i = 0; i <= STEPS; i++) cuts[n++] = (ld)i / STEPS;
  double pl[3][2];
  memcpy(pl, p, sizeof pl);
  if (is_line) /* the straight segment p0 p2, as a quadratic */
    for (int k = 0; k < 2; k++) pl[1][k] = 0.5 * (p[0][k] + p[2][k]);
  /* f' = 3 |b|^2 t^2 + 6 a.b t + 2 |a|^2 + m.b (a = p1 - p0, b = p2 - 2 p1 + p0, m = p0 - q). */
  ld a[2], b[2], m[2];
  for (int k = 0; k < 2; k++) {
    a[k] = (ld)pl[1][k] - pl[0][k];
    b[k] = (ld)pl[2][k] - 2.0L * pl[1][k] + pl[0][k];
    m[k] = (ld)pl[0][k] - q[k];
  }
  ld A = 3.0L * (b[0] * b[0] + b[1] * b[1]), B = 6.0L * (a[0] * b[0] + a[1] * b[1]);
  ld C = 2.0L * (a[0] * a[0] + a[1] * a[1]) + m[0] * b[0] + m[1] * b[1];
  ld disc = B * B - 4.0L * A * C;
  if (A != 0.0L && disc >= 0.0L) {
    ld sq = sqrtl(disc), qq = -0.5L * (B + (B >= 0 ? sq : -sq));
    ld r[2] = {qq / A, qq != 0.0L ? C / qq : qq / A};
    for (int i = 0; i < 2; i++)
      if (r[i] > 0.0L && r[i] < 1.0L) cuts[n++] = r[i];
  } else if (A == 0.0L && B != 0.0L) {
    ld r = -C / B;
    if (r > 0.0L && r < 1.0L) cuts[n++] = r;
  }
  qsort(cuts, (size_t)n, sizeof cuts[0], ref_cmp_ld);
  ld cand[STEPS + 6];
  int nc = 0;
  /* The ends where they are local minima (else, where the distance
   * changes by less than the rounding across a root next to an end, they
   * would win the ties). */
  if (ref_f(pl, q, 0.0L) >= 0.0L) cand[nc++] = 0.0L;
  if (ref_f(pl, q, 1.0L) <= 0.0L) cand[nc++] = 1.0L;
  for (int i = 0; i + 1 < n; i++) {
    ld lo = cuts[i], hi = cuts[i + 1];
    if (!(ref_f(pl, q, lo) <= 0.0L && ref_f(pl, q, hi) >= 0.0L) || lo == hi) continue;
    for (int it = 0; it < 200; it++) {
      ld mid = 0.5L * (lo + hi);
      if (mid <= lo || mid >= hi) break;
      if (ref_f(pl, q, mid) < 0.0L)
        lo = mid;
      else
        hi = mid;
    }
    cand[nc++] = 0.5L * (lo + hi);
  }
  /* The best, and the best local minimum apart from it (farther than a
   * hair in t: the same minimum found from two cut pairs is one). */
  ref_closest_t out = {0.0L, INFINITY, INFINITY, 0.0L};
  for (int i = 0; i < nc; i++) {
    ld g = ref_g(pl, q, cand[i]);
    if (g < out.g1 || (g == out.g1 && cand[i] < out.t)) out.g1 = g, out.t = cand[i];
  }
  for (int i = 0; i < nc; i++) {
    if (fabsl(cand[i] - out.t) <= 1e-6L) continue;
    /* an end is a local minimum only where the distance rises going in */
    if ((cand[i] == 0.0L && ref_f(pl, q, 0.0L) < 0.0L) || (cand[i] == 1.0L && ref_f(pl, q, 1.0L) > 0.0L)) continue;
    ld g = ref_g(pl, q, cand[i]);
    if (g < out.g2) out.g2 = g;
  }
  /* t is only known to about the cube root of the rounding where cond is 0 */
  ld x[2], d[2];
  ref_point(pl, q, out.t, x, d);
  ld dd = d[0] * d[0] + d[1] * d[1];
  out.cond = dd > 0.0L ? (dd + x[0] * b[0] + x[1] * b[1]) / dd : 0.0L;
  return out;
}

#endif
