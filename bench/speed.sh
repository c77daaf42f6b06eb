#!/usr/bin/env bash
# The speed figures: `chisel displace` from files to files at about
# 130k, 520k and 2.1M output triangles, split by stage (its --stats line),
# against Blender doing what its users do at the same triangle count
# (bench/blender/displace.py: OBJ import, subdivision, Displace modifier with
# a raster height map, OBJ export), in the same run, as a ratio. Blender's
# time is the whole `blender -b` process (start-up included: it is part of
# what a user or a CI job waits for) and, separately, its script's own
# import-to-export time. The height map Blender reads (chisel sample at
# 2048^2, converted to a Y channel) is made beforehand and not timed. Then
# chisel --no-snap at the same count (the naive mesh: what the embedding
# costs on top, as a ratio) and chisel's peak memory per output triangle.
#
# Usage: bench/speed.sh [BUILD_DIR] [BASE.obj CURVES.svg] [SIZES...]
#   default: build models/tablet.obj models/curves/glyphs.svg 130000 520000 2100000
# Needs Debian's blender package for the Blender column (skipped without it).
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
base=${2:-models/tablet.obj}
svg=${3:-models/curves/glyphs.svg}
shift 3 2>/dev/null || shift $#
sizes=("$@")
[ ${#sizes[@]} -gt 0 ] || sizes=(130000 520000 2100000)
dir=out/speed
mkdir -p "$dir"
now() { date +%s.%N; }
have_blender=0
[ -z "${CHISEL_NO_BLENDER:-}" ] && command -v blender >/dev/null && have_blender=1
if [ $have_blender = 1 ]; then
  "$build/chisel" sample "$svg" --res 2048 -o "$dir/h.exr" 2>/dev/null
  read -r strength midlevel < <(python3 bench/blender/height_to_y.py "$dir/h.exr" "$dir/h_y.exr")
fi
echo "base $base, curves $svg, $(nproc) threads"
printf "| %-9s | %-10s | %-9s | %-10s | %-9s | %-9s | %-7s | %-9s | %-8s | %-9s | %s\n" "target" "chisel tris" "chisel s" \
  "blender tris" "blender s" "(script s)" "ratio" "no-snap s" "snap / no-snap" "B / tri (above start)" "chisel stages"
echo "|---|---|---|---|---|---|---|---|---|---|---|"
for n in "${sizes[@]}"; do
  bl_tris=$n bl_s=nan bl_in=nan
  if [ $have_blender = 1 ]; then
    t0=$(now)
    line=$(blender -b --factory-startup --python bench/blender/displace.py -- "$base" "$dir/h_y.exr" \
      "$dir/blender.obj" "$n" "$strength" "$midlevel" 2>&1 | grep '^blender:')
    t1=$(now)
    bl_s=$(echo "$t1 - $t0" | bc -l)
    bl_tris=$(echo "$line" | sed 's/.*triangles \([0-9]*\).*/\1/')
    bl_in=$(echo "$line" | sed 's/.*total \([0-9.]*\).*/\1/')
    rm -f "$dir/blender.obj"
  fi
  # chisel at Blender's count, so both make the same number of triangles
  t0=$(now)
  "$build/chisel" displace "$base" "$svg" -o "$dir/chisel.obj" --target-tris "$bl_tris" --stats 2>"$dir/stats.txt"
  t1=$(now)
  ch_s=$(echo "$t1 - $t0" | bc -l)
  ch_tris=$(grep -o 'displace [0-9]* triangles' "$dir/stats.txt" | grep -o '[0-9]*')
  stages=$(grep 'chisel: displace' "$dir/stats.txt" | sed 's/^chisel: displace [0-9]* triangles: //; s/; h in.*//')
  # the process's peak per triangle, and above what it held at start
  bytes=$(grep -o '([0-9]* bytes per triangle; [0-9]* per triangle above' "$dir/stats.txt" | grep -o '[0-9]*' | paste -sd/)
  # the naive mesh of the same size, no embedding: what the embedding costs
  t0=$(now)
  "$build/chisel" displace "$base" "$svg" -o "$dir/chisel.obj" --target-tris "$bl_tris" --no-snap 2>/dev/null
  t1=$(now)
  ns_s=$(echo "$t1 - $t0" | bc -l)
  ratio=nan
  [ "$bl_s" != nan ] && ratio=$(echo "$bl_s / $ch_s" | bc -l)
  printf "| %-9s | %-11s | %-9.2f | %-12s | %-9s | %-10s | %-7s | %-9.2f | %-14s | %-9s | %s\n" "$n" "$ch_tris" "$ch_s" "$bl_tris" \
    "$(printf %.2f "$bl_s")" "$(printf %.2f "$bl_in")" "$(printf %.1fx "$ratio")" "$ns_s" \
    "$(printf %.1fx "$(echo "$ch_s / $ns_s" | bc -l)")" "$bytes" "$stages"
  rm -f "$dir/chisel.obj"
done
