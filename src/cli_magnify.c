/* chisel magnify: a zoomed crop of a DCI rendered from its R-sized maps
 * (diffusion-curves-on-surfaces, Figure 5, as a command). */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ch_curves.h"
#include "ch_dci.h"
#include "ch_exr.h"
#include "ch_png.h"
#include "ch_recon.h"
#include "ch_pipeline.h"
#include "cli.h"

static const char usage[] =
    "usage: chisel magnify MAPS.exr --rect u0,v0,u1,v1 --out-res N -o CROP.png\n"
    "                     [--method bilinear|recon5|recon3|exact] [--curves CURVES.svg]\n"
    "                     [--no-aa] [--exr CROP.exr]\n"
    "\n"
    "Renders the UV rectangle of a DCI written by `chisel dci` at N pixels across\n"
    "(height in proportion), reading only the maps: bilinear interpolation, or the\n"
    "feature reconstruction of the 5x5 or 3x3 neighbourhood, which keeps curves\n"
    "crisp at any magnification; `exact` takes the side from the vector curves\n"
    "(--curves) for comparison. Colour DCIs give colour, others h in false colour\n"
    "(blue low, red high, scaled by the DCI's range).\n"
    "\n"
    "  --rect u0,v0,u1,v1 the crop in UV (required)\n"
    "  --out-res N        pixels across, 1..16384 (required)\n"
    "  -o, --output FILE  the PNG to write (required)\n"
    "  --method M         bilinear, recon5 (default), recon3 or exact\n"
    "  --curves FILE      the curve file the DCI was made from (for exact)\n"
    "  --no-aa            no anti-aliasing of curve edges (paper §3.4)\n"
    "  --exr FILE         also write the crop's h as a float EXR (h, and\n"
    "                     Y = 0.5 + h / (2 max |h|) for image viewers)\n"
    "  --fill-height H    with --curves: the height of filled shapes drawn without\n"
    "                     data- attributes (docs/svg.md; default 0.01)\n";

static int run(int argc, char **argv) {
  const char *cmd = "magnify";
  const char *maps = NULL, *out = NULL, *curves = NULL, *exr = NULL;
  long out_res = 0;
  int method = CH_RECON_5X5, have_rect = 0, aa = 1;
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
      if ((method = ch_recon_method_parse(v)) < 0)
        return cli_usage_error(cmd, "unknown method '%s' (bilinear, recon5, recon3, exact)", v);
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
  if (!st) {
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
    cli_result("wrote %s (%d x %d)%s%s in %.2f s", out, W, H, exr ? ", " : "", exr ? exr : "",
               omp_get_wtime() - t_start);
  free(h);
  free(rgb);
  ch_recon_free(&recon);
  ch_curves_free(&set);
  ch_dci_free(&dci);
  return st ? cli_fail(&err) : 0;
}

const cli_command cli_magnify_command = {"magnify", "a zoomed crop of a DCI, crisp by feature reconstruction",
                                         usage, run};
