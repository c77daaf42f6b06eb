/* ch_mesh_obj_read: an OBJ's mesh from its scan (ch_mesh_obj_internal.h).
 *
 * The scanner (ch_mesh_scan.c) already reads every token the way OpenMesh
 * 9.0's OBJReader does (two passes, floats through strtof in the "C"
 * locale, indices resolved as its second pass resolves them) and rejects
 * what that reader would misread. Building the mesh from what it kept is
 * what OpenMesh's reader and the shim's importer did after it, without
 * parsing the file a third time through std::istream (5.3 of 12.7 s for a
 * 2.1M-triangle OBJ). The result is the same mesh, value for value: the
 * OBJ fuzz target compares the two on every input (and its replays on the
 * corpus, the test meshes and the bundled models), test_mesh the numbers
 * with strtof's. */
#include "ch_mesh_obj_internal.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* Indexes values of n floats by their exact bits, in order of first
 * appearance (open addressing; the table stays at most half full, doubling
 * as the distinct values grow). */
typedef struct dedup {
  int n;
  const float *values; /* the scan's list the keys index */
  int *slot;           /* -1: empty, else an index into first */
  size_t mask;
  int *first; /* distinct values, as indices into values */
  int count;
} dedup;

/* expect: about how many distinct values to make room for at once. */
static int dedup_init(dedup *d, int n, const float *values, size_t most, size_t expect) {
  size_t size = 1024;
  while (size < 2 * expect) size *= 2;
  d->n = n;
  d->values = values;
  d->mask = size - 1;
  d->count = 0;
  d->slot = malloc((d->mask + 1) * sizeof *d->slot);
  d->first = malloc((most > 0 ? most : 1) * sizeof *d->first);
  if (!d->slot || !d->first) return -1;
  memset(d->slot, 0xff, (d->mask + 1) * sizeof *d->slot);
  return 0;
}

static void dedup_free(dedup *d) {
  free(d->slot);
  free(d->first);
}

static uint32_t bits(float f) {
  uint32_t u;
  memcpy(&u, &f, sizeof u);
  return u;
}

static size_t dedup_hash(const dedup *d, const float *v) {
  uint64_t h = 0x9e3779b97f4a7c15u;
  for (int k = 0; k < d->n; k++) h = (h ^ bits(v[k])) * 0xff51afd7ed558ccdu;
  return (size_t)(h ^ (h >> 29));
}

/* Doubles the table (-1 out of memory). */
static int dedup_grow(dedup *d) {
  size_t size = 2 * (d->mask + 1);
  int *slot = malloc(size * sizeof *slot);
  if (!slot) return -1;
  memset(slot, 0xff, size * sizeof *slot);
  for (int s = 0; s < d->count; s++) {
    size_t at = dedup_hash(d, &d->values[(size_t)d->first[s] * (size_t)d->n]) & (size - 1);
    while (slot[at] >= 0) at = (at + 1) & (size - 1);
    slot[at] = s;
  }
  free(d->slot);
  d->slot = slot;
  d->mask = size - 1;
  return 0;
}

/* The distinct value number of values[i] (a new one if unseen; -1 out of
 * memory). */
static int dedup_add(dedup *d, int i) {
  if (2 * (size_t)d->count >= d->mask + 1 && dedup_grow(d)) return -1;
  const float *v = &d->values[(size_t)i * (size_t)d->n];
  for (size_t at = dedup_hash(d, v) & d->mask;; at = (at + 1) & d->mask) {
    int s = d->slot[at];
    if (s < 0) {
      d->slot[at] = d->count;
      d->first[d->count] = i;
      return d->count++;
    }
    const float *w = &d->values[(size_t)d->first[s] * (size_t)d->n];
    int same = 1;
    for (int k = 0; k < d->n; k++) same &= bits(v[k]) == bits(w[k]);
    if (same) return s;
  }
}

int ch_mesh_share_values(int n, const float *list, size_t listed, const int *idx, size_t corners, double **values,
                         int **corner, int *count) {
  dedup d;
  *values = NULL;
  *count = 0;
  int *number = malloc((listed > 0 ? listed : 1) * sizeof *number);
  /* A list the corners index (an OBJ's vt) holds mostly distinct values;
   * one value per corner repeats a vertex's about as often as it has
   * corners: a table sized for the whole list there missed the cache. */
  int ok = dedup_init(&d, n, list, listed, idx ? listed : listed / 4) == 0 && number;
  if (ok) ok = (*corner = malloc((corners > 0 ? corners : 1) * sizeof **corner)) != NULL;
  else
    *corner = NULL;
  if (ok) {
    /* number[i]: first the listed value's class (the first listed index with
     * its bits), then, for that first index, its number by first use */
    for (size_t i = 0; ok && i < listed; i++) {
      int s = dedup_add(&d, (int)i);
      if (s < 0)
        ok = 0;
      else
        number[i] = d.first[s];
    }
  }
  /* (the room for the class numbers by first use, -1 unused) */
  int *order = ok ? malloc((listed > 0 ? listed : 1) * sizeof *order) : NULL;
  if (ok && !order) ok = 0;
  if (ok) {
    int *canon = number, used = 0;
    memset(order, 0xff, listed * sizeof *order);
    for (size_t c = 0; c < corners; c++) {
      int r = canon[idx ? (size_t)idx[c] : c];
      if (order[r] < 0) {
        order[r] = used;
        d.first[used++] = r;
      }
      (*corner)[c] = order[r];
    }
    *count = used;
    ok = (*values = malloc((used > 0 ? (size_t)used : 1) * (size_t)n * sizeof **values)) != NULL;
    for (int i = 0; ok && i < used; i++)
      for (int k = 0; k < n; k++)
        (*values)[(size_t)i * (size_t)n + (size_t)k] = list[(size_t)d.first[i] * (size_t)n + (size_t)k];
  }
  free(number);
  free(order);
  dedup_free(&d);
  if (!ok) {
    free(*corner);
    *corner = NULL;
    *count = 0;
  }
  return ok ? 0 : -1;
}

static ch_status build(const ch_mesh_scan *s, const char *name, ch_mesh *out, ch_error *err) {
  size_t nv = (size_t)s->num_vertices, nf = (size_t)s->num_faces, nc = (size_t)s->num_corners;
  const int *fs = s->obj_face_start;
  /* UVs on every face or on none (the scanner checked each face's corners). */
  size_t with_uv = 0, first_without = nf;
  for (size_t f = 0; f < nf; f++) {
    if (s->obj_corner_tex[fs[f]] >= 0)
      with_uv++;
    else if (first_without == nf)
      first_without = f;
  }
  if (with_uv > 0 && with_uv != nf)
    return ch_error_set(err, CH_ERR_INPUT, "%s: face %zu has no texture coordinates while other faces have them", name,
                        first_without + 1);
  /* Normals: used where every corner of every face names one (OpenMesh
   * hands them over per corner; a face with some is "partial"). */
  size_t complete = 0, partial = 0;
  for (size_t f = 0; f < nf; f++) {
    int n = fs[f + 1] - fs[f], named = 0;
    for (int c = fs[f]; c < fs[f + 1]; c++) named += s->obj_corner_normal[c] >= 0;
    complete += named == n;
    partial += named > 0 && named < n;
  }
  int use_normals = complete > 0 && complete == nf;
  if ((complete > 0 || partial > 0) && !use_normals)
    ch_warn(err, "%s: only some faces have normals (vn) on every corner; normals ignored", name);

  ch_mesh m;
  memset(&m, 0, sizeof m);
  m.num_positions = (int)nv;
  m.num_faces = (int)nf;
  m.num_corners = (int)nc;
  m.positions = nv > 0 ? malloc(3 * nv * sizeof *m.positions) : NULL;
  m.face_start = malloc((nf + 1) * sizeof *m.face_start);
  m.corner_position = nc > 0 ? malloc(nc * sizeof *m.corner_position) : NULL;
  if ((nv > 0 && !m.positions) || !m.face_start || (nc > 0 && !m.corner_position)) goto nomem;
  for (size_t i = 0; i < 3 * nv; i++) m.positions[i] = s->obj_pos[i];
  memcpy(m.face_start, fs, (nf + 1) * sizeof *fs);
  if (nc > 0) memcpy(m.corner_position, s->obj_corner_pos, nc * sizeof *m.corner_position);
  if (with_uv > 0 && ch_mesh_share_values(2, s->obj_tex, (size_t)s->num_texcoords, s->obj_corner_tex, nc, &m.uvs,
                                          &m.corner_uv, &m.num_uvs))
    goto nomem;
  if (use_normals && ch_mesh_share_values(3, s->obj_normal, (size_t)s->num_normals, s->obj_corner_normal, nc,
                                          &m.normals, &m.corner_normal, &m.num_normals))
    goto nomem;
  *out = m;
  return CH_OK;
nomem:
  ch_mesh_free(&m);
  return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory", name);
}

ch_status ch_mesh_read_obj(const char *data, size_t size, const char *name, ch_mesh *out, ch_error *err) {
  memset(out, 0, sizeof *out);
  if (size == 0) return ch_error_set(err, CH_ERR_INPUT, "%s: file is empty", name);
  ch_mesh_scan s;
  ch_error scan_err = {0};
  ch_status st = ch_mesh_scan_obj_values(data, size, &s, &scan_err);
  if (st == CH_OK)
    st = build(&s, name, out, err);
  else if (st == CH_ERR_NOMEM)
    st = ch_error_set(err, st, "%s: out of memory", name);
  else
    st = ch_error_set(err, st, "%s: %s", name, scan_err.message);
  ch_mesh_scan_free(&s);
  return st;
}
