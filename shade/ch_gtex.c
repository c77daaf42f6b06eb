/* Path-based groove textures (ch_gtex.h): the representation of
 * path-based-grooves §4 and its rendering along rays (§5).
 *
 * Why one file of about 2,000 lines: it is one texture method, and its
 * build and its shader read the same packed texel layout through the same
 * loaders (elements, grooves, cells, the profile's value and slope, the
 * closest point on an element); the build uses them to bound h per cell
 * as the shader will see it. Cut at build / shader, both halves would need
 * that layout and those loaders in a shared header, which is what keeps a
 * GLSL twin easy to follow from one file.
 *
 * Departures from the paper, and why:
 * - The paper finds the visible facet per element and combines elements by
 *   CSG with priority tags for ends, corners and crossings (§5.3-5.4).
 *   docs/spec.md §3's h is defined by the nearest point of each path (rounded caps,
 *   the sector rule at joints) and the carve-by-minimum rule; a union of
 *   per-element profiles equals it only for symmetric profiles that fall
 *   monotonically away from the path. So the CSG here is over the ray's
 *   segments between events (every parameter where the ray can cross a
 *   facet of any element or where h can jump), and each segment is tested
 *   once against h evaluated exactly from the textures: the first solid
 *   segment is the hit. The events are the paper's per-profile
 *   intersections, in closed form for straight elements and around end
 *   points (circles), so nothing is sampled on straight paths.
 * - Curved (quadratic) elements: the paper uses the tangent line at the
 *   point nearest to the current point (§5.2); here the ray's signed
 *   distance to the quadratic itself is used: convex along the ray within
 *   the element's least radius of curvature, so each event function's
 *   values and rates at the ends of the ray's stretch over the element
 *   bracket its roots (refined by safeguarded Newton); the u ellipse's,
 *   not convex on the side the curve turns to, is split where bounds on
 *   its curvature cannot tell; grooves wider than that radius allows are
 *   sampled. `paper` keeps the tangent line, per cell, to measure the
 *   approximation.
 * - Events are only where h can change sides with the ray: facets inside
 *   the band with their foot on the element, jumps of the profile (rims
 *   too where raised and carved grooves meet), the base plane; a kink of
 *   a continuous profile needs none.
 * - The grid keeps min and max h per cell (the paper: the max only).
 * - Region sampling (§5.7) in closed form for one straight groove; the
 *   paper's supersampling is left to the caller (the study supersamples
 *   every pixel; bench_aa compares the two).
 * Everything per ray reads only `grid` and `data`. */
#include "ch_gtex.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ch_bezier.h"
#include "ch_groove.h"
#include "ch_math.h"

enum { ELEM_TEXELS = 3, GROOVE_TEXELS = 2 };
enum { FLAG_QUAD = 1, FLAG_OPEN_START = 2, FLAG_OPEN_END = 4 };
enum { PROFILE_POLY = 0, PROFILE_ELLIPSE = 1 };
/* Largest integer a float holds exactly. */
#define FLOAT_INT_MAX 16777216.0

/* Events kept per pass in a cell (more are handled by further passes). */
enum { EV_CAP = 96, MAX_PASSES = 64 };
/* Samples along the ray per quadratic element and cell, at most. */
enum { QUAD_SAMPLES_MAX = 24 };
/* Grid cells with the same list walked as one stretch, at most. */
enum { MERGE_MAX = 16 };

/* Comparisons (fmin and fmax are calls at -O2); no NaN reaches them. */
static inline double mn(double a, double b) { return a < b ? a : b; }
static inline double mx(double a, double b) { return a > b ? a : b; }
static inline double len2d(double x, double y) { return sqrt(x * x + y * y); }

/* ---- reading the textures ---- */

static inline const float *texel(const ch_gtex *g, int i) { return g->data + 4 * (size_t)i; }

/* An element as doubles. */
typedef struct elem {
  double p[3][2];
  int quad, open_start, open_end;
  double tin[2], tout[2]; /* the neighbours' tangents at the joints */
  int groove;             /* index in the groove table */
  double box[4];          /* umin vmin umax vmax of the control points */
  double t0[2], t1[2];    /* unit tangents at its ends (quadratics: once framed) */
  int framed;
  int ready;              /* elem_ready has run */
  double rho2;            /* quadratics: the square of the least radius of
                             curvature (within it of the curve every point
                             has one foot) */
  double dev;             /* how far the curve strays from its chord:
                             |p0 - 2 p1 + p2| / 4 (0 when straight) */
  /* Quadratics, for the closest point: B(tau) = p0 + tau (da + tau hb),
   * B' = da + tau db (hb = db / 2); the chord c and |c|^2. */
  double da[2], db[2], hb[2], c[2], cc;
} elem;

static void elem_frame(elem *E) {
  E->framed = 1;
  if (!E->quad) {
    double d[2] = {E->p[2][0] - E->p[0][0], E->p[2][1] - E->p[0][1]}, l = sqrt(d[0] * d[0] + d[1] * d[1]);
    E->t0[0] = E->t1[0] = l > 0.0 ? d[0] / l : 0.0;
    E->t0[1] = E->t1[1] = l > 0.0 ? d[1] / l : 0.0;
  } else {
    ch_bezier_end_tangents(E->p, E->t0, E->t1);
  }
}

static void elem_box(elem *E) {
  E->box[0] = mn(mn(E->p[0][0], E->p[1][0]), E->p[2][0]);
  E->box[1] = mn(mn(E->p[0][1], E->p[1][1]), E->p[2][1]);
  E->box[2] = mx(mx(E->p[0][0], E->p[1][0]), E->p[2][0]);
  E->box[3] = mx(mx(E->p[0][1], E->p[1][1]), E->p[2][1]);
}

static void elem_chord(elem *E) {
  E->c[0] = E->p[2][0] - E->p[0][0], E->c[1] = E->p[2][1] - E->p[0][1];
  E->cc = E->c[0] * E->c[0] + E->c[1] * E->c[1];
}

/* Reads element e: its points, flags and box. What the closest point and
 * the events need besides (elem_ready) waits until a ray or a point comes
 * within reach of the box: a cell lists elements many rays pass by. */
static void load_elem(const ch_gtex *g, int e, elem *E) {
  const float *a = texel(g, g->element_base + ELEM_TEXELS * e), *b = a + 4, *c = a + 8;
  E->p[0][0] = a[0], E->p[0][1] = a[1], E->p[2][0] = a[2], E->p[2][1] = a[3];
  E->p[1][0] = b[0], E->p[1][1] = b[1];
  E->groove = (int)b[2];
  int flags = (int)b[3];
  E->quad = flags & FLAG_QUAD;
  E->open_start = (flags & FLAG_OPEN_START) != 0;
  E->open_end = (flags & FLAG_OPEN_END) != 0;
  E->tin[0] = c[0], E->tin[1] = c[1], E->tout[0] = c[2], E->tout[1] = c[3];
  if (!E->quad) {
    E->p[1][0] = 0.5 * (E->p[0][0] + E->p[2][0]);
    E->p[1][1] = 0.5 * (E->p[0][1] + E->p[2][1]);
  }
  elem_box(E);
  E->ready = 0;
  E->framed = 0;
}

/* The chord, how far the curve strays from it, a quadratic's power form
 * and least radius, a straight element's frame. */
static void elem_ready(elem *E) {
  E->ready = 1;
  elem_chord(E);
  E->dev = E->quad ? 0.25 * len2d(E->p[0][0] - 2.0 * E->p[1][0] + E->p[2][0], E->p[0][1] - 2.0 * E->p[1][1] + E->p[2][1])
                   : 0.0;
  /* A straight element's frame is cheap; a quadratic's waits until a ray
   * comes within its band. */
  if (!E->quad) {
    elem_frame(E);
    return;
  }
  /* B'(t) = a + t b, B'' = b: the curvature |a x b| / |B'|^3 is largest
   * where |B'| is least. */
  double *da = E->da, *db = E->db;
  da[0] = 2.0 * (E->p[1][0] - E->p[0][0]), da[1] = 2.0 * (E->p[1][1] - E->p[0][1]);
  db[0] = 2.0 * (E->p[0][0] - 2.0 * E->p[1][0] + E->p[2][0]), db[1] = 2.0 * (E->p[0][1] - 2.0 * E->p[1][1] + E->p[2][1]);
  E->hb[0] = 0.5 * db[0], E->hb[1] = 0.5 * db[1];
  double bb = db[0] * db[0] + db[1] * db[1], K = fabs(da[0] * db[1] - da[1] * db[0]);
  double tm = bb > 0.0 ? -(da[0] * db[0] + da[1] * db[1]) / bb : 0.0;
  tm = tm < 0.0 ? 0.0 : tm > 1.0 ? 1.0 : tm;
  double v[2] = {da[0] + tm * db[0], da[1] + tm * db[1]}, v2 = v[0] * v[0] + v[1] * v[1];
  E->rho2 = K > 0.0 ? v2 * v2 * v2 / (K * K) : INFINITY;
}

/* A groove's cross-section and scale as doubles. */
typedef struct groove {
  double w, d;
  int priority, curve;
  int ellipse;          /* the u profile: -sqrt(1 - 4 t^2) */
  int n;                /* polyline points */
  const float *pts;     /* their (t, P): read from the data texture where
                           used, as a shader would (a copy per groove was
                           most of what loading a cell cost) */
  int nb;               /* break values of t: points, 0 and +-1/2 */
  const float *brk;     /* (in the texture too) */
  int mask;             /* bit k: P jumps at break k */
  int raises, carves;   /* d P takes positive, negative values */
  double lowest;        /* the least value of d P (0 included) */
  int asym;             /* P(t) != P(-t): the side matters */
  int monotone;         /* carved, symmetric, P <= 0 and not falling as |t|
                           grows: d P(s / w) grows with |s| (v, u, box) */
} groove;

/* A cross-section's point i (t, P), break k and whether P jumps there. */
#define PT(G, i) ((double)(G)->pts[2 * (i)])
#define PH(G, i) ((double)(G)->pts[2 * (i) + 1])
#define BRK(G, k) ((double)(G)->brk[k])
#define JUMP(G, k) (((G)->mask >> (k)) & 1)

static double prof_eval(const groove *G, double t);

static void load_groove(const ch_gtex *g, int k, groove *G) {
  const float *a = texel(g, g->curve_base + GROOVE_TEXELS * k), *b = a + 4;
  G->w = a[0];
  G->d = a[1];
  int prof = (int)a[2];
  G->priority = (int)a[3];
  G->curve = (int)b[0];
  /* The cross-section's block (written by profile_block). */
  const float *ph = texel(g, prof), *pts = ph + 8; /* two points a texel */
  G->ellipse = (int)ph[0] == PROFILE_ELLIPSE;
  int n = G->n = (int)ph[1];
  G->nb = (int)ph[2];
  const float *brk = pts + 4 * ((n + 1) / 2);
  /* Derived at build time (groove_derive), kept in the groove's texel. */
  int flags = (int)b[2], mask = (int)b[3];
  G->asym = (flags & 1) != 0;
  G->raises = (flags & 2) != 0;
  G->carves = (flags & 4) != 0;
  G->pts = pts;
  G->brk = brk;
  G->mask = mask;
  double pmin = ph[4], pmax = ph[5];
  G->lowest = G->d > 0.0 ? G->d * pmin : G->d * pmax;
  G->monotone = (int)ph[3] && !G->asym && G->d > 0.0;
}

/* Texels of a cross-section's block of np points: a header (kind, np,
 * breaks, monotone shape), the range (least and greatest P), the points
 * two a texel, the breaks four a texel (at most np + 3). */
static int profile_texels(int np) { return 2 + (np + 1) / 2 + (np + 3 + 3) / 4; }

/* Writes a cross-section's block at ph: what load_groove reads, with what
 * it derives from the points once: the breaks (-1/2, 0, 1/2 and the
 * points' t, each once), the range of P (the ellipse's down to -1), and
 * whether P <= 0 does not fall as |t| grows (with a symmetric profile and
 * a positive depth, d P(s / w) then grows with |s|: v, u, box). */
static void profile_block(float *ph, int kind, int np, const double pt[][2]) {
  ph[0] = (float)kind, ph[1] = (float)np;
  float *pts = ph + 8, *brk = pts + 4 * ((np + 1) / 2);
  int nb = 3, shape_monotone = 1;
  brk[0] = -0.5f, brk[1] = 0.0f, brk[2] = 0.5f;
  double pmin = kind == PROFILE_ELLIPSE ? -1.0 : 0.0, pmax = 0.0, t_prev = 0.0, h_prev = 0.0;
  for (int k = 0; k < np; k++) {
    float tf = (float)pt[k][0], hf = (float)pt[k][1];
    pts[2 * k] = tf, pts[2 * k + 1] = hf;
    double t = tf, h = hf;
    pmin = mn(pmin, h), pmax = mx(pmax, h);
    int seen = t == -0.5 || t == 0.0 || t == 0.5;
    for (int j = 3; j < nb && !seen; j++) seen = brk[j] == t;
    if (!seen) brk[nb++] = tf;
    shape_monotone = shape_monotone && h <= 0.0 && (k == 0 || t <= 0.0 || (t >= t_prev && h >= h_prev));
    t_prev = t, h_prev = h;
  }
  ph[2] = (float)nb, ph[3] = (float)shape_monotone;
  ph[4] = (float)pmin, ph[5] = (float)pmax;
}

/* Where h can jump: where P does (a side flip at 0 included); a rim where
 * P falls to 0 continuously matters only next to raised grooves (the
 * carve-over-raise rule then jumps there: cell_events). Returns the flags
 * and the mask of breaks with jumps that load_groove reads. */
static void groove_derive(groove *G, int *flags, int *mask) {
  double pmin = 0.0, pmax = 0.0;
  int asym = 0;
  *mask = 0;
  for (int k = 0; k < G->nb; k++) {
    double b = BRK(G, k), e = 1e-9;
    if (fabs(prof_eval(G, b - e) - prof_eval(G, b + e)) > 1e-6) *mask |= 1 << k;
    asym |= fabs(prof_eval(G, b) - prof_eval(G, -b)) > 1e-12 || fabs(prof_eval(G, b + e) - prof_eval(G, -b - e)) > 1e-9;
  }
  for (int i = 0; i < G->n; i++) pmin = PH(G, i) < pmin ? PH(G, i) : pmin, pmax = PH(G, i) > pmax ? PH(G, i) : pmax;
  if (G->ellipse) pmin = -1.0;
  int raises = G->d > 0.0 ? pmax > 0.0 : pmin < 0.0, carves = G->d > 0.0 ? pmin < 0.0 : pmax > 0.0;
  *flags = asym | raises << 1 | carves << 2;
}

/* P(t): the ellipse, or the polyline as ch_profile_eval reads custom
 * profiles (0 outside and at the outer points; at a jump, the value of
 * smaller magnitude). */
static double prof_eval(const groove *G, double t) {
  if (G->ellipse) return fabs(t) < 0.5 ? -sqrt(1.0 - 4.0 * t * t) : 0.0;
  int n = G->n;
  if (n < 1 || t <= PT(G, 0) || t >= PT(G, n - 1)) return 0.0;
  int exact = 0;
  double best = 0.0;
  for (int i = 0; i < n; i++)
    if (PT(G, i) == t && (!exact || fabs(PH(G, i)) < fabs(best))) best = PH(G, i), exact = 1;
  if (exact) return best;
  for (int i = 0; i + 1 < n; i++)
    if (t > PT(G, i) && t < PT(G, i + 1)) return PH(G, i) + (t - PT(G, i)) / (PT(G, i + 1) - PT(G, i)) * (PH(G, i + 1) - PH(G, i));
  return 0.0;
}

/* P'(t): the piece holding t (the one to the right at a point). */
static double prof_slope(const groove *G, double t) {
  if (G->ellipse) return fabs(t) < 0.5 ? 4.0 * t / sqrt(1.0 - 4.0 * t * t) : 0.0;
  for (int i = 0; i + 1 < G->n; i++)
    if (t >= PT(G, i) && t < PT(G, i + 1)) return (PH(G, i + 1) - PH(G, i)) / (PT(G, i + 1) - PT(G, i));
  return 0.0;
}

/* ---- exact geometry of one element ---- */

static void elem_point(const elem *E, double tau, double out[2]) {
  if (!E->quad) {
    out[0] = E->p[0][0] + tau * (E->p[2][0] - E->p[0][0]);
    out[1] = E->p[0][1] + tau * (E->p[2][1] - E->p[0][1]);
  } else {
    ch_bezier_eval(E->p, tau, out);
  }
}

static void elem_tangent(const elem *E, double tau, double out[2]) {
  if (!E->quad || (E->framed && tau <= 0.0)) {
    out[0] = E->t0[0], out[1] = E->t0[1];
  } else if (E->framed && tau >= 1.0) {
    out[0] = E->t1[0], out[1] = E->t1[1];
  } else {
    ch_bezier_tangent(E->p, tau < 0.0 ? 0.0 : tau > 1.0 ? 1.0 : tau, out);
  }
}

/* docs/spec.md §3's side of q for the closest point (tau) on this element: its
 * tangent inside, the tangent line at an open end, the sector at a joint
 * (as ch_curve_side). */
static int elem_side(const elem *E, double tau, const double q[2]) {
  double c[2], here[2];
  elem_point(E, tau, c);
  double dq[2] = {q[0] - c[0], q[1] - c[1]};
  if (tau > 0.0 && tau < 1.0) {
    if (E->quad) {
      /* Only the sign matters: the derivative, unnormalised, unless it
       * (nearly) vanishes (ch_bezier_tangent's limits then). */
      double D[2] = {2.0 * ((1.0 - tau) * (E->p[1][0] - E->p[0][0]) + tau * (E->p[2][0] - E->p[1][0])),
                     2.0 * ((1.0 - tau) * (E->p[1][1] - E->p[0][1]) + tau * (E->p[2][1] - E->p[1][1]))};
      double chord2 = (E->p[2][0] - E->p[0][0]) * (E->p[2][0] - E->p[0][0]) + (E->p[2][1] - E->p[0][1]) * (E->p[2][1] - E->p[0][1]);
      if (D[0] * D[0] + D[1] * D[1] > 1e-12 * chord2) return ch_cross2(D, dq) >= 0.0 ? 1 : -1;
    }
    elem_tangent(E, tau, here);
    return ch_cross2(here, dq) >= 0.0 ? 1 : -1;
  }
  int at_start = tau <= 0.0;
  elem_tangent(E, at_start ? 0.0 : 1.0, here);
  if (at_start ? E->open_start : E->open_end) return ch_cross2(here, dq) >= 0.0 ? 1 : -1;
  return at_start ? ch_joint_side(E->tin, here, dq) : ch_joint_side(here, E->tout, dq);
}

/* A curved element replaced by the straight line tangent to it at the
 * point nearest to ref (the paper's §5.2 approximation), as a long
 * straight element with the same ends' flags. */
static void paper_line(elem *E, const double ref[2]) {
  double tau, c[2], tg[2];
  ch_bezier_closest(E->p, 0, ref, &tau);
  ch_bezier_eval(E->p, tau, c);
  ch_bezier_tangent(E->p, tau, tg);
  /* The line through c along tg, as long as the quadratic's chord plus the
   * band on both sides, so that its ends stay outside the cell's reach. */
  double L = len2d(E->p[2][0] - E->p[0][0], E->p[2][1] - E->p[0][1]) + 1.0;
  for (int k = 0; k < 2; k++) {
    E->p[0][k] = c[k] - L * tg[k];
    E->p[2][k] = c[k] + L * tg[k];
    E->p[1][k] = c[k];
  }
  E->quad = 0;
  E->dev = 0.0;
  E->open_start = E->open_end = 1;
  elem_box(E);
  elem_chord(E);
  elem_frame(E);
  E->ready = 1;
}

/* Squared distance from q to the element and the closest parameter. */
/* Squared distance from q to the element and the closest parameter. A
 * quadratic closer to q than its least radius of curvature has one foot
 * for q (the normals meet no nearer than the evolute): Newton's method on
 * (B(t) - q) . B'(t) from the chord's projection finds it in a few steps,
 * clamped to the element's ends; farther away, the robust root finder of
 * ch_bezier_closest. */
/* (Through copies: GCC 12 at -O1 with the sanitizers warns, wrongly,
 * that passing E->p here reads past a 16-byte object.) */
static double robust_closest(const elem *E, const double q[2], double *tau) {
  double P[3][2], Q[2] = {q[0], q[1]};
  memcpy(P, E->p, sizeof P);
  return ch_bezier_closest(P, !E->quad, Q, tau);
}

/* From start (a parameter in [0, 1], or -1: the chord's projection), and
 * with the foot and the derivative there when asked (quad_s). */
static double elem_closest_from(const elem *E, const double q[2], double start, double *tau, double foot[2],
                                double deriv[2]) {
  const double *p0 = E->p[0], *a = E->da, *b = E->db, *hb = E->hb, *c = E->c;
  double w[2] = {q[0] - p0[0], q[1] - p0[1]}, cc = E->cc; /* q - p0 */
  double t = cc > 0.0 ? (w[0] * c[0] + w[1] * c[1]) / cc : 0.5;
  t = t < 0.0 ? 0.0 : t > 1.0 ? 1.0 : t;
  /* A point on the chord's box within the least radius is within it of
   * the curve: Newton stays in the basin. */
  double dx = w[0] - t * c[0], dy = w[1] - t * c[1];
  double dev2 = 0.0625 * (b[0] * b[0] + b[1] * b[1]); /* (|p0 - 2 p1 + p2| / 4)^2, the chord's distance to the curve */
  int robust = !(dx * dx + dy * dy + dev2 < 0.25 * E->rho2);
  if (!robust && start >= 0.0) t = start;
  /* Quadratic convergence: once a step is below 1e-8 the next is below
   * 1e-16, so take it and stop. Asked for the foot (quad_s, the events'
   * distance), a step below 1e-5 is the last: the distance is stationary
   * in tau at the foot, so the foot's error after it (about 1e-10) moves
   * it by the square, below rounding; the foot and its derivative then
   * only steer Newton along the ray. */
  const double stop = foot ? 1e-5 : 1e-8;
  for (int it = 0, last = 0; it < 16 && !last && !robust; it++) {
    double r[2] = {t * (a[0] + t * hb[0]) - w[0], t * (a[1] + t * hb[1]) - w[1]}; /* B - q */
    double D[2] = {a[0] + t * b[0], a[1] + t * b[1]};
    double f = r[0] * D[0] + r[1] * D[1], df = D[0] * D[0] + D[1] * D[1] + r[0] * b[0] + r[1] * b[1];
    if (!(df > 0.0)) {
      robust = 1;
      break;
    }
    double tn = t - f / df;
    tn = tn < 0.0 ? 0.0 : tn > 1.0 ? 1.0 : tn;
    last = fabs(tn - t) <= stop;
    t = tn;
  }
  double d2;
  if (robust) {
    d2 = robust_closest(E, q, &t);
    if (!foot) {
      *tau = t;
      return d2;
    }
  }
  double x[2] = {p0[0] + t * (a[0] + t * hb[0]), p0[1] + t * (a[1] + t * hb[1])};
  if (!robust) d2 = (x[0] - q[0]) * (x[0] - q[0]) + (x[1] - q[1]) * (x[1] - q[1]);
  *tau = t;
  if (foot) {
    foot[0] = x[0], foot[1] = x[1];
    deriv[0] = a[0] + t * b[0], deriv[1] = a[1] + t * b[1];
  }
  return d2;
}

/* Squared distance from q to the element's chord and the closest
 * parameter (ch_bezier_closest's straight case, on the chord kept). */
static inline double chord_closest(const elem *E, const double q[2], double *tau) {
  double w[2] = {q[0] - E->p[0][0], q[1] - E->p[0][1]};
  double t = E->cc > 0.0 ? (w[0] * E->c[0] + w[1] * E->c[1]) / E->cc : 0.0;
  t = t < 0.0 ? 0.0 : t > 1.0 ? 1.0 : t;
  double x = E->p[0][0] + t * E->c[0] - q[0], y = E->p[0][1] + t * E->c[1] - q[1];
  *tau = t;
  return x * x + y * y;
}

static double elem_closest(elem *E, const double q[2], double *tau) {
  if (!E->ready) elem_ready(E);
  if (!E->quad) return chord_closest(E, q, tau);
  return elem_closest_from(E, q, -1.0, tau, NULL, NULL);
}

/* ---- h at a point from a cell's elements ---- */

typedef struct cell {
  int n;
  elem e[CH_GTEX_MAX_CELL_ITEMS];
  int ng;                          /* distinct grooves, in list order */
  int gfirst[CH_GTEX_MAX_CELL_ITEMS + 1]; /* elements of groove run r: gfirst[r]..gfirst[r+1]-1 */
  groove g[CH_GTEX_MAX_CELL_ITEMS];
  int mixed;                       /* raised and carved grooves meet here */
  int raises;                      /* some groove here raises the surface */
  int elem_id[CH_GTEX_MAX_CELL_ITEMS];   /* each element's index in the texture */
  int groove_id[CH_GTEX_MAX_CELL_ITEMS]; /* each run's groove index */
} cell;

typedef struct point_state {
  double min_carve, max_raise;
  int carve_run, raise_run;
  double carve_s, raise_s;
  int carve_elem, raise_elem;
  double carve_tau, raise_tau;
  int owner_run, owner_priority;
  double owner_g;
} point_state;

static int decides_height(double g, double g_old) {
  if (g < 0.0) return g_old > 0.0 || g < g_old;
  return g_old > 0.0 && g > g_old;
}

/* Squared distance from q to box b (umin vmin umax vmax; 0 inside): it
 * bounds an element's distance from below. */
static inline double box_dist2(const double b[4], const double q[2]) {
  double dx = mx(mx(b[0] - q[0], q[0] - b[2]), 0.0), dy = mx(mx(b[1] - q[1], q[1] - b[3]), 0.0);
  return dx * dx + dy * dy;
}

/* One groove's value d P(s / w) at q from its nearest element in the cell
 * (ties to the first), with its signed distance, element and parameter; 0
 * beyond its band. */
static double groove_value(cell *C, int r, const double q[2], double *s, int *be, double *best_tau) {
  const groove *G = &C->g[r];
  double best = INFINITY;
  *be = -1;
  *best_tau = 0.0;
  double half = 0.5 * G->w, reach2 = half * half;
  for (int k = C->gfirst[r]; k < C->gfirst[r + 1]; k++) {
    /* The box's distance bounds the element's: skip elements beyond the
     * profile's support or farther than the best so far. */
    double bd2 = box_dist2(C->e[k].box, q);
    if (bd2 >= reach2 || bd2 > best) continue;
    double tau, d2 = elem_closest(&C->e[k], q, &tau);
    if (d2 < best) best = d2, *best_tau = tau, *be = k;
  }
  if (*be < 0 || !(best < half * half)) return 0.0;
  *s = sqrt(best) * elem_side(&C->e[*be], *best_tau, q);
  return G->d * prof_eval(G, *s / G->w);
}

/* The CSG rule of docs/spec.md §3 over the grooves of a cell at q, as
 * ch_groove_field_eval applies it (the nearest element per groove, ties to
 * the first; a tie tolerance for the deciding groove; owner by priority). */
static double cell_h(cell *C, const double q[2], point_state *ps) {
  point_state st = {.min_carve = 0.0, .max_raise = 0.0, .carve_run = -1, .raise_run = -1, .owner_run = -1};
  for (int r = 0; r < C->ng; r++) {
    const groove *G = &C->g[r];
    double s, best_tau;
    int be;
    double gv = groove_value(C, r, q, &s, &be, &best_tau);
    if (gv == 0.0) continue;
    double tie = 1e-12 * fabs(gv);
    if (gv < st.min_carve) {
      if (st.carve_run < 0 || gv < st.min_carve - tie)
        st.carve_run = r, st.carve_s = s, st.carve_elem = be, st.carve_tau = best_tau;
      st.min_carve = gv;
    }
    if (gv > st.max_raise) {
      if (st.raise_run < 0 || gv > st.max_raise + tie)
        st.raise_run = r, st.raise_s = s, st.raise_elem = be, st.raise_tau = best_tau;
      st.max_raise = gv;
    }
    if (st.owner_run < 0 || G->priority > st.owner_priority ||
        (G->priority == st.owner_priority && decides_height(gv, st.owner_g)))
      st.owner_run = r, st.owner_priority = G->priority, st.owner_g = gv;
  }
  if (ps) *ps = st;
  return st.min_carve < 0.0 ? st.min_carve : st.max_raise;
}

/* The active groove's run, signed distance, element and parameter. */
static int active_of(const point_state *st, double *s, int *e, double *tau) {
  if (st->min_carve < 0.0) {
    *s = st->carve_s, *e = st->carve_elem, *tau = st->carve_tau;
    return st->carve_run;
  }
  if (st->max_raise > 0.0) {
    *s = st->raise_s, *e = st->raise_elem, *tau = st->raise_tau;
    return st->raise_run;
  }
  return -1;
}

/* The unit gradient of the signed distance at q (s = side |q - foot|):
 * from the foot, or the left normal on the curve. */
static void distance_gradient(const elem *E, double tau, double s, const double q[2], double out[2]) {
  double c[2];
  elem_point(E, tau, c);
  double d[2] = {q[0] - c[0], q[1] - c[1]}, l = len2d(d[0], d[1]);
  if (l > 1e-12) {
    double sg = s >= 0.0 ? 1.0 : -1.0;
    out[0] = sg * d[0] / l;
    out[1] = sg * d[1] / l;
  } else {
    double tg[2];
    elem_tangent(E, tau, tg);
    out[0] = -tg[1];
    out[1] = tg[0];
  }
}

static void fill_sample(const cell *C, const point_state *st, double h, const double q[2], ch_gtex_sample *out) {
  out->h = h;
  out->grad[0] = out->grad[1] = 0.0;
  double s = 0.0, tau = 0.0;
  int e = -1, r = active_of(st, &s, &e, &tau);
  out->active = r >= 0 ? C->g[r].curve : -1;
  out->s = s;
  out->owner = st->owner_run >= 0 ? C->g[st->owner_run].curve : -1;
  if (r < 0) return;
  const groove *G = &C->g[r];
  double slope = prof_slope(G, s / G->w);
  if (slope == 0.0) return;
  double gs[2];
  distance_gradient(&C->e[e], tau, s, q, gs);
  double k = G->d / G->w * slope;
  out->grad[0] = k * gs[0];
  out->grad[1] = k * gs[1];
}

/* Loads the elements of grid cell ci (and their grooves, one per run).
 * prev (or NULL): the cell the ray read before, whose elements and
 * grooves are copied where the lists share them (a groove's elements run
 * through many cells along a ray; the lists are in element order, so one
 * merge finds them); what a copy holds is what loading gives. */
static void load_cell(const ch_gtex *g, int ci, cell *C, const cell *prev) {
  const float *gt = g->grid + 4 * (size_t)ci;
  int first = (int)gt[0], n = (int)gt[1];
  C->n = n;
  C->ng = 0;
  int last_groove = -1, j = 0, jg = 0;
  for (int k = 0; k < n; k++) {
    int e = (int)texel(g, first + k / 4)[k % 4];
    C->elem_id[k] = e;
    if (prev)
      while (j < prev->n && prev->elem_id[j] < e) j++;
    if (prev && j < prev->n && prev->elem_id[j] == e) C->e[k] = prev->e[j];
    else load_elem(g, e, &C->e[k]);
    if (C->e[k].groove != last_groove) {
      last_groove = C->e[k].groove;
      C->gfirst[C->ng] = k;
      C->groove_id[C->ng] = last_groove;
      if (prev)
        while (jg < prev->ng && prev->groove_id[jg] < last_groove) jg++;
      if (prev && jg < prev->ng && prev->groove_id[jg] == last_groove) C->g[C->ng] = prev->g[jg];
      else load_groove(g, last_groove, &C->g[C->ng]);
      C->ng++;
    }
  }
  C->gfirst[C->ng] = n;
  int raises = 0, carves = 0;
  for (int r = 0; r < C->ng; r++) raises |= C->g[r].raises, carves |= C->g[r].carves;
  C->mixed = raises && carves;
  C->raises = raises;
}

static int cell_index(const ch_gtex *g, double u, double v) {
  int G = g->resolution;
  int i = (int)floor(u * G), j = (int)floor(v * G);
  i = i < 0 ? 0 : i >= G ? G - 1 : i;
  j = j < 0 ? 0 : j >= G ? G - 1 : j;
  return j * G + i;
}

/* ch_gtex_eval with the cell held in C (*loaded: its index, or -1), so a
 * ray's last cell is not read twice. */
static double eval_in(const ch_gtex *g, double u, double v, cell *C, int *loaded, ch_gtex_sample *detail) {
  if (detail) memset(detail, 0, sizeof *detail), detail->active = detail->owner = -1;
  if (!(u >= 0.0 && u <= 1.0 && v >= 0.0 && v <= 1.0)) return 0.0;
  int ci = cell_index(g, u, v);
  if (*loaded != ci) {
    load_cell(g, ci, C, NULL);
    *loaded = ci;
  }
  const double q[2] = {u, v};
  point_state st;
  double h = cell_h(C, q, &st);
  if (detail) fill_sample(C, &st, h, q, detail);
  return h;
}

double ch_gtex_eval(const ch_gtex *g, double u, double v, ch_gtex_sample *detail) {
  cell C;
  int loaded = -1;
  return eval_in(g, u, v, &C, &loaded, detail);
}

/* ---- events along a ray in a cell ---- */

typedef struct ray {
  double o[3], d[3];
} ray;

typedef struct events {
  double lo, hi;
  int n, dropped;
  int wall_now;               /* the kind of the events being added */
  double t[EV_CAP];
  unsigned char wall[EV_CAP]; /* 1: h may jump there (a break line or
                                 circle, an open end's side line) */
} events;

/* The kind of an event found twice: a jump if either says so. */
static inline unsigned char ev_merge(unsigned char a, int b) { return (unsigned char)((a | b) & 1); }

/* Keeps the EV_CAP smallest events strictly inside (lo, hi), once each
 * (the same point comes from both elements at a joint, and from +-b). */
static void ev_add(events *E, double t) {
  if (!(t > E->lo && t < E->hi)) return;
  int i = E->n;
  while (i > 0 && E->t[i - 1] > t) i--;
  const double tie = 1e-15 * (1.0 + fabs(t));
  if (i > 0 && t - E->t[i - 1] <= tie) {
    E->wall[i - 1] = ev_merge(E->wall[i - 1], E->wall_now);
    return;
  }
  if (i < E->n && E->t[i] - t <= tie) {
    E->wall[i] = ev_merge(E->wall[i], E->wall_now);
    return;
  }
  if (E->n == EV_CAP) {
    E->dropped = 1;
    if (i == EV_CAP) return;
    E->n--;
  }
  for (int k = E->n; k > i; k--) E->t[k] = E->t[k - 1], E->wall[k] = E->wall[k - 1];
  E->t[i] = t;
  E->wall[i] = (unsigned char)E->wall_now;
  E->n++;
}

/* The real roots of a t^2 + b t + c (a linear equation where a vanishes
 * against the others), without cancellation; a double root lost to
 * rounding (a ray tangent to a cap circle) kept. */
static int quadratic_roots(double a, double b, double c, double r[2]) {
  double scale = fabs(a) + fabs(b) + fabs(c);
  if (!(scale > 0.0)) return 0;
  if (fabs(a) < 1e-14 * scale) {
    if (b == 0.0) return 0;
    r[0] = -c / b;
    return 1;
  }
  double disc = b * b - 4.0 * a * c;
  if (disc < 0.0) {
    if (!(disc > -1e-14 * b * b)) return 0;
    r[0] = -b / (2.0 * a);
    return 1;
  }
  double sq = sqrt(disc), qq = -0.5 * (b + (b >= 0.0 ? sq : -sq));
  r[0] = qq / a;
  if (qq == 0.0) return 1;
  r[1] = c / qq;
  return 2;
}

static void ev_linear(events *E, double a, double b) {
  /* a + b t = 0 */
  if (b != 0.0) ev_add(E, -a / b);
}

/* A straight element: the ray's offset from its line is s0 + s1 t, so
 * every break line is linear, every straight facet linear and the ellipse
 * quadratic in t. */
static void events_line(events *E, const ray *R, const elem *el, const groove *G, int all_breaks) {
  double T[2];
  elem_tangent(el, 0.5, T);
  double N[2] = {-T[1], T[0]};
  double s0 = (R->o[0] - el->p[0][0]) * N[0] + (R->o[1] - el->p[0][1]) * N[1];
  double s1 = R->d[0] * N[0] + R->d[1] * N[1];
  double a0 = (R->o[0] - el->p[0][0]) * T[0] + (R->o[1] - el->p[0][1]) * T[1], a1 = R->d[0] * T[0] + R->d[1] * T[1];
  double z0 = R->o[2], z1 = R->d[2], w = G->w, d = G->d;
  double L = len2d(el->p[2][0] - el->p[0][0], el->p[2][1] - el->p[0][1]), eps = 1e-9 * (1.0 + L + w);
  /* Only where the foot is on the segment (around its ends the caps' events
   * apply) and inside the band is a crossing real: the rest are dropped
   * here, so fewer segments need a point test. */
#define LINE_KEEP(t) (a0 + a1 * (t) >= -eps && a0 + a1 * (t) <= L + eps && fabs(s0 + s1 * (t)) <= 0.5 * w + eps)
  E->wall_now = 1;
  for (int k = 0; k < G->nb; k++)
    if ((all_breaks || JUMP(G, k)) && s1 != 0.0) {
      double t = (BRK(G, k) * w - s0) / s1;
      if (LINE_KEEP(t)) ev_add(E, t);
    }
  E->wall_now = 0;
  if (G->ellipse) {
    double k4 = 4.0 * d * d / (w * w), r[2];
    int n = quadratic_roots(z1 * z1 + k4 * s1 * s1, 2.0 * (z0 * z1 + k4 * s0 * s1), z0 * z0 + k4 * s0 * s0 - d * d, r);
    for (int i = 0; i < n; i++)
      if (LINE_KEEP(r[i])) ev_add(E, r[i]);
    return;
  }
  for (int k = 0; k + 1 < G->n; k++) {
    if (!(PT(G, k + 1) > PT(G, k))) continue; /* vertical: a break */
    double m = (PH(G, k + 1) - PH(G, k)) / (PT(G, k + 1) - PT(G, k));
    /* z0 + z1 t = d (h_k + m ((s0 + s1 t) / w - t_k)) */
    double a = z0 - d * (PH(G, k) + m * (s0 / w - PT(G, k))), b = z1 - d * m * s1 / w;
    if (b != 0.0 && LINE_KEEP(-a / b)) ev_add(E, -a / b);
  }
#undef LINE_KEEP
}

/* Around a point (an open end's cap or a joint's corner) the distance is
 * r(t) = |p(t) - E|, r^2 = a t^2 + b t + c: break circles and facets
 * (squared, both signs of s at once) are quadratics in t. */
static void events_point(events *E, const ray *R, const double P[2], const double T[2], int after,
                         const groove *G, int all_breaks) {
  double ox = R->o[0] - P[0], oy = R->o[1] - P[1];
  double a = R->d[0] * R->d[0] + R->d[1] * R->d[1], b = 2.0 * (ox * R->d[0] + oy * R->d[1]), c = ox * ox + oy * oy;
  double z0 = R->o[2], z1 = R->d[2], w = G->w, d = G->d;
  /* The point is the nearest feature only beyond its segment's end (its
   * side of the normal line there, along T: after = 1 past the end, 0
   * before the start) and within the band: other roots are dropped. */
  double a0 = ox * T[0] + oy * T[1], a1 = R->d[0] * T[0] + R->d[1] * T[1], eps = 1e-9 * (1.0 + w), r[2];
  /* Every event kept is within the band's radius of the point: where the
   * ray's stretch stays farther (its nearest point, with a margin far
   * above rounding), there are none. */
  if (a > 0.0 && isfinite(E->lo) && isfinite(E->hi)) {
    double tn = -b / (2.0 * a), far = 0.5 * w + 2.0 * eps;
    tn = tn < E->lo ? E->lo : tn > E->hi ? E->hi : tn;
    if (a * tn * tn + b * tn + c > far * far) return;
  }
#define POINT_KEEP(t)                                                                                            \
  ((after ? a0 + a1 * (t) >= -eps : a0 + a1 * (t) <= eps) &&                                                     \
   (a * (t) * (t) + b * (t) + c) <= (0.5 * w + eps) * (0.5 * w + eps))
  E->wall_now = 1;
  for (int k = 0; k < G->nb; k++) {
    /* Circles r = |b| w, each radius once. */
    int seen = BRK(G, k) == 0.0 || !(all_breaks || JUMP(G, k));
    for (int j = 0; j < k && !seen; j++) seen = fabs(BRK(G, j)) == fabs(BRK(G, k));
    double rr = BRK(G, k) * w;
    if (seen) continue;
    int n = quadratic_roots(a, b, c - rr * rr, r);
    for (int i = 0; i < n; i++)
      if (POINT_KEEP(r[i])) ev_add(E, r[i]);
  }
  E->wall_now = 0;
  if (G->ellipse) {
    double k4 = 4.0 * d * d / (w * w);
    int n = quadratic_roots(z1 * z1 + k4 * a, 2.0 * z0 * z1 + k4 * b, z0 * z0 + k4 * c - d * d, r);
    for (int i = 0; i < n; i++)
      if (POINT_KEEP(r[i])) ev_add(E, r[i]);
    return;
  }
  for (int k = 0; k + 1 < G->n; k++) {
    if (!(PT(G, k + 1) > PT(G, k))) continue;
    double m = (PH(G, k + 1) - PH(G, k)) / (PT(G, k + 1) - PT(G, k));
    /* (z - K)^2 = M r^2 with K = d (h_k - m t_k), M = (d m / w)^2 */
    double K = d * (PH(G, k) - m * PT(G, k)), M = (d * m / w) * (d * m / w), e0 = z0 - K;
    int n = quadratic_roots(z1 * z1 - M * a, 2.0 * z1 * e0 - M * b, e0 * e0 - M * c, r);
    for (int i = 0; i < n; i++)
      if (POINT_KEEP(r[i])) ev_add(E, r[i]);
  }
#undef POINT_KEEP
}

/* Beyond an open end the side is that of the end's tangent line: where the
 * ray crosses it, one-sided profiles jump. */
static void events_end_line(events *E, const ray *R, const double P[2], const double T[2]) {
  E->wall_now = 1;
  ev_linear(E, T[0] * (R->o[1] - P[1]) - T[1] * (R->o[0] - P[0]), T[0] * R->d[1] - T[1] * R->d[0]);
}

/* The signed distance from the ray's point at t to a quadratic element,
 * and its rate along the ray (the ray's direction against the distance's
 * gradient, the unit vector from the foot). Only called where the foot is
 * on the element (between the normal lines at its ends), so the side is
 * always the element's own: where the foot lands on an end point (the
 * stretch's ends lie on those normal lines) it is the end's tangent line,
 * not docs/spec.md §3's sector rule of the joint there. On the inner side
 * of a joint turning by more than a right angle the two disagree on the
 * normal line itself (it runs into the next element's outer side): the
 * sector's sign would make s jump at the stretch's end, and the bracketing
 * below, which needs s continuous and convex, would lose the crossing
 * inside. The corner's own region is events_point's. *hint: the foot's
 * parameter to start Newton from (-1: the chord's projection), set to
 * this one's (refining a root, the next point is close). */
static double quad_s(const elem *el, const ray *R, double t, double *rate, double *hint) {
  double q[2] = {R->o[0] + t * R->d[0], R->o[1] + t * R->d[1]}, tau, c[2], D[2];
  double d2 = elem_closest_from(el, q, *hint, &tau, c, D);
  *hint = tau;
  double side, d = sqrt(d2), dq[2] = {q[0] - c[0], q[1] - c[1]};
  if (tau > 0.0 && tau < 1.0) {
    /* elem_side's test, from the derivative Newton ended with. */
    double chord2 = (el->p[2][0] - el->p[0][0]) * (el->p[2][0] - el->p[0][0]) + (el->p[2][1] - el->p[0][1]) * (el->p[2][1] - el->p[0][1]);
    side = D[0] * D[0] + D[1] * D[1] > 1e-12 * chord2 ? (ch_cross2(D, dq) >= 0.0 ? 1.0 : -1.0) : elem_side(el, tau, q);
  } else {
    double tg[2], e[2];
    elem_tangent(el, tau <= 0.0 ? 0.0 : 1.0, tg);
    elem_point(el, tau <= 0.0 ? 0.0 : 1.0, e);
    double de[2] = {q[0] - e[0], q[1] - e[1]};
    side = ch_cross2(tg, de) >= 0.0 ? 1.0 : -1.0;
  }
  double g[2];
  if (d > 1e-14) {
    g[0] = side * dq[0] / d;
    g[1] = side * dq[1] / d;
  } else {
    double tg[2];
    elem_tangent(el, tau, tg);
    g[0] = -tg[1], g[1] = tg[0];
  }
  *rate = g[0] * R->d[0] + g[1] * R->d[1];
  return d * side;
}

/* Event function j of a quadratic element, given s and its rate ds/dt,
 * and its own rate: j < nb: a break line, s - brk w; else facet j - nb:
 * z - d P_k(s / w) with the piece extended beyond its ends; the ellipse
 * as (z / d)^2 + (2 s / w)^2 - 1, smooth where -sqrt is not (its roots
 * with z above the groove's floor side are extra events, harmless). */
static double quad_fn(const groove *G, const ray *R, int j, double t, double s, double ds, double *rate) {
  if (j < G->nb) {
    *rate = ds;
    return s - BRK(G, j) * G->w;
  }
  double x = s / G->w, z = R->o[2] + t * R->d[2];
  if (G->ellipse) {
    double zd = z / G->d;
    *rate = 2.0 * zd * R->d[2] / G->d + 8.0 * x * ds / G->w;
    return zd * zd + 4.0 * x * x - 1.0;
  }
  int k = j - G->nb;
  double m = (PH(G, k + 1) - PH(G, k)) / (PT(G, k + 1) - PT(G, k));
  *rate = R->d[2] - G->d * m * ds / G->w;
  return z - G->d * (PH(G, k) + m * (x - PT(G, k)));
}

/* A root in (a, b) of the cubic with values fa, fb (of opposite signs) and
 * rates ra, rb at a and b, by Newton on the cubic kept in its bracket
 * (bisection where a step leaves it); the secant's root where the rates
 * are not finite. */
static double hermite_root(double a, double b, double fa, double fb, double ra, double rb) {
  double h = b - a, t = fa != fb ? a - fa * h / (fb - fa) : 0.5 * (a + b);
  if (!(t > a && t < b)) t = 0.5 * (a + b);
  if (!(isfinite(ra) && isfinite(rb) && h > 0.0)) return t;
  /* p(x) = fa + ma x + c2 x^2 + c3 x^3 on x in [0, 1]. */
  double ma = ra * h, mb = rb * h, c2 = 3.0 * (fb - fa) - 2.0 * ma - mb, c3 = 2.0 * (fa - fb) + ma + mb;
  double lo = 0.0, hi = 1.0, x = (t - a) / h;
  int neg_lo = fa < 0.0;
  for (int it = 0; it < 12; it++) {
    double p = fa + x * (ma + x * (c2 + x * c3)), dp = ma + x * (2.0 * c2 + 3.0 * x * c3);
    if (p == 0.0) break;
    if ((p < 0.0) == neg_lo) lo = x;
    else hi = x;
    double xn = dp != 0.0 ? x - p / dp : 0.5 * (lo + hi);
    if (!(xn > lo && xn < hi)) xn = 0.5 * (lo + hi);
    int done = fabs(xn - x) <= 1e-12;
    x = xn;
    if (done) break;
  }
  t = a + x * h;
  return t > a && t < b ? t : 0.5 * (a + b);
}

/* A root of event function j in [a, b], whose ends' values differ in
 * sign: Newton's method on the exact distance (its rate is known), kept
 * inside the bracket by bisection where a step would leave it. */
static double quad_root(const elem *el, const groove *G, const ray *R, int j, double a, double b, double fa,
                        double fb, double ra, double rb) {
  /* From the root of the cubic with the ends' values and rates (Hermite),
   * found on the cubic itself by safeguarded Newton from the secant's: the
   * functions are smooth over a bracket, so that start is within a small
   * power of the bracket of the root and Newton on the exact distance
   * needs one or two steps; once a step is below 1e-9 of the bracket the
   * next is at rounding, so take it and stop. */
  double t = hermite_root(a, b, fa, fb, ra, rb), tol = 1e-9 * (b - a);
  /* Each foot from the last one: the steps shrink, so do the feet's moves.
   * A Newton step of e leaves an error of about |f'' / (2 f')| e^2, f''
   * read from the last two rates (at first, the nearer end's): where that
   * is below rounding of t, the step is the last (it saves the evaluation
   * that would only confirm it; near a double root f'' / f' is large and
   * the rule waits). */
  int near_a = t - a <= b - t;
  double hint = -1.0, t_prev = near_a ? a : b, r_prev = near_a ? ra : rb, width = b - a;
  for (int it = 0, last = 0; it < 60 && !last; it++) {
    double ds, rate, s = quad_s(el, R, t, &ds, &hint), f = quad_fn(G, R, j, t, s, ds, &rate);
    if (f == 0.0) return t;
    if ((f > 0.0) == (fa > 0.0)) a = t, fa = f;
    else b = t;
    double tn = rate != 0.0 ? t - f / rate : 0.5 * (a + b);
    if (tn == t) return t; /* the step is below rounding: t is the root (t is an end of the bracket now) */
    int newton = tn > a && tn < b;
    if (!newton) tn = 0.5 * (a + b);
    double step = fabs(tn - t);
    last = step <= tol || b - a <= 1e-15 * (1.0 + fabs(a));
    if (!last && newton && step <= 1e-6 * width && t != t_prev && rate != 0.0 && isfinite(r_prev)) {
      double curv = fabs((rate - r_prev) / (t - t_prev)) / (2.0 * fabs(rate));
      last = curv * step * step <= 1e-17 * (1.0 + fabs(tn));
    }
    t_prev = t, r_prev = rate;
    t = tn;
  }
  return t;
}

/* The roots of event function j on [ta, tb] (values fa, fb, rates ra, rb
 * at the ends) where it is convex or concave there: a sign change holds
 * one root; otherwise, turning towards zero and back, the function is
 * one-signed past the tangents' crossing (it lies on their side of both),
 * which bounds its extremum: the bracket is cut at the crossing until the
 * bound keeps the sign (no root) or the function changes it (two roots,
 * split there). */
static void convex_roots(events *E, const ray *R, const elem *el, const groove *G, int j, double ta, double fa,
                         double ra, double tb, double fb, double rb) {
  if ((fa > 0.0) != (fb > 0.0)) {
    ev_add(E, quad_root(el, G, R, j, ta, tb, fa, fb, ra, rb));
    return;
  }
  if (!((ra > 0.0) != (rb > 0.0) && (fa > 0.0) == (ra < 0.0))) return;
  double x0 = ta, x1 = tb, f0 = fa, f1 = fb, r0 = ra, r1 = rb, fm = fa, m = ta, rm_split = NAN;
  int split = 0;
  for (int it = 0; it < 40; it++) {
    /* f0 + r0 (x - x0) = f1 + r1 (x - x1) */
    m = r0 != r1 ? (f1 - f0 + r0 * x0 - r1 * x1) / (r0 - r1) : 0.5 * (x0 + x1);
    if (!(m > x0 && m < x1)) m = 0.5 * (x0 + x1);
    double bound = f0 + r0 * (m - x0);
    if ((bound > 0.0) == (fa > 0.0) && bound != 0.0) break; /* the extremum keeps the sign */
    double dsm, hint = -1.0, sm = quad_s(el, R, m, &dsm, &hint), rm;
    fm = quad_fn(G, R, j, m, sm, dsm, &rm);
    if ((fm > 0.0) != (fa > 0.0)) {
      split = 1;
      rm_split = rm;
      break;
    }
    if ((rm > 0.0) == (r0 > 0.0)) x0 = m, f0 = fm, r0 = rm;
    else x1 = m, f1 = fm, r1 = rm;
    if (x1 - x0 <= 1e-15 * (1.0 + fabs(x0))) break;
  }
  if (split) {
    ev_add(E, quad_root(el, G, R, j, ta, m, fa, fm, ra, rm_split));
    ev_add(E, quad_root(el, G, R, j, m, tb, fm, fb, rm_split, rb));
  }
}

/* A point of the ray with the distance and the ellipse's function there. */
typedef struct ell_end {
  double t, s, ds, f, r;
} ell_end;

/* Bounds of the ellipse's function's second derivative over [a, b], from
 * those of the distance: f = (z/d)^2 + (2s/w)^2 - 1 has f'' = 2 (z'/d)^2 +
 * 8 (s'^2 + s s'') / w^2 with s'^2 <= |dxy|^2 and |s''| = (dxy . T)^2 k /
 * (1 -+ k |s|) (the distance's Hessian at a foot of curvature k, minus on
 * the side the curve turns to), k at most 1/rho. |s| over [a, b] is
 * bounded by the chord and the tangents' crossing (s is convex or concave
 * along the ray). 0 where the bound fails (|s| reaches rho), -1 where
 * the stretch stays beyond the band. */
static int ellipse_curvature(const elem *el, const groove *G, const ray *R, const ell_end *a, const ell_end *b,
                             double *lo, double *hi) {
  double sl = mn(a->s, b->s), sh = mx(a->s, b->s);
  if (a->ds != b->ds) {
    double x = (b->s - a->s + a->ds * a->t - b->ds * b->t) / (a->ds - b->ds);
    if (x > a->t && x < b->t) {
      double sx = a->s + a->ds * (x - a->t);
      sl = mn(sl, sx), sh = mx(sh, sx);
    }
  }
  /* Beyond the band on one side throughout: (2s/w)^2 > 1, no root. */
  if (sl > 0.5 * G->w || sh < -0.5 * G->w) return -1;
  double A = mx(fabs(sl), fabs(sh)), k = 1.0 / sqrt(el->rho2);
  if (!(k * A < 1.0)) return 0;
  double dxy2 = R->d[0] * R->d[0] + R->d[1] * R->d[1], zz = 2.0 * (R->d[2] / G->d) * (R->d[2] / G->d);
  double c = 8.0 / (G->w * G->w);
  *lo = zz - c * A * dxy2 * k / (1.0 - k * A);
  *hi = zz + c * dxy2 * (1.0 + A * k);
  return 1;
}

/* The `u` ellipse's function where it may not be convex: on the side a
 * curved element turns to, s s'' < 0 can outweigh the rest for a ray
 * nearly level along the groove, and a stretch then holds up to four
 * roots whose ends show one sign change or none. Certified by the
 * bounds on f'' (ellipse_curvature) and split in halves where they
 * cannot tell: same signs at the ends and a chord bound keeping that sign
 * hold no root; a sign change with f' bounded away from 0 holds one. */
static void ellipse_roots(events *E, const ray *R, const elem *el, const groove *G, ell_end a0, ell_end b0) {
  enum { STACK = 24, SPLITS = 64 };
  ell_end st[STACK][2];
  int n = 0, splits = 0, j = G->nb;
  st[n][0] = a0, st[n][1] = b0, n++;
  while (n > 0) {
    n--;
    ell_end a = st[n][0], b = st[n][1];
    double lo, hi, h = b.t - a.t;
    int known = ellipse_curvature(el, G, R, &a, &b, &lo, &hi);
    if (known < 0) continue;
    if (known && lo >= 0.0) {
      convex_roots(E, R, el, G, j, a.t, a.f, a.r, b.t, b.f, b.r);
      continue;
    }
    int change = (a.f > 0.0) != (b.f > 0.0);
    if (known && !change) {
      if (a.f > 0.0 ? mn(a.f, b.f) - hi * h * h / 8.0 > 0.0 : mx(a.f, b.f) - lo * h * h / 8.0 < 0.0) continue;
    }
    if (known && change) {
      /* f' between the lines from a.r with slopes lo, hi and those back
       * from b.r: its least and greatest values over [a, b] are at an end
       * or where the two bounding lines cross. */
      double xl = (b.r - a.r - hi * b.t + lo * a.t) / (lo - hi), xh = (b.r - a.r - lo * b.t + hi * a.t) / (hi - lo);
      xl = xl < a.t ? a.t : xl > b.t ? b.t : xl;
      xh = xh < a.t ? a.t : xh > b.t ? b.t : xh;
      double rmin = mn(mx(a.r + lo * (a.t - a.t), b.r - hi * (b.t - a.t)), mx(a.r + lo * (b.t - a.t), b.r));
      rmin = mn(rmin, mx(a.r + lo * (xl - a.t), b.r - hi * (b.t - xl)));
      double rmax = mx(mn(a.r, b.r - lo * (b.t - a.t)), mn(a.r + hi * (b.t - a.t), b.r));
      rmax = mx(rmax, mn(a.r + hi * (xh - a.t), b.r - lo * (b.t - xh)));
      if (rmin > 0.0 || rmax < 0.0) {
        ev_add(E, quad_root(el, G, R, j, a.t, b.t, a.f, b.f, a.r, b.r));
        continue;
      }
    }
    if (splits >= SPLITS || n + 2 > STACK || h <= 1e-12 * (1.0 + fabs(a.t))) {
      if (change) ev_add(E, quad_root(el, G, R, j, a.t, b.t, a.f, b.f, a.r, b.r));
      continue;
    }
    splits++;
    ell_end m;
    m.t = 0.5 * (a.t + b.t);
    double hint = -1.0;
    m.s = quad_s(el, R, m.t, &m.ds, &hint);
    m.f = quad_fn(G, R, j, m.t, m.s, m.ds, &m.r);
    /* The later half first on the stack: the earlier one is taken next. */
    st[n][0] = m, st[n][1] = b, n++;
    st[n][0] = a, st[n][1] = m, n++;
  }
}

/* Events of a quadratic element over [lo, hi], the part of the ray whose
 * foot is inside the element. Within the element's least radius of
 * curvature of it, the signed distance s(t) is convex or concave (the
 * norm of an affine map to the nearest point of a curve turning one way),
 * so a break function s - b w, or a facet z - d P(s / w) with P linear,
 * has at most one extremum: the values and rates at the two ends tell a
 * single crossing (refined by safeguarded Newton) from a pair (split at
 * the extremum) from none (convex_roots). The ellipse's function (z/d)^2
 * + (2s/w)^2 is convex unless s s'' < 0 outweighs the rest (a ray along
 * the groove, nearly level, on the side the curve turns to): there its
 * roots are isolated by bounds on its curvature (ellipse_roots). A groove
 * wider than twice that radius has points with two feet (where the
 * paper's straight approximation fails too): those are sampled eight
 * times per width. */
static void events_quad_range(events *E, const ray *R, const elem *el, const groove *G, double lo, double hi,
                              int all_breaks) {
  double len = (hi - lo) * len2d(R->d[0], R->d[1]);
  int tight = el->rho2 < 0.25 * G->w * G->w;
  int ns = tight ? 2 + (int)ceil(8.0 * len / G->w) : 1;
  if (ns > QUAD_SAMPLES_MAX) ns = QUAD_SAMPLES_MAX;
  int nf = G->nb + (G->ellipse ? 1 : G->n - 1);
  double ta = lo, dsa, hint = -1.0, sa = quad_s(el, R, ta, &dsa, &hint);
  for (int i = 1; i <= ns; i++) {
    double tb = lo + (hi - lo) * i / ns, dsb;
    hint = -1.0; /* (samples far apart: the chord's projection is the better start) */
    double sb = quad_s(el, R, tb, &dsb, &hint);
    for (int j = 0; j < nf; j++) {
      if (j < G->nb && !(all_breaks || JUMP(G, j))) continue;
      if (j >= G->nb && !G->ellipse) {
        int k = j - G->nb;
        if (!(PT(G, k + 1) > PT(G, k))) continue;
        if (PH(G, k + 1) == PH(G, k)) {
          /* A flat facet: z = d h_k, whatever the distance. */
          if (i == 1) E->wall_now = 0, ev_linear(E, R->o[2] - G->d * PH(G, k), R->d[2]);
          continue;
        }
      }
      double ra, rb, fa = quad_fn(G, R, j, ta, sa, dsa, &ra), fb = quad_fn(G, R, j, tb, sb, dsb, &rb);
      E->wall_now = j < G->nb;
      if (j >= G->nb && G->ellipse && !tight) {
        ell_end a = {ta, sa, dsa, fa, ra}, b = {tb, sb, dsb, fb, rb};
        ellipse_roots(E, R, el, G, a, b);
      } else {
        convex_roots(E, R, el, G, j, ta, fa, ra, tb, fb, rb);
      }
    }
    ta = tb, sa = sb, dsa = dsb;
  }
}


/* A quadratic element. Its foot is inside it between the normal lines at
 * its ends (outside, the cap events around its end points apply). The
 * normal lines are no events themselves: only the distance's formula
 * changes there, not its value, so neither does h or the side of it the
 * ray is on. */
static void events_quad(events *E, const ray *R, const elem *el, const groove *G, int all_breaks) {
  double T0[2], T1[2];
  elem_tangent(el, 0.0, T0);
  elem_tangent(el, 1.0, T1);
  double lo = E->lo, hi = E->hi;
  /* (p(t) - B0) . T0 >= 0 and (p(t) - B1) . T1 <= 0: linear in t. That
   * pair of half-planes holds the feet inside the element only where each
   * end lies on the inner side of the other's normal line: a quadratic
   * bending by more than a right angle near one end can put its start
   * beyond its end's normal line (its normals then meet on its outer
   * side), and the pair would cut the element's own band away. Such an
   * element's events are sought over the whole stretch (the ends' caps
   * have theirs; extra roots where the foot is an end are harmless). */
  double a0 = (R->o[0] - el->p[0][0]) * T0[0] + (R->o[1] - el->p[0][1]) * T0[1], a1 = R->d[0] * T0[0] + R->d[1] * T0[1];
  double b0 = (R->o[0] - el->p[2][0]) * T1[0] + (R->o[1] - el->p[2][1]) * T1[1], b1 = R->d[0] * T1[0] + R->d[1] * T1[1];
  double c[2] = {el->p[2][0] - el->p[0][0], el->p[2][1] - el->p[0][1]};
  int wedge = c[0] * T0[0] + c[1] * T0[1] >= 0.0 && c[0] * T1[0] + c[1] * T1[1] >= 0.0;
  if (!wedge) {
    /* nothing cut */
  } else if (a1 != 0.0) {
    double tc = -a0 / a1;
    if (a1 > 0.0) lo = mx(lo, tc);
    else hi = mn(hi, tc);
  } else if (a0 < 0.0) {
    return;
  }
  if (!wedge) {
    /* nothing cut */
  } else if (b1 != 0.0) {
    double tc = -b0 / b1;
    if (b1 < 0.0) lo = mx(lo, tc);
    else hi = mn(hi, tc);
  } else if (b0 > 0.0) {
    return;
  }
  if (!(lo < hi)) return;
  events_quad_range(E, R, el, G, lo, hi, all_breaks);
}

/* Narrows E to where the ray is within r of box (umin vmin umax vmax):
 * 0 if it never is. */
static int clip_to_box(const events *E, const ray *R, const double box[4], double r, double *lo, double *hi) {
  *lo = E->lo;
  *hi = E->hi;
  for (int k = 0; k < 2; k++) {
    double a = box[k] - r, b = box[k + 2] + r;
    if (R->d[k] == 0.0) {
      if (R->o[k] < a || R->o[k] > b) return 0;
      continue;
    }
    double t0 = (a - R->o[k]) / R->d[k], t1 = (b - R->o[k]) / R->d[k];
    *lo = mx(*lo, mn(t0, t1));
    *hi = mn(*hi, mx(t0, t1));
  }
  return *lo <= *hi;
}

/* Narrows [lo, hi] to a slab: x0 + x1 t in [a, b]. 0 if empty. */
static int clip_to_slab(double x0, double x1, double a, double b, double *lo, double *hi) {
  if (x1 == 0.0) return x0 >= a && x0 <= b && *lo <= *hi;
  double t0 = (a - x0) / x1, t1 = (b - x0) / x1;
  *lo = mx(*lo, mn(t0, t1));
  *hi = mn(*hi, mx(t0, t1));
  return *lo <= *hi;
}

/* Narrows [lo, hi] to where the ray is within the band of width w around
 * a straight element, caps included (across its line and along it, a
 * rectangle holding the band), with a margin above the events' own
 * tolerances (events_line, events_point) so that none they keep is cut:
 * 0 if the ray never is. */
static int clip_to_band(const ray *R, const elem *el, double w, double *lo, double *hi) {
  double T[2] = {el->t0[0], el->t0[1]}, N[2] = {-T[1], T[0]};
  double ox = R->o[0] - el->p[0][0], oy = R->o[1] - el->p[0][1];
  double L = len2d(el->p[2][0] - el->p[0][0], el->p[2][1] - el->p[0][1]);
  double m = 0.5 * w + 4e-9 * (1.0 + L + w);
  return clip_to_slab(ox * N[0] + oy * N[1], R->d[0] * N[0] + R->d[1] * N[1], -m, m, lo, hi) &&
         clip_to_slab(ox * T[0] + oy * T[1], R->d[0] * T[0] + R->d[1] * T[1], -m, L + m, lo, hi);
}

/* Turns below this (radians) at a joint leave it no region of its own
 * wider than r sin(turn) < 1e-8 UV at the profile's half width: its
 * events are the neighbours' (cubics and arcs split into quadratics
 * meet so, tangent to rounding). */
#define SMOOTH_JOINT 1e-6

static void cell_events(events *E, const ray *R, cell *C) {
  /* The base plane: h = 0 wherever no profile reaches. */
  E->wall_now = 0;
  ev_linear(E, R->o[2], R->d[2]);
  const double lo0 = E->lo, hi0 = E->hi;
  for (int r = 0; r < C->ng; r++) {
    const groove *G = &C->g[r];
    const double reach = 0.5 * G->w * (1.0 + 1e-9) + 1e-12;
    /* Where nothing raises, h is the least of 0 and every groove's value,
     * so the ray is solid where it is below all of them: below a groove's
     * deepest value it is below that groove wherever it is, and the
     * groove's events there change nothing (the margin is far above
     * rounding). */
    double glo = lo0, ghi = hi0;
    if (!C->raises && R->d[2] != 0.0) {
      double tz = (G->lowest - 1e-9 * (1.0 + fabs(G->lowest)) - R->o[2]) / R->d[2];
      if (R->d[2] < 0.0) ghi = mn(ghi, tz);
      else glo = mx(glo, tz);
      if (!(glo < ghi)) continue;
    }
    E->lo = glo, E->hi = ghi;
    for (int k = C->gfirst[r]; k < C->gfirst[r + 1]; k++) {
      elem *el = &C->e[k];
      /* Only where the ray is within the element's band can its events
       * matter (its break lines at the band's edge included). */
      double lo, hi;
      if (!clip_to_box(E, R, el->box, reach, &lo, &hi)) continue;
      if (!el->ready) elem_ready(el);
      if (!el->framed) elem_frame(el);
      /* A straight element's box is loose (a diagonal's is its whole
       * extent): its facet, break and cap events all lie within its
       * band, so the ray's stretch there bounds them. */
      double blo = lo, bhi = hi;
      int near = el->quad || clip_to_band(R, el, G->w, &blo, &bhi);
      E->lo = blo, E->hi = bhi;
      if (!near) {
        /* nothing of the element's own */
      } else if (el->quad) {
        events_quad(E, R, el, G, C->mixed);
      } else {
        events_line(E, R, el, G, C->mixed);
      }
      /* A joint is the next element's start; an open end is nobody's. A
       * smooth joint has no region of its own. Beyond an open end the side
       * flips at its tangent line, which matters to asymmetric profiles. */
      double tg[2];
      elem_tangent(el, 0.0, tg);
      if (near && (el->open_start || fabs(ch_cross2(el->tin, tg)) > SMOOTH_JOINT || ch_dot2(el->tin, tg) < 0.0))
        events_point(E, R, el->p[0], tg, 0, G, C->mixed);
      if (near && el->open_end) {
        double te[2];
        elem_tangent(el, 1.0, te);
        events_point(E, R, el->p[2], te, 1, G, C->mixed);
      }
      /* The tangent lines beyond open ends reach past the band. */
      E->lo = lo, E->hi = hi;
      if (G->asym && el->open_start) events_end_line(E, R, el->p[0], tg);
      if (G->asym && el->open_end) {
        elem_tangent(el, 1.0, tg);
        events_end_line(E, R, el->p[2], tg);
      }
      E->lo = glo, E->hi = ghi;
    }
  }
  E->lo = lo0, E->hi = hi0;
}

/* ---- the traversal (Algorithm 1) ---- */

typedef struct trace {
  const ch_gtex *g;
  ray R;
  double duv;       /* |(dx, dy)| */
  /* the hit */
  double t;
  int maybe_wall;   /* whether h may jump at the hit */
  int at_top;       /* the walk is at its start, where it entered the
                       slab of h's range from above: no wall there */
  int cells;
  cell *C;          /* the cell last read, kept for the hit's probes */
  cell *spare;      /* the one read before (its elements are copied) */
  int loaded;       /* its index, or -1 (the paper's mode edits a cell) */
} trace;

/* Whether groove r's value at q lies below z, from bounds on its distance
 * alone: each element is within dev of its chord, so the chord's distance
 * +- dev brackets the element's (a straight element's is exact), and a
 * monotone profile's value is bracketed by its values there. 1 below, 0
 * not below, -1 when the bracket cannot tell (within its margin, far
 * above rounding and Newton's tolerance, of z). */
static int groove_below(cell *C, int r, const double q[2], double z) {
  const groove *G = &C->g[r];
  double half = 0.5 * G->w, reach2 = half * half, lo = INFINITY, hi = INFINITY;
  for (int k = C->gfirst[r]; k < C->gfirst[r + 1]; k++) {
    elem *E = &C->e[k];
    if (box_dist2(E->box, q) >= reach2) continue; /* beyond the band: no value */
    if (!E->ready) elem_ready(E);
    double tau, dc = sqrt(chord_closest(E, q, &tau));
    lo = mn(lo, dc - E->dev);
    hi = mn(hi, dc + E->dev);
  }
  lo = lo * (1.0 - 1e-9) - 1e-12;
  hi = hi * (1.0 + 1e-9) + 1e-12;
  double vhi = hi < half ? G->d * prof_eval(G, hi / G->w) : 0.0;
  if (z > vhi) return 1;
  double vlo = lo < half ? G->d * prof_eval(G, mx(lo, 0.0) / G->w) : 0.0;
  if (!(z > vlo)) return 0;
  return -1;
}

/* Whether the ray is on or below h at parameter t (the cell's elements).
 * Where nothing raises, h is the least of 0 and every groove's value, so
 * the ray's point z is above h as soon as one groove lies below z: the
 * grooves are tried from *first (the one that decided last time, as the
 * next test along the ray is usually decided by the same groove), and a
 * groove whose deepest value is not below z needs no distance. The answer
 * is z <= cell_h's exactly; only the work differs. */
static int solid_at(const trace *T, cell *C, double t, int *first) {
  double q[2] = {T->R.o[0] + t * T->R.d[0], T->R.o[1] + t * T->R.d[1]}, z = T->R.o[2] + t * T->R.d[2];
  if (C->raises) return z <= cell_h(C, q, NULL);
  if (z > 0.0) return 0;
  for (int i = 0; i < C->ng; i++) {
    int r = (*first + i) % C->ng;
    if (!(z > C->g[r].lowest)) continue;
    if (C->g[r].monotone) {
      int below = groove_below(C, r, q, z);
      if (below >= 0) {
        if (below) {
          *first = r;
          return 0;
        }
        continue;
      }
    }
    double s, tau;
    int e;
    if (z > groove_value(C, r, q, &s, &e, &tau)) {
      *first = r;
      return 0;
    }
  }
  return 1;
}

/* Whether q is farther than every band of the cell's elements (so h = 0
 * around it): by the box, else by the chord's distance less how far the
 * curve strays from it. */
static int clear_of_bands(cell *C, const double q[2]) {
  for (int r = 0; r < C->ng; r++) {
    const double reach = 0.5 * C->g[r].w * (1.0 + 1e-9) + 1e-12;
    for (int k = C->gfirst[r]; k < C->gfirst[r + 1]; k++) {
      elem *E = &C->e[k];
      if (box_dist2(E->box, q) >= reach * reach) continue;
      if (!E->ready) elem_ready(E);
      double tau;
      if (!(sqrt(chord_closest(E, q, &tau)) - E->dev >= reach)) return 0;
    }
  }
  return 1;
}

/* The first solid segment of the ray in [ta, tb] over cell C: 1 and *hit.
 * cuts: the borders of the grid cells inside [ta, tb] (cells merged for
 * holding the same list), kept as events of unknown kind, so each cell's
 * entry is tested as if it were walked alone. */
static int cell_hit(trace *T, cell *C, double ta, double tb, double zmax_cell, const double *cuts, int ncuts,
                    double *hit, int *maybe_wall) {
  const ray *R = &T->R;
  if (T->g->paper) {
    double tm = 0.5 * (ta + tb), ref[2] = {R->o[0] + tm * R->d[0], R->o[1] + tm * R->d[1]};
    for (int k = 0; k < C->n; k++)
      if (C->e[k].quad) paper_line(&C->e[k], ref);
  }
  /* Solid just past the entry: the hit is there (most rays meeting the top
   * surface near a groove end here, without events). */
  double tp = ta + 1e-13 * (1.0 + fabs(ta));
  int first = 0;
  if (R->o[2] + tp * R->d[2] <= zmax_cell && solid_at(T, C, tp, &first)) {
    *hit = ta;
    *maybe_wall = !T->at_top;
    return 1;
  }
  /* Where nothing raises, a ray coming down meets the base plane z = 0
   * first wherever no band reaches the point it crosses it: the segments
   * before are above every h <= 0, the one after starts below h = 0 (the
   * base plane's event, as cell_events finds it; most rays meeting the
   * top surface end here, without the elements' events). */
  if (!T->g->paper && !C->raises && R->d[2] < 0.0) {
    double t0 = -R->o[2] / R->d[2], q0[2] = {R->o[0] + t0 * R->d[0], R->o[1] + t0 * R->d[1]};
    if (t0 > ta && t0 < tb && clear_of_bands(C, q0)) {
      *hit = t0;
      *maybe_wall = 0;
      return 1;
    }
  }
  events E;
  double lo = ta;
  int lo_wall = 1; /* the cell's entry: unknown */
  for (int pass = 0; pass < MAX_PASSES; pass++) {
    E.lo = lo, E.hi = tb, E.n = 0, E.dropped = 0;
    cell_events(&E, R, C);
    E.wall_now = 1;
    for (int k = 0; k < ncuts; k++) ev_add(&E, cuts[k]);
    double prev = lo;
    int prev_wall = lo_wall;
    for (int i = 0; i <= E.n; i++) {
      if (i == E.n && E.dropped) break;
      double next = i < E.n ? E.t[i] : tb, mid = 0.5 * (prev + next);
      /* Above the cell's highest point: nothing to test. */
      if (R->o[2] + mid * R->d[2] <= zmax_cell && solid_at(T, C, mid, &first)) {
        *hit = prev;
        *maybe_wall = prev_wall;
        return 1;
      }
      prev = next;
      prev_wall = i < E.n ? E.wall[i] : 1;
    }
    if (!E.dropped) return 0;
    lo = E.t[E.n - 1];
    lo_wall = E.wall[E.n - 1];
  }
  return 0;
}

/* Whether two grid texels list the same elements. */
static int same_list(const ch_gtex *g, const float *a, const float *b) {
  int n = (int)a[1];
  if ((int)b[1] != n) return 0;
  if (a[0] == b[0]) return 1;
  const float *la = texel(g, (int)a[0]), *lb = texel(g, (int)b[0]);
  for (int k = 0; k < n; k++)
    if (la[k] != lb[k]) return 0;
  return 1;
}

/* Walks the cells from tnear to tfar; 1 with T->t at the first hit. */
static int walk(trace *T, double tnear, double tfar) {
  const ch_gtex *g = T->g;
  const ray *R = &T->R;
  const double *o = R->o, *d = R->d;
  int G = g->resolution;
  double ta = tnear, tb = tfar;
  /* Clip to the UV square. */
  for (int k = 0; k < 2; k++) {
    if (d[k] == 0.0) {
      if (o[k] < 0.0 || o[k] > 1.0) return 0;
      continue;
    }
    double t0 = (0.0 - o[k]) / d[k], t1 = (1.0 - o[k]) / d[k];
    ta = mx(ta, mn(t0, t1));
    tb = mn(tb, mx(t0, t1));
  }
  /* Only below the highest point can the ray meet the surface, and below
   * the lowest it is inside the solid: the hit is before. */
  double ztop = g->zmax + 1e-12 * (1.0 + fabs(g->zmax)), zbot = g->zmin - 1e-9 * (1.0 + fabs(g->zmin));
  if (d[2] < 0.0) {
    ta = mx(ta, (ztop - o[2]) / d[2]);
    tb = mn(tb, (zbot - o[2]) / d[2]);
  } else if (d[2] > 0.0) {
    tb = mn(tb, (ztop - o[2]) / d[2]);
  } else if (o[2] > ztop) {
    return 0;
  }
  if (!isfinite(tb)) return 0; /* a zero direction */
  if (!(ta <= tb)) return 0;
  double pu = o[0] + ta * d[0], pv = o[1] + ta * d[1];
  int ix = (int)floor(pu * G), iy = (int)floor(pv * G);
  ix = ix < 0 ? 0 : ix >= G ? G - 1 : ix;
  iy = iy < 0 ? 0 : iy >= G ? G - 1 : iy;
  int sx = d[0] > 0.0 ? 1 : -1, sy = d[1] > 0.0 ? 1 : -1;
  double cs = 1.0 / G;
  double dtx = d[0] != 0.0 ? cs / fabs(d[0]) : INFINITY, dty = d[1] != 0.0 ? cs / fabs(d[1]) : INFINITY;
  double tx = d[0] > 0.0 ? ((ix + 1) * cs - o[0]) / d[0] : d[0] < 0.0 ? (ix * cs - o[0]) / d[0] : INFINITY;
  double ty = d[1] > 0.0 ? ((iy + 1) * cs - o[1]) / d[1] : d[1] < 0.0 ? (iy * cs - o[1]) / d[1] : INFINITY;
  double t = ta;
  T->at_top = d[2] < 0.0 && ta > tnear;
  /* A bound on the cells a ray can cross (Algorithm 1's loop). */
  for (int steps = 0; steps < 2 * G + 2; steps++) {
    double t_exit = mn(mn(tx, ty), tb);
    int ci = iy * G + ix;
    const float *gt = g->grid + 4 * (size_t)ci;
    double cmax = gt[3];
    double za = o[2] + t * d[2], zb = o[2] + t_exit * d[2];
    T->cells++;
    if (!(mn(za, zb) > cmax)) {
      int n = (int)gt[1];
      if (n == 0) {
        /* The base plane h = 0. */
        if (za <= 0.0) {
          T->t = t, T->maybe_wall = 1;
          return 1;
        }
        if (zb <= 0.0) {
          T->t = d[2] != 0.0 ? -o[2] / d[2] : t;
          T->maybe_wall = 0;
          return 1;
        }
      } else {
        /* (The paper's mode edits a cell's elements: no copies.) */
        cell *into = T->spare;
        load_cell(g, ci, into, T->loaded >= 0 ? T->C : NULL);
        T->spare = T->C;
        T->C = into;
        T->loaded = g->paper ? -1 : ci;
        /* The next cells along the ray with the same list hold the same h
         * (a groove's run on a fine grid): one stretch, one set of events.
         * Not in the paper's mode, whose tangent lines are per cell. */
        double t0 = t, cuts[MERGE_MAX];
        int ncuts = 0;
        while (!g->paper && ncuts < MERGE_MAX && t_exit < tb && steps + 1 < 2 * G + 2) {
          int nx = ix, ny = iy;
          if (tx <= ty) nx += sx;
          else ny += sy;
          if (nx < 0 || nx >= G || ny < 0 || ny >= G) break;
          const float *nt = g->grid + 4 * ((size_t)ny * G + nx);
          if (!same_list(g, gt, nt)) break;
          cmax = mx(cmax, nt[3]);
          if (tx <= ty) ix = nx, t = tx, tx += dtx;
          else iy = ny, t = ty, ty += dty;
          cuts[ncuts++] = t;
          t_exit = mn(mn(tx, ty), tb);
          steps++;
          T->cells++;
        }
        double th;
        int mw;
        if (cell_hit(T, T->C, t0, t_exit, cmax, cuts, ncuts, &th, &mw)) {
          T->t = th, T->maybe_wall = mw;
          return 1;
        }
      }
    }
    if (t_exit >= tb) return 0;
    T->at_top = 0;
    if (tx <= ty) {
      ix += sx;
      t = tx;
      tx += dtx;
      if (ix < 0 || ix >= G) return 0;
    } else {
      iy += sy;
      t = ty;
      ty += dty;
      if (iy < 0 || iy >= G) return 0;
    }
  }
  return 0;
}

int ch_gtex_occluded(const ch_gtex *g, const double org[3], const double dir[3], double tnear, double tfar) {
  cell C[2];
  trace T = {.g = g, .C = &C[0], .spare = &C[1], .loaded = -1};
  memcpy(T.R.o, org, sizeof T.R.o);
  memcpy(T.R.d, dir, sizeof T.R.d);
  T.duv = len2d(dir[0], dir[1]);
  return walk(&T, tnear, tfar);
}

/* h and its detail at the ray's point t, from the cell holding it. */
static double h_on_ray(const ch_gtex *g, const ray *R, double t, cell *C, int *loaded, point_state *st,
                       double q[2]) {
  q[0] = R->o[0] + t * R->d[0];
  q[1] = R->o[1] + t * R->d[1];
  int ci = cell_index(g, q[0], q[1]);
  if (*loaded != ci) {
    load_cell(g, ci, C, NULL);
    *loaded = ci;
  }
  if (!(q[0] >= 0.0 && q[0] <= 1.0 && q[1] >= 0.0 && q[1] <= 1.0)) {
    memset(st, 0, sizeof *st);
    st->carve_run = st->raise_run = st->owner_run = -1;
    return 0.0;
  }
  return cell_h(C, q, st);
}

int ch_gtex_intersect(const ch_gtex *g, const double org[3], const double dir[3], double tnear, double tfar,
                      ch_gtex_hit *hit) {
  cell C[2];
  trace T = {.g = g, .C = &C[0], .spare = &C[1], .loaded = -1};
  memcpy(T.R.o, org, sizeof T.R.o);
  memcpy(T.R.d, dir, sizeof T.R.d);
  T.duv = len2d(dir[0], dir[1]);
  if (!walk(&T, tnear, tfar)) return 0;
  const ray *R = &T.R;
  cell *Ch = T.C; /* the hit's cell, or the last one read */
  double t = T.t;
  memset(hit, 0, sizeof *hit);
  hit->t = t;
  hit->cells = T.cells;
  for (int k = 0; k < 3; k++) hit->point[k] = org[k] + t * dir[k];
  /* A wall where h jumps across the ray at the hit (keeping its size as
   * the probes close in: a slope shrinks). */
  if (T.duv > 0.0 && T.maybe_wall) {
    int *loaded = &T.loaded;
    point_state sa, sb, s2;
    double qa[2], qb[2], q2[2], dt = 1e-9 / T.duv;
    double ha = h_on_ray(g, R, t - dt, Ch, loaded, &sa, qa), hb = h_on_ray(g, R, t + dt, Ch, loaded, &sb, qb);
    double ha2 = h_on_ray(g, R, t - dt / 16, Ch, loaded, &s2, q2), hb2 = h_on_ray(g, R, t + dt / 16, Ch, loaded, &s2, q2);
    double jump_eps = 1e-6 * mx(g->zmax - g->zmin, 1e-9);
    if (fabs(hb - ha) > jump_eps && fabs(hb2 - ha2) > 0.5 * fabs(hb - ha)) {
      /* Across the groove of the deeper side, facing the ray. */
      int deeper_b = fabs(hb) >= fabs(ha);
      point_state st;
      double q[2];
      h_on_ray(g, R, deeper_b ? t + dt : t - dt, Ch, loaded, &st, q);
      double s = 0.0, tau = 0.0;
      int e = -1, r = active_of(&st, &s, &e, &tau);
      double n2[2] = {-R->d[0] / T.duv, -R->d[1] / T.duv};
      if (r >= 0) {
        const elem *el = &Ch->e[e];
        const groove *G = &Ch->g[r];
        distance_gradient(el, tau, s, q, n2);
        /* Around an open end the walls are circles |s| = b w (radial
         * normals), except the side flip of an asymmetric profile on the
         * end's tangent line, whose normal is across that line. */
        int at_end = (tau <= 0.0 && el->open_start) || (tau >= 1.0 && el->open_end);
        if (at_end && G->asym) {
          int on_circle = 0;
          for (int k = 0; k < G->nb; k++)
            on_circle |= JUMP(G, k) && BRK(G, k) != 0.0 && fabs(fabs(s) - fabs(BRK(G, k)) * G->w) <= 1e-6 * G->w;
          if (!on_circle) {
            double tg[2];
            elem_tangent(el, tau <= 0.0 ? 0.0 : 1.0, tg);
            n2[0] = -tg[1], n2[1] = tg[0];
          }
        }
      }
      if (n2[0] * R->d[0] + n2[1] * R->d[1] > 0.0) n2[0] = -n2[0], n2[1] = -n2[1];
      hit->wall = 1;
      hit->normal[0] = n2[0];
      hit->normal[1] = n2[1];
      hit->normal[2] = 0.0;
      hit->curve = r >= 0 ? Ch->g[r].curve : -1;
      hit->owner = st.owner_run >= 0 ? Ch->g[st.owner_run].curve : -1;
      return 1;
    }
  }
  /* A facet: the normal of h at the hit. */
  ch_gtex_sample smp;
  eval_in(g, hit->point[0], hit->point[1], Ch, &T.loaded, &smp);
  double l = sqrt(smp.grad[0] * smp.grad[0] + smp.grad[1] * smp.grad[1] + 1.0);
  hit->normal[0] = -smp.grad[0] / l;
  hit->normal[1] = -smp.grad[1] / l;
  hit->normal[2] = 1.0 / l;
  hit->curve = smp.active;
  hit->owner = smp.owner;
  return 1;
}

/* ---- building ---- */

void ch_gtex_free(ch_gtex *g) {
  free(g->grid);
  free(g->data);
  memset(g, 0, sizeof *g);
}

size_t ch_gtex_bytes(const ch_gtex *g) {
  return 16 * ((size_t)g->resolution * g->resolution + (size_t)g->num_texels);
}

/* The range of P over [a, b] (a <= b): its ends, the points inside with
 * their one-sided limits (jumps), and the ellipse's bottom. */
static void prof_range(const groove *G, double a, double b, double *lo, double *hi) {
  double pa = prof_eval(G, a), pb = prof_eval(G, b);
  double l = mn(pa, pb), h = mx(pa, pb);
  const double eps = 1e-12;
  for (int k = 0; k < G->nb; k++) {
    double c = BRK(G, k);
    if (!(c >= a && c <= b)) continue;
    double ts[3] = {c, mx(a, c - eps), mn(b, c + eps)};
    for (int j = 0; j < 3; j++) {
      double p = prof_eval(G, ts[j]);
      l = mn(l, p);
      h = mx(h, p);
    }
  }
  *lo = l;
  *hi = h;
}

static float round_down(double x) {
  float f = (float)x;
  if ((double)f > x) f = nextafterf(f, -INFINITY);
  return nextafterf(f, -INFINITY);
}
static float round_up(double x) {
  float f = (float)x;
  if ((double)f < x) f = nextafterf(f, INFINITY);
  return nextafterf(f, INFINITY);
}

ch_status ch_gtex_build(ch_gtex *g, const ch_curve_set *set, const ch_gtex_desc *desc, const char *name,
                        ch_error *err) {
  memset(g, 0, sizeof *g);
  int G = desc ? desc->resolution : 0;
  if (G < CH_GTEX_MIN_RES || G > CH_GTEX_MAX_RES)
    return ch_error_set(err, CH_ERR_INPUT, "%s: groove texture: grid resolution %d out of range %d..%d", name, G,
                        CH_GTEX_MIN_RES, CH_GTEX_MAX_RES);
  for (int c = 0; c < set->num_curves; c++) {
    const ch_curve *cv = &set->curves[c];
    char what[160];
    ch_curve_describe(cv, what, sizeof what);
    if (cv->kind == CH_CURVE_STEP)
      return ch_error_set(err, CH_ERR_INPUT,
                          "%s: %s: a step curve, which a groove texture cannot hold (its height is a diffusion over "
                          "the whole square, not a profile along its path)",
                          name, what);
    if (cv->kind == CH_CURVE_GROOVE && cv->profile.kind == CH_PROFILE_CUSTOM &&
        cv->profile.num_points > CH_GTEX_MAX_PROFILE_POINTS)
      return ch_error_set(err, CH_ERR_INPUT,
                          "%s: %s: a cross-section of %d points, more than the %d a groove texture holds per profile",
                          name, what, cv->profile.num_points, CH_GTEX_MAX_PROFILE_POINTS);
    if (!(cv->width > 0.0) || !isfinite(cv->depth))
      return ch_error_set(err, CH_ERR_INPUT, "%s: %s: a groove needs a positive width and a finite depth", name, what);
  }
  g->resolution = G;
  g->paper = desc->paper;
  /* Grooves and their elements, in the set's order. */
  int ng = 0, ne = 0, prof_texels = 0;
  int *groove_of = malloc((size_t)(set->num_curves + 1) * sizeof *groove_of);
  if (!groove_of) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the groove texture");
  for (int c = 0; c < set->num_curves; c++) {
    const ch_curve *cv = &set->curves[c];
    groove_of[c] = ng++;
    ne += cv->num_segments;
    int np = cv->profile.kind == CH_PROFILE_U ? 0
             : cv->profile.kind == CH_PROFILE_CUSTOM ? cv->profile.num_points
             : cv->profile.kind == CH_PROFILE_BOX ? 4
                                                   : 3;
    prof_texels += profile_texels(np);
  }
  g->num_grooves = ng;
  g->num_elements = ne;
  /* Cell lists: count, then fill (elements in the set's order in every
   * list, so a groove's elements are one run, as the point test needs). */
  size_t ncell = (size_t)G * G;
  int *count = calloc(ncell + 1, sizeof *count);
  ch_status st = CH_OK;
  int *start = NULL, *items = NULL, *fill = NULL;
  if (!count) {
    st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for the groove texture");
    goto done;
  }
  const double cs = 1.0 / G, half_diag = 0.5 * sqrt(2.0) * cs;
  /* A band a little wider than the profile's support, so that the probes a
   * hit takes just beyond a cell's border still see every element. */
  for (int pass = 0; pass < 2; pass++) {
    for (int e = 0; e < set->num_segments; e++) {
      const ch_segment *sg = &set->segments[e];
      const ch_curve *cv = &set->curves[sg->curve];
      double r = 0.5 * cv->width + 1e-6, box[4];
      ch_segment_box(sg, r, box);
      /* (Clamped before the casts: curves may lie far outside the square.) */
      double c0 = mx(floor(box[0] * G), 0.0), c1 = mn(floor(box[2] * G), G - 1.0);
      double r0 = mx(floor(box[1] * G), 0.0), r1 = mn(floor(box[3] * G), G - 1.0);
      if (!(c0 <= c1 && r0 <= r1)) continue;
      int i0 = (int)c0, i1 = (int)c1, j0 = (int)r0, j1 = (int)r1;
      for (int j = j0; j <= j1; j++)
        for (int i = i0; i <= i1; i++) {
          double c[2] = {(i + 0.5) * cs, (j + 0.5) * cs}, tau;
          double d2 = ch_bezier_closest(sg->p, sg->is_line, c, &tau);
          double reach = r + half_diag;
          if (d2 > reach * reach) continue;
          size_t ci = (size_t)j * G + i;
          if (pass == 0) {
            count[ci]++;
          } else {
            items[start[ci] + fill[ci]++] = e;
          }
        }
    }
    if (pass == 0) {
      start = malloc((ncell + 1) * sizeof *start);
      fill = calloc(ncell, sizeof *fill);
      if (!start || !fill) {
        st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for the groove texture");
        goto done;
      }
      size_t total = 0;
      for (size_t ci = 0; ci < ncell; ci++) {
        if (count[ci] > CH_GTEX_MAX_CELL_ITEMS) {
          int i = (int)(ci % G), j = (int)(ci / G);
          st = ch_error_set(err, CH_ERR_INPUT,
                            "%s: groove texture: cell (%d, %d) (u %.4g..%.4g, v %.4g..%.4g) is crossed by %d curve "
                            "segments, more than the %d a cell holds: use a finer grid",
                            name, i, j, i * cs, (i + 1) * cs, j * cs, (j + 1) * cs, count[ci], CH_GTEX_MAX_CELL_ITEMS);
          goto done;
        }
        start[ci] = (int)total;
        total += (size_t)count[ci];
        if (count[ci] > g->max_cell_items) g->max_cell_items = count[ci];
      }
      start[ncell] = (int)total;
      /* Texels: the lists (4 per texel, each list padded), the elements,
       * the grooves, the profiles. */
      double texels = (double)ne * ELEM_TEXELS + (double)ng * GROOVE_TEXELS + prof_texels;
      for (size_t ci = 0; ci < ncell; ci++) texels += (count[ci] + 3) / 4;
      if (texels >= FLOAT_INT_MAX || total >= (size_t)INT32_MAX) {
        st = ch_error_set(err, CH_ERR_INPUT,
                          "%s: groove texture: %.0f data texels, more than floats index exactly (%.0f): use a "
                          "coarser grid",
                          name, texels, FLOAT_INT_MAX);
        goto done;
      }
      items = malloc((total + 1) * sizeof *items);
      if (!items) {
        st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for the groove texture");
        goto done;
      }
      g->num_texels = (int)texels;
    }
  }
  g->grid = calloc(ncell * 4, sizeof *g->grid);
  g->data = calloc((size_t)g->num_texels * 4 + 4, sizeof *g->data);
  if (!g->grid || !g->data) {
    st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for the groove texture");
    goto done;
  }
  int at = 0;
  for (size_t ci = 0; ci < ncell; ci++) {
    float *gt = g->grid + 4 * ci;
    gt[0] = (float)at;
    gt[1] = (float)count[ci];
    for (int k = 0; k < count[ci]; k++) g->data[4 * (size_t)at + k] = (float)items[start[ci] + k];
    at += (count[ci] + 3) / 4;
  }
  g->element_base = at;
  for (int e = 0; e < ne; e++) {
    const ch_segment *sg = &set->segments[e];
    float *a = g->data + 4 * (size_t)(at + ELEM_TEXELS * e);
    a[0] = (float)sg->p[0][0], a[1] = (float)sg->p[0][1], a[2] = (float)sg->p[2][0], a[3] = (float)sg->p[2][1];
    a[4] = (float)sg->p[1][0], a[5] = (float)sg->p[1][1];
    a[6] = (float)groove_of[sg->curve];
    a[7] = (float)((sg->is_line ? 0 : FLAG_QUAD) | (sg->prev < 0 ? FLAG_OPEN_START : 0) |
                   (sg->next < 0 ? FLAG_OPEN_END : 0));
    double tin[2] = {0, 0}, tout[2] = {0, 0};
    if (sg->prev >= 0) ch_bezier_tangent(set->segments[sg->prev].p, 1.0, tin);
    if (sg->next >= 0) ch_bezier_tangent(set->segments[sg->next].p, 0.0, tout);
    a[8] = (float)tin[0], a[9] = (float)tin[1], a[10] = (float)tout[0], a[11] = (float)tout[1];
  }
  at += ELEM_TEXELS * ne;
  g->curve_base = at;
  g->profile_base = at + GROOVE_TEXELS * ng;
  int pat = g->profile_base;
  for (int c = 0; c < set->num_curves; c++) {
    const ch_curve *cv = &set->curves[c];
    float *a = g->data + 4 * (size_t)(at + GROOVE_TEXELS * groove_of[c]);
    a[0] = (float)cv->width, a[1] = (float)cv->depth, a[2] = (float)pat, a[3] = (float)cv->priority;
    a[4] = (float)c, a[5] = (float)cv->profile.kind;
    double pt[CH_PROFILE_MAX_POINTS][2];
    int np = 0, kind = PROFILE_POLY;
    switch (cv->profile.kind) {
    case CH_PROFILE_U: kind = PROFILE_ELLIPSE; break;
    case CH_PROFILE_V: np = 3, pt[0][0] = -0.5, pt[0][1] = 0, pt[1][0] = 0, pt[1][1] = -1, pt[2][0] = 0.5, pt[2][1] = 0; break;
    case CH_PROFILE_RIDGE: np = 3, pt[0][0] = -0.5, pt[0][1] = 0, pt[1][0] = 0, pt[1][1] = 1, pt[2][0] = 0.5, pt[2][1] = 0; break;
    case CH_PROFILE_BEVEL: np = 3, pt[0][0] = 0, pt[0][1] = 0, pt[1][0] = 0, pt[1][1] = -1, pt[2][0] = 0.5, pt[2][1] = 0; break;
    case CH_PROFILE_BOX:
      np = 4;
      pt[0][0] = -0.5, pt[0][1] = 0, pt[1][0] = -0.5, pt[1][1] = -1, pt[2][0] = 0.5, pt[2][1] = -1, pt[3][0] = 0.5, pt[3][1] = 0;
      break;
    case CH_PROFILE_CUSTOM:
      np = cv->profile.num_points;
      for (int k = 0; k < np; k++) pt[k][0] = cv->profile.t[k], pt[k][1] = cv->profile.h[k];
      break;
    }
    profile_block(g->data + 4 * (size_t)pat, kind, np, (const double(*)[2])pt);
    pat += profile_texels(np);
  }
  for (int k = 0; k < ng; k++) {
    groove Gr;
    load_groove(g, k, &Gr);
    int flags, mask;
    groove_derive(&Gr, &flags, &mask);
    float *a = g->data + 4 * (size_t)(g->curve_base + GROOVE_TEXELS * k);
    a[6] = (float)flags, a[7] = (float)mask;
  }
  /* Per cell, bounds of h: per element the profile's range over the
   * distances the cell spans, per groove their union; the CSG rule is
   * non-decreasing in every g, so h lies between F(lows) and F(highs). */
  double zmin = 0.0, zmax = 0.0;
#pragma omp parallel for schedule(dynamic, 16) reduction(min : zmin) reduction(max : zmax)
  for (int j = 0; j < G; j++) {
    cell C;
    for (int i = 0; i < G; i++) {
      size_t ci = (size_t)j * G + i;
      float *gt = g->grid + 4 * ci;
      if (gt[1] == 0.0f) continue;
      load_cell(g, (int)ci, &C, NULL);
      double c[2] = {(i + 0.5) * cs, (j + 0.5) * cs};
      double carve_lo = 0.0, carve_hi = 0.0, raise_lo = 0.0, raise_hi = 0.0;
      int any_carve_lo = 0, any_carve_hi = 0;
      for (int r = 0; r < C.ng; r++) {
        const groove *Gr = &C.g[r];
        double glo = INFINITY, ghi = -INFINITY;
        for (int k = C.gfirst[r]; k < C.gfirst[r + 1]; k++) {
          double tau, D = sqrt(elem_closest(&C.e[k], c, &tau)), rr = half_diag + 1e-6;
          double plo, phi, w = Gr->w;
          if (D <= rr) {
            prof_range(Gr, -(D + rr) / w, (D + rr) / w, &plo, &phi);
          } else {
            double l1, h1, l2, h2;
            prof_range(Gr, (D - rr) / w, (D + rr) / w, &l1, &h1);
            prof_range(Gr, -(D + rr) / w, -(D - rr) / w, &l2, &h2);
            plo = mn(l1, l2), phi = mx(h1, h2);
          }
          double a = Gr->d * plo, b = Gr->d * phi;
          glo = mn(glo, mn(a, b));
          ghi = mx(ghi, mx(a, b));
        }
        /* F over lows and over highs, accumulated. */
        if (glo < 0.0) any_carve_lo = 1, carve_lo = mn(carve_lo, glo);
        else raise_lo = mx(raise_lo, glo);
        if (ghi < 0.0) any_carve_hi = 1, carve_hi = mn(carve_hi, ghi);
        else raise_hi = mx(raise_hi, ghi);
      }
      double lo = any_carve_lo ? carve_lo : raise_lo, hi = any_carve_hi ? carve_hi : raise_hi;
      gt[2] = round_down(lo);
      gt[3] = round_up(hi);
      if (gt[2] < zmin) zmin = gt[2];
      if (gt[3] > zmax) zmax = gt[3];
    }
  }
  g->zmin = zmin;
  g->zmax = zmax;
done:
  free(groove_of);
  free(count);
  free(start);
  free(fill);
  free(items);
  if (st) ch_gtex_free(g);
  return st;
}

/* ---- region sampling (§5.7) ---- */

/* The CDF of s0 = a p + b q, a, b uniform in [-1/2, 1/2] (p, q >= 0): a
 * trapezoid (a box where one of them vanishes). */
static double trapezoid_cdf(double x, double p, double q) {
  if (p < q) {
    double t = p;
    p = q;
    q = t;
  }
  double h = 0.5 * (p + q);
  if (x <= -h) return 0.0;
  if (x >= h) return 1.0;
  if (q <= 1e-15 * (p + 1e-300)) return p > 0.0 ? (x + 0.5 * p) / p : (x >= 0.0 ? 1.0 : 0.0);
  /* Density: rising over [-h, -h + q], flat 1/p to h - q, falling to h. */
  double a = -h + q, b = h - q;
  if (x <= a) return (x + h) * (x + h) / (2.0 * p * q);
  if (x <= b) return 0.5 * q / p + (x - a) / p;
  return 1.0 - (h - x) * (h - x) / (2.0 * p * q);
}

int ch_gtex_region(const ch_gtex *g, const double at[2], const double dir[3], const double du[2], const double dv[2],
                   const double L[3], ch_gtex_facet out[CH_GTEX_MAX_FACETS]) {
  if (!(dir[2] < 0.0) || !(L[2] > 0.0)) return 0;
  /* The region the pixel's rays and their shadow rays can reach in UV. */
  double zlow = g->zmin;
  double reach[2] = {dir[0] * zlow / dir[2], dir[1] * zlow / dir[2]}, lreach[2] = {-L[0] * zlow / L[2], -L[1] * zlow / L[2]};
  double box[4] = {INFINITY, INFINITY, -INFINITY, -INFINITY};
  for (int c = 0; c < 4; c++) {
    double a = c & 1 ? 0.5 : -0.5, b = c & 2 ? 0.5 : -0.5;
    double p[2] = {at[0] + a * du[0] + b * dv[0], at[1] + a * du[1] + b * dv[1]};
    for (int k = 0; k < 3; k++) {
      double x = p[0] + (k == 1 ? reach[0] : k == 2 ? reach[0] + lreach[0] : 0.0);
      double y = p[1] + (k == 1 ? reach[1] : k == 2 ? reach[1] + lreach[1] : 0.0);
      box[0] = mn(box[0], x), box[1] = mn(box[1], y), box[2] = mx(box[2], x), box[3] = mx(box[3], y);
    }
  }
  if (!(box[0] >= 0.0 && box[1] >= 0.0 && box[2] <= 1.0 && box[3] <= 1.0)) return 0;
  /* One element in every cell the region touches. */
  int G = g->resolution, i0 = (int)(box[0] * G), i1 = (int)(box[2] * G), j0 = (int)(box[1] * G), j1 = (int)(box[3] * G);
  i1 = i1 >= G ? G - 1 : i1, j1 = j1 >= G ? G - 1 : j1;
  if ((i1 - i0 + 1) * (j1 - j0 + 1) > 64) return 0; /* (a pixel many cells wide: the paper's own limit) */
  int elem_id = -1;
  for (int j = j0; j <= j1; j++)
    for (int i = i0; i <= i1; i++) {
      const float *gt = g->grid + 4 * ((size_t)j * G + i);
      int first = (int)gt[0], n = (int)gt[1];
      for (int k = 0; k < n; k++) {
        int e = (int)texel(g, first + k / 4)[k % 4];
        if (elem_id >= 0 && e != elem_id) return 0;
        elem_id = e;
      }
    }
  if (elem_id < 0) {
    /* No groove: the top, lit. */
    memset(out, 0, sizeof *out);
    out[0].weight = out[0].lit = 1.0;
    out[0].normal[2] = 1.0;
    out[0].curve = -1;
    return 1;
  }
  elem el;
  groove G0;
  load_elem(g, elem_id, &el);
  elem_ready(&el);
  load_groove(g, el.groove, &G0);
  if (el.quad || G0.raises) return 0;
  double T[2] = {el.t0[0], el.t0[1]}, N[2] = {-T[1], T[0]};
  double len = len2d(el.p[2][0] - el.p[0][0], el.p[2][1] - el.p[0][1]), half = 0.5 * G0.w;
  /* Away from its ends (their caps): the region's extent along it. */
  double amin = INFINITY, amax = -INFINITY;
  for (int c = 0; c < 4; c++) {
    double x = c & 1 ? box[2] : box[0], y = c & 2 ? box[3] : box[1];
    double a = (x - el.p[0][0]) * T[0] + (y - el.p[0][1]) * T[1];
    amin = mn(amin, a), amax = mx(amax, a);
  }
  if (!(amin >= half && amax <= len - half)) return 0;
  /* The cross-section: s across (left positive), z up; the profile as a
   * polyline, the top on either side. */
  double ps[2 * CH_GTEX_MAX_PROFILE_POINTS + 40], pz[2 * CH_GTEX_MAX_PROFILE_POINTS + 40];
  int np = 0;
  const double far = 4.0; /* beyond any footprint */
  ps[np] = -far, pz[np++] = 0.0;
  if (G0.ellipse) {
    /* Chords even in the ellipse's angle, so in slope: steep at the rims. */
    for (int k = 0; k <= 32; k++) {
      double th = 3.14159265358979323846 * k / 32.0;
      ps[np] = -0.5 * cos(th) * G0.w, pz[np++] = -G0.d * sin(th);
    }
  } else {
    for (int k = 0; k < G0.n; k++) ps[np] = PT(&G0, k) * G0.w, pz[np++] = G0.d * PH(&G0, k);
  }
  ps[np] = far, pz[np++] = 0.0;
  /* View and light in the cross-section, walked in the direction the rays
   * travel (mirrored where that is -s). */
  double vs = dir[0] * N[0] + dir[1] * N[1], ls = L[0] * N[0] + L[1] * N[1];
  double sc = (at[0] - el.p[0][0]) * N[0] + (at[1] - el.p[0][1]) * N[1];
  double p = fabs(du[0] * N[0] + du[1] * N[1]), q = fabs(dv[0] * N[0] + dv[1] * N[1]);
  /* Per segment: visible part [v0, v1] and lit part [l0, l1] of its
   * parameter (0 at ps[k], 1 at ps[k + 1]). */
  double v0[2 * CH_GTEX_MAX_PROFILE_POINTS + 40], v1[2 * CH_GTEX_MAX_PROFILE_POINTS + 40];
  double l0[2 * CH_GTEX_MAX_PROFILE_POINTS + 40], l1[2 * CH_GTEX_MAX_PROFILE_POINTS + 40];
  for (int pass = 0; pass < 2; pass++) {
    /* The rays travel along (ts, tz) in the cross-section, tz < 0. */
    double ts = pass == 0 ? vs : -ls, tz = pass == 0 ? dir[2] : -L[2], k = fabs(ts) / fabs(tz);
    int fwd = ts >= 0.0;
    double M = -INFINITY;
    for (int c = 0; c + 1 < np; c++) {
      int seg = fwd ? c : np - 2 - c;
      /* Walk the segment from its first point in the travel direction. */
      double sa = fwd ? ps[seg] : -ps[seg + 1], za = fwd ? pz[seg] : pz[seg + 1];
      double sb = fwd ? ps[seg + 1] : -ps[seg], zb = fwd ? pz[seg + 1] : pz[seg];
      double ua = sa + k * za, ub = sb + k * zb;
      double lo = 1.0, hi = 1.0; /* the visible part, in the walk's parameter */
      if (ub > M && ub > ua) {
        lo = ua >= M ? 0.0 : (M - ua) / (ub - ua);
        hi = 1.0;
      }
      M = mx(M, mx(ua, ub));
      /* Back to the segment's own parameter. */
      double a = fwd ? lo : 1.0 - hi, b = fwd ? hi : 1.0 - lo;
      if (pass == 0) v0[seg] = a, v1[seg] = b;
      else l0[seg] = a, l1[seg] = b;
    }
  }
  /* Weights: the measure of s0 over each visible part. */
  int nf = 0;
  double kv = -vs / dir[2];
  for (int seg = 0; seg + 1 < np && nf < CH_GTEX_MAX_FACETS; seg++) {
    if (!(v1[seg] > v0[seg])) continue;
    double ds = ps[seg + 1] - ps[seg], dz = pz[seg + 1] - pz[seg];
    /* s0 of a point = s + k z; of the parameter x: u(x). */
    double u0 = ps[seg] + kv * pz[seg], du_ = ds + kv * dz;
    double xa = v0[seg], xb = v1[seg];
    double w = fabs(trapezoid_cdf(u0 + du_ * xb - sc, p, q) - trapezoid_cdf(u0 + du_ * xa - sc, p, q));
    if (!(w > 0.0)) continue;
    double la = mx(xa, l0[seg]), lb = mn(xb, l1[seg]);
    double lit = lb > la ? fabs(trapezoid_cdf(u0 + du_ * lb - sc, p, q) - trapezoid_cdf(u0 + du_ * la - sc, p, q)) : 0.0;
    ch_gtex_facet *f = &out[nf++];
    memset(f, 0, sizeof *f);
    f->weight = w;
    f->lit = mn(lit, w);
    double ns = -dz, nz = ds, l = len2d(ns, nz);
    ns /= l, nz /= l;
    f->wall = ds == 0.0;
    if (f->wall && ns * vs > 0.0) ns = -ns; /* facing the viewer */
    f->normal[0] = ns * N[0];
    f->normal[1] = ns * N[1];
    f->normal[2] = nz;
    f->curve = seg == 0 || seg == np - 2 ? -1 : G0.curve;
  }
  return nf;
}
