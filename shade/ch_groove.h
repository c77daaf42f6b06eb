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
