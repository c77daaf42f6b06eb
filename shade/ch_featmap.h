/* ch_featmap: feature-curve textures (feature-curves-textures §3-§5,
 * normal-maps-discontinuities §4): distance and gradient maps whose
 * distance is exactly zero on the curves at any magnification, per-cell
 * discontinuity configurations and signatures (edge points, tangent
 * angles: quadratic pieces), and the normal of docs/spec.md §3's groove profiles
 * blended in by the papers' eq. (1).
 *
 * Layout. A map over a UV rectangle at resolution R has R x R cells and
 * (R + 1)^2 lattice points at the cells' corners, laid out row-major from
 * the bottom row (v0) up: lattice point (i, j) is at texel coordinates
 * (j + CH_FEATMAP_OFFSET_X, i + CH_FEATMAP_OFFSET_Y), i.e. at
 *   u = u0 + (j + ox) (u1 - u0) / R,  v = v0 + (i + oy) (v1 - v0) / R.
 * The tiny offsets keep curves drawn on round coordinates (a mortar line
 * at v = 1/32) off the lattice lines, so no curve runs along a cell edge
 * or through a sample. Per lattice point the maps hold the samples (signed
 * distance, gradient, nearest curve, base normal, a conventional normal
 * map); per cell (i, j) its south and west edges' signature and its
 * configuration word (the lattice's last row and column hold only the
 * edges of the cells below and left of them).
 *
 * Evaluation (ch_featmap_eval) reads only these arrays, the curve table
 * (profiles) and, for fallback cells, a short list of exact pieces; it is
 * shader-shaped: no allocation, no recursion, bounded loops, no global
 * state, so any number of threads may call it and a GLSL twin can follow.
 *
 * Thread safety: a map is read-only after it is built or read. */
#ifndef CH_FEATMAP_H
#define CH_FEATMAP_H

#include <stddef.h>
#include <stdint.h>

#include "ch_curves.h"
#include "ch_error.h"
#include "ch_exr.h"
#include "ch_image.h"
#include "ch_stepsing.h"

#ifdef __cplusplus
extern "C" {
#endif

struct ch_height; /* ch_height.h */
struct ch_msdf;   /* ch_msdf.h */
struct ch_warp;   /* ch_warp.h */

enum { CH_FEATMAP_MIN_RES = 4, CH_FEATMAP_MAX_RES = 4096 };

/* The lattice both feature maps and the msdf are built on: resolution in
 * CH_FEATMAP_MIN_RES..CH_FEATMAP_MAX_RES and rect finite and not empty,
 * the all-zero rect meaning the UV square; out receives the rect to use.
 * what names the map in the error ("feature map", "distance field"). */
ch_status ch_featmap_check_lattice(const char *what, int resolution, const double rect[4], double out[4],
                                   ch_error *err);
/* Most exact pieces a fallback cell lists (the nearest ones are kept). */
enum { CH_FEATMAP_MAX_PIECES = 32 };
#define CH_FEATMAP_OFFSET_X 1.3e-6
#define CH_FEATMAP_OFFSET_Y 0.7e-6
/* What a cell may be off by before it counts as one the representation
 * cannot hold, in cells: its segment from the curve it stands for (a
 * quadratic piece; the linear variant's straight ones, whose sagitta is
 * the method's own error), and the interpolated distance at its centre
 * (within a groove's band). 2e-4 cells is 1/80 of a pixel at 64x: at 5e-3
 * pixels within 2e-3 cells of a curve came out on its other side (7 of
 * 409,600 in the loops class at 16x, glyphs and panels 0.0005%), and
 * holding the pieces to 2e-4 costs the bundled sets 0-32 more fallback
 * cells at R 256 (of up to 5,600: +0.6% at most). */
#define CH_FEATMAP_TIGHT 0.0002
#define CH_FEATMAP_TIGHT_LINEAR 0.005
#define CH_FEATMAP_TIGHT_DISTANCE 0.005

/* The configuration word of a cell (< 2^24, exact in a float channel).
 * Segments are numbered by their edge pair: 1 S-E, 2 S-N, 3 S-W, 4 E-N,
 * 5 E-W, 6 N-W (edges S, E, N, W); 0 means no segment. */
enum {
  CH_FM_SEG_BITS = 3,
  CH_FM_SEG_MASK = 7,         /* (word >> (3 k)) & 7: segment k's pair */
  CH_FM_STRAIGHT0 = 1 << 6,   /* segment 0 is a straight piece */
  CH_FM_STRAIGHT1 = 1 << 7,
  CH_FM_REVERSED0 = 1 << 8,   /* its curve runs from the pair's second edge to its first */
  CH_FM_REVERSED1 = 1 << 9,
  CH_FM_POINT_S = 1 << 10,    /* the south edge has a discontinuity point */
  CH_FM_POINT_W = 1 << 11,
  CH_FM_FALLBACK = 1 << 12,   /* evaluated from its list of exact pieces */
  /* What the papers' representation could not hold in this cell: */
  CH_FM_LOST_DROPPED = 1 << 13, /* more than two curves: pieces dropped */
  CH_FM_LOST_MERGED = 1 << 14,  /* curves merged into one edge point or one segment */
  CH_FM_LOST_END = 1 << 15,     /* a curve ends inside the cell */
  CH_FM_LOST_LOOP = 1 << 16,    /* a piece leaves through the edge it came in by, or never leaves */
  CH_FM_LOST_CORNER = 1 << 17,  /* a corner of a curve (tangent jump) inside the cell */
  CH_FM_FITTED = 1 << 18,       /* its signature was refitted (constrained fit) */
  CH_FM_STRAIGHTENED = 1 << 19, /* a segment was made straight: no valid fit */
  CH_FM_LOST_MEDIAL = 1 << 20,  /* near the curves, two corners no segment separates have their
                                   nearest points far apart or lie on two sides of their curves:
                                   a medial axis (the inside of a corner, X and T crossings,
                                   close curves) or the tangent line beyond an open end */
  CH_FM_LOST_CSG = 1 << 21,     /* grooves overlap: at a corner h is decided by another groove than
                                   the nearest curve (docs/spec.md §3's CSG rule) */
  CH_FM_LOST_TIGHT = 1 << 22,   /* a segment strays from its curve by more than CH_FEATMAP_TIGHT
                                   cells, or within a groove's band the interpolated distance at the
                                   centre is off by more than CH_FEATMAP_TIGHT_DISTANCE: a curve
                                   bending tighter than a few cells (tiny loops), an inflection */
  CH_FM_LOST_ANY = CH_FM_LOST_DROPPED | CH_FM_LOST_MERGED | CH_FM_LOST_END | CH_FM_LOST_LOOP | CH_FM_LOST_CORNER |
                   CH_FM_STRAIGHTENED | CH_FM_LOST_MEDIAL | CH_FM_LOST_CSG | CH_FM_LOST_TIGHT
};

/* A curve as the maps know it: what its profile needs. */
typedef struct ch_featmap_curve {
  ch_curve_kind kind;
  ch_profile profile;
  double width, depth; /* UV, object units */
  int flat_side;       /* steps: the side where h_step is one value (ch_stepsing_flat_side), or 0 */
} ch_featmap_curve;

/* An exact piece (a whole segment of a curve, UV) listed by fallback
 * cells, with what the side rule of docs/spec.md §3 needs at its ends. */
typedef struct ch_featmap_piece {
  double p[3][2];
  int curve;
  int is_line;
  int start_open, end_open; /* 1: an open end of its subpath */
  double tin[2];            /* at a start joint: the previous segment's unit tangent there */
  double tout[2];           /* at an end joint: the next segment's unit tangent there */
} ch_featmap_piece;

/* Counts of the build (cells of the R x R grid). */
typedef struct ch_featmap_stats {
  long cells_one, cells_two;          /* cells holding one / two segments */
  long points;                        /* edge points */
  long lost_dropped, lost_merged, lost_end, lost_loop, lost_corner, lost_medial, lost_csg, lost_tight; /* cells, per class */
  long pieces_dropped, crossings_merged;
  long invalid, fitted, straightened; /* signatures invalid as crossed; refitted; straightened */
  long fallback_cells, fallback_entries, fallback_overflow;
  /* wall seconds per step; the cells' steps run beside the samples'
   * propagation, within seconds_samples */
  double seconds_samples, seconds_cells, seconds_fit, seconds_check, seconds_smooth, seconds_fallback, seconds_normal,
      seconds_total;
} ch_featmap_stats;

/* Zero means default. */
typedef struct ch_featmap_desc {
  int resolution;           /* R (required): CH_FEATMAP_MIN_RES..CH_FEATMAP_MAX_RES */
  double rect[4];           /* u0 v0 u1 v1; all zero: the unit square */
  int linear;               /* the linear variant (normal-maps-discontinuities §4):
                               straight segments, no angles, no fit */
  int no_fallback;          /* only the papers' handling of what a cell cannot hold */
  int smoothing;            /* gradient smoothing iterations: 0: 10 (the papers'); < 0: none */
  int smooth_everywhere;    /* smooth every sample, as the papers do; by default samples
                               within their curve's profile band (plus 1.5 cells) keep
                               their exact gradient: the smoothing acts away from the
                               features only, where b(d) = 1 hides it */
  int no_singular;          /* keep h_step's whole gradient in the base samples, even
                               near the step curves' ends and crossings (see
                               ch_featmap.singular) */
  int no_normal_map;        /* skip the conventional normal map (and its time) */
  int normal_supersample;   /* its samples per texel side (box filter): 0: 2 */
  const struct ch_height *height; /* h for the base and conventional normal maps where
                               there are step curves; NULL: h_step is taken flat
                               (grooves need no height: they are exact) */
  const struct ch_warp *warp; /* NULL, or the view-dependent warp: the maps are
                               built over `rect` in warped UV (the cells cut
                               along the curves warped through the cage,
                               every sample taken at its original UV), and
                               evaluated at original UV mapped through it.
                               Not owned; must outlive the maps. */
} ch_featmap_desc;

typedef struct ch_featmap {
  int resolution;
  double rect[4];
  int linear;               /* built as the linear variant */
  int has_fallback;         /* fallback lists built */
  int has_base;             /* base holds a non-flat base normal map */
  int has_normal;           /* normal holds the conventional normal map */
  const struct ch_warp *warp; /* the maps are in warped UV (not owned), or NULL */
  /* (R + 1)^2 lattice points */
  float *dist;              /* signed distance (UV) to the nearest curve, + on its left: exact
                               within the widest groove's half width plus two cells of the
                               curves, beyond that to a neighbour's nearest point (8SSEDT) */
  float *grad;              /* 2 each: unit gradient of the unsigned distance (UV), smoothed */
  int32_t *curve;           /* the nearest curve */
  float *base;              /* 3 each: the base normal B (h_step without grooves), unit */
  float *normal;            /* 3 each: conventional normal map of h (box-filtered), unit */
  /* (R + 1)^2 cells */
  float *edge;              /* 4 each: south pos, south angle, west pos, west angle */
  uint32_t *config;
  int32_t *seg_curve;       /* 2 each: the curve of segment 0 and 1 */
  int32_t *fb_start;        /* fallback cells: first entry in fb_list, else -1 */
  uint8_t *fb_count;
  int32_t *fb_list;         /* indices into pieces */
  int fb_list_size;
  ch_featmap_piece *pieces;
  int num_pieces;
  ch_featmap_curve *curves;
  int num_curves;
  /* Beyond the papers: where step curves end or cross, h_step's gradient
   * goes like 1/r (ch_stepsing.h), which no lattice follows. The base
   * samples within CH_FEATMAP_SINGULAR_R1 cells of such a point leave
   * out its term, windowed (ch_stepsing_window from R0 to R1 cells), and
   * evaluation adds it back exactly: sg_near names, per lattice point,
   * the point whose term its sample leaves out (-1: none); NULL when
   * there are none. */
  ch_stepsing_point *singular;
  int num_singular;
  int32_t *sg_near;
  double sg_window; /* R1 of this map (cells): CH_FEATMAP_SINGULAR_R1 when
                       built; 12 in files written before it was stored */
  ch_featmap_stats stats;
} ch_featmap;

/* (Wider than the 4 / 12 first used: with h_step's own terms taken out of
 * its diffusion (ch_dci.h) the samples' remainder is smooth farther out,
 * and the window's own curvature, which the blend must follow, falls as
 * 1 / R1^2.) */
#define CH_FEATMAP_SINGULAR_R0 8.0
#define CH_FEATMAP_SINGULAR_R1 24.0
/* R1 of maps files that do not say (written before it changed) */
#define CH_FEATMAP_SINGULAR_R1_LEGACY 12.0

/* Each singular point's term is whole within radius R0 / R1 and gone
 * from radius (its field ch_stepsing_point.radius): maps->sg_window cells, or half the
 * way to the nearest other point, so that no two windows overlap (one
 * term per point of the map, no seams between them) and a window ends
 * before an arm's curve does (a short dash: its other end). */
double ch_featmap_singular_window(const ch_stepsing_point *pt, double distance);

/* Fills maps->sg_near from maps->singular (the point whose window holds
 * each lattice point); CH_ERR_NOMEM only. Used by the build and the
 * reader, so both leave out the same terms. */
ch_status ch_featmap_singular_index(ch_featmap *maps, ch_error *err);

/* The term of the singular point that the samples around (u, v) (maps'
 * UV, no warp) leave out, windowed: added to the interpolated base
 * gradient. Zero where there is none. */
void ch_featmap_singular_gradient(const ch_featmap *maps, const size_t corner[4], const double uv[2], double g[2]);

/* Whether curve c of set is a discontinuity the maps encode: every groove,
 * and step curves without blur (a blurred step is smooth: it belongs to
 * the base normal map). */
int ch_featmap_encodes(const ch_curve_set *set, int c);

/* The transformation table (feature-curves §4): the configuration (the
 * segments' pairs in the low 6 bits, as in the configuration word) after
 * a piece joining edge pair `pair` (1..6) is added; *what (may be NULL):
 * 0 added, 1 merged with the same pair already there, 2 dropped (the cell
 * holds two). Every result is a valid configuration. */
unsigned ch_featmap_transform(unsigned config, int pair, int *what);

/* Builds the maps of set's curves. No curve to encode, R out of range, a
 * bad rectangle or non-finite curves give CH_ERR_INPUT. Parallel over
 * rows and cells where the work is independent; the result is the same for
 * any thread count. out is zeroed on failure. */
ch_status ch_featmap_build(const ch_curve_set *set, const ch_featmap_desc *desc, ch_featmap *out, ch_error *err);

void ch_featmap_free(ch_featmap *maps);

typedef enum ch_featmap_method {
  CH_FEATMAP_FEATNORM = 0, /* quadratic pieces, curvilinear triangles (feature-curves §5) */
  CH_FEATMAP_LINEAR,       /* straight pieces, straight triangles (normal-maps §4.3) */
  CH_FEATMAP_BILINEAR      /* plain bilinear: the signed distance's sign for the side,
                              the conventional normal map for the normal */
} ch_featmap_method;

/* What the maps say at a point. */
typedef struct ch_featmap_sample {
  double distance;    /* unsigned, UV */
  double gradient[2]; /* unit gradient of the distance (UV) */
  int curve;          /* the nearest curve, -1 if none */
  int side;           /* +1 left of it, -1 right */
  double base[3];     /* base normal B there */
  double normal[3];   /* the normal: eq. (1) with the curve's profile (unit, z up) */
  int kind;           /* 0: a cell without features, 1: with, 2: a fallback cell */
} ch_featmap_sample;

/* Evaluates the maps at UV (u, v) (in the maps' rectangle; outside, the
 * border cells extrapolate; with a warp, (u, v) is original UV, mapped
 * through it). Shader-shaped; thread-safe. */
void ch_featmap_eval(const ch_featmap *maps, ch_featmap_method method, double u, double v, ch_featmap_sample *out);

/* The papers' blend (feature-curves eq. (1), normal-maps eq. (1)) with
 * b(d) = 0 up to w0 and 1 from w1 (smoothstep between; w0 = w1 is a
 * step), for curve c at distance d on `side`, the unit distance gradient
 * and the base normal: n = (1 - b) n_p + b~ B, n_p the profile's normal
 * taken over the base's slope (for a flat base, exactly the papers'
 * (-p'(d) grad d, 1)), b~ = b |n_p|. With w0 = w1 = c's half width,
 * exact d, gradient and B give the exact normal of docs/spec.md §3's h. Steps
 * have no profile: n = B. n is unit. */
void ch_featmap_profile_normal(const ch_featmap_curve *c, int side, double d, const double grad[2],
                               const double base[3], double w0, double w1, double n[3]);

/* The profile's slope dP/dt at t (at a break, the piece to the right;
 * vertical rims of u give a large finite value). */
double ch_featmap_profile_slope(const ch_profile *profile, double t);

/* Parses "featnorm", "featnorm-linear" or "normal-bilinear"; -1 if none. */
int ch_featmap_method_parse(const char *name);

/* Bytes per texel a GPU layout of each representation needs (documented
 * in ch_featmap.c): method's lattice and cell data; fallback lists are
 * counted apart (ch_featmap_fallback_bytes). */
double ch_featmap_bytes_per_texel(const ch_featmap *maps, ch_featmap_method method);
double ch_featmap_fallback_bytes(const ch_featmap *maps);

/* Writes the maps (and, if msdf is not NULL, a distance field of the
 * same resolution beside them) as one float EXR of (R + 1) x (R + 1)
 * pixels, row 0 the top lattice row (v1). Layers: d (signed distance, UV),
 * grad.X grad.Y, curve, sig.S.pos sig.S.angle sig.W.pos sig.W.angle
 * (the cell's south and west edge points: position along the edge,
 * tangent angle in radians), config (the configuration word), seg.curve0
 * seg.curve1; base.X/Y/Z where h_step is not flat; N.X N.Y N.Z the
 * conventional normal map; msdf.R/G/B. Attributes: chisel:command
 * "featmap", chisel:featmap (format, "1"), chisel:featmap-mode,
 * chisel:resolution, chisel:rect, and the tables as text
 * (chisel:featmap-curves, -pieces, -fallback, -flat and -singular where
 * there are flat sides and singular points, chisel:msdf-range), plus
 * `extra`. Atomic. */
/* (Maps built under a warp are not written: CH_ERR_INPUT.) */
ch_status ch_featmap_write_exr(const char *path, const ch_featmap *maps, const struct ch_msdf *msdf,
                               const ch_exr_attribute *extra, int num_extra, ch_error *err);

/* Reads maps written by ch_featmap_write_exr; msdf, if not NULL, gets the
 * distance field (resolution 0 if the file has none). Anything else (a
 * file of another command, a truncated one, values out of range) gives
 * CH_ERR_INPUT naming the file and what is wrong; outputs are zeroed on
 * failure. */
ch_status ch_featmap_read_exr(const char *path, ch_featmap *maps, struct ch_msdf *msdf, ch_error *err);

/* The same from a file in memory (name is used in messages). */
ch_status ch_featmap_read_exr_memory(const void *data, size_t size, const char *name, ch_featmap *maps,
                                     struct ch_msdf *msdf, ch_error *err);

#ifdef __cplusplus
}
#endif
#endif
