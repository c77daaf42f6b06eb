/* Private to ch_featmap: the geometry of one cell of a feature map, shared
 * by the build (which checks that a signature can be evaluated) and the
 * evaluation (which locates a point and interpolates), so both see exactly
 * the same curves, partition and side tests.
 *
 * A cell is the unit square in its own coordinates, x right, y up, with
 * corners c0 = SW (0,0), c1 = SE (1,0), c2 = NE (1,1), c3 = NW (0,1) and
 * edges S (0), E (1), N (2), W (3); an edge point lies at `pos` along its
 * edge from its left / bottom corner (feature-curves-textures §4, Fig. 7).
 * Everything here is shader-shaped: fixed-size structs, no allocation, no
 * recursion, loops with constant bounds. */
#ifndef CH_FEATMAP_CELL_H
#define CH_FEATMAP_CELL_H

#include <math.h>
#include <string.h>

#include "ch_featmap.h"

enum { FM_S = 0, FM_E = 1, FM_N = 2, FM_W = 3 };

/* The six segments a cell can hold, by their two edges (a < b), numbered
 * 1..6 in the configuration word (0: none). */
static const int fm_pair_edges[7][2] = {{-1, -1}, {FM_S, FM_E}, {FM_S, FM_N}, {FM_S, FM_W},
                                        {FM_E, FM_N}, {FM_E, FM_W}, {FM_N, FM_W}};

static inline int fm_pair_index(int a, int b) {
  if (a > b) {
    int t = a;
    a = b;
    b = t;
  }
  for (int k = 1; k <= 6; k++)
    if (fm_pair_edges[k][0] == a && fm_pair_edges[k][1] == b) return k;
  return 0;
}

/* Corners at the two ends of edge e: at pos 0 and at pos 1. */
static const int fm_edge_corner[4][2] = {{0, 1}, {1, 2}, {3, 2}, {0, 3}};
static const double fm_corner_xy[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};

static inline void fm_edge_point(int e, double pos, double out[2]) {
  switch (e) {
  case FM_S: out[0] = pos, out[1] = 0.0; break;
  case FM_E: out[0] = 1.0, out[1] = pos; break;
  case FM_N: out[0] = pos, out[1] = 1.0; break;
  default: out[0] = 0.0, out[1] = pos; break;
  }
}

static inline double fm_cross(const double a[2], const double b[2]) { return a[0] * b[1] - a[1] * b[0]; }

/* A quadratic (or straight) curve of the partition, from p[0] to p[2]. */
typedef struct fm_curve {
  double p[3][2];
  int straight; /* p[1] is the midpoint; side tests are exact line tests */
  double orient; /* sign of cross(p2 - p0, p1 - p0): which side the bulge is on */
} fm_curve;

static inline void fm_curve_set(fm_curve *c, const double a[2], const double b1[2], const double b[2], int straight) {
  memcpy(c->p[0], a, 2 * sizeof(double));
  memcpy(c->p[2], b, 2 * sizeof(double));
  c->straight = straight;
  if (straight) {
    c->p[1][0] = 0.5 * (a[0] + b[0]);
    c->p[1][1] = 0.5 * (a[1] + b[1]);
  } else {
    memcpy(c->p[1], b1, 2 * sizeof(double));
  }
  double e1[2] = {c->p[1][0] - a[0], c->p[1][1] - a[1]}, e2[2] = {b[0] - a[0], b[1] - a[1]};
  double o = fm_cross(e2, e1);
  c->orient = o > 0.0 ? 1.0 : -1.0;
  /* A control point on the chord: the curve is a straight line. */
  double scale = e1[0] * e1[0] + e1[1] * e1[1] + e2[0] * e2[0] + e2[1] * e2[1];
  if (fabs(o) <= 1e-12 * scale) c->straight = 1;
}

static inline void fm_curve_eval(const fm_curve *c, double t, double out[2]) {
  double s = 1.0 - t;
  out[0] = s * s * c->p[0][0] + 2.0 * s * t * c->p[1][0] + t * t * c->p[2][0];
  out[1] = s * s * c->p[0][1] + 2.0 * s * t * c->p[1][1] + t * t * c->p[2][1];
}

/* The implicit form of the parabola through the curve (Loop and Blinn's
 * coordinates u^2 - v, equivalent to the resultant of feature-curves §5.2
 * eq. (4)) times det^2, so no division: positive on the bulge's side.
 * Also its gradient. Lines: the signed area, positive on the left. */
static inline double fm_implicit(const fm_curve *c, const double q[2], double grad[2]) {
  const double *P0 = c->p[0];
  double e1[2] = {c->p[1][0] - P0[0], c->p[1][1] - P0[1]}, e2[2] = {c->p[2][0] - P0[0], c->p[2][1] - P0[1]};
  double d[2] = {q[0] - P0[0], q[1] - P0[1]};
  if (c->straight) {
    if (grad) grad[0] = -e2[1], grad[1] = e2[0];
    return fm_cross(e2, d);
  }
  double A = fm_cross(d, e2), B = fm_cross(e1, d), det = fm_cross(e1, e2);
  double m = 0.5 * A + B;
  if (grad) {
    double gA[2] = {e2[1], -e2[0]}, gB[2] = {-e1[1], e1[0]};
    grad[0] = 2.0 * m * (0.5 * gA[0] + gB[0]) - det * gB[0];
    grad[1] = 2.0 * m * (0.5 * gA[1] + gB[1]) - det * gB[1];
  }
  return m * m - B * det;
}

/* Whether q is on the left of the curve walked from p[0] to p[2] (within a
 * cell where the parabola's other branch stays outside: checked when the
 * signature is made, fm_curve_safe). */
static inline int fm_left(const fm_curve *c, const double q[2]) {
  double f = fm_implicit(c, q, NULL);
  if (c->straight) return f > 0.0;
  /* The bulge (towards p1) is on the left when p1 is left of the chord. */
  return c->orient > 0.0 ? f > 0.0 : f < 0.0;
}

/* Distance from q to the curve, to first order (|f| / |grad f|), in cell
 * units scaled by (sx, sy) per axis: for the labels near a segment. */
static inline double fm_curve_distance(const fm_curve *c, const double q[2], double sx, double sy) {
  double g[2], f = fm_implicit(c, q, g);
  double gx = g[0] / sx, gy = g[1] / sy, gl = sqrt(gx * gx + gy * gy);
  return gl > 0.0 ? fabs(f) / gl : INFINITY;
}

/* Real roots of a t^2 + b t + c = 0; returns their count (0..2), sorted. */
static inline int fm_roots(double a, double b, double c, double r[2]) {
  double scale = fabs(a) + fabs(b) + fabs(c);
  if (!(scale > 0.0)) return 0;
  if (fabs(a) <= 1e-13 * scale) {
    if (b == 0.0) return 0;
    r[0] = -c / b;
    return 1;
  }
  double disc = b * b - 4.0 * a * c;
  if (disc < 0.0) {
    if (disc > -1e-14 * b * b) disc = 0.0;
    else return 0;
  }
  double sq = sqrt(disc), qq = -0.5 * (b + (b >= 0.0 ? sq : -sq));
  double x0 = qq / a, x1 = qq != 0.0 ? c / qq : x0;
  r[0] = fmin(x0, x1);
  r[1] = fmax(x0, x1);
  return 2;
}

/* Parameters t where the curve meets the line through o along dir: roots of
 * cross(C(t) - o, dir) = 0 (all real ones, unclamped). */
static inline int fm_curve_line(const fm_curve *c, const double o[2], const double dir[2], double t[2]) {
  double P0[2] = {c->p[0][0] - o[0], c->p[0][1] - o[1]}, P1[2] = {c->p[1][0] - o[0], c->p[1][1] - o[1]};
  double P2[2] = {c->p[2][0] - o[0], c->p[2][1] - o[1]};
  double c0 = fm_cross(P0, dir), c1 = fm_cross(P1, dir), c2 = fm_cross(P2, dir);
  return fm_roots(c0 - 2.0 * c1 + c2, 2.0 * (c1 - c0), c0, t);
}

/* The parameter in [0, 1] (within tol) among n roots closest to `guess`,
 * clamped; -1 if none. */
static inline double fm_pick(const double *t, int n, double guess, double tol) {
  double best = 0.0, bd = INFINITY;
  int found = 0;
  for (int k = 0; k < n; k++) {
    if (t[k] < -tol || t[k] > 1.0 + tol) continue;
    double d = fabs(t[k] - guess);
    if (d < bd) bd = d, best = t[k], found = 1;
  }
  if (!found) return -1.0;
  return best < 0.0 ? 0.0 : best > 1.0 ? 1.0 : best;
}

/* Whether the parabola of a curved segment meets the closed unit square
 * only along t in [0, 1] (feature-curves §5.2: otherwise the implicit side
 * test is ambiguous inside the cell). Lines are always safe. */
static inline int fm_curve_safe(const fm_curve *c) {
  if (c->straight) return 1;
  for (int axis = 0; axis < 2; axis++)
    for (int side = 0; side < 2; side++) {
      double a = c->p[0][axis] - 2.0 * c->p[1][axis] + c->p[2][axis];
      double b = 2.0 * (c->p[1][axis] - c->p[0][axis]), k = c->p[0][axis] - side;
      double r[2];
      int n = fm_roots(a, b, k, r);
      for (int i = 0; i < n; i++) {
        if (r[i] >= -1e-9 && r[i] <= 1.0 + 1e-9) continue;
        double pt[2];
        fm_curve_eval(c, r[i], pt);
        double other = pt[1 - axis];
        if (other >= -1e-9 && other <= 1.0 + 1e-9) return 0;
      }
    }
  return 1;
}

/* The sub-curve over [t0, t1] (de Casteljau blossoms). */
static inline void fm_curve_sub(const fm_curve *c, double t0, double t1, fm_curve *out) {
  double a[2], b[2], m[2];
  fm_curve_eval(c, t0, a);
  fm_curve_eval(c, t1, b);
  /* blossom B(t0, t1) */
  double s0 = 1.0 - t0, s1 = 1.0 - t1;
  for (int k = 0; k < 2; k++)
    m[k] = s0 * s1 * c->p[0][k] + (s0 * t1 + t0 * s1) * c->p[1][k] + t0 * t1 * c->p[2][k];
  fm_curve_set(out, a, m, b, c->straight);
}

/* The tangent-line intersection of a segment from edge point a (direction
 * da) to edge point b (direction db): its middle control point. Returns 1
 * with b1 set; 2 if the segment is a straight line (both tangents along
 * the chord); 0 if there is no usable intersection (parallel lines). */
static inline int fm_control_point(const double a[2], const double da[2], const double b[2], const double db[2],
                                   double b1[2]) {
  double chord[2] = {b[0] - a[0], b[1] - a[1]};
  double cl = sqrt(chord[0] * chord[0] + chord[1] * chord[1]);
  if (!(cl > 0.0)) return 0;
  double ca = fabs(fm_cross(da, chord)) / cl, cb = fabs(fm_cross(db, chord)) / cl;
  if (ca < 1e-7 && cb < 1e-7) return 2;
  double den = fm_cross(da, db);
  if (fabs(den) < 1e-9) return 0;
  double s = fm_cross(chord, db) / den;
  b1[0] = a[0] + s * da[0];
  b1[1] = a[1] + s * da[1];
  return 1;
}

/* The partition of a cell (feature-curves §5.1, Fig. 9): edge points q[e]
 * (the midpoint where an edge has none), the vertical spoke V (q_S to q_N)
 * and horizontal spoke H (q_W to q_E), each a segment's curve or a line,
 * their crossing r, and the four chords q_k to q_{k+1} (k = S..W, chord k's
 * corner is c_{k+1}), each a segment's curve or a line. Every segment of
 * the cell is V, H or one chord. */
typedef struct fm_partition {
  double q[4][2];
  int point[4];       /* the edge has a discontinuity point */
  fm_curve V, H, chord[4];
  int v_seg, h_seg;   /* segment index (0, 1) forming V / H, or -1 */
  int chord_seg[4];
  double r[2];
  double tv, th;      /* r's parameter on V and on H */
  int ok;             /* 0: V and H do not cross inside the cell */
} fm_partition;

/* A cell as stored: edge positions, angles and flags per edge, and up to
 * two segments (their edge pairs, straight flags). */
typedef struct fm_signature {
  double pos[4], angle[4];
  int point[4];
  int nseg;
  int pair[2];     /* 1..6 */
  int straight[2];
} fm_signature;

/* Makes the segments' curves: returns 0 if a curved segment has no
 * control point (fm_control_point failed). linear: every segment straight
 * (normal-maps-discontinuities' linear variant). */
static inline int fm_segment_curves(const fm_signature *s, int linear, fm_curve seg[2]) {
  for (int k = 0; k < s->nseg; k++) {
    int a = fm_pair_edges[s->pair[k]][0], b = fm_pair_edges[s->pair[k]][1];
    double qa[2], qb[2], b1[2] = {0, 0};
    fm_edge_point(a, s->pos[a], qa);
    fm_edge_point(b, s->pos[b], qb);
    int straight = linear || s->straight[k];
    if (!straight) {
      double da[2] = {cos(s->angle[a]), sin(s->angle[a])}, db[2] = {cos(s->angle[b]), sin(s->angle[b])};
      int res = fm_control_point(qa, da, qb, db, b1);
      if (res == 0) return 0;
      straight = res == 2;
    }
    fm_curve_set(&seg[k], qa, b1, qb, straight);
  }
  return 1;
}

/* The intersection of V and H: t on V, s on H. Both lines: closed form;
 * one curve: the roots of a quadratic; two curves: Newton from the chords'
 * crossing (8 steps). Returns 0 if none inside. */
static inline int fm_cross_spokes(const fm_curve *V, const fm_curve *H, double *tv, double *th) {
  double dv[2] = {V->p[2][0] - V->p[0][0], V->p[2][1] - V->p[0][1]};
  double dh[2] = {H->p[2][0] - H->p[0][0], H->p[2][1] - H->p[0][1]};
  double den = fm_cross(dv, dh);
  if (fabs(den) < 1e-12) return 0;
  double w[2] = {H->p[0][0] - V->p[0][0], H->p[0][1] - V->p[0][1]};
  double t = fm_cross(w, dh) / den, s = fm_cross(w, dv) / den;
  if (V->straight && H->straight) {
    *tv = t, *th = s;
    return t >= -1e-9 && t <= 1.0 + 1e-9 && s >= -1e-9 && s <= 1.0 + 1e-9;
  }
  if (H->straight) {
    double r[2];
    int n = fm_curve_line(V, H->p[0], dh, r);
    t = fm_pick(r, n, t, 1e-9);
    if (t < 0.0) return 0;
    double p[2];
    fm_curve_eval(V, t, p);
    s = ((p[0] - H->p[0][0]) * dh[0] + (p[1] - H->p[0][1]) * dh[1]) / (dh[0] * dh[0] + dh[1] * dh[1]);
    *tv = t, *th = s;
    return s >= -1e-9 && s <= 1.0 + 1e-9;
  }
  if (V->straight) {
    double r[2];
    int n = fm_curve_line(H, V->p[0], dv, r);
    s = fm_pick(r, n, s, 1e-9);
    if (s < 0.0) return 0;
    double p[2];
    fm_curve_eval(H, s, p);
    t = ((p[0] - V->p[0][0]) * dv[0] + (p[1] - V->p[0][1]) * dv[1]) / (dv[0] * dv[0] + dv[1] * dv[1]);
    *tv = t, *th = s;
    return t >= -1e-9 && t <= 1.0 + 1e-9;
  }
  t = fmin(fmax(t, 0.0), 1.0);
  s = fmin(fmax(s, 0.0), 1.0);
  for (int it = 0; it < 8; it++) {
    double a[2], b[2];
    fm_curve_eval(V, t, a);
    fm_curve_eval(H, s, b);
    double f[2] = {a[0] - b[0], a[1] - b[1]};
    double ja[2], jb[2]; /* dV/dt, -dH/ds */
    for (int k = 0; k < 2; k++) {
      ja[k] = 2.0 * ((1.0 - t) * (V->p[1][k] - V->p[0][k]) + t * (V->p[2][k] - V->p[1][k]));
      jb[k] = -2.0 * ((1.0 - s) * (H->p[1][k] - H->p[0][k]) + s * (H->p[2][k] - H->p[1][k]));
    }
    double det = fm_cross(ja, jb);
    if (fabs(det) < 1e-14) return 0;
    double dt = fm_cross(f, jb) / det, ds = fm_cross(ja, f) / det;
    t -= dt;
    s -= ds;
  }
  double a[2], b[2];
  fm_curve_eval(V, t, a);
  fm_curve_eval(H, s, b);
  *tv = t, *th = s;
  return fabs(a[0] - b[0]) + fabs(a[1] - b[1]) < 1e-9 && t >= -1e-9 && t <= 1.0 + 1e-9 && s >= -1e-9 &&
         s <= 1.0 + 1e-9;
}

/* Builds the partition from a signature and its segments' curves. */
static inline void fm_partition_make(const fm_signature *s, const fm_curve seg[2], fm_partition *P) {
  for (int e = 0; e < 4; e++) {
    P->point[e] = s->point[e];
    fm_edge_point(e, s->point[e] ? s->pos[e] : 0.5, P->q[e]);
  }
  P->v_seg = P->h_seg = -1;
  for (int k = 0; k < 4; k++) P->chord_seg[k] = -1;
  for (int k = 0; k < s->nseg; k++) {
    int a = fm_pair_edges[s->pair[k]][0], b = fm_pair_edges[s->pair[k]][1];
    if (a == FM_S && b == FM_N) P->v_seg = k;
    else if (a == FM_E && b == FM_W) P->h_seg = k;
    else P->chord_seg[(a == FM_S && b == FM_W) ? FM_W : a] = k; /* chord k joins edges k and k+1 */
  }
  static const double none[2] = {0, 0};
  /* V runs S -> N, H runs W -> E, chord k runs edge k -> edge k+1. */
  if (P->v_seg >= 0) P->V = seg[P->v_seg];
  else fm_curve_set(&P->V, P->q[FM_S], none, P->q[FM_N], 1);
  if (P->h_seg >= 0) {
    const fm_curve *c = &seg[P->h_seg]; /* stored E -> W (pair order): reverse */
    fm_curve_set(&P->H, c->p[2], c->p[1], c->p[0], c->straight);
  } else {
    fm_curve_set(&P->H, P->q[FM_W], none, P->q[FM_E], 1);
  }
  for (int k = 0; k < 4; k++) {
    int j = P->chord_seg[k];
    if (j < 0) {
      fm_curve_set(&P->chord[k], P->q[k], none, P->q[(k + 1) % 4], 1);
    } else {
      const fm_curve *c = &seg[j];
      /* the segment's curve runs from its lower edge index: chord W (3 -> 0)
       * is stored S -> W and is reversed */
      if (k == FM_W) fm_curve_set(&P->chord[k], c->p[2], c->p[1], c->p[0], c->straight);
      else P->chord[k] = *c;
    }
  }
  P->ok = fm_cross_spokes(&P->V, &P->H, &P->tv, &P->th);
  if (P->ok) {
    fm_curve_eval(&P->V, P->tv, P->r);
  } else {
    P->r[0] = P->r[1] = 0.5;
    P->tv = P->th = 0.5;
  }
}

/* The quadrant of q: the corner whose quadrant holds it (west of V and
 * south of H: c0, and so on). */
static inline int fm_quadrant(const fm_partition *P, const double q[2]) {
  int west = fm_left(&P->V, q), north = fm_left(&P->H, q);
  return north ? (west ? 3 : 2) : (west ? 0 : 1);
}

/* Whether q is on the corner's side of chord k (right of it: the chords
 * run counter-clockwise round the cell). */
static inline int fm_corner_side(const fm_partition *P, int k, const double q[2]) {
  return !fm_left(&P->chord[k], q);
}

/* The signature of cell (ci, cj) as stored in the maps. */
static inline void fm_cell_signature(const ch_featmap *m, int ci, int cj, fm_signature *s) {
  int R1 = m->resolution + 1;
  size_t c = (size_t)ci * R1 + cj, east = c + 1, north = c + R1;
  const float *ec = m->edge + 4 * c, *ee = m->edge + 4 * east, *en = m->edge + 4 * north;
  s->pos[FM_S] = ec[0], s->angle[FM_S] = ec[1], s->point[FM_S] = (m->config[c] & CH_FM_POINT_S) != 0;
  s->pos[FM_W] = ec[2], s->angle[FM_W] = ec[3], s->point[FM_W] = (m->config[c] & CH_FM_POINT_W) != 0;
  s->pos[FM_E] = ee[2], s->angle[FM_E] = ee[3], s->point[FM_E] = (m->config[east] & CH_FM_POINT_W) != 0;
  s->pos[FM_N] = en[0], s->angle[FM_N] = en[1], s->point[FM_N] = (m->config[north] & CH_FM_POINT_S) != 0;
  uint32_t w = m->config[c];
  s->nseg = 0;
  for (int k = 0; k < 2; k++) {
    int p = (int)((w >> (CH_FM_SEG_BITS * k)) & CH_FM_SEG_MASK);
    if (!p) continue;
    s->pair[s->nseg] = p;
    s->straight[s->nseg] = (w & (k ? CH_FM_STRAIGHT1 : CH_FM_STRAIGHT0)) != 0;
    s->nseg++;
  }
}

#endif
