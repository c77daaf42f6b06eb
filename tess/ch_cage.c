/* The warp's cage (diffusion-curves-on-surfaces §3.2 uses the mesh itself):
 * the base surface tessellated at one uniform rate, fine enough that the
 * piecewise-affine cage map follows the warp's intervals. */
#include <math.h>
#include <stdlib.h>

#include "ch_tess.h"

ch_status ch_tess_cage(const ch_surface *surface, long min_triangles, ch_tess_cage_arrays *out, ch_error *err) {
  out->num_triangles = 0;
  out->uv = out->position = NULL;
  ch_tess_result one = {0};
  ch_tess_desc d1 = {.uniform_rate = 1};
  ch_status st = ch_tess_build(surface, &d1, &one, err);
  if (st) return st;
  long fewest = one.mesh.num_faces;
  ch_tess_free(&one);
  /* a rate r gives about r^2 times the triangles of rate 1 */
  int rate = (int)ceil(sqrt((double)min_triangles / (double)(fewest > 0 ? fewest : 1)));
  if (rate < 1) rate = 1;
  if (rate > 64) rate = 64;
  ch_tess_result t = {0};
  ch_tess_desc d = {.uniform_rate = rate};
  if ((st = ch_tess_build(surface, &d, &t, err))) return st;
  const ch_mesh *m = &t.mesh;
  out->uv = malloc(6 * (size_t)m->num_faces * sizeof *out->uv);
  out->position = malloc(9 * (size_t)m->num_faces * sizeof *out->position);
  if (!out->uv || !out->position) {
    ch_tess_free(&t);
    ch_tess_cage_free(out);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the warp's cage (%d triangles)", m->num_faces);
  }
  for (int f = 0; f < m->num_faces; f++)
    for (int c = 0; c < 3; c++) {
      size_t corner = 3 * (size_t)f + c;
      const double *uv = &m->uvs[2 * (size_t)m->corner_uv[corner]];
      const double *p = &m->positions[3 * (size_t)m->corner_position[corner]];
      out->uv[2 * corner] = uv[0];
      out->uv[2 * corner + 1] = uv[1];
      for (int k = 0; k < 3; k++) out->position[3 * corner + k] = p[k];
    }
  out->num_triangles = m->num_faces;
  out->rate = rate;
  ch_tess_free(&t);
  return CH_OK;
}

void ch_tess_cage_free(ch_tess_cage_arrays *cage) {
  free(cage->uv);
  free(cage->position);
  cage->uv = cage->position = NULL;
  cage->num_triangles = 0;
}
