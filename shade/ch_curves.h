/* ch_curves: feature curves in UV space and their SVG reader (docs/spec.md §2).
 *
 * A curve is one SVG path (or basic shape): one or more subpaths made of
 * quadratic Bezier segments in UV (u right, v up). Lines are stored as
 * segments whose control point is the midpoint, flagged so that queries can
 * take the exact straight-line branch. Cubics and arcs are split into
 * quadratics within CH_CURVES_SPLIT_TOLERANCE UV. */
#ifndef CH_CURVES_H
#define CH_CURVES_H

#include <stddef.h>

#include "ch_error.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Cubic and arc approximation tolerance in UV (docs/spec.md §2). The
 * original SPEC asked for 1e-4; we use 1e-6 so the quadratics follow the
 * drawn cubic far below a texel even at 16k resolution, and so h_groove
 * agrees with an evaluation on the exact cubic to about 1e-6 for usual
 * groove slopes. */
#define CH_CURVES_SPLIT_TOLERANCE 1e-6

typedef enum ch_curve_kind { CH_CURVE_GROOVE = 0, CH_CURVE_STEP = 1 } ch_curve_kind;

typedef enum ch_profile_kind {
  CH_PROFILE_V = 0,
  CH_PROFILE_U,
  CH_PROFILE_BOX,
  CH_PROFILE_RIDGE,
  CH_PROFILE_BEVEL,
  CH_PROFILE_CUSTOM
} ch_profile_kind;

enum { CH_PROFILE_MAX_POINTS = 64, CH_CURVE_ID_MAX = 64 };

/* A groove cross-section P(t), t = s / width in [-1/2, 1/2], zero outside.
 * Custom profiles are (t, h) points with non-decreasing t in [-1/2, 1/2];
 * two points with equal t make a vertical wall. */
typedef struct ch_profile {
  ch_profile_kind kind;
  int num_points;
  double t[CH_PROFILE_MAX_POINTS];
  double h[CH_PROFILE_MAX_POINTS];
} ch_profile;

typedef struct ch_segment {
  double p[3][2];  /* quadratic Bezier control points in UV */
  int curve;       /* owning curve */
  int prev, next;  /* neighbouring segments in the subpath, -1 at open ends */
  int is_line;     /* 1 if straight (p[1] is the midpoint) */
} ch_segment;

typedef struct ch_subpath {
  int first_segment, num_segments;
  int closed;  /* Z, or the end coincides with the start */
} ch_subpath;

typedef struct ch_curve {
  char id[CH_CURVE_ID_MAX];  /* SVG id, or "" */
  char element[16];          /* "path", "circle", ... */
  int element_index;         /* 0-based index among the file's curve elements */
  int source_line;           /* line of the element in the SVG file */
  ch_curve_kind kind;
  ch_profile profile;
  double width;              /* groove width in UV */
  double depth;              /* object units; positive carves */
  double left, right;        /* step values on each side, object units */
  int has_colors;
  double left_color[3], right_color[3];  /* sRGB-encoded 0..1 from #rrggbb */
  double blur;               /* UV */
  int priority;
  int first_segment, num_segments;
  int first_subpath, num_subpaths;
  double bbox[4];            /* umin vmin umax vmax of the control polygon */
  /* What decided the kind and the width (docs/spec.md §2, docs/svg.md), for
   * `chisel info`: "data-attributes" (own or inherited),
   * "stroke" (a stroked path without them), "fill" (a filled closed shape
   * without stroke: a step raised by the fill height), "default" (none of
   * these); and "data-width", "stroke-width", "stroke" (SVG's default
   * stroke width, 1) or "default" (8 viewBox units). */
  char decided_by[16];
  char width_from[16];
} ch_curve;

typedef struct ch_curve_set {
  int num_curves;
  ch_curve *curves;
  int num_segments;
  ch_segment *segments;
  int num_subpaths;
  ch_subpath *subpaths;
  double viewbox[4];  /* x0 y0 w h of the source SVG */
  /* Painted fills whose outlines the reader replaced by their union
   * (docs/svg.md), and of them those left with nothing (inside others). */
  int fills_united, fills_dropped;
} ch_curve_set;

/* Upper limits that turn absurd files into a clear error: the file's size,
 * its segments, how deep elements nest, and the entity references the XML
 * parser may expand, in number, text and nesting (libxml2 runs in its huge
 * mode, which lifts its own limits of 10 MB per text node and 256 levels,
 * and with them its guard against entity expansion: these caps take their
 * place). */
enum {
  CH_CURVES_MAX_UV = 1000000, /* |u|, |v| of any point: a million texture widths */
  CH_CURVES_MAX_SEGMENTS = 1 << 24,
  CH_SVG_MAX_BYTES = 256 << 20,
  CH_SVG_MAX_DEPTH = 256,
  CH_SVG_MAX_ENTITY_REFS = 10000,
  CH_SVG_MAX_ENTITY_BYTES = 1 << 20,
  CH_SVG_MAX_ENTITY_DEPTH = 40
};

/* How drawings without data- attributes are read (docs/svg.md). Zero
 * means default. */
typedef struct ch_svg_desc {
  double fill_height; /* a filled shape's inside, object units; 0 -> 0.01 */
} ch_svg_desc;

/* Reads an SVG file (docs/spec.md §2) into out. Malformed files give CH_ERR_INPUT
 * with one line naming the file, the element (id or index, and line) and
 * the problem. Ignored elements produce warnings through err. out is zeroed
 * on failure. */
ch_status ch_curves_read_svg(const char *path, ch_curve_set *out, ch_error *err);

/* The same from memory; name is used in messages. */
ch_status ch_curves_parse_svg(const char *data, size_t size, const char *name,
                              ch_curve_set *out, ch_error *err);

/* The two above with options (desc may be NULL: defaults). */
ch_status ch_curves_read_svg_ex(const char *path, const ch_svg_desc *desc, ch_curve_set *out, ch_error *err);
ch_status ch_curves_parse_svg_ex(const char *data, size_t size, const char *name, const ch_svg_desc *desc,
                                 ch_curve_set *out, ch_error *err);

void ch_curves_free(ch_curve_set *set);

/* Evaluates a profile at t (any t; zero outside its support). At a vertical
 * wall the value of smaller magnitude is taken (the closure towards the
 * untouched surface), which for box gives 0 at t = +-1/2. */
double ch_profile_eval(const ch_profile *profile, double t);

/* The profile's slope dP/dt at t (0 outside its support and on flat
 * pieces; at a break point, the slope of the piece to its right; u's
 * 4t / sqrt(1 - 4t^2) grows without bound towards its rims). */
double ch_profile_slope(const ch_profile *profile, double t);

/* Parses a profile attribute value ("v", "u", "box", "ridge", "bevel" or
 * "t0,h0 t1,h1 ..."). Returns 0 on success, else writes a reason. */
int ch_profile_parse(const char *text, ch_profile *out, char *why, size_t why_size);

/* The profile's break points in t (where P or its slope jumps), sorted, for
 * crease lines: e.g. -1/2, 0, 1/2 for v. Returns the count (<= max). */
int ch_profile_creases(const ch_profile *profile, double *t, int max);

/* Sets the box of curve c (umin vmin umax vmax of its segments' control
 * points) from its segments. */
void ch_curve_update_box(ch_curve_set *set, int c);

/* The point of segment s at parameter t (exact on the straight branch). */
void ch_segment_point(const ch_segment *s, double t, double out[2]);

/* Winding number around q of the closed loop(s) made by segments first ..
 * first + count - 1: their crossings of the ray from q towards +u, signed
 * by the direction of travel. Each segment is read in pieces monotone in
 * v; a point with v = q_v exactly counts as below the ray (simulation of
 * simplicity), so a joint the path passes through counts once and a
 * corner or a curve that only touches the ray's line counts not at all. */
int ch_segments_winding(const ch_curve_set *set, int first, int count, const double q[2]);

/* Whether a crossing of segments ia and ib at parameters s on ia and t on
 * ib is only the joint of two neighbours: within 1e-9 of their ends in
 * parameter, or within 1e-7 UV of the point they share. Where a line runs
 * on into a curve along its tangent, Newton's steps for the crossing stop
 * well inside a short segment in parameter (a line 2.4e-4 UV long before a
 * rounded corner took a crossing 1e-8 in, and h_step a singular term of
 * slope 27 per radian). */
int ch_segments_at_joint(const ch_curve_set *set, int ia, int ib, double s, double t);

/* The box of s's control points (which holds the segment) grown by r on
 * every side: umin vmin umax vmax. */
void ch_segment_box(const ch_segment *s, double r, double box[4]);

/* A human-readable name of a curve for messages: "path 'id'" or "path #3". */
void ch_curve_describe(const ch_curve *curve, char *out, size_t out_size);

#ifdef __cplusplus
}
#endif
#endif
