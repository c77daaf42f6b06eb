/* ch_mesh_write.c: OBJ and binary PLY output, atomic and deterministic
 * (same mesh, same bytes: no timestamps; numbers with 9 significant digits
 * as "%.9g" prints them, which round-trips every float exactly). OBJ text
 * is formatted in parallel blocks by a fast formatter (printf's exact
 * decimal conversion was 80% of the time of writing a 2M-triangle mesh). */
#include "ch_mesh.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <omp.h>

#include "ch_file.h"
#include "ch_le_internal.h"

enum { FACE_OK, FACE_BAD_OFFSETS, FACE_BAD_INDEX };

/* What is wrong with face f, if anything: its corner offsets, or an index. */
static int face_fault(const ch_mesh *m, int f) {
  if (m->face_start[f] < 0 || m->face_start[f + 1] < m->face_start[f] || m->face_start[f + 1] > m->num_corners)
    return FACE_BAD_OFFSETS;
  for (int c = m->face_start[f]; c < m->face_start[f + 1]; c++)
    if (m->corner_position[c] < 0 || m->corner_position[c] >= m->num_positions ||
        (m->corner_uv && (m->corner_uv[c] < 0 || m->corner_uv[c] >= m->num_uvs || !m->uvs)) ||
        (m->corner_normal && (m->corner_normal[c] < 0 || m->corner_normal[c] >= m->num_normals || !m->normals)))
      return FACE_BAD_INDEX;
  return FACE_OK;
}

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
  /* On all threads (a serial pass was 10 ms of a 2M-triangle write); the
   * first bad face is the one named. */
  int first_bad = m->num_faces;
#pragma omp parallel for schedule(static) reduction(min : first_bad)
  for (int f = 0; f < m->num_faces; f++)
    if (face_fault(m, f) != FACE_OK && f < first_bad) first_bad = f;
  if (first_bad == m->num_faces) return CH_OK;
  return ch_error_set(err, CH_ERR_INPUT, "%s: face %d: %s", path, first_bad + 1,
                      face_fault(m, first_bad) == FACE_BAD_OFFSETS ? "inconsistent corner offsets"
                                                                   : "index out of range");
}

/* ---- OBJ ---------------------------------------------------------------- */

/* Two decimal digits at a time (the divisions by 100 are multiplications). */
static const char digit_pairs[201] =
    "00010203040506070809101112131415161718192021222324252627282930313233343536373839"
    "40414243444546474849505152535455565758596061626364656667686970717273747576777879"
    "8081828384858687888990919293949596979899";

/* The decimal digits of v: four at a time, then by comparison (a loop
 * multiplying by 10 took a third of put_uint's time on 7-digit indices). */
static int decimal_digits(unsigned long v) {
  int n = 1;
  while (v >= 10000) {
    v /= 10000;
    n += 4;
  }
  return n + (v >= 10) + (v >= 100) + (v >= 1000);
}

static char *put_uint(char *o, unsigned long v) {
  int n = decimal_digits(v); /* then written from the last */
  char *end = o + n;
  while (v >= 100) {
    unsigned long q = v / 100, r = v - 100 * q;
    *--end = digit_pairs[2 * r + 1];
    *--end = digit_pairs[2 * r];
    v = q;
  }
  if (v >= 10) {
    *--end = digit_pairs[2 * v + 1];
    *--end = digit_pairs[2 * v];
  } else {
    *--end = (char)('0' + v);
  }
  return o + n;
}

/* x as "%.9g" would print it: 9 significant digits, trailing zeros dropped,
 * exponent form below 1e-4 or from 1e9. The digits come from rounding
 * |x| * 10^(8 - e) to an integer in double precision, so in rare ties the
 * last digit can differ from printf's exact conversion by one; every float
 * still reads back exactly. Values outside 1e-290..1e290 go to snprintf.
 * No libm on the common path (a third of the time of printing an OBJ went
 * to log10, floor and nearbyint calls): the decimal exponent is estimated
 * from the binary one and corrected by the rounding test below, and the
 * rounding to an integer adds and subtracts 2^52 (round half to even, as
 * nearbyint in the default rounding mode, for values below 2^52). */
static char *put_g9(char *o, double x) {
  static const double p10[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                               1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
  if (x == 0.0) {
    if (signbit(x)) *o++ = '-';
    *o++ = '0';
    return o;
  }
  double ax = fabs(x);
  if (!(ax >= 1e-290 && ax <= 1e290)) return o + snprintf(o, 32, "%.9g", x);
  uint64_t bits;
  memcpy(&bits, &ax, sizeof bits);
  int e2 = (int)(bits >> 52) - 1023; /* ax in [2^e2, 2^(e2+1)): a normal number here */
  int e = (e2 * 78913) >> 18; /* floor(e2 log10 2), within one of floor(log10 ax) */
  uint32_t m = 0;
  for (int pass = 0; pass < 4; pass++) {
    int k = 8 - e;
    double scaled = k >= 0 ? (k <= 22 ? ax * p10[k] : ax * 1e22 * pow(10.0, k - 22))
                           : (-k <= 22 ? ax / p10[-k] : ax / 1e22 / pow(10.0, -k - 22));
    double r = (scaled + 0x1p52) - 0x1p52;
    if (r >= 1e9) {
      e++;
      continue;
    }
    if (r < 1e8) {
      e--;
      continue;
    }
    m = (uint32_t)r;
    break;
  }
  if (m == 0) return o + snprintf(o, 32, "%.9g", x);
  char d[10];
  for (int i = 8; i >= 1; i -= 2) {
    uint32_t q = m / 100, r = m - 100 * q;
    d[i] = digit_pairs[2 * r + 1];
    d[i - 1] = digit_pairs[2 * r];
    m = q;
  }
  d[0] = (char)('0' + m);
  int last = 8;
  while (last > 0 && d[last] == '0') last--;
  if (x < 0) *o++ = '-';
  if (e >= -4 && e < 9) {
    if (e >= 0) {
      for (int i = 0; i <= e; i++) *o++ = d[i];
      if (last > e) {
        *o++ = '.';
        for (int i = e + 1; i <= last; i++) *o++ = d[i];
      }
    } else {
      *o++ = '0';
      *o++ = '.';
      for (int i = 0; i < -e - 1; i++) *o++ = '0';
      for (int i = 0; i <= last; i++) *o++ = d[i];
    }
    return o;
  }
  *o++ = d[0];
  if (last > 0) {
    *o++ = '.';
    for (int i = 1; i <= last; i++) *o++ = d[i];
  }
  *o++ = 'e';
  *o++ = e < 0 ? '-' : '+';
  int ae = e < 0 ? -e : e;
  if (ae < 10) *o++ = '0';
  return put_uint(o, (unsigned long)ae);
}

/* The OBJ's lines in order: positions, UVs, normals, faces. */
typedef struct obj_lines {
  const ch_mesh *m;
  long nv, nt, nn, nf;
  int index_digits; /* of the largest index a face line prints */
} obj_lines;

/* Blocks of lines formatted by one thread, and the bytes a v, vt or vn
 * line may take: 2 + 3 x 18 + 1 (put_g9 writes 16 characters at most,
 * snprintf's terminator one more). The buffers (two rounds of two blocks
 * per thread) took a fixed 20-30 MB at a bound of 256 bytes a line, and
 * 15 MB at 16384 lines a block with room for 10-digit indices: at 130k
 * triangles that was a quarter of the run's peak memory. */
enum { OBJ_BLOCK = 1 << 13, OBJ_MAX_LINE = 80 };

/* Formats line i into o; returns the end. Faces longer than fit in
 * OBJ_MAX_LINE bytes are formatted by the caller. */
static char *obj_line(const obj_lines *L, long i, char *o) {
  const ch_mesh *m = L->m;
  if (i < L->nv) {
    const double *p = &m->positions[3 * (size_t)i];
    *o++ = 'v';
    for (int k = 0; k < 3; k++) {
      *o++ = ' ';
      o = put_g9(o, p[k]);
    }
  } else if ((i -= L->nv) < L->nt) {
    *o++ = 'v';
    *o++ = 't';
    for (int k = 0; k < 2; k++) {
      *o++ = ' ';
      o = put_g9(o, m->uvs[2 * (size_t)i + k]);
    }
  } else if ((i -= L->nt) < L->nn) {
    *o++ = 'v';
    *o++ = 'n';
    for (int k = 0; k < 3; k++) {
      *o++ = ' ';
      o = put_g9(o, m->normals[3 * (size_t)i + k]);
    }
  } else {
    i -= L->nn;
    *o++ = 'f';
    for (int c = m->face_start[i]; c < m->face_start[i + 1]; c++) {
      *o++ = ' ';
      o = put_uint(o, (unsigned long)m->corner_position[c] + 1);
      if (m->corner_uv) {
        *o++ = '/';
        o = put_uint(o, (unsigned long)m->corner_uv[c] + 1);
      }
      if (m->corner_normal) {
        *o++ = '/';
        if (!m->corner_uv) *o++ = '/';
        o = put_uint(o, (unsigned long)m->corner_normal[c] + 1);
      }
    }
  }
  *o++ = '\n';
  return o;
}

/* Bytes a face line can take: per corner a space, 3 indices and 2 slashes. */
static size_t face_line_bytes(const obj_lines *L, long f) {
  return 4 + (size_t)(L->m->face_start[f + 1] - L->m->face_start[f]) * (3 + 3 * (size_t)L->index_digits);
}

/* Formats blocks b0 .. b0 + n - 1 into bufs (one each; len 0 past the end);
 * called by every thread of a team, shares the blocks dynamically. */
static void format_round(const obj_lines *L, long total, long b0, int n, char **buf, size_t *cap, size_t *len,
                         int *failed) {
#pragma omp for schedule(dynamic, 1)
  for (int j = 0; j < n; j++) {
    long i0 = (b0 + j) * OBJ_BLOCK, i1 = i0 + OBJ_BLOCK < total ? i0 + OBJ_BLOCK : total;
    len[j] = 0;
    if (i0 >= total) continue;
    size_t need = 0;
    for (long i = i0; i < i1; i++)
      need += i >= L->nv + L->nt + L->nn ? face_line_bytes(L, i - L->nv - L->nt - L->nn) : OBJ_MAX_LINE;
    if (need > cap[j]) {
      char *nb = realloc(buf[j], need);
      if (!nb) {
#pragma omp atomic write
        *failed = 1;
        continue;
      }
      buf[j] = nb;
      cap[j] = need;
    }
    char *o = buf[j];
    for (long i = i0; i < i1; i++) o = obj_line(L, i, o);
    len[j] = (size_t)(o - buf[j]);
  }
}

/* 0 on success, -1 when out of memory, else the failed write's errno
 * (taken on the thread that wrote: errno is per thread). */
static int write_obj_body(FILE *fp, const ch_mesh *m) {
  fputs("# chisel\n", fp);
  long nv = m->num_positions, nt = m->corner_uv ? m->num_uvs : 0, nn = m->corner_normal ? m->num_normals : 0;
  long largest = nv > nt ? (nv > nn ? nv : nn) : (nt > nn ? nt : nn); /* (the indices are 1-based) */
  obj_lines L = {m, nv, nt, nn, m->num_faces, decimal_digits((unsigned long)largest)};
  long total = L.nv + L.nt + L.nn + L.nf;
  long nblocks = (total + OBJ_BLOCK - 1) / OBJ_BLOCK;
  /* Rounds of blocks in two buffer sets: while the team formats round r
   * into one set, one of its threads writes round r - 1 from the other (the
   * kernel's copy into the page cache took 3/4 of the time of writing a
   * 2M-triangle mesh, formatting the rest), in order, so the bytes do not
   * depend on the threads. */
  int per_round = 2 * omp_get_max_threads();
  char **buf = calloc(2 * (size_t)per_round, sizeof *buf);
  size_t *cap = calloc(2 * (size_t)per_round, sizeof *cap), *len = calloc(2 * (size_t)per_round, sizeof *len);
  int failed = !buf || !cap || !len, write_failed = 0; /* (write_failed: the errno) */
  long rounds = (nblocks + per_round - 1) / per_round;
  if (!failed) {
#pragma omp parallel
    for (long r = 0; r <= rounds; r++) {
      int prev = (int)((r + 1) & 1) * per_round, cur = (int)(r & 1) * per_round;
#pragma omp single nowait
      for (int j = 0; r > 0 && !write_failed && j < per_round; j++)
        if (len[prev + j] && fwrite(buf[prev + j], 1, len[prev + j], fp) != len[prev + j])
          write_failed = errno ? errno : EIO;
      if (r < rounds) format_round(&L, total, r * per_round, per_round, buf + cur, cap + cur, len + cur, &failed);
#pragma omp barrier
    }
  }
  if (buf)
    for (int j = 0; j < 2 * per_round; j++) free(buf[j]);
  free(buf);
  free(cap);
  free(len);
  return write_failed ? write_failed : failed ? -1 : 0;
}

ch_status ch_mesh_write_obj(const char *path, const ch_mesh *mesh, ch_error *err) {
  ch_status st = check_writable(mesh, path, err);
  if (st != CH_OK) return st;
  ch_atomic_file f;
  st = ch_atomic_open(&f, path, err);
  if (st != CH_OK) return st;
  if (write_obj_body(f.fp, mesh)) /* a write error names itself (ch_atomic_fail) */
    return ch_atomic_fail(&f, ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory", path), err);
  return ch_atomic_commit(&f, err);
}

/* ---- PLY ---------------------------------------------------------------- */

/* One PLY vertex per position, so the PLY is as closed as the mesh (no
 * vertex split at walls, creases or UV seams); UVs per face corner as the
 * face's `texcoord` list (u0 v0 u1 v1 ..., the wedge convention MeshLab
 * reads), and also per vertex as `s t` (what Blender's importer reads) when
 * every corner of each position has the same UV (within 1e-9). Normals are left out:
 * creases and walls need one per corner, which PLY has no convention for
 * (the OBJ has them). */
static int uvs_per_position(const ch_mesh *m) {
  if (!m->corner_uv) return 0;
  int *first = malloc((size_t)(m->num_positions ? m->num_positions : 1) * sizeof *first);
  if (!first) return 0;
  for (int p = 0; p < m->num_positions; p++) first[p] = -1;
  int ok = 1;
  for (int c = 0; c < m->num_corners && ok; c++) {
    int p = m->corner_position[c], uv = m->corner_uv[c];
    /* Corners of one vertex may differ by rounding (1e-12: points on a
     * shared edge interpolated from either end); a seam differs by more. */
    if (first[p] < 0) first[p] = uv;
    else if (fabs(m->uvs[2 * (size_t)first[p]] - m->uvs[2 * (size_t)uv]) > 1e-9 ||
             fabs(m->uvs[2 * (size_t)first[p] + 1] - m->uvs[2 * (size_t)uv + 1]) > 1e-9)
      ok = 0;
  }
  free(first);
  return ok;
}

/* The body goes out in chunks of this many vertices or faces, each
 * formatted in parallel into one buffer and written with one call (a
 * call per value took most of the time of writing a 2M-triangle PLY). */
enum { PLY_CHUNK = 1 << 16 };

static int write_ply_body(FILE *fp, const ch_mesh *m) {
  int most = 0;
  for (int f = 0; f < m->num_faces; f++)
    if (m->face_start[f + 1] - m->face_start[f] > most) most = m->face_start[f + 1] - m->face_start[f];
  int wide = most > 127; /* uchar counts cannot hold it (texcoord lists have 2 per corner) */
  int st_uv = uvs_per_position(m);
  int *vertex_uv = NULL;
  if (st_uv) {
    vertex_uv = malloc((size_t)(m->num_positions ? m->num_positions : 1) * sizeof *vertex_uv);
    if (!vertex_uv) return 0;
    for (int p = 0; p < m->num_positions; p++) vertex_uv[p] = -1;
    for (int c = 0; c < m->num_corners; c++)
      if (vertex_uv[m->corner_position[c]] < 0) vertex_uv[m->corner_position[c]] = m->corner_uv[c];
  }
  fprintf(fp,
          "ply\nformat binary_little_endian 1.0\ncomment chisel\nelement vertex %d\n"
          "property float x\nproperty float y\nproperty float z\n",
          m->num_positions);
  if (st_uv) fputs("property float s\nproperty float t\n", fp);
  fprintf(fp, "element face %d\nproperty list %s int vertex_indices\n", m->num_faces, wide ? "int" : "uchar");
  if (m->corner_uv) fprintf(fp, "property list %s float texcoord\n", wide ? "int" : "uchar");
  fputs("end_header\n", fp);
  size_t stride = st_uv ? 20 : 12, cap = (size_t)PLY_CHUNK * stride;
  size_t *offset = malloc(((size_t)PLY_CHUNK + 1) * sizeof *offset);
  unsigned char *buf = malloc(cap);
  int ok = buf && offset;
  for (int v0 = 0; ok && v0 < m->num_positions; v0 += PLY_CHUNK) {
    int v1 = v0 + PLY_CHUNK < m->num_positions ? v0 + PLY_CHUNK : m->num_positions;
#pragma omp parallel for schedule(static)
    for (int v = v0; v < v1; v++) {
      unsigned char *o = buf + (size_t)(v - v0) * stride;
      for (int k = 0; k < 3; k++) o = ch_le_f32(o, m->positions[3 * (size_t)v + k]);
      if (st_uv)
        for (int k = 0; k < 2; k++) o = ch_le_f32(o, vertex_uv[v] < 0 ? 0.0 : m->uvs[2 * (size_t)vertex_uv[v] + k]);
    }
    fwrite(buf, 1, (size_t)(v1 - v0) * stride, fp);
  }
  size_t count_bytes = wide ? 4 : 1;
  for (int f0 = 0; ok && f0 < m->num_faces; f0 += PLY_CHUNK) {
    int f1 = f0 + PLY_CHUNK < m->num_faces ? f0 + PLY_CHUNK : m->num_faces;
    offset[0] = 0;
    for (int f = f0; f < f1; f++) {
      size_t n = (size_t)(m->face_start[f + 1] - m->face_start[f]);
      offset[f - f0 + 1] = offset[f - f0] + count_bytes + 4 * n + (m->corner_uv ? count_bytes + 8 * n : 0);
    }
    if (offset[f1 - f0] > cap) {
      unsigned char *nb = realloc(buf, offset[f1 - f0]);
      if (!nb) {
        ok = 0;
        break;
      }
      buf = nb;
      cap = offset[f1 - f0];
    }
#pragma omp parallel for schedule(static)
    for (int f = f0; f < f1; f++) {
      unsigned char *o = buf + offset[f - f0];
      int n = m->face_start[f + 1] - m->face_start[f];
      if (wide) o = ch_le_u32(o, (uint32_t)n);
      else *o++ = (unsigned char)n;
      for (int c = m->face_start[f]; c < m->face_start[f + 1]; c++) o = ch_le_u32(o, (uint32_t)m->corner_position[c]);
      if (m->corner_uv) {
        if (wide) o = ch_le_u32(o, (uint32_t)(2 * n));
        else *o++ = (unsigned char)(2 * n);
        for (int c = m->face_start[f]; c < m->face_start[f + 1]; c++)
          for (int k = 0; k < 2; k++) o = ch_le_f32(o, m->uvs[2 * (size_t)m->corner_uv[c] + k]);
      }
    }
    fwrite(buf, 1, offset[f1 - f0], fp);
  }
  free(buf);
  free(offset);
  free(vertex_uv);
  return ok;
}

ch_status ch_mesh_write_ply(const char *path, const ch_mesh *mesh, ch_error *err) {
  ch_status st = check_writable(mesh, path, err);
  if (st != CH_OK) return st;
  ch_atomic_file f;
  st = ch_atomic_open(&f, path, err);
  if (st != CH_OK) return st;
  if (!write_ply_body(f.fp, mesh)) {
    ch_atomic_abort(&f);
    return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory", path);
  }
  return ch_atomic_commit(&f, err);
}

ch_status ch_mesh_write_obj_stream(FILE *fp, const char *name, const ch_mesh *mesh, ch_error *err) {
  ch_status st = check_writable(mesh, name, err);
  if (st != CH_OK) return st;
  int write_errno = write_obj_body(fp, mesh);
  if (write_errno < 0) return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory", name);
  if (!write_errno && (fflush(fp) != 0 || ferror(fp))) write_errno = errno ? errno : EIO;
  if (write_errno) return ch_file_error(err, name, "cannot write", write_errno);
  return CH_OK;
}

ch_status ch_mesh_write_ply_stream(FILE *fp, const char *name, const ch_mesh *mesh, ch_error *err) {
  ch_status st = check_writable(mesh, name, err);
  if (st != CH_OK) return st;
  errno = 0; /* (a failed write inside sets it; the stream keeps only that it failed) */
  if (!write_ply_body(fp, mesh)) return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory", name);
  if (fflush(fp) != 0 || ferror(fp)) return ch_file_error(err, name, "cannot write", errno ? errno : EIO);
  return CH_OK;
}
