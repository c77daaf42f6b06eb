/* ch_value_set: distinct values of a few doubles each, numbered as first
 * seen (see ch_mesh_values_internal.h). */
#include "ch_mesh_values_internal.h"

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
