/* ch_height: the displacement h = h_step + h_groove of docs/spec.md §3 at any UV:
 * exact grooves, and steps from a diffusion-curve image read through
 * feature reconstruction. */
#ifndef CH_HEIGHT_H
#define CH_HEIGHT_H

#include "ch_curves.h"
#include "ch_dci.h"
#include "ch_groove.h"
#include "ch_recon.h"
#include "ch_warp.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ch_height_desc {
  int dci_resolution;           /* R of the step DCI (required if there are steps) */
  ch_recon_method step_method;  /* how h_step is read between texels; 0 = bilinear */
  double tolerance;             /* diffusion tolerance; 0: 1e-6 */
  const ch_warp *warp;          /* NULL, or the view-dependent warp: the DCI
                                   is then built over the step curves warped
                                   through it (ch_warp_curves), R x R texels
                                   of warped UV, blur radii warped too, and
                                   h_step(u, v) is read at C(u, v). Not
                                   owned; must outlive the height. */
  int no_singular;              /* 1: the DCI without its singular terms (ch_dci_desc) */
  int no_extrapolate;           /* 1: the DCI's fixed texels at their side's value (ch_dci_desc) */
} ch_height_desc;

typedef struct ch_height {
  const ch_curve_set *set;      /* not owned */
  ch_groove_field grooves;
  int has_steps;
  ch_dci dci;
  ch_recon recon;
  ch_recon_method step_method;
  const ch_warp *warp;          /* not owned, or NULL */
  ch_curve_set warped;          /* the curves in warped UV (with a warp and steps) */
  ch_warp_curve_stats warp_stats;
} ch_height;

ch_status ch_height_init(ch_height *h, const ch_curve_set *set, const ch_height_desc *desc, ch_error *err);
void ch_height_free(ch_height *h);

/* The step part at (u, v) in original UV: the DCI read with step_method
 * (through the warp when there is one; then the sample's point and
 * distance are in warped UV). Needs has_steps. Thread-safe. */
void ch_height_step(const ch_height *h, double u, double v, ch_recon_sample *out);
/* The same on a given side of a step curve (ch_recon_eval_side): for
 * points on the curve, whose side in UV the warped DCI cannot tell. */
void ch_height_step_side(const ch_height *h, double u, double v, int curve, int side, ch_recon_sample *out);
/* h(u, v), u v in original UV. Thread-safe. */
double ch_height_eval(const ch_height *h, double u, double v);

/* docs/spec.md §5 sampling: an R x R plane (row 0 on top), each pixel the mean of
 * an S x S grid of point samples inside it (S = 1: the centre). Parallel
 * over rows; identical to a serial run. */
void ch_height_render(const ch_height *h, int resolution, int supersample, float *plane);
/* The same over warped UV: each sample point is taken back to UV through
 * C^-1 (ch_warp_unmap) first. warp NULL: ch_height_render. */
void ch_height_render_warped(const ch_height *h, const ch_warp *warp, int resolution, int supersample,
                             float *plane);

#ifdef __cplusplus
}
#endif
#endif
