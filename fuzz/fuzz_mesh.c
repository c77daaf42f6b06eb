/* libFuzzer target: a mesh reader (our scanner where we have one, then
 * OpenMesh's reader through our importer), then validation of whatever it
 * accepted. Built once per format: CHISEL_FUZZ_FORMAT is "obj", "ply",
 * "off", "stl", "glb" or "gltf" (glTF has a reader of our own,
 * mesh/ch_mesh_gltf_read.c, with no scanner before it). */
#include <stddef.h>
#include <stdint.h>

#include "ch_mesh.h"

#ifndef CHISEL_FUZZ_FORMAT
#define CHISEL_FUZZ_FORMAT "obj"
#endif

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  ch_mesh mesh;
  ch_error err = {0};
  if (ch_mesh_read_memory(data, size, CHISEL_FUZZ_FORMAT, "fuzz." CHISEL_FUZZ_FORMAT, &mesh, &err) == CH_OK) {
    ch_mesh_report report;
    ch_mesh_validate(&mesh, "fuzz." CHISEL_FUZZ_FORMAT, &report, &err);
  }
  ch_mesh_free(&mesh);
  return 0;
}
