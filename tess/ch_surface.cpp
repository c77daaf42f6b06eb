/* ch_surface: the base surface of docs/spec.md §1 through OpenSubdiv 3.5 (Far
 * topology, Bfr evaluation and tessellation patterns) behind a C API.
 *
 * This file and ch_tess.cpp are the only ones of chisel that include
 * OpenSubdiv (sharing ch_surface_internal.h). Every entry
 * point catches every exception; OpenSubdiv's error and warning callbacks
 * (process-global) are routed into the ch_error of the calling thread.
 *
 * Evaluation: Bfr::Surface<double>s for positions (limit surface for
 * catmark, bilinear patches for bilinear) and for the face-varying UVs
 * (FVAR_LINEAR_ALL: linear per face whatever the scheme). Catmark
 * positions have a surface per face and its patch points prepared at
 * creation. A linear surface depends on its face's size alone: one per
 * size serves every face, its patch points made from the face's corners
 * when evaluating (ch_surface_internal.h), the values Bfr gives a surface
 * per face bit for bit (test_tess). Under the bilinear scheme N is the
 * unit vertex normals taken as patch points of the position surface (the
 * same weights as the position), normalised: docs/spec.md §1's N. */
#include "ch_surface.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <mutex>
#include <new>
#include <string>
#include <thread>
#include <vector>

#include <opensubdiv/bfr/limits.h>
#include <opensubdiv/bfr/refinerSurfaceFactory.h>
#include <opensubdiv/bfr/surface.h>
#include <opensubdiv/far/error.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

#include "ch_surface_internal.h"

using namespace OpenSubdiv;
using namespace ch_surface_detail;

namespace {

typedef Far::TopologyDescriptor Descriptor;

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

}  // namespace

namespace {

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

  /* The refiner: vertex boundary interpolation edges-and-corners (docs/spec.md §1),
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

  /* Bfr surfaces: the linear ones, one per face size, from the first face
   * of that size; catmark positions face by face (the factory's cache
   * shares irregular patches between faces; it is not thread-safe). */
  const bool linear_pos = scheme == CH_SCHEME_BILINEAR;
  Bfr::RefinerSurfaceFactory<>::Options fopts;
  fopts.SetDefaultFVarID(0);
  Bfr::RefinerSurfaceFactory<> factory(*refiner, fopts);
  int max_size = 0;
  for (int f = 0; f < nf; f++) max_size = std::max(max_size, verts_per_face[f]);
  S->linear_tex.resize(max_size + 1);
  if (linear_pos)
    S->linear_pos.resize(max_size + 1);
  else {
    S->pos.resize(nf);
    S->pos_off.resize(nf + 1);
  }
  for (int f = 0; f < nf; f++) {
    Surface &tex = S->linear_tex[verts_per_face[f]];
    bool built = true;
    if (!tex.IsValid()) {
      Surface *pos = linear_pos ? &S->linear_pos[verts_per_face[f]] : &S->pos[f];
      built = factory.InitSurfaces(f, pos, &tex) && pos->IsValid() && tex.IsValid();
      if (built && (!tex.IsLinear() || (linear_pos && !pos->IsLinear())))
        return ch_error_set(err, CH_ERR_INTERNAL, "face %d: OpenSubdiv's surface is not linear", f);
    } else if (!linear_pos) {
      built = factory.InitVertexSurface(f, &S->pos[f]) && S->pos[f].IsValid();
    }
    if (!built) return ch_error_set(err, CH_ERR_INPUT, "base mesh: face %d: OpenSubdiv cannot build its surface", f);
  }
  S->positions.assign(mesh->positions, mesh->positions + 3 * (size_t)np);
  if (!linear_pos) {
    /* The irregular surfaces' patch points, stored where they average at
     * most kStoredPatchPoints a face (see there). */
    size_t irregular = 0;
    for (int f = 0; f < nf; f++)
      if (!S->pos[f].IsRegular()) irregular += (size_t)S->pos[f].GetNumPatchPoints();
    bool store = irregular <= (size_t)kStoredPatchPoints * (size_t)nf;
    size_t npos = 0;
    for (int f = 0; f < nf; f++) {
      S->pos_off[f] = npos;
      if (store && !S->pos[f].IsRegular()) npos += (size_t)S->pos[f].GetNumPatchPoints();
    }
    S->pos_off[nf] = npos;
    S->pos_pts.resize(3 * npos);
#pragma omp parallel for schedule(dynamic, 1024)
    for (int f = 0; f < nf; f++)
      if (S->pos_off[f + 1] > S->pos_off[f])
        S->pos[f].PreparePatchPoints(mesh->positions, PD(3), &S->pos_pts[3 * S->pos_off[f]], PD(3));
  }

  /* Bilinear: N's unit vertex normals from area vectors (Newell). */
  if (linear_pos) {
    large_vector<double> &vn = S->vertex_normals;
    vn.assign(3 * (size_t)np, 0.0);
    std::vector<unsigned char> used(np, 0);
    for (int f = 0; f < nf; f++) {
      int a = mesh->face_start[f], n = mesh->face_start[f + 1] - a;
      double area[3] = {0, 0, 0};
      for (int k = 0; k < n; k++) {
        const double *p = &mesh->positions[3 * mesh->corner_position[a + k]];
        const double *q = &mesh->positions[3 * mesh->corner_position[a + (k + 1) % n]];
        double c[3];
        ch_cross3(p, q, c);
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
      if (!ch_normalize3(&vn[3 * v]))
        return ch_error_set(err, CH_ERR_INPUT,
                            "base mesh: position %d (counting from 0): the faces around it have no "
                            "area, or as much facing one way as the other, so it has no normal",
                            v);
    }
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
  /* Room for the patches' corner UVs, made face by face at first use
   * (ch_surface_patch_uvs): pages no face touches cost nothing. */
  S->patch_start.resize(nf + 1);
  S->patch_start[0] = 0;
  for (int f = 0; f < nf; f++) {
    int n = verts_per_face[f];
    S->patch_start[f + 1] = S->patch_start[f] + (n == 4 ? 1 : n);
  }
  S->patch_uv.resize(8 * (size_t)S->patch_start[nf]);
  S->patch_state.reset(new std::atomic<unsigned char>[nf]());
  return CH_OK;
}

/* Face f's patches' corner UVs into out (8 numbers a patch). */
void face_patch_uvs(const ch_surface *S, int f, double *out) {
  static const double local[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  face_eval fe(S, f);
  int npatch = S->patch_start[f + 1] - S->patch_start[f];
  for (int k = 0; k < npatch; k++) {
    double origin[2] = {0.0, 0.0}, scale = 1.0;
    if (npatch > 1) {
      pos_surface(S, f).GetParameterization().GetVertexCoord(k, origin);
      scale = 0.5;
    }
    for (int c = 0; c < 4; c++) {
      double st[2] = {origin[0] + scale * local[c][0], origin[1] + scale * local[c][1]};
      fe.uv(st, &out[8 * (size_t)k + 2 * (size_t)c]);
    }
  }
}

}  // namespace

extern "C" ch_status ch_surface_create(const ch_mesh *mesh, ch_scheme scheme, ch_surface **out,
                                       ch_error *err) {
  if (out) *out = nullptr;
  if (!out) return ch_error_set(err, CH_ERR_INTERNAL, "ch_surface_create: out is NULL");
  /* C callers may pass any int: read it as one (loading an enum out of
   * its range is undefined in C++, and UBSan says so). */
  int scheme_value = 0;
  std::memcpy(&scheme_value, &scheme, sizeof scheme < sizeof scheme_value ? sizeof scheme : sizeof scheme_value);
  if (scheme_value != CH_SCHEME_BILINEAR && scheme_value != CH_SCHEME_CATMARK)
    return ch_error_set(err, CH_ERR_INPUT, "unknown subdivision scheme %d", scheme_value);
  ch_surface *S = nullptr;
  ch_status st = CH_OK;
  std::call_once(callbacks_once, [] {
    Far::SetErrorCallback(far_error);
    Far::SetWarningCallback(far_warning);
  });
  ch_error *saved = tl_err;
  tl_err = err;
  st = guarded(err, "building the base surface", "OpenSubdiv", [&] {
    S = new ch_surface();
    return build(mesh, scheme, S, err);
  });
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
  pos_surface(S, face).GetParameterization().GetVertexCoord(k, st);
  return CH_OK;
}

extern "C" const double *ch_surface_patch_uvs(const ch_surface *S, int face, int *num_patches) {
  if (!S || face < 0 || face >= S->num_faces) {
    if (num_patches) *num_patches = 0;
    return nullptr;
  }
  double *uv = &S->patch_uv[8 * (size_t)S->patch_start[face]];
  /* 0: not made, 1: being made (by another thread: wait, a few evaluations
   * long), 2: made (its values published by the release store). */
  std::atomic<unsigned char> &state = S->patch_state[face];
  for (;;) {
    unsigned char seen = state.load(std::memory_order_acquire);
    if (seen == 2) break;
    if (seen == 0 && state.compare_exchange_weak(seen, 1, std::memory_order_acquire)) {
      try {
        face_patch_uvs(S, face, uv);
      } catch (...) { /* out of memory (a face of over 16 corners): not made */
        state.store(0, std::memory_order_release);
        if (num_patches) *num_patches = 0;
        return nullptr;
      }
      state.store(2, std::memory_order_release);
      break;
    }
    std::this_thread::yield();
  }
  if (num_patches) *num_patches = S->patch_start[face + 1] - S->patch_start[face];
  return uv;
}

extern "C" ch_status ch_surface_edge_param(const ch_surface *S, int face, int k, double x,
                                           double st[2]) {
  int n = ch_surface_face_size(S, face);
  if (!n || k < 0 || k >= n || !(x >= 0.0 && x <= 1.0)) return CH_ERR_INPUT;
  pos_surface(S, face).GetParameterization().GetEdgeCoord(k, x, st);
  return CH_OK;
}

extern "C" ch_status ch_surface_eval_uv(const ch_surface *S, int face, double s, double t, double uv[2]) {
  if (!S || !uv || face < 0 || face >= S->num_faces) return CH_ERR_INPUT;
  try {
    if (!in_domain(pos_surface(S, face).GetParameterization(), s, t)) return CH_ERR_INPUT;
    double st[2] = {s, t};
    face_eval(S, face).uv(st, uv);
  } catch (...) {
    return CH_ERR_INTERNAL;
  }
  return CH_OK;
}

extern "C" ch_status ch_surface_eval_position(const ch_surface *S, int face, double s, double t, double P[3],
                                              double N[3]) {
  if (!S || !P || !N || face < 0 || face >= S->num_faces) return CH_ERR_INPUT;
  try {
    if (!in_domain(pos_surface(S, face).GetParameterization(), s, t)) return CH_ERR_INPUT;
    double st[2] = {s, t};
    face_eval fe(S, face);
    if (S->scheme == CH_SCHEME_BILINEAR && fe.bilinear(st, P, nullptr, nullptr, N)) return CH_OK;
    double Du[3], Dv[3];
    fe.point(st, P, Du, Dv, N, nullptr);
  } catch (...) {
    return CH_ERR_INTERNAL;
  }
  return CH_OK;
}

extern "C" ch_status ch_surface_eval(const ch_surface *S, int face, double s, double t,
                                     ch_surface_point *out) {
  if (!S || !out || face < 0 || face >= S->num_faces) return CH_ERR_INPUT;
  try {
    if (!in_domain(pos_surface(S, face).GetParameterization(), s, t)) return CH_ERR_INPUT;
    double st[2] = {s, t};
    eval_point(S, face, st, out->position, out->dpds, out->dpdt, out->normal, out->uv);
  } catch (...) {
    return CH_ERR_INTERNAL;
  }
  return CH_OK;
}

