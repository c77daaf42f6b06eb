/* ch_surface_internal: the base surface's handle and its evaluation, shared
 * by the surface (ch_surface.cpp) and the tessellation (ch_tess.cpp), the
 * two files that include OpenSubdiv. C++ only, not installed. */
#ifndef CH_SURFACE_INTERNAL_H
#define CH_SURFACE_INTERNAL_H

#include <cmath>
#include <cstddef>
#include <exception>
#include <new>
#include <vector>

#include <opensubdiv/bfr/surface.h>

#include "ch_math.h"
#include "ch_surface.h"

namespace ch_surface_detail {

using namespace OpenSubdiv;

typedef Bfr::Surface<double> Surface;
typedef Surface::PointDescriptor PD;

/* Bfr clamps larger rates silently (to SHRT_MAX): refuse them instead. */
constexpr int kMaxRate = 32767;
/* Output sizes stay far below int overflow of corner indices. */
constexpr long kMaxTriangles = 1L << 28;

/* The C boundary of an entry point: runs fn (returning a ch_status) and
 * turns any exception into a status and one line, "out of memory DOING"
 * or "WHO: what()", so that no exception crosses into C. */
template <class Fn>
ch_status guarded(ch_error *err, const char *doing, const char *who, Fn fn) {
  try {
    return fn();
  } catch (const std::bad_alloc &) {
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory %s", doing);
  } catch (const std::exception &e) {
    return ch_error_set(err, CH_ERR_INTERNAL, "%s: %s", who, e.what());
  } catch (...) {
    return ch_error_set(err, CH_ERR_INTERNAL, "%s: unknown exception", who);
  }
}

}  // namespace ch_surface_detail

/* The handle: what ch_surface_create prepares, read by evaluation and
 * tessellation alike. */
struct ch_surface {
  ch_scheme scheme = CH_SCHEME_BILINEAR;
  int num_faces = 0;
  int num_positions = 0;
  /* The mesh's topology and UVs (copied). */
  std::vector<int> face_start, corner_position, corner_uv;
  std::vector<double> uvs;
  /* Per face: surfaces and offsets (in points) of their patch points. */
  std::vector<ch_surface_detail::Surface> pos, tex;
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
  /* The UVs at the corners of each face's bilinear patches (ch_surface_patch_uvs):
   * 8 per patch, face f's from patch_start[f]. */
  std::vector<int> patch_start;
  std::vector<double> patch_uv;
};

namespace ch_surface_detail {

/* Evaluates position, derivatives, normal and UV at st of face f. */
inline void eval_point(const ch_surface *S, int f, const double st[2], double P[3], double Du[3],
                double Dv[3], double N[3], double uv[2]) {
  const Surface &s = S->pos[f];
  const double *pp = &S->pos_pts[3 * S->pos_off[f]];
  s.Evaluate(st, pp, PD(3), P, Du, Dv);
  if (S->scheme == CH_SCHEME_BILINEAR) {
    s.Evaluate(st, &S->nrm_pts[3 * S->pos_off[f]], PD(3), N);
    if (!ch_normalize3(N)) {
      /* The interpolated vertex normals cancel: use the patch's own. */
      ch_cross3(Du, Dv, N);
      if (!ch_normalize3(N)) N[0] = N[1] = N[2] = 0.0;
    }
  } else {
    ch_cross3(Du, Dv, N);
    double scale = ch_len3(Du) * ch_len3(Dv);
    if (!(ch_len3(N) > 1e-14 * scale) || !ch_normalize3(N)) {
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
      ch_cross3(Qu, Qv, N);
      if (!ch_normalize3(N)) N[0] = N[1] = N[2] = 0.0;
    }
  }
  if (uv) S->tex[f].Evaluate(st, &S->tex_pts[2 * S->tex_off[f]], PD(2), uv);
}

inline void eval_uv(const ch_surface *S, int f, const double st[2], double uv[2]) {
  S->tex[f].Evaluate(st, &S->tex_pts[2 * S->tex_off[f]], PD(2), uv);
}

}  // namespace ch_surface_detail

#endif
