/* chisel featmap: feature-curve textures of a curve file (distance,
 * gradient, signatures, curve ids), a conventional normal map and a
 * multi-channel distance field at the same resolution, in one EXR. */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ch_curves.h"
#include "ch_featmap.h"
#include "ch_height.h"
#include "ch_msdf.h"
#include "ch_png.h"
#include "cli.h"

static const char usage[] =
    "usage: chisel featmap CURVES.svg --res R -o MAPS.exr [--png P.png] [--rect u0,v0,u1,v1]\n"
    "                     [--linear] [--no-fallback] [--dci-res N] [--stats]\n"
    "\n"
    "Builds the feature-curve textures of the grooves and sharp step curves\n"
    "(feature-curves-textures, normal-maps-discontinuities): at the (R+1)^2\n"
    "corners of R x R cells the signed distance to the nearest curve, its\n"
    "gradient and that curve; per cell the discontinuity configuration (up to\n"
    "two segments) and signature (edge points, tangent angles: quadratic\n"
    "pieces, refitted where they do not fit); cells the papers' representation\n"
    "cannot hold (more curves, ends, corners, crossings, tiny loops) get a list\n"
    "of the exact curve pieces near them. Beside them, for comparison, a\n"
    "conventional normal map of h (box-filtered) and a multi-channel signed\n"
    "distance field (msdfgen's method) at the same lattice. One float EXR of\n"
    "(R+1) x (R+1) pixels, row 0 at v1; layers d, grad.X grad.Y, curve,\n"
    "sig.S.pos sig.S.angle sig.W.pos sig.W.angle, config, seg.curve0\n"
    "seg.curve1, N.X N.Y N.Z, msdf.R msdf.G msdf.B (base.X/Y/Z where h_step\n"
    "slopes), the profiles and exact pieces as attributes. chisel magnify\n"
    "reads it (methods featnorm, featnorm-linear, normal-bilinear, msdf).\n"
    "\n"
    "  --res R            cells per side, 4..4096 (required)\n"
    "  -o, --output FILE  the EXR to write (required)\n"
    "  --png FILE         a preview: the featnorm normals lit from the upper left,\n"
    "                     2R pixels across (at most 4096)\n"
    "  --rect u0,v0,u1,v1 the UV rectangle to cover (default 0,0,1,1)\n"
    "  --linear           the linear variant: straight pieces, no angles, no fit\n"
    "  --no-fallback      only the papers' handling of what a cell cannot hold\n"
    "  --dci-res N        resolution of the step DCI behind the base normals, when\n"
    "                     the curves have step curves (default 1024)\n"
    "  --stats            counts per configuration class, bytes and timings on stderr\n";

static ch_status write_preview(const char *path, const ch_featmap *m, ch_error *err) {
  int W = 2 * m->resolution;
  if (W > 4096) W = 4096;
  int H = (int)lround(W * (m->rect[3] - m->rect[1]) / (m->rect[2] - m->rect[0]));
  if (H < 1) H = 1;
  if (H > 4096) H = 4096;
  unsigned char *px = malloc((size_t)W * H);
  if (!px) return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory", path);
#pragma omp parallel for schedule(dynamic, 4)
  for (int y = 0; y < H; y++)
    for (int x = 0; x < W; x++) {
      ch_featmap_sample s;
      double u = m->rect[0] + (x + 0.5) * (m->rect[2] - m->rect[0]) / W;
      double v = m->rect[3] - (y + 0.5) * (m->rect[3] - m->rect[1]) / H;
      ch_featmap_eval(m, CH_FEATMAP_FEATNORM, u, v, &s);
      px[(size_t)y * W + x] = cli_lit_grey(s.normal);
    }
  unsigned char *rgb = malloc((size_t)W * H * 3);
  ch_status st = CH_OK;
  if (!rgb) st = ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory", path);
  else {
    for (size_t i = 0; i < (size_t)W * H; i++) rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = px[i];
    st = ch_png_write(path, W, H, 3, rgb, err);
  }
  free(rgb);
  free(px);
  return st;
}

static int run(int argc, char **argv) {
  const char *cmd = "featmap";
  const char *svg = NULL, *out = NULL, *png = NULL;
  long res = 0, dci_res = 1024;
  int stats = 0, have_rect = 0, linear = 0, no_fallback = 0;
  double rect[4] = {0, 0, 1, 1};
  ch_svg_desc svg_desc = {0};
  for (int i = 1; i < argc; i++) {
    const char *a = argv[i];
    if (!strcmp(a, "--res")) {
      const char *v = cli_option_value(cmd, argc, argv, &i);
      if (!v || cli_parse_int(cmd, a, v, CH_FEATMAP_MIN_RES, CH_FEATMAP_MAX_RES, &res)) return 2;
    } else if (!strcmp(a, "--dci-res")) {
      const char *v = cli_option_value(cmd, argc, argv, &i);
      if (!v || cli_parse_int(cmd, a, v, 16, 16384, &dci_res)) return 2;
    } else if (!strcmp(a, "--rect")) {
      const char *v = cli_option_value(cmd, argc, argv, &i);
      if (!v || cli_parse_doubles(cmd, a, v, 4, rect)) return 2;
      have_rect = 1;
    } else if (!strcmp(a, "-o") || !strcmp(a, "--output")) {
      if (!(out = cli_option_value(cmd, argc, argv, &i))) return 2;
    } else if (!strcmp(a, "--png")) {
      if (!(png = cli_option_value(cmd, argc, argv, &i))) return 2;
    } else if (!strcmp(a, "--linear")) {
      linear = 1;
    } else if (!strcmp(a, "--no-fallback")) {
      no_fallback = 1;
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
  if (have_rect && !(rect[2] > rect[0] && rect[3] > rect[1]))
    return cli_usage_error(cmd, "--rect needs u0 < u1 and v0 < v1");
  if (cli_is_stdout(out)) return cli_refuse_stdout(cmd, "-o", "an EXR");
  if (cli_is_stdout(png)) return cli_refuse_stdout(cmd, "--png", "a PNG");
  const cli_file in_files[] = {{"CURVES.svg", svg}}, out_files[] = {{"-o", out}, {"--png", png}};
  int rc = cli_check_files(cmd, in_files, 1, out_files, 2);
  if (rc) return rc;

  ch_error err = cli_error();
  ch_curve_set set;
  cli_progress_start(cmd);
  cli_progress_stage("reading %s", svg);
  if (ch_curves_read_svg_ex(svg, &svg_desc, &set, &err)) return cli_fail(&err);
  int steps = 0;
  for (int c = 0; c < set.num_curves; c++) steps += set.curves[c].kind == CH_CURVE_STEP;
  ch_height height = {0};
  ch_featmap maps = {0};
  ch_msdf msdf = {0};
  ch_status st = CH_OK;
  double t0 = omp_get_wtime(), t_height = 0.0;
  if (steps) {
    /* h_step, for the base normals and the conventional normal map */
    cli_progress_stage("h_step: the step curves' diffusion at %ld x %ld", dci_res, dci_res);
    ch_height_desc hd = {.dci_resolution = (int)dci_res, .step_method = CH_RECON_EXACT};
    st = ch_height_init(&height, &set, &hd, &err);
    t_height = omp_get_wtime() - t0;
  }
  ch_featmap_desc fd = {.resolution = (int)res, .linear = linear, .no_fallback = no_fallback,
                        .height = steps ? &height : NULL};
  memcpy(fd.rect, rect, sizeof rect);
  if (!st) cli_progress_stage("feature maps at %ld x %ld", res, res);
  if (!st) st = ch_featmap_build(&set, &fd, &maps, &err);
  ch_msdf_desc md = {.resolution = (int)res};
  memcpy(md.rect, rect, sizeof rect);
  if (!st) cli_progress_stage("msdf at %ld x %ld", res, res);
  if (!st) st = ch_msdf_build(&set, &md, &msdf, &err);
  if (!st && stats) {
    const ch_featmap_stats *s = &maps.stats;
    long cells = res * res;
    fprintf(stderr,
            "chisel: featmap %ldx%ld (%s%s): %ld cells with one segment, %ld with two, %ld edge points\n"
            "chisel: cells the papers' representation cannot hold: %ld more curves, %ld merged, %ld ends,\n"
            "chisel:   %ld loops, %ld corners, %ld medial axes, %ld overlapping grooves, %ld tight bends\n"
            "chisel: signatures: %ld invalid as crossed, %ld refitted, %ld straightened\n"
            "chisel: fallback: %ld cells (%.2f%%), %ld entries, %d pieces, %ld overflowing\n"
            "chisel: bytes per texel: featnorm %.0f, featnorm-linear %.0f, normal map %.0f, msdf %.0f, "
            "fallback lists %.2f\n"
            "chisel: time: h_step %.3f s; maps %.3f s (samples %.3f, cells %.3f, fit %.3f, checks %.3f, "
            "smoothing %.3f, fallback %.3f, normal maps %.3f); msdf %.3f s\n",
            res, res, maps.linear ? "linear" : "quadratic", no_fallback ? ", no fallback" : "", s->cells_one,
            s->cells_two, s->points, s->lost_dropped, s->lost_merged, s->lost_end, s->lost_loop, s->lost_corner,
            s->lost_medial, s->lost_csg, s->lost_tight, s->invalid, s->fitted, s->straightened, s->fallback_cells,
            100.0 * s->fallback_cells / cells, s->fallback_entries, maps.num_pieces, s->fallback_overflow,
            ch_featmap_bytes_per_texel(&maps, CH_FEATMAP_FEATNORM), ch_featmap_bytes_per_texel(&maps, CH_FEATMAP_LINEAR),
            ch_featmap_bytes_per_texel(&maps, CH_FEATMAP_BILINEAR), ch_msdf_bytes_per_texel(),
            ch_featmap_fallback_bytes(&maps), t_height, s->seconds_total, s->seconds_samples, s->seconds_cells,
            s->seconds_fit, s->seconds_check, s->seconds_smooth, s->seconds_fallback, s->seconds_normal, msdf.stats.seconds);
  }
  if (!st) {
    const ch_exr_attribute extra[] = {{"chisel:curves", svg}};
    cli_progress_stage("writing %s", out);
    st = ch_featmap_write_exr(out, &maps, &msdf, extra, 1, &err);
  }
  if (!st && png) st = write_preview(png, &maps, &err);
  if (!st)
    cli_result("wrote %s (%ld x %ld cells, %ld in the fallback)%s%s in %.2f s", out, res, res,
               maps.stats.fallback_cells, png ? ", " : "", png ? png : "", omp_get_wtime() - t0);
  ch_msdf_free(&msdf);
  ch_featmap_free(&maps);
  ch_height_free(&height);
  ch_curves_free(&set);
  return st ? cli_fail(&err) : 0;
}

const cli_command cli_featmap_command = {
    "featmap", "feature-curve textures: distance, gradient, signatures, normal map, msdf (EXR)", usage, run};
