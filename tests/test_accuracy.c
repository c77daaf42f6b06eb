/* The accuracy metric (bench/accuracy.h) checked on cases whose
 * figures a person can work out: a flat plane over no features, a missing
 * triangle, a v groove meshed exactly, a box groove and a step on a uniform
 * grid whose lines miss the walls (counted row by row here, and the 20%
 * band error of the continuous argument), determinism across threads. */
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "accuracy.h"
#include "ch_math.h"
#include "ch_test.h"

#define PI_ 3.14159265358979323846

static int parse(const char *body, ch_curve_set *set) {
  char buf[4096];
  snprintf(buf, sizeof buf, "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>%s</svg>", body);
  ch_error err = {0};
  int st = ch_curves_parse_svg(buf, strlen(buf), "t.svg", set, &err);
  if (st) fprintf(stderr, "parse: %s\n", err.message);
  return st;
}

/* Curves and their exact height, kept together. */
typedef struct scene {
  ch_curve_set set;
  ch_height height;
} scene;

static int scene_init(scene *s, const char *body, int dci_res) {
  if (parse(body, &s->set)) return -1;
  ch_height_desc hd = {.dci_resolution = dci_res, .step_method = CH_RECON_EXACT};
  ch_error err = {0};
  if (ch_height_init(&s->height, &s->set, &hd, &err)) {
    fprintf(stderr, "height: %s\n", err.message);
    ch_curves_free(&s->set);
    return -1;
  }
  return 0;
}

static void scene_free(scene *s) {
  ch_height_free(&s->height);
  ch_curves_free(&s->set);
}

static int measure(const ch_mesh *m, scene *s, int grid, ch_accuracy *a) {
  ch_error err = {0};
  ch_status st = ch_accuracy_measure(m, &s->height, &s->set, grid, a, &err);
  if (st) fprintf(stderr, "measure: %s\n", err.message);
  return st;
}

/* A mesh of the given triangles over the given positions. */
static void make_mesh(ch_mesh *m, int np, const double *pos, int nt, const int *tri) {
  memset(m, 0, sizeof *m);
  m->num_positions = np;
  m->positions = malloc(3 * (size_t)np * sizeof *m->positions);
  memcpy(m->positions, pos, 3 * (size_t)np * sizeof *pos);
  m->num_faces = nt;
  m->num_corners = 3 * nt;
  m->face_start = malloc(((size_t)nt + 1) * sizeof *m->face_start);
  m->corner_position = malloc(3 * (size_t)nt * sizeof *m->corner_position);
  for (int f = 0; f <= nt; f++) m->face_start[f] = 3 * f;
  memcpy(m->corner_position, tri, 3 * (size_t)nt * sizeof *tri);
}

/* plane.obj's quads split into fan triangles (0,1,2) (0,2,3), leaving out
 * triangle `skip` (-1: none). */
static int plane_triangles(ch_mesh *out, int skip) {
  ch_mesh q;
  ch_error err = {0};
  if (ch_mesh_read(CHISEL_MODELS "/plane.obj", &q, &err)) {
    fprintf(stderr, "%s\n", err.message);
    return -1;
  }
  int *tri = malloc(6 * (size_t)q.num_faces * sizeof *tri);
  int nt = 0;
  for (int f = 0; f < q.num_faces; f++) {
    const int *c = q.corner_position + q.face_start[f];
    for (int t = 0; t < 2; t++) {
      if (2 * f + t == skip) continue;
      tri[3 * nt] = c[0];
      tri[3 * nt + 1] = c[1 + t];
      tri[3 * nt + 2] = c[2 + t];
      nt++;
    }
  }
  make_mesh(out, q.num_positions, q.positions, nt, tri);
  free(tri);
  ch_mesh_free(&q);
  return 0;
}

/* The flat plane against curves that leave h = 0 on the unit square (the
 * reader refuses a file without curves): a groove outside it. */
static void test_flat_no_features(void) {
  ch_mesh m;
  REQUIRE(plane_triangles(&m, -1) == 0);
  const char *bodies[] = {"<path d='M 150 10 V 90' data-profile='box' data-width='8' data-depth='0.01'/>",
                          "<path d='M -20 -20 L 120 -20' data-profile='v' data-width='8' data-depth='0.01'/>"};
  for (int b = 0; b < 2; b++) {
    scene s;
    REQUIRE(scene_init(&s, bodies[b], 64) == 0);
    ch_accuracy a;
    REQUIRE(measure(&m, &s, 512, &a) == CH_OK);
    CHECK(a.l1 == 0.0);
    CHECK(a.band == 0.0);
    CHECK(a.band_samples == 0);
    CHECK(a.holes == 0.0);
    CHECK(a.samples == 512L * 512);
    CHECK(a.normal_samples == 0);
    CHECK(a.triangles == 512);
    CHECK(a.max_abs_h == 0.0);
    scene_free(&s);
  }
  ch_mesh_free(&m);
}

/* One triangle of plane.obj's first quad missing: its share of samples
 * becomes holes. The quad is 128 x 128 samples at grid 2048 and the 128
 * samples on its diagonal go to exactly one of its triangles: the lower
 * right one (0,0) (1,0) (1,1), whose edge (1,1) -> (0,0) points down (the
 * top-left rule). So the holes are 128*129/2 or 128*127/2 samples, never
 * both triangles' diagonal (a crack) nor neither (a double cover). */
static void test_missing_triangle(void) {
  scene s;
  REQUIRE(scene_init(&s, "<path d='M 0 50 H 100' data-profile='v' data-width='8' data-depth='0.01'/>", 64) == 0);
  const int G = 2048;
  long holes[2];
  for (int t = 0; t < 2; t++) {
    ch_mesh m;
    REQUIRE(plane_triangles(&m, t) == 0);
    ch_accuracy a;
    REQUIRE(measure(&m, &s, G, &a) == CH_OK);
    holes[t] = lround(a.holes * G * G);
    CHECK_NEAR(a.holes * G * G, (double)holes[t], 1e-6);
    CHECK((long)G * G - a.samples == holes[t]);
    /* The area share, 1/512 of the square, within one sample per edge sample. */
    CHECK(fabs(a.holes - 1.0 / 512) <= 128.0 / ((double)G * G));
    ch_mesh_free(&m);
  }
  CHECK(holes[0] == 128 * 129 / 2);
  CHECK(holes[1] == 128 * 127 / 2);
  CHECK(holes[0] + holes[1] == 128 * 128);
  scene_free(&s);
}

/* A v groove along v = 0.5, width 0.125, depth 0.01, meshed with vertex rows
 * on its three crease lines (v = 0.4375, 0.5, 0.5625) and exact heights:
 * the mesh is the exact surface. */
static void test_v_groove_exact(void) {
  scene s;
  REQUIRE(scene_init(&s, "<path d='M 0 50 H 100' data-profile='v' data-width='12.5' data-depth='0.01'/>", 64) == 0);
  const double rows[] = {0.0, 0.4375, 0.5, 0.5625, 1.0};
  const int nr = 5, nc = 9;
  double pos[5 * 9 * 3];
  for (int j = 0; j < nr; j++)
    for (int i = 0; i < nc; i++) {
      double *p = pos + 3 * (j * nc + i);
      p[0] = (double)i / (nc - 1);
      p[1] = rows[j];
      p[2] = ch_height_eval(&s.height, p[0], p[1]);
    }
  CHECK_NEAR(pos[3 * (2 * nc) + 2], -0.01, 1e-15);
  int tri[4 * 8 * 6], nt = 0;
  for (int j = 0; j + 1 < nr; j++)
    for (int i = 0; i + 1 < nc; i++) {
      int a = j * nc + i, b = a + 1, c = a + nc + 1, d = a + nc;
      int q[6] = {a, b, c, a, c, d};
      memcpy(tri + 3 * nt, q, sizeof q);
      nt += 2;
    }
  ch_mesh m;
  make_mesh(&m, nr * nc, pos, nt, tri);
  const int G = 2048;
  ch_accuracy a;
  REQUIRE(measure(&m, &s, G, &a) == CH_OK);
  CHECK(a.l1 < 1e-6);
  CHECK(a.band == 0.0);
  CHECK(a.holes == 0.0);
  CHECK_NEAR(a.max_abs_h, 0.01, 1e-4); /* the sample nearest the bottom of the v */
  CHECK(a.normal_mean_deg < 1e-3);
  CHECK(a.normal_p95_deg < 1e-3);
  /* Band and normal samples by hand: rows within 2e = 2 sqrt(2/64) of a
   * crease line, and rows 1e-3..1e-2 from one. */
  long rows_n = 0, rows_b = 0;
  for (int j = 0; j < G; j++) {
    double v = (j + 0.5) / G, d = INFINITY;
    for (int k = 1; k <= 3; k++) d = fmin(d, fabs(v - rows[k]));
    rows_n += d >= 1e-3 && d <= 1e-2;
    rows_b += d <= 2 * sqrt(2.0 / 64);
  }
  CHECK(a.triangles == 64);
  CHECK(a.normal_samples == rows_n * G);
  CHECK(a.band_samples == rows_b * G);
  CHECK(rows_b < G);
  CHECK(a.shading_samples == 0 && isnan(a.shading_p95_deg)); /* no vn */

  /* Shading normals: one vn per vertex row, tilted theta[j] in the (v, z)
   * plane, shared across the creases (the rims get half the slope, the
   * bottom none), interpolated linearly in v within every triangle (the
   * normals depend on the row only). Expected, row by row: the angle
   * between that interpolation and the exact normal (0 on the flat, +-alpha
   * on the sides, tan alpha = 0.01 / 0.0625). */
  double alpha = atan(0.01 / 0.0625), theta[5] = {0.0, 0.5 * alpha, 0.0, -0.5 * alpha, 0.0};
  m.num_normals = nr;
  m.normals = malloc(3 * (size_t)nr * sizeof *m.normals);
  m.corner_normal = malloc((size_t)m.num_corners * sizeof *m.corner_normal);
  REQUIRE(m.normals && m.corner_normal);
  for (int j = 0; j < nr; j++) {
    m.normals[3 * j] = 0.0;
    m.normals[3 * j + 1] = sin(theta[j]);
    m.normals[3 * j + 2] = cos(theta[j]);
  }
  for (int c = 0; c < m.num_corners; c++) m.corner_normal[c] = m.corner_position[c] / nc;
  REQUIRE(measure(&m, &s, G, &a) == CH_OK);
  double *want = malloc((size_t)G * sizeof *want), sum = 0.0;
  REQUIRE(want);
  long nw = 0;
  for (int j = 0; j < G; j++) {
    double v = (j + 0.5) / G, d = INFINITY;
    for (int k = 1; k <= 3; k++) d = fmin(d, fabs(v - rows[k]));
    if (!(d >= 1e-3 && d <= 1e-2)) continue;
    int k = 0;
    while (v > rows[k + 1]) k++;
    double t = (v - rows[k]) / (rows[k + 1] - rows[k]);
    double phi =
        atan2((1 - t) * sin(theta[k]) + t * sin(theta[k + 1]), (1 - t) * cos(theta[k]) + t * cos(theta[k + 1]));
    double exact = v > rows[1] && v < rows[2] ? alpha : v > rows[2] && v < rows[3] ? -alpha : 0.0;
    want[nw++] = fabs(phi - exact) * 180.0 / PI_;
    sum += want[nw - 1];
  }
  qsort(want, (size_t)nw, sizeof *want, ch_cmp_double);
  long rank = (long)ceil(0.95 * (double)nw * G) - 1; /* every row repeats G times */
  printf("  v groove, shared vn: shading mean %.4f p95 %.4f deg (expected %.4f, %.4f)\n", a.shading_mean_deg,
         a.shading_p95_deg, sum / nw, want[rank / G]);
  CHECK(a.shading_samples == a.normal_samples);
  CHECK_NEAR(a.shading_mean_deg, sum / nw, 1e-6);
  CHECK_NEAR(a.shading_p95_deg, want[rank / G], 1e-6);
  CHECK(a.shading_p95_deg > 1.0); /* (the case is not trivial) */
  free(want);
  ch_mesh_free(&m);
  scene_free(&s);
}

/* A uniform n x n grid with exact vertex heights over a field h(v) that only
 * depends on v and whose walls/creases lie strictly inside grid strips:
 * every vertex row has one height, so every triangle of a strip lies on the
 * same plane, z(v) linear between the rows. Expected figures row by row. */
typedef struct expected {
  double l1, band, normal_mean, normal_p95;
  long band_samples, normal_samples;
} expected;

static void expect_rows(const scene *s, int n, int G, const double *walls, int nwalls, expected *x) {
  double hmax = 0.0, l1 = 0.0, asum = 0.0;
  long band = 0, wrong = 0, nn = 0;
  double *h = malloc((size_t)G * sizeof *h), *z = malloc((size_t)G * sizeof *z);
  double *ang = malloc((size_t)G * sizeof *ang), *dist = malloc((size_t)G * sizeof *dist);
  double e = sqrt(2.0 / (2.0 * n * n));
  for (int j = 0; j < G; j++) {
    double v = (j + 0.5) / G;
    h[j] = ch_height_eval(&s->height, 0.5, v);
    int k = (int)floor(v * n);
    double z0 = ch_height_eval(&s->height, 0.5, (double)k / n);
    double z1 = ch_height_eval(&s->height, 0.5, (double)(k + 1) / n);
    z[j] = z0 + (z1 - z0) * (v * n - k);
    double hv = (ch_height_eval(&s->height, 0.5, v + 1e-5) - ch_height_eval(&s->height, 0.5, v - 1e-5)) / 2e-5;
    ang[j] = fabs(atan((z1 - z0) * n) - atan(hv)) * 180.0 / PI_;
    dist[j] = INFINITY;
    for (int w = 0; w < nwalls; w++) dist[j] = fmin(dist[j], fabs(v - walls[w]));
    hmax = fmax(hmax, fabs(h[j]));
  }
  double *list = malloc((size_t)G * sizeof *list);
  int nl = 0;
  for (int j = 0; j < G; j++) {
    double err = fabs(z[j] - h[j]);
    l1 += err;
    if (dist[j] <= 2 * e) {
      band++;
      wrong += err > 0.1 * hmax;
    }
    if (dist[j] >= 1e-3 && dist[j] <= 1e-2) {
      nn++;
      asum += ang[j];
      list[nl++] = ang[j];
    }
  }
  qsort(list, (size_t)nl, sizeof *list, ch_cmp_double);
  x->l1 = l1 / G / hmax;
  x->band = (double)wrong / (double)band;
  x->band_samples = band * G;
  x->normal_samples = nn * G;
  x->normal_mean = asum / (double)nn;
  /* Every row repeats G times: the ceil(0.95 nn G)-th of the G-fold list. */
  long rank = (long)ceil(0.95 * (double)nn * G) - 1;
  x->normal_p95 = list[rank / G];
  free(list);
  free(h);
  free(z);
  free(ang);
  free(dist);
}

/* A box groove of width 0.1 at v = 0.5 (walls at v = 0.45 and 0.55) on the
 * 64 x 64 grid (e = 1/64): the walls sit 0.8 e and 0.2 e into their strips
 * (0.45 = (28 + 0.8) / 64, 0.55 = (35 + 0.2) / 64). In a strip z runs
 * linearly from 0 to -d, so |z - h| > 0.1 d on 0.8 e of it whatever the
 * offset, inside a band of 4 e around each wall: band error 0.8/4 = 20%.
 * L1: per wall d/(2e) (a^2 + b^2) with a + b = e, a = 0.8 e: 0.34 d e, so
 * 0.68 e = 0.010625 over the square. Normals: the strip's slope d/e =
 * 0.64, 32.62 degrees, on the normal-band rows inside the strips, flat
 * (0 degrees) elsewhere. */
static void test_box_groove_uniform(void) {
  scene s;
  REQUIRE(scene_init(&s, "<path d='M 0 50 H 100' data-profile='box' data-width='10' data-depth='0.01'/>", 64) == 0);
  ch_mesh m;
  ch_error err = {0};
  REQUIRE(ch_accuracy_uniform_grid(&s.height, 64, &m, &err) == CH_OK);
  REQUIRE(m.num_faces == 2 * 64 * 64);
  const int G = 2048;
  ch_accuracy a;
  REQUIRE(measure(&m, &s, G, &a) == CH_OK);
  const double walls[2] = {0.45, 0.55};
  expected x;
  expect_rows(&s, 64, G, walls, 2, &x);
  CHECK(a.triangles == 8192);
  CHECK_NEAR(a.edge_length, 1.0 / 64, 1e-15);
  CHECK(a.holes == 0.0);
  CHECK(a.band_samples == x.band_samples);
  CHECK_NEAR(a.band, x.band, 1e-12);
  CHECK_NEAR(a.l1, x.l1, 1e-9);
  CHECK(a.normal_samples == x.normal_samples);
  CHECK_NEAR(a.normal_mean_deg, x.normal_mean, 1e-4);
  CHECK_NEAR(a.normal_p95_deg, x.normal_p95, 1e-4);
  /* By hand on the 2048 sample rows: a strip holds 32 rows, at fractions
   * f = (m + 1/2)/32 of it. Wrong where 0.1 < f < 0.9 (either wall offset):
   * m = 3..28, 26 rows; the band around 0.45 holds rows 858..985 (v within
   * 1/32), 128 rows: 26/128. L1 around the wall at f = 0.8 (and 0.2):
   * (sum of f below it + of 1 - f above it) / 32 = (10.5625 + 0.5625) / 32
   * = 0.34765625 per strip, the continuous 0.34 sampled at row centres. */
  CHECK(a.band == 26.0 / 128);
  CHECK(a.band_samples == 2 * 128L * G);
  CHECK_NEAR(a.l1, 2 * 0.34765625 / 64, 1e-15);
  /* The continuous figures, within the sampling of 2048 rows. */
  CHECK_NEAR(a.band, 0.2, 2.0 / 128);
  CHECK_NEAR(a.l1, 0.68 / 64, 3e-4);
  CHECK_NEAR(a.normal_p95_deg, atan(0.64) * 180.0 / PI_, 1e-4);
  /* Normal-band rows inside the strips: [0.44, 0.449] and [0.451, 0.453125]
   * around 0.45, [0.546875, 0.549] and [0.551, 0.56] around 0.55. */
  CHECK_NEAR(a.normal_mean_deg, atan(0.64) * 180.0 / PI_ * (0.011125 / 0.018), 0.3);
  fprintf(stderr, "  box on 64x64: L1 %.6g band %.6g (%ld) normal mean %.4g p95 %.4g (%ld)\n", a.l1, a.band,
          a.band_samples, a.normal_mean_deg, a.normal_p95_deg, a.normal_samples);
  ch_mesh_free(&m);
  scene_free(&s);
}

/* The same with a straight step curve (0.01 above v = 0.45, 0 below), h_step
 * from a DCI: one wall, the same 20% band error. */
static void test_step_uniform(void) {
  scene s;
  REQUIRE(scene_init(&s, "<path d='M 0 55 H 100' data-kind='step' data-left='0.01' data-right='0'/>", 256) == 0);
  CHECK_NEAR(ch_height_eval(&s.height, 0.3, 0.6), 0.01, 1e-7);
  CHECK_NEAR(ch_height_eval(&s.height, 0.3, 0.4), 0.0, 1e-7);
  ch_mesh m;
  ch_error err = {0};
  REQUIRE(ch_accuracy_uniform_grid(&s.height, 64, &m, &err) == CH_OK);
  const int G = 2048;
  ch_accuracy a;
  REQUIRE(measure(&m, &s, G, &a) == CH_OK);
  const double walls[1] = {0.45};
  expected x;
  expect_rows(&s, 64, G, walls, 1, &x);
  CHECK(a.band_samples == x.band_samples);
  CHECK_NEAR(a.band, x.band, 1e-12);
  CHECK_NEAR(a.l1, x.l1, 1e-5);
  CHECK(a.normal_samples == x.normal_samples);
  CHECK_NEAR(a.normal_p95_deg, x.normal_p95, 1e-3);
  CHECK_NEAR(a.band, 0.2, 2.0 / 128);
  ch_mesh_free(&m);
  scene_free(&s);

  /* A blurred step is no wall: no band samples at all. */
  REQUIRE(scene_init(&s, "<path d='M 0 55 H 100' data-kind='step' data-left='0.01' data-blur='2'/>", 256) == 0);
  REQUIRE(ch_accuracy_uniform_grid(&s.height, 64, &m, &err) == CH_OK);
  REQUIRE(measure(&m, &s, 512, &a) == CH_OK);
  CHECK(a.band_samples == 0);
  CHECK(a.normal_samples == 0);
  ch_mesh_free(&m);
  scene_free(&s);
}

/* The v groove on a grid whose rows miss its creases: clearly wrong. */
static void test_v_groove_unaligned(void) {
  scene s;
  REQUIRE(scene_init(&s, "<path d='M 0 49 H 100' data-profile='v' data-width='12.5' data-depth='0.01'/>", 64) == 0);
  ch_mesh m;
  ch_error err = {0};
  REQUIRE(ch_accuracy_uniform_grid(&s.height, 64, &m, &err) == CH_OK);
  ch_accuracy a;
  REQUIRE(measure(&m, &s, 2048, &a) == CH_OK);
  const double creases[3] = {0.51 - 0.0625, 0.51, 0.51 + 0.0625};
  expected x;
  expect_rows(&s, 64, 2048, creases, 3, &x);
  CHECK(a.l1 > 1e-4);
  CHECK(a.normal_p95_deg > 1.0);
  CHECK_NEAR(a.l1, x.l1, 1e-9);
  CHECK_NEAR(a.band, x.band, 1e-12);
  CHECK_NEAR(a.normal_mean_deg, x.normal_mean, 1e-4);
  CHECK(a.holes == 0.0);
  ch_mesh_free(&m);
  scene_free(&s);
}

/* Overlapping triangles: the higher one wins, with its normal. */
static void test_overlap_max_z(void) {
  scene s;
  REQUIRE(scene_init(&s, "<path d='M 150 10 V 90'/>", 64) == 0);
  const double pos[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, /* the flat square */
                        0, 0, 0.5, 1, 0, 0.5, 1, 1, 0.5, 0, 1, 0.5, /* a raised copy */
                        0.5, 0.5, 0, 0.5, 0.5, 1, 0.6, 0.6, 0}; /* a vertical triangle */
  const int tri[] = {0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7, 8, 9, 10};
  ch_mesh m;
  make_mesh(&m, 11, pos, 5, tri);
  ch_accuracy a;
  REQUIRE(measure(&m, &s, 256, &a) == CH_OK);
  CHECK(a.triangles == 5);
  CHECK(a.holes == 0.0);
  CHECK_NEAR(a.l1, 0.5, 1e-15); /* h = 0, max|h| = 0: absolute */
  ch_mesh_free(&m);
  scene_free(&s);
}

/* Same figures with one and with two threads, on a bundled curve set. */
static void test_determinism(void) {
  ch_curve_set set;
  ch_error err = {0};
  REQUIRE(ch_curves_read_svg(CHISEL_MODELS "/curves/glyphs.svg", &set, &err) == CH_OK);
  ch_height h;
  ch_height_desc hd = {.dci_resolution = 256, .step_method = CH_RECON_EXACT};
  REQUIRE(ch_height_init(&h, &set, &hd, &err) == CH_OK);
  ch_mesh m;
  REQUIRE(ch_accuracy_uniform_grid(&h, 100, &m, &err) == CH_OK);
  ch_accuracy a[2];
  for (int t = 0; t < 2; t++) {
    omp_set_num_threads(t + 1);
    REQUIRE(ch_accuracy_measure(&m, &h, &set, 1024, &a[t], &err) == CH_OK);
  }
  CHECK(memcmp(&a[0], &a[1], sizeof a[0]) == 0);
  CHECK(a[0].l1 > 0.0 && a[0].band > 0.0 && a[0].normal_p95_deg > 0.0 && a[0].holes == 0.0);
  fprintf(stderr, "  glyphs 100x100 at 1024: L1 %.6g band %.6g normal %.4g/%.4g\n", a[0].l1, a[0].band,
          a[0].normal_mean_deg, a[0].normal_p95_deg);
  ch_mesh_free(&m);
  ch_height_free(&h);
  ch_curves_free(&set);
}

/* The raster reading: a v groove of width 0.2 along v = 1/2 (h = -d (1 -
 * |v - 1/2| / 0.1)) read from a 10 x 10 raster (pixel centres at 0.05,
 * 0.15, ...): at v = 0.45, a pixel centre, h exactly (-d/2); at the crease
 * v = 1/2, between the centres 0.45 and 0.55, their mean -d/2 instead of
 * -d; away from the groove 0. */
static void test_raster_reading(void) {
  scene s;
  REQUIRE(scene_init(&s, "<path d='M 0 50 H 100' data-profile='v' data-width='20' data-depth='0.01'/>", 64) == 0);
  ch_mesh m;
  ch_error err = {0};
  REQUIRE(ch_accuracy_uniform_grid(&s.height, 20, &m, &err) == CH_OK);
  CHECK_NEAR(m.positions[3 * (10 * 21 + 7) + 2], -0.01, 1e-12); /* exact before: v = 0.5 */
  REQUIRE(ch_accuracy_read_raster(&s.height, 10, &m, &err) == CH_OK);
  CHECK_NEAR(m.positions[3 * (9 * 21 + 7) + 2], -0.005, 1e-8);  /* v = 0.45 */
  CHECK_NEAR(m.positions[3 * (10 * 21 + 7) + 2], -0.005, 1e-8); /* v = 0.5 */
  CHECK_NEAR(m.positions[3 * (2 * 21 + 7) + 2], 0.0, 1e-12);    /* v = 0.1 */
  ch_mesh_free(&m);
  scene_free(&s);
}

static void test_uniform_n(void) {
  CHECK(ch_accuracy_uniform_n(131072) == 256);
  CHECK(ch_accuracy_uniform_n(524288) == 512);
  CHECK(ch_accuracy_uniform_n(2097152) == 1024);
  CHECK(ch_accuracy_uniform_n(130000) == 255);  /* 2*255^2 = 130050 */
  CHECK(ch_accuracy_uniform_n(2) == 1);
  CHECK(ch_accuracy_uniform_n(7) == 2);  /* |8-7| < |2-7| */
  CHECK(ch_accuracy_uniform_n(5) == 1);  /* |2-5| = |8-5|: the smaller n */
}

int main(void) {
  RUN(test_uniform_n);
  RUN(test_raster_reading);
  RUN(test_flat_no_features);
  RUN(test_missing_triangle);
  RUN(test_v_groove_exact);
  RUN(test_box_groove_uniform);
  RUN(test_step_uniform);
  RUN(test_v_groove_unaligned);
  RUN(test_overlap_max_z);
  RUN(test_determinism);
  TEST_MAIN_END();
}
