/* Diffusion-curve image speed: feature samples, diffusion and reblur at
 * 256^2, 1024^2 and 4096^2 (median of 5), iterations and time per texel;
 * and the feature reconstruction's wrong-value rate at 16x magnification
 * for bilinear / recon3 / recon5 / exact.
 * usage: bench_dci [MODELS_DIR] [max_resolution] */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>

#include "bench_util.h"
#include "ch_curves.h"
#include "ch_dci.h"
#include "ch_groove.h"
#include "ch_recon.h"

static double truth(const ch_curve_set *set, double u, double v) {
  double q[2] = {u, v}, best = INFINITY, value = 0.0;
  for (int c = 0; c < set->num_curves; c++) {
    ch_curve_point cp;
    ch_curve_closest(set, c, q, &cp);
    if (cp.distance < best) {
      best = cp.distance;
      value = cp.signed_distance >= 0 ? set->curves[c].left : set->curves[c].right;
    }
  }
  return value;
}

int main(int argc, char **argv) {
  const char *models = argc > 1 ? argv[1] : "models";
  int max_res = argc > 2 ? atoi(argv[2]) : 4096;
  char path[1024];
  snprintf(path, sizeof path, "%s/curves/relief.svg", models);
  ch_curve_set set;
  ch_error err = {0};
  if (ch_curves_read_svg(path, &set, &err)) {
    fprintf(stderr, "%s\n", err.message);
    return 1;
  }
  printf("relief.svg (12 closed step curves, 2 blurred, colours): %d threads, median of 5\n", omp_get_max_threads());
  printf("%6s %-8s %12s %12s %12s %12s %6s %8s %14s\n", "R", "layers", "samples ms", "diffuse ms", "s+d ms",
         "reblur ms", "iters", "levels", "ns/texel total");
  for (int R = 256; R <= max_res; R *= 4)
    for (int no_colors = 1; no_colors >= 0; no_colors--) {
      double ts[5], td[5], tb[5];
      int iters = 0, levels = 0;
      for (int r = 0; r < 5; r++) {
        ch_dci dci;
        ch_dci_desc desc = {.resolution = R, .no_colors = no_colors};
        if (ch_dci_build(&set, &desc, &dci, &err)) {
          fprintf(stderr, "%s\n", err.message);
          return 1;
        }
        ts[r] = dci.seconds_samples;
        td[r] = dci.seconds_diffuse;
        tb[r] = dci.seconds_blur;
        iters = dci.stats.iterations;
        levels = dci.stats.levels;
        ch_dci_free(&dci);
      }
      double s = bench_median(ts, 5), d = bench_median(td, 5), b = bench_median(tb, 5);
      printf("%6d %-8s %12.1f %12.1f %12.1f %12.1f %6d %8d %14.1f\n", R, no_colors ? "h" : "h+rgb", 1e3 * s, 1e3 * d,
             1e3 * (s + d), 1e3 * b, iters, levels, 1e9 * (s + d + b) / ((double)R * R));
    }
  /* Without blur: the target case (samples + diffusion). */
  for (int c = 0; c < set.num_curves; c++) set.curves[c].blur = 0.0;
  printf("\nthe same curves without blur: wrong-value pixels at 16x over 200 crops of 4x4 texels on the curves\n");
  printf("%6s %10s %10s %10s %10s\n", "R", "bilinear", "recon3", "recon5", "exact");
  static const ch_recon_method order[] = {CH_RECON_BILINEAR, CH_RECON_3X3, CH_RECON_5X5, CH_RECON_EXACT};
  for (int R = 64; R <= 256; R *= 2) {
    ch_dci dci;
    ch_dci_desc desc = {.resolution = R};
    ch_recon rec;
    if (ch_dci_build(&set, &desc, &dci, &err) || ch_recon_init(&rec, &dci, &set, &err)) return 1;
    double rate[4];
    for (int m = 0; m < 4; m++) {
      long wrong = 0, total = 0;
      unsigned long long rng = 88172645463325252ull;
      for (int k = 0; k < 200; k++) {
        rng ^= rng << 13, rng ^= rng >> 7, rng ^= rng << 17;
        int sg = (int)(rng % (unsigned long long)set.num_segments);
        rng ^= rng << 13, rng ^= rng >> 7, rng ^= rng << 17;
        double t = (rng % 1000000) / 1e6, a = 1 - t, c[2];
        const ch_segment *seg = &set.segments[sg];
        for (int j = 0; j < 2; j++) c[j] = a * a * seg->p[0][j] + 2 * a * t * seg->p[1][j] + t * t * seg->p[2][j];
        double half = 2.0 / R;
        for (int y = 0; y < 64; y++)
          for (int x = 0; x < 64; x++) {
            double u = c[0] - half + (x + 0.5) * half / 32, v = c[1] + half - (y + 0.5) * half / 32;
            if (u < 0 || v < 0 || u > 1 || v > 1) continue;
            ch_recon_sample rs;
            ch_recon_eval(&rec, order[m], u, v, 0.0, &rs);
            total++;
            if (fabs(rs.value - truth(&set, u, v)) > 0.0015) wrong++;
          }
      }
      rate[m] = 100.0 * wrong / total;
    }
    printf("%6d %9.3f%% %9.3f%% %9.3f%% %9.3f%%\n", R, rate[0], rate[1], rate[2], rate[3]);
    ch_recon_free(&rec);
    ch_dci_free(&dci);
  }
  ch_curves_free(&set);
  return 0;
}
