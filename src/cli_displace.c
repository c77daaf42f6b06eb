/* chisel displace: base mesh + feature curves -> displaced mesh (SPEC §5). */
#include <cjson/cJSON.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ch_curves.h"
#include "ch_displace.h"
#include "ch_embed.h"
#include "ch_exr.h"
#include "ch_geomimage.h"
#include "ch_height.h"
#include "ch_mesh.h"
#include "ch_png.h"
#include "ch_surface.h"
#include "ch_warp.h"
#include "cli.h"
#include "cli_udim.h"

static const char usage[] =
    "usage: chisel displace BASE.obj CURVES.svg -o OUT.obj [--target-tris N] [--res R]\n"
    "                      [--scheme bilinear|catmark] [--no-snap] [--exr MAPS.exr]\n"
    "                      [--camera ex,ey,ez,ax,ay,az,fov [--warp-dci]]\n"
    "                      [--snap-to exact|recon5|recon3] [--png P.png] [--ply OUT.ply]\n"
    "                      [--height-png H16.png] [--fill-height H] [--stats] [--json]\n"
    "\n"
    "Tessellates the base surface (OpenSubdiv) and displaces it by h = h_step +\n"
    "h_groove (SPEC §3): P = B + h N. Writes OBJ with vt (the original UVs) and vn.\n"
    "\n"
    "  -o, --output FILE  the OBJ to write (required; - for standard output)\n"
    "  --target-tris N    triangles in the output, within 5% (default 520000)\n"
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
typedef struct held_warnings {
  char *text;
  size_t len;
} held_warnings;

static void hold_warning(void *user, const char *message) {
  held_warnings *h = user;
  size_t n = strlen(message);
  char *t = realloc(h->text, h->len + n + 2);
  if (!t) return; /* a warning lost, not the run */
  memcpy(t + h->len, message, n);
  t[h->len + n] = '\n';
  t[h->len + n + 1] = '\0';
  h->text = t;
  h->len += n + 1;
}

/* The curves of a UDIM base mesh (cli_udim.h): each tile's file, merged
 * into the atlas the mesh's UVs are mapped to. Prints nothing; fills err. */
static ch_status read_udim_curves(const char *base, const char *arg, const ch_svg_desc *desc, cli_udim *u,
                                  ch_mesh *mesh, ch_curve_set *set, ch_error *err) {
  ch_curve_set *sets = calloc((size_t)u->num_tiles, sizeof *sets);
  if (!sets) return ch_error_set(err, CH_ERR_NOMEM, "out of memory");
  ch_status st = CH_OK;
  double reach = 0.0;
  int open_steps = 0;
  for (int k = 0; k < u->num_tiles && !st; k++) {
    char path[4096], tried[2][4096];
    int found = 0, n = 0;
    for (int v = 0; v < 2 && !found; v++) {
      if (!cli_udim_curve_path(arg, u->tiles[k], path, sizeof path, v)) continue;
      snprintf(tried[n++], sizeof tried[0], "%s", path);
      FILE *fp = fopen(path, "rb");
      if (fp) fclose(fp), found = 1;
    }
    if (!found) {
      char tiles[512] = "";
      for (int j = 0; j < u->num_tiles && strlen(tiles) < 480; j++)
        snprintf(tiles + strlen(tiles), sizeof tiles - strlen(tiles), "%s%d", j ? ", " : "", u->tiles[j]);
      st = ch_error_set(err, CH_ERR_INPUT,
                        "%s: UVs span UDIM tiles %s: no curve file for tile %d (looked for %s%s%s; one file per "
                        "tile, NAME.%d.svg or NAME_%d.svg, see docs/udim.md)",
                        base, tiles, u->tiles[k], n ? tried[0] : arg, n > 1 ? " and " : "", n > 1 ? tried[1] : "",
                        u->tiles[k], u->tiles[k]);
      break;
    }
    st = ch_curves_read_svg_ex(path, desc, &sets[k], err);
    if (!st) reach = fmax(reach, cli_udim_reach(&sets[k])), open_steps |= cli_udim_open_steps(&sets[k]);
  }
  if (!st) {
    cli_udim_layout(u, reach);
    st = cli_udim_to_atlas(mesh, u, err);
  }
  if (!st) st = cli_udim_merge(sets, u, set, err);
  if (!st && open_steps)
    ch_warn(err, "%s: open step curves, or steps with a value outside them, are diffused over all the UDIM tiles "
            "as one image, so they may reach into a neighbouring tile (closed fills do not)", arg);
  for (int k = 0; k < u->num_tiles; k++) ch_curves_free(&sets[k]);
  free(sets);
  return st;
}

/* --camera's warp: W on 256 intervals per axis; its cage, the base surface
 * tessellated to 2 x 128^2 triangles or more, so the cage map follows W
 * within a knot on the plane (a 256^2 cage gives the same slopes to 3% at
 * three times the cost: 85 against 25 ms, most of it the triangle grids). */
enum { WARP_INTERVALS = 256, WARP_CAGE_SIDE = 128 };
/* Below this gain in texel density (the product of W's largest slopes) the
 * warp is left out: on views of the whole surface it only trades accuracy
 * in one part for another (measured: bench/warp.sh, full views). */
#define WARP_LEAST_GAIN 1.5

/* The EXR attributes of a warp: chisel:space, chisel:warp (the virtual
 * resolution and visible share), chisel:warp_u and chisel:warp_v (W at the
 * knots i / n), as four NUL-terminated strings in one block. */
static char *warp_attributes(const ch_warp *w, int res) {
  size_t cap = 256 + 2 * 24 * ((size_t)w->n + 1), len = 0;
  char *text = malloc(cap);
  if (!text) return NULL;
  len += (size_t)snprintf(text + len, cap - len, "warped UV (u v layers: the original UV)") + 1;
  len += (size_t)snprintf(text + len, cap - len,
                          "virtual resolution %.0f x %.0f; visible share %.4f (unwarped %.4f); intervals %d",
                          res * w->stats.max_slope[0], res * w->stats.max_slope[1], w->stats.visible_share,
                          w->stats.unwarped_share, w->n) +
         1;
  for (int axis = 0; axis < 2; axis++) {
    const double *k = axis == 0 ? w->wu : w->wv;
    for (int i = 0; i <= w->n; i++) len += (size_t)snprintf(text + len, cap - len, i ? " %.9g" : "%.9g", k[i]);
    len++;
  }
  return text;
}

/* The view-dependent warp of --camera: the cage, W from the camera. A
 * camera that sees no part of the surface holding curves leaves out zeroed
 * (out->n == 0: the run goes on unwarped) with a warning. */
static ch_status build_warp(const ch_surface *surface, const ch_camera *cam, const ch_curve_set *set,
                            const char *base, ch_warp *out, ch_error *err) {
  ch_tess_cage_arrays arrays;
  ch_status st = ch_tess_cage(surface, 2L * WARP_CAGE_SIDE * WARP_CAGE_SIDE, &arrays, err);
  if (st) return st;
  ch_warp_cage cage = {.num_triangles = arrays.num_triangles, .uv = arrays.uv, .position = arrays.position};
  ch_warp_desc wd = {.intervals = WARP_INTERVALS};
  st = ch_warp_build(cam, &cage, set, &wd, out, err);
  ch_tess_cage_free(&arrays);
  if (st) return st;
  const ch_warp_stats *ws = &out->stats;
  if (ws->needy_triangles == 0) {
    ch_warn(err, "%s: --camera sees %s; no warp", base,
            ws->visible_triangles == 0
                ? "no part of the surface (all of it is behind the eye, outside the view or facing away)"
                : "no curves on the surface");
    ch_warp_free(out);
  } else if (ws->max_slope[0] * ws->max_slope[1] < WARP_LEAST_GAIN) {
    /* A view of the whole surface: even density serves all it sees best. */
    ch_warn(err, "%s: --camera sees the surface about evenly (the warp would give %.2fx the texels at most); no warp",
            base, ws->max_slope[0] * ws->max_slope[1]);
    ch_warp_free(out);
  } else if (ws->folded_triangles > 0) {
    ch_warn(err, "%s: %d cage triangles fold over in warped UV (thin triangles across many warp intervals); the "
            "lowest-numbered one decides there", base, ws->folded_triangles);
  }
  return CH_OK;
}

static int run(int argc, char **argv) {
  const char *cmd = "displace";
  const char *base = NULL, *svg = NULL, *out = NULL, *exr = NULL, *png = NULL, *ply = NULL, *png16 = NULL;
  long target = 520000, res = 1024;
  int scheme = CH_SCHEME_BILINEAR, no_snap = 0, stats = 0, snap_to = CH_RECON_EXACT, has_camera = 0, warp_dci = 0;
  int json = 0;
  ch_svg_desc svg_desc = {0};
  double camera_values[7];
  for (int i = 1; i < argc; i++) {
    const char *a = argv[i];
    if (!strcmp(a, "--target-tris")) {
      const char *v = cli_option_value(cmd, argc, argv, &i);
      if (!v || cli_parse_int(cmd, a, v, 1, 100000000, &target)) return 2;
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
  if (warp_dci && !has_camera) return cli_usage_error(cmd, "--warp-dci needs --camera");
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
                                {"--height-png", png16}};
  int rc = cli_udim_check_files(cmd, in_files, 2, svg, out_files, 5);
  if (rc) return rc;

  ch_error err = cli_error();
  ch_camera camera;
  if (has_camera && ch_camera_init(&camera, camera_values, &err)) return cli_fail(&err);
  double t0 = omp_get_wtime();
  const ch_progress *progress = cli_progress_start(cmd);
  cli_progress_stage("reading %s", base);
  ch_mesh mesh;
  if (ch_mesh_read(base, &mesh, &err)) return cli_fail(&err);
  /* UDIM: UVs beyond the unit square, in tiles; each tile has its curves,
   * and the pipeline runs on an atlas of the tiles. */
  cli_udim udim;
  if (cli_udim_tiles(&mesh, base, &udim, &err)) {
    ch_mesh_free(&mesh);
    return cli_fail(&err);
  }
  int is_udim = udim.num_tiles > 1 || (udim.num_tiles == 1 && udim.tiles[0] != 1001);
  if (is_udim && (has_camera || exr || png || png16)) {
    ch_mesh_free(&mesh);
    return cli_usage_error(cmd, "%s has UDIM tiles: --camera, --exr, --png and --height-png work on one tile's "
                           "UV square only (chisel sample writes a tile's maps)", base);
  }
  ch_curve_set set;
  ch_status rst = is_udim ? read_udim_curves(base, svg, &svg_desc, &udim, &mesh, &set, &err) : CH_OK;
  if (rst) {
    ch_mesh_free(&mesh);
    return cli_fail(&err);
  }
  if (is_udim) /* each tile keeps its --res texels in its shrunk cell */
    res = (long)fmin(16384.0, ceil((double)res / udim.scale));
  ch_mesh_report report;
  /* A face without UV area has no texture to carry, one without area no
   * normal to displace along, so either is bad input here (one line),
   * though `chisel info` only reports them: the validation's warnings are
   * held until the mesh has passed. */
  held_warnings held = {0};
  ch_error hold = err;
  hold.warn = hold_warning;
  hold.warn_user = &held;
  ch_status vst = ch_mesh_validate(&mesh, base, &report, &hold);
  if (!vst && (report.num_zero_uv_area_faces > 0 || report.num_degenerate_faces > 0)) {
    int zero_uv = report.num_zero_uv_area_faces > 0;
    vst = ch_error_set(&hold, CH_ERR_INPUT, "%s: face %d has zero %s (%d such faces): %s", base,
                       (zero_uv ? report.first_zero_uv_area_face : report.first_degenerate_face) + 1,
                       zero_uv ? "UV area" : "area",
                       zero_uv ? report.num_zero_uv_area_faces : report.num_degenerate_faces,
                       zero_uv ? "no texture features can be placed on it" : "it has no normal to displace along");
  }
  if (vst) {
    free(held.text);
    ch_mesh_free(&mesh);
    if (is_udim) ch_curves_free(&set);
    return cli_fail(&hold);
  }
  for (char *line = held.text; line && *line;) { /* the warnings, now */
    char *end = strchr(line, '\n');
    *end = '\0';
    ch_warn(&err, "%s", line);
    line = end + 1;
  }
  free(held.text);
  char one_tile[4096];
  if (!is_udim && cli_udim_curve_path(svg, 1001, one_tile, sizeof one_tile, 0) && strstr(svg, "<UDIM>"))
    svg = one_tile; /* a <UDIM> pattern on a mesh in tile 1001 */
  cli_progress_stage("reading %s", svg);
  if (!is_udim && ch_curves_read_svg_ex(svg, &svg_desc, &set, &err)) {
    ch_mesh_free(&mesh);
    return cli_fail(&err);
  }
  double t_read = omp_get_wtime();
  ch_surface *surface = NULL;
  ch_tess_result tess = {0};
  ch_height height = {0};
  ch_displace_stats dstats = {0};
  double t_surface = 0, t_height = 0, t_disp = 0, t_write = 0;
  ch_height_desc hd = {.dci_resolution = (int)res, .step_method = (ch_recon_method)snap_to};
  ch_warp warp_store = {0};
  const ch_warp *warp = NULL; /* set when --camera gives a warp */
  double t_warp = 0;
  ch_status st = ch_surface_create(&mesh, (ch_scheme)scheme, &surface, &err);
  if (!st) t_surface = omp_get_wtime();
  if (!st && has_camera) {
    st = build_warp(surface, &camera, &set, base, &warp_store, &err);
    if (!st && warp_store.n > 0) warp = &warp_store;
    t_warp = omp_get_wtime() - t_surface;
  }
  if (!st) {
    hd.warp = warp_dci ? warp : NULL;
    cli_progress_stage("h: the step curves' diffusion at %ld x %ld", res, res);
    st = ch_height_init(&height, &set, &hd, &err);
    t_height = omp_get_wtime();
  }
  /* Embedding adds triangles: ch_embed_to_target tessellates for fewer so
   * that the output lands on the target. */
  ch_mesh embedded = {0};
  ch_embed_stats estats = {0};
  const ch_mesh *result = &tess.mesh;
  int passes = 1;
  if (!st) {
    if (no_snap) {
      cli_progress_stage("tessellating and displacing");
      ch_tess_desc td = {.target_triangles = target, .warp = warp};
      st = ch_tess_build(surface, &td, &tess, &err);
      double t_d = omp_get_wtime();
      if (!st) st = ch_displace_apply(&tess, &height, &dstats, &err);
      t_disp = omp_get_wtime() - t_d;
    } else {
      ch_embed_desc ed = {.warp = warp, .progress = progress};
      st = ch_embed_to_target(surface, &height, &ed, target, &tess, &embedded, &estats, &passes, &err);
      result = &embedded;
      dstats.min_h = estats.min_h;
      dstats.max_h = estats.max_h;
      t_disp = estats.seconds_refine + estats.seconds_cut + estats.seconds_normals;
    }
  }
  if (!st && is_udim) cli_udim_from_atlas((ch_mesh *)result, &udim); /* ours: embedded or tess.mesh */
  if (!st && labs((long)result->num_faces - target) > target / 20)
    ch_warn(&err, "%d triangles: the closest to --target-tris %ld that the base mesh and the features allow",
            result->num_faces, target);
  double t_passes = omp_get_wtime();
  t_write = t_passes;
  if (!st && !no_snap && estats.unresolved > 0)
    ch_warn(&err,
            "%s: %d triangle%s could not be cut along the features (a feature thinner than the refinement's "
            "1e-5 UV inside): filled as fans, the features not followed there; the first at UV (%.6f, %.6f), all "
            "within UV [%.6f, %.6f] .. [%.6f, %.6f]",
            svg, estats.unresolved, estats.unresolved == 1 ? "" : "s", estats.unresolved_uv[0],
            estats.unresolved_uv[1], estats.unresolved_box[0], estats.unresolved_box[1], estats.unresolved_box[2],
            estats.unresolved_box[3]);
  /* Files first; a mesh for standard output last, once nothing else can
   * fail (a stream cannot be taken back). */
  if (!st && !cli_is_stdout(out)) {
    cli_progress_stage("writing %s", out);
    st = ch_mesh_write_obj(out, result, &err);
  }
  if (!st && ply && !cli_is_stdout(ply)) {
    cli_progress_stage("writing %s", ply);
    st = ch_mesh_write_ply(ply, result, &err);
  }
  double height_scale = 0.0;
  if (!st && (exr || png || png16)) {
    /* The displacement map over the UV square at the pixel centres, and
     * with --exr the geometry image it displaces. */
    ch_image hmap = {0}, maps = {0};
    const char *layer[] = {"h"};
    cli_progress_stage("rendering the maps");
    st = ch_image_init(&hmap, (int)res, (int)res, 1, layer, &err);
    if (!st) ch_height_render_warped(&height, warp, (int)res, 1, ch_image_plane(&hmap, 0));
    if (!st && exr) {
      ch_geomimage gi;
      st = ch_geomimage_build_warped(surface, (int)res, (int)res, NULL, warp, &gi, &err);
      ch_image gimg = {0};
      if (!st) st = ch_geomimage_to_image(&gi, &gimg, &err);
      int extra = warp ? 2 : 0; /* u v: each warped texel's original UV */
      if (!st) {
        const char *names[CH_IMAGE_MAX_CHANNELS];
        names[0] = "h";
        for (int c = 0; c < gimg.num_channels; c++) names[1 + c] = gimg.names[c];
        names[1 + gimg.num_channels] = "u";
        names[2 + gimg.num_channels] = "v";
        st = ch_image_init(&maps, (int)res, (int)res, 1 + gimg.num_channels + extra, names, &err);
      }
      if (!st) {
        size_t plane = (size_t)res * (size_t)res * sizeof(float);
        memcpy(ch_image_plane(&maps, 0), ch_image_plane(&hmap, 0), plane);
        memcpy(ch_image_plane(&maps, 1), gimg.pixels, plane * (size_t)gimg.num_channels);
        if (warp) {
          float *pu = ch_image_plane(&maps, 1 + gimg.num_channels), *pv = ch_image_plane(&maps, 2 + gimg.num_channels);
          for (size_t i = 0; i < (size_t)res * (size_t)res; i++) {
            pu[i] = gi.uv[2 * i];
            pv[i] = gi.uv[2 * i + 1];
          }
        }
        char *warp_text = warp ? warp_attributes(warp, (int)res) : NULL;
        ch_exr_attribute attrs[8] = {{"chisel:command", "displace"}, {"chisel:rect", "0 0 1 1"}};
        int na = 2;
        if (warp && !warp_text) {
          st = ch_error_set(&err, CH_ERR_NOMEM, "out of memory for the EXR's warp attributes");
        } else if (warp) { /* four strings, one after the other */
          const char *keys[] = {"chisel:space", "chisel:warp", "chisel:warp_u", "chisel:warp_v"};
          const char *text = warp_text;
          for (int k = 0; k < 4; k++, text += strlen(text) + 1) attrs[na++] = (ch_exr_attribute){keys[k], text};
        }
        char scale_text[32];
        ch_exr_write_desc wd = {0};
        height_scale = cli_height_luminance(ch_image_plane(&maps, 0), (size_t)res * (size_t)res, "h", &wd,
                                            scale_text, sizeof scale_text);
        attrs[na++] = (ch_exr_attribute){"chisel:height_scale", scale_text};
        attrs[na++] = (ch_exr_attribute){"chisel:Y", CLI_Y_NOTE};
        wd.attributes = attrs;
        wd.num_attributes = na;
        cli_progress_stage("writing %s", exr);
        if (!st) st = ch_exr_write(exr, &maps, &wd, &err);
        free(warp_text);
      }
      ch_image_free(&gimg);
      ch_geomimage_free(&gi);
    }
    if (!st && png) {
      cli_progress_stage("writing %s", png);
      st = ch_png_write_height(png, ch_image_plane(&hmap, 0), hmap.width, hmap.height, &err);
    }
    if (!st && png16) {
      st = ch_png_write_height16(png16, ch_image_plane(&hmap, 0), hmap.width, hmap.height, &height_scale, &err);
    }
    ch_image_free(&maps);
    ch_image_free(&hmap);
  }
  if (!st && cli_is_stdout(out)) st = ch_mesh_write_obj_stream(stdout, "(standard output)", result, &err);
  if (!st && cli_is_stdout(ply)) st = ch_mesh_write_ply_stream(stdout, "(standard output)", result, &err);
  t_write = omp_get_wtime() - t_write;
  cli_progress_done();
  if (!st && warp && !cli_quiet) {
    const ch_warp_stats *ws = &warp->stats;
    double total = omp_get_wtime() - t0, cost = t_warp + height.warp_stats.seconds;
    double tri_share = ch_warp_visible_triangle_share(warp, result->num_faces, result->corner_uv, result->uvs);
    fprintf(stderr,
            "chisel: warp: virtual resolution %.0f x %.0f (%.2fx, %.2fx --res %ld); visible part %.1f%% of the "
            "texels (%.1f%% unwarped), %.1f%% of the triangles; %d of %d cage triangles visible, %d with curves; "
            "warp %.0f ms (%.1f%% of the run)\n",
            res * ws->max_slope[0], res * ws->max_slope[1], ws->max_slope[0], ws->max_slope[1], res,
            100.0 * ws->visible_share, 100.0 * ws->unwarped_share, 100.0 * tri_share, ws->visible_triangles,
            warp->num_triangles, ws->needy_triangles, 1e3 * cost, 100.0 * cost / total);
  }
  if (!st && stats) {
    fprintf(stderr,
            "chisel: displace %d triangles: read %.0f ms, surface %.0f ms, h setup %.0f ms, %s %.0f ms "
            "(%d pass%s; kept: %d base triangles, %s %.0f ms), write %.0f ms; h in [%.4g, %.4g]\n",
            result->num_faces, 1e3 * (t_read - t0), 1e3 * (t_surface - t_read), 1e3 * (t_height - t_surface - t_warp),
            no_snap ? "tessellate and displace" : "tessellate and embed", 1e3 * (t_passes - t_height), passes,
            passes > 1 ? "es" : "", tess.mesh.num_faces, no_snap ? "displace" : "embed", 1e3 * t_disp,
            1e3 * t_write, dstats.min_h, dstats.max_h);
    if (!no_snap)
      fprintf(stderr,
              "chisel: embed: %d refinement rounds (%d edges split), %d boundary points (%d on walls), %d "
              "junctions, %d wall triangles, %d unresolved, u lines every %.2f deg, %d vertices thinned; refine %.0f ms "
              "(setup %.0f, labels %.0f, edges %.0f, crossings %.0f, classify %.0f, split %.0f), cut %.0f ms (thin "
              "%.0f), normals %.0f ms\n",
              estats.refine_rounds, estats.refined_edges, estats.crossings, estats.wall_points, estats.junctions,
              estats.wall_triangles, estats.unresolved, estats.angle_deg, estats.thinned, 1e3 * estats.seconds_refine,
              1e3 * estats.seconds_setup, 1e3 * estats.seconds_labels, 1e3 * estats.seconds_edges,
              1e3 * estats.seconds_crossings, 1e3 * estats.seconds_classify, 1e3 * estats.seconds_split,
              1e3 * estats.seconds_cut, 1e3 * estats.seconds_thin, 1e3 * estats.seconds_normals);
  }
  double total = omp_get_wtime() - t0;
  if (!st) {
    char what[1024] = "";
    size_t len = 0;
    const char *written[5] = {out, ply, exr, png, png16};
    for (int i = 0; i < 5; i++)
      if (written[i])
        len += (size_t)snprintf(what + len, len < sizeof what ? sizeof what - len : 0, "%s%s", len ? ", " : "",
                                cli_is_stdout(written[i]) ? (i == 0 ? "OBJ to standard output" : "PLY to standard output")
                                                          : written[i]);
    char scale_note[96] = "";
    if (png16 || exr)
      snprintf(scale_note, sizeof scale_note, "; %s: 0.5 + h / (2 x %.6g)",
               png16 && exr ? "Y and the height PNG" : exr ? "Y" : "the height PNG", height_scale);
    cli_result("wrote %s: %d triangles, %d vertices, h in [%.4g, %.4g]%s, in %.2f s", what, result->num_faces,
               result->num_positions, dstats.min_h, dstats.max_h, scale_note, total);
  }
  if (!st && json) {
    cJSON *o = cJSON_CreateObject();
    cJSON *files = cJSON_AddArrayToObject(o, "outputs");
    const char *written[5] = {out, ply, exr, png, png16};
    for (int i = 0; i < 5; i++)
      if (written[i]) cJSON_AddItemToArray(files, cJSON_CreateString(written[i]));
    cJSON_AddNumberToObject(o, "triangles", result->num_faces);
    cJSON_AddNumberToObject(o, "vertices", result->num_positions);
    cJSON_AddNumberToObject(o, "target_triangles", (double)target);
    cJSON_AddNumberToObject(o, "base_triangles", tess.mesh.num_faces);
    cJSON_AddNumberToObject(o, "passes", passes);
    cJSON_AddNumberToObject(o, "h_min", dstats.min_h);
    cJSON_AddNumberToObject(o, "h_max", dstats.max_h);
    if (png16 || exr) cJSON_AddNumberToObject(o, "height_scale", height_scale);
    cJSON_AddBoolToObject(o, "snapped", !no_snap);
    cJSON *sec = cJSON_AddObjectToObject(o, "seconds");
    cJSON_AddNumberToObject(sec, "total", total);
    cJSON_AddNumberToObject(sec, "read", t_read - t0);
    cJSON_AddNumberToObject(sec, "surface", t_surface - t_read);
    cJSON_AddNumberToObject(sec, "h_setup", t_height - t_surface - t_warp);
    cJSON_AddNumberToObject(sec, "tessellate", t_passes - t_height);
    cJSON_AddNumberToObject(sec, "write", t_write);
    if (!no_snap) {
      cJSON *e = cJSON_AddObjectToObject(o, "embed");
      cJSON_AddNumberToObject(e, "refine_rounds", estats.refine_rounds);
      cJSON_AddNumberToObject(e, "refined_edges", estats.refined_edges);
      cJSON_AddNumberToObject(e, "boundary_points", estats.crossings);
      cJSON_AddNumberToObject(e, "wall_points", estats.wall_points);
      cJSON_AddNumberToObject(e, "junctions", estats.junctions);
      cJSON_AddNumberToObject(e, "wall_triangles", estats.wall_triangles);
      cJSON_AddNumberToObject(e, "unresolved", estats.unresolved);
      if (estats.unresolved > 0) {
        cJSON *u = cJSON_AddArrayToObject(e, "unresolved_first_uv");
        for (int k = 0; k < 2; k++) cJSON_AddItemToArray(u, cJSON_CreateNumber(estats.unresolved_uv[k]));
        cJSON *b = cJSON_AddArrayToObject(e, "unresolved_uv_box");
        for (int k = 0; k < 4; k++) cJSON_AddItemToArray(b, cJSON_CreateNumber(estats.unresolved_box[k]));
      }
      cJSON_AddNumberToObject(e, "thinned", estats.thinned);
      cJSON_AddNumberToObject(e, "angle_deg", estats.angle_deg);
      cJSON_AddNumberToObject(e, "seconds_refine", estats.seconds_refine);
      cJSON_AddNumberToObject(e, "seconds_cut", estats.seconds_cut);
      cJSON_AddNumberToObject(e, "seconds_normals", estats.seconds_normals);
    }
    if (warp) {
      const ch_warp_stats *ws = &warp->stats;
      cJSON *wj = cJSON_AddObjectToObject(o, "warp");
      cJSON_AddNumberToObject(wj, "virtual_resolution_u", res * ws->max_slope[0]);
      cJSON_AddNumberToObject(wj, "virtual_resolution_v", res * ws->max_slope[1]);
      cJSON_AddNumberToObject(wj, "visible_texel_share", ws->visible_share);
      cJSON_AddNumberToObject(wj, "unwarped_visible_texel_share", ws->unwarped_share);
    }
    char *text = cJSON_PrintUnformatted(o);
    cJSON_Delete(o);
    if (text) puts(text);
    free(text);
  }
  ch_warp_free(&warp_store);
  ch_tess_free(&tess);
  ch_mesh_free(&embedded);
  ch_height_free(&height);
  ch_surface_destroy(surface);
  ch_curves_free(&set);
  ch_mesh_free(&mesh);
  return st ? cli_fail(&err) : 0;
}

const cli_command cli_displace_command = {"displace", "displace a base mesh by the curves (OBJ out)", usage, run};
