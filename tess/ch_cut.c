/* Cutting the refined mesh along the piece boundaries, and the output
 * (see ch_cut_internal.h). */
#include "ch_cut_internal.h"

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
#include "ch_sort.h"
#include "ch_thin.h"
#include "ch_warp.h"

int ch_cut_out_vertex(ch_cut_out *o, int face, const double st[2], const double uv[2], double h) {
  if (o->count_only) return o->npos++;
  int i = o->npos - o->first_pos;
  if (i + 1 > o->cap_pos) {
    int cap = o->cap_pos ? 2 * o->cap_pos : 4096;
    int *f = realloc(o->face, (size_t)cap * sizeof *f);
    if (f) o->face = f;
    double *s = realloc(o->st, (size_t)cap * 2 * sizeof *s);
    if (s) o->st = s;
    double *hh = realloc(o->h, (size_t)cap * sizeof *hh);
    if (hh) o->h = hh;
    double *u = o->shared_uv ? realloc(o->vertex_uv, (size_t)cap * 2 * sizeof *u) : NULL;
    if (u) o->vertex_uv = u;
    if (!f || !s || !hh || (o->shared_uv && !u)) return -1;
    o->cap_pos = cap;
  }
  o->face[i] = face;
  o->st[2 * (size_t)i] = st[0];
  o->st[2 * (size_t)i + 1] = st[1];
  o->h[i] = h;
  if (o->shared_uv) memcpy(&o->vertex_uv[2 * (size_t)i], uv, 2 * sizeof *uv);
  return o->npos++;
}

/* The UV vertex v of part o has (ch_cut_out.shared_uv). */
static const double *part_vertex_uv(const ch_cut_out *o, int v) {
  return v < o->first_pos ? &o->shared_uv[2 * (size_t)v] : &o->vertex_uv[2 * (size_t)(v - o->first_pos)];
}

/* Lists corner c of part o with UV uv where that is not its vertex's. */
static int part_corner_uv(ch_cut_out *o, int c, int v, const double *uv) {
  const double *vu = part_vertex_uv(o, v);
  if (vu[0] == uv[0] && vu[1] == uv[1]) return 0;
  if (ch_alloc_grow((void **)&o->other_uv, &o->cap_other, o->nother + 1, sizeof *o->other_uv, 256)) return -1;
  ch_cut_corner_uv *x = &o->other_uv[o->nother++];
  x->corner = c;
  memcpy(x->uv, uv, sizeof x->uv);
  return 0;
}

int ch_cut_out_tri(ch_cut_out *o, int a, int b, int c, const double *ua, const double *ub, const double *uc,
                   uint64_t group) {
  if (a == b || b == c || c == a) return 0; /* collapsed: a wall of zero height */
  if (o->count_only) {
    o->ntri++;
    return 0;
  }
  if (o->ntri + 1 > o->cap_tri) {
    int cap = o->cap_tri ? 2 * o->cap_tri : 4096;
    int *t = realloc(o->tri, (size_t)cap * 3 * sizeof *t);
    if (t) o->tri = t;
    uint64_t *g = realloc(o->group, (size_t)cap * sizeof *g);
    if (g) o->group = g;
    if (!t || !g) return -1;
    o->cap_tri = cap;
  }
  int *t = &o->tri[3 * (size_t)o->ntri];
  t[0] = a;
  t[1] = b;
  t[2] = c;
  int c0 = 3 * o->ntri;
  if (part_corner_uv(o, c0, a, ua) || part_corner_uv(o, c0 + 1, b, ub) || part_corner_uv(o, c0 + 2, c, uc)) return -1;
  o->group[o->ntri++] = group;
  return 0;
}

void ch_cut_out_move_vertex(ch_cut_out *o, int to, int from) {
  if (to == from) return;
  o->face[to] = o->face[from];
  memcpy(&o->st[2 * (size_t)to], &o->st[2 * (size_t)from], 2 * sizeof *o->st);
  o->h[to] = o->h[from];
  memcpy(&o->vertex_uv[2 * (size_t)to], &o->vertex_uv[2 * (size_t)from], 2 * sizeof *o->vertex_uv);
  if (o->pos) memcpy(&o->pos[3 * (size_t)to], &o->pos[3 * (size_t)from], 3 * sizeof *o->pos);
}

static int out_quad(ch_cut_out *o, const int v[4], const double *uv[4], uint64_t group) {
  return ch_cut_out_tri(o, v[0], v[1], v[2], uv[0], uv[1], uv[2], group) |
         ch_cut_out_tri(o, v[0], v[2], v[3], uv[0], uv[2], uv[3], group);
}

/* realloc to n elements of size, keeping *p where that fails. */
static void shrink_to(void **p, size_t n, size_t size) {
  if (!*p) return;
  void *q = realloc(*p, (n ? n : 1) * size);
  if (q) *p = q;
}

void ch_cut_out_shrink(ch_cut_out *o) {
  size_t nv = (size_t)(o->npos - o->first_pos), nt = (size_t)o->ntri;
  if ((size_t)o->cap_pos > nv) {
    shrink_to((void **)&o->face, nv, sizeof *o->face);
    shrink_to((void **)&o->st, 2 * nv, sizeof *o->st);
    shrink_to((void **)&o->h, nv, sizeof *o->h);
    shrink_to((void **)&o->vertex_uv, 2 * nv, sizeof *o->vertex_uv);
    o->cap_pos = (int)nv;
  }
  if ((size_t)o->cap_tri > nt) {
    shrink_to((void **)&o->tri, 3 * nt, sizeof *o->tri);
    shrink_to((void **)&o->group, nt, sizeof *o->group);
    shrink_to((void **)&o->corner_uv, 3 * nt, sizeof *o->corner_uv);
    o->cap_tri = (int)nt;
  }
  if (o->cap_other > o->nother) {
    shrink_to((void **)&o->other_uv, (size_t)o->nother, sizeof *o->other_uv);
    o->cap_other = o->nother;
  }
}

void ch_cut_out_free(ch_cut_out *o) {
  free(o->pos);
  free(o->face);
  free(o->st);
  free(o->h);
  free(o->tri);
  free(o->group);
  free(o->corner_uv);
  free(o->extra_uv);
  free(o->vertex_uv);
  free(o->other_uv);
  ch_cut_blocks_free(&o->blocks);
  memset(o, 0, sizeof *o);
}

void ch_cut_blocks_free(ch_cut_blocks *b) {
  free(b->tri);
  free(b->vert);
  free(b->next);
  free(b->ccw);
  memset(b, 0, sizeof *b);
}

/* ---- cutting a triangle ------------------------------------------------------ */
static int node_copy(const ch_refine_node *n, uint64_t piece) {
  if (n->corner >= 0) return n->corner;
  return piece == n->lnext ? n->copy_next : n->copy_prev;
}

/* Whether the UV triangle a, b, c has no area (three points on a line, up
 * to the rounding of points placed along an edge). */
static int flat_uv(const double *a, const double *b, const double *c) {
  double u[2] = {b[0] - a[0], b[1] - a[1]}, v[2] = {c[0] - a[0], c[1] - a[1]};
  return fabs(ch_cross2(u, v)) <= 1e-10 * fmax(ch_dot2(u, u), ch_dot2(v, v));
}

/* Emits the region bounded by nodes idx[0..len) (counter-clockwise, convex)
 * as a fan; its piece is the one after a node along the triangle's
 * boundary. The fan starts at the first node whose fan has no triangle
 * without area: where a line runs along an edge (a groove's rim on a UV
 * seam), three nodes of the region lie on that edge, and a fan from one
 * end of them made a sliver that joined the other chart's into edges of
 * three faces once copies of one point were welded. */
static int emit_region(const ch_refine_node *nodes, int m, const int *idx, int len, ch_cut_out *o) {
  uint64_t piece = nodes[idx[0]].lnext;
  for (int i = 0; i < len; i++)
    if ((idx[i] + 1) % m == idx[(i + 1) % len]) {
      piece = nodes[idx[i]].lnext;
      break;
    }
  /* A region whose nodes all lie on one edge has no area: where a line
   * pokes through an edge between two crossings of another (a groove's
   * line past the one before it, between two of the edge's samples), the
   * pieces between their chords lie on that edge, and the triangles on
   * both sides of it may cut them off. Fanned from different nodes, the
   * two copies doubled back on each other as two different pairs of
   * triangles, and the edge was in four faces. From the lowest vertex,
   * they are the same triangles facing opposite ways: pillows, which the
   * cleanup takes out (ch_mesh_remove_pillows); where only one side cuts
   * such a piece off, its triangles close the mesh along the edge. */
  int one_edge = len >= 3, apex = 0;
  for (int i = 0; i < len && one_edge; i++)
    one_edge = nodes[idx[i]].corner < 0 && nodes[idx[i]].edge == nodes[idx[0]].edge;
  for (int a = 1; a < len && one_edge; a++)
    if (node_copy(&nodes[idx[a]], piece) < node_copy(&nodes[idx[apex]], piece)) apex = a;
  for (int a = 0; a < len && len > 3 && !one_edge; a++) {
    int flat = 0;
    for (int i = 1; i + 1 < len && !flat; i++)
      flat = flat_uv(nodes[idx[a]].uv, nodes[idx[(a + i) % len]].uv, nodes[idx[(a + i + 1) % len]].uv);
    if (!flat) {
      apex = a;
      break;
    }
  }
  const ch_refine_node *n0 = &nodes[idx[apex]];
  int v0 = node_copy(n0, piece), bad = 0;
  for (int i = 1; i + 1 < len; i++) {
    const ch_refine_node *n1 = &nodes[idx[(apex + i) % len]], *n2 = &nodes[idx[(apex + i + 1) % len]];
    bad |= ch_cut_out_tri(o, v0, node_copy(n1, piece), node_copy(n2, piece), n0->uv, n1->uv, n2->uv, piece);
  }
  return bad;
}

/* How closely a junction's spokes, and the pieces' ends next to it, are
 * found: 2^-30 of the segment searched (as JUNCTION_BISECTIONS), which
 * moves the junction by about that share of its triangle (1e-12 UV at
 * 2M triangles), far below the output's digits. */
#define SPOKE_TOL 0x1p-30

typedef struct cut_context {
  const ch_surface *surface;
  const ch_label_ctx *lb;
  const ch_refine_tri *T;
  double tol;
  ch_cut_out *o;
  ch_embed_stats *stats;
} cut_context;

/* Where the pieces meet: each spoke's boundary is the line through its
 * crossing and a second boundary point, found by bisection between points
 * inside the two pieces it separates; the junction is the least-squares
 * meeting point of those lines (exact where they are straight), or the
 * centroid of the crossings when that fails or falls outside the triangle.
 * (s,t) follow from the triangle's corners. */
static void junction_point(const cut_context *cx, const ch_refine_node *nodes, const int *idx, int len, const int *pos,
                           int n, double juv[2], double jst[2]) {
  const ch_refine_tri *T = cx->T;
  double c[2] = {0, 0};
  for (int k = 0; k < n; k++)
    for (int i = 0; i < 2; i++) c[i] += nodes[idx[pos[k]]].uv[i] / n;
  double inner[MAX_NODES][2];
  uint64_t piece[MAX_NODES];
  for (int k = 0; k < n; k++) {
    const ch_refine_node *a = &nodes[idx[pos[k]]], *b = &nodes[idx[(pos[k] + 1) % len]];
    piece[k] = a->lnext;
    for (int i = 0; i < 2; i++) inner[k][i] = (c[i] + a->uv[i] + b->uv[i]) / 3.0;
  }
  double A[3] = {0, 0, 0}, r[2] = {0, 0}; /* normal equations: sum n n^T J = sum n n^T X */
  int lines = 0;
  for (int k = 0; k < n; k++) {
    int km = (k + n - 1) % n;
    if (ch_label_at(cx->lb, inner[km]) != piece[km] || ch_label_at(cx->lb, inner[k]) != piece[k]) continue;
    /* (the crossing search's fast paths: most spokes are a level set of
     * one curve, found in a few one-curve evaluations, not 46 labels) */
    double lo, hi, q[2];
    ch_refine_segment_change(cx->lb, inner[km], inner[k], piece[km], piece[k], SPOKE_TOL, &lo, &hi);
    ch_refine_lerp2(inner[km], inner[k], 0.5 * (lo + hi), q);
    const double *x = nodes[idx[pos[k]]].uv;
    double d[2] = {q[0] - x[0], q[1] - x[1]}, len_d = ch_dist2d(d[0], d[1]);
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
  for (int i = 0; i < 2; i++)
    jst[i] = T->st[0][i] + b1 * (T->st[1][i] - T->st[0][i]) + b2 * (T->st[2][i] - T->st[0][i]);
}

/* A region where n >= 3 pieces meet at one point: a junction vertex per
 * piece at the centroid of the n unpaired crossings (h read just inside the
 * piece, found by bisection from the centroid), a fan per piece from it,
 * walls along the spokes where h jumps and a cap where the walls meet. */
static int emit_junction(const cut_context *cx, const ch_refine_node *nodes, const int *idx, int len) {
  int pos[MAX_NODES], n = 0;
  for (int i = 0; i < len; i++)
    if (nodes[idx[i]].corner < 0 && nodes[idx[i]].pair < 0) pos[n++] = i;
  double jst[2], juv[2];
  junction_point(cx, nodes, idx, len, pos, n, juv, jst);
  ch_refine_locate_st(cx->surface, cx->T->face, juv, jst);
  /* The junction's copy for piece k: pieces on the two sides of a spoke
   * share it where the spoke's crossing has one copy (no wall there). */
  int j[MAX_NODES], group[MAX_NODES];
  double hj[MAX_NODES];
  uint64_t at_junction = ch_label_at(cx->lb, juv);
  for (int k = 0; k < n; k++) {
    const ch_refine_node *a = &nodes[idx[pos[k]]], *b = &nodes[idx[(pos[k] + 1) % len]];
    uint64_t piece = a->lnext;
    double target[2] = {(juv[0] + a->uv[0] + b->uv[0]) / 3.0, (juv[1] + a->uv[1] + b->uv[1]) / 3.0}, q[2];
    uint64_t at_target = at_junction == piece ? piece : ch_label_at(cx->lb, target);
    if (at_junction == piece) {
      /* the junction itself in the piece: a step off it towards the
       * piece (where bisection from it ended, 30 labels later, wherever
       * the piece holds the way there) */
      ch_refine_lerp2(juv, target, ldexp(1.0, -JUNCTION_BISECTIONS), q);
    } else if (at_target != piece) {
      /* the piece not where it was expected: bisection for any point of it */
      double lo = 0.0, hi = 1.0;
      for (int it = 0; it < JUNCTION_BISECTIONS; it++) {
        double mid = 0.5 * (lo + hi);
        ch_refine_lerp2(juv, target, mid, q);
        if (ch_label_at(cx->lb, q) == piece)
          hi = mid;
        else
          lo = mid;
      }
      ch_refine_lerp2(juv, target, hi, q);
    } else { /* from inside the piece to where it ends towards the junction */
      double lo, hi;
      ch_refine_segment_change(cx->lb, target, juv, piece, at_junction, SPOKE_TOL, &lo, &hi);
      ch_refine_lerp2(target, juv, lo, q);
    }
    hj[k] = ch_label_piece_height(cx->lb, piece, q, juv);
  }
  /* Groups: runs of pieces joined across wall-free spokes (spoke k lies
   * between pieces k-1 and k). */
  int start = -1;
  for (int k = 0; k < n; k++)
    if (nodes[idx[pos[k]]].copy_prev != nodes[idx[pos[k]]].copy_next) start = k;
  for (int s = 0, g = -1; s < n; s++) {
    int k = start < 0 ? s : (start + s) % n;
    const ch_refine_node *x = &nodes[idx[pos[k]]];
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
    if ((j[k] = ch_cut_out_vertex(cx->o, cx->T->face, jst, juv, sum / count)) < 0) return -1;
  }
  for (int k = 0; k < n; k++) j[k] = j[group[k]];
  cx->stats->junctions++;
  int bad = 0;
  for (int k = 0; k < n; k++) {
    uint64_t piece = nodes[idx[pos[k]]].lnext;
    int end = pos[(k + 1) % n];
    for (int i = pos[k]; i != end; i = (i + 1) % len) {
      const ch_refine_node *a = &nodes[idx[i]], *b = &nodes[idx[(i + 1) % len]];
      bad |= ch_cut_out_tri(cx->o, j[k], node_copy(a, piece), node_copy(b, piece), juv, a->uv, b->uv, piece);
    }
  }
  int before = cx->o->ntri;
  for (int k = 0; k < n; k++) {
    const ch_refine_node *x = &nodes[idx[pos[k]]];
    int v[4] = {x->copy_next, j[k], j[(k + n - 1) % n], x->copy_prev};
    const double *uv[4] = {x->uv, juv, juv, x->uv};
    bad |= out_quad(cx->o, v, uv, WALL_GROUP);
  }
  for (int k = 1; k + 1 < n; k++) bad |= ch_cut_out_tri(cx->o, j[0], j[k], j[k + 1], juv, juv, juv, WALL_GROUP);
  cx->stats->wall_triangles += cx->o->ntri - before;
  return bad;
}

/* Splits the cycle idx by its first unused chord, recursively; a region
 * left without chords is a plain piece or holds the junction. */
static int split_regions(const cut_context *cx, const ch_refine_node *nodes, int m, unsigned char *used, const int *idx,
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
static int emit_walls(const ch_refine_node *nodes, int m, ch_cut_out *o, ch_embed_stats *stats) {
  int bad = 0, before = o->ntri;
  for (int p = 0; p < m; p++) {
    int q = nodes[p].pair;
    if (q < p) continue;
    uint64_t r1 = nodes[p].lnext, r2 = nodes[p].lprev;
    int v[4] = {node_copy(&nodes[p], r1), node_copy(&nodes[q], r1), node_copy(&nodes[q], r2), node_copy(&nodes[p], r2)};
    const double *uv[4] = {nodes[p].uv, nodes[q].uv, nodes[q].uv, nodes[p].uv};
    /* A chord along an edge (both ends on it: a step curve poking
     * through) may stand its wall in the triangles on both sides: split
     * from its lowest vertex, the two are the same triangles facing
     * opposite ways, pillows the cleanup takes out (as emit_region's
     * pieces along an edge), not two quads on different diagonals. */
    if (nodes[p].corner < 0 && nodes[q].corner < 0 && nodes[p].edge == nodes[q].edge) {
      int low = 0;
      for (int k = 1; k < 4; k++) low = v[k] < v[low] ? k : low;
      int rv[4];
      const double *ruv[4];
      for (int k = 0; k < 4; k++) rv[k] = v[(low + k) % 4], ruv[k] = uv[(low + k) % 4];
      bad |= out_quad(o, rv, ruv, WALL_GROUP);
      continue;
    }
    bad |= out_quad(o, v, uv, WALL_GROUP);
  }
  stats->wall_triangles += o->ntri - before;
  return bad;
}

/* Counts an unresolved triangle of centre uv: the first one's place and
 * the box of all. */
static void note_unresolved(ch_embed_stats *stats, const double uv[2], int at_seam) {
  stats->unresolved_at_seams += at_seam;
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

static int fan_triangle(const ch_label_ctx *lb, const ch_refine_mesh *w, const ch_refine_tri *T,
                        const ch_refine_node *nodes, int m, ch_cut_out *o);

/* Cuts triangle t into its pieces, with walls where h jumps. */
int ch_cut_triangle(const ch_label_ctx *lb, const ch_refine_mesh *w, int t, double tol, ch_cut_out *o,
                    ch_embed_stats *stats) {
  const ch_refine_tri *T = &w->tris[t];
  ch_refine_node nodes[MAX_NODES];
  int m = ch_refine_gather_nodes(w, t, nodes);
  ch_refine_cut kind = m < 0 ? CUT_COMPLEX : ch_refine_classify(nodes, m);
  if (kind == CUT_NONE)
    return ch_cut_out_tri(o, T->v[0], T->v[1], T->v[2], T->uv[0], T->uv[1], T->uv[2], w->verts[T->v[0]].label);
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
    note_unresolved(stats, cuv, ch_refine_at_differing_seam(lb, w, t));
  }
  ch_refine_node *all = nodes;
  if (m < 0) { /* more nodes than a cut takes: all of them for the fan, so its neighbours' crossings meet it */
    int total = 3;
    for (int k = 0; k < 3; k++) total += w->edges[w->tri_edge[3 * (size_t)t + k]].ncross;
    if (!(all = malloc((size_t)total * sizeof *all))) return -1;
    m = ch_refine_gather_nodes_into(w, t, all, total);
  }
  int bad = fan_triangle(lb, w, T, all, m, o);
  if (all != nodes) free(all);
  return bad;
}

/* The fan of ch_cut_triangle's last resort over nodes[m]. */
static int fan_triangle(const ch_label_ctx *lb, const ch_refine_mesh *w, const ch_refine_tri *T,
                        const ch_refine_node *nodes, int m, ch_cut_out *o) {
  double cst[2] = {0, 0}, cuv[2] = {0, 0};
  for (int k = 0; k < 3; k++)
    for (int i = 0; i < 2; i++) {
      cst[i] += T->st[k][i] / 3.0;
      cuv[i] += T->uv[k][i] / 3.0;
    }
  uint64_t piece = ch_label_at(lb, cuv);
  ch_refine_locate_st(w->surface, T->face, cuv, cst);
  int c = ch_cut_out_vertex(o, T->face, cst, cuv, ch_height_eval(lb->height, cuv[0], cuv[1]));
  if (c < 0) return -1;
  /* Around the boundary, a crossing on a wall contributes both copies,
   * so the fan stays closed (a sliver from the centre spans the wall). */
  int bad = 0;
  for (int i = 0; i < m; i++) {
    const ch_refine_node *a = &nodes[i], *b = &nodes[(i + 1) % m];
    if (a->corner < 0 && a->copy_prev != a->copy_next)
      bad |= ch_cut_out_tri(o, c, a->copy_prev, a->copy_next, cuv, a->uv, a->uv, piece);
    bad |= ch_cut_out_tri(o, c, a->corner >= 0 ? a->corner : a->copy_next, b->corner >= 0 ? b->corner : b->copy_prev,
                          cuv, a->uv, b->uv, piece);
  }
  return bad;
}

ch_status ch_cut_evaluate_positions(const ch_surface *surface, ch_cut_out *o, ch_error *err) {
  o->pos = ch_alloc_large(3 * (size_t)(o->npos > 0 ? o->npos : 1), sizeof *o->pos, 0);
  if (!o->pos) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for %d vertices", o->npos);
  int failed = 0;
#pragma omp parallel for schedule(dynamic, 1024) reduction(| : failed)
  for (int i = 0; i < o->npos; i++) {
    double b[3], n[3];
    if (ch_surface_eval_position(surface, o->face[i], o->st[2 * (size_t)i], o->st[2 * (size_t)i + 1], b, n)) {
      failed = 1;
      continue;
    }
    for (int k = 0; k < 3; k++) o->pos[3 * (size_t)i + k] = b[k] + o->h[i] * n[k];
  }
  if (failed) return ch_error_set(err, CH_ERR_INTERNAL, "feature embedding: a vertex left its base face");
  return CH_OK;
}

/* Per-corner normals: the angle-weighted mean of the face normals around a
 * vertex among the triangles of the same group (piece, or wall), so they
 * are smooth inside a piece and split at its boundary.
 *
 * A parallel walk over the vertices, each thread a block of them in order,
 * each vertex its own corners (in triangle order, from a counting sort),
 * gives a corner a new UV unless it is the vertex's first UV, and a corner
 * its group's normal. UVs and normals are numbered by vertex, then by the
 * corner where each is born: the same on any number of threads, and near
 * their vertices in the file. A block writes its UVs from its first
 * corner's index on (it has no more UVs than corners) and the blocks close
 * ranks after the walk; the normals, counted by then, are made where o's
 * UVs were (made before those went, it grew the peak by 35 MB at 2.1M).
 *
 * The weights are then summed in triangle order: each thread reads every
 * corner, in the order they lie in memory, and adds the weights of those
 * of its block's vertices. The walk by vertex read each corner's triangle
 * from a row of the base away and waited on those loads (it took as long
 * with the weights' arithmetic left out), and a vertex's triangles are too
 * far apart in the cut's order (those the refinement added come after the
 * base's) for chunks of triangles to hold most of them. A normal gets its corners' weights in corner order either
 * way: the same sums, to the bit, on any number of threads. */

/* Where group g's normal is among the k (*k) of the vertex at hand, in
 * groups; a new one is added last. */
static int group_slot(uint64_t *groups, int *k, uint64_t g) {
  int j = 0;
  while (j < *k && groups[j] != g) j++;
  if (j == *k) groups[(*k)++] = g;
  return j;
}

/* The walk over vertices [v0, v1), writing from UV `at`; returns the UVs it
 * made, and *normals the normals it gave the corners, numbered from 0 in
 * the block. groups: room for the largest vertex's corners. */
static int uv_block(const ch_cut_out *o, const int *start, const int *order, int v0, int v1, int at, ch_mesh *m,
                    uint64_t *groups, int *normals) {
  int n = at, count = 0;
  for (int p = v0; p < v1; p++) {
    int first = -1, k = 0;
    const double *fuv = NULL;
    for (int i = start[p]; i < start[p + 1]; i++) {
      int c = order[i];
      const double *uv = ch_cut_out_uv(o, (size_t)c);
      if (first < 0 || fuv[0] != uv[0] || fuv[1] != uv[1]) {
        memcpy(&m->uvs[2 * (size_t)n], uv, 2 * sizeof *uv);
        m->corner_uv[c] = n++;
        if (first < 0) first = m->corner_uv[c], fuv = uv;
      } else {
        m->corner_uv[c] = first;
      }
      m->corner_normal[c] = count + group_slot(groups, &k, o->group[c / 3]);
    }
    count += k;
  }
  *normals = count;
  return n - at;
}

/* A corner's share of its vertex's normal is the face's normal weighted
 * by the corner's angle (Thurmer and Wuthrich), not by area: a vertex
 * between slices of unequal width gets the mean of its two sides, not the
 * wider one's normal. The face's normal is worked out from the corner's
 * edges u and w, which the angle reads anyway, rather than kept per face
 * (32 bytes a triangle at the embedding's peak, first touched there):
 * u x w is it times twice the area at every corner, and the corner's sine
 * is |u x w| / (|u| |w|), so one cross product serves both.
 *
 * A sliver (a boundary point within rounding of a vertex, before the
 * cleanup collapses it) has a corner near 180 degrees, so the largest
 * weight of its vertex's, and a normal that rounding decides: it would
 * tilt that vertex's normal by tens of degrees for the real triangles
 * around it. Triangles thinner than `thin` of their longest edge count
 * for nothing.
 *
 * The weights are worked out a batch of corners at a time: their edges
 * gathered, then a loop the compiler vectorises (two corners an
 * instruction; the same arithmetic, so the same bits), then added. */
enum { WEIGHT_BATCH = 64 };
typedef struct weight_batch {
  int n;
  size_t corner[WEIGHT_BATCH];
  double u[3][WEIGHT_BATCH], w[3][WEIGHT_BATCH], e[3][WEIGHT_BATCH], out[3][WEIGHT_BATCH];
} weight_batch;

/* Adds the batch's weights to their corners' normals, in the batch's
 * order, and empties it. */
static void batch_flush(weight_batch *b, double thin, ch_mesh *m) {
  int n = b->n;
  /* (scalars, not small arrays: those keep the loop from vectorising;
   * the operations are ch_cross3's, ch_dot3's and ch_max3's, in order) */
#pragma omp simd
  for (int i = 0; i < n; i++) {
    double u0 = b->u[0][i], u1 = b->u[1][i], u2 = b->u[2][i], w0 = b->w[0][i], w1 = b->w[1][i], w2 = b->w[2][i];
    double e0 = b->e[0][i], e1 = b->e[1][i], e2 = b->e[2][i];
    double f0 = u1 * w2 - u2 * w1, f1 = u2 * w0 - u0 * w2, f2 = u0 * w1 - u1 * w0;
    double fl = sqrt(f0 * f0 + f1 * f1 + f2 * f2);
    double longest =
        sqrt(ch_max3(u0 * u0 + u1 * u1 + u2 * u2, w0 * w0 + w1 * w1 + w2 * w2, e0 * e0 + e1 * e1 + e2 * e2));
    /* (worked out for every corner, then kept or not: no branch) */
    double weight = ch_angle_positive(fl, u0 * w0 + u1 * w1 + u2 * w2) / fl;
    weight = fl >= thin * longest && fl > 0.0 ? weight : 0.0;
    b->out[0][i] = f0 * weight;
    b->out[1][i] = f1 * weight;
    b->out[2][i] = f2 * weight;
  }
  for (int i = 0; i < n; i++) {
    double *sum = &m->normals[3 * (size_t)m->corner_normal[b->corner[i]]];
    for (int x = 0; x < 3; x++) sum[x] += b->out[x][i];
  }
  b->n = 0;
}

/* The weights of the corners of vertices [v0, v1), summed into their
 * normals in corner order, a batch at a time. */
static void sum_block(const ch_cut_out *o, double thin, int v0, int v1, ch_mesh *m) {
  static const int next[3] = {1, 2, 0}, prev[3] = {2, 0, 1};
  size_t nc = 3 * (size_t)o->ntri;
  weight_batch b;
  b.n = 0;
  for (size_t c = 0; c < nc; c++) {
    int v = o->tri[c];
    if (v < v0 || v >= v1) continue;
    const int *t = &o->tri[c - c % 3];
    int k = (int)(c % 3);
    const double *pa = &o->pos[3 * (size_t)v], *pb = &o->pos[3 * (size_t)t[next[k]]];
    const double *pc = &o->pos[3 * (size_t)t[prev[k]]];
    for (int x = 0; x < 3; x++) {
      b.u[x][b.n] = pb[x] - pa[x];
      b.w[x][b.n] = pc[x] - pa[x];
      b.e[x][b.n] = pc[x] - pb[x];
    }
    b.corner[b.n++] = c;
    if (b.n == WEIGHT_BATCH) batch_flush(&b, thin, m);
  }
  batch_flush(&b, thin, m);
}

/* Moves each block's `width` doubles per item from its first corner's
 * index (at[b]) to the end of the blocks before it (made[b] items each),
 * filling dest_at; shrinks the array to the total. */
static void close_ranks(double **array, int width, int nb, const int *at, const int *made, int *dest_at) {
  dest_at[0] = 0;
  for (int b = 0; b < nb; b++) {
    double *to = &(*array)[(size_t)width * (size_t)dest_at[b]], *from = &(*array)[(size_t)width * (size_t)at[b]];
    size_t n = (size_t)width * (size_t)made[b];
    if (to != from && n > 0) {
      if (to + n <= from) {
        /* Apart (a block holds fewer items than corners): copied on all
         * threads, a huge page at a time, as the copy is where those pages
         * are first touched (on one thread, 20 ms at 2.1M triangles). */
        enum { CHUNK = (2 << 20) / sizeof(double) };
        size_t chunks = (n + CHUNK - 1) / CHUNK;
#pragma omp parallel for schedule(static)
        for (size_t k = 0; k < chunks; k++)
          memcpy(to + k * CHUNK, from + k * CHUNK, (n - k * CHUNK < CHUNK ? n - k * CHUNK : CHUNK) * sizeof *to);
      } else {
        memmove(to, from, n * sizeof *to);
      }
    }
    dest_at[b + 1] = dest_at[b] + made[b];
  }
  double *q = realloc(*array, (size_t)width * (size_t)(dest_at[nb] > 0 ? dest_at[nb] : 1) * sizeof **array);
  if (q) *array = q; /* (shrinking: keeps the block where it cannot) */
}

ch_status ch_cut_build_mesh(ch_cut_out *o, double thin, ch_mesh *m, ch_error *err) {
  memset(m, 0, sizeof *m);
  size_t nc = 3 * (size_t)o->ntri, np = (size_t)(o->npos > 0 ? o->npos : 1);
  m->num_positions = o->npos;
  m->positions = o->pos;
  m->num_faces = o->ntri;
  m->num_corners = (int)nc;
  m->face_start = ch_alloc_large((size_t)o->ntri + 1, sizeof *m->face_start, 0);
  m->corner_uv = ch_alloc_large(nc ? nc : 1, sizeof *m->corner_uv, 0);
  m->corner_normal = ch_alloc_large(nc ? nc : 1, sizeof *m->corner_normal, 0);
  int *start = ch_alloc_large(np + 1, sizeof *start, 0); /* a vertex's corners in order */
  int *order = ch_alloc_large(nc ? nc : 1, sizeof *order, 0);
  int nb = omp_get_max_threads();
  /* per block: its first vertex and first corner; the UVs and normals it
   * makes, and where they go */
  int *block = calloc(6 * ((size_t)nb + 1), sizeof *block);
  int *first_vertex = block, *first_corner = block + (nb + 1), *made_uvs = block + 2 * (nb + 1);
  int *uv_at = block + 3 * (nb + 1), *made_normals = block + 4 * (nb + 1), *normal_at = block + 5 * (nb + 1);
  uint64_t **groups = calloc((size_t)nb, sizeof *groups); /* per block: a vertex's normals' groups */
  if (!m->face_start || !m->corner_uv || !m->corner_normal || !start || !order || !block || !groups) goto nomem;
#pragma omp parallel for schedule(static)
  for (int t = 0; t < o->ntri; t++) m->face_start[t] = 3 * t;
  m->face_start[o->ntri] = (int)nc;
  /* Corners by vertex, in corner order. */
  if (ch_sort_buckets(o->tri, nc, o->npos, start, order)) goto nomem;
  /* The blocks: about as many corners each. */
  for (int b = 1, p = 0; b <= nb; b++) {
    size_t want = nc * (size_t)b / (size_t)nb;
    while (p < o->npos && (size_t)start[p] < want) p++;
    first_vertex[b] = b == nb ? o->npos : p;
  }
  int most = 1;
  for (int p = 0; p < o->npos; p++) most = start[p + 1] - start[p] > most ? start[p + 1] - start[p] : most;
  for (int b = 0; b <= nb; b++) first_corner[b] = start[first_vertex[b]];
  for (int b = 0; b < nb; b++)
    if (!(groups[b] = malloc((size_t)most * sizeof *groups[b]))) goto nomem;
  /* (as many as the corners at most: the pages past the UVs made are
   * never touched; the blocks then close ranks and the rest is given
   * back) */
  m->uvs = ch_alloc_large(2 * (nc ? nc : 1), sizeof *m->uvs, 0);
  if (!m->uvs) goto nomem;
#pragma omp parallel for schedule(static, 1) num_threads(nb)
  for (int b = 0; b < nb; b++)
    made_uvs[b] = uv_block(o, start, order, first_vertex[b], first_vertex[b + 1], first_corner[b], m, groups[b],
                           &made_normals[b]);
  close_ranks(&m->uvs, 2, nb, first_corner, made_uvs, uv_at);
  m->num_uvs = uv_at[nb];
  free(o->corner_uv);
  free(o->extra_uv);
  free(o->vertex_uv);
  o->corner_uv = NULL;
  o->extra_uv = NULL;
  o->vertex_uv = NULL;
  o->nextra = 0;
  /* The normals, counted: their array where o's UVs were. */
  normal_at[0] = 0;
  for (int b = 0; b < nb; b++) normal_at[b + 1] = normal_at[b] + made_normals[b];
  m->num_normals = normal_at[nb];
  m->normals = ch_alloc_large(3 * (size_t)(m->num_normals > 0 ? m->num_normals : 1), sizeof *m->normals, 1);
  if (!m->normals) goto nomem;
  /* Each corner's UV from where its block wrote it to where it landed,
   * and its normal's number from its block's to the mesh's. */
  if (nb > 1) {
#pragma omp parallel for schedule(static)
    for (size_t c = 0; c < nc; c++) {
      int v = o->tri[c], b = 0;
      while (v >= first_vertex[b + 1]) b++;
      m->corner_uv[c] -= first_corner[b] - uv_at[b];
      m->corner_normal[c] += normal_at[b];
    }
  }
#pragma omp parallel for schedule(static, 1) num_threads(nb)
  for (int b = 0; b < nb; b++) sum_block(o, thin, first_vertex[b], first_vertex[b + 1], m);
  free(o->group);
  o->group = NULL;
#pragma omp parallel for schedule(static)
  for (int n = 0; n < m->num_normals; n++) {
    double *s = &m->normals[3 * (size_t)n];
    if (!ch_normalize3(s)) s[0] = s[1] = 0.0, s[2] = 1.0; /* only zero-area triangles here: any unit vector */
  }
  for (int b = 0; b < nb; b++) free(groups[b]);
  free(groups);
  free(start);
  free(order);
  free(block);
  /* The triangles' corners are the mesh's corners, in the same order. */
  m->corner_position = o->tri;
  o->tri = NULL;
  return CH_OK;
nomem:
  if (groups)
    for (int b = 0; b < nb; b++) free(groups[b]);
  free(groups);
  free(start);
  free(order);
  free(block);
  m->positions = NULL; /* still o's */
  ch_mesh_free(m);
  return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the output mesh");
}

/* ---- thinning the grooves' layers ---------------------------------------- */
enum { EDGE_GRID = CH_CUT_EDGE_GRID };

typedef struct thin_context {
  const ch_label_ctx *lb;
  const ch_cut_out *o;
  const float *edge_grid; /* ch_cut_edge_grid's */
  double (*gradient)[3]; /* per output vertex: its distance's gradient, and t */
  unsigned char *known;  /* once computed: 1, or 2 where it has none (a rim) */
  double *distance;      /* per output vertex: its signed distance to distance_curve's */
  int *distance_curve;   /* -1 until computed */
  double (*normal)[3];   /* per output vertex: exact_normal's last, for normal_key */
  int *normal_key;       /* its curve * 256 + layer (0 for a u groove's), -1 until computed */
  double *height;        /* per output vertex: h at height_uv (the edge rule's), */
  const double **height_uv; /* NULL until computed */
  double *cos_max;       /* per curve: thin_triangle_ok's bound */
} thin_context;

/* Groove c's signed distance at output vertex v (at uv), cached. */
static double vertex_distance(thin_context *x, int c, int v, const double uv[2]) {
  if (x->distance_curve[v] != c) {
    x->distance[v] = ch_label_groove_distance(x->lb, c, uv);
    x->distance_curve[v] = c;
  }
  return x->distance[v];
}

int ch_cut_edge_grid(const ch_tess_result *tess, double fallback, float *grid) {
  double *sum = calloc(2 * EDGE_GRID * EDGE_GRID, sizeof *sum); /* longest edges, triangles */
  if (!sum) return -1;
  const ch_mesh *m = &tess->mesh;
  for (int t = 0; t < m->num_faces; t++) {
    const double *q[3];
    for (int k = 0; k < 3; k++) q[k] = &m->uvs[2 * (size_t)m->corner_uv[3 * (size_t)t + k]];
    double cx = (q[0][0] + q[1][0] + q[2][0]) / 3.0, cy = (q[0][1] + q[1][1] + q[2][1]) / 3.0;
    if (!(cx >= 0.0 && cx < 1.0 && cy >= 0.0 && cy < 1.0)) continue;
    double longest = 0.0;
    for (int k = 0; k < 3; k++)
      longest = fmax(longest, ch_dist2d(q[(k + 1) % 3][0] - q[k][0], q[(k + 1) % 3][1] - q[k][1]));
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
      grid[y * EDGE_GRID + x0] = (float)(0.5 * (n > 0.0 ? l / n : fallback));
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
  /* clamped as fmin(EDGE_GRID - 1, fmax(0, .)) would, NaN to 0, without
   * their library calls (gcc inlines them only with -ffinite-math-only) */
  double u = uv[0] * EDGE_GRID, v = uv[1] * EDGE_GRID;
  u = u > 0.0 ? u : 0.0;
  v = v > 0.0 ? v : 0.0;
  int gx = (int)(u < EDGE_GRID - 1 ? u : EDGE_GRID - 1), gy = (int)(v < EDGE_GRID - 1 ? v : EDGE_GRID - 1);
  return x->edge_grid[gy * EDGE_GRID + gx];
}

/* h at output vertex v (at uv), cached for that UV. */
static double vertex_height(thin_context *x, int v, const double uv[2]) {
  if (x->height_uv[v] != uv) {
    x->height[v] = ch_height_eval(x->lb->height, uv[0], uv[1]);
    x->height_uv[v] = uv;
  }
  return x->height[v];
}

/* The refinement's chord rule (ch_refine_needed) for any new edge. */
static int thin_edge_ok(void *ctx, int family, int va, int vb, const double a[2], const double b[2]) {
  thin_context *x = ctx;
  const ch_label_ctx *lb = x->lb;
  double mid[2] = {0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])};
  int c = family / LEVELS;
  const ch_curve *cv = &lb->set->curves[c];
  double err;
  if (cv->profile.kind == CH_PROFILE_U) { /* in t, as the rims' slivers have no area (ch_refine_needed) */
    double da = vertex_distance(x, c, va, a), db = vertex_distance(x, c, vb, b),
           dm = ch_label_groove_distance(lb, c, mid);
    err = fabs(dm - 0.5 * (da + db)) / cv->width * fabs(cv->depth);
  } else {
    err = fabs(ch_height_eval(lb->height, mid[0], mid[1]) - 0.5 * (vertex_height(x, va, a) + vertex_height(x, vb, b)));
  }
  return err <= lb->chord_tol[c] * ch_label_chord_factor(lb, mid);
}

/* The exact normal of groove c's h at output vertex v in layer k (its
 * profile segment), in the frame (UV times the object scale, h): the signed
 * distance's gradient (away from the closest point, cached per vertex)
 * times the profile's slope there, or, on a profile made of straight
 * pieces, the slope of layer k (a vertex on a crease has one per side).
 * 0 at a rim or beyond (the slope is unbounded or h is another's). */
static int exact_normal(thin_context *x, int c, int k, int v, const double uv[2], double n[3]) {
  const ch_label_ctx *lb = x->lb;
  const ch_curve *cv = &lb->set->curves[c];
  if (!x->known[v]) {
    int seg = -1;
    double u = 0.0, d = ch_label_groove_distance_in(lb, c, uv, &seg, &u, 0), t = d / cv->width;
    x->known[v] = 2;
    if (!(fabs(t) < 0.5 - 1e-6) || seg < 0) return 0;
    const ch_segment *sg = &lb->set->segments[seg];
    double cp[2], *g = x->gradient[v];
    ch_bezier_eval(sg->p, u, cp);
    double r = ch_dist2d(uv[0] - cp[0], uv[1] - cp[1]);
    if (r > 1e-12) {
      g[0] = (d < 0.0 ? -1.0 : 1.0) * (uv[0] - cp[0]) / r;
      g[1] = (d < 0.0 ? -1.0 : 1.0) * (uv[1] - cp[1]) / r;
    } else { /* on the curve: its left normal */
      double tg[2];
      ch_bezier_tangent(sg->p, u, tg);
      double l = ch_dist2d(tg[0], tg[1]);
      g[0] = l > 0.0 ? -tg[1] / l : 0.0;
      g[1] = l > 0.0 ? tg[0] / l : 0.0;
    }
    g[2] = t;
    x->known[v] = 1;
  }
  if (x->known[v] != 1) return 0;
  /* the normal depends on the curve and, but in a u groove, the layer:
   * the same one again is read back (a vertex is in many triangles) */
  int key = c * 256 + (cv->profile.kind == CH_PROFILE_U ? 0 : k);
  if (x->normal_key[v] == key) {
    for (int i = 0; i < 3; i++) n[i] = x->normal[v][i];
    return 1;
  }
  const double *g = x->gradient[v];
  double t = g[2], dp;
  if (cv->profile.kind == CH_PROFILE_U) {
    double dt = fmin(1e-6, 0.5 - fabs(t));
    dp = (ch_profile_eval(&cv->profile, t + dt) - ch_profile_eval(&cv->profile, t - dt)) / (2.0 * dt);
  } else {
    int nb;
    const double *br = ch_label_lines_of(lb, c, 0, &nb);
    if (k < 1 || k >= nb) return 0;
    dp = (ch_profile_eval(&cv->profile, br[k]) - ch_profile_eval(&cv->profile, br[k - 1])) / (br[k] - br[k - 1]);
  }
  double slope = cv->depth * dp / cv->width / lb->object_scale; /* dh/ds in object units */
  double m[3] = {-slope * g[0], -slope * g[1], 1.0}, l = sqrt(ch_dot3(m, m));
  for (int i = 0; i < 3; i++) n[i] = x->normal[v][i] = m[i] / l;
  x->normal_key[v] = key;
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
  const ch_label_ctx *lb = x->lb;
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
  double cos_max = x->cos_max[c];
  for (int k = 0; k < 3; k++) {
    double n[3];
    if (!exact_normal(x, c, layer, v[k], uv[k], n)) continue;
    if (ch_dot3(f, n) / l < cos_max) return 0;
  }
  return 1;
}

/* Thins o's groove layers (ch_thin.h) and drops the vertices it frees;
 * returns how many, -1 when out of memory. */
int ch_cut_thin(const ch_label_ctx *lb, const float *edge_grid, ch_cut_out *o) {
  thin_context *x = malloc(sizeof *x);
  unsigned char *removed = calloc((size_t)(o->npos > 0 ? o->npos : 1), 1);
  int *map = malloc((size_t)(o->npos > 0 ? o->npos : 1) * sizeof *map);
  if (!x || !removed || !map) {
    free(x);
    free(removed);
    free(map);
    return -1;
  }
  size_t np = (size_t)(o->npos > 0 ? o->npos : 1);
  int ncurves = lb->set->num_curves;
  x->lb = lb;
  x->o = o;
  x->edge_grid = edge_grid;
  x->gradient = malloc(np * sizeof *x->gradient);
  x->known = calloc(np, 1);
  x->distance = malloc(np * sizeof *x->distance);
  x->distance_curve = malloc(np * sizeof *x->distance_curve);
  x->normal = malloc(np * sizeof *x->normal);
  x->normal_key = malloc(np * sizeof *x->normal_key);
  x->height = malloc(np * sizeof *x->height);
  x->height_uv = calloc(np, sizeof *x->height_uv);
  x->cos_max = malloc((size_t)(ncurves > 0 ? ncurves : 1) * sizeof *x->cos_max);
  int n = -1;
  if (x->gradient && x->known && x->distance && x->distance_curve && x->normal && x->normal_key && x->height &&
      x->height_uv && x->cos_max) {
    for (int v = 0; v < o->npos; v++) x->distance_curve[v] = x->normal_key[v] = -1;
    for (int c = 0; c < ncurves; c++) x->cos_max[c] = cos(0.6 * lb->curve_angle[c]);
    ch_thin_rules rules = {thin_band, thin_max_edge, thin_edge_ok, thin_triangle_ok, x};
    n = ch_thin_bands(o->npos, &o->ntri, o->tri, o->corner_uv, o->vertex_uv, o->extra_uv, o->group, &rules, removed);
  }
  free(x->gradient);
  free(x->known);
  free(x->distance);
  free(x->distance_curve);
  free(x->normal);
  free(x->normal_key);
  free(x->height);
  free(x->height_uv);
  free(x->cos_max);
  if (n > 0) {
    int k = 0;
    for (int v = 0; v < o->npos; v++) {
      map[v] = removed[v] ? -1 : k;
      if (!removed[v]) ch_cut_out_move_vertex(o, k++, v);
    }
    o->npos = k;
    for (size_t i = 0; i < 3 * (size_t)o->ntri; i++) o->tri[i] = map[o->tri[i]];
  }
  free(x);
  free(removed);
  free(map);
  return n;
}
