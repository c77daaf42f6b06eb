/* libFuzzer target: the OBJ reader (our scanner, then OpenMesh's reader
 * through our importer), then validation of whatever it accepted. */
#include <stddef.h>
#include <stdint.h>

#include "ch_mesh.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  ch_mesh mesh;
  ch_error err = {0};
  if (ch_mesh_read_memory(data, size, "obj", "fuzz.obj", &mesh, &err) == CH_OK) {
    ch_mesh_report report;
    ch_mesh_validate(&mesh, "fuzz.obj", &report, &err);
  }
  ch_mesh_free(&mesh);
  return 0;
}
