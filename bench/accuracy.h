/* accuracy: how close a displaced mesh over the planar base B = (u, v, 0)
 * comes to the exact surface (the README's accuracy table), whose
 * vertices (x, y, z) should satisfy z = h(x, y) with h the exact height of
 * docs/spec.md §3.
 *
 * On the cell centres ((i + 1/2) / G, (j + 1/2) / G) of a G x G grid over
 * the unit square, the mesh's non-vertical triangles (|n_z| > 1e-3, polygons
 * split into fans) are rasterised in xy, keeping the largest z where several
 * cover a sample, and the face normal of that triangle. The rasteriser is
 * watertight: vertices are snapped to a fixed-point grid of 1/(G S) (S a
 * power of two, G S <= 2^26; about 1.5e-8 UV at G = 2048), edge functions
 * are exact 64-bit integers and samples on an edge or vertex go to exactly
 * one triangle (a symbolic perturbation of the sample by (eps, eps^2), the
 * "top-left" rule), so a sample is never missed between triangles that
 * share an edge. z is read from the plane of the unsnapped triangle.
 *
 * Then, with hmax = max |h| over the samples (1 if h is 0 everywhere):
 * - l1: mean |z - h| / hmax over the covered samples (holes are left out
 *   and counted in `holes`, which must be 0 for a valid result);
 * - band: among samples within 2e of a wall or crease of h, e =
 *   sqrt(2 / triangles), the fraction with |z - h| > 0.1 hmax; uncovered
 *   samples count as wrong;
 * - normal_mean_deg / normal_p95_deg: the angle between the face normal
 *   (oriented to n_z > 0: the shape, not the winding, is measured) and the
 *   exact normal (-h_u, -h_v, 1)/|.| over the covered samples whose
 *   distance to the nearest wall or crease is in [1e-3, 1e-2] UV; the 95th
 *   percentile is the nearest-rank one (the ceil(0.95 n)-th smallest). h_u
 *   and h_v are central differences of the exact h with step 1e-5 UV: the
 *   samples are at least 1e-3 from every feature, so the stencil never
 *   crosses one.
 * - holes: fraction of samples covered by no non-vertical triangle.
 *
 * Walls and creases of h: for every groove, the lines s = t_k w of the
 * break points t_k of its profile (ch_profile_creases: box and custom jumps
 * are walls, the others creases; t = 0 is the path itself), with the
 * distance to such a line taken as |s - t_k w| (s the signed distance to the
 * exact curve; exact away from the curve's medial axis); for every sharp
 * step curve (data-blur 0), the curve itself (a wall when left != right, a
 * crease of the diffused field otherwise). Blurred step curves are neither:
 * their h is smooth. CSG is ignored: a groove's lines count even where a
 * deeper groove removes them, and the lines where two grooves' profiles
 * meet are not counted; neither are the lines beyond an open end where a
 * one-sided profile (bevel, asymmetric custom) changes side.
 *
 * All loops run with OpenMP over rows or row bands, and every sum is made
 * in a fixed order: the figures do not depend on the thread count. */
#ifndef CH_ACCURACY_H
#define CH_ACCURACY_H

#include "ch_curves.h"
#include "ch_error.h"
#include "ch_height.h"
#include "ch_mesh.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ch_accuracy {
  double l1, band, normal_mean_deg, normal_p95_deg, holes;
  long samples;        /* covered samples (those l1 averages over) */
  long band_samples;   /* samples within 2e of a wall or crease */
  long normal_samples; /* covered samples 1e-3..1e-2 from a wall or crease */
  long triangles;      /* fan triangles of the mesh, vertical ones included */
  double edge_length;  /* e = sqrt(2 / triangles) */
  double max_abs_h;    /* max |h| over the samples */
  long counted;        /* samples the figures count (all, or the mask's) */
  /* The same for the mesh's own normals (vn) interpolated across each
   * triangle, as smooth shading shows them; NaN (and 0 samples) for a
   * mesh without normals. */
  double shading_mean_deg, shading_p95_deg;
  long shading_samples;
} ch_accuracy;

/* Distances to walls and creases count when below this bound (UV); the
 * normal band ends at 1e-2. */
#define CH_ACCURACY_NORMAL_MIN 1e-3
#define CH_ACCURACY_NORMAL_MAX 1e-2

/* The mesh-independent part: h, the distance to the nearest wall or crease
 * and the exact gradient near features, on the G x G sample grid. Building
 * it once lets many meshes be measured against the same curves. */
typedef struct ch_accuracy_reference {
  int grid;
  double max_abs_h;
  double reach;    /* distances above this are stored as +inf */
  double *h;       /* grid^2, row j (v) major: index j * grid + i */
  double *dist;    /* grid^2 */
  float *grad;     /* 2 * grid^2: (h_u, h_v) in the normal band, else NaN */
  const ch_height *height;   /* not owned */
  const ch_curve_set *set;   /* not owned */
  float *error_map;          /* optional, set by the caller: grid^2 floats that
                                measuring fills with (z - h) / max |h|, NaN
                                where uncovered (row j major, as h) */
  float *normal_map;         /* optional, likewise: the normal error in degrees
                                on the samples the normal figures use, NaN
                                elsewhere */
  float *shading_map;        /* optional, likewise: the shading normals' error */
  const unsigned char *mask; /* optional, set by the caller: grid^2 bytes
                                (row j major); samples with 0 are left out of
                                every figure (what a camera does not see) */
} ch_accuracy_reference;

ch_status ch_accuracy_reference_init(ch_accuracy_reference *ref, const ch_height *height,
                                     const ch_curve_set *set, int grid, ch_error *err);
void ch_accuracy_reference_free(ch_accuracy_reference *ref);

/* Measures a mesh against a reference (whose distances are extended if the
 * mesh is so coarse that 2e exceeds the reach). */
ch_status ch_accuracy_measure_reference(ch_accuracy_reference *ref, const ch_mesh *mesh,
                                        ch_accuracy *out, ch_error *err);

/* The figures above, on a grid x grid sample grid (the README's: 2048). height
 * must evaluate h of set (steps read with CH_RECON_EXACT from a fine DCI). */
ch_status ch_accuracy_measure(const ch_mesh *mesh, const ch_height *height, const ch_curve_set *set,
                              int grid /* 2048 */, ch_accuracy *out, ch_error *err);

/* The baseline "uniform grid with exact vertex heights": vertices
 * (i/n, j/n, h(i/n, j/n)) for 0 <= i, j <= n, UVs (i/n, j/n), no normals,
 * and 2 n^2 triangles, counter-clockwise, with the diagonal of cell (i, j)
 * alternating in a checkerboard ((i + j) even: from (i, j) to (i+1, j+1);
 * odd: from (i+1, j) to (i, j+1)) so that both diagonal directions are
 * treated alike. Heights are evaluated in parallel. */
ch_status ch_accuracy_uniform_grid(const ch_height *height, int n, ch_mesh *out, ch_error *err);

/* The n whose 2 n^2 is closest to target_tris (the smaller n on ties). */
int ch_accuracy_uniform_n(long target_tris);

/* Parses OBJ text (size bytes, and one more writable byte after them: the
 * parser ends lines with NULs in place) into m: v lines as positions (in
 * double), vn as normals, f as polygons (v, v/vt, v//vn or v/vt/vn; negative
 * indices count back). Normals are kept only where every corner names a
 * valid one (m->normals NULL otherwise); everything else is skipped. path
 * names the text in errors: CH_ERR_INPUT with the line for a bad number,
 * index or face, CH_ERR_NOMEM. */
ch_status ch_accuracy_parse_obj(char *text, size_t size, const char *path, ch_mesh *m, ch_error *err);

/* Replaces each vertex's z by the bilinear reading, at its (x, y), of an
 * R x R raster of h at the pixel centres (edges clamped): a mesh displaced
 * by a height texture, as a Displace modifier does. */
ch_status ch_accuracy_read_raster(const ch_height *height, int R, ch_mesh *mesh, ch_error *err);

#ifdef __cplusplus
}
#endif
#endif
