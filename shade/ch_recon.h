/* ch_recon: feature reconstruction (diffusion-curves-on-surfaces §3.3-3.4):
 * evaluates a DCI at any UV from its samples alone, keeping the step curves
 * crisp at any magnification, and exposes the reconstructed curve (nearest
 * point and side) that the mesh is snapped onto. */
#ifndef CH_RECON_H
#define CH_RECON_H

#include "ch_curves.h"
#include "ch_dci.h"
#include "ch_grid.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum ch_recon_method {
  CH_RECON_BILINEAR = 0, /* plain bilinear interpolation of the texels */
  CH_RECON_5X5,          /* the paper's reconstruction from 5x5 sorted samples */
  CH_RECON_3X3,          /* its faster 3x3 variant with per-sample side regions */
  CH_RECON_EXACT         /* the side from the exact vector curves (reference) */
} ch_recon_method;

/* What the reconstruction found at a point. */
typedef struct ch_recon_sample {
  float value;          /* h */
  float color[3];       /* when the DCI has colours */
  int curve;            /* the curve whose edge decides the point, or -1 */
  int side;             /* CH_SIDE_LEFT or CH_SIDE_RIGHT of it (0 if no curve) */
  double point[2];      /* nearest point of the reconstructed curve (UV) */
  double distance;      /* UV distance to it */
} ch_recon_sample;

/* An evaluator over a DCI. For CH_RECON_EXACT it also needs the curves (set
 * may be NULL for the other methods) and keeps a grid over the step
 * segments. Read-only after init: thread-safe queries. */
typedef struct ch_recon {
  const ch_dci *dci;
  const ch_curve_set *set;
  ch_grid grid;
  double (*boxes)[4];
} ch_recon;

ch_status ch_recon_init(ch_recon *r, const ch_dci *dci, const ch_curve_set *set, ch_error *err);
void ch_recon_free(ch_recon *r);

/* Evaluates at (u, v). footprint > 0 is a screen pixel's size in UV: points
 * within half a pixel of the curve are anti-aliased by the paper's eq. (1);
 * 0 gives the crisp value. */
void ch_recon_eval(const ch_recon *r, ch_recon_method method, double u, double v, double footprint,
                   ch_recon_sample *out);

/* The same (crisp) with the side of one curve given: where the samples
 * see that curve, the point is taken to lie on `side` (CH_SIDE_LEFT or
 * CH_SIDE_RIGHT) of it, whatever its position says. For points on the
 * curve itself (within rounding) whose side the caller knows better, e.g.
 * from the curve in another parameterisation (the warp). */
void ch_recon_eval_side(const ch_recon *r, ch_recon_method method, double u, double v, int curve, int side,
                        ch_recon_sample *out);

/* Whether every point of the UV box u0..u1 x v0..v1 reads as the plain
 * bilinear blend of the texels under method: no curve near enough to
 * decide a point (a sample's side) and no singular or layer term. There
 * ch_recon_eval_plain gives the same bits as ch_recon_eval's crisp value,
 * at a fraction of its cost. Conservative: 0 may be answered for a plain
 * box (one spanning many texels, or a DCI with colours). */
int ch_recon_box_is_plain(const ch_recon *r, ch_recon_method method, double u0, double v0, double u1, double v1);
float ch_recon_eval_plain(const ch_recon *r, double u, double v);

/* Parses "bilinear", "recon5", "recon3" or "exact"; -1 if unknown. */
int ch_recon_method_parse(const char *name);

#ifdef __cplusplus
}
#endif
#endif
