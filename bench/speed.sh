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
# Each of the three runs SPEED_REPEAT times (default 3), in turn, so that
# what slows the machine for a while slows all three; the table gives the
# fastest of each (the least disturbed: the ratios are between those) and,
# in brackets, the slowest. Blender's time alone moved by 30% from one run
# to the next on the team's VM.
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
# Before each timed command: no output of an earlier run is left, so none
# of the three replaces a file inside its time (Blender's was deleted
# after each run, chisel's replaced; freeing a 250 MB OBJ's pages takes
# 20-45 ms) and each starts right after one was deleted.
fresh() { rm -f "$dir/chisel.obj" "$dir/blender.obj"; }
repeat=${SPEED_REPEAT:-3}
# the smallest and the largest of the numbers on stdin, "min (max)"
span() { sort -g | sed -n '1p;$p' | paste -sd' ' | awk '{ printf "%.2f (%.2f)", $1, ($2 == "" ? $1 : $2) }'; }
have_blender=0
[ -z "${CHISEL_NO_BLENDER:-}" ] && command -v blender >/dev/null && have_blender=1
if [ $have_blender = 1 ]; then
  "$build/chisel" sample "$svg" --res 2048 -o "$dir/h.exr" 2>/dev/null
  read -r strength midlevel < <(python3 bench/blender/height_to_y.py "$dir/h.exr" "$dir/h_y.exr")
fi
echo "base $base, curves $svg, $(nproc) threads, fastest of $repeat runs (slowest)"
printf "| %-9s | %-10s | %-13s | %-10s | %-13s | %-9s | %-7s | %-13s | %-8s | %-9s | %s\n" "target" "chisel tris" "chisel s" \
  "blender tris" "blender s" "(script s)" "ratio" "no-snap s" "snap / no-snap" "B / tri (above start)" "chisel stages"
echo "|---|---|---|---|---|---|---|---|---|---|---|"
for n in "${sizes[@]}"; do
  bl_tris=$n
  rm -f "$dir/bl_s" "$dir/bl_in" "$dir/ch_s" "$dir/ns_s"
  best=
  for _ in $(seq "$repeat"); do
    if [ $have_blender = 1 ]; then
      fresh
      t0=$(now)
      line=$(blender -b --factory-startup --python bench/blender/displace.py -- "$base" "$dir/h_y.exr" \
        "$dir/blender.obj" "$n" "$strength" "$midlevel" 2>&1 | grep '^blender:')
      t1=$(now)
      echo "$t1 - $t0" | bc -l >>"$dir/bl_s"
      bl_tris=$(echo "$line" | sed 's/.*triangles \([0-9]*\).*/\1/')
      echo "$line" | sed 's/.*total \([0-9.]*\).*/\1/' >>"$dir/bl_in"
      rm -f "$dir/blender.obj"
    fi
    # chisel at Blender's count, so both make the same number of triangles
    fresh
    t0=$(now)
    "$build/chisel" displace "$base" "$svg" -o "$dir/chisel.obj" --target-tris "$bl_tris" --stats 2>"$dir/stats.txt"
    t1=$(now)
    t=$(echo "$t1 - $t0" | bc -l)
    echo "$t" >>"$dir/ch_s"
    # (the fastest run's stages)
    if [ -z "$best" ] || [ "$(echo "$t < $best" | bc -l)" = 1 ]; then
      best=$t
      cp "$dir/stats.txt" "$dir/stats_best.txt"
    fi
    # the naive mesh of the same size, no embedding: what the embedding costs
    fresh
    t0=$(now)
    "$build/chisel" displace "$base" "$svg" -o "$dir/chisel.obj" --target-tris "$bl_tris" --no-snap 2>/dev/null
    t1=$(now)
    echo "$t1 - $t0" | bc -l >>"$dir/ns_s"
  done
  ch_tris=$(grep -o 'displace [0-9]* triangles' "$dir/stats_best.txt" | grep -o '[0-9]*')
  stages=$(grep 'chisel: displace' "$dir/stats_best.txt" | sed 's/^chisel: displace [0-9]* triangles: //; s/; h in.*//')
  # the process's peak per triangle, and above what it held at start
  bytes=$(grep -o '([0-9]* bytes per triangle; [0-9]* per triangle above' "$dir/stats_best.txt" | grep -o '[0-9]*' | paste -sd/)
  ch_min=$(sort -g "$dir/ch_s" | head -1)
  ns_min=$(sort -g "$dir/ns_s" | head -1)
  ratio=nan bl_col=nan in_col=nan
  if [ $have_blender = 1 ]; then
    ratio=$(printf %.1fx "$(echo "$(sort -g "$dir/bl_s" | head -1) / $ch_min" | bc -l)")
    bl_col=$(span <"$dir/bl_s")
    in_col=$(span <"$dir/bl_in")
  fi
  printf "| %-9s | %-11s | %-13s | %-12s | %-13s | %-10s | %-7s | %-13s | %-14s | %-9s | %s\n" "$n" "$ch_tris" \
    "$(span <"$dir/ch_s")" "$bl_tris" "$bl_col" "$in_col" "$ratio" "$(span <"$dir/ns_s")" \
    "$(printf %.1fx "$(echo "$ch_min / $ns_min" | bc -l)")" "$bytes" "$stages"
  rm -f "$dir/chisel.obj" "$dir/stats.txt" "$dir/stats_best.txt" "$dir/bl_s" "$dir/bl_in" "$dir/ch_s" "$dir/ns_s"
done
