/* Thinning the bands of a layered cut by half-edge collapses (see
 * ch_thin.h). Greedy, as in mesh decimation (Hoppe et al. 1993, Garland
 * and Heckbert 1997), but with no error quadric: which collapses are
 * allowed is decided by the bands' structure and the caller's edge test,
 * and among the allowed ones the first wins (for a vertex inside a layer,
 * the nearest neighbour). */
#include "ch_thin.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "ch_math.h"

enum { MAX_RING = 48, PASSES = 3, TILE_EDGES = 32 };

typedef struct thin {
  int *tri;
  int *corner_uv; /* per corner: -1 (its vertex's UV) or an index into extra_uv */
  const double *vertex_uv, *extra_uv;
  const ch_thin_rules *rules;
  int *family, *layer;   /* per triangle */
  int *head, *next;      /* per vertex its corners (3 t + k), linked; dead triangles' too */
  unsigned char *dead;   /* per triangle */
  int64_t *key;          /* per vertex: the line it lies on, or -1 */
  int *stamp;            /* per vertex: = generation while it is a marked neighbour */
  int *tile;             /* per vertex: its tile of UV (see ch_thin_bands) */
  unsigned char *deferred; /* per vertex: its collapse reached beyond its tile */
  /* Alone on its cache line: every thread increments it for every
   * candidate, and the pointers above are read all the time. */
  _Alignas(64) int generation;
} thin;

static const double *uv_at(const thin *th, int c) {
  int x = th->corner_uv[c];
  return x < 0 ? &th->vertex_uv[2 * (size_t)th->tri[c]] : &th->extra_uv[2 * (size_t)x];
}

/* The ring of v: its live triangles with the corner after v (nxt) and the
 * one before (prv), counter-clockwise, and the UVs the triangles give them
 * (their first corners of that vertex: looked up once here, as the tests
 * read them again and again). Returns their number, -1 if above MAX_RING. */
typedef struct ring {
  int n;
  int tri[MAX_RING], corner[MAX_RING];
  int nxt[MAX_RING], prv[MAX_RING];
  int cnxt[MAX_RING];                            /* nxt's corner */
  const double *unxt[MAX_RING], *uprv[MAX_RING]; /* nxt's and prv's UVs */
  /* of a closed fan (closed_fan, collapse_vertex): */
  int back[MAX_RING];      /* the triangle with nxt[i] before v */
  double before[MAX_RING]; /* the triangle's doubled area in UV */
  int64_t line[MAX_RING];  /* nxt's and prv's common key, or -1 */
} ring;

/* The first corner of t holding the vertex of its corner k. */
static int first_corner(const thin *th, int t, int k) {
  const int *c = &th->tri[3 * t];
  return 3 * t + (c[0] == c[k] ? 0 : c[1] == c[k] ? 1 : k);
}

static int gather_ring(const thin *th, int v, ring *r) {
  r->n = 0;
  for (int c = th->head[v]; c >= 0; c = th->next[c]) {
    int t = c / 3, k = c % 3;
    if (th->dead[t]) continue;
    if (r->n == MAX_RING) return -1;
    int k1 = k == 2 ? 0 : k + 1, k2 = k == 0 ? 2 : k - 1;
    r->tri[r->n] = t;
    r->corner[r->n] = c;
    r->nxt[r->n] = th->tri[3 * t + k1];
    r->prv[r->n] = th->tri[3 * t + k2];
    r->cnxt[r->n] = first_corner(th, t, k1);
    r->unxt[r->n] = uv_at(th, r->cnxt[r->n]);
    r->uprv[r->n] = uv_at(th, first_corner(th, t, k2));
    r->n++;
  }
  return r->n;
}

/* Whether the ring closes once around v: every neighbour follows one
 * triangle and precedes another, and none twice. (The neighbours after v
 * all differ and each comes before v somewhere: then, n of them in n
 * places, each exactly once.) Sets back. */
static int closed_fan(ring *r) {
  if (r->n < 3) return 0;
  for (int i = 0; i < r->n; i++) {
    for (int j = 0; j < i; j++)
      if (r->nxt[j] == r->nxt[i]) return 0;
    int j = 0;
    while (j < r->n && r->prv[j] != r->nxt[i]) j++;
    if (j == r->n) return 0;
    r->back[i] = j;
  }
  return 1;
}

static double cross2(const double o[2], const double a[2], const double b[2]) {
  return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
}

/* Marks w's neighbours through live triangles (stamp = a new generation,
 * returned). 0 if one lies outside tile `in` (when in >= 0). (Not w
 * itself: it lies in the tile and is never looked up.) */
static int mark_neighbours(thin *th, int w, int in) {
  int g;
#pragma omp atomic capture
  g = ++th->generation;
  for (int c = th->head[w]; c >= 0; c = th->next[c]) {
    int t = c / 3, k = c % 3;
    if (th->dead[t]) continue;
    int x = th->tri[3 * t + (k == 2 ? 0 : k + 1)], y = th->tri[3 * t + (k == 0 ? 2 : k - 1)];
    if (in >= 0 && (th->tile[x] != in || th->tile[y] != in)) return 0;
    th->stamp[x] = th->stamp[y] = g;
  }
  return g;
}

/* Collapses v into its neighbour w = r->nxt[iw] (r a closed fan) if
 * every rule allows it: 1; 0 if not; -1 if w's neighbours reach beyond
 * tile `in` (in >= 0: only what lies in one tile is touched, so tiles of
 * one colour run side by side). */
static int try_collapse(thin *th, int v, const ring *r, int iw, int family, int in) {
  int w = r->nxt[iw], jw = r->back[iw]; /* the triangles (v, w, .) and (v, ., w) */
  int y1 = r->prv[iw], y2 = r->nxt[jw];
  if (y1 == y2) return 0;
  int cw = r->cnxt[iw]; /* (w's UV in v's chart) */
  const double *uw = r->unxt[iw];
  int64_t kw = th->key[w];
  for (int i = 0; i < r->n; i++) { /* the new edges' lengths first: the cheapest test */
    int x = r->nxt[i];
    if (x == w || x == y1 || x == y2) continue;
    const double *ux = r->unxt[i], mid[2] = {0.5 * (ux[0] + uw[0]), 0.5 * (ux[1] + uw[1])};
    if (ch_dist2d(ux[0] - uw[0], ux[1] - uw[1]) > th->rules->max_edge(th->rules->ctx, mid)) return 0;
  }
  int g = mark_neighbours(th, w, in);
  if (!g) return -1;
  for (int i = 0; i < r->n; i++) {
    if (i == iw || i == jw) continue;
    int x = r->nxt[i];
    /* the link condition: w's only common neighbours with v are y1, y2 */
    if (x != y1 && x != y2 && th->stamp[x] == g) return 0;
    if (kw >= 0 && kw == r->line[i]) return 0; /* not along a line */
    /* keeps its orientation, and is not a needle of no angle */
    const double *ux = r->unxt[i], *uy = r->uprv[i];
    double after = cross2(uw, ux, uy);
    if (!(after * r->before[i] > 0.0)) return 0;
    double lx = ch_dist2d(ux[0] - uw[0], ux[1] - uw[1]), ly = ch_dist2d(uy[0] - uw[0], uy[1] - uw[1]);
    if (fabs(after) <= 1e-9 * lx * ly) return 0;
  }
  for (int i = 0; i < r->n; i++) { /* then the caller's tests, dearer */
    if (i == iw || i == jw) continue;
    int t = r->tri[i], x = r->nxt[i], y = r->prv[i];
    const int tv[3] = {w, x, y};
    const double *tuv[3] = {uw, r->unxt[i], r->uprv[i]};
    if (th->rules->triangle_ok && !th->rules->triangle_ok(th->rules->ctx, family, th->layer[t], tv, tuv)) return 0;
  }
  for (int i = 0; i < r->n; i++) {
    int x = r->nxt[i];
    if (x == w || x == y1 || x == y2) continue;
    if (!th->rules->edge_ok(th->rules->ctx, family, w, x, uw, r->unxt[i])) return 0;
  }
  int uw_ref = th->corner_uv[cw]; /* (v's corners take it: the same UV value) */
  th->dead[r->tri[iw]] = th->dead[r->tri[jw]] = 1;
  /* w's corners: its live ones, then v's (now w's); dead ones dropped */
  int head = -1, *tail = &head;
  for (int pass = 0; pass < 2; pass++)
    for (int c = pass ? th->head[v] : th->head[w], nx; c >= 0; c = nx) {
      nx = th->next[c];
      if (th->dead[c / 3]) continue;
      if (pass) {
        th->tri[c] = w;
        th->corner_uv[c] = uw_ref;
      }
      *tail = c;
      tail = &th->next[c];
    }
  *tail = -1;
  th->head[w] = head;
  th->head[v] = -1;
  return 1;
}

/* What ch_thin_bands gathers of a vertex's triangles for its key. */
typedef struct vertex_band {
  int n, f, lo, hi, other;
} vertex_band;

/* Classifies v: its family (or -1: it stays) and its lowest and highest
 * layer; whether its corners agree in UV. */
static int classify_vertex(const thin *th, const ring *r, int *lo, int *hi) {
  if (r->n < 3) return -1;
  int f = th->family[r->tri[0]];
  *lo = *hi = th->layer[r->tri[0]];
  const double *u0 = uv_at(th, r->corner[0]);
  for (int i = 0; i < r->n; i++) {
    int t = r->tri[i];
    if (th->family[t] != f || f < 0) return -1;
    if (th->layer[t] < *lo) *lo = th->layer[t];
    if (th->layer[t] > *hi) *hi = th->layer[t];
    /* A seam: the corners see it at other UVs. Not rounding: a boundary
     * point is interpolated along its edge from either end by the two
     * triangles sharing it. */
    const double *u = uv_at(th, r->corner[i]);
    if (!(fabs(u[0] - u0[0]) <= 1e-12 && fabs(u[1] - u0[1]) <= 1e-12)) return -1;
  }
  return *hi - *lo <= 1 ? f : -1;
}

/* The two neighbours of line vertex v along its line (the edges with
 * different layers on their two sides), as indices into closed fan r; 0
 * if not two. */
static int line_neighbours(const thin *th, const ring *r, int out[2]) {
  int nc = 0;
  for (int i = 0; i < r->n; i++)
    if (th->layer[r->tri[r->back[i]]] != th->layer[r->tri[i]]) {
      if (nc == 2) return 0;
      out[nc++] = i;
    }
  return nc == 2;
}

static void collapse_vertex(thin *th, int v, int *removed_count, unsigned char *removed, unsigned char *dirty,
                            int in) {
  ring r;
  int lo, hi;
  if (gather_ring(th, v, &r) < 0) return;
  for (int i = 0; i < r.n && in >= 0; i++)
    if (th->tile[r.nxt[i]] != in) {
      th->deferred[v] = 1;
      return;
    }
  int f = classify_vertex(th, &r, &lo, &hi);
  if (f < 0 || !closed_fan(&r)) return;
  /* what try_collapse tests of each triangle whatever the candidate */
  const double *u = uv_at(th, r.corner[0]);
  for (int i = 0; i < r.n; i++) {
    int64_t kx = th->key[r.nxt[i]];
    r.line[i] = kx == th->key[r.prv[i]] ? kx : -1;
    r.before[i] = cross2(u, r.unxt[i], r.uprv[i]);
  }
  int cand[MAX_RING], nc = 0; /* indices into r */
  if (hi > lo) {
    /* On line lo: it moves along the line, to one of the two neighbours
     * the line's edges lead to. */
    if (!line_neighbours(th, &r, cand)) return;
    nc = 2;
  } else {
    /* Inside a layer: to the nearest neighbour that works. */
    double d[MAX_RING];
    for (int i = 0; i < r.n; i++) {
      const double *ux = r.unxt[i];
      double di = ch_dist2d(ux[0] - u[0], ux[1] - u[1]);
      int j = nc++;
      while (j > 0 && d[j - 1] > di) {
        d[j] = d[j - 1];
        cand[j] = cand[j - 1];
        j--;
      }
      d[j] = di;
      cand[j] = i;
    }
  }
  for (int i = 0; i < nc; i++) {
    int done = try_collapse(th, v, &r, cand[i], f, in);
    if (done < 0) { /* left for the sequential sweep, in the same order */
      th->deferred[v] = 1;
      return;
    }
    if (done) {
      removed[v] = 1;
      (*removed_count)++;
      for (int j = 0; j < r.n; j++) dirty[r.nxt[j]] = 1; /* their rings changed */
      return;
    }
  }
}

/* Buckets the vertices with corners by tile of a side x side grid over
 * UV shifted by `shift` tiles (0, or 1/2 for the grid whose tiles are
 * centred on the other's corners): tile[v] (-1 for none), and each tile's
 * vertices in index order, list[start[i] ..]. start has side^2 + 1
 * entries. -1 when out of memory. */
static int bucket_tiles(const thin *th, int nv, int side, double tiles, double shift, int *tile, int *start,
                        int *list) {
  int ntiles = side * side;
  memset(start, 0, ((size_t)ntiles + 1) * sizeof *start);
  for (int v = 0; v < nv; v++) {
    tile[v] = -1;
    if (th->head[v] < 0) continue;
    const double *u = uv_at(th, th->head[v]);
    /* clamped as by fmin(side - 1, fmax(0, .)), without their calls */
    double fx = floor(u[0] * tiles + shift), fy = floor(u[1] * tiles + shift);
    fx = fx > 0.0 ? fx : 0.0;
    fy = fy > 0.0 ? fy : 0.0;
    int tx = (int)(fx < side - 1 ? fx : side - 1), ty = (int)(fy < side - 1 ? fy : side - 1);
    tile[v] = ty * side + tx;
    start[tile[v] + 1]++;
  }
  for (int i = 0; i < ntiles; i++) start[i + 1] += start[i];
  int *fill = calloc((size_t)ntiles, sizeof *fill);
  if (!fill) return -1;
  for (int v = 0; v < nv; v++)
    if (tile[v] >= 0) list[start[tile[v]] + fill[tile[v]]++] = v;
  free(fill);
  return 0;
}

/* One pass over a grid of side x side tiles (start and list as
 * bucket_tiles makes them, th->tile its tiles), the tiles of one colour
 * of a 2 x 2 checkerboard side by side, colour after colour: each tile's
 * vertices marked in want, in index order (unmarked first where clear is
 * set). Returns the vertices removed. */
static int sweep_tiles(thin *th, int side, const int *start, const int *list, unsigned char *want, int clear,
                       unsigned char *removed, unsigned char *dirty) {
  int count = 0;
  for (int colour = 0; colour < 4; colour++) {
    int added = 0;
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : added)
    for (int i = 0; i < side * side; i++) {
      int tx = i % side, ty = i / side;
      if ((tx & 1) + 2 * (ty & 1) != colour) continue;
      for (int k = start[i]; k < start[i + 1]; k++) {
        int v = list[k];
        if (!want[v]) continue;
        if (clear) want[v] = 0;
        if (!removed[v]) collapse_vertex(th, v, &added, removed, dirty, i);
      }
    }
    count += added;
  }
  return count;
}

int ch_thin_bands(int num_vertices, int *num_triangles, int *tri, int *corner_uv, const double *vertex_uv,
                  const double *extra_uv, uint64_t *group, const ch_thin_rules *rules, unsigned char *removed) {
  int nv = num_vertices, nt = *num_triangles;
  if (nv <= 0 || nt <= 0) return 0;
  thin th = {.tri = tri, .corner_uv = corner_uv, .vertex_uv = vertex_uv, .extra_uv = extra_uv, .rules = rules};
  unsigned char *dirty = NULL, *visit = NULL;
  int *tile_start = NULL, *tile_list = NULL, *tile2 = NULL, *tile2_start = NULL, *tile2_list = NULL;
  th.family = malloc((size_t)nt * sizeof *th.family);
  th.layer = malloc((size_t)nt * sizeof *th.layer);
  th.head = malloc((size_t)nv * sizeof *th.head);
  th.next = malloc(3 * (size_t)nt * sizeof *th.next);
  th.dead = calloc((size_t)nt, 1);
  th.key = malloc((size_t)nv * sizeof *th.key);
  th.stamp = calloc((size_t)nv, sizeof *th.stamp);
  dirty = calloc((size_t)nv, 1);
  visit = malloc((size_t)nv);
  th.tile = malloc((size_t)nv * sizeof *th.tile);
  th.deferred = calloc((size_t)nv, 1);
  int count = -1;
  if (!th.family || !th.layer || !th.head || !th.next || !th.dead || !th.key || !th.stamp || !dirty || !visit ||
      !th.tile || !th.deferred)
    goto done;
  count = 0;
  int any = 0;
  for (int t = 0; t < nt; t++) {
    th.layer[t] = 0;
    th.family[t] = rules->band(rules->ctx, group[t], &th.layer[t]);
    any |= th.family[t] >= 0;
  }
  if (!any) goto done;
  /* Keys: a vertex between layers k and k + 1 of family f lies on line k;
   * one between layer k and what is not f's (a rim) on that layer's edge.
   * Three corners with one key make a triangle along a line. Gathered
   * from the triangles, in the same sweep as the corner lists: its
   * corners' count, its family (-1 none yet, -2 two), lowest and highest
   * layer, and whether a triangle of none touches it. */
  vertex_band *vb = malloc((size_t)nv * sizeof *vb);
  if (!vb) {
    count = -1;
    goto done;
  }
  for (int v = 0; v < nv; v++) {
    th.head[v] = -1;
    vb[v] = (vertex_band){.f = -1};
  }
  for (int c = 3 * nt - 1; c >= 0; c--) { /* each list in corner order */
    int v = tri[c], f = th.family[c / 3], l = th.layer[c / 3];
    vertex_band *b = &vb[v];
    th.next[c] = th.head[v];
    th.head[v] = c;
    b->n++;
    if (f < 0)
      b->other = 1;
    else if (b->f == -1) {
      b->f = f;
      b->lo = b->hi = l;
    } else if (b->f != f)
      b->f = -2;
    else {
      b->lo = l < b->lo ? l : b->lo;
      b->hi = l > b->hi ? l : b->hi;
    }
  }
  for (int v = 0; v < nv; v++) {
    const vertex_band *b = &vb[v];
    int f = b->f, lo = b->lo, hi = b->hi, other = b->other;
    th.key[v] = -1;
    if (b->n > MAX_RING || f < 0) continue; /* (as the collapses skip a ring above MAX_RING) */
    if (!other && hi == lo + 1) th.key[v] = ((int64_t)f << 21) | ((int64_t)lo << 1);
    if (other && hi == lo) th.key[v] = ((int64_t)f << 21) | ((int64_t)lo << 1) | 1;
    /* Only a vertex inside one family's band, inside a layer or on a
     * line, ever moves (collapses keep every triangle's band). */
    dirty[v] = !other && hi <= lo + 1;
  }
  free(vb);
  /* Tiles of UV TILE_EDGES mean band edges wide (at most 64 a side),
   * coloured like a 2 x 2 checkerboard: tiles of one colour share no
   * triangle a collapse inside one of them touches, so they run side by
   * side; a collapse reaching into another tile is deferred to the same
   * on a second grid, whose tiles are centred on the first's corners, and
   * what reaches beyond those too to a sequential sweep in index order.
   * The result does not depend on the number of threads. A collapse
   * reaches two rings out, so tiles 8 edges wide left most of the work to
   * the sweep (plane + ornament at 130k: 45863 vertices deferred in the
   * first pass, of 93655; the sweeps 131 of the thinning's 221 ms); 32
   * edges wide, 13723 and 42 of 167 ms, with L1 and the normals within
   * 0.1% on the bundled sets (which collapses win changes with the tiles'
   * order). The second grid leaves 1161 of those 13723 to the sweep. */
  double sum = 0.0;
  long edges = 0;
  for (int t = 0; t < nt; t++)
    if (th.family[t] >= 0)
      for (int k = 0; k < 3; k++, edges++) {
        const double *a = uv_at(&th, 3 * t + k), *b = uv_at(&th, 3 * t + (k + 1) % 3);
        sum += ch_dist2d(b[0] - a[0], b[1] - a[1]);
      }
  int tiles = (int)fmin(64.0, fmax(2.0, floor(edges > 0 ? (double)edges / (TILE_EDGES * sum) : 2.0)));
  int ntiles = tiles * tiles, side2 = tiles + 1, ntiles2 = side2 * side2;
  tile_start = malloc(((size_t)ntiles + 1) * sizeof *tile_start);
  tile_list = malloc((size_t)nv * sizeof *tile_list);
  tile2 = malloc((size_t)nv * sizeof *tile2);
  tile2_start = malloc(((size_t)ntiles2 + 1) * sizeof *tile2_start);
  tile2_list = malloc((size_t)nv * sizeof *tile2_list);
  if (!tile_start || !tile_list || !tile2 || !tile2_start || !tile2_list ||
      bucket_tiles(&th, nv, tiles, tiles, 0.0, th.tile, tile_start, tile_list) ||
      bucket_tiles(&th, nv, side2, tiles, 0.5, tile2, tile2_start, tile2_list)) {
    count = -1;
    goto done;
  }
  int *tile1 = th.tile;
  /* Later passes revisit only the vertices whose rings changed. */
  for (int pass = 0; pass < PASSES; pass++) {
    int before = count;
    memcpy(visit, dirty, (size_t)nv);
    memset(dirty, 0, (size_t)nv);
    count += sweep_tiles(&th, tiles, tile_start, tile_list, visit, 0, removed, dirty);
    /* The vertices whose collapse reached beyond their tile, again on the
     * grid whose tiles are centred on the first's corners (where those
     * vertices mostly lie); the few reaching beyond these too go to the
     * sequential sweep. */
    th.tile = tile2;
    count += sweep_tiles(&th, side2, tile2_start, tile2_list, th.deferred, 1, removed, dirty);
    th.tile = tile1;
    for (int v = 0; v < nv; v++)
      if (th.deferred[v]) {
        th.deferred[v] = 0;
        if (!removed[v]) collapse_vertex(&th, v, &count, removed, dirty, -1);
      }
    if (count == before) break;
  }
  /* Compact the live triangles in order. */
  int n = 0;
  for (int t = 0; t < nt; t++) {
    if (th.dead[t]) continue;
    if (n != t) {
      for (int k = 0; k < 3; k++) {
        tri[3 * (size_t)n + k] = tri[3 * (size_t)t + k];
        corner_uv[3 * (size_t)n + k] = corner_uv[3 * (size_t)t + k];
      }
      group[n] = group[t];
    }
    n++;
  }
  *num_triangles = n;
done:
  free(th.family);
  free(th.layer);
  free(th.head);
  free(th.next);
  free(th.dead);
  free(th.key);
  free(th.stamp);
  free(dirty);
  free(visit);
  free(th.tile);
  free(th.deferred);
  free(tile_start);
  free(tile_list);
  free(tile2);
  free(tile2_start);
  free(tile2_list);
  return count;
}
