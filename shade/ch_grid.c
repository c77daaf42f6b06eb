#include "ch_grid.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "ch_math.h"

void ch_grid_free(ch_grid *grid) {
  free(grid->cell_start);
  free(grid->items);
  memset(grid, 0, sizeof *grid);
}

static void cell_range(const ch_grid *g, const double b[4], int r[4]) { ch_grid_cell_range(g, b, r); }

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
    qsort(sizes, (size_t)valid, sizeof *sizes, ch_cmp_double);
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

/* A segment cut into pieces: piece k of m spans t in [k/m, (k+1)/m]; its
 * box holds the control points of that part of the quadratic (B(a), B(a) +
 * (b - a)/2 B'(a), B(b)), which hold the part. */
static void piece_box(const ch_segment *s, int k, int m, double grow, double box[4]) {
  double a = (double)k / m, b = (double)(k + 1) / m, q[3][2];
  for (int i = 0; i < 2; i++) {
    double p0 = s->p[0][i], p1 = s->p[1][i], p2 = s->p[2][i];
    double ua = 1.0 - a, ub = 1.0 - b;
    q[0][i] = ua * ua * p0 + 2.0 * ua * a * p1 + a * a * p2;
    q[2][i] = ub * ub * p0 + 2.0 * ub * b * p1 + b * b * p2;
    q[1][i] = q[0][i] + (b - a) * (ua * (p1 - p0) + a * (p2 - p1));
  }
  box[0] = fmin(q[0][0], fmin(q[1][0], q[2][0])) - grow;
  box[1] = fmin(q[0][1], fmin(q[1][1], q[2][1])) - grow;
  box[2] = fmax(q[0][0], fmax(q[1][0], q[2][0])) + grow;
  box[3] = fmax(q[0][1], fmax(q[1][1], q[2][1])) + grow;
}

/* Pieces of s about `length` long (its control box's extent over it). */
static int piece_count(const ch_segment *s, double length) {
  double b[4];
  ch_segment_box(s, 0.0, b);
  double n = ceil(fmax(b[2] - b[0], b[3] - b[1]) / length);
  return n < 1.0 ? 1 : n > 65536.0 ? 65536 : (int)n;
}

/* Counts (fill == NULL) or fills the items of every cell, segments in
 * order, each once per cell (last: per cell, the last segment listed).
 * Stops once the items or the cells visited (4 budgets: pieces far wider
 * than a cell overlap) are over budget, returning more than it, and in
 * *over how many times over it all would be (from the part done). */
static size_t place(const ch_grid *g, const ch_curve_set *set, const double *reach, int *last, int *count,
                    int *fill, int *items, size_t budget, double *over) {
  size_t total = 0, work = 0, work_budget = budget > SIZE_MAX / 4 ? SIZE_MAX : 4 * budget;
  *over = 1.0;
  for (int i = 0; i < set->num_segments; i++) {
    if (total > budget || work > work_budget) {
      double part = (double)(i > 0 ? i : 1) / set->num_segments;
      *over = fmax((double)total / budget, (double)work / work_budget) / part;
      return budget + 1;
    }
    if (!(reach[i] >= 0.0)) continue;
    const ch_segment *s = &set->segments[i];
    /* (grown a hair more than the reach: the pieces' points are rounded) */
    double grow = reach[i] + 1e-9 / g->inv_cell;
    /* pieces a cell long, or as long as the reach where that is more */
    int m = piece_count(s, fmax(1.0 / g->inv_cell, reach[i]));
    for (int k = 0; k < m; k++) {
      double b[4];
      int r[4];
      piece_box(s, k, m, grow, b);
      ch_grid_cell_range(g, b, r);
      work += (size_t)(r[2] - r[0] + 1) * (size_t)(r[3] - r[1] + 1);
      for (int y = r[1]; y <= r[3]; y++)
        for (int x = r[0]; x <= r[2]; x++) {
          size_t c = (size_t)y * g->nx + x;
          if (last[c] == i) continue;
          last[c] = i;
          total++;
          if (count) count[c + 1]++;
          if (fill) items[fill[c]++] = i;
        }
    }
  }
  return total;
}

ch_status ch_grid_build_curves(ch_grid *g, const ch_curve_set *set, const double *reach, ch_error *err) {
  memset(g, 0, sizeof *g);
  int n = set->num_segments, valid = 0;
  double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
  double *sizes = malloc(2 * (size_t)(n > 0 ? n : 1) * sizeof *sizes), *reaches = sizes + (n > 0 ? n : 1);
  if (!sizes) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the curve grid");
  for (int i = 0; i < n; i++) {
    if (!(reach[i] >= 0.0)) continue;
    double b[4];
    ch_segment_box(&set->segments[i], reach[i], b);
    lo[0] = fmin(lo[0], b[0]);
    lo[1] = fmin(lo[1], b[1]);
    hi[0] = fmax(hi[0], b[2]);
    hi[1] = fmax(hi[1], b[3]);
    sizes[valid] = fmax(b[2] - b[0], b[3] - b[1]);
    reaches[valid++] = reach[i];
  }
  double cell = 1.0;
  if (valid > 0) {
    qsort(sizes, (size_t)valid, sizeof *sizes, ch_cmp_double);
    qsort(reaches, (size_t)valid, sizeof *reaches, ch_cmp_double);
    cell = fmin(0.5 * sizes[valid / 2], fmax(2.0 * reaches[valid / 2], 0.0));
    double extent = fmax(hi[0] - lo[0], hi[1] - lo[1]);
    if (!(cell > 0.0)) cell = 0.5 * sizes[valid / 2];
    if (!(cell > 0.0)) cell = extent > 0.0 ? extent / 64.0 : 1.0;
    if (extent / cell > 2048.0) cell = extent / 2048.0;
  } else {
    lo[0] = lo[1] = 0.0;
    hi[0] = hi[1] = 1.0;
  }
  free(sizes);
  g->origin[0] = lo[0];
  g->origin[1] = lo[1];
  size_t budget = 16 * (size_t)valid + ((size_t)1 << 22), total = 0;
  int *last = NULL;
  for (;;) { /* coarser until within the budget (see ch_grid_build) */
    g->inv_cell = 1.0 / cell;
    g->nx = (int)floor((hi[0] - lo[0]) * g->inv_cell) + 1;
    g->ny = (int)floor((hi[1] - lo[1]) * g->inv_cell) + 1;
    size_t ncells = (size_t)g->nx * (size_t)g->ny;
    free(last);
    last = malloc(ncells * sizeof *last);
    if (!last) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the curve grid");
    /* the pieces alone first (degenerate curves, rounded to a line far
     * from the origin, can ask for 65536 each) */
    size_t pieces = 0;
    for (int i = 0; i < n; i++)
      if (reach[i] >= 0.0) pieces += (size_t)piece_count(&set->segments[i], fmax(cell, reach[i]));
    if (pieces > budget && !(g->nx == 1 && g->ny == 1)) {
      cell *= fmax(2.0, (double)pieces / budget);
      continue;
    }
    memset(last, 0xff, ncells * sizeof *last);
    double over;
    total = place(g, set, reach, last, NULL, NULL, NULL, budget, &over);
    if (total <= budget || (g->nx == 1 && g->ny == 1)) break;
    /* (items grow like 1 / cell along curves, 1 / cell^2 over areas) */
    cell *= fmin(1024.0, fmax(2.0, sqrt(over)));
  }
  size_t ncells = (size_t)g->nx * (size_t)g->ny;
  g->cell_start = calloc(ncells + 1, sizeof *g->cell_start);
  g->items = malloc((total > 0 ? total : 1) * sizeof *g->items);
  int *fill = malloc(ncells * sizeof *fill);
  if (!g->cell_start || !g->items || !fill || total > (size_t)1 << 30) {
    free(last);
    free(fill);
    ch_grid_free(g);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the curve grid");
  }
  memset(last, 0xff, ncells * sizeof *last);
  double over;
  place(g, set, reach, last, g->cell_start, NULL, NULL, SIZE_MAX / 8, &over);
  for (size_t c = 0; c < ncells; c++) g->cell_start[c + 1] += g->cell_start[c];
  memcpy(fill, g->cell_start, ncells * sizeof *fill);
  memset(last, 0xff, ncells * sizeof *last);
  place(g, set, reach, last, NULL, fill, g->items, SIZE_MAX / 8, &over);
  free(fill);
  free(last);
  return CH_OK;
}
