/* Relief mapping and parallax occlusion mapping (shade/ch_relief) on
 * height textures of SPEC §3's h, against answers a person can check.
 *
 * - The texture is `chisel sample`'s: each texel the mean of 4 x 4 point
 *   samples of h (ch_height_render), read bilinearly; 4 bytes a texel.
 * - Straight down onto the flat top the hit is at z = 0 with the normal up;
 *   onto a v groove's slope, away from its crease and rims by two texels,
 *   the map is exact (a box filter and bilinear reads keep linear
 *   functions), so the hit is h to the search's resolution.
 * - Obliquely the searches converge: their error against the exact
 *   crossing with the map falls with the step count; relief's stays within
 *   the last bracket of its binary search.
 * - Shadows: a point on a deep box groove's floor is in the shadow of its
 *   wall for a grazing light and lit from above; the top is lit.
 * - Bad parameters give CH_ERR_INPUT naming them. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ch_curves.h"
#include "ch_height.h"
#include "ch_relief.h"
#include "ch_test.h"

typedef struct scene {
  ch_curve_set set;
  ch_height height;
} scene;

static int load(scene *s, const char *body) {
  char svg[4096];
  snprintf(svg, sizeof svg, "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>%s</svg>", body);
  ch_error err = {0};
  ch_height_desc hd = {.dci_resolution = 64};
  if (ch_curves_parse_svg(svg, strlen(svg), "test.svg", &s->set, &err) || ch_height_init(&s->height, &s->set, &hd, &err)) {
    fprintf(stderr, "%s\n", err.message);
    return 0;
  }
  return 1;
}

static void unload(scene *s) {
  ch_height_free(&s->height);
  ch_curves_free(&s->set);
}

static int build(ch_relief *r, const scene *s, int R, int K, ch_relief_method m) {
  ch_error err = {0};
  ch_relief_desc d = {.resolution = R, .steps = K, .method = m};
  if (ch_relief_build(r, &s->height, &d, &err)) {
    fprintf(stderr, "%s\n", err.message);
    return 0;
  }
  return 1;
}

/* A v groove along u = 0.5, width 0.2, depth 0.02 (slope 0.2 in u). */
static const char v_groove[] = "<path d='M 50 -10 L 50 110' data-profile='v' data-width='20' data-depth='0.02'/>";

static void test_straight_down(void) {
  scene s;
  REQUIRE(load(&s, v_groove));
  ch_relief r;
  REQUIRE(build(&r, &s, 256, 32, CH_RELIEF_RELIEF));
  CHECK(ch_relief_bytes(&r) == 4 * 256 * 256);
  CHECK_NEAR(r.hmax, 0.0, 1e-12);
  CHECK(r.hmin < -0.0195 && r.hmin > -0.02);
  ch_relief_hit h;
  double d[3] = {0, 0, -1};
  /* The top, away from the groove. */
  double o[3] = {0.2, 0.3, 1.0};
  REQUIRE(ch_relief_intersect(&r, o, d, &h));
  CHECK_NEAR(h.point[2], 0.0, 1e-12);
  CHECK_NEAR(h.normal[2], 1.0, 1e-12);
  /* The slope at u = 0.45 (10 texels from the crease, 15 from the rim):
   * h = -0.02 (1 - 2 * 0.05 / 0.2) = -0.01, to the binary search's
   * resolution (depth range / K / 2^8), normal (-0.2, 0, 1)... negated:
   * the left slope falls towards +u. */
  double o2[3] = {0.45, 0.3, 1.0};
  REQUIRE(ch_relief_intersect(&r, o2, d, &h));
  double res = (r.hmax - r.hmin) / 32 / 256;
  CHECK(fabs(h.point[2] - (-0.01)) <= res);
  CHECK_NEAR(h.normal[0] / h.normal[2], 0.2, 1e-6);
  /* POM on a copy of the same map: the same texels and range. */
  ch_relief pom;
  ch_error err = {0};
  ch_relief_desc pd = {.resolution = 256, .steps = 16, .method = CH_RELIEF_POM};
  REQUIRE(ch_relief_copy(&pom, &r, &pd, &err) == CH_OK);
  CHECK(pom.method == CH_RELIEF_POM && pom.steps == 16 && pom.hmin == r.hmin &&
        memcmp(pom.h, r.h, (size_t)256 * 256 * sizeof(float)) == 0);
  pd.resolution = 128;
  CHECK(ch_relief_copy(&pom, &r, &pd, &err) != CH_OK);
  ch_relief_free(&pom);
  ch_relief_free(&r);
  unload(&s);
}

/* Obliquely at 20 degrees across the groove: the crossing with the map,
 * found by fine marching, against relief and POM at 8 and 64 steps. */
static void test_convergence(void) {
  scene s;
  REQUIRE(load(&s, v_groove));
  double err[2][2] = {{0, 0}, {0, 0}};
  int n = 200;
  for (int m = 0; m < 2; m++)
    for (int ki = 0; ki < 2; ki++) {
      ch_relief r;
      REQUIRE(build(&r, &s, 256, ki ? 64 : 8, m ? CH_RELIEF_POM : CH_RELIEF_RELIEF));
      for (int i = 0; i < n; i++) {
        double el = 20.0 * 3.14159265358979323846 / 180.0;
        double d[3] = {cos(el), 0, -sin(el)}, o[3] = {0.3 + 0.1 * i / n, 0.2 + 0.6 * i / n, 0.05};
        ch_relief_hit h;
        REQUIRE(ch_relief_intersect(&r, o, d, &h));
        /* The reference: the first t where the ray is at or below the map,
         * on a 1e-7 grid, refined by bisection. */
        double t0 = (0.0 - o[2]) / d[2], t = t0;
        while (o[2] + t * d[2] > ch_relief_height(&r, o[0] + t * d[0], o[1] + t * d[1])) t += 1e-5;
        double a = t - 1e-5, b = t;
        for (int k = 0; k < 40; k++) {
          double c = 0.5 * (a + b);
          if (o[2] + c * d[2] > ch_relief_height(&r, o[0] + c * d[0], o[1] + c * d[1])) a = c;
          else b = c;
        }
        err[m][ki] += fabs(h.t - b) / n;
      }
      ch_relief_free(&r);
    }
  fprintf(stderr, "  mean |t - t_map| at 20 deg: relief %.2e (8 steps) %.2e (64), pom %.2e (8) %.2e (64)\n", err[0][0],
          err[0][1], err[1][0], err[1][1]);
  CHECK(err[0][1] < err[0][0] && err[1][1] < err[1][0]);
  /* Relief's answer is the last point below after 8 halvings: within a
   * 256th of a step (in t) of the crossing. */
  double step = (0.0 - (-0.02)) / sin(20.0 * 3.14159265358979323846 / 180.0);
  CHECK(err[0][0] <= step / 8 / 256 && err[0][1] <= step / 64 / 256);
  unload(&s);
}

static void test_shadows(void) {
  /* A box groove u in [0.45, 0.55], depth 0.05. */
  scene s;
  REQUIRE(load(&s, "<path d='M 50 -10 L 50 110' data-profile='box' data-width='10' data-depth='0.05'/>"));
  for (int m = 0; m < 2; m++) {
    ch_relief r;
    REQUIRE(build(&r, &s, 512, 32, m ? CH_RELIEF_POM : CH_RELIEF_RELIEF));
    ch_relief_hit h;
    double o[3] = {0.5, 0.3, 1.0}, d[3] = {0, 0, -1};
    REQUIRE(ch_relief_intersect(&r, o, d, &h));
    CHECK(fabs(h.point[2] + 0.05) < 1e-3);
    double grazing[3] = {-0.9, 0, 0.3}, up[3] = {0, 0, 1}, p[3] = {h.point[0], h.point[1], h.point[2] + 1e-7};
    double l = sqrt(0.9 * 0.9 + 0.3 * 0.3);
    grazing[0] /= l, grazing[2] /= l;
    CHECK(ch_relief_occluded(&r, p, grazing));
    CHECK(!ch_relief_occluded(&r, p, up));
    double top[3] = {0.2, 0.3, 1e-7};
    CHECK(!ch_relief_occluded(&r, top, grazing));
    ch_relief_free(&r);
  }
  unload(&s);
}

static void test_bad_input(void) {
  scene s;
  REQUIRE(load(&s, v_groove));
  ch_relief r;
  ch_error err = {0};
  ch_relief_desc d = {.resolution = 1, .steps = 8};
  CHECK(ch_relief_build(&r, &s.height, &d, &err) == CH_ERR_INPUT && strstr(err.message, "resolution 1 out of range"));
  d.resolution = 64;
  d.steps = 5000;
  CHECK(ch_relief_build(&r, &s.height, &d, &err) == CH_ERR_INPUT && strstr(err.message, "5000 steps out of range"));
  unload(&s);
}

int main(void) {
  RUN(test_straight_down);
  RUN(test_convergence);
  RUN(test_shadows);
  RUN(test_bad_input);
  TEST_MAIN_END();
}
