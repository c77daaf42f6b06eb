/* Evaluating feature-curve textures at a point: feature-curves-textures
 * §5 (locating the point in the eight-triangle partition of its cell by
 * side tests, values at the triangle's corners from the cell corners in
 * the same domain, interpolation in straight, 1C and 2C triangles, the
 * normal by eq. (1)) and normal-maps-discontinuities §4.3 (the linear
 * variant: straight pieces and triangles).
 *
 * Departures, each for a reason:
 * - 2C triangles are swept by lines parallel to their straight edge (the
 *   paper's auxiliary point r taken at infinity along that edge): each
 *   line meets each curved edge where a quadratic equation says, so no
 *   Bezier clipping loop is needed; values on all three edges are the
 *   same as the paper's (linear along the straight edge, linear in the
 *   curve parameter along the curved ones), so continuity is unchanged.
 * - Which curve and side a point belongs to (for the profile and for a
 *   step's side) is the best of: each corner in the point's domain
 *   (its nearest curve, at its distance plus the way there) and each
 *   segment of the cell (at its first-order distance |f| / |grad f|).
 * - The profile normal is taken over the base normal's slope, so that a
 *   groove on a sloping h_step gets the normal of their sum (for a flat
 *   base it is the papers' (-p' grad d, 1)).
 * - Fallback cells (ch_featmap_build step 6) are evaluated exactly from
 *   their list of pieces: the nearest point, its side by docs/spec.md §3's rule.
 * Everything is per point, bounded and allocation-free (shader-shaped). */
#include <math.h>
#include <string.h>

#include "ch_bezier.h"
#include "ch_featmap.h"
#include "ch_featmap_cell.h"
#include "ch_groove.h"
#include "ch_math.h"
#include "ch_warp.h"

double ch_featmap_profile_slope(const ch_profile *pr, double t) {
  double a = fabs(t);
  switch (pr->kind) {
  case CH_PROFILE_V: return a < 0.5 ? (t < 0.0 ? -2.0 : 2.0) : 0.0;
  case CH_PROFILE_U: {
    if (!(a < 0.5)) return 0.0;
    double r = 1.0 - 4.0 * t * t;
    return 4.0 * t / sqrt(r > 1e-16 ? r : 1e-16);
  }
  case CH_PROFILE_BOX: return 0.0;
  case CH_PROFILE_RIDGE: return a < 0.5 ? (t < 0.0 ? 2.0 : -2.0) : 0.0;
  case CH_PROFILE_BEVEL: return t > 0.0 && t < 0.5 ? 2.0 : 0.0;
  case CH_PROFILE_CUSTOM:
    for (int i = 0; i + 1 < pr->num_points && i + 1 < CH_PROFILE_MAX_POINTS; i++)
      if (t >= pr->t[i] && t < pr->t[i + 1]) return (pr->h[i + 1] - pr->h[i]) / (pr->t[i + 1] - pr->t[i]);
    return 0.0;
  }
  return 0.0;
}

void ch_featmap_profile_normal(const ch_featmap_curve *c, int side, double d, const double grad[2],
                               const double base[3], double w0, double w1, double n[3]) {
  double B[3] = {base[0], base[1], base[2]};
  double bl = sqrt(B[0] * B[0] + B[1] * B[1] + B[2] * B[2]);
  if (!(bl > 0.0) || !(B[2] > 0.0)) B[0] = B[1] = 0.0, B[2] = bl = 1.0;
  for (int k = 0; k < 3; k++) B[k] /= bl;
  if (!c || c->kind != CH_CURVE_GROOVE || !(c->width > 0.0)) {
    memcpy(n, B, sizeof B);
    return;
  }
  /* b(d): 0 up to w0, 1 from w1, smoothstep between. */
  double b;
  if (d < w0) b = 0.0;
  else if (d >= w1) b = 1.0;
  else {
    double x = (d - w0) / (w1 - w0);
    b = x * x * (3.0 - 2.0 * x);
  }
  if (b >= 1.0) {
    memcpy(n, B, sizeof B);
    return;
  }
  double t = side * d / c->width;
  /* h_p = depth P(s / w), s = side d: grad h_p = depth / w P'(t) side grad d */
  double k = c->depth / c->width * ch_featmap_profile_slope(&c->profile, t) * side;
  double np[3] = {B[0] / B[2] - k * grad[0], B[1] / B[2] - k * grad[1], 1.0};
  if (b > 0.0) {
    double len = sqrt(np[0] * np[0] + np[1] * np[1] + 1.0);
    for (int i = 0; i < 3; i++) np[i] = (1.0 - b) * np[i] + b * len * B[i];
  }
  double l = sqrt(np[0] * np[0] + np[1] * np[1] + np[2] * np[2]);
  for (int i = 0; i < 3; i++) n[i] = np[i] / l;
}

int ch_featmap_method_parse(const char *name) {
  if (!strcmp(name, "featnorm")) return CH_FEATMAP_FEATNORM;
  if (!strcmp(name, "featnorm-linear")) return CH_FEATMAP_LINEAR;
  if (!strcmp(name, "normal-bilinear")) return CH_FEATMAP_BILINEAR;
  return -1;
}

double ch_featmap_bytes_per_texel(const ch_featmap *m, ch_featmap_method method) {
  /* As evaluated here, float32 / int32 per lattice point:
   * featnorm: distance 4, gradient 8, nearest curve 4; per cell south and
   * west edge (position, angle) 16, configuration 4, segments' curves 8;
   * the base normal 12 where h_step is not flat, and 4 for the index of
   * the singular point its sample leaves out where there are any.
   * featnorm-linear: no angles (8 less). normal-bilinear: the normal map,
   * 12. */
  double base = (m->has_base ? 12.0 : 0.0) + (m->sg_near ? 4.0 : 0.0);
  switch (method) {
  case CH_FEATMAP_FEATNORM: return 44.0 + base;
  case CH_FEATMAP_LINEAR: return 36.0 + base;
  case CH_FEATMAP_BILINEAR: return 12.0;
  }
  return 0.0;
}

double ch_featmap_fallback_bytes(const ch_featmap *m) {
  /* start and count per fallback cell, 4 per list entry, per piece 6
   * control coordinates, 2 tangents, curve and flags: 48 (float32). */
  double cells = (double)m->resolution * m->resolution;
  return (8.0 * m->stats.fallback_cells + 4.0 * m->fb_list_size + 48.0 * m->num_pieces) / cells;
}

/* ---- values interpolated over the cell: distance, gradient, base ---- */

enum { NV = 7 }; /* d, gx, gy, bx, by, bz, signed d */
typedef struct vals {
  double v[NV];
} vals;

static inline vals vlerp(const vals *a, const vals *b, double t) {
  vals r;
  for (int k = 0; k < NV; k++) r.v[k] = a->v[k] + t * (b->v[k] - a->v[k]);
  return r;
}

static inline vals vavg(const vals *a, const vals *b) { return vlerp(a, b, 0.5); }

typedef struct cell_ctx {
  const ch_featmap *m;
  double du, dv;     /* the cell's UV extent per cell unit, per axis (first order under a warp) */
  double cuv[4][2];  /* the corners' UV (the labels measure there) */
  double puv[2];     /* the point's UV */
  size_t corner[4];  /* lattice indices of c0..c3 */
  vals cv[4];        /* corner values */
  int ccurve[4], cside[4];
  fm_signature sig;
  fm_curve seg[2];
  fm_partition P;
  int dom_p[2];      /* the point's side of each segment */
  int reach[4];      /* corners in the point's domain */
} cell_ctx;

static void load_corners(cell_ctx *c, int ci, int cj) {
  const ch_featmap *m = c->m;
  int R1 = m->resolution + 1;
  c->corner[0] = (size_t)ci * R1 + cj;
  c->corner[1] = c->corner[0] + 1;
  c->corner[2] = c->corner[0] + R1 + 1;
  c->corner[3] = c->corner[0] + R1;
  for (int k = 0; k < 4; k++) {
    size_t s = c->corner[k];
    float d = m->dist[s];
    c->cv[k].v[0] = fabs(d);
    c->cv[k].v[1] = m->grad[2 * s];
    c->cv[k].v[2] = m->grad[2 * s + 1];
    c->cv[k].v[3] = m->base[3 * s];
    c->cv[k].v[4] = m->base[3 * s + 1];
    c->cv[k].v[5] = m->base[3 * s + 2];
    c->cv[k].v[6] = d;
    c->ccurve[k] = m->curve[s];
    c->cside[k] = d >= 0.0f ? 1 : -1;
  }
}

/* A corner's side of segment k (combinatorial: the segments run between
 * edge points, so the corners' sides follow from which edges they join). */
static int corner_dom(const fm_partition *P, int seg, int corner) {
  if (P->v_seg == seg) return corner == 0 || corner == 3; /* west */
  if (P->h_seg == seg) return corner == 2 || corner == 3; /* north */
  for (int ch = 0; ch < 4; ch++)
    if (P->chord_seg[ch] == seg) return corner == (ch + 1) % 4;
  return 0;
}

static void point_dom(cell_ctx *c, const double p[2], int quadrant) {
  const fm_partition *P = &c->P;
  for (int k = 0; k < c->sig.nseg; k++) {
    if (P->v_seg == k) c->dom_p[k] = quadrant == 0 || quadrant == 3;
    else if (P->h_seg == k) c->dom_p[k] = quadrant == 2 || quadrant == 3;
    else {
      int ch = 0;
      while (ch < 3 && P->chord_seg[ch] != k) ch++;
      c->dom_p[k] = quadrant == (ch + 1) % 4 && fm_corner_side(P, ch, p);
    }
  }
  for (int q = 0; q < 4; q++) {
    int same = 1;
    for (int k = 0; k < c->sig.nseg; k++) same &= corner_dom(P, k, q) == c->dom_p[k];
    c->reach[q] = same;
  }
}

/* The mean of the reachable corners (the fallback of the rules below). */
static vals reach_mean(const cell_ctx *c) {
  vals r = {{0}};
  int n = 0;
  for (int q = 0; q < 4; q++) {
    if (!c->reach[q]) continue;
    for (int k = 0; k < NV; k++) r.v[k] += c->cv[q].v[k];
    n++;
  }
  if (!n) return c->cv[0];
  for (int k = 0; k < NV; k++) r.v[k] /= n;
  return r;
}

/* Values at edge point e from its edge's corners in the point's domain
 * (feature-curves Appendix step 3.1: two corners interpolate, one is
 * copied, none: take the opposite end of a segment ending there). */
static int edge_from_corners(const cell_ctx *c, int e, vals *out) {
  int a = fm_edge_corner[e][0], b = fm_edge_corner[e][1];
  double pos = c->P.point[e] ? c->sig.pos[e] : 0.5;
  if (c->reach[a] && c->reach[b]) *out = vlerp(&c->cv[a], &c->cv[b], pos);
  else if (c->reach[a]) *out = c->cv[a];
  else if (c->reach[b]) *out = c->cv[b];
  else return 0;
  return 1;
}

static vals edge_value(const cell_ctx *c, int e) {
  vals r;
  if (!c->P.point[e]) {
    int a = fm_edge_corner[e][0], b = fm_edge_corner[e][1];
    r = vlerp(&c->cv[a], &c->cv[b], 0.5);
    if (!(c->reach[a] && c->reach[b]) && !edge_from_corners(c, e, &r)) r = reach_mean(c);
    return r;
  }
  if (!edge_from_corners(c, e, &r)) {
    int found = 0;
    for (int k = 0; k < c->sig.nseg && !found; k++) {
      int a = fm_pair_edges[c->sig.pair[k]][0], b = fm_pair_edges[c->sig.pair[k]][1];
      if (a != e && b != e) continue;
      found = edge_from_corners(c, a == e ? b : a, &r);
    }
    if (!found) r = reach_mean(c);
  }
  r.v[0] = r.v[6] = 0.0; /* on a discontinuity (or where a neighbour's curve ends) */
  return r;
}

static vals centre_value(const cell_ctx *c) {
  vals s = edge_value(c, FM_S), n = edge_value(c, FM_N), w = edge_value(c, FM_W), e = edge_value(c, FM_E);
  vals onv = vlerp(&s, &n, c->P.tv), onh = vlerp(&w, &e, c->P.th);
  int vs = c->P.v_seg >= 0, hs = c->P.h_seg >= 0;
  if (vs && hs) {
    vals r = vavg(&onv, &onh);
    r.v[0] = r.v[6] = 0.0;
    return r;
  }
  if (vs) return onv;
  if (hs) return onh;
  return vavg(&onv, &onh);
}

/* ---- interpolation in triangles ---- */

static vals bary(const double p[2], const double A[2], const double B[2], const double C[2], const vals *va,
                 const vals *vb, const vals *vc) {
  double ab[2] = {B[0] - A[0], B[1] - A[1]}, ac[2] = {C[0] - A[0], C[1] - A[1]}, ap[2] = {p[0] - A[0], p[1] - A[1]};
  double det = fm_cross(ab, ac);
  vals r;
  if (fabs(det) < 1e-300) return *va;
  double wb = fm_cross(ap, ac) / det, wc = fm_cross(ab, ap) / det, wa = 1.0 - wb - wc;
  for (int k = 0; k < NV; k++) r.v[k] = wa * va->v[k] + wb * vb->v[k] + wc * vc->v[k];
  return r;
}

/* 1C triangle: apex and a curved edge phi from P1 (value v1) to P2 (v2):
 * the ray from the apex through p meets phi at u (feature-curves eq. (9)),
 * s = |p' - p| / |p' - apex|, V = s V_apex + (1 - s) lerp(v1, v2, u). */
static vals one_c(const double p[2], const double apex[2], const fm_curve *phi, const vals *va, const vals *v1,
                  const vals *v2) {
  double D[2] = {p[0] - apex[0], p[1] - apex[1]};
  double dl = D[0] * D[0] + D[1] * D[1];
  if (dl < 1e-30) return *va;
  double t[2];
  int n = fm_curve_line(phi, apex, D, t);
  /* the crossing in front of the apex, within the edge */
  double best = -1.0, bd = INFINITY;
  for (int k = 0; k < n; k++) {
    if (t[k] < -1e-6 || t[k] > 1.0 + 1e-6) continue;
    double q[2];
    fm_curve_eval(phi, ch_clamp(t[k], 0.0, 1.0), q);
    double ahead = (q[0] - apex[0]) * D[0] + (q[1] - apex[1]) * D[1];
    if (ahead <= 0.0) continue;
    if (ahead < bd) bd = ahead, best = ch_clamp(t[k], 0.0, 1.0);
  }
  if (best < 0.0) return bary(p, apex, phi->p[0], phi->p[2], va, v1, v2);
  double q[2];
  fm_curve_eval(phi, best, q);
  double num = hypot(q[0] - p[0], q[1] - p[1]), den = hypot(q[0] - apex[0], q[1] - apex[1]);
  double s = den > 0.0 ? ch_clamp(num / den, 0.0, 1.0) : 1.0;
  vals onc = vlerp(v1, v2, best), r;
  for (int k = 0; k < NV; k++) r.v[k] = s * va->v[k] + (1.0 - s) * onc.v[k];
  return r;
}

/* 2C triangle <p1, p2, q>: curved phi1 (p1 -> p2) and phi2 (q -> p2), the
 * straight edge [p1, q]; swept by lines parallel to it (feature-curves eq.
 * (10) with the auxiliary point at infinity): the line through p meets
 * phi1 at u and phi2 at v, s = |p' - p| / |p' - p''|,
 * V = (1 - s) lerp(V1, V2, u) + s lerp(Vq, V2, v). */
static vals two_c(const double p[2], const fm_curve *phi1, const fm_curve *phi2, const vals *v1, const vals *vq,
                  const vals *v2) {
  const double *p1 = phi1->p[0], *q = phi2->p[0], *p2 = phi1->p[2];
  double D[2] = {q[0] - p1[0], q[1] - p1[1]};
  double h1 = fm_cross(D, (double[2]){p2[0] - p1[0], p2[1] - p1[1]});
  double h = fabs(h1) > 0.0 ? fm_cross(D, (double[2]){p[0] - p1[0], p[1] - p1[1]}) / h1 : 0.0;
  double tu[2], tv[2];
  int nu = fm_curve_line(phi1, p, D, tu), nv = fm_curve_line(phi2, p, D, tv);
  double u = fm_pick(tu, nu, h, 1e-6), v = fm_pick(tv, nv, h, 1e-6);
  if (u < 0.0 || v < 0.0) return bary(p, p1, p2, q, v1, v2, vq);
  double a[2], b[2];
  fm_curve_eval(phi1, u, a);
  fm_curve_eval(phi2, v, b);
  double ab = (b[0] - a[0]) * D[0] + (b[1] - a[1]) * D[1];
  double s = fabs(ab) > 1e-300 ? ch_clamp(((p[0] - a[0]) * D[0] + (p[1] - a[1]) * D[1]) / ab, 0.0, 1.0) : 0.0;
  vals e1 = vlerp(v1, v2, u), e2 = vlerp(vq, v2, v), r;
  for (int k = 0; k < NV; k++) r.v[k] = (1.0 - s) * e1.v[k] + s * e2.v[k];
  return r;
}

static void reverse_curve(const fm_curve *c, fm_curve *out) { fm_curve_set(out, c->p[2], c->p[1], c->p[0], c->straight); }

/* The spoke half from edge point e to r, as a curve from q_e to r. */
static void spoke_half(const fm_partition *P, int e, fm_curve *out) {
  fm_curve tmp;
  switch (e) {
  case FM_S: fm_curve_sub(&P->V, 0.0, P->tv, out); break;
  case FM_N: fm_curve_sub(&P->V, P->tv, 1.0, &tmp), reverse_curve(&tmp, out); break;
  case FM_W: fm_curve_sub(&P->H, 0.0, P->th, out); break;
  default: fm_curve_sub(&P->H, P->th, 1.0, &tmp), reverse_curve(&tmp, out); break;
  }
  /* its ends exactly at q_e and r */
  memcpy(out->p[0], P->q[e], sizeof out->p[0]);
  memcpy(out->p[2], P->r, sizeof out->p[2]);
}

/* Interpolates the partition's triangle holding p. */
static vals interpolate(cell_ctx *c, const double p[2]) {
  const fm_partition *P = &c->P;
  int quadrant = fm_quadrant(P, p);
  int ch = (quadrant + 3) % 4, a = ch, b = (ch + 1) % 4;
  int corner_side = fm_corner_side(P, ch, p);
  point_dom(c, p, quadrant);
  vals va = edge_value(c, a), vb = edge_value(c, b);
  if (corner_side) {
    const double *apex = fm_corner_xy[quadrant];
    if (P->chord[ch].straight) return bary(p, P->q[a], apex, P->q[b], &va, &c->cv[quadrant], &vb);
    return one_c(p, apex, &P->chord[ch], &c->cv[quadrant], &va, &vb);
  }
  vals vr = centre_value(c);
  fm_curve ha, hb;
  spoke_half(P, a, &ha);
  spoke_half(P, b, &hb);
  int cc = !P->chord[ch].straight, ac = !ha.straight, bc = !hb.straight;
  if (!cc && !ac && !bc) return bary(p, P->q[a], P->q[b], P->r, &va, &vb, &vr);
  if (cc && !ac && !bc) return one_c(p, P->r, &P->chord[ch], &vr, &va, &vb);
  if (ac && !cc && !bc) return one_c(p, P->q[b], &ha, &vb, &va, &vr);
  if (bc && !cc && !ac) return one_c(p, P->q[a], &hb, &va, &vb, &vr);
  fm_curve f1, f2;
  if (cc && ac) { /* meet at q_a; straight [q_b, r] */
    reverse_curve(&P->chord[ch], &f1);
    reverse_curve(&ha, &f2);
    f2.p[0][0] = P->r[0], f2.p[0][1] = P->r[1];
    return two_c(p, &f1, &f2, &vb, &vr, &va);
  }
  if (cc && bc) { /* meet at q_b; straight [q_a, r] */
    reverse_curve(&hb, &f2);
    return two_c(p, &P->chord[ch], &f2, &va, &vr, &vb);
  }
  /* both spoke halves: meet at r; straight [q_a, q_b] */
  return two_c(p, &ha, &hb, &va, &vb, &vr);
}

/* ---- labels ---- */

static void label(const cell_ctx *c, const double p[2], double signed_d, int *curve, int *side) {
  double best = INFINITY;
  int sides = 0;
  *curve = -1;
  *side = 1;
  for (int q = 0; q < 4; q++) {
    if (!c->reach[q]) continue;
    /* the distance to the corner's nearest curve point (the corner less
     * its distance along its gradient): exact where that point is p's
     * nearest too, an upper bound elsewhere */
    double dx = c->puv[0] - c->cuv[q][0] + c->cv[q].v[0] * c->cv[q].v[1];
    double dy = c->puv[1] - c->cuv[q][1] + c->cv[q].v[0] * c->cv[q].v[2];
    double d = sqrt(dx * dx + dy * dy);
    sides |= c->cside[q] > 0 ? 1 : 2;
    if (d < best) best = d, *curve = c->ccurve[q], *side = c->cside[q];
  }
  /* Corners on both sides with no segment between them: a medial axis or
   * the tangent line beyond an open end (docs/spec.md §3's cap) passes; its place
   * is where the interpolated signed distance changes sign. */
  if (sides == 3 && signed_d != 0.0) *side = signed_d > 0.0 ? 1 : -1;
  const ch_featmap *m = c->m;
  size_t cell = c->corner[0];
  uint32_t w = m->config[cell];
  for (int k = 0; k < c->sig.nseg; k++) {
    double d = fm_curve_distance(&c->seg[k], p, c->du, c->dv);
    if (!(d < best)) continue;
    int slot = (w & CH_FM_SEG_MASK) == (uint32_t)c->sig.pair[k] ? 0 : 1;
    int rev = (w & (slot ? CH_FM_REVERSED1 : CH_FM_REVERSED0)) != 0;
    int left = fm_left(&c->seg[k], p);
    best = d;
    *curve = m->seg_curve[2 * cell + slot];
    *side = (left != rev) ? 1 : -1;
  }
}

/* ---- the singular terms of h_step (ch_featmap.singular) ---- */

void ch_featmap_singular_gradient(const ch_featmap *m, const size_t corner[4], const double uv[2], double g[2]) {
  g[0] = g[1] = 0.0;
  if (!m->sg_near) return;
  int best = -1;
  double bd = INFINITY;
  for (int q = 0; q < 4; q++) {
    int k = m->sg_near[corner[q]];
    if (k < 0) continue;
    double d = hypot(uv[0] - m->singular[k].p[0], uv[1] - m->singular[k].p[1]);
    if (d < bd) bd = d, best = k;
  }
  if (best < 0) return;
  double w = ch_featmap_singular_window(&m->singular[best], bd), tg[2];
  ch_stepsing_term(&m->singular[best], uv, tg);
  g[0] = w * tg[0], g[1] = w * tg[1];
}

/* The base normal with the singular term added back to its gradient. */
static void add_singular(const ch_featmap *m, const size_t corner[4], const double uv[2], double B[3]) {
  if (!m->sg_near) return;
  double gs[2];
  ch_featmap_singular_gradient(m, corner, uv, gs);
  if (gs[0] == 0.0 && gs[1] == 0.0) return;
  double bz = B[2] > 1e-12 ? B[2] : 1e-12, g[2] = {-B[0] / bz + gs[0], -B[1] / bz + gs[1]};
  double len = sqrt(g[0] * g[0] + g[1] * g[1] + 1.0);
  B[0] = -g[0] / len, B[1] = -g[1] / len, B[2] = 1.0 / len;
}

/* Inside a region one step curve alone bounds, h_step is one value (a
 * slab thinner than a cell has no sample of its own to say so). */
static void flat_region(const ch_featmap *m, ch_featmap_sample *out) {
  if (out->curve < 0 || out->curve >= m->num_curves) return;
  int flat = m->curves[out->curve].flat_side;
  if (flat && flat == out->side) out->base[0] = out->base[1] = 0.0, out->base[2] = 1.0;
}

/* ---- fallback: exact pieces ---- */

static int piece_side(const ch_featmap_piece *pc, double t, const double q[2], const double P[2]) {
  double d[2] = {q[0] - P[0], q[1] - P[1]}, tg[2];
  if (t > 0.0 && t < 1.0) {
    ch_bezier_tangent(pc->p, t, tg);
    return ch_cross2(tg, d) >= 0.0 ? 1 : -1;
  }
  int start = t <= 0.0;
  ch_bezier_tangent(pc->p, start ? 0.0 : 1.0, tg);
  if (start ? pc->start_open : pc->end_open) return ch_cross2(tg, d) >= 0.0 ? 1 : -1;
  return start ? ch_joint_side(pc->tin, tg, d) : ch_joint_side(tg, pc->tout, d);
}

/* Whether the straight segment a-b crosses piece pc (the roots of the
 * quadratic along a-b's normal, inside both). */
static int piece_crosses(const ch_featmap_piece *pc, const double a[2], const double b[2]) {
  double d[2] = {b[0] - a[0], b[1] - a[1]}, n[2] = {-d[1], d[0]}, dd = d[0] * d[0] + d[1] * d[1];
  if (!(dd > 0.0)) return 0;
  const double(*p)[2] = pc->p;
  /* n . (B(t) - a), a quadratic in t */
  double f0 = n[0] * (p[0][0] - a[0]) + n[1] * (p[0][1] - a[1]), f1 = n[0] * (p[1][0] - a[0]) + n[1] * (p[1][1] - a[1]),
         f2 = n[0] * (p[2][0] - a[0]) + n[1] * (p[2][1] - a[1]);
  double roots[2];
  int nr = ch_quadratic_roots(f0 - 2.0 * f1 + f2, 2.0 * (f1 - f0), f0, roots);
  for (int k = 0; k < nr; k++) {
    double t = roots[k], x[2];
    if (!(t >= 0.0 && t <= 1.0)) continue;
    ch_bezier_eval(p, t, x);
    double sa = ((x[0] - a[0]) * d[0] + (x[1] - a[1]) * d[1]) / dd;
    if (sa >= 0.0 && sa <= 1.0) return 1;
  }
  return 0;
}

/* The exact pieces of a fallback cell: per curve its nearest piece, the
 * nearest curve overall (distance, gradient, side), and docs/spec.md §3's CSG over
 * the grooves' carve values, whose winner gives the normal. */
static void eval_fallback(const ch_featmap *m, const cell_ctx *c, const double uv[2], const double p[2],
                          ch_featmap_sample *out) {
  size_t cell = c->corner[0];
  int start = m->fb_start[cell], n = m->fb_count[cell];
  if (n > CH_FEATMAP_MAX_PIECES) n = CH_FEATMAP_MAX_PIECES;
  /* per curve: nearest piece */
  int cur[CH_FEATMAP_MAX_PIECES], pidx[CH_FEATMAP_MAX_PIECES], nc = 0;
  double cd2[CH_FEATMAP_MAX_PIECES], ct[CH_FEATMAP_MAX_PIECES];
  for (int k = 0; k < n; k++) {
    int pi = m->fb_list[start + k];
    const ch_featmap_piece *pc = &m->pieces[pi];
    double t, d2 = ch_bezier_closest(pc->p, pc->is_line, uv, &t);
    int j = 0;
    while (j < nc && cur[j] != pc->curve) j++;
    if (j == nc) cur[nc] = pc->curve, cd2[nc] = INFINITY, nc++;
    if (d2 < cd2[j]) cd2[j] = d2, ct[j] = t, pidx[j] = pi;
  }
  int best = -1, carve = -1, raise = -1;
  double gmin = 0.0, gmax = 0.0, sd[CH_FEATMAP_MAX_PIECES], grad[CH_FEATMAP_MAX_PIECES][2];
  for (int j = 0; j < nc; j++) {
    const ch_featmap_piece *pc = &m->pieces[pidx[j]];
    double P[2];
    ch_bezier_eval(pc->p, ct[j], P);
    double d = sqrt(cd2[j]);
    int side = piece_side(pc, ct[j], uv, P);
    sd[j] = side * d;
    if (d > 1e-12) {
      grad[j][0] = (uv[0] - P[0]) / d, grad[j][1] = (uv[1] - P[1]) / d;
    } else {
      double tg[2];
      ch_bezier_tangent(pc->p, ct[j], tg);
      grad[j][0] = -tg[1] * side, grad[j][1] = tg[0] * side;
    }
    if (best < 0 || cd2[j] < cd2[best]) best = j;
    const ch_featmap_curve *cv = cur[j] >= 0 && cur[j] < m->num_curves ? &m->curves[cur[j]] : NULL;
    if (!cv || cv->kind != CH_CURVE_GROOVE || !(d < 0.5 * cv->width)) continue;
    double g = cv->depth * ch_profile_eval(&cv->profile, sd[j] / cv->width);
    if (g < gmin) gmin = g, carve = j;
    if (g > gmax) gmax = g, raise = j;
  }
  if (best < 0) { /* an empty list: the corners */
    out->distance = c->cv[0].v[0];
    out->curve = c->ccurve[0];
    out->side = c->cside[0];
    out->gradient[0] = c->cv[0].v[1], out->gradient[1] = c->cv[0].v[2];
  } else {
    out->distance = fabs(sd[best]);
    out->curve = cur[best];
    out->side = sd[best] >= 0.0 ? 1 : -1;
    out->gradient[0] = grad[best][0], out->gradient[1] = grad[best][1];
  }
  /* Base normal: the corners no step curve separates from the point
   * (h_step's one-sided gradients differ across each: two sides of a
   * ring a quarter cell thick are one curve's same side, and where two
   * cross the nearest alone does not tell); else those on the same side
   * of the same curve; else all. */
  double wreg = 0.0, R3[3] = {0, 0, 0}, wsum = 0.0, B[3] = {0, 0, 0}, wall = 0.0, Ball[3] = {0, 0, 0};
  for (int q = 0; q < 4; q++) {
    double wx = fm_corner_xy[q][0] ? p[0] : 1.0 - p[0], wy = fm_corner_xy[q][1] ? p[1] : 1.0 - p[1];
    double w = ch_clamp(wx, 0.0, 1.0) * ch_clamp(wy, 0.0, 1.0) + 1e-9;
    for (int k = 0; k < 3; k++) Ball[k] += w * c->cv[q].v[3 + k];
    wall += w;
    int apart = 0;
    for (int e = 0; e < n && !apart; e++) {
      const ch_featmap_piece *pc = &m->pieces[m->fb_list[start + e]];
      if (pc->curve >= 0 && pc->curve < m->num_curves && m->curves[pc->curve].kind == CH_CURVE_STEP)
        apart = piece_crosses(pc, uv, c->cuv[q]);
    }
    if (!apart) {
      for (int k = 0; k < 3; k++) R3[k] += w * c->cv[q].v[3 + k];
      wreg += w;
    }
    if (c->ccurve[q] != out->curve || c->cside[q] != out->side) continue;
    for (int k = 0; k < 3; k++) B[k] += w * c->cv[q].v[3 + k];
    wsum += w;
  }
  for (int k = 0; k < 3; k++) out->base[k] = wreg > 0.0 ? R3[k] / wreg : wsum > 0.0 ? B[k] / wsum : Ball[k] / wall;
  add_singular(m, c->corner, uv, out->base);
  flat_region(m, out);
  /* the normal: the groove that decides h (carving first), else the base */
  int win = carve >= 0 ? carve : raise;
  if (win >= 0) {
    const ch_featmap_curve *cv = &m->curves[cur[win]];
    double half = 0.5 * cv->width, d = fabs(sd[win]);
    ch_featmap_profile_normal(cv, sd[win] >= 0.0 ? 1 : -1, d, grad[win], out->base, half, half, out->normal);
  } else {
    ch_featmap_profile_normal(NULL, 1, 0.0, out->gradient, out->base, 0.0, 0.0, out->normal);
  }
  out->kind = 2;
}

/* ---- the entry point ---- */

static void finish(const ch_featmap *m, ch_featmap_sample *out) {
  double gl = hypot(out->gradient[0], out->gradient[1]);
  if (gl > 1e-12) out->gradient[0] /= gl, out->gradient[1] /= gl;
  else out->gradient[0] = 1.0, out->gradient[1] = 0.0;
  const ch_featmap_curve *c = out->curve >= 0 && out->curve < m->num_curves ? &m->curves[out->curve] : NULL;
  double half = c ? 0.5 * c->width : 0.0;
  ch_featmap_profile_normal(c, out->side, out->distance, out->gradient, out->base, half, half, out->normal);
}

void ch_featmap_eval(const ch_featmap *m, ch_featmap_method method, double u, double v, ch_featmap_sample *out) {
  int R = m->resolution;
  cell_ctx c;
  c.m = m;
  c.du = (m->rect[2] - m->rect[0]) / R;
  c.dv = (m->rect[3] - m->rect[1]) / R;
  double uv[2] = {u, v}, wuv[2] = {u, v};
  if (m->warp) ch_warp_map(m->warp, uv, wuv);
  double x = (wuv[0] - m->rect[0]) / c.du - CH_FEATMAP_OFFSET_X, y = (wuv[1] - m->rect[1]) / c.dv - CH_FEATMAP_OFFSET_Y;
  if (!(x > -1e9 && x < 1e9)) x = 0.0; /* NaN or far away */
  if (!(y > -1e9 && y < 1e9)) y = 0.0;
  int cj = (int)floor(x), ci = (int)floor(y);
  cj = cj < 0 ? 0 : cj >= R ? R - 1 : cj;
  ci = ci < 0 ? 0 : ci >= R ? R - 1 : ci;
  double p[2] = {x - cj, y - ci};
  load_corners(&c, ci, cj);
  c.puv[0] = u, c.puv[1] = v;
  for (int q = 0; q < 4; q++) {
    double cw[2] = {m->rect[0] + (cj + fm_corner_xy[q][0] + CH_FEATMAP_OFFSET_X) * c.du,
                    m->rect[1] + (ci + fm_corner_xy[q][1] + CH_FEATMAP_OFFSET_Y) * c.dv};
    if (m->warp) ch_warp_unmap(m->warp, cw, c.cuv[q]);
    else c.cuv[q][0] = cw[0], c.cuv[q][1] = cw[1];
  }
  if (m->warp) { /* the segments' distances, to first order */
    c.du = hypot(c.cuv[1][0] - c.cuv[0][0], c.cuv[1][1] - c.cuv[0][1]);
    c.dv = hypot(c.cuv[3][0] - c.cuv[0][0], c.cuv[3][1] - c.cuv[0][1]);
  }
  memset(out, 0, sizeof *out);
  if (method == CH_FEATMAP_BILINEAR) {
    /* Plain bilinear interpolation of the samples: what a texture unit
     * does with a signed distance field and a normal map. */
    double w[4] = {(1 - p[0]) * (1 - p[1]), p[0] * (1 - p[1]), p[0] * p[1], (1 - p[0]) * p[1]};
    double sd = 0.0, g[2] = {0, 0}, B[3] = {0, 0, 0}, N[3] = {0, 0, 0}, wmax = -1.0;
    for (int q = 0; q < 4; q++) {
      size_t s = c.corner[q];
      sd += w[q] * m->dist[s];
      g[0] += w[q] * c.cv[q].v[1];
      g[1] += w[q] * c.cv[q].v[2];
      for (int k = 0; k < 3; k++) B[k] += w[q] * c.cv[q].v[3 + k];
      if (m->normal)
        for (int k = 0; k < 3; k++) N[k] += w[q] * m->normal[3 * s + k];
      if (w[q] > wmax) wmax = w[q], out->curve = c.ccurve[q];
    }
    out->distance = fabs(sd);
    out->side = sd >= 0.0 ? 1 : -1;
    out->gradient[0] = g[0], out->gradient[1] = g[1];
    memcpy(out->base, B, sizeof B);
    add_singular(m, c.corner, uv, out->base);
    finish(m, out);
    double nl = sqrt(N[0] * N[0] + N[1] * N[1] + N[2] * N[2]);
    if (m->normal && nl > 0.0)
      for (int k = 0; k < 3; k++) out->normal[k] = N[k] / nl;
    return;
  }
  size_t cell = c.corner[0];
  uint32_t w = m->config[cell];
  if ((w & CH_FM_FALLBACK) && m->has_fallback && m->fb_count[cell] > 0) {
    eval_fallback(m, &c, uv, p, out);
    return;
  }
  fm_cell_signature(m, ci, cj, &c.sig);
  int any = c.sig.nseg > 0 || c.sig.point[0] || c.sig.point[1] || c.sig.point[2] || c.sig.point[3];
  vals r;
  if (!any || !fm_segment_curves(&c.sig, method == CH_FEATMAP_LINEAR || m->linear, c.seg)) {
    double wq[4] = {(1 - p[0]) * (1 - p[1]), p[0] * (1 - p[1]), p[0] * p[1], (1 - p[0]) * p[1]};
    for (int k = 0; k < NV; k++) r.v[k] = 0.0;
    for (int q = 0; q < 4; q++)
      for (int k = 0; k < NV; k++) r.v[k] += wq[q] * c.cv[q].v[k];
    c.sig.nseg = 0;
    for (int q = 0; q < 4; q++) c.reach[q] = 1;
    out->kind = 0;
  } else {
    fm_partition_make(&c.sig, c.seg, &c.P);
    r = interpolate(&c, p);
    out->kind = 1;
  }
  out->distance = r.v[0] > 0.0 ? r.v[0] : 0.0;
  out->gradient[0] = r.v[1];
  out->gradient[1] = r.v[2];
  out->base[0] = r.v[3], out->base[1] = r.v[4], out->base[2] = r.v[5];
  add_singular(m, c.corner, uv, out->base);
  label(&c, p, r.v[6], &out->curve, &out->side);
  flat_region(m, out);
  finish(m, out);
}
