/* ch_cut: the cut and the output of the feature embedding (see ch_embed.h):
 * each triangle of the refined working mesh (ch_refine) cut along the
 * chords between its edges' crossings (regions, junctions, walls; fans
 * where it cannot be), the thinning of the grooves' layers (ch_thin.h),
 * positions and the output mesh with its normals by group. */
#ifndef CH_CUT_INTERNAL_H
#define CH_CUT_INTERNAL_H

#include <stdint.h>

#include "ch_embed.h"
#include "ch_error.h"
#include "ch_height.h"
#include "ch_label_internal.h"
#include "ch_mesh.h"
#include "ch_refine_internal.h"
#include "ch_surface.h"
#include "ch_tess.h"

#ifdef __cplusplus
extern "C" {
#endif

/* A corner whose UV is not its vertex's (ch_cut_out's parts). */
typedef struct ch_cut_corner_uv {
  int corner; /* 3 * triangle + k */
  double uv[2];
} ch_cut_corner_uv;

/* Blocks of 2 x 2 quads of the base tessellation's grid (a quad face's
 * interior, Bfr's pattern at its inner rates), each two triangles a quad,
 * that the cut left whole (far from every feature it copies them; nearer,
 * the refinement and the cut leave many untouched): where the coarsening
 * may merge a block into two triangles (ch_cut_coarsen). A block's grid
 * points (i, j) in 0..2 are numbered 3 j + i; its sides 0..3 are j = 0,
 * i = 2, j = 2 and i = 0. */
typedef struct ch_cut_blocks {
  int n;
  int *tri;         /* 8 per block: its triangles in the output (the
                       first -1: the cut did not leave them whole) */
  int *vert;        /* 9 per block: its grid points' vertices */
  int *next;        /* 4 per block: the block across each side, -1 if none
                       (another face's, or not a whole block) */
  signed char *ccw; /* per block: 1 if its triangles wind as the grid's
                       (i, j) does, else -1 */
} ch_cut_blocks;

/* The blocks of tess's grid (vertices are the tessellation's, as in the
 * cut's output), their triangles as base triangle indices until
 * ch_cut_blocks_place. None without tess->corner_st. Returns 0, or -1 out
 * of memory (out then empty). */
int ch_cut_blocks_find(const ch_surface *surface, const ch_tess_result *tess, ch_cut_blocks *out);

/* Renumbers the blocks' triangles from base triangles to the output's:
 * base triangle t's are first_out[t] .. first_out[t + 1] - 1 (first_out:
 * one more than the base's triangles). A block any of whose triangles the
 * cut did not leave as one is marked (its first triangle -1). */
void ch_cut_blocks_place(ch_cut_blocks *b, const int *first_out);

void ch_cut_blocks_free(ch_cut_blocks *b);

/* The cut's output before evaluation: vertices as (face, st, h), triangles
 * with their corner UVs and group (owns its arrays: ch_cut_out_free). A
 * part of the cut (one thread's chunk) is one of these too. A corner's UV
 * is most often its vertex's: the joined output keeps each vertex's UV,
 * and per corner only whether it differs (across a UV seam, or a crossing
 * interpolated from the other end of its edge: under 2% of the corners)
 * and then where its own UV is (ch_cut_out_uv). Per corner in full, the
 * UVs were 48 bytes a triangle, the largest array of the finish. */
typedef struct ch_cut_out {
  double *pos; /* filled after evaluation */
  int npos, cap_pos;
  int first_pos; /* index of the first vertex held here (a part of the
                      cut numbers its own vertices after the shared ones) */
  /* what each output vertex is: face, st, h */
  int *face;
  double *st, *h;
  int *tri;        /* 3 per triangle */
  uint64_t *group; /* per triangle: piece label or WALL_GROUP */
  int ntri, cap_tri;
  /* The joined output (no shared_uv): corner c's UV is vertex_uv's for
   * its vertex where corner_uv[c] < 0, else extra_uv's corner_uv[c]-th.
   * A corner that takes another corner's UV takes its corner_uv entry
   * (the tables only grow, so the value is the same). */
  int *corner_uv; /* 3 per triangle */
  double *extra_uv;
  int nextra;
  /* A part of the cut (shared_uv set) keeps no per-corner UVs: a corner's
   * UV is its vertex's (shared_uv below first_pos, vertex_uv from there)
   * except the corners listed in other_uv, by increasing corner: across a
   * UV seam, or where the corner's UV was interpolated in another order.
   * Per corner, the UVs were the largest array at the embedding's peak
   * (48 bytes a triangle, with the working mesh still alive). */
  const double *shared_uv;
  double *vertex_uv; /* 2 per vertex from first_pos (the joined output's
                        from 0) */
  ch_cut_corner_uv *other_uv;
  int nother, cap_other;
  int count_only; /* vertices and triangles are numbered and counted, not
                     stored (a sampled pilot's count: the cut's own) */
  ch_cut_blocks blocks; /* the joined output's, or none (n = 0) */
} ch_cut_out;

/* Merges o's blocks that lie flat in one plane, with UVs affine over
 * them, and are one plain piece, in block order until `fewer` triangles
 * are gone (less one) or none is left: each into the fewest triangles that
 * keep it joined to the blocks that stay (two, or a fan from its centre
 * over the midpoints of the sides towards those). The triangles and
 * vertices that go are dropped, the rest keep their order. Needs o's
 * positions. Returns the triangles removed, -1 out of memory. */
long ch_cut_merge_blocks(ch_cut_out *o, long fewer);

/* The UV of corner c (3 t + k) of the joined output o. */
static inline const double *ch_cut_out_uv(const ch_cut_out *o, size_t c) {
  int x = o->corner_uv[c];
  return x < 0 ? &o->vertex_uv[2 * (size_t)o->tri[c]] : &o->extra_uv[2 * (size_t)x];
}

/* Moves vertex `from` of the joined output o to index `to` (face, st, h,
 * UV and, once evaluated, position): the compactions after a thinning or
 * a coarsening. */
void ch_cut_out_move_vertex(ch_cut_out *o, int to, int from);

/* Drops the vertices v with remap[v] < 0 and the triangles whose first
 * corner is < 0, keeping the order; remap becomes the vertices' new
 * indices, and tri (room for 3 * o->ntri) o's triangles (o->tri is freed),
 * or with tri NULL the triangles stay in o->tri. The same on any number of
 * threads. */
void ch_cut_out_compact(ch_cut_out *o, int *remap, int *tri);

/* Frees o's arrays and zeroes it. */
void ch_cut_out_free(ch_cut_out *o);

/* Fills o->pos: each vertex's base point plus h along the normal, in
 * parallel. Errors: CH_ERR_NOMEM, CH_ERR_INTERNAL (a point the surface
 * does not evaluate). */
ch_status ch_cut_evaluate_positions(const ch_surface *surface, ch_cut_out *o, ch_error *err);

/* Per-corner normals: the angle-weighted mean of the face normals around a
 * vertex among the triangles of the same group (piece, or wall), so they
 * are smooth inside a piece and split at its boundary. Triangles thinner
 * than `thin` (twice their area over their longest edge) count for
 * nothing: their normal is rounding noise. UVs and normals are numbered
 * by vertex, then by the first corner of the vertex that has each (the
 * same on any number of threads). On success m takes o's
 * positions and triangles (o->tri is then NULL; the caller sets o->pos
 * to NULL); o's groups and UVs are spent there (freed and set to NULL;
 * after a failure ch_cut_out_free frees whatever is left). */
ch_status ch_cut_build_mesh(ch_cut_out *o, double thin, ch_mesh *m, ch_error *err);

/* Cuts triangle t into its pieces, with walls where h jumps, into o (fans
 * it where it cannot be cut, counted in stats->unresolved); tol: how close
 * a junction point must be found. 0, or -1 when out of memory. Reads lb
 * and w only: triangles may be cut in parallel into separate outputs. */
int ch_cut_triangle(const ch_label_ctx *lb, const ch_refine_mesh *w, int t, double tol, ch_cut_out *o,
                    ch_embed_stats *stats);

/* Gives back the capacity o's arrays hold beyond their counts (o stays
 * valid if a reallocation fails). */
void ch_cut_out_shrink(ch_cut_out *o);

/* Appends a vertex at uv (face's chart); its index, or -1 when out of
 * memory. */
int ch_cut_out_vertex(ch_cut_out *o, int face, const double st[2], const double uv[2], double h);

/* Appends a triangle to part o (shared_uv set, or count_only; none if
 * two corners are equal: a wall of zero height); 0, or -1 when out of
 * memory. */
int ch_cut_out_tri(ch_cut_out *o, int a, int b, int c, const double *ua, const double *ub, const double *uc,
                   uint64_t group);

/* Adds about `extra` triangles (2 per split) where no groove or wall is,
 * by longest-edge bisection of the triangles of pieces where h is h_step
 * alone (smooth inside, read at the new points by ch_height_eval), in at most
 * max_rounds rounds; o's positions must be evaluated. Returns how many it
 * added (fewer where the quiet part runs out), -1 when out of memory, -2
 * when the surface does not evaluate a new vertex. */
long ch_cut_densify(const ch_surface *surface, const ch_height *height, ch_cut_out *o, long extra, int max_rounds);

/* Removes about `fewer` triangles where h is smooth: first o's flat
 * blocks (ch_cut_merge_blocks: exact, and without a search); then the
 * rest, if any, by collapses (2 triangles each),
 * shortest first: a vertex inside a plain piece (h_step alone, off UV
 * seams) collapses along its shortest allowed edge into a neighbour that
 * keeps its place on the surface. o's positions must be evaluated. Serial
 * after a parallel start; the result does not depend on the thread count.
 * Returns how many it removed (fewer where no collapse is allowed), -1
 * when out of memory; *merged (or NULL) gets how many of them the merges
 * took. */
long ch_cut_coarsen(ch_cut_out *o, long fewer, long *merged);

/* The longest edge a thinning may make around uv, on a coarse grid of
 * CH_CUT_EDGE_GRID^2 cells over the UV square: half the mean longest edge
 * of the tessellation's triangles centred in the cell or its neighbours
 * (before any refinement; fallback where none is), about the spacing of
 * the points where its edges cross a line. So thinning undoes what the
 * refinement spent along the grooves beyond the tessellation's own
 * density (isotropic halvings for the lines' chords, junctions and caps),
 * the base surface is followed along them as finely as elsewhere, and a
 * dense tessellation is left nearly as it is (at 2.1M triangles longer
 * edges took a third more time for little). Made from the tessellation
 * before the embedding lets it go; 0, or -1 when out of memory. */
enum { CH_CUT_EDGE_GRID = 64 };
int ch_cut_edge_grid(const ch_tess_result *tess, double fallback, float *grid);

/* Thins o's groove layers (ch_thin.h) with the longest edges of
 * edge_grid (ch_cut_edge_grid's) and drops the vertices it frees; returns
 * how many, -1 when out of memory. */
int ch_cut_thin(const ch_label_ctx *lb, const float *edge_grid, ch_cut_out *o);

#ifdef __cplusplus
}
#endif
#endif
