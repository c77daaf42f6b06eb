/* Piece labels of the feature embedding (see ch_label_internal.h). */
#include "ch_label_internal.h"

#include <math.h>
#include <omp.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "ch_alloc.h"
#include "ch_bezier.h"
#include "ch_geomimage.h"
#include "ch_grid.h"
#include "ch_math.h"
#include "ch_samples.h"
#include "ch_segtree.h"
#include "ch_thin.h"
#include "ch_warp.h"

void ch_label_free(ch_label_ctx *lb) {
  free(lb->busy);
  free(lb->level_start);
  free(lb->level_t);
  free(lb->curve_density);
  free(lb->curve_angle);
  free(lb->crease_start);
  free(lb->crease_t);
  free(lb->chord_tol);
  free(lb->chord_curvature);
  free(lb->chord_kink);
  free(lb->chord_ends);
  free(lb->chord_end_start);
  free(lb->step_boxes);
  free(lb->step_outer);
  ch_grid_free(&lb->step_grid);
  ch_grid_free(&lb->groove_grid);
  ch_segtree_free(&lb->tree);
  free(lb->step_hint);
  free(lb->step_list);
  free(lb->step_list_start);
  free(lb->step_has_list);
  free(lb->corner_seg);
  free(lb->corner_start);
  free(lb->end_item);
  free(lb->end_start);
  memset(lb, 0, sizeof *lb);
}

/* Largest deviation of the chord of P over [a, b] from P (sampled). */
static double chord_error(const ch_profile *p, double a, double b) {
  double pa = ch_profile_eval(p, a), pb = ch_profile_eval(p, b), worst = 0.0;
  for (int i = 1; i < 32; i++) {
    double t = a + (b - a) * i / 32.0;
    worst = fmax(worst, fabs(pa + (pb - pa) * (t - a) / (b - a) - ch_profile_eval(p, t)));
  }
  return worst;
}

/* Break lines of a groove. A curved profile (u) gets extra lines, placed
 * so that the slope angle of the displaced cross-section, atan(dh/ds) in
 * object units, changes by at most `angle` (radians) from one line to the
 * next, and the chord between two stays within `tolerance` of P (in units
 * of depth): uniform in angle, so dense near the rims, where the slope is
 * infinite and no isotropic mesh could follow P. They cut the mesh like
 * creases: long edges along the groove, thin slices across it, and the
 * facet normals stay within about angle / 2 of the exact ones. `slope` is
 * depth / (width * object units per UV). */
static int groove_lines(const ch_curve *c, double tolerance, double angle, double slope, double min_spacing, double *t,
                        int max) {
  int n = ch_profile_creases(&c->profile, t, max);
  if (c->profile.kind != CH_PROFILE_U || n != 2 || max < 2 * MAX_U_LINES + 2) return n;
  double inner[MAX_U_LINES];
  int m = 0;
  double a = 0.5;
  int use_angle = angle > 0.0 && slope > 0.0;
  while (m < MAX_U_LINES) {
    /* Next line inwards from a: the nearer of what the chord rule (by
     * bisection) and the angle rule allow. The angle lines sit at
     * theta = (k - 1/2) angle; on P = -sqrt(1 - 4t^2), tan theta = dh/ds =
     * 2 slope x / sqrt(1 - x^2) with x = 2t. */
    double xa = 2.0 * a;
    double theta_a = a >= 0.5 ? 0.5 * CH_PI : atan(2.0 * slope * xa / sqrt(1.0 - xa * xa));
    int chord_done = chord_error(&c->profile, 0.0, a) <= tolerance;
    int angle_done = !use_angle || theta_a <= 0.5 * angle * (1.0 + 1e-9);
    if (chord_done && angle_done) break;
    double lo = 0.0, hi = a;
    if (!chord_done)
      for (int it = 0; it < 40; it++) {
        double mid = 0.5 * (lo + hi);
        if (chord_error(&c->profile, mid, a) <= tolerance)
          hi = mid;
        else
          lo = mid;
      }
    else
      hi = -1.0; /* (none by the chord rule) */
    if (!angle_done) {
      double k = ceil(theta_a / angle * (1.0 - 1e-9) + 0.5) - 1.0; /* the largest (k - 1/2) angle < theta_a */
      /* (where the slope is tiny against the angle step, an object in
       * millimetres, the lines crowd at the rim closer than x's rounding:
       * a line that rounds onto a is passed over for the next, which
       * otherwise came out as a again, for ever) */
      for (; k >= 1.0; k -= 1.0) {
        double q = tan((k - 0.5) * angle) / (2.0 * slope), x = q / sqrt(1.0 + q * q);
        if (0.5 * x < a) {
          hi = fmax(hi, 0.5 * x);
          break;
        }
      }
    }
    if (!(hi >= 0.0 && hi < a)) break; /* (no line inside a: none is left to place) */
    /* Lines closer than this to the previous one would ask for edges
     * below the refinement limit where they curve (around an end), or
     * spend more on the rim's last sliver than the density warrants. */
    if ((a - hi) * c->width >= min_spacing) inner[m++] = hi;
    a = hi;
  }
  n = 0;
  t[n++] = -0.5;
  for (int i = 0; i < m; i++) t[n++] = -inner[i];
  for (int i = m - 1; i >= 0; i--) t[n++] = inner[i];
  t[n++] = 0.5;
  return n;
}

/* groove_lines takes a few thousand evaluations of the profile per line
 * (the chord rule's bisections): grooves with the same profile, width and
 * rules (ornament's strokes, a glyph set's) share the lines of the first.
 * The last MEMO_SIZE distinct ones are remembered, by where their lines
 * are in the array being filled. */
enum { MEMO_SIZE = 16 };
typedef struct lines_memo {
  const ch_curve *curve;
  double tolerance, angle, slope, min_spacing;
  int at, n;
} lines_memo;

static int same_lines_asked(const lines_memo *m, const ch_curve *c, double tolerance, double angle, double slope,
                            double min_spacing) {
  const ch_profile *a = &m->curve->profile, *b = &c->profile;
  if (m->tolerance != tolerance || m->angle != angle || m->slope != slope || m->min_spacing != min_spacing ||
      m->curve->width != c->width || a->kind != b->kind || a->num_points != b->num_points)
    return 0;
  for (int i = 0; i < a->num_points; i++)
    if (a->t[i] != b->t[i] || a->h[i] != b->h[i]) return 0;
  return 1;
}

/* groove_lines into t[at..], or a copy of the same lines found earlier in
 * t (memo: MEMO_SIZE entries, *count of them used, round robin). */
static int groove_lines_memo(lines_memo *memo, int *count, const ch_curve *c, double tolerance, double angle,
                             double slope, double min_spacing, double *t, int at, int max) {
  for (int i = 0; i < *count && i < MEMO_SIZE; i++)
    if (same_lines_asked(&memo[i], c, tolerance, angle, slope, min_spacing)) {
      memmove(t + at, t + memo[i].at, (size_t)memo[i].n * sizeof *t);
      return memo[i].n;
    }
  int n = groove_lines(c, tolerance, angle, slope, min_spacing, t + at, max);
  memo[*count % MEMO_SIZE] = (lines_memo){c, tolerance, angle, slope, min_spacing, at, n};
  (*count)++;
  return n;
}

/* The density the warped mesh has at uv: sqrt(slope_u slope_v) of the
 * mesh's metric (ch_warp_mesh_slopes; the mesh's edge is e / that). */
double ch_label_mesh_density(const ch_warp *w, const double uv[2]) {
  double s[2];
  ch_warp_mesh_slopes(w, uv, s);
  return sqrt(s[0] * s[1]);
}

/* The warped mesh density along curve c: the mean over its length of
 * mesh_density; its length in *len. 1 without a warp. */
static double warp_density(const ch_warp *w, const ch_curve_set *set, int c, double *len) {
  const ch_curve *cv = &set->curves[c];
  double sum = 0.0, total = 0.0;
  for (int i = cv->first_segment; i < cv->first_segment + cv->num_segments; i++) {
    const ch_segment *sg = &set->segments[i];
    enum { SAMPLES = 16 };
    double prev[2];
    ch_segment_point(sg, 0.0, prev);
    for (int k = 1; k <= SAMPLES; k++) {
      double p[2], mid[2];
      ch_segment_point(sg, (double)k / SAMPLES, p);
      double l = hypot(p[0] - prev[0], p[1] - prev[1]);
      ch_segment_point(sg, (k - 0.5) / SAMPLES, mid);
      sum += l * (w ? ch_label_mesh_density(w, mid) : 1.0);
      total += l;
      prev[0] = p[0], prev[1] = p[1];
    }
  }
  *len = total;
  return total > 0.0 ? sum / total : 1.0;
}

/* Whether the joint at the start of step segment s turns by more than 30
 * degrees (a polygon's vertex: coarse_at_step_corner). */
static int sharp_step_corner(const ch_curve_set *set, int s) {
  const ch_segment *sg = &set->segments[s];
  if (sg->prev < 0 || set->curves[sg->curve].kind != CH_CURVE_STEP) return 0;
  double ta[2], tb[2], pa[3][2], pb[3][2];
  memcpy(pa, set->segments[sg->prev].p, sizeof pa);
  memcpy(pb, sg->p, sizeof pb);
  ch_bezier_tangent(pa, 1.0, ta);
  ch_bezier_tangent(pb, 0.0, tb);
  return ta[0] * tb[0] + ta[1] * tb[1] < 0.8660254037844387; /* cos 30 degrees */
}

/* The cell of coordinate x on res cells over [0, 1], clamped (far
 * outside, or not a number: the border's). */
int ch_label_corner_cell(int res, double x) {
  double f = floor(x * res);
  return !(f >= 0.0) ? 0 : f >= res ? res - 1 : (int)f;
}

/* The sharp corners of the step curves, bucketed (a counting sort keeps
 * each cell's in segment order). */
static ch_status find_step_corners(ch_label_ctx *lb, ch_error *err) {
  const ch_curve_set *set = lb->set;
  int n = 0;
  for (int s = 0; s < set->num_segments; s++) n += sharp_step_corner(set, s);
  int res = (int)fmin(256.0, fmax(1.0, floor(sqrt((double)n))));
  lb->corner_res = res;
  lb->corner_seg = malloc((size_t)(n > 0 ? n : 1) * sizeof *lb->corner_seg);
  lb->corner_start = calloc((size_t)res * res + 1, sizeof *lb->corner_start);
  if (!lb->corner_seg || !lb->corner_start) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for step corners");
  for (int s = 0; s < set->num_segments; s++)
    if (sharp_step_corner(set, s)) {
      const double *q = set->segments[s].p[0];
      lb->corner_start[ch_label_corner_cell(res, q[1]) * res + ch_label_corner_cell(res, q[0]) + 1]++;
    }
  for (int c = 0; c < res * res; c++) lb->corner_start[c + 1] += lb->corner_start[c];
  int *fill = malloc((size_t)res * res * sizeof *fill);
  if (!fill) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for step corners");
  memcpy(fill, lb->corner_start, (size_t)res * res * sizeof *fill);
  for (int s = 0; s < set->num_segments; s++)
    if (sharp_step_corner(set, s)) {
      const double *q = set->segments[s].p[0];
      lb->corner_seg[fill[ch_label_corner_cell(res, q[1]) * res + ch_label_corner_cell(res, q[0])]++] = s;
    }
  free(fill);
  return CH_OK;
}

/* Whether end (0: start, 1: end) of segment s is an open end of a groove
 * whose cap coarse_at_cap sizes (all profiles but u). */
int ch_label_capped_end(const ch_curve_set *set, int s, int end) {
  const ch_segment *sg = &set->segments[s];
  const ch_curve *cv = &set->curves[sg->curve];
  return cv->kind == CH_CURVE_GROOVE && cv->profile.kind != CH_PROFILE_U && (end == 0 ? sg->prev : sg->next) < 0;
}

/* Whether the convex hulls of two segments' control points overlap (or
 * touch): no axis among their edges' normals and directions separates
 * them. The segments lie in those hulls, so "no" proves they do not meet. */
static int hulls_meet(const ch_segment *a, const ch_segment *b) {
  const ch_segment *sg[2] = {a, b};
  for (int k = 0; k < 2; k++)
    for (int i = 0; i < 3; i++) {
      const double *p = sg[k]->p[i], *q = sg[k]->p[(i + 1) % 3];
      double d[2] = {q[0] - p[0], q[1] - p[1]}, axes[2][2] = {{-d[1], d[0]}, {d[0], d[1]}};
      for (int x = 0; x < 2; x++) {
        if (axes[x][0] == 0.0 && axes[x][1] == 0.0) continue;
        double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
        for (int m = 0; m < 2; m++)
          for (int j = 0; j < 3; j++) {
            double v = sg[m]->p[j][0] * axes[x][0] + sg[m]->p[j][1] * axes[x][1];
            lo[m] = fmin(lo[m], v);
            hi[m] = fmax(hi[m], v);
          }
        if (hi[0] < lo[1] || hi[1] < lo[0]) return 0;
      }
    }
  return 1;
}

/* Whether point q lies inside the closed loop through segment s0, by
 * the crossings of a ray along +u with the loop's chords (the loops this
 * is asked about keep their hulls off q's loop, so chords and curves
 * agree about it). */
static int inside_loop(const ch_curve_set *set, int s0, const double q[2]) {
  int inside = 0, s = s0;
  do {
    const double *a = set->segments[s].p[0], *b = set->segments[s].p[2];
    if ((a[1] > q[1]) != (b[1] > q[1]) && q[0] < a[0] + (q[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1])) inside = !inside;
    s = set->segments[s].next;
  } while (s != s0);
  return inside;
}

/* The outward side of every free closed loop of the step curves
 * (lb->step_outer): each loop followed by its segments' next links, its
 * orientation by the signed area of its control polygon (counter-clockwise
 * in UV: the inside is on the left, so the outward side is the right).
 * Outside free loops the labels are 0 whichever is nearest, so between two
 * such outsides there must be no wall a thin band could hide from the
 * crossing search. A loop is free when
 * - no other step segment (nor its own, but for its neighbours) touches
 *   it: where two loops cross, the outsides of both would meet at the
 *   crossing point, under one label, as different pieces of h;
 * - it holds no other loop and lies in none (a letter's outline and its
 *   counter: the body between them would be a band as thin as the stroke
 *   between two outsides);
 * - no open step curve comes within twice the radius (between two free
 *   loops, its band would be as thin as the gaps). A wall of a loop that
 *   is not free has its own labels on both sides, and 0 beyond them only
 *   outside it (nothing free lies inside it): no such band.
 * Needs the step grid (boxes grown by the radius). */
static ch_status find_step_outer(ch_label_ctx *lb, ch_error *err) {
  const ch_curve_set *set = lb->set;
  int n = set->num_segments, nloops = 0;
  lb->step_outer = calloc((size_t)(n > 0 ? n : 1), 1);
  int *loop_of = malloc((size_t)(n > 0 ? n : 1) * sizeof *loop_of); /* -1: not in a closed loop */
  int *loop_first = malloc((size_t)(n > 0 ? n : 1) * sizeof *loop_first);
  double *loop_area = malloc((size_t)(n > 0 ? n : 1) * sizeof *loop_area);
  unsigned char *loop_free = malloc((size_t)(n > 0 ? n : 1));
  double(*box)[4] = malloc((size_t)(n > 0 ? n : 1) * sizeof *box);
  double(*lbox)[4] = malloc((size_t)(n > 0 ? n : 1) * sizeof *lbox);
  ch_grid grid = {0}, loops = {0};
  ch_status st = CH_OK;
  if (!lb->step_outer || !loop_of || !loop_first || !loop_area || !loop_free || !box || !lbox) {
    st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for the step loops");
    goto done;
  }
  for (int i = 0; i < n; i++) {
    loop_of[i] = -1;
    if (set->curves[set->segments[i].curve].kind == CH_CURVE_STEP) {
      ch_segment_box(&set->segments[i], 0.0, box[i]);
    } else {
      box[i][0] = 1.0;
      box[i][2] = 0.0; /* empty: not in the grid */
    }
  }
  /* The closed loops, their orientation and boxes. */
  for (int s0 = 0; s0 < n; s0++) {
    if (loop_of[s0] != -1 || set->curves[set->segments[s0].curve].kind != CH_CURVE_STEP) continue;
    double area = 0.0;
    int s = s0, closed = 0;
    for (int steps = 0; s >= 0 && steps < n; steps++) {
      const ch_segment *g = &set->segments[s];
      loop_of[s] = -2; /* seen */
      area += (g->p[0][0] * g->p[1][1] - g->p[1][0] * g->p[0][1]) + (g->p[1][0] * g->p[2][1] - g->p[2][0] * g->p[1][1]);
      s = g->next;
      if (s == s0) {
        closed = 1;
        break;
      }
      if (s >= 0 && loop_of[s] != -1) break; /* (a loop not through s0: left open) */
    }
    if (!closed || area == 0.0) continue;
    int k = nloops++;
    loop_first[k] = s0;
    loop_area[k] = area;
    loop_free[k] = 1;
    memcpy(lbox[k], box[s0], sizeof lbox[k]);
    s = s0;
    do {
      loop_of[s] = k;
      for (int j = 0; j < 2; j++) {
        lbox[k][j] = fmin(lbox[k][j], box[s][j]);
        lbox[k][2 + j] = fmax(lbox[k][2 + j], box[s][2 + j]);
      }
      s = set->segments[s].next;
    } while (s != s0);
  }
  if (!nloops) {
    free(lb->step_outer);
    lb->step_outer = NULL;
    goto done;
  }
  if ((st = ch_grid_build(&grid, n, (const double(*)[4])box, err))) goto done;
  if ((st = ch_grid_build(&loops, nloops, (const double(*)[4])lbox, err))) goto done;
  for (int k = 0; k < nloops; k++) {
    /* touched by another step segment */
    int s = loop_first[k];
    do {
      const ch_segment *g = &set->segments[s];
      int r[4];
      ch_grid_cell_range(&grid, box[s], r);
      for (int y = r[1]; y <= r[3] && loop_free[k]; y++)
        for (int x = r[0]; x <= r[2] && loop_free[k]; x++) {
          int c = y * grid.nx + x;
          for (int i = grid.cell_start[c]; i < grid.cell_start[c + 1] && loop_free[k]; i++) {
            int t = grid.items[i];
            if (t == s || t == g->prev || t == g->next) continue;
            const double *b = box[t];
            if (b[0] > box[s][2] || b[2] < box[s][0] || b[1] > box[s][3] || b[3] < box[s][1]) continue;
            if (hulls_meet(g, &set->segments[t])) loop_free[k] = 0;
          }
        }
      s = g->next;
    } while (s != loop_first[k] && loop_free[k]);
    /* inside another loop (both are then not free) */
    const double *q = set->segments[loop_first[k]].p[0];
    const int *items;
    int m = ch_grid_query(&loops, q[0], q[1], &items);
    for (int i = 0; i < m; i++) {
      int o = items[i];
      const double *b = lbox[o];
      if (o == k || q[0] < b[0] || q[0] > b[2] || q[1] < b[1] || q[1] > b[3]) continue;
      if (inside_loop(set, loop_first[o], q)) loop_free[k] = loop_free[o] = 0;
    }
  }
  /* Near an open step curve: a grid of the open step segments alone
   * (most sets have none). Every loop's segments grown by the radius (4
   * mean edges: a quarter of the square at a coarse base) once scanned all
   * the step segments there, closed ones included, which grew as the square
   * of the loops' number (8000 filled stars: 30 s a run). */
  int nopen = 0;
  for (int t = 0; t < n; t++) {
    int open = loop_of[t] < 0 && lb->step_boxes[t][0] <= lb->step_boxes[t][2];
    memcpy(box[t], lb->step_boxes[t], sizeof box[t]);
    if (!open) box[t][0] = 1.0, box[t][2] = 0.0; /* empty: not in the grid */
    nopen += open;
  }
  ch_grid_free(&grid);
  if (nopen > 0 && (st = ch_grid_build(&grid, n, (const double(*)[4])box, err))) goto done;
  for (int k = 0; k < nloops && nopen > 0; k++) {
    int s = loop_first[k];
    while (loop_free[k]) {
      double grown[4];
      ch_segment_box(&set->segments[s], lb->radius, grown);
      int r[4];
      ch_grid_cell_range(&grid, grown, r);
      for (int y = r[1]; y <= r[3] && loop_free[k]; y++)
        for (int x = r[0]; x <= r[2] && loop_free[k]; x++) {
          int c = y * grid.nx + x;
          for (int i = grid.cell_start[c]; i < grid.cell_start[c + 1] && loop_free[k]; i++) {
            const double *b = box[grid.items[i]];
            if (!(b[0] > grown[2] || b[2] < grown[0] || b[1] > grown[3] || b[3] < grown[1])) loop_free[k] = 0;
          }
        }
      s = set->segments[s].next;
      if (s == loop_first[k]) break;
    }
  }
  int any = 0;
  for (int s = 0; s < n; s++)
    if (loop_of[s] >= 0 && loop_free[loop_of[s]]) {
      lb->step_outer[s] = loop_area[loop_of[s]] > 0.0 ? 1 : 2;
      any = 1;
    }
  if (!any) { /* none free: the labels and the crossing search skip the test */
    free(lb->step_outer);
    lb->step_outer = NULL;
  }
done:
  free(loop_of);
  free(loop_first);
  free(loop_area);
  free(loop_free);
  free(box);
  free(lbox);
  ch_grid_free(&grid);
  ch_grid_free(&loops);
  return st;
}

/* Whether the cap at end `end` of segment s lies wholly under other
 * grooves: at none of 65 points over its disk (the end point, and rings
 * at half and 0.98 of the half width) does its groove decide h (it is no
 * deeper there than another: docs/spec.md §3's CSG). Brick joints ending
 * inside the mortar beds are such ends; refining around their caps spent
 * a quarter of bricks' triangles at 2.1M on nothing the mesh shows. Where
 * more than CROWDED_END segments are listed at the end point the answer
 * is no, unasked: 1000 grooves ending at one point made the test 1.7 s of
 * each run's setup, for caps whose refinement they share. */
#define CROWDED_END 64
static int cap_hidden(const ch_label_ctx *lb, int s, int end) {
  const ch_segment *sg = &lb->set->segments[s];
  const double *q = sg->p[end == 0 ? 0 : 2], half = 0.5 * lb->set->curves[sg->curve].width;
  const int *items;
  if (ch_grid_query(&lb->height->grooves.grid, q[0], q[1], &items) > CROWDED_END) return 0;
  enum { DIRECTIONS = 32 };
  for (int k = 0; k < 1 + 2 * DIRECTIONS; k++) {
    double r = k == 0 ? 0.0 : k <= DIRECTIONS ? 0.5 * half : 0.98 * half, a = 2.0 * CH_PI * (double)k / DIRECTIONS;
    ch_groove_sample gs;
    ch_groove_field_eval(&lb->height->grooves, q[0] + r * cos(a), q[1] + r * sin(a), &gs);
    if (gs.active == sg->curve) return 0;
  }
  return 1;
}

/* The largest curvature of a quadratic segment: with B(t) = p0 + 2tA +
 * t^2 Q, |B' x B''| / |B'|^3 = |A x Q| / (2 |A + tQ|^3), largest where
 * |A + tQ| is least on [0, 1]. */
static double segment_curvature(const ch_segment *sg) {
  if (sg->is_line) return 0.0;
  const double(*p)[2] = sg->p;
  double A[2] = {p[1][0] - p[0][0], p[1][1] - p[0][1]};
  double Q[2] = {p[2][0] - 2.0 * p[1][0] + p[0][0], p[2][1] - 2.0 * p[1][1] + p[0][1]};
  double qq = ch_dot2(Q, Q), t = qq > 0.0 ? -ch_dot2(A, Q) / qq : 0.0;
  t = t < 0.0 ? 0.0 : t > 1.0 ? 1.0 : t;
  double m[2] = {A[0] + t * Q[0], A[1] + t * Q[1]}, l = ch_dist2d(m[0], m[1]);
  return l > 0.0 ? fabs(ch_cross2(A, Q)) / (2.0 * l * l * l) : INFINITY;
}

/* The least distance between segments a and b, from 33 points along a
 * (their spacing taken off, so never more than the true one), or, where
 * it is surely more than `enough`, the distance of their control
 * points' boxes (which hold them). */
static double segment_gap(const ch_segment *a, const ch_segment *b, double enough) {
  double ba[4], bb[4], ga = 0.0;
  ch_segment_box(a, 0.0, ba);
  ch_segment_box(b, 0.0, bb);
  for (int i = 0; i < 2; i++) ga = fmax(ga, fmax(bb[i] - ba[2 + i], ba[i] - bb[2 + i]));
  if (ga > enough) return ga;
  enum { POINTS = 32 };
  double best = INFINITY, len = 0.0, prev[2];
  for (int i = 0; i <= POINTS; i++) {
    double q[2], t;
    ch_segment_point(a, (double)i / POINTS, q);
    if (i > 0) len = fmax(len, ch_dist2d(q[0] - prev[0], q[1] - prev[1]));
    prev[0] = q[0], prev[1] = q[1];
    best = fmin(best, sqrt(ch_bezier_closest(b->p, b->is_line, q, &t)));
  }
  return best - len;
}

/* Whether segments a and b of curve cv lie more than `apart` from each
 * other along its path (arc[s]: the length of the subpath up to segment
 * s, from cv's first; closed subpaths the shorter way round); segments of
 * different subpaths are. */
static int path_apart(const ch_curve_set *set, const ch_curve *cv, const double *arc, int a, int b, double apart) {
  if (a == b) return 0;
  for (int p = cv->first_subpath; p < cv->first_subpath + cv->num_subpaths; p++) {
    const ch_subpath *sp = &set->subpaths[p];
    int f = sp->first_segment, l = f + sp->num_segments;
    if (!(a >= f && a < l)) continue;
    if (!(b >= f && b < l)) return 1;
    int lo = a < b ? a : b, hi = a < b ? b : a, i0 = f - cv->first_segment;
    double total = arc[l - cv->first_segment] - arc[i0];
    /* (from the end of the earlier to the start of the later) */
    double along = arc[hi - cv->first_segment] - arc[lo + 1 - cv->first_segment];
    if (sp->closed) along = fmin(along, total - (arc[hi + 1 - cv->first_segment] - arc[lo - cv->first_segment]));
    return along > apart;
  }
  return 1;
}

/* The chord bounds of the u grooves (ch_label_chord_within). A path of
 * more than CHORD_SEGMENTS segments, or more than CHORD_ENDS open ends,
 * gets none (its segments are compared pairwise). */
enum { CHORD_SEGMENTS = 256, CHORD_ENDS = 16 };
static ch_status find_chord_bounds(ch_label_ctx *lb, ch_error *err) {
  const ch_curve_set *set = lb->set;
  int nc = set->num_curves;
  lb->chord_curvature = malloc((size_t)(nc > 0 ? nc : 1) * sizeof *lb->chord_curvature);
  lb->chord_kink = calloc((size_t)(nc > 0 ? nc : 1), sizeof *lb->chord_kink);
  lb->chord_end_start = calloc((size_t)nc + 1, sizeof *lb->chord_end_start);
  lb->chord_ends = malloc((size_t)(2 * nc * CHORD_ENDS + 1) * sizeof *lb->chord_ends);
  if (!lb->chord_curvature || !lb->chord_kink || !lb->chord_end_start || !lb->chord_ends)
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the grooves' chords");
  int ne = 0;
#pragma omp parallel for schedule(dynamic, 1)
  for (int c = 0; c < nc; c++) {
    const ch_curve *cv = &set->curves[c];
    double k = INFINITY, kink = 0.0;
    if (cv->kind == CH_CURVE_GROOVE && cv->profile.kind == CH_PROFILE_U && cv->num_segments <= CHORD_SEGMENTS) {
      int s0 = cv->first_segment, s1 = s0 + cv->num_segments, ends = 0;
      double arc[CHORD_SEGMENTS + 1]; /* the path's length up to each segment (path_apart) */
      arc[0] = 0.0;
      for (int s = s0; s < s1; s++) arc[s - s0 + 1] = arc[s - s0] + ch_bezier_length(set->segments[s].p);
      k = 0.0;
      for (int s = s0; s < s1; s++) {
        const ch_segment *sg = &set->segments[s];
        k = fmax(k, segment_curvature(sg));
        ends += (sg->prev < 0) + (sg->next < 0);
        if (sg->next >= 0) {
          double a[2], b[2];
          ch_bezier_tangent(sg->p, 1.0, a);
          ch_bezier_tangent(set->segments[sg->next].p, 0.0, b);
          kink = fmax(kink, ch_angle(fabs(ch_cross2(a, b)), ch_dot2(a, b)));
        }
        /* a medial axis inside the groove: the path back within its
         * width of itself after going more than twice that along it (the
         * segments nearer along it are the curvature's) */
        for (int o = s0; o < s1 && k < INFINITY; o++)
          if (path_apart(set, cv, arc, s, o, 2.0 * cv->width) &&
              segment_gap(sg, &set->segments[o], cv->width) < cv->width)
            k = INFINITY;
      }
      if (ends > CHORD_ENDS || kink > 0.1) k = INFINITY;
    }
    lb->chord_curvature[c] = k;
    lb->chord_kink[c] = kink;
  }
  for (int c = 0; c < nc; c++) {
    const ch_curve *cv = &set->curves[c];
    lb->chord_end_start[c] = ne;
    if (lb->chord_curvature[c] < INFINITY)
      for (int s = cv->first_segment; s < cv->first_segment + cv->num_segments; s++) {
        const ch_segment *sg = &set->segments[s];
        for (int end = 0; end < 2; end++)
          if (end ? sg->next < 0 : sg->prev < 0) {
            lb->chord_ends[2 * ne] = sg->p[end ? 2 : 0][0];
            lb->chord_ends[2 * ne + 1] = sg->p[end ? 2 : 0][1];
            ne++;
          }
      }
  }
  lb->chord_end_start[nc] = ne;
  return CH_OK;
}

int ch_label_chord_within(const ch_label_ctx *lb, int c, double line, const double p[2], const double q[2],
                          const double mid[2], double err_max) {
  double k = lb->chord_curvature[c];
  const ch_curve *cv = &lb->set->curves[c];
  double w = cv->width, d = fabs(line) * w, len = ch_dist2d(q[0] - p[0], q[1] - p[1]);
  if (!(k * d <= 0.5)) return 0; /* (INFINITY: no bound) */
  for (int e = lb->chord_end_start[c]; e < lb->chord_end_start[c + 1]; e++) {
    const double *x = &lb->chord_ends[2 * e];
    if (ch_dist2d(mid[0] - x[0], mid[1] - x[1]) <= 0.5 * w + len) return 0; /* its cap's rings */
  }
  /* The line is the path's offset at d: curvature at most k / (1 - k d)
   * on its inner side; across a joint turning by a, a corner on the
   * inner side (off the chord by len a / 4 at most, taken twice) and an
   * arc of radius d on the outer (d a^2 / 8). Its sagitta over the chord
   * is t's distance from the line at mid times w (t = s / w, |grad s| =
   * 1), exact on a circle's offsets; a tenth more for the curvature's
   * change along the chord. */
  double a = lb->chord_kink[c], kl = k / (1.0 - k * d);
  double sagitta = len * len * kl / 8.0 + 0.5 * len * a + d * a * a / 8.0;
  return 1.1 * sagitta / w * fabs(cv->depth) <= 0.5 * err_max;
}

/* The open ends coarse_at_cap looks at (those not hidden), bucketed like
 * the step corners. */
static ch_status find_open_ends(ch_label_ctx *lb, ch_error *err) {
  const ch_curve_set *set = lb->set;
  unsigned char *hidden = calloc(2 * (size_t)(set->num_segments > 0 ? set->num_segments : 1), 1);
  if (!hidden) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the grooves' ends");
  for (int s = 0; s < set->num_segments; s++)
    for (int end = 0; end < 2; end++)
      hidden[2 * (size_t)s + end] = (unsigned char)(ch_label_capped_end(set, s, end) && cap_hidden(lb, s, end));
  int n = 0;
  for (int s = 0; s < set->num_segments; s++)
    for (int end = 0; end < 2; end++)
      if (ch_label_capped_end(set, s, end) && !hidden[2 * (size_t)s + end]) {
        n++;
        lb->end_reach = fmax(lb->end_reach, 0.5 * set->curves[set->segments[s].curve].width);
      }
  int res = (int)fmin(256.0, fmax(1.0, floor(sqrt((double)n))));
  lb->end_res = res;
  lb->end_item = malloc((size_t)(n > 0 ? n : 1) * sizeof *lb->end_item);
  lb->end_start = calloc((size_t)res * res + 1, sizeof *lb->end_start);
  int *fill = malloc((size_t)res * res * sizeof *fill);
  if (!lb->end_item || !lb->end_start || !fill) {
    free(fill);
    free(hidden);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the grooves' ends");
  }
  for (int pass = 0; pass < 2; pass++) {
    if (pass == 1) {
      for (int c = 0; c < res * res; c++) lb->end_start[c + 1] += lb->end_start[c];
      memcpy(fill, lb->end_start, (size_t)res * res * sizeof *fill);
    }
    for (int s = 0; s < set->num_segments; s++)
      for (int end = 0; end < 2; end++) {
        if (!ch_label_capped_end(set, s, end) || hidden[2 * (size_t)s + end]) continue;
        const double *q = set->segments[s].p[end == 0 ? 0 : 2];
        int cell = ch_label_corner_cell(res, q[1]) * res + ch_label_corner_cell(res, q[0]);
        if (pass == 0)
          lb->end_start[cell + 1]++;
        else
          lb->end_item[fill[cell]++] = 2 * s + end;
      }
  }
  free(fill);
  free(hidden);
  return CH_OK;
}

/* A tree walk from the root over many small curves, with only the radius
 * as its first bound, opens every node whose box reaches within the
 * radius: over 10,000 small loops at a coarse mesh's radius (up to a
 * fifth of the square) most of the labeller's time. The step hints give each walk a first
 * bound near the answer: per cell of a grid over the step segments (about
 * one segment per cell), the segment nearest the cell's centre. */
enum { STEP_HINT_MAX_RES = 1024 };
/* A cell's candidate list is kept up to STEP_LIST_MAX segments, gathered
 * from at most STEP_LIST_RINGS cells around it (else the walk serves). */
enum { STEP_LIST_MAX = 96, STEP_LIST_RINGS = 4, STEP_LIST_GATHER = 1024 };

/* The squared distance from q to box b (0 inside). */
static double box_d2(const double b[4], const double q[2]) {
  double dx = q[0] < b[0] ? b[0] - q[0] : q[0] > b[2] ? q[0] - b[2] : 0.0;
  double dy = q[1] < b[1] ? b[1] - q[1] : q[1] > b[3] ? q[1] - b[3] : 0.0;
  return dx * dx + dy * dy;
}

static int compare_ints(const void *pa, const void *pb) {
  int a = *(const int *)pa, b = *(const int *)pb;
  return (a > b) - (a < b);
}

/* The cell range [r0, r1] x [r2, r3] of the hint grid that box b overlaps. */
static void hint_cells(const ch_label_ctx *lb, const double b[4], int r[4]) {
  double f[4] = {floor((b[0] - lb->step_origin[0]) / lb->step_cell[0]),
                 floor((b[2] - lb->step_origin[0]) / lb->step_cell[0]),
                 floor((b[1] - lb->step_origin[1]) / lb->step_cell[1]),
                 floor((b[3] - lb->step_origin[1]) / lb->step_cell[1])};
  for (int i = 0; i < 4; i++) r[i] = !(f[i] >= 0.0) ? 0 : f[i] >= lb->step_res ? lb->step_res - 1 : (int)f[i];
}

/* Cell c's candidates (ascending, each once) into out (room for
 * STEP_LIST_GATHER): every step segment whose box lies within the hint's
 * distance from the centre plus a whole diagonal. For a point q of the
 * cell the nearest step segment is at most its hint's distance from q,
 * which is at most the hint's from the centre plus half the diagonal; so
 * its box is within that of q, and so within this of the centre. -1 when
 * the list would pass STEP_LIST_MAX or its rings STEP_LIST_RINGS. */
static int gather_step_list(const ch_label_ctx *lb, const int *bucket_start, const int *bucket, int c, int *out) {
  const ch_segment *h = lb->step_hint[c] >= 0 ? &lb->set->segments[lb->step_hint[c]] : NULL;
  if (!h) return -1;
  int res = lb->step_res, cx = c % res, cy = c / res;
  double centre[2] = {lb->step_origin[0] + (cx + 0.5) * lb->step_cell[0],
                      lb->step_origin[1] + (cy + 0.5) * lb->step_cell[1]};
  double t, dc = sqrt(ch_bezier_closest(h->p, h->is_line, centre, &t));
  double reach = (dc + hypot(lb->step_cell[0], lb->step_cell[1])) * (1.0 + 1e-7) + lb->step_slack;
  double b[4] = {centre[0] - reach, centre[1] - reach, centre[0] + reach, centre[1] + reach};
  int r[4];
  hint_cells(lb, b, r);
  if (r[1] - cx > STEP_LIST_RINGS || cx - r[0] > STEP_LIST_RINGS || r[3] - cy > STEP_LIST_RINGS ||
      cy - r[2] > STEP_LIST_RINGS)
    return -1;
  int n = 0;
  for (int y = r[2]; y <= r[3]; y++)
    for (int x = r[0]; x <= r[1]; x++)
      for (int k = bucket_start[y * res + x]; k < bucket_start[y * res + x + 1]; k++) {
        double sb[4];
        ch_segment_box(&lb->set->segments[bucket[k]], 0.0, sb);
        if (box_d2(sb, centre) > reach * reach) continue;
        if (n == STEP_LIST_GATHER) return -1;
        out[n++] = bucket[k];
      }
  qsort(out, (size_t)n, sizeof *out, compare_ints);
  int m = 0;
  for (int i = 0; i < n; i++)
    if (m == 0 || out[i] != out[m - 1]) out[m++] = out[i];
  return m <= STEP_LIST_MAX ? m : -1;
}

/* The candidate lists of the hint cells (lb->step_list_start, step_list;
 * a cell without one has start == end and the flag in step_has_list 0). */
static ch_status build_step_lists(ch_label_ctx *lb, ch_error *err) {
  const ch_curve_set *set = lb->set;
  int res = lb->step_res;
  size_t ncells = (size_t)res * res;
  /* the step segments bucketed by the cells their boxes overlap */
  int *bucket_start = calloc(ncells + 1, sizeof *bucket_start);
  int *count = calloc(ncells + 1, sizeof *count);
  lb->step_list_start = calloc(ncells + 1, sizeof *lb->step_list_start);
  if (!bucket_start || !count || !lb->step_list_start) {
    free(bucket_start);
    free(count);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the step lists");
  }
  size_t total = 0;
  for (int s = 0; s < set->num_segments; s++) { /* the entries, before a loop over them */
    if (set->curves[set->segments[s].curve].kind != CH_CURVE_STEP) continue;
    double b[4];
    int r[4];
    ch_segment_box(&set->segments[s], 0.0, b);
    hint_cells(lb, b, r);
    total += (size_t)(r[1] - r[0] + 1) * (size_t)(r[3] - r[2] + 1);
  }
  if (total > (size_t)1 << 26) { /* a few huge boxes over a fine grid: the walk serves */
    free(bucket_start);
    free(count);
    return CH_OK;
  }
  for (int pass = 0; pass < 2; pass++) {
    for (int s = 0; s < set->num_segments; s++) {
      if (set->curves[set->segments[s].curve].kind != CH_CURVE_STEP) continue;
      double b[4];
      int r[4];
      ch_segment_box(&set->segments[s], 0.0, b);
      hint_cells(lb, b, r);
      for (int y = r[2]; y <= r[3]; y++)
        for (int x = r[0]; x <= r[1]; x++) {
          if (pass == 0) {
            bucket_start[y * res + x + 1]++;
          } else {
            lb->step_list[count[y * res + x]++] = s;
          }
        }
    }
    if (pass == 0) {
      for (size_t c = 0; c < ncells; c++) bucket_start[c + 1] += bucket_start[c];
      memcpy(count, bucket_start, ncells * sizeof *count);
      lb->step_list = malloc((total > 0 ? total : 1) * sizeof *lb->step_list); /* the buckets, for now */
      if (!lb->step_list) {
        free(bucket_start);
        free(count);
        return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the step lists");
      }
    }
  }
  int *bucket = lb->step_list;
  lb->step_list = NULL;
  /* each cell's list: counted, then filled (each cell its own range, so
   * the lists are the same on any number of threads) */
  int failed = 0;
  for (int pass = 0; pass < 2 && !failed; pass++) {
#pragma omp parallel
    {
      int *buf = malloc(STEP_LIST_GATHER * sizeof *buf);
      if (!buf) {
#pragma omp atomic write
        failed = 1;
      }
#pragma omp for schedule(dynamic, 64)
      for (long c = 0; c < (long)ncells; c++) {
        if (!buf) continue;
        int m = gather_step_list(lb, bucket_start, bucket, (int)c, buf);
        if (pass == 0)
          count[c] = m;
        else if (m > 0)
          memcpy(lb->step_list + lb->step_list_start[c], buf, (size_t)m * sizeof *buf);
      }
      free(buf);
    }
    if (pass == 0 && !failed) {
      size_t sum = 0;
      for (size_t c = 0; c < ncells; c++) {
        lb->step_list_start[c] = (int)sum;
        sum += count[c] > 0 ? (size_t)count[c] : 0;
      }
      lb->step_list_start[ncells] = (int)sum;
      if (sum > (size_t)1 << 24) { /* over 64 MB: the walk serves */
        free(lb->step_list_start);
        lb->step_list_start = NULL;
        break;
      }
      lb->step_has_list = malloc(ncells);
      lb->step_list = malloc((sum > 0 ? sum : 1) * sizeof *lb->step_list);
      if (!lb->step_has_list || !lb->step_list) failed = 1;
      for (size_t c = 0; !failed && c < ncells; c++) lb->step_has_list[c] = count[c] >= 0;
    }
  }
  free(bucket_start);
  free(bucket);
  free(count);
  if (failed) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the step lists");
  return CH_OK;
}

static ch_status build_step_hints(ch_label_ctx *lb, ch_error *err) {
  const ch_curve_set *set = lb->set;
  double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
  int n = lb->tree.num_step_leaves;
  for (int s = 0; s < set->num_segments; s++) {
    if (set->curves[set->segments[s].curve].kind != CH_CURVE_STEP) continue;
    double b[4];
    ch_segment_box(&set->segments[s], 0.0, b);
    lo[0] = fmin(lo[0], b[0]), lo[1] = fmin(lo[1], b[1]);
    hi[0] = fmax(hi[0], b[2]), hi[1] = fmax(hi[1], b[3]);
  }
  if (!(n > 0 && lo[0] <= hi[0] && lo[1] <= hi[1] && isfinite(lo[0] + lo[1] + hi[0] + hi[1]))) return CH_OK;
  int res = (int)fmin(STEP_HINT_MAX_RES, fmax(1.0, ceil(sqrt((double)n))));
  lb->step_res = res;
  lb->step_origin[0] = lo[0], lb->step_origin[1] = lo[1];
  lb->step_cell[0] = fmax(hi[0] - lo[0], 1e-300) / res;
  lb->step_cell[1] = fmax(hi[1] - lo[1], 1e-300) / res;
  /* rounding's worth of the coordinates, for the lists' reach */
  lb->step_slack = 1e-12 * (1.0 + fmax(fmax(fabs(lo[0]), fabs(lo[1])), fmax(fabs(hi[0]), fabs(hi[1]))));
  lb->step_hint = malloc((size_t)res * res * sizeof *lb->step_hint);
  if (!lb->step_hint) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the step hints");
#pragma omp parallel for schedule(dynamic, 16)
  for (int c = 0; c < res * res; c++) {
    double q[2] = {lo[0] + (c % res + 0.5) * lb->step_cell[0], lo[1] + (c / res + 0.5) * lb->step_cell[1]}, d2, t;
    lb->step_hint[c] = ch_segtree_closest(&lb->tree, set, 0, n, q, INFINITY, &d2, &t);
  }
  return build_step_lists(lb, err);
}

/* The nearest step segment to q within the radius (squared distance and
 * parameter in *d2 and *t), the lowest index of equals, or -1: the answer
 * of the tree over the step leaves. From q's cell's list where it has
 * one; else the tree, bounded by the distance of q's hint (the walk then
 * keeps the segments at most that far, the hint among them, and the
 * lowest index of the nearest wins as before). */
static int nearest_step(const ch_label_ctx *lb, const double q[2], double *d2, double *t) {
  double bound = lb->radius * lb->radius;
  if (lb->step_hint) {
    double fx = floor((q[0] - lb->step_origin[0]) / lb->step_cell[0]);
    double fy = floor((q[1] - lb->step_origin[1]) / lb->step_cell[1]);
    int x = !(fx >= 0.0) ? 0 : fx >= lb->step_res ? lb->step_res - 1 : (int)fx;
    int y = !(fy >= 0.0) ? 0 : fy >= lb->step_res ? lb->step_res - 1 : (int)fy;
    size_t c = (size_t)y * lb->step_res + x;
    if (lb->step_has_list && lb->step_has_list[c] && fx == x && fy == y) {
      /* q is in its cell: the list holds every segment that can be nearest */
      const double slack = 1.0 + 1e-9; /* as the tree's: keeps every candidate that could tie */
      double best_t = 0.0;
      int best_seg = -1;
      for (int i = lb->step_list_start[c]; i < lb->step_list_start[c + 1]; i++) {
        int s = lb->step_list[i];
        const ch_segment *sg = &lb->set->segments[s];
        double sb[4];
        ch_segment_box(sg, 0.0, sb);
        if (box_d2(sb, q) > bound * slack) continue;
        double ts, d = ch_bezier_closest(sg->p, sg->is_line, q, &ts);
        if (d < bound) { /* ascending: the first of equals stays */
          bound = d;
          best_t = ts;
          best_seg = s;
        }
      }
      if (best_seg >= 0) {
        *d2 = bound;
        *t = best_t;
      }
      return best_seg;
    }
    int h = lb->step_hint[c];
    if (h >= 0) {
      const ch_segment *sg = &lb->set->segments[h];
      double th, dh = ch_bezier_closest(sg->p, sg->is_line, q, &th);
      if (dh < bound) bound = nextafter(dh, INFINITY); /* keeps dh itself: the walk finds h again */
    }
  }
  return ch_segtree_closest(&lb->tree, lb->set, 0, lb->tree.num_step_leaves, q, bound, d2, t);
}

ch_status ch_label_init(ch_label_ctx *lb, const ch_height *height, const ch_warp *warp, double radius,
                        double curve_tolerance, double angle, double object_scale, double mean_edge, double reach,
                        ch_error *err) {
  const ch_curve_set *set = height->set;
  memset(lb, 0, sizeof *lb);
  lb->height = height;
  lb->set = set;
  lb->radius = radius;
  if (set->num_curves >= MAX_CURVES_LABELLED)
    return ch_error_set(err, CH_ERR_INPUT, "%d curves: feature embedding handles at most %d", set->num_curves,
                        MAX_CURVES_LABELLED - 1);
  int nc = set->num_curves;
  lb->crease_start = malloc((size_t)(nc + 1) * sizeof *lb->crease_start);
  lb->crease_t = malloc(((size_t)nc * MAX_LINES + 1) * sizeof *lb->crease_t);
  lb->chord_tol = calloc((size_t)(nc > 0 ? nc : 1), sizeof *lb->chord_tol);
  lb->curve_angle = calloc((size_t)(nc > 0 ? nc : 1), sizeof *lb->curve_angle);
  lb->object_scale = object_scale;
  lb->step_boxes = malloc((size_t)(set->num_segments > 0 ? set->num_segments : 1) * sizeof *lb->step_boxes);
  if (!lb->crease_start || !lb->crease_t || !lb->chord_tol || !lb->curve_angle || !lb->step_boxes) {
    ch_label_free(lb);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the feature labels");
  }
  int n = 0;
  /* With a warp, a groove's lines and chords are as fine as the mesh
   * along it, relative to the grooves' mean (so the triangles the lines
   * take stay about the same in all: finer where the camera looks, coarser
   * where it does not). Lines run a whole groove, so the density is its
   * mean along the groove. */
  const double global_edge = mean_edge, global_angle = angle;
  double *density = calloc((size_t)(nc > 0 ? nc : 1), sizeof *density), mean_density = 1.0;
  if (!density) {
    ch_label_free(lb);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the feature labels");
  }
  if (warp) {
    double sum = 0.0, total = 0.0;
    for (int c = 0; c < nc; c++) {
      if (set->curves[c].kind != CH_CURVE_GROOVE) continue;
      double len;
      density[c] = warp_density(warp, set, c, &len);
      sum += density[c] * len;
      total += len;
    }
    if (sum > 0.0) mean_density = sum / total;
  }
  lb->warp = warp;
  lb->mean_density = mean_density;
  if (warp) {
    lb->level_start = calloc((size_t)nc * LEVELS + 1, sizeof *lb->level_start);
    lb->level_t = malloc(((size_t)nc * (LEVELS - 1) * MAX_LINES + 1) * sizeof *lb->level_t);
    lb->curve_density = malloc((size_t)(nc > 0 ? nc : 1) * sizeof *lb->curve_density);
    if (!lb->level_start || !lb->level_t || !lb->curve_density) {
      free(density);
      ch_label_free(lb);
      return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the feature labels");
    }
  }
  int nl = 0; /* lines of the finer sets */
  lines_memo crease_memo[MEMO_SIZE], level_memo[MEMO_SIZE];
  int crease_memos = 0, level_memos = 0;
  for (int c = 0; c < nc; c++) {
    lb->crease_start[c] = n;
    if (set->curves[c].kind == CH_CURVE_GROOVE) {
      double f = warp && density[c] > 0.0 ? fmin(4.0, fmax(0.125, mean_density / density[c])) : 1.0;
      mean_edge = global_edge * f;
      angle = warp ? fmin(CH_PI / 12.0, fmax(CH_PI / 180.0, global_angle * f)) : global_angle; /* 1 to 15 deg */
      lb->curve_angle[c] = angle;
      /* By default as fine as the mesh itself would follow P across the
       * groove's middle (chord error (e/w)^2 P''/8, P'' = 4 there), so the
       * error keeps shrinking with density; never coarser than 1%. */
      double tol = curve_tolerance;
      if (!(tol > 0.0)) {
        double r = mean_edge / set->curves[c].width;
        tol = fmin(0.01, fmax(1e-4, 0.5 * r * r));
      }
      const ch_curve *cv = &set->curves[c];
      {
        /* Along the lines: chords within 1% of the depth where edges are
         * under a quarter of the groove's width (130k triangles over the
         * bundled sets), fast coarser beyond (like (e/w)^4): at low
         * densities refining every curved line to 1% would take more
         * triangles than a small target holds. */
        double r = global_edge / cv->width / 0.25;
        /* (with a warp, scaled where it is checked, chord_factor:
         * sagittas go like e^2, but a tolerance that falls as fast where
         * the mesh is finer has the chords of a close view take most of
         * the triangles, and the count from the base stops being
         * monotone; where it is coarser it grows as fast) */
        lb->chord_tol[c] = 0.01 * fmax(1.0, r * r * r * r) * fabs(cv->depth);
      }
      double slope = fabs(cv->depth) / (cv->width * object_scale);
      /* Near the rim the lines crowd where P is vertical: down to 1/50 of
       * the mean edge (about 8e-5 UV at 130k triangles, 2e-5 at 2.1M). */
      double spacing = fmax(2.0 * MIN_SPLIT_LENGTH, mean_edge / 50.0);
      n += groove_lines_memo(crease_memo, &crease_memos, cv, tol, angle, slope, spacing, lb->crease_t, n, MAX_LINES);
      /* the finer sets of a u groove (level L: the angle step and the
       * rim's spacing / 2^L, as the mesh there is 2^L times finer) */
      for (int L = 1; lb->level_t && cv->profile.kind == CH_PROFILE_U && L < LEVELS; L++) {
        lb->level_start[c * LEVELS + L] = nl;
        double a = fmax(CH_PI / 180.0, angle / (double)(1 << L));
        double sp = fmax(2.0 * MIN_SPLIT_LENGTH, spacing / (double)(1 << L));
        nl += groove_lines_memo(level_memo, &level_memos, cv, tol, a, slope, sp, lb->level_t, nl, MAX_LINES);
      }
    }
    if (lb->level_t) {
      if (!(set->curves[c].kind == CH_CURVE_GROOVE && set->curves[c].profile.kind == CH_PROFILE_U))
        for (int L = 1; L < LEVELS; L++) lb->level_start[c * LEVELS + L] = nl;
      lb->level_start[c * LEVELS + LEVELS] = nl; /* the end of its last set */
    }
  }
  if (lb->curve_density) memcpy(lb->curve_density, density, (size_t)nc * sizeof *density);
  free(density);
  lb->crease_start[nc] = n;
  for (int i = 0; i < set->num_segments; i++) {
    const ch_segment *s = &set->segments[i];
    if (set->curves[s->curve].kind == CH_CURVE_STEP) {
      ch_segment_box(s, radius, lb->step_boxes[i]);
      lb->has_steps = 1;
    } else {
      lb->step_boxes[i][0] = 1.0;
      lb->step_boxes[i][2] = 0.0; /* empty: not in the grid */
    }
  }
  /* Box grids for one curve's distance (ch_curve_closest_in_cell), whose answer
   * beyond reach is the cell's (so the level functions the crossing search
   * follows, and the bytes out, stay as they were); the groove field's
   * own grid lists long segments only along their way. */
  ch_status st = ch_grid_build(&lb->step_grid, set->num_segments, (const double(*)[4])lb->step_boxes, err);
  if (!st) st = ch_grid_build(&lb->groove_grid, set->num_segments, (const double(*)[4])ch_groove_field_boxes(&height->grooves), err);
  if (!st) st = ch_segtree_build(&lb->tree, set, err);
  if (!st && lb->has_steps) st = build_step_hints(lb, err);
  if (!st && lb->has_steps) st = find_step_outer(lb, err);
  if (!st) st = find_step_corners(lb, err);
  if (!st) st = find_open_ends(lb, err);
  if (!st) st = find_chord_bounds(lb, err);
  if (st) {
    ch_label_free(lb);
    return st;
  }
  /* The quiet-cell mask, cells about one longest edge wide. */
  int res = (int)fmin(2048.0, fmax(16.0, ceil(1.0 / fmax(reach, 1e-9))));
  lb->mask_res = res;
  lb->busy = calloc((size_t)res * res, 1);
  if (!lb->busy) {
    ch_label_free(lb);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the feature mask");
  }
  double cell = 1.0 / res;
#pragma omp parallel for schedule(dynamic, 1)
  for (int i = 0; i < set->num_segments; i++) {
    const ch_segment *sg = &set->segments[i];
    const ch_curve *c = &set->curves[sg->curve];
    double margin = (c->kind == CH_CURVE_STEP ? radius : 0.5 * c->width) + 0.7072 * cell + reach;
    double box[4];
    ch_segment_box(sg, margin, box);
    int x0 = (int)floor(box[0] * res), x1 = (int)floor(box[2] * res);
    int y0 = (int)floor(box[1] * res), y1 = (int)floor(box[3] * res);
    x0 = x0 < 0 ? 0 : x0;
    y0 = y0 < 0 ? 0 : y0;
    x1 = x1 >= res ? res - 1 : x1;
    y1 = y1 >= res ? res - 1 : y1;
    for (int y = y0; y <= y1; y++)
      for (int x = x0; x <= x1; x++) {
        double q[2] = {(x + 0.5) * cell, (y + 0.5) * cell}, t;
        if (ch_bezier_closest(sg->p, sg->is_line, q, &t) <= margin * margin) {
#pragma omp atomic write
          lb->busy[(size_t)y * res + x] = 1;
        }
      }
  }
  return CH_OK;
}

int ch_label_quiet(const ch_label_ctx *lb, const double uv[2]) {
  double fx = uv[0] * lb->mask_res, fy = uv[1] * lb->mask_res;
  if (!(fx >= 0.0 && fy >= 0.0 && fx < lb->mask_res && fy < lb->mask_res)) return 0;
  return !lb->busy[(size_t)fy * lb->mask_res + (size_t)fx];
}

int ch_label_box_quiet(const ch_label_ctx *lb, const double lo[2], const double hi[2]) {
  double r = lb->mask_res;
  if (!(lo[0] >= 0.0 && lo[1] >= 0.0 && hi[0] < 1.0 && hi[1] < 1.0)) return 0;
  int x0 = (int)(lo[0] * r), x1 = (int)(hi[0] * r), y0 = (int)(lo[1] * r), y1 = (int)(hi[1] * r);
  x1 = x1 < lb->mask_res ? x1 : lb->mask_res - 1;
  y1 = y1 < lb->mask_res ? y1 : lb->mask_res - 1;
  for (int y = y0; y <= y1; y++)
    for (int x = x0; x <= x1; x++)
      if (lb->busy[(size_t)y * lb->mask_res + x]) return 0;
  return 1;
}

/* The break lines of groove c at level L (the finer sets of u grooves). */
const double *ch_label_lines_of(const ch_label_ctx *lb, int c, int L, int *nb) {
  if (L == 0 || !lb->level_t) {
    *nb = lb->crease_start[c + 1] - lb->crease_start[c];
    return lb->crease_t + lb->crease_start[c];
  }
  int a = lb->level_start[c * LEVELS + L], b = lb->level_start[c * LEVELS + L + 1];
  *nb = b - a;
  return lb->level_t + a;
}

/* The line set a point of u groove c takes: level L where the warped mesh
 * there is 2^L times denser than along the groove on average (the lines
 * were set for that average), at most LEVELS - 1; 0 without a warp. */
static int level_at(const ch_label_ctx *lb, int c, const double uv[2]) {
  if (!lb->level_t || lb->set->curves[c].profile.kind != CH_PROFILE_U) return 0;
  double d = ch_label_mesh_density(lb->warp, uv);
  double r = d / lb->curve_density[c];
  int L = 0;
  while (L + 1 < LEVELS && r >= (double)(2 << L)) L++;
  int nb;
  ch_label_lines_of(lb, c, L, &nb);
  return nb > 0 ? L : 0;
}

/* How many of the nb lines br are below x. A line set ascends (groove_lines
 * builds it in order, ch_profile_creases from a profile whose t never
 * decreases): by bisection (a u groove has up to 2 MAX_U_LINES + 2 lines,
 * and counting them one by one was 7% of a run's instructions). */
static int lines_below(const double *br, int nb, double x) {
  int lo = 0, hi = nb; /* those before lo are below x, those from hi on not */
  while (lo < hi) {
    int mid = lo + (hi - lo) / 2;
    if (br[mid] < x)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo;
}

uint64_t ch_label_at(const ch_label_ctx *lb, const double uv[2]) {
  const ch_curve_set *set = lb->set;
  ch_groove_sample gs;
  ch_groove_field_eval(&lb->height->grooves, uv[0], uv[1], &gs);
  uint64_t g = 0;
  if (gs.active >= 0) {
    double t = gs.active_signed_distance / set->curves[gs.active].width;
    int k = 0, L = level_at(lb, gs.active, uv), nb;
    const double *br = ch_label_lines_of(lb, gs.active, L, &nb);
    /* Points within rounding of a line belong to the piece below it, so
     * a path's own points do not flip sides with the noise of s. */
    k = lines_below(br, nb, t - 1e-13);
    /* An active groove is inside its support: the shift above must not
     * make a piece of the hair between the support's edge and the shifted
     * one. */
    if (k < 1) k = 1;
    if (nb > 1 && k > nb - 1) k = nb - 1;
    g = ((uint64_t)L << 28) | ((uint64_t)(gs.active + 1) << 8) | (uint64_t)k;
  }
  uint64_t s = 0;
  if (lb->has_steps) {
    /* The nearest step segment within the radius (the lowest index of
     * equals), from uv's step cell. */
    double best, best_t = 0.0;
    int best_seg = nearest_step(lb, uv, &best, &best_t);
    if (best_seg >= 0) {
      int curve = set->segments[best_seg].curve;
      int left = ch_curve_side(set, best_seg, best_t, uv) > 0;
      if (lb->height->step_method != CH_RECON_EXACT) {
        /* Walls follow the reconstructed curve: its side where it is this curve. */
        ch_recon_sample rs;
        ch_height_step(lb->height, uv[0], uv[1], &rs);
        if (rs.curve == curve) left = rs.side == CH_SIDE_LEFT;
      }
      /* Outside every free loop (find_step_outer) the step part is 0,
       * whichever loop is nearest: h is continuous between loops, and
       * labels that changed with the nearest loop (or at the radius) cut
       * the mesh along every such line for nothing, twice as many boundary
       * points as the walls themselves over many small loops. Each wall
       * still separates two labels: 0 outside, the loop's own inside. */
      int outer = lb->step_outer ? lb->step_outer[best_seg] : 0;
      s = outer && left == outer - 1 ? 0 : ((uint64_t)(curve + 1) << 1) | (uint64_t)left;
    }
  }
  return g << 32 | s;
}

/* Curve c's signed distance at uv from ch_curve_closest_in_cell over grid and
 * boxes (grown by reach); over all of c's segments where the cell has none
 * of them, or (without `beyond`) none within reach. */
double ch_label_signed_distance_in(const ch_label_ctx *lb, const ch_grid *grid, const double *boxes, int c,
                                   const double uv[2], double reach, int beyond, int *segment, double *param) {
  double d2, t;
  int seg = ch_curve_closest_in_cell(lb->set, grid, boxes, c, uv, reach, beyond, &d2, &t);
  if (seg < 0 || (!(d2 <= reach * reach) && !beyond)) {
    /* the whole curve (ch_curve_closest's answer), through the tree: a
     * scan of a path of 500k segments per point took minutes */
    int first, last;
    ch_segtree_curve(&lb->tree, lb->set, c, &first, &last);
    seg = ch_segtree_closest(&lb->tree, lb->set, first, last, uv, INFINITY, &d2, &t);
    if (seg < 0) { /* (a curve has segments; for safety, as ch_curve_closest would) */
      seg = lb->set->curves[c].first_segment;
      d2 = ch_bezier_closest(lb->set->segments[seg].p, lb->set->segments[seg].is_line, uv, &t);
    }
    if (segment) *segment = seg;
    if (param) *param = t;
    return sqrt(d2) * ch_curve_side(lb->set, seg, t, uv);
  }
  if (segment) *segment = seg;
  if (param) *param = t;
  return sqrt(d2) * ch_curve_side(lb->set, seg, t, uv);
}

/* Signed distance s from uv to groove curve c: over c's segments in the
 * grooves' grid cell (boxes grown by w/2); beyond w/2, over all of c's
 * segments, or with `cell_beyond` the closest of those in the cell if
 * there are any (enough to bracket a level inside the groove, and a scan
 * of a long curve less). */
double ch_label_groove_distance_in(const ch_label_ctx *lb, int c, const double uv[2], int *segment, double *param,
                                   int cell_beyond) {
  const ch_groove_field *gf = &lb->height->grooves;
  return ch_label_signed_distance_in(lb, &lb->groove_grid, ch_groove_field_boxes(gf), c, uv,
                                     0.5 * lb->set->curves[c].width, cell_beyond, segment, param);
}

double ch_label_groove_distance(const ch_label_ctx *lb, int c, const double uv[2]) {
  return ch_label_groove_distance_in(lb, c, uv, NULL, NULL, 0);
}

/* h in a given piece at a point on its boundary: h_step read at `inside`
 * (a point of the piece within rounding of `at`), plus the groove of the
 * label evaluated by its own profile segment, continued to `at`. Reading
 * the groove at a point could land on the wrong side of a wall: a label
 * sits a hair (1e-13 in t) off where h changes, and along an edge that
 * meets the line at a grazing angle no offset is safe. */
double ch_label_piece_height(const ch_label_ctx *lb, uint64_t label, const double inside[2], const double at[2]) {
  const ch_height *h = lb->height;
  double value = 0.0;
  if (h->has_steps) {
    ch_recon_sample rs;
    uint32_t step = (uint32_t)label; /* (curve + 1) << 1 | left, 0 away from steps */
    if (!step && h->warp && lb->step_outer) {
      /* 0 is also the outside of a free loop: the side of the nearest one */
      double d2, t;
      int seg = nearest_step(lb, inside, &d2, &t);
      if (seg >= 0 && lb->step_outer[seg])
        step = (uint32_t)(lb->set->segments[seg].curve + 1) << 1 | (uint32_t)(lb->step_outer[seg] - 1);
    }
    if (step && h->warp)             /* the label knows the side; in warped UV a point a hair off the curve may not */
      ch_height_step_side(h, inside[0], inside[1], (int)(step >> 1) - 1, (step & 1) ? CH_SIDE_LEFT : CH_SIDE_RIGHT,
                          &rs);
    else
      ch_height_step(h, inside[0], inside[1], &rs);
    value = rs.value;
  }
  uint64_t g = label >> 32;
  if (!g) return value;
  int curve = GROOVE_CURVE(g), k = (int)(g & 0xff);
  const ch_curve *c = &lb->set->curves[curve];
  double t = ch_label_groove_distance(lb, curve, at) / c->width;
  if (c->profile.kind == CH_PROFILE_U) {
    t = fmax(-0.5, fmin(0.5, t));
    return value + c->depth * ch_profile_eval(&c->profile, t);
  }
  /* Piece k lies between break points k-1 and k: a line through two
   * points well inside it. */
  int nb;
  const double *br = ch_label_lines_of(lb, curve, GROOVE_LEVEL(g), &nb);
  double a = k > 0 ? br[k - 1] : br[0] - 1.0, b = k < nb ? br[k] : br[nb - 1] + 1.0;
  double t1 = a + 0.25 * (b - a), t2 = a + 0.75 * (b - a);
  /* Beyond an open end the side, so the sign of s, flips across the line
   * that continues the path: on that line `at` may get either sign. The
   * limit from inside the piece has the piece's sign. */
  if (a >= 0.0 || b <= 0.0) {
    t = a >= 0.0 ? fabs(t) : -fabs(t);
  } else {
    t = ch_label_groove_distance(lb, curve, inside) >= 0.0 ? fabs(t) : -fabs(t);
  }
  t = fmax(a, fmin(b, t)); /* a junction estimate may lie a little outside */
  double p1 = ch_profile_eval(&c->profile, t1), p2 = ch_profile_eval(&c->profile, t2);
  return value + c->depth * (p1 + (p2 - p1) * (t - t1) / (t2 - t1));
}

/* How much finer than the mean the warped mesh is at uv (relative to the
 * grooves' mean density, within [1/8, 4]); 1 without a warp. */
double ch_label_local_factor(const ch_label_ctx *lb, const double uv[2]) {
  if (!lb->warp) return 1.0;
  double d = ch_label_mesh_density(lb->warp, uv);
  return fmin(4.0, fmax(0.125, lb->mean_density / d));
}

/* The factor of a groove's chord tolerance at uv. Where the warped mesh is
 * coarser than the grooves' mean (away from the view) a chord's sagitta
 * grows as the square of its length, so the tolerance does too, or the
 * chords would refine the coarse parts back towards the mean; where it is
 * finer, linear (see ch_label_init). */
double ch_label_chord_factor(const ch_label_ctx *lb, const double uv[2]) {
  double lf = ch_label_local_factor(lb, uv);
  return lf > 1.0 ? lf * lf : lf;
}
