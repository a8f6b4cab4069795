#!/usr/bin/env bash
# The test suite under AddressSanitizer + UndefinedBehaviorSanitizer (clang-14), in its own
# build directory (build-asan: Debug at -O1, benchmarks off, coverage for the fuzz targets
# that scripts/fuzz.sh builds in the same directory). Any sanitizer report fails the test that
# triggered it. Left out: soaks, the cross check (a gcc/clang/qemu matrix of its own) and the
# install test (it builds a consumer with the default compiler, which cannot link ASan
# objects). scripts/test.sh --full runs this; docs/testing.md.
#
# Then ThreadSanitizer on the parallel step (docs/physics.md, "Parallel step"), in build-tsan:
# only the sim targets that run threads (the pool, the phase runner, World's parallel and coloured tests)
# and the golden checksums at 2 workers and with one thread per task, about a minute.
#
#   bash scripts/sanitize.sh                  configure, build, run the tests (ASan, then TSan)
#   bash scripts/sanitize.sh --configure-only configure build-asan (used by scripts/fuzz.sh)
#   bash scripts/sanitize.sh --tsan-only      only the ThreadSanitizer part
set -euo pipefail
cd "$(dirname "$0")/.."
build=${ASAN_BUILD_DIR:-build-asan}
if ! command -v clang++ >/dev/null; then
  echo "sanitize: clang++ not installed (bash scripts/install-deps.sh --cross)" >&2
  exit 3
fi
tsan_build=${TSAN_BUILD_DIR:-build-tsan}
run_tsan() {
  cmake -S . -B "$tsan_build" -G Ninja -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_COMPILER=clang++ \
    -DCMAKE_CXX_FLAGS_DEBUG="-O1 -gline-tables-only -fsanitize=thread" -DCMAKE_EXE_LINKER_FLAGS=-fsanitize=thread \
    -DLOCKROLL_WERROR=ON >/dev/null  # benchmarks on: tests/server names relay_bench (built only if asked)
  cmake --build "$tsan_build" -j"$(nproc)" --target golden_main task_pool_test parallel_tasks_test world_test islands_test angular_friction_test
  # halt_on_error: a race fails the test that ran into it.
  TSAN_OPTIONS=${TSAN_OPTIONS:-halt_on_error=1:second_deadlock_stack=1} \
    ctest --test-dir "$tsan_build" --output-on-failure -j"$(nproc)" \
      -R '^(golden_checksums_workers_2|golden_checksums_runner_spawn|TaskPool\.|ParallelTasks\.|World\.Parallel|World\.Coloured|World\.Sleeping|AngularFriction\.SameBits|Islands\.Parallel)'
}
if [[ "${1:-}" == "--tsan-only" ]]; then
  run_tsan
  exit 0
fi
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_COMPILER=clang++ \
  -DCMAKE_CXX_FLAGS_DEBUG="-O1 -gline-tables-only" -DLOCKROLL_SANITIZE=ON -DLOCKROLL_FUZZ=ON \
  -DLOCKROLL_BUILD_BENCH=OFF -DLOCKROLL_WERROR=ON >/dev/null
[[ "${1:-}" == "--configure-only" ]] && exit 0
cmake --build "$build" -j"$(nproc)"
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:strict_string_checks=1:detect_stack_use_after_return=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
# examples: the WebAssembly page is built by emscripten, not under the sanitizers.
ctest --test-dir "$build" --output-on-failure -j"$(nproc)" -LE 'soak|cross|install|examples'
run_tsan
