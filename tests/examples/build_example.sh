#!/usr/bin/env bash
# Installs this build into a fresh prefix and builds examples/NAME against the installed package
# only (as a game outside lockroll would). Prints the example's build directory.
#   build_example.sh BUILD_DIR SOURCE_DIR WORK_DIR NAME CXX GENERATOR
set -euo pipefail
build=$1 src=$2 work=$3 name=$4 cxx=$5 gen=$6
rm -rf "$work" && mkdir -p "$work"
cmake --install "$build" --prefix "$work/prefix" > "$work/install.log" 2>&1 ||
  { cat "$work/install.log" >&2; echo "build_example: cmake --install failed" >&2; exit 1; }
dir=$(ls -d "$work"/prefix/lib*/cmake/lockroll | head -1)
cmake -S "$src/examples/$name" -B "$work/build" -G "$gen" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER="$cxx" \
  -Dlockroll_DIR="$dir" -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF -DCMAKE_FIND_USE_SYSTEM_PACKAGE_REGISTRY=OFF \
  > "$work/configure.log" 2>&1 || { cat "$work/configure.log" >&2; echo "build_example: configuring $name failed" >&2; exit 1; }
cmake --build "$work/build" > "$work/build.log" 2>&1 ||
  { cat "$work/build.log" >&2; echo "build_example: building $name failed" >&2; exit 1; }
echo "$work/build"
