/* Tests of tess/ch_surface: the base surface B, N and UV of docs/spec.md §1 and
 * the watertight tessellation.
 * - bilinear plane: B = (u, v, 0), N = (0, 0, 1) exactly; catmark plane too;
 * - the documented bilinear weights of triangles and n-gons;
 * - catmark cube against an independent OpenSubdiv path (Far PatchTable,
 *   tests/tess_reference.cpp) and the hand-computed limit of its corners;
 * - position and normal continuity across every shared edge (UV seams
 *   included), both schemes;
 * - watertightness, orientation and UVs of ch_tess_build on every bundled
 *   mesh (plus a cube and an n-gon fan) at several rates and targets;
 * - --target-tris accuracy at 130k / 520k / 2.1M on every bundled mesh;
 * - the same bytes with 1 and 2 threads; bad input;
 * - warped tessellation: watertight on every mesh, on target, a regular
 *   grid in the mesh's warped metric where the camera looks on the plane,
 *   denser there. */
#define _POSIX_C_SOURCE 200809L
#include <omp.h>
#include <stdint.h>
#include <string.h>
#include <time.h>

#include "ch_math.h"
#include "ch_surface.h"
#include "ch_test.h"
#include "ch_warp.h"

/* tests/tess_reference.cpp */
typedef struct ref_catmark ref_catmark;
ref_catmark *ref_catmark_create(int num_vertices, const double *positions, int num_faces,
                                const int *verts_per_face, const int *indices, int level);
int ref_catmark_eval(const ref_catmark *r, int face, double s, double t, double P[3],
                     double Ds[3], double Dt[3]);
void ref_catmark_destroy(ref_catmark *r);
typedef struct ref_bfr ref_bfr;
ref_bfr *ref_bfr_create(int num_positions, const double *positions, int num_uvs, const double *uvs, int num_faces,
                        const int *face_start, const int *corner_position, const int *corner_uv, int catmark);
int ref_bfr_eval(const ref_bfr *r, int face, double s, double t, double P[3], double Ds[3], double Dt[3], double N[3],
                 double uv[2]);
void ref_bfr_destroy(ref_bfr *r);

/* ---- helpers ------------------------------------------------------------ */

static int quick = 0;

static const char *models[] = {"plane", "torus", "obelisk", "vase", "tablet"};
enum { NUM_MODELS = 5 };
static const int model_closed[] = {0, 1, 1, 0, 1};


static int load_model(const char *name, ch_mesh *m) {
  char path[1024];
  snprintf(path, sizeof path, "%s/%s.obj", CHISEL_MODELS, name);
  ch_error err = {0};
  if (ch_mesh_read(path, m, &err) != CH_OK) {
    fprintf(stderr, "%s\n", err.message);
    return 0;
  }
  return 1;
}

static void *xcalloc(size_t n, size_t size) {
  void *p = calloc(n ? n : 1, size);
  if (!p) abort();
  return p;
}

/* A mesh from arrays; UVs one per corner when uv_per_corner, else one per
 * position. */
static void make_mesh(ch_mesh *m, int np, const double *pos, int nf, const int *sizes,
                      const int *idx, const double *uvs, int num_uvs, const int *corner_uv) {
  memset(m, 0, sizeof *m);
  m->num_positions = np;
  m->positions = xcalloc(3 * np, sizeof(double));
  memcpy(m->positions, pos, 3 * np * sizeof(double));
  m->num_faces = nf;
  m->face_start = xcalloc(nf + 1, sizeof(int));
  for (int f = 0; f < nf; f++) m->face_start[f + 1] = m->face_start[f] + sizes[f];
  m->num_corners = m->face_start[nf];
  m->corner_position = xcalloc(m->num_corners, sizeof(int));
  memcpy(m->corner_position, idx, m->num_corners * sizeof(int));
  m->num_uvs = num_uvs;
  m->uvs = xcalloc(2 * num_uvs, sizeof(double));
  memcpy(m->uvs, uvs, 2 * num_uvs * sizeof(double));
  m->corner_uv = xcalloc(m->num_corners, sizeof(int));
  memcpy(m->corner_uv, corner_uv, m->num_corners * sizeof(int));
}

/* The unit cube [0,1]^3, faces counter-clockwise seen from outside, each
 * face its own UV chart (so every edge is a UV seam). */
static const double cube_pos[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0,
                                  0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1};
static const int cube_idx[] = {0, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4,
                               1, 2, 6, 5, 2, 3, 7, 6, 3, 0, 4, 7};
static const int cube_sizes[] = {4, 4, 4, 4, 4, 4};

static void make_cube(ch_mesh *m) {
  double uvs[48];
  int cuv[24];
  for (int f = 0; f < 6; f++) {
    double u0 = (f % 3) / 3.0 + 0.01, v0 = (f / 3) / 2.0 + 0.01, w = 1 / 3.0 - 0.02, h = 0.5 - 0.02;
    double cu[4] = {0, 1, 1, 0}, cv[4] = {0, 0, 1, 1};
    for (int k = 0; k < 4; k++) {
      uvs[2 * (4 * f + k)] = u0 + w * cu[k];
      uvs[2 * (4 * f + k) + 1] = v0 + h * cv[k];
      cuv[4 * f + k] = 4 * f + k;
    }
  }
  make_mesh(m, 8, cube_pos, 6, cube_sizes, cube_idx, uvs, 24, cuv);
}

/* A pentagon ringed by ten triangles, slightly curved (z = 0.2 x y), one UV
 * per position: the n-gon and triangle parameterisations. Open. */
static void make_fan(ch_mesh *m) {
  double pos[30], uvs[20];
  int idx[5 + 30], sizes[11], cuv[35];
  for (int i = 0; i < 5; i++) {
    double a = 2 * 3.14159265358979323846 * i / 5, b = a + 3.14159265358979323846 / 5;
    double p[2] = {0.5 * cos(a), 0.5 * sin(a)}, q[2] = {cos(b), sin(b)};
    pos[3 * i] = p[0], pos[3 * i + 1] = p[1], pos[3 * i + 2] = 0.2 * p[0] * p[1];
    pos[3 * (5 + i)] = q[0], pos[3 * (5 + i) + 1] = q[1], pos[3 * (5 + i) + 2] = 0.2 * q[0] * q[1];
  }
  for (int v = 0; v < 10; v++) {
    uvs[2 * v] = 0.5 + 0.45 * pos[3 * v];
    uvs[2 * v + 1] = 0.5 + 0.45 * pos[3 * v + 1];
  }
  int c = 0;
  sizes[0] = 5;
  for (int i = 0; i < 5; i++) idx[c++] = i;
  for (int i = 0; i < 5; i++) {
    int p0 = i, p1 = (i + 1) % 5, q0 = 5 + i, q1 = 5 + (i + 1) % 5;
    sizes[1 + 2 * i] = 3;
    idx[c++] = p0, idx[c++] = q0, idx[c++] = p1;
    sizes[2 + 2 * i] = 3;
    idx[c++] = p1, idx[c++] = q0, idx[c++] = q1;
  }
  for (int i = 0; i < c; i++) cuv[i] = idx[i];
  make_mesh(m, 10, pos, 11, sizes, idx, uvs, 10, cuv);
}

/* A random point of the domain of face f. */
static void random_param(const ch_surface *S, int f, double st[2]) {
  int n = ch_surface_face_size(S, f);
  if (n == 4) {
    st[0] = ch_test_rnd(), st[1] = ch_test_rnd();
    return;
  }
  int k = (int)(ch_test_rnd() * n) % n;
  double c[2];
  ch_surface_corner_param(S, f, k, c);
  st[0] = c[0] + 0.5 * ch_test_rnd();
  st[1] = c[1] + 0.5 * ch_test_rnd();
}

static double dist3(const double a[3], const double b[3]) {
  return sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
              (a[2] - b[2]) * (a[2] - b[2]));
}

static ch_surface *surface_of(const ch_mesh *m, ch_scheme scheme) {
  ch_surface *S = NULL;
  ch_error err = {0};
  if (ch_surface_create(m, scheme, &S, &err) != CH_OK) fprintf(stderr, "%s\n", err.message);
  return S;
}

static const char *scheme_name(ch_scheme s) { return s == CH_SCHEME_CATMARK ? "catmark" : "bilinear"; }

/* ---- B and N on the plane ------------------------------------------------ */

static void test_plane(void) {
  ch_mesh m;
  REQUIRE(load_model("plane", &m));
  for (int sc = 0; sc < 2; sc++) {
    ch_surface *S = surface_of(&m, (ch_scheme)sc);
    REQUIRE(S);
    double maxp = 0, maxn = 0;
    for (int i = 0; i < 5000; i++) {
      int f = (int)(ch_test_rnd() * m.num_faces) % m.num_faces;
      double st[2];
      random_param(S, f, st);
      if (i < 200) st[i % 2] = (i / 2) % 2; /* on face edges too */
      ch_surface_point p;
      REQUIRE(ch_surface_eval(S, f, st[0], st[1], &p) == CH_OK);
      double e = fmax(fmax(fabs(p.position[0] - p.uv[0]), fabs(p.position[1] - p.uv[1])),
                      fabs(p.position[2]));
      double en = fmax(fmax(fabs(p.normal[0]), fabs(p.normal[1])), fabs(p.normal[2] - 1.0));
      maxp = fmax(maxp, e);
      maxn = fmax(maxn, en);
    }
    fprintf(stderr, "  plane %-8s max |B - (u,v,0)| = %.3g, max |N - z| = %.3g\n",
            scheme_name((ch_scheme)sc), maxp, maxn);
    CHECK(maxp <= 1e-12);
    CHECK(maxn <= 1e-12);
    ch_surface_destroy(S);
  }
  ch_mesh_free(&m);
}

/* ---- the documented bilinear weights of triangles and n-gons ------------- */

static void test_bilinear_weights(void) {
  ch_mesh m;
  make_fan(&m);
  ch_surface *S = surface_of(&m, CH_SCHEME_BILINEAR);
  REQUIRE(S);
  double maxe = 0;
  for (int i = 0; i < 3000; i++) {
    int f = (int)(ch_test_rnd() * m.num_faces) % m.num_faces;
    int n = m.face_start[f + 1] - m.face_start[f];
    int k = (int)(ch_test_rnd() * n) % n;
    double c[2], a = ch_test_rnd(), b = ch_test_rnd();
    ch_surface_corner_param(S, f, k, c);
    ch_surface_point p;
    REQUIRE(ch_surface_eval(S, f, c[0] + 0.5 * a, c[1] + 0.5 * b, &p) == CH_OK);
    double w[8];
    for (int j = 0; j < n; j++) w[j] = a * b / n;
    w[k] += (1 - a) * (1 - b) + a * (1 - b) / 2 + (1 - a) * b / 2;
    w[(k + 1) % n] += a * (1 - b) / 2;
    w[(k + n - 1) % n] += (1 - a) * b / 2;
    double P[3] = {0, 0, 0}, T[2] = {0, 0};
    for (int j = 0; j < n; j++) {
      int cc = m.face_start[f] + j;
      for (int d = 0; d < 3; d++) P[d] += w[j] * m.positions[3 * m.corner_position[cc] + d];
      for (int d = 0; d < 2; d++) T[d] += w[j] * m.uvs[2 * m.corner_uv[cc] + d];
    }
    maxe = fmax(maxe, dist3(P, p.position));
    maxe = fmax(maxe, fmax(fabs(T[0] - p.uv[0]), fabs(T[1] - p.uv[1])));
    /* A triangle is its plane: the weights are barycentric, so UV is affine. */
  }
  fprintf(stderr, "  fan: documented weights vs Bfr: max error %.3g\n", maxe);
  CHECK(maxe <= 1e-14);
  /* Corners and the face centre of the pentagon. */
  double st[2];
  ch_surface_point p;
  CHECK(ch_surface_corner_param(S, 0, 3, st) == CH_OK);
  CHECK(ch_surface_eval(S, 0, st[0], st[1], &p) == CH_OK);
  CHECK(dist3(p.position, &m.positions[9]) == 0.0);
  CHECK(ch_surface_edge_param(S, 0, 2, 0.5, st) == CH_OK);
  CHECK(ch_surface_eval(S, 0, st[0], st[1], &p) == CH_OK);
  double mid[3];
  for (int d = 0; d < 3; d++) mid[d] = 0.5 * (m.positions[6 + d] + m.positions[9 + d]);
  CHECK(dist3(p.position, mid) <= 1e-15);
  /* Outside the domain: the empty half of a tile, beyond the last tile. */
  CHECK(ch_surface_eval(S, 0, 0.75, 0.25, &p) == CH_ERR_INPUT);
  CHECK(ch_surface_eval(S, 0, 2.25, 1.25, &p) == CH_ERR_INPUT); /* pentagon: 5 tiles of 3x2 */
  CHECK(ch_surface_eval(S, 0, 1.25, 1.25, &p) == CH_OK);
  CHECK(ch_surface_eval(S, 1, 1.25, 1.25, &p) == CH_ERR_INPUT); /* triangle: 3 tiles of 2x2 */
  CHECK(ch_surface_eval(S, 1, 0.25, 1.25, &p) == CH_OK);
  CHECK(ch_surface_eval(S, 1, NAN, 0.2, &p) == CH_ERR_INPUT);
  CHECK(ch_surface_eval(S, 11, 0.2, 0.2, &p) == CH_ERR_INPUT);
  ch_surface_destroy(S);
  ch_mesh_free(&m);
}

/* ---- catmark cube: against Far's PatchTable and by hand ------------------ */

static void test_cube_catmark(void) {
  ch_mesh m;
  make_cube(&m);
  ch_surface *S = surface_of(&m, CH_SCHEME_CATMARK);
  REQUIRE(S);
  ref_catmark *ref = ref_catmark_create(8, cube_pos, 6, cube_sizes, cube_idx, 2);
  REQUIRE(ref);
  double ep = 0, ed = 0, en = 0;
  for (int i = 0; i < 3000; i++) {
    int f = (int)(ch_test_rnd() * 6) % 6;
    double s = ch_test_rnd(), t = ch_test_rnd();
    ch_surface_point p;
    double P[3], Ds[3], Dt[3], N[3];
    REQUIRE(ch_surface_eval(S, f, s, t, &p) == CH_OK);
    REQUIRE(ref_catmark_eval(ref, f, s, t, P, Ds, Dt) == 0);
    N[0] = Ds[1] * Dt[2] - Ds[2] * Dt[1];
    N[1] = Ds[2] * Dt[0] - Ds[0] * Dt[2];
    N[2] = Ds[0] * Dt[1] - Ds[1] * Dt[0];
    double l = sqrt(N[0] * N[0] + N[1] * N[1] + N[2] * N[2]);
    for (int d = 0; d < 3; d++) N[d] /= l;
    ep = fmax(ep, dist3(P, p.position));
    ed = fmax(ed, fmax(dist3(Ds, p.dpds), dist3(Dt, p.dpdt)));
    en = fmax(en, dist3(N, p.normal));
  }
  fprintf(stderr, "  cube: Bfr vs Far PatchTable: position %.3g, derivatives %.3g, normal %.3g\n",
          ep, ed, en);
  CHECK(ep <= 1e-12);
  CHECK(ed <= 1e-10);
  CHECK(en <= 1e-10);
  /* Valence-3 corner by hand: the Catmull-Clark limit of a vertex of
   * valence n is (n^2 p + 4 sum e_j + sum f_j) / (n (n + 5)), e_j its edge
   * neighbours, f_j the opposite corners of its faces. At the origin
   * (n = 3): e = (1,0,0), (0,1,0), (0,0,1); f = (1,1,0), (1,0,1), (0,1,1):
   * (0 + 4 (1,1,1) + (2,2,2)) / 24 = (1/4, 1/4, 1/4), and by symmetry the
   * normal is -(1,1,1)/sqrt(3). Every corner: 1/4 + p/2, normal (2p - 1)/sqrt 3. */
  double worst = 0, worstn = 0;
  for (int f = 0; f < 6; f++)
    for (int k = 0; k < 4; k++) {
      double st[2];
      ch_surface_point p;
      ch_surface_corner_param(S, f, k, st);
      REQUIRE(ch_surface_eval(S, f, st[0], st[1], &p) == CH_OK);
      const double *v = &cube_pos[3 * cube_idx[4 * f + k]];
      double want[3], wn[3];
      for (int d = 0; d < 3; d++) {
        want[d] = 0.25 + 0.5 * v[d];
        wn[d] = (2 * v[d] - 1) / sqrt(3.0);
      }
      worst = fmax(worst, dist3(want, p.position));
      worstn = fmax(worstn, dist3(wn, p.normal));
    }
  fprintf(stderr, "  cube corners vs hand limit: position %.3g, normal %.3g\n", worst, worstn);
  CHECK(worst <= 1e-14);
  CHECK(worstn <= 1e-12);
  ref_catmark_destroy(ref);
  ch_surface_destroy(S);
  ch_mesh_free(&m);
}

/* ch_surface shares one Bfr surface between the faces of a size where it
 * is linear and makes their patch points when evaluating: the values must
 * be those of a surface per face with stored patch points
 * (tests/tess_reference.cpp), bit for bit (P, derivatives, N, UV, and the
 * patches' corner UVs), on every bundled mesh, the cube and the n-gon fan,
 * both schemes. */
static int same_bits(const double *a, const double *b, int n) { return memcmp(a, b, (size_t)n * sizeof *a) == 0; }

static void shared_linear_surfaces(const char *name, const ch_mesh *m, ch_scheme scheme) {
  ch_surface *S = surface_of(m, scheme);
  ref_bfr *r = ref_bfr_create(m->num_positions, m->positions, m->num_uvs, m->uvs, m->num_faces, m->face_start,
                              m->corner_position, m->corner_uv, scheme == CH_SCHEME_CATMARK);
  CHECK(S && r);
  if (!S || !r) {
    ch_surface_destroy(S);
    ref_bfr_destroy(r);
    return;
  }
  long bad = 0, points = 0;
  for (int f = 0; f < m->num_faces; f++) {
    int n = ch_surface_face_size(S, f), np = 0;
    const double *corner_uvs = ch_surface_patch_uvs(S, f, &np);
    CHECK(corner_uvs && np == (n == 4 ? 1 : n));
    if (!corner_uvs) break;
    for (int k = 0; k < np; k++) {
      double origin[2] = {0, 0}, scale = 1.0;
      if (np > 1) {
        ch_surface_corner_param(S, f, k, origin);
        scale = 0.5;
      }
      static const double local[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
      for (int c = 0; c < 4 + 3; c++) { /* the patch's corners, then random points in it */
        double a = c < 4 ? local[c][0] : ch_test_rnd(), b = c < 4 ? local[c][1] : ch_test_rnd();
        double st[2] = {origin[0] + scale * a, origin[1] + scale * b};
        ch_surface_point p;
        double P[3], Ds[3], Dt[3], N[3] = {0, 0, 0}, uv[2];
        if (ch_surface_eval(S, f, st[0], st[1], &p) || ref_bfr_eval(r, f, st[0], st[1], P, Ds, Dt, N, uv)) {
          bad++;
          continue;
        }
        points++;
        int same = same_bits(p.position, P, 3) && same_bits(p.dpds, Ds, 3) && same_bits(p.dpdt, Dt, 3) &&
                   same_bits(p.uv, uv, 2);
        if (scheme == CH_SCHEME_BILINEAR && ch_normalize3(N)) same = same && same_bits(p.normal, N, 3);
        if (c < 4) same = same && same_bits(&corner_uvs[8 * k + 2 * c], uv, 2);
        bad += !same;
      }
    }
  }
  if (bad)
    fprintf(stderr, "  %s %s: %ld of %ld points differ from a surface per face\n", name, scheme_name(scheme), bad,
            points);
  CHECK(bad == 0 && points > 0);
  ch_surface_destroy(S);
  ref_bfr_destroy(r);
}

static void test_shared_linear_surfaces(void) {
  for (int s = 0; s < 2; s++) {
    ch_scheme scheme = s ? CH_SCHEME_CATMARK : CH_SCHEME_BILINEAR;
    for (int i = 0; i < NUM_MODELS; i++) {
      ch_mesh m;
      CHECK(load_model(models[i], &m));
      shared_linear_surfaces(models[i], &m, scheme);
      ch_mesh_free(&m);
    }
    ch_mesh cube, fan;
    make_cube(&cube);
    make_fan(&fan);
    shared_linear_surfaces("cube", &cube, scheme);
    shared_linear_surfaces("fan", &fan, scheme);
    ch_mesh_free(&cube);
    ch_mesh_free(&fan);
  }
}

/* ---- continuity across shared edges -------------------------------------- */

typedef struct half {
  uint64_t key; /* undirected edge */
  int face, k, forward;
} half;

static int cmp_half(const void *a, const void *b) {
  const half *x = a, *y = b;
  if (x->key != y->key) return x->key < y->key ? -1 : 1;
  return x->face != y->face ? (x->face < y->face ? -1 : 1) : x->k - y->k;
}

static half *mesh_halves(const ch_mesh *m) {
  half *h = xcalloc(m->num_corners, sizeof *h);
  for (int f = 0; f < m->num_faces; f++) {
    int a = m->face_start[f], n = m->face_start[f + 1] - a;
    for (int k = 0; k < n; k++) {
      uint64_t v0 = (uint64_t)m->corner_position[a + k];
      uint64_t v1 = (uint64_t)m->corner_position[a + (k + 1) % n];
      half *x = &h[a + k];
      x->key = v0 < v1 ? (v0 << 32 | v1) : (v1 << 32 | v0);
      x->face = f, x->k = k, x->forward = v0 < v1;
    }
  }
  qsort(h, m->num_corners, sizeof *h, cmp_half);
  return h;
}

static void continuity(const char *name, const ch_mesh *m, ch_scheme scheme) {
  ch_surface *S = surface_of(m, scheme);
  REQUIRE(S);
  half *h = mesh_halves(m);
  double ep = 0, en = 0;
  int edges = 0, seams = 0;
  static const double xs[] = {0.0, 0.13, 0.5, 0.77, 1.0};
  for (int i = 0; i + 1 < m->num_corners; i++) {
    if (h[i].key != h[i + 1].key) continue;
    const half *a = &h[i], *b = &h[i + 1];
    edges++;
    int ca = m->face_start[a->face] + a->k, cb = m->face_start[b->face] + b->k;
    int na = m->face_start[a->face + 1] - m->face_start[a->face];
    int nb = m->face_start[b->face + 1] - m->face_start[b->face];
    int uva0 = m->corner_uv[ca], uva1 = m->corner_uv[m->face_start[a->face] + (a->k + 1) % na];
    int uvb0 = m->corner_uv[cb], uvb1 = m->corner_uv[m->face_start[b->face] + (b->k + 1) % nb];
    if (!(uva0 == uvb1 && uva1 == uvb0) && !(uva0 == uvb0 && uva1 == uvb1)) seams++;
    for (int j = 0; j < 5; j++) {
      double x = xs[j], sa[2], sb[2];
      ch_surface_point pa, pb;
      ch_surface_edge_param(S, a->face, a->k, x, sa);
      ch_surface_edge_param(S, b->face, b->k, a->forward == b->forward ? x : 1.0 - x, sb);
      CHECK(ch_surface_eval(S, a->face, sa[0], sa[1], &pa) == CH_OK);
      CHECK(ch_surface_eval(S, b->face, sb[0], sb[1], &pb) == CH_OK);
      double qp[3], qn[3]; /* the position alone: the same bits */
      CHECK(ch_surface_eval_position(S, a->face, sa[0], sa[1], qp, qn) == CH_OK);
      CHECK(!memcmp(qp, pa.position, sizeof qp) && !memcmp(qn, pa.normal, sizeof qn));
      ep = fmax(ep, dist3(pa.position, pb.position));
      en = fmax(en, dist3(pa.normal, pb.normal));
    }
  }
  double tol_p = scheme == CH_SCHEME_BILINEAR ? 1e-12 : 1e-9;
  double tol_n = scheme == CH_SCHEME_BILINEAR ? 1e-12 : 1e-6;
  fprintf(stderr, "  %-8s %-8s %5d shared edges (%4d UV seams): max |dB| %.3g, max |dN| %.3g\n",
          name, scheme_name(scheme), edges, seams, ep, en);
  CHECK_MSG(ep <= tol_p, "%s %s position jump %g", name, scheme_name(scheme), ep);
  CHECK_MSG(en <= tol_n, "%s %s normal jump %g", name, scheme_name(scheme), en);
  if (!strcmp(name, "torus")) CHECK(seams == 48 + 24);
  free(h);
  ch_surface_destroy(S);
}

static void test_continuity(void) {
  for (int sc = 0; sc < 2; sc++) {
    for (int i = 0; i < NUM_MODELS; i++) {
      ch_mesh m;
      REQUIRE(load_model(models[i], &m));
      continuity(models[i], &m, (ch_scheme)sc);
      ch_mesh_free(&m);
    }
    ch_mesh m;
    make_cube(&m);
    continuity("cube", &m, (ch_scheme)sc);
    ch_mesh_free(&m);
    make_fan(&m);
    continuity("fan", &m, (ch_scheme)sc);
    ch_mesh_free(&m);
  }
}

/* ---- watertightness ------------------------------------------------------- */

static int cmp_u64(const void *a, const void *b) {
  uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
  return x < y ? -1 : x > y;
}

static const double *sort_pos;
static int cmp_pos(const void *a, const void *b) {
  const double *p = sort_pos + 3 * *(const int *)a, *q = sort_pos + 3 * *(const int *)b;
  for (int d = 0; d < 3; d++)
    if (p[d] != q[d]) return p[d] < q[d] ? -1 : 1;
  return 0;
}

/* The base edge an output vertex lies inside, -1 for base vertices and
 * interior points; *base the base position of a base vertex (else -1). */
static int classify(const ch_tess_result *r, const int *used, int nb, const long *edge_pt, long v,
                    int *base) {
  *base = -1;
  if (v < nb) {
    *base = used[v];
    return -1;
  }
  if (v >= nb + edge_pt[r->num_edges]) return -1;
  int lo = 0, hi = r->num_edges; /* edge_pt[lo] <= v - nb < edge_pt[hi] */
  while (hi - lo > 1) {
    int mid = (lo + hi) / 2;
    if (edge_pt[mid] <= v - nb)
      lo = mid;
    else
      hi = mid;
  }
  return lo;
}

/* Every check of the tessellation contract; returns the failures. */
static int check_tess(const char *what, const ch_mesh *base, const ch_surface *S,
                      const ch_tess_result *r, int closed) {
  int before = ch_test_failures;
  const ch_mesh *M = &r->mesh;
  const long nt = M->num_faces, nv = M->num_positions;
  /* Base edges: boundary (one face) or not, by position pair. */
  half *h = mesh_halves(base);
  uint64_t *bkeys = xcalloc(base->num_corners, sizeof *bkeys);
  int nbkeys = 0;
  for (int i = 0; i < base->num_corners; i++) {
    int prev = i > 0 && h[i - 1].key == h[i].key, next = i + 1 < base->num_corners && h[i + 1].key == h[i].key;
    if (!prev && !next) bkeys[nbkeys++] = h[i].key;
  }
  CHECK_MSG(!closed || nbkeys == 0, "%s: closed base mesh has %d boundary edges", what, nbkeys);
  /* Base vertex numbering: used positions in index order. */
  char *isused = xcalloc(base->num_positions, 1);
  for (int c = 0; c < base->num_corners; c++) isused[base->corner_position[c]] = 1;
  int *used = xcalloc(base->num_positions, sizeof *used), nb = 0;
  for (int v = 0; v < base->num_positions; v++)
    if (isused[v]) used[nb++] = v;
  long *edge_pt = xcalloc(r->num_edges + 1, sizeof *edge_pt);
  long boundary_rate = 0;
  qsort(bkeys, nbkeys, sizeof *bkeys, cmp_u64);
  for (int e = 0; e < r->num_edges; e++) {
    edge_pt[e + 1] = edge_pt[e] + r->edge_rates[e] - 1;
    uint64_t a = r->edge_vertices[2 * e], b = r->edge_vertices[2 * e + 1];
    uint64_t key = a < b ? (a << 32 | b) : (b << 32 | a);
    if (bsearch(&key, bkeys, nbkeys, sizeof key, cmp_u64)) boundary_rate += r->edge_rates[e];
  }

  /* Half-edges: directed (orientation) and undirected (use counts). */
  uint64_t *dir = xcalloc(3 * nt, sizeof *dir), *und = xcalloc(3 * nt, sizeof *und);
  for (long t = 0; t < nt; t++)
    for (int c = 0; c < 3; c++) {
      uint64_t a = (uint64_t)M->corner_position[3 * t + c];
      uint64_t b = (uint64_t)M->corner_position[3 * t + (c + 1) % 3];
      dir[3 * t + c] = a << 32 | b;
      und[3 * t + c] = a < b ? (a << 32 | b) : (b << 32 | a);
    }
  qsort(dir, 3 * nt, sizeof *dir, cmp_u64);
  qsort(und, 3 * nt, sizeof *und, cmp_u64);
  long dup_dir = 0, over = 0, once = 0, once_bad = 0;
  for (long i = 0; i + 1 < 3 * nt; i++) dup_dir += dir[i] == dir[i + 1];
  for (long i = 0; i < 3 * nt;) {
    long j = i;
    while (j < 3 * nt && und[j] == und[i]) j++;
    long uses = j - i;
    if (uses > 2) over++;
    if (uses == 1) {
      once++;
      /* Must lie along a base boundary edge. */
      long va = (long)(und[i] >> 32), vb = (long)(und[i] & 0xffffffffu);
      int ba, bb;
      int ea = classify(r, used, nb, edge_pt, va, &ba), eb = classify(r, used, nb, edge_pt, vb, &bb);
      int ok = 0;
      uint64_t key = 0;
      int e = ea >= 0 ? ea : eb;
      if (ea >= 0 && eb >= 0) {
        ok = ea == eb;
      } else if (e >= 0) {
        int bv = ea >= 0 ? bb : ba;
        ok = bv >= 0 && (r->edge_vertices[2 * e] == bv || r->edge_vertices[2 * e + 1] == bv);
      } else if (ba >= 0 && bb >= 0) {
        ok = 1;
        key = ba < bb ? ((uint64_t)ba << 32 | (uint64_t)bb) : ((uint64_t)bb << 32 | (uint64_t)ba);
      }
      if (ok && e >= 0) {
        uint64_t a = r->edge_vertices[2 * e], b = r->edge_vertices[2 * e + 1];
        key = a < b ? (a << 32 | b) : (b << 32 | a);
      }
      if (!ok || !bsearch(&key, bkeys, nbkeys, sizeof key, cmp_u64)) once_bad++;
    }
    i = j;
  }
  CHECK_MSG(dup_dir == 0, "%s: %ld directed edges used twice (orientation)", what, dup_dir);
  CHECK_MSG(over == 0, "%s: %ld edges used by more than two triangles", what, over);
  CHECK_MSG(once_bad == 0, "%s: %ld open edges not on the base boundary (cracks/T-junctions)", what,
            once_bad);
  CHECK_MSG(once == boundary_rate, "%s: %ld open edges, base boundary has %ld segments", what, once,
            boundary_rate);
  if (closed) CHECK_MSG(once == 0, "%s: closed mesh has %ld open edges", what, once);

  /* No two vertices at the same place (each point evaluated once). */
  int *order = xcalloc(nv, sizeof *order);
  for (long i = 0; i < nv; i++) order[i] = (int)i;
  sort_pos = M->positions;
  qsort(order, nv, sizeof *order, cmp_pos);
  long dup_pos = 0;
  for (long i = 0; i + 1 < nv; i++) dup_pos += cmp_pos(&order[i], &order[i + 1]) == 0;
  CHECK_MSG(dup_pos == 0, "%s: %ld duplicated positions", what, dup_pos);

  /* Every vertex is B and N at (vertex_face, vertex_st), to the bit. */
  long bad_eval = 0, bad_unit = 0;
  for (long v = 0; v < nv; v++) {
    ch_surface_point p;
    if (ch_surface_eval(S, r->vertex_face[v], r->vertex_st[2 * v], r->vertex_st[2 * v + 1], &p) ||
        memcmp(p.position, &M->positions[3 * v], sizeof p.position) ||
        memcmp(p.normal, &M->normals[3 * v], sizeof p.normal))
      bad_eval++;
    double l = sqrt(p.normal[0] * p.normal[0] + p.normal[1] * p.normal[1] + p.normal[2] * p.normal[2]);
    if (fabs(l - 1.0) > 1e-12) bad_unit++;
  }
  CHECK_MSG(bad_eval == 0, "%s: %ld vertices differ from ch_surface_eval", what, bad_eval);
  CHECK_MSG(bad_unit == 0, "%s: %ld normals not unit", what, bad_unit);

  /* Orientation against N; UV orientation and per-face UV area. */
  long flipped = 0, uv_flipped = 0, degenerate = 0, bad_uv = 0;
  double *uv_area = xcalloc(base->num_faces, sizeof *uv_area);
  for (long t = 0; t < nt; t++) {
    const int *c = &M->corner_position[3 * t];
    const double *p0 = &M->positions[3 * c[0]], *p1 = &M->positions[3 * c[1]], *p2 = &M->positions[3 * c[2]];
    double e1[3], e2[3], n[3], ns[3];
    for (int d = 0; d < 3; d++) {
      e1[d] = p1[d] - p0[d], e2[d] = p2[d] - p0[d];
      ns[d] = M->normals[3 * c[0] + d] + M->normals[3 * c[1] + d] + M->normals[3 * c[2] + d];
    }
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    double dot = n[0] * ns[0] + n[1] * ns[1] + n[2] * ns[2];
    if (n[0] == 0 && n[1] == 0 && n[2] == 0)
      degenerate++;
    else if (!(dot > 0))
      flipped++;
    const int *cu = &M->corner_uv[3 * t];
    const double *u0 = &M->uvs[2 * cu[0]], *u1 = &M->uvs[2 * cu[1]], *u2 = &M->uvs[2 * cu[2]];
    double a = 0.5 * ((u1[0] - u0[0]) * (u2[1] - u0[1]) - (u1[1] - u0[1]) * (u2[0] - u0[0]));
    if (a < -1e-15) uv_flipped++;
    int f = r->triangle_face[t];
    uv_area[f] += a;
    for (int k = 0; k < 3; k++) {
      if (r->vertex_face[c[k]] != f) continue;
      ch_surface_point p;
      ch_surface_eval(S, f, r->vertex_st[2 * c[k]], r->vertex_st[2 * c[k] + 1], &p);
      const double *u = &M->uvs[2 * cu[k]];
      if (fabs(p.uv[0] - u[0]) > 1e-12 || fabs(p.uv[1] - u[1]) > 1e-12) bad_uv++;
    }
  }
  double worst_area = 0;
  for (int f = 0; f < base->num_faces; f++) {
    int a = base->face_start[f], n = base->face_start[f + 1] - a;
    double area = 0;
    for (int k = 0; k < n; k++) {
      const double *p = &base->uvs[2 * base->corner_uv[a + k]];
      const double *q = &base->uvs[2 * base->corner_uv[a + (k + 1) % n]];
      area += 0.5 * (p[0] * q[1] - p[1] * q[0]);
    }
    worst_area = fmax(worst_area, fabs(area - uv_area[f]));
  }
  CHECK_MSG(degenerate == 0, "%s: %ld degenerate triangles", what, degenerate);
  CHECK_MSG(flipped == 0, "%s: %ld triangles facing against N", what, flipped);
  CHECK_MSG(uv_flipped == 0, "%s: %ld triangles flipped in UV", what, uv_flipped);
  CHECK_MSG(bad_uv == 0, "%s: %ld corner UVs differ from their face's evaluation", what, bad_uv);
  CHECK_MSG(worst_area <= 1e-12, "%s: UV area of a base face not covered exactly (%g)", what,
            worst_area);
  /* Bookkeeping. */
  CHECK(M->num_normals == M->num_positions && M->face_start[nt] == 3 * nt);
  CHECK(!memcmp(M->corner_normal, M->corner_position, 3 * nt * sizeof(int)));

  free(uv_area);
  free(order);
  free(dir);
  free(und);
  free(edge_pt);
  free(used);
  free(isused);
  free(bkeys);
  free(h);
  return ch_test_failures - before;
}

static void tess_one(const char *name, const ch_mesh *m, int closed, ch_scheme scheme,
                     ch_tess_desc desc) {
  ch_surface *S = surface_of(m, scheme);
  REQUIRE(S);
  ch_tess_result r;
  ch_error err = {0};
  ch_status st = ch_tess_build(S, &desc, &r, &err);
  CHECK_MSG(st == CH_OK, "%s: %s", name, err.message);
  if (st == CH_OK) {
    char what[256];
    snprintf(what, sizeof what, "%s %s rate %d target %ld (%d triangles)", name, scheme_name(scheme),
             desc.uniform_rate, desc.target_triangles, r.mesh.num_faces);
    int fails = check_tess(what, m, S, &r, closed);
    fprintf(stderr, "  %-60s %s\n", what, fails ? "FAILED" : "watertight");
  }
  ch_tess_free(&r);
  ch_surface_destroy(S);
}

static void test_watertight(void) {
  static const int rates[] = {1, 2, 3, 7};
  for (int i = 0; i < NUM_MODELS + 2; i++) {
    ch_mesh m;
    const char *name = i < NUM_MODELS ? models[i] : i == NUM_MODELS ? "cube" : "fan";
    int closed = i < NUM_MODELS ? model_closed[i] : i == NUM_MODELS;
    if (i < NUM_MODELS) {
      REQUIRE(load_model(name, &m));
    } else if (i == NUM_MODELS) {
      make_cube(&m);
    } else {
      make_fan(&m);
    }
    for (int sc = 0; sc < 2; sc++) {
      for (int k = 0; k < 4; k++)
        tess_one(name, &m, closed, (ch_scheme)sc, (ch_tess_desc){.uniform_rate = rates[k], .target_triangles = 0});
      tess_one(name, &m, closed, (ch_scheme)sc, (ch_tess_desc){.target_triangles = i < NUM_MODELS ? 30000 : 3000});
    }
    ch_mesh_free(&m);
  }
}

/* ---- --target-tris accuracy ------------------------------------------------ */

static void test_targets(void) {
  static const long targets[] = {130000, 520000, 2100000};
  const int ntargets = quick ? 2 : 3;
  for (int i = 0; i < NUM_MODELS; i++) {
    ch_mesh m;
    REQUIRE(load_model(models[i], &m));
    ch_surface *S = surface_of(&m, CH_SCHEME_BILINEAR);
    REQUIRE(S);
    { /* the count at rate 1 is the rate-1 tessellation's (the obelisk mixes triangles and quads) */
      ch_tess_result r;
      ch_error err = {0};
      REQUIRE(ch_tess_build(S, &(ch_tess_desc){.uniform_rate = 1}, &r, &err) == CH_OK);
      CHECK_MSG(ch_tess_fewest_triangles(S) == r.mesh.num_faces, "%s: %ld, rate 1 gave %d", models[i],
                ch_tess_fewest_triangles(S), r.mesh.num_faces);
      ch_tess_free(&r);
    }
    for (int k = 0; k < ntargets; k++) {
      ch_tess_result r;
      ch_error err = {0};
      ch_status st = ch_tess_build(S, &(ch_tess_desc){.target_triangles = targets[k]}, &r, &err);
      CHECK_MSG(st == CH_OK, "%s", err.message);
      if (st != CH_OK) continue;
      double rel = (r.mesh.num_faces - (double)targets[k]) / targets[k];
      int rmin = 1 << 30, rmax = 0;
      for (int e = 0; e < r.num_edges; e++) {
        if (r.edge_rates[e] < rmin) rmin = r.edge_rates[e];
        if (r.edge_rates[e] > rmax) rmax = r.edge_rates[e];
      }
      fprintf(stderr, "  %-8s target %8ld: %8d triangles (%+5.2f%%), edge rates %d..%d\n",
              models[i], targets[k], r.mesh.num_faces, 100 * rel, rmin, rmax);
      CHECK_MSG(fabs(rel) <= 0.05, "%s target %ld gave %d", models[i], targets[k], r.mesh.num_faces);
      if (k == 0) {
        char what[128];
        snprintf(what, sizeof what, "%s bilinear target %ld", models[i], targets[k]);
        check_tess(what, &m, S, &r, model_closed[i]);
      }
      ch_tess_free(&r);
    }
    ch_surface_destroy(S);
    ch_mesh_free(&m);
  }
}

/* The plane's edges all have one length, so its counts jump together
 * (512 r^2: 73728 at r = 12, 86528 at r = 13): 80000 needs some edges
 * raised on their own. */
static void test_target_between_steps(void) {
  ch_mesh m;
  REQUIRE(load_model("plane", &m));
  ch_surface *S = surface_of(&m, CH_SCHEME_CATMARK);
  REQUIRE(S);
  ch_tess_result r;
  REQUIRE(ch_tess_build(S, &(ch_tess_desc){.target_triangles = 80000}, &r, NULL) == CH_OK);
  int n12 = 0, n13 = 0;
  for (int e = 0; e < r.num_edges; e++) {
    n12 += r.edge_rates[e] == 12;
    n13 += r.edge_rates[e] == 13;
  }
  fprintf(stderr, "  plane target 80000: %d triangles, %d edges at 12, %d at 13\n", r.mesh.num_faces,
          n12, n13);
  CHECK(fabs(r.mesh.num_faces - 80000.0) <= 0.05 * 80000);
  CHECK(n12 > 0 && n13 > 0 && n12 + n13 == r.num_edges);
  check_tess("plane catmark target 80000", &m, S, &r, 0);
  ch_tess_free(&r);
  /* 84000 is within 5% of 86528 (r = 13 everywhere); asked for the
   * closest, some edges stay at 12 and the count lands within one edge's
   * step (a rate-13 edge adds 2 x 13 triangles to each of its two faces,
   * give or take the inner rates' rounding). */
  REQUIRE(ch_tess_build(S, &(ch_tess_desc){.target_triangles = 84000}, &r, NULL) == CH_OK);
  CHECK(r.mesh.num_faces == 86528);
  ch_tess_free(&r);
  REQUIRE(ch_tess_build(S, &(ch_tess_desc){.target_triangles = 84000, .closest = 1}, &r, NULL) == CH_OK);
  fprintf(stderr, "  plane target 84000, closest: %d triangles\n", r.mesh.num_faces);
  CHECK(fabs(r.mesh.num_faces - 84000.0) <= 4 * 26 + 4);
  check_tess("plane catmark target 84000 closest", &m, S, &r, 0);
  ch_tess_free(&r);
  ch_surface_destroy(S);
  ch_mesh_free(&m);
}

/* ---- corners' parameters ---------------------------------------------------- */

/* corner_st names, in each triangle's own face, the point its corner's
 * vertex was evaluated at in another face: evaluated there it gives the
 * vertex's position and the corner's UV (to rounding), and where the face
 * is the vertex's own it is vertex_st exactly. */
static void test_corner_st(void) {
  for (int i = 0; i < NUM_MODELS; i++)
    for (int sc = 0; sc < 2; sc++) {
      ch_mesh m;
      REQUIRE(load_model(models[i], &m));
      ch_surface *S = surface_of(&m, (ch_scheme)sc);
      REQUIRE(S);
      ch_tess_result r;
      REQUIRE(ch_tess_build(S, &(ch_tess_desc){.target_triangles = 20000, .corner_st = 1}, &r, NULL) == CH_OK);
      REQUIRE(r.corner_st);
      double worst_p = 0.0, worst_uv = 0.0, size = 0.0;
      long other = 0, own_differs = 0;
      for (int v = 0; v < r.mesh.num_positions; v++)
        for (int k = 0; k < 3; k++) size = fmax(size, fabs(r.mesh.positions[3 * (size_t)v + k]));
      for (int t = 0; t < r.mesh.num_faces; t++)
        for (int k = 0; k < 3; k++) {
          int c = 3 * t + k, v = r.mesh.corner_position[c], f = r.triangle_face[t];
          const double *st = &r.corner_st[2 * (size_t)c];
          ch_surface_point sp;
          REQUIRE(ch_surface_eval(S, f, st[0], st[1], &sp) == CH_OK);
          const double *p = &r.mesh.positions[3 * (size_t)v], *uv = &r.mesh.uvs[2 * (size_t)r.mesh.corner_uv[c]];
          for (int j = 0; j < 3; j++) worst_p = fmax(worst_p, fabs(sp.position[j] - p[j]));
          for (int j = 0; j < 2; j++) worst_uv = fmax(worst_uv, fabs(sp.uv[j] - uv[j]));
          if (r.vertex_face[v] != f)
            other++;
          else
            own_differs += st[0] != r.vertex_st[2 * (size_t)v] || st[1] != r.vertex_st[2 * (size_t)v + 1];
        }
      fprintf(stderr, "  %s %s: %ld corners in another face than their vertex's; position off by %.2g (size %.3g), UV by %.2g\n",
              models[i], sc ? "catmark" : "bilinear", other, worst_p, size, worst_uv);
      CHECK(i == 0 || other > 0); /* (the plane is one face) */
      CHECK(own_differs == 0);
      CHECK_MSG(worst_p <= 1e-12 * size && worst_uv <= 1e-12, "%s: position off by %g, UV by %g", models[i], worst_p,
                worst_uv);
      ch_tess_free(&r);
      ch_surface_destroy(S);
      ch_mesh_free(&m);
    }
}

/* ---- determinism with threads ---------------------------------------------- */

static int same_result(const ch_tess_result *a, const ch_tess_result *b) {
  const ch_mesh *x = &a->mesh, *y = &b->mesh;
  if (x->num_positions != y->num_positions || x->num_faces != y->num_faces ||
      x->num_uvs != y->num_uvs || a->num_edges != b->num_edges)
    return 0;
  return !memcmp(x->positions, y->positions, 3 * sizeof(double) * x->num_positions) &&
         !memcmp(x->normals, y->normals, 3 * sizeof(double) * x->num_positions) &&
         !memcmp(x->uvs, y->uvs, 2 * sizeof(double) * x->num_uvs) &&
         !memcmp(x->corner_position, y->corner_position, sizeof(int) * x->num_corners) &&
         !memcmp(x->corner_uv, y->corner_uv, sizeof(int) * x->num_corners) &&
         !memcmp(a->vertex_face, b->vertex_face, sizeof(int) * x->num_positions) &&
         !memcmp(a->vertex_st, b->vertex_st, 2 * sizeof(double) * x->num_positions) &&
         !memcmp(a->triangle_face, b->triangle_face, sizeof(int) * x->num_faces) &&
         (!a->corner_st) == (!b->corner_st) &&
         (!a->corner_st || !memcmp(a->corner_st, b->corner_st, 6 * sizeof(double) * x->num_faces)) &&
         !memcmp(a->edge_rates, b->edge_rates, sizeof(int) * a->num_edges);
}

static void test_threads(void) {
  static const char *names[] = {"torus", "vase"};
  int saved = omp_get_max_threads();
  for (int i = 0; i < 2; i++) {
    ch_mesh m;
    REQUIRE(load_model(names[i], &m));
    for (int sc = 0; sc < 2; sc++) {
      ch_surface *S = surface_of(&m, (ch_scheme)sc);
      REQUIRE(S);
      ch_tess_result r1, r2;
      ch_tess_desc d = {.target_triangles = 130000, .corner_st = 1};
      omp_set_num_threads(1);
      REQUIRE(ch_tess_build(S, &d, &r1, NULL) == CH_OK);
      omp_set_num_threads(2);
      REQUIRE(ch_tess_build(S, &d, &r2, NULL) == CH_OK);
      CHECK_MSG(same_result(&r1, &r2), "%s %s: 1 and 2 threads differ", names[i],
                scheme_name((ch_scheme)sc));
      ch_tess_free(&r1);
      ch_tess_free(&r2);
      ch_surface_destroy(S);
    }
    ch_mesh_free(&m);
  }
  omp_set_num_threads(saved);
}

/* ---- an OBJ to look at ----------------------------------------------------- */

static void test_write_obj(void) {
  ch_mesh m;
  REQUIRE(load_model("torus", &m));
  ch_surface *S = surface_of(&m, CH_SCHEME_CATMARK);
  REQUIRE(S);
  ch_tess_result r;
  REQUIRE(ch_tess_build(S, &(ch_tess_desc){.target_triangles = 20000}, &r, NULL) == CH_OK);
  const char *dir = getenv("TMPDIR");
  char path[1100];
  snprintf(path, sizeof path, "%s/tess_torus.obj", dir && *dir ? dir : "/tmp");
  ch_error err = {0};
  CHECK_MSG(ch_mesh_write_obj(path, &r.mesh, &err) == CH_OK, "%s", err.message);
  fprintf(stderr, "  wrote %s (%d triangles)\n", path, r.mesh.num_faces);
  ch_tess_free(&r);
  ch_surface_destroy(S);
  ch_mesh_free(&m);
}

/* ---- bad input ------------------------------------------------------------- */

static void test_bad_input(void) {
  ch_mesh m;
  make_cube(&m);
  ch_surface *S = NULL;
  ch_error err = {0};
  /* No UVs. */
  int *cuv = m.corner_uv;
  m.corner_uv = NULL;
  CHECK(ch_surface_create(&m, CH_SCHEME_BILINEAR, &S, &err) == CH_ERR_INPUT && S == NULL);
  CHECK(strstr(err.message, "texture") != NULL);
  m.corner_uv = cuv;
  /* Index out of range. */
  m.corner_position[5] = 8;
  CHECK(ch_surface_create(&m, CH_SCHEME_CATMARK, &S, &err) == CH_ERR_INPUT && S == NULL);
  m.corner_position[5] = cube_idx[5];
  CHECK(ch_surface_create(&m, (ch_scheme)7, &S, &err) == CH_ERR_INPUT);
  REQUIRE(ch_surface_create(&m, CH_SCHEME_CATMARK, &S, &err) == CH_OK);
  ch_tess_result r;
  CHECK(ch_tess_build(S, &(ch_tess_desc){.target_triangles = 0}, &r, &err) == CH_ERR_INPUT);
  CHECK(ch_tess_build(S, &(ch_tess_desc){.uniform_rate = 2, .target_triangles = 100}, &r, &err) == CH_ERR_INPUT);
  CHECK(ch_tess_build(S, &(ch_tess_desc){.uniform_rate = 40000, .target_triangles = 0}, &r, &err) == CH_ERR_INPUT);
  CHECK(ch_tess_build(S, &(ch_tess_desc){.uniform_rate = 32767, .target_triangles = 0}, &r, &err) ==
        CH_ERR_INPUT); /* 1.3e10 */
  CHECK(strstr(err.message, "maximum") != NULL);
  CHECK(ch_tess_build(S, &(ch_tess_desc){.target_triangles = 3}, &r, &err) == CH_ERR_INPUT); /* rate 1 gives 12 */
  CHECK(strstr(err.message, "below") != NULL);
  CHECK(ch_tess_build(S, &(ch_tess_desc){.target_triangles = 12}, &r, &err) == CH_OK && r.mesh.num_faces == 12);
  CHECK(ch_tess_fewest_triangles(S) == 12);
  ch_tess_free(&r);
  CHECK(ch_tess_build(S, &(ch_tess_desc){.target_triangles = 1L << 40}, &r, &err) == CH_ERR_INPUT);
  CHECK(r.mesh.positions == NULL && r.edge_rates == NULL);
  ch_surface_destroy(S);
  ch_surface_destroy(NULL);
  ch_tess_free(NULL);
  ch_mesh_free(&m);

  /* A position no face uses is not part of the output. */
  double pos9[27];
  memcpy(pos9, cube_pos, sizeof cube_pos);
  pos9[24] = pos9[25] = pos9[26] = 5.0;
  double uvs[8] = {0, 0, 1, 0, 1, 1, 0, 1};
  int cuv4[24];
  for (int c = 0; c < 24; c++) cuv4[c] = c % 4;
  make_mesh(&m, 9, pos9, 6, cube_sizes, cube_idx, uvs, 4, cuv4);
  for (int sc = 0; sc < 2; sc++) {
    REQUIRE(ch_surface_create(&m, (ch_scheme)sc, &S, &err) == CH_OK);
    REQUIRE(ch_tess_build(S, &(ch_tess_desc){.uniform_rate = 3}, &r, &err) == CH_OK);
    CHECK(r.mesh.num_positions == 8 + 12 * 2 + 6 * 4);
    CHECK(check_tess("cube with an unused position", &m, S, &r, 1) == 0);
    ch_tess_free(&r);
    ch_surface_destroy(S);
  }
  ch_mesh_free(&m);
}

/* usage: test_tess [--quick] [TEST...]: --quick skips the 2.1M targets;
 * names run only those tests. */
/* ---- the view-dependent warp (ch_tess_desc.warp) ---------------------------- */

/* A warp for a camera close above (0.25, 0.25) of the unit square, over the
 * surface's cage, with a curve there so that the need is not zero. */
static int warp_for(const ch_surface *S, const double camera[7], ch_warp *w, ch_curve_set *set) {
  static const char svg[] = "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 1 1'>"
                            "<path data-kind='groove' data-profile='v' data-width='0.01' data-depth='0.01' "
                            "d='M 0 0 L 1 1 M 0 1 L 1 0'/></svg>";
  ch_error err = {0};
  ch_camera cam;
  ch_tess_cage_arrays cage;
  if (ch_curves_parse_svg(svg, sizeof svg - 1, "test.svg", set, &err) || ch_camera_init(&cam, camera, &err) ||
      ch_tess_cage(S, 2L * 64 * 64, &cage, &err)) {
    fprintf(stderr, "  warp_for: %s\n", err.message);
    return 0;
  }
  ch_warp_cage c = {.num_triangles = cage.num_triangles, .uv = cage.uv, .position = cage.position};
  ch_warp_desc wd = {.intervals = 64};
  ch_status st = ch_warp_build(&cam, &c, set, &wd, w, &err);
  ch_tess_cage_free(&cage);
  if (st) fprintf(stderr, "  warp_for: %s\n", err.message);
  return st == CH_OK;
}

/* Every bundled mesh, both schemes, warped: still watertight, oriented, on
 * target; on the plane the points of every face the camera sees are a
 * regular grid in the mesh's metric (what the Coons blend gives when the
 * metric is separable over the face) and the triangles crowd where the
 * camera looks. */
static void test_warped(void) {
  static const double close_above[7] = {0.25, 0.2, 0.3, 0.25, 0.25, 0.0, 40.0};
  for (int i = 0; i < NUM_MODELS; i++) {
    ch_mesh m;
    REQUIRE(load_model(models[i], &m));
    for (int sc = 0; sc < 2; sc++) {
      ch_surface *S = surface_of(&m, (ch_scheme)sc);
      REQUIRE(S);
      /* the plane: close above (0.25, 0.25); the others: a close view of
       * their side from the front, half a diagonal away */
      double cam[7];
      memcpy(cam, close_above, sizeof cam);
      if (i > 0) {
        double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY}, diag = 0.0;
        for (int v = 0; v < m.num_positions; v++)
          for (int k = 0; k < 3; k++) {
            lo[k] = fmin(lo[k], m.positions[3 * v + k]);
            hi[k] = fmax(hi[k], m.positions[3 * v + k]);
          }
        for (int k = 0; k < 3; k++) diag += (hi[k] - lo[k]) * (hi[k] - lo[k]);
        diag = sqrt(diag);
        static const double dir[3] = {0.3, -0.8, 0.5};
        for (int k = 0; k < 3; k++) {
          cam[3 + k] = 0.5 * (lo[k] + hi[k]);
          cam[k] = cam[3 + k] + 0.6 * diag * dir[k];
        }
        cam[6] = 30.0;
      }
      ch_warp w;
      ch_curve_set set;
      REQUIRE(warp_for(S, cam, &w, &set));
      ch_tess_result r, flat;
      ch_error err = {0};
      ch_status st = ch_tess_build(S, &(ch_tess_desc){.target_triangles = 30000, .warp = &w}, &r, &err);
      CHECK_MSG(st == CH_OK, "%s: %s", models[i], err.message);
      if (st == CH_OK) {
        char what[256];
        snprintf(what, sizeof what, "%s %s warped target 30000 (%d triangles, max slopes %.2f %.2f)", models[i],
                 scheme_name((ch_scheme)sc), r.mesh.num_faces, w.stats.max_slope[0], w.stats.max_slope[1]);
        int fails = check_tess(what, &m, S, &r, model_closed[i]);
        fprintf(stderr, "  %-60s %s\n", what, fails ? "FAILED" : "watertight");
        CHECK(labs(r.mesh.num_faces - 30000L) <= 1500);
      }
      if (st == CH_OK && i == 0 && sc == 0) {
        /* plane: where the camera sees (the focus is 1 on the whole face)
         * the mesh's metric is separable, sqrt(W_u'(u) W_v'(v)), so where
         * opposite edges of a face have equal rates every point is at
         * k / rate of its face's span in that metric along each axis */
        double worst = 0.0;
        int checked = 0;
        for (int v = 0; v < r.mesh.num_positions; v++) {
          int f = r.vertex_face[v];
          double uv[2], c0[2], c2[2];
          ch_surface_eval_uv(S, f, r.vertex_st[2 * v], r.vertex_st[2 * v + 1], uv);
          ch_surface_eval_uv(S, f, 0.0, 0.0, c0);
          ch_surface_eval_uv(S, f, 1.0, 1.0, c2);
          int in_focus = 1;
          for (int y = 0; y < 8 && in_focus; y++)
            for (int x = 0; x < 8 && in_focus; x++) {
              double q[2] = {c0[0] + (x + 0.5) / 8 * (c2[0] - c0[0]), c0[1] + (y + 0.5) / 8 * (c2[1] - c0[1])}, sl[2];
              ch_warp_mesh_slopes(&w, q, sl);
              in_focus = sl[0] == sqrt(ch_warp_axis_slope(&w, 0, q[0]) * ch_warp_axis_slope(&w, 1, q[1]));
            }
          /* the face's rates along each axis, on its two sides */
          int rate[2][2] = {{0, 0}, {0, 0}};
          for (int e = 0; e < r.num_edges && in_focus; e++) {
            const double *pa = &r.mesh.positions[3 * r.edge_vertices[2 * e]];
            const double *pb = &r.mesh.positions[3 * r.edge_vertices[2 * e + 1]];
            for (int axis = 0; axis < 2; axis++)
              for (int side = 0; side < 2; side++) {
                double at = side ? c2[1 - axis] : c0[1 - axis];
                int along = fabs(pa[1 - axis] - at) < 1e-12 && fabs(pb[1 - axis] - at) < 1e-12;
                double lo = fmin(pa[axis], pb[axis]), hi = fmax(pa[axis], pb[axis]);
                if (along && fabs(lo - c0[axis]) < 1e-12 && fabs(hi - c2[axis]) < 1e-12)
                  rate[axis][side] = r.edge_rates[e];
              }
          }
          if (!in_focus || rate[0][0] != rate[0][1] || rate[1][0] != rate[1][1]) continue;
          checked++;
          for (int axis = 0; axis < 2; axis++) {
            double a[2] = {c0[0], c0[1]}, b[2] = {c0[0], c0[1]};
            b[axis] = c2[axis];
            double x = (uv[axis] - c0[axis]) / (c2[axis] - c0[axis]);
            double k = ch_warp_mesh_arc(&w, a, b, x) / ch_warp_mesh_arc(&w, a, b, 1.0) * rate[axis][0];
            worst = fmax(worst, fabs(k - round(k)));
          }
        }
        fprintf(stderr, "  plane warped: %d points where the camera sees, off the mesh's grid by at most %.3g of a step\n",
                checked, worst);
        CHECK(worst < 1e-6 && checked > r.mesh.num_positions / 10);
        /* density: the quarter the camera looks at holds more triangles */
        REQUIRE(ch_tess_build(S, &(ch_tess_desc){.target_triangles = 30000}, &flat, &err) == CH_OK);
        long near_w = 0, near_f = 0;
        for (int pass = 0; pass < 2; pass++) {
          const ch_mesh *M = pass ? &flat.mesh : &r.mesh;
          for (int t = 0; t < M->num_faces; t++) {
            const double *a = &M->uvs[2 * M->corner_uv[3 * t]];
            if (a[0] < 0.4 && a[1] < 0.4) *(pass ? &near_f : &near_w) += 1;
          }
        }
        fprintf(stderr, "  plane warped: %ld triangles in [0,0.4]^2 against %ld unwarped\n", near_w, near_f);
        /* and most of all of them: the mesh follows W only near the view,
         * not along the rows and columns through it */
        CHECK(near_w > 3 * near_f && near_w > 0.85 * r.mesh.num_faces);
        ch_tess_free(&flat);
      }
      ch_tess_free(&r);
      ch_warp_free(&w);
      ch_curves_free(&set);
      ch_surface_destroy(S);
    }
    ch_mesh_free(&m);
  }
}

static int want(int argc, char **argv, const char *name) {
  int any = 0;
  for (int i = 1; i < argc; i++) {
    if (argv[i][0] == '-') continue;
    any = 1;
    if (!strcmp(argv[i], name)) return 1;
  }
  return !any;
}

static double now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

#define RUN_IF(test)                                        \
  do {                                                      \
    if (want(argc, argv, #test)) {                          \
      double t0_ = now();                                   \
      RUN(test);                                            \
      fprintf(stderr, "  (%.2f s)\n", now() - t0_);          \
    }                                                       \
  } while (0)

int main(int argc, char **argv) {
  quick = argc > 1 && !strcmp(argv[1], "--quick");
  RUN_IF(test_plane);
  RUN_IF(test_bilinear_weights);
  RUN_IF(test_cube_catmark);
  RUN_IF(test_shared_linear_surfaces);
  RUN_IF(test_continuity);
  RUN_IF(test_watertight);
  RUN_IF(test_targets);
  RUN_IF(test_target_between_steps);
  RUN_IF(test_corner_st);
  RUN_IF(test_threads);
  RUN_IF(test_write_obj);
  RUN_IF(test_bad_input);
  RUN_IF(test_warped);
  TEST_MAIN_END();
}
