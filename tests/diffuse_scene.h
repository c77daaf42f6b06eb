/* Fixed-texel masks for the diffusion solver's tests and benchmark: curves
 * (closed or open polylines) drawn the way the curve rasterisation does it:
 * every texel whose centre lies within `radius` texels of a curve is fixed to
 * the value of its side (left or right) of the closest curve. Header-only,
 * deterministic (own random generator). */
#ifndef DIFFUSE_SCENE_H
#define DIFFUSE_SCENE_H

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define SCENE_PI 3.14159265358979323846

typedef struct scene_rng {
  uint64_t s;
} scene_rng;

static inline double scene_uniform(scene_rng *r) {
  r->s = r->s * 6364136223846793005ull + 1442695040888963407ull;
  return (double)(r->s >> 11) * (1.0 / 9007199254740992.0);
}

/* A scene under construction: per texel the distance to the closest curve
 * drawn so far, and the value (channels) of its side. */
typedef struct scene {
  int w, h, C;
  float *dist;
  unsigned char *fixed;
  float *values;
} scene;

static inline int scene_init(scene *s, int w, int h, int C) {
  s->w = w;
  s->h = h;
  s->C = C;
  size_t n = (size_t)w * h;
  s->dist = malloc((n ? n : 1) * sizeof *s->dist);
  s->fixed = calloc(n ? n : 1, 1);
  s->values = calloc((n ? n : 1) * C, sizeof *s->values);
  if (!s->dist || !s->fixed || !s->values) return 0;
  for (size_t i = 0; i < n; i++) s->dist[i] = INFINITY;
  return 1;
}

static inline void scene_free(scene *s) {
  free(s->dist);
  free(s->fixed);
  free(s->values);
  memset(s, 0, sizeof *s);
}

/* Draws a polyline (n points, xy interleaved, in texel units where texel
 * (i, j) has its centre at (i + 0.5, j + 0.5)). left / right: C values each. */
static inline void scene_polyline(scene *s, const double *pts, int n, int closed, double radius,
                                  const float *left, const float *right) {
  int nseg = closed ? n : n - 1;
  for (int k = 0; k < nseg; k++) {
    const double *p = pts + 2 * k, *q = pts + 2 * ((k + 1) % n);
    double dx = q[0] - p[0], dy = q[1] - p[1], len2 = dx * dx + dy * dy;
    int x0 = (int)floor(fmin(p[0], q[0]) - radius - 1), x1 = (int)ceil(fmax(p[0], q[0]) + radius + 1);
    int y0 = (int)floor(fmin(p[1], q[1]) - radius - 1), y1 = (int)ceil(fmax(p[1], q[1]) + radius + 1);
    if (x0 < 0) x0 = 0;
    if (y0 < 0) y0 = 0;
    if (x1 > s->w - 1) x1 = s->w - 1;
    if (y1 > s->h - 1) y1 = s->h - 1;
    for (int y = y0; y <= y1; y++)
      for (int x = x0; x <= x1; x++) {
        double cx = x + 0.5 - p[0], cy = y + 0.5 - p[1];
        double t = len2 > 0 ? (cx * dx + cy * dy) / len2 : 0.0;
        if (t < 0) t = 0;
        if (t > 1) t = 1;
        double ex = cx - t * dx, ey = cy - t * dy, d = sqrt(ex * ex + ey * ey);
        size_t i = (size_t)y * s->w + x;
        if (d >= radius || !(d < s->dist[i])) continue;
        s->dist[i] = (float)d;
        s->fixed[i] = 1;
        double side = dx * cy - dy * cx; /* > 0: left of the segment direction */
        const float *v = side >= 0 ? left : right;
        for (int c = 0; c < s->C; c++) s->values[i * s->C + c] = v[c];
      }
  }
}

/* A closed curve around (cx, cy): radius r modulated by a few random
 * harmonics (amplitude wob * r), counter-clockwise, so left = inside. */
static inline void scene_blob(scene *s, scene_rng *rng, double cx, double cy, double r, double wob,
                              double radius, const float *inside, const float *outside) {
  int n = (int)(2 * SCENE_PI * r / 2.0) + 16;
  double *pts = malloc((size_t)n * 2 * sizeof *pts);
  double a[4], ph[4];
  for (int k = 0; k < 4; k++) {
    a[k] = wob * (scene_uniform(rng) - 0.5);
    ph[k] = 2 * SCENE_PI * scene_uniform(rng);
  }
  for (int i = 0; i < n; i++) {
    double t = 2 * SCENE_PI * i / n, rr = r;
    for (int k = 0; k < 4; k++) rr += r * a[k] * sin((k + 2) * t + ph[k]);
    pts[2 * i] = cx + rr * cos(t);
    pts[2 * i + 1] = cy + rr * sin(t);
  }
  scene_polyline(s, pts, n, 1, radius, inside, outside);
  free(pts);
}

/* An open wavy curve from the left border to the right one at height y0. */
static inline void scene_wave(scene *s, scene_rng *rng, double y0, double amp, double radius,
                              const float *left, const float *right) {
  int n = s->w / 2 + 8;
  double *pts = malloc((size_t)n * 2 * sizeof *pts);
  double f1 = 1 + 3 * scene_uniform(rng), p1 = 2 * SCENE_PI * scene_uniform(rng);
  for (int i = 0; i < n; i++) {
    double x = -2.0 + (s->w + 4.0) * i / (n - 1);
    pts[2 * i] = x;
    pts[2 * i + 1] = y0 + amp * sin(2 * SCENE_PI * f1 * x / s->w + p1);
  }
  scene_polyline(s, pts, n, 0, radius, left, right);
  free(pts);
}

static inline void scene_random_value(scene_rng *rng, int C, float *v) {
  for (int c = 0; c < C; c++) v[c] = (float)scene_uniform(rng);
}

/* The benchmark's relief: 12 closed curves and 4 open curves across the
 * square, as 2-texel bands (radius 1), random side values. */
static inline void scene_relief(scene *s, uint64_t seed) {
  scene_rng rng = {seed * 2654435761u + 1};
  int N = s->w < s->h ? s->w : s->h;
  float a[8], b[8];
  for (int k = 0; k < 4; k++) {
    scene_random_value(&rng, s->C, a);
    scene_random_value(&rng, s->C, b);
    scene_wave(s, &rng, s->h * (0.15 + 0.7 * scene_uniform(&rng)), 0.08 * s->h, 1.0, a, b);
  }
  for (int k = 0; k < 12; k++) {
    scene_random_value(&rng, s->C, a);
    scene_random_value(&rng, s->C, b);
    double r = N * (0.04 + 0.12 * scene_uniform(&rng));
    scene_blob(s, &rng, s->w * scene_uniform(&rng), s->h * scene_uniform(&rng), r, 0.4, 1.0, a, b);
  }
}

#endif
