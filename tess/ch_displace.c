/* Displacement of a tessellation: P = B + h N. Normals are recomputed from
 * the displaced triangles (area weighted, so large faces dominate and the
 * sum is the same whatever the triangle order within a fan). */
#include "ch_displace.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "ch_alloc.h"
#include "ch_math.h"

ch_status ch_displace_apply(ch_tess_result *tess, const ch_height *height, ch_displace_stats *stats,
                            ch_error *err) {
  ch_mesh *m = &tess->mesh;
  int np = m->num_positions, nf = m->num_faces;
  double t0 = omp_get_wtime();
  /* The UV of each position: that of its first corner in face order (the
   * lowest-numbered face), so seam vertices get one height. */
  int *first_corner = ch_alloc_large((size_t)np, sizeof *first_corner, 0);
  double *h = ch_alloc_large((size_t)np, sizeof *h, 0);
  if (!first_corner || !h) {
    free(first_corner);
    free(h);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory displacing %d vertices", np);
  }
  for (int p = 0; p < np; p++) first_corner[p] = -1;
  for (int c = m->num_corners - 1; c >= 0; c--) first_corner[m->corner_position[c]] = c;
#pragma omp parallel for schedule(dynamic, 1024)
  for (int p = 0; p < np; p++) {
    int c = first_corner[p];
    if (c < 0) {
      h[p] = 0.0;
      continue;
    }
    const double *uv = &m->uvs[2 * (size_t)m->corner_uv[c]];
    h[p] = ch_height_eval(height, uv[0], uv[1]);
    double *pos = &m->positions[3 * (size_t)p];
    const double *n = &m->normals[3 * (size_t)p];
    for (int k = 0; k < 3; k++) pos[k] += h[p] * n[k];
  }
  double t1 = omp_get_wtime();
  if (stats) {
    stats->min_h = INFINITY;
    stats->max_h = -INFINITY;
    for (int p = 0; p < np; p++)
      if (first_corner[p] >= 0) {
        stats->min_h = fmin(stats->min_h, h[p]);
        stats->max_h = fmax(stats->max_h, h[p]);
      }
    stats->seconds_height = t1 - t0;
  }
  free(first_corner);
  free(h);
  /* Normals of the displaced surface: area-weighted sums per position.
   * Gathered per face in order (serial over faces keeps the sums' order
   * fixed), then normalised in parallel. */
  double *nrm = m->normals;
  memset(nrm, 0, 3 * (size_t)np * sizeof *nrm);
  for (int f = 0; f < nf; f++) {
    int a = m->corner_position[m->face_start[f]], b = m->corner_position[m->face_start[f] + 1],
        c = m->corner_position[m->face_start[f] + 2];
    const double *pa = &m->positions[3 * (size_t)a], *pb = &m->positions[3 * (size_t)b],
                 *pc = &m->positions[3 * (size_t)c];
    double e1[3] = {pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]};
    double e2[3] = {pc[0] - pa[0], pc[1] - pa[1], pc[2] - pa[2]};
    double fn[3];
    ch_cross3(e1, e2, fn);
    for (int k = 0; k < 3; k++) {
      nrm[3 * (size_t)a + k] += fn[k];
      nrm[3 * (size_t)b + k] += fn[k];
      nrm[3 * (size_t)c + k] += fn[k];
    }
  }
#pragma omp parallel for schedule(static)
  for (int p = 0; p < np; p++) {
    double *n = &nrm[3 * (size_t)p];
    double len = sqrt(ch_dot3(n, n));
    if (len > 0.0)
      for (int k = 0; k < 3; k++) n[k] /= len;
  }
  if (stats) stats->seconds_normals = omp_get_wtime() - t1;
  return CH_OK;
}
