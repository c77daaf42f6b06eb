// ch_mesh_io.cpp: reads OBJ, PLY, OFF and STL through OpenMesh into a
// ch_mesh. The only file of chisel that includes OpenMesh.
//
// Design. OpenMesh's halfedge meshes drop non-manifold faces silently, so we
// never build one: a BaseImporter of our own records what the reader
// modules hand over (vertices, faces as vertex lists, per-face and per-vertex
// texture coordinates, normals) into flat arrays.
//
// OpenMesh 9.0's readers trust their input. Before a buffer reaches them, a
// small scanner per format checks exactly what the reader will consume and
// rejects what it would misread or choke on, so every error names the file
// and the element. What they do with unchecked input (found by reading their
// sources and by probes):
//  - OBJ: unparsable `v`/`vn` lines (nan, inf, 1e39) are skipped, shifting
//    every later index; faces with fewer than 3 distinct corners vanish;
//    repeated corners are removed but their UVs are not; index 0 and
//    negative indices before the first vertex arrive as handles -1, -2...;
//    "f /1 ..." dereferences an empty vector; `mtllib` opens any path.
//  - PLY: a header without end_header, or with a non-numeric count, loops
//    forever (allocating); a comment or trailing blank right before
//    end_header shifts binary data by a byte and the file reads "fine";
//    list lengths are trusted (billions of push_backs); face lists other
//    than vertex_indices are misread.
//  - OFF: the istream reader never parses the header (ST/N flags come from
//    the previous file), so OFF goes through a private temporary file; face
//    colours without the C prefix desynchronise the reader; the face loop
//    has no end-of-file test.
//  - STL: NaN coordinates break the std::map the reader deduplicates with;
//    degenerate triangles are dropped silently (we count and warn).
// All readers are singletons with state, so reads are serialised by a mutex.

#include "ch_mesh.h"

#include <OpenMesh/Core/IO/IOManager.hh>
#include <OpenMesh/Core/IO/Options.hh>
#include <OpenMesh/Core/IO/importer/BaseImporter.hh>
#include <OpenMesh/Core/System/omstream.hh>

#include <algorithm>
#include <array>
#include <cerrno>
#include <clocale>
#include <cmath>
#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <map>
#include <mutex>
#include <new>
#include <sstream>
#include <stdexcept>
#include <streambuf>
#include <string>
#include <unordered_map>
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

// Largest file we read whole: far beyond a base mesh.
const size_t kMaxFileSize = (size_t)1 << 31;
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

// ---------------------------------------------------------------------------
// Tokens, as std::istream's operator>> sees them in the "C" locale.

bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\v' || c == '\f' || c == '\r';
}

// Quotes a token for a message, shortened and with control bytes escaped.
std::string quote(const char *b, const char *e) {
  std::string s = "'";
  for (const char *p = b; p < e && s.size() < 40; p++) {
    unsigned char c = (unsigned char)*p;
    if (c >= 32 && c < 127) {
      s += (char)c;
    } else {
      char hex[8];
      snprintf(hex, sizeof hex, "\\x%02x", c);
      s += hex;
    }
  }
  if (e - b > 38) s += "...";
  return s + "'";
}

locale_t c_locale() {
  static locale_t loc = newlocale(LC_ALL_MASK, "C", (locale_t)0);
  return loc;
}

// True when operator>>(float&) reads the whole token [b,e) and gets a finite
// value: libstdc++ collects only digits, sign, '.', 'e' (so no nan/inf/hex)
// and fails on float overflow. out receives the value.
bool float_token(const char *b, const char *e, float *out) {
  if (b == e || e - b > 400) return false;
  for (const char *p = b; p < e; p++)
    if (!strchr("0123456789+-.eE", *p)) return false;
  char buf[408];
  memcpy(buf, b, (size_t)(e - b));
  buf[e - b] = '\0';
  char *end = nullptr;
  float v = strtof_l(buf, &end, c_locale());
  if (end != buf + (e - b) || !std::isfinite(v)) return false;
  *out = v;
  return true;
}

// A strict integer token: [+-]?[0-9]+ within +-2^31-1.
bool int_token(const char *b, const char *e, long long *out) {
  const char *p = b;
  bool neg = false;
  if (p < e && (*p == '+' || *p == '-')) neg = *p++ == '-';
  if (p == e) return false;
  long long v = 0;
  for (; p < e; p++) {
    if (*p < '0' || *p > '9') return false;
    v = v * 10 + (*p - '0');
    if (v > 2147483647LL) return false;
  }
  *out = neg ? -v : v;
  return true;
}

// Whitespace-separated tokens of [b,e).
struct Tokens {
  const char *p, *e;
  Tokens(const char *b, const char *end) : p(b), e(end) {}
  bool next(const char **tb, const char **te) {
    while (p < e && is_space(*p)) p++;
    if (p == e) return false;
    *tb = p;
    while (p < e && !is_space(*p)) p++;
    *te = p;
    return true;
  }
};

bool token_is(const char *b, const char *e, const char *word) {
  size_t n = strlen(word);
  return (size_t)(e - b) == n && memcmp(b, word, n) == 0;
}

// Calls fn(begin, end, line_number) for every line as std::getline splits
// them, trimmed of " \t\r\n" like OpenMesh's OBJ/STL readers do.
template <class Fn>
void for_each_line(const char *d, size_t n, Fn fn) {
  size_t start = 0, line = 1;
  while (start < n) {
    const char *nl = (const char *)memchr(d + start, '\n', n - start);
    size_t end = nl ? (size_t)(nl - d) : n;
    const char *b = d + start, *e = d + end;
    while (b < e && strchr(" \t\r\n", *b)) b++;
    while (e > b && strchr(" \t\r\n", e[-1])) e--;
    fn(b, e, line);
    start = end + 1;
    line++;
  }
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
// OBJ scanner: mirrors the two passes of OpenMesh's OBJReader.

struct ObjScan {
  long long nv = 0, nt = 0, nn = 0, nf = 0, ncorners = 0;
  std::vector<size_t> mtllib_at;  // offsets of `mtllib` keywords
};

// The keyword of an OBJ line, or false for blank and comment lines (which
// OpenMesh recognises as empty, '#' or starting with \v or \f).
bool obj_keyword(const char *b, const char *e, Tokens *t, const char **kb, const char **ke) {
  if (b == e || *b == '#' || is_space(*b)) return false;
  *t = Tokens(b, e);
  return t->next(kb, ke);
}

void obj_numbers(Tokens t, int count, const char *what, long long index, size_t line,
                 const char *need) {
  for (int i = 0; i < count; i++) {
    const char *tb, *te;
    float v;
    if (!t.next(&tb, &te)) fail("%s %lld (line %zu): needs %s", what, index, line, need);
    if (!float_token(tb, te, &v))
      fail("%s %lld (line %zu): %s is not a finite number", what, index, line,
           quote(tb, te).c_str());
  }
}

// Resolves an OBJ index the way OpenMesh does (negative: relative to the
// elements read so far; positive: into the whole file) and checks it.
void obj_index(long long v, long long so_far, long long total, const char *what,
               long long face, size_t line) {
  if (v == 0)
    fail("face %lld (line %zu): %s index 0 is invalid (OBJ indices start at 1)", face, line,
         what);
  if (v < 0 && -v > so_far)
    fail("face %lld (line %zu): %s index %lld reaches before the first one (%lld defined so "
         "far)",
         face, line, what, v, so_far);
  if (v > total) {
    if (total == 0)
      fail("face %lld (line %zu): %s index %lld but the file has none", face, line, what, v);
    fail("face %lld (line %zu): %s index %lld out of range (1..%lld)", face, line, what, v,
         total);
  }
}

void scan_obj(const char *d, size_t n, ObjScan &s) {
  if (memchr(d, '\0', n)) fail("not a text OBJ file (contains NUL bytes)");
  // Pass 1: element totals and the syntax of v, vt, vn.
  for_each_line(d, n, [&](const char *b, const char *e, size_t line) {
    Tokens t(b, e);
    const char *kb, *ke;
    if (!obj_keyword(b, e, &t, &kb, &ke)) return;
    if (token_is(kb, ke, "v")) {
      obj_numbers(t, 3, "vertex", ++s.nv, line, "three coordinates x y z");
    } else if (token_is(kb, ke, "vt")) {
      obj_numbers(t, 2, "texture coordinate", ++s.nt, line, "two values u v");
    } else if (token_is(kb, ke, "vn")) {
      obj_numbers(t, 3, "normal", ++s.nn, line, "three values x y z");
    } else if (token_is(kb, ke, "mtllib")) {
      s.mtllib_at.push_back((size_t)(kb - d));
    }
    if (s.nv > kMax || s.nt > kMax || s.nn > kMax)
      fail("line %zu: too many elements (limit %lld)", line, kMax);
  });
  // Pass 2: faces, with indices resolved as OpenMesh's second pass does.
  long long v_so_far = 0, t_so_far = 0, n_so_far = 0;
  std::vector<long long> face_positions;
  for_each_line(d, n, [&](const char *b, const char *e, size_t line) {
    Tokens t(b, e);
    const char *kb, *ke;
    if (!obj_keyword(b, e, &t, &kb, &ke)) return;
    if (token_is(kb, ke, "v")) v_so_far++;
    if (token_is(kb, ke, "vt")) t_so_far++;
    if (token_is(kb, ke, "vn")) n_so_far++;
    if (!token_is(kb, ke, "f")) return;
    long long face = ++s.nf;
    int with_uv = 0, corners = 0;
    face_positions.clear();
    const char *tb, *te;
    while (t.next(&tb, &te)) {
      // corner: v[/[vt][/[vn]]]
      const char *part[3] = {tb, nullptr, nullptr}, *part_end[3] = {te, nullptr, nullptr};
      int parts = 1;
      for (const char *p = tb; p < te; p++) {
        if (*p != '/') continue;
        if (parts == 3) fail("face %lld (line %zu): cannot read corner %s", face, line,
                             quote(tb, te).c_str());
        part_end[parts - 1] = p;
        part[parts] = p + 1;
        part_end[parts] = te;
        parts++;
      }
      long long idx[3] = {0, 0, 0};
      for (int k = 0; k < parts; k++) {
        bool empty = part[k] == part_end[k];
        if ((k == 0 && empty) || (!empty && !int_token(part[k], part_end[k], &idx[k])))
          fail("face %lld (line %zu): cannot read corner %s", face, line, quote(tb, te).c_str());
      }
      obj_index(idx[0], v_so_far, s.nv, "position", face, line);
      face_positions.push_back(idx[0] < 0 ? v_so_far + idx[0] : idx[0] - 1);
      if (idx[1] != 0) {
        obj_index(idx[1], t_so_far, s.nt, "texture", face, line);
        with_uv++;
      }
      if (idx[2] != 0) obj_index(idx[2], n_so_far, s.nn, "normal", face, line);
      corners++;
    }
    if (corners < 3)
      fail("face %lld (line %zu): %d corner%s, a face needs at least 3", face, line, corners,
           corners == 1 ? "" : "s");
    // OpenMesh would drop the repeat (or the whole face) but keep its UVs.
    long long rep = first_repeat(face_positions);
    if (rep >= 0)
      fail("face %lld (line %zu): position %lld appears twice (degenerate face)", face, line,
           face_positions[rep] + 1);
    if (with_uv != 0 && with_uv != corners)
      fail("face %lld (line %zu): %d of its %d corners have texture coordinates", face, line,
           with_uv, corners);
    s.ncorners += corners;
    if (s.nf > kMax || s.ncorners > kMax)
      fail("line %zu: too many faces (limit %lld corners)", line, kMax);
  });
}

// ---------------------------------------------------------------------------
// PLY scanner: OpenMesh's header parser token by token, then a walk over the
// data with the sizes OpenMesh's reader consumes.

enum PlyType { P_BAD = -1, P_I8, P_U8, P_I16, P_U16, P_I32, P_U32, P_F32, P_F64 };
enum PlyRole { R_CUSTOM, R_COORD, R_NORMAL, R_TEX, R_COLOR, R_INDICES, R_FACE_TEX };

PlyType ply_type(const std::string &s) {
  if (s == "char" || s == "int8") return P_I8;
  if (s == "uchar" || s == "uint8") return P_U8;
  if (s == "short" || s == "int16") return P_I16;
  if (s == "ushort" || s == "uint16") return P_U16;
  if (s == "int" || s == "int32") return P_I32;
  if (s == "uint" || s == "uint32") return P_U32;
  if (s == "float" || s == "float32") return P_F32;
  if (s == "double" || s == "float64") return P_F64;
  return P_BAD;
}

int ply_size(PlyType t) {
  static const int size[] = {1, 1, 2, 2, 4, 4, 4, 8};
  return size[t];
}

bool ply_float(PlyType t) { return t == P_F32 || t == P_F64; }

struct PlyProp {
  std::string name;
  PlyType type = P_BAD;
  bool list = false;
  PlyType count_type = P_BAD;
  PlyRole role = R_CUSTOM;
};

struct PlyElem {
  std::string name;
  long long count = 0;
  std::vector<PlyProp> props;
};

struct PlyScan {
  bool binary = false, big_endian = false;
  long long nv = 0, nf = 0, ncorners = 0;
  bool texture_uv_names = false;  // texture_u/texture_v: not read by OpenMesh
  // A face `texcoord` list (u0 v0 u1 v1 ... per face, MeshLab's wedge UVs),
  // which OpenMesh misreads: the walk keeps the values and writes the file
  // without the list (stripped) for OpenMesh; the UVs are set afterwards.
  bool face_tex = false;
  std::vector<float> tex;         // 2 per corner, in file order
  std::vector<int> tex_first;     // per face: the first vertex index
  std::string stripped;
};

PlyRole ply_vertex_role(const std::string &n) {
  if (n == "x" || n == "y" || n == "z") return R_COORD;
  if (n == "nx" || n == "ny" || n == "nz") return R_NORMAL;
  if (n == "u" || n == "s" || n == "v" || n == "t") return R_TEX;
  if (n == "red" || n == "green" || n == "blue" || n == "alpha" || n == "diffuse_red" ||
      n == "diffuse_green" || n == "diffuse_blue")
    return R_COLOR;
  return R_CUSTOM;
}

struct PlyHeader {
  std::vector<PlyElem> elems;
  size_t data = 0;  // where OpenMesh starts reading the body
};

void ply_header(const char *d, size_t n, PlyScan &s, PlyHeader &h) {
  // First line: "ply", trimmed.
  const char *nl = (const char *)memchr(d, '\n', n);
  const char *b = d, *e = nl ? nl : d + n;
  while (b < e && is_space(*b)) b++;
  while (e > b && is_space(e[-1])) e--;
  if (!token_is(b, e, "ply") && !token_is(b, e, "PLY")) fail("not a PLY file (no 'ply' line)");
  size_t p = nl ? (size_t)(nl - d) + 1 : n;
  auto token = [&](std::string *out) {
    while (p < n && is_space(d[p])) p++;
    if (p == n) return false;
    size_t start = p;
    while (p < n && !is_space(d[p])) p++;
    out->assign(d + start, p - start);
    return true;
  };
  std::string kw, type, version;
  if (!token(&kw) || kw != "format" || !token(&type) || !token(&version))
    fail("PLY header: the second line must be 'format <type> 1.0'");
  float ver;
  if (!float_token(version.data(), version.data() + version.size(), &ver))
    fail("PLY header: bad format version %s", quote(version.data(), version.data() + version.size()).c_str());
  if (type == "binary_little_endian" || type == "binary_big_endian") {
    s.binary = true;
    s.big_endian = type == "binary_big_endian";
  } else if (type != "ascii") {
    fail("PLY header: unknown format '%s'", type.c_str());
  }
  size_t last = p;  // OpenMesh's streamPos: end of the last header item
  bool end = false;
  while (token(&kw)) {
    if (kw == "end_header") {
      end = true;
      break;
    }
    if (kw == "comment") {
      while (p < n && d[p] != '\n') p++;
      if (p < n) p++;
    } else if (kw == "element") {
      PlyElem el;
      std::string count;
      long long c;
      if (!token(&el.name) || !token(&count) ||
          !int_token(count.data(), count.data() + count.size(), &c) || c < 0 || count[0] == '+' ||
          count[0] == '-')
        fail("PLY header: element %s needs a count", el.name.c_str());
      if (c > kMax) fail("PLY header: element %s: count %lld too large", el.name.c_str(), c);
      el.count = c;
      for (const PlyElem &o : h.elems)
        if ((el.name == "vertex" || el.name == "face") && o.name == el.name)
          fail("PLY header: element %s declared twice", el.name.c_str());
      h.elems.push_back(el);
    } else if (kw == "property") {
      if (h.elems.empty()) fail("PLY header: property before the first element");
      PlyElem &el = h.elems.back();
      PlyProp pr;
      std::string t1, t2, t3;
      if (!token(&t1)) fail("PLY header: incomplete property");
      if (t1 == "list") {
        if (!token(&t2) || !token(&t3) || !token(&pr.name)) fail("PLY header: incomplete list property");
        if (t2 != "uint8" && t2 != "uchar" && t2 != "uint16" && t2 != "int")
          fail("PLY header: list count type '%s' of %s is not supported by OpenMesh (uchar, "
               "uint8, uint16 or int)",
               t2.c_str(), pr.name.c_str());
        pr.list = true;
        pr.count_type = ply_type(t2);
        pr.type = ply_type(t3);
        if (pr.type == P_BAD) fail("PLY header: unknown type '%s' of %s", t3.c_str(), pr.name.c_str());
        if (el.name == "face" && (pr.name == "vertex_indices" || pr.name == "vertex_index")) {
          pr.role = R_INDICES;
          if (ply_float(pr.type))
            fail("PLY header: vertex_indices must be integers, not '%s'", t3.c_str());
        } else if (el.name == "face" && pr.name == "texcoord") {
          if (!ply_float(pr.type)) fail("PLY header: texcoord must be float or double, not '%s'", t3.c_str());
          pr.role = R_FACE_TEX;
          s.face_tex = true;
        }
      } else {
        if (!token(&t2)) fail("PLY header: incomplete property '%s'", t1.c_str());
        // OpenMesh accepts "type name" and "name type".
        if (ply_type(t1) != P_BAD && ply_type(t2) == P_BAD) {
          pr.type = ply_type(t1);
          pr.name = t2;
        } else if (ply_type(t2) != P_BAD && ply_type(t1) == P_BAD) {
          pr.type = ply_type(t2);
          pr.name = t1;
        } else {
          fail("PLY header: cannot read property '%s %s'", t1.c_str(), t2.c_str());
        }
        if (el.name == "vertex") {
          pr.role = ply_vertex_role(pr.name);
          if (pr.name == "texture_u" || pr.name == "texture_v") s.texture_uv_names = true;
        } else if (el.name == "face") {
          if (pr.name == "red" || pr.name == "green" || pr.name == "blue" || pr.name == "alpha")
            pr.role = R_COLOR;
        }
      }
      el.props.push_back(pr);
    }
    // Other keywords (obj_info...) are skipped token by token, like OpenMesh.
    last = p;
  }
  if (!end) fail("PLY header: no end_header");
  if (s.binary) {
    // OpenMesh seeks to `last` and skips 12 bytes ("\nend_header\n"), or 14
    // after "\r\n": anything else between the last item and the data (a
    // comment line, trailing blanks) makes it read from the wrong offset.
    size_t om = last + ((last + 1 < n && d[last] == '\r' && d[last + 1] == '\n') ? 14 : 12);
    size_t real = p;
    if (real < n && d[real] == '\n') real += 1;
    else if (real + 1 < n && d[real] == '\r' && d[real + 1] == '\n') real += 2;
    else fail("PLY header: end_header must end its line");
    if (om != real)
      fail("PLY header: OpenMesh misplaces binary data after a comment or trailing blanks "
           "right before end_header; remove them");
    h.data = real;
  } else {
    h.data = p;
  }
}

// Checks what OpenMesh will do with the elements it reads (those up to the
// face element) and fills the counts.
void ply_check_elements(PlyScan &s, const PlyHeader &h, size_t *read_elems) {
  size_t nread = h.elems.size();
  int vertex = -1, face = -1;
  for (size_t i = 0; i < h.elems.size(); i++) {
    if (h.elems[i].name == "vertex") vertex = (int)i;
    if (h.elems[i].name == "face") {
      face = (int)i;
      nread = i + 1;  // OpenMesh stops after the faces
      break;
    }
  }
  if (face >= 0 && vertex < 0) {
    for (size_t i = (size_t)face + 1; i < h.elems.size(); i++)
      if (h.elems[i].name == "vertex")
        fail("PLY: the face element comes before the vertex element (OpenMesh stops after faces)");
  }
  if (vertex < 0) fail("PLY: no vertex element");
  for (size_t i = 0; i < nread; i++) {
    const PlyElem &el = h.elems[i];
    int xyz[3] = {0, 0, 0}, indices = 0;
    for (const PlyProp &pr : el.props) {
      if (pr.list && pr.role != R_INDICES && pr.role != R_FACE_TEX)
        fail("PLY: list property '%s' of element %s is not supported (OpenMesh misreads it); "
             "store texture coordinates as per-vertex u, v",
             pr.name.c_str(), el.name.c_str());
      if (pr.role == R_INDICES) indices++;
      if (pr.role == R_FACE_TEX && (int)i != face) fail("PLY: texcoord list outside the face element");
      if (pr.role == R_COORD) xyz[pr.name[0] - 'x']++;
      if (s.binary && (pr.role == R_COORD || pr.role == R_NORMAL || pr.role == R_TEX) &&
          !ply_float(pr.type))
        fail("PLY: vertex property '%s' must be float or double in binary PLY", pr.name.c_str());
      if (s.binary && pr.role == R_COLOR && pr.type == P_F64)
        fail("PLY: colour property '%s' of type double is not supported by OpenMesh",
             pr.name.c_str());
    }
    if ((int)i == vertex && (xyz[0] != 1 || xyz[1] != 1 || xyz[2] != 1))
      fail("PLY: the vertex element needs exactly one x, y and z property");
    if ((int)i == face && indices != 1)
      fail("PLY: the face element needs one vertex_indices list");
  }
  s.nv = vertex >= 0 ? h.elems[vertex].count : 0;
  s.nf = face >= 0 ? h.elems[face].count : 0;
  *read_elems = nread;
}

long long ply_binary_value(const unsigned char *q, PlyType t, bool big) {
  int size = ply_size(t);
  uint64_t u = 0;
  for (int i = 0; i < size; i++) u |= (uint64_t)q[big ? size - 1 - i : i] << (8 * i);
  switch (t) {
  case P_I8: return (int8_t)u;
  case P_I16: return (int16_t)u;
  case P_I32: return (int32_t)u;
  default: return (long long)u;
  }
}

void ply_face_corner(long long idx, long long nv, long long face) {
  if (idx < 0 || idx >= nv)
    fail("face %lld: vertex index %lld out of range (0..%lld)", face, idx, nv - 1);
}

void ply_face_count(long long count, long long face) {
  if (count < 3) fail("face %lld: %lld corners, a face needs at least 3", face, count);
}

[[noreturn]] void ply_truncated(const PlyElem &el, long long i) {
  fail("%s %lld of %lld: data ends here (file truncated?)", el.name.c_str(), i, el.count);
}

double ply_binary_float(const unsigned char *q, PlyType t, bool big) {
  unsigned char b[8];
  int size = ply_size(t);
  for (int i = 0; i < size; i++) b[i] = q[big ? size - 1 - i : i];
  if (t == P_F32) {
    float f;
    memcpy(&f, b, 4);
    return f;
  }
  double x;
  memcpy(&x, b, 8);
  return x;
}

// A face's texcoord list: 2 finite values per corner of the face.
void ply_face_tex(PlyScan &s, long long count, long long corners, long long face) {
  if (count != 2 * corners)
    fail("face %lld: %lld texcoord values for %lld corners (want 2 per corner)", face, count, corners);
  for (long long k = (long long)s.tex.size() - count; k < (long long)s.tex.size(); k++)
    if (!std::isfinite(s.tex[k])) fail("face %lld: texcoord is not a finite number", face);
}

// The header without the texcoord property line (the stripped copy's).
std::string ply_header_without_tex(const char *d, size_t data) {
  std::string out;
  size_t p = 0;
  while (p < data) {
    const char *nl = (const char *)memchr(d + p, '\n', data - p);
    size_t end = nl ? (size_t)(nl - d) + 1 : data;
    std::string line(d + p, end - p);
    if (!(line.find("property") != std::string::npos && line.find(" texcoord") != std::string::npos &&
          line.find("list") != std::string::npos))
      out += line;
    p = end;
  }
  if (out.empty() || out.back() != '\n') out += '\n';  // ASCII data starts after the token
  return out;
}

void ply_walk_binary(const char *d, size_t n, PlyScan &s, const PlyHeader &h, size_t nread) {
  size_t p = h.data;
  const unsigned char *u = (const unsigned char *)d;
  if (s.face_tex) s.stripped = ply_header_without_tex(d, h.data);
  for (size_t ei = 0; ei < nread; ei++) {
    const PlyElem &el = h.elems[ei];
    for (long long i = 0; i < el.count; i++) {
      long long corners = 0;
      for (const PlyProp &pr : el.props) {
        size_t at = p;
        if (!pr.list) {
          if (n - p < (size_t)ply_size(pr.type)) ply_truncated(el, i);
          p += ply_size(pr.type);
          if (s.face_tex) s.stripped.append(d + at, p - at);
          continue;
        }
        if (n - p < (size_t)ply_size(pr.count_type)) ply_truncated(el, i);
        long long count = ply_binary_value(u + p, pr.count_type, s.big_endian);
        p += ply_size(pr.count_type);
        if (pr.role == R_FACE_TEX) {
          if (count < 0 || (unsigned long long)count > (n - p) / ply_size(pr.type)) ply_truncated(el, i);
          for (long long k = 0; k < count; k++, p += ply_size(pr.type))
            s.tex.push_back((float)ply_binary_float(u + p, pr.type, s.big_endian));
          ply_face_tex(s, count, corners, i);
          continue;
        }
        ply_face_count(count, i);
        corners = count;
        if (s.face_tex && (unsigned long long)count <= (n - p) / ply_size(pr.type))
          s.tex_first.push_back((int)(unsigned)(ply_binary_value(u + p, pr.type, s.big_endian) & 0xffffffffLL));
        if ((unsigned long long)count > (n - p) / ply_size(pr.type)) ply_truncated(el, i);
        for (long long k = 0; k < count; k++) {
          long long idx = ply_binary_value(u + p, pr.type, s.big_endian);
          // OpenMesh reads into unsigned int, then makes an int handle.
          ply_face_corner((int)(unsigned)(idx & 0xffffffffLL), s.nv, i);
          p += ply_size(pr.type);
        }
        if (s.face_tex) s.stripped.append(d + at, p - at);
        s.ncorners += count;
        if (s.ncorners > kMax) fail("too many face corners (limit %lld)", kMax);
      }
    }
  }
}

void ply_walk_ascii(const char *d, size_t n, PlyScan &s, const PlyHeader &h, size_t nread) {
  Tokens t(d + h.data, d + n);
  const char *tb, *te;
  if (s.face_tex) s.stripped = ply_header_without_tex(d, h.data);
  for (size_t ei = 0; ei < nread; ei++) {
    const PlyElem &el = h.elems[ei];
    // OpenMesh gives up when the last token ended exactly at end of file.
    if (t.p == d + n) fail("element %s: data ends before it (file truncated?)", el.name.c_str());
    for (long long i = 0; i < el.count; i++) {
      long long corners = 0;
      for (const PlyProp &pr : el.props) {
        if (!t.next(&tb, &te)) ply_truncated(el, i);
        float f;
        long long v;
        const char *at = tb;
        if (pr.role == R_FACE_TEX) {
          if (!int_token(tb, te, &v) || *tb == '-' || *tb == '+')
            fail("face %lld: bad texcoord count %s", i, quote(tb, te).c_str());
          for (long long k = 0; k < v; k++) {
            if (!t.next(&tb, &te)) ply_truncated(el, i);
            if (!float_token(tb, te, &f)) fail("face %lld: texcoord %s is not a finite number", i, quote(tb, te).c_str());
            s.tex.push_back(f);
          }
          ply_face_tex(s, v, corners, i);
          continue;
        }
        if (pr.role == R_INDICES) {
          if (!int_token(tb, te, &v) || *tb == '-' || *tb == '+')
            fail("face %lld: bad corner count %s", i, quote(tb, te).c_str());
          ply_face_count(v, i);
          corners = v;
          for (long long k = 0; k < v; k++) {
            long long idx;
            if (!t.next(&tb, &te)) ply_truncated(el, i);
            if (!int_token(tb, te, &idx) || *tb == '+')
              fail("face %lld: bad vertex index %s", i, quote(tb, te).c_str());
            ply_face_corner(idx, s.nv, i);
            if (s.face_tex && k == 0) s.tex_first.push_back((int)idx);
          }
          s.ncorners += v;
          if (s.ncorners > kMax) fail("too many face corners (limit %lld)", kMax);
        } else if (pr.role == R_COORD || pr.role == R_NORMAL || pr.role == R_TEX ||
                   (pr.role == R_COLOR && ply_float(pr.type))) {
          if (!float_token(tb, te, &f))
            fail("%s %lld: property %s: %s is not a finite number", el.name.c_str(), i,
                 pr.name.c_str(), quote(tb, te).c_str());
        } else if (pr.role == R_COLOR) {
          if (!int_token(tb, te, &v))
            fail("%s %lld: property %s: %s is not an integer", el.name.c_str(), i,
                 pr.name.c_str(), quote(tb, te).c_str());
        }
        if (s.face_tex) {
          if (&pr != &el.props.front() && !s.stripped.empty() && s.stripped.back() != '\n') s.stripped += ' ';
          s.stripped.append(at, (size_t)(t.p - at));
        }
      }
      if (s.face_tex) s.stripped += '\n';
    }
  }
}

void scan_ply(const char *d, size_t n, PlyScan &s) {
  PlyHeader h;
  ply_header(d, n, s, h);
  size_t nread = 0;
  ply_check_elements(s, h, &nread);
  if (s.binary) ply_walk_binary(d, n, s, h, nread);
  else ply_walk_ascii(d, n, s, h, nread);
}

// ---------------------------------------------------------------------------
// OFF scanner: ASCII "[ST][N]OFF", one vertex or face per line.

struct OffScan {
  long long nv = 0, nf = 0, ncorners = 0;
};

void scan_off(const char *d, size_t n, OffScan &s) {
  if (memchr(d, '\0', n)) fail("not a text OFF file (contains NUL bytes)");
  bool st = false, normals = false;
  int state = 0;  // 0 header, 1 counts, 2 vertices, 3 faces, 4 done
  long long done = 0;
  size_t start = 0, line = 0;
  while (start < n && state != 4) {
    const char *nl = (const char *)memchr(d + start, '\n', n - start);
    size_t end = nl ? (size_t)(nl - d) : n;
    const char *b = d + start, *e = d + end;
    start = end + 1;
    line++;
    Tokens t(b, e);
    const char *tb, *te;
    if (state == 0) {
      while (e > b && is_space(e[-1])) e--;
      std::string head(b, e);
      if (head == "OFF" || head == "NOFF" || head == "STOFF" || head == "STNOFF") {
        st = head.compare(0, 2, "ST") == 0;
        normals = head.find('N') != std::string::npos;
        state = 1;
        continue;
      }
      if (head.find("OFF") == std::string::npos)
        fail("not an OFF file (the first line must be OFF)");
      if (head.find("BINARY") != std::string::npos)
        fail("binary OFF is not supported (OpenMesh reads it little-endian)");
      fail("OFF header %s is not supported (OFF, NOFF, STOFF or STNOFF, nothing else on the "
           "line)",
           quote(b, e).c_str());
    }
    if (!t.next(&tb, &te)) continue;  // blank line: operator>> skips it
    if (*tb == '#') fail("line %zu: OpenMesh's OFF reader does not accept comments", line);
    if (state == 1) {
      long long c[3];
      for (int k = 0; k < 3; k++) {
        if (k > 0 && !t.next(&tb, &te)) fail("line %zu: needs three counts (vertices faces edges)", line);
        if (!int_token(tb, te, &c[k]) || c[k] < 0)
          fail("line %zu: bad count %s", line, quote(tb, te).c_str());
      }
      if (t.next(&tb, &te)) fail("line %zu: needs exactly three counts", line);
      if (c[0] > kMax || c[1] > kMax) fail("line %zu: counts too large (limit %lld)", line, kMax);
      s.nv = c[0];
      s.nf = c[1];
      done = 0;
      state = s.nv > 0 ? 2 : (s.nf > 0 ? 3 : 4);
      continue;
    }
    if (state == 2) {
      int need = 3 + (normals ? 3 : 0) + (st ? 2 : 0);
      for (int k = 0; k < need; k++) {
        float f;
        if (k > 0 && !t.next(&tb, &te))
          fail("vertex %lld (line %zu): needs %d numbers on its line", done, line, need);
        if (!float_token(tb, te, &f))
          fail("vertex %lld (line %zu): %s is not a finite number", done, line,
               quote(tb, te).c_str());
      }
      if (++done == s.nv) {
        done = 0;
        state = s.nf > 0 ? 3 : 4;
      }
      continue;
    }
    long long count, idx;
    if (!int_token(tb, te, &count) || count < 0)
      fail("face %lld (line %zu): bad corner count %s", done, line, quote(tb, te).c_str());
    ply_face_count(count, done);
    for (long long k = 0; k < count; k++) {
      if (!t.next(&tb, &te)) fail("face %lld (line %zu): fewer than %lld indices", done, line, count);
      if (!int_token(tb, te, &idx)) fail("face %lld (line %zu): bad index %s", done, line, quote(tb, te).c_str());
      if (idx < 0 || idx >= s.nv)
        fail("face %lld (line %zu): vertex index %lld out of range (0..%lld)", done, line, idx,
             s.nv - 1);
    }
    if (t.next(&tb, &te))
      fail("face %lld (line %zu): values after the %lld indices (face colours need COFF, "
           "which is not supported)",
           done, line, count);
    s.ncorners += count;
    if (s.ncorners > kMax) fail("too many face corners (limit %lld)", kMax);
    if (++done == s.nf) state = 4;
  }
  if (state == 0) fail("empty OFF file");
  if (state == 1) fail("no counts line (file truncated?)");
  if (state == 2) fail("vertex %lld of %lld: data ends here (file truncated?)", done, s.nv);
  if (state == 3) fail("face %lld of %lld: data ends here (file truncated?)", done, s.nf);
}

// ---------------------------------------------------------------------------
// STL scanner.

struct StlScan {
  bool binary = false;
  long long triangles = 0;
};

void scan_stl(const char *d, size_t n, StlScan &s) {
  if (n >= 84) {
    const unsigned char *u = (const unsigned char *)d;
    uint32_t nt = (uint32_t)u[80] | (uint32_t)u[81] << 8 | (uint32_t)u[82] << 16 |
                  (uint32_t)u[83] << 24;
    // OpenMesh's own test: the size matches the triangle count.
    if (84 + 50 * (uint64_t)nt == n) {
      s.binary = true;
      s.triangles = nt;
      if (s.triangles > kMax / 3) fail("too many triangles (%lld)", s.triangles);
      for (uint32_t i = 0; i < nt; i++) {
        for (int k = 3; k < 12; k++) {
          float f;
          memcpy(&f, d + 84 + 50 * (size_t)i + 4 * k, 4);  // little-endian hosts only
          if (!std::isfinite(f))
            fail("triangle %u: vertex %d has a coordinate that is not finite", i, k / 3 - 1);
        }
      }
      return;
    }
  }
  if (memchr(d, '\0', n))
    fail("neither ASCII STL nor binary STL (size does not match the triangle count)");
  // ASCII: OpenMesh reads the three lines after every line containing
  // "outer" as "vertex x y z".
  int pending = 0;
  long long facet = 0;
  for_each_line(d, n, [&](const char *b, const char *e, size_t line) {
    if (pending > 0) {
      Tokens t(b, e);
      const char *tb, *te;
      float f;
      bool ok = t.next(&tb, &te);
      for (int k = 0; ok && k < 3; k++) ok = t.next(&tb, &te) && float_token(tb, te, &f);
      if (!ok) fail("facet %lld (line %zu): expected 'vertex x y z' with finite numbers", facet, line);
      pending--;
      return;
    }
    std::string l(b, e);
    if (l.find("outer") != std::string::npos || l.find("OUTER") != std::string::npos) {
      pending = 3;
      facet = s.triangles++;
      if (s.triangles > kMax / 3) fail("too many triangles");
    }
  });
  if (pending > 0) fail("facet %lld: data ends inside it (file truncated?)", facet);
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

  explicit Importer(Format f) : format(f), base(f == Format::OBJ ? 1 : 0) {}

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
    std::vector<int> idx;
    for (VertexHandle h : v) idx.push_back(h.idx());
    long long rep = first_repeat(idx);
    if (rep >= 0)
      fail("face %d: vertex %d appears twice (degenerate face)", face + base, idx[rep] + base);
    corners.insert(corners.end(), idx.begin(), idx.end());
    face_start.push_back((int)corners.size());
    face_has_uv.push_back(0);
    face_uv.resize(2 * corners.size(), 0.0f);
    take_pending_normals(v);
    return FaceHandle(face);
  }

  void take_pending_normals(const VHandles &v) {
    corner_n.resize(3 * corners.size(), 0.0f);
    if (format != Format::OBJ) return;
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

// Indexes values by their exact bits, in order of first appearance.
template <int N>
struct Dedup {
  std::map<std::array<uint32_t, N>, int> index;
  std::vector<double> values;
  int add(const float *v) {
    std::array<uint32_t, N> key;
    memcpy(key.data(), v, sizeof key);
    auto it = index.emplace(key, (int)index.size()).first;
    if (it->second == (int)values.size() / N)
      for (int k = 0; k < N; k++) values.push_back(v[k]);
    return it->second;
  }
};

struct Built {
  std::vector<double> uvs, normals;
  std::vector<int> corner_uv, corner_normal;
};

void build_uvs(const Importer &imp, Built &b) {
  size_t nf = imp.face_has_uv.size();
  size_t with = (size_t)std::count(imp.face_has_uv.begin(), imp.face_has_uv.end(), 1);
  Dedup<2> dd;
  if (with > 0) {
    if (with != nf) {
      size_t f = std::find(imp.face_has_uv.begin(), imp.face_has_uv.end(), 0) - imp.face_has_uv.begin();
      fail("face %zu has no texture coordinates while other faces have them", f + imp.base);
    }
    for (size_t c = 0; c < imp.corners.size(); c++) b.corner_uv.push_back(dd.add(&imp.face_uv[2 * c]));
  } else {
    for (int v : imp.corners)
      if (!imp.vert_has_uv[v]) return;  // no (complete) per-vertex UVs either
    for (int v : imp.corners) b.corner_uv.push_back(dd.add(&imp.vert_uv[2 * v]));
  }
  b.uvs = std::move(dd.values);
}

void build_normals(const Importer &imp, Built &b, const char *name, ch_error *err) {
  if (imp.format == Format::OBJ) {
    size_t complete = (size_t)std::count(imp.face_n.begin(), imp.face_n.end(), 1);
    if (complete == 0 && std::count(imp.face_n.begin(), imp.face_n.end(), 2) == 0) return;
    if (complete != imp.face_n.size()) {
      ch_warn(err, "%s: only some faces have normals (vn) on every corner; normals ignored", name);
      return;
    }
    Dedup<3> dd;
    for (size_t c = 0; c < imp.corners.size(); c++)
      b.corner_normal.push_back(dd.add(&imp.corner_n[3 * c]));
    b.normals = std::move(dd.values);
    return;
  }
  for (int v : imp.corners)
    if (!imp.vert_has_n[v]) return;
  Dedup<3> dd;
  for (int v : imp.corners) b.corner_normal.push_back(dd.add(&imp.vert_n[3 * v]));
  b.normals = std::move(dd.values);
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
  build_uvs(imp, b);
  build_normals(imp, b, name, err);
  ch_mesh m;
  memset(&m, 0, sizeof m);
  try {
    m.num_positions = nv;
    m.positions = c_array(imp.pos);
    m.num_faces = (int)imp.face_has_uv.size();
    m.face_start = c_array(imp.face_start);
    m.num_corners = (int)imp.corners.size();
    m.corner_position = c_array(imp.corners);
    m.num_uvs = (int)(b.uvs.size() / 2);
    m.uvs = c_array(b.uvs);
    m.corner_uv = c_array(b.corner_uv);
    m.num_normals = (int)(b.normals.size() / 3);
    m.normals = c_array(b.normals);
    m.corner_normal = c_array(b.corner_normal);
  } catch (...) {
    ch_mesh_free(&m);
    throw;
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
  switch (f) {
  case Format::OBJ: {
    ObjScan s;
    scan_obj(data, size, s);
    want_v = s.nv;
    want_f = s.nf;
    // Materials are not used; `mtllib` would open arbitrary paths.
    std::string copy;
    if (!s.mtllib_at.empty()) {
      copy.assign(data, size);
      for (size_t at : s.mtllib_at) copy[at] = '#';
      data = copy.data();
    }
    run_stream(data, size, "obj", false, imp);
    break;
  }
  case Format::PLY: {
    PlyScan s;
    scan_ply(data, size, s);
    if (s.texture_uv_names)
      ch_warn(err, "%s: PLY properties texture_u/texture_v are not read (OpenMesh knows u,v and s,t)", name);
    want_v = s.nv;
    want_f = s.nf;
    if (!s.face_tex) {
      run_stream(data, size, "ply", false, imp);
      break;
    }
    run_stream(s.stripped.data(), s.stripped.size(), "ply", false, imp);
    // The face texcoords, now that the faces exist (the first value pair
    // belongs to the corner at the face's first vertex).
    for (size_t f = 0, k = 0; f < s.tex_first.size() && f < imp.n_faces(); f++) {
      int corners = imp.face_corners((int)f);
      std::vector<Vec2f> uv;
      for (int c = 0; c < corners; c++, k += 2) uv.emplace_back(s.tex[k], s.tex[k + 1]);
      imp.add_face_texcoords(FaceHandle((int)f), VertexHandle(s.tex_first[f]), uv);
    }
    break;
  }
  case Format::OFF: {
    OffScan s;
    scan_off(data, size, s);
    want_v = s.nv;
    want_f = s.nf;
    run_off_file(data, size, imp);
    break;
  }
  case Format::STL: {
    StlScan s;
    scan_stl(data, size, s);
    run_stream(data, size, "stl", s.binary, imp);
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

const char kAccepted[] = ".obj, .ply, .off, .stl";

}  // namespace

extern "C" ch_status ch_mesh_read_memory(const void *data, size_t size, const char *format,
                                         const char *name, ch_mesh *out, ch_error *err) {
  memset(out, 0, sizeof *out);
  if (!name) name = "(memory)";
  Format f;
  if (!parse_format(format, &f))
    return ch_error_set(err, CH_ERR_INPUT, "%s: unknown mesh format '%s' (accepted: %s)", name,
                        format ? format : "", kAccepted);
  static const char empty = '\0';
  const char *bytes = size ? (const char *)data : &empty;
  return guarded(name, out, err, [&] { read_buffer(bytes, size, f, name, out, err); });
}

extern "C" ch_status ch_mesh_read(const char *path, ch_mesh *out, ch_error *err) {
  memset(out, 0, sizeof *out);
  char ext[16];
  ch_path_extension(path, ext, sizeof ext);
  Format f;
  if (!parse_format(ext, &f)) {
    if (!ext[0])
      return ch_error_set(err, CH_ERR_INPUT, "%s: no file extension (accepted: %s)", path, kAccepted);
    return ch_error_set(err, CH_ERR_INPUT, "%s: unknown mesh format '.%s' (accepted: %s)", path,
                        ext, kAccepted);
  }
  char *data = nullptr;
  size_t size = 0;
  ch_status st = ch_file_read_all(path, kMaxFileSize, &data, &size, err);
  if (st != CH_OK) return st;
  st = guarded(path, out, err, [&] { read_buffer(data, size, f, path, out, err); });
  free(data);
  return st;
}
