/* ch_warp: the view-dependent texture warp (diffusion-curves-on-surfaces
 * §3.2): texture space is resized so that parts of the object that appear
 * large on screen and carry curves get more texels (and, downstream, more
 * triangles).
 *
 * Two spaces: UV (the original texture coordinates) and warped UV, both
 * the unit square.
 * - W = (Wu, Wv): two monotone, piecewise-linear functions on n uniform
 *   intervals per axis, found from per-triangle texture need by a global
 *   per-axis optimisation (ch_warp_build). Exact inverse.
 * - The cage map C: the base surface's triangles (the cage) keep their
 *   barycentric coordinates: a UV point p in cage triangle T with
 *   barycentric b maps to sum_k b_k W(uv_k). This is how a renderer maps a
 *   warped texture onto the triangles (warped UVs at the vertices,
 *   interpolated linearly), so curves are warped by C, and every texel of
 *   warped UV is read back through C^-1. C is affine per triangle; where
 *   the cage does not cover a point, C is W itself.
 *
 * The camera is core's ch_camera; the curves warped through C are
 * ch_warp_curves.h. W is ch_warp.c, the cage map ch_warp_cage.c.
 *
 * Everything here is in shade/: the cage arrives as plain arrays (tess/
 * builds it from the base surface), so shade/ keeps depending on core/
 * only. */
#ifndef CH_WARP_H
#define CH_WARP_H
#include "ch_camera.h"
#include "ch_curves.h"
#include "ch_error.h"
#ifdef __cplusplus
extern "C" {
#endif

/* The cage: triangles of the base surface with per-corner UV and 3D
 * position (corners counter-clockwise in UV, as the base faces are). */
typedef struct ch_warp_cage {
  int num_triangles;
  const double *uv;        /* 6 per triangle: u0 v0 u1 v1 u2 v2 */
  const double *position;  /* 9 per triangle: x0 y0 z0 x1 ... z2 */
} ch_warp_cage;

/* The default exponent of the need (ch_warp_desc.exponent). Texels as
 * seen (1) gives the nearest part of a view the most, but accuracy over
 * all that is seen is best with even density over it: 1/2 keeps the
 * perspective's ordering at half its contrast (measured: bench/warp.sh). */
#ifndef CH_WARP_EXPONENT
#define CH_WARP_EXPONENT 0.5
#endif

/* Zero means default. */
typedef struct ch_warp_desc {
  int intervals;      /* n, intervals per axis; 0: 256 */
  double floor;       /* least slope of W (1 = uniform); 0: 0.1 */
  double max_slope;   /* largest slope of W; 0: 64 */
  double exponent;    /* slopes follow need^exponent: 1 is the paper's
                         texels-as-seen rule, smaller evens the warp out
                         over what is seen; 0: CH_WARP_EXPONENT */
  double max_ratio;   /* largest slope ratio between neighbouring
                         intervals (keeps the warp smooth); 0: 1.25 */
} ch_warp_desc;

typedef struct ch_warp_stats {
  int visible_triangles;    /* cage triangles in the frustum, facing the eye */
  int needy_triangles;      /* of those, the ones that hold curves */
  double max_slope[2];      /* largest slope of Wu, Wv: the virtual
                               resolution is R times these */
  double visible_share;     /* share of warped texels (of the unit square)
                               whose point lies in a visible cage triangle */
  double unwarped_share;    /* the same share without the warp */
  int folded_triangles;     /* cage triangles with UV area whose warped
                               corners turn the other way or collapse: W
                               varies too much across them (a coarse cage),
                               C is not one-to-one there and C^-1 takes the
                               lowest-numbered triangle; the caller warns */
  double seconds_need, seconds_functions, seconds_grids;
} ch_warp_stats;

typedef struct ch_warp {
  int n;                /* intervals per axis */
  double *wu, *wv;      /* n + 1 values each: W at the knots i / n;
                           wu[0] = 0, wu[n] = 1, strictly increasing */
  double floor;         /* the least slope W was built with */
  /* Focus: 1 on the UV cells that visible cage triangles touch, falling by
   * max_ratio per interval away from them (ch_warp_mesh_slopes); a
   * focus_n^2 grid of cells focus_cell intervals wide (row v, column u),
   * NULL for the identity (focus 1 everywhere). */
  int focus_n, focus_cell;
  double *focus;
  /* the cage (copied), its warped corners and a uniform grid over each space */
  int num_triangles;
  double *uv, *wuv;     /* 6 per triangle */
  unsigned char *visible; /* per triangle: 1 in the frustum, facing the eye */
  void *grids;          /* private: triangle grids over UV and warped UV */
  ch_warp_stats stats;
} ch_warp;

/* Builds W and the cage map for cam. Per cage triangle: visible (any part
 * in the frustum, depth > 0, front-facing: the normal of its corners'
 * positions towards the eye; the frustum test is conservative: the screen
 * box of the triangle clipped to the near plane) and holding curves (the
 * control box of one of the curves' segments, grown by half its groove
 * width or its blur radius, whichever is larger, overlaps the triangle's
 * UV box); the need of a visible triangle that holds curves is, per axis,
 * the largest screen-space length (in NDC units) of a unit step in u
 * (resp. v), from the triangle's affine UV -> 3D map, at its corners and
 * centroid that are in front (depth taken >= 1e-6 of the cage's diagonal);
 * others, and triangles without UV or 3D area, need 0. Per interval of
 * each axis the need is the largest of the triangles whose UV range
 * overlaps it; it is spread to the neighbours so that neighbouring needs
 * differ by at most max_ratio; the slopes are max(floor, a * need) capped
 * at max_slope, a chosen so that the slopes average 1 (W(1) = 1; a is
 * solved exactly, not iterated). When no triangle is needy, or the cage is
 * degenerate (no triangle with UV area and 3D area), W is the identity and
 * stats.visible_triangles / needy_triangles tell why; the caller warns. An
 * axis on which no a reaches mean 1 is the identity on its own: that needs
 * the spread need to underflow (n above ~3000) and the intervals with need
 * to be too few to make up for the rest at floor even at max_slope. desc
 * may be NULL (all defaults), set NULL (no curves: the identity).
 * Deterministic on any thread count. Errors: CH_ERR_INPUT for a bad desc
 * (floor outside [0, 1), max_slope < 1, max_ratio <= 1, non-finite values,
 * intervals outside [1, 65536]) or bad cage data (negative count, missing
 * arrays, non-finite values); CH_ERR_NOMEM. out is zeroed on failure. */
ch_status ch_warp_build(const ch_camera *cam, const ch_warp_cage *cage, const ch_curve_set *set,
                        const ch_warp_desc *desc, ch_warp *out, ch_error *err);

/* The identity warp over cage (for runs without --camera that still want
 * the cage map, and for tests): wu = wv = i / n, n = intervals (0: 256),
 * no triangle visible. Errors as ch_warp_build's for intervals and cage. */
ch_status ch_warp_identity(const ch_warp_cage *cage, int intervals, ch_warp *out, ch_error *err);

void ch_warp_free(ch_warp *w);

/* W and its exact inverse, per axis (axis 0: u, 1: v), for any x in
 * [0, 1] (clamped outside). W(0) = 0 and W(1) = 1 exactly. These and the
 * map functions below only read w: safe from any number of threads. */
double ch_warp_axis(const ch_warp *w, int axis, double x);
double ch_warp_axis_inverse(const ch_warp *w, int axis, double y);
/* The slope of W on axis at x (of the interval holding x; at a knot the
 * right one, at 1 the last one). */
double ch_warp_axis_slope(const ch_warp *w, int axis, double x);

/* The density a mesh should follow at uv, as slopes per axis (a mesh
 * edge of UV length l spans l times the slope). The mesh differs from the
 * texture twice:
 * - W has to be separable (a texture is a grid), so the rows and columns
 *   through what the camera sees get the view's slope on one axis all the
 *   way to the borders; a mesh need not be, so per axis W's slope is
 *   multiplied by the focus, falling off away from the view as fast as W's
 *   slopes may vary (max_ratio per interval), down to the floor (or W's
 *   slope where that is smaller).
 * - Texels follow the screen's foreshortening per axis; a mesh has to
 *   resolve walls and creases running in every direction, so it is
 *   isotropic: both slopes are the geometric mean of the two.
 * So where the camera sees, a mesh has as many triangles per UV area as W
 * gives texels (slope_u slope_v), in even shapes. */
void ch_warp_mesh_slopes(const ch_warp *w, const double uv[2], double slopes[2]);

/* The cage map C and its inverse (see above). Return the cage triangle
 * used, or -1 when none holds the point (then W, resp. W^-1, is used).
 * Where triangles overlap in UV the lowest-numbered one is used. */
int ch_warp_map(const ch_warp *w, const double uv[2], double out[2]);
int ch_warp_unmap(const ch_warp *w, const double wuv[2], double out[2]);

/* The share of a mesh's triangles whose UV centroid lies in a visible cage
 * triangle (uv: 2 per UV index, corner_uv: 3 per triangle): how much of
 * the mesh went to what the camera sees. 0 for no triangles. Parallel,
 * deterministic. */
double ch_warp_visible_triangle_share(const ch_warp *w, int num_triangles, const int *corner_uv,
                                      const double *uv);

/* Length of the image under W of the straight UV segment a -> b, from its
 * start up to fraction x in [0, 1] (exact: W is affine between the knot
 * lines the segment crosses), and the inverse: the fraction at which that
 * length is y times the whole (x, y clamped to [0, 1]). a == b, or an
 * image of length 0: arc 0, the inverse returns y. This is the texels'
 * metric; the tessellation uses the mesh's (below). */
double ch_warp_arc(const ch_warp *w, const double a[2], const double b[2], double x);
double ch_warp_arc_inverse(const ch_warp *w, const double a[2], const double b[2], double y);
/* The same in the mesh's metric (ch_warp_mesh_slopes, exact: the slopes
 * are constant between the knot lines, which bound the focus cells):
 * where the tessellation puts its points. */
double ch_warp_mesh_arc(const ch_warp *w, const double a[2], const double b[2], double x);
double ch_warp_mesh_arc_inverse(const ch_warp *w, const double a[2], const double b[2], double y);

#ifdef __cplusplus
}
#endif
/* The curves warped through the cage map: their own module, included
 * here for the code that reads the warp and its curves together. */
#include "ch_warp_curves.h"
#endif
