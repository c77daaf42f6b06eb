/* ch_pipeline: one library call per job, from descriptions to results.
 *
 * `chisel displace` is ch_pipeline_displace: read the base mesh and the
 * curves (UDIM tiles included), validate, build the base surface, the warp
 * of a camera, h = h_step + h_groove, tessellate and embed (or displace
 * without embedding), and render the maps. The result holds the displaced
 * mesh, the maps and every statistic; writing files and printing is the
 * caller's (the command line, a viewer, a test). docs/architecture.md shows
 * where each stage lives.
 *
 * Thread safety: a call uses OpenMP inside and shares no state with
 * another call; descriptions are read only. Results are the caller's
 * (free with ch_displace_result_free). */
#ifndef CH_PIPELINE_H
#define CH_PIPELINE_H

#include <stddef.h>

#include "ch_curves.h"
#include "ch_embed.h"
#include "ch_error.h"
#include "ch_exr.h"
#include "ch_image.h"
#include "ch_mesh.h"
#include "ch_progress.h"
#include "ch_recon.h"
#include "ch_surface.h"
#include "ch_warp.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Defaults of the command line (docs/cli.md). */
enum { CH_DISPLACE_DEFAULT_TARGET = 520000, CH_DISPLACE_DEFAULT_RESOLUTION = 1024 };
/* The default cap of the embedding's triangles: 8 x the target plus 8M,
 * far above what drawn features need (the bundled sets: under 1.2 x the
 * target) and below what fills this class of machine (large runs take
 * 300-460 bytes of peak memory per triangle: under 4.5 GB at the cap of a
 * 130k target). */
enum { CH_DISPLACE_DEFAULT_CAP_PER_TARGET = 8, CH_DISPLACE_DEFAULT_CAP_EXTRA = 8388608 };

/* The maps a displace run renders on request, over the UV square at R x R
 * pixel centres (warped UV under a warp). */
enum {
  CH_DISPLACE_HEIGHT_MAP = 1,    /* result.height: one channel h */
  CH_DISPLACE_GEOMETRY_MAPS = 2  /* result.maps: h, the geometry image (P N face s t), u v under a warp */
};

typedef struct ch_displace_desc {
  const char *base_path;    /* the base mesh: OBJ, PLY, OFF or STL with UVs (required) */
  const char *curves_path;  /* the SVG (docs/spec.md §2); for a base in UDIM tiles, the tiles' files by
                               pattern (NAME.<UDIM>.svg, NAME.1001.svg, NAME.svg: docs/udim.md) (required) */
  ch_svg_desc svg;          /* how SVGs drawn without data- attributes are read */
  long target_triangles;    /* the output's triangles, within 5% where the base allows; 0: the default */
  int resolution;           /* R of the step curves' diffusion and of the maps; 0: the default */
  ch_scheme scheme;         /* the base surface: bilinear or catmark */
  int no_snap;              /* the naive mesh: tessellate and displace, no embedding */
  ch_recon_method snap_to;  /* where step walls go: CH_RECON_EXACT, CH_RECON_5X5 or CH_RECON_3X3 */
  const ch_camera *camera;  /* a view-dependent warp for this camera, or NULL */
  int warp_dci;             /* with a camera: diffuse the step curves in warped UV too */
  int maps;                 /* CH_DISPLACE_HEIGHT_MAP | CH_DISPLACE_GEOMETRY_MAPS, or 0 */
  long max_triangles;       /* the embedding's cap: a run whose refinement or cut would make more
                               triangles fails with CH_ERR_INPUT ("the curves need more than N
                               triangles"); 0: CH_DISPLACE_DEFAULT_CAP_PER_TARGET x the target plus
                               CH_DISPLACE_DEFAULT_CAP_EXTRA */
  const ch_progress *progress; /* stage names and progress, or NULL */
} ch_displace_desc;

typedef struct ch_displace_timings { /* seconds */
  double read, surface, warp, height, tessellate, displace, maps, total;
} ch_displace_timings;

typedef struct ch_displace_result {
  ch_mesh mesh;             /* the displaced mesh: original UVs, per-corner normals */
  ch_image height;          /* with CH_DISPLACE_HEIGHT_MAP: R x R, channel h */
  ch_image maps;            /* with CH_DISPLACE_GEOMETRY_MAPS: R x R, channels h P.x P.y P.z N.x N.y N.z
                               face.X s t, and u v (each texel's original UV) under a warp */
  double min_h, max_h;      /* h over the output's vertices */
  long target_triangles;    /* the target the run aimed at */
  int base_triangles;       /* the tessellation the kept run embedded or displaced */
  int passes;               /* embedding runs (pilots included) */
  int udim_tiles;           /* 0 for a base in the UV square, else its tiles */
  int resolution;           /* R as run (a UDIM atlas raises it so each tile keeps R texels) */
  int snapped;              /* 1 when the features were embedded */
  ch_embed_stats embed;     /* with snapped */
  int warped;               /* 1 when a warp was applied (a camera can leave none: a warning says why) */
  ch_warp_stats warp;       /* with warped */
  int warp_cage_triangles;  /* with warped: the cage's triangles */
  double warp_visible_triangle_share; /* with warped: share of output triangles the camera sees */
  double warp_seconds;      /* with warped: building W and warping the curves */
  char *warp_text;          /* with warped: the maps' EXR attributes chisel:space, chisel:warp,
                               chisel:warp_u, chisel:warp_v as four NUL-terminated strings */
  ch_displace_timings seconds;
} ch_displace_result;

/* Runs displace. Bad input (a mesh or SVG that does not parse, faces
 * without area or UV area, UDIM tiles without their curve file, UDIM with
 * maps or a camera) returns CH_ERR_INPUT with one line naming the file;
 * warnings (a run off its target, unresolved triangles, a camera that sees
 * nothing) go through err's warn callback. out is zeroed on failure. */
ch_status ch_pipeline_displace(const ch_displace_desc *desc, ch_displace_result *out, ch_error *err);

/* Frees what a result holds and zeroes it. */
void ch_displace_result_free(ch_displace_result *r);

/* How the maps are written: desc for ch_exr_write over result.maps, with
 * the attributes of the run (command, rect, the warp) and a luminance Y =
 * 0.5 + h / (2 s) for viewers, s = max |h| (written as chisel:height_scale).
 * storage keeps the strings the attributes point to; *height_scale
 * receives s. Valid while result and storage live. */
typedef struct ch_displace_exr {
  ch_exr_write_desc desc;
  ch_exr_attribute attributes[8];
  char scale_text[32];
} ch_displace_exr;
void ch_displace_exr_desc(const ch_displace_result *result, ch_displace_exr *storage, double *height_scale);

/* An EXR's Y for a height channel h, as image viewers and Blender's image
 * texture read it (they look for Y or R G B): Y = 0.5 + h / (2 s) with s =
 * max |h| over the finite values (0.5 is h = 0, the same map as a height
 * PNG), so carved and raised parts both show; h stays exact beside it.
 * Sets desc's luminance fields for channel `name` of plane (n values),
 * prints s into scale_text (the chisel:height_scale attribute) and returns
 * it. */
double ch_pipeline_height_luminance(const float *plane, size_t n, const char *name, ch_exr_write_desc *desc,
                                    char *scale_text, size_t scale_size);

/* The note written beside Y as the chisel:Y attribute. */
#define CH_PIPELINE_Y_NOTE \
  "Y = 0.5 + h / (2 s), s = chisel:height_scale; Blender Displace: midlevel 0.5, strength 2 s"

#ifdef __cplusplus
}
#endif
#endif
