/* Collapsing edges shorter than a tolerance, where doing so keeps the mesh
 * manifold (see ch_mesh.h). */
#include <math.h>
#include <omp.h>
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

/* Sorts f[0..n) and keeps one of each value; returns how many. */
static int sort_distinct(int *f, int n) {
  qsort(f, (size_t)n, sizeof *f, cmp_int);
  int u = 0;
  for (int i = 0; i < n; i++)
    if (u == 0 || f[u - 1] != f[i]) f[u++] = f[i];
  return u;
}

/* Whether two triangles have the same three corners (in any order). */
static int same_corners(const int *c, const int *d) {
  int same = 1;
  for (int k = 0; k < 3; k++) same &= d[0] == c[k] || d[1] == c[k] || d[2] == c[k];
  return same;
}

/* Concatenates the nt lists into *out (NULL when all are empty) and frees
 * them: the number of items, or -1 when out of memory. Lists that the
 * threads filled in a loop of schedule(static), which gives thread t the
 * t-th of contiguous ranges in order (OpenMP 4.5, 2.7.1), so come out in
 * the serial order. */
static int concat_lists(vlist *lists, int nt, int **out) {
  size_t n = 0;
  for (int t = 0; t < nt; t++) n += (size_t)lists[t].n;
  int *all = n ? malloc(n * sizeof *all) : NULL;
  for (int t = 0, at = 0; t < nt; t++) {
    if (all && lists[t].n) memcpy(&all[at], lists[t].f, (size_t)lists[t].n * sizeof *all);
    at += lists[t].n;
    free(lists[t].f);
    lists[t] = (vlist){0};
  }
  *out = all;
  return n && !all ? -1 : (int)n;
}

/* The number of the sorted values[0..n) below x. */
static size_t count_below(const int *values, size_t n, size_t x) {
  size_t lo = 0, hi = n;
  while (lo < hi) {
    size_t mid = (lo + hi) / 2;
    if ((size_t)values[mid] < x)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo;
}

/* Removes the elements at the sorted, distinct indices gone[0..ngone) from
 * the n elements of size bytes at base, in place, keeping the others'
 * order: each moves back by the number gone before it. Each thread moves a
 * contiguous range of those after the first gone; a range's writes reach
 * back into the previous range's last k elements (k gone before it), which
 * that range copies aside before anyone writes. So ranges are longer than
 * ngone, else one thread moves them all (as it does when out of memory). */
static void remove_elements(void *base, size_t size, size_t n, const int *gone, size_t ngone) {
  if (!ngone) return;
  char *a = base;
  size_t first = (size_t)gone[0], span = n - first;
  int nt = omp_get_max_threads();
  if (span / (size_t)nt <= ngone) nt = 1;
  char *aside = nt > 1 ? malloc((size_t)nt * ngone * size) : NULL;
  if (!aside) nt = 1;
#pragma omp parallel num_threads(nt)
  {
    size_t nth = (size_t)omp_get_num_threads(), t = (size_t)omp_get_thread_num();
    size_t lo = first + span * t / nth, hi = first + span * (t + 1) / nth;
    size_t k = count_below(gone, ngone, lo);
    /* [risk, hi): what the next range's first writes overwrite */
    size_t risk = t + 1 < nth ? hi - count_below(gone, ngone, hi) : hi;
    char *mine = risk < hi ? aside + t * ngone * size : NULL;
    if (mine) memcpy(mine, a + risk * size, (hi - risk) * size);
#pragma omp barrier
    for (size_t i = lo; i < hi;) {
      /* the run [i, end) of kept elements moves back by k */
      size_t end = k < ngone && (size_t)gone[k] < hi ? (size_t)gone[k] : hi;
      size_t in_place = end < risk ? end : risk, aside_from = i > risk ? i : risk;
      if (i < in_place) memmove(a + (i - k) * size, a + i * size, (in_place - i) * size);
      if (aside_from < end)
        memcpy(a + (aside_from - k) * size, mine + (aside_from - risk) * size, (end - aside_from) * size);
      if (end == hi) break;
      i = end + 1;
      k++;
    }
  }
  free(aside);
}

/* Drops the faces at the sorted, distinct indices gone[0..ngone), their
 * corners with them, keeping the order of the others. */
static void drop_faces(ch_mesh *m, const int *gone, size_t ngone) {
  size_t corners = 3 * sizeof *m->corner_position;
  remove_elements(m->corner_position, corners, (size_t)m->num_faces, gone, ngone);
  if (m->corner_uv) remove_elements(m->corner_uv, corners, (size_t)m->num_faces, gone, ngone);
  if (m->corner_normal) remove_elements(m->corner_normal, corners, (size_t)m->num_faces, gone, ngone);
  int f2 = m->num_faces - (int)ngone;
  m->num_faces = f2;
  m->num_corners = 3 * f2;
#pragma omp parallel for schedule(static)
  for (int f = 0; f <= f2; f++) m->face_start[f] = 3 * f;
}

/* The distinct live neighbours of v (incident faces inc), sorted, into out
 * (grown as needed). */
static int neighbours(const ch_mesh *m, const vlist *inc, const uint64_t *dead, int v, int **out, int *cap) {
  int n = 0;
  for (int i = 0; i < inc->n; i++) {
    int f = inc->f[i];
    if (dead[f >> 6] >> (f & 63) & 1) continue;
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
  return sort_distinct(*out, n);
}

int ch_mesh_collapse_short_edges(ch_mesh *m, double eps) {
  if (m->num_faces == 0 || m->num_corners != 3 * m->num_faces || !(eps > 0.0)) return 0;
  int np = m->num_positions, nf = m->num_faces, nt = omp_get_max_threads();
  const double *P = m->positions;
  int *cp = m->corner_position;
  vlist *found = calloc((size_t)nt, sizeof *found);
  if (!found) return -1;
  /* Candidates: edges no longer than eps in every coordinate, (low, high):
   * a pass over every corner's position, on all threads (a few thousand
   * are found in millions). */
  int oom = 0;
#pragma omp parallel num_threads(nt) reduction(| : oom)
  {
    vlist *mine = &found[omp_get_thread_num()];
#pragma omp for schedule(static)
    for (int f = 0; f < nf; f++) {
      const int *c = &cp[3 * (size_t)f];
      for (int k = 0; k < 3; k++) {
        int a = c[k], b = c[k == 2 ? 0 : k + 1];
        const double *pa = &P[3 * (size_t)a], *pb = &P[3 * (size_t)b];
        if (a == b || fabs(pa[0] - pb[0]) > eps || fabs(pa[1] - pb[1]) > eps || fabs(pa[2] - pb[2]) > eps) continue;
        if (!oom) oom = vlist_push(mine, a < b ? a : b) || vlist_push(mine, a < b ? b : a);
      }
    }
  }
  int(*cand)[2] = NULL;
  int ncand2 = concat_lists(found, nt, (int **)&cand);
  if (oom || ncand2 < 0) {
    free(cand);
    free(found);
    return -1;
  }
  size_t nc = (size_t)ncand2 / 2;
  if (nc == 0) {
    free(found);
    return 0;
  }
  qsort(cand, nc, sizeof *cand, cmp_pair);
  /* Only the candidates' ends are ever read or merged into (merged_into
   * sends one to another end), so only theirs get incident faces: slot[v]
   * is 1 + v's number among the ends, 0 for the rest. */
  int *slot = calloc((size_t)np, sizeof *slot), nends = 0;
  size_t cap_ends = 2 * nc;
  vlist *inc = calloc(cap_ends, sizeof *inc), gone_faces = {0}, gone_positions = {0};
  int *merged_into = malloc(cap_ends * sizeof *merged_into);
  uint64_t *dead = calloc((size_t)nf / 64 + 1, sizeof *dead);
  int *na = NULL, *nb = NULL, capa = 0, capb = 0, collapsed = 0;
  oom = !slot || !inc || !merged_into || !dead;
  for (size_t i = 0; i < nc && !oom; i++)
    for (int e = 0; e < 2; e++) {
      int v = cand[i][e];
      if (slot[v]) continue;
      merged_into[nends] = v;
      slot[v] = ++nends;
    }
  /* Their incident faces, in face order: found on all threads, pushed in
   * the threads' order. */
  if (!oom) {
#pragma omp parallel num_threads(nt) reduction(| : oom)
    {
      vlist *mine = &found[omp_get_thread_num()];
#pragma omp for schedule(static)
      for (int f = 0; f < nf; f++)
        for (int k = 0; k < 3; k++) {
          int s = slot[cp[3 * (size_t)f + k]];
          if (s && !oom) oom = vlist_push(mine, s - 1) || vlist_push(mine, f);
        }
    }
    int *incident = NULL, ninc2 = concat_lists(found, nt, &incident);
    oom |= ninc2 < 0;
    for (int i = 0; i + 1 < ninc2 && !oom; i += 2) oom |= vlist_push(&inc[incident[i]], incident[i + 1]);
    free(incident);
  }
  free(found);
#define END(v) (&inc[slot[v] - 1])
#define ROOT(v) merged_into[slot[v] - 1]
#define DEAD(f) (dead[(f) >> 6] >> ((f)&63) & 1)
  for (size_t i = 0; i < nc && !oom; i++) {
    if (i > 0 && cand[i][0] == cand[i - 1][0] && cand[i][1] == cand[i - 1][1]) continue;
    /* An end already merged away: the edge now joins what it merged into
     * (several lines through one vertex leave several copies of it, and
     * the edge between two of them may exist only once a third is gone). */
    int a = cand[i][0], b = cand[i][1];
    while (ROOT(a) != a) a = ROOT(a);
    while (ROOT(b) != b) b = ROOT(b);
    if (a == b) continue;
    if (a > b) {
      int t = a;
      a = b;
      b = t;
    }
    const vlist *ia = END(a), *ib = END(b);
    /* Still an edge? And its opposite vertices. */
    int opp[4], nopp = 0, edge = 0;
    for (int j = 0; j < ib->n; j++) {
      int f = ib->f[j];
      if (DEAD(f)) continue;
      const int *c = &cp[3 * (size_t)f];
      if (c[0] != a && c[1] != a && c[2] != a) continue;
      edge = 1;
      int w = c[0] != a && c[0] != b ? c[0] : c[1] != a && c[1] != b ? c[1] : c[2];
      if (nopp < 4) opp[nopp] = w;
      nopp++;
    }
    if (!edge || nopp > 2) continue;
    /* Link condition: the common neighbours of a and b are exactly the
     * vertices opposite their edge, else the collapse pinches the mesh. */
    int ka = neighbours(m, ia, dead, a, &na, &capa), kb = neighbours(m, ib, dead, b, &nb, &capb);
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
        const vlist *l = e ? ib : ia;
        int here = 0;
        for (int j = 0; j < l->n && !here; j++) {
          int f = l->f[j];
          if (DEAD(f)) continue;
          const int *c = &cp[3 * (size_t)f];
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
    for (int j = 0; j < ib->n && !fin; j++)
      for (int j2 = j + 1; j2 < ib->n && !fin; j2++) {
        int f = ib->f[j], g = ib->f[j2];
        if (DEAD(f) || DEAD(g) || f == g) continue;
        fin = same_corners(&cp[3 * (size_t)f], &cp[3 * (size_t)g]);
      }
    for (int j = 0; j < ib->n && !fin; j++) {
      int f = ib->f[j];
      if (DEAD(f)) continue;
      const int *c = &cp[3 * (size_t)f];
      if (c[0] == a || c[1] == a || c[2] == a) continue;
      int u[3];
      for (int k = 0; k < 3; k++) u[k] = c[k] == b ? a : c[k];
      for (int i2 = 0; i2 < ia->n && !fin; i2++) {
        int g = ia->f[i2];
        if (DEAD(g)) continue;
        fin = same_corners(u, &cp[3 * (size_t)g]);
      }
    }
    if (fin) continue;
    /* Collapse b into a: its faces take a, those on the edge die. */
    for (int j = 0; j < ib->n && !oom; j++) {
      int f = ib->f[j];
      if (DEAD(f)) continue;
      int *c = &cp[3 * (size_t)f];
      int has_a = c[0] == a || c[1] == a || c[2] == a;
      if (has_a) {
        dead[f >> 6] |= UINT64_C(1) << (f & 63);
        oom |= vlist_push(&gone_faces, f);
        continue;
      }
      for (int k = 0; k < 3; k++)
        if (c[k] == b) c[k] = a;
      oom |= vlist_push(END(a), f);
    }
    ROOT(b) = a;
    oom |= vlist_push(&gone_positions, b);
    collapsed++;
  }
#undef END
#undef ROOT
#undef DEAD
  free(na);
  free(nb);
  free(cand);
  if (inc)
    for (int e = 0; e < nends; e++) free(inc[e].f);
  free(inc);
  free(merged_into);
  free(dead);
  if (!oom && collapsed) {
    /* Drop the dead faces and the merged positions, keeping the order of
     * everything else; slot becomes each kept position's new number. */
    qsort(gone_faces.f, (size_t)gone_faces.n, sizeof *gone_faces.f, cmp_int);
    qsort(gone_positions.f, (size_t)gone_positions.n, sizeof *gone_positions.f, cmp_int);
    drop_faces(m, gone_faces.f, (size_t)gone_faces.n);
    const int *gp = gone_positions.f;
    size_t ngp = (size_t)gone_positions.n;
    remove_elements(m->positions, 3 * sizeof *m->positions, (size_t)np, gp, ngp);
#pragma omp parallel
    {
      size_t nth = (size_t)omp_get_num_threads(), t = (size_t)omp_get_thread_num();
      size_t lo = (size_t)np * t / nth, hi = (size_t)np * (t + 1) / nth, k = count_below(gp, ngp, lo);
      for (size_t v = lo; v < hi; v++) {
        while (k < ngp && (size_t)gp[k] < v) k++;
        slot[v] = (int)(v - k);
      }
    }
    size_t ncorners = (size_t)m->num_corners;
#pragma omp parallel for schedule(static)
    for (size_t c = 0; c < ncorners; c++) cp[c] = slot[cp[c]];
    m->num_positions = np - (int)ngp;
  }
  free(slot);
  free(gone_faces.f);
  free(gone_positions.f);
  return oom ? -1 : collapsed;
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

/* A face's fingerprint among the faces of its lowest corner, low: a hash
 * of its other two corners, sorted. same_corners holds between two faces
 * of three distinct corners only when they have the same three, and so the
 * same fingerprint; where a corner repeats, it may hold without that, so
 * such a face's is COMPARE_CORNERS. */
#define COMPARE_CORNERS UINT32_MAX
static uint32_t fingerprint(const int *c, int low) {
  int r = c[0] == low ? 0 : c[1] == low ? 1 : 2;
  uint64_t x = (uint32_t)c[r == 2 ? 0 : r + 1], y = (uint32_t)c[r == 0 ? 2 : r - 1];
  if (x == y || x == (uint32_t)low || y == (uint32_t)low) return COMPARE_CORNERS;
  /* (Fibonacci hashing: the product's high bits depend on every bit) */
  uint32_t h = (uint32_t)(((x < y ? x << 32 | y : y << 32 | x) * UINT64_C(0x9E3779B97F4A7C15)) >> 32);
  return h == COMPARE_CORNERS ? h - 1 : h;
}

/* Drops the positions among cand[0..n) (sorted, distinct) that no face
 * uses, renumbering the corners: a pillow's own corners would print as
 * loose vertices. 0, or -1 out of memory. */
static int drop_loose_positions(ch_mesh *m, const int *cand, size_t n) {
  unsigned char *used = calloc(n ? n : 1, 1);
  if (!used) return -1;
  size_t nc = (size_t)m->num_corners;
#pragma omp parallel for schedule(static)
  for (size_t c = 0; c < nc; c++) {
    size_t k = count_below(cand, n, (size_t)m->corner_position[c]);
    if (k < n && cand[k] == m->corner_position[c]) {
#pragma omp atomic write
      used[k] = 1;
    }
  }
  int *gone = malloc((n ? n : 1) * sizeof *gone);
  size_t ngone = 0;
  if (!gone) {
    free(used);
    return -1;
  }
  for (size_t k = 0; k < n; k++)
    if (!used[k]) gone[ngone++] = cand[k];
  free(used);
  if (ngone) {
    remove_elements(m->positions, 3 * sizeof *m->positions, (size_t)m->num_positions, gone, ngone);
#pragma omp parallel for schedule(static)
    for (size_t c = 0; c < nc; c++)
      m->corner_position[c] -= (int)count_below(gone, ngone, (size_t)m->corner_position[c]);
    m->num_positions -= (int)ngone;
  }
  free(gone);
  return 0;
}

int ch_mesh_remove_pillows(ch_mesh *m) {
  if (m->num_faces == 0 || m->num_corners != 3 * m->num_faces) return 0;
  int nf = m->num_faces, np = m->num_positions, nt = omp_get_max_threads();
  const int *cp = m->corner_position;
  /* Faces by their lowest corner (ch_sort_buckets): the two faces of a
   * pillow share it, and few faces do, so pairs are found in linear time.
   * Each face's fingerprint is made as its corners are read in order: in
   * a bucket the fingerprints decide, and the corners, scattered over the
   * mesh (reading them bucket by bucket took most of the search), are
   * read only where two agree. */
  int *low = malloc((size_t)nf * sizeof *low), *start = malloc(((size_t)np + 1) * sizeof *start);
  int *order = malloc((size_t)nf * sizeof *order);
  uint32_t *print = malloc((size_t)nf * sizeof *print);
  vlist *found = calloc((size_t)nt, sizeof *found), gone = {0};
  int(*pairs)[2] = NULL;
  size_t npairs = 0;
  uint64_t *keys = NULL;
  long *uses = NULL;
  int removed = -1, oom = 0;
  if (!low || !start || !order || !print || !found) goto done;
#pragma omp parallel for schedule(static)
  for (int f = 0; f < nf; f++) {
    low[f] = lowest_corner(&cp[3 * (size_t)f]);
    print[f] = fingerprint(&cp[3 * (size_t)f], low[f]);
  }
  if (ch_sort_buckets(low, (size_t)nf, np, start, order)) goto done;
  free(low);
  low = NULL;
  /* The pairs (f, g), g > f, where f and g are a pillow (exactly two faces
   * on the same corners, opposite). Only a bucket where two fingerprints
   * agree, or one says to, can hold one: its corners are compared. */
#pragma omp parallel num_threads(nt) reduction(| : oom)
  {
    vlist *mine = &found[omp_get_thread_num()];
    int(*corners)[3] = NULL, cap = 0;
#pragma omp for schedule(dynamic, 4096)
    for (int v = 0; v < np; v++) {
      const int *bucket = &order[start[v]];
      int n = start[v + 1] - start[v], compare = 0;
      for (int i = 0; i < n && !compare; i++) {
        uint32_t fp = print[bucket[i]];
        compare = fp == COMPARE_CORNERS;
        for (int j = 0; j < i && !compare; j++) compare = print[bucket[j]] == fp;
      }
      if (!compare || oom) continue;
      if (n > cap) {
        void *p = realloc(corners, (size_t)n * sizeof *corners);
        if (!p) {
          oom = 1;
          continue;
        }
        corners = p;
        cap = n;
      }
      for (int i = 0; i < n; i++) memcpy(corners[i], &cp[3 * (size_t)bucket[i]], sizeof *corners);
      for (int i = 0; i < n; i++) {
        int twins = 0, twin = -1;
        for (int j = 0; j < n; j++)
          if (j != i && same_corners(corners[i], corners[j])) {
            twins++;
            twin = j;
          }
        int f = bucket[i], g = twin >= 0 ? bucket[twin] : -1;
        if (twins == 1 && g > f && reversed(corners[i], corners[twin]))
          oom |= vlist_push(mine, f) || vlist_push(mine, g);
      }
    }
    free(corners);
  }
  free(start);
  free(order);
  free(print);
  start = order = NULL;
  print = NULL;
  int npairs2 = concat_lists(found, nt, (int **)&pairs);
  if (oom || npairs2 < 0) goto done;
  npairs = (size_t)npairs2 / 2;
  removed = 0;
  if (!npairs) goto done;
  removed = -1;
  /* in face order (each face is the first of one pair at most) */
  qsort(pairs, npairs, sizeof *pairs, cmp_pair);
  /* Removing a pair takes two uses from each of its edges: only if none is
   * left with one (a hole). Count the uses of just those edges. */
  size_t nk = 3 * npairs;
  keys = malloc(nk * sizeof *keys);
  uses = calloc(nk, sizeof *uses);
  if (!keys || !uses) goto done;
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
  int dropped = 0;
  for (size_t i = 0; i < npairs && !oom; i++) {
    const int *a = &cp[3 * (size_t)pairs[i][0]];
    int safe = 1;
    for (int e = 0; e < 3; e++) {
      long u = uses[find_key(keys, nk, edge_key(a[e], a[(e + 1) % 3]))];
      safe &= u == 2 || u >= 4;
    }
    if (!safe) continue;
    oom |= vlist_push(&gone, pairs[i][0]) || vlist_push(&gone, pairs[i][1]);
    dropped += 2;
  }
  if (oom) goto done;
  if (dropped) {
    /* (a face in two pairs is dropped once) */
    int distinct = sort_distinct(gone.f, gone.n);
    /* their corners, before the faces go */
    vlist corners = {0};
    for (int i = 0; i < distinct && !oom; i++)
      for (int k = 0; k < 3 && !oom; k++) oom |= vlist_push(&corners, cp[3 * (size_t)gone.f[i] + (size_t)k]);
    drop_faces(m, gone.f, (size_t)distinct);
    if (!oom) oom |= drop_loose_positions(m, corners.f, (size_t)sort_distinct(corners.f, corners.n)) != 0;
    free(corners.f);
    if (oom) goto done;
  }
  removed = dropped;
done:
  free(low);
  free(start);
  free(order);
  free(print);
  if (found)
    for (int t = 0; t < nt; t++) free(found[t].f);
  free(found);
  free(pairs);
  free(keys);
  free(uses);
  free(gone.f);
  return removed;
}
