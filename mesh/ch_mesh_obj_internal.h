/* OBJ reading behind ch_mesh_read and ch_mesh_read_memory, and the sharing
 * of equal values every reader uses. Not installed. */
#ifndef CH_MESH_OBJ_INTERNAL_H
#define CH_MESH_OBJ_INTERNAL_H

#include <stddef.h>

#include "ch_mesh.h"
#include "ch_mesh_scan.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Reads an OBJ: the scanner's checks (ch_mesh_scan_obj_values), then the
 * mesh from the values it kept: positions as the file's floats, UVs and
 * normals per corner, each list's equal values shared (by their bits, in
 * order of first use), exactly as OpenMesh's reader and the shim's
 * importer build it. Errors name the file as `name` (CH_ERR_INPUT,
 * CH_ERR_NOMEM); a warning where only some faces have normals. */
ch_status ch_mesh_read_obj(const char *data, size_t size, const char *name, ch_mesh *out, ch_error *err);

/* The distinct values of a list of n-float values as the corners use them
 * (corner c uses list value idx[c]; value c where idx is NULL): equal
 * values (by their bits) share one number, numbered in order of first use;
 * *values gets them as doubles, n per number, *corner the corners' numbers
 * (both malloc'd), *count how many. Equal values are found among the
 * listed ones (an OBJ lists fewer than its corners), with a hash table.
 * 0, or -1 out of memory (nothing allocated then). */
int ch_mesh_share_values(int n, const float *list, size_t listed, const int *idx, size_t corners, double **values,
                         int **corner, int *count);

/* The same OBJ read by OpenMesh's OBJReader through the shim's importer
 * (after the same scan): the reference the tests and the fuzz target hold
 * ch_mesh_obj_build to. */
ch_status ch_mesh_read_obj_openmesh(const void *data, size_t size, const char *name, ch_mesh *out, ch_error *err);

#ifdef __cplusplus
}
#endif
#endif
