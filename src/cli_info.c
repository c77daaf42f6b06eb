/* chisel info: what a mesh or a curve file holds, and whether chisel can
 * use it. */
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ch_bezier.h"
#include "ch_curves.h"
#include "ch_exr.h"
#include "ch_file.h"
#include "ch_mesh.h"
#include "cli.h"

static const char usage[] =
    "usage: chisel info FILE... [--json] [--fill-height H]\n"
    "\n"
    "Describes each FILE: a base mesh (.obj .ply .off .stl .glb .gltf: counts, bounds, UV\n"
    "range and coverage, charts, boundary and manifoldness), a curve file (.svg:\n"
    "curves by kind and profile, segments, lengths, bounding box in UV) or an\n"
    "image (.exr: size, and per channel its range and how many values are not\n"
    "finite). Problems that stop chisel from using the file are errors (exit\n"
    "status 2). For each curve it says what decided its kind and its width\n"
    "(docs/svg.md): data- attributes, the stroke, the fill or the defaults.\n"
    "\n"
    "  --json             one JSON object per file, one per line (JSON Lines),\n"
    "                     with the same figures\n"
    "  --fill-height H    the height of filled shapes drawn without data-\n"
    "                     attributes (default 0.01)\n";

static ch_svg_desc svg_desc;

/* Prints obj as one line and frees it. */
static int print_json(cJSON *obj) {
  char *text = obj ? cJSON_PrintUnformatted(obj) : NULL;
  cJSON_Delete(obj);
  if (!text) {
    fprintf(stderr, "chisel: out of memory\n");
    return 1;
  }
  puts(text);
  free(text);
  return 0;
}

static cJSON *json_array(const double *v, int n) {
  cJSON *a = cJSON_CreateArray();
  for (int i = 0; i < n; i++) cJSON_AddItemToArray(a, cJSON_CreateNumber(isfinite(v[i]) ? v[i] : 0.0));
  return a;
}

static const char *profile_name(const ch_profile *p) {
  static const char *names[] = {"v", "u", "box", "ridge", "bevel", "custom"};
  return names[p->kind];
}

static int info_svg(const char *path, int json) {
  ch_error err = cli_error();
  ch_curve_set set;
  if (ch_curves_read_svg_ex(path, &svg_desc, &set, &err)) return cli_fail(&err);
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
  if (json) {
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "file", path);
    cJSON_AddStringToObject(o, "type", "svg");
    cJSON_AddItemToObject(o, "viewbox", json_array(set.viewbox, 4));
    cJSON_AddNumberToObject(o, "curves", set.num_curves);
    cJSON_AddNumberToObject(o, "grooves", grooves);
    cJSON_AddNumberToObject(o, "steps", steps);
    cJSON_AddNumberToObject(o, "subpaths", set.num_subpaths);
    cJSON_AddNumberToObject(o, "closed_subpaths", closed);
    cJSON_AddNumberToObject(o, "segments", set.num_segments);
    cJSON_AddNumberToObject(o, "lines", lines);
    cJSON_AddItemToObject(o, "uv_bounds", json_array(b, 4));
    cJSON_AddNumberToObject(o, "fills_united", set.fills_united);
    cJSON_AddNumberToObject(o, "fills_dropped", set.fills_dropped);
    cJSON *list = cJSON_AddArrayToObject(o, "curve_list");
    for (int i = 0; i < set.num_curves; i++) {
      const ch_curve *c = &set.curves[i];
      cJSON *j = cJSON_CreateObject();
      double length = 0.0;
      for (int k = 0; k < c->num_segments; k++) length += ch_bezier_length(set.segments[c->first_segment + k].p);
      cJSON_AddStringToObject(j, "id", c->id);
      cJSON_AddStringToObject(j, "element", c->element);
      cJSON_AddNumberToObject(j, "line", c->source_line);
      cJSON_AddStringToObject(j, "kind", c->kind == CH_CURVE_GROOVE ? "groove" : "step");
      cJSON_AddStringToObject(j, "decided_by", c->decided_by);
      if (c->kind == CH_CURVE_GROOVE) {
        cJSON_AddStringToObject(j, "profile", profile_name(&c->profile));
        cJSON_AddNumberToObject(j, "width_uv", c->width);
        cJSON_AddStringToObject(j, "width_from", c->width_from);
        cJSON_AddNumberToObject(j, "depth", c->depth);
      } else {
        cJSON_AddNumberToObject(j, "left", c->left);
        cJSON_AddNumberToObject(j, "right", c->right);
      }
      cJSON_AddNumberToObject(j, "segments", c->num_segments);
      cJSON_AddNumberToObject(j, "subpaths", c->num_subpaths);
      cJSON_AddNumberToObject(j, "length_uv", length);
      cJSON_AddItemToArray(list, j);
    }
    ch_curves_free(&set);
    return print_json(o);
  }
  printf("%s: SVG curve file\n", path);
  printf("  viewBox         %g %g %g %g\n", set.viewbox[0], set.viewbox[1], set.viewbox[2], set.viewbox[3]);
  printf("  curves          %d (%d groove, %d step)\n", set.num_curves, grooves, steps);
  printf("  subpaths        %d (%d closed, %d open)\n", set.num_subpaths, closed, set.num_subpaths - closed);
  printf("  segments        %d (%d lines, %d quadratics)\n", set.num_segments, lines, set.num_segments - lines);
  printf("  UV bounds       [%.6g, %.6g] .. [%.6g, %.6g] (control polygons)\n", b[0], b[1], b[2], b[3]);
  if (set.fills_united)
    printf(
        "  fills united    %d filled shape%s redrawn as the outline of the painted region (%d merged away; "
        "docs/svg.md)\n",
        set.fills_united, set.fills_united == 1 ? "" : "s", set.fills_dropped);
  if (grooves) {
    printf("  profiles       ");
    for (int k = 0; k < 6; k++)
      if (per_profile[k]) printf(" %s %d", profile_name(&(ch_profile){.kind = (ch_profile_kind)k}), per_profile[k]);
    printf("\n");
  }
  printf("  %-4s %-20s %-6s %-7s %9s %9s %8s %10s  %s\n", "#", "id", "kind", "profile", "width(UV)", "depth/L,R",
         "segments", "length(UV)", "decided by (kind; width)");
  for (int i = 0; i < set.num_curves; i++) {
    const ch_curve *c = &set.curves[i];
    char values[48];
    if (c->kind == CH_CURVE_GROOVE)
      snprintf(values, sizeof values, "%g", c->depth);
    else
      snprintf(values, sizeof values, "%g,%g", c->left, c->right);
    double length = 0.0;
    for (int k = 0; k < c->num_segments; k++) length += ch_bezier_length(set.segments[c->first_segment + k].p);
    printf("  %-4d %-20.20s %-6s %-7s %9.4g %9s %8d %10.4g  %s%s%s\n", i, c->id[0] ? c->id : "-",
           c->kind == CH_CURVE_GROOVE ? "groove" : "step",
           c->kind == CH_CURVE_GROOVE ? profile_name(&c->profile) : "-", c->width, values, c->num_segments, length,
           c->decided_by, c->kind == CH_CURVE_GROOVE ? "; " : "", c->kind == CH_CURVE_GROOVE ? c->width_from : "");
  }
  ch_curves_free(&set);
  return 0;
}

/* Whether path is a mesh chisel wrote: an OBJ whose first line is
 * "# chisel", or a .glb whose JSON chunk starts as chisel's writer starts
 * it (mesh/ch_mesh_gltf.c). */
static int is_chisel_output(const char *path, const char *ext) {
  int obj = !strcmp(ext, "obj");
  if (!obj && strcmp(ext, "glb") != 0) return 0;
  static const char glb_json[] = "{\"asset\":{\"version\":\"2.0\",\"generator\":\"chisel ";
  FILE *f = fopen(path, "rb");
  if (!f) return 0;
  char head[128] = {0};
  size_t n = fread(head, 1, sizeof head - 1, f);
  fclose(f);
  if (obj) return n >= 9 && !memcmp(head, "# chisel\n", 9);
  return n >= 20 + sizeof glb_json - 1 && !memcmp(head, "glTF", 4) && !memcmp(head + 16, "JSON", 4) &&
         !memcmp(head + 20, glb_json, sizeof glb_json - 1);
}

static int info_mesh(const char *path, const char *ext, int json) {
  ch_error err = cli_error();
  ch_mesh mesh;
  if (ch_mesh_read(path, &mesh, &err)) return cli_fail(&err);
  ch_mesh_report r;
  /* A displaced mesh of chisel's has walls: vertical faces without UV
   * area, and zero-area ones where a wall's height falls to nothing
   * (docs/spec.md §4). Those are its design, not a base mesh's defects: its
   * report says so instead of warning (the other warnings stay). */
  int output = is_chisel_output(path, ext);
  ch_status st = output ? ch_mesh_validate_displaced(&mesh, path, &r, &err) : ch_mesh_validate(&mesh, path, &r, &err);
  if (st && st != CH_ERR_INPUT) {
    ch_mesh_free(&mesh);
    return cli_fail(&err);
  }
  if (json) {
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "file", path);
    cJSON_AddStringToObject(o, "type", ext);
    cJSON_AddNumberToObject(o, "positions", mesh.num_positions);
    cJSON_AddNumberToObject(o, "faces", mesh.num_faces);
    cJSON_AddNumberToObject(o, "triangles", r.num_triangles);
    cJSON_AddNumberToObject(o, "quads", r.num_quads);
    cJSON_AddNumberToObject(o, "polygons", r.num_polygons);
    cJSON_AddNumberToObject(o, "corners", mesh.num_corners);
    if (mesh.num_faces > 0) {
      cJSON_AddItemToObject(o, "bounds_min", json_array(r.bounds_min, 3));
      cJSON_AddItemToObject(o, "bounds_max", json_array(r.bounds_max, 3));
    }
    cJSON_AddNumberToObject(o, "uvs", mesh.corner_uv ? mesh.num_uvs : 0);
    if (mesh.corner_uv) {
      cJSON_AddItemToObject(o, "uv_min", json_array(r.uv_min, 2));
      cJSON_AddItemToObject(o, "uv_max", json_array(r.uv_max, 2));
      cJSON_AddNumberToObject(o, "uvs_outside_unit_square", r.num_uvs_outside);
      cJSON_AddNumberToObject(o, "uv_coverage", r.uv_coverage);
      cJSON_AddNumberToObject(o, "uv_overlap", r.uv_overlap);
      cJSON_AddNumberToObject(o, "uv_charts", r.num_charts);
    }
    cJSON_AddBoolToObject(o, "normals", mesh.corner_normal != NULL);
    cJSON_AddNumberToObject(o, "components", r.num_components);
    cJSON_AddNumberToObject(o, "boundary_edges", r.num_boundary_edges);
    cJSON_AddNumberToObject(o, "nonmanifold_edges", r.num_nonmanifold_edges);
    cJSON_AddNumberToObject(o, "nonmanifold_vertices", r.num_nonmanifold_vertices);
    cJSON_AddNumberToObject(o, "zero_area_faces", r.num_degenerate_faces);
    cJSON_AddNumberToObject(o, "zero_uv_area_faces", r.num_zero_uv_area_faces);
    cJSON_AddBoolToObject(o, "chisel_output", output);
    ch_mesh_free(&mesh);
    if (st) return cli_fail(&err);
    return print_json(o);
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
  printf("  degenerate      %d faces with zero area, %d with zero UV area%s\n", r.num_degenerate_faces,
         r.num_zero_uv_area_faces,
         output ? " (a chisel output: its walls have no UV area, and zero-area faces end walls whose height "
                  "falls to nothing)"
                : "");
  ch_mesh_free(&mesh);
  if (st) return cli_fail(&err);
  return 0;
}

static int info_exr(const char *path, int json) {
  ch_error err = cli_error();
  ch_image img;
  if (ch_exr_read(path, &img, &err)) return cli_fail(&err);
  if (json) {
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "file", path);
    cJSON_AddStringToObject(o, "type", "exr");
    cJSON_AddNumberToObject(o, "width", img.width);
    cJSON_AddNumberToObject(o, "height", img.height);
    cJSON *chans = cJSON_AddArrayToObject(o, "channels");
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
      cJSON *j = cJSON_CreateObject();
      cJSON_AddStringToObject(j, "name", img.names[c]);
      if (bad < n) {
        cJSON_AddNumberToObject(j, "min", lo);
        cJSON_AddNumberToObject(j, "max", hi);
      }
      cJSON_AddNumberToObject(j, "non_finite", (double)bad);
      cJSON_AddItemToArray(chans, j);
    }
    ch_image_free(&img);
    return print_json(o);
  }
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
  int rc = 0, json = 0, files = 0;
  for (int i = 1; i < argc; i++) {
    if (!strcmp(argv[i], "--json")) {
      json = 1;
      argv[i] = NULL;
    } else if (!strcmp(argv[i], "--fill-height")) {
      const char *v = cli_option_value("info", argc, argv, &i);
      if (!v || cli_parse_fill_height("info", v, &svg_desc)) return 2;
      argv[i - 1] = argv[i] = NULL;
    } else if (argv[i][0] == '-' && argv[i][1]) {
      return cli_usage_error("info", "unknown option '%s'", argv[i]);
    } else {
      files++;
    }
  }
  if (!files) return cli_usage_error("info", "missing FILE");
  for (int i = 1; i < argc; i++) {
    if (!argv[i]) continue;
    char ext[16];
    ch_path_extension(argv[i], ext, sizeof ext);
    int r;
    if (!strcmp(ext, "svg"))
      r = info_svg(argv[i], json);
    else if (!strcmp(ext, "exr"))
      r = info_exr(argv[i], json);
    else
      r = info_mesh(argv[i], ext[0] ? ext : "unknown", json);
    if (r && !rc) rc = r;
    fflush(stdout);
  }
  return rc;
}

const cli_command cli_info_command = {"info", "describe a mesh, a curve file or an EXR image", usage, run};
