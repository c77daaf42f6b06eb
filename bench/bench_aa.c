/* Anti-aliasing of the path-based groove textures (path-based-grooves
 * §5.7): per pixel, the shading from one sample at the centre, from 2 x 2
 * samples, and from the paper's scheme (region sampling where the pixel
 * sees one isolated straight groove, else 4 samples halfway between the
 * centre and the corners), against 16 x 16 samples; by the pixel's
 * footprint in grid cells, since the paper's §7 expects its scheme to
 * break down beyond a few texels. Shading as chisel study's: Lambert with
 * an ambient term and shadows (texture-space shadow rays), no specular.
 *
 *   bench_aa CURVES.svg [G] [WIDTH]
 *
 * Views: the study's oblique orbit view, a grazing one (15 degrees) and a
 * close-up; WIDTH x 3/4 WIDTH pixels (default 160). */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"
#include "ch_curves.h"
#include "ch_gtex.h"

typedef struct cam {
  const char *name;
  double eye[3], target[3], fov;
  double f[3], r[3], u[3], hh, hw;
  int W, H;
} cam;

static void setup(cam *c, int W) {
  c->W = W;
  c->H = W * 3 / 4;
  double l = 0.0;
  for (int k = 0; k < 3; k++) c->f[k] = c->target[k] - c->eye[k], l += c->f[k] * c->f[k];
  for (int k = 0; k < 3; k++) c->f[k] /= sqrt(l);
  double up[3] = {0, 0, 1};
  c->r[0] = c->f[1] * up[2] - c->f[2] * up[1], c->r[1] = c->f[2] * up[0] - c->f[0] * up[2], c->r[2] = c->f[0] * up[1] - c->f[1] * up[0];
  l = sqrt(c->r[0] * c->r[0] + c->r[1] * c->r[1] + c->r[2] * c->r[2]);
  for (int k = 0; k < 3; k++) c->r[k] /= l;
  c->u[0] = c->r[1] * c->f[2] - c->r[2] * c->f[1], c->u[1] = c->r[2] * c->f[0] - c->r[0] * c->f[2];
  c->u[2] = c->r[0] * c->f[1] - c->r[1] * c->f[0];
  c->hh = tan(0.5 * c->fov * 3.14159265358979323846 / 180.0);
  c->hw = c->hh * c->W / c->H;
}

static void ray_dir(const cam *c, double px, double py, double d[3]) {
  double sx = (2.0 * px / c->W - 1.0) * c->hw, sy = (1.0 - 2.0 * py / c->H) * c->hh, l = 0.0;
  for (int k = 0; k < 3; k++) d[k] = c->f[k] + sx * c->r[k] + sy * c->u[k], l += d[k] * d[k];
  for (int k = 0; k < 3; k++) d[k] /= sqrt(l);
}

static const double light[3] = {-0.35 / 0.98, -0.45 / 0.98, 0.82 / 0.98}; /* about the study's default */

static double shade(const double n[3], int lit) {
  double nl = n[0] * light[0] + n[1] * light[1] + n[2] * light[2];
  return 0.75 * (0.15 + 0.85 * (nl > 0.0 ? nl : 0.0) * lit);
}

/* One point sample: 0 for a miss (outside the square). */
static double sample(const ch_gtex *g, const cam *c, double px, double py) {
  double d[3];
  ray_dir(c, px, py, d);
  ch_gtex_hit h;
  if (!ch_gtex_intersect(g, c->eye, d, 0.0, INFINITY, &h)) return 0.0;
  double n[3] = {h.normal[0], h.normal[1], h.normal[2]};
  if (n[0] * d[0] + n[1] * d[1] + n[2] * d[2] > 0.0)
    for (int k = 0; k < 3; k++) n[k] = -n[k];
  int lit = 0;
  if (n[0] * light[0] + n[1] * light[1] + n[2] * light[2] > 0.0) {
    double o[3];
    for (int k = 0; k < 3; k++) o[k] = h.point[k] + 1e-7 * n[k];
    lit = !ch_gtex_occluded(g, o, light, 0.0, INFINITY);
  }
  return shade(n, lit);
}

/* Where the ray through image point (px, py) meets the base plane. */
static int base_point(const cam *c, double px, double py, double p[2]) {
  double d[3];
  ray_dir(c, px, py, d);
  if (!(d[2] < 0.0)) return 0;
  double t = -c->eye[2] / d[2];
  p[0] = c->eye[0] + t * d[0];
  p[1] = c->eye[1] + t * d[1];
  return 1;
}

int main(int argc, char **argv) {
  if (argc < 2) {
    fprintf(stderr, "usage: bench_aa CURVES.svg [G] [WIDTH]\n");
    return 2;
  }
  int G = argc > 2 ? atoi(argv[2]) : 128, W = argc > 3 ? atoi(argv[3]) : 160;
  ch_error err = {0};
  ch_curve_set set;
  ch_gtex g;
  ch_gtex_desc gd = {.resolution = G};
  if (ch_curves_read_svg(argv[1], &set, &err) || ch_gtex_build(&g, &set, &gd, argv[1], &err)) {
    fprintf(stderr, "bench_aa: %s\n", err.message);
    return 1;
  }
  cam cams[3] = {{.name = "oblique", .eye = {0.2, -0.4, 0.9}, .target = {0.5, 0.5, -0.01}, .fov = 40},
                 {.name = "grazing15", .eye = {0.5, -0.3, 0.215}, .target = {0.5, 0.5, 0.0}, .fov = 50},
                 {.name = "closeup", .eye = {0.42, 0.3, 0.14}, .target = {0.5, 0.5, -0.01}, .fov = 30}};
  printf("%s, G = %d, %d x %d pixels: shading error against 16 x 16 samples (RMSE; share of pixels off by > 0.02)\n",
         argv[1], G, W, W * 3 / 4);
  printf("%-10s %-22s %8s %18s %18s %18s %10s\n", "view", "footprint (cells)", "pixels", "1 sample", "2 x 2", "paper (region/4)",
         "region %");
  for (int v = 0; v < 3; v++) {
    cam *c = &cams[v];
    setup(c, W);
    int n = c->W * c->H;
    double *ref = malloc(n * sizeof *ref), *one = malloc(n * sizeof *one), *four = malloc(n * sizeof *four);
    double *paper = malloc(n * sizeof *paper), *foot = malloc(n * sizeof *foot);
    int *region = calloc(n, sizeof *region);
    double t0 = bench_now();
#pragma omp parallel for schedule(dynamic, 1)
    for (int y = 0; y < c->H; y++)
      for (int x = 0; x < c->W; x++) {
        int p = y * c->W + x;
        double acc = 0.0;
        for (int j = 0; j < 16; j++)
          for (int i = 0; i < 16; i++) acc += sample(&g, c, x + (i + 0.5) / 16, y + (j + 0.5) / 16);
        ref[p] = acc / 256;
        one[p] = sample(&g, c, x + 0.5, y + 0.5);
        acc = 0.0;
        for (int j = 0; j < 2; j++)
          for (int i = 0; i < 2; i++) acc += sample(&g, c, x + 0.25 + 0.5 * i, y + 0.25 + 0.5 * j);
        four[p] = acc / 4;
        /* The footprint on the base plane, and the paper's scheme. */
        double a[2], b[2], cc[2], m[2];
        foot[p] = -1.0;
        paper[p] = four[p]; /* the fallback: 4 samples halfway to the corners */
        if (base_point(c, x + 0.5, y + 0.5, m) && base_point(c, x, y + 0.5, a) && base_point(c, x + 1, y + 0.5, b) &&
            base_point(c, x + 0.5, y, cc)) {
          double du[2] = {b[0] - a[0], b[1] - a[1]}, dv[2] = {2.0 * (m[0] - cc[0]), 2.0 * (m[1] - cc[1])};
          foot[p] = fmax(hypot(du[0], du[1]), hypot(dv[0], dv[1])) * G;
          double d[3];
          ray_dir(c, x + 0.5, y + 0.5, d);
          ch_gtex_facet f[CH_GTEX_MAX_FACETS];
          int nf = ch_gtex_region(&g, m, d, du, dv, light, f);
          if (nf > 0) {
            double s = 0.0;
            for (int k = 0; k < nf; k++) {
              double nn[3] = {f[k].normal[0], f[k].normal[1], f[k].normal[2]};
              s += f[k].lit * shade(nn, 1) + (f[k].weight - f[k].lit) * shade(nn, 0);
            }
            paper[p] = s;
            region[p] = 1;
          }
        }
      }
    double secs = bench_now() - t0;
    static const double edges[4] = {0.0, 1.0, 4.0, 1e30};
    static const char *names[4] = {"under 1", "1 to 4", "over 4", "all"};
    for (int cls = 0; cls < 4; cls++) {
      double e1 = 0, e4 = 0, ep = 0;
      long cnt = 0, b1 = 0, b4 = 0, bp = 0, reg = 0;
      for (int p = 0; p < n; p++) {
        if (cls < 3 && !(foot[p] >= edges[cls] && foot[p] < edges[cls + 1])) continue;
        cnt++;
        e1 += (one[p] - ref[p]) * (one[p] - ref[p]);
        e4 += (four[p] - ref[p]) * (four[p] - ref[p]);
        ep += (paper[p] - ref[p]) * (paper[p] - ref[p]);
        b1 += fabs(one[p] - ref[p]) > 0.02;
        b4 += fabs(four[p] - ref[p]) > 0.02;
        bp += fabs(paper[p] - ref[p]) > 0.02;
        reg += region[p];
      }
      if (!cnt) continue;
      printf("%-10s %-22s %8ld %8.4f (%5.1f%%) %8.4f (%5.1f%%) %8.4f (%5.1f%%) %9.1f%%\n", c->name, names[cls], cnt,
             sqrt(e1 / cnt), 100.0 * b1 / cnt, sqrt(e4 / cnt), 100.0 * b4 / cnt, sqrt(ep / cnt), 100.0 * bp / cnt,
             100.0 * reg / cnt);
    }
    fprintf(stderr, "bench_aa: %s in %.1f s\n", c->name, secs);
    free(ref), free(one), free(four), free(paper), free(foot), free(region);
  }
  ch_gtex_free(&g);
  ch_curves_free(&set);
  return 0;
}
