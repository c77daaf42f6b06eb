#include "ch_grid.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static int cmp_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

void ch_grid_free(ch_grid *grid) {
  free(grid->cell_start);
  free(grid->items);
  memset(grid, 0, sizeof *grid);
}

static void cell_range(const ch_grid *g, const double b[4], int r[4]) {
  r[0] = (int)floor((b[0] - g->origin[0]) * g->inv_cell);
  r[1] = (int)floor((b[1] - g->origin[1]) * g->inv_cell);
  r[2] = (int)floor((b[2] - g->origin[0]) * g->inv_cell);
  r[3] = (int)floor((b[3] - g->origin[1]) * g->inv_cell);
  if (r[0] < 0) r[0] = 0;
  if (r[1] < 0) r[1] = 0;
  if (r[2] >= g->nx) r[2] = g->nx - 1;
  if (r[3] >= g->ny) r[3] = g->ny - 1;
}

ch_status ch_grid_build(ch_grid *g, int n, const double (*boxes)[4], ch_error *err) {
  memset(g, 0, sizeof *g);
  double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
  double *sizes = malloc((size_t)(n > 0 ? n : 1) * sizeof *sizes);
  if (!sizes) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the curve grid");
  int valid = 0;
  for (int i = 0; i < n; i++) {
    const double *b = boxes[i];
    if (!(b[0] <= b[2] && b[1] <= b[3])) continue;
    lo[0] = fmin(lo[0], b[0]);
    lo[1] = fmin(lo[1], b[1]);
    hi[0] = fmax(hi[0], b[2]);
    hi[1] = fmax(hi[1], b[3]);
    sizes[valid++] = fmax(b[2] - b[0], b[3] - b[1]);
  }
  double cell = 1.0;
  if (valid > 0) {
    qsort(sizes, (size_t)valid, sizeof *sizes, cmp_double);
    /* Half the median box: a box covers about 3x3 cells, a cell sees few
     * boxes beyond those that really overlap it. */
    cell = 0.5 * sizes[valid / 2];
    double extent = fmax(hi[0] - lo[0], hi[1] - lo[1]);
    if (!(cell > 0.0)) cell = extent > 0.0 ? extent / 64.0 : 1.0;
    if (extent / cell > 2048.0) cell = extent / 2048.0;
  } else {
    lo[0] = lo[1] = 0.0;
    hi[0] = hi[1] = 1.0;
  }
  free(sizes);
  g->origin[0] = lo[0];
  g->origin[1] = lo[1];
  /* Boxes of very different sizes (a few grooves wider than the square
   * among many thin ones) would put each big one in millions of cells
   * (seconds and gigabytes for a few curves): coarser cells until the
   * items stay within 16 per box plus 4M. A query returns a superset of
   * the boxes holding the point either way, so answers do not change. */
  size_t budget = 16 * (size_t)valid + ((size_t)1 << 22);
  for (;;) {
    g->inv_cell = 1.0 / cell;
    g->nx = (int)floor((hi[0] - lo[0]) * g->inv_cell) + 1;
    g->ny = (int)floor((hi[1] - lo[1]) * g->inv_cell) + 1;
    size_t items = 0;
    for (int i = 0; i < n && items <= budget; i++) {
      const double *b = boxes[i];
      if (!(b[0] <= b[2] && b[1] <= b[3])) continue;
      int r[4];
      cell_range(g, b, r);
      items += (size_t)(r[2] - r[0] + 1) * (size_t)(r[3] - r[1] + 1);
    }
    if (items <= budget || (g->nx == 1 && g->ny == 1)) break;
    cell *= 2.0;
  }
  size_t ncells = (size_t)g->nx * (size_t)g->ny;
  g->cell_start = calloc(ncells + 1, sizeof *g->cell_start);
  if (!g->cell_start) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the curve grid");
  /* Two passes, counting then filling, so items stay in index order. */
  size_t total = 0;
  for (int i = 0; i < n; i++) {
    const double *b = boxes[i];
    if (!(b[0] <= b[2] && b[1] <= b[3])) continue;
    int r[4];
    cell_range(g, b, r);
    for (int y = r[1]; y <= r[3]; y++)
      for (int x = r[0]; x <= r[2]; x++) g->cell_start[(size_t)y * g->nx + x + 1]++;
    total += (size_t)(r[2] - r[0] + 1) * (size_t)(r[3] - r[1] + 1);
  }
  if (total > (size_t)1 << 30) {
    ch_grid_free(g);
    return ch_error_set(err, CH_ERR_INPUT, "curves too large for the curve grid");
  }
  for (size_t c = 0; c < ncells; c++) g->cell_start[c + 1] += g->cell_start[c];
  g->items = malloc((total > 0 ? total : 1) * sizeof *g->items);
  int *fill = malloc(ncells * sizeof *fill);
  if (!g->items || !fill) {
    free(fill);
    ch_grid_free(g);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the curve grid");
  }
  memcpy(fill, g->cell_start, ncells * sizeof *fill);
  for (int i = 0; i < n; i++) {
    const double *b = boxes[i];
    if (!(b[0] <= b[2] && b[1] <= b[3])) continue;
    int r[4];
    cell_range(g, b, r);
    for (int y = r[1]; y <= r[3]; y++)
      for (int x = r[0]; x <= r[2]; x++) g->items[fill[(size_t)y * g->nx + x]++] = i;
  }
  free(fill);
  return CH_OK;
}
