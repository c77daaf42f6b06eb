/* ch_diffuse speed on relief-like masks (12 closed curves and 4 open curves
 * across the square, 2-texel bands, random side values; free texels start
 * at 0): median of 5 solves per size, iterations, levels, time per texel,
 * and the CHOLMOD direct solve (analysis + factorisation + solve, double)
 * where it runs, as a ratio. Prints a table; never fails on timing.
 * usage: bench_diffuse [MAX_RES [CHANNELS [DIRECT_MAX_RES]]] */
#define _POSIX_C_SOURCE 200809L /* clock_gettime */
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../tests/diffuse_direct.h"
#include "../tests/diffuse_scene.h"
#include "ch_diffuse.h"

static double median(double *v, int n) {
  for (int i = 1; i < n; i++)
    for (int j = i; j > 0 && v[j] < v[j - 1]; j--) {
      double t = v[j];
      v[j] = v[j - 1];
      v[j - 1] = t;
    }
  return v[n / 2];
}

int main(int argc, char **argv) {
  int max_res = argc > 1 ? atoi(argv[1]) : 4096;
  int only_c = argc > 2 ? atoi(argv[2]) : 0;
  int direct_max = argc > 3 ? atoi(argv[3]) : 1024;
  enum { REPS = 5 };
  FILE *la = fopen("/proc/loadavg", "r");
  char load[64] = "?";
  if (la) {
    if (!fgets(load, sizeof load, la)) strcpy(load, "?");
    fclose(la);
    load[strcspn(load, "\n")] = 0;
  }
  printf("ch_diffuse on relief masks, %d threads, load average %s, median of %d\n", omp_get_max_threads(), load,
         REPS);
  printf("%6s %3s %7s %6s %6s %10s %10s %9s %12s %8s\n", "R", "C", "fixed%", "iters", "levels", "residual",
         "median ms", "ns/texel", "direct ms", "ratio");
  for (int C = 1; C <= 4; C += 3) {
    if (only_c && C != only_c) continue;
    for (int R = 256; R <= max_res; R *= 2) {
      scene s;
      if (!scene_init(&s, R, R, C)) return 1;
      scene_relief(&s, 1);
      size_t n = (size_t)R * R, nfixed = 0;
      for (size_t i = 0; i < n; i++) nfixed += s.fixed[i];
      float *v = malloc(n * C * sizeof *v);
      double t[REPS];
      ch_diffuse_stats st = {0};
      for (int r = 0; r < REPS; r++) {
        for (size_t i = 0; i < n * C; i++) v[i] = s.fixed[i / C] ? s.values[i] : 0.0f;
        ch_error err = {0};
        if (ch_diffuse_solve(R, R, C, s.fixed, v, NULL, &st, &err)) {
          fprintf(stderr, "%s\n", err.message);
          return 1;
        }
        t[r] = st.seconds;
      }
      double med = median(t, REPS);
      double worst = 0.0;
      for (int c = 0; c < C; c++)
        if (st.relative_residual[c] > worst) worst = st.relative_residual[c];
      char dms[32] = "-", ratio[32] = "-";
#ifdef CHISEL_HAVE_CHOLMOD
      if (R <= direct_max && C == 1) {
        double *ref = malloc(n * C * sizeof *ref);
        double td = direct_solve(R, R, C, s.fixed, s.values, NULL, ref);
        if (td >= 0.0) {
          snprintf(dms, sizeof dms, "%.1f", 1e3 * td);
          snprintf(ratio, sizeof ratio, "%.1fx", td / med);
        }
        free(ref);
      }
#else
      (void)direct_max;
#endif
      printf("%6d %3d %7.2f %6d %6d %10.2e %10.1f %9.2f %12s %8s\n", R, C, 100.0 * nfixed / n, st.iterations,
             st.levels, worst, 1e3 * med, 1e9 * med / n, dms, ratio);
      fflush(stdout);
      free(v);
      scene_free(&s);
    }
  }
  return 0;
}
