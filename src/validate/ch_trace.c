/* Embree scenes for the truth (user geometry) and for meshes (triangles);
 * see ch_trace.h. Embree 3.13 C API, DEPS.md. */
#include "ch_trace.h"

#include <embree3/rtcore.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

struct ch_trace {
  RTCDevice device;
  RTCScene scene;
  const ch_truth *truth; /* truth scene, or NULL */
  /* mesh scene: fan triangles as corner indices into the copied mesh */
  int num_tris;
  int *tri_corner;       /* 3 per triangle */
  int *tri_face;         /* input face of each triangle */
  double *positions;     /* 3 per position */
  double *uvs;           /* 2 per UV */
  double *normals;       /* 3 per normal, or NULL */
  int *corner_position, *corner_uv, *corner_normal;
  double bounds[6];
};

/* The truth's context: the double ray and the best hit so far. Embree hands
 * the context it was given to the callbacks, so extending it is the
 * documented way to pass per-ray data (rtcore_common.h). */
typedef struct truth_context {
  struct RTCIntersectContext ctx;
  const double *org, *dir;
  double tnear, tfar;
  int found;
  ch_truth_hit hit;
} truth_context;

static void truth_bounds(const struct RTCBoundsFunctionArguments *args) {
  const ch_truth *truth = args->geometryUserPtr;
  double b[6];
  ch_truth_tile_bounds(truth, (int)args->primID, b);
  /* Float boxes that hold the double ones. */
  float pad = 1e-6f;
  args->bounds_o->lower_x = (float)b[0] - pad;
  args->bounds_o->lower_y = (float)b[1] - pad;
  args->bounds_o->lower_z = (float)b[2] - pad;
  args->bounds_o->upper_x = (float)b[3] + pad;
  args->bounds_o->upper_y = (float)b[4] + pad;
  args->bounds_o->upper_z = (float)b[5] + pad;
}

static void truth_intersect(const struct RTCIntersectFunctionNArguments *args) {
  if (args->N != 1 || !args->valid[0]) return;
  truth_context *tc = (truth_context *)args->context;
  struct RTCRayHit *rh = (struct RTCRayHit *)args->rayhit;
  double tfar = tc->found ? tc->hit.t : tc->tfar;
  ch_truth_hit h;
  if (!ch_truth_intersect(args->geometryUserPtr, tc->org, tc->dir, tc->tnear, tfar, (int)args->primID, &h)) return;
  if (tc->found && !(h.t < tc->hit.t)) return;
  tc->found = 1;
  tc->hit = h;
  rh->ray.tfar = (float)h.t;
  rh->hit.Ng_x = (float)h.normal[0];
  rh->hit.Ng_y = (float)h.normal[1];
  rh->hit.Ng_z = (float)h.normal[2];
  rh->hit.u = rh->hit.v = 0.0f;
  rh->hit.primID = args->primID;
  rh->hit.geomID = args->geomID;
  rh->hit.instID[0] = args->context->instID[0];
}

static void truth_occluded(const struct RTCOccludedFunctionNArguments *args) {
  if (args->N != 1 || !args->valid[0]) return;
  truth_context *tc = (truth_context *)args->context;
  struct RTCRay *ray = (struct RTCRay *)args->ray;
  ch_truth_hit h;
  if (ch_truth_intersect(args->geometryUserPtr, tc->org, tc->dir, tc->tnear, tc->tfar, (int)args->primID, &h)) {
    tc->found = 1;
    ray->tfar = -INFINITY;
  }
}

static ch_status embree_failed(ch_trace *s, ch_error *err, const char *what) {
  enum RTCError e = s && s->device ? rtcGetDeviceError(s->device) : RTC_ERROR_UNKNOWN;
  ch_trace_destroy(s);
  return ch_error_set(err, e == RTC_ERROR_OUT_OF_MEMORY ? CH_ERR_NOMEM : CH_ERR_INTERNAL, "Embree: %s failed (error %d)",
                      what, (int)e);
}

static ch_status new_scene(ch_trace **out, ch_error *err) {
  ch_trace *s = calloc(1, sizeof *s);
  *out = s;
  if (!s) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for a trace scene");
  s->device = rtcNewDevice(NULL);
  if (!s->device) {
    *out = NULL;
    return embree_failed(s, err, "rtcNewDevice");
  }
  s->scene = rtcNewScene(s->device);
  if (!s->scene) {
    *out = NULL;
    return embree_failed(s, err, "rtcNewScene");
  }
  /* Robust traversal: no hit lost between triangles sharing an edge. */
  rtcSetSceneFlags(s->scene, RTC_SCENE_FLAG_ROBUST);
  return CH_OK;
}

ch_status ch_trace_create_truth(const ch_truth *truth, ch_trace **out, ch_error *err) {
  ch_trace *s;
  ch_status st = new_scene(&s, err);
  *out = NULL;
  if (st) return st;
  s->truth = truth;
  ch_truth_tile_bounds(truth, -1, s->bounds);
  int tiles = ch_truth_tiles(truth);
  RTCGeometry g = rtcNewGeometry(s->device, RTC_GEOMETRY_TYPE_USER);
  if (!g) return embree_failed(s, err, "rtcNewGeometry(user)");
  rtcSetGeometryUserPrimitiveCount(g, (unsigned)(tiles * tiles));
  rtcSetGeometryUserData(g, (void *)truth);
  rtcSetGeometryBoundsFunction(g, truth_bounds, (void *)truth);
  rtcSetGeometryIntersectFunction(g, truth_intersect);
  rtcSetGeometryOccludedFunction(g, truth_occluded);
  rtcCommitGeometry(g);
  rtcAttachGeometry(s->scene, g);
  rtcReleaseGeometry(g);
  rtcCommitScene(s->scene);
  if (rtcGetDeviceError(s->device) != RTC_ERROR_NONE) return embree_failed(s, err, "building the truth scene");
  *out = s;
  return CH_OK;
}

ch_status ch_trace_create_mesh(const ch_mesh *m, const char *name, ch_trace **out, ch_error *err) {
  *out = NULL;
  if (!m->uvs || !m->corner_uv)
    return ch_error_set(err, CH_ERR_INPUT, "%s: the mesh has no texture coordinates (needed for the visibility class)",
                        name);
  if (m->num_faces < 1) return ch_error_set(err, CH_ERR_INPUT, "%s: the mesh has no faces", name);
  ch_trace *s;
  ch_status st = new_scene(&s, err);
  if (st) return st;
  long tris = 0;
  for (int f = 0; f < m->num_faces; f++) tris += m->face_start[f + 1] - m->face_start[f] - 2;
  s->num_tris = (int)tris;
  s->tri_corner = malloc((size_t)tris * 3 * sizeof *s->tri_corner);
  s->tri_face = malloc((size_t)tris * sizeof *s->tri_face);
  s->positions = malloc((size_t)m->num_positions * 3 * sizeof *s->positions);
  s->uvs = malloc((size_t)m->num_uvs * 2 * sizeof *s->uvs);
  s->corner_position = malloc((size_t)m->num_corners * sizeof(int));
  s->corner_uv = malloc((size_t)m->num_corners * sizeof(int));
  int has_normals = m->normals && m->corner_normal;
  if (has_normals) {
    s->normals = malloc((size_t)m->num_normals * 3 * sizeof *s->normals);
    s->corner_normal = malloc((size_t)m->num_corners * sizeof(int));
  }
  if (!s->tri_corner || !s->tri_face || !s->positions || !s->uvs || !s->corner_position || !s->corner_uv ||
      (has_normals && (!s->normals || !s->corner_normal))) {
    ch_trace_destroy(s);
    return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory for %ld triangles", name, tris);
  }
  memcpy(s->positions, m->positions, (size_t)m->num_positions * 3 * sizeof(double));
  memcpy(s->uvs, m->uvs, (size_t)m->num_uvs * 2 * sizeof(double));
  memcpy(s->corner_position, m->corner_position, (size_t)m->num_corners * sizeof(int));
  memcpy(s->corner_uv, m->corner_uv, (size_t)m->num_corners * sizeof(int));
  if (has_normals) {
    memcpy(s->normals, m->normals, (size_t)m->num_normals * 3 * sizeof(double));
    memcpy(s->corner_normal, m->corner_normal, (size_t)m->num_corners * sizeof(int));
  }
  long k = 0;
  for (int f = 0; f < m->num_faces; f++)
    for (int c = m->face_start[f] + 1; c + 1 < m->face_start[f + 1]; c++, k++) {
      s->tri_corner[3 * k] = m->face_start[f];
      s->tri_corner[3 * k + 1] = c;
      s->tri_corner[3 * k + 2] = c + 1;
      s->tri_face[k] = f;
    }
  for (int a = 0; a < 3; a++) {
    s->bounds[a] = INFINITY;
    s->bounds[3 + a] = -INFINITY;
  }
  RTCGeometry g = rtcNewGeometry(s->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  if (!g) return embree_failed(s, err, "rtcNewGeometry(triangle)");
  float *vb = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                      (size_t)m->num_positions);
  unsigned *ib = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned),
                                         (size_t)tris);
  if (!vb || !ib) {
    rtcReleaseGeometry(g);
    return embree_failed(s, err, "allocating the mesh buffers");
  }
  for (int p = 0; p < m->num_positions; p++)
    for (int a = 0; a < 3; a++) {
      double x = m->positions[3 * (size_t)p + a];
      vb[3 * (size_t)p + a] = (float)x;
      s->bounds[a] = fmin(s->bounds[a], x);
      s->bounds[3 + a] = fmax(s->bounds[3 + a], x);
    }
  for (long t = 0; t < tris; t++)
    for (int a = 0; a < 3; a++) ib[3 * t + a] = (unsigned)m->corner_position[s->tri_corner[3 * t + a]];
  rtcCommitGeometry(g);
  rtcAttachGeometry(s->scene, g);
  rtcReleaseGeometry(g);
  rtcCommitScene(s->scene);
  if (rtcGetDeviceError(s->device) != RTC_ERROR_NONE) return embree_failed(s, err, "building the mesh scene");
  *out = s;
  return CH_OK;
}

void ch_trace_destroy(ch_trace *s) {
  if (!s) return;
  if (s->scene) rtcReleaseScene(s->scene);
  if (s->device) rtcReleaseDevice(s->device);
  free(s->tri_corner);
  free(s->tri_face);
  free(s->positions);
  free(s->uvs);
  free(s->normals);
  free(s->corner_position);
  free(s->corner_uv);
  free(s->corner_normal);
  free(s);
}

long ch_trace_triangles(const ch_trace *s) { return s->num_tris; }

void ch_trace_bounds(const ch_trace *s, double box[6]) { memcpy(box, s->bounds, sizeof s->bounds); }

static void make_ray(struct RTCRay *r, const double o[3], const double d[3], double tnear, double tfar) {
  r->org_x = (float)o[0];
  r->org_y = (float)o[1];
  r->org_z = (float)o[2];
  r->dir_x = (float)d[0];
  r->dir_y = (float)d[1];
  r->dir_z = (float)d[2];
  r->tnear = (float)tnear;
  r->tfar = isfinite(tfar) ? (float)tfar : INFINITY;
  r->time = 0.0f;
  r->mask = 0xffffffffu;
  r->id = 0;
  r->flags = 0;
}

static const double *tri_pos(const ch_trace *s, long t, int k) {
  return &s->positions[3 * (size_t)s->corner_position[s->tri_corner[3 * t + k]]];
}

/* The ray against triangle t in double (Moller-Trumbore, no range test:
 * Embree already chose the triangle). */
static void mesh_hit(const ch_trace *s, long t, const double o[3], const double d[3], float tf, float bu, float bv,
                     ch_trace_hit *hit) {
  const double *a = tri_pos(s, t, 0), *b = tri_pos(s, t, 1), *c = tri_pos(s, t, 2);
  double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  double p[3] = {d[1] * e2[2] - d[2] * e2[1], d[2] * e2[0] - d[0] * e2[2], d[0] * e2[1] - d[1] * e2[0]};
  double det = e1[0] * p[0] + e1[1] * p[1] + e1[2] * p[2];
  double tt = tf, u = bu, v = bv;
  if (fabs(det) > 1e-300) {
    double inv = 1.0 / det, w[3] = {o[0] - a[0], o[1] - a[1], o[2] - a[2]};
    double qv[3] = {w[1] * e1[2] - w[2] * e1[1], w[2] * e1[0] - w[0] * e1[2], w[0] * e1[1] - w[1] * e1[0]};
    u = (w[0] * p[0] + w[1] * p[1] + w[2] * p[2]) * inv;
    v = (d[0] * qv[0] + d[1] * qv[1] + d[2] * qv[2]) * inv;
    tt = (e2[0] * qv[0] + e2[1] * qv[1] + e2[2] * qv[2]) * inv;
  }
  hit->t = tt;
  for (int k = 0; k < 3; k++) hit->point[k] = o[k] + tt * d[k];
  double wts[3] = {1.0 - u - v, u, v};
  hit->uv[0] = hit->uv[1] = 0.0;
  for (int k = 0; k < 3; k++) {
    const double *q = &s->uvs[2 * (size_t)s->corner_uv[s->tri_corner[3 * t + k]]];
    hit->uv[0] += wts[k] * q[0];
    hit->uv[1] += wts[k] * q[1];
  }
  double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
  double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  for (int k = 0; k < 3; k++) hit->normal[k] = len > 0.0 ? n[k] / len : 0.0;
  hit->wall = fabs(hit->normal[2]) < 1e-3;
  memcpy(hit->shading_normal, hit->normal, sizeof hit->normal);
  if (s->normals) {
    double sn[3] = {0, 0, 0};
    for (int k = 0; k < 3; k++) {
      const double *q = &s->normals[3 * (size_t)s->corner_normal[s->tri_corner[3 * t + k]]];
      for (int a2 = 0; a2 < 3; a2++) sn[a2] += wts[k] * q[a2];
    }
    double l2 = sqrt(sn[0] * sn[0] + sn[1] * sn[1] + sn[2] * sn[2]);
    if (l2 > 0.0)
      for (int a2 = 0; a2 < 3; a2++) hit->shading_normal[a2] = sn[a2] / l2;
  }
  hit->face = s->tri_face[t];
}

/* The context that carries the ray in double precision to the truth's callbacks. */
static void init_context(truth_context *tc, const double o[3], const double d[3], double tnear, double tfar) {
  rtcInitIntersectContext(&tc->ctx);
  tc->org = o;
  tc->dir = d;
  tc->tnear = tnear;
  tc->tfar = tfar;
  tc->found = 0;
}

int ch_trace_intersect(const ch_trace *s, const double o[3], const double d[3], double tnear, double tfar,
                       ch_trace_hit *hit) {
  truth_context tc;
  init_context(&tc, o, d, tnear, tfar);
  struct RTCRayHit rh;
  make_ray(&rh.ray, o, d, tnear, tfar);
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(s->scene, &tc.ctx, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return 0;
  if (s->truth) {
    if (!tc.found) return 0;
    hit->t = tc.hit.t;
    memcpy(hit->point, tc.hit.point, sizeof hit->point);
    memcpy(hit->uv, tc.hit.uv, sizeof hit->uv);
    memcpy(hit->normal, tc.hit.normal, sizeof hit->normal);
    memcpy(hit->shading_normal, tc.hit.normal, sizeof hit->normal);
    hit->wall = tc.hit.wall;
    hit->face = (int)rh.hit.primID;
    return 1;
  }
  mesh_hit(s, rh.hit.primID, o, d, rh.ray.tfar, rh.hit.u, rh.hit.v, hit);
  return 1;
}

int ch_trace_occluded(const ch_trace *s, const double o[3], const double d[3], double tnear, double tfar) {
  truth_context tc;
  init_context(&tc, o, d, tnear, tfar);
  struct RTCRay r;
  make_ray(&r, o, d, tnear, tfar);
  rtcOccluded1(s->scene, &tc.ctx, &r);
  return r.tfar < 0.0f;
}
