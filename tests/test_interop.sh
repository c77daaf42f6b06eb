#!/usr/bin/env bash
# chisel's outputs in the tools people open them with: OpenEXR's exrheader,
# OpenImageIO's oiiotool and ImageMagick read the maps' values (checked
# against the repository's own Python EXR reader), and Blender 3.4 headless
# loads the height map, parses every EXR's layers, imports the OBJ and the
# PLY (counting boundary edges) and carves the base through the README's
# Displace route.
# usage: test_interop.sh CHISEL TESTS_DIR MODELS_DIR TMP_DIR
set -u
chisel=$1 tests=$2 models=$3 tmp=$4
rm -rf "$tmp"
mkdir -p "$tmp"
failures=0 checks=0
fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }
check() { checks=$((checks + 1)); "$@" || fail "$*"; }
need() { command -v "$1" >/dev/null || { echo "test_interop: $1 is missing (scripts/install-deps.sh installs it)" >&2; exit 1; }; }
need exrheader
need oiiotool
need convert
need blender
need python3

plane=$models/plane.obj
relief=$models/curves/relief.svg
"$chisel" sample "$relief" --res 32 --supersample 1 -o "$tmp/h.exr" --height-png "$tmp/h16.png" -q ||
  fail "sample"
"$chisel" displace "$plane" "$relief" -o "$tmp/r.obj" --ply "$tmp/r.ply" --glb "$tmp/r.glb" --exr "$tmp/maps.exr" \
  --res 32 --target-tris 20000 -q || fail "displace relief"
"$chisel" displace "$models/tablet.obj" "$models/curves/glyphs.svg" -o "$tmp/t.obj" --ply "$tmp/t.ply" \
  --target-tris 40000 -q 2>/dev/null || fail "displace tablet"
"$chisel" displace "$models/tablet.obj" "$models/curves/glyphs.svg" -o "$tmp/t.glb" --target-tris 40000 -q 2>/dev/null ||
  fail "displace tablet to glb"
"$chisel" dci "$models/curves/steps_simple.svg" --res 32 -o "$tmp/dci.exr" -q || fail "dci"
"$chisel" magnify "$tmp/dci.exr" --rect 0.2,0.2,0.4,0.4 --out-res 16 -o "$tmp/crop.png" --exr "$tmp/crop.exr" -q ||
  fail "magnify"

# ---- exrheader: the channels every reader needs ----
channels() { exrheader "$1" | sed -n '/^channels/,/^[a-z]/p' | grep '^    ' | sed 's/^ *//; s/,.*//' | sort | tr '\n' ' '; }
checks=$((checks + 1))
[ "$(channels "$tmp/h.exr")" = "Y h " ] || fail "h.exr channels: $(channels "$tmp/h.exr")"
checks=$((checks + 1))
[ "$(channels "$tmp/maps.exr")" = "N.x N.y N.z P.x P.y P.z Y face.X h s t " ] ||
  fail "maps.exr channels: $(channels "$tmp/maps.exr")"
checks=$((checks + 1))
channels "$tmp/dci.exr" | grep -q "distance.X" || fail "dci.exr channels: $(channels "$tmp/dci.exr")"
checks=$((checks + 1))
[ "$(channels "$tmp/crop.exr")" = "Y h " ] || fail "crop.exr channels: $(channels "$tmp/crop.exr")"

# ---- oiiotool and ImageMagick read the values ----
oiiotool -v --info --dumpdata "$tmp/h.exr" >"$tmp/oiio_h.txt" 2>&1 || fail "oiiotool h.exr"
oiiotool -v --info --dumpdata "$tmp/maps.exr" >"$tmp/oiio_maps.txt" 2>&1 || fail "oiiotool maps.exr"
convert "$tmp/h.exr" -format '%[fx:mean]' info: >"$tmp/im_mean.txt" 2>"$tmp/im_err.txt" || fail "convert h.exr"
convert "$tmp/h16.png" -format '%z' info: >"$tmp/im_depth.txt" || fail "convert h16.png"
convert "$tmp/h16.png" txt:- >"$tmp/im_png.txt" || fail "convert h16.png txt"
checks=$((checks + 1))
python3 - "$tmp" "$tests/tools" <<'EOF' || fail "values read by oiiotool and ImageMagick"
import re, sys
tmp = sys.argv[1]
sys.path.insert(0, sys.argv[2])
from exr_read import read_exr
h = read_exr(tmp + "/h.exr")["h"]
def dump(path, channel):  # oiiotool -v --info --dumpdata: the channel list, then "Pixel (x, y): v v ..."
    out, names = {}, None
    for line in open(path):
        if "channel list:" in line:
            names = [c.strip() for c in line.split(":", 1)[1].split(",")]
        m = re.match(r"\s*Pixel \((\d+), (\d+)\): (.*)", line)
        if m:
            out[int(m.group(1)), int(m.group(2))] = float(m.group(3).split()[names.index(channel)])
    return out
s = max(abs(v) for r in h for v in r)
Y = [[0.5 + v / (2 * s) for v in r] for r in h]  # what viewers show: 0.5 is h = 0
for channel, want in (("h", h), ("Y", Y)):
    d = dump(tmp + "/oiio_h.txt", channel)
    assert len(d) == 32 * 32, (channel, len(d))
    worst = max(abs(d[x, y] - want[y][x]) for x in range(32) for y in range(32))
    assert worst < 1e-7, (channel, worst)  # 9 decimals printed, Y in float
# P.x of the geometry image is u on the plane: (x + 0.5) / 32.
px = dump(tmp + "/oiio_maps.txt", "P.x")
assert max(abs(px[x, y] - (x + 0.5) / 32) for x in range(32) for y in range(32)) < 1e-6
# ImageMagick shows Y (Q16, [0,1]): its mean is Y's.
mean = sum(sum(r) for r in Y) / (32 * 32)
im = float(open(tmp + "/im_mean.txt").read())
assert 0.5 < mean < 1 and abs(im - mean) < 1e-3, (im, mean)  # it reads through OpenEXR's RGBA (half) interface
# The 16-bit PNG: 0.5 is h = 0, 0 and 1 are -s and +s, s = max |h|.
assert open(tmp + "/im_depth.txt").read().strip() == "16"
n = 0
for line in open(tmp + "/im_png.txt"):
    m = re.match(r"(\d+),(\d+): \((\d+)", line)
    if not m:
        continue
    x, y, q = int(m.group(1)), int(m.group(2)), int(m.group(3))
    want = round(65535 * (0.5 + 0.5 * h[y][x] / s))
    assert abs(q - want) <= 1, (x, y, q, want)
    n += 1
assert n == 32 * 32, n
EOF

# ---- Blender: images, layers, meshes, the Displace route ----
"$chisel" info "$tmp/r.obj" >"$tmp/info_r.txt" 2>/dev/null
want_boundary=$(sed -n 's/^  edges *\([0-9]*\) boundary.*/\1/p' "$tmp/info_r.txt")
s16=$(python3 -c "import sys; sys.path.insert(0, sys.argv[2]); from exr_read import read_exr; print(2 * max(abs(v) for r in read_exr(sys.argv[1])['h'] for v in r))" "$tmp/h.exr" "$tests/tools")
blender -b --factory-startup --python "$tests/tools/blender_check.py" -- \
  "image:$tmp/h.exr:5:7" "passes:$tmp/maps.exr" "passes:$tmp/dci.exr" \
  "mesh:$tmp/r.obj" "mesh:$tmp/r.ply" "mesh:$tmp/t.obj" "mesh:$tmp/t.ply" "mesh:$tmp/r.glb" "mesh:$tmp/t.glb" \
  "displace:$plane:$tmp/h.exr:0.5:$s16:4" "displace:$plane:$tmp/h16.png:0.5:$s16:4" >"$tmp/blender.txt" 2>&1 ||
  fail "blender: $(tail -5 "$tmp/blender.txt")"
checks=$((checks + 1))
python3 - "$tmp" "$tests/tools" "$want_boundary" <<'EOF' || { fail "Blender's reading"; grep -E "^[A-Z]+ |rror|token" "$tmp/blender.txt" >&2; }
import sys
tmp, want_boundary = sys.argv[1], int(sys.argv[3])
sys.path.insert(0, sys.argv[2])
from exr_read import read_exr
log = open(tmp + "/blender.txt").read()
assert "unknown channel token" not in log and "bad channel name" not in log, "Blender refused a channel name"
lines = {}
for line in log.splitlines():
    parts = line.split()
    if parts and parts[0] in ("IMAGE", "PASSES", "MESH", "DISPLACE"):
        lines.setdefault(parts[0], []).append(parts)
# The height map: a 32 x 32 grey image whose value is Y = 0.5 + h / (2 s)
# (a lone channel h loaded as zeros).
img = lines["IMAGE"][0]
h = read_exr(tmp + "/h.exr")["h"]
s = max(abs(v) for r in h for v in r)
assert img[3] == "IMAGE" and img[5:7] == ["32", "32"], img
assert abs(float(img[8]) - (0.5 + h[7][5] / (2 * s))) < 1e-7 and h[7][5] != 0.0, (img, h[7][5])
# Multilayer maps parse into their passes (not a 0 x 0 image).
maps, dci = lines["PASSES"]
assert maps[3] == "MULTILAYER" and {"h", "P", "N", "face", "s", "t", "Y"} <= set(maps[4:]), maps
assert {"h", "distance", "curve", "side", "opp"} <= set(dci[4:]), dci
# OBJ and PLY: closed where the OBJ is (the plane's border only; the
# tablet everywhere), with UVs.
meshes = {}
for m in lines["MESH"]:
    meshes[m[1].rsplit("/", 1)[1]] = {k: (v if k == "path" else int(v)) for k, v in zip(["path"] + m[2::2], m[1::2])}
for name in ("r.obj", "r.ply"):
    m = meshes[name]
    assert m["boundary"] == want_boundary and m["nonmanifold"] == 0 and m["uv"] == 1, (m, want_boundary)
for name in ("t.obj", "t.ply"):
    m = meshes[name]
    assert m["boundary"] == 0 and m["nonmanifold"] == 0, m
assert meshes["r.obj"]["faces"] == meshes["r.ply"]["faces"]
assert meshes["t.obj"]["faces"] == meshes["t.ply"]["faces"]
# glTF binary (-o by extension, --glb): Blender imports every triangle (the
# OBJ's count), split where UVs or normals differ as glTF needs. With the
# copies at identical coordinates joined it is the PLY joined the same way
# (both float32: faces, boundary, non-manifold edges) and closed where the
# OBJ is. Joining drops the faces with two corners at one float32 point
# (edges shorter than float32's step).
for glb, obj, ply in (("r.glb", "r.obj", "r.ply"), ("t.glb", "t.obj", "t.ply")):
    g, o, p = meshes[glb], meshes[obj], meshes[ply]
    assert g["faces"] == o["faces"] and g["uv"] == 1, (g, o)
    welded = ("welded_faces", "welded_boundary", "welded_nonmanifold")
    assert [g[k] for k in welded] == [p[k] for k in welded], (g, p)
    assert g["welded_boundary"] == o["boundary"] and g["welded_nonmanifold"] == 0, (g, o)
assert meshes["t.obj"]["uv"] == 1  # the tablet's UV seams: the PLY's UVs are per corner (MeshLab), not for Blender 3.4
# The Displace route gives back h's range (the EXR's Y and the 16-bit PNG,
# both with midlevel 0.5 and strength 2 s).
lo, hi = min(min(r) for r in h), max(max(r) for r in h)
for d in lines["DISPLACE"]:
    z0, z1 = float(d[3]), float(d[5])
    assert abs(z1 - hi) < 2e-4 and abs(z0 - lo) < 2e-4, (d, lo, hi)
EOF

# ---- glTF base meshes from Blender ----
# The tablet exported by Blender's glTF exporter (binary, and JSON with its
# .bin beside it) is the same base mesh to chisel as the OBJ: its positions
# (welded back at the UV seams and creases glTF splits), UVs, charts,
# bounds, closed; only its quads come as triangle pairs. It carves like the
# OBJ, closed.
blender -b --factory-startup --python "$tests/tools/blender_check.py" -- \
  "export:$models/tablet.obj:$tmp/tablet.glb" "export:$models/tablet.obj:$tmp/tablet.gltf" >"$tmp/export.txt" 2>&1 ||
  fail "blender export: $(tail -5 "$tmp/export.txt")"
checks=$((checks + 1))
"$chisel" info --json "$models/tablet.obj" "$tmp/tablet.glb" "$tmp/tablet.gltf" >"$tmp/gltf_info.jsonl" 2>/dev/null &&
  [ -f "$tmp/tablet.bin" ] &&
  python3 - "$tmp/gltf_info.jsonl" <<'EOF' || fail "chisel's reading of Blender's glTF: $(cat "$tmp/gltf_info.jsonl")"
import json, sys
obj, glb, gltf = [json.loads(l) for l in open(sys.argv[1])]
for g in (glb, gltf):
    assert g["faces"] == g["triangles"] == 2 * obj["quads"], (g, obj)
    for k in ("positions", "uvs", "uv_charts", "components", "boundary_edges", "nonmanifold_edges"):
        assert g[k] == obj[k], (k, g[k], obj[k])
    for k in ("bounds_min", "bounds_max", "uv_min", "uv_max"):
        assert all(abs(a - b) < 1e-6 for a, b in zip(g[k], obj[k])), (k, g[k], obj[k])
EOF
checks=$((checks + 1))
"$chisel" displace "$tmp/tablet.gltf" "$models/tablet_glyphs.svg" -o "$tmp/tg.obj" --target-tris 30000 -q 2>/dev/null &&
  "$chisel" info "$tmp/tg.obj" 2>/dev/null | grep -q "0 boundary, 0 non-manifold" ||
  fail "displace on Blender's .gltf of the tablet: not closed"

# A scene's transforms, instancing, mirroring and primitives, against
# Blender's own OBJ of it (transforms applied): the same bounds, UVs and
# charts, every quad as two triangles, the same boundary; and, carved by
# chisel (--no-snap), each monkey encloses the signed volume the OBJ's
# does (a mirrored one read with its winding left as stored would turn
# inside out: the sign flips).
blender -b --factory-startup --python "$tests/tools/blender_check.py" -- \
  "scene:$tmp/scene.glb:$tmp/scene.obj" >"$tmp/scene.txt" 2>&1 || fail "blender scene: $(tail -5 "$tmp/scene.txt")"
checks=$((checks + 1))
"$chisel" info --json "$tmp/scene.glb" "$tmp/scene.obj" >"$tmp/scene_info.jsonl" 2>/dev/null &&
  "$chisel" displace "$tmp/scene.glb" "$models/curves/star.svg" -o "$tmp/scene_d.obj" --no-snap --target-tris 60000 \
    -q 2>/dev/null &&
  python3 - "$tmp" <<'EOF' || fail "chisel's reading of Blender's glTF scene: $(cat "$tmp/scene_info.jsonl")"
import json, sys
tmp = sys.argv[1]
glb, obj = [json.loads(l) for l in open(tmp + "/scene_info.jsonl")]
assert glb["triangles"] == 2 * obj["quads"] + obj["triangles"], (glb, obj)
for k in ("uvs", "uv_charts", "boundary_edges"):
    assert glb[k] == obj[k], (k, glb[k], obj[k])
for k in ("bounds_min", "bounds_max"):
    assert all(abs(a - b) < 1e-5 for a, b in zip(glb[k], obj[k])), (k, glb[k], obj[k])
def volumes(path):
    v, out = [], [0.0, 0.0]  # the monkey at the origin, the mirrored one beyond x = 1.8
    for line in open(path):
        t = line.split()
        if t and t[0] == "v":
            v.append(tuple(map(float, t[1:4])))
        elif t and t[0] == "f":
            f = [v[int(x.split("/")[0]) - 1] for x in t[1:]]
            for k in range(1, len(f) - 1):
                a, b, c = f[0], f[k], f[k + 1]
                det = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0])
                out[(a[0] + b[0] + c[0]) / 3 > 1.8] += det / 6
    return out
want, got = volumes(tmp + "/scene.obj"), volumes(tmp + "/scene_d.obj")
assert all(abs(g - w) < 0.02 * abs(w) for g, w in zip(got, want)), (got, want)
EOF

echo "$checks checks, $failures failures"
[ "$failures" = 0 ]
