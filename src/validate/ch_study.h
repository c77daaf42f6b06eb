/* ch_study: a study run (docs/cli.md, "chisel study"): the Embree-traced
 * truth of a scene's curves over the planar base and every method of the
 * scene (a mesh as it is, or the base with a texture-space shader),
 * rendered from every view and compared per pixel, the pictures and the
 * report written by ch_report. Two steps, so that a caller (the command
 * line, a viewer, a test) can check every input before it writes anything:
 * ch_study_create reads and builds, ch_study_run renders and writes.
 *
 * Thread safety: one study is used by one thread at a time (its renders
 * use OpenMP inside); distinct studies are independent. No printing:
 * progress goes to the ch_progress callback. */
#ifndef CH_STUDY_H
#define CH_STUDY_H

#include <stddef.h>

#include "ch_error.h"
#include "ch_progress.h"
#include "ch_report.h"
#include "ch_scene.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ch_study ch_study;

/* Reads the scene's curves and every method's mesh, builds the methods'
 * textures (relief and POM at one resolution share one height texture),
 * the truth (h with the exact step reconstruction, at the scene's DCI
 * resolution and bounds grid) and its Embree scenes. scene is borrowed and
 * must outlive the study; scene_file names the scene in errors. Writes
 * nothing. On failure *out is NULL and err names the file at fault. */
ch_status ch_study_create(const ch_scene *scene, const char *scene_file, const ch_progress *progress, ch_study **out,
                          ch_error *err);

/* The bytes of method's textures (0 for a method without textures). */
size_t ch_study_texture_bytes(const ch_study *study, int method);

/* The diagonal of the truth's bounds, to which depth errors are relative. */
double ch_study_scene_size(const ch_study *study);

/* Renders the truth and every method from every view, in the scene's
 * order, and writes into the existing folder dir, per view V and method M:
 * V.truth.exr, V.truth.png, V.truth.class.png, V.M.exr, V.M.png,
 * V.M.class.png, V.M.normal.png, V.M.depth.png, V.montage.png, then
 * summary.csv, summary.json and index.html (info is quoted there).
 * *rows gets one row per view and method (view-major; the caller frees it
 * with free), *num_files the files written. On failure *rows is NULL and
 * files written so far stay (the caller stages them: ch_file.h). */
ch_status ch_study_run(ch_study *study, const char *dir, const ch_report_info *info, const ch_progress *progress,
                       ch_study_row **rows, int *num_rows, int *num_files, ch_error *err);

/* Frees the study (NULL: nothing). */
void ch_study_destroy(ch_study *study);

#ifdef __cplusplus
}
#endif
#endif
