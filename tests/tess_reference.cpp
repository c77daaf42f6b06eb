/* An independent Catmull-Clark evaluation for test_tess: OpenSubdiv's
 * older Far path (adaptive refinement, PatchTable with Gregory-basis end
 * caps, local-point stencils, PatchMap::FindPatch, EvaluateBasis), as
 * DEPS.md verified it, sharing no code with tess/ch_surface.cpp (which uses
 * Bfr). Quad meshes only (ptex face = base face). Test code: exceptions
 * are caught and reported as failure. */
#include <cstring>
#include <memory>
#include <vector>

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
