/* Curve sets and groove profiles (docs/spec.md §2-3). */
#include "ch_curves.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ch_bezier.h"
#include "ch_math.h"

void ch_curves_free(ch_curve_set *set) {
  free(set->curves);
  free(set->segments);
  free(set->subpaths);
  memset(set, 0, sizeof *set);
}

void ch_curve_update_box(ch_curve_set *set, int c) {
  ch_curve *cv = &set->curves[c];
  double *b = cv->bbox;
  b[0] = b[1] = INFINITY;
  b[2] = b[3] = -INFINITY;
  for (int i = cv->first_segment; i < cv->first_segment + cv->num_segments; i++)
    for (int k = 0; k < 3; k++) {
      const double *q = set->segments[i].p[k];
      b[0] = fmin(b[0], q[0]);
      b[1] = fmin(b[1], q[1]);
      b[2] = fmax(b[2], q[0]);
      b[3] = fmax(b[3], q[1]);
    }
}

void ch_segment_point(const ch_segment *s, double t, double out[2]) {
  if (s->is_line) {
    out[0] = s->p[0][0] + t * (s->p[2][0] - s->p[0][0]);
    out[1] = s->p[0][1] + t * (s->p[2][1] - s->p[0][1]);
  } else {
    double a = (1.0 - t) * (1.0 - t), b = 2.0 * (1.0 - t) * t, d = t * t;
    out[0] = a * s->p[0][0] + b * s->p[1][0] + d * s->p[2][0];
    out[1] = a * s->p[0][1] + b * s->p[1][1] + d * s->p[2][1];
  }
}

void ch_segment_box(const ch_segment *s, double r, double box[4]) {
  /* (ch_min3/ch_max3, not fmin/fmax: the step labels call this for every
   * segment of a cell's list, and gcc makes fmin/fmax libm calls) */
  for (int k = 0; k < 2; k++) {
    box[k] = ch_min3(s->p[0][k], s->p[1][k], s->p[2][k]) - r;
    box[2 + k] = ch_max3(s->p[0][k], s->p[1][k], s->p[2][k]) + r;
  }
}

void ch_curve_describe(const ch_curve *curve, char *out, size_t out_size) {
  const char *el = curve->element[0] ? curve->element : "path";
  if (curve->id[0])
    snprintf(out, out_size, "<%s> '%s' (line %d)", el, curve->id, curve->source_line);
  else
    snprintf(out, out_size, "<%s> #%d (line %d)", el, curve->element_index, curve->source_line);
}

/* Custom profile: linear between the points; at a jump (two points with
 * the same t) the smaller magnitude. */
static double custom_eval(const ch_profile *pr, double t) {
  int n = pr->num_points;
  /* Outside the points, and at the outer ones (a jump from 0 unless h is 0
   * there), the value is 0. */
  if (n < 1 || t <= pr->t[0] || t >= pr->t[n - 1]) return 0.0;
  int exact = 0;
  double best = 0.0;
  for (int i = 0; i < n; i++) {
    if (pr->t[i] == t && (!exact || fabs(pr->h[i]) < fabs(best))) {
      best = pr->h[i];
      exact = 1;
    }
  }
  if (exact) return best;
  for (int i = 0; i + 1 < n; i++) {
    if (t > pr->t[i] && t < pr->t[i + 1]) {
      double a = (t - pr->t[i]) / (pr->t[i + 1] - pr->t[i]);
      return pr->h[i] + a * (pr->h[i + 1] - pr->h[i]);
    }
  }
  return 0.0;
}

double ch_profile_eval(const ch_profile *pr, double t) {
  double a = fabs(t);
  switch (pr->kind) {
  case CH_PROFILE_V: return a < 0.5 ? -(1.0 - 2.0 * a) : 0.0;
  case CH_PROFILE_U: return a < 0.5 ? -sqrt(1.0 - 4.0 * t * t) : 0.0;
  case CH_PROFILE_BOX: return a < 0.5 ? -1.0 : 0.0;
  case CH_PROFILE_RIDGE: return a < 0.5 ? 1.0 - 2.0 * a : 0.0;
  /* The wall at t = 0 takes the smaller magnitude, 0, like box's ends. */
  case CH_PROFILE_BEVEL: return t > 0.0 && t < 0.5 ? -(1.0 - 2.0 * t) : 0.0;
  case CH_PROFILE_CUSTOM: return custom_eval(pr, t);
  }
  return 0.0;
}

double ch_profile_slope(const ch_profile *pr, double t) {
  double a = fabs(t);
  switch (pr->kind) {
  case CH_PROFILE_V: return a < 0.5 ? (t < 0.0 ? -2.0 : 2.0) : 0.0;
  case CH_PROFILE_U: return a < 0.5 ? 4.0 * t / sqrt(1.0 - 4.0 * t * t) : 0.0;
  case CH_PROFILE_BOX: return 0.0;
  case CH_PROFILE_RIDGE: return a < 0.5 ? (t < 0.0 ? 2.0 : -2.0) : 0.0;
  case CH_PROFILE_BEVEL: return t > 0.0 && t < 0.5 ? 2.0 : 0.0;
  case CH_PROFILE_CUSTOM:
    /* The piece holding t (the one to the right at a point). */
    for (int i = 0; i + 1 < pr->num_points; i++)
      if (t >= pr->t[i] && t < pr->t[i + 1]) return (pr->h[i + 1] - pr->h[i]) / (pr->t[i + 1] - pr->t[i]);
    return 0.0;
  }
  return 0.0;
}

static const struct {
  const char *name;
  ch_profile_kind kind;
} builtin_profiles[] = {{"v", CH_PROFILE_V},         {"u", CH_PROFILE_U},
                        {"box", CH_PROFILE_BOX},     {"ridge", CH_PROFILE_RIDGE},
                        {"bevel", CH_PROFILE_BEVEL}};

static int is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

int ch_profile_parse(const char *text, ch_profile *out, char *why, size_t why_size) {
  memset(out, 0, sizeof *out);
  while (is_space(*text)) text++;
  size_t len = strlen(text);
  while (len > 0 && is_space(text[len - 1])) len--;
  for (size_t i = 0; i < sizeof builtin_profiles / sizeof builtin_profiles[0]; i++) {
    if (strlen(builtin_profiles[i].name) == len && strncmp(text, builtin_profiles[i].name, len) == 0) {
      out->kind = builtin_profiles[i].kind;
      return 0;
    }
  }
  /* A custom list "t0,h0 t1,h1 ...": numbers separated by commas/spaces. */
  out->kind = CH_PROFILE_CUSTOM;
  double vals[2 * CH_PROFILE_MAX_POINTS];
  int n = 0;
  const char *p = text, *end = text + len;
  while (p < end) {
    while (p < end && (is_space(*p) || *p == ',')) p++;
    if (p >= end) break;
    char *next;
    double v = strtod(p, &next);
    if (next == p || next > end || (next < end && !is_space(*next) && *next != ',')) {
      snprintf(why, why_size, "unknown profile '%.*s' (expected v, u, box, ridge, bevel or \"t,h t,h ...\")",
               (int)(len > 40 ? 40 : len), text);
      return -1;
    }
    if (!isfinite(v)) {
      snprintf(why, why_size, "profile has a non-finite number");
      return -1;
    }
    if (n >= 2 * CH_PROFILE_MAX_POINTS) {
      snprintf(why, why_size, "profile has more than %d points", CH_PROFILE_MAX_POINTS);
      return -1;
    }
    vals[n++] = v;
    p = next;
  }
  if (n < 4 || n % 2) {
    snprintf(why, why_size, "custom profile needs at least two \"t,h\" pairs (got %d numbers)", n);
    return -1;
  }
  out->num_points = n / 2;
  for (int i = 0; i < out->num_points; i++) {
    out->t[i] = vals[2 * i];
    out->h[i] = vals[2 * i + 1];
    if (out->t[i] < -0.5 || out->t[i] > 0.5) {
      snprintf(why, why_size, "profile point %d has t = %g outside [-0.5, 0.5]", i, out->t[i]);
      return -1;
    }
    if (i > 0 && out->t[i] < out->t[i - 1]) {
      snprintf(why, why_size, "profile t values must not decrease (point %d)", i);
      return -1;
    }
    if (i > 1 && out->t[i] == out->t[i - 2]) {
      snprintf(why, why_size, "profile has three points at t = %g", out->t[i]);
      return -1;
    }
  }
  return 0;
}

int ch_profile_creases(const ch_profile *pr, double *t, int max) {
  double tmp[CH_PROFILE_MAX_POINTS + 2];
  int n = 0;
  switch (pr->kind) {
  case CH_PROFILE_V:
  case CH_PROFILE_RIDGE: tmp[n++] = -0.5; tmp[n++] = 0.0; tmp[n++] = 0.5; break;
  case CH_PROFILE_U:
  case CH_PROFILE_BOX: tmp[n++] = -0.5; tmp[n++] = 0.5; break;
  case CH_PROFILE_BEVEL: tmp[n++] = 0.0; tmp[n++] = 0.5; break;
  case CH_PROFILE_CUSTOM:
    for (int i = 0; i < pr->num_points; i++) {
      if (n > 0 && tmp[n - 1] == pr->t[i]) continue;
      /* Interior points where the slope does not change are no crease. */
      if (i > 0 && i + 1 < pr->num_points && pr->t[i - 1] < pr->t[i] && pr->t[i] < pr->t[i + 1]) {
        double s0 = (pr->h[i] - pr->h[i - 1]) / (pr->t[i] - pr->t[i - 1]);
        double s1 = (pr->h[i + 1] - pr->h[i]) / (pr->t[i + 1] - pr->t[i]);
        if (fabs(s0 - s1) <= 1e-12 * (fabs(s0) + fabs(s1))) continue;
      }
      tmp[n++] = pr->t[i];
    }
    break;
  }
  int k = n < max ? n : max;
  memcpy(t, tmp, (size_t)k * sizeof *t);
  return k;
}

int ch_segments_at_joint(const ch_curve_set *set, int ia, int ib, double s, double t) {
  const ch_segment *a = &set->segments[ia];
  for (int end = 0; end < 2; end++) {
    /* end 1: a's end is b's start; end 0: a's start is b's end */
    if ((end ? a->next : a->prev) != ib) continue;
    double sa = end ? 1.0 - s : s, tb = end ? t : 1.0 - t;
    if (sa <= 1e-9 && tb <= 1e-9) return 1;
    if (sa > 0.5 || tb > 0.5) continue;
    double p[2];
    ch_segment_point(a, s, p);
    const double *j = a->p[end ? 2 : 0];
    if (hypot(p[0] - j[0], p[1] - j[1]) <= 1e-7) return 1;
  }
  return 0;
}

int ch_segments_winding(const ch_curve_set *set, int first, int count, const double q[2]) {
  int w = 0;
  const double qv = q[1];
  for (int i = 0; i < count; i++) {
    const ch_segment *s = &set->segments[first + i];
    double v0 = s->p[0][1], v1 = s->p[1][1], v2 = s->p[2][1];
    if ((v0 <= qv) == (v2 <= qv) && (v1 <= qv) == (v0 <= qv)) continue; /* all on one side: no crossing */
    double a = v0 - 2.0 * v1 + v2, b = 2.0 * (v1 - v0);
    /* v(t) in monotone pieces, split at its turning point */
    double ts[3] = {0.0, 1.0, 1.0}, vs[3] = {v0, v2, v2};
    int pieces = 1;
    if (!s->is_line && a != 0.0) {
      double tm = -b / (2.0 * a);
      if (tm > 0.0 && tm < 1.0) {
        ts[1] = tm, vs[1] = (a * tm + b) * tm + v0;
        ts[2] = 1.0, vs[2] = v2;
        pieces = 2;
      }
    }
    for (int k = 0; k < pieces; k++) {
      double va = vs[k], vb = vs[k + 1], t0 = ts[k], t1 = ts[k + 1], t;
      if ((va <= qv) == (vb <= qv)) continue;
      if (s->is_line) {
        t = (qv - v0) / (v2 - v0);
      } else {
        /* the root in [t0, t1] (the nearest, against rounding) */
        double roots[2];
        int nr = ch_quadratic_roots(a, b, v0 - qv, roots);
        t = 0.5 * (t0 + t1);
        double best = 1e300;
        for (int j = 0; j < nr; j++) {
          double d = roots[j] < t0 ? t0 - roots[j] : roots[j] > t1 ? roots[j] - t1 : 0.0;
          if (d < best) best = d, t = roots[j];
        }
      }
      t = t < t0 ? t0 : t > t1 ? t1 : t;
      double pt[2];
      ch_segment_point(s, t, pt);
      if (pt[0] > q[0]) w += vb > va ? 1 : -1;
    }
  }
  return w;
}
