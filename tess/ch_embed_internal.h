/* ch_embed internals shared by the embedding's modules and its tests (not
 * installed): the knobs ch_embed_to_target's count model sets on each run. */
#ifndef CH_EMBED_INTERNAL_H
#define CH_EMBED_INTERNAL_H

#include "ch_embed.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ch_embed_pilot {
  int count_only;        /* only count the triangles the cut makes
                            (stats->triangles, before the cleanup; out stays
                            empty): the pilots of ch_embed_to_target */
  double reference_edge; /* e of the angle-step and thinning rules (see
                            ch_embed_desc); 0 -> the tessellation's mean UV
                            edge (ch_embed_to_target sets the target's, so
                            the lines do not change between its runs) */
  int run;               /* 1, 2, ...: the run number progress reports */
} ch_embed_pilot;

/* ch_embed_build with the pilot knobs (NULL: as ch_embed_build). Same
 * contract otherwise. */
ch_status ch_embed_run(const ch_surface *surface, const ch_tess_result *tess, const ch_height *height,
                       const ch_embed_desc *desc, const ch_embed_pilot *pilot, ch_mesh *out, ch_embed_stats *stats,
                       ch_error *err);

#ifdef __cplusplus
}
#endif
#endif
