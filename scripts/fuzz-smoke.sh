#!/usr/bin/env bash
# Builds the libFuzzer targets with clang and runs each for a few seconds on
# its seed corpus (the test inputs, and the corpus scripts/fuzz-campaign.sh
# keeps in fuzz/corpus/TARGET). usage: fuzz-smoke.sh [SECONDS]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-20}
# (-O1: libFuzzer's advice; at -O0 the sanitizers make some inputs 100x slower)
cmake -S . -B build-fuzz -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DCMAKE_BUILD_TYPE=Debug -DCMAKE_C_FLAGS_DEBUG="-g -O1" -DCMAKE_CXX_FLAGS_DEBUG="-g -O1" \
  -DCHISEL_FUZZ=ON -DBUILD_TESTING=OFF >/dev/null
cmake --build build-fuzz -j"$(nproc)" --target fuzz_svg fuzz_mesh_obj fuzz_mesh_ply fuzz_mesh_off fuzz_mesh_stl fuzz_mesh_glb fuzz_mesh_gltf \
  fuzz_exr fuzz_dci fuzz_featmap
run() {
  local target=$1 seeds=$2 secs=${3:-$seconds}
  local corpus=build-fuzz/corpus/$target
  mkdir -p "$corpus"
  local kept=()
  [ -d "fuzz/corpus/$target" ] && kept=("fuzz/corpus/$target")
  echo "-- $target: ${secs}s from $seeds ${kept[*]}"
  build-fuzz/fuzz/$target -max_total_time="$secs" -max_len=65536 -rss_limit_mb=4096 \
    -print_final_stats=1 "$corpus" "$seeds" "${kept[@]}" 2>&1 | tail -n 4
}
# Seeds per format: the test meshes of that format (and the others: bytes
# of another format are malformed input too).
mesh_seeds() {
  local dir=build-fuzz/seeds/$1
  mkdir -p "$dir"
  cp tests/data/mesh/*."$1" "$dir"/ 2>/dev/null || true
  echo "$dir"
}
run fuzz_svg tests/data/svg
run fuzz_mesh_obj tests/data/mesh
for format in ply off stl glb gltf; do
  run fuzz_mesh_$format "$(mesh_seeds $format)" $(( (seconds + 1) / 2 ))
done
run fuzz_exr tests/data/exr
run fuzz_dci tests/data/dci
run fuzz_featmap tests/data/featmap
# The study's scene file, from the test scenes.
cmake --build build-fuzz -j"$(nproc)" --target fuzz_scene
run fuzz_scene tests/data/study
# chisel-accuracy's OBJ reader, from the test meshes.
cmake --build build-fuzz -j"$(nproc)" --target fuzz_accuracy_obj
run fuzz_accuracy_obj "$(mesh_seeds obj)" $(( (seconds + 1) / 2 ))
