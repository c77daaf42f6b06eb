#!/usr/bin/env bash
# Runs chisel on every bundled case (snapped, --no-snap and warped) and
# prints one checksum per output file, so a refactoring can show it changed
# no byte:
#
#   scripts/same-bytes.sh build/chisel > before.txt   # on the old commit
#   scripts/same-bytes.sh build/chisel > after.txt    # on the new one
#   diff before.txt after.txt && echo same bytes
#
# Usage: scripts/same-bytes.sh CHISEL [SCRATCH]   (about a minute on 2 cores)
set -euo pipefail
chisel=$(realpath "$1")
src=$(cd "$(dirname "$0")/.." && pwd)
scratch=${2:-$(mktemp -d)}
mkdir -p "$scratch"
m=$src/models
c=$m/curves
n=60000
cd "$scratch"
run() { # run NAME ARGS...
  local name=$1
  shift
  "$chisel" displace -q "$@" -o "$name.obj" --ply "$name.ply" >/dev/null
  for f in "$name".*; do echo "$(sha256sum <"$f" | cut -c1-16)  $f"; done
}
for set in steps_simple relief bricks star frame spiral panels ornament glyphs; do
  run "plane_$set" "$m/plane.obj" "$c/$set.svg" --target-tris $n
  run "plane_${set}_nosnap" "$m/plane.obj" "$c/$set.svg" --target-tris $n --no-snap
done
run tablet_glyphs "$m/tablet.obj" "$c/glyphs.svg" --target-tris $n --exr tablet_glyphs.exr
run tablet_glyphs_nosnap "$m/tablet.obj" "$c/glyphs.svg" --target-tris $n --no-snap
run tablet_glyphs_warped "$m/tablet.obj" "$c/glyphs.svg" --target-tris $n \
  --camera -0.1,0.1,0.35,-0.15,-0.1,0.06,40 --exr tablet_glyphs_warped.exr
run tablet_glyphs_warped_dci "$m/tablet.obj" "$c/glyphs.svg" --target-tris $n \
  --camera -0.1,0.1,0.35,-0.15,-0.1,0.06,40 --warp-dci
run plane_steps_warped "$m/plane.obj" "$c/steps_simple.svg" --target-tris $n \
  --camera 0.3,-0.4,0.5,0.5,0.5,0,40
run vase_ornament "$m/vase.obj" "$c/ornament.svg" --target-tris $n --scheme catmark
run vase_ornament_nosnap "$m/vase.obj" "$c/ornament.svg" --target-tris $n --scheme catmark --no-snap
run torus_spiral "$m/torus.obj" "$c/spiral.svg" --target-tris $n --scheme catmark
run obelisk_panels "$m/obelisk.obj" "$c/panels.svg" --target-tris $n
run obelisk_relief "$m/obelisk.obj" "$c/relief.svg" --target-tris $n --snap-to recon5
run plane_relief_recon3 "$m/plane.obj" "$c/relief.svg" --target-tris $n --snap-to recon3
