/* chisel-silhouette TRUTH.exr METHOD.exr: for two study renders of one view
 * (V.truth.exr, V.M.exr), the pixels where the truth sees more than the
 * method (a larger coverage: samples whose rays pass the base mesh's
 * outline, such as those under the plane's edge into a groove left open
 * at the square's border, which no per-pixel method on the base sees; a
 * pixel on the border has some of its samples there), and the class and
 * shadow mismatch without them (all pixels, the truth's groove pixels; the
 * shadow over the pixels both hit), as ch_metrics counts them. One line:
 * pixels silhouette_misses class_pct groove_pct shadow_pct. */
#include <math.h>
#include <stdio.h>

#include "ch_exr.h"
#include "ch_render.h"
#include "ch_truth.h"

/* A layer by its render name, or as the study writes one-value layers of
 * longer names (NAME.X: ch_report_exr). */
static const float *plane(const ch_image *img, int layer) {
  char name[CH_IMAGE_NAME_MAX + 3];
  int c = ch_image_find(img, ch_render_layer_names[layer]);
  if (c < 0) {
    snprintf(name, sizeof name, "%s.X", ch_render_layer_names[layer]);
    c = ch_image_find(img, name);
  }
  return c < 0 ? NULL : ch_image_plane(img, c);
}

int main(int argc, char **argv) {
  if (argc != 3) {
    fprintf(stderr, "usage: chisel-silhouette TRUTH.exr METHOD.exr\n");
    return 2;
  }
  ch_image a, b;
  ch_error err = {0};
  if (ch_exr_read(argv[1], &a, &err) || ch_exr_read(argv[2], &b, &err)) {
    fprintf(stderr, "chisel-silhouette: %s\n", err.message);
    return 2;
  }
  const float *ca = plane(&a, CH_RENDER_CLASS), *cb = plane(&b, CH_RENDER_CLASS);
  const float *va = plane(&a, CH_RENDER_COVERAGE), *vb = plane(&b, CH_RENDER_COVERAGE);
  const float *sa = plane(&a, CH_RENDER_SHADOW), *sb = plane(&b, CH_RENDER_SHADOW);
  if (!ca || !cb || !va || !vb || !sa || !sb || a.width != b.width || a.height != b.height) {
    fprintf(stderr, "chisel-silhouette: not two study renders of one view\n");
    return 2;
  }
  long n = (long)a.width * a.height, miss = 0, kept = 0, bad = 0, groove = 0, groove_bad = 0, both = 0, shadow_bad = 0;
  for (long p = 0; p < n; p++) {
    if (va[p] > vb[p]) {
      miss++;
      continue;
    }
    if (va[p] > 0.0f && vb[p] > 0.0f) {
      both++;
      shadow_bad += fabs((double)sa[p] - sb[p]) > 0.5;
    }
    kept++;
    int ta = (int)ca[p], tb = (int)cb[p];
    bad += ta != tb;
    int g = ta == CH_VIS_GROOVE_WALL || ta == CH_VIS_GROOVE_FLOOR;
    groove += g;
    groove_bad += g && ta != tb;
  }
  printf("%ld %ld %.6f %.6f %.6f\n", n, miss, kept ? 100.0 * bad / kept : 0.0,
         groove ? 100.0 * groove_bad / groove : 0.0, both ? 100.0 * shadow_bad / both : 0.0);
  ch_image_free(&a);
  ch_image_free(&b);
  return 0;
}
