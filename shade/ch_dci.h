/* ch_dci: a diffusion-curve image (diffusion-curves-on-surfaces §3.2-3.3):
 * the feature samples of the step curves, the diffused values (h_step of
 * docs/spec.md §3, and RGB when curves carry colours) and the reblur. Together with
 * ch_recon it evaluates h_step crisply at any UV. */
#ifndef CH_DCI_H
#define CH_DCI_H

#include "ch_curves.h"
#include "ch_diffuse.h"
#include "ch_dlayer.h"
#include "ch_error.h"
#include "ch_grid.h"
#include "ch_image.h"
#include "ch_samples.h"
#include "ch_stepsing.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Zero means default. */
typedef struct ch_dci_desc {
  int resolution;     /* R: R x R texels (required) */
  double rect[4];     /* u0 v0 u1 v1; all zero: the unit square */
  double tolerance;   /* diffusion relative residual; 0: 1e-6 */
  int no_colors;      /* 1: diffuse h only, even where curves have colours
                         (displacement needs no colour; rgb stays NULL) */
  const float *blur_scale[2]; /* NULL, or per column (x) and per row (y):
                         texels per texel-sized UV step along that axis (the
                         warp's slope there), so data-blur radii, given in UV,
                         are warped like the texture (diffusion-curves §3.2) */
  int no_singular;    /* 1: diffuse h_step as it is, without taking the
                         singular terms out (to measure what they give) */
  int no_extrapolate; /* 1: fixed texels hold their side's value at the
                         curve as it is (first order; see below) */
} ch_dci_desc;

typedef struct ch_dci {
  ch_samples samples;      /* layout, closest points, sides, side values */
  float *h;                /* W*H: diffused and reblurred value (h_step) */
  float *rgb;              /* 3*W*H or NULL: diffused colour */
  float *blur;             /* W*H blur radius in texels, or NULL (no blur) */
  unsigned char *fixed;    /* W*H: 1 where the texel was a Dirichlet texel */
  ch_diffuse_stats stats;
  int extrapolations;      /* rounds of the fixed texels' extrapolation run */
  double seconds_samples, seconds_diffuse, seconds_blur;
  double seconds_terms; /* the singular terms and layers: set up, taken out, put back */
  /* The singular terms taken out of h before the diffusion (see below):
   * points in the texel frame (x right, y up, texel (x, y) at (x, -y),
   * texel units), each with its window's radius; a grid over the windows. */
  int num_sing;
  ch_stepsing_point *sing;
  ch_grid sing_grid; /* over the windows */
  /* The double layers taken out with them (see below), in the same frame,
   * and a grid over their windows. */
  int num_layers;
  ch_dlayer *layers;
  double *layer_far; /* per layer: texels from its box where its window ends */
  ch_grid layer_grid;
} ch_dci;

/* Texels at most this far (in texels) from a curve, on its side, are fixed
 * to that side's value. One texel is the least that keeps diffusion from
 * leaking across: a curve crossing the segment between two neighbouring
 * texel centres is within one texel of both. */
#define CH_DCI_FIXED_BAND 1.0
/* A fixed texel lies up to CH_DCI_FIXED_BAND off its curve, so holding the
 * side's value there moves the boundary by up to a texel: h converges only
 * at first order. Instead each holds the value at the curve extended along
 * the curve's normal to its centre, v + d (u(D) - v) / D, with u(D) the
 * solution (bilinear) CH_DCI_EXTRAPOLATE_PROBE texels out on its side: a
 * ghost value (Gibou, Fedkiw, Cheng, Kang, "A second-order-accurate
 * symmetric discretization of the Poisson equation on irregular domains",
 * JCP 176, 2002, here with a linear extrapolation), second order. The
 * values depend on the solution, so the solve is repeated from the last
 * one: each round's change is at most d / D <= 1/2 of the last's, and
 * over-relaxed by CH_DCI_EXTRAPOLATE_OMEGA three rounds reach what six
 * plain ones do (a circle between two Dirichlet circles, whose h is a
 * logarithm: mean error 1.1e-3 -> 1.5e-5 of the range at 1024^2). The
 * solves before the last stop at CH_DCI_EXTRAPOLATE_TOLERANCE (they only
 * feed the next round). Texels whose probe would read another region (a
 * slab thinner than the probe, another curve, an end) keep the side's
 * value. */
#define CH_DCI_EXTRAPOLATE_PROBE 2.0
#define CH_DCI_EXTRAPOLATE_ROUNDS 3
#define CH_DCI_EXTRAPOLATE_OMEGA 1.4
#define CH_DCI_EXTRAPOLATE_TOLERANCE 1e-4
/* Exact closest points are computed this far from curves (texels); the
 * reconstruction reads a 5 x 5 neighbourhood. */
#define CH_DCI_SAMPLE_BAND 3.0

/* Singular terms. Where sharp step curves end or cross, h_step is to first
 * order T = a + b theta in each sector (ch_stepsing), with a gradient like
 * 1/r that no texel grid follows: the diffusion converges there only at
 * first order, and the error runs out along the arms (their fixed texels
 * sit up to a texel off the curve, where h's normal derivative is b / r).
 * So the build solves for the remainder h - phi T, phi a window round the
 * point (1 up to CH_DCI_SING_INNER of its radius, 0 from the radius, which
 * stops half way to the next point): harmonic but for a source where phi
 * falls, and with Dirichlet data side value - phi T taken at each fixed
 * texel's closest curve point, which vanish along straight arms. The
 * zero-flux border leaves the remainder the flux of -phi T there, so the
 * window may cross it. h at texel centres (the h layer) is the remainder
 * plus phi T; ch_recon blends h - T near the point and adds T back.
 * Radius in texels: */
#define CH_DCI_SING_RADIUS 256.0
/* Double layers. An open sharp step curve whose two ends lie inside the
 * grid (CH_DCI_SING_MIN from its border) is taken out whole: its double
 * layer W (ch_dlayer.h) carries its jump exactly along all of it and is
 * the wedge at both ends, so the remainder is continuous across it and the
 * fixed texels' offset from the curve no longer meets a jump's b / r
 * gradient anywhere along it. W needs no window, but evaluating it costs
 * a texel and a curve each: so it is windowed by the distance to the
 * curve's box (1 up to far / 2, 0 from far texels). The source where a
 * window falls is the finite-volume form of -Laplace (phi W) without
 * phi Laplace W (W Lap phi + sum (phi_n - phi_i)(W_n - W_i)), and the
 * float solve's rounding grows with it (windows of 16 to 48 texels round
 * a line of the ends class moved h by 3e-6 everywhere and its gradient by
 * 3%): W falls like J L / r from a curve of size L, so far is f L (and at
 * least 24 texels), f as large as CH_DCI_LAYER_BUDGET evaluations per
 * texel more than those least windows allow, up to 8: a few long curves
 * are taken out on the whole grid, many short ones each in its own
 * neighbourhood. The border takes
 * phi dW/dn. The wedge terms above are then those of h - W (their ends on
 * such curves drop out); ch_recon mixes the blend of h - W plus W with the
 * plain blend by each layer's window, as for the wedges. */
#define CH_DCI_LAYER_BUDGET 4.0
/* Points nearer than this (texels) to the grid's border or to another * Points nearer than this (texels) to the grid's border or to another
 * point get no term: a border that close is a mirror, and h no wedge at
 * the texels' scale (on the border it has no angle term at all). */
#define CH_DCI_SING_MIN 2.0
/* phi is 1 up to this fraction of the radius */
#define CH_DCI_SING_INNER 0.4

/* The point whose window holds p of the texel frame, or -1. */
int ch_dci_sing_at(const ch_dci *d, const double p[2]);

/* T of point k at p (texel frame), unwindowed. The sector and branch
 * follow a hint where one is given: p lies on `side` (CH_SIDE_LEFT /
 * CH_SIDE_RIGHT) of step curve `curve`, whose closest point to p is cp;
 * with curve < 0 or cp NULL, p's direction from the point decides. */
double ch_dci_sing_value(const ch_dci *d, int k, const double p[2], int curve, int side, const double cp[2]);

/* The window phi of point k at p (texel frame). */
double ch_dci_sing_window(const ch_dci *d, int k, const double p[2]);

/* Whether no singular point's window and no layer's window reaches the
 * box lo..hi of the texel frame: there h is the texels' own blend, with no
 * term added back. Conservative (a box a window only grazes reads 0). */
int ch_dci_box_has_no_terms(const ch_dci *d, const double lo[2], const double hi[2]);

/* The layers whose windows may hold p (texel frame): their count, and
 * *items pointed at their indices. */
int ch_dci_layers_at(const ch_dci *d, const double p[2], const int **items);

/* Layer k's window at p (texel frame). */
double ch_dci_layer_window(const ch_dci *d, int k, const double p[2]);

/* The normal of texel i's nearest curve at its closest point, pointing to
 * `side` of it (texel frame; not unit). */
void ch_dci_side_normal(const ch_dci *d, size_t i, int side, double n[2]);

/* Builds the DCI of the step curves of set. A set without step curves gives
 * h = 0 everywhere. Curves with data-blur are blurred after diffusion by a
 * Gaussian whose radius is itself diffused from the curves (0 on sharp
 * curves) and capped at distance / (3 sqrt 2) to the nearest sharp curve,
 * so the separable footprint never reaches across a sharp curve. */
ch_status ch_dci_build(const ch_curve_set *set, const ch_dci_desc *desc, ch_dci *out, ch_error *err);

void ch_dci_free(ch_dci *dci);

/* The DCI as image layers for EXR: h, R G B (with colours), opp.h and
 * opp.R opp.G opp.B (the values on the other side), distance.X (texels),
 * sp.u sp.v (closest curve point, UV), chain.X, t (parameter along the
 * chain), curve.X, side.X (CH_SIDE_* bits), exact.X, fixed.X, blur.X
 * (with blur). ch_dci_from_image also takes the names without ".X". */
ch_status ch_dci_to_image(const ch_dci *dci, ch_image *out, ch_error *err);

/* Rebuilds a DCI from those layers (what `chisel magnify` reads); rect is
 * the UV rectangle the image covers. Missing layers give CH_ERR_INPUT
 * naming them; name is used in messages. */
ch_status ch_dci_from_image(const ch_image *img, const double rect[4], const char *name, ch_dci *out,
                            ch_error *err);

#ifdef __cplusplus
}
#endif
#endif
