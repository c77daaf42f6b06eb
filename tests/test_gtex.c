/* Path-based groove textures (shade/ch_gtex) against answers a person can
 * check and against two independent implementations of docs/spec.md §3's h: the
 * groove field (exact closest points, shade/ch_groove) point by point, and
 * the Embree-traced truth (src/validate) ray by ray.
 *
 * - Layout: bytes are 16 per texel of both textures; every element within
 *   half its groove's width of a point is in the list of the point's cell.
 * - h at points: the textures give the field's h (to 1e-12) and the same
 *   deciding groove and owner, on a curve set whose numbers are floats (the
 *   textures store floats; the set is rounded first so both see the same
 *   curves).
 * - Single rays with answers in closed form: a v slope straight down, a
 *   box groove's far wall, the bottom of a u groove, a rounded cap beyond
 *   an open end, a ridge's side met by a level ray, two box grooves
 *   crossing (the deeper wins), a bevel's end (the wall on its tangent
 *   line), shadows.
 * - Random rays at 1..40 degrees against the truth on a scene with every
 *   profile, open ends, corners, a crossing, raised and carved grooves and
 *   a tight circle, at G = 8, 64, 256.
 * - The paper's straight approximation of curved elements departs from the
 *   truth on a tight curve where the exact method does not.
 * - A ray past a sharp corner of two quadratic elements: its hit in closed
 *   form (the elements are straight), checked against the field's h; a
 *   nearly level ray along a curved u groove: its hit by a march of the
 *   field; a ray past a quadratic element bending by 135 degrees: the top
 *   plane, in closed form.
 * - Bad input: resolutions out of range, a step curve, a profile of too
 *   many points, a cell with too many elements.
 * - The same bytes on 1 and 2 threads. */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ch_bezier.h"
#include "ch_curves.h"
#include "ch_groove.h"
#include "ch_gtex.h"
#include "ch_height.h"
#include "ch_test.h"
#include "ch_trace.h"
#include "ch_truth.h"

static int parse(const char *body, ch_curve_set *set) {
  char svg[8192];
  snprintf(svg, sizeof svg, "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>%s</svg>", body);
  ch_error err = {0};
  if (ch_curves_parse_svg(svg, strlen(svg), "test.svg", set, &err)) {
    fprintf(stderr, "%s\n", err.message);
    return 0;
  }
  return 1;
}

/* The textures hold floats: round the set's numbers to floats so that the
 * references see the same curves. (Through a volatile: GCC 12.2 at -O2
 * vectorises "p[k][c] = (float)p[k][c]" over a 3 x 2 array into code that
 * rounds the first four values and leaves the last two alone.) */
static double to_float(double x) {
  volatile float f = (float)x;
  return f;
}

static void round_to_float(ch_curve_set *set) {
  for (int i = 0; i < set->num_segments; i++) {
    ch_segment *s = &set->segments[i];
    for (int k = 0; k < 3; k++)
      for (int c = 0; c < 2; c++) s->p[k][c] = to_float(s->p[k][c]);
    if (s->is_line)
      for (int c = 0; c < 2; c++) s->p[1][c] = 0.5 * (s->p[0][c] + s->p[2][c]);
  }
  for (int i = 0; i < set->num_curves; i++) {
    ch_curve *c = &set->curves[i];
    c->width = to_float(c->width);
    c->depth = to_float(c->depth);
    for (int k = 0; k < c->profile.num_points; k++) {
      c->profile.t[k] = to_float(c->profile.t[k]);
      c->profile.h[k] = to_float(c->profile.h[k]);
    }
    ch_curve_update_box(set, i);
  }
}

static int build(ch_gtex *g, const ch_curve_set *set, int G, int paper) {
  ch_error err = {0};
  ch_gtex_desc d = {.resolution = G, .paper = paper};
  if (ch_gtex_build(g, set, &d, "test.svg", &err)) {
    fprintf(stderr, "%s\n", err.message);
    return 0;
  }
  return 1;
}

/* Every profile, open ends inside the square (caps, the bevel's side flip
 * at its end), a closed bevel triangle (corners), a crossing, raised and
 * carved grooves crossing, a custom profile with a jump, a curved custom
 * profile and a u circle tighter than its width. */
static const char mixed[] =
    "<path d='M -10 30 L 110 36' data-profile='v' data-width='6' data-depth='0.01'/>"
    "<path d='M 20 -10 L 28 110' data-profile='box' data-width='5' data-depth='0.006'/>"
    "<path d='M 70 80 L 62 20' data-profile='bevel' data-width='7' data-depth='0.008'/>"
    "<path d='M 10 75 Q 50 50 90 60' data-profile='ridge' data-width='4' data-depth='0.005'/>"
    "<path d='M 30 90 L 90 85' data-profile='u' data-width='5' data-depth='0.01'/>"
    "<path d='M -10 12 L 110 16' data-profile='-0.5,0 -0.2,-1 0.1,-0.4 0.1,-0.8 0.5,0' data-width='8' "
    "data-depth='0.01'/>"
    "<path d='M 40 40 L 55 45 L 48 60 Z' data-profile='bevel' data-width='3' data-depth='0.007'/>"
    "<path d='M 75 40 Q 95 45 85 60 T 70 55' data-profile='-0.5,0 -0.3,-0.5 0.2,-1 0.5,0' data-width='3' "
    "data-depth='0.006'/>"
    "<circle cx='50' cy='50' r='3' data-profile='u' data-width='2' data-depth='0.008'/>"
    "<path d='M 5 50 L 35 52' data-profile='ridge' data-width='6' data-depth='0.008' data-priority='2'/>";

static void test_layout(void) {
  ch_curve_set set;
  REQUIRE(parse(mixed, &set));
  ch_gtex g;
  REQUIRE(build(&g, &set, 32, 0));
  CHECK(ch_gtex_bytes(&g) == 16 * ((size_t)32 * 32 + (size_t)g.num_texels));
  CHECK(g.num_elements == set.num_segments && g.num_grooves == set.num_curves);
  CHECK(g.zmin < -0.0099 && g.zmax > 0.0079 && g.zmax < 0.0081);
  /* Every element within w/2 of a point is listed in its cell, in order. */
  int missing = 0, unordered = 0;
  for (int k = 0; k < 20000; k++) {
    double q[2] = {ch_test_rnd(), ch_test_rnd()};
    int ci = (int)(q[1] * 32) * 32 + (int)(q[0] * 32);
    const float *gt = g.grid + 4 * (size_t)ci;
    int first = (int)gt[0], n = (int)gt[1];
    for (int i = 1; i < n; i++)
      unordered += g.data[4 * (size_t)(first + i / 4) + i % 4] <= g.data[4 * (size_t)(first + (i - 1) / 4) + (i - 1) % 4];
    for (int e = 0; e < set.num_segments; e++) {
      double t, d2 = ch_bezier_closest(set.segments[e].p, set.segments[e].is_line, q, &t);
      double r = 0.5 * set.curves[set.segments[e].curve].width;
      if (d2 >= r * r) continue;
      int found = 0;
      for (int i = 0; i < n && !found; i++) found = (int)g.data[4 * (size_t)(first + i / 4) + i % 4] == e;
      missing += !found;
    }
  }
  fprintf(stderr, "  G = 32: %zu bytes, %d data texels, longest list %d; %d elements missed, %d lists out of order\n",
          ch_gtex_bytes(&g), g.num_texels, g.max_cell_items, missing, unordered);
  CHECK(missing == 0 && unordered == 0);
  ch_gtex_free(&g);
  ch_curves_free(&set);
}

static void test_h_matches_field(void) {
  const char *sets[2] = {mixed, NULL};
  ch_curve_set glyphs;
  ch_error err = {0};
  REQUIRE(ch_curves_read_svg(CHISEL_MODELS "/curves/glyphs.svg", &glyphs, &err) == CH_OK);
  for (int which = 0; which < 2; which++) {
    ch_curve_set set;
    if (sets[which]) {
      REQUIRE(parse(sets[which], &set));
    } else {
      set = glyphs;
    }
    round_to_float(&set);
    ch_groove_field f;
    REQUIRE(ch_groove_field_init(&f, &set, &err) == CH_OK);
    for (int G = 8; G <= 128; G *= 4) {
      ch_gtex g;
      REQUIRE(build(&g, &set, G, 0));
      double worst = 0.0;
      int active = 0, owner = 0, n = 30000;
      for (int k = 0; k < n; k++) {
        double u = ch_test_rnd(), v = ch_test_rnd();
        ch_groove_sample a;
        ch_gtex_sample b;
        double ha = ch_groove_field_eval(&f, u, v, &a), hb = ch_gtex_eval(&g, u, v, &b);
        worst = fmax(worst, fabs(ha - hb));
        active += a.active != b.active;
        owner += a.owner != b.owner;
      }
      fprintf(stderr, "  %s, G = %d: max |h - field| %.2e, deciding groove differs at %d, owner at %d of %d\n",
              which ? "glyphs" : "mixed", G, worst, active, owner, n);
      CHECK(worst <= 1e-12 && active == 0 && owner == 0);
      ch_gtex_free(&g);
    }
    ch_groove_field_free(&f);
    ch_curves_free(&set);
  }
}

static int ch_gtex_dot3_positive(const double a[3], const double b[3]) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] > 0.0;
}

static int trace(const ch_gtex *g, double ox, double oy, double oz, double dx, double dy, double dz, ch_gtex_hit *h) {
  double o[3] = {ox, oy, oz}, d[3] = {dx, dy, dz};
  return ch_gtex_intersect(g, o, d, 0.0, INFINITY, h);
}

static void test_analytic_rays(void) {
  ch_curve_set set;
  ch_gtex g;
  ch_gtex_hit h;
  const double r2 = 1.0 / sqrt(2.0);
  /* A v groove along u = 0.5, width 0.1, depth 0.02: straight down at
   * u = 0.52 meets z = -0.02 (1 - 2 * 0.02 / 0.1) = -0.012; the slope is
   * 0.4 in u. */
  REQUIRE(parse("<path d='M 50 -10 L 50 110' data-profile='v' data-width='10' data-depth='0.02'/>", &set));
  REQUIRE(build(&g, &set, 16, 0));
  REQUIRE(trace(&g, 0.52, 0.3, 1.0, 0, 0, -1, &h));
  CHECK_NEAR(h.t, 1.012, 1e-9);
  CHECK(!h.wall && h.curve == 0);
  CHECK_NEAR(h.normal[0], -0.4 / sqrt(1.16), 1e-7); /* (the width is stored as a float) */
  CHECK_NEAR(h.normal[2], 1.0 / sqrt(1.16), 1e-7);
  /* At 45 degrees along u from (0.46, 0.3, 0.05): the right slope at
   * u = 0.5 + 0.03 / 1.4 (its near slope is seen edge on, masked). */
  REQUIRE(trace(&g, 0.46, 0.3, 0.05, r2, 0, -r2, &h));
  CHECK_NEAR(h.point[0], 0.5 + 0.03 / 1.4, 1e-9);
  CHECK_NEAR(h.point[2], -0.02 + 0.4 * (0.03 / 1.4), 1e-9);
  ch_gtex_free(&g);
  ch_curves_free(&set);

  /* A box groove u in [0.45, 0.55], depth 0.03: the far wall at z = -0.02
   * from (0.5, 0.3, 0.03) along (1, 0, -1), horizontal normal facing -u. */
  REQUIRE(parse("<path d='M 50 -10 L 50 110' data-profile='box' data-width='10' data-depth='0.03'/>", &set));
  REQUIRE(build(&g, &set, 16, 0));
  REQUIRE(trace(&g, 0.5, 0.3, 0.03, r2, 0, -r2, &h));
  CHECK(h.wall && h.curve == 0);
  CHECK_NEAR(h.point[0], 0.55, 1e-7); /* the wall at float(0.55) */
  CHECK_NEAR(h.point[2], -0.02, 1e-7);
  CHECK_NEAR(h.normal[0], -1.0, 1e-12);
  CHECK_NEAR(h.normal[2], 0.0, 1e-12);
  /* Straight down: the floor. */
  REQUIRE(trace(&g, 0.52, 0.3, 1.0, 0, 0, -1, &h));
  CHECK_NEAR(h.point[2], -0.03, 1e-9);
  CHECK(!h.wall && h.normal[2] == 1.0);
  /* Shadows: from the floor towards a grazing light the near wall blocks;
   * straight up nothing does. */
  double floor_pt[3] = {0.5, 0.3, -0.03 + 1e-7}, grazing[3] = {-0.9, 0, 0.3}, up[3] = {0, 0, 1};
  CHECK(ch_gtex_occluded(&g, floor_pt, grazing, 0.0, INFINITY));
  CHECK(!ch_gtex_occluded(&g, floor_pt, up, 0.0, INFINITY));
  ch_gtex_free(&g);
  ch_curves_free(&set);

  /* A u groove along v = 0.5 (width 0.1, depth 0.02): straight down at
   * s = 0.03, z = -0.02 sqrt(1 - 4 (0.3)^2) = -0.016; and a v groove
   * ending at (0.5, 0.5) (open end): beyond it at distance 0.02, the cap
   * z = -0.02 (1 - 2 * 0.2). */
  REQUIRE(parse("<path d='M -10 50 L 110 50' data-profile='u' data-width='10' data-depth='0.02'/>"
                "<path d='M 50 90 L 50 50' data-profile='v' data-width='10' data-depth='0.02'/>",
                &set));
  REQUIRE(build(&g, &set, 16, 0));
  REQUIRE(trace(&g, 0.2, 0.53, 1.0, 0, 0, -1, &h));
  CHECK_NEAR(h.point[2], -0.016, 1e-9);
  CHECK(h.curve == 0);
  /* The slope there: d/w * 4t / sqrt(1 - 4t^2) = 0.2 * 1.2 / 0.8 = 0.3 in v. */
  CHECK_NEAR(h.normal[1], -0.3 / sqrt(1.09), 1e-7);
  ch_gtex_free(&g);
  ch_curves_free(&set);
  REQUIRE(parse("<path d='M 50 10 L 50 50' data-profile='v' data-width='10' data-depth='0.02'/>", &set));
  REQUIRE(build(&g, &set, 16, 0));
  for (int k = 1; k < 6; k++) {
    double a = 3.14159265358979323846 * k / 6; /* around the end (0.5, 0.5), beyond it */
    REQUIRE(trace(&g, 0.5 + 0.02 * cos(a), 0.5 - 0.02 * sin(a), 1.0, 0, 0, -1, &h));
    CHECK_NEAR(h.point[2], -0.02 * (1.0 - 2.0 * 0.2), 1e-7);
    /* The normal is radial from the end, tilted by the slope 0.4. */
    CHECK_NEAR(h.normal[0] / h.normal[2], -0.4 * cos(a), 1e-6);
  }
  ch_gtex_free(&g);
  ch_curves_free(&set);

  /* A ridge along v = 0.5, width 0.1, height 0.02: a level ray at
   * z = 0.01 along +v meets its slope where 0.02 (1 - 2|s| / 0.1) = 0.01,
   * s = -0.025: v = 0.475, facing the ray. */
  REQUIRE(parse("<path d='M -10 50 L 110 50' data-profile='ridge' data-width='10' data-depth='0.02'/>", &set));
  REQUIRE(build(&g, &set, 16, 0));
  CHECK_NEAR(g.zmax, 0.02, 1e-6);
  REQUIRE(trace(&g, 0.3, 0.2, 0.01, 0, 1, 0, &h));
  CHECK_NEAR(h.point[1], 0.475, 1e-9);
  CHECK(!h.wall && h.normal[1] < 0.0);
  ch_gtex_free(&g);
  ch_curves_free(&set);

  /* Two box grooves crossing, depths 0.01 and 0.03: straight down in the
   * crossing, the deeper; the owner follows data-priority (the shallow
   * one's 1), the height does not. */
  REQUIRE(parse("<path d='M -10 50 L 110 50' data-profile='box' data-width='10' data-depth='0.01' data-priority='1'/>"
                "<path d='M 50 -10 L 50 110' data-profile='box' data-width='10' data-depth='0.03'/>",
                &set));
  REQUIRE(build(&g, &set, 16, 0));
  REQUIRE(trace(&g, 0.51, 0.52, 1.0, 0, 0, -1, &h));
  CHECK_NEAR(h.point[2], -0.03, 1e-9);
  CHECK(h.curve == 1 && h.owner == 0);
  /* Into the shallow groove along it, towards the deep one: its floor
   * drops at the deep groove's wall, so a ray at z = -0.02 meets the far
   * wall of the deep groove at u = 0.55. */
  REQUIRE(trace(&g, 0.2, 0.5, -0.0, r2, 0, -r2, &h));
  CHECK_NEAR(h.point[2], -0.01, 1e-7); /* first, the shallow floor */
  REQUIRE(trace(&g, 0.5, 0.5, -0.015, 1, 0, 0, &h));
  CHECK(h.wall && fabs(h.point[0] - 0.55) < 1e-7 && h.curve == 1);
  ch_gtex_free(&g);
  ch_curves_free(&set);

  /* A bevel (one-sided: left of the path, deepest on it) from (0.5, 0.2)
   * to (0.5, 0.5), going +v: its left is -u. Beyond its end the sides are
   * split by the end's tangent line u = 0.5: a level ray at z = -0.005
   * going -u at v = 0.52 (inside the cap) meets the wall there. */
  REQUIRE(parse("<path d='M 50 80 L 50 50' data-profile='bevel' data-width='10' data-depth='0.02'/>", &set));
  REQUIRE(build(&g, &set, 16, 0));
  REQUIRE(trace(&g, 0.49, 0.52, -0.005, 1, 0, 0, &h));
  CHECK(h.wall && h.curve == 0);
  CHECK_NEAR(h.point[0], 0.5, 1e-9);
  CHECK_NEAR(h.normal[0], -1.0, 1e-9);
  /* On the left of the path, inside the cap: h from the distance to the
   * end, 0.02 (1 - 2 |s| / 0.1) deep. */
  CHECK_NEAR(ch_gtex_eval(&g, 0.49, 0.52, NULL), -0.02 * (1.0 - 2.0 * sqrt(0.0005) / 0.1), 1e-9);
  CHECK(ch_gtex_eval(&g, 0.51, 0.52, NULL) == 0.0);
  ch_gtex_free(&g);
  ch_curves_free(&set);
}

typedef struct world {
  ch_curve_set set;
  ch_height height;
  ch_truth *truth;
  ch_trace *scene;
} world;

static int world_load(world *w, const char *body) {
  memset(w, 0, sizeof *w);
  ch_error err = {0};
  ch_height_desc hd = {.dci_resolution = 64, .step_method = CH_RECON_EXACT};
  ch_truth_desc td = {.grid = 512};
  if (!parse(body, &w->set)) return 0;
  round_to_float(&w->set);
  if (ch_height_init(&w->height, &w->set, &hd, &err) || ch_truth_create(&w->height, &td, &w->truth, &err) ||
      ch_trace_create_truth(w->truth, &w->scene, &err)) {
    fprintf(stderr, "%s\n", err.message);
    return 0;
  }
  return 1;
}

static void world_free(world *w) {
  ch_trace_destroy(w->scene);
  ch_truth_destroy(w->truth);
  ch_height_free(&w->height);
  ch_curves_free(&w->set);
}

/* Random rays (from 0.05..0.35 above the square, 1..41 degrees below the
 * horizon) against the truth: the number whose hit differs by more than
 * 1e-6 in t (or hits one and misses the other), or whose wall flag does. */
static int normal_differ;
static void against_truth(const world *w, const ch_gtex *g, int n, int *differ, int *walls, int *wall_differ) {
  *differ = *walls = *wall_differ = 0;
  normal_differ = 0;
  for (int i = 0; i < n; i++) {
    double o[3] = {ch_test_rnd(), ch_test_rnd(), 0.05 + 0.3 * ch_test_rnd()};
    double a = 2.0 * 3.14159265358979323846 * ch_test_rnd(), el = (1.0 + 40.0 * ch_test_rnd()) * 3.14159265358979323846 / 180.0;
    double d[3] = {cos(a) * cos(el), sin(a) * cos(el), -sin(el)};
    ch_trace_hit th;
    ch_gtex_hit gh;
    int ht = ch_trace_intersect(w->scene, o, d, 0.0, INFINITY, &th), hg = ch_gtex_intersect(g, o, d, 0.0, INFINITY, &gh);
    if (ht != hg || (ht && fabs(th.t - gh.t) > 1e-6)) {
      (*differ)++;
      continue;
    }
    if (!ht) continue;
    *walls += th.wall;
    *wall_differ += th.wall != gh.wall;
    /* Normals within 0.1 degree (the truth's walls face either way). */
    double dot = th.normal[0] * gh.normal[0] + th.normal[1] * gh.normal[1] + th.normal[2] * gh.normal[2];
    normal_differ += (th.wall ? fabs(dot) : dot) < cos(0.1 * 3.14159265358979323846 / 180.0);
  }
}

static void test_against_truth(void) {
  world w;
  REQUIRE(world_load(&w, mixed));
  for (int G = 8; G <= 256; G *= 8) {
    ch_gtex g;
    REQUIRE(build(&g, &w.set, G, 0));
    int differ, walls, wall_differ, n = 6000;
    against_truth(&w, &g, n, &differ, &walls, &wall_differ);
    fprintf(stderr, "  G = %d: %d of %d rays differ from the truth (t beyond 1e-6), walls %d (%d differ), normals %d\n", G,
            differ, n, walls, wall_differ, normal_differ);
    /* The truth samples along the ray and may miss a sliver thinner than
     * its probes (a ray grazing a rim): allow 1 in 2000. */
    CHECK(differ <= n / 2000 && wall_differ == 0 && walls > 20 && normal_differ <= n / 2000);
    ch_gtex_free(&g);
  }
  world_free(&w);
}

/* A u groove around a circle of radius 0.02 and width 0.03 (its inner
 * half wider than the radius: points near the centre have feet all
 * around): the paper's tangent lines go wrong, the exact method does not. */
static void test_paper_approximation(void) {
  world w;
  REQUIRE(world_load(&w, "<circle cx='50' cy='50' r='2' data-profile='u' data-width='3' data-depth='0.01'/>"
                         "<circle cx='30' cy='30' r='8' data-profile='v' data-width='2' data-depth='0.01'/>"));
  ch_gtex exact, paper;
  REQUIRE(build(&exact, &w.set, 16, 0));
  REQUIRE(build(&paper, &w.set, 16, 1));
  int n = 6000, de, dp, walls, wd;
  against_truth(&w, &exact, n, &de, &walls, &wd);
  against_truth(&w, &paper, n, &dp, &walls, &wd);
  fprintf(stderr, "  tight circles: exact %d, paper's tangent lines %d of %d rays off the truth\n", de, dp, n);
  CHECK(de <= n / 2000 && dp > 20 * (de + 1));
  ch_gtex_free(&exact);
  ch_gtex_free(&paper);
  world_free(&w);
}

/* A v groove along two quadratic elements (control points on their chords,
 * so both are the straight arms (0.6, 0.7)-(0.5, 0.5)-(0.4, 0.7), width
 * 0.04, depth 0.01) meeting at a sharp corner: the arms turn by 127
 * degrees, more than a right angle. The ray from (0.47, 0.6, 0.005) along
 * (0.4, -0.9, -0.12) stays more than w/2 = 0.02 from the right arm and
 * from the corner up to its hit on the left arm's near facet, where
 * s = (0.1 t - 0.04) / sqrt(5) (left of the arm positive) and h = -d (1 -
 * 2 |s| / w): 0.005 - 0.12 t = -0.01 + 0.5 (0.04 - 0.1 t) / sqrt(5), t =
 * (0.015 - 0.02 / sqrt(5)) / (0.12 - 0.05 / sqrt(5)) = 0.0620214. Past
 * the hit the ray crosses the left arm's normal line at the corner on the
 * right arm's outer side, where docs/spec.md §3's sector rule has the
 * other sign than the arm's own side: the crossing was lost and the hit
 * came at a grid cell's entry (t = 0.075 at u = 0.5 for G = 4..32, a
 * point above the surface at t = 0.059 for G = 64). The field's
 * h along the ray (an independent implementation) agrees: above before,
 * below after. */
static void test_sharp_corner_of_quadratics(void) {
  ch_curve_set set;
  ch_error err = {0};
  REQUIRE(parse("<path d='M 60 30 Q 55 40 50 50 Q 45 40 40 30' data-profile='v' data-width='4' data-depth='0.01'/>",
                &set));
  /* the reader stores straight quadratics as lines (their control points
   * are the midpoints); this is a test of the quadratic branch */
  REQUIRE(set.num_segments == 2 && set.segments[0].is_line && set.segments[1].is_line);
  set.segments[0].is_line = set.segments[1].is_line = 0;
  round_to_float(&set);
  ch_groove_field f;
  REQUIRE(ch_groove_field_init(&f, &set, &err) == CH_OK);
  const double o[3] = {0.47, 0.6, 0.005}, d[3] = {0.4, -0.9, -0.12}, s5 = sqrt(5.0);
  const double t_exact = (0.015 - 0.02 / s5) / (0.12 - 0.05 / s5);
  for (int G = 4; G <= 64; G *= 2) {
    ch_gtex g;
    REQUIRE(build(&g, &set, G, 0));
    ch_gtex_hit h;
    REQUIRE(ch_gtex_intersect(&g, o, d, 0.0, INFINITY, &h));
    fprintf(stderr, "  sharp corner, G = %d: hit t = %.9f (exact %.9f), curve %d\n", G, h.t, t_exact, h.curve);
    /* (The corners and the width are floats: 1e-7.) */
    CHECK_NEAR(h.t, t_exact, 1e-7);
    CHECK(h.curve == 0 && !h.wall);
    ch_gtex_free(&g);
  }
  for (int k = 1; k <= 1000; k++) {
    double t = t_exact * k / 1000.0 * 0.9999, z = o[2] + t * d[2];
    CHECK(z > ch_groove_field_eval(&f, o[0] + t * d[0], o[1] + t * d[1], NULL));
  }
  const double after = t_exact * 1.0001;
  CHECK(o[2] + after * d[2] < ch_groove_field_eval(&f, o[0] + after * d[0], o[1] + after * d[1], NULL));
  ch_groove_field_free(&f);
  ch_curves_free(&set);
}

/* The first t in [0, t1] where the ray is on or below the field's h (an
 * implementation of docs/spec.md §3 independent of the textures): a march
 * in steps of 1e-5, then bisection. -1 if none. */
static double march_field(const ch_groove_field *f, const double o[3], const double d[3], double t1) {
  double prev = 0.0;
  for (double t = 0.0; t <= t1; t += 1e-5) {
    if (o[2] + t * d[2] <= ch_groove_field_eval(f, o[0] + t * d[0], o[1] + t * d[1], NULL)) {
      double a = prev, b = t;
      for (int i = 0; i < 60; i++) {
        double m = 0.5 * (a + b);
        if (o[2] + m * d[2] <= ch_groove_field_eval(f, o[0] + m * d[0], o[1] + m * d[1], NULL)) b = m;
        else a = m;
      }
      return b;
    }
    prev = t;
  }
  return -1.0;
}

/* A u groove (width 0.04, depth 0.01) along the arch (0.2, 0.5) - (0.5,
 * 0.8) - (0.8, 0.5), one quadratic element, and a ray 2.6 degrees below
 * level along its chord under the apex, from inside the groove: it
 * crosses the curve twice, so on the side the curve turns to the
 * ellipse's function (z/d)^2 + (2s/w)^2 - 1 is not convex along it and
 * has several roots where its ends change sign once; the last was taken
 * and the hit (on the far wall, before the ray's second crossing of the
 * curve) came 0.007 late. Its t is the field's, by a march. */
static void test_level_ray_along_curved_u(void) {
  ch_curve_set set;
  ch_error err = {0};
  REQUIRE(parse("<path d='M 20 50 Q 50 20 80 50' data-profile='u' data-width='4' data-depth='0.01'/>", &set));
  round_to_float(&set);
  ch_groove_field f;
  REQUIRE(ch_groove_field_init(&f, &set, &err) == CH_OK);
  const double o[3] = {0.4, 0.645, 0.003}, d[3] = {1.0, -0.13, -0.045};
  double t_march = march_field(&f, o, d, 0.5);
  REQUIRE(t_march > 0.0);
  for (int G = 4; G <= 64; G *= 4) {
    ch_gtex g;
    REQUIRE(build(&g, &set, G, 0));
    ch_gtex_hit h;
    REQUIRE(ch_gtex_intersect(&g, o, d, 0.0, INFINITY, &h));
    fprintf(stderr, "  level ray along a curved u groove, G = %d: hit t = %.9f (the field's %.9f)\n", G, h.t, t_march);
    CHECK_NEAR(h.t, t_march, 1e-9);
    CHECK(h.curve == 0 && !h.wall);
    ch_gtex_free(&g);
  }
  ch_groove_field_free(&f);
  ch_curves_free(&set);
}

/* A v groove (width 0.02) along (0.2, 0.5) - (0.5, 0.8) - (0.8, 0.5) and
 * on, smoothly, along (0.8, 0.5) - (1.1, 0.2) - (0.95, 0.2): the second
 * element bends by 135 degrees, its start lies beyond its end's normal
 * line (u = 0.95), and the half-planes of its ends' normal lines, taken
 * as where its feet are, held none of its band. The ray from (0.98, 0.5,
 * 0.0013) along (-1, -0.25, -0.01) crosses the base plane at t = 0.13,
 * (0.85, 0.4675), outside the band: there it meets the top (the field's
 * h is 0 there and below the ray before). It was taken past the band's
 * edge, to the next grid cell's entry. */
static void test_element_bending_past_a_right_angle(void) {
  ch_curve_set set;
  ch_error err = {0};
  REQUIRE(parse("<path d='M 20 50 Q 50 20 80 50 T 95 80' data-profile='v' data-width='2' data-depth='0.004'/>", &set));
  REQUIRE(set.num_segments == 2 && !set.segments[1].is_line);
  round_to_float(&set);
  ch_groove_field f;
  REQUIRE(ch_groove_field_init(&f, &set, &err) == CH_OK);
  const double o[3] = {0.98, 0.5, 0.0013}, d[3] = {-1.0, -0.25, -0.01};
  CHECK(ch_groove_field_eval(&f, 0.85, 0.4675, NULL) == 0.0);
  CHECK_NEAR(march_field(&f, o, d, 0.5), 0.13, 1e-9);
  for (int G = 4; G <= 64; G *= 2) {
    ch_gtex g;
    REQUIRE(build(&g, &set, G, 0));
    ch_gtex_hit h;
    REQUIRE(ch_gtex_intersect(&g, o, d, 0.0, INFINITY, &h));
    fprintf(stderr, "  element bending by 135 degrees, G = %d: hit t = %.9f (0.13), curve %d\n", G, h.t, h.curve);
    CHECK_NEAR(h.t, 0.13, 1e-12);
    CHECK(h.curve == -1);
    ch_gtex_free(&g);
  }
  ch_groove_field_free(&f);
  ch_curves_free(&set);
}

static void test_bad_input(void) {
  ch_curve_set set;
  ch_gtex g;
  ch_error err = {0};
  REQUIRE(parse("<path d='M 10 10 L 90 90'/>", &set));
  ch_gtex_desc d = {.resolution = 0};
  CHECK(ch_gtex_build(&g, &set, &d, "a.svg", &err) == CH_ERR_INPUT && strstr(err.message, "a.svg: groove texture: grid "
                                                                                          "resolution 0 out of range 1..4096"));
  d.resolution = 4097;
  CHECK(ch_gtex_build(&g, &set, &d, "a.svg", &err) == CH_ERR_INPUT && strstr(err.message, "4097 out of range"));
  ch_curves_free(&set);
  REQUIRE(parse("<path id='s' d='M 10 10 L 90 90' data-kind='step' data-left='0.01'/>", &set));
  d.resolution = 16;
  CHECK(ch_gtex_build(&g, &set, &d, "a.svg", &err) == CH_ERR_INPUT &&
        strstr(err.message, "a.svg: <path> 's' (line 1): a step curve, which a groove texture cannot hold"));
  ch_curves_free(&set);
  REQUIRE(parse("<path id='c' d='M 10 10 L 90 90' data-profile='-0.5,0 -0.45,-1 -0.4,0 -0.35,-1 -0.3,0 -0.25,-1 -0.2,0 "
                "-0.15,-1 -0.1,0 -0.05,-1 0,0 0.05,-1 0.1,0 0.15,-1 0.2,0 0.25,-1 0.5,0'/>",
                &set));
  CHECK(ch_gtex_build(&g, &set, &d, "a.svg", &err) == CH_ERR_INPUT &&
        strstr(err.message, "'c' (line 1): a cross-section of 17 points, more than the 16"));
  ch_curves_free(&set);
  /* 70 short grooves through one cell. */
  char body[8192] = "";
  for (int i = 0; i < 70; i++)
    snprintf(body + strlen(body), sizeof body - strlen(body), "<path d='M %d 10 L %d 20' data-width='0.5'/>", 10 + i, 10 + i);
  REQUIRE(parse(body, &set));
  d.resolution = 1;
  CHECK(ch_gtex_build(&g, &set, &d, "a.svg", &err) == CH_ERR_INPUT &&
        strstr(err.message, "a.svg: groove texture: cell (0, 0) (u 0..1, v 0..1) is crossed by 70 curve segments, more "
                            "than the 64 a cell holds: use a finer grid"));
  d.resolution = 64;
  CHECK(ch_gtex_build(&g, &set, &d, "a.svg", &err) == CH_OK);
  ch_gtex_free(&g);
  ch_curves_free(&set);
}

static void test_threads_same_bytes(void) {
  ch_curve_set set;
  ch_error err = {0};
  REQUIRE(ch_curves_read_svg(CHISEL_MODELS "/curves/ornament.svg", &set, &err) == CH_OK);
  ch_gtex a, b;
  int saved = omp_get_max_threads();
  omp_set_num_threads(1);
  REQUIRE(build(&a, &set, 128, 0));
  omp_set_num_threads(2);
  REQUIRE(build(&b, &set, 128, 0));
  omp_set_num_threads(saved);
  CHECK(a.num_texels == b.num_texels && memcmp(a.grid, b.grid, (size_t)128 * 128 * 16) == 0 &&
        memcmp(a.data, b.data, (size_t)a.num_texels * 16) == 0);
  ch_gtex_free(&a);
  ch_gtex_free(&b);
  ch_curves_free(&set);
}

/* Region sampling against the mean of 24 x 24 point samples (parallel
 * rays through the pixel's parallelogram, shadow rays for each) over
 * isolated straight grooves of every kind of cross-section: the seen and
 * the lit shares of the top, the walls and the facets agree to the point
 * samples' resolution. Where the pixel reaches an end, another groove or
 * leaves the square, the function declines (0), as the paper does. */
static void test_region_sampling(void) {
  static const char *profiles[] = {"v", "box", "u", "bevel", "-0.5,0 -0.3,-0.5 0.2,-1 0.5,0"};
  const double pi = 3.14159265358979323846;
  int declined = 0, done = 0;
  double worst = 0.0;
  for (int pi_ = 0; pi_ < 5; pi_++) {
    char body[512];
    snprintf(body, sizeof body, "<path d='M 10 48 L 90 53' data-profile='%s' data-width='6' data-depth='0.012'/>",
             profiles[pi_]);
    ch_curve_set set;
    REQUIRE(parse(body, &set));
    ch_gtex g;
    REQUIRE(build(&g, &set, 32, 0));
    for (int k = 0; k < 40; k++) {
      /* A pixel near the groove, seen from 10..70 degrees, lit from 20..80. */
      double at[2] = {0.3 + 0.4 * ch_test_rnd(), 0.505 + 0.06 * (ch_test_rnd() - 0.5)};
      double az = 2 * pi * ch_test_rnd(), el = (10 + 60 * ch_test_rnd()) * pi / 180;
      double dir[3] = {cos(az) * cos(el), sin(az) * cos(el), -sin(el)};
      double laz = 2 * pi * ch_test_rnd(), lel = (20 + 60 * ch_test_rnd()) * pi / 180;
      double L[3] = {cos(laz) * cos(lel), sin(laz) * cos(lel), sin(lel)};
      double size = 0.002 + 0.02 * ch_test_rnd(), rot = pi * ch_test_rnd();
      double du[2] = {size * cos(rot), size * sin(rot)}, dv[2] = {-0.6 * size * sin(rot), 0.6 * size * cos(rot)};
      ch_gtex_facet f[CH_GTEX_MAX_FACETS];
      int n = ch_gtex_region(&g, at, dir, du, dv, L, f);
      if (n == 0) {
        declined++;
        continue;
      }
      done++;
      /* Shares by kind: top, wall, facet; lit and unlit. */
      double region[6] = {0}, points[6] = {0}, total = 0.0;
      for (int i = 0; i < n; i++) {
        int kind = f[i].curve < 0 ? 0 : f[i].wall ? 1 : 2;
        region[2 * kind] += f[i].lit;
        region[2 * kind + 1] += f[i].weight - f[i].lit;
        total += f[i].weight;
      }
      CHECK_NEAR(total, 1.0, 1e-9);
      const int S = 24;
      for (int a = 0; a < S; a++)
        for (int b = 0; b < S; b++) {
          double x = (a + 0.5) / S - 0.5, y = (b + 0.5) / S - 0.5;
          double o[3] = {at[0] + x * du[0] + y * dv[0] - dir[0], at[1] + x * du[1] + y * dv[1] - dir[1], -dir[2]};
          ch_gtex_hit h;
          if (!ch_gtex_intersect(&g, o, dir, 0.0, INFINITY, &h)) continue;
          int kind = h.curve < 0 ? 0 : h.wall ? 1 : 2;
          double so[3];
          for (int c = 0; c < 3; c++) so[c] = h.point[c] + 1e-7 * (h.wall ? -dir[c] : h.normal[c]);
          int lit = ch_gtex_dot3_positive(h.normal, L) && !ch_gtex_occluded(&g, so, L, 0.0, INFINITY);
          points[2 * kind + !lit] += 1.0 / (S * S);
        }
      for (int c = 0; c < 6; c++) worst = fmax(worst, fabs(region[c] - points[c]));
    }
    /* Declined: at the groove's end (its cap), and beyond the square. */
    double dir[3] = {0.5, 0.3, -0.8}, L[3] = {0, 0, 1}, du[2] = {0.004, 0}, dv[2] = {0, 0.004};
    double end[2] = {0.1, 0.52}, out[2] = {0.995, 0.5};
    ch_gtex_facet f[CH_GTEX_MAX_FACETS];
    CHECK(ch_gtex_region(&g, end, dir, du, dv, L, f) == 0);
    CHECK(ch_gtex_region(&g, out, dir, du, dv, L, f) == 0);
    ch_gtex_free(&g);
    ch_curves_free(&set);
  }
  fprintf(stderr, "  region sampling on %d pixels (%d declined): largest share off the 24 x 24 point samples %.4f\n", done,
          declined, worst);
  /* The point samples' own resolution is 1/576 of a share per sample on
   * each boundary; u's chords add a little. */
  CHECK(done >= 100 && worst <= 0.02);
  /* Two grooves crossing: declined there, answered away from the crossing. */
  ch_curve_set set;
  REQUIRE(parse("<path d='M 10 50 L 90 50' data-width='4'/><path d='M 50 10 L 50 90' data-width='4'/>", &set));
  ch_gtex g;
  REQUIRE(build(&g, &set, 32, 0));
  double dir[3] = {0.5, 0.3, -0.8}, L[3] = {0, 0, 1}, du[2] = {0.004, 0}, dv[2] = {0, 0.004};
  double cross[2] = {0.5, 0.5}, away[2] = {0.25, 0.5};
  ch_gtex_facet f[CH_GTEX_MAX_FACETS];
  CHECK(ch_gtex_region(&g, cross, dir, du, dv, L, f) == 0);
  CHECK(ch_gtex_region(&g, away, dir, du, dv, L, f) > 0);
  ch_gtex_free(&g);
  ch_curves_free(&set);
}

int main(void) {
  RUN(test_layout);
  RUN(test_h_matches_field);
  RUN(test_analytic_rays);
  RUN(test_against_truth);
  RUN(test_paper_approximation);
  RUN(test_sharp_corner_of_quadratics);
  RUN(test_level_ray_along_curved_u);
  RUN(test_element_bending_past_a_right_angle);
  RUN(test_region_sampling);
  RUN(test_bad_input);
  RUN(test_threads_same_bytes);
  TEST_MAIN_END();
}
