/* ch_bezier_closest against its version of main 4634b09 (kept below,
 * verbatim but renamed) and a long double reference: ns per call of both,
 * how far their results are apart, and how far each is from the
 * reference, counting any query where one misses the global minimum on
 * [0, 1].
 *
 * usage: bench_bezier [--reps N] [--no-check] FILE...   queries recorded from real runs
 *        bench_bezier [--reps N] [--no-check] --synthetic N   random and adversarial ones
 * (--no-check: the timing only, e.g. for instruction counts per function
 * under valgrind --tool=callgrind).
 *
 * A FILE holds records of 9 doubles: p[0], p[1], p[2] (x, y each), q (x, y)
 * and is_line (0 or 1), native byte order, as written by a temporary
 * fwrite at the top of ch_bezier_closest (one call in 50, say) during e.g.
 * "chisel displace models/plane.obj models/curves/ornament.svg -o out.obj
 * --target-tris 520000" (not kept in the library: the function is called
 * from many threads, and pure). */
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"
#include "bezier_reference.h"
#include "ch_bezier.h"

typedef struct query {
  double p[3][2], q[2];
  int is_line;
} query;

/* ---- ch_bezier_closest of main 4634b09, verbatim but renamed. */

static double before_dot2(const double a[2], const double b[2]) { return a[0] * b[0] + a[1] * b[1]; }

static void before_eval(const double p[3][2], double t, double out[2]) {
  double s = 1.0 - t;
  double a = s * s, b = 2.0 * s * t, c = t * t;
  out[0] = a * p[0][0] + b * p[1][0] + c * p[2][0];
  out[1] = a * p[0][1] + b * p[1][1] + c * p[2][1];
}

static double before_dist2_at(const double p[3][2], double t, const double q[2]) {
  double x[2];
  before_eval(p, t, x);
  double dx = x[0] - q[0], dy = x[1] - q[1];
  return dx * dx + dy * dy;
}

static int before_quadratic_roots_01(double a, double b, double c, double r[2]) {
  int n = 0;
  double scale = fabs(a) + fabs(b) + fabs(c);
  if (scale == 0.0) return 0;
  if (fabs(a) <= 1e-300 * scale || fabs(a) < 1e-15 * scale) {
    if (b != 0.0) {
      double x = -c / b;
      if (x > 0.0 && x < 1.0) r[n++] = x;
    }
    return n;
  }
  double disc = b * b - 4.0 * a * c;
  if (disc < 0.0) return 0;
  double sq = sqrt(disc);
  double qq = -0.5 * (b + (b >= 0.0 ? sq : -sq));
  double x0 = qq / a;
  double x1 = qq != 0.0 ? c / qq : x0;
  if (x0 > x1) {
    double tmp = x0;
    x0 = x1;
    x1 = tmp;
  }
  if (x0 > 0.0 && x0 < 1.0) r[n++] = x0;
  if (x1 > 0.0 && x1 < 1.0 && (n == 0 || x1 != r[0])) r[n++] = x1;
  return n;
}

static double before_bracketed_root(const double k[4], double lo, double hi, double flo, double start) {
  double t = start > lo && start < hi ? start : 0.5 * (lo + hi);
  for (int it = 0; it < 100; it++) {
    double f = ((k[0] * t + k[1]) * t + k[2]) * t + k[3];
    if (f == 0.0) return t;
    if ((f < 0.0) == (flo < 0.0)) {
      lo = t;
      flo = f;
    } else {
      hi = t;
    }
    double df = (3.0 * k[0] * t + 2.0 * k[1]) * t + k[2];
    double next = df != 0.0 ? t - f / df : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (fabs(next - t) <= 1e-16 * (1.0 + fabs(t)) || hi - lo <= 1e-16) return next;
    t = next;
  }
  return t;
}

static double closest_before(const double p[3][2], int is_line, const double q[2], double *t_out) {
  if (is_line) {
    double d[2] = {p[2][0] - p[0][0], p[2][1] - p[0][1]};
    double w[2] = {q[0] - p[0][0], q[1] - p[0][1]};
    double len2 = before_dot2(d, d);
    double t = len2 > 0.0 ? before_dot2(w, d) / len2 : 0.0;
    t = t < 0.0 ? 0.0 : t > 1.0 ? 1.0 : t;
    double x = p[0][0] + t * d[0] - q[0], y = p[0][1] + t * d[1] - q[1];
    if (t_out) *t_out = t;
    return x * x + y * y;
  }
  double a[2] = {p[1][0] - p[0][0], p[1][1] - p[0][1]};
  double b[2] = {p[2][0] - 2.0 * p[1][0] + p[0][0], p[2][1] - 2.0 * p[1][1] + p[0][1]};
  double m[2] = {p[0][0] - q[0], p[0][1] - q[1]};
  double k[4] = {before_dot2(b, b), 3.0 * before_dot2(a, b), 2.0 * before_dot2(a, a) + before_dot2(m, b),
                 before_dot2(m, a)};
  double cuts[4];
  int ncuts = 0;
  cuts[ncuts++] = 0.0;
  double crit[2];
  int ncrit = before_quadratic_roots_01(3.0 * k[0], 2.0 * k[1], k[2], crit);
  for (int i = 0; i < ncrit; i++) cuts[ncuts++] = crit[i];
  cuts[ncuts++] = 1.0;
  double best_t = 0.0, best = INFINITY;
  double f0 = k[3], f1 = k[0] + k[1] + k[2] + k[3];
  if (f0 >= 0.0) best = before_dot2(m, m);
  if (f1 <= 0.0) {
    double e[2] = {p[2][0] - q[0], p[2][1] - q[1]}, d1 = before_dot2(e, e);
    if (d1 < best) {
      best = d1;
      best_t = 1.0;
    }
  }
  double chord[2] = {p[2][0] - p[0][0], p[2][1] - p[0][1]}, chord2 = before_dot2(chord, chord);
  double start = chord2 > 0.0 ? -before_dot2(m, chord) / chord2 : 0.5;
  for (int i = 0; i + 1 < ncuts; i++) {
    double lo = cuts[i], hi = cuts[i + 1];
    double flo = i == 0 ? f0 : ((k[0] * lo + k[1]) * lo + k[2]) * lo + k[3];
    double fhi = i + 2 == ncuts ? f1 : ((k[0] * hi + k[1]) * hi + k[2]) * hi + k[3];
    double t;
    if (flo <= 0.0 && fhi >= 0.0 && !(flo == 0.0 && fhi == 0.0))
      t = flo == 0.0 ? lo : fhi == 0.0 ? hi : before_bracketed_root(k, lo, hi, flo, start);
    else
      continue;
    double d = before_dist2_at(p, t, q);
    if (d < best) {
      best = d;
      best_t = t;
    }
  }
  if (t_out) *t_out = best_t;
  return best;
}

/* ---- The reference, in long double and sharing nothing with either:
 * f(t) = (B(t) - q).B'(t) / 2 from the control points; [0, 1] cut at the
 * roots of f' (where f turns) and at 64 even steps, so that f is monotone
 * between consecutive cuts; every cut pair where f goes from <= 0 to >= 0
 * is bisected to the end of long double, and the ends are candidates
 * where they are local minima. g1 is the smallest |B - q|^2, g2 the next
 * local minimum's (to tell a unique minimum), cond f' there over
 * |B'/2|^2. */

typedef struct reference {
  double t, g1, g2, cond;
} reference;

static reference ref_closest(const double p[3][2], int is_line, const double q[2]) {
  ref_closest_t r = ref_closest_ld(p, is_line, q);
  return (reference){(double)r.t, (double)r.g1, (double)r.g2, (double)r.cond};
}

/* The point at t, for telling minima apart. */
static void ref_eval(const double p[3][2], int is_line, double t, double out[2]) {
  for (int k = 0; k < 2; k++)
    out[k] = is_line ? p[0][k] + t * (p[2][k] - p[0][k])
                     : (1 - t) * (1 - t) * p[0][k] + 2 * t * (1 - t) * p[1][k] + t * t * p[2][k];
}

/* ---- Queries. */

static query *read_queries(const char *path, query *qs, size_t *n, size_t *cap) {
  FILE *f = fopen(path, "rb");
  if (!f) {
    perror(path);
    exit(1);
  }
  double r[9];
  while (fread(r, sizeof r, 1, f) == 1) {
    if (*n == *cap) {
      *cap = *cap ? 2 * *cap : 1 << 16;
      qs = realloc(qs, *cap * sizeof *qs);
    }
    query *x = &qs[(*n)++];
    memcpy(x->p, r, sizeof x->p);
    x->q[0] = r[6], x->q[1] = r[7];
    x->is_line = r[8] != 0.0;
  }
  fclose(f);
  return qs;
}

static uint64_t rng_state = 0x9e3779b97f4a7c15ull;
static double rnd(void) { /* xorshift64* */
  rng_state ^= rng_state >> 12;
  rng_state ^= rng_state << 25;
  rng_state ^= rng_state >> 27;
  return (double)((rng_state * 0x2545f4914f6cdd1dull) >> 11) * (1.0 / 9007199254740992.0);
}

/* Random quadratics of the kinds that are hard for a closest-point search
 * (nearly straight, p1 far away, p0 == p2, tiny) with queries near them,
 * on them, at the centre of curvature and far away. */
static void synth(query *x, size_t i) {
  for (int j = 0; j < 3; j++) x->p[j][0] = rnd(), x->p[j][1] = rnd();
  x->is_line = 0;
  switch (i % 6) {
    case 1:
      for (int k = 0; k < 2; k++) x->p[1][k] = 0.5 * (x->p[0][k] + x->p[2][k]) + 1e-9 * (rnd() - 0.5);
      break;
    case 2:
      for (int k = 0; k < 2; k++) x->p[1][k] = x->p[0][k] + 1e3 * (rnd() - 0.5);
      break;
    case 3:
      memcpy(x->p[2], x->p[0], sizeof x->p[2]);
      break;
    case 4:
      for (int j = 1; j < 3; j++)
        for (int k = 0; k < 2; k++) x->p[j][k] = x->p[0][k] + 1e-6 * rnd();
      break;
    default:
      break;
  }
  double t = rnd(), s = 1.0 - t, pt[2], d[2];
  for (int k = 0; k < 2; k++) {
    pt[k] = s * s * x->p[0][k] + 2 * s * t * x->p[1][k] + t * t * x->p[2][k];
    d[k] = s * (x->p[1][k] - x->p[0][k]) + t * (x->p[2][k] - x->p[1][k]);
  }
  double b[2] = {x->p[2][0] - 2 * x->p[1][0] + x->p[0][0], x->p[2][1] - 2 * x->p[1][1] + x->p[0][1]};
  double dd = d[0] * d[0] + d[1] * d[1], cr = d[0] * b[1] - d[1] * b[0];
  switch ((i / 6) % 4) {
    case 0: /* near the curve */
      x->q[0] = pt[0] + 0.01 * (rnd() - 0.5), x->q[1] = pt[1] + 0.01 * (rnd() - 0.5);
      break;
    case 1:
      x->q[0] = pt[0], x->q[1] = pt[1];
      break;
    case 2: /* centre of curvature: pt + n |B'|^2 / (B' x B'') (B'' = 2b, B' = 2d) */
      if (cr != 0.0) {
        double r = dd / cr;
        x->q[0] = pt[0] - d[1] * r, x->q[1] = pt[1] + d[0] * r;
      } else {
        x->q[0] = pt[0], x->q[1] = pt[1];
      }
      break;
    default:
      x->q[0] = 100.0 * (rnd() - 0.5), x->q[1] = 100.0 * (rnd() - 0.5);
      break;
  }
}

/* ---- Timing. */

typedef double (*closest_fn)(const double p[3][2], int is_line, const double q[2], double *t);

static double time_fn(closest_fn fn, const query *qs, size_t n, double *sink) {
  double t0 = bench_now(), acc = 0.0;
  for (size_t i = 0; i < n; i++) {
    double t, d = fn(qs[i].p, qs[i].is_line, qs[i].q, &t);
    acc += d + t;
  }
  *sink += acc;
  return (bench_now() - t0) / (double)n * 1e9;
}

int main(int argc, char **argv) {
  int reps = 5, no_check = 0;
  size_t n = 0, cap = 0;
  query *qs = NULL;
  for (int a = 1; a < argc; a++) {
    if (!strcmp(argv[a], "--reps") && a + 1 < argc) {
      reps = atoi(argv[++a]);
    } else if (!strcmp(argv[a], "--no-check")) {
      no_check = 1;
    } else if (!strcmp(argv[a], "--synthetic") && a + 1 < argc) {
      size_t m = (size_t)atol(argv[++a]);
      qs = realloc(qs, (n + m) * sizeof *qs);
      for (size_t i = 0; i < m; i++) synth(&qs[n + i], i);
      n += m;
      cap = n;
    } else {
      qs = read_queries(argv[a], qs, &n, &cap);
    }
  }
  if (!n) {
    fprintf(stderr, "usage: bench_bezier [--reps N] [--no-check] FILE... | --synthetic N\n");
    return 2;
  }
  size_t lines = 0;
  for (size_t i = 0; i < n; i++) lines += (size_t)qs[i].is_line;
  printf("%zu queries (%zu straight)\n", n, lines);

  /* Alternating; the median and the fastest of each (the machine may be
   * shared: the fastest is the least disturbed). */
  static volatile closest_fn fns[2] = {closest_before, ch_bezier_closest};
  double ns[2][64], sink = 0.0, fastest[2] = {INFINITY, INFINITY};
  if (reps > 64) reps = 64;
  if (reps < 1) reps = 1;
  for (int r = 0; r < reps; r++)
    for (int f = 0; f < 2; f++) {
      ns[f][r] = time_fn(fns[f], qs, n, &sink);
      fastest[f] = fmin(fastest[f], ns[f][r]);
    }
  double med_before = bench_median(ns[0], reps), med_now = bench_median(ns[1], reps);
  printf("ns per call: before %.2f, now %.2f (x%.2f) median of %d; fastest %.2f, %.2f (x%.2f)%s\n", med_before, med_now,
         med_before / med_now, reps, fastest[0], fastest[1], fastest[0] / fastest[1], sink == 42.0 ? " " : "");

  if (no_check) {
    free(qs);
    return 0;
  }

  /* Against each other and against the reference. Distances are
   * compared in units of the coordinates' rounding, u = DBL_EPSILON times
   * the largest coordinate. A miss: a distance above the reference's by
   * more than 1e-12 of the segment's size (or of the distance, if larger)
   * plus 64 u, at another point than the reference's (at the same point it
   * is a flat minimum's imprecision: a folded segment's turning point).
   * t is compared where the minimum is unique (the next local minimum's
   * distance squared 1e-9 of the size squared away) and f' at the root is
   * above 1e-6 of |B'/2|^2 (at the centre of curvature t is only known to
   * about the cube root of the rounding), and separately where f' is above
   * 1e-2 of it. */
  double max_du = 0.0, max_dt[3] = {0, 0, 0}, err_ref[2] = {0, 0}, terr_ref[2][2] = {{0, 0}, {0, 0}};
  double other_du = 0.0, perr_ref[2] = {0, 0};
  size_t other = 0, misses[2] = {0, 0}, flat[2] = {0, 0}, differ = 0, ulps4 = 0, worst_dt = 0;
  for (size_t i = 0; i < n; i++) {
    const query *x = &qs[i];
    double t[2], d2[2];
    d2[0] = closest_before(x->p, x->is_line, x->q, &t[0]);
    d2[1] = ch_bezier_closest(x->p, x->is_line, x->q, &t[1]);
    reference ref = ref_closest(x->p, x->is_line, x->q);
    double size = 0.0, big = fmax(fabs(x->q[0]), fabs(x->q[1]));
    for (int j = 0; j < 3; j++) {
      size = fmax(size, hypot(x->p[j][0] - x->p[0][0], x->p[j][1] - x->p[0][1]));
      big = fmax(big, fmax(fabs(x->p[j][0]), fabs(x->p[j][1])));
    }
    double seg = fmax(size, DBL_MIN);
    size = fmax(fmax(size, sqrt(ref.g1)), DBL_MIN);
    double u = fmax(DBL_EPSILON * big, DBL_MIN);
    int unique = ref.g2 - ref.g1 > 1e-9 * size * size && ref.cond > 1e-6, steady = unique && ref.cond > 1e-2;
    if (d2[0] != d2[1] || t[0] != t[1]) differ++;
    if (fabs(d2[1] - d2[0]) > 4.0 * DBL_EPSILON * d2[0]) ulps4++;
    double du = fabs(sqrt(d2[1]) - sqrt(d2[0])) / u;
    max_du = fmax(max_du, du);
    max_dt[0] = fmax(max_dt[0], fabs(t[1] - t[0]));
    if (unique && fabs(t[1] - t[0]) > max_dt[1]) max_dt[1] = fabs(t[1] - t[0]), worst_dt = i;
    if (steady) max_dt[2] = fmax(max_dt[2], fabs(t[1] - t[0]));
    double x0[2], x1[2];
    ref_eval(x->p, x->is_line, t[0], x0);
    ref_eval(x->p, x->is_line, t[1], x1);
    if (hypot(x1[0] - x0[0], x1[1] - x0[1]) > 1e-6 * size) { /* another point: of a tie, one hopes */
      other++;
      other_du = fmax(other_du, du);
    }
    for (int f = 0; f < 2; f++) {
      double e = sqrt(d2[f]) - sqrt(ref.g1);
      err_ref[f] = fmax(err_ref[f], fabs(e) / u);
      if (unique) terr_ref[f][0] = fmax(terr_ref[f][0], fabs(t[f] - ref.t));
      if (steady) terr_ref[f][1] = fmax(terr_ref[f][1], fabs(t[f] - ref.t));
      if (unique) {
        /* where t puts the point, against the reference's, in u; the
         * rounding moves it by about u / (f' / |B'/2|^2), and by the
         * distance over the size where it turns the segment */
        double xf[2], xr[2];
        ref_eval(x->p, x->is_line, t[f], xf);
        ref_eval(x->p, x->is_line, ref.t, xr);
        perr_ref[f] = fmax(
            perr_ref[f], hypot(xf[0] - xr[0], xf[1] - xr[1]) * fmin(ref.cond, 1.0) / (u * (1.0 + sqrt(ref.g1) / seg)));
      }
      if (e > 1e-12 * size + 64.0 * u) {
        double xf[2], xr[2];
        ref_eval(x->p, x->is_line, t[f], xf);
        ref_eval(x->p, x->is_line, ref.t, xr);
        if (hypot(xf[0] - xr[0], xf[1] - xr[1]) < 1e-4 * size) {
          flat[f]++;
          continue;
        }
        misses[f]++;
        if (misses[f] <= 5)
          printf(
              "  miss (%s) #%zu: p (%.17g %.17g) (%.17g %.17g) (%.17g %.17g) q (%.17g %.17g) %s: d2 %.17g t %.17g,"
              " reference d2 %.17g t %.17g\n",
              f ? "now" : "before", i, x->p[0][0], x->p[0][1], x->p[1][0], x->p[1][1], x->p[2][0], x->p[2][1], x->q[0],
              x->q[1], x->is_line ? "line" : "quad", d2[f], t[f], ref.g1, ref.t);
      }
    }
  }
  printf(
      "now against before: %zu of %zu differ; d2 beyond 4 ulps of it in %zu; max |distance difference| %.3g u;"
      " max |t difference| %.3g (f' at the root > 1e-2), %.3g (> 1e-6), %.3g (all)\n",
      differ, n, ulps4, max_du, max_dt[2], max_dt[1], max_dt[0]);
  printf("  another point (1e-6 of the size away) in %zu, the distances %.3g u apart at most\n", other, other_du);
  if (max_dt[1] > 0.0) {
    const query *x = &qs[worst_dt];
    printf("  largest t difference (f' > 1e-6) at #%zu: p (%.17g %.17g) (%.17g %.17g) (%.17g %.17g) q (%.17g %.17g)\n",
           worst_dt, x->p[0][0], x->p[0][1], x->p[1][0], x->p[1][1], x->p[2][0], x->p[2][1], x->q[0], x->q[1]);
  }
  for (int f = 0; f < 2; f++)
    printf(
        "%-6s against the reference: %zu misses (%zu more beyond the tolerance at the right minimum), max |distance"
        " error| %.3g u, max |t error| %.3g (f' > 1e-2), %.3g (f' > 1e-6), point at t %.3g u off (times f'"
        " if < 1, over 1 + distance / size)\n",
        f ? "now" : "before", misses[f], flat[f], err_ref[f], terr_ref[f][1], terr_ref[f][0], perr_ref[f]);
  free(qs);
  return misses[0] || misses[1];
}
