/* ch_exr: OpenEXR files through the OpenEXRCore C API (the only file that
 * touches OpenEXR). Scanline images, half or float channels, any number of
 * channels, string attributes; readable by every EXR tool. */
#ifndef CH_EXR_H
#define CH_EXR_H

#include <stddef.h>

#include "ch_error.h"
#include "ch_image.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum ch_exr_type { CH_EXR_FLOAT = 0, CH_EXR_HALF = 1 } ch_exr_type;
typedef enum ch_exr_compression {
  CH_EXR_ZIP = 0, /* default: lossless, compact, universally readable */
  CH_EXR_NONE,
  CH_EXR_PIZ
} ch_exr_compression;

typedef struct ch_exr_attribute {
  const char *name;  /* e.g. "chisel:command" */
  const char *value; /* stored as an EXR string attribute */
} ch_exr_attribute;

/* Zero means default: all channels float, ZIP, no extra attributes. */
typedef struct ch_exr_write_desc {
  ch_exr_type type;                  /* for every channel unless channel_types */
  const ch_exr_type *channel_types;  /* optional, one per image channel */
  ch_exr_compression compression;
  const ch_exr_attribute *attributes;
  int num_attributes;
  const char *luminance;             /* NULL, or a channel also written as Y:
                                        the grey channel RGBA readers show
                                        (ImageMagick, Blender's image loader,
                                        viewers that know R G B A and Y only) */
  double luminance_offset, luminance_scale; /* Y = offset + scale * that
                                        channel; scale 0 means a plain copy */
} ch_exr_write_desc;

/* Writes img atomically (temporary file + rename). desc may be NULL. Channel
 * names are written as given (EXR sorts them; readers match by name). */
ch_status ch_exr_write(const char *path, const ch_image *img,
                       const ch_exr_write_desc *desc, ch_error *err);

/* Reads every channel of the first part of a scanline or tiled EXR file into
 * a float image (half is widened), in the file's channel order. Malformed or
 * unsupported files give CH_ERR_INPUT naming the file and the problem. */
ch_status ch_exr_read(const char *path, ch_image *out, ch_error *err);

/* The same from memory (name is used in messages); for the fuzz target. */
ch_status ch_exr_read_memory(const void *data, size_t size, const char *name,
                             ch_image *out, ch_error *err);

/* Looks up a string attribute of the first part; copies at most value_size-1
 * bytes. Returns CH_OK if found, CH_ERR_INPUT if absent or not a string. */
ch_status ch_exr_read_attribute(const char *path, const char *name, char *value,
                                size_t value_size, ch_error *err);

/* The same, of any length: *value is a new NUL-terminated copy (release
 * with free()), NULL on failure. */
ch_status ch_exr_read_attribute_alloc(const char *path, const char *name, char **value, ch_error *err);

/* The same from a file held in memory (file is used in messages). */
ch_status ch_exr_read_attribute_memory(const void *data, size_t size, const char *file, const char *name,
                                       char **value, ch_error *err);

#ifdef __cplusplus
}
#endif
#endif
