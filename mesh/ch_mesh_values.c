/* ch_value_set: distinct values of a few doubles each, numbered as first
 * seen (see ch_mesh_values_internal.h). */
#include "ch_mesh_values_internal.h"

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static uint64_t value_hash(const double *v, int width) {
  uint64_t h = 0x9E3779B97F4A7C15u;
  for (int k = 0; k < width; k++) {
    double x = v[k] == 0.0 ? 0.0 : v[k]; /* -0 as +0 */
    uint64_t bits;
    memcpy(&bits, &x, sizeof bits);
    h = (h ^ bits) * 0xff51afd7ed558ccdu;
    h ^= h >> 32;
  }
  return h;
}

int ch_value_set_index(ch_value_set *s, const double *v) {
  if ((size_t)s->count * 2 >= s->table_size) {
    size_t size = s->table_size ? 2 * s->table_size : 1024;
    int *table = malloc(size * sizeof *table);
    if (!table) return -1;
    memset(table, 0xff, size * sizeof *table);
    for (int i = 0; i < s->count; i++) {
      size_t slot = value_hash(&s->values[(size_t)i * s->width], s->width) & (size - 1);
      while (table[slot] >= 0) slot = (slot + 1) & (size - 1);
      table[slot] = i;
    }
    free(s->table);
    s->table = table;
    s->table_size = size;
  }
  size_t slot = value_hash(v, s->width) & (s->table_size - 1);
  for (; s->table[slot] >= 0; slot = (slot + 1) & (s->table_size - 1)) {
    const double *w = &s->values[(size_t)s->table[slot] * s->width];
    int same = 1;
    for (int k = 0; k < s->width; k++) same &= w[k] == v[k];
    if (same) return s->table[slot];
  }
  if (s->count >= CH_MESH_MAX_ELEMENTS) return -1;
  if (s->count == s->cap) {
    int cap = s->cap ? 2 * s->cap : 1024;
    double *values = realloc(s->values, (size_t)cap * s->width * sizeof *values);
    if (!values) return -1;
    s->values = values;
    s->cap = cap;
  }
  memcpy(&s->values[(size_t)s->count * s->width], v, (size_t)s->width * sizeof *v);
  s->table[slot] = s->count;
  return s->count++;
}

void ch_value_set_free(ch_value_set *s) {
  free(s->values);
  free(s->table);
  memset(s, 0, sizeof *s);
}

/* A corner's position and UV, for sorting corners by position. */
typedef struct pos_uv {
  int position, uv;
} pos_uv;

static int cmp_pos_uv(const void *x, const void *y) {
  const pos_uv *a = x, *b = y;
  if (a->position != b->position) return a->position < b->position ? -1 : 1;
  return (a->uv > b->uv) - (a->uv < b->uv);
}

ch_status ch_mesh_merge_near_uvs(ch_mesh *m, ch_error *err) {
  if (!m->corner_uv || m->num_corners == 0) return CH_OK;
  pos_uv *c = malloc((size_t)m->num_corners * sizeof *c);
  int *to = malloc((size_t)m->num_uvs * sizeof *to);
  if (!c || !to) {
    free(c), free(to);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory merging UVs");
  }
  for (int i = 0; i < m->num_uvs; i++) to[i] = i;
  for (int i = 0; i < m->num_corners; i++) c[i] = (pos_uv){m->corner_position[i], m->corner_uv[i]};
  qsort(c, (size_t)m->num_corners, sizeof *c, cmp_pos_uv);
  /* at each position, each UV against the lower-numbered ones kept there */
  for (int a = 0; a < m->num_corners;) {
    int b = a;
    while (b < m->num_corners && c[b].position == c[a].position) b++;
    for (int i = a; i < b; i++) {
      int u = c[i].uv;
      if (to[u] != u || (i > a && c[i - 1].uv == u)) continue;
      const double *p = &m->uvs[2 * (size_t)u];
      for (int j = a; j < i; j++) {
        int k = c[j].uv;
        if (to[k] != k) continue;
        const double *q = &m->uvs[2 * (size_t)k];
        double tol = 8.0 * FLT_EPSILON * fmax(1.0, fmax(fmax(fabs(p[0]), fabs(p[1])), fmax(fabs(q[0]), fabs(q[1]))));
        if (fabs(p[0] - q[0]) <= tol && fabs(p[1] - q[1]) <= tol) {
          to[u] = k;
          break;
        }
      }
    }
    a = b;
  }
  free(c);
  /* the corners take their targets (a UV merged at one position is merged
   * wherever it is used: the two are within the tolerance anyway), and
   * UVs no corner uses go */
  int *used = calloc((size_t)m->num_uvs, sizeof *used);
  if (!used) {
    free(to);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory merging UVs");
  }
  int merged = 0;
  for (int i = 0; i < m->num_corners; i++) {
    int u = m->corner_uv[i];
    while (to[u] != u) u = to[u];
    merged |= u != m->corner_uv[i];
    m->corner_uv[i] = u;
    used[u] = 1;
  }
  if (merged) {
    int n = 0;
    for (int i = 0; i < m->num_uvs; i++) {
      if (!used[i]) continue;
      m->uvs[2 * n] = m->uvs[2 * i], m->uvs[2 * n + 1] = m->uvs[2 * i + 1];
      used[i] = n++;
    }
    for (int i = 0; i < m->num_corners; i++) m->corner_uv[i] = used[m->corner_uv[i]];
    m->num_uvs = n;
  }
  free(used);
  free(to);
  return CH_OK;
}
