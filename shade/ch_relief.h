/* ch_relief: relief mapping (Policarpo, Oliveira and Comba 2005: "Real-time
 * relief mapping on arbitrary polygonal surfaces") and parallax occlusion
 * mapping (Tatarchuk 2006: "Dynamic parallax occlusion mapping with
 * approximate soft shadows"), the per-pixel displacement methods game
 * engines use, on an R x R height texture of SPEC §3's h: the baselines
 * the path-based groove textures (ch_gtex) are measured against.
 *
 * Set up as an engine user would: the height map is what `chisel sample
 * --res R` writes (each texel the mean of 4 x 4 point samples of h), read
 * bilinearly with clamp-to-edge; the relief volume spans the map's range
 * [hmin, hmax] over the UV square (the polygon at its top); normals come
 * from the map by central differences one texel apart (what a normal map
 * baked from it holds); no walls (a height map has none).
 * - relief: linear search of K equal steps from where the ray enters the
 *   volume to where it leaves it at hmin, then 8 binary search steps
 *   between the last point above and the first below (Policarpo's 5-8).
 * - pom: the step count interpolated between K (grazing) and max(4, K/4)
 *   (straight down) by the cosine of the view angle, and the intersection
 *   of the ray with the segment joining the heights at the last two
 *   steps (Tatarchuk's linear refinement), no binary search.
 * Shadows (Policarpo's): the same search from where the ray towards the
 * light leaves the volume back down to the hit; in shadow if it stops
 * above the hit by more than the search's depth resolution (one linear
 * step for pom, a 64th of one for relief: the bias against the
 * self-shadowing speckle a march from the hit itself gives).
 * Everything per ray is shader-shaped (bounded loops, no allocation) and
 * reads only the height texture; thread-safe. */
#ifndef CH_RELIEF_H
#define CH_RELIEF_H

#include <stddef.h>

#include "ch_error.h"
#include "ch_height.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum ch_relief_method { CH_RELIEF_RELIEF = 0, CH_RELIEF_POM = 1 } ch_relief_method;

enum {
  CH_RELIEF_MIN_RES = 2,
  CH_RELIEF_MAX_RES = 16384,
  CH_RELIEF_MIN_STEPS = 1,
  CH_RELIEF_MAX_STEPS = 4096,
  CH_RELIEF_BINARY_STEPS = 8
};

/* Zero means default. */
typedef struct ch_relief_desc {
  int resolution;        /* R: required, CH_RELIEF_MIN_RES..CH_RELIEF_MAX_RES */
  int steps;             /* K linear steps: CH_RELIEF_MIN_STEPS..CH_RELIEF_MAX_STEPS; 0: 32 */
  ch_relief_method method;
  int supersample;       /* point samples per texel side when baking; 0: 4 */
} ch_relief_desc;

typedef struct ch_relief {
  int resolution, steps, min_steps;
  ch_relief_method method;
  float *h;              /* R x R, row 0 at v = 1 (SPEC §5's layout) */
  double hmin, hmax;
} ch_relief;

/* Bakes the height texture of height (ch_height_render) and sets up the
 * method. Bad parameters give CH_ERR_INPUT naming them. Parallel. */
ch_status ch_relief_build(ch_relief *r, const ch_height *height, const ch_relief_desc *desc, ch_error *err);
/* The same method set up on a copy of from's height texture (of the same
 * resolution): relief and POM of one map without baking it twice. */
ch_status ch_relief_copy(ch_relief *r, const ch_relief *from, const ch_relief_desc *desc, ch_error *err);

void ch_relief_free(ch_relief *r);

/* Bytes of the height texture (4 per texel). */
size_t ch_relief_bytes(const ch_relief *r);

/* The height texture at (u, v), bilinear, clamp to edge. */
double ch_relief_height(const ch_relief *r, double u, double v);

typedef struct ch_relief_hit {
  double t;
  double point[3];  /* (u, v, height) */
  double normal[3]; /* from the map (central differences), unit */
} ch_relief_hit;

/* Marches org + t dir (x = u, y = v, z up; dir pointing down into the
 * volume) through the relief volume over the UV square. Returns 1 with
 * the hit, 0 if the ray misses the volume or climbs out of it. */
int ch_relief_intersect(const ch_relief *r, const double org[3], const double dir[3], ch_relief_hit *hit);

/* Whether the map occludes the ray from org along dir (upwards) before it
 * leaves the volume. */
int ch_relief_occluded(const ch_relief *r, const double org[3], const double dir[3]);

#ifdef __cplusplus
}
#endif
#endif
