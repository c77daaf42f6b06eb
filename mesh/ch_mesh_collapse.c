/* Collapsing edges shorter than a tolerance, where doing so keeps the mesh
 * manifold (see ch_mesh.h). */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "ch_mesh.h"
#include "ch_sort.h"

typedef struct vlist {
  int *f; /* incident faces (may hold dead ones) */
  int n, cap;
} vlist;

static int vlist_push(vlist *l, int f) {
  if (l->n == l->cap) {
    int cap = l->cap ? 2 * l->cap : 8;
    int *p = realloc(l->f, (size_t)cap * sizeof *p);
    if (!p) return -1;
    l->f = p;
    l->cap = cap;
  }
  l->f[l->n++] = f;
  return 0;
}

static int cmp_pair(const void *x, const void *y) {
  const int *a = x, *b = y;
  return a[0] != b[0] ? (a[0] < b[0] ? -1 : 1) : a[1] != b[1] ? (a[1] < b[1] ? -1 : 1) : 0;
}

static int cmp_int(const void *x, const void *y) {
  int a = *(const int *)x, b = *(const int *)y;
  return a < b ? -1 : a > b;
}

/* Whether two triangles have the same three corners (in any order). */
static int same_corners(const int *c, const int *d) {
  int same = 1;
  for (int k = 0; k < 3; k++) same &= d[0] == c[k] || d[1] == c[k] || d[2] == c[k];
  return same;
}

/* Drops the faces marked in drop, their corners with them, keeping the
 * order of the others. */
static void drop_faces(ch_mesh *m, const unsigned char *drop) {
  int f2 = 0;
  for (int f = 0; f < m->num_faces; f++) {
    if (drop[f]) continue;
    for (int k = 0; k < 3; k++) {
      size_t from = 3 * (size_t)f + k, to = 3 * (size_t)f2 + k;
      m->corner_position[to] = m->corner_position[from];
      if (m->corner_uv) m->corner_uv[to] = m->corner_uv[from];
      if (m->corner_normal) m->corner_normal[to] = m->corner_normal[from];
    }
    f2++;
  }
  m->num_faces = f2;
  m->num_corners = 3 * f2;
  for (int f = 0; f <= f2; f++) m->face_start[f] = 3 * f;
}

/* The distinct live neighbours of v, sorted, into out (grown as needed). */
static int neighbours(const ch_mesh *m, const vlist *inc, const unsigned char *dead, int v, int **out, int *cap) {
  int n = 0;
  for (int i = 0; i < inc[v].n; i++) {
    int f = inc[v].f[i];
    if (dead[f]) continue;
    for (int k = 0; k < 3; k++) {
      int w = m->corner_position[3 * (size_t)f + k];
      if (w == v) continue;
      if (n + 1 > *cap) {
        int c = *cap ? 2 * *cap : 32;
        int *p = realloc(*out, (size_t)c * sizeof *p);
        if (!p) return -1;
        *out = p;
        *cap = c;
      }
      (*out)[n++] = w;
    }
  }
  qsort(*out, (size_t)n, sizeof **out, cmp_int);
  int u = 0;
  for (int i = 0; i < n; i++)
    if (u == 0 || (*out)[u - 1] != (*out)[i]) (*out)[u++] = (*out)[i];
  return u;
}

int ch_mesh_collapse_short_edges(ch_mesh *m, double eps) {
  if (m->num_faces == 0 || m->num_corners != 3 * m->num_faces || !(eps > 0.0)) return 0;
  int np = m->num_positions, nf = m->num_faces;
  const double *P = m->positions;
  /* Candidates: edges no longer than eps in every coordinate. */
  int (*cand)[2] = NULL;
  size_t nc = 0, cc = 0;
  for (int f = 0; f < nf; f++)
    for (int k = 0; k < 3; k++) {
      int a = m->corner_position[3 * (size_t)f + k], b = m->corner_position[3 * (size_t)f + (k + 1) % 3];
      const double *pa = &P[3 * (size_t)a], *pb = &P[3 * (size_t)b];
      if (a == b || fabs(pa[0] - pb[0]) > eps || fabs(pa[1] - pb[1]) > eps || fabs(pa[2] - pb[2]) > eps) continue;
      if (nc == cc) {
        size_t c = cc ? 2 * cc : 1024;
        void *p = realloc(cand, c * sizeof *cand);
        if (!p) {
          free(cand);
          return -1;
        }
        cand = p;
        cc = c;
      }
      cand[nc][0] = a < b ? a : b;
      cand[nc][1] = a < b ? b : a;
      nc++;
    }
  if (nc == 0) return 0;
  qsort(cand, nc, sizeof *cand, cmp_pair);
  /* Only the candidates' ends are ever read or merged into (map sends a
   * vertex to another end), so only theirs get incident faces: a list per
   * vertex of a mesh of millions took most of the time. */
  vlist *inc = calloc((size_t)np, sizeof *inc);
  unsigned char *dead = calloc((size_t)nf, 1), *end = calloc((size_t)np, 1);
  int *map = malloc((size_t)np * sizeof *map);
  int *na = NULL, *nb = NULL, capa = 0, capb = 0, collapsed = 0, oom = !inc || !dead || !map || !end;
  for (size_t i = 0; i < nc && !oom; i++) end[cand[i][0]] = end[cand[i][1]] = 1;
  for (int f = 0; f < nf && !oom; f++)
    for (int k = 0; k < 3 && !oom; k++) {
      int v = m->corner_position[3 * (size_t)f + k];
      if (end[v]) oom |= vlist_push(&inc[v], f);
    }
  for (int v = 0; v < np && !oom; v++) map[v] = v;
  for (size_t i = 0; i < nc && !oom; i++) {
    if (i > 0 && cand[i][0] == cand[i - 1][0] && cand[i][1] == cand[i - 1][1]) continue;
    /* An end already merged away: the edge now joins what it merged into
     * (several lines through one vertex leave several copies of it, and
     * the edge between two of them may exist only once a third is gone). */
    int a = cand[i][0], b = cand[i][1];
    while (map[a] != a) a = map[a];
    while (map[b] != b) b = map[b];
    if (a == b) continue;
    if (a > b) {
      int t = a;
      a = b;
      b = t;
    }
    /* Still an edge? And its opposite vertices. */
    int opp[4], nopp = 0, edge = 0;
    for (int j = 0; j < inc[b].n; j++) {
      int f = inc[b].f[j];
      if (dead[f]) continue;
      const int *c = &m->corner_position[3 * (size_t)f];
      if (c[0] != a && c[1] != a && c[2] != a) continue;
      edge = 1;
      int w = c[0] != a && c[0] != b ? c[0] : c[1] != a && c[1] != b ? c[1] : c[2];
      if (nopp < 4) opp[nopp] = w;
      nopp++;
    }
    if (!edge || nopp > 2) continue;
    /* Link condition: the common neighbours of a and b are exactly the
     * vertices opposite their edge, else the collapse pinches the mesh. */
    int ka = neighbours(m, inc, dead, a, &na, &capa), kb = neighbours(m, inc, dead, b, &nb, &capb);
    if (ka < 0 || kb < 0) {
      oom = 1;
      break;
    }
    int common = 0, ok = 1;
    for (int x = 0, y = 0; x < ka && y < kb;) {
      if (na[x] < nb[y]) {
        x++;
      } else if (na[x] > nb[y]) {
        y++;
      } else {
        int w = na[x];
        common++;
        if (!(w == opp[0] || (nopp > 1 && w == opp[1]))) ok = 0;
        x++;
        y++;
      }
    }
    if (!ok || common != nopp) continue;
    /* Nor may the two opposite vertices be joined in both a's and b's
     * link (faces a-w-x and b-w-x: a tetrahedron's corner, which the
     * collapse would flatten into a doubled face). In one link only it is
     * the link condition's allowed case: b of valence 3 inside a-w-x (a
     * line through a vertex leaves such a copy of it, with two zero-area
     * faces), whose collapse leaves the face w-x-a. */
    if (nopp == 2) {
      int joined = 0;
      for (int e = 0; e < 2; e++) {
        const vlist *l = &inc[e ? b : a];
        int here = 0;
        for (int j = 0; j < l->n && !here; j++) {
          int f = l->f[j];
          if (dead[f]) continue;
          const int *c = &m->corner_position[3 * (size_t)f];
          int hw = c[0] == opp[0] || c[1] == opp[0] || c[2] == opp[0];
          int hx = c[0] == opp[1] || c[1] == opp[1] || c[2] == opp[1];
          here = hw && hx;
        }
        joined += here;
      }
      if (joined == 2) continue;
    }
    /* And no face of b may become a copy of a face of a, or be one of
     * another face of b already (a fin: the embedding leaves a few such
     * pairs where features cross a UV seam; collapsing into one would make
     * its edges non-manifold). */
    int fin = 0;
    for (int j = 0; j < inc[b].n && !fin; j++)
      for (int j2 = j + 1; j2 < inc[b].n && !fin; j2++) {
        int f = inc[b].f[j], g = inc[b].f[j2];
        if (dead[f] || dead[g] || f == g) continue;
        fin = same_corners(&m->corner_position[3 * (size_t)f], &m->corner_position[3 * (size_t)g]);
      }
    for (int j = 0; j < inc[b].n && !fin; j++) {
      int f = inc[b].f[j];
      if (dead[f]) continue;
      const int *c = &m->corner_position[3 * (size_t)f];
      if (c[0] == a || c[1] == a || c[2] == a) continue;
      int u[3];
      for (int k = 0; k < 3; k++) u[k] = c[k] == b ? a : c[k];
      for (int i2 = 0; i2 < inc[a].n && !fin; i2++) {
        int g = inc[a].f[i2];
        if (dead[g]) continue;
        fin = same_corners(u, &m->corner_position[3 * (size_t)g]);
      }
    }
    if (fin) continue;
    /* Collapse b into a: its faces take a, those on the edge die. */
    for (int j = 0; j < inc[b].n && !oom; j++) {
      int f = inc[b].f[j];
      if (dead[f]) continue;
      int *c = &m->corner_position[3 * (size_t)f];
      int has_a = c[0] == a || c[1] == a || c[2] == a;
      if (has_a) {
        dead[f] = 1;
        continue;
      }
      for (int k = 0; k < 3; k++)
        if (c[k] == b) c[k] = a;
      oom |= vlist_push(&inc[a], f);
    }
    map[b] = a;
    collapsed++;
  }
  free(na);
  free(nb);
  free(cand);
  if (inc && end)
    for (int v = 0; v < np; v++)
      if (end[v]) free(inc[v].f);
  free(inc);
  free(end);
  if (oom) {
    free(dead);
    free(map);
    return -1;
  }
  if (collapsed) {
    /* Drop the dead faces and the unused positions, keeping the order of
     * everything else. */
    drop_faces(m, dead);
    int p2 = 0;
    for (int v = 0; v < np; v++) {
      if (map[v] != v) continue;
      memmove(&m->positions[3 * (size_t)p2], &m->positions[3 * (size_t)v], 3 * sizeof *m->positions);
      map[v] = p2++;
    }
    for (size_t c = 0; c < (size_t)m->num_corners; c++) m->corner_position[c] = map[m->corner_position[c]];
    m->num_positions = p2;
  }
  free(dead);
  free(map);
  return collapsed;
}

static int cmp_u64(const void *x, const void *y) {
  uint64_t a = *(const uint64_t *)x, b = *(const uint64_t *)y;
  return a < b ? -1 : a > b;
}

static uint64_t edge_key(int u, int v) {
  return u < v ? (uint64_t)u << 32 | (uint64_t)v : (uint64_t)v << 32 | (uint64_t)u;
}

/* Index of key in the sorted list, or -1. */
static long find_key(const uint64_t *keys, size_t n, uint64_t key) {
  size_t lo = 0, hi = n;
  while (lo < hi) {
    size_t mid = (lo + hi) / 2;
    if (keys[mid] < key)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo < n && keys[lo] == key ? (long)lo : -1;
}

/* Whether face b runs the corners of face a backwards. */
static int reversed(const int *a, const int *b) {
  int r = 0;
  while (r < 3 && b[r] != a[0]) r++;
  return r < 3 && b[(r + 1) % 3] == a[2] && b[(r + 2) % 3] == a[1];
}

/* The lowest of a face's three corners. */
static int lowest_corner(const int *c) {
  return c[0] < c[1] ? (c[0] < c[2] ? c[0] : c[2]) : (c[1] < c[2] ? c[1] : c[2]);
}

int ch_mesh_remove_pillows(ch_mesh *m) {
  if (m->num_faces == 0 || m->num_corners != 3 * m->num_faces) return 0;
  int nf = m->num_faces, np = m->num_positions;
  const int *cp = m->corner_position;
  /* Faces by their lowest corner: the two faces of a pillow share it, and
   * few faces do, so pairs are found in linear time. */
  int *start = malloc(((size_t)np + 1) * sizeof *start), *order = malloc((size_t)nf * sizeof *order);
  int *low = malloc((size_t)nf * sizeof *low), *partner = malloc((size_t)nf * sizeof *partner);
  int(*pairs)[2] = NULL;
  size_t npairs = 0;
  uint64_t *keys = NULL;
  long *uses = NULL;
  unsigned char *drop = NULL;
  int removed = -1;
  if (!start || !order || !low || !partner) goto done;
#pragma omp parallel for schedule(static)
  for (int f = 0; f < nf; f++) low[f] = lowest_corner(&cp[3 * (size_t)f]);
  if (ch_sort_buckets(low, (size_t)nf, np, start, order)) goto done;
  /* partner[f]: g > f where f and g are a pillow (exactly two faces on the
   * same corners, opposite), else -1 */
#pragma omp parallel for schedule(dynamic, 4096)
  for (int v = 0; v < np; v++)
    for (int i = start[v]; i < start[v + 1]; i++) {
      int f = order[i], twins = 0, g = -1;
      for (int j = start[v]; j < start[v + 1]; j++)
        if (j != i && same_corners(&cp[3 * (size_t)f], &cp[3 * (size_t)order[j]])) {
          twins++;
          g = order[j];
        }
      partner[f] = twins == 1 && g > f && reversed(&cp[3 * (size_t)f], &cp[3 * (size_t)g]) ? g : -1;
    }
  for (int f = 0; f < nf; f++) npairs += partner[f] >= 0;
  removed = 0;
  if (!npairs) goto done;
  removed = -1;
  pairs = malloc(npairs * sizeof *pairs);
  if (!pairs) goto done;
  npairs = 0;
  for (int f = 0; f < nf; f++)
    if (partner[f] >= 0) {
      pairs[npairs][0] = f;
      pairs[npairs][1] = partner[f];
      npairs++;
    }
  /* Removing a pair takes two uses from each of its edges: only if none is
   * left with one (a hole). Count the uses of just those edges. */
  size_t nk = 3 * npairs;
  keys = malloc(nk * sizeof *keys);
  uses = calloc(nk, sizeof *uses);
  drop = calloc((size_t)nf, 1);
  if (!keys || !uses || !drop) goto done;
  for (size_t i = 0; i < npairs; i++)
    for (int e = 0; e < 3; e++) {
      const int *a = &cp[3 * (size_t)pairs[i][0]];
      keys[3 * i + e] = edge_key(a[e], a[(e + 1) % 3]);
    }
  qsort(keys, nk, sizeof *keys, cmp_u64);
#pragma omp parallel for schedule(static)
  for (size_t c = 0; c < 3 * (size_t)nf; c++) {
    long at = find_key(keys, nk, edge_key(cp[c], cp[c / 3 * 3 + (c % 3 + 1) % 3]));
    if (at >= 0) {
#pragma omp atomic
      uses[at]++;
    }
  }
  removed = 0;
  for (size_t i = 0; i < npairs; i++) {
    const int *a = &cp[3 * (size_t)pairs[i][0]];
    int safe = 1;
    for (int e = 0; e < 3; e++) {
      long u = uses[find_key(keys, nk, edge_key(a[e], a[(e + 1) % 3]))];
      safe &= u == 2 || u >= 4;
    }
    if (!safe) continue;
    drop[pairs[i][0]] = drop[pairs[i][1]] = 1;
    removed += 2;
  }
  if (removed) drop_faces(m, drop);
done:
  free(start);
  free(order);
  free(low);
  free(partner);
  free(pairs);
  free(keys);
  free(uses);
  free(drop);
  return removed;
}
