/* References for test_tess. An independent Catmull-Clark evaluation: OpenSubdiv's
 * older Far path (adaptive refinement, PatchTable with Gregory-basis end
 * caps, local-point stencils, PatchMap::FindPatch, EvaluateBasis), as
 * DEPS.md verified it, sharing no code with tess/ch_surface.cpp (which uses
 * Bfr). Quad meshes only (ptex face = base face). Test code: exceptions
 * are caught and reported as failure. */
#include <cmath>
#include <cstring>
#include <memory>
#include <vector>

#include <opensubdiv/bfr/refinerSurfaceFactory.h>
#include <opensubdiv/bfr/surface.h>
#include <opensubdiv/far/patchMap.h>
#include <opensubdiv/far/patchTable.h>
#include <opensubdiv/far/patchTableFactory.h>
#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/far/stencilTable.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

using namespace OpenSubdiv;

namespace {
struct Point {
  double p[3];
  void Clear() { p[0] = p[1] = p[2] = 0.0; }
  void AddWithWeight(const Point &s, double w) {
    p[0] += w * s.p[0], p[1] += w * s.p[1], p[2] += w * s.p[2];
  }
};
}  // namespace

struct ref_catmark {
  std::unique_ptr<Far::TopologyRefiner> refiner;
  std::unique_ptr<Far::PatchTable> table;
  std::unique_ptr<Far::PatchMap> map;
  std::vector<Point> points; /* base + refined + local points */
  int num_refined = 0;
};

extern "C" ref_catmark *ref_catmark_create(int num_vertices, const double *positions, int num_faces,
                                           const int *verts_per_face, const int *indices,
                                           int level) {
  try {
    typedef Far::TopologyDescriptor D;
    D desc;
    desc.numVertices = num_vertices;
    desc.numFaces = num_faces;
    desc.numVertsPerFace = verts_per_face;
    desc.vertIndicesPerFace = indices;
    Sdc::Options sdc;
    sdc.SetVtxBoundaryInterpolation(Sdc::Options::VTX_BOUNDARY_EDGE_AND_CORNER);
    std::unique_ptr<ref_catmark> r(new ref_catmark);
    r->refiner.reset(Far::TopologyRefinerFactory<D>::Create(
        desc, Far::TopologyRefinerFactory<D>::Options(Sdc::SCHEME_CATMARK, sdc)));
    if (!r->refiner) return nullptr;
    Far::PatchTableFactory::Options po((unsigned)level);
    po.SetEndCapType(Far::PatchTableFactory::Options::ENDCAP_GREGORY_BASIS);
    po.SetPatchPrecision<double>();
    po.useInfSharpPatch = true;
    r->refiner->RefineAdaptive(po.GetRefineAdaptiveOptions());
    r->table.reset(Far::PatchTableFactory::Create(*r->refiner, po));
    r->num_refined = r->refiner->GetNumVerticesTotal();
    int nlocal = r->table->GetNumLocalPoints();
    r->points.resize(r->num_refined + nlocal);
    for (int v = 0; v < num_vertices; v++)
      std::memcpy(r->points[v].p, positions + 3 * v, sizeof r->points[v].p);
    Far::PrimvarRefinerReal<double> primvar(*r->refiner);
    Point *src = r->points.data();
    for (int l = 1; l < r->refiner->GetNumLevels(); l++) {
      Point *dst = src + r->refiner->GetLevel(l - 1).GetNumVertices();
      primvar.Interpolate(l, src, dst);
      src = dst;
    }
    if (nlocal) {
      const Far::StencilTableReal<double> *st = r->table->GetLocalPointStencilTable<double>();
      st->UpdateValues(r->points.data(), r->points.data() + r->num_refined);
    }
    r->map.reset(new Far::PatchMap(*r->table));
    return r.release();
  } catch (...) {
    return nullptr;
  }
}

/* 0 on success. */
extern "C" int ref_catmark_eval(const ref_catmark *r, int face, double s, double t, double P[3],
                                double Ds[3], double Dt[3]) {
  try {
    const Far::PatchTable::PatchHandle *h = r->map->FindPatch(face, s, t);
    if (!h) return 1;
    double wP[20], wDs[20], wDt[20];
    r->table->EvaluateBasis(*h, s, t, wP, wDs, wDt);
    Far::ConstIndexArray cvs = r->table->GetPatchVertices(*h);
    for (int i = 0; i < 3; i++) P[i] = Ds[i] = Dt[i] = 0.0;
    for (int k = 0; k < cvs.size(); k++)
      for (int i = 0; i < 3; i++) {
        const double x = r->points[cvs[k]].p[i];
        P[i] += wP[k] * x, Ds[i] += wDs[k] * x, Dt[i] += wDt[k] * x;
      }
    return 0;
  } catch (...) {
    return 1;
  }
}

extern "C" void ref_catmark_destroy(ref_catmark *r) { delete r; }

/* The base surface as ch_surface built it before sharing linear surfaces:
 * a Bfr surface per face for positions and for UVs, with its patch points
 * prepared from the mesh (Surface::PreparePatchPoints), and under the
 * bilinear scheme the Newell vertex normals as patch points of the
 * position surface. test_tess compares ch_surface_eval with it bit for
 * bit. */
struct ref_bfr {
  bool bilinear = true;
  std::vector<Bfr::Surface<double>> pos, tex;
  std::vector<std::vector<double>> pos_pts, nrm_pts, tex_pts;
};

extern "C" ref_bfr *ref_bfr_create(int num_positions, const double *positions, int num_uvs, const double *uvs,
                                   int num_faces, const int *face_start, const int *corner_position,
                                   const int *corner_uv, int catmark) {
  try {
    typedef Far::TopologyDescriptor D;
    std::vector<int> sizes(num_faces);
    for (int f = 0; f < num_faces; f++) sizes[f] = face_start[f + 1] - face_start[f];
    D desc;
    desc.numVertices = num_positions;
    desc.numFaces = num_faces;
    desc.numVertsPerFace = sizes.data();
    desc.vertIndicesPerFace = corner_position;
    D::FVarChannel channel;
    channel.numValues = num_uvs;
    channel.valueIndices = corner_uv;
    desc.numFVarChannels = 1;
    desc.fvarChannels = &channel;
    Sdc::Options sdc;
    sdc.SetVtxBoundaryInterpolation(Sdc::Options::VTX_BOUNDARY_EDGE_AND_CORNER);
    sdc.SetFVarLinearInterpolation(Sdc::Options::FVAR_LINEAR_ALL);
    std::unique_ptr<Far::TopologyRefiner> refiner(Far::TopologyRefinerFactory<D>::Create(
        desc, Far::TopologyRefinerFactory<D>::Options(catmark ? Sdc::SCHEME_CATMARK : Sdc::SCHEME_BILINEAR, sdc)));
    if (!refiner) return nullptr;
    std::unique_ptr<ref_bfr> r(new ref_bfr);
    r->bilinear = !catmark;
    std::vector<double> vn(3 * (size_t)num_positions, 0.0);
    for (int f = 0; f < num_faces; f++) {
      int a = face_start[f], n = sizes[f];
      double area[3] = {0, 0, 0};
      for (int k = 0; k < n; k++) {
        const double *p = &positions[3 * corner_position[a + k]], *q = &positions[3 * corner_position[a + (k + 1) % n]];
        area[0] += 0.5 * (p[1] * q[2] - p[2] * q[1]);
        area[1] += 0.5 * (p[2] * q[0] - p[0] * q[2]);
        area[2] += 0.5 * (p[0] * q[1] - p[1] * q[0]);
      }
      for (int k = 0; k < n; k++)
        for (int i = 0; i < 3; i++) vn[3 * corner_position[a + k] + i] += area[i];
    }
    for (int v = 0; v < num_positions; v++) {
      double *x = &vn[3 * v], l = std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
      if (l > 0.0) x[0] /= l, x[1] /= l, x[2] /= l;
    }
    Bfr::RefinerSurfaceFactory<>::Options fopts;
    fopts.SetDefaultFVarID(0);
    Bfr::RefinerSurfaceFactory<> factory(*refiner, fopts);
    r->pos.resize(num_faces);
    r->tex.resize(num_faces);
    r->pos_pts.resize(num_faces);
    r->nrm_pts.resize(num_faces);
    r->tex_pts.resize(num_faces);
    typedef Bfr::Surface<double>::PointDescriptor PD;
    for (int f = 0; f < num_faces; f++) {
      if (!factory.InitSurfaces(f, &r->pos[f], &r->tex[f])) return nullptr;
      r->pos_pts[f].resize(3 * (size_t)r->pos[f].GetNumPatchPoints());
      r->nrm_pts[f].resize(3 * (size_t)r->pos[f].GetNumPatchPoints());
      r->tex_pts[f].resize(2 * (size_t)r->tex[f].GetNumPatchPoints());
      r->pos[f].PreparePatchPoints(positions, PD(3), r->pos_pts[f].data(), PD(3));
      r->pos[f].PreparePatchPoints(vn.data(), PD(3), r->nrm_pts[f].data(), PD(3));
      r->tex[f].PreparePatchPoints(uvs, PD(2), r->tex_pts[f].data(), PD(2));
    }
    return r.release();
  } catch (...) {
    return nullptr;
  }
}

/* P, its derivatives and UV at (s,t) of face; under the bilinear scheme
 * also the interpolated vertex normal, not normalised (N is left alone
 * under catmark). 0 on success. */
extern "C" int ref_bfr_eval(const ref_bfr *r, int face, double s, double t, double P[3], double Ds[3], double Dt[3],
                            double N[3], double uv[2]) {
  try {
    typedef Bfr::Surface<double>::PointDescriptor PD;
    double st[2] = {s, t};
    r->pos[face].Evaluate(st, r->pos_pts[face].data(), PD(3), P, Ds, Dt);
    if (r->bilinear) r->pos[face].Evaluate(st, r->nrm_pts[face].data(), PD(3), N);
    r->tex[face].Evaluate(st, r->tex_pts[face].data(), PD(2), uv);
    return 0;
  } catch (...) {
    return 1;
  }
}

extern "C" void ref_bfr_destroy(ref_bfr *r) { delete r; }
