#!/usr/bin/env bash
# The accuracy study (chisel study) on the bundled curve sets over the planar
# base (models/plane.obj): for each set, chisel's snapped mesh, the
# --no-snap mesh and a raster-displaced mesh (a uniform grid with its
# heights read bilinearly from a 2048^2 height raster: what a subdivided
# plane under a Displace modifier with a height texture gives) at the same
# triangle count, and the flat base with the exact normals (a perfect
# normal map), the texture methods of the feature-curve maps (featnorm,
# featnorm-linear, normal-bilinear: the conventional normal map of h,
# msdf) at STUDY_TEXTURE_RES (default 256),
# rendered with the Embree-traced truth from seven views (an orbit of four
# oblique ones, a grazing one, a close-up and one from straight above) by
# `chisel study`.
# usage: scripts/study.sh BUILD_DIR OUT_DIR [TRIANGLES] [SET ...]
#   BUILD_DIR  holds chisel and bench/chisel-uniform-grid (default build)
#   OUT_DIR    one folder per set (scene.json, the meshes, the study with
#              its index.html), plus summary.csv joining every set's table
#   TRIANGLES  comma-separated target triangle counts, each method made at
#              each (one family per method in the plots; default
#              25000,100000)
#   SET        curve sets of models/curves (default: all)
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$here/build}
out=${2:?usage: scripts/study.sh BUILD_DIR OUT_DIR [TRIANGLES] [SET ...]}
tris=${3:-25000,100000}
texres=${STUDY_TEXTURE_RES:-256}
shift $(( $# < 3 ? $# : 3 ))
sets=("$@")
if [ ${#sets[@]} -eq 0 ]; then
  for f in "$here"/models/curves/*.svg; do sets+=("$(basename "$f" .svg)"); done
fi
chisel=$build/chisel grid=$build/bench/chisel-uniform-grid
mkdir -p "$out"
summary=$out/summary.csv
first=1
for set in "${sets[@]}"; do
  svg=$here/models/curves/$set.svg dir=$out/$set
  mkdir -p "$dir"
  methods=""
  for n in ${tris//,/ }; do
    echo "study.sh: $set: meshes at $n triangles" >&2
    "$chisel" displace "$here/models/plane.obj" "$svg" -o "$dir/snapped_$n.obj" --target-tris "$n" 2>/dev/null
    "$chisel" displace "$here/models/plane.obj" "$svg" -o "$dir/naive_$n.obj" --target-tris "$n" --no-snap 2>/dev/null
    "$grid" "$svg" -o "$dir/raster_$n.obj" --target-tris "$n" --dci-res 1024 --raster 2048 2>/dev/null
    for m in snapped naive raster; do
      methods+="    {\"name\": \"${m}_$n\", \"family\": \"$m\", \"mesh\": \"${m}_$n.obj\"},
"
    done
  done
  # texture-space methods on the flat base at the texture resolution
  texmethods=""
  for sh in featnorm featnorm-linear normal-bilinear msdf; do
    [ -n "$texmethods" ] && texmethods+=",
"
    texmethods+="    {\"name\": \"${sh}_$texres\", \"mesh\": \"$here/models/plane.obj\", \"shader\": \"$sh\", \"resolution\": $texres}"
  done
  cat >"$dir/scene.json" <<JSON
{
  "curves": "$svg",
  "dci_resolution": 1024,
  "truth_grid": 512,
  "views": [
    {"name": "orbit", "eye": [0.2, -0.4, 0.9], "target": [0.5, 0.5, -0.01], "fov": 40,
     "width": 320, "height": 240, "supersample": 2, "orbit": 4},
    {"name": "grazing", "eye": [0.5, -0.3, 0.15], "target": [0.5, 0.5, -0.01], "fov": 50,
     "width": 320, "height": 240, "supersample": 2},
    {"name": "closeup", "eye": [0.42, 0.3, 0.14], "target": [0.5, 0.5, -0.01], "fov": 30,
     "width": 320, "height": 240, "supersample": 2},
    {"name": "top", "eye": [0.5, 0.5, 2], "target": [0.5, 0.5, 0], "up": [0, 1, 0], "ortho_height": 1,
     "width": 256, "height": 256, "supersample": 2}
  ],
  "methods": [
$methods    {"name": "normalmap", "mesh": "$here/models/plane.obj", "shader": "exact-normals"},
$texmethods
  ]
}
JSON
  rm -rf "$dir/study"
  "$chisel" study "$dir/scene.json" -o "$dir/study" >&2
  if [ $first = 1 ]; then
    { printf 'set,'; head -1 "$dir/study/summary.csv"; } >"$summary"
    first=0
  fi
  tail -n +2 "$dir/study/summary.csv" | sed "s/^/$set,/" >>"$summary"
done
echo "study.sh: wrote $summary" >&2
