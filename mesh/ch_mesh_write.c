/* ch_mesh_write.c: OBJ and binary PLY output, atomic and deterministic
 * (same mesh, same bytes: no timestamps, "%.9g" in the C locale, which
 * round-trips every float exactly). */
#include "ch_mesh.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ch_file.h"

/* The writers trust the counts but never index outside the arrays: a
 * malformed mesh is refused before anything is written. */
static ch_status check_writable(const ch_mesh *m, const char *path, ch_error *err) {
  if (m->num_faces < 0 || m->num_positions < 0 || (m->num_faces > 0 && !m->face_start) ||
      (m->num_positions > 0 && !m->positions))
    return ch_error_set(err, CH_ERR_INPUT, "%s: cannot write an inconsistent mesh", path);
  if (m->num_faces == 0) return CH_OK;
  if (m->face_start[0] != 0 || m->face_start[m->num_faces] != m->num_corners ||
      !m->corner_position)
    return ch_error_set(err, CH_ERR_INPUT, "%s: cannot write an inconsistent mesh", path);
  for (int f = 0; f < m->num_faces; f++) {
    if (m->face_start[f + 1] < m->face_start[f])
      return ch_error_set(err, CH_ERR_INPUT, "%s: face %d: inconsistent corner offsets", path, f + 1);
    for (int c = m->face_start[f]; c < m->face_start[f + 1]; c++) {
      if (m->corner_position[c] < 0 || m->corner_position[c] >= m->num_positions ||
          (m->corner_uv && (m->corner_uv[c] < 0 || m->corner_uv[c] >= m->num_uvs || !m->uvs)) ||
          (m->corner_normal &&
           (m->corner_normal[c] < 0 || m->corner_normal[c] >= m->num_normals || !m->normals)))
        return ch_error_set(err, CH_ERR_INPUT, "%s: face %d: index out of range", path, f + 1);
    }
  }
  return CH_OK;
}

/* ---- OBJ ---------------------------------------------------------------- */

static void write_obj_body(FILE *fp, const ch_mesh *m) {
  fputs("# chisel\n", fp);
  for (int v = 0; v < m->num_positions; v++) {
    const double *p = &m->positions[3 * (size_t)v];
    fprintf(fp, "v %.9g %.9g %.9g\n", p[0], p[1], p[2]);
  }
  if (m->corner_uv)
    for (int t = 0; t < m->num_uvs; t++)
      fprintf(fp, "vt %.9g %.9g\n", m->uvs[2 * (size_t)t], m->uvs[2 * (size_t)t + 1]);
  if (m->corner_normal)
    for (int n = 0; n < m->num_normals; n++) {
      const double *p = &m->normals[3 * (size_t)n];
      fprintf(fp, "vn %.9g %.9g %.9g\n", p[0], p[1], p[2]);
    }
  for (int f = 0; f < m->num_faces; f++) {
    fputc('f', fp);
    for (int c = m->face_start[f]; c < m->face_start[f + 1]; c++) {
      fprintf(fp, " %d", m->corner_position[c] + 1);
      if (m->corner_uv) fprintf(fp, "/%d", m->corner_uv[c] + 1);
      if (m->corner_normal) fprintf(fp, m->corner_uv ? "/%d" : "//%d", m->corner_normal[c] + 1);
    }
    fputc('\n', fp);
  }
}

ch_status ch_mesh_write_obj(const char *path, const ch_mesh *mesh, ch_error *err) {
  ch_status st = check_writable(mesh, path, err);
  if (st != CH_OK) return st;
  ch_atomic_file f;
  st = ch_atomic_open(&f, path, err);
  if (st != CH_OK) return st;
  write_obj_body(f.fp, mesh);
  return ch_atomic_commit(&f, err);
}

/* ---- PLY ---------------------------------------------------------------- */

/* Output vertex k of the PLY: a position with the UV and normal of one
 * corner. Vertices 0..num_positions-1 are the positions themselves, with the
 * attributes of their first corner; corners that disagree with it get extra
 * vertices, numbered in order of their first corner. */
typedef struct split {
  int *vertex_of_corner; /* num_corners */
  int *source_corner;    /* per output vertex: corner giving UV/normal, or -1 */
  int num_vertices;
} split;

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

/* Orders by (position, uv, normal) only. */
static int key_less(const corner_key *a, const corner_key *b) {
  if (a->pos != b->pos) return a->pos < b->pos;
  if (a->uv != b->uv) return a->uv < b->uv;
  return a->normal < b->normal;
}

static int cmp_first_corner(const void *pa, const void *pb) {
  const corner_key *a = pa, *b = pb;
  return (a->corner > b->corner) - (a->corner < b->corner);
}

static corner_key key_of(const ch_mesh *m, int c) {
  corner_key k = {m->corner_position[c], m->corner_uv ? m->corner_uv[c] : 0,
                  m->corner_normal ? m->corner_normal[c] : 0, c};
  return k;
}

static int split_vertices(const ch_mesh *m, split *s) {
  size_t np = (size_t)m->num_positions, nc = (size_t)m->num_corners;
  memset(s, 0, sizeof *s);
  s->vertex_of_corner = malloc((nc ? nc : 1) * sizeof(int));
  int *rep = malloc((np ? np : 1) * sizeof(int));
  corner_key *odd = malloc((nc ? nc : 1) * sizeof *odd);
  corner_key *groups = malloc((nc ? nc : 1) * sizeof *groups);
  s->source_corner = malloc((np + nc + 1) * sizeof(int));
  if (!s->vertex_of_corner || !rep || !odd || !groups || !s->source_corner) {
    free(rep), free(odd), free(groups);
    free(s->vertex_of_corner), free(s->source_corner);
    return 0;
  }
  for (size_t v = 0; v < np; v++) rep[v] = -1;
  size_t nodd = 0;
  for (size_t c = 0; c < nc; c++) {
    corner_key k = key_of(m, (int)c);
    if (rep[k.pos] < 0) rep[k.pos] = (int)c;
    corner_key r = key_of(m, rep[k.pos]);
    if (k.uv == r.uv && k.normal == r.normal) s->vertex_of_corner[c] = k.pos;
    else odd[nodd++] = k;
  }
  for (size_t v = 0; v < np; v++) s->source_corner[v] = rep[v];
  /* Group the disagreeing corners by (position, uv, normal); each group's
   * first corner decides its order. */
  qsort(odd, nodd, sizeof *odd, cmp_key);
  size_t ng = 0;
  for (size_t i = 0; i < nodd; i++)
    if (i == 0 || key_less(&odd[i - 1], &odd[i])) groups[ng++] = odd[i];
  qsort(groups, ng, sizeof *groups, cmp_first_corner);
  for (size_t g = 0; g < ng; g++) {
    s->source_corner[np + g] = groups[g].corner;
    groups[g].corner = (int)(np + g); /* reuse: output vertex of the group */
  }
  /* Each odd corner finds its group by binary search on the key. */
  qsort(groups, ng, sizeof *groups, cmp_key);
  for (size_t i = 0; i < nodd; i++) {
    size_t lo = 0, hi = ng;
    while (lo < hi) {
      size_t mid = (lo + hi) / 2;
      if (key_less(&groups[mid], &odd[i])) lo = mid + 1;
      else hi = mid;
    }
    s->vertex_of_corner[odd[i].corner] = groups[lo].corner;
  }
  s->num_vertices = (int)(np + ng);
  free(rep);
  free(odd);
  free(groups);
  return 1;
}

static void put_u32(FILE *fp, uint32_t u) {
  unsigned char b[4] = {(unsigned char)u, (unsigned char)(u >> 8), (unsigned char)(u >> 16),
                        (unsigned char)(u >> 24)};
  fwrite(b, 1, 4, fp);
}

static void put_f32(FILE *fp, double x) {
  float f = (float)x;
  uint32_t u;
  memcpy(&u, &f, 4);
  put_u32(fp, u);
}

static void write_ply_body(FILE *fp, const ch_mesh *m, const split *s) {
  int most = 0;
  for (int f = 0; f < m->num_faces; f++)
    if (m->face_start[f + 1] - m->face_start[f] > most) most = m->face_start[f + 1] - m->face_start[f];
  int wide = most > 255; /* uchar counts cannot hold it */
  fprintf(fp,
          "ply\nformat binary_little_endian 1.0\ncomment chisel\nelement vertex %d\n"
          "property float x\nproperty float y\nproperty float z\n",
          s->num_vertices);
  if (m->corner_normal) fputs("property float nx\nproperty float ny\nproperty float nz\n", fp);
  if (m->corner_uv) fputs("property float u\nproperty float v\n", fp);
  fprintf(fp, "element face %d\nproperty list %s int vertex_indices\nend_header\n", m->num_faces,
          wide ? "int" : "uchar");
  for (int v = 0; v < s->num_vertices; v++) {
    int c = s->source_corner[v];
    int p = v < m->num_positions ? v : m->corner_position[c];
    for (int k = 0; k < 3; k++) put_f32(fp, m->positions[3 * (size_t)p + k]);
    if (m->corner_normal)
      for (int k = 0; k < 3; k++)
        put_f32(fp, c < 0 ? 0.0 : m->normals[3 * (size_t)m->corner_normal[c] + k]);
    if (m->corner_uv)
      for (int k = 0; k < 2; k++) put_f32(fp, c < 0 ? 0.0 : m->uvs[2 * (size_t)m->corner_uv[c] + k]);
  }
  for (int f = 0; f < m->num_faces; f++) {
    int n = m->face_start[f + 1] - m->face_start[f];
    if (wide) put_u32(fp, (uint32_t)n);
    else fputc(n, fp);
    for (int c = m->face_start[f]; c < m->face_start[f + 1]; c++)
      put_u32(fp, (uint32_t)s->vertex_of_corner[c]);
  }
}

ch_status ch_mesh_write_ply(const char *path, const ch_mesh *mesh, ch_error *err) {
  ch_status st = check_writable(mesh, path, err);
  if (st != CH_OK) return st;
  split s;
  if (!split_vertices(mesh, &s)) return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory", path);
  ch_atomic_file f;
  st = ch_atomic_open(&f, path, err);
  if (st == CH_OK) {
    write_ply_body(f.fp, mesh, &s);
    st = ch_atomic_commit(&f, err);
  }
  free(s.vertex_of_corner);
  free(s.source_corner);
  return st;
}
