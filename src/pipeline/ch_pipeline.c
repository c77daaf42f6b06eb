/* The displace job as one library call (ch_pipeline.h): the stages of
 * docs/architecture.md in order, each from its own module. */
#include "ch_pipeline.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <omp.h>

#include "ch_displace.h"
#include "ch_geomimage.h"
#include "ch_height.h"
#include "ch_udim.h"

/* The warp of a camera: W on 256 intervals per axis; its cage, the base
 * surface tessellated to 2 x 128^2 triangles or more, so the cage map
 * follows W within a knot on the plane (a 256^2 cage gives the same slopes
 * to 3% at three times the cost: 85 against 25 ms, most of it the triangle
 * grids). */
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

/* The view-dependent warp of a camera: the cage, W from the camera. A
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

/* Warnings held back while something may still fail (so a failing input
 * prints its one line, not the warnings before it). */
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

/* A face without UV area has no texture to carry, one without area no
 * normal to displace along, so either is bad input here (one line), though
 * `chisel info` only reports them: the validation's warnings are held
 * until the mesh has passed. */
static ch_status validate_base(const ch_mesh *mesh, const char *base, ch_error *err) {
  ch_mesh_report report;
  held_warnings held = {0};
  ch_error hold = *err;
  hold.warn = hold_warning;
  hold.warn_user = &held;
  ch_status st = ch_mesh_validate(mesh, base, &report, &hold);
  if (!st && (report.num_zero_uv_area_faces > 0 || report.num_degenerate_faces > 0)) {
    int zero_uv = report.num_zero_uv_area_faces > 0;
    st = ch_error_set(&hold, CH_ERR_INPUT, "%s: face %d has zero %s (%d such faces): %s", base,
                      (zero_uv ? report.first_zero_uv_area_face : report.first_degenerate_face) + 1,
                      zero_uv ? "UV area" : "area",
                      zero_uv ? report.num_zero_uv_area_faces : report.num_degenerate_faces,
                      zero_uv ? "no texture features can be placed on it" : "it has no normal to displace along");
  }
  if (st) {
    free(held.text);
    err->status = hold.status;
    memcpy(err->message, hold.message, sizeof err->message);
    return st;
  }
  for (char *line = held.text; line && *line;) { /* the warnings, now */
    char *end = strchr(line, '\n');
    *end = '\0';
    ch_warn(err, "%s", line);
    line = end + 1;
  }
  free(held.text);
  return CH_OK;
}

/* The maps over the UV square at the pixel centres (warped UV under a
 * warp): h, and the geometry image it displaces. */
static ch_status render_maps(const ch_surface *surface, const ch_height *height, const ch_warp *warp, int res,
                             int which, ch_displace_result *out, ch_error *err) {
  const char *layer[] = {"h"};
  ch_status st = ch_image_init(&out->height, res, res, 1, layer, err);
  if (st) return st;
  ch_height_render_warped(height, warp, res, 1, ch_image_plane(&out->height, 0));
  if (!(which & CH_DISPLACE_GEOMETRY_MAPS)) return CH_OK;
  int extra = warp ? 2 : 0; /* u v: each warped texel's original UV */
  const char *names[CH_IMAGE_MAX_CHANNELS];
  names[0] = "h";
  for (int c = 0; c < CH_GEOMIMAGE_CHANNELS; c++) names[1 + c] = ch_geomimage_channel_names[c];
  names[1 + CH_GEOMIMAGE_CHANNELS] = "u";
  names[2 + CH_GEOMIMAGE_CHANNELS] = "v";
  if ((st = ch_image_init(&out->maps, res, res, 1 + CH_GEOMIMAGE_CHANNELS + extra, names, err))) return st;
  memcpy(ch_image_plane(&out->maps, 0), ch_image_plane(&out->height, 0), (size_t)res * (size_t)res * sizeof(float));
  /* the geometry image straight into the maps' planes */
  float *planes[CH_GEOMIMAGE_CHANNELS + 2];
  for (int c = 0; c < CH_GEOMIMAGE_CHANNELS + 2; c++)
    planes[c] = c < CH_GEOMIMAGE_CHANNELS + extra ? ch_image_plane(&out->maps, 1 + c) : NULL;
  return ch_geomimage_build_planes(surface, res, res, warp, planes, NULL, err);
}

ch_status ch_pipeline_displace(const ch_displace_desc *desc, ch_displace_result *out, ch_error *err) {
  memset(out, 0, sizeof *out);
  const char *base = desc->base_path, *svg = desc->curves_path;
  const ch_progress *progress = desc->progress;
  long target = desc->target_triangles > 0 ? desc->target_triangles : CH_DISPLACE_DEFAULT_TARGET;
  int res = desc->resolution > 0 ? desc->resolution : CH_DISPLACE_DEFAULT_RESOLUTION;
  if (!base || !svg) return ch_error_set(err, CH_ERR_INPUT, "displace: no base mesh or no curve file given");
  if (desc->warp_dci && !desc->camera) return ch_error_set(err, CH_ERR_INPUT, "displace: warp_dci needs a camera");
  out->target_triangles = target;
  double t0 = omp_get_wtime();

  ch_progress_reportf(progress, -1.0, "reading %s", base);
  ch_mesh mesh;
  ch_status st = ch_mesh_read(base, &mesh, err);
  if (st) return st;
  /* UDIM: UVs beyond the unit square, in tiles; each tile has its curves,
   * and the pipeline runs on an atlas of the tiles. */
  ch_udim udim;
  if ((st = ch_udim_tiles(&mesh, base, &udim, err))) {
    ch_mesh_free(&mesh);
    return st;
  }
  int is_udim = udim.num_tiles > 1 || (udim.num_tiles == 1 && udim.tiles[0] != 1001);
  if (is_udim && (desc->camera || desc->maps)) {
    ch_mesh_free(&mesh);
    return ch_error_set(err, CH_ERR_INPUT,
                        "%s has UDIM tiles: --camera, --exr, --png and --height-png work on one tile's UV square "
                        "only (chisel sample writes a tile's maps)",
                        base);
  }
  ch_curve_set set = {0};
  if (is_udim && (st = ch_udim_read_curves(base, svg, &desc->svg, &udim, &mesh, &set, err))) {
    ch_mesh_free(&mesh);
    return st;
  }
  if (is_udim) { /* each tile keeps its R texels in its shrunk cell */
    res = (int)fmin(16384.0, ceil((double)res / udim.scale));
    out->udim_tiles = udim.num_tiles;
  }
  out->resolution = res;
  if ((st = validate_base(&mesh, base, err))) {
    ch_mesh_free(&mesh);
    if (is_udim) ch_curves_free(&set);
    return st;
  }
  char one_tile[4096];
  if (!is_udim && ch_udim_curve_path(svg, 1001, one_tile, sizeof one_tile, 0) && strstr(svg, "<UDIM>"))
    svg = one_tile; /* a <UDIM> pattern on a mesh in tile 1001 */
  ch_progress_reportf(progress, -1.0, "reading %s", svg);
  if (!is_udim && (st = ch_curves_read_svg_ex(svg, &desc->svg, &set, err))) {
    ch_mesh_free(&mesh);
    return st;
  }
  double t_read = omp_get_wtime();
  out->seconds.read = t_read - t0;

  ch_surface *surface = NULL;
  ch_tess_result tess = {0};
  ch_height height = {0};
  ch_warp warp_store = {0};
  const ch_warp *warp = NULL; /* set when the camera gives a warp */
  ch_progress_reportf(progress, -1.0, "the base surface (%d faces)", mesh.num_faces);
  st = ch_surface_create(&mesh, desc->scheme, &surface, err);
  if (st == CH_ERR_INPUT && err) { /* its messages name the mesh, not the file */
    char what[sizeof err->message];
    snprintf(what, sizeof what, "%s", err->message);
    ch_error_set(err, st, "%s: %s", base, what);
  }
  ch_mesh_free(&mesh); /* the surface holds what it needs of it */
  double t_surface = omp_get_wtime();
  out->seconds.surface = t_surface - t_read;
  if (!st && desc->camera) {
    st = build_warp(surface, desc->camera, &set, base, &warp_store, err);
    if (!st && warp_store.n > 0) warp = &warp_store;
    out->seconds.warp = omp_get_wtime() - t_surface;
  }
  if (!st) {
    ch_height_desc hd = {.dci_resolution = res, .step_method = desc->snap_to, .warp = desc->warp_dci ? warp : NULL};
    ch_progress_reportf(progress, -1.0, "h: the step curves' diffusion at %d x %d", res, res);
    double th = omp_get_wtime();
    st = ch_height_init(&height, &set, &hd, err);
    out->seconds.height = omp_get_wtime() - th;
  }
  /* Embedding adds triangles: ch_embed_to_target tessellates for fewer so
   * that the output lands on the target. */
  double t_tess = omp_get_wtime();
  out->passes = 1;
  if (!st) {
    if (desc->no_snap) {
      ch_progress_reportf(progress, -1.0, "tessellating and displacing");
      /* Below what rate 1 gives (a dense base mesh), rate 1: the closest
       * to the target there is, as the embedding does (warned below). */
      long fewest = ch_tess_fewest_triangles(surface);
      ch_tess_desc td = {.target_triangles = target > fewest ? target : fewest, .warp = warp};
      st = ch_tess_build(surface, &td, &tess, err);
      double t_d = omp_get_wtime();
      ch_displace_stats dstats = {0};
      if (!st) st = ch_displace_apply(&tess, &height, &dstats, err);
      out->seconds.displace = omp_get_wtime() - t_d;
      out->min_h = dstats.min_h;
      out->max_h = dstats.max_h;
      if (!st) { /* the displaced tessellation is the result */
        out->mesh = tess.mesh;
        memset(&tess.mesh, 0, sizeof tess.mesh);
      }
    } else {
      long cap = desc->max_triangles > 0 ? desc->max_triangles
                                         : CH_DISPLACE_DEFAULT_CAP_PER_TARGET * target + CH_DISPLACE_DEFAULT_CAP_EXTRA;
      ch_embed_desc ed = {.warp = warp, .max_triangles = cap, .progress = progress};
      st = ch_embed_to_target(surface, &height, &ed, target, NULL, &out->mesh, &out->embed, &out->passes, err);
      if (st == CH_ERR_INPUT && err) { /* the curves' fault (over the cap): name their file */
        char why[CH_ERROR_MESSAGE_MAX];
        snprintf(why, sizeof why, "%s", err->message);
        ch_error_set(err, st, "%s: %s", svg, why);
      }
      out->snapped = 1;
      out->min_h = out->embed.min_h;
      out->max_h = out->embed.max_h;
      out->seconds.displace = out->embed.seconds_refine + out->embed.seconds_cut + out->embed.seconds_normals;
      out->base_triangles = out->embed.base_triangles;
    }
  }
  if (!st && desc->no_snap) out->base_triangles = out->mesh.num_faces;
  out->seconds.tessellate = omp_get_wtime() - t_tess;
  if (!st && is_udim) ch_udim_from_atlas(&out->mesh, &udim);
  if (!st && labs((long)out->mesh.num_faces - target) > target / 20)
    ch_warn(err, "%d triangles: the closest to --target-tris %ld%s that the base mesh and the features allow",
            out->mesh.num_faces, target, desc->target_triangles > 0 ? "" : " (the default)");
  if (!st && out->snapped && out->embed.unresolved > 0) {
    const ch_embed_stats *e = &out->embed;
    int seams = e->unresolved_at_seams, thin = e->unresolved - seams;
    /* Two causes, said apart: a UV seam whose charts hold different
     * features (h jumps across it; the shared vertex keeps the mesh closed
     * with the other chart's h), or a feature thinner than the refinement. */
    char why[320];
    if (thin == 0)
      snprintf(why, sizeof why,
               "on UV seams where the curves on the two charts differ (h jumps across the seam, and the vertices "
               "the charts share keep one side's h)");
    else if (seams == 0)
      snprintf(why, sizeof why, "(a feature thinner than the refinement's 1e-5 UV inside)");
    else
      snprintf(why, sizeof why,
               "(%d on UV seams where the curves on the two charts differ, %d with a feature thinner than the "
               "refinement's 1e-5 UV inside)",
               seams, thin);
    ch_warn(err,
            "%s: %d triangle%s could not be cut along the features %s: filled as fans, the features not followed "
            "there; the first at UV (%.6f, %.6f), all within UV [%.6f, %.6f] .. [%.6f, %.6f]",
            svg, e->unresolved, e->unresolved == 1 ? "" : "s", why, e->unresolved_uv[0], e->unresolved_uv[1],
            e->unresolved_box[0], e->unresolved_box[1], e->unresolved_box[2], e->unresolved_box[3]);
  }
  if (!st && desc->maps) {
    ch_progress_reportf(progress, -1.0, "rendering the maps");
    double tm = omp_get_wtime();
    st = render_maps(surface, &height, warp, res, desc->maps, out, err);
    out->seconds.maps = omp_get_wtime() - tm;
  }
  if (!st && warp) {
    out->warped = 1;
    out->warp = warp->stats;
    out->warp_cage_triangles = warp->num_triangles;
    out->warp_seconds = out->seconds.warp + height.warp_stats.seconds;
    out->warp_visible_triangle_share =
        ch_warp_visible_triangle_share(warp, out->mesh.num_faces, out->mesh.corner_uv, out->mesh.uvs);
    if (!(out->warp_text = warp_attributes(warp, res)))
      st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for the warp's attributes");
  }
  out->seconds.total = omp_get_wtime() - t0;
  ch_warp_free(&warp_store);
  ch_tess_free(&tess);
  ch_height_free(&height);
  ch_surface_destroy(surface);
  ch_curves_free(&set);
  if (st) ch_displace_result_free(out);
  return st;
}

void ch_displace_result_free(ch_displace_result *r) {
  ch_mesh_free(&r->mesh);
  ch_image_free(&r->height);
  ch_image_free(&r->maps);
  free(r->warp_text);
  memset(r, 0, sizeof *r);
}

double ch_pipeline_height_luminance(const float *plane, size_t n, const char *name, ch_exr_write_desc *desc,
                                    char *scale_text, size_t scale_size) {
  double s = 0.0;
  for (size_t i = 0; i < n; i++)
    if (isfinite(plane[i])) s = fmax(s, fabs((double)plane[i]));
  desc->luminance = name;
  desc->luminance_offset = 0.5;
  desc->luminance_scale = s > 0.0 ? 0.5 / s : 0.5;
  snprintf(scale_text, scale_size, "%.9g", s);
  return s;
}

void ch_displace_exr_desc(const ch_displace_result *result, ch_displace_exr *storage, double *height_scale) {
  memset(storage, 0, sizeof *storage);
  ch_exr_attribute *attrs = storage->attributes;
  int na = 0;
  attrs[na++] = (ch_exr_attribute){"chisel:command", "displace"};
  attrs[na++] = (ch_exr_attribute){"chisel:rect", "0 0 1 1"};
  if (result->warp_text) { /* four strings, one after the other */
    const char *keys[] = {"chisel:space", "chisel:warp", "chisel:warp_u", "chisel:warp_v"};
    const char *text = result->warp_text;
    for (int k = 0; k < 4; k++, text += strlen(text) + 1) attrs[na++] = (ch_exr_attribute){keys[k], text};
  }
  const ch_image *img = result->maps.pixels ? &result->maps : &result->height;
  double s = ch_pipeline_height_luminance(img->pixels, (size_t)img->width * (size_t)img->height, "h",
                                          &storage->desc, storage->scale_text, sizeof storage->scale_text);
  if (height_scale) *height_scale = s;
  attrs[na++] = (ch_exr_attribute){"chisel:height_scale", storage->scale_text};
  attrs[na++] = (ch_exr_attribute){"chisel:Y", CH_PIPELINE_Y_NOTE};
  storage->desc.attributes = attrs;
  storage->desc.num_attributes = na;
}
