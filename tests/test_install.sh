#!/usr/bin/env bash
# Installs the build into a scratch prefix and builds two programs against
# it as another project would: one with find_package(chisel), one with
# pkg-config. Both must run and read back h in closed form.
# Usage: test_install.sh BUILD_DIR SOURCE_DIR SCRATCH_DIR CC CXX (the
# compilers the build used, so both consumers use the same runtime).
set -euo pipefail
build=$1 src=$2 scratch=$3 cc=$4 cxx=$5
rm -rf "$scratch"
mkdir -p "$scratch"
prefix=$scratch/prefix
cmake --install "$build" --prefix "$prefix" >/dev/null
test -x "$prefix/bin/chisel"
test -f "$prefix/include/chisel/chisel.h"
test -f "$prefix/include/chisel/ch_version.h"

# CMake: find_package(chisel) with namespaced targets.
cmake -S "$src/tests/install" -B "$scratch/cmake-build" -DCMAKE_PREFIX_PATH="$prefix" \
  -DCMAKE_BUILD_TYPE=Release -DCMAKE_C_COMPILER="$cc" -DCMAKE_CXX_COMPILER="$cxx" >/dev/null
cmake --build "$scratch/cmake-build" >/dev/null
"$scratch/cmake-build/consumer"

# pkg-config, relocatable: the prefix was chosen at install time.
pcdir=$(dirname "$(find "$prefix" -name chisel.pc | head -n1)")
flags=$(PKG_CONFIG_PATH=$pcdir pkg-config --cflags --libs chisel)
# shellcheck disable=SC2086
"$cc" -std=c11 -o "$scratch/consumer-pc" "$src/tests/install/consumer.c" $flags
"$scratch/consumer-pc"
echo "install test: both consumers passed"
