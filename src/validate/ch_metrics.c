/* Per-pixel comparison of two renders (ch_metrics.h). */
#include "ch_metrics.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ch_math.h"
#include "ch_render.h"
#include "ch_truth.h"

static int is_groove(int c) { return c == CH_VIS_GROOVE_WALL || c == CH_VIS_GROOVE_FLOOR; }

static int cmp_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

static double pct(long k, long n) { return n > 0 ? 100.0 * (double)k / (double)n : 0.0; }

ch_status ch_metrics_compare(const ch_image *m, const ch_image *t, double scene_size, ch_metrics *out, ch_error *err) {
  memset(out, 0, sizeof *out);
  if (m->width != t->width || m->height != t->height)
    return ch_error_set(err, CH_ERR_INPUT, "metrics: render sizes differ (%d x %d against %d x %d)", m->width,
                        m->height, t->width, t->height);
  for (int c = 0; c < CH_RENDER_NUM_LAYERS; c++)
    if (ch_image_find(m, ch_render_layer_names[c]) != c || ch_image_find(t, ch_render_layer_names[c]) != c)
      return ch_error_set(err, CH_ERR_INPUT, "metrics: a render lacks the layer '%s'", ch_render_layer_names[c]);
  if (!(scene_size > 0.0)) return ch_error_set(err, CH_ERR_INPUT, "metrics: scene size %g is not positive", scene_size);
  size_t N = (size_t)m->width * m->height;
  double *angles = malloc((N > 0 ? N : 1) * sizeof *angles);
  if (!angles) return ch_error_set(err, CH_ERR_NOMEM, "metrics: out of memory");
#define L(img, c) ch_image_plane(img, c)
  long cls_bad = 0, groove = 0, groove_bad = 0, idp = 0, id_bad = 0, both = 0, shadow_bad = 0;
  double depth_sum = 0.0, angle_sum = 0.0, shade_sq = 0.0;
  for (size_t p = 0; p < N; p++) {
    int cm = (int)L(m, CH_RENDER_CLASS)[p], ct = (int)L(t, CH_RENDER_CLASS)[p];
    cls_bad += cm != ct;
    if (is_groove(cm) || is_groove(ct)) {
      groove++;
      groove_bad += cm != ct;
    }
    if (cm == ct && (is_groove(cm) || cm == CH_VIS_STEP_WALL)) {
      idp++;
      id_bad += L(m, CH_RENDER_ID)[p] != L(t, CH_RENDER_ID)[p];
    }
    double ds = (double)L(m, CH_RENDER_SHADE)[p] - L(t, CH_RENDER_SHADE)[p];
    shade_sq += ds * ds;
    if (!(L(m, CH_RENDER_COVERAGE)[p] > 0.0f && L(t, CH_RENDER_COVERAGE)[p] > 0.0f)) continue;
    depth_sum += fabs((double)L(m, CH_RENDER_DEPTH)[p] - L(t, CH_RENDER_DEPTH)[p]);
    double dot = 0.0;
    for (int k = 0; k < 3; k++) dot += (double)L(m, CH_RENDER_NX + k)[p] * L(t, CH_RENDER_NX + k)[p];
    double a = acos(ch_clamp(dot, -1.0, 1.0)) * 180.0 / CH_PI;
    angles[both++] = a;
    angle_sum += a;
    shadow_bad += fabs((double)L(m, CH_RENDER_SHADOW)[p] - L(t, CH_RENDER_SHADOW)[p]) > 0.5;
  }
#undef L
  out->pixels = (long)N;
  out->groove_pixels = groove;
  out->id_pixels = idp;
  out->both_hit = both;
  out->class_mismatch = pct(cls_bad, (long)N);
  out->class_mismatch_groove = pct(groove_bad, groove);
  out->id_mismatch = pct(id_bad, idp);
  out->shadow_mismatch = pct(shadow_bad, both);
  out->shade_rmse = N > 0 ? sqrt(shade_sq / (double)N) : 0.0;
  if (both > 0) {
    out->depth_error = depth_sum / both / scene_size;
    out->normal_mean_deg = angle_sum / both;
    qsort(angles, (size_t)both, sizeof *angles, cmp_double);
    long k = (long)ceil(0.95 * both) - 1;
    out->normal_p95_deg = angles[k < 0 ? 0 : k];
  }
  free(angles);
  return CH_OK;
}
