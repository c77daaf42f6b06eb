/* chisel study: every method against the Embree-traced truth, per view
 * (docs/spec.md, docs/cli.md). The scene file format is documented in `usage` below. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <omp.h>
#include <sys/stat.h>
#include <unistd.h>

#include "ch_featshade.h"
#include "ch_file.h"
#include "ch_metrics.h"
#include "ch_report.h"
#include "ch_scene.h"
#include "ch_study.h"
#include "ch_texray.h"
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
    "                                   (1..4096, default 32); \"shader\": \"pom\" with\n"
    "                                   the same keys: parallax occlusion mapping\n"
    "                                   (K..K/4 steps by view angle)\n"
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

/* Every file the study writes into dir (as run() names them), checked
 * against its inputs and each other before any work (cli_check_files);
 * nothing to check while dir does not exist. 0 or the exit status. */
static int check_outputs(const char *cmd, const char *scene_path, const ch_scene *s, const char *dir) {
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

/* The study's progress, one line per stage (ch_progress). */
static void print_progress(void *user, const char *stage, double fraction) {
  (void)user, (void)fraction;
  fprintf(stderr, "study: %s\n", stage);
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
  ch_scene s;
  ch_study *study = NULL;
  ch_study_row *rows = NULL;
  int nrows = 0, nfiles = 0, made_dir = 0;
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
  if (rc) {
    free(scene_text);
    ch_scene_free(&s);
    return rc;
  }
  double t_start = omp_get_wtime();
  /* Every input is read and checked before anything is written. */
  st = ch_study_create(&s, scene_path, NULL, &study, &err);
  for (int i = 0; !st && i < s.num_methods; i++) {
    const ch_scene_method *m = &s.methods[i];
    if (m->textured)
      printf("texture method %s: %s at %d, %zu bytes\n", m->name,
             m->tex.kind == CH_TEXRAY_GROOVES ? "grooves" : m->tex.kind == CH_TEXRAY_RELIEF ? "relief" : "pom",
             m->tex.resolution, ch_study_texture_bytes(study, i));
    else if (m->featshade >= 0)
      printf("texture method %s: %s at %d, %zu bytes\n", m->name, ch_featshade_method_name((ch_featshade_method)m->featshade), m->resolution,
             ch_study_texture_bytes(study, i));
  }
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
  /* A line per render on a terminal (stderr), as the study goes. */
  const ch_progress progress = {print_progress, NULL};
  const ch_report_info info = {command, scene_path, scene_text};
  if (!st)
    st = ch_study_run(study, dir, &info, isatty(2) && !cli_quiet ? &progress : NULL, &rows, &nrows, &nfiles, &err);
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
    cli_result("wrote %s/index.html and %d files (%d views x %d methods) in %.1f s", dir, nfiles - 1, s.num_views,
               s.num_methods, omp_get_wtime() - t_start);
  free(scene_text);
  /* Staged (cli_run): on failure they are removed, previous files kept. */
  if (st) ch_file_stage_abort(); /* before the folder it made goes */
  if (st && made_dir) rmdir(dir);
  free(rows);
  ch_study_destroy(study);
  ch_scene_free(&s);
  return st ? cli_fail(&err) : 0;
}

const cli_command cli_study_command = {
    "study", "meshes and texture methods (groove textures, relief mapping) against the Embree-traced true surface",
    usage, run};
