#include "ch_height.h"

#include <string.h>

ch_status ch_height_init(ch_height *h, const ch_curve_set *set, const ch_height_desc *desc, ch_error *err) {
  memset(h, 0, sizeof *h);
  h->set = set;
  h->step_method = desc->step_method;
  for (int c = 0; c < set->num_curves; c++) h->has_steps |= set->curves[c].kind == CH_CURVE_STEP;
  ch_status st = ch_groove_field_init(&h->grooves, set, err);
  if (st) return st;
  if (h->has_steps) {
    ch_dci_desc dd = {.resolution = desc->dci_resolution, .tolerance = desc->tolerance, .no_colors = 1};
    st = ch_dci_build(set, &dd, &h->dci, err);
    if (!st) st = ch_recon_init(&h->recon, &h->dci, set, err);
  }
  if (st) ch_height_free(h);
  return st;
}

void ch_height_free(ch_height *h) {
  ch_recon_free(&h->recon);
  ch_dci_free(&h->dci);
  ch_groove_field_free(&h->grooves);
  memset(h, 0, sizeof *h);
}

double ch_height_eval(const ch_height *h, double u, double v) {
  double value = ch_groove_field_eval(&h->grooves, u, v, NULL);
  if (h->has_steps) {
    ch_recon_sample rs;
    ch_recon_eval(&h->recon, h->step_method, u, v, 0.0, &rs);
    value += rs.value;
  }
  return value;
}

void ch_height_render(const ch_height *h, int R, int S, float *plane) {
  double inv = 1.0 / R, sub = 1.0 / S, norm = 1.0 / ((double)S * S);
#pragma omp parallel for schedule(dynamic, 4)
  for (int y = 0; y < R; y++) {
    for (int x = 0; x < R; x++) {
      double sum = 0.0;
      for (int j = 0; j < S; j++) {
        /* Row 0 is the top: v runs down from 1. */
        double v = 1.0 - (y + (j + 0.5) * sub) * inv;
        for (int i = 0; i < S; i++) sum += ch_height_eval(h, (x + (i + 0.5) * sub) * inv, v);
      }
      plane[(size_t)y * R + x] = (float)(sum * norm);
    }
  }
}
