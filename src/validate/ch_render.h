/* ch_render: renders a ch_trace scene (the truth or a mesh) from a pinhole
 * or orthographic camera into image layers, with n x n supersampling, one
 * directional light, shadow rays and a Blinn-Phong specular term. The
 * visibility class of every hit is read from the truth's structure at the
 * hit's UV (ch_truth_classify; walls: ch_truth_classify_wall with the
 * hit's horizontal normal), for the truth and for meshes alike, so that a
 * mesh that is the truth gets the truth's classes.
 *
 * Parallel over rows (OpenMP); every pixel is computed on its own, so the
 * output is identical for any thread count. */
#ifndef CH_RENDER_H
#define CH_RENDER_H

#include "ch_camera.h"
#include "ch_error.h"
#include "ch_image.h"
#include "ch_trace.h"
#include "ch_truth.h"

#ifdef __cplusplus
extern "C" {
#endif

/* A view of the study: where the camera is (its geometry becomes a
 * ch_camera, the same camera the warp uses, with aspect width / height) and
 * the image it renders. */
typedef struct ch_render_camera {
  double eye[3], target[3], up[3];
  double fov_deg;      /* vertical field of view (pinhole) */
  double ortho_height; /* > 0: orthographic, the view's height in world units */
  int width, height;
  int supersample;     /* n: n x n samples per pixel on a regular grid; 0: 1 */
} ch_render_camera;

/* Zero means default. */
typedef struct ch_light {
  double direction[3]; /* towards the light; all 0: (-0.35, -0.45, 0.82) normalised */
  double ambient;      /* 0: 0.15 */
  double albedo;       /* 0: 0.75 */
  double specular;     /* 0: 0.25 */
  double shininess;    /* 0: 40 */
} ch_light;

/* The layers of a render, in this order (ch_image channels). Per pixel,
 * over its n x n samples: shade is the mean of the samples' shading (0 for
 * a miss); coverage the share of samples that hit; class the most frequent
 * class (ties: the lower value) and id the most frequent curve id among the
 * samples of that class (ties: the lower id; -1 for top and misses); the
 * others are means over the samples that hit (0 without any): shadow the
 * share in shadow, depth the distance from the eye along the ray
 * (orthographic: from the image plane through the eye), N the normal
 * facing the eye (renormalised), P the point, uv its texture coordinates. */
enum {
  CH_RENDER_SHADE = 0,
  CH_RENDER_SHADOW,
  CH_RENDER_DEPTH,
  CH_RENDER_NX,
  CH_RENDER_NY,
  CH_RENDER_NZ,
  CH_RENDER_PX,
  CH_RENDER_PY,
  CH_RENDER_PZ,
  CH_RENDER_U,
  CH_RENDER_V,
  CH_RENDER_CLASS,
  CH_RENDER_ID,
  CH_RENDER_COVERAGE,
  CH_RENDER_NUM_LAYERS
};

/* The layer names (EXR channel names): "shade", "shadow", "depth", "N.X",
 * "N.Y", "N.Z", "P.X", "P.Y", "P.Z", "uv.u", "uv.v", "class", "id",
 * "coverage". */
extern const char *const ch_render_layer_names[CH_RENDER_NUM_LAYERS];

typedef struct ch_render_stats {
  long primary_rays, shadow_rays;
  double seconds;
} ch_render_stats;

/* A texture-space method as a per-pixel shader on the base surface (the
 * plug-in point of normal maps, pinchmaps, groove textures): the renderer
 * traces the scene (the undisplaced base mesh) and hands the shader every
 * hit, which it may move along the same ray (relief, groove textures: new
 * t, point and uv, or a miss by returning 0), mark as a wall, and whose
 * normals it may replace (normal maps). Its result is classified and shaded
 * like any hit. occluded, if set, answers shadow rays from a shaded hit
 * (texture-space shadowing); if NULL they are traced against the scene.
 * Both are called from many threads at once. */
typedef struct ch_render_shader {
  int (*shade)(void *user, const double org[3], const double dir[3], ch_trace_hit *hit);
  int (*occluded)(void *user, const ch_trace_hit *from, const double dir[3]);
  void *user;
} ch_render_shader;

/* Renders into out (allocated here: width x height, the layers above).
 * classifier gives the classes (it may be the truth the scene traces, or
 * the truth of the curves a mesh was made from). stats may be NULL. Bad
 * cameras (zero view direction, up parallel to it, sizes out of range)
 * give CH_ERR_INPUT. */
ch_status ch_render(const ch_trace *scene, const ch_truth *classifier, const ch_render_camera *camera,
                    const ch_light *light, ch_image *out, ch_render_stats *stats, ch_error *err);

/* The same through a shader (NULL: ch_render). */
ch_status ch_render_shaded(const ch_trace *scene, const ch_render_shader *shader, const ch_truth *classifier,
                           const ch_render_camera *camera, const ch_light *light, ch_image *out, ch_render_stats *stats,
                           ch_error *err);

/* The first shader: the base surface with the truth's exact normal at the
 * hit's UV (walls never): the best any normal map can do, with no parallax,
 * masking or silhouette. truth must outlive the shader. */
ch_render_shader ch_shader_exact_normals(const ch_truth *truth);

/* The primary ray through image point (px, py) in pixels (0,0 the top-left
 * corner of the image): origin and unit direction. Exposed for tests. */
ch_status ch_render_camera_ray(const ch_render_camera *camera, double px, double py, double org[3], double dir[3],
                               ch_error *err);

#ifdef __cplusplus
}
#endif
#endif
