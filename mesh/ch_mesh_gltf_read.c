/* ch_mesh_gltf_read.c: glTF 2.0 base meshes, binary (.glb) or JSON (.gltf
 * with its buffers in .bin files beside it or in data: URIs), read from the
 * Khronos glTF 2.0 specification (§3.6 buffers, buffer views and accessors,
 * §3.7 meshes, §3.5 nodes and hierarchy, §4.4 the GLB container).
 *
 * What a base mesh needs of a scene: the triangles of every mesh its
 * default scene's nodes place, in world space (node matrices, or
 * translation, rotation and scale, composed down the hierarchy; winding
 * reversed where a transform mirrors, §3.7.2.1), with TEXCOORD_0 as UVs
 * (v flipped back: glTF's runs down, chisel's up) and NORMAL where every
 * primitive has one. Triangle strips and fans become triangles; points and
 * lines are left out. Any component type is read, normalised or not, so
 * KHR_mesh_quantization files work; sparse accessors are applied.
 *
 * glTF splits vertices wherever an attribute differs (a UV seam, a
 * crease), and one point then appears as several vertices at the same
 * coordinates. Those are welded back into one position (equal values after
 * the node's transform), as chisel's base surface needs one normal per
 * position to displace without cracks (docs/spec.md §1); UVs and normals
 * are likewise kept once per distinct value, and UVs a few float roundings
 * apart at one position once (ch_mesh_merge_near_uvs).
 *
 * Every offset and count is checked against what it points into before
 * any byte is read; errors name the file and the element. */
#include <cjson/cJSON.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ch_file.h"
#include "ch_mesh.h"
#include "ch_mesh_gltf_internal.h"
#include "ch_mesh_values_internal.h"

enum { MAX_DEPTH = 256, MAX_ZEROS = 1 << 20, CHUNK_JSON = 0x4E4F534A, CHUNK_BIN = 0x004E4942, GLB_MAGIC = 0x46546C67 };

typedef struct gltf_reader {
  const char *name, *path; /* path NULL: no files beside it (from memory) */
  ch_error *err;
  ch_status status; /* the first failure's */
  cJSON *root;
  const cJSON *accessors, *views, *meshes, *nodes;
  /* their items by index (cJSON's arrays are lists) and counts */
  const cJSON **accessor, **view, **mesh, **node;
  int num_accessors, num_views, num_meshes, num_nodes;
  int num_buffers;
  const cJSON *buffers_json;
  const unsigned char **buffer; /* per buffer its bytes (NULL until a view needs them), and their count */
  size_t *buffer_size;
  char **owned; /* per buffer what was read or decoded for it */
  const unsigned char *bin;
  size_t bin_size;
  int has_bin;
  unsigned char *visited; /* per node: placed once (nodes form trees, §3.5.1) */
  /* the mesh being built */
  ch_value_set positions, uvs, normals;
  int *corners; /* 3 per triangle: position, uv, normal indices */
  size_t num_triangles, cap_triangles;
  int want_uvs, want_normals; /* -1 until the first primitive decides */
  long dropped, left_out;
} gltf_reader;

static int fail(gltf_reader *r, ch_status status, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static int fail(gltf_reader *r, ch_status status, const char *fmt, ...) {
  char text[400];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(text, sizeof text, fmt, ap);
  va_end(ap);
  ch_error_set(r->err, status, "%s: %s", r->name, text);
  r->status = status;
  return -1;
}

static int nomem(gltf_reader *r) { return fail(r, CH_ERR_NOMEM, "out of memory"); }

/* ---- JSON values -------------------------------------------------------- */

/* obj[key] as an index below limit: 1 if present and valid, 0 if absent
 * (and not required), -1 after an error. */
static int get_index(gltf_reader *r, const cJSON *obj, const char *key, int limit, int required, const char *what,
                     int *out) {
  const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
  if (!v) {
    if (required) return fail(r, CH_ERR_INPUT, "%s has no '%s'", what, key);
    return 0;
  }
  double x = cJSON_IsNumber(v) ? v->valuedouble : -1.0;
  if (!(x >= 0.0 && x < (double)limit && x == floor(x)))
    return fail(r, CH_ERR_INPUT, "%s: '%s' is not an index below %d", what, key, limit);
  *out = (int)x;
  return 1;
}

/* obj[key] as a whole number in [0, limit] (def where absent). */
static int get_size(gltf_reader *r, const cJSON *obj, const char *key, double limit, int required, size_t def,
                    const char *what, size_t *out) {
  const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
  *out = def;
  if (!v) return required ? fail(r, CH_ERR_INPUT, "%s has no '%s'", what, key) : 0;
  double x = cJSON_IsNumber(v) ? v->valuedouble : -1.0;
  if (!(x >= 0.0 && x <= limit && x == floor(x)))
    return fail(r, CH_ERR_INPUT, "%s: '%s' is not a whole number up to %.0f", what, key, limit);
  *out = (size_t)x;
  return 0;
}

/* n numbers of array obj[key] into out (left as they are where absent). */
static int get_numbers(gltf_reader *r, const cJSON *obj, const char *key, int n, const char *what, double *out) {
  const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
  if (!v) return 0;
  if (!cJSON_IsArray(v) || cJSON_GetArraySize(v) != n)
    return fail(r, CH_ERR_INPUT, "%s: '%s' is not an array of %d numbers", what, key, n);
  int i = 0;
  for (const cJSON *e = v->child; e; e = e->next, i++) {
    if (!cJSON_IsNumber(e) || !isfinite(e->valuedouble))
      return fail(r, CH_ERR_INPUT, "%s: '%s' holds something other than a finite number", what, key);
    out[i] = e->valuedouble;
  }
  return 0;
}

/* obj[key] if it is an array (NULL if absent); an error if it is not. */
static int get_array(gltf_reader *r, const cJSON *obj, const char *key, const cJSON **out) {
  const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
  *out = NULL;
  if (!v) return 0;
  if (!cJSON_IsArray(v)) return fail(r, CH_ERR_INPUT, "'%s' is not an array", key);
  *out = v;
  return 0;
}

/* The items of array (NULL: none) by index, into a new table. */
static int items(gltf_reader *r, const cJSON *array, const cJSON ***out, int *count) {
  *count = array ? cJSON_GetArraySize(array) : 0;
  *out = NULL;
  if (!*count) return 0;
  if (!(*out = malloc((size_t)*count * sizeof **out))) return nomem(r);
  int i = 0;
  for (const cJSON *e = array->child; e; e = e->next) (*out)[i++] = e;
  return 0;
}

/* ---- buffers ------------------------------------------------------------- */

static int base64_value(unsigned char c) {
  if (c >= 'A' && c <= 'Z') return c - 'A';
  if (c >= 'a' && c <= 'z') return c - 'a' + 26;
  if (c >= '0' && c <= '9') return c - '0' + 52;
  if (c == '+' || c == '-') return 62;
  if (c == '/' || c == '_') return 63;
  return -1;
}

/* Decodes base64 text (up to '=' or its end) into a new buffer. */
static int base64_decode(const char *text, char **out, size_t *size) {
  size_t n = strlen(text);
  char *o = malloc(n / 4 * 3 + 3);
  if (!o) return -1;
  size_t k = 0;
  uint32_t acc = 0;
  int bits = 0;
  for (size_t i = 0; i < n && text[i] != '='; i++) {
    int v = base64_value((unsigned char)text[i]);
    if (v < 0) {
      free(o);
      return 1;
    }
    acc = (acc << 6) | (uint32_t)v;
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      o[k++] = (char)(acc >> bits);
    }
  }
  *out = o;
  *size = k;
  return 0;
}

static int hex_digit(char c) {
  return c >= '0' && c <= '9'   ? c - '0'
         : c >= 'a' && c <= 'f' ? c - 'a' + 10
         : c >= 'A' && c <= 'F' ? c - 'A' + 10
                                : -1;
}

/* A relative URI's path with its %XX decoded (RFC 3986); NULL where it
 * has a scheme, is absolute or malformed, or without memory. */
static char *uri_path(const char *uri) {
  if (!uri[0] || uri[0] == '/' || strchr(uri, ':') || strchr(uri, '\\')) return NULL;
  size_t n = strlen(uri);
  char *p = malloc(n + 1), *o = p;
  if (!p) return NULL;
  for (size_t i = 0; i < n; i++) {
    if (uri[i] != '%') {
      *o++ = uri[i];
      continue;
    }
    int hi = i + 2 < n ? hex_digit(uri[i + 1]) : -1, lo = i + 2 < n ? hex_digit(uri[i + 2]) : -1;
    if (hi < 0 || lo < 0 || (hi == 0 && lo == 0)) {
      free(p);
      return NULL;
    }
    *o++ = (char)(hi * 16 + lo);
    i += 2;
  }
  *o = 0;
  return p;
}

/* The tables for the buffers, read only when a view needs them (a
 * missing file that no mesh uses, such as images' own buffer, is no
 * error). */
static int init_buffers(gltf_reader *r) {
  if (get_array(r, r->root, "buffers", &r->buffers_json)) return -1;
  r->num_buffers = r->buffers_json ? cJSON_GetArraySize(r->buffers_json) : 0;
  if (r->num_buffers == 0) return 0;
  r->buffer = calloc((size_t)r->num_buffers, sizeof *r->buffer);
  r->buffer_size = calloc((size_t)r->num_buffers, sizeof *r->buffer_size);
  r->owned = calloc((size_t)r->num_buffers, sizeof *r->owned);
  if (!r->buffer || !r->buffer_size || !r->owned) return nomem(r);
  return 0;
}

/* Buffer i's bytes: the GLB's BIN chunk, a data: URI decoded, or a file
 * beside the .gltf. */
static int load_buffer(gltf_reader *r, int i) {
  if (r->buffer[i]) return 0;
  const cJSON *b = cJSON_GetArrayItem(r->buffers_json, i);
  char what[48];
  snprintf(what, sizeof what, "buffer %d", i);
  size_t length;
  if (get_size(r, b, "byteLength", 9007199254740991.0, 1, 0, what, &length)) return -1;
  const cJSON *uri = cJSON_GetObjectItemCaseSensitive(b, "uri");
  const unsigned char *bytes = NULL;
  size_t have = 0;
  static const unsigned char none = 0;
  if (!uri) {
    if (i != 0 || !r->has_bin) return fail(r, CH_ERR_INPUT, "%s has no 'uri' and is not the GLB's BIN chunk", what);
    bytes = r->bin_size ? r->bin : &none;
    have = r->bin_size;
  } else if (!cJSON_IsString(uri)) {
    return fail(r, CH_ERR_INPUT, "%s: 'uri' is not a string", what);
  } else if (!strncmp(uri->valuestring, "data:", 5)) {
    const char *comma = strstr(uri->valuestring, ";base64,");
    if (!comma) return fail(r, CH_ERR_INPUT, "%s: a data: URI that is not base64", what);
    int st = base64_decode(comma + 8, &r->owned[i], &have);
    if (st < 0) return nomem(r);
    if (st > 0) return fail(r, CH_ERR_INPUT, "%s: the data: URI's base64 has a character outside base64", what);
    bytes = (const unsigned char *)r->owned[i];
  } else {
    char *rel = uri_path(uri->valuestring);
    if (!rel)
      return fail(r, CH_ERR_INPUT, "%s: uri '%.80s' is not a relative path to a file beside the .gltf", what,
                  uri->valuestring);
    if (!r->path) {
      free(rel);
      return fail(r, CH_ERR_INPUT, "%s: uri '%.80s' names a file, which a glTF read from memory cannot have", what,
                  uri->valuestring);
    }
    char *path = ch_path_beside(r->path, rel);
    free(rel);
    if (!path) return nomem(r);
    ch_error file_err = {0};
    ch_status st = ch_file_read_all(path, (size_t)1 << 31, &r->owned[i], &have, &file_err);
    free(path);
    if (st) return fail(r, st, "%s: %s", what, file_err.message); /* (it names the file and the problem) */
    bytes = (const unsigned char *)r->owned[i];
  }
  if (have < length)
    return fail(r, CH_ERR_INPUT, "%s: byteLength is %zu, but its data has %zu bytes", what, length, have);
  r->buffer[i] = bytes;
  r->buffer_size[i] = length;
  return 0;
}

/* ---- accessors ----------------------------------------------------------- */

static int component_size(int type) {
  switch (type) {
    case 5120:
    case 5121:
      return 1; /* BYTE, UNSIGNED_BYTE */
    case 5122:
    case 5123:
      return 2; /* SHORT, UNSIGNED_SHORT */
    case 5125:
    case 5126:
      return 4; /* UNSIGNED_INT, FLOAT */
    default:
      return 0;
  }
}

/* Component of type `type` at p, normalised as §3.11 asks where `norm`. */
static double component(const unsigned char *p, int type, int norm) {
  switch (type) {
    case 5120: {
      int8_t x = (int8_t)p[0];
      return norm ? fmax(x / 127.0, -1.0) : x;
    }
    case 5121:
      return norm ? p[0] / 255.0 : p[0];
    case 5122: {
      int16_t x = (int16_t)(p[0] | p[1] << 8);
      return norm ? fmax(x / 32767.0, -1.0) : x;
    }
    case 5123: {
      unsigned x = p[0] | (unsigned)p[1] << 8;
      return norm ? x / 65535.0 : x;
    }
    case 5125:
      return (double)((uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24);
    default: {
      uint32_t u = (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
      float f;
      memcpy(&f, &u, sizeof f);
      return f;
    }
  }
}

/* The bytes of buffer view `view` at `offset` for count elements of
 * `size` bytes (its byteStride, or `size`, apart): the first element's and
 * the stride, checked to lie within the view and the view in its buffer. */
static int view_span(gltf_reader *r, int view, size_t offset, size_t count, size_t size, int vertex, const char *what,
                     const unsigned char **first, size_t *stride) {
  const cJSON *v = r->view[view];
  char vwhat[48];
  snprintf(vwhat, sizeof vwhat, "buffer view %d", view);
  int buffer;
  size_t voff, vlen, vstride;
  if (get_index(r, v, "buffer", r->num_buffers, 1, vwhat, &buffer) < 0 ||
      get_size(r, v, "byteOffset", 9007199254740991.0, 0, 0, vwhat, &voff) ||
      get_size(r, v, "byteLength", 9007199254740991.0, 1, 0, vwhat, &vlen) ||
      get_size(r, v, "byteStride", 252, 0, 0, vwhat, &vstride))
    return -1;
  if (load_buffer(r, buffer)) return -1;
  if (voff > r->buffer_size[buffer] || vlen > r->buffer_size[buffer] - voff)
    return fail(r, CH_ERR_INPUT, "%s: bytes %zu..%zu lie past buffer %d's %zu", vwhat, voff, voff + vlen, buffer,
                r->buffer_size[buffer]);
  *stride = vertex && vstride ? vstride : size;
  if (*stride < size)
    return fail(r, CH_ERR_INPUT, "%s: byteStride %zu is below its elements' %zu bytes", what, *stride, size);
  /* the last element ends at offset + stride (count - 1) + size */
  if (count > 0 && (offset > vlen || size > vlen - offset || (vlen - offset - size) / *stride < count - 1))
    return fail(r, CH_ERR_INPUT, "%s: %zu elements from byte %zu do not fit in buffer view %d's %zu bytes", what, count,
                offset, view, vlen);
  *first = r->buffer[buffer] + voff + offset;
  return 0;
}

/* Accessor `index` as count x width doubles (width its type's components,
 * which must be one of `widths`' bits: 1 << width). */
static int read_accessor(gltf_reader *r, int index, unsigned widths, int vertex, double **out, size_t *count_out,
                         int *width_out) {
  char what[48];
  snprintf(what, sizeof what, "accessor %d", index);
  const cJSON *a = r->accessor[index];
  const cJSON *type = cJSON_GetObjectItemCaseSensitive(a, "type");
  int width = 0;
  if (cJSON_IsString(type)) {
    const char *t = type->valuestring;
    width = !strcmp(t, "SCALAR") ? 1 : !strcmp(t, "VEC2") ? 2 : !strcmp(t, "VEC3") ? 3 : !strcmp(t, "VEC4") ? 4 : 0;
  }
  if (!width || !(widths >> width & 1)) return fail(r, CH_ERR_INPUT, "%s: a 'type' this attribute cannot have", what);
  size_t ctype_z, count, offset;
  if (get_size(r, a, "componentType", 6000, 1, 0, what, &ctype_z) ||
      get_size(r, a, "count", CH_MESH_MAX_ELEMENTS, 1, 0, what, &count) ||
      get_size(r, a, "byteOffset", 9007199254740991.0, 0, 0, what, &offset))
    return -1;
  int ctype = (int)ctype_z, csize = component_size(ctype);
  if (!csize) return fail(r, CH_ERR_INPUT, "%s: componentType %d is none of glTF's", what, ctype);
  if (!vertex && ctype != 5121 && ctype != 5123 && ctype != 5125)
    return fail(r, CH_ERR_INPUT, "%s: indices of componentType %d (glTF's are 5121, 5123 or 5125)", what, ctype);
  const cJSON *nv = cJSON_GetObjectItemCaseSensitive(a, "normalized");
  int norm = cJSON_IsTrue(nv);
  int view, has_view = get_index(r, a, "bufferView", r->num_views, 0, what, &view);
  if (has_view < 0) return -1;
  /* Without a view nothing in the file bounds its size (all zeros until
   * a sparse part replaces some): a cap, so a few bytes cannot ask for
   * gigabytes. */
  if (!has_view && count > MAX_ZEROS)
    return fail(r, CH_ERR_INPUT, "%s: %zu elements without a buffer view, more than chisel takes (%d)", what, count,
                MAX_ZEROS);
  double *values = malloc((count ? count : 1) * (size_t)width * sizeof *values);
  if (!values) return nomem(r);
  if (has_view) {
    const unsigned char *p;
    size_t stride;
    if (view_span(r, view, offset, count, (size_t)width * csize, vertex, what, &p, &stride)) goto bad;
    for (size_t i = 0; i < count; i++)
      for (int k = 0; k < width; k++)
        values[i * width + k] = component(p + i * stride + (size_t)k * csize, ctype, norm);
  } else {
    for (size_t i = 0; i < count * width; i++) values[i] = 0.0; /* §3.6.2.3: zeros, unless sparse */
  }
  const cJSON *sparse = cJSON_GetObjectItemCaseSensitive(a, "sparse");
  if (sparse) {
    size_t n, ioff, voff, itype_z;
    const cJSON *ind = cJSON_GetObjectItemCaseSensitive(sparse, "indices");
    const cJSON *val = cJSON_GetObjectItemCaseSensitive(sparse, "values");
    int iview, vview, nviews = r->num_views;
    if (get_size(r, sparse, "count", (double)count, 1, 0, what, &n)) goto bad;
    if (!ind || !val) {
      fail(r, CH_ERR_INPUT, "%s: sparse without indices or values", what);
      goto bad;
    }
    if (get_index(r, ind, "bufferView", nviews, 1, what, &iview) < 0 ||
        get_size(r, ind, "byteOffset", 9007199254740991.0, 0, 0, what, &ioff) ||
        get_size(r, ind, "componentType", 6000, 1, 0, what, &itype_z) ||
        get_index(r, val, "bufferView", nviews, 1, what, &vview) < 0 ||
        get_size(r, val, "byteOffset", 9007199254740991.0, 0, 0, what, &voff))
      goto bad;
    int itype = (int)itype_z;
    if (itype != 5121 && itype != 5123 && itype != 5125) {
      fail(r, CH_ERR_INPUT, "%s: sparse indices of componentType %d", what, itype);
      goto bad;
    }
    const unsigned char *pi, *pv;
    size_t si, sv;
    if (view_span(r, iview, ioff, n, (size_t)component_size(itype), 0, what, &pi, &si) ||
        view_span(r, vview, voff, n, (size_t)width * csize, 0, what, &pv, &sv))
      goto bad;
    for (size_t j = 0; j < n; j++) {
      double at = component(pi + j * si, itype, 0);
      if (!(at < (double)count)) {
        fail(r, CH_ERR_INPUT, "%s: sparse index %.0f is past its %zu elements", what, at, count);
        goto bad;
      }
      for (int k = 0; k < width; k++)
        values[(size_t)at * width + k] = component(pv + j * sv + (size_t)k * csize, ctype, norm);
    }
  }
  for (size_t i = 0; i < count * width; i++)
    if (!isfinite(values[i])) {
      fail(r, CH_ERR_INPUT, "%s: element %zu is not a finite number", what, i / width);
      goto bad;
    }
  *out = values;
  *count_out = count;
  if (width_out) *width_out = width;
  return 0;
bad:
  free(values);
  return -1;
}

/* ---- meshes and nodes ---------------------------------------------------- */

/* 4 x 4 matrices, column-major as glTF writes them: m[col * 4 + row]. */
static void mat_mul(const double a[16], const double b[16], double out[16]) {
  double t[16];
  for (int c = 0; c < 4; c++)
    for (int row = 0; row < 4; row++) {
      double s = 0.0;
      for (int k = 0; k < 4; k++) s += a[k * 4 + row] * b[c * 4 + k];
      t[c * 4 + row] = s;
    }
  memcpy(out, t, sizeof t);
}

/* A node's local transform: its matrix, or T R S (§3.5.3). */
static int local_matrix(gltf_reader *r, const cJSON *node, const char *what, double m[16]) {
  static const double identity[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  memcpy(m, identity, sizeof identity);
  if (cJSON_GetObjectItemCaseSensitive(node, "matrix")) return get_numbers(r, node, "matrix", 16, what, m);
  double t[3] = {0, 0, 0}, q[4] = {0, 0, 0, 1}, s[3] = {1, 1, 1};
  if (get_numbers(r, node, "translation", 3, what, t) || get_numbers(r, node, "rotation", 4, what, q) ||
      get_numbers(r, node, "scale", 3, what, s))
    return -1;
  double x = q[0], y = q[1], z = q[2], w = q[3], n = sqrt(x * x + y * y + z * z + w * w);
  if (!(n > 0.0)) return fail(r, CH_ERR_INPUT, "%s: 'rotation' is not a unit quaternion", what);
  x /= n, y /= n, z /= n, w /= n;
  double rot[9] = {1 - 2 * (y * y + z * z), 2 * (x * y + z * w),     2 * (x * z - y * w),
                   2 * (x * y - z * w),     1 - 2 * (x * x + z * z), 2 * (y * z + x * w),
                   2 * (x * z + y * w),     2 * (y * z - x * w),     1 - 2 * (x * x + y * y)};
  for (int c = 0; c < 3; c++)
    for (int row = 0; row < 3; row++) m[c * 4 + row] = rot[c * 3 + row] * s[c];
  for (int row = 0; row < 3; row++) m[12 + row] = t[row];
  return 0;
}

static int add_triangle(gltf_reader *r, const int *pos, const int *uv, const int *nrm, int a, int b, int c) {
  if (pos[a] == pos[b] || pos[b] == pos[c] || pos[a] == pos[c]) {
    r->dropped++; /* no area at all once welded: an edge on itself */
    return 0;
  }
  if (r->num_triangles >= CH_MESH_MAX_ELEMENTS / 3)
    return fail(r, CH_ERR_INPUT, "more than %d triangles", CH_MESH_MAX_ELEMENTS / 3);
  if (r->num_triangles == r->cap_triangles) {
    size_t cap = r->cap_triangles ? 2 * r->cap_triangles : 4096;
    int *corners = realloc(r->corners, cap * 9 * sizeof *corners);
    if (!corners) return nomem(r);
    r->corners = corners;
    r->cap_triangles = cap;
  }
  int *o = &r->corners[9 * r->num_triangles++], v[3] = {a, b, c};
  for (int k = 0; k < 3; k++) {
    o[3 * k] = pos[v[k]];
    o[3 * k + 1] = uv ? uv[v[k]] : -1;
    o[3 * k + 2] = nrm ? nrm[v[k]] : -1;
  }
  return 0;
}

static int add_primitive(gltf_reader *r, const cJSON *prim, const double m[16], const char *what) {
  size_t mode;
  if (get_size(r, prim, "mode", 6, 0, 4, what, &mode)) return -1;
  if (mode < 4) {
    r->left_out++; /* points and lines: no surface */
    return 0;
  }
  const cJSON *attrs = cJSON_GetObjectItemCaseSensitive(prim, "attributes");
  if (!cJSON_IsObject(attrs)) return fail(r, CH_ERR_INPUT, "%s has no 'attributes'", what);
  int naccessors = r->num_accessors, ia, it = -1, in = -1, ii = -1;
  int has_pos = get_index(r, attrs, "POSITION", naccessors, 0, what, &ia);
  int has_uv = get_index(r, attrs, "TEXCOORD_0", naccessors, 0, what, &it);
  int has_n = get_index(r, attrs, "NORMAL", naccessors, 0, what, &in);
  int has_i = get_index(r, prim, "indices", naccessors, 0, what, &ii);
  if (has_pos < 0 || has_uv < 0 || has_n < 0 || has_i < 0) return -1;
  if (!has_pos) {
    r->left_out++; /* §3.7.2.1: no positions, nothing to draw */
    return 0;
  }
  if (r->want_uvs < 0) r->want_uvs = has_uv;
  if (has_uv != r->want_uvs)
    return fail(r, CH_ERR_INPUT, "%s %s TEXCOORD_0 (UVs) where the primitives before it %s", what,
                has_uv ? "has" : "has no", has_uv ? "had none" : "had them");
  if (r->want_normals < 0) r->want_normals = has_n;
  r->want_normals &= has_n; /* normals are for shading: kept only where every primitive has them */
  double *p = NULL, *t = NULL, *n = NULL, *idx = NULL;
  size_t np = 0, nt = 0, nn = 0, ni = 0;
  int *pos = NULL, *uv = NULL, *nrm = NULL, ret = -1;
  if (read_accessor(r, ia, 1u << 3, 1, &p, &np, NULL) || (has_uv && read_accessor(r, it, 1u << 2, 1, &t, &nt, NULL)) ||
      (has_n && read_accessor(r, in, 1u << 3, 1, &n, &nn, NULL)) ||
      (has_i && read_accessor(r, ii, 1u << 1, 0, &idx, &ni, NULL)))
    goto done;
  if ((has_uv && nt != np) || (has_n && nn != np)) {
    fail(r, CH_ERR_INPUT, "%s: its attributes have different counts (%zu positions, %zu UVs, %zu normals)", what, np,
         has_uv ? nt : np, has_n ? nn : np);
    goto done;
  }
  pos = malloc((np ? np : 1) * sizeof *pos);
  uv = has_uv ? malloc((np ? np : 1) * sizeof *uv) : NULL;
  nrm = has_n ? malloc((np ? np : 1) * sizeof *nrm) : NULL;
  if (!pos || (has_uv && !uv) || (has_n && !nrm)) {
    nomem(r);
    goto done;
  }
  /* Normals go through the inverse transpose of m's 3 x 3 part A: its
   * cofactor matrix C = det(A) A^-T, times the determinant's sign. */
  double A[3][3], C[3][3];
  for (int row = 0; row < 3; row++)
    for (int col = 0; col < 3; col++) A[row][col] = m[col * 4 + row];
  for (int row = 0; row < 3; row++)
    for (int col = 0; col < 3; col++) {
      int r1 = (row + 1) % 3, r2 = (row + 2) % 3, c1 = (col + 1) % 3, c2 = (col + 2) % 3;
      C[row][col] = A[r1][c1] * A[r2][c2] - A[r1][c2] * A[r2][c1];
    }
  double det = A[0][0] * C[0][0] + A[0][1] * C[0][1] + A[0][2] * C[0][2];
  size_t count = has_i ? ni : np;
  for (size_t i = 0; i < ni; i++)
    if (!(idx[i] >= 0.0 && idx[i] < (double)np)) {
      fail(r, CH_ERR_INPUT, "%s: index %zu is %.0f, past its %zu vertices", what, i, idx[i], np);
      goto done;
    }
  /* Only the vertices the triangles use become positions (an accessor
   * may hold other primitives' vertices too). */
  for (size_t i = 0; i < np; i++) pos[i] = -1;
  for (size_t i = 0; i < (count >= 3 ? count : 0); i++) pos[has_i ? (size_t)idx[i] : i] = 0;
  for (size_t i = 0; i < np; i++) {
    if (pos[i] < 0) continue;
    const double *q = &p[3 * i];
    double w[3];
    for (int row = 0; row < 3; row++) w[row] = m[row] * q[0] + m[4 + row] * q[1] + m[8 + row] * q[2] + m[12 + row];
    if ((pos[i] = ch_value_set_index(&r->positions, w)) < 0) goto full;
    if (has_uv) {
      double tv[2] = {t[2 * i], 1.0 - t[2 * i + 1]};
      if ((uv[i] = ch_value_set_index(&r->uvs, tv)) < 0) goto full;
    }
    if (has_n) {
      const double *q2 = &n[3 * i];
      double s = det < 0.0 ? -1.0 : 1.0, v[3];
      for (int row = 0; row < 3; row++)
        v[row] = s * (C[row][0] * q2[0] + C[row][1] * q2[1] + C[row][2] * q2[2]);
      double len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
      if (len > 0.0) v[0] /= len, v[1] /= len, v[2] /= len;
      if ((nrm[i] = ch_value_set_index(&r->normals, v)) < 0) goto full;
    }
  }
#define VERTEX(i) (has_i ? (int)idx[i] : (int)(i))
  int flip = det < 0.0; /* a mirroring transform turns the winding over */
  if (mode == 4) {
    if (count % 3) {
      fail(r, CH_ERR_INPUT, "%s: %zu vertices for triangles, not a multiple of 3", what, count);
      goto done;
    }
    for (size_t i = 0; i < count; i += 3)
      if (add_triangle(r, pos, uv, nrm, VERTEX(i), VERTEX(i + (flip ? 2 : 1)), VERTEX(i + (flip ? 1 : 2)))) goto done;
  } else {
    for (size_t i = 0; i + 2 < count; i++) {
      /* strips alternate their winding (§3.7.2.1); fans turn about their first vertex */
      int x = mode == 5 ? VERTEX(i) : VERTEX(i + 1), y = mode == 5 ? VERTEX(i + 1) : VERTEX(i + 2),
          z = mode == 5 ? VERTEX(i + 2) : VERTEX(0);
      if ((mode == 5 && (i & 1)) != flip) {
        int s = x;
        x = y;
        y = s;
      }
      if (add_triangle(r, pos, uv, nrm, x, y, z)) goto done;
    }
  }
#undef VERTEX
  ret = 0;
  goto done;
full:
  fail(r, CH_ERR_NOMEM, "out of memory, or more than %d distinct values", CH_MESH_MAX_ELEMENTS);
done:
  free(p);
  free(t);
  free(n);
  free(idx);
  free(pos);
  free(uv);
  free(nrm);
  return ret;
}

static int add_mesh(gltf_reader *r, int index, const double m[16]) {
  const cJSON *mesh = r->mesh[index], *prims;
  char what[64];
  snprintf(what, sizeof what, "mesh %d", index);
  if (get_array(r, mesh, "primitives", &prims)) return -1;
  if (!prims) return fail(r, CH_ERR_INPUT, "%s has no 'primitives'", what);
  int i = 0;
  for (const cJSON *p = prims->child; p; p = p->next, i++) {
    snprintf(what, sizeof what, "mesh %d primitive %d", index, i);
    if (add_primitive(r, p, m, what)) return -1;
  }
  return 0;
}

static int visit(gltf_reader *r, int index, const double parent[16], int depth) {
  char what[48];
  snprintf(what, sizeof what, "node %d", index);
  if (r->visited[index])
    return fail(r, CH_ERR_INPUT, "%s has more than one parent, or is its own ancestor (nodes form trees)", what);
  r->visited[index] = 1;
  if (depth > MAX_DEPTH) return fail(r, CH_ERR_INPUT, "nodes nested deeper than %d", MAX_DEPTH);
  const cJSON *node = r->node[index], *children;
  double local[16], m[16];
  if (local_matrix(r, node, what, local)) return -1;
  mat_mul(parent, local, m);
  int mesh, nmeshes = r->num_meshes;
  int has_mesh = get_index(r, node, "mesh", nmeshes, 0, what, &mesh);
  if (has_mesh < 0 || (has_mesh && add_mesh(r, mesh, m)) || get_array(r, node, "children", &children)) return -1;
  int nnodes = r->num_nodes;
  for (const cJSON *c = children ? children->child : NULL; c; c = c->next) {
    double x = cJSON_IsNumber(c) ? c->valuedouble : -1.0;
    if (!(x >= 0.0 && x < nnodes && x == floor(x)))
      return fail(r, CH_ERR_INPUT, "%s: a child that is not a node", what);
    if (visit(r, (int)x, m, depth + 1)) return -1;
  }
  return 0;
}

/* The meshes the default scene places (§3.3: `scene`, else the first);
 * without scenes, the nodes no node holds as a child; without nodes, every
 * mesh as it is. */
static int walk_scene(gltf_reader *r) {
  static const double identity[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  const cJSON *scenes;
  if (get_array(r, r->root, "scenes", &scenes)) return -1;
  int nnodes = r->num_nodes;
  if (nnodes > 0 && !(r->visited = calloc((size_t)nnodes, 1))) return nomem(r);
  if (scenes && cJSON_GetArraySize(scenes) > 0) {
    int s = 0;
    if (get_index(r, r->root, "scene", cJSON_GetArraySize(scenes), 0, "the file", &s) < 0) return -1;
    const cJSON *roots;
    if (get_array(r, cJSON_GetArrayItem(scenes, s), "nodes", &roots)) return -1;
    for (const cJSON *c = roots ? roots->child : NULL; c; c = c->next) {
      double x = cJSON_IsNumber(c) ? c->valuedouble : -1.0;
      if (!(x >= 0.0 && x < nnodes && x == floor(x)))
        return fail(r, CH_ERR_INPUT, "scene %d: a root that is not a node", s);
      if (visit(r, (int)x, identity, 0)) return -1;
    }
    return 0;
  }
  if (nnodes > 0) {
    unsigned char *child = calloc((size_t)nnodes, 1);
    if (!child) return nomem(r);
    for (const cJSON *node = r->nodes->child; node; node = node->next) {
      const cJSON *children = cJSON_GetObjectItemCaseSensitive(node, "children");
      for (const cJSON *c = cJSON_IsArray(children) ? children->child : NULL; c; c = c->next)
        if (cJSON_IsNumber(c) && c->valuedouble >= 0.0 && c->valuedouble < nnodes) child[(int)c->valuedouble] = 1;
    }
    int st = 0;
    for (int i = 0; i < nnodes && !st; i++)
      if (!child[i]) st = visit(r, i, identity, 0);
    free(child);
    return st;
  }
  int nmeshes = r->num_meshes;
  for (int i = 0; i < nmeshes; i++)
    if (add_mesh(r, i, identity)) return -1;
  return 0;
}

/* ---- the container and the whole ------------------------------------------ */

static uint32_t le32(const unsigned char *p) {
  return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* The JSON chunk and the BIN chunk of a GLB (§4.4). */
static int split_glb(gltf_reader *r, const unsigned char *d, size_t size, const char **json, size_t *json_size) {
  if (size < 20) return fail(r, CH_ERR_INPUT, "not a glTF binary: %zu bytes, shorter than its header", size);
  if (le32(d) != GLB_MAGIC) return fail(r, CH_ERR_INPUT, "not a glTF binary (its first bytes are not 'glTF')");
  if (le32(d + 4) != 2) return fail(r, CH_ERR_INPUT, "glTF binary version %u; chisel reads version 2", le32(d + 4));
  size_t length = le32(d + 8);
  if (length > size)
    return fail(r, CH_ERR_INPUT, "truncated: its header says %zu bytes, the file has %zu", length, size);
  size_t at = 12;
  for (int chunk = 0; at + 8 <= length; chunk++) {
    size_t n = le32(d + at);
    uint32_t type = le32(d + at + 4);
    if (n > length - at - 8) return fail(r, CH_ERR_INPUT, "chunk %d runs past the end of the file", chunk);
    if (chunk == 0 && type != CHUNK_JSON) return fail(r, CH_ERR_INPUT, "its first chunk is not JSON");
    if (chunk == 0) {
      *json = (const char *)d + at + 8;
      *json_size = n;
    } else if (chunk == 1 && type == CHUNK_BIN) {
      r->bin = d + at + 8;
      r->bin_size = n;
      r->has_bin = 1;
    }
    at += 8 + n;
  }
  if (!*json) return fail(r, CH_ERR_INPUT, "no JSON chunk");
  return 0;
}

static int check_asset(gltf_reader *r) {
  const cJSON *asset = cJSON_GetObjectItemCaseSensitive(r->root, "asset");
  const cJSON *version = asset ? cJSON_GetObjectItemCaseSensitive(asset, "version") : NULL;
  if (!cJSON_IsString(version)) return fail(r, CH_ERR_INPUT, "no asset.version: not a glTF 2.0 file");
  if (strncmp(version->valuestring, "2.", 2))
    return fail(r, CH_ERR_INPUT, "glTF version '%.20s'; chisel reads glTF 2.0", version->valuestring);
  const cJSON *required = cJSON_GetObjectItemCaseSensitive(r->root, "extensionsRequired");
  for (const cJSON *e = cJSON_IsArray(required) ? required->child : NULL; e; e = e->next) {
    if (!cJSON_IsString(e)) continue;
    const char *x = e->valuestring;
    /* Quantized attributes are read as any component type; materials and
     * textures do not change the geometry. Compression and instancing do. */
    if (!strcmp(x, "KHR_mesh_quantization") || !strncmp(x, "KHR_materials_", 14) || !strncmp(x, "KHR_texture_", 12))
      continue;
    return fail(r, CH_ERR_INPUT, "it requires the extension %.64s, which chisel does not read%s", x,
                strstr(x, "compression") ? " (decompress it first, e.g. with gltf-transform)" : "");
  }
  return 0;
}

static int read_all(gltf_reader *r, const void *data, size_t size, int binary) {
  const char *json = data;
  size_t json_size = size;
  if (binary) {
    json = NULL;
    if (split_glb(r, data, size, &json, &json_size)) return -1;
  } else if (size >= 3 && !memcmp(json, "\xEF\xBB\xBF", 3)) {
    json += 3, json_size -= 3; /* a byte order mark */
  }
  if (json_size == 0) return fail(r, CH_ERR_INPUT, "file is empty");
  r->root = cJSON_ParseWithLength(json, json_size);
  if (!r->root) {
    const char *at = cJSON_GetErrorPtr();
    size_t offset = at && at >= json && at <= json + json_size ? (size_t)(at - json) : 0;
    return fail(r, CH_ERR_INPUT, "its JSON is malformed near byte %zu", offset);
  }
  if (!cJSON_IsObject(r->root)) return fail(r, CH_ERR_INPUT, "its JSON is not an object");
  if (check_asset(r) || get_array(r, r->root, "accessors", &r->accessors) ||
      get_array(r, r->root, "bufferViews", &r->views) || get_array(r, r->root, "meshes", &r->meshes) ||
      get_array(r, r->root, "nodes", &r->nodes) || items(r, r->accessors, &r->accessor, &r->num_accessors) ||
      items(r, r->views, &r->view, &r->num_views) || items(r, r->meshes, &r->mesh, &r->num_meshes) ||
      items(r, r->nodes, &r->node, &r->num_nodes) || init_buffers(r) || walk_scene(r))
    return -1;
  if (r->num_triangles == 0)
    return fail(r, CH_ERR_INPUT, "no triangles in its scene%s", r->left_out ? " (only points or lines)" : "");
  return 0;
}

/* The triangles and their distinct values as a ch_mesh. */
static int to_mesh(gltf_reader *r, ch_mesh *out) {
  size_t nt = r->num_triangles, nc = 3 * nt;
  out->num_positions = r->positions.count;
  out->positions = r->positions.values;
  r->positions.values = NULL;
  out->num_faces = (int)nt;
  out->num_corners = (int)nc;
  out->face_start = malloc((nt + 1) * sizeof *out->face_start);
  out->corner_position = malloc(nc * sizeof *out->corner_position);
  if (!out->face_start || !out->corner_position) return nomem(r);
  if (r->want_uvs > 0) {
    out->num_uvs = r->uvs.count;
    out->uvs = r->uvs.values;
    r->uvs.values = NULL;
    if (!(out->corner_uv = malloc(nc * sizeof *out->corner_uv))) return nomem(r);
  }
  if (r->want_normals > 0) {
    out->num_normals = r->normals.count;
    out->normals = r->normals.values;
    r->normals.values = NULL;
    if (!(out->corner_normal = malloc(nc * sizeof *out->corner_normal))) return nomem(r);
  }
  for (size_t f = 0; f <= nt; f++) out->face_start[f] = (int)(3 * f);
  for (size_t c = 0; c < nc; c++) {
    out->corner_position[c] = r->corners[3 * c];
    if (out->corner_uv) out->corner_uv[c] = r->corners[3 * c + 1];
    if (out->corner_normal) out->corner_normal[c] = r->corners[3 * c + 2];
  }
  return 0;
}

ch_status ch_mesh_read_gltf(const void *data, size_t size, int binary, const char *path, const char *name, ch_mesh *out,
                            ch_error *err) {
  memset(out, 0, sizeof *out);
  gltf_reader r = {.name = name, .path = path, .err = err, .want_uvs = -1, .want_normals = -1};
  r.positions.width = 3;
  r.uvs.width = 2;
  r.normals.width = 3;
  int bad = read_all(&r, data, size, binary) || to_mesh(&r, out) || ch_mesh_merge_near_uvs(out, err) != CH_OK;
  if (!bad && r.dropped)
    ch_warn(err, "%s: %ld triangle%s with two corners at one position left out", name, r.dropped,
            r.dropped == 1 ? "" : "s");
  if (!bad && r.left_out)
    ch_warn(err, "%s: %ld primitive%s of points or lines, or without positions, left out", name, r.left_out,
            r.left_out == 1 ? "" : "s");
  cJSON_Delete(r.root);
  for (int i = 0; i < r.num_buffers && r.owned; i++) free(r.owned[i]);
  free(r.owned);
  free(r.buffer);
  free(r.buffer_size);
  free(r.visited);
  free(r.accessor);
  free(r.view);
  free(r.mesh);
  free(r.node);
  free(r.corners);
  ch_value_set_free(&r.positions);
  ch_value_set_free(&r.uvs);
  ch_value_set_free(&r.normals);
  if (bad) {
    ch_mesh_free(out);
    return r.status ? r.status : CH_ERR_INTERNAL;
  }
  return CH_OK;
}
