/* ch_scene: the study's scene file (docs/cli.md, "chisel study"): the
 * feature curves, the truth's resolutions, the light, the views (orbits
 * expanded) and the methods with their shaders, parsed from JSON (cJSON)
 * into plain values. Paths in the file are taken from the file's folder.
 * Every error is CH_ERR_INPUT with one line naming the file and the key
 * ("scene.json: views[1].fov: expected a number in [0.1, 170]").
 *
 * Thread safety: no global state; distinct scenes may be parsed and freed
 * from distinct threads at once. */
#ifndef CH_SCENE_H
#define CH_SCENE_H

#include "ch_error.h"
#include "ch_render.h"
#include "ch_texray.h"

#ifdef __cplusplus
extern "C" {
#endif

/* A view's or method's name: letters, digits, '-' and '_', shorter than
 * this (they name the files the study writes). */
enum { CH_SCENE_NAME_MAX = 64 };

/* At most this many views (after orbits) and methods. */
enum { CH_SCENE_MAX_VIEWS = 256, CH_SCENE_MAX_METHODS = 32 };

typedef struct ch_scene_view {
  char name[CH_SCENE_NAME_MAX];
  ch_render_camera camera;
} ch_scene_view;

/* A method: a mesh rendered as it is, or the base mesh with a
 * texture-space shader (at most one of exact_normals, featshade >= 0,
 * textured is set). */
typedef struct ch_scene_method {
  char name[CH_SCENE_NAME_MAX];
  char family[CH_SCENE_NAME_MAX]; /* methods plotted as one line against triangles (default: name) */
  char *path;                     /* the mesh file, resolved (owned) */
  int exact_normals;              /* "shader": "exact-normals" */
  int featshade;                  /* "shader": a ch_featshade_method, or -1 */
  int resolution;                 /* featshade: its maps' resolution R */
  int textured;                   /* "shader": "grooves", "relief" or "pom" */
  ch_texray_desc tex;             /* textured: kind, resolution, steps, paper (same_map NULL) */
} ch_scene_method;

typedef struct ch_scene {
  char *curves_path;  /* the SVG, resolved (owned) */
  int dci_resolution; /* the step DCI (default 1024) */
  int truth_grid;     /* the truth's bounds grid (default 512) */
  ch_light light;     /* the keys given; the others zero (ch_render's defaults) */
  int num_views, num_methods;
  ch_scene_view *views;     /* num_views (orbits expanded), owned */
  ch_scene_method *methods; /* num_methods, owned */
} ch_scene;

/* Parses text, the contents of the scene file named file (used in errors
 * and to resolve relative paths), into *out, which the caller frees with
 * ch_scene_free. On failure *out is empty (nothing to free) and err says
 * which key of which file is wrong (CH_ERR_INPUT) or CH_ERR_NOMEM. Reads
 * no other file: the curves and meshes are only named. */
ch_status ch_scene_parse(const char *file, const char *text, ch_scene *out, ch_error *err);

/* Frees what ch_scene_parse allocated and empties *s (NULL or an empty
 * scene: nothing). */
void ch_scene_free(ch_scene *s);

#ifdef __cplusplus
}
#endif
#endif
