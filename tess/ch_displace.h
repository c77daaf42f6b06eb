/* ch_displace: the displaced surface S = B + h N (docs/spec.md §3) on a
 * tessellation of the base surface, with normals for shading. */
#ifndef CH_DISPLACE_H
#define CH_DISPLACE_H

#include "ch_error.h"
#include "ch_height.h"
#include "ch_surface.h"
#include "ch_tess.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ch_displace_stats {
  double min_h, max_h;   /* over the vertices */
  double seconds_height; /* evaluating h */
  double seconds_normals;
} ch_displace_stats;

/* Moves every vertex of tess from B to B + h N, h evaluated at the vertex's
 * UV (a vertex on a UV seam takes the UV of its lowest-numbered face, so
 * the mesh stays watertight), and replaces the normals by the displaced
 * surface's: per position, the area-weighted mean of the normals of the
 * triangles around it. Parallel; the same bytes for any number of threads.
 * stats may be NULL. */
ch_status ch_displace_apply(ch_tess_result *tess, const ch_height *height, ch_displace_stats *stats,
                            ch_error *err);

#ifdef __cplusplus
}
#endif
#endif
