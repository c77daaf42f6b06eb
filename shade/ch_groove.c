/* Exact groove heights (docs/spec.md §3). Profiles are evaluated on the signed
 * distance to the exact quadratic segments; crossings combine by the CSG
 * rule of the path-based groove paper (§4: material added before it is
 * removed), as docs/spec.md §3 states it. */
#include "ch_groove.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ch_bezier.h"
#include "ch_math.h"

/* Whether segment s is certainly farther from q than best (a squared
 * distance): its control points' box (which holds the curve) is, with the
 * segment tree's relative slack and 1e-13 more for the rounding of the
 * closest point itself, so skipping it changes no answer, ties included.
 * (A tenth to a fifth of the closest points the labels asked for.) */
static int farther_than(const ch_segment *s, const double q[2], double best) {
  if (!(best < INFINITY)) return 0;
  /* (comparisons, not fmin/fmax: those are library calls without
   * -ffinite-math-only, a fifth of this test's time; the control points
   * are finite) */
  double lo0 = ch_min3(s->p[0][0], s->p[1][0], s->p[2][0]), hi0 = ch_max3(s->p[0][0], s->p[1][0], s->p[2][0]);
  double lo1 = ch_min3(s->p[0][1], s->p[1][1], s->p[2][1]), hi1 = ch_max3(s->p[0][1], s->p[1][1], s->p[2][1]);
  double dx = q[0] < lo0 ? lo0 - q[0] : q[0] > hi0 ? q[0] - hi0 : 0.0;
  double dy = q[1] < lo1 ? lo1 - q[1] : q[1] > hi1 ? q[1] - hi1 : 0.0;
  return dx * dx + dy * dy > best * (1.0 + 1e-9) + 1e-26;
}

int ch_curve_side(const ch_curve_set *set, int segment, double t, const double q[2]) {
  const ch_segment *s = &set->segments[segment];
  double c[2], d[2], here[2];
  ch_segment_point(s, t, c);
  d[0] = q[0] - c[0];
  d[1] = q[1] - c[1];
  if (t > 0.0 && t < 1.0) {
    /* The sign of B'(t) x d: B' need not be unit. */
    ch_bezier_direction(s->p, t, here);
    return ch_cross2(here, d) >= 0.0 ? 1 : -1;
  }
  int at_start = t <= 0.0;
  int other = at_start ? s->prev : s->next;
  ch_bezier_tangent(s->p, at_start ? 0.0 : 1.0, here);
  if (other < 0) return ch_cross2(here, d) >= 0.0 ? 1 : -1; /* open end */
  double there[2], tin[2], tout[2];
  ch_bezier_tangent(set->segments[other].p, at_start ? 1.0 : 0.0, there);
  memcpy(tin, at_start ? there : here, sizeof tin);
  memcpy(tout, at_start ? here : there, sizeof tout);
  return ch_joint_side(tin, tout, d);
}

int ch_joint_side(const double tin[2], const double tout[2], const double d[2]) {
  /* Near the joint the curve is two rays from it: back along the incoming
   * tangent (a) and along the outgoing one (b). Walking in along a and out
   * along b, the left side is the sector swept counter-clockwise from b to
   * a. (A test against each tangent alone fails for turns sharper than a
   * right angle.) */
  double a[2] = {-tin[0], -tin[1]};
  const double *b = tout;
  double sab = ch_cross2(b, a);
  if (sab > 0.0) return ch_cross2(b, d) >= 0.0 && ch_cross2(d, a) >= 0.0 ? 1 : -1;
  if (sab < 0.0) return ch_cross2(a, d) > 0.0 && ch_cross2(d, b) > 0.0 ? -1 : 1;
  if (ch_dot2(a, b) < 0.0) return ch_cross2(b, d) >= 0.0 ? 1 : -1; /* straight on */
  return 1; /* the path folds back on itself: both rays coincide */
}

void ch_curve_closest(const ch_curve_set *set, int curve, const double q[2], ch_curve_point *out) {
  const ch_curve *c = &set->curves[curve];
  double best = INFINITY, best_t = 0.0;
  int best_seg = c->first_segment;
  for (int i = c->first_segment; i < c->first_segment + c->num_segments; i++) {
    double t;
    double d2 = ch_bezier_closest(set->segments[i].p, set->segments[i].is_line, q, &t);
    if (d2 < best) {
      best = d2;
      best_t = t;
      best_seg = i;
    }
  }
  out->segment = best_seg;
  out->t = best_t;
  ch_segment_point(&set->segments[best_seg], best_t, out->point);
  out->distance = sqrt(best);
  out->signed_distance = out->distance * ch_curve_side(set, best_seg, best_t, q);
}

int ch_curve_closest_in_cell(const ch_curve_set *set, const ch_grid *grid, const double *boxes, int c,
                             const double q[2], double reach, int beyond, double *d2, double *t) {
  const int *items = NULL;
  int n = ch_grid_query(grid, q[0], q[1], &items), best_seg = -1;
  /* The cell's items ascend and c's segments are consecutive: its run
   * (by bisection: cells near many curves hold thousands of items). */
  int s0 = set->curves[c].first_segment, s1 = s0 + set->curves[c].num_segments, k0 = 0, k1 = n;
  while (k0 < k1) { /* the first item >= s0 */
    int mid = k0 + (k1 - k0) / 2;
    if (items[mid] < s0)
      k0 = mid + 1;
    else
      k1 = mid;
  }
  for (k1 = k0; k1 < n && items[k1] < s1;) k1++;
  double best = INFINITY, best_t = 0.0;
  for (int pass = 0; pass < (beyond ? 2 : 1) && !(best <= reach * reach); pass++)
    for (int k = k0; k < k1; k++) {
      const ch_segment *sg = &set->segments[items[k]];
      const double *b = &boxes[4 * (size_t)items[k]];
      int inside = !(q[0] < b[0] || q[0] > b[2] || q[1] < b[1] || q[1] > b[3]);
      if (inside != (pass == 0) || farther_than(sg, q, best)) continue;
      double tk, dk = ch_bezier_closest(sg->p, sg->is_line, q, &tk);
      if (dk < best || (dk == best && items[k] < best_seg)) {
        best = dk;
        best_t = tk;
        best_seg = items[k];
      }
    }
  *d2 = best;
  *t = best_t;
  return best_seg;
}

ch_status ch_groove_field_init(ch_groove_field *f, const ch_curve_set *set, ch_error *err) {
  memset(f, 0, sizeof *f);
  f->set = set;
  f->boxes = malloc((size_t)(set->num_segments > 0 ? set->num_segments : 1) * sizeof *f->boxes);
  if (!f->boxes) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the groove field");
  for (int i = 0; i < set->num_segments; i++) {
    const ch_segment *s = &set->segments[i];
    const ch_curve *c = &set->curves[s->curve];
    double *b = f->boxes[i];
    if (c->kind != CH_CURVE_GROOVE) {
      b[0] = b[1] = 1.0; /* empty: umin > umax */
      b[2] = b[3] = 0.0;
      continue;
    }
    /* The control polygon's box holds the quadratic; grow it by the half
     * width, beyond which the profile is zero. */
    ch_segment_box(s, 0.5 * c->width, b);
  }
  for (int i = 0; i < set->num_curves; i++) f->num_grooves += set->curves[i].kind == CH_CURVE_GROOVE;
  /* The grid lists a groove's segment in the cells within its half width
   * (along a long line, not all over its box) */
  double *reach = malloc((size_t)(set->num_segments > 0 ? set->num_segments : 1) * sizeof *reach);
  ch_status st = reach ? CH_OK : ch_error_set(err, CH_ERR_NOMEM, "out of memory for the groove field");
  for (int i = 0; reach && i < set->num_segments; i++) {
    const ch_curve *c = &set->curves[set->segments[i].curve];
    reach[i] = c->kind == CH_CURVE_GROOVE ? 0.5 * c->width : -1.0;
  }
  if (!st) st = ch_grid_build_curves(&f->grid, set, reach, err);
  free(reach);
  if (st) {
    free(f->boxes);
    f->boxes = NULL;
  }
  return st;
}

void ch_groove_field_free(ch_groove_field *f) {
  ch_grid_free(&f->grid);
  free(f->boxes);
  memset(f, 0, sizeof *f);
}

typedef struct csg_state {
  double min_carve, max_raise; /* most negative g < 0, most positive g > 0 */
  int carve_curve, raise_curve;
  double carve_s, raise_s; /* signed distances to them */
  int owner, owner_priority;
  double owner_s, owner_t, owner_g;
  int owner_seg;
} csg_state;

/* Whether carve value g wins over g_old for the height: carving beats
 * raising, then the deeper carve or the higher raise. */
static int decides_height(double g, double g_old) {
  if (g < 0.0) return g_old > 0.0 || g < g_old;
  return g_old > 0.0 && g > g_old;
}

/* Whether a profile is even in t (P(-t) = P(t) to the bit: it reads |t|
 * or t^2), so its carve needs no side. */
static int profile_is_even(ch_profile_kind kind) {
  return kind == CH_PROFILE_V || kind == CH_PROFILE_U || kind == CH_PROFILE_BOX || kind == CH_PROFILE_RIDGE;
}

/* How far the rounding of s moves carve g = depth P(s / w) of curve c at
 * q: 2^-50 of q's larger coordinate (a distance is as exact as the points
 * it is read from: mirrored grooves' distances on their line of symmetry
 * differ by up to 1.4e-16 at UV 0.5) times P's slope. A u profile's slope
 * grows without bound towards its rims: there 1e-16 in s moved g by
 * 3e-11 of itself, past a tie relative to g alone. */
static double carve_rounding(const ch_curve *c, double s, const double q[2]) {
  double scale = fmax(1.0, fmax(fabs(q[0]), fabs(q[1])));
  return fabs(c->depth * ch_profile_slope(&c->profile, s / c->width)) / c->width * (0x1p-50 * scale);
}

double ch_groove_tie(const ch_curve *later, double g, double s_later, const ch_curve *earlier, double s_earlier,
                     const double q[2]) {
  return 1e-12 * fabs(g) + carve_rounding(later, s_later, q) + carve_rounding(earlier, s_earlier, q);
}

static void combine(const ch_groove_field *f, csg_state *cs, int curve, double d2, int seg, double t,
                    const double q[2]) {
  const ch_curve *c = &f->set->curves[curve];
  double half = 0.5 * c->width;
  if (!(d2 < half * half)) return; /* outside the profile's support */
  /* The side (a tangent and a point of the curve) only where the profile
   * needs it or this curve takes a role below: where hundreds of grooves
   * cover a point, most lose (at 1000 grooves through a point the sides
   * were a quarter of the run's time). */
  double distance = sqrt(d2), s = distance;
  int sided = !profile_is_even(c->profile.kind);
  if (sided) s = distance * ch_curve_side(f->set, seg, t, q);
  double g = c->depth * ch_profile_eval(&c->profile, s / c->width);
  if (g == 0.0) return;
  int takes = g < cs->min_carve || g > cs->max_raise || cs->owner < 0 || c->priority > cs->owner_priority ||
              (c->priority == cs->owner_priority && decides_height(g, cs->owner_g));
  if (!takes) return;
  if (!sided) s = distance * ch_curve_side(f->set, seg, t, q);
  /* The deciding curve changes only when another is deeper (higher) by
   * more than rounding: mirrored grooves tie along their line of symmetry,
   * where the closest-point noise would otherwise flip it back and forth.
   * Rounding is P's own (relative) and that of s through P's slope. */
  const ch_curve *curves = f->set->curves;
  if (g < cs->min_carve) {
    int old = cs->carve_curve;
    if (old < 0 || g < cs->min_carve - ch_groove_tie(c, g, s, &curves[old], cs->carve_s, q)) {
      cs->carve_curve = curve;
      cs->carve_s = s;
    }
    cs->min_carve = g;
  }
  if (g > cs->max_raise) {
    int old = cs->raise_curve;
    if (old < 0 || g > cs->max_raise + ch_groove_tie(c, g, s, &curves[old], cs->raise_s, q)) {
      cs->raise_curve = curve;
      cs->raise_s = s;
    }
    cs->max_raise = g;
  }
  if (cs->owner < 0 || c->priority > cs->owner_priority ||
      (c->priority == cs->owner_priority && decides_height(g, cs->owner_g))) {
    cs->owner = curve;
    cs->owner_priority = c->priority;
    cs->owner_s = s;
    cs->owner_t = t;
    cs->owner_g = g;
    cs->owner_seg = seg;
  }
}

double ch_groove_field_eval(const ch_groove_field *f, double u, double v, ch_groove_sample *detail) {
  const int *items;
  int n = ch_grid_query(&f->grid, u, v, &items);
  const double q[2] = {u, v};
  csg_state cs = {.min_carve = 0.0, .max_raise = 0.0, .carve_curve = -1, .raise_curve = -1, .owner = -1};
  int cur = -1, best_seg = -1;
  double best = INFINITY, best_t = 0.0;
  /* Items are in segment order, so each curve's segments come as one run:
   * keep the closest point per run, then apply its profile. */
  for (int k = 0; k < n; k++) {
    int i = items[k];
    const double *b = f->boxes[i];
    if (u < b[0] || u > b[2] || v < b[1] || v > b[3]) continue;
    const ch_segment *s = &f->set->segments[i];
    if (s->curve != cur) {
      if (cur >= 0) combine(f, &cs, cur, best, best_seg, best_t, q);
      cur = s->curve;
      best = INFINITY;
    } else if (farther_than(s, q, best)) {
      continue;
    }
    double t;
    double d2 = ch_bezier_closest(s->p, s->is_line, q, &t);
    if (d2 < best) {
      best = d2;
      best_t = t;
      best_seg = i;
    }
  }
  if (cur >= 0) combine(f, &cs, cur, best, best_seg, best_t, q);
  double h = cs.min_carve < 0.0 ? cs.min_carve : cs.max_raise;
  if (detail) {
    detail->h = h;
    detail->owner = cs.owner;
    detail->signed_distance = cs.owner >= 0 ? cs.owner_s : 0.0;
    detail->segment = cs.owner >= 0 ? cs.owner_seg : -1;
    detail->t = cs.owner >= 0 ? cs.owner_t : 0.0;
    detail->active = cs.min_carve < 0.0 ? cs.carve_curve : cs.max_raise > 0.0 ? cs.raise_curve : -1;
    detail->active_signed_distance = cs.min_carve < 0.0 ? cs.carve_s : cs.max_raise > 0.0 ? cs.raise_s : 0.0;
  }
  return h;
}

void ch_groove_field_closest(const ch_groove_field *f, int curve, const double q[2], ch_curve_point *out) {
  double d2, t;
  int seg = ch_curve_closest_in_cell(f->set, &f->grid, (const double *)f->boxes, curve, q,
                                     0.5 * f->set->curves[curve].width, 1, &d2, &t);
  if (seg < 0) {
    ch_curve_closest(f->set, curve, q, out);
    return;
  }
  out->segment = seg;
  out->t = t;
  ch_segment_point(&f->set->segments[seg], t, out->point);
  out->distance = sqrt(d2);
  out->signed_distance = out->distance * ch_curve_side(f->set, seg, t, q);
}

int ch_groove_field_box_is_empty(const ch_groove_field *f, double u0, double v0, double u1, double v1) {
  const ch_grid *g = &f->grid;
  if (!g->cell_start) return 1;
  const double q[4] = {u0, v0, u1, v1};
  /* the cells ch_grid_query reads for the box's points (none outside) */
  if (!(u1 >= g->origin[0] && v1 >= g->origin[1] && (u0 - g->origin[0]) * g->inv_cell < g->nx &&
        (v0 - g->origin[1]) * g->inv_cell < g->ny))
    return 1;
  int r[4];
  ch_grid_cell_range(g, q, r);
  if ((long)(r[2] - r[0] + 1) * (r[3] - r[1] + 1) > 16) return 0;
  for (int y = r[1]; y <= r[3]; y++)
    for (int x = r[0]; x <= r[2]; x++) {
      int c = y * g->nx + x;
      for (int k = g->cell_start[c]; k < g->cell_start[c + 1]; k++) {
        /* ch_groove_field_eval's own box test, for the whole box */
        const double *b = f->boxes[g->items[k]];
        if (!(u1 < b[0] || u0 > b[2] || v1 < b[1] || v0 > b[3])) return 0;
      }
    }
  return 1;
}

int ch_groove_field_count(const ch_groove_field *f, double u, double v) {
  const int *items;
  return ch_grid_query(&f->grid, u, v, &items);
}

const double *ch_groove_field_boxes(const ch_groove_field *f) { return (const double *)f->boxes; }
