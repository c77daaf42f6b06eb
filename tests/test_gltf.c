/* Tests of the glTF 2.0 reader (mesh/ch_mesh_gltf_read.c): GLB and .gltf
 * files put together here byte by byte, with what the glTF 2.0
 * specification says they hold worked out by hand (node transforms,
 * strips, winding under a mirror, welding at UV seams, sparse accessors,
 * normalised UVs); a round trip through chisel's own .glb writer; and one
 * line of CH_ERR_INPUT for each way a file can be broken. Blender's own
 * .glb and .gltf exports are read in tests/test_interop.sh. */
#define _POSIX_C_SOURCE 200809L
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "ch_mesh.h"
#include "ch_test.h"

/* ---- building files ------------------------------------------------------ */

typedef struct bytes {
  unsigned char data[4096];
  size_t n;
} bytes;

static void put_f32(bytes *b, float x) {
  memcpy(b->data + b->n, &x, 4); /* (little-endian machines only, as glTF) */
  b->n += 4;
}
static void put_u16(bytes *b, unsigned x) {
  b->data[b->n++] = (unsigned char)x;
  b->data[b->n++] = (unsigned char)(x >> 8);
}
static void put_u8(bytes *b, unsigned x) { b->data[b->n++] = (unsigned char)x; }
static void pad4(bytes *b, unsigned char with) {
  while (b->n % 4) b->data[b->n++] = with;
}
static void put_le32(unsigned char *o, uint32_t u) {
  for (int k = 0; k < 4; k++) o[k] = (unsigned char)(u >> 8 * k);
}

/* A GLB of json (padded with spaces) and bin (padded with zeros, left out
 * when empty) into out; returns its size. */
static size_t make_glb(const char *json, const bytes *bin, unsigned char *out) {
  size_t jn = strlen(json), jpad = (jn + 3) / 4 * 4, bpad = bin ? (bin->n + 3) / 4 * 4 : 0;
  size_t total = 12 + 8 + jpad + (bin && bin->n ? 8 + bpad : 0);
  memcpy(out, "glTF", 4);
  put_le32(out + 4, 2);
  put_le32(out + 8, (uint32_t)total);
  put_le32(out + 12, (uint32_t)jpad);
  memcpy(out + 16, "JSON", 4);
  memcpy(out + 20, json, jn);
  memset(out + 20 + jn, ' ', jpad - jn);
  if (bin && bin->n) {
    unsigned char *c = out + 20 + jpad;
    put_le32(c, (uint32_t)bpad);
    memcpy(c + 4, "BIN\0", 4);
    memcpy(c + 8, bin->data, bin->n);
    memset(c + 8 + bin->n, 0, bpad - bin->n);
  }
  return total;
}

static ch_error quiet(void) { return (ch_error){0}; }

static ch_status read_glb(const char *json, const bytes *bin, ch_mesh *m, ch_error *err) {
  static unsigned char buf[16384];
  size_t n = make_glb(json, bin, buf);
  return ch_mesh_read_memory(buf, n, "glb", "t.glb", m, err);
}

/* The corner's position, UV and normal. */
static const double *cpos(const ch_mesh *m, int c) { return &m->positions[3 * m->corner_position[c]]; }
static const double *cuv(const ch_mesh *m, int c) { return &m->uvs[2 * m->corner_uv[c]]; }
static const double *cnrm(const ch_mesh *m, int c) { return &m->normals[3 * m->corner_normal[c]]; }

/* z of triangle f's geometric normal (corners counter-clockwise: > 0
 * seen from +z). */
static double winding_z(const ch_mesh *m, int f) {
  const double *a = cpos(m, 3 * f), *b = cpos(m, 3 * f + 1), *c = cpos(m, 3 * f + 2);
  return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
}

/* A unit square's 4 corners in local space: positions (float VEC3, 48
 * bytes at 0), UVs (normalised UNSIGNED_SHORT VEC2, 16 bytes at 48),
 * normals +z (float VEC3, 48 bytes at 64), then indices as the caller adds
 * them (at 112). */
static void square_bin(bytes *b) {
  b->n = 0;
  static const float p[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  for (int i = 0; i < 4; i++)
    for (int k = 0; k < 3; k++) put_f32(b, p[i][k]);
  for (int i = 0; i < 4; i++) {
    put_u16(b, p[i][0] ? 65535 : 0);
    put_u16(b, p[i][1] ? 65535 : 0);
  }
  for (int i = 0; i < 4; i++) put_f32(b, 0), put_f32(b, 0), put_f32(b, 1);
}

static const char *square_views =
    "\"bufferViews\":[{\"buffer\":0,\"byteLength\":48},{\"buffer\":0,\"byteOffset\":48,\"byteLength\":16},"
    "{\"buffer\":0,\"byteOffset\":64,\"byteLength\":48},{\"buffer\":0,\"byteOffset\":112,\"byteLength\":%d}],"
    "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":4,\"type\":\"VEC3\"},"
    "{\"bufferView\":1,\"componentType\":5123,\"normalized\":true,\"count\":4,\"type\":\"VEC2\"},"
    "{\"bufferView\":2,\"componentType\":5126,\"count\":4,\"type\":\"VEC3\"},"
    "{\"bufferView\":3,\"componentType\":%d,\"count\":%d,\"type\":\"SCALAR\"}],";

/* The square of b (its indices: count of componentType ctype, taking
 * index_bytes) drawn in `mode` by node 0 of `nodes` (the nodes array's
 * JSON, node 0 the scene's root), read into m. */
static ch_status read_square(const bytes *b, const char *nodes, int index_bytes, int ctype, int count, int mode,
                             ch_mesh *m) {
  char json[2048], views[1024];
  snprintf(views, sizeof views, square_views, index_bytes, ctype, count);
  snprintf(json, sizeof json,
           "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],\"nodes\":%s,"
           "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":1,\"NORMAL\":2},"
           "\"indices\":3,\"mode\":%d}]}],%s\"buffers\":[{\"byteLength\":%zu}]}",
           nodes, mode, views, b->n);
  ch_error err = quiet();
  return read_glb(json, b, m, &err);
}

/* ---- tests --------------------------------------------------------------- */

/* A strip of 4 vertices (two triangles) under a node rotated 90 degrees
 * about z, under one translated by (1, 2, 3) and scaled by 2: world = T S
 * R (§3.5.3), so local (1, 0, 0) -> (0, 1, 0) -> (0, 2, 0) -> (1, 4, 3). */
static void test_nodes_and_strip(void) {
  bytes b;
  square_bin(&b);
  for (unsigned i = 0; i < 4; i++) put_u8(&b, i);
  ch_mesh m;
  REQUIRE(read_square(&b,
                      "[{\"translation\":[1,2,3],\"scale\":[2,2,2],\"children\":[1]},"
                      "{\"rotation\":[0,0,0.70710678118654752,0.70710678118654752],\"mesh\":0}]",
                      4, 5121, 4, 5, &m) == CH_OK);
  ch_error err = quiet();
  CHECK(m.num_faces == 2 && m.num_corners == 6 && m.num_positions == 4 && m.num_uvs == 4 && m.num_normals == 1);
  /* strip: (0, 1, 2), then (2, 1, 3) (every other one turned over) */
  static const int want[6] = {0, 1, 2, 2, 1, 3};
  static const double world[4][3] = {{1, 2, 3}, {1, 4, 3}, {-1, 2, 3}, {-1, 4, 3}};
  static const double uv[4][2] = {{0, 1}, {1, 1}, {0, 0}, {1, 0}}; /* v flipped back up */
  for (int c = 0; c < 6; c++) {
    for (int k = 0; k < 3; k++) CHECK_NEAR(cpos(&m, c)[k], world[want[c]][k], 1e-12);
    CHECK(cuv(&m, c)[0] == uv[want[c]][0] && cuv(&m, c)[1] == uv[want[c]][1]);
    CHECK_NEAR(cnrm(&m, c)[2], 1.0, 1e-12);
  }
  CHECK(winding_z(&m, 0) > 0 && winding_z(&m, 1) > 0); /* still facing +z, as the normals */
  ch_mesh_report r;
  CHECK(ch_mesh_validate(&m, "t.glb", &r, &err) == CH_OK);
  CHECK(r.num_boundary_edges == 4 && r.num_nonmanifold_edges == 0 && r.num_charts == 1);
  ch_mesh_free(&m);
}

/* A mirror (scale -1 in x) turns the winding over (§3.7.2.1), so the
 * triangle keeps facing where its normal points; the normal goes through
 * the inverse transpose: +z stays +z. */
static void test_mirror(void) {
  bytes b;
  square_bin(&b);
  for (unsigned i = 0; i < 3; i++) put_u16(&b, i);
  pad4(&b, 0);
  ch_mesh m;
  REQUIRE(read_square(&b, "[{\"matrix\":[-1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1],\"mesh\":0}]", 6, 5123, 3, 4, &m) ==
          CH_OK);
  REQUIRE(m.num_faces == 1);
  /* (0, 1, 2) read as (0, 2, 1): local (0, 1, 0) then (1, 0, 0), mirrored */
  CHECK(cpos(&m, 1)[0] == 0.0 && cpos(&m, 1)[1] == 1.0 && cpos(&m, 2)[0] == -1.0 && cpos(&m, 2)[1] == 0.0);
  CHECK_MSG(winding_z(&m, 0) > 0, "winding %g", winding_z(&m, 0));
  CHECK(cnrm(&m, 0)[0] == 0.0 && cnrm(&m, 0)[2] == 1.0);
  ch_mesh_free(&m);
}

/* Normals under a rotation (90 degrees about z) of a non-uniform scale (2
 * in x): the inverse transpose R S^-1, so (1, 1, 0) / sqrt 2 -> (0.5, 1, 0)
 * -> (-1, 0.5, 0), normalised; positions by R S. */
static void test_normals(void) {
  bytes b;
  square_bin(&b);
  b.n = 64;
  for (int i = 0; i < 4; i++) put_f32(&b, 0.70710678f), put_f32(&b, 0.70710678f), put_f32(&b, 0);
  for (unsigned i = 0; i < 3; i++) put_u8(&b, i);
  ch_mesh m;
  REQUIRE(read_square(&b,
                      "[{\"rotation\":[0,0,0.70710678118654752,0.70710678118654752],\"scale\":[2,1,1],\"mesh\":0}]",
                      3, 5121, 3, 4, &m) == CH_OK);
  REQUIRE(m.num_faces == 1 && m.num_normals == 1);
  double s5 = 1.0 / sqrt(5.0);
  CHECK_NEAR(cnrm(&m, 0)[0], -2.0 * s5, 1e-7);
  CHECK_NEAR(cnrm(&m, 0)[1], s5, 1e-7);
  CHECK_NEAR(cnrm(&m, 0)[2], 0.0, 1e-12);
  /* local (1, 0, 0) -> (2, 0, 0) -> (0, 2, 0) */
  CHECK_NEAR(cpos(&m, 1)[0], 0.0, 1e-12);
  CHECK_NEAR(cpos(&m, 1)[1], 2.0, 1e-12);
  ch_mesh_free(&m);
}

/* Two triangles of the unit square in two primitives, (0,0) (1,0) (1,1)
 * and (0,0) (1,1) (0,1), with UVs t (float VEC2), read into m. */
static ch_status read_two_triangles(const float t[6][2], ch_mesh *m, ch_error *err) {
  bytes b = {.n = 0};
  static const float p[6][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  for (int i = 0; i < 6; i++) put_f32(&b, p[i][0]), put_f32(&b, p[i][1]), put_f32(&b, p[i][2]);
  for (int i = 0; i < 6; i++) put_f32(&b, t[i][0]), put_f32(&b, t[i][1]);
  const char *json =
      "{\"asset\":{\"version\":\"2.0\"},\"bufferViews\":[{\"buffer\":0,\"byteLength\":72},"
      "{\"buffer\":0,\"byteOffset\":72,\"byteLength\":48}],"
      "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
      "{\"bufferView\":0,\"byteOffset\":36,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
      "{\"bufferView\":1,\"componentType\":5126,\"count\":3,\"type\":\"VEC2\"},"
      "{\"bufferView\":1,\"byteOffset\":24,\"componentType\":5126,\"count\":3,\"type\":\"VEC2\"}],"
      "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":2}},"
      "{\"attributes\":{\"POSITION\":1,\"TEXCOORD_0\":3}}]}],\"buffers\":[{\"byteLength\":120}]}";
  return read_glb(json, &b, m, err);
}

/* Two primitives meeting along the diagonal with different UVs there (a
 * UV seam, as exporters split it): one position per point (4), the
 * diagonal an inner edge, 6 UVs in two charts. Without scenes or nodes the
 * meshes are read as they are. */
static void test_welding(void) {
  static const float t[6][2] = {{0, 1}, {.5f, 1}, {.5f, 0}, {.6f, 1}, {1, 0}, {.6f, 0}};
  ch_mesh m;
  ch_error err = quiet();
  REQUIRE(read_two_triangles(t, &m, &err) == CH_OK);
  CHECK(m.num_faces == 2 && m.num_positions == 4 && m.num_uvs == 6 && !m.corner_normal);
  ch_mesh_report r;
  CHECK(ch_mesh_validate(&m, "t.glb", &r, &err) == CH_OK);
  CHECK(r.num_boundary_edges == 4 && r.num_components == 1 && r.num_charts == 2);
  CHECK_NEAR(r.uv_coverage, 0.5 * 0.5 + 0.5 * 0.4, 0.01); /* (a raster's estimate) */
  ch_mesh_free(&m);
}

/* UVs a float rounding apart at one welded position are one UV: Blender's
 * exporter splits a vertex for its normals and rounds the copies' UVs
 * apart (0.599999964 and 0.600000024), which read as a UV seam. */
static void test_near_uvs(void) {
  float t[6][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 0}, {1, 1}, {0, 1}};
  t[4][1] = nextafterf(1.0f, 0.0f); /* the copy of (1, 1) one rounding below */
  t[3][0] = nextafterf(0.0f, 1.0f); /* and of (0, 0) one above */
  ch_mesh m;
  ch_error err = quiet();
  REQUIRE(read_two_triangles((const float(*)[2])t, &m, &err) == CH_OK);
  CHECK_MSG(m.num_positions == 4 && m.num_uvs == 4, "%d positions, %d UVs", m.num_positions, m.num_uvs);
  ch_mesh_report r;
  CHECK(ch_mesh_validate(&m, "t.glb", &r, &err) == CH_OK);
  CHECK(r.num_charts == 1 && r.num_boundary_edges == 4);
  /* the first seen is kept: (x, y) exactly, v flipped to chisel's 1 - y */
  for (int c = 0; c < m.num_corners; c++)
    CHECK(cuv(&m, c)[0] == cpos(&m, c)[0] && cuv(&m, c)[1] == 1.0 - cpos(&m, c)[1]);
  ch_mesh_free(&m);
}

/* The JSON form with its buffer in a data: URI, no indices, and a sparse
 * accessor (§3.6.2.3): zeros without a view, vertices 1 and 2 replaced. */
static void test_data_uri_and_sparse(void) {
  /* bytes: UVs (24), sparse indices 1, 2 as UNSIGNED_BYTE (4 with
   * padding), sparse values (24) */
  bytes b = {.n = 0};
  for (int i = 0; i < 3; i++) put_f32(&b, i == 1), put_f32(&b, i == 2);
  put_u8(&b, 1);
  put_u8(&b, 2);
  pad4(&b, 0);
  put_f32(&b, 1), put_f32(&b, 0), put_f32(&b, 0);
  put_f32(&b, 0), put_f32(&b, 1), put_f32(&b, 0);
  static const char b64[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  char text[256];
  size_t k = 0;
  for (size_t i = 0; i < b.n; i += 3) {
    uint32_t v = (uint32_t)b.data[i] << 16 | (i + 1 < b.n ? (uint32_t)b.data[i + 1] << 8 : 0) |
                 (i + 2 < b.n ? b.data[i + 2] : 0);
    text[k++] = b64[v >> 18 & 63];
    text[k++] = b64[v >> 12 & 63];
    text[k++] = i + 1 < b.n ? b64[v >> 6 & 63] : '=';
    text[k++] = i + 2 < b.n ? b64[v & 63] : '=';
  }
  text[k] = 0;
  char json[2048];
  snprintf(json, sizeof json,
           "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"byteLength\":%zu,"
           "\"uri\":\"data:application/octet-stream;base64,%s\"}],"
           "\"bufferViews\":[{\"buffer\":0,\"byteLength\":24},{\"buffer\":0,\"byteOffset\":24,\"byteLength\":2},"
           "{\"buffer\":0,\"byteOffset\":28,\"byteLength\":24}],"
           "\"accessors\":[{\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"sparse\":{\"count\":2,"
           "\"indices\":{\"bufferView\":1,\"componentType\":5121},\"values\":{\"bufferView\":2}}},"
           "{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC2\"}],"
           "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":1}}]}]}",
           b.n, text);
  ch_mesh m;
  ch_error err = quiet();
  REQUIRE(ch_mesh_read_memory(json, strlen(json), "gltf", "t.gltf", &m, &err) == CH_OK);
  REQUIRE(m.num_faces == 1 && m.num_positions == 3);
  static const double want[3][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  for (int c = 0; c < 3; c++) {
    for (int d = 0; d < 3; d++) CHECK(cpos(&m, c)[d] == want[c][d]);
    CHECK(cuv(&m, c)[0] == want[c][0] && cuv(&m, c)[1] == 1.0 - want[c][1]);
  }
  ch_mesh_free(&m);
  /* a character outside base64 */
  char *comma = strstr(json, "base64,");
  REQUIRE(comma);
  comma[7] = '*';
  err = quiet();
  CHECK(ch_mesh_read_memory(json, strlen(json), "gltf", "t.gltf", &m, &err) == CH_ERR_INPUT);
  CHECK(strstr(err.message, "outside base64") != NULL);
}

/* One file, written by chisel's .glb writer, read back: the cube's 8
 * positions (welded again from its 24 glTF vertices), 12 triangles, UVs
 * and normals as float32 has them, closed. */
static void test_round_trip(const char *dir) {
  char obj[1024], glb[1100];
  snprintf(obj, sizeof obj, "%s/mesh/cube.obj", CHISEL_TEST_DATA);
  snprintf(glb, sizeof glb, "%s/cube.glb", dir);
  ch_mesh a, b;
  ch_error err = quiet();
  REQUIRE(ch_mesh_read(obj, &a, &err) == CH_OK);
  REQUIRE(ch_mesh_write_glb(glb, &a, &err) == CH_OK);
  REQUIRE(ch_mesh_read(glb, &b, &err) == CH_OK);
  CHECK(b.num_positions == a.num_positions && b.num_faces == 2 * a.num_faces);
  CHECK(b.num_normals == a.num_normals && b.num_uvs == a.num_uvs);
  /* each triangle of b is the fan of a's quads, corner for corner */
  int bad = 0, t = 0;
  for (int f = 0; f < a.num_faces; f++)
    for (int c = a.face_start[f] + 1; c + 1 < a.face_start[f + 1]; c++, t++) {
      int ac[3] = {a.face_start[f], c, c + 1};
      for (int j = 0; j < 3; j++) {
        for (int d = 0; d < 3; d++) {
          bad += cpos(&b, 3 * t + j)[d] != (float)a.positions[3 * a.corner_position[ac[j]] + d];
          bad += cnrm(&b, 3 * t + j)[d] != (float)a.normals[3 * a.corner_normal[ac[j]] + d];
        }
        for (int d = 0; d < 2; d++) bad += fabs(cuv(&b, 3 * t + j)[d] - a.uvs[2 * a.corner_uv[ac[j]] + d]) > 1e-7;
      }
    }
  CHECK_MSG(bad == 0, "%d values differ", bad);
  ch_mesh_report r;
  CHECK(ch_mesh_validate(&b, glb, &r, &err) == CH_OK);
  CHECK(r.num_boundary_edges == 0 && r.num_components == 1);
  ch_mesh_free(&a);
  ch_mesh_free(&b);
  remove(glb);
}

/* A .gltf beside its .bin, named with a space (percent-encoded in the URI),
 * and a second buffer no view uses, whose file is not there (as images'
 * can be): read. Then the first .bin gone: CH_ERR_IO naming it. */
static void test_bin_file(const char *dir) {
  bytes b;
  square_bin(&b);
  for (unsigned i = 0; i < 3; i++) put_u8(&b, i);
  char views[1024], json[2048], gltf[1100], bin[1100];
  snprintf(views, sizeof views, square_views, 3, 5121, 3);
  snprintf(json, sizeof json,
           "{\"asset\":{\"version\":\"2.0\"},\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,"
           "\"TEXCOORD_0\":1}, \"indices\":3}]}],%s\"buffers\":[{\"byteLength\":%zu,\"uri\":\"the%%20data.bin\"},"
           "{\"byteLength\":10,\"uri\":\"images.bin\"}]}",
           views, b.n);
  snprintf(gltf, sizeof gltf, "%s/scene.gltf", dir);
  snprintf(bin, sizeof bin, "%s/the data.bin", dir);
  FILE *f = fopen(gltf, "wb");
  REQUIRE(f);
  fputs(json, f);
  fclose(f);
  REQUIRE((f = fopen(bin, "wb")));
  fwrite(b.data, 1, b.n, f);
  fclose(f);
  ch_mesh m;
  ch_error err = quiet();
  CHECK_MSG(ch_mesh_read(gltf, &m, &err) == CH_OK, "%s", err.message);
  CHECK(m.num_faces == 1 && m.num_positions == 3);
  ch_mesh_free(&m);
  remove(bin);
  err = quiet();
  CHECK(ch_mesh_read(gltf, &m, &err) == CH_ERR_IO);
  CHECK_MSG(strstr(err.message, "the data.bin") != NULL, "%s", err.message);
  remove(gltf);
}

/* Broken files: CH_ERR_INPUT, one line that starts with the file's name and
 * says what is wrong, and nothing left in the mesh. */
static void expect_error(const unsigned char *data, size_t n, const char *format, const char *want) {
  ch_mesh m;
  ch_error err = quiet();
  ch_status st = ch_mesh_read_memory(data, n, format, "bad.glb", &m, &err);
  CHECK_MSG(st == CH_ERR_INPUT, "%s: status %d", want, (int)st);
  CHECK_MSG(strstr(err.message, want) != NULL, "wanted '%s' in '%s'", want, err.message);
  CHECK(strncmp(err.message, "bad.glb: ", 9) == 0 && !strchr(err.message, '\n'));
  CHECK(m.num_faces == 0 && m.positions == NULL && m.corner_position == NULL);
}

static void test_errors(void) {
  bytes b;
  square_bin(&b);
  for (unsigned i = 0; i < 3; i++) put_u8(&b, i);
  char views[1024], json[4096];
  unsigned char buf[16384];
  const char *good =
      "{\"asset\":{\"version\":\"2.0\"},%s\"meshes\":[{\"primitives\":[{\"attributes\":"
      "{\"POSITION\":0,\"TEXCOORD_0\":1},\"indices\":3}]}],%s\"buffers\":[{\"byteLength\":%zu}]%s}";
  snprintf(views, sizeof views, square_views, 3, 5121, 3);
  snprintf(json, sizeof json, good, "", views, b.n, "");
  size_t n = make_glb(json, &b, buf);
  ch_mesh m;
  ch_error err = quiet();
  REQUIRE(ch_mesh_read_memory(buf, n, "glb", "bad.glb", &m, &err) == CH_OK); /* the control */
  ch_mesh_free(&m);

  buf[3] = 'X';
  expect_error(buf, n, "glb", "not a glTF binary");
  buf[3] = 'F';
  put_le32(buf + 4, 1);
  expect_error(buf, n, "glb", "version 1");
  put_le32(buf + 4, 2);
  expect_error(buf, n - 8, "glb", "truncated");
  expect_error(buf, 10, "glb", "shorter than its header");
  /* an index past the vertices */
  b.data[112 + 2] = 9;
  n = make_glb(json, &b, buf);
  expect_error(buf, n, "glb", "past its 4 vertices");
  b.data[112 + 2] = 2;
  /* more elements than the view holds */
  snprintf(views, sizeof views, square_views, 3, 5121, 9);
  snprintf(json, sizeof json, good, "", views, b.n, "");
  n = make_glb(json, &b, buf);
  expect_error(buf, n, "glb", "do not fit");
  snprintf(views, sizeof views, square_views, 3, 5121, 3);
  /* a view past its buffer */
  snprintf(json, sizeof json, good, "", views, (size_t)100, "");
  n = make_glb(json, &b, buf);
  expect_error(buf, n, "glb", "past buffer 0");
  /* a cycle of nodes */
  snprintf(json, sizeof json, good, "\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"children\":[1]},{\"children\":[0]}],",
           views, b.n, "");
  n = make_glb(json, &b, buf);
  expect_error(buf, n, "glb", "its own ancestor");
  /* a node with two parents: a scene graph that is not a tree */
  snprintf(json, sizeof json, good,
           "\"scenes\":[{\"nodes\":[0,1]}],\"nodes\":[{\"children\":[2]},{\"children\":[2]},{\"mesh\":0}],", views, b.n,
           "");
  n = make_glb(json, &b, buf);
  expect_error(buf, n, "glb", "more than one parent");
  /* float indices */
  snprintf(views, sizeof views, square_views, 3, 5126, 3);
  snprintf(json, sizeof json, good, "", views, b.n, "");
  n = make_glb(json, &b, buf);
  expect_error(buf, n, "glb", "indices of componentType 5126");
  snprintf(views, sizeof views, square_views, 3, 5121, 3);
  /* compressed geometry */
  snprintf(json, sizeof json, good, "", views, b.n, ",\"extensionsRequired\":[\"KHR_draco_mesh_compression\"]");
  n = make_glb(json, &b, buf);
  expect_error(buf, n, "glb", "KHR_draco_mesh_compression");
  /* glTF 1.0 */
  snprintf(json, sizeof json, "{\"asset\":{\"version\":\"1.0\"}}");
  n = make_glb(json, NULL, buf);
  expect_error(buf, n, "glb", "chisel reads glTF 2.0");
  /* malformed JSON */
  n = make_glb("{\"asset\":{\"version\":\"2.0\"},", NULL, buf);
  expect_error(buf, n, "glb", "malformed");
  /* a file named in a glTF read from memory */
  /* (a buffer is read when a view of it is: a mesh uses this one) */
  static const char uses[] = "\"bufferViews\":[{\"buffer\":0,\"byteLength\":12}],\"accessors\":[{\"bufferView\":0,\"componentType\":5126,"
  "\"count\":1,\"type\":\"VEC3\"}],\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0}}]}]}";
  snprintf(json, sizeof json, "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"byteLength\":12,\"uri\":\"x.bin\"}],%s",
           uses);
  expect_error((const unsigned char *)json, strlen(json), "gltf", "cannot have");
  snprintf(json, sizeof json,
           "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"byteLength\":12,\"uri\":\"https://example.com/x.bin\"}],%s",
           uses);
  expect_error((const unsigned char *)json, strlen(json), "gltf", "not a relative path");
  /* NaN in a position */
  bytes nan = b;
  put_le32(nan.data + 4, 0x7fc00000u);
  snprintf(json, sizeof json, good, "", views, b.n, "");
  n = make_glb(json, &nan, buf);
  expect_error(buf, n, "glb", "not a finite number");
  /* UVs in one primitive only */
  snprintf(json, sizeof json,
           "{\"asset\":{\"version\":\"2.0\"},\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,"
           "\"TEXCOORD_0\":1},\"indices\":3},{\"attributes\":{\"POSITION\":0},\"indices\":3}]}],%s"
           "\"buffers\":[{\"byteLength\":%zu}]}",
           views, b.n);
  n = make_glb(json, &b, buf);
  expect_error(buf, n, "glb", "TEXCOORD_0");
  /* no triangles: only lines */
  snprintf(json, sizeof json,
           "{\"asset\":{\"version\":\"2.0\"},\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},"
           "\"mode\":1}]}],%s\"buffers\":[{\"byteLength\":%zu}]}",
           views, b.n);
  n = make_glb(json, &b, buf);
  expect_error(buf, n, "glb", "no triangles");
  /* an accessor index out of range, and a non-number where an index goes */
  snprintf(json, sizeof json,
           "{\"asset\":{\"version\":\"2.0\"},\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":\"0\"}}]}]}");
  n = make_glb(json, NULL, buf);
  expect_error(buf, n, "glb", "'POSITION' is not an index");
}

int main(void) {
  char dir[1024];
  const char *base = getenv("TMPDIR");
  snprintf(dir, sizeof dir, "%s/test_gltf.XXXXXX", base && *base ? base : "/tmp");
  if (!mkdtemp(dir)) {
    perror("mkdtemp");
    return 1;
  }
  RUN(test_nodes_and_strip);
  RUN(test_mirror);
  RUN(test_normals);
  RUN(test_welding);
  RUN(test_near_uvs);
  RUN(test_data_uri_and_sparse);
  test_round_trip(dir);
  test_bin_file(dir);
  RUN(test_errors);
  rmdir(dir);
  TEST_MAIN_END();
}
