/* ch_tess: the base surface tessellated through OpenSubdiv 3.5's Bfr
 * tessellation patterns at shared per-edge rates (ch_tess.h).
 *
 * Tessellation follows DEPS.md's verified flow with one change: every base
 * vertex and every edge point is evaluated once (evaluating shared points
 * from each face separately differs in the last bits, see DEPS.md), and
 * the facets of each face are remapped here rather than with
 * Tessellation::TransformFacetCoordIndices, because the UV indices of the
 * same facets need a second, face-varying, mapping.
 */
#include "ch_tess.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <new>
#include <vector>

#include <opensubdiv/bfr/tessellation.h>

#include "ch_alloc.h"
#include "ch_surface_internal.h"
#include "ch_warp.h"

using namespace OpenSubdiv;
using namespace ch_surface_detail;

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

/* Triangle counts of faces for edge rates. A face's count depends on its
 * size and rates alone (its parameterization is its size's), and a base of
 * millions of triangles and quads has few distinct rate tuples: those are
 * counted once (a Bfr::Tessellation for every face in each of the rate
 * bisection's ~50 counts was seconds on a 2M-face base). Direct-mapped by a
 * key of the size and six 10-bit rates. */
class face_counter {
 public:
  explicit face_counter(const ch_surface *S) : S_(S), opts_(tess_options()), key_(kCache, 0), count_(kCache, 0) {}

  /* Face f's triangles, or -1 where Bfr's int counts could overflow. */
  long count(int f, const int *edge_rates) {
    int n = S_->face_start[f + 1] - S_->face_start[f];
    int local[64], *r = local;
    if (n + 2 > 64) {
      big_.resize(n + 2);
      r = big_.data();
    }
    int nr = face_rates(S_, f, edge_rates, r);
    long rmax = 0;
    for (int i = 0; i < nr; i++) rmax = std::max(rmax, (long)r[i]);
    if ((long)n * (rmax + 1) * (rmax + 1) > (1L << 30)) return -1;
    if (n <= 4 && rmax < 1024) {
      uint64_t key = (uint64_t)1 << 63 | (uint64_t)(n - 3) << 60; /* (0: empty) */
      for (int i = 0; i < nr; i++) key |= (uint64_t)r[i] << (10 * i);
      size_t at = (size_t)((key * 0x9e3779b97f4a7c15u) >> 52) & (kCache - 1);
      if (key_[at] != key) {
        Bfr::Tessellation tess(pos_surface(S_, f).GetParameterization(), nr, r, opts_);
        key_[at] = key;
        count_[at] = tess.GetNumFacets();
      }
      return count_[at];
    }
    Bfr::Tessellation tess(pos_surface(S_, f).GetParameterization(), nr, r, opts_);
    return tess.GetNumFacets();
  }

 private:
  enum { kCache = 4096 };
  const ch_surface *S_;
  Bfr::Tessellation::Options opts_;
  std::vector<uint64_t> key_;
  std::vector<int> count_;
  std::vector<int> big_;
};

/* The whole mesh's triangle count for a run of rate arrays that differ
 * little from one to the next (the bisection's): after the first, only the
 * faces on edges whose rate changed are counted again, the same total. */
class rate_counter {
 public:
  explicit rate_counter(const ch_surface *S)
      : S_(S), faces_(S), face_count_(S->num_faces, 0), stamp_(S->num_faces, 0) {}

  long count(const int *edge_rates) {
    const int ne = S_->num_edges, nf = S_->num_faces;
    if (rates_.empty()) return recount(edge_rates);
    changed_faces_.clear();
    ++epoch_;
    for (int e = 0; e < ne; e++) {
      if (edge_rates[e] == rates_[e]) continue;
      rates_[e] = edge_rates[e];
      for (int i = S_->edge_face_start[e]; i < S_->edge_face_start[e + 1]; i++) {
        int f = S_->edge_face[i];
        if (stamp_[f] != epoch_) {
          stamp_[f] = epoch_;
          changed_faces_.push_back(f);
        }
      }
    }
    if (2 * changed_faces_.size() > (size_t)nf) return recount(edge_rates);
    for (int f : changed_faces_) {
      long c = faces_.count(f, rates_.data());
      over_ += (c < 0) - (face_count_[f] < 0);
      total_ += std::max(c, 0L) - std::max(face_count_[f], 0L);
      face_count_[f] = c;
    }
    return over_ > 0 ? std::numeric_limits<long>::max() : total_;
  }

 private:
  long recount(const int *edge_rates) {
    rates_.assign(edge_rates, edge_rates + S_->num_edges);
    total_ = over_ = 0;
    for (int f = 0; f < S_->num_faces; f++) {
      face_count_[f] = faces_.count(f, edge_rates);
      over_ += face_count_[f] < 0;
      total_ += std::max(face_count_[f], 0L);
    }
    return over_ > 0 ? std::numeric_limits<long>::max() : total_;
  }

  const ch_surface *S_;
  face_counter faces_;
  std::vector<int> rates_;
  std::vector<long> face_count_;
  std::vector<unsigned> stamp_;
  std::vector<int> changed_faces_;
  unsigned epoch_ = 0;
  long total_ = 0, over_ = 0;
};

/* Triangle count of the whole mesh for these edge rates (LONG_MAX where a
 * face could overflow Bfr's counts). Serial: it is cheap (no evaluation),
 * and the bisection counts ~50 times, where a parallel region each time
 * costs a scheduler slice per call on a loaded machine (measured: 8 ms on
 * 1 thread became 580 ms on 2 busy cores). */
long count_triangles(const ch_surface *S, const int *edge_rates) { return rate_counter(S).count(edge_rates); }

/* Rates max(1, round(d L)); false when a rate would exceed kMaxRate. */
bool rates_for_density(const ch_surface *S, const double *length, double d, int *rates) {
  bool ok = true;
  for (int e = 0; e < S->num_edges; e++) {
    /* (x >= 0.5: truncation is floor, without the libm call the bisection
     * made 150M times on a 3M-edge base) */
    double x = d * length[e] + 0.5;
    int r;
    if (x >= kMaxRate + 1.0) {
      ok = false;
      r = kMaxRate;
    } else {
      r = (int)x;
    }
    rates[e] = r < 1 ? 1 : r;
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
  rate_counter counter(S);
  long cmin = counter.count(rates.data());
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
    chi = counter.count(rhi.data());
    if (chi >= target) break;
    if (!ok)
      return ch_error_set(err, CH_ERR_INPUT,
                          "target of %ld triangles needs edge rates above the maximum %d", target,
                          kMaxRate);
    lo = hi;
    hi *= 2.0;
  }
  rates_for_density(S, length, lo, rlo.data());
  long clo = counter.count(rlo.data());
  for (int it = 0; it < 200 && hi - lo > 1e-13 * hi; it++) {
    double mid = 0.5 * (lo + hi);
    std::vector<int> &r = rates;
    rates_for_density(S, length, mid, r.data());
    long c = counter.count(r.data());
    if (c < target) {
      lo = mid, clo = c, rlo.swap(r);
    } else {
      hi = mid, chi = c, rhi.swap(r);
    }
  }
  long best = (target - clo <= chi - target) ? clo : chi;
  rates = (best == clo) ? rlo : rhi;
  if (std::labs(best - target) <= 0.05 * target && !desc->closest) return CH_OK;

  /* Many edges of one length jump together at d: raise them one by one,
   * by the caller's priority, spread over the mesh (edge index times the
   * golden ratio, mod 1) among equals. */
  std::vector<int> jump;
  for (int e = 0; e < ne; e++)
    if (rhi[e] != rlo[e]) jump.push_back(e);
  std::vector<double> key(ne), priority(ne, 0.0);
  for (int e : jump) {
    double x = e * 0.6180339887498949;
    key[e] = x - std::floor(x);
    if (desc->edge_priority) {
      priority[e] = std::numeric_limits<double>::infinity();
      for (int i = S->edge_face_start[e]; i < S->edge_face_start[e + 1]; i++) {
        const double *a, *b;
        face_edge_uv(S, S->edge_face[i], S->edge_corner[i], &a, &b);
        priority[e] = std::min(priority[e], desc->edge_priority(desc->edge_priority_ctx, a, b));
      }
    }
  }
  std::stable_sort(jump.begin(), jump.end(), [&](int a, int b) {
    return priority[a] < priority[b] || (priority[a] == priority[b] && key[a] < key[b]);
  });
  auto count_k = [&](size_t k, std::vector<int> &r) {
    r = rlo;
    for (size_t i = 0; i < k; i++) r[jump[i]] = rhi[jump[i]];
    return counter.count(r.data());
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

/* Zeroed, in huge pages where large (ch_alloc_large): the tessellation's
 * arrays are first touched here, and 4 KiB page faults cost as much as
 * filling them. */
template <typename T>
T *alloc_array(size_t n) {
  T *p = (T *)ch_alloc_large(n ? n : 1, sizeof(T), 1);
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
      Bfr::Tessellation tess(pos_surface(S, f).GetParameterization(), nr, r.data(), opts);
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
  if (desc->corner_st) out->corner_st = alloc_array<double>(6 * ntri);
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
      pos_surface(S, f).GetParameterization().GetVertexCoord(S->vertex_corner[v], st2);
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
      Bfr::Parameterization param = pos_surface(S, f).GetParameterization();
      face_eval fe(S, f);
      for (int j = 0; j < r - 1; j++) {
        long o = nb + edge_pt[e] + j;
        double x = edge_place(f, k, fwd ? (double)(j + 1) / r : (double)(r - 1 - j) / r);
        double st2[2], du[3], dv[3];
        param.GetEdgeCoord(k, x, st2);
        fe.point(st2, &M.positions[3 * o], du, dv, &M.normals[3 * o], nullptr);
        out->vertex_face[o] = f;
        out->vertex_st[2 * o] = st2[0];
        out->vertex_st[2 * o + 1] = st2[1];
      }
      for (int g = 0; g < S->edge_num_groups[e]; g++) {
        int gi = S->edge_group_start[e] + g;
        int gf = S->edge_group_face[gi], gk = S->edge_group_corner[gi];
        bool gfwd = S->face_edge_fwd[S->face_start[gf] + gk];
        Bfr::Parameterization gparam = pos_surface(S, gf).GetParameterization();
        face_eval gfe(S, gf);
        for (int j = 0; j < r - 1; j++) {
          long o = nuv0 + edge_uv[e] + (long)g * (r - 1) + j;
          /* the same point as the positions' (one fraction per edge point) */
          double xf = edge_place(f, k, fwd ? (double)(j + 1) / r : (double)(r - 1 - j) / r);
          double x = gfwd == fwd ? xf : 1.0 - xf;
          double st2[2];
          gparam.GetEdgeCoord(gk, x, st2);
          gfe.uv(st2, &M.uvs[2 * o]);
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
    std::vector<double> coords, bst;
    try {
      coords.resize(2 * (size_t)max_coords);
      if (out->corner_st) bst.resize(2 * (size_t)max_coords);
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
        Bfr::Parameterization param = pos_surface(S, f).GetParameterization();
        Bfr::Tessellation tess(param, nr, r.data(), opts);
        const int nbd = tess.GetNumBoundaryCoords(), nint = tess.GetNumInteriorCoords();
        /* Boundary: corner k, then the rate-1 points of edge k. */
        int b = 0;
        for (int k = 0; k < n; k++) {
          int c = a + k;
          bpos[b] = S->vertex_out[S->corner_position[c]];
          buv[b] = S->corner_uv[c];
          if (out->corner_st) param.GetVertexCoord(k, &bst[2 * (size_t)b]);
          b++;
          int e = S->face_edge[c], re = rates[e];
          bool fwd = S->face_edge_fwd[c];
          long ub = nuv0 + edge_uv[e] + (long)S->face_edge_group[c] * (re - 1);
          /* (this face's coordinate of the edge's points: the fraction the
           * lowest face on the edge placed them at, as for the UVs above) */
          int i0 = S->edge_face_start[e], f0 = S->edge_face[i0], k0 = S->edge_corner[i0];
          bool fwd0 = S->face_edge_fwd[S->face_start[f0] + k0];
          for (int j = 0; j < re - 1; j++, b++) {
            int jc = fwd ? j : re - 2 - j; /* canonical index */
            bpos[b] = (int)(nb + edge_pt[e] + jc);
            buv[b] = (int)(ub + jc);
            if (out->corner_st) {
              double xf = edge_place(f0, k0, fwd0 ? (double)(jc + 1) / re : (double)(re - 1 - jc) / re);
              param.GetEdgeCoord(k, fwd == fwd0 ? xf : 1.0 - xf, &bst[2 * (size_t)b]);
            }
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
        face_eval fe(S, f);
        for (int i = 0; i < nint; i++) {
          long o = nb + edge_pt[ne] + face_int[f] + i;
          long u = nuv0 + edge_uv[ne] + face_int[f] + i;
          double du[3], dv[3];
          fe.point(&coords[2 * i], &M.positions[3 * o], du, dv, &M.normals[3 * o], &M.uvs[2 * u]);
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
            if (out->corner_st) {
              const double *q = i < nbd ? &bst[2 * (size_t)i] : &coords[2 * (size_t)(i - nbd)];
              out->corner_st[6 * tri + 2 * c] = q[0];
              out->corner_st[6 * tri + 2 * c + 1] = q[1];
            }
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
  ch_status st = guarded(err, "tessellating the base surface", "tessellation",
                         [&] { return tess_build(surface, desc, out, err); });
  if (st != CH_OK) ch_tess_free(out);
  return st;
}

extern "C" void ch_tess_free(ch_tess_result *r) {
  if (!r) return;
  ch_mesh_free(&r->mesh);
  std::free(r->vertex_face);
  std::free(r->vertex_st);
  std::free(r->triangle_face);
  std::free(r->corner_st);
  std::free(r->edge_rates);
  std::free(r->edge_vertices);
  std::memset(r, 0, sizeof *r);
}

extern "C" long ch_tess_fewest_triangles(const ch_surface *S) {
  std::vector<int> ones((size_t)S->num_edges, 1);
  return count_triangles(S, ones.data());
}

extern "C" int ch_tess_quad_inner_rates(const ch_surface *S, const ch_tess_result *r, int f, int rates[2]) {
  if (S->face_start[f + 1] - S->face_start[f] != 4) return 0;
  int all[6];
  face_rates(S, f, r->edge_rates, all);
  rates[0] = all[4];
  rates[1] = all[5];
  return 1;
}
