/* chisel study: every method against the Embree-traced truth, per view
 * (docs/spec.md, docs/cli.md). The scene file format is documented in `usage` below. */
#define _POSIX_C_SOURCE 200809L
#include <cjson/cJSON.h>
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <omp.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "ch_curves.h"
#include "ch_exr.h"
#include "ch_featshade.h"
#include "ch_file.h"
#include "ch_gtex.h"
#include "ch_height.h"
#include "ch_math.h"
#include "ch_mesh.h"
#include "ch_metrics.h"
#include "ch_png.h"
#include "ch_relief.h"
#include "ch_render.h"
#include "ch_scene.h"
#include "ch_texray.h"
#include "ch_trace.h"
#include "ch_version.h"
#include "ch_truth.h"
#include "cli.h"


static const char usage[] =
    "usage: chisel study SCENE.json -o DIR\n"
    "\n"
    "Renders the true surface of the scene's curves over the planar base\n"
    "(u, v, 0) (Embree, independent of the tessellator) and every method's mesh\n"
    "from every view, and compares them pixel by pixel: visibility class\n"
    "(top, groove wall, groove floor, step wall), groove id, depth, normal,\n"
    "shading and shadows.\n"
    "\n"
    "SCENE.json (relative paths are taken from the scene file's folder):\n"
    "  {\n"
    "    \"curves\": \"curves.svg\",        required: the feature curves (SPEC 2)\n"
    "    \"dci_resolution\": 1024,        optional: the step DCI, 16..16384\n"
    "    \"truth_grid\": 512,             optional: the truth's bounds grid, a\n"
    "                                   multiple of 16 in 16..16384\n"
    "    \"light\": {\"direction\": [x, y, z], \"ambient\": 0.15, \"albedo\": 0.75,\n"
    "              \"specular\": 0.25, \"shininess\": 40},      optional, any subset\n"
    "    \"views\": [                      required, at least one\n"
    "      {\"name\": \"top\", \"eye\": [x, y, z], \"target\": [x, y, z],\n"
    "       \"up\": [0, 0, 1], \"fov\": 40, \"width\": 320, \"height\": 240,\n"
    "       \"supersample\": 2},            up, fov (degrees), supersample optional;\n"
    "                                   \"ortho_height\": h instead of fov: orthographic;\n"
    "                                   \"orbit\": n (1..64) makes n views NAME_0..NAME_n-1,\n"
    "                                   the eye turned about the vertical through the\n"
    "                                   target in steps of 360/n degrees\n"
    "    ],\n"
    "    \"methods\": [                    optional\n"
    "      {\"name\": \"snapped\", \"mesh\": \"snapped.obj\"}   OBJ/PLY/OFF/STL with UVs\n"
    "      {\"name\": \"normalmap\", \"mesh\": \"plane.obj\", \"shader\": \"exact-normals\"}\n"
    "                                   optional \"family\": methods of one family\n"
    "                                   (e.g. one method at several triangle counts)\n"
    "                                   are one line in the report's plots\n"
    "                                   a texture-space method on the base mesh:\n"
    "                                   exact-normals = the truth's normal at the\n"
    "                                   hit's UV (a perfect normal map)\n"
    "      {\"name\": \"fn\", \"mesh\": \"plane.obj\", \"shader\": \"featnorm\", \"resolution\": 256}\n"
    "                                   normals from maps built from the curves at\n"
    "                                   R x R (R in 4..4096): featnorm,\n"
    "                                   featnorm-linear (feature-curve textures),\n"
    "                                   normal-bilinear (a conventional normal map\n"
    "                                   of h), msdf (a multi-channel distance field\n"
    "                                   with the grooves' profiles)\n"
    "      {\"name\": \"g\", \"mesh\": \"plane.obj\", \"shader\": \"grooves\", \"resolution\": 128}\n"
    "                                   path-based groove textures on a G x G grid\n"
    "                                   (G in 1..4096; grooves only: a step curve is\n"
    "                                   an error), traced per ray in texture space,\n"
    "                                   walls and shadows included; \"paper\": true\n"
    "                                   intersects curved pieces as the paper does\n"
    "      {\"name\": \"r\", \"mesh\": \"plane.obj\", \"shader\": \"relief\", \"resolution\": 1024,\n"
    "       \"steps\": 32}                relief mapping (linear + binary search) on an\n"
    "                                   R x R height texture of h (R in 2..16384, as\n"
    "                                   chisel sample bakes it), K linear steps\n"
    "                                   (1..4096, default 32); \"pom\": parallax\n"
    "                                   occlusion mapping (K..K/4 steps by view angle)\n"
    "    ]\n"
    "  }\n"
    "Names are letters, digits, '-' and '_' (they name files), unique per list.\n"
    "\n"
    "Writes into DIR (created if missing), per view V and method M:\n"
    "  V.truth.exr, V.M.exr     all render layers (shade, shadow, depth, N, P, uv,\n"
    "                           class, id, coverage)\n"
    "  V.truth.png, V.M.png     the shading\n"
    "  V.truth.class.png        classes: top grey, groove wall orange, floor blue,\n"
    "                           step wall green, nothing black\n"
    "  V.M.class.png            pixels whose class differs from the truth's in red\n"
    "  V.M.normal.png           normal error, heat map 0..20 degrees\n"
    "  V.M.depth.png            depth error, heat map 0..1% of the scene size\n"
    "  V.montage.png            truth and methods' shading side by side\n"
    "  index.html               the report: table, images, error against triangles\n"
    "  summary.csv, summary.json  one row per view and method: class mismatch %\n"
    "                           (all pixels, groove pixels), groove id mismatch %,\n"
    "                           depth error / scene size, normal error mean and\n"
    "                           p95 (degrees), shading RMSE and SSIM, shadow mismatch %\n"
    "On failure nothing is left in DIR. Prints the bytes of each texture\n"
    "method's textures, then the table (Mrays/s: primary and shadow rays).\n"
    "\n"
    "  -o, --output DIR   the output folder (required)\n";

/* What run() builds per method of the scene. */
typedef struct method_run {
  ch_featshade fs;
  ch_texray *tr;
  ch_mesh mesh;
  ch_trace *scene;
} method_run;

typedef ch_scene study;

typedef struct written {
  char **paths;
  int count, cap;
} written;

static int written_add(written *w, const char *path) {
  if (w->count == w->cap) {
    int cap = w->cap ? 2 * w->cap : 32;
    char **p = realloc(w->paths, (size_t)cap * sizeof *p);
    if (!p) return 0;
    w->paths = p;
    w->cap = cap;
  }
  if (!(w->paths[w->count] = strdup(path))) return 0;
  w->count++;
  return 1;
}

static void written_free(written *w, int remove_files) {
  for (int i = 0; i < w->count; i++) {
    if (remove_files) remove(w->paths[i]);
    free(w->paths[i]);
  }
  free(w->paths);
  memset(w, 0, sizeof *w);
}


/* ---- images ---- */

static uint8_t to8(double x) { return (uint8_t)lround(255.0 * pow(ch_clamp(x, 0.0, 1.0), 1.0 / 2.2)); }

typedef enum picture { PIC_SHADE, PIC_CLASSES, PIC_CLASS_DIFF, PIC_NORMAL, PIC_DEPTH } picture;

static ch_status write_png(const char *path, picture what, const ch_image *img, const ch_image *truth,
                           double scene_size, written *w, ch_error *err) {
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
    case PIC_SHADE: o[0] = o[1] = o[2] = to8(shade[p]); break;
    case PIC_CLASSES: memcpy(o, class_rgb[(int)cls[p] % CH_VIS_COUNT], 3); break;
    case PIC_CLASS_DIFF:
      if (cls[p] != tcls[p]) {
        o[0] = 230, o[1] = 20, o[2] = 20;
      } else {
        o[0] = o[1] = o[2] = to8(0.6 * tshade[p]);
      }
      break;
    case PIC_NORMAL:
    case PIC_DEPTH: {
      if (!both) {
        o[0] = o[1] = o[2] = 0;
        break;
      }
      double x;
      if (what == PIC_NORMAL) {
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
  if (!st && !written_add(w, path)) st = ch_error_set(err, CH_ERR_NOMEM, "out of memory");
  return st;
}

static ch_status write_exr(const char *path, const ch_image *img, const char *viewname, const char *methodname,
                           written *w, ch_error *err) {
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
  if (!st && !written_add(w, path)) st = ch_error_set(err, CH_ERR_NOMEM, "out of memory");
  return st;
}

/* ---- the run ---- */

typedef struct row {
  int view, method;
  long triangles;
  ch_metrics m;
  long rays;
  double seconds;
} row;

static ch_status write_summaries(const char *dir, const study *s, const row *rows, int nrows, written *w, ch_error *err) {
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
  if (!written_add(w, path)) return ch_error_set(err, CH_ERR_NOMEM, "out of memory");

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
  if (!st && !written_add(w, path)) st = ch_error_set(err, CH_ERR_NOMEM, "out of memory");
  return st;
}

/* Truth and methods' shading side by side, 4 black pixels apart. */
static ch_status write_montage(const char *path, const ch_image *const *imgs, int n, written *w, ch_error *err) {
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
  if (!st && !written_add(w, path)) st = ch_error_set(err, CH_ERR_NOMEM, "out of memory");
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
static void html_plot(FILE *f, const study *s, const row *rows, int nrows, int v, const char *title, int which) {
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
    const row *pts[64];
    int np = 0;
    for (int i = 0; i < nrows && np < 64; i++)
      if (rows[i].view == v && rows[i].triangles > 0 && !strcmp(s->methods[rows[i].method].family, s->methods[m].family))
        pts[np++] = &rows[i];
    for (int a = 1; a < np; a++)
      for (int b = a; b > 0 && pts[b]->triangles < pts[b - 1]->triangles; b--) {
        const row *t = pts[b];
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
static void html_colorbar(FILE *f, double lo, double hi, const char *unit) {
  static int id = 0;
  id++;
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
static double row_metric(const row *r, int which) {
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
static void html_summary_plot(FILE *f, const study *s, const row *rows, int nrows, int which, const char *title) {
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

static ch_status write_index(const char *dir, const study *s, const row *rows, int nrows, const char *command,
                             const char *scene_path, const char *scene_text, written *w, ch_error *err) {
  char path[4096];
  snprintf(path, sizeof path, "%s/index.html", dir);
  ch_atomic_file af;
  ch_status st = ch_atomic_open(&af, path, err);
  if (st) return st;
  FILE *f = af.fp;
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
      html_colorbar(f, 0.0, 20.0, "degrees");
      fprintf(f, "normal error (black: not seen by both)</figure><figure><img src=\"%s.%s.depth.png\" alt=\"depth error\">",
              vn, mn);
      html_colorbar(f, 0.0, 1.0, "% of the scene's diagonal");
      fputs("depth error</figure></div>\n", f);
    }
  }
  fputs("</body></html>\n", f);
  st = ch_atomic_commit(&af, err);
  if (!st && !written_add(w, path)) st = ch_error_set(err, CH_ERR_NOMEM, "out of memory");
  return st;
}

/* Every file the study writes into dir (as run() names them), checked
 * against its inputs and each other before any work (cli_check_files);
 * nothing to check while dir does not exist. 0 or the exit status. */
static int check_outputs(const char *cmd, const char *scene_path, const study *s, const char *dir) {
  struct stat sb;
  if (stat(dir, &sb) != 0 || !S_ISDIR(sb.st_mode)) return 0;
  static const char *const truth_files[] = {"truth.exr", "truth.png", "truth.class.png", "montage.png"};
  static const char *const method_files[] = {"exr", "png", "class.png", "normal.png", "depth.png"};
  static const char *const study_files[] = {"summary.csv", "summary.json", "index.html"};
  int per_view = 4 + 5 * s->num_methods, n = s->num_views * per_view + 3, k = 0;
  cli_file *outs = calloc((size_t)n, sizeof *outs);
  cli_file *ins = calloc((size_t)s->num_methods + 2, sizeof *ins);
  char *names = malloc((size_t)n * 4096);
  if (!outs || !ins || !names) {
    free(outs);
    free(ins);
    free(names);
    fprintf(stderr, "chisel: out of memory\n");
    return 1;
  }
  for (int v = 0; v < s->num_views; v++) {
    for (int i = 0; i < 4; i++, k++)
      snprintf(names + (size_t)k * 4096, 4096, "%s/%s.%s", dir, s->views[v].name, truth_files[i]);
    for (int m = 0; m < s->num_methods; m++)
      for (int i = 0; i < 5; i++, k++)
        snprintf(names + (size_t)k * 4096, 4096, "%s/%s.%s.%s", dir, s->views[v].name, s->methods[m].name,
                 method_files[i]);
  }
  for (int i = 0; i < 3; i++, k++) snprintf(names + (size_t)k * 4096, 4096, "%s/%s", dir, study_files[i]);
  for (int i = 0; i < n; i++) outs[i] = (cli_file){names + (size_t)i * 4096, names + (size_t)i * 4096};
  int ni = 0;
  ins[ni++] = (cli_file){"SCENE.json", scene_path};
  ins[ni++] = (cli_file){"curves", s->curves_path};
  for (int m = 0; m < s->num_methods; m++) ins[ni++] = (cli_file){s->methods[m].name, s->methods[m].path};
  int rc = cli_check_files(cmd, ins, ni, outs, n);
  free(outs);
  free(ins);
  free(names);
  return rc;
}

static int run(int argc, char **argv) {
  const char *cmd = "study";
  const char *scene_path = NULL, *dir = NULL;
  for (int i = 1; i < argc; i++) {
    const char *a = argv[i];
    if (!strcmp(a, "-o") || !strcmp(a, "--output")) {
      if (!(dir = cli_option_value(cmd, argc, argv, &i))) return 2;
    } else if (a[0] == '-' && a[1]) {
      return cli_usage_error(cmd, "unknown option '%s'", a);
    } else if (!scene_path) {
      scene_path = a;
    } else {
      return cli_usage_error(cmd, "unexpected argument '%s'", a);
    }
  }
  if (!scene_path) return cli_usage_error(cmd, "missing the scene file SCENE.json");
  if (!dir || !dir[0]) return cli_usage_error(cmd, "missing -o DIR");
  if (strlen(dir) > 3000) return cli_usage_error(cmd, "-o: path too long");

  ch_error err = cli_error();
  char *text = NULL;
  size_t size;
  study s;
  ch_curve_set set = {0};
  ch_height height = {0};
  ch_truth *truth = NULL;
  ch_trace *truth_scene = NULL;
  written w = {0};
  row *rows = NULL;
  int nrows = 0, made_dir = 0;
  if (ch_file_read_all(scene_path, 16 << 20, &text, &size, &err)) return cli_fail(&err);
  ch_status st = ch_scene_parse(scene_path, text, &s, &err);
  char *scene_text = text; /* kept for the report */
  if (st) {
    free(scene_text);
    return cli_fail(&err);
  }
  /* The command as typed (quoted where a shell would need it), for the report. */
  char command[4096];
  size_t clen = (size_t)snprintf(command, sizeof command, "chisel");
  int typed = cli_argv != NULL; /* as typed (with -q, -j), else as parsed */
  for (int i = typed ? 1 : 0; i < (typed ? cli_argc : argc) && clen < sizeof command; i++) {
    const char *a = typed ? cli_argv[i] : argv[i];
    int plain = a[0] != '\0';
    for (const char *c = a; *c; c++)
      if (!strchr("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789-_./=,:+@%", *c)) plain = 0;
    clen += (size_t)snprintf(command + clen, sizeof command - clen, plain ? " %s" : " '%s'", a);
  }
  int rc = check_outputs(cmd, scene_path, &s, dir);
  method_run *mr = rc ? NULL : calloc((size_t)s.num_methods + 1, sizeof *mr);
  if (!rc && !mr) rc = (fprintf(stderr, "chisel: out of memory\n"), 1);
  if (rc) {
    free(scene_text);
    ch_scene_free(&s);
    return rc;
  }
  double t_start = omp_get_wtime();
  /* Every input is read and checked before anything is written. */
  ch_height_desc hd = {.dci_resolution = s.dci_resolution, .step_method = CH_RECON_EXACT};
  ch_truth_desc td = {.grid = s.truth_grid};
  st = ch_curves_read_svg(s.curves_path, &set, &err);
  if (!st) st = ch_height_init(&height, &set, &hd, &err);
  for (int i = 0; !st && i < s.num_methods; i++) {
    const ch_scene_method *m = &s.methods[i];
    method_run *r = &mr[i];
    st = ch_mesh_read(m->path, &r->mesh, &err);
    if (!st) st = ch_trace_create_mesh(&r->mesh, m->path, &r->scene, &err);
    if (!st && m->textured) {
      ch_error terr = cli_error();
      ch_texray_desc tex = m->tex;
      /* Relief and POM at one resolution read one map: bake it once. */
      for (int j = 0; j < i && tex.kind != CH_TEXRAY_GROOVES; j++)
        if (s.methods[j].textured && s.methods[j].tex.kind != CH_TEXRAY_GROOVES &&
            s.methods[j].tex.resolution == tex.resolution)
          tex.same_map = mr[j].tr;
      st = ch_texray_create(&tex, &set, &height, s.curves_path, &r->tr, &terr);
      if (st) ch_error_set(&err, st, "%s: methods[%d] ('%s'): %s", scene_path, i, m->name, terr.message);
      else
        printf("texture method %s: %s at %d, %zu bytes\n", m->name,
               m->tex.kind == CH_TEXRAY_GROOVES ? "grooves" : m->tex.kind == CH_TEXRAY_RELIEF ? "relief" : "pom",
               m->tex.resolution, ch_texray_bytes(r->tr));
    }
  }
  for (int i = 0; !st && i < s.num_methods; i++)
    if (s.methods[i].featshade >= 0)
      st = ch_featshade_init(&mr[i].fs, (ch_featshade_method)s.methods[i].featshade, s.methods[i].resolution,
                             &set, &height, &err);
  if (!st) st = ch_truth_create(&height, &td, &truth, &err);
  if (!st) st = ch_trace_create_truth(truth, &truth_scene, &err);
  if (!st) {
    struct stat sb;
    if (stat(dir, &sb) == 0) {
      if (!S_ISDIR(sb.st_mode)) st = ch_error_set(&err, CH_ERR_IO, "%s: exists and is not a folder", dir);
    } else if (mkdir(dir, 0777) == 0) {
      made_dir = 1;
    } else {
      st = ch_error_set(&err, CH_ERR_IO, "%s: cannot create the folder: %s", dir, strerror(errno));
    }
    if (!st && access(dir, W_OK) != 0)
      st = ch_error_set(&err, CH_ERR_IO, "%s: cannot write into the folder: %s", dir, strerror(errno));
  }
  rows = calloc((size_t)(s.num_views * s.num_methods + 1), sizeof *rows);
  if (!st && !rows) st = ch_error_set(&err, CH_ERR_NOMEM, "out of memory");
  double tb[6];
  if (!st) ch_trace_bounds(truth_scene, tb);
  double scene_size = st ? 1.0 : sqrt(1.0 + 1.0 + (tb[5] - tb[2]) * (tb[5] - tb[2]));
  int progress = isatty(2) && !cli_quiet;
  char path[4096];
  for (int v = 0; !st && v < s.num_views; v++) {
    const ch_scene_view *vw = &s.views[v];
    ch_image timg = {0};
    ch_render_stats rs;
    st = ch_render(truth_scene, truth, &vw->camera, &s.light, &timg, &rs, &err);
    if (!st && progress)
      fprintf(stderr, "study: %s: truth, %ld rays in %.2f s\n", vw->name, rs.primary_rays + rs.shadow_rays, rs.seconds);
    if (!st) snprintf(path, sizeof path, "%s/%s.truth.exr", dir, vw->name), st = write_exr(path, &timg, vw->name, "truth", &w, &err);
    if (!st) snprintf(path, sizeof path, "%s/%s.truth.png", dir, vw->name), st = write_png(path, PIC_SHADE, &timg, NULL, scene_size, &w, &err);
    if (!st)
      snprintf(path, sizeof path, "%s/%s.truth.class.png", dir, vw->name),
          st = write_png(path, PIC_CLASSES, &timg, NULL, scene_size, &w, &err);
    ch_image *imgs = calloc((size_t)s.num_methods + 1, sizeof *imgs);
    if (!imgs) st = ch_error_set(&err, CH_ERR_NOMEM, "out of memory");
    for (int m = 0; !st && m < s.num_methods; m++) {
      const ch_scene_method *mt = &s.methods[m];
      const method_run *mrt = &mr[m];
      ch_image *img = &imgs[m + 1];
      row *r = &rows[nrows];
      ch_render_shader sh = mt->featshade >= 0 ? ch_featshade_shader(&mrt->fs)
                            : mt->textured      ? ch_texray_shader(mrt->tr)
                                                : ch_shader_exact_normals(truth);
      st = ch_render_shaded(mrt->scene, mt->exact_normals || mt->textured || mt->featshade >= 0 ? &sh : NULL, truth,
                            &vw->camera, &s.light, img, &rs, &err);
      if (!st) st = ch_metrics_compare(img, &timg, scene_size, &r->m, &err);
      if (!st) {
        r->view = v, r->method = m, r->rays = rs.primary_rays + rs.shadow_rays, r->seconds = rs.seconds;
        r->triangles = ch_trace_triangles(mrt->scene);
        nrows++;
        if (progress)
          fprintf(stderr, "study: %s: %s, class mismatch %.3f%%, normal p95 %.2f deg\n", vw->name, mt->name,
                  r->m.class_mismatch, r->m.normal_p95_deg);
      }
      static const struct {
        const char *suffix;
        picture what;
      } pics[] = {{"png", PIC_SHADE}, {"class.png", PIC_CLASS_DIFF}, {"normal.png", PIC_NORMAL}, {"depth.png", PIC_DEPTH}};
      if (!st) snprintf(path, sizeof path, "%s/%s.%s.exr", dir, vw->name, mt->name), st = write_exr(path, img, vw->name, mt->name, &w, &err);
      for (int k = 0; !st && k < 4; k++) {
        snprintf(path, sizeof path, "%s/%s.%s.%s", dir, vw->name, mt->name, pics[k].suffix);
        st = write_png(path, pics[k].what, img, &timg, scene_size, &w, &err);
      }
    }
    if (!st) {
      const ch_image *list[64];
      int nl = 0;
      list[nl++] = &timg;
      for (int m = 0; m < s.num_methods && nl < 64; m++) list[nl++] = &imgs[m + 1];
      snprintf(path, sizeof path, "%s/%s.montage.png", dir, vw->name);
      st = write_montage(path, list, nl, &w, &err);
    }
    for (int m = 0; imgs && m < s.num_methods; m++) ch_image_free(&imgs[m + 1]);
    free(imgs);
    ch_image_free(&timg);
  }
  if (!st) st = write_summaries(dir, &s, rows, nrows, &w, &err);
  if (!st) st = write_index(dir, &s, rows, nrows, command, scene_path, scene_text ? scene_text : "", &w, &err);
  if (!st) {
    printf("%-12s %-12s %9s %9s %9s %10s %9s %9s %9s %9s %9s %8s\n", "view", "method", "class%", "groove%", "id%",
           "depth", "n_mean", "n_p95", "shade", "ssim", "shadow%", "Mrays/s");
    for (int i = 0; i < nrows; i++) {
      const ch_metrics *m = &rows[i].m;
      printf("%-12s %-12s %9.4f %9.4f %9.4f %10.3e %9.3f %9.3f %9.4f %9.5f %9.4f %8.2f\n",
             s.views[rows[i].view].name, s.methods[rows[i].method].name, m->class_mismatch, m->class_mismatch_groove,
             m->id_mismatch, m->depth_error, m->normal_mean_deg, m->normal_p95_deg, m->shade_rmse, m->shade_ssim,
             m->shadow_mismatch, rows[i].seconds > 0 ? rows[i].rays / rows[i].seconds * 1e-6 : 0.0);
    }
  }
  if (!st)
    cli_result("wrote %s/index.html and %d files (%d views x %d methods) in %.1f s", dir, w.count - 1, s.num_views,
               s.num_methods, omp_get_wtime() - t_start);
  free(scene_text);
  written_free(&w, 0); /* staged (cli_run): on failure they are removed, previous files kept */
  if (st) ch_file_stage_abort(); /* before the folder it made goes */
  if (st && made_dir) rmdir(dir);
  free(rows);
  ch_trace_destroy(truth_scene);
  ch_truth_destroy(truth);
  ch_height_free(&height);
  ch_curves_free(&set);
  for (int i = 0; i < s.num_methods; i++) {
    ch_trace_destroy(mr[i].scene);
    ch_featshade_free(&mr[i].fs);
    ch_texray_destroy(mr[i].tr);
    ch_mesh_free(&mr[i].mesh);
  }
  free(mr);
  ch_scene_free(&s);
  return st ? cli_fail(&err) : 0;
}

const cli_command cli_study_command = {
    "study", "meshes and texture methods (groove textures, relief mapping) against the Embree-traced true surface",
    usage, run};
