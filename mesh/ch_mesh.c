/* ch_mesh.c: releasing a mesh and checking it for use as a base surface
 * (docs/spec.md §1).
 *
 * Topology is read from positions: an edge is an unordered pair of position
 * indices, and the face sides using it are found by sorting. UV charts join
 * faces across an edge when both shared corners have the same UV (same
 * index or same value). Coverage and overlap are measured by scan-converting
 * every face's UV polygon into a 1024x1024 grid of cell centres with the
 * nonzero winding rule. That is the signed sum over a fan triangulation of
 * the face, the same as an unsigned fan for convex faces, but it does not
 * count a concave face twice where its fan triangles overlap. Messages
 * number faces and positions from 1, like OBJ. */
#include "ch_mesh.h"

#include "ch_alloc.h"
#include "ch_sort.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

enum { GRID = 1024 };

void ch_mesh_free(ch_mesh *mesh) {
  if (!mesh) return;
  free(mesh->positions);
  free(mesh->face_start);
  free(mesh->corner_position);
  free(mesh->uvs);
  free(mesh->corner_uv);
  free(mesh->normals);
  free(mesh->corner_normal);
  memset(mesh, 0, sizeof *mesh);
}

/* ---- structure ---------------------------------------------------------- */

static int all_finite(const double *v, int n, int stride, int *bad) {
  for (int i = 0; i < n; i++)
    for (int k = 0; k < stride; k++)
      if (!isfinite(v[(size_t)i * stride + k])) {
        *bad = i;
        return 0;
      }
  return 1;
}

/* Corner indices of an attribute are within 0..count-1. */
static ch_status check_indices(const ch_mesh *m, const int *index, int count, const char *what,
                               const char *name, ch_error *err) {
  for (int f = 0; f < m->num_faces; f++)
    for (int c = m->face_start[f]; c < m->face_start[f + 1]; c++)
      if (index[c] < 0 || index[c] >= count)
        return ch_error_set(err, CH_ERR_INPUT, "%s: face %d: %s index %d out of range (1..%d)",
                            name, f + 1, what, index[c] + 1, count);
  return CH_OK;
}

static ch_status check_structure(const ch_mesh *m, const char *name, ch_error *err) {
  if (m->num_faces <= 0 || !m->face_start)
    return ch_error_set(err, CH_ERR_INPUT, "%s: mesh has no faces", name);
  if (m->num_faces > CH_MESH_MAX_ELEMENTS || m->num_corners > CH_MESH_MAX_ELEMENTS ||
      m->num_positions > CH_MESH_MAX_ELEMENTS || m->num_uvs > CH_MESH_MAX_ELEMENTS ||
      m->num_normals > CH_MESH_MAX_ELEMENTS || m->num_positions < 0 || m->num_corners < 0)
    return ch_error_set(err, CH_ERR_INPUT, "%s: mesh too large (limit %d elements)", name,
                        CH_MESH_MAX_ELEMENTS);
  if (m->face_start[0] != 0 || m->face_start[m->num_faces] != m->num_corners ||
      !m->corner_position || (m->num_positions > 0 && !m->positions))
    return ch_error_set(err, CH_ERR_INPUT, "%s: inconsistent face arrays", name);
  for (int f = 0; f < m->num_faces; f++) {
    int n = m->face_start[f + 1] - m->face_start[f];
    if (m->face_start[f + 1] < m->face_start[f] || m->face_start[f + 1] > m->num_corners)
      return ch_error_set(err, CH_ERR_INPUT, "%s: face %d: inconsistent corner offsets", name, f + 1);
    if (n < 3)
      return ch_error_set(err, CH_ERR_INPUT, "%s: face %d: %d corners, a face needs at least 3",
                          name, f + 1, n);
  }
  if (!m->uvs || !m->corner_uv || m->num_uvs <= 0)
    return ch_error_set(err, CH_ERR_INPUT,
                        "%s: mesh has no texture coordinates (UVs: vt in OBJ, TEXCOORD_0 in glTF); chisel needs UVs in [0,1]",
                        name);
  ch_status st = check_indices(m, m->corner_position, m->num_positions, "position", name, err);
  if (st == CH_OK) st = check_indices(m, m->corner_uv, m->num_uvs, "texture", name, err);
  if (st == CH_OK && m->corner_normal) {
    if (!m->normals || m->num_normals <= 0)
      return ch_error_set(err, CH_ERR_INPUT, "%s: normal indices without normals", name);
    st = check_indices(m, m->corner_normal, m->num_normals, "normal", name, err);
  }
  if (st != CH_OK) return st;
  int bad;
  if (!all_finite(m->positions, m->num_positions, 3, &bad))
    return ch_error_set(err, CH_ERR_INPUT, "%s: vertex %d: position is not finite", name, bad + 1);
  if (!all_finite(m->uvs, m->num_uvs, 2, &bad))
    return ch_error_set(err, CH_ERR_INPUT, "%s: texture coordinate %d is not finite", name, bad + 1);
  if (m->normals && !all_finite(m->normals, m->num_normals, 3, &bad))
    return ch_error_set(err, CH_ERR_INPUT, "%s: normal %d is not finite", name, bad + 1);
  return CH_OK;
}

/* ---- union-find --------------------------------------------------------- */

static int uf_find(int *parent, int x) {
  while (parent[x] != x) {
    parent[x] = parent[parent[x]];
    x = parent[x];
  }
  return x;
}

static void uf_union(int *parent, int a, int b) {
  a = uf_find(parent, a);
  b = uf_find(parent, b);
  if (a < b) parent[b] = a;
  else if (b < a) parent[a] = b;
}

static int *uf_new(int n) {
  int *p = malloc((size_t)(n > 0 ? n : 1) * sizeof *p);
  if (p)
    for (int i = 0; i < n; i++) p[i] = i;
  return p;
}

/* ---- edges -------------------------------------------------------------- */

/* One face side: the edge between positions lo < hi, its face, and the
 * corners at lo and hi. */
typedef struct side {
  int lo, hi, face, clo, chi;
} side;

/* A side with the UV values of its two corners (for chart grouping where
 * more than two faces share an edge). */
typedef struct side_uv {
  side s;
  double uv[4];
} side_uv;

static void corner_uvs(const ch_mesh *m, const side *e, double uv[4]) {
  /* Equal UV index means equal value, so comparing values covers both. */
  const double *ulo = &m->uvs[2 * (size_t)m->corner_uv[e->clo]];
  const double *uhi = &m->uvs[2 * (size_t)m->corner_uv[e->chi]];
  uv[0] = ulo[0];
  uv[1] = ulo[1];
  uv[2] = uhi[0];
  uv[3] = uhi[1];
}

static int cmp_side(const void *pa, const void *pb) {
  const side *a = pa, *b = pb;
  if (a->lo != b->lo) return a->lo < b->lo ? -1 : 1;
  if (a->hi != b->hi) return a->hi < b->hi ? -1 : 1;
  if (a->face != b->face) return a->face < b->face ? -1 : 1;
  return (a->clo > b->clo) - (a->clo < b->clo);
}

static int cmp_side_uv(const void *pa, const void *pb) {
  const side_uv *a = pa, *b = pb;
  for (int k = 0; k < 4; k++)
    if (a->uv[k] != b->uv[k]) return a->uv[k] < b->uv[k] ? -1 : 1;
  return cmp_side(&a->s, &b->s);
}

static int same_uv(const double a[4], const double b[4]) {
  return a[0] == b[0] && a[1] == b[1] && a[2] == b[2] && a[3] == b[3];
}

/* The sides sorted by (lo, hi), each edge's in face order: two stable
 * counting sorts of the corners (by hi, then by lo) rather than qsort over
 * the sides (a third of `chisel info` on a 2M-triangle mesh). A face's
 * positions are distinct, so no edge repeats within a face. */
static side *make_sides(const ch_mesh *m) {
  size_t nc = (size_t)m->num_corners, np = (size_t)(m->num_positions > 0 ? m->num_positions : 1);
  side *s = ch_alloc_large(nc > 0 ? nc : 1, sizeof *s, 0);
  int *lo = malloc((nc > 0 ? nc : 1) * sizeof *lo), *hi = malloc((nc > 0 ? nc : 1) * sizeof *hi);
  int *by_hi = malloc((nc > 0 ? nc : 1) * sizeof *by_hi), *order = malloc((nc > 0 ? nc : 1) * sizeof *order);
  int *start = malloc((np + 1) * sizeof *start);
  int ok = s && lo && hi && by_hi && order && start;
  if (ok) {
    for (int f = 0; f < m->num_faces; f++) {
      int b = m->face_start[f], n = m->face_start[f + 1] - b;
      for (int i = 0; i < n; i++) {
        int p0 = m->corner_position[b + i], p1 = m->corner_position[b + (i + 1) % n];
        lo[b + i] = p0 < p1 ? p0 : p1;
        hi[b + i] = p0 < p1 ? p1 : p0;
      }
    }
    ok = ch_sort_buckets(hi, nc, (int)np, start, by_hi) == 0;
  }
  if (ok) {
    for (size_t i = 0; i < nc; i++) hi[i] = lo[by_hi[i]]; /* (hi's room: the lo keys in that order) */
    ok = ch_sort_buckets(hi, nc, (int)np, start, order) == 0;
  }
  if (ok) {
    int *face_of = lo; /* (lo's room: each corner's face) */
    for (int f = 0; f < m->num_faces; f++)
      for (int c = m->face_start[f]; c < m->face_start[f + 1]; c++) face_of[c] = f;
    for (size_t i = 0; i < nc; i++) {
      int c0 = by_hi[order[i]], f = face_of[c0];
      int b = m->face_start[f], n = m->face_start[f + 1] - b, c1 = b + (c0 - b + 1) % n;
      int swap = m->corner_position[c0] > m->corner_position[c1];
      side *e = &s[i];
      e->clo = swap ? c1 : c0;
      e->chi = swap ? c0 : c1;
      e->lo = m->corner_position[e->clo];
      e->hi = m->corner_position[e->chi];
      e->face = f;
    }
  }
  free(lo);
  free(hi);
  free(by_hi);
  free(order);
  free(start);
  if (!ok) {
    free(s);
    return NULL;
  }
  return s;
}

typedef struct topology {
  int boundary, nonmanifold, first_nm_lo, first_nm_hi;
  int nm_vertices, first_nm_vertex;
  int charts;
} topology;

/* Walks the groups of sides sharing an edge: counts boundary and
 * non-manifold edges, joins corners across edges (for vertex fans) and
 * faces with matching UVs (for charts). */
static ch_status edge_groups(const ch_mesh *m, const side *s, int *corner_set, int *face_set, topology *t,
                             side_uv **group, int *cap_group) {
  int n = m->num_corners;
  for (int i = 0; i < n;) {
    int j = i + 1;
    while (j < n && s[j].lo == s[i].lo && s[j].hi == s[i].hi) j++;
    int k = j - i;
    if (k == 1) t->boundary++;
    if (k > 2 && t->nonmanifold++ == 0) {
      t->first_nm_lo = s[i].lo;
      t->first_nm_hi = s[i].hi;
    }
    for (int a = i + 1; a < j; a++) {
      uf_union(corner_set, s[i].clo, s[a].clo);
      uf_union(corner_set, s[i].chi, s[a].chi);
    }
    if (k == 2) {
      double a[4], b[4];
      corner_uvs(m, &s[i], a);
      corner_uvs(m, &s[i + 1], b);
      if (same_uv(a, b)) uf_union(face_set, s[i].face, s[i + 1].face);
    } else if (k > 2) {
      if (k > *cap_group) {
        side_uv *g = realloc(*group, (size_t)k * sizeof *g);
        if (!g) return CH_ERR_NOMEM;
        *group = g;
        *cap_group = k;
      }
      side_uv *g = *group;
      for (int a = 0; a < k; a++) {
        g[a].s = s[i + a];
        corner_uvs(m, &s[i + a], g[a].uv);
      }
      qsort(g, (size_t)k, sizeof *g, cmp_side_uv);
      for (int a = 1; a < k; a++)
        if (same_uv(g[a - 1].uv, g[a].uv)) uf_union(face_set, g[a - 1].s.face, g[a].s.face);
    }
    i = j;
  }
  return CH_OK;
}

/* A vertex is non-manifold when its corners fall into several fans (corners
 * joined across shared edges). Faces around a non-manifold edge are joined
 * too: that edge is reported once, not again at its two vertices. */
static ch_status vertex_fans(const ch_mesh *m, int *corner_set, topology *t) {
  int *root = malloc((size_t)(m->num_positions > 0 ? m->num_positions : 1) * sizeof *root);
  char *multi = calloc((size_t)(m->num_positions > 0 ? m->num_positions : 1), 1);
  if (!root || !multi) {
    free(root);
    free(multi);
    return CH_ERR_NOMEM;
  }
  for (int v = 0; v < m->num_positions; v++) root[v] = -1;
  for (int c = 0; c < m->num_corners; c++) {
    int v = m->corner_position[c], r = uf_find(corner_set, c);
    if (root[v] < 0) root[v] = r;
    else if (root[v] != r) multi[v] = 1;
  }
  t->first_nm_vertex = -1;
  for (int v = 0; v < m->num_positions; v++)
    if (multi[v]) {
      if (t->nm_vertices++ == 0) t->first_nm_vertex = v;
    }
  free(root);
  free(multi);
  return CH_OK;
}

static ch_status topology_stats(const ch_mesh *m, topology *t) {
  memset(t, 0, sizeof *t);
  side *s = make_sides(m);
  int *corner_set = uf_new(m->num_corners);
  int *face_set = uf_new(m->num_faces);
  side_uv *group = NULL; /* (a non-manifold edge's sides) */
  int cap_group = 0;
  ch_status st = CH_ERR_NOMEM;
  if (s && corner_set && face_set) st = edge_groups(m, s, corner_set, face_set, t, &group, &cap_group);
  if (st == CH_OK) {
    st = vertex_fans(m, corner_set, t);
    for (int f = 0; f < m->num_faces; f++)
      if (uf_find(face_set, f) == f) t->charts++;
  }
  free(group);
  free(s);
  free(corner_set);
  free(face_set);
  return st;
}

static ch_status count_components(const ch_mesh *m, int *components) {
  int *set = uf_new(m->num_positions);
  char *used = calloc((size_t)(m->num_positions > 0 ? m->num_positions : 1), 1);
  if (!set || !used) {
    free(set);
    free(used);
    return CH_ERR_NOMEM;
  }
  for (int f = 0; f < m->num_faces; f++)
    for (int c = m->face_start[f]; c < m->face_start[f + 1]; c++) {
      used[m->corner_position[c]] = 1;
      uf_union(set, m->corner_position[m->face_start[f]], m->corner_position[c]);
    }
  *components = 0;
  for (int v = 0; v < m->num_positions; v++)
    if (used[v] && uf_find(set, v) == v) (*components)++;
  free(set);
  free(used);
  return CH_OK;
}

/* ---- per-face geometry -------------------------------------------------- */

/* Twice the area of the face (Newell normal length) against a scale: zero
 * area is |N| <= 1e-12 times the sum of squared edge lengths, so it does
 * not depend on units. */
static int zero_area_3d(const ch_mesh *m, int f) {
  int b = m->face_start[f], n = m->face_start[f + 1] - b;
  const double *p0 = &m->positions[3 * (size_t)m->corner_position[b]];
  double nx = 0, ny = 0, nz = 0, scale = 0;
  for (int i = 0; i < n; i++) {
    const double *p = &m->positions[3 * (size_t)m->corner_position[b + i]];
    const double *q = &m->positions[3 * (size_t)m->corner_position[b + (i + 1) % n]];
    /* Relative to the first corner, to keep far-off meshes accurate. */
    double ax = p[0] - p0[0], ay = p[1] - p0[1], az = p[2] - p0[2];
    double bx = q[0] - p0[0], by = q[1] - p0[1], bz = q[2] - p0[2];
    nx += (ay - by) * (az + bz);
    ny += (az - bz) * (ax + bx);
    nz += (ax - bx) * (ay + by);
    scale += (ax - bx) * (ax - bx) + (ay - by) * (ay - by) + (az - bz) * (az - bz);
  }
  return sqrt(nx * nx + ny * ny + nz * nz) <= 1e-12 * scale;
}

static int zero_area_uv(const ch_mesh *m, int f) {
  int b = m->face_start[f], n = m->face_start[f + 1] - b;
  const double *t0 = &m->uvs[2 * (size_t)m->corner_uv[b]];
  double area = 0, scale = 0;
  for (int i = 0; i < n; i++) {
    const double *p = &m->uvs[2 * (size_t)m->corner_uv[b + i]];
    const double *q = &m->uvs[2 * (size_t)m->corner_uv[b + (i + 1) % n]];
    double ax = p[0] - t0[0], ay = p[1] - t0[1], bx = q[0] - t0[0], by = q[1] - t0[1];
    area += ax * by - bx * ay;
    scale += (ax - bx) * (ax - bx) + (ay - by) * (ay - by);
  }
  return fabs(area) <= 1e-12 * scale;
}

/* ---- UV coverage -------------------------------------------------------- */

/* Clamps before converting so that huge UVs never overflow an int. */
static int cell_index(double x) {
  if (!(x > -1.0)) return -1;
  if (x > GRID) return GRID;
  return (int)x;
}

typedef struct crossing {
  double x;
  int dir;
} crossing;

static int cmp_crossing(const void *pa, const void *pb) {
  const crossing *a = pa, *b = pb;
  return (a->x > b->x) - (a->x < b->x);
}

/* Rows usually cross a face twice: insertion sort, qsort for big faces. */
static void sort_crossings(crossing *xs, int count) {
  if (count > 16) {
    qsort(xs, (size_t)count, sizeof *xs, cmp_crossing);
    return;
  }
  for (int i = 1; i < count; i++) {
    crossing c = xs[i];
    int k = i;
    while (k > 0 && xs[k - 1].x > c.x) {
      xs[k] = xs[k - 1];
      k--;
    }
    xs[k] = c;
  }
}

/* Adds 1 to every cell whose centre the face covers (nonzero winding),
 * once per face, counting the cells covered once and twice as they reach
 * it (no scan of the whole grid afterwards: it cost the fuzzer 40 ms per
 * input). xs has room for the face's corner count. */
static void raster_face(const ch_mesh *m, int f, unsigned char *grid, crossing *xs, long *covered, long *twice) {
  int b = m->face_start[f], n = m->face_start[f + 1] - b;
  double vmin = INFINITY, vmax = -INFINITY;
  for (int i = 0; i < n; i++) {
    double v = m->uvs[2 * (size_t)m->corner_uv[b + i] + 1];
    vmin = fmin(vmin, v);
    vmax = fmax(vmax, v);
  }
  int j0 = cell_index(ceil(vmin * GRID - 0.5)), j1 = cell_index(floor(vmax * GRID - 0.5));
  if (j0 < 0) j0 = 0;
  if (j1 > GRID - 1) j1 = GRID - 1;
  for (int j = j0; j <= j1; j++) {
    double yc = (j + 0.5) / GRID;
    int count = 0;
    for (int i = 0; i < n; i++) {
      const double *p = &m->uvs[2 * (size_t)m->corner_uv[b + i]];
      const double *q = &m->uvs[2 * (size_t)m->corner_uv[b + (i + 1) % n]];
      if (p[1] == q[1]) continue;
      /* Ordered by v, so a shared edge gives both faces the same x. */
      const double *lo = p[1] < q[1] ? p : q, *hi = p[1] < q[1] ? q : p;
      if (!(lo[1] <= yc && yc < hi[1])) continue;
      xs[count].x = lo[0] + (yc - lo[1]) * (hi[0] - lo[0]) / (hi[1] - lo[1]);
      xs[count].dir = p[1] < q[1] ? 1 : -1;
      count++;
    }
    sort_crossings(xs, count);
    int winding = 0;
    for (int k = 0; k + 1 < count; k++) {
      winding += xs[k].dir;
      if (winding == 0) continue;
      /* Cells whose centre lies in [x_k, x_k+1). */
      int i0 = cell_index(ceil(xs[k].x * GRID - 0.5));
      int i1 = cell_index(ceil(xs[k + 1].x * GRID - 0.5));
      if (i0 < 0) i0 = 0;
      if (i1 > GRID) i1 = GRID;
      unsigned char *row = grid + (size_t)j * GRID;
      for (int i = i0; i < i1; i++) {
        *covered += row[i] == 0;
        *twice += row[i] == 1;
        if (row[i] < 255) row[i]++;
      }
    }
  }
}

static ch_status uv_coverage(const ch_mesh *m, double *coverage, double *overlap) {
  int most = 0;
  for (int f = 0; f < m->num_faces; f++)
    if (m->face_start[f + 1] - m->face_start[f] > most) most = m->face_start[f + 1] - m->face_start[f];
  unsigned char *grid = calloc((size_t)GRID * GRID, 1);
  crossing *xs = malloc((size_t)most * sizeof *xs);
  if (!grid || !xs) {
    free(grid);
    free(xs);
    return CH_ERR_NOMEM;
  }
  long covered = 0, twice = 0;
  for (int f = 0; f < m->num_faces; f++) raster_face(m, f, grid, xs, &covered, &twice);
  *coverage = (double)covered / ((double)GRID * GRID);
  *overlap = (double)twice / ((double)GRID * GRID);
  free(grid);
  free(xs);
  return CH_OK;
}

/* ---- report ------------------------------------------------------------- */

static void basic_stats(const ch_mesh *m, ch_mesh_report *r) {
  for (int f = 0; f < m->num_faces; f++) {
    int n = m->face_start[f + 1] - m->face_start[f];
    if (n == 3) r->num_triangles++;
    else if (n == 4) r->num_quads++;
    else r->num_polygons++;
  }
  for (int k = 0; k < 3; k++) {
    r->bounds_min[k] = INFINITY;
    r->bounds_max[k] = -INFINITY;
  }
  for (int v = 0; v < m->num_positions; v++)
    for (int k = 0; k < 3; k++) {
      r->bounds_min[k] = fmin(r->bounds_min[k], m->positions[3 * (size_t)v + k]);
      r->bounds_max[k] = fmax(r->bounds_max[k], m->positions[3 * (size_t)v + k]);
    }
  for (int k = 0; k < 2; k++) {
    r->uv_min[k] = INFINITY;
    r->uv_max[k] = -INFINITY;
  }
  for (int t = 0; t < m->num_uvs; t++) {
    double u = m->uvs[2 * (size_t)t], v = m->uvs[2 * (size_t)t + 1];
    r->uv_min[0] = fmin(r->uv_min[0], u);
    r->uv_max[0] = fmax(r->uv_max[0], u);
    r->uv_min[1] = fmin(r->uv_min[1], v);
    r->uv_max[1] = fmax(r->uv_max[1], v);
    if (u < 0 || u > 1 || v < 0 || v > 1) r->num_uvs_outside++;
  }
}

static void warn_all(const ch_mesh_report *r, const topology *t, int first_degenerate,
                     int first_zero_uv, int displaced, const char *name, ch_error *err) {
  if (r->num_uvs_outside > 0)
    ch_warn(err, "%s: %d texture coordinates lie outside [0,1] (u %g..%g, v %g..%g)", name,
            r->num_uvs_outside, r->uv_min[0], r->uv_max[0], r->uv_min[1], r->uv_max[1]);
  if (t->nonmanifold > 0)
    ch_warn(err, "%s: %d non-manifold edges (more than two faces), first between positions %d and %d",
            name, t->nonmanifold, t->first_nm_lo + 1, t->first_nm_hi + 1);
  if (t->nm_vertices > 0)
    ch_warn(err, "%s: %d non-manifold vertices (separate fans of faces), first: position %d", name,
            t->nm_vertices, t->first_nm_vertex + 1);
  if (displaced) return; /* its walls: see ch_mesh_validate_displaced */
  if (r->num_degenerate_faces > 0)
    ch_warn(err, "%s: %d faces have zero area, first: face %d", name, r->num_degenerate_faces,
            first_degenerate + 1);
  if (r->num_zero_uv_area_faces > 0)
    ch_warn(err, "%s: %d faces have zero UV area, first: face %d", name,
            r->num_zero_uv_area_faces, first_zero_uv + 1);
}

static ch_status validate(const ch_mesh *mesh, const char *name, int displaced, ch_mesh_report *report,
                          ch_error *err) {
  if (!name) name = "mesh";
  if (report) memset(report, 0, sizeof *report);
  if (!mesh) return ch_error_set(err, CH_ERR_INTERNAL, "%s: no mesh given", name);
  ch_status st = check_structure(mesh, name, err);
  if (st != CH_OK) return st;

  ch_mesh_report r;
  memset(&r, 0, sizeof r);
  basic_stats(mesh, &r);
  int first_degenerate = -1, first_zero_uv = -1;
  for (int f = 0; f < mesh->num_faces; f++) {
    if (zero_area_3d(mesh, f) && r.num_degenerate_faces++ == 0) first_degenerate = f;
    if (zero_area_uv(mesh, f) && r.num_zero_uv_area_faces++ == 0) first_zero_uv = f;
  }
  topology t;
  st = topology_stats(mesh, &t);
  if (st == CH_OK) st = count_components(mesh, &r.num_components);
  if (st == CH_OK) st = uv_coverage(mesh, &r.uv_coverage, &r.uv_overlap);
  if (st != CH_OK) return ch_error_set(err, st, "%s: out of memory while checking the mesh", name);
  r.num_boundary_edges = t.boundary;
  r.num_nonmanifold_edges = t.nonmanifold;
  r.num_nonmanifold_vertices = t.nm_vertices;
  r.num_charts = t.charts;
  r.first_degenerate_face = first_degenerate;
  r.first_zero_uv_area_face = first_zero_uv;
  warn_all(&r, &t, first_degenerate, first_zero_uv, displaced, name, err);
  if (report) *report = r;
  return CH_OK;
}

ch_status ch_mesh_validate(const ch_mesh *mesh, const char *name, ch_mesh_report *report, ch_error *err) {
  return validate(mesh, name, 0, report, err);
}

ch_status ch_mesh_validate_displaced(const ch_mesh *mesh, const char *name, ch_mesh_report *report,
                                     ch_error *err) {
  return validate(mesh, name, 1, report, err);
}
