/* A bounding-box hierarchy over curve segments (see ch_segtree.h): a
 * linear BVH in the manner of Lauterbach et al. 2009 (primitives sorted
 * along a Morton curve, the tree implicit in that order), sorting whole
 * curves rather than segments so that a curve stays one range of leaves. */
#include "ch_segtree.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "ch_bezier.h"
#include "ch_math.h"

void ch_segtree_free(ch_segtree *tree) {
  free(tree->box);
  free(tree->segment);
  free(tree->curve_first);
  memset(tree, 0, sizeof *tree);
}

/* Spreads the low 16 bits of x to the even bits. */
static uint32_t spread16(uint32_t x) {
  x &= 0xffff;
  x = (x | (x << 8)) & 0x00ff00ff;
  x = (x | (x << 4)) & 0x0f0f0f0f;
  x = (x | (x << 2)) & 0x33333333;
  x = (x | (x << 1)) & 0x55555555;
  return x;
}

typedef struct curve_key {
  uint64_t key; /* step curves first, then along the Morton curve */
  int curve;
} curve_key;

static int cmp_key(const void *a, const void *b) {
  const curve_key *x = a, *y = b;
  if (x->key != y->key) return x->key < y->key ? -1 : 1;
  return (x->curve > y->curve) - (x->curve < y->curve);
}


static void segment_box(const ch_segment *s, double b[4]) {
  b[0] = ch_min3(s->p[0][0], s->p[1][0], s->p[2][0]);
  b[1] = ch_min3(s->p[0][1], s->p[1][1], s->p[2][1]);
  b[2] = ch_max3(s->p[0][0], s->p[1][0], s->p[2][0]);
  b[3] = ch_max3(s->p[0][1], s->p[1][1], s->p[2][1]);
}

ch_status ch_segtree_build(ch_segtree *t, const ch_curve_set *set, ch_error *err) {
  memset(t, 0, sizeof *t);
  int nc = set->num_curves, n = set->num_segments;
  t->num_leaves = n;
  curve_key *keys = malloc((size_t)(nc > 0 ? nc : 1) * sizeof *keys);
  t->segment = malloc((size_t)(n > 0 ? n : 1) * sizeof *t->segment);
  t->curve_first = malloc((size_t)(nc > 0 ? nc : 1) * sizeof *t->curve_first);
  /* level sizes: ceil(n / LEAF), then halving to 1 */
  size_t total = 0;
  int count = (n + CH_SEGTREE_LEAF - 1) / CH_SEGTREE_LEAF;
  while (count > 0 && t->num_levels < CH_SEGTREE_MAX_LEVELS) {
    t->level_start[t->num_levels++] = (int)total;
    total += (size_t)count;
    if (count == 1) break;
    count = (count + 1) / 2;
  }
  t->level_start[t->num_levels] = (int)total;
  t->box = malloc((total > 0 ? total : 1) * sizeof *t->box);
  if (!keys || !t->segment || !t->curve_first || !t->box) {
    free(keys);
    ch_segtree_free(t);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the curves' tree (%d segments)", n);
  }
  double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
  for (int c = 0; c < nc; c++)
    for (int k = 0; k < 2; k++) {
      double m = 0.5 * (set->curves[c].bbox[k] + set->curves[c].bbox[k + 2]);
      lo[k] = fmin(lo[k], m);
      hi[k] = fmax(hi[k], m);
    }
  for (int c = 0; c < nc; c++) {
    uint32_t q[2];
    for (int k = 0; k < 2; k++) {
      double m = 0.5 * (set->curves[c].bbox[k] + set->curves[c].bbox[k + 2]);
      double f = hi[k] > lo[k] ? (m - lo[k]) / (hi[k] - lo[k]) : 0.0;
      q[k] = (uint32_t)fmin(65535.0, fmax(0.0, f * 65535.0));
    }
    keys[c].key = (uint64_t)(set->curves[c].kind != CH_CURVE_STEP) << 32 | (spread16(q[0]) | spread16(q[1]) << 1);
    keys[c].curve = c;
  }
  qsort(keys, (size_t)nc, sizeof *keys, cmp_key);
  int leaf = 0;
  for (int i = 0; i < nc; i++) {
    const ch_curve *cv = &set->curves[keys[i].curve];
    t->curve_first[keys[i].curve] = leaf;
    for (int s = 0; s < cv->num_segments; s++) t->segment[leaf++] = cv->first_segment + s;
    if (cv->kind == CH_CURVE_STEP) t->num_step_leaves = leaf;
  }
  free(keys);
  /* Level 0 from the segments, each level above from the one below. */
  for (int i = 0; t->num_levels > 0 && i < t->level_start[1]; i++) {
    double *b = t->box[i];
    b[0] = b[1] = INFINITY;
    b[2] = b[3] = -INFINITY;
    for (int l = i * CH_SEGTREE_LEAF; l < (i + 1) * CH_SEGTREE_LEAF && l < n; l++) {
      double s[4];
      segment_box(&set->segments[t->segment[l]], s);
      b[0] = fmin(b[0], s[0]);
      b[1] = fmin(b[1], s[1]);
      b[2] = fmax(b[2], s[2]);
      b[3] = fmax(b[3], s[3]);
    }
  }
  for (int L = 1; L < t->num_levels; L++) {
    int below = t->level_start[L - 1], nbelow = t->level_start[L] - below;
    for (int i = 0; i < t->level_start[L + 1] - t->level_start[L]; i++) {
      double *b = t->box[t->level_start[L] + i];
      memcpy(b, t->box[below + 2 * i], sizeof t->box[0]);
      if (2 * i + 1 < nbelow) {
        const double *o = t->box[below + 2 * i + 1];
        b[0] = fmin(b[0], o[0]);
        b[1] = fmin(b[1], o[1]);
        b[2] = fmax(b[2], o[2]);
        b[3] = fmax(b[3], o[3]);
      }
    }
  }
  return CH_OK;
}

static double box_d2(const double b[4], const double q[2]) {
  double dx = q[0] < b[0] ? b[0] - q[0] : q[0] > b[2] ? q[0] - b[2] : 0.0;
  double dy = q[1] < b[1] ? b[1] - q[1] : q[1] > b[3] ? q[1] - b[3] : 0.0;
  return dx * dx + dy * dy;
}

int ch_segtree_closest(const ch_segtree *t, const ch_curve_set *set, int first, int last, const double q[2],
                       double max_d2, double *d2, double *tp) {
  if (first < 0) first = 0;
  if (last > t->num_leaves) last = t->num_leaves;
  if (first >= last || t->num_levels == 0) return -1;
  double best = max_d2, best_t = 0.0;
  int best_seg = -1;
  /* A box's distance is a bound on its curves' up to rounding of their
   * points: a relative 1e-9 of slack keeps every candidate that could tie. */
  const double slack = 1.0 + 1e-9;
  int stack[2 * CH_SEGTREE_MAX_LEVELS + 2][2], top = 0;
  stack[top][0] = t->num_levels - 1;
  stack[top++][1] = 0;
  while (top > 0) {
    top--;
    int L = stack[top][0], i = stack[top][1];
    long span = (long)CH_SEGTREE_LEAF << L, lo = (long)i * span, hi = lo + span;
    if (hi <= first || lo >= last) continue;
    if (box_d2(t->box[t->level_start[L] + i], q) > best * slack) continue;
    if (L == 0) {
      int a = (int)(lo > first ? lo : first), b = (int)(hi < last ? hi : last);
      for (int l = a; l < b; l++) {
        int s = t->segment[l];
        const ch_segment *sg = &set->segments[s];
        double sb[4];
        segment_box(sg, sb);
        if (box_d2(sb, q) > best * slack) continue;
        double ts, d = ch_bezier_closest(sg->p, sg->is_line, q, &ts);
        if (d < best || (d == best && best_seg >= 0 && s < best_seg)) {
          best = d;
          best_t = ts;
          best_seg = s;
        }
      }
      continue;
    }
    /* the children, the nearer on top */
    int c0 = 2 * i, c1 = 2 * i + 1, nb = t->level_start[L] - t->level_start[L - 1];
    if (c1 >= nb) {
      stack[top][0] = L - 1;
      stack[top++][1] = c0;
      continue;
    }
    double d0 = box_d2(t->box[t->level_start[L - 1] + c0], q), d1 = box_d2(t->box[t->level_start[L - 1] + c1], q);
    int near = d0 <= d1 ? c0 : c1, far = near == c0 ? c1 : c0;
    stack[top][0] = L - 1;
    stack[top++][1] = far;
    stack[top][0] = L - 1;
    stack[top++][1] = near;
  }
  if (best_seg >= 0) {
    *d2 = best;
    *tp = best_t;
  }
  return best_seg;
}
