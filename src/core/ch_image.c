#include "ch_image.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

ch_status ch_image_init(ch_image *img, int width, int height, int num_channels,
                        const char *const *names, ch_error *err) {
  memset(img, 0, sizeof *img);
  if (width < 1 || height < 1 || width > CH_IMAGE_MAX_SIDE || height > CH_IMAGE_MAX_SIDE)
    return ch_error_set(err, CH_ERR_INPUT, "image size %dx%d outside 1..%d", width, height,
                        CH_IMAGE_MAX_SIDE);
  if (num_channels < 1 || num_channels > CH_IMAGE_MAX_CHANNELS)
    return ch_error_set(err, CH_ERR_INPUT, "%d image channels (1..%d allowed)", num_channels,
                        CH_IMAGE_MAX_CHANNELS);
  size_t n = (size_t)width * (size_t)height * (size_t)num_channels;
  img->pixels = calloc(n, sizeof(float));
  if (!img->pixels)
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for a %dx%dx%d image", width, height,
                        num_channels);
  img->width = width;
  img->height = height;
  img->num_channels = num_channels;
  for (int c = 0; c < num_channels; c++) {
    if (names && names[c])
      snprintf(img->names[c], CH_IMAGE_NAME_MAX, "%s", names[c]);
    else
      snprintf(img->names[c], CH_IMAGE_NAME_MAX, "c%d", c);
  }
  return CH_OK;
}

void ch_image_free(ch_image *img) {
  free(img->pixels);
  memset(img, 0, sizeof *img);
}

int ch_image_find(const ch_image *img, const char *name) {
  for (int c = 0; c < img->num_channels; c++)
    if (strcmp(img->names[c], name) == 0) return c;
  return -1;
}
