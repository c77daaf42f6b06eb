/* ch_height: the displacement h = h_step + h_groove of SPEC §3 at any UV:
 * exact grooves, and steps from a diffusion-curve image read through
 * feature reconstruction. */
#ifndef CH_HEIGHT_H
#define CH_HEIGHT_H

#include "ch_curves.h"
#include "ch_dci.h"
#include "ch_groove.h"
#include "ch_recon.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ch_height_desc {
  int dci_resolution;           /* R of the step DCI (required if there are steps) */
  ch_recon_method step_method;  /* how h_step is read between texels; 0 = bilinear */
  double tolerance;             /* diffusion tolerance; 0: 1e-6 */
} ch_height_desc;

typedef struct ch_height {
  const ch_curve_set *set;      /* not owned */
  ch_groove_field grooves;
  int has_steps;
  ch_dci dci;
  ch_recon recon;
  ch_recon_method step_method;
} ch_height;

ch_status ch_height_init(ch_height *h, const ch_curve_set *set, const ch_height_desc *desc, ch_error *err);
void ch_height_free(ch_height *h);

/* h(u, v). Thread-safe. */
double ch_height_eval(const ch_height *h, double u, double v);

/* SPEC §5 sampling: an R x R plane (row 0 on top), each pixel the mean of
 * an S x S grid of point samples inside it (S = 1: the centre). Parallel
 * over rows; identical to a serial run. */
void ch_height_render(const ch_height *h, int resolution, int supersample, float *plane);

#ifdef __cplusplus
}
#endif
#endif
