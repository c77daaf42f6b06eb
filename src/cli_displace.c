/* chisel displace: base mesh + feature curves -> displaced mesh (docs/spec.md §5). */
#include <cjson/cJSON.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include "ch_exr.h"
#include "ch_mesh.h"
#include "ch_pipeline.h"
#include "ch_udim.h"
#include "ch_png.h"
#include "cli.h"

static const char usage[] =
    "usage: chisel displace BASE.obj CURVES.svg -o OUT.obj [--target-tris N] [--max-tris M] [--res R]\n"
    "                      [--scheme bilinear|catmark] [--no-snap] [--exr MAPS.exr]\n"
    "                      [--camera ex,ey,ez,ax,ay,az,fov [--warp-dci]]\n"
    "                      [--snap-to exact|recon5|recon3] [--png P.png] [--ply OUT.ply]\n"
    "                      [--glb OUT.glb] [--height-png H16.png] [--fill-height H] [--stats] [--json]\n"
    "\n"
    "Tessellates the base surface (OpenSubdiv) and displaces it by h = h_step +\n"
    "h_groove (docs/spec.md §3): P = B + h N. Writes OBJ with vt (the original UVs)\n"
    "and vn, binary PLY or glTF 2.0 binary, by -o's extension. BASE may be OBJ, PLY,\n"
    "OFF, STL or glTF 2.0 (.glb, or .gltf with its buffers beside it).\n"
    "\n"
    "  -o, --output FILE  the mesh to write (required): .obj, .ply or .glb (glTF 2.0\n"
    "                     binary: POSITION, NORMAL, TEXCOORD_0, for real-time\n"
    "                     engines); - for OBJ on standard output\n"
    "  --target-tris N    triangles in the output, within 5% (default 520000)\n"
    "  --max-tris M       the embedding's cap: curves that would need more triangles\n"
    "                     stop the run with an error, before time and memory run\n"
    "                     away (default 8 x N + 8388608; large runs take about\n"
    "                     190-460 bytes of memory per triangle)\n"
    "  --res R            resolution of the step curves' diffusion image (default 1024)\n"
    "  --scheme S         base surface: bilinear (default) or catmark (Catmull-Clark)\n"
    "  --no-snap          the naive mesh: no feature embedding (for comparison)\n"
    "  --snap-to C        where step walls go: the exact curves (default), or the\n"
    "                     curves reconstructed from the diffusion image (recon5,\n"
    "                     recon3), which h_step is then read through as well\n"
    "  --camera E,A,FOV   view-dependent texture warp for the camera at eye E\n"
    "                     looking at A with vertical field of view FOV degrees\n"
    "                     (object space; up +z, or +y when looking along z; a\n"
    "                     square frustum): triangles (and, with --exr/--png, the\n"
    "                     maps' texels) move to what the camera sees large; the\n"
    "                     virtual resolution and the visible share go to stderr\n"
    "  --warp-dci         with --camera, also diffuse the step curves in warped UV\n"
    "                     (the paper's way: R x R warped texels; the warp bends the\n"
    "                     diffusion, so smooth steps come out less exact)\n"
    "  --exr FILE         maps on an R x R grid over the UV square (warped UV with\n"
    "                     --camera, where u v give each texel's original UV): h\n"
    "                     (and Y = 0.5 + h / (2 max |h|) for viewers), the geometry\n"
    "                     image (P.x P.y P.z N.x N.y N.z face.X s t) of the base\n"
    "                     surface, evaluated exactly at the texel centres\n"
    "  --png FILE         a preview of h (false colour, hill shaded), in warped UV\n"
    "                     with --camera\n"
    "  --ply FILE         also write binary PLY (- for standard output): one vertex\n"
    "                     per position, so closed where the OBJ is; UVs per face\n"
    "                     corner (texcoord), and per vertex (s t) where unique\n"
    "  --glb FILE         also write glTF 2.0 binary (vertices split where the UV or\n"
    "                     the normal differs, as glTF needs)\n"
    "  --height-png FILE  h as a 16-bit grey PNG (0.5 is h = 0; the scale is in\n"
    "                     the PNG and the result line), in warped UV with --camera\n"
    "  --fill-height H    the height of filled shapes drawn without data-\n"
    "                     attributes (docs/svg.md; default 0.01)\n"
    "  --stats            stage timings on stderr\n"
    "  --json             the result and the statistics as one JSON object on\n"
    "                     standard output (not with -o - or --ply -)\n"
    "\n"
    "With feature embedding (the default) the mesh is cut along every wall and\n"
    "crease of h: chains of edges lie on the curves and on the break lines of\n"
    "every groove profile, wall vertices are split in two and joined by\n"
    "vertical triangles, and normals are split there. The count of triangles\n"
    "includes what the cut adds.\n";

/* Warnings kept back (one per line) until the input has passed. */
typedef enum { FORMAT_UNKNOWN, FORMAT_OBJ, FORMAT_PLY, FORMAT_GLB } mesh_format;

/* A mesh format by the path's extension (any case). */
static mesh_format format_of(const char *path) {
  const char *dot = strrchr(path, '.'), *slash = strrchr(path, '/');
  if (!dot || (slash && dot < slash)) return FORMAT_UNKNOWN;
  static const struct {
    const char *ext;
    mesh_format format;
  } known[] = {{".obj", FORMAT_OBJ}, {".ply", FORMAT_PLY}, {".glb", FORMAT_GLB}};
  for (size_t i = 0; i < sizeof known / sizeof known[0]; i++)
    if (!strcasecmp(dot, known[i].ext)) return known[i].format;
  return FORMAT_UNKNOWN;
}

/* cli_check_files with every existing file that would be a UDIM tile's
 * curves for the CURVES argument (any tile, either spelling, see
 * ch_udim_curve_path) counted as an input too: which tiles the mesh spans
 * is known only after reading it, and no output may replace a tile's file.
 * Prints one line and returns 2 (1: out of memory) on a problem; else 0. */
static int check_files_with_tiles(const char *cmd, const cli_file *inputs, int num_inputs, const char *curves,
                         const cli_file *outputs, int num_outputs) {
  /* Which tiles are read is known only once the mesh is read; any file
   * that would be a tile's (1001 + u + 10 v, u < 10, v < 100, both
   * spellings) and exists is an input, so no output replaces it. */
  enum { FIRST = 1001, LAST = 1001 + 9 + 10 * 99, NAME = 64 };
  typedef struct tile_file {
    char option[NAME];
    char path[4096];
  } tile_file;
  tile_file *tf = NULL;
  int n = 0, cap = 0;
  for (int t = FIRST; curves && t <= LAST; t++)
    for (int v = 0; v < 2; v++) {
      char path[4096];
      struct stat st;
      if (!ch_udim_curve_path(curves, t, path, sizeof path, v) || stat(path, &st) != 0) continue;
      if (n == cap) {
        cap = cap ? 2 * cap : 8;
        tile_file *g = realloc(tf, (size_t)cap * sizeof *g);
        if (!g) {
          free(tf);
          fprintf(stderr, "chisel: out of memory\n");
          return 1;
        }
        tf = g;
      }
      snprintf(tf[n].option, NAME, "the curves of UDIM tile %d", t);
      snprintf(tf[n].path, sizeof tf[n].path, "%s", path);
      n++;
    }
  cli_file *all = malloc((size_t)(num_inputs + n) * sizeof *all);
  if (!all) {
    free(tf);
    fprintf(stderr, "chisel: out of memory\n");
    return 1;
  }
  for (int i = 0; i < num_inputs; i++) all[i] = inputs[i];
  for (int i = 0; i < n; i++) all[num_inputs + i] = (cli_file){tf[i].option, tf[i].path};
  int rc = cli_check_files(cmd, all, num_inputs + n, outputs, num_outputs);
  free(all);
  free(tf);
  return rc;
}

/* The process's resident bytes now (Linux's /proc/self/statm; 0 where it
 * cannot be read). */
static double resident_bytes(void) {
  FILE *f = fopen("/proc/self/statm", "r");
  long size = 0, resident = 0;
  int got = f ? fscanf(f, "%ld %ld", &size, &resident) : 0;
  if (f) fclose(f);
  return got == 2 ? (double)resident * (double)sysconf(_SC_PAGESIZE) : 0.0;
}

static int run(int argc, char **argv) {
  /* What the program holds before it reads anything (its code and
   * libraries, about 10 MB): not part of what each triangle costs. */
  double start_bytes = resident_bytes();
  const char *cmd = "displace";
  const char *base = NULL, *svg = NULL, *out = NULL, *exr = NULL, *png = NULL, *ply = NULL, *png16 = NULL;
  const char *glb = NULL;
  long target = 0, res = 1024, max_tris = 0; /* (target 0: the library's default, named so in its warnings) */
  int scheme = CH_SCHEME_BILINEAR, no_snap = 0, stats = 0, snap_to = CH_RECON_EXACT, has_camera = 0, warp_dci = 0;
  int json = 0;
  ch_svg_desc svg_desc = {0};
  double camera_values[7];
  for (int i = 1; i < argc; i++) {
    const char *a = argv[i];
    if (!strcmp(a, "--target-tris")) {
      const char *v = cli_option_value(cmd, argc, argv, &i);
      if (!v || cli_parse_int(cmd, a, v, 1, 100000000, &target)) return 2;
    } else if (!strcmp(a, "--max-tris")) {
      const char *v = cli_option_value(cmd, argc, argv, &i);
      if (!v || cli_parse_int(cmd, a, v, 1, 700000000, &max_tris)) return 2;
    } else if (!strcmp(a, "--res")) {
      const char *v = cli_option_value(cmd, argc, argv, &i);
      if (!v || cli_parse_int(cmd, a, v, 16, 16384, &res)) return 2;
    } else if (!strcmp(a, "--scheme")) {
      const char *v = cli_option_value(cmd, argc, argv, &i);
      if (!v) return 2;
      if (!strcmp(v, "bilinear"))
        scheme = CH_SCHEME_BILINEAR;
      else if (!strcmp(v, "catmark"))
        scheme = CH_SCHEME_CATMARK;
      else
        return cli_usage_error(cmd, "unknown scheme '%s' (bilinear or catmark)", v);
    } else if (!strcmp(a, "--camera")) {
      const char *v = cli_option_value(cmd, argc, argv, &i);
      if (!v || cli_parse_doubles(cmd, a, v, 7, camera_values)) return 2;
      has_camera = 1;
    } else if (!strcmp(a, "-o") || !strcmp(a, "--output")) {
      if (!(out = cli_option_value(cmd, argc, argv, &i))) return 2;
    } else if (!strcmp(a, "--exr")) {
      if (!(exr = cli_option_value(cmd, argc, argv, &i))) return 2;
    } else if (!strcmp(a, "--png")) {
      if (!(png = cli_option_value(cmd, argc, argv, &i))) return 2;
    } else if (!strcmp(a, "--glb")) {
      if (!(glb = cli_option_value(cmd, argc, argv, &i))) return 2;
    } else if (!strcmp(a, "--ply")) {
      if (!(ply = cli_option_value(cmd, argc, argv, &i))) return 2;
    } else if (!strcmp(a, "--height-png")) {
      if (!(png16 = cli_option_value(cmd, argc, argv, &i))) return 2;
    } else if (!strcmp(a, "--fill-height")) {
      const char *v = cli_option_value(cmd, argc, argv, &i);
      if (!v || cli_parse_fill_height(cmd, v, &svg_desc)) return 2;
    } else if (!strcmp(a, "--json")) {
      json = 1;
    } else if (!strcmp(a, "--snap-to")) {
      const char *v = cli_option_value(cmd, argc, argv, &i);
      if (!v) return 2;
      snap_to = ch_recon_method_parse(v);
      if (snap_to != CH_RECON_EXACT && snap_to != CH_RECON_5X5 && snap_to != CH_RECON_3X3)
        return cli_usage_error(cmd, "--snap-to: unknown curves '%s' (exact, recon5 or recon3)", v);
    } else if (!strcmp(a, "--no-snap")) {
      no_snap = 1;
    } else if (!strcmp(a, "--warp-dci")) {
      warp_dci = 1;
    } else if (!strcmp(a, "--stats")) {
      stats = 1;
    } else if (a[0] == '-' && a[1]) {
      return cli_usage_error(cmd, "unknown option '%s'", a);
    } else if (!base) {
      base = a;
    } else if (!svg) {
      svg = a;
    } else {
      return cli_usage_error(cmd, "unexpected argument '%s'", a);
    }
  }
  if (!base) return cli_usage_error(cmd, "missing the base mesh BASE.obj");
  if (!svg) return cli_usage_error(cmd, "missing the curve file CURVES.svg");
  if (!out) return cli_usage_error(cmd, "missing -o OUT.obj");
  if (cli_is_stdout(glb)) return cli_refuse_stdout(cmd, "--glb", "a glTF binary");
  if (warp_dci && !has_camera) return cli_usage_error(cmd, "--warp-dci needs --camera");
  long aimed = target ? target : (long)CH_DISPLACE_DEFAULT_TARGET;
  if (max_tris && max_tris < aimed)
    return cli_usage_error(cmd, "--max-tris %ld is below --target-tris %ld", max_tris, aimed);
  /* Standard output takes one mesh, OBJ or PLY; EXR and PNG need seeks or
   * are not what a pipe expects. */
  if (cli_is_stdout(exr)) return cli_refuse_stdout(cmd, "--exr", "an EXR");
  if (cli_is_stdout(png)) return cli_refuse_stdout(cmd, "--png", "a PNG");
  if (cli_is_stdout(png16)) return cli_refuse_stdout(cmd, "--height-png", "a PNG");
  if (json && (cli_is_stdout(out) || cli_is_stdout(ply)))
    return cli_usage_error(cmd, "--json and a mesh on standard output (-) cannot share it");
  if (out && ply && cli_is_stdout(out) && cli_is_stdout(ply))
    return cli_usage_error(cmd, "-o and --ply name the same standard output");
  const cli_file in_files[] = {{"BASE.obj", base}, {"CURVES.svg", svg}};
  const cli_file out_files[] = {{"-o", cli_is_stdout(out) ? NULL : out},
                                {"--exr", exr},
                                {"--png", png},
                                {"--ply", cli_is_stdout(ply) ? NULL : ply},
                                {"--height-png", png16},
                                {"--glb", glb}};
  int rc = check_files_with_tiles(cmd, in_files, 2, svg, out_files, 6);
  if (rc) return rc;
  /* The format of -o by its extension (after the checks that an output
   * is no input, device or folder); --ply and --glb name theirs. */
  mesh_format out_format = cli_is_stdout(out) ? FORMAT_OBJ : format_of(out);
  if (out_format == FORMAT_UNKNOWN) {
    const char *dot = strrchr(out, '.'), *slash = strrchr(out, '/');
    return cli_usage_error(cmd, "-o %s: %s (.obj, .ply or .glb)", out,
                           dot && (!slash || dot > slash) ? "unknown mesh format" : "no extension to tell the format");
  }

  ch_error err = cli_error();
  ch_camera camera;
  if (has_camera && ch_camera_init(&camera, camera_values, &err)) return cli_fail(&err);
  ch_displace_desc desc = {.base_path = base,
                           .curves_path = svg,
                           .svg = svg_desc,
                           .target_triangles = target,
                           .max_triangles = max_tris,
                           .resolution = (int)res,
                           .scheme = (ch_scheme)scheme,
                           .no_snap = no_snap,
                           .snap_to = (ch_recon_method)snap_to,
                           .camera = has_camera ? &camera : NULL,
                           .warp_dci = warp_dci,
                           .maps = (exr ? CH_DISPLACE_GEOMETRY_MAPS : 0) | (png || png16 ? CH_DISPLACE_HEIGHT_MAP : 0),
                           .progress = cli_progress_start(cmd)};
  ch_displace_result r;
  if (ch_pipeline_displace(&desc, &r, &err)) return cli_fail(&err);
  const ch_mesh *result = &r.mesh;
  double t_write = omp_get_wtime(), height_scale = 0.0;
  /* Files first; a mesh for standard output last, once nothing else can
   * fail (a stream cannot be taken back). */
  ch_status st = CH_OK;
  if (!cli_is_stdout(out)) {
    cli_progress_stage("writing %s", out);
    st = out_format == FORMAT_PLY   ? ch_mesh_write_ply(out, result, &err)
         : out_format == FORMAT_GLB ? ch_mesh_write_glb(out, result, &err)
                                    : ch_mesh_write_obj(out, result, &err);
  }
  if (!st && glb) {
    cli_progress_stage("writing %s", glb);
    st = ch_mesh_write_glb(glb, result, &err);
  }
  if (!st && ply && !cli_is_stdout(ply)) {
    cli_progress_stage("writing %s", ply);
    st = ch_mesh_write_ply(ply, result, &err);
  }
  if (!st && exr) {
    ch_displace_exr x;
    ch_displace_exr_desc(&r, &x, &height_scale);
    cli_progress_stage("writing %s", exr);
    st = ch_exr_write(exr, &r.maps, &x.desc, &err);
  }
  const ch_image *hmap = &r.height;
  if (!st && png) {
    cli_progress_stage("writing %s", png);
    st = ch_png_write_height(png, ch_image_plane(hmap, 0), hmap->width, hmap->height, &err);
  }
  if (!st && png16)
    st = ch_png_write_height16(png16, ch_image_plane(hmap, 0), hmap->width, hmap->height, &height_scale, &err);
  if (!st && cli_is_stdout(out)) st = ch_mesh_write_obj_stream(stdout, "(standard output)", result, &err);
  if (!st && cli_is_stdout(ply)) st = ch_mesh_write_ply_stream(stdout, "(standard output)", result, &err);
  t_write = omp_get_wtime() - t_write;
  cli_progress_done();
  if (st) {
    ch_displace_result_free(&r);
    return cli_fail(&err);
  }
  const ch_displace_timings *t = &r.seconds;
  const ch_embed_stats *e = &r.embed;
  /* The process's peak resident memory (Linux reports it in kB): what the
   * run needed, reading and writing included. */
  struct rusage usage;
  double peak_bytes = getrusage(RUSAGE_SELF, &usage) == 0 ? 1024.0 * (double)usage.ru_maxrss : 0.0;
  if (r.warped && !cli_quiet) {
    const ch_warp_stats *ws = &r.warp;
    fprintf(stderr,
            "chisel: warp: virtual resolution %.0f x %.0f (%.2fx, %.2fx --res %d); visible part %.1f%% of the "
            "texels (%.1f%% unwarped), %.1f%% of the triangles; %d of %d cage triangles visible, %d with curves; "
            "warp %.0f ms (%.1f%% of the run)\n",
            r.resolution * ws->max_slope[0], r.resolution * ws->max_slope[1], ws->max_slope[0], ws->max_slope[1],
            r.resolution, 100.0 * ws->visible_share, 100.0 * ws->unwarped_share,
            100.0 * r.warp_visible_triangle_share, ws->visible_triangles, r.warp_cage_triangles,
            ws->needy_triangles, 1e3 * r.warp_seconds, 100.0 * r.warp_seconds / (t->total + t_write));
  }
  if (stats) {
    fprintf(stderr,
            "chisel: displace %d triangles: read %.0f ms, surface %.0f ms, h setup %.0f ms, %s %.0f ms "
            "(%d pass%s; kept: %d base triangles, %s %.0f ms), maps %.0f ms, write %.0f ms; h in [%.4g, %.4g]; "
            "peak memory %.0f MB (%.0f bytes per triangle; %.0f per triangle above the %.0f MB the program held "
            "at start)\n",
            result->num_faces, 1e3 * t->read, 1e3 * t->surface, 1e3 * t->height,
            no_snap ? "tessellate and displace" : "tessellate and embed", 1e3 * t->tessellate, r.passes,
            r.passes > 1 ? "es" : "", r.base_triangles, no_snap ? "displace" : "embed", 1e3 * t->displace,
            1e3 * t->maps, 1e3 * t_write, r.min_h, r.max_h, peak_bytes / 1e6,
            result->num_faces > 0 ? peak_bytes / result->num_faces : 0.0,
            result->num_faces > 0 ? fmax(0.0, peak_bytes - start_bytes) / result->num_faces : 0.0, start_bytes / 1e6);
    if (!no_snap)
      fprintf(stderr,
              "chisel: embed: %d refinement rounds (%d edges split), %d boundary points (%d on walls), %d "
              "junctions, %d wall triangles, %d unresolved (%d on UV seams), u lines every %.2f deg, %d vertices "
              "thinned, %ld triangles added where h is smooth (%ld merged in flat blocks), %d base triangles far from "
              "the features; refine %.0f ms "
              "(setup %.0f, labels %.0f, edges %.0f, crossings %.0f, classify %.0f, split %.0f), cut %.0f ms (thin "
              "%.0f), normals %.0f ms\n",
              e->refine_rounds, e->refined_edges, e->crossings, e->wall_points, e->junctions, e->wall_triangles,
              e->unresolved, e->unresolved_at_seams, e->angle_deg, e->thinned, e->densified, e->merged,
              e->far_triangles, 1e3 * e->seconds_refine, 1e3 * e->seconds_setup, 1e3 * e->seconds_labels,
              1e3 * e->seconds_edges, 1e3 * e->seconds_crossings, 1e3 * e->seconds_classify, 1e3 * e->seconds_split,
              1e3 * e->seconds_cut, 1e3 * e->seconds_thin, 1e3 * e->seconds_normals);
  }
  double total = t->total + t_write;
  const char *written[6] = {out, ply, exr, png, png16, glb};
  char what[1024] = "";
  size_t len = 0;
  for (int i = 0; i < 6; i++)
    if (written[i])
      len += (size_t)snprintf(what + len, len < sizeof what ? sizeof what - len : 0, "%s%s", len ? ", " : "",
                              cli_is_stdout(written[i]) ? (i == 0 ? "OBJ to standard output" : "PLY to standard output")
                                                        : written[i]);
  char scale_note[96] = "";
  if (png16 || exr)
    snprintf(scale_note, sizeof scale_note, "; %s: 0.5 + h / (2 x %.6g)",
             png16 && exr ? "Y and the height PNG" : exr ? "Y" : "the height PNG", height_scale);
  cli_result("wrote %s: %d triangles, %d vertices, h in [%.4g, %.4g]%s, in %.2f s", what, result->num_faces,
             result->num_positions, r.min_h, r.max_h, scale_note, total);
  if (json) {
    cJSON *o = cJSON_CreateObject();
    cJSON *files = cJSON_AddArrayToObject(o, "outputs");
    for (int i = 0; i < 6; i++)
      if (written[i]) cJSON_AddItemToArray(files, cJSON_CreateString(written[i]));
    cJSON_AddNumberToObject(o, "triangles", result->num_faces);
    cJSON_AddNumberToObject(o, "vertices", result->num_positions);
    cJSON_AddNumberToObject(o, "target_triangles", (double)r.target_triangles);
    cJSON_AddNumberToObject(o, "base_triangles", r.base_triangles);
    cJSON_AddNumberToObject(o, "passes", r.passes);
    cJSON_AddNumberToObject(o, "h_min", r.min_h);
    cJSON_AddNumberToObject(o, "h_max", r.max_h);
    if (png16 || exr) cJSON_AddNumberToObject(o, "height_scale", height_scale);
    cJSON_AddBoolToObject(o, "snapped", r.snapped);
    cJSON *sec = cJSON_AddObjectToObject(o, "seconds");
    cJSON_AddNumberToObject(sec, "total", total);
    cJSON_AddNumberToObject(sec, "read", t->read);
    cJSON_AddNumberToObject(sec, "surface", t->surface);
    cJSON_AddNumberToObject(sec, "h_setup", t->height);
    cJSON_AddNumberToObject(sec, "tessellate", t->tessellate);
    cJSON_AddNumberToObject(sec, "maps", t->maps);
    cJSON_AddNumberToObject(sec, "write", t_write);
    cJSON_AddNumberToObject(o, "peak_memory_bytes", peak_bytes);
    cJSON_AddNumberToObject(o, "peak_bytes_per_triangle", result->num_faces > 0 ? peak_bytes / result->num_faces : 0.0);
    cJSON_AddNumberToObject(o, "start_memory_bytes", start_bytes);
    if (r.snapped) {
      cJSON *ej = cJSON_AddObjectToObject(o, "embed");
      cJSON_AddNumberToObject(ej, "refine_rounds", e->refine_rounds);
      cJSON_AddNumberToObject(ej, "refined_edges", e->refined_edges);
      cJSON_AddNumberToObject(ej, "boundary_points", e->crossings);
      cJSON_AddNumberToObject(ej, "wall_points", e->wall_points);
      cJSON_AddNumberToObject(ej, "junctions", e->junctions);
      cJSON_AddNumberToObject(ej, "wall_triangles", e->wall_triangles);
      cJSON_AddNumberToObject(ej, "unresolved", e->unresolved);
      cJSON_AddNumberToObject(ej, "unresolved_at_seams", e->unresolved_at_seams);
      if (e->unresolved > 0) {
        cJSON *u = cJSON_AddArrayToObject(ej, "unresolved_first_uv");
        for (int k = 0; k < 2; k++) cJSON_AddItemToArray(u, cJSON_CreateNumber(e->unresolved_uv[k]));
        cJSON *b = cJSON_AddArrayToObject(ej, "unresolved_uv_box");
        for (int k = 0; k < 4; k++) cJSON_AddItemToArray(b, cJSON_CreateNumber(e->unresolved_box[k]));
      }
      cJSON_AddNumberToObject(ej, "thinned", e->thinned);
      cJSON_AddNumberToObject(ej, "densified", (double)e->densified);
      cJSON_AddNumberToObject(ej, "merged", (double)e->merged);
      cJSON_AddNumberToObject(ej, "far_triangles", e->far_triangles);
      cJSON_AddNumberToObject(ej, "angle_deg", e->angle_deg);
      cJSON_AddNumberToObject(ej, "seconds_refine", e->seconds_refine);
      cJSON_AddNumberToObject(ej, "seconds_cut", e->seconds_cut);
      cJSON_AddNumberToObject(ej, "seconds_normals", e->seconds_normals);
    }
    if (r.warped) {
      const ch_warp_stats *ws = &r.warp;
      cJSON *wj = cJSON_AddObjectToObject(o, "warp");
      cJSON_AddNumberToObject(wj, "virtual_resolution_u", r.resolution * ws->max_slope[0]);
      cJSON_AddNumberToObject(wj, "virtual_resolution_v", r.resolution * ws->max_slope[1]);
      cJSON_AddNumberToObject(wj, "visible_texel_share", ws->visible_share);
      cJSON_AddNumberToObject(wj, "unwarped_visible_texel_share", ws->unwarped_share);
    }
    char *text = cJSON_PrintUnformatted(o);
    cJSON_Delete(o);
    if (text) puts(text);
    free(text);
  }
  ch_displace_result_free(&r);
  return 0;
}

const cli_command cli_displace_command = {"displace", "displace a base mesh by the curves (OBJ out)", usage, run};
