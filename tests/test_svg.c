/* The SVG reader (docs/spec.md §2): every path command, shapes, transforms,
 * inheritance and the viewBox mapping on valid input; one clear message for
 * every malformed file in data/svg/bad. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ch_bezier.h"
#include "ch_curves.h"
#include "ch_groove.h"
#include "ch_height.h"
#include "ch_test.h"

static int parse(const char *body, ch_curve_set *set, ch_error *err) {
  char buf[8192];
  snprintf(buf, sizeof buf,
           "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>%s</svg>", body);
  memset(err, 0, sizeof *err);
  return ch_curves_parse_svg(buf, strlen(buf), "t.svg", set, err);
}

/* The UV point of control point k of segment i. */
static double P(const ch_curve_set *s, int i, int k, int axis) { return s->segments[i].p[k][axis]; }

static void test_viewbox_mapping(void) {
  ch_curve_set s;
  ch_error err;
  const char *svg = "<svg xmlns='http://www.w3.org/2000/svg' viewBox='10 20 200 100'>"
                    "<path d='M 10 20 L 210 120' data-width='8'/></svg>";
  REQUIRE(ch_curves_parse_svg(svg, strlen(svg), "vb.svg", &s, &err) == CH_OK);
  REQUIRE(s.num_segments == 1);
  CHECK_NEAR(P(&s, 0, 0, 0), 0.0, 1e-15);
  CHECK_NEAR(P(&s, 0, 0, 1), 1.0, 1e-15); /* SVG top is v = 1 */
  CHECK_NEAR(P(&s, 0, 2, 0), 1.0, 1e-15);
  CHECK_NEAR(P(&s, 0, 2, 1), 0.0, 1e-15);
  CHECK(s.segments[0].is_line);
  /* Width in viewBox units, geometric mean scale for non-square boxes. */
  CHECK_NEAR(s.curves[0].width, 8.0 / sqrt(200.0 * 100.0), 1e-15);
  ch_curves_free(&s);
  /* Without a viewBox: width/height in user units (mm -> px). */
  svg = "<svg xmlns='http://www.w3.org/2000/svg' width='50mm' height='50mm'>"
        "<path d='M 0 0 L 94.48818897637796 0'/></svg>";
  REQUIRE(ch_curves_parse_svg(svg, strlen(svg), "wh.svg", &s, &err) == CH_OK);
  CHECK_NEAR(P(&s, 0, 2, 0), 0.5, 1e-12);
  ch_curves_free(&s);
}

static void test_path_commands(void) {
  ch_curve_set s;
  ch_error err;
  /* Relative commands, H/V, implicit lineto after M, closepath. */
  REQUIRE(parse("<path d='m 10 10 l 10 0 h 5 v 5 20 z'/>", &s, &err) == CH_OK);
  REQUIRE(s.num_segments == 5); /* "v 5 20" is two vertical linetos */
  CHECK_NEAR(P(&s, 0, 2, 0), 0.20, 1e-15);
  CHECK_NEAR(P(&s, 1, 2, 0), 0.25, 1e-15);
  CHECK_NEAR(P(&s, 2, 2, 1), 1 - 0.15, 1e-15);
  CHECK_NEAR(P(&s, 3, 2, 1), 1 - 0.35, 1e-15);
  CHECK_NEAR(P(&s, 4, 2, 0), 0.10, 1e-15); /* z returns to the start */
  CHECK(s.subpaths[0].closed);
  ch_curves_free(&s);
  /* Numbers without separators: "M10-5L.5.5" is (10,-5) (.5,.5). */
  REQUIRE(parse("<path d='M10-5L.5.5'/>", &s, &err) == CH_OK);
  CHECK_NEAR(P(&s, 0, 0, 0), 0.10, 1e-15);
  CHECK_NEAR(P(&s, 0, 0, 1), 1.05, 1e-15);
  CHECK_NEAR(P(&s, 0, 2, 0), 0.005, 1e-15);
  CHECK_NEAR(P(&s, 0, 2, 1), 0.995, 1e-15);
  ch_curves_free(&s);
  /* Implicit lineto after M, exponent numbers. */
  REQUIRE(parse("<path d='M 0 0 1e1 0 10 1E1'/>", &s, &err) == CH_OK);
  CHECK(s.num_segments == 2);
  CHECK_NEAR(P(&s, 1, 2, 1), 0.9, 1e-15);
  ch_curves_free(&s);
  /* Q then T reflects the control point. */
  REQUIRE(parse("<path d='M 10 50 Q 30 10 50 50 T 90 50'/>", &s, &err) == CH_OK);
  REQUIRE(s.num_segments == 2);
  CHECK_NEAR(P(&s, 1, 1, 0), 0.70, 1e-15);
  CHECK_NEAR(P(&s, 1, 1, 1), 1 - 0.90, 1e-15);
  ch_curves_free(&s);
  /* C then S: S's first control point mirrors C's second. Both cubics are
   * symmetric S-curves; check that the point at the join is exact and that
   * the curve passes through the cubic's midpoint. */
  REQUIRE(parse("<path d='M 10 50 C 10 20 40 20 40 50 S 70 80 70 50'/>", &s, &err) == CH_OK);
  CHECK(s.num_segments > 2);
  {
    /* Cubic 2 is (40,50) (40,80) (70,80) (70,50): midpoint (55, 72.5). */
    double q[2] = {0.55, 1 - 0.725};
    ch_curve_point cp;
    ch_curve_closest(&s, 0, q, &cp);
    CHECK(cp.distance < 1e-6);
  }
  ch_curves_free(&s);
  /* Arc: a half circle of radius 40 about (50,50); flags without spaces. */
  REQUIRE(parse("<path d='M10 50A40 40 0 0190 50'/>", &s, &err) == CH_OK);
  {
    double max_dev = 0;
    for (int i = 0; i < s.num_segments; i++)
      for (int k = 0; k <= 10; k++) {
        double x[2];
        ch_bezier_eval(s.segments[i].p, k / 10.0, x);
        max_dev = fmax(max_dev, fabs(hypot(x[0] - 0.5, x[1] - 0.5) - 0.4));
      }
    CHECK(max_dev < 1e-6);
    /* Sweep 1 runs clockwise on screen from the left: over the top, v > 0.5. */
    double mid[2];
    ch_bezier_eval(s.segments[s.num_segments / 2].p, 0.5, mid);
    CHECK(mid[1] > 0.85);
    CHECK_NEAR(P(&s, s.num_segments - 1, 2, 0), 0.9, 0);
  }
  ch_curves_free(&s);
  /* Arc with radii too small is scaled up (F.6.6): still a half circle. */
  REQUIRE(parse("<path d='M 10 50 A 1 1 0 0 0 90 50'/>", &s, &err) == CH_OK);
  {
    double mid[2];
    ch_bezier_eval(s.segments[s.num_segments / 2].p, 0.5, mid);
    CHECK_NEAR(hypot(mid[0] - 0.5, mid[1] - 0.5), 0.4, 1e-6);
    CHECK(mid[1] < 0.15);
  }
  ch_curves_free(&s);
  /* Subpaths: two open pieces in one path; Z closes and links. */
  REQUIRE(parse("<path d='M 10 10 L 20 10 M 30 30 L 40 30 L 40 40 Z'/>", &s, &err) == CH_OK);
  CHECK(s.num_subpaths == 2 && s.curves[0].num_subpaths == 2);
  CHECK(!s.subpaths[0].closed && s.subpaths[1].closed);
  CHECK(s.segments[0].prev == -1 && s.segments[0].next == -1);
  CHECK(s.segments[1].prev == 3 && s.segments[3].next == 1);
  ch_curves_free(&s);
  /* A path ending on its start without Z counts as closed. */
  REQUIRE(parse("<path d='M 10 10 L 20 10 L 20 20 L 10 10'/>", &s, &err) == CH_OK);
  CHECK(s.subpaths[0].closed);
  ch_curves_free(&s);
  /* a straight cubic is a line; a straight quadratic that runs out past
   * its end and back is two lines, split where it turns */
  REQUIRE(parse("<path d='M 10 10 C 20 10 30 10 40 10'/><path d='M 10 20 Q 50 20 30 20'/>", &s, &err) == CH_OK);
  REQUIRE(s.num_segments == 3);
  CHECK(s.segments[0].is_line && s.segments[1].is_line && s.segments[2].is_line);
  CHECK_NEAR(P(&s, 1, 2, 0), (1.0 / 9 * 10 + 4.0 / 9 * 50 + 4.0 / 9 * 30) / 100, 1e-15); /* B(2/3) */
  CHECK_NEAR(P(&s, 2, 2, 0), 0.30, 1e-15);
  ch_curves_free(&s);
}

static void test_shapes_and_sides(void) {
  ch_curve_set s;
  ch_error err;
  /* SVG lays circles out clockwise as seen on screen (from (cx+r, cy)
   * towards (cx, cy+r), which is below the centre): the inside is on the
   * right. */
  REQUIRE(parse("<circle cx='50' cy='50' r='20' data-kind='step' data-left='1'/>", &s, &err) == CH_OK);
  CHECK(s.curves[0].kind == CH_CURVE_STEP && s.curves[0].left == 1.0);
  CHECK(s.subpaths[0].closed);
  ch_curve_point cp;
  ch_curve_closest(&s, 0, (double[2]){0.5, 0.55}, &cp);
  CHECK_NEAR(cp.signed_distance, -0.15, 1e-6);
  ch_curve_closest(&s, 0, (double[2]){0.95, 0.5}, &cp);
  CHECK_NEAR(cp.signed_distance, 0.25, 1e-6);
  ch_curves_free(&s);
  /* Rounded rect: straight sides plus quarter arcs, also clockwise. */
  REQUIRE(parse("<rect x='20' y='30' width='60' height='40' rx='10'/>", &s, &err) == CH_OK);
  CHECK(s.subpaths[0].closed);
  ch_curve_closest(&s, 0, (double[2]){0.5, 0.5}, &cp);
  CHECK_NEAR(cp.signed_distance, -0.2, 1e-12);
  ch_curve_closest(&s, 0, (double[2]){0.2, 0.7}, &cp); /* the rounded corner's outside */
  CHECK_NEAR(cp.signed_distance, sqrt(2) * 0.1 - 0.1, 1e-6);
  ch_curves_free(&s);
  REQUIRE(parse("<ellipse cx='50' cy='50' rx='30' ry='10'/><line x1='0' y1='0' x2='100' y2='100'/>"
                "<polygon points='10,10 20,10 20,20'/><polyline points='10 10, 20 10 20 20'/>",
                &s, &err) == CH_OK);
  CHECK(s.num_curves == 4);
  CHECK(s.subpaths[s.curves[2].first_subpath].closed && !s.subpaths[s.curves[3].first_subpath].closed);
  CHECK(strcmp(s.curves[0].element, "ellipse") == 0);
  ch_curves_free(&s);
}

static void test_transforms_and_inheritance(void) {
  ch_curve_set s;
  ch_error err;
  REQUIRE(parse("<g transform='translate(50,50)' data-profile='box' data-width='4'>"
                "  <g transform='rotate(90) scale(2)' data-depth='0.05'>"
                "    <path d='M 0 0 L 10 0'/>"
                "    <path d='M 0 0 L 0 5' data-profile='u' data-width='2'/>"
                "  </g>"
                "</g>"
                "<path d='M 0 0 L 1 1' transform='matrix(1 0 0 1 5 5) skewX(45)'/>",
                &s, &err) == CH_OK);
  REQUIRE(s.num_curves == 3);
  /* (10,0) -> scale 2 -> (20,0) -> rotate 90 -> (0,20) -> +(50,50) -> (50,70). */
  CHECK_NEAR(P(&s, 0, 2, 0), 0.5, 1e-15);
  CHECK_NEAR(P(&s, 0, 2, 1), 1 - 0.7, 1e-15);
  CHECK(s.curves[0].profile.kind == CH_PROFILE_BOX && s.curves[0].depth == 0.05);
  CHECK_NEAR(s.curves[0].width, 0.04, 1e-15); /* widths are in viewBox units */
  CHECK(s.curves[1].profile.kind == CH_PROFILE_U);
  CHECK_NEAR(s.curves[1].width, 0.02, 1e-15);
  CHECK(s.curves[2].profile.kind == CH_PROFILE_V && s.curves[2].depth == 0.01);
  CHECK_NEAR(s.curves[2].width, 0.08, 1e-15); /* default 8 */
  /* skewX(45) maps (1,1) to (2,1), then +(5,5). */
  CHECK_NEAR(P(&s, 2, 2, 0), 0.07, 1e-15);
  ch_curves_free(&s);
  /* Hidden elements and descriptive ones are skipped; unknown ones warn. */
  REQUIRE(parse("<title>x</title><g style='display:none'><path d='M 0 0 L 1 1'/></g>"
                "<path display='none' d='M 0 0 L 1 1'/><text>hi</text><text>ho</text>"
                "<path id='kept' d='M 0 0 L 1 1' data-kind='step' data-left='0.5' data-right='-0.5'"
                " data-left-color='#ff8000' data-right-color='#0f0' data-blur='2' data-priority='3'/>",
                &s, &err) == CH_OK);
  CHECK(s.num_curves == 1 && strcmp(s.curves[0].id, "kept") == 0);
  CHECK(err.num_warnings == 1); /* one line for both <text> elements */
  CHECK(s.curves[0].has_colors);
  CHECK_NEAR(s.curves[0].left_color[1], 128 / 255.0, 1e-15);
  CHECK_NEAR(s.curves[0].right_color[1], 1.0, 0);
  CHECK_NEAR(s.curves[0].blur, 0.02, 1e-15);
  CHECK(s.curves[0].priority == 3 && s.curves[0].right == -0.5);
  ch_curves_free(&s);
}

/* Every malformed file: CH_ERR_INPUT, the file named, the problem named. */
static void test_malformed_files(void) {
  static const struct { const char *file, *expect; } cases[] = {
      {"not_xml.svg", "bad XML"},
      {"unclosed.svg", "bad XML"},
      {"html_root.svg", "not an SVG"},
      {"no_viewbox.svg", "no viewBox"},
      {"bad_viewbox.svg", "viewBox width and height must be positive"},
      {"bad_path_data.svg", "<path> 'p1' (line 2): bad path data at offset 11 ('x'): expected a number"},
      {"no_moveto.svg", "must start with a moveto"},
      {"unknown_profile.svg", "unknown profile 'w'"},
      {"negative_width.svg", "<path> #0 (line 3): negative data-width"},
      {"zero_width.svg", "zero data-width"},
      {"bad_kind.svg", "unknown data-kind 'rail'"},
      {"bad_depth.svg", "data-depth 'deep' is not a number"},
      {"nan_depth.svg", "data-depth 'NaN' is not a number"},
      {"inf_coordinate.svg", "bad path data"},
      {"overflow_transform.svg", "out of range"},
      {"bad_transform.svg", "missing ')'"},
      {"unknown_transform.svg", "bad transform"},
      {"zero_length.svg", "'dot' (line 1): curve has zero length"},
      {"moveto_only.svg", "zero length"},
      {"no_curves.svg", "no curves"},
      {"odd_points.svg", "odd number of coordinates"},
      {"negative_radius.svg", "negative radius"},
      {"zero_radius.svg", "zero length"},
      {"negative_rect.svg", "negative rect size"},
      {"bad_color.svg", "bad data-left-color 'red'"},
      {"bad_custom_profile.svg", "must not decrease"},
      {"custom_profile_range.svg", "outside [-0.5, 0.5]"},
      {"empty.svg", "bad XML"},
      {"garbage.svg", "bad XML"},
      {"missing_d.svg", "missing d attribute"},
      {"bad_arc_flag.svg", "expected an arc flag"},
      {"fractional_priority.svg", "not an integer"},
      {"negative_blur.svg", "negative data-blur"},
      {"bad_length.svg", "is not a length"},
      {"billion_laughs.svg", "more than 10000 entity references"},
      {"bad_encoding.svg", "bad XML: input conversion failed"},
      {"not_utf8.svg", "Input is not proper UTF-8, indicate encoding !; Bytes: 0xFF 0xFE"},
      {"external_entity.svg", "external entity"},
      {"deep_nesting.svg", "<g> (line 1): elements nested deeper than 256 levels"},
      {"huge_entity.svg", "entities expand to more than 1048576 bytes"},
      {"far_viewbox.svg", "'far' (line 1): coordinates far outside the texture (|u| or |v| above 1e+06"},
  };
  for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
    char path[512];
    snprintf(path, sizeof path, "%s/svg/bad/%s", CHISEL_TEST_DATA, cases[i].file);
    ch_curve_set s;
    ch_error err = {0};
    ch_status st = ch_curves_read_svg(path, &s, &err);
    CHECK_MSG(st == CH_ERR_INPUT, "%s: status %d", cases[i].file, st);
    CHECK_MSG(strstr(err.message, cases[i].file) != NULL, "%s: message lacks the file: %s", cases[i].file,
              err.message);
    CHECK_MSG(strstr(err.message, cases[i].expect) != NULL, "%s: expected '%s' in: %s", cases[i].file,
              cases[i].expect, err.message);
    CHECK_MSG(strchr(err.message, '\n') == NULL, "%s: message is not one line: %s", cases[i].file, err.message);
    CHECK(s.num_curves == 0 && s.curves == NULL);
  }
  /* A missing file is an I/O error naming it. */
  ch_curve_set s;
  ch_error err = {0};
  CHECK(ch_curves_read_svg("/nonexistent/x.svg", &s, &err) == CH_ERR_IO);
  CHECK(strstr(err.message, "/nonexistent/x.svg") != NULL);
}

/* Files beyond libxml2's default limits but within chisel's: a path whose d
 * attribute is over 10 MB (libxml2's cap on one text node without its huge
 * mode) parses, with every segment; elements nest up to CH_SVG_MAX_DEPTH
 * levels and one more is refused; an entity expansion in text content (not
 * expanded by the reader) passes with the ignored element's warning. */
static void test_large_and_deep(void) {
  enum { SEGMENTS = 900000 };
  size_t cap = 200 + (size_t)SEGMENTS * 16, len = 0;
  char *text = malloc(cap);
  REQUIRE(text != NULL);
  len += (size_t)snprintf(text + len, cap - len,
                          "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'><path d='M 0 0");
  for (int i = 1; i <= SEGMENTS; i++) /* a zigzag, so no two segments are collinear */
    len += (size_t)snprintf(text + len, cap - len, " L %.3f %d", 100.0 * i / SEGMENTS, i % 2 ? 50 : 49);
  len += (size_t)snprintf(text + len, cap - len, "'/></svg>");
  CHECK(len > 10u * 1000 * 1000);
  ch_curve_set s;
  ch_error err = {0};
  CHECK_MSG(ch_curves_parse_svg(text, len, "long.svg", &s, &err) == CH_OK, "%s", err.message);
  CHECK(s.num_segments == SEGMENTS);
  if (s.num_segments == SEGMENTS) CHECK_NEAR(s.segments[SEGMENTS - 1].p[2][0], 1.0, 1e-12);
  ch_curves_free(&s);
  for (int depth = CH_SVG_MAX_DEPTH; depth <= CH_SVG_MAX_DEPTH + 1; depth++) {
    len = 0;
    len += (size_t)snprintf(text + len, cap - len, "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 1 1'>");
    for (int i = 1; i < depth; i++) len += (size_t)snprintf(text + len, cap - len, "<g>");
    len += (size_t)snprintf(text + len, cap - len, "<path d='M 0 0 L 1 1'/>");
    for (int i = 1; i < depth; i++) len += (size_t)snprintf(text + len, cap - len, "</g>");
    len += (size_t)snprintf(text + len, cap - len, "</svg>");
    memset(&err, 0, sizeof err);
    ch_status st = ch_curves_parse_svg(text, len, "deep.svg", &s, &err);
    if (depth == CH_SVG_MAX_DEPTH) {
      CHECK_MSG(st == CH_OK && s.num_curves == 1, "%d levels: %s", depth, err.message);
      ch_curves_free(&s);
    } else {
      CHECK(st == CH_ERR_INPUT && strstr(err.message, "nested deeper than 256 levels") != NULL);
    }
  }
  free(text);
  char path[512];
  snprintf(path, sizeof path, "%s/svg/laughs_in_text.svg", CHISEL_TEST_DATA);
  memset(&err, 0, sizeof err);
  CHECK_MSG(ch_curves_read_svg(path, &s, &err) == CH_OK, "%s", err.message);
  CHECK(s.num_curves == 1 && err.num_warnings == 1);
  ch_curves_free(&s);
}

/* Painted fills are raised against 0 all round their edges: where two
 * overlap, share an edge, nest, or one crosses itself, h_step blends
 * instead of filling their union, and one warning says where (two tiles
 * side by side: 0 in a third of one). Fills apart, touching at a corner,
 * and a ring drawn as one evenodd path do not warn. */
/* <use>: copies of shapes, groups and symbols where the use stands, moved
 * by its x and y and styled from it (and <switch>'s first child that needs
 * no extension); cycles and expansion attacks fail
 * with one line; a reference to nothing is ignored with a warning. */
static void test_use(void) {
  ch_curve_set s;
  ch_error err;
  REQUIRE(parse("<rect id='r' fill='#888' x='10' y='10' width='10' height='10'/>"
                "<use xlink:href='#r' x='50' transform='translate(0,5)' xmlns:xlink='http://www.w3.org/1999/xlink'/>"
                "<defs><path id='p' d='M 0 0 L 10 0'/>"
                "<symbol id='s' viewBox='0 0 10 10'><circle cx='5' cy='5' r='5' fill='#000'/></symbol></defs>"
                "<use href='#p' stroke='#000' stroke-width='2' y='50'/>"
                "<use href='#s' x='20' y='20' width='40' height='20'/>",
                &s, &err) == CH_OK);
  REQUIRE(s.num_curves == 4);
  CHECK(err.num_warnings == 0);
  CHECK(s.curves[0].kind == CH_CURVE_STEP && s.curves[1].kind == CH_CURVE_STEP);
  /* the copy: 50 right, 5 down */
  CHECK_NEAR(s.curves[1].bbox[0] - s.curves[0].bbox[0], 0.5, 1e-12);
  CHECK_NEAR(s.curves[1].bbox[1] - s.curves[0].bbox[1], -0.05, 1e-12);
  /* the path from <defs>, a groove by the use's stroke, at y = 50 */
  CHECK(s.curves[2].kind == CH_CURVE_GROOVE && strcmp(s.curves[2].decided_by, "stroke") == 0);
  CHECK_NEAR(s.curves[2].width, 0.02, 1e-15);
  CHECK_NEAR(P(&s, s.curves[2].first_segment, 0, 1), 0.5, 1e-15);
  /* the symbol's 10 x 10 fitted into 40 x 20 at (20, 20): scale 2, centred:
   * the circle at (40, 30) with radius 10 */
  CHECK(s.curves[3].kind == CH_CURVE_STEP);
  CHECK_NEAR(s.curves[3].bbox[0], 0.30, 1e-6);
  CHECK_NEAR(s.curves[3].bbox[2], 0.50, 1e-6);
  CHECK_NEAR(s.curves[3].bbox[1], 1.0 - 0.40, 1e-6);
  CHECK_NEAR(s.curves[3].bbox[3], 1.0 - 0.20, 1e-6);
  ch_curves_free(&s);
  /* Illustrator's <switch>: its private data passed over, the drawing read */
  REQUIRE(parse("<switch><foreignObject requiredExtensions='http://ns.adobe.com/AdobeIllustrator/10.0/' x='0' y='0' "
                "width='1' height='1'/><g><path fill='#000' d='M 0 0 L 10 0 L 10 10 Z'/></g>"
                "<path d='M 0 0 L 1 1'/></switch>",
                &s, &err) == CH_OK);
  CHECK(s.num_curves == 1 && s.curves[0].kind == CH_CURVE_STEP && err.num_warnings == 0);
  ch_curves_free(&s);
  /* a reference to nothing: ignored, said once */
  REQUIRE(parse("<use href='#nope'/><path d='M 0 0 L 1 1'/>", &s, &err) == CH_OK);
  CHECK(s.num_curves == 1 && err.num_warnings == 1);
  ch_curves_free(&s);
  /* cycles and expansion */
  static const struct {
    const char *body, *message;
  } bad[] = {
      {"<g id='a'><use href='#a'/></g>", "<use> refers to an element that holds it"},
      {"<use id='u1' href='#u2'/><use id='u2' href='#u1'/>", "<use> refers to itself"},
      {"<path id='l0' d='M 0 0 L 1 1'/>"
       "<g id='l1'><use href='#l0'/><use href='#l0'/><use href='#l0'/><use href='#l0'/><use href='#l0'/>"
       "<use href='#l0'/><use href='#l0'/><use href='#l0'/><use href='#l0'/><use href='#l0'/></g>"
       "<g id='l2'><use href='#l1'/><use href='#l1'/><use href='#l1'/><use href='#l1'/><use href='#l1'/>"
       "<use href='#l1'/><use href='#l1'/><use href='#l1'/><use href='#l1'/><use href='#l1'/></g>"
       "<g id='l3'><use href='#l2'/><use href='#l2'/><use href='#l2'/><use href='#l2'/><use href='#l2'/>"
       "<use href='#l2'/><use href='#l2'/><use href='#l2'/><use href='#l2'/><use href='#l2'/></g>"
       "<g id='l4'><use href='#l3'/><use href='#l3'/><use href='#l3'/><use href='#l3'/><use href='#l3'/>"
       "<use href='#l3'/><use href='#l3'/><use href='#l3'/><use href='#l3'/><use href='#l3'/></g>"
       "<g id='l5'><use href='#l4'/><use href='#l4'/><use href='#l4'/><use href='#l4'/><use href='#l4'/>"
       "<use href='#l4'/><use href='#l4'/><use href='#l4'/><use href='#l4'/><use href='#l4'/></g>"
       "<g id='l6'><use href='#l5'/><use href='#l5'/><use href='#l5'/><use href='#l5'/><use href='#l5'/>"
       "<use href='#l5'/><use href='#l5'/><use href='#l5'/><use href='#l5'/><use href='#l5'/></g>",
       "more than 100000 <use> copies"},
      {"<symbol id='s' viewBox='0 0 0 10'/><use href='#s'/>", "viewBox with a zero or negative size"},
      {"<path id='p' d='M 0 0 L 1 1'/><use href='#p' x='5%'/>", "<use> x '5%' is not a length"},
  };
  for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
    ch_status st = parse(bad[i].body, &s, &err);
    CHECK_MSG(st == CH_ERR_INPUT && strstr(err.message, bad[i].message) && strncmp(err.message, "t.svg: ", 7) == 0,
              "case %zu: %d '%s'", i, (int)st, err.message);
    if (st == CH_OK) ch_curves_free(&s);
  }
}

/* Fills as icon sets draw them (GNOME's Adwaita): a rounded corner that
 * leaves a rectangle's edge along it, and a circle closed by a line 0.001
 * long back over its start. The first failed to close into loops (two
 * pieces 2e-9 long between a crossing Newton's steps left 1e-8 from the
 * corner and the corner) and fell back to blending, h up to 0.018; the
 * second left a sliver loop whose corners made h reach 0.0117. */
static void test_fill_union_icons(void) {
  static const struct {
    const char *svg;
    int curves, subpaths;
  } cases[] = {
      {"<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 16 16'><path fill='#000' d='M2 1v14h2V1z'/>"
       "<path fill='#000' d='M3 1a1 1 0 00-1 1v6a1 1 0 001 1h10V1z'/></svg>",
       1, 1},
      {"<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 16 16'><path fill='#000' "
       "d='M10.511 2.813a.697.697 0 110 1.398.697.697 0 01-.699-.7c0-.387.312-.698.7-.698z'/></svg>",
       1, 1},
      /* a straight cubic that runs down an edge and back before the edge */
      {"<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 16 16'><path fill='#000' d='M3.8 0C2.849 0 2 .793 2 "
       "1.746v6.613c0 .953.849 1.746 1.868 1.746h5.264c1.02 0 1.868-.793 1.868-1.746V1.746C11 .793 10.151 0 9.132 "
       "0zM4 2h5c0 .317 0-.316 0 0v6H4s0 .044 0 0V2c0-.044 0 0 0 0z'/></svg>",
       1, 2},
  };
  for (int k = 0; k < (int)(sizeof cases / sizeof cases[0]); k++) {
    ch_curve_set s;
    ch_error err = {0};
    REQUIRE(ch_curves_parse_svg(cases[k].svg, strlen(cases[k].svg), "icon.svg", &s, &err) == CH_OK);
    CHECK_MSG(err.num_warnings == 0 && s.num_curves == cases[k].curves && s.num_subpaths == cases[k].subpaths,
              "case %d: %d warnings, %d curves, %d subpaths", k, err.num_warnings, s.num_curves, s.num_subpaths);
    ch_height h;
    ch_height_desc hd = {.dci_resolution = 256, .step_method = CH_RECON_EXACT};
    REQUIRE(ch_height_init(&h, &s, &hd, &err) == CH_OK);
    double lo = 1e300, hi = -1e300;
    for (int y = 0; y < 256; y++)
      for (int x = 0; x < 256; x++) {
        double e = ch_height_eval(&h, (x + 0.5) / 256, 1.0 - (y + 0.5) / 256);
        lo = fmin(lo, e), hi = fmax(hi, e);
      }
    CHECK_MSG(lo >= -1e-9 && hi <= 0.01 + 1e-9, "case %d: h in [%g, %g]", k, lo, hi);
    ch_height_free(&h);
    ch_curves_free(&s);
  }
}

static void keep_warning(void *user, const char *msg) { snprintf(user, 600, "%s", msg); }

/* <style> rules as Illustrator writes them, and the cascade (ch_css.h):
 * presentation attribute < rules by specificity, then order < style
 * attribute < !important rules. */
static void test_stylesheets(void) {
  ch_curve_set s;
  ch_error err;
  /* Illustrator's default export: every paint from a class */
  REQUIRE(parse("<style type='text/css'>\n\t.st0{fill:#231F20;}\n\t.st1{fill:none;stroke:#231F20;stroke-width:2;"
                "stroke-miterlimit:10;}\n</style>"
                "<circle class='st0' cx='30' cy='30' r='12'/><path class='st1' d='M10,80 C30,60 60,90 90,70'/>",
                &s, &err) == CH_OK);
  REQUIRE(s.num_curves == 2);
  CHECK(s.curves[0].kind == CH_CURVE_STEP && strcmp(s.curves[0].decided_by, "fill") == 0);
  CHECK(s.curves[1].kind == CH_CURVE_GROOVE && strcmp(s.curves[1].decided_by, "stroke") == 0);
  CHECK_NEAR(s.curves[1].width, 0.02, 1e-15);
  CHECK(err.num_warnings == 0);
  ch_curves_free(&s);
  /* the cascade: each path says in its id what it should come out as */
  REQUIRE(parse("<defs><style><![CDATA[ /* a comment { } */\n"
                "@media print { .a { stroke: red } }\n"
                "@import url('x.css');\n"
                "path { fill: #000 }\n"
                ".a, .b { stroke: #000; stroke-width: 3 }\n"
                ".c { fill: none }\n"
                "#g1 { fill: none }\n"
                ".c.d { stroke: none; fill: #111 }\n"
                ".e { stroke: #000 !important }\n"
                ".hide { display: none }\n"
                "g > path, path:hover, [fill] { fill: none }\n"
                ".url { fill: url(#grad); }\n"
                "]]></style></defs>"
                "<path id='fill-by-type' d='M 0 0 L 10 0 L 10 10 Z'/>"
                "<path id='groove-class-over-type' class='a' d='M 0 20 L 10 20 L 10 30 Z'/>"
                "<path id='groove-second-of-list' class=' x b ' d='M 0 40 L 10 40 L 10 50 Z'/>"
                "<path id='g1' class='b' d='M 0 60 L 10 60 L 10 70 Z'/>"
                "<path id='fill-two-classes' class='a c d' d='M 20 0 L 30 0 L 30 10 Z'/>"
                "<path id='default-class-over-attribute' class='c' fill='#000' d='M 20 20 L 30 20 L 30 30 Z'/>"
                "<path id='fill-style-over-class' class='c' style='fill:#000' d='M 20 40 L 30 40 L 30 50 Z'/>"
                "<path id='groove-important-over-style' class='e' style='stroke:none' d='M 20 60 L 30 60 L 30 70 Z'/>"
                "<path id='hidden' class='hide' d='M 40 0 L 50 0 L 50 10 Z'/>"
                "<g class='c'><path id='fill-own-type-rule' d='M 40 20 L 50 20 L 50 30 Z'/></g>"
                "<g class='a'><rect id='groove-inherited' x='40' y='40' width='5' height='5'/></g>"
                "<path id='fill-url-paint' class='c url' d='M 40 60 L 50 60 L 50 70 Z'/>",
                &s, &err) == CH_OK);
  static const char *want[][2] = {{"fill-by-type", "fill"},
                                  {"groove-class-over-type", "stroke"},
                                  {"groove-second-of-list", "stroke"},
                                  {"g1", "stroke"},
                                  {"fill-two-classes", "fill"},
                                  {"default-class-over-attribute", "default"},
                                  {"fill-style-over-class", "fill"},
                                  {"groove-important-over-style", "stroke"},
                                  {"fill-own-type-rule", "fill"},
                                  {"groove-inherited", "stroke"},
                                  {"fill-url-paint", "fill"}};
  int n = (int)(sizeof want / sizeof want[0]);
  CHECK_MSG(s.num_curves == n, "%d curves", s.num_curves);
  for (int i = 0; i < n && i < s.num_curves; i++)
    CHECK_MSG(strcmp(s.curves[i].id, want[i][0]) == 0 && strcmp(s.curves[i].decided_by, want[i][1]) == 0,
              "curve %d '%s': decided by %s, want %s", i, s.curves[i].id, s.curves[i].decided_by, want[i][1]);
  if (s.num_curves > 1) CHECK_NEAR(s.curves[1].width, 0.03, 1e-15);
  ch_curves_free(&s);
  /* selectors it does not read: one warning names the first */
  char msg[600] = "";
  ch_error werr = {.warn = keep_warning, .warn_user = msg};
  const char *svg =
      "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'><style>g > path, path:hover, "
      ".ok { fill: #000 }</style><path class='ok' d='M 0 0 L 10 0 L 10 10 Z'/></svg>";
  REQUIRE(ch_curves_parse_svg(svg, strlen(svg), "w.svg", &s, &werr) == CH_OK);
  CHECK(s.num_curves == 1 && s.curves[0].kind == CH_CURVE_STEP);
  CHECK_MSG(werr.num_warnings == 1 && strstr(msg, "w.svg: <style>: 2 selectors ignored (first 'g > path')"), "%s", msg);
  ch_curves_free(&s);
}

/* The painted regions of the fill cases below, in SVG units (y down): 1
 * painted, 0 not; d gets the distance to the nearest edge (points closer
 * than the quadratics' 1e-6 approximation of arcs are not judged). */
static double circle_in(double x, double y, double cx, double cy, double r, double *d) {
  double e = fabs(hypot(x - cx, y - cy) - r);
  if (e < *d) *d = e;
  return hypot(x - cx, y - cy) < r;
}

static double rect_in(double x, double y, double x0, double y0, double w, double h, double *d) {
  double e = fmin(fmin(fabs(x - x0), fabs(x - x0 - w)), fmin(fabs(y - y0), fabs(y - y0 - h)));
  if (e < *d) *d = e;
  return x > x0 && x < x0 + w && y > y0 && y < y0 + h;
}

/* The pentagram's winding number at (x, y), and the distance to its
 * edges. */
static int star_winding(double x, double y, double *d) {
  static const double p[5][2] = {{50, 10}, {73.5, 82.4}, {12, 37.6}, {88, 37.6}, {26.5, 82.4}};
  int w = 0;
  for (int i = 0; i < 5; i++) {
    const double *a = p[i], *b = p[(i + 1) % 5];
    double ex = b[0] - a[0], ey = b[1] - a[1], t = ((x - a[0]) * ex + (y - a[1]) * ey) / (ex * ex + ey * ey);
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    double e = hypot(x - a[0] - t * ex, y - a[1] - t * ey);
    if (e < *d) *d = e;
    double cr = ex * (y - a[1]) - (x - a[0]) * ey;
    if (a[1] <= y && b[1] > y && cr > 0) w++;
    if (b[1] <= y && a[1] > y && cr < 0) w--;
  }
  return w;
}

static int fill_case_painted(int k, double x, double y, double *d) {
  switch (k) {
    case 0:
      return circle_in(x, y, 40, 50, 15, d) + circle_in(x, y, 60, 50, 15, d) > 0;
    case 1:
      return rect_in(x, y, 20, 20, 30, 30, d) + rect_in(x, y, 50, 20, 30, 30, d) > 0;
    case 2:
      return rect_in(x, y, 20, 20, 60, 60, d) + circle_in(x, y, 50, 50, 10, d) > 0;
    case 3:
      return (star_winding(x, y, d) & 1) != 0;
    case 4:
      return star_winding(x, y, d) != 0;
    case 5:
      return rect_in(x, y, 20, 20, 30, 30, d) + rect_in(x, y, 50, 50, 30, 30, d) > 0;
    case 6:
      return circle_in(x, y, 50, 50, 30, d) && !circle_in(x, y, 50, 50, 15, d);
    case 7:
      return rect_in(x, y, 10, 10, 80, 15, d) + rect_in(x, y, 10, 75, 80, 15, d) + rect_in(x, y, 10, 10, 15, 80, d) +
                 rect_in(x, y, 75, 10, 15, 80, d) >
             0;
    case 8:
      return rect_in(x, y, 20, 20, 40, 40, d) + rect_in(x, y, 20, 20, 40, 40, d) > 0;
    default:
      return rect_in(x, y, 20, 20, 60, 30, d) + rect_in(x, y, 40, 50, 20, 20, d) > 0;
  }
}

/* Painted fills that overlap, share an edge, nest, cross themselves or are
 * drawn twice come out as the union the drawing shows (docs/svg.md):
 * outlines whose winding numbers, summed, are 1 exactly where the union
 * is painted and 0 elsewhere (so each loop has it on its left, and no edge
 * is left inside it or drawn twice), without a warning; fills apart are
 * left as read. */
static void test_fill_union(void) {
  static const struct {
    const char *body;
    int curves, subpaths, segments; /* after the union (segments -1: not checked) */
  } cases[] = {
      {"<circle fill='#888' cx='40' cy='50' r='15'/><circle fill='#888' cx='60' cy='50' r='15'/>", 1, 1, -1},
      {"<rect fill='#888' x='20' y='20' width='30' height='30'/><rect fill='#888' x='50' y='20' width='30' "
       "height='30'/>",
       1, 1, 6},
      {"<rect fill='#888' x='20' y='20' width='60' height='60'/><circle fill='#fff' cx='50' cy='50' r='10'/>", 1, 1, 4},
      {"<path fill='#888' fill-rule='evenodd' d='M 50 10 L 73.5 82.4 L 12 37.6 L 88 37.6 L 26.5 82.4 Z'/>", 1, 5, 15},
      {"<path fill='#888' d='M 50 10 L 73.5 82.4 L 12 37.6 L 88 37.6 L 26.5 82.4 Z'/>", 1, 1, 10},
      /* touching at a corner: as read */
      {"<rect fill='#888' x='20' y='20' width='30' height='30'/><rect fill='#888' x='50' y='50' width='30' "
       "height='30'/>",
       2, 2, 8},
      /* a ring by the even-odd rule: as read */
      {"<path fill='#888' fill-rule='evenodd' d='M 50 20 A 30 30 0 1 0 50 80 A 30 30 0 1 0 50 20 Z "
       "M 50 35 A 15 15 0 1 0 50 65 A 15 15 0 1 0 50 35 Z'/>",
       1, 2, -1},
      /* four bars make a frame: an outline and a hole */
      {"<rect fill='#888' x='10' y='10' width='80' height='15'/><rect fill='#888' x='10' y='75' width='80' "
       "height='15'/><rect fill='#888' x='10' y='10' width='15' height='80'/><rect fill='#888' x='75' y='10' "
       "width='15' height='80'/>",
       1, 2, -1},
      /* drawn twice */
      {"<rect fill='#888' x='20' y='20' width='40' height='40'/><rect fill='#888' x='20' y='20' width='40' "
       "height='40'/>",
       1, 1, 4},
      /* a T: the stem's top edge lies along part of the bar's bottom edge */
      {"<rect fill='#888' x='20' y='20' width='60' height='30'/><rect fill='#888' x='40' y='50' width='20' "
       "height='20'/>",
       1, 1, 8},
  };
  for (int k = 0; k < (int)(sizeof cases / sizeof cases[0]); k++) {
    ch_curve_set s;
    ch_error err;
    REQUIRE(parse(cases[k].body, &s, &err) == CH_OK);
    CHECK_MSG(err.num_warnings == 0, "case %d: %d warnings", k, err.num_warnings);
    CHECK_MSG(s.num_curves == cases[k].curves && s.num_subpaths == cases[k].subpaths &&
                  (cases[k].segments < 0 || s.num_segments == cases[k].segments),
              "case %d: %d curves, %d subpaths, %d segments", k, s.num_curves, s.num_subpaths, s.num_segments);
    /* how many fills were redrawn and merged away, for chisel info */
    static const int united[10][2] = {{2, 1}, {2, 1}, {1, 1}, {1, 0}, {1, 0}, {0, 0}, {0, 0}, {4, 3}, {2, 1}, {2, 1}};
    CHECK_MSG(s.fills_united == united[k][0] && s.fills_dropped == united[k][1], "case %d: %d united, %d dropped", k,
              s.fills_united, s.fills_dropped);
    int wrong = 0, judged = 0;
    for (int j = 0; j < 200; j++)
      for (int i = 0; i < 200; i++) {
        double x = (i + 0.5) / 2.0, y = (j + 0.5) / 2.0, d = 1e300, q[2] = {x / 100.0, 1.0 - y / 100.0};
        int want = fill_case_painted(k, x, y, &d);
        if (d < 1e-3) continue;
        int w = 0;
        for (int c = 0; c < s.num_curves; c++)
          w += ch_segments_winding(&s, s.curves[c].first_segment, s.curves[c].num_segments, q);
        judged++;
        wrong += w != want;
      }
    CHECK_MSG(wrong == 0 && judged > 30000, "case %d: %d of %d points wrong", k, wrong, judged);
    /* h itself, as displace and sample read it (the DCI at 256^2 through
     * exact reconstruction): the fill height or 0, nothing between, away
     * from the edges by more than a texel */
    ch_height h;
    ch_height_desc hd = {.dci_resolution = 256, .step_method = CH_RECON_EXACT};
    REQUIRE(ch_height_init(&h, &s, &hd, &err) == CH_OK);
    int off = 0;
    double worst = 0.0;
    for (int j = 0; j < 64; j++)
      for (int i = 0; i < 64; i++) {
        double x = (i + 0.5) * 100.0 / 64, y = (j + 0.5) * 100.0 / 64, d = 1e300;
        int want = fill_case_painted(k, x, y, &d);
        if (d < 0.5) continue;
        double e = fabs(ch_height_eval(&h, x / 100.0, 1.0 - y / 100.0) - 0.01 * want);
        off += e > 1e-9;
        if (e > worst) worst = e;
      }
    CHECK_MSG(off == 0, "case %d: h off at %d points (by up to %g)", k, off, worst);
    ch_height_free(&h);
    for (int c = 0; c < s.num_curves; c++) CHECK(s.curves[c].left == 0.01 && s.curves[c].right == 0.0);
    ch_curves_free(&s);
  }
  /* a background over the whole square: said */
  {
    ch_curve_set s;
    char msg[600] = "";
    ch_error werr = {.warn = keep_warning, .warn_user = msg};
    const char *svg =
        "<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'><rect width='100' height='100' "
        "fill='white'/><circle fill='#000' cx='50' cy='50' r='10'/></svg>";
    REQUIRE(ch_curves_parse_svg(svg, strlen(svg), "bg.svg", &s, &werr) == CH_OK);
    CHECK_MSG(werr.num_warnings == 1 && strstr(msg, "bg.svg: <rect> #0 (line 1) is filled over the whole UV square"),
              "%s", msg);
    ch_curves_free(&s);
  }
  /* explicit sides are the drawing's own: left as read */
  ch_curve_set s;
  ch_error err;
  REQUIRE(parse("<circle data-kind='step' data-left='0.01' cx='40' cy='50' r='15'/><circle data-kind='step' "
                "data-left='0.01' cx='60' cy='50' r='15'/>",
                &s, &err) == CH_OK);
  CHECK(s.num_curves == 2 && err.num_warnings == 0);
  ch_curves_free(&s);
}

/* Every bundled curve set parses without warnings. */
static void test_bundled_curves(void) {
  static const char *files[] = {"glyphs", "ornament", "frame", "relief", "star", "spiral", "bricks", "panels"};
  for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
    char path[512];
    snprintf(path, sizeof path, "%s/curves/%s.svg", CHISEL_MODELS, files[i]);
    ch_curve_set s;
    ch_error err = {0};
    CHECK_MSG(ch_curves_read_svg(path, &s, &err) == CH_OK, "%s", err.message);
    CHECK_MSG(err.num_warnings == 0, "%s: %d warnings", files[i], err.num_warnings);
    ch_curves_free(&s);
  }
}

int main(void) {
  RUN(test_viewbox_mapping);
  RUN(test_path_commands);
  RUN(test_shapes_and_sides);
  RUN(test_transforms_and_inheritance);
  RUN(test_malformed_files);
  RUN(test_large_and_deep);
  RUN(test_bundled_curves);
  RUN(test_stylesheets);
  RUN(test_use);
  RUN(test_fill_union);
  RUN(test_fill_union_icons);
  TEST_MAIN_END();
}
