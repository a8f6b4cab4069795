#!/usr/bin/env bash
# Runs the Google Benchmark programs with repetitions and keeps the medians as CSV in
# bench/results/<host>-<date>.csv (one file per machine and day), for docs/performance.md.
# Shared, noisy machines: compare figures from one run, and quote medians.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${BUILD_DIR:-build}
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" --target step_bench >/dev/null
mkdir -p bench/results
out="bench/results/$(hostname -s)-$(date +%Y-%m-%d).csv"
"$build/bench/step_bench" --benchmark_repetitions="${REPS:-7}" --benchmark_report_aggregates_only=true \
  --benchmark_format=csv 2>/dev/null | grep -E '^name|_median' >"$out"
echo "wrote $out"
column -s, -t <"$out" | cut -c1-110
