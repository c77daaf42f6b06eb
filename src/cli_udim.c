/* UDIM for `chisel displace`: a base mesh whose UVs span tiles (u in
 * [k, k + 1], tile 1001 + k + 10 l for v in [l, l + 1], as Mari and Blender
 * number them) takes one curve file per tile. The pipeline works on the UV
 * square, so the tiles are laid side by side in an atlas of it, each in a
 * cell of a g x g grid, shrunk by a margin wider than any groove's reach
 * (so a groove never carves its neighbour tile, as separate texture tiles
 * would not); the base mesh's UVs and each tile's curves go through the
 * same affine map, and the output's UVs come back through its inverse.
 * Grooves are exact this way. Step curves are diffused over the atlas as
 * one image: closed fills with nothing outside them come out as they
 * would per tile; other step curves can reach across tiles (warned). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "cli.h"
#include "cli_udim.h"

static int tile_number(int tu, int tv) { return 1001 + tu + 10 * tv; }

ch_status cli_udim_tiles(const ch_mesh *mesh, const char *name, cli_udim *u, ch_error *err) {
  memset(u, 0, sizeof *u);
  if (!mesh->corner_uv) return CH_OK;
  for (int f = 0; f < mesh->num_faces; f++) {
    int c0 = mesh->face_start[f], c1 = mesh->face_start[f + 1];
    double cu = 0.0, cv = 0.0;
    for (int c = c0; c < c1; c++) {
      cu += mesh->uvs[2 * (size_t)mesh->corner_uv[c]];
      cv += mesh->uvs[2 * (size_t)mesh->corner_uv[c] + 1];
    }
    cu /= c1 - c0, cv /= c1 - c0;
    if (!(cu >= 0.0 && cu < 10.0 && cv >= 0.0 && cv < 100.0))
      return ch_error_set(err, CH_ERR_INPUT, "%s: face %d: UVs around (%g, %g) are outside the UDIM tiles (u in [0, 10), v >= 0)",
                          name, f + 1, cu, cv);
    int tu = (int)floor(cu), tv = (int)floor(cv);
    /* A face belongs to one tile: every corner within it (to rounding). */
    for (int c = c0; c < c1; c++) {
      const double *p = &mesh->uvs[2 * (size_t)mesh->corner_uv[c]];
      if (p[0] < tu - 1e-9 || p[0] > tu + 1 + 1e-9 || p[1] < tv - 1e-9 || p[1] > tv + 1 + 1e-9)
        return ch_error_set(err, CH_ERR_INPUT, "%s: face %d spans UDIM tiles (UV (%g, %g) is outside tile %d)", name,
                            f + 1, p[0], p[1], tile_number(tu, tv));
    }
    int t = tile_number(tu, tv), k = 0;
    while (k < u->num_tiles && u->tiles[k] != t) k++;
    if (k == u->num_tiles) {
      if (u->num_tiles == CLI_UDIM_MAX_TILES)
        return ch_error_set(err, CH_ERR_INPUT, "%s: UVs span more than %d UDIM tiles", name, CLI_UDIM_MAX_TILES);
      u->tiles[u->num_tiles++] = t;
    }
  }
  /* Ascending tile numbers: the atlas and the messages in a fixed order. */
  for (int a = 1; a < u->num_tiles; a++)
    for (int b = a; b > 0 && u->tiles[b] < u->tiles[b - 1]; b--) {
      int t = u->tiles[b];
      u->tiles[b] = u->tiles[b - 1], u->tiles[b - 1] = t;
    }
  return CH_OK;
}

int cli_udim_curve_path(const char *arg, int tile, char *out, size_t size, int variant) {
  const char *token = strstr(arg, "<UDIM>");
  if (token)
    return variant == 0 && snprintf(out, size, "%.*s%d%s", (int)(token - arg), arg, tile, token + 6) < (int)size;
  /* NAME.1001.svg or NAME_1001.svg given: the same with the tile's number. */
  size_t n = strlen(arg);
  if (n > 9 && !strcmp(arg + n - 4, ".svg") && (arg[n - 9] == '.' || arg[n - 9] == '_') && arg[n - 8] == '1' &&
      arg[n - 7] >= '0' && arg[n - 7] <= '9' && arg[n - 6] >= '0' && arg[n - 6] <= '9' && arg[n - 5] >= '0' &&
      arg[n - 5] <= '9')
    return variant == 0 && snprintf(out, size, "%.*s%d.svg", (int)(n - 8), arg, tile) < (int)size;
  /* NAME.svg: NAME.1001.svg, else NAME_1001.svg. */
  size_t stem = n > 4 && !strcmp(arg + n - 4, ".svg") ? n - 4 : n;
  if (variant > 1) return 0;
  return snprintf(out, size, "%.*s%c%d.svg", (int)stem, arg, variant == 0 ? '.' : '_', tile) < (int)size;
}

void cli_udim_layout(cli_udim *u, double reach) {
  int g = 1;
  while (g * g < u->num_tiles) g++;
  u->grid = g;
  double cell = 1.0 / g;
  /* The margin keeps a groove's reach (in tile UV, shrunk with the tile)
   * inside the tile's own cell, with room to spare. */
  double f = fmin(0.25, reach + 1.0 / 64.0);
  u->scale = cell * (1.0 - 2.0 * f);
  u->margin = cell * f;
  for (int k = 0; k < u->num_tiles; k++) {
    u->origin[k][0] = (k % g) * cell + u->margin;
    u->origin[k][1] = (k / g) * cell + u->margin;
  }
}

static int tile_index(const cli_udim *u, int tile) {
  for (int k = 0; k < u->num_tiles; k++)
    if (u->tiles[k] == tile) return k;
  return -1;
}

typedef struct corner_ref {
  int uv, tile, corner;
} corner_ref;

static int cmp_ref(const void *a, const void *b) {
  const corner_ref *x = a, *y = b;
  if (x->uv != y->uv) return x->uv < y->uv ? -1 : 1;
  if (x->tile != y->tile) return x->tile < y->tile ? -1 : 1;
  return (x->corner > y->corner) - (x->corner < y->corner);
}

ch_status cli_udim_to_atlas(ch_mesh *mesh, const cli_udim *u, ch_error *err) {
  size_t nc = (size_t)mesh->num_corners;
  corner_ref *refs = malloc((nc ? nc : 1) * sizeof *refs);
  double *uvs = malloc((nc ? nc : 1) * 2 * sizeof *uvs);
  if (!refs || !uvs) {
    free(refs), free(uvs);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the UDIM atlas");
  }
  for (int f = 0; f < mesh->num_faces; f++) {
    int c0 = mesh->face_start[f], c1 = mesh->face_start[f + 1];
    double cu = 0.0, cv = 0.0;
    for (int c = c0; c < c1; c++) {
      cu += mesh->uvs[2 * (size_t)mesh->corner_uv[c]];
      cv += mesh->uvs[2 * (size_t)mesh->corner_uv[c] + 1];
    }
    int tile = tile_number((int)floor(cu / (c1 - c0)), (int)floor(cv / (c1 - c0)));
    for (int c = c0; c < c1; c++) refs[c] = (corner_ref){mesh->corner_uv[c], tile, c};
  }
  /* One UV value per (value, tile): a value on a tile's border shared by
   * faces of two tiles becomes one per tile. */
  qsort(refs, nc, sizeof *refs, cmp_ref);
  int n = 0;
  for (size_t i = 0; i < nc; i++) {
    if (i == 0 || refs[i].uv != refs[i - 1].uv || refs[i].tile != refs[i - 1].tile) {
      int k = tile_index(u, refs[i].tile);
      double tu = (refs[i].tile - 1001) % 10, tv = (refs[i].tile - 1001) / 10;
      const double *p = &mesh->uvs[2 * (size_t)refs[i].uv];
      uvs[2 * (size_t)n] = u->origin[k][0] + (p[0] - tu) * u->scale;
      uvs[2 * (size_t)n + 1] = u->origin[k][1] + (p[1] - tv) * u->scale;
      n++;
    }
    mesh->corner_uv[refs[i].corner] = n - 1;
  }
  free(refs);
  free(mesh->uvs);
  mesh->uvs = uvs;
  mesh->num_uvs = n;
  return CH_OK;
}

void cli_udim_from_atlas(ch_mesh *mesh, const cli_udim *u) {
  double cell = 1.0 / u->grid;
  for (int i = 0; i < mesh->num_uvs; i++) {
    double *p = &mesh->uvs[2 * (size_t)i];
    int gx = (int)floor(p[0] / cell), gy = (int)floor(p[1] / cell);
    gx = gx < 0 ? 0 : gx >= u->grid ? u->grid - 1 : gx;
    gy = gy < 0 ? 0 : gy >= u->grid ? u->grid - 1 : gy;
    int k = gy * u->grid + gx;
    if (k >= u->num_tiles) k = u->num_tiles - 1;
    int tile = u->tiles[k];
    double tu = (tile - 1001) % 10, tv = (tile - 1001) / 10;
    p[0] = tu + (p[0] - u->origin[k][0]) / u->scale;
    p[1] = tv + (p[1] - u->origin[k][1]) / u->scale;
  }
}

ch_status cli_udim_merge(const ch_curve_set *sets, const cli_udim *u, ch_curve_set *out, ch_error *err) {
  memset(out, 0, sizeof *out);
  int nc = 0, ns = 0, np = 0;
  for (int k = 0; k < u->num_tiles; k++) {
    nc += sets[k].num_curves;
    ns += sets[k].num_segments;
    np += sets[k].num_subpaths;
  }
  out->curves = calloc((size_t)(nc ? nc : 1), sizeof *out->curves);
  out->segments = calloc((size_t)(ns ? ns : 1), sizeof *out->segments);
  out->subpaths = calloc((size_t)(np ? np : 1), sizeof *out->subpaths);
  if (!out->curves || !out->segments || !out->subpaths) {
    ch_curves_free(out);
    return ch_error_set(err, CH_ERR_NOMEM, "out of memory for the UDIM atlas's curves");
  }
  out->viewbox[2] = out->viewbox[3] = 1.0;
  for (int k = 0; k < u->num_tiles; k++) {
    const ch_curve_set *s = &sets[k];
    int c0 = out->num_curves, s0 = out->num_segments, p0 = out->num_subpaths;
    for (int i = 0; i < s->num_segments; i++) {
      ch_segment g = s->segments[i];
      for (int j = 0; j < 3; j++)
        for (int a = 0; a < 2; a++) g.p[j][a] = u->origin[k][a] + g.p[j][a] * u->scale;
      g.curve += c0;
      if (g.prev >= 0) g.prev += s0;
      if (g.next >= 0) g.next += s0;
      out->segments[out->num_segments++] = g;
    }
    for (int i = 0; i < s->num_subpaths; i++) {
      ch_subpath p = s->subpaths[i];
      p.first_segment += s0;
      out->subpaths[out->num_subpaths++] = p;
    }
    for (int i = 0; i < s->num_curves; i++) {
      ch_curve c = s->curves[i];
      c.first_segment += s0;
      c.first_subpath += p0;
      c.width *= u->scale;
      c.blur *= u->scale;
      c.element_index += c0;
      out->curves[out->num_curves++] = c;
      ch_curve_update_box(out, out->num_curves - 1);
    }
  }
  return CH_OK;
}

double cli_udim_reach(const ch_curve_set *set) {
  double r = 0.0;
  for (int i = 0; i < set->num_curves; i++) {
    const ch_curve *c = &set->curves[i];
    r = fmax(r, c->kind == CH_CURVE_GROOVE ? 0.5 * c->width : 3.0 * c->blur);
  }
  return r;
}

int cli_udim_open_steps(const ch_curve_set *set) {
  for (int i = 0; i < set->num_curves; i++) {
    const ch_curve *c = &set->curves[i];
    if (c->kind != CH_CURVE_STEP) continue;
    if (c->right != 0.0) return 1;
    for (int k = 0; k < c->num_subpaths; k++)
      if (!set->subpaths[c->first_subpath + k].closed) return 1;
  }
  return 0;
}

int cli_udim_check_files(const char *cmd, const cli_file *inputs, int num_inputs, const char *curves,
                         const cli_file *outputs, int num_outputs) {
  /* Which tiles are read is known only once the mesh is read; any file
   * that would be a tile's (1001 + u + 10 v, u < 10, v < 100, both
   * spellings) and exists is an input, so no output replaces it. */
  enum { FIRST = 1001, LAST = 1001 + 9 + 10 * 99, NAME = 64 };
  typedef struct tile_file {
    char option[NAME];
    char path[4096];
  } tile_file;
  tile_file *tf = NULL;
  int n = 0, cap = 0;
  for (int t = FIRST; curves && t <= LAST; t++)
    for (int v = 0; v < 2; v++) {
      char path[4096];
      struct stat st;
      if (!cli_udim_curve_path(curves, t, path, sizeof path, v) || stat(path, &st) != 0) continue;
      if (n == cap) {
        cap = cap ? 2 * cap : 8;
        tile_file *g = realloc(tf, (size_t)cap * sizeof *g);
        if (!g) {
          free(tf);
          fprintf(stderr, "chisel: out of memory\n");
          return 1;
        }
        tf = g;
      }
      snprintf(tf[n].option, NAME, "the curves of UDIM tile %d", t);
      snprintf(tf[n].path, sizeof tf[n].path, "%s", path);
      n++;
    }
  cli_file *all = malloc((size_t)(num_inputs + n) * sizeof *all);
  if (!all) {
    free(tf);
    fprintf(stderr, "chisel: out of memory\n");
    return 1;
  }
  for (int i = 0; i < num_inputs; i++) all[i] = inputs[i];
  for (int i = 0; i < n; i++) all[num_inputs + i] = (cli_file){tf[i].option, tf[i].path};
  int rc = cli_check_files(cmd, all, num_inputs + n, outputs, num_outputs);
  free(all);
  free(tf);
  return rc;
}
