/* Geometry images: every texel centre lands on the right face and point of
 * the base surface (checked against shapes known in closed form), overlaps
 * and gaps are handled, and ch_surface_locate inverts the UV map. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ch_geomimage.h"
#include "ch_mesh.h"
#include "ch_surface.h"
#include "ch_test.h"

static ch_surface *load(const char *path, ch_scheme scheme, ch_mesh *mesh) {
  ch_error err = {0};
  if (ch_mesh_read(path, mesh, &err)) {
    fprintf(stderr, "%s\n", err.message);
    return NULL;
  }
  ch_surface *s = NULL;
  if (ch_surface_create(mesh, scheme, &s, &err)) fprintf(stderr, "%s\n", err.message);
  return s;
}

/* The plane: B = (u, v, 0) at every texel centre, N = +z, full coverage. */
static void test_plane(void) {
  ch_mesh mesh;
  ch_surface *s = load(CHISEL_MODELS "/plane.obj", CH_SCHEME_BILINEAR, &mesh);
  REQUIRE(s);
  ch_geomimage gi;
  ch_error err = {0};
  REQUIRE(ch_geomimage_build(s, 96, 80, NULL, &gi, &err) == CH_OK);
  CHECK(gi.covered == 96 * 80);
  double max_err = 0;
  int face_ok = 1;
  /* 96 x 80 texels (multiples of 16): no centre falls on a face boundary. */
  for (int y = 0; y < 80; y++)
    for (int x = 0; x < 96; x++) {
      size_t i = (size_t)y * 96 + x;
      double u = (x + 0.5) / 96, v = 1 - (y + 0.5) / 80;
      max_err = fmax(max_err, fabs(gi.position[3 * i] - u) + fabs(gi.position[3 * i + 1] - v) +
                                  fabs(gi.position[3 * i + 2]) + fabs(gi.normal[3 * i + 2] - 1));
      /* 16 x 16 quads, row-major from v = 0 (the generator's layout). */
      int fx = (int)(u * 16), fy = (int)(v * 16);
      face_ok &= gi.face[i] == fy * 16 + fx;
    }
  CHECK_MSG(max_err < 1e-6, "max error %g", max_err);
  CHECK(face_ok);
  ch_geomimage_free(&gi);
  ch_surface_destroy(s);
  ch_mesh_free(&mesh);
}

/* The torus (R = 1, r = 0.35, UV seams both ways): bilinear B lies on the
 * tube within the chordal error of 48 x 24 quads; catmark's limit is
 * closer; coverage is the whole square. */
static void test_torus(void) {
  for (int scheme = 0; scheme < 2; scheme++) {
    ch_mesh mesh;
    ch_surface *s = load(CHISEL_MODELS "/torus.obj", (ch_scheme)scheme, &mesh);
    REQUIRE(s);
    ch_geomimage gi;
    ch_error err = {0};
    REQUIRE(ch_geomimage_build(s, 256, 256, NULL, &gi, &err) == CH_OK);
    CHECK(gi.covered == 256 * 256);
    double max_dev = 0, max_n = 0;
    for (size_t i = 0; i < 256 * 256; i++) {
      const float *p = &gi.position[3 * i], *n = &gi.normal[3 * i];
      double rho = hypot(p[0], p[1]);
      double d = hypot(rho - 1.0, p[2]);
      max_dev = fmax(max_dev, fabs(d - 0.35));
      /* The tube's normal points from the tube centre. */
      double c[3] = {p[0] / rho, p[1] / rho, 0};
      double e[3] = {p[0] - c[0], p[1] - c[1], p[2]};
      double len = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
      double dot = (e[0] * n[0] + e[1] * n[1] + e[2] * n[2]) / len;
      max_n = fmax(max_n, acos(fmin(1.0, dot)) * 180 / 3.14159265358979);
    }
    fprintf(stderr, "  torus %s: max distance from the tube %.2g, normal %.2g degrees\n",
            scheme ? "catmark" : "bilinear", max_dev, max_n);
    /* Bilinear: at a patch centre the sagittas of a 7.5-degree ring arc
     * (1.35 (1 - cos 3.75) = 0.0029 on the outer equator) and a 15-degree
     * tube arc (0.35 (1 - cos 7.5) = 0.003) add up: about 0.006. Catmark's
     * limit shrinks the coarse rings by about as much. */
    CHECK(max_dev < (scheme ? 0.01 : 0.0065));
    CHECK(max_n < 5.0);
    ch_geomimage_free(&gi);
    ch_surface_destroy(s);
    ch_mesh_free(&mesh);
  }
}

/* Locate inverts the UV map on quads and on the triangles' sub-faces. */
static void test_locate(void) {
  ch_mesh mesh;
  ch_surface *s = load(CHISEL_MODELS "/vase.obj", CH_SCHEME_CATMARK, &mesh);
  REQUIRE(s);
  double max_err = 0;
  int located = 0, tried = 0;
  for (int f = 0; f < ch_surface_num_faces(s); f += 7) {
    double st0[2];
    for (int k = 0; k < 3; k++) {
      /* A point inside the face's domain: near corner k, a bit inside. */
      ch_surface_corner_param(s, f, k, st0);
      double st_in[2] = {st0[0] + 0.13, st0[1] + 0.21};
      ch_surface_point sp;
      if (ch_surface_eval(s, f, st_in[0], st_in[1], &sp) != CH_OK) continue;
      tried++;
      double st[2];
      if (ch_surface_locate(s, f, sp.uv, st) != CH_OK) continue;
      located++;
      ch_surface_point back;
      ch_surface_eval(s, f, st[0], st[1], &back);
      max_err = fmax(max_err, hypot(back.uv[0] - sp.uv[0], back.uv[1] - sp.uv[1]));
    }
  }
  CHECK(tried > 100 && located == tried);
  CHECK_MSG(max_err < 1e-12, "max uv error %g", max_err);
  /* A UV outside the face: refused. */
  double st[2];
  CHECK(ch_surface_locate(s, 0, (double[2]){2.0, 2.0}, st) == CH_ERR_INPUT);
  ch_geomimage gi;
  ch_error err = {0};
  REQUIRE(ch_geomimage_build(s, 128, 128, NULL, &gi, &err) == CH_OK);
  /* The vase's charts cover 81.2% of the square (chisel info). */
  CHECK_NEAR((double)gi.covered / (128 * 128), 0.812, 0.01);
  ch_geomimage_free(&gi);
  ch_surface_destroy(s);
  ch_mesh_free(&mesh);
}

/* The planes (ch_geomimage_build_planes, what the maps' EXR holds) carry
 * exactly the geometry image's values, channel by channel, on a mesh with
 * several charts and texels outside them (the tablet); a NULL plane is
 * left alone. */
static void test_planes(void) {
  ch_mesh mesh;
  ch_surface *s = load(CHISEL_MODELS "/tablet.obj", CH_SCHEME_BILINEAR, &mesh);
  REQUIRE(s);
  enum { W = 200, H = 150 };
  ch_geomimage gi;
  ch_error err = {0};
  REQUIRE(ch_geomimage_build(s, W, H, NULL, &gi, &err) == CH_OK);
  size_t n = (size_t)W * H;
  float *planes[CH_GEOMIMAGE_CHANNELS + 2], *store = malloc((CH_GEOMIMAGE_CHANNELS + 2) * n * sizeof *store);
  REQUIRE(store);
  for (size_t i = 0; i < (CH_GEOMIMAGE_CHANNELS + 2) * n; i++) store[i] = 12345.0f;
  for (int c = 0; c < CH_GEOMIMAGE_CHANNELS + 2; c++) planes[c] = store + (size_t)c * n;
  planes[CH_GEOMIMAGE_CHANNELS + 1] = NULL; /* v: not asked for */
  long covered = 0;
  REQUIRE(ch_geomimage_build_planes(s, W, H, NULL, planes, &covered, &err) == CH_OK);
  CHECK(covered == gi.covered && covered > 0 && covered < (long)n);
  long differ = 0;
  for (size_t i = 0; i < n; i++) {
    const float want[CH_GEOMIMAGE_CHANNELS + 1] = {
        gi.position[3 * i],   gi.position[3 * i + 1], gi.position[3 * i + 2], gi.normal[3 * i], gi.normal[3 * i + 1],
        gi.normal[3 * i + 2], (float)gi.face[i],      gi.st[2 * i],           gi.st[2 * i + 1], gi.uv[2 * i]};
    for (int c = 0; c <= CH_GEOMIMAGE_CHANNELS; c++) differ += memcmp(&planes[c][i], &want[c], sizeof(float)) != 0;
  }
  CHECK_MSG(differ == 0, "%ld values differ", differ);
  long touched = 0;
  for (size_t i = 0; i < n; i++) touched += store[(CH_GEOMIMAGE_CHANNELS + 1) * n + i] != 12345.0f;
  CHECK(touched == 0);
  free(store);
  ch_geomimage_free(&gi);
  ch_surface_destroy(s);
  ch_mesh_free(&mesh);
}

int main(void) {
  RUN(test_plane);
  RUN(test_torus);
  RUN(test_locate);
  RUN(test_planes);
  TEST_MAIN_END();
}
