/* ch_surface: the base surface B, its normal N and its texture coordinates
 * (docs/spec.md §1), evaluated through OpenSubdiv (Far + Bfr). Its watertight
 * tessellation at per-edge rates is ch_tess.h.
 *
 * Parameterisation of a base face (that of Bfr::Parameterization):
 * - quads: (s,t) in [0,1]^2; corner k at (0,0), (1,0), (1,1), (0,1); edge k
 *   runs from corner k to corner k+1 (edge 0 is t = 0).
 * - every other face size, TRIANGLES INCLUDED (Catmull-Clark and bilinear
 *   are quad schemes, so Bfr gives triangles sub-faces too): N quad
 *   sub-faces, one per corner, tiled in a grid of U = 2 (N <= 4), 3 (N < 10)
 *   or 1 + isqrt(N-1) columns. Sub-face k occupies [a, a+1/2] x [b, b+1/2]
 *   with a = k % U, b = k / U; its corner (a,b) is face corner k, (a+1/2, b)
 *   the midpoint of edge k, (a, b+1/2) the midpoint of edge k-1 and
 *   (a+1/2, b+1/2) the face centre. Points outside the sub-faces (the
 *   other half of each tile) are not in the domain.
 *   ch_surface_corner_param and ch_surface_edge_param give the (s,t) of
 *   corners and edge points.
 *
 * The surface (docs/spec.md §1):
 * - CH_SCHEME_BILINEAR: a quad is its bilinear patch. An N-gon (triangles
 *   included) is N bilinear patches, sub-face k spanned by corner k, the
 *   midpoint of edge k, the centroid of the corners, the midpoint of edge
 *   k-1, i.e. for local (a,b) in [0,1]^2 (twice the offset inside the
 *   sub-face) the weights are
 *     w(corner k)   = (1-a)(1-b) + a(1-b)/2 + (1-a)b/2 + ab/N
 *     w(corner k+1) = a(1-b)/2 + ab/N,   w(corner k-1) = (1-a)b/2 + ab/N,
 *     w(other corners) = ab/N.
 *   For a triangle these are its barycentric coordinates (so a triangle is
 *   its plane, and UV is affine over it). N is the same interpolation,
 *   with the same weights, of unit vertex normals, normalised; a vertex
 *   normal is the normalised sum over the faces around the position of
 *   their area vectors (Newell: half the sum of p_k x p_k+1), so it is one
 *   per position and N is continuous across edges and UV seams.
 * - CH_SCHEME_CATMARK: the Catmull-Clark limit surface (boundary
 *   interpolation: edges and corners; Bfr's default approximation near
 *   extraordinary vertices: Gregory patches after 2 levels), N the
 *   normalised cross product of its derivatives.
 * - UV: linear inside each face (bilinear for quads, the weights above
 *   for other faces) whatever the scheme: OpenSubdiv's face-varying
 *   channel with FVAR_LINEAR_ALL.
 */
#ifndef CH_SURFACE_H
#define CH_SURFACE_H

#include <stddef.h>

#include "ch_error.h"
#include "ch_mesh.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum ch_scheme { CH_SCHEME_BILINEAR = 0, CH_SCHEME_CATMARK = 1 } ch_scheme;

typedef struct ch_surface ch_surface;

/* Builds the surface of mesh (which must have UVs; positions shared across
 * UV seams; faces of 3 corners up to OpenSubdiv's limit) with scheme:
 * through an OpenSubdiv refiner, Bfr surfaces (catmark: one per face with
 * its patch points; linear ones: one per face size) and the edge topology
 * for ch_tess_build. The mesh is not referenced
 * afterwards (what is needed is copied). Errors: CH_ERR_INPUT for a mesh
 * without faces or UVs, an index out of range, a face OpenSubdiv rejects
 * (message names the face, 0-based), with the bilinear scheme a position
 * whose faces have no area (no normal); CH_ERR_NOMEM; CH_ERR_INTERNAL.
 * *out is NULL on failure. OpenSubdiv's warnings (non-manifold topology)
 * go to ch_warn. Positions no face uses are ignored. Takes well under a
 * millisecond for the bundled meshes. */
ch_status ch_surface_create(const ch_mesh *mesh, ch_scheme scheme, ch_surface **out,
                            ch_error *err);

/* Releases the surface. NULL is fine. */
void ch_surface_destroy(ch_surface *surface);

int ch_surface_num_faces(const ch_surface *surface);
ch_scheme ch_surface_scheme(const ch_surface *surface);
/* Number of corners of face (0 when face is out of range). */
int ch_surface_face_size(const ch_surface *surface, int face);

/* The (s,t) of corner k of face, and of the point at fraction x in [0,1]
 * along edge k (from corner k to corner k+1). 0 or CH_ERR_INPUT when face,
 * k or x is out of range. */
ch_status ch_surface_corner_param(const ch_surface *surface, int face, int k, double st[2]);
ch_status ch_surface_edge_param(const ch_surface *surface, int face, int k, double x,
                                double st[2]);

/* The UV map is bilinear on each of a face's patches (docs/spec.md §1): a
 * quad is one patch, (s,t) in [0,1]^2; an n-gon's are its n sub-faces,
 * patch k at corner k's (s,t), half a unit wide. The UVs at their corners
 * (s,t) + (0,0), (1,0), (1,1), (0,1) times the patch's size, 8 numbers a
 * patch, as ch_surface_eval_uv gives them (evaluated at the first call
 * for that face: a run that locates nothing makes none); *num_patches gets
 * their count. NULL (and 0) when face is out of range. Thread-safe. */
const double *ch_surface_patch_uvs(const ch_surface *surface, int face, int *num_patches);

typedef struct ch_surface_point {
  double position[3]; /* B */
  double dpds[3], dpdt[3];
  double normal[3];   /* N, unit length */
  double uv[2];
} ch_surface_point;

/* Evaluates B, its derivatives, N and UV at (s,t) of face. Thread-safe (the
 * surface is only read). CH_ERR_INPUT when face is out of range or (s,t)
 * is not finite or outside the face's domain (by more than 1e-9).
 * Catmark: where the derivatives are parallel (cannot happen on a valid
 * Bfr patch, checked anyway) N is taken 1e-7 towards the (sub-)face
 * centre; bilinear: where the interpolated normals cancel, N is the
 * normalised dpds x dpdt. */
ch_status ch_surface_eval(const ch_surface *surface, int face, double s, double t,
                          ch_surface_point *out);

/* Only the UV of ch_surface_eval (the same value, a fraction of the cost). */
ch_status ch_surface_eval_uv(const ch_surface *surface, int face, double s, double t, double uv[2]);

/* Only B and N of ch_surface_eval (the same values, without the UV and,
 * on a bilinear surface where the normals do not cancel, the derivatives):
 * what a displaced point needs. */
ch_status ch_surface_eval_position(const ch_surface *surface, int face, double s, double t, double position[3],
                                   double normal[3]);

#ifdef __cplusplus
}
#endif
/* The tessellation of the surface: its own module, included here for the
 * code that builds and tessellates a surface together. */
#include "ch_tess.h"
#endif
