/* ch_samples: the feature samples of a diffusion-curve image
 * (diffusion-curves-on-surfaces §3.3): per texel of a W x H grid over a UV
 * rectangle, the closest point SP on the step curves, which curve, chain and
 * parameter it lies at, the texel's side, its distance, and the values (and
 * colours) on its side and on the opposite side.
 *
 * Texel (x, y), row 0 on top, has its centre at
 *   u = u0 + (x + 1/2) (u1 - u0) / W,   v = v1 - (y + 1/2) (v1 - v0) / H,
 * so a crop of the UV square can be sampled at any resolution. */
#ifndef CH_SAMPLES_H
#define CH_SAMPLES_H

#include <stdint.h>

#include "ch_curves.h"
#include "ch_error.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Side bits of a sample. An END sample's closest point is an open end of a
 * curve; it still has LEFT or RIGHT by the tangent line there. SOFT: the
 * curve has a blur, so no crisp edge is reconstructed along it. CLOSED: the
 * sample's chain is a closed subpath (its parameter wraps from 1 to 0). */
enum { CH_SIDE_LEFT = 1, CH_SIDE_RIGHT = 2, CH_SIDE_END = 4, CH_SIDE_SOFT = 8, CH_SIDE_CLOSED = 16 };

enum { CH_SAMPLES_MAX_COLORS = 3 };

typedef struct ch_samples {
  int width, height;
  double rect[4];        /* u0 v0 u1 v1 */
  double texel[2];       /* texel size in u and v */
  double band;           /* samples closer than this (texels) are exact */
  int num_colors;        /* 3 if any step curve has colours, else 0 */
  /* Per texel, row-major, row 0 on top. No curve: curve = -1. */
  float *offset;         /* 2 per texel: SP - centre, in texels (x right, y up) */
  float *distance;       /* |SP - centre| in texels */
  int32_t *curve;        /* nearest step curve */
  int32_t *segment;      /* its segment holding SP */
  float *seg_t;          /* SP's parameter on that segment */
  int32_t *chain;        /* subpath of SP: samples join only within a chain */
  float *param;          /* SP's position along its chain, in [0, 1] */
  uint8_t *side;         /* CH_SIDE_* bits */
  uint8_t *exact;        /* 1: SP exact (within the band); 0: propagated */
  float *value;          /* 2 per texel: value on its own side, opposite side */
  float *color;          /* 6 per texel (own rgb, opposite rgb) or NULL */
} ch_samples;

/* Builds the samples of the step curves of set (grooves are ignored) over
 * rect at width x height. Texels within `band` texels of a curve get the
 * exact closest point (a grid over the curve segments keeps this
 * proportional to the curves' length); all others get the closest point of
 * their nearest band sample by a two-pass propagation (8SSEDT order),
 * O(W H). Parallel over rows; deterministic. */
ch_status ch_samples_build(const ch_curve_set *set, int width, int height, const double rect[4],
                           double band, ch_samples *out, ch_error *err);

/* The same over the step curves c with use_curve[c] != 0 only (use_curve
 * has set->num_curves entries; NULL means every step curve); colors 0
 * leaves the colours out (num_colors 0, color NULL) even where curves have
 * them: a quarter of the samples' memory that only a colour DCI reads. */
ch_status ch_samples_build_subset(const ch_curve_set *set, const unsigned char *use_curve, int width, int height,
                                  const double rect[4], double band, int colors, ch_samples *out, ch_error *err);

void ch_samples_free(ch_samples *samples);

/* The UV centre of texel (x, y). */
static inline void ch_samples_center(const ch_samples *s, int x, int y, double uv[2]) {
  uv[0] = s->rect[0] + (x + 0.5) * s->texel[0];
  uv[1] = s->rect[3] - (y + 0.5) * s->texel[1];
}

#ifdef __cplusplus
}
#endif
#endif
