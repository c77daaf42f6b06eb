/* Geometry images: the base surface sampled on a grid in UV. Every face's
 * UV map is bilinear on each of its quad patches (docs/spec.md §1), so a texel
 * centre is located by inverting a bilinear map in closed form and then
 * evaluated exactly on the surface. */
#include "ch_geomimage.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ch_alloc.h"
#include "ch_image.h"
#include "ch_math.h"
#include "ch_warp.h"

/* A bilinear patch of a face: (s, t) = origin + scale * (a, b) for local
 * (a, b) in [0,1]^2, with the UVs of its four corners (a, b) = (0,0),
 * (1,0), (1,1), (0,1). */
typedef struct patch {
  int face;
  double origin[2], scale;
  double uv[4][2];
  double box[4];
} patch;

/* Local (a, b) of q in the bilinear quad p (closed form: the quadratic in b
 * of Quilez's inverse bilinear map, then two Newton steps). Returns 0 when
 * q lies inside (within eps). */
static int inverse_bilinear(const double p[4][2], const double q[2], double eps, double ab[2]) {
  double e[2] = {p[1][0] - p[0][0], p[1][1] - p[0][1]};
  double f[2] = {p[3][0] - p[0][0], p[3][1] - p[0][1]};
  double g[2] = {p[0][0] - p[1][0] + p[2][0] - p[3][0], p[0][1] - p[1][1] + p[2][1] - p[3][1]};
  double h[2] = {q[0] - p[0][0], q[1] - p[0][1]};
  double k2 = ch_cross2(g, f), k1 = ch_cross2(e, f) + ch_cross2(h, g), k0 = ch_cross2(h, e);
  double cand[2];
  int nc = 0;
  double scale = fabs(k1) + fabs(k2) + fabs(k0);
  if (scale == 0.0) return -1;
  if (fabs(k2) <= 1e-12 * scale) {
    if (k1 == 0.0) return -1;
    cand[nc++] = -k0 / k1;
  } else {
    double disc = k1 * k1 - 4.0 * k0 * k2;
    if (disc < 0.0) {
      if (disc < -1e-12 * k1 * k1) return -1;
      disc = 0.0;
    }
    double sq = sqrt(disc), qq = -0.5 * (k1 + (k1 >= 0.0 ? sq : -sq));
    cand[nc++] = qq / k2;
    if (qq != 0.0) cand[nc++] = k0 / qq;
  }
  for (int i = 0; i < nc; i++) {
    double b = cand[i];
    double dx = e[0] + g[0] * b, dy = e[1] + g[1] * b;
    double a = fabs(dx) >= fabs(dy) ? (h[0] - f[0] * b) / dx : (h[1] - f[1] * b) / dy;
    if (!isfinite(a) || !isfinite(b)) continue;
    /* Newton on q = p0 + a e + b f + a b g. */
    for (int it = 0; it < 2; it++) {
      double r[2] = {p[0][0] + a * e[0] + b * f[0] + a * b * g[0] - q[0],
                     p[0][1] + a * e[1] + b * f[1] + a * b * g[1] - q[1]};
      double ja[2] = {e[0] + b * g[0], e[1] + b * g[1]}, jb[2] = {f[0] + a * g[0], f[1] + a * g[1]};
      double det = ch_cross2(ja, jb);
      if (det == 0.0) break;
      a -= ch_cross2(r, jb) / det;
      b -= ch_cross2(ja, r) / det;
    }
    if (a >= -eps && a <= 1.0 + eps && b >= -eps && b <= 1.0 + eps) {
      ab[0] = ch_clamp(a, 0.0, 1.0);
      ab[1] = ch_clamp(b, 0.0, 1.0);
      return 0;
    }
  }
  return -1;
}

/* The patches of one face: the quad itself, or one per corner; their UV
 * boxes where asked (the rasteriser's: locating a point, called for every
 * new vertex of the embedding, needs none, and the boxes' fmin and fmax
 * were library calls, a third of its instructions). */
static int face_patches(const ch_surface *s, int face, patch *out, int with_box) {
  int n = ch_surface_face_size(s, face), np;
  const double *uvs = ch_surface_patch_uvs(s, face, &np);
  if (!uvs || np != (n == 4 ? 1 : n)) return -1;
  for (int k = 0; k < np; k++) {
    patch *p = &out[k];
    p->face = face;
    if (n == 4) {
      p->origin[0] = p->origin[1] = 0.0;
      p->scale = 1.0;
    } else {
      ch_surface_corner_param(s, face, k, p->origin);
      p->scale = 0.5;
    }
    memcpy(p->uv, &uvs[8 * (size_t)k], sizeof p->uv);
    if (!with_box) continue;
    p->box[0] = p->box[1] = INFINITY;
    p->box[2] = p->box[3] = -INFINITY;
    for (int c = 0; c < 4; c++) {
      p->box[0] = fmin(p->box[0], p->uv[c][0]);
      p->box[1] = fmin(p->box[1], p->uv[c][1]);
      p->box[2] = fmax(p->box[2], p->uv[c][0]);
      p->box[3] = fmax(p->box[3], p->uv[c][1]);
    }
  }
  return np;
}

ch_status ch_surface_locate(const ch_surface *s, int face, const double uv[2], double st[2]) {
  int n = ch_surface_face_size(s, face);
  if (n < 3) return CH_ERR_INPUT;
  patch local[8], *ps = n <= 8 ? local : malloc((size_t)n * sizeof *ps); /* called per new vertex: no malloc for the usual faces */
  if (!ps) return CH_ERR_NOMEM;
  int np = face_patches(s, face, ps, 0);
  ch_status st_code = CH_ERR_INPUT;
  for (int k = 0; k < np; k++) {
    double ab[2];
    if (inverse_bilinear(ps[k].uv, uv, 1e-9, ab) == 0) {
      st[0] = ps[k].origin[0] + ps[k].scale * ab[0];
      st[1] = ps[k].origin[1] + ps[k].scale * ab[1];
      st_code = CH_OK;
      break;
    }
  }
  if (ps != local) free(ps);
  return st_code;
}

void ch_geomimage_free(ch_geomimage *gi) {
  free(gi->face);
  free(gi->st);
  free(gi->uv);
  free(gi->position);
  free(gi->normal);
  memset(gi, 0, sizeof *gi);
}

ch_status ch_geomimage_build(const ch_surface *s, int W, int H, const double rect_in[4], ch_geomimage *gi,
                             ch_error *err) {
  return ch_geomimage_build_warped(s, W, H, rect_in, NULL, gi, err);
}

/* Where the rasteriser puts each texel's values: channel k of texel i at
 * value[k][i * stride[k]] (channels in ch_geomimage_channel_names' order,
 * then u and v; NULL: not kept), and its face, -1 where none, in face (an
 * int array) or as the float of value[6]. */
enum {
  P_CHANNEL = 0, /* P.x P.y P.z */
  N_CHANNEL = 3, /* N.x N.y N.z */
  FACE_CHANNEL = 6,
  S_CHANNEL = 7,
  T_CHANNEL = 8,
  U_CHANNEL = CH_GEOMIMAGE_CHANNELS,
  V_CHANNEL,
  SINK_CHANNELS
};
typedef struct sink {
  float *value[SINK_CHANNELS];
  size_t stride[SINK_CHANNELS];
  int *face;
} sink;

static void sink_put(const sink *k, int c, size_t i, double x) {
  if (k->value[c]) k->value[c][i * k->stride[c]] = (float)x;
}

/* The geometry image's texels into out (see ch_geomimage_build_warped);
 * *covered: the texels with a face. */
static ch_status rasterise(const ch_surface *s, int W, int H, const double rect[4], const ch_warp *warp,
                           const sink *out, long *covered_out, ch_error *err) {
  int nf = ch_surface_num_faces(s), total = 0;
  for (int f = 0; f < nf; f++) {
    int n = ch_surface_face_size(s, f);
    total += n == 4 ? 1 : n;
  }
  patch *ps = malloc((size_t)(total > 0 ? total : 1) * sizeof *ps);
  int *first = malloc((size_t)(nf + 1) * sizeof *first);
  if (!ps || !first) {
    free(ps);
    free(first);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for a %dx%d geometry image", W, H);
  }
  first[0] = 0;
  for (int f = 0; f < nf; f++) first[f + 1] = first[f] + (ch_surface_face_size(s, f) == 4 ? 1 : ch_surface_face_size(s, f));
  int failed = 0;
#pragma omp parallel for schedule(dynamic, 64) reduction(| : failed)
  for (int f = 0; f < nf; f++)
    if (face_patches(s, f, ps + first[f], 1) < 0) failed = 1;
  free(first);
  if (failed) {
    free(ps);
    return ch_error_set(err, CH_ERR_INTERNAL, "geometry image: a face could not be evaluated");
  }
  if (warp) /* texels of warped UV: a patch's texels lie in the warped box
                of its UV box (C is W at the cage's corners, W is monotone) */
    for (int k = 0; k < total; k++) {
      double *b = ps[k].box;
      for (int c = 0; c < 4; c++) b[c] = ch_warp_axis(warp, c & 1, b[c]);
    }
  double tu = (rect[2] - rect[0]) / W, tv = (rect[3] - rect[1]) / H;
  /* Patches by texel row, in face order, so the first hit per texel is the
   * lowest-numbered face whatever the threads do. */
  int *row_count = calloc((size_t)H + 1, sizeof *row_count);
  if (!row_count) {
    free(ps);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for a geometry image");
  }
#define ROW_RANGE(p, y0, y1)                                                                     \
  int y0 = (int)ceil((rect[3] - (p)->box[3]) / tv - 0.5), y1 = (int)floor((rect[3] - (p)->box[1]) / tv - 0.5); \
  if (y0 < 0) y0 = 0;                                                                            \
  if (y1 > H - 1) y1 = H - 1;
  size_t entries = 0;
  for (int k = 0; k < total; k++) {
    ROW_RANGE(&ps[k], y0, y1)
    for (int y = y0; y <= y1; y++) row_count[y + 1]++;
    entries += y1 >= y0 ? (size_t)(y1 - y0 + 1) : 0;
  }
  for (int y = 0; y < H; y++) row_count[y + 1] += row_count[y];
  int *row_items = malloc((entries > 0 ? entries : 1) * sizeof *row_items);
  int *fill = malloc((size_t)H * sizeof *fill);
  if (!row_items || !fill) {
    free(row_items);
    free(fill);
    free(row_count);
    free(ps);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for a geometry image");
  }
  memcpy(fill, row_count, (size_t)H * sizeof *fill);
  for (int k = 0; k < total; k++) {
    ROW_RANGE(&ps[k], y0, y1)
    for (int y = y0; y <= y1; y++) row_items[fill[y]++] = k;
  }
#undef ROW_RANGE
  free(fill);
  long covered = 0;
  int out_of_memory = 0;
#pragma omp parallel for schedule(dynamic, 4) reduction(+ : covered) reduction(| : out_of_memory)
  for (int y = 0; y < H; y++) {
    double v = rect[3] - (y + 0.5) * tv;
    size_t row = (size_t)y * W;
    /* The row's faces, and the UV of its texel centres taken back through
     * the warp once (patches overlap in their boxes: a texel is tried by
     * several). */
    int *row_face = out->face ? out->face + row : malloc((size_t)W * sizeof *row_face);
    double *row_uv = warp ? malloc(2 * (size_t)W * sizeof *row_uv) : NULL;
    if (!row_face || (warp && !row_uv)) {
      if (!out->face) free(row_face);
      free(row_uv);
      out_of_memory = 1;
      continue;
    }
    for (int x = 0; x < W; x++) row_face[x] = -1;
    for (int x = 0; x < W; x++) {
      double q[2] = {rect[0] + (x + 0.5) * tu, v};
      if (warp) {
        ch_warp_unmap(warp, q, &row_uv[2 * x]);
        q[0] = row_uv[2 * x];
        q[1] = row_uv[2 * x + 1];
      }
      sink_put(out, U_CHANNEL, row + x, q[0]);
      sink_put(out, V_CHANNEL, row + x, q[1]);
    }
    for (int it = row_count[y]; it < row_count[y + 1]; it++) {
      const patch *p = &ps[row_items[it]];
      int x0 = (int)ceil((p->box[0] - rect[0]) / tu - 0.5), x1 = (int)floor((p->box[2] - rect[0]) / tu - 0.5);
      if (x0 < 0) x0 = 0;
      if (x1 > W - 1) x1 = W - 1;
      for (int x = x0; x <= x1; x++) {
        if (row_face[x] >= 0) continue;
        double q[2] = {rect[0] + (x + 0.5) * tu, v}, ab[2];
        if (warp) q[0] = row_uv[2 * x], q[1] = row_uv[2 * x + 1];
        if (inverse_bilinear(p->uv, q, 1e-9, ab)) continue;
        double st2[2] = {p->origin[0] + p->scale * ab[0], p->origin[1] + p->scale * ab[1]};
        ch_surface_point sp;
        if (ch_surface_eval(s, p->face, st2[0], st2[1], &sp) != CH_OK) continue;
        size_t i = row + x;
        row_face[x] = p->face;
        for (int k = 0; k < 3; k++) {
          sink_put(out, P_CHANNEL + k, i, sp.position[k]);
          sink_put(out, N_CHANNEL + k, i, sp.normal[k]);
        }
        sink_put(out, S_CHANNEL, i, st2[0]);
        sink_put(out, T_CHANNEL, i, st2[1]);
        covered++;
      }
    }
    for (int x = 0; x < W; x++) {
      size_t i = row + x;
      sink_put(out, FACE_CHANNEL, i, row_face[x]);
      if (row_face[x] < 0)
        for (int c = 0; c < CH_GEOMIMAGE_CHANNELS; c++)
          if (c != FACE_CHANNEL) sink_put(out, c, i, 0.0);
    }
    if (!out->face) free(row_face);
    free(row_uv);
  }
  free(row_items);
  free(row_count);
  free(ps);
  if (out_of_memory) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for a geometry image's rows");
  *covered_out = covered;
  return CH_OK;
}

/* Checks a geometry image's size and rectangle (NULL: the unit square),
 * which it copies to rect. */
static ch_status check_size(int W, int H, const double rect_in[4], const ch_warp *warp, double rect[4], ch_error *err) {
  rect[0] = rect[1] = 0.0;
  rect[2] = rect[3] = 1.0;
  if (rect_in) memcpy(rect, rect_in, 4 * sizeof *rect);
  if (warp && (rect[0] != 0.0 || rect[1] != 0.0 || rect[2] != 1.0 || rect[3] != 1.0))
    return ch_error_set(err, CH_ERR_INPUT, "a warped geometry image covers the unit square, not %g,%g,%g,%g", rect[0],
                        rect[1], rect[2], rect[3]);
  if (W < 1 || H < 1 || W > CH_IMAGE_MAX_SIDE || H > CH_IMAGE_MAX_SIDE || !(rect[2] > rect[0]) || !(rect[3] > rect[1]))
    return ch_error_set(err, CH_ERR_INPUT, "geometry image %dx%d over %g,%g,%g,%g is empty or too large", W, H, rect[0],
                        rect[1], rect[2], rect[3]);
  return CH_OK;
}

ch_status ch_geomimage_build_warped(const ch_surface *s, int W, int H, const double rect_in[4], const ch_warp *warp,
                                    ch_geomimage *gi, ch_error *err) {
  memset(gi, 0, sizeof *gi);
  double rect[4];
  ch_status st = check_size(W, H, rect_in, warp, rect, err);
  if (st) return st;
  size_t n = (size_t)W * H;
  /* (not zeroed here: each row's uncovered texels are, by the thread that
   * fills the row, so the pages are first touched in parallel and once) */
  gi->face = ch_alloc_large(n, sizeof *gi->face, 0);
  gi->st = ch_alloc_large(2 * n, sizeof *gi->st, 0);
  gi->uv = ch_alloc_large(2 * n, sizeof *gi->uv, 0);
  gi->position = ch_alloc_large(3 * n, sizeof *gi->position, 0);
  gi->normal = ch_alloc_large(3 * n, sizeof *gi->normal, 0);
  if (!gi->face || !gi->st || !gi->uv || !gi->position || !gi->normal) {
    ch_geomimage_free(gi);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for a %dx%d geometry image", W, H);
  }
  gi->width = W;
  gi->height = H;
  memcpy(gi->rect, rect, sizeof rect);
  sink out = {.value = {gi->position, gi->position + 1, gi->position + 2, gi->normal, gi->normal + 1, gi->normal + 2,
                        NULL, gi->st, gi->st + 1, gi->uv, gi->uv + 1},
              .stride = {3, 3, 3, 3, 3, 3, 1, 2, 2, 2, 2},
              .face = gi->face};
  if ((st = rasterise(s, W, H, rect, warp, &out, &gi->covered, err))) ch_geomimage_free(gi);
  return st;
}

ch_status ch_geomimage_build_planes(const ch_surface *s, int W, int H, const ch_warp *warp,
                                    float *const planes[CH_GEOMIMAGE_CHANNELS + 2], long *covered, ch_error *err) {
  double rect[4];
  ch_status st = check_size(W, H, NULL, warp, rect, err);
  if (st) return st;
  sink out = {.face = NULL};
  for (int c = 0; c < SINK_CHANNELS; c++) {
    out.value[c] = planes[c];
    out.stride[c] = 1;
  }
  long n = 0;
  st = rasterise(s, W, H, rect, warp, &out, &n, err);
  if (!st && covered) *covered = n;
  return st;
}

const char *const ch_geomimage_channel_names[CH_GEOMIMAGE_CHANNELS] = {"P.x", "P.y",    "P.z", "N.x", "N.y",
                                                                       "N.z", "face.X", "s",   "t"};
