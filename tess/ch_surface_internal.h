/* ch_surface_internal: the base surface's handle and its evaluation, shared
 * by the surface (ch_surface.cpp) and the tessellation (ch_tess.cpp), the
 * two files that include OpenSubdiv. C++ only, not installed. */
#ifndef CH_SURFACE_INTERNAL_H
#define CH_SURFACE_INTERNAL_H

#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdlib>
#include <exception>
#include <memory>
#include <new>
#include <utility>
#include <vector>

#include <opensubdiv/bfr/surface.h>

#include "ch_alloc.h"
#include "ch_math.h"
#include "ch_surface.h"

namespace ch_surface_detail {

using namespace OpenSubdiv;

typedef Bfr::Surface<double> Surface;
typedef Surface::PointDescriptor PD;

/* The allocator of the per-face and per-corner arrays: ch_alloc_large's
 * huge pages, and elements left uninitialised by resize (each is written
 * once; a 2M-face mesh's patch points and surfaces were otherwise zeroed
 * and faulted in 4 KiB at a time, half of building its surface). */
template <class T>
struct large_allocator {
  typedef T value_type;
  large_allocator() = default;
  template <class U>
  large_allocator(const large_allocator<U> &) {}
  T *allocate(size_t n) {
    void *p = ch_alloc_large(n, sizeof(T), 0);
    if (!p) throw std::bad_alloc();
    return static_cast<T *>(p);
  }
  void deallocate(T *p, size_t) { std::free(p); }
  template <class U>
  void construct(U *p) {
    ::new (static_cast<void *>(p)) U;
  }
  template <class U, class... Args>
  void construct(U *p, Args &&...args) {
    ::new (static_cast<void *>(p)) U(std::forward<Args>(args)...);
  }
  template <class U>
  bool operator==(const large_allocator<U> &) const {
    return true;
  }
  template <class U>
  bool operator!=(const large_allocator<U> &) const {
    return false;
  }
};
template <class T>
using large_vector = std::vector<T, large_allocator<T>>;

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
  ch_surface_detail::large_vector<int> face_start, corner_position, corner_uv;
  ch_surface_detail::large_vector<double> uvs;
  /* The surfaces. A linear surface (the UVs of every face; the positions
   * of every face under the bilinear scheme) is evaluated from its patch
   * points with its face size alone (Bfr's linear patches: no topology
   * beyond the face's own corners), so one surface per face size serves all
   * such faces: linear_pos and linear_tex, indexed by face size. Their
   * patch points are the face's corner values followed by those Bfr derives
   * from them, made when evaluating (linear_points): stored, they were
   * 390 bytes per triangle of a dense base mesh. Catmark positions keep a
   * surface per face (pos; empty under bilinear); the patch points of the
   * irregular ones are stored (pos_pts, face f's from pos_off[f], none
   * where pos_off[f + 1] == pos_off[f]) or made when evaluating, as a
   * regular one's are (see kStoredPatchPoints). */
  ch_surface_detail::large_vector<ch_surface_detail::Surface> pos;
  std::vector<ch_surface_detail::Surface> linear_pos, linear_tex;
  ch_surface_detail::large_vector<size_t> pos_off;
  ch_surface_detail::large_vector<double> pos_pts;
  /* The mesh's positions, and under bilinear its unit vertex normals (3
   * per position): the values patch points are made from. */
  ch_surface_detail::large_vector<double> positions, vertex_normals;
  /* Edges (Far's base level numbering). */
  int num_edges = 0;
  ch_surface_detail::large_vector<int> edge_vertices;           /* 2 per edge */
  ch_surface_detail::large_vector<int> face_edge;               /* per corner: the edge from corner k to k+1 */
  ch_surface_detail::large_vector<unsigned char> face_edge_fwd; /* per corner: runs edge_vertices[0] -> [1] */
  ch_surface_detail::large_vector<int> face_edge_group;         /* per corner: UV group of that edge side */
  ch_surface_detail::large_vector<int> edge_face_start;         /* CSR over edges: incident (face, corner) */
  ch_surface_detail::large_vector<int> edge_face, edge_corner;  /* sorted by face */
  ch_surface_detail::large_vector<int> edge_num_groups;         /* distinct UV pairs along the edge */
  ch_surface_detail::large_vector<int> edge_group_face, edge_group_corner; /* per (edge, group): first face */
  ch_surface_detail::large_vector<int> edge_group_start;                   /* CSR over edges into edge_group_* */
  ch_surface_detail::large_vector<double> edge_uv_length;                  /* max over the edge's sides */
  /* Base vertices: output index (-1 unused), owner face and corner. */
  int num_used_vertices = 0;
  ch_surface_detail::large_vector<int> vertex_out, vertex_face, vertex_corner;
  /* The UVs at the corners of each face's bilinear patches (ch_surface_patch_uvs):
   * 8 per patch, face f's from patch_start[f], made at the first call for
   * that face (patch_state[f]: 0 not yet, 1 being made, 2 made). */
  ch_surface_detail::large_vector<int> patch_start;
  mutable ch_surface_detail::large_vector<double> patch_uv;
  std::unique_ptr<std::atomic<unsigned char>[]> patch_state;
};

namespace ch_surface_detail {

/* Catmark patch points: a regular surface's are its 16 control points,
 * gathered when evaluating; an irregular one's (65-256 on the bundled
 * meshes) take a stencil product to make, so they are stored, unless they
 * average more than this a face over the mesh (a triangle mesh: 212 a
 * triangle under Catmull-Clark, 5 KB each, 11 GB for a 2M-triangle base),
 * where they are made when evaluating. */
constexpr int kStoredPatchPoints = 64;

/* The surfaces of face f's positions and UVs. */
inline const Surface &pos_surface(const ch_surface *S, int f) {
  return S->scheme == CH_SCHEME_BILINEAR ? S->linear_pos[S->face_start[f + 1] - S->face_start[f]] : S->pos[f];
}
inline const Surface &tex_surface(const ch_surface *S, int f) {
  return S->linear_tex[S->face_start[f + 1] - S->face_start[f]];
}

/* Room for a linear surface's patch points: on the stack for faces of up
 * to 16 corners (2n + 1 points of up to 3 values), on the heap beyond. */
class patch_buffer {
 public:
  double *get(size_t n) {
    if (n <= sizeof small / sizeof small[0]) return small;
    big.resize(n);
    return big.data();
  }

 private:
  double small[3 * 33];
  std::vector<double> big;
};

/* The patch points of linear surface s on face f: its corners' values
 * (dim per value, values[dim * index[corner]]) gathered as
 * Surface::PreparePatchPoints gathers them, the rest computed by Bfr. */
inline const double *linear_points(const ch_surface *S, const Surface &s, int f, const double *values, const int *index,
                                   int dim, patch_buffer &buf) {
  int a = S->face_start[f], n = S->face_start[f + 1] - a;
  double *p = buf.get((size_t)dim * (size_t)s.GetNumPatchPoints());
  for (int k = 0; k < n; k++)
    for (int i = 0; i < dim; i++) p[dim * k + i] = values[(size_t)dim * (size_t)index[a + k] + i];
  s.ComputePatchPoints(p, PD(dim));
  return p;
}

/* Face f's patch points, made at the first evaluation that needs them and
 * kept for those that follow (a tessellation evaluates many points of a
 * face in a row). */
class face_eval {
 public:
  face_eval(const ch_surface *S, int f) : S_(S), f_(f), pos_(pos_surface(S, f)), tex_(tex_surface(S, f)) {}

  /* UV at st. */
  void uv(const double st[2], double uv[2]) {
    if (!tex_pts_) tex_pts_ = linear_points(S_, tex_, f_, S_->uvs.data(), S_->corner_uv.data(), 2, tex_buf_);
    tex_.Evaluate(st, tex_pts_, PD(2), uv);
  }

  /* B and N at st under the bilinear scheme (derivatives too where Du is
   * not null); false where the interpolated vertex normals cancel (N is
   * then not unit). */
  bool bilinear(const double st[2], double P[3], double Du[3], double Dv[3], double N[3]) {
    prepare_positions();
    if (Du)
      pos_.Evaluate(st, pos_pts_, PD(3), P, Du, Dv);
    else
      pos_.Evaluate(st, pos_pts_, PD(3), P);
    pos_.Evaluate(st, nrm_pts_, PD(3), N);
    return ch_normalize3(N);
  }

  /* Position, derivatives, normal and UV (where uv is not null) at st. */
  void point(const double st[2], double P[3], double Du[3], double Dv[3], double N[3], double uv[2]) {
    if (S_->scheme == CH_SCHEME_BILINEAR) {
      if (!bilinear(st, P, Du, Dv, N)) {
        /* The interpolated vertex normals cancel: use the patch's own. */
        ch_cross3(Du, Dv, N);
        if (!ch_normalize3(N)) N[0] = N[1] = N[2] = 0.0;
      }
    } else {
      prepare_positions();
      pos_.Evaluate(st, pos_pts_, PD(3), P, Du, Dv);
      ch_cross3(Du, Dv, N);
      double scale = ch_len3(Du) * ch_len3(Dv);
      if (!(ch_len3(N) > 1e-14 * scale) || !ch_normalize3(N)) {
        /* Parallel derivatives: step 1e-7 towards the (sub-)face centre. */
        Bfr::Parameterization param = pos_.GetParameterization();
        double c[2] = {0.5, 0.5};
        if (param.HasSubFaces()) {
          c[0] = std::floor(st[0] + 0.25) + 0.25;
          c[1] = std::floor(st[1] + 0.25) + 0.25;
        }
        double q[2] = {st[0] + 1e-7 * (c[0] - st[0]), st[1] + 1e-7 * (c[1] - st[1])};
        double Q[3], Qu[3], Qv[3];
        pos_.Evaluate(q, pos_pts_, PD(3), Q, Qu, Qv);
        ch_cross3(Qu, Qv, N);
        if (!ch_normalize3(N)) N[0] = N[1] = N[2] = 0.0;
      }
    }
    if (uv) this->uv(st, uv);
  }

 private:
  void prepare_positions() {
    if (pos_pts_) return;
    if (S_->scheme == CH_SCHEME_BILINEAR) {
      const int *index = S_->corner_position.data();
      pos_pts_ = linear_points(S_, pos_, f_, S_->positions.data(), index, 3, pos_buf_);
      nrm_pts_ = linear_points(S_, pos_, f_, S_->vertex_normals.data(), index, 3, nrm_buf_);
    } else if (S_->pos_off[f_ + 1] > S_->pos_off[f_]) {
      pos_pts_ = &S_->pos_pts[3 * S_->pos_off[f_]];
    } else {
      double *p = pos_buf_.get(3 * (size_t)pos_.GetNumPatchPoints());
      pos_.PreparePatchPoints(S_->positions.data(), PD(3), p, PD(3));
      pos_pts_ = p;
    }
  }

  const ch_surface *S_;
  int f_;
  const Surface &pos_, &tex_;
  const double *pos_pts_ = nullptr, *nrm_pts_ = nullptr, *tex_pts_ = nullptr;
  patch_buffer pos_buf_, nrm_buf_, tex_buf_;
};

/* One evaluation of face f (face_eval::point). */
inline void eval_point(const ch_surface *S, int f, const double st[2], double P[3], double Du[3], double Dv[3],
                       double N[3], double uv[2]) {
  face_eval(S, f).point(st, P, Du, Dv, N, uv);
}

}  // namespace ch_surface_detail

#endif
