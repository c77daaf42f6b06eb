/* The format scanners (ch_mesh_scan.h): what OpenMesh 9.0's readers would
 * consume, checked before they see it.
 *
 * OpenMesh 9.0's readers trust their input. A small scanner per format
 * checks exactly what the reader will consume and rejects what it would
 * misread or choke on, so every error names the file and the element. What
 * they do with unchecked input (found by reading their sources and by
 * probes):
 *  - OBJ: unparsable `v`/`vn` lines (nan, inf, 1e39) are skipped, shifting
 *    every later index; faces with fewer than 3 distinct corners vanish;
 *    repeated corners are removed but their UVs are not; index 0 and
 *    negative indices before the first vertex arrive as handles -1, -2...;
 *    "f /1 ..." dereferences an empty vector; `mtllib` opens any path.
 *  - PLY: a header without end_header, or with a non-numeric count, loops
 *    forever (allocating); a comment or trailing blank right before
 *    end_header shifts binary data by a byte and the file reads "fine";
 *    list lengths are trusted (billions of push_backs); face lists other
 *    than vertex_indices are misread.
 *  - OFF: the istream reader never parses the header (ST/N flags come from
 *    the previous file), so OFF goes through a private temporary file; face
 *    colours without the C prefix desynchronise the reader; the face loop
 *    has no end-of-file test.
 *  - STL: NaN coordinates break the std::map the reader deduplicates with;
 *    degenerate triangles are dropped silently (the shim counts and warns).
 *
 * A scan stops at the first problem: fail() records the message and jumps
 * back to the entry point (setjmp), which keeps the scanners as straight as
 * the readers they mirror; everything they allocate hangs off the scan or
 * the context, so the entry point frees it. */
#define _GNU_SOURCE /* strtof_l, newlocale */
#include "ch_mesh_scan.h"

#include <locale.h>
#include <math.h>
#include <pthread.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ch_alloc.h"
#include "ch_mesh.h"

#define MAX_ELEMENTS ((long long)CH_MESH_MAX_ELEMENTS)

typedef struct ply_prop ply_prop;
typedef struct ply_elem ply_elem;

/* A scan in progress: where fail() jumps, and the scratch it frees. */
typedef struct ctx {
  jmp_buf jump;
  ch_status status;
  char message[CH_ERROR_MESSAGE_MAX];
  ch_mesh_scan *s;
  long long *positions; /* OBJ: one face's positions */
  size_t cap_positions;
  long long (*pairs)[2]; /* OBJ: (position, corner) sorted, for large faces */
  size_t cap_pairs;
  ply_elem *elems; /* PLY header */
  size_t num_elems, cap_elems;
  size_t cap_mtllib, cap_tex, cap_tex_first, cap_stripped;
  int keep; /* OBJ: keep the values and corners (ch_mesh_scan_obj_values) */
  size_t cap_obj_pos, cap_obj_tex, cap_obj_normal, cap_obj_faces, cap_obj_corners[3];
} ctx;

#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
static _Noreturn void fail(ctx *c, const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(c->message, sizeof c->message, fmt, ap);
  va_end(ap);
  c->status = CH_ERR_INPUT;
  longjmp(c->jump, 1);
}

static _Noreturn void fail_nomem(ctx *c) {
  snprintf(c->message, sizeof c->message, "out of memory");
  c->status = CH_ERR_NOMEM;
  longjmp(c->jump, 1);
}

/* Makes room for need elements in *p (capacity *cap), doubling. */
static void reserve(ctx *c, void **p, size_t *cap, size_t need, size_t elem) {
  if (need <= *cap) return;
  size_t n = *cap ? *cap : 16;
  while (n < need) n *= 2;
  if (ch_alloc_resize(p, *cap, n, elem)) fail_nomem(c); /* (huge pages for an OBJ's values) */
  *cap = n;
}

/* ---- tokens, as std::istream's operator>> sees them in the "C" locale -- */

static int is_space(char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\v' || c == '\f' || c == '\r';
}

/* Quotes a token for a message, shortened and with control bytes escaped
 * (out: at least 64 bytes). */
static const char *quote(const char *b, const char *e, char out[64]) {
  size_t k = 0;
  out[k++] = '\'';
  for (const char *p = b; p < e && k < 40; p++) {
    unsigned char ch = (unsigned char)*p;
    if (ch >= 32 && ch < 127) {
      out[k++] = (char)ch;
    } else {
      snprintf(out + k, 8, "\\x%02x", ch);
      k += 4;
    }
  }
  if (e - b > 38) {
    memcpy(out + k, "...", 3);
    k += 3;
  }
  out[k++] = '\'';
  out[k] = '\0';
  return out;
}
#define Q(b, e) quote((b), (e), (char[64]){0})

static locale_t c_loc;
static pthread_once_t c_loc_once = PTHREAD_ONCE_INIT;
static void make_c_locale(void) { c_loc = newlocale(LC_ALL_MASK, "C", (locale_t)0); }

/* A decimal token [+-]d*[.d*][(e|E)[+-]d+] with at least one mantissa
 * digit, at most 19 significant digits whose value is at most 2^53 and a
 * power of ten within 10^+-22, as the float strtof gives: the double
 * m * 10^e (or m / 10^-e) is then correctly rounded (both operands are
 * exact: Clinger's fast path, 1990), and rounding it to float again gives
 * strtof's float unless the double lies exactly halfway between two
 * floats (for x below a halfway point M, RN(x) <= M as M is a double).
 * 0 where it does not apply (strtof decides). */
static int fast_float_token(const char *p, const char *e, float *out) {
  static const double pow10[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                                 1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
  int neg = 0;
  if (p < e && (*p == '+' || *p == '-')) neg = *p++ == '-';
  uint64_t m = 0;
  int digits = 0, significant = 0, exp10 = 0;
  for (; p < e && *p >= '0' && *p <= '9'; p++, digits++)
    if (significant || *p != '0') {
      if (++significant > 19) return 0;
      m = m * 10 + (uint64_t)(*p - '0');
    }
  if (p < e && *p == '.')
    for (p++; p < e && *p >= '0' && *p <= '9'; p++, digits++) {
      exp10--;
      if (significant || *p != '0') {
        if (++significant > 19) return 0;
        m = m * 10 + (uint64_t)(*p - '0');
      }
    }
  if (digits == 0) return 0;
  if (p < e && (*p == 'e' || *p == 'E')) {
    p++;
    int eneg = 0, edigits = 0, ev = 0;
    if (p < e && (*p == '+' || *p == '-')) eneg = *p++ == '-';
    for (; p < e && *p >= '0' && *p <= '9'; p++, edigits++)
      if ((ev = ev * 10 + (*p - '0')) > 1000) return 0;
    if (edigits == 0) return 0;
    exp10 += eneg ? -ev : ev;
  }
  if (p != e || m > (UINT64_C(1) << 53) || exp10 < -22 || exp10 > 22) return 0;
  double d = exp10 < 0 ? (double)m / pow10[-exp10] : (double)m * pow10[exp10];
  /* halfway between two floats: the double's 29 bits below a normal
   * float's 24 are 1 followed by zeros (subnormal floats: strtof decides) */
  uint64_t bits;
  memcpy(&bits, &d, sizeof bits);
  if (d != 0.0 && (d < 1.2e-38 || (bits & ((UINT64_C(1) << 29) - 1)) == (UINT64_C(1) << 28))) return 0;
  float f = (float)d;
  if (!isfinite(f)) return 0;
  *out = neg ? -f : f;
  return 1;
}

/* True when operator>>(float&) reads the whole token [b,e) and gets a finite
 * value: libstdc++ collects only digits, sign, '.', 'e' (so no nan/inf/hex)
 * and fails on float overflow. out receives the value. */
static int float_token(const char *b, const char *e, float *out) {
  if (b == e || e - b > 400) return 0;
  if (fast_float_token(b, e, out)) return 1;
  for (const char *p = b; p < e; p++)
    if (!((*p >= '0' && *p <= '9') || *p == '+' || *p == '-' || *p == '.' || *p == 'e' || *p == 'E')) return 0;
  char buf[408];
  memcpy(buf, b, (size_t)(e - b));
  buf[e - b] = '\0';
  pthread_once(&c_loc_once, make_c_locale);
  char *end = NULL;
  float v = strtof_l(buf, &end, c_loc);
  if (end != buf + (e - b) || !isfinite(v)) return 0;
  *out = v;
  return 1;
}

/* A strict integer token: [+-]?[0-9]+ within +-2^31-1. */
static int int_token(const char *b, const char *e, long long *out) {
  const char *p = b;
  int neg = 0;
  if (p < e && (*p == '+' || *p == '-')) neg = *p++ == '-';
  if (p == e) return 0;
  long long v = 0;
  for (; p < e; p++) {
    if (*p < '0' || *p > '9') return 0;
    v = v * 10 + (*p - '0');
    if (v > 2147483647LL) return 0;
  }
  *out = neg ? -v : v;
  return 1;
}

/* Whitespace-separated tokens of [p,e). */
typedef struct tokens {
  const char *p, *e;
} tokens;

static int next_token(tokens *t, const char **tb, const char **te) {
  while (t->p < t->e && is_space(*t->p)) t->p++;
  if (t->p == t->e) return 0;
  *tb = t->p;
  while (t->p < t->e && !is_space(*t->p)) t->p++;
  *te = t->p;
  return 1;
}

static int token_is(const char *b, const char *e, const char *word) {
  size_t n = strlen(word);
  return (size_t)(e - b) == n && memcmp(b, word, n) == 0;
}

/* Whether [b,e) contains word. */
static int contains(const char *b, const char *e, const char *word) {
  size_t n = strlen(word);
  for (const char *p = b; p + n <= e; p++)
    if (memcmp(p, word, n) == 0) return 1;
  return 0;
}

/* The next line as std::getline splits them, trimmed of " \t\r\n" like
 * OpenMesh's OBJ/STL readers do; *start moves past it. 0 at the end. */
static int next_line(const char *d, size_t n, size_t *start, const char **b, const char **e) {
  if (*start >= n) return 0;
  const char *nl = memchr(d + *start, '\n', n - *start);
  size_t end = nl ? (size_t)(nl - d) : n;
  *b = d + *start;
  *e = d + end;
  while (*b < *e && strchr(" \t\r\n", **b)) (*b)++;
  while (*e > *b && strchr(" \t\r\n", (*e)[-1])) (*e)--;
  *start = end + 1;
  return 1;
}

static int cmp_pair(const void *a, const void *b) {
  const long long *x = a, *y = b;
  if (x[0] != y[0]) return x[0] < y[0] ? -1 : 1;
  return (x[1] > y[1]) - (x[1] < y[1]);
}

/* Index of the first value of v[0..n) that repeats an earlier one, or -1.
 * Pairwise for small faces, by sorting for large ones. */
static long long first_repeat(ctx *c, const long long *v, size_t n) {
  if (n <= 32) {
    for (size_t i = 1; i < n; i++)
      for (size_t j = 0; j < i; j++)
        if (v[j] == v[i]) return (long long)i;
    return -1;
  }
  reserve(c, (void **)&c->pairs, &c->cap_pairs, n, sizeof *c->pairs);
  for (size_t i = 0; i < n; i++) c->pairs[i][0] = v[i], c->pairs[i][1] = (long long)i;
  qsort(c->pairs, n, sizeof *c->pairs, cmp_pair);
  long long first = -1;
  for (size_t i = 1; i < n; i++)
    if (c->pairs[i][0] == c->pairs[i - 1][0] && (first < 0 || c->pairs[i][1] < first)) first = c->pairs[i][1];
  return first;
}

/* ---- OBJ: mirrors the two passes of OpenMesh's OBJReader --------------- */

/* The keyword of an OBJ line, or 0 for blank and comment lines (which
 * OpenMesh recognises as empty, '#' or starting with \v or \f). */
static int obj_keyword(const char *b, const char *e, tokens *t, const char **kb, const char **ke) {
  if (b == e || *b == '#' || is_space(*b)) return 0;
  *t = (tokens){b, e};
  return next_token(t, kb, ke);
}

/* Checks the count values of element `index` (1-based) and, when the
 * scan keeps values, appends them to *values (capacity *cap). */
static void obj_numbers(ctx *c, tokens t, int count, const char *what, long long index, size_t line, const char *need,
                        float **values, size_t *cap) {
  float v[3];
  for (int i = 0; i < count; i++) {
    const char *tb, *te;
    if (!next_token(&t, &tb, &te)) fail(c, "%s %lld (line %zu): needs %s", what, index, line, need);
    if (!float_token(tb, te, &v[i]))
      fail(c, "%s %lld (line %zu): %s is not a finite number", what, index, line, Q(tb, te));
  }
  if (!c->keep) return;
  reserve(c, (void **)values, cap, (size_t)index * (size_t)count, sizeof **values);
  memcpy(*values + (size_t)(index - 1) * (size_t)count, v, (size_t)count * sizeof *v);
}

/* Resolves an OBJ index the way OpenMesh does (negative: relative to the
 * elements read so far; positive: into the whole file) and checks it. */
static void obj_index(ctx *c, long long v, long long so_far, long long total, const char *what, long long face,
                      size_t line) {
  if (v == 0) fail(c, "face %lld (line %zu): %s index 0 is invalid (OBJ indices start at 1)", face, line, what);
  if (v < 0 && -v > so_far)
    fail(c,
         "face %lld (line %zu): %s index %lld reaches before the first one (%lld defined so "
         "far)",
         face, line, what, v, so_far);
  if (v > total) {
    if (total == 0) fail(c, "face %lld (line %zu): %s index %lld but the file has none", face, line, what, v);
    fail(c, "face %lld (line %zu): %s index %lld out of range (1..%lld)", face, line, what, v, total);
  }
}

static void scan_obj(ctx *c, const char *d, size_t n) {
  ch_mesh_scan *s = c->s;
  if (memchr(d, '\0', n)) fail(c, "not a text OBJ file (contains NUL bytes)");
  /* Pass 1: element totals and the syntax of v, vt, vn. */
  size_t at = 0, line = 0;
  const char *b, *e;
  while (next_line(d, n, &at, &b, &e)) {
    line++;
    tokens t;
    const char *kb, *ke;
    if (!obj_keyword(b, e, &t, &kb, &ke)) continue;
    if (token_is(kb, ke, "v")) {
      obj_numbers(c, t, 3, "vertex", ++s->num_vertices, line, "three coordinates x y z", &s->obj_pos, &c->cap_obj_pos);
    } else if (token_is(kb, ke, "vt")) {
      obj_numbers(c, t, 2, "texture coordinate", ++s->num_texcoords, line, "two values u v", &s->obj_tex,
                  &c->cap_obj_tex);
    } else if (token_is(kb, ke, "vn")) {
      obj_numbers(c, t, 3, "normal", ++s->num_normals, line, "three values x y z", &s->obj_normal, &c->cap_obj_normal);
    } else if (token_is(kb, ke, "mtllib")) {
      reserve(c, (void **)&s->mtllib_at, &c->cap_mtllib, s->num_mtllib + 1, sizeof *s->mtllib_at);
      s->mtllib_at[s->num_mtllib++] = (size_t)(kb - d);
    }
    if (s->num_vertices > MAX_ELEMENTS || s->num_texcoords > MAX_ELEMENTS || s->num_normals > MAX_ELEMENTS)
      fail(c, "line %zu: too many elements (limit %lld)", line, MAX_ELEMENTS);
  }
  /* Pass 2: faces, with indices resolved as OpenMesh's second pass does. */
  long long v_so_far = 0, t_so_far = 0, n_so_far = 0;
  if (c->keep) {
    reserve(c, (void **)&s->obj_face_start, &c->cap_obj_faces, 1, sizeof *s->obj_face_start);
    s->obj_face_start[0] = 0;
  }
  at = 0;
  line = 0;
  while (next_line(d, n, &at, &b, &e)) {
    line++;
    tokens t;
    const char *kb, *ke;
    if (!obj_keyword(b, e, &t, &kb, &ke)) continue;
    if (token_is(kb, ke, "v")) v_so_far++;
    if (token_is(kb, ke, "vt")) t_so_far++;
    if (token_is(kb, ke, "vn")) n_so_far++;
    if (!token_is(kb, ke, "f")) continue;
    long long face = ++s->num_faces;
    int with_uv = 0, corners = 0;
    size_t num_positions = 0;
    const char *tb, *te;
    while (next_token(&t, &tb, &te)) {
      /* corner: v[/[vt][/[vn]]] */
      const char *part[3] = {tb, NULL, NULL}, *part_end[3] = {te, NULL, NULL};
      int parts = 1;
      for (const char *p = tb; p < te; p++) {
        if (*p != '/') continue;
        if (parts == 3) fail(c, "face %lld (line %zu): cannot read corner %s", face, line, Q(tb, te));
        part_end[parts - 1] = p;
        part[parts] = p + 1;
        part_end[parts] = te;
        parts++;
      }
      long long idx[3] = {0, 0, 0};
      for (int k = 0; k < parts; k++) {
        int empty = part[k] == part_end[k];
        if ((k == 0 && empty) || (!empty && !int_token(part[k], part_end[k], &idx[k])))
          fail(c, "face %lld (line %zu): cannot read corner %s", face, line, Q(tb, te));
      }
      obj_index(c, idx[0], v_so_far, s->num_vertices, "position", face, line);
      reserve(c, (void **)&c->positions, &c->cap_positions, num_positions + 1, sizeof *c->positions);
      c->positions[num_positions++] = idx[0] < 0 ? v_so_far + idx[0] : idx[0] - 1;
      if (idx[1] != 0) {
        obj_index(c, idx[1], t_so_far, s->num_texcoords, "texture", face, line);
        with_uv++;
      }
      if (idx[2] != 0) obj_index(c, idx[2], n_so_far, s->num_normals, "normal", face, line);
      if (c->keep) {
        /* (the limits keep every index and count within int) */
        size_t k = (size_t)(s->num_corners + corners);
        reserve(c, (void **)&s->obj_corner_pos, &c->cap_obj_corners[0], k + 1, sizeof *s->obj_corner_pos);
        reserve(c, (void **)&s->obj_corner_tex, &c->cap_obj_corners[1], k + 1, sizeof *s->obj_corner_tex);
        reserve(c, (void **)&s->obj_corner_normal, &c->cap_obj_corners[2], k + 1, sizeof *s->obj_corner_normal);
        s->obj_corner_pos[k] = (int)c->positions[num_positions - 1];
        s->obj_corner_tex[k] = idx[1] == 0 ? -1 : (int)(idx[1] < 0 ? t_so_far + idx[1] : idx[1] - 1);
        s->obj_corner_normal[k] = idx[2] == 0 ? -1 : (int)(idx[2] < 0 ? n_so_far + idx[2] : idx[2] - 1);
      }
      corners++;
    }
    if (corners < 3)
      fail(c, "face %lld (line %zu): %d corner%s, a face needs at least 3", face, line, corners,
           corners == 1 ? "" : "s");
    /* OpenMesh would drop the repeat (or the whole face) but keep its UVs. */
    long long rep = first_repeat(c, c->positions, num_positions);
    if (rep >= 0)
      fail(c, "face %lld (line %zu): position %lld appears twice (degenerate face)", face, line,
           c->positions[rep] + 1);
    if (with_uv != 0 && with_uv != corners)
      fail(c, "face %lld (line %zu): %d of its %d corners have texture coordinates", face, line, with_uv,
           corners);
    s->num_corners += corners;
    if (s->num_faces > MAX_ELEMENTS || s->num_corners > MAX_ELEMENTS)
      fail(c, "line %zu: too many faces (limit %lld corners)", line, MAX_ELEMENTS);
    if (c->keep) {
      reserve(c, (void **)&s->obj_face_start, &c->cap_obj_faces, (size_t)face + 1, sizeof *s->obj_face_start);
      s->obj_face_start[face] = (int)s->num_corners;
    }
  }
}

/* ---- PLY: OpenMesh's header parser token by token, then a walk over the
 * data with the sizes OpenMesh's reader consumes ---------------------------- */

typedef enum ply_type { P_BAD = -1, P_I8, P_U8, P_I16, P_U16, P_I32, P_U32, P_F32, P_F64 } ply_type;
typedef enum ply_role { R_CUSTOM, R_COORD, R_NORMAL, R_TEX, R_COLOR, R_INDICES, R_FACE_TEX } ply_role;

/* A header token: [b, e) of the file. */
typedef struct tok {
  const char *b, *e;
} tok;

static int tok_is(tok t, const char *word) { return token_is(t.b, t.e, word); }
static int tok_eq(tok a, tok b) { return a.e - a.b == b.e - b.b && memcmp(a.b, b.b, (size_t)(a.e - a.b)) == 0; }
/* For messages (which are cut at CH_ERROR_MESSAGE_MAX anyway). */
#define TOK(t) (int)((t).e - (t).b > 4096 ? 4096 : (t).e - (t).b), (t).b

static ply_type ply_type_of(tok t) {
  if (tok_is(t, "char") || tok_is(t, "int8")) return P_I8;
  if (tok_is(t, "uchar") || tok_is(t, "uint8")) return P_U8;
  if (tok_is(t, "short") || tok_is(t, "int16")) return P_I16;
  if (tok_is(t, "ushort") || tok_is(t, "uint16")) return P_U16;
  if (tok_is(t, "int") || tok_is(t, "int32")) return P_I32;
  if (tok_is(t, "uint") || tok_is(t, "uint32")) return P_U32;
  if (tok_is(t, "float") || tok_is(t, "float32")) return P_F32;
  if (tok_is(t, "double") || tok_is(t, "float64")) return P_F64;
  return P_BAD;
}

static int ply_size(ply_type t) {
  static const int size[] = {1, 1, 2, 2, 4, 4, 4, 8};
  return size[t];
}

static int ply_float(ply_type t) { return t == P_F32 || t == P_F64; }

struct ply_prop {
  tok name;
  ply_type type;
  int list;
  ply_type count_type;
  ply_role role;
};

struct ply_elem {
  tok name;
  long long count;
  ply_prop *props;
  size_t num_props, cap_props;
};

static ply_role ply_vertex_role(tok n) {
  if (tok_is(n, "x") || tok_is(n, "y") || tok_is(n, "z")) return R_COORD;
  if (tok_is(n, "nx") || tok_is(n, "ny") || tok_is(n, "nz")) return R_NORMAL;
  if (tok_is(n, "u") || tok_is(n, "s") || tok_is(n, "v") || tok_is(n, "t")) return R_TEX;
  if (tok_is(n, "red") || tok_is(n, "green") || tok_is(n, "blue") || tok_is(n, "alpha") ||
      tok_is(n, "diffuse_red") || tok_is(n, "diffuse_green") || tok_is(n, "diffuse_blue"))
    return R_COLOR;
  return R_CUSTOM;
}

/* The next header token from *p, or 0 at the end of the file. */
static int header_token(const char *d, size_t n, size_t *p, tok *out) {
  while (*p < n && is_space(d[*p])) (*p)++;
  if (*p == n) return 0;
  size_t start = *p;
  while (*p < n && !is_space(d[*p])) (*p)++;
  out->b = d + start;
  out->e = d + *p;
  return 1;
}

/* Parses the header into c->elems; returns where OpenMesh starts reading
 * the body. */
static size_t ply_header(ctx *c, const char *d, size_t n) {
  ch_mesh_scan *s = c->s;
  /* First line: "ply", trimmed. */
  const char *nl = memchr(d, '\n', n);
  const char *b = d, *e = nl ? nl : d + n;
  while (b < e && is_space(*b)) b++;
  while (e > b && is_space(e[-1])) e--;
  if (!token_is(b, e, "ply") && !token_is(b, e, "PLY")) fail(c, "not a PLY file (no 'ply' line)");
  size_t p = nl ? (size_t)(nl - d) + 1 : n;
  tok kw, type, version;
  if (!header_token(d, n, &p, &kw) || !tok_is(kw, "format") || !header_token(d, n, &p, &type) ||
      !header_token(d, n, &p, &version))
    fail(c, "PLY header: the second line must be 'format <type> 1.0'");
  float ver;
  if (!float_token(version.b, version.e, &ver)) fail(c, "PLY header: bad format version %s", Q(version.b, version.e));
  if (tok_is(type, "binary_little_endian") || tok_is(type, "binary_big_endian")) {
    s->binary = 1;
    s->big_endian = tok_is(type, "binary_big_endian");
  } else if (!tok_is(type, "ascii")) {
    fail(c, "PLY header: unknown format '%.*s'", TOK(type));
  }
  size_t last = p; /* OpenMesh's streamPos: end of the last header item */
  int end = 0;
  while (header_token(d, n, &p, &kw)) {
    if (tok_is(kw, "end_header")) {
      end = 1;
      break;
    }
    if (tok_is(kw, "comment")) {
      while (p < n && d[p] != '\n') p++;
      if (p < n) p++;
    } else if (tok_is(kw, "element")) {
      ply_elem el = {.name = {d, d}};
      tok count = {d, d};
      long long cnt;
      if (!header_token(d, n, &p, &el.name) || !header_token(d, n, &p, &count) ||
          !int_token(count.b, count.e, &cnt) || cnt < 0 || count.b[0] == '+' || count.b[0] == '-')
        fail(c, "PLY header: element %.*s needs a count", TOK(el.name));
      if (cnt > MAX_ELEMENTS) fail(c, "PLY header: element %.*s: count %lld too large", TOK(el.name), cnt);
      el.count = cnt;
      for (size_t i = 0; i < c->num_elems; i++)
        if ((tok_is(el.name, "vertex") || tok_is(el.name, "face")) && tok_eq(c->elems[i].name, el.name))
          fail(c, "PLY header: element %.*s declared twice", TOK(el.name));
      reserve(c, (void **)&c->elems, &c->cap_elems, c->num_elems + 1, sizeof *c->elems);
      c->elems[c->num_elems++] = el;
    } else if (tok_is(kw, "property")) {
      if (c->num_elems == 0) fail(c, "PLY header: property before the first element");
      ply_elem *el = &c->elems[c->num_elems - 1];
      ply_prop pr = {.type = P_BAD, .count_type = P_BAD, .role = R_CUSTOM};
      pr.name = (tok){d, d};
      tok t1, t2, t3;
      if (!header_token(d, n, &p, &t1)) fail(c, "PLY header: incomplete property");
      if (tok_is(t1, "list")) {
        if (!header_token(d, n, &p, &t2) || !header_token(d, n, &p, &t3) || !header_token(d, n, &p, &pr.name))
          fail(c, "PLY header: incomplete list property");
        if (!tok_is(t2, "uint8") && !tok_is(t2, "uchar") && !tok_is(t2, "uint16") && !tok_is(t2, "int"))
          fail(c,
               "PLY header: list count type '%.*s' of %.*s is not supported by OpenMesh (uchar, "
               "uint8, uint16 or int)",
               TOK(t2), TOK(pr.name));
        pr.list = 1;
        pr.count_type = ply_type_of(t2);
        pr.type = ply_type_of(t3);
        if (pr.type == P_BAD) fail(c, "PLY header: unknown type '%.*s' of %.*s", TOK(t3), TOK(pr.name));
        if (tok_is(el->name, "face") && (tok_is(pr.name, "vertex_indices") || tok_is(pr.name, "vertex_index"))) {
          pr.role = R_INDICES;
          if (ply_float(pr.type)) fail(c, "PLY header: vertex_indices must be integers, not '%.*s'", TOK(t3));
        } else if (tok_is(el->name, "face") && tok_is(pr.name, "texcoord")) {
          if (!ply_float(pr.type)) fail(c, "PLY header: texcoord must be float or double, not '%.*s'", TOK(t3));
          pr.role = R_FACE_TEX;
          s->face_tex = 1;
        }
      } else {
        if (!header_token(d, n, &p, &t2)) fail(c, "PLY header: incomplete property '%.*s'", TOK(t1));
        /* OpenMesh accepts "type name" and "name type". */
        if (ply_type_of(t1) != P_BAD && ply_type_of(t2) == P_BAD) {
          pr.type = ply_type_of(t1);
          pr.name = t2;
        } else if (ply_type_of(t2) != P_BAD && ply_type_of(t1) == P_BAD) {
          pr.type = ply_type_of(t2);
          pr.name = t1;
        } else {
          fail(c, "PLY header: cannot read property '%.*s %.*s'", TOK(t1), TOK(t2));
        }
        if (tok_is(el->name, "vertex")) {
          pr.role = ply_vertex_role(pr.name);
          if (tok_is(pr.name, "texture_u") || tok_is(pr.name, "texture_v")) s->texture_uv_names = 1;
        } else if (tok_is(el->name, "face")) {
          if (tok_is(pr.name, "red") || tok_is(pr.name, "green") || tok_is(pr.name, "blue") ||
              tok_is(pr.name, "alpha"))
            pr.role = R_COLOR;
        }
      }
      reserve(c, (void **)&el->props, &el->cap_props, el->num_props + 1, sizeof *el->props);
      el->props[el->num_props++] = pr;
    }
    /* Other keywords (obj_info...) are skipped token by token, like OpenMesh. */
    last = p;
  }
  if (!end) fail(c, "PLY header: no end_header");
  if (!s->binary) return p;
  /* OpenMesh seeks to `last` and skips 12 bytes ("\nend_header\n"), or 14
   * after "\r\n": anything else between the last item and the data (a
   * comment line, trailing blanks) makes it read from the wrong offset. */
  size_t om = last + ((last + 1 < n && d[last] == '\r' && d[last + 1] == '\n') ? 14 : 12);
  size_t real = p;
  if (real < n && d[real] == '\n')
    real += 1;
  else if (real + 1 < n && d[real] == '\r' && d[real + 1] == '\n')
    real += 2;
  else
    fail(c, "PLY header: end_header must end its line");
  if (om != real)
    fail(c,
         "PLY header: OpenMesh misplaces binary data after a comment or trailing blanks "
         "right before end_header; remove them");
  return real;
}

/* Checks what OpenMesh will do with the elements it reads (those up to the
 * face element), fills the counts and returns how many it reads. */
static size_t ply_check_elements(ctx *c) {
  ch_mesh_scan *s = c->s;
  size_t nread = c->num_elems;
  int vertex = -1, face = -1;
  for (size_t i = 0; i < c->num_elems; i++) {
    if (tok_is(c->elems[i].name, "vertex")) vertex = (int)i;
    if (tok_is(c->elems[i].name, "face")) {
      face = (int)i;
      nread = i + 1; /* OpenMesh stops after the faces */
      break;
    }
  }
  if (face >= 0 && vertex < 0) {
    for (size_t i = (size_t)face + 1; i < c->num_elems; i++)
      if (tok_is(c->elems[i].name, "vertex"))
        fail(c, "PLY: the face element comes before the vertex element (OpenMesh stops after faces)");
  }
  if (vertex < 0) fail(c, "PLY: no vertex element");
  for (size_t i = 0; i < nread; i++) {
    const ply_elem *el = &c->elems[i];
    int xyz[3] = {0, 0, 0}, indices = 0;
    for (size_t k = 0; k < el->num_props; k++) {
      const ply_prop *pr = &el->props[k];
      if (pr->list && pr->role != R_INDICES && pr->role != R_FACE_TEX)
        fail(c,
             "PLY: list property '%.*s' of element %.*s is not supported (OpenMesh misreads it); "
             "store texture coordinates as per-vertex u, v",
             TOK(pr->name), TOK(el->name));
      if (pr->role == R_INDICES) indices++;
      if (pr->role == R_FACE_TEX && (int)i != face) fail(c, "PLY: texcoord list outside the face element");
      if (pr->role == R_COORD) xyz[pr->name.b[0] - 'x']++;
      if (s->binary && (pr->role == R_COORD || pr->role == R_NORMAL || pr->role == R_TEX) && !ply_float(pr->type))
        fail(c, "PLY: vertex property '%.*s' must be float or double in binary PLY", TOK(pr->name));
      if (s->binary && pr->role == R_COLOR && pr->type == P_F64)
        fail(c, "PLY: colour property '%.*s' of type double is not supported by OpenMesh", TOK(pr->name));
    }
    if ((int)i == vertex && (xyz[0] != 1 || xyz[1] != 1 || xyz[2] != 1))
      fail(c, "PLY: the vertex element needs exactly one x, y and z property");
    if ((int)i == face && indices != 1) fail(c, "PLY: the face element needs one vertex_indices list");
  }
  s->num_vertices = vertex >= 0 ? c->elems[vertex].count : 0;
  s->num_faces = face >= 0 ? c->elems[face].count : 0;
  return nread;
}

static long long ply_binary_value(const unsigned char *q, ply_type t, int big) {
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

static void ply_face_corner(ctx *c, long long idx, long long nv, long long face) {
  if (idx < 0 || idx >= nv) fail(c, "face %lld: vertex index %lld out of range (0..%lld)", face, idx, nv - 1);
}

static void face_count(ctx *c, long long count, long long face) {
  if (count < 3) fail(c, "face %lld: %lld corners, a face needs at least 3", face, count);
}

static _Noreturn void ply_truncated(ctx *c, const ply_elem *el, long long i) {
  fail(c, "%.*s %lld of %lld: data ends here (file truncated?)", TOK(el->name), i, el->count);
}

static double ply_binary_float(const unsigned char *q, ply_type t, int big) {
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

static void push_tex(ctx *c, float v) {
  ch_mesh_scan *s = c->s;
  reserve(c, (void **)&s->tex, &c->cap_tex, s->num_tex + 1, sizeof *s->tex);
  s->tex[s->num_tex++] = v;
}

static void push_tex_first(ctx *c, int v) {
  ch_mesh_scan *s = c->s;
  reserve(c, (void **)&s->tex_first, &c->cap_tex_first, s->num_tex_first + 1, sizeof *s->tex_first);
  s->tex_first[s->num_tex_first++] = v;
}

static void append(ctx *c, const char *b, size_t len) {
  ch_mesh_scan *s = c->s;
  reserve(c, (void **)&s->stripped, &c->cap_stripped, s->stripped_size + len + 1, 1);
  memcpy(s->stripped + s->stripped_size, b, len);
  s->stripped_size += len;
  s->stripped[s->stripped_size] = '\0';
}

/* A face's texcoord list: 2 finite values per corner of the face. */
static void ply_face_tex(ctx *c, long long count, long long corners, long long face) {
  ch_mesh_scan *s = c->s;
  if (count != 2 * corners)
    fail(c, "face %lld: %lld texcoord values for %lld corners (want 2 per corner)", face, count, corners);
  for (long long k = (long long)s->num_tex - count; k < (long long)s->num_tex; k++)
    if (!isfinite(s->tex[k])) fail(c, "face %lld: texcoord is not a finite number", face);
}

/* The header without the texcoord property line (the stripped copy's). */
static void ply_header_without_tex(ctx *c, const char *d, size_t data) {
  size_t p = 0;
  while (p < data) {
    const char *nl = memchr(d + p, '\n', data - p);
    size_t end = nl ? (size_t)(nl - d) + 1 : data;
    const char *b = d + p, *e = d + end;
    if (!(contains(b, e, "property") && contains(b, e, " texcoord") && contains(b, e, "list"))) append(c, b, end - p);
    p = end;
  }
  /* ASCII data starts after the token */
  if (c->s->stripped_size == 0 || c->s->stripped[c->s->stripped_size - 1] != '\n') append(c, "\n", 1);
}

static void ply_walk_binary(ctx *c, const char *d, size_t n, size_t data, size_t nread) {
  ch_mesh_scan *s = c->s;
  size_t p = data;
  const unsigned char *u = (const unsigned char *)d;
  if (s->face_tex) ply_header_without_tex(c, d, data);
  for (size_t ei = 0; ei < nread; ei++) {
    const ply_elem *el = &c->elems[ei];
    for (long long i = 0; i < el->count; i++) {
      long long corners = 0;
      for (size_t k = 0; k < el->num_props; k++) {
        const ply_prop *pr = &el->props[k];
        size_t at = p;
        if (!pr->list) {
          if (n - p < (size_t)ply_size(pr->type)) ply_truncated(c, el, i);
          p += (size_t)ply_size(pr->type);
          if (s->face_tex) append(c, d + at, p - at);
          continue;
        }
        if (n - p < (size_t)ply_size(pr->count_type)) ply_truncated(c, el, i);
        long long count = ply_binary_value(u + p, pr->count_type, s->big_endian);
        p += (size_t)ply_size(pr->count_type);
        size_t size = (size_t)ply_size(pr->type);
        if (pr->role == R_FACE_TEX) {
          if (count < 0 || (unsigned long long)count > (n - p) / size) ply_truncated(c, el, i);
          for (long long j = 0; j < count; j++, p += size)
            push_tex(c, (float)ply_binary_float(u + p, pr->type, s->big_endian));
          ply_face_tex(c, count, corners, i);
          continue;
        }
        face_count(c, count, i);
        corners = count;
        if (s->face_tex && (unsigned long long)count <= (n - p) / size)
          push_tex_first(c, (int)(unsigned)(ply_binary_value(u + p, pr->type, s->big_endian) & 0xffffffffLL));
        if ((unsigned long long)count > (n - p) / size) ply_truncated(c, el, i);
        for (long long j = 0; j < count; j++) {
          long long idx = ply_binary_value(u + p, pr->type, s->big_endian);
          /* OpenMesh reads into unsigned int, then makes an int handle. */
          ply_face_corner(c, (int)(unsigned)(idx & 0xffffffffLL), s->num_vertices, i);
          p += size;
        }
        if (s->face_tex) append(c, d + at, p - at);
        s->num_corners += count;
        if (s->num_corners > MAX_ELEMENTS) fail(c, "too many face corners (limit %lld)", MAX_ELEMENTS);
      }
    }
  }
}

static void ply_walk_ascii(ctx *c, const char *d, size_t n, size_t data, size_t nread) {
  ch_mesh_scan *s = c->s;
  tokens t = {d + data, d + n};
  const char *tb, *te;
  if (s->face_tex) ply_header_without_tex(c, d, data);
  for (size_t ei = 0; ei < nread; ei++) {
    const ply_elem *el = &c->elems[ei];
    /* OpenMesh gives up when the last token ended exactly at end of file. */
    if (t.p == d + n) fail(c, "element %.*s: data ends before it (file truncated?)", TOK(el->name));
    for (long long i = 0; i < el->count; i++) {
      long long corners = 0;
      for (size_t k = 0; k < el->num_props; k++) {
        const ply_prop *pr = &el->props[k];
        if (!next_token(&t, &tb, &te)) ply_truncated(c, el, i);
        float f;
        long long v;
        const char *at = tb;
        if (pr->role == R_FACE_TEX) {
          if (!int_token(tb, te, &v) || *tb == '-' || *tb == '+')
            fail(c, "face %lld: bad texcoord count %s", i, Q(tb, te));
          for (long long j = 0; j < v; j++) {
            if (!next_token(&t, &tb, &te)) ply_truncated(c, el, i);
            if (!float_token(tb, te, &f)) fail(c, "face %lld: texcoord %s is not a finite number", i, Q(tb, te));
            push_tex(c, f);
          }
          ply_face_tex(c, v, corners, i);
          continue;
        }
        if (pr->role == R_INDICES) {
          if (!int_token(tb, te, &v) || *tb == '-' || *tb == '+')
            fail(c, "face %lld: bad corner count %s", i, Q(tb, te));
          face_count(c, v, i);
          corners = v;
          for (long long j = 0; j < v; j++) {
            long long idx;
            if (!next_token(&t, &tb, &te)) ply_truncated(c, el, i);
            if (!int_token(tb, te, &idx) || *tb == '+') fail(c, "face %lld: bad vertex index %s", i, Q(tb, te));
            ply_face_corner(c, idx, s->num_vertices, i);
            if (s->face_tex && j == 0) push_tex_first(c, (int)idx);
          }
          s->num_corners += v;
          if (s->num_corners > MAX_ELEMENTS) fail(c, "too many face corners (limit %lld)", MAX_ELEMENTS);
        } else if (pr->role == R_COORD || pr->role == R_NORMAL || pr->role == R_TEX ||
                   (pr->role == R_COLOR && ply_float(pr->type))) {
          if (!float_token(tb, te, &f))
            fail(c, "%.*s %lld: property %.*s: %s is not a finite number", TOK(el->name), i, TOK(pr->name),
                 Q(tb, te));
        } else if (pr->role == R_COLOR) {
          if (!int_token(tb, te, &v))
            fail(c, "%.*s %lld: property %.*s: %s is not an integer", TOK(el->name), i, TOK(pr->name), Q(tb, te));
        }
        if (s->face_tex) {
          if (k != 0 && s->stripped_size > 0 && s->stripped[s->stripped_size - 1] != '\n') append(c, " ", 1);
          append(c, at, (size_t)(t.p - at));
        }
      }
      if (s->face_tex) append(c, "\n", 1);
    }
  }
}

static void scan_ply(ctx *c, const char *d, size_t n) {
  size_t data = ply_header(c, d, n);
  size_t nread = ply_check_elements(c);
  if (c->s->binary)
    ply_walk_binary(c, d, n, data, nread);
  else
    ply_walk_ascii(c, d, n, data, nread);
}

/* ---- OFF: ASCII "[ST][N]OFF", one vertex or face per line -------------- */

static void scan_off(ctx *c, const char *d, size_t n) {
  ch_mesh_scan *s = c->s;
  if (memchr(d, '\0', n)) fail(c, "not a text OFF file (contains NUL bytes)");
  int st = 0, normals = 0;
  int state = 0; /* 0 header, 1 counts, 2 vertices, 3 faces, 4 done */
  long long done = 0;
  size_t start = 0, line = 0;
  while (start < n && state != 4) {
    const char *nl = memchr(d + start, '\n', n - start);
    size_t end = nl ? (size_t)(nl - d) : n;
    const char *b = d + start, *e = d + end;
    start = end + 1;
    line++;
    tokens t = {b, e};
    const char *tb, *te;
    if (state == 0) {
      while (e > b && is_space(e[-1])) e--;
      if (token_is(b, e, "OFF") || token_is(b, e, "NOFF") || token_is(b, e, "STOFF") || token_is(b, e, "STNOFF")) {
        st = e - b >= 2 && memcmp(b, "ST", 2) == 0;
        normals = memchr(b, 'N', (size_t)(e - b)) != NULL;
        state = 1;
        continue;
      }
      if (!contains(b, e, "OFF")) fail(c, "not an OFF file (the first line must be OFF)");
      if (contains(b, e, "BINARY")) fail(c, "binary OFF is not supported (OpenMesh reads it little-endian)");
      fail(c,
           "OFF header %s is not supported (OFF, NOFF, STOFF or STNOFF, nothing else on the "
           "line)",
           Q(b, e));
    }
    if (!next_token(&t, &tb, &te)) continue; /* blank line: operator>> skips it */
    if (*tb == '#') fail(c, "line %zu: OpenMesh's OFF reader does not accept comments", line);
    if (state == 1) {
      long long cnt[3];
      for (int k = 0; k < 3; k++) {
        if (k > 0 && !next_token(&t, &tb, &te)) fail(c, "line %zu: needs three counts (vertices faces edges)", line);
        if (!int_token(tb, te, &cnt[k]) || cnt[k] < 0) fail(c, "line %zu: bad count %s", line, Q(tb, te));
      }
      if (next_token(&t, &tb, &te)) fail(c, "line %zu: needs exactly three counts", line);
      if (cnt[0] > MAX_ELEMENTS || cnt[1] > MAX_ELEMENTS)
        fail(c, "line %zu: counts too large (limit %lld)", line, MAX_ELEMENTS);
      s->num_vertices = cnt[0];
      s->num_faces = cnt[1];
      done = 0;
      state = s->num_vertices > 0 ? 2 : (s->num_faces > 0 ? 3 : 4);
      continue;
    }
    if (state == 2) {
      int need = 3 + (normals ? 3 : 0) + (st ? 2 : 0);
      for (int k = 0; k < need; k++) {
        float f;
        if (k > 0 && !next_token(&t, &tb, &te))
          fail(c, "vertex %lld (line %zu): needs %d numbers on its line", done, line, need);
        if (!float_token(tb, te, &f)) fail(c, "vertex %lld (line %zu): %s is not a finite number", done, line, Q(tb, te));
      }
      if (++done == s->num_vertices) {
        done = 0;
        state = s->num_faces > 0 ? 3 : 4;
      }
      continue;
    }
    long long count, idx;
    if (!int_token(tb, te, &count) || count < 0)
      fail(c, "face %lld (line %zu): bad corner count %s", done, line, Q(tb, te));
    face_count(c, count, done);
    for (long long k = 0; k < count; k++) {
      if (!next_token(&t, &tb, &te)) fail(c, "face %lld (line %zu): fewer than %lld indices", done, line, count);
      if (!int_token(tb, te, &idx)) fail(c, "face %lld (line %zu): bad index %s", done, line, Q(tb, te));
      if (idx < 0 || idx >= s->num_vertices)
        fail(c, "face %lld (line %zu): vertex index %lld out of range (0..%lld)", done, line, idx,
             s->num_vertices - 1);
    }
    if (next_token(&t, &tb, &te))
      fail(c,
           "face %lld (line %zu): values after the %lld indices (face colours need COFF, "
           "which is not supported)",
           done, line, count);
    s->num_corners += count;
    if (s->num_corners > MAX_ELEMENTS) fail(c, "too many face corners (limit %lld)", MAX_ELEMENTS);
    if (++done == s->num_faces) state = 4;
  }
  if (state == 0) fail(c, "empty OFF file");
  if (state == 1) fail(c, "no counts line (file truncated?)");
  if (state == 2) fail(c, "vertex %lld of %lld: data ends here (file truncated?)", done, s->num_vertices);
  if (state == 3) fail(c, "face %lld of %lld: data ends here (file truncated?)", done, s->num_faces);
}

/* ---- STL ------------------------------------------------------------------ */

static void scan_stl(ctx *c, const char *d, size_t n) {
  ch_mesh_scan *s = c->s;
  if (n >= 84) {
    const unsigned char *u = (const unsigned char *)d;
    uint32_t nt = (uint32_t)u[80] | (uint32_t)u[81] << 8 | (uint32_t)u[82] << 16 | (uint32_t)u[83] << 24;
    /* OpenMesh's own test: the size matches the triangle count. */
    if (84 + 50 * (uint64_t)nt == n) {
      s->binary = 1;
      s->triangles = nt;
      if (s->triangles > MAX_ELEMENTS / 3) fail(c, "too many triangles (%lld)", s->triangles);
      for (uint32_t i = 0; i < nt; i++) {
        for (int k = 3; k < 12; k++) {
          float f;
          memcpy(&f, d + 84 + 50 * (size_t)i + 4 * k, 4); /* little-endian hosts only */
          if (!isfinite(f)) fail(c, "triangle %u: vertex %d has a coordinate that is not finite", i, k / 3 - 1);
        }
      }
      return;
    }
  }
  if (memchr(d, '\0', n)) fail(c, "neither ASCII STL nor binary STL (size does not match the triangle count)");
  /* ASCII: OpenMesh reads the three lines after every line containing
   * "outer" as "vertex x y z". */
  int pending = 0;
  long long facet = 0;
  size_t at = 0, line = 0;
  const char *b, *e;
  while (next_line(d, n, &at, &b, &e)) {
    line++;
    if (pending > 0) {
      tokens t = {b, e};
      const char *tb, *te;
      float f;
      int ok = next_token(&t, &tb, &te);
      for (int k = 0; ok && k < 3; k++) ok = next_token(&t, &tb, &te) && float_token(tb, te, &f);
      if (!ok) fail(c, "facet %lld (line %zu): expected 'vertex x y z' with finite numbers", facet, line);
      pending--;
      continue;
    }
    if (contains(b, e, "outer") || contains(b, e, "OUTER")) {
      pending = 3;
      facet = s->triangles++;
      if (s->triangles > MAX_ELEMENTS / 3) fail(c, "too many triangles");
    }
  }
  if (pending > 0) fail(c, "facet %lld: data ends inside it (file truncated?)", facet);
}

/* ---- entry points ----------------------------------------------------- */

void ch_mesh_scan_free(ch_mesh_scan *scan) {
  if (!scan) return;
  free(scan->mtllib_at);
  free(scan->tex);
  free(scan->tex_first);
  free(scan->stripped);
  free(scan->obj_pos);
  free(scan->obj_tex);
  free(scan->obj_normal);
  free(scan->obj_face_start);
  free(scan->obj_corner_pos);
  free(scan->obj_corner_tex);
  free(scan->obj_corner_normal);
  memset(scan, 0, sizeof *scan);
}

typedef void (*scanner)(ctx *c, const char *d, size_t n);

static ch_status run(scanner fn, int keep, const char *d, size_t n, ch_mesh_scan *out, ch_error *err) {
  memset(out, 0, sizeof *out);
  ctx *c = calloc(1, sizeof *c);
  if (!c) return ch_error_set(err, CH_ERR_NOMEM, "out of memory");
  c->s = out;
  c->keep = keep;
  ch_status st = CH_OK;
  if (setjmp(c->jump) == 0) {
    fn(c, d, n);
  } else {
    st = ch_error_set(err, c->status, "%s", c->message);
  }
  free(c->positions);
  free(c->pairs);
  for (size_t i = 0; i < c->num_elems; i++) free(c->elems[i].props);
  free(c->elems);
  free(c);
  return st;
}

ch_status ch_mesh_scan_obj(const char *d, size_t n, ch_mesh_scan *out, ch_error *err) {
  return run(scan_obj, 0, d, n, out, err);
}

ch_status ch_mesh_scan_obj_values(const char *d, size_t n, ch_mesh_scan *out, ch_error *err) {
  return run(scan_obj, 1, d, n, out, err);
}

ch_status ch_mesh_scan_ply(const char *d, size_t n, ch_mesh_scan *out, ch_error *err) {
  return run(scan_ply, 0, d, n, out, err);
}

ch_status ch_mesh_scan_off(const char *d, size_t n, ch_mesh_scan *out, ch_error *err) {
  return run(scan_off, 0, d, n, out, err);
}

ch_status ch_mesh_scan_stl(const char *d, size_t n, ch_mesh_scan *out, ch_error *err) {
  return run(scan_stl, 0, d, n, out, err);
}
