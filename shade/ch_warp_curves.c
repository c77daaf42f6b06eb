/* The curves warped through the cage map (diffusion-curves-on-surfaces
 * §3.2, ch_warp_curves.h): segments that span several cage triangles are
 * cut and registered per piece, and a regular grid of triangles over
 * texture space keeps the registration fast enough for animated curves.
 *
 * Where we depart from the paper: our curves are quadratic Beziers, not
 * polylines: a segment is cut at the exact roots of the quadratic on every
 * triangle edge near it, and a piece's control points go through its
 * triangle's affine map, so the warped piece is the exact image (an affine
 * map of a quadratic is the quadratic of the mapped control points). */
#include "ch_warp_curves.h"

#include <limits.h>
#include <stdlib.h>
#include <string.h>

#include "ch_alloc.h"
#include "ch_warp_internal.h"

/* Curve parameters closer than this are one cut. */
#define CUT_MERGE 1e-12
/* Relative tolerance of the cut point lying on an edge: a spurious cut near
 * a vertex costs one more piece, a missed one a piece in the wrong triangle. */
#define EDGE_TOL 1e-9

/* Per-thread scratch: candidate triangles of one segment (each once: a bit
 * per triangle, cleared after the segment) and its cut parameters. */
typedef struct reg_scratch {
  unsigned char *seen;
  int *tris, num_tris, cap_tris;
  double *cuts;
  int num_cuts, cap_cuts;
} reg_scratch;

/* A chunk of consecutive segments' pieces, filled by one thread. */
typedef struct piece_chunk {
  ch_segment *pieces;
  int num, cap;
  int failed;
} piece_chunk;

/* Adds the triangles of the grid cells near the quadratic q: its control box
 * is split in halves (de Casteljau) until it spans at most 2x2 cells, so a
 * long segment visits the cells along it, not its whole box. */
static int gather_triangles(const ch_grid *g, const double q[3][2], int depth, reg_scratch *sc) {
  double box[4] = {fmin(fmin(q[0][0], q[1][0]), q[2][0]), fmin(fmin(q[0][1], q[1][1]), q[2][1]),
                   fmax(fmax(q[0][0], q[1][0]), q[2][0]), fmax(fmax(q[0][1], q[1][1]), q[2][1])};
  int r[4];
  cell_range(g, box, r);
  if (r[0] > r[2] || r[1] > r[3]) return 0;
  if ((r[2] - r[0] + 1) * (r[3] - r[1] + 1) > 4 && depth < 16) {
    double h[2][3][2];
    for (int k = 0; k < 2; k++) {
      double m0 = 0.5 * (q[0][k] + q[1][k]), m1 = 0.5 * (q[1][k] + q[2][k]), mid = 0.5 * (m0 + m1);
      h[0][0][k] = q[0][k], h[0][1][k] = m0, h[0][2][k] = mid;
      h[1][0][k] = mid, h[1][1][k] = m1, h[1][2][k] = q[2][k];
    }
    return gather_triangles(g, (const double(*)[2])h[0], depth + 1, sc) ||
           gather_triangles(g, (const double(*)[2])h[1], depth + 1, sc);
  }
  for (int y = r[1]; y <= r[3]; y++)
    for (int x = r[0]; x <= r[2]; x++) {
      int c = y * g->nx + x;
      for (int k = g->cell_start[c]; k < g->cell_start[c + 1]; k++) {
        int t = g->items[k];
        if (sc->seen[t >> 3] & (1u << (t & 7))) continue;
        sc->seen[t >> 3] |= (unsigned char)(1u << (t & 7));
        if (ch_alloc_grow((void **)&sc->tris, &sc->cap_tris, sc->num_tris + 1, sizeof *sc->tris, 64)) return -1;
        sc->tris[sc->num_tris++] = t;
      }
    }
  return 0;
}

static int add_cut(reg_scratch *sc, double t) {
  if (ch_alloc_grow((void **)&sc->cuts, &sc->cap_cuts, sc->num_cuts + 1, sizeof *sc->cuts, 64)) return -1;
  sc->cuts[sc->num_cuts++] = t;
  return 0;
}

/* Roots in (0, 1) of a t^2 + b t + c (the stable form). */
static int roots01(double a, double b, double c, double r[2]) {
  int m = 0;
  if (a == 0.0) {
    if (b != 0.0) r[m++] = -c / b;
  } else {
    double disc = b * b - 4.0 * a * c;
    if (disc < 0.0) return 0;
    double q = -0.5 * (b + copysign(sqrt(disc), b));
    r[m++] = q / a;
    if (q != 0.0) r[m++] = c / q;
  }
  int k = 0;
  for (int i = 0; i < m; i++)
    if (r[i] > 0.0 && r[i] < 1.0) r[k++] = r[i];
  return k;
}

/* Cuts where segment s crosses edge P -> Q: the roots of the quadratic's
 * offset along the edge normal whose points lie on the edge. */
static int cut_edge(const ch_segment *s, const double P[2], const double Q[2], reg_scratch *sc) {
  double e[2] = {Q[0] - P[0], Q[1] - P[1]}, nrm[2] = {-e[1], e[0]};
  double off[3];
  for (int k = 0; k < 3; k++) off[k] = nrm[0] * (s->p[k][0] - P[0]) + nrm[1] * (s->p[k][1] - P[1]);
  /* All control points strictly on one side: the curve (in their hull)
   * does not reach the edge's line. */
  if ((off[0] > 0.0 && off[1] > 0.0 && off[2] > 0.0) || (off[0] < 0.0 && off[1] < 0.0 && off[2] < 0.0)) return 0;
  double r[2];
  int m = s->is_line ? roots01(0.0, off[2] - off[0], off[0], r)
                     : roots01(off[0] - 2.0 * off[1] + off[2], 2.0 * (off[1] - off[0]), off[0], r);
  double ee = ch_dot2(e, e);
  for (int i = 0; i < m; i++) {
    double x[2];
    ch_segment_point(s, r[i], x);
    double along = ((x[0] - P[0]) * e[0] + (x[1] - P[1]) * e[1]) / ee;
    if (along >= -EDGE_TOL && along <= 1.0 + EDGE_TOL && add_cut(sc, r[i])) return -1;
  }
  return 0;
}

/* Points of the original segment on [t0, t1] as a quadratic: the blossom
 * values b(t0, t0), b(t0, t1), b(t1, t1); lines keep the midpoint rule. */
static void sub_segment(const ch_segment *s, double t0, double t1, double q[3][2]) {
  if (t0 == 0.0) memcpy(q[0], s->p[0], sizeof q[0]);
  else ch_segment_point(s, t0, q[0]);
  if (t1 == 1.0) memcpy(q[2], s->p[2], sizeof q[2]);
  else ch_segment_point(s, t1, q[2]);
  if (s->is_line) {
    q[1][0] = 0.5 * (q[0][0] + q[2][0]);
    q[1][1] = 0.5 * (q[0][1] + q[2][1]);
  } else {
    double w0 = (1.0 - t0) * (1.0 - t1), w1 = (1.0 - t0) * t1 + t0 * (1.0 - t1), w2 = t0 * t1;
    for (int k = 0; k < 2; k++) q[1][k] = w0 * s->p[0][k] + w1 * s->p[1][k] + w2 * s->p[2][k];
  }
}

static void map_point(const ch_warp *w, int t, const double q[2], double out[2]) {
  if (t >= 0) {
    ch_warp_cage_apply(w, t, 0, q, out);
  } else {
    out[0] = ch_warp_axis(w, 0, q[0]);
    out[1] = ch_warp_axis(w, 1, q[1]);
  }
}

static void set_line_midpoint(ch_segment *s) {
  if (!s->is_line) return;
  s->p[1][0] = 0.5 * (s->p[0][0] + s->p[2][0]);
  s->p[1][1] = 0.5 * (s->p[0][1] + s->p[2][1]);
}

/* Cuts segment s at the cage edges, maps each piece and appends it to ch.
 * Returns the number of pieces, or -1 when out of memory. */
static int register_segment(const ch_warp *w, const ch_segment *s, reg_scratch *sc, piece_chunk *ch) {
  const cage_index *ix = w->grids;
  sc->num_tris = sc->num_cuts = 0;
  int failed = gather_triangles(&ix->grid[0], (const double(*)[2])s->p, 0, sc);
  for (int i = 0; i < sc->num_tris; i++) sc->seen[sc->tris[i] >> 3] = 0;
  if (failed) return -1;
  double sbox[4];
  ch_segment_box(s, 0.0, sbox);
  for (int i = 0; i < sc->num_tris; i++) {
    const double *c = w->uv + 6 * (size_t)sc->tris[i];
    double tb[4];
    tri_box(c, tb);
    if (!boxes_overlap(tb, sbox)) continue;
    for (int k = 0; k < 3; k++) {
      const double *P = c + 2 * k, *Q = c + 2 * ((k + 1) % 3);
      /* One orientation per edge, so the two triangles sharing it find
       * the same roots and the duplicates merge exactly. */
      int swap = P[0] > Q[0] || (P[0] == Q[0] && P[1] > Q[1]);
      if (cut_edge(s, swap ? Q : P, swap ? P : Q, sc)) return -1;
    }
  }
  if (sc->num_cuts > 1) qsort(sc->cuts, (size_t)sc->num_cuts, sizeof *sc->cuts, ch_cmp_double);
  int m = 0;
  double last = 0.0;
  for (int i = 0; i < sc->num_cuts; i++) {
    double t = sc->cuts[i];
    if (t - last > CUT_MERGE && 1.0 - t > CUT_MERGE) sc->cuts[m++] = last = t;
  }
  if (ch_alloc_grow((void **)&ch->pieces, &ch->cap, ch->num + m + 1, sizeof *ch->pieces, 64)) return -1;
  for (int i = 0; i <= m; i++) {
    double t0 = i > 0 ? sc->cuts[i - 1] : 0.0, t1 = i < m ? sc->cuts[i] : 1.0;
    double q[3][2], mid[2], b[2];
    sub_segment(s, t0, t1, q);
    ch_segment_point(s, 0.5 * (t0 + t1), mid);
    int t = ch_warp_cage_locate(ix, 0, mid, b);
    ch_segment *out = &ch->pieces[ch->num + i];
    *out = *s;
    out->prev = out->next = -1;
    if (i > 0) /* the joint exactly where the piece before ends */
      memcpy(out->p[0], ch->pieces[ch->num + i - 1].p[2], sizeof out->p[0]);
    else
      map_point(w, t, q[0], out->p[0]);
    map_point(w, t, q[2], out->p[2]);
    if (s->is_line)
      set_line_midpoint(out);
    else
      map_point(w, t, q[1], out->p[1]);
  }
  ch->num += m + 1;
  return m + 1;
}

enum { CHUNK_SEGMENTS = 64 };

ch_status ch_warp_curves(const ch_warp *w, const ch_curve_set *in, ch_curve_set *out, ch_warp_curve_stats *stats,
                         ch_error *err) {
  double t0 = ch_progress_seconds();
  memset(out, 0, sizeof *out);
  if (stats) memset(stats, 0, sizeof *stats);
  int ns = in->num_segments;
  int nchunks = (ns + CHUNK_SEGMENTS - 1) / CHUNK_SEGMENTS;
  piece_chunk *chunks = calloc((size_t)(nchunks > 0 ? nchunks : 1), sizeof *chunks);
  int *first = malloc((size_t)(ns + 1) * sizeof *first); /* first piece per segment */
  ch_status st = CH_OK;
  if (!chunks || !first) {
    st = ch_error_set(err, CH_ERR_NOMEM, "out of memory warping the curves");
    goto done;
  }
  /* Chunks of consecutive segments, each filled by one thread into its own
   * buffer and concatenated in order: the same pieces on any thread count. */
#pragma omp parallel
  {
    reg_scratch sc = {0};
    sc.seen = calloc((size_t)w->num_triangles / 8 + 1, 1);
#pragma omp for schedule(dynamic, 1)
    for (int c = 0; c < nchunks; c++) {
      piece_chunk *ch = &chunks[c];
      if (!sc.seen) {
        ch->failed = 1;
        continue;
      }
      int end = (c + 1) * CHUNK_SEGMENTS < ns ? (c + 1) * CHUNK_SEGMENTS : ns;
      for (int i = c * CHUNK_SEGMENTS; i < end && !ch->failed; i++) {
        int k = register_segment(w, &in->segments[i], &sc, ch);
        if (k < 0)
          ch->failed = 1;
        else
          first[i + 1] = k; /* a count for now */
      }
    }
    free(sc.seen);
    free(sc.tris);
    free(sc.cuts);
  }
  for (int c = 0; c < nchunks; c++)
    if (chunks[c].failed) {
      st = ch_error_set(err, CH_ERR_NOMEM, "out of memory warping the curves");
      goto done;
    }
  first[0] = 0;
  for (int i = 0; i < ns; i++) {
    if (first[i + 1] > INT_MAX - first[i]) {
      st = ch_error_set(err, CH_ERR_INPUT, "warping the curves: too many pieces");
      goto done;
    }
    first[i + 1] += first[i];
  }
  int np = first[ns];
  out->segments = malloc((size_t)(np > 0 ? np : 1) * sizeof *out->segments);
  out->curves = malloc((size_t)(in->num_curves > 0 ? in->num_curves : 1) * sizeof *out->curves);
  out->subpaths = malloc((size_t)(in->num_subpaths > 0 ? in->num_subpaths : 1) * sizeof *out->subpaths);
  if (!out->segments || !out->curves || !out->subpaths) {
    st = ch_error_set(err, CH_ERR_NOMEM, "out of memory warping the curves");
    goto done;
  }
  for (int c = 0, at = 0; c < nchunks; c++) {
    if (chunks[c].num > 0) memcpy(out->segments + at, chunks[c].pieces, (size_t)chunks[c].num * sizeof *out->segments);
    at += chunks[c].num;
  }
  out->num_segments = np;
  /* Links: pieces of a segment in a row; its ends to the neighbouring
   * segments' end pieces, so closed subpaths link round as read. */
  for (int i = 0; i < ns; i++) {
    const ch_segment *s = &in->segments[i];
    for (int j = first[i]; j < first[i + 1]; j++) {
      out->segments[j].prev = j > first[i] ? j - 1 : s->prev >= 0 ? first[s->prev + 1] - 1 : -1;
      out->segments[j].next = j + 1 < first[i + 1] ? j + 1 : s->next >= 0 ? first[s->next] : -1;
    }
  }
  /* Joints between segments, where the original ones meet exactly: the
   * start of a piece is the end of the one before; a subpath that closes
   * ends on its first point. */
  for (int pass = 0; pass < 2; pass++)
    for (int i = 0; i < ns; i++) {
      const ch_segment *s = &in->segments[i];
      int p = s->prev;
      if (p < 0 || (pass == 0) != (p < i)) continue;
      if (s->p[0][0] != in->segments[p].p[2][0] || s->p[0][1] != in->segments[p].p[2][1]) continue;
      ch_segment *head = &out->segments[first[i]], *tail = &out->segments[first[p + 1] - 1];
      if (pass == 0) {
        memcpy(head->p[0], tail->p[2], sizeof head->p[0]);
        set_line_midpoint(head);
      } else {
        memcpy(tail->p[2], head->p[0], sizeof tail->p[2]);
        set_line_midpoint(tail);
      }
    }
  out->num_curves = in->num_curves;
  if (in->num_curves > 0) memcpy(out->curves, in->curves, (size_t)in->num_curves * sizeof *out->curves);
  for (int c = 0; c < in->num_curves; c++) {
    ch_curve *cv = &out->curves[c];
    const ch_curve *src = &in->curves[c];
    cv->first_segment = first[src->first_segment];
    cv->num_segments = first[src->first_segment + src->num_segments] - cv->first_segment;
    ch_curve_update_box(out, c);
  }
  out->num_subpaths = in->num_subpaths;
  for (int i = 0; i < in->num_subpaths; i++) {
    const ch_subpath *sp = &in->subpaths[i];
    out->subpaths[i] = *sp;
    out->subpaths[i].first_segment = first[sp->first_segment];
    out->subpaths[i].num_segments = first[sp->first_segment + sp->num_segments] - first[sp->first_segment];
  }
  memcpy(out->viewbox, in->viewbox, sizeof out->viewbox);
  if (stats) {
    stats->registered_pieces = np;
    stats->seconds = ch_progress_seconds() - t0;
  }

done:
  if (chunks)
    for (int c = 0; c < nchunks; c++) free(chunks[c].pieces);
  free(chunks);
  free(first);
  if (st) ch_curves_free(out);
  return st;
}
