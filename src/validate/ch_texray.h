/* ch_texray: the texture-space methods that move hits along the ray, as
 * study shaders (ch_render_shader) on the planar base (u, v, 0): the
 * path-based groove textures (ch_gtex), relief mapping and parallax
 * occlusion mapping (ch_relief). The renderer traces the base mesh; the
 * shader re-traces the same ray in texture space from where it enters the
 * textures' height range (before the base for raised features), so the
 * hit it returns may lie before or after the base's, may be a wall
 * (groove textures only) and carries the method's normal; shadow rays are
 * answered in texture space (`occluded`), never against the base mesh.
 *
 * Thread safety: read-only after creation; the shaders may be called from
 * many threads at once. */
#ifndef CH_TEXRAY_H
#define CH_TEXRAY_H

#include <stddef.h>

#include "ch_curves.h"
#include "ch_error.h"
#include "ch_height.h"
#include "ch_render.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum ch_texray_kind { CH_TEXRAY_GROOVES = 0, CH_TEXRAY_RELIEF, CH_TEXRAY_POM } ch_texray_kind;

struct ch_texray;

typedef struct ch_texray_desc {
  ch_texray_kind kind;
  int resolution; /* grooves: the grid's G; relief, pom: the height texture's R */
  int steps;      /* relief, pom: linear steps (0: 32) */
  int paper;      /* grooves: curved elements as the paper intersects them */
  const struct ch_texray *same_map; /* relief, pom: a method built with the
                                       same resolution, whose height
                                       texture is copied rather than baked
                                       again (NULL: bake) */
} ch_texray_desc;

typedef struct ch_texray ch_texray;

/* Builds the method's textures from the curves (grooves) or from height
 * (relief, pom: baked as `chisel sample` bakes h). set and height are not
 * kept. curves_name names the curve file in messages. Bad parameters and
 * curves the method cannot hold give CH_ERR_INPUT (ch_gtex_build,
 * ch_relief_build). */
ch_status ch_texray_create(const ch_texray_desc *desc, const ch_curve_set *set, const ch_height *height,
                           const char *curves_name, ch_texray **out, ch_error *err);
void ch_texray_destroy(ch_texray *tr);

/* Bytes of the method's textures. */
size_t ch_texray_bytes(const ch_texray *tr);

/* The shader (user = tr, which must outlive it). */
ch_render_shader ch_texray_shader(const ch_texray *tr);

#ifdef __cplusplus
}
#endif
#endif
