# The study scene bench/grooves.sh and bench/featmap_study.sh share: the
# truth at grid 512 and these views (an orbit of four at 44 degrees, two
# grazing ones at 10 and 20 degrees above the plane, two close-ups), the
# snapped mesh at 131k first and the exact normals on the flat base last,
# so their tables compare. Source it, then:
#   study_scene CURVES.svg PLANE.obj "METHOD LINES" >scene.json
# (METHOD LINES: JSON objects, each followed by ",\n").
# Also the scripts' arguments: study_args DEFAULT_OUT [BUILD_DIR] [OUT_DIR]
# [SET ...] sets build, out and sets (every bundled curve set by default;
# $here is the repository).
study_args() {
  local default_out=$1
  shift
  build=${1:-$here/build}
  out=${2:-$default_out}
  shift $(( $# < 2 ? $# : 2 ))
  sets=("$@")
  if [ ${#sets[@]} -eq 0 ]; then
    for f in "$here"/models/curves/*.svg; do sets+=("$(basename "$f" .svg)"); done
  fi
}

study_scene() {
  local svg=$1 plane=$2 methods=$3
  cat <<JSON
{
  "curves": "$svg",
  "dci_resolution": 1024,
  "truth_grid": 512,
  "views": [
    {"name": "orbit", "eye": [0.2, -0.4, 0.9], "target": [0.5, 0.5, -0.01], "fov": 40,
     "width": 320, "height": 240, "supersample": 2, "orbit": 4},
    {"name": "graze10", "eye": [0.5, -0.288, 0.139], "target": [0.5, 0.5, 0.0], "fov": 50,
     "width": 320, "height": 240, "supersample": 2},
    {"name": "graze20", "eye": [-0.25, 0.45, 0.273], "target": [0.5, 0.45, 0.0], "fov": 50,
     "width": 320, "height": 240, "supersample": 2},
    {"name": "closeup", "eye": [0.42, 0.3, 0.14], "target": [0.5, 0.5, -0.01], "fov": 30,
     "width": 320, "height": 240, "supersample": 2},
    {"name": "closeup2", "eye": [0.66, 0.7, 0.09], "target": [0.55, 0.55, -0.01], "fov": 30,
     "width": 320, "height": 240, "supersample": 2}
  ],
  "methods": [
    {"name": "snapped131k", "mesh": "snapped.obj"},
$methods    {"name": "normals", "mesh": "$plane", "shader": "exact-normals"}
  ]
}
JSON
}
