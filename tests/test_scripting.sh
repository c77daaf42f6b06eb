#!/usr/bin/env bash
# The command line as scripts use it: --opt=value, -q, -j, --json, the
# one-line result, -o - (and its refusals), "did you mean", SVGs drawn
# without data- attributes (docs/svg.md) read back through `info --json`,
# the study report's contents and UDIM tiles (docs/udim.md).
# usage: test_scripting.sh CHISEL TESTS_DIR MODELS_DIR TMP_DIR
set -u
chisel=$1 tests=$2 models=$3 tmp=$4
rm -rf "$tmp"
mkdir -p "$tmp"
failures=0 checks=0
fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }
check() { checks=$((checks + 1)); "$@" || fail "$*"; }
# run STATUS CMD...: runs CMD, keeps stdout and stderr, checks the status.
run() {
  local want=$1
  shift
  checks=$((checks + 1))
  "$@" >"$tmp/out" 2>"$tmp/err"
  local got=$?
  [ "$got" = "$want" ] || { fail "exit $got (want $want): $*"; sed 's/^/    /' "$tmp/err" >&2; }
}
err_has() { checks=$((checks + 1)); grep -qF -- "$1" "$tmp/err" || fail "stderr lacks '$1': $(cat "$tmp/err")"; }
err_lines() { checks=$((checks + 1)); [ "$(wc -l <"$tmp/err")" = "$1" ] || fail "stderr has $(wc -l <"$tmp/err") lines, want $1: $(cat "$tmp/err")"; }
# json EXPR FILE: a Python expression over the JSON object d is true.
json() { checks=$((checks + 1)); python3 -c "import json,sys; d=json.load(open(sys.argv[1])); assert $1, d" "$2" || fail "json: $1"; }

plane=$models/plane.obj
relief=$models/curves/relief.svg

# ---- --opt=value is --opt value; a flag takes no value ----
run 0 "$chisel" sample "$relief" --res=32 --supersample=1 -o "$tmp/a.exr"
run 0 "$chisel" sample "$relief" --res 32 --supersample 1 -o "$tmp/b.exr"
check cmp -s "$tmp/a.exr" "$tmp/b.exr"
run 0 "$chisel" sample "$relief" --res 32 --output="$tmp/c.exr"
run 2 "$chisel" displace "$plane" "$relief" -o "$tmp/x.obj" --no-snap=yes
err_has "option --no-snap takes no value"

# ---- the result line, and -q ----
run 0 "$chisel" sample "$relief" --res 32 -o "$tmp/a.exr"
err_lines 1
err_has "chisel: wrote $tmp/a.exr (32 x 32, h in [0, 0.03]; Y = 0.5 + h / (2 x 0.03)) in "
run 0 "$chisel" sample "$relief" --res 32 -o "$tmp/a.exr" -q
err_lines 0
run 0 "$chisel" displace "$plane" "$relief" -o "$tmp/r.obj" --target-tris 8000 --res 128
err_lines 1
checks=$((checks + 1))
grep -qE "^chisel: wrote $tmp/r.obj: [0-9]+ triangles, [0-9]+ vertices, h in \[0, 0.03\], in [0-9.]+ s$" "$tmp/err" ||
  fail "displace result line: $(cat "$tmp/err")"
run 0 "$chisel" displace "$plane" "$relief" -o "$tmp/q.obj" --target-tris 8000 --res 128 --quiet
err_lines 0

# ---- -j: the same bytes on 1 and 2 threads ----
run 0 "$chisel" displace "$plane" "$relief" -o "$tmp/j1.obj" --target-tris 8000 --res 128 -j 1 -q
run 0 "$chisel" displace "$plane" "$relief" -o "$tmp/j2.obj" --target-tris 8000 --res 128 --threads=2 -q
check cmp -s "$tmp/j1.obj" "$tmp/j2.obj"
check cmp -s "$tmp/j1.obj" "$tmp/r.obj"
run 2 "$chisel" sample "$relief" --res 32 -o "$tmp/a.exr" -j 0
err_has "-j 0 is outside 1..1024"

# ---- the mesh format by -o's extension: the same bytes as --ply; glTF binary ----
run 0 "$chisel" displace "$plane" "$relief" -o "$tmp/e.ply" --glb "$tmp/e2.glb" --target-tris 8000 --res 128 -q
run 0 "$chisel" displace "$plane" "$relief" -o "$tmp/e.obj" --ply "$tmp/e2.ply" --target-tris 8000 --res 128 -q
check cmp -s "$tmp/e.ply" "$tmp/e2.ply"
run 0 "$chisel" displace "$plane" "$relief" -o "$tmp/E.GLB" --target-tris 8000 --res 128 -q
check cmp -s "$tmp/E.GLB" "$tmp/e2.glb"
checks=$((checks + 1))
[ "$(head -c 4 "$tmp/E.GLB")" = glTF ] || fail "-o E.GLB is not a glTF binary"
run 2 "$chisel" displace "$plane" "$relief" -o "$tmp/x.fbx" --target-tris 8000
err_has "-o $tmp/x.fbx: unknown mesh format (.obj, .ply or .glb)"
err_lines 1
check test ! -e "$tmp/x.fbx"
run 2 "$chisel" displace "$plane" "$relief" -o "$tmp/noext" --target-tris 8000
err_has "no extension to tell the format"
run 2 "$chisel" displace "$plane" "$relief" -o "$tmp/x.obj" --glb -
err_has "--glb -: a glTF binary cannot be written to standard output"

# ---- -o -: OBJ and PLY to standard output, the same bytes as files ----
run 0 "$chisel" displace "$plane" "$relief" -o - --target-tris 8000 --res 128 -q
cp "$tmp/out" "$tmp/stdout.obj"
check cmp -s "$tmp/stdout.obj" "$tmp/r.obj"
run 0 "$chisel" displace "$plane" "$relief" -o "$tmp/r2.obj" --ply "$tmp/r.ply" --target-tris 8000 --res 128 -q
run 0 "$chisel" displace "$plane" "$relief" -o "$tmp/r3.obj" --ply - --target-tris 8000 --res 128
cp "$tmp/out" "$tmp/stdout.ply"
check cmp -s "$tmp/stdout.ply" "$tmp/r.ply"
err_has "PLY to standard output"
run 2 "$chisel" sample "$relief" --res 32 -o -
err_has "-o -: an EXR cannot be written to standard output"
run 2 "$chisel" displace "$plane" "$relief" -o "$tmp/x.obj" --exr -
err_has "--exr -: an EXR cannot be written to standard output"
run 2 "$chisel" displace "$plane" "$relief" -o - --ply -
err_has "name the same standard output"
run 2 "$chisel" displace "$plane" "$relief" -o - --json
err_has "--json and a mesh on standard output"
check [ ! -e "$tmp/-" ]

# ---- --json ----
run 0 "$chisel" displace "$plane" "$relief" -o "$tmp/r4.obj" --target-tris 8000 --res 128 --json -q
cp "$tmp/out" "$tmp/d.json"
json 'd["outputs"] == [sys.argv[1].rsplit("/", 1)[0] + "/r4.obj"] and abs(d["triangles"] - 8000) <= 400' "$tmp/d.json"
json 'd["embed"]["unresolved"] == 0 and d["h_max"] > 0.029 and d["seconds"]["total"] > 0' "$tmp/d.json"
run 0 "$chisel" info --json "$plane" "$relief" "$tmp/a.exr"
checks=$((checks + 1))
python3 - "$tmp/out" <<'EOF' || fail "info --json"
import json, sys
lines = open(sys.argv[1]).read().splitlines()
assert len(lines) == 3, lines
mesh, svg, exr = (json.loads(l) for l in lines)
assert mesh["faces"] == 256 and mesh["boundary_edges"] == 64 and mesh["uv_charts"] == 1, mesh
assert mesh["chisel_output"] is False, mesh
assert svg["type"] == "svg" and svg["curves"] == len(svg["curve_list"]) > 0, svg
assert sorted(c["name"] for c in exr["channels"]) == ["Y", "h"], exr
h = [c for c in exr["channels"] if c["name"] == "h"][0]
assert abs(h["max"] - 0.03) < 1e-6 and h["non_finite"] == 0, h
EOF

# A displaced mesh's walls have no UV area: info explains them instead of
# warning about them (a base mesh's zero UV area is still a warning).
run 0 "$chisel" info --json "$tmp/r4.obj"
cp "$tmp/out" "$tmp/i.json"
json 'd["chisel_output"] is True and d["zero_uv_area_faces"] > 0 and d["nonmanifold_edges"] == 0' "$tmp/i.json"
err_lines 0
run 0 "$chisel" info "$tmp/r4.obj"
err_lines 0
checks=$((checks + 1))
grep -q "with zero UV area (a chisel output: its walls have no UV area" "$tmp/out" || fail "info: walls not explained"

# ---- did you mean ----
run 2 "$chisel" displce
err_has "unknown command 'displce' (did you mean 'displace'?"
run 2 "$chisel" sampel
err_has "did you mean 'sample'?"
run 2 "$chisel" displace "$plane" "$relief" -o "$tmp/x.obj" --target-tri 5
err_has "unknown option '--target-tri' (did you mean --target-tris?)"
run 2 "$chisel" sample "$relief" --res 32 -o "$tmp/x.exr" --supersampel 2
err_has "did you mean --supersample?"
run 2 "$chisel" info --jsn "$plane"
err_has "did you mean --json?"
run 2 "$chisel" frobnicate
err_lines 1
checks=$((checks + 1))
grep -q "did you mean" "$tmp/err" && fail "a guess for a word far from every command"

# ---- SVGs as drawn (docs/svg.md) ----
info_svg() { "$chisel" info --json "$@" >"$tmp/svg.json" 2>"$tmp/err" || fail "info $*: $(cat "$tmp/err")"; }
# In Inkscape's style: style attributes, mm units, a layer with a transform.
info_svg "$tests/data/svg/drawn/inkscape.svg"
checks=$((checks + 1))
python3 - "$tmp/svg.json" <<'EOF' || fail "inkscape.svg"
import json, sys
d = json.load(open(sys.argv[1]))
c = {x["id"]: x for x in d["curve_list"]}
vb = 100.0
# A stroke 2 units wide under the layer's scale(0.5): 1 viewBox unit, 1/100 UV.
s = c["stroke-scaled"]
assert s["kind"] == "groove" and s["decided_by"] == "stroke" and s["width_from"] == "stroke-width", s
assert abs(s["width_uv"] - 0.01) < 1e-12, s["width_uv"]
# stroke from style overrides the stroke="none" attribute.
s = c["style-wins"]
assert s["decided_by"] == "stroke" and abs(s["width_uv"] - 0.03) < 1e-12, s
# A filled shape without stroke: a step raised by the fill height inside.
f = c["filled-rect"]
assert f["kind"] == "step" and f["decided_by"] == "fill" and f["left"] == 0.01 and f["right"] == 0, f
# data- attributes decide; the width still comes from the stroke.
g = c["with-data"]
assert g["decided_by"] == "data-attributes" and g["profile"] == "u" and g["width_from"] == "stroke-width", g
assert abs(g["width_uv"] - 0.04) < 1e-12, g
# Nothing painted: a groove with the defaults (8 viewBox units).
n = c["unpainted"]
assert n["decided_by"] == "default" and n["width_from"] == "default" and abs(n["width_uv"] - 0.08) < 1e-12, n
EOF
# In a public icon set's style: viewBox 0 0 24 24, paint on the root.
info_svg "$tests/data/svg/drawn/icon_outline.svg"
checks=$((checks + 1))
python3 - "$tmp/svg.json" <<'EOF' || fail "icon_outline.svg"
import json, sys
d = json.load(open(sys.argv[1]))
assert d["curves"] == 3 and d["grooves"] == 3, d
for c in d["curve_list"]:
    # stroke-width 2 of 24: 1/12 of the icon, not 8 units (a third of it).
    assert c["decided_by"] == "stroke" and abs(c["width_uv"] - 2 / 24) < 1e-12, c
EOF
info_svg "$tests/data/svg/drawn/icon_solid.svg" --fill-height 0.02
checks=$((checks + 1))
python3 - "$tmp/svg.json" <<'EOF' || fail "icon_solid.svg"
import json, sys
d = json.load(open(sys.argv[1]))
assert d["steps"] == 2 and d["grooves"] == 0, d
for c in d["curve_list"]:
    assert c["decided_by"] == "fill" and c["left"] == 0.02 and c["right"] == 0, c
EOF
# The ring (evenodd, both subpaths drawn the same way) and the disc are
# raised inside and nowhere else: h at the ring, in its hole, outside.
run 0 "$chisel" sample "$tests/data/svg/drawn/icon_solid.svg" --res 48 --supersample 1 -o "$tmp/solid.exr" \
  --fill-height 0.02 -q
checks=$((checks + 1))
python3 - "$tmp/solid.exr" "$tests/tools" <<'EOF' || fail "icon_solid.svg heights"
import sys
sys.path.insert(0, sys.argv[2])
from exr_read import read_exr
h = read_exr(sys.argv[1])["h"]
def at(x, y):  # viewBox units (0..24, y down) to the pixel there
    return h[int(y / 24 * 48)][int(x / 24 * 48)]
assert abs(at(12, 3.5) - 0.02) < 1e-5, at(12, 3.5)   # on the ring (radii 6..10 around 12,12)
assert abs(at(12, 12)) < 1e-5, at(12, 12)            # the hole
assert abs(at(1, 23)) < 1e-5, at(1, 23)              # outside everything
assert abs(at(21.5, 21.5) - 0.02) < 1e-5, at(21.5, 21.5)  # the disc
EOF
# The bundled curve sets (data- attributes everywhere) read as before.
for f in "$models"/curves/*.svg; do
  info_svg "$f"
  checks=$((checks + 1))
  python3 -c "import json,sys; d=json.load(open(sys.argv[1])); assert all(c['decided_by']=='data-attributes' and c.get('width_from','data-width') in ('data-width','default') for c in d['curve_list']), sys.argv[1]" "$tmp/svg.json" || fail "$f: not decided by data- attributes"
done

# ---- the study's report: what a researcher publishes from ----
cp "$tests/data/study/box_groove.json" "$tests/data/study/box_groove.svg" "$tests/data/study/box_groove.obj" "$tmp/"
(cd "$tmp" && SOURCE_DATE_EPOCH=86400 "$chisel" study box_groove.json -o report >"$tmp/out" 2>"$tmp/err") ||
  fail "study: $(cat "$tmp/err")"
err_has "chisel: wrote report/index.html"
checks=$((checks + 1))
python3 - "$tmp/report/index.html" "$tmp/box_groove.json" <<'EOF' || fail "study report"
import re, sys
html = open(sys.argv[1]).read()
assert re.search(r"chisel \d+\.\d+\.\d+, 1970-01-02 00:00:00 UTC", html), "version and date"
assert "Command: <code>chisel study box_groove.json -o report</code>" in html, "command"
assert '"truth_grid": 256' in html.replace("&quot;", '"'), "the scene"
assert "Over the 3 views: mean (worst)" in html
# Every heat map (normal and depth error, per view and method) has a
# colour bar with its unit; the class map a legend.
bars = html.count("<linearGradient")
assert bars == 2 * 3 * 1, bars
assert html.count(">degrees</text>") == 3 and html.count(">% of the scene's diagonal</text>") == 3
assert html.count("class differs from the truth") == 3
assert html.count("triangles (log scale)") >= 3 and "mean over views (log scale)" in html
EOF
# The same report again (same bytes, with SOURCE_DATE_EPOCH set).
mv "$tmp/report" "$tmp/report1"
(cd "$tmp" && SOURCE_DATE_EPOCH=86400 "$chisel" study box_groove.json -o report >/dev/null 2>&1)
check cmp -s "$tmp/report1/index.html" "$tmp/report/index.html"

# ---- UDIM: one curve file per tile ----
udim=$tests/data/mesh/udim_two_tiles.obj
mkdir -p "$tmp/udim"
cp "$models/curves/frame.svg" "$tmp/udim/carve.1001.svg" # carved only (h <= 0)
cp "$models/curves/star.svg" "$tmp/udim/carve.1002.svg"
cp "$models/curves/frame.svg" "$tmp/udim/mixed_1001.svg"
cp "$models/curves/relief.svg" "$tmp/udim/mixed_1002.svg" # raised only (h >= 0)
run 2 "$chisel" displace "$udim" "$models/curves/glyphs.svg" -o "$tmp/udim/x.obj" --target-tris 20000 --res 128
err_has "UVs span UDIM tiles 1001, 1002: no curve file for tile 1001"
check [ ! -e "$tmp/udim/x.obj" ]
run 2 "$chisel" displace "$udim" "$tmp/udim/carve.svg" -o "$tmp/udim/x.obj" --exr "$tmp/udim/x.exr"
err_has "has UDIM tiles: --camera, --exr"
run 0 "$chisel" displace "$udim" "$tmp/udim/carve.svg" -o "$tmp/udim/a.obj" --target-tris 20000 --res 128 -q
run 0 "$chisel" displace "$udim" "$tmp/udim/carve.<UDIM>.svg" -o "$tmp/udim/b.obj" --target-tris 20000 --res 128 -q
check cmp -s "$tmp/udim/a.obj" "$tmp/udim/b.obj"
run 0 "$chisel" displace "$udim" "$tmp/udim/mixed_1002.svg" -o "$tmp/udim/m.obj" --target-tris 20000 --res 128 -q
checks=$((checks + 1))
python3 - "$tmp/udim/a.obj" "$tmp/udim/m.obj" <<'EOF' || fail "UDIM outputs"
import sys
def load(path):
    v, vt, f = [], [], []
    for line in open(path):
        p = line.split()
        if not p:
            continue
        if p[0] == "v":
            v.append(tuple(map(float, p[1:4])))
        elif p[0] == "vt":
            vt.append(tuple(map(float, p[1:3])))
        elif p[0] == "f":
            f.append([tuple(int(x) - 1 for x in c.split("/")[:2]) for c in p[1:]])
    return v, vt, f
for path, second in ((sys.argv[1], "carved"), (sys.argv[2], "raised")):
    v, vt, f = load(path)
    # The output's UVs are in the tiles again: u over 0..2.
    us = [t[0] for t in vt]
    assert min(us) > -1e-9 and max(us) < 2 + 1e-9 and max(us) > 1.9, (path, min(us), max(us))
    # Each tile has its own curves: frame carves tile 1001 only (x < 1 on
    # this mesh, where u = x); the second tile's set acts on x > 1 only.
    left = [p[2] for p in v if p[0] < 1 - 1e-6]
    right = [p[2] for p in v if p[0] > 1 + 1e-6]
    assert max(left) < 1e-9 and min(left) < -0.01, (path, min(left), max(left))
    if second == "carved":
        assert max(right) < 1e-9 and min(right) < -0.005, (path, min(right), max(right))
    else:
        assert min(right) > -1e-9 and max(right) > 0.029, (path, min(right), max(right))
    # UV follows position (u = x, v = y on this mesh) at every corner.
    worst = max(abs(vt[t][0] - v[p][0]) + abs(vt[t][1] - v[p][1]) for face in f for p, t in face)
    assert worst < 1e-6, (path, worst)
    # Closed across the tiles' seam: boundary edges only on the outer border.
    count = {}
    for face in f:
        for i in range(len(face)):
            a, b = face[i][0], face[(i + 1) % len(face)][0]
            key = (min(a, b), max(a, b))
            count[key] = count.get(key, 0) + 1
    on_border = lambda p: min(abs(p[0]), abs(p[0] - 2), abs(p[1]), abs(p[1] - 1)) < 1e-9
    for (a, b), n in count.items():
        if n == 1:
            assert on_border(v[a]) and on_border(v[b]), (path, v[a], v[b])
EOF

echo "$checks checks, $failures failures"
[ "$failures" = 0 ]
