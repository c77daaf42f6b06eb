/* ch_scene: the study's scene file. A scene that sets every key parses to
 * the values written (paths resolved from the file's folder, orbits
 * expanded by hand-computed rotations); each wrong key, number, name or
 * shader is CH_ERR_INPUT with one message naming the file and the key. */
#include <string.h>

#include "ch_featshade.h"
#include "ch_scene.h"
#include "ch_test.h"

static const char *const file = "scenes/a/scene.json";

static void test_good(void) {
  const char *text =
      "{\n"
      "  \"curves\": \"c.svg\", \"dci_resolution\": 256, \"truth_grid\": 128,\n"
      "  \"light\": {\"direction\": [1, 2, 3], \"ambient\": 0.5, \"albedo\": 0.25, \"specular\": 2,\n"
      "            \"shininess\": 10},\n"
      "  \"views\": [\n"
      "    {\"name\": \"top\", \"eye\": [0.5, 0.5, 2], \"target\": [0.5, 0.5, 0], \"up\": [0, 1, 0],\n"
      "     \"ortho_height\": 1.5, \"width\": 64, \"height\": 32, \"supersample\": 3},\n"
      "    {\"name\": \"o\", \"eye\": [1, 0, 0.5], \"target\": [0, 0, 0], \"fov\": 30, \"orbit\": 4}\n"
      "  ],\n"
      "  \"methods\": [\n"
      "    {\"name\": \"m\", \"mesh\": \"/abs/m.obj\", \"family\": \"meshes\"},\n"
      "    {\"name\": \"en\", \"mesh\": \"../p.obj\", \"shader\": \"exact-normals\"},\n"
      "    {\"name\": \"g\", \"mesh\": \"p.obj\", \"shader\": \"grooves\", \"resolution\": 48, \"paper\": true},\n"
      "    {\"name\": \"r\", \"mesh\": \"p.obj\", \"shader\": \"relief\", \"resolution\": 100, \"steps\": 7},\n"
      "    {\"name\": \"p\", \"mesh\": \"p.obj\", \"shader\": \"pom\", \"resolution\": 64},\n"
      "    {\"name\": \"f\", \"mesh\": \"p.obj\", \"shader\": \"featnorm-linear\", \"resolution\": 32},\n"
      "    {\"name\": \"d\", \"mesh\": \"p.obj\", \"shader\": \"msdf\", \"resolution\": 16}\n"
      "  ]\n"
      "}\n";
  ch_scene s;
  ch_error err = {0};
  REQUIRE(ch_scene_parse(file, text, &s, &err) == CH_OK);
  CHECK(!strcmp(s.curves_path, "scenes/a/c.svg"));
  CHECK(s.dci_resolution == 256 && s.truth_grid == 128);
  CHECK(s.light.direction[0] == 1 && s.light.direction[1] == 2 && s.light.direction[2] == 3);
  CHECK(s.light.ambient == 0.5 && s.light.albedo == 0.25 && s.light.specular == 2 && s.light.shininess == 10);
  REQUIRE(s.num_views == 5);
  const ch_render_camera *c = &s.views[0].camera;
  CHECK(!strcmp(s.views[0].name, "top"));
  CHECK(c->eye[2] == 2 && c->target[0] == 0.5 && c->up[0] == 0 && c->up[1] == 1 && c->up[2] == 0);
  CHECK(c->ortho_height == 1.5 && c->width == 64 && c->height == 32 && c->supersample == 3);
  /* The orbit: the eye (1, 0) turned by 90 degrees per view about the
   * vertical through the target; defaults up (0, 0, 1), 320 x 240, 2. */
  static const double ex[4] = {1, 0, -1, 0}, ey[4] = {0, 1, 0, -1};
  for (int k = 0; k < 4; k++) {
    const ch_scene_view *v = &s.views[1 + k];
    char name[16];
    snprintf(name, sizeof name, "o_%d", k);
    CHECK_MSG(!strcmp(v->name, name), "%s", v->name);
    CHECK_NEAR(v->camera.eye[0], ex[k], 1e-12);
    CHECK_NEAR(v->camera.eye[1], ey[k], 1e-12);
    CHECK(v->camera.eye[2] == 0.5 && v->camera.fov_deg == 30 && v->camera.ortho_height == 0);
    CHECK(v->camera.up[2] == 1 && v->camera.width == 320 && v->camera.height == 240 && v->camera.supersample == 2);
  }
  REQUIRE(s.num_methods == 7);
  const ch_scene_method *m = s.methods;
  CHECK(!strcmp(m[0].name, "m") && !strcmp(m[0].family, "meshes") && !strcmp(m[0].path, "/abs/m.obj"));
  CHECK(!m[0].exact_normals && !m[0].textured && m[0].featshade < 0);
  CHECK(!strcmp(m[1].family, "en") && !strcmp(m[1].path, "scenes/a/../p.obj") && m[1].exact_normals);
  CHECK(m[2].textured && m[2].tex.kind == CH_TEXRAY_GROOVES && m[2].tex.resolution == 48 && m[2].tex.paper);
  CHECK(m[3].textured && m[3].tex.kind == CH_TEXRAY_RELIEF && m[3].tex.resolution == 100 && m[3].tex.steps == 7);
  CHECK(!m[3].tex.paper && !m[3].tex.same_map);
  CHECK(m[4].textured && m[4].tex.kind == CH_TEXRAY_POM && m[4].tex.resolution == 64 && m[4].tex.steps == 32);
  CHECK(m[5].featshade == CH_FEATSHADE_LINEAR && m[5].resolution == 32 && !m[5].textured);
  CHECK(m[6].featshade == CH_FEATSHADE_MSDF && m[6].resolution == 16);
  ch_scene_free(&s);
  CHECK(s.views == NULL && s.methods == NULL && s.num_views == 0);
  ch_scene_free(&s); /* twice: nothing */
  ch_scene_free(NULL);
}

/* The smallest scene with one key's text put in: TOP adds top-level keys,
 * VIEW keys to the view, METHOD keys to a method. */
static void expect_bad(const char *top, const char *view, const char *method, const char *words) {
  /* The view's and method's keys go first: cJSON finds the first of a
   * key written twice, so they replace the defaults after them. */
  char text[2048];
  snprintf(text, sizeof text,
           "{\"curves\": \"c.svg\"%s, \"views\": [{%s%s\"name\": \"v\", \"eye\": [0, 0, 1], \"target\": [0, 0, 0],"
           " \"up\": [0, 1, 0]}], \"methods\": [{%s%s\"name\": \"m\", \"mesh\": \"p.obj\"}]}",
           top, view[0] ? view + 2 : "", view[0] ? ", " : "", method[0] ? method + 2 : "", method[0] ? ", " : "");
  ch_scene s;
  ch_error err = {0};
  ch_status st = ch_scene_parse(file, text, &s, &err);
  CHECK_MSG(st == CH_ERR_INPUT, "%s%s%s: status %d", top, view, method, (int)st);
  CHECK_MSG(!strncmp(err.message, "scenes/a/scene.json: ", 21) && strstr(err.message, words) &&
                !strchr(err.message, '\n'),
            "%s%s%s: got '%s', expected '%s'", top, view, method, err.message, words);
  if (st == CH_OK) ch_scene_free(&s);
  CHECK(s.views == NULL && s.methods == NULL && s.curves_path == NULL);
}

static void test_bad(void) {
  /* The minimal scene itself is good. */
  ch_scene s;
  ch_error err = {0};
  REQUIRE(ch_scene_parse(file, "{\"curves\": \"c.svg\", \"views\": [{\"name\": \"v\", \"eye\": [0, 0, 1], "
                         "\"target\": [0, 0, 0], \"up\": [0, 1, 0]}], \"methods\": [{\"name\": \"m\", "
                         "\"mesh\": \"p.obj\"}]}", &s, &err) == CH_OK);
  CHECK(s.num_views == 1 && s.num_methods == 1 && s.dci_resolution == 1024 && s.truth_grid == 512);
  ch_scene_free(&s);
  expect_bad(", \"colour\": 1", "", "", "unknown key 'colour'");
  expect_bad(", \"light\": {\"colour\": 1}", "", "", "light: unknown key 'colour'");
  expect_bad("", ", \"zoom\": 2", "", "views[0]: unknown key 'zoom'");
  expect_bad("", "", ", \"shade\": \"pom\"", "methods[0]: unknown key 'shade'");
  expect_bad(", \"dci_resolution\": 8", "", "", "scene.dci_resolution: expected an integer in [16, 16384]");
  expect_bad(", \"truth_grid\": 100", "", "", "scene.truth_grid: 100 is not a multiple of 16");
  expect_bad(", \"truth_grid\": \"512\"", "", "", "scene.truth_grid");
  expect_bad(", \"light\": {\"ambient\": 2}", "", "", "light.ambient: expected a number in [0, 1]");
  expect_bad(", \"light\": {\"direction\": [1, 2]}", "", "", "light.direction: expected an array of 3");
  expect_bad(", \"light\": 3", "", "", "\"light\": expected an object");
  expect_bad("", ", \"fov\": 0", "", "views[0].fov: expected a number in [0.1, 170]");
  expect_bad("", ", \"width\": 1.5", "", "views[0].width: expected an integer");
  expect_bad("", ", \"supersample\": 17", "", "views[0].supersample");
  expect_bad("", ", \"orbit\": 65", "", "views[0].orbit");
  expect_bad("", ", \"eye\": [0, 0, \"x\"]", "", "views[0].eye: expected an array of 3 finite numbers");
  expect_bad("", ", \"target\": [0, 0, 1]", "", "views[0] ('v')");
  expect_bad("", ", \"name\": \"a b\"", "", "views[0]: \"name\" must be");
  expect_bad("", "", ", \"name\": \"truth\"", "methods[0]: the name 'truth' is reserved");
  expect_bad("", "", ", \"mesh\": 3", "methods[0].mesh: expected the path");
  expect_bad("", "", ", \"family\": \"<b>\"", "methods[0].family");
  expect_bad("", "", ", \"shader\": \"phong\"", "methods[0].shader: unknown shader");
  expect_bad("", "", ", \"shader\": \"grooves\"", "methods[0].resolution: missing");
  expect_bad("", "", ", \"shader\": \"featnorm\"", "methods[0].resolution: missing");
  expect_bad("", "", ", \"shader\": \"grooves\", \"resolution\": 5000", "methods[0].resolution: expected an integer");
  expect_bad("", "", ", \"shader\": \"featnorm\", \"resolution\": 2", "methods[0].resolution: expected an integer");
  expect_bad("", "", ", \"shader\": \"relief\", \"resolution\": 64, \"steps\": 0", "methods[0].steps");
  expect_bad("", "", ", \"shader\": \"grooves\", \"resolution\": 64, \"steps\": 8", "methods[0].steps: only for");
  expect_bad("", "", ", \"shader\": \"pom\", \"resolution\": 64, \"paper\": true", "methods[0].paper: only for");
  expect_bad("", "", ", \"shader\": \"grooves\", \"resolution\": 64, \"paper\": 1", "methods[0].paper: expected true");
  expect_bad("", "", ", \"resolution\": 64", "methods[0].resolution: only for");
  /* Names used twice: a view, an orbit's view, a method. */
  ch_status st = ch_scene_parse(
      file,
      "{\"curves\": \"c.svg\", \"views\": [{\"name\": \"v\", \"eye\": [0, -1, 1], \"target\": [0, 0, 0], \"orbit\": 2},"
      " {\"name\": \"v_1\", \"eye\": [0, -1, 1], \"target\": [0, 0, 0]}]}",
      &s, &err);
  CHECK(st == CH_ERR_INPUT && strstr(err.message, "scenes/a/scene.json: views[1]: the name 'v_1' is used twice"));
  st = ch_scene_parse(file,
                      "{\"curves\": \"c.svg\", \"views\": [{\"name\": \"v\", \"eye\": [0, -1, 1], \"target\": [0, 0, 0]}],"
                      " \"methods\": [{\"name\": \"m\", \"mesh\": \"a.obj\"}, {\"name\": \"m\", \"mesh\": \"b.obj\"}]}",
                      &s, &err);
  CHECK(st == CH_ERR_INPUT && strstr(err.message, "methods[1]: the name 'm' is used twice"));
  /* Not JSON: the line of the error; not an object; no views; no curves. */
  st = ch_scene_parse(file, "{\n\"curves\": \"c.svg\",\n\"views\": [,]\n}", &s, &err);
  CHECK_MSG(st == CH_ERR_INPUT && !strcmp(err.message, "scenes/a/scene.json: line 3: not valid JSON"), "%s",
            err.message);
  st = ch_scene_parse(file, "[1, 2]", &s, &err);
  CHECK(st == CH_ERR_INPUT && strstr(err.message, "scenes/a/scene.json: the scene must be a JSON object"));
  st = ch_scene_parse(file, "{\"curves\": \"c.svg\", \"views\": []}", &s, &err);
  CHECK(st == CH_ERR_INPUT && strstr(err.message, "\"views\": expected an array of at least one view"));
  st = ch_scene_parse(file, "{\"views\": [{\"name\": \"v\", \"eye\": [0, -1, 1], \"target\": [0, 0, 0]}]}", &s, &err);
  CHECK(st == CH_ERR_INPUT && strstr(err.message, "\"curves\": expected the path of an SVG file"));
  /* Too many views once orbits are expanded. */
  char big[4096];
  int n = snprintf(big, sizeof big, "{\"curves\": \"c.svg\", \"views\": [");
  for (int i = 0; i < 5; i++)
    n += snprintf(big + n, sizeof big - (size_t)n, "%s{\"name\": \"v%d\", \"eye\": [0, -1, 1], \"target\": [0, 0, 0], "
                  "\"orbit\": 64}", i ? ", " : "", i);
  snprintf(big + n, sizeof big - (size_t)n, "]}");
  st = ch_scene_parse(file, big, &s, &err);
  CHECK_MSG(st == CH_ERR_INPUT && strstr(err.message, "at most 256 views and 32 methods (got 320 and 0)"), "%s",
            err.message);
}

int main(void) {
  RUN(test_good);
  RUN(test_bad);
  TEST_MAIN_END();
}
