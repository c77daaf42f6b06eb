/* chisel study: every method against the Embree-traced truth, per view
 * (docs/spec.md, docs/cli.md). The scene file format is documented in `usage` below. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <omp.h>
#include <sys/stat.h>
#include <unistd.h>

#include "ch_curves.h"
#include "ch_featshade.h"
#include "ch_file.h"
#include "ch_gtex.h"
#include "ch_height.h"
#include "ch_math.h"
#include "ch_mesh.h"
#include "ch_metrics.h"
#include "ch_relief.h"
#include "ch_render.h"
#include "ch_report.h"
#include "ch_scene.h"
#include "ch_texray.h"
#include "ch_trace.h"
#include "ch_truth.h"
#include "cli.h"


static const char usage[] =
    "usage: chisel study SCENE.json -o DIR\n"
    "\n"
    "Renders the true surface of the scene's curves over the planar base\n"
    "(u, v, 0) (Embree, independent of the tessellator) and every method's mesh\n"
    "from every view, and compares them pixel by pixel: visibility class\n"
    "(top, groove wall, groove floor, step wall), groove id, depth, normal,\n"
    "shading and shadows.\n"
    "\n"
    "SCENE.json (relative paths are taken from the scene file's folder):\n"
    "  {\n"
    "    \"curves\": \"curves.svg\",        required: the feature curves (SPEC 2)\n"
    "    \"dci_resolution\": 1024,        optional: the step DCI, 16..16384\n"
    "    \"truth_grid\": 512,             optional: the truth's bounds grid, a\n"
    "                                   multiple of 16 in 16..16384\n"
    "    \"light\": {\"direction\": [x, y, z], \"ambient\": 0.15, \"albedo\": 0.75,\n"
    "              \"specular\": 0.25, \"shininess\": 40},      optional, any subset\n"
    "    \"views\": [                      required, at least one\n"
    "      {\"name\": \"top\", \"eye\": [x, y, z], \"target\": [x, y, z],\n"
    "       \"up\": [0, 0, 1], \"fov\": 40, \"width\": 320, \"height\": 240,\n"
    "       \"supersample\": 2},            up, fov (degrees), supersample optional;\n"
    "                                   \"ortho_height\": h instead of fov: orthographic;\n"
    "                                   \"orbit\": n (1..64) makes n views NAME_0..NAME_n-1,\n"
    "                                   the eye turned about the vertical through the\n"
    "                                   target in steps of 360/n degrees\n"
    "    ],\n"
    "    \"methods\": [                    optional\n"
    "      {\"name\": \"snapped\", \"mesh\": \"snapped.obj\"}   OBJ/PLY/OFF/STL with UVs\n"
    "      {\"name\": \"normalmap\", \"mesh\": \"plane.obj\", \"shader\": \"exact-normals\"}\n"
    "                                   optional \"family\": methods of one family\n"
    "                                   (e.g. one method at several triangle counts)\n"
    "                                   are one line in the report's plots\n"
    "                                   a texture-space method on the base mesh:\n"
    "                                   exact-normals = the truth's normal at the\n"
    "                                   hit's UV (a perfect normal map)\n"
    "      {\"name\": \"fn\", \"mesh\": \"plane.obj\", \"shader\": \"featnorm\", \"resolution\": 256}\n"
    "                                   normals from maps built from the curves at\n"
    "                                   R x R (R in 4..4096): featnorm,\n"
    "                                   featnorm-linear (feature-curve textures),\n"
    "                                   normal-bilinear (a conventional normal map\n"
    "                                   of h), msdf (a multi-channel distance field\n"
    "                                   with the grooves' profiles)\n"
    "      {\"name\": \"g\", \"mesh\": \"plane.obj\", \"shader\": \"grooves\", \"resolution\": 128}\n"
    "                                   path-based groove textures on a G x G grid\n"
    "                                   (G in 1..4096; grooves only: a step curve is\n"
    "                                   an error), traced per ray in texture space,\n"
    "                                   walls and shadows included; \"paper\": true\n"
    "                                   intersects curved pieces as the paper does\n"
    "      {\"name\": \"r\", \"mesh\": \"plane.obj\", \"shader\": \"relief\", \"resolution\": 1024,\n"
    "       \"steps\": 32}                relief mapping (linear + binary search) on an\n"
    "                                   R x R height texture of h (R in 2..16384, as\n"
    "                                   chisel sample bakes it), K linear steps\n"
    "                                   (1..4096, default 32); \"pom\": parallax\n"
    "                                   occlusion mapping (K..K/4 steps by view angle)\n"
    "    ]\n"
    "  }\n"
    "Names are letters, digits, '-' and '_' (they name files), unique per list.\n"
    "\n"
    "Writes into DIR (created if missing), per view V and method M:\n"
    "  V.truth.exr, V.M.exr     all render layers (shade, shadow, depth, N, P, uv,\n"
    "                           class, id, coverage)\n"
    "  V.truth.png, V.M.png     the shading\n"
    "  V.truth.class.png        classes: top grey, groove wall orange, floor blue,\n"
    "                           step wall green, nothing black\n"
    "  V.M.class.png            pixels whose class differs from the truth's in red\n"
    "  V.M.normal.png           normal error, heat map 0..20 degrees\n"
    "  V.M.depth.png            depth error, heat map 0..1% of the scene size\n"
    "  V.montage.png            truth and methods' shading side by side\n"
    "  index.html               the report: table, images, error against triangles\n"
    "  summary.csv, summary.json  one row per view and method: class mismatch %\n"
    "                           (all pixels, groove pixels), groove id mismatch %,\n"
    "                           depth error / scene size, normal error mean and\n"
    "                           p95 (degrees), shading RMSE and SSIM, shadow mismatch %\n"
    "On failure nothing is left in DIR. Prints the bytes of each texture\n"
    "method's textures, then the table (Mrays/s: primary and shadow rays).\n"
    "\n"
    "  -o, --output DIR   the output folder (required)\n";

/* What run() builds per method of the scene. */
typedef struct method_run {
  ch_featshade fs;
  ch_texray *tr;
  ch_mesh mesh;
  ch_trace *scene;
} method_run;

typedef ch_scene study;

typedef struct written {
  char **paths;
  int count, cap;
} written;

static int written_add(written *w, const char *path) {
  if (w->count == w->cap) {
    int cap = w->cap ? 2 * w->cap : 32;
    char **p = realloc(w->paths, (size_t)cap * sizeof *p);
    if (!p) return 0;
    w->paths = p;
    w->cap = cap;
  }
  if (!(w->paths[w->count] = strdup(path))) return 0;
  w->count++;
  return 1;
}

static void written_free(written *w, int remove_files) {
  for (int i = 0; i < w->count; i++) {
    if (remove_files) remove(w->paths[i]);
    free(w->paths[i]);
  }
  free(w->paths);
  memset(w, 0, sizeof *w);
}


/* ---- the report's files (ch_report), counted as they are written ---- */

typedef ch_study_row row;

static ch_status counted(ch_status st, const char *path, written *w, ch_error *err) {
  if (!st && !written_add(w, path)) st = ch_error_set(err, CH_ERR_NOMEM, "out of memory");
  return st;
}

static ch_status write_png(const char *path, ch_report_picture what, const ch_image *img, const ch_image *truth,
                           double scene_size, written *w, ch_error *err) {
  return counted(ch_report_png(path, what, img, truth, scene_size, err), path, w, err);
}

static ch_status write_exr(const char *path, const ch_image *img, const char *viewname, const char *methodname,
                           written *w, ch_error *err) {
  return counted(ch_report_exr(path, img, viewname, methodname, err), path, w, err);
}

static ch_status write_montage(const char *path, const ch_image *const *imgs, int n, written *w, ch_error *err) {
  return counted(ch_report_montage(path, imgs, n, err), path, w, err);
}

static ch_status write_summaries(const char *dir, const study *s, const row *rows, int nrows, written *w, ch_error *err) {
  char path[4096];
  ch_status st = ch_report_summaries(dir, s, rows, nrows, err);
  snprintf(path, sizeof path, "%s/summary.csv", dir);
  st = counted(st, path, w, err);
  snprintf(path, sizeof path, "%s/summary.json", dir);
  return counted(st, path, w, err);
}

static ch_status write_index(const char *dir, const study *s, const row *rows, int nrows, const char *command,
                             const char *scene_path, const char *scene_text, written *w, ch_error *err) {
  char path[4096];
  const ch_report_info info = {command, scene_path, scene_text};
  snprintf(path, sizeof path, "%s/index.html", dir);
  return counted(ch_report_index(dir, s, rows, nrows, &info, err), path, w, err);
}


/* Every file the study writes into dir (as run() names them), checked
 * against its inputs and each other before any work (cli_check_files);
 * nothing to check while dir does not exist. 0 or the exit status. */
static int check_outputs(const char *cmd, const char *scene_path, const study *s, const char *dir) {
  struct stat sb;
  if (stat(dir, &sb) != 0 || !S_ISDIR(sb.st_mode)) return 0;
  static const char *const truth_files[] = {"truth.exr", "truth.png", "truth.class.png", "montage.png"};
  static const char *const method_files[] = {"exr", "png", "class.png", "normal.png", "depth.png"};
  static const char *const study_files[] = {"summary.csv", "summary.json", "index.html"};
  int per_view = 4 + 5 * s->num_methods, n = s->num_views * per_view + 3, k = 0;
  cli_file *outs = calloc((size_t)n, sizeof *outs);
  cli_file *ins = calloc((size_t)s->num_methods + 2, sizeof *ins);
  char *names = malloc((size_t)n * 4096);
  if (!outs || !ins || !names) {
    free(outs);
    free(ins);
    free(names);
    fprintf(stderr, "chisel: out of memory\n");
    return 1;
  }
  for (int v = 0; v < s->num_views; v++) {
    for (int i = 0; i < 4; i++, k++)
      snprintf(names + (size_t)k * 4096, 4096, "%s/%s.%s", dir, s->views[v].name, truth_files[i]);
    for (int m = 0; m < s->num_methods; m++)
      for (int i = 0; i < 5; i++, k++)
        snprintf(names + (size_t)k * 4096, 4096, "%s/%s.%s.%s", dir, s->views[v].name, s->methods[m].name,
                 method_files[i]);
  }
  for (int i = 0; i < 3; i++, k++) snprintf(names + (size_t)k * 4096, 4096, "%s/%s", dir, study_files[i]);
  for (int i = 0; i < n; i++) outs[i] = (cli_file){names + (size_t)i * 4096, names + (size_t)i * 4096};
  int ni = 0;
  ins[ni++] = (cli_file){"SCENE.json", scene_path};
  ins[ni++] = (cli_file){"curves", s->curves_path};
  for (int m = 0; m < s->num_methods; m++) ins[ni++] = (cli_file){s->methods[m].name, s->methods[m].path};
  int rc = cli_check_files(cmd, ins, ni, outs, n);
  free(outs);
  free(ins);
  free(names);
  return rc;
}

static int run(int argc, char **argv) {
  const char *cmd = "study";
  const char *scene_path = NULL, *dir = NULL;
  for (int i = 1; i < argc; i++) {
    const char *a = argv[i];
    if (!strcmp(a, "-o") || !strcmp(a, "--output")) {
      if (!(dir = cli_option_value(cmd, argc, argv, &i))) return 2;
    } else if (a[0] == '-' && a[1]) {
      return cli_usage_error(cmd, "unknown option '%s'", a);
    } else if (!scene_path) {
      scene_path = a;
    } else {
      return cli_usage_error(cmd, "unexpected argument '%s'", a);
    }
  }
  if (!scene_path) return cli_usage_error(cmd, "missing the scene file SCENE.json");
  if (!dir || !dir[0]) return cli_usage_error(cmd, "missing -o DIR");
  if (strlen(dir) > 3000) return cli_usage_error(cmd, "-o: path too long");

  ch_error err = cli_error();
  char *text = NULL;
  size_t size;
  study s;
  ch_curve_set set = {0};
  ch_height height = {0};
  ch_truth *truth = NULL;
  ch_trace *truth_scene = NULL;
  written w = {0};
  row *rows = NULL;
  int nrows = 0, made_dir = 0;
  if (ch_file_read_all(scene_path, 16 << 20, &text, &size, &err)) return cli_fail(&err);
  ch_status st = ch_scene_parse(scene_path, text, &s, &err);
  char *scene_text = text; /* kept for the report */
  if (st) {
    free(scene_text);
    return cli_fail(&err);
  }
  /* The command as typed (quoted where a shell would need it), for the report. */
  char command[4096];
  size_t clen = (size_t)snprintf(command, sizeof command, "chisel");
  int typed = cli_argv != NULL; /* as typed (with -q, -j), else as parsed */
  for (int i = typed ? 1 : 0; i < (typed ? cli_argc : argc) && clen < sizeof command; i++) {
    const char *a = typed ? cli_argv[i] : argv[i];
    int plain = a[0] != '\0';
    for (const char *c = a; *c; c++)
      if (!strchr("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789-_./=,:+@%", *c)) plain = 0;
    clen += (size_t)snprintf(command + clen, sizeof command - clen, plain ? " %s" : " '%s'", a);
  }
  int rc = check_outputs(cmd, scene_path, &s, dir);
  method_run *mr = rc ? NULL : calloc((size_t)s.num_methods + 1, sizeof *mr);
  if (!rc && !mr) rc = (fprintf(stderr, "chisel: out of memory\n"), 1);
  if (rc) {
    free(scene_text);
    ch_scene_free(&s);
    return rc;
  }
  double t_start = omp_get_wtime();
  /* Every input is read and checked before anything is written. */
  ch_height_desc hd = {.dci_resolution = s.dci_resolution, .step_method = CH_RECON_EXACT};
  ch_truth_desc td = {.grid = s.truth_grid};
  st = ch_curves_read_svg(s.curves_path, &set, &err);
  if (!st) st = ch_height_init(&height, &set, &hd, &err);
  for (int i = 0; !st && i < s.num_methods; i++) {
    const ch_scene_method *m = &s.methods[i];
    method_run *r = &mr[i];
    st = ch_mesh_read(m->path, &r->mesh, &err);
    if (!st) st = ch_trace_create_mesh(&r->mesh, m->path, &r->scene, &err);
    if (!st && m->textured) {
      ch_error terr = cli_error();
      ch_texray_desc tex = m->tex;
      /* Relief and POM at one resolution read one map: bake it once. */
      for (int j = 0; j < i && tex.kind != CH_TEXRAY_GROOVES; j++)
        if (s.methods[j].textured && s.methods[j].tex.kind != CH_TEXRAY_GROOVES &&
            s.methods[j].tex.resolution == tex.resolution)
          tex.same_map = mr[j].tr;
      st = ch_texray_create(&tex, &set, &height, s.curves_path, &r->tr, &terr);
      if (st) ch_error_set(&err, st, "%s: methods[%d] ('%s'): %s", scene_path, i, m->name, terr.message);
      else
        printf("texture method %s: %s at %d, %zu bytes\n", m->name,
               m->tex.kind == CH_TEXRAY_GROOVES ? "grooves" : m->tex.kind == CH_TEXRAY_RELIEF ? "relief" : "pom",
               m->tex.resolution, ch_texray_bytes(r->tr));
    }
  }
  for (int i = 0; !st && i < s.num_methods; i++)
    if (s.methods[i].featshade >= 0)
      st = ch_featshade_init(&mr[i].fs, (ch_featshade_method)s.methods[i].featshade, s.methods[i].resolution,
                             &set, &height, &err);
  if (!st) st = ch_truth_create(&height, &td, &truth, &err);
  if (!st) st = ch_trace_create_truth(truth, &truth_scene, &err);
  if (!st) {
    struct stat sb;
    if (stat(dir, &sb) == 0) {
      if (!S_ISDIR(sb.st_mode)) st = ch_error_set(&err, CH_ERR_IO, "%s: exists and is not a folder", dir);
    } else if (mkdir(dir, 0777) == 0) {
      made_dir = 1;
    } else {
      st = ch_error_set(&err, CH_ERR_IO, "%s: cannot create the folder: %s", dir, strerror(errno));
    }
    if (!st && access(dir, W_OK) != 0)
      st = ch_error_set(&err, CH_ERR_IO, "%s: cannot write into the folder: %s", dir, strerror(errno));
  }
  rows = calloc((size_t)(s.num_views * s.num_methods + 1), sizeof *rows);
  if (!st && !rows) st = ch_error_set(&err, CH_ERR_NOMEM, "out of memory");
  double tb[6];
  if (!st) ch_trace_bounds(truth_scene, tb);
  double scene_size = st ? 1.0 : sqrt(1.0 + 1.0 + (tb[5] - tb[2]) * (tb[5] - tb[2]));
  int progress = isatty(2) && !cli_quiet;
  char path[4096];
  for (int v = 0; !st && v < s.num_views; v++) {
    const ch_scene_view *vw = &s.views[v];
    ch_image timg = {0};
    ch_render_stats rs;
    st = ch_render(truth_scene, truth, &vw->camera, &s.light, &timg, &rs, &err);
    if (!st && progress)
      fprintf(stderr, "study: %s: truth, %ld rays in %.2f s\n", vw->name, rs.primary_rays + rs.shadow_rays, rs.seconds);
    if (!st) snprintf(path, sizeof path, "%s/%s.truth.exr", dir, vw->name), st = write_exr(path, &timg, vw->name, "truth", &w, &err);
    if (!st) snprintf(path, sizeof path, "%s/%s.truth.png", dir, vw->name), st = write_png(path, CH_REPORT_SHADE, &timg, NULL, scene_size, &w, &err);
    if (!st)
      snprintf(path, sizeof path, "%s/%s.truth.class.png", dir, vw->name),
          st = write_png(path, CH_REPORT_CLASSES, &timg, NULL, scene_size, &w, &err);
    ch_image *imgs = calloc((size_t)s.num_methods + 1, sizeof *imgs);
    if (!imgs) st = ch_error_set(&err, CH_ERR_NOMEM, "out of memory");
    for (int m = 0; !st && m < s.num_methods; m++) {
      const ch_scene_method *mt = &s.methods[m];
      const method_run *mrt = &mr[m];
      ch_image *img = &imgs[m + 1];
      row *r = &rows[nrows];
      ch_render_shader sh = mt->featshade >= 0 ? ch_featshade_shader(&mrt->fs)
                            : mt->textured      ? ch_texray_shader(mrt->tr)
                                                : ch_shader_exact_normals(truth);
      st = ch_render_shaded(mrt->scene, mt->exact_normals || mt->textured || mt->featshade >= 0 ? &sh : NULL, truth,
                            &vw->camera, &s.light, img, &rs, &err);
      if (!st) st = ch_metrics_compare(img, &timg, scene_size, &r->m, &err);
      if (!st) {
        r->view = v, r->method = m, r->rays = rs.primary_rays + rs.shadow_rays, r->seconds = rs.seconds;
        r->triangles = ch_trace_triangles(mrt->scene);
        nrows++;
        if (progress)
          fprintf(stderr, "study: %s: %s, class mismatch %.3f%%, normal p95 %.2f deg\n", vw->name, mt->name,
                  r->m.class_mismatch, r->m.normal_p95_deg);
      }
      static const struct {
        const char *suffix;
        ch_report_picture what;
      } pics[] = {{"png", CH_REPORT_SHADE}, {"class.png", CH_REPORT_CLASS_DIFF}, {"normal.png", CH_REPORT_NORMAL}, {"depth.png", CH_REPORT_DEPTH}};
      if (!st) snprintf(path, sizeof path, "%s/%s.%s.exr", dir, vw->name, mt->name), st = write_exr(path, img, vw->name, mt->name, &w, &err);
      for (int k = 0; !st && k < 4; k++) {
        snprintf(path, sizeof path, "%s/%s.%s.%s", dir, vw->name, mt->name, pics[k].suffix);
        st = write_png(path, pics[k].what, img, &timg, scene_size, &w, &err);
      }
    }
    if (!st) {
      const ch_image *list[64];
      int nl = 0;
      list[nl++] = &timg;
      for (int m = 0; m < s.num_methods && nl < 64; m++) list[nl++] = &imgs[m + 1];
      snprintf(path, sizeof path, "%s/%s.montage.png", dir, vw->name);
      st = write_montage(path, list, nl, &w, &err);
    }
    for (int m = 0; imgs && m < s.num_methods; m++) ch_image_free(&imgs[m + 1]);
    free(imgs);
    ch_image_free(&timg);
  }
  if (!st) st = write_summaries(dir, &s, rows, nrows, &w, &err);
  if (!st) st = write_index(dir, &s, rows, nrows, command, scene_path, scene_text ? scene_text : "", &w, &err);
  if (!st) {
    printf("%-12s %-12s %9s %9s %9s %10s %9s %9s %9s %9s %9s %8s\n", "view", "method", "class%", "groove%", "id%",
           "depth", "n_mean", "n_p95", "shade", "ssim", "shadow%", "Mrays/s");
    for (int i = 0; i < nrows; i++) {
      const ch_metrics *m = &rows[i].m;
      printf("%-12s %-12s %9.4f %9.4f %9.4f %10.3e %9.3f %9.3f %9.4f %9.5f %9.4f %8.2f\n",
             s.views[rows[i].view].name, s.methods[rows[i].method].name, m->class_mismatch, m->class_mismatch_groove,
             m->id_mismatch, m->depth_error, m->normal_mean_deg, m->normal_p95_deg, m->shade_rmse, m->shade_ssim,
             m->shadow_mismatch, rows[i].seconds > 0 ? rows[i].rays / rows[i].seconds * 1e-6 : 0.0);
    }
  }
  if (!st)
    cli_result("wrote %s/index.html and %d files (%d views x %d methods) in %.1f s", dir, w.count - 1, s.num_views,
               s.num_methods, omp_get_wtime() - t_start);
  free(scene_text);
  written_free(&w, 0); /* staged (cli_run): on failure they are removed, previous files kept */
  if (st) ch_file_stage_abort(); /* before the folder it made goes */
  if (st && made_dir) rmdir(dir);
  free(rows);
  ch_trace_destroy(truth_scene);
  ch_truth_destroy(truth);
  ch_height_free(&height);
  ch_curves_free(&set);
  for (int i = 0; i < s.num_methods; i++) {
    ch_trace_destroy(mr[i].scene);
    ch_featshade_free(&mr[i].fs);
    ch_texray_destroy(mr[i].tr);
    ch_mesh_free(&mr[i].mesh);
  }
  free(mr);
  ch_scene_free(&s);
  return st ? cli_fail(&err) : 0;
}

const cli_command cli_study_command = {
    "study", "meshes and texture methods (groove textures, relief mapping) against the Embree-traced true surface",
    usage, run};
