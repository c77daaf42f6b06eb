#!/usr/bin/env bash
# Installs the Debian 12 packages chisel needs; skips what is already there.
# Usage: scripts/install-deps.sh [--fuzz]   (--fuzz adds clang + libFuzzer runtime)
set -euo pipefail
pkgs=(build-essential cmake pkg-config
      libosd-dev libopenmesh-dev libembree-dev libglfw3-dev libopenexr-dev
      libcjson-dev libxml2-dev libpng-dev zlib1g-dev openexr libsuitesparse-dev
      xvfb xauth libgl1-mesa-dri libgl-dev
      python3
      # the tools the interop test opens chisel's outputs with
      openimageio-tools imagemagick libmagickcore-6.q16-6-extra blender
      # (Blender's glTF importer needs numpy)
      python3-numpy)
if [ "${1:-}" = "--fuzz" ]; then
  pkgs+=(clang libomp-dev libclang-rt-14-dev)
fi
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#pkgs[@]} packages present"
  exit 0
fi
echo "install-deps: installing ${missing[*]}"
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
