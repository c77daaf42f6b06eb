/* ch_metrics: a method's render against the truth's, pixel by pixel, for
 * the same camera (docs/cli.md, chisel study: the summary's columns). Both
 * are ch_render outputs. */
#ifndef CH_METRICS_H
#define CH_METRICS_H

#include "ch_error.h"
#include "ch_image.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ch_metrics {
  long pixels;          /* all pixels */
  long groove_pixels;   /* pixels where the truth or the method has a groove class (wall or floor) */
  long id_pixels;       /* pixels where both have the same class among groove wall, floor, step wall */
  long both_hit;        /* pixels both cover (coverage > 0) */
  double class_mismatch;        /* % of all pixels whose class differs */
  double class_mismatch_groove; /* % of groove_pixels whose class differs */
  double id_mismatch;           /* % of id_pixels whose curve id differs */
  double depth_error;           /* mean |depth - depth_truth| over both_hit, / scene_size */
  double normal_mean_deg, normal_p95_deg; /* angle between the normals over both_hit (p95: nearest rank) */
  double shade_rmse;            /* over all pixels (shade in [0, ~1]) */
  double shade_ssim;            /* perceptual: mean SSIM of the shading (Wang et al. 2004:
                                   Gaussian window sigma 1.5 px, 11 taps, edges clamped,
                                   C1 = 0.01^2, C2 = 0.03^2 for a range of 1); 1 = same */
  double shadow_mismatch;       /* % of both_hit where the shadow shares differ by more than 1/2 */
} ch_metrics;

/* Compares method with truth (same size, ch_render layers). scene_size
 * (> 0, e.g. the scene's diagonal) scales the depth error. Mismatched
 * sizes or missing layers give CH_ERR_INPUT. A percentage over an empty
 * set is 0. */
ch_status ch_metrics_compare(const ch_image *method, const ch_image *truth, double scene_size, ch_metrics *out,
                             ch_error *err);

#ifdef __cplusplus
}
#endif
#endif
