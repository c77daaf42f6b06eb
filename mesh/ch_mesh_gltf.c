/* ch_mesh_gltf.c: glTF 2.0 binary (.glb) output, the format real-time
 * engines, three.js and Blender take. Written from the Khronos glTF 2.0
 * specification: a 12-byte header, a JSON chunk (padded with spaces) and a
 * BIN chunk (padded with zeros), both 4-byte aligned; one mesh, one
 * triangle primitive with POSITION, NORMAL and TEXCOORD_0 accessors and
 * uint32 indices.
 *
 * glTF has no face-varying attributes: a vertex is one (position, UV,
 * normal) triple, so positions are split where corners disagree (at walls,
 * creases and UV seams), as every glTF exporter does. Coordinates are
 * written as the OBJ has them (importers treat both as +Y up, so the two
 * files open the same way); UVs follow glTF's convention of v down
 * (TEXCOORD_0 = (u, 1 - v)). Deterministic: vertices in order of their
 * first corner, no timestamps. */
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ch_file.h"
#include "ch_le_internal.h"
#include "ch_mesh.h"
#include "ch_version.h"

/* One output vertex per distinct (position, uv, normal) of the corners. */
typedef struct corner_key {
  int pos, uv, normal, corner;
} corner_key;

static int cmp_key(const void *pa, const void *pb) {
  const corner_key *a = pa, *b = pb;
  if (a->pos != b->pos) return a->pos < b->pos ? -1 : 1;
  if (a->uv != b->uv) return a->uv < b->uv ? -1 : 1;
  if (a->normal != b->normal) return a->normal < b->normal ? -1 : 1;
  return (a->corner > b->corner) - (a->corner < b->corner);
}

static int cmp_corner(const void *pa, const void *pb) {
  const corner_key *a = pa, *b = pb;
  return (a->corner > b->corner) - (a->corner < b->corner);
}

/* vertex_of_corner[c] for every corner, source[k] the first corner of
 * output vertex k; returns the vertex count, or -1 without memory. */
static int weld_corners(const ch_mesh *m, int *vertex_of_corner, int **source_out) {
  size_t nc = (size_t)m->num_corners;
  corner_key *keys = malloc((nc ? nc : 1) * sizeof *keys);
  int *source = malloc((nc ? nc : 1) * sizeof *source);
  if (!keys || !source) {
    free(keys);
    free(source);
    return -1;
  }
  for (size_t c = 0; c < nc; c++)
    keys[c] = (corner_key){m->corner_position[c], m->corner_uv ? m->corner_uv[c] : 0,
                           m->corner_normal ? m->corner_normal[c] : 0, (int)c};
  qsort(keys, nc, sizeof *keys, cmp_key);
  /* Each group's first corner represents it (corner holds the group's
   * first corner for every member); numbering groups by that corner makes
   * the order independent of the sort. */
  size_t ng = 0;
  for (size_t i = 0; i < nc; i++) {
    int fresh = i == 0 || cmp_key(&(corner_key){keys[i - 1].pos, keys[i - 1].uv, keys[i - 1].normal, 0},
                                  &(corner_key){keys[i].pos, keys[i].uv, keys[i].normal, 0}) != 0;
    if (fresh) source[ng++] = keys[i].corner;
    vertex_of_corner[keys[i].corner] = source[ng - 1]; /* the group's first corner, for now */
  }
  /* Renumber: vertex k is the k-th group in order of first corner. */
  for (size_t g = 0; g < ng; g++) keys[g] = (corner_key){0, 0, 0, source[g]};
  qsort(keys, ng, sizeof *keys, cmp_corner);
  int *rank = malloc((nc ? nc : 1) * sizeof *rank);
  if (!rank) {
    free(keys);
    free(source);
    return -1;
  }
  for (size_t g = 0; g < ng; g++) {
    source[g] = keys[g].corner;
    rank[keys[g].corner] = (int)g;
  }
  for (size_t c = 0; c < nc; c++) vertex_of_corner[c] = rank[vertex_of_corner[c]];
  free(rank);
  free(keys);
  *source_out = source;
  return (int)ng;
}

/* Appends printf output to a growing JSON buffer; 0 without memory. */
typedef struct text {
  char *s;
  size_t len, cap;
} text;

#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
static int text_add(text *t, const char *fmt, ...) {
  for (;;) {
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(t->s ? t->s + t->len : NULL, t->s ? t->cap - t->len : 0, fmt, ap);
    va_end(ap);
    if (n < 0) return 0;
    if (t->s && t->len + (size_t)n < t->cap) {
      t->len += (size_t)n;
      return 1;
    }
    size_t cap = t->cap ? 2 * t->cap : 4096;
    while (cap < t->len + (size_t)n + 1) cap *= 2;
    char *s = realloc(t->s, cap);
    if (!s) return 0;
    t->s = s;
    t->cap = cap;
  }
}

ch_status ch_mesh_write_glb(const char *path, const ch_mesh *mesh, ch_error *err) {
  const ch_mesh *m = mesh;
  if (m->num_faces < 0 || m->num_positions < 0 || (m->num_faces > 0 && (!m->face_start || !m->corner_position)) ||
      (m->num_positions > 0 && !m->positions))
    return ch_error_set(err, CH_ERR_INPUT, "%s: cannot write an inconsistent mesh", path);
  long num_triangles = 0;
  for (int f = 0; f < m->num_faces; f++) {
    int n = m->face_start[f + 1] - m->face_start[f];
    if (n < 3) return ch_error_set(err, CH_ERR_INPUT, "%s: face %d has %d corners", path, f + 1, n);
    for (int c = m->face_start[f]; c < m->face_start[f + 1]; c++)
      if (m->corner_position[c] < 0 || m->corner_position[c] >= m->num_positions ||
          (m->corner_uv && (m->corner_uv[c] < 0 || m->corner_uv[c] >= m->num_uvs)) ||
          (m->corner_normal && (m->corner_normal[c] < 0 || m->corner_normal[c] >= m->num_normals)))
        return ch_error_set(err, CH_ERR_INPUT, "%s: face %d: index out of range", path, f + 1);
    num_triangles += n - 2;
  }
  /* glTF sizes are uint32: the BIN chunk must stay under 4 GB. */
  size_t nc = (size_t)m->num_corners;
  int *vertex_of_corner = malloc((nc ? nc : 1) * sizeof(int)), *source = NULL;
  int nv = vertex_of_corner ? weld_corners(m, vertex_of_corner, &source) : -1;
  if (nv < 0) {
    free(vertex_of_corner);
    return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory", path);
  }
  int has_n = m->corner_normal != NULL, has_uv = m->corner_uv != NULL;
  size_t pos_bytes = 12 * (size_t)nv, nrm_bytes = has_n ? 12 * (size_t)nv : 0, uv_bytes = has_uv ? 8 * (size_t)nv : 0;
  size_t idx_bytes = 12 * (size_t)num_triangles;
  size_t bin_len = pos_bytes + nrm_bytes + uv_bytes + idx_bytes; /* every view is a multiple of 4 */
  if (bin_len > 0xF0000000u) {
    free(vertex_of_corner);
    free(source);
    return ch_error_set(err, CH_ERR_INPUT, "%s: %ld triangles are too many for one glTF buffer (4 GB)", path,
                        num_triangles);
  }
  unsigned char *bin = malloc(bin_len ? bin_len : 1);
  if (!bin) {
    free(vertex_of_corner);
    free(source);
    return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory", path);
  }
  /* POSITION needs its bounds (glTF 2.0 §5.1.1: min and max are required),
   * taken from the float32 values written. */
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  unsigned char *o = bin;
  for (int v = 0; v < nv; v++) {
    const double *p = &m->positions[3 * (size_t)m->corner_position[source[v]]];
    for (int k = 0; k < 3; k++) {
      float f = (float)p[k];
      if (f < lo[k]) lo[k] = f;
      if (f > hi[k]) hi[k] = f;
      o = ch_le_f32(o, p[k]);
    }
  }
  if (has_n)
    for (int v = 0; v < nv; v++) {
      const double *n = &m->normals[3 * (size_t)m->corner_normal[source[v]]];
      double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
      /* glTF requires unit normals; a zero normal gets +z rather than NaN. */
      double q[3] = {0, 0, 1};
      if (len > 0)
        for (int k = 0; k < 3; k++) q[k] = n[k] / len;
      for (int k = 0; k < 3; k++) o = ch_le_f32(o, q[k]);
    }
  if (has_uv)
    for (int v = 0; v < nv; v++) {
      const double *t = &m->uvs[2 * (size_t)m->corner_uv[source[v]]];
      o = ch_le_f32(o, t[0]);
      o = ch_le_f32(o, 1.0 - t[1]);
    }
  for (int f = 0; f < m->num_faces; f++) /* fans: chisel's faces are triangles, a base mesh's convex */
    for (int c = m->face_start[f] + 1; c + 1 < m->face_start[f + 1]; c++) {
      o = ch_le_u32(o, (uint32_t)vertex_of_corner[m->face_start[f]]);
      o = ch_le_u32(o, (uint32_t)vertex_of_corner[c]);
      o = ch_le_u32(o, (uint32_t)vertex_of_corner[c + 1]);
    }
  free(vertex_of_corner);
  free(source);

  /* The JSON: buffer views in the BIN's order, one accessor each. */
  text j = {0};
  int ok = text_add(&j, "{\"asset\":{\"version\":\"2.0\",\"generator\":\"chisel %s\"},", CH_VERSION_STRING);
  ok = ok && text_add(&j, "\"scene\":0,\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0,\"name\":\"chisel\"}],");
  int view = 0;
  size_t offset = 0;
  char attributes[128] = "";
  int na = 0;
  ok = ok && text_add(&j, "\"bufferViews\":[");
  const size_t sizes[4] = {pos_bytes, nrm_bytes, uv_bytes, idx_bytes};
  for (int a = 0; a < 4; a++) {
    if (sizes[a] == 0 && a != 0 && a != 3) continue;
    ok = ok && text_add(&j, "%s{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu,\"target\":%d}", view ? "," : "",
                        offset, sizes[a], a == 3 ? 34963 : 34962);
    offset += sizes[a];
    view++;
  }
  ok = ok && text_add(&j, "],\"accessors\":[");
  ok = ok && text_add(&j,
                      "{\"bufferView\":0,\"componentType\":5126,\"count\":%d,\"type\":\"VEC3\","
                      "\"min\":[%.9g,%.9g,%.9g],\"max\":[%.9g,%.9g,%.9g]}",
                      nv, nv ? lo[0] : 0.0, nv ? lo[1] : 0.0, nv ? lo[2] : 0.0, nv ? hi[0] : 0.0, nv ? hi[1] : 0.0,
                      nv ? hi[2] : 0.0);
  na += snprintf(attributes + na, sizeof attributes - (size_t)na, "\"POSITION\":0");
  int acc = 1;
  view = 1;
  if (has_n) {
    ok = ok && text_add(&j, ",{\"bufferView\":%d,\"componentType\":5126,\"count\":%d,\"type\":\"VEC3\"}", view, nv);
    na += snprintf(attributes + na, sizeof attributes - (size_t)na, ",\"NORMAL\":%d", acc++);
    view++;
  }
  if (has_uv) {
    ok = ok && text_add(&j, ",{\"bufferView\":%d,\"componentType\":5126,\"count\":%d,\"type\":\"VEC2\"}", view, nv);
    na += snprintf(attributes + na, sizeof attributes - (size_t)na, ",\"TEXCOORD_0\":%d", acc++);
    view++;
  }
  ok = ok && text_add(&j, ",{\"bufferView\":%d,\"componentType\":5125,\"count\":%ld,\"type\":\"SCALAR\"}", view,
                      3 * num_triangles);
  ok = ok && text_add(&j, "],\"meshes\":[{\"name\":\"chisel\",\"primitives\":[{\"attributes\":{%s},\"indices\":%d,"
                      "\"mode\":4}]}],\"buffers\":[{\"byteLength\":%zu}]}",
                      attributes, acc, bin_len);
  while (ok && j.len % 4) ok = text_add(&j, " "); /* the JSON chunk is padded with spaces */
  if (!ok) {
    free(j.s);
    free(bin);
    return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory", path);
  }
  unsigned char header[20], bin_header[8];
  ch_le_u32(header, 0x46546C67u); /* "glTF" */
  ch_le_u32(header + 4, 2);
  ch_le_u32(header + 8, (uint32_t)(12 + 8 + j.len + 8 + bin_len));
  ch_le_u32(header + 12, (uint32_t)j.len);
  ch_le_u32(header + 16, 0x4E4F534Au); /* "JSON" */
  ch_le_u32(bin_header, (uint32_t)bin_len);
  ch_le_u32(bin_header + 4, 0x004E4942u); /* "BIN\0" */
  ch_atomic_file f;
  ch_status st = ch_atomic_open(&f, path, err);
  if (st == CH_OK) {
    fwrite(header, 1, sizeof header, f.fp);
    fwrite(j.s, 1, j.len, f.fp);
    fwrite(bin_header, 1, sizeof bin_header, f.fp);
    fwrite(bin, 1, bin_len, f.fp);
    st = ch_atomic_commit(&f, err); /* a short write shows in the commit's flush and error check */
  }
  free(j.s);
  free(bin);
  return st;
}
