#!/usr/bin/env bash
# Whether displace's meshes are closed where the base is, and manifold,
# over every base x every curve set (bundled and torture) x the options
# that change the cut (--snap-to, --camera, --warp-dci, catmark) x a few
# triangle counts. Each output goes through `chisel info`; a run counts as
# bad where info sees an edge of more than two faces, a non-manifold
# vertex, or (on the closed bases: tablet, torus) a boundary edge, or
# where displace fails. Prints one line per bad run and a summary; exit 1
# if any.
#
# Usage: bench/manifold.sh [BUILD_DIR] [SIZES...]   (default: build 25000 70000 200000)
# About 25 minutes for the default 1680 runs on 2 cores.
set -uo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
shift || true
sizes=("$@")
[ ${#sizes[@]} -gt 0 ] || sizes=(25000 70000 200000)
chisel=$build/chisel
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
options=("" "--snap-to recon5" "--snap-to recon3" "--camera 0.2,0.3,0.25,0.3,0.4,0,50"
  "--camera 0.5,-0.6,0.9,0.5,0.5,0,35 --warp-dci" "--scheme catmark"
  "--camera 0.9,0.8,0.3,0.6,0.6,0,45 --scheme catmark")
runs=0 bad=0
for base in plane tablet vase torus obelisk; do
  for svg in models/curves/*.svg models/torture/*.svg; do
    for opt in "${options[@]}"; do
      for n in "${sizes[@]}"; do
        runs=$((runs + 1))
        what="$base $(basename "$svg" .svg) $n [$opt]"
        # shellcheck disable=SC2086 # (opt holds several words on purpose)
        if ! "$chisel" displace "models/$base.obj" "$svg" -o "$tmp/m.obj" --target-tris "$n" $opt -q 2>"$tmp/err"; then
          bad=$((bad + 1))
          echo "FAILED: $what: $(tail -1 "$tmp/err")"
          continue
        fi
        edges=$("$chisel" info "$tmp/m.obj" 2>/dev/null | grep -o 'edges .*' | sed 's/edges *//')
        boundary=${edges%% boundary*}
        if ! [[ $edges == *" 0 non-manifold; 0 non-manifold vertices" ]] ||
          { [[ $base == tablet || $base == torus ]] && [ "$boundary" != 0 ]; }; then
          bad=$((bad + 1))
          echo "BAD: $what: $edges"
        fi
      done
    done
  done
done
echo "$runs runs, $bad bad"
[ "$bad" = 0 ]
