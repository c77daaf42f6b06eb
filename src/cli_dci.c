/* chisel dci: the diffusion-curve image of a curve file, all its layers. */
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ch_curves.h"
#include "ch_dci.h"
#include "ch_exr.h"
#include "ch_png.h"
#include "ch_pipeline.h"
#include "cli.h"

static const char usage[] =
    "usage: chisel dci CURVES.svg --res R -o MAPS.exr [--rect u0,v0,u1,v1] [--png P.png]\n"
    "                 [--stats]\n"
    "\n"
    "Builds the diffusion-curve image of the step curves: feature samples (exact\n"
    "closest curve points near the curves), Laplace diffusion with the curves as\n"
    "two-sided boundaries (multigrid, relative residual 1e-6) and the reblur of\n"
    "curves with data-blur. Writes every layer as float32 EXR: h (and, without\n"
    "colours, Y = 0.5 + h / (2 max |h|), the grey channel viewers show), R G B (with\n"
    "colours), opp.h opp.R opp.G opp.B (values across the curve), distance.X\n"
    "(texels), sp.u sp.v (closest curve point), chain.X and t (which subpath and\n"
    "where along it), curve.X, side.X (1 left, 2 right, +4 near an open end, +8\n"
    "blurred curve, +16 closed subpath), exact.X, fixed.X, blur.X. `chisel\n"
    "magnify` reads it.\n"
    "\n"
    "  --res R            R x R texels, 1..16384 (required)\n"
    "  -o, --output FILE  the EXR to write (required)\n"
    "  --rect u0,v0,u1,v1 the UV rectangle to cover (default 0,0,1,1)\n"
    "  --png FILE         a preview: the colours, or h in false colour\n"
    "  --stats            timings and solver figures on stderr\n"
    "  --fill-height H    the height of filled shapes drawn without data-\n"
    "                     attributes (docs/svg.md; default 0.01)\n";

static ch_status write_preview(const char *path, const ch_dci *d, ch_error *err) {
  const ch_samples *s = &d->samples;
  size_t n = (size_t)s->width * s->height;
  if (!d->rgb) return ch_png_write_height(path, d->h, s->width, s->height, err);
  unsigned char *px = malloc(3 * n);
  if (!px) return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory", path);
  for (size_t i = 0; i < 3 * n; i++) {
    float v = d->rgb[i];
    px[i] = (unsigned char)(v <= 0.0f ? 0 : v >= 1.0f ? 255 : (int)(v * 255.0f + 0.5f));
  }
  ch_status st = ch_png_write(path, s->width, s->height, 3, px, err);
  free(px);
  return st;
}

static int run(int argc, char **argv) {
  const char *cmd = "dci";
  const char *svg = NULL, *out = NULL, *png = NULL;
  long res = 0;
  int stats = 0, have_rect = 0;
  ch_svg_desc svg_desc = {0};
  double rect[4] = {0, 0, 1, 1};
  for (int i = 1; i < argc; i++) {
    const char *a = argv[i];
    if (!strcmp(a, "--res")) {
      const char *v = cli_option_value(cmd, argc, argv, &i);
      if (!v || cli_parse_int(cmd, a, v, 1, 16384, &res)) return 2;
    } else if (!strcmp(a, "--rect")) {
      const char *v = cli_option_value(cmd, argc, argv, &i);
      if (!v || cli_parse_doubles(cmd, a, v, 4, rect)) return 2;
      have_rect = 1;
    } else if (!strcmp(a, "-o") || !strcmp(a, "--output")) {
      if (!(out = cli_option_value(cmd, argc, argv, &i))) return 2;
    } else if (!strcmp(a, "--png")) {
      if (!(png = cli_option_value(cmd, argc, argv, &i))) return 2;
    } else if (!strcmp(a, "--stats")) {
      stats = 1;
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
  if (!out) return cli_usage_error(cmd, "missing -o MAPS.exr");
  if (cli_is_stdout(out)) return cli_refuse_stdout(cmd, "-o", "an EXR");
  if (png && cli_is_stdout(png)) return cli_refuse_stdout(cmd, "--png", "a PNG");
  if (have_rect && !(rect[2] > rect[0] && rect[3] > rect[1]))
    return cli_usage_error(cmd, "--rect needs u0 < u1 and v0 < v1");
  const cli_file in_files[] = {{"CURVES.svg", svg}}, out_files[] = {{"-o", out}, {"--png", png}};
  int rc = cli_check_files(cmd, in_files, 1, out_files, 2);
  if (rc) return rc;

  double t_start = omp_get_wtime();
  ch_error err = cli_error();
  ch_curve_set set;
  cli_progress_start(cmd);
  cli_progress_stage("reading %s", svg);
  if (ch_curves_read_svg_ex(svg, &svg_desc, &set, &err)) return cli_fail(&err);
  int steps = 0;
  for (int c = 0; c < set.num_curves; c++) steps += set.curves[c].kind == CH_CURVE_STEP;
  if (!steps) ch_warn(&err, "%s: no step curves: the DCI is flat", svg);
  ch_dci dci;
  ch_dci_desc desc = {.resolution = (int)res};
  memcpy(desc.rect, rect, sizeof rect);
  ch_image img = {0};
  cli_progress_stage("the diffusion-curve image at %ld x %ld", res, res);
  ch_status st = ch_dci_build(&set, &desc, &dci, &err);
  cli_progress_stage("writing %s", out);
  if (!st && stats)
    fprintf(stderr,
            "chisel: dci %ldx%ld: feature samples %.1f ms, diffusion %.1f ms (%d levels, %d iterations, "
            "residual %.2g, %d rounds of the fixed texels' extrapolation), reblur %.1f ms\n",
            res, res, 1e3 * dci.seconds_samples, 1e3 * dci.seconds_diffuse, dci.stats.levels,
            dci.stats.iterations, dci.stats.relative_residual[0], dci.extrapolations, 1e3 * dci.seconds_blur);
  double t_write = omp_get_wtime();
  if (!st) st = ch_dci_to_image(&dci, &img, &err);
  if (!st) {
    char rect_text[128], res_text[32];
    snprintf(rect_text, sizeof rect_text, "%.17g %.17g %.17g %.17g", rect[0], rect[1], rect[2], rect[3]);
    snprintf(res_text, sizeof res_text, "%ld", res);
    char scale_text[32];
    ch_exr_write_desc wd = {0};
    if (!dci.rgb) /* colours are what a viewer shows; else h as grey */
      ch_pipeline_height_luminance(dci.h, (size_t)res * (size_t)res, "h", &wd, scale_text, sizeof scale_text);
    const ch_exr_attribute attrs[] = {{"chisel:command", "dci"},
                                      {"chisel:rect", rect_text},
                                      {"chisel:resolution", res_text},
                                      {"chisel:height_scale", scale_text},
                                      {"chisel:Y", CH_PIPELINE_Y_NOTE}};
    wd.attributes = attrs;
    wd.num_attributes = dci.rgb ? 3 : 5;
    st = ch_exr_write(out, &img, &wd, &err);
  }
  if (!st && png) {
    st = write_preview(png, &dci, &err);
  }
  cli_progress_done();
  if (!st && stats)
    fprintf(stderr, "chisel: dci: %d layers written in %.1f ms\n", img.num_channels, 1e3 * (omp_get_wtime() - t_write));
  if (!st)
    cli_result("wrote %s (%ld x %ld, %d layers)%s%s in %.2f s", out, res, res, img.num_channels + (dci.rgb ? 0 : 1),
               png ? ", " : "", png ? png : "", omp_get_wtime() - t_start);
  ch_image_free(&img);
  ch_dci_free(&dci);
  ch_curves_free(&set);
  return st ? cli_fail(&err) : 0;
}

const cli_command cli_dci_command = {"dci", "the diffusion-curve image of the step curves (EXR layers)", usage,
                                     run};
