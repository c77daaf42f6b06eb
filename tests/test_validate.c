/* The validator (src/validate): the true surface traced by Embree, the
 * renderer and the metrics, checked against answers a person can work out.
 *
 * - Analytic: a straight v groove of width w along v seen orthographically
 *   from above covers w / (view width) of every row, all groove wall; seen
 *   at 30 degrees across it, its left slope covers a cos(th) - d sin(th)
 *   and the right one a cos(th) + d sin(th) of image width (a = w / 2); a
 *   box groove seen so shows w cos(th) - d sin(th) of floor and d sin(th) of
 *   far wall, a straight step of height d its wall over d sin(th). Counted
 *   per row, within a pixel per boundary.
 * - Single rays: straight down onto a v slope (depth and normal in closed
 *   form), obliquely into a box groove's far wall (point, horizontal
 *   normal, class).
 * - A mesh that is the truth (the flat plane; a plane with a box groove
 *   whose walls are exactly representable) renders with no mismatch.
 * - Convergence: doubling the truth's grid and halving its tolerance
 *   changes fewer than 0.1% of the pixels' classes, on a scene with every
 *   profile, open ends, a crossing and a step circle.
 * - The same bytes with 1 and 2 threads. */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ch_curves.h"
#include "ch_height.h"
#include "ch_mesh.h"
#include "ch_metrics.h"
#include "ch_render.h"
#include "ch_test.h"
#include "ch_trace.h"
#include "ch_truth.h"

typedef struct world {
  ch_curve_set set;
  ch_height height;
  ch_truth *truth;
  ch_trace *scene;
} world;

static int world_load(world *w, const char *body, int grid, double tol) {
  memset(w, 0, sizeof *w);
  char svg[8192];
  snprintf(svg, sizeof svg, "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>%s</svg>", body);
  ch_error err = {0};
  ch_height_desc hd = {.dci_resolution = 256, .step_method = CH_RECON_EXACT};
  ch_truth_desc td = {.grid = grid, .tolerance = tol};
  if (ch_curves_parse_svg(svg, strlen(svg), "test.svg", &w->set, &err) || ch_height_init(&w->height, &w->set, &hd, &err) ||
      ch_truth_create(&w->height, &td, &w->truth, &err) || ch_trace_create_truth(w->truth, &w->scene, &err)) {
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

/* A v groove of width 10 (0.1 UV) and depth 0.02 along u = 0.5. */
static const char v_groove[] = "<path d='M 50 -10 L 50 110' data-profile='v' data-width='10' data-depth='0.02'/>";
static const char box_groove[] = "<path d='M 50 -10 L 50 110' data-profile='box' data-width='10' data-depth='0.03'/>";

/* Orthographic, looking along (sin th, 0, -cos th) at (0.5, 0.5, 0), image
 * 0.5 x 0.5 world units, 200 x 200 pixels, one sample per pixel. */
static ch_render_camera tilted(double th_deg, int size) {
  double th = th_deg * 3.14159265358979323846 / 180.0;
  ch_render_camera c = {.target = {0.5, 0.5, 0.0}, .up = {0, 1, 0}, .ortho_height = 0.5, .width = size, .height = size,
                 .supersample = 1};
  c.eye[0] = 0.5 - 2.0 * sin(th);
  c.eye[1] = 0.5;
  c.eye[2] = 2.0 * cos(th);
  return c;
}

static long count_class(const ch_image *img, int cls) {
  long n = 0;
  const float *p = ch_image_plane(img, CH_RENDER_CLASS);
  for (size_t i = 0; i < (size_t)img->width * img->height; i++) n += (int)p[i] == cls;
  return n;
}

static void test_v_groove_from_above(void) {
  world w;
  REQUIRE(world_load(&w, v_groove, 256, 0));
  ch_render_camera cam = tilted(0.0, 200);
  ch_image img;
  ch_error err = {0};
  REQUIRE(ch_render(w.scene, w.truth, &cam, NULL, &img, NULL, &err) == CH_OK);
  /* The groove is 0.1 of the 0.5 view: 40 of 200 pixels in every row. */
  long wall = count_class(&img, CH_VIS_GROOVE_WALL), top = count_class(&img, CH_VIS_TOP);
  fprintf(stderr, "  v from above: wall %ld (expected %d), top %ld (expected %d)\n", wall, 40 * 200, top, 160 * 200);
  CHECK(labs(wall - 40 * 200) <= 2 * 200);
  CHECK(wall + top == 200 * 200);
  /* Every row alike, and the groove id is the path's. */
  const float *cls = ch_image_plane(&img, CH_RENDER_CLASS), *id = ch_image_plane(&img, CH_RENDER_ID);
  int ids_ok = 1;
  for (int p = 0; p < 200 * 200; p++) ids_ok &= (int)cls[p] != CH_VIS_GROOVE_WALL || id[p] == 0.0f;
  CHECK(ids_ok);
  ch_image_free(&img);
  world_free(&w);
}

static void test_tilted_views(void) {
  const double th = 30.0 * 3.14159265358979323846 / 180.0, a = 0.05, pix = 0.5 / 200;
  world w;
  REQUIRE(world_load(&w, v_groove, 256, 0));
  ch_render_camera cam = tilted(30.0, 200);
  ch_image img;
  ch_error err = {0};
  REQUIRE(ch_render(w.scene, w.truth, &cam, NULL, &img, NULL, &err) == CH_OK);
  const float *cls = ch_image_plane(&img, CH_RENDER_CLASS), *nx = ch_image_plane(&img, CH_RENDER_NX);
  long left = 0, right = 0;
  for (int p = 0; p < 200 * 200; p++)
    if ((int)cls[p] == CH_VIS_GROOVE_WALL) {
      if (nx[p] > 0.0f)
        left++;
      else
        right++;
    }
  double d = 0.02, el = (a * cos(th) - d * sin(th)) / pix * 200, er = (a * cos(th) + d * sin(th)) / pix * 200;
  fprintf(stderr, "  v at 30 deg: left slope %ld (expected %.0f), right %ld (expected %.0f)\n", left, el, right, er);
  CHECK(fabs(left - el) <= 2 * 200);
  CHECK(fabs(right - er) <= 2 * 200);
  ch_image_free(&img);
  world_free(&w);

  REQUIRE(world_load(&w, box_groove, 256, 0));
  REQUIRE(ch_render(w.scene, w.truth, &cam, NULL, &img, NULL, &err) == CH_OK);
  d = 0.03;
  double ef = (2 * a * cos(th) - d * sin(th)) / pix * 200, ew = d * sin(th) / pix * 200;
  long floor_n = count_class(&img, CH_VIS_GROOVE_FLOOR), wall = count_class(&img, CH_VIS_GROOVE_WALL);
  fprintf(stderr, "  box at 30 deg: floor %ld (expected %.0f), wall %ld (expected %.0f)\n", floor_n, ef, wall, ew);
  CHECK(fabs(floor_n - ef) <= 2 * 200);
  CHECK(fabs(wall - ew) <= 2 * 200);
  /* The far wall faces the eye: normal -u. */
  const float *c2 = ch_image_plane(&img, CH_RENDER_CLASS), *nx2 = ch_image_plane(&img, CH_RENDER_NX),
              *nz2 = ch_image_plane(&img, CH_RENDER_NZ);
  int normals_ok = 1;
  for (int p = 0; p < 200 * 200; p++)
    if ((int)c2[p] == CH_VIS_GROOVE_WALL) normals_ok &= fabsf(nx2[p] + 1.0f) < 1e-6f && fabsf(nz2[p]) < 1e-6f;
  CHECK(normals_ok);
  ch_image_free(&img);
  world_free(&w);

  /* A straight step along u = 0.5, written downwards in v: its left (+u)
   * is 0.02 higher. Seen at 30 degrees towards +u, the wall (facing -u)
   * covers 0.02 sin(th) of image width; the rest is top. */
  REQUIRE(world_load(&w, "<path d='M 50 -10 L 50 110' data-kind='step' data-left='0.02' data-right='0'/>", 256, 0));
  REQUIRE(ch_render(w.scene, w.truth, &cam, NULL, &img, NULL, &err) == CH_OK);
  double es = 0.02 * sin(th) / pix * 200;
  long step = count_class(&img, CH_VIS_STEP_WALL), top = count_class(&img, CH_VIS_TOP);
  fprintf(stderr, "  step at 30 deg: wall %ld (expected %.0f), top %ld (expected %.0f)\n", step, es, top,
          200 * 200 - es);
  CHECK(fabs(step - es) <= 2 * 200);
  CHECK(step + top == 200 * 200);
  ch_image_free(&img);
  world_free(&w);
}

static void test_single_rays(void) {
  world w;
  REQUIRE(world_load(&w, v_groove, 256, 0));
  ch_trace_hit h;
  /* Straight down at u = 0.52: h = -d (1 - 2 |u - 0.5| / w) = -0.012. */
  double o[3] = {0.52, 0.3, 1.0}, d[3] = {0, 0, -1};
  REQUIRE(ch_trace_intersect(w.scene, o, d, 0.0, INFINITY, &h));
  CHECK_NEAR(h.t, 1.012, 1e-9);
  CHECK_NEAR(h.point[2], -0.012, 1e-9);
  CHECK(!h.wall);
  /* Slope +2d/w = 0.4 in u: n = (-0.4, 0, 1) / sqrt(1.16). */
  CHECK_NEAR(h.normal[0], -0.4 / sqrt(1.16), 1e-9);
  CHECK_NEAR(h.normal[1], 0.0, 1e-9);
  CHECK_NEAR(h.normal[2], 1.0 / sqrt(1.16), 1e-9);
  /* Oblique, along u at 45 degrees: z = 0.05 - (u - 0.46) meets the right slope
   * z = -0.02 + 0.4 (u - 0.5) at u = 0.5 + 0.03 / 1.4. */
  double o2[3] = {0.46, 0.3, 0.05}, d2[3] = {1 / sqrt(2.0), 0, -1 / sqrt(2.0)};
  REQUIRE(ch_trace_intersect(w.scene, o2, d2, 0.0, INFINITY, &h));
  double u = 0.5 + 0.03 / 1.4;
  CHECK_NEAR(h.point[0], u, 1e-9);
  CHECK_NEAR(h.point[2], -0.02 + 0.4 * (u - 0.5), 1e-9);
  ch_vis_class cls;
  int id;
  ch_truth_classify(w.truth, h.uv, &cls, &id);
  CHECK(cls == CH_VIS_GROOVE_WALL && id == 0);
  /* Shadow rays: from the groove bottom towards the grazing left, the rim blocks. */
  double bottom[3] = {0.5, 0.3, -0.02 + 1e-7}, toward[3] = {-0.99, 0, 0.141};
  double l = sqrt(toward[0] * toward[0] + toward[2] * toward[2]);
  toward[0] /= l, toward[2] /= l;
  CHECK(ch_trace_occluded(w.scene, bottom, toward, 0.0, INFINITY));
  double up[3] = {0, 0, 1};
  CHECK(!ch_trace_occluded(w.scene, bottom, up, 0.0, INFINITY));
  world_free(&w);

  /* Into a box groove's far wall: from (0.5, 0.3, 0.03) along (1, 0, -1),
   * the wall u = 0.55 is met at z = -0.02 (above the floor, -0.03). */
  REQUIRE(world_load(&w, box_groove, 256, 0));
  double o3[3] = {0.5, 0.3, 0.03}, d3[3] = {1 / sqrt(2.0), 0, -1 / sqrt(2.0)};
  REQUIRE(ch_trace_intersect(w.scene, o3, d3, 0.0, INFINITY, &h));
  CHECK(h.wall);
  CHECK_NEAR(h.point[0], 0.55, 1e-9);
  CHECK_NEAR(h.point[2], -0.02, 1e-9);
  CHECK_NEAR(h.t, 0.05 * sqrt(2.0), 1e-9);
  CHECK_NEAR(h.normal[0], -1.0, 1e-12);
  CHECK_NEAR(h.normal[2], 0.0, 1e-12);
  double nuv[2] = {h.normal[0], h.normal[1]};
  ch_truth_classify_wall(w.truth, h.uv, nuv, &cls, &id);
  CHECK(cls == CH_VIS_GROOVE_WALL && id == 0);
  /* The same against a box groove whose far wall u = 0.5625 lies on a tile
   * border (tiles are 16 cells of 1/256): through Embree, tile by tile. */
  world w2;
  REQUIRE(world_load(&w2, "<path d='M 50 -10 L 50 110' data-profile='box' data-width='12.5' data-depth='0.05'/>", 256, 0));
  REQUIRE(ch_trace_intersect(w2.scene, o3, d3, 0.0, INFINITY, &h));
  CHECK(h.wall);
  CHECK_NEAR(h.point[0], 0.5625, 1e-9);
  CHECK_NEAR(h.point[2], 0.03 - 0.0625, 1e-9);
  world_free(&w2);
  /* Straight down into it: the floor. */
  double o4[3] = {0.52, 0.3, 1.0};
  REQUIRE(ch_trace_intersect(w.scene, o4, d, 0.0, INFINITY, &h));
  CHECK_NEAR(h.point[2], -0.03, 1e-9);
  ch_truth_classify(w.truth, h.uv, &cls, &id);
  CHECK(cls == CH_VIS_GROOVE_FLOOR && id == 0);
  world_free(&w);
}

/* A mesh given as OBJ text, read through the project's reader. */
static int mesh_from_obj(const char *text, ch_mesh *m) {
  ch_error err = {0};
  if (ch_mesh_read_memory(text, strlen(text), "obj", "inline.obj", m, &err)) {
    fprintf(stderr, "%s\n", err.message);
    return 0;
  }
  return 1;
}

static ch_render_camera oblique(void) {
  ch_render_camera c = {.eye = {0.15, -0.6, 0.75}, .target = {0.5, 0.5, -0.01}, .up = {0, 0, 1}, .fov_deg = 40,
                 .width = 160, .height = 120, .supersample = 2};
  return c;
}

static void compare_mesh(const char *what, const world *w, const ch_mesh *m, ch_metrics *mt) {
  ch_error err = {0};
  ch_trace *ms = NULL;
  ch_image a = {0}, b = {0};
  memset(mt, 0, sizeof *mt);
  mt->class_mismatch = 100;
  ch_render_camera cam = oblique();
  if (ch_trace_create_mesh(m, what, &ms, &err) || ch_render(ms, w->truth, &cam, NULL, &a, NULL, &err) ||
      ch_render(w->scene, w->truth, &cam, NULL, &b, NULL, &err) || ch_metrics_compare(&a, &b, sqrt(2.0), mt, &err))
    fprintf(stderr, "%s\n", err.message);
  fprintf(stderr,
          "  %s: class mismatch %.4f%% (groove %.4f%%), id %.4f%%, depth %.2e, normal %.2e / %.2e deg, shade rmse "
          "%.2e, shadow %.4f%%\n",
          what, mt->class_mismatch, mt->class_mismatch_groove, mt->id_mismatch, mt->depth_error, mt->normal_mean_deg,
          mt->normal_p95_deg, mt->shade_rmse, mt->shadow_mismatch);
  ch_image_free(&a);
  ch_image_free(&b);
  ch_trace_destroy(ms);
}

static void test_mesh_is_truth(void) {
  world w;
  ch_metrics mt;
  /* The flat plane, no curves. */
  /* (The SVG reader wants a curve: one far outside the square.) */
  REQUIRE(world_load(&w, "<path d='M -50 -10 L -50 110' data-width='4'/>", 64, 0));
  ch_mesh plane = {0};
  ch_error err = {0};
  REQUIRE(ch_mesh_read(CHISEL_MODELS "/plane.obj", &plane, &err) == CH_OK);
  compare_mesh("plane", &w, &plane, &mt);
  CHECK(mt.class_mismatch == 0.0 && mt.id_mismatch == 0.0 && mt.shadow_mismatch == 0.0);
  CHECK(mt.depth_error < 1e-9 && mt.normal_p95_deg < 1e-4 && mt.shade_rmse < 1e-6);
  CHECK(mt.both_hit > 0);
  ch_mesh_free(&plane);
  world_free(&w);

  /* A box groove u in [0.45, 0.55], depth 0.03: top, two vertical walls, floor. */
  REQUIRE(world_load(&w, box_groove, 256, 0));
  static const char obj[] =
      "v 0 0 0\nv 0.45 0 0\nv 0.45 1 0\nv 0 1 0\n"
      "v 0.45 0 -0.03\nv 0.55 0 -0.03\nv 0.55 1 -0.03\nv 0.45 1 -0.03\n"
      "v 0.55 0 0\nv 1 0 0\nv 1 1 0\nv 0.55 1 0\n"
      "vt 0 0\nvt 0.45 0\nvt 0.45 1\nvt 0 1\nvt 0.55 0\nvt 0.55 1\nvt 1 0\nvt 1 1\n"
      "f 1/1 2/2 3/3 4/4\n"
      "f 2/2 5/2 8/3 3/3\n"   /* left wall, facing +u */
      "f 5/2 6/5 7/6 8/3\n"   /* floor */
      "f 6/5 9/5 12/6 7/6\n"  /* right wall, facing -u */
      "f 9/5 10/7 11/8 12/6\n";
  ch_mesh m = {0};
  REQUIRE(mesh_from_obj(obj, &m));
  compare_mesh("box-groove mesh", &w, &m, &mt);
  /* Exact up to samples within float rounding (1e-7) of an edge, where
   * Embree's float traversal may pick the neighbouring face. */
  CHECK(mt.class_mismatch <= 0.05 && mt.id_mismatch <= 0.05);
  CHECK(mt.class_mismatch_groove <= 0.05 && mt.shadow_mismatch <= 0.05);
  CHECK(mt.depth_error < 1e-7);
  CHECK(mt.groove_pixels > 500);
  ch_mesh_free(&m);
  world_free(&w);
}

/* Every profile, open ends inside the square (the bevel's cap side flip),
 * a crossing, a custom profile with a jump, and a step circle. */
static const char mixed[] =
    "<path d='M -10 30 L 110 36' data-profile='v' data-width='6' data-depth='0.01'/>"
    "<path d='M 20 -10 L 28 110' data-profile='box' data-width='5' data-depth='0.006'/>"
    "<path d='M 70 80 L 62 20' data-profile='bevel' data-width='7' data-depth='0.008'/>"
    "<path d='M 10 75 Q 50 50 90 60' data-profile='ridge' data-width='4' data-depth='0.005'/>"
    "<path d='M 30 90 L 90 85' data-profile='u' data-width='5' data-depth='0.01'/>"
    "<path d='M -10 12 L 110 16' data-profile='-0.5,0 -0.2,-1 0.1,-0.4 0.1,-0.8 0.5,0' data-width='8' "
    "data-depth='0.01'/>"
    "<circle cx='45' cy='55' r='10' data-kind='step' data-left='0.008' data-right='0'/>";

static ch_render_camera grazing(void) {
  ch_render_camera c = {.eye = {0.5, -0.35, 0.22}, .target = {0.5, 0.55, -0.005}, .up = {0, 0, 1}, .fov_deg = 55,
                 .width = 160, .height = 120, .supersample = 1};
  return c;
}

static void test_convergence(void) {
  world a, b;
  REQUIRE(world_load(&a, mixed, 256, 1e-9));
  REQUIRE(world_load(&b, mixed, 512, 5e-10));
  ch_render_camera cams[2] = {oblique(), grazing()};
  for (int k = 0; k < 2; k++) {
    cams[k].supersample = 1;
    ch_image ia, ib;
    ch_error err = {0};
    ch_render_stats st;
    REQUIRE(ch_render(a.scene, a.truth, &cams[k], NULL, &ia, &st, &err) == CH_OK);
    REQUIRE(ch_render(b.scene, b.truth, &cams[k], NULL, &ib, NULL, &err) == CH_OK);
    ch_metrics mt;
    REQUIRE(ch_metrics_compare(&ia, &ib, sqrt(2.0), &mt, &err) == CH_OK);
    long classes[CH_VIS_COUNT];
    for (int c = 0; c < CH_VIS_COUNT; c++) classes[c] = count_class(&ia, c);
    fprintf(stderr,
            "  view %d: classes none/top/wall/floor/step %ld/%ld/%ld/%ld/%ld; grid x2 changes %.4f%% of classes, "
            "depth %.1e; %.2f Mrays/s (%d threads)\n",
            k, classes[0], classes[1], classes[2], classes[3], classes[4], mt.class_mismatch, mt.depth_error,
            (st.primary_rays + st.shadow_rays) / st.seconds * 1e-6, omp_get_max_threads());
    CHECK(mt.class_mismatch < 0.1);
    CHECK(classes[CH_VIS_GROOVE_WALL] > 0 && classes[CH_VIS_GROOVE_FLOOR] > 0 && classes[CH_VIS_STEP_WALL] > 0);
    ch_image_free(&ia);
    ch_image_free(&ib);
  }
  world_free(&a);
  world_free(&b);
}

static void test_threads_same_bytes(void) {
  world w;
  REQUIRE(world_load(&w, mixed, 256, 0));
  ch_render_camera cam = grazing();
  cam.width = 80;
  cam.height = 60;
  ch_image a, b;
  ch_error err = {0};
  int saved = omp_get_max_threads();
  omp_set_num_threads(1);
  REQUIRE(ch_render(w.scene, w.truth, &cam, NULL, &a, NULL, &err) == CH_OK);
  omp_set_num_threads(2);
  REQUIRE(ch_render(w.scene, w.truth, &cam, NULL, &b, NULL, &err) == CH_OK);
  omp_set_num_threads(saved);
  CHECK(memcmp(a.pixels, b.pixels, (size_t)a.width * a.height * a.num_channels * sizeof(float)) == 0);
  ch_image_free(&a);
  ch_image_free(&b);
  world_free(&w);
}

/* Metrics on renders made by hand: 10 x 10 pixels, all hit, top; the
 * method differs in 5 pixels' class (2 of them groove), its normals are
 * tilted by 30 degrees in 10 pixels, its depth is 0.1 off in 20, and its
 * shading is a constant 0.6 against 0.5: SSIM (2ab + C1) / (a^2 + b^2 + C1). */
static void test_metrics_by_hand(void) {
  ch_image a, b;
  ch_error err = {0};
  REQUIRE(ch_image_init(&a, 10, 10, CH_RENDER_NUM_LAYERS, ch_render_layer_names, &err) == CH_OK);
  REQUIRE(ch_image_init(&b, 10, 10, CH_RENDER_NUM_LAYERS, ch_render_layer_names, &err) == CH_OK);
  for (int p = 0; p < 100; p++) {
    ch_image *im[2] = {&a, &b};
    for (int k = 0; k < 2; k++) {
      ch_image_plane(im[k], CH_RENDER_COVERAGE)[p] = 1.0f;
      ch_image_plane(im[k], CH_RENDER_CLASS)[p] = CH_VIS_TOP;
      ch_image_plane(im[k], CH_RENDER_ID)[p] = -1.0f;
      ch_image_plane(im[k], CH_RENDER_NZ)[p] = 1.0f;
      ch_image_plane(im[k], CH_RENDER_DEPTH)[p] = 2.0f;
      ch_image_plane(im[k], CH_RENDER_SHADE)[p] = k ? 0.5f : 0.6f;
    }
    if (p < 3) ch_image_plane(&a, CH_RENDER_CLASS)[p] = CH_VIS_STEP_WALL;
    if (p >= 3 && p < 5) ch_image_plane(&a, CH_RENDER_CLASS)[p] = CH_VIS_GROOVE_FLOOR;
    if (p >= 50 && p < 60) {
      ch_image_plane(&a, CH_RENDER_NX)[p] = 0.5f;
      ch_image_plane(&a, CH_RENDER_NZ)[p] = (float)sqrt(0.75);
    }
    if (p >= 60 && p < 80) ch_image_plane(&a, CH_RENDER_DEPTH)[p] = 2.1f;
  }
  ch_metrics m;
  REQUIRE(ch_metrics_compare(&a, &b, 2.0, &m, &err) == CH_OK);
  CHECK_NEAR(m.class_mismatch, 5.0, 1e-12);
  CHECK(m.groove_pixels == 2);
  CHECK_NEAR(m.class_mismatch_groove, 100.0, 1e-12);
  CHECK_NEAR(m.normal_mean_deg, 10 * 30.0 / 100, 1e-4);
  CHECK_NEAR(m.normal_p95_deg, 30.0, 1e-4);
  CHECK_NEAR(m.depth_error, 20 * 0.1 / 100 / 2.0, 1e-7);
  CHECK_NEAR(m.shade_rmse, 0.1, 1e-7);
  double x = 0.6, y = 0.5, c1 = 1e-4;
  CHECK_NEAR(m.shade_ssim, (2 * x * y + c1) / (x * x + y * y + c1), 1e-7);
  REQUIRE(ch_metrics_compare(&b, &b, 2.0, &m, &err) == CH_OK);
  CHECK(m.class_mismatch == 0.0 && m.normal_p95_deg == 0.0);
  CHECK_NEAR(m.shade_ssim, 1.0, 1e-12);
  ch_image_free(&a);
  ch_image_free(&b);
}

/* The exact-normals shader on the flat plane, seen from straight above
 * (orthographic, the v groove of test_v_groove_from_above): the classes
 * and normals are the truth's (same UV under every pixel), the depth is off
 * by |h|, whose mean over the 40 groove pixels of a row (midpoints of a
 * linear profile) is d / 2: over all pixels 0.2 d / 2 = 0.002. */
static void test_normal_map_shader(void) {
  world w;
  REQUIRE(world_load(&w, v_groove, 256, 0));
  ch_mesh plane = {0};
  ch_error err = {0};
  ch_trace *base = NULL;
  REQUIRE(ch_mesh_read(CHISEL_MODELS "/plane.obj", &plane, &err) == CH_OK);
  REQUIRE(ch_trace_create_mesh(&plane, "plane.obj", &base, &err) == CH_OK);
  ch_render_camera cam = tilted(0.0, 200);
  ch_render_shader sh = ch_shader_exact_normals(w.truth);
  ch_image a, b;
  REQUIRE(ch_render_shaded(base, &sh, w.truth, &cam, NULL, &a, NULL, &err) == CH_OK);
  REQUIRE(ch_render(w.scene, w.truth, &cam, NULL, &b, NULL, &err) == CH_OK);
  ch_metrics m;
  REQUIRE(ch_metrics_compare(&a, &b, 1.0, &m, &err) == CH_OK);
  fprintf(stderr, "  normal map from above: class %.4f%%, depth %.6f (expected 0.002), normal p95 %.2e deg\n",
          m.class_mismatch, m.depth_error, m.normal_p95_deg);
  CHECK(m.class_mismatch == 0.0);
  CHECK_NEAR(m.depth_error, 0.002, 1e-6);
  CHECK(m.normal_p95_deg < 1e-3);
  ch_image_free(&a);
  ch_image_free(&b);
  ch_trace_destroy(base);
  ch_mesh_free(&plane);
  world_free(&w);
}

/* A wall hit's class does not hang on where exactly the mesh put its
 * wall: on a box groove across a raised step plateau (u 0.3..0.7, v
 * 0.2..0.8, +0.02; groove u 0.58..0.62, depth 0.01), points off each wall
 * by a float's rounding (3e-8), by a vertex placed a little off (2e-6) and
 * by a chord's sagitta (5e-5), on either side, along the wall's normal, are
 * classed as that wall: the groove's walls on and off the plateau, the
 * plateau's step wall, and the step wall inside the groove's floor. */
static void test_wall_classes(void) {
  world w;
  REQUIRE(world_load(&w,
                     "<rect x='30' y='20' width='40' height='60' data-kind='step' data-left='0' data-right='0.02'/>"
                     "<path d='M 60 -10 L 60 110' data-profile='box' data-width='4' data-depth='0.01'/>",
                     256, 0));
  static const struct {
    double uv[2], n[2];
    ch_vis_class cls;
    int id;
  } walls[] = {
      {{0.58, 0.5}, {1, 0}, CH_VIS_GROOVE_WALL, 1},  /* groove wall on the plateau */
      {{0.62, 0.1}, {-1, 0}, CH_VIS_GROOVE_WALL, 1}, /* off it */
      {{0.45, 0.8}, {0, -1}, CH_VIS_STEP_WALL, 0},   /* the plateau's edge */
      {{0.3, 0.5}, {1, 0}, CH_VIS_STEP_WALL, 0},
      {{0.6, 0.8}, {0, -1}, CH_VIS_STEP_WALL, 0},    /* the step inside the groove's floor */
      {{0.6, 0.2}, {0, 1}, CH_VIS_STEP_WALL, 0},
  };
  static const double offsets[] = {0.0, 3e-8, -3e-8, 2e-6, -2e-6, 5e-5, -5e-5};
  int wrong = 0;
  for (size_t i = 0; i < sizeof walls / sizeof walls[0]; i++)
    for (size_t k = 0; k < sizeof offsets / sizeof offsets[0]; k++) {
      double uv[2] = {walls[i].uv[0] + offsets[k] * walls[i].n[0], walls[i].uv[1] + offsets[k] * walls[i].n[1]};
      ch_vis_class cls;
      int id;
      ch_truth_classify_wall(w.truth, uv, walls[i].n, &cls, &id);
      if (cls != walls[i].cls || id != walls[i].id) {
        wrong++;
        fprintf(stderr, "  wall %zu off by %g: class %d id %d (want %d, %d)\n", i, offsets[k], (int)cls, id,
                (int)walls[i].cls, walls[i].id);
      }
    }
  CHECK(wrong == 0);
  /* Away from any wall (a mesh wall where the truth has none): the old
   * rules (groove wall inside a groove, top outside). */
  ch_vis_class cls;
  int id;
  double in[2] = {0.6, 0.1}, out[2] = {0.1, 0.1}, n[2] = {1, 0};
  ch_truth_classify_wall(w.truth, in, n, &cls, &id);
  CHECK(cls == CH_VIS_GROOVE_WALL && id == 1);
  ch_truth_classify_wall(w.truth, out, n, &cls, &id);
  CHECK(cls == CH_VIS_TOP && id == -1);
  world_free(&w);
}

/* A blurred step has no wall: h_step is smooth there, though read from
 * float texels it moves in steps of a float's rounding (5e-10 at 0.006),
 * which the truth must not take for walls (it did: horizontal normals on
 * 0.5% of a blurred cloud's pixels). */
static void test_blur_has_no_walls(void) {
  world w;
  REQUIRE(world_load(&w, "<circle cx='50' cy='50' r='25' data-kind='step' data-left='0.01' data-right='0' data-blur='4'/>",
                     256, 0));
  ch_render_camera cam = grazing();
  ch_image img;
  ch_error err = {0};
  REQUIRE(ch_render(w.scene, w.truth, &cam, NULL, &img, NULL, &err) == CH_OK);
  long walls = count_class(&img, CH_VIS_STEP_WALL), flat = 0, hits = 0;
  const float *nz = ch_image_plane(&img, CH_RENDER_NZ), *cov = ch_image_plane(&img, CH_RENDER_COVERAGE);
  for (int p = 0; p < img.width * img.height; p++) {
    hits += cov[p] > 0.0f;
    flat += cov[p] > 0.0f && nz[p] < 0.5f;
  }
  fprintf(stderr, "  blurred step: %ld of %ld pixels step wall, %ld steeper than 60 degrees\n", walls, hits, flat);
  CHECK(hits > 1000 && walls == 0 && flat == 0);
  ch_image_free(&img);
  world_free(&w);
}

int main(void) {
  RUN(test_metrics_by_hand);
  RUN(test_normal_map_shader);
  RUN(test_single_rays);
  RUN(test_v_groove_from_above);
  RUN(test_tilted_views);
  RUN(test_mesh_is_truth);
  RUN(test_wall_classes);
  RUN(test_blur_has_no_walls);
  RUN(test_convergence);
  RUN(test_threads_same_bytes);
  TEST_MAIN_END();
}
