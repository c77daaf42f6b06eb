/* Rendering of trace scenes into layers (ch_render.h). */
#include "ch_render.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "ch_math.h"

const char *const ch_render_layer_names[CH_RENDER_NUM_LAYERS] = {
    "shade", "shadow", "depth", "N.X", "N.Y", "N.Z", "P.X", "P.Y", "P.Z", "uv.u", "uv.v", "class", "id", "coverage"};

/* The view of a render camera, set up once (ch_camera, shared with the
 * warp). */
static ch_status camera_frame(const ch_render_camera *c, ch_camera *fr, ch_error *err) {
  if (c->width < 1 || c->height < 1 || c->width > CH_IMAGE_MAX_SIDE || c->height > CH_IMAGE_MAX_SIDE)
    return ch_error_set(err, CH_ERR_INPUT, "camera: image size %d x %d out of range", c->width, c->height);
  if (c->supersample < 0 || c->supersample > 16)
    return ch_error_set(err, CH_ERR_INPUT, "camera: supersample %d out of range 1..16", c->supersample);
  return ch_camera_look(fr, c->eye, c->target, c->up, c->fov_deg, c->ortho_height, (double)c->width / c->height,
                        err);
}

/* Image point (px, py) in pixels, (0, 0) the top-left corner, to NDC. */
static void frame_ray(const ch_render_camera *c, const ch_camera *fr, double px, double py, double o[3], double d[3]) {
  ch_camera_ray(fr, 2.0 * px / c->width - 1.0, 1.0 - 2.0 * py / c->height, o, d);
}

ch_status ch_render_camera_ray(const ch_render_camera *c, double px, double py, double o[3], double d[3],
                               ch_error *err) {
  ch_camera fr;
  ch_status st = camera_frame(c, &fr, err);
  if (st) return st;
  frame_ray(c, &fr, px, py, o, d);
  return CH_OK;
}

typedef struct sample {
  int hit;
  ch_vis_class cls;
  int id;
  double shade, shadow, depth, n[3], p[3], uv[2];
} sample;

static void trace_sample(const ch_trace *scene, const ch_render_shader *shader, const ch_truth *truth,
                         const double L[3], const ch_light *lt, const double o[3], const double d[3], sample *s,
                         long *shadow_rays) {
  memset(s, 0, sizeof *s);
  s->cls = CH_VIS_NONE;
  s->id = -1;
  ch_trace_hit h;
  if (!ch_trace_intersect(scene, o, d, 0.0, INFINITY, &h)) return;
  if (shader && !shader->shade(shader->user, o, d, &h)) return;
  s->hit = 1;
  s->depth = h.t;
  memcpy(s->p, h.point, sizeof s->p);
  memcpy(s->uv, h.uv, sizeof s->uv);
  if (h.wall) {
    double nuv[2] = {h.normal[0], h.normal[1]}, l = hypot(nuv[0], nuv[1]);
    nuv[0] /= l;
    nuv[1] /= l;
    ch_truth_classify_wall(truth, h.uv, nuv, &s->cls, &s->id);
  } else {
    ch_truth_classify(truth, h.uv, &s->cls, &s->id);
  }
  /* Normals face the eye (a sheet is seen from either side). */
  double ng[3], ns[3];
  memcpy(ng, h.normal, sizeof ng);
  memcpy(ns, h.shading_normal, sizeof ns);
  if (ch_dot3(ng, d) > 0.0)
    for (int k = 0; k < 3; k++) ng[k] = -ng[k];
  if (ch_dot3(ns, d) > 0.0)
    for (int k = 0; k < 3; k++) ns[k] = -ns[k];
  memcpy(s->n, ns, sizeof s->n);
  int lit = 0;
  if (ch_dot3(ng, L) > 0.0) {
    /* Off the surface by a hair, on the lit side. */
    double so[3];
    for (int k = 0; k < 3; k++) so[k] = h.point[k] + 1e-7 * ng[k];
    (*shadow_rays)++;
    lit = shader && shader->occluded ? !shader->occluded(shader->user, &h, L) : !ch_trace_occluded(scene, so, L, 0.0, INFINITY);
  }
  s->shadow = lit ? 0.0 : 1.0;
  double half[3] = {L[0] - d[0], L[1] - d[1], L[2] - d[2]};
  ch_normalize3(half);
  double diff = fmax(0.0, ch_dot3(ns, L)), spec = pow(fmax(0.0, ch_dot3(ns, half)), lt->shininess);
  s->shade = lt->albedo * (lt->ambient + (1.0 - lt->ambient) * diff * lit) + lt->specular * spec * lit;
}

ch_status ch_render(const ch_trace *scene, const ch_truth *truth, const ch_render_camera *cam, const ch_light *light,
                    ch_image *out, ch_render_stats *stats, ch_error *err) {
  return ch_render_shaded(scene, NULL, truth, cam, light, out, stats, err);
}

static int exact_normals(void *user, const double org[3], const double dir[3], ch_trace_hit *hit) {
  (void)org;
  (void)dir;
  ch_truth_normal(user, hit->uv, hit->shading_normal);
  memcpy(hit->normal, hit->shading_normal, sizeof hit->normal);
  hit->wall = 0;
  return 1;
}

ch_render_shader ch_shader_exact_normals(const ch_truth *truth) {
  ch_render_shader sh = {exact_normals, NULL, (void *)truth};
  return sh;
}

ch_status ch_render_shaded(const ch_trace *scene, const ch_render_shader *shader, const ch_truth *truth,
                           const ch_render_camera *cam, const ch_light *light_in, ch_image *out, ch_render_stats *stats,
                           ch_error *err) {
  memset(out, 0, sizeof *out);
  ch_camera fr;
  ch_status st = camera_frame(cam, &fr, err);
  if (st) return st;
  ch_light lt = light_in ? *light_in : (ch_light){0};
  double L[3] = {lt.direction[0], lt.direction[1], lt.direction[2]};
  if (L[0] == 0.0 && L[1] == 0.0 && L[2] == 0.0) L[0] = -0.35, L[1] = -0.45, L[2] = 0.82;
  ch_normalize3(L);
  if (lt.ambient <= 0.0) lt.ambient = 0.15;
  if (lt.albedo <= 0.0) lt.albedo = 0.75;
  if (lt.specular <= 0.0) lt.specular = 0.25;
  if (lt.shininess <= 0.0) lt.shininess = 40.0;
  st = ch_image_init(out, cam->width, cam->height, CH_RENDER_NUM_LAYERS, ch_render_layer_names, err);
  if (st) return st;
  int n = cam->supersample > 0 ? cam->supersample : 1, W = cam->width, H = cam->height;
  float *plane[CH_RENDER_NUM_LAYERS];
  for (int c = 0; c < CH_RENDER_NUM_LAYERS; c++) plane[c] = ch_image_plane(out, c);
  long shadow_total = 0;
  int failed = 0;
  double t0 = omp_get_wtime();
#pragma omp parallel reduction(+ : shadow_total)
  {
    sample *smp = malloc((size_t)n * n * sizeof *smp);
    if (!smp) {
#pragma omp atomic write
      failed = 1;
    }
#pragma omp for schedule(dynamic, 1)
    for (int y = 0; y < H; y++) {
      if (!smp) continue;
      for (int x = 0; x < W; x++) {
        int count[CH_VIS_COUNT] = {0}, hits = 0;
        double acc[CH_RENDER_NUM_LAYERS] = {0};
        for (int j = 0; j < n; j++)
          for (int i = 0; i < n; i++) {
            double o[3], d[3];
            frame_ray(cam, &fr, x + (i + 0.5) / n, y + (j + 0.5) / n, o, d);
            sample *s = &smp[j * n + i];
            trace_sample(scene, shader, truth, L, &lt, o, d, s, &shadow_total);
            count[s->cls]++;
            acc[CH_RENDER_SHADE] += s->shade;
            if (!s->hit) continue;
            hits++;
            /* Orthographic depth: from the image plane through the eye. */
            double depth = s->depth;
            if (cam->ortho_height > 0.0) {
              double e[3] = {o[0] - cam->eye[0], o[1] - cam->eye[1], o[2] - cam->eye[2]};
              depth += ch_dot3(e, fr.forward);
            }
            acc[CH_RENDER_SHADOW] += s->shadow;
            acc[CH_RENDER_DEPTH] += depth;
            for (int k = 0; k < 3; k++) {
              acc[CH_RENDER_NX + k] += s->n[k];
              acc[CH_RENDER_PX + k] += s->p[k];
            }
            acc[CH_RENDER_U] += s->uv[0];
            acc[CH_RENDER_V] += s->uv[1];
          }
        int best = 0;
        for (int c = 1; c < CH_VIS_COUNT; c++)
          if (count[c] > count[best]) best = c;
        /* The most frequent id among the samples of that class. */
        int best_id = -1, best_n = 0;
        for (int a = 0; a < n * n; a++) {
          if ((int)smp[a].cls != best) continue;
          int m = 0;
          for (int b = 0; b < n * n; b++) m += (int)smp[b].cls == best && smp[b].id == smp[a].id;
          if (m > best_n || (m == best_n && smp[a].id < best_id)) best_n = m, best_id = smp[a].id;
        }
        size_t p = (size_t)y * W + x;
        double inv = hits ? 1.0 / hits : 0.0;
        plane[CH_RENDER_SHADE][p] = (float)(acc[CH_RENDER_SHADE] / (n * n));
        for (int c = CH_RENDER_SHADOW; c <= CH_RENDER_V; c++) plane[c][p] = (float)(acc[c] * inv);
        double nl = sqrt(acc[CH_RENDER_NX] * acc[CH_RENDER_NX] + acc[CH_RENDER_NY] * acc[CH_RENDER_NY] +
                         acc[CH_RENDER_NZ] * acc[CH_RENDER_NZ]);
        for (int k = 0; k < 3; k++) plane[CH_RENDER_NX + k][p] = nl > 0.0 ? (float)(acc[CH_RENDER_NX + k] / nl) : 0.0f;
        plane[CH_RENDER_CLASS][p] = (float)best;
        plane[CH_RENDER_ID][p] = (float)best_id;
        plane[CH_RENDER_COVERAGE][p] = (float)((double)hits / (n * n));
      }
    }
    free(smp);
  }
  if (failed) {
    ch_image_free(out);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for render samples");
  }
  if (stats) {
    stats->primary_rays = (long)W * H * n * n;
    stats->shadow_rays = shadow_total;
    stats->seconds = omp_get_wtime() - t0;
  }
  return CH_OK;
}
