#!/usr/bin/env bash
# Builds the libFuzzer targets with clang and runs each for a few seconds on
# its seed corpus (the test inputs). usage: fuzz-smoke.sh [SECONDS]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-20}
cmake -S . -B build-fuzz -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DCMAKE_BUILD_TYPE=Debug -DCHISEL_FUZZ=ON -DBUILD_TESTING=OFF >/dev/null
cmake --build build-fuzz -j"$(nproc)" --target fuzz_svg fuzz_mesh_obj fuzz_exr fuzz_dci
run() {
  local target=$1 seeds=$2
  local corpus=build-fuzz/corpus/$target
  mkdir -p "$corpus"
  echo "-- $target: ${seconds}s from $seeds"
  build-fuzz/fuzz/$target -max_total_time="$seconds" -max_len=65536 -rss_limit_mb=4096 \
    -print_final_stats=1 "$corpus" "$seeds" 2>&1 | tail -n 4
}
run fuzz_svg tests/data/svg
run fuzz_mesh_obj tests/data/mesh
run fuzz_exr tests/data/exr
run fuzz_dci tests/data/dci
