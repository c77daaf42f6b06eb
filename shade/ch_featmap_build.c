/* Building feature-curve textures: feature-curves-textures §4 (signatures,
 * the transformation table, the constrained fit, the distance and gradient
 * rasterisation and its constrained Laplacian smoothing) and
 * normal-maps-discontinuities §4.1-4.2 (the linear variant).
 *
 * Why one file of about 1,700 lines: the steps below are one build over
 * one private working state (the lattice's samples, the per-cell pieces,
 * the edge points and their fit), each step reading what the one before
 * left there; the evaluation, its cell geometry and the EXR form are
 * already their own files (ch_featmap_eval.c, ch_featmap_cell.h,
 * ch_featmap_io.c), and cutting the build further would put that working
 * state in a header for no caller.
 *
 * Steps, and where they depart from the papers:
 * 1. Samples at the lattice points: the exact closest point on the curves
 *    within a band of the curves (a grid over the segments), the closest
 *    point of a neighbour beyond (8SSEDT propagation), so every sample has
 *    its distance, gradient, nearest curve and side. The papers rasterise
 *    each segment's distance over its bounding box; same result in band.
 * 2. Every curve is cut at the lattice lines (the papers' scan conversion):
 *    a piece per cell, from the edge it enters by to the edge it leaves by.
 *    Steps 2-3 read no sample: they run on one thread while the other
 *    propagates the samples (a sequential sweep).
 * 3. Per cell the through-pieces, longest first, go through the
 *    transformation table (configuration, new pair) -> configuration: a
 *    pair already present is merged, a third pair is dropped (§4, Fig. 6).
 *    Pieces that end inside, leave by their entry edge or never leave are
 *    the papers' one-intersection case: only their crossing point is kept.
 *    Every edge point is the centre of mass of the crossings of kept
 *    pieces on that edge, its angle the mean tangent direction.
 * 4. A signature is valid when its segments' tangent lines meet inside the
 *    cell, the implicit side test is unambiguous there (§5.2: the
 *    parabola's other branch stays outside; tested exactly rather than by
 *    the paper's bound (7)) and the eight-triangle partition is proper
 *    (spokes cross once, no curve crosses another edge of the partition).
 *    Invalid cells get the constrained fit of §4 eq. (2)-(3): the
 *    thin-plate energy of the cell's segments and of the neighbours'
 *    segments joined to them, minimised over the shared edge points'
 *    tangent angles subject to every affected cell staying valid (the
 *    paper also frees the edge points' positions and solves by SQP; we keep
 *    the positions, which are where the curve crosses, and search the few
 *    angles coordinate-wise, which needs no derivatives of the validity
 *    conditions). Where no valid angles exist the segment is made straight
 *    (§5.2's own remedy for too flat segments).
 * 5. The gradient samples are smoothed by the constrained Laplacian (10
 *    Jacobi steps, each sample half-way to the mean of its 4-neighbours
 *    not across a discontinuity: an edge with a point); the distance is
 *    left alone (§4 "Rasterization").
 * 6. Beyond the papers: cells that hold what the representation cannot
 *    (more curves, merged points, ends, loops, corners, straightened
 *    segments) get a list of the exact segments near them (at most
 *    CH_FEATMAP_MAX_PIECES, the nearest) and are evaluated exactly from it.
 * 7. The base normal map B (the normal of h_step alone, one-sided at step
 *    curves) and a conventional normal map of h (box-filtered) at the same
 *    lattice, for comparison. */
#include "ch_featmap.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "ch_alloc.h"
#include "ch_bezier.h"
#include "ch_edt.h"
#include "ch_featmap_cell.h"
#include "ch_grid.h"
#include "ch_groove.h"
#include "ch_height.h"
#include "ch_math.h"

int ch_featmap_encodes(const ch_curve_set *set, int c) {
  const ch_curve *cv = &set->curves[c];
  return cv->kind == CH_CURVE_GROOVE || !(cv->blur > 0.0);
}

void ch_featmap_free(ch_featmap *m) {
  free(m->dist);
  free(m->grad);
  free(m->curve);
  free(m->base);
  free(m->normal);
  free(m->edge);
  free(m->config);
  free(m->seg_curve);
  free(m->fb_start);
  free(m->fb_count);
  free(m->fb_list);
  free(m->pieces);
  free(m->curves);
  free(m->singular);
  free(m->sg_near);
  memset(m, 0, sizeof *m);
}

double ch_featmap_singular_window(const ch_stepsing_point *pt, double distance) {
  return ch_stepsing_window(distance, pt->radius * (CH_FEATMAP_SINGULAR_R0 / CH_FEATMAP_SINGULAR_R1), pt->radius);
}

ch_status ch_featmap_singular_index(ch_featmap *m, ch_error *err) {
  free(m->sg_near);
  m->sg_near = NULL;
  if (m->num_singular <= 0) return CH_OK;
  int R = m->resolution, R1 = R + 1;
  m->sg_near = malloc((size_t)R1 * R1 * sizeof *m->sg_near);
  if (!m->sg_near) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the maps' singular points");
  for (size_t k = 0; k < (size_t)R1 * R1; k++) m->sg_near[k] = -1;
  double du = (m->rect[2] - m->rect[0]) / R, dv = (m->rect[3] - m->rect[1]) / R;
  if (!(m->sg_window > 0.0)) m->sg_window = CH_FEATMAP_SINGULAR_R1;
  ch_status st = ch_stepsing_limit_radii(m->singular, m->num_singular, m->sg_window * sqrt(du * dv), err);
  if (st) return st;
  /* each point stamps the lattice points within its radius; the nearest keeps them */
  for (int p = 0; p < m->num_singular; p++) {
    const double *c = m->singular[p].p, reach = m->singular[p].radius;
    double x = (c[0] - m->rect[0]) / du - CH_FEATMAP_OFFSET_X, y = (c[1] - m->rect[1]) / dv - CH_FEATMAP_OFFSET_Y;
    double rx = reach / du + 1.0, ry = reach / dv + 1.0;
    if (!(x + rx >= 0.0 && x - rx <= R && y + ry >= 0.0 && y - ry <= R)) continue;
    int j0 = (int)fmax(0.0, ceil(x - rx)), j1 = (int)fmin(R, floor(x + rx));
    int i0 = (int)fmax(0.0, ceil(y - ry)), i1 = (int)fmin(R, floor(y + ry));
    for (int i = i0; i <= i1; i++)
      for (int j = j0; j <= j1; j++) {
        double q[2] = {m->rect[0] + (j + CH_FEATMAP_OFFSET_X) * du, m->rect[1] + (i + CH_FEATMAP_OFFSET_Y) * dv};
        double d = hypot(q[0] - c[0], q[1] - c[1]);
        if (d > reach) continue;
        int32_t *slot = &m->sg_near[(size_t)i * R1 + j];
        if (*slot >= 0) {
          const double *o = m->singular[*slot].p;
          if (!(d < hypot(q[0] - o[0], q[1] - o[1]))) continue;
        }
        *slot = p;
      }
  }
  return CH_OK;
}

/* ---- the lattice ---- */

typedef struct lattice {
  int R, R1;
  double rect[4];
  double du, dv;        /* cell size in the maps' space (UV, or warped UV) */
  const ch_warp *warp;  /* NULL, or the maps live in warped UV */
} lattice;

/* The original UV of lattice coordinates (x, y). */
static void lattice_uv(const lattice *L, double x, double y, double uv[2]) {
  double w[2] = {L->rect[0] + (x + CH_FEATMAP_OFFSET_X) * L->du, L->rect[1] + (y + CH_FEATMAP_OFFSET_Y) * L->dv};
  if (L->warp) ch_warp_unmap(L->warp, w, uv);
  else uv[0] = w[0], uv[1] = w[1];
}

/* Lattice coordinates of a point of the maps' space. */
static void maps_lattice(const lattice *L, const double w[2], double xy[2]) {
  xy[0] = (w[0] - L->rect[0]) / L->du - CH_FEATMAP_OFFSET_X;
  xy[1] = (w[1] - L->rect[1]) / L->dv - CH_FEATMAP_OFFSET_Y;
}

/* Lattice coordinates of an original UV point. */
static void uv_lattice(const lattice *L, const double uv[2], double xy[2]) {
  double w[2] = {uv[0], uv[1]};
  if (L->warp) ch_warp_map(L->warp, uv, w);
  maps_lattice(L, w, xy);
}

/* The UV image of cell (ci, cj)'s unit square to first order: the UV of
 * its SW corner and the UV steps along x and y (columns of the Jacobian). */
static void cell_frame(const lattice *L, int ci, int cj, double o[2], double ex[2], double ey[2]) {
  double a[2], b[2];
  lattice_uv(L, cj, ci, o);
  lattice_uv(L, cj + 1, ci, a);
  lattice_uv(L, cj, ci + 1, b);
  ex[0] = a[0] - o[0], ex[1] = a[1] - o[1];
  ey[0] = b[0] - o[0], ey[1] = b[1] - o[1];
}

/* ---- 1. samples ---- */

/* Writes a sample's record from its closest point (segment seg at t). */
static void set_sample(const ch_curve_set *set, ch_featmap *m, size_t k, const double q[2], int seg, double t) {
  double P[2];
  ch_segment_point(&set->segments[seg], t, P);
  double dx = q[0] - P[0], dy = q[1] - P[1], d = sqrt(dx * dx + dy * dy);
  int side = ch_curve_side(set, seg, t, q);
  m->dist[k] = (float)(side * d);
  m->curve[k] = set->segments[seg].curve;
  if (d > 1e-12) {
    m->grad[2 * k] = (float)(dx / d);
    m->grad[2 * k + 1] = (float)(dy / d);
  } else {
    /* On the curve: the normal pointing to the sample's side. */
    double tg[2];
    ch_bezier_tangent(set->segments[seg].p, t, tg);
    m->grad[2 * k] = (float)(-tg[1] * side);
    m->grad[2 * k + 1] = (float)(tg[0] * side);
  }
}

/* The segments near the lattice, kept from the samples to the checks:
 * each encoded segment's box grown by the band, a grid over those boxes,
 * and which lattice points got an exact sample. */
typedef struct sample_index {
  double band;
  double (*boxes)[4];
  ch_grid grid;
  uint8_t *exact;
  /* until the samples are done: per exact point its closest segment and
   * parameter, and the seeds propagated from them */
  int32_t *seg;
  float *segt;
  ch_edt_rec *rec;
} sample_index;

static void sample_index_free(sample_index *ix) {
  ch_grid_free(&ix->grid);
  free(ix->boxes);
  free(ix->exact);
  free(ix->seg);
  free(ix->segt);
  free(ix->rec);
  memset(ix, 0, sizeof *ix);
}

/* The exact distance from UV point q to the nearest encoded curve, or NaN
 * beyond the band. */
static double index_distance(const ch_curve_set *set, const sample_index *ix, const double q[2]) {
  const int *items;
  int cnt = ch_grid_query(&ix->grid, q[0], q[1], &items);
  double best = INFINITY;
  for (int a = 0; a < cnt; a++) {
    const double *b = ix->boxes[items[a]];
    if (q[0] < b[0] || q[0] > b[2] || q[1] < b[1] || q[1] > b[3]) continue;
    const ch_segment *s = &set->segments[items[a]];
    double t, d2 = ch_bezier_closest(s->p, s->is_line, q, &t);
    if (d2 < best) best = d2;
  }
  return sqrt(best) <= ix->band ? sqrt(best) : NAN;
}

/* Samples in three steps: the exact ones within the band (samples_exact),
 * their seeds propagated (ch_edt_propagate on ix->rec), the rest from the
 * seeds (samples_rest). cover[k] is set where a groove other
 * than the nearest curve reaches the point (distance under its half width),
 * the only points where the grooves' CSG can pick another curve than the
 * nearest: the overlap check evaluates the groove field there alone. */
static ch_status samples_exact(const ch_curve_set *set, const unsigned char *use, const lattice *L, ch_featmap *m,
                               sample_index *ix, uint8_t *cover, ch_error *err) {
  int R1 = L->R1;
  size_t n = (size_t)R1 * R1;
  double texel = fmax(L->du, L->dv), half = 0.0;
  for (int c = 0; c < set->num_curves; c++)
    if (use[c] && set->curves[c].kind == CH_CURVE_GROOVE) half = fmax(half, 0.5 * set->curves[c].width);
  /* Exact within the widest groove's half width plus two cells: where
   * profiles are read and where cells hold curves. */
  double band = ch_clamp(half / texel + 2.0, 3.0, 64.0) * texel;
  /* Grooves wider than the band (the clamp) may reach a point from
   * segments the band leaves out: every point is then checked. */
  int cover_all = !(band > half);
  memset(ix, 0, sizeof *ix);
  ix->band = band;
  ix->boxes = malloc((size_t)(set->num_segments > 0 ? set->num_segments : 1) * sizeof *ix->boxes);
  ix->exact = ch_alloc_large(n, 1, 0);
  double(*boxes)[4] = ix->boxes;
  uint8_t *exact = ix->exact;
  int32_t *seg = ix->seg = ch_alloc_large(n, sizeof *seg, 0);
  float *segt = ix->segt = ch_alloc_large(n, sizeof *segt, 0);
  ch_edt_rec *rec = ix->rec = ch_alloc_large(n, sizeof *rec, 0);
  if (!boxes || !seg || !segt || !exact || !rec)
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for %dx%d feature samples", R1, R1);
  for (int i = 0; i < set->num_segments; i++) {
    const ch_segment *s = &set->segments[i];
    if (!use[s->curve]) {
      boxes[i][0] = boxes[i][1] = 1.0;
      boxes[i][2] = boxes[i][3] = 0.0;
    } else {
      ch_segment_box(s, band, boxes[i]);
    }
  }
  ch_status st = ch_grid_build(&ix->grid, set->num_segments, (const double(*)[4])boxes, err);
  if (st) return st;
#pragma omp parallel for schedule(dynamic, 4)
  for (int y = 0; y < R1; y++)
    for (int x = 0; x < R1; x++) {
      size_t k = (size_t)y * R1 + x;
      double q[2];
      lattice_uv(L, x, y, q);
      const int *items;
      int cnt = ch_grid_query(&ix->grid, q[0], q[1], &items);
      double best = INFINITY, bt = 0.0;
      int bs = -1, cov0 = -1, cov1 = -1; /* the first two grooves reaching q */
      for (int a = 0; a < cnt; a++) {
        const double *b = boxes[items[a]];
        if (q[0] < b[0] || q[0] > b[2] || q[1] < b[1] || q[1] > b[3]) continue;
        const ch_segment *s = &set->segments[items[a]];
        double t, d2 = ch_bezier_closest(s->p, s->is_line, q, &t);
        if (d2 < best) best = d2, bt = t, bs = items[a];
        const ch_curve *cv = &set->curves[s->curve];
        double hw = 0.5 * cv->width; /* as the groove field's support test */
        if (cv->kind == CH_CURVE_GROOVE && d2 < hw * hw && s->curve != cov0) {
          if (cov0 < 0) cov0 = s->curve;
          else cov1 = s->curve;
        }
      }
      exact[k] = bs >= 0 && sqrt(best) <= band;
      int near_curve = bs >= 0 ? set->segments[bs].curve : -1;
      cover[k] = (uint8_t)(cover_all || cov1 >= 0 || (cov0 >= 0 && cov0 != near_curve));
      seg[k] = exact[k] ? bs : -1;
      segt[k] = (float)bt;
      rec[k].seed = exact[k] ? (int32_t)k : -1;
      rec[k].d2 = INFINITY;
      if (exact[k]) {
        double P[2], xy[2];
        ch_segment_point(&set->segments[bs], bt, P);
        uv_lattice(L, P, xy);
        rec[k].x = (float)xy[0];
        rec[k].y = (float)xy[1];
        rec[k].d2 = (float)((xy[0] - x) * (xy[0] - x) + (xy[1] - y) * (xy[1] - y));
        set_sample(set, m, k, q, bs, bt);
      }
    }
  return CH_OK;
}

/* Beyond the band: the seed's exact closest point, measured in UV. */
static void samples_rest(const ch_curve_set *set, const unsigned char *use, const lattice *L, ch_featmap *m,
                         sample_index *ix) {
  int R1 = L->R1;
  const uint8_t *exact = ix->exact;
  const int32_t *seg = ix->seg;
  const float *segt = ix->segt;
  const ch_edt_rec *rec = ix->rec;
#pragma omp parallel for schedule(dynamic, 16)
  for (int y = 0; y < R1; y++)
    for (int x = 0; x < R1; x++) {
      size_t k = (size_t)y * R1 + x;
      if (exact[k]) continue;
      double q[2];
      lattice_uv(L, x, y, q);
      int s0 = rec[k].seed;
      if (s0 >= 0) {
        set_sample(set, m, k, q, seg[s0], segt[s0]);
        continue;
      }
      /* No curve within the band anywhere (curves far outside the
       * rectangle): the nearest of all, by brute force. */
      double best = INFINITY, bt = 0.0;
      int bs = -1;
      for (int i = 0; i < set->num_segments; i++) {
        if (!use[set->segments[i].curve]) continue;
        double t, d2 = ch_bezier_closest(set->segments[i].p, set->segments[i].is_line, q, &t);
        if (d2 < best) best = d2, bt = t, bs = i;
      }
      set_sample(set, m, k, q, bs, bt);
    }
  free(ix->seg);
  free(ix->segt);
  free(ix->rec);
  ix->seg = NULL, ix->segt = NULL, ix->rec = NULL;
}

/* ---- 2. crossings and pieces ---- */

typedef struct event {
  double g;     /* position along the subpath: segment index within it + t */
  int axis;     /* 0: a vertical lattice line x = k, 1: a horizontal one y = k */
  int k;
  double xy[2]; /* lattice coordinates */
  double angle; /* tangent direction in lattice coordinates, mod pi */
  int used;     /* a kept piece ends here */
} event;

typedef struct piece {
  int cell;            /* i * R + j, or -1 outside the grid */
  int ea, eb;          /* events at its ends (-1: it ends inside) */
  int edge_a, edge_b;  /* cell edges of those events (-1: none or inconsistent) */
  int curve, subpath;
  double length;       /* lattice units */
  double sagitta;      /* largest distance from its chord (lattice units) */
  int corner;          /* a tangent jump inside */
  double ga, gb;       /* its ends along the subpath (gb may pass the end of a closed one) */
  int kept;
  int forward;         /* runs from edge_a to edge_b */
} piece;

typedef struct vec_event {
  event *v;
  size_t n, cap;
} vec_event;
typedef struct vec_piece {
  piece *v;
  size_t n, cap;
} vec_piece;

static int push_event(vec_event *a, const event *e) {
  if (a->n == a->cap) {
    size_t cap = a->cap ? 2 * a->cap : 1024;
    event *p = realloc(a->v, cap * sizeof *p);
    if (!p) return -1;
    a->v = p, a->cap = cap;
  }
  a->v[a->n++] = *e;
  return 0;
}

static int push_piece(vec_piece *a, const piece *e) {
  if (a->n == a->cap) {
    size_t cap = a->cap ? 2 * a->cap : 1024;
    piece *p = realloc(a->v, cap * sizeof *p);
    if (!p) return -1;
    a->v = p, a->cap = cap;
  }
  a->v[a->n++] = *e;
  return 0;
}

static int cmp_event(const void *a, const void *b) {
  double x = ((const event *)a)->g, y = ((const event *)b)->g;
  return (x > y) - (x < y);
}

/* A segment in lattice coordinates. */
static void segment_lattice(const lattice *L, const ch_segment *s, double p[3][2]) {
  for (int k = 0; k < 3; k++) maps_lattice(L, s->p[k], p[k]);
  if (s->is_line) { /* exact midpoint: the quadratic is the line */
    p[1][0] = 0.5 * (p[0][0] + p[2][0]);
    p[1][1] = 0.5 * (p[0][1] + p[2][1]);
  }
}

static void quad_eval(const double p[3][2], double t, double out[2]) {
  double s = 1.0 - t;
  out[0] = s * s * p[0][0] + 2.0 * s * t * p[1][0] + t * t * p[2][0];
  out[1] = s * s * p[0][1] + 2.0 * s * t * p[1][1] + t * t * p[2][1];
}

static double tangent_angle(const double p[3][2], double t) {
  double d[2];
  ch_bezier_tangent(p, t, d);
  double a = atan2(d[1], d[0]);
  if (a > 0.5 * CH_PI) a -= CH_PI;
  if (a <= -0.5 * CH_PI) a += CH_PI;
  return a;
}

/* Crossings of one segment (lattice coordinates) with the lattice lines
 * 0..R, t in [0, 1). Touching a line without crossing it is no event. */
static int segment_events(const double p[3][2], int R, double g0, vec_event *out) {
  for (int axis = 0; axis < 2; axis++) {
    double a = p[0][axis] - 2.0 * p[1][axis] + p[2][axis], b = 2.0 * (p[1][axis] - p[0][axis]), c = p[0][axis];
    double lo = fmin(p[0][axis], p[2][axis]), hi = fmax(p[0][axis], p[2][axis]);
    if (a != 0.0) {
      double tv = -b / (2.0 * a);
      if (tv > 0.0 && tv < 1.0) {
        double cv = c + tv * (b + a * tv);
        lo = fmin(lo, cv), hi = fmax(hi, cv);
      }
    }
    int k0 = (int)fmax(0.0, ceil(lo)), k1 = (int)fmin((double)R, floor(hi));
    for (int k = k0; k <= k1; k++) {
      double r[2];
      int nr = fm_roots(a, b, c - k, r);
      if (nr == 2 && fabs(r[1] - r[0]) < 1e-12) continue; /* touches */
      for (int i = 0; i < nr; i++) {
        if (!(r[i] >= 0.0 && r[i] < 1.0)) continue;
        event e = {.g = g0 + r[i], .axis = axis, .k = k, .used = 0};
        quad_eval(p, r[i], e.xy);
        e.xy[axis] = k;
        e.angle = tangent_angle(p, r[i]);
        if (push_event(out, &e)) return -1;
      }
    }
  }
  return 0;
}

/* The point of a subpath at position g (segment index + t), lattice; a
 * closed subpath wraps round, an open one ends at its last point. */
static void subpath_point(const ch_curve_set *set, const lattice *L, const ch_subpath *sp, double g, double out[2]) {
  if (sp->closed && g >= sp->num_segments) g -= sp->num_segments;
  int i = (int)floor(g);
  if (i >= sp->num_segments) i = sp->num_segments - 1;
  if (i < 0) i = 0;
  double p[3][2];
  segment_lattice(L, &set->segments[sp->first_segment + i], p);
  quad_eval(p, ch_clamp(g - i, 0.0, 1.0), out);
}

/* The cell edge that event e is on, seen from cell (ci, cj); -1 if e does
 * not bound that cell. */
static int event_edge(const event *e, int ci, int cj) {
  if (e->axis == 0) return e->k == cj ? FM_W : e->k == cj + 1 ? FM_E : -1;
  return e->k == ci ? FM_S : e->k == ci + 1 ? FM_N : -1;
}

/* The position of e along that edge. */
static double event_pos(const event *e, int ci, int cj) { return e->axis == 0 ? e->xy[1] - ci : e->xy[0] - cj; }

/* Walks [ga, gb] (gb may pass the end of a closed subpath: wraps) and
 * measures the piece: polyline length and tangent jumps at joints. */
static void measure_piece(const ch_curve_set *set, const lattice *L, const ch_subpath *sp, double ga, double gb,
                          double *length, double *sagitta, int *corner) {
  int ns = sp->num_segments;
  double len = 0.0, prev[2], a[2], b[2], sag = 0.0;
  *corner = 0;
  const int steps = 8;
  subpath_point(set, L, sp, ga, prev);
  subpath_point(set, L, sp, ga, a);
  subpath_point(set, L, sp, gb, b);
  double ch[2] = {b[0] - a[0], b[1] - a[1]}, cl = hypot(ch[0], ch[1]);
  for (int s = 1; s <= steps; s++) {
    double g = ga + (gb - ga) * s / steps, pt[2];
    subpath_point(set, L, sp, g, pt);
    len += hypot(pt[0] - prev[0], pt[1] - prev[1]);
    prev[0] = pt[0], prev[1] = pt[1];
    double d[2] = {pt[0] - a[0], pt[1] - a[1]};
    sag = fmax(sag, cl > 0.0 ? fabs(ch_cross2(ch, d)) / cl : hypot(d[0], d[1]));
  }
  *length = len;
  *sagitta = sag;
  /* joints strictly inside */
  for (double j = floor(ga) + 1.0; j < gb; j += 1.0) {
    int b = (int)fmod(j, ns), a = (b - 1 + ns) % ns;
    if (!sp->closed && b == 0) continue;
    const ch_segment *sa = &set->segments[sp->first_segment + a], *sb = &set->segments[sp->first_segment + b];
    double pa[3][2], pb[3][2], ta[2], tb[2];
    segment_lattice(L, sa, pa);
    segment_lattice(L, sb, pb);
    ch_bezier_tangent(pa, 1.0, ta);
    ch_bezier_tangent(pb, 0.0, tb);
    if (ch_dot2(ta, tb) < cos(1e-3)) *corner = 1;
  }
}

/* Cuts every encoded curve into pieces per cell. */
static ch_status build_pieces(const ch_curve_set *set, const unsigned char *use, const lattice *L, vec_event *ev,
                              vec_piece *pc, ch_error *err) {
  int R = L->R;
  for (int si = 0; si < set->num_subpaths; si++) {
    const ch_subpath *sp = &set->subpaths[si];
    if (sp->num_segments < 1) continue;
    int curve = set->segments[sp->first_segment].curve;
    if (!use[curve]) continue;
    size_t first = ev->n;
    for (int i = 0; i < sp->num_segments; i++) {
      double p[3][2];
      segment_lattice(L, &set->segments[sp->first_segment + i], p);
      if (segment_events(p, R, i, ev)) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for curve crossings");
    }
    size_t ne = ev->n - first;
    if (ne > 1) qsort(ev->v + first, ne, sizeof *ev->v, cmp_event); /* (ev->v is NULL before any event) */
    int ns = sp->num_segments;
    /* Pieces between consecutive events; the ends of an open subpath, or
     * the wrap of a closed one. */
    size_t npieces = sp->closed ? (ne ? ne : 1) : ne + 1;
    for (size_t k = 0; k < npieces; k++) {
      piece p = {.ea = -1, .eb = -1, .edge_a = -1, .edge_b = -1, .curve = curve, .subpath = si, .forward = 1};
      double ga, gb;
      if (sp->closed) {
        if (ne == 0) {
          ga = 0.0, gb = ns;
        } else {
          p.ea = (int)(first + k);
          p.eb = (int)(first + (k + 1) % ne);
          ga = ev->v[p.ea].g;
          gb = ev->v[p.eb].g;
          if (gb <= ga) gb += ns;
        }
      } else {
        p.ea = k > 0 ? (int)(first + k - 1) : -1;
        p.eb = k < ne ? (int)(first + k) : -1;
        ga = p.ea >= 0 ? ev->v[p.ea].g : 0.0;
        gb = p.eb >= 0 ? ev->v[p.eb].g : ns;
      }
      p.ga = ga, p.gb = gb;
      double mid[2];
      subpath_point(set, L, sp, 0.5 * (ga + gb), mid);
      int ci = (int)floor(mid[1]), cj = (int)floor(mid[0]);
      p.cell = ci >= 0 && cj >= 0 && ci < R && cj < R ? ci * R + cj : -1;
      if (p.cell < 0) {
        if (push_piece(pc, &p)) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for curve pieces");
        continue;
      }
      if (p.ea >= 0) p.edge_a = event_edge(&ev->v[p.ea], ci, cj);
      if (p.eb >= 0) p.edge_b = event_edge(&ev->v[p.eb], ci, cj);
      measure_piece(set, L, sp, ga, gb, &p.length, &p.sagitta, &p.corner);
      if (push_piece(pc, &p)) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for curve pieces");
    }
  }
  return CH_OK;
}

/* Pieces closer than this to their chord (texels) are stored straight. */
#define FLAT 1e-4

/* ---- 3. configurations: the transformation table ---- */

/* A configuration is the set of segments (edge pairs 1..6) of a cell, at
 * most two. Adding pair p to configuration c gives the new configuration
 * and what happened: 0 added, 1 merged (already there), 2 dropped (the
 * cell is full). Every result is a valid configuration (at most two
 * segments; each edge carries one point, shared by the segments using it). */
typedef struct transform {
  uint8_t seg[2];
  uint8_t what;
} transform;

static transform table_apply(const uint8_t seg[2], int p);

unsigned ch_featmap_transform(unsigned config, int pair, int *what) {
  uint8_t seg[2] = {(uint8_t)(config & CH_FM_SEG_MASK), (uint8_t)((config >> CH_FM_SEG_BITS) & CH_FM_SEG_MASK)};
  transform t = table_apply(seg, pair);
  if (what) *what = t.what;
  return (unsigned)t.seg[0] | ((unsigned)t.seg[1] << CH_FM_SEG_BITS);
}

static transform table_apply(const uint8_t seg[2], int p) {
  transform t = {{seg[0], seg[1]}, 0};
  if (seg[0] == p || seg[1] == p) {
    t.what = 1;
  } else if (!seg[0]) {
    t.seg[0] = (uint8_t)p;
  } else if (!seg[1]) {
    t.seg[1] = (uint8_t)p;
  } else {
    t.what = 2;
  }
  return t;
}

/* ---- 4. signatures, validity and the fit ---- */

/* Samples of a partition curve strictly inside (t in (0, 1)). */
enum { CHECK_SAMPLES = 12 };

static int curve_in_quadrant(const fm_partition *P, const fm_curve *c, int corner) {
  for (int i = 1; i < CHECK_SAMPLES; i++) {
    double q[2];
    fm_curve_eval(c, (double)i / CHECK_SAMPLES, q);
    if (fm_quadrant(P, q) != corner) return 0;
  }
  return 1;
}

/* Whether a spoke (V: vertical 1, H: 0) stays off every chord's corner
 * side and crosses the other spoke once, at r. */
static int spoke_ok(const fm_partition *P, int vertical) {
  const fm_curve *c = vertical ? &P->V : &P->H;
  const fm_curve *o = vertical ? &P->H : &P->V;
  double tr = vertical ? P->tv : P->th;
  for (int i = 1; i < CHECK_SAMPLES; i++) {
    double t = (double)i / CHECK_SAMPLES, q[2];
    fm_curve_eval(c, t, q);
    for (int k = 0; k < 4; k++)
      if (fm_corner_side(P, k, q)) return 0;
    if (fabs(t - tr) < 1e-3) continue;
    /* V below r is south of H (right of W -> E), above r north; H left of
     * r is west of V (left of S -> N), right of r east. */
    int left = fm_left(o, q);
    if (vertical ? left != (t > tr) : left != (t < tr)) return 0;
  }
  return 1;
}

static int cell_valid(const fm_signature *s, int linear) {
  fm_curve seg[2];
  if (!fm_segment_curves(s, linear, seg)) return 0;
  for (int k = 0; k < s->nseg; k++) {
    if (seg[k].straight) continue;
    const double *b1 = seg[k].p[1];
    if (!(b1[0] > 1e-6 && b1[0] < 1.0 - 1e-6 && b1[1] > 1e-6 && b1[1] < 1.0 - 1e-6)) return 0;
    if (!fm_curve_safe(&seg[k])) return 0;
  }
  fm_partition P;
  fm_partition_make(s, seg, &P);
  if (!P.ok) return 0;
  if (!(P.r[0] > 0.0 && P.r[0] < 1.0 && P.r[1] > 0.0 && P.r[1] < 1.0)) return 0;
  if (!P.V.straight || !P.H.straight || s->nseg > 0) {
    if (!spoke_ok(&P, 1) || !spoke_ok(&P, 0)) return 0;
    for (int k = 0; k < 4; k++)
      if (!P.chord[k].straight && !curve_in_quadrant(&P, &P.chord[k], (k + 1) % 4)) return 0;
  }
  return 1;
}

/* Thin-plate energy of a cell's curved segments, feature-curves eq. (3):
 * 4 |b0 - 2 b1 + b2|^2 (0 for straight ones). */
static double cell_energy(const fm_signature *s) {
  fm_curve seg[2];
  if (!fm_segment_curves(s, 0, seg)) return INFINITY;
  double e = 0.0;
  for (int k = 0; k < s->nseg; k++) {
    if (seg[k].straight) continue;
    double dx = seg[k].p[0][0] - 2.0 * seg[k].p[1][0] + seg[k].p[2][0];
    double dy = seg[k].p[0][1] - 2.0 * seg[k].p[1][1] + seg[k].p[2][1];
    e += 4.0 * (dx * dx + dy * dy);
  }
  return e;
}

/* Whether cell (i, j) has a segment ending on its edge e. */
static int cell_uses_edge(const fm_signature *s, int e) {
  for (int k = 0; k < s->nseg; k++)
    if (fm_pair_edges[s->pair[k]][0] == e || fm_pair_edges[s->pair[k]][1] == e) return 1;
  return 0;
}

/* The angle slot of cell (ci, cj)'s edge e in m->edge. */
static float *edge_angle(ch_featmap *m, int R, int ci, int cj, int e) {
  int R1 = R + 1;
  switch (e) {
  case FM_S: return &m->edge[4 * ((size_t)ci * R1 + cj) + 1];
  case FM_W: return &m->edge[4 * ((size_t)ci * R1 + cj) + 3];
  case FM_E: return &m->edge[4 * ((size_t)ci * R1 + cj + 1) + 3];
  default: return &m->edge[4 * ((size_t)(ci + 1) * R1 + cj) + 1];
  }
}

typedef struct fit_cell {
  int i, j;
} fit_cell;

/* The objective over the affected cells: energy, plus 1e6 per invalid one. */
static double fit_objective(const ch_featmap *m, const fit_cell *cells, int n) {
  double f = 0.0;
  for (int k = 0; k < n; k++) {
    fm_signature s;
    fm_cell_signature(m, cells[k].i, cells[k].j, &s);
    if (!s.nseg) continue;
    double e = cell_energy(&s);
    f += cell_valid(&s, 0) ? (isfinite(e) ? e : 1e6) : 1e6;
  }
  return f;
}

/* The constrained fit of cell (ci, cj): its used edge points' angles. The
 * other cells touched are the neighbours across those edges. Returns 1 if
 * the cell is valid afterwards. */
static int fit_cell_angles(ch_featmap *m, int R, int ci, int cj) {
  fm_signature s;
  fm_cell_signature(m, ci, cj, &s);
  fit_cell cells[5] = {{ci, cj}};
  int ncells = 1;
  float *var[4];
  int nvar = 0;
  static const int di[4] = {-1, 0, 1, 0}, dj[4] = {0, 1, 0, -1};
  for (int e = 0; e < 4; e++) {
    if (!cell_uses_edge(&s, e)) continue;
    var[nvar++] = edge_angle(m, R, ci, cj, e);
    int ni = ci + di[e], nj = cj + dj[e];
    if (ni >= 0 && nj >= 0 && ni < R && nj < R) cells[ncells++] = (fit_cell){ni, nj};
  }
  double best = fit_objective(m, cells, ncells);
  /* Coordinate search: a coarse sweep of each angle over half a turn,
   * then two finer ones around the best. */
  static const int sweeps[3] = {24, 9, 9};
  static const double spans[3] = {CH_PI, CH_PI / 12.0, CH_PI / 54.0};
  for (int round = 0; round < 3; round++)
    for (int v = 0; v < nvar; v++) {
      float start = *var[v], keep = start;
      for (int k = 0; k < sweeps[round]; k++) {
        double a = round == 0 ? -0.5 * CH_PI + CH_PI * (k + 0.5) / sweeps[round]
                              : start + spans[round] * ((double)k / (sweeps[round] - 1) - 0.5);
        if (a > 0.5 * CH_PI) a -= CH_PI;
        if (a <= -0.5 * CH_PI) a += CH_PI;
        *var[v] = (float)a;
        double f = fit_objective(m, cells, ncells);
        if (f < best) best = f, keep = (float)a;
      }
      *var[v] = keep;
    }
  fm_cell_signature(m, ci, cj, &s);
  return cell_valid(&s, 0);
}

/* ---- 5. smoothing ---- */

/* Whether sample k is smoothed (see smooth_gradient). */
static int smoothed(const ch_featmap *m, size_t k, double texel, int everywhere) {
  const ch_featmap_curve *c = &m->curves[m->curve[k]];
  double band = (c->kind == CH_CURVE_GROOVE ? 0.5 * c->width : 0.0) + 1.5 * texel, d = fabs(m->dist[k]);
  return everywhere || (d > band && d <= band + 8.0 * texel);
}

/* The papers' constrained Laplacian smoothing (feature-curves §4, 10
 * iterations): each sample moves half-way to the mean of its 4-neighbours
 * that no discontinuity separates from it (an edge with a point), then is
 * renormalised; Jacobi steps, so the order of work does not matter.
 * Departure: samples within their curve's profile band (plus 1.5 cells)
 * keep their exact gradient, and samples farther than 8 cells beyond it
 * are not visited: the smoothing acts on a ring away from the features,
 * where it removes the medial axes' jumps, and where b(d) = 1 hides it
 * from the normal (everywhere, as the papers do, with `everywhere`). */
static ch_status smooth_gradient(ch_featmap *m, const lattice *L, int iterations, int everywhere, ch_error *err) {
  int R = L->R, R1 = R + 1;
  size_t n = (size_t)R1 * R1;
  double texel = fmax(L->du, L->dv);
  /* The samples to smooth, in index order: counted per row, then listed. */
  size_t *row = malloc(((size_t)R1 + 1) * sizeof *row);
  if (!row) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the gradient smoothing");
#pragma omp parallel for schedule(static)
  for (int y = 0; y < R1; y++) {
    size_t cnt = 0;
    for (size_t k = (size_t)y * R1; k < (size_t)(y + 1) * R1; k++) cnt += (size_t)smoothed(m, k, texel, everywhere);
    row[y + 1] = cnt;
  }
  row[0] = 0;
  for (int y = 0; y < R1; y++) row[y + 1] += row[y];
  size_t count = row[R1];
  int32_t *list = ch_alloc_large(count > 0 ? count : 1, sizeof *list, 0);
  /* Jacobi steps from one copy of the gradients into the other and back:
   * one pass and one wait per step. */
  float *other = iterations > 0 ? ch_alloc_large(2 * n, sizeof *other, 0) : NULL;
  if (!list || (iterations > 0 && !other)) {
    free(row);
    free(list);
    free(other);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the gradient smoothing");
  }
#pragma omp parallel for schedule(static)
  for (int y = 0; y < R1; y++) {
    size_t at = row[y];
    for (size_t k = (size_t)y * R1; k < (size_t)(y + 1) * R1; k++)
      if (smoothed(m, k, texel, everywhere)) list[at++] = (int32_t)k;
    if (other) memcpy(other + 2 * (size_t)y * R1, m->grad + 2 * (size_t)y * R1, 2 * (size_t)R1 * sizeof *other);
  }
  free(row);
  float *bufs[2] = {m->grad, other};
  const uint32_t *config = m->config;
#pragma omp parallel if (count > (1 << 16))
  for (int it = 0; it < iterations; it++) {
    const float *g = bufs[it % 2];
    float *next = bufs[(it + 1) % 2];
#pragma omp for schedule(static)
    for (long a = 0; a < (long)count; a++) {
      size_t k = (size_t)list[a];
      int x = (int)(k % R1), y = (int)(k / R1);
      double sx = 0.0, sy = 0.0;
      int cnt = 0;
      /* The edge between two neighbours is a cell edge: S edge of (y, x)
       * joins (y, x) and (y, x+1); W edge of (y, x) joins (y, x), (y+1, x). */
      if (x + 1 < R1 && !(config[k] & CH_FM_POINT_S)) sx += g[2 * (k + 1)], sy += g[2 * (k + 1) + 1], cnt++;
      if (x > 0 && !(config[k - 1] & CH_FM_POINT_S)) sx += g[2 * (k - 1)], sy += g[2 * (k - 1) + 1], cnt++;
      if (y + 1 < R1 && !(config[k] & CH_FM_POINT_W)) sx += g[2 * (k + R1)], sy += g[2 * (k + R1) + 1], cnt++;
      if (y > 0 && !(config[k - R1] & CH_FM_POINT_W)) sx += g[2 * (k - R1)], sy += g[2 * (k - R1) + 1], cnt++;
      double gx = g[2 * k], gy = g[2 * k + 1];
      if (cnt) {
        gx += 0.5 * (sx / cnt - gx);
        gy += 0.5 * (sy / cnt - gy);
      }
      double l = sqrt(gx * gx + gy * gy);
      if (l > 1e-12) gx /= l, gy /= l;
      else gx = g[2 * k], gy = g[2 * k + 1];
      next[2 * k] = (float)gx;
      next[2 * k + 1] = (float)gy;
    }
  }
  /* The last step's copy is the gradient map. */
  if (iterations % 2) {
    m->grad = other;
    other = bufs[0];
  }
  free(list);
  free(other);
  return CH_OK;
}

/* ---- 7. normals of h ---- */

/* The exact unit normal of h at uv (grooves analytic, steps by one-sided
 * differences of h_step), as ch_truth_normal computes it, from the groove
 * field and, if given, the height's step part. */
static double profile_slope_checked(const ch_profile *pr, double t) { return ch_featmap_profile_slope(pr, t); }

static void across(const ch_curve_set *set, const ch_groove_field *f, int curve, const double q[2], double n[2]) {
  const int *items;
  int cnt = ch_grid_query(&f->grid, q[0], q[1], &items);
  double best = INFINITY, bt = 0.0;
  int bs = -1;
  for (int k = 0; k < cnt; k++) {
    const ch_segment *s = &set->segments[items[k]];
    if (s->curve != curve) continue;
    double t, d2 = ch_bezier_closest(s->p, s->is_line, q, &t);
    if (d2 < best) best = d2, bt = t, bs = items[k];
  }
  if (bs < 0) {
    ch_curve_point cp;
    ch_curve_closest(set, curve, q, &cp);
    bs = cp.segment, bt = cp.t;
  }
  double P[2];
  ch_segment_point(&set->segments[bs], bt, P);
  double d[2] = {q[0] - P[0], q[1] - P[1]}, l = hypot(d[0], d[1]);
  if (l > 1e-12) {
    n[0] = d[0] / l, n[1] = d[1] / l;
  } else {
    double tg[2];
    ch_bezier_tangent(set->segments[bs].p, bt, tg);
    n[0] = -tg[1], n[1] = tg[0];
  }
}

static void step_gradient(const ch_height *h, double u, double v, int curve, int side, double dist, double g[2]) {
  const double e = 1e-5;
  ch_recon_sample rs;
  if (curve >= 0 && fabs(dist) < 4.0 * e) { /* dist: the lattice's, a float; the exact one below */
    /* A stencil across the curve reads the other side's field (with an
     * open curve's double layer, h_step's own jump): a point nearer than
     * 2e takes the gradient 2e off the curve on its side instead (a corner
     * 1e-5 UV from a step at R 1024 read 500 for a slope of 0.01). */
    double q[2] = {u, v}, n[2];
    ch_curve_point cp;
    ch_curve_closest(h->set, curve, q, &cp);
    if (cp.distance < 2.0 * e) {
      if (cp.distance > 1e-12) {
        n[0] = (q[0] - cp.point[0]) / cp.distance, n[1] = (q[1] - cp.point[1]) / cp.distance;
        if ((cp.signed_distance >= 0.0) != (side == CH_SIDE_LEFT)) n[0] = -n[0], n[1] = -n[1];
      } else {
        double tg[2];
        ch_bezier_tangent(h->set->segments[cp.segment].p, cp.t, tg);
        double l = hypot(tg[0], tg[1]), s = side == CH_SIDE_LEFT ? 1.0 : -1.0;
        n[0] = l > 0.0 ? -s * tg[1] / l : 0.0, n[1] = l > 0.0 ? s * tg[0] / l : 0.0;
      }
      u = cp.point[0] + 2.0 * e * n[0];
      v = cp.point[1] + 2.0 * e * n[1];
    }
  }
  for (int axis = 0; axis < 2; axis++) {
    double p[2] = {u, v}, q[2] = {u, v};
    p[axis] += e;
    q[axis] -= e;
    if (curve >= 0) {
      ch_height_step_side(h, p[0], p[1], curve, side, &rs);
      double a = rs.value;
      ch_height_step_side(h, q[0], q[1], curve, side, &rs);
      g[axis] = (a - rs.value) / (2.0 * e);
    } else {
      ch_height_step(h, p[0], p[1], &rs);
      double a = rs.value;
      ch_height_step(h, q[0], q[1], &rs);
      g[axis] = (a - rs.value) / (2.0 * e);
    }
  }
}

static void exact_normal(const ch_curve_set *set, const ch_groove_field *f, const ch_height *h, double u, double v,
                         double n[3]) {
  double g[2] = {0.0, 0.0}, q[2] = {u, v};
  ch_groove_sample gs;
  ch_groove_field_eval(f, u, v, &gs);
  if (gs.active >= 0) {
    const ch_curve *c = &set->curves[gs.active];
    double slope = profile_slope_checked(&c->profile, gs.active_signed_distance / c->width);
    if (slope != 0.0) {
      double ds[2];
      across(set, f, gs.active, q, ds);
      double sign = gs.active_signed_distance >= 0.0 ? 1.0 : -1.0;
      double k = c->depth / c->width * slope * sign;
      g[0] += k * ds[0];
      g[1] += k * ds[1];
    }
  }
  if (h && h->has_steps) {
    /* One-sided differences, the flatter side (ch_truth_normal's rule). */
    const double e = 1e-5;
    ch_recon_sample rs;
    ch_height_step(h, u, v, &rs);
    double h0 = rs.value;
    for (int axis = 0; axis < 2; axis++) {
      double p[2] = {u, v}, mq[2] = {u, v};
      p[axis] += e;
      mq[axis] -= e;
      ch_height_step(h, p[0], p[1], &rs);
      double fwd = (rs.value - h0) / e;
      ch_height_step(h, mq[0], mq[1], &rs);
      double back = (h0 - rs.value) / e;
      g[axis] += fabs(fwd) <= fabs(back) ? fwd : back;
    }
  }
  double len = sqrt(g[0] * g[0] + g[1] * g[1] + 1.0);
  n[0] = -g[0] / len;
  n[1] = -g[1] / len;
  n[2] = 1.0 / len;
}

/* ---- 6. fallback lists ---- */

static void piece_from_segment(const ch_curve_set *set, int si, ch_featmap_piece *p) {
  const ch_segment *s = &set->segments[si];
  memset(p, 0, sizeof *p);
  memcpy(p->p, s->p, sizeof p->p);
  p->curve = s->curve;
  p->is_line = s->is_line;
  p->start_open = s->prev < 0;
  p->end_open = s->next < 0;
  if (s->prev >= 0) ch_bezier_tangent(set->segments[s->prev].p, 1.0, p->tin);
  if (s->next >= 0) ch_bezier_tangent(set->segments[s->next].p, 0.0, p->tout);
}

typedef struct cand {
  double d;
  int seg;
} cand;

static int cmp_cand(const void *a, const void *b) {
  const cand *x = a, *y = b;
  if (x->d != y->d) return (x->d > y->d) - (x->d < y->d);
  return (x->seg > y->seg) - (x->seg < y->seg);
}

static ch_status build_fallback(const ch_curve_set *set, const unsigned char *use, const lattice *L, ch_featmap *m,
                                ch_error *err) {
  int R = L->R, R1 = R + 1;
  size_t ncell = (size_t)R1 * R1;
  double widest = 0.0;
  for (int c = 0; c < set->num_curves; c++)
    if (use[c] && set->curves[c].kind == CH_CURVE_GROOVE) widest = fmax(widest, 0.5 * set->curves[c].width);
  /* Candidate segments through the grid of segment boxes (grown by
   * nothing: the cell's box is grown instead, per cell). */
  double(*boxes)[4] = malloc((size_t)(set->num_segments > 0 ? set->num_segments : 1) * sizeof *boxes);
  int32_t *counts = calloc(ncell, sizeof *counts);
  int32_t(*lists)[CH_FEATMAP_MAX_PIECES] = NULL;
  int32_t *piece_of = malloc((size_t)(set->num_segments > 0 ? set->num_segments : 1) * sizeof *piece_of);
  ch_grid grid = {0};
  ch_status st = CH_OK;
  long nfb = 0;
  for (size_t c = 0; c < ncell; c++) nfb += (m->config[c] & CH_FM_FALLBACK) != 0;
  int32_t *fb_cells = malloc((size_t)(nfb > 0 ? nfb : 1) * sizeof *fb_cells);
  lists = malloc((size_t)(nfb > 0 ? nfb : 1) * sizeof *lists);
  if (!boxes || !counts || !piece_of || !fb_cells || !lists) {
    st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for the fallback lists");
    goto done;
  }
  nfb = 0;
  for (size_t c = 0; c < ncell; c++)
    if (m->config[c] & CH_FM_FALLBACK) fb_cells[nfb++] = (int32_t)c;
  for (int i = 0; i < set->num_segments; i++) {
    if (!use[set->segments[i].curve]) {
      boxes[i][0] = boxes[i][1] = 1.0;
      boxes[i][2] = boxes[i][3] = 0.0;
    } else {
      ch_segment_box(&set->segments[i], 0.0, boxes[i]);
    }
  }
  if ((st = ch_grid_build(&grid, set->num_segments, (const double(*)[4])boxes, err))) goto done;
  long overflow = 0;
#pragma omp parallel for schedule(dynamic, 4) reduction(+ : overflow) if (nfb > 512)
  for (long f = 0; f < nfb; f++) {
    int c = fb_cells[f], ci = c / R1, cj = c % R1;
    /* the cell's UV box: its corners' (and, under a warp, a margin) */
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (int k = 0; k < 4; k++) {
      double uv[2];
      lattice_uv(L, cj + (k == 1 || k == 2), ci + (k >= 2), uv);
      lo[0] = fmin(lo[0], uv[0]), lo[1] = fmin(lo[1], uv[1]);
      hi[0] = fmax(hi[0], uv[0]), hi[1] = fmax(hi[1], uv[1]);
    }
    if (L->warp) {
      double g = 0.1 * fmax(hi[0] - lo[0], hi[1] - lo[1]);
      lo[0] -= g, lo[1] -= g, hi[0] += g, hi[1] += g;
    }
    double diag = hypot(hi[0] - lo[0], hi[1] - lo[1]);
    double cen[2] = {0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])};
    /* The nearest curve point of any point of the cell is within the
     * nearest corner's distance plus the cell's diagonal of it; grooves
     * reaching into the cell are within their half width. */
    double reach = INFINITY;
    for (int k = 0; k < 4; k++) {
      size_t s = (size_t)(ci + (k >= 2)) * R1 + cj + (k == 1 || k == 2);
      reach = fmin(reach, fabs(m->dist[s]));
    }
    reach = fmax(reach + 2.0 * diag, widest + diag);
    double box[4] = {lo[0] - reach, lo[1] - reach, hi[0] + reach, hi[1] + reach};
    cand cs[128];
    int nc = 0;
    /* Visit the grid cells under the grown box. */
    int gx0 = (int)floor((box[0] - grid.origin[0]) * grid.inv_cell), gy0 = (int)floor((box[1] - grid.origin[1]) * grid.inv_cell);
    int gx1 = (int)floor((box[2] - grid.origin[0]) * grid.inv_cell), gy1 = (int)floor((box[3] - grid.origin[1]) * grid.inv_cell);
    gx0 = gx0 < 0 ? 0 : gx0, gy0 = gy0 < 0 ? 0 : gy0;
    gx1 = gx1 >= grid.nx ? grid.nx - 1 : gx1, gy1 = gy1 >= grid.ny ? grid.ny - 1 : gy1;
    for (int gy = gy0; gy <= gy1; gy++)
      for (int gx = gx0; gx <= gx1; gx++) {
        int gc = gy * grid.nx + gx;
        for (int a = grid.cell_start[gc]; a < grid.cell_start[gc + 1]; a++) {
          int si = grid.items[a];
          const double *b = boxes[si];
          if (b[2] < box[0] || b[0] > box[2] || b[3] < box[1] || b[1] > box[3]) continue;
          int dup = 0;
          for (int k = 0; k < nc && !dup; k++) dup = cs[k].seg == si;
          if (dup) continue;
          double t, d2 = ch_bezier_closest(set->segments[si].p, set->segments[si].is_line, cen, &t);
          if (nc < 128) cs[nc++] = (cand){sqrt(d2), si};
          else overflow++;
        }
      }
    qsort(cs, (size_t)nc, sizeof *cs, cmp_cand);
    /* Keep those that can be the nearest somewhere in the cell, and
     * grooves whose band reaches into it (they take part in the CSG). */
    int kept = 0;
    double dmin = nc ? cs[0].d : 0.0;
    for (int k = 0; k < nc; k++) {
      const ch_curve *cv = &set->curves[set->segments[cs[k].seg].curve];
      double band = cv->kind == CH_CURVE_GROOVE ? 0.5 * cv->width + 0.5 * diag : 0.0;
      if (!(cs[k].d <= dmin + diag || cs[k].d <= band)) continue;
      if (kept == CH_FEATMAP_MAX_PIECES) {
        overflow++;
        break;
      }
      lists[f][kept++] = cs[k].seg;
    }
    counts[c] = kept;
  }
  /* Pieces: the segments listed, in segment order (deterministic). */
  for (int i = 0; i < set->num_segments; i++) piece_of[i] = -1;
  long entries = 0;
  for (long f = 0; f < nfb; f++) {
    int c = fb_cells[f];
    entries += counts[c];
    for (int k = 0; k < counts[c]; k++) piece_of[lists[f][k]] = 0;
  }
  int np = 0;
  for (int i = 0; i < set->num_segments; i++)
    if (piece_of[i] == 0) piece_of[i] = np++;
  m->pieces = malloc((size_t)(np > 0 ? np : 1) * sizeof *m->pieces);
  m->fb_list = malloc((size_t)(entries > 0 ? entries : 1) * sizeof *m->fb_list);
  if (!m->pieces || !m->fb_list) {
    st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for the fallback lists");
    goto done;
  }
  for (int i = 0; i < set->num_segments; i++)
    if (piece_of[i] >= 0) piece_from_segment(set, i, &m->pieces[piece_of[i]]);
  m->num_pieces = np;
  long at = 0;
  for (long f = 0; f < nfb; f++) {
    int c = fb_cells[f];
    m->fb_start[c] = (int32_t)at;
    m->fb_count[c] = (uint8_t)counts[c];
    for (int k = 0; k < counts[c]; k++) m->fb_list[at++] = piece_of[lists[f][k]];
  }
  m->fb_list_size = (int)at;
  m->has_fallback = 1;
  m->stats.fallback_cells = nfb;
  m->stats.fallback_entries = at;
  m->stats.fallback_overflow = overflow;
done:
  ch_grid_free(&grid);
  free(boxes);
  free(counts);
  free(lists);
  free(piece_of);
  free(fb_cells);
  return st;
}

/* ---- the build ---- */

/* Whether |a - b| > limit, as hypot decides it, calling hypot only where
 * the two bounds max(|dx|, |dy|) <= |a - b| <= |dx| + |dy| leave it open
 * (the check asks this for every pair of corners near the curves). */
static int jumps(const double a[2], const double b[2], double limit) {
  double dx = fabs(a[0] - b[0]), dy = fabs(a[1] - b[1]);
  if (fmax(dx, dy) > limit) return 1;
  if ((dx + dy) * (1.0 + 1e-12) <= limit) return 0;
  return hypot(dx, dy) > limit;
}

/* A used crossing on edge slot 2 c + (W edge). */
typedef struct edge_use {
  size_t slot, event;
  double pos;
} edge_use;

/* Sorts uses by slot, keeping the order of equal slots (so by event):
 * two stable counting passes, by the slot's column and side, then by its
 * row (rows 0..R1-1, 2 R1 slots a row). */
static int sort_edge_uses(edge_use *eu, size_t nu, int R1) {
  size_t width = 2 * (size_t)R1, nb = width > (size_t)R1 ? width : (size_t)R1;
  edge_use *tmp = malloc((nu > 0 ? nu : 1) * sizeof *tmp);
  size_t *at = malloc((nb + 1) * sizeof *at);
  if (!tmp || !at) {
    free(tmp);
    free(at);
    return -1;
  }
  for (int pass = 0; pass < 2; pass++) {
    edge_use *from = pass ? tmp : eu, *to = pass ? eu : tmp;
    size_t buckets = pass ? (size_t)R1 : width;
    memset(at, 0, (buckets + 1) * sizeof *at);
    for (size_t a = 0; a < nu; a++) at[(pass ? from[a].slot / width : from[a].slot % width) + 1]++;
    for (size_t b = 0; b < buckets; b++) at[b + 1] += at[b];
    for (size_t a = 0; a < nu; a++) to[at[pass ? from[a].slot / width : from[a].slot % width]++] = from[a];
  }
  free(tmp);
  free(at);
  return 0;
}

static int cmp_piece_cell(const void *a, const void *b) {
  const piece *x = *(piece *const *)a, *y = *(piece *const *)b;
  if (x->cell != y->cell) return (x->cell > y->cell) - (x->cell < y->cell);
  /* longest first; ties by position in the list (stable) */
  if (x->length != y->length) return (x->length < y->length) - (x->length > y->length);
  return (x > y) - (x < y);
}

/* Steps 2-3: the curves cut into pieces per cell (under a warp, the curves
 * warped through the cage, into *warped), the configurations and the edge
 * points. Reads only the curves and the lattice, so it runs beside the
 * samples' propagation. */
static ch_status build_cells(const ch_curve_set *set, const unsigned char *use, const lattice *L, const ch_warp *warp,
                             ch_curve_set *warped, const ch_curve_set **pset, vec_event *ev, vec_piece *pc,
                             piece ***order_out, size_t *nin_out, ch_featmap *m, ch_error *err) {
  int R = L->R, R1 = R + 1;
  ch_status st = CH_OK;
  if (warp) {
    if ((st = ch_warp_curves(warp, set, warped, NULL, err))) return st;
    *pset = warped;
  }
  if ((st = build_pieces(*pset, use, L, ev, pc, err))) return st;
  piece **order = *order_out = malloc((pc->n > 0 ? pc->n : 1) * sizeof *order);
  if (!order) {
    st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for curve pieces");
    return st;
  }
  size_t nin = 0;
  for (size_t k = 0; k < pc->n; k++)
    if (pc->v[k].cell >= 0) order[nin++] = &pc->v[k];
  *nin_out = nin;
  qsort(order, nin, sizeof *order, cmp_piece_cell);
  for (size_t a = 0; a < nin;) {
    size_t b = a;
    int cell = order[a]->cell, ci = cell / R, cj = cell % R;
    size_t c = (size_t)ci * R1 + cj;
    uint8_t segs[2] = {0, 0};
    uint32_t lost = 0;
    int curve_of[2] = {-1, -1}, rev[2] = {0, 0}, flat[2] = {0, 0};
    for (; b < nin && order[b]->cell == cell; b++) {
      piece *p = order[b];
      if (p->corner) lost |= CH_FM_LOST_CORNER;
      int na = p->edge_a >= 0, nb = p->edge_b >= 0;
      if ((p->ea >= 0 && !na) || (p->eb >= 0 && !nb)) {
        lost |= CH_FM_LOST_LOOP; /* crossings that do not bound its cell */
        continue;
      }
      if (!na && !nb) {
        lost |= CH_FM_LOST_LOOP;
        continue;
      }
      if (na != nb) {
        lost |= CH_FM_LOST_END;
        continue;
      }
      if (p->edge_a == p->edge_b) {
        lost |= CH_FM_LOST_LOOP;
        continue;
      }
      int pair = fm_pair_index(p->edge_a, p->edge_b);
      transform t = table_apply(segs, pair);
      if (t.what == 2) {
        lost |= CH_FM_LOST_DROPPED;
        m->stats.pieces_dropped++;
        continue;
      }
      if (t.what == 1) lost |= CH_FM_LOST_MERGED;
      else {
        int slot = segs[0] ? 1 : 0;
        curve_of[slot] = p->curve;
        rev[slot] = p->edge_a > p->edge_b;
        /* A piece within FLAT of its chord is a straight segment: exact
         * enough, and its tangent lines (often a tiny corner clip) need
         * not meet inside the cell. */
        flat[slot] = !p->corner && p->sagitta < FLAT;
      }
      segs[0] = t.seg[0], segs[1] = t.seg[1];
      p->kept = 1;
      if (p->ea >= 0) ev->v[p->ea].used++;
      if (p->eb >= 0) ev->v[p->eb].used++;
    }
    m->config[c] |= (uint32_t)segs[0] | ((uint32_t)segs[1] << CH_FM_SEG_BITS) | lost;
    if (rev[0]) m->config[c] |= CH_FM_REVERSED0;
    if (rev[1]) m->config[c] |= CH_FM_REVERSED1;
    if (flat[0] && !m->linear) m->config[c] |= CH_FM_STRAIGHT0;
    if (flat[1] && !m->linear) m->config[c] |= CH_FM_STRAIGHT1;
    m->seg_curve[2 * c] = curve_of[0];
    m->seg_curve[2 * c + 1] = curve_of[1];
    a = b;
  }
  /* Edge points: the crossings of kept pieces, centre of mass. The used
   * crossings are sorted by edge slot (then by their order, so every sum
   * adds in the same order): a pass over those few, not over every slot. */
  {
    edge_use *eu = malloc((ev->n > 0 ? ev->n : 1) * sizeof *eu);
    if (!eu) {
      st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for edge points");
      return st;
    }
    size_t nu = 0;
    for (size_t k = 0; k < ev->n; k++) {
      const event *e = &ev->v[k];
      if (!e->used) continue;
      /* the edge: vertical line x = k at y -> W edge of cell (floor y, k);
       * horizontal y = k at x -> S edge of cell (k, floor x) */
      int ci = e->axis == 0 ? (int)floor(e->xy[1]) : e->k, cj = e->axis == 0 ? e->k : (int)floor(e->xy[0]);
      /* vertical edges exist for rows 0..R-1, horizontal ones for columns 0..R-1 */
      if (ci < 0 || cj < 0 || ci > R || cj > R || (e->axis == 0 ? ci == R : cj == R)) continue;
      size_t c = (size_t)ci * R1 + cj;
      eu[nu++] = (edge_use){2 * c + (e->axis == 0), k, event_pos(e, ci, cj)};
    }
    if (sort_edge_uses(eu, nu, R1)) {
      free(eu);
      st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for edge points");
      return st;
    }
    for (size_t a = 0; a < nu;) {
      size_t slot = eu[a].slot, c = slot / 2;
      int w = (int)(slot % 2);
      double acc[4] = {0.0, 0.0, 0.0, 0.0}; /* count, pos, cos 2a, sin 2a */
      for (; a < nu && eu[a].slot == slot; a++) {
        double angle = ev->v[eu[a].event].angle;
        acc[0] += 1.0;
        acc[1] += eu[a].pos;
        acc[2] += cos(2.0 * angle);
        acc[3] += sin(2.0 * angle);
      }
      double pos = ch_clamp(acc[1] / acc[0], 1e-9, 1.0 - 1e-9);
      double ang = 0.5 * atan2(acc[3], acc[2]);
      m->edge[4 * c + 2 * w] = (float)pos;
      m->edge[4 * c + 2 * w + 1] = (float)ang;
      m->config[c] |= w ? CH_FM_POINT_W : CH_FM_POINT_S;
      m->stats.points++;
      if (acc[0] > 1.0) {
        m->stats.crossings_merged += (long)acc[0] - 1;
        /* both cells sharing the edge */
        int ci = (int)(c / R1), cj = (int)(c % R1);
        if (ci < R && cj < R) m->config[c] |= CH_FM_LOST_MERGED;
        if (w == 0 && ci > 0 && cj < R) m->config[c - R1] |= CH_FM_LOST_MERGED;
        if (w == 1 && cj > 0 && ci < R) m->config[c - 1] |= CH_FM_LOST_MERGED;
      }
    }
    free(eu);
  }
  return CH_OK;
}

ch_status ch_featmap_check_lattice(const char *what, int resolution, const double rect[4], double out[4],
                                   ch_error *err) {
  if (resolution < CH_FEATMAP_MIN_RES || resolution > CH_FEATMAP_MAX_RES)
    return ch_error_set(err, CH_ERR_INPUT, "%s resolution %d outside %d..%d", what, resolution, CH_FEATMAP_MIN_RES,
                        CH_FEATMAP_MAX_RES);
  for (int k = 0; k < 4; k++) out[k] = rect[k];
  if (out[0] == 0.0 && out[1] == 0.0 && out[2] == 0.0 && out[3] == 0.0) out[2] = out[3] = 1.0;
  for (int k = 0; k < 4; k++)
    if (!isfinite(out[k])) return ch_error_set(err, CH_ERR_INPUT, "%s rectangle is not finite", what);
  if (!(out[2] > out[0] && out[3] > out[1]))
    return ch_error_set(err, CH_ERR_INPUT, "empty %s rectangle %g,%g,%g,%g", what, out[0], out[1], out[2], out[3]);
  return CH_OK;
}

ch_status ch_featmap_build(const ch_curve_set *set, const ch_featmap_desc *desc, ch_featmap *m, ch_error *err) {
  memset(m, 0, sizeof *m);
  double t0 = omp_get_wtime();
  int R = desc->resolution;
  double rect[4];
  ch_status lst = ch_featmap_check_lattice("feature map", R, desc->rect, rect, err);
  if (lst) return lst;
  unsigned char *use = calloc((size_t)(set->num_curves > 0 ? set->num_curves : 1), 1);
  if (!use) return ch_error_set(err, CH_ERR_NOMEM, "out of memory");
  int nuse = 0;
  for (int c = 0; c < set->num_curves; c++) {
    use[c] = (unsigned char)ch_featmap_encodes(set, c);
    const ch_curve *cv = &set->curves[c];
    for (int i = cv->first_segment; use[c] && i < cv->first_segment + cv->num_segments; i++)
      for (int k = 0; k < 3; k++)
        if (!ch_finite2(set->segments[i].p[k])) {
          free(use);
          char what[160];
          ch_curve_describe(cv, what, sizeof what);
          return ch_error_set(err, CH_ERR_INPUT, "%s: a control point is not finite", what);
        }
    if (use[c] && cv->kind == CH_CURVE_GROOVE && !(isfinite(cv->width) && cv->width > 0.0 && isfinite(cv->depth))) {
      free(use);
      char what[160];
      ch_curve_describe(cv, what, sizeof what);
      return ch_error_set(err, CH_ERR_INPUT, "%s: groove width or depth is not a finite positive number", what);
    }
    nuse += use[c] && cv->num_segments > 0;
  }
  if (!nuse) {
    free(use);
    return ch_error_set(err, CH_ERR_INPUT,
                        "no curve to encode (feature maps hold grooves and step curves without blur)");
  }
  lattice L = {.R = R, .R1 = R + 1, .du = (rect[2] - rect[0]) / R, .dv = (rect[3] - rect[1]) / R,
               .warp = desc->warp};
  memcpy(L.rect, rect, sizeof L.rect);
  m->warp = desc->warp;
  m->resolution = R;
  memcpy(m->rect, rect, sizeof m->rect);
  m->linear = desc->linear != 0;
  size_t n = (size_t)(R + 1) * (R + 1);
  m->num_curves = set->num_curves;
  m->curves = calloc((size_t)(set->num_curves > 0 ? set->num_curves : 1), sizeof *m->curves);
  m->dist = ch_alloc_large(n, sizeof *m->dist, 0);
  m->grad = ch_alloc_large(2 * n, sizeof *m->grad, 0);
  m->curve = ch_alloc_large(n, sizeof *m->curve, 0);
  m->base = ch_alloc_large(3 * n, sizeof *m->base, 0);
  m->edge = ch_alloc_large(4 * n, sizeof *m->edge, 0);
  m->config = ch_alloc_large(n, sizeof *m->config, 1);
  m->seg_curve = ch_alloc_large(2 * n, sizeof *m->seg_curve, 0);
  m->fb_start = ch_alloc_large(n, sizeof *m->fb_start, 0);
  m->fb_count = ch_alloc_large(n, sizeof *m->fb_count, 1);
  vec_event ev = {0};
  vec_piece pc = {0};
  piece **order = NULL;
  size_t nin = 0;
  int R1 = R + 1;
  sample_index ix = {0};
  uint8_t *cover = NULL;
  /* Cells are cut in the maps' space: under a warp, along the curves
   * warped through the cage (ch_warp_curves: exact images of the pieces). */
  ch_curve_set warped = {0};
  const ch_curve_set *pset = set;
  ch_status st = CH_OK;
  if (!m->curves || !m->dist || !m->grad || !m->curve || !m->base || !m->edge || !m->config || !m->seg_curve ||
      !m->fb_start || !m->fb_count) {
    st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for %dx%d feature maps", R, R);
    goto fail;
  }
  {
    int *flat = malloc((size_t)(set->num_curves > 0 ? set->num_curves : 1) * sizeof *flat);
    if (!flat) {
      st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for %dx%d feature maps", R, R);
      goto fail;
    }
    if ((st = ch_stepsing_flat_sides(set, flat, err))) {
      free(flat);
      goto fail;
    }
    for (int c = 0; c < set->num_curves; c++) {
      const ch_curve *cv = &set->curves[c];
      m->curves[c] = (ch_featmap_curve){cv->kind, cv->profile, cv->width, cv->depth, flat[c]};
    }
    free(flat);
  }
#pragma omp parallel for schedule(static)
  for (size_t k = 0; k < n; k++) {
    m->edge[4 * k] = m->edge[4 * k + 2] = 0.5f;
    m->edge[4 * k + 1] = m->edge[4 * k + 3] = 0.0f;
    m->seg_curve[2 * k] = m->seg_curve[2 * k + 1] = -1;
    m->fb_start[k] = -1;
    m->base[3 * k] = m->base[3 * k + 1] = 0.0f;
    m->base[3 * k + 2] = 1.0f;
  }

  /* 1. samples */
  double t1 = omp_get_wtime();
  cover = ch_alloc_large(n, 1, 0);
  if (!cover) {
    st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for %dx%d feature maps", R, R);
    goto fail;
  }
  if ((st = samples_exact(set, use, &L, m, &ix, cover, err))) goto fail;
  /* 2-3. pieces, configurations, edge points: they read no sample, so they
   * run beside the propagation, which is one sequential sweep. */
  double t_cells = 0.0;
#pragma omp parallel sections
  {
#pragma omp section
    ch_edt_propagate(ix.rec, ix.exact, R1, R1);
#pragma omp section
    {
      double tc = omp_get_wtime();
      st = build_cells(set, use, &L, desc->warp, &warped, &pset, &ev, &pc, &order, &nin, m, err);
      t_cells = omp_get_wtime() - tc;
    }
  }
  if (st) goto fail;
  samples_rest(set, use, &L, m, &ix);
  m->stats.seconds_samples = omp_get_wtime() - t1; /* overlapping seconds_cells */
  m->stats.seconds_cells = t_cells;

  /* 4. signatures: validity, fit */
  t1 = omp_get_wtime();
  {
    uint8_t *bad = ch_alloc_large((size_t)R * R, 1, 1);
    if (!bad) {
      st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for the signature check");
      goto fail;
    }
    int linear = m->linear;
#pragma omp parallel for schedule(dynamic, 16)
    for (int ci = 0; ci < R; ci++)
      for (int cj = 0; cj < R; cj++) {
        fm_signature s;
        fm_cell_signature(m, ci, cj, &s);
        if (s.nseg && !cell_valid(&s, linear)) bad[(size_t)ci * R + cj] = 1;
      }
    long invalid = 0;
    for (size_t k = 0; k < (size_t)R * R; k++) invalid += bad[k];
    m->stats.invalid = invalid;
    if (!linear && invalid) {
      /* Cells three apart have disjoint neighbourhoods: nine phases, each
       * parallel, always in the same order. */
      long fitted = 0, straightened = 0;
      for (int phase = 0; phase < 9; phase++) {
#pragma omp parallel for schedule(dynamic, 4) reduction(+ : fitted, straightened) if (invalid > 256)
        for (int ci = phase / 3; ci < R; ci += 3)
          for (int cj = phase % 3; cj < R; cj += 3) {
            if (!bad[(size_t)ci * R + cj]) continue;
            fm_signature s;
            fm_cell_signature(m, ci, cj, &s);
            if (cell_valid(&s, 0)) continue; /* a neighbour's fit mended it */
            size_t c = (size_t)ci * R1 + cj;
            if (fit_cell_angles(m, R, ci, cj)) {
              m->config[c] |= CH_FM_FITTED;
              fitted++;
              continue;
            }
            /* Straighten the cell's segments one at a time until valid. */
            fm_cell_signature(m, ci, cj, &s);
            for (int k = 0; k < s.nseg && !cell_valid(&s, 0); k++) {
              s.straight[k] = 1;
              m->config[c] |= k ? CH_FM_STRAIGHT1 : CH_FM_STRAIGHT0;
            }
            m->config[c] |= CH_FM_STRAIGHTENED;
            straightened++;
          }
      }
      m->stats.fitted = fitted;
      m->stats.straightened = straightened;
    }
    free(bad);
  }
  m->stats.seconds_fit = omp_get_wtime() - t1;

  double t_check = omp_get_wtime();
  /* What a cell's corners say it cannot hold, near the curves (within
   * the widest groove's half width, at least two cells, plus one): the
   * side or the nearest point jumping inside a domain (a medial axis),
   * and grooves overlapping so that the nearest curve does not decide h. */
  {
    double texel = fmax(L.du, L.dv), half = 0.0;
    for (int c = 0; c < set->num_curves; c++)
      if (use[c] && set->curves[c].kind == CH_CURVE_GROOVE) half = fmax(half, 0.5 * set->curves[c].width);
    double near = fmax(half, 2.0 * texel) + texel;
    int32_t *active = ch_alloc_large(n, sizeof *active, 0);
    ch_groove_field gf;
    if (!active) {
      st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for the overlap check");
      goto fail;
    }
    if ((st = ch_groove_field_init(&gf, set, err))) {
      free(active);
      goto fail;
    }
#pragma omp parallel for schedule(dynamic, 16)
    for (int y = 0; y < R1; y++)
      for (int x = 0; x < R1; x++) {
        size_t k = (size_t)y * R1 + x;
        active[k] = -1;
        /* elsewhere the field's curve is the nearest one or none */
        if (!(fabs(m->dist[k]) < half) || !cover[k]) continue;
        double q[2];
        ch_groove_sample gs;
        lattice_uv(&L, x, y, q);
        ch_groove_field_eval(&gf, q[0], q[1], &gs);
        active[k] = gs.active;
      }
    ch_groove_field_free(&gf);
#pragma omp parallel for schedule(static)
    for (int ci = 0; ci < R; ci++)
      for (int cj = 0; cj < R; cj++) {
        size_t c = (size_t)ci * R1 + cj;
        size_t cs[4] = {c, c + 1, c + R1 + 1, c + R1};
        double dmin = INFINITY;
        for (int q = 0; q < 4; q++) {
          dmin = fmin(dmin, fabs(m->dist[cs[q]]));
          if (active[cs[q]] >= 0 && active[cs[q]] != m->curve[cs[q]]) m->config[c] |= CH_FM_LOST_CSG;
        }
        if (!(dmin < near)) continue;
        /* nearest points, UV: sample - d grad (gradients are still exact) */
        double P[4][2], fo[2], fx[2], fy[2];
        cell_frame(&L, ci, cj, fo, fx, fy);
        double cell_uv = fmax(hypot(fx[0], fx[1]), hypot(fy[0], fy[1]));
        for (int q = 0; q < 4; q++) {
          double uv[2];
          lattice_uv(&L, cj + (q == 1 || q == 2), ci + (q >= 2), uv);
          double d = fabs(m->dist[cs[q]]);
          P[q][0] = uv[0] - d * m->grad[2 * cs[q]];
          P[q][1] = uv[1] - d * m->grad[2 * cs[q] + 1];
        }
        fm_signature s;
        fm_cell_signature(m, ci, cj, &s);
        int dom[4] = {0, 0, 0, 0};
        for (int k = 0; k < s.nseg; k++) {
          int a = fm_pair_edges[s.pair[k]][0], b = fm_pair_edges[s.pair[k]][1];
          for (int q = 0; q < 4; q++) {
            int side;
            if (a == FM_S && b == FM_N) side = q == 0 || q == 3;
            else if (a == FM_E && b == FM_W) side = q == 2 || q == 3;
            else side = q == (((a == FM_S && b == FM_W) ? FM_W : a) + 1) % 4;
            dom[q] |= side << k;
          }
        }
        /* A corner nearer to another curve than a segment's beside it, or
         * to another part of the same curve (its gradient points back
         * across the segment: the inside of a sharp turn): a medial axis
         * runs between them. */
        for (int k = 0; k < s.nseg; k++) {
          double qa[2], qb[2];
          fm_edge_point(fm_pair_edges[s.pair[k]][0], s.pos[fm_pair_edges[s.pair[k]][0]], qa);
          fm_edge_point(fm_pair_edges[s.pair[k]][1], s.pos[fm_pair_edges[s.pair[k]][1]], qb);
          double dq[2] = {qb[0] - qa[0], qb[1] - qa[1]};
          double ch[2] = {dq[0] * fx[0] + dq[1] * fy[0], dq[0] * fx[1] + dq[1] * fy[1]};
          for (int q = 0; q < 4; q++) {
            if (m->seg_curve[2 * c + ((m->config[c] & CH_FM_SEG_MASK) == (uint32_t)s.pair[k] ? 0 : 1)] !=
                m->curve[cs[q]])
              m->config[c] |= CH_FM_LOST_MEDIAL;
            double dt[2] = {fm_corner_xy[q][0] - qa[0], fm_corner_xy[q][1] - qa[1]};
            double to[2] = {dt[0] * fx[0] + dt[1] * fy[0], dt[0] * fx[1] + dt[1] * fy[1]};
            double side = ch_cross2(ch, to) >= 0.0 ? 1.0 : -1.0;
            double away[2] = {-ch[1] * side, ch[0] * side}, al = hypot(away[0], away[1]);
            if (al > 0.0 && (away[0] * m->grad[2 * cs[q]] + away[1] * m->grad[2 * cs[q] + 1]) / al < -0.1)
              m->config[c] |= CH_FM_LOST_MEDIAL;
          }
        }
        for (int q = 0; q < 4; q++)
          for (int r = q + 1; r < 4; r++) {
            if (dom[q] != dom[r]) continue;
            /* Two corners no segment separates are nearest to one curve,
             * on one side of it; their nearest points move less than a
             * cell (about r / (r - d) of it on the concave side of a
             * curve of radius r) and their gradients turn by less than
             * 1 / r radians (30 degrees: r under two cells, a tight bend
             * anyway). Otherwise a medial axis runs between them. */
            double turn = m->grad[2 * cs[q]] * m->grad[2 * cs[r]] + m->grad[2 * cs[q] + 1] * m->grad[2 * cs[r] + 1];
            if ((m->dist[cs[q]] >= 0.0f) != (m->dist[cs[r]] >= 0.0f) || m->curve[cs[q]] != m->curve[cs[r]] ||
                turn < 0.866 || jumps(P[q], P[r], 2.5 * cell_uv))
              m->config[c] |= CH_FM_LOST_MEDIAL;
          }
        /* The representation's own error at the centre (before fallback
         * lists exist, ch_featmap_eval uses the partition). */
        if (m->config[c] & CH_FM_LOST_ANY || !ix.exact[c]) continue;
        /* only where a profile reads the distance: within the nearest
         * corner's groove band */
        int qn = 0;
        for (int q = 1; q < 4; q++)
          if (fabs(m->dist[cs[q]]) < fabs(m->dist[cs[qn]])) qn = q;
        const ch_featmap_curve *cq = &m->curves[m->curve[cs[qn]]];
        double bandc = cq->kind == CH_CURVE_GROOVE ? 0.5 * cq->width + 0.5 * cell_uv : 0.0;
        if (!(bandc > 0.0)) continue;
        double uv[2];
        lattice_uv(&L, cj + 0.5, ci + 0.5, uv);
        float dc = (float)index_distance(set, &ix, uv);
        if (dc == dc && dc < bandc) {
          ch_featmap_sample fs;
          ch_featmap_eval(m, m->linear ? CH_FEATMAP_LINEAR : CH_FEATMAP_FEATNORM, uv[0], uv[1], &fs);
          if (fabs(fs.distance - dc) > CH_FEATMAP_TIGHT_DISTANCE * cell_uv) m->config[c] |= CH_FM_LOST_TIGHT;
        }
      }
    free(active);
  }

  /* The stored pieces against the curves: a kept piece whose curve
   * strays from its cell's segment by more than CH_FEATMAP_TIGHT cells
   * (a tight bend, an inflection, a fit or straightening that moved it). */
  for (size_t k = 0; k < nin; k++) {
    const piece *p = order[k];
    if (!p->kept || p->edge_a < 0 || p->edge_b < 0) continue;
    int ci = p->cell / R, cj = p->cell % R;
    size_t c = (size_t)ci * R1 + cj;
    if (m->config[c] & CH_FM_LOST_ANY) continue;
    fm_signature s;
    fm_curve seg[2];
    fm_cell_signature(m, ci, cj, &s);
    if (!fm_segment_curves(&s, m->linear, seg)) continue;
    int pair = fm_pair_index(p->edge_a, p->edge_b), which = -1;
    for (int q = 0; q < s.nseg; q++)
      if (s.pair[q] == pair) which = q;
    if (which < 0) continue;
    const ch_subpath *sp = &pset->subpaths[p->subpath];
    double worst = 0.0;
    for (int q = 1; q < 8; q++) {
      double pt[2];
      subpath_point(pset, &L, sp, p->ga + (p->gb - p->ga) * q / 8.0, pt);
      double local[2] = {pt[0] - cj, pt[1] - ci};
      worst = fmax(worst, fm_curve_distance(&seg[which], local, 1.0, 1.0));
    }
    if (worst > (m->linear ? CH_FEATMAP_TIGHT_LINEAR : CH_FEATMAP_TIGHT)) m->config[c] |= CH_FM_LOST_TIGHT;
  }

  m->stats.seconds_check = omp_get_wtime() - t_check;

  /* cell statistics */
  {
    long one = 0, two = 0, dropped = 0, merged = 0, end = 0, loop = 0, corner = 0, medial = 0, csg = 0, tight = 0;
#pragma omp parallel for schedule(static) reduction(+ : one, two, dropped, merged, end, loop, corner, medial, csg, tight)
    for (int ci = 0; ci < R; ci++)
      for (int cj = 0; cj < R; cj++) {
        uint32_t w = m->config[(size_t)ci * R1 + cj];
        int ns = ((w & CH_FM_SEG_MASK) != 0) + (((w >> CH_FM_SEG_BITS) & CH_FM_SEG_MASK) != 0);
        one += ns == 1;
        two += ns == 2;
        dropped += (w & CH_FM_LOST_DROPPED) != 0;
        merged += (w & CH_FM_LOST_MERGED) != 0;
        end += (w & CH_FM_LOST_END) != 0;
        loop += (w & CH_FM_LOST_LOOP) != 0;
        corner += (w & CH_FM_LOST_CORNER) != 0;
        medial += (w & CH_FM_LOST_MEDIAL) != 0;
        csg += (w & CH_FM_LOST_CSG) != 0;
        tight += (w & CH_FM_LOST_TIGHT) != 0;
      }
    m->stats.cells_one = one, m->stats.cells_two = two;
    m->stats.lost_dropped = dropped, m->stats.lost_merged = merged, m->stats.lost_end = end;
    m->stats.lost_loop = loop, m->stats.lost_corner = corner, m->stats.lost_medial = medial;
    m->stats.lost_csg = csg, m->stats.lost_tight = tight;
  }

  /* 5. smoothing */
  t1 = omp_get_wtime();
  int iterations = desc->smoothing == 0 ? 10 : desc->smoothing < 0 ? 0 : desc->smoothing;
  if (iterations && (st = smooth_gradient(m, &L, iterations, desc->smooth_everywhere, err))) goto fail;
  m->stats.seconds_smooth = omp_get_wtime() - t1;

  /* 6. fallback */
  t1 = omp_get_wtime();
  if (!desc->no_fallback) {
#pragma omp parallel for schedule(static)
    for (int ci = 0; ci < R; ci++)
      for (int cj = 0; cj < R; cj++) {
        size_t c = (size_t)ci * R1 + cj;
        if (m->config[c] & CH_FM_LOST_ANY) m->config[c] |= CH_FM_FALLBACK;
      }
    if ((st = build_fallback(set, use, &L, m, err))) goto fail;
  }
  m->stats.seconds_fallback = omp_get_wtime() - t1;

  /* 7. base and conventional normal maps */
  t1 = omp_get_wtime();
  {
    const ch_height *h = desc->height && desc->height->has_steps ? desc->height : NULL;
    ch_groove_field gf;
    if ((st = ch_groove_field_init(&gf, set, err))) goto fail;
    int has_base = 0;
    if (h && !desc->warp && !desc->no_singular) {
      ch_stepsing sing;
      if ((st = ch_stepsing_find(set, h->dci.samples.rect, &sing, err))) {
        ch_groove_field_free(&gf);
        goto fail;
      }
      m->singular = sing.points;
      m->num_singular = sing.num_points;
      /* the maps carry no curve per arm (evaluation needs none) */
      for (int p = 0; p < m->num_singular; p++)
        for (int k = 0; k < CH_STEPSING_MAX_ARMS; k++) m->singular[p].arm_curve[k] = -1, m->singular[p].arm_left_ccw[k] = 0;
      if ((st = ch_featmap_singular_index(m, err))) {
        ch_groove_field_free(&gf);
        goto fail;
      }
    }
    if (h) {
#pragma omp parallel for schedule(dynamic, 8) reduction(| : has_base)
      for (int y = 0; y < R1; y++)
        for (int x = 0; x < R1; x++) {
          size_t k = (size_t)y * R1 + x;
          double q[2], g[2];
          lattice_uv(&L, x, y, q);
          int c = m->curve[k];
          int step = c >= 0 && set->curves[c].kind == CH_CURVE_STEP;
          step_gradient(h, q[0], q[1], step ? c : -1, m->dist[k] >= 0.0f ? CH_SIDE_LEFT : CH_SIDE_RIGHT, m->dist[k],
                        g);
          if (m->sg_near && m->sg_near[k] >= 0) { /* the 1/r part is added back exactly */
            const ch_stepsing_point *pt = &m->singular[m->sg_near[k]];
            double tg[2], w = ch_featmap_singular_window(pt, hypot(q[0] - pt->p[0], q[1] - pt->p[1]));
            ch_stepsing_term(pt, q, tg);
            g[0] -= w * tg[0];
            g[1] -= w * tg[1];
          }
          double len = sqrt(g[0] * g[0] + g[1] * g[1] + 1.0);
          m->base[3 * k] = (float)(-g[0] / len);
          m->base[3 * k + 1] = (float)(-g[1] / len);
          m->base[3 * k + 2] = (float)(1.0 / len);
          has_base |= g[0] != 0.0 || g[1] != 0.0;
        }
    }
    m->has_base = has_base;
    if (!desc->no_normal_map) {
      m->normal = ch_alloc_large(3 * n, sizeof *m->normal, 0);
      if (!m->normal) {
        ch_groove_field_free(&gf);
        st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for the normal map");
        goto fail;
      }
      int S = desc->normal_supersample > 0 ? desc->normal_supersample : 2;
#pragma omp parallel for schedule(dynamic, 4)
      for (int y = 0; y < R1; y++)
        for (int x = 0; x < R1; x++) {
          double acc[3] = {0, 0, 0};
          for (int a = 0; a < S; a++)
            for (int b = 0; b < S; b++) {
              double q[2], nn[3];
              lattice_uv(&L, x - 0.5 + (b + 0.5) / S, y - 0.5 + (a + 0.5) / S, q);
              exact_normal(set, &gf, h, q[0], q[1], nn);
              for (int k = 0; k < 3; k++) acc[k] += nn[k];
            }
          double l = sqrt(acc[0] * acc[0] + acc[1] * acc[1] + acc[2] * acc[2]);
          size_t k = (size_t)y * R1 + x;
          for (int c = 0; c < 3; c++) m->normal[3 * k + c] = (float)(l > 0.0 ? acc[c] / l : c == 2);
        }
      m->has_normal = 1;
    }
    ch_groove_field_free(&gf);
  }
  m->stats.seconds_normal = omp_get_wtime() - t1;
  m->stats.seconds_total = omp_get_wtime() - t0;
  free(ev.v);
  free(pc.v);
  free(order);
  free(use);
  free(cover);
  sample_index_free(&ix);
  ch_curves_free(&warped);
  return CH_OK;
fail:
  free(ev.v);
  free(pc.v);
  free(order);
  free(use);
  free(cover);
  sample_index_free(&ix);
  ch_curves_free(&warped);
  ch_featmap_free(m);
  return st;
}
