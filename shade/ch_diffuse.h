/* ch_diffuse: the diffusion solver behind diffusion-curve images (docs/spec.md §3
 * "Steps"): Laplace's equation on a texel grid with fixed (Dirichlet) texels
 * and zero-flux image borders, by Galerkin multigrid; optionally Poisson's,
 * with a per-texel source. Which texels are fixed and to what is decided by
 * the caller (the curve rasterisation). */
#ifndef CH_DIFFUSE_H
#define CH_DIFFUSE_H

#include "ch_error.h"

#ifdef __cplusplus
extern "C" {
#endif

enum { CH_DIFFUSE_MAX_CHANNELS = 8 };

typedef struct ch_diffuse_desc { /* zero = defaults */
  double tolerance;   /* relative residual ||b - A x||_2 / ||b||_2 per channel; 0 -> 1e-6 */
  int max_iterations; /* 0 -> 100 */
  /* NULL, or width*height*channels values laid out like values: at each free
   * texel the 5-point equation becomes sum over its existing neighbours n of
   * (x_n - x_i) = source[i] (texel spacing 1; a missing border neighbour
   * still left out, i.e. zero flux); ignored on fixed texels. For singularity
   * subtraction: a caller that takes a known singular term (windowed) out of
   * the solution passes the window's Laplacian of it here. */
  const float *source;
} ch_diffuse_desc;

typedef struct ch_diffuse_stats {
  int iterations; /* outer iterations (multigrid cycles) */
  int levels;     /* multigrid levels */
  double relative_residual[CH_DIFFUSE_MAX_CHANNELS];
  double seconds;
} ch_diffuse_stats;

/* Solves Laplace's equation on a width x height grid (5-point stencil,
 * texel spacing 1): texels with fixed[i] != 0 keep values[i*channels + c];
 * all others get the harmonic solution (with desc->source, the solution of
 * Poisson's equation). Borders are zero-flux (a missing neighbour is left out
 * of the stencil). values is texel-major, channels interleaved
 * (1..CH_DIFFUSE_MAX_CHANNELS); on entry free texels hold an initial guess
 * (may be anything finite). A connected region of free texels that touches
 * no fixed texel (only possible if no texel is fixed) has no unique
 * solution: it gets the mean of its initial guess, constant; with a source
 * it is refused, as pure zero flux has a solution only for a source summing
 * to 0. Deterministic (same bytes with 1 or 2 threads). stats may be NULL.
 * Fails only on absurd sizes or a source without fixed texels (CH_ERR_INPUT),
 * out of memory, or if the tolerance is not reached in max_iterations
 * (CH_ERR_INTERNAL with the residual reached in the message).
 *
 * Buffers: fixed holds width*height bytes, values (and source)
 * width*height*channels floats, all row-major (texel (x, y) at y*width + x),
 * owned by the caller; fixed texels' values are never written. The solver
 * allocates only scratch: about 0.7 x the size of values for the coarse
 * levels (2 or 3 channels count as 4), plus a copy of values (and of source)
 * when channels > 1. width or height 0 is an empty grid (CH_OK; the pointers
 * may then be NULL).
 *
 * Residual: b is the free texels' coupling to their fixed neighbours minus
 * their source (A x = b with A the positive 5-point operator); the residual
 * is that of the returned float values, evaluated from them. A channel with
 * b = 0 has the exact solution 0 on free texels, which it gets (residual
 * 0). Float values cannot get below about 1.2e-7 ||x|| / ||b||
 * (above 1e-6 on large grids with few fixed texels): a solve that reaches
 * that limit returns CH_OK with the residual reached (which may then exceed
 * the tolerance). The residual bounds the error only loosely: at 1e-6 the
 * max error can reach ~6e-5 of the value range in weakly held regions; ask
 * for 1e-8 (the float limit) when values must match a direct solve.
 *
 * Threads: reentrant; runs OpenMP teams of up to omp_get_max_threads(); the
 * result does not depend on the thread count. */
ch_status ch_diffuse_solve(int width, int height, int channels, const unsigned char *fixed,
                           float *values, const ch_diffuse_desc *desc, ch_diffuse_stats *stats,
                           ch_error *err);

#ifdef __cplusplus
}
#endif
#endif
