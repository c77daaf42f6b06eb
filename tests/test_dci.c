/* Diffusion-curve images: feature samples against the exact curves,
 * piecewise-constant exactness of the diffusion, and the reconstruction's
 * wrong-side rates at 16x magnification for bilinear, recon3, recon5 and
 * exact, on curves whose true value everywhere is known. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "ch_bezier.h"
#include "ch_curves.h"
#include "ch_dci.h"
#include "ch_dlayer.h"
#include "ch_groove.h"
#include "ch_height.h"
#include "ch_math.h"
#include "ch_recon.h"
#include "ch_stepsing.h"
#include "ch_test.h"

static uint64_t rng = 0x243f6a8885a308d3ull;
static double rnd(void) {
  rng ^= rng >> 12;
  rng ^= rng << 25;
  rng ^= rng >> 27;
  return (double)((rng * 0x2545f4914f6cdd1dull) >> 11) * (1.0 / 9007199254740992.0);
}

static int load(const char *path, ch_curve_set *set) {
  ch_error err = {0};
  if (ch_curves_read_svg(path, set, &err)) {
    fprintf(stderr, "%s\n", err.message);
    return -1;
  }
  return 0;
}

/* The true value at q of a piecewise-constant step scene: the value on q's
 * side of its nearest curve. */
static double truth(const ch_curve_set *set, double u, double v, double *dist) {
  double q[2] = {u, v}, best = INFINITY, value = 0.0;
  for (int c = 0; c < set->num_curves; c++) {
    if (set->curves[c].kind != CH_CURVE_STEP) continue;
    ch_curve_point cp;
    ch_curve_closest(set, c, q, &cp);
    if (cp.distance < best) {
      best = cp.distance;
      value = cp.signed_distance >= 0 ? set->curves[c].left : set->curves[c].right;
    }
  }
  if (dist) *dist = best;
  return value;
}

static void test_samples_exact_and_propagated(void) {
  ch_curve_set set;
  REQUIRE(load(CHISEL_MODELS "/curves/relief.svg", &set) == 0);
  ch_samples s;
  ch_error err = {0};
  double rect[4] = {0, 0, 1, 1};
  REQUIRE(ch_samples_build(&set, 200, 200, rect, 3.0, &s, &err) == CH_OK);
  double max_exact = 0.0, max_prop = 0.0, sum_prop = 0.0;
  int n_prop = 0, side_wrong = 0, n_exact = 0;
  for (int y = 0; y < s.height; y++)
    for (int x = 0; x < s.width; x++) {
      size_t i = (size_t)y * s.width + x;
      double q[2];
      ch_samples_center(&s, x, y, q);
      /* The exact nearest curve point over all step curves. */
      double best = INFINITY, sd = 0;
      for (int c = 0; c < set.num_curves; c++) {
        ch_curve_point cp;
        ch_curve_closest(&set, c, q, &cp);
        if (cp.distance < best) best = cp.distance, sd = cp.signed_distance;
      }
      double d_texels = best / s.texel[0];
      REQUIRE(s.curve[i] >= 0);
      double err_d = fabs(s.distance[i] - d_texels);
      if (s.exact[i]) {
        n_exact++;
        if (err_d > max_exact) max_exact = err_d;
        int left = (s.side[i] & CH_SIDE_LEFT) != 0;
        if (best > 1e-9 && left != (sd > 0)) side_wrong++;
      } else {
        n_prop++;
        sum_prop += err_d;
        if (err_d > max_prop) max_prop = err_d;
      }
    }
  fprintf(stderr, "  samples 200x200: %d exact (max distance error %.2g texels), %d propagated "
                  "(mean error %.3g, max %.3g texels), %d exact sides wrong\n",
          n_exact, max_exact, n_prop, sum_prop / n_prop, max_prop, side_wrong);
  CHECK(max_exact < 1e-4); /* float storage of the distance */
  CHECK(side_wrong == 0);
  CHECK(sum_prop / n_prop < 0.05);
  CHECK(max_prop < 1.0);
  ch_samples_free(&s);
  ch_curves_free(&set);
}

/* Every region carries one value on its whole boundary: the diffusion is
 * exactly that value outside the one-texel band. */
static void test_piecewise_constant(void) {
  ch_curve_set set;
  REQUIRE(load(CHISEL_MODELS "/curves/relief.svg", &set) == 0);
  for (int c = 0; c < set.num_curves; c++) set.curves[c].blur = 0.0; /* crisp everywhere */
  ch_dci dci;
  ch_error err = {0};
  ch_dci_desc desc = {.resolution = 256};
  REQUIRE(ch_dci_build(&set, &desc, &dci, &err) == CH_OK);
  double max_err = 0.0;
  int counted = 0;
  for (int y = 0; y < 256; y++)
    for (int x = 0; x < 256; x++) {
      double q[2], d;
      ch_samples_center(&dci.samples, x, y, q);
      double want = truth(&set, q[0], q[1], &d);
      if (d <= 1.0 / 256 * 1.0001) continue; /* the one-texel band */
      counted++;
      double e = fabs(dci.h[(size_t)y * 256 + x] - want);
      if (e > max_err) max_err = e;
    }
  fprintf(stderr, "  piecewise constant 256x256: max error %.3g over %d texels outside the band "
                  "(%d iterations, residual %.2g)\n",
          max_err, counted, dci.stats.iterations, dci.stats.relative_residual[0]);
  CHECK(max_err <= 1e-6 * 0.03); /* 1e-6 of the value range */
  /* h alone (what displacement asks for) is the same field, without rgb. */
  ch_dci mono;
  desc.no_colors = 1;
  REQUIRE(ch_dci_build(&set, &desc, &mono, &err) == CH_OK);
  CHECK(dci.rgb != NULL && mono.rgb == NULL);
  double diff = 0.0;
  for (size_t i = 0; i < (size_t)256 * 256; i++) diff = fmax(diff, fabs(mono.h[i] - dci.h[i]));
  CHECK_MSG(diff <= 1e-6 * 0.03, "h with and without colours differs by %g", diff);
  ch_dci_free(&mono);
  ch_dci_free(&dci);
  ch_curves_free(&set);
}

/* Wrong-side pixels at 16x magnification around points of the curves. */
static double wrong_rate(const ch_curve_set *set, int R, ch_recon_method method, int crops) {
  ch_dci dci;
  ch_error err = {0};
  ch_dci_desc desc = {.resolution = R};
  if (ch_dci_build(set, &desc, &dci, &err)) return 1.0;
  ch_recon rec;
  if (ch_recon_init(&rec, &dci, set, &err)) return 1.0;
  const int texels = 4, px = 16 * texels; /* a 4x4-texel crop at 16x */
  long wrong = 0, total = 0;
  uint64_t saved = rng;
  rng = 0x9e3779b97f4a7c15ull + (uint64_t)R; /* same crops for every method */
  for (int k = 0; k < crops; k++) {
    /* A random point on a random step segment. */
    int s = (int)(rnd() * set->num_segments);
    double t = rnd(), c[2];
    const ch_segment *sg = &set->segments[s];
    double a = 1 - t;
    for (int j = 0; j < 2; j++) c[j] = a * a * sg->p[0][j] + 2 * a * t * sg->p[1][j] + t * t * sg->p[2][j];
    double half = 0.5 * texels / R;
    for (int y = 0; y < px; y++)
      for (int x = 0; x < px; x++) {
        double u = c[0] - half + (x + 0.5) * 2 * half / px, v = c[1] + half - (y + 0.5) * 2 * half / px;
        if (u < 0 || v < 0 || u > 1 || v > 1) continue;
        ch_recon_sample rs;
        ch_recon_eval(&rec, method, u, v, 0.0, &rs);
        double want = truth(set, u, v, NULL);
        total++;
        /* Values are 0..0.03 in steps of at least 0.004: a wrong side is off
         * by a step; keep clear of the blend across one texel. */
        if (fabs(rs.value - want) > 0.0015) wrong++;
      }
  }
  rng = saved;
  ch_recon_free(&rec);
  ch_dci_free(&dci);
  return (double)wrong / (double)(total ? total : 1);
}

static void test_reconstruction_rates(void) {
  ch_curve_set set;
  REQUIRE(load(CHISEL_MODELS "/curves/relief.svg", &set) == 0);
  for (int c = 0; c < set.num_curves; c++) set.curves[c].blur = 0.0;
  static const char *names[] = {"bilinear", "recon5", "recon3", "exact"};
  int Rs[] = {64, 128, 256};
  for (int r = 0; r < 3; r++) {
    double rate[4];
    for (int m = 0; m < 4; m++) rate[m] = wrong_rate(&set, Rs[r], (ch_recon_method)m, 40);
    fprintf(stderr, "  R=%3d wrong-value pixels at 16x: %s %.4f%%  %s %.4f%%  %s %.4f%%  %s %.4f%%\n", Rs[r],
            names[0], 100 * rate[0], names[1], 100 * rate[1], names[2], 100 * rate[2], names[3], 100 * rate[3]);
    /* The reconstruction beats bilinear by a wide margin. */
    CHECK(rate[1] * 5 < rate[0]);
    CHECK(rate[2] * 5 < rate[0]);
    CHECK(rate[3] * 5 < rate[0]);
  }
  ch_curves_free(&set);
}

/* Reblur against the discrete Gaussian computed directly: a straight step
 * u = 0.5 with a blur of 8 texels over a 256^2 image diffuses to the
 * exact step (each side's region carries one value) with a constant
 * radius field, so each row must be the step convolved with exp(-j^2/2s^2)
 * over |j| <= 3s, normalised, borders clamped. */
static void test_reblur_profile(void) {
  static const char svg[] =
      "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
      "<path d='M 50 -10 V 110' data-kind='step' data-left='1' data-right='0' data-blur='3.125'/></svg>";
  ch_curve_set set;
  ch_error err = {0};
  REQUIRE(ch_curves_parse_svg(svg, sizeof svg - 1, "inline.svg", &set, &err) == CH_OK);
  ch_dci dci;
  ch_dci_desc desc = {.resolution = 256, .tolerance = 1e-8};
  REQUIRE(ch_dci_build(&set, &desc, &dci, &err) == CH_OK);
  REQUIRE(dci.blur != NULL);
  const double sigma = 8.0;
  const int k = 24;
  double worst = 0.0, worst_sigma = 0.0;
  for (int y = 0; y < 256; y += 17)
    for (int x = 0; x < 256; x++) {
      /* The path runs down the SVG (v decreasing): its left is +u. */
      double acc = 0.0, wsum = 0.0;
      for (int j = -k; j <= k; j++) {
        int xx = x + j < 0 ? 0 : x + j > 255 ? 255 : x + j;
        double w = exp(-(double)j * j / (2.0 * sigma * sigma));
        acc += w * (xx >= 128 ? 1.0 : 0.0);
        wsum += w;
      }
      worst = fmax(worst, fabs(dci.h[(size_t)y * 256 + x] - acc / wsum));
      worst_sigma = fmax(worst_sigma, fabs(dci.blur[(size_t)y * 256 + x] - sigma));
    }
  fprintf(stderr, "  reblur of a straight step, sigma 8 texels: max error %.3g (radius field off by %.3g)\n", worst,
          worst_sigma);
  CHECK(worst_sigma <= 1e-4);
  CHECK_MSG(worst <= 2e-5, "blurred step off the discrete Gaussian by %g", worst);
  ch_dci_free(&dci);
  ch_curves_free(&set);
}

/* Steps plus grooves through ch_height: a step disc with a v groove. */
static void test_height_sum(void) {
  static const char svg[] =
      "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
      "<circle cx='50' cy='50' r='30' data-kind='step' data-left='0' data-right='0.02'/>"
      "<path d='M 0 50 L 100 50' data-width='10' data-depth='0.01'/></svg>";
  ch_curve_set set;
  ch_error err = {0};
  REQUIRE(ch_curves_parse_svg(svg, sizeof svg - 1, "inline.svg", &set, &err) == CH_OK);
  ch_height h;
  ch_height_desc hd = {.dci_resolution = 128, .step_method = CH_RECON_EXACT};
  REQUIRE(ch_height_init(&h, &set, &hd, &err) == CH_OK);
  /* Inside the disc (the right of a clockwise circle), away from the groove. */
  CHECK_NEAR(ch_height_eval(&h, 0.5, 0.7), 0.02, 1e-8);
  CHECK_NEAR(ch_height_eval(&h, 0.05, 0.9), 0.0, 1e-8);
  /* On the groove's centre line inside the disc: 0.02 - 0.01. */
  CHECK_NEAR(ch_height_eval(&h, 0.5, 0.5), 0.01, 1e-8);
  /* Just inside and outside the wall at u = 0.8, v = 0.5 +- 0.1 off the groove. */
  CHECK_NEAR(ch_height_eval(&h, 0.5 + sqrt(0.09 - 0.01) - 1e-4, 0.6), 0.02, 1e-8);
  CHECK_NEAR(ch_height_eval(&h, 0.5 + sqrt(0.09 - 0.01) + 1e-4, 0.6), 0.0, 1e-8);
  ch_height_free(&h);
  ch_curves_free(&set);
}

/* ch_height_render takes pixels that no curve reaches by a shorter path
 * (no groove, no side to decide, no singular or layer term): the image
 * must be the same bits as every sample read by ch_height_eval. Scene 0:
 * a blurred closed step (a smooth field), two closed steps that cross
 * (singular points) and a groove, with pixels of both kinds; scene 1 adds
 * two open steps, whose layers' windows reach every pixel at this size. */
static void test_render_plain_pixels(void) {
  static const char closed[] =
      "<circle cx='35' cy='40' r='20' data-kind='step' data-left='0' data-right='0.02' data-blur='6'/>"
      "<rect x='60' y='60' width='25' height='20' data-kind='step' data-left='0.01' data-right='0.004'/>"
      "<rect x='70' y='50' width='10' height='40' data-kind='step' data-left='0' data-right='0.015'/>"
      "<path d='M 5 95 Q 50 70 95 90' data-width='4' data-depth='0.01'/>";
  static const char open[] = "<path d='M 10 10 C 20 20 30 5 40 15' data-kind='step' data-left='0.01' data-right='0'/>";
  for (int scene = 0; scene < 2; scene++) {
    char svg[2048];
    snprintf(svg, sizeof svg, "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>%s%s</svg>", closed,
             scene ? open : "");
    ch_curve_set set;
    ch_error err = {0};
    REQUIRE(ch_curves_parse_svg(svg, strlen(svg), "inline.svg", &set, &err) == CH_OK);
    for (int m = 0; m < 2; m++) {
      ch_recon_method method = m ? CH_RECON_EXACT : CH_RECON_5X5;
      const int R = 192, S = 2;
      ch_height h;
      ch_height_desc hd = {.dci_resolution = R, .step_method = method};
      REQUIRE(ch_height_init(&h, &set, &hd, &err) == CH_OK);
      REQUIRE(h.dci.num_sing > 0 && (h.dci.num_layers > 0) == scene);
      float *img = malloc(sizeof *img * R * R);
      REQUIRE(img);
      ch_height_render(&h, R, S, img);
      int differ = 0, plain = 0, empty = 0;
      for (int y = 0; y < R; y++)
        for (int x = 0; x < R; x++) {
          /* the samples where ch_height_render takes them, to the bit */
          double inv = 1.0 / R, sub = 1.0 / S, sum = 0.0;
          for (int j = 0; j < S; j++)
            for (int i = 0; i < S; i++)
              sum += ch_height_eval(&h, (x + (i + 0.5) * sub) * inv, 1.0 - (y + (j + 0.5) * sub) * inv);
          float want = (float)(sum * (1.0 / ((double)S * S)));
          differ += memcmp(&want, &img[(size_t)y * R + x], sizeof want) != 0;
          double u0 = (x + 0.5 * sub) * inv, u1 = (x + (S - 0.5) * sub) * inv;
          double v0 = 1.0 - (y + (S - 0.5) * sub) * inv, v1 = 1.0 - (y + 0.5 * sub) * inv;
          plain += ch_recon_box_is_plain(&h.recon, method, u0, v0, u1, v1);
          empty += ch_groove_field_box_is_empty(&h.grooves, u0, v0, u1, v1);
        }
      fprintf(stderr, "  render, scene %d, %s: %d of %d pixels plain, %d without grooves, %d differ\n", scene,
              m ? "exact" : "recon5", plain, R * R, empty, differ);
      CHECK_MSG(differ == 0, "%d pixels differ from the samples read one by one", differ);
      CHECK(empty > R * R / 2 && empty < R * R);
      CHECK(scene ? plain == 0 : plain > R * R / 4 && plain < R * R);
      /* and point by point inside plain boxes (random, up to 3 texels) */
      int checked = 0;
      for (int k = 0; k < 4000; k++) {
        double u = rnd(), v = rnd(), size = rnd() * 3.0 / R;
        if (!ch_recon_box_is_plain(&h.recon, method, u, v, u + size, v + size)) continue;
        double pu = u + rnd() * size, pv = v + rnd() * size;
        ch_recon_sample rs;
        ch_recon_eval(&h.recon, method, pu, pv, 0.0, &rs);
        float fast = ch_recon_eval_plain(&h.recon, pu, pv);
        checked++;
        CHECK(rs.curve == -1 && memcmp(&fast, &rs.value, sizeof fast) == 0);
      }
      CHECK(scene || checked > 500);
      free(img);
      ch_height_free(&h);
    }
    ch_curves_free(&set);
  }
}

/* Degenerate step curves: handled, never a crash or a hang. */
static void test_degenerate_steps(void) {
  static const char *bodies[] = {
      /* coincident control points, a self-crossing figure eight, crossing curves */
      "<path d='M 10 10 Q 10 10 60 60' data-kind='step' data-left='1'/>",
      "<path d='M 20 20 L 80 80 L 80 20 L 20 80 Z' data-kind='step' data-left='1' data-right='-1'/>",
      "<path d='M 0 50 L 100 50' data-kind='step' data-left='1'/><path d='M 50 0 L 50 100' data-kind='step' data-right='1'/>",
      "<path d='M 50 50 L 50.0001 50' data-kind='step' data-left='1'/>",
  };
  for (size_t k = 0; k < sizeof bodies / sizeof bodies[0]; k++) {
    char svg[1024];
    snprintf(svg, sizeof svg, "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>%s</svg>", bodies[k]);
    ch_curve_set set;
    ch_error err = {0};
    REQUIRE(ch_curves_parse_svg(svg, strlen(svg), "degenerate.svg", &set, &err) == CH_OK);
    if (k == 0) { /* the reader makes that quadratic a line: put its control point back on its start */
      REQUIRE(set.num_segments == 1 && set.segments[0].is_line);
      set.segments[0].is_line = 0;
      memcpy(set.segments[0].p[1], set.segments[0].p[0], sizeof set.segments[0].p[1]);
    }
    ch_dci dci;
    ch_dci_desc desc = {.resolution = 64};
    ch_status st = ch_dci_build(&set, &desc, &dci, &err);
    CHECK_MSG(st == CH_OK, "case %zu: %s", k, err.message);
    if (st == CH_OK) {
      int finite = 1;
      for (int i = 0; i < 64 * 64; i++) finite &= isfinite(dci.h[i]);
      CHECK(finite);
      ch_dci_free(&dci);
    }
    ch_curves_free(&set);
  }
}

/* h at (u, v) and its gradient (central differences, step fd) through the
 * exact reconstruction. */
static double recon_grad(const ch_recon *r, double u, double v, double fd, double g[2]) {
  ch_recon_sample s, a, b, c, d;
  ch_recon_eval(r, CH_RECON_EXACT, u, v, 0.0, &s);
  ch_recon_eval(r, CH_RECON_EXACT, u + fd, v, 0.0, &a);
  ch_recon_eval(r, CH_RECON_EXACT, u - fd, v, 0.0, &b);
  ch_recon_eval(r, CH_RECON_EXACT, u, v + fd, 0.0, &c);
  ch_recon_eval(r, CH_RECON_EXACT, u, v - fd, 0.0, &d);
  g[0] = (a.value - b.value) / (2.0 * fd);
  g[1] = (c.value - d.value) / (2.0 * fd);
  return s.value;
}

/* The double layer of an open curve (ch_dlayer.h) against values a person
 * can check: the angle a segment spans, a jump of exactly J all along a
 * bent curve, no jump across its chord, the gradient against differences,
 * and the dipole's fall far away. */
static void test_double_layer(void) {
  double seg[1][3][2] = {{{0, 0}, {0.5, 0}, {1, 0}}};
  ch_dlayer line = {.jump = 1.0, .num_pieces = 1, .p = seg, .box = {0, 0, 1, 0}};
  double q[2] = {0.5, 0.1};
  double want = atan2(-0.1, 0.5) - atan2(-0.1, -0.5);
  CHECK_MSG(fabs(ch_dlayer_angle(&line, q) - want) < 1e-12, "segment: %.15g, want %.15g", ch_dlayer_angle(&line, q),
            want);
  q[1] = -0.1;
  CHECK(fabs(ch_dlayer_angle(&line, q) + want) < 1e-12);
  /* a C: two quadratic pieces from (1, 0) round by (0, 1) to (-1, 0) */
  double arc[2][3][2] = {{{1, 0}, {1, 1}, {0, 1}}, {{0, 1}, {-1, 1}, {-1, 0}}};
  ch_dlayer c = {.jump = 0.3, .num_pieces = 2, .p = arc, .box = {-1, 0, 1, 1}};
  double worst_jump = 0.0, worst_chord = 0.0, worst_grad = 0.0;
  for (int i = 1; i < 40; i++) {
    int piece = i < 20 ? 0 : 1;
    double t = (i % 20) / 20.0, pt[2], tg[2];
    ch_bezier_eval((const double(*)[2])arc[piece], t, pt);
    ch_bezier_direction((const double(*)[2])arc[piece], t, tg);
    double left[2] = {-tg[1], tg[0]}, right[2] = {tg[1], -tg[0]};
    worst_jump = fmax(worst_jump, fabs(ch_dlayer_value_beside(&c, pt, left) - ch_dlayer_value_beside(&c, pt, right) - 0.3));
    /* across the chord (y = 0 between the ends), inside the C and out */
    double x = -0.95 + 1.9 * i / 40.0, a[2] = {x, 1e-9}, b[2] = {x, -1e-9};
    worst_chord = fmax(worst_chord, fabs(ch_dlayer_value(&c, a, NULL) - ch_dlayer_value(&c, b, NULL)));
    /* the gradient against central differences, off the curve */
    double r[2] = {0.3 * cos(i), 0.3 + 0.2 * sin(3.0 * i)}, g[2], h = 1e-6;
    ch_dlayer_value(&c, r, g);
    double dx[2] = {r[0] + h, r[1]}, mx[2] = {r[0] - h, r[1]}, dy[2] = {r[0], r[1] + h}, my[2] = {r[0], r[1] - h};
    double fd[2] = {(ch_dlayer_value(&c, dx, NULL) - ch_dlayer_value(&c, mx, NULL)) / (2 * h),
                    (ch_dlayer_value(&c, dy, NULL) - ch_dlayer_value(&c, my, NULL)) / (2 * h)};
    worst_grad = fmax(worst_grad, hypot(g[0] - fd[0], g[1] - fd[1]) / hypot(fd[0], fd[1]));
  }
  printf("  double layer: jump off by %.2g, across the chord %.2g, gradient %.2g (relative)\n", worst_jump,
         worst_chord, worst_grad);
  CHECK(worst_jump < 3e-6); /* W a hair (1e-7) off the curve on each side */
  CHECK(worst_chord < 1e-6);
  CHECK(worst_grad < 1e-5);
  double far[2] = {300.0, 400.0};
  CHECK(fabs(ch_dlayer_value(&c, far, NULL)) < 0.3 * 2.0 / 500.0); /* a dipole: J |chord| / (2 pi r) at most */
}

/* An X of two short step curves, each taken out as a layer: the wedge left
 * at their crossing is h - W's expansion only up to the arms' ends, so its
 * window stops there; and h stays continuous across an arm's ray beyond
 * its curve's end. */
static void test_crossing_window(void) {
  const char *svg = "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
                    "<path d='M 45 50 L 55 50' data-kind='step' data-left='1' data-right='0'/>"
                    "<path d='M 50 45 L 50 55' data-kind='step' data-left='0.5' data-right='0'/></svg>";
  ch_curve_set set;
  ch_error err = {0};
  REQUIRE(ch_curves_parse_svg(svg, strlen(svg), "x.svg", &set, &err) == CH_OK);
  ch_dci dci;
  ch_recon rec;
  ch_dci_desc desc = {.resolution = 128, .tolerance = 1e-8};
  REQUIRE(ch_dci_build(&set, &desc, &dci, &err) == CH_OK);
  REQUIRE(ch_recon_init(&rec, &dci, &set, &err) == CH_OK);
  CHECK(dci.num_layers == 2 && dci.num_sing == 1);
  CHECK(dci.num_sing == 1 && dci.sing[0].radius <= 5.0 * 1.28 + 1e-9); /* the arms' length, in texels */
  /* across the ray of the first curve beyond its end (u 0.58 to 0.62) */
  double worst = 0.0;
  for (int k = 0; k <= 8; k++) {
    double u = 0.58 + 0.005 * k, prev = 0.0;
    for (int i = 0; i <= 200; i++) {
      ch_recon_sample s;
      ch_recon_eval(&rec, CH_RECON_EXACT, u, 0.49 + 0.02 * i / 200.0, 0.0, &s);
      if (i > 0) worst = fmax(worst, fabs(s.value - prev));
      prev = s.value;
    }
  }
  CHECK_MSG(worst < 2e-3, "a step of %g across the ray beyond the curve's end", worst);
  ch_recon_free(&rec);
  ch_dci_free(&dci);
  ch_curves_free(&set);
}

/* Near the interior ends of an open step curve, 128^2 against 1024^2 (both
 * with the terms; the plain 1024^2 is itself first order there): mean
 * value error and gradient error (over the reference's mean gradient) on
 * rings round the ends, for the plain DCI (k = 0) and the one with terms
 * (k = 1). */
static void ends_error(const ch_curve_set *set, const ch_recon rec[3], const double (*ends)[2], int num_ends,
                       double eh[2], double eg[2]) {
  const double radii[4] = {0.5, 1.0, 2.0, 4.0}, tex = 1.0 / 128.0, fd = 0.01 * tex;
  double gsum = 0.0;
  int n = 0;
  eh[0] = eh[1] = eg[0] = eg[1] = 0.0;
  for (int e = 0; e < num_ends; e++)
    for (int ri = 0; ri < 4; ri++)
      for (int a = 0; a < 48; a++) {
        double th = 2.0 * CH_PI * (a + 0.5) / 48.0;
        double u = ends[e][0] + radii[ri] * tex * cos(th), v = ends[e][1] + radii[ri] * tex * sin(th);
        /* off the curve by more than the differences' step */
        double q[2] = {u, v};
        ch_curve_point cp;
        ch_curve_closest(set, 0, q, &cp);
        if (cp.distance < 0.05 * tex) continue;
        double gr[2], g[2];
        double hr = recon_grad(&rec[2], u, v, fd, gr);
        gsum += hypot(gr[0], gr[1]);
        n++;
        for (int k = 0; k < 2; k++) {
          double hv = recon_grad(&rec[k], u, v, fd, g);
          eh[k] += fabs(hv - hr);
          eg[k] += hypot(g[0] - gr[0], g[1] - gr[1]);
        }
      }
  for (int k = 0; k < 2; k++) eh[k] /= n, eg[k] /= gsum;
}

/* The singular terms (ch_dci.h): around an open step curve's end h is to
 * first order linear in the angle, and a plain diffusion and bilinear
 * blend get it wrong by a fair part of the step within a few texels. A
 * curve with both ends inside is taken out whole as a double layer; one
 * running to the border has a windowed wedge at its inner end. With them a
 * 128^2 DCI agrees with a 1024^2 one several times better in value and
 * gradient, and the reconstruction has no seam where a window ends. */
static void test_singular_terms(void) {
  /* the third: the same curve among 80 short dashes, whose layers are
   * windowed (the budget of evaluations per texel) */
  char many[16384];
  int len = snprintf(many, sizeof many,
                     "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
                     "<path d='M 30 55 L 70 45' data-kind='step' data-left='1' data-right='0'/>");
  for (int k = 0; k < 80; k++) {
    double x = 5.0 + 90.0 * rnd(), y = 5.0 + 90.0 * rnd(), a = 6.2832 * rnd();
    if (fabs(y - 50.0) < 12.0) y += y < 50.0 ? -12.0 : 12.0; /* clear of the rings round the curve's ends */
    len += snprintf(many + len, sizeof many - (size_t)len,
                    "<path d='M %.3f %.3f L %.3f %.3f' data-kind='step' data-left='%.2f' data-right='0'/>", x, y,
                    x + 2.0 * cos(a), y + 2.0 * sin(a), 0.2 + rnd());
  }
  snprintf(many + len, sizeof many - (size_t)len, "</svg>");
  const char *svgs[3] = {"<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
                         "<path d='M 30 55 L 70 45' data-kind='step' data-left='1' data-right='0'/></svg>",
                         "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
                         "<path d='M 30 55 L 100 45' data-kind='step' data-left='1' data-right='0'/></svg>",
                         many};
  const double ends[2][2] = {{0.3, 0.45}, {0.7, 0.55}};
  for (int c = 0; c < 3; c++) {
    ch_curve_set set;
    ch_error err = {0};
    REQUIRE(ch_curves_parse_svg(svgs[c], strlen(svgs[c]), "ends.svg", &set, &err) == CH_OK);
    enum { N = 3 };
    const int res[N] = {128, 128, 1024}, plain[N] = {1, 0, 0};
    ch_dci dci[N];
    ch_recon rec[N];
    for (int k = 0; k < N; k++) {
      ch_dci_desc desc = {.resolution = res[k], .tolerance = 1e-8, .no_singular = plain[k]};
      REQUIRE(ch_dci_build(&set, &desc, &dci[k], &err) == CH_OK);
      REQUIRE(ch_recon_init(&rec[k], &dci[k], &set, &err) == CH_OK);
    }
    if (c == 0) {
      CHECK(dci[0].num_layers == 0 && dci[1].num_layers == 1 && dci[1].num_sing == 0);
    } else if (c == 1) {
      CHECK(dci[1].num_layers == 0 && dci[1].num_sing == 1 && dci[1].sing[0].radius > 8.0);
    } else {
      CHECK(dci[1].num_layers >= 70); /* (dashes that cross or touch the border have none) */
      CHECK(dci[1].layer_far[1] < 64.0); /* a dash's window: its neighbourhood, not the grid */
    }
    double eh[2], eg[2];
    ends_error(&set, rec, ends, c == 1 ? 1 : 2, eh, eg);
    static const char *what[3] = {"both ends inside (a layer)", "one end on the border (a wedge)",
                                  "among 80 dashes (windowed layers)"};
    printf("  %s, at 128^2 against 1024^2 near the inner ends: |dh| plain %.3g, with terms %.3g; |d grad| / |grad| "
           "plain %.3f, with terms %.3f\n",
           what[c], eh[0], eh[1], eg[0], eg[1]);
    CHECK_MSG(eh[1] <= eh[0] / 5.0, "value error with terms %g, plain %g", eh[1], eh[0]);
    CHECK_MSG(eg[1] <= eg[0] / 3.0, "gradient error with terms %g, plain %g", eg[1], eg[0]);
    if (c == 1) {
      /* across the edge of the window, along a line through it: steps
       * between neighbouring samples no larger than the smooth field's own */
      const ch_stepsing_point *pt = &dci[1].sing[0];
      double tex = 1.0 / 128.0, worst = 0.0, typical = 0.0, prev = 0.0;
      for (int i = 0; i <= 400; i++) {
        double rt = pt->radius * (0.8 + 0.4 * i / 400.0); /* texels, straight below the point */
        double u = dci[1].samples.rect[0] + (pt->p[0] + 0.5) * tex,
               v = dci[1].samples.rect[3] + (pt->p[1] - 0.5 - rt) * tex;
        ch_recon_sample s;
        ch_recon_eval(&rec[1], CH_RECON_EXACT, u, v, 0.0, &s);
        if (i > 0) {
          double step = fabs(s.value - prev);
          worst = fmax(worst, step);
          typical += step / 400.0;
        }
        prev = s.value;
      }
      CHECK_MSG(worst <= 4.0 * typical, "steps across the window's edge: largest %g, mean %g", worst, typical);
    }
    for (int k = 0; k < N; k++) {
      ch_recon_free(&rec[k]);
      ch_dci_free(&dci[k]);
    }
    ch_curves_free(&set);
  }
}


/* Between two circles held at different values h is a logarithm of the
 * radius. Fixed texels holding their side's value move the boundary by up
 * to a texel (first order: the error halves as R doubles); with their
 * values extrapolated to their centres (ch_dci.h) it falls about four
 * times. */
static double annulus_error(const ch_curve_set *set, int R, int no_extrapolate) {
  const double cx = 0.503, cy = 0.503, a = 0.1037, b = 0.4021;
  ch_dci dci;
  ch_error err = {0};
  ch_dci_desc desc = {.resolution = R, .tolerance = 1e-8, .no_extrapolate = no_extrapolate};
  if (ch_dci_build(set, &desc, &dci, &err)) {
    fprintf(stderr, "%s\n", err.message);
    return INFINITY;
  }
  CHECK(no_extrapolate ? dci.extrapolations == 0 : dci.extrapolations == CH_DCI_EXTRAPOLATE_ROUNDS);
  double sum = 0.0;
  long n = 0;
  for (int y = 0; y < R; y++)
    for (int x = 0; x < R; x++) {
      double q[2];
      ch_samples_center(&dci.samples, x, y, q);
      double r = hypot(q[0] - cx, q[1] - cy);
      if (r < a + 1.5 / R || r > b - 1.5 / R) continue;
      double want = 0.01 - 0.01 * log(r / a) / log(b / a);
      sum += fabs(dci.h[(size_t)y * R + x] - want) / 0.01;
      n++;
    }
  ch_dci_free(&dci);
  return n ? sum / n : INFINITY;
}

static void test_extrapolated_boundary(void) {
  static const char svg[] =
      "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 100 100\"><g data-kind=\"step\">"
      "<circle cx=\"50.3\" cy=\"49.7\" r=\"10.37\" data-left=\"0.01\" data-right=\"0.01\"/>"
      "<circle cx=\"50.3\" cy=\"49.7\" r=\"40.21\" data-left=\"0\" data-right=\"0\"/></g></svg>";
  ch_curve_set set;
  ch_error err = {0};
  REQUIRE(ch_curves_parse_svg(svg, sizeof svg - 1, "annulus.svg", &set, &err) == CH_OK);
  double plain[2], ghost[2];
  for (int k = 0; k < 2; k++) {
    plain[k] = annulus_error(&set, 128 << (2 * k), 1);
    ghost[k] = annulus_error(&set, 128 << (2 * k), 0);
  }
  fprintf(stderr, "  annulus, mean |h - log| / range at 128^2 and 512^2: side values %.3g, %.3g (%.1fx); "
                  "extrapolated %.3g, %.3g (%.1fx)\n",
          plain[0], plain[1], plain[0] / plain[1], ghost[0], ghost[1], ghost[0] / ghost[1]);
  CHECK(plain[0] / plain[1] < 5.0);  /* first order: 4x over two doublings */
  CHECK(ghost[0] / ghost[1] > 10.0); /* second order: 16x */
  CHECK(ghost[1] < 0.1 * plain[1]);
  ch_curves_free(&set);
}

/* A short line running on into a curve along its tangent is a joint, not
 * a crossing. GNOME's package icon's rounded square with one extra vertex
 * 0.0039 units before a corner: the crossing search's Newton steps stopped
 * 1e-8 inside the short line, a singular point with arms 3.7e-4 rad apart
 * was found there, and h reached 37 for a fill height of 0.01. Now no
 * singular point, and h within [0, 0.01] everywhere. */
static void test_tangent_joint(void) {
  static const char svg[] =
      "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 16 16'><path fill='#000' d='M 4.023438 0.996094 C "
      "2.363281 0.996094 0.996094 2.363281 0.996094 4.023438 L 0.996094 11.933594 C 0.996094 13.59375 2.363281 "
      "14.960938 4.023438 14.960938 L 11.972656 14.960938 C 13.632812 14.960938 15 13.59375 15 11.933594 L 15 "
      "4.027344 L 15 4.023438 C 15 2.363281 13.632812 0.996094 11.972656 0.996094 Z M 4.023438 2.996094 L 11.972656 "
      "2.996094 C 12.558594 2.996094 13 3.4375 13 4.023438 L 13 11.933594 C 13 12.519531 12.558594 12.960938 "
      "11.972656 12.960938 L 4.023438 12.960938 C 3.4375 12.960938 2.996094 12.519531 2.996094 11.933594 L 2.996094 "
      "4.023438 C 2.996094 3.4375 3.4375 2.996094 4.023438 2.996094 Z'/></svg>";
  ch_curve_set set;
  ch_error err = {0};
  REQUIRE(ch_curves_parse_svg(svg, sizeof svg - 1, "package.svg", &set, &err) == CH_OK);
  static const double all[4] = {0, 0, 1, 1};
  ch_stepsing sg;
  REQUIRE(ch_stepsing_find(&set, all, &sg, &err) == CH_OK);
  CHECK_MSG(sg.num_points == 0, "%d singular points", sg.num_points);
  ch_stepsing_free(&sg);
  ch_height h;
  ch_height_desc hd = {.dci_resolution = 256, .step_method = CH_RECON_EXACT};
  REQUIRE(ch_height_init(&h, &set, &hd, &err) == CH_OK);
  double lo = 1e300, hi = -1e300;
  for (int y = 0; y < 256; y++)
    for (int x = 0; x < 256; x++) {
      double e = ch_height_eval(&h, (x + 0.5) / 256, 1.0 - (y + 0.5) / 256);
      lo = fmin(lo, e), hi = fmax(hi, e);
    }
  CHECK_MSG(lo >= -1e-9 && hi <= 0.01 + 1e-9, "h in [%g, %g]", lo, hi);
  ch_height_free(&h);
  ch_curves_free(&set);
}

int main(void) {
  RUN(test_samples_exact_and_propagated);
  RUN(test_piecewise_constant);
  RUN(test_reconstruction_rates);
  RUN(test_height_sum);
  RUN(test_render_plain_pixels);
  RUN(test_reblur_profile);
  RUN(test_degenerate_steps);
  RUN(test_double_layer);
  RUN(test_singular_terms);
  RUN(test_crossing_window);
  RUN(test_extrapolated_boundary);
  RUN(test_tangent_joint);
  TEST_MAIN_END();
}
