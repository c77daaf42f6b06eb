/* ch_grid: a uniform grid over axis-aligned boxes in UV, so that a query
 * point visits only the boxes of its cell: evaluation cost depends on the
 * curves near a point, not on all curves. */
#ifndef CH_GRID_H
#define CH_GRID_H

#include <math.h>

#include "ch_curves.h"
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

/* Builds the grid over a curve set's segments, segment i listed in the
 * cells within reach[i] of it (reach[i] < 0 or NaN: left out): each segment
 * is cut into pieces about a cell long and each piece's box, grown by the
 * reach, names its cells, so a long line is listed along its way, not in
 * every cell of its box (lines through a point across the square each held
 * every cell). Items of a cell ascend and are unique, a superset of the
 * segments within reach of any point in it. Cells: half the median grown
 * box, or twice the median reach where that is smaller, capped at 2^22
 * cells and coarser where items would exceed 16 per segment plus 4M. */
ch_status ch_grid_build_curves(ch_grid *grid, const ch_curve_set *set, const double *reach, ch_error *err);

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

/* The cells box (as given to ch_grid_build) is listed in: x0 y0 x1 y1,
 * inclusive. */
static inline void ch_grid_cell_range(const ch_grid *g, const double b[4], int r[4]) {
  r[0] = (int)floor((b[0] - g->origin[0]) * g->inv_cell);
  r[1] = (int)floor((b[1] - g->origin[1]) * g->inv_cell);
  r[2] = (int)floor((b[2] - g->origin[0]) * g->inv_cell);
  r[3] = (int)floor((b[3] - g->origin[1]) * g->inv_cell);
  if (r[0] < 0) r[0] = 0;
  if (r[1] < 0) r[1] = 0;
  if (r[2] >= g->nx) r[2] = g->nx - 1;
  if (r[3] >= g->ny) r[3] = g->ny - 1;
}

/* Whether a non-empty box (as given to ch_grid_build) is among the items
 * ch_grid_query returns for (u, v), without scanning them. */
static inline int ch_grid_cell_holds(const ch_grid *g, const double b[4], double u, double v) {
  double fx = (u - g->origin[0]) * g->inv_cell, fy = (v - g->origin[1]) * g->inv_cell;
  if (!(fx >= 0.0 && fy >= 0.0 && fx < g->nx && fy < g->ny) || !(b[0] <= b[2] && b[1] <= b[3])) return 0;
  int r[4], x = (int)fx, y = (int)fy;
  ch_grid_cell_range(g, b, r);
  return x >= r[0] && x <= r[2] && y >= r[1] && y <= r[3];
}

#ifdef __cplusplus
}
#endif
#endif
