/* libFuzzer target: a DCI read back from EXR (what `chisel magnify` does):
 * the EXR reader, the layer checks of ch_dci_from_image, then feature
 * reconstruction at a few points with every method but exact. */
#include <stddef.h>
#include <stdint.h>

#include "ch_dci.h"
#include "ch_exr.h"
#include "ch_recon.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  ch_image img;
  ch_error err = {0};
  if (ch_exr_read_memory(data, size, "fuzz.exr", &img, &err) != CH_OK) return 0;
  ch_dci dci;
  double rect[4] = {0, 0, 1, 1};
  if (ch_dci_from_image(&img, rect, "fuzz.exr", &dci, &err) == CH_OK) {
    ch_recon rec;
    if (ch_recon_init(&rec, &dci, NULL, &err) == CH_OK) {
      for (int m = CH_RECON_BILINEAR; m <= CH_RECON_3X3; m++)
        for (int i = 0; i < 16; i++) {
          ch_recon_sample rs;
          ch_recon_eval(&rec, (ch_recon_method)m, (i % 4 + 0.3) / 4, (i / 4 + 0.6) / 4, 0.01, &rs);
        }
      ch_recon_free(&rec);
    }
    ch_dci_free(&dci);
  }
  ch_image_free(&img);
  return 0;
}
