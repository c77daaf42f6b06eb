/* ch_camera: the one camera of chisel, a pinhole (or orthographic) view
 * with an orthonormal frame. The warp builds it from the 7 numbers of
 * --camera (ch_camera_init: square frustum, up chosen for the user); the
 * study's renderer from a view with an explicit up vector and an image
 * aspect (ch_camera_look). Both project points (ch_camera_project) and
 * shoot rays (ch_camera_ray) through the same frame, so a point the warp
 * counts as seen is where a ray of the same view would hit it.
 *
 * Screen coordinates are normalised device coordinates: x right, y up, in
 * [-1, 1] inside the view. A ch_camera is plain data once set up: every
 * function below only reads it, safe from any number of threads. */
#ifndef CH_CAMERA_H
#define CH_CAMERA_H

#include "ch_error.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ch_camera {
  double eye[3], at[3];
  double fov_deg;      /* vertical field of view (pinhole) */
  double ortho_height; /* > 0: orthographic, the view's height in world units */
  double aspect;       /* width / height of the view */
  /* derived by ch_camera_init / ch_camera_look: unit forward, right and up */
  double forward[3], right[3], up[3];
  /* half the view's height and width at distance 1 (pinhole: tan(fov / 2)
   * and that times aspect) or in world units (orthographic) */
  double half_height, half_width;
} ch_camera;

/* Sets up the camera of --camera (docs/spec.md §5) from its 7 numbers: eye, the
 * point looked at, vertical field of view in degrees. Up is +z, or +y when
 * the view is along z (|dir.z| > 0.999 |dir|). The frustum is square
 * (aspect 1), since the command line names no image size. CH_ERR_INPUT
 * (message "camera: ...", no file name: the caller prefixes it) for a
 * non-finite value, eye == at (closer than 1e-12), or a field of view
 * outside [0.01, 179] degrees; cam is zeroed first. */
ch_status ch_camera_init(ch_camera *cam, const double values[7], ch_error *err);

/* Sets up a camera at eye looking at `at` with the given up vector (any
 * length, not parallel to the view), vertical field of view fov_deg (used
 * when ortho_height <= 0) or orthographic view height ortho_height (> 0),
 * and aspect = width / height (> 0). CH_ERR_INPUT ("camera: ...") when eye
 * and at coincide, up is parallel to the view direction, the field of view
 * is outside (0, 179) degrees, or aspect is not a positive finite number;
 * cam is zeroed first. */
ch_status ch_camera_look(ch_camera *cam, const double eye[3], const double at[3], const double up[3],
                         double fov_deg, double ortho_height, double aspect, ch_error *err);

/* Projects p: ndc[0] right, ndc[1] up, in [-1, 1] inside the view, and the
 * depth along forward (depth may be NULL). Returns 1 when depth > 0 (in
 * front of the eye), else 0 (ndc then set to 0). */
int ch_camera_project(const ch_camera *cam, const double p[3], double ndc[2], double *depth);

/* The ray through the screen point (x, y) in NDC: origin and direction.
 * Pinhole: from the eye, unit direction. Orthographic: from the point of
 * the image plane through the eye, direction forward. */
void ch_camera_ray(const ch_camera *cam, double x, double y, double org[3], double dir[3]);

#ifdef __cplusplus
}
#endif
#endif
