/* ch_value_set: a growing array of values of `width` doubles with one
 * index per distinct value, numbered in the order they are first seen (an
 * open-addressing table on the values' bits; -0 as +0). The glTF reader's
 * positions, UVs and normals, and the welding of PLY and OFF vertices at
 * equal coordinates. Not installed. */
#ifndef CH_MESH_VALUES_INTERNAL_H
#define CH_MESH_VALUES_INTERNAL_H

#include <stddef.h>

#include "ch_error.h"
#include "ch_mesh.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ch_value_set {
  int width, count, cap;
  double *values;
  int *table; /* table_size slots: -1 or an index */
  size_t table_size;
} ch_value_set;

/* The index of value v (width doubles), added if new; -1 without memory
 * or past CH_MESH_MAX_ELEMENTS. */
int ch_value_set_index(ch_value_set *s, const double *v);

void ch_value_set_free(ch_value_set *s);

/* UVs a few float roundings apart at one position become one UV (the
 * first), and UVs no corner uses any more are dropped, the rest keeping
 * their order. Exporters that split a vertex for its normals round its
 * copies' UVs apart: Blender 3.4's glTF writes v = 0.599999964 on one copy
 * and 0.600000024 on the next, which chisel would take for a UV seam.
 * Within 8 float epsilons of the larger coordinate (about 1e-6 in the unit
 * square), far below any real seam's gap. CH_ERR_NOMEM only. */
ch_status ch_mesh_merge_near_uvs(ch_mesh *m, ch_error *err);

#ifdef __cplusplus
}
#endif
#endif
