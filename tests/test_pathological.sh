#!/usr/bin/env bash
# Pathological curve sets at a size CI affords (Release and ASan builds):
# many small closed step loops, many grooves through one point, a long
# path, a large SVG. Each run ends with exit 0 and a mesh `chisel info`
# reads, manifold (but where step loops cross each other: a known limit of
# the cut at crossing walls, as before these sets ran at all). Speed is
# bench/pathological.sh's business: nothing here is timed.
# usage: test_pathological.sh CHISEL PROJECT_DIR TMP_DIR
set -u
chisel=$1 root=$2 tmp=$3
rm -rf "$tmp"
mkdir -p "$tmp"
failures=0 checks=0
fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }
gen() { python3 "$root/bench/pathological.py" "$@"; }
gen loops 300 "$tmp/loops.svg"
gen crossing 100 "$tmp/crossing.svg"
gen path 20000 "$tmp/path.svg"
gen bigpath 700000 "$tmp/big.svg"
for case in loops crossing path; do
  checks=$((checks + 1))
  if ! OMP_NUM_THREADS=2 "$chisel" displace "$root/models/plane.obj" "$tmp/$case.svg" -o "$tmp/$case.obj" \
    --target-tris 20000 2>"$tmp/err.txt"; then
    fail "$case: $(cat "$tmp/err.txt")"
    continue
  fi
  checks=$((checks + 1))
  "$chisel" info "$tmp/$case.obj" >"$tmp/info.txt" 2>&1 || fail "$case: chisel info failed"
  [ $case = loops ] && continue
  checks=$((checks + 1))
  grep -q "edges *[0-9]* boundary, 0 non-manifold; 0 non-manifold vertices" "$tmp/info.txt" ||
    fail "$case: not manifold: $(grep edges "$tmp/info.txt")"
done
# The nearest step curve of a label (the many loops' case: the step
# hints' first bounds, then the tree) is the same on any thread: the bytes
# of 1 and 2 threads agree.
checks=$((checks + 1))
if OMP_NUM_THREADS=1 "$chisel" displace "$root/models/plane.obj" "$tmp/loops.svg" -o "$tmp/loops1.obj" \
  --target-tris 20000 2>"$tmp/err.txt"; then
  cmp -s "$tmp/loops.obj" "$tmp/loops1.obj" || fail "loops: 1 and 2 threads differ"
else
  fail "loops, one thread: $(cat "$tmp/err.txt")"
fi
# The embedding's cap (--max-tris): the loops need about 7k triangles at
# the plane's fewest base (512), so a cap of 6k stops every run: exit 2,
# one line naming the curve file and the cap, and the output from before
# left as it was; a cap no run of the count model's search reaches changes
# nothing (the same bytes as without one); one that stops a search run
# leaves a run under it.
checks=$((checks + 1))
echo "kept" >"$tmp/capped.obj"
"$chisel" displace "$root/models/plane.obj" "$tmp/loops.svg" -o "$tmp/capped.obj" --target-tris 5000 \
  --max-tris 6000 >"$tmp/out.txt" 2>"$tmp/err.txt"
rc=$?
[ $rc = 2 ] || fail "over the cap: exit $rc, not 2"
[ "$(wc -l <"$tmp/err.txt")" = 1 ] && grep -q "loops.svg: .*need more than 6000 triangles" "$tmp/err.txt" ||
  fail "over the cap: not one line naming the file and the cap: $(cat "$tmp/err.txt")"
[ "$(cat "$tmp/capped.obj")" = kept ] || fail "over the cap: the previous output was touched"
checks=$((checks + 1))
if OMP_NUM_THREADS=2 "$chisel" displace "$root/models/plane.obj" "$tmp/loops.svg" -o "$tmp/capped.obj" \
  --target-tris 20000 --max-tris 1000000 2>"$tmp/err.txt"; then
  cmp -s "$tmp/loops.obj" "$tmp/capped.obj" || fail "a cap above the need changed the mesh"
else
  fail "under the cap: $(cat "$tmp/err.txt")"
fi
checks=$((checks + 1))
if "$chisel" displace "$root/models/plane.obj" "$tmp/loops.svg" -o "$tmp/capped.obj" --target-tris 20000 \
  --max-tris 21000 2>"$tmp/err.txt"; then
  faces=$(grep -c "^f " "$tmp/capped.obj")
  [ "$faces" -le 21000 ] && [ "$faces" -gt 5000 ] || fail "a search run over the cap: $faces triangles"
else
  fail "a search run over the cap: $(cat "$tmp/err.txt")"
fi
# more than libxml2's 10 MB in one attribute, within chisel's 256 MB
checks=$((checks + 1))
[ "$(stat -c %s "$tmp/big.svg")" -gt 10485760 ] || fail "big.svg is not over 10 MB"
checks=$((checks + 1))
"$chisel" info "$tmp/big.svg" >"$tmp/info.txt" 2>"$tmp/err.txt" && grep -q "segments *700000" "$tmp/info.txt" ||
  fail "a 700000-segment path: $(cat "$tmp/err.txt")"
checks=$((checks + 1))
[ -z "$(find "$tmp" -name '*.tmp.*')" ] || fail "temporaries left"
echo "$checks checks, $failures failures" >&2
[ "$failures" = 0 ]
