/* The SVG reader of docs/spec.md §2: libxml2 builds the tree; we walk it carrying
 * the current transform (user space -> UV) and the inherited data-
 * attributes, and turn every path and basic shape into quadratic segments
 * in UV. Path data follows the SVG 1.1 grammar (implicit repeated commands,
 * numbers without separators, arc flags without separators); arcs use the
 * end-point to centre conversion of SVG 1.1 appendix F.6.
 *
 * Why one file of about 1,300 lines: it is one reader of one grammar
 * (the tree walk, style and attribute inheritance, transforms, path data,
 * shapes, libxml2's limits and errors), whose parts share the walk's state
 * and the error messages' element numbering; its only interface is
 * ch_curves_read_svg*. */
#include <libxml/globals.h>
#include <libxml/parser.h>
#include <libxml/tree.h>
#include <libxml/xmlerror.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ch_bezier.h"
#include "ch_css.h"
#include "ch_curves.h"
#include "ch_file.h"
#include "ch_fillunion.h"
#include "ch_math.h"

/* Inherited state: the data- attributes as strings (pointers into the
 * document, resolved on each curve), the paint given explicitly (attribute
 * or style declaration; copies, "" when not given) and the current
 * transform. */
enum { PAINT_MAX = 48 };
typedef struct svg_style {
  const char *kind, *profile, *width, *depth, *left, *right;
  const char *left_color, *right_color, *blur, *priority;
  int has_data; /* any data- attribute, own or inherited */
  char fill[PAINT_MAX], stroke[PAINT_MAX], stroke_width[PAINT_MAX], fill_rule[PAINT_MAX];
  double ctm[6]; /* user space -> UV: x' = a x + c y + e, y' = b x + d y + f */
} svg_style;

enum { IGNORED_KINDS = 16 };

typedef struct id_entry {
  const char *id;
  const xmlNode *node;
  int order;
} id_entry;

/* <use> nesting and instances, at most (an expansion attack of nested uses
 * would otherwise walk 10^k copies). */
enum { CH_SVG_MAX_USE_DEPTH = 32, CH_SVG_MAX_USES = 100000 };

typedef struct svg_parser {
  const char *name; /* file name for messages */
  ch_error *err;
  ch_curve_set *set;
  int cap_curves, cap_segments, cap_subpaths;
  double width_scale; /* viewBox units -> UV for widths and blur radii */
  double fill_height; /* a filled shape's inside (ch_svg_desc) */
  int num_elements;
  int fill_curve;       /* the curve is a fill: close open subpaths, inside left */
  int fill_evenodd;     /* its fill-rule */
  /* For the union of fills: each curve's fill rule (CH_FILL_*), and the
   * subpaths orient_fill reversed. */
  unsigned char *fill_rule, *flipped;
  int cap_fill_rule, cap_flipped;
  ch_css css; /* the rules of every <style> */
  /* Elements by id for <use>, sorted by id and then document order; the
   * <use> targets being drawn (to refuse cycles), and how many in all. */
  struct id_entry *ids;
  int num_ids, cap_ids;
  const xmlNode *use_stack[CH_SVG_MAX_USE_DEPTH];
  int use_depth;
  long use_count;
  /* The curve under construction. */
  ch_curve *curve;
  int subpath_open;     /* a subpath record is open */
  int subpath_closed;   /* it was closed with Z */
  /* Ignored elements, reported as one warning per element name. */
  char ignored_name[IGNORED_KINDS][32];
  int ignored_count[IGNORED_KINDS];
  int ignored_line[IGNORED_KINDS];
  int num_ignored_kinds;
} svg_parser;

/* ---- errors ---- */

static ch_status fail_curve(svg_parser *ps, const char *fmt, const char *detail) {
  char what[160];
  ch_curve_describe(ps->curve, what, sizeof what);
  char msg[600];
  snprintf(msg, sizeof msg, fmt, detail ? detail : "");
  return ch_error_set(ps->err, CH_ERR_INPUT, "%s: %s: %s", ps->name, what, msg);
}

static ch_status fail_node(svg_parser *ps, const xmlNode *node, const char *msg) {
  return ch_error_set(ps->err, CH_ERR_INPUT, "%s: <%s> (line %d): %s", ps->name,
                      (const char *)node->name, (int)xmlGetLineNo(node), msg);
}

/* ---- numbers ---- */

static int is_wsp(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f'; }
static int is_digit(char c) { return c >= '0' && c <= '9'; }

/* Scans one SVG number at *pp (sign, digits, fraction, exponent); strtod
 * alone would also take "inf", "nan" and hex. Returns 0 and advances on
 * success. */
static int scan_number(const char **pp, double *out) {
  const char *p = *pp, *start = p;
  if (*p == '+' || *p == '-') p++;
  int digits = 0;
  while (is_digit(*p)) p++, digits++;
  if (*p == '.') {
    p++;
    while (is_digit(*p)) p++, digits++;
  }
  if (!digits) return -1;
  if (*p == 'e' || *p == 'E') {
    const char *e = p + 1;
    if (*e == '+' || *e == '-') e++;
    if (is_digit(*e)) {
      while (is_digit(*e)) e++;
      p = e;
    }
  }
  char buf[128];
  size_t n = (size_t)(p - start);
  if (n >= sizeof buf) return -1;
  memcpy(buf, start, n);
  buf[n] = '\0';
  double v = strtod(buf, NULL);
  if (!isfinite(v)) return -1;
  *out = v;
  *pp = p;
  return 0;
}

static void skip_wsp(const char **pp) {
  while (is_wsp(**pp)) (*pp)++;
}
/* Whitespace with at most one comma: the separator between arguments. */
static void skip_sep(const char **pp) {
  skip_wsp(pp);
  if (**pp == ',') {
    (*pp)++;
    skip_wsp(pp);
  }
}

/* A whole attribute that must be exactly one number. */
static int parse_single_number(const char *s, double *out) {
  skip_wsp(&s);
  if (scan_number(&s, out)) return -1;
  skip_wsp(&s);
  return *s ? -1 : 0;
}

/* A length with an optional absolute unit, in user units (px). */
static int parse_length(const char *s, double *out) {
  skip_wsp(&s);
  double v;
  if (scan_number(&s, &v)) return -1;
  static const struct { const char *unit; double px; } units[] = {
      {"px", 1.0}, {"mm", 96.0 / 25.4}, {"cm", 96.0 / 2.54}, {"in", 96.0}, {"pt", 96.0 / 72.0},
      {"pc", 16.0}};
  double scale = 1.0;
  for (size_t i = 0; i < sizeof units / sizeof units[0]; i++) {
    size_t n = strlen(units[i].unit);
    if (strncmp(s, units[i].unit, n) == 0) {
      scale = units[i].px;
      s += n;
      break;
    }
  }
  skip_wsp(&s);
  if (*s) return -1;
  *out = v * scale;
  return 0;
}

/* ---- transforms ---- */

static void mat_mul(const double a[6], const double b[6], double out[6]) {
  /* out = a * b (apply b first). */
  double r[6] = {a[0] * b[0] + a[2] * b[1], a[1] * b[0] + a[3] * b[1],
                 a[0] * b[2] + a[2] * b[3], a[1] * b[2] + a[3] * b[3],
                 a[0] * b[4] + a[2] * b[5] + a[4], a[1] * b[4] + a[3] * b[5] + a[5]};
  memcpy(out, r, sizeof r);
}

static void mat_apply(const double m[6], double x, double y, double out[2]) {
  out[0] = m[0] * x + m[2] * y + m[4];
  out[1] = m[1] * x + m[3] * y + m[5];
}

/* Parses a transform list; on error writes a reason. */
static int parse_transform(const char *s, double m[6], char *why, size_t why_size) {
  double acc[6] = {1, 0, 0, 1, 0, 0};
  skip_wsp(&s);
  while (*s) {
    static const char *names[] = {"matrix", "translate", "scale", "rotate", "skewX", "skewY"};
    int which = -1;
    for (int i = 0; i < 6; i++) {
      size_t n = strlen(names[i]);
      if (strncmp(s, names[i], n) == 0) {
        which = i;
        s += n;
        break;
      }
    }
    if (which < 0) {
      snprintf(why, why_size, "bad transform near '%.20s'", s);
      return -1;
    }
    skip_wsp(&s);
    if (*s != '(') {
      snprintf(why, why_size, "bad transform: expected '(' after %s", names[which]);
      return -1;
    }
    s++;
    double a[6];
    int n = 0;
    skip_wsp(&s);
    while (*s && *s != ')') {
      if (n >= 6 || scan_number(&s, &a[n])) {
        snprintf(why, why_size, "bad transform: bad number in %s(...)", names[which]);
        return -1;
      }
      n++;
      skip_sep(&s);
    }
    if (*s != ')') {
      snprintf(why, why_size, "bad transform: missing ')' after %s", names[which]);
      return -1;
    }
    s++;
    static const int min_args[] = {6, 1, 1, 1, 1, 1}, max_args[] = {6, 2, 2, 3, 1, 1};
    if (n < min_args[which] || n > max_args[which] || (which == 3 && n == 2)) {
      snprintf(why, why_size, "bad transform: %s takes %d..%d numbers, got %d", names[which],
               min_args[which], max_args[which], n);
      return -1;
    }
    double t[6] = {1, 0, 0, 1, 0, 0};
    switch (which) {
    case 0: memcpy(t, a, sizeof t); break;
    case 1: t[4] = a[0]; t[5] = n > 1 ? a[1] : 0.0; break;
    case 2: t[0] = a[0]; t[3] = n > 1 ? a[1] : a[0]; break;
    case 3: {
      double r = a[0] * CH_PI / 180.0, c = cos(r), sn = sin(r);
      double cx = n == 3 ? a[1] : 0.0, cy = n == 3 ? a[2] : 0.0;
      /* translate(cx,cy) rotate(a) translate(-cx,-cy) */
      t[0] = c; t[1] = sn; t[2] = -sn; t[3] = c;
      t[4] = cx - c * cx + sn * cy;
      t[5] = cy - sn * cx - c * cy;
      break;
    }
    case 4: t[2] = tan(a[0] * CH_PI / 180.0); break;
    case 5: t[1] = tan(a[0] * CH_PI / 180.0); break;
    }
    for (int i = 0; i < 6; i++) {
      if (!isfinite(t[i])) {
        snprintf(why, why_size, "bad transform: %s gives a non-finite matrix", names[which]);
        return -1;
      }
    }
    mat_mul(acc, t, acc);
    skip_sep(&s);
  }
  memcpy(m, acc, sizeof acc);
  return 0;
}

/* ---- building curves ---- */

static ch_status grow(svg_parser *ps, void **array, int *cap, int need, size_t elem) {
  if (need <= *cap) return CH_OK;
  int cap2 = *cap ? *cap : 16;
  while (cap2 < need) cap2 = cap2 > INT_MAX / 2 ? need : cap2 * 2;
  void *p = realloc(*array, (size_t)cap2 * elem);
  if (!p) return ch_error_set(ps->err, CH_ERR_NOMEM, "%s: out of memory", ps->name);
  *array = p;
  *cap = cap2;
  return CH_OK;
}

static void subpath_begin(svg_parser *ps) {
  ps->subpath_open = 1;
  ps->subpath_closed = 0;
}

static ch_status add_quad_uv(svg_parser *ps, const double q[3][2], int is_line);

/* Ends the open subpath: drops it if empty, links neighbours, detects
 * closure (Z, or the end on the start). */
static ch_status subpath_end(svg_parser *ps) {
  if (!ps->subpath_open) return CH_OK;
  ps->subpath_open = 0;
  ch_curve_set *set = ps->set;
  ch_curve *c = ps->curve;
  int first = c->first_segment;
  /* Segments of this subpath are those after the previous subpath's. */
  if (c->num_subpaths > 0) {
    const ch_subpath *last = &set->subpaths[set->num_subpaths - 1];
    first = last->first_segment + last->num_segments;
  }
  int n = set->num_segments - first;
  if (n <= 0) return CH_OK;
  ch_status st = grow(ps, (void **)&set->subpaths, &ps->cap_subpaths, set->num_subpaths + 1,
                      sizeof *set->subpaths);
  if (st) return st;
  ch_segment *s0 = &set->segments[first], *s1 = &set->segments[first + n - 1];
  double du = s1->p[2][0] - s0->p[0][0], dv = s1->p[2][1] - s0->p[0][1];
  if (ps->fill_curve && !ps->subpath_closed && du * du + dv * dv > 1e-24) {
    /* A fill closes an open subpath with a straight line (SVG 1.1 §11.3),
     * so the step curve is the outline that is drawn. */
    double q[3][2] = {{s1->p[2][0], s1->p[2][1]}, {0, 0}, {s0->p[0][0], s0->p[0][1]}};
    if ((st = add_quad_uv(ps, q, 1))) return st;
    n = set->num_segments - first;
    s0 = &set->segments[first];
    s1 = &set->segments[first + n - 1];
    du = dv = 0.0;
  }
  int closed = ps->subpath_closed || du * du + dv * dv <= 1e-24;
  if (closed) {
    /* Make the joint exact so the two ends are one point. */
    s1->p[2][0] = s0->p[0][0];
    s1->p[2][1] = s0->p[0][1];
  }
  for (int i = 0; i < n; i++) {
    ch_segment *s = &set->segments[first + i];
    s->prev = i > 0 ? first + i - 1 : closed ? first + n - 1 : -1;
    s->next = i + 1 < n ? first + i + 1 : closed ? first : -1;
  }
  ch_subpath *sp = &set->subpaths[set->num_subpaths++];
  sp->first_segment = first;
  sp->num_segments = n;
  sp->closed = closed;
  c->num_subpaths++;
  return CH_OK;
}

static int near_equal(const double a[2], const double b[2]) {
  double du = a[0] - b[0], dv = a[1] - b[1];
  return du * du + dv * dv <= 1e-28;
}

/* Appends a segment already in UV; drops segments of zero length. */
static ch_status add_quad_uv(svg_parser *ps, const double q[3][2], int is_line) {
  /* A line's control point is not set by its caller (it becomes the
   * midpoint below): only the ends are checked then. */
  for (int i = 0; i < 3; i++)
    if ((i != 1 || !is_line) && !ch_finite2(q[i])) return fail_curve(ps, "coordinates out of range%s", "");
  /* Far outside the texture a curve means nothing and its coordinates
   * have lost their precision (a viewBox 1e80 off its origin folds every
   * curve onto one line: the grids and trees then list each everywhere). */
  for (int i = 0; i < 3; i++)
    if ((i != 1 || !is_line) && !(fabs(q[i][0]) <= CH_CURVES_MAX_UV && fabs(q[i][1]) <= CH_CURVES_MAX_UV)) {
      char what[96];
      snprintf(what, sizeof what, " (|u| or |v| above %g: %g texture widths away)", (double)CH_CURVES_MAX_UV,
               fmax(fabs(q[i][0]), fabs(q[i][1])));
      return fail_curve(ps, "coordinates far outside the texture%s", what);
    }
  if (near_equal(q[0], q[2]) && (is_line || near_equal(q[0], q[1]))) return CH_OK;
  if (!is_line) {
    /* A quadratic whose control point lies on its chord (a straight cubic,
     * as editors write straight edges, gives these) is a line, and one
     * whose control point lies beyond an end runs out and back: two
     * lines, split where it turns. Queries then take the exact straight
     * branch, and the union of fills sees edges that lie on one another. */
    double d[2] = {q[2][0] - q[0][0], q[2][1] - q[0][1]}, e[2] = {q[1][0] - q[0][0], q[1][1] - q[0][1]};
    double len2 = d[0] * d[0] + d[1] * d[1];
    if (len2 > 0.0 && fabs(d[0] * e[1] - d[1] * e[0]) <= 1e-12 * len2) {
      double u = (e[0] * d[0] + e[1] * d[1]) / len2; /* the control point along the chord */
      if (u >= 0.0 && u <= 1.0) return add_quad_uv(ps, q, 1);
      double turn[2];
      ch_bezier_eval(q, u / (2.0 * u - 1.0), turn); /* where d/dt of the chord coordinate is 0 */
      double a[3][2] = {{q[0][0], q[0][1]}, {0, 0}, {turn[0], turn[1]}};
      double b[3][2] = {{turn[0], turn[1]}, {0, 0}, {q[2][0], q[2][1]}};
      ch_status st = add_quad_uv(ps, a, 1);
      return st ? st : add_quad_uv(ps, b, 1);
    }
  }
  ch_curve_set *set = ps->set;
  if (set->num_segments >= CH_CURVES_MAX_SEGMENTS)
    return fail_curve(ps, "too many segments (a cubic or arc this large is not a feature curve)%s", "");
  ch_status st = grow(ps, (void **)&set->segments, &ps->cap_segments, set->num_segments + 1,
                      sizeof *set->segments);
  if (st) return st;
  ch_segment *s = &set->segments[set->num_segments++];
  memcpy(s->p, q, sizeof s->p);
  if (is_line) {
    s->p[1][0] = 0.5 * (q[0][0] + q[2][0]);
    s->p[1][1] = 0.5 * (q[0][1] + q[2][1]);
  }
  s->is_line = is_line;
  s->curve = set->num_curves - 1;
  s->prev = s->next = -1;
  ps->curve->num_segments++;
  return CH_OK;
}

typedef struct geom_ctx {
  svg_parser *ps;
  const double *ctm;
  double cur[2], start[2];   /* current point and subpath start, user space */
  double last_ctrl[2];       /* for S/T reflection */
  char last_cmd;             /* previous command, upper case */
} geom_ctx;

static ch_status line_to(geom_ctx *g, double x, double y) {
  double q[3][2];
  mat_apply(g->ctm, g->cur[0], g->cur[1], q[0]);
  mat_apply(g->ctm, x, y, q[2]);
  q[1][0] = 0.5 * (q[0][0] + q[2][0]);
  q[1][1] = 0.5 * (q[0][1] + q[2][1]);
  g->cur[0] = x;
  g->cur[1] = y;
  return add_quad_uv(g->ps, q, 1);
}

static ch_status quad_to(geom_ctx *g, double x1, double y1, double x, double y) {
  double q[3][2];
  mat_apply(g->ctm, g->cur[0], g->cur[1], q[0]);
  mat_apply(g->ctm, x1, y1, q[1]);
  mat_apply(g->ctm, x, y, q[2]);
  g->cur[0] = x;
  g->cur[1] = y;
  return add_quad_uv(g->ps, q, 0);
}

static int sink_quad(void *user, const double q[3][2]) {
  svg_parser *ps = user;
  return add_quad_uv(ps, q, 0) != CH_OK;
}

static ch_status cubic_to(geom_ctx *g, double x1, double y1, double x2, double y2, double x, double y) {
  double c[4][2];
  mat_apply(g->ctm, g->cur[0], g->cur[1], c[0]);
  mat_apply(g->ctm, x1, y1, c[1]);
  mat_apply(g->ctm, x2, y2, c[2]);
  mat_apply(g->ctm, x, y, c[3]);
  g->cur[0] = x;
  g->cur[1] = y;
  for (int i = 0; i < 4; i++)
    if (!ch_finite2(c[i])) return fail_curve(g->ps, "coordinates out of range%s", "");
  if (ch_cubic_to_quads(c, CH_CURVES_SPLIT_TOLERANCE, sink_quad, g->ps))
    return g->ps->err->status ? g->ps->err->status : CH_ERR_INTERNAL;
  return CH_OK;
}

/* SVG 1.1 F.6.5: end-point parameterisation to centre parameterisation. */
static ch_status arc_to(geom_ctx *g, double rx, double ry, double phi_deg, int large, int sweep,
                        double x, double y) {
  double x0 = g->cur[0], y0 = g->cur[1];
  if (x0 == x && y0 == y) return CH_OK; /* F.6.2: omitted */
  rx = fabs(rx);
  ry = fabs(ry);
  if (rx == 0.0 || ry == 0.0) return line_to(g, x, y);
  double phi = fmod(phi_deg, 360.0) * CH_PI / 180.0, cp = cos(phi), sp = sin(phi);
  double dx = 0.5 * (x0 - x), dy = 0.5 * (y0 - y);
  double x1p = cp * dx + sp * dy, y1p = -sp * dx + cp * dy;
  double lambda = (x1p * x1p) / (rx * rx) + (y1p * y1p) / (ry * ry);
  if (lambda > 1.0) { /* F.6.6: radii too small, scale up */
    double s = sqrt(lambda);
    rx *= s;
    ry *= s;
  }
  double num = rx * rx * ry * ry - rx * rx * y1p * y1p - ry * ry * x1p * x1p;
  double den = rx * rx * y1p * y1p + ry * ry * x1p * x1p;
  double coef = den > 0.0 && num > 0.0 ? sqrt(num / den) : 0.0;
  if (large == sweep) coef = -coef;
  double cxp = coef * rx * y1p / ry, cyp = -coef * ry * x1p / rx;
  double cx = cp * cxp - sp * cyp + 0.5 * (x0 + x), cy = sp * cxp + cp * cyp + 0.5 * (y0 + y);
  double ux = (x1p - cxp) / rx, uy = (y1p - cyp) / ry;
  double vx = (-x1p - cxp) / rx, vy = (-y1p - cyp) / ry;
  double theta1 = atan2(uy, ux);
  double dtheta = atan2(ux * vy - uy * vx, ux * vx + uy * vy);
  if (!sweep && dtheta > 0.0) dtheta -= 2.0 * CH_PI;
  if (sweep && dtheta < 0.0) dtheta += 2.0 * CH_PI;
  /* Unit circle -> ellipse in user space -> UV. */
  double ell[6] = {rx * cp, rx * sp, -ry * sp, ry * cp, cx, cy}, m[6];
  mat_mul(g->ctm, ell, m);
  for (int i = 0; i < 6; i++)
    if (!isfinite(m[i])) return fail_curve(g->ps, "arc out of range%s", "");
  int first = g->ps->set->num_segments;
  if (ch_arc_to_quads(theta1, dtheta, m, CH_CURVES_SPLIT_TOLERANCE, sink_quad, g->ps))
    return g->ps->err->status ? g->ps->err->status : CH_ERR_INTERNAL;
  /* Pin the arc's ends to the exact path points so the joints are exact. */
  int last = g->ps->set->num_segments - 1;
  if (last >= first) {
    mat_apply(g->ctm, x0, y0, g->ps->set->segments[first].p[0]);
    mat_apply(g->ctm, x, y, g->ps->set->segments[last].p[2]);
  }
  g->cur[0] = x;
  g->cur[1] = y;
  return CH_OK;
}

static ch_status close_path(geom_ctx *g) {
  ch_status st = CH_OK;
  if (g->cur[0] != g->start[0] || g->cur[1] != g->start[1]) st = line_to(g, g->start[0], g->start[1]);
  if (st) return st;
  g->ps->subpath_closed = 1;
  st = subpath_end(g->ps);
  g->cur[0] = g->start[0];
  g->cur[1] = g->start[1];
  return st;
}

static ch_status move_to(geom_ctx *g, double x, double y) {
  ch_status st = subpath_end(g->ps);
  if (st) return st;
  subpath_begin(g->ps);
  g->cur[0] = g->start[0] = x;
  g->cur[1] = g->start[1] = y;
  return CH_OK;
}

static int path_args(char cmd) {
  switch (cmd) {
  case 'M': case 'L': case 'T': return 2;
  case 'H': case 'V': return 1;
  case 'Q': case 'S': return 4;
  case 'C': return 6;
  case 'A': return 7;
  default: return 0;
  }
}

/* Parses SVG path data into the current curve. */
static ch_status parse_path_data(svg_parser *ps, const char *d, const double ctm[6]) {
  geom_ctx g = {.ps = ps, .ctm = ctm};
  const char *p = d;
  char cmd = 0;
  int first = 1;
  char why[200];
  skip_wsp(&p);
  while (*p) {
    char c = *p;
    int explicit_cmd = strchr("MmLlHhVvQqTtCcSsAaZz", c) != NULL && c != '\0';
    if (explicit_cmd) {
      cmd = c;
      p++;
    } else if (!cmd || cmd == 'Z' || cmd == 'z') {
      snprintf(why, sizeof why, "bad path data at offset %d ('%.12s'): expected a command",
               (int)(p - d), p);
      return fail_curve(ps, "%s", why);
    }
    if (first && cmd != 'M' && cmd != 'm') {
      snprintf(why, sizeof why, "path data must start with a moveto, not '%c'", cmd);
      return fail_curve(ps, "%s", why);
    }
    first = 0;
    char up = (char)(cmd >= 'a' ? cmd - 32 : cmd);
    int rel = cmd >= 'a';
    double a[7];
    int n = path_args(up);
    skip_wsp(&p);
    for (int i = 0; i < n; i++) {
      if (i > 0) skip_sep(&p);
      if (up == 'A' && (i == 3 || i == 4)) {
        if (*p != '0' && *p != '1') {
          snprintf(why, sizeof why, "bad path data at offset %d ('%.12s'): expected an arc flag 0 or 1",
                   (int)(p - d), p);
          return fail_curve(ps, "%s", why);
        }
        a[i] = *p++ - '0';
      } else if (scan_number(&p, &a[i])) {
        snprintf(why, sizeof why, "bad path data at offset %d ('%.12s'): expected a number for '%c'",
                 (int)(p - d), p, cmd);
        return fail_curve(ps, "%s", why);
      }
    }
    double ox = rel ? g.cur[0] : 0.0, oy = rel ? g.cur[1] : 0.0;
    ch_status st = CH_OK;
    /* After Z without a moveto, the next subpath starts at the old start. */
    if (up != 'M' && up != 'Z' && !ps->subpath_open) {
      subpath_begin(ps);
      g.start[0] = g.cur[0];
      g.start[1] = g.cur[1];
    }
    double ctrl[2] = {g.cur[0], g.cur[1]};
    switch (up) {
    case 'M':
      st = move_to(&g, ox + a[0], oy + a[1]);
      cmd = rel ? 'l' : 'L'; /* further pairs are linetos */
      break;
    case 'L': st = line_to(&g, ox + a[0], oy + a[1]); break;
    case 'H': st = line_to(&g, ox + a[0], g.cur[1]); break;
    case 'V': st = line_to(&g, g.cur[0], oy + a[0]); break;
    case 'Q':
      g.last_ctrl[0] = ox + a[0];
      g.last_ctrl[1] = oy + a[1];
      st = quad_to(&g, ox + a[0], oy + a[1], ox + a[2], oy + a[3]);
      break;
    case 'T':
      if (g.last_cmd == 'Q' || g.last_cmd == 'T') {
        ctrl[0] = 2.0 * g.cur[0] - g.last_ctrl[0];
        ctrl[1] = 2.0 * g.cur[1] - g.last_ctrl[1];
      }
      g.last_ctrl[0] = ctrl[0];
      g.last_ctrl[1] = ctrl[1];
      st = quad_to(&g, ctrl[0], ctrl[1], ox + a[0], oy + a[1]);
      break;
    case 'C':
      g.last_ctrl[0] = ox + a[2];
      g.last_ctrl[1] = oy + a[3];
      st = cubic_to(&g, ox + a[0], oy + a[1], ox + a[2], oy + a[3], ox + a[4], oy + a[5]);
      break;
    case 'S':
      if (g.last_cmd == 'C' || g.last_cmd == 'S') {
        ctrl[0] = 2.0 * g.cur[0] - g.last_ctrl[0];
        ctrl[1] = 2.0 * g.cur[1] - g.last_ctrl[1];
      }
      g.last_ctrl[0] = ox + a[0];
      g.last_ctrl[1] = oy + a[1];
      st = cubic_to(&g, ctrl[0], ctrl[1], ox + a[0], oy + a[1], ox + a[2], oy + a[3]);
      break;
    case 'A':
      st = arc_to(&g, a[0], a[1], a[2], (int)a[3], (int)a[4], ox + a[5], oy + a[6]);
      break;
    case 'Z': st = close_path(&g); break;
    }
    if (st) return st;
    g.last_cmd = up;
    skip_sep(&p);
  }
  return subpath_end(ps);
}

/* ---- attributes ---- */

static const char *attr(const xmlNode *node, const char *name) {
  for (const xmlAttr *a = node->properties; a; a = a->next) {
    if (a->ns) continue; /* inkscape:, sodipodi:, xlink: ... */
    if (strcmp((const char *)a->name, name) == 0)
      return a->children && a->children->content ? (const char *)a->children->content : "";
  }
  return NULL;
}

/* s equals kw up to surrounding whitespace. */
static int keyword_is(const char *s, const char *kw) {
  skip_wsp(&s);
  size_t n = strlen(kw);
  if (strncmp(s, kw, n) != 0) return 0;
  s += n;
  skip_wsp(&s);
  return *s == '\0';
}

static int parse_color(const char *s, double rgb[3]) {
  skip_wsp(&s);
  if (*s != '#') return -1;
  s++;
  unsigned v[6];
  int n = 0;
  while (n < 6 && s[n]) {
    char c = s[n];
    if (c >= '0' && c <= '9') v[n] = (unsigned)(c - '0');
    else if (c >= 'a' && c <= 'f') v[n] = (unsigned)(c - 'a' + 10);
    else if (c >= 'A' && c <= 'F') v[n] = (unsigned)(c - 'A' + 10);
    else break;
    n++;
  }
  const char *rest = s + n;
  skip_wsp(&rest);
  if (*rest || (n != 3 && n != 6)) return -1;
  for (int i = 0; i < 3; i++)
    rgb[i] = n == 6 ? (double)(v[2 * i] * 16 + v[2 * i + 1]) / 255.0 : (double)(v[i] * 17) / 255.0;
  return 0;
}

/* Copies a paint value (trimmed) into a style slot. */
static void set_paint(char dst[PAINT_MAX], const char *value, size_t len) {
  while (len && is_wsp(*value)) value++, len--;
  while (len && is_wsp(value[len - 1])) len--;
  if (len >= PAINT_MAX) len = PAINT_MAX - 1;
  memcpy(dst, value, len);
  dst[len] = '\0';
}

/* The properties chisel reads from an element's own styling. */
enum { PROP_FILL, PROP_STROKE, PROP_STROKE_WIDTH, PROP_FILL_RULE, PROP_DISPLAY, NUM_PROPS };
static const char *const prop_names[NUM_PROPS] = {"fill", "stroke", "stroke-width", "fill-rule", "display"};

typedef struct own_props {
  char value[NUM_PROPS][PAINT_MAX]; /* "" where the element sets none */
} own_props;

static void set_prop(void *user, const char *name, const char *value) {
  own_props *o = user;
  for (int i = 0; i < NUM_PROPS; i++)
    if (strcmp(name, prop_names[i]) == 0) set_paint(o->value[i], value, strlen(value));
}

/* What the element itself sets, by the cascade (ch_css.h): presentation
 * attributes, then the stylesheets' rules, then the style attribute's
 * declarations, then the rules' !important ones. */
static void own_styling(const svg_parser *ps, const xmlNode *node, own_props *o) {
  memset(o, 0, sizeof *o);
  for (int i = 0; i < NUM_PROPS; i++) {
    const char *v = attr(node, prop_names[i]);
    if (v) set_paint(o->value[i], v, strlen(v));
  }
  const char *element = (const char *)node->name, *id = attr(node, "id"), *classes = attr(node, "class");
  ch_css_cascade(&ps->css, element, id, classes, 0, set_prop, o);
  const char *style = attr(node, "style");
  for (const char *p = style; p && *p;) {
    size_t decl = strcspn(p, ";");
    const char *colon = memchr(p, ':', decl);
    if (colon) {
      const char *name = p;
      size_t nlen = (size_t)(colon - p);
      while (nlen && is_wsp(*name)) name++, nlen--;
      while (nlen && is_wsp(name[nlen - 1])) nlen--;
      for (int i = 0; i < NUM_PROPS; i++)
        if (strlen(prop_names[i]) == nlen && !strncmp(name, prop_names[i], nlen))
          set_paint(o->value[i], colon + 1, decl - (size_t)(colon + 1 - p));
    }
    p += decl;
    if (*p == ';') p++;
  }
  ch_css_cascade(&ps->css, element, id, classes, 1, set_prop, o);
}

static int own_hidden(const own_props *own) { return keyword_is(own->value[PROP_DISPLAY], "none"); }

/* Whether a paint value paints: given, and not "none". */
static int paints(const char *paint) { return paint[0] && !keyword_is(paint, "none"); }

/* Updates style with the node's own data- attributes, paint (own: its
 * own_styling) and transform. */
static ch_status inherit(svg_parser *ps, const xmlNode *node, const own_props *own, svg_style *st) {
  char *paint[] = {st->fill, st->stroke, st->stroke_width, st->fill_rule};
  for (int i = 0; i < 4; i++)
    if (own->value[i][0]) memcpy(paint[i], own->value[i], PAINT_MAX);
  static const char *known[] = {"data-kind", "data-profile", "data-width", "data-depth",
                                "data-left", "data-right", "data-left-color", "data-right-color",
                                "data-blur", "data-priority"};
  const char **slots[] = {&st->kind, &st->profile, &st->width, &st->depth, &st->left, &st->right,
                          &st->left_color, &st->right_color, &st->blur, &st->priority};
  for (const xmlAttr *a = node->properties; a; a = a->next) {
    if (a->ns) continue;
    const char *name = (const char *)a->name;
    if (strncmp(name, "data-", 5) != 0) continue;
    const char *value = a->children && a->children->content ? (const char *)a->children->content : "";
    int found = 0;
    st->has_data = 1;
    for (int i = 0; i < 10; i++) {
      if (strcmp(name, known[i]) == 0) {
        *slots[i] = value;
        found = 1;
      }
    }
    if (!found)
      ch_warn(ps->err, "%s: <%s> (line %d): unknown attribute %s ignored", ps->name,
              (const char *)node->name, (int)xmlGetLineNo(node), name);
  }
  const char *tf = attr(node, "transform");
  if (tf) {
    double m[6];
    char why[160];
    if (parse_transform(tf, m, why, sizeof why)) return fail_node(ps, node, why);
    mat_mul(st->ctm, m, st->ctm);
  }
  return CH_OK;
}

static ch_status attr_number(svg_parser *ps, const char *text, const char *what, double *out) {
  char why[200];
  if (parse_single_number(text, out)) {
    snprintf(why, sizeof why, "%s '%.40s' is not a number", what, text);
    return fail_curve(ps, "%s", why);
  }
  return CH_OK;
}

/* Starts a curve for an element, resolving its attributes. */
static ch_status begin_curve(svg_parser *ps, const xmlNode *node, const svg_style *st) {
  ch_curve_set *set = ps->set;
  ch_status s = grow(ps, (void **)&set->curves, &ps->cap_curves, set->num_curves + 1, sizeof *set->curves);
  if (!s) s = grow(ps, (void **)&ps->fill_rule, &ps->cap_fill_rule, set->num_curves + 1, 1);
  if (s) return s;
  ps->fill_rule[set->num_curves] = CH_FILL_NONE;
  ch_curve *c = &set->curves[set->num_curves++];
  memset(c, 0, sizeof *c);
  ps->curve = c;
  c->element_index = ps->num_elements++;
  c->source_line = (int)xmlGetLineNo(node);
  snprintf(c->element, sizeof c->element, "%s", (const char *)node->name);
  const char *id = attr(node, "id");
  if (id) snprintf(c->id, sizeof c->id, "%s", id);
  c->first_segment = set->num_segments;
  c->first_subpath = set->num_subpaths;
  ps->subpath_open = 0;

  c->kind = CH_CURVE_GROOVE;
  ps->fill_curve = 0;
  /* Drawings without data- attributes mean what they show (docs/spec.md §2). */
  int stroked = paints(st->stroke), filled = paints(st->fill) && strcmp(c->element, "line") != 0;
  double stroke_w = 1.0; /* SVG's initial stroke-width */
  int has_stroke_w = st->stroke_width[0] != '\0';
  if (has_stroke_w && parse_length(st->stroke_width, &stroke_w))
    return fail_curve(ps, "stroke-width '%.40s' is not a length", st->stroke_width);
  if (has_stroke_w && !(stroke_w >= 0.0))
    return fail_curve(ps, "negative stroke-width '%.40s'", st->stroke_width);
  /* A stroke is as wide as drawn: its width in user space scaled by the
   * transforms down to UV (the square root of the area scale). */
  double stroke_uv = stroke_w * sqrt(fabs(st->ctm[0] * st->ctm[3] - st->ctm[1] * st->ctm[2]));
  if (st->has_data) {
    snprintf(c->decided_by, sizeof c->decided_by, "data-attributes");
  } else if (stroked) {
    snprintf(c->decided_by, sizeof c->decided_by, "stroke");
  } else if (filled) {
    snprintf(c->decided_by, sizeof c->decided_by, "fill");
    c->kind = CH_CURVE_STEP;
    c->left = ps->fill_height;
    ps->fill_curve = 1;
    ps->fill_evenodd = keyword_is(st->fill_rule, "evenodd");
    ps->fill_rule[set->num_curves - 1] = ps->fill_evenodd ? CH_FILL_EVENODD : CH_FILL_NONZERO;
  } else {
    snprintf(c->decided_by, sizeof c->decided_by, "default");
  }
  if (st->kind) {
    if (keyword_is(st->kind, "step"))
      c->kind = CH_CURVE_STEP;
    else if (!keyword_is(st->kind, "groove"))
      return fail_curve(ps, "unknown data-kind '%.40s' (expected groove or step)", st->kind);
  }
  char why[200];
  if (ch_profile_parse(st->profile ? st->profile : "v", &c->profile, why, sizeof why))
    return fail_curve(ps, "%s", why);
  double w = 8.0, depth = 0.01, left = c->left, right = 0.0, blur = 0.0, prio = 0.0;
  int width_uv = 0; /* w already in UV (a stroke's) */
  snprintf(c->width_from, sizeof c->width_from, "default");
  if (st->width) {
    if ((s = attr_number(ps, st->width, "data-width", &w))) return s;
    snprintf(c->width_from, sizeof c->width_from, "data-width");
  } else if (has_stroke_w || (!st->has_data && stroked)) {
    w = stroke_uv;
    width_uv = 1;
    snprintf(c->width_from, sizeof c->width_from, has_stroke_w ? "stroke-width" : "stroke");
    if (w == 0.0 && c->kind == CH_CURVE_GROOVE) return fail_curve(ps, "zero stroke-width%s", "");
  }
  if (st->depth && (s = attr_number(ps, st->depth, "data-depth", &depth))) return s;
  if (st->left && (s = attr_number(ps, st->left, "data-left", &left))) return s;
  if (st->right && (s = attr_number(ps, st->right, "data-right", &right))) return s;
  if (st->blur && (s = attr_number(ps, st->blur, "data-blur", &blur))) return s;
  if (st->priority && (s = attr_number(ps, st->priority, "data-priority", &prio))) return s;
  if (w < 0.0) return fail_curve(ps, "negative data-width '%.40s'", st->width);
  if (w == 0.0 && c->kind == CH_CURVE_GROOVE) return fail_curve(ps, "zero data-width%s", "");
  if (blur < 0.0) return fail_curve(ps, "negative data-blur '%.40s'", st->blur);
  if (prio != floor(prio) || fabs(prio) > 1e9)
    return fail_curve(ps, "data-priority '%.40s' is not an integer", st->priority);
  c->width = width_uv ? w : w * ps->width_scale;
  c->depth = depth;
  c->left = left;
  c->right = right;
  c->blur = blur * ps->width_scale;
  c->priority = (int)prio;
  if (st->left_color || st->right_color) {
    c->has_colors = 1;
    if (st->left_color && parse_color(st->left_color, c->left_color))
      return fail_curve(ps, "bad data-left-color '%.40s' (expected #rrggbb)", st->left_color);
    if (st->right_color && parse_color(st->right_color, c->right_color))
      return fail_curve(ps, "bad data-right-color '%.40s' (expected #rrggbb)", st->right_color);
  }
  return CH_OK;
}

/* ---- fills ---- */

/* Painted fills are united as the drawing shows them (ch_fillunion.h);
 * where that fails, one warning says where h_step blends instead. */
static ch_status unite_fills(svg_parser *ps) {
  if (!ps->fill_rule) return CH_OK;
  /* A fill over the whole square (a design tool's frame background, as
   * Figma exports it) raises everything, and the union with it leaves
   * nothing else: say so. */
  for (int c = 0; c < ps->set->num_curves; c++) {
    const ch_curve *cv = &ps->set->curves[c];
    if (ps->fill_rule[c] == CH_FILL_NONE || cv->bbox[0] > 1e-6 || cv->bbox[1] > 1e-6 || cv->bbox[2] < 1.0 - 1e-6 ||
        cv->bbox[3] < 1.0 - 1e-6)
      continue;
    static const double probe[5][2] = {
        {1e-4, 1e-4}, {1 - 1e-4, 1e-4}, {1e-4, 1 - 1e-4}, {1 - 1e-4, 1 - 1e-4}, {0.5, 0.5}};
    int inside = 0;
    for (int k = 0; k < 5; k++) {
      int w = ch_segments_winding(ps->set, cv->first_segment, cv->num_segments, probe[k]);
      inside += ps->fill_rule[c] == CH_FILL_EVENODD ? (w & 1) != 0 : w != 0;
    }
    if (inside < 5) continue;
    char what[160];
    ch_curve_describe(cv, what, sizeof what);
    ch_warn(ps->err,
            "%s: %s is filled over the whole UV square (a background?): every fill is raised, so it raises "
            "everything and the fills on it vanish into it; delete it or set fill='none'",
            ps->name, what);
    break;
  }
  ch_fillunion_report r;
  ch_status st = ch_fillunion_apply(ps->set, ps->fill_rule, ps->flipped, &r, ps->err);
  ps->set->fills_united = r.united, ps->set->fills_dropped = r.dropped;
  if (st || !r.failed) return st;
  char what[160] = "painted fills";
  if (r.curve_a >= 0) ch_curve_describe(&ps->set->curves[r.curve_a], what, sizeof what);
  ch_warn(ps->err,
          "%s: %s near UV (%.4g, %.4g): the painted fills that overlap there could not be united (%s), so h_step "
          "blends between their outlines; unite them in the editor (Inkscape: Path > Union) or give data-left and "
          "data-right",
          ps->name, what, r.at[0], r.at[1],
          r.failed == 2 ? "too many crossings to test" : "their outlines do not close into loops");
  return CH_OK;
}

/* Reverses a subpath in place (segments and their links). */
static void reverse_subpath(ch_curve_set *set, const ch_subpath *sp) {
  ch_segment *s = &set->segments[sp->first_segment];
  int n = sp->num_segments;
  for (int i = 0; i < n / 2; i++) {
    ch_segment t = s[i];
    s[i] = s[n - 1 - i];
    s[n - 1 - i] = t;
  }
  for (int i = 0; i < n; i++) {
    double p0[2] = {s[i].p[0][0], s[i].p[0][1]};
    s[i].p[0][0] = s[i].p[2][0], s[i].p[0][1] = s[i].p[2][1];
    s[i].p[2][0] = p0[0], s[i].p[2][1] = p0[1];
    int first = sp->first_segment;
    s[i].prev = i > 0 ? first + i - 1 : first + n - 1;
    s[i].next = i + 1 < n ? first + i + 1 : first;
  }
}

/* A fill's step curve: every subpath is turned so that the filled side
 * (by the fill rule, tested just beside its longest segment) is on its
 * left, which then holds the fill height (docs/spec.md §2: a filled shape's inside
 * is raised). */
static ch_status orient_fill(svg_parser *ps) {
  ch_curve_set *set = ps->set;
  ch_curve *c = ps->curve;
  int had = ps->cap_flipped;
  ch_status st = grow(ps, (void **)&ps->flipped, &ps->cap_flipped, set->num_subpaths, 1);
  if (st) return st;
  memset(ps->flipped + had, 0, (size_t)(ps->cap_flipped - had));
  double size = fmax(c->bbox[2] - c->bbox[0], c->bbox[3] - c->bbox[1]);
  for (int k = 0; k < c->num_subpaths; k++) {
    const ch_subpath *sp = &set->subpaths[c->first_subpath + k];
    int best = sp->first_segment;
    double best_len = -1.0;
    for (int i = sp->first_segment; i < sp->first_segment + sp->num_segments; i++) {
      const ch_segment *s = &set->segments[i];
      double du = s->p[2][0] - s->p[0][0], dv = s->p[2][1] - s->p[0][1];
      if (du * du + dv * dv > best_len) best_len = du * du + dv * dv, best = i;
    }
    const ch_segment *s = &set->segments[best];
    double m[2], d[2];
    ch_segment_point(s, 0.5, m);
    /* B'(1/2) = p2 - p0 for a quadratic. */
    d[0] = s->p[2][0] - s->p[0][0];
    d[1] = s->p[2][1] - s->p[0][1];
    double len = sqrt(d[0] * d[0] + d[1] * d[1]);
    if (!(len > 0.0)) continue;
    double eps = 1e-7 * fmax(size, 1e-3);
    double q[2] = {m[0] - d[1] / len * eps, m[1] + d[0] / len * eps};
    int w = ch_segments_winding(set, c->first_segment, c->num_segments, q);
    int left_filled = ps->fill_evenodd ? (w & 1) != 0 : w != 0;
    if (!left_filled) {
      reverse_subpath(set, sp);
      ps->flipped[c->first_subpath + k] = 1;
    }
  }
  return CH_OK;
}

static ch_status end_curve(svg_parser *ps) {
  ch_status st = subpath_end(ps);
  if (st) return st;
  ch_curve_set *set = ps->set;
  ch_curve *c = ps->curve;
  if (c->num_segments == 0) return fail_curve(ps, "curve has zero length%s", "");
  if (ps->fill_curve) {
    ch_curve_update_box(set, (int)(c - set->curves));
    if ((st = orient_fill(ps))) return st;
  }
  ch_curve_update_box(set, (int)(c - set->curves));
  const double *b = c->bbox;
  double r = c->kind == CH_CURVE_GROOVE ? 0.5 * c->width : 0.0;
  if (b[2] + r <= 0.0 || b[0] - r >= 1.0 || b[3] + r <= 0.0 || b[1] - r >= 1.0) {
    char what[160];
    ch_curve_describe(c, what, sizeof what);
    ch_warn(ps->err, "%s: %s: lies entirely outside the UV square", ps->name, what);
  }
  ps->curve = NULL;
  return CH_OK;
}

/* Reads the "points" list of polyline/polygon. */
static ch_status shape_points(svg_parser *ps, const xmlNode *node, const svg_style *st, int close) {
  const char *p = attr(node, "points");
  if (!p) return fail_curve(ps, "missing points attribute%s", "");
  geom_ctx g = {.ps = ps, .ctm = st->ctm};
  int n = 0;
  skip_wsp(&p);
  while (*p) {
    double x, y;
    if (scan_number(&p, &x)) return fail_curve(ps, "bad points list near '%.12s'", p);
    skip_sep(&p);
    if (scan_number(&p, &y)) return fail_curve(ps, "points list has an odd number of coordinates%s", "");
    skip_sep(&p);
    ch_status s = n == 0 ? move_to(&g, x, y) : line_to(&g, x, y);
    if (s) return s;
    n++;
  }
  if (n < 2) return fail_curve(ps, "needs at least two points%s", "");
  return close ? close_path(&g) : CH_OK;
}

static ch_status shape_geometry(svg_parser *ps, const xmlNode *node, const svg_style *st) {
  const char *name = (const char *)node->name;
  const char *names[6];
  double v[6] = {0};
  int n = 0;
  if (strcmp(name, "path") == 0) {
    const char *d = attr(node, "d");
    if (!d) return fail_curve(ps, "missing d attribute%s", "");
    return parse_path_data(ps, d, st->ctm);
  }
  if (strcmp(name, "polyline") == 0) return shape_points(ps, node, st, 0);
  if (strcmp(name, "polygon") == 0) return shape_points(ps, node, st, 1);
  if (strcmp(name, "line") == 0) {
    names[0] = "x1", names[1] = "y1", names[2] = "x2", names[3] = "y2", n = 4;
  } else if (strcmp(name, "rect") == 0) {
    names[0] = "x", names[1] = "y", names[2] = "width", names[3] = "height", names[4] = "rx",
    names[5] = "ry", n = 6;
  } else if (strcmp(name, "circle") == 0) {
    names[0] = "cx", names[1] = "cy", names[2] = "r", n = 3;
  } else { /* ellipse */
    names[0] = "cx", names[1] = "cy", names[2] = "rx", names[3] = "ry", n = 4;
  }
  int present[6] = {0};
  for (int i = 0; i < n; i++) {
    const char *text = attr(node, names[i]);
    if (!text) continue;
    present[i] = 1;
    if (parse_length(text, &v[i])) {
      char why[120];
      snprintf(why, sizeof why, "attribute %s='%.30s' is not a length", names[i], text);
      return fail_curve(ps, "%s", why);
    }
  }
  geom_ctx g = {.ps = ps, .ctm = st->ctm};
  ch_status s;
  if (strcmp(name, "line") == 0) {
    if ((s = move_to(&g, v[0], v[1])) || (s = line_to(&g, v[2], v[3]))) return s;
    return CH_OK;
  }
  if (strcmp(name, "rect") == 0) {
    double x = v[0], y = v[1], w = v[2], h = v[3];
    if (w < 0.0 || h < 0.0) return fail_curve(ps, "negative rect size%s", "");
    if (w == 0.0 || h == 0.0) return fail_curve(ps, "curve has zero length (empty rect)%s", "");
    double rx = v[4], ry = v[5];
    if (rx < 0.0 || ry < 0.0) return fail_curve(ps, "negative corner radius%s", "");
    if (present[4] && !present[5]) ry = rx;
    if (present[5] && !present[4]) rx = ry;
    rx = fmin(rx, 0.5 * w);
    ry = fmin(ry, 0.5 * h);
    /* SVG 1.1 §9.2: the rect as a path, clockwise as seen: inside on the right. */
    if ((s = move_to(&g, x + rx, y))) return s;
    if ((s = line_to(&g, x + w - rx, y))) return s;
    if (rx > 0.0 && ry > 0.0 && (s = arc_to(&g, rx, ry, 0, 0, 1, x + w, y + ry))) return s;
    if ((s = line_to(&g, x + w, y + h - ry))) return s;
    if (rx > 0.0 && ry > 0.0 && (s = arc_to(&g, rx, ry, 0, 0, 1, x + w - rx, y + h))) return s;
    if ((s = line_to(&g, x + rx, y + h))) return s;
    if (rx > 0.0 && ry > 0.0 && (s = arc_to(&g, rx, ry, 0, 0, 1, x, y + h - ry))) return s;
    if ((s = line_to(&g, x, y + ry))) return s;
    if (rx > 0.0 && ry > 0.0 && (s = arc_to(&g, rx, ry, 0, 0, 1, x + rx, y))) return s;
    return close_path(&g);
  }
  double cx = v[0], cy = v[1], rx = v[2], ry = strcmp(name, "circle") == 0 ? v[2] : v[3];
  if (rx < 0.0 || ry < 0.0) return fail_curve(ps, "negative radius%s", "");
  if (rx == 0.0 || ry == 0.0) return fail_curve(ps, "curve has zero length (zero radius)%s", "");
  /* Starts at (cx + rx, cy) towards (cx, cy + ry), as SVG 1.1 §9.3-9.4
   * lay out circles and ellipses: clockwise as seen, so in UV (v up, the
   * picture unchanged) the inside is on the right. */
  if ((s = move_to(&g, cx + rx, cy))) return s;
  if ((s = arc_to(&g, rx, ry, 0, 0, 1, cx, cy + ry))) return s;
  if ((s = arc_to(&g, rx, ry, 0, 0, 1, cx - rx, cy))) return s;
  if ((s = arc_to(&g, rx, ry, 0, 0, 1, cx, cy - ry))) return s;
  if ((s = arc_to(&g, rx, ry, 0, 0, 1, cx + rx, cy))) return s;
  return close_path(&g);
}

static void note_ignored(svg_parser *ps, const xmlNode *node) {
  const char *name = (const char *)node->name;
  for (int i = 0; i < ps->num_ignored_kinds; i++) {
    if (strcmp(ps->ignored_name[i], name) == 0) {
      ps->ignored_count[i]++;
      return;
    }
  }
  if (ps->num_ignored_kinds == IGNORED_KINDS) return;
  int i = ps->num_ignored_kinds++;
  snprintf(ps->ignored_name[i], sizeof ps->ignored_name[i], "%s", name);
  ps->ignored_count[i] = 1;
  ps->ignored_line[i] = (int)xmlGetLineNo(node);
}

static int is_svg_element(const xmlNode *node) {
  return node->type == XML_ELEMENT_NODE &&
         (!node->ns || !node->ns->href ||
          strcmp((const char *)node->ns->href, "http://www.w3.org/2000/svg") == 0);
}

/* Reads the rules of every <style> in the document (CSS applies wherever
 * the element stands, in <defs> or not) and lists the elements' ids. */
static ch_status index_document(svg_parser *ps, const xmlNode *node, int depth) {
  for (const xmlNode *n = node; n; n = n->next) {
    if (!is_svg_element(n) || depth > CH_SVG_MAX_DEPTH) continue; /* too deep: walk says so */
    const char *id = attr(n, "id");
    if (id && id[0]) {
      ch_status st = grow(ps, (void **)&ps->ids, &ps->cap_ids, ps->num_ids + 1, sizeof *ps->ids);
      if (st) return st;
      ps->ids[ps->num_ids] = (id_entry){id, n, ps->num_ids};
      ps->num_ids++;
    }
    if (strcmp((const char *)n->name, "style") == 0) {
      const char *type = attr(n, "type");
      if (type && type[0] && !keyword_is(type, "text/css")) continue;
      xmlChar *text = xmlNodeGetContent(n);
      if (!text) continue;
      ch_status st = ch_css_parse(&ps->css, (const char *)text, ps->name, ps->err);
      xmlFree(text);
      if (st) return st;
      continue;
    }
    ch_status st = index_document(ps, n->children, depth + 1);
    if (st) return st;
  }
  return CH_OK;
}

static int cmp_id(const void *x, const void *y) {
  const id_entry *a = x, *b = y;
  int c = strcmp(a->id, b->id);
  return c ? c : (a->order > b->order) - (a->order < b->order);
}

/* The first element in document order with that id, or NULL. */
static const xmlNode *find_id(const svg_parser *ps, const char *id) {
  int lo = 0, hi = ps->num_ids;
  while (lo < hi) {
    int mid = lo + (hi - lo) / 2;
    if (strcmp(ps->ids[mid].id, id) < 0)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo < ps->num_ids && strcmp(ps->ids[lo].id, id) == 0 ? ps->ids[lo].node : NULL;
}

/* A <use>'s reference: href (SVG 2) or xlink:href (SVG 1.1). */
static const char *use_href(const xmlNode *node) {
  const char *h = attr(node, "href");
  if (h) return h;
  for (const xmlAttr *a = node->properties; a; a = a->next)
    if (a->ns && a->ns->href && strcmp((const char *)a->ns->href, "http://www.w3.org/1999/xlink") == 0 &&
        strcmp((const char *)a->name, "href") == 0)
      return a->children && a->children->content ? (const char *)a->children->content : "";
  return NULL;
}

static ch_status walk_node(svg_parser *ps, const xmlNode *n, const svg_style *parent, int depth);
static ch_status walk(svg_parser *ps, const xmlNode *node, const svg_style *parent, int depth);

/* A length attribute of a <use> (x, y, width, height), or def where there
 * is none; percentages are refused. */
static ch_status use_length(svg_parser *ps, const xmlNode *node, const char *name, double def, double *out) {
  const char *v = attr(node, name);
  *out = def;
  if (!v) return CH_OK;
  if (parse_length(v, out)) {
    char why[96];
    snprintf(why, sizeof why, "<use> %s '%.30s' is not a length", name, v);
    return fail_node(ps, node, why);
  }
  return CH_OK;
}

/* <use>: the referenced element drawn as a child of a group at the use,
 * moved by (x, y) (SVG 1.1 §5.6); a <symbol> with a viewBox is fitted
 * into the use's width and height (xMidYMid meet), one without is a
 * group. A reference to nothing is skipped with a warning. */
static ch_status walk_use(svg_parser *ps, const xmlNode *n, const own_props *own, const svg_style *parent, int depth) {
  const char *href = use_href(n);
  const xmlNode *target = href && href[0] == '#' ? find_id(ps, href + 1) : NULL;
  if (!target) {
    note_ignored(ps, n);
    return CH_OK;
  }
  if (ps->use_depth >= CH_SVG_MAX_USE_DEPTH) {
    char msg[96];
    snprintf(msg, sizeof msg, "<use> elements nested deeper than %d levels", CH_SVG_MAX_USE_DEPTH);
    return fail_node(ps, n, msg);
  }
  for (int i = 0; i < ps->use_depth; i++) /* a cycle comes back to a use being drawn */
    if (ps->use_stack[i] == n) return fail_node(ps, n, "<use> refers to itself (a cycle of references)");
  for (const xmlNode *a = n; a; a = a->parent)
    if (a == target) return fail_node(ps, n, "<use> refers to an element that holds it");
  if (++ps->use_count > CH_SVG_MAX_USES) {
    char msg[96];
    snprintf(msg, sizeof msg, "more than %d <use> copies (a reference expansion attack?)", CH_SVG_MAX_USES);
    return fail_node(ps, n, msg);
  }
  svg_style st = *parent;
  ch_status s = inherit(ps, n, own, &st);
  double x, y;
  if (!s) s = use_length(ps, n, "x", 0.0, &x);
  if (!s) s = use_length(ps, n, "y", 0.0, &y);
  if (s) return s;
  double move[6] = {1, 0, 0, 1, x, y};
  mat_mul(st.ctm, move, st.ctm);
  const char *vbs = strcmp((const char *)target->name, "symbol") == 0 ? attr(target, "viewBox") : NULL;
  if (vbs) {
    double vb[4], w, h;
    const char *p = vbs;
    skip_wsp(&p);
    for (int i = 0; i < 4; i++) {
      if (i) skip_sep(&p);
      if (scan_number(&p, &vb[i])) return fail_node(ps, target, "bad viewBox (expected four numbers)");
    }
    if ((s = use_length(ps, n, "width", vb[2], &w)) || (s = use_length(ps, n, "height", vb[3], &h))) return s;
    if (!(vb[2] > 0.0 && vb[3] > 0.0)) return fail_node(ps, target, "viewBox with a zero or negative size");
    double k = fmin(w / vb[2], h / vb[3]);
    double fit[6] = {k, 0, 0, k, 0.5 * (w - k * vb[2]) - k * vb[0], 0.5 * (h - k * vb[3]) - k * vb[1]};
    mat_mul(st.ctm, fit, st.ctm);
  }
  ps->use_stack[ps->use_depth++] = n;
  if (strcmp((const char *)target->name, "symbol") == 0) {
    own_props target_own;
    own_styling(ps, target, &target_own);
    if (!own_hidden(&target_own)) {
      s = inherit(ps, target, &target_own, &st);
      if (!s) s = walk(ps, target->children, &st, depth + 1);
    }
  } else {
    s = walk_node(ps, target, &st, depth + 1);
  }
  ps->use_depth--;
  return s;
}

static ch_status walk_node(svg_parser *ps, const xmlNode *n, const svg_style *parent, int depth) {
  if (!is_svg_element(n)) return CH_OK; /* text, comments, foreign namespaces */
  if (depth > CH_SVG_MAX_DEPTH) {
    char msg[96];
    snprintf(msg, sizeof msg, "elements nested deeper than %d levels", CH_SVG_MAX_DEPTH);
    return fail_node(ps, n, msg);
  }
  const char *name = (const char *)n->name;
  /* Non-rendering and descriptive elements: silently skipped. */
  if (!strcmp(name, "title") || !strcmp(name, "desc") || !strcmp(name, "metadata") || !strcmp(name, "style") ||
      !strcmp(name, "defs") || !strcmp(name, "symbol") || !strcmp(name, "clipPath") || !strcmp(name, "mask") ||
      !strcmp(name, "linearGradient") || !strcmp(name, "radialGradient") || !strcmp(name, "pattern") ||
      !strcmp(name, "marker"))
    return CH_OK;
  own_props own; /* what the element sets itself, read once */
  own_styling(ps, n, &own);
  if (own_hidden(&own)) return CH_OK;
  svg_style st = *parent;
  ch_status s;
  int is_shape = !strcmp(name, "path") || !strcmp(name, "rect") || !strcmp(name, "circle") ||
                 !strcmp(name, "ellipse") || !strcmp(name, "line") || !strcmp(name, "polyline") ||
                 !strcmp(name, "polygon");
  if (!strcmp(name, "g") || !strcmp(name, "a")) {
    if ((s = inherit(ps, n, &own, &st))) return s;
    if ((s = walk(ps, n->children, &st, depth + 1))) return s;
  } else if (is_shape) {
    if ((s = inherit(ps, n, &own, &st))) return s;
    if ((s = begin_curve(ps, n, &st))) return s;
    if ((s = shape_geometry(ps, n, &st))) return s;
    if ((s = end_curve(ps))) return s;
  } else if (!strcmp(name, "use")) {
    if ((s = walk_use(ps, n, &own, parent, depth))) return s;
  } else if (!strcmp(name, "switch")) {
    /* The first direct child whose conditions hold (SVG 1.1 §5.8.2):
     * chisel supports no extension, so a child that requires one (as
     * Illustrator's <foreignObject> of private data does) is passed over;
     * languages and features are taken to hold. */
    if ((s = inherit(ps, n, &own, &st))) return s;
    for (const xmlNode *c = n->children; c; c = c->next) {
      if (!is_svg_element(c)) continue;
      const char *ext = attr(c, "requiredExtensions");
      if ((ext && ext[0]) || !strcmp((const char *)c->name, "foreignObject")) continue;
      if ((s = walk_node(ps, c, &st, depth + 1))) return s;
      break;
    }
  } else {
    note_ignored(ps, n);
  }
  return CH_OK;
}

static ch_status walk(svg_parser *ps, const xmlNode *node, const svg_style *parent, int depth) {
  for (const xmlNode *n = node; n; n = n->next) {
    ch_status s = walk_node(ps, n, parent, depth);
    if (s) return s;
  }
  return CH_OK;
}

/* The root's viewBox (or width/height) gives the user space -> UV map. */
static ch_status root_mapping(svg_parser *ps, const xmlNode *root, svg_style *st) {
  double vb[4];
  const char *vbs = attr(root, "viewBox");
  if (vbs) {
    const char *p = vbs;
    skip_wsp(&p);
    for (int i = 0; i < 4; i++) {
      if (i) skip_sep(&p);
      if (scan_number(&p, &vb[i])) return fail_node(ps, root, "bad viewBox (expected four numbers)");
    }
    skip_wsp(&p);
    if (*p) return fail_node(ps, root, "bad viewBox (expected four numbers)");
    if (!(vb[2] > 0.0) || !(vb[3] > 0.0)) return fail_node(ps, root, "viewBox width and height must be positive");
  } else {
    const char *ws = attr(root, "width"), *hs = attr(root, "height");
    if (!ws || !hs) return fail_node(ps, root, "no viewBox and no width/height: cannot map to UV");
    vb[0] = vb[1] = 0.0;
    if (parse_length(ws, &vb[2]) || parse_length(hs, &vb[3]))
      return fail_node(ps, root, "width/height must be absolute lengths when there is no viewBox");
    if (!(vb[2] > 0.0) || !(vb[3] > 0.0)) return fail_node(ps, root, "width and height must be positive");
  }
  memcpy(ps->set->viewbox, vb, sizeof vb);
  /* u = (x - x0)/w, v = 1 - (y - y0)/h (docs/spec.md §2). */
  double m[6] = {1.0 / vb[2], 0.0, 0.0, -1.0 / vb[3], -vb[0] / vb[2], 1.0 + vb[1] / vb[3]};
  memcpy(st->ctm, m, sizeof m);
  /* Widths are lengths in viewBox units; with a non-square viewBox the
   * geometric mean of the two scales keeps areas right. */
  ps->width_scale = 1.0 / sqrt(vb[2] * vb[3]);
  return CH_OK;
}

/* What the XML parser may do on chisel's behalf: libxml2 runs in its huge
 * mode (no 10 MB cap on a text node, such as the d attribute of a long
 * path), which also switches off its own guard against entity expansion
 * (the "billion laughs"); every entity reference it resolves passes
 * through count_entity, which stops the parse past chisel's caps. Every
 * message libxml2 raises while parsing (including the encoding and I/O
 * ones it would print itself) is caught by keep_error; the first error
 * becomes chisel's one line. */
typedef struct xml_guard {
  xmlParserCtxtPtr ctx;
  xmlEntityPtr (*get_entity)(void *, const xmlChar *); /* libxml2's own */
  long refs;
  size_t bytes;
  int over;            /* 1: too many references, 2: too much text, 3: too deep */
  char message[300];   /* the first error, one line */
  int line;
} xml_guard;

/* Past a cap the parse is stopped, but libxml2 still goes through the
 * rest of the entity text it is expanding, and raises (and formats) an
 * error for every reference it cannot resolve: a predefined entity ("&amp;",
 * plain text) resolves them quietly instead (an entity loop raised ~10^5
 * errors: 0.3 s, seconds per fuzzed input). The file is refused anyway. */
static xmlEntityPtr stopped(xmlParserCtxtPtr ctx, xml_guard *g, int over) {
  if (!g->over) {
    g->over = over;
    xmlStopParser(ctx);
  }
  return xmlGetPredefinedEntity(BAD_CAST "amp");
}

static xmlEntityPtr count_entity(void *user, const xmlChar *name) {
  xmlParserCtxtPtr ctx = user;
  xml_guard *g = ctx->_private;
  if (g->over) return stopped(ctx, g, g->over);
  xmlEntityPtr ent = g->get_entity(user, name);
  /* (undefined ones count too: libxml2 raises an error for each, and
   * entities can repeat them by the hundred thousand) */
  if (++g->refs > CH_SVG_MAX_ENTITY_REFS) return stopped(ctx, g, 1);
  if (!ent) return NULL;
  /* (entities within entities: a file's own are never nested deep) */
  if (ctx->depth > CH_SVG_MAX_ENTITY_DEPTH) return stopped(ctx, g, 3);
  g->bytes += ent->length > 0 ? (size_t)ent->length : 0;
  if (g->bytes > CH_SVG_MAX_ENTITY_BYTES) return stopped(ctx, g, 2);
  return ent;
}

static void keep_error(void *user, xmlErrorPtr e) {
  xml_guard *g = user;
  if (!e || e->level < XML_ERR_ERROR || g->message[0]) return;
  /* libxml2 ends messages with a newline and sometimes has one inside
   * (an encoding error's "Bytes: ..."): one line, separated by "; ". */
  const char *m = e->message ? e->message : "";
  size_t n = strlen(m), k = 0;
  while (n > 0 && (m[n - 1] == '\n' || m[n - 1] == ' ')) n--;
  for (size_t i = 0; i < n && k + 3 < sizeof g->message; i++) {
    if (m[i] != '\n') {
      g->message[k++] = m[i];
    } else {
      g->message[k++] = ';';
      g->message[k++] = ' ';
    }
  }
  g->message[k] = '\0';
  if (!k) snprintf(g->message, sizeof g->message, "not well-formed XML");
  g->line = e->line;
}

static void drop_message(void *user, const char *fmt, ...) {
  (void)user;
  (void)fmt;
}

/* Parses data into a tree under the guard; NULL with the reason in g. */
static xmlDocPtr parse_xml(const char *data, size_t size, const char *name, xml_guard *g) {
  /* libxml2's error handlers are per thread: set for this parse, then
   * restored, so other threads and callers are not affected. */
  xmlStructuredErrorFunc old_structured = xmlStructuredError;
  void *old_structured_user = xmlStructuredErrorContext;
  xmlGenericErrorFunc old_generic = xmlGenericError;
  void *old_generic_user = xmlGenericErrorContext;
  xmlSetStructuredErrorFunc(g, keep_error);
  xmlSetGenericErrorFunc(NULL, drop_message);
  xmlDocPtr doc = NULL;
  g->ctx = xmlNewParserCtxt();
  if (g->ctx) {
    g->ctx->_private = g;
    g->get_entity = g->ctx->sax->getEntity;
    g->ctx->sax->getEntity = count_entity;
    doc = xmlCtxtReadMemory(g->ctx, data, (int)size, name, NULL, XML_PARSE_NONET | XML_PARSE_HUGE);
    if (doc && (g->over || !g->ctx->wellFormed)) {
      xmlFreeDoc(doc);
      doc = NULL;
    }
  }
  xmlSetStructuredErrorFunc(old_structured_user, old_structured);
  xmlSetGenericErrorFunc(old_generic_user, old_generic);
  return doc;
}

ch_status ch_curves_parse_svg(const char *data, size_t size, const char *name, ch_curve_set *out,
                              ch_error *err) {
  return ch_curves_parse_svg_ex(data, size, name, NULL, out, err);
}

ch_status ch_curves_parse_svg_ex(const char *data, size_t size, const char *name, const ch_svg_desc *desc,
                                 ch_curve_set *out, ch_error *err) {
  memset(out, 0, sizeof *out);
  if (size > (size_t)CH_SVG_MAX_BYTES)
    return ch_error_set(err, CH_ERR_INPUT, "%s: file too large for an SVG (%zu bytes, limit %d)", name, size,
                        CH_SVG_MAX_BYTES);
  xml_guard guard = {0};
  xmlDocPtr doc = parse_xml(data, size, name, &guard);
  xmlParserCtxtPtr ctx = guard.ctx;
  if (!ctx) return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory", name);
  if (!doc) {
    ch_status st;
    if (guard.over == 1)
      st = ch_error_set(err, CH_ERR_INPUT, "%s: more than %d entity references (an entity expansion attack?)", name,
                        CH_SVG_MAX_ENTITY_REFS);
    else if (guard.over == 3)
      st = ch_error_set(err, CH_ERR_INPUT, "%s: entities nested deeper than %d levels (an entity expansion attack?)",
                        name, CH_SVG_MAX_ENTITY_DEPTH);
    else if (guard.over == 2)
      st = ch_error_set(err, CH_ERR_INPUT, "%s: entities expand to more than %d bytes (an entity expansion attack?)",
                        name, CH_SVG_MAX_ENTITY_BYTES);
    else if (guard.line > 0)
      st = ch_error_set(err, CH_ERR_INPUT, "%s: line %d: bad XML: %s", name, guard.line,
                        guard.message[0] ? guard.message : "not well-formed XML");
    else /* encoding and I/O errors have no line */
      st = ch_error_set(err, CH_ERR_INPUT, "%s: bad XML: %s", name,
                        guard.message[0] ? guard.message : "not well-formed XML");
    xmlFreeParserCtxt(ctx);
    return st;
  }
  svg_parser ps = {.name = name, .err = err, .set = out};
  ps.fill_height = desc && desc->fill_height != 0.0 ? desc->fill_height : 0.01;
  ch_error local = {0};
  if (!err) ps.err = &local;
  ch_status st = CH_OK;
  const xmlNode *root = xmlDocGetRootElement(doc);
  if (!root || !is_svg_element(root) || strcmp((const char *)root->name, "svg") != 0) {
    st = ch_error_set(ps.err, CH_ERR_INPUT, "%s: not an SVG file (root element is <%s>)", name,
                      root ? (const char *)root->name : "none");
  } else {
    svg_style style = {0};
    st = index_document(&ps, root, 0);
    if (!st && ps.num_ids > 1) qsort(ps.ids, (size_t)ps.num_ids, sizeof *ps.ids, cmp_id);
    if (!st && ps.css.unsupported)
      ch_warn(ps.err,
              "%s: <style>: %d selector%s ignored (first '%s'): chisel reads type, .class and #id selectors and "
              "lists of them",
              name, ps.css.unsupported, ps.css.unsupported > 1 ? "s" : "", ps.css.first_unsupported);
    if (!st) st = root_mapping(&ps, root, &style);
    own_props root_own;
    if (!st) own_styling(&ps, root, &root_own);
    if (!st) st = inherit(&ps, root, &root_own, &style);
    if (!st) st = walk(&ps, root->children, &style, 1);
  }
  if (!st && out->num_curves == 0)
    st = ch_error_set(ps.err, CH_ERR_INPUT, "%s: no curves (no <path> or basic shape elements)", name);
  if (!st) st = unite_fills(&ps);
  free(ps.fill_rule);
  free(ps.flipped);
  ch_css_free(&ps.css);
  free(ps.ids);
  if (!st) {
    for (int i = 0; i < ps.num_ignored_kinds; i++)
      ch_warn(ps.err, "%s: ignored %d <%s> element%s (first on line %d): not a feature curve", name,
              ps.ignored_count[i], ps.ignored_name[i], ps.ignored_count[i] > 1 ? "s" : "",
              ps.ignored_line[i]);
  }
  xmlFreeDoc(doc);
  xmlFreeParserCtxt(ctx);
  if (st) {
    ch_curves_free(out);
    return st;
  }
  return CH_OK;
}

ch_status ch_curves_read_svg(const char *path, ch_curve_set *out, ch_error *err) {
  return ch_curves_read_svg_ex(path, NULL, out, err);
}

ch_status ch_curves_read_svg_ex(const char *path, const ch_svg_desc *desc, ch_curve_set *out, ch_error *err) {
  memset(out, 0, sizeof *out);
  char *data;
  size_t size;
  ch_status st = ch_file_read_all(path, CH_SVG_MAX_BYTES, &data, &size, err);
  if (st) return st;
  st = ch_curves_parse_svg_ex(data, size, path, desc, out, err);
  free(data);
  return st;
}
