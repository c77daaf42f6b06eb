/* ch_truth: the true displaced surface of SPEC §3 over the planar base
 * B(u, v) = (u, v, 0), N = +z, on the unit square: the height field
 * z = h(u, v) of the exact h (ch_height), plus the vertical walls where h
 * jumps (step curves, box / bevel / custom jumps of groove profiles).
 *
 * It is independent of tess/: rays are intersected with h itself, never
 * with a tessellation. Method (why: exact walls and crisp classes at any
 * resolution, which a displaced subdivision surface cannot give, since it
 * turns every vertical wall into a slope one micro-polygon wide):
 * - a G x G grid of cells over UV with conservative bounds [lo, hi] of h
 *   per cell (grooves: the distance to a curve is 1-Lipschitz, so over a
 *   disk of radius r around c the signed distance lies in s(c) -+ r and
 *   the profile's range over that interval bounds g; the CSG rule is
 *   non-decreasing in every g_i, so h_groove lies in [F(lo), F(hi)];
 *   steps: h_step is a
 *   bilinear blend of four DCI texel values, bounded by a min/max pyramid);
 * - a ray walks the cells (2D DDA, as the path-based-grooves paper's
 *   Algorithm 1 walks texels); a cell whose bounds the ray passes wholly
 *   above or below is skipped (its side is known); in the others f = z - h
 *   is sampled at most cell / CH_TRUTH_SAMPLES apart in UV, and the first
 *   change of side (against the last known point, so a wall at a cell
 *   border is not lost) is bisected down to `tolerance` (1e-9 in t);
 * - a bracket where h keeps its jump as it shrinks is a wall hit: the
 *   normal is horizontal, across the curve that makes the jump.
 * - between two samples on the same side, halves whose disk bound the
 *   ray's z range still meets are split (8 levels, a budget of 256 bounds
 *   per ray), so a ray skimming a rim just before a wall drops away, or a
 *   ridge's tip, still finds the crossing.
 * The sampling is the truth's resolution: a feature crossed by the ray over
 *   less than spacing / 256 (or once the budget is spent) can be missed;
 *   doubling G halves the spacing (the convergence test). The
 *   bounds assume a curve does not cross itself (the side of a
 *   self-crossing path can flip off the curve); near the open ends of
 *   one-sided profiles they take both sides.
 * Rays are taken to start above the surface; one starting below reports
 * its first crossing upwards.
 *
 * Thread safety: read-only after creation; every query is thread-safe. */
#ifndef CH_TRUTH_H
#define CH_TRUTH_H

#include "ch_error.h"
#include "ch_height.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Visibility classes of a surface point (see ch_truth_classify). */
typedef enum ch_vis_class {
  CH_VIS_NONE = 0,         /* the ray hit nothing */
  CH_VIS_TOP = 1,          /* h_groove = 0: outside every groove (steps included) */
  CH_VIS_GROOVE_WALL = 2,  /* a sloped part of the active groove's profile
                              (P'(t) != 0), or a vertical groove wall */
  CH_VIS_GROOVE_FLOOR = 3, /* a flat part of it (P'(t) = 0, P != 0): box
                              floors, flat pieces of custom profiles */
  CH_VIS_STEP_WALL = 4,    /* the vertical face where h_step jumps */
  CH_VIS_COUNT = 5
} ch_vis_class;

/* Zero means default. */
typedef struct ch_truth_desc {
  int grid;          /* G cells per side of the bounds grid (a multiple of
                        CH_TRUTH_TILE); 0: 512 */
  double tolerance;  /* bisection length in ray parameter t; 0: 1e-9 */
} ch_truth_desc;

typedef struct ch_truth ch_truth;

/* Builds the bounds grid over height (not owned; must outlive the truth).
 * Parallel; deterministic. */
ch_status ch_truth_create(const ch_height *height, const ch_truth_desc *desc, ch_truth **out, ch_error *err);
void ch_truth_destroy(ch_truth *truth);

/* Cells per side, and tiles per side of `tile` cells (for the tracer's
 * primitives); the z bounds of a tile, or of the whole square with tile
 * = -1. */
int ch_truth_grid(const ch_truth *truth);
enum { CH_TRUTH_TILE = 16 };
/* Samples per cell width along a ray (see above). */
enum { CH_TRUTH_SAMPLES = 8 };
int ch_truth_tiles(const ch_truth *truth);
void ch_truth_tile_bounds(const ch_truth *truth, int tile, double box[6]);

typedef struct ch_truth_hit {
  double t;          /* ray parameter */
  double uv[2];      /* = (x, y) of the point */
  double point[3];
  double normal[3];  /* unit; horizontal on walls; not oriented to the ray */
  int wall;          /* 1 on a vertical wall */
} ch_truth_hit;

/* The first crossing of org + t dir (t in (tnear, tfar)) with the surface
 * over the cells of tile (-1: every cell). Returns 1 and fills hit, else 0. */
int ch_truth_intersect(const ch_truth *truth, const double org[3], const double dir[3], double tnear, double tfar,
                       int tile, ch_truth_hit *hit);

/* The class of the surface (non-wall) point at uv, and its curve: the
 * active groove (ch_groove_sample.active) for groove classes, -1 for top.
 * With t = s / w of that groove: wall where its profile's slope P'(t) is
 * not 0, floor where it is 0 (P linear pieces are flat or not exactly). */
void ch_truth_classify(const ch_truth *truth, const double uv[2], ch_vis_class *cls, int *curve);

/* The class of a vertical wall at uv whose horizontal normal is n_uv: the
 * wall of the jump of h nearest to uv along n_uv, within 1e-4 UV (a mesh's
 * wall lies on its curve only to its coordinates' precision: float
 * coordinates put it 3e-8 off, chords of curved walls more), found per
 * part of h (groove, step) in windows growing from 1e-8 and located to
 * 1e-13 by bisection. A groove jump: groove wall of the active groove on
 * the side where |h_groove| is larger; a step jump: step wall of the
 * nearest step curve; both: the nearer, then the larger. Without a jump
 * within reach (a mesh wall where the truth has none): groove wall if a
 * groove is active on either side, else step wall if a step curve is
 * within 1e-4 UV, else top. */
void ch_truth_classify_wall(const ch_truth *truth, const double uv[2], const double n_uv[2], ch_vis_class *cls,
                            int *curve);

/* The exact unit normal of the surface at a non-wall point uv:
 * (-h_u, -h_v, 1) normalised, the groove part analytic (profile slope times
 * the signed distance's gradient), the step part by one-sided differences
 * (the side with the smaller slope, so a nearby jump is not differenced). */
void ch_truth_normal(const ch_truth *truth, const double uv[2], double n[3]);

/* h at uv (ch_height_eval). */
double ch_truth_height(const ch_truth *truth, double u, double v);

#ifdef __cplusplus
}
#endif
#endif
