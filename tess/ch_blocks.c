/* ch_blocks: the base tessellation's grid blocks the cut leaves whole,
 * found before the cut and merged by the coarsening (ch_cut_internal.h).
 *
 * A full run of the embedding is aimed above its target and gives the
 * difference back where h is smooth (ch_cut_coarsen). Far from every
 * feature the cut copies the base's triangles whole, and nearer the
 * refinement and the cut leave many of them as they were; inside a quad
 * face those are Bfr's regular grid at the face's inner rates, two
 * triangles a quad. Where a block of 2 x 2 quads lies in one plane, and its
 * UVs follow its positions affinely, two triangles are the same surface
 * and the same UV map as its eight: the merge gives those back without
 * the greedy collapses' searches (about a microsecond a collapse), and
 * exactly (no vertex moves). Merged blocks next to blocks that stay keep
 * the midpoints of the sides between them, in a fan from their centre, so
 * the mesh stays conforming (as in restricted quadtree triangulations,
 * e.g. Pajarola 1998). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ch_alloc.h"
#include "ch_cut_internal.h"
#include "ch_embed_internal.h"

/* (points on the grid of a face's inner rates: st * rate within this of
 * an integer; Bfr's coordinates are i / rate, to rounding) */
#define GRID_TOL 1e-7

/* A block's grid point (i, j) is 3 j + i; the corners, the midpoints of
 * sides 0..3 (j = 0, i = 2, j = 2, i = 0), the centre. */
static const int corner_at[4] = {0, 2, 8, 6}, mid_at[4] = {1, 5, 7, 3};
enum { CENTRE = 4 };

/* Where base triangle t sits in its face's grid: its block (within the
 * face, bi + nbu * bj) and its place in the block (two per quad: the
 * quad's corner it leaves out decides which), or -1 where it is not half
 * of a grid quad of a whole block. *points: its corners' grid points in
 * the block (i + 3 j, 0..8), four bits each, corner k's from bit 4 k. */
static long grid_place(const double *st, int ru, int rv, int nbu, int nbv, int *points) {
  long gi[3], gj[3];
  for (int k = 0; k < 3; k++) {
    double a = st[2 * k] * ru, b = st[2 * k + 1] * rv;
    if (!(fabs(a) < 0x1p30 && fabs(b) < 0x1p30)) return -1;
    /* the nearest integers by adding and taking away 2^52 (lround is a
     * library call, 15 ms over a million triangles; the two differ only at
     * halves, which are off the grid either way) */
    double ra = (a + 0x1p52) - 0x1p52, rb = (b + 0x1p52) - 0x1p52;
    if (!(fabs(a - ra) <= GRID_TOL && fabs(b - rb) <= GRID_TOL)) return -1;
    gi[k] = (long)ra;
    gj[k] = (long)rb;
  }
  long ci = gi[0], cj = gj[0], xi = gi[0], xj = gj[0];
  for (int k = 1; k < 3; k++) {
    ci = gi[k] < ci ? gi[k] : ci;
    cj = gj[k] < cj ? gj[k] : cj;
    xi = gi[k] > xi ? gi[k] : xi;
    xj = gj[k] > xj ? gj[k] : xj;
  }
  if (xi - ci != 1 || xj - cj != 1 || ci < 0 || cj < 0 || ci / 2 >= nbu || cj / 2 >= nbv) return -1;
  /* the quad's corners 0..3 (i + 2 j): three distinct ones */
  int seen = 0, sum = 0;
  for (int k = 0; k < 3; k++) {
    int q = (int)(gi[k] - ci) + 2 * (int)(gj[k] - cj);
    seen |= 1 << q;
    sum += q;
  }
  int missing = 6 - sum, quad = (int)(ci % 2) + 2 * (int)(cj % 2);
  if (missing < 0 || missing > 3 || seen != 15 - (1 << missing)) return -1;
  *points = 0;
  for (int k = 0; k < 3; k++) *points |= (int)((gi[k] - ci / 2 * 2) + 3 * (gj[k] - cj / 2 * 2)) << (4 * k);
  /* a quad's two triangles leave out opposite corners (0 and 3, or 1 and
   * 2): one of each pair below 2 */
  return 8 * ((ci / 2) + (long)nbu * (cj / 2)) + 2 * quad + (missing >= 2);
}

int ch_cut_blocks_find(const ch_surface *surface, const ch_tess_result *tess, ch_cut_blocks *out) {
  memset(out, 0, sizeof *out);
  const ch_mesh *tm = &tess->mesh;
  int nf = ch_surface_num_faces(surface), nt = tm->num_faces;
  if (!tess->corner_st || nt <= 0) return 0;
  /* Per face: its inner rates and its first block. */
  long *first = malloc(((size_t)nf + 1) * sizeof *first);
  int *rate = malloc(2 * (size_t)(nf > 0 ? nf : 1) * sizeof *rate);
  long *place = ch_alloc_large((size_t)nt, sizeof *place, 0);
  unsigned short *points = ch_alloc_large((size_t)nt, sizeof *points, 0); /* (grid_place's) */
  int *slot = NULL, *index = NULL;
  int status = -1;
  if (!first || !rate || !place || !points) goto done;
  first[0] = 0;
  for (int f = 0; f < nf; f++) {
    int r[2] = {0, 0};
    if (!ch_tess_quad_inner_rates(surface, tess, f, r)) r[0] = r[1] = 0;
    rate[2 * f] = r[0];
    rate[2 * f + 1] = r[1];
    first[f + 1] = first[f] + (long)(r[0] / 2) * (long)(r[1] / 2);
  }
  long nb = first[nf];
  if (nb <= 0 || 8 * nb >= INT32_MAX) {
    status = 0;
    goto done;
  }
#pragma omp parallel for schedule(static)
  for (int t = 0; t < nt; t++) {
    int f = tess->triangle_face[t], ru = rate[2 * f], rv = rate[2 * f + 1], g = 0;
    long p = -1;
    if (ru >= 2 && rv >= 2) p = grid_place(&tess->corner_st[6 * (size_t)t], ru, rv, ru / 2, rv / 2, &g);
    place[t] = p < 0 ? -1 : 8 * first[f] + p;
    points[t] = (unsigned short)g;
  }
  /* Each block's eight triangles (in order: the same on any number of
   * threads); a place taken twice spoils its block. */
  slot = ch_alloc_large(8 * (size_t)nb, sizeof *slot, 0);
  index = ch_alloc_large((size_t)nb, sizeof *index, 0);
  if (!slot || !index) goto done;
#pragma omp parallel
  {
#pragma omp for schedule(static)
    for (long b = 0; b < nb; b++) {
      index[b] = 0;
      for (int s = 0; s < 8; s++) slot[8 * b + s] = -1;
    }
    /* Where two triangles take one place, one of them finds the other's
     * there (whichever wrote last): the block is spoiled either way. */
#pragma omp for schedule(static)
    for (int t = 0; t < nt; t++)
      if (place[t] >= 0) {
#pragma omp atomic write
        slot[place[t]] = t;
      }
#pragma omp for schedule(static)
    for (int t = 0; t < nt; t++)
      if (place[t] >= 0 && slot[place[t]] != t) {
#pragma omp atomic write
        index[place[t] / 8] = -1;
      }
#pragma omp for schedule(static)
    for (long b = 0; b < nb; b++) {
      int whole = index[b] == 0;
      for (int s = 0; s < 8 && whole; s++) whole = slot[8 * b + s] >= 0;
      index[b] = whole ? 1 : -1;
    }
  }
  int n = 0;
  for (long b = 0; b < nb; b++) index[b] = index[b] > 0 ? n++ : -1;
  if (n == 0) {
    status = 0;
    goto done;
  }
  out->tri = malloc(8 * (size_t)n * sizeof *out->tri);
  out->vert = malloc(9 * (size_t)n * sizeof *out->vert);
  out->next = malloc(4 * (size_t)n * sizeof *out->next);
  out->ccw = malloc((size_t)n * sizeof *out->ccw);
  if (!out->tri || !out->vert || !out->next || !out->ccw) goto done;
  out->n = n;
  int bad = 0;
  /* (by block, not by face: a plane is one face) */
#pragma omp parallel for schedule(static) reduction(| : bad)
  for (long b = 0; b < nb; b++) {
    int k = index[b];
    if (k < 0) continue;
    int f = 0, f1 = nf; /* the face whose blocks hold b: the last with first[f] <= b */
    while (f1 - f > 1) {
      int mid = f + (f1 - f) / 2;
      if (first[mid] <= b)
        f = mid;
      else
        f1 = mid;
    }
    int ru = rate[2 * f], rv = rate[2 * f + 1], nbu = ru / 2, nbv = rv / 2;
    long lb = b - first[f];
    int bi = (int)(lb % nbu), bj = (int)(lb / nbu), *v = &out->vert[9 * (size_t)k];
    for (int g = 0; g < 9; g++) v[g] = -1;
    for (int s = 0; s < 8; s++) {
      int t = slot[8 * b + s], g[3];
      out->tri[8 * (size_t)k + s] = t;
      for (int c = 0; c < 3; c++) {
        g[c] = points[t] >> (4 * c) & 15;
        int x = tm->corner_position[tm->face_start[t] + c];
        if (v[g[c]] >= 0 && v[g[c]] != x) bad = 1;
        v[g[c]] = x;
      }
      if (s == 0) {
        int cross = (g[1] % 3 - g[0] % 3) * (g[2] / 3 - g[0] / 3) - (g[2] % 3 - g[0] % 3) * (g[1] / 3 - g[0] / 3);
        out->ccw[k] = cross > 0 ? 1 : -1;
      }
    }
    const int di[4] = {0, 1, 0, -1}, dj[4] = {-1, 0, 1, 0};
    for (int s = 0; s < 4; s++) {
      int ni = bi + di[s], nj = bj + dj[s];
      out->next[4 * (size_t)k + s] =
          ni >= 0 && ni < nbu && nj >= 0 && nj < nbv ? index[first[f] + ni + (long)nbu * nj] : -1;
    }
  }
  if (bad) ch_cut_blocks_free(out); /* (a grid point on two vertices: not a grid after all) */
  status = 0;
done:
  if (status) ch_cut_blocks_free(out);
  free(first);
  free(rate);
  free(place);
  free(points);
  free(slot);
  free(index);
  return status;
}

void ch_cut_blocks_place(ch_cut_blocks *b, const int *first_out) {
#pragma omp parallel for schedule(static)
  for (int k = 0; k < b->n; k++) {
    int *t = &b->tri[8 * (size_t)k], whole = 1;
    for (int s = 0; s < 8; s++) {
      whole &= first_out[t[s] + 1] - first_out[t[s]] == 1;
      t[s] = first_out[t[s]];
    }
    if (!whole) t[0] = -1;
  }
}

/* Whether p (dim values per point, 9 points) is the affine grid of its
 * corners 0, 2 and 6: p(i, j) = p0 + i/2 (p2 - p0) + j/2 (p6 - p0), within
 * tol of the block's size, the parallelogram's far corner included. */
static int affine_grid(const double *const p[9], int dim, double tol) {
  double size = 0.0;
  for (int x = 0; x < dim; x++) size += fabs(p[2][x] - p[0][x]) + fabs(p[6][x] - p[0][x]);
  if (!(size > 0.0)) return 0;
  for (int g = 0; g < 9; g++) {
    double i = 0.5 * (g % 3), j = 0.5 * (g / 3);
    for (int x = 0; x < dim; x++) {
      double want = p[0][x] + i * (p[2][x] - p[0][x]) + j * (p[6][x] - p[0][x]);
      if (!(fabs(p[g][x] - want) <= tol * size)) return 0;
    }
  }
  return 1;
}

/* Whether block k can be merged: its triangles one plain piece, each
 * corner with its vertex's UV, and its nine points an affine grid in
 * space and in UV (so any triangulation of them is the same surface and
 * the same map). */
static int mergeable(const ch_cut_out *o, const ch_cut_blocks *bl, int k) {
  const int *t = &bl->tri[8 * (size_t)k], *v = &bl->vert[9 * (size_t)k];
  if (t[0] < 0) return 0;
  uint64_t group = o->group[t[0]];
  if (group == WALL_GROUP || (group >> 32) != 0) return 0;
  /* each still the grid's: its corners the block's points (a triangle the
   * refinement split has a midpoint of its own) */
  for (int s = 0; s < 8; s++) {
    if (o->group[t[s]] != group) return 0;
    for (int c = 0; c < 3; c++) {
      int x = o->tri[3 * (size_t)t[s] + c], in = 0;
      for (int g = 0; g < 9; g++) in |= v[g] == x;
      if (!in || o->corner_uv[3 * (size_t)t[s] + c] >= 0) return 0;
    }
  }
  const double *pos[9], *uv[9];
  for (int g = 0; g < 9; g++) {
    pos[g] = &o->pos[3 * (size_t)v[g]];
    uv[g] = &o->vertex_uv[2 * (size_t)v[g]];
  }
  /* (far below the OBJ's 9 digits; a flat grid's rounding is 1e-16) */
  return affine_grid(pos, 3, 1e-10) && affine_grid(uv, 2, 1e-10);
}

/* Triangles a merged block keeps with m sides still split. */
static int kept_triangles(int m) { return m == 0 ? 2 : 4 + m; }

long ch_cut_merge_blocks(ch_cut_out *o, long fewer) {
  ch_cut_blocks *bl = &o->blocks;
  int n = bl->n;
  if (n <= 0 || fewer < 2) return 0;
  unsigned char *ok = malloc((size_t)n);
  unsigned char *in = calloc((size_t)n, 1);
  signed char *open = malloc((size_t)n); /* per merged block: its sides still split */
  int *remap = ch_alloc_large((size_t)(o->npos > 0 ? o->npos : 1), sizeof *remap, 0);
  long saved = -1;
  if (!ok || !in || !open || !remap) goto done;
#pragma omp parallel for schedule(static)
  for (int k = 0; k < n; k++) ok[k] = (unsigned char)mergeable(o, bl, k);
  /* In block order (a face's rows) until enough are gone: each block's
   * share is what its own sides and its merged neighbours' change. */
  saved = 0;
  for (int k = 0; k < n && saved + 1 < fewer; k++) {
    if (!ok[k]) continue;
    int m = 0;
    for (int s = 0; s < 4; s++) {
      int x = bl->next[4 * (size_t)k + s];
      if (x < 0 || !in[x]) {
        m++;
      } else {
        saved += kept_triangles(open[x]) - kept_triangles(open[x] - 1);
        open[x]--;
      }
    }
    in[k] = 1;
    open[k] = (signed char)m;
    saved += 8 - kept_triangles(m);
  }
  /* Each merged block writes its triangles over its own first ones and
   * drops the rest; its centre goes where no side is split, and the
   * midpoint of a side between two merged blocks goes (written by the
   * lower block). Every other vertex stays. */
#pragma omp parallel for schedule(static)
  for (int v = 0; v < o->npos; v++) remap[v] = v;
#pragma omp parallel for schedule(static)
  for (int k = 0; k < n; k++) {
    if (!in[k]) continue;
    const int *v = &bl->vert[9 * (size_t)k], *next = &bl->next[4 * (size_t)k];
    int *slots = &bl->tri[8 * (size_t)k];
    int ring[8], nr = 0, made[8][3], nm = 0;
    for (int s = 0; s < 4; s++) {
      ring[nr++] = corner_at[s];
      int split = next[s] < 0 || !in[next[s]];
      if (split)
        ring[nr++] = mid_at[s];
      else if (k < next[s])
        remap[v[mid_at[s]]] = -1;
    }
    if (nr == 4) {
      int a[3] = {ring[0], ring[1], ring[2]}, b[3] = {ring[0], ring[2], ring[3]};
      memcpy(made[nm++], a, sizeof a);
      memcpy(made[nm++], b, sizeof b);
      remap[v[CENTRE]] = -1;
    } else {
      for (int i = 0; i < nr; i++) {
        int a[3] = {CENTRE, ring[i], ring[(i + 1) % nr]};
        memcpy(made[nm++], a, sizeof a);
      }
    }
    /* its slots in increasing order: the new triangles where its first were */
    int order[8];
    for (int s = 0; s < 8; s++) {
      int j = s;
      for (; j > 0 && slots[order[j - 1]] > slots[s]; j--) order[j] = order[j - 1];
      order[j] = s;
    }
    for (int i = 0; i < 8; i++) {
      int *c = &o->tri[3 * (size_t)slots[order[i]]];
      if (i >= nm) {
        c[0] = -1; /* removed */
        continue;
      }
      c[0] = v[made[i][0]];
      c[1] = v[bl->ccw[k] > 0 ? made[i][1] : made[i][2]];
      c[2] = v[bl->ccw[k] > 0 ? made[i][2] : made[i][1]];
      /* (its group and corner UVs are the block's, as they were: one
       * plain piece, every corner with its vertex's UV) */
    }
  }
  if (saved > 0) ch_cut_out_compact(o, remap, NULL);
done:
  free(ok);
  free(in);
  free(open);
  free(remap);
  return saved;
}
