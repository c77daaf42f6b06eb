/* ch_grid: a uniform grid over axis-aligned boxes in UV, so that a query
 * point visits only the boxes of its cell: evaluation cost depends on the
 * curves near a point, not on all curves. */
#ifndef CH_GRID_H
#define CH_GRID_H

#include "ch_error.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ch_grid {
  double origin[2];  /* lower corner of cell (0, 0) */
  double inv_cell;   /* 1 / cell size */
  int nx, ny;
  int *cell_start;   /* nx * ny + 1 offsets into items */
  int *items;        /* box indices, ascending within each cell */
} ch_grid;

/* Builds the grid over n boxes (umin vmin umax vmax). The cell size follows
 * the median box size, capped at 2^22 cells, and coarser where boxes would
 * otherwise fill more than 16 cells each plus 2^22 in all. Empty boxes
 * (umin > umax) are left out. */
ch_status ch_grid_build(ch_grid *grid, int n, const double (*boxes)[4], ch_error *err);

void ch_grid_free(ch_grid *grid);

/* The boxes whose cells contain (u, v): a superset of the boxes containing
 * it. Returns the count and points *items at them (ascending). */
static inline int ch_grid_query(const ch_grid *grid, double u, double v, const int **items) {
  double fx = (u - grid->origin[0]) * grid->inv_cell, fy = (v - grid->origin[1]) * grid->inv_cell;
  if (!(fx >= 0.0 && fy >= 0.0 && fx < grid->nx && fy < grid->ny)) return 0;
  int c = (int)fy * grid->nx + (int)fx;
  *items = grid->items + grid->cell_start[c];
  return grid->cell_start[c + 1] - grid->cell_start[c];
}

#ifdef __cplusplus
}
#endif
#endif
