/* ch_trace: Embree scenes for validation (the only file group that uses
 * Embree, docs/architecture.md): the true surface as an Embree user geometry (one
 * primitive per tile of the truth's bounds grid, so Embree's BVH culls
 * tiles by their z bounds and ch_truth intersects inside a tile), and any
 * triangle mesh as an Embree triangle geometry.
 *
 * Rays are given and answered in double: Embree traverses in float, then a
 * mesh hit is re-intersected in double with the same triangle (so a mesh
 * that is the truth gives the truth's t and UV to ~1e-15, not 1e-7), and
 * the truth computes its hit in double from the double ray it is handed.
 *
 * Thread safety: a scene is read-only after creation; intersect and
 * occluded may be called from many threads at once. */
#ifndef CH_TRACE_H
#define CH_TRACE_H

#include "ch_error.h"
#include "ch_mesh.h"
#include "ch_truth.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ch_trace ch_trace;

/* truth is not owned and must outlive the scene. */
ch_status ch_trace_create_truth(const ch_truth *truth, ch_trace **out, ch_error *err);

/* Copies the mesh (polygons split into fans). It must have UVs (the
 * visibility class is read at the hit's UV); name is used in messages. */
ch_status ch_trace_create_mesh(const ch_mesh *mesh, const char *name, ch_trace **out, ch_error *err);

void ch_trace_destroy(ch_trace *scene);

typedef struct ch_trace_hit {
  double t;                 /* along the ray (dir as given) */
  double point[3];
  double uv[2];             /* truth: (x, y); mesh: interpolated from the corners */
  double normal[3];         /* geometric, unit: truth's exact normal, a mesh face's normal */
  double shading_normal[3]; /* mesh: interpolated vn where the mesh has them; else = normal */
  int wall;                 /* truth: on a vertical wall; mesh: |normal z| < 1e-3 */
  int face;                 /* mesh: the input face; truth: the tile */
} ch_trace_hit;

/* Closest hit in (tnear, tfar). Returns 1 and fills hit, else 0. */
int ch_trace_intersect(const ch_trace *scene, const double org[3], const double dir[3], double tnear, double tfar,
                       ch_trace_hit *hit);

/* Whether anything is hit in (tnear, tfar). */
int ch_trace_occluded(const ch_trace *scene, const double org[3], const double dir[3], double tnear, double tfar);

/* Triangles of a mesh scene (polygons counted as fans); 0 for the truth. */
long ch_trace_triangles(const ch_trace *scene);

/* Scene bounds: min xyz, max xyz. */
void ch_trace_bounds(const ch_trace *scene, double box[6]);

#ifdef __cplusplus
}
#endif
#endif
