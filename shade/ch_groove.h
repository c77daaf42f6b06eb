/* ch_groove: exact queries on the feature curves (docs/spec.md §3): closest point,
 * signed distance with the side rule and rounded caps, and the groove
 * height field h_groove(u, v) with its CSG rule. */
#ifndef CH_GROOVE_H
#define CH_GROOVE_H

#include "ch_curves.h"
#include "ch_error.h"
#include "ch_grid.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The closest point of a curve to a query point. */
typedef struct ch_curve_point {
  int segment;        /* segment holding the closest point */
  double t;           /* its parameter there */
  double point[2];    /* the closest point, UV */
  double distance;    /* |query - point| */
  double signed_distance; /* positive on the left (docs/spec.md §3) */
} ch_curve_point;

/* Which side of the curve q lies on, given its closest point (segment, t):
 * +1 left, -1 right. Inside a segment: the side of its tangent there. At a
 * joint: the sector between the two pieces that q falls in. At an open end:
 * the side of the tangent line at that end (docs/spec.md §3's rounded cap). Points
 * on a tangent line count as left. */
int ch_curve_side(const ch_curve_set *set, int segment, double t, const double q[2]);

/* The side of d (a vector from a joint) for a path arriving along tin and
 * leaving along tout: +1 left, -1 right. Correct for turns of any
 * sharpness (a test against one tangent is wrong beyond 90 degrees). */
int ch_joint_side(const double tin[2], const double tout[2], const double d[2]);

/* Closest point of curve `curve` to q by visiting all its segments; ties go
 * to the first segment. */
void ch_curve_closest(const ch_curve_set *set, int curve, const double q[2], ch_curve_point *out);

/* The closest point of curve c to q among c's segments that grid lists in
 * q's cell, first those whose box (boxes: 4 per segment, umin vmin umax
 * vmax, as given to ch_grid_build, grown by reach) holds q: they hold the
 * closest point wherever it is within reach. With `beyond`, if none is
 * within reach, the closest of c's other segments in the cell (not always
 * the least distance, but one beyond reach still). Ties go to the first
 * segment, as in ch_curve_closest. Returns the segment (-1: none of c's in
 * the cell, or without `beyond` none whose box holds q), its squared
 * distance and parameter in *d2 and *t; the caller scans the whole curve
 * where it needs an answer beyond the cell (ch_curve_closest, or a
 * ch_segtree). Reads only: safe from many threads. */
int ch_curve_closest_in_cell(const ch_curve_set *set, const ch_grid *grid, const double *boxes, int c,
                             const double q[2], double reach, int beyond, double *d2, double *t);

/* h_groove over a curve set, with a grid over the grooves' segments (each
 * box grown by half its groove's width) so a query looks at nearby grooves
 * only. Read-only after creation: safe to query from many threads. */
typedef struct ch_groove_field {
  const ch_curve_set *set; /* not owned; must outlive the field */
  ch_grid grid;
  double (*boxes)[4];      /* per segment; empty for step curves */
  int num_grooves;
} ch_groove_field;

ch_status ch_groove_field_init(ch_groove_field *field, const ch_curve_set *set, ch_error *err);
void ch_groove_field_free(ch_groove_field *field);

/* The closest point of groove `curve` to q: over its segments the field's
 * grid lists at q (ch_curve_closest_in_cell, reach half its width, beyond
 * it the others in the cell), else over all its segments
 * (ch_curve_closest). Fills every field of out (the signed distance by
 * ch_curve_side). Reads only: safe from many threads. */
void ch_groove_field_closest(const ch_groove_field *field, int curve, const double q[2], ch_curve_point *out);

/* Whether no groove reaches the UV box u0..u1 x v0..v1: ch_groove_field_eval
 * is then 0 at every point of it. Conservative (0 for a box over many of
 * the grid's cells). */
int ch_groove_field_box_is_empty(const ch_groove_field *f, double u0, double v0, double u1, double v1);

/* How many segments the field's grid lists at (u, v): how crowded the
 * grooves are there (0 outside the grid). */
int ch_groove_field_count(const ch_groove_field *field, double u, double v);

/* The boxes of the field's segments, 4 per segment (umin vmin umax vmax,
 * grown by half the groove's width; empty for step curves): owned by the
 * field, valid while it lives. */
const double *ch_groove_field_boxes(const ch_groove_field *field);

/* The deciding groove's tie (ch_groove_field_eval): curve `later`, after
 * the deciding `earlier` in a cell's order, takes over at q only where its
 * carve g is deeper (a raise: higher) than the other's by more than this:
 * 1e-12 |g| plus how far the rounding of each signed distance s moves its
 * carve depth P(s / w) through P's slope. Mirrored grooves tie along their
 * line of symmetry, where the closest point's noise would flip the label. */
double ch_groove_tie(const ch_curve *later, double g, double s_later, const ch_curve *earlier, double s_earlier,
                     const double q[2]);

/* What decides h at a point. */
typedef struct ch_groove_sample {
  double h;            /* h_groove */
  int owner;           /* curve owning the point (highest data-priority
                          among grooves with g != 0; ties: the one giving h),
                          or -1 */
  double signed_distance; /* to the owner */
  int segment;         /* owner's closest segment */
  double t;
  int active;          /* curve whose g gives h (the deepest carve, else the
                          highest raise), or -1 where h_groove = 0 */
  double active_signed_distance; /* to the active curve */
} ch_groove_sample;

/* h_groove(u, v) per docs/spec.md §3: if any g_i < 0, min g_i, else max(0, max g_i).
 * detail may be NULL. */
double ch_groove_field_eval(const ch_groove_field *field, double u, double v,
                            ch_groove_sample *detail);

#ifdef __cplusplus
}
#endif
#endif
