#!/usr/bin/env bash
# Installs what chisel needs (Debian 12), builds it, and runs it on a
# bundled example, writing the results under out/.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$(nproc)"
mkdir -p out
set -x
build/chisel info models/curves/glyphs.svg
build/chisel sample models/curves/glyphs.svg --res 1024 -o out/glyphs_h.exr --png out/glyphs_h.png
