#!/usr/bin/env python3
"""Rewrites the `h` channel of a chisel EXR (chisel sample) as the single
channel `Y` of an uncompressed float EXR: the luminance channel Blender's
image loader reads as a grey height map (it ignores a channel named h).
Blender's textures clamp to [0, 1], so the map holds (h - lo) / (hi - lo)
and the Displace modifier gets strength hi - lo and midlevel -lo / (hi - lo),
which this prints as `STRENGTH MIDLEVEL`, as a user would set them.

usage: height_to_y.py IN.exr OUT.exr
"""
import os
import struct
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tests", "tools"))
from exr_read import read_exr  # noqa: E402  (the repo's independent reader)


def attribute(name, type_name, payload):
    return name.encode() + b"\0" + type_name.encode() + b"\0" + struct.pack("<i", len(payload)) + payload


def write_y(path, rows):
    height, width = len(rows), len(rows[0])
    chlist = b"Y\0" + struct.pack("<iB3xii", 2, 0, 1, 1) + b"\0"  # FLOAT, linear, no subsampling
    box = struct.pack("<iiii", 0, 0, width - 1, height - 1)
    header = (struct.pack("<ii", 20000630, 2) +
              attribute("channels", "chlist", chlist) +
              attribute("compression", "compression", b"\0") +
              attribute("dataWindow", "box2i", box) +
              attribute("displayWindow", "box2i", box) +
              attribute("lineOrder", "lineOrder", b"\0") +
              attribute("pixelAspectRatio", "float", struct.pack("<f", 1.0)) +
              attribute("screenWindowCenter", "v2f", struct.pack("<ff", 0.0, 0.0)) +
              attribute("screenWindowWidth", "float", struct.pack("<f", 1.0)) + b"\0")
    line = 4 * width
    first = len(header) + 8 * height
    offsets = b"".join(struct.pack("<Q", first + y * (8 + line)) for y in range(height))
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(header + offsets)
        for y, row in enumerate(rows):
            f.write(struct.pack("<ii", y, line) + struct.pack("<%df" % width, *row))
    os.replace(tmp, path)


def main(argv):
    if len(argv) != 3:
        sys.stderr.write(__doc__)
        return 2
    channels = read_exr(argv[1])
    if "h" not in channels:
        sys.stderr.write("height_to_y.py: %s: no channel h\n" % argv[1])
        return 2
    rows = channels["h"]
    lo = min(min(r) for r in rows)
    hi = max(max(r) for r in rows)
    lo, hi = min(lo, 0.0), max(hi, 0.0)
    span = hi - lo if hi > lo else 1.0
    write_y(argv[2], [[(v - lo) / span for v in r] for r in rows])
    print("%.9g %.9g" % (span, -lo / span))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
