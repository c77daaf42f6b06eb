#!/usr/bin/env bash
# A long libFuzzer campaign: every fuzz target in turn (one at a time: the
# machine may be shared) for RUNS executions (default 10^6), starting from
# the corpus kept in the repo (fuzz/corpus/TARGET/) and the test inputs;
# afterwards the inputs that add coverage are merged back into the kept
# corpus (files up to MAX_LEN bytes, so it stays small), and a table of the
# figures is printed (and left in build-fuzz/campaign/summary.txt).
# A crash or leak stops that target; its input is saved under
# build-fuzz/campaign/TARGET/ and the script exits 1 at the end.
#
# usage: scripts/fuzz-campaign.sh [RUNS] [TARGET...]
#   RUNS defaults to 1000000; targets default to all of them.
#   MAX_LEN (default 8192) bounds inputs and kept files; MAX_SECS (default
#   0: none) caps each target's wall time, so a slow target cannot take the
#   whole campaign; JOBS is unused on purpose: one process at a time.
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-1000000}
shift || true
targets=("$@")
all=(fuzz_svg fuzz_mesh_obj fuzz_mesh_ply fuzz_mesh_off fuzz_mesh_stl fuzz_mesh_glb fuzz_mesh_gltf fuzz_exr fuzz_dci fuzz_featmap fuzz_scene)
[ ${#targets[@]} -gt 0 ] || targets=("${all[@]}")
max_len=${MAX_LEN:-8192}
max_secs=${MAX_SECS:-0}
# (configured as scripts/fuzz-smoke.sh does)
cmake -S . -B build-fuzz -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DCMAKE_BUILD_TYPE=Debug -DCMAKE_C_FLAGS_DEBUG="-g -O1" -DCMAKE_CXX_FLAGS_DEBUG="-g -O1" \
  -DCHISEL_FUZZ=ON -DBUILD_TESTING=OFF >/dev/null
cmake --build build-fuzz -j"$(nproc)" --target "${targets[@]}" >/dev/null
# The test inputs of each target's format.
seeds_of() {
  case $1 in
  fuzz_svg) echo tests/data/svg tests/data/svg/bad ;;
  fuzz_mesh_obj) echo tests/data/mesh ;;
  fuzz_mesh_*) local d=build-fuzz/seeds/${1#fuzz_mesh_}; mkdir -p "$d"
    cp tests/data/mesh/*."${1#fuzz_mesh_}" "$d"/ 2>/dev/null || true; echo "$d" ;;
  fuzz_exr | fuzz_dci) echo tests/data/exr tests/data/dci ;;
  fuzz_featmap) echo tests/data/featmap tests/data/fuzz/fuzz_featmap ;;
  fuzz_scene) echo tests/data/study ;;
  esac
}
out=build-fuzz/campaign
mkdir -p "$out"
summary=$out/summary.txt
printf "| %-14s | %10s | %8s | %9s | %8s | %10s | %8s | %s\n" target executions seconds "exec/s" "peak MB" \
  "coverage" "corpus" result >"$summary"
echo "|---|---|---|---|---|---|---|---|" >>"$summary"
failed=0
for t in "${targets[@]}"; do
  kept=fuzz/corpus/$t work=$out/$t
  mkdir -p "$kept" "$work/corpus"
  start=$(date +%s)
  set +e
  build-fuzz/fuzz/$t -runs="$runs" -max_total_time="$max_secs" -max_len="$max_len" -timeout=30 -rss_limit_mb=4096 -print_final_stats=1 \
    -artifact_prefix="$work/" "$work/corpus" "$kept" $(seeds_of "$t") >"$work/log.txt" 2>&1
  rc=$?
  set -e
  secs=$(( $(date +%s) - start ))
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$work/log.txt" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$work/log.txt" | tail -1)
  rss=$(sed -n 's/^stat::peak_rss_mb: *//p' "$work/log.txt" | tail -1)
  cov=$(grep -o 'cov: [0-9]* ft: [0-9]*' "$work/log.txt" | tail -1 | sed 's/cov: \([0-9]*\) ft: \([0-9]*\)/\1 \/ \2/')
  result=ok
  if [ $rc -ne 0 ]; then
    result="FAILED (exit $rc, see $work/)"
    failed=1
  fi
  # Keep what adds coverage, small files only.
  mkdir -p "$work/merged"
  build-fuzz/fuzz/$t -merge=1 -max_len="$max_len" "$work/merged" "$kept" "$work/corpus" >"$work/merge.txt" 2>&1 || true
  if [ -n "$(ls -A "$work/merged")" ]; then
    rm -f "$kept"/*
    find "$work/merged" -type f -size -"$((max_len + 1))"c -exec cp {} "$kept"/ \;
  fi
  rm -rf "$work/merged"
  files=$(ls "$kept" | wc -l)
  printf "| %-14s | %10s | %8s | %9s | %8s | %10s | %8s | %s\n" "$t" "${execs:-?}" "$secs" "${rate:-?}" \
    "${rss:-?}" "${cov:-?}" "$files files" "$result" | tee -a "$summary"
done
echo
cat "$summary"
exit $failed
