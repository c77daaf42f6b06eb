/* ch_camera: the one camera of the warp and the renderer. Projections are
 * checked against hand-worked numbers, rays against projections (a point
 * projected and shot back lies on its ray), and the two set-ups against
 * each other (--camera's frame is a look-at with up +z). */
#include <math.h>
#include <string.h>

#include "ch_camera.h"
#include "ch_test.h"

static double dist_to_ray(const double o[3], const double d[3], const double p[3]) {
  double e[3] = {p[0] - o[0], p[1] - o[1], p[2] - o[2]};
  double t = e[0] * d[0] + e[1] * d[1] + e[2] * d[2];
  double r[3] = {e[0] - t * d[0], e[1] - t * d[1], e[2] - t * d[2]};
  return sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
}

static void test_look_pinhole(void) {
  ch_camera cam;
  ch_error err = {0};
  /* at the origin looking along +y, up +z, 90 degrees, twice as wide as high */
  REQUIRE(ch_camera_look(&cam, (const double[3]){0, 0, 0}, (const double[3]){0, 5, 0}, (const double[3]){0, 0, 3}, 90.0,
                         0.0, 2.0, &err) == CH_OK);
  CHECK_NEAR(cam.half_height, 1.0, 1e-15);
  CHECK_NEAR(cam.half_width, 2.0, 1e-15);
  double ndc[2], depth;
  CHECK(ch_camera_project(&cam, (const double[3]){1.0, 2.0, -1.0}, ndc, &depth) == 1);
  CHECK_NEAR(depth, 2.0, 1e-15);
  CHECK_NEAR(ndc[0], 0.25, 1e-15); /* 1 / (2 x 2) */
  CHECK_NEAR(ndc[1], -0.5, 1e-15); /* -1 / (2 x 1) */
  /* the ray through the corner (1, 1): direction (2, 1, 1) normalised */
  double o[3], d[3];
  ch_camera_ray(&cam, 1.0, 1.0, o, d);
  CHECK(o[0] == 0.0 && o[1] == 0.0 && o[2] == 0.0);
  CHECK_NEAR(d[0], 2.0 / sqrt(6.0), 1e-15);
  CHECK_NEAR(d[1], 1.0 / sqrt(6.0), 1e-15);
  CHECK_NEAR(d[2], 1.0 / sqrt(6.0), 1e-15);
  /* random points in front: the ray through their projection meets them */
  double worst = 0.0;
  for (int i = 0; i < 1000; i++) {
    double p[3] = {4 * ch_test_rnd() - 2, 0.1 + 5 * ch_test_rnd(), 4 * ch_test_rnd() - 2};
    REQUIRE(ch_camera_project(&cam, p, ndc, NULL) == 1);
    ch_camera_ray(&cam, ndc[0], ndc[1], o, d);
    worst = fmax(worst, dist_to_ray(o, d, p));
  }
  CHECK_MSG(worst < 1e-14, "worst distance %g", worst);
  CHECK(ch_camera_project(&cam, (const double[3]){0, -1, 0}, ndc, &depth) == 0 && depth == -1.0);
}

static void test_look_ortho(void) {
  ch_camera cam;
  ch_error err = {0};
  /* looking down -z from (1, 1, 5), view 2 high, 1.5 times as wide */
  REQUIRE(ch_camera_look(&cam, (const double[3]){1, 1, 5}, (const double[3]){1, 1, 0}, (const double[3]){0, 1, 0}, 0.0,
                         2.0, 1.5, &err) == CH_OK);
  CHECK_NEAR(cam.half_height, 1.0, 1e-15);
  CHECK_NEAR(cam.half_width, 1.5, 1e-15);
  double o[3], d[3], ndc[2], depth;
  ch_camera_ray(&cam, 1.0, -1.0, o, d);
  /* right = forward x up = (0,0,-1) x (0,1,0) = (1, 0, 0) */
  CHECK_NEAR(o[0], 2.5, 1e-15);
  CHECK_NEAR(o[1], 0.0, 1e-15);
  CHECK_NEAR(o[2], 5.0, 1e-15);
  CHECK(d[0] == 0.0 && d[1] == 0.0 && d[2] == -1.0);
  CHECK(ch_camera_project(&cam, (const double[3]){2.5, 0.0, 1.0}, ndc, &depth) == 1);
  CHECK_NEAR(ndc[0], 1.0, 1e-15);
  CHECK_NEAR(ndc[1], -1.0, 1e-15);
  CHECK_NEAR(depth, 4.0, 1e-15);
}

/* --camera's frame is the look-at one with up +z: the same numbers. */
static void test_init_is_look(void) {
  const double v[7] = {0.15, -0.6, 0.75, 0.5, 0.5, -0.01, 40.0};
  ch_camera a, b;
  ch_error err = {0};
  REQUIRE(ch_camera_init(&a, v, &err) == CH_OK);
  REQUIRE(ch_camera_look(&b, v, v + 3, (const double[3]){0, 0, 1}, v[6], 0.0, 1.0, &err) == CH_OK);
  for (int k = 0; k < 3; k++) {
    CHECK_NEAR(a.forward[k], b.forward[k], 1e-15);
    CHECK_NEAR(a.right[k], b.right[k], 1e-15);
    CHECK_NEAR(a.up[k], b.up[k], 1e-15);
  }
  CHECK(a.half_height == b.half_height && a.half_width == a.half_height);
}

static void test_errors(void) {
  ch_camera cam;
  const double z[3] = {0, 0, 0}, y[3] = {0, 1, 0}, up[3] = {0, 0, 1};
  struct {
    const double *eye, *at, *up;
    double fov, ortho, aspect;
  } bad[] = {{z, z, up, 40, 0, 1}, {z, y, y, 40, 0, 1}, {z, y, up, 0, 0, 1},
             {z, y, up, 179, 0, 1}, {z, y, up, 40, 0, 0}, {z, y, up, 40, 1, NAN}};
  for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
    ch_error e = {0};
    CHECK(ch_camera_look(&cam, bad[i].eye, bad[i].at, bad[i].up, bad[i].fov, bad[i].ortho, bad[i].aspect, &e) ==
          CH_ERR_INPUT);
    CHECK(strncmp(e.message, "camera: ", 8) == 0);
  }
  ch_error e = {0};
  CHECK(ch_camera_look(&cam, z, y, up, 0.0, 3.0, 1.0, &e) == CH_OK); /* orthographic: no field of view */
}

int main(void) {
  RUN(test_look_pinhole);
  RUN(test_look_ortho);
  RUN(test_init_is_look);
  RUN(test_errors);
  TEST_MAIN_END();
}
