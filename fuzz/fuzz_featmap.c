/* libFuzzer target: feature maps read back from EXR (what `chisel magnify
 * --method featnorm|featnorm-linear|normal-bilinear|msdf` does): the EXR
 * reader, the string attributes, the layer and table checks of
 * ch_featmap_read_exr_memory, then every method at points inside and
 * around the maps' rectangle (the evaluation must stay in bounds on any
 * maps the reader accepts). */
#include <stddef.h>
#include <stdint.h>

#include "ch_featmap.h"
#include "ch_msdf.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  ch_featmap maps;
  ch_msdf msdf;
  ch_error err = {0};
  if (ch_featmap_read_exr_memory(data, size, "fuzz.exr", &maps, &msdf, &err) != CH_OK) return 0;
  for (int i = 0; i < 49; i++) {
    double u = maps.rect[0] + (maps.rect[2] - maps.rect[0]) * ((i % 7) / 5.0 - 0.1);
    double v = maps.rect[1] + (maps.rect[3] - maps.rect[1]) * ((i / 7) / 5.0 - 0.1);
    ch_featmap_sample s;
    for (int m = CH_FEATMAP_FEATNORM; m <= CH_FEATMAP_BILINEAR; m++) ch_featmap_eval(&maps, (ch_featmap_method)m, u, v, &s);
    if (msdf.resolution) ch_msdf_eval(&msdf, u, v, &s);
  }
  ch_msdf_free(&msdf);
  ch_featmap_free(&maps);
  return 0;
}
