#!/usr/bin/env bash
# Groove visibility from textures against the truth: on every bundled curve
# set over the plane, `chisel study` with the snapped mesh at 131k
# triangles, the path-based groove textures at G = 64/128/256 (and at 128
# as the paper intersects curved elements), relief mapping and parallax
# occlusion mapping at R = 512/1024/2048/4096 with 32 steps, and the exact
# normals on the flat base; views: an orbit of four at 44 degrees, two
# grazing ones (10 and 20 degrees above the plane), two close-ups. Prints
# per set and method the means over the views (and over the grazing ones)
# of class mismatch (all and groove pixels), shadow mismatch, depth and
# normal error, SSIM, the textures' bytes and the rate in Mrays/s (primary
# plus shadow rays, 2 cores unless OMP_NUM_THREADS says otherwise), then
# the targets per set (grooves' class mismatch at most 2x the snapped
# mesh's and 10x below relief mapping's at the next memory up, README).
# usage: bench/grooves.sh [BUILD_DIR] [OUT_DIR] [SET ...]
# CHISEL_REUSE_STUDY=1 keeps a set's study already in OUT_DIR and only
# tabulates it again.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
. "$here/bench/study_scene.sh"
study_args "$here/out/grooves" "$@"
chisel=$build/chisel silhouette=$build/bench/chisel-silhouette
plane=$here/models/plane.obj
mkdir -p "$out"
for set in "${sets[@]}"; do
  svg=$here/models/curves/$set.svg dir=$out/$set
  mkdir -p "$dir"
  [ -s "$dir/snapped.obj" ] || "$chisel" displace "$plane" "$svg" -o "$dir/snapped.obj" --target-tris 131000 2>/dev/null
  # A groove texture cannot hold step curves: those sets have no grooves rows.
  grooves=""
  if ! grep -q 'data-kind="step"' "$svg"; then
    for g in 64 128 256; do
      grooves+="    {\"name\": \"grooves$g\", \"family\": \"grooves\", \"mesh\": \"$plane\", \"shader\": \"grooves\", \"resolution\": $g},
"
    done
    grooves+="    {\"name\": \"paper128\", \"mesh\": \"$plane\", \"shader\": \"grooves\", \"resolution\": 128, \"paper\": true},
"
  fi
  relief=""
  for r in 512 1024 2048 4096; do
    for m in relief pom; do
      relief+="    {\"name\": \"$m$r\", \"family\": \"$m\", \"mesh\": \"$plane\", \"shader\": \"$m\", \"resolution\": $r, \"steps\": 32},
"
    done
  done
  study_scene "$svg" "$plane" "$grooves$relief" >"$dir/scene.json"
  if [ -n "${CHISEL_REUSE_STUDY:-}" ] && [ -s "$dir/study/summary.csv" ]; then
    echo "grooves.sh: $set (the study already there)" >&2
  else
    rm -rf "$dir/study"
    echo "grooves.sh: $set" >&2
    "$chisel" study "$dir/scene.json" -o "$dir/study" >"$dir/study.txt"
  fi
  # Per view and method: class mismatch without the pixels no per-pixel
  # method on the base can see (rays passing the base's outline).
  for f in "$dir"/study/*.exr; do
    case $f in *.truth.exr) continue ;; esac
    b=$(basename "$f" .exr) v=${b%%.*} m=${b#*.}
    echo "$v $m $("$silhouette" "$dir/study/$v.truth.exr" "$f")"
  done >"$dir/silhouette.txt"
done
# The table: means over views per set and method, from summary.csv (metrics)
# and study.txt (bytes, Mrays/s).
for set in "${sets[@]}"; do
  dir=$out/$set
  awk -v set="$set" '
    FNR == 1 { file++ }
    file == 1 && /^texture method / { sub(":", "", $3); bytes[$3] = $(NF - 1) }
    file == 1 && NF == 12 && $1 != "view" { rate[$2] += $12; nr[$2]++ }
    file == 2 { inside[$2] += $5; ishadow[$2] += $7; nin[$2]++; if ($1 ~ /^graze/) { ginside[$2] += $5; gishadow[$2] += $7; ngin[$2]++ } }
    file == 3 && FNR > 1 {
      split($0, f, ",");
      m = f[2]; if (!(m in n)) order[++nm] = m;
      n[m]++; cls[m] += f[5]; grv[m] += f[6]; dep[m] += f[8]; p95[m] += f[10]; ssim[m] += f[12]; sh[m] += f[13];
      if (f[1] ~ /^graze/) { ng[m]++; gcls[m] += f[5]; ggrv[m] += f[6]; gsh[m] += f[13] }
    }
    END {
      for (i = 1; i <= nm; i++) {
        m = order[i];
        printf "%-13s %-12s %10s %8.4f %8.4f %8.3f %8.4f %9.2e %7.2f %8.5f | %8.4f %8.4f %8.3f %8.4f | %6.2f | %8.4f %8.4f\n", set, m,
               (m in bytes) ? bytes[m] : "-", cls[m] / n[m], nin[m] ? inside[m] / nin[m] : 0, grv[m] / n[m], sh[m] / n[m],
               dep[m] / n[m], p95[m] / n[m], ssim[m] / n[m], gcls[m] / ng[m], ngin[m] ? ginside[m] / ngin[m] : 0,
               ggrv[m] / ng[m], gsh[m] / ng[m], nr[m] ? rate[m] / nr[m] : 0, nin[m] ? ishadow[m] / nin[m] : 0,
               ngin[m] ? gishadow[m] / ngin[m] : 0
      }
    }' "$dir/study.txt" "$dir/silhouette.txt" "$dir/study/summary.csv"
done >"$out/table.txt"
{
  printf '%-13s %-12s %10s %8s %8s %8s %8s %9s %7s %8s | %8s %8s %8s %8s | %6s | %8s %8s\n' set method bytes class% inside% \
    groove% shadow% depth n_p95 ssim class% inside% groove% shadow% Mrays/s shadow% shadow%
  printf '%-13s %-12s %10s %8s %8s %8s %8s %9s %7s %8s | %8s %8s %8s %8s | %6s | %8s %8s\n' "" "" "" "(all" "" views ")" "" "" "" \
    "(grazing" "" views ")" "" "(inside:" "grazing)"
  cat "$out/table.txt"
} | tee "$out/table_with_header.txt"
# Targets: grooves' class mismatch at most 2x the snapped mesh's and 10x
# below relief's at the next memory up (all views and grazing ones), and
# the same for shadows; grooves' rate against the mesh's.
echo
echo "targets (grooves G vs snapped131k, and vs relief at the smallest R with at least G's bytes):"
awk '
  { m = $2; set = $1; key = set SUBSEP m; b[key] = $3; c[key] = $4; in_[key] = $5; s[key] = $7; gc[key] = $12
    gin[key] = $13; gs[key] = $15; r[key] = $17; insh[key] = $19; sets[set] = 1 }
  function verdict(x) { return x ? "met" : "NOT met" }
  END {
    for (set in sets)
      for (G = 64; G <= 256; G *= 2) {
        g = set SUBSEP "grooves" G; if (!(g in b)) continue; sn = set SUBSEP "snapped131k";
        rel = ""; for (R = 512; R <= 4096; R *= 2) { k = set SUBSEP "relief" R; if (rel == "" && (k in b) && b[k] + 0 >= b[g] + 0) rel = k }
        if (rel == "") rel = set SUBSEP "relief4096";
        split(rel, rr, SUBSEP);
        printf "%-12s G=%-3d class %.4f%% (inside the base %.4f%%) vs snapped %.4f%%: %s (inside: %s); vs %s %.4f%%: %s; grazing %.4f%% (inside %.4f%%) vs %.4f%% / %.4f%%: %s (inside: %s), %s; shadow %.4f%% (inside %.4f%%) vs %.4f%% / %.4f%%: %s (inside: %s), %s; rate %.2fx the mesh\n",
               rr[1], G, c[g], in_[g], c[sn], verdict(c[g] <= 2 * c[sn] + 1e-9), verdict(in_[g] <= 2 * in_[sn] + 1e-9), rr[2], c[rel],
               verdict(10 * c[g] <= c[rel]), gc[g], gin[g], gc[sn], gc[rel], verdict(gc[g] <= 2 * gc[sn] + 1e-9),
               verdict(gin[g] <= 2 * gin[sn] + 1e-9), verdict(10 * gc[g] <= gc[rel]),
               s[g], insh[g], s[sn], s[rel], verdict(s[g] <= 2 * s[sn] + 1e-9), verdict(insh[g] <= 2 * insh[sn] + 1e-9),
               verdict(10 * s[g] <= s[rel]), (r[sn] > 0 ? r[g] / r[sn] : 0)
      }
  }' "$out/table.txt" | sort
