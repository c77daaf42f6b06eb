/* ch_tess: a watertight tessellation of the base surface (ch_surface.h) at
 * per-edge rates, uniform or chosen for a triangle target, optionally
 * following the view-dependent warp, and the warp's cage (the surface at a
 * coarse uniform rate, ch_cage.c). Evaluated through OpenSubdiv's Bfr
 * tessellation patterns (ch_tess.cpp). */
#ifndef CH_TESS_H
#define CH_TESS_H

#include "ch_error.h"
#include "ch_mesh.h"
#include "ch_surface.h"

#ifdef __cplusplus
extern "C" {
#endif

struct ch_warp;

/* Exactly one of the two counts must be > 0. */
typedef struct ch_tess_desc {
  int uniform_rate;      /* > 0: every base edge gets this rate (max 32767) */
  long target_triangles; /* > 0: rates chosen so the count lands within 5% */
  /* NULL, or the view-dependent warp (ch_warp.h): the lengths L below are
   * then lengths in the mesh's warped metric (ch_warp_mesh_arc: warped UV
   * where the camera sees, falling off to the floor away from it), the
   * points of an edge whose faces are all quads are placed evenly in that
   * metric along it, and the interior points of a quad follow (a Coons
   * blend of its four edges' placements, the exact warped grid where W is
   * affine and the focus 1 over the quad's UV rectangle). So the density
   * follows the warp where the camera looks, at the same count. */
  const struct ch_warp *warp;
  int corner_st; /* also fill ch_tess_result.corner_st */
  int closest;   /* with target_triangles: the count closest to it that
                    raising edges one by one gives, even where one
                    density's rates land within 5% */
  /* NULL, or which edges are raised first where edges of one length jump
   * together: those of the lowest priority (an edge on a UV seam: the
   * lower of its sides'), ties spread over the mesh. */
  double (*edge_priority)(void *ctx, const double uv_a[2], const double uv_b[2]);
  void *edge_priority_ctx;
} ch_tess_desc;

/* Rates for target_triangles: the rate of a base edge is max(1, round(d *
 * L)) with L its UV length (the larger of its lengths in the faces that
 * share it, so seams count once at their longer side), d found by
 * bisection so the triangle count brackets the target. When the best of
 * the two bracketing counts is more than 5% off (many edges of one length
 * jump together), the edges that jump are raised one by one, in edge
 * order, until the count is closest to the target. Inner rates of a face
 * (Bfr's interior pattern): quads, the rounded mean of the two opposite
 * edges in each direction ((r0 + r2 + 1) / 2, (r1 + r3 + 1) / 2); other
 * faces, the rounded mean of all edges. So a face whose edges share a rate
 * is a regular grid. Quads and sub-face quads are split into triangles
 * (Bfr facet size 3).
 *
 * Output vertices are ordered: base vertices (the positions faces use, in
 * index order), then the rate-1 inner points of every base edge (edge by
 * edge, from edge_vertices[2e] to edge_vertices[2e+1]), then the interior
 * points of every face (face by face). Each is evaluated once and shared
 * by every triangle that uses it, so the mesh is watertight wherever the
 * base mesh is (UV seams included: positions are shared, UVs are
 * face-varying). vertex_face/vertex_st: where each vertex was evaluated:
 * a base vertex from the lowest-numbered face around it, an edge point
 * from the lowest-numbered face on its edge, an interior point from its
 * face. Triangles are counter-clockwise as their base face is. */
typedef struct ch_tess_result {
  ch_mesh mesh;         /* triangles; positions of B; face-varying UVs;
                           normals: one N per position (corner_normal ==
                           corner_position) */
  int *vertex_face;     /* mesh.num_positions */
  double *vertex_st;    /* 2 * mesh.num_positions */
  int *triangle_face;   /* mesh.num_faces: the base face of each triangle */
  double *corner_st;    /* with ch_tess_desc.corner_st, else NULL: 6 *
                           mesh.num_faces, each corner's (s,t) in its
                           triangle's face (where vertex_face differs, the
                           same point in this face's parameters: Bfr's
                           coordinate of it, not a search for its UV) */
  int num_edges;        /* base edges */
  int *edge_rates;      /* num_edges */
  int *edge_vertices;   /* 2 * num_edges: base position indices */
} ch_tess_result;

/* Tessellates every face of surface. Evaluation runs in parallel with
 * OpenMP over faces and edges; the result is the same bytes for any
 * number of threads. Errors: CH_ERR_INPUT for a bad desc (both or neither
 * set, a rate above 32767, a target below what rate 1 gives or so large
 * that indices would overflow), CH_ERR_NOMEM. out is zeroed on failure. */
ch_status ch_tess_build(const ch_surface *surface, const ch_tess_desc *desc,
                        ch_tess_result *out, ch_error *err);

/* Releases every array of result and zeroes it. Safe on a zeroed struct. */
void ch_tess_free(ch_tess_result *result);

/* The triangles ch_tess_build gives at rate 1 on every edge: the fewest a
 * tessellation of surface has (counted, nothing evaluated). */
long ch_tess_fewest_triangles(const ch_surface *surface);

/* The inner rates of quad face f in result (along s, along t: its
 * interior points are (i / rates[0], j / rates[1])); returns 0 for a face
 * that is not a quad. */
int ch_tess_quad_inner_rates(const ch_surface *surface, const ch_tess_result *result, int f, int rates[2]);

/* The cage of the view-dependent warp (ch_warp_cage's arrays): the surface
 * tessellated at the uniform rate (at most 64) that gives at least
 * min_triangles, per triangle its corners' UV (6) and positions (9). */
typedef struct ch_tess_cage_arrays {
  int num_triangles, rate;
  double *uv, *position;
} ch_tess_cage_arrays;
ch_status ch_tess_cage(const ch_surface *surface, long min_triangles, ch_tess_cage_arrays *out, ch_error *err);
void ch_tess_cage_free(ch_tess_cage_arrays *cage);

#ifdef __cplusplus
}
#endif
#endif
