/* ch_segtree: a bounding-box hierarchy over a curve set's segments, for
 * nearest-segment queries whose cost follows the segments near the query
 * point rather than those in the set or in one curve: the closest segment
 * of one curve (a path of 500k segments), or of any step curve within a
 * radius (10,000 small loops, whose grid cells at a coarse mesh's radius
 * hold thousands of segments).
 *
 * Curves are ordered along a Z-order curve of their boxes' centres, step
 * curves first, each curve's segments kept together in their order (so a
 * curve, and all the step curves, are ranges of leaves); nodes of an
 * implicit tree over that order, LEAF segments at the bottom and two
 * children per node above, store their boxes level by level. Flat arrays;
 * queries use no allocation and no recursion (a stack of 2 per level), so
 * many threads may query one tree. */
#ifndef CH_SEGTREE_H
#define CH_SEGTREE_H

#include "ch_curves.h"
#include "ch_error.h"

#ifdef __cplusplus
extern "C" {
#endif

enum { CH_SEGTREE_LEAF = 4, CH_SEGTREE_MAX_LEVELS = 32 };

typedef struct ch_segtree {
  int num_leaves;          /* the set's segments */
  int num_levels;          /* level 0: nodes of LEAF segments; the last: one root */
  int level_start[CH_SEGTREE_MAX_LEVELS + 1]; /* offset of each level's nodes in box */
  double (*box)[4];        /* per node: umin vmin umax vmax of its segments' control points */
  int *segment;            /* per leaf: its segment */
  int *curve_first;        /* per curve: its first leaf (its segments follow in order) */
  int num_step_leaves;     /* leaves [0, num_step_leaves) are the step curves' */
} ch_segtree;

/* Builds the tree over set's segments (the set must outlive it and stay
 * unchanged). CH_ERR_NOMEM on failure, leaving *tree empty. */
ch_status ch_segtree_build(ch_segtree *tree, const ch_curve_set *set, ch_error *err);

void ch_segtree_free(ch_segtree *tree);

/* The segment closest to q among leaves [first, last) whose squared
 * distance is below max_d2 (INFINITY: any); ties go to the lowest segment
 * index, so the answer is the one a scan of those segments in index order
 * keeping strictly smaller distances gives (ch_curve_closest's). Returns
 * the segment, or -1 if none is that near, with its squared distance and
 * parameter in *d2 and *t (left alone on -1). Thread-safe. */
int ch_segtree_closest(const ch_segtree *tree, const ch_curve_set *set, int first, int last, const double q[2],
                       double max_d2, double *d2, double *t);

/* The leaves of curve c of set: [*first, *last). */
static inline void ch_segtree_curve(const ch_segtree *tree, const ch_curve_set *set, int c, int *first, int *last) {
  *first = tree->curve_first[c];
  *last = *first + set->curves[c].num_segments;
}

#ifdef __cplusplus
}
#endif
#endif
