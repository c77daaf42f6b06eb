/* chisel sample: the exact displacement h of SPEC §3 as an R x R EXR. */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ch_curves.h"
#include "ch_exr.h"
#include "ch_height.h"
#include "ch_image.h"
#include "ch_png.h"
#include "cli.h"

static const char usage[] =
    "usage: chisel sample CURVES.svg --res R -o H.exr [--supersample S] [--png P.png]\n"
    "                    [--height-png H16.png] [--fill-height H]\n"
    "\n"
    "Writes the displacement h = h_step + h_groove of the curves (SPEC §3) as an\n"
    "R x R float32 EXR with the channel h, and beside it Y = 0.5 + h / (2 s),\n"
    "s = max |h| (the attribute chisel:height_scale and the result line), the\n"
    "grey channel image viewers, ImageMagick and Blender's image texture read\n"
    "(in Blender: Non-Color, Displace modifier with midlevel 0.5 and strength\n"
    "2 s). Pixel (x, y), y counted down from the top row, covers u in\n"
    "[x/R, (x+1)/R] and v in [1-(y+1)/R, 1-y/R].\n"
    "Grooves are exact; steps are diffused on an R x R grid (chisel dci) and read\n"
    "with the exact curves' sides, so walls are sharp inside pixels.\n"
    "\n"
    "  --res R            image resolution, 1..16384 (required)\n"
    "  -o, --output FILE  the EXR to write (required)\n"
    "  --supersample S    mean of an S x S grid of point samples per pixel,\n"
    "                     1..16 (default 4); 1 samples the pixel centre\n"
    "  --png FILE         also write a preview: false colour (blue carved, red\n"
    "                     raised) with hill shading\n"
    "  --height-png FILE  also write h as a 16-bit grey PNG for tools that read\n"
    "                     only integer images: 0.5 is h = 0, 0 and 1 are -s and +s\n"
    "                     with s = max |h| (in the PNG's text and the result\n"
    "                     line; Blender: midlevel 0.5, strength 2s)\n"
    "  --fill-height H    the height of filled shapes drawn without data-\n"
    "                     attributes (docs/svg.md; default 0.01)\n";

static int run(int argc, char **argv) {
  const char *cmd = "sample";
  const char *svg = NULL, *out = NULL, *png = NULL, *png16 = NULL;
  long res = 0, ss = 4;
  ch_svg_desc svg_desc = {0};
  for (int i = 1; i < argc; i++) {
    const char *a = argv[i];
    if (!strcmp(a, "--res") || !strcmp(a, "--supersample")) {
      const char *v = cli_option_value(cmd, argc, argv, &i);
      if (!v) return 2;
      int bad = !strcmp(a, "--res") ? cli_parse_int(cmd, a, v, 1, 16384, &res)
                                    : cli_parse_int(cmd, a, v, 1, 16, &ss);
      if (bad) return 2;
    } else if (!strcmp(a, "-o") || !strcmp(a, "--output")) {
      if (!(out = cli_option_value(cmd, argc, argv, &i))) return 2;
    } else if (!strcmp(a, "--png")) {
      if (!(png = cli_option_value(cmd, argc, argv, &i))) return 2;
    } else if (!strcmp(a, "--height-png")) {
      if (!(png16 = cli_option_value(cmd, argc, argv, &i))) return 2;
    } else if (!strcmp(a, "--fill-height")) {
      const char *v = cli_option_value(cmd, argc, argv, &i);
      if (!v || cli_parse_fill_height(cmd, v, &svg_desc)) return 2;
    } else if (a[0] == '-' && a[1]) {
      return cli_usage_error(cmd, "unknown option '%s'", a);
    } else if (!svg) {
      svg = a;
    } else {
      return cli_usage_error(cmd, "unexpected argument '%s'", a);
    }
  }
  if (!svg) return cli_usage_error(cmd, "missing the curve file CURVES.svg");
  if (!res) return cli_usage_error(cmd, "missing --res R");
  if (!out) return cli_usage_error(cmd, "missing -o H.exr");
  if (cli_is_stdout(out)) return cli_refuse_stdout(cmd, "-o", "an EXR");
  if (cli_is_stdout(png)) return cli_refuse_stdout(cmd, "--png", "a PNG");
  if (cli_is_stdout(png16)) return cli_refuse_stdout(cmd, "--height-png", "a PNG");
  const cli_file in_files[] = {{"CURVES.svg", svg}},
                 out_files[] = {{"-o", out}, {"--png", png}, {"--height-png", png16}};
  int rc = cli_check_files(cmd, in_files, 1, out_files, 3);
  if (rc) return rc;
  double t_start = omp_get_wtime();

  ch_error err = cli_error();
  ch_curve_set set;
  cli_progress_start(cmd);
  cli_progress_stage("reading %s", svg);
  if (ch_curves_read_svg_ex(svg, &svg_desc, &set, &err)) return cli_fail(&err);
  /* h_step comes from a DCI at the output resolution, read with the exact
   * curves' sides so that supersampled pixels resolve the walls. */
  ch_height height;
  ch_height_desc hd = {.dci_resolution = (int)res, .step_method = CH_RECON_EXACT};
  ch_image img = {0};
  const char *names[] = {"h"};
  cli_progress_stage("h: the step curves' diffusion at %ld x %ld", res, res);
  ch_status st = ch_height_init(&height, &set, &hd, &err);
  if (!st) st = ch_image_init(&img, (int)res, (int)res, 1, names, &err);
  if (!st) {
    cli_progress_stage("sampling h at %ld x %ld, %ld x %ld per pixel", res, res, ss, ss);
    ch_height_render(&height, (int)res, (int)ss, ch_image_plane(&img, 0));
    char res_text[32], ss_text[32];
    snprintf(res_text, sizeof res_text, "%ld", res);
    snprintf(ss_text, sizeof ss_text, "%ld", ss);
    char scale_text[32];
    ch_exr_write_desc desc = {0};
    cli_height_luminance(ch_image_plane(&img, 0), (size_t)res * (size_t)res, "h", &desc, scale_text, sizeof scale_text);
    const ch_exr_attribute attrs[] = {{"chisel:command", "sample"},
                                      {"chisel:resolution", res_text},
                                      {"chisel:supersample", ss_text},
                                      {"chisel:height_scale", scale_text},
                                      {"chisel:Y", CLI_Y_NOTE}};
    desc.attributes = attrs;
    desc.num_attributes = 5;
    cli_progress_stage("writing %s", out);
    st = ch_exr_write(out, &img, &desc, &err);
  }
  if (!st && png) {
    st = ch_png_write_height(png, ch_image_plane(&img, 0), img.width, img.height, &err);
  }
  if (!st && png16) {
    st = ch_png_write_height16(png16, ch_image_plane(&img, 0), img.width, img.height, NULL, &err);
  }
  if (!st) {
    float lo = INFINITY, hi = -INFINITY;
    const float *p = ch_image_plane(&img, 0);
    for (size_t i = 0; i < (size_t)res * (size_t)res; i++) lo = fminf(lo, p[i]), hi = fmaxf(hi, p[i]);
    double s = fmax(fabs((double)lo), fabs((double)hi));
    char extra[512] = "";
    if (png) snprintf(extra + strlen(extra), sizeof extra - strlen(extra), ", %s", png);
    if (png16) snprintf(extra + strlen(extra), sizeof extra - strlen(extra), ", %s (16-bit)", png16);
    cli_result("wrote %s (%ld x %ld, h in [%.6g, %.6g]; Y%s = 0.5 + h / (2 x %.6g))%s in %.2f s", out, res, res, lo,
               hi, png16 ? " and the PNG" : "", s, extra, omp_get_wtime() - t_start);
  }
  ch_image_free(&img);
  ch_height_free(&height);
  ch_curves_free(&set);
  return st ? cli_fail(&err) : 0;
}

const cli_command cli_sample_command = {"sample", "the exact displacement h of a curve file as an EXR",
                                        usage, run};
