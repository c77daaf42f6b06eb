#!/usr/bin/env python3
"""What an ideal line-following mesh of a u groove can reach: the facet
normal error of structured strips (quads between cross-sections placed
every phi degrees of the path's turning, split by lines every delta
degrees of the profile's slope, both exact) measured as bench/accuracy.c
measures a mesh: the p95 over samples 1e-3..1e-2 in UV from a groove's
rim, flat samples outside counting 0, against the triangles the strips
take. No junctions, no caps (samples near a path's ends are left out),
no rims stitched to the rest of the mesh: a lower bound on what a real
mesh spends.

Reads the u grooves of an SVG whose paths use M, C, S and semicircle a
commands, with rotate() on their groups (models/curves/spiral.svg), over
the unit square of a 0 0 100 100 viewBox. Python 3 alone, no numpy.

Usage: bench/strip_bound.py [CURVES.svg] [SAMPLES]
       (default: models/curves/spiral.svg 150000)
"""
import bisect
import math
import random
import re
import sys
import xml.etree.ElementTree as ET


def fail(message):
    """One line on stderr, exit status 2 (bad input)."""
    sys.stderr.write("strip_bound: %s\n" % message)
    sys.exit(2)


def cubic(p0, p1, p2, p3, n=200):
    out = []
    for i in range(n):
        t = i / n
        a, b, c, d = (1 - t) ** 3, 3 * (1 - t) ** 2 * t, 3 * (1 - t) * t * t, t ** 3
        out.append((a * p0[0] + b * p1[0] + c * p2[0] + d * p3[0], a * p0[1] + b * p1[1] + c * p2[1] + d * p3[1]))
    return out


def path_points(d):
    """Dense points of a path of M, C, S (absolute) and a (relative
    semicircles: the end point diametrically opposite the start)."""
    tok = re.findall(r"[A-Za-z]|-?[0-9.]+(?:e-?[0-9]+)?", d)
    i, pts, cur, lastc = 0, [], None, None
    def num(k):
        if i + k >= len(tok) or tok[i + k].isalpha():
            fail("a path command without its numbers")
        return float(tok[i + k])

    cmd = None
    while i < len(tok):
        if tok[i].isalpha():
            cmd = tok[i]
            i += 1
            if cmd not in "MCSa":
                fail("path command %r: only M, C, S and semicircle a are read" % cmd)
        if cmd == "M":
            cur = (num(0), num(1))
            i += 2
        elif cmd == "C":
            p1, p2, p3 = (num(0), num(1)), (num(2), num(3)), (num(4), num(5))
            pts += cubic(cur, p1, p2, p3)
            lastc, cur = p2, p3
            i += 6
        elif cmd == "S":
            p1, p2, p3 = (2 * cur[0] - lastc[0], 2 * cur[1] - lastc[1]), (num(0), num(1)), (num(2), num(3))
            pts += cubic(cur, p1, p2, p3)
            lastc, cur = p2, p3
            i += 4
        elif cmd == "a":
            r, sweep, dx, dy = num(0), num(4), num(5), num(6)
            if not r > 0:
                fail("an arc of radius %g" % r)
            if abs(math.hypot(dx, dy) - 2 * r) > 1e-9 * r:
                fail("only semicircle arcs are read")
            cx, cy = cur[0] + dx / 2, cur[1] + dy / 2
            a0 = math.atan2(cur[1] - cy, cur[0] - cx)
            sign = 1 if sweep else -1  # SVG's y runs down: sweep 1 is increasing angle
            for k in range(400):
                a = a0 + sign * math.pi * k / 400
                pts.append((cx + r * math.cos(a), cy + r * math.sin(a)))
            cur = (cur[0] + dx, cur[1] + dy)
            i += 7
        else:
            fail("path data before any command")
    pts.append(cur)
    return pts


def u_grooves(svg):
    """(points in UV, width, depth) of every u groove, inherited attributes and rotations applied."""
    ns = "{http://www.w3.org/2000/svg}"
    out = []

    def walk(el, attrs, rot):
        a = dict(attrs)
        for k, v in el.attrib.items():
            if k.startswith("data-"):
                a[k] = v
        m = re.match(r"rotate\(([-0-9.]+) ([-0-9.]+) ([-0-9.]+)\)", el.attrib.get("transform", ""))
        if m:
            rot = rot + [tuple(map(float, m.groups()))]
        if el.tag == ns + "path" and a.get("data-profile") == "u" and a.get("data-kind", "groove") == "groove":
            pts = path_points(el.attrib["d"])
            for ang, ox, oy in reversed(rot):
                c, s = math.cos(math.radians(ang)), math.sin(math.radians(ang))
                pts = [(ox + c * (x - ox) - s * (y - oy), oy + s * (x - ox) + c * (y - oy)) for x, y in pts]
            uv = []
            for x, y in pts:
                q = (x / 100.0, y / 100.0)
                if not uv or math.hypot(q[0] - uv[-1][0], q[1] - uv[-1][1]) > 1e-9:
                    uv.append(q)
            out.append((uv, float(a["data-width"]) / 100.0, float(a["data-depth"])))
        for ch in el:
            walk(ch, a, rot)

    try:
        root = ET.parse(svg).getroot()
    except (OSError, ET.ParseError) as e:
        fail("%s: %s" % (svg, e))
    walk(root, {}, [])
    return out


def main():
    svg = sys.argv[1] if len(sys.argv) > 1 else "models/curves/spiral.svg"
    try:
        nsamples = int(sys.argv[2]) if len(sys.argv) > 2 else 150000
    except ValueError:
        fail("SAMPLES %r is not a whole number" % sys.argv[2])
    if nsamples < 1:
        fail("SAMPLES must be at least 1")
    random.seed(1)
    grooves = []
    for pts, w, depth in u_grooves(svg):
        n = len(pts)
        tang = []
        for i in range(n):
            a, b = pts[max(0, i - 1)], pts[min(n - 1, i + 1)]
            l = math.hypot(b[0] - a[0], b[1] - a[1])
            tang.append(((b[0] - a[0]) / l, (b[1] - a[1]) / l))
        turn = [0.0]
        for i in range(1, n):
            t0, t1 = tang[i - 1], tang[i]
            turn.append(turn[-1] + abs(math.atan2(t0[0] * t1[1] - t0[1] * t1[0], t0[0] * t1[0] + t0[1] * t1[1])))
        grooves.append(dict(p=pts, t=tang, turn=turn, w=w, D=depth))
        length = sum(math.hypot(pts[i][0] - pts[i - 1][0], pts[i][1] - pts[i - 1][1]) for i in range(1, n))
        print("u groove: length %.3f, turning %.0f deg, width %.3f, depth %.3f" % (length, math.degrees(turn[-1]), w, depth))
    if not grooves:
        fail("no u groove in %s" % svg)

    cells = 128
    grid = {}
    for gi, g in enumerate(grooves):
        for i, (x, y) in enumerate(g["p"]):
            grid.setdefault((int(x * cells), int(y * cells)), []).append((gi, i))

    def foot(q):
        """The nearest groove's (index, parameter, signed distance, left normal) at q."""
        bx, by = int(q[0] * cells), int(q[1] * cells)
        best, ref = 1e9, None
        for dx in (-2, -1, 0, 1, 2):
            for dy in (-2, -1, 0, 1, 2):
                for gi, i in grid.get((bx + dx, by + dy), ()):
                    p = grooves[gi]["p"][i]
                    d = (p[0] - q[0]) ** 2 + (p[1] - q[1]) ** 2
                    if d < best:
                        best, ref = d, (gi, i)
        if ref is None:
            return None
        gi, i = ref
        p, out = grooves[gi]["p"], None
        for j in (i - 1, i):
            if j < 0 or j + 1 >= len(p):
                continue
            a, b = p[j], p[j + 1]
            dx, dy = b[0] - a[0], b[1] - a[1]
            l2 = dx * dx + dy * dy
            u = max(0.0, min(1.0, ((q[0] - a[0]) * dx + (q[1] - a[1]) * dy) / l2))
            f = (a[0] + u * dx, a[1] + u * dy)
            d = math.hypot(q[0] - f[0], q[1] - f[1])
            if out is None or d < out[0]:
                l = math.sqrt(l2)
                nrm = (-dy / l, dx / l)
                side = 1 if (q[0] - f[0]) * nrm[0] + (q[1] - f[1]) * nrm[1] >= 0 else -1
                out = (d, gi, j + u, side * d, nrm)
        return out[1:]

    samples = []
    while len(samples) < nsamples:
        q = (random.random(), random.random())
        f = foot(q)
        if f is None:
            continue
        gi, par, s, nrm = f
        rim = abs(abs(s) - grooves[gi]["w"] / 2)
        if 1e-3 <= rim <= 1e-2 and 2 <= par <= len(grooves[gi]["p"]) - 3:
            samples.append((q, gi, par, s, nrm))

    def h(t, depth):
        return -depth * math.sqrt(max(0.0, 1 - 4 * t * t))

    def measure(delta, phi):
        tris = 0
        for g in grooves:
            idx = [0]
            for i in range(1, len(g["p"])):
                if g["turn"][i] - g["turn"][idx[-1]] >= phi:
                    idx.append(i)
            if idx[-1] != len(g["p"]) - 1:
                idx.append(len(g["p"]) - 1)
            ks, k = [], 1
            while k * delta < math.pi / 2 - 1e-9:  # t where the slope angle is k delta
                q = math.tan(k * delta) * g["w"] / g["D"] / 4
                ks.append(q / math.sqrt(1 + 4 * q * q))
                k += 1
            g["idx"], g["ts"] = idx, [-0.5] + [-x for x in reversed(ks)] + [0.0] + ks + [0.5]
            tris += 2 * (len(idx) - 1) * (len(g["ts"]) - 1)
        errs = []
        for q, gi, par, s, nrm in samples:
            g = grooves[gi]
            w, depth, t = g["w"], g["D"], s / g["w"]
            if abs(t) >= 0.5:
                errs.append(0.0)  # flat outside: exact facets
                continue
            j = min(bisect.bisect_right(g["idx"], par) - 1, len(g["idx"]) - 2)
            k = min(bisect.bisect_right(g["ts"], t) - 1, len(g["ts"]) - 2)

            def corner(jj, tt):
                i = g["idx"][jj]
                p, tg = g["p"][i], g["t"][i]
                return (p[0] - tt * w * tg[1], p[1] + tt * w * tg[0], h(tt, depth))

            a, b = corner(j, g["ts"][k]), corner(j + 1, g["ts"][k])
            c, d = corner(j + 1, g["ts"][k + 1]), corner(j, g["ts"][k + 1])
            side_q = (c[0] - a[0]) * (q[1] - a[1]) - (c[1] - a[1]) * (q[0] - a[0])
            side_b = (c[0] - a[0]) * (b[1] - a[1]) - (c[1] - a[1]) * (b[0] - a[0])
            tri = (a, b, c) if side_q * side_b > 0 else (a, c, d)
            u = [tri[1][m] - tri[0][m] for m in range(3)]
            v = [tri[2][m] - tri[0][m] for m in range(3)]
            fn = (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
            if fn[2] < 0:
                fn = tuple(-x for x in fn)
            slope = depth * 4 * t / math.sqrt(1 - 4 * t * t) / w  # dh/ds; grad s = the left normal
            ex = (-slope * nrm[0], -slope * nrm[1], 1.0)
            cosang = sum(fn[m] * ex[m] for m in range(3)) / math.sqrt(sum(x * x for x in fn)) / math.sqrt(sum(x * x for x in ex))
            errs.append(math.degrees(math.acos(max(-1.0, min(1.0, cosang)))))
        errs.sort()
        return tris, errs[int(math.ceil(0.95 * len(errs))) - 1]

    print("%d samples (%d inside the grooves)" % (len(samples), sum(1 for x in samples if abs(x[3]) < grooves[x[1]]["w"] / 2)))
    print("| slope step | turning step | strip triangles | normal p95 |")
    print("|---|---|---|---|")
    for delta, phi in [(7.06, 0.5), (7.06, 7.06), (5.0, 5.0), (4.4, 4.4), (4.0, 4.0), (3.8, 3.8), (4.0, 3.0), (3.5, 3.5)]:
        tris, p95 = measure(math.radians(delta), math.radians(phi))
        print("| %.2f deg | %.2f deg | %d | %.2f deg |" % (delta, phi, tris, p95))


if __name__ == "__main__":
    main()
