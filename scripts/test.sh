#!/usr/bin/env bash
# Builds lockroll with warnings as errors and runs the whole test suite (ctest). This is the
# README's test command and what CI runs. Long soaks and sweeps are excluded here
# (ctest -L soak runs them by hand).
set -euo pipefail
cd "$(dirname "$0")/.."
# --cross: the golden-checksum cross check (ctest label "cross") needs the cross compilers,
# clang and qemu-user; without them it is reported as skipped.
bash scripts/install-deps.sh --cross
build=${BUILD_DIR:-build}
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DLOCKROLL_WERROR=ON >/dev/null
cmake --build "$build" -j"$(nproc)"
ctest --test-dir "$build" --output-on-failure -j"$(nproc)" -LE soak
