#!/usr/bin/env bash
# Configures the build directory the quick start and the test command share (default build/):
# Release, warnings as errors. One line for both, so running one after the other rebuilds
# nothing: a different flag would recompile every file.
#
#   bash scripts/configure.sh [BUILD_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B "${1:-build}" -G Ninja -DCMAKE_BUILD_TYPE=Release -DLOCKROLL_WERROR=ON >/dev/null
