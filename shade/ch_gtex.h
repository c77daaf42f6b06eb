/* ch_gtex: path-based groove textures (path-based-grooves §4-§5): the
 * grooves of a curve set as two float textures, a G x G grid over the UV
 * square and a data texture, and the surface h_groove of docs/spec.md §3 they
 * encode, intersected along rays in texture space.
 *
 * Representation (§4.2), all RGBA32F texels (4 floats), as a GPU holds it:
 * - the grid texture, G x G texels, row j = v index: (first list texel in
 *   the data texture, number of elements, min h, max h over the cell; the
 *   paper keeps only the maximum, which Algorithm 1 skips by);
 * - the data texture: per cell the list of the feature elements (curve
 *   segments, straight or quadratic) whose band (half the groove's width
 *   around the segment, rounded caps included) touches the cell, four
 *   element indices per texel; the elements, three texels each (end
 *   points; control point, curve, flags for quadratic and open ends; the
 *   neighbours' tangents at the joints, for docs/spec.md §3's side rule); the
 *   grooves, two texels each (width, depth, profile, priority; the curve's
 *   index in the set, its kind, flags for a one-sided profile and raised
 *   or carved values, the mask of the profile's jumps); the cross-sections
 *   as point lists headed by their kind and count (§4.2, Figure 3(b)),
 *   with what the renderer derives from them stored once: the break
 *   values of t, the range of the profile, whether it is monotone.
 * Integers are stored in floats (exact below 2^24). Positions in float put
 * the curves within 3e-8 UV of the SVG's.
 *
 * Rendering along a ray (§5), shader-shaped (no allocation, no recursion,
 * loops bounded by constants and by the texture's counts; only the two
 * textures are read; thread-safe):
 * - Algorithm 1: a 2D DDA over the grid cells along the ray's projection,
 *   skipping cells the ray passes above (their max h); an empty cell is the
 *   base plane h = 0.
 * - In a cell, every place where the ray can meet the surface or where h
 *   can jump is an event: for each element, where the ray crosses its
 *   profile's facets and break lines (closed form: linear in the ray
 *   parameter for straight segments and straight profile pieces, quadratic
 *   for the `u` ellipse (solved without cancellation) and for every piece
 *   swept around an end point or joint, i.e. the rounded caps and corners);
 *   for quadratic segments on the exact signed distance along the ray,
 *   bracketed by its convexity (the u ellipse's function, not convex on
 *   the side the curve turns to, by bounds on its curvature) and refined
 *   by safeguarded Newton. Between two
 *   events the ray is on one side of h, so the events are the CSG ray
 *   segments of §5.3-5.4 and one point test of h inside each (h evaluated
 *   exactly from the textures: per groove the nearest element and docs/spec.md §3's
 *   side rule, then the CSG rule: carves by minimum over raises) says
 *   whether it is solid. The first solid segment's start is the hit:
 *   masking, crossings, ends, corners and ridges come out of the same rule,
 *   with no per-case priorities (the paper's priority tags are what its
 *   union of per-element profiles needs; docs/spec.md §3's h is the nearest-point
 *   profile, which the point test applies directly). data-priority picks
 *   the hit's owner (material), never the height.
 * - Walls: a hit where h jumps across the ray (box, bevel, custom jumps)
 *   is a wall with a horizontal normal across its curve; elsewhere the
 *   normal is that of h (profile slope times the distance's gradient).
 * - Shadows (§5.6): the same traversal from a point towards the light.
 * Where this departs from the paper: the paper intersects a curved element
 * as the straight line tangent at the point nearest to the current point,
 * and combines the elements of one path as independent features; both are
 * exact only for straight paths and symmetric profiles (its §7 names low
 * curvature as a requirement). ch_gtex_desc.paper selects that
 * approximation for curved elements so the difference can be measured. */
#ifndef CH_GTEX_H
#define CH_GTEX_H

#include <stddef.h>

#include "ch_curves.h"
#include "ch_error.h"

#ifdef __cplusplus
extern "C" {
#endif

enum {
  CH_GTEX_MIN_RES = 1,
  CH_GTEX_MAX_RES = 4096,      /* G^2 texels of 16 bytes: 256 MB at the top */
  CH_GTEX_MAX_CELL_ITEMS = 64, /* elements per cell (the shader's loop bound) */
  CH_GTEX_MAX_PROFILE_POINTS = 16 /* points of a custom cross-section */
};

/* Zero means default. */
typedef struct ch_gtex_desc {
  int resolution; /* G, cells per side over the UV square: required, in
                     [CH_GTEX_MIN_RES, CH_GTEX_MAX_RES] */
  int paper;      /* 1: intersect a quadratic element as the paper does, as
                     its tangent line at the point nearest to the ray in the
                     middle of the cell (for measuring that approximation) */
} ch_gtex_desc;

typedef struct ch_gtex {
  int resolution;      /* G */
  int paper;
  float *grid;         /* G * G * 4: first list texel, count, min h, max h */
  int num_texels;      /* data texels */
  float *data;         /* num_texels * 4 */
  int element_base, curve_base, profile_base; /* texel offsets of the sections */
  int num_elements, num_grooves;
  int max_cell_items;  /* the longest cell list */
  double zmin, zmax;   /* range of h over the square (0 included) */
} ch_gtex;

/* Builds the textures of the grooves of set at desc->resolution.
 * Bad input (CH_ERR_INPUT, one line naming the element and why): a
 * resolution out of range; a step curve (its height is a diffusion over the
 * whole square, which no path profile holds); a custom profile of more
 * than CH_GTEX_MAX_PROFILE_POINTS points; a cell crossed by more than
 * CH_GTEX_MAX_CELL_ITEMS elements (name of the cell and its curves; a finer
 * grid splits it); more data than floats index exactly (2^24 texels).
 * name is the curve file, used in messages. The set is not kept. */
ch_status ch_gtex_build(ch_gtex *tex, const ch_curve_set *set, const ch_gtex_desc *desc, const char *name,
                        ch_error *err);

void ch_gtex_free(ch_gtex *tex);

/* Bytes of the two textures (16 per texel). */
size_t ch_gtex_bytes(const ch_gtex *tex);

/* A hit of a ray with the encoded surface. */
typedef struct ch_gtex_hit {
  double t;          /* ray parameter (dir as given) */
  double point[3];   /* (u, v, h): the plane base (u, v, 0) + h (0, 0, 1) */
  double normal[3];  /* unit; horizontal on walls, facing the ray there */
  int wall;          /* 1 where h jumps across the ray at the hit */
  int curve;         /* index in the set of the groove whose profile gives h
                        there (walls: the deeper side's), or -1 */
  int owner;         /* the groove owning the point (highest data-priority
                        among those with g != 0), or -1 */
  int cells;         /* grid cells visited (for statistics) */
} ch_gtex_hit;

/* The first point of org + t dir, t in [tnear, tfar], on or below the
 * surface z = h_groove(u, v) over the UV square (x = u, y = v). Returns 1
 * and fills hit, else 0. A ray that starts below the surface hits at its
 * start. Thread-safe. */
int ch_gtex_intersect(const ch_gtex *tex, const double org[3], const double dir[3], double tnear, double tfar,
                      ch_gtex_hit *hit);

/* Whether the ray meets the surface in [tnear, tfar] (a shadow ray: start
 * it off the surface). Thread-safe. */
int ch_gtex_occluded(const ch_gtex *tex, const double org[3], const double dir[3], double tnear, double tfar);

/* A facet a pixel sees (region sampling). */
typedef struct ch_gtex_facet {
  double weight;    /* share of the pixel's footprint that sees it */
  double lit;       /* the part of weight the light reaches */
  double normal[3]; /* unit: up for the top and the profile's facets,
                       horizontal for walls (facing the viewer) */
  int wall;
  int curve;        /* the groove, or -1 for the top */
} ch_gtex_facet;

enum { CH_GTEX_MAX_FACETS = 72 };

/* Region sampling (§5.7): what a pixel sees of an isolated straight
 * groove, in closed form. The pixel is the parallelogram of base-plane
 * points at + a du + b dv (a, b in [-1/2, 1/2], UV) seen along dir (a
 * direction into the surface, the same for the whole pixel); L points to
 * the light. Along the groove nothing changes, so in its cross-section
 * every ray is known by where it crosses the base plane, s0; the profile
 * (a polyline; `u` as 32 chords even in its angle) is walked in the rays' direction keeping
 * the farthest s0 seen so far (a facet is visible where its s0 exceeds
 * it), and the same walk along the light gives each facet's lit part. The
 * weights are the measure of s0 over the pixel: the trapezoid that the
 * parallelogram projects to across the groove (the paper takes it as an
 * interval). Returns the facets (weights summing to 1), or 0 where the
 * paper too falls back to supersampling: the pixel, with the rays' and
 * light's travel down to the groove's floor, reaches any element but one
 * straight carved one, or comes within half a width of its ends, or leaves
 * the square. Thread-safe; reads only the textures. */
int ch_gtex_region(const ch_gtex *tex, const double at[2], const double dir[3], const double du[2], const double dv[2],
                   const double L[3], ch_gtex_facet out[CH_GTEX_MAX_FACETS]);

/* What the textures say at one point. */
typedef struct ch_gtex_sample {
  double h;          /* h_groove */
  int active;        /* curve giving h, or -1 */
  double s;          /* signed distance to it */
  double grad[2];    /* gradient of h (0 on flat parts) */
  int owner;         /* as in ch_gtex_hit */
} ch_gtex_sample;

/* h_groove at (u, v) from the textures (0 outside the square). detail may
 * be NULL. Thread-safe. */
double ch_gtex_eval(const ch_gtex *tex, double u, double v, ch_gtex_sample *detail);

#ifdef __cplusplus
}
#endif
#endif
