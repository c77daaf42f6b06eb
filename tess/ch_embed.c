/* Feature embedding by cutting the tessellation along piece boundaries of h
 * (see ch_embed.h for the method and why). */
#include "ch_embed.h"

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

enum { MAX_U_LINES = 60, MAX_LINES = 2 * MAX_U_LINES + 2, MAX_CURVES_LABELLED = 1 << 20, BISECTIONS = 46, JUNCTION_BISECTIONS = 30, MAX_EDGE_SAMPLES = 32 };
/* A triangle is cut from at most MAX_NODES boundary nodes (its corners and
 * its edges' crossings); one with more is refined, in the first
 * DENSE_ROUNDS rounds only: where crossings are spread along its edges
 * (a hatch of lines) halving resolves them, where they meet at a point
 * (grooves crossing there) it never does, and every round would quadruple
 * the triangles there (2000 grooves through a point: minutes). */
enum { MAX_NODES = 192, DENSE_ROUNDS = 4 };
/* Grooves crowd where a cell of the groove field's grid lists more than
 * this many segments (the bundled sets: 24 at most): compute_crossings. */
enum { CROWDED_CELL = 48 };
/* The refinement's cap on working triangles (ch_embed_desc.max_triangles):
 * 8 per base triangle plus 8M (some GB of working mesh and crossings), far
 * above what the bundled sets need. */
#define MAX_REFINED_PER_BASE 8.0
#define MAX_REFINED_EXTRA 8388608.0
#define MIN_SPLIT_LENGTH 1e-5
#define WALL_GROUP (UINT64_C(1) << 62)

/* ---- piece labels ---------------------------------------------------------
 * label = groove part << 32 | step part. Groove part: (line set << 20 |
 * (active curve + 1)) << 8 | index of the profile segment (break points
 * below t = s / w), 0 where no groove decides h; the line set is 0 but
 * for u grooves under a warp (level_at). Step part: (nearest step curve within the radius + 1)
 * << 1 | (side is left), 0 when none is that near. */
typedef struct labeler {
  const ch_height *height;
  const ch_curve_set *set;
  int *crease_start;   /* per curve, into crease_t */
  double *crease_t;
  ch_grid step_grid;   /* step segments, boxes grown by radius */
  double (*step_boxes)[4];
  ch_grid groove_grid; /* groove segments, boxes grown by half their width */
  ch_segtree tree;     /* every segment: a curve's closest, the nearest step curve */
  /* Sharp corners of step curves (joints turning by more than 30 degrees,
   * coarse_at_step_corner): the segments leaving them, bucketed by the
   * corner's cell of a corner_res^2 grid over the unit square (clamped). */
  int *corner_seg, *corner_start, corner_res;
  /* Open ends of grooves but u ones (coarse_at_cap): 2 * segment + end,
   * bucketed so by their point; the largest half width among them. */
  int *end_item, *end_start, end_res;
  double end_reach;
  double radius;
  int has_steps;
  /* Quiet cells: no point within reach of a cell's points is in a groove's
   * support or within `radius` of a step curve, reach = the longest mesh
   * edge; so an edge or triangle whose corners all lie in quiet cells has
   * label 0 throughout. Cells cover [0,1]^2; outside is never quiet. */
  unsigned char *busy;
  int mask_res;
  double *chord_tol;   /* per curve: how far h along a chord may leave the
                          mesh's (a groove's line curves away from its chords) */
  double wall_tol;     /* a jump of h above this is a wall */
  double junction_size; /* triangles holding a junction are refined to this */
  double cap_angle;     /* around an open end, edges span at most this angle */
  const ch_warp *warp;  /* or NULL: then caps and junctions are sized by the
                           warped density there over the grooves' mean */
  double mean_density;
  /* With a warp, u grooves have a finer line set (level 1: the angle step
   * halved) where the warped mesh is at least twice as dense as along the
   * groove on average: a groove's lines run its whole length, so one step
   * for all of it serves only its mean. Where the level changes the labels
   * change across the groove: the cut runs there too (h is continuous),
   * the lines of one side ending on it. level_start[c * LEVELS + L] into
   * level_t. (Three levels measured worse: the junctions where lines end
   * took the triangles.) */
  int *level_start;
  double *level_t;
  double *curve_density; /* per curve: the mean warped density along it */
  double *curve_angle;   /* per curve: the angle step of its lines (radians) */
  double object_scale;   /* object units per UV unit */
} labeler;

enum { LEVELS = 2 };
/* The groove part g of a label: (level << 20 | (curve + 1)) << 8 | k. */
#define GROOVE_CURVE(g) ((int)(((g) >> 8) & 0xfffff) - 1)
#define GROOVE_LEVEL(g) ((int)(((g) >> 28) & 3))

static void labeler_free(labeler *lb) {
  free(lb->busy);
  free(lb->level_start);
  free(lb->level_t);
  free(lb->curve_density);
  free(lb->curve_angle);
  free(lb->crease_start);
  free(lb->crease_t);
  free(lb->chord_tol);
  free(lb->step_boxes);
  ch_grid_free(&lb->step_grid);
  ch_grid_free(&lb->groove_grid);
  ch_segtree_free(&lb->tree);
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
static int groove_lines(const ch_curve *c, double tolerance, double angle, double slope, double min_spacing,
                        double *t, int max) {
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
      hi = 0.0;
    if (!angle_done) {
      double k = ceil(theta_a / angle * (1.0 - 1e-9) + 0.5) - 1.0; /* the largest (k - 1/2) angle < theta_a */
      double q = tan((k - 0.5) * angle) / (2.0 * slope), x = q / sqrt(1.0 + q * q);
      hi = fmax(hi, 0.5 * x);
    }
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

/* The density the warped mesh has at uv: sqrt(slope_u slope_v) of the
 * mesh's metric (ch_warp_mesh_slopes; the mesh's edge is e / that). */
static double mesh_density(const ch_warp *w, const double uv[2]) {
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
      sum += l * (w ? mesh_density(w, mid) : 1.0);
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
static int corner_cell(int res, double x) {
  double f = floor(x * res);
  return !(f >= 0.0) ? 0 : f >= res ? res - 1 : (int)f;
}

/* The sharp corners of the step curves, bucketed (a counting sort keeps
 * each cell's in segment order). */
static ch_status find_step_corners(labeler *lb, ch_error *err) {
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
      lb->corner_start[corner_cell(res, q[1]) * res + corner_cell(res, q[0]) + 1]++;
    }
  for (int c = 0; c < res * res; c++) lb->corner_start[c + 1] += lb->corner_start[c];
  int *fill = malloc((size_t)res * res * sizeof *fill);
  if (!fill) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for step corners");
  memcpy(fill, lb->corner_start, (size_t)res * res * sizeof *fill);
  for (int s = 0; s < set->num_segments; s++)
    if (sharp_step_corner(set, s)) {
      const double *q = set->segments[s].p[0];
      lb->corner_seg[fill[corner_cell(res, q[1]) * res + corner_cell(res, q[0])]++] = s;
    }
  free(fill);
  return CH_OK;
}

/* Whether end (0: start, 1: end) of segment s is an open end of a groove
 * whose cap coarse_at_cap sizes (all profiles but u). */
static int capped_end(const ch_curve_set *set, int s, int end) {
  const ch_segment *sg = &set->segments[s];
  const ch_curve *cv = &set->curves[sg->curve];
  return cv->kind == CH_CURVE_GROOVE && cv->profile.kind != CH_PROFILE_U && (end == 0 ? sg->prev : sg->next) < 0;
}

/* The open ends coarse_at_cap looks at, bucketed like the step corners. */
static ch_status find_open_ends(labeler *lb, ch_error *err) {
  const ch_curve_set *set = lb->set;
  int n = 0;
  for (int s = 0; s < set->num_segments; s++)
    for (int end = 0; end < 2; end++)
      if (capped_end(set, s, end)) {
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
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the grooves' ends");
  }
  for (int pass = 0; pass < 2; pass++) {
    if (pass == 1) {
      for (int c = 0; c < res * res; c++) lb->end_start[c + 1] += lb->end_start[c];
      memcpy(fill, lb->end_start, (size_t)res * res * sizeof *fill);
    }
    for (int s = 0; s < set->num_segments; s++)
      for (int end = 0; end < 2; end++) {
        if (!capped_end(set, s, end)) continue;
        const double *q = set->segments[s].p[end == 0 ? 0 : 2];
        int cell = corner_cell(res, q[1]) * res + corner_cell(res, q[0]);
        if (pass == 0) lb->end_start[cell + 1]++;
        else lb->end_item[fill[cell]++] = 2 * s + end;
      }
  }
  free(fill);
  return CH_OK;
}

static ch_status labeler_init(labeler *lb, const ch_height *height, const ch_warp *warp, double radius,
                              double curve_tolerance, double angle, double object_scale, double mean_edge,
                              double reach, ch_error *err) {
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
    labeler_free(lb);
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
    labeler_free(lb);
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
      labeler_free(lb);
      return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the feature labels");
    }
  }
  int nl = 0; /* lines of the finer sets */
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
      n += groove_lines(cv, tol, angle, slope, spacing, lb->crease_t + n, MAX_LINES);
      /* the finer sets of a u groove (level L: the angle step and the
       * rim's spacing / 2^L, as the mesh there is 2^L times finer) */
      for (int L = 1; lb->level_t && cv->profile.kind == CH_PROFILE_U && L < LEVELS; L++) {
        lb->level_start[c * LEVELS + L] = nl;
        double a = fmax(CH_PI / 180.0, angle / (double)(1 << L));
        double sp = fmax(2.0 * MIN_SPLIT_LENGTH, spacing / (double)(1 << L));
        nl += groove_lines(cv, tol, a, slope, sp, lb->level_t + nl, MAX_LINES);
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
  /* Box grids for one curve's distance (closest_in_cell), whose answer
   * beyond reach is the cell's (so the level functions the crossing search
   * follows, and the bytes out, stay as they were); the groove field's
   * own grid lists long segments only along their way. */
  ch_status st = ch_grid_build(&lb->step_grid, set->num_segments, (const double(*)[4])lb->step_boxes, err);
  if (!st) st = ch_grid_build(&lb->groove_grid, set->num_segments, (const double(*)[4])height->grooves.boxes, err);
  if (!st) st = ch_segtree_build(&lb->tree, set, err);
  if (!st) st = find_step_corners(lb, err);
  if (!st) st = find_open_ends(lb, err);
  if (st) {
    labeler_free(lb);
    return st;
  }
  /* The quiet-cell mask, cells about one longest edge wide. */
  int res = (int)fmin(2048.0, fmax(16.0, ceil(1.0 / fmax(reach, 1e-9))));
  lb->mask_res = res;
  lb->busy = calloc((size_t)res * res, 1);
  if (!lb->busy) {
    labeler_free(lb);
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

static int quiet(const labeler *lb, const double uv[2]) {
  double fx = uv[0] * lb->mask_res, fy = uv[1] * lb->mask_res;
  if (!(fx >= 0.0 && fy >= 0.0 && fx < lb->mask_res && fy < lb->mask_res)) return 0;
  return !lb->busy[(size_t)fy * lb->mask_res + (size_t)fx];
}

/* The break lines of groove c at level L (the finer sets of u grooves). */
static const double *lines_of(const labeler *lb, int c, int L, int *nb) {
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
static int level_at(const labeler *lb, int c, const double uv[2]) {
  if (!lb->level_t || lb->set->curves[c].profile.kind != CH_PROFILE_U) return 0;
  double d = mesh_density(lb->warp, uv);
  double r = d / lb->curve_density[c];
  int L = 0;
  while (L + 1 < LEVELS && r >= (double)(2 << L)) L++;
  int nb;
  lines_of(lb, c, L, &nb);
  return nb > 0 ? L : 0;
}

static uint64_t label_at(const labeler *lb, const double uv[2]) {
  const ch_curve_set *set = lb->set;
  ch_groove_sample gs;
  ch_groove_field_eval(&lb->height->grooves, uv[0], uv[1], &gs);
  uint64_t g = 0;
  if (gs.active >= 0) {
    double t = gs.active_signed_distance / set->curves[gs.active].width;
    int k = 0, L = level_at(lb, gs.active, uv), nb;
    const double *br = lines_of(lb, gs.active, L, &nb);
    /* Points within rounding of a line belong to the piece below it, so
     * a path's own points do not flip sides with the noise of s. */
    for (int i = 0; i < nb; i++) k += br[i] < t - 1e-13;
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
     * equals): through the tree, whose cost follows the curves near uv,
     * not all those within the radius (a grid cell of a coarse mesh's
     * radius over 10,000 small loops holds thousands). */
    double best, best_t = 0.0;
    int best_seg = ch_segtree_closest(&lb->tree, set, 0, lb->tree.num_step_leaves, uv, lb->radius * lb->radius,
                                      &best, &best_t);
    if (best_seg >= 0) {
      int curve = set->segments[best_seg].curve;
      int left = ch_curve_side(set, best_seg, best_t, uv) > 0;
      if (lb->height->step_method != CH_RECON_EXACT) {
        /* Walls follow the reconstructed curve: its side where it is this curve. */
        ch_recon_sample rs;
        ch_height_step(lb->height, uv[0], uv[1], &rs);
        if (rs.curve == curve) left = rs.side == CH_SIDE_LEFT;
      }
      s = ((uint64_t)(curve + 1) << 1) | (uint64_t)left;
    }
  }
  return g << 32 | s;
}

/* The segment of curve c closest to uv among those in uv's cell of grid
 * whose box (grown by reach) holds uv: they hold the closest one wherever
 * it is within reach. With `beyond`, if none is within reach, the closest
 * of c's other segments in the cell (not always the least distance, but
 * one beyond reach still). Ties go to the first segment, as in
 * ch_curve_closest. Returns the segment (-1: none in the cell), its
 * squared distance and parameter in *d2 and *t. */
static int closest_in_cell(const ch_curve_set *set, const ch_grid *grid, const double (*boxes)[4], int c,
                           const double uv[2], double reach, int beyond, double *d2, double *t) {
  const int *items = NULL;
  int n = ch_grid_query(grid, uv[0], uv[1], &items), best_seg = -1;
  /* The cell's items ascend and c's segments are consecutive: its run
   * (by bisection: cells near many curves hold thousands of items). */
  int s0 = set->curves[c].first_segment, s1 = s0 + set->curves[c].num_segments, k0 = 0, k1 = n;
  while (k0 < k1) { /* the first item >= s0 */
    int mid = k0 + (k1 - k0) / 2;
    if (items[mid] < s0) k0 = mid + 1;
    else k1 = mid;
  }
  for (k1 = k0; k1 < n && items[k1] < s1;) k1++;
  double best = INFINITY, best_t = 0.0;
  for (int pass = 0; pass < (beyond ? 2 : 1) && !(best <= reach * reach); pass++)
    for (int k = k0; k < k1; k++) {
      const ch_segment *sg = &set->segments[items[k]];
      const double *b = boxes[items[k]];
      int inside = !(uv[0] < b[0] || uv[0] > b[2] || uv[1] < b[1] || uv[1] > b[3]);
      if (inside != (pass == 0)) continue;
      double tk, dk = ch_bezier_closest(sg->p, sg->is_line, uv, &tk);
      if (dk < best || (dk == best && items[k] < best_seg)) {
        best = dk;
        best_t = tk;
        best_seg = items[k];
      }
    }
  *d2 = best;
  *t = best_t;
  return best_seg;
}

/* Signed distance s from uv to groove curve c: over c's segments in the
 * grooves' grid cell (boxes grown by w/2); beyond w/2, over all of c's
 * segments, or with `cell_beyond` the closest of those in the cell if
 * there are any (enough to bracket a level inside the groove, and a scan
 * of a long curve less). */
/* Curve c's signed distance at uv from closest_in_cell over grid and
 * boxes (grown by reach); over all of c's segments where the cell has none
 * of them, or (without `beyond`) none within reach. */
static double signed_distance_in(const labeler *lb, const ch_grid *grid, const double (*boxes)[4], int c,
                                 const double uv[2], double reach, int beyond, int *segment) {
  double d2, t;
  int seg = closest_in_cell(lb->set, grid, boxes, c, uv, reach, beyond, &d2, &t);
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
    return sqrt(d2) * ch_curve_side(lb->set, seg, t, uv);
  }
  if (segment) *segment = seg;
  return sqrt(d2) * ch_curve_side(lb->set, seg, t, uv);
}

static double groove_distance_in(const labeler *lb, int c, const double uv[2], int *segment, int cell_beyond) {
  const ch_groove_field *gf = &lb->height->grooves;
  return signed_distance_in(lb, &lb->groove_grid, (const double(*)[4])gf->boxes, c, uv, 0.5 * lb->set->curves[c].width,
                            cell_beyond, segment);
}

static double groove_distance(const labeler *lb, int c, const double uv[2]) {
  return groove_distance_in(lb, c, uv, NULL, 0);
}

/* h in a given piece at a point on its boundary: h_step read at `inside`
 * (a point of the piece within rounding of `at`), plus the groove of the
 * label evaluated by its own profile segment, continued to `at`. Reading
 * the groove at a point could land on the wrong side of a wall: a label
 * sits a hair (1e-13 in t) off where h changes, and along an edge that
 * meets the line at a grazing angle no offset is safe. */
static double piece_height(const labeler *lb, uint64_t label, const double inside[2], const double at[2]) {
  const ch_height *h = lb->height;
  double value = 0.0;
  if (h->has_steps) {
    ch_recon_sample rs;
    uint32_t step = (uint32_t)label; /* (curve + 1) << 1 | left, 0 away from steps */
    if (step && h->warp) /* the label knows the side; in warped UV a point a hair off the curve may not */
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
  double t = groove_distance(lb, curve, at) / c->width;
  if (c->profile.kind == CH_PROFILE_U) {
    t = fmax(-0.5, fmin(0.5, t));
    return value - c->depth * sqrt(fmax(0.0, 1.0 - 4.0 * t * t));
  }
  /* Piece k lies between break points k-1 and k: a line through two
   * points well inside it. */
  int nb;
  const double *br = lines_of(lb, curve, GROOVE_LEVEL(g), &nb);
  double a = k > 0 ? br[k - 1] : br[0] - 1.0, b = k < nb ? br[k] : br[nb - 1] + 1.0;
  double t1 = a + 0.25 * (b - a), t2 = a + 0.75 * (b - a);
  /* Beyond an open end the side, so the sign of s, flips across the line
   * that continues the path: on that line `at` may get either sign. The
   * limit from inside the piece has the piece's sign. */
  if (a >= 0.0 || b <= 0.0) {
    t = a >= 0.0 ? fabs(t) : -fabs(t);
  } else {
    t = groove_distance(lb, curve, inside) >= 0.0 ? fabs(t) : -fabs(t);
  }
  t = fmax(a, fmin(b, t)); /* a junction estimate may lie a little outside */
  double p1 = ch_profile_eval(&c->profile, t1), p2 = ch_profile_eval(&c->profile, t2);
  return value + c->depth * (p1 + (p2 - p1) * (t - t1) / (t2 - t1));
}

/* ---- the working mesh ------------------------------------------------------ */
typedef struct wvert {
  double uv[2];   /* UV where labels and h are read (the chart of its face) */
  double st[2];
  int face;
  uint64_t label;
  double h;
} wvert;

typedef struct wtri {
  int v[3];
  int face;
  double uv[3][2]; /* corner UVs (face-varying) */
  double st[3][2]; /* corner parameters in face */
} wtri;

/* A point where an edge passes from one piece into the next. */
typedef struct crossing {
  double x;           /* fraction from the edge's a to its b */
  uint64_t la, lb;    /* the pieces on a's and on b's side */
  double ha, hb;      /* h just inside each */
  int copy_a, copy_b; /* output vertices (equal where h does not jump) */
} crossing;

typedef struct wedge {
  int a, b;          /* vertices, a < b */
  int tri, k;        /* canonical triangle (the first) and its edge k: v[k] -> v[k+1] */
  int ncross;
  crossing *cross;   /* ncross, by increasing x; owned */
  int mid;           /* midpoint vertex when split (the edge is then gone), else -1 */
  int half[2];       /* when split: the halves from a and from b */
} wedge;

typedef struct work {
  const ch_surface *surface;
  wvert *verts;
  int nverts, cap_verts;
  wtri *tris;
  int ntris, cap_tris;
  wedge *edges;
  int nedges, cap_edges;
  int *tri_edge; /* 3 per triangle */
  int cap_tri_edge;
} work;

static int grow(void **p, int *cap, int need, size_t size) {
  if (need <= *cap) return 0;
  int n = *cap ? *cap : 1024;
  while (n < need) n = n > (1 << 29) ? need : 2 * n;
  void *q = realloc(*p, (size_t)n * size);
  if (!q) return -1;
  *p = q;
  *cap = n;
  return 0;
}

static void lerp2(const double a[2], const double b[2], double x, double out[2]) {
  out[0] = a[0] + x * (b[0] - a[0]);
  out[1] = a[1] + x * (b[1] - a[1]);
}

/* The (s,t) in face of a new point from its UV (UV is linear in each face,
 * its (s,t) is not: an N-gon's sub-faces tile the parameter plane, so
 * interpolating (s,t) across a triangle can leave the domain). st holds
 * the interpolated guess, kept if the point is not found. */
static void locate_st(const ch_surface *surface, int face, const double uv[2], double st[2]) {
  double found[2];
  if (ch_surface_locate(surface, face, uv, found) == CH_OK) memcpy(st, found, sizeof found);
}

/* The UV and (s,t) of edge e at fraction x from e->a, in its canonical triangle. */
static void edge_point(const work *w, const wedge *e, double x, double uv[2], double st[2]) {
  const wtri *t = &w->tris[e->tri];
  int i = e->k, j = (e->k + 1) % 3;
  if (t->v[i] != e->a) {
    int tmp = i;
    i = j;
    j = tmp;
  }
  if (uv) lerp2(t->uv[i], t->uv[j], x, uv);
  if (st) lerp2(t->st[i], t->st[j], x, st);
}

static uint64_t edge_label(const labeler *lb, const work *w, const wedge *e, double x) {
  if (x <= 0.0) return w->verts[e->a].label;
  if (x >= 1.0) return w->verts[e->b].label;
  double uv[2];
  edge_point(w, e, x, uv, NULL);
  return label_at(lb, uv);
}

static void free_edges(wedge *edges, int n) {
  for (int i = 0; i < n; i++) free(edges[i].cross);
  free(edges);
}

/* The unique edges of the triangles, sorted by vertex pair (a counting
 * sort by the lower vertex, then each short run by the other); the
 * canonical triangle of an edge is the lowest one holding it. Refinement
 * then updates them in place (split_triangles). */
static ch_status build_edges(work *w, ch_error *err) {
  size_t n = 3 * (size_t)w->ntris;
  int *start = calloc((size_t)w->nverts + 1, sizeof *start);
  int(*entry)[2] = malloc(n * sizeof *entry); /* other vertex, corner */
  w->edges = malloc(n * sizeof *w->edges);
  w->tri_edge = malloc(n * sizeof *w->tri_edge);
  if (!start || !entry || !w->edges || !w->tri_edge) {
    free(start);
    free(entry);
    free(w->edges);
    free(w->tri_edge);
    w->edges = NULL;
    w->tri_edge = NULL;
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for %zu mesh edges", n);
  }
  for (size_t c = 0; c < n; c++) {
    int a = w->tris[c / 3].v[c % 3], b = w->tris[c / 3].v[(c % 3 + 1) % 3];
    start[(a < b ? a : b) + 1]++;
  }
  for (int v = 0; v < w->nverts; v++) start[v + 1] += start[v];
  for (size_t c = 0; c < n; c++) { /* corners in order: runs stay in corner order */
    int a = w->tris[c / 3].v[c % 3], b = w->tris[c / 3].v[(c % 3 + 1) % 3];
    int lo = a < b ? a : b, hi = a < b ? b : a;
    int *slot = entry[start[lo]++];
    slot[0] = hi;
    slot[1] = (int)c;
  }
  for (int v = w->nverts; v > 0; v--) start[v] = start[v - 1];
  start[0] = 0;
  int ne = 0;
  for (int a = 0; a < w->nverts; a++) {
    int s0 = start[a], s1 = start[a + 1];
    for (int p = s0 + 1; p < s1; p++) /* by other vertex, stable */
      for (int q = p; q > s0 && entry[q - 1][0] > entry[q][0]; q--) {
        int t0 = entry[q][0], t1 = entry[q][1];
        entry[q][0] = entry[q - 1][0];
        entry[q][1] = entry[q - 1][1];
        entry[q - 1][0] = t0;
        entry[q - 1][1] = t1;
      }
    for (int i = s0; i < s1;) {
      int j = i + 1;
      while (j < s1 && entry[j][0] == entry[i][0]) j++;
      wedge *e = &w->edges[ne];
      memset(e, 0, sizeof *e);
      e->a = a;
      e->b = entry[i][0];
      e->tri = entry[i][1] / 3;
      e->k = entry[i][1] % 3;
      e->mid = -1;
      e->ncross = -1; /* not computed */
      for (int p = i; p < j; p++) w->tri_edge[entry[p][1]] = ne;
      ne++;
      i = j;
    }
  }
  w->nedges = ne;
  w->cap_edges = (int)n;
  w->cap_tri_edge = (int)n;
  free(start);
  free(entry);
  return CH_OK;
}

static double edge_length(const work *w, const wedge *e) {
  double a[2], b[2];
  edge_point(w, e, 0.0, a, NULL);
  edge_point(w, e, 1.0, b, NULL);
  return hypot(b[0] - a[0], b[1] - a[1]);
}

/* Signed distance from uv to step curve c over c's segments in the step
 * grid's cell (boxes grown by the radius); beyond the radius, the closest
 * of c's segments in the cell (the level functions only need a distance
 * beyond the radius there), or over all of c's segments if the cell has
 * none. */
static double step_distance_at(const labeler *lb, int c, const double uv[2], int *segment) {
  return signed_distance_in(lb, &lb->step_grid, (const double(*)[4])lb->step_boxes, c, uv, lb->radius, 1, segment);
}

/* The level functions the crossing search follows along an edge: t = s / w
 * of a groove (its break lines), |t| (its rim), the signed distance to a
 * step curve (its wall or crease), the difference of two grooves' carves
 * (where one takes over from the other, SPEC §3's CSG: the deeper wins);
 * and for the labels' own boundaries, the distance to a step curve (the
 * edge of its radius) and the difference of the distances to two (where
 * the nearest changes). */
typedef enum { LEVEL_LINE, LEVEL_RIM, LEVEL_STEP, LEVEL_PAIR, LEVEL_REACH, LEVEL_NEAREST } level_kind;

/* Groove c's carve (or raise) g = depth P(t) at uv, 0 outside it. */
static double groove_carve(const labeler *lb, int c, const double uv[2]) {
  const ch_curve *cv = &lb->set->curves[c];
  double t = groove_distance_in(lb, c, uv, NULL, 1) / cv->width;
  return fabs(t) < 0.5 ? cv->depth * ch_profile_eval(&cv->profile, t) : 0.0;
}

/* The level function at point x of edge e, against curve c (LEVEL_PAIR
 * and LEVEL_NEAREST: c = a * MAX_CURVES_LABELLED + b for curves a and b),
 * or only its segment seg when seg >= 0 (both bracket ends nearest it);
 * *segment gets the nearest segment when asked. */
static double level_value(const labeler *lb, const work *w, const wedge *e, level_kind kind, int c, int seg, double x,
                          int *segment) {
  double uv[2];
  edge_point(w, e, x, uv, NULL);
  if (kind == LEVEL_PAIR)
    return groove_carve(lb, c / MAX_CURVES_LABELLED, uv) - groove_carve(lb, c % MAX_CURVES_LABELLED, uv);
  if (kind == LEVEL_NEAREST)
    return fabs(step_distance_at(lb, c / MAX_CURVES_LABELLED, uv, NULL)) -
           fabs(step_distance_at(lb, c % MAX_CURVES_LABELLED, uv, NULL));
  double v;
  if (seg >= 0) {
    const ch_segment *sg = &lb->set->segments[seg];
    double t, d2 = ch_bezier_closest(sg->p, sg->is_line, uv, &t);
    v = sqrt(d2) * ch_curve_side(lb->set, seg, t, uv);
    if (segment) *segment = seg;
  } else {
    v = kind == LEVEL_STEP || kind == LEVEL_REACH ? step_distance_at(lb, c, uv, segment)
                                                  : groove_distance_in(lb, c, uv, segment, 1);
  }
  if (kind == LEVEL_STEP) return v;
  if (kind == LEVEL_REACH) return fabs(v);
  v /= lb->set->curves[c].width;
  return kind == LEVEL_RIM ? fabs(v) : v;
}

/* A level set of a level function f - target along edge e, bracketed by
 * [*a, *b] with f(a) = *fa and f(b) = *fb of opposite signs, by false
 * position (Illinois) until the bracket is below tol, or until the last
 * estimate m is within tol / 4 of the root by the secant's slope: then
 * [*a, *b] = m -+ tol / 2 (unchecked: callers check the answer by the
 * labels). One segment of c (seg >= 0: both ends are nearest it) is
 * enough for the search. On return [*a, *b] brackets the root (in either
 * order) and *fa is f(*a)'s sign. */
static void level_root(const labeler *lb, const work *w, const wedge *e, level_kind kind, int c, int seg,
                       double target, double tol, double *a, double *b, double *fa, double *fb) {
  int side = 0;
  for (int it = 0; it < 80 && fabs(*b - *a) > tol; it++) {
    double m = (*a * *fb - *b * *fa) / (*fb - *fa);
    if (!(m > fmin(*a, *b) && m < fmax(*a, *b))) m = 0.5 * (*a + *b);
    double fm = level_value(lb, w, e, kind, c, seg, m, NULL) - target;
    /* On the level itself a line's label is still the lower piece's:
     * keep bracketing. */
    if (fm == 0.0) fm = -1e-300;
    double slope = (fm - *fb) / (m - *b);
    if (fabs(fm) <= 0.25 * tol * fabs(slope)) {
      /* the side of m - tol / 2 is the one opposite to fm's along the slope */
      double lo = m - 0.5 * tol, hi = m + 0.5 * tol, flo = (slope > 0.0) == (fm > 0.0) ? -fm : fm;
      *a = lo;
      *fa = flo;
      *b = hi;
      *fb = -flo;
      return;
    }
    if (fm * *fb < 0.0) {
      *a = *b;
      *fa = *fb;
      side = 0;
    } else if (++side >= 2) {
      *fa *= 0.5;
    }
    *b = m;
    *fb = fm;
  }
}

/* Finds the level of f = target between x0 < x1 (label l0 at x0, f -
 * target = f0 there and f1 of the other sign at x1) and narrows the
 * bisection's bracket [*lo, *hi] to it if the labels agree: l0 on x0's
 * side of it, another label on the other; returns whether they did. The
 * labels decide by their own evaluation, which can put the change a few
 * roundings away (on a step curve itself the side is rounding): the
 * bracket widens until they confirm it. */
static int narrow_to_level(const labeler *lb, const work *w, const wedge *e, uint64_t l0, level_kind kind, int c,
                           int seg, double target, double x0, double f0, double x1, double f1, double *lo,
                           double *hi, uint64_t *lhi) {
  double a = x0, b = x1, fa = f0, fb = f1;
  level_root(lb, w, e, kind, c, seg, target, 1e-14, &a, &b, &fa, &fb);
  double near = (fa * f0 > 0.0) ? a : b, far = near == a ? b : a;
  if (!(near < far)) return 0;
  static const double widen[] = {0.0, 1e-13, 1e-11, 1e-9};
  for (int k = 0; k < 4; k++) {
    double l = fmax(x0, near - widen[k]), h = fmin(x1, far + widen[k]);
    uint64_t next = edge_label(lb, w, e, h);
    if (next == l0 || edge_label(lb, w, e, l) != l0) continue;
    *lo = l;
    *hi = h;
    *lhi = next;
    return 1;
  }
  return 0;
}

/* The fast paths of the crossing search: where two labels differ by one
 * level function, its level set is found by false position in a dozen
 * closest-point queries and confirmed by the labels at both ends of the
 * bracket, which bisection then closes (a bracket of ~1e-14 already: no
 * step; one the labels cannot confirm: bisection from the samples, 46
 * label evaluations, as every crossing took before but lines and rims).
 * - between two pieces of one groove (its break lines, the many lines of a
 *   u profile), or out of a groove through its lines towards the rim, one
 *   line at a time: t = the line;
 * - at a groove's rim (one side outside it, the same step piece): |t| =
 *   1/2 (a u profile is vertical there: the heights on its two sides only
 *   agree where the label itself flips, hence the confirmation);
 * - between two grooves: g_a = g_b;
 * - across a step curve (the same curve, the sides differ, walls on the
 *   exact curve): its signed distance = 0;
 * - at the edge of a step curve's radius: distance = radius; where the
 *   nearest step curve changes: the two distances equal. */
static void narrow_crossing(const labeler *lb, const work *w, const wedge *e, uint64_t l0, uint64_t l1, double x0,
                            double x1, double *lo, double *hi, uint64_t *lhi) {
  uint64_t g0 = l0 >> 32, g1 = l1 >> 32, s0 = l0 & 0xffffffffu, s1 = l1 & 0xffffffffu;
  int sa = -1, sb = -1;
  if (s0 == s1 && g0 && (!g1 || (g0 >> 8) == (g1 >> 8))) { /* lines of one groove */
    int c = GROOVE_CURVE(g0), k0 = (int)(g0 & 0xff), k1 = (int)(g1 & 0xff), nb;
    const double *br = lines_of(lb, c, GROOVE_LEVEL(g0), &nb);
    double ta = level_value(lb, w, e, LEVEL_LINE, c, -1, x0, &sa);
    double tb = level_value(lb, w, e, LEVEL_LINE, c, -1, x1, &sb);
    if (!g1) k1 = k0 + (tb > ta ? 1 : -1);
    if (k1 != k0 && k1 >= 1 && k1 <= nb - 1) {
      double target = (k1 > k0 ? br[k0] : br[k0 - 1]) + 1e-13; /* where the label's piece index steps */
      if (ta - target != 0.0 && (ta - target) * (tb - target) < 0.0)
        narrow_to_level(lb, w, e, l0, LEVEL_LINE, c, sa == sb ? sa : -1, target, x0, ta - target, x1, tb - target,
                        lo, hi, lhi);
      return;
    }
  }
  if (s0 == s1 && (!g0 != !g1)) { /* a rim (the outermost piece of the groove on one side) */
    int c = GROOVE_CURVE(g0 ? g0 : g1);
    double fa = level_value(lb, w, e, LEVEL_RIM, c, -1, x0, &sa) - 0.5;
    double fb = level_value(lb, w, e, LEVEL_RIM, c, -1, x1, &sb) - 0.5;
    if (fa != 0.0 && fa * fb < 0.0)
      narrow_to_level(lb, w, e, l0, LEVEL_RIM, c, sa == sb ? sa : -1, 0.5, x0, fa, x1, fb, lo, hi, lhi);
  } else if (s0 == s1 && g0 && g1 && GROOVE_CURVE(g0) != GROOVE_CURVE(g1) && lb->set->num_curves < 2048) {
    /* two grooves: where the deeper carve (or the higher raise) changes */
    int c = GROOVE_CURVE(g0) * MAX_CURVES_LABELLED + GROOVE_CURVE(g1);
    double fa = level_value(lb, w, e, LEVEL_PAIR, c, -1, x0, NULL);
    double fb = level_value(lb, w, e, LEVEL_PAIR, c, -1, x1, NULL);
    if (fa != 0.0 && fa * fb < 0.0) narrow_to_level(lb, w, e, l0, LEVEL_PAIR, c, -1, 0.0, x0, fa, x1, fb, lo, hi, lhi);
  } else if (g0 == g1 && s0 && s1 && (s0 >> 1) == (s1 >> 1) && lb->height->step_method == CH_RECON_EXACT) {
    int c = (int)(s0 >> 1) - 1; /* one step curve's two sides */
    double fa = level_value(lb, w, e, LEVEL_STEP, c, -1, x0, &sa);
    double fb = level_value(lb, w, e, LEVEL_STEP, c, -1, x1, &sb);
    if (fa != 0.0 && fa * fb < 0.0)
      narrow_to_level(lb, w, e, l0, LEVEL_STEP, c, sa == sb ? sa : -1, 0.0, x0, fa, x1, fb, lo, hi, lhi);
  } else if (g0 == g1 && !s0 != !s1) { /* the edge of a step curve's radius */
    int c = (int)((s0 ? s0 : s1) >> 1) - 1;
    double fa = level_value(lb, w, e, LEVEL_REACH, c, -1, x0, &sa) - lb->radius;
    double fb = level_value(lb, w, e, LEVEL_REACH, c, -1, x1, &sb) - lb->radius;
    if (fa != 0.0 && fa * fb < 0.0)
      narrow_to_level(lb, w, e, l0, LEVEL_REACH, c, sa == sb ? sa : -1, lb->radius, x0, fa, x1, fb, lo, hi, lhi);
  } else if (g0 == g1 && s0 && s1 && (s0 >> 1) != (s1 >> 1) && lb->set->num_curves < 2048) {
    /* where the nearest step curve changes */
    int c = (int)((s0 >> 1) - 1) * MAX_CURVES_LABELLED + (int)((s1 >> 1) - 1);
    double fa = level_value(lb, w, e, LEVEL_NEAREST, c, -1, x0, NULL);
    double fb = level_value(lb, w, e, LEVEL_NEAREST, c, -1, x1, NULL);
    if (fa != 0.0 && fa * fb < 0.0)
      narrow_to_level(lb, w, e, l0, LEVEL_NEAREST, c, -1, 0.0, x0, fa, x1, fb, lo, hi, lhi);
  }
}

/* Every boundary between pieces along e. Labels are sampled about delta
 * apart; from each sample whose label differs from the next, bisection
 * (in the bracket a fast path narrowed) finds a change to about 1e-14 of
 * the edge, and the search goes on from there, so lines closer together
 * than the samples (the break lines near a u groove's rim) are all found.
 * h is read on both sides. */
static int compute_crossings(const labeler *lb, const work *w, wedge *e, double delta) {
  double pa[2], pb[2];
  edge_point(w, e, 0.0, pa, NULL);
  edge_point(w, e, 1.0, pb, NULL);
  if (quiet(lb, pa) && quiet(lb, pb)) {
    e->ncross = 0;
    e->cross = NULL;
    return 0;
  }
  double len = hypot(pb[0] - pa[0], pb[1] - pa[1]);
  int n = (int)ceil(len / delta);
  /* At least the midpoint: short edges cross lines one after the other,
   * which the ends' labels show; a midpoint catches most slivers a
   * triangle's corners miss, and the refinement's hidden-piece check the
   * rest (a third sample more made no difference on the bundled sets). */
  n = n < 2 ? 2 : n > MAX_EDGE_SAMPLES ? MAX_EDGE_SAMPLES : n;
  crossing *list = NULL;
  int count = 0, cap = 0;
  double x0 = 0.0;
  uint64_t l0 = w->verts[e->a].label;
  const int *items;
  int crowded = ch_grid_query(&lb->height->grooves.grid, 0.5 * (pa[0] + pb[0]), 0.5 * (pa[1] + pb[1]), &items) >
                CROWDED_CELL;
  /* An edge with MAX_NODES crossings makes every triangle holding it one
   * that cannot be cut: the search stops there (what is found is kept). */
  for (int i = 1; i <= n && count < MAX_NODES; i++) {
    double x1 = (double)i / n;
    uint64_t l1 = edge_label(lb, w, e, x1);
    while (l0 != l1 && count < MAX_NODES) {
      double lo = x0, hi = x1;
      uint64_t lhi = l1;
      narrow_crossing(lb, w, e, l0, l1, x0, x1, &lo, &hi, &lhi);
      for (int it = 0; it < BISECTIONS && hi - lo > 1e-14; it++) {
        double mid = 0.5 * (lo + hi);
        uint64_t lm = edge_label(lb, w, e, mid);
        if (lm == l0) {
          lo = mid;
        } else {
          hi = mid;
          lhi = lm;
        }
        /* Where grooves crowd (many crossing each other), many changes
         * between two samples defeat the fast path and every label is a
         * sum over all of them: once bisection has cut the bracket 64
         * times, it tries again between l0 and the label the bracket now
         * ends on, most often the only change left in it (a dozen
         * one-curve evaluations instead of 40 more labels). */
        if (crowded && it % 6 == 5 && hi - lo > 1e-14) narrow_crossing(lb, w, e, l0, lhi, lo, hi, &lo, &hi, &lhi);
      }
      if (grow((void **)&list, &cap, count + 1, sizeof *list)) {
        free(list);
        e->cross = NULL;
        e->ncross = 0;
        return -1;
      }
      crossing *c = &list[count++];
      double uv[2];
      c->x = 0.5 * (lo + hi);
      c->la = l0;
      c->lb = lhi;
      double at[2];
      edge_point(w, e, c->x, at, NULL);
      edge_point(w, e, lo, uv, NULL);
      c->ha = piece_height(lb, l0, uv, at);
      edge_point(w, e, hi, uv, NULL);
      c->hb = piece_height(lb, lhi, uv, at);
      c->copy_a = c->copy_b = -1;
      x0 = hi;
      l0 = lhi;
    }
    x0 = x1;
    l0 = l1;
  }
  /* Where two pieces tie (two mirrored grooves along their line of
   * symmetry) rounding flips the label back and forth within a hair:
   * a crossing that returns to the piece before it within 1e-9 of the edge
   * cancels with it. */
  for (int changed = 1; changed;) {
    changed = 0;
    for (int i = 0; i + 1 < count; i++)
      if (list[i + 1].x - list[i].x < 1e-9 && list[i + 1].lb == list[i].la) {
        memmove(&list[i], &list[i + 2], (size_t)(count - i - 2) * sizeof *list);
        count -= 2;
        changed = 1;
        break;
      }
  }
  e->cross = list;
  e->ncross = count;
  return 0;
}

static void label_vertices(const labeler *lb, work *w, int from) {
#pragma omp parallel for schedule(dynamic, 256)
  for (int v = from; v < w->nverts; v++) {
    w->verts[v].label = quiet(lb, w->verts[v].uv) ? 0 : label_at(lb, w->verts[v].uv);
    w->verts[v].h = ch_height_eval(lb->height, w->verts[v].uv[0], w->verts[v].uv[1]);
  }
}

/* New vertex at the midpoint of edge i (in its canonical triangle's
 * chart), and the edge's two halves: half[0] from a to it, half[1] from b
 * (their canonical triangles are set when the triangles split). */
static int add_midpoint(work *w, int i) {
  if (grow((void **)&w->verts, &w->cap_verts, w->nverts + 1, sizeof *w->verts) ||
      grow((void **)&w->edges, &w->cap_edges, w->nedges + 2, sizeof *w->edges))
    return -1;
  wedge *e = &w->edges[i];
  wvert *v = &w->verts[w->nverts];
  edge_point(w, e, 0.5, v->uv, v->st);
  locate_st(w->surface, w->tris[e->tri].face, v->uv, v->st);
  v->face = w->tris[e->tri].face;
  v->label = 0;
  e->mid = w->nverts++;
  for (int j = 0; j < 2; j++) {
    wedge *h = &w->edges[w->nedges];
    memset(h, 0, sizeof *h);
    h->a = j ? e->b : e->a; /* below the new vertex: a < b holds */
    h->b = e->mid;
    h->tri = -1;
    h->ncross = -1;
    h->mid = -1;
    e->half[j] = w->nedges++;
  }
  return 0;
}

/* A corner of a child triangle: a corner of its parent (tag 0-2) or the
 * midpoint of the parent's edge k (tag 3 + k). */
typedef struct corner_ref {
  int v, tag;
  double uv[2], st[2];
} corner_ref;

static void set_tri(wtri *t, int face, const corner_ref *a, const corner_ref *b, const corner_ref *c) {
  const corner_ref *r[3] = {a, b, c};
  t->face = face;
  for (int i = 0; i < 3; i++) {
    t->v[i] = r[i]->v;
    memcpy(t->uv[i], r[i]->uv, sizeof t->uv[i]);
    memcpy(t->st[i], r[i]->st, sizeof t->st[i]);
  }
}

/* Which edges of t have a midpoint (bit k: edge k). */
static int split_mask(const work *w, int t) {
  int mask = 0;
  for (int k = 0; k < 3; k++)
    if (w->edges[w->tri_edge[3 * (size_t)t + k]].mid >= 0) mask |= 1 << k;
  return mask;
}

/* Splits every triangle with midpoints on its edges (red: 4 children,
 * green: 2 or 3), in parallel: the first child takes the parent's slot,
 * the others are appended, and the edges are updated in place (a split
 * edge gives way to its halves, each parent gets as many new inner edges
 * as it has split edges), so a round costs what it changes, not the size
 * of the mesh. The result does not depend on the thread count. fresh[t]
 * (resized with the triangles) tells the children from the untouched. */
static ch_status split_triangles(work *w, unsigned char **fresh, ch_error *err) {
  int n0 = w->ntris, e0 = w->nedges;
  int *first = malloc(((size_t)n0 + 1) * sizeof *first); /* per parent: its first appended child and inner edge */
  if (!first) return ch_error_set(err, CH_ERR_NOMEM, "out of memory refining the mesh");
  long added = 0;
  for (int t = 0; t < n0; t++) {
    first[t] = (int)added;
    int mask = split_mask(w, t);
    added += (mask & 1) + ((mask >> 1) & 1) + ((mask >> 2) & 1); /* children beyond the first; inner edges alike */
    if (n0 + added >= INT32_MAX / 3 || e0 + added >= INT32_MAX / 3) {
      free(first);
      return ch_error_set(err, CH_ERR_NOMEM, "refinement would make too many triangles");
    }
  }
  int n = n0 + (int)added, cap_edge_index = w->cap_tri_edge;
  unsigned char *fr = realloc(*fresh, (size_t)(n > 0 ? n : 1));
  if (fr) *fresh = fr;
  if (!fr || grow((void **)&w->tris, &w->cap_tris, n, sizeof *w->tris) ||
      grow((void **)&w->edges, &w->cap_edges, e0 + (int)added, sizeof *w->edges) ||
      grow((void **)&w->tri_edge, &cap_edge_index, 3 * n, sizeof *w->tri_edge)) {
    free(first);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory refining the mesh");
  }
  w->cap_tri_edge = cap_edge_index;
  memset(fr, 0, (size_t)n);
#pragma omp parallel for schedule(dynamic, 1024)
  for (int t = 0; t < n0; t++) {
    int mask = split_mask(w, t);
    if (!mask) continue;
    const wtri T = w->tris[t];
    int pe[3]; /* the parent's edges */
    memcpy(pe, &w->tri_edge[3 * (size_t)t], sizeof pe);
    corner_ref c[3], m[3];
    for (int k = 0; k < 3; k++) {
      c[k].v = T.v[k];
      c[k].tag = k;
      memcpy(c[k].uv, T.uv[k], sizeof c[k].uv);
      memcpy(c[k].st, T.st[k], sizeof c[k].st);
      const wedge *e = &w->edges[pe[k]];
      if (e->mid < 0) continue;
      m[k].v = e->mid;
      m[k].tag = 3 + k;
      lerp2(T.uv[k], T.uv[(k + 1) % 3], 0.5, m[k].uv);
      lerp2(T.st[k], T.st[(k + 1) % 3], 0.5, m[k].st);
    }
    int slot[4], f = T.face, cnt = (mask & 1) + ((mask >> 1) & 1) + ((mask >> 2) & 1);
    slot[0] = t;
    for (int i = 1; i <= cnt; i++) slot[i] = n0 + first[t] + i - 1;
    const corner_ref *kids[4][3];
    if (cnt == 3) {
      const corner_ref *r[4][3] = {{&c[0], &m[0], &m[2]}, {&m[0], &c[1], &m[1]}, {&m[2], &m[1], &c[2]},
                                   {&m[0], &m[1], &m[2]}};
      memcpy(kids, r, sizeof r);
    } else if (cnt == 1) {
      int k = mask == 1 ? 0 : mask == 2 ? 1 : 2;
      const corner_ref *a = &c[k], *b = &c[(k + 1) % 3], *o = &c[(k + 2) % 3];
      const corner_ref *r[2][3] = {{a, &m[k], o}, {&m[k], b, o}};
      memcpy(kids, r, sizeof r);
    } else {
      int k = (mask & 1) == 0 ? 1 : (mask & 2) == 0 ? 2 : 0; /* edges k, k+1 split; k+2 not */
      const corner_ref *a = &c[k], *b = &c[(k + 1) % 3], *o = &c[(k + 2) % 3];
      const corner_ref *m1 = &m[k], *m2 = &m[(k + 1) % 3];
      const corner_ref *r[3][3] = {{m1, b, m2}, {a, m1, m2}, {a, m2, o}};
      memcpy(kids, r, sizeof r);
    }
    /* Inner edges by their two tags, numbered as first met. */
    int inner_tags[3][2], ninner = 0;
    for (int i = 0; i <= cnt; i++) {
      set_tri(&w->tris[slot[i]], f, kids[i][0], kids[i][1], kids[i][2]);
      fr[slot[i]] = 1;
      for (int j = 0; j < 3; j++) {
        int p = kids[i][j]->tag, q = kids[i][(j + 1) % 3]->tag, edge;
        int corner = p < q ? p : q, k = (p < q ? q : p) - 3; /* when one is a corner, one a midpoint */
        if (p < 3 && q < 3) { /* an unsplit edge of the parent: corners p, q */
          edge = pe[(q == (p + 1) % 3) ? p : q];
        } else if (corner < 3 && k >= 0 && (corner == k || corner == (k + 1) % 3)) {
          /* a corner and the midpoint of an edge it ends: a half */
          const wedge *e = &w->edges[pe[k]];
          edge = e->half[T.v[corner] == e->a ? 0 : 1];
        } else { /* between the midpoints or a midpoint and the opposite corner */
          int lo = p < q ? p : q, hi = p < q ? q : p, x = 0;
          while (x < ninner && !(inner_tags[x][0] == lo && inner_tags[x][1] == hi)) x++;
          edge = e0 + first[t] + x;
          if (x == ninner) {
            inner_tags[ninner][0] = lo;
            inner_tags[ninner][1] = hi;
            ninner++;
            wedge *e = &w->edges[edge];
            memset(e, 0, sizeof *e);
            e->a = kids[i][j]->v < kids[i][(j + 1) % 3]->v ? kids[i][j]->v : kids[i][(j + 1) % 3]->v;
            e->b = kids[i][j]->v ^ kids[i][(j + 1) % 3]->v ^ e->a;
            e->tri = slot[i];
            e->k = j;
            e->ncross = -1;
            e->mid = -1;
          }
        }
        w->tri_edge[3 * (size_t)slot[i] + j] = edge;
      }
    }
    /* Edges whose canonical triangle was the parent now name the first
     * child holding them, halves of a split one likewise: one writer each
     * (the parent), atomic as the other triangle of an unsplit edge reads
     * it. */
    for (int k = 0; k < 3; k++) {
      wedge *e = &w->edges[pe[k]];
      int owner;
#pragma omp atomic read
      owner = e->tri;
      if (owner != t) continue;
      for (int h = 0; h < (e->mid < 0 ? 1 : 2); h++) {
        int target = e->mid < 0 ? pe[k] : e->half[h], done = 0;
        for (int i = 0; i <= cnt && !done; i++)
          for (int j = 0; j < 3 && !done; j++)
            if (w->tri_edge[3 * (size_t)slot[i] + j] == target) {
              wedge *x = &w->edges[target];
#pragma omp atomic write
              x->tri = slot[i];
              x->k = j;
              done = 1;
            }
      }
    }
  }
  /* The split edges are gone from the mesh. */
  for (int i = 0; i < e0; i++) {
    wedge *e = &w->edges[i];
    if (e->mid < 0 || !e->cross) continue;
    free(e->cross);
    e->cross = NULL;
    e->ncross = 0;
  }
  free(first);
  w->ntris = n;
  w->nedges = e0 + (int)added;
  return CH_OK;
}

/* ---- output ---------------------------------------------------------------- */
typedef struct out_mesh {
  double *pos;     /* filled after evaluation */
  int npos, cap_pos;
  int first_pos;   /* index of the first vertex held here (a part of the
                      cut numbers its own vertices after the shared ones) */
  /* what each output vertex is: face, st, h */
  int *face;
  double *st, *h;
  int *tri;        /* 3 per triangle */
  uint64_t *group; /* per triangle: piece label or WALL_GROUP */
  double *uv;      /* 6 per triangle: corner UVs */
  int ntri, cap_tri;
} out_mesh;

static int out_vertex(out_mesh *o, int face, const double st[2], double h) {
  int i = o->npos - o->first_pos;
  if (i + 1 > o->cap_pos) {
    int cap = o->cap_pos ? 2 * o->cap_pos : 4096;
    int *f = realloc(o->face, (size_t)cap * sizeof *f);
    if (f) o->face = f;
    double *s = realloc(o->st, (size_t)cap * 2 * sizeof *s);
    if (s) o->st = s;
    double *hh = realloc(o->h, (size_t)cap * sizeof *hh);
    if (hh) o->h = hh;
    if (!f || !s || !hh) return -1;
    o->cap_pos = cap;
  }
  o->face[i] = face;
  o->st[2 * (size_t)i] = st[0];
  o->st[2 * (size_t)i + 1] = st[1];
  o->h[i] = h;
  return o->npos++;
}

static int out_tri(out_mesh *o, int a, int b, int c, const double *ua, const double *ub, const double *uc,
                   uint64_t group) {
  if (a == b || b == c || c == a) return 0; /* collapsed: a wall of zero height */
  if (o->ntri + 1 > o->cap_tri) {
    int cap = o->cap_tri ? 2 * o->cap_tri : 4096;
    int *t = realloc(o->tri, (size_t)cap * 3 * sizeof *t);
    if (t) o->tri = t;
    uint64_t *g = realloc(o->group, (size_t)cap * sizeof *g);
    if (g) o->group = g;
    double *u = realloc(o->uv, (size_t)cap * 6 * sizeof *u);
    if (u) o->uv = u;
    if (!t || !g || !u) return -1;
    o->cap_tri = cap;
  }
  int *t = &o->tri[3 * (size_t)o->ntri];
  t[0] = a;
  t[1] = b;
  t[2] = c;
  double *u = &o->uv[6 * (size_t)o->ntri];
  memcpy(u, ua, 2 * sizeof *u);
  memcpy(u + 2, ub, 2 * sizeof *u);
  memcpy(u + 4, uc, 2 * sizeof *u);
  o->group[o->ntri++] = group;
  return 0;
}

static int out_quad(out_mesh *o, const int v[4], const double *uv[4], uint64_t group) {
  return out_tri(o, v[0], v[1], v[2], uv[0], uv[1], uv[2], group) |
         out_tri(o, v[0], v[2], v[3], uv[0], uv[2], uv[3], group);
}

static void out_free(out_mesh *o) {
  free(o->pos);
  free(o->face);
  free(o->st);
  free(o->h);
  free(o->tri);
  free(o->group);
  free(o->uv);
  memset(o, 0, sizeof *o);
}

/* ---- cutting a triangle ------------------------------------------------------
 * The boundary of a triangle as a cycle of nodes: its corners and, between
 * them, the crossings of its edges. Each crossing joins the piece before it
 * to the piece after it; inside the triangle it is one end of a chord to the
 * crossing with the same two pieces. */

typedef struct bnode {
  int corner;               /* vertex of a corner, -1 for a crossing */
  int edge;                 /* local edge holding a crossing */
  uint64_t lprev, lnext;    /* pieces before and after it (a corner: its own, twice) */
  int copy_prev, copy_next; /* output vertices in those pieces */
  double hprev, hnext;      /* h just inside each */
  double uv[2], st[2];
  int pair;                 /* the other end of its chord, -1 */
} bnode;

typedef enum cut_kind { CUT_NONE, CUT_REGIONS, CUT_COMPLEX } cut_kind;

/* The boundary's nodes into nodes[cap]; -1 if there are more (the
 * triangle is then refined, or fanned once refinement is over). */
static int gather_nodes_into(const work *w, int t, bnode *nodes, int cap) {
  const wtri *T = &w->tris[t];
  int m = 0;
  for (int k = 0; k < 3; k++) {
    const wvert *v = &w->verts[T->v[k]];
    const wedge *e = &w->edges[w->tri_edge[3 * (size_t)t + k]];
    /* room for the corner and its edge's crossings (2000 grooves through
     * one point overran the array by the corner written before a check
     * that counted only the crossings) */
    if (e->ncross < 0 || m + 1 + e->ncross > cap) return -1;
    bnode *c = &nodes[m++];
    c->corner = T->v[k];
    c->edge = -1;
    c->lprev = c->lnext = v->label;
    c->copy_prev = c->copy_next = T->v[k];
    c->hprev = c->hnext = v->h;
    memcpy(c->uv, T->uv[k], sizeof c->uv);
    memcpy(c->st, T->st[k], sizeof c->st);
    c->pair = -1;
    int forward = T->v[k] == e->a;
    for (int i = 0; i < e->ncross; i++) {
      const crossing *x = &e->cross[forward ? i : e->ncross - 1 - i];
      bnode *b = &nodes[m++];
      double f = forward ? x->x : 1.0 - x->x;
      b->corner = -1;
      b->edge = k;
      b->lprev = forward ? x->la : x->lb;
      b->lnext = forward ? x->lb : x->la;
      b->copy_prev = forward ? x->copy_a : x->copy_b;
      b->copy_next = forward ? x->copy_b : x->copy_a;
      b->hprev = forward ? x->ha : x->hb;
      b->hnext = forward ? x->hb : x->ha;
      lerp2(T->uv[k], T->uv[(k + 1) % 3], f, b->uv);
      lerp2(T->st[k], T->st[(k + 1) % 3], f, b->st);
      b->pair = -1;
    }
  }
  return m;
}

static int gather_nodes(const work *w, int t, bnode *nodes) { return gather_nodes_into(w, t, nodes, MAX_NODES); }

/* Pairs the crossings into chords: two crossings between the same two
 * pieces, in opposite directions. Crossings left unpaired must be where
 * pieces meet at one point inside (a junction: three or more of them, each
 * piece between two consecutive ones). CUT_REGIONS when that works out, no
 * two chords cross and no chord separates the junction's crossings;
 * CUT_COMPLEX otherwise (refined, or fanned if refinement is over). */
static cut_kind classify(bnode *nodes, int m) {
  int nc = 0;
  for (int i = 0; i < m; i++) nc += nodes[i].corner < 0;
  if (nc == 0) return CUT_NONE;
  int unpaired[MAX_NODES], nu = 0;
  for (int i = 0; i < m; i++) {
    if (nodes[i].corner >= 0 || nodes[i].pair >= 0) continue;
    int found = -1;
    for (int j = i + 1; j < m; j++) {
      if (nodes[j].corner >= 0 || nodes[j].lprev != nodes[i].lnext || nodes[j].lnext != nodes[i].lprev) continue;
      if (found >= 0 || nodes[j].pair >= 0) return CUT_COMPLEX; /* ambiguous */
      found = j;
    }
    if (found < 0) {
      unpaired[nu++] = i;
      continue;
    }
    nodes[i].pair = found;
    nodes[found].pair = i;
  }
  if (nu == 1 || nu == 2) return CUT_COMPLEX;
  for (int i = 0; i < nu; i++)
    if (nodes[unpaired[i]].lnext != nodes[unpaired[(i + 1) % nu]].lprev) return CUT_COMPLEX;
  for (int i = 0; i < m; i++) {
    int j = nodes[i].pair;
    if (j < i) continue;
    for (int k = i + 1; k < j; k++) {
      int l = nodes[k].pair;
      if (l >= 0 && (l < i || l > j)) return CUT_COMPLEX; /* chords cross */
    }
    int inside = 0;
    for (int u = 0; u < nu; u++) inside += unpaired[u] > i && unpaired[u] < j;
    if (inside != 0 && inside != nu) return CUT_COMPLEX;
  }
  return CUT_REGIONS;
}

static int node_copy(const bnode *n, uint64_t piece) {
  if (n->corner >= 0) return n->corner;
  return piece == n->lnext ? n->copy_next : n->copy_prev;
}

/* Emits the region bounded by nodes idx[0..len) (counter-clockwise, convex)
 * as a fan; its piece is the one after a node along the triangle's boundary. */
static int emit_region(const bnode *nodes, int m, const int *idx, int len, out_mesh *o) {
  uint64_t piece = nodes[idx[0]].lnext;
  for (int i = 0; i < len; i++)
    if ((idx[i] + 1) % m == idx[(i + 1) % len]) {
      piece = nodes[idx[i]].lnext;
      break;
    }
  int v0 = node_copy(&nodes[idx[0]], piece), bad = 0;
  for (int i = 1; i + 1 < len; i++)
    bad |= out_tri(o, v0, node_copy(&nodes[idx[i]], piece), node_copy(&nodes[idx[i + 1]], piece),
                   nodes[idx[0]].uv, nodes[idx[i]].uv, nodes[idx[i + 1]].uv, piece);
  return bad;
}

typedef struct cut_context {
  const ch_surface *surface;
  const labeler *lb;
  const wtri *T;
  double tol;
  out_mesh *o;
  ch_embed_stats *stats;
} cut_context;

/* Where the pieces meet: each spoke's boundary is the line through its
 * crossing and a second boundary point, found by bisection between points
 * inside the two pieces it separates; the junction is the least-squares
 * meeting point of those lines (exact where they are straight), or the
 * centroid of the crossings when that fails or falls outside the triangle.
 * (s,t) follow from the triangle's corners. */
static void junction_point(const cut_context *cx, const bnode *nodes, const int *idx, int len, const int *pos,
                           int n, double juv[2], double jst[2]) {
  const wtri *T = cx->T;
  double c[2] = {0, 0};
  for (int k = 0; k < n; k++)
    for (int i = 0; i < 2; i++) c[i] += nodes[idx[pos[k]]].uv[i] / n;
  double inner[MAX_NODES][2];
  uint64_t piece[MAX_NODES];
  for (int k = 0; k < n; k++) {
    const bnode *a = &nodes[idx[pos[k]]], *b = &nodes[idx[(pos[k] + 1) % len]];
    piece[k] = a->lnext;
    for (int i = 0; i < 2; i++) inner[k][i] = (c[i] + a->uv[i] + b->uv[i]) / 3.0;
  }
  double A[3] = {0, 0, 0}, r[2] = {0, 0}; /* normal equations: sum n n^T J = sum n n^T X */
  int lines = 0;
  for (int k = 0; k < n; k++) {
    int km = (k + n - 1) % n;
    if (label_at(cx->lb, inner[km]) != piece[km] || label_at(cx->lb, inner[k]) != piece[k]) continue;
    double lo = 0.0, hi = 1.0, q[2];
    for (int it = 0; it < BISECTIONS; it++) {
      double mid = 0.5 * (lo + hi);
      lerp2(inner[km], inner[k], mid, q);
      if (label_at(cx->lb, q) == piece[km])
        lo = mid;
      else
        hi = mid;
    }
    lerp2(inner[km], inner[k], 0.5 * (lo + hi), q);
    const double *x = nodes[idx[pos[k]]].uv;
    double d[2] = {q[0] - x[0], q[1] - x[1]}, len_d = hypot(d[0], d[1]);
    if (!(len_d > 1e-15)) continue;
    double nx = -d[1] / len_d, ny = d[0] / len_d, dot = nx * x[0] + ny * x[1];
    A[0] += nx * nx;
    A[1] += nx * ny;
    A[2] += ny * ny;
    r[0] += nx * dot;
    r[1] += ny * dot;
    lines++;
  }
  double det = A[0] * A[2] - A[1] * A[1];
  juv[0] = c[0];
  juv[1] = c[1];
  if (lines >= 2 && fabs(det) > 1e-6 * (A[0] + A[2]) * (A[0] + A[2])) {
    double j[2] = {(A[2] * r[0] - A[1] * r[1]) / det, (A[0] * r[1] - A[1] * r[0]) / det};
    /* Inside the triangle (barycentric coordinates in UV)? */
    double e1[2] = {T->uv[1][0] - T->uv[0][0], T->uv[1][1] - T->uv[0][1]};
    double e2[2] = {T->uv[2][0] - T->uv[0][0], T->uv[2][1] - T->uv[0][1]};
    double area = e1[0] * e2[1] - e1[1] * e2[0];
    double p[2] = {j[0] - T->uv[0][0], j[1] - T->uv[0][1]};
    double b1 = (p[0] * e2[1] - p[1] * e2[0]) / area, b2 = (e1[0] * p[1] - e1[1] * p[0]) / area;
    if (b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0) {
      juv[0] = j[0];
      juv[1] = j[1];
    }
  }
  /* (s,t) by the barycentric coordinates of juv. */
  double e1[2] = {T->uv[1][0] - T->uv[0][0], T->uv[1][1] - T->uv[0][1]};
  double e2[2] = {T->uv[2][0] - T->uv[0][0], T->uv[2][1] - T->uv[0][1]};
  double area = e1[0] * e2[1] - e1[1] * e2[0];
  double p[2] = {juv[0] - T->uv[0][0], juv[1] - T->uv[0][1]};
  double b1 = area != 0.0 ? (p[0] * e2[1] - p[1] * e2[0]) / area : 1.0 / 3.0;
  double b2 = area != 0.0 ? (e1[0] * p[1] - e1[1] * p[0]) / area : 1.0 / 3.0;
  for (int i = 0; i < 2; i++) jst[i] = T->st[0][i] + b1 * (T->st[1][i] - T->st[0][i]) + b2 * (T->st[2][i] - T->st[0][i]);
}

/* A region where n >= 3 pieces meet at one point: a junction vertex per
 * piece at the centroid of the n unpaired crossings (h read just inside the
 * piece, found by bisection from the centroid), a fan per piece from it,
 * walls along the spokes where h jumps and a cap where the walls meet. */
static int emit_junction(const cut_context *cx, const bnode *nodes, const int *idx, int len) {
  int pos[MAX_NODES], n = 0;
  for (int i = 0; i < len; i++)
    if (nodes[idx[i]].corner < 0 && nodes[idx[i]].pair < 0) pos[n++] = i;
  double jst[2], juv[2];
  junction_point(cx, nodes, idx, len, pos, n, juv, jst);
  locate_st(cx->surface, cx->T->face, juv, jst);
  /* The junction's copy for piece k: pieces on the two sides of a spoke
   * share it where the spoke's crossing has one copy (no wall there). */
  int j[MAX_NODES], group[MAX_NODES];
  double hj[MAX_NODES];
  for (int k = 0; k < n; k++) {
    const bnode *a = &nodes[idx[pos[k]]], *b = &nodes[idx[(pos[k] + 1) % len]];
    uint64_t piece = a->lnext;
    double target[2] = {(juv[0] + a->uv[0] + b->uv[0]) / 3.0, (juv[1] + a->uv[1] + b->uv[1]) / 3.0};
    double lo = 0.0, hi = 1.0, q[2];
    for (int it = 0; it < JUNCTION_BISECTIONS; it++) {
      double mid = 0.5 * (lo + hi);
      lerp2(juv, target, mid, q);
      if (label_at(cx->lb, q) == piece)
        hi = mid;
      else
        lo = mid;
    }
    lerp2(juv, target, hi, q);
    hj[k] = piece_height(cx->lb, piece, q, juv);
  }
  /* Groups: runs of pieces joined across wall-free spokes (spoke k lies
   * between pieces k-1 and k). */
  int start = -1;
  for (int k = 0; k < n; k++)
    if (nodes[idx[pos[k]]].copy_prev != nodes[idx[pos[k]]].copy_next) start = k;
  for (int s = 0, g = -1; s < n; s++) {
    int k = start < 0 ? s : (start + s) % n;
    const bnode *x = &nodes[idx[pos[k]]];
    if (g < 0 || x->copy_prev != x->copy_next) g = k;
    group[k] = g;
  }
  for (int k = 0; k < n; k++) {
    if (group[k] != k) continue;
    double sum = 0.0;
    int count = 0;
    for (int i = 0; i < n; i++)
      if (group[i] == k) {
        sum += hj[i];
        count++;
      }
    if ((j[k] = out_vertex(cx->o, cx->T->face, jst, sum / count)) < 0) return -1;
  }
  for (int k = 0; k < n; k++) j[k] = j[group[k]];
  cx->stats->junctions++;
  int bad = 0;
  for (int k = 0; k < n; k++) {
    uint64_t piece = nodes[idx[pos[k]]].lnext;
    int end = pos[(k + 1) % n];
    for (int i = pos[k]; i != end; i = (i + 1) % len) {
      const bnode *a = &nodes[idx[i]], *b = &nodes[idx[(i + 1) % len]];
      bad |= out_tri(cx->o, j[k], node_copy(a, piece), node_copy(b, piece), juv, a->uv, b->uv, piece);
    }
  }
  int before = cx->o->ntri;
  for (int k = 0; k < n; k++) {
    const bnode *x = &nodes[idx[pos[k]]];
    int v[4] = {x->copy_next, j[k], j[(k + n - 1) % n], x->copy_prev};
    const double *uv[4] = {x->uv, juv, juv, x->uv};
    bad |= out_quad(cx->o, v, uv, WALL_GROUP);
  }
  for (int k = 1; k + 1 < n; k++) bad |= out_tri(cx->o, j[0], j[k], j[k + 1], juv, juv, juv, WALL_GROUP);
  cx->stats->wall_triangles += cx->o->ntri - before;
  return bad;
}

/* Splits the cycle idx by its first unused chord, recursively; a region
 * left without chords is a plain piece or holds the junction. */
static int split_regions(const cut_context *cx, const bnode *nodes, int m, unsigned char *used, const int *idx,
                         int len) {
  for (int a = 0; a < len; a++) {
    int p = idx[a], q = nodes[p].pair;
    if (q < 0 || used[p]) continue;
    int b = -1;
    for (int i = 0; i < len; i++)
      if (idx[i] == q) b = i;
    if (b < 0) continue;
    used[p] = used[q] = 1;
    if (b < a) {
      int tmp = a;
      a = b;
      b = tmp;
    }
    int one[MAX_NODES], two[MAX_NODES], n1 = 0, n2 = 0;
    for (int i = a; i <= b; i++) one[n1++] = idx[i];
    for (int i = b; i < len; i++) two[n2++] = idx[i];
    for (int i = 0; i <= a; i++) two[n2++] = idx[i];
    return split_regions(cx, nodes, m, used, one, n1) | split_regions(cx, nodes, m, used, two, n2);
  }
  for (int i = 0; i < len; i++)
    if (nodes[idx[i]].corner < 0 && nodes[idx[i]].pair < 0) return emit_junction(cx, nodes, idx, len);
  return emit_region(nodes, m, idx, len, cx->o);
}

/* Walls along the chords, between the copies on their two sides. */
static int emit_walls(const bnode *nodes, int m, out_mesh *o, ch_embed_stats *stats) {
  int bad = 0, before = o->ntri;
  for (int p = 0; p < m; p++) {
    int q = nodes[p].pair;
    if (q < p) continue;
    uint64_t r1 = nodes[p].lnext, r2 = nodes[p].lprev;
    int v[4] = {node_copy(&nodes[p], r1), node_copy(&nodes[q], r1), node_copy(&nodes[q], r2),
                node_copy(&nodes[p], r2)};
    const double *uv[4] = {nodes[p].uv, nodes[q].uv, nodes[q].uv, nodes[p].uv};
    bad |= out_quad(o, v, uv, WALL_GROUP);
  }
  stats->wall_triangles += o->ntri - before;
  return bad;
}

/* Counts an unresolved triangle of centre uv: the first one's place and
 * the box of all. */
static void note_unresolved(ch_embed_stats *stats, const double uv[2]) {
  if (stats->unresolved++ == 0) {
    stats->unresolved_uv[0] = uv[0], stats->unresolved_uv[1] = uv[1];
    stats->unresolved_box[0] = stats->unresolved_box[2] = uv[0];
    stats->unresolved_box[1] = stats->unresolved_box[3] = uv[1];
    return;
  }
  stats->unresolved_box[0] = fmin(stats->unresolved_box[0], uv[0]);
  stats->unresolved_box[1] = fmin(stats->unresolved_box[1], uv[1]);
  stats->unresolved_box[2] = fmax(stats->unresolved_box[2], uv[0]);
  stats->unresolved_box[3] = fmax(stats->unresolved_box[3], uv[1]);
}

static int fan_triangle(const labeler *lb, const work *w, const wtri *T, const bnode *nodes, int m, out_mesh *o);

/* Cuts triangle t into its pieces, with walls where h jumps. */
static int cut_triangle(const labeler *lb, const work *w, int t, double tol, out_mesh *o, ch_embed_stats *stats) {
  const wtri *T = &w->tris[t];
  bnode nodes[MAX_NODES];
  int m = gather_nodes(w, t, nodes);
  cut_kind kind = m < 0 ? CUT_COMPLEX : classify(nodes, m);
  if (kind == CUT_NONE)
    return out_tri(o, T->v[0], T->v[1], T->v[2], T->uv[0], T->uv[1], T->uv[2], w->verts[T->v[0]].label);
  if (kind == CUT_REGIONS) {
    int idx[MAX_NODES] = {0};
    unsigned char used[MAX_NODES] = {0};
    for (int i = 0; i < m; i++) idx[i] = i;
    cut_context cx = {w->surface, lb, T, tol, o, stats};
    return split_regions(&cx, nodes, m, used, idx, m) | emit_walls(nodes, m, o, stats);
  }
  /* Left after refinement: a fan from a vertex at the centre over the
   * whole boundary, in the centre's piece: closed, but not following the
   * features inside (counted, and where, for the warning). */
  {
    double cuv[2] = {0, 0};
    for (int k = 0; k < 3; k++)
      for (int i = 0; i < 2; i++) cuv[i] += T->uv[k][i] / 3.0;
    note_unresolved(stats, cuv);
  }
  bnode *all = nodes;
  if (m < 0) { /* more nodes than a cut takes: all of them for the fan, so its neighbours' crossings meet it */
    int total = 3;
    for (int k = 0; k < 3; k++) total += w->edges[w->tri_edge[3 * (size_t)t + k]].ncross;
    if (!(all = malloc((size_t)total * sizeof *all))) return -1;
    m = gather_nodes_into(w, t, all, total);
  }
  int bad = fan_triangle(lb, w, T, all, m, o);
  if (all != nodes) free(all);
  return bad;
}

/* The fan of cut_triangle's last resort over nodes[m]. */
static int fan_triangle(const labeler *lb, const work *w, const wtri *T, const bnode *nodes, int m, out_mesh *o) {
  double cst[2] = {0, 0}, cuv[2] = {0, 0};
  for (int k = 0; k < 3; k++)
    for (int i = 0; i < 2; i++) {
      cst[i] += T->st[k][i] / 3.0;
      cuv[i] += T->uv[k][i] / 3.0;
    }
  uint64_t piece = label_at(lb, cuv);
  locate_st(w->surface, T->face, cuv, cst);
  int c = out_vertex(o, T->face, cst, ch_height_eval(lb->height, cuv[0], cuv[1]));
  if (c < 0) return -1;
  /* Around the boundary, a crossing on a wall contributes both copies,
   * so the fan stays closed (a sliver from the centre spans the wall). */
  int bad = 0;
  for (int i = 0; i < m; i++) {
    const bnode *a = &nodes[i], *b = &nodes[(i + 1) % m];
    if (a->corner < 0 && a->copy_prev != a->copy_next)
      bad |= out_tri(o, c, a->copy_prev, a->copy_next, cuv, a->uv, a->uv, piece);
    bad |= out_tri(o, c, a->corner >= 0 ? a->corner : a->copy_next, b->corner >= 0 ? b->corner : b->copy_prev, cuv,
                   a->uv, b->uv, piece);
  }
  return bad;
}

/* Whether a triangle of centre c and longest edge `longest` overlaps the
 * rounded cap of a groove's open end and is too coarse for it: there the
 * profile is swept around the end point, a cone (or dome) whose facets must
 * span at most cap_angle around it, so edges up to cap_angle * w / 2. */
/* How much finer than the mean the warped mesh is at uv (relative to the
 * grooves' mean density, within [1/8, 4]); 1 without a warp. */
static double local_factor(const labeler *lb, const double uv[2]) {
  if (!lb->warp) return 1.0;
  double d = mesh_density(lb->warp, uv);
  return fmin(4.0, fmax(0.125, lb->mean_density / d));
}

/* The factor of a groove's chord tolerance at uv. Where the warped mesh is
 * coarser than the grooves' mean (away from the view) a chord's sagitta
 * grows as the square of its length, so the tolerance does too, or the
 * chords would refine the coarse parts back towards the mean; where it is
 * finer, linear (see labeler_init). */
static double chord_factor(const labeler *lb, const double uv[2]) {
  double lf = local_factor(lb, uv);
  return lf > 1.0 ? lf * lf : lf;
}

static int coarse_at_cap(const labeler *lb, const double c[2], double longest) {
  /* The open ends near c (bucketed once: 2000 lines through a point put
   * all of theirs in every cell there), counted only if the grooves' grid
   * lists their segment at c, as the scan of its cell did. A u cap is
   * already cut into rings by its lines; refining under all of them costs
   * more than it gains (capped_end leaves them out). */
  int res = lb->end_res, r[4];
  double reach = lb->end_reach + longest;
  r[0] = corner_cell(res, c[0] - reach), r[1] = corner_cell(res, c[1] - reach);
  r[2] = corner_cell(res, c[0] + reach), r[3] = corner_cell(res, c[1] + reach);
  for (int y = r[1]; y <= r[3]; y++)
    for (int x = r[0]; x <= r[2]; x++)
      for (int k = lb->end_start[y * res + x]; k < lb->end_start[y * res + x + 1]; k++) {
        int s = lb->end_item[k] / 2, end = lb->end_item[k] % 2;
        const ch_segment *sg = &lb->set->segments[s];
        double half = 0.5 * lb->set->curves[sg->curve].width;
        const double *q = sg->p[end == 0 ? 0 : 2];
        if (longest > lb->cap_angle * local_factor(lb, q) * half && hypot(c[0] - q[0], c[1] - q[1]) <= half + longest &&
            ch_grid_cell_holds(&lb->groove_grid, lb->height->grooves.boxes[s], c[0], c[1]))
          return 1;
      }
  return 0;
}

/* Whether a sharp corner of a step curve (a joint turning by more than 30
 * degrees, as at a polygon's vertices) lies in the triangle of corners uv
 * and longest edge `longest` above the junction size there: such a corner
 * can poke into a triangle through one edge, crossing it twice between two
 * of its samples, and be missed whole (relief's roof: a region of the
 * wrong height one triangle wide). */
static int coarse_at_step_corner(const labeler *lb, const double uv[3][2], const double c[2], double longest) {
  if (!lb->has_steps) return 0;
  /* The corners in the triangle's box (bucketed once: a scan of the step
   * curves near it took a fifth of 1000 small loops' run), counted only if
   * the step grid's cell at c lists their segment, as the scan of that
   * cell did. */
  int res = lb->corner_res, r[4];
  double lo[2] = {fmin(uv[0][0], fmin(uv[1][0], uv[2][0])), fmin(uv[0][1], fmin(uv[1][1], uv[2][1]))};
  double hi[2] = {fmax(uv[0][0], fmax(uv[1][0], uv[2][0])), fmax(uv[0][1], fmax(uv[1][1], uv[2][1]))};
  r[0] = corner_cell(res, lo[0]), r[1] = corner_cell(res, lo[1]), r[2] = corner_cell(res, hi[0]);
  r[3] = corner_cell(res, hi[1]);
  for (int y = r[1]; y <= r[3]; y++)
    for (int x = r[0]; x <= r[2]; x++)
      for (int k = lb->corner_start[y * res + x]; k < lb->corner_start[y * res + x + 1]; k++) {
        int s = lb->corner_seg[k];
        const double *q = lb->set->segments[s].p[0];
        double d0 = (uv[1][0] - uv[0][0]) * (q[1] - uv[0][1]) - (uv[1][1] - uv[0][1]) * (q[0] - uv[0][0]);
        double d1 = (uv[2][0] - uv[1][0]) * (q[1] - uv[1][1]) - (uv[2][1] - uv[1][1]) * (q[0] - uv[1][0]);
        double d2 = (uv[0][0] - uv[2][0]) * (q[1] - uv[2][1]) - (uv[0][1] - uv[2][1]) * (q[0] - uv[2][0]);
        if (!((d0 >= 0.0 && d1 >= 0.0 && d2 >= 0.0) || (d0 <= 0.0 && d1 <= 0.0 && d2 <= 0.0))) continue;
        if (!ch_grid_cell_holds(&lb->step_grid, lb->step_boxes[s], c[0], c[1])) continue;
        if (longest <= lb->junction_size * local_factor(lb, q)) continue;
        return 1;
      }
  return 0;
}

/* Whether triangle t needs splitting: its crossings do not make chords and
 * one junction, or a piece that none of its boundary touches hides inside,
 * or it is coarse over a rounded cap. */
static int needs_refinement(const labeler *lb, const work *w, int t, int only_uncut, int round) {
  const wtri *T = &w->tris[t];
  if (quiet(lb, T->uv[0]) && quiet(lb, T->uv[1]) && quiet(lb, T->uv[2])) return 0;
  double longest = 0.0;
  for (int k = 0; k < 3; k++)
    longest = fmax(longest, hypot(T->uv[(k + 1) % 3][0] - T->uv[k][0], T->uv[(k + 1) % 3][1] - T->uv[k][1]));
  const double centre[2] = {(T->uv[0][0] + T->uv[1][0] + T->uv[2][0]) / 3.0,
                            (T->uv[0][1] + T->uv[1][1] + T->uv[2][1]) / 3.0};
  /* (the extra rounds of a warped mesh, only_uncut: what cannot be cut yet, nothing else) */
  if (!only_uncut && lb->cap_angle > 0.0 && coarse_at_cap(lb, centre, longest)) return 1;
  if (!only_uncut && coarse_at_step_corner(lb, T->uv, centre, longest)) return 1;
  bnode nodes[MAX_NODES];
  int m = gather_nodes(w, t, nodes);
  if (m < 0) return round < DENSE_ROUNDS;
  if (classify(nodes, m) == CUT_COMPLEX) return 1;
  if (only_uncut) return 0;
  /* Junctions are placed by estimate: keep their triangles small. */
  for (int i = 0; i < m; i++)
    if (nodes[i].corner < 0 && nodes[i].pair < 0) return longest > lb->junction_size * local_factor(lb, nodes[i].uv);
  /* A groove's lines curve away from the chords that follow them (by
   * len^2 / 8r): where h at a chord's middle leaves the mesh's h there
   * (the mean of its ends) by more than the groove's tolerance, the chords
   * are too long for the curve (tight circles, the curls of a scroll).
   * Walls are not measured so: h jumps across them. */
  for (int i = 0; i < m; i++) {
    const bnode *p = &nodes[i];
    if (p->corner >= 0 || p->pair <= i) continue;
    const bnode *q = &nodes[p->pair];
    if (!(fabs(p->hprev - p->hnext) <= lb->wall_tol && fabs(q->hprev - q->hnext) <= lb->wall_tol)) continue;
    uint64_t g = (p->lprev >> 32) ? p->lprev >> 32 : p->lnext >> 32;
    if (!g) continue; /* between step pieces: h is smooth across */
    int c = GROOVE_CURVE(g);
    const ch_curve *cv = &lb->set->curves[c];
    double mid[2] = {0.5 * (p->uv[0] + q->uv[0]), 0.5 * (p->uv[1] + q->uv[1])}, err;
    if (cv->profile.kind == CH_PROFILE_U) {
      /* A u profile is vertical at its rims, where the least sagitta
       * would count as a large error of h over a sliver of no area: there
       * the chords keep within the tolerance (in units of the width) of
       * the curved line they follow, measured by t at the chord's middle
       * against t at its ends. */
      double tp = groove_distance(lb, c, p->uv) / cv->width, tq = groove_distance(lb, c, q->uv) / cv->width;
      double tm = groove_distance(lb, c, mid) / cv->width;
      err = fabs(tm - 0.5 * (tp + tq)) * fabs(cv->depth);
    } else {
      double mesh_h = 0.25 * (p->hprev + p->hnext + q->hprev + q->hnext);
      err = fabs(ch_height_eval(lb->height, mid[0], mid[1]) - mesh_h);
    }
    if (err > lb->chord_tol[c] * chord_factor(lb, mid)) return 1;
  }
  uint64_t l = label_at(lb, centre);
  for (int i = 0; i < m; i++)
    if (nodes[i].lprev == l || nodes[i].lnext == l) return 0;
  return 1;
}

static ch_status evaluate_positions(const ch_surface *surface, out_mesh *o, ch_error *err) {
  o->pos = malloc(3 * (size_t)(o->npos > 0 ? o->npos : 1) * sizeof *o->pos);
  if (!o->pos) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for %d vertices", o->npos);
  int failed = 0;
#pragma omp parallel for schedule(dynamic, 1024) reduction(| : failed)
  for (int i = 0; i < o->npos; i++) {
    ch_surface_point sp;
    if (ch_surface_eval(surface, o->face[i], o->st[2 * (size_t)i], o->st[2 * (size_t)i + 1], &sp)) {
      failed = 1;
      continue;
    }
    for (int k = 0; k < 3; k++) o->pos[3 * (size_t)i + k] = sp.position[k] + o->h[i] * sp.normal[k];
  }
  if (failed) return ch_error_set(err, CH_ERR_INTERNAL, "feature embedding: a vertex left its base face");
  return CH_OK;
}

/* Per-corner normals: the area-weighted mean of the face normals around a
 * vertex among the triangles of the same group (piece, or wall), so they
 * are smooth inside a piece and split at its boundary. */
static ch_status build_mesh(const out_mesh *o, ch_mesh *m, ch_error *err) {
  memset(m, 0, sizeof *m);
  size_t nc = 3 * (size_t)o->ntri;
  m->num_positions = o->npos;
  m->positions = o->pos;
  m->num_faces = o->ntri;
  m->num_corners = (int)nc;
  m->face_start = malloc(((size_t)o->ntri + 1) * sizeof *m->face_start);
  m->corner_position = malloc(nc * sizeof *m->corner_position);
  m->corner_uv = malloc(nc * sizeof *m->corner_uv);
  m->corner_normal = malloc(nc * sizeof *m->corner_normal);
  m->uvs = malloc(2 * nc * sizeof *m->uvs);
  m->normals = malloc(3 * nc * sizeof *m->normals);
  int *first_uv = malloc((size_t)(o->npos > 0 ? o->npos : 1) * sizeof *first_uv);
  int *head = malloc((size_t)(o->npos > 0 ? o->npos : 1) * sizeof *head);
  int *next = malloc(nc * sizeof *next);
  uint64_t *slot_group = malloc(nc * sizeof *slot_group);
  if (!m->face_start || !m->corner_position || !m->corner_uv || !m->corner_normal || !m->uvs || !m->normals ||
      !first_uv || !head || !next || !slot_group) {
    free(first_uv);
    free(head);
    free(next);
    free(slot_group);
    m->positions = NULL;
    ch_mesh_free(m);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the output mesh");
  }
  for (int i = 0; i < o->npos; i++) first_uv[i] = head[i] = -1;
  int nuv = 0, nslot = 0;
  for (int t = 0; t < o->ntri; t++) {
    m->face_start[t] = 3 * t;
    const int *v = &o->tri[3 * (size_t)t];
    const double *p0 = &o->pos[3 * (size_t)v[0]], *p1 = &o->pos[3 * (size_t)v[1]], *p2 = &o->pos[3 * (size_t)v[2]];
    double e1[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
    double e2[3] = {p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]};
    double fn[3];
    ch_cross3(e1, e2, fn);
    /* Weighted by the corner's angle (Thurmer and Wuthrich), not by area:
     * a vertex between slices of unequal width gets the mean of its two
     * sides, not the wider one's normal. */
    double fl = sqrt(ch_dot3(fn, fn)), corner_angle[3] = {0, 0, 0};
    if (fl > 0.0) {
      const double *q[3] = {p0, p1, p2};
      for (int k = 0; k < 3; k++) {
        const double *a = q[k], *b = q[(k + 1) % 3], *c = q[(k + 2) % 3];
        double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]}, x[3];
        ch_cross3(u, v, x);
        corner_angle[k] = atan2(sqrt(ch_dot3(x, x)), ch_dot3(u, v)) / fl;
      }
    }
    for (int k = 0; k < 3; k++) {
      size_t c = 3 * (size_t)t + k;
      int p = v[k];
      m->corner_position[c] = p;
      const double *uv = &o->uv[6 * (size_t)t + 2 * k];
      int u = first_uv[p];
      if (u < 0 || m->uvs[2 * (size_t)u] != uv[0] || m->uvs[2 * (size_t)u + 1] != uv[1]) {
        u = nuv++;
        m->uvs[2 * (size_t)u] = uv[0];
        m->uvs[2 * (size_t)u + 1] = uv[1];
        if (first_uv[p] < 0) first_uv[p] = u;
      }
      m->corner_uv[c] = u;
      int s = head[p];
      while (s >= 0 && slot_group[s] != o->group[t]) s = next[s];
      if (s < 0) {
        s = nslot++;
        slot_group[s] = o->group[t];
        next[s] = head[p];
        head[p] = s;
        memset(&m->normals[3 * (size_t)s], 0, 3 * sizeof(double));
      }
      for (int i = 0; i < 3; i++) m->normals[3 * (size_t)s + i] += fn[i] * corner_angle[k];
      m->corner_normal[c] = s;
    }
  }
  m->face_start[o->ntri] = (int)nc;
  m->num_uvs = nuv;
  m->num_normals = nslot;
  for (int s = 0; s < nslot; s++) {
    double *n = &m->normals[3 * (size_t)s];
    double len = sqrt(ch_dot3(n, n));
    if (len > 0.0) {
      for (int i = 0; i < 3; i++) n[i] /= len;
    } else {
      n[0] = n[1] = 0.0;
      n[2] = 1.0; /* only zero-area triangles here: any unit vector */
    }
  }
  free(first_uv);
  free(head);
  free(next);
  free(slot_group);
  return CH_OK;
}

/* ---- thinning the grooves' layers ---------------------------------------- */
/* The longest edge a thinning may make around uv, on a coarse grid: half
 * the mean longest edge of the tessellation's triangles centred in the
 * cell or its neighbours (before any refinement), about the spacing of
 * the points where its edges cross a line. So thinning undoes what the
 * refinement spent along the grooves beyond the tessellation's own
 * density (isotropic halvings for the lines' chords, junctions and caps),
 * the base surface is followed along them as finely as elsewhere, and a
 * dense tessellation is left nearly as it is (at 2.1M triangles longer
 * edges took a third more time for little). */
enum { EDGE_GRID = 64 };

typedef struct thin_context {
  const labeler *lb;
  const out_mesh *o;
  float edge_grid[EDGE_GRID * EDGE_GRID];
  double (*gradient)[3]; /* per output vertex: its distance's gradient, and t */
  unsigned char *known;  /* once computed: 1, or 2 where it has none (a rim) */
  double *distance;      /* per output vertex: its signed distance to distance_curve's */
  int *distance_curve;   /* -1 until computed */
} thin_context;

/* Groove c's signed distance at output vertex v (at uv), cached. */
static double vertex_distance(thin_context *x, int c, int v, const double uv[2]) {
  if (x->distance_curve[v] != c) {
    x->distance[v] = groove_distance(x->lb, c, uv);
    x->distance_curve[v] = c;
  }
  return x->distance[v];
}

static int edge_grid_build(thin_context *x, const ch_tess_result *tess, double fallback) {
  double *sum = calloc(2 * EDGE_GRID * EDGE_GRID, sizeof *sum); /* longest edges, triangles */
  if (!sum) return -1;
  const ch_mesh *m = &tess->mesh;
  for (int t = 0; t < m->num_faces; t++) {
    const double *q[3];
    for (int k = 0; k < 3; k++) q[k] = &m->uvs[2 * (size_t)m->corner_uv[3 * (size_t)t + k]];
    double cx = (q[0][0] + q[1][0] + q[2][0]) / 3.0, cy = (q[0][1] + q[1][1] + q[2][1]) / 3.0;
    if (!(cx >= 0.0 && cx < 1.0 && cy >= 0.0 && cy < 1.0)) continue;
    double longest = 0.0;
    for (int k = 0; k < 3; k++) longest = fmax(longest, hypot(q[(k + 1) % 3][0] - q[k][0], q[(k + 1) % 3][1] - q[k][1]));
    int cell = (int)(cy * EDGE_GRID) * EDGE_GRID + (int)(cx * EDGE_GRID);
    sum[2 * cell] += longest;
    sum[2 * cell + 1] += 1.0;
  }
  for (int y = 0; y < EDGE_GRID; y++)
    for (int x0 = 0; x0 < EDGE_GRID; x0++) {
      double l = 0.0, n = 0.0;
      for (int dy = -1; dy <= 1; dy++)
        for (int dx = -1; dx <= 1; dx++) {
          int yy = y + dy, xx = x0 + dx;
          if (yy < 0 || yy >= EDGE_GRID || xx < 0 || xx >= EDGE_GRID) continue;
          l += sum[2 * (yy * EDGE_GRID + xx)];
          n += sum[2 * (yy * EDGE_GRID + xx) + 1];
        }
      x->edge_grid[y * EDGE_GRID + x0] = (float)(0.5 * (n > 0.0 ? l / n : fallback));
    }
  free(sum);
  return 0;
}

static int thin_band(void *ctx, uint64_t group, int *layer) {
  (void)ctx;
  uint64_t g = group >> 32;
  if (group == WALL_GROUP || !g || (group & UINT64_C(0xffffffff))) return -1; /* not a groove's alone */
  *layer = (int)(g & 0xff);
  return GROOVE_CURVE(g) * LEVELS + GROOVE_LEVEL(g);
}

static double thin_max_edge(void *ctx, const double uv[2]) {
  const thin_context *x = ctx;
  int gx = (int)fmin(EDGE_GRID - 1, fmax(0.0, uv[0] * EDGE_GRID)), gy = (int)fmin(EDGE_GRID - 1, fmax(0.0, uv[1] * EDGE_GRID));
  return x->edge_grid[gy * EDGE_GRID + gx];
}

/* The refinement's chord rule (needs_refinement) for any new edge. */
static int thin_edge_ok(void *ctx, int family, int va, int vb, const double a[2], const double b[2]) {
  thin_context *x = ctx;
  const labeler *lb = x->lb;
  double mid[2] = {0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])};
  int c = family / LEVELS;
  const ch_curve *cv = &lb->set->curves[c];
  double err;
  if (cv->profile.kind == CH_PROFILE_U) { /* in t, as the rims' slivers have no area (needs_refinement) */
    double da = vertex_distance(x, c, va, a), db = vertex_distance(x, c, vb, b), dm = groove_distance(lb, c, mid);
    err = fabs(dm - 0.5 * (da + db)) / cv->width * fabs(cv->depth);
  } else {
    err = fabs(ch_height_eval(lb->height, mid[0], mid[1]) -
               0.5 * (ch_height_eval(lb->height, a[0], a[1]) + ch_height_eval(lb->height, b[0], b[1])));
  }
  return err <= lb->chord_tol[c] * chord_factor(lb, mid);
}

/* The exact normal of groove c's h at output vertex v in layer k (its
 * profile segment), in the frame (UV times the object scale, h): the signed
 * distance's gradient (away from the closest point, cached per vertex)
 * times the profile's slope there, or, on a profile made of straight
 * pieces, the slope of layer k (a vertex on a crease has one per side).
 * 0 at a rim or beyond (the slope is unbounded or h is another's). */
static int exact_normal(thin_context *x, int c, int k, int v, const double uv[2], double n[3]) {
  const labeler *lb = x->lb;
  const ch_curve *cv = &lb->set->curves[c];
  if (!x->known[v]) {
    int seg = -1;
    double d = groove_distance_in(lb, c, uv, &seg, 0), t = d / cv->width;
    x->known[v] = 2;
    if (!(fabs(t) < 0.5 - 1e-6) || seg < 0) return 0;
    const ch_segment *sg = &lb->set->segments[seg];
    double u, cp[2], *g = x->gradient[v];
    ch_bezier_closest(sg->p, sg->is_line, uv, &u);
    ch_bezier_eval(sg->p, u, cp);
    double r = hypot(uv[0] - cp[0], uv[1] - cp[1]);
    if (r > 1e-12) {
      g[0] = (d < 0.0 ? -1.0 : 1.0) * (uv[0] - cp[0]) / r;
      g[1] = (d < 0.0 ? -1.0 : 1.0) * (uv[1] - cp[1]) / r;
    } else { /* on the curve: its left normal */
      double tg[2];
      ch_bezier_tangent(sg->p, u, tg);
      double l = hypot(tg[0], tg[1]);
      g[0] = l > 0.0 ? -tg[1] / l : 0.0;
      g[1] = l > 0.0 ? tg[0] / l : 0.0;
    }
    g[2] = t;
    x->known[v] = 1;
  }
  if (x->known[v] != 1) return 0;
  const double *g = x->gradient[v];
  double t = g[2], dp;
  if (cv->profile.kind == CH_PROFILE_U) {
    double dt = fmin(1e-6, 0.5 - fabs(t));
    dp = (ch_profile_eval(&cv->profile, t + dt) - ch_profile_eval(&cv->profile, t - dt)) / (2.0 * dt);
  } else {
    int nb;
    const double *br = lines_of(lb, c, 0, &nb);
    if (k < 1 || k >= nb) return 0;
    dp = (ch_profile_eval(&cv->profile, br[k]) - ch_profile_eval(&cv->profile, br[k - 1])) / (br[k] - br[k - 1]);
  }
  double slope = cv->depth * dp / cv->width / lb->object_scale; /* dh/ds in object units */
  double m[3] = {-slope * g[0], -slope * g[1], 1.0}, l = sqrt(ch_dot3(m, m));
  for (int i = 0; i < 3; i++) n[i] = m[i] / l;
  return 1;
}

/* A new facet's normal stays within 0.6 angle steps of the exact normal
 * at each of its corners (but rims): a long straight edge leaves a curved
 * groove's thin layers by its sagitta, which tilts the facet across them,
 * and turns away from the groove's direction. 0.6: at 130k triangles over
 * ornament, glyphs and spiral the normals' p95 went 0.1-0.3 degrees below
 * thinning without it, L1 within 3%; 1.0 gave back half of that. */
static int thin_triangle_ok(void *ctx, int family, int layer, const int v[3], const double *uv[3]) {
  thin_context *x = ctx;
  const labeler *lb = x->lb;
  int c = family / LEVELS;
  double q[3][3];
  for (int k = 0; k < 3; k++) {
    q[k][0] = uv[k][0] * lb->object_scale;
    q[k][1] = uv[k][1] * lb->object_scale;
    q[k][2] = x->o->h[v[k]];
  }
  double a[3] = {q[1][0] - q[0][0], q[1][1] - q[0][1], q[1][2] - q[0][2]};
  double b[3] = {q[2][0] - q[0][0], q[2][1] - q[0][1], q[2][2] - q[0][2]}, f[3];
  ch_cross3(a, b, f);
  double l = sqrt(ch_dot3(f, f));
  if (!(l > 0.0)) return 0;
  if (f[2] < 0.0) l = -l;
  double cos_max = cos(0.6 * lb->curve_angle[c]);
  for (int k = 0; k < 3; k++) {
    double n[3];
    if (!exact_normal(x, c, layer, v[k], uv[k], n)) continue;
    if (ch_dot3(f, n) / l < cos_max) return 0;
  }
  return 1;
}

/* Thins o's groove layers (ch_thin.h) and drops the vertices it frees;
 * returns how many, -1 when out of memory. */
static int thin_output(const labeler *lb, const ch_tess_result *tess, double longest_edge, out_mesh *o) {
  thin_context *x = malloc(sizeof *x);
  unsigned char *removed = calloc((size_t)(o->npos > 0 ? o->npos : 1), 1);
  int *map = malloc((size_t)(o->npos > 0 ? o->npos : 1) * sizeof *map);
  if (!x || !removed || !map) {
    free(x);
    free(removed);
    free(map);
    return -1;
  }
  x->lb = lb;
  x->o = o;
  x->gradient = malloc((size_t)(o->npos > 0 ? o->npos : 1) * sizeof *x->gradient);
  x->known = calloc((size_t)(o->npos > 0 ? o->npos : 1), 1);
  x->distance = malloc((size_t)(o->npos > 0 ? o->npos : 1) * sizeof *x->distance);
  x->distance_curve = malloc((size_t)(o->npos > 0 ? o->npos : 1) * sizeof *x->distance_curve);
  if (x->distance_curve)
    for (int v = 0; v < o->npos; v++) x->distance_curve[v] = -1;
  if (!x->gradient || !x->known || !x->distance || !x->distance_curve || edge_grid_build(x, tess, longest_edge)) {
    free(x->distance);
    free(x->distance_curve);
    free(x->gradient);
    free(x->known);
    free(x);
    free(removed);
    free(map);
    return -1;
  }
  ch_thin_rules rules = {thin_band, thin_max_edge, thin_edge_ok, thin_triangle_ok, x};
  int n = ch_thin_bands(o->npos, &o->ntri, o->tri, o->uv, o->group, &rules, removed);
  free(x->gradient);
  free(x->known);
  free(x->distance);
  free(x->distance_curve);
  if (n > 0) {
    int k = 0;
    for (int v = 0; v < o->npos; v++) {
      map[v] = removed[v] ? -1 : k;
      if (!removed[v]) {
        o->face[k] = o->face[v];
        o->st[2 * (size_t)k] = o->st[2 * (size_t)v];
        o->st[2 * (size_t)k + 1] = o->st[2 * (size_t)v + 1];
        o->h[k] = o->h[v];
        k++;
      }
    }
    o->npos = k;
    for (size_t i = 0; i < 3 * (size_t)o->ntri; i++) o->tri[i] = map[o->tri[i]];
  }
  free(x);
  free(removed);
  free(map);
  return n;
}

/* ---- the whole embedding ------------------------------------------------- */
double ch_embed_angle_deg(double reference_edge) { return fmin(10.0, fmax(1.0, 1800.0 * reference_edge)); }

/* What a count-only run leaves for embed_finish: its cut. */
typedef struct embed_kept {
  out_mesh o;
  ch_embed_stats stats;
} embed_kept;

/* From the cut to the displaced mesh: positions, normals by group, the
 * collapse of zero-length edges. On return o's positions are out's (the
 * caller still frees o with out_free). */
static ch_status embed_finish(const ch_surface *surface, const ch_curve_set *set, out_mesh *o, ch_embed_stats *stats,
                              ch_mesh *out, ch_error *err) {
  double t_start = omp_get_wtime();
  ch_status st;
  if ((st = evaluate_positions(surface, o, err))) return st;
  double t2 = omp_get_wtime();
  stats->seconds_cut += t2 - t_start;
  stats->min_h = INFINITY;
  stats->max_h = -INFINITY;
  for (int i = 0; i < o->npos; i++) {
    stats->min_h = fmin(stats->min_h, o->h[i]);
    stats->max_h = fmax(stats->max_h, o->h[i]);
  }
  /* Normals are shared within a group. The pieces of a u groove between
   * its rims meet at lines where the surface is smooth (its slices exist
   * only so that facets follow P): one group for them all, so shading is
   * smooth across them and split only at its rims. */
#pragma omp parallel for schedule(static)
  for (int t = 0; t < o->ntri; t++) {
    uint64_t gr = o->group[t], g = gr >> 32;
    if (gr == WALL_GROUP || !g) continue;
    const ch_curve *cv = &set->curves[GROOVE_CURVE(g)];
    if (cv->profile.kind == CH_PROFILE_U) /* one group over its slices and line sets */
      o->group[t] = (gr & ~((UINT64_C(0xff) | (UINT64_C(3) << 28)) << 32)) | (UINT64_C(1) << 32);
  }
  if ((st = build_mesh(o, out, err))) return st;
  o->pos = NULL; /* now out's */
  {
    /* A line through a vertex of the tessellation puts its boundary point
     * within rounding of that vertex: collapse those zero-length edges
     * (where the mesh stays manifold) rather than keep zero-area slivers. */
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int v = 0; v < out->num_positions; v++)
      for (int k = 0; k < 3; k++) {
        lo[k] = fmin(lo[k], out->positions[3 * (size_t)v + k]);
        hi[k] = fmax(hi[k], out->positions[3 * (size_t)v + k]);
      }
    double span[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
    double diag = out->num_positions ? sqrt(ch_dot3(span, span)) : 0.0;
    if (ch_mesh_collapse_short_edges(out, 1e-12 * diag) < 0 || ch_mesh_remove_pillows(out) < 0) {
      ch_mesh_free(out);
      return ch_error_set(err, CH_ERR_NOMEM, "out of memory for feature embedding");
    }
  }
  stats->triangles = out->num_faces;
  stats->seconds_normals = omp_get_wtime() - t2;
  return CH_OK;
}

/* ch_embed_build; a count-only run hands its cut to *kept if asked. */
/* Reports a stage of embedding run `run` (1, 2, ... of ch_embed_to_target)
 * at refinement round `round`. */
static void report(const ch_embed_desc *desc, int run, int round, const char *what, double fraction) {
  if (!desc || !desc->progress) return;
  ch_progress_reportf(desc->progress, fraction, "embedding: run %d%s, round %d, %s", run,
                      desc->count_only ? " (pilot)" : "", round, what);
}

static ch_status embed_run(const ch_surface *surface, const ch_tess_result *tess, const ch_height *height,
                           const ch_embed_desc *desc, ch_mesh *out, ch_embed_stats *stats_out, embed_kept *kept,
                           int run, ch_error *err) {
  memset(out, 0, sizeof *out);
  ch_embed_stats stats = {0};
  const ch_mesh *tm = &tess->mesh;
  double t0 = omp_get_wtime();
  work w = {.surface = surface};
  unsigned char *fresh = NULL; /* triangles the last split made; NULL: all */
  labeler lb = {0};
  out_mesh o = {0};
  ch_status st = CH_OK;

  /* The working mesh: the tessellation, each corner with its (s,t) in its face. */
  w.nverts = w.cap_verts = tm->num_positions;
  w.ntris = w.cap_tris = tm->num_faces;
  w.verts = malloc((size_t)(w.nverts > 0 ? w.nverts : 1) * sizeof *w.verts);
  w.tris = malloc((size_t)(w.ntris > 0 ? w.ntris : 1) * sizeof *w.tris);
  if (!w.verts || !w.tris) goto nomem;
  double uv_area = 0.0, longest_edge = 0.0;
  int failed = 0;
#pragma omp parallel for schedule(static) reduction(| : failed) reduction(max : longest_edge)
  for (int t = 0; t < w.ntris; t++) {
    wtri *T = &w.tris[t];
    T->face = tess->triangle_face[t];
    for (int k = 0; k < 3; k++) {
      int c = tm->face_start[t] + k, v = tm->corner_position[c];
      T->v[k] = v;
      memcpy(T->uv[k], &tm->uvs[2 * (size_t)tm->corner_uv[c]], sizeof T->uv[k]);
      if (tess->vertex_face[v] == T->face) {
        memcpy(T->st[k], &tess->vertex_st[2 * (size_t)v], sizeof T->st[k]);
      } else if (ch_surface_locate(surface, T->face, T->uv[k], T->st[k])) {
        failed = 1;
      }
    }
    for (int k = 0; k < 3; k++)
      longest_edge = fmax(longest_edge, hypot(T->uv[(k + 1) % 3][0] - T->uv[k][0], T->uv[(k + 1) % 3][1] - T->uv[k][1]));
  }
  for (int t = 0; t < w.ntris; t++) { /* in order: the same sum for any thread count */
    const wtri *T = &w.tris[t];
    uv_area += 0.5 * fabs((T->uv[1][0] - T->uv[0][0]) * (T->uv[2][1] - T->uv[0][1]) -
                          (T->uv[2][0] - T->uv[0][0]) * (T->uv[1][1] - T->uv[0][1]));
  }
  if (failed) {
    st = ch_error_set(err, CH_ERR_INTERNAL, "feature embedding: a tessellation corner is outside its face's UV");
    goto done;
  }
#pragma omp parallel for schedule(static)
  for (int v = 0; v < w.nverts; v++) {
    ch_surface_point sp;
    w.verts[v].face = tess->vertex_face[v];
    memcpy(w.verts[v].st, &tess->vertex_st[2 * (size_t)v], sizeof w.verts[v].st);
    ch_surface_eval(surface, w.verts[v].face, w.verts[v].st[0], w.verts[v].st[1], &sp);
    memcpy(w.verts[v].uv, sp.uv, sizeof sp.uv);
  }
  double mean_edge = sqrt(2.0 * uv_area / (w.ntris > 0 ? w.ntris : 1));
  double radius = desc && desc->step_radius > 0.0 ? desc->step_radius : 4.0 * mean_edge;
  /* A warped mesh's edges vary about the mean by the warp's slopes: every
   * corner of a triangle a step curve crosses must still see the curve. */
  if (desc && desc->warp && !(desc->step_radius > 0.0)) radius = fmax(radius, 2.0 * longest_edge);
  double curve_tolerance = desc && desc->curve_tolerance > 0.0 ? desc->curve_tolerance : 0.0;
  /* A warped mesh's coarse parts have edges up to 1 / floor = 10x the
   * mean: four halvings more to bring them down to the features (only
   * for triangles that cannot be cut yet: refining the rest there spends
   * triangles the camera does not see). */
  int max_rounds = desc && desc->max_refine_rounds > 0 ? desc->max_refine_rounds : desc && desc->warp ? 12 : 8;
  /* The angle step of the u lines: finer with density, as the mesh would
   * be, about 7 degrees at 130k triangles over the UV square, 3.5 at 520k
   * (measured on the bundled curve sets: finer steps starve the rest of
   * the mesh at a fixed count, coarser ones leave the normals faceted). */
  double reference_edge = desc && desc->reference_edge > 0.0 ? desc->reference_edge : mean_edge;
  double angle_deg = desc && desc->normal_tolerance_deg > 0.0 ? desc->normal_tolerance_deg
                                                              : ch_embed_angle_deg(reference_edge);
  double angle = angle_deg * CH_PI / 180.0;
  /* Object units per UV unit, for the slope of the displaced profiles. */
  double area3 = 0.0;
  for (int f = 0; f < tess->mesh.num_faces; f++) { /* in order, as above */
    const int *cp = &tess->mesh.corner_position[tess->mesh.face_start[f]];
    const double *p0 = &tess->mesh.positions[3 * (size_t)cp[0]];
    const double *p1 = &tess->mesh.positions[3 * (size_t)cp[1]];
    const double *p2 = &tess->mesh.positions[3 * (size_t)cp[2]];
    double a[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]}, b[3] = {p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]}, n[3];
    ch_cross3(a, b, n);
    area3 += 0.5 * sqrt(ch_dot3(n, n));
  }
  double object_scale = uv_area > 0.0 && area3 > 0.0 ? sqrt(area3 / uv_area) : 1.0;
  if ((st = labeler_init(&lb, height, desc ? desc->warp : NULL, radius, curve_tolerance, angle, object_scale,
                         reference_edge, longest_edge, err)))
    goto done;
  lb.junction_size = mean_edge / 8.0;
  lb.cap_angle = 4.0 * angle;
  stats.seconds_setup = omp_get_wtime() - t0;
  /* Edge samples: a quarter of the thinnest groove, so no groove slips
   * between two samples unseen. */
  double delta = INFINITY, scale = 0.0;
  for (int c = 0; c < height->set->num_curves; c++) {
    const ch_curve *cv = &height->set->curves[c];
    if (cv->kind == CH_CURVE_GROOVE) {
      delta = fmin(delta, 0.25 * cv->width);
      scale = fmax(scale, fabs(cv->depth));
    } else {
      scale = fmax(scale, fmax(fabs(cv->left), fabs(cv->right)));
    }
  }
  double tol = 1e-5 * scale + 1e-12; /* a jump above this is a wall */
  lb.wall_tol = tol;

  /* Local refinement until every triangle's crossings pair into chords. */
  int labelled = 0;
  for (int round = 0;; round++) {
    double ta = omp_get_wtime();
    report(desc, run, round, "labels", -1.0);
    label_vertices(&lb, &w, labelled);
    labelled = w.nverts;
    double tb = omp_get_wtime();
    if (round == 0 && (st = build_edges(&w, err))) goto done;
    double tc = omp_get_wtime();
    stats.seconds_labels += tb - ta;
    stats.seconds_edges += tc - tb;
    int oom = 0;
    /* (in blocks, so a long search reports how far it is) */
    for (int i0 = 0, block = w.nedges / 32 > 4096 ? w.nedges / 32 : 4096; i0 < w.nedges && !oom; i0 += block) {
      report(desc, run, round, "crossings", (double)i0 / w.nedges);
      int i1 = i0 + block < w.nedges ? i0 + block : w.nedges;
#pragma omp parallel for schedule(dynamic, 64) reduction(| : oom)
      for (int i = i0; i < i1; i++) {
        wedge *e = &w.edges[i];
        if (e->ncross < 0) oom |= compute_crossings(&lb, &w, e, delta);
      }
    }
    if (oom) goto nomem;
    double td = omp_get_wtime();
    stats.seconds_crossings += td - tc;
    if (round >= max_rounds) break;
    unsigned char *refine = calloc((size_t)(w.ntris > 0 ? w.ntris : 1), 1);
    if (!refine) goto nomem;
    report(desc, run, round, "refinement", -1.0);
    /* Only triangles made by the last split can have changed: the others
     * kept their edges and crossings, so their answer too. */
#pragma omp parallel for schedule(dynamic, 256)
    for (int t = 0; t < w.ntris; t++)
      refine[t] = (unsigned char)((!fresh || fresh[t]) && needs_refinement(&lb, &w, t, round >= 8, round));
    double te = omp_get_wtime();
    stats.seconds_classify += te - td;
    int split = 0;
    for (int t = 0; t < w.ntris; t++)
      for (int k = 0; k < 3 && refine[t]; k++) {
        int i = w.tri_edge[3 * (size_t)t + k];
        if (w.edges[i].mid >= 0 || edge_length(&w, &w.edges[i]) < MIN_SPLIT_LENGTH) continue;
        if (add_midpoint(&w, i)) {
          free(refine);
          goto nomem;
        }
        split++;
      }
    free(refine);
    if (!split) break;
    /* Each split edge adds about two triangles. Curves that need more than
     * the cap would take memory and time without end: */
    double cap = desc && desc->max_triangles > 0 ? (double)desc->max_triangles
                                                 : MAX_REFINED_PER_BASE * (double)tm->num_faces + MAX_REFINED_EXTRA;
    if ((double)w.ntris + 2.0 * split > cap) {
      st = ch_error_set(err, CH_ERR_INPUT,
                        "feature embedding: the curves need more than %.0f triangles (refinement round %d over %d "
                        "base triangles): too many curves meet in too small a place; fewer or wider curves, or "
                        "--no-snap", cap, round + 1, tm->num_faces);
      goto done;
    }
    stats.refine_rounds = round + 1;
    stats.refined_edges += split;
    if ((st = split_triangles(&w, &fresh, err))) goto done;
    stats.seconds_split += omp_get_wtime() - te;
  }
  double t1 = omp_get_wtime();

  /* Output vertices: the working vertices, then the crossings' copies
   * (one, or two on a wall), numbered edge by edge and filled in parallel. */
  {
    int *first = malloc(((size_t)w.nedges + 1) * sizeof *first);
    if (!first) goto nomem;
    long total = w.nverts;
    for (int i = 0; i < w.nedges; i++) {
      first[i] = (int)total;
      const wedge *e = &w.edges[i];
      for (int c = 0; c < e->ncross; c++) total += fabs(e->cross[c].ha - e->cross[c].hb) <= tol ? 1 : 2;
      if (total >= INT32_MAX / 3) {
        free(first);
        goto nomem;
      }
    }
    int n = (int)total;
    o.face = malloc((size_t)(n > 0 ? n : 1) * sizeof *o.face);
    o.st = malloc(2 * (size_t)(n > 0 ? n : 1) * sizeof *o.st);
    o.h = malloc((size_t)(n > 0 ? n : 1) * sizeof *o.h);
    if (!o.face || !o.st || !o.h) {
      free(first);
      goto nomem;
    }
    o.npos = o.cap_pos = n;
#pragma omp parallel for schedule(static)
    for (int v = 0; v < w.nverts; v++) {
      o.face[v] = w.verts[v].face;
      memcpy(&o.st[2 * (size_t)v], w.verts[v].st, sizeof w.verts[v].st);
      o.h[v] = w.verts[v].h;
    }
    long crossings = 0, walls = 0;
#pragma omp parallel for schedule(dynamic, 1024) reduction(+ : crossings, walls)
    for (int i = 0; i < w.nedges; i++) {
      wedge *e = &w.edges[i];
      int face = w.tris[e->tri].face, k = first[i];
      for (int c = 0; c < e->ncross; c++) {
        crossing *x = &e->cross[c];
        double pst[2], puv[2];
        edge_point(&w, e, x->x, puv, pst);
        locate_st(surface, face, puv, pst);
        crossings++;
        int wall = !(fabs(x->ha - x->hb) <= tol);
        walls += wall;
        for (int j = 0; j <= wall; j++) {
          o.face[k + j] = face;
          memcpy(&o.st[2 * (size_t)(k + j)], pst, sizeof pst);
          o.h[k + j] = wall ? (j ? x->hb : x->ha) : 0.5 * (x->ha + x->hb);
        }
        x->copy_a = k;
        x->copy_b = k + wall;
        k += 1 + wall;
      }
    }
    stats.crossings += (int)crossings;
    stats.wall_points += (int)walls;
    free(first);
  }
  report(desc, run, stats.refine_rounds, "cut", -1.0);
  /* The cut, in parallel over fixed chunks of triangles: each part numbers
   * its new vertices (junctions) after the shared ones; the parts are then
   * joined in chunk order, so the bytes do not depend on the threads. */
  {
    enum { CUT_CHUNK = 4096 };
    int nchunks = (w.ntris + CUT_CHUNK - 1) / CUT_CHUNK, shared = o.npos, oom = 0;
    out_mesh *part = calloc((size_t)(nchunks > 0 ? nchunks : 1), sizeof *part);
    ch_embed_stats *pstats = calloc((size_t)(nchunks > 0 ? nchunks : 1), sizeof *pstats);
    if (!part || !pstats) {
      free(part);
      free(pstats);
      goto nomem;
    }
#pragma omp parallel for schedule(dynamic, 1) reduction(| : oom)
    for (int c = 0; c < nchunks; c++) {
      part[c].npos = part[c].first_pos = shared;
      int t1 = (c + 1) * CUT_CHUNK < w.ntris ? (c + 1) * CUT_CHUNK : w.ntris;
      for (int t = c * CUT_CHUNK; t < t1 && !oom; t++) oom |= cut_triangle(&lb, &w, t, tol, &part[c], &pstats[c]) != 0;
    }
    for (int c = 0; c < nchunks && !oom; c++) {
      out_mesh *q = &part[c];
      int delta = o.npos - shared; /* the part's vertex x >= shared lands at x + delta */
      for (int i = 0; i < q->npos - shared && !oom; i++)
        oom |= out_vertex(&o, q->face[i], &q->st[2 * (size_t)i], q->h[i]) < 0;
      for (int t = 0; t < q->ntri && !oom; t++) {
        int v[3];
        for (int k = 0; k < 3; k++) {
          int x = q->tri[3 * (size_t)t + k];
          v[k] = x >= shared ? x + delta : x;
        }
        const double *u = &q->uv[6 * (size_t)t];
        oom |= out_tri(&o, v[0], v[1], v[2], u, u + 2, u + 4, q->group[t]) != 0;
      }
      if (pstats[c].unresolved > 0) { /* chunks in order: the first is the first chunk's */
        if (stats.unresolved == 0) {
          memcpy(stats.unresolved_uv, pstats[c].unresolved_uv, sizeof stats.unresolved_uv);
          memcpy(stats.unresolved_box, pstats[c].unresolved_box, sizeof stats.unresolved_box);
        } else {
          for (int k = 0; k < 2; k++) {
            stats.unresolved_box[k] = fmin(stats.unresolved_box[k], pstats[c].unresolved_box[k]);
            stats.unresolved_box[2 + k] = fmax(stats.unresolved_box[2 + k], pstats[c].unresolved_box[2 + k]);
          }
        }
      }
      stats.unresolved += pstats[c].unresolved;
      stats.junctions += pstats[c].junctions;
      stats.wall_triangles += pstats[c].wall_triangles;
    }
    for (int c = 0; c < nchunks; c++) out_free(&part[c]);
    free(part);
    free(pstats);
    if (oom) goto nomem;
  }
  /* Thinning pays where the target is coarse (measured on the plane's
   * sets: at 130k triangles L1 13-80% lower on the u and box sets, the
   * normals' p95 up to 1.3 degrees; at 520k and 2.1M L1 only 7-17% lower
   * for 25-130% more time, from the bigger base it leaves room for and
   * runs the count model then misses). Below a mean edge of 1/360 (about
   * 260k triangles over the UV square) the cut is left as it is. */
  if (!(desc && desc->no_thinning) && reference_edge >= 1.0 / 360.0) {
    double tt = omp_get_wtime();
    report(desc, run, stats.refine_rounds, "thinning", -1.0);
    int thinned = thin_output(&lb, tess, longest_edge, &o);
    if (thinned < 0) goto nomem;
    stats.thinned = thinned;
    stats.seconds_thin = omp_get_wtime() - tt;
  }
  stats.angle_deg = angle_deg;
  stats.seconds_refine = t1 - t0;
  stats.seconds_cut = omp_get_wtime() - t1;
  if (desc && desc->count_only) {
    stats.triangles = o.ntri;
    if (stats_out) *stats_out = stats;
    if (kept) { /* the caller may finish it */
      kept->o = o;
      kept->stats = stats;
      memset(&o, 0, sizeof o);
    }
    goto done;
  }
  st = embed_finish(surface, height->set, &o, &stats, out, err);
  if (!st && stats_out) *stats_out = stats;
  goto done;
nomem:
  st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for feature embedding");
done:
  out_free(&o);
  labeler_free(&lb);
  free(w.verts);
  free(w.tris);
  free_edges(w.edges, w.nedges);
  free(w.tri_edge);
  free(fresh);
  return st;
}

ch_status ch_embed_build(const ch_surface *surface, const ch_tess_result *tess, const ch_height *height,
                         const ch_embed_desc *desc, ch_mesh *out, ch_embed_stats *stats, ch_error *err) {
  return embed_run(surface, tess, height, desc, out, stats, NULL, 1, err);
}

/* The base count b with b + c0 + c1 sqrt(b) = target (bisection; 1 if
 * none is above 1). */
static double model_base(double target, double c0, double c1) {
  double lo = 1.0, hi = target;
  for (int it = 0; it < 80; it++) {
    double mid = 0.5 * (lo + hi);
    if (mid + c0 + c1 * sqrt(mid) < target)
      lo = mid;
    else
      hi = mid;
  }
  return lo;
}

/* The base count b with b + f2 (b / b2)^p = target, p the power through
 * (b1, f1) and (b2, f2) within [0, 1]: what the features add at two runs. */
static double power_base(double target, double b1, double f1, double b2, double f2) {
  double pw = fmin(1.0, fmax(0.0, log(f2 / f1) / log(b2 / b1)));
  double lo = 1.0, hi = target;
  for (int it = 0; it < 80; it++) {
    double mid = 0.5 * (lo + hi);
    if (mid + f2 * pow(mid / b2, pw) < target)
      lo = mid;
    else
      hi = mid;
  }
  return lo;
}

ch_status ch_embed_to_target(const ch_surface *surface, const ch_height *height, const ch_embed_desc *desc,
                             long target, ch_tess_result *tess, ch_mesh *out, ch_embed_stats *stats, int *passes,
                             ch_error *err) {
  memset(tess, 0, sizeof *tess);
  memset(out, 0, sizeof *out);
  ch_tess_result best_tess = {0}, cur_tess = {0};
  ch_mesh best = {0}, cur = {0};
  ch_embed_stats best_stats = {0}, cur_stats = {0};
  double best_miss = INFINITY;
  double xs[8], ys[8]; /* base triangles, output triangles of each run */
  int runs = 0;
  ch_status st = CH_OK;
  /* The fewest triangles the base mesh gives (every edge at rate 1). */
  ch_tess_desc one = {.uniform_rate = 1};
  if ((st = ch_tess_build(surface, &one, &cur_tess, err))) return st;
  long fewest = cur_tess.mesh.num_faces;
  ch_tess_free(&cur_tess);
  memset(&cur_tess, 0, sizeof cur_tess);
  if (target < fewest) target = fewest;
  /* Cheap pilots first: at 1/64 and 1/16 of the target (fewer for small
   * targets). Where the base mesh allows only the second, another at twice
   * it, below a quarter of the target: one pilot gives no model of what
   * does not grow with the base, and taken as growing all (c0 = 0) it
   * coarsened the u lines twice over the vase at 130k (ornament: 6 runs). */
  long pilot[2];
  int pilots = 0;
  for (int k = 0; k < 2; k++) {
    long b = target / (k == 0 ? 64 : 16);
    if (b >= 2000 && b >= fewest) pilot[pilots++] = b;
  }
  if (pilots == 1 && pilot[0] == target / 16 && 2 * pilot[0] <= target / 4) pilot[pilots++] = 2 * pilot[0];
  long first_base = pilots > 0 ? pilot[0] : target, base = first_base;
  double model_c1 = 0.0; /* the pilots' sqrt term, kept for the first correction */
  double rescale_f0 = 0.0, rescale_f1 = 0.0; /* what the features added to the pilots before a coarsening */
  ch_embed_desc d = desc ? *desc : (ch_embed_desc){0};
  int auto_angle = !(d.normal_tolerance_deg > 0.0), coarsenings = 0;
  /* The angle step shapes only grooves (their u lines, the caps of open
   * ends, the thinning's normals): with step curves alone a coarser one
   * changes nothing, and each coarsening would rerun the pilots (1000
   * small loops: four times, for the same answer). */
  int has_grooves = 0, has_u = 0;
  for (int c = 0; c < height->set->num_curves; c++) {
    const ch_curve *cv = &height->set->curves[c];
    has_grooves |= cv->kind == CH_CURVE_GROOVE;
    has_u |= cv->kind == CH_CURVE_GROOVE && cv->profile.kind == CH_PROFILE_U;
  }
  if (!has_grooves) auto_angle = 0;
  for (int pass = 0; pass < 8; pass++) {
    ch_tess_desc td = {.target_triangles = base, .warp = d.warp};
    if ((st = ch_tess_build(surface, &td, &cur_tess, err))) break;
    if (pass == 0 && !(d.reference_edge > 0.0)) {
      /* The mean UV edge at the target's density, from this run's area. */
      const ch_mesh *m = &cur_tess.mesh;
      double area = 0.0;
      for (int f = 0; f < m->num_faces; f++) {
        const double *a = &m->uvs[2 * (size_t)m->corner_uv[3 * (size_t)f]];
        const double *b = &m->uvs[2 * (size_t)m->corner_uv[3 * (size_t)f + 1]];
        const double *c = &m->uvs[2 * (size_t)m->corner_uv[3 * (size_t)f + 2]];
        area += 0.5 * fabs((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]));
      }
      d.reference_edge = sqrt(2.0 * area / (double)target);
    }
    /* Pilots only count; one that lands is finished from its cut. */
    d.count_only = pass < pilots;
    embed_kept kept = {0};
    st = embed_run(surface, &cur_tess, height, &d, &cur, &cur_stats, d.count_only ? &kept : NULL, runs + 1, err);
    if (st) break;
    runs++;
    double nb = cur_tess.mesh.num_faces, no = (double)cur_stats.triangles, miss = fabs(no - (double)target);
    xs[pass] = nb;
    ys[pass] = no;
    if (d.count_only && miss <= 0.04 * (double)target) {
      d.count_only = 0;
      cur_stats = kept.stats;
      st = embed_finish(surface, height->set, &kept.o, &cur_stats, &cur, err);
      out_free(&kept.o);
      if (st) break;
      no = ys[pass] = (double)cur_stats.triangles; /* the cleanup's count */
      miss = fabs(no - (double)target);
    }
    out_free(&kept.o);
    if (d.count_only && pass == 0 && no > 1.25 * (double)target && !has_u) {
      /* The first pilot alone is well over the target. Without u lines the
       * angle step shapes only the caps of open ends: the coarsest step at
       * once (one rerun of the first pilot, not four: bricks at 60k needs
       * it), and if the features still need more than the target, the
       * fewest triangles the base gives (by the model), without the second
       * pilot (500 grooves through a point: 7 runs to reach the same base). */
      if (auto_angle && coarsenings < 4) {
        double step = coarsenings == 0 ? ch_embed_angle_deg(d.reference_edge) : d.normal_tolerance_deg;
        for (; coarsenings < 4; coarsenings++) step *= 1.5;
        d.normal_tolerance_deg = step;
        ch_tess_free(&cur_tess);
        ch_mesh_free(&cur);
        memset(&cur_tess, 0, sizeof cur_tess);
        memset(&cur, 0, sizeof cur);
        pass = -1;
        base = first_base;
        continue;
      }
      pilots = 1;
      auto_angle = 0;
    }
    if (d.count_only && pass == 0 && rescale_f0 > 0.0) {
      /* After a coarsening only the first pilot runs again: what the
       * features add to the second is taken to change as they did at the
       * first (glyphs over the tablet at 130k: 0.4% off its rerun). */
      ys[1] = xs[1] + rescale_f1 * (no - nb) / rescale_f0;
      rescale_f0 = 0.0;
      pass = 1;
    }
    if (!d.count_only && miss < best_miss) { /* keep the closest full run */
      ch_tess_free(&best_tess);
      ch_mesh_free(&best);
      best_tess = cur_tess;
      best = cur;
      best_stats = cur_stats;
      best_miss = miss;
    } else {
      ch_tess_free(&cur_tess);
      ch_mesh_free(&cur);
    }
    memset(&cur_tess, 0, sizeof cur_tess);
    memset(&cur, 0, sizeof cur);
    /* A full run's count is exact: SPEC's 5% is enough (a pilot's is
     * before the cleanup, hence 4% above). */
    if (best_miss <= 0.05 * (double)target) break;
    /* Next base count: after the pilots, the model out = base + c0 + c1
     * sqrt(base) through them (what the cut adds grows like the length of
     * the feature lines over the edge length, plus what does not grow: the
     * refinement at junctions and ends, the rims' last slices; on the
     * bundled sets it predicts a 16x larger run within about 1%), then the
     * secant through the last two runs. One pilot: c0 = 0. */
    double next;
    if (pass + 1 < pilots) {
      next = (double)pilot[pass + 1];
    } else if (pass + 1 == pilots) {
      double c0 = 0.0, c1 = no > nb ? (no - nb) / sqrt(nb) : 0.0;
      if (pilots >= 2) {
        int i0 = pass - 1, i1 = pass; /* the two pilots */
        double s0 = sqrt(xs[i0]), s1 = sqrt(xs[i1]);
        c1 = fmax(0.0, ((ys[i1] - xs[i1]) - (ys[i0] - xs[i0])) / (s1 - s0));
        c0 = (ys[i1] - xs[i1]) - c1 * s1;
      }
      model_c1 = c1;
      next = model_base((double)target, c0, c1);
      if (next < (double)target / 8.0 && auto_angle && coarsenings < 4) {
        /* The u lines would take more than 7/8 of the triangles and starve
         * everything else (crossings, CSG seams, the flat parts): coarser
         * angle steps, and the pilots again (the first only, below). */
        d.normal_tolerance_deg = (coarsenings == 0 ? ch_embed_angle_deg(d.reference_edge) : d.normal_tolerance_deg) * 1.5;
        coarsenings++;
        if (pilots >= 2 && ys[0] > xs[0] && ys[1] > xs[1]) {
          rescale_f0 = ys[0] - xs[0];
          rescale_f1 = ys[1] - xs[1];
        }
        pass = -1;
        base = first_base;
        ch_tess_free(&best_tess);
        ch_mesh_free(&best);
        memset(&best_tess, 0, sizeof best_tess);
        memset(&best, 0, sizeof best);
        best_miss = INFINITY;
        continue;
      }
    } else if (pass == 0) {
      next = xs[0] * (double)target / no; /* no pilot (a small target) */
    } else if (pilots >= 2 && pass > pilots && (ys[pass] - ys[pass - 1]) * (xs[pass] - xs[pass - 1]) <= 0.0 &&
               no > nb && ys[1] > xs[1] && nb != xs[1]) {
      /* Two full runs whose counts fall as the base grows (thinning
       * makes the count bumpy: bricks at 130k): no secant, the power
       * model through the last run and the second pilot again. */
      next = power_base((double)target, xs[1], ys[1] - xs[1], nb, no - nb);
    } else if (pass == pilots && pilots > 0) {
      /* The first full run missed: what the features add taken as a power
       * of the base through it and the second pilot (thinning makes it
       * grow faster than the pilots' sqrt model says: bricks at 130k, 6 ->
       * 5 runs); without two pilots, the model through it, its slope kept
       * (a secant to a pilot far below runs too flat or too steep). */
      if (pilots >= 2 && no > nb && ys[pass - 1] > xs[pass - 1] && nb != xs[pass - 1]) {
        next = power_base((double)target, xs[pass - 1], ys[pass - 1] - xs[pass - 1], nb, no - nb);
      } else {
        next = model_base((double)target, (no - nb) - model_c1 * sqrt(nb), model_c1);
      }
    } else {
      double dx = xs[pass] - xs[pass - 1], dy = ys[pass] - ys[pass - 1];
      next = dy != 0.0 ? xs[pass] + ((double)target - ys[pass]) * dx / dy : xs[pass] * (double)target / no;
      if (!(next > 0.0)) next = xs[pass] * 0.5;
    }
    long nl = (long)llround(fmin(next, 4.0 * (double)target));
    if (nl < fewest) nl = fewest;
    if (nl == base) break;
    base = nl;
  }
  ch_tess_free(&cur_tess);
  ch_mesh_free(&cur);
  if (!st && best_miss == INFINITY) { /* only pilots ran (the next base was a pilot's): that one in full */
    ch_tess_desc td = {.target_triangles = base, .warp = d.warp};
    d.count_only = 0;
    if (!(st = ch_tess_build(surface, &td, &best_tess, err)))
      st = ch_embed_build(surface, &best_tess, height, &d, &best, &best_stats, err);
    runs++;
  }
  if (passes) *passes = runs;
  if (st) {
    ch_tess_free(&best_tess);
    ch_mesh_free(&best);
    return st;
  }
  *tess = best_tess;
  *out = best;
  if (stats) *stats = best_stats;
  return CH_OK;
}
