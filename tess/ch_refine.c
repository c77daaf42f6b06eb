/* The working mesh and its refinement (see ch_refine_internal.h). */
#include "ch_refine_internal.h"

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

/* Capacity for need elements: by a quarter at a time, not double (the
 * working mesh is the embedding's largest array and a round adds a few
 * percent to it). Each growth copies (ch_alloc_resize); doubling below
 * 64 MiB saved the copies of a 130k run's pilot (28, 50 MB) but left the
 * README example's peak 15 MB higher (136 -> 151 MB), in the heap's holes. */
static int grow(void **p, int *cap, int need, size_t size) {
  if (need <= *cap) return 0;
  int n = *cap ? *cap : 1024;
  while (n < need) n = n > (1 << 29) ? need : n + n / 4 + 1;
  if (ch_alloc_resize(p, (size_t)*cap, (size_t)n, size)) return -1;
  *cap = n;
  return 0;
}

void ch_refine_lerp2(const double a[2], const double b[2], double x, double out[2]) {
  out[0] = a[0] + x * (b[0] - a[0]);
  out[1] = a[1] + x * (b[1] - a[1]);
}

/* The (s,t) in face of a new point from its UV (UV is linear in each face,
 * its (s,t) is not: an N-gon's sub-faces tile the parameter plane, so
 * interpolating (s,t) across a triangle can leave the domain). st holds
 * the interpolated guess, kept if the point is not found. */
void ch_refine_locate_st(const ch_surface *surface, int face, const double uv[2], double st[2]) {
  double found[2];
  if (ch_surface_locate(surface, face, uv, found) == CH_OK) memcpy(st, found, sizeof found);
}

/* The corners of e's canonical triangle at e->a (*i) and e->b (*j). */
static void edge_corners(const ch_refine_mesh *w, const ch_refine_edge *e, int *i, int *j) {
  int k1 = (e->k + 1) % 3;
  *i = w->tris[e->tri].v[e->k] == e->a ? e->k : k1;
  *j = *i == e->k ? k1 : e->k;
}

/* The UV and (s,t) of edge e at fraction x from e->a, in its canonical triangle. */
void ch_refine_edge_point(const ch_refine_mesh *w, const ch_refine_edge *e, double x, double uv[2], double st[2]) {
  const ch_refine_tri *t = &w->tris[e->tri];
  int i, j;
  edge_corners(w, e, &i, &j);
  if (uv) ch_refine_lerp2(t->uv[i], t->uv[j], x, uv);
  if (st) ch_refine_lerp2(t->st[i], t->st[j], x, st);
}

/* What the crossing search walks along: a straight UV segment from a to b
 * (an edge in its canonical triangle's chart, or a spoke of a junction),
 * with the labels of its two ends. */
typedef struct span {
  double a[2], b[2];
  uint64_t la, lb;
} span;

/* The point at fraction x from a (ch_refine_edge_point's for an edge). */
static void span_point(const span *s, double x, double uv[2]) { ch_refine_lerp2(s->a, s->b, x, uv); }

static uint64_t span_label(const ch_label_ctx *lb, const span *s, double x) {
  if (x <= 0.0) return s->la;
  if (x >= 1.0) return s->lb;
  double uv[2];
  span_point(s, x, uv);
  return ch_label_at(lb, uv);
}

int ch_refine_pools_init(ch_refine_mesh *w) {
  int n = omp_get_max_threads();
  w->pools = aligned_alloc(_Alignof(ch_refine_pool), (size_t)n * sizeof *w->pools);
  if (!w->pools) return -1;
  memset(w->pools, 0, (size_t)n * sizeof *w->pools);
  w->npools = n;
  return 0;
}

void ch_refine_pools_free(ch_refine_mesh *w) {
  for (int i = 0; i < w->npools; i++) {
    for (int b = 0; b < w->pools[i].nblocks; b++) free(w->pools[i].blocks[b]);
    free(w->pools[i].blocks);
  }
  free(w->pools);
  w->pools = NULL;
  w->npools = 0;
}

/* n crossings from the calling thread's pool (NULL when out of memory). */
static ch_refine_crossing *pool_take(const ch_refine_mesh *w, int n) {
  enum { BLOCK = 1 << 20 }; /* (a 2.1M-triangle run's lists take about 40 MB) */
  int t = omp_get_thread_num();
  if (t >= w->npools) return NULL;
  ch_refine_pool *p = &w->pools[t];
  size_t bytes = (size_t)n * sizeof(ch_refine_crossing);
  if (!p->block || p->size - p->used < bytes) {
    size_t size = bytes > BLOCK ? bytes : BLOCK;
    char *block = NULL;
    if (ch_alloc_grow((void **)&p->blocks, &p->cap, p->nblocks + 1, sizeof *p->blocks, 16) || !(block = malloc(size)))
      return NULL;
    p->blocks[p->nblocks++] = block;
    p->block = block;
    p->size = size;
    p->used = 0;
  }
  ch_refine_crossing *out = (ch_refine_crossing *)(p->block + p->used);
  p->used += bytes;
  return out;
}

/* The unique edges of the triangles, sorted by vertex pair (a counting
 * sort by the lower vertex, then each short run by the other); the
 * canonical triangle of an edge is the lowest one holding it. Refinement
 * then updates them in place (ch_refine_split). */
ch_status ch_refine_build_edges(ch_refine_mesh *w, ch_error *err) {
  size_t n = 3 * (size_t)w->ntris;
  int nv = w->nverts;
  int *start = ch_alloc_large((size_t)nv + 1, sizeof *start, 1);
  int *fill = ch_alloc_large((size_t)nv + 1, sizeof *fill, 0);
  int(*entry)[2] = ch_alloc_large(n, sizeof *entry, 0); /* other vertex, corner */
  size_t cap_index = n > 3 * (size_t)w->cap_tris ? n : 3 * (size_t)w->cap_tris; /* the triangles' room too */
  w->edges = ch_alloc_large(n, sizeof *w->edges, 0);
  w->tri_edge = ch_alloc_large(cap_index, sizeof *w->tri_edge, 0);
  if (!start || !fill || !entry || !w->edges || !w->tri_edge) {
    free(start);
    free(fill);
    free(entry);
    free(w->edges);
    free(w->tri_edge);
    w->edges = NULL;
    w->tri_edge = NULL;
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for %zu mesh edges", n);
  }
  /* Corners by their edge's lower vertex (a counting sort, in parallel:
   * each bucket is then sorted by (other vertex, corner), so the order
   * the slots were taken in does not matter), then per vertex its edges
   * counted, numbered by a prefix sum and filled: the same edges, in the
   * same order, as one serial pass in corner order (a 20M-triangle run
   * spent seconds here on one core). */
#pragma omp parallel for schedule(static)
  for (size_t c = 0; c < n; c++) {
    int a = w->tris[c / 3].v[c % 3], b = w->tris[c / 3].v[(c % 3 + 1) % 3];
#pragma omp atomic
    start[(a < b ? a : b) + 1]++;
  }
  for (int v = 0; v < nv; v++) start[v + 1] += start[v];
  memcpy(fill, start, ((size_t)nv + 1) * sizeof *fill);
#pragma omp parallel for schedule(static)
  for (size_t c = 0; c < n; c++) {
    int a = w->tris[c / 3].v[c % 3], b = w->tris[c / 3].v[(c % 3 + 1) % 3];
    int lo = a < b ? a : b, hi = a < b ? b : a, at;
#pragma omp atomic capture
    at = fill[lo]++;
    entry[at][0] = hi;
    entry[at][1] = (int)c;
  }
  /* fill[a]: a's edges (after sorting its bucket), then their first index */
#pragma omp parallel for schedule(dynamic, 4096)
  for (int a = 0; a < nv; a++) {
    int s0 = start[a], s1 = start[a + 1], count = 0;
    for (int p = s0 + 1; p < s1; p++) /* by (other vertex, corner) */
      for (int q = p; q > s0 && (entry[q - 1][0] > entry[q][0] ||
                                 (entry[q - 1][0] == entry[q][0] && entry[q - 1][1] > entry[q][1]));
           q--) {
        int t0 = entry[q][0], t1 = entry[q][1];
        entry[q][0] = entry[q - 1][0];
        entry[q][1] = entry[q - 1][1];
        entry[q - 1][0] = t0;
        entry[q - 1][1] = t1;
      }
    for (int i = s0; i < s1; i++) count += i == s0 || entry[i][0] != entry[i - 1][0];
    fill[a] = count;
  }
  int ne = 0;
  for (int a = 0; a < nv; a++) {
    int c = fill[a];
    fill[a] = ne;
    ne += c;
  }
#pragma omp parallel for schedule(dynamic, 4096)
  for (int a = 0; a < nv; a++) {
    int s1 = start[a + 1], k = fill[a];
    for (int i = start[a]; i < s1;) {
      int j = i + 1;
      while (j < s1 && entry[j][0] == entry[i][0]) j++;
      ch_refine_edge *e = &w->edges[k];
      memset(e, 0, sizeof *e);
      e->a = a;
      e->b = entry[i][0];
      e->tri = entry[i][1] / 3;
      e->k = entry[i][1] % 3;
      e->mid = -1;
      e->ncross = -1; /* not computed */
      for (int p = i; p < j; p++) w->tri_edge[entry[p][1]] = k;
      k++;
      i = j;
    }
  }
  w->nedges = ne;
  w->cap_edges = (int)n;
  w->cap_tri_edge = (int)cap_index;
  free(start);
  free(fill);
  free(entry);
  return CH_OK;
}

double ch_refine_edge_length(const ch_refine_mesh *w, const ch_refine_edge *e) {
  double a[2], b[2];
  ch_refine_edge_point(w, e, 0.0, a, NULL);
  ch_refine_edge_point(w, e, 1.0, b, NULL);
  return ch_dist2d(b[0] - a[0], b[1] - a[1]);
}

/* Signed distance from uv to step curve c over c's segments in the step
 * grid's cell (boxes grown by the radius); beyond the radius, the closest
 * of c's segments in the cell (the level functions only need a distance
 * beyond the radius there), or over all of c's segments if the cell has
 * none. */
static double step_distance_at(const ch_label_ctx *lb, int c, const double uv[2], int *segment) {
  return ch_label_signed_distance_in(lb, &lb->step_grid, (const double *)lb->step_boxes, c, uv, lb->radius, 1, segment,
                                     NULL);
}

/* The level functions the crossing search follows along an edge: t = s / w
 * of a groove (its break lines), |t| (its rim), the signed distance to a
 * step curve (its wall or crease), the difference of two grooves' carves
 * (where one takes over from the other, docs/spec.md §3's CSG: the deeper wins);
 * and for the labels' own boundaries, the distance to a step curve (the
 * edge of its radius) and the difference of the distances to two (where
 * the nearest changes). */
typedef enum { LEVEL_LINE, LEVEL_RIM, LEVEL_STEP, LEVEL_PAIR, LEVEL_REACH, LEVEL_NEAREST } level_kind;

/* Groove c's carve (or raise) g = depth P(t) at uv, 0 outside it; *s
 * gets its signed distance. */
static double groove_carve(const ch_label_ctx *lb, int c, const double uv[2], double *s) {
  const ch_curve *cv = &lb->set->curves[c];
  *s = ch_label_groove_distance_in(lb, c, uv, NULL, NULL, 1);
  double t = *s / cv->width;
  return fabs(t) < 0.5 ? cv->depth * ch_profile_eval(&cv->profile, t) : 0.0;
}

/* Where groove b takes over from groove a, by the labels' own rule (the
 * tie of ch_groove_field_eval: of two carves, or two raises, the curve
 * later in a cell's order, the higher index, takes over only where it is
 * deeper or higher by more than ch_groove_tie):
 * negative on a's side, positive on b's. Where one carves and the other
 * raises (or either is 0), their difference. */
static double pair_level(const ch_label_ctx *lb, int a, int b, const double uv[2]) {
  double sa, sb, ga = groove_carve(lb, a, uv, &sa), gb = groove_carve(lb, b, uv, &sb);
  if (!(ga * gb > 0.0)) return ga - gb;
  /* Equal to the bit: flat bottoms of one depth (box profiles) meet, where
   * the earlier curve stays: a plateau on its side, not a difference of
   * rounding that would pass for the root anywhere on it. */
  if (ga == gb) return a < b ? -fabs(ga) : fabs(ga);
  double sigma = ga < 0.0 ? -1.0 : 1.0; /* carves: the deeper (lower) wins */
  const ch_curve *curves = lb->set->curves;
  if (a < b) return sigma * (gb - ga) - ch_groove_tie(&curves[b], gb, sb, &curves[a], sa, uv);
  return -(sigma * (ga - gb) - ch_groove_tie(&curves[a], ga, sa, &curves[b], sb, uv));
}

/* The level function at point x of edge e, against curve c (LEVEL_PAIR
 * and LEVEL_NEAREST: c = a * MAX_CURVES_LABELLED + b for curves a and b,
 * in 64 bits: any number of curves),
 * or only its segment seg when seg >= 0 (both bracket ends nearest it);
 * *segment and *param get the closest point's segment and parameter when
 * asked (one curve's levels only). */
static double level_value(const ch_label_ctx *lb, const span *e, level_kind kind, int64_t c, int seg, double x,
                          int *segment, double *param) {
  double uv[2];
  span_point(e, x, uv);
  if (kind == LEVEL_PAIR) return pair_level(lb, (int)(c / MAX_CURVES_LABELLED), (int)(c % MAX_CURVES_LABELLED), uv);
  if (kind == LEVEL_NEAREST)
    return fabs(step_distance_at(lb, (int)(c / MAX_CURVES_LABELLED), uv, NULL)) -
           fabs(step_distance_at(lb, (int)(c % MAX_CURVES_LABELLED), uv, NULL));
  double v;
  if (seg >= 0) {
    const ch_segment *sg = &lb->set->segments[seg];
    double t, d2 = ch_bezier_closest(sg->p, sg->is_line, uv, &t);
    v = sqrt(d2) * ch_curve_side(lb->set, seg, t, uv);
    if (segment) *segment = seg;
    if (param) *param = t;
  } else {
    v = kind == LEVEL_STEP || kind == LEVEL_REACH ? step_distance_at(lb, c, uv, segment)
                                                  : ch_label_groove_distance_in(lb, c, uv, segment, param, 1);
  }
  if (kind == LEVEL_STEP) return v;
  if (kind == LEVEL_REACH) return fabs(v);
  v /= lb->set->curves[c].width;
  return kind == LEVEL_RIM ? fabs(v) : v;
}

/* How closely a crossing is found, as a fraction of its edge: at 2M
 * triangles 1e-15 in UV, ten times the rounding of a UV near 1 and far
 * below what an output keeps (the OBJ's 9 digits). The search once went
 * to 1e-14, under the noise of the distances themselves (t = s / w is
 * read to about 1e-14): its last steps chased that noise (13.2 closest-
 * point queries a line on glyphs at 2.1M; 8.9 at 1e-12, 7.8 with
 * level_guess). */
#define CROSSING_TOL 1e-12

enum { LEVEL_HISTORY = 6 };

/* The last groove level read at the far end of a crossing search: the
 * search after a line starts again towards the same sample (x1), so its
 * value is read once per sample, not once per line. c < 0: empty. */
typedef struct level_cache {
  double x, t;
  int c, segment;
  /* Every t of groove hc read on the edge so far (the last LEVEL_HISTORY):
   * all the lines of a groove are level sets of the one smooth t, so what
   * was read finding one line places the next (see level_guess). */
  int hc, hn, hnext;
  double hx[LEVEL_HISTORY], ht[LEVEL_HISTORY];
  /* Where the last line of groove rc was found: t read at rx, the root
   * (within CROSSING_TOL / 4 of it by the slope rs). rc < 0: none. */
  int rc;
  double rx, rt, rs;
  /* The closest point of the last t read of groove hc: its segment (< 0:
   * none) and parameter, where offset_crossing starts. */
  int ns;
  double np;
} level_cache;

/* An empty cache. */
#define LEVEL_CACHE_EMPTY \
  { .c = -1, .segment = -1, .hc = -1, .rc = -1, .ns = -1 }

/* Remembers t(x) of groove c. */
static void history_add(level_cache *h, int c, double x, double t) {
  if (h->hc != c) {
    h->hc = c;
    h->hn = h->hnext = 0;
  }
  h->hx[h->hnext] = x;
  h->ht[h->hnext] = t;
  h->hnext = (h->hnext + 1) % LEVEL_HISTORY;
  if (h->hn < LEVEL_HISTORY) h->hn++;
}

/* Where t(x) = target by inverse interpolation (quadratic through the
 * three points read nearest the target in t, or the secant through two)
 * of groove c's history; 0 if there is too little of it or the guess
 * falls outside (lo, hi). *slope gets dt/dx there. Inverse quadratic
 * interpolation as in Brent's method (Brent 1973, ch. 4): consecutive
 * lines are close, so a line's search most often ends in two or three
 * reads (traced on glyphs: the first guess within about 5e-4 of the
 * edge, the next within about 2e-7). */
static int level_guess(const level_cache *h, int c, double target, double lo, double hi, double *x, double *slope) {
  if (h->hc != c || h->hn < 2) return 0;
  /* the reads by distance from the target in t (ties: the earlier slot),
   * then the first three of them apart from each other in x and t */
  int order[LEVEL_HISTORY], pick[3], np = 0;
  double dist[LEVEL_HISTORY];
  for (int i = 0; i < h->hn; i++) {
    double d = fabs(h->ht[i] - target);
    int j = i;
    for (; j > 0 && d < dist[j - 1]; j--) {
      dist[j] = dist[j - 1];
      order[j] = order[j - 1];
    }
    dist[j] = d;
    order[j] = i;
  }
  for (int o = 0; o < h->hn && np < 3; o++) {
    int i = order[o], apart = 1;
    for (int j = 0; j < np; j++) apart &= fabs(h->hx[i] - h->hx[pick[j]]) > 1e-12 && h->ht[i] != h->ht[pick[j]];
    if (apart) pick[np++] = i;
  }
  if (np < 2) return 0;
  double x0 = h->hx[pick[0]], t0 = h->ht[pick[0]], x1 = h->hx[pick[1]], t1 = h->ht[pick[1]];
  double s01 = (x1 - x0) / (t1 - t0), g;
  if (np == 3) {
    double x2 = h->hx[pick[2]], t2 = h->ht[pick[2]];
    double s12 = (x2 - x1) / (t2 - t1), s012 = (s12 - s01) / (t2 - t0);
    g = x0 + (target - t0) * (s01 + (target - t1) * s012); /* Newton's form of x(t) */
    *slope = 1.0 / (s01 + (2.0 * target - t0 - t1) * s012);
  } else {
    g = x0 + (target - t0) * s01;
    *slope = 1.0 / s01;
  }
  if (!(g > lo && g < hi) || !isfinite(*slope) || *slope == 0.0) return 0;
  *x = g;
  return 1;
}

/* t = s / w of groove c at x along e (level_value's LEVEL_LINE), through
 * cache where it holds that point. */
static double groove_level(const ch_label_ctx *lb, const span *e, int c, double x, int *segment, level_cache *cache) {
  if (cache->c == c && cache->x == x) {
    *segment = cache->segment;
    return cache->t;
  }
  double t = level_value(lb, e, LEVEL_LINE, c, -1, x, segment, &cache->np);
  history_add(cache, c, x, t);
  cache->ns = *segment;
  cache->x = x;
  cache->t = t;
  cache->c = c;
  cache->segment = *segment;
  return t;
}

/* t of groove c at x0, where a search starts: the cache's where it holds
 * that point (a search from a sample starts where the one before ended,
 * at the sample it read), else read (and not cached: the cache keeps the
 * far end, which the next search reads again). */
static double start_level(const ch_label_ctx *lb, const span *e, int c, double x0, int *segment, level_cache *cache) {
  if (cache->c == c && cache->x == x0) {
    *segment = cache->segment;
    return cache->t;
  }
  /* A search from the line just found (x0 is its bracket's far end): t
   * there is the root's moved along the slope, where t is smooth: the
   * root's closest point inside its segment (at a segment's end the
   * nearest segment changes, and beyond an open end t changes sign across
   * the path's continuation, which a line may meet within CROSSING_TOL).
   * The move (half CROSSING_TOL times the slope) is twice what the root
   * may miss the line by: t stands on the line's far side, as a read
   * would show, where the edge turns back across the same line. */
  if (cache->rc == c && fabs(cache->rx - x0) <= CROSSING_TOL && cache->ns >= 0 && cache->np > 1e-9 &&
      cache->np < 1.0 - 1e-9) {
    *segment = cache->ns;
    return cache->rt + cache->rs * (x0 - cache->rx);
  }
  double t = level_value(lb, e, LEVEL_LINE, c, -1, x0, segment, &cache->np);
  cache->ns = *segment;
  return t;
}

/* Where edge e crosses the offset of segment sg at signed distance d (the
 * line t = d / w of its groove, where the closest point of the groove's
 * path lies inside sg): Newton's method in the pair (x, tau) for
 * e(x) = B(tau) + d N(tau), N the unit left normal (the signed distance
 * is positive on the left, ch_curve_side), from *x and *tau. Each step
 * costs a few products where a level read is a closest-point query, and
 * from the last read's parameter the steps halve the digits to go (two
 * or three to the rounding). Returns 1 with the point and dt/dx there
 * (t's slope along e: the distance's gradient is N) where it converges
 * with tau in [0, 1]; 0 otherwise (a cap's circle, another segment: the
 * search goes on without it). Unchecked: the read at x tells. */
static int offset_crossing(const ch_segment *sg, const span *e, double d, double width, double *x, double *tau,
                           double *slope) {
  const double(*p)[2] = sg->p;
  /* B(tau) = p0 + 2 tau A + tau^2 Q */
  double A[2], Q[2];
  if (sg->is_line) {
    A[0] = 0.5 * (p[2][0] - p[0][0]), A[1] = 0.5 * (p[2][1] - p[0][1]);
    Q[0] = Q[1] = 0.0;
  } else {
    A[0] = p[1][0] - p[0][0], A[1] = p[1][1] - p[0][1];
    Q[0] = p[2][0] - 2.0 * p[1][0] + p[0][0], Q[1] = p[2][1] - 2.0 * p[1][1] + p[0][1];
  }
  double D[2] = {e->b[0] - e->a[0], e->b[1] - e->a[1]}, dlen = ch_dist2d(D[0], D[1]), xx = *x, t = *tau;
  for (int it = 0; it < 8; it++) {
    double d1[2] = {2.0 * (A[0] + t * Q[0]), 2.0 * (A[1] + t * Q[1])}, len = ch_dist2d(d1[0], d1[1]);
    if (!(len > 0.0)) return 0;
    double T[2] = {d1[0] / len, d1[1] / len}, N[2] = {-T[1], T[0]};
    /* dT/dtau = (B'' - T (T . B'')) / |B'|, B'' = 2Q; dN/dtau is its left turn */
    double tq = 2.0 * ch_dot2(T, Q), dT[2] = {(2.0 * Q[0] - T[0] * tq) / len, (2.0 * Q[1] - T[1] * tq) / len};
    double J[2] = {-d1[0] + d * dT[1], -d1[1] - d * dT[0]}; /* dF/dtau = -B' - d dN/dtau */
    double F[2] = {e->a[0] + xx * D[0] - (p[0][0] + t * (2.0 * A[0] + t * Q[0])) - d * N[0],
                   e->a[1] + xx * D[1] - (p[0][1] + t * (2.0 * A[1] + t * Q[1])) - d * N[1]};
    double det = D[0] * J[1] - D[1] * J[0];
    if (!(fabs(det) > 0.0)) return 0;
    double dx = (F[1] * J[0] - F[0] * J[1]) / det, dt = (D[1] * F[0] - D[0] * F[1]) / det;
    xx += dx;
    t += dt;
    if (!(fabs(t - 0.5) < 4.0)) return 0; /* (running away) */
    /* (converged: a step below 1e-14 in UV, near the rounding of F's
     * terms; in x that is 1e-14 / |D|, 2.5e-12 on an edge of 0.004) */
    if (fabs(dx) * dlen <= 1e-14 && fabs(dt) * len <= 1e-14) {
      if (!(t >= 0.0 && t <= 1.0)) return 0;
      *x = xx;
      *tau = t;
      *slope = ch_dot2(N, D) / width;
      return 1;
    }
  }
  return 0;
}

/* Where span e crosses the continuation of segment sg beyond its open
 * start (at_start) or end P (set): the line through that end along its
 * tangent, across which the side of the points nearest the end flips
 * (ch_curve_side), so t jumps from |t| to -|t|; -1 where e runs parallel
 * to it. */
static double open_end_flip(const ch_segment *sg, int at_start, const span *e, double P[2]) {
  double T[2];
  ch_bezier_tangent(sg->p, at_start ? 0.0 : 1.0, T);
  ch_segment_point(sg, at_start ? 0.0 : 1.0, P);
  double D[2] = {e->b[0] - e->a[0], e->b[1] - e->a[1]}, w[2] = {P[0] - e->a[0], P[1] - e->a[1]};
  double den = ch_cross2(T, D);
  return fabs(den) > 0.0 ? ch_cross2(T, w) / den : -1.0;
}

/* A level set of a level function f - target along edge e, bracketed by
 * [*a, *b] with f(a) = *fa and f(b) = *fb of opposite signs, by false
 * position (Illinois) until the bracket is below tol, or until the last
 * estimate m is within tol / 4 of the root by the secant's slope: then
 * [*a, *b] = m -+ tol / 2 (unchecked: callers check the answer by the
 * labels). Where f jumps across the level rather than crossing it (t at
 * the side change beyond an open end, a groove's edge where two flat
 * bottoms meet) false position crawls: after two steps whose |f| did not
 * halve, a bisection (a safeguard in the manner of Dekker's and Brent's,
 * Brent 1973, ch. 4; the secant from a bisection's point is no slope to
 * stop on). One segment of c (seg >= 0: both ends are nearest it) is
 * enough for the search. On return [*a, *b] brackets the root (in either
 * order) and *fa is f(*a)'s sign. history: what was read, for
 * level_guess (a groove's t: all its reads on the edge; other levels:
 * this search's). A groove's line starts from offset_crossing, and a
 * read nearest an open end looks at once at the line where t jumps (see
 * open_end_flip). */
static void level_root(const ch_label_ctx *lb, const span *e, level_kind kind, int64_t c, int seg, double target,
                       double tol, double *a, double *b, double *fa, double *fb, level_cache *history) {
  int side = 0, flip_tried = 0;
  double last[3] = {INFINITY, INFINITY, INFINITY}; /* |f| read one, two and three steps before */
  for (int it = 0; it < 100 && fabs(*b - *a) > tol; it++) {
    double m = (*a * *fb - *b * *fa) / (*fb - *fa), model_slope = 0.0;
    int bisect = it >= 3 && last[0] > 0.5 * last[1] && last[1] > 0.5 * last[2];
    /* (a few guesses only: where t jumps, at the side change beyond an
     * open end, the history has nothing to say and bisection decides) */
    int guessed =
        !bisect && it < 4 && level_guess(history, (int)c, target, fmin(*a, *b), fmax(*a, *b), &m, &model_slope);
    if (bisect || !(m > fmin(*a, *b) && m < fmax(*a, *b))) m = 0.5 * (*a + *b);
    /* A groove's line: first from the offset of the segment last read
     * (most often the root itself, to the rounding, in one read). */
    if (kind == LEVEL_LINE && it == 0 && history->ns >= 0 && lb->set->segments[history->ns].curve == c) {
      double xn = m, tn = history->np, sl;
      const ch_curve *cv = &lb->set->curves[c];
      if (offset_crossing(&lb->set->segments[history->ns], e, target * cv->width, cv->width, &xn, &tn, &sl) &&
          xn > fmin(*a, *b) && xn < fmax(*a, *b)) {
        m = xn;
        model_slope = sl;
        guessed = 1;
      }
    }
    int read_seg = -1;
    double fm = level_value(lb, e, kind, c, seg, m, &read_seg, kind == LEVEL_LINE ? &history->np : NULL) - target;
    if (kind == LEVEL_LINE) history->ns = read_seg;
    history_add(history, (int)c, m, fm + target);
    /* On the level itself a line's label is still the lower piece's:
     * keep bracketing. */
    if (fm == 0.0) fm = -1e-300;
    last[2] = last[1];
    last[1] = last[0];
    last[0] = fabs(fm);
    /* the secant's slope, or the model's where that is flatter: the
     * stop asks the smaller step of the two to be below tol / 4 */
    double slope = (fm - *fb) / (m - *b);
    if (guessed && fabs(model_slope) < fabs(slope)) slope = model_slope;
    if (!bisect && fabs(fm) <= 0.25 * tol * fabs(slope)) {
      history->rc = (int)c;
      history->rx = m;
      history->rt = fm + target;
      history->rs = slope;
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
    /* A line read nearest an open end: where the bracket holds the line
     * across which t flips, the two sides of it tell at once whether the
     * level is that jump (bisection took 40-50 reads to close in on it:
     * half of a run's line reads on glyphs, whose strokes end on the
     * lines of the base's grid) or on which side the search goes on. */
    if (kind == LEVEL_LINE && !flip_tried && read_seg >= 0) {
      const ch_segment *sg = &lb->set->segments[read_seg];
      int at_start = history->np <= 0.0 && sg->prev < 0, at_end = history->np >= 1.0 && sg->next < 0;
      double P[2], u = fmin(*a, *b), v = fmax(*a, *b);
      double xs = at_start || at_end ? open_end_flip(sg, at_start, e, P) : -1.0;
      if (xs > u && xs < v) {
        flip_tried = 1;
        double fu = u == *a ? *fa : *fb, fv = v == *a ? *fa : *fb; /* (their signs: the bracket's ends) */
        /* (tol either side: the bisection after it puts the crossing
         * tol / 2 off the line, as bisection alone did; a crossing on the
         * line itself, where the side is a matter of rounding, cost the
         * refinement 0.7-0.8% more boundary points on glyphs and panels) */
        double xl = fmax(u, xs - tol), xr = fmin(v, xs + tol);
        double fl = xl == u ? fu : level_value(lb, e, kind, c, seg, xl, NULL, NULL) - target;
        double fr = xr == v ? fv : level_value(lb, e, kind, c, seg, xr, NULL, NULL) - target;
        if (fl == 0.0) fl = -1e-300;
        if (fr == 0.0) fr = -1e-300;
        /* Before the jump t is |t| or -|t| of the distance to the end, a
         * convex function along e: the level may be crossed twice there
         * (an edge grazing the cap), both crossings hidden from the
         * bracket's signs; the distance's least point tells. */
        if ((fu > 0.0) == (fl > 0.0)) {
          double w[2] = {P[0] - e->a[0], P[1] - e->a[1]}, D[2] = {e->b[0] - e->a[0], e->b[1] - e->a[1]};
          double xp = ch_dot2(w, D) / ch_dot2(D, D);
          if (xp > u && xp < xl) {
            double fp = level_value(lb, e, kind, c, seg, xp, NULL, NULL) - target;
            if (fp == 0.0) fp = -1e-300;
            if ((fp > 0.0) != (fu > 0.0)) {
              *a = u, *fa = fu, *b = xp, *fb = fp;
              side = 0;
              last[0] = last[1] = last[2] = INFINITY;
              continue;
            }
          }
        }
        if ((fl > 0.0) != (fr > 0.0)) { /* the jump is the level's crossing */
          *a = xl;
          *fa = fl;
          *b = xr;
          *fb = fr;
          return;
        }
        if ((fu > 0.0) != (fl > 0.0)) {
          *a = u, *fa = fu, *b = xl, *fb = fl;
        } else {
          *a = xr, *fa = fr, *b = v, *fb = fv;
        }
        side = 0;
        last[0] = last[1] = last[2] = INFINITY;
      }
    }
  }
}

/* The distance from q to the triangle a b c (0 inside it): a lower bound
 * on the distance to a quadratic segment with those control points, which
 * their triangle holds. */
static double triangle_distance(const double a[2], const double b[2], const double c[2], const double q[2]) {
  const double *p[3] = {a, b, c};
  double area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]), best = INFINITY;
  int inside = 1;
  for (int k = 0; k < 3; k++) {
    const double *u = p[k], *v = p[(k + 1) % 3];
    double e[2] = {v[0] - u[0], v[1] - u[1]}, w[2] = {q[0] - u[0], q[1] - u[1]}, ee = ch_dot2(e, e);
    double side = e[0] * w[1] - e[1] * w[0];
    inside &= area >= 0.0 ? side >= 0.0 : side <= 0.0;
    double t = ee > 0.0 ? ch_dot2(w, e) / ee : 0.0;
    t = t < 0.0 ? 0.0 : t > 1.0 ? 1.0 : t;
    best = fmin(best, ch_dist2d(w[0] - t * e[0], w[1] - t * e[1]));
  }
  return inside && area != 0.0 ? 0.0 : best;
}

/* Whether the label at uv is groove c's alone to decide: every other
 * groove's segment whose box (grown by half its width) holds uv, as
 * ch_label_at reads them (ch_groove_field_eval), is farther than that
 * half width from it (its control triangle is), so carves nothing there;
 * and neither step curves nor a warp's line sets enter it. (The boxes
 * alone: a rosette's circles hold each other's grooves in their quarter
 * segments' boxes, and most of ornament's lines were read.) */
static int groove_alone_at(const ch_label_ctx *lb, int c, const double uv[2]) {
  if (lb->has_steps || lb->level_t) return 0;
  const ch_groove_field *f = &lb->height->grooves;
  const int *items;
  int n = ch_grid_query(&f->grid, uv[0], uv[1], &items);
  for (int k = 0; k < n; k++) {
    const double *b = f->boxes[items[k]];
    if (uv[0] < b[0] || uv[0] > b[2] || uv[1] < b[1] || uv[1] > b[3]) continue;
    const ch_segment *sg = &lb->set->segments[items[k]];
    if (sg->curve == c) continue;
    /* (a margin of 1e-9 of the width for the rounding of either distance) */
    if (!(triangle_distance(sg->p[0], sg->p[1], sg->p[2], uv) > 0.5 * lb->set->curves[sg->curve].width * (1.0 + 1e-9)))
      return 0;
  }
  return 1;
}

/* No label is all ones (a label's groove part uses its low 30 bits). */
#define NO_LABEL UINT64_MAX

/* Finds the level of f = target between x0 < x1 (label l0 at x0, f -
 * target = f0 there and f1 of the other sign at x1) and narrows the
 * bisection's bracket [*lo, *hi] to it if the labels agree: l0 on x0's
 * side of it, another label on the other; returns whether they did. The
 * labels decide by their own evaluation, which can put the change a few
 * roundings away (on a step curve itself the side is rounding): the
 * bracket widens until they confirm it. expect (or NO_LABEL): the label
 * the level leads to where nothing else changes there. */
static int narrow_to_level(const ch_label_ctx *lb, const span *e, uint64_t l0, uint64_t expect, level_kind kind,
                           int64_t c, int seg, double target, double x0, double f0, double x1, double f1, double *lo,
                           double *hi, uint64_t *lhi, level_cache *history) {
  double a = x0, b = x1, fa = f0, fb = f1;
  /* Level functions other than a groove's lines keep what this search
   * reads: from the third read on, inverse quadratic interpolation
   * through the last ones (level_guess) rather than false position alone
   * (where two grooves cross on ornament: 8.6 -> 7.0 reads a root, each
   * of two carves). */
  level_cache local;
  if (!history) {
    local = (level_cache)LEVEL_CACHE_EMPTY;
    history = &local;
    history_add(history, (int)c, x0, f0 + target);
    history_add(history, (int)c, x1, f1 + target);
  }
  level_root(lb, e, kind, c, seg, target, CROSSING_TOL, &a, &b, &fa, &fb, history);
  double near = (fa * f0 > 0.0) ? a : b, far = near == a ? b : a;
  if (!(near < far)) return 0;
  /* A u groove's line where that groove alone decides the labels past
   * it: its piece steps there (the root stands within a quarter of the
   * bracket of the level, by the slope, and inside the groove the carve
   * is never 0), so the label past it is the one expected without a
   * read (a third of a run's labels on ornament). The root must be this
   * search's: inside (x0, x1) and t passing the level the way it goes
   * from x0 to x1 (from a line just crossed, Newton's method finds that
   * line again, where t passes it the other way: the label read there
   * showed l0 still); and its closest point inside its segment, away from
   * an open end's cap, where t's jump can fall within the bracket of a
   * line (glyphs: 1 edge in 250k, whose label past both was another). */
  if (kind == LEVEL_LINE && expect != NO_LABEL && history->rc == (int)c &&
      fabs(history->rx - 0.5 * (near + far)) <= 0.5 * CROSSING_TOL && near > x0 && far < x1 &&
      (history->rs > 0.0) == (f1 > f0) && history->np > 1e-9 && history->np < 1.0 - 1e-9 && fabs(target) < 0.5 &&
      lb->set->curves[c].profile.kind == CH_PROFILE_U) {
    double uv[2];
    span_point(e, far, uv);
    if (groove_alone_at(lb, (int)c, uv)) {
      *lo = near;
      *hi = far;
      *lhi = expect;
      return 1;
    }
  }
  static const double widen[] = {0.0, 1e-13, 1e-11, 1e-9};
  for (int k = 0; k < 4; k++) {
    double l = fmax(x0, near - widen[k]), h = fmin(x1, far + widen[k]);
    uint64_t next = span_label(lb, e, h);
    /* Past the level the label it leads to (expect) confirms the near
     * side as well: anything else that changed before the level would
     * still show 1e-12 further on. */
    if (next == l0) continue;
    if (next != expect) {
      uint64_t ll = span_label(lb, e, l);
      /* another line of l0's groove before the level: a change of its
       * own, not a rounding a wider bracket would take in */
      if (ll != l0 && kind != LEVEL_LINE && (ll & 0xffffffffu) == (l0 & 0xffffffffu) && (ll >> 32) && (l0 >> 32) &&
          GROOVE_CURVE(ll >> 32) == GROOVE_CURVE(l0 >> 32))
        return 0;
      if (ll != l0) continue;
    }
    *lo = l;
    *hi = h;
    *lhi = next;
    return 1;
  }
  return 0;
}

/* From piece k0 of groove line set g0 (l0's) to piece k1 of the same set
 * (k1 < 0: the next one the way t goes from x0 to x1) across its line:
 * -1 where there is no such line (k1 beyond the set: a rim), else whether
 * narrow_to_level confirmed it. */
static int narrow_to_line(const ch_label_ctx *lb, const span *e, uint64_t l0, int k1, double x0, double x1,
                          double *lo, double *hi, uint64_t *lhi, level_cache *cache) {
  uint64_t g0 = l0 >> 32;
  int c = GROOVE_CURVE(g0), k0 = (int)(g0 & 0xff), nb, sa = -1, sb = -1;
  const double *br = ch_label_lines_of(lb, c, GROOVE_LEVEL(g0), &nb);
  double ta = start_level(lb, e, c, x0, &sa, cache);
  history_add(cache, c, x0, ta);
  double tb = groove_level(lb, e, c, x1, &sb, cache);
  if (k1 < 0) k1 = k0 + (tb > ta ? 1 : -1);
  if (!(k1 != k0 && k1 >= 1 && k1 <= nb - 1)) return -1;
  double target = (k1 > k0 ? br[k0] : br[k0 - 1]) + 1e-13; /* where the label's piece index steps */
  if (!(ta - target != 0.0 && (ta - target) * (tb - target) < 0.0)) return 0;
  /* past the line, the next piece (k1 may lie beyond it: where t jumps
   * to k1, beyond an open end, the lines before the jump are changes of
   * their own) */
  int next = k1 > k0 ? k0 + 1 : k0 - 1;
  uint64_t expect = ((g0 & ~(uint64_t)0xff) | (uint64_t)next) << 32 | (l0 & 0xffffffffu);
  return narrow_to_level(lb, e, l0, expect, LEVEL_LINE, c, sa == sb ? sa : -1, target, x0, ta - target, x1, tb - target,
                         lo, hi, lhi, cache);
}

/* The fast paths of the crossing search: where two labels differ by one
 * level function, its level set is found by false position in a dozen
 * closest-point queries (for a groove's lines, most often two from where
 * the lines before it were found) and confirmed by the labels at both
 * ends of the bracket, which bisection then closes (a bracket of
 * CROSSING_TOL already: no step; one the labels cannot confirm: bisection from the samples, 46
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
static void narrow_crossing(const ch_label_ctx *lb, const span *e, uint64_t l0, uint64_t l1, double x0, double x1,
                            double *lo, double *hi, uint64_t *lhi, level_cache *cache) {
  uint64_t g0 = l0 >> 32, g1 = l1 >> 32, s0 = l0 & 0xffffffffu, s1 = l1 & 0xffffffffu;
  int sa = -1, sb = -1;
  if (s0 == s1 && g0 && (!g1 || (g0 >> 8) == (g1 >> 8))) /* lines of one groove */
    if (narrow_to_line(lb, e, l0, g1 ? (int)(g1 & 0xff) : -1, x0, x1, lo, hi, lhi, cache) >= 0) return;
  if (s0 == s1 && (!g0 != !g1)) { /* a rim (the outermost piece of the groove on one side) */
    int c = GROOVE_CURVE(g0 ? g0 : g1);
    double ta = start_level(lb, e, c, x0, &sa, cache), tb = groove_level(lb, e, c, x1, &sb, cache);
    double fa = fabs(ta) - 0.5, fb = fabs(tb) - 0.5; /* LEVEL_RIM */
    if (fa != 0.0 && fa * fb < 0.0)
      narrow_to_level(lb, e, l0, NO_LABEL, LEVEL_RIM, c, sa == sb ? sa : -1, 0.5, x0, fa, x1, fb, lo, hi, lhi, NULL);
    else if (ta != 0.0 && ta * tb < 0.0) /* a profile zero on one side of its curve (bevel): a wall at t = 0 */
      narrow_to_level(lb, e, l0, NO_LABEL, LEVEL_LINE, c, sa == sb ? sa : -1, 0.0, x0, ta, x1, tb, lo, hi, lhi, NULL);
  } else if (s0 == s1 && g0 && g1 && GROOVE_CURVE(g0) != GROOVE_CURVE(g1)) {
    /* two grooves: where the deeper carve (or the higher raise) changes */
    int64_t c = (int64_t)GROOVE_CURVE(g0) * MAX_CURVES_LABELLED + GROOVE_CURVE(g1);
    double fa = level_value(lb, e, LEVEL_PAIR, c, -1, x0, NULL, NULL);
    double fb = level_value(lb, e, LEVEL_PAIR, c, -1, x1, NULL, NULL);
    /* Where the first groove's lines come first (a u groove running
     * into another: its lines until the other is deeper), its next line;
     * the labels tell (one level root and two labels, not bisection). */
    if (!(fa != 0.0 && fa * fb < 0.0 &&
          narrow_to_level(lb, e, l0, NO_LABEL, LEVEL_PAIR, c, -1, 0.0, x0, fa, x1, fb, lo, hi, lhi, NULL)))
      narrow_to_line(lb, e, l0, -1, x0, x1, lo, hi, lhi, cache);
  } else if (g0 == g1 && s0 && s1 && (s0 >> 1) == (s1 >> 1) && lb->height->step_method == CH_RECON_EXACT) {
    int c = (int)(s0 >> 1) - 1; /* one step curve's two sides */
    double fa = level_value(lb, e, LEVEL_STEP, c, -1, x0, &sa, NULL);
    double fb = level_value(lb, e, LEVEL_STEP, c, -1, x1, &sb, NULL);
    if (fa != 0.0 && fa * fb < 0.0)
      narrow_to_level(lb, e, l0, NO_LABEL, LEVEL_STEP, c, sa == sb ? sa : -1, 0.0, x0, fa, x1, fb, lo, hi, lhi, NULL);
  } else if (g0 == g1 && !s0 != !s1) { /* a loop's wall from outside, or the edge of a step curve's radius */
    int c = (int)((s0 ? s0 : s1) >> 1) - 1;
    if (lb->step_outer && lb->height->step_method == CH_RECON_EXACT) {
      double fa = level_value(lb, e, LEVEL_STEP, c, -1, x0, &sa, NULL);
      double fb = level_value(lb, e, LEVEL_STEP, c, -1, x1, &sb, NULL);
      if (fa != 0.0 && fa * fb < 0.0 &&
          narrow_to_level(lb, e, l0, NO_LABEL, LEVEL_STEP, c, sa == sb ? sa : -1, 0.0, x0, fa, x1, fb, lo, hi, lhi,
                          NULL))
        return;
    }
    double fa = level_value(lb, e, LEVEL_REACH, c, -1, x0, &sa, NULL) - lb->radius;
    double fb = level_value(lb, e, LEVEL_REACH, c, -1, x1, &sb, NULL) - lb->radius;
    if (fa != 0.0 && fa * fb < 0.0)
      narrow_to_level(lb, e, l0, NO_LABEL, LEVEL_REACH, c, sa == sb ? sa : -1, lb->radius, x0, fa, x1, fb, lo, hi, lhi,
                      NULL);
  } else if (g0 == g1 && s0 && s1 && (s0 >> 1) != (s1 >> 1)) {
    /* where the nearest step curve changes */
    int64_t c = (int64_t)((s0 >> 1) - 1) * MAX_CURVES_LABELLED + (int64_t)((s1 >> 1) - 1);
    double fa = level_value(lb, e, LEVEL_NEAREST, c, -1, x0, NULL, NULL);
    double fb = level_value(lb, e, LEVEL_NEAREST, c, -1, x1, NULL, NULL);
    if (fa != 0.0 && fa * fb < 0.0)
      narrow_to_level(lb, e, l0, NO_LABEL, LEVEL_NEAREST, c, -1, 0.0, x0, fa, x1, fb, lo, hi, lhi, NULL);
  }
}

/* Records the change from piece la (at lo) to piece lb_ (at hi) along e,
 * at the middle of [lo, hi], with h read just inside each piece. */
static void record_crossing(const ch_label_ctx *lb, const span *e, double lo, double hi, uint64_t la, uint64_t lb_,
                            const level_cache *cache, ch_refine_crossing *c) {
  double uv[2], at[2];
  c->x = 0.5 * (lo + hi);
  c->la = la;
  c->lb = lb_;
  span_point(e, c->x, at);
  /* Across a u groove's line both pieces read its profile at `at` (and
   * nothing else without step curves): the same height, read once; and
   * where the line was just found by its level root, t there is the root's
   * (within CROSSING_TOL of `at`: t differs by the slope times that,
   * far below h's rounding), so h needs no closest-point query of its own
   * (one per u line, a sixth of the search's queries on ornament). */
  uint64_t ga = la >> 32, gb = lb_ >> 32;
  if (ga && gb && GROOVE_CURVE(ga) == GROOVE_CURVE(gb) && !lb->height->has_steps &&
      lb->set->curves[GROOVE_CURVE(ga)].profile.kind == CH_PROFILE_U) {
    const ch_curve *cv = &lb->set->curves[GROOVE_CURVE(ga)];
    if (cache->rc == GROOVE_CURVE(ga) && fabs(cache->rx - c->x) <= CROSSING_TOL) {
      c->ha = cv->depth * ch_profile_eval(&cv->profile, fmax(-0.5, fmin(0.5, cache->rt)));
    } else {
      span_point(e, lo, uv);
      c->ha = ch_label_piece_height(lb, la, uv, at);
    }
    c->hb = c->ha;
  } else {
    span_point(e, lo, uv);
    c->ha = ch_label_piece_height(lb, la, uv, at);
    span_point(e, hi, uv);
    c->hb = ch_label_piece_height(lb, lb_, uv, at);
  }
  c->copy_a = c->copy_b = -1;
}

/* Bisection in [*lo, *hi] (label l0 at *lo, another, *lhi, at *hi) until
 * the bracket is below tol, for the change nearest *lo's side that the
 * labels show. */
static void bisect_change(const ch_label_ctx *lb, const span *s, uint64_t l0, int crowded, level_cache *cache,
                          double tol, double *lo, double *hi, uint64_t *lhi) {
  /* (a bracket a fast path left is m -+ tol / 2, whose width rounds to
   * a hair over tol about half the time, by up to 2.2e-16 for fractions
   * up to 1 (two half ulps): not a reason for another label) */
  double stop = tol + 0x1p-50;
  for (int it = 0; it < BISECTIONS && (*hi - *lo) > stop; it++) {
    double mid = 0.5 * (*lo + *hi);
    uint64_t lm = span_label(lb, s, mid);
    if (lm == l0) {
      *lo = mid;
    } else {
      *hi = mid;
      *lhi = lm;
    }
    /* Where grooves crowd (many crossing each other), many changes
     * between two samples defeat the fast path and every label is a
     * sum over all of them: once bisection has cut the bracket 64
     * times, it tries again between l0 and the label the bracket now
     * ends on, most often the only change left in it (a dozen
     * one-curve evaluations instead of 40 more labels). */
    if (crowded && it % 6 == 5 && (*hi - *lo) > stop)
      narrow_crossing(lb, s, l0, *lhi, *lo, *hi, lo, hi, lhi, cache);
  }
}

/* Whether grooves crowd at uv (see bisect_change). */
static int crowded_at(const ch_label_ctx *lb, const double a[2], const double b[2]) {
  return ch_groove_field_count(&lb->height->grooves, 0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])) > CROWDED_CELL;
}

void ch_refine_segment_change(const ch_label_ctx *lb, const double p[2], const double q[2], uint64_t lp, uint64_t lq,
                              double tol, double *lo, double *hi) {
  span s = {.a = {p[0], p[1]}, .b = {q[0], q[1]}, .la = lp, .lb = lq};
  level_cache cache = LEVEL_CACHE_EMPTY;
  uint64_t lhi = lq;
  *lo = 0.0;
  *hi = 1.0;
  narrow_crossing(lb, &s, lp, lq, 0.0, 1.0, lo, hi, &lhi, &cache);
  bisect_change(lb, &s, lp, crowded_at(lb, p, q), &cache, tol, lo, hi, &lhi);
}

/* How far from a vertex on a UV seam the edge's own chart is read (below
 * CROSSING_TOL). */
#define SEAM_X 0x1p-47

int ch_refine_on_seam(const ch_refine_mesh *w, int v, const double uv[2]) {
  return fabs(w->verts[v].uv[0] - uv[0]) > 1e-9 || fabs(w->verts[v].uv[1] - uv[1]) > 1e-9;
}

/* Gives e an array of exactly the count crossings of list: edges hold
 * their crossings until the cut, and a per-edge array grown by doubling
 * from a large first capacity took gigabytes. 0, or -1 out of memory. */
static int keep_crossings(const ch_refine_mesh *w, ch_refine_edge *e, const ch_refine_crossing *list, int count) {
  e->cross = NULL;
  e->ncross = 0;
  if (count > 0) {
    if (!(e->cross = pool_take(w, count))) return -1;
    memcpy(e->cross, list, (size_t)count * sizeof *e->cross);
    e->ncross = count;
  }
  return 0;
}

/* How many parts the search samples an edge of UV length len in: about
 * delta long, at least two (at least the midpoint: short edges cross
 * lines one after the other, which the ends' labels show; a midpoint
 * catches most slivers a triangle's corners miss, and the refinement's
 * hidden-piece check the rest; a third sample more made no difference on
 * the bundled sets). The halves that take their crossings check them at
 * the same samples. */
static int edge_samples(double len, double delta) {
  int n = (int)ceil(len / delta);
  return n < 2 ? 2 : n > MAX_EDGE_SAMPLES ? MAX_EDGE_SAMPLES : n;
}

/* Every boundary between pieces along e. Labels are sampled about delta
 * apart; from each sample whose label differs from the next, bisection
 * (in the bracket a fast path narrowed) finds a change to CROSSING_TOL of
 * the edge, and the search goes on from there, so lines closer together
 * than the samples (the break lines near a u groove's rim) are all found.
 * h is read on both sides. */
int ch_refine_crossings(const ch_label_ctx *lb, const ch_refine_mesh *w, ch_refine_edge *e, double delta) {
  /* (from the canonical triangle's corners: ch_refine_edge_point's points) */
  const ch_refine_tri *T = &w->tris[e->tri];
  int ka, kb;
  edge_corners(w, e, &ka, &kb);
  span s = {.a = {T->uv[ka][0], T->uv[ka][1]},
            .b = {T->uv[kb][0], T->uv[kb][1]},
            .la = w->verts[e->a].label,
            .lb = w->verts[e->b].label};
  double pa[2], pb[2];
  span_point(&s, 0.0, pa);
  span_point(&s, 1.0, pb);
  if (ch_label_quiet(lb, pa) && ch_label_quiet(lb, pb)) {
    e->ncross = 0;
    e->cross = NULL;
    return 0;
  }
  int n = edge_samples(ch_dist2d(pb[0] - pa[0], pb[1] - pa[1]), delta);
  /* Crossings gather in a buffer on the stack (most edges have a few; the
   * search stops at MAX_NODES), and the edge keeps exactly its count
   * (keep_crossings). */
  ch_refine_crossing list[MAX_NODES];
  int count = 0;
  double x0 = 0.0;
  uint64_t l0 = s.la;
  int crowded = crowded_at(lb, pa, pb);
  /* A vertex on a UV seam was labelled in another chart than this edge's:
   * where h differs across the seam the edge starts (or ends) with a
   * change at the vertex itself, a wall of no width, which no level
   * function brackets; bisection took 46 labels to close in on it. */
  int seam_a = ch_refine_on_seam(w, e->a, pa), seam_b = ch_refine_on_seam(w, e->b, pb);
  level_cache cache = LEVEL_CACHE_EMPTY;
  /* An edge with MAX_NODES crossings makes every triangle holding it one
   * that cannot be cut: the search stops there (what is found is kept). */
  for (int i = 1; i <= n && count < MAX_NODES; i++) {
    double x1 = (double)i / n;
    uint64_t l1 = span_label(lb, &s, x1);
    while (l0 != l1 && count < MAX_NODES) {
      double lo = x0, hi = x1;
      uint64_t lhi = l1;
      narrow_crossing(lb, &s, l0, l1, x0, x1, &lo, &hi, &lhi, &cache);
      if (lo == x0 && hi == x1 && hi - lo > CROSSING_TOL) { /* no fast path: a change at a seam vertex? */
        if (x0 == 0.0 && seam_a) {
          uint64_t chart = span_label(lb, &s, SEAM_X);
          if (chart != l0) { /* the first label on the edge's side differs: the change is at a */
            hi = SEAM_X;
            lhi = chart;
          }
        } else if (x1 == 1.0 && seam_b && span_label(lb, &s, 1.0 - SEAM_X) == l0) {
          lo = 1.0 - SEAM_X; /* the last label on the edge's side is l0's: the change is at b */
        }
      }
      bisect_change(lb, &s, l0, crowded, &cache, CROSSING_TOL, &lo, &hi, &lhi);
      record_crossing(lb, &s, lo, hi, l0, lhi, &cache, &list[count++]);
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
  return keep_crossings(w, e, list, count);
}

void ch_refine_label_vertices(const ch_label_ctx *lb, ch_refine_mesh *w, int from) {
#pragma omp parallel for schedule(dynamic, 256)
  for (int v = from; v < w->nverts; v++) {
    w->verts[v].label = ch_label_quiet(lb, w->verts[v].uv) ? 0 : ch_label_at(lb, w->verts[v].uv);
    w->verts[v].h = ch_height_eval(lb->height, w->verts[v].uv[0], w->verts[v].uv[1]);
  }
}

/* New vertex at the midpoint of edge i (in its canonical triangle's
 * chart), and the edge's two halves: half[0] from a to it, half[1] from b
 * (their canonical triangles are set when the triangles split). */
int ch_refine_add_midpoint(ch_refine_mesh *w, int i) {
  if (grow((void **)&w->verts, &w->cap_verts, w->nverts + 1, sizeof *w->verts) ||
      grow((void **)&w->edges, &w->cap_edges, w->nedges + 2, sizeof *w->edges))
    return -1;
  ch_refine_edge *e = &w->edges[i];
  ch_refine_vert *v = &w->verts[w->nverts];
  ch_refine_edge_point(w, e, 0.5, v->uv, v->st); /* (s,t) interpolated: ch_refine_locate_new */
  v->face = w->tris[e->tri].face;
  v->label = 0;
  e->mid = w->nverts++;
  for (int j = 0; j < 2; j++) {
    ch_refine_edge *h = &w->edges[w->nedges];
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

void ch_refine_locate_new(ch_refine_mesh *w, int from) {
#pragma omp parallel for schedule(dynamic, 256)
  for (int v = from; v < w->nverts; v++) ch_refine_locate_st(w->surface, w->verts[v].face, w->verts[v].uv, w->verts[v].st);
}

int ch_refine_inherit_crossings(const ch_label_ctx *lb, ch_refine_mesh *w, int i, double delta) {
  ch_refine_edge *e = &w->edges[i];
  int n = e->ncross, ok = e->mid >= 0 && n >= 0 && n < MAX_NODES;
  /* (a crossing at the midpoint itself: neither half's alone) */
  for (int c = 0; c < n && ok; c++) ok = !(fabs(e->cross[c].x - 0.5) < 1e-9);
  for (int j = 0; j < 2 && ok; j++) {
    ch_refine_edge *h = &w->edges[e->half[j]];
    if (h->ncross >= 0 || h->tri < 0) continue;
    const ch_refine_tri *T = &w->tris[h->tri];
    const double *mid = w->verts[e->mid].uv;
    int ka, kb;
    edge_corners(w, h, &ka, &kb);
    /* In the split edge's chart (the midpoint's UV was made in it), and
     * its end labelled in it too. */
    if (T->uv[kb][0] != mid[0] || T->uv[kb][1] != mid[1] || ch_refine_on_seam(w, h->a, T->uv[ka])) continue;
    ch_refine_crossing list[MAX_NODES];
    int count = 0, chain = 1;
    uint64_t at = w->verts[h->a].label;
    for (int c = 0; c < n; c++) {
      /* half 0 runs from a to the midpoint, half 1 from b: backwards */
      const ch_refine_crossing *x = &e->cross[j ? n - 1 - c : c];
      if (j ? !(x->x > 0.5) : !(x->x < 0.5)) continue;
      ch_refine_crossing *y = &list[count++];
      *y = *x;
      if (j) {
        y->x = 2.0 * (1.0 - x->x); /* (exact: 1 - x for x in [0.5, 1] is) */
        y->la = x->lb, y->lb = x->la;
        y->ha = x->hb, y->hb = x->ha;
      } else {
        y->x = 2.0 * x->x;
      }
      if (y->la != at) {
        chain = 0;
        break;
      }
      at = y->lb;
    }
    if (!chain || at != w->verts[e->mid].label) continue; /* the labels tell another story: searched afresh */
    /* The half's own samples, where the search would read them, must see
     * the pieces the list says: a piece between two of the split edge's
     * samples that its search missed may show at these, and only a search
     * finds it (each level of refinement samples anew). */
    span sp = {.a = {T->uv[ka][0], T->uv[ka][1]}, .b = {T->uv[kb][0], T->uv[kb][1]}};
    if (ch_label_quiet(lb, sp.a) && ch_label_quiet(lb, sp.b)) continue; /* (the search's at once) */
    int ns = edge_samples(ch_dist2d(sp.b[0] - sp.a[0], sp.b[1] - sp.a[1]), delta), next = 0;
    uint64_t piece = w->verts[h->a].label, before = piece;
    for (int k = 1; k <= ns && chain; k++) {
      double x = (double)k / ns;
      int first = next;
      while (next < count && list[next].x < x) piece = list[next++].lb;
      /* (a sample on a crossing, to its bracket: the search's call) */
      if ((next < count && list[next].x - x < 1e-9) || (next > 0 && x - list[next - 1].x < 1e-9)) {
        chain = 0;
      } else {
        uint64_t here = k == ns ? piece : span_label(lb, &sp, x); /* (the midpoint's: checked above) */
        /* and between two samples the search stops at the first change
         * into the far sample's piece (none where both read one piece): a
         * way out and back the split edge's search found between its
         * samples is not the half's (kept, the triangle is split for
         * ever, or cut against neighbours that do not have it) */
        chain = here == piece && !(here == before && next > first);
        for (int c = first; c + 1 < next && chain; c++) chain = list[c].lb != here;
        before = here;
      }
    }
    if (!chain) continue;
    if (keep_crossings(w, h, list, count)) return -1;
  }
  if (e->cross) { /* (as ch_refine_split left them before; the pool keeps the list) */
    e->cross = NULL;
    e->ncross = 0;
  }
  return 0;
}

/* A corner of a child triangle: a corner of its parent (tag 0-2) or the
 * midpoint of the parent's edge k (tag 3 + k). */
typedef struct corner_ref {
  int v, tag;
  double uv[2], st[2];
} corner_ref;

static void set_tri(ch_refine_tri *t, int face, const corner_ref *a, const corner_ref *b, const corner_ref *c) {
  const corner_ref *r[3] = {a, b, c};
  t->face = face;
  for (int i = 0; i < 3; i++) {
    t->v[i] = r[i]->v;
    memcpy(t->uv[i], r[i]->uv, sizeof t->uv[i]);
    memcpy(t->st[i], r[i]->st, sizeof t->st[i]);
  }
}

/* Which of triangle t's edges are split (bit k: edge k), from a flag per edge. */
static int split_mask(const ch_refine_mesh *w, const unsigned char *edge_split, int t) {
  int mask = 0;
  for (int k = 0; k < 3; k++)
    if (edge_split[w->tri_edge[3 * (size_t)t + k]]) mask |= 1 << k;
  return mask;
}

enum { SPLIT_CHUNK = 1 << 16 };

ch_status ch_refine_split(ch_refine_mesh *w, const int *split_edges, int nsplit, unsigned char **fresh, ch_error *err) {
  int n0 = w->ntris, e0 = w->nedges, nchunks = (n0 + SPLIT_CHUNK - 1) / SPLIT_CHUNK;
  /* The parents, in triangle order: a byte a split edge and a sweep of the
   * triangles' edge indices finds them (reading each triangle's edges
   * themselves, three scattered 40-byte records, took 25-33 ms a round at
   * 1M triangles, for a few thousand parents); the parents' numbering is
   * then what one serial pass over all triangles would give. */
  unsigned char *edge_split = calloc((size_t)(e0 > 0 ? e0 : 1), 1);
  int *chunk_first = calloc((size_t)nchunks + 1, sizeof *chunk_first), *parent = NULL, *first = NULL;
  const char *why = "out of memory refining the mesh";
  if (!edge_split || !chunk_first) goto fail;
  for (int i = 0; i < nsplit; i++) edge_split[split_edges[i]] = 1;
#pragma omp parallel for schedule(static)
  for (int c = 0; c < nchunks; c++) {
    int t1 = (c + 1) * SPLIT_CHUNK < n0 ? (c + 1) * SPLIT_CHUNK : n0, n = 0;
    for (int t = c * SPLIT_CHUNK; t < t1; t++) n += split_mask(w, edge_split, t) != 0;
    chunk_first[c + 1] = n;
  }
  for (int c = 0; c < nchunks; c++) chunk_first[c + 1] += chunk_first[c];
  int nparents = chunk_first[nchunks];
  parent = malloc((size_t)(nparents > 0 ? nparents : 1) * sizeof *parent);
  first = malloc(((size_t)nparents + 1) * sizeof *first); /* per parent: its first appended child and inner edge */
  if (!parent || !first) goto fail;
#pragma omp parallel for schedule(static)
  for (int c = 0; c < nchunks; c++) {
    int t1 = (c + 1) * SPLIT_CHUNK < n0 ? (c + 1) * SPLIT_CHUNK : n0, at = chunk_first[c];
    for (int t = c * SPLIT_CHUNK; t < t1; t++) {
      int mask = split_mask(w, edge_split, t);
      if (!mask) continue;
      parent[at] = t;
      first[at++] = (mask & 1) + ((mask >> 1) & 1) + ((mask >> 2) & 1);
    }
  }
  free(chunk_first);
  chunk_first = NULL;
  /* Children beyond the first (inner edges alike) per parent: their offsets. */
  long added = 0;
  for (int i = 0; i < nparents; i++) {
    int c = first[i];
    first[i] = (int)added;
    added += c;
  }
  if (n0 + added >= INT32_MAX / 3 || e0 + added >= INT32_MAX / 3) {
    why = "refinement would make too many triangles";
    goto fail;
  }
  int n = n0 + (int)added, cap_edge_index = w->cap_tri_edge;
  unsigned char *fr = realloc(*fresh, (size_t)(n > 0 ? n : 1));
  if (fr) *fresh = fr;
  if (!fr || grow((void **)&w->tris, &w->cap_tris, n, sizeof *w->tris) ||
      grow((void **)&w->edges, &w->cap_edges, e0 + (int)added, sizeof *w->edges) ||
      grow((void **)&w->tri_edge, &cap_edge_index, 3 * n, sizeof *w->tri_edge))
    goto fail;
  w->cap_tri_edge = cap_edge_index;
  memset(fr, 0, (size_t)n);
  /* (the children land past n0 in parent order, from whichever thread
   * takes the parent: two threads writing into one fresh huge page wait
   * for each other's fault) */
  ch_alloc_prefault(w->tris + n0, (size_t)added * sizeof *w->tris);
#pragma omp parallel for schedule(dynamic, 64)
  for (int pi = 0; pi < nparents; pi++) {
    int t = parent[pi], mask = split_mask(w, edge_split, t), child0 = first[pi];
    const ch_refine_tri T = w->tris[t];
    int pe[3]; /* the parent's edges */
    memcpy(pe, &w->tri_edge[3 * (size_t)t], sizeof pe);
    corner_ref c[3], m[3];
    for (int k = 0; k < 3; k++) {
      c[k].v = T.v[k];
      c[k].tag = k;
      memcpy(c[k].uv, T.uv[k], sizeof c[k].uv);
      memcpy(c[k].st, T.st[k], sizeof c[k].st);
      const ch_refine_edge *e = &w->edges[pe[k]];
      if (e->mid < 0) continue;
      m[k].v = e->mid;
      m[k].tag = 3 + k;
      ch_refine_lerp2(T.uv[k], T.uv[(k + 1) % 3], 0.5, m[k].uv);
      ch_refine_lerp2(T.st[k], T.st[(k + 1) % 3], 0.5, m[k].st);
    }
    int slot[4], f = T.face, cnt = (mask & 1) + ((mask >> 1) & 1) + ((mask >> 2) & 1);
    slot[0] = t;
    for (int i = 1; i <= cnt; i++) slot[i] = n0 + child0 + i - 1;
    const corner_ref *kids[4][3];
    if (cnt == 3) {
      const corner_ref *r[4][3] = {
          {&c[0], &m[0], &m[2]}, {&m[0], &c[1], &m[1]}, {&m[2], &m[1], &c[2]}, {&m[0], &m[1], &m[2]}};
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
        if (p < 3 && q < 3) {                                /* an unsplit edge of the parent: corners p, q */
          edge = pe[(q == (p + 1) % 3) ? p : q];
        } else if (corner < 3 && k >= 0 && (corner == k || corner == (k + 1) % 3)) {
          /* a corner and the midpoint of an edge it ends: a half */
          const ch_refine_edge *e = &w->edges[pe[k]];
          edge = e->half[T.v[corner] == e->a ? 0 : 1];
        } else { /* between the midpoints or a midpoint and the opposite corner */
          int lo = p < q ? p : q, hi = p < q ? q : p, x = 0;
          while (x < ninner && !(inner_tags[x][0] == lo && inner_tags[x][1] == hi)) x++;
          edge = e0 + child0 + x;
          if (x == ninner) {
            inner_tags[ninner][0] = lo;
            inner_tags[ninner][1] = hi;
            ninner++;
            ch_refine_edge *e = &w->edges[edge];
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
      ch_refine_edge *e = &w->edges[pe[k]];
      int owner;
#pragma omp atomic read
      owner = e->tri;
      if (owner != t) continue;
      for (int h = 0; h < (e->mid < 0 ? 1 : 2); h++) {
        int target = e->mid < 0 ? pe[k] : e->half[h], done = 0;
        for (int i = 0; i <= cnt && !done; i++)
          for (int j = 0; j < 3 && !done; j++)
            if (w->tri_edge[3 * (size_t)slot[i] + j] == target) {
              ch_refine_edge *x = &w->edges[target];
#pragma omp atomic write
              x->tri = slot[i];
              x->k = j;
              done = 1;
            }
      }
    }
  }
  /* The split edges are gone from the mesh; their crossings stay for their
   * halves (ch_refine_inherit_crossings). */
  free(edge_split);
  free(parent);
  free(first);
  w->ntris = n;
  w->nedges = e0 + (int)added;
  return CH_OK;
fail:
  free(edge_split);
  free(chunk_first);
  free(parent);
  free(first);
  return ch_error_set(err, CH_ERR_NOMEM, "%s", why);
}

/* ---- a triangle's boundary -------------------------------------------------
 * The boundary of a triangle as a cycle of nodes: its corners and, between
 * them, the crossings of its edges. Each crossing joins the piece before it
 * to the piece after it; inside the triangle it is one end of a chord to the
 * crossing with the same two pieces. */

/* The boundary's nodes into nodes[cap]; -1 if there are more (the
 * triangle is then refined, or fanned once refinement is over). */
int ch_refine_gather_nodes_into(const ch_refine_mesh *w, int t, ch_refine_node *nodes, int cap) {
  const ch_refine_tri *T = &w->tris[t];
  int m = 0;
  for (int k = 0; k < 3; k++) {
    const ch_refine_vert *v = &w->verts[T->v[k]];
    const ch_refine_edge *e = &w->edges[w->tri_edge[3 * (size_t)t + k]];
    /* room for the corner and its edge's crossings (2000 grooves through
     * one point overran the array by the corner written before a check
     * that counted only the crossings) */
    if (e->ncross < 0 || m + 1 + e->ncross > cap) return -1;
    ch_refine_node *c = &nodes[m++];
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
      const ch_refine_crossing *x = &e->cross[forward ? i : e->ncross - 1 - i];
      ch_refine_node *b = &nodes[m++];
      double f = forward ? x->x : 1.0 - x->x;
      b->corner = -1;
      b->edge = k;
      b->lprev = forward ? x->la : x->lb;
      b->lnext = forward ? x->lb : x->la;
      b->copy_prev = forward ? x->copy_a : x->copy_b;
      b->copy_next = forward ? x->copy_b : x->copy_a;
      b->hprev = forward ? x->ha : x->hb;
      b->hnext = forward ? x->hb : x->ha;
      ch_refine_lerp2(T->uv[k], T->uv[(k + 1) % 3], f, b->uv);
      ch_refine_lerp2(T->st[k], T->st[(k + 1) % 3], f, b->st);
      b->pair = -1;
    }
  }
  return m;
}

int ch_refine_gather_nodes(const ch_refine_mesh *w, int t, ch_refine_node *nodes) {
  return ch_refine_gather_nodes_into(w, t, nodes, MAX_NODES);
}

/* Pairs the crossings into chords: two crossings between the same two
 * pieces, in opposite directions. Crossings left unpaired must be where
 * pieces meet at one point inside (a junction: three or more of them, each
 * piece between two consecutive ones). CUT_REGIONS when that works out, no
 * two chords cross and no chord separates the junction's crossings;
 * CUT_COMPLEX otherwise (refined, or fanned if refinement is over). */
ch_refine_cut ch_refine_classify(ch_refine_node *nodes, int m) {
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

/* Whether a triangle of centre c and longest edge `longest` overlaps the
 * rounded cap of a groove's open end and is too coarse for it: there the
 * profile is swept around the end point, a cone (or dome) whose facets must
 * span at most cap_angle around it, so edges up to cap_angle * w / 2, but
 * never below the junction size: the caps of grooves far narrower than the
 * mesh's edges (484 strokes 0.0013 of the square wide at 130k triangles)
 * were each refined down to their own width, a fixed cost per cap that
 * no base count could bring down to the target (188k triangles). */
static int coarse_at_cap(const ch_label_ctx *lb, const double c[2], double longest) {
  /* The open ends near c (bucketed once: 2000 lines through a point put
   * all of theirs in every cell there), counted only if the grooves' grid
   * lists their segment at c, as the scan of its cell did. A u cap is
   * already cut into rings by its lines; refining under all of them costs
   * more than it gains (capped_end leaves them out). */
  int res = lb->end_res, r[4];
  double reach = lb->end_reach + longest;
  r[0] = ch_label_corner_cell(res, c[0] - reach), r[1] = ch_label_corner_cell(res, c[1] - reach);
  r[2] = ch_label_corner_cell(res, c[0] + reach), r[3] = ch_label_corner_cell(res, c[1] + reach);
  for (int y = r[1]; y <= r[3]; y++)
    for (int x = r[0]; x <= r[2]; x++)
      for (int k = lb->end_start[y * res + x]; k < lb->end_start[y * res + x + 1]; k++) {
        int s = lb->end_item[k] / 2, end = lb->end_item[k] % 2;
        const ch_segment *sg = &lb->set->segments[s];
        double half = 0.5 * lb->set->curves[sg->curve].width;
        const double *q = sg->p[end == 0 ? 0 : 2];
        if (longest > fmax(lb->cap_angle * half, lb->junction_size) * ch_label_local_factor(lb, q) &&
            ch_dist2d(c[0] - q[0], c[1] - q[1]) <= half + longest &&
            ch_grid_cell_holds(&lb->groove_grid, ch_groove_field_boxes(&lb->height->grooves) + 4 * (size_t)s, c[0],
                               c[1]))
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
static int coarse_at_step_corner(const ch_label_ctx *lb, const double uv[3][2], const double c[2], double longest) {
  if (!lb->has_steps) return 0;
  /* The corners in the triangle's box (bucketed once: a scan of the step
   * curves near it took a fifth of 1000 small loops' run), counted only if
   * the step grid's cell at c lists their segment, as the scan of that
   * cell did. */
  int res = lb->corner_res, r[4];
  double lo[2] = {fmin(uv[0][0], fmin(uv[1][0], uv[2][0])), fmin(uv[0][1], fmin(uv[1][1], uv[2][1]))};
  double hi[2] = {fmax(uv[0][0], fmax(uv[1][0], uv[2][0])), fmax(uv[0][1], fmax(uv[1][1], uv[2][1]))};
  r[0] = ch_label_corner_cell(res, lo[0]), r[1] = ch_label_corner_cell(res, lo[1]),
  r[2] = ch_label_corner_cell(res, hi[0]);
  r[3] = ch_label_corner_cell(res, hi[1]);
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
        if (longest <= lb->junction_size * ch_label_local_factor(lb, q)) continue;
        return 1;
      }
  return 0;
}

/* Whether triangle t needs splitting: its crossings do not make chords and
 * one junction, or a piece that none of its boundary touches hides inside,
 * or it is coarse over a rounded cap. */
/* Whether pieces a and b are neighbours in one line set of a groove (k
 * and k + 1: piece k lies between lines k - 1 and k); *t gets the line
 * between them. */
static int line_between(const ch_label_ctx *lb, uint64_t a, uint64_t b, double *t) {
  uint64_t ga = a >> 32, gb = b >> 32;
  if (!ga || (ga >> 8) != (gb >> 8) || (uint32_t)a != (uint32_t)b) return 0;
  int ka = (int)(ga & 0xff), kb = (int)(gb & 0xff), nb;
  if (ka - kb != 1 && kb - ka != 1) return 0;
  const double *br = ch_label_lines_of(lb, GROOVE_CURVE(ga), GROOVE_LEVEL(ga), &nb);
  int k = ka < kb ? ka : kb;
  if (k < 1 || k > nb - 2) return 0;
  *t = br[k];
  return 1;
}

int ch_refine_at_differing_seam(const ch_label_ctx *lb, const ch_refine_mesh *w, int t) {
  const ch_refine_tri *T = &w->tris[t];
  for (int k = 0; k < 3; k++)
    if (ch_refine_on_seam(w, T->v[k], T->uv[k]) && ch_label_at(lb, T->uv[k]) != w->verts[T->v[k]].label) return 1;
  return 0;
}

int ch_refine_uncut(const ch_label_ctx *lb, const ch_refine_mesh *w, int t) {
  ch_refine_node nodes[MAX_NODES];
  int m = ch_refine_gather_nodes(w, t, nodes);
  return m >= 0 && ch_refine_classify(nodes, m) == CUT_COMPLEX && !ch_refine_at_differing_seam(lb, w, t);
}

int ch_refine_needed(const ch_label_ctx *lb, const ch_refine_mesh *w, int t, int only_uncut, int round) {
  const ch_refine_tri *T = &w->tris[t];
  if (ch_label_quiet(lb, T->uv[0]) && ch_label_quiet(lb, T->uv[1]) && ch_label_quiet(lb, T->uv[2])) return 0;
  double longest = 0.0;
  for (int k = 0; k < 3; k++)
    longest = fmax(longest, ch_dist2d(T->uv[(k + 1) % 3][0] - T->uv[k][0], T->uv[(k + 1) % 3][1] - T->uv[k][1]));
  const double centre[2] = {(T->uv[0][0] + T->uv[1][0] + T->uv[2][0]) / 3.0,
                            (T->uv[0][1] + T->uv[1][1] + T->uv[2][1]) / 3.0};
  /* (the extra rounds of a warped mesh, only_uncut: what cannot be cut yet, nothing else) */
  if (!only_uncut && lb->cap_angle > 0.0 && coarse_at_cap(lb, centre, longest)) return 1;
  if (!only_uncut && coarse_at_step_corner(lb, T->uv, centre, longest)) return 1;
  ch_refine_node nodes[MAX_NODES];
  int m = ch_refine_gather_nodes(w, t, nodes);
  if (m < 0) return round < DENSE_ROUNDS;
  if (ch_refine_classify(nodes, m) == CUT_COMPLEX) return 1;
  /* A chord with both ends on one edge: the piece between them pokes in
   * through that edge and out through another between two of its samples
   * (missed there), or in and out again; either way the chord runs along
   * the edge and cuts off a piece of no area (relief's roof near its
   * corner: walls along the edge, edges of three faces). Where h is
   * continuous too: a rivet or a slot crossing an edge twice left the same
   * chord in both triangles beside it, each with slivers hanging from it,
   * and the edge in four faces (plane + panels at 15000 triangles: 8 such
   * edges). Split down to the junction size, as at a step corner; below
   * it is cut as it is (splitting on left pieces no cut resolves). Across
   * a wall, down to a sixteenth of it: a step corner 2e-4 across an edge
   * at the junction size (relief's roof at 20000 triangles, with the
   * base's finer edges nearest the curves) left that chord in both
   * triangles beside the edge, each standing a wall on it, and the edge
   * in four faces; smaller triangles put the corner's two lines on
   * different edges. */
  for (int i = 0; i < m; i++)
    if (nodes[i].corner < 0 && nodes[i].pair > i && nodes[nodes[i].pair].edge == nodes[i].edge) {
      int wall = !(fabs(nodes[i].hprev - nodes[i].hnext) <= lb->wall_tol);
      if (longest > (wall ? 1.0 / 16.0 : 1.0) * lb->junction_size * ch_label_local_factor(lb, nodes[i].uv)) return 1;
    }
  if (only_uncut) return 0;
  /* Junctions are placed by estimate: keep their triangles small. */
  for (int i = 0; i < m; i++)
    if (nodes[i].corner < 0 && nodes[i].pair < 0)
      return longest > lb->junction_size * ch_label_local_factor(lb, nodes[i].uv);
  /* A groove's lines curve away from the chords that follow them (by
   * len^2 / 8r): where h at a chord's middle leaves the mesh's h there
   * (the mean of its ends) by more than the groove's tolerance, the chords
   * are too long for the curve (tight circles, the curls of a scroll).
   * Walls are not measured so: h jumps across them. */
  for (int i = 0; i < m; i++) {
    const ch_refine_node *p = &nodes[i];
    if (p->corner >= 0 || p->pair <= i) continue;
    const ch_refine_node *q = &nodes[p->pair];
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
      double tp, tq, line;
      if (line_between(lb, p->lprev, p->lnext, &line)) {
        /* (most chords are short for the curve they follow: the path's
         * curvature proves them within the tolerance without a read) */
        if (ch_label_chord_within(lb, c, line, p->uv, q->uv, mid, lb->chord_tol[c] * ch_label_chord_factor(lb, mid)))
          continue;
        tp = tq = line; /* both ends lie on that line (to 1e-12 of their edges) */
      } else {
        tp = ch_label_groove_distance(lb, c, p->uv) / cv->width;
        tq = ch_label_groove_distance(lb, c, q->uv) / cv->width;
      }
      double tm = ch_label_groove_distance(lb, c, mid) / cv->width;
      err = fabs(tm - 0.5 * (tp + tq)) * fabs(cv->depth);
    } else {
      double mesh_h = 0.25 * (p->hprev + p->hnext + q->hprev + q->hnext);
      err = fabs(ch_height_eval(lb->height, mid[0], mid[1]) - mesh_h);
    }
    if (err > lb->chord_tol[c] * ch_label_chord_factor(lb, mid)) return 1;
  }
  uint64_t l = ch_label_at(lb, centre);
  for (int i = 0; i < m; i++)
    if (nodes[i].lprev == l || nodes[i].lnext == l) return 0;
  return 1;
}
