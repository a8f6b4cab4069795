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
json=$(mktemp)
trap 'rm -f "$json"' EXIT
"$build/bench/step_bench" --benchmark_repetitions="${REPS:-7}" --benchmark_report_aggregates_only=true \
  --benchmark_out="$json" --benchmark_out_format=json >/dev/null
/usr/bin/python3 - "$json" "$out" <<'PY'
import csv, json, sys
data = json.load(open(sys.argv[1]))
ctx = data["context"]
rows = [b for b in data["benchmarks"] if b.get("aggregate_name") == "median"]
with open(sys.argv[2], "w", newline="") as f:
    w = csv.writer(f)
    w.writerow(["# host", ctx.get("host_name"), "cpus", ctx.get("num_cpus"), "mhz", ctx.get("mhz_per_cpu"),
                "date", ctx.get("date"), "build", ctx.get("library_build_type")])
    w.writerow(["benchmark", "median_real_time", "median_cpu_time", "unit", "repetitions", "extra"])
    skip = {"name", "run_name", "run_type", "aggregate_name", "aggregate_unit", "family_index",
            "per_family_instance_index", "repetitions", "threads", "iterations", "real_time", "cpu_time",
            "time_unit", "repetition_index", "label"}
    for b in rows:
        extra = ";".join(f"{k}={v:g}" for k, v in b.items() if k not in skip and isinstance(v, (int, float)))
        if b.get("label"): extra = (b["label"] + ";" + extra).strip(";")
        w.writerow([b["run_name"], f'{b["real_time"]:.4g}', f'{b["cpu_time"]:.4g}', b["time_unit"],
                    b.get("repetitions", ""), extra])
PY
echo "wrote $out"
column -s, -t <"$out"
