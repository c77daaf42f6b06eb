/* The accuracy figures over the planar base: see accuracy.h for the
 * definitions. */
#include "accuracy.h"

#include <ctype.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "ch_alloc.h"
#include "ch_bezier.h"
#include "ch_grid.h"
#include "ch_groove.h"
#include "ch_sort.h"

#define PI_ 3.14159265358979323846

/* Central-difference step for the exact gradient (UV). Normal samples are at
 * least CH_ACCURACY_NORMAL_MIN from every wall and crease, so a stencil of
 * +-1e-5 stays on the sample's side of all of them. */
#define GRADIENT_STEP 1e-5
/* Distances are resolved up to this bound at least; a mesh so coarse that
 * 2e exceeds it (fewer than ~20000 triangles) extends them. */
#define DEFAULT_REACH 0.02
/* Rows per rasterisation band. */
#define BAND_ROWS 16
/* Triangles whose |n_z| is not above this are vertical (walls): skipped. */
#define VERTICAL_NZ 1e-3
/* Vertices must lie within [-COORD_LIMIT, COORD_LIMIT] in x and y for the
 * exact integer edge functions (|X| <= 2^29 with G S = 2^26). */
#define COORD_LIMIT 8.0

/* ---- walls and creases ----------------------------------------------------- */

typedef struct feature_index {
  ch_grid grid;
  double (*boxes)[4];  /* per segment; empty for curves that are no feature */
  int *crease_start;   /* per curve: offsets into creases (num_curves + 1) */
  double *creases;     /* groove: s offsets t_k w; steps: none (distance to the curve) */
  unsigned char *kind; /* per curve: 0 none, 1 groove, 2 sharp step */
} feature_index;

static void feature_index_free(feature_index *fi) {
  ch_grid_free(&fi->grid);
  free(fi->boxes);
  free(fi->crease_start);
  free(fi->creases);
  free(fi->kind);
  memset(fi, 0, sizeof *fi);
}

static ch_status feature_index_init(feature_index *fi, const ch_curve_set *set, double reach, ch_error *err) {
  memset(fi, 0, sizeof *fi);
  int nc = set->num_curves, ns = set->num_segments;
  fi->boxes = malloc((size_t)(ns > 0 ? ns : 1) * sizeof *fi->boxes);
  fi->crease_start = calloc((size_t)nc + 1, sizeof *fi->crease_start);
  fi->creases = malloc(((size_t)nc * (CH_PROFILE_MAX_POINTS + 2) + 1) * sizeof *fi->creases);
  fi->kind = calloc((size_t)(nc > 0 ? nc : 1), 1);
  if (!fi->boxes || !fi->crease_start || !fi->creases || !fi->kind) {
    feature_index_free(fi);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the feature index");
  }
  int n = 0;
  for (int c = 0; c < nc; c++) {
    const ch_curve *cv = &set->curves[c];
    fi->crease_start[c] = n;
    if (cv->kind == CH_CURVE_GROOVE) {
      double t[CH_PROFILE_MAX_POINTS + 2];
      int k = ch_profile_creases(&cv->profile, t, CH_PROFILE_MAX_POINTS + 2);
      for (int i = 0; i < k; i++) fi->creases[n++] = t[i] * cv->width;
      fi->kind[c] = k > 0 && cv->width > 0.0 && cv->depth != 0.0 ? 1 : 0;
      if (!fi->kind[c]) n = fi->crease_start[c];
    } else if (cv->blur <= 0.0) {
      fi->kind[c] = 2; /* a sharp step: wall (left != right) or crease */
    }
  }
  fi->crease_start[nc] = n;
  for (int i = 0; i < ns; i++) {
    const ch_segment *s = &set->segments[i];
    const ch_curve *cv = &set->curves[s->curve];
    double *b = fi->boxes[i];
    if (!fi->kind[s->curve]) {
      b[0] = b[1] = 1.0;
      b[2] = b[3] = 0.0;
      continue;
    }
    double r = reach + (fi->kind[s->curve] == 1 ? 0.5 * cv->width : 0.0);
    b[0] = fmin(fmin(s->p[0][0], s->p[1][0]), s->p[2][0]) - r;
    b[1] = fmin(fmin(s->p[0][1], s->p[1][1]), s->p[2][1]) - r;
    b[2] = fmax(fmax(s->p[0][0], s->p[1][0]), s->p[2][0]) + r;
    b[3] = fmax(fmax(s->p[0][1], s->p[1][1]), s->p[2][1]) + r;
  }
  ch_status st = ch_grid_build(&fi->grid, ns, (const double(*)[4])fi->boxes, err);
  if (st) feature_index_free(fi);
  return st;
}

/* Distance from q to the nearest wall or crease line, or +inf beyond reach.
 * Segments come in index order, so each curve's segments form one run;
 * the closest point of a curve is exact whenever it is within the grown
 * box radius (its segment's box then holds q). */
static double feature_distance(const feature_index *fi, const ch_curve_set *set, double reach, const double q[2]) {
  const int *items;
  int n = ch_grid_query(&fi->grid, q[0], q[1], &items);
  double best = INFINITY;
  int k = 0;
  while (k < n) {
    int curve = set->segments[items[k]].curve;
    double d2 = INFINITY, t_best = 0.0;
    int seg_best = -1;
    for (; k < n && set->segments[items[k]].curve == curve; k++) {
      int i = items[k];
      const double *b = fi->boxes[i];
      if (q[0] < b[0] || q[0] > b[2] || q[1] < b[1] || q[1] > b[3]) continue;
      double t;
      double e2 = ch_bezier_closest(set->segments[i].p, set->segments[i].is_line, q, &t);
      if (e2 < d2) {
        d2 = e2;
        t_best = t;
        seg_best = i;
      }
    }
    if (seg_best < 0) continue;
    double d = sqrt(d2);
    if (fi->kind[curve] == 2) {
      if (d < best) best = d;
      continue;
    }
    const ch_curve *cv = &set->curves[curve];
    if (d > 0.5 * cv->width + reach) continue;
    double s = d * ch_curve_side(set, seg_best, t_best, q);
    for (int j = fi->crease_start[curve]; j < fi->crease_start[curve + 1]; j++) {
      double e = fabs(s - fi->creases[j]);
      if (e < best) best = e;
    }
  }
  return best <= reach ? best : INFINITY;
}

static ch_status compute_distances(ch_accuracy_reference *ref, double reach, ch_error *err) {
  feature_index fi;
  ch_status st = feature_index_init(&fi, ref->set, reach, err);
  if (st) return st;
  int G = ref->grid;
#pragma omp parallel for schedule(dynamic, 4)
  for (int j = 0; j < G; j++) {
    for (int i = 0; i < G; i++) {
      double q[2] = {(i + 0.5) / G, (j + 0.5) / G};
      ref->dist[(size_t)j * G + i] = feature_distance(&fi, ref->set, reach, q);
    }
  }
  feature_index_free(&fi);
  ref->reach = reach;
  return CH_OK;
}

/* ---- the reference ----------------------------------------------------------- */

void ch_accuracy_reference_free(ch_accuracy_reference *ref) {
  free(ref->h);
  free(ref->dist);
  free(ref->grad);
  memset(ref, 0, sizeof *ref);
}

ch_status ch_accuracy_reference_init(ch_accuracy_reference *ref, const ch_height *height,
                                     const ch_curve_set *set, int grid, ch_error *err) {
  memset(ref, 0, sizeof *ref);
  if (grid < 1 || grid > 16384)
    return ch_error_set(err, CH_ERR_INPUT, "accuracy grid %d outside 1..16384", grid);
  int G = grid;
  size_t n = (size_t)G * G;
  ref->grid = G;
  ref->height = height;
  ref->set = set;
  ref->h = malloc(n * sizeof *ref->h);
  ref->dist = malloc(n * sizeof *ref->dist);
  ref->grad = malloc(2 * n * sizeof *ref->grad);
  double *row_max = calloc((size_t)G, sizeof *row_max);
  if (!ref->h || !ref->dist || !ref->grad || !row_max) {
    free(row_max);
    ch_accuracy_reference_free(ref);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for a %d x %d accuracy grid", G, G);
  }
#pragma omp parallel for schedule(dynamic, 4)
  for (int j = 0; j < G; j++) {
    double m = 0.0;
    for (int i = 0; i < G; i++) {
      double h = ch_height_eval(height, (i + 0.5) / G, (j + 0.5) / G);
      ref->h[(size_t)j * G + i] = h;
      if (fabs(h) > m) m = fabs(h);
    }
    row_max[j] = m;
  }
  for (int j = 0; j < G; j++)
    if (row_max[j] > ref->max_abs_h) ref->max_abs_h = row_max[j];
  free(row_max);
  ch_status st = compute_distances(ref, DEFAULT_REACH, err);
  if (st) {
    ch_accuracy_reference_free(ref);
    return st;
  }
  const double dl = GRADIENT_STEP;
#pragma omp parallel for schedule(dynamic, 4)
  for (int j = 0; j < G; j++) {
    for (int i = 0; i < G; i++) {
      size_t k = (size_t)j * G + i;
      double d = ref->dist[k];
      if (d >= CH_ACCURACY_NORMAL_MIN && d <= CH_ACCURACY_NORMAL_MAX) {
        double u = (i + 0.5) / G, v = (j + 0.5) / G;
        double hu = (ch_height_eval(height, u + dl, v) - ch_height_eval(height, u - dl, v)) / (2 * dl);
        double hv = (ch_height_eval(height, u, v + dl) - ch_height_eval(height, u, v - dl)) / (2 * dl);
        ref->grad[2 * k] = (float)hu;
        ref->grad[2 * k + 1] = (float)hv;
      } else {
        ref->grad[2 * k] = ref->grad[2 * k + 1] = NAN;
      }
    }
  }
  return CH_OK;
}

/* ---- rasterisation ------------------------------------------------------------- */

typedef struct raster_tri {
  int p[3];   /* position indices, counter-clockwise in the snapped xy */
  int c[3];   /* its corners (for their normals), in the same order */
  int j0, j1; /* sample rows it may cover */
} raster_tri;

static int64_t floor_div(int64_t a, int64_t b) { /* b > 0 */
  int64_t q = a / b;
  return (a % b != 0 && a < 0) ? q - 1 : q;
}

/* First and last sample index k with k S + S/2 in [lo, hi] (may be empty). */
static void sample_range(int64_t lo, int64_t hi, int64_t S, int64_t *k0, int64_t *k1) {
  *k0 = -floor_div(-(lo - S / 2), S); /* ceil */
  *k1 = floor_div(hi - S / 2, S);
}

/* Whether sample (X, Y) is on the inner (left) side of the directed edge
 * P -> Q, exactly; on the edge, whether (X + eps, Y + eps^2) is. */
static inline int edge_inside(int64_t px, int64_t py, int64_t qx, int64_t qy, int64_t X, int64_t Y) {
  int64_t dx = qx - px, dy = qy - py;
  int64_t e = dx * (Y - py) - dy * (X - px);
  return e > 0 || (e == 0 && (dy < 0 || (dy == 0 && dx > 0)));
}

static void face_normal(const double *pos, const int p[3], double n[3]) {
  const double *a = pos + 3 * (size_t)p[0], *b = pos + 3 * (size_t)p[1], *c = pos + 3 * (size_t)p[2];
  double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  double e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  n[0] = e1[1] * e2[2] - e1[2] * e2[1];
  n[1] = e1[2] * e2[0] - e1[0] * e2[2];
  n[2] = e1[0] * e2[1] - e1[1] * e2[0];
}

/* The mesh's corner normals of triangle rt interpolated at (x, y) by its
 * barycentric coordinates in xy (what a renderer's smooth shading shows
 * there), oriented to n_z > 0; 0 when the mesh has no normals or they
 * cancel. */
static int shading_normal(const ch_mesh *mesh, const raster_tri *rt, double x, double y, double n[3]) {
  if (!mesh->normals || !mesh->corner_normal) return 0;
  const double *a = mesh->positions + 3 * (size_t)rt->p[0], *b = mesh->positions + 3 * (size_t)rt->p[1],
               *c = mesh->positions + 3 * (size_t)rt->p[2];
  double d = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
  if (!(fabs(d) > 0.0)) return 0;
  double w1 = ((x - a[0]) * (c[1] - a[1]) - (y - a[1]) * (c[0] - a[0])) / d;
  double w2 = ((b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0])) / d, w[3] = {1.0 - w1 - w2, w1, w2};
  n[0] = n[1] = n[2] = 0.0;
  for (int k = 0; k < 3; k++) {
    int i = mesh->corner_normal[rt->c[k]];
    if (i < 0 || i >= mesh->num_normals) return 0;
    const double *m = mesh->normals + 3 * (size_t)i;
    double l = sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
    if (!(l > 0.0)) return 0;
    for (int j = 0; j < 3; j++) n[j] += w[k] * m[j] / l;
  }
  if (n[2] < 0.0) n[0] = -n[0], n[1] = -n[1], n[2] = -n[2];
  return n[0] * n[0] + n[1] * n[1] + n[2] * n[2] > 0.0;
}

/* The angle between a and b in degrees: atan2(|a x b|, a . b), accurate
 * for small angles. */
static double angle_deg(const double a[3], const double b[3]) {
  double cx = a[1] * b[2] - a[2] * b[1], cy = a[2] * b[0] - a[0] * b[2], cz = a[0] * b[1] - a[1] * b[0];
  return atan2(sqrt(cx * cx + cy * cy + cz * cz), a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) * (180.0 / PI_);
}

typedef struct raster {
  int G;
  int64_t S;
  double *z;    /* G^2, -inf where uncovered */
  int *tri;     /* G^2, index into tris, -1 where uncovered */
  raster_tri *tris;
  long num_tris;
  long triangles; /* all fan triangles */
} raster;

static void raster_free(raster *r) {
  free(r->z);
  free(r->tri);
  free(r->tris);
  memset(r, 0, sizeof *r);
}

static ch_status rasterise(const ch_mesh *mesh, int G, raster *r, ch_error *err) {
  memset(r, 0, sizeof *r);
  r->G = G;
  int64_t S = 1;
  while ((int64_t)G * S * 2 <= ((int64_t)1 << 26)) S *= 2;
  r->S = S;
  const double scale = (double)G * (double)S;
  size_t n = (size_t)G * G;
  int np = mesh->num_positions;
  int32_t *snap = malloc(2 * (size_t)(np > 0 ? np : 1) * sizeof *snap);
  unsigned char *valid = malloc((size_t)(np > 0 ? np : 1));
  long ntri = 0;
  for (int f = 0; f < mesh->num_faces; f++) {
    int k = mesh->face_start[f + 1] - mesh->face_start[f];
    if (k >= 3) ntri += k - 2;
  }
  r->triangles = ntri;
  r->tris = malloc((size_t)(ntri > 0 ? ntri : 1) * sizeof *r->tris);
  r->z = malloc(n * sizeof *r->z);
  r->tri = malloc(n * sizeof *r->tri);
  if (!snap || !valid || !r->tris || !r->z || !r->tri) {
    free(snap);
    free(valid);
    raster_free(r);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory rasterising the mesh");
  }
  for (int p = 0; p < np; p++) {
    const double *x = mesh->positions + 3 * (size_t)p;
    valid[p] = isfinite(x[0]) && isfinite(x[1]) && isfinite(x[2]) && fabs(x[0]) <= COORD_LIMIT &&
               fabs(x[1]) <= COORD_LIMIT;
    snap[2 * p] = valid[p] ? (int32_t)llround(x[0] * scale) : 0;
    snap[2 * p + 1] = valid[p] ? (int32_t)llround(x[1] * scale) : 0;
  }
  /* The triangles that can cover samples, in face order. */
  long far = 0, m = 0;
  for (int f = 0; f < mesh->num_faces; f++) {
    int c0 = mesh->face_start[f], k = mesh->face_start[f + 1] - c0;
    for (int t = 1; t + 1 < k; t++) {
      raster_tri rt = {{mesh->corner_position[c0], mesh->corner_position[c0 + t], mesh->corner_position[c0 + t + 1]},
                       {c0, c0 + t, c0 + t + 1},
                       0,
                       0};
      if (!valid[rt.p[0]] || !valid[rt.p[1]] || !valid[rt.p[2]]) {
        far++;
        continue;
      }
      double nrm[3];
      face_normal(mesh->positions, rt.p, nrm);
      double len = sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
      if (!(len > 0.0) || !(fabs(nrm[2]) > VERTICAL_NZ * len)) continue;
      int64_t ax = snap[2 * rt.p[0]], ay = snap[2 * rt.p[0] + 1];
      int64_t bx = snap[2 * rt.p[1]], by = snap[2 * rt.p[1] + 1];
      int64_t cx = snap[2 * rt.p[2]], cy = snap[2 * rt.p[2] + 1];
      int64_t area2 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax);
      if (area2 == 0) continue;
      if (area2 < 0) {
        int tmp = rt.p[1];
        rt.p[1] = rt.p[2];
        rt.p[2] = tmp;
        tmp = rt.c[1];
        rt.c[1] = rt.c[2];
        rt.c[2] = tmp;
      }
      int64_t ylo = ay < by ? (ay < cy ? ay : cy) : (by < cy ? by : cy);
      int64_t yhi = ay > by ? (ay > cy ? ay : cy) : (by > cy ? by : cy);
      int64_t xlo = ax < bx ? (ax < cx ? ax : cx) : (bx < cx ? bx : cx);
      int64_t xhi = ax > bx ? (ax > cx ? ax : cx) : (bx > cx ? bx : cx);
      int64_t j0, j1, i0, i1;
      sample_range(ylo, yhi, S, &j0, &j1);
      sample_range(xlo, xhi, S, &i0, &i1);
      if (j0 < 0) j0 = 0;
      if (j1 > G - 1) j1 = G - 1;
      if (i0 < 0) i0 = 0;
      if (i1 > G - 1) i1 = G - 1;
      if (j0 > j1 || i0 > i1) continue;
      rt.j0 = (int)j0;
      rt.j1 = (int)j1;
      r->tris[m++] = rt;
    }
  }
  r->num_tris = m;
  free(valid);
  if (far) ch_warn(err, "%ld triangles with a vertex outside [-%g, %g] in x or y (or not finite) left out", far,
                   COORD_LIMIT, COORD_LIMIT);
  /* Bins of BAND_ROWS rows, each holding its triangles in order. */
  int nb = (G + BAND_ROWS - 1) / BAND_ROWS;
  size_t *bin_start = calloc((size_t)nb + 1, sizeof *bin_start);
  if (!bin_start) {
    free(snap);
    raster_free(r);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory rasterising the mesh");
  }
  for (long t = 0; t < m; t++)
    for (int b = r->tris[t].j0 / BAND_ROWS; b <= r->tris[t].j1 / BAND_ROWS; b++) bin_start[b + 1]++;
  for (int b = 0; b < nb; b++) bin_start[b + 1] += bin_start[b];
  int *bins = malloc((bin_start[nb] > 0 ? bin_start[nb] : 1) * sizeof *bins);
  size_t *fill = malloc((size_t)nb * sizeof *fill);
  if (!bins || !fill) {
    free(bins);
    free(fill);
    free(bin_start);
    free(snap);
    raster_free(r);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory rasterising the mesh");
  }
  memcpy(fill, bin_start, (size_t)nb * sizeof *fill);
  for (long t = 0; t < m; t++)
    for (int b = r->tris[t].j0 / BAND_ROWS; b <= r->tris[t].j1 / BAND_ROWS; b++) bins[fill[b]++] = (int)t;
  free(fill);

  const double *pos = mesh->positions;
#pragma omp parallel for schedule(dynamic, 1)
  for (int b = 0; b < nb; b++) {
    int row0 = b * BAND_ROWS, row1 = row0 + BAND_ROWS - 1;
    if (row1 > G - 1) row1 = G - 1;
    for (int j = row0; j <= row1; j++)
      for (int i = 0; i < G; i++) {
        r->z[(size_t)j * G + i] = -INFINITY;
        r->tri[(size_t)j * G + i] = -1;
      }
    for (size_t q = bin_start[b]; q < bin_start[b + 1]; q++) {
      int t = bins[q];
      const raster_tri *rt = &r->tris[t];
      int64_t ax = snap[2 * rt->p[0]], ay = snap[2 * rt->p[0] + 1];
      int64_t bx = snap[2 * rt->p[1]], by = snap[2 * rt->p[1] + 1];
      int64_t cx = snap[2 * rt->p[2]], cy = snap[2 * rt->p[2] + 1];
      int64_t xlo = ax < bx ? (ax < cx ? ax : cx) : (bx < cx ? bx : cx);
      int64_t xhi = ax > bx ? (ax > cx ? ax : cx) : (bx > cx ? bx : cx);
      int64_t i0, i1;
      sample_range(xlo, xhi, S, &i0, &i1);
      if (i0 < 0) i0 = 0;
      if (i1 > G - 1) i1 = G - 1;
      /* z on the plane of the unsnapped triangle. */
      double nrm[3];
      face_normal(pos, rt->p, nrm);
      const double *p0 = pos + 3 * (size_t)rt->p[0];
      double gx = -nrm[0] / nrm[2], gy = -nrm[1] / nrm[2];
      int ja = rt->j0 > row0 ? rt->j0 : row0, jb = rt->j1 < row1 ? rt->j1 : row1;
      for (int j = ja; j <= jb; j++) {
        int64_t Y = (int64_t)j * S + S / 2;
        double y = (j + 0.5) / G;
        for (int64_t i = i0; i <= i1; i++) {
          int64_t X = i * S + S / 2;
          if (!edge_inside(ax, ay, bx, by, X, Y) || !edge_inside(bx, by, cx, cy, X, Y) ||
              !edge_inside(cx, cy, ax, ay, X, Y))
            continue;
          double x = (i + 0.5) / G;
          double z = p0[2] + gx * (x - p0[0]) + gy * (y - p0[1]);
          size_t k = (size_t)j * G + (size_t)i;
          if (r->tri[k] < 0 || z > r->z[k]) {
            r->z[k] = z;
            r->tri[k] = t;
          }
        }
      }
    }
  }
  free(bins);
  free(bin_start);
  free(snap);
  return CH_OK;
}

/* ---- the figures ------------------------------------------------------------------ */

ch_status ch_accuracy_measure_reference(ch_accuracy_reference *ref, const ch_mesh *mesh, ch_accuracy *out,
                                        ch_error *err) {
  memset(out, 0, sizeof *out);
  if (!mesh || mesh->num_faces <= 0)
    return ch_error_set(err, CH_ERR_INPUT, "accuracy: the mesh has no faces");
  int G = ref->grid;
  size_t n = (size_t)G * G;
  raster r;
  ch_status st = rasterise(mesh, G, &r, err);
  if (st) return st;
  out->triangles = r.triangles;
  out->edge_length = r.triangles > 0 ? sqrt(2.0 / (double)r.triangles) : 1.0;
  out->max_abs_h = ref->max_abs_h;
  double band_dist = 2.0 * out->edge_length;
  if (band_dist > ref->reach) {
    st = compute_distances(ref, band_dist * (1.0 + 1e-9), err);
    if (st) {
      raster_free(&r);
      return st;
    }
  }
  double hmax = ref->max_abs_h > 0.0 ? ref->max_abs_h : 1.0;
  double wrong_tol = 0.1 * hmax;
  double *row = calloc(4 * (size_t)G, sizeof *row); /* l1 sum, angle sum, shading angle sum per row */
  long *cnt = calloc(6 * (size_t)G, sizeof *cnt);   /* covered, band, wrong, normal, counted, shading */
  double *angles = malloc(n * sizeof *angles);
  int shaded = mesh->normals && mesh->corner_normal;
  double *shading = shaded ? malloc(n * sizeof *shading) : NULL;
  if (!row || !cnt || !angles || (shaded && !shading)) {
    free(row);
    free(cnt);
    free(angles);
    free(shading);
    raster_free(&r);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory measuring the mesh");
  }
  const double *pos = mesh->positions;
#pragma omp parallel for schedule(dynamic, 8)
  for (int j = 0; j < G; j++) {
    double l1 = 0.0, asum = 0.0, ssum = 0.0;
    long covered = 0, band = 0, wrong = 0, nn = 0, counted = 0, ns_count = 0;
    double *arow = angles + (size_t)j * G, *srow = shading ? shading + (size_t)j * G : NULL;
    for (int i = 0; i < G; i++) {
      size_t k = (size_t)j * G + i;
      if (ref->mask && !ref->mask[k]) {
        if (ref->error_map) ref->error_map[k] = NAN;
        if (ref->normal_map) ref->normal_map[k] = NAN;
        if (ref->shading_map) ref->shading_map[k] = NAN;
        continue;
      }
      counted++;
      int t = r.tri[k];
      double h = ref->h[k], d = ref->dist[k];
      double err_h = t >= 0 ? fabs(r.z[k] - h) : INFINITY;
      if (ref->error_map) ref->error_map[k] = t >= 0 ? (float)((r.z[k] - h) / hmax) : NAN;
      if (ref->normal_map) ref->normal_map[k] = NAN;
      if (ref->shading_map) ref->shading_map[k] = NAN;
      if (t >= 0) {
        covered++;
        l1 += err_h;
      }
      if (d <= band_dist) {
        band++;
        if (!(err_h <= wrong_tol)) wrong++;
      }
      if (t >= 0 && d >= CH_ACCURACY_NORMAL_MIN && d <= CH_ACCURACY_NORMAL_MAX) {
        double nf[3], me[3] = {-(double)ref->grad[2 * k], -(double)ref->grad[2 * k + 1], 1.0};
        face_normal(pos, r.tris[t].p, nf);
        if (nf[2] < 0.0) nf[0] = -nf[0], nf[1] = -nf[1], nf[2] = -nf[2];
        double a = angle_deg(nf, me), ns[3];
        if (srow && shading_normal(mesh, &r.tris[t], (i + 0.5) / G, (j + 0.5) / G, ns)) {
          double b = angle_deg(ns, me);
          srow[ns_count++] = b;
          if (ref->shading_map) ref->shading_map[k] = (float)b;
          ssum += b;
        }
        arow[nn++] = a;
        if (ref->normal_map) ref->normal_map[k] = (float)a;
        asum += a;
      }
    }
    row[4 * (size_t)j] = l1;
    row[4 * (size_t)j + 1] = asum;
    row[4 * (size_t)j + 2] = ssum;
    cnt[6 * (size_t)j] = covered;
    cnt[6 * (size_t)j + 1] = band;
    cnt[6 * (size_t)j + 2] = wrong;
    cnt[6 * (size_t)j + 3] = nn;
    cnt[6 * (size_t)j + 4] = counted;
    cnt[6 * (size_t)j + 5] = ns_count;
  }
  double l1 = 0.0, asum = 0.0, ssum = 0.0;
  long covered = 0, band = 0, wrong = 0, nn = 0, counted = 0, ns = 0;
  for (int j = 0; j < G; j++) {
    l1 += row[4 * (size_t)j];
    asum += row[4 * (size_t)j + 1];
    ssum += row[4 * (size_t)j + 2];
    covered += cnt[6 * (size_t)j];
    band += cnt[6 * (size_t)j + 1];
    wrong += cnt[6 * (size_t)j + 2];
    counted += cnt[6 * (size_t)j + 4];
    long rn = cnt[6 * (size_t)j + 3], rs = cnt[6 * (size_t)j + 5];
    /* Compact the rows' angles to the front, in row order. */
    memmove(angles + nn, angles + (size_t)j * G, (size_t)rn * sizeof *angles);
    nn += rn;
    if (shading) memmove(shading + ns, shading + (size_t)j * G, (size_t)rs * sizeof *shading);
    ns += rs;
  }
  out->samples = covered;
  out->band_samples = band;
  out->normal_samples = nn;
  out->l1 = covered > 0 ? l1 / (double)covered / hmax : 0.0;
  out->band = band > 0 ? (double)wrong / (double)band : 0.0;
  out->holes = counted > 0 ? (double)(counted - covered) / (double)counted : 0.0;
  out->counted = counted;
  out->normal_mean_deg = nn > 0 ? asum / (double)nn : 0.0;
  if (nn > 0) {
    long rank = (long)ceil(0.95 * (double)nn) - 1;
    if (rank < 0) rank = 0;
    out->normal_p95_deg = ch_sort_select(angles, nn, rank);
  }
  out->shading_samples = ns;
  out->shading_mean_deg = ns > 0 ? ssum / (double)ns : NAN;
  out->shading_p95_deg = NAN;
  if (ns > 0) {
    long rank = (long)ceil(0.95 * (double)ns) - 1;
    out->shading_p95_deg = ch_sort_select(shading, ns, rank < 0 ? 0 : rank);
  }
  free(shading);
  free(row);
  free(cnt);
  free(angles);
  raster_free(&r);
  return CH_OK;
}

ch_status ch_accuracy_measure(const ch_mesh *mesh, const ch_height *height, const ch_curve_set *set, int grid,
                              ch_accuracy *out, ch_error *err) {
  ch_accuracy_reference ref;
  memset(out, 0, sizeof *out);
  ch_status st = ch_accuracy_reference_init(&ref, height, set, grid, err);
  if (st) return st;
  st = ch_accuracy_measure_reference(&ref, mesh, out, err);
  ch_accuracy_reference_free(&ref);
  return st;
}

/* ---- the uniform-grid baseline ------------------------------------------------------ */

int ch_accuracy_uniform_n(long target) {
  if (target < 2) return 1;
  long n = (long)floor(sqrt((double)target / 2.0));
  if (n < 1) n = 1;
  long best = n;
  for (long c = n; c <= n + 1; c++) {
    long e = labs(2 * c * c - target), eb = labs(2 * best * best - target);
    if (e < eb) best = c;
  }
  return (int)best;
}

ch_status ch_accuracy_uniform_grid(const ch_height *height, int n, ch_mesh *out, ch_error *err) {
  memset(out, 0, sizeof *out);
  if (n < 1 || 6.0 * (double)n * n > (double)CH_MESH_MAX_ELEMENTS)
    return ch_error_set(err, CH_ERR_INPUT, "uniform grid %d x %d out of range", n, n);
  int nv = (n + 1) * (n + 1), nf = 2 * n * n;
  out->num_positions = nv;
  out->num_uvs = nv;
  out->num_faces = nf;
  out->num_corners = 3 * nf;
  out->positions = malloc(3 * (size_t)nv * sizeof *out->positions);
  out->uvs = malloc(2 * (size_t)nv * sizeof *out->uvs);
  out->face_start = malloc(((size_t)nf + 1) * sizeof *out->face_start);
  out->corner_position = malloc(3 * (size_t)nf * sizeof *out->corner_position);
  out->corner_uv = malloc(3 * (size_t)nf * sizeof *out->corner_uv);
  if (!out->positions || !out->uvs || !out->face_start || !out->corner_position || !out->corner_uv) {
    ch_mesh_free(out);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for a %d x %d grid", n, n);
  }
#pragma omp parallel for schedule(dynamic, 4)
  for (int j = 0; j <= n; j++) {
    for (int i = 0; i <= n; i++) {
      size_t k = (size_t)j * (n + 1) + i;
      double u = (double)i / n, v = (double)j / n;
      out->positions[3 * k] = u;
      out->positions[3 * k + 1] = v;
      out->positions[3 * k + 2] = ch_height_eval(height, u, v);
      out->uvs[2 * k] = u;
      out->uvs[2 * k + 1] = v;
    }
  }
  size_t f = 0;
  for (int j = 0; j < n; j++) {
    for (int i = 0; i < n; i++) {
      int v00 = j * (n + 1) + i, v10 = v00 + 1, v01 = v00 + n + 1, v11 = v01 + 1;
      int tri[2][3];
      if ((i + j) % 2 == 0) {
        int a[2][3] = {{v00, v10, v11}, {v00, v11, v01}};
        memcpy(tri, a, sizeof tri);
      } else {
        int a[2][3] = {{v00, v10, v01}, {v10, v11, v01}};
        memcpy(tri, a, sizeof tri);
      }
      for (int t = 0; t < 2; t++, f++) {
        out->face_start[f] = (int)(3 * f);
        for (int c = 0; c < 3; c++) {
          out->corner_position[3 * f + c] = tri[t][c];
          out->corner_uv[3 * f + c] = tri[t][c];
        }
      }
    }
  }
  out->face_start[nf] = 3 * nf;
  return CH_OK;
}

ch_status ch_accuracy_read_raster(const ch_height *height, int R, ch_mesh *mesh, ch_error *err) {
  float *img = malloc((size_t)R * R * sizeof *img);
  if (!img) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for a %d x %d raster", R, R);
#pragma omp parallel for schedule(dynamic, 8)
  for (int y = 0; y < R; y++)
    for (int x = 0; x < R; x++) img[(size_t)y * R + x] = (float)ch_height_eval(height, (x + 0.5) / R, (y + 0.5) / R);
#pragma omp parallel for schedule(static)
  for (int v = 0; v < mesh->num_positions; v++) {
    double *p = &mesh->positions[3 * (size_t)v];
    double fx = fmin(fmax(p[0] * R - 0.5, 0.0), R - 1.0), fy = fmin(fmax(p[1] * R - 0.5, 0.0), R - 1.0);
    int x0 = (int)fx, y0 = (int)fy, x1 = x0 + 1 < R ? x0 + 1 : x0, y1 = y0 + 1 < R ? y0 + 1 : y0;
    double ax = fx - x0, ay = fy - y0;
    const float *r0 = &img[(size_t)y0 * R], *r1 = &img[(size_t)y1 * R];
    p[2] = (1 - ay) * ((1 - ax) * r0[x0] + ax * r0[x1]) + ay * ((1 - ax) * r1[x0] + ax * r1[x1]);
  }
  free(img);
  return CH_OK;
}

/* ---- reading OBJ ---------------------------------------------------------------- */

/* Three finite numbers from q into out; nonzero if there are not. */
static int read_three(const char *q, double out[3]) {
  for (int k = 0; k < 3; k++) {
    char *next;
    out[k] = strtod(q, &next);
    if (next == q || !isfinite(out[k])) return -1;
    q = next;
  }
  return 0;
}

static ch_status out_of_memory(ch_error *err, const char *path) {
  return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory", path);
}

ch_status ch_accuracy_parse_obj(char *text, size_t size, const char *path, ch_mesh *m, ch_error *err) {
  memset(m, 0, sizeof *m);
  /* (counts stay below CH_MESH_MAX_ELEMENTS, checked every line: ints) */
  int np = 0, nf = 0, nc = 0, nn = 0, cap_p = 0, cap_f = 0, cap_c = 0, cap_cn = 0, cap_n = 0;
  double *pos = NULL, *nrm = NULL;
  int *fs = NULL, *cp = NULL, *cn = NULL;
  int every_corner_normal = 1; /* (normals are kept only if every corner names one) */
  ch_status st = CH_OK;
  long line = 0;
  char *p = text, *end = text + size;
  while (p < end && !st) {
    line++;
    char *eol = memchr(p, '\n', (size_t)(end - p));
    if (!eol) eol = end;
    *eol = '\0';
    if (p[0] == 'v' && (p[1] == ' ' || p[1] == '\t')) {
      if (ch_alloc_grow((void **)&pos, &cap_p, np + 1, 3 * sizeof *pos, 1024)) {
        st = out_of_memory(err, path);
        break;
      }
      if (read_three(p + 1, &pos[3 * (size_t)np]))
        st = ch_error_set(err, CH_ERR_INPUT, "%s: line %ld: bad vertex", path, line);
      np++;
    } else if (p[0] == 'v' && p[1] == 'n' && (p[2] == ' ' || p[2] == '\t')) {
      if (ch_alloc_grow((void **)&nrm, &cap_n, nn + 1, 3 * sizeof *nrm, 1024)) {
        st = out_of_memory(err, path);
        break;
      }
      if (read_three(p + 2, &nrm[3 * (size_t)nn]))
        st = ch_error_set(err, CH_ERR_INPUT, "%s: line %ld: bad normal", path, line);
      nn++;
    } else if (p[0] == 'f' && (p[1] == ' ' || p[1] == '\t')) {
      int first = nc;
      char *q = p + 1;
      for (;;) {
        while (*q == ' ' || *q == '\t' || *q == '\r') q++;
        if (!*q) break;
        char *next;
        long idx = strtol(q, &next, 10);
        if (next == q) {
          st = ch_error_set(err, CH_ERR_INPUT, "%s: line %ld: bad face", path, line);
          break;
        }
        if (idx < 0) idx += (long)np + 1;
        if (idx < 1 || idx > (long)np) {
          st = ch_error_set(err, CH_ERR_INPUT, "%s: line %ld: vertex index out of range", path, line);
          break;
        }
        if (ch_alloc_grow((void **)&cp, &cap_c, nc + 1, sizeof *cp, 4096) ||
            ch_alloc_grow((void **)&cn, &cap_cn, nc + 1, sizeof *cn, 4096)) {
          st = out_of_memory(err, path);
          break;
        }
        /* v/vt/vn or v//vn: the normal's index after the second slash */
        long normal = 0;
        q = next;
        if (*q == '/') {
          q++;
          while (*q && *q != '/' && *q != ' ' && *q != '\t' && *q != '\r') q++;
          if (*q == '/' && (isdigit((unsigned char)q[1]) || q[1] == '-')) normal = strtol(q + 1, &next, 10), q = next;
        }
        if (normal < 0) normal += (long)nn + 1;
        if (normal < 1 || normal > (long)nn) every_corner_normal = 0;
        cn[nc] = (int)(normal - 1);
        cp[nc++] = (int)(idx - 1);
        while (*q && *q != ' ' && *q != '\t' && *q != '\r') q++;
      }
      if (!st && nc - first < 3)
        st = ch_error_set(err, CH_ERR_INPUT, "%s: line %ld: face with fewer than 3 corners", path, line);
      if (!st) {
        if (ch_alloc_grow((void **)&fs, &cap_f, nf + 1, sizeof *fs, 1024))
          st = out_of_memory(err, path);
        else
          fs[nf++] = first;
      }
    }
    if (!st && (np > CH_MESH_MAX_ELEMENTS || nc > CH_MESH_MAX_ELEMENTS || nn > CH_MESH_MAX_ELEMENTS))
      st = ch_error_set(err, CH_ERR_INPUT, "%s: too many elements", path);
    p = eol + 1;
  }
  if (!st && ch_alloc_grow((void **)&fs, &cap_f, nf + 1, sizeof *fs, 1)) /* (the end of the last face) */
    st = out_of_memory(err, path);
  if (st || !every_corner_normal || nn == 0) {
    free(nrm);
    free(cn);
    nrm = NULL;
    cn = NULL;
    nn = 0;
  }
  if (st) {
    free(pos);
    free(fs);
    free(cp);
    return st;
  }
  fs[nf] = nc;
  m->num_positions = np;
  m->positions = pos;
  m->num_faces = nf;
  m->face_start = fs;
  m->num_corners = nc;
  m->corner_position = cp;
  m->num_normals = nn;
  m->normals = nrm;
  m->corner_normal = cn;
  return CH_OK;
}
