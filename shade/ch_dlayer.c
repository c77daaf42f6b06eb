/* ch_dlayer: the double layer of an open curve (see ch_dlayer.h). */
#include "ch_dlayer.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ch_bezier.h"
#include "ch_math.h"

/* Coordinate k of the piece at t. */
static double coord(const double p[3][2], double t, int k) {
  double u = 1.0 - t;
  return u * u * p[0][k] + 2.0 * u * t * p[1][k] + t * t * p[2][k];
}

/* The signed crossings of the ray from q towards +x with the part of a
 * y-monotone quadratic between ta and tb: +1 going up, -1 going down, the
 * lower end counted and the upper not (so a joint is counted once). */
static int monotone_crossing(const double p[3][2], double ta, double tb, const double q[2]) {
  double ya = coord(p, ta, 1), yb = coord(p, tb, 1);
  int up = ya <= q[1] && q[1] < yb, down = yb <= q[1] && q[1] < ya;
  if (!up && !down) return 0;
  /* the parameter where y = q's: one root in [ta, tb] (monotone there) */
  double a = p[0][1] - 2.0 * p[1][1] + p[2][1], b = 2.0 * (p[1][1] - p[0][1]), c = p[0][1] - q[1], r[2], t = -1.0;
  int n = ch_quadratic_roots(a, b, c, r);
  double lo = fmin(ta, tb), hi = fmax(ta, tb), best = INFINITY;
  for (int k = 0; k < n; k++) {
    double off = r[k] < lo ? lo - r[k] : r[k] > hi ? r[k] - hi : 0.0;
    if (off < best) best = off, t = r[k];
  }
  t = t < lo ? lo : t > hi ? hi : t;
  if (!(best <= 1e-9)) { /* rounding: bisect the monotone part instead */
    double l = ta, h = tb;
    for (int it = 0; it < 60; it++) {
      double m = 0.5 * (l + h);
      if ((coord(p, m, 1) < q[1]) == (ya < yb)) l = m;
      else h = m;
    }
    t = 0.5 * (l + h);
  }
  return coord(p, t, 0) > q[0] ? (up ? 1 : -1) : 0;
}

static int piece_crossings(const double p[3][2], const double q[2]) {
  double den = p[0][1] - 2.0 * p[1][1] + p[2][1];
  double ts = den != 0.0 ? (p[0][1] - p[1][1]) / den : -1.0;
  if (ts > 0.0 && ts < 1.0) return monotone_crossing(p, 0.0, ts, q) + monotone_crossing(p, ts, 1.0, q);
  return monotone_crossing(p, 0.0, 1.0, q);
}

static int line_crossing(const double a[2], const double b[2], const double q[2]) {
  int up = a[1] <= q[1] && q[1] < b[1], down = b[1] <= q[1] && q[1] < a[1];
  if (!up && !down) return 0;
  double x = a[0] + (q[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
  return x > q[0] ? (up ? 1 : -1) : 0;
}

double ch_dlayer_angle(const ch_dlayer *l, const double q[2]) {
  const double *s = l->p[0][0], *e = l->p[l->num_pieces - 1][2];
  double ds[2] = {s[0] - q[0], s[1] - q[1]}, de[2] = {e[0] - q[0], e[1] - q[1]};
  double principal = atan2(ch_cross2(ds, de), ds[0] * de[0] + ds[1] * de[1]);
  /* the winding number of the curve closed by its chord (end to start) */
  int wind = 0;
  if (q[0] <= l->box[2] && q[1] >= l->box[1] && q[1] <= l->box[3]) {
    for (int i = 0; i < l->num_pieces; i++) wind += piece_crossings((const double(*)[2])l->p[i], q);
    wind += line_crossing(e, s, q);
  }
  return principal + 2.0 * CH_PI * wind;
}

double ch_dlayer_value(const ch_dlayer *l, const double q[2], double grad[2]) {
  if (grad) {
    /* grad of arg(x - q) over q is (dy, -dx) / |d|^2, d = x - q */
    const double *s = l->p[0][0], *e = l->p[l->num_pieces - 1][2];
    double ds[2] = {s[0] - q[0], s[1] - q[1]}, de[2] = {e[0] - q[0], e[1] - q[1]};
    double ns = ds[0] * ds[0] + ds[1] * ds[1], ne = de[0] * de[0] + de[1] * de[1], k = l->jump / (2.0 * CH_PI);
    grad[0] = ns > 0.0 && ne > 0.0 ? k * (de[1] / ne - ds[1] / ns) : 0.0;
    grad[1] = ns > 0.0 && ne > 0.0 ? k * (-de[0] / ne + ds[0] / ns) : 0.0;
  }
  return l->jump / (2.0 * CH_PI) * ch_dlayer_angle(l, q);
}

double ch_dlayer_value_beside(const ch_dlayer *l, const double c[2], const double n[2]) {
  double len = hypot(n[0], n[1]);
  /* a hair: far below any texel, far above the rounding of c */
  double h = 1e-7 * (1.0 + fmax(fabs(c[0]), fabs(c[1]))) / (len > 0.0 ? len : 1.0);
  double q[2] = {c[0] + h * n[0], c[1] + h * n[1]};
  return ch_dlayer_value(l, q, NULL);
}

void ch_dlayer_free(ch_dlayer *l) {
  free(l->p);
  memset(l, 0, sizeof *l);
}
