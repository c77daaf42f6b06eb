#include "ch_height.h"

#include <stdlib.h>
#include <string.h>

ch_status ch_height_init(ch_height *h, const ch_curve_set *set, const ch_height_desc *desc, ch_error *err) {
  memset(h, 0, sizeof *h);
  h->set = set;
  h->step_method = desc->step_method;
  for (int c = 0; c < set->num_curves; c++) h->has_steps |= set->curves[c].kind == CH_CURVE_STEP;
  ch_status st = ch_groove_field_init(&h->grooves, set, err);
  if (st) return st;
  if (h->has_steps) {
    ch_dci_desc dd = {.resolution = desc->dci_resolution, .tolerance = desc->tolerance, .no_colors = 1, .no_singular = desc->no_singular,
                       .no_extrapolate = desc->no_extrapolate};
    const ch_curve_set *steps = set;
    float *scale = NULL;
    if (desc->warp) {
      h->warp = desc->warp;
      /* The paper's DCI in warped UV is diffused as the paper does, without
       * the singular terms: there the cut reads h_step by side
       * (ch_height_step_side: in warped UV a point a hair off a curve may
       * be on neither), and ch_recon_eval_side adds the double layers W
       * back by the point's own side, not the side asked for (the
       * crossings torture class seen close: +-0.28 for steps of 0 to
       * 0.01, a mesh with h down to -0.52). The DCI in UV (the default)
       * keeps them. */
      dd.no_singular = 1;
      st = ch_warp_curves(desc->warp, set, &h->warped, &h->warp_stats, err);
      steps = &h->warped;
      /* per column and row of warped texels: the slope of W there */
      int R = desc->dci_resolution;
      if (!st && !(scale = malloc(2 * (size_t)R * sizeof *scale)))
        st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for the warped blur");
      for (int i = 0; !st && i < R; i++)
        for (int axis = 0; axis < 2; axis++) {
          double y = axis == 0 ? (i + 0.5) / R : 1.0 - (i + 0.5) / R; /* row 0 on top */
          double x = ch_warp_axis_inverse(desc->warp, axis, y);
          scale[axis * R + i] = (float)ch_warp_axis_slope(desc->warp, axis, x);
        }
      dd.blur_scale[0] = scale;
      dd.blur_scale[1] = scale ? scale + R : NULL;
    }
    if (!st) st = ch_dci_build(steps, &dd, &h->dci, err);
    if (!st) st = ch_recon_init(&h->recon, &h->dci, steps, err);
    free(scale);
  }
  if (st) ch_height_free(h);
  return st;
}

void ch_height_free(ch_height *h) {
  ch_recon_free(&h->recon);
  ch_dci_free(&h->dci);
  ch_curves_free(&h->warped);
  ch_groove_field_free(&h->grooves);
  memset(h, 0, sizeof *h);
}

/* Where the DCI is read for UV (u, v): through the warp when there is one. */
static void dci_point(const ch_height *h, double u, double v, double out[2]) {
  out[0] = u;
  out[1] = v;
  if (h->warp) {
    double uv[2] = {u, v};
    ch_warp_map(h->warp, uv, out);
  }
}

void ch_height_step(const ch_height *h, double u, double v, ch_recon_sample *out) {
  double q[2];
  dci_point(h, u, v, q);
  ch_recon_eval(&h->recon, h->step_method, q[0], q[1], 0.0, out);
}

void ch_height_step_side(const ch_height *h, double u, double v, int curve, int side, ch_recon_sample *out) {
  double q[2];
  dci_point(h, u, v, q);
  ch_recon_eval_side(&h->recon, h->step_method, q[0], q[1], curve, side, out);
}

double ch_height_eval(const ch_height *h, double u, double v) {
  double value = ch_groove_field_eval(&h->grooves, u, v, NULL);
  if (h->has_steps) {
    ch_recon_sample rs;
    ch_height_step(h, u, v, &rs);
    value += rs.value;
  }
  return value;
}

void ch_height_render(const ch_height *h, int R, int S, float *plane) {
  ch_height_render_warped(h, NULL, R, S, plane);
}

void ch_height_render_warped(const ch_height *h, const ch_warp *warp, int R, int S, float *plane) {
  double inv = 1.0 / R, sub = 1.0 / S, norm = 1.0 / ((double)S * S);
  /* Most pixels of a drawing lie away from its curves: there no groove
   * reaches and h_step is the DCI's texels blended, with nothing to decide
   * by side. Such pixels skip those searches per sample (the same bits:
   * ch_groove_field_box_is_empty, ch_recon_box_is_plain). Through a warp
   * the samples are not in the pixel's UV box: every one searches. */
  int boxes = !warp && !h->warp;
#pragma omp parallel for schedule(dynamic, 4)
  for (int y = 0; y < R; y++) {
    for (int x = 0; x < R; x++) {
      double u0 = (x + 0.5 * sub) * inv, u1 = (x + (S - 0.5) * sub) * inv;
      double v1 = 1.0 - (y + 0.5 * sub) * inv, v0 = 1.0 - (y + (S - 0.5) * sub) * inv;
      int no_groove = boxes && ch_groove_field_box_is_empty(&h->grooves, u0, v0, u1, v1);
      int plain_step = boxes && h->has_steps && ch_recon_box_is_plain(&h->recon, h->step_method, u0, v0, u1, v1);
      double sum = 0.0;
      for (int j = 0; j < S; j++) {
        /* Row 0 is the top: v runs down from 1. */
        double v = 1.0 - (y + (j + 0.5) * sub) * inv;
        for (int i = 0; i < S; i++) {
          double q[2] = {(x + (i + 0.5) * sub) * inv, v}, uv[2] = {q[0], q[1]};
          if (warp) ch_warp_unmap(warp, q, uv);
          if (!no_groove && !plain_step) {
            sum += ch_height_eval(h, uv[0], uv[1]);
            continue;
          }
          /* ch_height_eval's sum, in its order */
          double value = no_groove ? 0.0 : ch_groove_field_eval(&h->grooves, uv[0], uv[1], NULL);
          if (plain_step) {
            value += ch_recon_eval_plain(&h->recon, uv[0], uv[1]);
          } else if (h->has_steps) {
            ch_recon_sample rs;
            ch_height_step(h, uv[0], uv[1], &rs);
            value += rs.value;
          }
          sum += value;
        }
      }
      plane[(size_t)y * R + x] = (float)(sum * norm);
    }
  }
}
