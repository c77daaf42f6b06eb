/* Feature-curve textures against their baselines (the figures the papers compare: normal-maps-discontinuities §5):
 * - wrong-side pixels and normal error (mean, p95, degrees, against the
 *   exact normal of docs/spec.md §3: ch_truth_normal) in crops along the curves at
 *   4x, 16x and 64x (crops of 4 x 4 texels around points spread evenly
 *   along the curves, as bench_dci does for the DCI; at 64x, the texel
 *   around the point), for featnorm with and without the fallback,
 *   featnorm-linear, msdf at the same R and at equal bytes, and bilinear
 *   (the signed distance's sign; the conventional normal map), R = 64 to
 *   1024, on every bundled set and every torture class (pixels exactly
 *   on a curve, where there is no side and on a crease no normal, are
 *   left out of both); where there are step curves, also the truth
 *   against the truth from a DCI twice as fine over the same pixels (the
 *   reference's own error: h_step comes from a DCI);
 * - bytes per texel; build time at 1024^2 and 4096^2; evaluation speed in
 *   Msamples/s on all threads.
 * usage: bench_featmap [MODELS_DIR] [--res 64,128,...] [--crops N] [--sets a,b]
 *                      [--no-accuracy] [--no-time] [--no-speed] [--max-build R]
 *                      [--dci-res N]  (the DCI behind h_step and the truth: 1024)
 *                      [--no-dci-singular]  (that DCI without its singular terms)
 *                      [--no-dci-extrapolate]  (that DCI's fixed texels at their side's value) */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

#include "bench_util.h"
#include "ch_bezier.h"
#include "ch_curves.h"
#include "ch_featmap.h"
#include "ch_grid.h"
#include "ch_groove.h"
#include "ch_height.h"
#include "ch_math.h"
#include "ch_msdf.h"
#include "ch_truth.h"

enum { M_FN, M_FN_OFF, M_LIN, M_MSDF, M_MSDF_EQ, M_BIL, NM };
static const char *mname[NM] = {"featnorm", "fn-nofb", "linear", "msdf", "msdf=B", "bilinear"};
static const int mags[3] = {4, 16, 64};

/* CPU seconds of this process so far (all threads): a build's CPU time
 * does not grow when other work shares the cores, its wall time does. */
static double cpu_seconds(void) {
  struct rusage ru;
  getrusage(RUSAGE_SELF, &ru);
  return ru.ru_utime.tv_sec + ru.ru_stime.tv_sec + 1e-6 * (ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
}

typedef struct setup {
  const ch_curve_set *set;
  ch_height height;
  ch_truth *truth;
  /* where there are steps: the truth again from a DCI twice as fine, so
   * that the reference's own error beside featnorm's is seen */
  ch_height height2;
  ch_truth *truth2;
  double *cum; /* cumulative arc length per encoded segment */
  int *segs;
  int nsegs;
} setup;

static unsigned long long rng_next(unsigned long long *s) {
  *s ^= *s << 13, *s ^= *s >> 7, *s ^= *s << 17;
  return *s;
}

/* A point spread evenly along the encoded curves. */
static void curve_point(const setup *su, unsigned long long *rng, double c[2]) {
  double x = (rng_next(rng) % 1000000007ull) / 1000000007.0 * su->cum[su->nsegs - 1];
  int lo = 0, hi = su->nsegs - 1;
  while (lo < hi) {
    int mid = (lo + hi) / 2;
    if (su->cum[mid] < x) lo = mid + 1;
    else hi = mid;
  }
  double t = (rng_next(rng) % 1000003ull) / 1000003.0;
  ch_segment_point(&su->set->segments[su->segs[lo]], t, c);
}

/* The exact nearest encoded curve: side and distance, through a grid. */
typedef struct exact_idx {
  ch_grid grid;
  double (*boxes)[4];
} exact_idx;

static int exact_side(const ch_curve_set *set, const exact_idx *ix, const double q[2], double *dist, int *curve) {
  const int *items;
  int n = ch_grid_query(&ix->grid, q[0], q[1], &items);
  double best = INFINITY, bt = 0.0;
  int bs = -1;
  for (int k = 0; k < n; k++) {
    const double *b = ix->boxes[items[k]];
    if (q[0] < b[0] || q[0] > b[2] || q[1] < b[1] || q[1] > b[3]) continue;
    const ch_segment *s = &set->segments[items[k]];
    double t, d2 = ch_bezier_closest(s->p, s->is_line, q, &t);
    if (d2 < best) best = d2, bt = t, bs = items[k];
  }
  if (bs < 0)
    for (int i = 0; i < set->num_segments; i++) {
      if (!ch_featmap_encodes(set, set->segments[i].curve)) continue;
      double t, d2 = ch_bezier_closest(set->segments[i].p, set->segments[i].is_line, q, &t);
      if (d2 < best) best = d2, bt = t, bs = i;
    }
  *dist = sqrt(best);
  *curve = set->segments[bs].curve;
  return ch_curve_side(set, bs, bt, q);
}

static int cmp_float(const void *a, const void *b) {
  float x = *(const float *)a, y = *(const float *)b;
  return (x > y) - (x < y);
}

typedef struct result {
  double wrong[3][NM]; /* % per magnification */
  double nmean[3][NM], np95[3][NM];
  double ngroove[3][NM]; /* normal mean over the pixels whose nearest curve is a groove */
  double nref[3];        /* the truth against the truth at twice the DCI's resolution (0: no steps) */
} result;

typedef struct methods {
  ch_featmap fn, fn_off, lin;
  ch_msdf msdf, msdf_eq;
} methods;

static void eval_method(const methods *mm, int m, double u, double v, ch_featmap_sample *s) {
  switch (m) {
  case M_FN: ch_featmap_eval(&mm->fn, CH_FEATMAP_FEATNORM, u, v, s); break;
  case M_FN_OFF: ch_featmap_eval(&mm->fn_off, CH_FEATMAP_FEATNORM, u, v, s); break;
  case M_LIN: ch_featmap_eval(&mm->lin, CH_FEATMAP_LINEAR, u, v, s); break;
  case M_MSDF: ch_msdf_eval(&mm->msdf, u, v, s); break;
  case M_MSDF_EQ: ch_msdf_eval(&mm->msdf_eq, u, v, s); break;
  default: ch_featmap_eval(&mm->fn, CH_FEATMAP_BILINEAR, u, v, s); break;
  }
}

static int measure(setup *su, int R, int crops, result *res, int *req, ch_error *err) {
  methods mm;
  memset(&mm, 0, sizeof mm);
  const ch_height *h = su->height.has_steps ? &su->height : NULL;
  ch_featmap_desc d = {.resolution = R, .height = h};
  ch_featmap_desc doff = {.resolution = R, .height = h, .no_fallback = 1, .no_normal_map = 1};
  ch_featmap_desc dlin = {.resolution = R, .height = h, .linear = 1, .no_normal_map = 1};
  if (ch_featmap_build(su->set, &d, &mm.fn, err) || ch_featmap_build(su->set, &doff, &mm.fn_off, err) ||
      ch_featmap_build(su->set, &dlin, &mm.lin, err))
    return -1;
  double bytes = ch_featmap_bytes_per_texel(&mm.fn, CH_FEATMAP_FEATNORM);
  int Req = (int)lround(R * sqrt(bytes / ch_msdf_bytes_per_texel()));
  if (Req > CH_FEATMAP_MAX_RES) Req = CH_FEATMAP_MAX_RES;
  *req = Req;
  ch_msdf_desc md = {.resolution = R}, mde = {.resolution = Req};
  if (ch_msdf_build(su->set, &md, &mm.msdf, err) || ch_msdf_build(su->set, &mde, &mm.msdf_eq, err)) return -1;
  double texel = 1.0 / R;
  exact_idx ix = {0};
  ix.boxes = malloc((size_t)su->set->num_segments * sizeof *ix.boxes);
  for (int i = 0; i < su->set->num_segments; i++) {
    if (!ch_featmap_encodes(su->set, su->set->segments[i].curve)) ix.boxes[i][0] = 1, ix.boxes[i][2] = 0;
    else ch_segment_box(&su->set->segments[i], 3.5 * texel, ix.boxes[i]);
    if (!ch_featmap_encodes(su->set, su->set->segments[i].curve)) ix.boxes[i][1] = 1, ix.boxes[i][3] = 0;
  }
  ch_grid_build(&ix.grid, su->set->num_segments, (const double(*)[4])ix.boxes, err);
  for (int g = 0; g < 3; g++) {
    int mag = mags[g], npx = g == 2 ? 64 : 4 * mag; /* pixels across a crop */
    double half = g == 2 ? 0.5 * texel : 2.0 * texel, px = 2.0 * half / npx;
    size_t total = (size_t)crops * npx * npx;
    float *nerr[NM];
    for (int m = 0; m < NM; m++) nerr[m] = malloc(total * sizeof(float));
    long wrong[NM] = {0}, counted = 0, ngc = 0;
    double nsum[NM] = {0}, ngs[NM] = {0}, rsum = 0.0;
    unsigned long long rng = 88172645463325252ull ^ (unsigned long long)(R * 131 + mag);
    double (*centres)[2] = malloc((size_t)crops * sizeof *centres);
    for (int k = 0; k < crops; k++) curve_point(su, &rng, centres[k]);
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : counted, ngc, rsum)
    for (int k = 0; k < crops; k++) {
      long w[NM] = {0};
      double ns[NM] = {0}, gs[NM] = {0};
      for (int y = 0; y < npx; y++)
        for (int x = 0; x < npx; x++) {
          size_t at = ((size_t)k * npx + y) * npx + x;
          double q[2] = {centres[k][0] - half + (x + 0.5) * px, centres[k][1] + half - (y + 0.5) * px};
          int out = q[0] < 0 || q[1] < 0 || q[0] > 1 || q[1] > 1;
          double ed = 0.0, tn[3] = {0, 0, 1};
          int ec = -1, es = out ? 0 : exact_side(su->set, &ix, q, &ed, &ec);
          int groove = ec >= 0 && su->set->curves[ec].kind == CH_CURVE_GROOVE;
          /* Points on a curve have no side, and on a crease or wall no
           * normal (the two sides' differ; a crop centred on a 45 degree
           * line puts a whole diagonal of pixel centres on it): both
           * figures leave them out. */
          int side_counts = !out && ed > 1e-9;
          counted += side_counts;
          ngc += side_counts && groove;
          if (side_counts) ch_truth_normal(su->truth, q, tn);
          if (side_counts && su->truth2) {
            double t2[3];
            ch_truth_normal(su->truth2, q, t2);
            double dot = tn[0] * t2[0] + tn[1] * t2[1] + tn[2] * t2[2];
            rsum += acos(dot > 1.0 ? 1.0 : dot < -1.0 ? -1.0 : dot) * 180.0 / CH_PI;
          }
          for (int m = 0; m < NM; m++) {
            if (!side_counts) {
              nerr[m][at] = -1.0f;
              continue;
            }
            ch_featmap_sample s;
            eval_method(&mm, m, q[0], q[1], &s);
            if (s.side != es) w[m]++;
            double dot = s.normal[0] * tn[0] + s.normal[1] * tn[1] + s.normal[2] * tn[2];
            double a = acos(dot > 1.0 ? 1.0 : dot < -1.0 ? -1.0 : dot) * 180.0 / CH_PI;
            nerr[m][at] = (float)a;
            ns[m] += a;
            if (groove) gs[m] += a;
          }
        }
#pragma omp critical
      for (int m = 0; m < NM; m++) wrong[m] += w[m], nsum[m] += ns[m], ngs[m] += gs[m];
    }
    for (int m = 0; m < NM; m++) {
      /* pixels out of the square or on a curve were marked -1: sort and skip them */
      qsort(nerr[m], total, sizeof(float), cmp_float);
      size_t first = 0;
      while (first < total && nerr[m][first] < 0.0f) first++;
      size_t n = total - first;
      res->wrong[g][m] = counted ? 100.0 * wrong[m] / counted : 0.0;
      res->nmean[g][m] = n ? nsum[m] / n : 0.0;
      res->ngroove[g][m] = ngc ? ngs[m] / ngc : 0.0;
      res->np95[g][m] = n ? nerr[m][first + (size_t)(0.95 * (n - 1))] : 0.0;
      res->nref[g] = counted ? rsum / counted : 0.0;
      free(nerr[m]);
    }
    free(centres);
  }
  ch_grid_free(&ix.grid);
  free(ix.boxes);
  ch_featmap_free(&mm.fn);
  ch_featmap_free(&mm.fn_off);
  ch_featmap_free(&mm.lin);
  ch_msdf_free(&mm.msdf);
  ch_msdf_free(&mm.msdf_eq);
  return 0;
}

static int setup_init(setup *su, const ch_curve_set *set, int dci_res, int no_sing, int no_extra, int with_ref2,
                      ch_error *err) {
  memset(su, 0, sizeof *su);
  su->set = set;
  ch_height_desc hd = {
      .dci_resolution = dci_res, .step_method = CH_RECON_EXACT, .no_singular = no_sing, .no_extrapolate = no_extra};
  if (ch_height_init(&su->height, set, &hd, err)) return -1;
  ch_truth_desc td = {.grid = 64};
  if (ch_truth_create(&su->height, &td, &su->truth, err)) return -1;
  if (with_ref2 && su->height.has_steps) {
    ch_height_desc h2 = {
        .dci_resolution = 2 * dci_res, .step_method = CH_RECON_EXACT, .no_singular = no_sing, .no_extrapolate = no_extra};
    if (ch_height_init(&su->height2, set, &h2, err) || ch_truth_create(&su->height2, &td, &su->truth2, err)) return -1;
  }
  su->cum = malloc((size_t)(set->num_segments + 1) * sizeof *su->cum);
  su->segs = malloc((size_t)(set->num_segments + 1) * sizeof *su->segs);
  double acc = 0.0;
  for (int i = 0; i < set->num_segments; i++) {
    if (!ch_featmap_encodes(set, set->segments[i].curve)) continue;
    acc += ch_bezier_length(set->segments[i].p);
    su->cum[su->nsegs] = acc;
    su->segs[su->nsegs++] = i;
  }
  return su->nsegs ? 0 : -1;
}

static void setup_free(setup *su) {
  ch_truth_destroy(su->truth);
  ch_truth_destroy(su->truth2);
  ch_height_free(&su->height2);
  ch_height_free(&su->height);
  free(su->cum);
  free(su->segs);
}

static int parse_list(const char *s, int *out, int max) {
  int n = 0;
  while (*s && n < max) {
    out[n++] = atoi(s);
    const char *c = strchr(s, ',');
    if (!c) break;
    s = c + 1;
  }
  return n;
}

int main(int argc, char **argv) {
  const char *models = "models";
  int res[8] = {64, 128, 256, 512, 1024}, nres = 5, crops = 100, do_acc = 1, do_time = 1, do_speed = 1;
  int max_build = 4096, dci_res = 1024, no_sing = 0, no_extra = 0;
  const char *only = NULL;
  for (int i = 1; i < argc; i++) {
    if (!strcmp(argv[i], "--res") && i + 1 < argc) nres = parse_list(argv[++i], res, 8);
    else if (!strcmp(argv[i], "--crops") && i + 1 < argc) crops = atoi(argv[++i]);
    else if (!strcmp(argv[i], "--sets") && i + 1 < argc) only = argv[++i];
    else if (!strcmp(argv[i], "--no-accuracy")) do_acc = 0;
    else if (!strcmp(argv[i], "--no-time")) do_time = 0;
    else if (!strcmp(argv[i], "--no-speed")) do_speed = 0;
    else if (!strcmp(argv[i], "--max-build") && i + 1 < argc) max_build = atoi(argv[++i]);
    else if (!strcmp(argv[i], "--dci-res") && i + 1 < argc)
      dci_res = atoi(argv[++i]);
    else if (!strcmp(argv[i], "--no-dci-singular"))
      no_sing = 1;
    else if (!strcmp(argv[i], "--no-dci-extrapolate"))
      no_extra = 1;
    else models = argv[i];
  }
  static const char *bundled[] = {"glyphs", "ornament", "frame", "relief", "star", "spiral", "bricks", "panels",
                                  "steps_simple"};
  static const char *torture[] = {"easy", "corners", "thin", "triple", "ends", "crossings", "loops"};
  enum { NB = 9, NT = 7 };
  int threads = omp_get_max_threads();
  ch_error err = {0};
  printf("bench_featmap: %d threads; wrong side: %% of crop pixels off the curves on the other side of the\n"
         "nearest curve than the exact one; normal: degrees from the exact normal of h (mean / p95)\n",
         threads);
  static result tor[NT][8];
  static int have_tor[NT][8];
  if (do_acc) {
    for (int t = 0; t < NB + NT; t++) {
      const char *name = t < NB ? bundled[t] : torture[t - NB];
      if (only && !strstr(only, name)) continue;
      char path[1024];
      snprintf(path, sizeof path, "%s/%s/%s.svg", models, t < NB ? "curves" : "torture", name);
      ch_curve_set set;
      if (ch_curves_read_svg(path, &set, &err)) {
        fprintf(stderr, "%s\n", err.message);
        return 1;
      }
      setup su;
      if (setup_init(&su, &set, dci_res, no_sing, no_extra, 1, &err)) {
        fprintf(stderr, "%s: %s\n", path, err.message);
        return 1;
      }
      printf("\n%s%s (%d crops per magnification)\n", t < NB ? "" : "torture/", name, crops);
      printf("%5s %4s %6s |%9s %9s %9s %9s %9s %9s | normal mean / p95: %-9s %-9s %-9s %-9s %-9s %-9s\n", "R",
             "mag", "R(=B)", mname[0], mname[1], mname[2], mname[3], mname[4], mname[5], mname[0], mname[1], mname[2],
             mname[3], mname[4], mname[5]);
      for (int r = 0; r < nres; r++) {
        result rs;
        int req;
        double t0 = bench_now();
        if (measure(&su, res[r], crops, &rs, &req, &err)) {
          fprintf(stderr, "%s: %s\n", path, err.message);
          return 1;
        }
        for (int g = 0; g < 3; g++) {
          printf("%5d %3dx %6d |", res[r], mags[g], req);
          for (int m = 0; m < NM; m++) printf(" %8.4f%%", rs.wrong[g][m]);
          printf(" |                   ");
          for (int m = 0; m < NM; m++) printf(" %4.2f/%-5.1f", rs.nmean[g][m], rs.np95[g][m]);
          if (su.truth2) printf(" | truth vs 2x DCI %.3f", rs.nref[g]);
          printf("\n");
        }
        if (t >= NB) tor[t - NB][r] = rs, have_tor[t - NB][r] = 1;
        if (res[r] == 256) {
          const double *w = rs.wrong[1], *nm = rs.nmean[1];
          printf("  targets at R 256, 16x: wrong side %.4f%% (< 0.1%%: %s), bilinear / featnorm %.1fx (>= 10x: %s), "
                 "msdf at equal bytes %.4f%% (featnorm fewer: %s); normal mean %.3f vs bilinear %.3f (<= 1/10: %s)\n",
                 w[M_FN], w[M_FN] < 0.1 ? "met" : "NOT met", w[M_FN] > 0 ? w[M_BIL] / w[M_FN] : INFINITY,
                 w[M_BIL] >= 10 * w[M_FN] ? "met" : "NOT met", w[M_MSDF_EQ],
                 w[M_FN] < w[M_MSDF_EQ] ? "met" : w[M_FN] == 0.0 ? "none wrong on either" : "NOT met",
                 nm[M_FN], nm[M_BIL], nm[M_FN] <= 0.1 * nm[M_BIL] ? "met" : "NOT met");
        }
        fflush(stdout);
        (void)t0;
      }
      setup_free(&su);
      ch_curves_free(&set);
    }
    /* Torture classes against the easy one. */
    for (int r = 0; r < nres; r++) {
      if (!have_tor[0][r]) continue;
      printf("\ntorture classes at R %d, 16x, against easy (wrong side %%, normal mean deg; ratio to easy):\n", res[r]);
      printf("%-10s %22s %22s %22s %22s %22s %16s\n", "class", "featnorm side", "fn-nofb side", "featnorm normal",
             "fn-nofb normal", "featnorm on grooves", "truth vs 2x DCI");
      const result *e = &tor[0][r];
      for (int c = 0; c < NT; c++) {
        if (!have_tor[c][r]) continue;
        const result *x = &tor[c][r];
        double fl = 1e-4; /* a floor so that an exact easy class does not divide by 0 */
        printf("%-10s %10.4f (%6.2fx) %10.4f (%6.2fx) %10.3f (%6.2fx) %10.3f (%6.2fx) %10.3f (%6.2fx) %16.3f\n",
               torture[c], x->wrong[1][M_FN], (x->wrong[1][M_FN] + fl) / (e->wrong[1][M_FN] + fl),
               x->wrong[1][M_FN_OFF], (x->wrong[1][M_FN_OFF] + fl) / (e->wrong[1][M_FN_OFF] + fl), x->nmean[1][M_FN],
               (x->nmean[1][M_FN] + fl) / (e->nmean[1][M_FN] + fl), x->nmean[1][M_FN_OFF],
               (x->nmean[1][M_FN_OFF] + fl) / (e->nmean[1][M_FN_OFF] + fl), x->ngroove[1][M_FN],
               (x->ngroove[1][M_FN] + fl) / (e->ngroove[1][M_FN] + fl), x->nref[1]);
      }
    }
  }
  if (do_time) {
    printf("\nbuild (%d threads): featnorm maps without the conventional normal map; median of 3 at 1024, one at 4096;\n"
           "wall seconds, cpu: CPU seconds of all threads (the work, whatever the load); stages of the last run\n",
           threads);
    printf("%-12s %5s %9s %9s %9s %9s %9s %9s %9s %9s %9s | %9s %9s %9s %8s %8s %8s\n", "curves", "R", "featnorm",
           "cpu", "samples", "cells", "fit", "check", "smooth", "fallback", "linear", "normalmap", "msdf", "fb cells", "B/texel",
           "fb B/tx", "msdf B");
    for (int t = 0; t < NB; t++) {
      if (only && !strstr(only, bundled[t])) continue;
      char path[1024];
      snprintf(path, sizeof path, "%s/curves/%s.svg", models, bundled[t]);
      ch_curve_set set;
      if (ch_curves_read_svg(path, &set, &err)) return 1;
      for (int R = 1024; R <= max_build; R *= 4) {
        int reps = R <= 1024 ? 3 : 1;
        double tf[3], tl[3], tm[3], cf[3];
        ch_featmap keep = {0};
        for (int k = 0; k < reps; k++) {
          ch_featmap a, b;
          ch_featmap_desc d = {.resolution = R, .no_normal_map = 1}, dl = {.resolution = R, .linear = 1, .no_normal_map = 1};
          ch_msdf ms;
          ch_msdf_desc md = {.resolution = R};
          double c0 = cpu_seconds();
          ch_status sa = ch_featmap_build(&set, &d, &a, &err);
          cf[k] = cpu_seconds() - c0;
          if (sa || ch_featmap_build(&set, &dl, &b, &err) || ch_msdf_build(&set, &md, &ms, &err)) {
            fprintf(stderr, "%s: %s\n", path, err.message);
            return 1;
          }
          tf[k] = a.stats.seconds_total, tl[k] = b.stats.seconds_total, tm[k] = ms.stats.seconds;
          if (k == reps - 1) keep = a;
          else ch_featmap_free(&a);
          ch_featmap_free(&b);
          ch_msdf_free(&ms);
        }
        /* the conventional normal map alone (2x2 samples per texel) */
        ch_featmap nm;
        ch_featmap_desc dn = {.resolution = R, .no_fallback = 1};
        double tn = 0.0;
        if (R <= 1024 && !ch_featmap_build(&set, &dn, &nm, &err)) {
          tn = nm.stats.seconds_normal;
          ch_featmap_free(&nm);
        }
        const ch_featmap_stats *s = &keep.stats;
        printf("%-12s %5d %8.3fs %8.3fs %8.3fs %8.3fs %8.3fs %8.3fs %8.3fs %8.3fs %8.3fs | %8.3fs %8.3fs %9ld %8.0f %8.2f %8.0f\n",
               bundled[t], R, bench_median(tf, reps), bench_median(cf, reps), s->seconds_samples, s->seconds_cells, s->seconds_fit,
               s->seconds_check, s->seconds_smooth, s->seconds_fallback, bench_median(tl, reps), tn, bench_median(tm, reps),
               s->fallback_cells, ch_featmap_bytes_per_texel(&keep, CH_FEATMAP_FEATNORM),
               ch_featmap_fallback_bytes(&keep), ch_msdf_bytes_per_texel());
        ch_featmap_free(&keep);
        fflush(stdout);
      }
      ch_curves_free(&set);
    }
  }
  if (do_speed) {
    char path[1024];
    snprintf(path, sizeof path, "%s/curves/glyphs.svg", models);
    ch_curve_set set;
    if (ch_curves_read_svg(path, &set, &err)) return 1;
    setup su;
    if (setup_init(&su, &set, dci_res, no_sing, no_extra, 0, &err)) return 1;
    int R = 1024;
    methods mm;
    memset(&mm, 0, sizeof mm);
    ch_featmap_desc d = {.resolution = R}, doff = {.resolution = R, .no_fallback = 1, .no_normal_map = 1};
    ch_featmap_desc dl = {.resolution = R, .linear = 1, .no_normal_map = 1};
    ch_msdf_desc md = {.resolution = R};
    if (ch_featmap_build(&set, &d, &mm.fn, &err) || ch_featmap_build(&set, &doff, &mm.fn_off, &err) ||
        ch_featmap_build(&set, &dl, &mm.lin, &err) || ch_msdf_build(&set, &md, &mm.msdf, &err))
      return 1;
    mm.msdf_eq = mm.msdf;
    enum { N = 1 << 21 };
    double(*pts)[2] = malloc(2 * (size_t)N * sizeof *pts);
    unsigned long long rng = 1234567ull;
    /* In the order a renderer asks: the whole square as a 1448^2 image,
     * row by row; and 512 crops of 64 x 64 pixels (4 x 4 texels, 16x)
     * along the curves, each row by row. */
    const int side = 1448;
    for (int k = 0; k < N; k++) {
      int x = k % side, y = k / side;
      pts[k][0] = (x + 0.5) / side;
      pts[k][1] = 1.0 - (y + 0.5) / side;
    }
    for (int k = 0; k < N / 4096; k++) {
      double c[2];
      curve_point(&su, &rng, c);
      for (int p = 0; p < 4096; p++) {
        pts[N + k * 4096 + p][0] = c[0] - 2.0 / R + ((p % 64) + 0.5) * (4.0 / R) / 64;
        pts[N + k * 4096 + p][1] = c[1] + 2.0 / R - ((p / 64) + 0.5) * (4.0 / R) / 64;
      }
    }
    printf("\nevaluation speed, glyphs at R %d, %d threads, Msamples/s (median of 3), points in raster order: the\n"
           "square as a 1448^2 image, and 512 crops of 64^2 pixels (16x) along the curves; the exact h_groove\n"
           "through its grid (ch_groove_field_eval) as the reference in the same run\n",
           R, threads);
    printf("%-16s %12s %12s\n", "method", "image", "crops");
    static const int order[] = {M_FN, M_FN_OFF, M_LIN, M_MSDF, M_BIL};
    for (int o = 0; o < 6; o++) {
      double rate[2];
      for (int part = 0; part < 2; part++) {
        double ts[3];
        for (int rep = 0; rep < 3; rep++) {
          double t0 = bench_now(), sink = 0.0;
#pragma omp parallel for schedule(static) reduction(+ : sink)
          for (int k = part * N; k < (part + 1) * N; k++) {
            if (o < 5) {
              ch_featmap_sample s;
              eval_method(&mm, order[o], pts[k][0], pts[k][1], &s);
              sink += s.normal[2];
            } else {
              sink += ch_groove_field_eval(&su.height.grooves, pts[k][0], pts[k][1], NULL);
            }
          }
          ts[rep] = bench_now() - t0;
          if (sink == 12345.678) printf(" ");
        }
        rate[part] = N / bench_median(ts, 3) * 1e-6;
      }
      printf("%-16s %12.2f %12.2f\n", o < 5 ? mname[order[o]] : "exact h_groove", rate[0], rate[1]);
    }
    free(pts);
    ch_featmap_free(&mm.fn);
    ch_featmap_free(&mm.fn_off);
    ch_featmap_free(&mm.lin);
    ch_msdf_free(&mm.msdf);
    setup_free(&su);
    ch_curves_free(&set);
  }
  return 0;
}
