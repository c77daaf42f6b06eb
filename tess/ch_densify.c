/* ch_densify: more or fewer triangles away from the grooves and walls,
 * after the cut (see ch_cut_internal.h).
 *
 * Where a run of the embedding misses its target (its base count came from
 * a model of what the features add), the difference is made up where h is
 * smooth, rather than by another run at another base that cuts every
 * feature again. More: a triangle's longest edge is split where it is
 * also the longest of the triangle across it (longest-edge bisection on
 * terminal edges, Rivara 1984), longest edges first; on a tessellation of
 * quads cut in two that splits the diagonals, then the quads' sides (a
 * 4-8 mesh), so the triangles keep their shapes and no vertex hangs in
 * another's edge. Fewer: first the flat blocks of the base's grid the cut
 * left whole (ch_blocks.c), then shortest edges first, a vertex
 * collapses into a neighbour that keeps its place on the surface, where
 * the link condition holds (Dey et al. 1999) and no triangle turns over. */
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "ch_alloc.h"
#include "ch_cut_internal.h"
#include "ch_embed_internal.h"
#include "ch_height.h"
#include "ch_math.h"
#include "ch_refine_internal.h"
#include "ch_sort.h"

/* The longest edge of a plain triangle: its two vertices as a key (smaller first)
 * and where it is (3 t + k: corner k to k + 1 of triangle t). */
typedef struct half_edge {
  uint64_t key;
  int64_t at;
} half_edge;

typedef struct split {
  double length2; /* of the edge, in space */
  uint64_t key;
  int64_t at0, at1; /* its two half-edges */
} split;

static int by_key(const void *a, const void *b) {
  const half_edge *x = a, *y = b;
  if (x->key != y->key) return x->key < y->key ? -1 : 1;
  return x->at < y->at ? -1 : x->at > y->at;
}

static int longest_first(const void *a, const void *b) {
  const split *x = a, *y = b;
  if (x->length2 != y->length2) return x->length2 > y->length2 ? -1 : 1;
  return x->key < y->key ? -1 : x->key > y->key;
}

static double dist2(const double *a, const double *b) {
  double d[3];
  ch_sub3(b, a, d);
  return ch_dot3(d, d);
}

/* A piece where h is h_step alone (no groove, not a wall): smooth inside,
 * so h at a new point inside it is h there. */
static int plain(uint64_t group) { return group != WALL_GROUP && (group >> 32) == 0; }

/* Twice triangle t's area vector (its normal times twice its area), with
 * corner k (>= 0) moved to vertex `with`. */
static void tri_normal(const ch_cut_out *o, int t, int k, int with, double n[3]) {
  const double *p[3];
  for (int i = 0; i < 3; i++) p[i] = &o->pos[3 * (size_t)o->tri[3 * (size_t)t + i]];
  if (k >= 0) p[k] = &o->pos[3 * (size_t)with];
  double a[3], b[3];
  ch_sub3(p[1], p[0], a);
  ch_sub3(p[2], p[0], b);
  ch_cross3(a, b, n);
}

/* Twice triangle t's area, squared. */
static double area2(const ch_cut_out *o, size_t t) {
  double n[3];
  tri_normal(o, (int)t, -1, 0, n);
  return ch_dot3(n, n);
}

/* The corner of triangle t whose outgoing edge is its longest (ties: the
 * first). */
static int longest_corner(const ch_cut_out *o, size_t t) {
  const int *v = &o->tri[3 * t];
  int best = 0;
  double bl = -1.0;
  for (int k = 0; k < 3; k++) {
    double l = dist2(&o->pos[3 * (size_t)v[k]], &o->pos[3 * (size_t)v[(k + 1) % 3]]);
    if (l > bl) {
      bl = l;
      best = k;
    }
  }
  return best;
}

/* Whether corner k of triangle t reads its vertex's UV from the vertex's
 * own face (not across a UV seam from another chart). */
static int corner_in_chart(const ch_surface *surface, const ch_cut_out *o, size_t t, int k) {
  int v = o->tri[3 * t + (size_t)k];
  double uv[2];
  if (ch_surface_eval_uv(surface, o->face[v], o->st[2 * (size_t)v], o->st[2 * (size_t)v + 1], uv)) return 0;
  const double *c = ch_cut_out_uv(o, 3 * t + (size_t)k);
  return fabs(uv[0] - c[0]) <= 1e-12 && fabs(uv[1] - c[1]) <= 1e-12;
}

/* The splits one round can make, longest first: edges between two
 * triangles of one plain piece, the longest of both, with both ends'
 * (s,t) in one base face of at most four corners (affine along its edges:
 * the middle in (s,t) is on the surface's edge; ends on a face's border
 * may be kept in the neighbour's (s,t): those edges wait), off UV seams,
 * not slivers. */
static long round_candidates(const ch_surface *surface, const ch_cut_out *o, split **out) {
  size_t nh = 0;
  for (int t = 0; t < o->ntri; t++) nh += plain(o->group[t]);
  half_edge *he = malloc((nh > 0 ? nh : 1) * sizeof *he);
  if (!he) return -1;
  nh = 0;
  for (int t = 0; t < o->ntri; t++) {
    if (!plain(o->group[t])) continue;
    int k = longest_corner(o, (size_t)t);
    int a = o->tri[3 * (size_t)t + (size_t)k], b = o->tri[3 * (size_t)t + (size_t)(k + 1) % 3];
    uint64_t lo = (uint64_t)(a < b ? a : b), hi = (uint64_t)(a < b ? b : a);
    he[nh].key = lo << 32 | hi;
    he[nh].at = 3 * (int64_t)t + k;
    nh++;
  }
  qsort(he, nh, sizeof *he, by_key);
  split *s = malloc((nh / 2 + 1) * sizeof *s);
  if (!s) {
    free(he);
    return -1;
  }
  long ns = 0;
  for (size_t i = 0; i + 1 < nh; i++) {
    if (he[i].key != he[i + 1].key) continue;
    /* a terminal edge: the longest of both triangles on it (an edge has
     * at most two triangles in a manifold part; a third means not) */
    if (i + 2 < nh && he[i + 2].key == he[i].key) {
      while (i + 1 < nh && he[i + 1].key == he[i].key) i++;
      continue;
    }
    int64_t x = he[i].at, y = he[i + 1].at;
    size_t tx = (size_t)(x / 3), ty = (size_t)(y / 3);
    int kx = (int)(x % 3), ky = (int)(y % 3);
    int a = o->tri[3 * tx + (size_t)kx], b = o->tri[3 * tx + (size_t)(kx + 1) % 3];
    i++;
    if (o->tri[3 * ty + (size_t)ky] != b || o->tri[3 * ty + (size_t)(ky + 1) % 3] != a) continue; /* opposite ways */
    if (o->group[tx] != o->group[ty]) continue;                                                   /* one piece */
    int face = o->face[a];
    if (o->face[b] != face || ch_surface_face_size(surface, face) > 4) continue;
    if (!corner_in_chart(surface, o, tx, kx) || !corner_in_chart(surface, o, tx, (kx + 1) % 3) ||
        !corner_in_chart(surface, o, ty, ky) || !corner_in_chart(surface, o, ty, (ky + 1) % 3))
      continue;
    double l2 = dist2(&o->pos[3 * (size_t)a], &o->pos[3 * (size_t)b]);
    if (!(area2(o, tx) > 1e-6 * l2 * l2 && area2(o, ty) > 1e-6 * l2 * l2)) continue; /* slivers stay as they are */
    s[ns].length2 = l2;
    s[ns].key = he[i].key;
    s[ns].at0 = x;
    s[ns].at1 = y;
    ns++;
  }
  free(he);
  qsort(s, (size_t)ns, sizeof *s, longest_first);
  *out = s;
  return ns;
}

static int grow(void **p, size_t n, size_t size) {
  void *q = realloc(*p, (n > 0 ? n : 1) * size);
  if (!q) return -1;
  *p = q;
  return 0;
}

long ch_cut_densify(const ch_surface *surface, const ch_height *height, ch_cut_out *o, long extra, int max_rounds) {
  long added = 0;
  for (int round = 0; round < max_rounds && added + 1 < extra; round++) {
    split *s = NULL;
    long ns = round_candidates(surface, o, &s);
    if (ns < 0) return -1;
    long take = (extra - added) / 2;
    if (take > ns) take = ns;
    if (take == 0) {
      free(s);
      break;
    }
    size_t np = (size_t)o->npos + (size_t)take, nt = (size_t)o->ntri + 2 * (size_t)take;
    if (np >= INT32_MAX / 3 || nt >= INT32_MAX / 6) { /* (the indices the cut allows) */
      free(s);
      break;
    }
    if (grow((void **)&o->face, np, sizeof *o->face) || grow((void **)&o->st, 2 * np, sizeof *o->st) ||
        grow((void **)&o->h, np, sizeof *o->h) || grow((void **)&o->pos, 3 * np, sizeof *o->pos) ||
        grow((void **)&o->tri, 3 * nt, sizeof *o->tri) || grow((void **)&o->group, nt, sizeof *o->group) ||
        grow((void **)&o->corner_uv, 3 * nt, sizeof *o->corner_uv) ||
        grow((void **)&o->vertex_uv, 2 * np, sizeof *o->vertex_uv)) {
      free(s);
      return -1;
    }
    o->cap_pos = (int)np;
    o->cap_tri = (int)nt;
    int failed = 0;
    /* Each split: the new vertex m in the middle of edge a-b (in the
     * face's (s,t)), triangles (a, b, c) and (b, a, d) become (a, m, c),
     * (b, m, d) in place and (m, b, c), (m, a, d) appended. The splits of
     * a round touch different triangles (one longest edge each). */
#pragma omp parallel for schedule(static) reduction(| : failed)
    for (long i = 0; i < take; i++) {
      size_t m = (size_t)o->npos + (size_t)i;
      size_t tx = (size_t)(s[i].at0 / 3), ty = (size_t)(s[i].at1 / 3);
      int kx = (int)(s[i].at0 % 3), ky = (int)(s[i].at1 % 3);
      int a = o->tri[3 * tx + (size_t)kx], b = o->tri[3 * tx + (size_t)(kx + 1) % 3];
      int c = o->tri[3 * tx + (size_t)(kx + 2) % 3], d = o->tri[3 * ty + (size_t)(ky + 2) % 3];
      /* (the corners' UVs by their corner_uv entries: the values move
       * with them) */
      const double *ua = ch_cut_out_uv(o, 3 * tx + (size_t)kx), *ub = ch_cut_out_uv(o, 3 * tx + (size_t)(kx + 1) % 3);
      int ra = o->corner_uv[3 * tx + (size_t)kx], rb = o->corner_uv[3 * tx + (size_t)(kx + 1) % 3];
      int rc = o->corner_uv[3 * tx + (size_t)(kx + 2) % 3], rd = o->corner_uv[3 * ty + (size_t)(ky + 2) % 3];
      o->face[m] = o->face[a];
      for (int j = 0; j < 2; j++) o->st[2 * m + j] = 0.5 * (o->st[2 * (size_t)a + j] + o->st[2 * (size_t)b + j]);
      /* The middle in UV, located in the face: an N-gon's sub-faces tile
       * its parameter plane, so the mean (s,t) of two corners in different
       * sub-faces can be another point, or outside the face (the mean is
       * the search's start and stays where it is not found). */
      double mid[2] = {0.5 * (ua[0] + ub[0]), 0.5 * (ua[1] + ub[1])};
      ch_refine_locate_st(surface, o->face[m], mid, &o->st[2 * m]);
      ch_surface_point sp;
      if (ch_surface_eval(surface, o->face[m], o->st[2 * m], o->st[2 * m + 1], &sp)) {
        failed = 1;
        continue;
      }
      o->h[m] = ch_height_eval(height, sp.uv[0], sp.uv[1]);
      for (int j = 0; j < 3; j++) o->pos[3 * m + j] = sp.position[j] + o->h[m] * sp.normal[j];
      size_t n1 = (size_t)o->ntri + 2 * (size_t)i, n2 = n1 + 1;
      int *T = o->tri, *R = o->corner_uv;
      T[3 * tx] = a, T[3 * tx + 1] = (int)m, T[3 * tx + 2] = c;
      T[3 * ty] = b, T[3 * ty + 1] = (int)m, T[3 * ty + 2] = d;
      T[3 * n1] = (int)m, T[3 * n1 + 1] = b, T[3 * n1 + 2] = c;
      T[3 * n2] = (int)m, T[3 * n2 + 1] = a, T[3 * n2 + 2] = d;
      /* (a and b read in tx's corners on both sides of the edge, m its own) */
      memcpy(&o->vertex_uv[2 * m], sp.uv, 2 * sizeof *o->vertex_uv);
      const int refs[4][3] = {{ra, -1, rc}, {rb, -1, rd}, {-1, rb, rc}, {-1, ra, rd}};
      size_t which[4] = {tx, ty, n1, n2};
      for (int q = 0; q < 4; q++)
        for (int k = 0; k < 3; k++) R[3 * which[q] + (size_t)k] = refs[q][k];
      o->group[n1] = o->group[n2] = o->group[tx];
    }
    free(s);
    if (failed) return -2;
    o->npos += (int)take;
    o->ntri += 2 * (int)take;
    added += 2 * take;
  }
  return added;
}

/* ---- the other way: fewer triangles where h is smooth -------------------- */

/* The coarsening runs on COARSEN_REGIONS slabs of space at once, each its
 * own greedy order: a vertex collapses only where its whole fan is in its
 * slab, so a collapse reads and writes only its slab's vertices, fans and
 * triangles (a triangle with a corner in another slab is in no such fan),
 * and the result does not depend on the threads. Then, if it must, again
 * on slabs shifted by half a slab, where the first slabs' borders were. */
enum { COARSEN_REGIONS = 16 };

/* Fans a collapse rewrote, for the vertices of one slab. */
typedef struct fan_store {
  int *tri;
  size_t len, cap;
} fan_store;

/* Vertex -> triangles, in triangle order: vertex v's are fan(f, v)[0 ..
 * count[v] - 1]. Built once; a collapse rewrites the fans it changes (one
 * that grows moves to the store of the slab that collapses). */
typedef struct vertex_fans {
  int *start, *count; /* npos each; start >= len: in store[v] */
  int *tri;           /* the fans as built */
  size_t len;
  unsigned char *region, *store;       /* per vertex: its slab; where its fan is */
  fan_store more[2 * COARSEN_REGIONS]; /* by the phase's parity: each slab writes only its own */
  int phase;
  int axis; /* the slabs: along this axis, lo + (i + shift) / scale */
  double lo, scale;
} vertex_fans;

static int *fan(const vertex_fans *f, int v) {
  size_t s = (size_t)f->start[v];
  return s < f->len ? &f->tri[s] : &f->more[f->store[v]].tri[s - f->len];
}

/* Each vertex's slab: equal parts of the positions' box along its longest
 * side, starting `shift` of a part before it. */
static void assign_slabs(const ch_cut_out *o, vertex_fans *f, double shift) {
#pragma omp parallel for schedule(static)
  for (int v = 0; v < o->npos; v++) {
    double x = (o->pos[3 * (size_t)v + f->axis] - f->lo) * f->scale + shift;
    f->region[v] = (unsigned char)(x > 0.0 ? (x < COARSEN_REGIONS - 1 ? (int)x : COARSEN_REGIONS - 1) : 0);
  }
}

/* Below this many corners per thread the threads' counts cost more than
 * they save (as in ch_sort_buckets). */
enum { FAN_CORNERS_PER_THREAD = 1 << 16 };

static int fans_build(const ch_cut_out *o, vertex_fans *f) {
  size_t n = 3 * (size_t)o->ntri, np = (size_t)(o->npos > 0 ? o->npos : 0);
  size_t nb = (size_t)omp_get_max_threads();
  if (nb > n / FAN_CORNERS_PER_THREAD) nb = n / FAN_CORNERS_PER_THREAD;
  if (nb < 1) nb = 1;
  /* (the large arrays in huge pages where the kernel gives them, each
   * first touched by the threads that fill it: fresh 4 KiB pages cost
   * about 6 us each, on 2.1M triangles 35 ms for the heaps' and the new
   * indices' 22 MB, 7 ms in huge pages; start and count in one block) */
  f->start = ch_alloc_large(2 * (np + 1), sizeof *f->start, 0);
  f->count = f->start ? f->start + np + 1 : NULL;
  f->tri = ch_alloc_large(n ? n : 1, sizeof *f->tri, 0);
  f->region = malloc(np + 1);
  f->store = malloc(np + 1);
  /* at[b * np + v]: range b's corners of vertex v, then where range b
   * puts its first one */
  int *at = ch_alloc_large(nb * np + 1, sizeof *at, 0);
  if (!f->start || !f->count || !f->tri || !f->region || !f->store || !at) {
    free(at);
    return -1;
  }
  /* Triangles by vertex in triangle order: a counting sort of the
   * corners, as ch_sort_buckets, that writes the triangle (not the
   * corner) and sums the vertices' counts in parallel. */
  size_t nt = (size_t)o->ntri;
#pragma omp parallel for schedule(static, 1) num_threads((int)nb)
  for (size_t b = 0; b < nb; b++) {
    int *c = &at[b * np];
    memset(c, 0, np * sizeof *c);
    for (size_t i = 3 * (b * nt / nb), i1 = 3 * ((b + 1) * nt / nb); i < i1; i++) c[o->tri[i]]++;
  }
  int nth = omp_get_max_threads(), *part = calloc((size_t)nth + 1, sizeof *part);
  if (!part) {
    free(at);
    return -1;
  }
  /* The slabs: along the longest side of the positions' box (ch_box3's,
   * found here in parallel: a NaN is passed over as fmin does). */
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
#pragma omp parallel num_threads(nth)
  {
    /* each thread its block of vertices: their counts and box, then
     * (after the blocks' sums) their starts */
    int th = omp_get_thread_num(), nth_ = omp_get_num_threads();
    size_t v0 = (size_t)th * np / (size_t)nth_, v1 = (size_t)(th + 1) * np / (size_t)nth_;
    int sum = 0;
    double l[3] = {INFINITY, INFINITY, INFINITY}, h[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t v = v0; v < v1; v++) {
      int c = 0;
      for (size_t b = 0; b < nb; b++) c += at[b * np + v];
      f->count[v] = c;
      sum += c;
      for (int k = 0; k < 3; k++) {
        double x = o->pos[3 * v + (size_t)k];
        l[k] = x < l[k] ? x : l[k];
        h[k] = x > h[k] ? x : h[k];
      }
    }
    part[th + 1] = sum;
#pragma omp critical
    for (int k = 0; k < 3; k++) {
      lo[k] = l[k] < lo[k] ? l[k] : lo[k];
      hi[k] = h[k] > hi[k] ? h[k] : hi[k];
    }
#pragma omp barrier
#pragma omp single
    for (int k = 0; k < nth_; k++) part[k + 1] += part[k];
    int s = part[th];
    for (size_t v = v0; v < v1; v++) {
      f->start[v] = s;
      for (size_t b = 0; b < nb; b++) {
        int c = at[b * np + v];
        at[b * np + v] = s;
        s += c;
      }
    }
  }
  f->start[np] = (int)n;
  free(part);
#pragma omp parallel for schedule(static, 1) num_threads((int)nb)
  for (size_t b = 0; b < nb; b++) {
    int *c = &at[b * np];
    for (size_t t = b * nt / nb, t1 = (b + 1) * nt / nb; t < t1; t++)
      for (int k = 0; k < 3; k++) f->tri[c[o->tri[3 * t + (size_t)k]]++] = (int)t;
  }
  free(at);
  f->len = n;
  int axis = 0;
  for (int k = 1; k < 3; k++)
    if (hi[k] - lo[k] > hi[axis] - lo[axis]) axis = k;
  f->axis = axis;
  f->lo = lo[axis];
  f->scale = hi[axis] > lo[axis] ? COARSEN_REGIONS / (hi[axis] - lo[axis]) : 0.0;
  return 0;
}

static void fans_free(vertex_fans *f) {
  free(f->start); /* (and count) */
  free(f->tri);
  free(f->region);
  free(f->store);
  for (int r = 0; r < 2 * COARSEN_REGIONS; r++) free(f->more[r].tri);
}

static int corner_of(const ch_cut_out *o, int t, int v) {
  for (int k = 0; k < 3; k++)
    if (o->tri[3 * (size_t)t + k] == v) return k;
  return -1;
}

/* Twice the UV area of triangle t (*before) and with corner k's UV
 * replaced by uv (*after). */
static void uv_areas(const ch_cut_out *o, int t, int k, const double uv[2], double *before, double *after) {
  const double *c[3];
  for (int j = 0; j < 3; j++) c[j] = ch_cut_out_uv(o, 3 * (size_t)t + (size_t)j);
  *before = (c[1][0] - c[0][0]) * (c[2][1] - c[0][1]) - (c[2][0] - c[0][0]) * (c[1][1] - c[0][1]);
  c[k] = uv;
  *after = (c[1][0] - c[0][0]) * (c[2][1] - c[0][1]) - (c[2][0] - c[0][0]) * (c[1][1] - c[0][1]);
}

/* Whether collapsing v into its neighbour u keeps the mesh as it should:
 * u and v share exactly the two neighbours across edge u-v (the link
 * condition), and every triangle left keeps its UV orientation and turns
 * its normal by under 20 degrees. (The tests read only: the one that
 * fails most, the UV orientation, goes first.) kv[i]: v's corner in its
 * i-th triangle. Bit i of *on_edge: that triangle holds u (it would go);
 * where the collapse is allowed, bit i of *held: u's triangles hold its
 * next corner (not u). */
static int collapse_ok(const ch_cut_out *o, const vertex_fans *f, int v, int u, const int *kv, uint32_t *on_edge,
                       uint32_t *held) {
  int nv = f->count[v], nu = f->count[u], shared = 0;
  const int *tv = fan(f, v), *tu = fan(f, u);
  const double *uvu = NULL;
  *on_edge = 0;
  for (int i = 0; i < nv; i++) {
    const int *c = &o->tri[3 * (size_t)tv[i]];
    int k = kv[i];
    if (c[k == 2 ? 0 : k + 1] == u || c[k == 0 ? 2 : k - 1] == u) {
      *on_edge |= (uint32_t)1 << i;
      if (!uvu) uvu = ch_cut_out_uv(o, 3 * (size_t)tv[i] + (size_t)corner_of(o, tv[i], u));
    }
  }
  if (!uvu) return 0;
  for (int i = 0; i < nv; i++) {
    if (*on_edge >> i & 1) continue;
    double before, after;
    uv_areas(o, tv[i], kv[i], uvu, &before, &after);
    if (!(after > 1e-3 * before)) return 0;
  }
  /* v's neighbours (its fan is closed: each is one triangle's next
   * corner), and how many of them u's triangles hold */
  *held = 0;
  for (int i = 0; i < nv; i++) {
    int k = kv[i], w = o->tri[3 * (size_t)tv[i] + (size_t)(k == 2 ? 0 : k + 1)];
    if (w == u) continue;
    for (int j = 0; j < nu; j++) {
      const int *d = &o->tri[3 * (size_t)tu[j]];
      if (d[0] == w || d[1] == w || d[2] == w) {
        shared++;
        *held |= (uint32_t)1 << i;
        break;
      }
    }
  }
  if (shared != 2) return 0;
  for (int i = 0; i < nv; i++) {
    if (*on_edge >> i & 1) continue;
    double n0[3], n1[3];
    tri_normal(o, tv[i], -1, 0, n0);
    tri_normal(o, tv[i], kv[i], u, n1);
    if (!(ch_dot3(n0, n1) > 0.94 * sqrt(ch_dot3(n0, n0) * ch_dot3(n1, n1)))) return 0;
  }
  return 1;
}

/* Vertex v's shortest edge squared as a collapse candidate, INFINITY
 * where v is not inside a plain piece: one piece, off UV seams (one UV in
 * every triangle), its triangles one closed fan (each next corner is
 * another's previous once). *crosses: whether a neighbour is in another
 * slab (then v is no candidate in this one; where `slabbed` the answer
 * is then INFINITY at once). */
static double candidate(const ch_cut_out *o, const vertex_fans *f, int v, int slabbed, int *crosses) {
  int n = f->count[v], cross = 0;
  *crosses = 0;
  if (n < 3 || n > 32) return INFINITY;
  const int *ts = fan(f, v);
  uint64_t group = o->group[ts[0]];
  if (!plain(group)) return INFINITY;
  const double *uv0 = ch_cut_out_uv(o, 3 * (size_t)ts[0] + (size_t)corner_of(o, ts[0], v)),
               *pv = &o->pos[3 * (size_t)v];
  /* (prev padded to whole vectors with -1, no vertex, for the count) */
  int next[32], prev[32], n4 = (n + 3) & ~3;
  double shortest = INFINITY;
  for (int i = 0; i < n; i++) {
    int t = ts[i];
    const int *c = &o->tri[3 * (size_t)t];
    int k = c[0] == v ? 0 : c[1] == v ? 1 : 2; /* (v is one of them) */
    if (o->group[t] != group) return INFINITY;
    const double *uv = ch_cut_out_uv(o, 3 * (size_t)t + (size_t)k);
    if (uv[0] != uv0[0] || uv[1] != uv0[1]) return INFINITY;
    next[i] = c[k == 2 ? 0 : k + 1];
    prev[i] = c[k == 0 ? 2 : k - 1];
    if (f->region[next[i]] != f->region[v]) {
      cross = 1;
      if (slabbed) {
        *crosses = 1;
        return INFINITY;
      }
    }
    double d = dist2(pv, &o->pos[3 * (size_t)next[i]]);
    shortest = d < shortest ? d : shortest;
  }
  for (int j = n; j < n4; j++) prev[j] = -1;
  for (int i = 0; i < n; i++) {
    int m = 0, w = next[i];
#pragma omp simd reduction(+ : m)
    for (int j = 0; j < n4; j++) m += prev[j] == w;
    if (m != 1) return INFINITY;
  }
  *crosses = cross;
  return shortest;
}

/* Vertex v's shortest edge squared and *crosses as candidate() finds
 * them, where v is one. */
static double shortest_edge(const ch_cut_out *o, const vertex_fans *f, int v, int *crosses) {
  const int *ts = fan(f, v);
  const double *p = &o->pos[3 * (size_t)v];
  double shortest = INFINITY;
  int cross = 0;
  for (int i = 0; i < f->count[v]; i++) {
    const int *c = &o->tri[3 * (size_t)ts[i]];
    int w = c[c[0] == v ? 1 : c[1] == v ? 2 : 0];
    cross |= f->region[w] != f->region[v];
    double d = dist2(p, &o->pos[3 * (size_t)w]);
    shortest = d < shortest ? d : shortest;
  }
  *crosses = cross;
  return shortest;
}

/* Whether a neighbour of v (a candidate: its fan closed) is in another
 * slab: candidate()'s *crosses. */
static int crosses_slab(const ch_cut_out *o, const vertex_fans *f, int v) {
  const int *ts = fan(f, v);
  for (int i = 0; i < f->count[v]; i++) {
    const int *c = &o->tri[3 * (size_t)ts[i]];
    int k = c[0] == v ? 0 : c[1] == v ? 1 : 2;
    if (f->region[c[k == 2 ? 0 : k + 1]] != f->region[v]) return 1;
  }
  return 0;
}

/* Drops triangle t from vertex w's fan (keeping its order). */
static void fan_drop(vertex_fans *f, int w, int t) {
  int *ts = fan(f, w), n = f->count[w], j = 0;
  for (int i = 0; i < n; i++)
    if (ts[i] != t) ts[j++] = ts[i];
  f->count[w] = j;
}

/* Collapses v into u: the two triangles on edge u-v go (first corner -1,
 * out of their corners' fans), v's others take u (and its UV in this
 * chart) in v's place and join u's fan, in triangle order, in u's slab's
 * store. kv and on_edge: collapse_ok's. Returns the triangles removed, -1
 * when out of memory. Touches only v's fan, its triangles and its
 * neighbours' fans. */
static int collapse_apply(ch_cut_out *o, vertex_fans *f, int v, int u, const int *kv, uint32_t on_edge) {
  int in = (f->phase & 1) * COARSEN_REGIONS + f->region[u];
  fan_store *store = &f->more[in];
  int nv = f->count[v], ne = 0;
  for (int j = 0; j < nv; j++) ne += on_edge >> j & 1;
  /* u's fan and v's kept triangles, less those on edge u-v (which leave
   * u's fan too) */
  size_t need = (size_t)(f->count[u] - ne) + (size_t)(nv - ne), at = store->len;
  if (at + need > store->cap) { /* (before any pointer into the store is taken) */
    size_t cap = (at + need) + (at + need) / 2 + 1024;
    if (f->len + cap >= INT32_MAX) return -1;
    int *p = realloc(store->tri, cap * sizeof *p);
    if (!p) return -1;
    store->tri = p;
    store->cap = cap;
  }
  int removed = 0;
  const int *tv = fan(f, v);
  int ref = 0; /* u's UV in this chart: its corner_uv entry */
  for (int j = 0; j < nv; j++)
    if (on_edge >> j & 1) {
      ref = o->corner_uv[3 * (size_t)tv[j] + (size_t)corner_of(o, tv[j], u)];
      break;
    }
  int kept[32], nk = 0;
  for (int j = 0; j < nv; j++) {
    int t = tv[j];
    if (on_edge >> j & 1) {
      for (int a = 0; a < 3; a++) {
        int w = o->tri[3 * (size_t)t + a];
        if (w != v) fan_drop(f, w, t);
      }
      o->tri[3 * (size_t)t] = -1; /* removed */
      removed++;
      continue;
    }
    o->tri[3 * (size_t)t + kv[j]] = u;
    o->corner_uv[3 * (size_t)t + (size_t)kv[j]] = ref;
    kept[nk++] = t;
  }
  /* u's fan and v's kept triangles, merged in triangle order */
  const int *tu = fan(f, u);
  int nu = f->count[u], i = 0, j = 0, *out = &store->tri[at];
  for (int m = 0; m < nu + nk; m++) out[m] = j >= nk || (i < nu && tu[i] < kept[j]) ? tu[i++] : kept[j++];
  store->len += need;
  f->start[u] = (int)(f->len + at);
  f->store[u] = (unsigned char)in;
  f->count[u] = nu + nk;
  f->count[v] = 0;
  return removed;
}

/* The collapse candidates, an indexed 4-ary min-heap by (length2, v),
 * the keys in it (read in place, not through the vertex): at[v] is v's
 * place in it, -1 when out (not a candidate, or no collapse allowed until
 * its fan changes). A vertex's key changes in place. The keys are
 * distinct, so any heap of them takes the vertices out in the same order.
 * unslabbed keeps candidate() of every vertex as its fan is now, its slab
 * aside (NAN: not known, a neighbour was in another slab): only a
 * collapse's vertex and its neighbours change it, so with the next
 * phase's slabs the others need only their neighbours' slabs read. */
typedef struct cand_item {
  double length2;
  int v;
} cand_item;

typedef struct cand_heap {
  cand_item *e;      /* the heap */
  double *unslabbed; /* per vertex */
  int *at;           /* per vertex */
  int n;
} cand_heap;

static int item_less(cand_item a, cand_item b) {
  return a.length2 < b.length2 || (a.length2 == b.length2 && a.v < b.v);
}

static void heap_place(cand_heap *h, int i, cand_item x) {
  h->e[i] = x;
  h->at[x.v] = i;
}

/* Puts x at place i or above (the places above i hold no larger key). */
static void heap_up(cand_heap *h, int i, cand_item x) {
  while (i > 0 && item_less(x, h->e[(i - 1) / 4])) {
    heap_place(h, i, h->e[(i - 1) / 4]);
    i = (i - 1) / 4;
  }
  heap_place(h, i, x);
}

/* Puts x at place i or below. */
static void heap_down(cand_heap *h, int i, cand_item x) {
  for (;;) {
    int c = 4 * i + 1, m = c, end = c + 4 < h->n ? c + 4 : h->n;
    if (c >= h->n) break;
    for (int j = c + 1; j < end; j++)
      if (item_less(h->e[j], h->e[m])) m = j;
    if (!item_less(h->e[m], x)) break;
    heap_place(h, i, h->e[m]);
    i = m;
  }
  heap_place(h, i, x);
}

/* Puts x at place i, up or down from there. */
static void heap_fix(cand_heap *h, int i, cand_item x) {
  if (i > 0 && item_less(x, h->e[(i - 1) / 4]))
    heap_up(h, i, x);
  else
    heap_down(h, i, x);
}

/* Takes v out of the heap (if in). */
static void heap_remove(cand_heap *h, int v) {
  int i = h->at[v];
  if (i < 0) return;
  h->at[v] = -1;
  if (i == --h->n) return;
  heap_fix(h, i, h->e[h->n]); /* the last, in v's place */
}

/* Sets v's key (INFINITY: out of the heap). */
static void heap_set(cand_heap *h, int v, double length2) {
  if (!(length2 < INFINITY)) {
    heap_remove(h, v);
    return;
  }
  cand_item x = {length2, v};
  if (h->at[v] < 0)
    heap_up(h, h->n++, x);
  else
    heap_fix(h, h->at[v], x);
}

/* Slab r's greedy order until it has removed `budget` triangles (less
 * one) or has no candidate left: the vertex with the shortest edge
 * collapses along its shortest allowed edge, and its neighbours, whose
 * fans and edges changed, are weighed again. Returns the triangles
 * removed, -1 when out of memory. */
static long coarsen_region(ch_cut_out *o, vertex_fans *f, cand_heap *heap, int *remap, long budget) {
  long removed = 0;
  while (removed + 1 < budget && heap->n > 0) {
    int v = heap->e[0].v;
    heap_remove(heap, v);
    /* its edges shortest first (ties: the lower vertex), the first
     * allowed; ia: where each is in v's fan, kv: v's corner there */
    int n = f->count[v], us[32], ia[32], kv[32], u = -1;
    uint32_t on_edge = 0, held = 0;
    double ls[32];
    const int *tv = fan(f, v);
    for (int a = 0; a < n; a++) {
      const int *c = &o->tri[3 * (size_t)tv[a]];
      kv[a] = c[0] == v ? 0 : c[1] == v ? 1 : 2;
      us[a] = c[kv[a] == 2 ? 0 : kv[a] + 1];
      ls[a] = dist2(&o->pos[3 * (size_t)v], &o->pos[3 * (size_t)us[a]]);
      ia[a] = a;
    }
    for (int a = 1; a < n; a++)
      for (int b = a; b > 0 && (ls[b] < ls[b - 1] || (ls[b] == ls[b - 1] && us[b] < us[b - 1])); b--) {
        double tl = ls[b];
        int tu = us[b], ti = ia[b];
        ls[b] = ls[b - 1], us[b] = us[b - 1], ia[b] = ia[b - 1];
        ls[b - 1] = tl, us[b - 1] = tu, ia[b - 1] = ti;
      }
    for (int a = 0; a < n && u < 0; a++)
      if (collapse_ok(o, f, v, us[a], kv, &on_edge, &held)) u = us[a];
    if (u < 0) continue; /* (weighed again if its fan changes) */
    int gone = collapse_apply(o, f, v, u, kv, on_edge);
    if (gone < 0) return -1;
    removed += gone;
    remap[v] = -1;
    heap->unslabbed[v] = INFINITY; /* (its fan is empty) */
    /* v's neighbours (u among them): their fans or edges changed. Those
     * in none of u's triangles (collapse_ok's *held) keep their
     * triangles, UVs and fan structure, with u in v's place (a name they
     * did not hold): of candidate() only their edges change, and only
     * their edge to v (v is the next corner of one of their triangles:
     * each is the previous corner of one of v's), now to u. */
    for (int a = 0; a < n; a++) {
      int w = us[a], cross;
      double l = heap->unslabbed[w];
      if (w != u && !(held >> ia[a] & 1) && !isnan(l)) {
        if (!(l < INFINITY)) continue; /* (no candidate before, none now) */
        const double *pw = &o->pos[3 * (size_t)w];
        if (heap->at[w] >= 0 && l < dist2(pw, &o->pos[3 * (size_t)v])) {
          /* (in the heap: its slab holds its neighbours) the shortest is
           * another edge, still there */
          double d = dist2(pw, &o->pos[3 * (size_t)u]);
          l = heap->unslabbed[w] = d < l ? d : l;
          heap_set(heap, w, l);
          continue;
        }
        l = heap->unslabbed[w] = shortest_edge(o, f, w, &cross);
        heap_set(heap, w, cross ? INFINITY : l);
      } else {
        l = candidate(o, f, w, 1, &cross);
        heap->unslabbed[w] = cross ? NAN : l;
        heap_set(heap, w, l);
      }
    }
  }
  return removed;
}

/* The triangles' blocks in the compaction: each gathers its kept ones from
 * where those of the blocks before it end (the same on any number of
 * threads). */
enum { COMPACT_BLOCKS = 256 };

static size_t block_at(size_t n, int b) { return (size_t)b * n / COMPACT_BLOCKS; }

/* Each in place on one thread, side by side: the vertices
 * (ch_cut_out_move_vertex), and the triangles' groups and UV references
 * with where each block's kept triangles start; then all threads gather
 * the triangles, their corners renumbered, into tri, or with tri NULL in
 * place: each block to the front of its own range, in parallel, then the
 * blocks to where they go, one after the other (a gather in place on
 * several threads would overwrite what another has still to read; a new
 * array is fresh memory, 26 MB at 2.1M triangles, whose first touch cost
 * more than the moves). Two or three parallel regions: on a busy machine
 * each costs about a time slice. */
void ch_cut_out_compact(ch_cut_out *o, int *remap, int *tri) {
  size_t np = (size_t)o->npos, nt = (size_t)o->ntri;
  int nv = 0, toff[COMPACT_BLOCKS + 1];
#pragma omp parallel sections
  {
#pragma omp section
    for (size_t v = 0; v < np; v++)
      if (remap[v] >= 0) {
        remap[v] = nv;
        ch_cut_out_move_vertex(o, nv++, (int)v);
      }
#pragma omp section
    {
      size_t to = 0;
      toff[0] = 0;
      for (int b = 0; b < COMPACT_BLOCKS; b++) {
        for (size_t t = block_at(nt, b); t < block_at(nt, b + 1); t++) {
          if (o->tri[3 * t] < 0) continue;
          if (to != t) {
            o->group[to] = o->group[t];
            memcpy(&o->corner_uv[3 * to], &o->corner_uv[3 * t], 3 * sizeof *o->corner_uv);
          }
          to++;
        }
        toff[b + 1] = (int)to;
      }
    }
  }
  /* each block's kept triangles, renumbered, to where they go in tri, or
   * in place to the front of its own range */
  int *dest = tri ? tri : o->tri;
#pragma omp parallel for schedule(static)
  for (int b = 0; b < COMPACT_BLOCKS; b++)
    for (size_t t = block_at(nt, b), to = tri ? (size_t)toff[b] : block_at(nt, b); t < block_at(nt, b + 1); t++)
      if (o->tri[3 * t] >= 0) {
        for (int k = 0; k < 3; k++) dest[3 * to + (size_t)k] = remap[o->tri[3 * t + (size_t)k]];
        to++;
      }
  if (tri) {
    free(o->tri);
    o->tri = tri;
    o->cap_tri = o->ntri; /* (what tri holds) */
  } else {
    /* (toff[b] <= block b's start, and block b + 1 starts past toff[b + 1]) */
    for (int b = 1; b < COMPACT_BLOCKS; b++)
      memmove(&o->tri[3 * (size_t)toff[b]], &o->tri[3 * block_at(nt, b)],
              3 * (size_t)(toff[b + 1] - toff[b]) * sizeof *o->tri);
  }
  o->npos = nv;
  o->ntri = toff[COMPACT_BLOCKS];
}

static long coarsen_greedy(ch_cut_out *o, long fewer) {
  long removed = 0;
  size_t np = (size_t)(o->npos > 0 ? o->npos : 1);
  vertex_fans f = {0};
  double *length2 = ch_alloc_large(np, sizeof *length2, 0), *unslabbed = ch_alloc_large(np, sizeof *unslabbed, 0);
  int *at = ch_alloc_large(2 * np, sizeof *at, 0), *remap = at ? at + np : NULL; /* (one block) */
  cand_item *items = ch_alloc_large(np, sizeof *items, 0);
  if (!length2 || !unslabbed || !at || !items || !remap || fans_build(o, &f)) {
    removed = -1;
    goto done;
  }
#pragma omp parallel for schedule(static)
  for (int v = 0; v < o->npos; v++) {
    remap[v] = v;
    items[v] = (cand_item){INFINITY, v}; /* (its pages faulted in parallel: the heaps fill on one thread) */
  }
  /* Every vertex inside a plain piece by its shortest edge (in parallel),
   * then in each slab shortest first, one at a time (the greedy order of
   * Garland and Heckbert 1997, with edge length for the cost), the slabs
   * side by side. (Collapsing in rounds of collapses that share no fan, in
   * parallel, rescanned every candidate each round for the one in nine a
   * round could take; one greedy order over the whole mesh ran alone on
   * one core, about 1.5 us a collapse.) */
  for (int phase = 0; phase < 4 && removed + 1 < fewer; phase++) {
    f.phase = phase;
    assign_slabs(o, &f, phase & 1 ? 0.5 : 0.0);
    long blocked = 0; /* candidates but for their slab */
#pragma omp parallel for schedule(static) reduction(+ : blocked)
    for (int v = 0; v < o->npos; v++) {
      if (phase == 0 || isnan(unslabbed[v])) {
        int cross;
        unslabbed[v] = candidate(o, &f, v, 0, &cross);
        blocked += cross && unslabbed[v] < INFINITY;
        length2[v] = cross ? INFINITY : unslabbed[v];
      } else {
        length2[v] = unslabbed[v] < INFINITY && !crosses_slab(o, &f, v) ? unslabbed[v] : INFINITY;
      }
      at[v] = -1;
    }
    /* Each slab's heap in its own part of items. */
    cand_heap heap[COARSEN_REGIONS];
    long in_region[COARSEN_REGIONS] = {0}, candidates = 0;
    for (int v = 0; v < o->npos; v++) in_region[f.region[v]]++;
    for (int r = 0, first = 0; r < COARSEN_REGIONS; r++) {
      heap[r] = (cand_heap){.e = items + first, .unslabbed = unslabbed, .at = at, .n = 0};
      first += (int)in_region[r];
    }
    for (int v = 0; v < o->npos; v++)
      if (length2[v] < INFINITY) heap_place(&heap[f.region[v]], heap[f.region[v]].n++, (cand_item){length2[v], v});
    for (int r = 0; r < COARSEN_REGIONS; r++) {
      for (int i = heap[r].n > 1 ? (heap[r].n - 2) / 4 + 1 : 0; i-- > 0;) heap_down(&heap[r], i, heap[r].e[i]);
      candidates += heap[r].n;
    }
    /* The first slabs leave the share of the vertices on their borders to
     * the shifted ones (where the shortest edges are then theirs, as in one
     * greedy order over all); the phases alternate (four at most) while
     * collapses are left to do and allowed. Within a phase the slabs take
     * their shares, and what one could not take goes to the others' (three
     * times at most); what the shares' rounding left is then taken slab
     * after slab. */
    long goal = phase == 0 && candidates + blocked > 0
                    ? (long)((double)fewer * (double)candidates / (double)(candidates + blocked))
                    : fewer;
    for (int pass = 0; pass < 3 && removed + 1 < goal && candidates > 0; pass++) {
      long share[COARSEN_REGIONS], got[COARSEN_REGIONS], left = goal - removed, given = 0;
      int oom = 0;
      /* The shares: each slab's of the shortest edges one greedy order
       * over all would collapse first (a collapse takes two triangles). */
      long k = left / 2 < candidates ? left / 2 : candidates;
      for (long i = 0, r = 0; r < COARSEN_REGIONS; r++)
        for (int j = 0; j < heap[r].n; j++) length2[i++] = heap[r].e[j].length2; /* (free till the next phase) */
      double cut = k > 0 ? ch_sort_select(length2, candidates, k - 1) : -INFINITY;
      for (int r = 0; r < COARSEN_REGIONS; r++) {
        long below = 0;
        for (int j = 0; j < heap[r].n; j++) below += heap[r].e[j].length2 <= cut;
        share[r] = 2 * below;
        given += share[r];
      }
      if (given > left) /* (ties at the cut) */
        for (int r = 0; r < COARSEN_REGIONS; r++) share[r] = (long)((double)share[r] * (double)left / (double)given);
      /* A slab takes nothing below two triangles, and then neither would
       * the next pass (the same shares): no parallel region for none (on
       * a busy machine one waits for a time slice) */
      int some = 0;
      for (int r = 0; r < COARSEN_REGIONS; r++) some |= share[r] >= 2;
      if (!some) break;
#pragma omp parallel for schedule(dynamic, 1) reduction(| : oom)
      for (int r = 0; r < COARSEN_REGIONS; r++) {
        got[r] = coarsen_region(o, &f, &heap[r], remap, share[r]);
        oom |= got[r] < 0;
      }
      if (oom) {
        removed = -1;
        goto done;
      }
      candidates = 0;
      for (int r = 0; r < COARSEN_REGIONS; r++) {
        removed += got[r];
        candidates += heap[r].n;
      }
    }
    for (int r = 0; r < COARSEN_REGIONS && removed + 1 < goal; r++) {
      long got = coarsen_region(o, &f, &heap[r], remap, goal - removed);
      if (got < 0) {
        removed = -1;
        goto done;
      }
      removed += got;
    }
  }
  ch_cut_out_compact(o, remap, f.tri);
  f.tri = NULL; /* (now o's) */
done:
  free(length2), free(unslabbed), free(at), free(items); /* (at: and remap) */
  fans_free(&f);
  return removed;
}

long ch_cut_coarsen(ch_cut_out *o, long fewer, long *merged_out) {
  long merged = ch_cut_merge_blocks(o, fewer);
  ch_cut_blocks_free(&o->blocks);
  if (merged < 0) return -1;
  if (merged_out) *merged_out = merged;
  if (merged + 1 >= fewer) return merged;
  long removed = coarsen_greedy(o, fewer - merged);
  return removed < 0 ? -1 : merged + removed;
}
