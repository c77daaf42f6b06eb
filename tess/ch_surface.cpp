/* ch_surface: the base surface of SPEC §1 through OpenSubdiv 3.5 (Far
 * topology, Bfr evaluation and tessellation patterns) behind a C API.
 *
 * This is the only file of chisel that includes OpenSubdiv. Every entry
 * point catches every exception; OpenSubdiv's error and warning callbacks
 * (process-global) are routed into the ch_error of the calling thread.
 *
 * Evaluation: one Bfr::Surface<double> per face for positions (limit
 * surface for catmark, bilinear patches for bilinear) and one for the
 * face-varying UVs (FVAR_LINEAR_ALL: linear per face whatever the scheme),
 * with their patch points prepared once at creation, so ch_surface_eval
 * only reads. For the bilinear scheme a third set of patch points holds the
 * unit vertex normals, evaluated with the same Surface (hence the same
 * weights as the position) and normalised: SPEC §1's N.
 *
 * Tessellation follows DEPS.md's verified flow with one change: every base
 * vertex and every edge point is evaluated once (evaluating shared points
 * from each face separately differs in the last bits, see DEPS.md), and
 * the facets of each face are remapped here rather than with
 * Tessellation::TransformFacetCoordIndices, because the UV indices of the
 * same facets need a second, face-varying, mapping.
 */
#include "ch_surface.h"
#include "ch_warp.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <new>
#include <string>
#include <vector>

#include <opensubdiv/bfr/limits.h>
#include <opensubdiv/bfr/refinerSurfaceFactory.h>
#include <opensubdiv/bfr/surface.h>
#include <opensubdiv/bfr/tessellation.h>
#include <opensubdiv/far/error.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

using namespace OpenSubdiv;

namespace {

typedef Bfr::Surface<double> Surface;
typedef Surface::PointDescriptor PD;
typedef Far::TopologyDescriptor Descriptor;

/* Bfr clamps larger rates silently (to SHRT_MAX): refuse them instead. */
const int kMaxRate = 32767;
/* Output sizes stay far below int overflow of corner indices. */
const long kMaxTriangles = 1L << 28;

/* ---- OpenSubdiv's callbacks, routed to the calling thread -------------- */

thread_local ch_error *tl_err = nullptr;
thread_local std::string *tl_far_error = nullptr;

void far_error(Far::ErrorType, const char *message) {
  if (tl_far_error && tl_far_error->empty()) *tl_far_error = message;
}
void far_warning(const char *message) {
  if (tl_err) ch_warn(tl_err, "OpenSubdiv: %s", message);
}
std::once_flag callbacks_once;

/* ---- small vector helpers ---------------------------------------------- */

inline void cross3(const double a[3], const double b[3], double o[3]) {
  double x = a[1] * b[2] - a[2] * b[1];
  double y = a[2] * b[0] - a[0] * b[2];
  double z = a[0] * b[1] - a[1] * b[0];
  o[0] = x, o[1] = y, o[2] = z;
}
inline double norm3(const double a[3]) { return std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]); }
/* Normalises a in place; false (a untouched) when it has no direction. */
inline bool normalize3(double a[3]) {
  double n = norm3(a);
  if (!(n > 0.0) || !std::isfinite(n)) return false;
  a[0] /= n, a[1] /= n, a[2] /= n;
  return true;
}

}  // namespace

/* ---- the handle -------------------------------------------------------- */

struct ch_surface {
  ch_scheme scheme = CH_SCHEME_BILINEAR;
  int num_faces = 0;
  int num_positions = 0;
  /* The mesh's topology and UVs (copied). */
  std::vector<int> face_start, corner_position, corner_uv;
  std::vector<double> uvs;
  /* Per face: surfaces and offsets (in points) of their patch points. */
  std::vector<Surface> pos, tex;
  std::vector<size_t> pos_off, tex_off;
  std::vector<double> pos_pts, nrm_pts, tex_pts; /* 3, 3 and 2 per point */
  /* Edges (Far's base level numbering). */
  int num_edges = 0;
  std::vector<int> edge_vertices;      /* 2 per edge */
  std::vector<int> face_edge;          /* per corner: the edge from corner k to k+1 */
  std::vector<unsigned char> face_edge_fwd; /* per corner: runs edge_vertices[0] -> [1] */
  std::vector<int> face_edge_group;    /* per corner: UV group of that edge side */
  std::vector<int> edge_face_start;    /* CSR over edges: incident (face, corner) */
  std::vector<int> edge_face, edge_corner; /* sorted by face */
  std::vector<int> edge_num_groups;    /* distinct UV pairs along the edge */
  std::vector<int> edge_group_face, edge_group_corner; /* per (edge, group): first face */
  std::vector<int> edge_group_start;   /* CSR over edges into edge_group_* */
  std::vector<double> edge_uv_length;  /* max over the edge's sides */
  /* Base vertices: output index (-1 unused), owner face and corner. */
  int num_used_vertices = 0;
  std::vector<int> vertex_out, vertex_face, vertex_corner;
};

namespace {

/* Evaluates position, derivatives, normal and UV at st of face f. */
void eval_point(const ch_surface *S, int f, const double st[2], double P[3], double Du[3],
                double Dv[3], double N[3], double uv[2]) {
  const Surface &s = S->pos[f];
  const double *pp = &S->pos_pts[3 * S->pos_off[f]];
  s.Evaluate(st, pp, PD(3), P, Du, Dv);
  if (S->scheme == CH_SCHEME_BILINEAR) {
    s.Evaluate(st, &S->nrm_pts[3 * S->pos_off[f]], PD(3), N);
    if (!normalize3(N)) {
      /* The interpolated vertex normals cancel: use the patch's own. */
      cross3(Du, Dv, N);
      if (!normalize3(N)) N[0] = N[1] = N[2] = 0.0;
    }
  } else {
    cross3(Du, Dv, N);
    double scale = norm3(Du) * norm3(Dv);
    if (!(norm3(N) > 1e-14 * scale) || !normalize3(N)) {
      /* Parallel derivatives: step 1e-7 towards the (sub-)face centre. */
      Bfr::Parameterization param = s.GetParameterization();
      double c[2] = {0.5, 0.5};
      if (param.HasSubFaces()) {
        c[0] = std::floor(st[0] + 0.25) + 0.25;
        c[1] = std::floor(st[1] + 0.25) + 0.25;
      }
      double q[2] = {st[0] + 1e-7 * (c[0] - st[0]), st[1] + 1e-7 * (c[1] - st[1])};
      double Q[3], Qu[3], Qv[3];
      s.Evaluate(q, pp, PD(3), Q, Qu, Qv);
      cross3(Qu, Qv, N);
      if (!normalize3(N)) N[0] = N[1] = N[2] = 0.0;
    }
  }
  if (uv) S->tex[f].Evaluate(st, &S->tex_pts[2 * S->tex_off[f]], PD(2), uv);
}

void eval_uv(const ch_surface *S, int f, const double st[2], double uv[2]) {
  S->tex[f].Evaluate(st, &S->tex_pts[2 * S->tex_off[f]], PD(2), uv);
}

/* True when st lies in the domain of param (tolerance 1e-9). */
bool in_domain(const Bfr::Parameterization &param, double s, double t) {
  const double tol = 1e-9;
  if (!std::isfinite(s) || !std::isfinite(t)) return false;
  if (!param.HasSubFaces()) {
    if (s < -tol || t < -tol) return false;
    if (param.GetType() == Bfr::Parameterization::TRI) return s + t <= 1.0 + tol;
    return s <= 1.0 + tol && t <= 1.0 + tol;
  }
  double a = std::floor(s + tol), b = std::floor(t + tol);
  if (a < 0.0 || b < 0.0 || s > a + 0.5 + tol || t > b + 0.5 + tol) return false;
  /* The tiling: corner k sits at (k % U, k / U); U is the first corner
   * on the second row. */
  const int n = param.GetFaceSize();
  int U = 1;
  for (double c[2] = {0, 0}; U < n; U++) {
    param.GetVertexCoord(U, c);
    if (c[1] >= 1.0) break;
  }
  if (a >= U || b > n) return false;
  return (int)b * U + (int)a < n;
}

ch_status build(const ch_mesh *mesh, ch_scheme scheme, ch_surface *S, ch_error *err) {
  if (!mesh || mesh->num_faces <= 0 || !mesh->face_start || !mesh->corner_position ||
      !mesh->positions)
    return ch_error_set(err, CH_ERR_INPUT, "base mesh: no faces");
  if (!mesh->uvs || !mesh->corner_uv || mesh->num_uvs <= 0)
    return ch_error_set(err, CH_ERR_INPUT, "base mesh: no texture coordinates");
  if (scheme != CH_SCHEME_BILINEAR && scheme != CH_SCHEME_CATMARK)
    return ch_error_set(err, CH_ERR_INPUT, "unknown subdivision scheme %d", (int)scheme);
  const int nf = mesh->num_faces, np = mesh->num_positions;
  if (mesh->face_start[0] != 0 || mesh->face_start[nf] != mesh->num_corners)
    return ch_error_set(err, CH_ERR_INPUT, "base mesh: face offsets do not match the corner count");
  for (int f = 0; f < nf; f++) {
    int n = mesh->face_start[f + 1] - mesh->face_start[f];
    if (n < 3 || n > Bfr::Limits::MaxFaceSize())
      return ch_error_set(err, CH_ERR_INPUT, "base mesh: face %d has %d corners", f, n);
  }
  for (int c = 0; c < mesh->num_corners; c++) {
    if (mesh->corner_position[c] < 0 || mesh->corner_position[c] >= np)
      return ch_error_set(err, CH_ERR_INPUT, "base mesh: corner %d: position index out of range", c);
    if (mesh->corner_uv[c] < 0 || mesh->corner_uv[c] >= mesh->num_uvs)
      return ch_error_set(err, CH_ERR_INPUT, "base mesh: corner %d: UV index out of range", c);
  }
  for (long i = 0; i < 3L * np; i++)
    if (!std::isfinite(mesh->positions[i]))
      return ch_error_set(err, CH_ERR_INPUT, "base mesh: position %ld is not finite", i / 3);
  for (long i = 0; i < 2L * mesh->num_uvs; i++)
    if (!std::isfinite(mesh->uvs[i]))
      return ch_error_set(err, CH_ERR_INPUT, "base mesh: UV %ld is not finite", i / 2);

  S->scheme = scheme;
  S->num_faces = nf;
  S->num_positions = np;
  S->face_start.assign(mesh->face_start, mesh->face_start + nf + 1);
  S->corner_position.assign(mesh->corner_position, mesh->corner_position + mesh->num_corners);
  S->corner_uv.assign(mesh->corner_uv, mesh->corner_uv + mesh->num_corners);
  S->uvs.assign(mesh->uvs, mesh->uvs + 2 * (size_t)mesh->num_uvs);

  /* The refiner: vertex boundary interpolation edges-and-corners (SPEC §1),
   * face-varying UVs linear everywhere. */
  std::vector<int> verts_per_face(nf);
  for (int f = 0; f < nf; f++) verts_per_face[f] = mesh->face_start[f + 1] - mesh->face_start[f];
  Descriptor desc;
  desc.numVertices = np;
  desc.numFaces = nf;
  desc.numVertsPerFace = verts_per_face.data();
  desc.vertIndicesPerFace = mesh->corner_position;
  Descriptor::FVarChannel channel;
  channel.numValues = mesh->num_uvs;
  channel.valueIndices = mesh->corner_uv;
  desc.numFVarChannels = 1;
  desc.fvarChannels = &channel;
  Sdc::Options sdc;
  sdc.SetVtxBoundaryInterpolation(Sdc::Options::VTX_BOUNDARY_EDGE_AND_CORNER);
  sdc.SetFVarLinearInterpolation(Sdc::Options::FVAR_LINEAR_ALL);
  Sdc::SchemeType type = scheme == CH_SCHEME_CATMARK ? Sdc::SCHEME_CATMARK : Sdc::SCHEME_BILINEAR;

  std::string far_message;
  tl_far_error = &far_message;
  std::unique_ptr<Far::TopologyRefiner> refiner(
      Far::TopologyRefinerFactory<Descriptor>::Create(
          desc, Far::TopologyRefinerFactory<Descriptor>::Options(type, sdc)));
  tl_far_error = nullptr;
  if (!refiner)
    return ch_error_set(err, CH_ERR_INPUT, "base mesh: OpenSubdiv rejects the topology: %s",
                        far_message.empty() ? "no reason given" : far_message.c_str());

  /* Bfr surfaces and patch points, face by face (the factory's cache
   * shares irregular patches between faces; it is not thread-safe). */
  Bfr::RefinerSurfaceFactory<>::Options fopts;
  fopts.SetDefaultFVarID(0);
  Bfr::RefinerSurfaceFactory<> factory(*refiner, fopts);
  S->pos.resize(nf);
  S->tex.resize(nf);
  S->pos_off.resize(nf + 1);
  S->tex_off.resize(nf + 1);
  size_t npos = 0, ntex = 0;
  for (int f = 0; f < nf; f++) {
    if (!factory.InitSurfaces(f, &S->pos[f], &S->tex[f]) || !S->pos[f].IsValid() ||
        !S->tex[f].IsValid())
      return ch_error_set(err, CH_ERR_INPUT, "base mesh: face %d: OpenSubdiv cannot build its surface",
                          f);
    S->pos_off[f] = npos;
    S->tex_off[f] = ntex;
    npos += S->pos[f].GetNumPatchPoints();
    ntex += S->tex[f].GetNumPatchPoints();
  }
  S->pos_off[nf] = npos;
  S->tex_off[nf] = ntex;
  S->pos_pts.resize(3 * npos);
  S->tex_pts.resize(2 * ntex);
  for (int f = 0; f < nf; f++) {
    S->pos[f].PreparePatchPoints(mesh->positions, PD(3), &S->pos_pts[3 * S->pos_off[f]], PD(3));
    S->tex[f].PreparePatchPoints(mesh->uvs, PD(2), &S->tex_pts[2 * S->tex_off[f]], PD(2));
  }

  /* Bilinear N: unit vertex normals from area vectors (Newell), as a
   * second set of patch points of the position surfaces. */
  if (scheme == CH_SCHEME_BILINEAR) {
    std::vector<double> vn(3 * (size_t)np, 0.0);
    std::vector<unsigned char> used(np, 0);
    for (int f = 0; f < nf; f++) {
      int a = mesh->face_start[f], n = mesh->face_start[f + 1] - a;
      double area[3] = {0, 0, 0};
      for (int k = 0; k < n; k++) {
        const double *p = &mesh->positions[3 * mesh->corner_position[a + k]];
        const double *q = &mesh->positions[3 * mesh->corner_position[a + (k + 1) % n]];
        double c[3];
        cross3(p, q, c);
        area[0] += 0.5 * c[0], area[1] += 0.5 * c[1], area[2] += 0.5 * c[2];
      }
      for (int k = 0; k < n; k++) {
        int v = mesh->corner_position[a + k];
        used[v] = 1;
        for (int i = 0; i < 3; i++) vn[3 * v + i] += area[i];
      }
    }
    for (int v = 0; v < np; v++) {
      if (!used[v]) continue;
      if (!normalize3(&vn[3 * v]))
        return ch_error_set(err, CH_ERR_INPUT,
                            "base mesh: position %d: the faces around it have no area, so it has "
                            "no normal",
                            v);
    }
    S->nrm_pts.resize(3 * npos);
    for (int f = 0; f < nf; f++)
      S->pos[f].PreparePatchPoints(vn.data(), PD(3), &S->nrm_pts[3 * S->pos_off[f]], PD(3));
  }

  /* Edge topology from Far's base level. */
  const Far::TopologyLevel &L = refiner->GetLevel(0);
  const int ne = L.GetNumEdges();
  S->num_edges = ne;
  S->edge_vertices.resize(2 * (size_t)ne);
  for (int e = 0; e < ne; e++) {
    Far::ConstIndexArray ev = L.GetEdgeVertices(e);
    S->edge_vertices[2 * e] = ev[0];
    S->edge_vertices[2 * e + 1] = ev[1];
  }
  const int nc = mesh->num_corners;
  S->face_edge.resize(nc);
  S->face_edge_fwd.resize(nc);
  S->face_edge_group.assign(nc, 0);
  for (int f = 0; f < nf; f++) {
    Far::ConstIndexArray fv = L.GetFaceVertices(f), fe = L.GetFaceEdges(f);
    int a = mesh->face_start[f], n = fv.size();
    if (n != mesh->face_start[f + 1] - a)
      return ch_error_set(err, CH_ERR_INTERNAL, "face %d: OpenSubdiv changed its size", f);
    for (int k = 0; k < n; k++) {
      if (fv[k] != mesh->corner_position[a + k])
        return ch_error_set(err, CH_ERR_INTERNAL, "face %d: OpenSubdiv reordered its corners", f);
      S->face_edge[a + k] = fe[k];
      S->face_edge_fwd[a + k] = (unsigned char)(S->edge_vertices[2 * fe[k]] == fv[k]);
    }
  }
  /* Incident (face, corner) per edge, sorted by face then corner. */
  S->edge_face_start.assign(ne + 1, 0);
  for (int c = 0; c < nc; c++) S->edge_face_start[S->face_edge[c] + 1]++;
  for (int e = 0; e < ne; e++) S->edge_face_start[e + 1] += S->edge_face_start[e];
  S->edge_face.resize(nc);
  S->edge_corner.resize(nc);
  {
    std::vector<int> fill(S->edge_face_start.begin(), S->edge_face_start.end() - 1);
    for (int f = 0; f < nf; f++)
      for (int c = mesh->face_start[f]; c < mesh->face_start[f + 1]; c++) {
        int e = S->face_edge[c], slot = fill[e]++;
        S->edge_face[slot] = f;
        S->edge_corner[slot] = c - mesh->face_start[f];
      }
  }
  /* UV groups: sides of an edge with the same UV pair (in the edge's
   * direction) share their edge points' UVs; a seam has two groups. */
  S->edge_num_groups.assign(ne, 0);
  S->edge_group_start.assign(ne + 1, 0);
  S->edge_uv_length.assign(ne, 0.0);
  for (int e = 0; e < ne; e++) {
    int first = S->edge_face_start[e], last = S->edge_face_start[e + 1];
    int ng = 0;
    std::vector<std::pair<int, int>> keys;
    for (int i = first; i < last; i++) {
      int f = S->edge_face[i], k = S->edge_corner[i];
      int a = mesh->face_start[f], n = mesh->face_start[f + 1] - a;
      int c = a + k, c1 = a + (k + 1) % n;
      int u0 = mesh->corner_uv[c], u1 = mesh->corner_uv[c1];
      if (!S->face_edge_fwd[c]) std::swap(u0, u1);
      const double *p = &S->uvs[2 * u0], *q = &S->uvs[2 * u1];
      S->edge_uv_length[e] = std::max(S->edge_uv_length[e], std::hypot(q[0] - p[0], q[1] - p[1]));
      int g = 0;
      while (g < ng && keys[g] != std::make_pair(u0, u1)) g++;
      if (g == ng) {
        keys.emplace_back(u0, u1);
        S->edge_group_face.push_back(f);
        S->edge_group_corner.push_back(k);
        ng++;
      }
      S->face_edge_group[c] = g;
    }
    S->edge_num_groups[e] = ng;
    S->edge_group_start[e + 1] = S->edge_group_start[e] + ng;
  }
  /* Base vertices: compact output numbering, lowest face as owner. */
  S->vertex_out.assign(np, -1);
  S->vertex_face.assign(np, -1);
  S->vertex_corner.assign(np, -1);
  for (int f = nf - 1; f >= 0; f--)
    for (int c = mesh->face_start[f + 1] - 1; c >= mesh->face_start[f]; c--) {
      int v = mesh->corner_position[c];
      S->vertex_face[v] = f;
      S->vertex_corner[v] = c - mesh->face_start[f];
    }
  int nu = 0;
  for (int v = 0; v < np; v++)
    if (S->vertex_face[v] >= 0) S->vertex_out[v] = nu++;
  S->num_used_vertices = nu;
  return CH_OK;
}

}  // namespace

extern "C" ch_status ch_surface_create(const ch_mesh *mesh, ch_scheme scheme, ch_surface **out,
                                       ch_error *err) {
  if (out) *out = nullptr;
  if (!out) return ch_error_set(err, CH_ERR_INTERNAL, "ch_surface_create: out is NULL");
  ch_surface *S = nullptr;
  ch_status st = CH_OK;
  std::call_once(callbacks_once, [] {
    Far::SetErrorCallback(far_error);
    Far::SetWarningCallback(far_warning);
  });
  ch_error *saved = tl_err;
  tl_err = err;
  try {
    S = new ch_surface();
    st = build(mesh, scheme, S, err);
  } catch (const std::bad_alloc &) {
    st = ch_error_set(err, CH_ERR_NOMEM, "out of memory building the base surface");
  } catch (const std::exception &e) {
    st = ch_error_set(err, CH_ERR_INTERNAL, "OpenSubdiv: %s", e.what());
  } catch (...) {
    st = ch_error_set(err, CH_ERR_INTERNAL, "OpenSubdiv: unknown exception");
  }
  tl_err = saved;
  tl_far_error = nullptr;
  if (st != CH_OK) {
    delete S;
    return st;
  }
  *out = S;
  return CH_OK;
}

extern "C" void ch_surface_destroy(ch_surface *surface) { delete surface; }

extern "C" int ch_surface_num_faces(const ch_surface *S) { return S ? S->num_faces : 0; }

extern "C" ch_scheme ch_surface_scheme(const ch_surface *S) {
  return S ? S->scheme : CH_SCHEME_BILINEAR;
}

extern "C" int ch_surface_face_size(const ch_surface *S, int face) {
  if (!S || face < 0 || face >= S->num_faces) return 0;
  return S->face_start[face + 1] - S->face_start[face];
}

extern "C" ch_status ch_surface_corner_param(const ch_surface *S, int face, int k, double st[2]) {
  int n = ch_surface_face_size(S, face);
  if (!n || k < 0 || k >= n) return CH_ERR_INPUT;
  S->pos[face].GetParameterization().GetVertexCoord(k, st);
  return CH_OK;
}

extern "C" ch_status ch_surface_edge_param(const ch_surface *S, int face, int k, double x,
                                           double st[2]) {
  int n = ch_surface_face_size(S, face);
  if (!n || k < 0 || k >= n || !(x >= 0.0 && x <= 1.0)) return CH_ERR_INPUT;
  S->pos[face].GetParameterization().GetEdgeCoord(k, x, st);
  return CH_OK;
}

extern "C" ch_status ch_surface_eval_uv(const ch_surface *S, int face, double s, double t, double uv[2]) {
  if (!S || !uv || face < 0 || face >= S->num_faces) return CH_ERR_INPUT;
  try {
    if (!in_domain(S->pos[face].GetParameterization(), s, t)) return CH_ERR_INPUT;
    double st[2] = {s, t};
    eval_uv(S, face, st, uv);
  } catch (...) {
    return CH_ERR_INTERNAL;
  }
  return CH_OK;
}

extern "C" ch_status ch_surface_eval(const ch_surface *S, int face, double s, double t,
                                     ch_surface_point *out) {
  if (!S || !out || face < 0 || face >= S->num_faces) return CH_ERR_INPUT;
  try {
    if (!in_domain(S->pos[face].GetParameterization(), s, t)) return CH_ERR_INPUT;
    double st[2] = {s, t};
    eval_point(S, face, st, out->position, out->dpds, out->dpdt, out->normal, out->uv);
  } catch (...) {
    return CH_ERR_INTERNAL;
  }
  return CH_OK;
}

/* ---- tessellation ------------------------------------------------------ */

namespace {

/* The UVs of the ends of edge k of face f (corner k, then corner k + 1). */
void face_edge_uv(const ch_surface *S, int f, int k, const double **a, const double **b) {
  int s = S->face_start[f], n = S->face_start[f + 1] - s;
  *a = &S->uvs[2 * S->corner_uv[s + k]];
  *b = &S->uvs[2 * S->corner_uv[s + (k + 1) % n]];
}

/* Outer and inner rates of face f from the edge rates (see the header). */
int face_rates(const ch_surface *S, int f, const int *edge_rates, int *rates) {
  int a = S->face_start[f], n = S->face_start[f + 1] - a;
  long sum = 0;
  for (int k = 0; k < n; k++) {
    rates[k] = edge_rates[S->face_edge[a + k]];
    sum += rates[k];
  }
  if (n == 4) {
    rates[4] = (rates[0] + rates[2] + 1) / 2;
    rates[5] = (rates[1] + rates[3] + 1) / 2;
    return 6;
  }
  rates[n] = (int)((sum + n / 2) / n);
  return n + 1;
}

Bfr::Tessellation::Options tess_options() {
  Bfr::Tessellation::Options o;
  o.SetFacetSize(3);
  o.PreserveQuads(false);
  return o;
}

/* Triangle count of the whole mesh for these edge rates. Serial: it is
 * cheap (no evaluation), and the bisection calls it ~50 times, where a
 * parallel region each time costs a scheduler slice per call on a loaded
 * machine (measured: 8 ms on 1 thread became 580 ms on 2 busy cores). */
long count_triangles(const ch_surface *S, const int *edge_rates) {
  long total = 0;
  const Bfr::Tessellation::Options opts = tess_options();
  int rates[64];
  std::vector<int> big;
  for (int f = 0; f < S->num_faces; f++) {
    int n = S->face_start[f + 1] - S->face_start[f];
    int *r = rates;
    if (n + 2 > 64) {
      big.resize(n + 2);
      r = big.data();
    }
    int nr = face_rates(S, f, edge_rates, r);
    /* Bfr counts in int: a face that could overflow it is "too many". */
    long rmax = 0;
    for (int i = 0; i < nr; i++) rmax = std::max(rmax, (long)r[i]);
    if ((long)n * (rmax + 1) * (rmax + 1) > (1L << 30)) return std::numeric_limits<long>::max();
    Bfr::Tessellation tess(S->pos[f].GetParameterization(), nr, r, opts);
    total += tess.GetNumFacets();
  }
  return total;
}

/* Rates max(1, round(d L)); false when a rate would exceed kMaxRate. */
bool rates_for_density(const ch_surface *S, const double *length, double d, int *rates) {
  bool ok = true;
  for (int e = 0; e < S->num_edges; e++) {
    double r = std::floor(d * length[e] + 0.5);
    if (r > kMaxRate) {
      ok = false;
      r = kMaxRate;
    }
    rates[e] = r < 1.0 ? 1 : (int)r;
  }
  return ok;
}

ch_status choose_rates(const ch_surface *S, const ch_tess_desc *desc, const double *length,
                       std::vector<int> &rates, ch_error *err) {
  const int ne = S->num_edges;
  rates.assign(ne, 1);
  if (desc->uniform_rate > 0) {
    if (desc->uniform_rate > kMaxRate)
      return ch_error_set(err, CH_ERR_INPUT, "tessellation rate %d is above the maximum %d",
                          desc->uniform_rate, kMaxRate);
    rates.assign(ne, desc->uniform_rate);
    long c = count_triangles(S, rates.data());
    if (c > kMaxTriangles)
      return ch_error_set(err, CH_ERR_INPUT,
                          "tessellation rate %d gives more than the maximum of %ld triangles",
                          desc->uniform_rate, kMaxTriangles);
    return CH_OK;
  }
  const long target = desc->target_triangles;
  if (target > kMaxTriangles)
    return ch_error_set(err, CH_ERR_INPUT, "target of %ld triangles is above the maximum %ld", target,
                        kMaxTriangles);
  long cmin = count_triangles(S, rates.data());
  if (cmin >= target) {
    if (cmin <= target * 1.05) return CH_OK;
    return ch_error_set(err, CH_ERR_INPUT,
                        "target of %ld triangles is below the %ld this mesh has at rate 1", target,
                        cmin);
  }
  /* Bracket: count(lo) < target <= count(hi). */
  std::vector<int> rlo(ne), rhi(ne);
  double lo = 0.0, hi = 1.0;
  long chi;
  for (;;) {
    bool ok = rates_for_density(S, length, hi, rhi.data());
    chi = count_triangles(S, rhi.data());
    if (chi >= target) break;
    if (!ok)
      return ch_error_set(err, CH_ERR_INPUT,
                          "target of %ld triangles needs edge rates above the maximum %d", target,
                          kMaxRate);
    lo = hi;
    hi *= 2.0;
  }
  rates_for_density(S, length, lo, rlo.data());
  long clo = count_triangles(S, rlo.data());
  for (int it = 0; it < 200 && hi - lo > 1e-13 * hi; it++) {
    double mid = 0.5 * (lo + hi);
    std::vector<int> &r = rates;
    rates_for_density(S, length, mid, r.data());
    long c = count_triangles(S, r.data());
    if (c < target) {
      lo = mid, clo = c, rlo.swap(r);
    } else {
      hi = mid, chi = c, rhi.swap(r);
    }
  }
  long best = (target - clo <= chi - target) ? clo : chi;
  rates = (best == clo) ? rlo : rhi;
  if (std::labs(best - target) <= 0.05 * target) return CH_OK;

  /* Many edges of one length jump together at d: raise them one by one,
   * spread over the mesh (edge index times the golden ratio, mod 1). */
  std::vector<int> jump;
  for (int e = 0; e < ne; e++)
    if (rhi[e] != rlo[e]) jump.push_back(e);
  std::vector<double> key(ne);
  for (int e : jump) {
    double x = e * 0.6180339887498949;
    key[e] = x - std::floor(x);
  }
  std::stable_sort(jump.begin(), jump.end(), [&](int a, int b) { return key[a] < key[b]; });
  auto count_k = [&](size_t k, std::vector<int> &r) {
    r = rlo;
    for (size_t i = 0; i < k; i++) r[jump[i]] = rhi[jump[i]];
    return count_triangles(S, r.data());
  };
  size_t klo = 0, khi = jump.size();
  while (khi - klo > 1) {
    size_t mid = (klo + khi) / 2;
    std::vector<int> r;
    if (count_k(mid, r) < target)
      klo = mid;
    else
      khi = mid;
  }
  std::vector<int> ra, rb;
  long ca = count_k(klo, ra), cb = count_k(khi, rb);
  if (target - ca <= cb - target) {
    rates.swap(ra);
    best = ca;
  } else {
    rates.swap(rb);
    best = cb;
  }
  if (std::labs(best - target) <= 0.05 * target) return CH_OK;
  return ch_error_set(err, CH_ERR_INPUT, "cannot land within 5%% of %ld triangles (closest: %ld)",
                      target, best);
}

template <typename T>
T *alloc_array(size_t n) {
  T *p = (T *)std::calloc(n ? n : 1, sizeof(T));
  if (!p) throw std::bad_alloc();
  return p;
}

ch_status tess_build(const ch_surface *S, const ch_tess_desc *desc, ch_tess_result *out,
                     ch_error *err) {
  if (!desc || (desc->uniform_rate > 0) == (desc->target_triangles > 0) ||
      desc->uniform_rate < 0 || desc->target_triangles < 0)
    return ch_error_set(err, CH_ERR_INPUT,
                        "tessellation: give exactly one of a uniform rate or a triangle target");
  const int nf = S->num_faces, ne = S->num_edges;
  /* With a warp, edge lengths are measured in warped UV, and points go
   * evenly in warped UV along edges whose faces are all quads and inside
   * quads (a Coons blend of the four edges' placements, which is the exact
   * warped grid where W is separable over the quad, as on the plane). */
  const ch_warp *W = desc->warp;
  std::vector<double> warped_length;
  std::vector<unsigned char> remap;
  const double *length = S->edge_uv_length.data();
  if (W) {
    warped_length.assign(ne, 0.0);
    remap.assign(ne, 1);
    for (int e = 0; e < ne; e++)
      for (int i = S->edge_face_start[e]; i < S->edge_face_start[e + 1]; i++) {
        int f = S->edge_face[i], k = S->edge_corner[i];
        const double *a, *b;
        face_edge_uv(S, f, k, &a, &b);
        warped_length[e] = std::max(warped_length[e], ch_warp_mesh_arc(W, a, b, 1.0));
        if (S->face_start[f + 1] - S->face_start[f] != 4) remap[e] = 0;
      }
    length = warped_length.data();
  }
  /* The fraction along edge k of face f at which the point of fraction x
   * (unwarped) goes. */
  auto edge_place = [&](int f, int k, double x) {
    if (!W || !remap[S->face_edge[S->face_start[f] + k]]) return x;
    const double *a, *b;
    face_edge_uv(S, f, k, &a, &b);
    return ch_warp_mesh_arc_inverse(W, a, b, x);
  };
  std::vector<int> rates;
  ch_status st = choose_rates(S, desc, length, rates, err);
  if (st != CH_OK) return st;

  const Bfr::Tessellation::Options opts = tess_options();

  /* Sizes: per face interior points and triangles; per edge points. */
  std::vector<long> face_int(nf + 1, 0), face_tri(nf + 1, 0);
  int max_coords = 0, max_facets = 0;
  {
    std::vector<int> r;
    for (int f = 0; f < nf; f++) {
      r.resize(S->face_start[f + 1] - S->face_start[f] + 2);
      int nr = face_rates(S, f, rates.data(), r.data());
      Bfr::Tessellation tess(S->pos[f].GetParameterization(), nr, r.data(), opts);
      face_int[f + 1] = tess.GetNumInteriorCoords();
      face_tri[f + 1] = tess.GetNumFacets();
      max_coords = std::max(max_coords, tess.GetNumCoords());
      max_facets = std::max(max_facets, tess.GetNumFacets());
    }
  }
  std::vector<long> edge_pt(ne + 1, 0), edge_uv(ne + 1, 0);
  for (int e = 0; e < ne; e++) {
    edge_pt[e + 1] = edge_pt[e] + (rates[e] - 1);
    edge_uv[e + 1] = edge_uv[e] + (long)(rates[e] - 1) * S->edge_num_groups[e];
  }
  for (int f = 0; f < nf; f++) {
    face_int[f + 1] += face_int[f];
    face_tri[f + 1] += face_tri[f];
  }
  const long nb = S->num_used_vertices;
  const long npos = nb + edge_pt[ne] + face_int[nf];
  const long nuv0 = (long)(S->uvs.size() / 2);
  const long nuv = nuv0 + edge_uv[ne] + face_int[nf];
  const long ntri = face_tri[nf];
  if (ntri > kMaxTriangles || npos > kMaxTriangles || nuv > kMaxTriangles)
    return ch_error_set(err, CH_ERR_INPUT, "tessellation of %ld triangles is above the maximum %ld",
                        ntri, kMaxTriangles);

  ch_mesh &M = out->mesh;
  M.num_positions = (int)npos;
  M.positions = alloc_array<double>(3 * npos);
  M.num_faces = (int)ntri;
  M.face_start = alloc_array<int>(ntri + 1);
  M.num_corners = (int)(3 * ntri);
  M.corner_position = alloc_array<int>(3 * ntri);
  M.num_uvs = (int)nuv;
  M.uvs = alloc_array<double>(2 * nuv);
  M.corner_uv = alloc_array<int>(3 * ntri);
  M.num_normals = (int)npos;
  M.normals = alloc_array<double>(3 * npos);
  M.corner_normal = alloc_array<int>(3 * ntri);
  out->vertex_face = alloc_array<int>(npos);
  out->vertex_st = alloc_array<double>(2 * npos);
  out->triangle_face = alloc_array<int>(ntri);
  out->num_edges = ne;
  out->edge_rates = alloc_array<int>(ne);
  out->edge_vertices = alloc_array<int>(2 * (size_t)ne);
  std::copy(rates.begin(), rates.end(), out->edge_rates);
  std::copy(S->edge_vertices.begin(), S->edge_vertices.end(), out->edge_vertices);
  std::copy(S->uvs.begin(), S->uvs.end(), M.uvs);
  for (long i = 0; i <= ntri; i++) M.face_start[i] = (int)(3 * i);

  std::atomic<bool> failed(false);

  /* Base vertices, from their owner face (few: serial). */
  for (int v = 0; v < S->num_positions; v++) {
    int o = S->vertex_out[v];
    if (o < 0) continue;
    try {
      int f = S->vertex_face[v];
      double st2[2], du[3], dv[3];
      S->pos[f].GetParameterization().GetVertexCoord(S->vertex_corner[v], st2);
      eval_point(S, f, st2, &M.positions[3 * o], du, dv, &M.normals[3 * o], nullptr);
      out->vertex_face[o] = f;
      out->vertex_st[2 * o] = st2[0];
      out->vertex_st[2 * o + 1] = st2[1];
    } catch (...) {
      failed = true;
    }
  }

  /* Edge points, from the lowest face on the edge; UVs per UV group. */
#pragma omp parallel for schedule(dynamic, 64)
  for (int e = 0; e < ne; e++) {
    const int r = rates[e];
    if (r == 1) continue;
    try {
      int i0 = S->edge_face_start[e];
      int f = S->edge_face[i0], k = S->edge_corner[i0];
      bool fwd = S->face_edge_fwd[S->face_start[f] + k];
      Bfr::Parameterization param = S->pos[f].GetParameterization();
      for (int j = 0; j < r - 1; j++) {
        long o = nb + edge_pt[e] + j;
        double x = edge_place(f, k, fwd ? (double)(j + 1) / r : (double)(r - 1 - j) / r);
        double st2[2], du[3], dv[3];
        param.GetEdgeCoord(k, x, st2);
        eval_point(S, f, st2, &M.positions[3 * o], du, dv, &M.normals[3 * o], nullptr);
        out->vertex_face[o] = f;
        out->vertex_st[2 * o] = st2[0];
        out->vertex_st[2 * o + 1] = st2[1];
      }
      for (int g = 0; g < S->edge_num_groups[e]; g++) {
        int gi = S->edge_group_start[e] + g;
        int gf = S->edge_group_face[gi], gk = S->edge_group_corner[gi];
        bool gfwd = S->face_edge_fwd[S->face_start[gf] + gk];
        Bfr::Parameterization gparam = S->pos[gf].GetParameterization();
        for (int j = 0; j < r - 1; j++) {
          long o = nuv0 + edge_uv[e] + (long)g * (r - 1) + j;
          /* the same point as the positions' (one fraction per edge point) */
          double xf = edge_place(f, k, fwd ? (double)(j + 1) / r : (double)(r - 1 - j) / r);
          double x = gfwd == fwd ? xf : 1.0 - xf;
          double st2[2];
          gparam.GetEdgeCoord(gk, x, st2);
          eval_uv(S, gf, st2, &M.uvs[2 * o]);
        }
      }
    } catch (...) {
      failed = true;
    }
  }

  /* Faces: interior points and triangles. */
#pragma omp parallel
  {
    std::vector<int> r, bpos, buv, facets;
    std::vector<double> coords;
    try {
      coords.resize(2 * (size_t)max_coords);
      bpos.resize(max_coords);
      buv.resize(max_coords);
      facets.resize(3 * (size_t)max_facets);
    } catch (...) {
      failed = true;
    }
#pragma omp for schedule(dynamic, 16)
    for (int f = 0; f < nf; f++) {
      if (failed) continue;
      try {
        const int a = S->face_start[f], n = S->face_start[f + 1] - a;
        r.resize(n + 2);
        int nr = face_rates(S, f, rates.data(), r.data());
        Bfr::Parameterization param = S->pos[f].GetParameterization();
        Bfr::Tessellation tess(param, nr, r.data(), opts);
        const int nbd = tess.GetNumBoundaryCoords(), nint = tess.GetNumInteriorCoords();
        /* Boundary: corner k, then the rate-1 points of edge k. */
        int b = 0;
        for (int k = 0; k < n; k++) {
          int c = a + k;
          bpos[b] = S->vertex_out[S->corner_position[c]];
          buv[b] = S->corner_uv[c];
          b++;
          int e = S->face_edge[c], re = rates[e];
          bool fwd = S->face_edge_fwd[c];
          long ub = nuv0 + edge_uv[e] + (long)S->face_edge_group[c] * (re - 1);
          for (int j = 0; j < re - 1; j++, b++) {
            int jc = fwd ? j : re - 2 - j; /* canonical index */
            bpos[b] = (int)(nb + edge_pt[e] + jc);
            buv[b] = (int)(ub + jc);
          }
        }
        if (b != nbd) {
          failed = true;
          continue;
        }
        /* Interior points. */
        tess.GetInteriorCoords(coords.data());
        if (W && n == 4) {
          for (int i = 0; i < nint; i++) {
            double s0 = coords[2 * i], t0 = coords[2 * i + 1];
            /* edges 0 and 2 run along s (2 backwards), 1 and 3 along t (3 backwards) */
            double g0 = edge_place(f, 0, s0), g2 = 1.0 - edge_place(f, 2, 1.0 - s0);
            double g1 = edge_place(f, 1, t0), g3 = 1.0 - edge_place(f, 3, 1.0 - t0);
            coords[2 * i] = (1.0 - t0) * g0 + t0 * g2;
            coords[2 * i + 1] = (1.0 - s0) * g3 + s0 * g1;
          }
        }
        for (int i = 0; i < nint; i++) {
          long o = nb + edge_pt[ne] + face_int[f] + i;
          long u = nuv0 + edge_uv[ne] + face_int[f] + i;
          double du[3], dv[3];
          eval_point(S, f, &coords[2 * i], &M.positions[3 * o], du, dv, &M.normals[3 * o],
                     &M.uvs[2 * u]);
          out->vertex_face[o] = f;
          out->vertex_st[2 * o] = coords[2 * i];
          out->vertex_st[2 * o + 1] = coords[2 * i + 1];
        }
        /* Triangles. */
        int nt = tess.GetFacets(facets.data());
        const long ibase = nb + edge_pt[ne] + face_int[f] - nbd;
        const long ubase = nuv0 + edge_uv[ne] + face_int[f] - nbd;
        for (int t = 0; t < nt; t++) {
          long tri = face_tri[f] + t;
          out->triangle_face[tri] = f;
          for (int c = 0; c < 3; c++) {
            int i = facets[3 * t + c];
            int p = i < nbd ? bpos[i] : (int)(ibase + i);
            int u = i < nbd ? buv[i] : (int)(ubase + i);
            M.corner_position[3 * tri + c] = p;
            M.corner_normal[3 * tri + c] = p;
            M.corner_uv[3 * tri + c] = u;
          }
        }
      } catch (...) {
        failed = true;
      }
    }
  }
  if (failed)
    return ch_error_set(err, CH_ERR_INTERNAL, "tessellation failed inside OpenSubdiv");
  return CH_OK;
}

}  // namespace

extern "C" ch_status ch_tess_build(const ch_surface *surface, const ch_tess_desc *desc,
                                   ch_tess_result *out, ch_error *err) {
  if (!out) return ch_error_set(err, CH_ERR_INTERNAL, "ch_tess_build: out is NULL");
  std::memset(out, 0, sizeof *out);
  if (!surface) return ch_error_set(err, CH_ERR_INTERNAL, "ch_tess_build: surface is NULL");
  ch_status st;
  try {
    st = tess_build(surface, desc, out, err);
  } catch (const std::bad_alloc &) {
    st = ch_error_set(err, CH_ERR_NOMEM, "out of memory tessellating the base surface");
  } catch (const std::exception &e) {
    st = ch_error_set(err, CH_ERR_INTERNAL, "tessellation: %s", e.what());
  } catch (...) {
    st = ch_error_set(err, CH_ERR_INTERNAL, "tessellation: unknown exception");
  }
  if (st != CH_OK) ch_tess_free(out);
  return st;
}

extern "C" void ch_tess_free(ch_tess_result *r) {
  if (!r) return;
  ch_mesh_free(&r->mesh);
  std::free(r->vertex_face);
  std::free(r->vertex_st);
  std::free(r->triangle_face);
  std::free(r->edge_rates);
  std::free(r->edge_vertices);
  std::memset(r, 0, sizeof *r);
}
