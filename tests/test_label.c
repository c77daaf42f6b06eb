/* The piece labels of the embedding (tess/ch_label) on a scene whose sides
 * a person can tell: one straight v groove and one step circle, apart.
 * For random points, decided independently by a scan of each curve
 * (ch_curve_closest, its signed distance positive on the left):
 *
 * - within the step radius of the circle (and off the groove): inside it,
 *   the step part is (circle + 1) << 1 | (the point is on its left); on
 *   its outside 0, as no other step curve touches it (a free loop: the
 *   outsides of all such loops are one piece, so the mesh is not cut
 *   where the nearest loop changes);
 * - nor are a circle inside another, or one near an open step curve;
 * - two step circles that cross each other are not free: their outsides
 *   keep the curve and the side (at their crossing points the outsides of
 *   both would meet the inside of the other under one label);
 * - inside the groove (off the circle's radius): the groove part names
 *   the groove, and two points share a label exactly when they lie on the
 *   same half of the v (t < 0 or t > 0, its break at 0);
 * - away from both: label 0, and a quiet cell never holds a label;
 * - h of a point's own piece, read there, is h.
 * And the crossings a split edge's halves take from it (the refinement's,
 * built on these labels) against the search and the labels themselves. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ch_groove.h"
#include "ch_height.h"
#include "ch_label_internal.h"
#include "ch_math.h"
#include "ch_refine_internal.h"
#include "ch_test.h"

static const char svg[] =
    "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
    "<path d='M -10 30 L 110 34' data-profile='v' data-width='8' data-depth='0.02'/>"
    "<circle cx='50' cy='70' r='15' data-kind='step' data-left='0.01' data-right='0.03'/>"
    "</svg>";

/* A scene of curves with its height and labeler (edge: the mesh's mean
 * edge; reach twice it). */
typedef struct label_scene {
  ch_curve_set set;
  ch_height height;
  ch_label_ctx lb;
} label_scene;

static int scene_open(label_scene *sc, const char *text, const char *name, double radius, double edge) {
  ch_error err = {0};
  if (ch_curves_parse_svg(text, strlen(text), name, &sc->set, &err) != CH_OK) return 0;
  ch_height_desc hd = {.dci_resolution = 256, .step_method = CH_RECON_EXACT};
  if (ch_height_init(&sc->height, &sc->set, &hd, &err) != CH_OK) {
    ch_curves_free(&sc->set);
    return 0;
  }
  if (ch_label_init(&sc->lb, &sc->height, NULL, radius, 0.0, 7.0 * CH_PI / 180.0, 1.0, edge, 2.0 * edge, &err) !=
      CH_OK) {
    ch_label_free(&sc->lb);
    ch_height_free(&sc->height);
    ch_curves_free(&sc->set);
    return 0;
  }
  return 1;
}

/* A scene as the embedding's crossing search sees it at mean edge
 * `edge`: the step radius four edges, junctions an eighth of an edge,
 * walls 1e-5 of the largest |h| a curve sets. */
static int search_scene_open(label_scene *sc, const char *text, const char *name, double edge, double largest_h) {
  if (!scene_open(sc, text, name, 4.0 * edge, edge)) return 0;
  sc->lb.junction_size = edge / 8.0;
  sc->lb.wall_tol = 1e-5 * largest_h + 1e-12;
  return 1;
}

static void scene_close(label_scene *sc) {
  ch_label_free(&sc->lb);
  ch_height_free(&sc->height);
  ch_curves_free(&sc->set);
}

static void test_labels(void) {
  const double radius = 0.02, edge = 0.005;
  label_scene sc;
  REQUIRE(scene_open(&sc, svg, "labels.svg", radius, edge));
  REQUIRE(sc.set.num_curves == 2);
  int groove = sc.set.curves[0].kind == CH_CURVE_GROOVE ? 0 : 1, circle = 1 - groove;
  REQUIRE(sc.set.curves[circle].kind == CH_CURVE_STEP);
  const double width = sc.set.curves[groove].width;
  int in_step = 0, in_groove = 0, outside = 0, bad_step = 0, bad_groove = 0, bad_zero = 0, bad_quiet = 0, bad_h = 0;
  int inside_left = 0, inside_right = 0;
  /* The circle's centre and radius in UV, from its segments' ends. */
  double centre[2] = {0.0, 0.0}, ring = 0.0;
  const ch_curve *cc = &sc.set.curves[circle];
  for (int i = cc->first_segment; i < cc->first_segment + cc->num_segments; i++)
    for (int k = 0; k < 2; k++) centre[k] += sc.set.segments[i].p[0][k] / cc->num_segments;
  ring = hypot(sc.set.segments[cc->first_segment].p[0][0] - centre[0], sc.set.segments[cc->first_segment].p[0][1] - centre[1]);
  uint64_t half_label[2] = {0, 0};
  for (int i = 0; i < 20000; i++) {
    double q[2] = {0.02 + 0.96 * ch_test_rnd(), 0.02 + 0.96 * ch_test_rnd()};
    ch_curve_point g, c;
    ch_curve_closest(&sc.set, groove, q, &g);
    ch_curve_closest(&sc.set, circle, q, &c);
    uint64_t l = ch_label_at(&sc.lb, q), gp = l >> 32, sp = l & 0xffffffffu;
    double margin = 1e-4;
    if (fabs(c.distance) < radius - margin && c.distance > margin && g.distance > 0.5 * width + margin) {
      in_step++;
      int inside = hypot(q[0] - centre[0], q[1] - centre[1]) < ring;
      inside_left += inside && c.signed_distance >= 0.0;
      inside_right += inside && c.signed_distance < 0.0;
      bad_step += gp != 0 || sp != (inside ? ((uint64_t)(circle + 1) << 1 | (c.signed_distance >= 0.0)) : 0);
    } else if (g.distance < 0.5 * width - margin && fabs(g.signed_distance) > margin && c.distance > radius + margin) {
      in_groove++;
      int half = g.signed_distance > 0.0;
      bad_groove += sp != 0 || GROOVE_CURVE(gp) != groove;
      if (!half_label[half]) half_label[half] = l;
      bad_groove += l != half_label[half];
    } else if (g.distance > 0.5 * width + margin && c.distance > radius + margin) {
      outside++;
      bad_zero += l != 0;
    }
    bad_quiet += ch_label_quiet(&sc.lb, q) && l != 0;
    double h = ch_height_eval(&sc.height, q[0], q[1]);
    bad_h += fabs(ch_label_piece_height(&sc.lb, l, q, q) - h) > 1e-9;
  }
  CHECK_MSG(in_step > 100 && in_groove > 100 && outside > 1000, "%d %d %d", in_step, in_groove, outside);
  CHECK_MSG(bad_step == 0, "%d of %d step labels wrong", bad_step, in_step);
  /* the inside is one side of the circle */
  CHECK_MSG((inside_left > 50) != (inside_right > 50) && (inside_left == 0 || inside_right == 0), "%d %d", inside_left,
            inside_right);
  CHECK_MSG(bad_groove == 0, "%d of %d groove labels wrong", bad_groove, in_groove);
  CHECK(half_label[0] != 0 && half_label[1] != 0 && half_label[0] != half_label[1]);
  CHECK_MSG(bad_zero == 0, "%d of %d labels away from the curves not 0", bad_zero, outside);
  CHECK_MSG(bad_quiet == 0, "%d quiet points with a label", bad_quiet);
  CHECK_MSG(bad_h == 0, "%d points where the piece's h is not h", bad_h);
  scene_close(&sc);
}

static const char crossing_svg[] =
    "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
    "<g data-kind='step' data-left='0' data-right='0.01'>"
    "<circle cx='40' cy='50' r='15'/><circle cx='60' cy='50' r='15'/></g>"
    "</svg>";

/* Two crossing circles: on the outside of each, near it and off the
 * other, the label still names the nearest circle and its side. */
static void test_crossing_loops(void) {
  const double radius = 0.03;
  label_scene sc;
  REQUIRE(scene_open(&sc, crossing_svg, "crossing.svg", radius, 0.005));
  REQUIRE(sc.set.num_curves == 2);
  int near = 0, bad = 0;
  for (int i = 0; i < 20000; i++) {
    double q[2] = {ch_test_rnd(), ch_test_rnd()};
    ch_curve_point a, b;
    ch_curve_closest(&sc.set, 0, q, &a);
    ch_curve_closest(&sc.set, 1, q, &b);
    const ch_curve_point *n = a.distance < b.distance ? &a : &b;
    if (!(n->distance < radius - 1e-4 && fabs(a.distance - b.distance) > 1e-4 && n->distance > 1e-4)) continue;
    near++;
    int curve = a.distance < b.distance ? 0 : 1;
    bad += (ch_label_at(&sc.lb, q) & 0xffffffffu) != ((uint64_t)(curve + 1) << 1 | (n->signed_distance >= 0.0));
  }
  CHECK_MSG(near > 1000, "%d", near);
  CHECK_MSG(bad == 0, "%d of %d labels near crossing loops wrong", bad, near);
  scene_close(&sc);
}

static const char nested_svg[] =
    "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
    "<g data-kind='step' data-left='0' data-right='0.01'>"
    "<circle cx='30' cy='50' r='20'/><circle cx='30' cy='50' r='10'/>"
    "<circle cx='75' cy='50' r='8'/><path d='M 88 0 L 88 100'/>"
    "<circle cx='70' cy='15' r='5'/></g>"
    "</svg>";

/* Loops whose outsides must keep their labels: a circle inside another
 * (a letter's counter: the body between them would be a band as thin as
 * the stroke between two label-0 outsides), and a circle 5 units (0.05)
 * from an open step line, within twice the radius (0.03). A circle far
 * from both is free: label 0 on its outside. */
static void test_nested_loops(void) {
  const double radius = 0.03;
  label_scene sc;
  REQUIRE(scene_open(&sc, nested_svg, "nested.svg", radius, 0.005));
  REQUIRE(sc.set.num_curves == 5);
  int near[5] = {0}, bad[5] = {0};
  for (int i = 0; i < 40000; i++) {
    double q[2] = {ch_test_rnd(), ch_test_rnd()};
    ch_curve_point p[5];
    int c = 0;
    for (int k = 0; k < 5; k++) {
      ch_curve_closest(&sc.set, k, q, &p[k]);
      if (p[k].distance < p[c].distance) c = k;
    }
    int alone = 1;
    for (int k = 0; k < 5; k++) alone &= k == c || p[k].distance > p[c].distance + 1e-4;
    if (!(alone && p[c].distance < radius - 1e-4 && p[c].distance > 1e-4)) continue;
    /* the circles' centres in UV: the mean of their segments' starts */
    const ch_curve *cv = &sc.set.curves[c];
    double centre[2] = {0.0, 0.0}, r0;
    for (int g = cv->first_segment; g < cv->first_segment + cv->num_segments; g++)
      for (int k = 0; k < 2; k++) centre[k] += sc.set.segments[g].p[0][k] / cv->num_segments;
    r0 = hypot(sc.set.segments[cv->first_segment].p[0][0] - centre[0], sc.set.segments[cv->first_segment].p[0][1] - centre[1]);
    if (c == 3 || hypot(q[0] - centre[0], q[1] - centre[1]) < r0) continue; /* the outsides of the circles */
    near[c]++;
    uint64_t named = (uint64_t)(c + 1) << 1 | (p[c].signed_distance >= 0.0);
    bad[c] += (ch_label_at(&sc.lb, q) & 0xffffffffu) != (c == 4 ? 0 : named);
  }
  for (int c = 0; c < 5; c++)
    if (c != 3) CHECK_MSG(near[c] > 200 && bad[c] == 0, "circle %d: %d of %d outside labels wrong", c, bad[c], near[c]);
  scene_close(&sc);
}

/* Caps under other grooves (docs/spec.md §3's CSG: the deeper carve
 * decides h, the first of equals): a box joint ending on a bed's centre
 * line has its cap wholly inside the bed, no deeper than it, so the
 * refinement leaves that end out of the open ends it sizes caps at; the
 * joint's other end (in the open), one ending half a unit outside the
 * bed's rim (part of its cap shows), one deeper than the bed (its cap
 * decides h) and the bed's own two ends stay. */
static void test_hidden_caps(void) {
  static const char bricks[] =
      "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
      "<g data-profile='box' data-width='6' data-depth='0.01'>"
      "<path d='M 5 50 L 95 50'/>"
      "<path d='M 30 20 L 30 50'/>"
      "<path d='M 70 20 L 70 46.5'/>"
      "</g>"
      "<path d='M 50 20 L 50 50' data-profile='box' data-width='6' data-depth='0.02'/>"
      "</svg>";
  label_scene sc;
  REQUIRE(scene_open(&sc, bricks, "bricks.svg", 0.05, 0.01));
  REQUIRE(sc.set.num_segments == 4);
  int listed[4][2] = {{0}};
  int n = sc.lb.end_start[sc.lb.end_res * sc.lb.end_res];
  for (int k = 0; k < n; k++) {
    int s = sc.lb.end_item[k] / 2, end = sc.lb.end_item[k] % 2;
    CHECK(sc.set.segments[s].curve == s);
    listed[s][end]++;
  }
  CHECK_MSG(n == 7, "%d open ends listed", n);
  for (int s = 0; s < 4; s++)
    for (int end = 0; end < 2; end++)
      CHECK_MSG(listed[s][end] == (s == 1 && end == 1 ? 0 : 1), "curve %d end %d listed %d times", s, end,
                listed[s][end]);
  scene_close(&sc);
}

/* Mirrored grooves tie along their line of symmetry (docs/spec.md §3: the
 * first of equals decides h): two u circles as ornament's rosette draws
 * them, mirrored about u = 0.5. Their distances there differ by rounding
 * (1e-16), which a u profile's slope towards its rims amplifies past a
 * tie relative to g; the label along the line must still name the first
 * circle throughout, or an edge lying on the line is cut at random. */
static void test_mirrored_tie(void) {
  static const char mirrored[] =
      "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
      "<g data-profile='u' data-width='1.8' data-depth='0.012'>"
      "<circle cx='37.876' cy='43' r='14'/><circle cx='62.124' cy='43' r='14'/>"
      "</g></svg>";
  label_scene sc;
  REQUIRE(scene_open(&sc, mirrored, "mirrored.svg", 0.05, 0.002));
  REQUIRE(sc.set.num_curves == 2);
  int both = 0, rim = 0, other = 0;
  for (int i = 0; i <= 200000; i++) {
    double q[2] = {0.5, 0.3 + 0.4 * i / 200000.0};
    ch_curve_point a, b;
    ch_curve_closest(&sc.set, 0, q, &a);
    ch_curve_closest(&sc.set, 1, q, &b);
    double half = 0.5 * sc.set.curves[0].width;
    if (!(a.distance < half && b.distance < half)) continue;
    both++;
    rim += a.distance > 0.9 * half;
    uint64_t g = ch_label_at(&sc.lb, q) >> 32;
    other += GROOVE_CURVE(g) != 0;
  }
  CHECK_MSG(both > 1000 && rim > 100, "%d points in both grooves, %d near the rims", both, rim);
  CHECK_MSG(other == 0, "%d of %d points on the line of symmetry labelled by the second circle", other, both);
  scene_close(&sc);
}

/* The pieces a crossing list says lie along a half (from its end's label,
 * one list entry at a time) against the labels read at n points along it,
 * skipping points within 1e-9 of a crossing: how many disagree. */
static int list_mismatches(const ch_label_ctx *lb, const double a[2], const double b[2], uint64_t la,
                           const ch_refine_edge *e, int n) {
  int bad = 0, next = 0;
  uint64_t piece = la;
  for (int i = 1; i < n; i++) {
    double x = (double)i / n, uv[2];
    while (next < e->ncross && e->cross[next].x < x) piece = e->cross[next++].lb;
    if ((next < e->ncross && e->cross[next].x - x < 1e-9) || (next > 0 && x - e->cross[next - 1].x < 1e-9)) continue;
    ch_refine_lerp2(a, b, x, uv);
    bad += ch_label_at(lb, uv) != piece;
  }
  return bad;
}

/* A split edge's halves take its crossings (ch_refine_inherit_crossings)
 * only where they are right: on random edges over a curved u groove (its
 * many close lines) crossing a v groove, and a step circle, each
 * inherited list is the search's own on that half (the same crossings
 * and labels, the points to 1e-9 of the half, heights to 1e-6 (h is read
 * 1e-12 of the edge inside each piece: beside a u groove's vertical rim
 * that is h to 1e-8) and the same walls), or differs where the labels
 * read at 400 points along the half (an independent reading, finer than
 * any piece here) contradict the search's list, and contradict the
 * inherited one no more (the search runs a u groove's lines by their
 * level function and can step over the other groove between two of its
 * samples). Most halves must inherit (the check is not vacuous). */
static void test_inherited_crossings(void) {
  static const char scene[] =
      "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
      "<path d='M 5 60 Q 50 0 95 60' data-profile='u' data-width='10' data-depth='0.02'/>"
      "<path d='M -10 30 L 110 34' data-profile='v' data-width='8' data-depth='0.02'/>"
      "<circle cx='50' cy='70' r='15' data-kind='step' data-left='0.01' data-right='0.03'/>"
      "</svg>";
  label_scene sc;
  double edge = 0.02;
  CHECK(search_scene_open(&sc, scene, "inherit.svg", edge, 0.03));
  if (!sc.set.num_curves) return;
  double delta = 0.25 * 0.08;           /* a quarter of the thinnest groove, as the embedding's */
  int halves = 0, inherited = 0, differ = 0, worse = 0, search_right = 0, crossings = 0;
  for (int trial = 0; trial < 1500; trial++) {
    /* vertices a, b, a third corner c, and the midpoint m (numbered after
     * them, as ch_refine_add_midpoint does); the split edge a-b in T0,
     * its halves a-m in T1 and b-m in T2, one chart */
    ch_refine_vert v[4];
    memset(v, 0, sizeof v);
    double len = 0.02 + 0.2 * ch_test_rnd(), ang = 2.0 * CH_PI * ch_test_rnd();
    v[0].uv[0] = 0.05 + 0.9 * ch_test_rnd(), v[0].uv[1] = 0.05 + 0.9 * ch_test_rnd();
    v[1].uv[0] = v[0].uv[0] + len * cos(ang), v[1].uv[1] = v[0].uv[1] + len * sin(ang);
    v[2].uv[0] = v[0].uv[0] - len * sin(ang), v[2].uv[1] = v[0].uv[1] + len * cos(ang);
    ch_refine_lerp2(v[0].uv, v[1].uv, 0.5, v[3].uv);
    for (int i = 0; i < 4; i++) v[i].label = ch_label_quiet(&sc.lb, v[i].uv) ? 0 : ch_label_at(&sc.lb, v[i].uv);
    ch_refine_tri t[3] = {{.v = {0, 1, 2}}, {.v = {0, 3, 2}}, {.v = {1, 3, 2}}};
    for (int i = 0; i < 3; i++)
      for (int k = 0; k < 3; k++) memcpy(t[i].uv[k], v[t[i].v[k]].uv, sizeof t[i].uv[k]);
    ch_refine_edge e[3] = {{.a = 0, .b = 1, .tri = 0, .k = 0, .ncross = -1, .mid = 3, .half = {1, 2}},
                           {.a = 0, .b = 3, .tri = 1, .k = 0, .ncross = -1, .mid = -1},
                           {.a = 1, .b = 3, .tri = 2, .k = 0, .ncross = -1, .mid = -1}};
    ch_refine_mesh w = {.verts = v, .nverts = 4, .tris = t, .ntris = 3, .edges = e, .nedges = 3};
    REQUIRE(ch_refine_pools_init(&w) == 0);
    CHECK(ch_refine_crossings(&sc.lb, &w, &e[0], delta) == 0);
    crossings += e[0].ncross;
    CHECK(ch_refine_inherit_crossings(&sc.lb, &w, 0, delta) == 0);
    CHECK(e[0].ncross <= 0 && !e[0].cross); /* (the split edge's are spent) */
    for (int j = 1; j <= 2; j++) {
      halves++;
      if (e[j].ncross < 0) continue; /* left to the search */
      inherited++;
      const double *a = v[e[j].a].uv, *b = v[3].uv;
      ch_refine_edge fresh = e[j];
      fresh.ncross = -1;
      fresh.cross = NULL;
      CHECK(ch_refine_crossings(&sc.lb, &w, &fresh, delta) == 0);
      int same = fresh.ncross == e[j].ncross;
      for (int c = 0; c < e[j].ncross && same; c++) {
        const ch_refine_crossing *x = &e[j].cross[c], *y = &fresh.cross[c];
        int wall_x = !(fabs(x->ha - x->hb) <= sc.lb.wall_tol), wall_y = !(fabs(y->ha - y->hb) <= sc.lb.wall_tol);
        same = fabs(x->x - y->x) < 1e-9 && x->la == y->la && x->lb == y->lb && fabs(x->ha - y->ha) < 1e-6 &&
               fabs(x->hb - y->hb) < 1e-6 && wall_x == wall_y;
      }
      if (!same) {
        int bad = list_mismatches(&sc.lb, a, b, v[e[j].a].label, &e[j], 400);
        int search_bad = list_mismatches(&sc.lb, a, b, v[e[j].a].label, &fresh, 400);
        differ++;
        worse += bad > search_bad;
        search_right += search_bad == 0;
      }
    }
    ch_refine_pools_free(&w); /* (every list at once) */
  }
  CHECK_MSG(worse == 0 && search_right == 0,
            "%d inherited lists differ from the search's: %d disagree more with the labels, %d where the search's "
            "agrees with them",
            differ, worse, search_right);
  CHECK_MSG(inherited > halves / 2 && crossings > 1500, "%d of %d halves inherited, %d crossings", inherited, halves,
            crossings);
  scene_close(&sc);
}

/* Every crossing the search finds is a change of label where it says:
 * on random edges over u grooves (their many lines, found by Newton's
 * method on the offset of the segment read last, their heights from the
 * root's own t) that end in open ends (t flips sign across the line that
 * continues a stroke, looked at directly) and cross each other, and on
 * edges starting on such a line, the labels read 1e-9 of the edge before
 * and after each crossing are its two pieces (an independent reading);
 * across a groove's line both sides' h is h read there; on a straight
 * stroke each line lies at its level times the width from the stroke's
 * axis (the exact answer) to 1e-13 in UV (the search before Newton's
 * method: 2.7e-14 at worst, now 8e-15); and along each edge the list
 * agrees with the labels at 400 points but on a few edges that graze a
 * line between two samples (28 of the 3000, before and after). */
static void test_crossings_found(void) {
  static const char scene[] =
      "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
      "<path d='M 50 10 L 50 40' data-profile='u' data-width='8' data-depth='0.02'/>"
      "<path d='M 10 60 Q 50 20 90 60' data-profile='u' data-width='10' data-depth='0.015'/>"
      "<path d='M 30 95 L 70 45' data-profile='u' data-width='6' data-depth='0.02'/>"
      "</svg>";
  label_scene sc;
  double edge = 0.02;
  CHECK(search_scene_open(&sc, scene, "found.svg", edge, 0.02));
  if (!sc.set.num_curves) return;
  double delta = 0.25 * 0.06, eps = 1e-9;
  int stroke = sc.set.segments[0].curve, edges = 0, crossings = 0, wrong_sides = 0, wrong_h = 0, mismatched = 0;
  int jumps = 0, axis_checked = 0, axis_wrong = 0;
  double worst_axis = 0.0;
  for (int trial = 0; trial < 3000; trial++) {
    ch_refine_vert v[2];
    memset(v, 0, sizeof v);
    double len = 0.01 + 0.1 * ch_test_rnd(), ang = 2.0 * CH_PI * ch_test_rnd();
    const ch_segment *sg = &sc.set.segments[0];
    if (trial % 3 == 0) { /* from the line that continues the stroke past its ends, in its caps */
      double end = trial % 2 ? sg->p[0][1] : sg->p[2][1], out = end < 0.5 * (sg->p[0][1] + sg->p[2][1]) ? -1.0 : 1.0;
      v[0].uv[0] = 0.5, v[0].uv[1] = end + out * 0.05 * ch_test_rnd();
    } else if (trial % 3 == 1) { /* across the stroke's middle, level */
      double v0 = fmin(sg->p[0][1], sg->p[2][1]), v1 = fmax(sg->p[0][1], sg->p[2][1]);
      v[0].uv[0] = 0.5 - 0.5 * len, v[0].uv[1] = v0 + (0.25 + 0.5 * ch_test_rnd()) * (v1 - v0);
      ang = 0.0;
    } else {
      v[0].uv[0] = 0.05 + 0.9 * ch_test_rnd(), v[0].uv[1] = 0.05 + 0.9 * ch_test_rnd();
    }
    v[1].uv[0] = v[0].uv[0] + len * cos(ang), v[1].uv[1] = v[0].uv[1] + len * sin(ang);
    for (int i = 0; i < 2; i++) v[i].label = ch_label_quiet(&sc.lb, v[i].uv) ? 0 : ch_label_at(&sc.lb, v[i].uv);
    ch_refine_tri t = {.v = {0, 1, 1}};
    memcpy(t.uv[0], v[0].uv, sizeof t.uv[0]);
    memcpy(t.uv[1], v[1].uv, sizeof t.uv[1]);
    memcpy(t.uv[2], v[1].uv, sizeof t.uv[2]);
    ch_refine_edge e = {.a = 0, .b = 1, .tri = 0, .k = 0, .ncross = -1, .mid = -1};
    ch_refine_mesh w = {.verts = v, .nverts = 2, .tris = &t, .ntris = 1, .edges = &e, .nedges = 1};
    REQUIRE(ch_refine_pools_init(&w) == 0);
    CHECK(ch_refine_crossings(&sc.lb, &w, &e, delta) == 0);
    edges++;
    for (int i = 0; i < e.ncross; i++) {
      const ch_refine_crossing *x = &e.cross[i];
      crossings++;
      uint64_t ga = x->la >> 32, gb = x->lb >> 32;
      int same = ga && gb && GROOVE_CURVE(ga) == GROOVE_CURVE(gb);
      int ka = (int)(ga & 0xff), kb = (int)(gb & 0xff);
      jumps += same && abs(ka - kb) > 1;
      double before = i > 0 ? e.cross[i - 1].x : -1.0, after = i + 1 < e.ncross ? e.cross[i + 1].x : 2.0;
      double pa[2], pb[2], at[2];
      ch_refine_lerp2(v[0].uv, v[1].uv, x->x, at);
      if (x->x - before > 4.0 * eps && after - x->x > 4.0 * eps && x->x > eps && x->x < 1.0 - eps) {
        ch_refine_lerp2(v[0].uv, v[1].uv, x->x - eps, pa);
        ch_refine_lerp2(v[0].uv, v[1].uv, x->x + eps, pb);
        wrong_sides += ch_label_at(&sc.lb, pa) != x->la || ch_label_at(&sc.lb, pb) != x->lb;
        if (same && abs(ka - kb) == 1)
          wrong_h += !(fabs(x->ha - ch_label_piece_height(&sc.lb, x->la, pa, at)) < 1e-9 &&
                       fabs(x->hb - ch_label_piece_height(&sc.lb, x->lb, pb, at)) < 1e-9);
      }
      /* the stroke's lines, away from its ends: |u - 1/2| = |line| w */
      if (trial % 3 == 1 && same && GROOVE_CURVE(ga) == stroke && abs(ka - kb) == 1) {
        int nb;
        const double *br = ch_label_lines_of(&sc.lb, stroke, GROOVE_LEVEL(ga), &nb);
        double off = fabs(fabs(at[0] - 0.5) - fabs(br[ka < kb ? ka : kb]) * sc.set.curves[stroke].width);
        worst_axis = fmax(worst_axis, off);
        axis_wrong += !(off < 1e-13);
        axis_checked++;
      }
    }
    mismatched += list_mismatches(&sc.lb, v[0].uv, v[1].uv, v[0].label, &e, 400) > 0;
    ch_refine_pools_free(&w);
  }
  CHECK_MSG(wrong_sides == 0 && wrong_h == 0, "%d of %d crossings with other labels 1e-9 either side, %d with h off",
            wrong_sides, crossings, wrong_h);
  CHECK_MSG(axis_wrong == 0 && axis_checked > 500, "%d of %d stroke lines off their level (worst %.3g in UV)",
            axis_wrong, axis_checked, worst_axis);
  CHECK_MSG(mismatched <= edges / 50, "%d of %d edges disagree with the labels along them", mismatched, edges);
  CHECK_MSG(crossings > 10000 && jumps > 200, "%d crossings, %d of them jumps past an open end", crossings, jumps);
  scene_close(&sc);
}

/* The point at angle a from centre where u groove c's t = line, by
 * bisection along the ray (t is monotone across the groove there); 0 if
 * the ray does not cross that line within the groove. */
static int ray_on_line(const label_scene *sc, int c, const double centre[2], double r, double a, double line,
                       double uv[2]) {
  double w = sc->set.curves[c].width, lo = r - 0.6 * w, hi = r + 0.6 * w, p[2];
  double flo, fhi;
  p[0] = centre[0] + lo * cos(a), p[1] = centre[1] + lo * sin(a);
  flo = ch_label_groove_distance(&sc->lb, c, p) / w - line;
  p[0] = centre[0] + hi * cos(a), p[1] = centre[1] + hi * sin(a);
  fhi = ch_label_groove_distance(&sc->lb, c, p) / w - line;
  if (!(flo * fhi < 0.0)) return 0;
  for (int it = 0; it < 200 && hi - lo > 1e-15; it++) {
    double m = 0.5 * (lo + hi);
    p[0] = centre[0] + m * cos(a), p[1] = centre[1] + m * sin(a);
    double fm = ch_label_groove_distance(&sc->lb, c, p) / w - line;
    if ((fm < 0.0) == (flo < 0.0))
      lo = m, flo = fm;
    else
      hi = m;
  }
  double m = 0.5 * (lo + hi);
  uv[0] = centre[0] + m * cos(a), uv[1] = centre[1] + m * sin(a);
  /* (a change of sign may be t's jump past an open end, not the line) */
  return fabs(ch_label_groove_distance(&sc->lb, c, uv) / w - line) < 1e-9;
}

/* The chord test's bound (ch_label_chord_within) against the read it
 * spares: on the lines of a u circle and of a u half circle with open
 * ends, random chords between two points of one line (found by bisection
 * along rays from the centre, independently of the search), each proven
 * one reads within half the tolerance asked at its middle (what the bound
 * proves); most are proven; near the half circle's ends, where its cap
 * curves the lines, none is. */
static void test_chord_bound(void) {
  static const char scene[] =
      "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
      "<circle cx='30' cy='50' r='20' data-profile='u' data-width='4' data-depth='0.02'/>"
      "<path d='M 65 30 A 20 20 0 0 1 65 70' data-profile='u' data-width='4' data-depth='0.02'/>"
      "</svg>";
  label_scene sc;
  CHECK(scene_open(&sc, scene, "chords.svg", 0.02, 0.005));
  if (!sc.set.num_curves) return;
  int proven = 0, tried = 0, wrong = 0, proven_at_ends = 0, at_ends = 0;
  for (int trial = 0; trial < 4000; trial++) {
    int c = trial % 2;
    const ch_curve *cv = &sc.set.curves[c];
    double centre[2] = {c == 0 ? 0.30 : 0.65, 0.5}, r = 0.2, uv[2][2];
    int nb;
    const double *br = ch_label_lines_of(&sc.lb, c, 0, &nb);
    double line = br[1 + (int)(ch_test_rnd() * (nb - 2))];
    /* the half circle runs on the right of its centre, its ends straight
     * up and down; every other of its chords on a cap's ring, by rays
     * from the end (the rings are circles about it, beyond it) */
    double a0 = c == 0 ? 2.0 * CH_PI * ch_test_rnd() : CH_PI * (ch_test_rnd() - 0.5) * 0.9;
    double da = (0.002 + 0.05 * ch_test_rnd()) / r;
    if (c == 1 && trial % 4 == 1) {
      const ch_segment *sg = &sc.set.segments[cv->first_segment];
      double end[2] = {sg->p[0][0], sg->p[0][1]}, out = end[1] > centre[1] ? 1.0 : -1.0;
      r = fabs(line) * cv->width;
      a0 = out * CH_PI * (0.1 + 0.6 * ch_test_rnd());
      da = 0.2 * ch_test_rnd();
      centre[0] = end[0], centre[1] = end[1];
    }
    if (!ray_on_line(&sc, c, centre, r, a0, line, uv[0]) || !ray_on_line(&sc, c, centre, r, a0 + da, line, uv[1]))
      continue;
    double mid[2] = {0.5 * (uv[0][0] + uv[1][0]), 0.5 * (uv[0][1] + uv[1][1])};
    /* tolerances from under to forty times what the chord's sagitta on
     * the circle (radius r + line w) would give */
    double len = ch_dist2d(uv[1][0] - uv[0][0], uv[1][1] - uv[0][1]), rr = 0.2 - fabs(line) * cv->width;
    double tol = (0.5 + 40.0 * ch_test_rnd()) * len * len / (8.0 * rr) / cv->width * fabs(cv->depth);
    tried++;
    int near_end = 0;
    for (int k = 0; k < 2 && c == 1; k++) {
      const ch_segment *sg = &sc.set.segments[k ? cv->first_segment + cv->num_segments - 1 : cv->first_segment];
      const double *end = sg->p[k ? 2 : 0];
      near_end |= ch_dist2d(mid[0] - end[0], mid[1] - end[1]) < 0.5 * cv->width;
    }
    at_ends += near_end;
    if (!ch_label_chord_within(&sc.lb, c, line, uv[0], uv[1], mid, tol)) continue;
    proven++;
    double err = fabs(ch_label_groove_distance(&sc.lb, c, mid) / cv->width - line) * fabs(cv->depth);
    wrong += !(err <= 0.5 * tol); /* (the bound proves half of it) */
    proven_at_ends += near_end;
  }
  CHECK_MSG(wrong == 0 && proven_at_ends == 0, "%d of %d proven chords read beyond the tolerance, %d proven at an end",
            wrong, proven, proven_at_ends);
  CHECK_MSG(tried > 2000 && proven > tried / 2 && at_ends > 200, "%d of %d chords proven, %d at an end", proven, tried,
            at_ends);
  scene_close(&sc);
}

/* Grooves that share a profile, width and depth share their u lines
 * (ch_label_init computes them once): each groove's lines, among 24
 * grooves of 20 kinds (more than the kinds it remembers; some repeated,
 * one after others pushed it out; two with the width of a remembered one
 * but another profile or depth), are those of a scene holding that groove
 * alone. */
static void test_shared_lines(void) {
  static const struct {
    double width, depth;
    const char *profile;
  } g[] = {{4, .02, "u"},  {5, .02, "u"},  {6, .02, "u"},  {7, .02, "u"},  {8, .02, "u"},  {9, .02, "u"},
           {10, .02, "u"}, {11, .02, "u"}, {12, .02, "u"}, {13, .02, "u"}, {14, .02, "u"}, {15, .02, "u"},
           {16, .02, "u"}, {17, .02, "u"}, {18, .02, "u"}, {19, .02, "u"}, {4, .02, "u"},  {6, .02, "u"},
           {20, .02, "u"}, {5, .02, "u"},  {5, .02, "v"},  {6, .03, "u"},  {4, .02, "u"},  {8, .02, "u"}};
  enum { N = sizeof g / sizeof *g };
  char all[8192], one[512];
  int len = snprintf(all, sizeof all, "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>");
  for (int i = 0; i < N; i++)
    len += snprintf(all + len, sizeof all - (size_t)len,
                    "<path d='M 5 %d L 95 %d' data-profile='%s' data-width='%g' data-depth='%g'/>", 4 + 4 * i,
                    4 + 4 * i, g[i].profile, 0.1 * g[i].width, g[i].depth);
  snprintf(all + len, sizeof all - (size_t)len, "</svg>");
  label_scene sc;
  REQUIRE(scene_open(&sc, all, "shared.svg", 0.02, 0.002));
  for (int i = 0; i < N; i++) {
    snprintf(one, sizeof one,
             "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
             "<path d='M 5 %d L 95 %d' data-profile='%s' data-width='%g' data-depth='%g'/></svg>",
             4 + 4 * i, 4 + 4 * i, g[i].profile, 0.1 * g[i].width, g[i].depth);
    label_scene alone;
    REQUIRE(scene_open(&alone, one, "one.svg", 0.02, 0.002));
    int n_all = 0, n_one = 0;
    const double *t_all = ch_label_lines_of(&sc.lb, i, 0, &n_all), *t_one = ch_label_lines_of(&alone.lb, 0, 0, &n_one);
    CHECK(n_all == n_one && n_all >= 3);
    CHECK(n_all == n_one && memcmp(t_all, t_one, (size_t)n_all * sizeof *t_all) == 0);
    scene_close(&alone);
  }
  scene_close(&sc);
}

/* A u groove on an object far larger than its depth (a tablet modelled
 * in millimetres, 1e5 units to the UV square, a groove 0.02 deep): the
 * displaced profile's slope is so small that the lines the angle step
 * asks for crowd at the rims closer than a double can tell apart, and
 * placing them once went round for ever. The lines are finite, strictly
 * increasing and symmetric, from rim to rim; at a scale of 1 the same
 * groove's are too. */
static void test_lines_at_any_scale(void) {
  static const char *text =
      "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
      "<path d='M 5 50 L 95 50' data-profile='u' data-width='2' data-depth='0.02'/></svg>";
  static const double scales[] = {1.0, 1e3, 1e5, 1e-5};
  for (int s = 0; s < 4; s++) {
    label_scene sc = {0};
    ch_error err = {0};
    REQUIRE(ch_curves_parse_svg(text, strlen(text), "scale.svg", &sc.set, &err) == CH_OK);
    ch_height_desc hd = {.dci_resolution = 256, .step_method = CH_RECON_EXACT};
    REQUIRE(ch_height_init(&sc.height, &sc.set, &hd, &err) == CH_OK);
    REQUIRE(ch_label_init(&sc.lb, &sc.height, NULL, 0.02, 0.0, 7.0 * CH_PI / 180.0, scales[s], 0.002, 0.004, &err) ==
            CH_OK);
    int n = 0;
    const double *t = ch_label_lines_of(&sc.lb, 0, 0, &n);
    int ok = n >= 2 && t[0] == -0.5 && t[n - 1] == 0.5;
    for (int i = 0; i + 1 < n && ok; i++) ok = isfinite(t[i]) && t[i] < t[i + 1] && t[i] == -t[n - 1 - i];
    CHECK_MSG(ok, "scale %g: %d lines", scales[s], n);
    scene_close(&sc);
  }
}

int main(void) {
  RUN(test_labels);
  RUN(test_lines_at_any_scale);
  RUN(test_crossing_loops);
  RUN(test_nested_loops);
  RUN(test_hidden_caps);
  RUN(test_mirrored_tie);
  RUN(test_inherited_crossings);
  RUN(test_crossings_found);
  RUN(test_chord_bound);
  RUN(test_shared_lines);
  TEST_MAIN_END();
}
