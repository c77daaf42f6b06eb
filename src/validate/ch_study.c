/* ch_study: the study's run (ch_study.h), from the scene's values to the
 * files ch_report writes. */
#include "ch_study.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ch_curves.h"
#include "ch_featshade.h"
#include "ch_height.h"
#include "ch_mesh.h"
#include "ch_metrics.h"
#include "ch_render.h"
#include "ch_texray.h"
#include "ch_trace.h"
#include "ch_truth.h"

/* What the study builds per method of the scene. */
typedef struct method_run {
  ch_featshade fs;
  ch_texray *tr;
  ch_mesh mesh;
  ch_trace *scene;
} method_run;

struct ch_study {
  const ch_scene *s;
  ch_curve_set set;
  ch_height height;
  ch_truth *truth;
  ch_trace *truth_scene;
  method_run *mr; /* num_methods */
  double scene_size;
};

void ch_study_destroy(ch_study *st) {
  if (!st) return;
  for (int i = 0; st->mr && i < st->s->num_methods; i++) {
    ch_trace_destroy(st->mr[i].scene);
    ch_featshade_free(&st->mr[i].fs);
    ch_texray_destroy(st->mr[i].tr);
    ch_mesh_free(&st->mr[i].mesh);
  }
  free(st->mr);
  ch_trace_destroy(st->truth_scene);
  ch_truth_destroy(st->truth);
  ch_height_free(&st->height);
  ch_curves_free(&st->set);
  free(st);
}

ch_status ch_study_create(const ch_scene *scene, const char *scene_file, const ch_progress *progress, ch_study **out,
                          ch_error *err) {
  *out = NULL;
  ch_study *study = calloc(1, sizeof *study);
  if (study) study->mr = calloc((size_t)scene->num_methods + 1, sizeof *study->mr);
  if (!study || !study->mr) {
    free(study);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory");
  }
  study->s = scene;
  const ch_scene *s = scene;
  method_run *mr = study->mr;
  ch_height_desc hd = {.dci_resolution = s->dci_resolution, .step_method = CH_RECON_EXACT};
  ch_truth_desc td = {.grid = s->truth_grid};
  ch_progress_reportf(progress, -1.0, "reading %s", s->curves_path);
  ch_status st = ch_curves_read_svg(s->curves_path, &study->set, err);
  if (!st) st = ch_height_init(&study->height, &study->set, &hd, err);
  for (int i = 0; !st && i < s->num_methods; i++) {
    const ch_scene_method *m = &s->methods[i];
    method_run *r = &mr[i];
    ch_progress_reportf(progress, (double)i / s->num_methods, "method %s", m->name);
    st = ch_mesh_read(m->path, &r->mesh, err);
    if (!st) st = ch_trace_create_mesh(&r->mesh, m->path, &r->scene, err);
    if (!st && m->textured) {
      ch_error terr = {0};
      terr.warn = err->warn, terr.warn_user = err->warn_user;
      ch_texray_desc tex = m->tex;
      /* Relief and POM at one resolution read one map: bake it once. */
      for (int j = 0; j < i && tex.kind != CH_TEXRAY_GROOVES; j++)
        if (s->methods[j].textured && s->methods[j].tex.kind != CH_TEXRAY_GROOVES &&
            s->methods[j].tex.resolution == tex.resolution)
          tex.same_map = mr[j].tr;
      st = ch_texray_create(&tex, &study->set, &study->height, s->curves_path, &r->tr, &terr);
      if (st) ch_error_set(err, st, "%s: methods[%d] ('%s'): %s", scene_file, i, m->name, terr.message);
    }
  }
  for (int i = 0; !st && i < s->num_methods; i++)
    if (s->methods[i].featshade >= 0)
      st = ch_featshade_init(&mr[i].fs, (ch_featshade_method)s->methods[i].featshade, s->methods[i].resolution,
                             &study->set, &study->height, err);
  ch_progress_report(progress, "the truth", -1.0);
  if (!st) st = ch_truth_create(&study->height, &td, &study->truth, err);
  if (!st) st = ch_trace_create_truth(study->truth, &study->truth_scene, err);
  if (st) {
    ch_study_destroy(study);
    return st;
  }
  double tb[6];
  ch_trace_bounds(study->truth_scene, tb);
  study->scene_size = sqrt(1.0 + 1.0 + (tb[5] - tb[2]) * (tb[5] - tb[2]));
  *out = study;
  return CH_OK;
}

size_t ch_study_texture_bytes(const ch_study *study, int method) {
  if (study->mr[method].tr) return ch_texray_bytes(study->mr[method].tr);
  return study->s->methods[method].featshade >= 0 ? ch_featshade_bytes(&study->mr[method].fs) : 0;
}

double ch_study_scene_size(const ch_study *study) { return study->scene_size; }

ch_status ch_study_run(ch_study *study, const char *dir, const ch_report_info *info, const ch_progress *progress,
                       ch_study_row **rows_out, int *num_rows, int *num_files, ch_error *err) {
  const ch_scene *s = study->s;
  const method_run *mr = study->mr;
  const ch_truth *truth = study->truth;
  double scene_size = study->scene_size;
  *rows_out = NULL;
  *num_rows = 0;
  *num_files = 0;
  int nrows = 0, files = 0;
  ch_study_row *rows = calloc((size_t)(s->num_views * s->num_methods + 1), sizeof *rows);
  if (!rows) return ch_error_set(err, CH_ERR_NOMEM, "out of memory");
  ch_status st = CH_OK;
  char path[4096];
  double total = (double)s->num_views * (s->num_methods + 1);
  for (int v = 0; !st && v < s->num_views; v++) {
    const ch_scene_view *vw = &s->views[v];
    ch_image timg = {0};
    ch_render_stats rs;
    st = ch_render(study->truth_scene, truth, &vw->camera, &s->light, &timg, &rs, err);
    if (!st)
      ch_progress_reportf(progress, (v * (s->num_methods + 1) + 1) / total, "%s: truth, %ld rays in %.2f s", vw->name,
                          rs.primary_rays + rs.shadow_rays, rs.seconds);
    if (!st) snprintf(path, sizeof path, "%s/%s.truth.exr", dir, vw->name), st = ch_report_exr(path, &timg, vw->name, "truth", err), files += !st;
    if (!st)
      snprintf(path, sizeof path, "%s/%s.truth.png", dir, vw->name),
          st = ch_report_png(path, CH_REPORT_SHADE, &timg, NULL, scene_size, err), files += !st;
    if (!st)
      snprintf(path, sizeof path, "%s/%s.truth.class.png", dir, vw->name),
          st = ch_report_png(path, CH_REPORT_CLASSES, &timg, NULL, scene_size, err), files += !st;
    ch_image *imgs = calloc((size_t)s->num_methods + 1, sizeof *imgs);
    if (!imgs && !st) st = ch_error_set(err, CH_ERR_NOMEM, "out of memory");
    for (int m = 0; !st && m < s->num_methods; m++) {
      const ch_scene_method *mt = &s->methods[m];
      const method_run *mrt = &mr[m];
      ch_image *img = &imgs[m + 1];
      ch_study_row *r = &rows[nrows];
      ch_render_shader sh = mt->featshade >= 0 ? ch_featshade_shader(&mrt->fs)
                            : mt->textured      ? ch_texray_shader(mrt->tr)
                                                : ch_shader_exact_normals(truth);
      st = ch_render_shaded(mrt->scene, mt->exact_normals || mt->textured || mt->featshade >= 0 ? &sh : NULL, truth,
                            &vw->camera, &s->light, img, &rs, err);
      if (!st) st = ch_metrics_compare(img, &timg, scene_size, &r->m, err);
      if (!st) {
        r->view = v, r->method = m, r->rays = rs.primary_rays + rs.shadow_rays, r->seconds = rs.seconds;
        r->triangles = ch_trace_triangles(mrt->scene);
        nrows++;
        ch_progress_reportf(progress, (v * (s->num_methods + 1) + m + 2) / total,
                            "%s: %s, class mismatch %.3f%%, normal p95 %.2f deg", vw->name, mt->name,
                            r->m.class_mismatch, r->m.normal_p95_deg);
      }
      static const struct {
        const char *suffix;
        ch_report_picture what;
      } pics[] = {{"png", CH_REPORT_SHADE}, {"class.png", CH_REPORT_CLASS_DIFF}, {"normal.png", CH_REPORT_NORMAL}, {"depth.png", CH_REPORT_DEPTH}};
      if (!st) snprintf(path, sizeof path, "%s/%s.%s.exr", dir, vw->name, mt->name), st = ch_report_exr(path, img, vw->name, mt->name, err), files += !st;
      for (int k = 0; !st && k < 4; k++) {
        snprintf(path, sizeof path, "%s/%s.%s.%s", dir, vw->name, mt->name, pics[k].suffix);
        st = ch_report_png(path, pics[k].what, img, &timg, scene_size, err);
        files += !st;
      }
    }
    if (!st) {
      const ch_image *list[64];
      int nl = 0;
      list[nl++] = &timg;
      for (int m = 0; m < s->num_methods && nl < 64; m++) list[nl++] = &imgs[m + 1];
      snprintf(path, sizeof path, "%s/%s.montage.png", dir, vw->name);
      st = ch_report_montage(path, list, nl, err);
      files += !st;
    }
    for (int m = 0; imgs && m < s->num_methods; m++) ch_image_free(&imgs[m + 1]);
    free(imgs);
    ch_image_free(&timg);
  }
  if (!st) st = ch_report_summaries(dir, s, rows, nrows, err), files += st ? 0 : 2;
  if (!st) st = ch_report_index(dir, s, rows, nrows, info, err), files += !st;
  if (st) {
    free(rows);
    return st;
  }
  *rows_out = rows;
  *num_rows = nrows;
  *num_files = files;
  return CH_OK;
}
