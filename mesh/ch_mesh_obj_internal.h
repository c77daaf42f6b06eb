/* OBJ reading behind ch_mesh_read and ch_mesh_read_memory. Not installed. */
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

/* The same OBJ read by OpenMesh's OBJReader through the shim's importer
 * (after the same scan): the reference the tests and the fuzz target hold
 * ch_mesh_obj_build to. */
ch_status ch_mesh_read_obj_openmesh(const void *data, size_t size, const char *name, ch_mesh *out, ch_error *err);

#ifdef __cplusplus
}
#endif
#endif
