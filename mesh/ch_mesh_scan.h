/* ch_mesh_scan: checks an OBJ, PLY, OFF or STL buffer exactly the way
 * OpenMesh 9.0's readers will consume it, before it reaches them, so every
 * error names the element and what is wrong (OpenMesh's readers trust their
 * input: what they do with unchecked input is listed at the top of
 * ch_mesh_scan.c). The OpenMesh shim (ch_mesh_io.cpp) runs a scanner, then
 * the reader, and compares the counts; for OBJ the scanner keeps the values
 * and ch_mesh_obj_read.c builds the mesh from them instead. Plain C, no
 * OpenMesh.
 *
 * Every scanner: d[0..n) is the whole file (not NUL-terminated); out is
 * zeroed first and filled with the counts (and for PLY the face texture
 * coordinates and the stripped copy); release it with ch_mesh_scan_free,
 * also after a failure. Errors: CH_ERR_INPUT with the message "element:
 * reason" and no file name (the caller prefixes it), CH_ERR_NOMEM. Counts
 * stay within CH_MESH_MAX_ELEMENTS (ch_mesh.h). Reentrant: no global state
 * (one locale object, created once, is shared read-only). */
#ifndef CH_MESH_SCAN_H
#define CH_MESH_SCAN_H

#include <stddef.h>

#include "ch_error.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ch_mesh_scan {
  long long num_vertices, num_faces, num_corners;
  /* OBJ: `vt` and `vn` lines, and the offsets of `mtllib` keywords (which
   * the shim comments out: they would open arbitrary paths) */
  long long num_texcoords, num_normals;
  size_t *mtllib_at;
  size_t num_mtllib;
  /* PLY: binary (and byte order); vertex properties texture_u/texture_v,
   * which OpenMesh does not read (the caller warns) */
  int binary, big_endian;
  int texture_uv_names;
  /* PLY with a face `texcoord` list (MeshLab's wedge UVs), which OpenMesh
   * misreads: the values (2 per corner, in file order), each face's first
   * vertex index, and the file without the list (stripped, stripped_size
   * bytes) for OpenMesh to read instead */
  int face_tex;
  float *tex;
  size_t num_tex;
  int *tex_first;
  size_t num_tex_first;
  char *stripped;
  size_t stripped_size;
  /* STL: binary (the size matches the triangle count), and the triangles
   * (facets) in the file, degenerate ones included */
  long long triangles;
  /* OBJ read with ch_mesh_scan_obj_values: the values as OpenMesh's reader
   * parses them (floats), 3 per `v`, 2 per `vt`, 3 per `vn`, and every
   * face's corners (face_start[f] .. face_start[f + 1] - 1) with their
   * indices resolved to 0-based (corner_tex and corner_normal -1 where the
   * corner has none) */
  float *obj_pos, *obj_tex, *obj_normal;
  int *obj_face_start, *obj_corner_pos, *obj_corner_tex, *obj_corner_normal;
} ch_mesh_scan;

/* OBJ: the totals and the syntax of v, vt, vn (finite numbers), then every
 * face with its indices resolved as OpenMesh's second pass does (negative:
 * relative to the elements so far), at least 3 distinct positions, UVs on
 * all corners or none. No NUL bytes. */
ch_status ch_mesh_scan_obj(const char *d, size_t n, ch_mesh_scan *out, ch_error *err);

/* The same checks, keeping the values and the resolved corners (the obj_
 * fields above): what ch_mesh_read builds an OBJ's mesh from. */
ch_status ch_mesh_scan_obj_values(const char *d, size_t n, ch_mesh_scan *out, ch_error *err);

/* PLY: OpenMesh's header parser token by token (format line, elements,
 * properties, end_header and where OpenMesh will start reading the body),
 * the properties it can read, then a walk over the elements it reads (up
 * to the face element) with the sizes it consumes: finite coordinates,
 * faces of 3 or more corners with indices in range, texcoord lists of 2
 * values per corner. */
ch_status ch_mesh_scan_ply(const char *d, size_t n, ch_mesh_scan *out, ch_error *err);

/* OFF: ASCII "[ST][N]OFF" alone on the first line, three counts, one
 * vertex or face per line with exactly its values, no comments. */
ch_status ch_mesh_scan_off(const char *d, size_t n, ch_mesh_scan *out, ch_error *err);

/* STL: binary when the size is 84 + 50 x the triangle count (finite
 * coordinates), else ASCII: the three lines after every line containing
 * "outer" (or "OUTER") must be "vertex x y z" with finite numbers. */
ch_status ch_mesh_scan_stl(const char *d, size_t n, ch_mesh_scan *out, ch_error *err);

/* Releases the arrays of scan and zeroes it. Safe on a zeroed struct. */
void ch_mesh_scan_free(ch_mesh_scan *scan);

#ifdef __cplusplus
}
#endif
#endif
