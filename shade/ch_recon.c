/* Feature reconstruction, diffusion-curves-on-surfaces §3.3-3.4.
 *
 * A sample is valid when its closest curve point SP lies within one texel of
 * its centre in x and y. Near a curve (all four bilinear samples valid) the
 * curve is rebuilt as line segments joining the SPs of nearby valid samples
 * in order of their parameter along the chain, the segment nearest to the
 * query decides its side (ties at shared vertices broken by the extended
 * Voronoi rule), and the bilinear blend substitutes the opposite-side value
 * for samples lying across the curve. The 3x3 variant adds the per-sample
 * segments centre -> SP, whose side overrules a wrong segment at cusps.
 *
 * Departures from the paper: chains (one per subpath) replace its 2, 4, 6
 * curve numbering; closed chains wrap their parameter; links longer than
 * three texels are not made (they would cross a gap where the curve leaves
 * the window); curves with a blur are never reconstructed crisply. */
#include "ch_recon.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ch_bezier.h"
#include "ch_groove.h"

int ch_recon_method_parse(const char *name) {
  if (!strcmp(name, "bilinear")) return CH_RECON_BILINEAR;
  if (!strcmp(name, "recon5")) return CH_RECON_5X5;
  if (!strcmp(name, "recon3")) return CH_RECON_3X3;
  if (!strcmp(name, "exact")) return CH_RECON_EXACT;
  return -1;
}

/* Reach of the exact method's search, in texels: the query is within
 * sqrt 2 of a cell corner that is within sqrt 2 of the curve. */
#define EXACT_REACH 3.0
/* Longest link between two samples' curve points, texels. */
#define MAX_LINK 3.0

ch_status ch_recon_init(ch_recon *r, const ch_dci *dci, const ch_curve_set *set, ch_error *err) {
  memset(r, 0, sizeof *r);
  r->dci = dci;
  r->set = set;
  if (!set) return CH_OK;
  const ch_samples *s = &dci->samples;
  double reach = EXACT_REACH * fmax(s->texel[0], s->texel[1]);
  r->boxes = malloc((size_t)(set->num_segments > 0 ? set->num_segments : 1) * sizeof *r->boxes);
  if (!r->boxes) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the reconstruction");
  for (int i = 0; i < set->num_segments; i++) {
    const ch_segment *sg = &set->segments[i];
    const ch_curve *c = &set->curves[sg->curve];
    double *b = r->boxes[i];
    if (c->kind != CH_CURVE_STEP || c->blur > 0.0) {
      b[0] = b[1] = 1.0;
      b[2] = b[3] = 0.0;
      continue;
    }
    ch_segment_box(sg, reach, b);
  }
  ch_status st = ch_grid_build(&r->grid, set->num_segments, (const double(*)[4])r->boxes, err);
  if (st) {
    free(r->boxes);
    r->boxes = NULL;
  }
  return st;
}

void ch_recon_free(ch_recon *r) {
  ch_grid_free(&r->grid);
  free(r->boxes);
  memset(r, 0, sizeof *r);
}

/* ---- samples in a frame of texel units, v up: texel (x, y) is at (x, -y) ---- */

typedef struct rsample {
  double p[2];  /* SP */
  double c[2];  /* texel centre */
  int chain, curve, side;
  float param;
} rsample;

static int valid_sample(const ch_samples *s, size_t i) {
  return s->curve[i] >= 0 && s->exact[i] && !(s->side[i] & CH_SIDE_SOFT) && fabsf(s->offset[2 * i]) <= 1.0f &&
         fabsf(s->offset[2 * i + 1]) <= 1.0f;
}

static void load_sample(const ch_samples *s, int x, int y, rsample *out) {
  size_t i = (size_t)y * s->width + x;
  out->c[0] = x;
  out->c[1] = -y;
  out->p[0] = x + s->offset[2 * i];
  out->p[1] = -y + s->offset[2 * i + 1];
  out->chain = s->chain[i];
  out->curve = s->curve[i];
  out->side = s->side[i];
  out->param = s->param[i];
}

static int cmp_rsample(const void *a, const void *b) {
  const rsample *x = a, *y = b;
  if (x->chain != y->chain) return x->chain < y->chain ? -1 : 1;
  if (x->param != y->param) return x->param < y->param ? -1 : 1;
  return 0;
}

/* Distance from t to the segment a-b, with the extended Voronoi tie key:
 * where the closest point is an end, the distance to a point a quarter
 * texel (at most half the segment) inside it. */
typedef struct seg_dist {
  double d, key;
  double point[2];
} seg_dist;

static seg_dist segment_distance(const double a[2], const double b[2], const double t[2]) {
  double e[2] = {b[0] - a[0], b[1] - a[1]}, w[2] = {t[0] - a[0], t[1] - a[1]};
  double len2 = e[0] * e[0] + e[1] * e[1];
  double u = len2 > 0.0 ? (w[0] * e[0] + w[1] * e[1]) / len2 : 0.0;
  seg_dist r;
  double k = u <= 0.0 ? 0.0 : u >= 1.0 ? 1.0 : u;
  r.point[0] = a[0] + k * e[0];
  r.point[1] = a[1] + k * e[1];
  r.d = hypot(t[0] - r.point[0], t[1] - r.point[1]);
  r.key = r.d;
  if ((u <= 0.0 || u >= 1.0) && len2 > 0.0) {
    double len = sqrt(len2), step = fmin(0.25, 0.5 * len) / len;
    double kk = u <= 0.0 ? step : 1.0 - step;
    r.key = hypot(t[0] - (a[0] + kk * e[0]), t[1] - (a[1] + kk * e[1]));
  }
  return r;
}

static int closer(const seg_dist *x, const seg_dist *best) {
  if (x->d < best->d - 1e-12) return 1;
  if (x->d > best->d + 1e-12) return 0;
  return x->key < best->key;
}

/* The reconstructed edge near a query: which curve, which side, where. */
typedef struct edge {
  int found;
  int curve, side, at_end;
  double point[2]; /* texel frame */
  double distance; /* texels */
} edge;

/* Links samples sorted by (chain, param) into directed segments and finds
 * the closest one; with per_sample (3x3) the centre -> SP segments of its
 * two samples compete for the side. */
static void reconstruct(rsample *smp, int n, const double t[2], int per_sample, edge *out) {
  qsort(smp, (size_t)n, sizeof *smp, cmp_rsample);
  /* Samples sharing a curve point (all those in a corner's outer wedge
   * share the corner) become one vertex, so links meet at it. */
  int m = 0;
  for (int i = 0; i < n; i++) {
    if (m > 0 && smp[m - 1].chain == smp[i].chain && smp[m - 1].p[0] == smp[i].p[0] &&
        smp[m - 1].p[1] == smp[i].p[1])
      continue;
    smp[m++] = smp[i];
  }
  n = m;
  int link_a[25], link_b[25], links = 0;
  for (int i = 0; i < n; i++) {
    int first = i;
    while (i + 1 < n && smp[i + 1].chain == smp[first].chain) i++;
    int count = i - first + 1;
    int closed = (smp[first].side & CH_SIDE_CLOSED) != 0;
    int k_links = closed && count > 2 ? count : count - 1;
    for (int k = 0; k < k_links; k++) {
      int a = first + k, b = k + 1 < count ? a + 1 : first;
      /* Along a closed chain the way forward is the shorter one round. */
      if (closed && fmodf(smp[b].param - smp[a].param + 1.0f, 1.0f) > 0.5f) {
        int tmp = a;
        a = b;
        b = tmp;
      }
      double gap = hypot(smp[b].p[0] - smp[a].p[0], smp[b].p[1] - smp[a].p[1]);
      if (gap > MAX_LINK || gap == 0.0) continue;
      link_a[links] = a;
      link_b[links++] = b;
    }
  }
  seg_dist best = {INFINITY, INFINITY, {0, 0}};
  int bl = -1;
  for (int k = 0; k < links; k++) {
    seg_dist sd = segment_distance(smp[link_a[k]].p, smp[link_b[k]].p, t);
    if (closer(&sd, &best)) {
      best = sd;
      bl = k;
    }
  }
  out->found = 0;
  if (bl < 0) {
    /* No link (a lone sample): its own side, if any. */
    if (n == 0) return;
    int k = 0;
    double dk = INFINITY;
    for (int i = 0; i < n; i++) {
      double d = hypot(t[0] - smp[i].p[0], t[1] - smp[i].p[1]);
      if (d < dk) dk = d, k = i;
    }
    out->found = 1;
    out->curve = smp[k].curve;
    out->side = smp[k].side & (CH_SIDE_LEFT | CH_SIDE_RIGHT);
    out->at_end = (smp[k].side & CH_SIDE_END) != 0;
    out->point[0] = smp[k].p[0];
    out->point[1] = smp[k].p[1];
    out->distance = dk;
    return;
  }
  int ba = link_a[bl], bb = link_b[bl];
  double e[2] = {smp[bb].p[0] - smp[ba].p[0], smp[bb].p[1] - smp[ba].p[1]};
  double w[2] = {t[0] - best.point[0], t[1] - best.point[1]};
  int left = e[0] * w[1] - e[1] * w[0] >= 0.0;
  /* At a vertex where two links meet, the sector between them decides
   * (the extended Voronoi tie-break alone misjudges sharp corners). */
  int vertex = best.point[0] == smp[ba].p[0] && best.point[1] == smp[ba].p[1] ? ba
               : best.point[0] == smp[bb].p[0] && best.point[1] == smp[bb].p[1] ? bb
                                                                                : -1;
  if (vertex >= 0) {
    for (int k = 0; k < links; k++) {
      int in = link_b[k] == vertex && vertex == ba, out_ = link_a[k] == vertex && vertex == bb;
      if (!in && !out_) continue;
      int pa = in ? link_a[k] : ba, pv = vertex, pb = in ? bb : link_b[k];
      double tin[2] = {smp[pv].p[0] - smp[pa].p[0], smp[pv].p[1] - smp[pa].p[1]};
      double tout[2] = {smp[pb].p[0] - smp[pv].p[0], smp[pb].p[1] - smp[pv].p[1]};
      left = ch_joint_side(tin, tout, w) > 0;
      break;
    }
  }
  int side = left ? CH_SIDE_LEFT : CH_SIDE_RIGHT;
  if (per_sample) {
    const rsample *ends[2] = {&smp[ba], &smp[bb]};
    seg_dist sbest = best;
    for (int k = 0; k < 2; k++) {
      seg_dist sd = segment_distance(ends[k]->c, ends[k]->p, t);
      if (closer(&sd, &sbest)) {
        sbest = sd;
        side = ends[k]->side & (CH_SIDE_LEFT | CH_SIDE_RIGHT);
      }
    }
  }
  out->found = 1;
  out->curve = smp[ba].curve;
  out->side = side;
  out->at_end = ((smp[ba].side | smp[bb].side) & CH_SIDE_END) != 0;
  out->point[0] = best.point[0];
  out->point[1] = best.point[1];
  out->distance = best.d;
}

/* The exact edge of one curve: its closest point and q's side of it. */
static void exact_edge(const ch_recon *r, int curve, double u, double v, edge *out) {
  const ch_samples *s = &r->dci->samples;
  double q[2] = {u, v};
  ch_curve_point cp = {.segment = -1};
  double best;
  cp.segment = ch_curve_closest_in_cell(r->set, &r->grid, (const double *)r->boxes, curve, q, 0.0, 0, &best, &cp.t);
  if (cp.segment >= 0) {
    ch_segment_point(&r->set->segments[cp.segment], cp.t, cp.point);
    cp.distance = sqrt(best);
    cp.signed_distance = cp.distance * ch_curve_side(r->set, cp.segment, cp.t, q);
  } else {
    ch_curve_closest(r->set, curve, q, &cp); /* beyond the grid's reach */
  }
  const ch_segment *sg = &r->set->segments[cp.segment];
  out->found = 1;
  out->curve = curve;
  out->side = cp.signed_distance >= 0.0 ? CH_SIDE_LEFT : CH_SIDE_RIGHT;
  out->at_end = (cp.t <= 0.0 && sg->prev < 0) || (cp.t >= 1.0 && sg->next < 0);
  /* Into the texel frame (x right, v up, texel units). */
  out->point[0] = (cp.point[0] - s->rect[0]) / s->texel[0] - 0.5;
  out->point[1] = -((s->rect[3] - cp.point[1]) / s->texel[1] - 0.5);
  out->distance = cp.distance / sqrt(s->texel[0] * s->texel[1]);
}

/* T's side of every curve seen by the four bilinear samples. */
typedef struct curve_sides {
  int n;
  int curve[4];
  edge e[4];
} curve_sides;

static const edge *side_for(const curve_sides *cs, int curve) {
  for (int k = 0; k < cs->n; k++)
    if (cs->curve[k] == curve) return cs->e[k].found ? &cs->e[k] : NULL;
  return NULL;
}

/* Bilinear blend of the four samples: a sample lying across its curve from
 * the query (by that curve's reconstructed edge) contributes the value on
 * the other side. flip inverts every side decision (for anti-aliasing).
 *
 * Near a singular point of the DCI (ch_dci.h) h is to first order T, linear
 * in the angle, which no bilinear blend follows: there the blend is also
 * taken of h - T, smooth, and T at the query added back (T unwindowed: a
 * window's curvature, some J / w^2, would itself be more than a bilinear
 * blend follows). The two blends are mixed by the window of the point, so
 * the value is continuous where the window ends. A sample across a curve
 * stands for the query's side of it at its closest curve point, so its T
 * is taken there, on that side. sp: the point (or -1), qt: T at the query,
 * psi: its window there. The DCI's double layers (whole open curves)
 * round the query t are taken out and added back the same way, each mixed
 * by its own window. */
static void blend(const ch_dci *d, const int xs[2], const int ys[2], double fx, double fy, const curve_sides *cs,
                  int flip, int sp, double qt, double psi, const double t[2], float *value, float color[3]) {
  const ch_samples *s = &d->samples;
  /* the layers whose windows hold the query: their window, W there, and
   * (below) the blend of W at the samples */
  enum { MAX_LAYERS = 64 };
  const int *items;
  int lay[MAX_LAYERS], nl = 0, m = ch_dci_layers_at(d, t, &items);
  double lphi[MAX_LAYERS], lq[MAX_LAYERS], lw[MAX_LAYERS];
  for (int j = 0; j < m && nl < MAX_LAYERS; j++) {
    double phi = ch_dci_layer_window(d, items[j], t);
    if (!(phi > 0.0)) continue;
    lay[nl] = items[j];
    lphi[nl] = phi;
    lq[nl] = ch_dlayer_value(&d->layers[items[j]], t, NULL);
    lw[nl++] = 0.0;
  }
  double w[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
  double acc = 0.0, acc_t = 0.0, rgb[3] = {0, 0, 0};
  for (int k = 0; k < 4; k++) {
    int x = xs[k % 2], y = ys[k / 2];
    size_t i = (size_t)y * s->width + x;
    const edge *e = cs && s->curve[i] >= 0 ? side_for(cs, s->curve[i]) : NULL;
    int across = 0, side = 0;
    if (e && !e->at_end) {
      side = e->side;
      if (flip) side = side == CH_SIDE_LEFT ? CH_SIDE_RIGHT : CH_SIDE_LEFT;
      across = (s->side[i] & (CH_SIDE_LEFT | CH_SIDE_RIGHT)) != side;
    }
    double v = across ? s->value[2 * i + 1] : d->h[i];
    acc += w[k] * v;
    /* the double layers round the query: W at the sample (across a curve,
     * at its closest point on the query's side) */
    for (int j = 0; j < nl; j++) {
      const ch_dlayer *l = &d->layers[lay[j]];
      if (!across) {
        double c[2] = {x, -y};
        lw[j] += w[k] * ch_dlayer_value(l, c, NULL);
      } else {
        double cp[2] = {x + s->offset[2 * i], -y + s->offset[2 * i + 1]}, nrm[2];
        ch_dci_side_normal(d, i, side, nrm);
        lw[j] += w[k] * ch_dlayer_value_beside(l, cp, nrm);
      }
    }
    if (sp >= 0) {
      double cp[2] = {x + s->offset[2 * i], -y + s->offset[2 * i + 1]};
      if (across) {
        acc_t += w[k] * ch_dci_sing_value(d, sp, cp, s->curve[i], side, cp);
      } else {
        double c[2] = {x, -y};
        int own = (s->side[i] & CH_SIDE_END) ? -1 : s->curve[i];
        acc_t += w[k] * ch_dci_sing_value(d, sp, c, own, s->side[i] & (CH_SIDE_LEFT | CH_SIDE_RIGHT), cp);
      }
    }
    if (d->rgb)
      for (int c = 0; c < 3; c++) rgb[c] += w[k] * (across ? s->color[6 * i + 3 + c] : d->rgb[3 * i + c]);
  }
  if (sp >= 0) acc += psi * (qt - acc_t);
  for (int j = 0; j < nl; j++) acc += lphi[j] * (lq[j] - lw[j]);
  *value = (float)acc;
  for (int c = 0; c < 3; c++) color[c] = (float)rgb[c];
}

/* The singular point whose window holds the query t (texel frame), its
 * window there, and T at t: the branch from the deciding edge where there
 * is one, else from the sample of the nearest corner. */
static int query_term(const ch_dci *d, const double t[2], const edge *e, int flip, const int xs[2], const int ys[2],
                      double fx, double fy, double *qt, double *psi) {
  int k = d->num_sing ? ch_dci_sing_at(d, t) : -1;
  if (k < 0) return -1;
  *psi = ch_dci_sing_window(d, k, t);
  if (e) {
    int side = e->side;
    if (flip) side = side == CH_SIDE_LEFT ? CH_SIDE_RIGHT : CH_SIDE_LEFT;
    *qt = ch_dci_sing_value(d, k, t, e->at_end ? -1 : e->curve, side, e->point);
    return k;
  }
  const ch_samples *s = &d->samples;
  int x = xs[fx > 0.5], y = ys[fy > 0.5];
  size_t i = (size_t)y * s->width + x;
  double cp[2] = {x + s->offset[2 * i], -y + s->offset[2 * i + 1]};
  int curve = (s->side[i] & CH_SIDE_END) ? -1 : s->curve[i];
  *qt = ch_dci_sing_value(d, k, t, curve, s->side[i] & (CH_SIDE_LEFT | CH_SIDE_RIGHT), cp);
  return k;
}

/* A curve point this close (texels) to a corner of the bilinear cell means
 * the curve may cross the cell: every point of the cell is within sqrt 2 of
 * each corner. (The paper tests the samples' validity instead, which misses
 * curves that clip a corner of the cell.) */
#define NEAR_CELL 1.41422

static void recon_eval(const ch_recon *r, ch_recon_method method, double u, double v, double footprint,
                       int force_curve, int force_side, ch_recon_sample *out);

void ch_recon_eval(const ch_recon *r, ch_recon_method method, double u, double v, double footprint,
                   ch_recon_sample *out) {
  recon_eval(r, method, u, v, footprint, -1, 0, out);
}

void ch_recon_eval_side(const ch_recon *r, ch_recon_method method, double u, double v, int curve, int side,
                        ch_recon_sample *out) {
  recon_eval(r, method, u, v, 0.0, curve, side, out);
}

/* The texel grid's coordinates of (u, v), clamped to the texels' centres
 * (gx right, gy down). */
static inline void grid_point(const ch_samples *s, double u, double v, double *gx, double *gy) {
  int W = s->width, H = s->height;
  double x = (u - s->rect[0]) / s->texel[0] - 0.5, y = (s->rect[3] - v) / s->texel[1] - 0.5;
  *gx = x < 0.0 ? 0.0 : x > W - 1 ? W - 1 : x;
  *gy = y < 0.0 ? 0.0 : y > H - 1 ? H - 1 : y;
}

/* The bilinear cell of grid point (gx, gy): its corner texels' columns xs
 * and rows ys, and the fractions along them. */
static inline void grid_cell(const ch_samples *s, double gx, double gy, int xs[2], int ys[2], double *fx, double *fy) {
  int W = s->width, H = s->height;
  int x0 = (int)floor(gx), y0 = (int)floor(gy);
  if (x0 > W - 2) x0 = W > 1 ? W - 2 : 0;
  if (y0 > H - 2) y0 = H > 1 ? H - 2 : 0;
  xs[0] = x0, xs[1] = x0 + 1 < W ? x0 + 1 : x0;
  ys[0] = y0, ys[1] = y0 + 1 < H ? y0 + 1 : y0;
  *fx = gx - x0, *fy = gy - y0;
}

/* Whether texel i lets its curve decide points of the cells it is a corner
 * of (recon_eval's test). */
static inline int texel_near_curve(const ch_samples *s, size_t i) {
  return s->curve[i] >= 0 && s->exact[i] && !(s->side[i] & CH_SIDE_SOFT) && !(s->distance[i] > NEAR_CELL);
}

int ch_recon_box_is_plain(const ch_recon *r, ch_recon_method method, double u0, double v0, double u1, double v1) {
  const ch_dci *d = r->dci;
  const ch_samples *s = &d->samples;
  if (d->rgb || !(u0 <= u1 && v0 <= v1)) return 0;
  double gx0, gy0, gx1, gy1;
  grid_point(s, u0, v1, &gx0, &gy0);
  grid_point(s, u1, v0, &gx1, &gy1);
  /* every corner texel of every cell the box's points fall in (one more
   * each way than needed, for the clamping at the last texel) */
  int x0 = (int)floor(gx0) - 1, y0 = (int)floor(gy0) - 1, x1 = (int)floor(gx1) + 2, y1 = (int)floor(gy1) + 2;
  x0 = x0 < 0 ? 0 : x0, y0 = y0 < 0 ? 0 : y0;
  x1 = x1 > s->width - 1 ? s->width - 1 : x1, y1 = y1 > s->height - 1 ? s->height - 1 : y1;
  if ((long)(x1 - x0 + 1) * (y1 - y0 + 1) > 64) return 0;
  if (method != CH_RECON_BILINEAR)
    for (int y = y0; y <= y1; y++)
      for (int x = x0; x <= x1; x++)
        if (texel_near_curve(s, (size_t)y * s->width + x)) return 0;
  double lo[2] = {gx0, -gy1}, hi[2] = {gx1, -gy0};
  return ch_dci_box_has_no_terms(d, lo, hi);
}

float ch_recon_eval_plain(const ch_recon *r, double u, double v) {
  const ch_samples *s = &r->dci->samples;
  const float *h = r->dci->h;
  double gx, gy, fx, fy;
  int xs[2], ys[2];
  grid_point(s, u, v, &gx, &gy);
  grid_cell(s, gx, gy, xs, ys, &fx, &fy);
  /* blend()'s sum without curves or terms, in its order: the same bits */
  double w[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy}, acc = 0.0;
  for (int k = 0; k < 4; k++) acc += w[k] * h[(size_t)ys[k / 2] * s->width + xs[k % 2]];
  return (float)acc;
}

static void recon_eval(const ch_recon *r, ch_recon_method method, double u, double v, double footprint,
                       int force_curve, int force_side, ch_recon_sample *out) {
  const ch_dci *d = r->dci;
  const ch_samples *s = &d->samples;
  int W = s->width, H = s->height;
  double gx, gy, fx, fy;
  int xs[2], ys[2];
  grid_point(s, u, v, &gx, &gy);
  grid_cell(s, gx, gy, xs, ys, &fx, &fy);
  double t[2] = {gx, -gy};
  memset(out, 0, sizeof *out);
  out->curve = -1;

  /* The curves near the cell. */
  curve_sides cs = {0};
  if (method != CH_RECON_BILINEAR) {
    for (int k = 0; k < 4; k++) {
      size_t i = (size_t)ys[k / 2] * W + xs[k % 2];
      int c = s->curve[i];
      if (!texel_near_curve(s, i)) continue;
      int seen = 0;
      for (int j = 0; j < cs.n; j++) seen |= cs.curve[j] == c;
      if (!seen) cs.curve[cs.n++] = c;
    }
  }
  if (cs.n > 0 && method == CH_RECON_EXACT && r->set) {
    for (int k = 0; k < cs.n; k++) exact_edge(r, cs.curve[k], u, v, &cs.e[k]);
  } else if (cs.n > 0 && (method == CH_RECON_5X5 || method == CH_RECON_3X3)) {
    int half = method == CH_RECON_5X5 ? 2 : 1;
    int cx = (int)floor(gx + 0.5), cy = (int)floor(gy + 0.5);
    rsample all[25], smp[25];
    int n = 0;
    for (int y = cy - half; y <= cy + half; y++)
      for (int x = cx - half; x <= cx + half; x++)
        if (x >= 0 && y >= 0 && x < W && y < H && valid_sample(s, (size_t)y * W + x)) load_sample(s, x, y, &all[n++]);
    for (int k = 0; k < cs.n; k++) {
      int m = 0;
      for (int j = 0; j < n; j++)
        if (all[j].curve == cs.curve[k]) smp[m++] = all[j];
      reconstruct(smp, m, t, method == CH_RECON_3X3, &cs.e[k]);
    }
  }
  /* The edge that decides the point: the nearest of the curves' edges, or
   * the one the caller names, on the caller's side. */
  const edge *e = NULL;
  for (int k = 0; k < cs.n; k++)
    if (cs.e[k].found && (!e || cs.e[k].distance < e->distance)) e = &cs.e[k];
  for (int k = 0; k < cs.n; k++)
    if (cs.e[k].found && cs.curve[k] == force_curve) {
      cs.e[k].side = force_side;
      e = &cs.e[k];
    }
  double qt = 0.0, psi = 0.0;
  int sp = query_term(d, t, e, 0, xs, ys, fx, fy, &qt, &psi);
  blend(d, xs, ys, fx, fy, e ? &cs : NULL, 0, sp, qt, psi, t, &out->value, out->color);
  if (!e) return;
  out->curve = e->curve;
  out->side = e->side;
  out->point[0] = s->rect[0] + (e->point[0] + 0.5) * s->texel[0];
  out->point[1] = s->rect[3] - (-e->point[1] + 0.5) * s->texel[1];
  out->distance = e->distance * sqrt(s->texel[0] * s->texel[1]);
  /* Anti-aliasing (§3.4, eq. 1) within half a pixel of the edge. */
  if (footprint > 0.0 && !e->at_end) {
    double dp = out->distance / footprint;
    if (dp < 0.5) {
      float other, other_rgb[3];
      double qo = 0.0;
      query_term(d, t, e, 1, xs, ys, fx, fy, &qo, &psi);
      blend(d, xs, ys, fx, fy, &cs, 1, sp, qo, psi, t, &other, other_rgb);
      double a = 1.0 - 2.0 * dp;
      out->value = (float)(a * 0.5 * (out->value + other) + 2.0 * dp * out->value);
      for (int c = 0; c < 3; c++)
        out->color[c] = (float)(a * 0.5 * (out->color[c] + other_rgb[c]) + 2.0 * dp * out->color[c]);
    }
  }
}
