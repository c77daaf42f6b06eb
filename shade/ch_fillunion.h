/* ch_fillunion: painted fills united as an SVG viewer paints them
 * (docs/svg.md "Fills").
 *
 * A painted fill is a step curve with the fill height on its inside and 0
 * outside (docs/spec.md §2). Where fills overlap, share an edge, lie one
 * inside another, or cross themselves, some outline's 0 side lies inside a
 * fill, and h_step would blend between the outlines instead of showing the
 * painted region. Every fill has the same height, so what the drawing shows
 * is the union of the painted regions: this replaces the outlines of the
 * fills involved by the union's boundary. */
#ifndef CH_FILLUNION_H
#define CH_FILLUNION_H

#include "ch_curves.h"
#include "ch_error.h"

#ifdef __cplusplus
extern "C" {
#endif

/* A curve's fill rule (SVG 1.1 §11.3 'fill-rule'), or none for curves that
 * are not painted fills. */
enum { CH_FILL_NONE = 0, CH_FILL_NONZERO = 1, CH_FILL_EVENODD = 2 };

typedef struct ch_fillunion_report {
  int united;  /* fill curves whose outline was replaced (dropped ones included) */
  int dropped; /* of them, curves with nothing left (inside other fills) */
  /* Where the union could not be closed into loops (the set is then left
   * as it was): at is a UV point there. */
  int failed;
  double at[2];
  int curve_a, curve_b; /* the fills that meet there (-1: none) */
} ch_fillunion_report;

/* Replaces the outlines of the painted fills that overlap, share an edge,
 * nest, or cross themselves by the boundary of the painted region: closed
 * loops with that region on their left. rule[c] gives curve c's fill rule;
 * flipped[k] is 1 where subpath k was reversed after it was read (so that
 * nonzero's winding is counted in the drawn direction), NULL for none.
 * Each loop goes to the first of the curves its pieces come from, in
 * place of that curve's subpaths; a fill with no loop left is removed.
 * Fills that need no change, and all other curves, keep their segments as
 * they are. CH_ERR_NOMEM only: a union that does not close leaves the set
 * unchanged and says where in report. */
ch_status ch_fillunion_apply(ch_curve_set *set, const unsigned char *rule, const unsigned char *flipped,
                             ch_fillunion_report *report, ch_error *err);

#ifdef __cplusplus
}
#endif
#endif
