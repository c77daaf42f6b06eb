#!/usr/bin/env python3
"""Pathological curve sets for chisel (bench/pathological.sh, the tests).

usage: pathological.py KIND N OUT.svg
  crossing N  N v grooves (width 0.2, depth 0.01, viewBox 100) through the
              centre of the square, at angles k 180/N, border to border
  loops N     N small closed step curves (circles of radius 0.3 to 0.8,
              inside raised 0.01), centres from a fixed generator, so they
              overlap and cross each other
  path N      one groove (v, width 0.3) along an Archimedean spiral of 40
              turns from radius 2 to 45, as N line segments
  bigpath N   like path, but a u groove drawn with N segments in a single
              d attribute written with 6 decimals (a large file: a million
              segments is about 18 MB)
Deterministic: the same arguments give the same bytes.
"""
import math
import sys


def header(out, title):
    out.write('<?xml version="1.0" encoding="UTF-8"?>\n')
    out.write('<svg xmlns="http://www.w3.org/2000/svg" version="1.1" viewBox="0 0 100 100">\n')
    out.write("  <title>%s</title>\n" % title)


def crossing(n, out):
    header(out, "%d v grooves through the centre" % n)
    out.write('  <g data-kind="groove" data-profile="v" data-width="0.2" data-depth="0.01">\n')
    for k in range(n):
        a = math.pi * k / n
        # from border to border through (50, 50): the longer of the two
        # half-lengths that stay inside the square
        c, s = math.cos(a), math.sin(a)
        r = min(50.0 / abs(c) if abs(c) > 1e-12 else 1e9, 50.0 / abs(s) if abs(s) > 1e-12 else 1e9)
        out.write('    <path d="M %.6f %.6f L %.6f %.6f"/>\n' % (50 - r * c, 50 - r * s, 50 + r * c, 50 + r * s))
    out.write("  </g>\n</svg>\n")


def lcg(seed):
    state = seed
    while True:
        state = (state * 6364136223846793005 + 1442695040888963407) % (1 << 64)
        yield (state >> 11) / float(1 << 53)


def loops(n, out):
    header(out, "%d small closed step curves" % n)
    out.write('  <g data-kind="step" data-left="0" data-right="0.01">\n')
    rnd = lcg(19)
    for _ in range(n):
        cx, cy = 1 + 98 * next(rnd), 1 + 98 * next(rnd)
        r = 0.3 + 0.5 * next(rnd)
        out.write('    <circle cx="%.4f" cy="%.4f" r="%.4f"/>\n' % (cx, cy, r))
    out.write("  </g>\n</svg>\n")


def spiral(n, out, profile, width):
    header(out, "one groove of %d segments" % n)
    out.write('  <path data-kind="groove" data-profile="%s" data-width="%s" data-depth="0.01" d="' % (profile, width))
    turns, r0, r1 = 40.0, 2.0, 45.0
    for i in range(n + 1):
        f = i / n
        a, r = 2 * math.pi * turns * f, r0 + (r1 - r0) * f
        out.write("%s%.6f %.6f" % ("M " if i == 0 else " L " if i == 1 else " ", 50 + r * math.cos(a), 50 + r * math.sin(a)))
    out.write('"/>\n</svg>\n')


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    kind, n, path = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    with open(path, "w") as out:
        if kind == "crossing":
            crossing(n, out)
        elif kind == "loops":
            loops(n, out)
        elif kind == "path":
            spiral(n, out, "v", "0.3")
        elif kind == "bigpath":
            spiral(n, out, "u", "0.3")
        else:
            sys.exit(__doc__)


if __name__ == "__main__":
    main()
