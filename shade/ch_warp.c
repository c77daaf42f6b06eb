/* The view-dependent texture warp W (diffusion-curves-on-surfaces §3.2).
 *
 * As in the paper: the need of each triangle comes from its visibility (in
 * the frustum, not back-facing), its closeness to the observer and whether
 * it holds curves; a global optimisation per texture axis (after Dachsbacher
 * and Stamminger 2004) gives one monotone, easily inverted function per
 * axis; the mesh is a cage: its vertices' UVs are warped, the curves keep
 * their barycentric coordinates in the triangle they lie in, segments that
 * span several triangles are cut and registered per piece, and a regular
 * grid of triangles over texture space keeps the registration fast enough
 * for animated curves.
 *
 * Where we depart from it:
 * - Need is a measured quantity: per axis, the NDC length of a unit UV step
 *   (the projection's Jacobian times the triangle's affine UV -> 3D map), the
 *   largest at the corners and centroid in front of the eye.
 * - The optimisation is solved exactly: the need is spread so neighbouring
 *   intervals differ by at most max_ratio (smoothness), the slopes are
 *   max(floor, a need) capped at max_slope, and a is the root of
 *   mean slope = 1, a monotone piecewise-linear equation in a.
 * - The frustum test is conservative: the screen box of the triangle clipped
 *   to the near plane against the square.
 *
 * This file holds the need and W (with the mesh's density and arc lengths);
 * the cage map is ch_warp_cage.c, the curves' registration
 * ch_warp_curves.c. */
#include "ch_warp.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ch_warp_internal.h"

enum { DEFAULT_INTERVALS = 256, MAX_INTERVALS = 65536 };
/* Focus cells per axis (at most; a cell is a whole number of intervals). */
enum { FOCUS_CELLS = 64 };

/* ---- per-triangle need ---------------------------------------------- */

/* Whether any of the grid's boxes overlaps b. */
static int grid_any_overlap(const ch_grid *g, const double (*boxes)[4], const double b[4]) {
  int r[4];
  cell_range(g, b, r);
  for (int y = r[1]; y <= r[3]; y++)
    for (int x = r[0]; x <= r[2]; x++) {
      int c = y * g->nx + x;
      for (int k = g->cell_start[c]; k < g->cell_start[c + 1]; k++)
        if (boxes_overlap(boxes[g->items[k]], b)) return 1;
    }
  return 0;
}

/* Some part of the triangle in the frustum: clip it to depth >= near
 * (Sutherland-Hodgman, at most 4 corners remain) and test the screen box of
 * what remains against the square. Conservative (a box, not the polygon). */
static int in_frustum(const ch_camera *cam, const double pos[9], double near) {
  double q[3][3], z[3], poly[4][3];
  for (int k = 0; k < 3; k++) {
    ch_sub3(pos + 3 * k, cam->eye, q[k]);
    z[k] = ch_dot3(q[k], cam->forward);
  }
  int m = 0;
  for (int k = 0; k < 3; k++) {
    int j = (k + 1) % 3;
    int in_k = z[k] >= near, in_j = z[j] >= near;
    if (in_k) memcpy(poly[m++], q[k], sizeof poly[0]);
    if (in_k != in_j) {
      double s = (near - z[k]) / (z[j] - z[k]);
      for (int a = 0; a < 3; a++) poly[m][a] = q[k][a] + s * (q[j][a] - q[k][a]);
      m++;
    }
  }
  if (m == 0) return 0;
  double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
  for (int k = 0; k < m; k++) {
    double zz = fmax(ch_dot3(poly[k], cam->forward), near);
    double x = ch_dot3(poly[k], cam->right) / (zz * cam->half_width);
    double y = ch_dot3(poly[k], cam->up) / (zz * cam->half_height);
    lo[0] = fmin(lo[0], x);
    hi[0] = fmax(hi[0], x);
    lo[1] = fmin(lo[1], y);
    hi[1] = fmax(hi[1], y);
  }
  return lo[0] <= 1.0 && hi[0] >= -1.0 && lo[1] <= 1.0 && hi[1] >= -1.0;
}

/* NDC lengths of the 3D steps du, dv taken at p (in front). With d = p - eye,
 * z = d.forward and x = d.right / z: d(ndc_x)/dp = (right - x forward) /
 * (z half_width), likewise for y. z is kept >= min_depth. */
static void step_lengths(const ch_camera *cam, const double p[3], double min_depth, const double du[3],
                         const double dv[3], double out[2]) {
  double d[3];
  ch_sub3(p, cam->eye, d);
  double z = fmax(ch_dot3(d, cam->forward), min_depth);
  double x = ch_dot3(d, cam->right) / z, y = ch_dot3(d, cam->up) / z;
  double sx = 1.0 / (z * cam->half_width), sy = 1.0 / (z * cam->half_height);
  double jx[3], jy[3];
  for (int k = 0; k < 3; k++) {
    jx[k] = (cam->right[k] - x * cam->forward[k]) * sx;
    jy[k] = (cam->up[k] - y * cam->forward[k]) * sy;
  }
  out[0] = hypot(ch_dot3(jx, du), ch_dot3(jy, du));
  out[1] = hypot(ch_dot3(jx, dv), ch_dot3(jy, dv));
}

/* Visibility (front-facing, in the frustum) and, for a visible triangle
 * holding curves, its need per axis. Degenerate triangles (no 3D area: not
 * visible; no UV area: no need) are skipped. */
static void analyse_triangle(const ch_camera *cam, const double uv[6], const double pos[9], double near,
                             const ch_grid *curve_grid, const double (*curve_boxes)[4],
                             unsigned char *visible, int *holds, double need[2]) {
  need[0] = need[1] = 0.0;
  *visible = 0;
  *holds = 0;
  double e1[3], e2[3], nrm[3], cen[3], to_eye[3];
  ch_sub3(pos + 3, pos, e1);
  ch_sub3(pos + 6, pos, e2);
  ch_cross3(e1, e2, nrm);
  double scale = ch_dot3(e1, e1) + ch_dot3(e2, e2);
  if (!(ch_dot3(nrm, nrm) > 1e-28 * scale * scale)) return;
  for (int k = 0; k < 3; k++) cen[k] = (pos[k] + pos[3 + k] + pos[6 + k]) / 3.0;
  ch_sub3(cam->eye, cen, to_eye);
  if (!(ch_dot3(nrm, to_eye) > 0.0) || !in_frustum(cam, pos, near)) return;
  *visible = 1;
  double box[4], f[6];
  tri_box(uv, box);
  if (!curve_grid || !grid_any_overlap(curve_grid, curve_boxes, box)) return;
  *holds = 1;
  if (!tri_frame(uv, f)) return;
  /* The affine UV -> 3D map: [e1 e2] = [dP/du dP/dv] [uv edges], so
   * [dP/du dP/dv] = [e1 e2] times the inverse edge matrix. */
  double du[3], dv[3];
  for (int k = 0; k < 3; k++) {
    du[k] = e1[k] * f[2] + e2[k] * f[4];
    dv[k] = e1[k] * f[3] + e2[k] * f[5];
  }
  const double *pts[4] = {pos, pos + 3, pos + 6, cen};
  for (int i = 0; i < 4; i++) {
    double d[3], len[2];
    ch_sub3(pts[i], cam->eye, d);
    if (!(ch_dot3(d, cam->forward) > 0.0)) continue;
    step_lengths(cam, pts[i], near, du, dv, len);
    need[0] = fmax(need[0], len[0]);
    need[1] = fmax(need[1], len[1]);
  }
}

/* ---- the per-axis functions ----------------------------------------- */

static double slope_of(double a, double need, double fl, double ms) { return fmin(ms, fmax(fl, a * need)); }

static double slope_sum(const double *need, int n, double a, double fl, double ms) {
  double s = 0.0;
  for (int i = 0; i < n; i++) s += slope_of(a, need[i], fl, ms);
  return s;
}

/* Knots of the function whose slopes are s_i = clamp(a need_i, fl, ms) with
 * mean 1. The sum of the slopes is continuous, nondecreasing and linear
 * between the breaks fl / need_i and ms / need_i: a binary search over the
 * sorted breaks finds the piece that reaches n, solved there. Returns 0 (w
 * untouched) when no a reaches it: no need, or so few intervals with need
 * that even all of them at ms cannot make up for the rest at fl. */
static int solve_axis(const double *need, int n, double fl, double ms, double *w, double *scratch) {
  int m = 0;
  for (int i = 0; i < n; i++)
    if (need[i] > 0.0) {
      scratch[m++] = fl / need[i];
      scratch[m++] = ms / need[i];
    }
  if (m == 0) return 0;
  qsort(scratch, (size_t)m, sizeof *scratch, ch_cmp_double);
  double target = n;
  if (slope_sum(need, n, scratch[m - 1], fl, ms) < target) return 0;
  /* At scratch[0] every slope is fl < 1: below the target. */
  int lo = 0, hi = m - 1;
  while (hi - lo > 1) {
    int mid = lo + (hi - lo) / 2;
    if (slope_sum(need, n, scratch[mid], fl, ms) >= target)
      hi = mid;
    else
      lo = mid;
  }
  double a0 = scratch[lo], a1 = scratch[hi];
  double f0 = slope_sum(need, n, a0, fl, ms), f1 = slope_sum(need, n, a1, fl, ms);
  double a = f1 > f0 ? a0 + (target - f0) / (f1 - f0) * (a1 - a0) : a1;
  /* Cumulative sums, normalised so that the last knot is 1 exactly. */
  double sum = 0.0;
  w[0] = 0.0;
  for (int i = 0; i < n; i++) {
    sum += slope_of(a, need[i], fl, ms);
    w[i + 1] = sum;
  }
  for (int i = 1; i < n; i++) w[i] /= sum;
  w[n] = 1.0;
  /* Strictly increasing even for a floor near 0 (the inverse divides). */
  for (int i = 1; i < n; i++)
    if (!(w[i] > w[i - 1])) w[i] = nextafter(w[i - 1], 2.0);
  for (int i = n - 1; i > 0 && !(w[i] < w[i + 1]); i--) w[i] = nextafter(w[i + 1], -1.0);
  return 1;
}

static void identity_knots(double *w, int n) {
  for (int i = 0; i <= n; i++) w[i] = (double)i / n;
  w[n] = 1.0;
}

static double max_slope(const double *w, int n) {
  double s = 0.0;
  for (int i = 0; i < n; i++) s = fmax(s, (w[i + 1] - w[i]) * n);
  return s;
}

double ch_warp_axis(const ch_warp *w, int axis, double x) {
  const double *k = axis ? w->wv : w->wu;
  int n = w->n;
  if (!(x > 0.0)) return 0.0; /* also NaN */
  if (x >= 1.0) return 1.0;
  double t = x * n;
  int i = (int)t;
  if (i >= n) i = n - 1;
  return k[i] + (t - i) * (k[i + 1] - k[i]);
}

/* The interval i with k[i] <= y < k[i + 1], for y in [0, 1). */
static int find_interval(const double *k, int n, double y) {
  int lo = 0, hi = n;
  while (hi - lo > 1) {
    int mid = lo + (hi - lo) / 2;
    if (k[mid] <= y)
      lo = mid;
    else
      hi = mid;
  }
  return lo;
}

double ch_warp_axis_inverse(const ch_warp *w, int axis, double y) {
  const double *k = axis ? w->wv : w->wu;
  int n = w->n;
  if (!(y > 0.0)) return 0.0;
  if (y >= 1.0) return 1.0;
  int i = find_interval(k, n, y);
  return (i + (y - k[i]) / (k[i + 1] - k[i])) / n;
}

double ch_warp_axis_slope(const ch_warp *w, int axis, double x) {
  const double *k = axis ? w->wv : w->wu;
  int n = w->n;
  double t = ch_clamp(x, 0.0, 1.0) * n;
  int i = t >= n ? n - 1 : (int)t;
  return (k[i + 1] - k[i]) * n;
}

/* The focus at uv (1 without one); on a line between cells, the larger
 * of the two sides (so an edge along it follows the denser side, the same
 * from either face). */
static double focus_at(const ch_warp *w, const double uv[2]) {
  if (!w->focus) return 1.0;
  int lo[2], hi[2];
  for (int k = 0; k < 2; k++) {
    double t = ch_clamp(uv[k], 0.0, 1.0) * w->n;
    int i = t >= w->n ? w->n - 1 : (int)t;
    lo[k] = hi[k] = i / w->focus_cell;
    if (t == (double)i && i % w->focus_cell == 0 && lo[k] > 0) lo[k]--;
  }
  double f = 0.0;
  for (int y = lo[1]; y <= hi[1]; y++)
    for (int x = lo[0]; x <= hi[0]; x++) f = fmax(f, w->focus[(size_t)y * w->focus_n + x]);
  return f;
}

/* ch_warp_mesh_slopes, with W's slopes at uv in axis[] (the arc walk
 * needs both). */
static void mesh_slopes_at(const ch_warp *w, const double uv[2], double axis[2], double slopes[2]) {
  double f = focus_at(w, uv), r[2];
  for (int k = 0; k < 2; k++) {
    axis[k] = ch_warp_axis_slope(w, k, uv[k]);
    r[k] = fmax(axis[k] * f, fmin(axis[k], w->floor));
  }
  slopes[0] = slopes[1] = sqrt(r[0] * r[1]);
}

void ch_warp_mesh_slopes(const ch_warp *w, const double uv[2], double slopes[2]) {
  double axis[2];
  mesh_slopes_at(w, uv, axis, slopes);
}

/* The focus grid: 1 on the cells that visible triangles' UV boxes touch,
 * elsewhere q^-d for the Chebyshev distance d in cells to the nearest
 * such cell, q = max_ratio^(intervals per cell), so that the mesh's slopes
 * vary between cells no faster than W's may. Two chamfer sweeps. */
static ch_status build_focus(ch_warp *w, double mr, ch_error *err) {
  int n = w->n, cell = n / FOCUS_CELLS > 1 ? n / FOCUS_CELLS : 1, fn = (n + cell - 1) / cell;
  double *f = calloc((size_t)fn * fn, sizeof *f);
  if (!f) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the warp's focus");
  for (int t = 0; t < w->num_triangles; t++) {
    if (!w->visible[t]) continue;
    double b[4];
    tri_box(w->uv + 6 * (size_t)t, b);
    if (b[2] < 0.0 || b[3] < 0.0 || b[0] > 1.0 || b[1] > 1.0) continue;
    int r[4]; /* the cells the box overlaps (a box edge on a cell line: not the next cell) */
    for (int k = 0; k < 4; k++) {
      double x = ch_clamp(b[k], 0.0, 1.0) * n;
      int i = k < 2 ? (int)floor(x) : (int)ceil(x) - 1;
      r[k] = (i < 0 ? 0 : i >= n ? n - 1 : i) / cell;
    }
    if (r[2] < r[0]) r[2] = r[0];
    if (r[3] < r[1]) r[3] = r[1];
    for (int y = r[1]; y <= r[3]; y++)
      for (int x = r[0]; x <= r[2]; x++) f[(size_t)y * fn + x] = 1.0;
  }
  double q = pow(mr, cell);
#define FOCUS(x, y) ((x) >= 0 && (x) < fn && (y) >= 0 && (y) < fn ? f[(size_t)(y) * fn + (x)] : 0.0)
  for (int y = 0; y < fn; y++)
    for (int x = 0; x < fn; x++) {
      double m = fmax(fmax(FOCUS(x - 1, y), FOCUS(x - 1, y - 1)), fmax(FOCUS(x, y - 1), FOCUS(x + 1, y - 1)));
      f[(size_t)y * fn + x] = fmax(f[(size_t)y * fn + x], m / q);
    }
  for (int y = fn - 1; y >= 0; y--)
    for (int x = fn - 1; x >= 0; x--) {
      double m = fmax(fmax(FOCUS(x + 1, y), FOCUS(x + 1, y + 1)), fmax(FOCUS(x, y + 1), FOCUS(x - 1, y + 1)));
      f[(size_t)y * fn + x] = fmax(f[(size_t)y * fn + x], m / q);
    }
#undef FOCUS
  w->focus = f;
  w->focus_n = fn;
  w->focus_cell = cell;
  return CH_OK;
}

void ch_warp_free(ch_warp *w) {
  free(w->focus);
  free(w->wu);
  free(w->wv);
  free(w->uv);
  free(w->wuv);
  free(w->visible);
  ch_warp_cage_index_free(w->grids);
  memset(w, 0, sizeof *w);
}


static ch_status check_cage(const ch_warp_cage *cage, ch_error *err) {
  if (!cage || cage->num_triangles < 0 || (cage->num_triangles > 0 && (!cage->uv || !cage->position)))
    return ch_error_set(err, CH_ERR_INPUT, "warp: bad cage (negative count or missing arrays)");
  for (size_t i = 0; i < (size_t)cage->num_triangles * 6; i++)
    if (!isfinite(cage->uv[i]))
      return ch_error_set(err, CH_ERR_INPUT, "warp: cage triangle %zu has a non-finite UV", i / 6);
  for (size_t i = 0; i < (size_t)cage->num_triangles * 9; i++)
    if (!isfinite(cage->position[i]))
      return ch_error_set(err, CH_ERR_INPUT, "warp: cage triangle %zu has a non-finite position", i / 9);
  return CH_OK;
}

/* Allocates out for n intervals and the cage (UVs copied, W the identity). */
static ch_status warp_alloc(const ch_warp_cage *cage, int n, ch_warp *out, ch_error *err) {
  size_t nt = (size_t)cage->num_triangles, m = nt > 0 ? nt : 1;
  out->n = n;
  out->num_triangles = cage->num_triangles;
  out->wu = malloc((size_t)(n + 1) * sizeof *out->wu);
  out->wv = malloc((size_t)(n + 1) * sizeof *out->wv);
  out->uv = malloc(m * 6 * sizeof *out->uv);
  out->wuv = malloc(m * 6 * sizeof *out->wuv);
  out->visible = calloc(m, 1);
  if (!out->wu || !out->wv || !out->uv || !out->wuv || !out->visible) {
    ch_warp_free(out);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the warp");
  }
  if (nt > 0) memcpy(out->uv, cage->uv, nt * 6 * sizeof *out->uv);
  identity_knots(out->wu, n);
  identity_knots(out->wv, n);
  out->stats.max_slope[0] = out->stats.max_slope[1] = 1.0;
  return CH_OK;
}

ch_status ch_warp_identity(const ch_warp_cage *cage, int intervals, ch_warp *out, ch_error *err) {
  memset(out, 0, sizeof *out);
  int n = intervals ? intervals : DEFAULT_INTERVALS;
  if (n < 1 || n > MAX_INTERVALS)
    return ch_error_set(err, CH_ERR_INPUT, "warp: %d intervals outside [1, %d]", intervals, MAX_INTERVALS);
  ch_status st = check_cage(cage, err);
  if (!st) st = warp_alloc(cage, n, out, err);
  if (st) return st;
  double t0 = ch_progress_seconds();
  st = ch_warp_cage_finish(out, err);
  out->stats.seconds_grids = ch_progress_seconds() - t0;
  if (st) ch_warp_free(out);
  return st;
}

/* Box of each segment grown by half its groove width or its blur radius,
 * whichever is larger: what the curve touches in UV. */
static double (*curve_reach_boxes(const ch_curve_set *set))[4] {
  int ns = set->num_segments;
  double(*boxes)[4] = malloc((size_t)(ns > 0 ? ns : 1) * sizeof *boxes);
  if (!boxes) return NULL;
  for (int i = 0; i < ns; i++) {
    const ch_segment *s = &set->segments[i];
    const ch_curve *c = &set->curves[s->curve];
    double r = fmax(c->kind == CH_CURVE_GROOVE ? 0.5 * c->width : 0.0, c->blur);
    ch_segment_box(s, r, boxes[i]);
  }
  return boxes;
}

ch_status ch_warp_build(const ch_camera *cam, const ch_warp_cage *cage, const ch_curve_set *set,
                        const ch_warp_desc *desc, ch_warp *out, ch_error *err) {
  memset(out, 0, sizeof *out);
  ch_warp_desc d = desc ? *desc : (ch_warp_desc){0};
  int n = d.intervals ? d.intervals : DEFAULT_INTERVALS;
  double fl = d.floor != 0.0 ? d.floor : 0.1;
  double ms = d.max_slope != 0.0 ? d.max_slope : 64.0;
  double mr = d.max_ratio != 0.0 ? d.max_ratio : 1.25;
  double ex = d.exponent != 0.0 ? d.exponent : CH_WARP_EXPONENT;
  if (n < 1 || n > MAX_INTERVALS)
    return ch_error_set(err, CH_ERR_INPUT, "warp: %d intervals outside [1, %d]", d.intervals, MAX_INTERVALS);
  if (!(fl >= 0.0 && fl < 1.0)) return ch_error_set(err, CH_ERR_INPUT, "warp: floor %g outside [0, 1)", fl);
  if (!(ms >= 1.0) || !isfinite(ms))
    return ch_error_set(err, CH_ERR_INPUT, "warp: max_slope %g is not a finite number >= 1", ms);
  if (!(ex > 0.0 && ex <= 4.0))
    return ch_error_set(err, CH_ERR_INPUT, "warp: exponent %g outside (0, 4]", ex);
  if (!(mr > 1.0) || !isfinite(mr))
    return ch_error_set(err, CH_ERR_INPUT, "warp: max_ratio %g is not a finite number > 1", mr);
  ch_status st = check_cage(cage, err);
  if (st) return st;
  if ((st = warp_alloc(cage, n, out, err))) return st;

  /* Need per triangle. */
  double t0 = ch_progress_seconds();
  int nt = cage->num_triangles;
  double *tri_need = malloc((size_t)(nt > 0 ? nt : 1) * 2 * sizeof *tri_need);
  int *holds = malloc((size_t)(nt > 0 ? nt : 1) * sizeof *holds);
  double(*curve_boxes)[4] = NULL;
  ch_grid curve_grid = {0};
  int have_curves = set && set->num_segments > 0;
  if (!tri_need || !holds || (have_curves && !(curve_boxes = curve_reach_boxes(set)))) {
    st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for the warp");
    goto done;
  }
  if (have_curves && (st = ch_grid_build(&curve_grid, set->num_segments, (const double(*)[4])curve_boxes, err)))
    goto done;
  double lo[3], hi[3];
  ch_box3(cage->position, (size_t)nt * 3, lo, hi);
  double diag = nt > 0 ? sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                              (hi[2] - lo[2]) * (hi[2] - lo[2]))
                       : 0.0;
  /* The near plane and the least depth of the need: keeps the Jacobian
   * finite for triangles that reach the eye plane. */
  double near = 1e-6 * diag;
#pragma omp parallel for schedule(dynamic, 256)
  for (int t = 0; t < nt; t++)
    analyse_triangle(cam, cage->uv + 6 * (size_t)t, cage->position + 9 * (size_t)t, near,
                     have_curves ? &curve_grid : NULL, (const double(*)[4])curve_boxes, &out->visible[t],
                     &holds[t], tri_need + 2 * (size_t)t);
  if (ex != 1.0)
    for (size_t i = 0; i < 2 * (size_t)nt; i++)
      if (tri_need[i] > 0.0) tri_need[i] = pow(tri_need[i], ex);
  int nvis = 0, nneedy = 0;
  for (int t = 0; t < nt; t++) {
    nvis += out->visible[t];
    nneedy += out->visible[t] && holds[t];
  }
  out->stats.visible_triangles = nvis;
  out->stats.needy_triangles = nneedy;
  double t1 = ch_progress_seconds();
  out->stats.seconds_need = t1 - t0;

  /* Per axis: need per interval, spread, solved. */
  double *need = malloc((size_t)n * sizeof *need), *scratch = malloc((size_t)n * 2 * sizeof *scratch);
  if (!need || !scratch) {
    free(need);
    free(scratch);
    st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for the warp");
    goto done;
  }
  for (int axis = 0; axis < 2 && nneedy > 0; axis++) {
    for (int i = 0; i < n; i++) need[i] = 0.0;
    for (int t = 0; t < nt; t++) {
      double g = tri_need[2 * (size_t)t + axis];
      if (!(g > 0.0)) continue;
      const double *c = cage->uv + 6 * (size_t)t;
      double a = ch_min3(c[axis], c[2 + axis], c[4 + axis]), b = ch_max3(c[axis], c[2 + axis], c[4 + axis]);
      if (b < 0.0 || a > 1.0) continue;
      int i0 = (int)floor(fmax(a, 0.0) * n), i1 = (int)ceil(fmin(b, 1.0) * n) - 1;
      if (i0 > n - 1) i0 = n - 1;
      if (i1 < i0) i1 = i0;
      if (i1 > n - 1) i1 = n - 1;
      for (int i = i0; i <= i1; i++) need[i] = fmax(need[i], g);
    }
    /* Spread: need_i >= need_j / mr^|i - j|, so neighbouring slopes differ
     * by at most mr (the clamp keeps that). Needs that underflow to
     * denormals count as none: their breaks would overflow. */
    for (int i = 1; i < n; i++) need[i] = fmax(need[i], need[i - 1] / mr);
    for (int i = n - 2; i >= 0; i--) need[i] = fmax(need[i], need[i + 1] / mr);
    for (int i = 0; i < n; i++)
      if (need[i] < 1e-300) need[i] = 0.0;
    double *w = axis ? out->wv : out->wu;
    if (!solve_axis(need, n, fl, ms, w, scratch)) identity_knots(w, n);
  }
  free(need);
  free(scratch);
  out->stats.max_slope[0] = max_slope(out->wu, n);
  out->stats.max_slope[1] = max_slope(out->wv, n);
  out->floor = fl;
  if (nneedy > 0 && (st = build_focus(out, mr, err))) goto done;
  double t2 = ch_progress_seconds();
  out->stats.seconds_functions = t2 - t1;

  st = ch_warp_cage_finish(out, err);
  out->stats.seconds_grids = ch_progress_seconds() - t2;

done:
  free(tri_need);
  free(holds);
  free(curve_boxes);
  ch_grid_free(&curve_grid);
  if (st) ch_warp_free(out);
  return st;
}

/* ---- arc length under W ----------------------------------------------- */

/* Walks the UV segment a -> b from parameter 0 to t_end through the pieces
 * between its crossings with the knot lines (W is affine on each, so a
 * piece's image is straight). Returns the image's length; with target >= 0
 * it stops where the length reaches target and returns the parameter there
 * in *t_at (else *t_at = t_end). */
static double knot_walk(const ch_warp *w, int mesh, const double a[2], const double b[2], double t_end,
                        double target, double *t_at) {
  int n = w->n;
  double d[2] = {b[0] - a[0], b[1] - a[1]};
  int idx[2] = {0, 0}, step[2] = {0, 0};
  double tk[2];
  for (int k = 0; k < 2; k++) {
    /* The first knot line strictly ahead of a on axis k, and its parameter. */
    tk[k] = INFINITY;
    if (d[k] > 0.0) {
      step[k] = 1;
      idx[k] = a[k] < 0.0 ? 0 : (int)fmin(floor(a[k] * n) + 1.0, n + 1.0);
    } else if (d[k] < 0.0) {
      step[k] = -1;
      idx[k] = a[k] > 1.0 ? n : (int)fmax(ceil(a[k] * n) - 1.0, -1.0);
    } else {
      continue;
    }
    if (idx[k] >= 0 && idx[k] <= n) tk[k] = ((double)idx[k] / n - a[k]) / d[k];
  }
  double t = 0.0, len = 0.0;
  double prev[2] = {ch_warp_axis(w, 0, a[0]), ch_warp_axis(w, 1, a[1])};
  *t_at = t_end;
  while (t < t_end) {
    double tn = fmin(fmin(tk[0], tk[1]), t_end);
    double here[2];
    for (int k = 0; k < 2; k++) {
      /* On a knot line the knot value itself: sums along an axis telescope. */
      const double *kn = k ? w->wv : w->wu;
      here[k] = tn == tk[k] ? kn[idx[k]] : ch_warp_axis(w, k, a[k] + tn * d[k]);
    }
    double piece;
    if (mesh && w->focus) { /* the piece lies in one interval per axis, so in one focus cell */
      double tm = 0.5 * (t + tn), mid[2] = {a[0] + tm * d[0], a[1] + tm * d[1]}, m[2], axis[2];
      mesh_slopes_at(w, mid, axis, m);
      for (int k = 0; k < 2; k++) m[k] /= axis[k];
      piece = hypot(m[0] * (here[0] - prev[0]), m[1] * (here[1] - prev[1]));
    } else {
      piece = hypot(here[0] - prev[0], here[1] - prev[1]);
    }
    if (target >= 0.0 && len + piece >= target) {
      *t_at = piece > 0.0 ? t + (tn - t) * ((target - len) / piece) : t;
      return target;
    }
    len += piece;
    for (int k = 0; k < 2; k++)
      if (tn == tk[k]) {
        idx[k] += step[k];
        tk[k] = idx[k] >= 0 && idx[k] <= n ? ((double)idx[k] / n - a[k]) / d[k] : INFINITY;
      }
    t = tn;
    prev[0] = here[0];
    prev[1] = here[1];
  }
  return len;
}

static double arc(const ch_warp *w, int mesh, const double a[2], const double b[2], double x) {
  if (a[0] == b[0] && a[1] == b[1]) return 0.0;
  double t;
  return knot_walk(w, mesh, a, b, ch_clamp(x, 0.0, 1.0), -1.0, &t);
}

static double arc_inverse(const ch_warp *w, int mesh, const double a[2], const double b[2], double y) {
  y = ch_clamp(y, 0.0, 1.0);
  if (a[0] == b[0] && a[1] == b[1]) return y;
  double t, total = knot_walk(w, mesh, a, b, 1.0, -1.0, &t);
  if (!(total > 0.0)) return y;
  if (y >= 1.0) return 1.0;
  knot_walk(w, mesh, a, b, 1.0, y * total, &t);
  return ch_clamp(t, 0.0, 1.0);
}

double ch_warp_arc(const ch_warp *w, const double a[2], const double b[2], double x) { return arc(w, 0, a, b, x); }

double ch_warp_arc_inverse(const ch_warp *w, const double a[2], const double b[2], double y) {
  return arc_inverse(w, 0, a, b, y);
}

double ch_warp_mesh_arc(const ch_warp *w, const double a[2], const double b[2], double x) {
  return arc(w, 1, a, b, x);
}

double ch_warp_mesh_arc_inverse(const ch_warp *w, const double a[2], const double b[2], double y) {
  return arc_inverse(w, 1, a, b, y);
}
