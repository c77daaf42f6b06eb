/* ch_report: what the study writes (docs/cli.md, "chisel study"): a
 * render's pictures (PNG: shading, classes, class mismatch, normal and
 * depth error against the truth), its EXR layers, a montage of the
 * shadings, and from the metrics rows summary.csv, summary.json and
 * index.html (tables, means and worst views, colour bars, plots of error
 * against triangles).
 *
 * Every file is written atomically (ch_file.h: it appears whole or not at
 * all, and joins the staged outputs when staging is on). No printing, no
 * global state: distinct files may be written from distinct threads. */
#ifndef CH_REPORT_H
#define CH_REPORT_H

#include "ch_error.h"
#include "ch_image.h"
#include "ch_metrics.h"
#include "ch_scene.h"

#ifdef __cplusplus
extern "C" {
#endif

/* One method seen from one view: indices into the scene's views and
 * methods, the method's triangles, its metrics against the truth, and the
 * rays (primary and shadow) its render traced in seconds. */
typedef struct ch_study_row {
  int view, method;
  long triangles;
  ch_metrics m;
  long rays;
  double seconds;
} ch_study_row;

typedef enum ch_report_picture {
  CH_REPORT_SHADE = 0,   /* the shading, grey (sRGB-ish gamma 2.2) */
  CH_REPORT_CLASSES,     /* classes: top grey, groove wall orange, floor blue, step wall green, nothing black */
  CH_REPORT_CLASS_DIFF,  /* pixels whose class differs from the truth's red, the others the truth's shading dimmed */
  CH_REPORT_NORMAL,      /* normal error, heat map 0..20 degrees (black: not seen by both) */
  CH_REPORT_DEPTH        /* depth error, heat map 0..1% of scene_size (black: not seen by both) */
} ch_report_picture;

/* Writes a picture of img (a ch_render image) to the PNG path; truth (the
 * truth's render of the same camera) is needed by CLASS_DIFF, NORMAL and
 * DEPTH, ignored by the others (may be NULL); scene_size scales DEPTH. */
ch_status ch_report_png(const char *path, ch_report_picture what, const ch_image *img, const ch_image *truth,
                        double scene_size, ch_error *err);

/* Writes every layer of img to the EXR path, named so that Blender's and
 * other multilayer readers open it (NAME.X for a one-value layer), the
 * shading also as luminance, with the attributes chisel:command "study",
 * chisel:view and chisel:method. img is not changed. */
ch_status ch_report_exr(const char *path, const ch_image *img, const char *view, const char *method, ch_error *err);

/* The shadings of imgs[0..n) (n >= 1, all of imgs[0]'s size) side by side,
 * 4 black pixels apart, to the PNG path. */
ch_status ch_report_montage(const char *path, const ch_image *const *imgs, int n, ch_error *err);

/* Writes DIR/summary.csv and DIR/summary.json: one line (object) per row,
 * named by the scene's views and methods. */
ch_status ch_report_summaries(const char *dir, const ch_scene *scene, const ch_study_row *rows, int num_rows,
                              ch_error *err);

/* What made the report, quoted in index.html (NULL text: empty). */
typedef struct ch_report_info {
  const char *command;    /* the command line */
  const char *scene_path; /* the scene file as named */
  const char *scene_text; /* its contents */
} ch_report_info;

/* Writes DIR/index.html: what made it (version, date: SOURCE_DATE_EPOCH
 * when set, else now; the command; the scene), the rows' table, each
 * method's mean and worst view, plots against triangles (one line per
 * family), and per view the pictures the study writes beside it
 * (V.truth.png, V.M.png, ... as chisel study names them). */
ch_status ch_report_index(const char *dir, const ch_scene *scene, const ch_study_row *rows, int num_rows,
                          const ch_report_info *info, ch_error *err);

#ifdef __cplusplus
}
#endif
#endif
