/* The cage map C of the view-dependent warp (diffusion-curves-on-surfaces
 * §3.2, ch_warp.h): the base surface's triangles keep their barycentric
 * coordinates, so C is affine per triangle; a uniform grid of triangles
 * over each space finds the triangle holding a point. Where cage triangles
 * overlap in UV (or fold in warped UV) the lowest-numbered one is used. */
#include <stdlib.h>
#include <string.h>

#include "ch_warp_internal.h"

/* Barycentric tolerance of the cage lookup: points on an edge belong to both
 * triangles, the lowest-numbered one is taken. */
#define INSIDE_TOL 1e-12
/* Texel grid of the visible shares. */
enum { SHARE_RES = 256 };

int ch_warp_cage_locate(const cage_index *ix, int s, const double q[2], double b[2]) {
  const int *items;
  int m = ch_grid_query(&ix->grid[s], q[0], q[1], &items);
  for (int k = 0; k < m; k++) {
    const double *f = ix->frame[s] + 6 * (size_t)items[k];
    double du = q[0] - f[0], dv = q[1] - f[1];
    double b1 = f[2] * du + f[3] * dv, b2 = f[4] * du + f[5] * dv;
    if (b1 >= -INSIDE_TOL && b2 >= -INSIDE_TOL && 1.0 - b1 - b2 >= -INSIDE_TOL) {
      b[0] = b1;
      b[1] = b2;
      return items[k];
    }
  }
  return -1;
}

/* The point with barycentrics b in triangle t of space s's counterpart. */
static void combine(const ch_warp *w, int t, int s, const double b[2], double out[2]) {
  const double *c = (s ? w->uv : w->wuv) + 6 * (size_t)t;
  out[0] = c[0] + b[0] * (c[2] - c[0]) + b[1] * (c[4] - c[0]);
  out[1] = c[1] + b[0] * (c[3] - c[1]) + b[1] * (c[5] - c[1]);
}

void ch_warp_cage_apply(const ch_warp *w, int t, int s, const double q[2], double out[2]) {
  const cage_index *ix = w->grids;
  const double *f = ix->frame[s] + 6 * (size_t)t;
  double du = q[0] - f[0], dv = q[1] - f[1];
  double b[2] = {f[2] * du + f[3] * dv, f[4] * du + f[5] * dv};
  combine(w, t, s, b, out);
}

/* C (s = 0) or C^-1 (s = 1) at q: the triangle's map, else W or W^-1. */
static int cage_map(const ch_warp *w, int s, const double q[2], double out[2]) {
  double b[2];
  int t = ch_warp_cage_locate(w->grids, s, q, b);
  if (t >= 0) {
    combine(w, t, s, b, out);
  } else {
    for (int k = 0; k < 2; k++) out[k] = s ? ch_warp_axis_inverse(w, k, q[k]) : ch_warp_axis(w, k, q[k]);
  }
  return t;
}

int ch_warp_map(const ch_warp *w, const double uv[2], double out[2]) { return cage_map(w, 0, uv, out); }

int ch_warp_unmap(const ch_warp *w, const double wuv[2], double out[2]) { return cage_map(w, 1, wuv, out); }

double ch_warp_visible_triangle_share(const ch_warp *w, int num_triangles, const int *corner_uv,
                                      const double *uv) {
  if (num_triangles <= 0) return 0.0;
  long count = 0;
#pragma omp parallel for schedule(static) reduction(+ : count)
  for (int t = 0; t < num_triangles; t++) {
    double c[2] = {0.0, 0.0}, b[2];
    for (int k = 0; k < 3; k++) {
      const double *p = uv + 2 * (size_t)corner_uv[3 * (size_t)t + k];
      c[0] += p[0] / 3.0;
      c[1] += p[1] / 3.0;
    }
    int cage = ch_warp_cage_locate(w->grids, 0, c, b);
    count += cage >= 0 && w->visible[cage];
  }
  return (double)count / num_triangles;
}

void ch_warp_cage_index_free(cage_index *ix) {
  if (!ix) return;
  for (int s = 0; s < 2; s++) {
    ch_grid_free(&ix->grid[s]);
    free(ix->frame[s]);
  }
  free(ix);
}

ch_status ch_warp_cage_finish(ch_warp *w, ch_error *err) {
  int nt = w->num_triangles;
  for (size_t i = 0; i < (size_t)nt * 3; i++) {
    w->wuv[2 * i] = ch_warp_axis(w, 0, w->uv[2 * i]);
    w->wuv[2 * i + 1] = ch_warp_axis(w, 1, w->uv[2 * i + 1]);
  }
  cage_index *ix = calloc(1, sizeof *ix);
  double(*boxes)[4] = malloc((size_t)(nt > 0 ? nt : 1) * sizeof *boxes);
  if (!ix || !boxes) {
    free(ix);
    free(boxes);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the warp's cage grids");
  }
  w->grids = ix;
  for (int s = 0; s < 2; s++) {
    const double *c = s ? w->wuv : w->uv;
    ix->frame[s] = malloc((size_t)(nt > 0 ? nt : 1) * 6 * sizeof(double));
    if (!ix->frame[s]) {
      free(boxes);
      return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the warp's cage grids");
    }
#pragma omp parallel for schedule(static)
    for (int t = 0; t < nt; t++) {
      double *f = ix->frame[s] + 6 * (size_t)t;
      if (tri_frame(c + 6 * (size_t)t, f)) {
        tri_box(c + 6 * (size_t)t, boxes[t]);
      } else { /* no area: left out of the grid (an empty box) */
        memset(f, 0, 6 * sizeof *f);
        boxes[t][0] = boxes[t][1] = 1.0;
        boxes[t][2] = boxes[t][3] = 0.0;
      }
    }
    ch_status st = ch_grid_build(&ix->grid[s], nt, (const double(*)[4])boxes, err);
    if (st) {
      free(boxes);
      return st;
    }
  }
  free(boxes);
  int folded = 0;
  for (int t = 0; t < nt; t++) {
    const double *a = w->uv + 6 * (size_t)t, *b = w->wuv + 6 * (size_t)t;
    double da = (a[2] - a[0]) * (a[5] - a[1]) - (a[4] - a[0]) * (a[3] - a[1]);
    double db = (b[2] - b[0]) * (b[5] - b[1]) - (b[4] - b[0]) * (b[3] - b[1]);
    double f[6];
    if (tri_frame(a, f)) folded += !tri_frame(b, f) || (da > 0.0) != (db > 0.0);
  }
  w->stats.folded_triangles = folded;
  /* The shares: texel centres of both squares, looked up in each space. */
  for (int s = 0; s < 2; s++) {
    long count = 0;
#pragma omp parallel for schedule(static) reduction(+ : count)
    for (int y = 0; y < SHARE_RES; y++)
      for (int x = 0; x < SHARE_RES; x++) {
        double q[2] = {(x + 0.5) / SHARE_RES, (y + 0.5) / SHARE_RES}, b[2];
        int t = ch_warp_cage_locate(ix, s, q, b);
        if (t >= 0 && w->visible[t]) count++;
      }
    double share = (double)count / ((double)SHARE_RES * SHARE_RES);
    if (s)
      w->stats.visible_share = share;
    else
      w->stats.unwarped_share = share;
  }
  return CH_OK;
}
