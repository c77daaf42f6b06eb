/* A program that uses an installed chisel through its umbrella header, one
 * call into each library: a v groove across the unit square (shade), h read
 * back where docs/spec.md §3 gives it in closed form; a one-quad base mesh
 * read from memory (mesh, OpenMesh) and evaluated on its surface (tess,
 * OpenSubdiv); a ray traced onto the true surface (validate, Embree); a
 * study scene parsed (validate, cJSON: a dependency the package finds).
 * Exit 0 only if every value matches. */
#include <chisel/chisel.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

static const char svg[] =
    "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
    "<path d='M 0 50 L 100 50' data-profile='v' data-width='10' data-depth='0.02'/></svg>";

int main(void) {
  if (strcmp(ch_version(), CH_VERSION_STRING) != 0) {
    fprintf(stderr, "library %s, headers %s\n", ch_version(), CH_VERSION_STRING);
    return 1;
  }
  ch_error err = {0};
  ch_curve_set set;
  if (ch_curves_parse_svg(svg, sizeof svg - 1, "inline.svg", &set, &err) != CH_OK) {
    fprintf(stderr, "%s\n", err.message);
    return 1;
  }
  ch_height_desc desc = {0};
  ch_height h;
  if (ch_height_init(&h, &set, &desc, &err) != CH_OK) {
    fprintf(stderr, "%s\n", err.message);
    return 1;
  }
  /* The groove runs along v = 0.5, width 0.1 UV: h = -0.02 (1 - |s| / 0.05)
   * within 0.05 of it, 0 beyond. */
  const double v[] = {0.5, 0.525, 0.49, 0.6};
  const double want[] = {-0.02, -0.01, -0.016, 0.0};
  int bad = 0;
  for (int i = 0; i < 4; i++) {
    double got = ch_height_eval(&h, 0.3, v[i]);
    printf("h(0.3, %g) = %.12f (want %g)\n", v[i], got, want[i]);
    if (fabs(got - want[i]) > 1e-12) bad = 1;
  }

  /* The unit square as one quad: B(s, t) = (s, t, 0) with uv = (s, t). */
  static const char obj[] = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                            "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n";
  ch_mesh mesh;
  ch_surface *surface = NULL;
  ch_surface_point p;
  if (ch_mesh_read_memory(obj, sizeof obj - 1, "obj", "quad.obj", &mesh, &err) != CH_OK ||
      ch_surface_create(&mesh, CH_SCHEME_BILINEAR, &surface, &err) != CH_OK ||
      ch_surface_eval(surface, 0, 0.25, 0.75, &p) != CH_OK) {
    fprintf(stderr, "%s\n", err.message);
    return 1;
  }
  printf("B(0.25, 0.75) = (%g, %g, %g), uv (%g, %g)\n", p.position[0], p.position[1], p.position[2], p.uv[0],
         p.uv[1]);
  if (fabs(p.position[0] - 0.25) + fabs(p.position[1] - 0.75) + fabs(p.position[2]) > 1e-12 ||
      fabs(p.uv[0] - 0.25) + fabs(p.uv[1] - 0.75) > 1e-12 || fabs(p.normal[2] - 1) > 1e-12)
    bad = 1;
  ch_surface_destroy(surface);
  ch_mesh_free(&mesh);

  /* Straight down onto the groove's floor line: the hit is at z = -0.02. */
  ch_truth_desc tdesc = {0};
  ch_truth *truth = NULL;
  ch_trace *scene = NULL;
  if (ch_truth_create(&h, &tdesc, &truth, &err) != CH_OK || ch_trace_create_truth(truth, &scene, &err) != CH_OK) {
    fprintf(stderr, "%s\n", err.message);
    return 1;
  }
  const double org[3] = {0.3, 0.5, 1}, dir[3] = {0, 0, -1};
  ch_trace_hit hit;
  int hits = ch_trace_intersect(scene, org, dir, 0, 10, &hit);
  printf("ray hit %d at t = %.9f (want 1.02)\n", hits, hits ? hit.t : 0.0);
  if (!hits || fabs(hit.t - 1.02) > 1e-8) bad = 1;
  ch_trace_destroy(scene);
  ch_truth_destroy(truth);
  ch_height_free(&h);
  ch_curves_free(&set);

  /* A study scene: its curves resolved from the scene file's folder. */
  ch_scene sc;
  if (ch_scene_parse("dir/scene.json",
                     "{\"curves\": \"c.svg\", \"views\": [{\"name\": \"v\", \"eye\": [0, -1, 1], "
                     "\"target\": [0, 0, 0], \"orbit\": 3}]}",
                     &sc, &err) != CH_OK) {
    fprintf(stderr, "%s\n", err.message);
    return 1;
  }
  printf("scene: %s, %d views\n", sc.curves_path, sc.num_views);
  if (strcmp(sc.curves_path, "dir/c.svg") != 0 || sc.num_views != 3) bad = 1;
  ch_scene_free(&sc);
  printf("chisel %s\n", ch_version());
  return bad;
}
