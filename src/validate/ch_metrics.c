/* Per-pixel comparison of two renders (ch_metrics.h). */
#include "ch_metrics.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ch_math.h"
#include "ch_render.h"
#include "ch_truth.h"

static int is_groove(int c) { return c == CH_VIS_GROOVE_WALL || c == CH_VIS_GROOVE_FLOOR; }

/* Separable Gaussian blur (sigma 1.5, 11 taps, edges clamped) of a W x H plane. */
static void blur(const double *in, double *tmp, double *out, int W, int H) {
  double w[11], sum = 0.0;
  for (int k = 0; k < 11; k++) sum += w[k] = exp(-0.5 * (k - 5) * (k - 5) / (1.5 * 1.5));
  for (int k = 0; k < 11; k++) w[k] /= sum;
  for (int y = 0; y < H; y++)
    for (int x = 0; x < W; x++) {
      double a = 0.0;
      for (int k = 0; k < 11; k++) {
        int xx = x + k - 5;
        xx = xx < 0 ? 0 : xx >= W ? W - 1 : xx;
        a += w[k] * in[(size_t)y * W + xx];
      }
      tmp[(size_t)y * W + x] = a;
    }
  for (int y = 0; y < H; y++)
    for (int x = 0; x < W; x++) {
      double a = 0.0;
      for (int k = 0; k < 11; k++) {
        int yy = y + k - 5;
        yy = yy < 0 ? 0 : yy >= H ? H - 1 : yy;
        a += w[k] * tmp[(size_t)yy * W + x];
      }
      out[(size_t)y * W + x] = a;
    }
}

/* Mean SSIM of two planes (Wang, Bovik, Sheikh, Simoncelli 2004, eq. 13). */
static int ssim(const float *a, const float *b, int W, int H, double *out) {
  size_t n = (size_t)W * H;
  double *buf = calloc(7 * n, sizeof *buf);
  if (!buf) return 0;
  double *x = buf, *tmp = buf + n, *mx = buf + 2 * n, *my = buf + 3 * n, *sxx = buf + 4 * n, *syy = buf + 5 * n,
         *sxy = buf + 6 * n;
  for (size_t p = 0; p < n; p++) x[p] = a[p];
  blur(x, tmp, mx, W, H);
  for (size_t p = 0; p < n; p++) x[p] = b[p];
  blur(x, tmp, my, W, H);
  for (size_t p = 0; p < n; p++) x[p] = (double)a[p] * a[p];
  blur(x, tmp, sxx, W, H);
  for (size_t p = 0; p < n; p++) x[p] = (double)b[p] * b[p];
  blur(x, tmp, syy, W, H);
  for (size_t p = 0; p < n; p++) x[p] = (double)a[p] * b[p];
  blur(x, tmp, sxy, W, H);
  const double c1 = 0.01 * 0.01, c2 = 0.03 * 0.03;
  double sum = 0.0;
  for (size_t p = 0; p < n; p++) {
    double vx = sxx[p] - mx[p] * mx[p], vy = syy[p] - my[p] * my[p], cxy = sxy[p] - mx[p] * my[p];
    sum += (2 * mx[p] * my[p] + c1) * (2 * cxy + c2) / ((mx[p] * mx[p] + my[p] * my[p] + c1) * (vx + vy + c2));
  }
  free(buf);
  *out = n ? sum / (double)n : 1.0;
  return 1;
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
    /* atan2(|a x b|, a . b): accurate for small angles, where acos of a
     * dot product of float normals is not (1e-2 degrees of noise). */
    double na[3], nb[3], cr[3];
    for (int k = 0; k < 3; k++) na[k] = L(m, CH_RENDER_NX + k)[p], nb[k] = L(t, CH_RENDER_NX + k)[p];
    ch_cross3(na, nb, cr);
    double a = atan2(sqrt(ch_dot3(cr, cr)), ch_dot3(na, nb)) * 180.0 / CH_PI;
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
    qsort(angles, (size_t)both, sizeof *angles, ch_cmp_double);
    long k = (long)ceil(0.95 * both) - 1;
    out->normal_p95_deg = angles[k < 0 ? 0 : k];
  }
  free(angles);
  if (!ssim(ch_image_plane(m, CH_RENDER_SHADE), ch_image_plane(t, CH_RENDER_SHADE), m->width, m->height,
            &out->shade_ssim))
    return ch_error_set(err, CH_ERR_NOMEM, "metrics: out of memory");
  return CH_OK;
}
