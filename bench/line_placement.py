#!/usr/bin/env python3
"""Where a u groove's lines could go for its facet normals: the cross-section
of one straight u groove (P = -sqrt(1 - 4t^2), width w and depth D in UV
and height units over the plane), its lines as the cut places them (slope
angles (k - 1/2) delta, tess/ch_label.c's groove_lines without its chord
rule and spacing), each slice between two lines one flat facet, measured
as bench/accuracy.c measures a mesh: the p95 of the facet normal's error
over samples 1e-3..1e-2 in UV from the rim, the flat samples outside
counting 0. Against that, the same number of lines placed to lower the
p95 (a step delta1 up to a slope theta*, a coarser one beyond), and what
each costs in L1 (the mean |facet - P| across the groove, in units of D).

It answers whether moving lines, rather than adding them, can bring the
p95 under 2 degrees at 130k triangles (delta = 7.06): it cannot without
giving up L1 (see docs/measurements.md).

Usage: bench/line_placement.py [WIDTH DEPTH DELTA_DEG]
       (default: 0.016 0.01 7.06, spiral's narrower groove at 130k)
"""
import math
import sys


def fail(message):
    """One line on stderr, exit status 2 (bad input)."""
    sys.stderr.write("line_placement: %s\n" % message)
    sys.exit(2)


def height(s, a, depth):
    x = min(1.0, abs(s) / a)
    return -depth * math.sqrt(1.0 - x * x)


def slope_angle(s, a, depth):
    x = abs(s) / a
    return math.atan(depth * x / (a * math.sqrt(1.0 - x * x)))


def lines_at(angles, a, depth):
    """Offsets s in (0, a) where the profile's slope angle is each of angles."""
    out = []
    for th in angles:
        q = math.tan(th) * a / depth  # x / sqrt(1 - x^2)
        out.append(a * q / math.sqrt(1.0 + q * q))
    return sorted(out)


def slices(lines, a):
    """Both halves' lines and the rims, ascending."""
    return sorted(set([-a, a] + [-s for s in lines] + list(lines)))


def facet(s, cuts, a, depth):
    """The slice holding s: its chord's slope and height there."""
    lo, hi = 0, len(cuts) - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if cuts[mid] <= s:
            lo = mid
        else:
            hi = mid
    s1, s2 = cuts[lo], cuts[hi]
    h1, h2 = height(s1, a, depth), height(s2, a, depth)
    k = (h2 - h1) / (s2 - s1)
    return k, h1 + k * (s - s1)


def p95(lines, a, depth, n=6000):
    cuts = slices(lines, a)
    errors = [0.0] * n  # the flat band outside the rim
    for i in range(n):
        d = 1e-3 + 9e-3 * (i + 0.5) / n
        s = a - d
        if s <= -a:
            continue
        k, _ = facet(s, cuts, a, depth)
        true = math.copysign(math.tan(slope_angle(s, a, depth)), s)
        errors.append(math.degrees(abs(math.atan(k) - math.atan(true))))
    errors.sort()
    return errors[max(0, math.ceil(0.95 * len(errors)) - 1)]


def l1(lines, a, depth, n=20000):
    cuts = slices(lines, a)
    total = 0.0
    for i in range(n):
        s = -a + 2.0 * a * (i + 0.5) / n
        _, h = facet(s, cuts, a, depth)
        total += abs(h - height(s, a, depth))
    return total / n / depth


def chisel_angles(delta):
    out, k = [], 1
    while (k - 0.5) * delta < 90.0:
        out.append(math.radians((k - 0.5) * delta))
        k += 1
    return out


def main():
    args = sys.argv[1:]
    if len(args) not in (0, 3):
        fail("usage: bench/line_placement.py [WIDTH DEPTH DELTA_DEG]")
    try:
        w, depth, delta = (float(v) for v in args) if args else (0.016, 0.01, 7.06)
    except ValueError:
        fail("WIDTH, DEPTH and DELTA_DEG must be numbers")
    if not (w > 0 and depth > 0 and 0.5 <= delta <= 45):
        fail("WIDTH and DEPTH must be positive, DELTA_DEG in [0.5, 45]")
    a = 0.5 * w
    base = chisel_angles(delta)
    n = len(base)
    print("u groove w %g, D %g: %d lines a side" % (w, depth, n))
    for d in (delta, 5.0, 4.0, 3.5):
        lines = lines_at(chisel_angles(d), a, depth)
        print("  the cut's placement, delta %.2f: %2d lines a side, p95 %.2f deg, L1 %.2e D"
              % (d, len(lines), p95(lines, a, depth), l1(lines, a, depth)))
    best = None
    for tstar in range(30, 90, 3):
        for n1 in range(max(1, n // 2), n):
            n2 = n - n1
            d1, d2 = tstar / n1, (90.0 - tstar) / (n2 + 0.5)
            angles = [math.radians((k + 0.5) * d1) for k in range(n1)]
            angles += [math.radians(tstar + (k + 0.5) * d2) for k in range(n2)]
            lines = lines_at([t for t in angles if t < 0.5 * math.pi], a, depth)
            p = p95(lines, a, depth, 2000)
            if best is None or p < best[0]:
                best = (p, tstar, n1, d1, n2, d2, lines)
    p, tstar, n1, d1, n2, d2, lines = best
    print("  moved, same %d lines: %d every %.2f deg up to %d, %d beyond: p95 %.2f deg, L1 %.2e D"
          % (n, n1, d1, tstar, n2, p95(lines, a, depth), l1(lines, a, depth)))


if __name__ == "__main__":
    main()
