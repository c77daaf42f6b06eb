/* chisel-accuracy: the accuracy figures for displaced meshes over
 * the planar base (see accuracy.h for the definitions).
 *
 * usage: chisel-accuracy MESH.obj [MORE.obj ...] CURVES.svg [--grid 2048]
 *                        [--dci-res 4096] [--json] [--verbose]
 * One line per mesh: text, or one JSON object. Several meshes share one
 * reference (h, distances to features, exact gradients), which is where the
 * time goes for step curves (the DCI). Exit status: 0, 2 bad input or usage,
 * 1 internal failure. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "accuracy.h"
#include "ch_png.h"
#include "ch_warp.h"

static const char usage[] =
    "usage: chisel-accuracy MESH.obj [MORE.obj ...] CURVES.svg [--grid G] [--dci-res R] [--json] [--verbose]\n"
    "                       [--error-png PREFIX] [--normal-png PREFIX] [--shading-png PREFIX]\n"
    "                       [--camera E,A,FOV]\n"
    "\n"
    "Rasterises each mesh's non-vertical triangles in xy on the cell centres of a\n"
    "G x G grid over the unit square (planar base: z should be h(x, y)) and prints\n"
    "L1, band error, normal error near features (mean, p95: the facets'; for an OBJ\n"
    "with vn on every corner also the shading normals', vn interpolated across each\n"
    "triangle as smooth shading does) and holes.\n"
    "  --grid G      sample grid, 16..16384 (default 2048)\n"
    "  --dci-res R   resolution of the step curves' DCI for the exact h (default 4096)\n"
    "  --json        one JSON object per mesh instead of a text line\n"
    "  --verbose     timings, and the first uncovered samples (holes), on stderr\n"
    "  --error-png P writes P<k>.png per mesh k (from 0): the error (z - h) / max|h|\n"
    "                in false colour (blue below, red above), uncovered samples 0\n"
    "  --normal-png P writes P<k>.png: the normal error (degrees, 10 full blue) on\n"
    "                the samples the normal figures use\n"
    "  --shading-png P likewise for the shading normals' error\n"
    "  --camera ex,ey,ez,ax,ay,az,fov  count only the samples this camera sees\n"
    "                (chisel displace --camera): (u, v, 0) inside its square frustum\n"
    "                and in front of it, from above the plane (bench/warp.sh)\n";

static void print_warning(void *user, const char *message) {
  (void)user;
  fprintf(stderr, "chisel-accuracy: warning: %s\n", message);
}

static int fail(const ch_error *err) {
  fprintf(stderr, "chisel-accuracy: %s\n", err->message[0] ? err->message : ch_status_name(err->status));
  int code = ch_status_exit_code(err->status);
  return code ? code : 1;
}

static int usage_error(const char *what, const char *arg) {
  fprintf(stderr, "chisel-accuracy: %s%s%s\n%s", what, arg ? " " : "", arg ? arg : "", usage);
  return 2;
}

static int parse_int(const char *text, long lo, long hi, long *out) {
  char *end;
  errno = 0;
  long v = strtol(text, &end, 10);
  if (end == text || *end || errno || v < lo || v > hi) return -1;
  *out = v;
  return 0;
}

static double now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* A plain OBJ reader (ch_accuracy_parse_obj) for .obj: ch_mesh_read goes
 * through OpenMesh, which takes about 7 s for a 2.1M-triangle OBJ; this
 * takes well under 1 s. Anything but .obj goes to ch_mesh_read. */
static ch_status read_obj_fast(const char *path, ch_mesh *m, ch_error *err) {
  memset(m, 0, sizeof *m);
  FILE *fp = fopen(path, "rb");
  if (!fp) return ch_error_set(err, CH_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
  char *text = NULL;
  size_t size = 0, cap = 0;
  for (;;) {
    if (cap - size < (1u << 20)) {
      cap = cap ? 2 * cap : (size_t)1 << 24;
      char *grown = realloc(text, cap + 1);
      if (!grown) {
        free(text);
        fclose(fp);
        return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory", path);
      }
      text = grown;
    }
    size_t got = fread(text + size, 1, cap - size, fp);
    size += got;
    if (got == 0) break;
  }
  int bad_read = ferror(fp);
  fclose(fp);
  if (bad_read) {
    free(text);
    return ch_error_set(err, CH_ERR_IO, "%s: read error", path);
  }
  text[size] = '\0';
  ch_status st = ch_accuracy_parse_obj(text, size, path, m, err);
  free(text);
  return st;
}

static ch_status read_mesh(const char *path, ch_mesh *m, ch_error *err) {
  size_t n = strlen(path);
  if (n >= 4 && (!strcmp(path + n - 4, ".obj") || !strcmp(path + n - 4, ".OBJ"))) return read_obj_fast(path, m, err);
  return ch_mesh_read(path, m, err);
}

/* JSON string body: paths with quotes or backslashes are escaped. */
/* Writes PREFIX<k>.png: a G x G sample map (rows up from v = 0; PNG rows
 * run down from v = 1) as a height preview of sign * value, capped at
 * `full` with the scale fixed there when full > 0; uncovered (NaN) is 0. */
static ch_status write_map_png(const char *prefix, int k, const float *map, size_t G, float sign, float full,
                               ch_error *err) {
  float *img = malloc(G * G * sizeof *img);
  if (!img) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for a %zux%zu map", G, G);
  char name[4096];
  snprintf(name, sizeof name, "%s%d.png", prefix, k);
  for (size_t j = 0; j < G; j++)
    for (size_t i = 0; i < G; i++) {
      float e = map[j * G + i];
      img[(G - 1 - j) * G + i] = e == e ? sign * (full > 0.0f ? fminf(e, full) : e) : 0.0f;
    }
  if (full > 0.0f) img[0] = sign * full; /* fixes the scale */
  ch_status st = ch_png_write_height(name, img, (int)G, (int)G, err);
  free(img);
  return st;
}

static void json_string(const char *s) {
  putchar('"');
  for (; *s; s++) {
    if (*s == '"' || *s == '\\') putchar('\\');
    if ((unsigned char)*s < 0x20) printf("\\u%04x", (unsigned char)*s);
    else putchar(*s);
  }
  putchar('"');
}

int main(int argc, char **argv) {
  const char *paths[256];
  int npaths = 0, json = 0, verbose = 0;
  const char *error_png = NULL, *normal_png = NULL, *shading_png = NULL;
  long grid = 2048, dci_res = 4096;
  const char *camera_text = NULL;
  for (int i = 1; i < argc; i++) {
    const char *a = argv[i];
    if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
      fputs(usage, stdout);
      return 0;
    } else if (!strcmp(a, "--grid") || !strcmp(a, "--dci-res")) {
      if (i + 1 >= argc) return usage_error("missing the value of", a);
      int bad = !strcmp(a, "--grid") ? parse_int(argv[i + 1], 16, 16384, &grid)
                                     : parse_int(argv[i + 1], 16, 16384, &dci_res);
      if (bad) return usage_error("bad value (16..16384) for", a);
      i++;
    } else if (!strcmp(a, "--normal-png")) {
      if (i + 1 >= argc) return usage_error("missing the value of", a);
      normal_png = argv[++i];
    } else if (!strcmp(a, "--shading-png")) {
      if (i + 1 >= argc) return usage_error("missing the value of", a);
      shading_png = argv[++i];
    } else if (!strcmp(a, "--error-png")) {
      if (i + 1 >= argc) return usage_error("missing the value of", a);
      error_png = argv[++i];
    } else if (!strcmp(a, "--camera")) {
      if (i + 1 >= argc) return usage_error("missing the value of", a);
      camera_text = argv[++i];
    } else if (!strcmp(a, "--json")) {
      json = 1;
    } else if (!strcmp(a, "--verbose") || !strcmp(a, "-v")) {
      verbose = 1;
    } else if (a[0] == '-' && a[1]) {
      return usage_error("unknown option", a);
    } else {
      if (npaths >= 256) return usage_error("too many files", NULL);
      paths[npaths++] = a;
    }
  }
  if (npaths < 2) return usage_error("needs MESH.obj and CURVES.svg", NULL);
  const char *svg = paths[npaths - 1];

  ch_error err = {0};
  err.warn = print_warning;
  ch_camera camera;
  if (camera_text) {
    double v[7];
    char *end = NULL;
    const char *p = camera_text;
    for (int k = 0; k < 7; k++, p = end + 1) {
      v[k] = strtod(p, &end);
      if (end == p || (k < 6 ? *end != ',' : *end != '\0')) return usage_error("bad value (7 numbers) for", "--camera");
    }
    if (ch_camera_init(&camera, v, &err)) return fail(&err);
  }
  ch_curve_set set;
  double t0 = now();
  if (ch_curves_read_svg(svg, &set, &err)) return fail(&err);
  ch_height height;
  ch_height_desc hd = {.dci_resolution = (int)dci_res, .step_method = CH_RECON_EXACT};
  if (ch_height_init(&height, &set, &hd, &err)) {
    ch_curves_free(&set);
    return fail(&err);
  }
  double t1 = now();
  ch_accuracy_reference ref;
  if (ch_accuracy_reference_init(&ref, &height, &set, (int)grid, &err)) {
    ch_height_free(&height);
    ch_curves_free(&set);
    return fail(&err);
  }
  unsigned char *mask = NULL;
  if (camera_text) { /* the plane's samples the camera sees: in front, in the frustum, from above */
    if (!(mask = malloc((size_t)grid * (size_t)grid))) {
      fprintf(stderr, "chisel-accuracy: out of memory for the camera mask\n");
      return 1;
    }
    long seen = 0;
    for (long j = 0; j < grid; j++)
      for (long i = 0; i < grid; i++) {
        double p[3] = {(i + 0.5) / grid, (j + 0.5) / grid, 0.0}, ndc[2], depth;
        int in = camera.eye[2] > 0.0 && ch_camera_project(&camera, p, ndc, &depth) && fabs(ndc[0]) <= 1.0 &&
                 fabs(ndc[1]) <= 1.0;
        mask[j * grid + i] = (unsigned char)in;
        seen += in;
      }
    ref.mask = mask;
    if (verbose) fprintf(stderr, "chisel-accuracy: the camera sees %.2f%% of the samples\n", 100.0 * seen / ((double)grid * grid));
  }
  double t2 = now();
  if (verbose)
    fprintf(stderr, "chisel-accuracy: %s: h (DCI %ld) %.2f s, reference %ld^2 %.2f s\n", svg, dci_res, t1 - t0,
            grid, t2 - t1);
  int rc = 0;
  if ((error_png || verbose) && !(ref.error_map = malloc((size_t)grid * (size_t)grid * sizeof *ref.error_map))) {
    fprintf(stderr, "chisel-accuracy: out of memory for the error map\n");
    rc = 1;
  }
  if (normal_png && !(ref.normal_map = malloc((size_t)grid * (size_t)grid * sizeof *ref.normal_map))) {
    fprintf(stderr, "chisel-accuracy: out of memory for the normal map\n");
    rc = 1;
  }
  if (shading_png && !(ref.shading_map = malloc((size_t)grid * (size_t)grid * sizeof *ref.shading_map))) {
    fprintf(stderr, "chisel-accuracy: out of memory for the shading map\n");
    rc = 1;
  }
  for (int m = 0; !rc && m + 1 < npaths; m++) {
    ch_mesh mesh;
    double t3 = now();
    if (read_mesh(paths[m], &mesh, &err)) {
      rc = fail(&err);
      break;
    }
    double t4 = now();
    ch_accuracy a;
    ch_status st = ch_accuracy_measure_reference(&ref, &mesh, &a, &err);
    double t5 = now();
    ch_mesh_free(&mesh);
    if (st) {
      rc = fail(&err);
      break;
    }
    if (verbose) {
      fprintf(stderr, "chisel-accuracy: %s: read %.2f s, measure %.2f s\n", paths[m], t4 - t3, t5 - t4);
      long worst = -1;
      for (long k = 0; k < grid * grid; k++)
        if (ref.error_map[k] == ref.error_map[k] && (worst < 0 || fabsf(ref.error_map[k]) > fabsf(ref.error_map[worst])))
          worst = k;
      if (worst >= 0)
        fprintf(stderr, "chisel-accuracy: %s: largest error %.4g of max |h| at uv (%.6f, %.6f)\n", paths[m],
                ref.error_map[worst], (worst % grid + 0.5) / grid, (worst / grid + 0.5) / grid);
      /* Where the error lives: its share of the L1 sum (and of the samples)
       * by distance to the nearest wall or crease, in mean edges e. */
      static const double edges[] = {0.25, 1.0, 2.0, 4.0, INFINITY};
      double part[5] = {0}, total = 0.0;
      long cnt[5] = {0}, all = 0;
      for (long k = 0; k < grid * grid; k++) {
        float x = ref.error_map[k];
        if (x != x) continue;
        int b = 0;
        while (b < 4 && !(ref.dist[k] < edges[b] * a.edge_length)) b++;
        part[b] += fabsf(x);
        total += fabsf(x);
        cnt[b]++;
        all++;
      }
      if (total > 0.0)
        fprintf(stderr,
                "chisel-accuracy: %s: L1 by distance to the features (e): < 1/4 %.1f%% (%.1f%% of samples), < 1 "
                "%.1f%% (%.1f%%), < 2 %.1f%% (%.1f%%), < 4 %.1f%% (%.1f%%), beyond %.1f%% (%.1f%%)\n",
                paths[m], 100 * part[0] / total, 100.0 * cnt[0] / all, 100 * part[1] / total, 100.0 * cnt[1] / all,
                100 * part[2] / total, 100.0 * cnt[2] / all, 100 * part[3] / total, 100.0 * cnt[3] / all,
                100 * part[4] / total, 100.0 * cnt[4] / all);
      int shown = 0;
      for (long k = 0; k < grid * grid && shown < 8; k++)
        if (ref.error_map[k] != ref.error_map[k]) /* uncovered */
          fprintf(stderr, "chisel-accuracy: %s: hole at uv (%.6f, %.6f)\n", paths[m], (k % grid + 0.5) / grid,
                  (k / grid + 0.5) / grid), shown++;
    }
    /* Normal error as -h so the height preview draws it blue, 10 deg full. */
    if (normal_png && (st = write_map_png(normal_png, m, ref.normal_map, (size_t)grid, -1.0f, 10.0f, &err))) {
      rc = fail(&err);
      break;
    }
    if (shading_png && (st = write_map_png(shading_png, m, ref.shading_map, (size_t)grid, -1.0f, 10.0f, &err))) {
      rc = fail(&err);
      break;
    }
    if (error_png && (st = write_map_png(error_png, m, ref.error_map, (size_t)grid, 1.0f, 0.0f, &err))) {
      rc = fail(&err);
      break;
    }
    if (json) {
      printf("{\"mesh\": ");
      json_string(paths[m]);
      printf(", \"curves\": ");
      json_string(svg);
      printf(
          ", \"grid\": %ld, \"dci_res\": %ld, \"triangles\": %ld, \"edge_length\": %.9g, "
          "\"max_abs_h\": %.9g, \"l1\": %.9g, \"band\": %.9g, \"normal_mean_deg\": %.9g, "
          "\"normal_p95_deg\": %.9g, \"holes\": %.9g, \"samples\": %ld, \"band_samples\": %ld, "
          "\"normal_samples\": %ld, \"counted\": %ld, \"shading_samples\": %ld",
          grid, dci_res, a.triangles, a.edge_length, a.max_abs_h, a.l1, a.band, a.normal_mean_deg, a.normal_p95_deg,
          a.holes, a.samples, a.band_samples, a.normal_samples, a.counted, a.shading_samples);
      /* (JSON has no NaN: null for a mesh without normals) */
      if (a.shading_samples > 0)
        printf(", \"shading_mean_deg\": %.9g, \"shading_p95_deg\": %.9g}\n", a.shading_mean_deg, a.shading_p95_deg);
      else
        printf(", \"shading_mean_deg\": null, \"shading_p95_deg\": null}\n");
    } else {
      printf(
          "%s: triangles %ld e %.4g L1 %.4g band %.4g (%ld samples) normal mean %.3g p95 %.3g deg (%ld "
          "samples)",
          paths[m], a.triangles, a.edge_length, a.l1, a.band, a.band_samples, a.normal_mean_deg, a.normal_p95_deg,
          a.normal_samples);
      if (a.shading_samples > 0) printf(" shading mean %.3g p95 %.3g deg", a.shading_mean_deg, a.shading_p95_deg);
      printf(" holes %.4g max|h| %.4g\n", a.holes, a.max_abs_h);
    }
    fflush(stdout);
  }
  free(ref.error_map);
  free(ref.normal_map);
  free(ref.shading_map);
  free(mask);
  ch_accuracy_reference_free(&ref);
  ch_height_free(&height);
  ch_curves_free(&set);
  return rc;
}
