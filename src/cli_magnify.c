/* chisel magnify: a zoomed crop rendered from R-sized maps alone: a DCI
 * (diffusion-curves-on-surfaces, Figure 5, as a command) or feature maps
 * (feature-curves-textures, normal-maps-discontinuities, and the baselines
 * stored beside them). */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ch_curves.h"
#include "ch_dci.h"
#include "ch_exr.h"
#include "ch_featmap.h"
#include "ch_msdf.h"
#include "ch_png.h"
#include "ch_recon.h"
#include "ch_pipeline.h"
#include "cli.h"

static const char usage[] =
    "usage: chisel magnify MAPS.exr --rect u0,v0,u1,v1 --out-res N -o CROP.(png|exr)\n"
    "                     [--method bilinear|recon5|recon3|exact|featnorm|featnorm-linear|\n"
    "                               normal-bilinear|msdf] [--curves CURVES.svg] [--no-aa]\n"
    "                     [--exr CROP.exr]\n"
    "\n"
    "Renders the UV rectangle at N pixels across (height in proportion), reading\n"
    "only the maps, laid out like `sample`'s images (row 0 at v1, pixel centres\n"
    "at u0 + (x+0.5)(u1-u0)/N, v1 - (y+0.5)(v1-v0)/N).\n"
    "\n"
    "A DCI written by `chisel dci`: bilinear interpolation, or the feature\n"
    "reconstruction of the 5x5 or 3x3 neighbourhood, which keeps curves crisp at\n"
    "any magnification; `exact` takes the side from the vector curves (--curves)\n"
    "for comparison. Colour DCIs give colour, others h in false colour (blue low,\n"
    "red high, scaled by the DCI's range).\n"
    "\n"
    "Feature maps written by `chisel featmap`: the normal, lit from the upper\n"
    "left (the study's light), by featnorm (quadratic pieces, curvilinear\n"
    "triangles, the profiles blended in by eq. (1)), featnorm-linear (straight\n"
    "pieces), normal-bilinear (the conventional normal map, bilinear) or msdf\n"
    "(the multi-channel distance field: median of three bilinear channels,\n"
    "with the profiles). With -o ending in .exr the crop's values instead of a\n"
    "picture: the normal N.X N.Y N.Z (unit, z up in UV space), d (signed\n"
    "distance to the nearest curve, UV, + on its left), side (+1 left, -1\n"
    "right) and curve; for a DCI, h (or R G B).\n"
    "\n"
    "  --rect u0,v0,u1,v1 the crop in UV (required)\n"
    "  --out-res N        pixels across, 1..16384 (required)\n"
    "  -o, --output FILE  the PNG (or EXR of values) to write (required)\n"
    "  --method M         DCI: bilinear, recon5 (default), recon3 or exact;\n"
    "                     feature maps: featnorm (default), featnorm-linear,\n"
    "                     normal-bilinear or msdf\n"
    "  --curves FILE      the curve file the DCI was made from (for exact)\n"
    "  --no-aa            no anti-aliasing of curve edges (paper §3.4)\n"
    "  --exr FILE         also write the crop's values as a float EXR (a DCI's h,\n"
    "                     and Y = 0.5 + h / (2 max |h|) for image viewers)\n"
    "  --fill-height H    with --curves: the height of filled shapes drawn without\n"
    "                     data- attributes (docs/svg.md; default 0.01)\n";

/* Feature-map methods: ch_featmap_method values, and msdf after them. */
enum { METHOD_MSDF = 16 };

static int feature_method(const char *name) {
  int m = ch_featmap_method_parse(name);
  if (m >= 0) return m;
  return !strcmp(name, "msdf") ? METHOD_MSDF : -1;
}

static int ends_with_exr(const char *path) {
  size_t n = strlen(path);
  return n >= 4 && (!strcmp(path + n - 4, ".exr") || !strcmp(path + n - 4, ".EXR"));
}

/* A crop of feature maps: the normals lit (PNG) and / or the values (EXR). */
static int run_featmap(const char *maps_path, int method, const double rect[4], int W, int H, const char *png,
                       const char *exr, double t_start) {
  ch_error err = cli_error();
  ch_featmap maps;
  ch_msdf msdf;
  if (ch_featmap_read_exr(maps_path, &maps, &msdf, &err)) return cli_fail(&err);
  ch_status st = CH_OK;
  if (method == METHOD_MSDF && !msdf.resolution)
    st = ch_error_set(&err, CH_ERR_INPUT, "%s: the maps hold no msdf layers", maps_path);
  if (!st && method == CH_FEATMAP_BILINEAR && !maps.has_normal)
    st = ch_error_set(&err, CH_ERR_INPUT, "%s: the maps hold no normal map (N.X N.Y N.Z)", maps_path);
  ch_image crop = {0};
  static const char *const names[] = {"N.X", "N.Y", "N.Z", "d", "side", "curve"};
  if (!st) st = ch_image_init(&crop, W, H, 6, names, &err);
  if (!st) {
    double px = (rect[2] - rect[0]) / W, py = (rect[3] - rect[1]) / H;
#pragma omp parallel for schedule(dynamic, 4)
    for (int y = 0; y < H; y++)
      for (int x = 0; x < W; x++) {
        ch_featmap_sample s;
        double u = rect[0] + (x + 0.5) * px, v = rect[3] - (y + 0.5) * py;
        if (method == METHOD_MSDF) ch_msdf_eval(&msdf, u, v, &s);
        else ch_featmap_eval(&maps, (ch_featmap_method)method, u, v, &s);
        size_t i = (size_t)y * W + x;
        for (int k = 0; k < 3; k++) ch_image_plane(&crop, k)[i] = (float)s.normal[k];
        ch_image_plane(&crop, 3)[i] = (float)(s.side * s.distance);
        ch_image_plane(&crop, 4)[i] = (float)s.side;
        ch_image_plane(&crop, 5)[i] = (float)s.curve;
      }
  }
  if (!st && png) {
    unsigned char *rgb = malloc((size_t)W * H * 3);
    if (!rgb) st = ch_error_set(&err, CH_ERR_NOMEM, "out of memory");
    for (size_t i = 0; !st && i < (size_t)W * H; i++) {
      double n[3] = {ch_image_plane(&crop, 0)[i], ch_image_plane(&crop, 1)[i], ch_image_plane(&crop, 2)[i]};
      rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = cli_lit_grey(n);
    }
    if (!st) st = ch_png_write(png, W, H, 3, rgb, &err);
    free(rgb);
  }
  if (!st && exr) {
    static const char *const methods[] = {"featnorm", "featnorm-linear", "normal-bilinear"};
    const ch_exr_attribute attrs[] = {{"chisel:command", "magnify"},
                                      {"chisel:method", method == METHOD_MSDF ? "msdf" : methods[method]}};
    ch_exr_write_desc wd = {.attributes = attrs, .num_attributes = 2};
    st = ch_exr_write(exr, &crop, &wd, &err);
  }
  if (!st)
    cli_result("wrote %s (%d x %d)%s%s in %.2f s", png ? png : exr, W, H, png && exr ? ", " : "",
               png && exr ? exr : "", omp_get_wtime() - t_start);
  ch_image_free(&crop);
  ch_msdf_free(&msdf);
  ch_featmap_free(&maps);
  return st ? cli_fail(&err) : 0;
}

static int run(int argc, char **argv) {
  const char *cmd = "magnify";
  const char *maps = NULL, *out = NULL, *curves = NULL, *exr = NULL;
  long out_res = 0;
  int method = CH_RECON_5X5, have_rect = 0, aa = 1, fmethod = -1;
  double rect[4];
  ch_svg_desc svg_desc = {0};
  for (int i = 1; i < argc; i++) {
    const char *a = argv[i];
    if (!strcmp(a, "--out-res")) {
      const char *v = cli_option_value(cmd, argc, argv, &i);
      if (!v || cli_parse_int(cmd, a, v, 1, 16384, &out_res)) return 2;
    } else if (!strcmp(a, "--rect")) {
      const char *v = cli_option_value(cmd, argc, argv, &i);
      if (!v || cli_parse_doubles(cmd, a, v, 4, rect)) return 2;
      have_rect = 1;
    } else if (!strcmp(a, "--method")) {
      const char *v = cli_option_value(cmd, argc, argv, &i);
      if (!v) return 2;
      if ((fmethod = feature_method(v)) < 0 && (method = ch_recon_method_parse(v)) < 0)
        return cli_usage_error(cmd,
                               "unknown method '%s' (bilinear, recon5, recon3, exact, featnorm, featnorm-linear, "
                               "normal-bilinear, msdf)",
                               v);
    } else if (!strcmp(a, "-o") || !strcmp(a, "--output")) {
      if (!(out = cli_option_value(cmd, argc, argv, &i))) return 2;
    } else if (!strcmp(a, "--curves")) {
      if (!(curves = cli_option_value(cmd, argc, argv, &i))) return 2;
    } else if (!strcmp(a, "--exr")) {
      if (!(exr = cli_option_value(cmd, argc, argv, &i))) return 2;
    } else if (!strcmp(a, "--no-aa")) {
      aa = 0;
    } else if (!strcmp(a, "--fill-height")) {
      const char *v = cli_option_value(cmd, argc, argv, &i);
      if (!v || cli_parse_fill_height(cmd, v, &svg_desc)) return 2;
    } else if (a[0] == '-' && a[1]) {
      return cli_usage_error(cmd, "unknown option '%s'", a);
    } else if (!maps) {
      maps = a;
    } else {
      return cli_usage_error(cmd, "unexpected argument '%s'", a);
    }
  }
  if (!maps) return cli_usage_error(cmd, "missing MAPS.exr");
  if (!have_rect) return cli_usage_error(cmd, "missing --rect u0,v0,u1,v1");
  if (!out_res) return cli_usage_error(cmd, "missing --out-res N");
  if (!out) return cli_usage_error(cmd, "missing -o CROP.png");
  if (!(rect[2] > rect[0] && rect[3] > rect[1])) return cli_usage_error(cmd, "--rect needs u0 < u1 and v0 < v1");
  if (method == CH_RECON_EXACT && !curves) return cli_usage_error(cmd, "--method exact needs --curves CURVES.svg");
  double aspect = (rect[3] - rect[1]) / (rect[2] - rect[0]);
  long out_h = lround(out_res * aspect);
  if (out_h < 1 || out_h > 16384) return cli_usage_error(cmd, "--rect and --out-res give %ld rows (1..16384)", out_h);
  if (cli_is_stdout(out)) return cli_refuse_stdout(cmd, "-o", "a PNG");
  if (cli_is_stdout(exr)) return cli_refuse_stdout(cmd, "--exr", "an EXR");
  const cli_file in_files[] = {{"MAPS.exr", maps}, {"--curves", curves}}, out_files[] = {{"-o", out}, {"--exr", exr}};
  int rc = cli_check_files(cmd, in_files, 2, out_files, 2);
  if (rc) return rc;
  double t_start = omp_get_wtime();
  if (ends_with_exr(out)) { /* the crop's values instead of a picture */
    if (exr) return cli_usage_error(cmd, "-o is an EXR already: --exr is not needed");
    exr = out;
    out = NULL;
  }
  if (fmethod >= 0) return run_featmap(maps, fmethod, rect, (int)out_res, (int)out_h, out, exr, t_start);

  ch_error err = cli_error();
  ch_image maps_img = {0};
  if (ch_exr_read(maps, &maps_img, &err)) return cli_fail(&err);
  char rect_text[256];
  double map_rect[4] = {0, 0, 1, 1};
  if (ch_exr_read_attribute(maps, "chisel:rect", rect_text, sizeof rect_text, &err) == CH_OK &&
      sscanf(rect_text, "%lf %lf %lf %lf", &map_rect[0], &map_rect[1], &map_rect[2], &map_rect[3]) != 4) {
    ch_image_free(&maps_img);
    ch_error_set(&err, CH_ERR_INPUT, "%s: bad chisel:rect attribute '%s'", maps, rect_text);
    return cli_fail(&err);
  }
  if (!(map_rect[2] > map_rect[0] && map_rect[3] > map_rect[1])) {
    ch_image_free(&maps_img);
    ch_error_set(&err, CH_ERR_INPUT, "%s: empty chisel:rect attribute", maps);
    return cli_fail(&err);
  }
  ch_dci dci;
  ch_status st = ch_dci_from_image(&maps_img, map_rect, maps, &dci, &err);
  ch_image_free(&maps_img);
  if (st) return cli_fail(&err);
  ch_curve_set set = {0};
  ch_recon recon = {0};
  if (curves) st = ch_curves_read_svg_ex(curves, &svg_desc, &set, &err);
  if (!st) st = ch_recon_init(&recon, &dci, curves ? &set : NULL, &err);
  int W = (int)out_res, H = (int)out_h;
  float *h = NULL;
  float *rgb = NULL;
  if (!st) {
    h = malloc((size_t)W * H * sizeof *h);
    rgb = malloc((size_t)W * H * 3 * sizeof *rgb);
    if (!h || !rgb) st = ch_error_set(&err, CH_ERR_NOMEM, "out of memory for a %dx%d crop", W, H);
  }
  if (!st) {
    double px = (rect[2] - rect[0]) / W, py = (rect[3] - rect[1]) / H;
    double footprint = aa ? sqrt(px * py) : 0.0;
#pragma omp parallel for schedule(dynamic, 4)
    for (int y = 0; y < H; y++)
      for (int x = 0; x < W; x++) {
        ch_recon_sample rs;
        ch_recon_eval(&recon, (ch_recon_method)method, rect[0] + (x + 0.5) * px, rect[3] - (y + 0.5) * py,
                      footprint, &rs);
        size_t i = (size_t)y * W + x;
        h[i] = rs.value;
        memcpy(rgb + 3 * i, rs.color, sizeof rs.color);
      }
  }
  if (!st && out) {
    unsigned char *pix = malloc((size_t)W * H * 3);
    if (!pix) st = ch_error_set(&err, CH_ERR_NOMEM, "out of memory");
    if (!st) {
      /* False colour scaled by the whole DCI's range, so crops compare. */
      size_t n = (size_t)dci.samples.width * dci.samples.height;
      double scale = 0.0;
      for (size_t i = 0; i < n; i++) scale = fmax(scale, fabs(dci.h[i]));
      for (size_t i = 0; i < (size_t)W * H; i++) {
        if (dci.rgb) {
          for (int c = 0; c < 3; c++) {
            float v = rgb[3 * i + c];
            pix[3 * i + c] = (unsigned char)(v <= 0.0f ? 0 : v >= 1.0f ? 255 : (int)(v * 255.0f + 0.5f));
          }
        } else {
          ch_colormap_diverging(scale > 0.0 ? h[i] / scale : 0.0, pix + 3 * i);
        }
      }
      st = ch_png_write(out, W, H, 3, pix, &err);
      free(pix);
    }
  }
  if (!st && exr) {
    ch_image crop = {0};
    const char *names[] = {"h"};
    st = ch_image_init(&crop, W, H, 1, names, &err);
    if (!st) {
      memcpy(ch_image_plane(&crop, 0), h, (size_t)W * H * sizeof *h);
      char scale_text[32];
      ch_exr_write_desc wd = {0};
      ch_pipeline_height_luminance(h, (size_t)W * H, "h", &wd, scale_text, sizeof scale_text);
      const ch_exr_attribute attrs[] = {{"chisel:height_scale", scale_text}, {"chisel:Y", CH_PIPELINE_Y_NOTE}};
      wd.attributes = attrs;
      wd.num_attributes = 2;
      st = ch_exr_write(exr, &crop, &wd, &err);
    }
    ch_image_free(&crop);
  }
  if (!st)
    cli_result("wrote %s (%d x %d)%s%s in %.2f s", out ? out : exr, W, H, out && exr ? ", " : "",
               out && exr ? exr : "", omp_get_wtime() - t_start);
  free(h);
  free(rgb);
  ch_recon_free(&recon);
  ch_curves_free(&set);
  ch_dci_free(&dci);
  return st ? cli_fail(&err) : 0;
}

const cli_command cli_magnify_command = {"magnify", "a zoomed crop of a DCI, crisp by feature reconstruction",
                                         usage, run};
