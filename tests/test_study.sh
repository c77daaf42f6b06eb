#!/usr/bin/env bash
# chisel study end to end: a mesh that is the truth has no mismatch in any
# view; chisel's snapped mesh beats the --no-snap one on groove classes;
# the summary is deterministic; bad scenes give exit 2, one line naming the
# file and the problem, and leave nothing behind.
# usage: test_study.sh CHISEL DATA_DIR MODELS_DIR TMP_DIR
set -u
chisel=$1 data=$2 models=$3 tmp=$4
rm -rf "$tmp"
mkdir -p "$tmp"
failures=0 checks=0
fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }
check() { checks=$((checks + 1)); "$@" || fail "$*"; }

# 1. The box-groove mesh is the truth: every metric 0 (depth to 1e-8 of the
#    scene size: the mesh's coordinates are read as float); its report.
checks=$((checks + 1))
if "$chisel" study "$data/box_groove.json" -o "$tmp/exact" >"$tmp/stdout" 2>"$tmp/stderr"; then
  rows=$(tail -n +2 "$tmp/exact/summary.csv" | wc -l)
  check [ "$rows" = 3 ]
  bad=$(tail -n +2 "$tmp/exact/summary.csv" |
        awk -F, '$5 != 0 || $6 != 0 || $7 != 0 || $8 > 1e-8 || $10 > 1e-3 || $11 > 1e-6 || $12 < 0.999999 || $13 != 0 || $4 != 10' | wc -l)
  check [ "$bad" = 0 ]
  # Per view: truth exr/png/class.png, method exr + 4 png; and the two summaries.
  check [ "$(ls "$tmp/exact" | wc -l)" = $((3 * 9 + 3)) ]
  check grep -q '"class_mismatch_pct":	0' "$tmp/exact/summary.json"
  # The report: every image it shows exists, the table has a row per result.
  imgs=$(grep -o 'src="[^"]*"' "$tmp/exact/index.html" | sed 's/src="//; s/"$//')
  check [ "$(echo "$imgs" | wc -l)" = $((3 * 7)) ]
  for i in $imgs; do check [ -s "$tmp/exact/$i" ]; done
  check [ "$(grep -c '<tr><td class="l">' "$tmp/exact/index.html")" = 3 ]
else
  fail "study of box_groove.json failed: $(cat "$tmp/stderr")"
fi

# 1b. A box groove across a raised step plateau, seen from 0.2 above the
#    plane: its exact mesh (coordinates such as 0.58 and 0.8 are not floats,
#    so the mesh reader puts its walls up to 3e-8 off the curves) and
#    chisel's snapped mesh have the truth's classes; walls once classed by
#    probes 1e-8 apart were groove walls where the step inside the groove's
#    floor is (0.44% of the pixels seen along the groove).
checks=$((checks + 1))
"$chisel" displace "$models/plane.obj" "$data/plateaus.svg" -o "$tmp/plateaus_snapped.obj" --target-tris 30000 \
  2>/dev/null || fail "displace plateaus"
sed 's#"plateaus.svg"#"'"$data"'/plateaus.svg"#; s#"plateaus.obj"}#"'"$data"'/plateaus.obj"},\n    {"name": "snapped", "mesh": "plateaus_snapped.obj"}#' \
  "$data/plateaus.json" >"$tmp/plateaus.json"
if "$chisel" study "$tmp/plateaus.json" -o "$tmp/plateaus" >"$tmp/stdout" 2>"$tmp/stderr"; then
  check [ "$(tail -n +2 "$tmp/plateaus/summary.csv" | wc -l)" = 4 ]
  bad=$(tail -n +2 "$tmp/plateaus/summary.csv" | awk -F, '$2 == "exact" && ($5 != 0 || $7 != 0 || $8 > 1e-8 || $10 > 1e-3)' | wc -l)
  check [ "$bad" = 0 ]
  bad=$(tail -n +2 "$tmp/plateaus/summary.csv" | awk -F, '$2 == "snapped" && ($5 > 0.02 || $7 != 0)' | wc -l)
  check [ "$bad" = 0 ]
  # Both views see walls of both kinds.
  check grep -q '"groove_pixels":	[1-9]' "$tmp/plateaus/summary.json"
else
  fail "study of plateaus failed: $(cat "$tmp/stderr")"
fi

# 1c. Texture methods that move hits, on the box groove: the groove
#    texture is the truth's surface (walls, floor, shadows in texture
#    space; its curves are floats, 3e-8 off), relief mapping on a 256^2 map
#    is not; they and the normal-map methods report their bytes.
sed 's#"mesh": "box_groove.obj"}#"mesh": "box_groove.obj"},\n    {"name": "g16", "mesh": "'"$models"'/plane.obj", "shader": "grooves", "resolution": 16},\n    {"name": "r256", "mesh": "'"$models"'/plane.obj", "shader": "relief", "resolution": 256, "steps": 32},\n    {"name": "m64", "mesh": "'"$models"'/plane.obj", "shader": "msdf", "resolution": 64},\n    {"name": "n64", "mesh": "'"$models"'/plane.obj", "shader": "normal-bilinear", "resolution": 64}#; s#"box_groove.svg"#"'"$data"'/box_groove.svg"#; s#"box_groove.obj"#"'"$data"'/box_groove.obj"#' \
  "$data/box_groove.json" >"$tmp/textures.json"
checks=$((checks + 1))
if "$chisel" study "$tmp/textures.json" -o "$tmp/textures" >"$tmp/stdout" 2>"$tmp/stderr"; then
  # 16 bytes a texel: 16^2 grid texels and 43 data texels (the box
  # profile's block: header, range, 4 points in 2, room for 7 breaks in 2).
  check grep -q '^texture method g16: grooves at 16, 4784 bytes$' "$tmp/stdout"
  check grep -q '^texture method r256: relief at 256, 262144 bytes$' "$tmp/stdout"
  # The normal-map methods: 16 bytes a texel for the msdf, 12 for a normal map.
  check grep -q '^texture method m64: msdf at 64, 65536 bytes$' "$tmp/stdout"
  check grep -q '^texture method n64: normal-bilinear at 64, 49152 bytes$' "$tmp/stdout"
  bad=$(tail -n +2 "$tmp/textures/summary.csv" |
        awk -F, '$2 == "g16" && $1 != "oblique" && ($5 != 0 || $8 > 1e-7 || $10 > 0.01 || $13 != 0)' | wc -l)
  check [ "$bad" = 0 ]
  # Seen from the square's open side, rays that pass under the plane's edge
  # into the groove miss the base mesh, so no shader sees them: at most
  # those pixels (0.27%) differ.
  bad=$(tail -n +2 "$tmp/textures/summary.csv" | awk -F, '$1 == "oblique" && $2 == "g16" && ($5 > 0.3 || $13 != 0)' | wc -l)
  check [ "$bad" = 0 ]
  # Relief mapping: sloped walls a texel wide, so more class mismatch in
  # every view but the orthographic one from above.
  worse=$(awk -F, '$2 == "g16" {g[$1] = $5} $2 == "r256" {r[$1] = $5} END {n = 0; for (v in g) n += r[v] > g[v]; print n}' \
          "$tmp/textures/summary.csv")
  check [ "$worse" -ge 2 ]
else
  fail "study of texture methods failed: $(cat "$tmp/stderr")"
fi

# 2. Snapped against naive at equal triangles on the glyphs.
svg="$models/curves/glyphs.svg"
"$chisel" displace "$models/plane.obj" "$svg" -o "$tmp/snapped.obj" --target-tris 20000 2>/dev/null || fail "displace"
"$chisel" displace "$models/plane.obj" "$svg" -o "$tmp/naive.obj" --target-tris 20000 --no-snap 2>/dev/null ||
  fail "displace --no-snap"
cat >"$tmp/glyphs.json" <<JSON
{"curves": "$svg", "dci_resolution": 256, "truth_grid": 256,
 "views": [{"name": "oblique", "eye": [0.2, -0.4, 0.9], "target": [0.5, 0.5, -0.01], "width": 160, "height": 120},
           {"name": "grazing", "eye": [0.5, -0.3, 0.15], "target": [0.5, 0.5, -0.01], "fov": 50,
            "width": 160, "height": 120, "supersample": 1}],
 "methods": [{"name": "snapped", "mesh": "snapped.obj"}, {"name": "naive", "mesh": "naive.obj"},
             {"name": "normalmap", "mesh": "$models/plane.obj", "shader": "exact-normals"}]}
JSON
checks=$((checks + 1))
if "$chisel" study "$tmp/glyphs.json" -o "$tmp/glyphs" >"$tmp/stdout" 2>"$tmp/stderr"; then
  cat "$tmp/stdout" >&2
  for v in oblique grazing; do
    s=$(awk -F, -v v=$v '$1 == v && $2 == "snapped" {print $6}' "$tmp/glyphs/summary.csv")
    n=$(awk -F, -v v=$v '$1 == v && $2 == "naive" {print $6}' "$tmp/glyphs/summary.csv")
    check awk -v s="$s" -v n="$n" 'BEGIN { exit !(s != "" && n != "" && s < n) }'
    # A perfect normal map has the truth's classes where carved grooves meet
    # the surface at their rims (z = 0 both), but no depth: its depth error
    # is far above the snapped mesh's.
    s=$(awk -F, -v v=$v '$1 == v && $2 == "snapped" {print $8}' "$tmp/glyphs/summary.csv")
    p=$(awk -F, -v v=$v '$1 == v && $2 == "normalmap" {print $8}' "$tmp/glyphs/summary.csv")
    check awk -v s="$s" -v p="$p" 'BEGIN { exit !(s != "" && p != "" && 10 * s < p) }'
  done
  # Same bytes again.
  "$chisel" study "$tmp/glyphs.json" -o "$tmp/glyphs2" >/dev/null 2>&1
  check cmp -s "$tmp/glyphs/summary.csv" "$tmp/glyphs2/summary.csv"
  check cmp -s "$tmp/glyphs/grazing.naive.exr" "$tmp/glyphs2/grazing.naive.exr"
else
  fail "study of glyphs failed: $(cat "$tmp/stderr")"
fi

# An orbit: view o_0 is the given eye (the same picture as a plain view
# from there), o_1 is turned 90 degrees about the target's vertical (a
# different picture of the glyphs), five views in all.
cat >"$tmp/orbit.json" <<JSON
{"curves": "$svg", "dci_resolution": 256, "truth_grid": 256,
 "views": [{"name": "o", "eye": [0.2, -0.4, 0.9], "target": [0.5, 0.5, -0.01], "width": 64, "height": 48,
            "supersample": 1, "orbit": 4},
           {"name": "plain", "eye": [0.2, -0.4, 0.9], "target": [0.5, 0.5, -0.01], "width": 64, "height": 48,
            "supersample": 1}]}
JSON
checks=$((checks + 1))
if "$chisel" study "$tmp/orbit.json" -o "$tmp/orbit" >/dev/null 2>"$tmp/stderr"; then
  check cmp -s "$tmp/orbit/o_0.truth.png" "$tmp/orbit/plain.truth.png"
  check test -s "$tmp/orbit/o_3.truth.png"
  if cmp -s "$tmp/orbit/o_0.truth.png" "$tmp/orbit/o_1.truth.png"; then fail "orbit: o_1 is o_0"; fi
  check test ! -e "$tmp/orbit/o_4.truth.png"
else
  fail "orbit study failed: $(cat "$tmp/stderr")"
fi

# 3. Bad scenes: exit 2, one line naming the file and the problem, no output.
bad() {
  local name=$1 want=$2 body=$3
  printf '%s\n' "$body" >"$tmp/$name.json"
  checks=$((checks + 1))
  "$chisel" study "$tmp/$name.json" -o "$tmp/out_$name" >"$tmp/stdout" 2>"$tmp/stderr"
  local rc=$?
  [ "$rc" = 2 ] || fail "$name: exit $rc (want 2)"
  [ "$(wc -l <"$tmp/stderr")" = 1 ] || fail "$name: stderr is not one line: $(cat "$tmp/stderr")"
  grep -qF -- "$want" "$tmp/stderr" || fail "$name: stderr lacks '$want': $(cat "$tmp/stderr")"
  [ ! -e "$tmp/out_$name" ] || fail "$name: output folder left behind"
}
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' >"$tmp/nouv.obj"
view='{"name": "v", "eye": [0.5, -1, 1], "target": [0.5, 0.5, 0]}'
bad syntax "syntax.json: line 2: not valid JSON" $'{"curves": "x.svg",\n "views": [}'
bad nocurves 'nocurves.json: "curves"' '{"views": ['"$view"']}'
bad noviews 'noviews.json: "views"' '{"curves": "'"$svg"'", "views": []}'
bad unknown "unknown.json: views[0]: unknown key 'fovy'" \
  '{"curves": "'"$svg"'", "views": [{"name": "v", "eye": [0, 0, 1], "target": [0, 0, 0], "fovy": 3}]}'
bad eye "eye.json: views[0].eye: expected an array of 3 finite numbers" \
  '{"curves": "'"$svg"'", "views": [{"name": "v", "eye": [0, 1], "target": [0, 0, 0]}]}'
bad upview "upview.json: views[0] ('v'): camera: up is parallel" \
  '{"curves": "'"$svg"'", "views": [{"name": "v", "eye": [0.5, 0.5, 1], "target": [0.5, 0.5, 0]}]}'
bad grid "grid.json: scene.truth_grid: 100 is not a multiple of 16" \
  '{"curves": "'"$svg"'", "truth_grid": 100, "views": ['"$view"']}'
bad dupe "dupe.json: methods[1]: the name 'm' is used twice" \
  '{"curves": "'"$svg"'", "views": ['"$view"'], "methods": [{"name": "m", "mesh": "a.obj"}, {"name": "m", "mesh": "b.obj"}]}'
bad badname "badname.json: views[0]: \"name\" must be" \
  '{"curves": "'"$svg"'", "views": [{"name": "a/b", "eye": [0, 0, 1], "target": [1, 0, 0]}]}'
bad nouv "nouv.obj: the mesh has no texture coordinates" \
  '{"curves": "'"$svg"'", "views": ['"$view"'], "methods": [{"name": "m", "mesh": "nouv.obj"}]}'
bad shader "shader.json: methods[0].shader: unknown shader" \
  '{"curves": "'"$svg"'", "views": ['"$view"'], "methods": [{"name": "m", "mesh": "a.obj", "shader": "parallax"}]}'
# Texture methods: their parameters, and curves they cannot hold.
plane="$models/plane.obj"
bad nores 'nores.json: methods[0].resolution: missing (shader "grooves"' \
  '{"curves": "'"$svg"'", "views": ['"$view"'], "methods": [{"name": "g", "mesh": "'"$plane"'", "shader": "grooves"}]}'
bad nores2 'nores2.json: methods[1].resolution: missing (shader "pom"' \
  '{"curves": "'"$svg"'", "views": ['"$view"'], "methods": [{"name": "g", "mesh": "'"$plane"'", "shader": "grooves",
    "resolution": 64}, {"name": "p", "mesh": "'"$plane"'", "shader": "pom", "steps": 16}]}'
bad gres 'gres.json: methods[0].resolution: expected an integer in [1, 4096]' \
  '{"curves": "'"$svg"'", "views": ['"$view"'], "methods": [{"name": "g", "mesh": "'"$plane"'", "shader": "grooves",
    "resolution": 5000}]}'
bad rsteps 'rsteps.json: methods[0].steps: expected an integer in [1, 4096]' \
  '{"curves": "'"$svg"'", "views": ['"$view"'], "methods": [{"name": "r", "mesh": "'"$plane"'", "shader": "relief",
    "resolution": 256, "steps": 0}]}'
bad gsteps 'gsteps.json: methods[0].steps: only for "shader": "relief" or "pom"' \
  '{"curves": "'"$svg"'", "views": ['"$view"'], "methods": [{"name": "g", "mesh": "'"$plane"'", "shader": "grooves",
    "resolution": 64, "steps": 8}]}'
bad meshres 'meshres.json: methods[0].resolution: only for "shader": "grooves", "relief" or "pom"' \
  '{"curves": "'"$svg"'", "views": ['"$view"'], "methods": [{"name": "m", "mesh": "'"$plane"'", "resolution": 64}]}'
bad gsteps2 "gsteps2.json: methods[0] ('g'): $models/curves/relief.svg: <path> 'ground' (line 13): a step curve, which a groove texture cannot hold" \
  '{"curves": "'"$models/curves/relief.svg"'", "views": ['"$view"'], "methods": [{"name": "g", "mesh": "'"$plane"'",
    "shader": "grooves", "resolution": 64}]}'
bad gcell "gcell.json: methods[0] ('g'): $svg: groove texture: cell (0, 0) (u 0..1, v 0..1) is crossed by" \
  '{"curves": "'"$svg"'", "views": ['"$view"'], "methods": [{"name": "g", "mesh": "'"$plane"'",
    "shader": "grooves", "resolution": 1}]}'
bad nosvg "missing.svg" '{"curves": "missing.svg", "views": ['"$view"']}'
bad orbit0 "orbit0.json: views[0].orbit" \
  '{"curves": "'"$svg"'", "views": [{"name": "v", "eye": [0.5, -1, 1], "target": [0.5, 0.5, 0], "orbit": 0}]}'

echo "$checks checks, $failures failures" >&2
[ "$failures" = 0 ]
