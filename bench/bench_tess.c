/* Base-surface tessellation speed (tess/ch_surface): ch_tess_build at
 * --target-tris 130k / 520k / 2.1M for the plane and the torus, bilinear
 * and catmark, on 1 thread and on all threads; median of 5 runs. The time
 * includes choosing the rates (bisection over the triangle count), the
 * evaluation of every point (B, N, UV) and the output arrays.
 * usage: bench_tess [MODELS_DIR] */
#define _POSIX_C_SOURCE 200809L
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "bench_util.h"
#include "ch_surface.h"

/* Median seconds of ch_tess_build; *tris gets the count. */
static double time_build(const ch_surface *S, long target, int *tris) {
  enum { RUNS = 5 };
  double t[RUNS];
  for (int r = 0; r < RUNS; r++) {
    ch_tess_result res;
    ch_error err = {0};
    double t0 = bench_now();
    if (ch_tess_build(S, &(ch_tess_desc){.target_triangles = target}, &res, &err) != CH_OK) {
      fprintf(stderr, "%s\n", err.message);
      exit(1);
    }
    t[r] = bench_now() - t0;
    *tris = res.mesh.num_faces;
    ch_tess_free(&res);
  }
  return bench_median(t, RUNS);
}

int main(int argc, char **argv) {
  const char *models = argc > 1 ? argv[1] : "models";
  static const char *names[] = {"plane", "torus"};
  static const long targets[] = {130000, 520000, 2100000};
  const int threads = omp_get_max_threads();
  printf("ch_tess_build, median of 5; %d threads vs 1\n", threads);
  printf("%-6s %-8s %9s %9s %10s %10s %10s %10s %8s\n", "mesh", "scheme", "target", "triangles",
         "create ms", "1t ms", "Mtri/s 1t", "Nt ms", "Mtri/s Nt");
  for (int m = 0; m < 2; m++) {
    char path[1024];
    snprintf(path, sizeof path, "%s/%s.obj", models, names[m]);
    ch_mesh mesh;
    ch_error err = {0};
    if (ch_mesh_read(path, &mesh, &err) != CH_OK) {
      fprintf(stderr, "%s\n", err.message);
      return 1;
    }
    for (int sc = 0; sc < 2; sc++) {
      ch_surface *S;
      double t0 = bench_now();
      if (ch_surface_create(&mesh, (ch_scheme)sc, &S, &err) != CH_OK) {
        fprintf(stderr, "%s\n", err.message);
        return 1;
      }
      double tc = bench_now() - t0;
      for (int k = 0; k < 3; k++) {
        int tris = 0;
        omp_set_num_threads(1);
        double t1 = time_build(S, targets[k], &tris);
        omp_set_num_threads(threads);
        double tn = time_build(S, targets[k], &tris);
        printf("%-6s %-8s %9ld %9d %10.2f %10.1f %10.2f %10.1f %8.2f\n", names[m],
               sc ? "catmark" : "bilinear", targets[k], tris, 1e3 * tc, 1e3 * t1, tris / t1 / 1e6,
               1e3 * tn, tris / tn / 1e6);
        fflush(stdout);
      }
      ch_surface_destroy(S);
    }
    ch_mesh_free(&mesh);
  }
  return 0;
}
