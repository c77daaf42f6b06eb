/* ch_png: PNG previews through libpng, and the false-colour maps used to
 * show height fields and error maps to a person. */
#ifndef CH_PNG_H
#define CH_PNG_H

#include <stdint.h>

#include "ch_error.h"
#include "ch_image.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Writes 8-bit RGB (channels = 3) or RGBA (channels = 4) pixels, rows top to
 * bottom, atomically. */
ch_status ch_png_write(const char *path, int width, int height, int channels,
                       const uint8_t *pixels, ch_error *err);

/* Reads an 8-bit RGB or RGBA PNG (other formats converted); *pixels is
 * malloc'ed, *channels is 3 or 4. For tests and round trips. */
ch_status ch_png_read(const char *path, int *width, int *height, int *channels,
                      uint8_t **pixels, ch_error *err);

/* A height field preview: a diverging false colour (carved blue, zero white,
 * raised red, scaled by max |h|) shaded by a light from the upper left so
 * walls and creases read as relief. plane is width*height floats, row 0 on
 * top; the slope used for shading is relative to max |h| per texel. */
ch_status ch_png_write_height(const char *path, const float *plane, int width,
                              int height, ch_error *err);

/* A height map for tools that read only integer images: 16-bit grey, row 0
 * on top, value 0.5 + h / (2 s) of full scale with s = max |h| (so 0.5 is
 * h = 0: Blender's Displace modifier with midlevel 0.5 and strength 2 s
 * gives back h, to 1/65535 of 2 s). The PNG carries s in a tEXt chunk
 * "chisel:height_scale" and the recipe in "Comment"; *scale (may be NULL)
 * gets s. Non-finite values are written as 0.5. Atomic. */
ch_status ch_png_write_height16(const char *path, const float *plane, int width, int height, double *scale,
                               ch_error *err);

/* Maps x in [0,1] to an sRGB colour of a perceptually ordered map (turbo-like)
 * for error heat maps. */
void ch_colormap_heat(double x, uint8_t rgb[3]);

/* Diverging map for signed values: x in [-1,1], blue - white - red. */
void ch_colormap_diverging(double x, uint8_t rgb[3]);

#ifdef __cplusplus
}
#endif
#endif
