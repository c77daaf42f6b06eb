/* ch_pipeline: the displace job as one library call. Checked against the
 * same stages called one by one (the chain docs/architecture.md follows),
 * against P = B + h N on the plane with h evaluated independently, and on
 * its errors. */
#include <stdio.h>
#include <string.h>

#include "ch_embed.h"
#include "ch_height.h"
#include "ch_pipeline.h"
#include "ch_surface.h"
#include "ch_test.h"

static const char *models(const char *name) {
  static char path[4][1024];
  static int next = 0;
  char *p = path[next++ % 4];
  snprintf(p, sizeof path[0], "%s/%s", CHISEL_MODELS, name);
  return p;
}

static int stages_seen = 0, reading_seen = 0;
static void count_stage(void *user, const char *stage, double fraction) {
  (void)user;
  (void)fraction;
  stages_seen++;
  reading_seen |= !strncmp(stage, "reading ", 8);
}

/* The pipeline's mesh is the chain's, bit for bit: read, surface, h,
 * embed to the target. */
static void test_same_as_the_stages(void) {
  const char *base = models("plane.obj"), *svg = models("curves/star.svg");
  ch_error err = {0};
  ch_progress progress = {count_stage, NULL};
  ch_displace_desc d = {.base_path = base, .curves_path = svg, .target_triangles = 20000, .resolution = 256,
                        .progress = &progress};
  ch_displace_result r;
  REQUIRE(ch_pipeline_displace(&d, &r, &err) == CH_OK);
  CHECK(stages_seen > 2 && reading_seen);
  CHECK(r.snapped && r.passes >= 1 && r.resolution == 256);
  CHECK_MSG(labs((long)r.mesh.num_faces - 20000) <= 1000, "%d triangles", r.mesh.num_faces);

  ch_mesh mesh;
  ch_curve_set set;
  ch_surface *surface = NULL;
  ch_height height = {0};
  ch_tess_result tess;
  ch_mesh chain = {0};
  ch_embed_stats stats;
  int passes = 0;
  REQUIRE(ch_mesh_read(base, &mesh, &err) == CH_OK);
  REQUIRE(ch_curves_read_svg(svg, &set, &err) == CH_OK);
  REQUIRE(ch_surface_create(&mesh, CH_SCHEME_BILINEAR, &surface, &err) == CH_OK);
  ch_height_desc hd = {.dci_resolution = 256, .step_method = CH_RECON_EXACT};
  REQUIRE(ch_height_init(&height, &set, &hd, &err) == CH_OK);
  REQUIRE(ch_embed_to_target(surface, &height, NULL, 20000, &tess, &chain, &stats, &passes, &err) == CH_OK);
  CHECK(chain.num_faces == r.mesh.num_faces && chain.num_positions == r.mesh.num_positions);
  CHECK(passes == r.passes && tess.mesh.num_faces == r.base_triangles);
  if (chain.num_positions == r.mesh.num_positions)
    CHECK(!memcmp(chain.positions, r.mesh.positions, 3 * sizeof(double) * (size_t)chain.num_positions));
  if (chain.num_corners == r.mesh.num_corners)
    CHECK(!memcmp(chain.corner_uv, r.mesh.corner_uv, sizeof(int) * (size_t)chain.num_corners));

  /* On the plane B = (u, v, 0) and N = +z: every corner's position is
   * (u, v, h(u, v)) but at walls, where h has two values. */
  long corners = 0, on_h = 0, off_uv = 0;
  for (int c = 0; c < r.mesh.num_corners; c++) {
    const double *p = &r.mesh.positions[3 * (size_t)r.mesh.corner_position[c]];
    const double *uv = &r.mesh.uvs[2 * (size_t)r.mesh.corner_uv[c]];
    corners++;
    off_uv += fabs(p[0] - uv[0]) > 1e-12 || fabs(p[1] - uv[1]) > 1e-12;
    on_h += fabs(p[2] - ch_height_eval(&height, uv[0], uv[1])) <= 1e-9;
  }
  CHECK_MSG(off_uv == 0, "%ld of %ld corners away from (u, v)", off_uv, corners);
  CHECK_MSG(on_h >= corners * 95 / 100, "%ld of %ld corners at h(u, v)", on_h, corners);
  CHECK_NEAR(r.min_h, -0.016, 1e-3); /* star.svg: v grooves 0.016 deep */
  CHECK(r.max_h <= 1e-12);
  ch_tess_free(&tess);
  ch_mesh_free(&chain);
  ch_height_free(&height);
  ch_surface_destroy(surface);
  ch_curves_free(&set);
  ch_mesh_free(&mesh);
  ch_displace_result_free(&r);
}

/* The unsnapped mesh and the maps: h channel first, the geometry image's
 * P at a texel centre is the plane's point there. */
static void test_no_snap_and_maps(void) {
  ch_error err = {0};
  ch_displace_desc d = {.base_path = models("plane.obj"),
                        .curves_path = models("curves/steps_simple.svg"),
                        .target_triangles = 8000,
                        .resolution = 64,
                        .no_snap = 1,
                        .maps = CH_DISPLACE_GEOMETRY_MAPS};
  ch_displace_result r;
  REQUIRE(ch_pipeline_displace(&d, &r, &err) == CH_OK);
  CHECK(!r.snapped && r.base_triangles == r.mesh.num_faces);
  CHECK_MSG(labs((long)r.mesh.num_faces - 8000) <= 400, "%d triangles", r.mesh.num_faces);
  REQUIRE(r.maps.width == 64 && r.maps.height == 64 && r.height.width == 64);
  CHECK(!strcmp(r.maps.names[0], "h") && !strcmp(r.maps.names[1], "P.x"));
  int px = -1, py = -1;
  for (int c = 0; c < r.maps.num_channels; c++) {
    if (!strcmp(r.maps.names[c], "P.x")) px = c;
    if (!strcmp(r.maps.names[c], "P.y")) py = c;
  }
  REQUIRE(px >= 0 && py >= 0);
  /* pixel (x, y) is UV ((x + 0.5) / 64, 1 - (y + 0.5) / 64): row 0 at v = 1 */
  size_t i = (size_t)10 * 64 + 3;
  CHECK_NEAR(ch_image_plane(&r.maps, px)[i], 3.5 / 64, 1e-6);
  CHECK_NEAR(ch_image_plane(&r.maps, py)[i], 1.0 - 10.5 / 64, 1e-6);
  CHECK(!memcmp(ch_image_plane(&r.maps, 0), ch_image_plane(&r.height, 0), 64 * 64 * sizeof(float)));
  ch_displace_exr x;
  double s = 0;
  ch_displace_exr_desc(&r, &x, &s);
  CHECK(s > 0.0 && x.desc.num_attributes == 4 && !strcmp(x.desc.luminance, "h"));
  ch_displace_result_free(&r);
}

static void test_errors(void) {
  ch_error err = {0};
  ch_displace_result r;
  ch_displace_desc d = {.base_path = models("no-such.obj"), .curves_path = models("curves/star.svg")};
  CHECK(ch_pipeline_displace(&d, &r, &err) != CH_OK);
  CHECK(strstr(err.message, "no-such.obj") != NULL);
  CHECK(r.mesh.num_faces == 0 && r.mesh.positions == NULL);
  d = (ch_displace_desc){.base_path = models("plane.obj"), .curves_path = models("curves/no-such.svg")};
  CHECK(ch_pipeline_displace(&d, &r, &err) != CH_OK);
  CHECK(strstr(err.message, "no-such.svg") != NULL);
  d = (ch_displace_desc){.base_path = models("plane.obj"), .curves_path = models("curves/star.svg"), .warp_dci = 1};
  CHECK(ch_pipeline_displace(&d, &r, &err) == CH_ERR_INPUT);
}

/* The paper's DCI in warped UV, on step curves that end and cross inside
 * the square seen close: h stays within the steps' values (0 to 0.01)
 * less the grooves' depth (0.008). */
static void test_warped_dci_range(void) {
  ch_error err = {0};
  ch_camera cam;
  const double view[7] = {0.5, 0.3, 0.3, 0.5, 0.5, 0.0, 40.0};
  REQUIRE(ch_camera_init(&cam, view, &err) == CH_OK);
  ch_displace_desc d = {.base_path = models("plane.obj"),
                        .curves_path = models("torture/crossings.svg"),
                        .target_triangles = 20000,
                        .resolution = 256,
                        .camera = &cam,
                        .warp_dci = 1};
  ch_displace_result r;
  REQUIRE(ch_pipeline_displace(&d, &r, &err) == CH_OK);
  CHECK(r.warped);
  CHECK_MSG(r.min_h >= -0.0081 && r.max_h <= 0.0101, "h in [%g, %g]", r.min_h, r.max_h);
  ch_displace_result_free(&r);
}

int main(void) {
  RUN(test_same_as_the_stages);
  RUN(test_no_snap_and_maps);
  RUN(test_errors);
  RUN(test_warped_dci_range);
  TEST_MAIN_END();
}
