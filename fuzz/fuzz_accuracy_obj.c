/* libFuzzer target: chisel-accuracy's OBJ reader (ch_accuracy_parse_obj,
 * bench/accuracy.h), then a check that every index it kept is in range. */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "accuracy.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  char *text = malloc(size + 1); /* (the parser writes one byte past the text) */
  if (!text) return 0;
  memcpy(text, data, size);
  text[size] = '\0';
  ch_mesh m;
  ch_error err = {0};
  if (ch_accuracy_parse_obj(text, size, "fuzz.obj", &m, &err) == CH_OK) {
    for (int c = 0; c < m.num_corners; c++) {
      if (m.corner_position[c] < 0 || m.corner_position[c] >= m.num_positions) abort();
      if (m.corner_normal && (m.corner_normal[c] < 0 || m.corner_normal[c] >= m.num_normals)) abort();
    }
    for (int f = 0; f < m.num_faces; f++)
      if (m.face_start[f + 1] - m.face_start[f] < 3) abort();
  }
  ch_mesh_free(&m);
  free(text);
  return 0;
}
