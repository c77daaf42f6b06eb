#!/usr/bin/env python3
"""Checks `chisel magnify` crops of feature maps with an independent EXR
reader (exr_read.py) against a straight v groove in closed form: at every
pixel the signed distance to the line, and the normal of h = -depth (1 - 2
|s| / w) inside the band, up elsewhere (computed here, not by chisel).
featnorm and featnorm-linear must match to float precision away from the
profile's creases; normal-bilinear and msdf must give unit normals whose
sign of d is the side.
usage: check_featmap.py CHISEL TMP_DIR"""

import math
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from exr_read import read_exr  # noqa: E402

chisel, tmp = sys.argv[1], sys.argv[2]
os.makedirs(tmp, exist_ok=True)
# the line from (10, 23.3) to (90, 61.7) in viewBox units: UV y flipped
A, B = (0.10, 0.767), (0.90, 0.383)
W, DEPTH = 0.06, 0.02
svg = os.path.join(tmp, 'line.svg')
with open(svg, 'w') as f:
    f.write("<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 100 100'>"
            "<path d='M 10 23.3 L 90 61.7' data-kind='groove' data-profile='v' data-width='6' "
            "data-depth='0.02'/></svg>\n")
maps = os.path.join(tmp, 'line.exr')
subprocess.run([chisel, 'featmap', svg, '--res', '24', '-o', maps], check=True)
rect = (0.35, 0.50, 0.55, 0.70)
N = 40
tx, ty = B[0] - A[0], B[1] - A[1]
tl = math.hypot(tx, ty)
tx, ty = tx / tl, ty / tl
nx, ny = -ty, tx  # left normal
failures = 0
for method in ('featnorm', 'featnorm-linear', 'normal-bilinear', 'msdf'):
    crop = os.path.join(tmp, 'crop_%s.exr' % method)
    subprocess.run([chisel, 'magnify', maps, '--rect', ','.join(map(str, rect)), '--out-res', str(N), '-o', crop,
                    '--method', method], check=True)
    ch = read_exr(crop)
    worst_n = worst_d = 0.0
    for y in range(N):
        for x in range(N):
            u = rect[0] + (x + 0.5) * (rect[2] - rect[0]) / N
            v = rect[3] - (y + 0.5) * (rect[3] - rect[1]) / N
            s = (u - A[0]) * nx + (v - A[1]) * ny  # signed distance, + left
            n = [ch['N.X'][y][x], ch['N.Y'][y][x], ch['N.Z'][y][x]]
            d, side = ch['d'][y][x], ch['side'][y][x]
            if abs(math.sqrt(sum(c * c for c in n)) - 1.0) > 1e-5 or side not in (-1.0, 1.0) or \
                    (d != 0.0 and (d > 0) != (side > 0)):
                print('%s: pixel (%d, %d): not a unit normal, or side %g against d %g' % (method, x, y, side, d))
                failures += 1
            if method not in ('featnorm', 'featnorm-linear'):
                continue
            if abs(s) < W:  # exact samples near the curves (propagated beyond)
                worst_d = max(worst_d, abs(d - s))
            if abs(s) < 1e-5 or abs(abs(s) - W / 2) < 1e-5:
                continue  # on a crease of the profile
            e = [0.0, 0.0, 1.0]
            if abs(s) < W / 2:
                k = 2 * DEPTH / W * (1 if s > 0 else -1)
                l = math.sqrt(k * k + 1)
                e = [-k * nx / l, -k * ny / l, 1 / l]
            dot = max(-1.0, min(1.0, sum(a * b for a, b in zip(n, e))))
            worst_n = max(worst_n, math.degrees(math.acos(dot)))
    if method in ('featnorm', 'featnorm-linear') and (worst_d > 2e-6 or worst_n > 0.01):
        print('%s: distance off by %g UV, normal by %g degrees' % (method, worst_d, worst_n))
        failures += 1
    print('%s: max |d - s| %.3g UV, max normal error %.3g degrees' % (method, worst_d, worst_n))
sys.exit(1 if failures else 0)
