#!/usr/bin/env bash
# Builds lockroll with warnings as errors and runs the whole test suite (ctest). This is the
# README's test command and what CI runs. Long soaks and sweeps are excluded here
# (ctest -L soak runs them by hand). With clang++ installed (--cross installs it) it then runs
# the suite again under ASan + UBSan and every fuzz target for 30 s (docs/reliability.md);
# SANITIZE=0 skips both.
set -euo pipefail
cd "$(dirname "$0")/.."
# --cross: the golden-checksum cross check (ctest label "cross") needs the cross compilers,
# clang and qemu-user; without them it is reported as skipped.
bash scripts/install-deps.sh --cross
build=${BUILD_DIR:-build}
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DLOCKROLL_WERROR=ON >/dev/null
cmake --build "$build" -j"$(nproc)"
ctest --test-dir "$build" --output-on-failure -j"$(nproc)" -LE soak
if [[ "${SANITIZE:-1}" != 0 ]]; then
  if command -v clang++ >/dev/null; then
    bash scripts/sanitize.sh
    bash scripts/fuzz.sh
  else
    echo "sanitizer pass and fuzzing skipped: clang++ is not installed" >&2
  fi
fi
