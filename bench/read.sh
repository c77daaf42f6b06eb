#!/usr/bin/env bash
# Reading large meshes: chisel's own output of tablet + glyphs at 2.1M
# triangles written as OBJ, PLY and glb, then read back by ch_mesh_read and
# checked by ch_mesh_validate (bench_mesh_read: median of 3, OBJ also through
# OpenMesh's OBJ reader as the baseline, in the same run), `chisel info` on
# the OBJ timed whole, and the --no-snap mesh of that size (whose faces all
# have UV area) as the base of `chisel displace`: --no-snap at twice the
# count and at the default target (rate 1), snapped at the default target:
# a dense base mesh, by stage, with peak memory.
# Usage: bench/read.sh [BUILD_DIR] [TRIANGLES]   (default: build 2100000)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
n=${2:-2100000}
dir=out/read
mkdir -p "$dir"
now() { date +%s.%N; }
for ext in obj ply glb; do
  "$build/chisel" displace models/tablet.obj models/curves/glyphs.svg -o "$dir/big.$ext" --target-tris "$n" -q 2>/dev/null
done
"$build/bench/bench_mesh_read" "$dir/big.obj" "$dir/big.ply" "$dir/big.glb"
t0=$(now)
"$build/chisel" info "$dir/big.obj" >/dev/null 2>&1
t1=$(now)
printf "chisel info %s: %.2f s\n" "$dir/big.obj" "$(echo "$t1 - $t0" | bc -l)"
"$build/chisel" displace models/tablet.obj models/curves/glyphs.svg -o "$dir/base.obj" --target-tris "$n" --no-snap -q \
  2>/dev/null
for mode in "--no-snap --target-tris $((2 * n))" "--no-snap" ""; do
  what=${mode:-snapped}
  [[ $mode == *--target-tris* ]] || what="$what, default target (rate 1 where the base gives more)"
  echo "dense base, $what:"
  # shellcheck disable=SC2086 # (mode is a list of options)
  "$build/chisel" displace "$dir/base.obj" models/curves/glyphs.svg -o "$dir/dense.obj" $mode --stats 2>&1 |
    grep '^chisel: displace' | sed 's/; h in \[[^]]*\]//'
done
rm -f "$dir"/big.* "$dir/base.obj" "$dir/dense.obj"
