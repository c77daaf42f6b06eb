// ch_mesh_io.cpp: reads PLY, OFF and STL through OpenMesh into a ch_mesh,
// and dispatches by extension (OBJ to ch_mesh_obj_read.c, glTF to
// ch_mesh_gltf_read.c). The only file of chisel that includes OpenMesh.
//
// OBJ. Its scanner already parses every token as OpenMesh's OBJReader does;
// the mesh is built from the values it keeps. OpenMesh's reader, three
// times slower again through std::istream and a std::map per value, stays
// here as the reference (ch_mesh_read_obj_openmesh) that test_mesh and the
// OBJ fuzz target compare ours with.
//
// Design. OpenMesh's halfedge meshes drop non-manifold faces silently, so we
// never build one: a BaseImporter of our own records what the reader
// modules hand over (vertices, faces as vertex lists, per-face and per-vertex
// texture coordinates, normals) into flat arrays.
//
// OpenMesh 9.0's readers trust their input. Before a buffer reaches them,
// the scanner of its format (ch_mesh_scan.c, plain C, which lists what the
// readers do with unchecked input) checks exactly what the reader will
// consume and rejects what it would misread or choke on, so every error
// names the file and the element; the counts it promises are compared with
// what the reader delivers. All readers are singletons with state, so reads
// are serialised by a mutex.
#include "ch_mesh.h"
#include "ch_mesh_gltf_internal.h"
#include "ch_mesh_obj_internal.h"
#include "ch_mesh_scan.h"
#include "ch_mesh_values_internal.h"

#include <OpenMesh/Core/IO/IOManager.hh>
#include <OpenMesh/Core/IO/Options.hh>
#include <OpenMesh/Core/IO/importer/BaseImporter.hh>
#include <OpenMesh/Core/System/omstream.hh>

#include <algorithm>
#include <cerrno>
#include <clocale>
#include <cmath>
#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <memory>
#include <mutex>
#include <new>
#include <sstream>
#include <stdexcept>
#include <streambuf>
#include <string>
#include <vector>

#include <locale.h>
#include <unistd.h>

#include "ch_file.h"

namespace {

using OpenMesh::Vec2f;
using OpenMesh::Vec3d;
using OpenMesh::Vec3f;
using OpenMesh::VertexHandle;
using OpenMesh::FaceHandle;
using OpenMesh::HalfedgeHandle;
using OpenMesh::EdgeHandle;

// Largest file we read whole: far beyond a base mesh, and beyond what
// displace writes at 20M triangles (a 2.5 GB OBJ), which info and study
// read back.
const size_t kMaxFileSize = (size_t)1 << 34;
const long long kMax = CH_MESH_MAX_ELEMENTS;

enum class Format { OBJ, PLY, OFF, STL };

// Thrown to abort a read; `what` is "element: reason" (the file name is
// prefixed at the boundary).
struct InputError {
  std::string what;
};

// Thrown when our own temporary file cannot be written.
struct IoError {
  std::string what;
};

std::string format_string(const char *fmt, va_list ap) {
  char buf[CH_ERROR_MESSAGE_MAX];
  vsnprintf(buf, sizeof buf, fmt, ap);
  return buf;
}

[[noreturn]] void fail(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
[[noreturn]] void fail(const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  InputError e{format_string(fmt, ap)};
  va_end(ap);
  throw e;
}

// Index of the first value that repeats an earlier one, or -1. Pairwise for
// small faces, by sorting for large ones.
template <class T>
long long first_repeat(const std::vector<T> &v) {
  if (v.size() <= 32) {
    for (size_t i = 1; i < v.size(); i++)
      for (size_t j = 0; j < i; j++)
        if (v[j] == v[i]) return (long long)i;
    return -1;
  }
  std::vector<std::pair<T, size_t>> s;
  for (size_t i = 0; i < v.size(); i++) s.emplace_back(v[i], i);
  std::sort(s.begin(), s.end());
  long long first = -1;
  for (size_t i = 1; i < s.size(); i++)
    if (s[i].first == s[i - 1].first && (first < 0 || (long long)s[i].second < first))
      first = (long long)s[i].second;
  return first;
}

// ---------------------------------------------------------------------------
// The importer: records what OpenMesh's reader modules hand over.

struct Importer final : OpenMesh::IO::BaseImporter {
  Format format;
  int base;  // index base in messages: 1 for OBJ, 0 otherwise
  std::vector<double> pos;
  std::vector<int> face_start{0};
  std::vector<int> corners;
  std::vector<float> face_uv;      // 2 per corner, for faces with face_has_uv
  std::vector<char> face_has_uv;
  std::vector<float> vert_uv;      // 2 per vertex
  std::vector<char> vert_has_uv;
  std::vector<float> vert_n;       // 3 per vertex
  std::vector<char> vert_has_n;
  // OBJ: normals arrive per corner (set_normal on the corner's vertex just
  // before add_face); matched to the face they precede.
  std::vector<std::pair<int, Vec3f>> pending_n;
  std::vector<float> corner_n;     // 3 per corner
  std::vector<char> face_n;        // 0 none, 1 every corner, 2 some corners

  std::vector<int> face_scratch;  // add_face's corners, kept between calls

  explicit Importer(Format f) : format(f), base(f == Format::OBJ ? 1 : 0) {}

  // Room for what the scanner counted (negative: unknown), so that the
  // arrays are not copied as they grow (a sixth of reading a 2M-face PLY).
  void reserve_counts(long long nv, long long nf, long long nc) {
    if (nv > 0) {
      pos.reserve(3 * (size_t)nv);
      vert_uv.reserve(2 * (size_t)nv);
      vert_has_uv.reserve((size_t)nv);
      vert_n.reserve(3 * (size_t)nv);
      vert_has_n.reserve((size_t)nv);
    }
    if (nf > 0) {
      face_start.reserve((size_t)nf + 1);
      face_has_uv.reserve((size_t)nf);
      face_n.reserve((size_t)nf);
    }
    if (nc > 0) {
      corners.reserve((size_t)nc);
      face_uv.reserve(2 * (size_t)nc);
    }
  }

  int vertex_count() const { return (int)(pos.size() / 3); }
  int face_corners(int f) const { return face_start[f + 1] - face_start[f]; }

  void check_vertex(VertexHandle vh) const {
    if (vh.idx() < 0 || vh.idx() >= vertex_count())
      fail("vertex %d: no such vertex (OpenMesh passed handle %d)", vh.idx() + base, vh.idx());
  }

  void check_finite(const float *v, int n, const char *what, int index) const {
    for (int i = 0; i < n; i++)
      if (!std::isfinite(v[i])) fail("%s %d: a value is not finite", what, index + base);
  }

  VertexHandle push_vertex(double x, double y, double z) {
    if (vertex_count() >= kMax) fail("too many vertices (limit %lld)", kMax);
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
      fail("vertex %d: position is not finite", vertex_count() + base);
    pos.insert(pos.end(), {x, y, z});
    vert_uv.insert(vert_uv.end(), {0.0f, 0.0f});
    vert_has_uv.push_back(0);
    vert_n.insert(vert_n.end(), {0.0f, 0.0f, 0.0f});
    vert_has_n.push_back(0);
    return VertexHandle(vertex_count() - 1);
  }

  VertexHandle add_vertex(const Vec3f &p) override { return push_vertex(p[0], p[1], p[2]); }
  VertexHandle add_vertex(const Vec3d &p) override { return push_vertex(p[0], p[1], p[2]); }
  VertexHandle add_vertex() override { return push_vertex(0, 0, 0); }

  void set_point(VertexHandle vh, const Vec3f &p) override {
    check_vertex(vh);
    check_finite(p.data(), 3, "vertex", vh.idx());
    for (int k = 0; k < 3; k++) pos[3 * vh.idx() + k] = p[k];
  }

  FaceHandle add_face(const VHandles &v) override {
    int face = (int)face_has_uv.size();
    if (v.size() < 3) fail("face %d: %zu corners, a face needs at least 3", face + base, v.size());
    if ((long long)corners.size() + (long long)v.size() > kMax)
      fail("too many face corners (limit %lld)", kMax);
    // Ranges are checked at the end (faces may precede vertices in a file).
    std::vector<int> &idx = face_scratch;
    idx.clear();
    for (VertexHandle h : v) idx.push_back(h.idx());
    long long rep = first_repeat(idx);
    if (rep >= 0)
      fail("face %d: vertex %d appears twice (degenerate face)", face + base, idx[rep] + base);
    corners.insert(corners.end(), idx.begin(), idx.end());
    face_start.push_back((int)corners.size());
    face_has_uv.push_back(0);
    take_pending_normals(v);
    return FaceHandle(face);
  }

  void take_pending_normals(const VHandles &v) {
    if (format != Format::OBJ) return;
    corner_n.resize(3 * corners.size(), 0.0f);
    char state = 0;
    if (!pending_n.empty()) {
      state = 2;
      if (pending_n.size() == v.size()) {
        state = 1;
        for (size_t i = 0; i < v.size(); i++)
          if (pending_n[i].first != v[i].idx()) state = 2;
      }
      if (state == 1) {
        size_t c0 = corners.size() - v.size();
        for (size_t i = 0; i < v.size(); i++)
          for (int k = 0; k < 3; k++) corner_n[3 * (c0 + i) + k] = pending_n[i].second[k];
      }
    }
    face_n.push_back(state);
    pending_n.clear();
  }

  void add_face_texcoords(FaceHandle fh, VertexHandle vh,
                          const std::vector<Vec2f> &uv) override {
    if (uv.empty()) return;
    int f = fh.idx();
    if (f < 0 || f >= (int)face_has_uv.size()) fail("face %d: no such face", f + base);
    int b = face_start[f], n = face_start[f + 1] - b;
    if ((int)uv.size() != n)
      fail("face %d: %zu texture coordinates for %d corners", f + base, uv.size(), n);
    // uv[0] belongs to the corner at vertex vh.
    int first = -1;
    for (int i = 0; i < n; i++)
      if (corners[b + i] == vh.idx()) first = i;
    if (first < 0) fail("face %d: texture coordinates start at a vertex not in the face", f + base);
    if (face_uv.size() < 2 * corners.size()) face_uv.resize(2 * corners.size(), 0.0f);
    for (int i = 0; i < n; i++) {
      check_finite(uv[i].data(), 2, "face", f);
      int c = b + (first + i) % n;
      face_uv[2 * c] = uv[i][0];
      face_uv[2 * c + 1] = uv[i][1];
    }
    face_has_uv[f] = 1;
  }

  void set_texcoord(VertexHandle vh, const Vec2f &t) override {
    check_vertex(vh);
    check_finite(t.data(), 2, "vertex", vh.idx());
    vert_uv[2 * vh.idx()] = t[0];
    vert_uv[2 * vh.idx() + 1] = t[1];
    vert_has_uv[vh.idx()] = 1;
  }

  void set_normal(VertexHandle vh, const Vec3f &n) override {
    check_vertex(vh);
    check_finite(n.data(), 3, "vertex", vh.idx());
    if (format == Format::OBJ) {
      pending_n.emplace_back(vh.idx(), n);
      return;
    }
    for (int k = 0; k < 3; k++) vert_n[3 * vh.idx() + k] = n[k];
    vert_has_n[vh.idx()] = 1;
  }
  void set_normal(VertexHandle vh, const Vec3d &n) override { set_normal(vh, Vec3f(n)); }

  // Halfedge-level calls come only from the OM reader, which we do not use.
  HalfedgeHandle add_edge(VertexHandle, VertexHandle) override {
    fail("unexpected halfedge data");
  }
  FaceHandle add_face(HalfedgeHandle) override { fail("unexpected halfedge data"); }

  // Everything else (colours, status, 3D texcoords, materials) is not used.
  void add_face_texcoords(FaceHandle, VertexHandle, const std::vector<Vec3f> &) override {}
  void set_face_texindex(FaceHandle, int) override {}
  void set_halfedge(VertexHandle, HalfedgeHandle) override {}
  void set_color(VertexHandle, const OpenMesh::Vec3uc &) override {}
  void set_color(VertexHandle, const OpenMesh::Vec4uc &) override {}
  void set_color(VertexHandle, const Vec3f &) override {}
  void set_color(VertexHandle, const OpenMesh::Vec4f &) override {}
  void set_status(VertexHandle, const OpenMesh::Attributes::StatusInfo &) override {}
  void set_next(HalfedgeHandle, HalfedgeHandle) override {}
  void set_face(HalfedgeHandle, FaceHandle) override {}
  void request_face_texcoords2D() override {}
  void set_texcoord(HalfedgeHandle, const Vec2f &) override {}
  void set_texcoord(VertexHandle, const Vec3f &) override {}
  void set_texcoord(HalfedgeHandle, const Vec3f &) override {}
  void set_status(HalfedgeHandle, const OpenMesh::Attributes::StatusInfo &) override {}
  void set_color(EdgeHandle, const OpenMesh::Vec3uc &) override {}
  void set_color(EdgeHandle, const OpenMesh::Vec4uc &) override {}
  void set_color(EdgeHandle, const Vec3f &) override {}
  void set_color(EdgeHandle, const OpenMesh::Vec4f &) override {}
  void set_status(EdgeHandle, const OpenMesh::Attributes::StatusInfo &) override {}
  void set_normal(FaceHandle, const Vec3f &) override {}
  void set_normal(FaceHandle, const Vec3d &) override {}
  void set_color(FaceHandle, const OpenMesh::Vec3uc &) override {}
  void set_color(FaceHandle, const OpenMesh::Vec4uc &) override {}
  void set_color(FaceHandle, const Vec3f &) override {}
  void set_color(FaceHandle, const OpenMesh::Vec4f &) override {}
  void set_status(FaceHandle, const OpenMesh::Attributes::StatusInfo &) override {}
  void add_texture_information(int, std::string) override {}

  size_t n_vertices() const override { return (size_t)vertex_count(); }
  size_t n_faces() const override { return face_has_uv.size(); }
  size_t n_edges() const override { return 0; }
};

// ---------------------------------------------------------------------------
// Running OpenMesh.

// A read-only, seekable stream over a buffer (the OBJ reader seeks back to
// the start for its second pass).
struct MemoryBuf : std::streambuf {
  MemoryBuf(const char *data, size_t size) {
    char *p = const_cast<char *>(data);  // never written: no put area
    setg(p, p, p + size);
  }
  pos_type seekoff(off_type off, std::ios_base::seekdir dir, std::ios_base::openmode) override {
    off_type base = dir == std::ios_base::beg ? 0
                    : dir == std::ios_base::cur ? gptr() - eback()
                                                : egptr() - eback();
    return seekpos(pos_type(base + off), std::ios_base::in);
  }
  pos_type seekpos(pos_type pos, std::ios_base::openmode) override {
    off_type p = off_type(pos);
    if (p < 0 || p > egptr() - eback()) return pos_type(off_type(-1));
    setg(eback(), eback() + p, egptr());
    return pos;
  }
};

// Silences OpenMesh's console output for the duration of a read and keeps
// what it writes to std::cerr/std::clog (omerr, and a few direct writes).
class QuietConsole {
 public:
  QuietConsole()
      : cerr_(std::cerr.rdbuf(text_.rdbuf())),
        clog_(std::clog.rdbuf(text_.rdbuf())),
        cout_(std::cout.rdbuf(text_.rdbuf())),
        log_on_(omlog().is_enabled()),
        out_on_(omout().is_enabled()),
        err_on_(omerr().is_enabled()) {
    omlog().disable();
    omout().disable();
    omerr().enable();
  }
  ~QuietConsole() {
    omerr().flush();
    std::cerr.rdbuf(cerr_);
    std::clog.rdbuf(clog_);
    std::cout.rdbuf(cout_);
    if (log_on_) omlog().enable();
    if (out_on_) omout().enable();
    if (!err_on_) omerr().disable();
  }
  // The first line OpenMesh complained with, or "".
  std::string first_line() {
    omerr().flush();
    std::string s = text_.str(), line;
    std::istringstream in(s);
    while (std::getline(in, line)) {
      size_t b = line.find_first_not_of(" \t\r"), e = line.find_last_not_of(" \t\r");
      if (b != std::string::npos) return line.substr(b, e - b + 1);
    }
    return "";
  }

 private:
  std::ostringstream text_;
  std::streambuf *cerr_, *clog_, *cout_;
  bool log_on_, out_on_, err_on_;
};

std::mutex &openmesh_mutex() {
  static std::mutex m;
  return m;
}

OpenMesh::IO::Options read_options() {
  return OpenMesh::IO::Options(OpenMesh::IO::Options::FaceTexCoord |
                               OpenMesh::IO::Options::VertexTexCoord |
                               OpenMesh::IO::Options::VertexNormal);
}

void openmesh_failed(QuietConsole &quiet) {
  std::string why = quiet.first_line();
  if (why.empty()) fail("OpenMesh could not read the file");
  fail("OpenMesh could not read the file (%s)", why.c_str());
}

void run_stream(const char *data, size_t size, const char *ext, bool binary_stl, Importer &imp) {
  std::lock_guard<std::mutex> lock(openmesh_mutex());
  MemoryBuf buf(data, size);
  std::istream in(&buf);
  OpenMesh::IO::Options opt = read_options();
  if (binary_stl) opt += OpenMesh::IO::Options::Binary;
  QuietConsole quiet;
  if (!OpenMesh::IO::IOManager().read(in, ext, imp, opt)) openmesh_failed(quiet);
}

// OpenMesh's OFF reader parses its header only when given a file name.
void run_off_file(const char *data, size_t size, Importer &imp) {
  const char *dir = getenv("TMPDIR");
  std::string path = std::string(dir && *dir ? dir : "/tmp") + "/chisel-mesh-XXXXXX.off";
  std::vector<char> name(path.begin(), path.end());
  name.push_back('\0');
  int fd = mkstemps(name.data(), 4);
  if (fd < 0) throw IoError{std::string("cannot create a temporary file in ") + (dir && *dir ? dir : "/tmp")};
  struct Unlink {
    const char *p;
    ~Unlink() { unlink(p); }
  } cleanup{name.data()};
  size_t done = 0;
  while (done < size) {
    ssize_t w = write(fd, data + done, size - done);
    if (w <= 0) {
      close(fd);
      throw IoError{"cannot write a temporary file for the OFF reader"};
    }
    done += (size_t)w;
  }
  close(fd);
  std::lock_guard<std::mutex> lock(openmesh_mutex());
  OpenMesh::IO::Options opt = read_options();
  QuietConsole quiet;
  if (!OpenMesh::IO::IOManager().read(std::string(name.data()), imp, opt)) openmesh_failed(quiet);
}

// ---------------------------------------------------------------------------
// From the importer's arrays to a ch_mesh.

template <class T>
T *c_array(const std::vector<T> &v) {
  if (v.empty()) return nullptr;
  T *p = (T *)malloc(v.size() * sizeof(T));
  if (!p) throw std::bad_alloc();
  memcpy(p, v.data(), v.size() * sizeof(T));
  return p;
}

// The mesh's shared UVs and normals (ch_mesh_share_values: equal values by
// their bits, numbered in order of first use), owned until to_mesh takes
// them.
struct Built {
  double *uvs = nullptr, *normals = nullptr;
  int *corner_uv = nullptr, *corner_normal = nullptr;
  int num_uvs = 0, num_normals = 0;
  Built() = default;
  Built(const Built &) = delete;
  Built &operator=(const Built &) = delete;
  ~Built() {
    free(uvs);
    free(normals);
    free(corner_uv);
    free(corner_normal);
  }
};

// Corner c takes list value idx[c] (c where idx is null) of n floats each.
void share(int n, const std::vector<float> &list, const int *idx, size_t corners, double **values, int **corner,
           int *count) {
  if (corners == 0) return;
  if (ch_mesh_share_values(n, list.data(), list.size() / (size_t)n, idx, corners, values, corner, count))
    throw std::bad_alloc();
}

// Returns whether the UVs came per vertex (exporters split such vertices
// at UV seams; see weld_positions).
bool build_uvs(const Importer &imp, Built &b) {
  size_t nf = imp.face_has_uv.size();
  size_t with = (size_t)std::count(imp.face_has_uv.begin(), imp.face_has_uv.end(), 1);
  if (with > 0) {
    if (with != nf) {
      size_t f = std::find(imp.face_has_uv.begin(), imp.face_has_uv.end(), 0) - imp.face_has_uv.begin();
      fail("face %zu has no texture coordinates while other faces have them", f + imp.base);
    }
    share(2, imp.face_uv, nullptr, imp.corners.size(), &b.uvs, &b.corner_uv, &b.num_uvs);
    return false;
  }
  for (int v : imp.corners)
    if (!imp.vert_has_uv[v]) return false;  // no (complete) per-vertex UVs either
  share(2, imp.vert_uv, imp.corners.data(), imp.corners.size(), &b.uvs, &b.corner_uv, &b.num_uvs);
  return true;
}

void build_normals(const Importer &imp, Built &b, const char *name, ch_error *err) {
  if (imp.format == Format::OBJ) {
    size_t complete = (size_t)std::count(imp.face_n.begin(), imp.face_n.end(), 1);
    if (complete == 0 && std::count(imp.face_n.begin(), imp.face_n.end(), 2) == 0) return;
    if (complete != imp.face_n.size()) {
      ch_warn(err, "%s: only some faces have normals (vn) on every corner; normals ignored", name);
      return;
    }
    share(3, imp.corner_n, nullptr, imp.corners.size(), &b.normals, &b.corner_normal, &b.num_normals);
    return;
  }
  for (int v : imp.corners)
    if (!imp.vert_has_n[v]) return;
  share(3, imp.vert_n, imp.corners.data(), imp.corners.size(), &b.normals, &b.corner_normal, &b.num_normals);
}

// A PLY or OFF with UVs per vertex has one set of attributes per vertex, so
// an exporter splits a vertex wherever its UV differs (Blender's PLY at every
// UV seam): one point appears as several vertices at the same coordinates,
// and the base surface falls apart there, each side tessellated and cut on
// its own (the displaced mesh open along every seam). They are welded back
// into one position, the first copy's, as glTF's are (docs/spec.md §1), by
// the same value set; the positions keep their order. Returns each vertex's
// position and fills kept with the positions' coordinates.
std::vector<int> weld_positions(const std::vector<double> &pos, std::vector<double> &kept) {
  size_t n = pos.size() / 3;
  std::vector<int> at(n);
  ch_value_set set = {};
  set.width = 3;
  for (size_t i = 0; i < n; i++)
    if ((at[i] = ch_value_set_index(&set, &pos[3 * i])) < 0) {
      ch_value_set_free(&set);
      throw std::bad_alloc();
    }
  kept.assign(set.values, set.values + 3 * (size_t)set.count);
  ch_value_set_free(&set);
  return at;
}

void to_mesh(const Importer &imp, const char *name, ch_mesh *out, ch_error *err) {
  int nv = imp.vertex_count();
  for (size_t f = 0; f + 1 < imp.face_start.size(); f++)
    for (int c = imp.face_start[f]; c < imp.face_start[f + 1]; c++)
      if (imp.corners[c] < 0 || imp.corners[c] >= nv) {
        if (imp.base == 1)
          fail("face %zu: position index %d out of range (1..%d)", f + 1, imp.corners[c] + 1, nv);
        fail("face %zu: vertex index %d out of range (0..%d)", f, imp.corners[c], nv - 1);
      }
  Built b;
  // (OBJ indexes positions and UVs apart, and is read here only as the
  // reference for chisel's own OBJ reader; UVs per face corner, as chisel's
  // own PLY has them, need no split vertices)
  bool weld = build_uvs(imp, b) && imp.format != Format::OBJ;
  build_normals(imp, b, name, err);
  std::vector<double> welded_pos;
  std::vector<int> face_start, corners;
  if (weld) {
    std::vector<int> at = weld_positions(imp.pos, welded_pos);
    // A face with two corners at one position once welded has an edge on
    // itself: left out, its corners' UVs and normals with it.
    size_t nf = imp.face_start.size() - 1, dropped = 0, c_out = 0;
    std::vector<int> seen;
    face_start.reserve(nf + 1);
    face_start.push_back(0);
    corners.reserve(imp.corners.size());
    for (size_t f = 0; f < nf; f++) {
      seen.clear();
      for (int c = imp.face_start[f]; c < imp.face_start[f + 1]; c++) seen.push_back(at[(size_t)imp.corners[c]]);
      if (first_repeat(seen) >= 0) {
        dropped++;
        continue;
      }
      for (int c = imp.face_start[f]; c < imp.face_start[f + 1]; c++, c_out++) {
        corners.push_back(at[(size_t)imp.corners[c]]);
        if (b.corner_uv) b.corner_uv[c_out] = b.corner_uv[c];
        if (b.corner_normal) b.corner_normal[c_out] = b.corner_normal[c];
      }
      face_start.push_back((int)corners.size());
    }
    if (dropped)
      ch_warn(err, "%s: %zu face%s with two corners at one position (vertices at equal coordinates) left out", name,
              dropped, dropped == 1 ? "" : "s");
    nv = (int)(welded_pos.size() / 3);
  }
  ch_mesh m;
  memset(&m, 0, sizeof m);
  try {
    m.num_positions = nv;
    m.positions = c_array(weld ? welded_pos : imp.pos);
    m.num_faces = (int)(weld ? face_start : imp.face_start).size() - 1;
    m.face_start = c_array(weld ? face_start : imp.face_start);
    m.num_corners = (int)(weld ? corners : imp.corners).size();
    m.corner_position = c_array(weld ? corners : imp.corners);
    m.num_uvs = b.num_uvs;
    m.uvs = b.uvs;
    m.corner_uv = b.corner_uv;
    m.num_normals = b.num_normals;
    m.normals = b.normals;
    m.corner_normal = b.corner_normal;
    b.uvs = b.normals = nullptr;
    b.corner_uv = b.corner_normal = nullptr;
  } catch (...) {
    ch_mesh_free(&m);
    throw;
  }
  // the split vertices' UVs may have been rounded apart by the exporter
  if (weld && ch_mesh_merge_near_uvs(&m, err) != CH_OK) {
    ch_mesh_free(&m);
    throw std::bad_alloc();
  }
  *out = m;
}

// ---------------------------------------------------------------------------

bool parse_format(const char *ext, Format *f) {
  std::string e = ext ? ext : "";
  for (char &c : e) c = (char)tolower((unsigned char)c);
  if (e == "obj") *f = Format::OBJ;
  else if (e == "ply") *f = Format::PLY;
  else if (e == "off") *f = Format::OFF;
  else if (e == "stl") *f = Format::STL;
  else return false;
  return true;
}

void read_buffer(const char *data, size_t size, Format f, const char *name, ch_mesh *out,
                 ch_error *err) {
  if (size == 0) fail("file is empty");
  Importer imp(f);
  long long want_v = -1, want_f = -1;
  ch_mesh_scan s;
  ch_error scan_err = {};
  ch_status st = CH_OK;
  switch (f) {
  case Format::OBJ: st = ch_mesh_scan_obj(data, size, &s, &scan_err); break;
  case Format::PLY: st = ch_mesh_scan_ply(data, size, &s, &scan_err); break;
  case Format::OFF: st = ch_mesh_scan_off(data, size, &s, &scan_err); break;
  case Format::STL: st = ch_mesh_scan_stl(data, size, &s, &scan_err); break;
  }
  // Freed on every way out, exceptions included.
  std::unique_ptr<ch_mesh_scan, void (*)(ch_mesh_scan *)> owned(&s, ch_mesh_scan_free);
  if (st == CH_ERR_NOMEM) throw std::bad_alloc();
  if (st != CH_OK) throw InputError{scan_err.message};
  switch (f) {
  case Format::OBJ: {
    want_v = s.num_vertices;
    want_f = s.num_faces;
    // Materials are not used; `mtllib` would open arbitrary paths.
    std::string copy;
    if (s.num_mtllib > 0) {
      copy.assign(data, size);
      for (size_t i = 0; i < s.num_mtllib; i++) copy[s.mtllib_at[i]] = '#';
      data = copy.data();
    }
    run_stream(data, size, "obj", false, imp);
    break;
  }
  case Format::PLY: {
    if (s.texture_uv_names)
      ch_warn(err, "%s: PLY properties texture_u/texture_v are not read (OpenMesh knows u,v and s,t)", name);
    want_v = s.num_vertices;
    want_f = s.num_faces;
    imp.reserve_counts(want_v, want_f, s.num_corners);
    if (!s.face_tex) {
      run_stream(data, size, "ply", false, imp);
      break;
    }
    run_stream(s.stripped, s.stripped_size, "ply", false, imp);
    // The face texcoords, now that the faces exist (the first value pair
    // belongs to the corner at the face's first vertex).
    std::vector<Vec2f> uv;
    for (size_t f = 0, k = 0; f < s.num_tex_first && f < imp.n_faces(); f++) {
      int corners = imp.face_corners((int)f);
      uv.clear();
      for (int c = 0; c < corners; c++, k += 2) uv.emplace_back(s.tex[k], s.tex[k + 1]);
      imp.add_face_texcoords(FaceHandle((int)f), VertexHandle(s.tex_first[f]), uv);
    }
    break;
  }
  case Format::OFF: {
    want_v = s.num_vertices;
    want_f = s.num_faces;
    imp.reserve_counts(want_v, want_f, s.num_corners);
    run_off_file(data, size, imp);
    break;
  }
  case Format::STL: {
    run_stream(data, size, "stl", s.binary != 0, imp);
    long long dropped = s.triangles - (long long)imp.n_faces();
    if (dropped > 0)
      ch_warn(err, "%s: OpenMesh dropped %lld degenerate triangle%s", name, dropped,
              dropped == 1 ? "" : "s");
    break;
  }
  }
  // The scanners promise what OpenMesh will deliver; a mismatch is our bug.
  if ((want_v >= 0 && want_v != imp.vertex_count()) ||
      (want_f >= 0 && want_f != (long long)imp.n_faces()))
    throw std::runtime_error("OpenMesh delivered " + std::to_string(imp.vertex_count()) +
                             " vertices and " + std::to_string(imp.n_faces()) +
                             " faces, expected " + std::to_string(want_v) + " and " +
                             std::to_string(want_f));
  to_mesh(imp, name, out, err);
}

// Runs fn, turning every exception into a status and a one-line message.
template <class Fn>
ch_status guarded(const char *name, ch_mesh *out, ch_error *err, Fn fn) {
  try {
    fn();
    return CH_OK;
  } catch (const InputError &e) {
    ch_mesh_free(out);
    return ch_error_set(err, CH_ERR_INPUT, "%s: %s", name, e.what.c_str());
  } catch (const IoError &e) {
    ch_mesh_free(out);
    return ch_error_set(err, CH_ERR_IO, "%s: %s", name, e.what.c_str());
  } catch (const std::bad_alloc &) {
    ch_mesh_free(out);
    return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory", name);
  } catch (const std::exception &e) {
    ch_mesh_free(out);
    return ch_error_set(err, CH_ERR_INTERNAL, "%s: %s", name, e.what());
  } catch (...) {
    ch_mesh_free(out);
    return ch_error_set(err, CH_ERR_INTERNAL, "%s: unknown failure while reading", name);
  }
}

const char kAccepted[] = ".obj, .ply, .off, .stl, .glb, .gltf";

// glTF (1: binary, 0: JSON) by extension, or -1 for another format.
int gltf_kind(const char *ext) {
  std::string e = ext ? ext : "";
  for (char &c : e) c = (char)tolower((unsigned char)c);
  return e == "glb" ? 1 : e == "gltf" ? 0 : -1;
}

}  // namespace

extern "C" ch_status ch_mesh_read_memory(const void *data, size_t size, const char *format,
                                         const char *name, ch_mesh *out, ch_error *err) {
  memset(out, 0, sizeof *out);
  if (!name) name = "(memory)";
  int gltf = gltf_kind(format);
  if (gltf >= 0) return ch_mesh_read_gltf(data, size, gltf, nullptr, name, out, err);
  Format f;
  if (!parse_format(format, &f))
    return ch_error_set(err, CH_ERR_INPUT, "%s: unknown mesh format '%s' (accepted: %s)", name,
                        format ? format : "", kAccepted);
  static const char empty = '\0';
  const char *bytes = size ? (const char *)data : &empty;
  if (f == Format::OBJ) return ch_mesh_read_obj(bytes, size, name, out, err);
  return guarded(name, out, err, [&] { read_buffer(bytes, size, f, name, out, err); });
}

extern "C" ch_status ch_mesh_read_obj_openmesh(const void *data, size_t size, const char *name, ch_mesh *out,
                                               ch_error *err) {
  memset(out, 0, sizeof *out);
  static const char empty = '\0';
  const char *bytes = size ? (const char *)data : &empty;
  return guarded(name, out, err, [&] { read_buffer(bytes, size, Format::OBJ, name, out, err); });
}

extern "C" ch_status ch_mesh_read(const char *path, ch_mesh *out, ch_error *err) {
  memset(out, 0, sizeof *out);
  char ext[16];
  ch_path_extension(path, ext, sizeof ext);
  int gltf = gltf_kind(ext);
  Format f;
  if (gltf < 0 && !parse_format(ext, &f)) {
    if (!ext[0])
      return ch_error_set(err, CH_ERR_INPUT, "%s: no file extension (accepted: %s)", path, kAccepted);
    return ch_error_set(err, CH_ERR_INPUT, "%s: unknown mesh format '.%s' (accepted: %s)", path,
                        ext, kAccepted);
  }
  char *data = nullptr;
  size_t size = 0;
  ch_status st = ch_file_read_all(path, kMaxFileSize, &data, &size, err);
  if (st != CH_OK) return st;
  if (gltf >= 0) {
    st = ch_mesh_read_gltf(data, size, gltf, path, path, out, err);
    free(data);
    return st;
  }
  if (f == Format::OBJ) {
    st = ch_mesh_read_obj(data, size, path, out, err);
    free(data);
    return st;
  }
  st = guarded(path, out, err, [&] { read_buffer(data, size, f, path, out, err); });
  free(data);
  return st;
}
