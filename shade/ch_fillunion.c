/* ch_fillunion: the union of painted fills, by boundary evaluation.
 *
 * The classic way polygon Booleans are evaluated (Greiner and Hormann
 * 1998; Martinez, Rueda and Feito 2009), here on the quadratic Beziers
 * themselves so that no curve is flattened (docs/spec.md §3 measures to
 * the exact curves):
 * 1. every fill segment is split where fill segments cross (ch_bezier's
 *    crossings; a corner on another's edge is a crossing at an end);
 * 2. whether each side of a piece is painted can change only at those
 *    points, so each stretch of outline between two of them is tested once,
 *    a winding number just left and just right of its longest piece, under
 *    each fill's own rule;
 * 3. a piece with one side painted is kept, turned so that side is its
 *    left; one with both or neither is dropped (an edge two tiles share,
 *    a fill inside another); a piece drawn twice is kept once;
 * 4. the kept pieces are chained into loops: at a point where several
 *    leave, the loop takes the first clockwise from where it came in, so
 *    that regions touching at a point stay separate loops.
 * Fills that none of this changes keep their own segments and bytes. */
#include "ch_fillunion.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ch_alloc.h"
#include "ch_bezier.h"
#include "ch_grid.h"
#include "ch_math.h"

/* Points closer than this (UV) are one vertex; parameters this close to a
 * segment's end are that end (as ch_bezier_crossings and ch_stepsing). */
#define SAME_POINT 1e-9
#define AT_END 1e-9
/* Crossings this close (UV) to a segment's end are moved onto it. */
#define SNAP 1e-8
/* The side tests read at most this many segments (a traced drawing of one
 * path of 36k segments crossing itself at thousands of places would
 * otherwise read its whole path for each stretch). */
#define MAX_READS 100000000L

typedef struct hit {
  int slot; /* the fill segment (index into fseg) */
  double t;
  int point;
} hit;

typedef struct piece {
  double p[3][2];
  int is_line;
  int from, to; /* vertices */
  int curve;    /* the curve it comes from */
  int run;      /* its stretch between crossings */
  int split;    /* cut from inside its segment */
  int slot;     /* its fill segment */
} piece;

typedef struct work {
  const ch_curve_set *set;
  const unsigned char *rule, *flipped;
  int nseg;
  int *fseg;       /* fill segments, in the set's order */
  double (*pt)[2]; /* points: segment starts (slot i), then crossings */
  int npt, cap_pt;
  int *vertex;     /* point -> vertex */
  double (*vx)[2]; /* vertex -> its place */
  int nv;
  unsigned char *crossing; /* per vertex: a crossing is there */
  hit *hits;
  int nhit, cap_hit;
  piece *pc;
  int npc, cap_pc;
  ch_grid curve_grid;
  double (*curve_box)[4];
  double (*sub_box)[4]; /* per subpath of a fill: outside it its winding is 0 */
  long reads;
} work;

static int add_point(work *w, const double p[2]) {
  if (ch_alloc_grow((void **)&w->pt, &w->cap_pt, w->npt + 1, sizeof *w->pt, 64)) return -1;
  w->pt[w->npt][0] = p[0], w->pt[w->npt][1] = p[1];
  return w->npt++;
}

static int add_hit(work *w, int slot, double t, int point) {
  if (ch_alloc_grow((void **)&w->hits, &w->cap_hit, w->nhit + 1, sizeof *w->hits, 64)) return 0;
  w->hits[w->nhit++] = (hit){slot, t, point};
  return 1;
}

/* ---- 1. crossings ---- */

/* Where lines a and b lie on one another (an edge two tiles share, drawn
 * in different pieces), the ends of each inside the other, as crossings
 * (ch_bezier_crossings finds none where they are parallel). */
static int overlap_ends(const ch_segment *a, const ch_segment *b, double *s, double *t) {
  double da[2] = {a->p[2][0] - a->p[0][0], a->p[2][1] - a->p[0][1]};
  double db[2] = {b->p[2][0] - b->p[0][0], b->p[2][1] - b->p[0][1]};
  double la2 = da[0] * da[0] + da[1] * da[1], lb2 = db[0] * db[0] + db[1] * db[1];
  if (!(la2 > 0.0 && lb2 > 0.0)) return 0;
  /* b's ends within SAME_POINT of a's line */
  for (int k = 0; k < 3; k += 2) {
    double e[2] = {b->p[k][0] - a->p[0][0], b->p[k][1] - a->p[0][1]};
    if (fabs(da[0] * e[1] - da[1] * e[0]) > SAME_POINT * sqrt(la2)) return 0;
  }
  int n = 0;
  for (int k = 0; k < 3; k += 2) {
    double e[2] = {b->p[k][0] - a->p[0][0], b->p[k][1] - a->p[0][1]};
    double u = (e[0] * da[0] + e[1] * da[1]) / la2;
    if (u > AT_END && u < 1.0 - AT_END) s[n] = u, t[n] = k == 0 ? 0.0 : 1.0, n++;
    double f[2] = {a->p[k][0] - b->p[0][0], a->p[k][1] - b->p[0][1]};
    double v = (f[0] * db[0] + f[1] * db[1]) / lb2;
    if (v > AT_END && v < 1.0 - AT_END) s[n] = k == 0 ? 0.0 : 1.0, t[n] = v, n++;
  }
  return n;
}

/* The crossings of fill segments in slots i and j, as points and hits. */
static int cross_pair(work *w, int i, int j) {
  const ch_segment *sa = &w->set->segments[w->fseg[i]], *sb = &w->set->segments[w->fseg[j]];
  double hs[CH_BEZIER_MAX_CROSSINGS + 4], ht[CH_BEZIER_MAX_CROSSINGS + 4];
  int n = 0;
  if (sa->is_line && sb->is_line) {
    /* two lines: where they cross in closed form (the halving search takes
     * 14 levels to get there), and where they lie on one another */
    double da[2] = {sa->p[2][0] - sa->p[0][0], sa->p[2][1] - sa->p[0][1]};
    double db[2] = {sb->p[2][0] - sb->p[0][0], sb->p[2][1] - sb->p[0][1]};
    double e[2] = {sb->p[0][0] - sa->p[0][0], sb->p[0][1] - sa->p[0][1]};
    double det = da[0] * db[1] - da[1] * db[0];
    if (fabs(det) > 1e-12 * hypot(da[0], da[1]) * hypot(db[0], db[1])) {
      double s = (e[0] * db[1] - e[1] * db[0]) / det, t = (e[0] * da[1] - e[1] * da[0]) / det;
      if (s >= -AT_END && s <= 1.0 + AT_END && t >= -AT_END && t <= 1.0 + AT_END)
        hs[n] = s < 0.0 ? 0.0 : s > 1.0 ? 1.0 : s, ht[n] = t < 0.0 ? 0.0 : t > 1.0 ? 1.0 : t, n++;
    }
    n += overlap_ends(sa, sb, hs + n, ht + n);
  } else {
    n = ch_bezier_crossings(sa->p, sb->p, hs, ht);
  }
  for (int k = 0; k < n; k++) {
    double s = hs[k], t = ht[k];
    /* neighbours meet at their joint: not a crossing */
    if (ch_segments_at_joint(w->set, w->fseg[i], w->fseg[j], s, t)) continue;
    /* a crossing within SNAP of an end is at that end: where a curve leaves
     * a corner along the edge it meets (a rounded corner on a rectangle's
     * edge), Newton's steps stop 1e-8 from the corner, and the two pieces
     * between would each be kept */
    double pa[2], pb[2];
    ch_segment_point(sa, s, pa);
    ch_segment_point(sb, t, pb);
    for (int e = 0; e < 3; e += 2) {
      if (hypot(pa[0] - sa->p[e][0], pa[1] - sa->p[e][1]) < SNAP) s = e ? 1.0 : 0.0;
      if (hypot(pb[0] - sb->p[e][0], pb[1] - sb->p[e][1]) < SNAP) t = e ? 1.0 : 0.0;
    }
    /* an end on the other is that end exactly, so pieces meet there */
    double p[2];
    if (s <= AT_END || s >= 1.0 - AT_END)
      memcpy(p, sa->p[s <= AT_END ? 0 : 2], sizeof p);
    else if (t <= AT_END || t >= 1.0 - AT_END)
      memcpy(p, sb->p[t <= AT_END ? 0 : 2], sizeof p);
    else
      ch_segment_point(sa, s, p);
    int pi = add_point(w, p);
    if (pi < 0 || !add_hit(w, i, s, pi) || !add_hit(w, j, t, pi)) return 0;
  }
  return 1;
}

/* Every pair of fill segments whose boxes meet, each pair once: in the
 * grid cell holding the lower corner of the two boxes' overlap. */
static int find_crossings(work *w, ch_error *err) {
  double(*box)[4] = malloc((size_t)w->nseg * sizeof *box);
  if (!box) return 0;
  const double pad = 1e-12;
  for (int i = 0; i < w->nseg; i++) {
    ch_bezier_box(w->set->segments[w->fseg[i]].p, box[i]);
    box[i][0] -= pad, box[i][1] -= pad, box[i][2] += pad, box[i][3] += pad;
  }
  ch_grid g = {0};
  if (ch_grid_build(&g, w->nseg, (const double(*)[4])box, err) != CH_OK) {
    free(box);
    return 0;
  }
  int ok = 1;
  for (int i = 0; ok && i < w->nseg; i++) {
    int r[4];
    ch_grid_cell_range(&g, box[i], r);
    for (int y = r[1]; ok && y <= r[3]; y++)
      for (int x = r[0]; ok && x <= r[2]; x++) {
        int cell = y * g.nx + x;
        for (int k = g.cell_start[cell]; ok && k < g.cell_start[cell + 1]; k++) {
          int j = g.items[k];
          const double *a = box[i], *b = box[j];
          if (j <= i || a[0] > b[2] || b[0] > a[2] || a[1] > b[3] || b[1] > a[3]) continue;
          double lo[4] = {fmax(a[0], b[0]), fmax(a[1], b[1]), fmax(a[0], b[0]), fmax(a[1], b[1])};
          int rc[4];
          ch_grid_cell_range(&g, lo, rc);
          if (rc[0] != x || rc[1] != y) continue;
          ok = cross_pair(w, i, j);
        }
      }
  }
  ch_grid_free(&g);
  free(box);
  return ok;
}

/* ---- vertices ---- */

typedef struct by_u {
  double u;
  int i;
} by_u;

static int cmp_by_u(const void *x, const void *y) {
  const by_u *a = x, *b = y;
  if (a->u != b->u) return a->u < b->u ? -1 : 1;
  return (a->i > b->i) - (a->i < b->i);
}

/* Points within SAME_POINT of a first one (in order of u) are its vertex. */
static int make_vertices(work *w) {
  by_u *order = malloc((size_t)w->npt * sizeof *order);
  w->vertex = malloc((size_t)w->npt * sizeof *w->vertex);
  w->vx = malloc((size_t)w->npt * sizeof *w->vx);
  w->crossing = calloc((size_t)w->npt, 1);
  if (!order || !w->vertex || !w->vx || !w->crossing) {
    free(order);
    return 0;
  }
  for (int i = 0; i < w->npt; i++) order[i] = (by_u){w->pt[i][0], i}, w->vertex[i] = -1;
  qsort(order, (size_t)w->npt, sizeof *order, cmp_by_u);
  for (int a = 0; a < w->npt; a++) {
    int i = order[a].i;
    if (w->vertex[i] >= 0) continue;
    int v = w->nv++;
    w->vx[v][0] = w->pt[i][0], w->vx[v][1] = w->pt[i][1];
    w->vertex[i] = v;
    for (int b = a + 1; b < w->npt && order[b].u - order[a].u <= SAME_POINT; b++) {
      int j = order[b].i;
      if (w->vertex[j] < 0 && fabs(w->pt[j][1] - w->pt[i][1]) <= SAME_POINT) w->vertex[j] = v;
    }
  }
  free(order);
  for (int k = 0; k < w->nhit; k++) w->crossing[w->vertex[w->hits[k].point]] = 1;
  return 1;
}

/* ---- 2. pieces ---- */

static int cmp_hit(const void *x, const void *y) {
  const hit *a = x, *b = y;
  if (a->slot != b->slot) return a->slot < b->slot ? -1 : 1;
  if (a->t != b->t) return a->t < b->t ? -1 : 1;
  return (a->point > b->point) - (a->point < b->point);
}

/* The quadratic's blossom b(u, v): the control point of its piece [u, v]. */
static void blossom(const double p[3][2], double u, double v, double out[2]) {
  double a = (1.0 - u) * (1.0 - v), b = (1.0 - u) * v + u * (1.0 - v), c = u * v;
  for (int k = 0; k < 2; k++) out[k] = a * p[0][k] + b * p[1][k] + c * p[2][k];
}

static int add_piece(work *w, int slot, double t0, double t1, int from, int to, int split) {
  if (ch_alloc_grow((void **)&w->pc, &w->cap_pc, w->npc + 1, sizeof *w->pc, 64)) return 0;
  const ch_segment *s = &w->set->segments[w->fseg[slot]];
  piece *q = &w->pc[w->npc++];
  memset(q, 0, sizeof *q);
  q->is_line = s->is_line;
  q->from = from, q->to = to, q->curve = s->curve, q->split = split, q->run = -1, q->slot = slot;
  memcpy(q->p[0], w->vx[from], sizeof q->p[0]);
  memcpy(q->p[2], w->vx[to], sizeof q->p[2]);
  if (s->is_line) {
    q->p[1][0] = 0.5 * (q->p[0][0] + q->p[2][0]);
    q->p[1][1] = 0.5 * (q->p[0][1] + q->p[2][1]);
  } else {
    blossom(s->p, t0, t1, q->p[1]);
  }
  return 1;
}

/* Each fill segment cut at its crossings inside it; slot i's start is
 * point i, its end the start of the next segment (fills are closed). */
static int make_pieces(work *w, const int *slot_of) {
  if (w->nhit > 1) qsort(w->hits, (size_t)w->nhit, sizeof *w->hits, cmp_hit);
  int h = 0;
  for (int i = 0; i < w->nseg; i++) {
    const ch_segment *s = &w->set->segments[w->fseg[i]];
    int at = w->vertex[i], end = w->vertex[slot_of[s->next]];
    double t_at = 0.0;
    int split = 0;
    for (; h < w->nhit && w->hits[h].slot == i; h++) {
      const hit *x = &w->hits[h];
      int v = w->vertex[x->point];
      if (x->t <= AT_END || x->t >= 1.0 - AT_END || v == at || v == end) continue;
      if (!add_piece(w, i, t_at, x->t, at, v, 1)) return 0;
      at = v, t_at = x->t, split = 1;
    }
    if (at != end && !add_piece(w, i, t_at, 1.0, at, end, split)) return 0;
  }
  return 1;
}

/* ---- 3. which sides are painted ---- */

/* Whether q is painted by curve c, under its fill rule, the winding of each
 * subpath counted in its drawn direction. */
static int painted_by(work *w, int c, const double q[2]) {
  const ch_curve *cv = &w->set->curves[c];
  int wn = 0;
  for (int k = cv->first_subpath; k < cv->first_subpath + cv->num_subpaths; k++) {
    const ch_subpath *sp = &w->set->subpaths[k];
    const double *b = w->sub_box[k];
    if (q[0] < b[0] || q[0] > b[2] || q[1] < b[1] || q[1] > b[3]) continue;
    int wk = ch_segments_winding(w->set, sp->first_segment, sp->num_segments, q);
    wn += w->flipped && w->flipped[k] ? -wk : wk;
    w->reads += sp->num_segments;
  }
  return w->rule[c] == CH_FILL_EVENODD ? (wn & 1) != 0 : wn != 0;
}

static int painted(work *w, const double q[2]) {
  const int *items;
  int n = ch_grid_query(&w->curve_grid, q[0], q[1], &items);
  for (int k = 0; k < n; k++) {
    const double *b = w->curve_box[items[k]];
    if (q[0] < b[0] || q[0] > b[2] || q[1] < b[1] || q[1] > b[3]) continue;
    if (painted_by(w, items[k], q)) return 1;
  }
  return 0;
}

/* ---- 4. loops ---- */

static double start_angle(const piece *q) {
  double d[2] = {q->p[1][0] - q->p[0][0], q->p[1][1] - q->p[0][1]};
  if (d[0] == 0.0 && d[1] == 0.0) d[0] = q->p[2][0] - q->p[0][0], d[1] = q->p[2][1] - q->p[0][1];
  return atan2(d[1], d[0]);
}

/* The direction back along q from its end. */
static double end_back_angle(const piece *q) {
  double d[2] = {q->p[1][0] - q->p[2][0], q->p[1][1] - q->p[2][1]};
  if (d[0] == 0.0 && d[1] == 0.0) d[0] = q->p[0][0] - q->p[2][0], d[1] = q->p[0][1] - q->p[2][1];
  return atan2(d[1], d[0]);
}

static void reverse_piece(piece *q) {
  double t[2] = {q->p[0][0], q->p[0][1]};
  q->p[0][0] = q->p[2][0], q->p[0][1] = q->p[2][1];
  q->p[2][0] = t[0], q->p[2][1] = t[1];
  int v = q->from;
  q->from = q->to, q->to = v;
}

/* A kept piece's key: equal pieces sort next to each other. */
typedef struct piece_key {
  int from, to;
  double c[2]; /* control point */
  int i;
} piece_key;

static int cmp_piece_key(const void *x, const void *y) {
  const piece_key *a = x, *b = y;
  if (a->from != b->from) return a->from < b->from ? -1 : 1;
  if (a->to != b->to) return a->to < b->to ? -1 : 1;
  if (a->c[0] != b->c[0]) return a->c[0] < b->c[0] ? -1 : 1;
  if (a->c[1] != b->c[1]) return a->c[1] < b->c[1] ? -1 : 1;
  return (a->i > b->i) - (a->i < b->i);
}

typedef struct loops {
  int *piece; /* the pieces of every loop, loop after loop */
  int *start; /* loop k: piece[start[k]] .. piece[start[k + 1] - 1] */
  int n, len;
} loops;

/* Chains the kept pieces (kept[0..nk-1], indices into w->pc) into loops.
 * Returns 1, 0 out of memory, -1 a vertex left open (report says where). */
static int chain(work *w, const int *kept, int nk, loops *out, ch_fillunion_report *report) {
  int *count = calloc((size_t)w->nv + 1, sizeof *count), *outs = malloc((size_t)(nk ? nk : 1) * sizeof *outs);
  unsigned char *used = calloc((size_t)(nk ? nk : 1), 1);
  double *phi = malloc((size_t)(nk ? nk : 1) * sizeof *phi), *theta = malloc((size_t)(nk ? nk : 1) * sizeof *theta);
  out->piece = malloc((size_t)(nk ? nk : 1) * sizeof *out->piece);
  out->start = malloc((size_t)(nk + 1) * sizeof *out->start);
  int ok = count && outs && used && phi && theta && out->piece && out->start;
  if (ok) {
    for (int k = 0; k < nk; k++) count[w->pc[kept[k]].from + 1]++;
    for (int v = 0; v < w->nv; v++) count[v + 1] += count[v];
    int *fill = malloc((size_t)w->nv * sizeof *fill);
    ok = fill != NULL;
    if (ok) {
      memcpy(fill, count, (size_t)w->nv * sizeof *fill);
      for (int k = 0; k < nk; k++) outs[fill[w->pc[kept[k]].from]++] = k;
      free(fill);
    }
    for (int k = 0; ok && k < nk; k++) {
      phi[k] = start_angle(&w->pc[kept[k]]);
      theta[k] = end_back_angle(&w->pc[kept[k]]);
    }
  }
  for (int s0 = 0; ok > 0 && s0 < nk; s0++) {
    if (used[s0]) continue;
    out->start[out->n++] = out->len;
    used[s0] = 1;
    out->piece[out->len++] = kept[s0];
    for (int cur = s0;;) {
      int v = w->pc[kept[cur]].to, best = -1;
      double best_turn = 0.0;
      for (int o = count[v]; o < count[v + 1]; o++) {
        int k = outs[o];
        if (used[k] && k != s0) continue;
        /* the clockwise turn from the way in to the way out, in (0, 2 pi] */
        double turn = theta[cur] - phi[k];
        while (turn <= 0.0) turn += 2.0 * CH_PI;
        while (turn > 2.0 * CH_PI) turn -= 2.0 * CH_PI;
        if (best < 0 || turn < best_turn) best = k, best_turn = turn;
      }
      if (best < 0) {
        report->failed = 1;
        report->at[0] = w->vx[v][0], report->at[1] = w->vx[v][1];
        report->curve_a = w->pc[kept[cur]].curve;
        ok = -1;
        break;
      }
      if (best == s0) break;
      used[best] = 1;
      out->piece[out->len++] = kept[best];
      cur = best;
    }
  }
  if (ok > 0) out->start[out->n] = out->len;
  free(count);
  free(outs);
  free(used);
  free(phi);
  free(theta);
  return ok;
}

/* Whether loop k is a sliver no resolution shows: mean width 2 |area| /
 * perimeter under 1e-7 UV. A path that runs back over itself (GNOME's
 * screensaver icon closes a circle with a line 0.001 units long against
 * the way it came) leaves one between its two passes, and h_step's
 * singular terms at its corners, arms 2e-3 rad apart, reached 5.9 for a
 * fill height of 0.01. */
static int is_sliver(const work *w, const loops *lp, int k) {
  double area = 0.0, perimeter = 0.0;
  for (int i = lp->start[k]; i < lp->start[k + 1]; i++) {
    const double(*p)[2] = w->pc[lp->piece[i]].p;
    /* Green's theorem on a quadratic: (p0 x p1 + p1 x p2) / 3 + p0 x p2 / 6 */
    double c01 = p[0][0] * p[1][1] - p[1][0] * p[0][1], c12 = p[1][0] * p[2][1] - p[2][0] * p[1][1];
    double c02 = p[0][0] * p[2][1] - p[2][0] * p[0][1];
    area += (c01 + c12) / 3.0 + c02 / 6.0;
    perimeter += hypot(p[2][0] - p[0][0], p[2][1] - p[0][1]);
  }
  return 2.0 * fabs(area) < 1e-7 * perimeter;
}

/* ---- the new set ---- */

/* The set with changed curves' subpaths replaced by their loops (owner[k]:
 * the curve loop k goes to) and changed curves without loops removed. */
static int rebuild(work *w, ch_curve_set *set, const unsigned char *changed, const loops *lp, const int *owner,
                   ch_fillunion_report *report) {
  const ch_curve_set *old = w->set;
  int nseg = 0, nsub = 0;
  for (int c = 0; c < old->num_curves; c++)
    if (!changed[c]) nseg += old->curves[c].num_segments, nsub += old->curves[c].num_subpaths;
  nseg += lp->len, nsub += lp->n;
  ch_curve *curves = malloc((size_t)old->num_curves * sizeof *curves);
  ch_segment *segs = malloc((size_t)(nseg ? nseg : 1) * sizeof *segs);
  ch_subpath *subs = malloc((size_t)(nsub ? nsub : 1) * sizeof *subs);
  int *by_owner = malloc((size_t)(lp->n ? lp->n : 1) * sizeof *by_owner);
  int *first_of = calloc((size_t)old->num_curves + 1, sizeof *first_of);
  if (!curves || !segs || !subs || !by_owner || !first_of) {
    free(curves), free(segs), free(subs), free(by_owner), free(first_of);
    return 0;
  }
  /* loops grouped by owner, in their order */
  for (int k = 0; k < lp->n; k++)
    if (owner[k] >= 0) first_of[owner[k] + 1]++;
  for (int c = 0; c < old->num_curves; c++) first_of[c + 1] += first_of[c];
  {
    int *next = malloc((size_t)old->num_curves * sizeof *next);
    if (!next) {
      free(curves), free(segs), free(subs), free(by_owner), free(first_of);
      return 0;
    }
    memcpy(next, first_of, (size_t)old->num_curves * sizeof *next);
    for (int k = 0; k < lp->n; k++)
      if (owner[k] >= 0) by_owner[next[owner[k]]++] = k;
    free(next);
  }
  int nc = 0, ns = 0, nb = 0;
  for (int c = 0; c < old->num_curves; c++) {
    const ch_curve *oc = &old->curves[c];
    ch_curve *cv = &curves[nc];
    *cv = *oc;
    cv->first_segment = ns, cv->first_subpath = nb;
    if (!changed[c]) {
      int shift = ns - oc->first_segment;
      for (int i = 0; i < oc->num_segments; i++) {
        ch_segment s = old->segments[oc->first_segment + i];
        s.curve = nc;
        if (s.prev >= 0) s.prev += shift;
        if (s.next >= 0) s.next += shift;
        segs[ns++] = s;
      }
      for (int k = 0; k < oc->num_subpaths; k++) {
        ch_subpath sp = old->subpaths[oc->first_subpath + k];
        sp.first_segment += shift;
        subs[nb++] = sp;
      }
    } else {
      cv->num_segments = cv->num_subpaths = 0;
      for (int o = first_of[c]; o < first_of[c + 1]; o++) {
        int k = by_owner[o], first = ns, n = lp->start[k + 1] - lp->start[k];
        for (int i = 0; i < n; i++) {
          const piece *q = &w->pc[lp->piece[lp->start[k] + i]];
          ch_segment *s = &segs[ns++];
          memcpy(s->p, q->p, sizeof s->p);
          s->is_line = q->is_line;
          s->curve = nc;
          s->prev = first + (i + n - 1) % n;
          s->next = first + (i + 1) % n;
        }
        subs[nb++] = (ch_subpath){.first_segment = first, .num_segments = n, .closed = 1};
        cv->num_segments += n, cv->num_subpaths++;
      }
      if (cv->num_subpaths == 0) {
        report->dropped++;
        continue;
      }
    }
    nc++;
  }
  free(by_owner);
  free(first_of);
  free(set->curves), free(set->segments), free(set->subpaths);
  set->curves = curves, set->num_curves = nc;
  set->segments = segs, set->num_segments = ns;
  set->subpaths = subs, set->num_subpaths = nb;
  for (int c = 0; c < nc; c++) ch_curve_update_box(set, c);
  return 1;
}

ch_status ch_fillunion_apply(ch_curve_set *set, const unsigned char *rule, const unsigned char *flipped,
                             ch_fillunion_report *report, ch_error *err) {
  memset(report, 0, sizeof *report);
  report->curve_a = report->curve_b = -1;
  work w = {.set = set, .rule = rule, .flipped = flipped};
  int nfill = 0;
  for (int c = 0; c < set->num_curves; c++)
    if (rule[c] != CH_FILL_NONE) nfill++, w.nseg += set->curves[c].num_segments;
  if (nfill == 0 || w.nseg == 0) return CH_OK;
  ch_status st = CH_OK;
  int *slot_of = malloc((size_t)set->num_segments * sizeof *slot_of);
  unsigned char *changed = calloc((size_t)set->num_curves, 1);
  int *run_keep = NULL, *run_best = NULL, *kept = NULL, *owner = NULL;
  loops lp = {0};
  w.fseg = malloc((size_t)w.nseg * sizeof *w.fseg);
  w.curve_box = malloc((size_t)set->num_curves * sizeof *w.curve_box);
  w.sub_box = malloc((size_t)(set->num_subpaths ? set->num_subpaths : 1) * sizeof *w.sub_box);
  int ok = slot_of && changed && w.fseg && w.curve_box && w.sub_box;
  for (int k = 0; ok && k < set->num_subpaths; k++) {
    const ch_subpath *sp = &set->subpaths[k];
    double *b = w.sub_box[k];
    b[0] = b[1] = INFINITY, b[2] = b[3] = -INFINITY;
    for (int i = sp->first_segment; i < sp->first_segment + sp->num_segments; i++) {
      double sb[4];
      ch_bezier_box(set->segments[i].p, sb);
      b[0] = fmin(b[0], sb[0]), b[1] = fmin(b[1], sb[1]), b[2] = fmax(b[2], sb[2]), b[3] = fmax(b[3], sb[3]);
    }
  }
  /* fill segments and their starts, the first points */
  for (int c = 0, n = 0; ok && c < set->num_curves; c++) {
    const ch_curve *cv = &set->curves[c];
    memcpy(w.curve_box[c], cv->bbox, sizeof w.curve_box[c]);
    if (rule[c] == CH_FILL_NONE) {
      w.curve_box[c][0] = 1.0, w.curve_box[c][2] = 0.0; /* empty: not in the grid */
      for (int i = cv->first_segment; i < cv->first_segment + cv->num_segments; i++) slot_of[i] = -1;
      continue;
    }
    for (int i = cv->first_segment; i < cv->first_segment + cv->num_segments; i++) {
      slot_of[i] = n;
      w.fseg[n++] = i;
      ok = ok && add_point(&w, set->segments[i].p[0]) >= 0;
    }
  }
  ok = ok && find_crossings(&w, err) && make_vertices(&w) && make_pieces(&w, slot_of);
  if (ok) ok = ch_grid_build(&w.curve_grid, set->num_curves, (const double(*)[4])w.curve_box, err) == CH_OK;
  /* stretches between crossings, each tested once: a subpath's pieces
   * (in order) start a new stretch at every crossing */
  int nrun = 0;
  if (ok) ok = (run_keep = malloc((size_t)(w.npc ? w.npc : 1) * sizeof *run_keep)) != NULL;
  for (int k = 0, p = 0; ok && k < set->num_subpaths; k++) {
    const ch_subpath *sp = &set->subpaths[k];
    int lo = slot_of[sp->first_segment];
    if (lo < 0) continue;
    int hi = lo + sp->num_segments, pa = p;
    while (p < w.npc && w.pc[p].slot < hi) p++;
    int n = p - pa, first = -1;
    for (int i = 0; i < n && first < 0; i++)
      if (w.crossing[w.pc[pa + i].from]) first = i;
    if (first < 0) first = 0;
    for (int i = 0; i < n; i++) {
      piece *q = &w.pc[pa + (first + i) % n];
      if (i == 0 || w.crossing[q->from]) nrun++;
      q->run = nrun - 1;
    }
  }
  if (ok) {
    /* the longest piece of each stretch */
    run_best = malloc((size_t)(nrun ? nrun : 1) * sizeof *run_best);
    double *best_len = malloc((size_t)(nrun ? nrun : 1) * sizeof *best_len);
    ok = run_best && best_len;
    for (int r = 0; ok && r < nrun; r++) run_best[r] = -1, best_len[r] = -1.0;
    for (int i = 0; ok && i < w.npc; i++) {
      const piece *q = &w.pc[i];
      double len = hypot(q->p[2][0] - q->p[0][0], q->p[2][1] - q->p[0][1]);
      if (len > best_len[q->run]) best_len[q->run] = len, run_best[q->run] = i;
    }
    free(best_len);
  }
  for (int r = 0; ok && r < nrun && !report->failed; r++) {
    const piece *q = &w.pc[run_best[r]];
    /* B(1/2) and B'(1/2) = p2 - p0 */
    double m[2] = {0.25 * (q->p[0][0] + q->p[2][0]) + 0.5 * q->p[1][0],
                   0.25 * (q->p[0][1] + q->p[2][1]) + 0.5 * q->p[1][1]};
    double d[2] = {q->p[2][0] - q->p[0][0], q->p[2][1] - q->p[0][1]};
    double len = hypot(d[0], d[1]), eps = 1e-7 * fmax(len, 1e-6);
    double ql[2] = {m[0] - d[1] / len * eps, m[1] + d[0] / len * eps};
    double qr[2] = {m[0] + d[1] / len * eps, m[1] - d[0] / len * eps};
    int left = painted(&w, ql), right = painted(&w, qr);
    run_keep[r] = left && !right ? 1 : !left && right ? -1 : 0;
    if (w.reads > MAX_READS) {
      report->failed = 2;
      report->at[0] = m[0], report->at[1] = m[1];
      report->curve_a = q->curve;
    }
  }
  /* the pieces kept, turned so the painted side is their left */
  int nk = 0;
  unsigned char *dup = NULL;
  if (ok && !report->failed) {
    kept = malloc((size_t)(w.npc ? w.npc : 1) * sizeof *kept);
    dup = calloc((size_t)(w.npc ? w.npc : 1), 1);
    ok = kept && dup;
  }
  for (int i = 0; ok && !report->failed && i < w.npc; i++) {
    piece *q = &w.pc[i];
    if (run_keep[q->run] == 0) continue;
    if (run_keep[q->run] < 0) reverse_piece(q);
    kept[nk++] = i;
  }
  /* a piece drawn twice (a shape drawn twice, an edge two fills share the
   * same way round) is kept once; both curves are then rebuilt */
  if (ok && nk > 1) {
    piece_key *key = malloc((size_t)nk * sizeof *key);
    ok = key != NULL;
    for (int i = 0; ok && i < nk; i++) {
      const piece *q = &w.pc[kept[i]];
      key[i] = (piece_key){q->from, q->to, {q->p[1][0], q->p[1][1]}, kept[i]};
    }
    if (ok) qsort(key, (size_t)nk, sizeof *key, cmp_piece_key);
    for (int i = 1, first = 0; ok && i < nk; i++) {
      const piece *a = &w.pc[key[i].i], *b = &w.pc[key[first].i];
      if (a->from == b->from && a->to == b->to && fabs(a->p[1][0] - b->p[1][0]) <= SNAP &&
          fabs(a->p[1][1] - b->p[1][1]) <= SNAP) {
        dup[key[i].i] = 1;
        changed[a->curve] = changed[b->curve] = 1;
      } else {
        first = i;
      }
    }
    free(key);
  }
  /* the curves that change: cut, with a stretch dropped or turned, or
   * sharing a piece */
  for (int i = 0; ok && !report->failed && i < w.npc; i++) {
    const piece *q = &w.pc[i];
    if (q->split || run_keep[q->run] != 1) changed[q->curve] = 1;
  }
  int nchanged = 0;
  for (int c = 0; c < set->num_curves; c++) nchanged += changed[c];
  if (ok && !report->failed && nchanged > 0) {
    int m = 0;
    for (int i = 0; i < nk; i++)
      if (changed[w.pc[kept[i]].curve] && !dup[kept[i]]) kept[m++] = kept[i];
    nk = m;
    int chained = ok ? chain(&w, kept, nk, &lp, report) : 0;
    ok = chained != 0;
    if (chained > 0) {
      ok = (owner = malloc((size_t)(lp.n ? lp.n : 1) * sizeof *owner)) != NULL;
      for (int k = 0; ok && k < lp.n; k++) {
        owner[k] = set->num_curves;
        for (int i = lp.start[k]; i < lp.start[k + 1]; i++)
          if (w.pc[lp.piece[i]].curve < owner[k]) owner[k] = w.pc[lp.piece[i]].curve;
        if (is_sliver(&w, &lp, k)) owner[k] = -1;
      }
      report->united = nchanged;
      ok = ok && rebuild(&w, set, changed, &lp, owner, report);
    }
  }
  if (!ok && !st) st = ch_error_set(err, CH_ERR_NOMEM, "out of memory uniting the painted fills");
  free(slot_of);
  free(changed);
  free(run_keep);
  free(run_best);
  free(kept);
  free(dup);
  free(owner);
  free(lp.piece);
  free(lp.start);
  free(w.fseg);
  free(w.curve_box);
  free(w.sub_box);
  free(w.pt);
  free(w.vertex);
  free(w.vx);
  free(w.crossing);
  free(w.hits);
  free(w.pc);
  ch_grid_free(&w.curve_grid);
  return st;
}
