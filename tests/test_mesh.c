/* Tests of the mesh module: readers (OBJ, PLY, OFF, STL through OpenMesh),
 * validation statistics, and the OBJ/PLY writers. Inputs are in
 * tests/data/mesh; the expected values are worked out by hand in the
 * comments of those files. */
#define _POSIX_C_SOURCE 200809L
#include <fcntl.h>
#include <float.h>
#include <omp.h>
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "ch_mesh.h"
#include "ch_mesh_obj_internal.h"
#include "ch_mesh_scan.h"
#include "ch_test.h"

/* ---- helpers ------------------------------------------------------------ */

static const char *data_path(const char *name) {
  static char buf[4][1024];
  static int slot;
  char *p = buf[slot++ % 4];
  snprintf(p, 1024, "%s/mesh/%s", CHISEL_TEST_DATA, name);
  return p;
}

static char tmp_dir[1024];

static const char *tmp_path(const char *name) {
  static char buf[4][1100];
  static int slot;
  char *p = buf[slot++ % 4];
  snprintf(p, 1100, "%s/%s", tmp_dir, name);
  return p;
}

typedef struct warnings {
  int count;
  char text[4096];
} warnings;

static void collect(void *user, const char *msg) {
  warnings *w = user;
  w->count++;
  size_t n = strlen(w->text);
  snprintf(w->text + n, sizeof w->text - n, "%s\n", msg);
}

static ch_error new_error(warnings *w) {
  ch_error e;
  memset(&e, 0, sizeof e);
  if (w) {
    memset(w, 0, sizeof *w);
    e.warn = collect;
    e.warn_user = w;
  }
  return e;
}

static int mesh_is_zero(const ch_mesh *m) {
  ch_mesh z;
  memset(&z, 0, sizeof z);
  return memcmp(m, &z, sizeof z) == 0;
}

static int same_array(const void *a, const void *b, size_t bytes) {
  if (!a || !b) return a == b;
  return memcmp(a, b, bytes) == 0;
}

static int mesh_equal(const ch_mesh *a, const ch_mesh *b) {
  return a->num_positions == b->num_positions && a->num_faces == b->num_faces &&
         a->num_corners == b->num_corners && a->num_uvs == b->num_uvs &&
         a->num_normals == b->num_normals &&
         same_array(a->positions, b->positions, 3 * sizeof(double) * a->num_positions) &&
         same_array(a->face_start, b->face_start, sizeof(int) * (a->num_faces + 1)) &&
         same_array(a->corner_position, b->corner_position, sizeof(int) * a->num_corners) &&
         same_array(a->uvs, b->uvs, 2 * sizeof(double) * a->num_uvs) &&
         same_array(a->corner_uv, b->corner_uv, sizeof(int) * a->num_corners) &&
         same_array(a->normals, b->normals, 3 * sizeof(double) * a->num_normals) &&
         same_array(a->corner_normal, b->corner_normal, sizeof(int) * a->num_corners);
}

static char *slurp(const char *path, size_t *size) {
  FILE *fp = fopen(path, "rb");
  if (!fp) return NULL;
  fseek(fp, 0, SEEK_END);
  long n = ftell(fp);
  fseek(fp, 0, SEEK_SET);
  char *buf = malloc((size_t)n + 1);
  if (buf && fread(buf, 1, (size_t)n, fp) != (size_t)n) {
    free(buf);
    buf = NULL;
  }
  fclose(fp);
  if (buf) buf[n] = '\0';
  *size = (size_t)n;
  return buf;
}

static int files_equal(const char *a, const char *b) {
  size_t na, nb;
  char *da = slurp(a, &na), *db = slurp(b, &nb);
  int same = da && db && na == nb && memcmp(da, db, na) == 0;
  free(da);
  free(db);
  return same;
}

static const double *corner_pos(const ch_mesh *m, int c) {
  return &m->positions[3 * m->corner_position[c]];
}

static const double *corner_uv(const ch_mesh *m, int c) {
  return &m->uvs[2 * m->corner_uv[c]];
}

/* Reads name (under data/mesh) and expects success. */
static ch_status read_data(const char *name, ch_mesh *m, warnings *w) {
  ch_error err = new_error(w);
  ch_status st = ch_mesh_read(data_path(name), m, &err);
  CHECK_MSG(st == CH_OK, "%s: %s", name, err.message);
  return st;
}

/* Expects the read of name to fail with status and a message that is the
 * path, ": ", then `tail`, on one line. */
static void expect_read_error(const char *name, ch_status status, const char *tail) {
  ch_mesh m;
  ch_error err = new_error(NULL);
  const char *path = data_path(name);
  ch_status st = ch_mesh_read(path, &m, &err);
  CHECK_MSG(st == status, "%s: status %d (%s)", name, (int)st, err.message);
  CHECK(mesh_is_zero(&m));
  size_t n = strlen(path);
  CHECK_MSG(strncmp(err.message, path, n) == 0 && strncmp(err.message + n, ": ", 2) == 0,
            "%s: message '%s'", name, err.message);
  CHECK_MSG(strstr(err.message, tail) != NULL, "%s: message '%s' lacks '%s'", name, err.message, tail);
  CHECK(strchr(err.message, '\n') == NULL);
  ch_mesh_free(&m);
}

/* The same from a string, through ch_mesh_read_memory. */
static void expect_memory_error(const char *text, const char *format, const char *tail) {
  ch_mesh m;
  ch_error err = new_error(NULL);
  ch_status st = ch_mesh_read_memory(text, strlen(text), format, "mem", &m, &err);
  CHECK_MSG(st == CH_ERR_INPUT, "status %d for %s input (%s)", (int)st, format, err.message);
  CHECK_MSG(strstr(err.message, tail) != NULL, "message '%s' lacks '%s'", err.message, tail);
  CHECK(strncmp(err.message, "mem: ", 5) == 0);
  CHECK(mesh_is_zero(&m));
  ch_mesh_free(&m);
}

static ch_status validate(const ch_mesh *m, ch_mesh_report *r, warnings *w) {
  ch_error err = new_error(w);
  ch_status st = ch_mesh_validate(m, "test", r, &err);
  CHECK_MSG(st == CH_OK, "validate: %s", err.message);
  return st;
}

/* ---- readers ------------------------------------------------------------ */

static void test_plane_obj(void) {
  ch_mesh m;
  REQUIRE(read_data("plane.obj", &m, NULL) == CH_OK);
  CHECK(m.num_positions == 9 && m.num_faces == 4 && m.num_corners == 16);
  CHECK(m.num_uvs == 9 && m.num_normals == 1);
  /* Position 5 of the file is (1,1,0), position 9 is (2,2,0). */
  CHECK(m.positions[3 * 4] == 1.0 && m.positions[3 * 4 + 1] == 1.0 && m.positions[3 * 4 + 2] == 0.0);
  CHECK(m.positions[3 * 8] == 2.0 && m.positions[3 * 8 + 1] == 2.0);
  CHECK(m.face_start[0] == 0 && m.face_start[1] == 4 && m.face_start[4] == 16);
  /* The second face is "2 3 6 5". */
  CHECK(m.corner_position[4] == 1 && m.corner_position[5] == 2 && m.corner_position[6] == 5 &&
        m.corner_position[7] == 4);
  /* On this plane every corner's UV is its (x, y) halved. */
  int uv_ok = 1;
  for (int c = 0; c < m.num_corners; c++)
    uv_ok &= corner_uv(&m, c)[0] == corner_pos(&m, c)[0] / 2 &&
             corner_uv(&m, c)[1] == corner_pos(&m, c)[1] / 2;
  CHECK(uv_ok);
  /* Corners sharing a UV value share its index: position 5 has one UV. */
  CHECK(m.corner_uv[2] == m.corner_uv[7] && m.corner_uv[7] == m.corner_uv[9]);
  CHECK(m.normals[0] == 0 && m.normals[1] == 0 && m.normals[2] == 1);
  int normals_ok = 1;
  for (int c = 0; c < m.num_corners; c++) normals_ok &= m.corner_normal[c] == 0;
  CHECK(normals_ok);

  ch_mesh_report r;
  warnings w;
  REQUIRE(validate(&m, &r, &w) == CH_OK);
  CHECK(r.num_quads == 4 && r.num_triangles == 0 && r.num_polygons == 0);
  CHECK(r.bounds_min[0] == 0 && r.bounds_max[0] == 2 && r.bounds_max[1] == 2 && r.bounds_max[2] == 0);
  CHECK(r.uv_min[0] == 0 && r.uv_max[0] == 1 && r.uv_min[1] == 0 && r.uv_max[1] == 1);
  CHECK(r.num_uvs_outside == 0);
  CHECK(r.num_boundary_edges == 8 && r.num_nonmanifold_edges == 0);
  CHECK(r.num_nonmanifold_vertices == 0 && r.num_degenerate_faces == 0);
  CHECK(r.num_zero_uv_area_faces == 0);
  CHECK(r.num_components == 1 && r.num_charts == 1);
  CHECK_NEAR(r.uv_coverage, 1.0, 1e-3);
  CHECK(r.uv_overlap == 0.0);
  CHECK_MSG(w.count == 0, "%s", w.text);
  ch_mesh_free(&m);
  CHECK(mesh_is_zero(&m));
  ch_mesh_free(&m); /* safe twice */
}

static void test_cube_obj(void) {
  ch_mesh m;
  warnings rw;
  REQUIRE(read_data("cube.obj", &m, &rw) == CH_OK);
  CHECK_MSG(rw.count == 0, "%s", rw.text); /* missing cube.mtl/usemtl: silent */
  CHECK(m.num_positions == 8 && m.num_faces == 6 && m.num_corners == 24);
  CHECK(m.num_uvs == 18 && m.num_normals == 6);
  /* Face-varying normals survive: every corner of a face has its normal. */
  static const double face_normal[6][3] = {{0, -1, 0}, {1, 0, 0}, {0, 1, 0},
                                           {-1, 0, 0}, {0, 0, 1}, {0, 0, -1}};
  int normals_ok = 1;
  for (int f = 0; f < 6; f++)
    for (int c = m.face_start[f]; c < m.face_start[f + 1]; c++)
      normals_ok &= memcmp(&m.normals[3 * m.corner_normal[c]], face_normal[f], sizeof face_normal[f]) == 0;
  CHECK(normals_ok);
  /* The seam: position 1 is (0,0) in the front face and (1,0) in the left. */
  CHECK(m.corner_position[0] == 0 && corner_uv(&m, 0)[0] == 0.0 && corner_uv(&m, 0)[1] == 0.0);
  CHECK(m.corner_position[13] == 0 && corner_uv(&m, 13)[0] == 1.0 && corner_uv(&m, 13)[1] == 0.0);

  ch_mesh_report r;
  warnings w;
  REQUIRE(validate(&m, &r, &w) == CH_OK);
  CHECK(r.num_quads == 6);
  CHECK(r.num_boundary_edges == 0 && r.num_nonmanifold_edges == 0 && r.num_nonmanifold_vertices == 0);
  CHECK(r.num_components == 1);
  CHECK_MSG(r.num_charts == 3, "charts %d", r.num_charts);
  CHECK_NEAR(r.uv_coverage, 0.375, 1e-3);
  CHECK(r.uv_overlap == 0.0);
  CHECK_MSG(w.count == 0, "%s", w.text);
  ch_mesh_free(&m);
}

static void test_ply(void) {
  ch_mesh m;
  ch_mesh_report r;
  REQUIRE(read_data("plane.ply", &m, NULL) == CH_OK);
  CHECK(m.num_positions == 4 && m.num_faces == 2 && m.num_corners == 6 && m.num_uvs == 4);
  CHECK(m.positions[3 * 2] == 1 && m.positions[3 * 2 + 1] == 1 && m.positions[3 * 2 + 2] == 0);
  CHECK(m.normals == NULL && m.corner_normal == NULL);
  int uv_ok = 1; /* per-vertex UVs: u = x, v = y */
  for (int c = 0; c < m.num_corners; c++)
    uv_ok &= corner_uv(&m, c)[0] == corner_pos(&m, c)[0] && corner_uv(&m, c)[1] == corner_pos(&m, c)[1];
  CHECK(uv_ok);
  REQUIRE(validate(&m, &r, NULL) == CH_OK);
  CHECK(r.num_triangles == 2 && r.num_charts == 1 && r.num_boundary_edges == 4);
  CHECK_NEAR(r.uv_coverage, 1.0, 1e-3);
  CHECK(r.uv_overlap == 0.0);
  ch_mesh_free(&m);

  REQUIRE(read_data("plane_bin.ply", &m, NULL) == CH_OK);
  CHECK(m.num_positions == 4 && m.num_faces == 1 && m.num_corners == 4 && m.num_uvs == 4);
  /* One normal value, shared by every corner (values are deduplicated). */
  CHECK(m.num_normals == 1 && m.normals[2] == 1.0 && m.corner_normal[3] == 0);
  CHECK(m.positions[3 * 3 + 1] == 1.0 && m.uvs[2 * m.corner_uv[3] + 1] == 1.0);
  REQUIRE(validate(&m, &r, NULL) == CH_OK);
  CHECK(r.num_quads == 1);
  CHECK_NEAR(r.uv_coverage, 1.0, 1e-3);
  ch_mesh_free(&m);
}

/* A PLY keeps one UV per vertex, so exporters split every vertex on a UV
 * seam (Blender's PLY does): the reader welds equal coordinates back into
 * one position, so the cube is closed again and reads as cube.obj does. */
static void test_ply_welded(void) {
  ch_mesh a, b;
  warnings w;
  REQUIRE(read_data("cube.obj", &a, NULL) == CH_OK);
  REQUIRE(read_data("cube_split.ply", &b, &w) == CH_OK);
  CHECK_MSG(w.count == 0, "%s", w.text);
  CHECK_MSG(b.num_positions == 8 && b.num_faces == 6 && b.num_corners == 24 && b.num_uvs == 18,
            "%d positions, %d faces, %d corners, %d UVs", b.num_positions, b.num_faces, b.num_corners, b.num_uvs);
  /* the same position and UV at every corner (numbered in another order:
   * the PLY lists its vertices face by face), and corners share a number
   * where they share a position */
  int same = a.num_corners == b.num_corners;
  for (int c = 0; same && c < a.num_corners; c++) {
    same = memcmp(corner_pos(&a, c), corner_pos(&b, c), 3 * sizeof(double)) == 0 &&
           memcmp(corner_uv(&a, c), corner_uv(&b, c), 2 * sizeof(double)) == 0;
    for (int d = 0; d < c; d++)
      same &= (a.corner_position[c] == a.corner_position[d]) == (b.corner_position[c] == b.corner_position[d]);
  }
  CHECK(same);
  ch_mesh_report r;
  REQUIRE(validate(&b, &r, NULL) == CH_OK);
  CHECK(r.num_boundary_edges == 0 && r.num_nonmanifold_edges == 0 && r.num_components == 1 && r.num_charts == 3);
  ch_mesh_free(&a);
  ch_mesh_free(&b);

  /* -0 and 0 are one coordinate; a face whose corners weld into one
   * position twice is left out, with a warning */
  static const char two[] =
      "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n"
      "property float z\nproperty float s\nproperty float t\nelement face 2\n"
      "property list uchar int vertex_indices\nend_header\n"
      "0 0 0 0 0\n1 0 0 1 0\n1 1 0 1 1\n-0 0 0 0.5 0\n1 0 -0 0.5 1\n3 4 2 3\n3 0 3 2\n";
  ch_error err = new_error(&w);
  REQUIRE(ch_mesh_read_memory(two, sizeof two - 1, "ply", "two", &b, &err) == CH_OK);
  CHECK_MSG(b.num_positions == 3 && b.num_faces == 1 && b.num_corners == 3, "%d positions, %d faces", b.num_positions,
            b.num_faces);
  CHECK_MSG(w.count == 1 && strstr(w.text, "two: 1 face with two corners at one position") != NULL, "%s", w.text);
  ch_mesh_free(&b);
}

static void test_off(void) {
  ch_mesh m;
  ch_mesh_report r;
  REQUIRE(read_data("plane.off", &m, NULL) == CH_OK);
  CHECK(m.num_positions == 4 && m.num_faces == 2 && m.uvs == NULL && m.corner_uv == NULL);
  CHECK(m.positions[3 * 3 + 1] == 1.0);
  ch_error err = new_error(NULL);
  CHECK(ch_mesh_validate(&m, "plane.off", &r, &err) == CH_ERR_INPUT);
  CHECK(strcmp(err.message,
               "plane.off: mesh has no texture coordinates (UVs: vt in OBJ, TEXCOORD_0 in glTF); chisel needs UVs in [0,1]") == 0);
  ch_mesh_free(&m);

  /* STOFF: per-vertex texture coordinates (lost by OpenMesh's stream reader). */
  REQUIRE(read_data("plane_st.off", &m, NULL) == CH_OK);
  CHECK(m.num_positions == 4 && m.num_faces == 1 && m.num_uvs == 4);
  CHECK(m.positions[3 * 2] == 2.0 && corner_uv(&m, 2)[0] == 1.0 && corner_uv(&m, 2)[1] == 1.0);
  REQUIRE(validate(&m, &r, NULL) == CH_OK);
  CHECK_NEAR(r.uv_coverage, 1.0, 1e-3);
  ch_mesh_free(&m);

  /* From memory as well (goes through a temporary file). */
  size_t n;
  char *text = slurp(data_path("plane_st.off"), &n);
  REQUIRE(text);
  ch_error err2 = new_error(NULL);
  CHECK(ch_mesh_read_memory(text, n, "off", "st", &m, &err2) == CH_OK);
  CHECK(m.num_uvs == 4);
  ch_mesh_free(&m);
  free(text);
}

static void test_stl(void) {
  const char *names[] = {"square.stl", "square_bin.stl"};
  for (int i = 0; i < 2; i++) {
    ch_mesh m;
    REQUIRE(read_data(names[i], &m, NULL) == CH_OK);
    /* OpenMesh merges equal positions: 4 vertices, 2 triangles, no UVs. */
    CHECK_MSG(m.num_positions == 4 && m.num_faces == 2 && m.num_corners == 6, "%s", names[i]);
    CHECK(m.uvs == NULL);
    CHECK(m.positions[3 * 2] == 1.0 && m.positions[3 * 2 + 1] == 1.0);
    CHECK(m.corner_position[3] == 0 && m.corner_position[4] == 2 && m.corner_position[5] == 3);
    ch_mesh_free(&m);
  }
}

static void test_float_precision(void) {
  /* OpenMesh's readers hold coordinates in float. */
  const char *text = "v 0.1 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n";
  ch_mesh m;
  ch_error err = new_error(NULL);
  REQUIRE(ch_mesh_read_memory(text, strlen(text), "obj", "p", &m, &err) == CH_OK);
  CHECK(m.positions[0] == (double)0.1f);
  ch_mesh_free(&m);
}

/* ch_mesh_share_values against its definition: every corner gets its own
 * value back bit for bit, two corners share a number exactly when their
 * values have the same bits (+0 and -0 apart), and numbers appear in order
 * of first use; lists of one value per corner (idx NULL) and indexed ones,
 * large enough for the table to grow many times. */
static int share_sort_n;
static int share_cmp(const void *a, const void *b) { return memcmp(a, b, (size_t)share_sort_n * sizeof(double)); }

static void share_check(int n, const float *list, size_t listed, const int *idx, size_t corners) {
  double *values = NULL;
  int *corner = NULL, count = -1;
  CHECK(ch_mesh_share_values(n, list, listed, idx, corners, &values, &corner, &count) == 0);
  if (!values || !corner) return;
  int bad = 0, next = 0;
  /* the first corner of each number, to compare bits with */
  int *first = malloc((size_t)(count > 0 ? count : 1) * sizeof *first);
  for (size_t c = 0; c < corners && first; c++) {
    const float *v = &list[(size_t)(idx ? idx[c] : (int)c) * (size_t)n];
    int k = corner[c];
    if (k < 0 || k > next || k >= count) {
      bad++;
      continue;
    }
    if (k == next) first[next++] = (int)c;
    for (int i = 0; i < n; i++) {
      float back = (float)values[(size_t)k * (size_t)n + (size_t)i];
      bad += memcmp(&back, &v[i], sizeof back) != 0;
    }
  }
  CHECK(bad == 0 && next == count);
  /* distinct numbers, distinct bits: sorted by their bits, no two
   * neighbours alike */
  share_sort_n = n;
  qsort(values, (size_t)count, (size_t)n * sizeof *values, share_cmp);
  for (int a = 0; a + 1 < count; a++)
    bad +=
        memcmp(&values[(size_t)a * (size_t)n], &values[(size_t)(a + 1) * (size_t)n], (size_t)n * sizeof *values) == 0;
  CHECK(bad == 0);
  free(first);
  free(values);
  free(corner);
}

static void test_share_values(void) {
  enum { LISTED = 60000, CORNERS = 200000 };
  float *list = malloc(3 * LISTED * sizeof *list);
  int *idx = malloc(CORNERS * sizeof *idx);
  CHECK(list && idx);
  if (!list || !idx) return;
  /* values from a small alphabet (many repeats, +0 and -0 among them) */
  static const float alphabet[] = {0.0f, -0.0f, 1.0f, 0.5f, 1e-30f, -3.25f, 0.1f};
  for (int n = 2; n <= 3; n++) {
    for (int i = 0; i < n * LISTED; i++)
      list[i] = i % 7 == 0 ? (float)(ch_test_rnd() * 1000) : alphabet[(int)(ch_test_rnd() * 7) % 7];
    for (int c = 0; c < CORNERS; c++) idx[c] = (int)(ch_test_rnd() * LISTED) % LISTED;
    share_check(n, list, LISTED, idx, CORNERS);
    share_check(n, list, LISTED, NULL, LISTED);
    share_check(n, list, 5, NULL, 5);
  }
  /* +0 and -0 are two values */
  float zeros[4] = {0.0f, 0.0f, -0.0f, 0.0f};
  double *values = NULL;
  int *corner = NULL, count = 0;
  CHECK(ch_mesh_share_values(2, zeros, 2, NULL, 2, &values, &corner, &count) == 0 && count == 2);
  free(values);
  free(corner);
  free(list);
  free(idx);
}

/* The OBJ reader's numbers are strtof's (what OpenMesh's operator>> gives),
 * including where its fast path must step aside: decimals whose nearest
 * double is halfway between two floats but which are not (found by a search
 * with exact fractions), subnormals, more than 19 digits; and exact
 * halfway decimals (16777217, 8388608.5: ties to even), the top of the
 * float range. And OpenMesh's own
 * reading of the same file agrees. */
static void test_obj_floats_as_strtof(void) {
  static const char *fixed[] = {"16777217", "16777219", "8388608.5", "8388609.5", "-0", "0.1", "+.5", "5.", "1e-38",
                                "1e-45", "3.4028235e38", "-3.4028235e38", "123456789012345678901",
                                "0.000000000000000000000000000001234", "1E5", "-2.5e-3", "7e+22", "7e23",
                                /* their nearest double is halfway between two floats, they are not */
                                "4.077673673629761", "8.028053760528564", "1.90711909532547", "6.517818908691406e2",
                                "1.687670648097992"};
  enum { NFIXED = sizeof fixed / sizeof *fixed, N = 3 * 40000 };
  char(*tok)[48] = malloc(sizeof *tok * N);
  REQUIRE(tok);
  uint64_t state = 99;
  for (int i = 0; i < N; i++) {
    if (i < NFIXED) {
      snprintf(tok[i], sizeof tok[i], "%s", fixed[i]);
      continue;
    }
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    int digits = 1 + (int)((state >> 20) % 20), point = (int)((state >> 30) % (digits + 1)),
        form = (int)((state >> 40) % 4), e = (int)((state >> 45) % 61) - 30;
    if (e + point > 38) e = 38 - point; /* (within the float range) */
    char mant[32];
    uint64_t r = state;
    for (int k = 0; k < digits; k++) {
      r = r * 6364136223846793005ull + 1442695040888963407ull;
      mant[k] = (char)('0' + (r >> 33) % 10);
    }
    mant[digits] = '\0';
    const char *sign = (state >> 50) % 3 == 0 ? "-" : "";
    if (form == 0) /* an integer */
      snprintf(tok[i], sizeof tok[i], "%s%s", sign, mant);
    else if (form == 1) /* digits with a point */
      snprintf(tok[i], sizeof tok[i], "%s%.*s.%s", sign, point, mant, mant + point);
    else /* with an exponent */
      snprintf(tok[i], sizeof tok[i], "%s%.*s.%se%d", sign, point, mant, mant + point, e);
  }
  size_t cap = (size_t)N * 52 + 64, len = 0;
  char *text = malloc(cap);
  REQUIRE(text);
  for (int v = 0; v < N / 3; v++)
    len += (size_t)snprintf(text + len, cap - len, "v %s %s %s\n", tok[3 * v], tok[3 * v + 1], tok[3 * v + 2]);
  len += (size_t)snprintf(text + len, cap - len, "f 1 2 3\n");
  ch_mesh m, ref;
  ch_error err = new_error(NULL);
  CHECK_MSG(ch_mesh_read_memory(text, len, "obj", "floats.obj", &m, &err) == CH_OK, "%s", err.message);
  REQUIRE(err.status == CH_OK);
  REQUIRE(ch_mesh_read_obj_openmesh(text, len, "floats.obj", &ref, &err) == CH_OK);
  REQUIRE(m.num_positions == N / 3 && ref.num_positions == N / 3);
  int differ = 0, differ_om = 0;
  for (int i = 0; i < N; i++) {
    float want = strtof(tok[i], NULL);
    if (m.positions[i] != (double)want || !signbit(m.positions[i]) != !signbit(want)) {
      if (differ++ < 5) fprintf(stderr, "'%s': read %.9g, strtof %.9g\n", tok[i], m.positions[i], want);
    }
    differ_om += memcmp(&m.positions[i], &ref.positions[i], sizeof(double)) != 0;
  }
  CHECK_MSG(differ == 0, "%d of %d numbers are not strtof's", differ, N);
  CHECK_MSG(differ_om == 0, "%d of %d numbers differ from OpenMesh's", differ_om, N);
  CHECK(m.positions[0] == 16777216.0 && m.positions[1] == 16777220.0); /* ties to even */
  CHECK(m.positions[2] == 8388608.0 && m.positions[3] == 8388610.0);
  CHECK(signbit(m.positions[4]) && m.positions[4] == 0.0);
  CHECK(m.positions[10] == (double)FLT_MAX && m.positions[11] == -(double)FLT_MAX);
  ch_mesh_free(&m);
  ch_mesh_free(&ref);
  free(text);
  free(tok);
}

static void test_read_errors(void) {
  expect_read_error("index_range.obj", CH_ERR_INPUT,
                    "face 2 (line 10): position index 40 out of range (1..8)");
  expect_read_error("negative_index.obj", CH_ERR_INPUT,
                    "face 2 (line 8): position index -10 reaches before the first one (3 defined so far)");
  expect_read_error("nan.obj", CH_ERR_INPUT, "vertex 3 (line 3): 'nan' is not a finite number");
  expect_read_error("two_corners.obj", CH_ERR_INPUT, "face 2 (line 8): 2 corners, a face needs at least 3");
  expect_read_error("vt_range.obj", CH_ERR_INPUT, "face 1 (line 7): texture index 9 out of range (1..3)");
  expect_read_error("empty.obj", CH_ERR_INPUT, "file is empty");
  expect_read_error("garbage.obj", CH_ERR_INPUT, "not a text OBJ file");
  expect_read_error("garbage.ply", CH_ERR_INPUT, "not a PLY file");
  expect_read_error("truncated.ply", CH_ERR_INPUT, "vertex 2 of 4: data ends here");
  expect_read_error("comment_before_end.ply", CH_ERR_INPUT, "misplaces binary data");
  expect_read_error("no_end_header.ply", CH_ERR_INPUT, "no end_header");
  expect_read_error("face_colors.off", CH_ERR_INPUT, "face 0 (line 6): values after the 3 indices");
  expect_read_error("does_not_exist.obj", CH_ERR_IO, "cannot open");
  expect_read_error("model.dae", CH_ERR_INPUT,
                    "unknown mesh format '.dae' (accepted: .obj, .ply, .off, .stl, .glb, .gltf)");

  ch_mesh m;
  ch_error err = new_error(NULL);
  CHECK(ch_mesh_read_memory("v 0 0 0\n", 8, "3ds", "x", &m, &err) == CH_ERR_INPUT);
  CHECK(strstr(err.message, "unknown mesh format '3ds'") != NULL);
}

/* Inputs that OpenMesh itself crashes on, hangs on or misreads. */
static void test_hostile_inputs(void) {
  const char *tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n";
  char buf[512];
  snprintf(buf, sizeof buf, "%sf /1 2/2 3/3\n", tri); /* back() of an empty vector */
  expect_memory_error(buf, "obj", "cannot read corner '/1'");
  snprintf(buf, sizeof buf, "%sf 0/1 1/2 2/3\n", tri);
  expect_memory_error(buf, "obj", "position index 0 is invalid (OBJ indices start at 1)");
  snprintf(buf, sizeof buf, "%sf 1/1 2/2 3/3 2/2\n", tri); /* OpenMesh drops the corner */
  expect_memory_error(buf, "obj", "position 2 appears twice");
  snprintf(buf, sizeof buf, "%sf 1/1 2 3/3\n", tri);
  expect_memory_error(buf, "obj", "2 of its 3 corners have texture coordinates");
  snprintf(buf, sizeof buf, "%sf 1 2 x3\n", tri);
  expect_memory_error(buf, "obj", "cannot read corner 'x3'");
  expect_memory_error("v 1e39 0 0\n", "obj", "vertex 1 (line 1): '1e39' is not a finite number");
  expect_memory_error("v 1 2\n", "obj", "needs three coordinates");
  expect_memory_error("vt 0.5\n", "obj", "texture coordinate 1 (line 1): needs two values u v");
  expect_memory_error("vn 0 0 inf\n", "obj", "normal 1 (line 1): 'inf' is not a finite number");

  expect_memory_error("ply\nformat ascii 1.0\nelement vertex abc\nproperty float x\nend_header\n",
                      "ply", "element vertex needs a count");
  expect_memory_error("ply\nformat ascii 1.0\nproperty float x\nelement vertex 1\nend_header\n1\n",
                      "ply", "property before the first element");
  expect_memory_error("ply\nformat ascii x.y\nend_header\n", "ply", "bad format version");
  expect_memory_error("ply\nformat ascii 1\nend_header\n", "ply", "PLY: no vertex element");
  expect_memory_error("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                      "property float z\nelement face 1\nproperty list uint int vertex_indices\n"
                      "end_header\n",
                      "ply", "list count type 'uint'");
  expect_memory_error("ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\n"
                      "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
                      "3 0 1 2\n0 0 0\n1 0 0\n0 1 0\n",
                      "ply", "face element comes before the vertex element");
  expect_memory_error("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                      "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                      "property list uchar float texcoord\nend_header\n0 0 0\n1 0 0\n0 1 0\n"
                      "3 0 1 2 4 0 0 1 0\n",
                      "ply", "face 0: 4 texcoord values for 3 corners (want 2 per corner)");
  expect_memory_error("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                      "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                      "property list uchar float texcoords\nend_header\n0 0 0\n1 0 0\n0 1 0\n"
                      "3 0 1 2 6 0 0 1 0 0 1\n",
                      "ply", "list property 'texcoords' of element face is not supported");
  expect_memory_error("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                      "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                      "end_header\n0 0 0\n1 0 0\n0 1 nan\n3 0 1 2\n",
                      "ply", "vertex 2: property z: 'nan' is not a finite number");
  expect_memory_error("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                      "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                      "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n",
                      "ply", "face 0: vertex index 7 out of range (0..2)");
  expect_memory_error("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                      "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                      "end_header\n0 0 0\n1 0 0\n0 1 0\n4000000000 0 1 2\n",
                      "ply", "bad corner count");
  {
    /* A binary face claiming 2^30 corners (OpenMesh would push them all). */
    static const char hdr[] =
        "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nelement face 1\nproperty list int int vertex_indices\nend_header\n";
    unsigned char bin[sizeof hdr - 1 + 36 + 4 + 12];
    memset(bin, 0, sizeof bin);
    memcpy(bin, hdr, sizeof hdr - 1);
    unsigned char *count = bin + sizeof hdr - 1 + 36;
    count[3] = 0x40;
    ch_mesh m;
    ch_error err = new_error(NULL);
    CHECK(ch_mesh_read_memory(bin, sizeof bin, "ply", "big", &m, &err) == CH_ERR_INPUT);
    CHECK_MSG(strstr(err.message, "face 0 of 1: data ends here") != NULL, "%s", err.message);
  }
  expect_memory_error("OFF BINARY\n", "off", "binary OFF is not supported");
  expect_memory_error("OFF\n# comment\n3 1 0\n", "off", "does not accept comments");
  expect_memory_error("OFF\n3 1 0\n0 0 0\n1 0 0\n", "off", "vertex 2 of 3: data ends here");
  expect_memory_error("COFF\n3 1 0\n", "off", "OFF header 'COFF' is not supported");
  expect_memory_error("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
                      "vertex nan 1 0\nendloop\nendfacet\nendsolid\n",
                      "stl", "facet 0 (line 6): expected 'vertex x y z'");
}

/* The scanners on their own (ch_mesh_scan.h): the counts they promise, the
 * stripped PLY copy, and messages without a file name. */
static void test_scanners(void) {
  ch_mesh_scan s;
  ch_error err = new_error(NULL);
  const char obj[] = "mtllib x.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvn 0 0 1\n"
                     "f 1 2 3\nf -1 -3 -2\n";
  REQUIRE(ch_mesh_scan_obj(obj, sizeof obj - 1, &s, &err) == CH_OK);
  CHECK(s.num_vertices == 4 && s.num_texcoords == 1 && s.num_normals == 1);
  CHECK(s.num_faces == 2 && s.num_corners == 6);
  CHECK(s.num_mtllib == 1 && s.mtllib_at[0] == 0);
  ch_mesh_scan_free(&s);
  CHECK(s.mtllib_at == NULL && s.num_vertices == 0);

  /* face texcoords: kept, and the list stripped from the copy for OpenMesh */
  const char ply[] = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                     "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                     "property list uchar float texcoord\nend_header\n0 0 0\n1 0 0\n0 1 0\n"
                     "3 2 0 1 6 0.5 0.25 0 0 1 0\n";
  REQUIRE(ch_mesh_scan_ply(ply, sizeof ply - 1, &s, &err) == CH_OK);
  CHECK(s.num_vertices == 3 && s.num_faces == 1 && s.num_corners == 3 && !s.binary && s.face_tex);
  CHECK(s.num_tex == 6 && s.tex[0] == 0.5f && s.tex[1] == 0.25f && s.tex[4] == 1.0f);
  CHECK(s.num_tex_first == 1 && s.tex_first[0] == 2);
  const char want[] = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                      "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                      "end_header\n0 0 0\n1 0 0\n0 1 0\n3 2 0 1\n";
  CHECK_MSG(s.stripped_size == sizeof want - 1 && memcmp(s.stripped, want, sizeof want - 1) == 0, "%.*s",
            (int)s.stripped_size, s.stripped);
  ch_mesh_scan_free(&s);

  const char off[] = "STNOFF\n3 1 0\n0 0 0 0 0 1 0 0\n1 0 0 0 0 1 1 0\n0 1 0 0 0 1 0 1\n3 0 1 2\n";
  REQUIRE(ch_mesh_scan_off(off, sizeof off - 1, &s, &err) == CH_OK);
  CHECK(s.num_vertices == 3 && s.num_faces == 1 && s.num_corners == 3);
  ch_mesh_scan_free(&s);

  const char stl[] = "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
                     "endloop\nendfacet\nendsolid\n";
  REQUIRE(ch_mesh_scan_stl(stl, sizeof stl - 1, &s, &err) == CH_OK);
  CHECK(!s.binary && s.triangles == 1);
  ch_mesh_scan_free(&s);
  unsigned char bin[84 + 2 * 50] = {0};
  bin[80] = 2;
  REQUIRE(ch_mesh_scan_stl((const char *)bin, sizeof bin, &s, &err) == CH_OK);
  CHECK(s.binary && s.triangles == 2);
  ch_mesh_scan_free(&s);

  /* the message names the element, not the file (the reader adds that) */
  const char bad[] = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n";
  CHECK(ch_mesh_scan_obj(bad, sizeof bad - 1, &s, &err) == CH_ERR_INPUT);
  CHECK_MSG(strcmp(err.message, "face 1 (line 4): position index 4 out of range (1..3)") == 0, "%s", err.message);
  ch_mesh_scan_free(&s);
}

/* `mtllib` is neutralised: OpenMesh would open any path it names. */
static void test_mtllib_ignored(void) {
  const char *text = "mtllib /dev/zero\nmtllib ../../../../../../../../dev/stdin\n"
                     "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl x\nf 1/1 2/2 3/3\n";
  ch_mesh m;
  ch_error err = new_error(NULL);
  CHECK(ch_mesh_read_memory(text, strlen(text), "obj", "mtl", &m, &err) == CH_OK);
  CHECK(m.num_faces == 1);
  ch_mesh_free(&m);
}

/* OpenMesh prints to std::cerr; none of it may reach the process's stderr. */
static void test_silence(void) {
  fflush(stderr);
  int saved = dup(2);
  const char *log = tmp_path("stderr.txt");
  int fd = open(log, O_WRONLY | O_CREAT | O_TRUNC, 0644);
  REQUIRE(saved >= 0 && fd >= 0);
  dup2(fd, 2);
  close(fd);
  ch_mesh m;
  ch_error err = new_error(NULL);
  ch_mesh_read(data_path("cube.obj"), &m, &err); /* usemtl of an unknown material */
  ch_mesh_free(&m);
  ch_mesh_read(data_path("garbage.ply"), &m, &err);
  ch_mesh_read(data_path("square_bin.stl"), &m, &err);
  ch_mesh_free(&m);
  fflush(stderr);
  dup2(saved, 2);
  close(saved);
  size_t n = 0;
  char *text = slurp(log, &n);
  CHECK_MSG(text && n == 0, "stderr got: %.200s", text ? text : "(unreadable)");
  free(text);
}

/* Every prefix of valid files: a clean status, never a crash or leak. */
static void test_truncations(void) {
  const char *names[] = {"cube.obj", "plane.ply", "plane_bin.ply", "plane_st.off", "square_bin.stl"};
  const char *formats[] = {"obj", "ply", "ply", "off", "stl"};
  for (int i = 0; i < 5; i++) {
    size_t n;
    char *text = slurp(data_path(names[i]), &n);
    REQUIRE(text);
    int bad = 0, ok = 0;
    for (size_t k = 0; k <= n; k++) {
      ch_mesh m;
      ch_error err = new_error(NULL);
      ch_status st = ch_mesh_read_memory(text, k, formats[i], names[i], &m, &err);
      if (st == CH_OK) {
        ok++;
        ch_mesh_report r;
        ch_error verr = new_error(NULL);
        ch_status vs = ch_mesh_validate(&m, names[i], &r, &verr);
        if (vs != CH_OK && vs != CH_ERR_INPUT) bad++;
      } else if (st != CH_ERR_INPUT || !mesh_is_zero(&m)) {
        bad++;
      }
      ch_mesh_free(&m);
    }
    CHECK_MSG(bad == 0, "%s: %d prefixes gave an unexpected status", names[i], bad);
    CHECK(ok >= 1); /* at least the whole file */
    free(text);
  }
}

/* ---- validation of meshes built in memory ------------------------------- */

typedef struct small_mesh {
  ch_mesh m;
  double pos[3 * 16], uv[2 * 16];
  int start[9], cpos[32], cuv[32];
} small_mesh;

/* Faces given as position index lists of length 3 or 4 (-1 ends a face of
 * 3); UVs per position unless uv_per_corner. */
static void make_mesh(small_mesh *s, int npos, const double *pos, const double *uv, int nfaces,
                      const int (*faces)[4]) {
  memset(s, 0, sizeof *s);
  memcpy(s->pos, pos, sizeof(double) * 3 * npos);
  memcpy(s->uv, uv, sizeof(double) * 2 * npos);
  int c = 0;
  for (int f = 0; f < nfaces; f++) {
    s->start[f] = c;
    for (int k = 0; k < 4 && faces[f][k] >= 0; k++) {
      s->cpos[c] = faces[f][k];
      s->cuv[c] = faces[f][k];
      c++;
    }
  }
  s->start[nfaces] = c;
  s->m.num_positions = npos;
  s->m.positions = s->pos;
  s->m.num_faces = nfaces;
  s->m.face_start = s->start;
  s->m.num_corners = c;
  s->m.corner_position = s->cpos;
  s->m.num_uvs = npos;
  s->m.uvs = s->uv;
  s->m.corner_uv = s->cuv;
}

/* Zero-length edges: a sliver between two coincident vertices collapses
 * away and leaves the clean quad; where the endpoints share a neighbour
 * off the edge (the collapse would pinch the mesh) nothing changes. */
static void test_collapse_short_edges(void) {
  /* 0 (0,0) 1 (1,0) 2 (1,1) 3 (0,1), 4 = 1 again; the sliver 1-4-3. */
  static const double pos[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 1, 0, 0};
  static const double uv[] = {0, 0, 1, 0, 1, 1, 0, 1, 1, 0};
  static const int faces[][4] = {{0, 1, 3, -1}, {1, 4, 3, -1}, {4, 2, 3, -1}};
  small_mesh s;
  make_mesh(&s, 5, pos, uv, 3, faces);
  CHECK(ch_mesh_collapse_short_edges(&s.m, 1e-12) == 1);
  CHECK(s.m.num_faces == 2 && s.m.num_positions == 4 && s.m.num_corners == 6);
  int want[6] = {0, 1, 3, 1, 2, 3}, same = 1;
  for (int c = 0; c < 6; c++) same &= s.m.corner_position[c] == want[c];
  CHECK_MSG(same, "collapsed faces %d %d %d / %d %d %d", s.m.corner_position[0], s.m.corner_position[1],
            s.m.corner_position[2], s.m.corner_position[3], s.m.corner_position[4], s.m.corner_position[5]);
  CHECK(s.m.corner_uv[3] == 4 && s.m.corner_uv[4] == 2); /* corners keep their UVs */
  /* 1 and 4 coincide and share the edge 1-4 (opposite 3) but also the
   * neighbour 5, off the edge: collapsing would join two sheets at 5. */
  static const double pos2[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 1, 0, 0, 2, 0, 0, 2, -1, 0, 1, -1, 0};
  static const double uv2[] = {0, 0, 1, 0, 1, 1, 0, 1, 1, 0, 1, 0, 1, 0, 1, 0};
  static const int faces2[][4] = {{0, 1, 3, -1}, {1, 4, 3, -1}, {4, 2, 3, -1}, {1, 6, 5, -1}, {4, 5, 7, -1}};
  make_mesh(&s, 8, pos2, uv2, 5, faces2);
  CHECK(ch_mesh_collapse_short_edges(&s.m, 1e-12) == 0);
  CHECK(s.m.num_faces == 5 && s.m.num_positions == 8);
}

/* Whether the mesh's faces are these position triples (each in any
 * rotation, in this order). */
static int faces_are(const ch_mesh *m, int n, const int (*want)[3]) {
  if (m->num_faces != n) return 0;
  for (int f = 0; f < n; f++) {
    const int *c = &m->corner_position[3 * f];
    int rot = 0;
    for (int r = 0; r < 3; r++) rot |= c[r] == want[f][0] && c[(r + 1) % 3] == want[f][1] && c[(r + 2) % 3] == want[f][2];
    if (!rot) return 0;
  }
  return 1;
}

/* Copies of a vertex left where several lines pass through it: a copy of
 * valence 3 inside a triangle of the original (two zero-area faces) goes
 * (the link condition allows it: only its own link holds the far edge);
 * a second copy inside a triangle of the first goes too, through the edge
 * that joins it to the original only once the first is gone. */
static void test_collapse_vertex_copies(void) {
  /* 0 (0,0) 1 (1,0) 2 (1,1) 3 (0,1); 4 and 5 at 0. */
  static const double pos[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0};
  static const double uv[] = {0, 0, 1, 0, 1, 1, 0, 1, 0, 0, 0, 0};
  static const int faces[][4] = {{0, 1, 4, -1}, {1, 2, 4, -1}, {2, 0, 4, -1}, {0, 2, 3, -1}};
  static const int want[][3] = {{1, 2, 0}, {0, 2, 3}};
  small_mesh s;
  make_mesh(&s, 5, pos, uv, 4, faces);
  CHECK(ch_mesh_collapse_short_edges(&s.m, 1e-12) == 1);
  CHECK(s.m.num_positions == 4 && faces_are(&s.m, 2, want));
  static const int faces2[][4] = {{0, 1, 4, -1}, {2, 0, 4, -1}, {4, 1, 5, -1}, {1, 2, 5, -1}, {2, 4, 5, -1}, {0, 2, 3, -1}};
  make_mesh(&s, 6, pos, uv, 6, faces2);
  CHECK(ch_mesh_collapse_short_edges(&s.m, 1e-12) == 2);
  CHECK_MSG(s.m.num_positions == 4 && faces_are(&s.m, 2, want), "%d faces, %d positions", s.m.num_faces,
            s.m.num_positions);
}

/* A flap (a triangle and its reverse) hanging off the diagonal of a quad
 * goes, leaving the quad, and its own vertex with it (a loose vertex in
 * the OBJ otherwise); a reversed copy of one of the quad's own triangles
 * stays (removing both would open a hole). */
static void test_remove_pillows(void) {
  static const double pos[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0.5, 0.5, 1};
  static const double uv[] = {0, 0, 1, 0, 1, 1, 0, 1, 0.5, 0.5};
  static const int faces[][4] = {{0, 1, 2, -1}, {0, 2, 4, -1}, {0, 2, 3, -1}, {2, 0, 4, -1}};
  small_mesh s;
  make_mesh(&s, 5, pos, uv, 4, faces);
  CHECK(ch_mesh_remove_pillows(&s.m) == 2);
  CHECK(s.m.num_faces == 2 && s.m.corner_position[3] == 0 && s.m.corner_position[4] == 2 &&
        s.m.corner_position[5] == 3);
  CHECK(s.m.num_positions == 4 && memcmp(s.m.positions, pos, 12 * sizeof *pos) == 0);
  static const int faces2[][4] = {{0, 1, 2, -1}, {0, 2, 3, -1}, {2, 1, 0, -1}};
  make_mesh(&s, 5, pos, uv, 3, faces2);
  CHECK(ch_mesh_remove_pillows(&s.m) == 0 && s.m.num_faces == 3);
  /* the flap's vertex first of the positions after the corner: those
   * after it move down by one, and the corners with them */
  static const double pos3[] = {0, 0, 0, 0.5, 0.5, 1, 1, 0, 0, 1, 1, 0, 0, 1, 0};
  static const int faces3[][4] = {{0, 2, 3, -1}, {0, 3, 1, -1}, {0, 3, 4, -1}, {3, 0, 1, -1}};
  static const int want3[][3] = {{0, 1, 2}, {0, 2, 3}};
  make_mesh(&s, 5, pos3, uv, 4, faces3);
  CHECK(ch_mesh_remove_pillows(&s.m) == 2);
  CHECK(s.m.num_positions == 4 && faces_are(&s.m, 2, want3));
  CHECK(s.m.positions[3] == 1.0 && s.m.positions[4] == 0.0 && s.m.positions[9] == 0.0 && s.m.positions[10] == 1.0);
}

/* A mesh of GRID x GRID unit squares, the triangles a-b-c and a-c-d each
 * (180000: the collapse and the pillow search split it between threads),
 * with room for more positions and faces. Corner k's UV index is k and
 * its normal index 2k + 1, so that a corner moved wrongly shows. */
enum { GRID = 300, GRID_POSITIONS = (GRID + 1) * (GRID + 1), GRID_FACES = 2 * GRID * GRID };

static void add_face(ch_mesh *m, int a, int b, int c) {
  int f = m->num_faces++, k = 3 * f;
  m->corner_position[k] = a;
  m->corner_position[k + 1] = b;
  m->corner_position[k + 2] = c;
  for (int i = k; i < k + 3; i++) {
    m->corner_uv[i] = i;
    m->corner_normal[i] = 2 * i + 1;
  }
  m->face_start[f] = k;
  m->face_start[f + 1] = k + 3;
  m->num_corners = k + 3;
}

static int add_position(ch_mesh *m, double x, double y, double z) {
  double *p = &m->positions[3 * m->num_positions];
  p[0] = x;
  p[1] = y;
  p[2] = z;
  return m->num_positions++;
}

static void grid_mesh(ch_mesh *m, int more_positions, int more_faces) {
  memset(m, 0, sizeof *m);
  size_t corners = 3 * (size_t)(GRID_FACES + more_faces);
  m->positions = malloc(3 * sizeof *m->positions * (GRID_POSITIONS + more_positions));
  m->face_start = malloc(sizeof *m->face_start * (GRID_FACES + more_faces + 1));
  m->corner_position = malloc(sizeof *m->corner_position * corners);
  m->corner_uv = malloc(sizeof *m->corner_uv * corners);
  m->corner_normal = malloc(sizeof *m->corner_normal * corners);
  REQUIRE(m->positions && m->face_start && m->corner_position && m->corner_uv && m->corner_normal);
  m->face_start[0] = 0;
  for (int j = 0; j <= GRID; j++)
    for (int i = 0; i <= GRID; i++) add_position(m, i, j, 0);
  for (int j = 0; j < GRID; j++)
    for (int i = 0; i < GRID; i++) {
      int a = j * (GRID + 1) + i, b = a + 1, c = a + GRID + 2, d = a + GRID + 1;
      add_face(m, a, b, c);
      add_face(m, a, c, d);
    }
}

/* Whether m is `before` without the faces marked in drop (the others in
 * their order with their corners' indices), its positions the first
 * num_positions of before's, corners at positions past them renamed by
 * rename[p - num_positions]. */
static int grid_is(const ch_mesh *m, const ch_mesh *before, const unsigned char *drop, int num_positions,
                   const int *rename) {
  if (m->num_positions != num_positions ||
      memcmp(m->positions, before->positions, 3 * sizeof *m->positions * num_positions))
    return 0;
  int f2 = 0;
  for (int f = 0; f < before->num_faces; f++) {
    if (drop[f]) continue;
    if (f2 >= m->num_faces || m->face_start[f2] != 3 * f2) return 0;
    for (int k = 0; k < 3; k++) {
      int c = 3 * f + k, c2 = 3 * f2 + k, p = before->corner_position[c];
      if (m->corner_position[c2] != (p < num_positions ? p : rename[p - num_positions]) ||
          m->corner_uv[c2] != before->corner_uv[c] || m->corner_normal[c2] != before->corner_normal[c])
        return 0;
    }
    f2++;
  }
  return f2 == m->num_faces && m->num_corners == 3 * f2 && m->face_start[f2] == 3 * f2;
}

static void copy_mesh(ch_mesh *to, const ch_mesh *m) {
  *to = *m;
  size_t corners = sizeof(int) * (size_t)m->num_corners;
  to->positions = malloc(3 * sizeof *m->positions * m->num_positions);
  to->face_start = malloc(sizeof *m->face_start * (m->num_faces + 1));
  to->corner_position = malloc(corners);
  to->corner_uv = malloc(corners);
  to->corner_normal = malloc(corners);
  REQUIRE(to->positions && to->face_start && to->corner_position && to->corner_uv && to->corner_normal);
  memcpy(to->positions, m->positions, 3 * sizeof *m->positions * m->num_positions);
  memcpy(to->face_start, m->face_start, sizeof *m->face_start * (m->num_faces + 1));
  memcpy(to->corner_position, m->corner_position, corners);
  memcpy(to->corner_uv, m->corner_uv, corners);
  memcpy(to->corner_normal, m->corner_normal, corners);
}

/* On a mesh large enough to be split between threads (and on 1 to 3 of
 * them): thousands of vertex copies of valence 3 (each at a corner of the
 * square's first triangle, which it splits) collapse into their originals,
 * leaving the grid with each such triangle's one face moved to the end;
 * flaps on diagonals go as pillows, while a reversed copy of a triangle
 * (the diagonal would be left with one face) and faces with a repeated
 * corner stay. */
static void test_collapse_and_pillows_in_parallel(void) {
  int threads = omp_get_max_threads();
  enum { STEP = 4, COPIES = (GRID / STEP) * (GRID / STEP) };
  unsigned char *drop = calloc(GRID_FACES + 2 * COPIES, 1);
  int *original = malloc(sizeof *original * COPIES);
  REQUIRE(drop && original);
  for (int t = 1; t <= 3; t++) {
    omp_set_num_threads(t);
    ch_mesh m, before;
    grid_mesh(&m, COPIES, 2 * COPIES);
    memset(drop, 0, GRID_FACES + 2 * COPIES);
    for (int j = 0; j < GRID; j += STEP)
      for (int i = 0; i < GRID; i += STEP) {
        int f = 2 * (j * GRID + i), *c = &m.corner_position[3 * f], a = c[0], b = c[1], d = c[2];
        int v = add_position(&m, i, j, 0);
        original[v - GRID_POSITIONS] = a;
        c[2] = v; /* a-b-v, b-d-v, d-a-v: the two faces on a-v go */
        drop[f] = 1;
        add_face(&m, b, d, v);
        add_face(&m, d, a, v);
        drop[m.num_faces - 1] = 1;
      }
    copy_mesh(&before, &m);
    CHECK_MSG(ch_mesh_collapse_short_edges(&m, 1e-9) == COPIES, "%d threads", t);
    CHECK_MSG(grid_is(&m, &before, drop, GRID_POSITIONS, original), "%d threads: %d faces, %d positions", t,
              m.num_faces, m.num_positions);
    ch_mesh_free(&m);
    ch_mesh_free(&before);

    enum { FLAP = 6 };
    int flaps = 0;
    grid_mesh(&m, COPIES, 2 * COPIES);
    memset(drop, 0, GRID_FACES + 2 * COPIES);
    for (int j = 1; j < GRID; j += FLAP)
      for (int i = 1; i < GRID; i += FLAP) {
        const int *c = &m.corner_position[6 * (j * GRID + i)];
        int w = add_position(&m, i + 0.5, j + 0.5, 1);
        add_face(&m, c[0], c[2], w);
        drop[m.num_faces - 1] = 1;
        add_face(&m, c[2], c[0], w);
        drop[m.num_faces - 1] = 1;
        flaps++;
        const int *e = &m.corner_position[6 * (j * GRID + i + 3) + 3]; /* a-c-d, a square on */
        add_face(&m, e[2], e[1], e[0]);
        if (i % (2 * FLAP) == 1) add_face(&m, c[1], c[1], c[0]);
      }
    copy_mesh(&before, &m);
    CHECK_MSG(ch_mesh_remove_pillows(&m) == 2 * flaps, "%d threads", t);
    /* (the flaps' own vertices go with them: no loose ones) */
    CHECK_MSG(grid_is(&m, &before, drop, GRID_POSITIONS, NULL), "%d threads: %d faces, %d positions", t, m.num_faces,
              m.num_positions);
    ch_mesh_free(&m);
    ch_mesh_free(&before);
  }
  omp_set_num_threads(threads);
  free(drop);
  free(original);
}

static void test_nonmanifold(void) {
  ch_mesh m;
  REQUIRE(read_data("nonmanifold.obj", &m, NULL) == CH_OK); /* reported, not fatal */
  CHECK(m.num_faces == 3);
  ch_mesh_report r;
  warnings w;
  REQUIRE(validate(&m, &r, &w) == CH_OK);
  CHECK(r.num_nonmanifold_edges == 1);
  CHECK(r.num_boundary_edges == 6);
  CHECK(r.num_components == 1);
  CHECK_MSG(strstr(w.text, "test: 1 non-manifold edges (more than two faces), first between positions 1 and 2"),
            "%s", w.text);
  ch_mesh_free(&m);

  /* A bow tie: two triangles meeting at one vertex. */
  static const double pos[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, -1, 0, 0, 0, -1, 0};
  static const double uv[] = {.5, .5, 1, .5, .5, 1, 0, .5, .5, 0};
  static const int faces[][4] = {{0, 1, 2, -1}, {0, 3, 4, -1}};
  small_mesh s;
  make_mesh(&s, 5, pos, uv, 2, faces);
  REQUIRE(validate(&s.m, &r, &w) == CH_OK);
  CHECK(r.num_nonmanifold_vertices == 1 && r.num_nonmanifold_edges == 0);
  CHECK(r.num_components == 1 && r.num_charts == 2 && r.num_boundary_edges == 6);
  CHECK(strstr(w.text, "1 non-manifold vertices (separate fans of faces), first: position 1") != NULL);
  CHECK(w.count == 1);
}

static void test_validate_uv(void) {
  /* Two quads over the same UV square: coverage 1, overlap 1, one chart each
   * (no shared edge), two components. */
  static const double pos[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 5, 1, 0, 5, 1, 1, 5, 0, 1, 5};
  static const double uv[] = {0, 0, 1, 0, 1, 1, 0, 1, 0, 0, 1, 0, 1, 1, 0, 1};
  static const int faces[][4] = {{0, 1, 2, 3}, {4, 5, 6, 7}};
  small_mesh s;
  ch_mesh_report r;
  warnings w;
  make_mesh(&s, 8, pos, uv, 2, faces);
  REQUIRE(validate(&s.m, &r, &w) == CH_OK);
  CHECK_NEAR(r.uv_coverage, 1.0, 1e-3);
  CHECK_NEAR(r.uv_overlap, 1.0, 1e-3);
  CHECK(r.num_components == 2 && r.num_charts == 2);

  /* A triangle over the lower-left half: coverage 1/2 within a cell row. */
  static const int tri[][4] = {{0, 1, 3, -1}};
  make_mesh(&s, 4, pos, uv, 1, tri);
  REQUIRE(validate(&s.m, &r, &w) == CH_OK);
  CHECK_NEAR(r.uv_coverage, 0.5, 1e-3);
  CHECK(r.uv_overlap == 0.0);

  /* A concave (arrow) quad: its area, not its fan's, is counted once. */
  static const double apos[] = {0, 0, 0, 1, .5, 0, 0, 1, 0, .5, .5, 0};
  static const double auv[] = {0, 0, 1, .5, 0, 1, .5, .5};
  static const int arrow[][4] = {{0, 1, 2, 3}};
  make_mesh(&s, 4, apos, auv, 1, arrow);
  REQUIRE(validate(&s.m, &r, &w) == CH_OK);
  CHECK_NEAR(r.uv_coverage, 0.25, 1e-3); /* 1/2 * 1 * 1/2 */
  CHECK(r.uv_overlap == 0.0);

  /* UVs outside [0,1], a zero-area face and a zero-UV-area face: warnings,
   * one line each. */
  static const double bpos[] = {0, 0, 0, 1, 0, 0, 2, 0, 0, 0, 1, 0};
  static const double buv[] = {0, 0, 1.5, 0, 0, -0.25, 0, 0};
  static const int bad[][4] = {{0, 1, 2, -1}, {0, 1, 3, -1}};
  make_mesh(&s, 4, bpos, buv, 2, bad);
  REQUIRE(validate(&s.m, &r, &w) == CH_OK);
  CHECK(r.num_uvs_outside == 2);
  CHECK(r.num_degenerate_faces == 1 && r.num_zero_uv_area_faces == 1);
  CHECK(r.uv_min[1] == -0.25 && r.uv_max[0] == 1.5);
  CHECK_MSG(w.count == 3, "%s", w.text);
  CHECK(strstr(w.text, "test: 2 texture coordinates lie outside [0,1] (u 0..1.5, v -0.25..0)") != NULL);
  CHECK(strstr(w.text, "test: 1 faces have zero area, first: face 1") != NULL);
  CHECK(strstr(w.text, "test: 1 faces have zero UV area, first: face 2") != NULL);
}

static void test_validate_errors(void) {
  static const double pos[] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  static const double uv[] = {0, 0, 1, 0, 0, 1};
  static const int faces[][4] = {{0, 1, 2, -1}};
  small_mesh s;
  ch_mesh_report r;
  ch_error err;

  make_mesh(&s, 3, pos, uv, 1, faces);
  s.m.num_faces = 0;
  err = new_error(NULL);
  CHECK(ch_mesh_validate(&s.m, "m", &r, &err) == CH_ERR_INPUT);
  CHECK(strcmp(err.message, "m: mesh has no faces") == 0);

  make_mesh(&s, 3, pos, uv, 1, faces);
  s.pos[4] = NAN;
  err = new_error(NULL);
  CHECK(ch_mesh_validate(&s.m, "m", &r, &err) == CH_ERR_INPUT);
  CHECK(strcmp(err.message, "m: vertex 2: position is not finite") == 0);

  make_mesh(&s, 3, pos, uv, 1, faces);
  s.uv[5] = INFINITY;
  err = new_error(NULL);
  CHECK(ch_mesh_validate(&s.m, "m", &r, &err) == CH_ERR_INPUT);
  CHECK(strcmp(err.message, "m: texture coordinate 3 is not finite") == 0);

  make_mesh(&s, 3, pos, uv, 1, faces);
  s.cpos[2] = 3;
  err = new_error(NULL);
  CHECK(ch_mesh_validate(&s.m, "m", &r, &err) == CH_ERR_INPUT);
  CHECK(strcmp(err.message, "m: face 1: position index 4 out of range (1..3)") == 0);

  make_mesh(&s, 3, pos, uv, 1, faces);
  s.cuv[0] = -1;
  err = new_error(NULL);
  CHECK(ch_mesh_validate(&s.m, "m", &r, &err) == CH_ERR_INPUT);
  CHECK(strcmp(err.message, "m: face 1: texture index 0 out of range (1..3)") == 0);

  make_mesh(&s, 3, pos, uv, 1, faces);
  s.start[1] = 2;
  s.m.num_corners = 2;
  err = new_error(NULL);
  CHECK(ch_mesh_validate(&s.m, "m", &r, &err) == CH_ERR_INPUT);
  CHECK(strcmp(err.message, "m: face 1: 2 corners, a face needs at least 3") == 0);
}

/* ---- writers ------------------------------------------------------------ */

static void test_obj_round_trip(void) {
  const char *names[] = {"cube.obj", "plane.obj", "plane_bin.ply", "nonmanifold.obj"};
  for (int i = 0; i < 4; i++) {
    ch_mesh a, b;
    REQUIRE(read_data(names[i], &a, NULL) == CH_OK);
    ch_error err = new_error(NULL);
    const char *out1 = tmp_path("round1.obj"), *out2 = tmp_path("round2.obj");
    CHECK(ch_mesh_write_obj(out1, &a, &err) == CH_OK);
    CHECK(ch_mesh_write_obj(out2, &a, &err) == CH_OK);
    CHECK_MSG(files_equal(out1, out2), "%s: two writes differ", names[i]);
    CHECK(ch_mesh_read(out1, &b, &err) == CH_OK);
    CHECK_MSG(mesh_equal(&a, &b), "%s: read -> write -> read changed the arrays", names[i]);
    ch_mesh_free(&a);
    ch_mesh_free(&b);
  }
  /* The bytes themselves, for a small mesh. */
  ch_mesh m;
  REQUIRE(read_data("plane_st.off", &m, NULL) == CH_OK);
  ch_error err = new_error(NULL);
  CHECK(ch_mesh_write_obj(tmp_path("st.obj"), &m, &err) == CH_OK);
  size_t n;
  char *text = slurp(tmp_path("st.obj"), &n);
  CHECK(text && strcmp(text, "# chisel\nv 0 0 0\nv 2 0 0\nv 2 2 0\nv 0 2 0\nvt 0 0\nvt 1 0\nvt 1 1\n"
                             "vt 0 1\nf 1/1 2/2 3/3 4/4\n") == 0);
  free(text);
  ch_mesh_free(&m);
}

/* The OBJ writer's own number formatting against printf's "%.9g": the
 * same text, but for a last digit in rare rounding ties, and every value
 * reads back within half a unit of its ninth digit. Positions span magnitudes and signs; the
 * mesh is large enough to be written in several parallel blocks. */
static void test_obj_numbers(void) {
  enum { N = 60000 };
  ch_mesh m = {0};
  double *pos = malloc(sizeof(double) * 3 * N);
  int start[2] = {0, 3}, corners[3] = {0, 1, 2};
  REQUIRE(pos);
  uint64_t state = 12345;
  for (int i = 0; i < 3 * N; i++) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    double u = (double)(state >> 11) / 9007199254740992.0;       /* [0,1) */
    int e = (int)((state >> 3) % 40) - 20;                          /* 1e-20 .. 1e19 */
    double v = (u + 0.01) * pow(10.0, e);
    if (i % 7 == 0) v = -v;
    if (i % 101 == 0) v = (double)(i % 1000); /* integers */
    if (i % 103 == 0) v = 0.0;
    pos[i] = v;
  }
  m.num_positions = N;
  m.positions = pos;
  m.num_faces = 1;
  m.face_start = start;
  m.num_corners = 3;
  m.corner_position = corners;
  ch_error err = new_error(NULL);
  REQUIRE(ch_mesh_write_obj(tmp_path("numbers.obj"), &m, &err) == CH_OK);
  size_t n;
  char *text = slurp(tmp_path("numbers.obj"), &n);
  REQUIRE(text);
  char *line = strchr(text, '\n') + 1; /* after "# chisel" */
  int differ = 0, bad = 0;
  for (int v = 0; v < N; v++) {
    char expect[128];
    snprintf(expect, sizeof expect, "v %.9g %.9g %.9g", pos[3 * v], pos[3 * v + 1], pos[3 * v + 2]);
    char *end = strchr(line, '\n');
    REQUIRE(end);
    *end = '\0';
    if (strcmp(line, expect) != 0) differ++;
    double x, y, z;
    /* Nine significant digits: within half a unit of the ninth. */
    if (sscanf(line, "v %lf %lf %lf", &x, &y, &z) != 3 || fabs(x - pos[3 * v]) > 5.000001e-9 * fabs(pos[3 * v]) ||
        fabs(y - pos[3 * v + 1]) > 5.000001e-9 * fabs(pos[3 * v + 1]) ||
        fabs(z - pos[3 * v + 2]) > 5.000001e-9 * fabs(pos[3 * v + 2]))
      bad++;
    line = end + 1;
  }
  CHECK_MSG(bad == 0, "%d of %d lines do not read back", bad, N);
  CHECK_MSG(differ <= N / 1000, "%d of %d lines differ from printf", differ, N);
  CHECK(strcmp(line, "f 1 2 3\n") == 0);
  free(text);
  free(pos);
  remove(tmp_path("numbers.obj"));
}

static void test_ply_round_trip(void) {
  ch_mesh a, b;
  ch_error err = new_error(NULL);
  REQUIRE(read_data("cube.obj", &a, NULL) == CH_OK);
  const char *out1 = tmp_path("cube1.ply"), *out2 = tmp_path("cube2.ply");
  CHECK(ch_mesh_write_ply(out1, &a, &err) == CH_OK);
  CHECK(ch_mesh_write_ply(out2, &a, &err) == CH_OK);
  CHECK(files_equal(out1, out2));
  REQUIRE(ch_mesh_read(out1, &b, &err) == CH_OK);
  /* One vertex per position, so the cube stays closed although each corner
   * has its own UV (the face texcoord lists) and three normals meet there
   * (left out: PLY has no per-corner normals). */
  CHECK_MSG(b.num_positions == 8, "%d", b.num_positions);
  CHECK(b.num_faces == a.num_faces && b.num_corners == a.num_corners);
  CHECK(memcmp(b.positions, a.positions, sizeof(double) * 3 * 8) == 0);
  CHECK(memcmp(b.corner_position, a.corner_position, sizeof(int) * (size_t)a.num_corners) == 0);
  CHECK(!b.corner_normal);
  int same = 1;
  for (int c = 0; c < a.num_corners; c++) {
    same &= memcmp(corner_pos(&a, c), corner_pos(&b, c), 3 * sizeof(double)) == 0;
    same &= memcmp(corner_uv(&a, c), corner_uv(&b, c), 2 * sizeof(double)) == 0;
  }
  CHECK(same);
  ch_mesh_report rb;
  REQUIRE(validate(&b, &rb, NULL) == CH_OK);
  CHECK_MSG(rb.num_boundary_edges == 0, "%d boundary edges", rb.num_boundary_edges);
  ch_mesh_free(&a);
  ch_mesh_free(&b);

  /* Without seams the PLY keeps the positions exactly as they were. */
  REQUIRE(read_data("plane.obj", &a, NULL) == CH_OK);
  CHECK(ch_mesh_write_ply(out1, &a, &err) == CH_OK);
  REQUIRE(ch_mesh_read(out1, &b, &err) == CH_OK);
  CHECK(b.num_positions == 9 && memcmp(a.positions, b.positions, sizeof(double) * 27) == 0);
  CHECK(memcmp(a.corner_position, b.corner_position, sizeof(int) * 16) == 0);
  ch_mesh_report r;
  REQUIRE(validate(&b, &r, NULL) == CH_OK);
  CHECK(r.num_charts == 1);
  CHECK_NEAR(r.uv_coverage, 1.0, 1e-3);
  ch_mesh_free(&a);
  ch_mesh_free(&b);
}

/* A PLY large enough to be written in several chunks (more than 65536
 * vertices and faces), read back by the OpenMesh reader: positions as
 * floats, corners and UVs in order; and a face of 200 corners (counts that
 * need int lists). */
static void test_ply_large_and_wide(void) {
  enum { G = 260, NV = (G + 1) * (G + 1), NF = 2 * G * G, W = 200 };
  ch_mesh m = {0};
  double *pos = malloc(sizeof(double) * 3 * NV), *uv = malloc(sizeof(double) * 2 * NV);
  int *start = malloc(sizeof(int) * (NF + 1)), *cp = malloc(sizeof(int) * 3 * NF), *cu = malloc(sizeof(int) * 3 * NF);
  REQUIRE(pos && uv && start && cp && cu);
  for (int j = 0; j <= G; j++)
    for (int i = 0; i <= G; i++) {
      int v = j * (G + 1) + i;
      pos[3 * v] = i / (double)G;
      pos[3 * v + 1] = j / (double)G;
      pos[3 * v + 2] = 0.01 * sin(0.1 * i) * cos(0.07 * j);
      uv[2 * v] = pos[3 * v];
      uv[2 * v + 1] = pos[3 * v + 1];
    }
  int f = 0;
  for (int j = 0; j < G; j++)
    for (int i = 0; i < G; i++) {
      int a = j * (G + 1) + i, b = a + 1, c = a + G + 2, d = a + G + 1;
      int tri[2][3] = {{a, b, c}, {a, c, d}};
      for (int t = 0; t < 2; t++, f++) {
        start[f] = 3 * f;
        for (int k = 0; k < 3; k++) cp[3 * f + k] = cu[3 * f + k] = tri[t][k];
      }
    }
  start[NF] = 3 * NF;
  m.num_positions = NV;
  m.positions = pos;
  m.num_uvs = NV;
  m.uvs = uv;
  m.num_faces = NF;
  m.face_start = start;
  m.num_corners = 3 * NF;
  m.corner_position = cp;
  m.corner_uv = cu;
  ch_error err = new_error(NULL);
  const char *out = tmp_path("large.ply");
  REQUIRE(ch_mesh_write_ply(out, &m, &err) == CH_OK);
  ch_mesh b;
  CHECK_MSG(ch_mesh_read(out, &b, &err) == CH_OK, "%s", err.message);
  REQUIRE(b.num_positions > 0);
  CHECK_MSG(b.num_positions == NV && b.num_faces == NF, "%d positions, %d faces", b.num_positions, b.num_faces);
  int bad = 0;
  for (int v = 0; v < NV && v < b.num_positions; v++)
    for (int k = 0; k < 3; k++) bad += b.positions[3 * v + k] != (double)(float)pos[3 * v + k];
  for (int c = 0; c < 3 * NF && c < b.num_corners; c++) {
    bad += b.corner_position[c] != cp[c];
    for (int k = 0; k < 2; k++) bad += b.uvs[2 * b.corner_uv[c] + k] != (double)(float)uv[2 * cu[c] + k];
  }
  CHECK_MSG(bad == 0, "%d values differ", bad);
  ch_mesh_free(&b);

  /* One face of W corners on a circle. */
  int wstart[2] = {0, W};
  for (int k = 0; k < W; k++) {
    pos[3 * k] = cos(2.0 * 3.14159265358979323846 * k / W);
    pos[3 * k + 1] = sin(2.0 * 3.14159265358979323846 * k / W);
    pos[3 * k + 2] = 0.0;
    uv[2 * k] = 0.5 + 0.5 * pos[3 * k];
    uv[2 * k + 1] = 0.5 + 0.5 * pos[3 * k + 1];
    cp[k] = cu[k] = k;
  }
  m.num_positions = m.num_uvs = W;
  m.num_faces = 1;
  m.face_start = wstart;
  m.num_corners = W;
  REQUIRE(ch_mesh_write_ply(out, &m, &err) == CH_OK);
  CHECK_MSG(ch_mesh_read(out, &b, &err) == CH_OK, "%s", err.message);
  REQUIRE(b.num_positions > 0);
  CHECK(b.num_positions == W && b.num_faces == 1 && b.num_corners == W);
  bad = 0;
  for (int c = 0; c < W && c < b.num_corners; c++) {
    bad += b.corner_position[c] != c;
    for (int k = 0; k < 2; k++) bad += b.uvs[2 * b.corner_uv[c] + k] != (double)(float)uv[2 * c + k];
  }
  CHECK_MSG(bad == 0, "%d values differ", bad);
  ch_mesh_free(&b);
  free(pos);
  free(uv);
  free(start);
  free(cp);
  free(cu);
  remove(out);
}

static uint32_t le32(const unsigned char *p) {
  return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static float lef32(const unsigned char *p) {
  uint32_t u = le32(p);
  float f;
  memcpy(&f, &u, 4);
  return f;
}

/* glTF binary: the container's lengths, then every triangle corner read
 * back through the index buffer equals the OBJ's corner (float32). */
static void test_glb(void) {
  ch_mesh a;
  ch_error err = new_error(NULL);
  REQUIRE(read_data("cube.obj", &a, NULL) == CH_OK);
  const char *out1 = tmp_path("cube1.glb"), *out2 = tmp_path("cube2.glb");
  CHECK_MSG(ch_mesh_write_glb(out1, &a, &err) == CH_OK, "%s", err.message);
  CHECK(ch_mesh_write_glb(out2, &a, &err) == CH_OK);
  CHECK(files_equal(out1, out2));
  FILE *fp = fopen(out1, "rb");
  REQUIRE(fp);
  unsigned char buf[8192];
  size_t n = fread(buf, 1, sizeof buf, fp);
  fclose(fp);
  REQUIRE(n > 28 && n < sizeof buf);
  CHECK(memcmp(buf, "glTF", 4) == 0 && le32(buf + 4) == 2 && le32(buf + 8) == n);
  uint32_t jlen = le32(buf + 12);
  CHECK(jlen % 4 == 0 && memcmp(buf + 16, "JSON", 4) == 0);
  REQUIRE(20 + jlen + 8 <= n);
  const unsigned char *bh = buf + 20 + jlen, *bin = bh + 8;
  CHECK(memcmp(bh + 4, "BIN\0", 4) == 0);
  /* 8 positions with 3 normals each: 24 vertices; 6 quads: 36 indices. */
  uint32_t nv = 24, ni = 36;
  CHECK_MSG(le32(bh) == nv * 12 + nv * 12 + nv * 8 + ni * 4, "BIN %u bytes", le32(bh));
  CHECK(20 + jlen + 8 + le32(bh) == n);
  CHECK(strstr((const char *)buf + 20, "\"TEXCOORD_0\":2") != NULL);
  const unsigned char *pos = bin, *nrm = bin + 12 * nv, *uv = nrm + 12 * nv, *idx = uv + 8 * nv;
  int bad = 0, k = 0;
  for (int f = 0; f < a.num_faces; f++)
    for (int c = a.face_start[f] + 1; c + 1 < a.face_start[f + 1]; c++) {
      int corners[3] = {a.face_start[f], c, c + 1};
      for (int j = 0; j < 3; j++, k++) {
        uint32_t v = le32(idx + 4 * k);
        int oc = corners[j];
        if (v >= nv) {
          bad++;
          continue;
        }
        for (int d = 0; d < 3; d++) {
          bad += lef32(pos + 12 * v + 4 * d) != (float)corner_pos(&a, oc)[d];
          bad += lef32(nrm + 12 * v + 4 * d) != (float)a.normals[3 * a.corner_normal[oc] + d];
        }
        bad += lef32(uv + 8 * v) != (float)corner_uv(&a, oc)[0];
        bad += lef32(uv + 8 * v + 4) != (float)(1.0 - corner_uv(&a, oc)[1]);
      }
    }
  CHECK(k == (int)ni);
  CHECK_MSG(bad == 0, "%d values differ", bad);
  ch_mesh_free(&a);
}

static void test_write_errors(void) {
  ch_mesh m;
  REQUIRE(read_data("plane.obj", &m, NULL) == CH_OK);
  const char *bad_obj = tmp_path("no/such/dir/out.obj"), *bad_ply = tmp_path("no/such/dir/out.ply");
  ch_error err = new_error(NULL);
  CHECK(ch_mesh_write_obj(bad_obj, &m, &err) == CH_ERR_IO);
  CHECK(strncmp(err.message, bad_obj, strlen(bad_obj)) == 0);
  err = new_error(NULL);
  CHECK(ch_mesh_write_ply(bad_ply, &m, &err) == CH_ERR_IO);
  struct stat st;
  CHECK(stat(bad_obj, &st) != 0 && stat(bad_ply, &st) != 0 && stat(tmp_path("no"), &st) != 0);
  ch_mesh_free(&m);
}

/* A malformed mesh in memory is refused before anything is written, the
 * first bad face named (the check runs on all threads). */
static void test_write_refuses_bad_meshes(void) {
  enum { F = 50000 };
  double pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  int *start = malloc((F + 1) * sizeof *start), *corner = malloc(3 * (size_t)F * sizeof *corner);
  REQUIRE(start && corner);
  for (int f = 0; f <= F; f++) start[f] = 3 * f;
  for (int c = 0; c < 3 * F; c++) corner[c] = c % 3;
  ch_mesh m = {.num_positions = 3,
               .positions = pos,
               .num_faces = F,
               .face_start = start,
               .num_corners = 3 * F,
               .corner_position = corner};
  const char *out = tmp_path("refused.obj");
  struct stat st;
  ch_error err = new_error(NULL);
  CHECK(ch_mesh_write_obj(out, &m, &err) == CH_OK); /* well formed */
  remove(out);
  corner[3 * 40000 + 1] = 3; /* two bad faces: 40001 and (below) 30001 */
  corner[3 * 30000 + 2] = -1;
  err = new_error(NULL);
  CHECK(ch_mesh_write_obj(out, &m, &err) == CH_ERR_INPUT);
  CHECK_MSG(strstr(err.message, "face 30001: index out of range") != NULL, "%s", err.message);
  CHECK(stat(out, &st) != 0);
  corner[3 * 30000 + 2] = 2;
  corner[3 * 40000 + 1] = 1;
  start[20001] = 3 * F + 3; /* past the corners: faces 20001 and 20002 inconsistent */
  err = new_error(NULL);
  CHECK(ch_mesh_write_ply(tmp_path("refused.ply"), &m, &err) == CH_ERR_INPUT);
  CHECK_MSG(strstr(err.message, "face 20001: inconsistent corner offsets") != NULL, "%s", err.message);
  CHECK(stat(tmp_path("refused.ply"), &st) != 0);
  start[20001] = -3; /* before the corners */
  err = new_error(NULL);
  CHECK(ch_mesh_write_obj(out, &m, &err) == CH_ERR_INPUT);
  CHECK_MSG(strstr(err.message, "face 20001: inconsistent corner offsets") != NULL, "%s", err.message);
  CHECK(stat(out, &st) != 0);
  free(start);
  free(corner);
}

int main(void) {
  const char *base = getenv("TMPDIR");
  snprintf(tmp_dir, sizeof tmp_dir, "%s/test_mesh.XXXXXX", base && *base ? base : "/tmp");
  if (!mkdtemp(tmp_dir)) {
    perror("mkdtemp");
    return 1;
  }
  RUN(test_plane_obj);
  RUN(test_cube_obj);
  RUN(test_ply);
  RUN(test_ply_welded);
  RUN(test_off);
  RUN(test_stl);
  RUN(test_float_precision);
  RUN(test_obj_floats_as_strtof);
  RUN(test_share_values);
  RUN(test_read_errors);
  RUN(test_hostile_inputs);
  RUN(test_scanners);
  RUN(test_mtllib_ignored);
  RUN(test_silence);
  RUN(test_truncations);
  RUN(test_nonmanifold);
  RUN(test_collapse_short_edges);
  RUN(test_collapse_vertex_copies);
  RUN(test_remove_pillows);
  RUN(test_collapse_and_pillows_in_parallel);
  RUN(test_validate_uv);
  RUN(test_validate_errors);
  RUN(test_obj_round_trip);
  RUN(test_obj_numbers);
  RUN(test_ply_round_trip);
  RUN(test_ply_large_and_wide);
  RUN(test_glb);
  RUN(test_write_errors);
  RUN(test_write_refuses_bad_meshes);
  const char *made[] = {"stderr.txt", "round1.obj", "round2.obj", "st.obj", "cube1.ply", "cube2.ply",
                        "cube1.glb",  "cube2.glb"};
  for (size_t i = 0; i < sizeof made / sizeof made[0]; i++) remove(tmp_path(made[i]));
  rmdir(tmp_dir);
  TEST_MAIN_END();
}
