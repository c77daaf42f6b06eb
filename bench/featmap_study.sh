#!/usr/bin/env bash
# Feature-curve textures in the accuracy study: on every bundled curve set
# over the plane, `chisel study` with the snapped mesh at 131k triangles,
# featnorm, featnorm-linear, the conventional normal map (normal-bilinear)
# and the msdf at each R of RES (default 256), and the truth's own normals
# on the flat base (exact-normals: the best any normal-only method on the
# base can do); the views of bench/grooves.sh (an orbit of four at 44
# degrees, two grazing ones, two close-ups). Prints per set and method the
# means over the views of class mismatch (all and groove pixels), normal
# error (mean, p95, degrees) and SSIM of the shading. Bytes per texel:
# featnorm 44 (plus its fallback lists), featnorm-linear 36, the normal
# map 12, the msdf 16 (chisel featmap --stats).
# usage: [RES="256 1024"] bench/featmap_study.sh [BUILD_DIR] [OUT_DIR] [SET ...]
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
. "$here/bench/study_scene.sh"
study_args "$here/out/featmap_study" "$@"
res=${RES:-256}
chisel=$build/chisel
plane=$here/models/plane.obj
mkdir -p "$out"
for set in "${sets[@]}"; do
  svg=$here/models/curves/$set.svg dir=$out/$set
  mkdir -p "$dir"
  [ -s "$dir/snapped.obj" ] || "$chisel" displace "$plane" "$svg" -o "$dir/snapped.obj" --target-tris 131000 -q
  feat=""
  for r in $res; do
    for m in featnorm featnorm-linear normal-bilinear msdf; do
      feat+="    {\"name\": \"$m$r\", \"family\": \"$m\", \"mesh\": \"$plane\", \"shader\": \"$m\", \"resolution\": $r},
"
    done
  done
  study_scene "$svg" "$plane" "$feat" >"$dir/scene.json"
  rm -rf "$dir/study"
  echo "featmap_study.sh: $set" >&2
  "$chisel" study "$dir/scene.json" -o "$dir/study" -q >"$dir/study.txt"
done
# The table: means over the views per set and method (summary.csv).
{
  printf '%-13s %-20s %8s %8s %8s %8s %8s\n' set method class% groove% n_mean n_p95 ssim
  for set in "${sets[@]}"; do
    dir=$out/$set
    awk -v set="$set" '
      FNR == 1 { for (i = 1; i <= NF; i++) col[$i] = i; next }
      {
        m = $col["method"]; if (!(m in n)) order[++nm] = m
        n[m]++; cls[m] += $col["class_mismatch_pct"]; grv[m] += $col["class_mismatch_groove_pct"]
        nmean[m] += $col["normal_mean_deg"]; np95[m] += $col["normal_p95_deg"]; ssim[m] += $col["shade_ssim"]
      }
      END {
        for (i = 1; i <= nm; i++) {
          m = order[i]
          printf "%-13s %-20s %8.4f %8.4f %8.3f %8.3f %8.5f\n", set, m, cls[m] / n[m], grv[m] / n[m], nmean[m] / n[m], np95[m] / n[m], ssim[m] / n[m]
        }
      }' FS=',' "$dir/study/summary.csv"
  done
} | tee "$out/table.txt"
