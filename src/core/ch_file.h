/* ch_file: output files that never lose a user's data, and whole-file
 * reading.
 *
 * An output is written to a temporary file beside its target, named
 * TARGET.tmp.chisel-PID-XXXXXX, and moved over the target only when it is
 * complete, so a failed run never leaves a partial file behind and never
 * touches the previous one. Every write error is kept with its errno, so a
 * full disk is reported as such whatever the format.
 *
 * Staging: between ch_file_stage_begin and ch_file_stage_commit, completed
 * files wait as temporaries, and the commit moves them all into place
 * together (each exchanged with the file it replaces, so a failure half way
 * puts the earlier ones back): a run's outputs appear all together or not
 * at all. ch_file_stage_abort removes them.
 *
 * Every temporary is listed process-wide until it is renamed or removed;
 * ch_file_remove_temporaries removes them all, for a thread that handles
 * SIGINT/SIGTERM. A run killed outright (SIGKILL, a crash) leaves its
 * temporaries; the next ch_atomic_open of the same target removes those
 * whose process is gone (the PID in the name) and which no process holds
 * locked (flock), and says so through err's warnings.
 *
 * Thread safety: the list is guarded by a mutex; files may be opened,
 * written and committed from several threads, each file from one. */
#ifndef CH_FILE_H
#define CH_FILE_H

#include <stddef.h>
#include <stdio.h>

#include "ch_error.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ch_temp_entry ch_temp_entry;

typedef struct ch_atomic_file {
  FILE *fp;            /* write through this stream */
  char *final_path;    /* owned copy of the target path */
  char *temp_path;     /* owned: TARGET.tmp.chisel-PID-XXXXXX */
  ch_temp_entry *temp; /* its entry in the process-wide list */
} ch_atomic_file;

/* Records a failed create or write of path as "PATH: WHAT: reason (ENAME)"
 * ("No space left on device (ENOSPC)": the name for scripts and searches).
 * A full disk or quota, a file over the size limit and a device error are
 * the system's failures (CH_ERR_WRITE, exit status 1); the rest (no such
 * folder, no permission, a read-only file system) are the user's to fix
 * (CH_ERR_IO, exit status 2). Returns the status. */
ch_status ch_file_error(ch_error *err, const char *path, const char *what, int code);

/* Removes stale temporaries of path's (see above), then creates a
 * temporary file in the target's directory. On failure fills err (CH_ERR_IO
 * naming the path and the reason) and leaves *f empty. */
ch_status ch_atomic_open(ch_atomic_file *f, const char *path, ch_error *err);

/* Flushes and closes the temporary. Outside staging, renames it over the
 * target; while staging, keeps it for ch_file_stage_commit. On any failure
 * (a write error on the way, seen by any writer, included) the temporary is
 * removed, the target is untouched and err says "PATH: cannot write:
 * REASON (ERRNO)". Always releases f. */
ch_status ch_atomic_commit(ch_atomic_file *f, ch_error *err);

/* Closes and removes the temporary file; the target is untouched. */
void ch_atomic_abort(ch_atomic_file *f);

/* The errno of the first failed write to f, 0 if none. */
int ch_atomic_errno(const ch_atomic_file *f);

/* A writer's failure: if a write to f failed, err names that (path,
 * reason, errno; the real cause behind a library's "write error") and the
 * result is CH_ERR_IO; otherwise err and st are kept. Aborts f. */
ch_status ch_atomic_fail(ch_atomic_file *f, ch_status st, ch_error *err);

/* Starts staging (see above). Not nested: one stage per process at a time. */
void ch_file_stage_begin(void);

/* Renames every staged file over its target, in the order they were
 * committed, and ends staging. If one rename fails, the ones done are
 * undone (the previous files put back, new ones removed), every staged
 * temporary is removed and err names the file; where the file system
 * cannot exchange two names (no RENAME_EXCHANGE) an earlier file cannot be
 * put back, and err says which were replaced. */
ch_status ch_file_stage_commit(ch_error *err);

/* Removes every staged temporary and ends staging. */
void ch_file_stage_abort(void);

/* Removes every temporary this process has listed (being written or
 * staged) and blocks further ones: for a signal-handling thread before it
 * exits. Returns how many were removed. Not async-signal-safe (it takes the
 * list's mutex): call it from a thread, not from a signal handler. */
int ch_file_remove_temporaries(void);

/* Reads a whole file into a malloc'ed buffer (NUL-terminated, size excludes
 * the NUL). Files larger than max_size are refused with CH_ERR_INPUT. */
ch_status ch_file_read_all(const char *path, size_t max_size, char **data,
                           size_t *size, ch_error *err);

/* rel read from beside the file at path: rel itself when it is absolute
 * or path has no folder, else path's folder joined with rel. A new string
 * (NULL without memory). */
char *ch_path_beside(const char *path, const char *rel);

/* The extension of a path, lower-cased, without the dot ("" if none),
 * written into out (at most out_size bytes). */
void ch_path_extension(const char *path, char *out, size_t out_size);

#ifdef __cplusplus
}
#endif
#endif
