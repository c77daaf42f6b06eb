/* ch_featshade: the feature-map normal methods as study shaders
 * (ch_render_shader): on the planar base (u, v, 0), whose UV axes are the
 * world's x and y, a hit's normal is replaced by the method's normal at
 * its UV: featnorm, featnorm-linear, normal-bilinear (the conventional
 * normal map, bilinear) or msdf. No parallax, masking or silhouettes: what
 * a normal map can show.
 *
 * Thread safety: the shader only reads its maps; it may be called from
 * many threads at once. */
#ifndef CH_FEATSHADE_H
#define CH_FEATSHADE_H

#include "ch_error.h"
#include "ch_featmap.h"
#include "ch_height.h"
#include "ch_msdf.h"
#include "ch_render.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum ch_featshade_method {
  CH_FEATSHADE_FEATNORM = 0,
  CH_FEATSHADE_LINEAR,
  CH_FEATSHADE_NORMAL_BILINEAR,
  CH_FEATSHADE_MSDF
} ch_featshade_method;

/* Parses "featnorm", "featnorm-linear", "normal-bilinear" or "msdf"; -1. */
int ch_featshade_method_parse(const char *name);

/* The method's name, as parsed. */
const char *ch_featshade_method_name(ch_featshade_method method);

/* The maps a method reads, built over the unit square at resolution R. */
typedef struct ch_featshade {
  ch_featshade_method method;
  ch_featmap maps;
  ch_msdf msdf;
} ch_featshade;

/* Builds what method needs from the curves (height gives h_step for the
 * base and conventional normal maps; it may be NULL without step curves;
 * not owned). */
ch_status ch_featshade_init(ch_featshade *fs, ch_featshade_method method, int resolution, const ch_curve_set *set,
                            const ch_height *height, ch_error *err);
void ch_featshade_free(ch_featshade *fs);

/* Bytes a GPU layout of the method's maps takes at its resolution R:
 * R x R texels at ch_featmap_bytes_per_texel (and the fallback lists of
 * featnorm and featnorm-linear) or ch_msdf_bytes_per_texel. */
size_t ch_featshade_bytes(const ch_featshade *fs);

/* The shader; fs must outlive it. */
ch_render_shader ch_featshade_shader(const ch_featshade *fs);

#ifdef __cplusplus
}
#endif
#endif
