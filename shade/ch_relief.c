/* Relief mapping and parallax occlusion mapping on a baked height texture
 * (ch_relief.h). Policarpo, Oliveira and Comba 2005 (§3: linear search,
 * then binary search, on a depth map over the polygon); Tatarchuk 2006
 * (§3: sample count by view angle, linear intersection of the last
 * segment). Their tangent space is ours on the plane: x = u, y = v, z up;
 * the depth map's [0, 1] is [hmax, hmin] here. */
#include "ch_relief.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void ch_relief_free(ch_relief *r) {
  free(r->h);
  memset(r, 0, sizeof *r);
}

size_t ch_relief_bytes(const ch_relief *r) { return 4 * (size_t)r->resolution * r->resolution; }

/* Checks desc and sets r up around a map of R x R (allocated, not filled). */
static ch_status setup(ch_relief *r, const ch_relief_desc *desc, ch_error *err) {
  memset(r, 0, sizeof *r);
  int R = desc->resolution, K = desc->steps ? desc->steps : 32, S = desc->supersample ? desc->supersample : 4;
  if (R < CH_RELIEF_MIN_RES || R > CH_RELIEF_MAX_RES)
    return ch_error_set(err, CH_ERR_INPUT, "height texture: resolution %d out of range %d..%d", R, CH_RELIEF_MIN_RES,
                        CH_RELIEF_MAX_RES);
  if (K < CH_RELIEF_MIN_STEPS || K > CH_RELIEF_MAX_STEPS)
    return ch_error_set(err, CH_ERR_INPUT, "relief mapping: %d steps out of range %d..%d", K, CH_RELIEF_MIN_STEPS,
                        CH_RELIEF_MAX_STEPS);
  if (S < 1 || S > 16) return ch_error_set(err, CH_ERR_INPUT, "height texture: supersample %d out of range 1..16", S);
  if (desc->method != CH_RELIEF_RELIEF && desc->method != CH_RELIEF_POM)
    return ch_error_set(err, CH_ERR_INPUT, "relief mapping: unknown method %d", (int)desc->method);
  r->h = malloc((size_t)R * R * sizeof *r->h);
  if (!r->h) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for a %d x %d height texture", R, R);
  r->resolution = R;
  r->steps = K;
  r->min_steps = K / 4 > 4 ? K / 4 : (K < 4 ? K : 4);
  r->method = desc->method;
  return CH_OK;
}

ch_status ch_relief_copy(ch_relief *r, const ch_relief *from, const ch_relief_desc *desc, ch_error *err) {
  if (desc->resolution != from->resolution)
    return ch_error_set(err, CH_ERR_INTERNAL, "relief mapping: a %d x %d map is not %d x %d", from->resolution,
                        from->resolution, desc->resolution, desc->resolution);
  ch_status st = setup(r, desc, err);
  if (st) return st;
  memcpy(r->h, from->h, (size_t)r->resolution * r->resolution * sizeof *r->h);
  r->hmin = from->hmin;
  r->hmax = from->hmax;
  return CH_OK;
}

ch_status ch_relief_build(ch_relief *r, const ch_height *height, const ch_relief_desc *desc, ch_error *err) {
  ch_status st = setup(r, desc, err);
  if (st) return st;
  int R = r->resolution, S = desc->supersample ? desc->supersample : 4;
  ch_height_render(height, R, S, r->h);
  double lo = INFINITY, hi = -INFINITY;
  for (size_t i = 0; i < (size_t)R * R; i++) {
    lo = fmin(lo, r->h[i]);
    hi = fmax(hi, r->h[i]);
  }
  r->hmin = lo;
  r->hmax = hi;
  return CH_OK;
}

/* Bilinear, clamp to edge; texel (x, y) centred at ((x + 1/2) / R,
 * 1 - (y + 1/2) / R). */
double ch_relief_height(const ch_relief *r, double u, double v) {
  int R = r->resolution;
  double gx = u * R - 0.5, gy = (1.0 - v) * R - 0.5;
  gx = gx < 0.0 ? 0.0 : gx > R - 1 ? R - 1 : gx;
  gy = gy < 0.0 ? 0.0 : gy > R - 1 ? R - 1 : gy;
  int x0 = (int)gx, y0 = (int)gy;
  if (x0 > R - 2) x0 = R - 2;
  if (y0 > R - 2) y0 = R - 2;
  double fx = gx - x0, fy = gy - y0;
  const float *row0 = r->h + (size_t)y0 * R, *row1 = row0 + R;
  double a = row0[x0] + fx * (row0[x0 + 1] - row0[x0]), b = row1[x0] + fx * (row1[x0 + 1] - row1[x0]);
  return a + fy * (b - a);
}

static void map_normal(const ch_relief *r, double u, double v, double n[3]) {
  double e = 1.0 / r->resolution;
  double hu = (ch_relief_height(r, u + e, v) - ch_relief_height(r, u - e, v)) / (2.0 * e);
  double hv = (ch_relief_height(r, u, v + e) - ch_relief_height(r, u, v - e)) / (2.0 * e);
  double l = sqrt(hu * hu + hv * hv + 1.0);
  n[0] = -hu / l;
  n[1] = -hv / l;
  n[2] = 1.0 / l;
}

/* Below the map at t: z <= H(u, v). */
static int below(const ch_relief *r, const double o[3], const double d[3], double t, double *gap) {
  double z = o[2] + t * d[2], H = ch_relief_height(r, o[0] + t * d[0], o[1] + t * d[1]);
  *gap = z - H;
  return z <= H;
}

/* The search of the method along o + t d from tin to tout (both within
 * the volume, d pointing down): the first crossing of the map. */
static double search(const ch_relief *r, const double o[3], const double d[3], double tin, double tout) {
  int n = r->steps;
  if (r->method == CH_RELIEF_POM) {
    double c = -d[2] / sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    n = (int)lround(r->steps + (r->min_steps - r->steps) * c);
    if (n < 1) n = 1;
  }
  double dt = (tout - tin) / n, prev = tin, gprev;
  if (below(r, o, d, tin, &gprev)) return tin;
  for (int i = 1; i <= n; i++) {
    double ti = i == n ? tout : tin + dt * i, g;
    if (!below(r, o, d, ti, &g)) {
      prev = ti;
      gprev = g;
      continue;
    }
    if (r->method == CH_RELIEF_POM) {
      /* The ray against the segment between the last two heights. */
      double a = gprev, b = -g;
      return prev + (ti - prev) * (a + b > 0.0 ? a / (a + b) : 1.0);
    }
    double lo = prev, hi = ti;
    for (int k = 0; k < CH_RELIEF_BINARY_STEPS; k++) {
      double m = 0.5 * (lo + hi), gm;
      if (below(r, o, d, m, &gm)) hi = m;
      else lo = m;
    }
    return hi;
  }
  return tout;
}

int ch_relief_intersect(const ch_relief *r, const double o[3], const double d[3], ch_relief_hit *hit) {
  if (!(d[2] < 0.0)) return 0;
  /* The volume between hmax (the polygon) and hmin along the ray. */
  double tin = fmax(0.0, (r->hmax - o[2]) / d[2]), tout = (r->hmin - o[2]) / d[2];
  if (!(tout >= tin)) tout = tin;
  double t = search(r, o, d, tin, tout);
  hit->t = t;
  for (int k = 0; k < 3; k++) hit->point[k] = o[k] + t * d[k];
  map_normal(r, hit->point[0], hit->point[1], hit->normal);
  return 1;
}

/* Policarpo's shadow test: the same search from where the light's ray
 * enters the volume towards the point; the point is lit if that search
 * reaches it (within the search's depth resolution, its bias against
 * self-shadowing). */
int ch_relief_occluded(const ch_relief *r, const double o[3], const double d[3]) {
  if (!(d[2] > 0.0)) return 0;
  double s = (r->hmax - o[2]) / d[2];
  if (!(s > 0.0)) return 0;
  double e[3] = {o[0] + s * d[0], o[1] + s * d[1], r->hmax}, back[3] = {-d[0], -d[1], -d[2]};
  double t = search(r, e, back, 0.0, s);
  double step = (r->hmax - r->hmin) / r->steps;
  double bias = r->method == CH_RELIEF_POM ? step : step / (1 << (CH_RELIEF_BINARY_STEPS - 2));
  return e[2] + t * back[2] > o[2] + bias;
}
