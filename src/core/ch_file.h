/* ch_file: atomic output files. Data goes to a temporary file beside the
 * target, which is renamed over the target only when complete, so a failed
 * run never leaves a partial OBJ/EXR/PNG behind. Also whole-file reading. */
#ifndef CH_FILE_H
#define CH_FILE_H

#include <stddef.h>
#include <stdio.h>

#include "ch_error.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ch_atomic_file {
  FILE *fp;            /* write through this stream */
  char *final_path;    /* owned copy of the target path */
  char *temp_path;     /* owned: target + ".tmp.XXXXXX" */
} ch_atomic_file;

/* Opens a temporary file in the target's directory. On failure fills err
 * (CH_ERR_IO naming the path) and leaves *f empty. */
ch_status ch_atomic_open(ch_atomic_file *f, const char *path, ch_error *err);

/* Flushes, closes and renames over the target. On any failure the temporary
 * file is removed and the target is untouched. Always releases f. */
ch_status ch_atomic_commit(ch_atomic_file *f, ch_error *err);

/* Closes and removes the temporary file; the target is untouched. */
void ch_atomic_abort(ch_atomic_file *f);

/* Reads a whole file into a malloc'ed buffer (NUL-terminated, size excludes
 * the NUL). Files larger than max_size are refused with CH_ERR_INPUT. */
ch_status ch_file_read_all(const char *path, size_t max_size, char **data,
                           size_t *size, ch_error *err);

/* The extension of a path, lower-cased, without the dot ("" if none),
 * written into out (at most out_size bytes). */
void ch_path_extension(const char *path, char *out, size_t out_size);

#ifdef __cplusplus
}
#endif
#endif
