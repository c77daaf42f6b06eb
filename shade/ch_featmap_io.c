/* Feature maps as an EXR file every tool opens (ch_exr, OpenEXRCore): one
 * (R + 1) x (R + 1) float image, row 0 the top lattice row (v1), with the
 * lattice and cell layers named as in ch_featmap.h, the multi-channel
 * distance field beside them, and the tables (curves' profiles, exact
 * pieces, fallback lists) as text attributes. The reader checks every
 * value it will index or divide by, so a damaged or foreign file is one
 * clear error, never a crash. */
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ch_alloc.h"
#include "ch_exr.h"
#include "ch_featmap.h"
#include "ch_math.h"
#include "ch_msdf.h"

/* Lattice and cell layers, in the order written. */
enum {
  L_D, L_GX, L_GY, L_CURVE, L_SPOS, L_SANG, L_WPOS, L_WANG, L_CONFIG, L_SEG0, L_SEG1, L_REQUIRED,
  L_BX = L_REQUIRED, L_BY, L_BZ, L_NX, L_NY, L_NZ, L_MR, L_MG, L_MB, L_COUNT
};
static const char *const layer_names[L_COUNT] = {
    "d",       "grad.X",  "grad.Y",   "curve",  "sig.S.pos", "sig.S.angle", "sig.W.pos", "sig.W.angle",
    "config",  "seg.curve0", "seg.curve1", "base.X", "base.Y", "base.Z", "N.X", "N.Y", "N.Z",
    "msdf.R", "msdf.G", "msdf.B"};

/* Every bit a configuration word may carry. */
#define CONFIG_BITS 0x7fffffu

/* ---- growing text ---- */

typedef struct text {
  char *s;
  size_t n, cap;
  int failed;
} text;

static void tprintf(text *t, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void tprintf(text *t, const char *fmt, ...) {
  if (t->failed) return;
  for (;;) {
    va_list ap;
    va_start(ap, fmt);
    int k = vsnprintf(t->s ? t->s + t->n : NULL, t->s ? t->cap - t->n : 0, fmt, ap);
    va_end(ap);
    if (k < 0) {
      t->failed = 1;
      return;
    }
    if (t->s && t->n + (size_t)k < t->cap) {
      t->n += (size_t)k;
      return;
    }
    size_t cap = t->cap ? 2 * t->cap : 4096;
    while (cap < t->n + (size_t)k + 1) cap *= 2;
    char *p = realloc(t->s, cap);
    if (!p) {
      t->failed = 1;
      return;
    }
    t->s = p, t->cap = cap;
  }
}

/* ---- writing ---- */

ch_status ch_featmap_write_exr(const char *path, const ch_featmap *m, const struct ch_msdf *msdf,
                               const ch_exr_attribute *extra, int num_extra, ch_error *err) {
  int R = m->resolution, R1 = R + 1;
  if (m->warp)
    return ch_error_set(err, CH_ERR_INPUT, "%s: maps in warped UV are not written (the file holds no warp)", path);
  if (msdf && msdf->resolution != R)
    return ch_error_set(err, CH_ERR_INTERNAL, "distance field resolution %d differs from the maps' %d",
                        msdf->resolution, R);
  const char *names[L_COUNT];
  int idx[L_COUNT], nc = 0;
  for (int l = 0; l < L_COUNT; l++) {
    idx[l] = -1;
    if ((l >= L_BX && l <= L_BZ && !m->has_base) || (l >= L_NX && l <= L_NZ && !m->has_normal) ||
        (l >= L_MR && !msdf))
      continue;
    idx[l] = nc;
    names[nc++] = layer_names[l];
  }
  ch_image img;
  ch_status st = ch_image_init(&img, R1, R1, nc, names, err);
  if (st) return st;
  for (int i = 0; i < R1; i++)
    for (int j = 0; j < R1; j++) {
      size_t k = (size_t)i * R1 + j, px = (size_t)(R - i) * R1 + j;
#define PUT(l, v) ch_image_plane(&img, idx[l])[px] = (float)(v)
      PUT(L_D, m->dist[k]);
      PUT(L_GX, m->grad[2 * k]);
      PUT(L_GY, m->grad[2 * k + 1]);
      PUT(L_CURVE, m->curve[k]);
      PUT(L_SPOS, m->edge[4 * k]);
      PUT(L_SANG, m->edge[4 * k + 1]);
      PUT(L_WPOS, m->edge[4 * k + 2]);
      PUT(L_WANG, m->edge[4 * k + 3]);
      PUT(L_CONFIG, m->config[k]);
      PUT(L_SEG0, m->seg_curve[2 * k]);
      PUT(L_SEG1, m->seg_curve[2 * k + 1]);
      if (idx[L_BX] >= 0)
        for (int c = 0; c < 3; c++) PUT(L_BX + c, m->base[3 * k + c]);
      if (idx[L_NX] >= 0)
        for (int c = 0; c < 3; c++) PUT(L_NX + c, m->normal[3 * k + c]);
      if (idx[L_MR] >= 0)
        for (int c = 0; c < 3; c++) PUT(L_MR + c, msdf->channels[3 * k + c]);
#undef PUT
    }
  /* tables */
  text curves = {0}, pieces = {0}, fallback = {0}, singular = {0};
  tprintf(&curves, "%d\n", m->num_curves);
  for (int c = 0; c < m->num_curves; c++) {
    const ch_featmap_curve *cv = &m->curves[c];
    tprintf(&curves, "%d %.17g %.17g %d %d", (int)cv->kind, cv->width, cv->depth, (int)cv->profile.kind,
            cv->profile.num_points);
    for (int k = 0; k < cv->profile.num_points; k++) tprintf(&curves, " %.17g %.17g", cv->profile.t[k], cv->profile.h[k]);
    tprintf(&curves, "\n");
  }
  tprintf(&pieces, "%d\n", m->num_pieces);
  for (int p = 0; p < m->num_pieces; p++) {
    const ch_featmap_piece *pc = &m->pieces[p];
    tprintf(&pieces, "%d %d %d %d", pc->curve, pc->is_line, pc->start_open, pc->end_open);
    for (int k = 0; k < 3; k++) tprintf(&pieces, " %.17g %.17g", pc->p[k][0], pc->p[k][1]);
    tprintf(&pieces, " %.17g %.17g %.17g %.17g\n", pc->tin[0], pc->tin[1], pc->tout[0], pc->tout[1]);
  }
  long cells = 0;
  for (size_t k = 0; k < (size_t)R1 * R1; k++) cells += (m->config[k] & CH_FM_FALLBACK) && m->has_fallback;
  tprintf(&fallback, "%ld\n", cells);
  for (size_t k = 0; m->has_fallback && k < (size_t)R1 * R1; k++) {
    if (!(m->config[k] & CH_FM_FALLBACK)) continue;
    tprintf(&fallback, "%d", m->fb_count[k]);
    for (int e = 0; e < m->fb_count[k]; e++) tprintf(&fallback, " %d", m->fb_list[m->fb_start[k] + e]);
    tprintf(&fallback, "\n");
  }
  /* the singular points: position, arms (angle, value, slope) */
  tprintf(&singular, "%d\n", m->num_singular);
  for (int p = 0; p < m->num_singular; p++) {
    const ch_stepsing_point *pt = &m->singular[p];
    tprintf(&singular, "%.17g %.17g %d", pt->p[0], pt->p[1], pt->num_arms);
    for (int k = 0; k < pt->num_arms; k++)
      tprintf(&singular, " %.17g %.17g %.17g", pt->angle[k], pt->value[k], pt->slope[k]);
    tprintf(&singular, "\n");
  }
  /* steps' flat sides (ch_stepsing_flat_side): curve, side */
  text flat = {0};
  int num_flat = 0;
  for (int c = 0; c < m->num_curves; c++) num_flat += m->curves[c].flat_side != 0;
  tprintf(&flat, "%d\n", num_flat);
  for (int c = 0; c < m->num_curves; c++)
    if (m->curves[c].flat_side) tprintf(&flat, "%d %d\n", c, m->curves[c].flat_side);
  char rect[160], res[32], range[64];
  snprintf(rect, sizeof rect, "%.17g %.17g %.17g %.17g", m->rect[0], m->rect[1], m->rect[2], m->rect[3]);
  snprintf(res, sizeof res, "%d", R);
  snprintf(range, sizeof range, "%.17g", msdf ? msdf->range : 0.0);
  ch_exr_attribute attrs[24];
  int na = 0;
  attrs[na++] = (ch_exr_attribute){"chisel:command", "featmap"};
  attrs[na++] = (ch_exr_attribute){"chisel:featmap", "1"};
  attrs[na++] = (ch_exr_attribute){"chisel:featmap-mode", m->linear ? "linear" : "quadratic"};
  attrs[na++] = (ch_exr_attribute){"chisel:resolution", res};
  attrs[na++] = (ch_exr_attribute){"chisel:rect", rect};
  attrs[na++] = (ch_exr_attribute){"chisel:featmap-curves", curves.s ? curves.s : ""};
  attrs[na++] = (ch_exr_attribute){"chisel:featmap-pieces", pieces.s ? pieces.s : ""};
  attrs[na++] = (ch_exr_attribute){"chisel:featmap-fallback", fallback.s ? fallback.s : ""};
  if (num_flat > 0) attrs[na++] = (ch_exr_attribute){"chisel:featmap-flat", flat.s ? flat.s : ""};
  char window[32];
  snprintf(window, sizeof window, "%.17g", m->sg_window > 0.0 ? m->sg_window : CH_FEATMAP_SINGULAR_R1);
  if (m->num_singular > 0) attrs[na++] = (ch_exr_attribute){"chisel:featmap-singular", singular.s ? singular.s : ""};
  if (m->num_singular > 0) attrs[na++] = (ch_exr_attribute){"chisel:featmap-singular-window", window};
  if (msdf) attrs[na++] = (ch_exr_attribute){"chisel:msdf-range", range};
  for (int k = 0; k < num_extra && na < 24; k++) attrs[na++] = extra[k];
  if (curves.failed || pieces.failed || fallback.failed || singular.failed || flat.failed) {
    st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for the maps' tables");
  } else {
    ch_exr_write_desc wd = {.attributes = attrs, .num_attributes = na};
    st = ch_exr_write(path, &img, &wd, err);
  }
  free(curves.s);
  free(pieces.s);
  free(fallback.s);
  free(singular.s);
  free(flat.s);
  ch_image_free(&img);
  return st;
}

/* ---- reading ---- */

typedef struct source {
  const char *path;   /* a file, or */
  const void *data;   /* a file in memory */
  size_t size;
  const char *name;   /* for messages */
} source;

static ch_status get_attr(const source *s, const char *attr, char **value, ch_error *err) {
  if (s->data) return ch_exr_read_attribute_memory(s->data, s->size, s->name, attr, value, err);
  return ch_exr_read_attribute_alloc(s->path, attr, value, err);
}

/* An attribute the maps may go without (a table written only where it has
 * rows): *value is NULL when it is absent; present but not a string is
 * an error like any malformed table. */
static ch_status optional_attr(const source *s, const char *attr, char **value, ch_error *err) {
  ch_error probe = {0};
  if (!get_attr(s, attr, value, &probe)) return CH_OK;
  *value = NULL;
  /* ch_exr tells an absent attribute from one of another type only by its message */
  if (strstr(probe.message, "not a string")) return ch_error_set(err, CH_ERR_INPUT, "%s", probe.message);
  return CH_OK;
}

/* A cursor over a table's text: numbers separated by white space. */
typedef struct cursor {
  const char *p;
} cursor;

static int next_double(cursor *c, double *out) {
  while (*c->p == ' ' || *c->p == '\n' || *c->p == '\t' || *c->p == '\r') c->p++;
  if (!*c->p) return 0;
  char *end;
  errno = 0;
  double v = strtod(c->p, &end);
  if (end == c->p || errno == ERANGE || !isfinite(v)) return 0;
  c->p = end;
  *out = v;
  return 1;
}

static int next_int(cursor *c, long lo, long hi, long *out) {
  double v;
  if (!next_double(c, &v) || v != floor(v) || v < lo || v > hi) return 0;
  *out = (long)v;
  return 1;
}

static int at_end(cursor *c) {
  while (*c->p == ' ' || *c->p == '\n' || *c->p == '\t' || *c->p == '\r') c->p++;
  return !*c->p;
}

static ch_status parse_curves(const char *txt, const char *name, ch_featmap *m, ch_error *err) {
  cursor c = {txt};
  long n;
  /* A curve is at least five numbers of two characters each: a count the
   * text cannot hold is refused before anything is allocated for it. */
  if (!next_int(&c, 1, 1 << 24, &n) || (size_t)n > strlen(txt) / 10)
    return ch_error_set(err, CH_ERR_INPUT, "%s: bad curve table (count)", name);
  m->curves = calloc((size_t)n, sizeof *m->curves);
  if (!m->curves) return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory for %ld curves", name, n);
  m->num_curves = (int)n;
  for (long i = 0; i < n; i++) {
    ch_featmap_curve *cv = &m->curves[i];
    long kind, pk, np;
    double w, d;
    if (!next_int(&c, 0, 1, &kind) || !next_double(&c, &w) || !next_double(&c, &d) || !next_int(&c, 0, 5, &pk) ||
        !next_int(&c, 0, CH_PROFILE_MAX_POINTS, &np) || !(w > 0.0))
      return ch_error_set(err, CH_ERR_INPUT, "%s: bad curve table (curve %ld)", name, i);
    cv->kind = (ch_curve_kind)kind;
    cv->width = w;
    cv->depth = d;
    cv->profile.kind = (ch_profile_kind)pk;
    cv->profile.num_points = (int)np;
    for (long k = 0; k < np; k++) {
      double t, h;
      if (!next_double(&c, &t) || !next_double(&c, &h) || t < -0.5 || t > 0.5 || (k > 0 && t < cv->profile.t[k - 1]))
        return ch_error_set(err, CH_ERR_INPUT, "%s: bad curve table (profile of curve %ld)", name, i);
      cv->profile.t[k] = t;
      cv->profile.h[k] = h;
    }
    if (pk == CH_PROFILE_CUSTOM && np < 2)
      return ch_error_set(err, CH_ERR_INPUT, "%s: bad curve table (profile of curve %ld)", name, i);
  }
  if (!at_end(&c)) return ch_error_set(err, CH_ERR_INPUT, "%s: bad curve table (trailing data)", name);
  return CH_OK;
}

static ch_status parse_pieces(const char *txt, const char *name, ch_featmap *m, ch_error *err) {
  cursor c = {txt};
  long n;
  /* fourteen numbers a piece */
  if (!next_int(&c, 0, 1 << 24, &n) || (size_t)n > strlen(txt) / 28)
    return ch_error_set(err, CH_ERR_INPUT, "%s: bad piece table (count)", name);
  m->pieces = calloc((size_t)(n > 0 ? n : 1), sizeof *m->pieces);
  if (!m->pieces) return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory for %ld pieces", name, n);
  m->num_pieces = (int)n;
  for (long i = 0; i < n; i++) {
    ch_featmap_piece *pc = &m->pieces[i];
    long curve = 0, line = 0, so = 0, eo = 0;
    int ok = next_int(&c, 0, m->num_curves - 1, &curve) && next_int(&c, 0, 1, &line) && next_int(&c, 0, 1, &so) &&
             next_int(&c, 0, 1, &eo);
    for (int k = 0; ok && k < 3; k++) ok = next_double(&c, &pc->p[k][0]) && next_double(&c, &pc->p[k][1]);
    ok = ok && next_double(&c, &pc->tin[0]) && next_double(&c, &pc->tin[1]) && next_double(&c, &pc->tout[0]) &&
         next_double(&c, &pc->tout[1]);
    if (!ok) return ch_error_set(err, CH_ERR_INPUT, "%s: bad piece table (piece %ld)", name, i);
    pc->curve = (int)curve, pc->is_line = (int)line, pc->start_open = (int)so, pc->end_open = (int)eo;
  }
  if (!at_end(&c)) return ch_error_set(err, CH_ERR_INPUT, "%s: bad piece table (trailing data)", name);
  return CH_OK;
}

static ch_status parse_fallback(const char *txt, const char *name, ch_featmap *m, ch_error *err) {
  cursor c = {txt};
  int R1 = m->resolution + 1;
  size_t n = (size_t)R1 * R1;
  long cells;
  long flagged = 0;
  for (size_t k = 0; k < n; k++) flagged += (m->config[k] & CH_FM_FALLBACK) != 0;
  if (!next_int(&c, 0, (long)n, &cells) || cells != flagged)
    return ch_error_set(err, CH_ERR_INPUT, "%s: fallback lists do not match the cells marked for them", name);
  m->fb_list = malloc((size_t)(cells * CH_FEATMAP_MAX_PIECES + 1) * sizeof *m->fb_list);
  if (!m->fb_list) return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory for fallback lists", name);
  long at = 0;
  for (size_t k = 0; k < n; k++) {
    if (!(m->config[k] & CH_FM_FALLBACK)) continue;
    long cnt;
    if (!next_int(&c, 0, CH_FEATMAP_MAX_PIECES, &cnt))
      return ch_error_set(err, CH_ERR_INPUT, "%s: bad fallback list", name);
    m->fb_start[k] = (int32_t)at;
    m->fb_count[k] = (uint8_t)cnt;
    for (long e = 0; e < cnt; e++) {
      long p;
      if (!next_int(&c, 0, (long)m->num_pieces - 1, &p))
        return ch_error_set(err, CH_ERR_INPUT, "%s: bad fallback list (piece index)", name);
      m->fb_list[at++] = (int32_t)p;
    }
  }
  if (!at_end(&c)) return ch_error_set(err, CH_ERR_INPUT, "%s: bad fallback lists (trailing data)", name);
  m->fb_list_size = (int)at;
  m->has_fallback = cells > 0;
  m->stats.fallback_cells = cells;
  m->stats.fallback_entries = at;
  return CH_OK;
}

static ch_status parse_singular(const char *txt, const char *name, ch_featmap *m, ch_error *err) {
  cursor c = {txt};
  long n;
  /* a point is at least six numbers of two characters */
  if (!next_int(&c, 0, 1 << 24, &n) || (size_t)n > strlen(txt) / 12)
    return ch_error_set(err, CH_ERR_INPUT, "%s: bad singular point table (count)", name);
  m->singular = calloc((size_t)(n > 0 ? n : 1), sizeof *m->singular);
  if (!m->singular) return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory for %ld singular points", name, n);
  m->num_singular = (int)n;
  for (long i = 0; i < n; i++) {
    ch_stepsing_point *pt = &m->singular[i];
    long arms;
    int ok = next_double(&c, &pt->p[0]) && next_double(&c, &pt->p[1]) && next_int(&c, 1, CH_STEPSING_MAX_ARMS, &arms) &&
             fabs(pt->p[0]) <= CH_CURVES_MAX_UV && fabs(pt->p[1]) <= CH_CURVES_MAX_UV;
    pt->num_arms = ok ? (int)arms : 0;
    for (int k = 0; k < CH_STEPSING_MAX_ARMS; k++) pt->arm_curve[k] = -1; /* not in the file */
    for (int k = 0; ok && k < pt->num_arms; k++)
      ok = next_double(&c, &pt->angle[k]) && next_double(&c, &pt->value[k]) && next_double(&c, &pt->slope[k]) &&
           pt->angle[k] >= 0.0 && pt->angle[k] < 2.0 * CH_PI && (k == 0 || pt->angle[k] > pt->angle[k - 1]);
    if (!ok) return ch_error_set(err, CH_ERR_INPUT, "%s: bad singular point table (point %ld)", name, i);
  }
  if (!at_end(&c)) return ch_error_set(err, CH_ERR_INPUT, "%s: bad singular point table (trailing data)", name);
  return ch_featmap_singular_index(m, err); /* the radii too: they follow from the points */
}

static ch_status parse_flat(const char *txt, const char *name, ch_featmap *m, ch_error *err) {
  cursor c = {txt};
  long n;
  if (!next_int(&c, 0, m->num_curves, &n))
    return ch_error_set(err, CH_ERR_INPUT, "%s: bad flat side table (count)", name);
  for (long i = 0; i < n; i++) {
    long curve, side;
    if (!next_int(&c, 0, m->num_curves - 1, &curve) || !next_int(&c, -1, 1, &side) || !side ||
        m->curves[curve].kind != CH_CURVE_STEP)
      return ch_error_set(err, CH_ERR_INPUT, "%s: bad flat side table (entry %ld)", name, i);
    m->curves[curve].flat_side = (int)side;
  }
  if (!at_end(&c)) return ch_error_set(err, CH_ERR_INPUT, "%s: bad flat side table (trailing data)", name);
  return CH_OK;
}

/* Whether a configuration word is one the build can make. */
static int config_ok(uint32_t w) {
  if (w & ~CONFIG_BITS) return 0;
  unsigned a = w & CH_FM_SEG_MASK, b = (w >> CH_FM_SEG_BITS) & CH_FM_SEG_MASK;
  if (a > 6 || b > 6 || (b && (!a || a == b))) return 0;
  return 1;
}

static ch_status read_maps(const source *src, const ch_image *img, ch_featmap *m, struct ch_msdf *msdf, ch_error *err) {
  const char *name = src->name;
  char *cmd = NULL, *ver = NULL, *mode = NULL, *res = NULL, *rect = NULL, *curves = NULL, *pieces = NULL,
       *fallback = NULL, *range = NULL, *singular = NULL, *flat = NULL;
  ch_status st;
  ch_error quiet = {0};
  if (get_attr(src, "chisel:command", &cmd, &quiet) || strcmp(cmd, "featmap")) {
    st = ch_error_set(err, CH_ERR_INPUT, "%s: not a feature map (no chisel:command \"featmap\"; made by `chisel featmap`)",
                      name);
    goto done;
  }
  if ((st = get_attr(src, "chisel:featmap", &ver, err))) goto done;
  if (strcmp(ver, "1")) {
    st = ch_error_set(err, CH_ERR_INPUT, "%s: feature map format '%.32s' is not 1", name, ver);
    goto done;
  }
  if ((st = get_attr(src, "chisel:featmap-mode", &mode, err)) || (st = get_attr(src, "chisel:resolution", &res, err)) ||
      (st = get_attr(src, "chisel:rect", &rect, err)) || (st = get_attr(src, "chisel:featmap-curves", &curves, err)) ||
      (st = get_attr(src, "chisel:featmap-pieces", &pieces, err)) ||
      (st = get_attr(src, "chisel:featmap-fallback", &fallback, err)))
    goto done;
  long R;
  cursor cr = {res};
  if (!next_int(&cr, CH_FEATMAP_MIN_RES, CH_FEATMAP_MAX_RES, &R) || !at_end(&cr)) {
    st = ch_error_set(err, CH_ERR_INPUT, "%s: resolution '%.32s' outside %d..%d", name, res, CH_FEATMAP_MIN_RES,
                      CH_FEATMAP_MAX_RES);
    goto done;
  }
  if (img->width != R + 1 || img->height != R + 1) {
    st = ch_error_set(err, CH_ERR_INPUT, "%s: image is %dx%d, a resolution %ld map is %ldx%ld", name, img->width,
                      img->height, R, R + 1, R + 1);
    goto done;
  }
  double rc[4];
  cursor crr = {rect};
  if (!next_double(&crr, &rc[0]) || !next_double(&crr, &rc[1]) || !next_double(&crr, &rc[2]) ||
      !next_double(&crr, &rc[3]) || !at_end(&crr) || !(rc[2] > rc[0] && rc[3] > rc[1])) {
    st = ch_error_set(err, CH_ERR_INPUT, "%s: bad chisel:rect '%.64s'", name, rect);
    goto done;
  }
  int idx[L_COUNT];
  for (int l = 0; l < L_COUNT; l++) {
    idx[l] = ch_image_find(img, layer_names[l]);
    if (l < L_REQUIRED && idx[l] < 0) {
      st = ch_error_set(err, CH_ERR_INPUT, "%s: no channel '%s'", name, layer_names[l]);
      goto done;
    }
  }
  int has_base = idx[L_BX] >= 0 && idx[L_BY] >= 0 && idx[L_BZ] >= 0;
  int has_normal = idx[L_NX] >= 0 && idx[L_NY] >= 0 && idx[L_NZ] >= 0;
  int has_msdf = idx[L_MR] >= 0 && idx[L_MG] >= 0 && idx[L_MB] >= 0;
  m->resolution = (int)R;
  memcpy(m->rect, rc, sizeof rc);
  m->linear = !strcmp(mode, "linear");
  if (!m->linear && strcmp(mode, "quadratic")) {
    st = ch_error_set(err, CH_ERR_INPUT, "%s: unknown feature map mode '%.32s'", name, mode);
    goto done;
  }
  if ((st = parse_curves(curves, name, m, err))) goto done;
  int R1 = (int)R + 1;
  size_t n = (size_t)R1 * R1;
  m->dist = ch_alloc_large(n, sizeof *m->dist, 0);
  m->grad = ch_alloc_large(2 * n, sizeof *m->grad, 0);
  m->curve = ch_alloc_large(n, sizeof *m->curve, 0);
  m->base = ch_alloc_large(3 * n, sizeof *m->base, 0);
  m->edge = ch_alloc_large(4 * n, sizeof *m->edge, 0);
  m->config = ch_alloc_large(n, sizeof *m->config, 0);
  m->seg_curve = ch_alloc_large(2 * n, sizeof *m->seg_curve, 0);
  m->fb_start = ch_alloc_large(n, sizeof *m->fb_start, 0);
  m->fb_count = ch_alloc_large(n, sizeof *m->fb_count, 1);
  if (has_normal) m->normal = ch_alloc_large(3 * n, sizeof *m->normal, 0);
  if (!m->dist || !m->grad || !m->curve || !m->base || !m->edge || !m->config || !m->seg_curve || !m->fb_start ||
      !m->fb_count || (has_normal && !m->normal)) {
    st = ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory for the maps", name);
    goto done;
  }
  m->has_base = has_base;
  m->has_normal = has_normal;
  for (int i = 0; i < R1; i++)
    for (int j = 0; j < R1; j++) {
      size_t k = (size_t)i * R1 + j, px = (size_t)(R - i) * R1 + j;
#define GET(l) ((double)ch_image_plane(img, idx[l])[px])
      double v[L_COUNT];
      for (int l = 0; l < L_COUNT; l++) {
        v[l] = idx[l] >= 0 ? GET(l) : 0.0;
        if (!isfinite(v[l])) {
          st = ch_error_set(err, CH_ERR_INPUT, "%s: channel '%s' is not finite at pixel (%d, %d)", name,
                            layer_names[l], j, (int)(R - i));
          goto done;
        }
      }
#undef GET
      const char *bad = NULL;
      if (v[L_CURVE] != floor(v[L_CURVE]) || v[L_CURVE] < 0 || v[L_CURVE] >= m->num_curves) bad = "curve";
      else if (v[L_SEG0] != floor(v[L_SEG0]) || v[L_SEG0] < -1 || v[L_SEG0] >= m->num_curves) bad = "seg.curve0";
      else if (v[L_SEG1] != floor(v[L_SEG1]) || v[L_SEG1] < -1 || v[L_SEG1] >= m->num_curves) bad = "seg.curve1";
      else if (!(v[L_SPOS] >= 0.0 && v[L_SPOS] <= 1.0)) bad = "sig.S.pos";
      else if (!(v[L_WPOS] >= 0.0 && v[L_WPOS] <= 1.0)) bad = "sig.W.pos";
      else if (fabs(v[L_SANG]) > 4.0) bad = "sig.S.angle";
      else if (fabs(v[L_WANG]) > 4.0) bad = "sig.W.angle";
      else if (v[L_CONFIG] != floor(v[L_CONFIG]) || v[L_CONFIG] < 0 || v[L_CONFIG] > CONFIG_BITS ||
               !config_ok((uint32_t)v[L_CONFIG]))
        bad = "config";
      if (bad) {
        st = ch_error_set(err, CH_ERR_INPUT, "%s: channel '%s' holds an impossible value at pixel (%d, %d)", name, bad,
                          j, (int)(R - i));
        goto done;
      }
      m->dist[k] = (float)v[L_D];
      m->grad[2 * k] = (float)v[L_GX];
      m->grad[2 * k + 1] = (float)v[L_GY];
      m->curve[k] = (int32_t)v[L_CURVE];
      m->edge[4 * k] = (float)v[L_SPOS];
      m->edge[4 * k + 1] = (float)v[L_SANG];
      m->edge[4 * k + 2] = (float)v[L_WPOS];
      m->edge[4 * k + 3] = (float)v[L_WANG];
      uint32_t w = (uint32_t)v[L_CONFIG];
      if (i == R || j == R) w &= CH_FM_POINT_S | CH_FM_POINT_W; /* not cells: only their edges count */
      m->config[k] = w;
      m->seg_curve[2 * k] = (int32_t)v[L_SEG0];
      m->seg_curve[2 * k + 1] = (int32_t)v[L_SEG1];
      m->fb_start[k] = -1;
      m->base[3 * k] = (float)(has_base ? v[L_BX] : 0.0);
      m->base[3 * k + 1] = (float)(has_base ? v[L_BY] : 0.0);
      m->base[3 * k + 2] = (float)(has_base ? v[L_BZ] : 1.0);
      if (has_normal)
        for (int c = 0; c < 3; c++) m->normal[3 * k + c] = (float)v[L_NX + c];
    }
  if ((st = parse_pieces(pieces, name, m, err)) || (st = parse_fallback(fallback, name, m, err))) goto done;
  /* maps without flat sides or singular points (or written before they were) have no tables */
  if ((st = optional_attr(src, "chisel:featmap-flat", &flat, err)) || (flat && (st = parse_flat(flat, name, m, err))))
    goto done;
  /* the windows' reach (cells), which files before it changed do not give */
  char *window = NULL;
  m->sg_window = CH_FEATMAP_SINGULAR_R1_LEGACY;
  if ((st = optional_attr(src, "chisel:featmap-singular-window", &window, err))) goto done;
  if (window) {
    cursor cw = {window};
    double rw = 0.0;
    int ok = next_double(&cw, &rw) && at_end(&cw) && rw >= 1.0 && rw <= 4096.0;
    free(window);
    if (!ok) {
      st = ch_error_set(err, CH_ERR_INPUT, "%s: bad chisel:featmap-singular-window (a reach in cells, 1 to 4096)", name);
      goto done;
    }
    m->sg_window = rw;
  }
  if ((st = optional_attr(src, "chisel:featmap-singular", &singular, err)) ||
      (singular && (st = parse_singular(singular, name, m, err))))
    goto done;
  if (msdf) {
    memset(msdf, 0, sizeof *msdf);
    if (has_msdf) {
      double rg = 0.0;
      if ((st = get_attr(src, "chisel:msdf-range", &range, err))) goto done;
      cursor cg = {range};
      if (!next_double(&cg, &rg) || !at_end(&cg) || !(rg > 0.0)) {
        st = ch_error_set(err, CH_ERR_INPUT, "%s: bad chisel:msdf-range '%.32s'", name, range);
        goto done;
      }
      msdf->resolution = (int)R;
      memcpy(msdf->rect, rc, sizeof rc);
      msdf->range = rg;
      msdf->channels = ch_alloc_large(3 * n, sizeof *msdf->channels, 0);
      msdf->curve = ch_alloc_large(n, sizeof *msdf->curve, 0);
      msdf->curves = malloc((size_t)m->num_curves * sizeof *msdf->curves);
      if (!msdf->channels || !msdf->curve || !msdf->curves) {
        st = ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory for the distance field", name);
        goto done;
      }
      msdf->num_curves = m->num_curves;
      memcpy(msdf->curves, m->curves, (size_t)m->num_curves * sizeof *msdf->curves);
      memcpy(msdf->curve, m->curve, n * sizeof *msdf->curve);
      for (int i = 0; i < R1; i++)
        for (int j = 0; j < R1; j++) {
          size_t k = (size_t)i * R1 + j, px = (size_t)(R - i) * R1 + j;
          for (int c = 0; c < 3; c++) msdf->channels[3 * k + c] = ch_image_plane(img, idx[L_MR + c])[px];
        }
    }
  }
  st = CH_OK;
done:
  free(cmd);
  free(ver);
  free(mode);
  free(res);
  free(rect);
  free(curves);
  free(pieces);
  free(fallback);
  free(singular);
  free(flat);
  free(range);
  if (st) {
    ch_featmap_free(m);
    if (msdf) ch_msdf_free(msdf);
  }
  return st;
}

ch_status ch_featmap_read_exr(const char *path, ch_featmap *m, struct ch_msdf *msdf, ch_error *err) {
  memset(m, 0, sizeof *m);
  if (msdf) memset(msdf, 0, sizeof *msdf);
  ch_image img;
  ch_status st = ch_exr_read(path, &img, err);
  if (st) return st;
  source src = {.path = path, .name = path};
  st = read_maps(&src, &img, m, msdf, err);
  ch_image_free(&img);
  return st;
}

ch_status ch_featmap_read_exr_memory(const void *data, size_t size, const char *name, ch_featmap *m,
                                     struct ch_msdf *msdf, ch_error *err) {
  memset(m, 0, sizeof *m);
  if (msdf) memset(msdf, 0, sizeof *msdf);
  ch_image img;
  ch_status st = ch_exr_read_memory(data, size, name, &img, err);
  if (st) return st;
  source src = {.data = data, .size = size, .name = name ? name : "(memory)"};
  st = read_maps(&src, &img, m, msdf, err);
  ch_image_free(&img);
  return st;
}
