/* The true surface of docs/spec.md §3 over the planar base, intersected exactly
 * (see ch_truth.h for the method and why). The cell walk and bisection
 * follow the path-based-grooves paper §5.1 (Algorithm 1: skip texels whose
 * maximum height the ray passes over), with conservative bounds instead of
 * stored per-texel maxima, and bisection instead of per-profile facets so
 * that any profile, crossing and step is handled by the same code. */
#include "ch_truth.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ch_bezier.h"
#include "ch_grid.h"
#include "ch_math.h"

/* A min/max pyramid of the step texels' values (each texel: its own value
 * and, next to a curve, the value across it, which the blend may use). */
typedef struct step_pyramid {
  int levels;
  int w[24], h[24];
  float *lo[24], *hi[24];
} step_pyramid;

struct ch_truth {
  const ch_height *height;
  const ch_curve_set *set;
  int grid, tiles;
  double tol, cell, radius; /* cell size, half its diagonal */
  double *lo, *hi;          /* per cell, row-major (row = v index) */
  double *tile_lo, *tile_hi;
  double zmin, zmax;
  double jump_eps;          /* smallest jump of h taken as a wall */
  ch_grid seg_grid;         /* groove segments grown by w/2 + 2 radius */
  double (*seg_boxes)[4];
  unsigned char *symmetric; /* per curve: P(t) = P(-t) */
  step_pyramid steps;
};

/* ---- profiles (their value and slope: ch_profile_eval, ch_profile_slope) ---- */

/* The range of P over [a, b]: its ends, 0 (the extremum of u), and every
 * break point inside with both one-sided values (walls jump there). */
static void profile_range(const ch_profile *pr, double a, double b, double *lo, double *hi) {
  double creases[CH_PROFILE_MAX_POINTS + 4];
  int n = ch_profile_creases(pr, creases, CH_PROFILE_MAX_POINTS + 2);
  creases[n++] = 0.0;
  double pa = ch_profile_eval(pr, a), pb = ch_profile_eval(pr, b);
  double l = fmin(pa, pb), h = fmax(pa, pb);
  const double eps = 1e-12;
  for (int k = 0; k < n; k++) {
    double c = creases[k];
    if (!(c >= a && c <= b)) continue;
    double ts[3] = {c, fmax(a, c - eps), fmin(b, c + eps)};
    for (int j = 0; j < 3; j++) {
      double p = ch_profile_eval(pr, ts[j]);
      l = fmin(l, p);
      h = fmax(h, p);
    }
  }
  *lo = l;
  *hi = h;
}

static int profile_is_symmetric(const ch_profile *pr) {
  if (pr->kind != CH_PROFILE_CUSTOM) return pr->kind != CH_PROFILE_BEVEL;
  for (int k = 0; k <= 1000; k++) {
    double t = 0.5 * k / 1000.0;
    if (fabs(ch_profile_eval(pr, t) - ch_profile_eval(pr, -t)) > 1e-12) return 0;
  }
  for (int i = 0; i < pr->num_points; i++)
    if (fabs(ch_profile_eval(pr, pr->t[i]) - ch_profile_eval(pr, -pr->t[i])) > 1e-12) return 0;
  return 1;
}

/* ---- step bounds ---- */

static void pyramid_free(step_pyramid *p) {
  for (int l = 0; l < p->levels; l++) {
    free(p->lo[l]);
    free(p->hi[l]);
  }
  memset(p, 0, sizeof *p);
}

/* Widens the finest level's bounds by `widen` over the texels of a box
 * (u0, v0, u1, v1) in the DCI's texel frame (x right, y up: texel (x, y) at
 * (x, -y)). */
static void widen_box(step_pyramid *p, int W, int H, double u0, double v0, double u1, double v1, float widen) {
  int x0 = ch_clampi((int)floor(u0), 0, W - 1), x1 = ch_clampi((int)ceil(u1), 0, W - 1);
  int y0 = ch_clampi((int)floor(-v1), 0, H - 1), y1 = ch_clampi((int)ceil(-v0), 0, H - 1);
  for (int y = y0; y <= y1; y++)
    for (int x = x0; x <= x1; x++) {
      p->lo[0][(size_t)y * W + x] -= widen;
      p->hi[0][(size_t)y * W + x] += widen;
    }
}

static ch_status pyramid_build(step_pyramid *p, const ch_dci *d, ch_error *err) {
  const ch_samples *s = &d->samples;
  int W = s->width, H = s->height;
  memset(p, 0, sizeof *p);
  p->w[0] = W;
  p->h[0] = H;
  p->lo[0] = malloc((size_t)W * H * sizeof(float));
  p->hi[0] = malloc((size_t)W * H * sizeof(float));
  p->levels = 1;
  if (!p->lo[0] || !p->hi[0]) goto nomem;
  for (size_t i = 0; i < (size_t)W * H; i++) {
    float a = d->h[i], b = s->curve[i] >= 0 ? s->value[2 * i + 1] : a;
    p->lo[0][i] = fminf(a, b);
    p->hi[0][i] = fmaxf(a, b);
  }
  /* In a singular window the reconstruction blends h less phi T and adds
   * phi T at the point (ch_dci.h): both terms lie in [min(0, T), max(0, T)]
   * over the point's sectors, so h can leave its texels' range by that
   * span. Texels within a cell's diagonal of a window blend into it. */
  /* The double layers likewise within their windows: W's part in a blend
   * and at the query each lie within [-|J| Omega_max / 2 pi, ...]; near
   * the curve a cell spans its jump J, near an end its fan, and elsewhere
   * far less: widened by 2 |J| (the sweep of a curve that turns more than
   * a half turn, by its share). */
  for (int k = 0; k < d->num_layers; k++) {
    const ch_dlayer *l = &d->layers[k];
    double turn = 0.0;
    for (int i = 0; i < l->num_pieces; i++) {
      double a[2], b[2];
      ch_bezier_end_tangents((const double(*)[2])l->p[i], a, b);
      turn += fabs(atan2(a[0] * b[1] - a[1] * b[0], a[0] * b[0] + a[1] * b[1]));
      if (i + 1 < l->num_pieces) {
        double c[2], e[2];
        ch_bezier_end_tangents((const double(*)[2])l->p[i + 1], c, e);
        turn += fabs(atan2(b[0] * c[1] - b[1] * c[0], b[0] * c[0] + b[1] * c[1]));
      }
    }
    float widen = (float)(2.0 * fabs(l->jump) * fmax(1.0, (turn + CH_PI) / (2.0 * CH_PI)));
    float g = (float)(d->layer_far[k] + 1.5);
    widen_box(p, W, H, l->box[0] - g, l->box[1] - g, l->box[2] + g, l->box[3] + g, widen);
  }
  for (int k = 0; k < d->num_sing; k++) {
    const ch_stepsing_point *pt = &d->sing[k];
    if (!(pt->radius > 0.0)) continue;
    double tmin = 0.0, tmax = 0.0;
    for (int j = 0; j < pt->num_arms; j++) {
      double span = (pt->num_arms == 1 ? 2.0 * CH_PI : pt->angle[(j + 1) % pt->num_arms] - pt->angle[j]);
      if (span <= 0.0) span += 2.0 * CH_PI;
      double e = pt->value[j] + pt->slope[j] * span;
      tmin = fmin(tmin, fmin(pt->value[j], e));
      tmax = fmax(tmax, fmax(pt->value[j], e));
    }
    float widen = (float)(tmax - tmin), reach = (float)(pt->radius + 1.5);
    widen_box(p, W, H, pt->p[0] - reach, pt->p[1] - reach, pt->p[0] + reach, pt->p[1] + reach, widen);
  }
  while (p->w[p->levels - 1] > 1 || p->h[p->levels - 1] > 1) {
    int l = p->levels, pw = p->w[l - 1], ph = p->h[l - 1];
    int w = (pw + 1) / 2, h = (ph + 1) / 2;
    p->w[l] = w;
    p->h[l] = h;
    p->lo[l] = malloc((size_t)w * h * sizeof(float));
    p->hi[l] = malloc((size_t)w * h * sizeof(float));
    p->levels++;
    if (!p->lo[l] || !p->hi[l]) goto nomem;
    for (int y = 0; y < h; y++)
      for (int x = 0; x < w; x++) {
        float lo = INFINITY, hi = -INFINITY;
        for (int j = 0; j < 2; j++)
          for (int i = 0; i < 2; i++) {
            int xx = 2 * x + i < pw ? 2 * x + i : pw - 1, yy = 2 * y + j < ph ? 2 * y + j : ph - 1;
            lo = fminf(lo, p->lo[l - 1][(size_t)yy * pw + xx]);
            hi = fmaxf(hi, p->hi[l - 1][(size_t)yy * pw + xx]);
          }
        p->lo[l][(size_t)y * w + x] = lo;
        p->hi[l][(size_t)y * w + x] = hi;
      }
  }
  return CH_OK;
nomem:
  pyramid_free(p);
  return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the truth's step bounds");
}


/* Bounds of h_step over the UV box: the texels any point of it blends
 * (ch_recon_eval's bilinear cell, clamped the same way). */
static void step_bounds(const ch_truth *T, const double box[4], double *lo, double *hi) {
  const ch_samples *s = &T->height->dci.samples;
  const step_pyramid *p = &T->steps;
  int W = s->width, H = s->height;
  double gx0 = (box[0] - s->rect[0]) / s->texel[0] - 0.5, gx1 = (box[2] - s->rect[0]) / s->texel[0] - 0.5;
  double gy0 = (s->rect[3] - box[3]) / s->texel[1] - 0.5, gy1 = (s->rect[3] - box[1]) / s->texel[1] - 0.5;
  int xa = ch_clampi((int)floor(ch_clamp(gx0, 0, W - 1)), 0, W > 1 ? W - 2 : 0);
  int xb = ch_clampi((int)floor(ch_clamp(gx1, 0, W - 1)) + 1, 0, W - 1);
  int ya = ch_clampi((int)floor(ch_clamp(gy0, 0, H - 1)), 0, H > 1 ? H - 2 : 0);
  int yb = ch_clampi((int)floor(ch_clamp(gy1, 0, H - 1)) + 1, 0, H - 1);
  int l = 0;
  while (l + 1 < p->levels && ((xb >> l) - (xa >> l) > 1 || (yb >> l) - (ya >> l) > 1)) l++;
  float a = INFINITY, b = -INFINITY;
  for (int y = ya >> l; y <= yb >> l; y++)
    for (int x = xa >> l; x <= xb >> l; x++) {
      /* (Plain comparisons: fminf is a libm call here, and this is hot.) */
      float lo = p->lo[l][(size_t)y * p->w[l] + x], hi = p->hi[l][(size_t)y * p->w[l] + x];
      a = lo < a ? lo : a;
      b = hi > b ? hi : b;
    }
  *lo = a;
  *hi = b;
}

/* ---- bounds of h over a disk ---- */

typedef struct disk_bound {
  double lo, hi;
  int constant; /* no groove reaches the disk and h_step is one value */
} disk_bound;

/* items: the groove segments listed for the disk's cell. */
static void bound_disk(const ch_truth *T, const int *items, int n, const double c[2], double r, disk_bound *out) {
  const ch_curve_set *set = T->set;
  double glo = 0.0, ghi = 0.0;
  double min_lo = INFINITY, max_lo = -INFINITY, min_hi = INFINITY, max_hi = -INFINITY;
  int touched = 0;
  for (int k = 0; k < n;) {
    int curve = set->segments[items[k]].curve;
    double best = INFINITY, best_t = 0.0;
    int best_seg = -1, first = k;
    for (; k < n && set->segments[items[k]].curve == curve; k++) {
      const double *b = T->seg_boxes[items[k]];
      if (c[0] < b[0] || c[0] > b[2] || c[1] < b[1] || c[1] > b[3]) continue;
      double t, d2 = ch_bezier_closest(set->segments[items[k]].p, set->segments[items[k]].is_line, c, &t);
      if (d2 < best) best = d2, best_t = t, best_seg = items[k];
    }
    if (best_seg < 0) continue;
    const ch_curve *cv = &set->curves[curve];
    double D = sqrt(best), w = cv->width, rr = r + 1e-12;
    if (D - rr >= 0.5 * w) continue; /* the profile is 0 on the whole disk */
    touched = 1;
    int both = D <= rr;
    double plo, phi;
    if (!both && !T->symmetric[curve]) {
      /* Beyond an open end the side flips off the curve (docs/spec.md §3's cap). */
      for (int j = first; j < k && !both; j++) {
        const ch_segment *sg = &set->segments[items[j]];
        for (int e = 0; e < 2; e++) {
          if ((e == 0 ? sg->prev : sg->next) >= 0) continue;
          const double *E = sg->p[e == 0 ? 0 : 2];
          if (hypot(c[0] - E[0], c[1] - E[1]) <= D + 2.0 * rr) both = 1;
        }
      }
    }
    if (D <= rr) {
      profile_range(&cv->profile, -(D + rr) / w, (D + rr) / w, &plo, &phi);
    } else if (both) {
      double l1, h1, l2, h2;
      profile_range(&cv->profile, (D - rr) / w, (D + rr) / w, &l1, &h1);
      profile_range(&cv->profile, -(D + rr) / w, -(D - rr) / w, &l2, &h2);
      plo = fmin(l1, l2);
      phi = fmax(h1, h2);
    } else {
      int side = ch_curve_side(set, best_seg, best_t, c);
      if (side > 0)
        profile_range(&cv->profile, (D - rr) / w, (D + rr) / w, &plo, &phi);
      else
        profile_range(&cv->profile, -(D + rr) / w, -(D - rr) / w, &plo, &phi);
    }
    double g0 = cv->depth * plo, g1 = cv->depth * phi, slack = 1e-9 * fabs(cv->depth);
    double l = fmin(g0, g1) - slack, h = fmax(g0, g1) + slack;
    min_lo = fmin(min_lo, l), max_lo = fmax(max_lo, l);
    min_hi = fmin(min_hi, h), max_hi = fmax(max_hi, h);
  }
  /* The CSG rule F(g) = min g if some g < 0, else max(0, max g) is
   * non-decreasing in every g_i, so over the box of ranges it lies in
   * [F(lows), F(highs)]. */
  if (touched) {
    glo = min_lo < 0.0 ? min_lo : fmax(0.0, max_lo);
    ghi = min_hi < 0.0 ? min_hi : fmax(0.0, max_hi);
  }
  double slo = 0.0, shi = 0.0;
  if (T->height->has_steps) {
    double box[4] = {c[0] - r, c[1] - r, c[0] + r, c[1] + r};
    step_bounds(T, box, &slo, &shi);
  }
  out->constant = !touched && slo == shi;
  out->lo = glo + slo - (out->constant ? 0.0 : 1e-12);
  out->hi = ghi + shi + (out->constant ? 0.0 : 1e-12);
}

/* The groove segments that may reach cell (i, j) (see bound_disk). */
static int cell_items(const ch_truth *T, int i, int j, const int **items, double centre[2]) {
  centre[0] = (i + 0.5) * T->cell;
  centre[1] = (j + 0.5) * T->cell;
  return ch_grid_query(&T->seg_grid, centre[0], centre[1], items);
}

/* ---- creation ---- */

ch_status ch_truth_create(const ch_height *height, const ch_truth_desc *desc, ch_truth **out, ch_error *err) {
  *out = NULL;
  int G = desc && desc->grid > 0 ? desc->grid : 512;
  if (G > 16384 || G % CH_TRUTH_TILE)
    return ch_error_set(err, CH_ERR_INPUT, "truth grid %d: must be a multiple of %d up to 16384", G, CH_TRUTH_TILE);
  ch_truth *T = calloc(1, sizeof *T);
  if (!T) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the truth");
  const ch_curve_set *set = height->set;
  T->height = height;
  T->set = set;
  T->grid = G;
  T->tiles = G / CH_TRUTH_TILE;
  T->tol = desc && desc->tolerance > 0.0 ? desc->tolerance : 1e-9;
  T->cell = 1.0 / G;
  T->radius = 0.5 * sqrt(2.0) * T->cell;
  ch_status st = CH_OK;
  T->lo = malloc((size_t)G * G * sizeof *T->lo);
  T->hi = malloc((size_t)G * G * sizeof *T->hi);
  T->tile_lo = malloc((size_t)T->tiles * T->tiles * sizeof *T->tile_lo);
  T->tile_hi = malloc((size_t)T->tiles * T->tiles * sizeof *T->tile_hi);
  T->seg_boxes = malloc((size_t)(set->num_segments > 0 ? set->num_segments : 1) * sizeof *T->seg_boxes);
  T->symmetric = calloc((size_t)(set->num_curves > 0 ? set->num_curves : 1), 1);
  if (!T->lo || !T->hi || !T->tile_lo || !T->tile_hi || !T->seg_boxes || !T->symmetric) {
    st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for the truth's %d x %d grid", G, G);
    goto fail;
  }
  for (int c = 0; c < set->num_curves; c++) T->symmetric[c] = (unsigned char)profile_is_symmetric(&set->curves[c].profile);
  for (int i = 0; i < set->num_segments; i++) {
    const ch_segment *s = &set->segments[i];
    const ch_curve *c = &set->curves[s->curve];
    if (c->kind != CH_CURVE_GROOVE) {
      T->seg_boxes[i][0] = T->seg_boxes[i][1] = 1.0; /* empty */
      T->seg_boxes[i][2] = T->seg_boxes[i][3] = 0.0;
    } else {
      ch_segment_box(s, 0.5 * c->width + 2.0 * T->radius, T->seg_boxes[i]);
    }
  }
  st = ch_grid_build(&T->seg_grid, set->num_segments, (const double(*)[4])T->seg_boxes, err);
  if (st) goto fail;
  if (height->has_steps && (st = pyramid_build(&T->steps, &height->dci, err))) goto fail;
#pragma omp parallel for schedule(dynamic, 8)
  for (int j = 0; j < G; j++)
    for (int i = 0; i < G; i++) {
      const int *items = NULL;
      double c[2];
      int n = cell_items(T, i, j, &items, c);
      disk_bound b;
      bound_disk(T, items, n, c, T->radius, &b);
      T->lo[(size_t)j * G + i] = b.lo;
      T->hi[(size_t)j * G + i] = b.hi;
    }
  T->zmin = INFINITY;
  T->zmax = -INFINITY;
  for (int tj = 0; tj < T->tiles; tj++)
    for (int ti = 0; ti < T->tiles; ti++) {
      double lo = INFINITY, hi = -INFINITY;
      for (int j = tj * CH_TRUTH_TILE; j < (tj + 1) * CH_TRUTH_TILE; j++)
        for (int i = ti * CH_TRUTH_TILE; i < (ti + 1) * CH_TRUTH_TILE; i++) {
          lo = fmin(lo, T->lo[(size_t)j * G + i]);
          hi = fmax(hi, T->hi[(size_t)j * G + i]);
        }
      T->tile_lo[tj * T->tiles + ti] = lo;
      T->tile_hi[tj * T->tiles + ti] = hi;
      T->zmin = fmin(T->zmin, lo);
      T->zmax = fmax(T->zmax, hi);
    }
  /* h_step comes from float texels: it moves in steps of one float ulp of
   * its values (5e-10 at 0.006) even where it is smooth (blurred curves),
   * and such a step is no wall. A millionth of the surface's height range
   * is 16 ulps of its largest value and far below any drawn jump. */
  T->jump_eps = 1e-6 * fmax(T->zmax - T->zmin, 1e-9);
  *out = T;
  return CH_OK;
fail:
  ch_truth_destroy(T);
  return st;
}

void ch_truth_destroy(ch_truth *T) {
  if (!T) return;
  free(T->lo);
  free(T->hi);
  free(T->tile_lo);
  free(T->tile_hi);
  free(T->seg_boxes);
  free(T->symmetric);
  ch_grid_free(&T->seg_grid);
  pyramid_free(&T->steps);
  free(T);
}

int ch_truth_grid(const ch_truth *T) { return T->grid; }
int ch_truth_tiles(const ch_truth *T) { return T->tiles; }

void ch_truth_tile_bounds(const ch_truth *T, int tile, double box[6]) {
  if (tile < 0) {
    double b[6] = {0.0, 0.0, T->zmin, 1.0, 1.0, T->zmax};
    memcpy(box, b, sizeof b);
    return;
  }
  int ti = tile % T->tiles, tj = tile / T->tiles;
  double s = (double)CH_TRUTH_TILE / T->grid;
  box[0] = ti * s;
  box[1] = tj * s;
  box[2] = T->tile_lo[tile];
  box[3] = (ti + 1) * s;
  box[4] = (tj + 1) * s;
  box[5] = T->tile_hi[tile];
}

double ch_truth_height(const ch_truth *T, double u, double v) { return ch_height_eval(T->height, u, v); }

/* ---- structure at a point ---- */

static double step_value(const ch_truth *T, double u, double v, int *curve) {
  if (!T->height->has_steps) {
    if (curve) *curve = -1;
    return 0.0;
  }
  ch_recon_sample rs;
  ch_recon_eval(&T->height->recon, T->height->step_method, u, v, 0.0, &rs);
  if (curve) *curve = rs.distance < 1e-4 ? rs.curve : -1;
  return rs.value;
}

/* The unit UV direction across curve `curve` at q (away from it): radial
 * from the closest point, or the left normal where q is on the curve; for
 * a wall (wall = 1) beyond a one-sided groove's open end, across the end's
 * tangent line where the side flips. */
static void across_curve(const ch_truth *T, int curve, const double q[2], int wall, double n[2]) {
  int seg;
  double t, cp[2];
  if (T->set->curves[curve].kind == CH_CURVE_GROOVE) {
    /* q is within its half width, so the closest is among the segments
     * the groove field lists at q */
    ch_curve_point p;
    ch_groove_field_closest(&T->height->grooves, curve, q, &p);
    seg = p.segment, t = p.t, cp[0] = p.point[0], cp[1] = p.point[1];
  } else {
    ch_curve_point p;
    ch_curve_closest(T->set, curve, q, &p);
    seg = p.segment, t = p.t, cp[0] = p.point[0], cp[1] = p.point[1];
  }
  double d[2] = {q[0] - cp[0], q[1] - cp[1]}, len = hypot(d[0], d[1]);
  const ch_segment *sg = &T->set->segments[seg];
  const ch_curve *cv = &T->set->curves[curve];
  if (wall && cv->kind == CH_CURVE_GROOVE && !T->symmetric[curve] &&
      ((t <= 0.0 && sg->prev < 0) || (t >= 1.0 && sg->next < 0))) {
    /* Around an open end a one-sided profile's walls are circles |s| = b w
     * (radial), but its side flips on the end's tangent line: across that
     * line where q is on no jump circle. */
    double cr[CH_PROFILE_MAX_POINTS + 2];
    int nc = ch_profile_creases(&cv->profile, cr, CH_PROFILE_MAX_POINTS + 2), on_circle = 0;
    for (int k = 0; k < nc; k++) {
      double b = cr[k], e = 1e-9;
      on_circle |= b != 0.0 && fabs(len - fabs(b) * cv->width) <= 1e-6 * cv->width &&
                   fabs(ch_profile_eval(&cv->profile, b - e) - ch_profile_eval(&cv->profile, b + e)) > 1e-6;
    }
    if (!on_circle) {
      double tg[2];
      ch_bezier_tangent(sg->p, t <= 0.0 ? 0.0 : 1.0, tg);
      n[0] = -tg[1];
      n[1] = tg[0];
      return;
    }
  }
  if (len > 1e-7) {
    n[0] = d[0] / len;
    n[1] = d[1] / len;
  } else {
    double tg[2];
    ch_bezier_tangent(T->set->segments[seg].p, t, tg);
    n[0] = -tg[1];
    n[1] = tg[0];
  }
}

void ch_truth_classify(const ch_truth *T, const double uv[2], ch_vis_class *cls, int *curve) {
  ch_groove_sample gs;
  ch_groove_field_eval(&T->height->grooves, uv[0], uv[1], &gs);
  if (gs.active < 0) {
    *cls = CH_VIS_TOP;
    *curve = -1;
    return;
  }
  const ch_curve *c = &T->set->curves[gs.active];
  double slope = ch_profile_slope(&c->profile, gs.active_signed_distance / c->width);
  *cls = slope != 0.0 ? CH_VIS_GROOVE_WALL : CH_VIS_GROOVE_FLOOR;
  *curve = gs.active;
}

/* One part of h at p: the groove part (filling *gs) or the step part. */
static double part_at(const ch_truth *T, int groove, const double p[2], ch_groove_sample *gs) {
  return groove ? ch_groove_field_eval(&T->height->grooves, p[0], p[1], gs) : step_value(T, p[0], p[1], NULL);
}

/* The jump of one part of h nearest to uv along n, within WALL_REACH.
 * Windows [-r, r] grow by 4 from 1e-8; in the first whose ends differ,
 * the half with the larger difference is kept down to 1e-13 UV; a jump
 * keeps (at least a tenth of) the window's difference there, a slope
 * does not, and jumps below jump_eps (float steps of h_step) do not
 * count. Why a reach: a mesh's wall lies on the curve only as well as
 * its coordinates do (float: 3e-8 at u ~ 0.6; a chord of a curved step
 * or a vertex placed near a junction: 1e-6..5e-5), and probes closer
 * than that stay on one side of the truth's jump. */
#define WALL_REACH 1e-4
typedef struct part_jump {
  int window;                 /* the window index it was found in, or -1 */
  double size;                /* |difference| across it */
  double a[2], b[2];          /* the last bracket: either side of the jump */
  ch_groove_sample ga, gb;    /* groove part: the samples at a and b */
} part_jump;

static void find_jump(const ch_truth *T, int groove, const double uv[2], const double n[2], part_jump *J) {
  J->window = -1;
  J->size = 0.0;
  for (int k = 0;; k++) {
    double r = fmin(1e-8 * pow(4.0, k), WALL_REACH), lo = -r, hi = r;
    double pa[2] = {uv[0] + lo * n[0], uv[1] + lo * n[1]}, pb[2] = {uv[0] + hi * n[0], uv[1] + hi * n[1]};
    ch_groove_sample ga, gb;
    double fa = part_at(T, groove, pa, &ga), fb = part_at(T, groove, pb, &gb), d0 = fabs(fb - fa);
    if (!(d0 > T->jump_eps)) {
      if (r >= WALL_REACH) return;
      continue;
    }
    while (hi - lo > 1e-13) {
      double m = 0.5 * (lo + hi), pm[2] = {uv[0] + m * n[0], uv[1] + m * n[1]};
      ch_groove_sample gm;
      double fm = part_at(T, groove, pm, &gm);
      if (fabs(fm - fa) >= fabs(fb - fm)) {
        hi = m, fb = fm, gb = gm;
        memcpy(pb, pm, sizeof pm);
      } else {
        lo = m, fa = fm, ga = gm;
        memcpy(pa, pm, sizeof pm);
      }
    }
    double d = fabs(fb - fa);
    if (d > T->jump_eps && d >= 0.1 * d0) {
      J->window = k;
      J->size = d;
      memcpy(J->a, pa, sizeof pa);
      memcpy(J->b, pb, sizeof pb);
      J->ga = ga;
      J->gb = gb;
      return;
    }
    if (r >= WALL_REACH) return;
  }
}

void ch_truth_classify_wall(const ch_truth *T, const double uv[2], const double n_uv[2], ch_vis_class *cls, int *curve) {
  part_jump g, s;
  find_jump(T, 1, uv, n_uv, &g);
  find_jump(T, 0, uv, n_uv, &s);
  if (!T->height->has_steps) s.window = -1;
  /* The nearer jump (by window); in one window, the larger. */
  int use_g = g.window >= 0 && (s.window < 0 || g.window < s.window || (g.window == s.window && g.size >= s.size));
  int step_curve;
  if (use_g) {
    *cls = CH_VIS_GROOVE_WALL;
    *curve = fabs(g.ga.h) >= fabs(g.gb.h) ? g.ga.active : g.gb.active;
  } else if (s.window >= 0) {
    double m[2] = {0.5 * (s.a[0] + s.b[0]), 0.5 * (s.a[1] + s.b[1])};
    step_value(T, m[0], m[1], &step_curve);
    *cls = CH_VIS_STEP_WALL;
    *curve = step_curve;
  } else {
    /* No jump within reach (a mesh wall where the truth has none, e.g. a
     * steep facet near a u groove's rim): groove wall if a groove is
     * active on either side, else step wall next to a step curve, else top. */
    double a[2] = {uv[0] - 1e-7 * n_uv[0], uv[1] - 1e-7 * n_uv[1]}, b[2] = {uv[0] + 1e-7 * n_uv[0], uv[1] + 1e-7 * n_uv[1]};
    ch_groove_sample ga, gb;
    ch_groove_field_eval(&T->height->grooves, a[0], a[1], &ga);
    ch_groove_field_eval(&T->height->grooves, b[0], b[1], &gb);
    int deeper = fabs(ga.h) >= fabs(gb.h) ? ga.active : gb.active;
    if (ga.active >= 0 || gb.active >= 0) {
      *cls = CH_VIS_GROOVE_WALL;
      *curve = deeper >= 0 ? deeper : ga.active >= 0 ? ga.active : gb.active;
    } else {
      step_value(T, uv[0], uv[1], &step_curve);
      *cls = step_curve >= 0 ? CH_VIS_STEP_WALL : CH_VIS_TOP;
      *curve = step_curve;
    }
  }
}

void ch_truth_normal(const ch_truth *T, const double uv[2], double n[3]) {
  double g[2] = {0.0, 0.0};
  ch_groove_sample gs;
  ch_groove_field_eval(&T->height->grooves, uv[0], uv[1], &gs);
  if (gs.active >= 0) {
    const ch_curve *c = &T->set->curves[gs.active];
    double slope = ch_profile_slope(&c->profile, gs.active_signed_distance / c->width);
    if (slope != 0.0) {
      /* s = side |q - cp|: its gradient is the unit vector from cp, signed. */
      double ds[2];
      across_curve(T, gs.active, uv, 0, ds);
      double sign = gs.active_signed_distance >= 0.0 ? 1.0 : -1.0;
      ch_curve_point cp;
      ch_groove_field_closest(&T->height->grooves, gs.active, uv, &cp);
      if (hypot(uv[0] - cp.point[0], uv[1] - cp.point[1]) <= 1e-7) sign = 1.0; /* on the curve: the left normal */
      double k = c->depth / c->width * slope * sign;
      g[0] += k * ds[0];
      g[1] += k * ds[1];
    }
  }
  if (T->height->has_steps) {
    /* h_step is bilinear per texel: one-sided differences of 1e-5 UV (its
     * float values would make smaller steps noisy), the flatter side. */
    const double e = 1e-5;
    double h0 = step_value(T, uv[0], uv[1], NULL);
    for (int axis = 0; axis < 2; axis++) {
      double p[2] = {uv[0], uv[1]}, m[2] = {uv[0], uv[1]};
      p[axis] += e;
      m[axis] -= e;
      double fwd = (step_value(T, p[0], p[1], NULL) - h0) / e, back = (h0 - step_value(T, m[0], m[1], NULL)) / e;
      g[axis] += fabs(fwd) <= fabs(back) ? fwd : back;
    }
  }
  double len = sqrt(g[0] * g[0] + g[1] * g[1] + 1.0);
  n[0] = -g[0] / len;
  n[1] = -g[1] / len;
  n[2] = 1.0 / len;
}

/* ---- intersection ---- */

typedef struct ray {
  const double *o, *d;
  double duv_len; /* |(dx, dy)| */
} ray;

static double ray_f(const ch_truth *T, const ray *R, double t, double *h) {
  double hh = ch_height_eval(T->height, R->o[0] + t * R->d[0], R->o[1] + t * R->d[1]);
  if (h) *h = hh;
  return R->o[2] + t * R->d[2] - hh;
}

static void finish_hit(const ch_truth *T, const ray *R, double a, double b, double fa, double fb, ch_truth_hit *hit) {
  double ha = R->o[2] + a * R->d[2] - fa, hb = R->o[2] + b * R->d[2] - fb, dh0 = fabs(hb - ha);
  double aa = a, bb = b, faa = fa, dh = dh0;
  for (int k = 0; k < 4; k++) {
    double m = 0.5 * (aa + bb), hm, fm = ray_f(T, R, m, &hm);
    if ((fm > 0.0) == (faa > 0.0)) {
      aa = m, faa = fm, ha = hm;
    } else {
      bb = m, hb = hm;
    }
    dh = fabs(hb - ha);
  }
  hit->wall = dh > 0.5 * dh0 && dh > T->jump_eps && R->duv_len > 0.0;
  double t = hit->wall ? 0.5 * (aa + bb) : (fa == fb ? a : a + (b - a) * fa / (fa - fb));
  hit->t = t;
  hit->uv[0] = R->o[0] + t * R->d[0];
  hit->uv[1] = R->o[1] + t * R->d[1];
  hit->point[0] = hit->uv[0];
  hit->point[1] = hit->uv[1];
  hit->point[2] = R->o[2] + t * R->d[2];
  if (!hit->wall) {
    ch_truth_normal(T, hit->uv, hit->normal);
    return;
  }
  /* Across the curve that makes the jump, facing the ray. */
  double dn[2] = {R->d[0] / R->duv_len, R->d[1] / R->duv_len}, n2[2] = {-dn[0], -dn[1]};
  ch_vis_class cls;
  int curve;
  ch_truth_classify_wall(T, hit->uv, dn, &cls, &curve);
  if (curve >= 0) across_curve(T, curve, hit->uv, 1, n2);
  if (n2[0] * R->d[0] + n2[1] * R->d[1] > 0.0) n2[0] = -n2[0], n2[1] = -n2[1];
  hit->normal[0] = n2[0];
  hit->normal[1] = n2[1];
  hit->normal[2] = 0.0;
}

/* Between two samples on the same side (pos) the ray may still dip
 * through the surface and back (skimming a rim just before a wall drops
 * away): halves whose disk bound the ray's z range meets are split, up to
 * PROBE_DEPTH levels (the spacing / 256) and a budget of bound
 * evaluations per ray. Returns 1 with [*ra, *rb] holding a change of side. */
enum { PROBE_DEPTH = 8, PROBE_STACK = 2 * PROBE_DEPTH + 2 };
static int probe(const ch_truth *T, const ray *R, const int *items, int n, double a0, double b0, int pos, int *budget,
                 double *ra, double *rb) {
  double sa[PROBE_STACK], sb[PROBE_STACK];
  int sd[PROBE_STACK], top = 0;
  sa[0] = a0, sb[0] = b0, sd[0] = 0, top = 1;
  while (top > 0 && *budget > 0) {
    top--;
    double a = sa[top], b = sb[top];
    int depth = sd[top];
    double za = R->o[2] + a * R->d[2], zb = R->o[2] + b * R->d[2];
    double c[2] = {R->o[0] + 0.5 * (a + b) * R->d[0], R->o[1] + 0.5 * (a + b) * R->d[1]};
    disk_bound db;
    (*budget)--;
    bound_disk(T, items, n, c, 0.5 * (b - a) * R->duv_len, &db);
    double pad = 1e-12 * (1.0 + fabs(za) + fabs(zb));
    if (fmax(za, zb) < db.lo - pad || fmin(za, zb) > db.hi + pad || db.constant || depth >= PROBE_DEPTH) continue;
    double m = 0.5 * (a + b);
    if ((ray_f(T, R, m, NULL) > 0.0) != pos) {
      *ra = a;
      *rb = m;
      return 1;
    }
    sa[top] = m, sb[top] = b, sd[top++] = depth + 1;
    sa[top] = a, sb[top] = m, sd[top++] = depth + 1;
  }
  return 0;
}

/* Bisects a sign change of f between a and b (fa_pos: f(a) > 0) down to
 * the tolerance, then fills the hit. */
static void bisect(const ch_truth *T, const ray *R, double a, double b, int fa_pos, ch_truth_hit *hit) {
  while (b - a > T->tol) {
    double m = 0.5 * (a + b);
    if ((ray_f(T, R, m, NULL) > 0.0) == fa_pos)
      a = m;
    else
      b = m;
  }
  finish_hit(T, R, a, b, ray_f(T, R, a, NULL), ray_f(T, R, b, NULL), hit);
}

int ch_truth_intersect(const ch_truth *T, const double o[3], const double d[3], double tnear, double tfar, int tile,
                       ch_truth_hit *hit) {
  int G = T->grid;
  int i0 = 0, j0 = 0, i1 = G, j1 = G;
  if (tile >= 0) {
    i0 = (tile % T->tiles) * CH_TRUTH_TILE;
    j0 = (tile / T->tiles) * CH_TRUTH_TILE;
    i1 = i0 + CH_TRUTH_TILE;
    j1 = j0 + CH_TRUTH_TILE;
  }
  ray R = {o, d, hypot(d[0], d[1])};
  /* Clip to the UV rectangle of the cells. */
  double ta = tnear, tb = tfar;
  double lo[2] = {i0 * T->cell, j0 * T->cell}, hi[2] = {i1 * T->cell, j1 * T->cell};
  for (int k = 0; k < 2; k++) {
    if (d[k] == 0.0) {
      if (o[k] < lo[k] || o[k] > hi[k]) return 0;
      continue;
    }
    double t0 = (lo[k] - o[k]) / d[k], t1 = (hi[k] - o[k]) / d[k];
    if (t0 > t1) {
      double x = t0;
      t0 = t1;
      t1 = x;
    }
    ta = fmax(ta, t0);
    tb = fmin(tb, t1);
  }
  if (!(ta <= tb)) return 0;
  /* A ray along z without end: stop it beyond the surface's z range. */
  if (!isfinite(tb)) {
    if (d[2] == 0.0) return 0;
    double t0 = (T->zmin - 1.0 - o[2]) / d[2], t1 = (T->zmax + 1.0 - o[2]) / d[2];
    tb = fmin(tb, fmax(t0, t1));
    if (!(ta <= tb)) return 0;
  }
  /* 2D DDA over the cells (Amanatides-Woo). */
  double pu = d[0] != 0.0 ? o[0] + ta * d[0] : o[0], pv = d[1] != 0.0 ? o[1] + ta * d[1] : o[1];
  int ix = ch_clampi((int)floor(pu * G), i0, i1 - 1), iy = ch_clampi((int)floor(pv * G), j0, j1 - 1);
  int sx = d[0] > 0.0 ? 1 : -1, sy = d[1] > 0.0 ? 1 : -1;
  double dtx = d[0] != 0.0 ? T->cell / fabs(d[0]) : INFINITY, dty = d[1] != 0.0 ? T->cell / fabs(d[1]) : INFINITY;
  double tx = d[0] > 0.0 ? ((ix + 1) * T->cell - o[0]) / d[0] : d[0] < 0.0 ? (ix * T->cell - o[0]) / d[0] : INFINITY;
  double ty = d[1] > 0.0 ? ((iy + 1) * T->cell - o[1]) / d[1] : d[1] < 0.0 ? (iy * T->cell - o[1]) / d[1] : INFINITY;
  /* The last point whose side is known: f > 0 above the surface. Where the
   * ray enters this tile from a neighbouring one, that is a hair before the
   * entry: a wall on the tile's border is then a change of side (the
   * neighbour's walk stops at its border). */
  double t = ta, last_t = ta;
  if (ta > tnear) {
    double tp = fmax(tnear, ta - 1e-9 * (1.0 + fabs(ta)));
    double up = o[0] + tp * d[0], vp = o[1] + tp * d[1];
    if (up > 0.0 && up < 1.0 && vp > 0.0 && vp < 1.0) last_t = tp;
  }
  int last_pos = ray_f(T, &R, last_t, NULL) > 0.0;
  const double spacing = T->cell / CH_TRUTH_SAMPLES;
  int budget = 256;
  for (;;) {
    double t_exit = fmin(fmin(tx, ty), tb);
    size_t ci = (size_t)iy * G + ix;
    double za = o[2] + t * d[2], zb = o[2] + t_exit * d[2];
    double pad = 1e-12 * (1.0 + fabs(T->lo[ci]) + fabs(T->hi[ci]));
    int above = fmin(za, zb) > T->hi[ci] + pad, below = fmax(za, zb) < T->lo[ci] - pad;
    if (above || below) {
      /* The whole piece is on one side: a change of side happened between
       * the last known point and this cell's entry. */
      if (above != last_pos) {
        bisect(T, &R, last_t, t, last_pos, hit);
        return 1;
      }
      last_t = t_exit;
    } else {
      /* Samples no farther apart than cell / CH_TRUTH_SAMPLES in UV. */
      double len = (t_exit - t) * R.duv_len;
      int n = (int)ceil(len / spacing);
      if (n < 1) n = 1;
      const int *items = NULL;
      double centre[2];
      int n_items = cell_items(T, ix, iy, &items, centre);
      for (int k = 1; k <= n; k++) {
        double tk = k == n ? t_exit : t + (t_exit - t) * k / n, ra, rb;
        int pos = ray_f(T, &R, tk, NULL) > 0.0;
        if (pos != last_pos) {
          bisect(T, &R, last_t, tk, last_pos, hit);
          return 1;
        }
        if (probe(T, &R, items, n_items, last_t, tk, pos, &budget, &ra, &rb)) {
          bisect(T, &R, ra, rb, pos, hit);
          return 1;
        }
        last_t = tk;
      }
    }
    if (t_exit >= tb) return 0;
    if (tx <= ty) {
      ix += sx;
      t = tx;
      tx += dtx;
      if (ix < i0 || ix >= i1) return 0;
    } else {
      iy += sy;
      t = ty;
      ty += dty;
      if (iy < j0 || iy >= j1) return 0;
    }
  }
}
