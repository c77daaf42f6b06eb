/* ch_image: a float image with named channels, stored planar (one W*H plane
 * per channel), row 0 at the top as EXR stores it. Texel (x, y) covers
 * u in [x/W, (x+1)/W], v in [1-(y+1)/H, 1-y/H] (docs/spec.md §5). */
#ifndef CH_IMAGE_H
#define CH_IMAGE_H

#include <stddef.h>

#include "ch_error.h"

#ifdef __cplusplus
extern "C" {
#endif

enum { CH_IMAGE_NAME_MAX = 64, CH_IMAGE_MAX_CHANNELS = 64 };
/* Largest accepted side: keeps W*H*channels*4 bytes far from overflow and
 * refuses absurd sizes with a message instead of an allocation failure. */
enum { CH_IMAGE_MAX_SIDE = 32768 };

typedef struct ch_image {
  int width, height, num_channels;
  char names[CH_IMAGE_MAX_CHANNELS][CH_IMAGE_NAME_MAX];
  float *pixels; /* num_channels planes of width*height floats */
} ch_image;

/* Allocates a zero-filled image. names may be NULL (channels are then named
 * "c0", "c1", ...). Sizes outside [1, CH_IMAGE_MAX_SIDE] or more than
 * CH_IMAGE_MAX_CHANNELS channels give CH_ERR_INPUT. */
ch_status ch_image_init(ch_image *img, int width, int height, int num_channels,
                        const char *const *names, ch_error *err);

/* Releases the pixels and zeroes the struct. Safe on a zeroed struct. */
void ch_image_free(ch_image *img);

/* The plane of channel c (row-major, row 0 at the top). */
static inline float *ch_image_plane(const ch_image *img, int c) {
  return img->pixels + (size_t)c * (size_t)img->width * (size_t)img->height;
}

/* Index of the channel named name, or -1. */
int ch_image_find(const ch_image *img, const char *name);

#ifdef __cplusplus
}
#endif
#endif
