/* The camera (ch_camera.h). */
#include "ch_camera.h"

#include <math.h>
#include <string.h>

#include "ch_math.h"

/* Right = forward x up normalised, up = right x forward: the frame both
 * set-ups share. Returns 0 when up is parallel to forward. */
static int set_frame(ch_camera *cam, const double up[3]) {
  ch_cross3(cam->forward, up, cam->right);
  if (!ch_normalize3(cam->right)) return 0;
  ch_cross3(cam->right, cam->forward, cam->up);
  return 1;
}

static void set_halves(ch_camera *cam) {
  cam->half_height = cam->ortho_height > 0.0 ? 0.5 * cam->ortho_height : tan(0.5 * cam->fov_deg * CH_PI / 180.0);
  cam->half_width = cam->half_height * cam->aspect;
}

ch_status ch_camera_init(ch_camera *cam, const double values[7], ch_error *err) {
  memset(cam, 0, sizeof *cam);
  for (int i = 0; i < 7; i++)
    if (!isfinite(values[i]))
      return ch_error_set(err, CH_ERR_INPUT, "camera: value %d is not a finite number", i + 1);
  double dir[3] = {values[3] - values[0], values[4] - values[1], values[5] - values[2]};
  double len = sqrt(ch_dot3(dir, dir));
  if (!(len >= 1e-12)) return ch_error_set(err, CH_ERR_INPUT, "camera: the eye is on the point looked at");
  if (!(values[6] >= 0.01 && values[6] <= 179.0))
    return ch_error_set(err, CH_ERR_INPUT, "camera: field of view %g outside [0.01, 179] degrees", values[6]);
  memcpy(cam->eye, values, sizeof cam->eye);
  memcpy(cam->at, values + 3, sizeof cam->at);
  cam->fov_deg = values[6];
  cam->aspect = 1.0;
  for (int k = 0; k < 3; k++) cam->forward[k] = dir[k] / len;
  double world_up[3] = {0.0, 0.0, 1.0};
  if (fabs(dir[2]) > 0.999 * len) {
    world_up[1] = 1.0;
    world_up[2] = 0.0;
  }
  set_frame(cam, world_up); /* |forward x up| >= sqrt(1 - 0.999^2) */
  set_halves(cam);
  return CH_OK;
}

ch_status ch_camera_look(ch_camera *cam, const double eye[3], const double at[3], const double up[3],
                         double fov_deg, double ortho_height, double aspect, ch_error *err) {
  memset(cam, 0, sizeof *cam);
  memcpy(cam->eye, eye, sizeof cam->eye);
  memcpy(cam->at, at, sizeof cam->at);
  cam->fov_deg = fov_deg;
  cam->ortho_height = ortho_height > 0.0 ? ortho_height : 0.0;
  cam->aspect = aspect;
  for (int k = 0; k < 3; k++) cam->forward[k] = at[k] - eye[k];
  if (!ch_normalize3(cam->forward)) return ch_error_set(err, CH_ERR_INPUT, "camera: eye and target coincide");
  if (!set_frame(cam, up)) return ch_error_set(err, CH_ERR_INPUT, "camera: up is parallel to the view direction");
  if (!(cam->ortho_height > 0.0) && !(fov_deg > 0.0 && fov_deg < 179.0))
    return ch_error_set(err, CH_ERR_INPUT, "camera: field of view %g outside (0, 179) degrees", fov_deg);
  if (!(aspect > 0.0 && isfinite(aspect)))
    return ch_error_set(err, CH_ERR_INPUT, "camera: aspect %g is not a positive number", aspect);
  set_halves(cam);
  return CH_OK;
}

int ch_camera_project(const ch_camera *cam, const double p[3], double ndc[2], double *depth) {
  double d[3] = {p[0] - cam->eye[0], p[1] - cam->eye[1], p[2] - cam->eye[2]};
  double z = ch_dot3(d, cam->forward);
  if (depth) *depth = z;
  if (!(z > 0.0)) {
    ndc[0] = ndc[1] = 0.0;
    return 0;
  }
  if (cam->ortho_height > 0.0) {
    ndc[0] = ch_dot3(d, cam->right) / cam->half_width;
    ndc[1] = ch_dot3(d, cam->up) / cam->half_height;
    return 1;
  }
  /* One reciprocal per axis; with aspect 1 both are the same number. */
  double sx = 1.0 / (z * cam->half_width), sy = 1.0 / (z * cam->half_height);
  ndc[0] = ch_dot3(d, cam->right) * sx;
  ndc[1] = ch_dot3(d, cam->up) * sy;
  return 1;
}

void ch_camera_ray(const ch_camera *cam, double x, double y, double org[3], double dir[3]) {
  double sx = x * cam->half_width, sy = y * cam->half_height;
  if (cam->ortho_height > 0.0) {
    for (int k = 0; k < 3; k++) {
      org[k] = cam->eye[k] + sx * cam->right[k] + sy * cam->up[k];
      dir[k] = cam->forward[k];
    }
  } else {
    for (int k = 0; k < 3; k++) {
      org[k] = cam->eye[k];
      dir[k] = cam->forward[k] + sx * cam->right[k] + sy * cam->up[k];
    }
    ch_normalize3(dir);
  }
}
