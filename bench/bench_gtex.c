/* Tracing rates of the texture methods that move hits (path-based groove
 * textures, relief mapping, parallax occlusion mapping) against a mesh
 * traced by Embree, from the study's views (an oblique one, a grazing one
 * 15 degrees above the plane, a close-up), all in one run so the ratios
 * are measured under the same load. Rays are counted as the study counts
 * them: primary plus shadow rays; for a texture method a primary ray is
 * the base plane's Embree hit and the method's trace. The machine is
 * shared, so each method's render alternates with the mesh's and the
 * ratio printed is the median of the per-pair ratios, and next to it the
 * method's pixels per second (Mpix/s: output pixels, each 2x2 samples
 * with their shadow rays). Memory of each method's textures.
 *
 *   bench_gtex CURVES.svg [MESH.obj] [G,G,...] [R,R,...] [K] [REPEATS]
 *
 * defaults: no mesh, G = 64,128,256, R = 512,1024,2048,4096, K = 32, 3
 * repeats (the median is printed). OMP_NUM_THREADS sets the cores.
 *
 *   bench_gtex --count CURVES.svg G [STRIDE]
 *
 * traces, on one thread, every STRIDE-th pixel (default 16) of the
 * study's two close-ups (bench/study_scene.sh) through the groove
 * texture's shader as the renderer calls it (2 x 2 samples, a shadow ray
 * where the hit faces the light), in trace_closeups alone, so that
 * instruction counts compare across versions:
 *   valgrind --tool=callgrind --toggle-collect=trace_closeups bench_gtex --count ...
 * It prints the hits and lit samples (the same for any version up to
 * float rounding). */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"
#include "ch_curves.h"
#include "ch_height.h"
#include "ch_mesh.h"
#include "ch_render.h"
#include "ch_texray.h"
#include "ch_trace.h"
#include "ch_truth.h"

static int parse_list(const char *s, int *out, int max) {
  int n = 0;
  while (s && *s && n < max) {
    out[n++] = atoi(s);
    s = strchr(s, ',');
    if (s) s++;
  }
  return n;
}

typedef struct view {
  const char *name;
  ch_render_camera cam;
} view;

/* One render's rate (Mrays/s), and its Mpixels/s in *mpix. */
static double rate1(const ch_trace *scene, const ch_render_shader *sh, const ch_truth *truth,
                    const ch_render_camera *cam, double *mpix) {
  ch_image img;
  ch_render_stats st;
  ch_error err = {0};
  if (ch_render_shaded(scene, sh, truth, cam, NULL, &img, &st, &err)) {
    fprintf(stderr, "bench_gtex: %s\n", err.message);
    exit(1);
  }
  ch_image_free(&img);
  *mpix = (double)cam->width * cam->height / st.seconds * 1e-6;
  return (st.primary_rays + st.shadow_rays) / st.seconds * 1e-6;
}

/* Median rate over repeats of one method and view, and (with a mesh) the
 * median ratio to the mesh's rate measured right before each repeat. */
static double rate(const ch_trace *scene, const ch_render_shader *sh, const ch_truth *truth, const ch_render_camera *cam,
                   int repeats, const ch_trace *mesh, double *ratio, double *mpix) {
  double r[16], q[16], px[16], unused;
  for (int k = 0; k < repeats; k++) {
    double m = mesh ? rate1(mesh, NULL, truth, cam, &unused) : 0.0;
    r[k] = rate1(scene, sh, truth, cam, &px[k]);
    q[k] = m > 0.0 ? r[k] / m : 0.0;
  }
  if (ratio) *ratio = bench_median(q, repeats);
  if (mpix) *mpix = bench_median(px, repeats);
  return bench_median(r, repeats);
}

/* The rays of the study's two close-ups, every stride-th pixel, 2 x 2
 * samples each (bench/study_scene.sh's closeup and closeup2). */
static int closeup_rays(int stride, double (**rays)[6]) {
  const double eye[2][3] = {{0.42, 0.3, 0.14}, {0.66, 0.7, 0.09}}, target[2][3] = {{0.5, 0.5, -0.01}, {0.55, 0.55, -0.01}};
  int W = 320, H = 240, n = 0;
  *rays = malloc(sizeof **rays * 2 * ((size_t)W * H / stride + 1) * 4);
  if (!*rays) return -1;
  for (int v = 0; v < 2; v++) {
    ch_render_camera cam = {.eye = {eye[v][0], eye[v][1], eye[v][2]},
                            .target = {target[v][0], target[v][1], target[v][2]},
                            .up = {0, 0, 1},
                            .fov_deg = 30,
                            .width = W,
                            .height = H,
                            .supersample = 2};
    for (int p = 0; p < W * H; p += stride)
      for (int sj = 0; sj < 4; sj++) {
        ch_error err = {0};
        if (ch_render_camera_ray(&cam, p % W + (sj % 2 + 0.5) / 2, p / W + (sj / 2 + 0.5) / 2, (*rays)[n],
                                 (*rays)[n] + 3, &err))
          return -1;
        n++;
      }
  }
  return n;
}

/* The renderer's work per sample (ch_render's trace_sample) with the
 * shader alone: the hit, and a shadow ray where it faces the light. */
static __attribute__((noinline)) long trace_closeups(const ch_render_shader *sh, const double (*rays)[6], int n, long *lit) {
  double L[3] = {-0.35, -0.45, 0.82}, l = sqrt(L[0] * L[0] + L[1] * L[1] + L[2] * L[2]);
  for (int k = 0; k < 3; k++) L[k] /= l;
  long hits = 0;
  *lit = 0;
  for (int i = 0; i < n; i++) {
    const double *o = rays[i], *d = rays[i] + 3;
    ch_trace_hit h = {0};
    if (!sh->shade(sh->user, o, d, &h)) continue;
    hits++;
    double s = h.normal[0] * d[0] + h.normal[1] * d[1] + h.normal[2] * d[2] > 0.0 ? -1.0 : 1.0;
    if (s * (h.normal[0] * L[0] + h.normal[1] * L[1] + h.normal[2] * L[2]) > 0.0) *lit += !sh->occluded(sh->user, &h, L);
  }
  return hits;
}

static int count_main(int argc, char **argv) {
  if (argc < 4) {
    fprintf(stderr, "usage: bench_gtex --count CURVES.svg G [STRIDE]\n");
    return 2;
  }
  int G = atoi(argv[3]), stride = argc > 4 ? atoi(argv[4]) : 16;
  if (stride < 1) stride = 1;
  ch_error err = {0};
  ch_curve_set set;
  ch_texray *tr;
  ch_texray_desc d = {.kind = CH_TEXRAY_GROOVES, .resolution = G};
  if (ch_curves_read_svg(argv[2], &set, &err) || ch_texray_create(&d, &set, NULL, argv[2], &tr, &err)) {
    fprintf(stderr, "bench_gtex: %s\n", err.message);
    return 1;
  }
  double(*rays)[6];
  int n = closeup_rays(stride, &rays);
  if (n < 0) {
    fprintf(stderr, "bench_gtex: close-up rays failed\n");
    return 1;
  }
  ch_render_shader sh = ch_texray_shader(tr);
  long lit, hits = trace_closeups(&sh, (const double(*)[6])rays, n, &lit);
  printf("%s G = %d: %d samples, %ld hits, %ld lit\n", argv[2], G, n, hits, lit);
  free(rays);
  ch_texray_destroy(tr);
  ch_curves_free(&set);
  return 0;
}

int main(int argc, char **argv) {
  if (argc > 1 && !strcmp(argv[1], "--count")) return count_main(argc, argv);
  if (argc < 2) {
    fprintf(stderr, "usage: bench_gtex CURVES.svg [MESH.obj|-] [G,...] [R,...] [K] [REPEATS]\n");
    return 2;
  }
  const char *svg = argv[1], *mesh_path = argc > 2 && strcmp(argv[2], "-") ? argv[2] : NULL;
  int gs[16], rs[16], ng = parse_list(argc > 3 ? argv[3] : "64,128,256", gs, 16);
  int nr = parse_list(argc > 4 ? argv[4] : "512,1024,2048,4096", rs, 16);
  int K = argc > 5 ? atoi(argv[5]) : 32, repeats = argc > 6 ? atoi(argv[6]) : 3;
  if (repeats < 1) repeats = 1;
  if (repeats > 16) repeats = 16;
  ch_error err = {0};
  ch_curve_set set;
  ch_height height;
  ch_truth *truth;
  ch_trace *plane, *mesh = NULL;
  ch_mesh base = {0}, m = {0};
  ch_height_desc hd = {.dci_resolution = 1024, .step_method = CH_RECON_EXACT};
  ch_truth_desc td = {.grid = 256};
  if (ch_curves_read_svg(svg, &set, &err) || ch_height_init(&height, &set, &hd, &err) ||
      ch_truth_create(&height, &td, &truth, &err) || ch_mesh_read(CHISEL_MODELS "/plane.obj", &base, &err) ||
      ch_trace_create_mesh(&base, "plane.obj", &plane, &err) ||
      (mesh_path && (ch_mesh_read(mesh_path, &m, &err) || ch_trace_create_mesh(&m, mesh_path, &mesh, &err)))) {
    fprintf(stderr, "bench_gtex: %s\n", err.message);
    return 1;
  }
  view views[3] = {
      {"oblique", {.eye = {0.2, -0.4, 0.9}, .target = {0.5, 0.5, -0.01}, .up = {0, 0, 1}, .fov_deg = 40}},
      {"grazing15", {.eye = {0.5, -0.3, 0.215}, .target = {0.5, 0.5, 0.0}, .up = {0, 0, 1}, .fov_deg = 50}},
      {"closeup", {.eye = {0.42, 0.3, 0.14}, .target = {0.5, 0.5, -0.01}, .up = {0, 0, 1}, .fov_deg = 30}},
  };
  for (int v = 0; v < 3; v++) views[v].cam.width = 320, views[v].cam.height = 240, views[v].cam.supersample = 2;
  printf("%s, %d threads, Mrays/s (primary + shadow) per view, median of %d\n", svg, omp_get_max_threads(), repeats);
  printf("%-16s %12s %10s %10s %10s\n", "method", "bytes", views[0].name, views[1].name, views[2].name);
  double mesh_rate[3] = {0, 0, 0};
  if (mesh) {
    printf("%-16s %12s", "mesh", "-");
    for (int v = 0; v < 3; v++) {
      double px;
      printf(" %10.2f", mesh_rate[v] = rate(mesh, NULL, truth, &views[v].cam, repeats, NULL, NULL, &px));
      printf(" %.3f Mpix/s", px);
    }
    printf("   (%ld triangles)\n", ch_trace_triangles(mesh));
  }
  for (int pass = 0; pass < 3; pass++) {
    int n = pass == 0 ? ng : nr;
    for (int i = 0; i < n; i++) {
      ch_texray_desc d = {.kind = pass == 0 ? CH_TEXRAY_GROOVES : pass == 1 ? CH_TEXRAY_RELIEF : CH_TEXRAY_POM,
                          .resolution = pass == 0 ? gs[i] : rs[i],
                          .steps = K};
      ch_texray *tr;
      double t0 = bench_now();
      if (ch_texray_create(&d, &set, &height, svg, &tr, &err)) {
        printf("%s %d: %s\n", pass == 0 ? "grooves" : pass == 1 ? "relief" : "pom", d.resolution, err.message);
        continue;
      }
      double build = bench_now() - t0;
      ch_render_shader sh = ch_texray_shader(tr);
      char name[32];
      snprintf(name, sizeof name, "%s %d", pass == 0 ? "grooves" : pass == 1 ? "relief" : "pom", d.resolution);
      printf("%-16s %12zu", name, ch_texray_bytes(tr));
      for (int v = 0; v < 3; v++) {
        double q, px, r = rate(plane, &sh, truth, &views[v].cam, repeats, mesh, &q, &px);
        printf(" %10.2f", r);
        if (mesh) printf(" (%.2fx)", q);
        printf(" %.3f Mpix/s", px);
      }
      printf("   build %.2f s\n", build);
      ch_texray_destroy(tr);
    }
  }
  ch_trace_destroy(mesh);
  ch_trace_destroy(plane);
  ch_mesh_free(&m);
  ch_mesh_free(&base);
  ch_truth_destroy(truth);
  ch_height_free(&height);
  ch_curves_free(&set);
  return 0;
}
