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
build/chisel info models/tablet.obj models/tablet_glyphs.svg
# The main job: the glyphs carved into the tablet's front, walls and creases on the curves
# (tablet_glyphs.svg is glyphs.svg laid out on the front's UV chart).
build/chisel displace models/tablet.obj models/tablet_glyphs.svg -o out/tablet_glyphs.obj \
  --exr out/tablet_glyphs.exr --png out/tablet_glyphs.png --stats
build/chisel info out/tablet_glyphs.obj
# The same seen from close by a camera (--camera): triangles and the maps' texels move to what it sees;
# the PNG shows h in warped UV, the glyphs near the camera magnified.
build/chisel displace models/tablet.obj models/tablet_glyphs.svg -o out/tablet_glyphs_close.obj --target-tris 130000 \
  --camera -0.25,0.1,0.35,-0.3,-0.1,0.06,40 --png out/tablet_glyphs_close.png
