/* View-dependent warp speed (diffusion-curves-on-surfaces §3.2): building W
 * and the cage maps for a close camera (need, functions, grids), then curve
 * re-registration per frame for animated curves (the set moved a little
 * each frame, the warp kept), on 1 thread and on all threads. The cage is a
 * gently bent sheet of QUADS x QUADS quads made here (no tess/ dependency).
 * usage: bench_warp [CURVES.svg] [FRAMES] [QUADS]   (run from the repo root;
 * defaults models/curves/glyphs.svg, 50, 64) */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"
#include "ch_curves.h"
#include "ch_warp.h"

enum { BUILDS = 5 };

/* quads x quads grid over the unit square, two counter-clockwise triangles
 * per quad, at (u, v, 0.15 sin(pi u)). */
static void make_cage(int quads, double *uv, double *pos) {
  int t = 0;
  for (int j = 0; j < quads; j++)
    for (int i = 0; i < quads; i++) {
      static const int corner[2][3][2] = {{{0, 0}, {1, 0}, {1, 1}}, {{0, 0}, {1, 1}, {0, 1}}};
      for (int k = 0; k < 2; k++, t++)
        for (int m = 0; m < 3; m++) {
          double u = (double)(i + corner[k][m][0]) / quads, v = (double)(j + corner[k][m][1]) / quads;
          uv[6 * t + 2 * m] = u;
          uv[6 * t + 2 * m + 1] = v;
          pos[9 * t + 3 * m] = u;
          pos[9 * t + 3 * m + 1] = v;
          pos[9 * t + 3 * m + 2] = 0.15 * sin(3.14159265358979323846 * u);
        }
    }
}

int main(int argc, char **argv) {
  const char *path = argc > 1 ? argv[1] : "models/curves/glyphs.svg";
  int frames = argc > 2 ? atoi(argv[2]) : 50;
  int quads = argc > 3 ? atoi(argv[3]) : 64;
  if (frames < 1) frames = 1;
  if (quads < 1 || quads > 2048) quads = 64;
  ch_curve_set set;
  ch_error err = {0};
  if (ch_curves_read_svg(path, &set, &err)) {
    fprintf(stderr, "%s\n", err.message);
    return 1;
  }
  int nt = 2 * quads * quads;
  double *uv = malloc((size_t)nt * 6 * sizeof *uv), *pos = malloc((size_t)nt * 9 * sizeof *pos);
  if (!uv || !pos) return 1;
  make_cage(quads, uv, pos);
  ch_warp_cage cage = {.num_triangles = nt, .uv = uv, .position = pos};
  ch_camera cam;
  const double view[7] = {0.3, 0.25, 0.55, 0.3, 0.45, 0.1, 45.0};
  if (ch_camera_init(&cam, view, &err)) {
    fprintf(stderr, "%s\n", err.message);
    return 1;
  }
  int threads = omp_get_max_threads();
  printf("view-dependent warp: %s (%d curves, %d segments), cage %d triangles, %d frames\n", path,
         set.num_curves, set.num_segments, nt, frames);

  ch_warp w;
  for (int mode = 0; mode < 2; mode++) {
    omp_set_num_threads(mode == 0 ? 1 : threads);
    double need[BUILDS], fun[BUILDS], grids[BUILDS], total[BUILDS];
    for (int r = 0; r < BUILDS; r++) {
      double t0 = bench_now();
      if (ch_warp_build(&cam, &cage, &set, NULL, &w, &err)) {
        fprintf(stderr, "%s\n", err.message);
        return 1;
      }
      total[r] = bench_now() - t0;
      need[r] = w.stats.seconds_need;
      fun[r] = w.stats.seconds_functions;
      grids[r] = w.stats.seconds_grids;
      if (r + 1 < BUILDS) ch_warp_free(&w);
    }
    printf("build, %d thread(s), median of %d (ms): need %.3f  functions %.3f  grids+shares %.3f  total %.3f\n",
           mode == 0 ? 1 : threads, BUILDS, 1e3 * bench_median(need, BUILDS), 1e3 * bench_median(fun, BUILDS),
           1e3 * bench_median(grids, BUILDS), 1e3 * bench_median(total, BUILDS));
    if (mode == 0) {
      printf("  n %d, visible %d, needy %d, max slope %.2f x %.2f, visible share %.3f (unwarped %.3f)\n", w.n,
             w.stats.visible_triangles, w.stats.needy_triangles, w.stats.max_slope[0], w.stats.max_slope[1],
             w.stats.visible_share, w.stats.unwarped_share);
    }
    if (mode + 1 < 2) ch_warp_free(&w);
  }

  /* Animated curves: each frame the set drifts by (0.5, 0.25) per mille. */
  ch_segment *orig = malloc((size_t)set.num_segments * sizeof *orig);
  double *ms = malloc((size_t)frames * sizeof *ms);
  if (!orig || !ms) return 1;
  memcpy(orig, set.segments, (size_t)set.num_segments * sizeof *orig);
  for (int mode = 0; mode < 2; mode++) {
    omp_set_num_threads(mode == 0 ? 1 : threads);
    long pieces = 0;
    double sum = 0.0;
    for (int f = 0; f < frames; f++) {
      double du = 5e-4 * f, dv = 2.5e-4 * f;
      for (int i = 0; i < set.num_segments; i++)
        for (int k = 0; k < 3; k++) {
          set.segments[i].p[k][0] = orig[i].p[k][0] + du;
          set.segments[i].p[k][1] = orig[i].p[k][1] + dv;
        }
      ch_curve_set out;
      ch_warp_curve_stats st;
      double t0 = bench_now();
      if (ch_warp_curves(&w, &set, &out, &st, &err)) {
        fprintf(stderr, "%s\n", err.message);
        return 1;
      }
      ms[f] = 1e3 * (bench_now() - t0);
      sum += ms[f];
      pieces += st.registered_pieces;
      ch_curves_free(&out);
    }
    printf("re-registration, %d thread(s): %.3f ms/frame median, %.3f mean, %.0f pieces/frame from %d segments\n",
           mode == 0 ? 1 : threads, bench_median(ms, frames), sum / frames, (double)pieces / frames,
           set.num_segments);
  }
  ch_warp_free(&w);
  free(ms);
  free(orig);
  free(uv);
  free(pos);
  ch_curves_free(&set);
  return 0;
}
