#!/usr/bin/env bash
# The README's test command.
#
#   bash scripts/test.sh          the default tier (docs/testing.md): installs what is missing,
#                                 builds build/ (scripts/configure.sh, the quick start's flags, so
#                                 nothing it built is rebuilt) and runs every unit, integration and
#                                 real-process test: ctest -LE 'soak|cross|examples'. About 9.5
#                                 minutes from a fresh clone on the 2-core VM, build included.
#   bash scripts/test.sh --full   what CI runs (.ci/run): the cross toolchains too, the default
#                                 tier, then the 11-target golden cross check and the WebAssembly
#                                 page (labels cross, examples), the suite again under ASan + UBSan
#                                 (scripts/sanitize.sh) and 30 s of every fuzz target
#                                 (scripts/fuzz.sh).
#
# Soaks and sweeps (label soak) run only by hand: ctest --test-dir build -L soak.
# Each phase's wall time is printed at the end.
set -euo pipefail
cd "$(dirname "$0")/.."
full=0
case "${1:-}" in
  "") ;;
  --full) full=1 ;;
  *) echo "test.sh: unknown argument '$1' (usage: bash scripts/test.sh [--full])" >&2; exit 2 ;;
esac
build=${BUILD_DIR:-build}
phases=()
t0=$SECONDS
phase() {  # phase NAME COMMAND...: runs it and records its wall time
  local name=$1 start=$SECONDS; shift
  "$@"
  phases+=("$name $((SECONDS - start)) s")
}
if [[ $full -eq 1 ]]; then
  phase install bash scripts/install-deps.sh --cross
else
  phase install bash scripts/install-deps.sh
fi
phase build bash -c "bash scripts/configure.sh '$build' && cmake --build '$build' -j$(nproc)"
# The benchmark programs are not in `all` (bench/CMakeLists.txt): CI builds them so they stay whole.
if [[ $full -eq 1 ]]; then phase benchmarks cmake --build "$build" -j"$(nproc)" --target benchmarks; fi
phase tests ctest --test-dir "$build" --output-on-failure -j"$(nproc)" -LE 'soak|cross|examples'
if [[ $full -eq 1 ]]; then
  # The platform matrix apart, so the default tier's own time shows in CI's output too.
  phase platforms ctest --test-dir "$build" --output-on-failure -j"$(nproc)" -L 'cross|examples' -LE soak
  phase sanitizers bash scripts/sanitize.sh
  phase fuzz bash scripts/fuzz.sh
fi
echo "test.sh$([[ $full -eq 1 ]] && echo ' --full'): $(IFS=,; echo "${phases[*]}" | sed 's/,/, /g'); total $((SECONDS - t0)) s"
