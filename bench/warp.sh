#!/usr/bin/env bash
# The warp's figures: the view-dependent warp (chisel displace --camera) on
# every bundled curve set over the planar base, for two close views and a
# full view, against the unwarped run at the same --res and --target-tris,
# snapped and --no-snap: the accuracy figures (accuracy.h) counted only on
# what the camera sees (chisel-accuracy --camera), the virtual resolution
# and visible share the warp reports, and the warp's share of the run.
#
# Usage: bench/warp.sh [BUILD_DIR] [TARGET_TRIS] [RES]   (default: build 130000 1024)
# WARP_SETS="glyphs star" limits the run to those curve sets.
# Prints a markdown table and writes it, with the JSON lines, under out/warp/.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
n=${2:-130000}
res=${3:-1024}
dir=out/warp
mkdir -p "$dir"
json="$dir/warp.jsonl"
: >"$json"
# close: a quarter of a unit up, looking down at 45 degrees onto (0.35, 0.35)
# (sees 12% of the plane); closer: 0.08 up (2%); full: the whole plane.
declare -A cameras=(
  [close]="0.35,0.1,0.25,0.35,0.35,0,40"
  [closer]="0.35,0.25,0.08,0.35,0.35,0,40"
  [full]="0.5,-0.55,1.3,0.5,0.5,0,50"
)
# one case: a curve set seen from one camera, unwarped and warped, snapped and --no-snap
run_case() {
  local svg=$1 name=$2 view=$3 cam=$4
  for method in snap naive; do
    flag=()
    [ $method = naive ] && flag=(--no-snap)
    base="$dir/$name-$view-$method"
    "$build/chisel" displace models/plane.obj "$svg" -o "$base-flat.obj" --target-tris "$n" --res "$res" \
      "${flag[@]}" 2>/dev/null
    log=$("$build/chisel" displace models/plane.obj "$svg" -o "$base-warp.obj" --target-tris "$n" --res "$res" \
      "${flag[@]}" --camera "$cam" 2>&1 >/dev/null | grep '^chisel: warp' | tr '\n' ' ' || true)
    "$build/bench/chisel-accuracy" "$base-flat.obj" "$base-warp.obj" "$svg" --camera "$cam" --json |
      python3 -c 'import json,sys
for line in sys.stdin:
    r = json.loads(line); r["warp_log"] = sys.argv[1]; print(json.dumps(r))' "$log" >>"$json"
    rm -f "$base-flat.obj" "$base-warp.obj"
  done
  echo "warp: $name $view done" >&2
}
for svg in models/curves/*.svg; do
  name=$(basename "$svg" .svg)
  if [ -n "${WARP_SETS:-}" ] && ! [[ " $WARP_SETS " == *" $name "* ]]; then continue; fi
  for view in close closer full; do run_case "$svg" "$name" "$view" "${cameras[$view]}"; done
done
# Fans: thin grooves meeting at one point, seen close from above that
# point (the star's 24 rays, and 16 or 64 grooves 0.2 viewBox units wide
# crossing at the centre: bench/pathological.py crossing N).
declare -A fan_cameras=(
  [centre]="0.5,0.25,0.25,0.5,0.5,0,40"
  [centrecloser]="0.5,0.4,0.08,0.5,0.5,0,40"
)
for fan in star fan16 fan64; do
  if [ -n "${WARP_SETS:-}" ] && ! [[ " $WARP_SETS " == *" $fan "* ]]; then continue; fi
  svg=models/curves/star.svg
  if [ "$fan" != star ]; then svg="$dir/$fan.svg"; python3 bench/pathological.py crossing "${fan#fan}" "$svg"; fi
  for view in centre centrecloser; do run_case "$svg" "$fan" "$view" "${fan_cameras[$view]}"; done
done
# The virtual resolution of a close view of each bundled base mesh (glyphs
# on it): R times the warp's largest slopes, and the visible share.
scenes="$dir/scenes.txt"
: >"$scenes"
declare -A close_views=(
  [plane]="0.35,0.25,0.08,0.35,0.35,0,40"
  [tablet]="-0.1,0.1,0.35,-0.15,-0.1,0.06,40"
  [vase]="0,-1.1,1.1,0,-0.45,0.9,30"
  [torus]="0,-2.1,0.3,0,-1.35,0,30"
  [obelisk]="0.1,-1.4,1.5,0,-0.45,1.2,30"
)
if [ -z "${WARP_SETS:-}" ]; then
  for model in plane tablet vase torus obelisk; do
    line=$("$build/chisel" displace "models/$model.obj" models/curves/glyphs.svg -o "$dir/scene.obj" --target-tris "$n" \
      --res "$res" --camera "${close_views[$model]}" 2>&1 >/dev/null | grep '^chisel: warp' || echo "no warp")
    echo "$model: $line" >>"$scenes"
    rm -f "$dir/scene.obj"
  done
fi
python3 - "$json" <<'PY' | tee "$dir/warp.md"
import json, os, re, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
by = {}
for r in rows:
    b = os.path.basename(r["mesh"])[:-4]
    name, view, method, kind = b.rsplit("-", 3)
    by[(name, view, method, kind)] = r
print("| curves | view | method | triangles flat / warped | L1 flat | L1 warped | flat / warped | band flat / warped | "
      "normal p95 flat / warped | holes | virtual resolution | visible share of texels (unwarped), of triangles | "
      "warp cost |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
order = {"close": 0, "closer": 1, "full": 2, "centre": 3, "centrecloser": 4}
for (name, view, method, kind), r in sorted(by.items(), key=lambda kv: (kv[0][0], order[kv[0][1]], kv[0][2])):
    if kind != "flat":
        continue
    w = by.get((name, view, method, "warp"))
    if not w:
        continue
    log = w["warp_log"]
    m = re.search(r"virtual resolution (\d+) x (\d+) \(([\d.]+)x, ([\d.]+)x", log)
    vr = f"{m.group(1)} x {m.group(2)} ({m.group(3)}x, {m.group(4)}x)" if m else "no warp"
    m = re.search(r"visible part ([\d.]+)% of the texels \(([\d.]+)% unwarped\), ([\d.]+)% of the triangles", log)
    share = f"{m.group(1)}% ({m.group(2)}%), {m.group(3)}%" if m else "-"
    m = re.search(r"warp (\d+) ms \(([\d.]+)% of the run\)", log)
    cost = f"{m.group(1)} ms ({m.group(2)}%)" if m else "-"
    # both at rounding level (under 1e-9 of max |h|): no ratio to speak of
    ratio = "both exact" if max(r["l1"], w["l1"]) < 1e-9 else \
        f"{r['l1'] / w['l1']:.2f}" if w["l1"] > 0 else "inf"
    print(f"| {name} | {view} | {method} | {r['triangles']} / {w['triangles']} | {r['l1']:.3g} | {w['l1']:.3g} | "
          f"{ratio} | {100 * r['band']:.2f}% / {100 * w['band']:.2f}% | "
          f"{r['normal_p95_deg']:.2f} / {w['normal_p95_deg']:.2f} | {max(r['holes'], w['holes']):.2g} | {vr} | "
          f"{share} | {cost} |")
PY
if [ -s "$scenes" ]; then
  { echo; echo "Close views of the bundled base meshes (glyphs):"; sed 's/^/    /' "$scenes"; } | tee -a "$dir/warp.md"
fi
