#!/usr/bin/env bash
# The accuracy figures (bench/accuracy.h): for every bundled curve set
# over the planar base, at about 130k, 520k and 2.1M triangles, the
# snapped mesh (chisel displace; for sets with step curves also --snap-to
# recon5, walls on the curves reconstructed from the DCI), the naive mesh
# (--no-snap) and the uniform grid with exact vertex heights
# (chisel-uniform-grid) and, where Debian's blender is installed,
# Blender's Subdivision Surface + Displace with a 2048^2 raster height map
# (bench/blender/displace.py), measured by chisel-accuracy on a
# 2048^2 grid (L1, band, normal error near features, holes).
#
# Usage: bench/accuracy.sh [BUILD_DIR] [SIZES...]   (default: build 130000 520000 2100000)
# Prints a markdown table and writes it, with the JSON lines, under out/accuracy/.
# CHISEL_NO_BLENDER=1 leaves Blender out even where it is installed.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
shift || true
sizes=("$@")
[ ${#sizes[@]} -gt 0 ] || sizes=(130000 520000 2100000)
res=2048 # DCI resolution for both the meshes and the reference
dir=out/accuracy
mkdir -p "$dir"
json="$dir/accuracy.jsonl"
: >"$json"
have_blender=0
[ -z "${CHISEL_NO_BLENDER:-}" ] && command -v blender >/dev/null && have_blender=1
for svg in models/curves/*.svg; do
  name=$(basename "$svg" .svg)
  if [ $have_blender = 1 ]; then
    "$build/chisel" sample "$svg" --res $res -o "$dir/$name-h.exr" 2>/dev/null
    read -r strength midlevel < <(python3 bench/blender/height_to_y.py "$dir/$name-h.exr" "$dir/$name-hy.exr")
  fi
  for n in "${sizes[@]}"; do
    meshes=("$dir/$name-$n-snap.obj" "$dir/$name-$n-naive.obj" "$dir/$name-$n-grid.obj")
    if grep -q 'data-kind="step"' "$svg"; then # walls on the reconstructed curves too
      "$build/chisel" displace models/plane.obj "$svg" -o "$dir/$name-$n-recon5.obj" --target-tris "$n" --res $res \
        --snap-to recon5 2>/dev/null
      meshes+=("$dir/$name-$n-recon5.obj")
    fi
    if [ $have_blender = 1 ]; then
      blender -b --factory-startup --python bench/blender/displace.py -- models/plane.obj "$dir/$name-hy.exr" \
        "$dir/$name-$n-blender.obj" "$n" "$strength" "$midlevel" >/dev/null 2>&1
      meshes+=("$dir/$name-$n-blender.obj")
    fi
    "$build/chisel" displace models/plane.obj "$svg" -o "$dir/$name-$n-snap.obj" --target-tris "$n" --res $res \
      2>/dev/null
    "$build/chisel" displace models/plane.obj "$svg" -o "$dir/$name-$n-naive.obj" --target-tris "$n" --res $res \
      --no-snap 2>/dev/null
    "$build/bench/chisel-uniform-grid" "$svg" -o "$dir/$name-$n-grid.obj" --target-tris "$n" --dci-res $res \
      2>/dev/null
    "$build/bench/chisel-accuracy" "${meshes[@]}" "$svg" --dci-res $res --json >>"$json"
    rm -f "$dir/$name-$n-"*.obj
    echo "accuracy: $name $n done" >&2
  done
  rm -f "$dir/$name-h.exr" "$dir/$name-hy.exr"
done
python3 - "$json" <<'EOF' | tee "$dir/accuracy.md"
import json, sys, os
rows = [json.loads(l) for l in open(sys.argv[1])]
def key(r):
    b = os.path.basename(r["mesh"])[:-4]
    name, n, method = b.rsplit("-", 2)
    return name, int(n), method
table = {}
for r in rows:
    table[key(r)] = r
names = sorted({k[0] for k in table})
sizes = sorted({k[1] for k in table})
print("| curves | size | method | triangles | L1 | L1 / grid | band | normal mean | normal p95 | shading p95 | holes |")
print("|---|---|---|---|---|---|---|---|---|---|---|")
for name in names:
    for n in sizes:
        grid = table.get((name, n, "grid"))
        for method in ("snap", "recon5", "naive", "grid", "blender"):
            r = table.get((name, n, method))
            if not r:
                continue
            ratio = r["l1"] / grid["l1"] if grid and grid["l1"] > 0 else float("nan")
            shading = r.get("shading_p95_deg")
            shading = f"{shading:.2f}" if shading is not None else "-"
            print(f"| {name} | {n // 1000}k | {method} | {r['triangles']} | {r['l1']:.3g} | {ratio:.3f} | "
                  f"{100 * r['band']:.2f}% | {r['normal_mean_deg']:.2f} | {r['normal_p95_deg']:.2f} | {shading} | "
                  f"{r['holes']:.2g} |")
EOF
