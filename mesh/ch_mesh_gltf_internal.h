/* The glTF 2.0 reader behind ch_mesh_read and ch_mesh_read_memory (for
 * .glb and .gltf). Not installed. */
#ifndef CH_MESH_GLTF_INTERNAL_H
#define CH_MESH_GLTF_INTERNAL_H

#include <stddef.h>

#include "ch_mesh.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Reads a glTF 2.0 scene's triangles into out (see ch_mesh_gltf_read.c):
 * binary a GLB container, else JSON. path: the file, whose relative buffer
 * URIs are read from beside it (NULL: none are, as from memory). name is
 * used in messages. */
ch_status ch_mesh_read_gltf(const void *data, size_t size, int binary, const char *path, const char *name, ch_mesh *out,
                            ch_error *err);

#ifdef __cplusplus
}
#endif
#endif
