/* libFuzzer target: the study's scene file (ch_scene_parse: JSON through
 * cJSON, every key's checks, orbits expanded, paths resolved), freed on
 * success; on failure the scene must be empty. */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "ch_scene.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  char *text = malloc(size + 1); /* the parser reads a C string */
  if (!text) return 0;
  memcpy(text, data, size);
  text[size] = '\0';
  ch_scene s;
  ch_error err = {0};
  if (ch_scene_parse("fuzz/scene.json", text, &s, &err) == CH_OK) {
    for (int i = 0; i < s.num_methods; i++)
      if (!s.methods[i].path || !s.methods[i].name[0]) abort();
    ch_scene_free(&s);
  } else if (s.views || s.methods || s.curves_path || !err.message[0]) {
    abort();
  }
  free(text);
  return 0;
}
