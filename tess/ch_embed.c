/* Feature embedding by cutting the tessellation along piece boundaries of h
 * (see ch_embed.h for the method and why). */
#include "ch_embed.h"
#include "ch_cut_internal.h"
#include "ch_embed_internal.h"
#include "ch_label_internal.h"
#include "ch_refine_internal.h"

#include <math.h>
#include <omp.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "ch_alloc.h"
#include "ch_bezier.h"
#include "ch_count.h"
#include "ch_geomimage.h"
#include "ch_grid.h"
#include "ch_math.h"
#include "ch_samples.h"
#include "ch_segtree.h"
#include "ch_thin.h"
#include "ch_warp.h"

/* ---- the whole embedding ------------------------------------------------- */
double ch_embed_angle_deg(double reference_edge) { return fmin(10.0, fmax(1.0, 1800.0 * reference_edge)); }

/* Rounds of ch_cut_densify: each can double the quiet part's triangles. */
#define DENSIFY_ROUNDS 4
/* Refinement rounds after the last that only split triangles the cut
 * would fan (ch_refine_uncut): the last round's children, and theirs.
 * Those the bundled sets left uncut at 8 rounds took one (plane + panels
 * at 440k and 540k, plane + glyphs at 730k); where no split resolves a
 * triangle (two creases crossing in an X) the rounds end at the split's
 * least length (plane + ornament at 620k: after two). */
#define FINISH_ROUNDS 4
/* The largest share of the target a full run may take that way (further
 * below, the base near the features would be coarser than the target's:
 * another run is the better answer), and the largest it may give back
 * where it went over (ch_cut_coarsen): there the base near the features
 * is finer than the target's, as the full runs' margin asks, and only the
 * smooth part loses triangles. (At 15% both ways ornament at 520k ran a
 * third time: its first full run, aimed 12% of what the features add
 * over the target, came out 16% over.) */
#define DENSIFY_SHARE 0.15
#define COARSEN_SHARE 0.25
/* Within this share of the target a run has landed (docs/spec.md §5's 5%, less
 * a margin for the cleanup's estimate). */
#define LANDED 0.045

/* A sampled pilot refines and cuts only the triangles in every other tile
 * of a SAMPLE_TILES^2 checkerboard over UV (lines much longer than a
 * tile cross the black and the white tiles alike), where its base has at
 * least SAMPLE_MIN_BASE triangles (about 80 a tile; measured within 1-4%
 * of the whole pilot at a 32.5k base, 0.1-2.5% at 131k). Below it the
 * target is small enough that a pilot may land and be finished. From
 * SAMPLE_QUARTER_BASE on (about 80 a tile again) a quarter: the grid
 * twice as fine, one tile of each 2x2 block, which one by a hash of the
 * block (stratified sampling). A lattice of one in four (i + 3j = 0 mod
 * 4) aliased with the glyphs and the spiral: their full runs then missed
 * their aim by 5-7% where the checkerboard's missed by 0.3-1.8%. Over the
 * 27 bundled base x set cases the full runs' miss of their aim (the level
 * model's own error included) averaged 2.2% (at most 6.1%) at 2.1M and
 * 2.0% (6.1%) at 1.5M, against the checkerboard's 2.0% (6.1%) and 2.2%
 * (6.6%), for a pilot 1.3-1.6x faster (ornament at 2.1M: 573 -> 349 ms). */
#define SAMPLE_TILES 16
#define SAMPLE_MIN_BASE 20000
#define SAMPLE_QUARTER_BASE 80000

/* Whether the triangle of corner UVs uv is in a sampled pilot's tiles (by
 * its centroid). */
static int sample_tile(const double *const uv[3], int quarter) {
  double u = (uv[0][0] + uv[1][0] + uv[2][0]) / 3.0, v = (uv[0][1] + uv[1][1] + uv[2][1]) / 3.0;
  if (quarter) {
    long i = (long)floor(u * 2 * SAMPLE_TILES), j = (long)floor(v * 2 * SAMPLE_TILES);
    uint32_t h = (uint32_t)(i >> 1) * 0x9E3779B1u ^ (uint32_t)(j >> 1) * 0x85EBCA77u;
    h ^= h >> 15;
    h *= 0x2C1B3C6Du;
    h ^= h >> 12;
    return (int)((h >> 7) & 3) == (int)((i & 1) | ((j & 1) << 1));
  }
  long i = (long)floor(u * SAMPLE_TILES), j = (long)floor(v * SAMPLE_TILES);
  return ((i + j) & 1) == 0;
}

/* Whether working triangle t is in a sampled pilot's tiles. */
static int tri_sampled(const ch_refine_mesh *w, int t, int quarter) {
  const double *uv[3] = {w->tris[t].uv[0], w->tris[t].uv[1], w->tris[t].uv[2]};
  return sample_tile(uv, quarter);
}

/* Base triangle t's corner UVs. */
static void base_corner_uvs(const ch_mesh *m, int t, const double *uv[3]) {
  for (int k = 0; k < 3; k++) uv[k] = &m->uvs[2 * (size_t)m->corner_uv[m->face_start[t] + k]];
}

/* The base's triangles far from every feature (see embed_run): out of the
 * working mesh, copied by the cut in their place. The cut's order is the
 * base's triangles, then those the refinement appended, as if the far
 * ones were in the working mesh: the same output either way. */
typedef struct far_set {
  int nbase, nactive, nfar;
  int *where; /* per base triangle: its index in the working mesh (whose
                 first nactive are the base's near ones, in order), or
                 -1 - f for far triangle f */
  int *far_v; /* 3 per far triangle: its vertices */
} far_set;

/* Triangles in the cut's order. */
static int far_order_count(const far_set *fs, const ch_refine_mesh *w) { return fs->nbase + (w->ntris - fs->nactive); }

/* The t-th triangle of the cut's order: its index in the working mesh, or
 * -1 - f for far triangle f. */
static int far_order_slot(const far_set *fs, int t) {
  return t < fs->nbase ? fs->where[t] : fs->nactive + (t - fs->nbase);
}

/* Far triangle f's vertices. */
static const int *far_tri(const far_set *fs, int f) { return &fs->far_v[3 * (size_t)f]; }

/* Cuts the t-th triangle of the cut's order into o. */
static int cut_in_order(const ch_label_ctx *lb, const ch_refine_mesh *w, const far_set *fs, int t, double tol,
                        ch_cut_out *o, ch_embed_stats *stats) {
  int i = far_order_slot(fs, t);
  if (i >= 0) return ch_cut_triangle(lb, w, i, tol, o, stats);
  const int *v = far_tri(fs, -1 - i);
  return ch_cut_out_tri(o, v[0], v[1], v[2], w->verts[v[0]].uv, w->verts[v[1]].uv, w->verts[v[2]].uv,
                        w->verts[v[0]].label);
}

/* Whether the t-th triangle of the cut's order is in a sampled pilot's tiles. */
static int in_order_sampled(const ch_refine_mesh *w, const far_set *fs, int t, int quarter) {
  int i = far_order_slot(fs, t);
  if (i >= 0) return tri_sampled(w, i, quarter);
  const int *v = far_tri(fs, -1 - i);
  const double *uv[3] = {w->verts[v[0]].uv, w->verts[v[1]].uv, w->verts[v[2]].uv};
  return sample_tile(uv, quarter);
}

/* Thinning pays where the target is coarse (measured on the plane's sets:
 * at 130k triangles L1 13-80% lower on the u and box sets, the normals'
 * p95 up to 1.3 degrees; at 520k and 2.1M L1 only 7-17% lower for 25-130%
 * more time, from the bigger base it leaves room for and runs the count
 * model then misses). Below a mean edge of 1/360 (about 260k triangles
 * over the UV square) the cut is left as it is. */
static int thins(const ch_embed_desc *desc, double reference_edge) {
  return !(desc && desc->no_thinning) && reference_edge >= 1.0 / 360.0;
}

/* A sampled pilot's count: the crossings' copies numbered from first[]
 * (as the cut numbers them), then the triangles in its tiles cut into
 * parts that count and store nothing (the cut's own count: the same code
 * decides it). Returns the triangles those tiles' cut makes. */
static long count_sampled_cut(const ch_label_ctx *lb, ch_refine_mesh *w, const far_set *fs, const int *first,
                              double tol, int quarter) {
#pragma omp parallel for schedule(dynamic, 1024)
  for (int i = 0; i < w->nedges; i++) {
    ch_refine_edge *e = &w->edges[i];
    for (int c = 0, k = first[i]; c < e->ncross; c++) {
      ch_refine_crossing *x = &e->cross[c];
      int wall = !(fabs(x->ha - x->hb) <= tol);
      x->copy_a = k;
      x->copy_b = k + wall;
      k += 1 + wall;
    }
  }
  enum { COUNT_CHUNK = 4096 };
  int n = far_order_count(fs, w), nchunks = (n + COUNT_CHUNK - 1) / COUNT_CHUNK;
  long tris = 0;
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : tris)
  for (int c = 0; c < nchunks; c++) {
    ch_cut_out part = {.count_only = 1};
    ch_embed_stats ps = {0};
    int t1 = (c + 1) * COUNT_CHUNK < n ? (c + 1) * COUNT_CHUNK : n;
    for (int t = c * COUNT_CHUNK; t < t1; t++)
      if (in_order_sampled(w, fs, t, quarter)) cut_in_order(lb, w, fs, t, tol, &part, &ps);
    tris += part.ntri;
  }
  return tris;
}

/* What a count-only run leaves for embed_finish: its cut. */
typedef struct embed_kept {
  ch_cut_out o;
  ch_embed_stats stats;
} embed_kept;

/* How short an edge the cleanup collapses: 1e-8 of the diagonal of the
 * positions' box (see embed_finish). */
static double collapse_length(const double *pos, int n) {
  double lo0 = INFINITY, lo1 = INFINITY, lo2 = INFINITY, hi0 = -INFINITY, hi1 = -INFINITY, hi2 = -INFINITY;
  /* (ch_box3 on all threads: min and max are exact, so the same box) */
#pragma omp parallel for schedule(static) reduction(min : lo0, lo1, lo2) reduction(max : hi0, hi1, hi2)
  for (int i = 0; i < n; i++) {
    const double *p = &pos[3 * (size_t)i];
    lo0 = p[0] < lo0 ? p[0] : lo0, hi0 = p[0] > hi0 ? p[0] : hi0;
    lo1 = p[1] < lo1 ? p[1] : lo1, hi1 = p[1] > hi1 ? p[1] : hi1;
    lo2 = p[2] < lo2 ? p[2] : lo2, hi2 = p[2] > hi2 ? p[2] : hi2;
  }
  double span[3] = {hi0 - lo0, hi1 - lo1, hi2 - lo2};
  return n ? 1e-8 * sqrt(ch_dot3(span, span)) : 0.0;
}

/* The triangles the cleanup will remove, about: those with an edge it
 * collapses (at 130k over the tablet, 4.6% of the cut's). */
static long cleanup_estimate(const ch_cut_out *o) {
  double eps = collapse_length(o->pos, o->npos), eps2 = eps * eps;
  long n = 0;
#pragma omp parallel for schedule(static) reduction(+ : n)
  for (int t = 0; t < o->ntri; t++) {
    const int *v = &o->tri[3 * (size_t)t];
    for (int k = 0; k < 3; k++) {
      const double *a = &o->pos[3 * (size_t)v[k]], *b = &o->pos[3 * (size_t)v[(k + 1) % 3]];
      double d[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
      if (ch_dot3(d, d) < eps2) {
        n++;
        break;
      }
    }
  }
  return n;
}

/* From the cut to the displaced mesh: positions, normals by group, the
 * collapse of zero-length edges. On return o's positions are out's (the
 * caller still frees o with ch_cut_out_free). */
static ch_status embed_finish(const ch_surface *surface, const ch_height *height, ch_cut_out *o, long target,
                              const ch_progress *progress, int run, ch_embed_stats *stats, ch_mesh *out,
                              ch_error *err) {
  const ch_curve_set *set = height->set;
  double t_start = omp_get_wtime();
  ch_status st;
  /* (the stages after the cut: a third of a large run) */
  ch_progress_reportf(progress, -1.0, "embedding: run %d, positions", run);
  if ((st = ch_cut_evaluate_positions(surface, o, err))) return st;
  long extra = target > 0 ? target - (o->ntri - cleanup_estimate(o)) : 0;
  /* Short of the target by more than docs/spec.md §5 allows and by at
   * most DENSIFY_SHARE of it: the rest where h is smooth; over it by up to
   * COARSEN_SHARE: fewer triangles there. A run within the 5% is left as
   * it is. */
  if (extra > LANDED * (double)target && extra <= DENSIFY_SHARE * (double)target) {
    ch_progress_reportf(progress, -1.0, "embedding: run %d, adding triangles where h is smooth", run);
    long added = ch_cut_densify(surface, height, o, extra, DENSIFY_ROUNDS);
    if (added == -1) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for feature embedding");
    if (added < 0) return ch_error_set(err, CH_ERR_INTERNAL, "feature embedding: a vertex left its base face");
    stats->densified = added;
  } else if (-extra > LANDED * (double)target && -extra <= COARSEN_SHARE * (double)target) {
    /* over it: fewer triangles where h is smooth, the features' untouched */
    ch_progress_reportf(progress, -1.0, "embedding: run %d, coarsening where h is smooth", run);
    long removed = ch_cut_coarsen(o, -extra, &stats->merged);
    if (removed < 0) return ch_error_set(err, CH_ERR_NOMEM, "out of memory for feature embedding");
    stats->densified = -removed;
  }
  double t2 = omp_get_wtime();
  stats->seconds_cut += t2 - t_start;
  double min_h = INFINITY, max_h = -INFINITY; /* (compared: see ch_box3) */
  for (int i = 0; i < o->npos; i++) {
    min_h = o->h[i] < min_h ? o->h[i] : min_h;
    max_h = o->h[i] > max_h ? o->h[i] : max_h;
  }
  stats->min_h = min_h;
  stats->max_h = max_h;
  /* What each vertex is (face, st, h) is spent in its position: gone
   * before the mesh's arrays are made. */
  free(o->face);
  free(o->st);
  free(o->h);
  o->face = NULL;
  o->st = o->h = NULL;
  /* Normals are shared within a group. The pieces of a u groove between
   * its rims meet at lines where the surface is smooth (its slices exist
   * only so that facets follow P): one group for them all, so shading is
   * smooth across them and split only at its rims. */
#pragma omp parallel for schedule(static)
  for (int t = 0; t < o->ntri; t++) {
    uint64_t gr = o->group[t], g = gr >> 32;
    if (gr == WALL_GROUP || !g) continue;
    const ch_curve *cv = &set->curves[GROOVE_CURVE(g)];
    if (cv->profile.kind == CH_PROFILE_U) /* one group over its slices and line sets */
      o->group[t] = (gr & ~((UINT64_C(0xff) | (UINT64_C(3) << 28)) << 32)) | (UINT64_C(1) << 32);
  }
  /* (edges shorter than this are collapsed below; triangles thinner than it
   * count for nothing in the normals) */
  double eps = collapse_length(o->pos, o->npos);
  ch_progress_reportf(progress, -1.0, "embedding: run %d, normals", run);
  if ((st = ch_cut_build_mesh(o, eps, out, err))) return st;
  o->pos = NULL; /* now out's */
  {
    /* A line through a vertex of the tessellation puts its boundary point
     * within rounding of that vertex (a bisection's 1e-12 of the edge, or
     * a level function's root a few 1e-9 off, and next to a u groove's rim,
     * where the profile is vertical, heights 1e-9 apart): collapse those
     * edges (where the mesh stays manifold) rather than keep zero-area
     * slivers and copies of one point, which print as one in the OBJ. 1e-8
     * of the size is far below any feature (the u lines' first offset is
     * about 1e-3 of the groove's width) and changes no accuracy figure. */
    if (ch_mesh_collapse_short_edges(out, eps) < 0 || ch_mesh_remove_pillows(out) < 0) {
      ch_mesh_free(out);
      return ch_error_set(err, CH_ERR_NOMEM, "out of memory for feature embedding");
    }
  }
  stats->triangles = out->num_faces;
  stats->seconds_normals = omp_get_wtime() - t2;
  return CH_OK;
}

/* Reports a stage of embedding run `run` (1, 2, ... of ch_embed_to_target)
 * at refinement round `round`. */
static void report(const ch_embed_desc *desc, const ch_embed_pilot *pilot, int round, const char *what,
                   double fraction) {
  if (!desc || !desc->progress) return;
  ch_progress_reportf(desc->progress, fraction, "embedding: run %d%s, round %d, %s", pilot->run,
                      pilot->count_only && !pilot->full ? " (pilot)" : "", round, what);
}

/* The error of a run whose triangles would pass the cap (at `stage` n). */
static ch_status over_cap(ch_error *err, const ch_embed_pilot *pilot, double cap, const char *stage, int n,
                          int base) {
  if (pilot->over_cap) *pilot->over_cap = 1;
  return ch_error_set(err, CH_ERR_INPUT,
                      "feature embedding: the curves need more than %.0f triangles (the cap; %s %d over %d base "
                      "triangles): too many curves meet in too small a place; fewer or wider curves, a higher cap, "
                      "or no embedding (--no-snap)",
                      cap, stage, n, base);
}

/* Frees the working mesh's arrays (and empties it). */
static void free_working_mesh(ch_refine_mesh *w) {
  free(w->verts);
  free(w->tris);
  free(w->edges);
  ch_refine_pools_free(w);
  free(w->tri_edge);
  memset(w, 0, sizeof *w);
}

/* realloc to n elements of size (at least one), keeping *p where that fails. */
static void shrink_array(void **p, size_t n, size_t size) {
  void *q = *p ? realloc(*p, (n ? n : 1) * size) : NULL;
  if (q) *p = q;
}

/* Gives back what the working mesh's arrays hold beyond their counts once
 * refinement is over (they grew a quarter at a time, and the edges start
 * at one per corner): the cut's parts then fit in it. */
static void shrink_working_mesh(ch_refine_mesh *w) {
  shrink_array((void **)&w->verts, (size_t)w->nverts, sizeof *w->verts);
  shrink_array((void **)&w->tris, (size_t)w->ntris, sizeof *w->tris);
  shrink_array((void **)&w->edges, (size_t)w->nedges, sizeof *w->edges);
  shrink_array((void **)&w->tri_edge, 3 * (size_t)w->ntris, sizeof *w->tri_edge);
  w->cap_verts = w->nverts;
  w->cap_tris = w->ntris;
  w->cap_edges = w->nedges;
  w->cap_tri_edge = 3 * w->ntris;
}

/* ch_embed_run; a count-only run hands its cut to *kept if asked. */
/* An edge's refinement level (ch_embed_stats): 0 for the tessellation's
 * own edges (both ends its vertices: a split never joins two of them),
 * else the rounded number of halvings from the mean edge, at least 1. */
static int edge_level(const ch_refine_mesh *w, const ch_refine_edge *e, int base_verts, double mean_edge) {
  if (e->b < base_verts) return 0; /* (a < b) */
  double len = ch_refine_edge_length(w, e);
  long d = len > 0.0 ? lround(log2(mean_edge / len)) : CH_EMBED_LEVELS;
  return d < 1 ? 1 : d >= CH_EMBED_LEVELS ? CH_EMBED_LEVELS - 1 : (int)d;
}

/* The output vertices edge e's crossings make: one each, two on a wall
 * (heights apart by more than tol). */
static long crossing_copies(const ch_refine_edge *e, double tol) {
  long n = 0;
  for (int c = 0; c < e->ncross; c++) n += fabs(e->cross[c].ha - e->cross[c].hb) <= tol ? 1 : 2;
  return n;
}

static ch_status embed_run(const ch_surface *surface, const ch_tess_result *tess, const ch_height *height,
                           const ch_embed_desc *desc, const ch_embed_pilot *pilot, ch_mesh *out,
                           ch_embed_stats *stats_out, embed_kept *kept, ch_error *err) {
  memset(out, 0, sizeof *out);
  ch_embed_stats stats = {0};
  const ch_mesh *tm = &tess->mesh;
  /* (the tessellation may be let go below: its counts are kept) */
  const int base_faces = tm->num_faces, base_positions = tm->num_positions;
  stats.base_triangles = base_faces;
  double t0 = omp_get_wtime();
  ch_refine_mesh w = {.surface = surface};
  unsigned char *fresh = NULL; /* triangles the last split made; NULL: all */
  unsigned char *edge_sampled = NULL; /* a sampled pilot's: the edges of its tiles' triangles */
  double *shared_uv = NULL;           /* the cut's shared vertices' UVs (ch_cut_out.shared_uv) */
  float *edge_grid = NULL;            /* with thinning: ch_cut_edge_grid's */
  int *split_edges = NULL, cap_split = 0; /* a round's: the edges given midpoints */
  ch_label_ctx lb = {0};
  ch_cut_out o = {0};
  far_set far = {0};
  ch_cut_blocks blocks = {0}; /* the grid's (ch_cut_blocks_find) */
  int *first_out = NULL;      /* with blocks: each base triangle's first in the cut (and one more) */
  ch_status st = CH_OK;

  /* The working mesh: the tessellation's vertices, and its triangles near
   * the features (far ones are set aside below), each corner with its
   * (s,t) in its face. */
  w.nverts = tm->num_positions;
  w.cap_verts = w.nverts + w.nverts / 4 + 1024;
  w.verts = ch_alloc_large((size_t)w.cap_verts, sizeof *w.verts, 0);
  if (!w.verts || ch_refine_pools_init(&w)) goto nomem;
  ch_alloc_prefault(w.verts, (size_t)w.nverts * sizeof *w.verts); /* (the room past nverts stays untouched) */
  double uv_area = 0.0, longest2 = 0.0;
  /* (squared lengths compared, one square root at the end: hypot and fmax
   * are library calls, 15 ms over a million triangles) */
#pragma omp parallel for schedule(static) reduction(max : longest2)
  for (int t = 0; t < base_faces; t++) {
    const double *uv[3];
    base_corner_uvs(tm, t, uv);
    for (int k = 0; k < 3; k++) {
      double du = uv[(k + 1) % 3][0] - uv[k][0], dv = uv[(k + 1) % 3][1] - uv[k][1], l2 = du * du + dv * dv;
      longest2 = l2 > longest2 ? l2 : longest2;
    }
  }
  double longest_edge = sqrt(longest2);
  int sampled = pilot->count_only && !pilot->full && pilot->sampled;
  int quarter = sampled && base_faces >= SAMPLE_QUARTER_BASE; /* (see sample_tile) */
  double sampled_area = 0.0;
  long sampled_base = 0;
  for (int t = 0; t < base_faces; t++) { /* in order: the same sum for any thread count */
    const double *uv[3];
    base_corner_uvs(tm, t, uv);
    double a =
        0.5 * fabs((uv[1][0] - uv[0][0]) * (uv[2][1] - uv[0][1]) - (uv[2][0] - uv[0][0]) * (uv[1][1] - uv[0][1]));
    uv_area += a;
    if (sampled && sample_tile(uv, quarter)) {
      sampled_area += a;
      sampled_base++;
    }
  }
#pragma omp parallel for schedule(static)
  for (int v = 0; v < w.nverts; v++) {
    w.verts[v].face = tess->vertex_face[v];
    memcpy(w.verts[v].st, &tess->vertex_st[2 * (size_t)v], sizeof w.verts[v].st);
    ch_surface_eval_uv(surface, w.verts[v].face, w.verts[v].st[0], w.verts[v].st[1], w.verts[v].uv);
  }
  double mean_edge = sqrt(2.0 * uv_area / (base_faces > 0 ? base_faces : 1));
  double radius = desc && desc->step_radius > 0.0 ? desc->step_radius : 4.0 * mean_edge;
  /* A warped mesh's edges vary about the mean by the warp's slopes: every
   * corner of a triangle a step curve crosses must still see the curve. */
  if (desc && desc->warp && !(desc->step_radius > 0.0)) radius = fmax(radius, 2.0 * longest_edge);
  double curve_tolerance = desc && desc->curve_tolerance > 0.0 ? desc->curve_tolerance : 0.0;
  /* A warped mesh's coarse parts have edges up to 1 / floor = 10x the
   * mean: four halvings more to bring them down to the features (only
   * for triangles that cannot be cut yet: refining the rest there spends
   * triangles the camera does not see). */
  int max_rounds = desc && desc->max_refine_rounds > 0 ? desc->max_refine_rounds : desc && desc->warp ? 12 : 8;
  /* The angle step of the u lines: finer with density, as the mesh would
   * be, about 7 degrees at 130k triangles over the UV square, 3.5 at 520k
   * (measured on the bundled curve sets: finer steps starve the rest of
   * the mesh at a fixed count, coarser ones leave the normals faceted). */
  double reference_edge = pilot->reference_edge > 0.0 ? pilot->reference_edge : mean_edge;
  double angle_deg = desc && desc->normal_tolerance_deg > 0.0 ? desc->normal_tolerance_deg
                                                              : ch_embed_angle_deg(reference_edge);
  double angle = angle_deg * CH_PI / 180.0;
  /* Object units per UV unit, for the slope of the displaced profiles. */
  double area3 = 0.0;
  for (int f = 0; f < tess->mesh.num_faces; f++) { /* in order, as above */
    const int *cp = &tess->mesh.corner_position[tess->mesh.face_start[f]];
    const double *p0 = &tess->mesh.positions[3 * (size_t)cp[0]];
    const double *p1 = &tess->mesh.positions[3 * (size_t)cp[1]];
    const double *p2 = &tess->mesh.positions[3 * (size_t)cp[2]];
    double a[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]}, b[3] = {p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]}, n[3];
    ch_cross3(a, b, n);
    area3 += 0.5 * sqrt(ch_dot3(n, n));
  }
  double object_scale = uv_area > 0.0 && area3 > 0.0 ? sqrt(area3 / uv_area) : 1.0;
  if (thins(desc, reference_edge)) {
    edge_grid = malloc(CH_CUT_EDGE_GRID * CH_CUT_EDGE_GRID * sizeof *edge_grid);
    if (!edge_grid || ch_cut_edge_grid(tess, longest_edge, edge_grid)) goto nomem;
  }
  if ((st = ch_label_init(&lb, height, desc ? desc->warp : NULL, radius, curve_tolerance, angle, object_scale,
                          reference_edge, longest_edge, err)))
    goto done;
  /* Far triangles: no cell within one longest edge of their corners is
   * touched by a feature, so neither they nor their neighbours (which lie
   * within that edge) are ever refined (ch_refine_needed leaves triangles
   * with quiet corners alone, and a split reaches a triangle only across
   * an edge of one refined), their edges cross nothing, and the cut would
   * copy them whole. They stay out of the working mesh, its edges and its
   * rounds (at 2.1M triangles most of the base, and most of the
   * embedding's memory traffic), and the cut copies them in their place
   * (far_set). A vertex whose corners' UVs are not all its own (a seam, or
   * rounding) keeps its triangles in. */
  if (!(far.where = malloc((size_t)(base_faces > 0 ? base_faces : 1) * sizeof *far.where))) goto nomem;
  far.nbase = base_faces;
  {
    unsigned char *odd = calloc((size_t)(w.nverts > 0 ? w.nverts : 1), 1);
    if (!odd) goto nomem;
#pragma omp parallel for schedule(static)
    for (int t = 0; t < base_faces; t++)
      for (int k = 0; k < 3; k++) {
        int c = tm->face_start[t] + k, v = tm->corner_position[c];
        const double *uv = &tm->uvs[2 * (size_t)tm->corner_uv[c]];
        if (uv[0] != w.verts[v].uv[0] || uv[1] != w.verts[v].uv[1]) {
#pragma omp atomic write
          odd[v] = 1;
        }
      }
#pragma omp parallel for schedule(static)
    for (int t = 0; t < base_faces; t++) {
      const double *uv[3];
      base_corner_uvs(tm, t, uv);
      const int *v = &tm->corner_position[tm->face_start[t]];
      double lo[2], hi[2];
      for (int i = 0; i < 2; i++) {
        lo[i] = fmin(uv[0][i], fmin(uv[1][i], uv[2][i])) - longest_edge;
        hi[i] = fmax(uv[0][i], fmax(uv[1][i], uv[2][i])) + longest_edge;
      }
      far.where[t] =
          !(desc && desc->keep_far) && !odd[v[0]] && !odd[v[1]] && !odd[v[2]] && ch_label_box_quiet(&lb, lo, hi) ? -1
                                                                                                                 : 0;
    }
    free(odd);
  }
  for (int t = 0; t < base_faces; t++) /* numbered in base order */
    far.where[t] = far.where[t] < 0 ? -1 - far.nfar++ : far.nactive++;
  /* With room for a quarter of the base more: the refinement adds 5-15%
   * at large counts, and growing the arrays then copies them whole (1.7 GB
   * of triangles at 20M, while both copies live); untouched room costs no
   * memory. */
  w.ntris = far.nactive;
  stats.far_triangles = far.nfar;
  w.cap_tris = far.nactive + base_faces / 4 + 1024;
  w.tris = ch_alloc_large((size_t)w.cap_tris, sizeof *w.tris, 0);
  ch_alloc_prefault(w.tris, (size_t)w.ntris * sizeof *w.tris);
  far.far_v = malloc(3 * (size_t)(far.nfar > 0 ? far.nfar : 1) * sizeof *far.far_v);
  if (!w.tris || !far.far_v) goto nomem;
  int failed = 0;
#pragma omp parallel for schedule(static) reduction(| : failed)
  for (int t = 0; t < base_faces; t++) {
    int i = far.where[t];
    if (i < 0) {
      memcpy(&far.far_v[3 * (size_t)(-1 - i)], &tm->corner_position[tm->face_start[t]], 3 * sizeof *far.far_v);
      continue;
    }
    ch_refine_tri *T = &w.tris[i];
    T->face = tess->triangle_face[t];
    for (int k = 0; k < 3; k++) {
      int c = tm->face_start[t] + k, v = tm->corner_position[c];
      T->v[k] = v;
      memcpy(T->uv[k], &tm->uvs[2 * (size_t)tm->corner_uv[c]], sizeof T->uv[k]);
      if (tess->corner_st) {
        memcpy(T->st[k], &tess->corner_st[6 * (size_t)t + 2 * k], sizeof T->st[k]);
      } else if (tess->vertex_face[v] == T->face) {
        memcpy(T->st[k], &tess->vertex_st[2 * (size_t)v], sizeof T->st[k]);
      } else if (ch_surface_locate(surface, T->face, T->uv[k], T->st[k])) {
        failed = 1;
      }
    }
  }
  if (failed) {
    st = ch_error_set(err, CH_ERR_INTERNAL, "feature embedding: a tessellation corner is outside its face's UV");
    goto done;
  }
  /* A run the finish will coarsen (aimed above its target by more than
   * it may land, with no warp and no thinning to renumber the cut) finds
   * the grid's blocks the coarsening merges first where the cut leaves
   * them whole (ch_blocks.c); for a run that lands they were a fifth of a
   * GB at 20M triangles, for nothing. */
  if (pilot->count_only && pilot->takes_back && !sampled && !(desc && desc->warp) && !thins(desc, reference_edge)) {
    if (ch_cut_blocks_find(surface, tess, &blocks)) goto nomem;
    if (blocks.n > 0 && !(first_out = ch_alloc_large((size_t)base_faces + 1, sizeof *first_out, 0))) goto nomem;
  }
  /* All the run needs of the tessellation is read: where the caller does
   * not keep it (ch_embed_to_target's), it goes before the run's peak. */
  if (pilot->release_tess) {
    ch_tess_free(pilot->release_tess);
    tess = NULL;
    tm = NULL;
  } else if (pilot->release_corner_st) {
    free(*pilot->release_corner_st);
    *pilot->release_corner_st = NULL;
  }
  lb.junction_size = mean_edge / 8.0;
  lb.cap_angle = 4.0 * angle;
  stats.seconds_setup = omp_get_wtime() - t0;
  /* Edge samples: a quarter of the thinnest groove, so no groove slips
   * between two samples unseen. */
  double delta = INFINITY, scale = 0.0;
  for (int c = 0; c < height->set->num_curves; c++) {
    const ch_curve *cv = &height->set->curves[c];
    if (cv->kind == CH_CURVE_GROOVE) {
      delta = fmin(delta, 0.25 * cv->width);
      scale = fmax(scale, fabs(cv->depth));
    } else {
      scale = fmax(scale, fmax(fabs(cv->left), fabs(cv->right)));
    }
  }
  double tol = 1e-5 * scale + 1e-12; /* a jump above this is a wall */
  lb.wall_tol = tol;

  /* Each split edge adds about two triangles, and the cut a few per
   * crossing. Curves that need more than the cap would take memory and time
   * without end: the refinement and the cut stop there with an error. */
  double cap = desc && desc->max_triangles > 0 ? (double)desc->max_triangles
                                               : MAX_REFINED_PER_BASE * (double)base_faces + MAX_REFINED_EXTRA;
  /* Local refinement until every triangle's crossings pair into chords. */
  int labelled = 0, crossed = 0, last_split = 0;
  for (int round = 0;; round++) {
    double ta = omp_get_wtime();
    report(desc, pilot, round, "labels", -1.0);
    ch_refine_label_vertices(&lb, &w, labelled);
    labelled = w.nverts;
    double tb = omp_get_wtime();
    if (round == 0 && (st = ch_refine_build_edges(&w, err))) goto done;
    double tc = omp_get_wtime();
    stats.seconds_labels += tb - ta;
    stats.seconds_edges += tc - tb;
    /* The last split's halves take their edges' crossings: about half of
     * a round's new edges, searched again before. */
    int oom = 0;
#pragma omp parallel for schedule(dynamic, 256) reduction(| : oom)
    for (int i = 0; i < last_split; i++) oom |= ch_refine_inherit_crossings(&lb, &w, split_edges[i], delta) != 0;
    if (oom) goto nomem;
    if (sampled) {
      unsigned char *es = realloc(edge_sampled, (size_t)(w.nedges > 0 ? w.nedges : 1));
      if (!es) goto nomem;
      edge_sampled = es;
      memset(es, 0, (size_t)w.nedges);
#pragma omp parallel for schedule(static)
      for (int t = 0; t < w.ntris; t++)
        if (tri_sampled(&w, t, quarter))
          for (int k = 0; k < 3; k++) {
#pragma omp atomic write
            es[w.tri_edge[3 * (size_t)t + k]] = 1;
          }
    }
    /* (in blocks, so a long search reports how far it is). Without tiles
     * every edge before `crossed` has its crossings: a split appends its
     * new edges, so a round looks at those alone. */
    int from = edge_sampled ? 0 : crossed, todo = w.nedges - from;
    for (int i0 = from, block = todo / 32 > 4096 ? todo / 32 : 4096; i0 < w.nedges && !oom; i0 += block) {
      report(desc, pilot, round, "crossings", (double)(i0 - from) / todo);
      int i1 = i0 + block < w.nedges ? i0 + block : w.nedges;
#pragma omp parallel for schedule(dynamic, 64) reduction(| : oom)
      for (int i = i0; i < i1; i++) {
        ch_refine_edge *e = &w.edges[i];
        if (e->ncross < 0 && (!edge_sampled || edge_sampled[i])) oom |= ch_refine_crossings(&lb, &w, e, delta);
      }
    }
    if (oom) goto nomem;
    crossed = w.nedges;
    double td = omp_get_wtime();
    stats.seconds_crossings += td - tc;
    /* The triangles of the last round's split have their crossings but
     * were never looked at: after max_rounds, up to FINISH_ROUNDS more
     * rounds split those the cut would fan, and only those (a mesh without
     * them comes out the same), until the split reaches its least length. */
    if (round >= max_rounds + FINISH_ROUNDS) break;
    int finishing = round >= max_rounds;
    unsigned char *refine = calloc((size_t)(w.ntris > 0 ? w.ntris : 1), 1);
    if (!refine) goto nomem;
    report(desc, pilot, round, "refinement", -1.0);
    /* Only triangles made by the last split can have changed: the others
     * kept their edges and crossings, so their answer too. */
#pragma omp parallel for schedule(dynamic, 256)
    for (int t = 0; t < w.ntris; t++)
      refine[t] =
          (unsigned char)((!fresh || fresh[t]) && (!sampled || tri_sampled(&w, t, quarter)) &&
                          (finishing ? ch_refine_uncut(&lb, &w, t) : ch_refine_needed(&lb, &w, t, round >= 8, round)));
    double te = omp_get_wtime();
    stats.seconds_classify += te - td;
    int split = 0, first_new = w.nverts;
    for (int t = 0; t < w.ntris; t++)
      for (int k = 0; k < 3 && refine[t]; k++) {
        int i = w.tri_edge[3 * (size_t)t + k];
        if (w.edges[i].mid >= 0 || ch_refine_edge_length(&w, &w.edges[i]) < MIN_SPLIT_LENGTH) continue;
        stats.splits_at_level[edge_level(&w, &w.edges[i], base_positions, mean_edge)]++;
        if (ch_refine_add_midpoint(&w, i) ||
            ch_alloc_grow((void **)&split_edges, &cap_split, split + 1, sizeof *split_edges, 1024)) {
          free(refine);
          goto nomem;
        }
        split_edges[split++] = i;
      }
    free(refine);
    ch_refine_locate_new(&w, first_new);
    if (!split) break;
    if ((double)(w.ntris + far.nfar) + 2.0 * split > cap) {
      st = over_cap(err, pilot, cap, "refinement round", round + 1, base_faces);
      goto done;
    }
    stats.refine_rounds = round + 1;
    stats.refined_edges += split;
    if ((st = ch_refine_split(&w, split_edges, split, &fresh, err))) goto done;
    last_split = split;
    stats.seconds_split += omp_get_wtime() - te;
  }
  double t1 = omp_get_wtime();
  shrink_working_mesh(&w);
  free(fresh); /* (the refinement's only) */
  fresh = NULL;

  /* Output vertices: the working vertices, then the crossings' copies
   * (one, or two on a wall), numbered edge by edge and filled in parallel. */
  {
    /* (counted by blocks of edges in parallel, then numbered from each
     * block's start: the numbers one pass in edge order gives) */
    enum { COUNT_BLOCK = 1 << 14 };
    int nblocks = (w.nedges + COUNT_BLOCK - 1) / COUNT_BLOCK, at_level[CH_EMBED_LEVELS] = {0};
    int *first = malloc(((size_t)w.nedges + 1) * sizeof *first);
    long *block_at = malloc(((size_t)nblocks + 1) * sizeof *block_at);
    if (!first || !block_at) {
      free(first);
      free(block_at);
      goto nomem;
    }
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : at_level[:CH_EMBED_LEVELS])
    for (int b = 0; b < nblocks; b++) {
      long n = 0;
      for (int i = b * COUNT_BLOCK, i1 = i + COUNT_BLOCK < w.nedges ? i + COUNT_BLOCK : w.nedges; i < i1; i++) {
        const ch_refine_edge *e = &w.edges[i];
        if (e->ncross <= 0) continue;
        at_level[edge_level(&w, e, base_positions, mean_edge)] += e->ncross;
        n += crossing_copies(e, tol);
      }
      block_at[b] = n;
    }
    long total = w.nverts;
    for (int b = 0; b < nblocks; b++) {
      long n = block_at[b];
      block_at[b] = total;
      total += n;
    }
    for (int d = 0; d < CH_EMBED_LEVELS; d++) stats.crossings_at_level[d] += at_level[d];
    if (total >= INT32_MAX / 3) {
      free(first);
      free(block_at);
      goto nomem;
    }
#pragma omp parallel for schedule(dynamic, 1)
    for (int b = 0; b < nblocks; b++) {
      long k = block_at[b];
      for (int i = b * COUNT_BLOCK, i1 = i + COUNT_BLOCK < w.nedges ? i + COUNT_BLOCK : w.nedges; i < i1; i++) {
        first[i] = (int)k;
        if (w.edges[i].ncross > 0) k += crossing_copies(&w.edges[i], tol);
      }
    }
    free(block_at);
    if (sampled) {
      /* What the tiles' cut adds over their base triangles, scaled by the
       * area (as are the crossings and splits by level). */
      long tris = count_sampled_cut(&lb, &w, &far, first, tol, quarter);
      free(first);
      double scale = sampled_area > 0.0 ? uv_area / sampled_area : 1.0;
      stats.triangles = base_faces + llround(scale * (double)(tris - sampled_base));
      for (int d = 0; d < CH_EMBED_LEVELS; d++) {
        stats.crossings_at_level[d] = (int)lround(scale * stats.crossings_at_level[d]);
        stats.splits_at_level[d] = (int)lround(scale * stats.splits_at_level[d]);
      }
      if ((double)stats.triangles > cap) {
        st = over_cap(err, pilot, cap, "the cut after round", stats.refine_rounds, base_faces);
        goto done;
      }
      stats.angle_deg = angle_deg;
      stats.seconds_refine = t1 - t0;
      stats.seconds_cut = omp_get_wtime() - t1;
      if (stats_out) *stats_out = stats;
      goto done;
    }
    int n = (int)total;
    o.face = ch_alloc_large((size_t)(n > 0 ? n : 1), sizeof *o.face, 0);
    o.st = ch_alloc_large(2 * (size_t)(n > 0 ? n : 1), sizeof *o.st, 0);
    o.h = ch_alloc_large((size_t)(n > 0 ? n : 1), sizeof *o.h, 0);
    if (!o.face || !o.st || !o.h) {
      free(first);
      goto nomem;
    }
    shared_uv = ch_alloc_large(2 * (size_t)(n > 0 ? n : 1), sizeof *shared_uv, 0);
    if (!shared_uv) {
      free(first);
      goto nomem;
    }
    o.npos = o.cap_pos = n;
#pragma omp parallel for schedule(static)
    for (int v = 0; v < w.nverts; v++) {
      o.face[v] = w.verts[v].face;
      memcpy(&o.st[2 * (size_t)v], w.verts[v].st, sizeof w.verts[v].st);
      memcpy(&shared_uv[2 * (size_t)v], w.verts[v].uv, sizeof w.verts[v].uv);
      o.h[v] = w.verts[v].h;
    }
    long crossings = 0, walls = 0;
#pragma omp parallel for schedule(dynamic, 1024) reduction(+ : crossings, walls)
    for (int i = 0; i < w.nedges; i++) {
      ch_refine_edge *e = &w.edges[i];
      if (e->ncross <= 0) continue; /* (most: their triangles not read) */
      int face = w.tris[e->tri].face, k = first[i];
      for (int c = 0; c < e->ncross; c++) {
        ch_refine_crossing *x = &e->cross[c];
        double pst[2], puv[2];
        ch_refine_edge_point(&w, e, x->x, puv, pst);
        ch_refine_locate_st(surface, face, puv, pst);
        crossings++;
        int wall = !(fabs(x->ha - x->hb) <= tol);
        walls += wall;
        for (int j = 0; j <= wall; j++) {
          o.face[k + j] = face;
          memcpy(&o.st[2 * (size_t)(k + j)], pst, sizeof pst);
          memcpy(&shared_uv[2 * (size_t)(k + j)], puv, sizeof puv);
          o.h[k + j] = wall ? (j ? x->hb : x->ha) : 0.5 * (x->ha + x->hb);
        }
        x->copy_a = k;
        x->copy_b = k + wall;
        k += 1 + wall;
      }
    }
    stats.crossings += (int)crossings;
    stats.wall_points += (int)walls;
    free(first);
  }
  report(desc, pilot, stats.refine_rounds, "cut", -1.0);
  /* The cut, in parallel over fixed chunks of triangles: each part numbers
   * its new vertices (junctions) after the shared ones; the parts are then
   * joined in chunk order, so the bytes do not depend on the threads. */
  {
    enum { CUT_CHUNK = 4096 };
    int norder = far_order_count(&far, &w), nchunks = (norder + CUT_CHUNK - 1) / CUT_CHUNK, shared = o.npos, oom = 0,
        over = 0;
    ch_cut_out *part = calloc((size_t)(nchunks > 0 ? nchunks : 1), sizeof *part);
    ch_embed_stats *pstats = calloc((size_t)(nchunks > 0 ? nchunks : 1), sizeof *pstats);
    if (!part || !pstats) {
      free(part);
      free(pstats);
      goto nomem;
    }
#pragma omp parallel for schedule(dynamic, 1) reduction(| : oom)
    for (int c = 0; c < nchunks; c++) {
      part[c].npos = part[c].first_pos = shared;
      part[c].shared_uv = shared_uv;
      int t1 = (c + 1) * CUT_CHUNK < norder ? (c + 1) * CUT_CHUNK : norder;
      for (int t = c * CUT_CHUNK; t < t1 && !oom; t++) {
        if (first_out && t <= base_faces) first_out[t] = part[c].ntri; /* (within the part, for now) */
        oom |= cut_in_order(&lb, &w, &far, t, tol, &part[c], &pstats[c]) != 0;
      }
      ch_cut_out_shrink(&part[c]); /* all parts live until the join: not twice their size */
    }
    /* The working mesh is done with once the parts are cut: its memory goes
     * before the join makes the output's arrays (it was a third of the
     * peak, the join's, when it went after). */
    free_working_mesh(&w);
    free(far.where);
    free(far.far_v);
    far.where = far.far_v = NULL;
    /* Joined in chunk order: each part's vertices and triangles land at
     * offsets known from the counts, so the copy runs in parallel into
     * arrays allocated once (appending them one by one grew the arrays by
     * doubling, copies and page faults that cost as much as the cut). */
    long *vbase = oom ? NULL : malloc(((size_t)nchunks + 1) * sizeof *vbase);
    long *tbase = oom ? NULL : malloc(((size_t)nchunks + 1) * sizeof *tbase);
    long *xbase = oom ? NULL : malloc(((size_t)nchunks + 1) * sizeof *xbase); /* the corners listed with their own UV */
    if (!vbase || !tbase || !xbase) oom = 1;
    if (!oom) {
      vbase[0] = o.npos;
      tbase[0] = o.ntri;
      xbase[0] = 0;
      for (int c = 0; c < nchunks; c++) {
        vbase[c + 1] = vbase[c] + (part[c].npos - shared);
        tbase[c + 1] = tbase[c] + part[c].ntri;
        xbase[c + 1] = xbase[c] + part[c].nother;
      }
      if (vbase[nchunks] >= INT32_MAX / 3 || tbase[nchunks] >= INT32_MAX / 6 || xbase[nchunks] >= INT32_MAX / 2)
        oom = 1;
      if (!oom && (double)tbase[nchunks] > cap) over = 1;
    }
    if (over) oom = 1; /* (the parts are freed below, then the error set) */
    if (!oom) {
      size_t nv = (size_t)vbase[nchunks], nt = (size_t)tbase[nchunks], ov = (size_t)o.npos, ot = (size_t)o.ntri;
      size_t nx = (size_t)xbase[nchunks];
      /* the shared vertices' UVs are the output's first */
      o.vertex_uv = shared_uv;
      shared_uv = NULL;
      if (ch_alloc_resize((void **)&o.face, ov, nv ? nv : 1, sizeof *o.face) ||
          ch_alloc_resize((void **)&o.st, 2 * ov, 2 * (nv ? nv : 1), sizeof *o.st) ||
          ch_alloc_resize((void **)&o.h, ov, nv ? nv : 1, sizeof *o.h) ||
          ch_alloc_resize((void **)&o.vertex_uv, 2 * ov, 2 * (nv ? nv : 1), sizeof *o.vertex_uv) ||
          ch_alloc_resize((void **)&o.tri, 3 * ot, 3 * (nt ? nt : 1), sizeof *o.tri) ||
          ch_alloc_resize((void **)&o.group, ot, nt ? nt : 1, sizeof *o.group) ||
          ch_alloc_resize((void **)&o.corner_uv, 3 * ot, 3 * (nt ? nt : 1), sizeof *o.corner_uv) ||
          !(o.extra_uv = malloc(2 * (nx ? nx : 1) * sizeof *o.extra_uv)))
        oom = 1;
      else
        o.nextra = (int)nx;
    }
    if (!oom) {
#pragma omp parallel for schedule(dynamic, 1)
      for (int c = 0; c < nchunks; c++) {
        const ch_cut_out *q = &part[c];
        size_t v0 = (size_t)vbase[c], t0 = (size_t)tbase[c], nv = (size_t)(q->npos - shared);
        int delta = (int)vbase[c] - shared; /* the part's vertex x >= shared lands at x + delta */
        if (nv) {
          memcpy(&o.face[v0], q->face, nv * sizeof *o.face);
          memcpy(&o.st[2 * v0], q->st, 2 * nv * sizeof *o.st);
          memcpy(&o.h[v0], q->h, nv * sizeof *o.h);
          memcpy(&o.vertex_uv[2 * v0], q->vertex_uv, 2 * nv * sizeof *o.vertex_uv);
        }
        for (size_t t = 0; t < (size_t)q->ntri; t++)
          for (int k = 0; k < 3; k++) {
            int x = q->tri[3 * t + k];
            o.tri[3 * (t0 + t) + k] = x >= shared ? x + delta : x;
          }
        if (q->ntri) memcpy(&o.group[t0], q->group, (size_t)q->ntri * sizeof *o.group);
        /* (a part lists its corners with their own UV by increasing corner) */
        size_t x0 = (size_t)xbase[c];
        for (int j = 0; j < q->nother; j++)
          memcpy(&o.extra_uv[2 * (x0 + (size_t)j)], q->other_uv[j].uv, 2 * sizeof *o.extra_uv);
        for (size_t k = 0, j = 0; k < 3 * (size_t)q->ntri; k++) {
          int own = j < (size_t)q->nother && (size_t)q->other_uv[j].corner == k;
          o.corner_uv[3 * t0 + k] = own ? (int)(x0 + j++) : -1;
        }
        ch_cut_out_free(&part[c]); /* (not both copies at once) */
      }
      o.npos = o.cap_pos = (int)vbase[nchunks];
      o.ntri = o.cap_tri = (int)tbase[nchunks];
      if (first_out) {
#pragma omp parallel for schedule(static)
        for (int t = 0; t < base_faces; t++) first_out[t] += (int)tbase[t / CUT_CHUNK];
        /* (after the base's, the triangles the refinement added, or none) */
        first_out[base_faces] =
            norder > base_faces ? first_out[base_faces] + (int)tbase[base_faces / CUT_CHUNK] : o.ntri;
        ch_cut_blocks_place(&blocks, first_out);
        o.blocks = blocks;
        memset(&blocks, 0, sizeof blocks);
      }
    }
    for (int c = 0; c < nchunks && !oom; c++) {
      if (pstats[c].unresolved > 0) { /* chunks in order: the first is the first chunk's */
        if (stats.unresolved == 0) {
          memcpy(stats.unresolved_uv, pstats[c].unresolved_uv, sizeof stats.unresolved_uv);
          memcpy(stats.unresolved_box, pstats[c].unresolved_box, sizeof stats.unresolved_box);
        } else {
          for (int k = 0; k < 2; k++) {
            stats.unresolved_box[k] = fmin(stats.unresolved_box[k], pstats[c].unresolved_box[k]);
            stats.unresolved_box[2 + k] = fmax(stats.unresolved_box[2 + k], pstats[c].unresolved_box[2 + k]);
          }
        }
      }
      stats.unresolved += pstats[c].unresolved;
      stats.unresolved_at_seams += pstats[c].unresolved_at_seams;
      stats.junctions += pstats[c].junctions;
      stats.wall_triangles += pstats[c].wall_triangles;
    }
    free(vbase);
    free(tbase);
    free(xbase);
    free(shared_uv);
    shared_uv = NULL;
    for (int c = 0; c < nchunks; c++) ch_cut_out_free(&part[c]);
    free(part);
    free(pstats);
    if (over) {
      st = over_cap(err, pilot, cap, "the cut after round", stats.refine_rounds, base_faces);
      goto done;
    }
    if (oom) goto nomem;
  }
  if (thins(desc, reference_edge)) {
    double tt = omp_get_wtime();
    report(desc, pilot, stats.refine_rounds, "thinning", -1.0);
    int thinned = ch_cut_thin(&lb, edge_grid, &o);
    if (thinned < 0) goto nomem;
    ch_cut_out_shrink(&o); /* what thinning removed, back before the mesh is built */
    stats.thinned = thinned;
    stats.seconds_thin = omp_get_wtime() - tt;
  }
  stats.angle_deg = angle_deg;
  stats.seconds_refine = t1 - t0;
  stats.seconds_cut = omp_get_wtime() - t1;
  if (pilot->count_only) {
    stats.triangles = o.ntri;
    if (stats_out) *stats_out = stats;
    if (kept) { /* the caller may finish it */
      kept->o = o;
      kept->stats = stats;
      memset(&o, 0, sizeof o);
    }
    goto done;
  }
  st = embed_finish(surface, height, &o, 0, desc ? desc->progress : NULL, pilot->run, &stats, out, err);
  if (!st && stats_out) *stats_out = stats;
  goto done;
nomem:
  st = ch_error_set(err, CH_ERR_NOMEM, "out of memory for feature embedding");
done:
  ch_cut_blocks_free(&blocks);
  free(first_out);
  free(shared_uv);
  free(edge_grid);
  free(edge_sampled);
  free(split_edges);
  free(far.where);
  free(far.far_v);
  ch_cut_out_free(&o);
  ch_label_free(&lb);
  free_working_mesh(&w);
  free(fresh);
  return st;
}

ch_status ch_embed_build(const ch_surface *surface, const ch_tess_result *tess, const ch_height *height,
                         const ch_embed_desc *desc, ch_mesh *out, ch_embed_stats *stats, ch_error *err) {
  ch_embed_pilot one = {.run = 1};
  return embed_run(surface, tess, height, desc, &one, out, stats, NULL, err);
}

ch_status ch_embed_run(const ch_surface *surface, const ch_tess_result *tess, const ch_height *height,
                       const ch_embed_desc *desc, const ch_embed_pilot *pilot, ch_mesh *out, ch_embed_stats *stats,
                       ch_error *err) {
  ch_embed_pilot one = {.run = 1};
  return embed_run(surface, tess, height, desc, pilot ? pilot : &one, out, stats, NULL, err);
}

/* ch_embed_to_target's side of the count model (ch_count.h): the runs it
 * asks for, and the current and the closest full run. */
typedef struct target_runs {
  const ch_surface *surface;
  const ch_height *height;
  const ch_embed_desc *desc; /* the caller's (never NULL) */
  double default_angle;      /* the caller's normal_tolerance_deg (0: auto) */
  ch_embed_desc d;
  ch_embed_pilot pilot;
  long target;
  ch_tess_result cur_tess, best_tess;
  ch_mesh cur, best;
  ch_embed_stats cur_stats, best_stats;
  embed_kept kept; /* the last pilot's cut */
  int keep_tess;   /* the caller asked for the kept run's tessellation */
  long finish_target; /* > 0: the count a CH_COUNT_FINISH may add or
                         remove triangles towards where h is smooth */
  /* The closest run is dropped when another starts (two meshes at once
   * were a third of the peak memory where the first full run missed):
   * the last run is the closest whenever the search lands, and where it
   * does not, the closest is run again from its request. */
  ch_count_request best_request;
  int best_dropped;
  ch_segtree curves; /* for edge_priority */
  ch_error *err;
} target_runs;

/* The base's edges that are raised first where many jump together
 * (ch_tess_desc.edge_priority): the nearest the curves, so that the finer
 * rate goes where the features are (the margin of the full runs below
 * asks for the same, and takes the rest back where h is smooth). */
static double edge_priority(void *ctx, const double a[2], const double b[2]) {
  const target_runs *r = ctx;
  const double mid[2] = {0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])};
  double d2 = INFINITY, t;
  ch_segtree_closest(&r->curves, r->height->set, 0, r->curves.num_leaves, mid, INFINITY, &d2, &t);
  return d2;
}

static void target_drop_current(target_runs *r) {
  ch_tess_free(&r->cur_tess);
  ch_mesh_free(&r->cur);
  ch_cut_out_free(&r->kept.o);
  memset(&r->cur_tess, 0, sizeof r->cur_tess);
  memset(&r->cur, 0, sizeof r->cur);
  memset(&r->kept, 0, sizeof r->kept);
}

static ch_status target_run(void *ctx, const ch_count_request *rq, ch_count_reply *rp) {
  target_runs *r = ctx;
  ch_status st;
  if (rq->kind == CH_COUNT_KEEP) {
    ch_tess_free(&r->best_tess);
    ch_mesh_free(&r->best);
    r->best_tess = r->cur_tess;
    r->best = r->cur;
    r->best_stats = r->cur_stats;
    r->best_request = *rq;
    r->best_request.kind = CH_COUNT_FULL;
    r->best_dropped = 0;
    memset(&r->cur_tess, 0, sizeof r->cur_tess);
    memset(&r->cur, 0, sizeof r->cur);
    return CH_OK;
  }
  if (rq->kind == CH_COUNT_FINISH) {
    if (!r->kept.o.tri) /* (a sampled pilot keeps no cut: ch_count_reply.estimated) */
      return ch_error_set(r->err, CH_ERR_INTERNAL, "feature embedding: a pilot without a cut to finish");
    r->cur_stats = r->kept.stats;
    st = embed_finish(r->surface, r->height, &r->kept.o, r->finish_target, r->d.progress, r->pilot.run, &r->cur_stats,
                      &r->cur, r->err);
    ch_cut_out_free(&r->kept.o);
    memset(&r->kept, 0, sizeof r->kept);
    if (!st) rp->count = (double)r->cur_stats.triangles;
    return st;
  }
  target_drop_current(r);
  if (r->best.num_faces > 0) {
    ch_tess_free(&r->best_tess);
    ch_mesh_free(&r->best);
    memset(&r->best_tess, 0, sizeof r->best_tess);
    memset(&r->best, 0, sizeof r->best);
    r->best_dropped = 1;
  }
  /* The base closest to the count asked for, not just within 5%: on a base
   * whose edges share one length (the plane's) the counts jump 10% a step
   * at 520k, and a few percent in the count model's estimate moved the
   * base that far. The warp places its own. */
  ch_tess_desc td = {.target_triangles = rq->base,
                     .warp = r->d.warp,
                     .corner_st = 1,
                     .closest = !r->d.warp,
                     .edge_priority = r->d.warp || !r->curves.num_leaves ? NULL : edge_priority,
                     .edge_priority_ctx = r};
  if ((st = ch_tess_build(r->surface, &td, &r->cur_tess, r->err))) return st;
  if (!(r->pilot.reference_edge > 0.0)) {
    /* The mean UV edge at the target's density, from this run's area. */
    const ch_mesh *m = &r->cur_tess.mesh;
    double area = 0.0;
    for (int f = 0; f < m->num_faces; f++) {
      const double *a = &m->uvs[2 * (size_t)m->corner_uv[3 * (size_t)f]];
      const double *b = &m->uvs[2 * (size_t)m->corner_uv[3 * (size_t)f + 1]];
      const double *c = &m->uvs[2 * (size_t)m->corner_uv[3 * (size_t)f + 2]];
      area += 0.5 * fabs((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]));
    }
    r->pilot.reference_edge = sqrt(2.0 * area / (double)r->target);
  }
  /* The angle step, coarsened by 1.5 a step at a time (the same rounding
   * whether the steps come one by one or at once). */
  r->d.normal_tolerance_deg = r->default_angle;
  if (rq->coarsenings > 0) {
    double step = ch_embed_angle_deg(r->pilot.reference_edge);
    for (int k = 0; k < rq->coarsenings; k++) step *= 1.5;
    r->d.normal_tolerance_deg = step;
  }
  /* A full run is cut first and finished below, so that where its count
   * misses the target it can make up the difference where h is smooth
   * (ch_cut_densify, ch_cut_coarsen) rather than run again at another
   * base. */
  r->pilot.count_only = 1;
  r->pilot.full = rq->kind == CH_COUNT_FULL;
  r->pilot.takes_back = rq->kind == CH_COUNT_FULL && rq->aim > (1.0 + LANDED) * (double)r->target;
  r->pilot.run = rq->run;
  /* Pilots of large targets sample the surface (their count is what the
   * level model needs, not their cut; a pilot that would land is not
   * finished then, but the targets where one lands are small). */
  r->pilot.sampled = rq->kind == CH_COUNT_PILOT && !r->d.warp && r->cur_tess.mesh.num_faces >= SAMPLE_MIN_BASE &&
                     !thins(&r->d, r->pilot.reference_edge);
  int over = 0;
  r->pilot.over_cap = &over;
  r->pilot.release_corner_st = &r->cur_tess.corner_st;
  r->pilot.release_tess = r->keep_tess ? NULL : &r->cur_tess;
  st = embed_run(r->surface, &r->cur_tess, r->height, &r->d, &r->pilot, &r->cur, &r->cur_stats, &r->kept, r->err);
  r->pilot.release_corner_st = NULL;
  r->pilot.release_tess = NULL;
  r->pilot.over_cap = NULL;
  if (st && over) { /* the count model decides (its error keeps the message set here) */
    target_drop_current(r);
    rp->over_cap = 1;
    return CH_OK;
  }
  if (st) return st;
  rp->base = r->cur_stats.base_triangles;
  rp->count = (double)r->cur_stats.triangles;
  rp->estimated = r->pilot.sampled;
  for (int d = 0; d < CH_EMBED_LEVELS; d++) /* (two triangles for each) */
    rp->level_added[d < CH_COUNT_LEVELS ? d : CH_COUNT_LEVELS - 1] +=
        2.0 * (r->cur_stats.crossings_at_level[d] + r->cur_stats.splits_at_level[d]);
  if (rq->kind == CH_COUNT_FULL) {
    /* The warp places the triangles where its camera sees them: not here. */
    r->finish_target = r->d.warp ? 0 : r->target;
    ch_count_request finish = *rq;
    finish.kind = CH_COUNT_FINISH;
    st = target_run(r, &finish, rp);
    r->finish_target = 0;
    if (st) return st;
  }
  return CH_OK;
}

ch_status ch_embed_to_target(const ch_surface *surface, const ch_height *height, const ch_embed_desc *desc,
                             long target, ch_tess_result *tess, ch_mesh *out, ch_embed_stats *stats, int *passes,
                             ch_error *err) {
  if (tess) memset(tess, 0, sizeof *tess);
  memset(out, 0, sizeof *out);
  ch_embed_desc none = {0};
  target_runs r = {.surface = surface,
                   .height = height,
                   .desc = desc ? desc : &none,
                   .target = target,
                   .keep_tess = !!tess,
                   .err = err};
  r.d = *r.desc;
  r.default_angle = r.d.normal_tolerance_deg;
  ch_status st;
  /* The fewest triangles the base mesh gives (every edge at rate 1). */
  long fewest = ch_tess_fewest_triangles(surface);
  if (target < fewest) r.target = target = fewest;
  /* The angle step shapes only grooves (their u lines, the caps of open
   * ends, the thinning's normals): with step curves alone a coarser one
   * changes nothing, and each coarsening would rerun the pilot (1000
   * small loops: four times, for the same answer). */
  int has_grooves = 0, has_u = 0;
  for (int c = 0; c < height->set->num_curves; c++) {
    const ch_curve *cv = &height->set->curves[c];
    has_grooves |= cv->kind == CH_CURVE_GROOVE;
    has_u |= cv->kind == CH_CURVE_GROOVE && cv->profile.kind == CH_PROFILE_U;
  }
  /* Full runs aim above the target by 12% of what the features add,
   * and embed_finish takes that back where h is smooth: near the features
   * the base is then as fine as a larger target's. Over the plane that
   * kept L1 at or below what runs aimed at the target gave (glyphs at
   * 2.1M: 10% lower), for the coarsening's time. Under a warp the finish
   * leaves the count as it is: no margin. */
  ch_count_desc cd = {.target = target,
                      .fewest = fewest,
                      .can_coarsen = !(r.d.normal_tolerance_deg > 0.0) && has_grooves,
                      .has_u = has_u,
                      .take_back = r.d.warp ? 0.0 : COARSEN_SHARE,
                      .feature_margin = r.d.warp ? 0.0 : 0.12};
  ch_count_result res;
  if (!r.d.warp && (st = ch_segtree_build(&r.curves, height->set, err))) return st;
  st = ch_count_search(&cd, target_run, &r, &res);
  if (!st && r.best_dropped) { /* a later run missed more: the closest again */
    ch_count_reply again = {0};
    if (!(st = target_run(&r, &r.best_request, &again))) {
      ch_count_request keep = r.best_request;
      keep.kind = CH_COUNT_KEEP;
      st = target_run(&r, &keep, &again);
      res.runs++;
    }
  }
  target_drop_current(&r);
  ch_segtree_free(&r.curves);
  if (passes) *passes = res.runs;
  if (st) {
    ch_tess_free(&r.best_tess);
    ch_mesh_free(&r.best);
    return st;
  }
  if (tess)
    *tess = r.best_tess;
  else
    ch_tess_free(&r.best_tess);
  *out = r.best;
  if (stats) *stats = r.best_stats;
  return CH_OK;
}
