/* Multi-channel signed distance fields, from the published description of
 * msdfgen (Chlumsky 2015, §3-4; msdfgen 1.x: edgeColoringSimple,
 * generateMSDF, msdfErrorCorrection), written here in C:
 * - edge colouring per contour (subpath): a corner is a joint where
 *   dot(a, b) <= 0 or |cross(a, b)| > sin(threshold); a smooth contour is
 *   white (all channels); one corner (a teardrop) gets three colours along
 *   the contour, edges split in thirds where it has fewer than three;
 *   more corners switch colour at every corner (cyan, magenta, yellow,
 *   switching by the seed's bits, the last spline not taking the first's
 *   colour). Departure: our contours may be open (grooves); an open
 *   contour's ends need no colour change, so corners are counted at
 *   interior joints only.
 * - per channel, the edge nearest by true distance (ties: the more
 *   orthogonal, msdfgen's SignedDistance order), and its pseudo-distance:
 *   beyond an end, the distance to the tangent line there when that is
 *   nearer (distanceToPseudoDistance); the sign is the side (left +).
 * - the legacy clash correction: a texel whose two changing channels jump
 *   by at least 1.001 texels against a neighbour (and which is the farther
 *   of the pair from the edge) takes its median in all three.
 * Departure for cost: msdfgen measures every edge from every texel; we do
 * so within a band of the curves (a grid over the edges) and clamp to
 * +-range there as its pixel range does; beyond the band every channel is
 * +-range with the side of the nearest curve (propagated, ch_edt). */
#include "ch_msdf.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "ch_alloc.h"
#include "ch_bezier.h"
#include "ch_edt.h"
#include "ch_grid.h"
#include "ch_groove.h"
#include "ch_math.h"

enum { RED = 1, GREEN = 2, BLUE = 4, YELLOW = RED | GREEN, MAGENTA = RED | BLUE, CYAN = GREEN | BLUE, WHITE = 7 };

typedef struct edge {
  double p[3][2]; /* UV */
  int is_line;
  int color;
  int curve;
  int prev_open, next_open; /* msdfgen's edges all extend: kept for the record */
} edge;

typedef struct edges {
  edge *v;
  int n, cap;
} edges;

static int push(edges *e, const edge *x) {
  if (e->n == e->cap) {
    int cap = e->cap ? 2 * e->cap : 256;
    edge *p = realloc(e->v, (size_t)cap * sizeof *p);
    if (!p) return -1;
    e->v = p, e->cap = cap;
  }
  e->v[e->n++] = *x;
  return 0;
}

static void direction(const edge *e, double t, double out[2]) {
  /* msdfgen: mix(p1 - p0, p2 - p1, t), the chord where it vanishes */
  for (int k = 0; k < 2; k++) out[k] = (1.0 - t) * (e->p[1][k] - e->p[0][k]) + t * (e->p[2][k] - e->p[1][k]);
  if (out[0] == 0.0 && out[1] == 0.0)
    for (int k = 0; k < 2; k++) out[k] = e->p[2][k] - e->p[0][k];
  double l = hypot(out[0], out[1]);
  if (l > 0.0) out[0] /= l, out[1] /= l;
}

static int is_corner(const double a[2], const double b[2], double cross_threshold) {
  return ch_dot2(a, b) <= 0.0 || fabs(ch_cross2(a, b)) > cross_threshold;
}

static void switch_color(int *color, unsigned long long *seed, int banned) {
  int combined = *color & banned;
  if (combined == RED || combined == GREEN || combined == BLUE) {
    *color = combined ^ WHITE;
    return;
  }
  if (*color == 0 || *color == WHITE) {
    static const int start[3] = {CYAN, MAGENTA, YELLOW};
    *color = start[*seed % 3];
    *seed /= 3;
    return;
  }
  int shifted = *color << (1 + (*seed & 1));
  *color = (shifted | shifted >> 3) & WHITE;
  *seed >>= 1;
}

/* The sub-curve over [a, b] of a quadratic. */
static void split(const edge *e, double a, double b, edge *out) {
  *out = *e;
  double sa = 1.0 - a, sb = 1.0 - b;
  for (int k = 0; k < 2; k++) {
    out->p[0][k] = sa * sa * e->p[0][k] + 2 * sa * a * e->p[1][k] + a * a * e->p[2][k];
    out->p[2][k] = sb * sb * e->p[0][k] + 2 * sb * b * e->p[1][k] + b * b * e->p[2][k];
    out->p[1][k] = sa * sb * e->p[0][k] + (sa * b + a * sb) * e->p[1][k] + a * b * e->p[2][k];
  }
}

/* Colours one contour's edges in place (they are c->v[first .. first+n-1]);
 * may split edges (teardrops with fewer than three), appending to out. */
static int color_contour(const edge *in, int n, int closed, double cross_threshold, unsigned long long *seed,
                         edges *out, int *ncorners) {
  int corners[4096], nc = 0;
  if (n > 4096) { /* too many to track: treat every joint as a corner */
    for (int i = 0; i < n; i++) {
      edge e = in[i];
      e.color = i % 2 ? CYAN : YELLOW;
      if (push(out, &e)) return -1;
    }
    return 0;
  }
  for (int i = closed ? 0 : 1; i < n; i++) {
    double a[2], b[2];
    direction(&in[(i - 1 + n) % n], 1.0, a);
    direction(&in[i], 0.0, b);
    if (is_corner(a, b, cross_threshold)) corners[nc++] = i;
  }
  *ncorners += nc;
  if (!closed) {
    /* An open contour: its start is no corner but begins the first spline. */
    if (nc == 0) {
      for (int i = 0; i < n; i++) {
        edge e = in[i];
        e.color = WHITE;
        if (push(out, &e)) return -1;
      }
      return 0;
    }
    int color = WHITE;
    switch_color(&color, seed, 0);
    for (int i = 0, spline = 0; i < n; i++) {
      if (spline < nc && corners[spline] == i) {
        spline++;
        switch_color(&color, seed, 0);
      }
      edge e = in[i];
      e.color = color;
      if (push(out, &e)) return -1;
    }
    return 0;
  }
  if (nc == 0) {
    for (int i = 0; i < n; i++) {
      edge e = in[i];
      e.color = WHITE;
      if (push(out, &e)) return -1;
    }
  } else if (nc == 1) {
    /* teardrop: three colours along the contour */
    int colors[3] = {WHITE, WHITE, WHITE};
    switch_color(&colors[0], seed, 0);
    colors[2] = colors[0];
    switch_color(&colors[2], seed, 0);
    int corner = corners[0];
    if (n >= 3) {
      for (int i = 0; i < n; i++) {
        edge e = in[(corner + i) % n];
        e.color = (colors + 1)[(int)(3 + 2.875 * i / (n - 1) - 1.4375 + 0.5) - 3];
        if (push(out, &e)) return -1;
      }
    } else {
      /* split each edge in thirds: parts[0..2] of the corner's edge first */
      edge parts[6];
      int np = 0;
      for (int k = 0; k < n; k++) {
        const edge *e = &in[(corner + k) % n];
        for (int j = 0; j < 3; j++) split(e, j / 3.0, (j + 1) / 3.0, &parts[np++]);
      }
      if (np == 6) {
        parts[0].color = parts[1].color = colors[0];
        parts[2].color = parts[3].color = colors[1];
        parts[4].color = parts[5].color = colors[2];
      } else {
        parts[0].color = colors[0], parts[1].color = colors[1], parts[2].color = colors[2];
      }
      for (int k = 0; k < np; k++)
        if (push(out, &parts[k])) return -1;
    }
  } else {
    int spline = 0, start = corners[0], color = WHITE;
    switch_color(&color, seed, 0);
    int initial = color;
    for (int i = 0; i < n; i++) {
      int index = (start + i) % n;
      if (spline + 1 < nc && corners[spline + 1] == index) {
        spline++;
        switch_color(&color, seed, spline == nc - 1 ? initial : 0);
      }
      edge e = in[index];
      e.color = color;
      if (push(out, &e)) return -1;
    }
  }
  return 0;
}

/* msdfgen's SignedDistance: the true distance, signed by the side, and the
 * tie-break dot (how far from orthogonal the nearest direction is at an
 * end); param may leave [0, 1] past an end. */
typedef struct sdist {
  double dist, dot, param;
} sdist;

static int sd_less(const sdist *a, const sdist *b) {
  double x = fabs(a->dist), y = fabs(b->dist);
  return x < y || (x == y && a->dot < b->dot);
}

static void edge_distance(const edge *e, const double q[2], sdist *out) {
  double t, d2 = ch_bezier_closest(e->p, e->is_line, q, &t);
  double P[2], dir[2];
  ch_bezier_eval(e->p, t, P);
  direction(e, t, dir);
  double w[2] = {q[0] - P[0], q[1] - P[1]}, d = sqrt(d2);
  double cr = ch_cross2(dir, w);
  out->dist = cr >= 0.0 ? d : -d;
  out->dot = 0.0;
  out->param = t;
  if ((t <= 0.0 || t >= 1.0) && d > 0.0) {
    out->dot = fabs(ch_dot2(dir, w)) / d;
    /* the parameter of the projection onto the tangent line past the end */
    double s = ch_dot2(w, dir);
    out->param = t <= 0.0 ? (s < 0.0 ? -1.0 : 0.0) : (s > 0.0 ? 2.0 : 1.0);
  }
}

/* Past an end, the distance to the tangent line there if it is nearer. */
static void to_pseudo(const edge *e, const double q[2], sdist *sd) {
  if (sd->param < 0.0) {
    double dir[2], a[2] = {q[0] - e->p[0][0], q[1] - e->p[0][1]};
    direction(e, 0.0, dir);
    if (ch_dot2(a, dir) < 0.0) {
      double pd = ch_cross2(dir, a);
      if (fabs(pd) <= fabs(sd->dist)) sd->dist = pd, sd->dot = 0.0;
    }
  } else if (sd->param > 1.0) {
    double dir[2], b[2] = {q[0] - e->p[2][0], q[1] - e->p[2][1]};
    direction(e, 1.0, dir);
    if (ch_dot2(b, dir) > 0.0) {
      double pd = ch_cross2(dir, b);
      if (fabs(pd) <= fabs(sd->dist)) sd->dist = pd, sd->dot = 0.0;
    }
  }
}

static double median3(double a, double b, double c) { return fmax(fmin(a, b), fmin(fmax(a, b), c)); }

/* msdfgen's pixelClash with 0 as the edge (its 0.5). */
static int clash(const float *a, const float *b, double threshold) {
  int ain = (a[0] > 0) + (a[1] > 0) + (a[2] > 0) >= 2, bin = (b[0] > 0) + (b[1] > 0) + (b[2] > 0) >= 2;
  if (ain != bin) return 0;
  if ((a[0] > 0 && a[1] > 0 && a[2] > 0) || (a[0] < 0 && a[1] < 0 && a[2] < 0) || (b[0] > 0 && b[1] > 0 && b[2] > 0) ||
      (b[0] < 0 && b[1] < 0 && b[2] < 0))
    return 0;
  int flip[3], nf = 0;
  for (int k = 0; k < 3; k++)
    if ((a[k] > 0) != (b[k] > 0) && (a[k] < 0) != (b[k] < 0)) flip[nf++] = k;
  if (nf != 2) return 0;
  int c = 3 - flip[0] - flip[1];
  return fabs(a[flip[0]] - b[flip[0]]) >= threshold && fabs(a[flip[1]] - b[flip[1]]) >= threshold &&
         fabs(a[c]) >= fabs(b[c]);
}

void ch_msdf_free(ch_msdf *m) {
  free(m->channels);
  free(m->curve);
  free(m->curves);
  memset(m, 0, sizeof *m);
}

double ch_msdf_bytes_per_texel(void) { return 16.0; }

ch_status ch_msdf_build(const ch_curve_set *set, const ch_msdf_desc *desc, ch_msdf *m, ch_error *err) {
  memset(m, 0, sizeof *m);
  double t0 = omp_get_wtime();
  int R = desc->resolution;
  double rect[4];
  ch_status lst = ch_featmap_check_lattice("distance field", R, desc->rect, rect, err);
  if (lst) return lst;
  double du = (rect[2] - rect[0]) / R, dv = (rect[3] - rect[1]) / R, texel = fmax(du, dv);
  double half = 0.0;
  int any = 0;
  for (int c = 0; c < set->num_curves; c++) {
    if (!ch_featmap_encodes(set, c) || set->curves[c].num_segments < 1) continue;
    any = 1;
    for (int i = set->curves[c].first_segment; i < set->curves[c].first_segment + set->curves[c].num_segments; i++)
      for (int k = 0; k < 3; k++)
        if (!ch_finite2(set->segments[i].p[k])) return ch_error_set(err, CH_ERR_INPUT, "a control point is not finite");
    if (set->curves[c].kind == CH_CURVE_GROOVE) half = fmax(half, 0.5 * set->curves[c].width);
  }
  if (!any)
    return ch_error_set(err, CH_ERR_INPUT, "no curve to encode (distance fields hold grooves and step curves without blur)");
  double range = desc->range > 0.0 ? desc->range * texel : fmax(half / texel + 2.0, 4.0) * texel;
  m->resolution = R;
  memcpy(m->rect, rect, sizeof m->rect);
  m->range = range;
  int R1 = R + 1;
  size_t n = (size_t)R1 * R1;
  edges E = {0};
  m->channels = ch_alloc_large(3 * n, sizeof *m->channels, 0);
  m->curve = ch_alloc_large(n, sizeof *m->curve, 0);
  m->curves = calloc((size_t)(set->num_curves > 0 ? set->num_curves : 1), sizeof *m->curves);
  uint8_t *exact = ch_alloc_large(n, 1, 0);
  int32_t *near_edge = ch_alloc_large(n, sizeof *near_edge, 0);
  ch_edt_rec *rec = ch_alloc_large(n, sizeof *rec, 0);
  double(*boxes)[4] = NULL;
  ch_grid grid = {0};
  ch_status st = CH_OK;
  if (!m->channels || !m->curve || !m->curves || !exact || !rec || !near_edge) goto nomem;
  m->num_curves = set->num_curves;
  for (int c = 0; c < set->num_curves; c++) {
    const ch_curve *cv = &set->curves[c];
    m->curves[c] = (ch_featmap_curve){cv->kind, cv->profile, cv->width, cv->depth, 0};
  }
  /* Edges and their colours, contour by contour. */
  double cross_threshold = sin(desc->angle_threshold > 0.0 ? desc->angle_threshold : 3.0);
  unsigned long long seed = 0;
  for (int s = 0; s < set->num_subpaths; s++) {
    const ch_subpath *sp = &set->subpaths[s];
    if (sp->num_segments < 1 || !ch_featmap_encodes(set, set->segments[sp->first_segment].curve)) continue;
    edge *in = malloc((size_t)sp->num_segments * sizeof *in);
    if (!in) goto nomem;
    for (int i = 0; i < sp->num_segments; i++) {
      const ch_segment *sg = &set->segments[sp->first_segment + i];
      memset(&in[i], 0, sizeof in[i]);
      memcpy(in[i].p, sg->p, sizeof in[i].p);
      in[i].is_line = sg->is_line;
      in[i].curve = sg->curve;
    }
    int rc = color_contour(in, sp->num_segments, sp->closed, cross_threshold, &seed, &E, &m->stats.corners);
    free(in);
    if (rc) goto nomem;
    m->stats.contours++;
  }
  m->stats.edges = E.n;
  boxes = malloc((size_t)(E.n > 0 ? E.n : 1) * sizeof *boxes);
  if (!boxes) goto nomem;
  for (int i = 0; i < E.n; i++) {
    const edge *e = &E.v[i];
    boxes[i][0] = fmin(fmin(e->p[0][0], e->p[1][0]), e->p[2][0]) - range;
    boxes[i][1] = fmin(fmin(e->p[0][1], e->p[1][1]), e->p[2][1]) - range;
    boxes[i][2] = fmax(fmax(e->p[0][0], e->p[1][0]), e->p[2][0]) + range;
    boxes[i][3] = fmax(fmax(e->p[0][1], e->p[1][1]), e->p[2][1]) + range;
  }
  if ((st = ch_grid_build(&grid, E.n, (const double(*)[4])boxes, err))) goto fail;
#pragma omp parallel for schedule(dynamic, 4)
  for (int y = 0; y < R1; y++)
    for (int x = 0; x < R1; x++) {
      size_t k = (size_t)y * R1 + x;
      double q[2] = {rect[0] + (x + CH_FEATMAP_OFFSET_X) * du, rect[1] + (y + CH_FEATMAP_OFFSET_Y) * dv};
      const int *items;
      int cnt = ch_grid_query(&grid, q[0], q[1], &items);
      sdist best[3], all = {0, 0, 0};
      int bi[3] = {-1, -1, -1}, ai = -1;
      for (int a = 0; a < cnt; a++) {
        const double *b = boxes[items[a]];
        if (q[0] < b[0] || q[0] > b[2] || q[1] < b[1] || q[1] > b[3]) continue;
        const edge *e = &E.v[items[a]];
        sdist sd;
        edge_distance(e, q, &sd);
        if (ai < 0 || sd_less(&sd, &all)) all = sd, ai = items[a];
        for (int ch = 0; ch < 3; ch++)
          if ((e->color & (1 << ch)) && (bi[ch] < 0 || sd_less(&sd, &best[ch]))) best[ch] = sd, bi[ch] = items[a];
      }
      exact[k] = ai >= 0 && fabs(all.dist) <= range;
      rec[k].seed = -1;
      rec[k].d2 = INFINITY;
      if (!exact[k]) continue;
      double side = all.dist >= 0.0 ? 1.0 : -1.0;
      for (int ch = 0; ch < 3; ch++) {
        double v;
        if (bi[ch] < 0) {
          v = side * range; /* no edge of this colour within the range */
        } else {
          to_pseudo(&E.v[bi[ch]], q, &best[ch]);
          v = ch_clamp(best[ch].dist, -range, range);
        }
        m->channels[3 * k + ch] = (float)v;
      }
      m->curve[k] = E.v[ai].curve;
      near_edge[k] = ai;
      /* a seed for the far field: its nearest point, grid coordinates */
      double P[2];
      ch_bezier_eval(E.v[ai].p, all.param < 0.0 ? 0.0 : all.param > 1.0 ? 1.0 : all.param, P);
      rec[k].x = (float)((P[0] - rect[0]) / du - CH_FEATMAP_OFFSET_X);
      rec[k].y = (float)((P[1] - rect[1]) / dv - CH_FEATMAP_OFFSET_Y);
      rec[k].d2 = (float)((rec[k].x - x) * (rec[k].x - x) + (rec[k].y - y) * (rec[k].y - y));
      rec[k].seed = (int32_t)k;
    }
  ch_edt_propagate(rec, exact, R1, R1);
  /* Beyond the range: every channel +-range, the side of the nearest curve
   * (its seed's nearest edge, measured from here). */
#pragma omp parallel for schedule(dynamic, 16)
  for (int y = 0; y < R1; y++)
    for (int x = 0; x < R1; x++) {
      size_t k = (size_t)y * R1 + x;
      if (exact[k]) continue;
      double q[2] = {rect[0] + (x + CH_FEATMAP_OFFSET_X) * du, rect[1] + (y + CH_FEATMAP_OFFSET_Y) * dv};
      int s = rec[k].seed;
      double side = 1.0;
      int curve = -1;
      if (s >= 0) {
        /* the side of the seed's nearest edge, seen from here */
        sdist sd;
        edge_distance(&E.v[near_edge[s]], q, &sd);
        side = sd.dist >= 0.0 ? 1.0 : -1.0;
        curve = m->curve[s];
      }
      for (int ch = 0; ch < 3; ch++) m->channels[3 * k + ch] = (float)(side * range);
      m->curve[k] = curve;
    }
  /* msdfErrorCorrection (legacy). */
  if (!desc->no_correction) {
    uint8_t *mark = ch_alloc_large(n, 1, 1);
    if (!mark) goto nomem;
    double thx = 1.001 * du, thy = 1.001 * dv;
#pragma omp parallel for schedule(static)
    for (int y = 0; y < R1; y++)
      for (int x = 0; x < R1; x++) {
        size_t k = (size_t)y * R1 + x;
        const float *p = &m->channels[3 * k];
        if ((x > 0 && clash(p, p - 3, thx)) || (x + 1 < R1 && clash(p, p + 3, thx)) ||
            (y > 0 && clash(p, p - 3 * R1, thy)) || (y + 1 < R1 && clash(p, p + 3 * R1, thy)))
          mark[k] = 1;
      }
    long clashes = 0;
    for (size_t k = 0; k < n; k++) {
      if (!mark[k]) continue;
      float *p = &m->channels[3 * k];
      float med = (float)median3(p[0], p[1], p[2]);
      p[0] = p[1] = p[2] = med;
      clashes++;
    }
    m->stats.clashes = clashes;
    free(mark);
  }
  m->stats.seconds = omp_get_wtime() - t0;
  goto done;
nomem:
  st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for a %dx%d distance field", R, R);
fail:
  ch_msdf_free(m);
done:
  ch_grid_free(&grid);
  free(boxes);
  free(E.v);
  free(exact);
  free(near_edge);
  free(rec);
  return st;
}

void ch_msdf_eval(const ch_msdf *m, double u, double v, ch_featmap_sample *out) {
  int R = m->resolution, R1 = R + 1;
  double du = (m->rect[2] - m->rect[0]) / R, dv = (m->rect[3] - m->rect[1]) / R;
  double x = (u - m->rect[0]) / du - CH_FEATMAP_OFFSET_X, y = (v - m->rect[1]) / dv - CH_FEATMAP_OFFSET_Y;
  if (!(x > -1e9 && x < 1e9)) x = 0.0;
  if (!(y > -1e9 && y < 1e9)) y = 0.0;
  int j = (int)floor(x), i = (int)floor(y);
  j = j < 0 ? 0 : j >= R ? R - 1 : j;
  i = i < 0 ? 0 : i >= R ? R - 1 : i;
  double fx = x - j, fy = y - i;
  size_t c[4] = {(size_t)i * R1 + j, (size_t)i * R1 + j + 1, (size_t)(i + 1) * R1 + j + 1, (size_t)(i + 1) * R1 + j};
  double w[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), fx * fy, (1 - fx) * fy};
  double ch[3] = {0, 0, 0};
  for (int q = 0; q < 4; q++)
    for (int k = 0; k < 3; k++) ch[k] += w[q] * m->channels[3 * c[q] + k];
  double med = median3(ch[0], ch[1], ch[2]);
  int mc = med == ch[0] ? 0 : med == ch[1] ? 1 : 2;
  /* gradient of the median channel's bilinear interpolant, per UV */
  const float *a = &m->channels[3 * c[0] + mc], *b = &m->channels[3 * c[1] + mc];
  const float *cc = &m->channels[3 * c[2] + mc], *d = &m->channels[3 * c[3] + mc];
  double gx = ((1 - fy) * (*b - *a) + fy * (*cc - *d)) / du, gy = ((1 - fx) * (*d - *a) + fx * (*cc - *b)) / dv;
  memset(out, 0, sizeof *out);
  out->distance = fabs(med);
  out->side = med >= 0.0 ? 1 : -1;
  double gl = hypot(gx, gy);
  /* the gradient of the unsigned distance: the signed one's, times the side */
  out->gradient[0] = gl > 0.0 ? out->side * gx / gl : 1.0;
  out->gradient[1] = gl > 0.0 ? out->side * gy / gl : 0.0;
  int nq = fx < 0.5 ? (fy < 0.5 ? 0 : 3) : (fy < 0.5 ? 1 : 2);
  out->curve = m->curve[c[nq]];
  out->base[2] = 1.0;
  const ch_featmap_curve *cv = out->curve >= 0 && out->curve < m->num_curves ? &m->curves[out->curve] : NULL;
  double half = cv ? 0.5 * cv->width : 0.0;
  ch_featmap_profile_normal(cv, out->side, out->distance, out->gradient, out->base, half, half, out->normal);
  out->kind = 0;
}
