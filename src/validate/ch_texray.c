/* Texture methods that move hits, as study shaders (ch_texray.h). */
#include "ch_texray.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ch_gtex.h"
#include "ch_math.h"
#include "ch_relief.h"

struct ch_texray {
  ch_texray_kind kind;
  ch_gtex gtex;
  ch_relief relief;
};

ch_status ch_texray_create(const ch_texray_desc *desc, const ch_curve_set *set, const ch_height *height,
                           const char *curves_name, ch_texray **out, ch_error *err) {
  *out = NULL;
  ch_texray *tr = calloc(1, sizeof *tr);
  if (!tr) return ch_error_set(err, CH_ERR_NOMEM, "out of memory");
  tr->kind = desc->kind;
  ch_status st;
  if (desc->kind == CH_TEXRAY_GROOVES) {
    ch_gtex_desc gd = {.resolution = desc->resolution, .paper = desc->paper};
    st = ch_gtex_build(&tr->gtex, set, &gd, curves_name, err);
  } else {
    ch_relief_desc rd = {.resolution = desc->resolution,
                         .steps = desc->steps,
                         .method = desc->kind == CH_TEXRAY_POM ? CH_RELIEF_POM : CH_RELIEF_RELIEF};
    const ch_texray *same = desc->same_map;
    if (same && same->kind != CH_TEXRAY_GROOVES && same->relief.resolution == desc->resolution)
      st = ch_relief_copy(&tr->relief, &same->relief, &rd, err);
    else
      st = ch_relief_build(&tr->relief, height, &rd, err);
  }
  if (st) {
    free(tr);
    return st;
  }
  *out = tr;
  return CH_OK;
}

void ch_texray_destroy(ch_texray *tr) {
  if (!tr) return;
  ch_gtex_free(&tr->gtex);
  ch_relief_free(&tr->relief);
  free(tr);
}

size_t ch_texray_bytes(const ch_texray *tr) {
  return tr->kind == CH_TEXRAY_GROOVES ? ch_gtex_bytes(&tr->gtex) : ch_relief_bytes(&tr->relief);
}

static void set_hit(ch_trace_hit *hit, double t, const double p[3], const double n[3], int wall) {
  hit->t = t;
  memcpy(hit->point, p, sizeof hit->point);
  hit->uv[0] = p[0];
  hit->uv[1] = p[1];
  memcpy(hit->normal, n, sizeof hit->normal);
  memcpy(hit->shading_normal, n, sizeof hit->shading_normal);
  hit->wall = wall;
}

/* The shadow ray's origin: off the surface by a hair on the light's side
 * (as the renderer offsets its own shadow rays). */
static void shadow_origin(const ch_trace_hit *from, const double dir[3], double o[3]) {
  double s = ch_dot3(from->normal, dir) >= 0.0 ? 1e-7 : -1e-7;
  for (int k = 0; k < 3; k++) o[k] = from->point[k] + s * from->normal[k];
}

static int shade_grooves(void *user, const double org[3], const double dir[3], ch_trace_hit *hit) {
  const ch_texray *tr = user;
  ch_gtex_hit g;
  if (!ch_gtex_intersect(&tr->gtex, org, dir, 0.0, INFINITY, &g)) return 0;
  set_hit(hit, g.t, g.point, g.normal, g.wall);
  return 1;
}

static int occluded_grooves(void *user, const ch_trace_hit *from, const double dir[3]) {
  const ch_texray *tr = user;
  double o[3];
  shadow_origin(from, dir, o);
  return ch_gtex_occluded(&tr->gtex, o, dir, 0.0, INFINITY);
}

static int shade_relief(void *user, const double org[3], const double dir[3], ch_trace_hit *hit) {
  const ch_texray *tr = user;
  ch_relief_hit r;
  if (!ch_relief_intersect(&tr->relief, org, dir, &r)) return 0;
  set_hit(hit, r.t, r.point, r.normal, 0);
  return 1;
}

static int occluded_relief(void *user, const ch_trace_hit *from, const double dir[3]) {
  const ch_texray *tr = user;
  double o[3];
  shadow_origin(from, dir, o);
  return ch_relief_occluded(&tr->relief, o, dir);
}

ch_render_shader ch_texray_shader(const ch_texray *tr) {
  ch_render_shader sh = {shade_relief, occluded_relief, (void *)tr};
  if (tr->kind == CH_TEXRAY_GROOVES) sh.shade = shade_grooves, sh.occluded = occluded_grooves;
  return sh;
}
