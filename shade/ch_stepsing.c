/* ch_stepsing: singular points of h_step and its leading term there (see
 * ch_stepsing.h for the expansion). */
#include "ch_stepsing.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ch_bezier.h"
#include "ch_grid.h"
#include "ch_math.h"

#define TWO_PI (2.0 * CH_PI)
/* Points closer than this (UV) are one point; arms closer than this in
 * angle are one arm. */
#define SAME_POINT 1e-9
#define SAME_ANGLE 1e-7
/* Arms closer than this in angle are merged (see make_point). */
#define SLIVER_ANGLE 1e-4
/* Parameters this close to a segment's end are its end. */
#define AT_END 1e-9

static int is_sharp_step(const ch_curve_set *set, int c) {
  const ch_curve *cv = &set->curves[c];
  return cv->kind == CH_CURVE_STEP && !(cv->blur > 0.0);
}

/* ---- arms ---- */

typedef struct arm_event {
  double p[2];
  double angle;
  double ccw, cw; /* h on the arm's counter-clockwise and clockwise side */
  int curve;
  int left_ccw; /* the curve's left is the arm's counter-clockwise side */
} arm_event;

typedef struct events {
  arm_event *v;
  int n, cap;
  int failed;
} events;

static void push_event(events *ev, const double p[2], const double dir[2], double ccw, double cw, int curve,
                       int left_ccw) {
  if (!(dir[0] != 0.0 || dir[1] != 0.0)) return;
  if (ev->n == ev->cap) {
    int cap = ev->cap ? 2 * ev->cap : 64;
    arm_event *v = realloc(ev->v, (size_t)cap * sizeof *v);
    if (!v) {
      ev->failed = 1;
      return;
    }
    ev->v = v;
    ev->cap = cap;
  }
  double a = atan2(dir[1], dir[0]);
  if (a < 0.0) a += TWO_PI;
  if (a >= TWO_PI) a = 0.0;
  ev->v[ev->n++] = (arm_event){{p[0], p[1]}, a, ccw, cw, curve, left_ccw};
}

/* The arms segment s leaves point p by at parameter t: forward along the
 * curve (left on its counter-clockwise side) unless t is an open end,
 * backward (right on that side) unless t is an open start. */
static void add_arms(const ch_curve_set *set, int s, double t, const double p[2], events *ev) {
  const ch_segment *sg = &set->segments[s];
  if (t >= 1.0 - AT_END && sg->next >= 0) {
    s = sg->next;
    sg = &set->segments[s];
    t = 0.0;
  }
  const ch_curve *cv = &set->curves[sg->curve];
  double tg[2];
  if (!(t >= 1.0 - AT_END)) {
    ch_bezier_tangent(sg->p, t, tg);
    push_event(ev, p, tg, cv->left, cv->right, sg->curve, 1);
  }
  if (t <= AT_END) {
    if (sg->prev >= 0) {
      ch_bezier_tangent(set->segments[sg->prev].p, 1.0, tg);
      double back[2] = {-tg[0], -tg[1]};
      push_event(ev, p, back, cv->right, cv->left, sg->curve, 0);
    }
  } else {
    ch_bezier_tangent(sg->p, t, tg);
    double back[2] = {-tg[0], -tg[1]};
    push_event(ev, p, back, cv->right, cv->left, sg->curve, 0);
  }
}

/* ---- crossings of two quadratic segments ---- */

/* A box's least u and its index, for the sweep over pairs. */
typedef struct by_u {
  double u0;
  int i;
} by_u;

static int cmp_by_u(const void *x, const void *y) {
  const by_u *a = x, *b = y;
  if (a->u0 != b->u0) return a->u0 < b->u0 ? -1 : 1;
  return (a->i > b->i) - (a->i < b->i);
}

/* ---- the points ---- */

static int cmp_event(const void *x, const void *y) {
  const arm_event *a = x, *b = y;
  if (a->p[0] != b->p[0]) return a->p[0] < b->p[0] ? -1 : 1;
  if (a->p[1] != b->p[1]) return a->p[1] < b->p[1] ? -1 : 1;
  return (a->angle > b->angle) - (a->angle < b->angle);
}

static int cmp_arm(const void *x, const void *y) {
  const arm_event *a = x, *b = y;
  return (a->angle > b->angle) - (a->angle < b->angle);
}

/* One point from the events of one place (sorted by angle in place). */
static int make_point(arm_event *e, int n, ch_stepsing_point *pt) {
  qsort(e, (size_t)n, sizeof *e, cmp_arm);
  memset(pt, 0, sizeof *pt);
  pt->p[0] = e[0].p[0], pt->p[1] = e[0].p[1];
  double ccw[CH_STEPSING_MAX_ARMS], cw[CH_STEPSING_MAX_ARMS];
  int m = 0;
  for (int i = 0; i < n && m < CH_STEPSING_MAX_ARMS; i++) {
    if (m > 0 && e[i].angle - pt->angle[m - 1] < SAME_ANGLE && ccw[m - 1] == e[i].ccw && cw[m - 1] == e[i].cw) continue;
    if (m > 0 && i + 1 == n && pt->angle[0] + TWO_PI - e[i].angle < SAME_ANGLE && ccw[0] == e[i].ccw &&
        cw[0] == e[i].cw)
      continue;
    /* Arms closer than a sliver are one arm: its clockwise side that of
     * the first, its counter-clockwise side that of the last. (A curve
     * that touches itself at a joint, as a flattened or warped polyline
     * can, gives two; a wedge between them would be a slope of the whole
     * step over a millionth of a turn.) */
    if (m > 0 && e[i].angle - pt->angle[m - 1] < SLIVER_ANGLE) {
      ccw[m - 1] = e[i].ccw;
      pt->arm_curve[m - 1] = e[i].curve;
      pt->arm_left_ccw[m - 1] = (signed char)e[i].left_ccw;
      continue;
    }
    if (m > 0 && i + 1 == n && pt->angle[0] + TWO_PI - e[i].angle < SLIVER_ANGLE) {
      cw[0] = e[i].cw;
      continue;
    }
    pt->angle[m] = e[i].angle, ccw[m] = e[i].ccw, cw[m] = e[i].cw;
    pt->arm_curve[m] = e[i].curve;
    pt->arm_left_ccw[m] = (signed char)e[i].left_ccw;
    m++;
  }
  pt->num_arms = m;
  int singular = 0;
  for (int k = 0; k < m; k++) {
    int next = (k + 1) % m;
    double span = pt->angle[next] - pt->angle[k];
    if (!(span > 0.0)) span += TWO_PI;
    pt->value[k] = ccw[k];
    pt->slope[k] = (cw[next] - ccw[k]) / span;
    singular |= pt->slope[k] != 0.0;
  }
  return singular;
}

ch_status ch_stepsing_find(const ch_curve_set *set, const double rect[4], ch_stepsing *out, ch_error *err) {
  memset(out, 0, sizeof *out);
  events ev = {0};
  /* open ends */
  for (int i = 0; i < set->num_subpaths; i++) {
    const ch_subpath *sp = &set->subpaths[i];
    if (sp->num_segments <= 0) continue;
    int first = sp->first_segment, last = first + sp->num_segments - 1;
    if (!is_sharp_step(set, set->segments[first].curve)) continue;
    if (set->segments[first].prev < 0) {
      add_arms(set, first, 0.0, set->segments[first].p[0], &ev);
    }
    if (set->segments[last].next < 0) {
      add_arms(set, last, 1.0, set->segments[last].p[2], &ev);
    }
  }
  /* crossings: every pair of sharp step segments whose boxes meet, but a
   * segment and its neighbours (they meet at their joint) */
  int *steps = malloc((size_t)(set->num_segments > 0 ? set->num_segments : 1) * sizeof *steps);
  double(*box)[4] = malloc((size_t)(set->num_segments > 0 ? set->num_segments : 1) * sizeof *box);
  int ns = 0;
  if (!steps || !box) ev.failed = 1;
  for (int i = 0; !ev.failed && i < set->num_segments; i++)
    if (is_sharp_step(set, set->segments[i].curve)) {
      ch_bezier_box(set->segments[i].p, box[ns]);
      steps[ns++] = i;
    }
  /* sweep along u: a pair is looked at only while the boxes' u ranges meet */
  by_u *order = malloc((size_t)(ns > 0 ? ns : 1) * sizeof *order);
  if (!order) ev.failed = 1;
  for (int i = 0; !ev.failed && i < ns; i++) order[i] = (by_u){box[i][0], i};
  if (!ev.failed) qsort(order, (size_t)ns, sizeof *order, cmp_by_u);
  for (int oa = 0; !ev.failed && oa < ns; oa++)
    for (int ob = oa + 1; ob < ns && order[ob].u0 <= box[order[oa].i][2]; ob++) {
      int x = order[oa].i, y = order[ob].i, a = x < y ? x : y, b = x < y ? y : x;
      const double *ba = box[a], *bb = box[b];
      if (ba[1] > bb[3] || bb[1] > ba[3]) continue;
      const ch_segment *sa = &set->segments[steps[a]], *sb = &set->segments[steps[b]];
      int adjacent = sa->next == steps[b] || sa->prev == steps[b];
      double hs[CH_BEZIER_MAX_CROSSINGS], ht[CH_BEZIER_MAX_CROSSINGS];
      int nh = ch_bezier_crossings(sa->p, sb->p, hs, ht);
      for (int k = 0; k < nh; k++) {
        /* neighbours meet at their joint: not a crossing */
        if (adjacent && ch_segments_at_joint(set, steps[a], steps[b], hs[k], ht[k])) continue;
        double p[2];
        ch_bezier_eval(sa->p, hs[k], p);
        add_arms(set, steps[a], hs[k], p, &ev);
        add_arms(set, steps[b], ht[k], p, &ev);
      }
    }
  free(order);
  ch_status st = CH_OK;
  if (ev.failed) st = ch_error_set(err, CH_ERR_NOMEM, "out of memory finding the step curves' ends and crossings");
  /* group the events by place */
  if (!st && ev.n > 0) {
    qsort(ev.v, (size_t)ev.n, sizeof *ev.v, cmp_event);
    out->points = calloc((size_t)ev.n, sizeof *out->points);
    char *used = calloc((size_t)ev.n, 1);
    arm_event *group = malloc((size_t)ev.n * sizeof *group);
    if (!out->points || !used || !group) {
      st = ch_error_set(err, CH_ERR_NOMEM, "out of memory grouping the step curves' ends and crossings");
    } else {
      for (int i = 0; i < ev.n; i++) {
        if (used[i]) continue;
        int g = 0;
        for (int j = i; j < ev.n && ev.v[j].p[0] - ev.v[i].p[0] <= SAME_POINT; j++)
          if (!used[j] && fabs(ev.v[j].p[1] - ev.v[i].p[1]) <= SAME_POINT) {
            used[j] = 1;
            group[g++] = ev.v[j];
          }
        const double *p = group[0].p, margin = 1e-9 * (1.0 + fabs(rect[2] - rect[0]) + fabs(rect[3] - rect[1]));
        int inside =
            p[0] > rect[0] + margin && p[0] < rect[2] - margin && p[1] > rect[1] + margin && p[1] < rect[3] - margin;
        if (inside && make_point(group, g, &out->points[out->num_points])) out->num_points++;
      }
    }
    free(used);
    free(group);
  }
  free(steps);
  free(box);
  free(ev.v);
  if (st) ch_stepsing_free(out);
  return st;
}

void ch_stepsing_free(ch_stepsing *s) {
  free(s->points);
  memset(s, 0, sizeof *s);
}

ch_status ch_stepsing_limit_radii(ch_stepsing_point *pts, int n, double most, ch_error *err) {
  for (int i = 0; i < n; i++) pts[i].radius = most;
  if (n < 2) return CH_OK;
  by_u *o = malloc((size_t)n * sizeof *o);
  if (!o) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the singular points' radii");
  for (int i = 0; i < n; i++) o[i] = (by_u){pts[i].p[0], i};
  qsort(o, (size_t)n, sizeof *o, cmp_by_u);
  /* a sweep along u, stopping where u alone is farther */
  for (int a = 0; a < n; a++)
    for (int b = a + 1; b < n && o[b].u0 - o[a].u0 < 2.0 * most; b++) {
      ch_stepsing_point *pa = &pts[o[a].i], *pb = &pts[o[b].i];
      double half = 0.5 * hypot(pa->p[0] - pb->p[0], pa->p[1] - pb->p[1]);
      pa->radius = fmin(pa->radius, half);
      pb->radius = fmin(pb->radius, half);
    }
  free(o);
  return CH_OK;
}

double ch_stepsing_term(const ch_stepsing_point *pt, const double q[2], double grad[2]) {
  double dx = q[0] - pt->p[0], dy = q[1] - pt->p[1], r2 = dx * dx + dy * dy;
  if (!(r2 > 0.0)) {
    if (grad) grad[0] = grad[1] = 0.0;
    return pt->value[0];
  }
  double th = atan2(dy, dx);
  if (th < 0.0) th += TWO_PI;
  int n = pt->num_arms, k = n - 1;
  for (int i = 0; i < n; i++)
    if (pt->angle[i] <= th) k = i;
  double rel = th - pt->angle[k];
  if (rel < 0.0) rel += TWO_PI;
  /* d theta = (-dy, dx) / r^2 */
  if (grad) grad[0] = -pt->slope[k] * dy / r2, grad[1] = pt->slope[k] * dx / r2;
  return pt->value[k] + pt->slope[k] * rel;
}

int ch_stepsing_arm_toward(const ch_stepsing_point *pt, int curve, const double dir[2]) {
  double th = atan2(dir[1], dir[0]);
  int best = -1;
  double best_d = INFINITY;
  for (int k = 0; k < pt->num_arms; k++) {
    if (pt->arm_curve[k] != curve) continue;
    double d = fabs(remainder(th - pt->angle[k], TWO_PI));
    if (d < best_d) best_d = d, best = k;
  }
  return best;
}

double ch_stepsing_term_beside(const ch_stepsing_point *pt, const double q[2], int arm, int ccw_side,
                               double grad[2]) {
  double dx = q[0] - pt->p[0], dy = q[1] - pt->p[1], r2 = dx * dx + dy * dy;
  int n = pt->num_arms;
  if (!(r2 > 0.0) || arm < 0 || arm >= n) return ch_stepsing_term(pt, q, grad);
  /* q's angle from the arm, on the branch nearest the arm: slightly
   * negative where the curve has bent past its tangent ray */
  double off = remainder(atan2(dy, dx) - pt->angle[arm], TWO_PI);
  int k = arm;
  double rel = off;
  if (!ccw_side) { /* the end of the sector before the arm */
    k = (arm + n - 1) % n;
    double span = pt->angle[arm] - pt->angle[k];
    if (!(span > 0.0)) span += TWO_PI;
    rel = span + off;
  }
  if (grad) grad[0] = -pt->slope[k] * dy / r2, grad[1] = pt->slope[k] * dx / r2;
  return pt->value[k] + pt->slope[k] * rel;
}

double ch_stepsing_window(double r, double r0, double r1) {
  if (r <= r0) return 1.0;
  if (r >= r1) return 0.0;
  double s = (r - r0) / (r1 - r0);
  return 1.0 - s * s * (3.0 - 2.0 * s);
}

/* Signed area of a closed subpath: the chords' shoelace plus each
 * parabolic cap (2/3 of its control triangle). */
static double subpath_area(const ch_curve_set *set, const ch_subpath *sb) {
  double area = 0.0;
  for (int i = sb->first_segment; i < sb->first_segment + sb->num_segments; i++) {
    const double(*p)[2] = set->segments[i].p;
    double tri = (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0]);
    area += 0.5 * (p[0][0] * p[2][1] - p[2][0] * p[0][1]) + tri / 3.0;
  }
  return area;
}

/* ch_stepsing_flat_side, the other step segments near c's box listed by
 * grid (over boxes, ch_bezier_box's; NULL: every segment is tested). */
static int flat_side_near(const ch_curve_set *set, int c, const ch_grid *grid, const double (*boxes)[4]) {
  const ch_curve *cv = &set->curves[c];
  enum { MAX_SUBPATHS = 64 };
  int n = cv->num_subpaths;
  if (cv->kind != CH_CURVE_STEP || cv->blur > 0.0 || n <= 0 || n > MAX_SUBPATHS) return 0;
  double area[MAX_SUBPATHS], box[4] = {INFINITY, INFINITY, -INFINITY, -INFINITY};
  for (int k = 0; k < n; k++) {
    const ch_subpath *sb = &set->subpaths[cv->first_subpath + k];
    if (!sb->closed || sb->num_segments <= 0) return 0;
    area[k] = subpath_area(set, sb);
    if (area[k] == 0.0) return 0;
  }
  for (int i = cv->first_segment; i < cv->first_segment + cv->num_segments; i++)
    for (int k = 0; k < 3; k++) {
      const double *q = set->segments[i].p[k];
      box[0] = fmin(box[0], q[0]), box[1] = fmin(box[1], q[1]);
      box[2] = fmax(box[2], q[0]), box[3] = fmax(box[3], q[1]);
    }
  /* nothing else of h_step's within the curve's box (a segment lies
   * within its control points' box) */
  if (grid) {
    int r[4];
    ch_grid_cell_range(grid, box, r);
    for (int y = r[1]; y <= r[3]; y++)
      for (int x = r[0]; x <= r[2]; x++) {
        int cell = y * grid->nx + x;
        for (int k = grid->cell_start[cell]; k < grid->cell_start[cell + 1]; k++) {
          int i = grid->items[k];
          const double *b = boxes[i];
          if (set->segments[i].curve != c && !(b[0] > box[2] || b[2] < box[0] || b[1] > box[3] || b[3] < box[1]))
            return 0;
        }
      }
  } else {
    for (int i = 0; i < set->num_segments; i++) {
      if (set->segments[i].curve == c || set->curves[set->segments[i].curve].kind != CH_CURVE_STEP) continue;
      double b[4];
      ch_bezier_box(set->segments[i].p, b);
      if (!(b[0] > box[2] || b[2] < box[0] || b[1] > box[3] || b[3] < box[1])) return 0;
    }
  }
  /* Each subpath's parent: the smallest other one around it. A region
   * inside a subpath and outside its children is bounded by this curve
   * alone: one value if every child shows it the parent's inside value. */
  int left_flat = 1, right_flat = 1;
  for (int k = 0; k < n; k++) {
    const ch_subpath *sb = &set->subpaths[cv->first_subpath + k];
    const double *q = set->segments[sb->first_segment].p[0];
    int parent = -1;
    for (int j = 0; j < n; j++)
      if (j != k &&
          ch_segments_winding(set, set->subpaths[cv->first_subpath + j].first_segment,
                              set->subpaths[cv->first_subpath + j].num_segments, q) != 0 &&
          (parent < 0 || fabs(area[j]) < fabs(area[parent])))
        parent = j;
    int in_left = area[k] > 0.0; /* counter-clockwise: the inside is on the left */
    if (parent >= 0) {
      double out_value = in_left ? cv->right : cv->left;
      double parent_in = area[parent] > 0.0 ? cv->left : cv->right;
      if (out_value != parent_in) return 0;
    } else {
      /* the outside of an outermost subpath is the rest of the square */
      if (in_left)
        right_flat = 0;
      else
        left_flat = 0;
    }
  }
  return left_flat ? 1 : right_flat ? -1 : 0;
}

int ch_stepsing_flat_side(const ch_curve_set *set, int c) { return flat_side_near(set, c, NULL, NULL); }

ch_status ch_stepsing_flat_sides(const ch_curve_set *set, int *side, ch_error *err) {
  int n = set->num_segments;
  double(*boxes)[4] = malloc((size_t)(n > 0 ? n : 1) * sizeof *boxes);
  if (!boxes) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the step curves' boxes");
  for (int i = 0; i < n; i++) {
    if (set->curves[set->segments[i].curve].kind == CH_CURVE_STEP) {
      ch_bezier_box(set->segments[i].p, boxes[i]);
    } else {
      boxes[i][0] = 1.0;
      boxes[i][2] = 0.0; /* empty: not in the grid */
    }
  }
  ch_grid grid = {0};
  ch_status st = ch_grid_build(&grid, n, (const double(*)[4])boxes, err);
  if (st == CH_OK) {
#pragma omp parallel for schedule(dynamic, 64)
    for (int c = 0; c < set->num_curves; c++) side[c] = flat_side_near(set, c, &grid, (const double(*)[4])boxes);
  }
  ch_grid_free(&grid);
  free(boxes);
  return st;
}
