/* libFuzzer target: the SVG reader, then the groove field and the groove
 * texture on what it read (a few evaluations and rays), so geometry built
 * from hostile input is exercised. */
#include <stddef.h>
#include <stdint.h>

#include "ch_curves.h"
#include "ch_groove.h"
#include "ch_gtex.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  ch_curve_set set;
  ch_error err = {0};
  if (ch_curves_parse_svg((const char *)data, size, "fuzz.svg", &set, &err) != CH_OK) return 0;
  ch_groove_field field;
  if (ch_groove_field_init(&field, &set, &err) == CH_OK) {
    for (int i = 0; i < 16; i++) ch_groove_field_eval(&field, (i % 4 + 0.5) / 4, (i / 4 + 0.5) / 4, NULL);
    ch_groove_field_free(&field);
  }
  ch_gtex tex;
  ch_gtex_desc desc = {.resolution = 4};
  if (ch_gtex_build(&tex, &set, &desc, "fuzz.svg", &err) == CH_OK) {
    for (int i = 0; i < 8; i++) {
      double o[3] = {(i % 4 + 0.3) / 4, (i / 4 + 0.6) / 2, 0.05}, d[3] = {0.3 - 0.1 * i, 0.2 * i - 0.5, -0.4};
      ch_gtex_hit hit;
      ch_gtex_intersect(&tex, o, d, 0.0, 1e30, &hit);
      double up[3] = {-d[0], -d[1], 0.4}, du[2] = {0.01, 0.0}, dv[2] = {0.0, 0.01};
      ch_gtex_occluded(&tex, o, up, 0.0, 1e30);
      ch_gtex_facet facets[CH_GTEX_MAX_FACETS];
      ch_gtex_region(&tex, o, d, du, dv, up, facets);
    }
    ch_gtex_free(&tex);
  }
  ch_curves_free(&set);
  return 0;
}
