/* ch_densify: more triangles away from the grooves and walls, after the
 * cut (see ch_cut_internal.h).
 *
 * Where a run of the embedding falls short of its target (its base count
 * came from a model of what the features add), the rest goes to the parts
 * of the mesh where h is smooth, rather than to a run at a larger base
 * that cuts every feature again: there a
 * triangle's longest edge is split where it is also the longest of the
 * triangle across it (longest-edge bisection on terminal edges, Rivara
 * 1984), longest edges first. On a tessellation of quads cut in two that
 * splits the diagonals, then the quads' sides (a 4-8 mesh), so the
 * triangles keep their shapes and no vertex hangs in another's edge. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ch_cut_internal.h"
#include "ch_embed_internal.h"
#include "ch_height.h"
#include "ch_math.h"

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
  double d[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  return ch_dot3(d, d);
}

/* A piece where h is h_step alone (no groove, not a wall): smooth inside,
 * so h at a new point inside it is h there. */
static int plain(uint64_t group) { return group != WALL_GROUP && (group >> 32) == 0; }

/* Twice triangle t's area, squared. */
static double area2(const ch_cut_out *o, size_t t) {
  const double *a = &o->pos[3 * (size_t)o->tri[3 * t]], *b = &o->pos[3 * (size_t)o->tri[3 * t + 1]];
  const double *c = &o->pos[3 * (size_t)o->tri[3 * t + 2]];
  double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]}, x[3];
  ch_cross3(u, w, x);
  return ch_dot3(x, x);
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
  const double *c = &o->uv[6 * t + 2 * (size_t)k];
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
        grow((void **)&o->uv, 6 * nt, sizeof *o->uv)) {
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
      o->face[m] = o->face[a];
      for (int j = 0; j < 2; j++) o->st[2 * m + j] = 0.5 * (o->st[2 * (size_t)a + j] + o->st[2 * (size_t)b + j]);
      ch_surface_point sp;
      if (ch_surface_eval(surface, o->face[m], o->st[2 * m], o->st[2 * m + 1], &sp)) {
        failed = 1;
        continue;
      }
      o->h[m] = ch_height_eval(height, sp.uv[0], sp.uv[1]);
      for (int j = 0; j < 3; j++) o->pos[3 * m + j] = sp.position[j] + o->h[m] * sp.normal[j];
      double ua[2], ub[2], uc[2], ud[2];
      memcpy(ua, &o->uv[6 * tx + 2 * (size_t)kx], sizeof ua);
      memcpy(ub, &o->uv[6 * tx + 2 * (size_t)((kx + 1) % 3)], sizeof ub);
      memcpy(uc, &o->uv[6 * tx + 2 * (size_t)((kx + 2) % 3)], sizeof uc);
      memcpy(ud, &o->uv[6 * ty + 2 * (size_t)((ky + 2) % 3)], sizeof ud);
      size_t n1 = (size_t)o->ntri + 2 * (size_t)i, n2 = n1 + 1;
      int *T = o->tri;
      double *U = o->uv;
      T[3 * tx] = a, T[3 * tx + 1] = (int)m, T[3 * tx + 2] = c;
      T[3 * ty] = b, T[3 * ty + 1] = (int)m, T[3 * ty + 2] = d;
      T[3 * n1] = (int)m, T[3 * n1 + 1] = b, T[3 * n1 + 2] = c;
      T[3 * n2] = (int)m, T[3 * n2 + 1] = a, T[3 * n2 + 2] = d;
      const double *corners[4][3] = {{ua, sp.uv, uc}, {ub, sp.uv, ud}, {sp.uv, ub, uc}, {sp.uv, ua, ud}};
      size_t which[4] = {tx, ty, n1, n2};
      for (int q = 0; q < 4; q++)
        for (int k = 0; k < 3; k++) memcpy(&U[6 * which[q] + 2 * (size_t)k], corners[q][k], 2 * sizeof *U);
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
