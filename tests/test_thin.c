/* Thinning the bands of a layered cut (tess/ch_thin), on a strip of quads
 * over [0,1] x [0,1] with rows as layers: rows 0 and R-1 belong to no band
 * (their vertices must stay), rows 1..R-2 to one family, layer = row. The
 * lines between band rows run along x from border to border.
 *
 * - Unlimited edges: every inner line keeps only its two end vertices (on
 *   the strip's border, which never moves), the lines touching the outer
 *   rows keep all theirs, so the count of triangles is known exactly:
 *   4N outside, N+1 for each layer next to them, 2 for each layer between
 *   two inner lines. The UV area is unchanged and no triangle turns over.
 * - Edges at most 0.25 long: each inner line keeps a chain of edges no
 *   longer than that from border to border.
 * - A vertex on a UV seam (the triangles on one side see it at another
 *   UV) stays. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ch_test.h"
#include "ch_thin.h"

enum { N = 10, R = 8 }; /* quads per row, rows */

typedef struct strip {
  int nv, nt;
  int tri[2 * N * R * 3];
  int corner_uv[2 * N * R * 3]; /* -1: the vertex's UV (pos), else extra_uv's */
  double extra_uv[2 * 16];
  int nextra;
  uint64_t group[2 * N * R];
  double pos[(N + 1) * (R + 1)][2];
} strip;

/* The UVs of triangle t's corners (6). */
static void tri_uv(const strip *s, int t, double uv[6]) {
  for (int k = 0; k < 3; k++) {
    int c = 3 * t + k, x = s->corner_uv[c];
    memcpy(&uv[2 * k], x < 0 ? s->pos[s->tri[c]] : &s->extra_uv[2 * x], 2 * sizeof(double));
  }
}

static void strip_build(strip *s) {
  s->nv = (N + 1) * (R + 1);
  s->nt = 0;
  s->nextra = 0;
  for (int j = 0; j <= R; j++)
    for (int i = 0; i <= N; i++) {
      /* a little jitter along the lines, so collapses see unequal edges */
      double jx = (i > 0 && i < N) ? 0.02 * sin(7.0 * i + 3.0 * j) : 0.0;
      s->pos[j * (N + 1) + i][0] = (i + jx * N) / N;
      s->pos[j * (N + 1) + i][1] = (double)j / R;
    }
  for (int j = 0; j < R; j++)
    for (int i = 0; i < N; i++) {
      int a = j * (N + 1) + i, b = a + 1, c = a + N + 2, d = a + N + 1;
      int quad[2][3] = {{a, b, c}, {a, c, d}};
      for (int k = 0; k < 2; k++) {
        for (int m = 0; m < 3; m++) {
          s->tri[3 * s->nt + m] = quad[k][m];
          s->corner_uv[3 * s->nt + m] = -1;
        }
        s->group[s->nt++] = (uint64_t)j;
      }
    }
}

static int band_of(void *ctx, uint64_t group, int *layer) {
  (void)ctx;
  if (group == 0 || group == R - 1) return -1;
  *layer = (int)group;
  return 0;
}

static double max_len = INFINITY;
static double max_edge(void *ctx, const double uv[2]) {
  (void)ctx, (void)uv;
  return max_len;
}

static int any_edge(void *ctx, int family, int va, int vb, const double a[2], const double b[2]) {
  (void)ctx, (void)family, (void)va, (void)vb, (void)a, (void)b;
  return 1;
}

static double signed_area(const strip *s, int t) {
  double uv[6];
  tri_uv(s, t, uv);
  return 0.5 * ((uv[2] - uv[0]) * (uv[5] - uv[1]) - (uv[4] - uv[0]) * (uv[3] - uv[1]));
}

static int thin(strip *s, const ch_thin_rules *rules, unsigned char *removed) {
  return ch_thin_bands(s->nv, &s->nt, s->tri, s->corner_uv, &s->pos[0][0], s->extra_uv, s->group, rules, removed);
}

static void check_common(const strip *s, double area0) {
  double area = 0.0;
  int flipped = 0;
  for (int t = 0; t < s->nt; t++) {
    area += signed_area(s, t);
    flipped += !(signed_area(s, t) > 0.0);
  }
  CHECK_MSG(fabs(area - area0) < 1e-12, "UV area %.15g, was %.15g", area, area0);
  CHECK_MSG(flipped == 0, "%d triangles turned over", flipped);
}

/* The vertices still used on line j (y = j / R), sorted by x. */
static int line_vertices(const strip *s, int j, double *xs) {
  int used[(N + 1) * (R + 1)] = {0}, n = 0;
  for (int c = 0; c < 3 * s->nt; c++) used[s->tri[c]] = 1;
  for (int i = 0; i <= N; i++)
    if (used[j * (N + 1) + i]) xs[n++] = s->pos[j * (N + 1) + i][0];
  return n;
}

static void test_unlimited(void) {
  strip s;
  strip_build(&s);
  double area0 = 0.0;
  for (int t = 0; t < s.nt; t++) area0 += signed_area(&s, t);
  unsigned char removed[(N + 1) * (R + 1)] = {0};
  max_len = INFINITY;
  ch_thin_rules rules = {band_of, max_edge, any_edge, NULL, NULL};
  int n = thin(&s, &rules, removed);
  /* inner lines 2..R-2 lose their N-1 inner vertices */
  CHECK_MSG(n == (R - 3) * (N - 1), "removed %d vertices, expected %d", n, (R - 3) * (N - 1));
  int expected = 4 * N + 2 * (N + 1) + 2 * (R - 4);
  CHECK_MSG(s.nt == expected, "%d triangles, expected %d", s.nt, expected);
  check_common(&s, area0);
  double xs[N + 1];
  for (int j = 0; j <= R; j++) {
    int k = line_vertices(&s, j, xs);
    if (j >= 2 && j <= R - 2)
      CHECK_MSG(k == 2 && xs[0] == 0.0 && xs[1] == 1.0, "inner line %d keeps %d vertices", j, k);
    else
      CHECK_MSG(k == N + 1, "line %d (touching the outside) keeps %d of %d vertices", j, k, N + 1);
  }
}

static void test_limited(void) {
  strip s;
  strip_build(&s);
  double area0 = 0.0;
  for (int t = 0; t < s.nt; t++) area0 += signed_area(&s, t);
  int nt0 = s.nt;
  unsigned char removed[(N + 1) * (R + 1)] = {0};
  max_len = 0.25;
  ch_thin_rules rules = {band_of, max_edge, any_edge, NULL, NULL};
  REQUIRE(thin(&s, &rules, removed) > 0);
  CHECK(s.nt < nt0);
  check_common(&s, area0);
  double xs[N + 1];
  for (int j = 2; j <= R - 2; j++) {
    int k = line_vertices(&s, j, xs);
    CHECK(k >= 5 && xs[0] == 0.0 && xs[k - 1] == 1.0);
    for (int i = 0; i + 1 < k; i++) CHECK_MSG(xs[i + 1] - xs[i] <= 0.25, "line %d: a gap of %g", j, xs[i + 1] - xs[i]);
  }
  /* every edge of every triangle inside the band is within the limit */
  for (int t = 0; t < s.nt; t++) {
    if (s.group[t] == 0 || s.group[t] == R - 1) continue;
    double uv[6];
    tri_uv(&s, t, uv);
    for (int k = 0; k < 3; k++) {
      const double *a = &uv[2 * k], *b = &uv[2 * ((k + 1) % 3)];
      CHECK(hypot(b[0] - a[0], b[1] - a[1]) <= 0.25 + 1e-15);
    }
  }
}

static void test_seam_vertex_stays(void) {
  strip s;
  strip_build(&s);
  /* vertex (5, 4) on line 4 is on a seam: the triangles right of it see
   * it at another UV (by 1e-9, far above rounding) */
  int v = 4 * (N + 1) + 5;
  for (int c = 0; c < 3 * s.nt; c++) {
    double t[6];
    tri_uv(&s, c / 3, t);
    if (s.tri[c] == v && (t[0] + t[2] + t[4]) / 3.0 > s.pos[v][0]) {
      REQUIRE(s.nextra < 16);
      s.extra_uv[2 * s.nextra] = s.pos[v][0] + 1e-9;
      s.extra_uv[2 * s.nextra + 1] = s.pos[v][1];
      s.corner_uv[c] = s.nextra++;
    }
  }
  unsigned char removed[(N + 1) * (R + 1)] = {0};
  max_len = INFINITY;
  ch_thin_rules rules = {band_of, max_edge, any_edge, NULL, NULL};
  REQUIRE(thin(&s, &rules, removed) > 0);
  CHECK(!removed[v]);
}

int main(void) {
  RUN(test_unlimited);
  RUN(test_limited);
  RUN(test_seam_vertex_stays);
  TEST_MAIN_END();
}
