/* ch_math: small inline helpers shared by every module (2D/3D vectors as
 * double arrays, clamping, min/max of three, the box of a point array, a
 * qsort comparator), and pi,
 * which strict C11 does not define. Plain C, usable from C++ shims too. */
#ifndef CH_MATH_H
#define CH_MATH_H

#include <math.h>
#include <stddef.h>

#define CH_PI 3.14159265358979323846

static inline double ch_clamp(double x, double lo, double hi) {
  return x < lo ? lo : x > hi ? hi : x;
}
static inline int ch_clampi(int x, int lo, int hi) { return x < lo ? lo : x > hi ? hi : x; }
/* Smallest and largest of three (comparisons, not fmin/fmax, which are
 * calls at -O2 for their NaN rules: no NaN may reach these). */
static inline double ch_min3(double a, double b, double c) { return a < b ? (a < c ? a : c) : (b < c ? b : c); }
static inline double ch_max3(double a, double b, double c) { return a > b ? (a > c ? a : c) : (b > c ? b : c); }
static inline double ch_dot2(const double a[2], const double b[2]) {
  return a[0] * b[0] + a[1] * b[1];
}
/* z of the 3D cross product: > 0 when b turns left of a (u right, v up). */
static inline double ch_cross2(const double a[2], const double b[2]) {
  return a[0] * b[1] - a[1] * b[0];
}
static inline double ch_dot3(const double a[3], const double b[3]) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
static inline void ch_sub3(const double a[3], const double b[3], double out[3]) {
  out[0] = a[0] - b[0];
  out[1] = a[1] - b[1];
  out[2] = a[2] - b[2];
}
static inline double ch_len3(const double a[3]) { return sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]); }
/* |(x, y)| where neither overflows when squared (UV and object
 * coordinates): glibc's hypot guards against that at ten times the cost,
 * 4% of an embedding run in the thinning's and the refinement's loops. */
static inline double ch_dist2d(double x, double y) { return sqrt(x * x + y * y); }
static inline void ch_cross3(const double a[3], const double b[3], double out[3]) {
  double x = a[1] * b[2] - a[2] * b[1];
  double y = a[2] * b[0] - a[0] * b[2];
  double z = a[0] * b[1] - a[1] * b[0];
  out[0] = x;
  out[1] = y;
  out[2] = z;
}
/* atan(x) for x in [0, 1]: Moshier's Cephes atan (range reduction at 0.66
 * by atan(x) = pi/4 + atan((x - 1) / (x + 1)), then a rational function of
 * degree 4/5 in x^2; about 1e-16 relative error). */
static inline double ch_atan01(double x) {
  /* (both arguments, then selects, not a branch: loops over many angles
   * vectorise, and which way a value goes is data) */
  double reduced = (x - 1.0) / (x + 1.0);
  double y = x > 0.66 ? 0.25 * CH_PI : 0.0,
         bits = x > 0.66 ? 0.5 * 6.123233995736765886130e-17 : 0.0; /* (pi/4's low bits) */
  x = x > 0.66 ? reduced : x;
  double z = x * x;
  double p = (((-8.750608600031904122785e-1 * z - 1.615753718733365076637e1) * z - 7.500855792314704667340e1) * z -
              1.228866684490136173410e2) *
                 z -
             6.485021904942025371773e1;
  double q = ((((z + 2.485846490142306297962e1) * z + 1.650270098316988542046e2) * z + 4.328810604912902668951e2) * z +
              4.853903996359136964868e2) *
                 z +
             1.945506571482613964425e2;
  return y + (x * (z * p / q) + x + bits);
}
/* ch_angle for s > 0, without a branch (see ch_atan01). */
static inline double ch_angle_positive(double s, double c) {
  double ac = fabs(c);
  double r = ch_atan01((s <= ac ? s : ac) / (s <= ac ? ac : s)), a = s <= ac ? r : 0.5 * CH_PI - r;
  return c < 0.0 ? CH_PI - a : a;
}
/* atan2(s, c) for s >= 0 (an angle in [0, pi] from its sine and cosine
 * times one length, as |a x b| and a . b): inlined, where glibc's atan2
 * is a call (the output's normals take 5% less time). Within 4.5e-16 (an
 * ulp of pi) of atan2 in radians (tests/test_math.c). */
static inline double ch_angle(double s, double c) {
  if (!(s > 0.0)) return signbit(c) ? CH_PI : 0.0; /* (atan2(+0, -0) is pi) */
  return ch_angle_positive(s, c);
}
/* Scales v to unit length; returns 0 (v unchanged) when its length is 0 or
 * not finite. */
static inline int ch_normalize3(double v[3]) {
  double len = sqrt(ch_dot3(v, v));
  if (!(len > 0.0) || !isfinite(len)) return 0;
  v[0] /= len;
  v[1] /= len;
  v[2] /= len;
  return 1;
}

/* The box of n points (3 doubles each); lo = +inf, hi = -inf when n = 0. */
static inline void ch_box3(const double *p, size_t n, double lo[3], double hi[3]) {
  for (int k = 0; k < 3; k++) {
    lo[k] = INFINITY;
    hi[k] = -INFINITY;
  }
  /* Compared, not fmin/fmax: those are library calls without
   * -ffinite-math-only (15 ms over a million points); a NaN is skipped
   * all the same. */
  for (size_t i = 0; i < n; i++)
    for (int k = 0; k < 3; k++) {
      double x = p[3 * i + k];
      lo[k] = x < lo[k] ? x : lo[k];
      hi[k] = x > hi[k] ? x : hi[k];
    }
}

/* qsort comparator for doubles in ascending order (NaNs compare equal to
 * everything: keep them out). */
static inline int ch_cmp_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}
static inline int ch_finite2(const double a[2]) { return isfinite(a[0]) && isfinite(a[1]); }

#endif
