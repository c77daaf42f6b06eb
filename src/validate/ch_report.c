/* ch_report: the study's pictures and report (ch_report.h). */
#define _POSIX_C_SOURCE 200809L
#include "ch_report.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "ch_exr.h"
#include "ch_file.h"
#include "ch_math.h"
#include "ch_png.h"
#include "ch_truth.h"
#include "ch_version.h"

static uint8_t to8(double x) { return (uint8_t)lround(255.0 * pow(ch_clamp(x, 0.0, 1.0), 1.0 / 2.2)); }

ch_status ch_report_png(const char *path, ch_report_picture what, const ch_image *img, const ch_image *truth,
                           double scene_size, ch_error *err) {
  size_t n = (size_t)img->width * img->height;
  uint8_t *px = malloc(3 * n);
  if (!px) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for %s", path);
  static const uint8_t class_rgb[CH_VIS_COUNT][3] = {{0, 0, 0}, {200, 200, 200}, {235, 140, 40}, {60, 110, 220},
                                                     {60, 170, 80}};
  const float *shade = ch_image_plane(img, CH_RENDER_SHADE), *cls = ch_image_plane(img, CH_RENDER_CLASS);
  const float *tshade = truth ? ch_image_plane(truth, CH_RENDER_SHADE) : NULL;
  const float *tcls = truth ? ch_image_plane(truth, CH_RENDER_CLASS) : NULL;
  for (size_t p = 0; p < n; p++) {
    uint8_t *o = &px[3 * p];
    int both = truth && ch_image_plane(img, CH_RENDER_COVERAGE)[p] > 0.0f &&
               ch_image_plane(truth, CH_RENDER_COVERAGE)[p] > 0.0f;
    switch (what) {
    case CH_REPORT_SHADE: o[0] = o[1] = o[2] = to8(shade[p]); break;
    case CH_REPORT_CLASSES: memcpy(o, class_rgb[(int)cls[p] % CH_VIS_COUNT], 3); break;
    case CH_REPORT_CLASS_DIFF:
      if (cls[p] != tcls[p]) {
        o[0] = 230, o[1] = 20, o[2] = 20;
      } else {
        o[0] = o[1] = o[2] = to8(0.6 * tshade[p]);
      }
      break;
    case CH_REPORT_NORMAL:
    case CH_REPORT_DEPTH: {
      if (!both) {
        o[0] = o[1] = o[2] = 0;
        break;
      }
      double x;
      if (what == CH_REPORT_NORMAL) {
        double dot = 0.0;
        for (int k = 0; k < 3; k++) dot += (double)ch_image_plane(img, CH_RENDER_NX + k)[p] * ch_image_plane(truth, CH_RENDER_NX + k)[p];
        x = acos(ch_clamp(dot, -1.0, 1.0)) * 180.0 / CH_PI / 20.0;
      } else {
        x = fabs((double)ch_image_plane(img, CH_RENDER_DEPTH)[p] - ch_image_plane(truth, CH_RENDER_DEPTH)[p]) /
            scene_size / 1e-2;
      }
      ch_colormap_heat(ch_clamp(x, 0.0, 1.0), o);
      break;
    }
    }
  }
  ch_status st = ch_png_write(path, img->width, img->height, 3, px, err);
  free(px);
  return st;
}

ch_status ch_report_exr(const char *path, const ch_image *img, const char *viewname, const char *methodname,
                           ch_error *err) {
  const ch_exr_attribute attrs[] = {{"chisel:command", "study"}, {"chisel:view", viewname}, {"chisel:method", methodname}};
  /* Names every reader parses: a one-value layer of more than one letter
   * is written NAME.X (Blender's multilayer reader wants a layer and a
   * one-letter channel, as its own index passes have), the shading also
   * as Y for viewers. The pixels are shared, not copied. */
  ch_image named = *img;
  for (int c = 0; c < named.num_channels; c++)
    if (!strchr(named.names[c], '.') && strlen(named.names[c]) > 1 && strlen(named.names[c]) + 3 <= CH_IMAGE_NAME_MAX)
      strcat(named.names[c], ".X");
  ch_exr_write_desc desc = {.attributes = attrs, .num_attributes = 3, .luminance = "shade.X"};
  ch_status st = ch_exr_write(path, &named, &desc, err);
  return st;
}


ch_status ch_report_summaries(const char *dir, const ch_scene *s, const ch_study_row *rows, int nrows, ch_error *err) {
  char path[4096];
  snprintf(path, sizeof path, "%s/summary.csv", dir);
  ch_atomic_file f;
  ch_status st = ch_atomic_open(&f, path, err);
  if (st) return st;
  fprintf(f.fp, "view,method,family,triangles,class_mismatch_pct,class_mismatch_groove_pct,id_mismatch_pct,depth_error_rel,"
                "normal_mean_deg,normal_p95_deg,shade_rmse,shade_ssim,shadow_mismatch_pct,pixels,groove_pixels\n");
  for (int i = 0; i < nrows; i++) {
    const ch_metrics *m = &rows[i].m;
    fprintf(f.fp, "%s,%s,%s,%ld,%.6f,%.6f,%.6f,%.6e,%.6f,%.6f,%.6f,%.6f,%.6f,%ld,%ld\n", s->views[rows[i].view].name,
            s->methods[rows[i].method].name, s->methods[rows[i].method].family, rows[i].triangles, m->class_mismatch, m->class_mismatch_groove, m->id_mismatch,
            m->depth_error, m->normal_mean_deg, m->normal_p95_deg, m->shade_rmse, m->shade_ssim, m->shadow_mismatch,
            m->pixels, m->groove_pixels);
  }
  if ((st = ch_atomic_commit(&f, err))) return st;

  cJSON *root = cJSON_CreateObject(), *arr = cJSON_AddArrayToObject(root, "rows");
  cJSON_AddStringToObject(root, "curves", s->curves_path);
  cJSON_AddNumberToObject(root, "truth_grid", s->truth_grid);
  cJSON_AddNumberToObject(root, "dci_resolution", s->dci_resolution);
  for (int i = 0; i < nrows && arr; i++) {
    const ch_metrics *m = &rows[i].m;
    cJSON *r = cJSON_CreateObject();
    cJSON_AddItemToArray(arr, r);
    cJSON_AddStringToObject(r, "view", s->views[rows[i].view].name);
    cJSON_AddStringToObject(r, "method", s->methods[rows[i].method].name);
    cJSON_AddStringToObject(r, "family", s->methods[rows[i].method].family);
    cJSON_AddNumberToObject(r, "triangles", (double)rows[i].triangles);
    cJSON_AddNumberToObject(r, "class_mismatch_pct", m->class_mismatch);
    cJSON_AddNumberToObject(r, "class_mismatch_groove_pct", m->class_mismatch_groove);
    cJSON_AddNumberToObject(r, "id_mismatch_pct", m->id_mismatch);
    cJSON_AddNumberToObject(r, "depth_error_rel", m->depth_error);
    cJSON_AddNumberToObject(r, "normal_mean_deg", m->normal_mean_deg);
    cJSON_AddNumberToObject(r, "normal_p95_deg", m->normal_p95_deg);
    cJSON_AddNumberToObject(r, "shade_rmse", m->shade_rmse);
    cJSON_AddNumberToObject(r, "shade_ssim", m->shade_ssim);
    cJSON_AddNumberToObject(r, "shadow_mismatch_pct", m->shadow_mismatch);
    cJSON_AddNumberToObject(r, "pixels", (double)m->pixels);
    cJSON_AddNumberToObject(r, "groove_pixels", (double)m->groove_pixels);
  }
  char *text = root && arr ? cJSON_Print(root) : NULL;
  cJSON_Delete(root);
  if (!text) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for summary.json");
  snprintf(path, sizeof path, "%s/summary.json", dir);
  st = ch_atomic_open(&f, path, err);
  if (!st) {
    fputs(text, f.fp);
    fputc('\n', f.fp);
    st = ch_atomic_commit(&f, err);
  }
  cJSON_free(text);
  return st;
}

/* Truth and methods' shading side by side, 4 black pixels apart. */
ch_status ch_report_montage(const char *path, const ch_image *const *imgs, int n, ch_error *err) {
  int W = imgs[0]->width, H = imgs[0]->height, gap = 4, MW = n * W + (n - 1) * gap;
  uint8_t *px = calloc((size_t)MW * H * 3, 1);
  if (!px) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for %s", path);
  for (int k = 0; k < n; k++) {
    const float *shade = ch_image_plane(imgs[k], CH_RENDER_SHADE);
    for (int y = 0; y < H; y++)
      for (int x = 0; x < W; x++) {
        uint8_t *o = &px[3 * ((size_t)y * MW + k * (W + gap) + x)];
        o[0] = o[1] = o[2] = to8(shade[(size_t)y * W + x]);
      }
  }
  ch_status st = ch_png_write(path, MW, H, 3, px, err);
  free(px);
  return st;
}

static void html_text(FILE *f, const char *t) {
  for (; *t; t++) {
    if (*t == '<') fputs("&lt;", f);
    else if (*t == '>') fputs("&gt;", f);
    else if (*t == '&') fputs("&amp;", f);
    else if (*t == '"') fputs("&quot;", f);
    else fputc(*t, f);
  }
}

/* One SVG plot of a metric against triangles (log scale), a line per family. */
static void html_plot(FILE *f, const ch_scene *s, const ch_study_row *rows, int nrows, int v, const char *title, int which) {
  const int PW = 420, PH = 260, L = 60, R = 120, T = 30, B = 40;
  double xmin = INFINITY, xmax = -INFINITY, ymax = 0.0;
#define METRIC(r) (which == 0 ? (r)->m.class_mismatch_groove : which == 1 ? (r)->m.normal_p95_deg : (r)->m.depth_error)
  for (int i = 0; i < nrows; i++) {
    if (rows[i].view != v || rows[i].triangles < 1) continue;
    double x = log10((double)rows[i].triangles);
    xmin = fmin(xmin, x), xmax = fmax(xmax, x), ymax = fmax(ymax, METRIC(&rows[i]));
  }
  if (!(xmin <= xmax)) return;
  if (xmax - xmin < 0.5) xmin -= 0.25, xmax += 0.25;
  if (!(ymax > 0.0)) ymax = 1.0;
  ymax *= 1.1;
  fprintf(f, "<svg class=\"plot\" width=\"%d\" height=\"%d\" viewBox=\"0 0 %d %d\">\n", PW, PH, PW, PH);
  fprintf(f, "<text x=\"%d\" y=\"18\" font-size=\"13\">%s</text>\n", L, title);
  fprintf(f, "<rect x=\"%d\" y=\"%d\" width=\"%d\" height=\"%d\" fill=\"none\" stroke=\"#888\"/>\n", L, T, PW - L - R,
          PH - T - B);
  for (int k = 0; k <= 4; k++) {
    double y = ymax * k / 4, py = PH - B - (PH - T - B) * k / 4.0;
    fprintf(f, "<text x=\"%d\" y=\"%.1f\" font-size=\"10\" text-anchor=\"end\">%.3g</text>\n", L - 4, py + 3, y);
  }
  for (int e = (int)ceil(xmin); e <= (int)floor(xmax); e++) {
    double px = L + (PW - L - R) * (e - xmin) / (xmax - xmin);
    fprintf(f, "<text x=\"%.1f\" y=\"%d\" font-size=\"10\" text-anchor=\"middle\">1e%d</text>\n", px, PH - B + 14, e);
  }
  fprintf(f, "<text x=\"%d\" y=\"%d\" font-size=\"11\" text-anchor=\"middle\">triangles (log scale)</text>\n",
          L + (PW - L - R) / 2, PH - 8);
  static const char *colours[] = {"#d62728", "#1f77b4", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#17becf"};
  int nf = 0;
  for (int m = 0; m < s->num_methods; m++) {
    int first = 1;
    for (int j = 0; j < m; j++) first &= strcmp(s->methods[j].family, s->methods[m].family) != 0;
    if (!first) continue;
    const char *col = colours[nf % 7];
    /* The family's rows in this view, by triangle count. */
    const ch_study_row *pts[64];
    int np = 0;
    for (int i = 0; i < nrows && np < 64; i++)
      if (rows[i].view == v && rows[i].triangles > 0 && !strcmp(s->methods[rows[i].method].family, s->methods[m].family))
        pts[np++] = &rows[i];
    for (int a = 1; a < np; a++)
      for (int b = a; b > 0 && pts[b]->triangles < pts[b - 1]->triangles; b--) {
        const ch_study_row *t = pts[b];
        pts[b] = pts[b - 1];
        pts[b - 1] = t;
      }
    fprintf(f, "<polyline fill=\"none\" stroke=\"%s\" stroke-width=\"1.5\" points=\"", col);
    for (int a = 0; a < np; a++)
      fprintf(f, "%.1f,%.1f ", L + (PW - L - R) * (log10((double)pts[a]->triangles) - xmin) / (xmax - xmin),
              PH - B - (PH - T - B) * METRIC(pts[a]) / ymax);
    fprintf(f, "\"/>\n");
    for (int a = 0; a < np; a++)
      fprintf(f, "<circle r=\"3\" fill=\"%s\" cx=\"%.1f\" cy=\"%.1f\"><title>%s: %ld triangles, %.4g</title></circle>\n",
              col, L + (PW - L - R) * (log10((double)pts[a]->triangles) - xmin) / (xmax - xmin),
              PH - B - (PH - T - B) * METRIC(pts[a]) / ymax, s->methods[pts[a]->method].name, pts[a]->triangles,
              METRIC(pts[a]));
    fprintf(f, "<text x=\"%d\" y=\"%d\" font-size=\"11\" fill=\"%s\">%s</text>\n", PW - R + 8, T + 12 + 14 * nf, col,
            s->methods[m].family);
    nf++;
  }
#undef METRIC
  fprintf(f, "</svg>\n");
}

/* A colour bar for a heat map: the map chisel's PNGs use (ch_colormap_heat)
 * from lo to hi in unit, as an inline SVG beside the picture. */
static void html_colorbar(FILE *f, int *ids, double lo, double hi, const char *unit) {
  int id = ++*ids;
  fprintf(f, "<svg class=\"bar\" width=\"170\" height=\"40\" viewBox=\"0 0 170 40\"><defs><linearGradient id=\"cb%d\">",
          id);
  for (int k = 0; k <= 10; k++) {
    uint8_t c[3];
    ch_colormap_heat(k / 10.0, c);
    fprintf(f, "<stop offset=\"%d%%\" stop-color=\"#%02x%02x%02x\"/>", 10 * k, c[0], c[1], c[2]);
  }
  fprintf(f, "</linearGradient></defs><rect x=\"5\" y=\"2\" width=\"160\" height=\"10\" fill=\"url(#cb%d)\"/>", id);
  for (int k = 0; k <= 2; k++)
    fprintf(f, "<text x=\"%d\" y=\"24\" font-size=\"10\" text-anchor=\"%s\">%g</text>", 5 + 80 * k,
            k == 0 ? "start" : k == 1 ? "middle" : "end", lo + (hi - lo) * k / 2.0);
  fprintf(f, "<text x=\"85\" y=\"36\" font-size=\"10\" text-anchor=\"middle\">%s</text></svg>", unit);
}

/* A metric of a row, for the tables and plots: class % in grooves, normal
 * p95 (degrees), depth error (relative), SSIM. */
static double row_metric(const ch_study_row *r, int which) {
  switch (which) {
  case 0: return r->m.class_mismatch;
  case 1: return r->m.class_mismatch_groove;
  case 2: return r->m.depth_error;
  case 3: return r->m.normal_p95_deg;
  default: return r->m.shade_ssim;
  }
}

/* Means over the views, per method: the figure a paper quotes. One plot per
 * metric, log-log, a line per family. */
static void html_summary_plot(FILE *f, const ch_scene *s, const ch_study_row *rows, int nrows, int which, const char *title) {
  const int PW = 440, PH = 270, L = 64, R = 120, T = 30, B = 44;
  double mean[64] = {0}, x[64] = {0};
  int count[64] = {0};
  for (int i = 0; i < nrows; i++) {
    int m = rows[i].method;
    if (m >= 64) continue;
    mean[m] += row_metric(&rows[i], which), count[m]++;
    x[m] = (double)rows[i].triangles;
  }
  double xmin = INFINITY, xmax = -INFINITY, ymin = INFINITY, ymax = -INFINITY;
  for (int m = 0; m < s->num_methods && m < 64; m++) {
    if (!count[m] || x[m] < 1) continue;
    mean[m] /= count[m];
    xmin = fmin(xmin, log10(x[m])), xmax = fmax(xmax, log10(x[m]));
    if (mean[m] > 0) ymin = fmin(ymin, log10(mean[m])), ymax = fmax(ymax, log10(mean[m]));
  }
  if (!(xmin <= xmax)) return;
  if (!(ymin <= ymax)) ymin = -3, ymax = 0;
  xmin = floor(xmin - 0.05), xmax = ceil(xmax + 0.05);
  ymin = floor(ymin), ymax = ceil(ymax);
  if (xmax - xmin < 1) xmax = xmin + 1;
  if (ymax - ymin < 1) ymax = ymin + 1;
  double floor_y = ymin; /* zeros sit on the bottom axis */
  fprintf(f, "<svg class=\"plot\" width=\"%d\" height=\"%d\" viewBox=\"0 0 %d %d\">\n", PW, PH, PW, PH);
  fprintf(f, "<text x=\"%d\" y=\"18\" font-size=\"13\">%s</text>\n", L, title);
  fprintf(f, "<rect x=\"%d\" y=\"%d\" width=\"%d\" height=\"%d\" fill=\"none\" stroke=\"#888\"/>\n", L, T, PW - L - R,
          PH - T - B);
#define PX(lx) (L + (PW - L - R) * ((lx) - xmin) / (xmax - xmin))
#define PY(ly) (PH - B - (PH - T - B) * ((ly) - ymin) / (ymax - ymin))
  for (int e = (int)ymin; e <= (int)ymax; e++)
    fprintf(f, "<line x1=\"%d\" x2=\"%d\" y1=\"%.1f\" y2=\"%.1f\" stroke=\"#eee\"/><text x=\"%d\" y=\"%.1f\" "
               "font-size=\"10\" text-anchor=\"end\">1e%d</text>\n",
            L, PW - R, PY(e), PY(e), L - 4, PY(e) + 3, e);
  for (int e = (int)xmin; e <= (int)xmax; e++)
    fprintf(f, "<text x=\"%.1f\" y=\"%d\" font-size=\"10\" text-anchor=\"middle\">1e%d</text>\n", PX(e), PH - B + 14, e);
  fprintf(f, "<text x=\"%d\" y=\"%d\" font-size=\"11\" text-anchor=\"middle\">triangles (log scale)</text>\n",
          L + (PW - L - R) / 2, PH - 10);
  fprintf(f, "<text x=\"12\" y=\"%d\" font-size=\"11\" text-anchor=\"middle\" transform=\"rotate(-90 12 %d)\">"
             "mean over views (log scale)</text>\n", T + (PH - T - B) / 2, T + (PH - T - B) / 2);
  static const char *colours[] = {"#d62728", "#1f77b4", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#17becf"};
  int nf = 0;
  for (int m = 0; m < s->num_methods && m < 64; m++) {
    int first = 1;
    for (int j = 0; j < m; j++) first &= strcmp(s->methods[j].family, s->methods[m].family) != 0;
    if (!first) continue;
    const char *col = colours[nf % 7];
    int idx[64], np = 0;
    for (int j = 0; j < s->num_methods && j < 64; j++)
      if (count[j] && x[j] >= 1 && !strcmp(s->methods[j].family, s->methods[m].family)) idx[np++] = j;
    for (int a = 1; a < np; a++)
      for (int b = a; b > 0 && x[idx[b]] < x[idx[b - 1]]; b--) {
        int t = idx[b];
        idx[b] = idx[b - 1], idx[b - 1] = t;
      }
    fprintf(f, "<polyline fill=\"none\" stroke=\"%s\" stroke-width=\"1.5\" points=\"", col);
    for (int a = 0; a < np; a++)
      fprintf(f, "%.1f,%.1f ", PX(log10(x[idx[a]])), PY(mean[idx[a]] > 0 ? fmax(log10(mean[idx[a]]), floor_y) : floor_y));
    fputs("\"/>\n", f);
    for (int a = 0; a < np; a++)
      fprintf(f, "<circle r=\"3\" fill=\"%s\" cx=\"%.1f\" cy=\"%.1f\"><title>%s: %.0f triangles, mean %.4g</title></circle>\n",
              col, PX(log10(x[idx[a]])), PY(mean[idx[a]] > 0 ? fmax(log10(mean[idx[a]]), floor_y) : floor_y),
              s->methods[idx[a]].name, x[idx[a]], mean[idx[a]]);
    fprintf(f, "<text x=\"%d\" y=\"%d\" font-size=\"11\" fill=\"%s\">%s</text>\n", PW - R + 8, T + 12 + 14 * nf, col,
            s->methods[m].family);
    nf++;
  }
#undef PX
#undef PY
  fprintf(f, "<text x=\"%d\" y=\"%d\" font-size=\"9\" fill=\"#666\">0 is drawn on the bottom axis</text>\n", L + 4,
          PH - B - 4);
  fputs("</svg>\n", f);
}

ch_status ch_report_index(const char *dir, const ch_scene *s, const ch_study_row *rows, int nrows,
                          const ch_report_info *info, ch_error *err) {
  const char *command = info->command, *scene_path = info->scene_path;
  const char *scene_text = info->scene_text ? info->scene_text : "";
  char path[4096];
  snprintf(path, sizeof path, "%s/index.html", dir);
  ch_atomic_file af;
  ch_status st = ch_atomic_open(&af, path, err);
  if (st) return st;
  FILE *f = af.fp;
  int bar_ids = 0; /* the colour bars' gradients, cb1, cb2, ... */
  fputs("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>chisel study</title>\n"
        "<style>body{font-family:sans-serif;margin:1.5em;color:#222}table{border-collapse:collapse;font-size:13px}"
        "td,th{border:1px solid #ccc;padding:3px 6px;text-align:right}th{background:#eee}td.l{text-align:left}"
        "figure{display:inline-block;margin:4px;text-align:center;font-size:12px}figure img{display:block;"
        "image-rendering:pixelated}figure.wide{display:block}figure.wide img{max-width:100%}"
        ".plot{margin:6px;background:#fff}.bar{display:block;margin:2px auto}pre{background:#f6f6f6;padding:6px;"
        "font-size:12px;max-height:16em;overflow:auto}</style></head><body>\n",
        f);
  fputs("<h1>chisel study</h1>\n", f);
  /* What made the report: a published figure needs them. The date is
   * SOURCE_DATE_EPOCH when set (reproducible builds' convention), so a
   * rerun can give the same bytes. */
  {
    char date[64] = "unknown";
    const char *sde = getenv("SOURCE_DATE_EPOCH");
    time_t now = sde && *sde ? (time_t)strtoll(sde, NULL, 10) : time(NULL);
    struct tm tmv;
    if (gmtime_r(&now, &tmv)) strftime(date, sizeof date, "%Y-%m-%d %H:%M:%S UTC", &tmv);
    fprintf(f, "<p>chisel %s, %s. Command: <code>", CH_VERSION_STRING, date);
    html_text(f, command);
    fputs("</code>. Scene <code>", f);
    html_text(f, scene_path);
    fputs("</code>:</p>\n<pre>", f);
    html_text(f, scene_text);
    fputs("</pre>\n<p>Curves <code>", f);
  }
  html_text(f, s->curves_path);
  fprintf(f,
          "</code> over the planar base; truth: Embree, exact h of docs/spec.md §3 (bounds grid %d, step DCI %d). Classes: "
          "top, groove wall, groove floor, step wall. Depth error relative to the scene's diagonal; SSIM of the "
          "shading (1 = same).</p>\n",
          s->truth_grid, s->dci_resolution);
  fputs("<h2>Summary</h2>\n<table><tr><th>view</th><th>method</th><th>triangles</th><th>class %</th>"
        "<th>in grooves %</th><th>groove id %</th><th>depth</th><th>normal mean °</th><th>normal p95 °</th>"
        "<th>shade RMSE</th><th>SSIM</th><th>shadow %</th></tr>\n",
        f);
  for (int i = 0; i < nrows; i++) {
    const ch_metrics *m = &rows[i].m;
    fprintf(f,
            "<tr><td class=\"l\">%s</td><td class=\"l\">%s</td><td>%ld</td><td>%.4f</td><td>%.4f</td><td>%.4f</td>"
            "<td>%.3e</td><td>%.3f</td><td>%.3f</td><td>%.4f</td><td>%.5f</td><td>%.4f</td></tr>\n",
            s->views[rows[i].view].name, s->methods[rows[i].method].name, rows[i].triangles, m->class_mismatch,
            m->class_mismatch_groove, m->id_mismatch, m->depth_error, m->normal_mean_deg, m->normal_p95_deg,
            m->shade_rmse, m->shade_ssim, m->shadow_mismatch);
  }
  fputs("</table>\n<p>Also as <a href=\"summary.csv\">summary.csv</a> and <a href=\"summary.json\">summary.json</a>."
        "</p>\n",
        f);
  /* Over the views: the mean a paper quotes and the worst view beside it. */
  fprintf(f, "<h2>Over the %d views: mean (worst)</h2>\n<table><tr><th>method</th><th>triangles</th><th>class %%</th>"
             "<th>in grooves %%</th><th>depth / scene</th><th>normal p95 °</th><th>SSIM</th></tr>\n",
          s->num_views);
  for (int m = 0; m < s->num_methods; m++) {
    double sum[5] = {0}, worst[5] = {0, 0, 0, 0, 1};
    long tris = 0;
    int n = 0;
    for (int i = 0; i < nrows; i++) {
      if (rows[i].method != m) continue;
      for (int k = 0; k < 5; k++) {
        double v = row_metric(&rows[i], k);
        sum[k] += v;
        worst[k] = k == 4 ? fmin(worst[k], v) : fmax(worst[k], v);
      }
      tris = rows[i].triangles;
      n++;
    }
    if (!n) continue;
    fprintf(f, "<tr class=\"over\"><td class=\"l\">");
    html_text(f, s->methods[m].name);
    fprintf(f, "</td><td>%ld</td>", tris);
    for (int k = 0; k < 5; k++)
      fprintf(f, k == 2 ? "<td>%.3e (%.3e)</td>" : k == 4 ? "<td>%.5f (%.5f)</td>" : "<td>%.4f (%.4f)</td>", sum[k] / n,
              worst[k]);
    fputs("</tr>\n", f);
  }
  fputs("</table>\n<div>\n", f);
  if (s->num_methods > 0) {
    html_summary_plot(f, s, rows, nrows, 3, "normal error p95 (degrees) against triangles");
    html_summary_plot(f, s, rows, nrows, 1, "class mismatch in grooves (%) against triangles");
    html_summary_plot(f, s, rows, nrows, 2, "depth error / scene size against triangles");
  }
  fputs("</div>\n", f);
  for (int v = 0; v < s->num_views; v++) {
    const char *vn = s->views[v].name;
    fprintf(f, "<h2>View %s</h2>\n<div>\n", vn);
    if (s->num_methods > 0) {
      html_plot(f, s, rows, nrows, v, "class mismatch in grooves (%)", 0);
      html_plot(f, s, rows, nrows, v, "normal error p95 (degrees)", 1);
      html_plot(f, s, rows, nrows, v, "depth error / scene size", 2);
    }
    fprintf(f, "</div>\n<div><figure class=\"wide\"><img src=\"%s.montage.png\" alt=\"montage\">truth", vn);
    for (int m = 0; m < s->num_methods; m++) fprintf(f, " | %s", s->methods[m].name);
    fprintf(f, "</figure></div>\n<div><figure><img src=\"%s.truth.png\" alt=\"truth\">truth</figure>"
               "<figure><img src=\"%s.truth.class.png\" alt=\"truth classes\">truth classes</figure></div>\n",
            vn, vn);
    for (int m = 0; m < s->num_methods; m++) {
      const char *mn = s->methods[m].name;
      fprintf(f, "<div><figure><img src=\"%s.%s.png\" alt=\"%s\">%s</figure>", vn, mn, mn, mn);
      fprintf(f, "<figure><img src=\"%s.%s.class.png\" alt=\"class mismatch\"><svg class=\"bar\" width=\"170\" "
                 "height=\"40\"><rect x=\"5\" y=\"2\" width=\"10\" height=\"10\" fill=\"#e61414\"/><text x=\"20\" "
                 "y=\"11\" font-size=\"10\">class differs from the truth</text></svg>class mismatch</figure>",
              vn, mn);
      fprintf(f, "<figure><img src=\"%s.%s.normal.png\" alt=\"normal error\">", vn, mn);
      html_colorbar(f, &bar_ids, 0.0, 20.0, "degrees");
      fprintf(f, "normal error (black: not seen by both)</figure><figure><img src=\"%s.%s.depth.png\" alt=\"depth error\">",
              vn, mn);
      html_colorbar(f, &bar_ids, 0.0, 1.0, "% of the scene's diagonal");
      fputs("depth error</figure></div>\n", f);
    }
  }
  fputs("</body></html>\n", f);
  st = ch_atomic_commit(&af, err);
  return st;
}
