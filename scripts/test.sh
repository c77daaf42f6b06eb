#!/usr/bin/env bash
# Installs what chisel needs (Debian 12), then builds and tests it four
# ways: Release with gcc (ctest, including the installed-package test),
# Release with clang (ctest), ASan+UBSan (ctest), and clang libFuzzer
# targets (a short smoke run of each). This is what CI runs.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh --fuzz
jobs=$(nproc)
start=$(date +%s)
echo "== Release build and tests"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DCHISEL_WERROR=ON >/dev/null
cmake --build build -j"$jobs"
ctest --test-dir build --output-on-failure -j"$jobs"
echo "== clang Release build and tests"
CC=clang CXX=clang++ cmake -S . -B build-clang -DCMAKE_BUILD_TYPE=Release -DCHISEL_WERROR=ON >/dev/null
cmake --build build-clang -j"$jobs"
ctest --test-dir build-clang --output-on-failure -j"$jobs"
echo "== ASan + UBSan build and tests"
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=Asan -DCHISEL_WERROR=ON >/dev/null
cmake --build build-asan -j"$jobs"
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
  ctest --test-dir build-asan --output-on-failure -j"$jobs"
echo "== libFuzzer smoke runs"
scripts/fuzz-smoke.sh "${FUZZ_SECONDS:-20}"
echo "== all tests passed in $(( $(date +%s) - start )) s"
