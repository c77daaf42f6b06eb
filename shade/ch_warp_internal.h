/* ch_warp_internal: what the warp's files share and nobody else sees (not
 * installed): the cage's lookup grids, small triangle and box helpers, and
 * the cage map's lookups the curve registration calls. */
#ifndef CH_WARP_INTERNAL_H
#define CH_WARP_INTERNAL_H

#include <math.h>
#include <omp.h>

#include "ch_grid.h"
#include "ch_math.h"
#include "ch_progress.h"
#include "ch_warp.h"

/* The private part of ch_warp (ch_warp.grids): a uniform grid over the
 * triangles' boxes in UV (0) and in warped UV (1), and per triangle and
 * space its corner 0 and the inverse of its edge matrix (barycentrics in
 * two multiply-adds). */
typedef struct cage_index {
  ch_grid grid[2];
  double *frame[2];
} cage_index;

/* Corner 0 and the inverse edge matrix of the triangle c (u0 v0 u1 v1 u2
 * v2): b1 = f2 du + f3 dv, b2 = f4 du + f5 dv for (du, dv) = q - corner 0.
 * Returns 0 for a triangle without area (relative to its edges). */
static inline int tri_frame(const double c[6], double f[6]) {
  double e1[2] = {c[2] - c[0], c[3] - c[1]}, e2[2] = {c[4] - c[0], c[5] - c[1]};
  double det = ch_cross2(e1, e2);
  if (!(fabs(det) > 1e-14 * (ch_dot2(e1, e1) + ch_dot2(e2, e2)))) return 0;
  f[0] = c[0];
  f[1] = c[1];
  f[2] = e2[1] / det;
  f[3] = -e2[0] / det;
  f[4] = -e1[1] / det;
  f[5] = e1[0] / det;
  return 1;
}

static inline void tri_box(const double c[6], double b[4]) {
  b[0] = ch_min3(c[0], c[2], c[4]);
  b[1] = ch_min3(c[1], c[3], c[5]);
  b[2] = ch_max3(c[0], c[2], c[4]);
  b[3] = ch_max3(c[1], c[3], c[5]);
}

static inline int boxes_overlap(const double a[4], const double b[4]) {
  return a[0] <= b[2] && b[0] <= a[2] && a[1] <= b[3] && b[1] <= a[3];
}

/* The cells of g that box b touches, clamped to the grid (empty when b
 * misses it). Clamped in double first: boxes may be far outside. */
static inline void cell_range(const ch_grid *g, const double b[4], int r[4]) {
  double lim[2] = {g->nx, g->ny};
  for (int k = 0; k < 4; k++) {
    double f = floor((b[k] - g->origin[k & 1]) * g->inv_cell);
    if (!(f > -1.0)) f = -1.0; /* also NaN */
    if (f > lim[k & 1]) f = lim[k & 1];
    r[k] = (int)f;
  }
  if (r[0] < 0) r[0] = 0;
  if (r[1] < 0) r[1] = 0;
  if (r[2] >= g->nx) r[2] = g->nx - 1;
  if (r[3] >= g->ny) r[3] = g->ny - 1;
}

/* The lowest-numbered triangle of space s (0 UV, 1 warped UV) holding q,
 * with q's barycentrics b1, b2 in it; -1 if none (ch_warp_cage.c). */
int ch_warp_cage_locate(const cage_index *ix, int s, const double q[2], double b[2]);
/* Triangle t's affine map from space s to the other, for any q (the map
 * extended beyond the triangle). */
void ch_warp_cage_apply(const ch_warp *w, int t, int s, const double q[2], double out[2]);
/* Warped corners, both triangle grids, the folded count and the visible
 * shares of w, whose W and cage UVs are set. */
ch_status ch_warp_cage_finish(ch_warp *w, ch_error *err);
void ch_warp_cage_index_free(cage_index *ix);

#endif
