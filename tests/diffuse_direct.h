/* An independent direct solve of the diffusion problem for the tests and
 * the benchmark: the reduced system on free texels (5-point stencil, a
 * missing border neighbour left out, fixed neighbours and minus the source
 * moved to the right-hand side) assembled as a sparse SPD matrix and solved by a CHOLMOD
 * Cholesky factorisation, in double. Only built with CHISEL_HAVE_CHOLMOD. */
#ifndef DIFFUSE_DIRECT_H
#define DIFFUSE_DIRECT_H

#ifdef CHISEL_HAVE_CHOLMOD
#include <cholmod.h>
#include <stdlib.h>
#include <time.h>

static inline double direct_now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Writes the solution into out (w*h*C doubles, interleaved like values;
 * fixed texels copied). source: NULL or laid out like values, as in
 * ch_diffuse_desc (sum over a free texel's neighbours of (x_n - x_i) =
 * source[i]). Needs at least one fixed texel (else the system is singular).
 * Returns the seconds taken by analysis, factorisation and solve, or -1 on
 * failure. */
static inline double direct_solve(int w, int h, int C, const unsigned char *fixed, const float *values,
                                  const float *source, double *out) {
  size_t N = (size_t)w * h;
  int *id = malloc(N * sizeof *id);
  int n = 0;
  for (size_t i = 0; i < N; i++) id[i] = fixed[i] ? -1 : n++;
  cholmod_common cm;
  cholmod_start(&cm);
  cholmod_triplet *T = cholmod_allocate_triplet(n, n, (size_t)n * 3 + 1, -1, CHOLMOD_REAL, &cm);
  cholmod_dense *B = cholmod_zeros(n, C, CHOLMOD_REAL, &cm);
  int *Ti = T->i, *Tj = T->j;
  double *Tx = T->x, *Bx = B->x;
  size_t nz = 0;
  for (int y = 0; y < h; y++)
    for (int x = 0; x < w; x++) {
      size_t i = (size_t)y * w + x;
      if (fixed[i]) continue;
      size_t nb[4];
      int deg = 0;
      if (x > 0) nb[deg++] = i - 1;
      if (x < w - 1) nb[deg++] = i + 1;
      if (y > 0) nb[deg++] = i - (size_t)w;
      if (y < h - 1) nb[deg++] = i + (size_t)w;
      Ti[nz] = Tj[nz] = id[i];
      Tx[nz++] = deg;
      if (source)
        for (int c = 0; c < C; c++) Bx[(size_t)c * n + id[i]] -= source[i * C + c];
      for (int k = 0; k < deg; k++) {
        size_t j = nb[k];
        if (fixed[j]) {
          for (int c = 0; c < C; c++) Bx[(size_t)c * n + id[i]] += values[j * C + c];
        } else if (id[j] > id[i]) { /* lower triangle: row > column */
          Ti[nz] = id[j];
          Tj[nz] = id[i];
          Tx[nz++] = -1.0;
        }
      }
    }
  T->nnz = nz;
  double t0 = direct_now();
  cholmod_sparse *A = cholmod_triplet_to_sparse(T, nz, &cm);
  cholmod_factor *L = cholmod_analyze(A, &cm);
  cholmod_factorize(A, L, &cm);
  cholmod_dense *X = cholmod_solve(CHOLMOD_A, L, B, &cm);
  double t = direct_now() - t0;
  if (!X || cm.status != CHOLMOD_OK) t = -1.0;
  for (size_t i = 0; i < N; i++)
    for (int c = 0; c < C; c++)
      out[i * C + c] = fixed[i] ? values[i * C + c] : (X ? ((double *)X->x)[(size_t)c * n + id[i]] : 0.0);
  cholmod_free_dense(&X, &cm);
  cholmod_free_factor(&L, &cm);
  cholmod_free_sparse(&A, &cm);
  cholmod_free_dense(&B, &cm);
  cholmod_free_triplet(&T, &cm);
  cholmod_finish(&cm);
  free(id);
  return t;
}
#endif

#endif
