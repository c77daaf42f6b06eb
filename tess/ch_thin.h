/* ch_thin: thinning the bands of a layered cut. The feature embedding cuts
 * a groove into layers (slices between its break lines, dense near a u
 * groove's rims) through an isotropic tessellation, so every line gets a
 * vertex wherever an edge of the tessellation crosses it, however straight
 * the line runs there: each slice costs as many triangles as the isotropic
 * triangles it crosses. Thinning collapses, one at a time, the vertices
 * inside a family of layers (one groove's), moving each onto a neighbour:
 * along its line for a vertex on a line, anywhere for one inside a layer.
 * What it keeps: every line stays a chain of edges (a line vertex moves only
 * along it), the mesh stays manifold (the link condition), no triangle
 * turns over or lies along a single line (all three corners on it: flat
 * where the layer slopes), vertices touching another family, a wall or the
 * outside never move, and every new edge passes the caller's test (its
 * chord follows h; not longer than the tessellation around it). The result
 * has long edges along the grooves and thin triangles across them, as a
 * mesh made for them would (an anisotropic mesh by decimation).
 * In index order within tiles of UV, tiles of one colour of a 2 x 2
 * checkerboard side by side (OpenMP), collapses reaching beyond their tile
 * again on a grid shifted by half a tile, and those reaching beyond that
 * too in a sequential sweep: the same bytes for any thread count. The
 * rules' callbacks are called from several threads at once, for vertices of
 * different tiles. */
#ifndef CH_THIN_H
#define CH_THIN_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ch_thin_rules {
  /* The band of a triangle of group `group`: its family (>= 0) with its
   * layer in *layer (layers k and k + 1 of a family meet along line k), or
   * -1 for a triangle in none (its corners never move). */
  int (*band)(void *ctx, uint64_t group, int *layer);
  /* The longest new edge allowed with its middle at uv (a cheap test,
   * made before all others). */
  double (*max_edge)(void *ctx, const double uv[2]);
  /* Whether the straight edge between vertices va and vb, at UV a and b,
   * inside the band of `family`, may be made: h along it close enough to
   * the chord. */
  int (*edge_ok)(void *ctx, int family, int va, int vb, const double a[2], const double b[2]);
  /* Whether the triangle of vertices v with UVs uv, which a collapse would
   * make in `layer` of the band of `family`, may be made (its facet's
   * normal); may be NULL. */
  int (*triangle_ok)(void *ctx, int family, int layer, const int v[3], const double *uv[3]);
  void *ctx;
} ch_thin_rules;

/* Thins the triangles tri (3 vertex indices each, below num_vertices), with
 * their corners' UVs (counter-clockwise or all clockwise: corner c's is
 * vertex_uv's of its vertex where corner_uv[c] < 0, else extra_uv's
 * corner_uv[c]-th; a corner that moves to another vertex takes that
 * vertex's corner_uv entry in the chart it moves in) and groups (one per
 * triangle), in place: collapsed triangles
 * are removed and the rest keep their order; *num_triangles is updated.
 * removed (num_vertices, zeroed by the caller) gets 1 for every vertex no
 * triangle uses any more. Vertices whose corners differ in UV by more than
 * rounding (1e-12: a seam) stay.
 * Returns the number of vertices removed, or -1 when out of memory (then
 * nothing is changed). */
int ch_thin_bands(int num_vertices, int *num_triangles, int *tri, int *corner_uv, const double *vertex_uv,
                  const double *extra_uv, uint64_t *group, const ch_thin_rules *rules, unsigned char *removed);

#ifdef __cplusplus
}
#endif
#endif
