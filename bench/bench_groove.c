/* h_groove evaluation speed on the bundled curve sets: point samples per
 * second on 1 thread and on all threads, and against a scan of every curve
 * without the grid (the baseline the grid must beat), in the same run.
 * usage: bench_groove [RES] [MODELS_DIR] */
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "bench_util.h"
#include "ch_curves.h"
#include "ch_groove.h"

/* The baseline: every groove's closest point, no grid. */
static double scan_eval(const ch_curve_set *set, double u, double v) {
  double carve = 0.0, raise = 0.0, q[2] = {u, v};
  for (int c = 0; c < set->num_curves; c++) {
    const ch_curve *cv = &set->curves[c];
    if (cv->kind != CH_CURVE_GROOVE) continue;
    ch_curve_point cp;
    ch_curve_closest(set, c, q, &cp);
    double g = cv->depth * ch_profile_eval(&cv->profile, cp.signed_distance / cv->width);
    if (g < carve) carve = g;
    if (g > raise) raise = g;
  }
  return carve < 0.0 ? carve : raise;
}

int main(int argc, char **argv) {
  int res = argc > 1 ? atoi(argv[1]) : 1024;
  const char *models = argc > 2 ? argv[2] : "models";
  static const char *sets[] = {"glyphs", "ornament", "frame", "relief", "star", "spiral", "bricks", "panels"};
  float *plane = malloc((size_t)res * res * sizeof *plane);
  int threads = omp_get_max_threads();
  printf("h_groove evaluation, %dx%d pixel centres, median of 5 (Msamples/s)\n", res, res);
  printf("%-10s %8s %8s %10s %10s %10s %8s\n", "curves", "grooves", "segments", "1 thread", "threads",
         "scan (1t)", "grid/scan");
  for (size_t k = 0; k < sizeof sets / sizeof sets[0]; k++) {
    char path[1024];
    snprintf(path, sizeof path, "%s/curves/%s.svg", models, sets[k]);
    ch_curve_set set;
    ch_error err = {0};
    if (ch_curves_read_svg(path, &set, &err)) {
      fprintf(stderr, "%s\n", err.message);
      return 1;
    }
    ch_groove_field f;
    if (ch_groove_field_init(&f, &set, &err)) {
      fprintf(stderr, "%s\n", err.message);
      return 1;
    }
    double rate[2];
    for (int mode = 0; mode < 2; mode++) {
      omp_set_num_threads(mode == 0 ? 1 : threads);
      double t[5];
      for (int r = 0; r < 5; r++) {
        double t0 = bench_now();
        #pragma omp parallel for schedule(dynamic, 4)
        for (int y = 0; y < res; y++)
          for (int x = 0; x < res; x++)
            plane[(size_t)y * res + x] =
                (float)ch_groove_field_eval(&f, (x + 0.5) / res, 1.0 - (y + 0.5) / res, NULL);
        t[r] = bench_now() - t0;
      }
      rate[mode] = (double)res * res / bench_median(t, 5) / 1e6;
    }
    /* The scan is slow: time it on a 128x128 subset of the same centres. */
    int sub = res < 128 ? res : 128, step = res / sub;
    double t[5];
    volatile double sink = 0.0;
    for (int r = 0; r < 5; r++) {
      double t0 = bench_now();
      for (int y = 0; y < sub; y++)
        for (int x = 0; x < sub; x++)
          sink += scan_eval(&set, (x * step + 0.5) / res, 1.0 - (y * step + 0.5) / res);
      t[r] = bench_now() - t0;
    }
    (void)sink;
    double scan_rate = (double)sub * sub / bench_median(t, 5) / 1e6;
    printf("%-10s %8d %8d %10.2f %10.2f %10.3f %7.0fx\n", sets[k], f.num_grooves, set.num_segments,
           rate[0], rate[1], scan_rate, rate[0] / scan_rate);
    ch_groove_field_free(&f);
    ch_curves_free(&set);
  }
  free(plane);
  return 0;
}
