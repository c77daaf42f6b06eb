/* The view-dependent warp (ch_warp, diffusion-curves-on-surfaces §3.2) on
 * plane cages whose numbers can be checked by hand: the camera's projection,
 * which triangles a close camera sees, the per-axis functions (monotone,
 * exact inverse, floor, cap, smoothness, more texels where visible), the
 * cage map (equal to W where the cage lines are the knot lines, inverted
 * exactly elsewhere), the arc length under W, the mesh's density (W's
 * slopes where the camera sees, falling off away from it), and the curves
 * cut at the cage edges and mapped through it. */
#include <math.h>
#include <omp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ch_bezier.h"
#include "ch_curves.h"
#include "ch_test.h"
#include "ch_warp.h"


/* An N x N grid of quads over [0, u_max] x [0, 1], each split along its
 * diagonal into two counter-clockwise triangles, at positions (u, v, 0).
 * Interior vertices move by up to jitter cells (the same vertex in every
 * triangle that has it), so cage edges are not on any knot line. */
typedef struct plane_cage {
  ch_warp_cage cage;
  double *uv, *pos;
} plane_cage;

static void vertex(int n, double u_max, double jitter, int i, int j, double out[2]) {
  out[0] = u_max * i / n;
  out[1] = (double)j / n;
  if (jitter > 0.0 && i > 0 && i < n && j > 0 && j < n) {
    /* a hash of (i, j), so shared vertices move alike */
    uint32_t h = (uint32_t)(i * 73856093u) ^ (uint32_t)(j * 19349663u);
    h ^= h >> 13;
    h *= 0x5bd1e995u;
    h ^= h >> 15;
    double a = (h & 0xffff) / 65535.0 - 0.5, b = (h >> 16) / 65535.0 - 0.5;
    out[0] += 2.0 * jitter * a * u_max / n;
    out[1] += 2.0 * jitter * b / n;
  }
}

static plane_cage make_plane(int n, double u_max, double jitter) {
  plane_cage p;
  int nt = 2 * n * n;
  p.uv = malloc((size_t)nt * 6 * sizeof *p.uv);
  p.pos = malloc((size_t)nt * 9 * sizeof *p.pos);
  int t = 0;
  for (int j = 0; j < n; j++)
    for (int i = 0; i < n; i++) {
      double c[4][2];
      vertex(n, u_max, jitter, i, j, c[0]);
      vertex(n, u_max, jitter, i + 1, j, c[1]);
      vertex(n, u_max, jitter, i + 1, j + 1, c[2]);
      vertex(n, u_max, jitter, i, j + 1, c[3]);
      static const int tri[2][3] = {{0, 1, 2}, {0, 2, 3}};
      for (int k = 0; k < 2; k++, t++)
        for (int m = 0; m < 3; m++) {
          const double *q = c[tri[k][m]];
          p.uv[6 * t + 2 * m] = q[0];
          p.uv[6 * t + 2 * m + 1] = q[1];
          p.pos[9 * t + 3 * m] = q[0];
          p.pos[9 * t + 3 * m + 1] = q[1];
          p.pos[9 * t + 3 * m + 2] = 0.0;
        }
    }
  p.cage.num_triangles = nt;
  p.cage.uv = p.uv;
  p.cage.position = p.pos;
  return p;
}

static void free_plane(plane_cage *p) {
  free(p->uv);
  free(p->pos);
}

static int parse(const char *svg, ch_curve_set *set) {
  ch_error err = {0};
  ch_status st = ch_curves_parse_svg(svg, strlen(svg), "test.svg", set, &err);
  if (st) fprintf(stderr, "parse: %s\n", err.message);
  return st == CH_OK;
}

/* 40 horizontal grooves: every triangle of a 16 x 16 cage holds curves. */
static int curves_everywhere(ch_curve_set *set) {
  char svg[8192];
  int n = snprintf(svg, sizeof svg,
                   "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 1 1'><g data-width='0.01'>");
  for (int k = 0; k < 40; k++)
    n += snprintf(svg + n, sizeof svg - (size_t)n, "<path d='M 0.01 %.4f H 0.99'/>", (k + 0.5) / 40.0);
  snprintf(svg + n, sizeof svg - (size_t)n, "</g></svg>");
  return parse(svg, set);
}

/* The close camera of the plane tests: 0.3 above (0.2, 0.2), looking down,
 * 40 degrees: it sees [0.2 -+ 0.3 tan 20] ~ [0.0908, 0.3092] on each axis. */
static void close_camera(ch_camera *cam) {
  const double v[7] = {0.2, 0.2, 0.3, 0.2, 0.2, 0.0, 40.0};
  ch_error err = {0};
  ch_camera_init(cam, v, &err);
}

/* W for the close camera over cage, with curves everywhere. */
static ch_status build_close(const ch_warp_cage *cage, int intervals, ch_warp *w) {
  ch_curve_set set;
  if (!curves_everywhere(&set)) return CH_ERR_INPUT;
  ch_camera cam;
  close_camera(&cam);
  ch_error err = {0};
  ch_warp_desc desc = {.intervals = intervals};
  ch_status st = ch_warp_build(&cam, cage, &set, &desc, w, &err);
  ch_curves_free(&set);
  return st;
}

static double slope_at(const ch_warp *w, int axis, int i) {
  const double *k = axis ? w->wv : w->wu;
  return (k[i + 1] - k[i]) * w->n;
}

static void test_camera(void) {
  ch_camera cam;
  ch_error err = {0};
  const double v[7] = {0, 0, 0, 0, 1, 0, 90};
  REQUIRE(ch_camera_init(&cam, v, &err) == CH_OK);
  CHECK_NEAR(cam.half_height, 1.0, 1e-15);
  /* looking along +y with z up: right is +x */
  CHECK_NEAR(cam.right[0], 1.0, 1e-15);
  CHECK_NEAR(cam.up[2], 1.0, 1e-15);
  double ndc[2], depth;
  CHECK(ch_camera_project(&cam, (const double[3]){0.5, 2.0, -1.0}, ndc, &depth) == 1);
  CHECK_NEAR(depth, 2.0, 1e-15);
  CHECK_NEAR(ndc[0], 0.25, 1e-15); /* 0.5 / (2 tan 45) */
  CHECK_NEAR(ndc[1], -0.5, 1e-15);
  CHECK(ch_camera_project(&cam, (const double[3]){0.0, -1.0, 0.0}, ndc, &depth) == 0);
  CHECK_NEAR(depth, -1.0, 1e-15);

  /* looking down z: up becomes +y, right +x */
  close_camera(&cam);
  CHECK_NEAR(cam.up[1], 1.0, 1e-15);
  CHECK_NEAR(cam.right[0], 1.0, 1e-15);
  CHECK(ch_camera_project(&cam, (const double[3]){0.3, 0.25, 0.0}, ndc, &depth) == 1);
  double th = tan(20.0 * 3.14159265358979323846 / 180.0);
  CHECK_NEAR(depth, 0.3, 1e-15);
  CHECK_NEAR(ndc[0], 0.1 / (0.3 * th), 1e-13);
  CHECK_NEAR(ndc[1], 0.05 / (0.3 * th), 1e-13);

  const double bad[][7] = {{NAN, 0, 0, 0, 1, 0, 40}, {1, 1, 1, 1, 1, 1, 40}, {0, 0, 0, 0, 1, 0, 0.0},
                           {0, 0, 0, 0, 1, 0, 180}, {0, 0, 0, 0, 1, 0, INFINITY}};
  for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
    ch_error e = {0};
    CHECK(ch_camera_init(&cam, bad[i], &e) == CH_ERR_INPUT);
    CHECK(strncmp(e.message, "camera: ", 8) == 0);
  }
}

/* The close camera over a 16 x 16 plane with curves everywhere. */
static void test_close_camera_functions(void) {
  plane_cage p = make_plane(16, 1.0, 0.0);
  ch_curve_set set;
  REQUIRE(curves_everywhere(&set));
  ch_camera cam;
  close_camera(&cam);
  ch_warp w;
  ch_error err = {0};
  ch_warp_desc desc = {.intervals = 64};
  REQUIRE(ch_warp_build(&cam, &p.cage, &set, &desc, &w, &err) == CH_OK);
  /* Quads 1..4 of each axis ([0.0625, 0.3125]) reach the visible square
   * [0.0908, 0.3092]: 16 quads, 32 triangles, all holding curves. */
  CHECK(w.stats.visible_triangles == 32);
  CHECK(w.stats.needy_triangles == 32);
  int n = w.n;
  CHECK(n == 64);
  for (int axis = 0; axis < 2; axis++) {
    const double *k = axis ? w.wv : w.wu;
    CHECK(k[0] == 0.0 && k[n] == 1.0);
    double smax = 0.0, smin = INFINITY, vis_min = INFINITY, far_max = 0.0, ratio = 0.0, mean = 0.0;
    for (int i = 0; i < n; i++) {
      CHECK(k[i + 1] > k[i]);
      double s = slope_at(&w, axis, i);
      mean += s / n;
      smax = fmax(smax, s);
      smin = fmin(smin, s);
      if (i >= 4 && i < 20) vis_min = fmin(vis_min, s); /* [0.0625, 0.3125] */
      if (i >= 32) far_max = fmax(far_max, s);          /* [0.5, 1] */
      if (i > 0) {
        double r = s / slope_at(&w, axis, i - 1);
        ratio = fmax(ratio, fmax(r, 1.0 / r));
      }
    }
    CHECK_NEAR(mean, 1.0, 1e-12);
    /* 12 intervals or more from the visible ones: 1.25^12 ~ 14.6 */
    CHECK_MSG(vis_min > 2.0 && vis_min > 14.0 * far_max, "visible %g far %g", vis_min, far_max);
    CHECK(smin >= 0.1 * (1.0 - 1e-12));
    CHECK(smax <= 64.0);
    CHECK(ratio <= 1.25 * (1.0 + 1e-12));
    CHECK_NEAR(w.stats.max_slope[axis], smax, 1e-15);
    /* One need for all the visible triangles, 1 / (0.3 tan 20): the
     * visible intervals share one slope. */
    CHECK_NEAR(slope_at(&w, axis, 4), slope_at(&w, axis, 19), 1e-12);
  }
  double uv[2] = {0.2, 0.2}, out[2];
  int t = ch_warp_map(&w, uv, out);
  CHECK(t >= 0 && w.visible[t]);
  uv[0] = uv[1] = 0.9;
  t = ch_warp_map(&w, uv, out);
  CHECK(t >= 0 && !w.visible[t]);
  /* Visible triangles cover 0.25^2 of UV; the warp gives them much more. */
  CHECK_NEAR(w.stats.unwarped_share, 0.0625, 0.005);
  CHECK(w.stats.visible_share > 4.0 * w.stats.unwarped_share);
  CHECK(w.stats.folded_triangles == 0);
  /* the same functions on one thread */
  int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  ch_warp one;
  REQUIRE(ch_warp_build(&cam, &p.cage, &set, &desc, &one, &err) == CH_OK);
  omp_set_num_threads(threads);
  CHECK(memcmp(one.wu, w.wu, (size_t)(n + 1) * sizeof *w.wu) == 0);
  CHECK(memcmp(one.wv, w.wv, (size_t)(n + 1) * sizeof *w.wv) == 0);
  CHECK(memcmp(one.visible, w.visible, (size_t)w.num_triangles) == 0);
  CHECK(one.stats.visible_share == w.stats.visible_share);
  ch_warp_free(&one);
  ch_warp_free(&w);

  /* No curves near what the camera sees: no need, the identity. */
  ch_curve_set far;
  REQUIRE(parse("<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 1 1'>"
                "<path d='M 0.8 0.1 L 0.9 0.2' data-width='0.01'/></svg>",
                &far));
  REQUIRE(ch_warp_build(&cam, &p.cage, &far, &desc, &w, &err) == CH_OK);
  CHECK(w.stats.visible_triangles == 32 && w.stats.needy_triangles == 0);
  for (int i = 0; i <= w.n; i++) CHECK(w.wu[i] == (double)i / w.n && w.wv[i] == (double)i / w.n);
  ch_warp_free(&w);
  ch_curves_free(&far);
  ch_curves_free(&set);
  free_plane(&p);
}

static void test_axis_inverse(void) {
  plane_cage p = make_plane(16, 1.0, 0.0);
  ch_warp w;
  REQUIRE(build_close(&p.cage, 0, &w) == CH_OK);
  CHECK(w.n == 256);
  for (int axis = 0; axis < 2; axis++) {
    CHECK(ch_warp_axis(&w, axis, 0.0) == 0.0 && ch_warp_axis(&w, axis, 1.0) == 1.0);
    CHECK(ch_warp_axis(&w, axis, -0.5) == 0.0 && ch_warp_axis(&w, axis, 1.5) == 1.0);
    double worst = 0.0, prev = -1.0;
    for (int i = 0; i < 2000; i++) {
      double x = ch_test_rnd(), y = ch_warp_axis(&w, axis, x);
      worst = fmax(worst, fabs(ch_warp_axis_inverse(&w, axis, y) - x));
      worst = fmax(worst, fabs(ch_warp_axis(&w, axis, ch_warp_axis_inverse(&w, axis, x)) - x));
    }
    CHECK_MSG(worst <= 1e-12, "round trip %g", worst);
    for (int i = 0; i <= 10000; i++) { /* monotone */
      double y = ch_warp_axis(&w, axis, i / 10000.0);
      CHECK(y > prev);
      prev = y;
    }
    /* the slope is the interval's, the right one at a knot */
    double x = 7.0 / w.n;
    CHECK_NEAR(ch_warp_axis_slope(&w, axis, x), slope_at(&w, axis, 7), 1e-15);
    CHECK_NEAR(ch_warp_axis_slope(&w, axis, 1.0), slope_at(&w, axis, w.n - 1), 1e-15);
  }
  ch_warp_free(&w);
  free_plane(&p);
}

static void test_looking_away(void) {
  plane_cage p = make_plane(16, 1.0, 0.0);
  ch_curve_set set;
  REQUIRE(curves_everywhere(&set));
  ch_error err = {0};
  /* up, away from the plane; and from below, where it shows its back */
  const double views[2][7] = {{0.2, 0.2, 0.3, 0.2, 0.2, 1.0, 40}, {0.5, 0.5, -0.5, 0.5, 0.5, 0.0, 60}};
  for (int v = 0; v < 2; v++) {
    ch_camera cam;
    REQUIRE(ch_camera_init(&cam, views[v], &err) == CH_OK);
    ch_warp w;
    REQUIRE(ch_warp_build(&cam, &p.cage, &set, NULL, &w, &err) == CH_OK);
    CHECK(w.stats.visible_triangles == 0 && w.stats.needy_triangles == 0);
    CHECK(w.stats.max_slope[0] == 1.0 && w.stats.max_slope[1] == 1.0);
    CHECK(w.stats.visible_share == 0.0);
    int identity = 1;
    for (int i = 0; i <= w.n; i++) identity &= w.wu[i] == (double)i / w.n && w.wv[i] == (double)i / w.n;
    CHECK(identity);
    ch_warp_free(&w);
  }
  ch_curves_free(&set);
  free_plane(&p);
}

/* Cage lines on the knot lines: W is affine on every triangle, so the
 * cage map is W itself. */
static void test_cage_map_on_knots(void) {
  plane_cage p = make_plane(16, 1.0, 0.0);
  ch_warp w;
  REQUIRE(build_close(&p.cage, 16, &w) == CH_OK);
  CHECK(w.stats.max_slope[0] > 1.5);
  double worst_w = 0.0, worst_inv = 0.0;
  int outside = 0;
  for (int i = 0; i < 5000; i++) {
    double q[2] = {ch_test_rnd(), ch_test_rnd()}, m[2], back[2];
    outside += ch_warp_map(&w, q, m) < 0;
    worst_w = fmax(worst_w, fmax(fabs(m[0] - ch_warp_axis(&w, 0, q[0])), fabs(m[1] - ch_warp_axis(&w, 1, q[1]))));
    outside += ch_warp_unmap(&w, m, back) < 0;
    worst_inv = fmax(worst_inv, fmax(fabs(back[0] - q[0]), fabs(back[1] - q[1])));
  }
  CHECK(outside == 0);
  CHECK_MSG(worst_w <= 1e-12, "C - W %g", worst_w);
  CHECK_MSG(worst_inv <= 1e-12, "C^-1 C %g", worst_inv);
  /* warped corners are W of the corners */
  for (int t = 0; t < w.num_triangles; t++)
    for (int k = 0; k < 3; k++) {
      CHECK(w.wuv[6 * t + 2 * k] == ch_warp_axis(&w, 0, w.uv[6 * t + 2 * k]));
      CHECK(w.wuv[6 * t + 2 * k + 1] == ch_warp_axis(&w, 1, w.uv[6 * t + 2 * k + 1]));
    }
  ch_warp_free(&w);

  /* A cage over the left half only: the right half is mapped by W. */
  plane_cage half = make_plane(8, 0.5, 0.0);
  REQUIRE(build_close(&half.cage, 16, &w) == CH_OK);
  double q[2] = {0.75, 0.4}, m[2], back[2];
  CHECK(ch_warp_map(&w, q, m) == -1);
  CHECK(m[0] == ch_warp_axis(&w, 0, 0.75) && m[1] == ch_warp_axis(&w, 1, 0.4));
  CHECK(ch_warp_unmap(&w, m, back) == -1);
  CHECK_NEAR(back[0], 0.75, 1e-12);
  CHECK_NEAR(back[1], 0.4, 1e-12);
  ch_warp_free(&w);
  free_plane(&half);
  free_plane(&p);
}

static int count_folds(const ch_warp *w) {
  int folds = 0;
  for (int t = 0; t < w->num_triangles; t++) {
    const double *c = w->wuv + 6 * t;
    folds += !((c[2] - c[0]) * (c[5] - c[1]) - (c[4] - c[0]) * (c[3] - c[1]) > 0.0);
  }
  return folds;
}

/* A cage off the knot lines: C is inverted exactly where the warped
 * triangles keep their orientation. Thin triangles spanning many intervals
 * can fold: in this 12 x 12 cage with vertices moved by up to 0.3 cells
 * (aspect down to 0.1) and 21 intervals a cell, one turns over, and the
 * stats say so. */
static void test_cage_map_jittered(void) {
  ch_warp w;
  plane_cage coarse = make_plane(12, 1.0, 0.3);
  REQUIRE(build_close(&coarse.cage, 0, &w) == CH_OK);
  CHECK(w.stats.folded_triangles == count_folds(&w));
  CHECK(w.stats.folded_triangles > 0);
  ch_warp_free(&w);
  free_plane(&coarse);

  /* 16 x 16, moved by up to 0.15 cells, 4 intervals a cell: no fold */
  plane_cage p = make_plane(16, 1.0, 0.15);
  REQUIRE(build_close(&p.cage, 64, &w) == CH_OK);
  CHECK(w.stats.max_slope[0] > 2.0);
  REQUIRE(w.stats.folded_triangles == 0 && count_folds(&w) == 0);
  double worst = 0.0;
  for (int i = 0; i < 5000; i++) {
    double q[2] = {ch_test_rnd(), ch_test_rnd()}, m[2], back[2];
    int t = ch_warp_map(&w, q, m);
    CHECK(t >= 0);
    CHECK(ch_warp_unmap(&w, m, back) >= 0);
    worst = fmax(worst, fmax(fabs(back[0] - q[0]), fabs(back[1] - q[1])));
  }
  CHECK_MSG(worst <= 1e-12, "C^-1 C %g", worst);
  ch_warp_free(&w);
  free_plane(&p);
}

static void test_arc(void) {
  plane_cage p = make_plane(16, 1.0, 0.0);
  ch_warp w;
  REQUIRE(build_close(&p.cage, 64, &w) == CH_OK);
  /* along u: the image is the u interval itself */
  double a[2] = {0.1, 0.3}, b[2] = {0.8, 0.3};
  CHECK_NEAR(ch_warp_arc(&w, a, b, 1.0), ch_warp_axis(&w, 0, 0.8) - ch_warp_axis(&w, 0, 0.1), 1e-14);
  CHECK_NEAR(ch_warp_arc(&w, a, b, 0.5), ch_warp_axis(&w, 0, 0.45) - ch_warp_axis(&w, 0, 0.1), 1e-14);
  CHECK_NEAR(ch_warp_arc(&w, b, a, 1.0), ch_warp_arc(&w, a, b, 1.0), 1e-14);
  /* diagonal: against a fine polyline through W */
  double c[2] = {0.05, 0.9}, d[2] = {0.7, 0.12}, poly = 0.0, prev[2] = {ch_warp_axis(&w, 0, c[0]), ch_warp_axis(&w, 1, c[1])};
  enum { STEPS = 200000 };
  for (int i = 1; i <= STEPS; i++) {
    double x = (double)i / STEPS;
    double q[2] = {ch_warp_axis(&w, 0, c[0] + x * (d[0] - c[0])), ch_warp_axis(&w, 1, c[1] + x * (d[1] - c[1]))};
    poly += hypot(q[0] - prev[0], q[1] - prev[1]);
    prev[0] = q[0];
    prev[1] = q[1];
  }
  /* the inscribed polyline is shorter, by O(step) at each knot crossing */
  double total = ch_warp_arc(&w, c, d, 1.0);
  CHECK_MSG(total >= poly && total - poly <= 1e-7, "arc %.17g polyline %.17g", total, poly);
  double worst = 0.0;
  for (int i = 0; i < 500; i++) {
    double x = ch_test_rnd();
    double y = ch_warp_arc(&w, c, d, x) / total;
    worst = fmax(worst, fabs(ch_warp_arc_inverse(&w, c, d, y) - x));
  }
  CHECK_MSG(worst <= 1e-12, "arc inverse %g", worst);
  CHECK(ch_warp_arc_inverse(&w, c, d, 0.0) == 0.0 && ch_warp_arc_inverse(&w, c, d, 1.0) == 1.0);
  /* degenerate segment */
  CHECK(ch_warp_arc(&w, a, a, 0.7) == 0.0);
  CHECK(ch_warp_arc_inverse(&w, a, a, 0.3) == 0.3);
  ch_warp_free(&w);
  free_plane(&p);
}

/* The mesh's density (ch_warp_mesh_slopes): per axis W's slope where the
 * camera sees, falling by 1.25 per interval (the smoothness) away from it,
 * down to the floor; isotropic, both slopes the geometric mean of those;
 * the mesh arc integrates it exactly. Close camera, 64 intervals, so a
 * focus cell is one interval: the visible triangles' boxes cover cells
 * 4..19 of each axis ([0.0625, 0.3125]). */
static void expect_mesh_slopes(const ch_warp *w, const double q[2], double focus) {
  double r[2], s[2];
  for (int k = 0; k < 2; k++) {
    double sk = ch_warp_axis_slope(w, k, q[k]);
    r[k] = fmax(sk * focus, fmin(sk, 0.1));
  }
  ch_warp_mesh_slopes(w, q, s);
  CHECK_MSG(fabs(s[0] - sqrt(r[0] * r[1])) <= 1e-14 && s[1] == s[0], "mesh slopes at %g %g: %.17g %.17g, not %.17g",
            q[0], q[1], s[0], s[1], sqrt(r[0] * r[1]));
}

static void test_mesh_slopes(void) {
  plane_cage p = make_plane(16, 1.0, 0.0);
  ch_warp w;
  REQUIRE(build_close(&p.cage, 64, &w) == CH_OK);
  REQUIRE(w.focus && w.focus_cell == 1 && w.focus_n == 64);
  /* inside, also on the cells' rim (the denser side): the texels' density */
  const double inside[][2] = {{0.2, 0.2}, {0.07, 0.3}, {0.3125, 0.3125}, {0.0625, 0.1}};
  for (size_t i = 0; i < sizeof inside / sizeof inside[0]; i++) {
    expect_mesh_slopes(&w, inside[i], 1.0);
    double s[2];
    ch_warp_mesh_slopes(&w, inside[i], s);
    CHECK_NEAR(s[0] * s[1],
               ch_warp_axis_slope(&w, 0, inside[i][0]) * ch_warp_axis_slope(&w, 1, inside[i][1]), 1e-12);
  }
  /* four cells right of the view, in its rows (where W keeps the view's
   * slope on v), and diagonally (Chebyshev distance 4, not 8) */
  double q[2] = {(23 + 0.5) / 64.0, 0.2}, s[2];
  expect_mesh_slopes(&w, q, pow(1.25, -4.0));
  ch_warp_mesh_slopes(&w, q, s);
  CHECK(s[1] < ch_warp_axis_slope(&w, 1, q[1]) / 2.0);
  q[0] = q[1] = (23 + 0.5) / 64.0;
  expect_mesh_slopes(&w, q, pow(1.25, -4.0));
  /* far, and in the view's column far away: the floor */
  const double far[][2] = {{0.9, 0.9}, {0.2, 0.95}, {0.95, 0.2}};
  for (size_t i = 0; i < sizeof far / sizeof far[0]; i++) {
    ch_warp_mesh_slopes(&w, far[i], s);
    CHECK_NEAR(s[0], 0.1, 1e-12);
    CHECK_NEAR(s[1], 0.1, 1e-12);
  }
  /* the mesh arc: along v through the view and beyond, the sum of the
   * slopes over the cells it crosses */
  double a[2] = {0.2 + 1.0 / 128, 0.01}, b[2] = {0.2 + 1.0 / 128, 0.93}, sum = 0.0;
  for (int j = 0; j < 64; j++) {
    double lo = fmax(a[1], j / 64.0), hi = fmin(b[1], (j + 1) / 64.0);
    if (hi <= lo) continue;
    double m[2] = {a[0], 0.5 * (lo + hi)};
    ch_warp_mesh_slopes(&w, m, s);
    sum += s[1] * (hi - lo);
  }
  double total = ch_warp_mesh_arc(&w, a, b, 1.0);
  CHECK_NEAR(total, sum, 1e-13);
  CHECK(total < ch_warp_arc(&w, a, b, 1.0));
  double worst = 0.0;
  for (int i = 0; i < 200; i++) {
    double x = ch_test_rnd();
    worst = fmax(worst, fabs(ch_warp_mesh_arc_inverse(&w, a, b, ch_warp_mesh_arc(&w, a, b, x) / total) - x));
  }
  CHECK_MSG(worst <= 1e-12, "mesh arc inverse %g", worst);
  /* isotropic: a step along u and one along v inside a cell are as long */
  double c[2] = {0.201, 0.202}, du[2] = {0.203, 0.202}, dv[2] = {0.201, 0.204};
  CHECK_NEAR(ch_warp_mesh_arc(&w, c, du, 1.0), ch_warp_mesh_arc(&w, c, dv, 1.0), 1e-15);
  ch_warp_free(&w);

  /* the identity: no focus, the mesh's slopes are 1 */
  REQUIRE(ch_warp_identity(&p.cage, 64, &w, &(ch_error){0}) == CH_OK);
  CHECK(!w.focus);
  ch_warp_mesh_slopes(&w, (const double[2]){0.3, 0.8}, s);
  CHECK(s[0] == 1.0 && s[1] == 1.0);
  double e[2] = {0.29, 0.3};
  CHECK_NEAR(ch_warp_mesh_arc(&w, c, e, 1.0), hypot(0.089, 0.098), 1e-15);
  ch_warp_free(&w);
  free_plane(&p);
}

/* Distance from q to the curve's original segments. */
static double curve_distance(const ch_curve_set *set, int curve, const double q[2]) {
  const ch_curve *c = &set->curves[curve];
  double best = INFINITY;
  for (int i = c->first_segment; i < c->first_segment + c->num_segments; i++) {
    double t;
    best = fmin(best, ch_bezier_closest(set->segments[i].p, set->segments[i].is_line, q, &t));
  }
  return sqrt(best);
}

/* The warped set is a complete set: counts, links, joints, boxes. */
static void check_structure(const ch_curve_set *in, const ch_curve_set *out) {
  CHECK(out->num_curves == in->num_curves && out->num_subpaths == in->num_subpaths);
  int total = 0;
  for (int c = 0; c < out->num_curves; c++) {
    const ch_curve *cv = &out->curves[c];
    CHECK(cv->first_segment == total);
    CHECK(cv->num_subpaths == in->curves[c].num_subpaths && cv->first_subpath == in->curves[c].first_subpath);
    CHECK(strcmp(cv->id, in->curves[c].id) == 0 && cv->width == in->curves[c].width);
    total += cv->num_segments;
    for (int i = cv->first_segment; i < cv->first_segment + cv->num_segments; i++) {
      const ch_segment *s = &out->segments[i];
      CHECK(s->curve == c);
      for (int k = 0; k < 3; k++)
        CHECK(s->p[k][0] >= cv->bbox[0] && s->p[k][0] <= cv->bbox[2] && s->p[k][1] >= cv->bbox[1] &&
              s->p[k][1] <= cv->bbox[3]);
      if (s->is_line) {
        CHECK(s->p[1][0] == 0.5 * (s->p[0][0] + s->p[2][0]));
        CHECK(s->p[1][1] == 0.5 * (s->p[0][1] + s->p[2][1]));
      }
    }
  }
  CHECK(total == out->num_segments);
  int joints = 0;
  for (int sp = 0; sp < out->num_subpaths; sp++) {
    const ch_subpath *p = &out->subpaths[sp];
    CHECK(p->closed == in->subpaths[sp].closed);
    int first = p->first_segment, last = first + p->num_segments - 1;
    for (int i = first; i <= last; i++) {
      const ch_segment *s = &out->segments[i];
      int prev = i > first ? i - 1 : p->closed ? last : -1, next = i < last ? i + 1 : p->closed ? first : -1;
      CHECK(s->prev == prev && s->next == next);
      if (next >= 0) {
        joints++;
        CHECK(memcmp(s->p[2], out->segments[next].p[0], sizeof s->p[2]) == 0);
      }
    }
  }
  CHECK(joints > 0);
}

static const char *mixed_svg =
    "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 1 1'>"
    "<path id='line' d='M 0.05 0.9 L 0.9 0.15' data-width='0.01'/>"
    "<path id='quad' d='M 0.1 0.1 Q 0.5 1.0 0.95 0.3' data-width='0.01'/>"
    "<circle id='circle' cx='0.3' cy='0.3' r='0.15' data-width='0.01'/>"
    "<path id='wave' d='M 0.1 0.6 C 0.3 0.4 0.5 0.8 0.9 0.55 L 0.9 0.7 Z' data-width='0.01'/>"
    "</svg>";

static void check_pieces_on_curves(const ch_warp *w, const ch_curve_set *in, const ch_curve_set *out,
                                   double tol) {
  double worst = 0.0;
  int unregistered = 0;
  for (int i = 0; i < out->num_segments; i++) {
    const ch_segment *s = &out->segments[i];
    for (int k = 0; k <= 10; k++) {
      double x[2], back[2];
      ch_segment_point(s, k / 10.0, x);
      unregistered += ch_warp_unmap(w, x, back) < 0;
      worst = fmax(worst, curve_distance(in, s->curve, back));
    }
  }
  CHECK(unregistered == 0);
  CHECK_MSG(worst <= tol, "pieces off the curve by %g", worst);
}

static void test_warp_curves(void) {
  plane_cage p = make_plane(16, 1.0, 0.15);
  ch_curve_set set, out;
  REQUIRE(parse(mixed_svg, &set));
  ch_warp w;
  ch_error err = {0};
  REQUIRE(build_close(&p.cage, 64, &w) == CH_OK);
  REQUIRE(w.stats.folded_triangles == 0);
  ch_warp_curve_stats st;
  REQUIRE(ch_warp_curves(&w, &set, &out, &st, &err) == CH_OK);
  CHECK(st.registered_pieces == out.num_segments);
  CHECK_MSG(out.num_segments > 2 * set.num_segments, "%d pieces from %d segments", out.num_segments,
            set.num_segments);
  /* the line, (0.05, 0.1) -> (0.9, 0.85), crosses about 0.85 x 16 columns
   * and 0.75 x 16 rows of edges (the diagonals run nearly along it) */
  CHECK_MSG(out.curves[0].num_segments >= 25, "%d line pieces", out.curves[0].num_segments);
  check_structure(&set, &out);
  check_pieces_on_curves(&w, &set, &out, 1e-9);
  /* the circle's last piece ends exactly on its first point */
  const ch_subpath *circle = &out.subpaths[out.curves[2].first_subpath];
  CHECK(circle->closed);
  const ch_segment *first = &out.segments[circle->first_segment];
  const ch_segment *last = &out.segments[circle->first_segment + circle->num_segments - 1];
  CHECK(memcmp(last->p[2], first->p[0], sizeof first->p[0]) == 0);
  /* the ends: the original ends mapped */
  double m[2];
  ch_warp_map(&w, set.segments[0].p[0], m);
  CHECK_NEAR(out.segments[0].p[0][0], m[0], 1e-15);
  CHECK_NEAR(out.segments[0].p[0][1], m[1], 1e-15);

  /* the same pieces, bit for bit, on one thread */
  int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  ch_curve_set again;
  REQUIRE(ch_warp_curves(&w, &set, &again, NULL, &err) == CH_OK);
  omp_set_num_threads(threads);
  CHECK(again.num_segments == out.num_segments);
  CHECK(memcmp(again.segments, out.segments, (size_t)out.num_segments * sizeof *out.segments) == 0);
  ch_curves_free(&again);
  ch_curves_free(&out);
  ch_warp_free(&w);

  /* the identity warp gives the original curves back, cut */
  REQUIRE(ch_warp_identity(&p.cage, 0, &w, &err) == CH_OK);
  CHECK(w.n == 256 && w.stats.max_slope[0] == 1.0);
  REQUIRE(ch_warp_curves(&w, &set, &out, NULL, &err) == CH_OK);
  check_structure(&set, &out);
  double worst = 0.0;
  for (int i = 0; i < out.num_segments; i++)
    for (int k = 0; k <= 10; k++) {
      double x[2];
      ch_segment_point(&out.segments[i], k / 10.0, x);
      worst = fmax(worst, curve_distance(&set, out.segments[i].curve, x));
    }
  CHECK_MSG(worst <= 1e-13, "identity off by %g", worst);
  for (int c = 0; c < set.num_curves; c++) {
    const ch_segment *a = &set.segments[set.curves[c].first_segment];
    const ch_segment *b = &out.segments[out.curves[c].first_segment];
    CHECK_NEAR(a->p[0][0], b->p[0][0], 1e-15);
    CHECK_NEAR(a->p[0][1], b->p[0][1], 1e-15);
  }
  ch_curves_free(&out);
  ch_warp_free(&w);
  ch_curves_free(&set);
  free_plane(&p);
}

/* A line along the quads' diagonals, through their corners: on the knot-
 * aligned cage it is cut at the 15 inner corners, and C = W there. */
static void test_curve_through_vertices(void) {
  plane_cage p = make_plane(16, 1.0, 0.0);
  ch_curve_set set, out;
  REQUIRE(parse("<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 1 1'>"
                "<path d='M 0 1 L 1 0' data-width='0.01'/></svg>",
                &set));
  ch_warp w;
  ch_error err = {0};
  REQUIRE(build_close(&p.cage, 16, &w) == CH_OK);
  REQUIRE(ch_warp_curves(&w, &set, &out, NULL, &err) == CH_OK);
  CHECK(out.num_segments == 16);
  check_structure(&set, &out);
  double worst = 0.0;
  for (int i = 0; i < out.num_segments; i++) {
    const ch_segment *s = &out.segments[i];
    CHECK(s->is_line);
    /* piece i runs from corner (i, i) to (i+1, i+1) of the knot grid */
    worst = fmax(worst, fabs(s->p[0][0] - w.wu[i]) + fabs(s->p[0][1] - w.wv[i]));
    worst = fmax(worst, fabs(s->p[2][0] - w.wu[i + 1]) + fabs(s->p[2][1] - w.wv[i + 1]));
  }
  CHECK_MSG(worst <= 1e-12, "corners off by %g", worst);
  check_pieces_on_curves(&w, &set, &out, 1e-12);
  ch_curves_free(&out);

  /* animated: moved curves re-register on the same warp */
  for (int i = 0; i < set.num_segments; i++)
    for (int k = 0; k < 3; k++) set.segments[i].p[k][0] = 0.9 * set.segments[i].p[k][0] + 0.013;
  REQUIRE(ch_warp_curves(&w, &set, &out, NULL, &err) == CH_OK);
  CHECK(out.num_segments > 16);
  check_pieces_on_curves(&w, &set, &out, 1e-12);
  ch_curves_free(&out);
  ch_warp_free(&w);
  ch_curves_free(&set);
  free_plane(&p);
}

/* The bundled curve sets, through a warp for a camera close over the
 * middle of a 32 x 32 cage: complete sets whose pieces lie on the curves. */
static void test_bundled_curves(void) {
  plane_cage p = make_plane(32, 1.0, 0.15);
  ch_camera cam;
  const double view[7] = {0.45, 0.4, 0.35, 0.5, 0.55, 0.0, 50.0};
  ch_error err = {0};
  REQUIRE(ch_camera_init(&cam, view, &err) == CH_OK);
  static const char *names[] = {"glyphs", "ornament", "spiral", "bricks", "panels"};
  for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
    char path[1024];
    snprintf(path, sizeof path, "%s/curves/%s.svg", CHISEL_MODELS, names[i]);
    ch_curve_set set, out;
    CHECK_MSG(ch_curves_read_svg(path, &set, &err) == CH_OK, "%s", err.message);
    if (err.status) continue;
    ch_warp w;
    REQUIRE(ch_warp_build(&cam, &p.cage, &set, NULL, &w, &err) == CH_OK);
    CHECK_MSG(w.stats.needy_triangles > 0 && w.stats.max_slope[0] > 1.5 && w.stats.folded_triangles == 0,
              "%s: needy %d, slope %g, folds %d", names[i], w.stats.needy_triangles, w.stats.max_slope[0],
              w.stats.folded_triangles);
    REQUIRE(ch_warp_curves(&w, &set, &out, NULL, &err) == CH_OK);
    check_structure(&set, &out);
    check_pieces_on_curves(&w, &set, &out, 1e-9);
    ch_curves_free(&out);
    ch_warp_free(&w);
    ch_curves_free(&set);
  }
  free_plane(&p);
}

static void test_bad_input(void) {
  plane_cage p = make_plane(4, 1.0, 0.0);
  ch_camera cam;
  close_camera(&cam);
  const ch_warp_desc bad[] = {{.floor = -0.1},   {.floor = 1.0},     {.floor = NAN},      {.max_slope = 0.5},
                              {.max_slope = INFINITY}, {.max_ratio = 1.0}, {.max_ratio = 0.9}, {.intervals = -1},
                              {.intervals = 70000}};
  for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
    ch_warp w;
    ch_error err = {0};
    CHECK_MSG(ch_warp_build(&cam, &p.cage, NULL, &bad[i], &w, &err) == CH_ERR_INPUT, "desc %zu", i);
    CHECK(w.wu == NULL && w.grids == NULL && w.n == 0);
    CHECK(strncmp(err.message, "warp: ", 6) == 0);
  }
  ch_warp w;
  ch_error err = {0};
  p.pos[5] = NAN;
  CHECK(ch_warp_build(&cam, &p.cage, NULL, NULL, &w, &err) == CH_ERR_INPUT);
  CHECK(ch_warp_identity(&p.cage, 0, &w, &err) == CH_ERR_INPUT);
  p.pos[5] = 0.0;
  p.uv[7] = INFINITY;
  CHECK(ch_warp_build(&cam, &p.cage, NULL, NULL, &w, &err) == CH_ERR_INPUT);
  p.uv[7] = 0.0;
  ch_warp_cage neg = {.num_triangles = -1};
  CHECK(ch_warp_build(&cam, &neg, NULL, NULL, &w, &err) == CH_ERR_INPUT);
  CHECK(ch_warp_identity(&p.cage, -3, &w, &err) == CH_ERR_INPUT);
  /* no curves at all, and an empty cage: the identity, no error */
  REQUIRE(ch_warp_build(&cam, &p.cage, NULL, NULL, &w, &err) == CH_OK);
  CHECK(w.stats.visible_triangles > 0 && w.stats.needy_triangles == 0 && w.wu[1] == 1.0 / 256);
  ch_warp_free(&w);
  ch_warp_cage empty = {0};
  REQUIRE(ch_warp_identity(&empty, 8, &w, &err) == CH_OK);
  double q[2] = {0.3, 0.6}, m[2];
  CHECK(ch_warp_map(&w, q, m) == -1);
  CHECK_NEAR(m[0], 0.3, 1e-15);
  CHECK_NEAR(m[1], 0.6, 1e-15);
  ch_warp_free(&w);
  free_plane(&p);
}

int main(void) {
  RUN(test_camera);
  RUN(test_close_camera_functions);
  RUN(test_axis_inverse);
  RUN(test_looking_away);
  RUN(test_cage_map_on_knots);
  RUN(test_cage_map_jittered);
  RUN(test_arc);
  RUN(test_mesh_slopes);
  RUN(test_warp_curves);
  RUN(test_curve_through_vertices);
  RUN(test_bundled_curves);
  RUN(test_bad_input);
  TEST_MAIN_END();
}
