/* Feature samples (diffusion-curves-on-surfaces §3.3). The paper gets them
 * from curve rasterisation on the GPU; we have the vector curves, so samples
 * within a band of the curves hold the exact closest point (found through a
 * grid of segment boxes), and the rest inherit the closest point of a
 * neighbour by the two-pass propagation of 8SSEDT (Leymarie and Levine's
 * sequential Euclidean distance transform carrying vectors), so every texel
 * knows its nearest curve at O(W H) cost.
 *
 * The paper's parameter numbering (2, 4, 6, ... per curve, so samples of
 * different curves are never joined) becomes an explicit chain index: one
 * chain per subpath, and a parameter in [0, 1] along it. */
#include "ch_samples.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ch_alloc.h"
#include "ch_bezier.h"
#include "ch_grid.h"
#include "ch_groove.h"
#include "ch_image.h"

void ch_samples_free(ch_samples *s) {
  free(s->offset);
  free(s->distance);
  free(s->curve);
  free(s->segment);
  free(s->seg_t);
  free(s->chain);
  free(s->param);
  free(s->side);
  free(s->exact);
  free(s->value);
  free(s->color);
  memset(s, 0, sizeof *s);
}

/* Chain and parameter of every segment: chains are subpaths; the parameter
 * runs 0..1 along a chain by equal shares per segment. */
typedef struct chain_info {
  int32_t *chain;
  float *param0, *dparam;
} chain_info;

static int chain_info_build(const ch_curve_set *set, chain_info *ci) {
  size_t n = (size_t)(set->num_segments > 0 ? set->num_segments : 1);
  ci->chain = malloc(n * sizeof *ci->chain);
  ci->param0 = malloc(n * sizeof *ci->param0);
  ci->dparam = malloc(n * sizeof *ci->dparam);
  if (!ci->chain || !ci->param0 || !ci->dparam) return -1;
  for (int k = 0; k < set->num_subpaths; k++) {
    const ch_subpath *sp = &set->subpaths[k];
    for (int i = 0; i < sp->num_segments; i++) {
      int s = sp->first_segment + i;
      ci->chain[s] = k;
      ci->param0[s] = (float)((double)i / sp->num_segments);
      ci->dparam[s] = (float)(1.0 / sp->num_segments);
    }
  }
  return 0;
}

static void chain_info_free(chain_info *ci) {
  free(ci->chain);
  free(ci->param0);
  free(ci->dparam);
}

static int alloc_all(ch_samples *s, size_t n) {
/* Not zeroed: the exact pass writes every texel's record. */
#define ALLOC(field, count) (s->field = ch_alloc_large((count), sizeof *s->field, 0)) != NULL
  int ok = ALLOC(offset, 2 * n) && ALLOC(distance, n) && ALLOC(curve, n) && ALLOC(segment, n) &&
           ALLOC(seg_t, n) && ALLOC(chain, n) && ALLOC(param, n) && ALLOC(side, n) &&
           ALLOC(exact, n) && ALLOC(value, 2 * n);
  if (ok && s->num_colors) ok = ALLOC(color, 6 * n);
#undef ALLOC
  return ok ? 0 : -1;
}

/* Propagation state per texel: its seed (the exact texel whose closest
 * point it takes, -1 none), that point in grid coordinates (x right, y
 * down, texels) and the squared distance to it. One 16-byte record keeps a
 * step to one cache line. */
typedef struct seed_rec {
  float x, y, d2;
  int32_t seed;
} seed_rec;

/* One step: record r (texel at x, y) considers neighbour record n. */
static inline void relax(seed_rec *r, const seed_rec *n, float x, float y) {
  if (n->seed < 0) return;
  float ox = n->x - x, oy = n->y - y;
  float d2 = ox * ox + oy * oy;
  if (d2 < r->d2) {
    r->x = n->x;
    r->y = n->y;
    r->d2 = d2;
    r->seed = n->seed;
  }
}

/* The two raster passes of 8SSEDT over the texels that are not exact
 * (exact texels already hold their true closest point). */
static void propagate(seed_rec *p, const uint8_t *exact, int W, int H) {
  for (int y = 0; y < H; y++) {
    seed_rec *row = p + (size_t)y * W, *up = y > 0 ? row - W : NULL;
    const uint8_t *ex = exact + (size_t)y * W;
    float fy = (float)y;
    for (int x = 0; x < W; x++) {
      if (ex[x]) continue;
      float fx = (float)x;
      if (x > 0) relax(&row[x], &row[x - 1], fx, fy);
      if (up) {
        if (x > 0) relax(&row[x], &up[x - 1], fx, fy);
        relax(&row[x], &up[x], fx, fy);
        if (x + 1 < W) relax(&row[x], &up[x + 1], fx, fy);
      }
    }
    for (int x = W - 2; x >= 0; x--)
      if (!ex[x]) relax(&row[x], &row[x + 1], (float)x, fy);
  }
  for (int y = H - 1; y >= 0; y--) {
    seed_rec *row = p + (size_t)y * W, *down = y + 1 < H ? row + W : NULL;
    const uint8_t *ex = exact + (size_t)y * W;
    float fy = (float)y;
    for (int x = W - 1; x >= 0; x--) {
      if (ex[x]) continue;
      float fx = (float)x;
      if (x + 1 < W) relax(&row[x], &row[x + 1], fx, fy);
      if (down) {
        if (x + 1 < W) relax(&row[x], &down[x + 1], fx, fy);
        relax(&row[x], &down[x], fx, fy);
        if (x > 0) relax(&row[x], &down[x - 1], fx, fy);
      }
    }
    for (int x = 1; x < W; x++)
      if (!ex[x]) relax(&row[x], &row[x - 1], (float)x, fy);
  }
}

/* Whether segment seg's subpath is closed (its neighbours wrap round). */
static int closed_chain(const ch_curve_set *set, int seg) {
  const ch_curve *c = &set->curves[set->segments[seg].curve];
  for (int k = c->first_subpath; k < c->first_subpath + c->num_subpaths; k++) {
    const ch_subpath *sp = &set->subpaths[k];
    if (seg >= sp->first_segment && seg < sp->first_segment + sp->num_segments) return sp->closed;
  }
  return 0;
}

static uint8_t side_bits(const ch_curve_set *set, int seg, double t, const double q[2]) {
  const ch_segment *sg = &set->segments[seg];
  int left = ch_curve_side(set, seg, t, q) > 0;
  int end = (t <= 0.0 && sg->prev < 0) || (t >= 1.0 && sg->next < 0);
  int soft = set->curves[sg->curve].blur > 0.0;
  int closed = closed_chain(set, seg);
  return (uint8_t)((left ? CH_SIDE_LEFT : CH_SIDE_RIGHT) | (end ? CH_SIDE_END : 0) |
                   (soft ? CH_SIDE_SOFT : 0) | (closed ? CH_SIDE_CLOSED : 0));
}

ch_status ch_samples_build(const ch_curve_set *set, int W, int H, const double rect[4], double band,
                           ch_samples *s, ch_error *err) {
  return ch_samples_build_subset(set, NULL, W, H, rect, band, 1, s, err);
}

ch_status ch_samples_build_subset(const ch_curve_set *set, const unsigned char *use_curve, int W, int H,
                                  const double rect[4], double band, int colors, ch_samples *s, ch_error *err) {
  memset(s, 0, sizeof *s);
  if (W < 1 || H < 1 || W > CH_IMAGE_MAX_SIDE || H > CH_IMAGE_MAX_SIDE)
    return ch_error_set(err, CH_ERR_INPUT, "sample grid %dx%d outside 1..%d", W, H, CH_IMAGE_MAX_SIDE);
  for (int i = 0; i < 4; i++)
    if (!isfinite(rect[i])) return ch_error_set(err, CH_ERR_INPUT, "sample rectangle is not finite");
  if (!(rect[2] > rect[0] && rect[3] > rect[1]))
    return ch_error_set(err, CH_ERR_INPUT, "empty sample rectangle %g,%g,%g,%g", rect[0], rect[1], rect[2],
                        rect[3]);
  if (!(band >= 1.0 && band <= 64.0))
    return ch_error_set(err, CH_ERR_INPUT, "sample band %g outside 1..64 texels", band);
  s->width = W;
  s->height = H;
  memcpy(s->rect, rect, sizeof s->rect);
  s->texel[0] = (rect[2] - rect[0]) / W;
  s->texel[1] = (rect[3] - rect[1]) / H;
  s->band = band;
  for (int c = 0; c < set->num_curves; c++)
    if (colors && set->curves[c].kind == CH_CURVE_STEP && set->curves[c].has_colors && (!use_curve || use_curve[c]))
      s->num_colors = 3;
  size_t n = (size_t)W * H;
  chain_info ci = {0};
  double (*boxes)[4] = malloc((size_t)(set->num_segments > 0 ? set->num_segments : 1) * sizeof *boxes);
  ch_grid grid = {0};
  if (alloc_all(s, n) || chain_info_build(set, &ci) || !boxes) {
    free(boxes);
    chain_info_free(&ci);
    ch_samples_free(s);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for %dx%d feature samples", W, H);
  }
  /* Exact band: segment boxes grown by the band, in UV. */
  double reach = band * fmax(s->texel[0], s->texel[1]);
  for (int i = 0; i < set->num_segments; i++) {
    const ch_segment *sg = &set->segments[i];
    double *b = boxes[i];
    if (set->curves[sg->curve].kind != CH_CURVE_STEP || (use_curve && !use_curve[sg->curve])) {
      b[0] = b[1] = 1.0;
      b[2] = b[3] = 0.0;
      continue;
    }
    ch_segment_box(sg, reach, b);
  }
  /* (boxes[i] grown by the band; empty for the segments left out) */
  double *grow = malloc((size_t)(set->num_segments > 0 ? set->num_segments : 1) * sizeof *grow);
  ch_status st = grow ? CH_OK : ch_error_set(err, CH_ERR_NOMEM, "out of memory for %dx%d feature samples", W, H);
  for (int i = 0; grow && i < set->num_segments; i++) grow[i] = boxes[i][0] <= boxes[i][2] ? reach : -1.0;
  if (!st) st = ch_grid_build_curves(&grid, set, grow, err);
  free(grow);
  if (st) {
    free(boxes);
    chain_info_free(&ci);
    ch_samples_free(s);
    return st;
  }
  double unit = sqrt(s->texel[0] * s->texel[1]); /* texel size for distances */
#pragma omp parallel for schedule(dynamic, 8)
  for (int y = 0; y < H; y++) {
    for (int x = 0; x < W; x++) {
      size_t i = (size_t)y * W + x;
      double q[2];
      ch_samples_center(s, x, y, q);
      /* Defaults: no curve; the propagation fills these in later. */
      s->curve[i] = -1;
      s->exact[i] = 0;
      s->side[i] = 0;
      s->segment[i] = -1;
      s->seg_t[i] = 0.0f;
      s->chain[i] = -1;
      s->param[i] = 0.0f;
      s->offset[2 * i] = s->offset[2 * i + 1] = 0.0f;
      s->distance[i] = INFINITY;
      const int *items;
      int m = ch_grid_query(&grid, q[0], q[1], &items);
      double best = INFINITY, best_t = 0.0;
      int best_seg = -1;
      for (int k = 0; k < m; k++) {
        const double *b = boxes[items[k]];
        if (q[0] < b[0] || q[0] > b[2] || q[1] < b[1] || q[1] > b[3]) continue;
        const ch_segment *sg = &set->segments[items[k]];
        double t, d2 = ch_bezier_closest(sg->p, sg->is_line, q, &t);
        if (d2 < best) {
          best = d2;
          best_t = t;
          best_seg = items[k];
        }
      }
      if (best_seg < 0 || sqrt(best) > reach) continue;
      double sp[2];
      ch_segment_point(&set->segments[best_seg], best_t, sp);
      s->offset[2 * i] = (float)((sp[0] - q[0]) / s->texel[0]);
      s->offset[2 * i + 1] = (float)((sp[1] - q[1]) / s->texel[1]);
      s->distance[i] = (float)(sqrt(best) / unit);
      s->curve[i] = set->segments[best_seg].curve;
      s->segment[i] = best_seg;
      s->seg_t[i] = (float)best_t;
      s->chain[i] = ci.chain[best_seg];
      s->param[i] = (float)(ci.param0[best_seg] + best_t * ci.dparam[best_seg]);
      s->side[i] = side_bits(set, best_seg, best_t, q);
      s->exact[i] = 1;
    }
  }
  ch_grid_free(&grid);
  free(boxes);
  chain_info_free(&ci);

  /* Every other texel takes the closest point of its nearest exact texel. */
  seed_rec *p = ch_alloc_large(n, sizeof *p, 0);
  if (!p) {
    ch_samples_free(s);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for %dx%d feature samples", W, H);
  }
#pragma omp parallel for schedule(static)
  for (int y = 0; y < H; y++)
    for (int x = 0; x < W; x++) {
      size_t i = (size_t)y * W + x;
      int ex = s->exact[i];
      p[i].seed = ex ? (int32_t)i : -1;
      p[i].d2 = ex ? s->distance[i] * s->distance[i] : INFINITY;
      p[i].x = (float)x + s->offset[2 * i];
      p[i].y = (float)y - s->offset[2 * i + 1];
    }
  propagate(p, s->exact, W, H);

  /* Propagated texels copy their seed's record (its side too: a seed lies
   * between a texel and the curve, on the texel's side); then values. */
#pragma omp parallel for schedule(static)
  for (int y = 0; y < H; y++) {
    for (int x = 0; x < W; x++) {
      size_t i = (size_t)y * W + x;
      int32_t sd = p[i].seed;
      if (!s->exact[i] && sd >= 0) {
        s->offset[2 * i] = p[i].x - (float)x;
        s->offset[2 * i + 1] = (float)y - p[i].y;
        s->distance[i] = sqrtf(p[i].d2);
        s->curve[i] = s->curve[sd];
        s->segment[i] = s->segment[sd];
        s->seg_t[i] = s->seg_t[sd];
        s->chain[i] = s->chain[sd];
        s->param[i] = s->param[sd];
        s->side[i] = s->side[sd];
      }
      if (s->curve[i] < 0) {
        s->value[2 * i] = s->value[2 * i + 1] = 0.0f;
        if (s->color)
          for (int k = 0; k < 6; k++) s->color[6 * i + k] = 0.0f;
        continue;
      }
      const ch_curve *c = &set->curves[s->curve[i]];
      int left = (s->side[i] & CH_SIDE_LEFT) != 0;
      s->value[2 * i] = (float)(left ? c->left : c->right);
      s->value[2 * i + 1] = (float)(left ? c->right : c->left);
      if (s->color) {
        for (int k = 0; k < 3; k++) {
          s->color[6 * i + k] = (float)(left ? c->left_color[k] : c->right_color[k]);
          s->color[6 * i + 3 + k] = (float)(left ? c->right_color[k] : c->left_color[k]);
        }
      }
    }
  }
  free(p);
  return CH_OK;
}
