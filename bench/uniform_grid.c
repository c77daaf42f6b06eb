/* chisel-uniform-grid: the baseline of the accuracy figures (accuracy.h),
 * "the best uniform grid with exact vertex heights" on the planar base: an
 * n x n grid of the unit square in 2 n^2 triangles (n such that 2 n^2 is closest to N;
 * diagonals alternate in a checkerboard), vertex z = exact h there, written
 * as OBJ with vt = (x, y) and no normals. With --raster R the vertex heights
 * are read instead from an R x R raster of h (pixel centres, bilinear,
 * edges clamped): what a displacement modifier with a height texture gives
 * (the study's "raster-displaced mesh", scripts/study.sh).
 *
 * usage: chisel-uniform-grid CURVES.svg -o OUT.obj --target-tris N [--dci-res 4096] [--raster R] */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "accuracy.h"

static const char usage[] =
    "usage: chisel-uniform-grid CURVES.svg -o OUT.obj --target-tris N [--dci-res R] [--raster R]\n"
    "\n"
    "Writes the n x n uniform grid of the unit square (2 n^2 triangles, n such that\n"
    "2 n^2 is closest to N, diagonals alternating in a checkerboard) with every\n"
    "vertex at z = h(x, y), the exact height of docs/spec.md §3; vt = (x, y), no normals.\n"
    "  --target-tris N  triangle count to approach, 2..1e9\n"
    "  --dci-res R      resolution of the step curves' DCI (default 4096)\n"
    "  --raster R       heights read bilinearly from an R x R raster of h (pixel\n"
    "                   centres, edges clamped), as a height-texture displacement\n"
    "                   does, instead of exactly; 2..16384\n";

static void print_warning(void *user, const char *message) {
  (void)user;
  fprintf(stderr, "chisel-uniform-grid: warning: %s\n", message);
}

static int fail(const ch_error *err) {
  fprintf(stderr, "chisel-uniform-grid: %s\n", err->message[0] ? err->message : ch_status_name(err->status));
  int code = ch_status_exit_code(err->status);
  return code ? code : 1;
}

static int usage_error(const char *what, const char *arg) {
  fprintf(stderr, "chisel-uniform-grid: %s%s%s\n%s", what, arg ? " " : "", arg ? arg : "", usage);
  return 2;
}

static int parse_long(const char *text, long lo, long hi, long *out) {
  char *end;
  errno = 0;
  long v = strtol(text, &end, 10);
  if (end == text || *end || errno || v < lo || v > hi) return -1;
  *out = v;
  return 0;
}

int main(int argc, char **argv) {
  const char *svg = NULL, *out = NULL;
  long target = 0, dci_res = 4096, raster = 0;
  for (int i = 1; i < argc; i++) {
    const char *a = argv[i];
    if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
      fputs(usage, stdout);
      return 0;
    } else if (!strcmp(a, "--target-tris") || !strcmp(a, "--dci-res") || !strcmp(a, "-o") ||
               !strcmp(a, "--output") || !strcmp(a, "--raster")) {
      if (i + 1 >= argc) return usage_error("missing the value of", a);
      const char *v = argv[++i];
      if (!strcmp(a, "--target-tris")) {
        if (parse_long(v, 2, 1000000000L, &target)) return usage_error("bad value (2..1e9) for", a);
      } else if (!strcmp(a, "--dci-res")) {
        if (parse_long(v, 16, 16384, &dci_res)) return usage_error("bad value (16..16384) for", a);
      } else if (!strcmp(a, "--raster")) {
        if (parse_long(v, 2, 16384, &raster)) return usage_error("bad value (2..16384) for", a);
      } else {
        out = v;
      }
    } else if (a[0] == '-' && a[1]) {
      return usage_error("unknown option", a);
    } else if (!svg) {
      svg = a;
    } else {
      return usage_error("unexpected argument", a);
    }
  }
  if (!svg) return usage_error("missing CURVES.svg", NULL);
  if (!out) return usage_error("missing -o OUT.obj", NULL);
  if (!target) return usage_error("missing --target-tris N", NULL);

  ch_error err = {0};
  err.warn = print_warning;
  ch_curve_set set;
  if (ch_curves_read_svg(svg, &set, &err)) return fail(&err);
  ch_height height;
  ch_height_desc hd = {.dci_resolution = (int)dci_res, .step_method = CH_RECON_EXACT};
  ch_status st = ch_height_init(&height, &set, &hd, &err);
  if (!st) {
    int n = ch_accuracy_uniform_n(target);
    ch_mesh mesh;
    st = ch_accuracy_uniform_grid(&height, n, &mesh, &err);
    if (!st && raster) st = ch_accuracy_read_raster(&height, (int)raster, &mesh, &err);
    if (!st) {
      st = ch_mesh_write_obj(out, &mesh, &err);
      if (!st) fprintf(stderr, "chisel-uniform-grid: %s: %d x %d grid, %d triangles\n", out, n, n, mesh.num_faces);
      ch_mesh_free(&mesh);
    }
    ch_height_free(&height);
  }
  ch_curves_free(&set);
  return st ? fail(&err) : 0;
}
