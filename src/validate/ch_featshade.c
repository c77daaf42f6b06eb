/* Feature-map normal methods as study shaders (ch_featshade.h). */
#include "ch_featshade.h"

#include <math.h>
#include <string.h>

/* By ch_featshade_method: its name, and the feature maps' method it reads
 * (all but the msdf). */
static const char *const method_names[] = {"featnorm", "featnorm-linear", "normal-bilinear", "msdf"};
static const ch_featmap_method map_method[] = {CH_FEATMAP_FEATNORM, CH_FEATMAP_LINEAR, CH_FEATMAP_BILINEAR};

int ch_featshade_method_parse(const char *name) {
  for (int m = 0; m <= CH_FEATSHADE_MSDF; m++)
    if (!strcmp(name, method_names[m])) return m;
  return -1;
}

const char *ch_featshade_method_name(ch_featshade_method method) { return method_names[method]; }

ch_status ch_featshade_init(ch_featshade *fs, ch_featshade_method method, int resolution, const ch_curve_set *set,
                            const ch_height *height, ch_error *err) {
  memset(fs, 0, sizeof *fs);
  fs->method = method;
  if (method == CH_FEATSHADE_MSDF) {
    ch_msdf_desc md = {.resolution = resolution};
    return ch_msdf_build(set, &md, &fs->msdf, err);
  }
  ch_featmap_desc fd = {.resolution = resolution,
                        .linear = method == CH_FEATSHADE_LINEAR,
                        .no_normal_map = method != CH_FEATSHADE_NORMAL_BILINEAR,
                        .height = height};
  return ch_featmap_build(set, &fd, &fs->maps, err);
}

void ch_featshade_free(ch_featshade *fs) {
  ch_featmap_free(&fs->maps);
  ch_msdf_free(&fs->msdf);
}

size_t ch_featshade_bytes(const ch_featshade *fs) {
  if (fs->method == CH_FEATSHADE_MSDF) {
    double texels = (double)fs->msdf.resolution * fs->msdf.resolution;
    return (size_t)llround(texels * ch_msdf_bytes_per_texel());
  }
  double texels = (double)fs->maps.resolution * fs->maps.resolution;
  double per = ch_featmap_bytes_per_texel(&fs->maps, map_method[fs->method]);
  if (fs->method != CH_FEATSHADE_NORMAL_BILINEAR) per += ch_featmap_fallback_bytes(&fs->maps);
  return (size_t)llround(texels * per);
}

static int shade(void *user, const double org[3], const double dir[3], ch_trace_hit *hit) {
  (void)org;
  (void)dir;
  const ch_featshade *fs = user;
  ch_featmap_sample s;
  if (fs->method == CH_FEATSHADE_MSDF) ch_msdf_eval(&fs->msdf, hit->uv[0], hit->uv[1], &s);
  else ch_featmap_eval(&fs->maps, map_method[fs->method], hit->uv[0], hit->uv[1], &s);
  memcpy(hit->shading_normal, s.normal, sizeof hit->shading_normal);
  memcpy(hit->normal, s.normal, sizeof hit->normal);
  hit->wall = 0;
  return 1;
}

ch_render_shader ch_featshade_shader(const ch_featshade *fs) {
  ch_render_shader sh = {shade, NULL, (void *)fs};
  return sh;
}
