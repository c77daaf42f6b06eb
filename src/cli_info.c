/* chisel info: what a mesh or a curve file holds, and whether chisel can
 * use it. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "ch_bezier.h"
#include "ch_curves.h"
#include "ch_exr.h"
#include "ch_file.h"
#include "ch_mesh.h"
#include "cli.h"

static const char usage[] =
    "usage: chisel info FILE...\n"
    "\n"
    "Describes each FILE: a base mesh (.obj .ply .off .stl: counts, bounds, UV\n"
    "range and coverage, charts, boundary and manifoldness), a curve file (.svg:\n"
    "curves by kind and profile, segments, lengths, bounding box in UV) or an\n"
    "image (.exr: size, and per channel its range and how many values are not\n"
    "finite). Problems that stop chisel from using the file are errors (exit\n"
    "status 2).\n";

static const char *profile_name(const ch_profile *p) {
  static const char *names[] = {"v", "u", "box", "ridge", "bevel", "custom"};
  return names[p->kind];
}

static int info_svg(const char *path) {
  ch_error err = cli_error();
  ch_curve_set set;
  if (ch_curves_read_svg(path, &set, &err)) return cli_fail(&err);
  int grooves = 0, steps = 0, lines = 0, closed = 0;
  int per_profile[6] = {0};
  double b[4] = {INFINITY, INFINITY, -INFINITY, -INFINITY};
  for (int i = 0; i < set.num_curves; i++) {
    const ch_curve *c = &set.curves[i];
    if (c->kind == CH_CURVE_GROOVE) {
      grooves++;
      per_profile[c->profile.kind]++;
    } else {
      steps++;
    }
    b[0] = fmin(b[0], c->bbox[0]);
    b[1] = fmin(b[1], c->bbox[1]);
    b[2] = fmax(b[2], c->bbox[2]);
    b[3] = fmax(b[3], c->bbox[3]);
  }
  for (int i = 0; i < set.num_segments; i++) lines += set.segments[i].is_line;
  for (int i = 0; i < set.num_subpaths; i++) closed += set.subpaths[i].closed;
  printf("%s: SVG curve file\n", path);
  printf("  viewBox         %g %g %g %g\n", set.viewbox[0], set.viewbox[1], set.viewbox[2], set.viewbox[3]);
  printf("  curves          %d (%d groove, %d step)\n", set.num_curves, grooves, steps);
  printf("  subpaths        %d (%d closed, %d open)\n", set.num_subpaths, closed, set.num_subpaths - closed);
  printf("  segments        %d (%d lines, %d quadratics)\n", set.num_segments, lines, set.num_segments - lines);
  printf("  UV bounds       [%.6g, %.6g] .. [%.6g, %.6g] (control polygons)\n", b[0], b[1], b[2], b[3]);
  if (grooves) {
    printf("  profiles       ");
    for (int k = 0; k < 6; k++)
      if (per_profile[k]) printf(" %s %d", profile_name(&(ch_profile){.kind = (ch_profile_kind)k}), per_profile[k]);
    printf("\n");
  }
  printf("  %-4s %-20s %-6s %-7s %9s %9s %8s %10s\n", "#", "id", "kind", "profile", "width(UV)", "depth/L,R", "segments",
         "length(UV)");
  for (int i = 0; i < set.num_curves; i++) {
    const ch_curve *c = &set.curves[i];
    char values[48];
    if (c->kind == CH_CURVE_GROOVE)
      snprintf(values, sizeof values, "%g", c->depth);
    else
      snprintf(values, sizeof values, "%g,%g", c->left, c->right);
    double length = 0.0;
    for (int k = 0; k < c->num_segments; k++) length += ch_bezier_length(set.segments[c->first_segment + k].p);
    printf("  %-4d %-20.20s %-6s %-7s %9.4g %9s %8d %10.4g\n", i, c->id[0] ? c->id : "-",
           c->kind == CH_CURVE_GROOVE ? "groove" : "step",
           c->kind == CH_CURVE_GROOVE ? profile_name(&c->profile) : "-", c->width, values, c->num_segments, length);
  }
  ch_curves_free(&set);
  return 0;
}

static int info_mesh(const char *path, const char *ext) {
  ch_error err = cli_error();
  ch_mesh mesh;
  if (ch_mesh_read(path, &mesh, &err)) return cli_fail(&err);
  ch_mesh_report r;
  ch_status st = ch_mesh_validate(&mesh, path, &r, &err);
  if (st && st != CH_ERR_INPUT) {
    ch_mesh_free(&mesh);
    return cli_fail(&err);
  }
  printf("%s: %s mesh\n", path, ext);
  printf("  positions       %d\n", mesh.num_positions);
  printf("  faces           %d (%d triangles, %d quads, %d polygons), %d corners\n", mesh.num_faces,
         r.num_triangles, r.num_quads, r.num_polygons, mesh.num_corners);
  if (mesh.num_faces > 0) {
    printf("  bounds          [%.6g, %.6g, %.6g] .. [%.6g, %.6g, %.6g]\n", r.bounds_min[0], r.bounds_min[1],
           r.bounds_min[2], r.bounds_max[0], r.bounds_max[1], r.bounds_max[2]);
  }
  if (mesh.corner_uv) {
    printf("  UVs             %d, range [%.6g, %.6g] .. [%.6g, %.6g]%s\n", mesh.num_uvs, r.uv_min[0],
           r.uv_min[1], r.uv_max[0], r.uv_max[1], r.num_uvs_outside ? " (outside [0,1]!)" : "");
    printf("  UV coverage     %.1f%% of the unit square, %.1f%% covered twice or more\n",
           100.0 * r.uv_coverage, 100.0 * r.uv_overlap);
    printf("  UV charts       %d\n", r.num_charts);
  } else {
    printf("  UVs             none\n");
  }
  printf("  normals         %s\n", mesh.corner_normal ? "from the file" : "none");
  printf("  components      %d\n", r.num_components);
  printf("  edges           %d boundary, %d non-manifold; %d non-manifold vertices\n",
         r.num_boundary_edges, r.num_nonmanifold_edges, r.num_nonmanifold_vertices);
  printf("  degenerate      %d faces with zero area, %d with zero UV area\n", r.num_degenerate_faces,
         r.num_zero_uv_area_faces);
  ch_mesh_free(&mesh);
  if (st) return cli_fail(&err);
  return 0;
}

static int info_exr(const char *path) {
  ch_error err = cli_error();
  ch_image img;
  if (ch_exr_read(path, &img, &err)) return cli_fail(&err);
  printf("%s: EXR image\n", path);
  printf("  size            %d x %d\n", img.width, img.height);
  printf("  channels        %d\n", img.num_channels);
  size_t n = (size_t)img.width * img.height;
  for (int c = 0; c < img.num_channels; c++) {
    const float *p = img.pixels + (size_t)c * n;
    double lo = INFINITY, hi = -INFINITY;
    size_t bad = 0;
    for (size_t i = 0; i < n; i++) {
      if (!isfinite(p[i])) {
        bad++;
        continue;
      }
      lo = fmin(lo, p[i]);
      hi = fmax(hi, p[i]);
    }
    if (bad == n)
      printf("  %-15s no finite values\n", img.names[c]);
    else
      printf("  %-15s %.6g .. %.6g\n", img.names[c], lo, hi);
    if (bad && bad != n) printf("  %-15s %zu values not finite\n", "", bad);
  }
  ch_image_free(&img);
  return 0;
}

static int run(int argc, char **argv) {
  if (argc < 2) return cli_usage_error("info", "missing FILE");
  int rc = 0;
  for (int i = 1; i < argc; i++) {
    if (argv[i][0] == '-' && argv[i][1]) return cli_usage_error("info", "unknown option '%s'", argv[i]);
  }
  for (int i = 1; i < argc; i++) {
    char ext[16];
    ch_path_extension(argv[i], ext, sizeof ext);
    int r;
    if (!strcmp(ext, "svg"))
      r = info_svg(argv[i]);
    else if (!strcmp(ext, "exr"))
      r = info_exr(argv[i]);
    else
      r = info_mesh(argv[i], ext[0] ? ext : "unknown");
    if (r && !rc) rc = r;
    fflush(stdout);
  }
  return rc;
}

const cli_command cli_info_command = {"info", "describe a mesh, a curve file or an EXR image", usage, run};
