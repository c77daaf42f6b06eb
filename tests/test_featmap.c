/* Feature-curve textures (ch_featmap) and the multi-channel distance field
 * (ch_msdf): values a person can verify (straight grooves' distances and
 * normals in closed form, points on a quadratic reconstructed exactly,
 * sides of a circle), the exact normal of h from exact maps (against the
 * study's truth, ch_truth_normal), the transformation table, fallback
 * cells, thread-count independence, the EXR round trip and bad files. */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ch_curves.h"
#include "ch_featmap.h"
#include "ch_file.h"
#include "ch_groove.h"
#include "ch_height.h"
#include "ch_math.h"
#include "ch_msdf.h"
#include "ch_stepsing.h"
#include "ch_test.h"
#include "ch_truth.h"
#include "ch_warp.h"

static int parse(const char *svg, ch_curve_set *set) {
  ch_error err = {0};
  if (ch_curves_parse_svg(svg, strlen(svg), "test.svg", set, &err)) {
    fprintf(stderr, "%s\n", err.message);
    return -1;
  }
  return 0;
}

static double angle_deg(const double a[3], const double b[3]) {
  double d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  return acos(d > 1.0 ? 1.0 : d < -1.0 ? -1.0 : d) * 180.0 / CH_PI;
}

/* The nearest of a set's encoded curves: signed distance, gradient. */
static int nearest(const ch_curve_set *set, const double q[2], double *sd, double grad[2]) {
  double best = INFINITY;
  int curve = -1;
  for (int c = 0; c < set->num_curves; c++) {
    if (!ch_featmap_encodes(set, c)) continue;
    ch_curve_point cp;
    ch_curve_closest(set, c, q, &cp);
    if (cp.distance < best) {
      best = cp.distance, curve = c, *sd = cp.signed_distance;
      if (cp.distance > 1e-12) grad[0] = (q[0] - cp.point[0]) / cp.distance, grad[1] = (q[1] - cp.point[1]) / cp.distance;
    }
  }
  return curve;
}

static void test_table(void) {
  /* every configuration (at most two distinct pairs) and every new pair */
  int configs = 0;
  for (unsigned a = 0; a <= 6; a++)
    for (unsigned b = 0; b <= 6; b++) {
      if ((b && !a) || (b && a == b)) continue;
      configs += !b || a < b; /* as sets */
      unsigned c = a | (b << CH_FM_SEG_BITS);
      for (int p = 1; p <= 6; p++) {
        int what;
        unsigned r = ch_featmap_transform(c, p, &what);
        unsigned ra = r & 7, rb = (r >> 3) & 7;
        CHECK(ra <= 6 && rb <= 6 && !(rb && !ra) && !(rb && ra == rb)); /* valid */
        if (a == (unsigned)p || b == (unsigned)p) CHECK(what == 1 && r == c); /* merged */
        else if (a && b) CHECK(what == 2 && r == c);                         /* dropped */
        else CHECK(what == 0 && (ra == (unsigned)p || rb == (unsigned)p));   /* added */
      }
    }
  CHECK(configs == 22); /* empty, 6 single, 15 pairs */
}

/* A straight v groove: the distance is linear on each side, so the maps
 * give it exactly away from the ends; the normal is (-+2 d / w n, 1). */
static void test_straight(void) {
  const char *svg = "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
                    "<path d='M 10 23.3 L 90 61.7' data-kind='groove' data-profile='v' data-width='6' "
                    "data-depth='0.02'/></svg>";
  ch_curve_set set;
  REQUIRE(parse(svg, &set) == 0);
  double a[2] = {0.10, 1 - 0.233}, b[2] = {0.90, 1 - 0.617};
  double t[2] = {b[0] - a[0], b[1] - a[1]}, tl = hypot(t[0], t[1]);
  t[0] /= tl, t[1] /= tl;
  double nl[2] = {-t[1], t[0]}; /* left normal */
  for (int mode = 0; mode < 2; mode++) {
    ch_featmap m;
    ch_error err = {0};
    ch_featmap_desc d = {.resolution = 32, .linear = mode, .no_normal_map = 1};
    REQUIRE(ch_featmap_build(&set, &d, &m, &err) == CH_OK);
    CHECK(m.stats.cells_one > 0 && m.stats.cells_two == 0);
    double worst_d = 0.0, worst_n = 0.0;
    int wrong = 0, n = 0;
    for (int k = 0; k < 4000; k++) {
      /* along the middle of the groove, within its band */
      double s = 0.1 + 0.8 * ch_test_rnd(), off = (ch_test_rnd() - 0.5) * 0.07;
      double q[2] = {a[0] + s * tl * t[0] + off * nl[0], a[1] + s * tl * t[1] + off * nl[1]};
      ch_featmap_sample fs;
      ch_featmap_eval(&m, mode ? CH_FEATMAP_LINEAR : CH_FEATMAP_FEATNORM, q[0], q[1], &fs);
      double ad = fabs(off);
      worst_d = fmax(worst_d, fabs(fs.distance - ad));
      if (ad > 1e-9) wrong += fs.side != (off > 0 ? 1 : -1);
      /* the exact normal: h = -depth (1 - 2 |s| / w) inside the band */
      double w = 0.06, depth = 0.02, nn[3] = {0, 0, 1};
      if (ad < 0.5 * w) {
        double k2 = 2.0 * depth / w * (off > 0 ? 1 : -1); /* dh/ds */
        nn[0] = -k2 * nl[0], nn[1] = -k2 * nl[1];
        double l = sqrt(nn[0] * nn[0] + nn[1] * nn[1] + 1.0);
        nn[0] /= l, nn[1] /= l, nn[2] = 1.0 / l;
      }
      /* away from the profile's breaks (|s| = 0, w / 2), where the
       * normal jumps and float storage decides the side of the jump */
      if (ad > 1e-5 && fabs(ad - 0.5 * w) > 1e-5) worst_n = fmax(worst_n, angle_deg(fs.normal, nn)), n++;
    }
    CHECK_MSG(worst_d < 2e-6, "mode %d: distance off by %g", mode, worst_d);
    CHECK_MSG(worst_n < 0.01, "mode %d: normal off by %g degrees", mode, worst_n);
    CHECK(wrong == 0);
    CHECK(n > 3000);
    ch_featmap_free(&m);
  }
  ch_curves_free(&set);
}

/* A curved quadratic: the cells' quadratic pieces (tangent lines at the
 * edge points) are the curve's own sub-curves, so points of the curve are
 * at distance 0 from the reconstruction; straight pieces are not. */
static void test_quadratic(void) {
  const char *svg = "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
                    "<path d='M 8 80 Q 50 -10 92 70' data-kind='groove' data-profile='v' data-width='2' "
                    "data-depth='0.01'/></svg>";
  ch_curve_set set;
  REQUIRE(parse(svg, &set) == 0);
  ch_featmap m;
  ch_error err = {0};
  ch_featmap_desc d = {.resolution = 24, .no_fallback = 1, .no_normal_map = 1};
  REQUIRE(ch_featmap_build(&set, &d, &m, &err) == CH_OK);
  CHECK(m.stats.fitted + m.stats.straightened == 0); /* every signature valid as crossed */
  double worst_q = 0.0, worst_l = 0.0;
  for (int k = 0; k < 2000; k++) {
    double p[2];
    ch_segment_point(&set.segments[0], 0.02 + 0.96 * ch_test_rnd(), p);
    ch_featmap_sample a, b;
    ch_featmap_eval(&m, CH_FEATMAP_FEATNORM, p[0], p[1], &a);
    ch_featmap_eval(&m, CH_FEATMAP_LINEAR, p[0], p[1], &b);
    worst_q = fmax(worst_q, a.distance);
    worst_l = fmax(worst_l, b.distance);
  }
  /* pieces within 1e-4 cells of their chord are stored straight */
  CHECK_MSG(worst_q < 1e-4 / 24 + 1e-7, "quadratic pieces miss the curve by %g UV", worst_q);
  CHECK_MSG(worst_l > 1e-4, "straight pieces follow a curved quadratic too well (%g)", worst_l);
  ch_featmap_free(&m);
  ch_curves_free(&set);
}

/* With exact distance, gradient, curve and side, the papers' blend with
 * b stepping at the half width gives the exact normal of h (independently:
 * the study's truth). */
static void test_exact_maps(void) {
  char path[1024];
  snprintf(path, sizeof path, "%s/curves/glyphs.svg", CHISEL_MODELS);
  ch_curve_set set;
  ch_error err = {0};
  REQUIRE(ch_curves_read_svg(path, &set, &err) == CH_OK);
  ch_height h;
  ch_height_desc hd = {.dci_resolution = 64};
  REQUIRE(ch_height_init(&h, &set, &hd, &err) == CH_OK);
  ch_truth *truth;
  ch_truth_desc td = {.grid = 16};
  REQUIRE(ch_truth_create(&h, &td, &truth, &err) == CH_OK);
  double worst = 0.0;
  int n = 0;
  for (int k = 0; k < 3000; k++) {
    double q[2] = {ch_test_rnd(), ch_test_rnd()}, sd = 0, g[2] = {1, 0};
    int c = nearest(&set, q, &sd, g);
    ch_groove_sample gs;
    ch_groove_field_eval(&h.grooves, q[0], q[1], &gs);
    if (gs.active >= 0 && gs.active != c) continue; /* another groove decides h (CSG) */
    const ch_curve *cv = &set.curves[c];
    ch_featmap_curve fc = {cv->kind, cv->profile, cv->width, cv->depth, 0};
    double B[3] = {0, 0, 1}, nf[3], nt[3];
    double d = fabs(sd), half = 0.5 * cv->width;
    if (fabs(d - half) < 1e-9 || d < 1e-9) continue; /* on a break */
    ch_featmap_profile_normal(&fc, sd >= 0 ? 1 : -1, d, g, B, half, half, nf);
    ch_truth_normal(truth, q, nt);
    worst = fmax(worst, angle_deg(nf, nt));
    n++;
  }
  CHECK_MSG(worst < 1e-5, "exact maps give normals %g degrees off", worst);
  CHECK(n > 2500);
  /* b(d) between w0 and w1 blends: the normal lies between the profile's
   * and the base's, and at the ends it is each of them */
  const ch_curve *cv = &set.curves[1];
  ch_featmap_curve fc = {cv->kind, cv->profile, cv->width, cv->depth, 0};
  double g[2] = {1, 0}, B[3] = {0.3, 0, 0.953939}, n0[3], n1[3], nm[3];
  double half = 0.5 * cv->width;
  ch_featmap_profile_normal(&fc, 1, 0.1 * half, g, B, 0.2 * half, 0.8 * half, n0);
  ch_featmap_profile_normal(&fc, 1, 0.9 * half, g, B, 0.2 * half, 0.8 * half, n1);
  ch_featmap_profile_normal(&fc, 1, 0.5 * half, g, B, 0.2 * half, 0.8 * half, nm);
  double Bn[3] = {B[0] / 1.0, B[1], B[2]}, bl = sqrt(Bn[0] * Bn[0] + Bn[2] * Bn[2]);
  Bn[0] /= bl, Bn[2] /= bl;
  CHECK(angle_deg(n1, Bn) < 1e-9);
  CHECK(angle_deg(nm, n0) > 1.0 && angle_deg(nm, Bn) > 1.0);
  CHECK(fabs(angle_deg(n0, nm) + angle_deg(nm, Bn) - angle_deg(n0, Bn)) < 1e-6); /* on the arc between */
  ch_truth_destroy(truth);
  ch_height_free(&h);
  ch_curves_free(&set);
}

/* A step circle: near it the side is that of the exact circle, at any
 * magnification; the bilinear signed distance gets it wrong somewhere. */
static void test_circle_side(void) {
  const char *svg = "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
                    "<circle cx='51.3' cy='48.7' r='17.3' data-kind='step' data-left='0' data-right='0.01'/></svg>";
  ch_curve_set set;
  REQUIRE(parse(svg, &set) == 0);
  ch_featmap m;
  ch_error err = {0};
  ch_featmap_desc d = {.resolution = 16, .no_normal_map = 1};
  REQUIRE(ch_featmap_build(&set, &d, &m, &err) == CH_OK);
  int wrong_fn = 0, wrong_bil = 0, n = 0;
  for (int k = 0; k < 20000; k++) {
    double a = 2 * CH_PI * ch_test_rnd(), r = 0.173 + (ch_test_rnd() - 0.5) * 0.02;
    double q[2] = {0.513 + r * cos(a), 1 - 0.487 + r * sin(a)}, sd = 0, g[2];
    /* a cell's piece may stray from the curve by CH_FEATMAP_TIGHT cells */
    if (fabs(r - 0.173) < CH_FEATMAP_TIGHT / 16.0) continue;
    nearest(&set, q, &sd, g);
    int es = sd >= 0 ? 1 : -1;
    ch_featmap_sample fs, bs;
    ch_featmap_eval(&m, CH_FEATMAP_FEATNORM, q[0], q[1], &fs);
    ch_featmap_eval(&m, CH_FEATMAP_BILINEAR, q[0], q[1], &bs);
    wrong_fn += fs.side != es;
    wrong_bil += bs.side != es;
    n++;
  }
  CHECK_MSG(wrong_fn == 0, "%d of %d points on the wrong side", wrong_fn, n);
  CHECK_MSG(wrong_bil > 20, "bilinear got %d wrong: the test does not test", wrong_bil);
  ch_featmap_free(&m);
  ch_curves_free(&set);
}

/* Three lines through each cell: the configuration drops one; with the
 * fallback those cells are evaluated exactly from their pieces. */
static void test_fallback(void) {
  const char *svg = "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
                    "<g data-kind='groove' data-profile='v' data-width='0.5' data-depth='0.002'>"
                    "<path d='M 10 40 L 90 47'/><path d='M 10 40.7 L 90 47.7'/><path d='M 10 41.4 L 90 48.4'/>"
                    "</g></svg>";
  ch_curve_set set;
  REQUIRE(parse(svg, &set) == 0);
  for (int fb = 0; fb < 2; fb++) {
    ch_featmap m;
    ch_error err = {0};
    ch_featmap_desc d = {.resolution = 32, .no_fallback = !fb, .no_normal_map = 1};
    REQUIRE(ch_featmap_build(&set, &d, &m, &err) == CH_OK);
    CHECK(m.stats.lost_dropped + m.stats.lost_merged > 10);
    CHECK(fb ? m.stats.fallback_cells > 10 : m.stats.fallback_cells == 0);
    double worst = 0.0;
    int wrong = 0;
    for (int k = 0; k < 4000; k++) {
      double u = 0.15 + 0.7 * ch_test_rnd(), v = 1 - (0.40 + 0.07 * (u - 0.1) / 0.8) - 0.015 * ch_test_rnd();
      double q[2] = {u, v}, sd = 0, g[2];
      nearest(&set, q, &sd, g);
      ch_featmap_sample fs;
      ch_featmap_eval(&m, CH_FEATMAP_FEATNORM, u, v, &fs);
      if (fs.kind != 2 && fb) continue;
      worst = fmax(worst, fabs(fs.distance - fabs(sd)));
      wrong += fabs(sd) > 1e-9 && fs.side != (sd >= 0 ? 1 : -1);
    }
    if (fb) {
      CHECK_MSG(worst < 1e-12 && wrong == 0, "fallback cells: distance off by %g, %d wrong sides", worst, wrong);
    } else {
      CHECK_MSG(worst > 1e-3 / 32 && wrong > 0, "without fallback the dropped lines should show (%g, %d)", worst,
                wrong);
    }
    ch_featmap_free(&m);
  }
  ch_curves_free(&set);
}

static int maps_equal(const ch_featmap *a, const ch_featmap *b) {
  size_t n = (size_t)(a->resolution + 1) * (a->resolution + 1);
  return a->resolution == b->resolution && !memcmp(a->dist, b->dist, n * sizeof *a->dist) &&
         !memcmp(a->grad, b->grad, 2 * n * sizeof *a->grad) && !memcmp(a->curve, b->curve, n * sizeof *a->curve) &&
         !memcmp(a->edge, b->edge, 4 * n * sizeof *a->edge) && !memcmp(a->config, b->config, n * sizeof *a->config) &&
         !memcmp(a->seg_curve, b->seg_curve, 2 * n * sizeof *a->seg_curve) &&
         !memcmp(a->base, b->base, 3 * n * sizeof *a->base) && a->fb_list_size == b->fb_list_size &&
         !memcmp(a->fb_list, b->fb_list, (size_t)a->fb_list_size * sizeof *a->fb_list) &&
         a->num_pieces == b->num_pieces && !memcmp(a->pieces, b->pieces, (size_t)a->num_pieces * sizeof *a->pieces) &&
         (!a->normal || !memcmp(a->normal, b->normal, 3 * n * sizeof *a->normal)) &&
         a->num_singular == b->num_singular &&
         (!a->num_singular || !memcmp(a->singular, b->singular, (size_t)a->num_singular * sizeof *a->singular)) &&
         !a->sg_near == !b->sg_near && (!a->sg_near || !memcmp(a->sg_near, b->sg_near, n * sizeof *a->sg_near));
}

/* Ends and crossings of step curves (ch_stepsing): an X of two straight
 * curves at right angles has four arms whose sectors' slopes are the
 * value differences over a quarter turn (written out by hand below); the
 * term's gradient is its value's; near an open end the feature maps with
 * the term added back follow the truth far closer than without, and the
 * table survives the maps file. */
static void test_step_ends(void) {
  /* A runs +u along v = 0.5 (left, above: 0.01; right: 0); B runs -v along
   * u = 0.5 (left, +u: 0.004; right: 0). */
  const char *svg =
      "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
      "<path d='M 10 50 L 90 50' data-kind='step' data-left='0.01' data-right='0'/>"
      "<path d='M 50 10 L 50 90' data-kind='step' data-left='0.004' data-right='0'/></svg>";
  ch_curve_set set;
  REQUIRE(parse(svg, &set) == 0);
  ch_error err = {0};
  ch_stepsing sg;
  const double square[4] = {0, 0, 1, 1};
  REQUIRE(ch_stepsing_find(&set, square, &sg, &err) == CH_OK);
  CHECK(sg.num_points == 5);
  const ch_stepsing_point *x = NULL;
  for (int i = 0; i < sg.num_points; i++)
    if (hypot(sg.points[i].p[0] - 0.5, sg.points[i].p[1] - 0.5) < 1e-12) x = &sg.points[i];
  REQUIRE(x != NULL && x->num_arms == 4);
  /* arms at 0 (A on), pi/2 (B back), pi (A back), 3 pi/2 (B on); sector k
   * from h on arm k's counter-clockwise side to h on arm k+1's clockwise side */
  const double want_angle[4] = {0.0, 0.5 * CH_PI, CH_PI, 1.5 * CH_PI};
  const double want_value[4] = {0.01, 0.0, 0.0, 0.004};
  const double want_slope[4] = {(0.004 - 0.01) / (0.5 * CH_PI), 0.01 / (0.5 * CH_PI), 0.0,
                                (0.0 - 0.004) / (0.5 * CH_PI)};
  for (int k = 0; k < 4; k++) {
    double da = fabs(x->angle[k] - want_angle[k]);
    CHECK_MSG(fmin(da, 2 * CH_PI - da) < 1e-9 && fabs(x->value[k] - want_value[k]) < 1e-15 &&
                  fabs(x->slope[k] - want_slope[k]) < 1e-12,
              "arm %d: angle %g value %g slope %g", k, x->angle[k], x->value[k], x->slope[k]);
  }
  /* an end: one arm, a whole turn from left to right */
  for (int i = 0; i < sg.num_points; i++) {
    const ch_stepsing_point *pt = &sg.points[i];
    if (pt == x) continue;
    CHECK(pt->num_arms == 1 && fabs(fabs(pt->slope[0]) * 2 * CH_PI - (pt->p[1] == 0.5 ? 0.01 : 0.004)) < 1e-12);
  }
  /* the gradient is the value's, off the arms */
  for (int k = 0; k < 200; k++) {
    double a = 2 * CH_PI * ch_test_rnd(), r = 0.001 + 0.02 * ch_test_rnd(), e = 1e-7 * r;
    if (fabs(remainder(a, 0.5 * CH_PI)) < 0.01) continue;
    double q[2] = {0.5 + r * cos(a), 0.5 + r * sin(a)}, g[2], fd[2];
    ch_stepsing_term(x, q, g);
    for (int ax = 0; ax < 2; ax++) {
      double p[2] = {q[0], q[1]}, m[2] = {q[0], q[1]};
      p[ax] += e, m[ax] -= e;
      fd[ax] = (ch_stepsing_term(x, p, NULL) - ch_stepsing_term(x, m, NULL)) / (2 * e);
    }
    CHECK(fabs(g[0] - fd[0]) + fabs(g[1] - fd[1]) < 1e-6 * (1.0 + hypot(g[0], g[1])));
  }
  ch_stepsing_free(&sg);
  ch_curves_free(&set);
  /* ends on the border of the square: the zero-flux border, no term */
  const char *across =
      "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
      "<path d='M 0 28 L 100 22' data-kind='step' data-left='0.01' data-right='0'/></svg>";
  REQUIRE(parse(across, &set) == 0);
  REQUIRE(ch_stepsing_find(&set, square, &sg, &err) == CH_OK);
  CHECK(sg.num_points == 0);
  ch_stepsing_free(&sg);
  ch_curves_free(&set);

  /* near an open end, against the truth */
  const char *end =
      "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
      "<path d='M 20.2 50.3 L 60.7 43.9' data-kind='step' data-left='0.01' data-right='0'/></svg>";
  REQUIRE(parse(end, &set) == 0);
  ch_height h;
  ch_height_desc hd = {.dci_resolution = 1024, .step_method = CH_RECON_EXACT};
  REQUIRE(ch_height_init(&h, &set, &hd, &err) == CH_OK);
  ch_truth *truth;
  ch_truth_desc td = {.grid = 16};
  REQUIRE(ch_truth_create(&h, &td, &truth, &err) == CH_OK);
  const int R = 32;
  ch_featmap with, without, back;
  ch_featmap_desc d = {.resolution = R, .height = &h, .no_normal_map = 1};
  REQUIRE(ch_featmap_build(&set, &d, &with, &err) == CH_OK);
  d.no_singular = 1;
  REQUIRE(ch_featmap_build(&set, &d, &without, &err) == CH_OK);
  CHECK(with.num_singular == 2 && without.num_singular == 0 && !without.sg_near);
  double sum_with = 0, sum_without = 0;
  int n = 0;
  for (int e = 0; e < 2; e++) {
    double c[2] = {e ? 0.607 : 0.202, e ? 1 - 0.439 : 1 - 0.503};
    for (int k = 0; k < 2000; k++) {
      double a = 2 * CH_PI * ch_test_rnd(), r = (0.2 + 2.3 * ch_test_rnd()) / R;
      double q[2] = {c[0] + r * cos(a), c[1] + r * sin(a)}, tn[3];
      ch_truth_normal(truth, q, tn);
      ch_featmap_sample fw, fo;
      ch_featmap_eval(&with, CH_FEATMAP_FEATNORM, q[0], q[1], &fw);
      ch_featmap_eval(&without, CH_FEATMAP_FEATNORM, q[0], q[1], &fo);
      sum_with += angle_deg(fw.normal, tn);
      sum_without += angle_deg(fo.normal, tn);
      n++;
    }
  }
  fprintf(stderr, "  within 2.5 cells of a step end at R %d: normal error %.4f deg with the term, %.4f without\n", R,
          sum_with / n, sum_without / n);
  CHECK_MSG(sum_with < 0.25 * sum_without, "mean normal error near the ends %.4f deg with the term, %.4f without",
            sum_with / n, sum_without / n);
  /* each end's window: R1 cells or half way to the other end */
  double apart = hypot(with.singular[0].p[0] - with.singular[1].p[0], with.singular[0].p[1] - with.singular[1].p[1]);
  for (int i = 0; i < with.num_singular; i++)
    CHECK(fabs(with.singular[i].radius - fmin(CH_FEATMAP_SINGULAR_R1 / R, 0.5 * apart)) < 1e-12);
  /* the table and its index through the maps file */
  const char *tmp = getenv("TMPDIR");
  char file[1200];
  snprintf(file, sizeof file, "%s/test_featmap_ends.exr", tmp ? tmp : "/tmp");
  REQUIRE(ch_featmap_write_exr(file, &with, NULL, NULL, 0, &err) == CH_OK);
  REQUIRE(ch_featmap_read_exr(file, &back, NULL, &err) == CH_OK);
  CHECK(maps_equal(&with, &back));
  CHECK(with.sg_window == CH_FEATMAP_SINGULAR_R1 && back.sg_window == with.sg_window);
  for (int k = 0; k < 500; k++) {
    double u = 0.15 + 0.5 * ch_test_rnd(), v = 0.45 + 0.15 * ch_test_rnd();
    ch_featmap_sample x1, y1;
    ch_featmap_eval(&with, CH_FEATMAP_FEATNORM, u, v, &x1);
    ch_featmap_eval(&back, CH_FEATMAP_FEATNORM, u, v, &y1);
    CHECK(!memcmp(x1.normal, y1.normal, sizeof x1.normal));
  }
  remove(file);
  ch_featmap_free(&with);
  ch_featmap_free(&without);
  ch_featmap_free(&back);
  ch_truth_destroy(truth);
  ch_height_free(&h);
  ch_curves_free(&set);

  /* A dash a third of a cell long: its two ends' windows stop half way
   * between them, so crossing the line half way between them (where the
   * nearest end changes), beside the dash, the base normal has no seam. */
  const char *dash =
      "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
      "<path d='M 49.7 50.3 L 50.74 50.3' data-kind='step' data-left='0.01' data-right='0'/></svg>";
  REQUIRE(parse(dash, &set) == 0);
  REQUIRE(ch_height_init(&h, &set, &hd, &err) == CH_OK);
  ch_featmap_desc dd = {.resolution = R, .height = &h, .no_normal_map = 1};
  REQUIRE(ch_featmap_build(&set, &dd, &with, &err) == CH_OK);
  REQUIRE(with.num_singular == 2);
  for (int i = 0; i < 2; i++) CHECK(fabs(with.singular[i].radius - 0.5 * 0.0104) < 1e-9);
  double worst_step = 0.0, prev[3] = {0, 0, 0};
  for (int k = 0; k <= 2000; k++) {
    double u = 0.5022 + 0.004 * (k / 2000.0 - 0.5), v = 1 - 0.503 + 0.003; /* a tenth of a cell above it */
    ch_featmap_sample fs;
    ch_featmap_eval(&with, CH_FEATMAP_FEATNORM, u, v, &fs);
    double bl = sqrt(fs.base[0] * fs.base[0] + fs.base[1] * fs.base[1] + fs.base[2] * fs.base[2]);
    double b[3] = {fs.base[0] / bl, fs.base[1] / bl, fs.base[2] / bl};
    if (k > 0) worst_step = fmax(worst_step, angle_deg(b, prev));
    memcpy(prev, b, sizeof prev);
  }
  CHECK_MSG(worst_step < 0.5, "base normal jumps by %.3f deg between neighbours 2e-6 apart", worst_step);
  ch_featmap_free(&with);
  ch_height_free(&h);
  ch_curves_free(&set);
}

/* Regions one step curve alone bounds, with one value all round, are
 * flat (docs/spec.md §3): a slab a third of a cell thick (drawn clockwise:
 * its inside is on the right) and a ring of two circles; an open curve
 * never is. Inside the slab, where no lattice point lies, featnorm's base
 * is exactly flat, and the flat sides survive the maps file. */
static void test_flat_regions(void) {
  const char *svg =
      "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
      "<rect x='20.3' y='40.2' width='40' height='1.04' data-kind='step' data-left='0' data-right='0.01'/>"
      "<path d='M 30 60 A 10 10 0 1 0 50 60 A 10 10 0 1 0 30 60 Z M 29.5 60 A 10.5 10.5 0 1 1 50.5 60 "
      "A 10.5 10.5 0 1 1 29.5 60 Z' data-kind='step' data-left='0.01' data-right='0'/>"
      "<path d='M 20 20 L 70 25' data-kind='step' data-left='0.01' data-right='0'/></svg>";
  ch_curve_set set;
  REQUIRE(parse(svg, &set) == 0);
  REQUIRE(set.num_curves == 3);
  CHECK(ch_stepsing_flat_side(&set, 0) == -1);
  CHECK(ch_stepsing_flat_side(&set, 1) == -1); /* the band between the circles: 0 on both */
  CHECK(ch_stepsing_flat_side(&set, 2) == 0);
  int sides[3] = {9, 9, 9};
  ch_error err = {0};
  REQUIRE(ch_stepsing_flat_sides(&set, sides, &err) == CH_OK); /* (every curve at once, by grid) */
  CHECK(sides[0] == -1 && sides[1] == -1 && sides[2] == 0);
  {
    /* a circle whose box meets the slab's: neither is known flat, by
     * the grid as by the scan */
    const char *two =
        "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
        "<rect x='20.3' y='40.2' width='40' height='1.04' data-kind='step' data-left='0' data-right='0.01'/>"
        "<circle cx='70' cy='40.5' r='12' data-kind='step' data-left='0.02' data-right='0'/></svg>";
    ch_curve_set t;
    REQUIRE(parse(two, &t) == 0);
    int got[2] = {9, 9};
    REQUIRE(ch_stepsing_flat_sides(&t, got, &err) == CH_OK);
    CHECK_MSG(
        got[0] == ch_stepsing_flat_side(&t, 0) && got[1] == ch_stepsing_flat_side(&t, 1) && got[0] == 0 && got[1] == 0,
        "sides %d %d", got[0], got[1]);
    ch_curves_free(&t);
  }
  ch_height h;
  ch_height_desc hd = {.dci_resolution = 512, .step_method = CH_RECON_EXACT};
  REQUIRE(ch_height_init(&h, &set, &hd, &err) == CH_OK);
  ch_featmap m, back;
  ch_featmap_desc d = {.resolution = 32, .height = &h, .no_normal_map = 1};
  REQUIRE(ch_featmap_build(&set, &d, &m, &err) == CH_OK);
  CHECK(m.has_base && m.curves[0].flat_side == -1 && m.curves[1].flat_side == -1 && m.curves[2].flat_side == 0);
  int flat = 0, n = 0;
  for (int k = 0; k < 400; k++) { /* inside the slab, away from its ends */
    double u = 0.22 + 0.36 * ch_test_rnd(), v = 1 - (0.402 + 0.0104 * (0.1 + 0.8 * ch_test_rnd()));
    ch_featmap_sample fs;
    ch_featmap_eval(&m, CH_FEATMAP_FEATNORM, u, v, &fs);
    flat += fs.curve == 0 && fs.side == -1 && fs.base[0] == 0.0 && fs.base[1] == 0.0 && fs.base[2] == 1.0;
    n++;
  }
  CHECK_MSG(flat == n, "%d of %d points inside the slab flat", flat, n);
  /* Inside the disc the ring bounds, h_step is one value too; a cell
   * across the ring (a sixth of a cell thick) has corners outside it on
   * the same side of the same curve, where h_step slopes: those the ring
   * separates from the point must not tilt it. */
  double worst = 0.0, outside = 0.0;
  for (int k = 0; k < 400; k++) {
    double a = 2 * CH_PI * ch_test_rnd(), r = 0.1 - 0.5 / 32 * ch_test_rnd();
    ch_featmap_sample fs;
    ch_featmap_eval(&m, CH_FEATMAP_FEATNORM, 0.4 + r * cos(a), 0.4 + r * sin(a), &fs);
    worst = fmax(worst, acos(fmin(1.0, fs.base[2] / sqrt(fs.base[0] * fs.base[0] + fs.base[1] * fs.base[1] +
                                                         fs.base[2] * fs.base[2]))) *
                            180 / CH_PI);
    ch_featmap_eval(&m, CH_FEATMAP_FEATNORM, 0.4 + (0.105 + 0.5 / 32) * cos(a), 0.4 + (0.105 + 0.5 / 32) * sin(a), &fs);
    outside = fmax(outside, acos(fmin(1.0, fs.base[2] / sqrt(fs.base[0] * fs.base[0] + fs.base[1] * fs.base[1] +
                                                             fs.base[2] * fs.base[2]))) *
                                180 / CH_PI);
  }
  CHECK_MSG(worst < 0.02 && outside > 0.2, "base inside the ring tilts by up to %.4f deg (outside %.3f)", worst,
            outside);
  const char *tmp = getenv("TMPDIR");
  char file[1200];
  snprintf(file, sizeof file, "%s/test_featmap_flat.exr", tmp ? tmp : "/tmp");
  REQUIRE(ch_featmap_write_exr(file, &m, NULL, NULL, 0, &err) == CH_OK);
  REQUIRE(ch_featmap_read_exr(file, &back, NULL, &err) == CH_OK);
  CHECK(maps_equal(&m, &back));
  for (int c = 0; c < 3; c++) CHECK(back.curves[c].flat_side == m.curves[c].flat_side);
  remove(file);
  ch_featmap_free(&m);
  ch_featmap_free(&back);
  ch_height_free(&h);
  ch_curves_free(&set);
}

/* One and three smoothing steps against the papers' Jacobi step written out
 * here from the unsmoothed gradients: samples beyond their curve's band
 * (half width plus 1.5 cells) and within 8 cells of it move half-way to
 * the mean of the neighbours no edge point separates from them and are
 * renormalised; every other sample keeps its exact gradient. Also on 1
 * and 2 threads alike. */
static void test_smoothing(void) {
  char path[1024];
  snprintf(path, sizeof path, "%s/curves/glyphs.svg", CHISEL_MODELS);
  ch_curve_set set;
  ch_error err = {0};
  REQUIRE(ch_curves_read_svg(path, &set, &err) == CH_OK);
  const int R = 80, R1 = R + 1;
  const size_t n = (size_t)R1 * R1;
  ch_featmap raw, one, three, three2;
  ch_featmap_desc d = {.resolution = R, .no_normal_map = 1, .no_fallback = 1, .smoothing = -1};
  REQUIRE(ch_featmap_build(&set, &d, &raw, &err) == CH_OK);
  d.smoothing = 1;
  REQUIRE(ch_featmap_build(&set, &d, &one, &err) == CH_OK);
  d.smoothing = 3;
  omp_set_num_threads(1);
  REQUIRE(ch_featmap_build(&set, &d, &three, &err) == CH_OK);
  omp_set_num_threads(2);
  REQUIRE(ch_featmap_build(&set, &d, &three2, &err) == CH_OK);
  CHECK(!memcmp(three.grad, three2.grad, 2 * n * sizeof *three.grad));
  float *g = malloc(2 * n * sizeof *g), *next = malloc(2 * n * sizeof *next);
  REQUIRE(g && next);
  memcpy(g, raw.grad, 2 * n * sizeof *g);
  double texel = 1.0 / R, worst1 = 0.0, worst3 = 0.0;
  long moved = 0;
  for (int step = 1; step <= 3; step++) {
    memcpy(next, g, 2 * n * sizeof *g);
    for (int y = 0; y < R1; y++)
      for (int x = 0; x < R1; x++) {
        size_t k = (size_t)y * R1 + x;
        const ch_featmap_curve *c = &raw.curves[raw.curve[k]];
        double band = (c->kind == CH_CURVE_GROOVE ? 0.5 * c->width : 0.0) + 1.5 * texel, dk = fabs(raw.dist[k]);
        if (!(dk > band && dk <= band + 8.0 * texel)) continue;
        double sx = 0.0, sy = 0.0;
        int cnt = 0;
        if (x + 1 < R1 && !(raw.config[k] & CH_FM_POINT_S)) sx += g[2 * (k + 1)], sy += g[2 * (k + 1) + 1], cnt++;
        if (x > 0 && !(raw.config[k - 1] & CH_FM_POINT_S)) sx += g[2 * (k - 1)], sy += g[2 * (k - 1) + 1], cnt++;
        if (y + 1 < R1 && !(raw.config[k] & CH_FM_POINT_W)) sx += g[2 * (k + R1)], sy += g[2 * (k + R1) + 1], cnt++;
        if (y > 0 && !(raw.config[k - R1] & CH_FM_POINT_W)) sx += g[2 * (k - R1)], sy += g[2 * (k - R1) + 1], cnt++;
        double gx = g[2 * k], gy = g[2 * k + 1];
        if (cnt) gx += 0.5 * (sx / cnt - gx), gy += 0.5 * (sy / cnt - gy);
        double l = hypot(gx, gy);
        if (l > 1e-12) next[2 * k] = (float)(gx / l), next[2 * k + 1] = (float)(gy / l);
        moved += step == 1 && (next[2 * k] != g[2 * k] || next[2 * k + 1] != g[2 * k + 1]);
      }
    memcpy(g, next, 2 * n * sizeof *g);
    const float *built = step == 1 ? one.grad : three.grad;
    if (step == 2) continue;
    double worst = 0.0;
    for (size_t k = 0; k < 2 * n; k++) worst = fmax(worst, fabs((double)built[k] - g[k]));
    if (step == 1) worst1 = worst;
    else worst3 = worst;
  }
  CHECK(moved > 100);        /* the ring is there and the step moves it */
  CHECK(worst1 < 1e-6 && worst3 < 1e-6);
  CHECK(!memcmp(raw.dist, three.dist, n * sizeof *raw.dist)); /* the distance is left alone */
  free(g);
  free(next);
  ch_featmap_free(&raw);
  ch_featmap_free(&one);
  ch_featmap_free(&three);
  ch_featmap_free(&three2);
  ch_curves_free(&set);
}

/* Same maps on 1 and 2 threads; the EXR round trip gives them back. */
static void test_threads_and_file(void) {
  char path[1024];
  snprintf(path, sizeof path, "%s/curves/ornament.svg", CHISEL_MODELS);
  ch_curve_set set;
  ch_error err = {0};
  REQUIRE(ch_curves_read_svg(path, &set, &err) == CH_OK);
  ch_featmap a, b, c;
  ch_msdf ma, mb, mc;
  ch_featmap_desc d = {.resolution = 96, .normal_supersample = 1};
  ch_msdf_desc md = {.resolution = 96};
  omp_set_num_threads(1);
  REQUIRE(ch_featmap_build(&set, &d, &a, &err) == CH_OK && ch_msdf_build(&set, &md, &ma, &err) == CH_OK);
  omp_set_num_threads(2);
  REQUIRE(ch_featmap_build(&set, &d, &b, &err) == CH_OK && ch_msdf_build(&set, &md, &mb, &err) == CH_OK);
  CHECK(maps_equal(&a, &b));
  size_t n = 97 * 97;
  CHECK(!memcmp(ma.channels, mb.channels, 3 * n * sizeof *ma.channels));
  CHECK(a.stats.fallback_cells > 0 && a.stats.lost_csg > 0); /* the rosette's grooves overlap */
  const char *tmp = getenv("TMPDIR");
  char file[1200];
  snprintf(file, sizeof file, "%s/test_featmap.exr", tmp ? tmp : "/tmp");
  REQUIRE(ch_featmap_write_exr(file, &a, &ma, NULL, 0, &err) == CH_OK);
  REQUIRE(ch_featmap_read_exr(file, &c, &mc, &err) == CH_OK);
  CHECK(maps_equal(&a, &c));
  CHECK(!memcmp(ma.channels, mc.channels, 3 * n * sizeof *ma.channels) && mc.range == ma.range);
  for (int k = 0; k < 2000; k++) {
    double u = ch_test_rnd(), v = ch_test_rnd();
    for (int meth = 0; meth < 3; meth++) {
      ch_featmap_sample x, y;
      ch_featmap_eval(&a, (ch_featmap_method)meth, u, v, &x);
      ch_featmap_eval(&c, (ch_featmap_method)meth, u, v, &y);
      CHECK(!memcmp(x.normal, y.normal, sizeof x.normal) && x.side == y.side && x.distance == y.distance);
    }
  }
  /* Damaged files: every prefix is an error, never a crash. */
  char *data;
  size_t size;
  REQUIRE(ch_file_read_all(file, 1 << 28, &data, &size, &err) == CH_OK);
  int errors = 0, tried = 0;
  for (size_t len = 0; len < size; len += 1 + size / 97) {
    ch_featmap t;
    ch_msdf tm;
    ch_error e = {0};
    tried++;
    errors += ch_featmap_read_exr_memory(data, len, "cut.exr", &t, &tm, &e) == CH_ERR_INPUT;
  }
  CHECK(errors == tried);
  /* A table claiming more curves (or pieces) than its text can hold is
   * refused before it is allocated (2^24 curves would be 17 GB). */
  static const char *const tables[2] = {"chisel:featmap-curves", "chisel:featmap-pieces"};
  for (int t = 0; t < 2; t++) {
    size_t key = strlen(tables[t]) + 1;
    char *at = NULL;
    for (size_t k = 0; !at && k + key <= size; k++)
      if (!memcmp(data + k, tables[t], key)) at = data + k;
    REQUIRE(at != NULL);
    char *value = at + strlen(tables[t]) + 1 + strlen("string") + 1 + 4;
    int32_t len;
    memcpy(&len, value - 4, 4);
    REQUIRE(len >= 8 && value + len <= data + size);
    char *saved = malloc((size_t)len);
    REQUIRE(saved != NULL);
    memcpy(saved, value, (size_t)len);
    memset(value, ' ', (size_t)len);
    memcpy(value, "16777216", 8);
    ch_featmap t2;
    ch_msdf tm;
    ch_error e = {0};
    CHECK(ch_featmap_read_exr_memory(data, size, "big.exr", &t2, &tm, &e) == CH_ERR_INPUT &&
          strstr(e.message, "(count)"));
    memcpy(value, saved, (size_t)len);
    free(saved);
  }
  free(data);
  ch_featmap_free(&a);
  ch_featmap_free(&b);
  ch_featmap_free(&c);
  ch_msdf_free(&ma);
  ch_msdf_free(&mb);
  ch_msdf_free(&mc);
  ch_curves_free(&set);
  /* A file of another command. */
  ch_image img;
  REQUIRE(ch_image_init(&img, 9, 9, 1, (const char *[]){"h"}, &err) == CH_OK);
  ch_exr_attribute at[] = {{"chisel:command", "dci"}};
  ch_exr_write_desc wd = {.attributes = at, .num_attributes = 1};
  REQUIRE(ch_exr_write(file, &img, &wd, &err) == CH_OK);
  ch_error e = {0};
  CHECK(ch_featmap_read_exr(file, &c, NULL, &e) == CH_ERR_INPUT && strstr(e.message, "not a feature map"));
  ch_image_free(&img);
  remove(file);
}

/* The msdf keeps a square's corners sharp where one distance cannot. */
static void test_msdf(void) {
  const char *svg = "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
                    "<path d='M 20.3 20.6 L 79.1 20.6 L 79.1 79.4 L 20.3 79.4 Z' data-kind='step' data-left='0' "
                    "data-right='0.01'/></svg>";
  ch_curve_set set;
  REQUIRE(parse(svg, &set) == 0);
  ch_msdf m;
  ch_featmap f;
  ch_error err = {0};
  ch_msdf_desc md = {.resolution = 12};
  ch_featmap_desc fd = {.resolution = 12, .no_normal_map = 1};
  REQUIRE(ch_msdf_build(&set, &md, &m, &err) == CH_OK && ch_featmap_build(&set, &fd, &f, &err) == CH_OK);
  CHECK(m.stats.corners == 4 && m.stats.edges == 4);
  int wrong_m = 0, wrong_b = 0, wrong_f = 0;
  static const double cx[4] = {0.203, 0.791, 0.791, 0.203}, cy[4] = {0.794, 0.794, 0.206, 0.206};
  for (int k = 0; k < 8000; k++) {
    int c = k % 4;
    double q[2] = {cx[c] + (ch_test_rnd() - 0.5) * 0.08, cy[c] + (ch_test_rnd() - 0.5) * 0.08}, sd = 0, g[2];
    nearest(&set, q, &sd, g);
    if (fabs(sd) < 1e-9) continue;
    int es = sd >= 0 ? 1 : -1;
    ch_featmap_sample a, b, x;
    ch_msdf_eval(&m, q[0], q[1], &a);
    ch_featmap_eval(&f, CH_FEATMAP_BILINEAR, q[0], q[1], &b);
    ch_featmap_eval(&f, CH_FEATMAP_FEATNORM, q[0], q[1], &x);
    wrong_m += a.side != es;
    wrong_b += b.side != es;
    wrong_f += x.side != es;
  }
  CHECK_MSG(wrong_m * 4 < wrong_b, "msdf %d wrong, one distance %d: corners not kept", wrong_m, wrong_b);
  CHECK_MSG(wrong_f == 0, "feature maps: %d wrong near corners", wrong_f);
  ch_msdf_free(&m);
  ch_featmap_free(&f);
  ch_curves_free(&set);
}

/* Under a view-dependent warp the cells where the camera looks are
 * smaller in UV: there the same R gives the maps more detail. A plane
 * cage (16 x 16 quads, jittered), a camera 0.3 above (0.2, 0.2) looking
 * down (test_warp's close camera), a groove circle and a line in view. */
static void test_warped(void) {
  enum { N = 16 };
  double *uvs = malloc(2 * N * N * 6 * sizeof *uvs), *pos = malloc(2 * N * N * 9 * sizeof *pos);
  int t = 0;
  for (int j = 0; j < N; j++)
    for (int i = 0; i < N; i++) {
      double c[4][2] = {{(double)i / N, (double)j / N}, {(i + 1.0) / N, (double)j / N},
                        {(i + 1.0) / N, (j + 1.0) / N}, {(double)i / N, (j + 1.0) / N}};
      static const int tri[2][3] = {{0, 1, 2}, {0, 2, 3}};
      for (int k = 0; k < 2; k++, t++)
        for (int m = 0; m < 3; m++) {
          uvs[6 * t + 2 * m] = c[tri[k][m]][0], uvs[6 * t + 2 * m + 1] = c[tri[k][m]][1];
          pos[9 * t + 3 * m] = c[tri[k][m]][0], pos[9 * t + 3 * m + 1] = c[tri[k][m]][1], pos[9 * t + 3 * m + 2] = 0;
        }
    }
  ch_warp_cage cage = {2 * N * N, uvs, pos};
  const char *svg = "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
                    "<g data-kind='groove' data-profile='u' data-width='1.2' data-depth='0.004'>"
                    "<circle cx='20.3' cy='79.6' r='5.7'/><path d='M 10.2 91 L 30.5 70.1'/></g></svg>";
  ch_curve_set set;
  REQUIRE(parse(svg, &set) == 0);
  ch_camera cam;
  ch_error err = {0};
  const double v[7] = {0.2, 0.2, 0.3, 0.2, 0.2, 0.0, 40.0};
  REQUIRE(ch_camera_init(&cam, v, &err) == CH_OK);
  ch_warp w;
  REQUIRE(ch_warp_build(&cam, &cage, &set, NULL, &w, &err) == CH_OK);
  CHECK(w.stats.max_slope[0] > 2.0 && w.stats.max_slope[1] > 2.0);
  ch_featmap plain, warped;
  ch_featmap_desc d = {.resolution = 48, .no_normal_map = 1}, dw = d;
  dw.warp = &w;
  REQUIRE(ch_featmap_build(&set, &d, &plain, &err) == CH_OK);
  REQUIRE(ch_featmap_build(&set, &dw, &warped, &err) == CH_OK);
  /* The papers' representation alone (no exact pieces: at R 48 most cells
   * along these tight curves fall back, exact with or without the warp) is
   * what more texels in view improve. */
  ch_featmap plain_nf, warped_nf;
  ch_featmap_desc dn = d, dwn = dw;
  dn.no_fallback = dwn.no_fallback = 1;
  REQUIRE(ch_featmap_build(&set, &dn, &plain_nf, &err) == CH_OK);
  REQUIRE(ch_featmap_build(&set, &dwn, &warped_nf, &err) == CH_OK);
  CHECK(warped.stats.cells_one > 2 * plain.stats.cells_one); /* the curves cross more cells */
  double e_plain = 0.0, e_warp = 0.0, e_full[2] = {0.0, 0.0}, worst_d = 0.0;
  int n = 0, wrong = 0;
  for (int k = 0; k < 6000; k++) {
    double q[2] = {0.12 + 0.16 * ch_test_rnd(), 0.12 + 0.16 * ch_test_rnd()}, sd = 0, g[2] = {1, 0};
    int c = nearest(&set, q, &sd, g);
    const ch_curve *cv = &set.curves[c];
    if (fabs(sd) > 0.6 * cv->width) continue;
    ch_featmap_curve fc = {cv->kind, cv->profile, cv->width, cv->depth, 0};
    double B[3] = {0, 0, 1}, ne[3], half = 0.5 * cv->width;
    ch_featmap_profile_normal(&fc, sd >= 0 ? 1 : -1, fabs(sd), g, B, half, half, ne);
    ch_featmap_sample a, b;
    ch_featmap_eval(&plain_nf, CH_FEATMAP_FEATNORM, q[0], q[1], &a);
    ch_featmap_eval(&warped_nf, CH_FEATMAP_FEATNORM, q[0], q[1], &b);
    e_plain += angle_deg(a.normal, ne);
    e_warp += angle_deg(b.normal, ne);
    ch_featmap_eval(&plain, CH_FEATMAP_FEATNORM, q[0], q[1], &a);
    ch_featmap_eval(&warped, CH_FEATMAP_FEATNORM, q[0], q[1], &b);
    e_full[0] += angle_deg(a.normal, ne);
    e_full[1] += angle_deg(b.normal, ne);
    worst_d = fmax(worst_d, fabs(b.distance - fabs(sd)));
    wrong += fabs(sd) > 1e-9 && b.side != (sd >= 0 ? 1 : -1);
    n++;
  }
  CHECK(n > 1000);
  fprintf(stderr,
          "  in view at R 48: normal error %.3f deg unwarped, %.3f warped without the fallback (slopes up to %.1f x "
          "%.1f); with it %.3f, %.3f\n",
          e_plain / n, e_warp / n, w.stats.max_slope[0], w.stats.max_slope[1], e_full[0] / n, e_full[1] / n);
  CHECK(e_full[0] < 0.1 * n && e_full[1] < 0.1 * n);
  CHECK_MSG(e_warp < 0.5 * e_plain, "normal error under the warp %g, without %g (degrees, mean)", e_warp / n,
            e_plain / n);
  CHECK_MSG(worst_d < 1e-3 && wrong < n / 500, "warped maps: distance off by %g, %d wrong sides", worst_d, wrong);
  ch_error e = {0};
  CHECK(ch_featmap_write_exr("/nonexistent/x.exr", &warped, NULL, NULL, 0, &e) == CH_ERR_INPUT);
  ch_featmap_free(&plain);
  ch_featmap_free(&warped);
  ch_featmap_free(&plain_nf);
  ch_featmap_free(&warped_nf);
  ch_warp_free(&w);
  ch_curves_free(&set);
  free(uvs);
  free(pos);
}

static void test_bad_input(void) {
  const char *svg = "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
                    "<path d='M 10 10 L 90 90' data-kind='step' data-left='1' data-blur='2'/></svg>";
  ch_curve_set set;
  REQUIRE(parse(svg, &set) == 0);
  ch_featmap m;
  ch_msdf ms;
  ch_error err = {0};
  ch_featmap_desc d = {.resolution = 16};
  CHECK(ch_featmap_build(&set, &d, &m, &err) == CH_ERR_INPUT && strstr(err.message, "no curve to encode"));
  ch_msdf_desc md = {.resolution = 16};
  CHECK(ch_msdf_build(&set, &md, &ms, &err) == CH_ERR_INPUT);
  set.curves[0].blur = 0.0;
  d.resolution = 3;
  CHECK(ch_featmap_build(&set, &d, &m, &err) == CH_ERR_INPUT && strstr(err.message, "resolution 3"));
  d.resolution = CH_FEATMAP_MAX_RES + 1;
  CHECK(ch_featmap_build(&set, &d, &m, &err) == CH_ERR_INPUT);
  d.resolution = 16;
  d.rect[2] = NAN;
  CHECK(ch_featmap_build(&set, &d, &m, &err) == CH_ERR_INPUT);
  d.rect[2] = 0.0;
  set.segments[0].p[1][0] = NAN;
  CHECK(ch_featmap_build(&set, &d, &m, &err) == CH_ERR_INPUT && strstr(err.message, "not finite"));
  ch_curves_free(&set);
}

int main(void) {
  RUN(test_table);
  RUN(test_straight);
  RUN(test_quadratic);
  RUN(test_exact_maps);
  RUN(test_circle_side);
  RUN(test_fallback);
  RUN(test_step_ends);
  RUN(test_flat_regions);
  RUN(test_smoothing);
  RUN(test_threads_and_file);
  RUN(test_msdf);
  RUN(test_warped);
  RUN(test_bad_input);
  TEST_MAIN_END();
}
