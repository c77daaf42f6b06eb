#!/usr/bin/env python3
"""A minimal, independent OpenEXR reader (stdlib only: struct, zlib).

It shares no code with OpenEXR: it exists so tests can check the EXR files
chisel writes against a second implementation of the format, written from
the "OpenEXR File Layout" document (openexr.com, "Technical Information").

Supported: single-part scanline files, compression NONE, ZIPS (1 scanline
per chunk) and ZIP (16 scanlines per chunk), FLOAT, HALF and UINT channels,
any data window, increasing or decreasing line order. Anything else
(tiled, deep, multi-part, other compressions, subsampled channels) raises
ExrError.

Library use:
    from exr_read import read_exr, read_header
    channels = read_exr("out.exr")      # {name: [row0, row1, ...]}, row 0 on top
    header = read_header("out.exr")     # {attribute name: (type name, value)}

Command line:
    exr_read.py FILE                     summary of the channels
    exr_read.py --check EXPECTED         compare files with the values listed
                                         in EXPECTED (written by
                                         `test_image --write-exr-samples DIR`)
"""

import os
import struct
import sys
import zlib

MAGIC = 20000630
PIXEL_UINT, PIXEL_HALF, PIXEL_FLOAT = 0, 1, 2
COMPRESSION_NAMES = ["NONE", "RLE", "ZIPS", "ZIP", "PIZ", "PXR24", "B44", "B44A",
                     "DWAA", "DWAB"]
LINES_PER_CHUNK = {"NONE": 1, "ZIPS": 1, "ZIP": 16}


class ExrError(Exception):
    pass


class _Cursor:
    def __init__(self, data, pos=0):
        self.data = data
        self.pos = pos

    def take(self, n):
        if n < 0 or self.pos + n > len(self.data):
            raise ExrError("unexpected end of file at byte %d" % self.pos)
        chunk = self.data[self.pos:self.pos + n]
        self.pos += n
        return chunk

    def unpack(self, fmt):
        return struct.unpack("<" + fmt, self.take(struct.calcsize("<" + fmt)))

    def cstring(self, limit=256):
        end = self.data.find(b"\0", self.pos, self.pos + limit + 1)
        if end < 0:
            raise ExrError("unterminated name at byte %d" % self.pos)
        s = self.data[self.pos:end].decode("latin-1")
        self.pos = end + 1
        return s


def _parse_chlist(raw):
    cur = _Cursor(raw)
    channels = []
    while True:
        name = cur.cstring()
        if name == "":
            break
        ptype, plinear, _r0, _r1, _r2, xs, ys = cur.unpack("iBBBBii")
        channels.append({"name": name, "type": ptype, "plinear": plinear,
                         "xsampling": xs, "ysampling": ys})
    return channels


def _parse_attribute(type_name, raw):
    if type_name == "chlist":
        return _parse_chlist(raw)
    if type_name == "compression" or type_name == "lineOrder":
        return raw[0]
    if type_name == "box2i":
        return struct.unpack("<iiii", raw)
    if type_name == "string":
        return raw.decode("utf-8", "replace")
    if type_name == "int":
        return struct.unpack("<i", raw)[0]
    if type_name == "float":
        return struct.unpack("<f", raw)[0]
    if type_name == "v2f":
        return struct.unpack("<ff", raw)
    return raw  # other types: raw bytes


def _parse_header(data):
    cur = _Cursor(data)
    magic, version = cur.unpack("II")
    if magic != MAGIC:
        raise ExrError("not an OpenEXR file")
    if version & 0xff != 2:
        raise ExrError("unsupported file version %d" % (version & 0xff))
    if version & 0x200:
        raise ExrError("tiled files are not supported")
    if version & 0x800:
        raise ExrError("deep files are not supported")
    if version & 0x1000:
        raise ExrError("multi-part files are not supported")
    name_limit = 255 if version & 0x400 else 31
    header = {}
    while True:
        name = cur.cstring(name_limit)
        if name == "":
            break
        type_name = cur.cstring(name_limit)
        (size,) = cur.unpack("i")
        header[name] = (type_name, _parse_attribute(type_name, cur.take(size)))
    return header, cur.pos


def read_header(path):
    """Returns {attribute name: (type name, parsed value)} of a scanline file."""
    with open(path, "rb") as f:
        return _parse_header(f.read())[0]


def _undo_zip(packed, expected_size):
    """ZIP / ZIPS decompression, the inverse of what the writer does:

    1. the writer splits the raw bytes into two halves, interleaving: bytes
       0, 2, 4, ... go to the first half and bytes 1, 3, 5, ... to the second
       (first half has (n + 1) // 2 bytes). This groups the low and high
       bytes of the little-endian 16/32-bit samples, which compress better;
    2. it then replaces each byte (but the first) by a delta predictor:
       t[i] = (raw[i] - raw[i-1] + 128) mod 256;
    3. and deflates the result with zlib (with the zlib header).

    So here: inflate, undo the predictor with a running sum
    (raw[i] = raw[i-1] + t[i] - 128 mod 256), then interleave the halves back.
    """
    try:
        t = bytearray(zlib.decompress(packed))
    except zlib.error as e:
        raise ExrError("bad zlib data: %s" % e)
    if len(t) != expected_size:
        raise ExrError("ZIP chunk inflates to %d bytes, expected %d"
                       % (len(t), expected_size))
    for i in range(1, len(t)):
        t[i] = (t[i - 1] + t[i] - 128) & 0xff
    half = (len(t) + 1) // 2
    out = bytearray(len(t))
    out[0::2] = t[:half]
    out[1::2] = t[half:]
    return bytes(out)


def _half_to_float(h):
    return struct.unpack("<e", struct.pack("<H", h))[0]


def read_exr(path):
    """Reads a scanline EXR file; returns {channel name: list of rows} where
    each row is a list of Python floats (HALF and UINT widened), row 0 being
    the top of the data window."""
    with open(path, "rb") as f:
        data = f.read()
    header, pos = _parse_header(data)
    for required in ("channels", "compression", "dataWindow", "lineOrder"):
        if required not in header:
            raise ExrError("missing required attribute '%s'" % required)
    channels = header["channels"][1]
    comp_id = header["compression"][1]
    comp = COMPRESSION_NAMES[comp_id] if comp_id < len(COMPRESSION_NAMES) else str(comp_id)
    if comp not in LINES_PER_CHUNK:
        raise ExrError("compression %s not supported by this reader" % comp)
    xmin, ymin, xmax, ymax = header["dataWindow"][1]
    width, height = xmax - xmin + 1, ymax - ymin + 1
    if width < 1 or height < 1:
        raise ExrError("empty data window")
    sizes = {PIXEL_UINT: 4, PIXEL_HALF: 2, PIXEL_FLOAT: 4}
    for ch in channels:
        if ch["xsampling"] != 1 or ch["ysampling"] != 1:
            raise ExrError("subsampled channel '%s'" % ch["name"])
        if ch["type"] not in sizes:
            raise ExrError("channel '%s' has unknown type %d" % (ch["name"], ch["type"]))
    lpc = LINES_PER_CHUNK[comp]
    nchunks = (height + lpc - 1) // lpc
    cur = _Cursor(data, pos)
    offsets = [cur.unpack("Q")[0] for _ in range(nchunks)]
    bytes_per_line = sum(width * sizes[ch["type"]] for ch in channels)

    result = {ch["name"]: [None] * height for ch in channels}
    for offset in offsets:
        chunk = _Cursor(data, offset)
        y, packed_size = chunk.unpack("ii")
        row0 = y - ymin
        if row0 < 0 or row0 >= height or (row0 % lpc) != 0:
            raise ExrError("chunk at byte %d has bad y %d" % (offset, y))
        lines = min(lpc, height - row0)
        raw_size = lines * bytes_per_line
        packed = chunk.take(packed_size)
        if packed_size == raw_size:
            raw = packed  # stored uncompressed (ZIP did not help, or NONE)
        elif comp == "NONE":
            raise ExrError("uncompressed chunk of %d bytes, expected %d"
                           % (packed_size, raw_size))
        else:
            raw = _undo_zip(packed, raw_size)
        # Layout inside a chunk: for each line, for each channel (in the
        # sorted order of the channel list), `width` little-endian samples.
        p = 0
        for line in range(lines):
            for ch in channels:
                t = ch["type"]
                n = width * sizes[t]
                seg = raw[p:p + n]
                p += n
                if t == PIXEL_FLOAT:
                    row = list(struct.unpack("<%df" % width, seg))
                elif t == PIXEL_UINT:
                    row = [float(v) for v in struct.unpack("<%dI" % width, seg)]
                else:
                    row = [_half_to_float(v) for v in struct.unpack("<%dH" % width, seg)]
                result[ch["name"]][row0 + line] = row
    for name, rows in result.items():
        if any(r is None for r in rows):
            raise ExrError("channel '%s' has missing scanlines" % name)
    return result


# --------------------------------------------------------------------------
# --check: compare with expected values written by test_image.

def _bits_of_float(v):
    return struct.unpack("<I", struct.pack("<f", v))[0]


def _expected_half(bits):
    """The half a correct writer stores for the float with these bits:
    round to nearest, ties to even (Python's struct 'e' does exactly that)."""
    f = struct.unpack("<f", struct.pack("<I", bits))[0]
    return struct.unpack("<e", struct.pack("<e", f))[0]


def _load_expected(path):
    files = []
    with open(path) as f:
        lines = [ln.rstrip("\n") for ln in f]
    i = 0
    current = None
    while i < len(lines):
        parts = lines[i].split()
        i += 1
        if not parts:
            continue
        if parts[0] == "end":
            break
        if parts[0] == "file":
            current = {"file": parts[1], "w": int(parts[2]), "h": int(parts[3]),
                       "comp": parts[4], "channels": []}
            files.append(current)
        elif parts[0] == "channel":
            rows = []
            for _ in range(current["h"]):
                rows.append([int(v, 16) for v in lines[i].split()])
                i += 1
            current["channels"].append({"name": parts[1], "type": parts[2], "rows": rows})
        else:
            raise ExrError("bad line in %s: %s" % (path, lines[i - 1]))
    return files


def check(expected_path):
    base = os.path.dirname(os.path.abspath(expected_path))
    failures = 0
    files = _load_expected(expected_path)
    if not files:
        print("no files listed in %s" % expected_path)
        return 1
    for entry in files:
        path = os.path.join(base, entry["file"])
        try:
            header = read_header(path)
            got = read_exr(path)
        except (ExrError, OSError) as e:
            print("FAIL %s: %s" % (entry["file"], e))
            failures += 1
            continue
        comp = COMPRESSION_NAMES[header["compression"][1]]
        if comp != entry["comp"]:
            print("FAIL %s: compression %s, expected %s" % (entry["file"], comp, entry["comp"]))
            failures += 1
        names = sorted(c["name"] for c in entry["channels"])
        file_names = [c["name"] for c in header["channels"][1]]
        if file_names != names:
            print("FAIL %s: channels %s, expected %s (sorted)" % (entry["file"], file_names, names))
            failures += 1
            continue
        types = {c["name"]: c["type"] for c in header["channels"][1]}
        bad = 0
        for ch in entry["channels"]:
            want_type = PIXEL_HALF if ch["type"] == "HALF" else PIXEL_FLOAT
            if types[ch["name"]] != want_type:
                print("FAIL %s: channel %s has type %d" % (entry["file"], ch["name"],
                                                           types[ch["name"]]))
                bad += 1
                continue
            rows = got[ch["name"]]
            if len(rows) != entry["h"] or any(len(r) != entry["w"] for r in rows):
                print("FAIL %s: channel %s has the wrong size" % (entry["file"], ch["name"]))
                bad += 1
                continue
            for y in range(entry["h"]):
                for x in range(entry["w"]):
                    bits = ch["rows"][y][x]
                    v = rows[y][x]
                    if want_type == PIXEL_FLOAT:
                        ok = _bits_of_float(v) == bits
                        want = struct.unpack("<f", struct.pack("<I", bits))[0]
                    else:
                        want = _expected_half(bits)
                        ok = struct.pack("<e", v) == struct.pack("<e", want)
                    if not ok:
                        if bad < 5:
                            print("FAIL %s: %s[%d][%d] = %r, expected %r"
                                  % (entry["file"], ch["name"], y, x, v, want))
                        bad += 1
        if entry["file"].startswith("s_") and not entry["file"].endswith("_hand.exr") \
                and header.get("chisel:test", (None, None))[1] != "hello":
            print("FAIL %s: attribute chisel:test missing" % entry["file"])
            bad += 1
        if bad:
            failures += 1
        else:
            print("ok   %s (%dx%d, %s, %s)" % (entry["file"], entry["w"], entry["h"], comp,
                                              ", ".join("%s:%s" % (c["name"], c["type"])
                                                        for c in entry["channels"])))
    return 1 if failures else 0


def main(argv):
    if len(argv) == 3 and argv[1] == "--check":
        return check(argv[2])
    if len(argv) == 2:
        try:
            channels = read_exr(argv[1])
        except ExrError as e:
            print("%s: %s" % (argv[1], e), file=sys.stderr)
            return 2
        for name, rows in channels.items():
            flat = [v for r in rows for v in r]
            print("%s: %dx%d min %g max %g" % (name, len(rows[0]), len(rows), min(flat),
                                               max(flat)))
        return 0
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv))
