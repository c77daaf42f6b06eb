/* Diffusion-curve images (diffusion-curves-on-surfaces §3.2; the diffusion
 * itself follows Orzan et al.'s formulation: Laplace with the curves as
 * two-sided Dirichlet boundaries). Where the paper rasterises curve colours
 * into the texels a curve touches, we fix every texel within one texel of a
 * curve to its side's value, taken from the exact feature samples and
 * extended to the texel's centre by the solution's slope (ch_dci.h: the
 * curve, not the texel, is the boundary); texels near open ends stay free
 * so values flow round the ends, as in the paper.
 *
 * Reblur (docs/spec.md §3, Jeschke et al. 2009): the blur radius is diffused like a
 * colour (the curve's radius on blurred curves, 0 on sharp ones), capped at
 * d / (3 sqrt 2), d the distance to the nearest sharp curve, and applied as
 * a separable Gaussian truncated at 3 sigma: both passes together stay in
 * the L-infinity ball of radius 3 sigma, which then never crosses a sharp
 * curve. */
#include "ch_dci.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ch_bezier.h"
#include "ch_math.h"
#include "ch_progress.h"

void ch_dci_free(ch_dci *d) {
  ch_samples_free(&d->samples);
  free(d->h);
  free(d->rgb);
  free(d->blur);
  free(d->fixed);
  free(d->sing);
  ch_grid_free(&d->sing_grid);
  for (int i = 0; i < d->num_layers; i++) ch_dlayer_free(&d->layers[i]);
  free(d->layers);
  free(d->layer_far);
  ch_grid_free(&d->layer_grid);
  memset(d, 0, sizeof *d);
}

/* ---- singular terms ---- */

static double sing_phi(const ch_stepsing_point *pt, double r) {
  return ch_stepsing_window(r, CH_DCI_SING_INNER * pt->radius, pt->radius);
}

int ch_dci_sing_at(const ch_dci *d, const double p[2]) {
  if (!d->num_sing) return -1;
  const int *items;
  int n = ch_grid_query(&d->sing_grid, p[0], p[1], &items);
  for (int j = 0; j < n; j++) {
    const ch_stepsing_point *pt = &d->sing[items[j]];
    if (hypot(p[0] - pt->p[0], p[1] - pt->p[1]) < pt->radius) return items[j];
  }
  return -1;
}

/* The distance from point p to the box lo..hi (0 inside). */
static double box_point_distance(const double lo[2], const double hi[2], const double p[2]) {
  double dx = p[0] < lo[0] ? lo[0] - p[0] : p[0] > hi[0] ? p[0] - hi[0] : 0.0;
  double dy = p[1] < lo[1] ? lo[1] - p[1] : p[1] > hi[1] ? p[1] - hi[1] : 0.0;
  return hypot(dx, dy);
}

/* Whether any item listed in the cells of grid g over the box lo..hi
 * passes reaches(d, item, lo, hi); 1 also where the box spans too many
 * cells to walk (the caller then takes the general path). */
static int grid_box_any(const ch_grid *g, const ch_dci *d, const double lo[2], const double hi[2],
                        int (*reaches)(const ch_dci *, int, const double *, const double *)) {
  if (!g->cell_start) return 0;
  double b[4] = {lo[0], lo[1], hi[0], hi[1]};
  if (b[2] < g->origin[0] || b[3] < g->origin[1] || (b[0] - g->origin[0]) * g->inv_cell >= g->nx ||
      (b[1] - g->origin[1]) * g->inv_cell >= g->ny)
    return 0;
  int r[4];
  ch_grid_cell_range(g, b, r);
  if ((long)(r[2] - r[0] + 1) * (r[3] - r[1] + 1) > 64) return 1;
  for (int y = r[1]; y <= r[3]; y++)
    for (int x = r[0]; x <= r[2]; x++) {
      int c = y * g->nx + x;
      for (int j = g->cell_start[c]; j < g->cell_start[c + 1]; j++)
        if (reaches(d, g->items[j], lo, hi)) return 1;
    }
  return 0;
}

static int sing_reaches(const ch_dci *d, int k, const double *lo, const double *hi) {
  return box_point_distance(lo, hi, d->sing[k].p) < d->sing[k].radius;
}

static int layer_reaches(const ch_dci *d, int k, const double *lo, const double *hi) {
  const double *b = d->layers[k].box;
  double dx = fmax(0.0, fmax(b[0] - hi[0], lo[0] - b[2])), dy = fmax(0.0, fmax(b[1] - hi[1], lo[1] - b[3]));
  return !(hypot(dx, dy) >= d->layer_far[k]);
}

int ch_dci_box_has_no_terms(const ch_dci *d, const double lo[2], const double hi[2]) {
  return !(d->num_sing && grid_box_any(&d->sing_grid, d, lo, hi, sing_reaches)) &&
         !(d->num_layers && grid_box_any(&d->layer_grid, d, lo, hi, layer_reaches));
}

/* T of pt at p with the hint (see ch_dci_sing_value), and its gradient in
 * grad if not NULL. */
static double sing_value_grad(const ch_stepsing_point *pt, const double p[2], int curve, int side,
                              const double cp[2], double grad[2]) {
  if (curve >= 0 && cp && (side == CH_SIDE_LEFT || side == CH_SIDE_RIGHT)) {
    double dir[2] = {cp[0] - pt->p[0], cp[1] - pt->p[1]};
    /* a closest point at the point itself (beyond an end) names no arm */
    if (hypot(dir[0], dir[1]) > 1e-6) {
      int arm = ch_stepsing_arm_toward(pt, curve, dir);
      if (arm >= 0) return ch_stepsing_term_beside(pt, p, arm, (side == CH_SIDE_LEFT) == pt->arm_left_ccw[arm], grad);
    }
  }
  return ch_stepsing_term(pt, p, grad);
}

static double sing_value(const ch_stepsing_point *pt, const double p[2], int curve, int side, const double cp[2]) {
  return sing_value_grad(pt, p, curve, side, cp, NULL);
}

double ch_dci_sing_value(const ch_dci *d, int k, const double p[2], int curve, int side, const double cp[2]) {
  return sing_value(&d->sing[k], p, curve, side, cp);
}

double ch_dci_sing_window(const ch_dci *d, int k, const double p[2]) {
  const ch_stepsing_point *pt = &d->sing[k];
  return sing_phi(pt, hypot(p[0] - pt->p[0], p[1] - pt->p[1]));
}

/* phi T of point k at p with the hint. */
static double sing_term(const ch_dci *d, int k, const double p[2], int curve, int side, const double cp[2]) {
  const ch_stepsing_point *pt = &d->sing[k];
  double phi = sing_phi(pt, hypot(p[0] - pt->p[0], p[1] - pt->p[1]));
  return phi > 0.0 ? phi * sing_value(&d->sing[k], p, curve, side, cp) : 0.0;
}

/* The hint a texel's sample gives: its curve, side and closest point. */
static void texel_hint(const ch_samples *s, int x, int y, int *curve, int *side, double cp[2]) {
  size_t i = (size_t)y * s->width + x;
  *curve = (s->side[i] & CH_SIDE_END) ? -1 : s->curve[i];
  *side = s->side[i] & (CH_SIDE_LEFT | CH_SIDE_RIGHT);
  cp[0] = x + s->offset[2 * i];
  cp[1] = -y + s->offset[2 * i + 1];
}

int ch_dci_layers_at(const ch_dci *d, const double p[2], const int **items) {
  return d->num_layers ? ch_grid_query(&d->layer_grid, p[0], p[1], items) : 0;
}

double ch_dci_layer_window(const ch_dci *d, int k, const double p[2]) {
  const double *b = d->layers[k].box;
  double dx = p[0] < b[0] ? b[0] - p[0] : p[0] > b[2] ? p[0] - b[2] : 0.0;
  double dy = p[1] < b[1] ? b[1] - p[1] : p[1] > b[3] ? p[1] - b[3] : 0.0;
  return ch_stepsing_window(hypot(dx, dy), 0.5 * d->layer_far[k], d->layer_far[k]);
}

/* The sum of the windowed layers phi W at p; with n not NULL, at p moved a
 * hair along n (to one side of a curve p lies on). */
static double layers_sum(const ch_dci *d, const double p[2], const double n[2]) {
  const int *items;
  int m = ch_dci_layers_at(d, p, &items);
  double w = 0.0;
  for (int j = 0; j < m; j++) {
    const ch_dlayer *l = &d->layers[items[j]];
    double phi = ch_dci_layer_window(d, items[j], p);
    if (phi > 0.0) w += phi * (n ? ch_dlayer_value_beside(l, p, n) : ch_dlayer_value(l, p, NULL));
  }
  return w;
}

void ch_dci_side_normal(const ch_dci *d, size_t i, int side, double n[2]) {
  const ch_samples *s = &d->samples;
  double tg[2] = {1.0, 0.0};
  int seg = s->curve[i] >= 0 ? s->segment[i] : -1;
  /* the tangent from the layer's own pieces (in the texel frame); a curve
   * without a layer has no jump in W to take a side of */
  for (int k = 0; seg >= 0 && k < d->num_layers; k++) {
    const ch_dlayer *l = &d->layers[k];
    if (seg >= l->first_segment && seg < l->first_segment + l->num_pieces) {
      ch_bezier_direction((const double(*)[2])l->p[seg - l->first_segment], s->seg_t[i], tg);
      break;
    }
  }
  double sign = side == CH_SIDE_RIGHT ? -1.0 : 1.0;
  n[0] = -sign * tg[1];
  n[1] = sign * tg[0];
}

/* The texel frame of the samples: u, v to x right, y up, texel (x, y) at
 * (x, -y). */
static void to_texel_frame(const ch_samples *s, const double uv[2], double out[2]) {
  out[0] = (uv[0] - s->rect[0]) / s->texel[0] - 0.5;
  out[1] = (uv[1] - s->rect[3]) / s->texel[1] + 0.5;
}

static double border_distance(const ch_samples *s, const double p[2]) {
  /* the zero-flux line is half a texel beyond the outer centres */
  return fmin(fmin(p[0] + 0.5, s->width - 0.5 - p[0]), fmin(0.5 - p[1], p[1] + s->height - 0.5));
}

/* A double layer for every open sharp step subpath with a jump whose ends
 * both lie inside the grid. */
static ch_status layers_setup(const ch_curve_set *set, ch_dci *d, ch_error *err) {
  const ch_samples *s = &d->samples;
  d->layers = calloc((size_t)(set->num_subpaths > 0 ? set->num_subpaths : 1), sizeof *d->layers);
  if (!d->layers) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the double layers");
  for (int k = 0; k < set->num_subpaths; k++) {
    const ch_subpath *sp = &set->subpaths[k];
    if (sp->closed || sp->num_segments <= 0) continue;
    const ch_segment *first = &set->segments[sp->first_segment];
    const ch_curve *cv = &set->curves[first->curve];
    if (cv->kind != CH_CURVE_STEP || cv->blur > 0.0 || !(cv->left != cv->right)) continue;
    double a[2], b[2];
    to_texel_frame(s, first->p[0], a);
    to_texel_frame(s, set->segments[sp->first_segment + sp->num_segments - 1].p[2], b);
    if (border_distance(s, a) < CH_DCI_SING_MIN || border_distance(s, b) < CH_DCI_SING_MIN) continue;
    ch_dlayer *l = &d->layers[d->num_layers];
    l->p = malloc((size_t)sp->num_segments * sizeof *l->p);
    if (!l->p) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the double layers");
    l->curve = first->curve;
    l->first_segment = sp->first_segment;
    l->jump = cv->left - cv->right;
    l->num_pieces = sp->num_segments;
    l->box[0] = l->box[1] = INFINITY;
    l->box[2] = l->box[3] = -INFINITY;
    for (int i = 0; i < sp->num_segments; i++)
      for (int j = 0; j < 3; j++) {
        double *q = l->p[i][j];
        to_texel_frame(s, set->segments[sp->first_segment + i].p[j], q);
        l->box[0] = fmin(l->box[0], q[0]), l->box[1] = fmin(l->box[1], q[1]);
        l->box[2] = fmax(l->box[2], q[0]), l->box[3] = fmax(l->box[3], q[1]);
      }
    d->num_layers++;
  }
  if (!d->num_layers) {
    free(d->layers);
    d->layers = NULL;
    return CH_OK;
  }
  /* far = f L, L the box's diagonal, at least 24 texels: the largest f up
   * to 8 whose windows (on the grid) hold at most the budget's texels more
   * than the least windows do */
  d->layer_far = malloc((size_t)d->num_layers * sizeof *d->layer_far);
  double(*boxes)[4] = malloc((size_t)d->num_layers * sizeof *boxes);
  if (!d->layer_far || !boxes) {
    free(boxes);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the double layers");
  }
  double W = s->width, H = s->height, lo = 0.0, hi = 8.0;
  /* every layer gets at least its least window; the budget bounds what
   * they take beyond */
  double budget = CH_DCI_LAYER_BUDGET * W * H;
  for (int pass = 0; pass < 31; pass++) {
    double f = pass == 0 ? 0.0 : 0.5 * (lo + hi), area = 0.0;
    for (int k = 0; k < d->num_layers; k++) {
      const double *b = d->layers[k].box;
      double far = fmax(24.0, f * hypot(b[2] - b[0], b[3] - b[1]));
      double w = fmin(b[2] + far, W) - fmax(b[0] - far, 0.0), h = fmin(-b[1] + far, H) - fmax(-b[3] - far, 0.0);
      area += fmax(w, 0.0) * fmax(h, 0.0);
    }
    if (pass == 0) budget += area;
    else if (area <= budget) lo = f;
    else hi = f;
  }
  for (int k = 0; k < d->num_layers; k++) {
    const double *b = d->layers[k].box;
    double far = d->layer_far[k] = fmax(24.0, lo * hypot(b[2] - b[0], b[3] - b[1]));
    boxes[k][0] = b[0] - far, boxes[k][1] = b[1] - far;
    boxes[k][2] = b[2] + far, boxes[k][3] = b[3] + far;
  }
  ch_status st = ch_grid_build(&d->layer_grid, d->num_layers, (const double(*)[4])boxes, err);
  free(boxes);
  return st;
}

/* The wedge of h - W round a point: in each sector W adds a constant and
 * a slope in the angle (a layer through the point is constant on each
 * side, one ending there linear), read a hair from the point. */
static void subtract_layers(const ch_dci *d, ch_stepsing_point *pt) {
  int m = pt->num_arms;
  for (int k = 0; k < m; k++) {
    double span = (m == 1 ? pt->angle[0] + 2.0 * CH_PI : pt->angle[(k + 1) % m]) - pt->angle[k];
    if (!(span > 0.0)) span += 2.0 * CH_PI;
    double w[2];
    for (int j = 0; j < 2; j++) {
      double a = pt->angle[k] + span * (j + 1) / 3.0, q[2] = {pt->p[0] + 1e-4 * cos(a), pt->p[1] + 1e-4 * sin(a)};
      w[j] = layers_sum(d, q, NULL);
    }
    double slope = (w[1] - w[0]) / (span / 3.0);
    pt->value[k] -= w[0] - slope * span / 3.0;
    pt->slope[k] -= slope;
  }
}

/* The singular points of the sharp step curves in the texel frame, their
 * windows' radii and the grid over them. */
static ch_status sing_setup(const ch_curve_set *set, ch_dci *d, ch_error *err) {
  const ch_samples *s = &d->samples;
  ch_stepsing found;
  ch_status st = ch_stepsing_find(set, s->rect, &found, err);
  if (st || found.num_points == 0) {
    ch_stepsing_free(&found);
    return st;
  }
  int n = found.num_points;
  ch_stepsing_point *pts = found.points;
  double tu = s->texel[0], tv = s->texel[1];
  for (int i = 0; i < n; i++) {
    ch_stepsing_point *pt = &pts[i];
    pt->p[0] = (pt->p[0] - s->rect[0]) / tu - 0.5;
    pt->p[1] = (pt->p[1] - s->rect[3]) / tv + 0.5;
    /* directions and sector spans as the texel grid sees them (texels
     * need not be square); a sector's slope keeps its change of value */
    int m = pt->num_arms;
    double old_span[CH_STEPSING_MAX_ARMS], a[CH_STEPSING_MAX_ARMS];
    for (int k = 0; k < m; k++) {
      double sp = (m == 1 ? pt->angle[0] + 2.0 * CH_PI : pt->angle[(k + 1) % m]) - pt->angle[k];
      old_span[k] = sp > 0.0 ? sp : sp + 2.0 * CH_PI;
      a[k] = atan2(sin(pt->angle[k]) / tv, cos(pt->angle[k]) / tu);
      if (a[k] < 0.0) a[k] += 2.0 * CH_PI;
    }
    for (int k = 0; k < m; k++) pt->angle[k] = a[k];
    for (int k = 0; k < m; k++) {
      double sp = (m == 1 ? pt->angle[0] + 2.0 * CH_PI : pt->angle[(k + 1) % m]) - pt->angle[k];
      sp = sp > 0.0 ? sp : sp + 2.0 * CH_PI;
      pt->slope[k] *= old_span[k] / sp;
    }
  }
  /* the layers' ends, which drop out of the points below */
  double(*gone)[2] = malloc((size_t)n * sizeof *gone);
  int num_gone = 0;
  if (!gone) {
    ch_stepsing_free(&found);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the singular terms");
  }
  if (d->num_layers) {
    /* ends of curves with a layer are the layer's; the rest are wedges of
     * h - W, and those with no slope left drop out */
    double most_jump = 0.0;
    for (int k = 0; k < d->num_layers; k++) most_jump = fmax(most_jump, fabs(d->layers[k].jump));
    int kept = 0;
    for (int i = 0; i < n; i++) {
      ch_stepsing_point *pt = &pts[i];
      int layer_end = 0;
      for (int k = 0; pt->num_arms == 1 && k < d->num_layers; k++) {
        const ch_dlayer *l = &d->layers[k];
        const double *a = l->p[0][0], *b = l->p[l->num_pieces - 1][2];
        layer_end |= hypot(pt->p[0] - a[0], pt->p[1] - a[1]) < 1e-6 || hypot(pt->p[0] - b[0], pt->p[1] - b[1]) < 1e-6;
      }
      if (layer_end) {
        gone[num_gone][0] = pt->p[0], gone[num_gone++][1] = pt->p[1];
        continue;
      }
      subtract_layers(d, pt);
      double most = 0.0;
      for (int k = 0; k < pt->num_arms; k++) most = fmax(most, fabs(pt->slope[k]));
      if (!(most * 2.0 * CH_PI > 1e-6 * most_jump)) continue;
      pts[kept++] = *pt;
    }
    n = kept;
  }
  /* Windows stop half way to the next point, and at the layers' ends: a
   * wedge is h - W's expansion at its point only up to the next thing its
   * arms do. (Reaching past a dash's end, among 80 dashes, a crossing's
   * window moved h by 5% of a step and would not converge: 512^2 to
   * 4096^2 gave 0.684 to 0.734 at a point where 0.744-0.745 is right.) */
  st = n ? ch_stepsing_limit_radii(pts, n, CH_DCI_SING_RADIUS, err) : CH_OK;
  for (int i = 0; i < n; i++)
    for (int j = 0; j < num_gone; j++)
      pts[i].radius = fmin(pts[i].radius, hypot(pts[i].p[0] - gone[j][0], pts[i].p[1] - gone[j][1]));
  free(gone);
  if (st || !n) {
    ch_stepsing_free(&found);
    return st;
  }
  double(*boxes)[4] = st ? NULL : malloc((size_t)n * sizeof *boxes);
  if (!st && !boxes) st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for the singular terms");
  if (st) {
    ch_stepsing_free(&found);
    return st;
  }
  for (int i = 0; i < n; i++) {
    ch_stepsing_point *pt = &pts[i];
    /* the zero-flux line is half a texel beyond the outer centres */
    double edge = fmin(fmin(pt->p[0] + 0.5, s->width - 0.5 - pt->p[0]), fmin(0.5 - pt->p[1], pt->p[1] + s->height - 0.5));
    if (edge < CH_DCI_SING_MIN || pt->radius < CH_DCI_SING_MIN) pt->radius = 0.0;
    double r = pt->radius, *b = boxes[i];
    if (r > 0.0) {
      b[0] = pt->p[0] - r, b[1] = pt->p[1] - r, b[2] = pt->p[0] + r, b[3] = pt->p[1] + r;
    } else {
      b[0] = b[1] = 1.0, b[2] = b[3] = 0.0;
    }
  }
  st = ch_grid_build(&d->sing_grid, n, (const double(*)[4])boxes, err);
  free(boxes);
  if (st) {
    ch_stepsing_free(&found);
    return st;
  }
  d->sing = pts;
  d->num_sing = n;
  return CH_OK;
}

/* The texels of point k's window grown by `grow` texels: x0..x1, y0..y1
 * (texel indices). */
static void sing_texels(const ch_dci *d, int k, double grow, int r[4]) {
  const ch_stepsing_point *pt = &d->sing[k];
  double rad = pt->radius + grow;
  r[0] = (int)ceil(pt->p[0] - rad), r[2] = (int)floor(pt->p[0] + rad);
  r[1] = (int)ceil(-pt->p[1] - rad), r[3] = (int)floor(-pt->p[1] + rad);
  r[0] = r[0] < 0 ? 0 : r[0], r[1] = r[1] < 0 ? 0 : r[1];
  r[2] = r[2] > d->samples.width - 1 ? d->samples.width - 1 : r[2];
  r[3] = r[3] > d->samples.height - 1 ? d->samples.height - 1 : r[3];
}

/* Takes phi T out of values (channel 0 of `channels`): the fixed texels'
 * Dirichlet data and the free texels' guesses, and writes the ring's
 * source. */
/* The texels of layer k's window grown by `grow` texels. */
static void layer_texels(const ch_dci *d, int k, double grow, int r[4]) {
  const double *b = d->layers[k].box;
  double g = d->layer_far[k] + grow;
  r[0] = (int)ceil(b[0] - g), r[2] = (int)floor(b[2] + g);
  r[1] = (int)ceil(-b[3] - g), r[3] = (int)floor(-b[1] + g);
  r[0] = r[0] < 0 ? 0 : r[0], r[1] = r[1] < 0 ? 0 : r[1];
  r[2] = r[2] > d->samples.width - 1 ? d->samples.width - 1 : r[2];
  r[3] = r[3] > d->samples.height - 1 ? d->samples.height - 1 : r[3];
}

/* Takes the windowed layers out of values (channel 0): fixed texels hold
 * side value -
 * phi W on their side of their closest point, free texels' guesses lose
 * phi W, which `taken` sums at every texel centre (to be put back after
 * the solve). The source, by finite volumes as for the wedges: minus the flux
 * of phi W through the faces, less phi's part of W's (its continuous sum
 * round a cell is zero), from the product rule on the grid:
 * W_i Lap phi + sum (phi_n - phi_i)(W_n - W_i); at the border the face
 * drops out and leaves phi dW/dn (outward). */
static void layers_take_out(const ch_dci *d, float *values, int channels, float *source, float *taken) {
  const ch_samples *s = &d->samples;
  int W = s->width, H = s->height;
  /* rows in parallel, the layers whose windows reach a row inside: one
   * parallel region, and every texel written by one thread */
#pragma omp parallel for schedule(dynamic, 4)
  for (int y = 0; y < H; y++)
    for (int k = 0; k < d->num_layers; k++) {
      const ch_dlayer *l = &d->layers[k];
      int r[4];
      layer_texels(d, k, 1.0, r);
      if (y < r[1] || y > r[3]) continue;
      for (int x = r[0]; x <= r[2]; x++) {
        size_t i = (size_t)y * W + x;
        double c[2] = {x, -y}, phi = ch_dci_layer_window(d, k, c);
        if (d->fixed[i]) {
          double cp[2] = {x + s->offset[2 * i], -y + s->offset[2 * i + 1]}, nrm[2];
          double pc = ch_dci_layer_window(d, k, cp);
          if (pc > 0.0) {
            ch_dci_side_normal(d, i, s->side[i] & (CH_SIDE_LEFT | CH_SIDE_RIGHT), nrm);
            values[i * channels] -= (float)(pc * ch_dlayer_value_beside(l, cp, nrm));
          }
          if (phi > 0.0) taken[i] += (float)(phi * ch_dlayer_value(l, c, NULL));
          continue;
        }
        const double nb[4][2] = {{c[0] - 1, c[1]}, {c[0] + 1, c[1]}, {c[0], c[1] + 1}, {c[0], c[1] - 1}};
        const int present[4] = {x > 0, x < W - 1, y > 0, y < H - 1};
        double pn[4], lap = 0.0;
        int varies = 0;
        for (int j = 0; j < 4; j++) {
          pn[j] = ch_dci_layer_window(d, k, nb[j]);
          varies |= pn[j] != phi;
        }
        int border = !(present[0] && present[1] && present[2] && present[3]);
        if (!(phi > 0.0) && !varies) continue;
        double gw[2], w = ch_dlayer_value(l, c, gw);
        values[i * channels] -= (float)(phi * w);
        taken[i] += (float)(phi * w);
        if (!varies && !border) continue;
        double src = 0.0;
        for (int j = 0; j < 4; j++) {
          if (present[j]) {
            /* W_n - W_i by W's gradient: W is smooth where phi falls, and
             * the second-order parts cancel between opposite neighbours */
            lap += pn[j] - phi;
            src -= (pn[j] - phi) * (gw[0] * (nb[j][0] - c[0]) + gw[1] * (nb[j][1] - c[1]));
            continue;
          }
          double f[2] = {0.5 * (c[0] + nb[j][0]), 0.5 * (c[1] + nb[j][1])}, g[2];
          double pf = ch_dci_layer_window(d, k, f);
          if (!(pf > 0.0)) continue;
          ch_dlayer_value(l, f, g);
          src += pf * (g[0] * (nb[j][0] - c[0]) + g[1] * (nb[j][1] - c[1]));
        }
        source[i * channels] += (float)(src - w * lap);
      }
    }
}

static void sing_take_out(const ch_dci *d, float *values, int channels, float *source) {
  const ch_samples *s = &d->samples;
  int W = s->width;
  /* windows are disjoint: their texels can be written in parallel */
#pragma omp parallel for schedule(dynamic, 1)
  for (int k = 0; k < d->num_sing; k++) {
    const ch_stepsing_point *pt = &d->sing[k];
    if (!(pt->radius > 0.0)) continue;
    int r[4];
    sing_texels(d, k, 0.0, r);
    for (int y = r[1]; y <= r[3]; y++)
      for (int x = r[0]; x <= r[2]; x++) {
        double c[2] = {x, -y};
        if (!(hypot(c[0] - pt->p[0], c[1] - pt->p[1]) < pt->radius)) continue;
        size_t i = (size_t)y * W + x;
        int curve, side;
        double cp[2];
        texel_hint(s, x, y, &curve, &side, cp);
        /* fixed: the Dirichlet value of the remainder at the closest curve
         * point; free: the guess */
        values[i * channels] -= (float)sing_term(d, k, d->fixed[i] ? cp : c, curve, side, cp);
      }
  }
  /* The source, by finite volumes: Laplace rem = -Laplace (phi T) is, over
   * a texel's cell, the flux of rem through its faces equal to minus that
   * of phi T. Through a face to a neighbour, phi T's flux is taken as
   * T (phi_n - phi_i): with phi sampled, the fluxes of phi telescope to 0
   * over the grid as the integral of Laplace phi does (the continuous
   * phi'' + phi' / r sampled at the centres does not: phi is only C1, and
   * the jumps of phi'' fall between samples, a ring of unbalanced sources
   * that bent h by a few % of the step); phi's part of T's flux sums to
   * the integral of grad phi . grad T = 0 round a cell. At the border the
   * zero flux of h leaves rem the flux of -phi T: the face drops out of
   * the balance, which leaves the other faces' phi dT/dn, that is minus
   * the border face's. So windows need not stop at the border. The
   * discrete Laplacian reaches a texel beyond the window, where windows
   * may meet: summed, one point after the other. */
  int H = s->height;
  for (int k = 0; k < d->num_sing; k++) {
    const ch_stepsing_point *pt = &d->sing[k];
    if (!(pt->radius > 0.0)) continue;
    int r[4];
    sing_texels(d, k, 1.0, r);
    double r0 = CH_DCI_SING_INNER * pt->radius;
    for (int y = r[1]; y <= r[3]; y++)
      for (int x = r[0]; x <= r[2]; x++) {
        double c[2] = {x, -y}, rad = hypot(c[0] - pt->p[0], c[1] - pt->p[1]);
        size_t i = (size_t)y * W + x;
        if (!(rad < pt->radius + 1.0) || d->fixed[i]) continue;
        int border = x == 0 || y == 0 || x == W - 1 || y == H - 1;
        if (!(rad > r0 - 1.0) && !border) continue;
        double lap = 0.0, phi = sing_phi(pt, rad), flux = 0.0;
        const double nb[4][2] = {{c[0] - 1, c[1]}, {c[0] + 1, c[1]}, {c[0], c[1] + 1}, {c[0], c[1] - 1}};
        const int present[4] = {x > 0, x < W - 1, y > 0, y < H - 1};
        int curve, side;
        double cp[2], g[2];
        texel_hint(s, x, y, &curve, &side, cp);
        for (int j = 0; j < 4; j++) {
          if (present[j]) {
            lap += sing_phi(pt, hypot(nb[j][0] - pt->p[0], nb[j][1] - pt->p[1])) - phi;
            continue;
          }
          /* the border face, half way to the missing neighbour */
          double f[2] = {0.5 * (c[0] + nb[j][0]), 0.5 * (c[1] + nb[j][1])};
          double pf = sing_phi(pt, hypot(f[0] - pt->p[0], f[1] - pt->p[1]));
          if (!(pf > 0.0)) continue;
          sing_value_grad(pt, f, curve, side, cp, g);
          flux += pf * (g[0] * (nb[j][0] - c[0]) + g[1] * (nb[j][1] - c[1]));
        }
        if (lap == 0.0 && flux == 0.0) continue;
        source[i * channels] += (float)(flux - sing_value(pt, c, curve, side, cp) * lap);
      }
  }
}

/* Puts phi T back at every texel centre. */
static void sing_put_back(const ch_dci *d, float *values, int channels) {
  int W = d->samples.width;
#pragma omp parallel for schedule(dynamic, 1)
  for (int k = 0; k < d->num_sing; k++) {
    const ch_stepsing_point *pt = &d->sing[k];
    if (!(pt->radius > 0.0)) continue;
    int r[4];
    sing_texels(d, k, 0.0, r);
    for (int y = r[1]; y <= r[3]; y++)
      for (int x = r[0]; x <= r[2]; x++) {
        double c[2] = {x, -y};
        if (!(hypot(c[0] - pt->p[0], c[1] - pt->p[1]) < pt->radius)) continue;
        int curve, side;
        double cp[2];
        texel_hint(&d->samples, x, y, &curve, &side, cp);
        values[((size_t)y * W + x) * channels] += (float)sing_term(d, k, c, curve, side, cp);
      }
  }
}

/* Separable Gaussian with a radius per texel (in texels); axis 0 blurs
 * along x, 1 along y. Borders clamp (zero flux). */
static void blur_pass(int W, int H, int channels, const float *sigma, const float *in, float *out, int axis) {
#pragma omp parallel for schedule(dynamic, 8)
  for (int y = 0; y < H; y++) {
    for (int x = 0; x < W; x++) {
      size_t i = (size_t)y * W + x;
      float s = sigma[i];
      int k = (int)floorf(3.0f * s);
      if (s < 0.25f || k < 1) {
        for (int c = 0; c < channels; c++) out[i * channels + c] = in[i * channels + c];
        continue;
      }
      /* Taps j = 0, +-1, ...: w_j = exp(-j^2 / 2s^2) by the recurrence
       * w_{j+1} = w_j a_j, a_{j+1} = a_j b (b = exp(-1/s^2)): two products
       * a tap instead of an exp. */
      double acc[4], wsum = 1.0, w = 1.0, step = exp(-0.5 / ((double)s * s)), b = step * step;
      for (int c = 0; c < channels; c++) acc[c] = in[i * channels + c];
      for (int j = 1; j <= k; j++) {
        w *= step;
        step *= b;
        int lo = axis == 0 ? x - j : y - j, hi = axis == 0 ? x + j : y + j, lim = axis == 0 ? W : H;
        lo = lo < 0 ? 0 : lo;
        hi = hi >= lim ? lim - 1 : hi;
        size_t nl = axis == 0 ? (size_t)y * W + lo : (size_t)lo * W + x;
        size_t nh = axis == 0 ? (size_t)y * W + hi : (size_t)hi * W + x;
        for (int c = 0; c < channels; c++) acc[c] += w * ((double)in[nl * channels + c] + in[nh * channels + c]);
        wsum += 2.0 * w;
      }
      for (int c = 0; c < channels; c++) out[i * channels + c] = (float)(acc[c] / wsum);
    }
  }
}

/* Blurs h (and rgb) where curves carry data-blur. values holds the diffused
 * channels interleaved (h, [r g b]); sigma is the diffused radius field,
 * capped here and kept as d->blur. */
/* ---- fixed texels' values extrapolated to their centres (ch_dci.h) ---- */

/* A fixed texel whose value is extrapolated: the first (top left) of the
 * 2 x 2 texels of its probe, their bilinear weights, and d / D. */
typedef struct ghost {
  size_t texel, probe;
  float weight[4];
  float ratio;
} ghost;

/* The probe of fixed texel i, if every texel of its bilinear footprint is
 * on the same side of the same curve (nearest), not at an end and at
 * least half a texel off the curve: else the probe would read another
 * region (the far side of a slab thinner than D, another curve). */
static int ghost_make(const ch_samples *s, size_t i, ghost *g) {
  int R = s->width, H = s->height, x = (int)(i % (size_t)R), y = (int)(i / (size_t)R);
  double d = s->distance[i];
  if (!(d > 1e-4)) return 0; /* on the curve: its value is the curve's */
  const double D = CH_DCI_EXTRAPOLATE_PROBE;
  /* offset = SP - centre (x right, y up); the probe is SP + D n with n
   * the unit vector from SP to the centre, in texel-centre coordinates
   * (rows down) */
  double ox = s->offset[2 * i], oy = s->offset[2 * i + 1];
  double px = x + ox - D * ox / d, py = y - (oy - D * oy / d);
  double fx0 = floor(px), fy0 = floor(py);
  if (!(fx0 >= 0.0 && fy0 >= 0.0 && fx0 + 1.0 < R && fy0 + 1.0 < H)) return 0;
  int x0 = (int)fx0, y0 = (int)fy0;
  double fx = px - fx0, fy = py - fy0;
  int curve = s->curve[i], side = s->side[i] & (CH_SIDE_LEFT | CH_SIDE_RIGHT);
  for (int k = 0; k < 4; k++) {
    size_t j = (size_t)(y0 + (k >> 1)) * R + (size_t)(x0 + (k & 1));
    if (s->curve[j] != curve || (s->side[j] & (CH_SIDE_LEFT | CH_SIDE_RIGHT)) != side || (s->side[j] & CH_SIDE_END) ||
        !(s->distance[j] >= 0.5f))
      return 0;
  }
  g->texel = i;
  g->probe = (size_t)y0 * R + (size_t)x0;
  g->weight[0] = (float)((1.0 - fx) * (1.0 - fy));
  g->weight[1] = (float)(fx * (1.0 - fy));
  g->weight[2] = (float)((1.0 - fx) * fy);
  g->weight[3] = (float)(fx * fy);
  g->ratio = (float)(d / D);
  return 1;
}

/* The fixed texels that extrapolate, in texel order, with their values as
 * the first solve held them (base, channels each). */
static ch_status ghosts_setup(const ch_dci *d, int channels, const float *values, ghost **out, float **base,
                              size_t *count, ch_error *err) {
  const ch_samples *s = &d->samples;
  size_t n = (size_t)s->width * s->height, m = 0;
  *out = NULL, *base = NULL, *count = 0;
  for (size_t i = 0; i < n; i++) m += d->fixed[i];
  if (!m) return CH_OK;
  ghost *g = malloc(m * sizeof *g);
  if (!g) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the fixed texels' extrapolation");
  size_t k = 0;
  for (size_t i = 0; i < n; i++)
    if (d->fixed[i] && ghost_make(s, i, &g[k])) k++;
  float *b = k ? malloc(k * channels * sizeof *b) : NULL;
  if (k && !b) {
    free(g);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the fixed texels' extrapolation");
  }
  for (size_t j = 0; j < k; j++) memcpy(b + j * channels, values + g[j].texel * channels, channels * sizeof *b);
  *out = g, *base = b, *count = k;
  return CH_OK;
}

/* One round: every ghost's value from the current solution (all read
 * before any is written: the same bytes on any thread count). Returns
 * whether any value changed (where h is one value per region, as between
 * closed curves of one value all round, none does and no solve is due). */
static int ghosts_update(const ghost *g, size_t count, int width, const float *base, int channels, float *values,
                         float *next) {
  const size_t offset[4] = {0, 1, (size_t)width, (size_t)width + 1};
  int changed = 0;
#pragma omp parallel for schedule(static) reduction(| : changed)
  for (size_t j = 0; j < count; j++)
    for (int c = 0; c < channels; c++) {
      double u = 0.0;
      for (int k = 0; k < 4; k++) u += (double)g[j].weight[k] * values[(g[j].probe + offset[k]) * channels + c];
      double v = base[j * channels + c];
      float old = values[g[j].texel * channels + c];
      next[j * channels + c] = (float)(old + CH_DCI_EXTRAPOLATE_OMEGA * (v + g[j].ratio * (u - v) - old));
      changed |= next[j * channels + c] != old;
    }
  if (!changed) return 0;
#pragma omp parallel for schedule(static)
  for (size_t j = 0; j < count; j++)
    memcpy(values + g[j].texel * channels, next + j * channels, channels * sizeof *values);
  return 1;
}

/* The cap on the blur radius, per texel (W x H over rect): a third of the
 * distance to the nearest sharp step curve over sqrt 2, INFINITY where there
 * is none; *cap NULL when no step curve is sharp. Made before the DCI's
 * own samples, so that the two sets of samples are not held at once (they
 * were most of the peak memory of a displacement with blurred steps). */
static ch_status sharp_caps(const ch_curve_set *set, int W, int H, const double rect[4], float **cap, ch_error *err) {
  *cap = NULL;
  unsigned char *sharp = calloc((size_t)(set->num_curves > 0 ? set->num_curves : 1), 1);
  if (!sharp) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the reblur");
  int any_sharp = 0;
  for (int c = 0; c < set->num_curves; c++) {
    sharp[c] = set->curves[c].kind == CH_CURVE_STEP && set->curves[c].blur == 0.0;
    any_sharp |= sharp[c];
  }
  ch_samples sharp_samples = {0};
  ch_status st =
      any_sharp ? ch_samples_build_subset(set, sharp, W, H, rect, CH_DCI_SAMPLE_BAND, 0, &sharp_samples, err) : CH_OK;
  free(sharp);
  if (st || !any_sharp) return st;
  size_t n = (size_t)W * H;
  if (!(*cap = malloc(n * sizeof **cap))) {
    ch_samples_free(&sharp_samples);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the reblur");
  }
#pragma omp parallel for schedule(static)
  for (size_t i = 0; i < n; i++)
    (*cap)[i] = sharp_samples.curve[i] >= 0 ? sharp_samples.distance[i] / (3.0f * 1.41421356f) : INFINITY;
  ch_samples_free(&sharp_samples);
  return CH_OK;
}

/* cap: sharp_caps' (NULL: no cap). */
static ch_status reblur(const ch_dci_desc *desc, ch_dci *d, float *values, int channels, float *sigma, const float *cap,
                        ch_error *err) {
  ch_samples *s = &d->samples;
  int W = s->width, H = s->height;
  size_t n = (size_t)W * H;
  /* In warped UV a radius in UV spans its axis' slope times as many texels
   * along that axis: one radius field per pass, each capped. */
  int scaled = desc->blur_scale[0] || desc->blur_scale[1];
  float *tmp = malloc(n * channels * sizeof *tmp);
  float *sigma_y = scaled ? malloc(n * sizeof *sigma_y) : NULL;
  if (!tmp || (scaled && !sigma_y)) {
    free(tmp);
    free(sigma_y);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the reblur");
  }
#pragma omp parallel for schedule(static)
  for (size_t i = 0; i < n; i++) {
    float cap_i = cap ? cap[i] : INFINITY;
    float sx = sigma[i], sy = sigma[i];
    if (scaled) {
      if (desc->blur_scale[0]) sx *= desc->blur_scale[0][i % (size_t)W];
      if (desc->blur_scale[1]) sy *= desc->blur_scale[1][i / (size_t)W];
    }
    sx = sx > cap_i ? cap_i : sx;
    sy = sy > cap_i ? cap_i : sy;
    sigma[i] = sx > 0.0f ? sx : 0.0f;
    if (scaled) sigma_y[i] = sy > 0.0f ? sy : 0.0f;
  }
  d->blur = sigma;
  blur_pass(W, H, channels, sigma, values, tmp, 0);
  blur_pass(W, H, channels, scaled ? sigma_y : sigma, tmp, values, 1);
  if (scaled) /* kept: the geometric mean of the two radii */
    for (size_t i = 0; i < n; i++) sigma[i] = sqrtf(sigma[i] * sigma_y[i]);
  free(sigma_y);
  free(tmp);
  return CH_OK;
}

ch_status ch_dci_build(const ch_curve_set *set, const ch_dci_desc *desc, ch_dci *d, ch_error *err) {
  memset(d, 0, sizeof *d);
  int R = desc->resolution;
  double rect[4] = {desc->rect[0], desc->rect[1], desc->rect[2], desc->rect[3]};
  if (rect[0] == 0.0 && rect[1] == 0.0 && rect[2] == 0.0 && rect[3] == 0.0) rect[2] = rect[3] = 1.0;
  int any_blur = 0;
  for (int c = 0; c < set->num_curves; c++)
    if (set->curves[c].kind == CH_CURVE_STEP && set->curves[c].blur > 0.0) any_blur = 1;
  double t0 = ch_progress_seconds();
  float *cap = NULL;
  ch_status st = any_blur ? sharp_caps(set, R, R, rect, &cap, err) : CH_OK;
  if (st) return st;
  double seconds_caps = ch_progress_seconds() - t0;
  t0 = ch_progress_seconds();
  st = ch_samples_build_subset(set, NULL, R, R, rect, CH_DCI_SAMPLE_BAND, !desc->no_colors, &d->samples, err);
  if (st) {
    free(cap);
    return st;
  }
  d->seconds_samples = ch_progress_seconds() - t0;
  ch_samples *s = &d->samples;
  size_t n = (size_t)R * R;
  int colors = s->num_colors; /* (0 with no_colors: the samples were made without) */
  int channels = 1 + colors;
  float *values = malloc(n * channels * sizeof *values);
  float *sigma = any_blur ? malloc(n * sizeof *sigma) : NULL;
  d->fixed = calloc(n, 1);
  d->h = malloc(n * sizeof *d->h);
  if (colors) d->rgb = malloc(3 * n * sizeof *d->rgb);
  if (!values || (any_blur && !sigma) || !d->fixed || !d->h || (colors && !d->rgb)) {
    free(values);
    free(sigma);
    free(cap);
    ch_dci_free(d);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for a %dx%d diffusion-curve image", R, R);
  }
  double texel = sqrt(s->texel[0] * s->texel[1]);
  for (size_t i = 0; i < n; i++) {
    int fixed = s->curve[i] >= 0 && s->exact[i] && !(s->side[i] & CH_SIDE_END) &&
                s->distance[i] <= CH_DCI_FIXED_BAND;
    d->fixed[i] = (unsigned char)fixed;
    /* Free texels start from their nearest curve's side: a good guess. */
    float *v = values + i * channels;
    v[0] = s->curve[i] >= 0 ? s->value[2 * i] : 0.0f;
    for (int c = 0; c < colors; c++) v[1 + c] = s->curve[i] >= 0 ? s->color[6 * i + c] : 0.0f;
    if (any_blur) sigma[i] = s->curve[i] >= 0 ? (float)(set->curves[s->curve[i]].blur / texel) : 0.0f;
  }
  float *source = NULL, *taken = NULL;
  t0 = ch_progress_seconds();
  if (!desc->no_singular) {
    int any_fixed = 0;
    for (size_t i = 0; i < n && !any_fixed; i++) any_fixed = d->fixed[i];
    /* without a fixed texel h is one constant: nothing to take out */
    if (any_fixed) st = layers_setup(set, d, err);
    if (!st && any_fixed) st = sing_setup(set, d, err);
    if (!st && (d->num_sing || d->num_layers)) {
      source = calloc(n * channels, sizeof *source);
      taken = d->num_layers ? calloc(n, sizeof *taken) : NULL;
      if (!source || (d->num_layers && !taken))
        st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for the singular terms");
      if (!st && d->num_layers) layers_take_out(d, values, channels, source, taken);
      if (!st && d->num_sing) sing_take_out(d, values, channels, source);
    }
    if (st) {
      free(source);
      free(taken);
      free(values);
      free(sigma);
      free(cap);
      ch_dci_free(d);
      return st;
    }
  }
  d->seconds_terms = ch_progress_seconds() - t0;
  t0 = ch_progress_seconds();
  ch_diffuse_desc dd = {.tolerance = desc->tolerance, .source = source};
  ghost *ghosts = NULL;
  float *ghost_base = NULL, *ghost_next = NULL;
  size_t num_ghosts = 0;
  if (!desc->no_extrapolate) {
    st = ghosts_setup(d, channels, values, &ghosts, &ghost_base, &num_ghosts, err);
    if (!st && num_ghosts && !(ghost_next = malloc(num_ghosts * channels * sizeof *ghost_next)))
      st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for the fixed texels' extrapolation");
  }
  /* the solves before the last only feed the next round's ghosts */
  ch_diffuse_desc loose = dd;
  if (num_ghosts) loose.tolerance = fmax(CH_DCI_EXTRAPOLATE_TOLERANCE, dd.tolerance);
  if (!st) st = ch_diffuse_solve(R, R, channels, d->fixed, values, &loose, &d->stats, err);
  int rounds = 0;
  while (!st && num_ghosts) {
    int update = rounds < CH_DCI_EXTRAPOLATE_ROUNDS && ghosts_update(ghosts, num_ghosts, R, ghost_base, channels, values,
                                                                     ghost_next);
    rounds += update;
    /* the last solve is at the caller's tolerance (also when nothing
     * changed: the first was looser) */
    int final = !update || rounds == CH_DCI_EXTRAPOLATE_ROUNDS;
    ch_diffuse_stats more;
    st = ch_diffuse_solve(R, R, channels, d->fixed, values, final ? &dd : &loose, &more, err);
    if (!st) {
      more.iterations += d->stats.iterations;
      more.seconds += d->stats.seconds;
      d->stats = more;
    }
    if (final) break;
  }
  d->extrapolations = rounds;
  free(ghosts);
  free(ghost_base);
  free(ghost_next);
  free(source);
  double t1 = ch_progress_seconds();
  if (!st && d->num_sing) sing_put_back(d, values, channels);
  if (!st && taken)
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++) values[i * channels] += taken[i];
  free(taken);
  d->seconds_terms += ch_progress_seconds() - t1;
  t0 += ch_progress_seconds() - t1; /* the put-back is the terms' time, not the diffusion's */
  if (!st && any_blur) {
    /* The blur radius on its own: a radius needs no 1e-6 (1e-3 is far
     * below a texel), and a lone channel runs the solver's 1-lane path
     * where a fifth channel would cost as much as eight. */
    ch_diffuse_desc ds = {.tolerance = fmax(1e-3, desc->tolerance)};
    st = ch_diffuse_solve(R, R, 1, d->fixed, sigma, &ds, NULL, err);
  }
  d->seconds_diffuse = ch_progress_seconds() - t0;
  if (!st && any_blur) {
    t0 = ch_progress_seconds();
    st = reblur(desc, d, values, channels, sigma, cap, err);
    if (!st) sigma = NULL; /* now d->blur */
    d->seconds_blur = seconds_caps + ch_progress_seconds() - t0;
  }
  free(sigma);
  free(cap);
  if (st) {
    free(values);
    ch_dci_free(d);
    return st;
  }
  for (size_t i = 0; i < n; i++) {
    d->h[i] = values[i * channels];
    for (int c = 0; c < colors; c++) d->rgb[3 * i + c] = values[i * channels + 1 + c];
  }
  free(values);
  return CH_OK;
}

/* ---- EXR layers ---- */

enum {
  L_H, L_R, L_G, L_B, L_OPP_H, L_OPP_R, L_OPP_G, L_OPP_B, L_DIST, L_SPU, L_SPV, L_CHAIN, L_T,
  L_CURVE, L_SIDE, L_EXACT, L_FIXED, L_BLUR, NUM_LAYERS
};
/* One-value layers of more than one letter are written NAME.X (Blender's
 * multilayer reader, like its own index passes, wants a layer and a
 * one-letter channel); files of before are read by their bare names. */
static const char *layer_names[NUM_LAYERS] = {
    "h", "R", "G", "B", "opp.h", "opp.R", "opp.G", "opp.B", "distance.X", "sp.u", "sp.v", "chain.X", "t",
    "curve.X", "side.X", "exact.X", "fixed.X", "blur.X"};

static int find_layer(const ch_image *img, int layer) {
  int i = ch_image_find(img, layer_names[layer]);
  size_t n = strlen(layer_names[layer]);
  if (i < 0 && n > 2 && !strcmp(layer_names[layer] + n - 2, ".X")) {
    char bare[32];
    snprintf(bare, sizeof bare, "%.*s", (int)(n - 2), layer_names[layer]);
    i = ch_image_find(img, bare);
  }
  return i;
}

static int layer_present(const ch_dci *d, int layer) {
  if (layer == L_R || layer == L_G || layer == L_B || (layer >= L_OPP_R && layer <= L_OPP_B))
    return d->rgb != NULL;
  if (layer == L_BLUR) return d->blur != NULL;
  return 1;
}

ch_status ch_dci_to_image(const ch_dci *d, ch_image *out, ch_error *err) {
  const ch_samples *s = &d->samples;
  const char *names[NUM_LAYERS];
  int map[NUM_LAYERS], count = 0;
  for (int l = 0; l < NUM_LAYERS; l++) {
    map[l] = -1;
    if (layer_present(d, l)) {
      map[l] = count;
      names[count++] = layer_names[l];
    }
  }
  ch_status st = ch_image_init(out, s->width, s->height, count, names, err);
  if (st) return st;
  size_t n = (size_t)s->width * s->height;
  for (size_t i = 0; i < n; i++) {
    int x = (int)(i % (size_t)s->width), y = (int)(i / (size_t)s->width);
    double c[2];
    ch_samples_center(s, x, y, c);
    float v[NUM_LAYERS] = {0};
    v[L_H] = d->h[i];
    v[L_OPP_H] = s->value[2 * i + 1];
    if (d->rgb)
      for (int k = 0; k < 3; k++) {
        v[L_R + k] = d->rgb[3 * i + k];
        v[L_OPP_R + k] = s->color[6 * i + 3 + k];
      }
    v[L_DIST] = s->curve[i] >= 0 ? s->distance[i] : INFINITY;
    v[L_SPU] = (float)(c[0] + s->offset[2 * i] * s->texel[0]);
    v[L_SPV] = (float)(c[1] + s->offset[2 * i + 1] * s->texel[1]);
    v[L_CHAIN] = (float)s->chain[i];
    v[L_T] = s->param[i];
    v[L_CURVE] = (float)s->curve[i];
    v[L_SIDE] = (float)s->side[i];
    v[L_EXACT] = (float)s->exact[i];
    v[L_FIXED] = (float)d->fixed[i];
    if (d->blur) v[L_BLUR] = d->blur[i];
    for (int l = 0; l < NUM_LAYERS; l++)
      if (map[l] >= 0) ch_image_plane(out, map[l])[i] = v[l];
  }
  return CH_OK;
}

ch_status ch_dci_from_image(const ch_image *img, const double rect[4], const char *name, ch_dci *d,
                            ch_error *err) {
  memset(d, 0, sizeof *d);
  int idx[NUM_LAYERS];
  for (int l = 0; l < NUM_LAYERS; l++) idx[l] = find_layer(img, l);
  static const int required[] = {L_H, L_OPP_H, L_DIST, L_SPU, L_SPV, L_CHAIN, L_T, L_CURVE, L_SIDE, L_EXACT};
  for (size_t k = 0; k < sizeof required / sizeof required[0]; k++)
    if (idx[required[k]] < 0)
      return ch_error_set(err, CH_ERR_INPUT, "%s: not a chisel DCI: no '%s' layer (write it with chisel dci)",
                          name, layer_names[required[k]]);
  int colors = idx[L_R] >= 0 && idx[L_G] >= 0 && idx[L_B] >= 0 && idx[L_OPP_R] >= 0 && idx[L_OPP_G] >= 0 &&
               idx[L_OPP_B] >= 0;
  ch_samples *s = &d->samples;
  int W = img->width, H = img->height;
  size_t n = (size_t)W * H;
  s->width = W;
  s->height = H;
  memcpy(s->rect, rect, sizeof s->rect);
  s->texel[0] = (rect[2] - rect[0]) / W;
  s->texel[1] = (rect[3] - rect[1]) / H;
  s->band = CH_DCI_SAMPLE_BAND;
  s->num_colors = colors ? 3 : 0;
#define ALLOC(p, count) (((p) = calloc((count), sizeof *(p))) != NULL)
  int ok = ALLOC(s->offset, 2 * n) && ALLOC(s->distance, n) && ALLOC(s->curve, n) && ALLOC(s->segment, n) &&
           ALLOC(s->seg_t, n) && ALLOC(s->chain, n) && ALLOC(s->param, n) && ALLOC(s->side, n) &&
           ALLOC(s->exact, n) && ALLOC(s->value, 2 * n) && ALLOC(d->h, n) && ALLOC(d->fixed, n);
  if (ok && colors) ok = ALLOC(s->color, 6 * n) && ALLOC(d->rgb, 3 * n);
  if (ok && idx[L_BLUR] >= 0) ok = ALLOC(d->blur, n);
#undef ALLOC
  if (!ok) {
    ch_dci_free(d);
    return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory", name);
  }
#define L(layer) ch_image_plane(img, idx[layer])[i]
  for (size_t i = 0; i < n; i++) {
    int x = (int)(i % (size_t)W), y = (int)(i / (size_t)W);
    double c[2];
    ch_samples_center(s, x, y, c);
    float curve = L(L_CURVE), side = L(L_SIDE), chain = L(L_CHAIN);
    if (!(curve >= -1.0f && curve < 16777216.0f && curve == floorf(curve)) || !(side >= 0.0f && side < 32.0f && side == floorf(side)) ||
        !(chain >= -1.0f && chain < 16777216.0f) || !isfinite(L(L_H)) || !isfinite(L(L_OPP_H))) {
      ch_dci_free(d);
      return ch_error_set(err, CH_ERR_INPUT, "%s: pixel (%d, %d): DCI layers out of range", name, x, y);
    }
    d->h[i] = L(L_H);
    s->value[2 * i] = L(L_H);
    s->value[2 * i + 1] = L(L_OPP_H);
    s->curve[i] = (int32_t)curve;
    s->chain[i] = (int32_t)chain;
    s->param[i] = L(L_T);
    s->side[i] = (uint8_t)side;
    s->exact[i] = L(L_EXACT) != 0.0f;
    s->distance[i] = L(L_DIST);
    s->segment[i] = -1; /* segments are not stored: the curves are not known here */
    if (s->curve[i] >= 0) {
      s->offset[2 * i] = (float)((L(L_SPU) - c[0]) / s->texel[0]);
      s->offset[2 * i + 1] = (float)((L(L_SPV) - c[1]) / s->texel[1]);
    }
    if (idx[L_FIXED] >= 0) d->fixed[i] = L(L_FIXED) != 0.0f;
    if (colors)
      for (int k = 0; k < 3; k++) {
        d->rgb[3 * i + k] = L(L_R + k);
        s->color[6 * i + k] = L(L_R + k);
        s->color[6 * i + 3 + k] = L(L_OPP_R + k);
      }
    if (d->blur) d->blur[i] = L(L_BLUR);
  }
#undef L
  return CH_OK;
}
