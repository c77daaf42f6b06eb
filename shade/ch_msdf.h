/* ch_msdf: the multi-channel signed distance field of Chlumsky's msdfgen
 * (V. Chlumsky, "Shape Decomposition for Multi-channel Distance Fields",
 * MSc thesis, CTU Prague 2015, and msdfgen 1.x), today's practical way to
 * keep vector edges crisp in a texture, as the baseline for the feature
 * maps: edges coloured so that corners see two channels, per channel the
 * signed pseudo-distance to its nearest edge, the legacy clash correction,
 * and evaluation as its users do it: bilinear per channel, then the median
 * of the three.
 *
 * Layout: the lattice of ch_featmap.h ((R + 1)^2 points at the corners of
 * R x R cells, the same tiny offsets), so both can be read at the same
 * points and stored in one file. Channel values are signed distances in UV
 * (positive on the curve's left, docs/spec.md §3), clamped to +-range as msdfgen's
 * pixel range clamps them. A nearest-curve id per point (nearest-neighbour
 * lookup, as an id texture would be read) lets the normal use the curve's
 * profile.
 *
 * Thread safety: read-only after build; ch_msdf_eval is shader-shaped. */
#ifndef CH_MSDF_H
#define CH_MSDF_H

#include <stdint.h>

#include "ch_curves.h"
#include "ch_error.h"
#include "ch_featmap.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Zero means default. */
typedef struct ch_msdf_desc {
  int resolution;         /* R (required): CH_FEATMAP_MIN_RES..CH_FEATMAP_MAX_RES */
  double rect[4];         /* u0 v0 u1 v1; all zero: the unit square */
  double angle_threshold; /* corners: a turn sharper than pi - this (radians); 0: 3 (msdfgen's) */
  double range;           /* clamp, in cells: 0: the widest groove's half width plus 2, at least 4 */
  int no_correction;      /* skip the clash correction */
} ch_msdf_desc;

typedef struct ch_msdf_stats {
  int edges, corners, contours;
  long clashes;           /* lattice points set to their median by the correction */
  double seconds;
} ch_msdf_stats;

typedef struct ch_msdf {
  int resolution;
  double rect[4];
  double range;           /* UV */
  float *channels;        /* 3 per lattice point (R, G, B): signed pseudo-distances, UV */
  int32_t *curve;         /* nearest curve per lattice point */
  ch_featmap_curve *curves;
  int num_curves;
  ch_msdf_stats stats;
} ch_msdf;

/* Builds the field of set's encoded curves (ch_featmap_encodes). No curve
 * to encode or R out of range give CH_ERR_INPUT. Parallel over rows; the
 * same result for any thread count. out is zeroed on failure. */
ch_status ch_msdf_build(const ch_curve_set *set, const ch_msdf_desc *desc, ch_msdf *out, ch_error *err);

void ch_msdf_free(ch_msdf *msdf);

/* At (u, v): bilinear per channel, median; side, distance, the gradient of
 * the median's bilinear interpolant, the nearest lattice point's curve,
 * and the normal of its profile (ch_featmap_profile_normal, flat base).
 * Shader-shaped; thread-safe. */
void ch_msdf_eval(const ch_msdf *msdf, double u, double v, ch_featmap_sample *out);

/* Bytes per lattice point as evaluated: three float32 channels and an
 * int32 curve id. */
double ch_msdf_bytes_per_texel(void);

#ifdef __cplusplus
}
#endif
#endif
