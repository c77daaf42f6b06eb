#!/usr/bin/env bash
# chisel featmap and chisel magnify on feature maps, end to end: exit
# statuses (docs/spec.md §5), one-line messages naming the file and the problem, no
# output on failure, the same bytes on 1 and 2 threads, and the crop's
# values read back by an independent EXR reader against a straight groove's
# normal in closed form (tools/check_featmap.py).
# usage: test_featmap_cli.sh CHISEL TESTS_DIR MODELS_DIR TMP_DIR [PYTHON]
set -u
chisel=$1 tests=$2 models=$3 tmp=$4 python=${5:-python3}
rm -rf "$tmp"
mkdir -p "$tmp"
failures=0 checks=0

fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }
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
  ls "$(dirname "$1")" | grep -q '\.tmp\.' && fail "temporary file left in $(dirname "$1")"
}

svg=$models/curves/glyphs.svg
maps=$tmp/maps.exr
# ---- usage ----
expect 0 "$chisel" featmap --help && grep -q "usage: chisel featmap" "$tmp/stdout" || fail "featmap --help"
expect 0 "$chisel" --help && grep -q "featmap" "$tmp/stdout" || fail "--help lists no featmap"
expect 0 "$chisel" magnify --help && grep -q "featnorm-linear" "$tmp/stdout" || fail "magnify --help"
expect 2 "$chisel" featmap && one_line_with "missing the curve file"
expect 2 "$chisel" featmap "$svg" -o "$maps" && one_line_with "missing --res"
expect 2 "$chisel" featmap "$svg" --res 16 && one_line_with "missing -o"
expect 2 "$chisel" featmap "$svg" --res 3 -o "$maps" && one_line_with "--res 3 is outside 4..4096"
expect 2 "$chisel" featmap "$svg" --res 4097 -o "$maps" && one_line_with "--res 4097 is outside 4..4096"
expect 2 "$chisel" featmap "$svg" --res 16 -o "$svg" && one_line_with "an output never replaces an input"
expect 2 "$chisel" featmap "$svg" --res 16 -o "$maps" --rect 0.5,0,0.2,1 && one_line_with "--rect needs"
expect 2 "$chisel" featmap "$svg" --res 16 -o "$maps" --frob && one_line_with "unknown option '--frob'"
no_file "$maps"
# ---- bad curve files: every malformed SVG, and curves with nothing to encode ----
for bad in "$tests"/data/svg/bad/*.svg; do
  expect 2 "$chisel" featmap "$bad" --res 8 -o "$maps" --png "$tmp/p.png" && one_line_with "$(basename "$bad")"
  no_file "$maps"
  no_file "$tmp/p.png"
done
cat >"$tmp/blurred.svg" <<'SVG'
<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100">
  <circle cx="50" cy="50" r="20" data-kind="step" data-left="0.01" data-blur="3"/>
</svg>
SVG
expect 2 "$chisel" featmap "$tmp/blurred.svg" --res 16 -o "$maps" && one_line_with "no curve to encode"
no_file "$maps"

# ---- a real run: the same bytes on 1 and 2 threads ----
expect 0 "$chisel" featmap "$svg" --res 48 -o "$maps" --png "$tmp/maps.png" --stats &&
  grep -q "bytes per texel" "$tmp/stderr" || fail "featmap --stats"
[ -s "$maps" ] && [ -s "$tmp/maps.png" ] || fail "featmap wrote no EXR / PNG"
OMP_NUM_THREADS=1 "$chisel" featmap "$svg" --res 48 -o "$tmp/maps1.exr" --png "$tmp/maps1.png" 2>/dev/null
OMP_NUM_THREADS=2 "$chisel" featmap "$svg" --res 48 -o "$tmp/maps2.exr" --png "$tmp/maps2.png" 2>/dev/null
checks=$((checks + 1))
cmp -s "$tmp/maps1.exr" "$tmp/maps2.exr" && cmp -s "$tmp/maps1.png" "$tmp/maps2.png" &&
  cmp -s "$tmp/maps1.exr" "$maps" || fail "featmap: different bytes on 1 and 2 threads"
# a groove crossing no lattice line (a ring inside one cell), first in the
# file: its pieces come before any crossing is listed (UBSan once stopped
# at sorting that empty list)
cat >"$tmp/ring.svg" <<'SVG'
<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100">
  <circle cx="53" cy="53" r="1.5" data-kind="groove" data-width="0.5" data-depth="0.01" data-profile="u"/>
  <path d="M 10 20 L 90 70" data-kind="groove" data-width="2" data-depth="0.01" data-profile="v"/>
</svg>
SVG
expect 0 "$chisel" featmap "$tmp/ring.svg" --res 16 -o "$tmp/ring.exr" && [ -s "$tmp/ring.exr" ] ||
  fail "featmap of a ring inside one cell"
steps=$models/curves/steps_simple.svg
expect 0 "$chisel" featmap "$steps" --res 32 --dci-res 128 -o "$tmp/steps.exr" --linear --no-fallback ||
  fail "featmap of step curves"

# ---- magnify: every method, pictures and values ----
for m in featnorm featnorm-linear normal-bilinear msdf; do
  expect 0 "$chisel" magnify "$maps" --rect 0.45,0.3,0.51,0.36 --out-res 48 --method $m -o "$tmp/crop_$m.png" \
    --exr "$tmp/crop_$m.exr" || fail "magnify --method $m"
  [ -s "$tmp/crop_$m.png" ] && [ -s "$tmp/crop_$m.exr" ] || fail "magnify --method $m wrote no PNG / EXR"
done
expect 0 "$chisel" magnify "$maps" --rect 0.45,0.3,0.51,0.36 --out-res 48 -o "$tmp/crop.exr" --method featnorm &&
  cmp -s "$tmp/crop.exr" "$tmp/crop_featnorm.exr" || fail "magnify -o CROP.exr: not the same values as --exr"
dci=$tmp/dci.exr
"$chisel" dci "$steps" --res 16 -o "$dci" 2>/dev/null
expect 2 "$chisel" magnify "$dci" --rect 0,0,1,1 --out-res 8 --method featnorm -o "$tmp/m.png" &&
  one_line_with "not a feature map"
no_file "$tmp/m.png"
expect 2 "$chisel" magnify "$maps" --rect 0,0,1,1 --out-res 8 --method recon5 -o "$tmp/m.png" &&
  one_line_with "$maps"
no_file "$tmp/m.png"
size=$(wc -c <"$maps")
for cut in 100 $((size / 3)) $((size - 40)); do
  head -c "$cut" "$maps" >"$tmp/cut.exr"
  expect 2 "$chisel" magnify "$tmp/cut.exr" --rect 0,0,1,1 --out-res 8 --method featnorm -o "$tmp/m.png" &&
    one_line_with "cut.exr"
  no_file "$tmp/m.png"
done
expect 2 "$chisel" magnify "$maps" --rect 0,0,1,1 --out-res 8 --method featnorm -o "$maps" && one_line_with "an output never replaces an input"

# ---- the crop's values against a straight groove in closed form ----
if command -v "$python" >/dev/null; then
  checks=$((checks + 1))
  "$python" "$tests/tools/check_featmap.py" "$chisel" "$tmp/values" || fail "check_featmap.py"
fi
echo "$checks checks, $failures failures" >&2
[ "$failures" = 0 ]
