/* ch_edt: nearest-seed propagation over a grid (the two raster passes of
 * Danielsson's 8SSEDT, carrying each seed's nearest curve point), so that
 * samples far from the curves know their nearest one at O(W H) cost once
 * the samples near them are exact. Shared by the feature maps and the
 * multi-channel distance field; ch_samples keeps the DCI's own copy. */
#ifndef CH_EDT_H
#define CH_EDT_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* One sample's state: its seed's nearest curve point in grid coordinates
 * (x right, y along the rows), the squared distance to it, and the seed
 * (an exact sample's index, or -1 for none yet). */
typedef struct ch_edt_rec {
  float x, y, d2;
  int32_t seed;
} ch_edt_rec;

/* Propagates seeds into every sample whose exact[] is 0 (exact samples are
 * left alone), rows of W samples, H rows. Sequential and deterministic. */
void ch_edt_propagate(ch_edt_rec *recs, const uint8_t *exact, int W, int H);

#ifdef __cplusplus
}
#endif
#endif
