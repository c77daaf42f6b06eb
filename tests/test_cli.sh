#!/usr/bin/env bash
# The chisel command line end to end: exit statuses (docs/spec.md §5), one-line
# messages naming the file and the problem, no output file on failure,
# deterministic output.
# usage: test_cli.sh CHISEL TESTS_DIR MODELS_DIR TMP_DIR
set -u
chisel=$1 tests=$2 models=$3 tmp=$4
rm -rf "$tmp"
mkdir -p "$tmp"
failures=0 checks=0

fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }

# expect STATUS CMD...: runs CMD, checks its exit status, keeps stdout/stderr.
expect() {
  local want=$1
  shift
  checks=$((checks + 1))
  "$@" >"$tmp/stdout" 2>"$tmp/stderr"
  local got=$?
  if [ "$got" != "$want" ]; then
    fail "exit $got (want $want): $*"
    sed 's/^/    /' "$tmp/stderr" >&2
    return 1
  fi
  return 0
}
# The last command wrote exactly one line on stderr, containing $1.
one_line_with() {
  checks=$((checks + 1))
  local lines
  lines=$(wc -l <"$tmp/stderr")
  if [ "$lines" != 1 ]; then fail "$lines stderr lines (want 1), expected '$1':"; sed 's/^/    /' "$tmp/stderr" >&2; return; fi
  grep -qF -- "$1" "$tmp/stderr" || fail "stderr lacks '$1': $(cat "$tmp/stderr")"
}
no_file() {
  checks=$((checks + 1))
  [ ! -e "$1" ] || fail "output $1 exists after a failure"
  # Nor a temporary file beside it.
  ls "$(dirname "$1")" | grep -q '\.tmp\.' && fail "temporary file left in $(dirname "$1")"
}

# ---- help and usage ----
expect 2 "$chisel" && grep -q "usage: chisel COMMAND" "$tmp/stderr" || fail "no usage without arguments"
expect 0 "$chisel" --help && grep -q "sample" "$tmp/stdout" || fail "--help lists no commands"
expect 0 "$chisel" --version && grep -q "^chisel " "$tmp/stdout" || fail "--version"
expect 0 "$chisel" help sample && grep -q "usage: chisel sample" "$tmp/stdout" || fail "help sample"
expect 0 "$chisel" sample --help && grep -q "supersample" "$tmp/stdout" || fail "sample --help"
expect 0 "$chisel" info -h && grep -q "usage: chisel info" "$tmp/stdout" || fail "info -h"
expect 2 "$chisel" bogus && one_line_with "unknown command 'bogus'"
expect 2 "$chisel" help bogus && one_line_with "unknown command 'bogus'"

svg=$models/curves/glyphs.svg
out=$tmp/h.exr
expect 2 "$chisel" sample && one_line_with "missing the curve file"
expect 2 "$chisel" sample "$svg" -o "$out" && one_line_with "missing --res"
expect 2 "$chisel" sample "$svg" --res 16 && one_line_with "missing -o"
expect 2 "$chisel" sample "$svg" --res 0 -o "$out" && one_line_with "--res 0 is outside 1..16384"
expect 2 "$chisel" sample "$svg" --res abc -o "$out" && one_line_with "--res expects an integer, got 'abc'"
expect 2 "$chisel" sample "$svg" --res 99999999999 -o "$out" && one_line_with "--res"
expect 2 "$chisel" sample "$svg" --res 16 --supersample 0 -o "$out" && one_line_with "--supersample 0"
expect 2 "$chisel" sample "$svg" --res 16 --frobnicate -o "$out" && one_line_with "unknown option '--frobnicate'"
expect 2 "$chisel" sample "$svg" --res && one_line_with "option --res needs a value"
expect 2 "$chisel" sample "$svg" other.svg --res 16 -o "$out" && one_line_with "unexpected argument 'other.svg'"
no_file "$out"
expect 2 "$chisel" sample "$svg" --res 16 -o "$tmp/no/such/dir/h.exr" && one_line_with "cannot write into directory"
expect 2 "$chisel" sample "$svg" --res 16 -o "$out" --png "$tmp/no/such/h.png" && one_line_with "cannot write into directory"
no_file "$out"
expect 2 "$chisel" sample "$tmp/missing.svg" --res 16 -o "$out" && one_line_with "$tmp/missing.svg: cannot open"
no_file "$out"

# ---- every malformed curve file: exit 2, one line naming it, no output ----
for bad in "$tests"/data/svg/bad/*.svg; do
  name=$(basename "$bad")
  expect 2 "$chisel" sample "$bad" --res 8 -o "$out" --png "$tmp/h.png" && one_line_with "$name"
  no_file "$out"
  no_file "$tmp/h.png"
done

# ---- a real run: EXR + PNG, deterministic bytes ----
expect 0 "$chisel" sample "$svg" --res 64 -o "$out" --png "$tmp/h.png" || true
checks=$((checks + 1))
[ -s "$out" ] && [ -s "$tmp/h.png" ] || fail "sample wrote no EXR/PNG"
checks=$((checks + 1))
[ "$(head -c 8 "$tmp/h.png" | od -An -tx1 | tr -d ' \n')" = "89504e470d0a1a0a" ] || fail "PNG signature"
expect 0 "$chisel" sample "$svg" --res 64 -o "$tmp/h2.exr" --png "$tmp/h2.png" || true
checks=$((checks + 1))
cmp -s "$out" "$tmp/h2.exr" && cmp -s "$tmp/h.png" "$tmp/h2.png" || fail "same input gave different bytes"
# -o writes EXR whatever the name: a .png name gets a warning, and the EXR
expect 0 "$chisel" sample "$svg" --res 64 -o "$tmp/h3.png" -q &&
  one_line_with "-o $tmp/h3.png: writes an OpenEXR file, though the name says .png"
checks=$((checks + 1))
cmp -s "$out" "$tmp/h3.png" || fail "sample -o h3.png: not the EXR"
# Same bytes with one thread as with two.
expect 0 env OMP_NUM_THREADS=1 "$chisel" sample "$svg" --res 64 -o "$tmp/h1.exr" || true
checks=$((checks + 1))
cmp -s "$out" "$tmp/h1.exr" || fail "one thread and two threads differ"
# chisel info on the EXR: its size, and the range of h as the independent reader sees it.
expect 0 "$chisel" info "$out" && grep -q "size *64 x 64" "$tmp/stdout" || fail "info on an EXR: size"
if command -v python3 >/dev/null; then
  checks=$((checks + 1))
  python3 - "$out" "$tests/tools" "$tmp/stdout" <<'EOF' || fail "info on an EXR: range of h"
import sys
sys.path.insert(0, sys.argv[2])
from exr_read import read_exr
rows = read_exr(sys.argv[1])["h"]
lo, hi = min(min(r) for r in rows), max(max(r) for r in rows)
line = [l for l in open(sys.argv[3]) if l.split()[:1] == ["h"]][0].split()
got = float(line[1]), float(line[3])
assert abs(got[0] - lo) <= 1e-5 * abs(lo) + 1e-12 and abs(got[1] - hi) <= 1e-5 * abs(hi) + 1e-12, (got, lo, hi)  # %.6g
EOF
fi
printf 'not an EXR file\n' >"$tmp/bad.exr"
expect 2 "$chisel" info "$tmp/bad.exr" && one_line_with "bad.exr: not an OpenEXR file"
if command -v python3 >/dev/null; then
  checks=$((checks + 1))
  python3 - "$out" "$tests/tools" <<'EOF' || fail "EXR content"
import sys
sys.path.insert(0, sys.argv[2])
from exr_read import read_exr
h = read_exr(sys.argv[1])
assert sorted(h) == ["Y", "h"], list(h)
# Y, for image viewers: 0.5 + h / (2 max |h|), so 0.5 where h = 0.
s = max(abs(v) for r in h["h"] for v in r)
assert s > 0 and all(abs(y - (0.5 + v / (2 * s))) < 1e-6 for ry, rh in zip(h["Y"], h["h"]) for y, v in zip(ry, rh))
rows = h["h"]
assert len(rows) == 64 and all(len(r) == 64 for r in rows)
lo = min(min(r) for r in rows)
assert lo < -0.001, lo   # glyphs carve
EOF
fi

# ---- steps: sample includes h_step; dci writes every layer; magnify reads them ----
steps=$models/curves/steps_simple.svg
expect 0 "$chisel" sample "$steps" --res 50 --supersample 1 -o "$tmp/steps.exr" || true
if command -v python3 >/dev/null; then
  checks=$((checks + 1))
  python3 - "$tmp/steps.exr" "$tests/tools" <<'EOF' || fail "h_step values of steps_simple"
import sys
sys.path.insert(0, sys.argv[2])
from exr_read import read_exr
h = read_exr(sys.argv[1])["h"]
# Disc of radius 0.18 about (0.35, 0.38): 0.02 inside; 0 between; 0.01 above
# the crossing curve (which runs near v = 0.72 .. 0.78).
def at(u, v):
    return h[int((1 - v) * 50)][int(u * 50)]
assert abs(at(0.35, 0.38) - 0.02) < 1e-7, at(0.35, 0.38)
assert abs(at(0.8, 0.4) - 0.0) < 1e-7, at(0.8, 0.4)
assert abs(at(0.5, 0.95) - 0.01) < 1e-7, at(0.5, 0.95)
EOF
fi
relief=$models/curves/relief.svg
expect 0 "$chisel" dci "$relief" --res 128 -o "$tmp/dci.exr" --png "$tmp/dci.png" || true
checks=$((checks + 1))
[ -s "$tmp/dci.exr" ] && [ -s "$tmp/dci.png" ] || fail "dci wrote no EXR/PNG"
if command -v python3 >/dev/null; then
  checks=$((checks + 1))
  python3 - "$tmp/dci.exr" "$tests/tools" <<'EOF' || fail "dci layers"
import sys
sys.path.insert(0, sys.argv[2])
from exr_read import read_exr, read_header
d = read_exr(sys.argv[1])
want = {"h", "R", "G", "B", "opp.h", "opp.R", "opp.G", "opp.B", "distance.X", "sp.u", "sp.v",
        "chain.X", "t", "curve.X", "side.X", "exact.X", "fixed.X", "blur.X"}
assert want <= set(d), sorted(want - set(d))
assert read_header(sys.argv[1])["chisel:rect"][1] == "0 0 1 1", read_header(sys.argv[1])["chisel:rect"]
EOF
fi
expect 0 "$chisel" dci "$svg" --res 32 -o "$tmp/flat.exr" && grep -q "no step curves" "$tmp/stderr" || fail "dci without steps warns"
for m in bilinear recon5 recon3; do
  expect 0 "$chisel" magnify "$tmp/dci.exr" --rect 0.6,0.75,0.7,0.85 --out-res 64 -o "$tmp/mag_$m.png" --method $m || true
done
expect 0 "$chisel" magnify "$tmp/dci.exr" --rect 0.6,0.75,0.7,0.85 --out-res 64 -o "$tmp/mag_exact.png" \
  --method exact --curves "$relief" --exr "$tmp/mag.exr" || true
checks=$((checks + 1))
[ -s "$tmp/mag_exact.png" ] && [ -s "$tmp/mag.exr" ] || fail "magnify wrote no PNG/EXR"
expect 2 "$chisel" magnify "$tmp/dci.exr" --rect 0.6,0.75,0.7,0.85 --out-res 64 -o "$tmp/m.png" --method exact \
  && one_line_with "--method exact needs --curves"
expect 2 "$chisel" magnify "$tmp/dci.exr" --rect 0.6,0.75,0.7,0.85 --out-res 64 -o "$tmp/m.png" --method cubic \
  && one_line_with "unknown method 'cubic'"
expect 2 "$chisel" magnify "$tmp/dci.exr" --rect 0.7,0.75,0.6,0.85 --out-res 64 -o "$tmp/m.png" \
  && one_line_with "--rect needs u0 < u1"
expect 2 "$chisel" magnify "$tmp/dci.exr" --rect 0.6,0.75,0.7 --out-res 64 -o "$tmp/m.png" \
  && one_line_with "--rect expects 4 comma-separated numbers"
expect 2 "$chisel" magnify "$out" --rect 0.6,0.75,0.7,0.85 --out-res 64 -o "$tmp/m.png" \
  && one_line_with "not a chisel DCI: no 'opp.h' layer"
no_file "$tmp/m.png"
expect 2 "$chisel" magnify "$tests/data/svg/bad/garbage.svg" --rect 0,0,1,1 --out-res 8 -o "$tmp/m.png" \
  && one_line_with "garbage.svg"
no_file "$tmp/m.png"

# ---- displace ----
expect 0 "$chisel" displace "$models/plane.obj" "$svg" -o "$tmp/d.obj" --target-tris 20000 --no-snap \
  --png "$tmp/d.png" --exr "$tmp/d.exr" --ply "$tmp/d.ply" || true
checks=$((checks + 1))
[ -s "$tmp/d.obj" ] && [ -s "$tmp/d.png" ] && [ -s "$tmp/d.exr" ] && [ -s "$tmp/d.ply" ] || fail "displace outputs"
expect 0 "$chisel" info "$tmp/d.obj" || true
checks=$((checks + 1))
tris=$(sed -n 's/^ *faces *\([0-9]*\) (\([0-9]*\) triangles.*/\2/p' "$tmp/stdout")
[ -n "$tris" ] && [ "$tris" -ge 19000 ] && [ "$tris" -le 21000 ] || fail "displace: $tris triangles for a target of 20000"
grep -q "UV charts *1" "$tmp/stdout" || fail "displace: UVs lost"
grep -q "normals *from the file" "$tmp/stdout" || fail "displace: no normals"
grep -q "edges *[0-9]* boundary, 0 non-manifold" "$tmp/stdout" || fail "displace: non-manifold output"
expect 0 "$chisel" displace "$models/torus.obj" "$svg" -o "$tmp/t.obj" --target-tris 20000 --no-snap --scheme catmark || true
expect 0 "$chisel" info "$tmp/t.obj" && grep -q "edges *0 boundary, 0 non-manifold" "$tmp/stdout" || fail "displaced torus not closed"
expect 0 "$chisel" displace "$models/plane.obj" "$svg" -o "$tmp/d2.obj" --target-tris 20000 --no-snap || true
checks=$((checks + 1))
cmp -s "$tmp/d.obj" "$tmp/d2.obj" || fail "displace: same input, different bytes"
# Feature embedding (the default): the count still lands on the target,
# the torus stays closed, the bytes are the same twice, stats are printed.
expect 0 "$chisel" displace "$models/plane.obj" "$svg" -o "$tmp/s.obj" --target-tris 40000 --stats || true
checks=$((checks + 1))
grep -q "chisel: embed: .* boundary points" "$tmp/stderr" || fail "displace --stats: no embedding line"
expect 0 "$chisel" info "$tmp/s.obj" || true
checks=$((checks + 1))
tris=$(sed -n 's/^ *faces *\([0-9]*\) (\([0-9]*\) triangles.*/\2/p' "$tmp/stdout")
[ -n "$tris" ] && [ "$tris" -ge 38000 ] && [ "$tris" -le 42000 ] || fail "snapped displace: $tris triangles for a target of 40000"
expect 0 "$chisel" displace "$models/torus.obj" "$svg" -o "$tmp/st.obj" --target-tris 30000 --scheme catmark || true
expect 0 "$chisel" info "$tmp/st.obj" && grep -q "edges *0 boundary, 0 non-manifold; 0 non-manifold vertices" "$tmp/stdout" \
  || fail "snapped torus not closed"
# 484 short strokes 0.0013 of the square wide, far narrower than the edges of 130k triangles: their rounded caps
# are refined down to the junction size, not to their own width, and the count lands (188140 triangles before).
awk 'BEGIN { s = 22; step = 1000 / s; print "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 1000 1000\">"
  for (i = 0; i < s; i++) for (j = 0; j < s; j++) { cx = (i + 0.5) * step; cy = (j + 0.5) * step; r = step * 0.3
    printf "<path fill=\"none\" stroke=\"#000\" stroke-width=\"%.3f\" d=\"M %.3f %.3f Q %.3f %.3f %.3f %.3f T %.3f %.3f\"/>\n",
      step * 0.06, cx - r, cy, cx, cy - 2 * r, cx + r, cy, cx + 2.5 * r, cy }
  print "</svg>" }' > "$tmp/hatch.svg"
expect 0 "$chisel" displace "$models/plane.obj" "$tmp/hatch.svg" -o "$tmp/hatch.obj" --target-tris 130000 || true
checks=$((checks + 1))
tris=$(sed -n 's/.*wrote [^:]*: \([0-9]*\) triangles.*/\1/p' "$tmp/stderr")
[ -n "$tris" ] && [ "$tris" -ge 123500 ] && [ "$tris" -le 136500 ] || fail "484 thin strokes: $tris triangles for a target of 130000"
# A cube written as exporters write PLY (its vertices split at every UV seam): displaced closed, as its OBJ.
expect 0 "$chisel" displace "$tests/data/mesh/cube_split.ply" "$svg" -o "$tmp/cube.obj" --target-tris 20000 || true
expect 0 "$chisel" info "$tmp/cube.obj" && grep -q "edges *0 boundary, 0 non-manifold; 0 non-manifold vertices" \
  "$tmp/stdout" || fail "a cube from a PLY split at its UV seams not closed"
# The README's scene: the glyphs laid out on the tablet's front chart. Every triangle is cut (no warning) and
# the mesh is closed.
expect 0 "$chisel" displace "$models/tablet.obj" "$models/tablet_glyphs.svg" -o "$tmp/tab.obj" --target-tris 130000 &&
  ! grep -q "could not be cut" "$tmp/stderr" || fail "the README's example scene left triangles uncut"
expect 0 "$chisel" info "$tmp/tab.obj" && grep -q "edges *0 boundary, 0 non-manifold; 0 non-manifold vertices" \
  "$tmp/stdout" || fail "the README's example scene not closed and manifold"
# Coarse targets, where rivets and slots cross a base edge twice between two of its samples (a chord with both ends
# on one edge): each mesh is manifold (these gave 1-8 edges of four faces before such triangles were split).
for c in "plane panels 15000" "plane panels 20000" "tablet ornament 15000" "tablet glyphs 20000"; do
  set -- $c
  expect 0 "$chisel" displace "$models/$1.obj" "$models/curves/$2.svg" -o "$tmp/coarse.obj" --target-tris $3 -q || true
  expect 0 "$chisel" info "$tmp/coarse.obj" && grep -q "edges .* 0 non-manifold; 0 non-manifold vertices" "$tmp/stdout" ||
    fail "$1 + $2 at $3 not manifold"
done
# A step corner poking through an edge at the junction size (relief's roof, with the base's finer edges nearest the
# curves): both triangles beside the edge stood a wall on the same chord before such triangles were split further.
for n in 20000 21000 23000; do
  expect 0 "$chisel" displace "$models/plane.obj" "$models/curves/relief.svg" -o "$tmp/coarse.obj" --res 32 \
    --target-tris $n -q || true
  expect 0 "$chisel" info "$tmp/coarse.obj" && grep -q "edges .* 0 non-manifold; 0 non-manifold vertices" "$tmp/stdout" ||
    fail "plane + relief at $n (--res 32) not manifold"
done
# The square's glyphs on the tablet: they cross the front's edges into the side columns, so the UV charts that
# meet there hold different curves.
for n in 130000 520000; do
  expect 0 "$chisel" displace "$models/tablet.obj" "$models/curves/glyphs.svg" -o "$tmp/tab.obj" --target-tris $n || true
  expect 0 "$chisel" info "$tmp/tab.obj" && grep -q "edges *0 boundary, 0 non-manifold; 0 non-manifold vertices" \
    "$tmp/stdout" || fail "snapped tablet at $n not closed and manifold"
done
expect 0 "$chisel" displace "$models/plane.obj" "$svg" -o "$tmp/s2.obj" --target-tris 40000 || true
checks=$((checks + 1))
cmp -s "$tmp/s.obj" "$tmp/s2.obj" || fail "snapped displace: same input, different bytes"
expect 0 "$chisel" displace "$models/plane.obj" "$models/curves/steps_simple.svg" -o "$tmp/r5.obj" --target-tris 20000 \
  --snap-to recon5 || true
expect 2 "$chisel" displace "$models/plane.obj" "$svg" -o "$tmp/x.obj" --snap-to bilinear && one_line_with "--snap-to"
no_file "$tmp/x.obj"
expect 2 "$chisel" displace "$tests/data/mesh/no_uv.obj" "$svg" -o "$tmp/x.obj" --no-snap && one_line_with "no_uv.obj: mesh has no texture coordinates"
no_file "$tmp/x.obj"
expect 2 "$chisel" displace "$tests/data/mesh/zero_uv_face.obj" "$svg" -o "$tmp/x.obj" \
  && one_line_with "zero_uv_face.obj: face 2 has zero UV area"
no_file "$tmp/x.obj"
expect 2 "$chisel" displace "$tests/data/mesh/zero_area_face.obj" "$svg" -o "$tmp/x.obj" --no-snap \
  && one_line_with "zero_area_face.obj: face 2 has zero area"
no_file "$tmp/x.obj"
expect 2 "$chisel" displace "$tests/data/mesh/opposite_faces.obj" "$svg" -o "$tmp/x.obj" --no-snap \
  && one_line_with "opposite_faces.obj: base mesh: position 1 (counting from 0)"
no_file "$tmp/x.obj"
expect 2 "$chisel" displace "$models/plane.obj" "$tests/data/svg/bad/negative_width.svg" -o "$tmp/x.obj" --no-snap \
  && one_line_with "negative data-width"
no_file "$tmp/x.obj"
expect 2 "$chisel" displace "$models/plane.obj" "$svg" -o "$tmp/x.obj" --target-tris 0 && one_line_with "--target-tris 0"
# Below what the base gives at rate 1 (a dense base mesh): rate 1, as with the
# embedding, and a warning naming the count (the plane's 256 quads: 512).
expect 0 "$chisel" displace "$models/plane.obj" "$svg" -o "$tmp/x.obj" --target-tris 10 --no-snap \
  && grep -q "512 triangles: the closest to --target-tris 10" "$tmp/stderr" && [ "$(grep -c '^f ' "$tmp/x.obj")" = 512 ] \
  || fail "--no-snap below rate 1: not the rate-1 mesh with a warning"
rm -f "$tmp/x.obj"
# A base denser than the default target (a 540 x 540 grid of quads: 583200
# triangles at rate 1), no --target-tris: rate 1, and the warning says the
# 520000 it could not meet is the default.
awk 'BEGIN { n = 540
  for (j = 0; j <= n; j++) for (i = 0; i <= n; i++) { printf "v %g %g 0\n", i / n, j / n; printf "vt %g %g\n", i / n, j / n }
  for (j = 0; j < n; j++) for (i = 0; i < n; i++) { a = j * (n + 1) + i + 1; b = a + 1; c = b + n + 1; d = a + n + 1
    printf "f %d/%d %d/%d %d/%d %d/%d\n", a, a, b, b, c, c, d, d } }' >"$tmp/dense.obj"
expect 0 "$chisel" displace "$tmp/dense.obj" "$svg" -o "$tmp/x.obj" --no-snap \
  && grep -q "583200 triangles: the closest to --target-tris 520000 (the default)" "$tmp/stderr" \
  || fail "a dense base at the default target: not rate 1 with the default named"
rm -f "$tmp/x.obj" "$tmp/dense.obj"
expect 2 "$chisel" displace "$models/plane.obj" "$svg" -o "$tmp/x.obj" --res 99999999 && one_line_with "--res"
expect 2 "$chisel" displace "$models/plane.obj" "$svg" -o "$tmp/x.obj" --scheme loop && one_line_with "unknown scheme 'loop'"
expect 2 "$chisel" displace "$models/plane.obj" "$svg" && one_line_with "missing -o"
expect 2 "$chisel" displace "$models/plane.obj" "$svg" -o "$tmp/x.obj" --exr "$tmp/x.obj" && one_line_with "name the same file"
no_file "$tmp/x.obj"

# ---- displace --camera: the view-dependent warp ----
cam=0.25,0.2,0.3,0.25,0.25,0,40 # close above (0.25, 0.25)
expect 0 "$chisel" displace "$models/plane.obj" "$svg" -o "$tmp/w.obj" --target-tris 40000 --res 128 --camera $cam \
  --exr "$tmp/w.exr" --png "$tmp/w.png" || true
grep -q "^chisel: warp: virtual resolution" "$tmp/stderr" || fail "displace --camera: no warp line"
[ -s "$tmp/w.obj" ] && [ -s "$tmp/w.png" ] && [ -s "$tmp/w.exr" ] || fail "displace --camera outputs"
expect 0 "$chisel" info "$tmp/w.obj" && grep -q "edges *[0-9]* boundary, 0 non-manifold" "$tmp/stdout" ||
  fail "displace --camera: non-manifold output"
# A close view of the tablet's glyphs: where a u line pokes through an
# edge between two crossings of the line before it, the triangles on both
# sides cut off the same pieces, of no area; they once doubled back on
# each other (an edge of four faces, two of them at 30000 triangles).
expect 0 "$chisel" displace "$models/tablet.obj" "$models/curves/glyphs.svg" -o "$tmp/wt.obj" --target-tris 30000 \
  --camera 0.2,0.3,0.25,0.3,0.4,0,50 || true
expect 0 "$chisel" info "$tmp/wt.obj" && grep -q "edges *0 boundary, 0 non-manifold; 0 non-manifold vertices" \
  "$tmp/stdout" || fail "displace --camera, tablet + glyphs: not closed and manifold"
# The same for a step curve's wall along an edge: relief's walls read
# through the diffusion image's reconstruction over the tablet stood on
# both sides of one edge (four faces on it).
expect 0 "$chisel" displace "$models/tablet.obj" "$models/curves/relief.svg" -o "$tmp/wr.obj" --target-tris 50000 \
  --snap-to recon3 || true
expect 0 "$chisel" info "$tmp/wr.obj" && grep -q "edges *0 boundary, 0 non-manifold; 0 non-manifold vertices" \
  "$tmp/stdout" || fail "displace --snap-to recon3, tablet + relief: not closed and manifold"
if command -v python3 >/dev/null; then
  checks=$((checks + 1))
  python3 - "$tmp/w.exr" "$tmp/w.obj" "$tmp/s.obj" "$tests/tools" <<'EOF' || fail "displace --camera: warped maps and density"
import sys
sys.path.insert(0, sys.argv[4])
from exr_read import read_exr
img = read_exr(sys.argv[1])
for name in ("h", "P.x", "P.y", "u", "v"):
    assert name in img, (name, list(img))
u, v, px = img["u"], img["v"], img["P.x"]
R = len(u)
# u grows along a row, v falls down a column, and on the plane P.x is u
assert all(u[R // 2][x] < u[R // 2][x + 1] for x in range(R - 1))
assert all(v[y][R // 2] > v[y + 1][R // 2] for y in range(R - 1))
assert max(abs(px[y][x] - u[y][x]) for y in range(R) for x in range(R)) < 1e-5
# the camera looks at u = 0.25: that part gets more than its share of texels
assert u[R // 2][R // 2] < 0.4, u[R // 2][R // 2]
def near_share(path):  # share of triangles with a corner in [0, 0.4]^2
    vt, n, near = [], 0, 0
    for line in open(path):
        if line.startswith("vt "):
            vt.append(tuple(map(float, line.split()[1:3])))
        elif line.startswith("f "):
            n += 1
            c = [vt[int(w.split("/")[1]) - 1] for w in line.split()[1:]]
            near += any(a < 0.4 and b < 0.4 for a, b in c)
    return near / n
warped, flat = near_share(sys.argv[2]), near_share(sys.argv[3])
assert warped > 2 * flat, (warped, flat)
EOF
fi
expect 2 "$chisel" displace "$models/plane.obj" "$svg" -o "$tmp/x.obj" --warp-dci && one_line_with "--warp-dci needs --camera"
expect 0 "$chisel" displace "$models/plane.obj" "$models/curves/steps_simple.svg" -o "$tmp/wd.obj" --target-tris 20000 \
  --res 128 --camera $cam --warp-dci && grep -q "^chisel: warp: virtual resolution" "$tmp/stderr" ||
  fail "displace --camera --warp-dci"
expect 2 "$chisel" displace "$models/plane.obj" "$svg" -o "$tmp/x.obj" --camera 1,2,3 && one_line_with "--camera expects 7"
no_file "$tmp/x.obj"
expect 2 "$chisel" displace "$models/plane.obj" "$svg" -o "$tmp/x.obj" --camera 0.5,0.5,1,0.5,0.5,1,40 &&
  one_line_with "camera"
expect 2 "$chisel" displace "$models/plane.obj" "$svg" -o "$tmp/x.obj" --camera 0.5,0.5,1,0.5,0.5,0,0 &&
  one_line_with "field of view"
expect 2 "$chisel" displace "$models/plane.obj" "$svg" -o "$tmp/x.obj" --camera 0.5,0.5,1,0.5,0.5,0,180 &&
  one_line_with "field of view"
expect 2 "$chisel" displace "$models/plane.obj" "$svg" -o "$tmp/x.obj" --camera 0.5,0.5,1,0.5,0.5,0,nan &&
  one_line_with "--camera"
no_file "$tmp/x.obj"
# looking away from the plane: a warning, and the unwarped mesh
expect 0 "$chisel" displace "$models/plane.obj" "$svg" -o "$tmp/away.obj" --target-tris 40000 \
  --camera 0.5,0.5,1,0.5,0.5,2,40 -q && one_line_with "no warp"
cmp -s "$tmp/away.obj" "$tmp/s.obj" || fail "displace --camera looking away: not the unwarped mesh"
# an output named for another format than its option writes: a warning,
# and the format the option names; an extension in capitals is the same
expect 0 "$chisel" displace "$models/plane.obj" "$svg" -o "$tmp/n.obj" --glb "$tmp/n.gltf" --target-tris 40000 -q &&
  one_line_with "--glb $tmp/n.gltf: writes binary glTF (.glb), though the name says .gltf"
checks=$((checks + 1))
[ "$(head -c 4 "$tmp/n.gltf")" = glTF ] || fail "--glb n.gltf: not binary glTF"
expect 0 "$chisel" displace "$models/plane.obj" "$svg" -o "$tmp/n.obj" --glb "$tmp/n.GLB" --ply "$tmp/n.mesh" \
  --target-tris 40000 -q
checks=$((checks + 1))
[ ! -s "$tmp/stderr" ] || fail "--glb n.GLB --ply n.mesh: a warning: $(cat "$tmp/stderr")"

# ---- info ----
# glTF base meshes: Blender's .glb of the test plane carves; chisel's own
# .glb reads back as a chisel output; broken ones are one line, exit 2
expect 0 "$chisel" displace "$tests/data/mesh/plane.glb" "$svg" -o "$tmp/g.obj" --target-tris 60000 --json &&
  python3 -c "import json,sys; d=json.load(open(sys.argv[1])); assert abs(d['triangles']-60000) <= 3000, d['triangles']" \
    "$tmp/stdout" || fail "displace plane.glb: not within 5% of the target"
expect 0 "$chisel" info "$tmp/n.GLB" && grep -q "a chisel output" "$tmp/stdout" || fail "info n.GLB: not a chisel output"
head -c 40 "$tests/data/mesh/plane.glb" >"$tmp/cut.glb"
expect 2 "$chisel" displace "$tmp/cut.glb" "$svg" -o "$tmp/x.obj" && one_line_with "cut.glb: truncated"
no_file "$tmp/x.obj"
printf '%s' '{"asset":{"version":"2.0"},"buffers":[{"byteLength":12,"uri":"gone.bin"}],"bufferViews":[{"buffer":0,' \
  '"byteLength":12}],"accessors":[{"bufferView":0,"componentType":5126,"count":1,"type":"VEC3"}],' \
  '"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}]}' >"$tmp/gone.gltf"
expect 2 "$chisel" info "$tmp/gone.gltf" && one_line_with "gone.bin"
expect 0 "$chisel" info "$svg" && grep -q "SVG curve file" "$tmp/stdout" || fail "info svg"
expect 0 "$chisel" info "$models/plane.obj" && grep -q "UV charts *1" "$tmp/stdout" || fail "info plane.obj"
expect 2 "$chisel" info "$tests/data/svg/bad/negative_width.svg" && one_line_with "negative data-width"
expect 2 "$chisel" info "$tmp/nothing.obj" && one_line_with "nothing.obj"
expect 2 "$chisel" info && one_line_with "missing FILE"

echo "$checks checks, $failures failures" >&2
[ "$failures" = 0 ]
