/* ch_mesh: the base mesh as a plain C struct, its readers (OBJ, PLY, OFF,
 * STL through OpenMesh), validation and statistics, and the OBJ/PLY writers.
 *
 * Faces have any number of corners. Attributes are face-varying: corner k of
 * the mesh (faces are runs of corners) has a position index, and, when the
 * file has them, a UV index and a normal index. */
#ifndef CH_MESH_H
#define CH_MESH_H

#include <stddef.h>
#include <stdio.h>

#include "ch_error.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ch_mesh {
  int num_positions;
  double *positions;     /* 3 * num_positions */
  int num_faces;
  int *face_start;       /* num_faces + 1 offsets into the corner arrays */
  int num_corners;       /* face_start[num_faces] */
  int *corner_position;  /* num_corners position indices */
  int num_uvs;
  double *uvs;           /* 2 * num_uvs, NULL when the file has no UVs */
  int *corner_uv;        /* num_corners UV indices, NULL when no UVs */
  int num_normals;
  double *normals;       /* 3 * num_normals, NULL when the file has none */
  int *corner_normal;    /* num_corners normal indices, NULL when none */
} ch_mesh;

/* Largest accepted counts: far beyond any base mesh, small enough that
 * int offsets never overflow. */
enum { CH_MESH_MAX_ELEMENTS = 1 << 28 };

/* Reads OBJ, PLY, OFF, STL or glTF 2.0 (.glb, or .gltf with its buffers
 * beside it: docs/spec.md §1) into out, chosen by extension. Structural
 * problems the file itself has (indices out of range, faces with fewer than
 * 3 corners, NaN/Inf coordinates, a face whose UV count does not match its
 * corners) give CH_ERR_INPUT naming the file and the element. Missing UVs
 * are not an error here: see ch_mesh_validate. out is zeroed on failure.
 * Messages number elements as the file does (OBJ from 1, PLY/OFF from 0).
 * UV and normal values are deduplicated exactly (equal bits, one index).
 * OpenMesh reads coordinates as float, so values carry float precision.
 * Thread-safe, but reads are serialised (OpenMesh's readers are global). */
ch_status ch_mesh_read(const char *path, ch_mesh *out, ch_error *err);

/* The same from memory; format is "obj", "ply", "off", "stl", "glb" or
 * "gltf" (whose buffers can only be data: URIs here); name is used in
 * messages. For the fuzz targets. OFF goes through a temporary file
 * in $TMPDIR (OpenMesh parses OFF headers only from files). */
ch_status ch_mesh_read_memory(const void *data, size_t size, const char *format,
                              const char *name, ch_mesh *out, ch_error *err);

/* Releases every array and zeroes the struct. Safe on a zeroed struct. */
void ch_mesh_free(ch_mesh *mesh);

/* What chisel needs of a base mesh, as ch_mesh_validate checks it. */
typedef struct ch_mesh_report {
  int num_triangles, num_quads, num_polygons;  /* faces by corner count */
  double bounds_min[3], bounds_max[3];
  double uv_min[2], uv_max[2];
  int num_uvs_outside;          /* UV values outside [0,1] (warning) */
  int num_boundary_edges;       /* edges with one face */
  int num_nonmanifold_edges;    /* edges with more than two faces */
  int num_nonmanifold_vertices; /* vertices whose faces form several fans */
  int num_degenerate_faces;     /* zero area in 3D */
  int num_zero_uv_area_faces;   /* zero area in UV */
  int first_degenerate_face;    /* 0-based index of the first, -1 if none */
  int first_zero_uv_area_face;  /* likewise */
  int num_components;           /* connected components (by shared positions) */
  int num_charts;               /* UV charts (faces joined across edges with equal UVs) */
  double uv_coverage;           /* share of the unit square covered by UV faces */
  double uv_overlap;            /* share of the unit square covered twice or more */
} ch_mesh_report;

/* Checks mesh for use as a base surface and fills report (may be NULL).
 * Errors (CH_ERR_INPUT, message names `name` and the element): no faces,
 * no UVs, NaN/Inf, indices out of range. Warnings through err: UVs outside
 * [0,1], non-manifold edges or vertices, degenerate faces, zero UV area. */
ch_status ch_mesh_validate(const ch_mesh *mesh, const char *name,
                           ch_mesh_report *report, ch_error *err);

/* ch_mesh_validate of a displaced mesh chisel wrote: its walls are
 * vertical, so faces without UV area (and zero-area ones where a wall's
 * height falls to nothing) are its design, not defects: the same checks
 * and report, without those two warnings. */
ch_status ch_mesh_validate_displaced(const ch_mesh *mesh, const char *name,
                                     ch_mesh_report *report, ch_error *err);

/* Collapses every edge of a triangle mesh no longer than eps (in each
 * coordinate) whose collapse keeps the mesh manifold (the link condition:
 * its endpoints share no neighbour but the vertices opposite the edge),
 * removing the triangles on it and the merged positions; the rest keeps
 * its order, UV and normal indices. Deterministic (edges in index order).
 * Returns the number collapsed, or -1 when out of memory (the mesh is
 * then unchanged in its counts but may have merged corners; discard it). */
int ch_mesh_collapse_short_edges(ch_mesh *mesh, double eps);

/* Removes pillows: pairs of triangles on the same three corners with
 * opposite orientations (they enclose nothing, and where they hang off the
 * surface they make its edge non-manifold), unless that would leave an
 * edge with one face. Positions are kept (some may be left unused).
 * Returns the number of triangles removed, or -1 when out of memory. */
int ch_mesh_remove_pillows(ch_mesh *mesh);

/* Writes OBJ (v, vt, vn, f with the indices the mesh has) atomically with
 * deterministic bytes (%.9g coordinates). */
ch_status ch_mesh_write_obj(const char *path, const ch_mesh *mesh, ch_error *err);

/* Writes binary little-endian PLY atomically: one vertex per position
 * (float x y z), so the PLY is closed wherever the mesh is, and the UVs
 * per face corner as the face's float `texcoord` list (u0 v0 u1 v1 ...,
 * MeshLab's wedge convention); also per vertex as float s t (what
 * Blender's importer reads) when every position has a single UV. No
 * normals: creases need one per corner, which PLY has no convention for. */
ch_status ch_mesh_write_ply(const char *path, const ch_mesh *mesh, ch_error *err);

/* The OBJ and PLY writers to an open stream (standard output for -o -):
 * the same bytes as the file writers, not atomic (a stream cannot be taken
 * back). name is used in messages. */
ch_status ch_mesh_write_obj_stream(FILE *fp, const char *name, const ch_mesh *mesh, ch_error *err);
ch_status ch_mesh_write_ply_stream(FILE *fp, const char *name, const ch_mesh *mesh, ch_error *err);

/* Writes glTF 2.0 binary (.glb) atomically: one mesh of triangles (faces
 * fanned) with POSITION (float32, with min/max), NORMAL (unit) and
 * TEXCOORD_0 (u, 1 - v: glTF's v points down) where the mesh has them, and
 * uint32 indices. Vertices are split where a position's corners disagree
 * in UV or normal (glTF has no face-varying data), numbered in order of
 * their first corner: deterministic bytes. CH_ERR_INPUT for inconsistent
 * meshes or a buffer past glTF's 4 GB. */
ch_status ch_mesh_write_glb(const char *path, const ch_mesh *mesh, ch_error *err);

#ifdef __cplusplus
}
#endif
#endif
