/* ch_geomimage: a geometry image of the base surface (Gu et al. 2002, as
 * diffusion-curves-on-surfaces §3.5 uses it): for every texel centre of a
 * W x H grid over a UV rectangle, the base face whose UV patch holds it,
 * the point (s, t) of that face, and the surface's position and normal
 * there, evaluated exactly through ch_surface (not interpolated).
 *
 * It lives in tess/ rather than mesh/ (where the original design put geometry
 * images) because it evaluates the OpenSubdiv surface, and mesh/ must not
 * depend on tess/. */
#ifndef CH_GEOMIMAGE_H
#define CH_GEOMIMAGE_H

#include "ch_error.h"
#include "ch_image.h"
#include "ch_surface.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ch_geomimage {
  int width, height;
  double rect[4];     /* u0 v0 u1 v1 */
  int *face;          /* W*H: base face covering the texel centre, -1 if none */
  float *st;          /* 2 per texel: its (s, t) in that face */
  float *uv;          /* 2 per texel: the UV of its centre (in warped images
                         taken back through the warp), for every texel */
  float *position;    /* 3 per texel: B */
  float *normal;      /* 3 per texel: N */
  long covered;       /* texels with a face */
} ch_geomimage;

/* Rasterises every face's UV patch (a quad: its bilinear patch; other
 * faces: their quad sub-faces as ch_surface parameterises them) over the
 * texel centres, inverts the bilinear UV map to (s, t) and evaluates B and
 * N. Where UV patches overlap, the lowest-numbered face wins. Parallel over
 * rows of texels; deterministic. rect NULL: the unit square. */
ch_status ch_geomimage_build(const ch_surface *surface, int width, int height, const double rect[4],
                             ch_geomimage *out, ch_error *err);

/* The same over texels of warped UV (the unit square of ch_warp.h, rect
 * must be NULL or the unit square): each texel centre is taken back to UV
 * through C^-1 (ch_warp_unmap), so the image holds the surface with the
 * warp's texel density. warp NULL: ch_geomimage_build. */
ch_status ch_geomimage_build_warped(const ch_surface *surface, int width, int height, const double rect[4],
                                    const struct ch_warp *warp, ch_geomimage *out, ch_error *err);
void ch_geomimage_free(ch_geomimage *gi);

/* The geometry image as EXR layers, CH_GEOMIMAGE_CHANNELS of them named
 * ch_geomimage_channel_names: P.x P.y P.z, N.x N.y N.z, face.X (the base
 * face, -1 outside the charts; a one-channel layer, as Blender names its
 * index passes, since Blender's multilayer reader refuses a channel name
 * of more than one letter without a layer), s, t. */
enum { CH_GEOMIMAGE_CHANNELS = 9 };
extern const char *const ch_geomimage_channel_names[CH_GEOMIMAGE_CHANNELS];
/* The geometry image over the unit square (of warped UV where warp is not
 * NULL) straight into the caller's float planes, of width * height each:
 * planes[0..8] the channels above (face.X -1.0 outside the charts), then
 * planes[9], planes[10] each texel centre's UV (u, v); any may be NULL (not
 * written). The same values as ch_geomimage_build_warped, without its
 * arrays (44 bytes a texel: 740 MB at 4096^2 for maps that are EXR planes
 * anyway). *covered (may be NULL): the texels with a face. */
ch_status ch_geomimage_build_planes(const ch_surface *surface, int width, int height, const struct ch_warp *warp,
                                    float *const planes[CH_GEOMIMAGE_CHANNELS + 2], long *covered, ch_error *err);

/* Finds the (s, t) of face whose UV is uv. Returns CH_OK with st set, or
 * CH_ERR_INPUT if uv is not inside the face's UV patch (within 1e-9). */
ch_status ch_surface_locate(const ch_surface *surface, int face, const double uv[2], double st[2]);

#ifdef __cplusplus
}
#endif
#endif
