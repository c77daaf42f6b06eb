/* ch_refine: the working mesh of the feature embedding (see ch_embed.h): the
 * tessellation with its edges, the points where they cross from one piece
 * into the next (ch_label), and the conforming red/green splits of edges
 * and triangles until each triangle holds what a cut can take (chords
 * between its edges' crossings, at most one junction). */
#ifndef CH_REFINE_INTERNAL_H
#define CH_REFINE_INTERNAL_H

#include <stdint.h>

#include "ch_error.h"
#include "ch_label_internal.h"
#include "ch_surface.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- the working mesh ------------------------------------------------------ */
/* A vertex of the working mesh. */
typedef struct ch_refine_vert {
  double uv[2]; /* UV where labels and h are read (the chart of its face) */
  double st[2];
  int face;
  uint64_t label;
  double h;
} ch_refine_vert;

/* A triangle of the working mesh, in one face of the base surface. */
typedef struct ch_refine_tri {
  int v[3];
  int face;
  double uv[3][2]; /* corner UVs (face-varying) */
  double st[3][2]; /* corner parameters in face */
} ch_refine_tri;

/* A point where an edge passes from one piece into the next. */
typedef struct ch_refine_crossing {
  double x;           /* fraction from the edge's a to its b */
  uint64_t la, lb;    /* the pieces on a's and on b's side */
  double ha, hb;      /* h just inside each */
  int copy_a, copy_b; /* output vertices (equal where h does not jump) */
} ch_refine_crossing;

/* An edge of the working mesh with the crossings found along it. */
typedef struct ch_refine_edge {
  int a, b;   /* vertices, a < b */
  int tri, k; /* canonical triangle (the first) and its edge k: v[k] -> v[k+1] */
  int ncross;
  ch_refine_crossing *cross; /* ncross, by increasing x; owned */
  int mid;                   /* midpoint vertex when split (the edge is then gone), else -1 */
  int half[2];               /* when split: the halves from a and from b */
} ch_refine_edge;

/* Where the edges' crossing lists live: blocks per thread, handed out in
 * order and freed all at once with the working mesh (a malloc per crossed
 * edge was 600k small chunks at 2.1M triangles, and a serial pass freeing
 * them). Aligned to a cache line: each thread bumps its own. */
typedef struct ch_refine_pool {
  _Alignas(64) char *block; /* the block being filled (a cache line each) */
  size_t used, size;        /* in it */
  void **blocks;            /* every block, to free */
  int nblocks, cap;
} ch_refine_pool;

/* The working mesh: the tessellation, each corner with its (s,t) in its
 * face, refined in place (owns its arrays; ch_embed frees them). */
typedef struct ch_refine_mesh {
  const ch_surface *surface;
  ch_refine_vert *verts;
  int nverts, cap_verts;
  ch_refine_tri *tris;
  int ntris, cap_tris;
  ch_refine_edge *edges;
  int nedges, cap_edges;
  int *tri_edge; /* 3 per triangle */
  int cap_tri_edge;
  ch_refine_pool *pools; /* one per thread (ch_refine_pools_init): the edges' crossings */
  int npools;
} ch_refine_mesh;

/* Makes w's crossing pools, one for each of omp_get_max_threads(); 0 or -1
 * when out of memory. */
int ch_refine_pools_init(ch_refine_mesh *w);

/* Frees every crossing list of w at once (the edges' cross pointers then
 * dangle: free the edges too, or forget them). */
void ch_refine_pools_free(ch_refine_mesh *w);

/* The boundary of a triangle as a cycle of nodes: its corners and, between
 * them, the crossings of its edges. Each crossing joins the piece before it
 * to the piece after it; inside the triangle it is one end of a chord to the
 * crossing with the same two pieces. */
typedef struct ch_refine_node {
  int corner;               /* vertex of a corner, -1 for a crossing */
  int edge;                 /* local edge holding a crossing */
  uint64_t lprev, lnext;    /* pieces before and after it (a corner: its own, twice) */
  int copy_prev, copy_next; /* output vertices in those pieces */
  double hprev, hnext;      /* h just inside each */
  double uv[2], st[2];
  int pair; /* the other end of its chord, -1 */
} ch_refine_node;

/* Whether vertex v's UV (where its label was read: its home face's chart)
 * is another chart's point than uv, a corner's or an edge end's UV in its
 * own triangle: v lies on a UV seam. */
int ch_refine_on_seam(const ch_refine_mesh *w, int v, const double uv[2]);

/* How a triangle's boundary can be cut (ch_refine_classify). */
typedef enum ch_refine_cut { CUT_NONE, CUT_REGIONS, CUT_COMPLEX } ch_refine_cut;

/* Every boundary between pieces along e. Labels are sampled about delta
 * apart; from each sample whose label differs from the next, bisection
 * (in the bracket a fast path narrowed) finds a change to 1e-12 of the
 * edge, and the search goes on from there, so lines closer together
 * than the samples (the break lines near a u groove's rim) are all found.
 * h is read on both sides. */
int ch_refine_crossings(const ch_label_ctx *lb, const ch_refine_mesh *w, ch_refine_edge *e,
                        double delta); /* 0, or -1: out of memory */

/* The first change of label on the UV segment from p (label lp) towards q
 * (label lq, another), as the crossing search finds it on an edge (its
 * fast paths to 1e-12 of the segment, then bisection to tol of it): at
 * fractions [*lo, *hi] of the segment, p's label at *lo and another at
 * *hi. */
void ch_refine_segment_change(const ch_label_ctx *lb, const double p[2], const double q[2], uint64_t lp, uint64_t lq,
                              double tol, double *lo, double *hi);

/* out = a + x (b - a). */
void ch_refine_lerp2(const double a[2], const double b[2], double x, double out[2]);

/* The (s,t) in face of a new point from its UV (UV is linear in each face,
 * its (s,t) is not: an N-gon's sub-faces tile the parameter plane, so
 * interpolating (s,t) across a triangle can leave the domain). st holds
 * the interpolated guess, kept if the point is not found. */
void ch_refine_locate_st(const ch_surface *surface, int face, const double uv[2], double st[2]);

/* Whether triangle t needs splitting: its crossings do not make chords and
 * one junction, or a piece that none of its boundary touches hides inside,
 * or it is coarse over a rounded cap. */
int ch_refine_needed(const ch_label_ctx *lb, const ch_refine_mesh *w, int t, int only_uncut, int round);

/* Whether a corner of triangle t is a vertex of a UV seam labelled in its
 * other chart (its home face's UV) with another piece than t's UV there
 * gives: the features differ across the seam, h jumps there, and the one
 * shared vertex (which keeps the mesh closed) takes the other chart's h. */
int ch_refine_at_differing_seam(const ch_label_ctx *lb, const ch_refine_mesh *w, int t);

/* Whether the cut would fan triangle t (ch_cut_triangle: its crossings
 * do not make chords and one junction) where splitting may still help:
 * not when it holds more nodes than a cut takes (ch_refine_needed's
 * DENSE_ROUNDS), nor at a differing seam (smaller triangles there still
 * share the vertex on the seam). */
int ch_refine_uncut(const ch_label_ctx *lb, const ch_refine_mesh *w, int t);

/* Labels (ch_label_at) and h of the vertices from `from` on, in parallel. */
void ch_refine_label_vertices(const ch_label_ctx *lb, ch_refine_mesh *w, int from);

/* The unique edges of the triangles, sorted by vertex pair (a counting
 * sort by the lower vertex, then each short run by the other); the
 * canonical triangle of an edge is the lowest one holding it. Refinement
 * then updates them in place (ch_refine_split). Errors: CH_ERR_NOMEM. */
ch_status ch_refine_build_edges(ch_refine_mesh *w, ch_error *err);

/* The UV length of e in its canonical triangle. */
double ch_refine_edge_length(const ch_refine_mesh *w, const ch_refine_edge *e);

/* New vertex at the midpoint of edge i (in its canonical triangle's
 * chart), and the edge's two halves: half[0] from a to it, half[1] from b
 * (their canonical triangles are set when the triangles split). Its (s,t)
 * is interpolated along the edge until ch_refine_locate_new finds it. */
int ch_refine_add_midpoint(ch_refine_mesh *w, int i); /* -1: out of memory */

/* The exact (s,t) of vertices from..nverts-1 in their faces
 * (ch_refine_locate_st), in parallel: numbering the midpoints is serial,
 * finding them on the surface need not be. */
void ch_refine_locate_new(ch_refine_mesh *w, int from);

/* Splits every triangle with midpoints on its edges (red: 4 children,
 * green: 2 or 3), in parallel: the first child takes the parent's slot,
 * the others are appended, and the edges are updated in place (a split
 * edge gives way to its halves, each parent gets as many new inner edges
 * as it has split edges), so a round costs what it changes, not the size
 * of the mesh. split_edges: the nsplit edges given midpoints since the
 * last split (their crossings are kept for ch_refine_inherit_crossings).
 * The result does not depend on the thread count. fresh[t]
 * (resized with the triangles) tells the children from the untouched. */
ch_status ch_refine_split(ch_refine_mesh *w, const int *split_edges, int nsplit, unsigned char **fresh, ch_error *err);

/* The crossings of split edge i's halves from its own (ch_refine_split
 * keeps them for this), which are then freed. A half takes those on its
 * side, at twice the fraction from its end, where it lies in the split
 * edge's chart, its end is on no UV seam, they lead from its end's label
 * to the midpoint's, the labels at the half's own samples (delta apart,
 * as ch_refine_crossings reads them) are the pieces they say, and between
 * two samples they go as the search goes (none between two of one piece,
 * none into the far sample's piece but the last): the points the search
 * would find (to its tolerance), without narrowing to each again. Other
 * halves are left to ch_refine_crossings (ncross -1). Call once the
 * midpoints are labelled. 0, or -1 out of memory. */
int ch_refine_inherit_crossings(const ch_label_ctx *lb, ch_refine_mesh *w, int i, double delta);

/* The UV and (s,t) of edge e at fraction x from e->a, in its canonical triangle. */
void ch_refine_edge_point(const ch_refine_mesh *w, const ch_refine_edge *e, double x, double uv[2], double st[2]);

/* The boundary's nodes of triangle t into nodes[cap]; -1 if there are more
 * (the triangle is then refined, or fanned once refinement is over). */
int ch_refine_gather_nodes_into(const ch_refine_mesh *w, int t, ch_refine_node *nodes, int cap);

/* ch_refine_gather_nodes_into with cap MAX_NODES. */
int ch_refine_gather_nodes(const ch_refine_mesh *w, int t, ch_refine_node *nodes);

/* Pairs the crossings into chords: two crossings between the same two
 * pieces, in opposite directions. Crossings left unpaired must be where
 * pieces meet at one point inside (a junction: three or more of them, each
 * piece between two consecutive ones). CUT_REGIONS when that works out, no
 * two chords cross and no chord separates the junction's crossings;
 * CUT_COMPLEX otherwise (refined, or fanned if refinement is over). */
ch_refine_cut ch_refine_classify(ch_refine_node *nodes, int m);

#ifdef __cplusplus
}
#endif
#endif
