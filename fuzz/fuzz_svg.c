/* libFuzzer target: the SVG reader, then the groove field on what it read
 * (a few evaluations), so geometry built from hostile input is exercised. */
#include <stddef.h>
#include <stdint.h>

#include "ch_curves.h"
#include "ch_groove.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  ch_curve_set set;
  ch_error err = {0};
  if (ch_curves_parse_svg((const char *)data, size, "fuzz.svg", &set, &err) != CH_OK) return 0;
  ch_groove_field field;
  if (ch_groove_field_init(&field, &set, &err) == CH_OK) {
    for (int i = 0; i < 16; i++) ch_groove_field_eval(&field, (i % 4 + 0.5) / 4, (i / 4 + 0.5) / 4, NULL);
    ch_groove_field_free(&field);
  }
  ch_curves_free(&set);
  return 0;
}
