#!/usr/bin/env bash
# Builds the libFuzzer targets (fuzz/, clang with ASan + UBSan, in build-asan as
# scripts/sanitize.sh configures it) and runs each for a bounded time, starting from the
# committed seed corpus. Exit 1 when any target finds a crash, a leak, a timeout or an
# out-of-memory; the input is then in build-asan/fuzz-artifacts/. scripts/test.sh --full runs it
# with the default 30 s per target (membership_fuzz and drop_agreement_fuzz: 15 s each; the drop
# agreement's split again, 8 s with every process honest and 7 s with a hostile one); long runs
# by hand are recorded in docs/reliability.md.
#
#   bash scripts/fuzz.sh [--seconds N | --runs N] [TARGET...]   (default: every target)
set -euo pipefail
cd "$(dirname "$0")/.."
all=(protocol_fuzz session_fuzz replay_fuzz snapshot_fuzz scene_fuzz transfer_fuzz relay_fuzz token_fuzz membership_fuzz drop_agreement_fuzz capi_fuzz)
seconds=${FUZZ_SECONDS:-30}
limit=(-max_total_time="$seconds")
# membership_fuzz and drop_agreement_fuzz (two views of the same drops) share one target's time
# by default, so CI's fuzz phase keeps its length: half each.
shared=" membership_fuzz drop_agreement_fuzz "
by_default=1
# drop_agreement_fuzz runs twice, in its two modes, on its time halved (--runs: N runs each):
# every process honest (DROP_AGREEMENT_FUZZ_HONEST=1: one slot chosen per view, no drop without a
# majority voting it gone) and as written, with a hostile process (no drop without that majority;
# one hostile voter can split a view, a stated limit: fuzz/drop_agreement_fuzz.cpp, property 1).
targets=()
while [[ $# -gt 0 ]]; do
  case $1 in
    --seconds) limit=(-max_total_time="$2"); by_default=0; shift 2 ;;
    --runs) limit=(-runs="$2"); by_default=0; shift 2 ;;
    *) targets+=("$1"); shift ;;
  esac
done
[[ ${#targets[@]} -eq 0 ]] && targets=("${all[@]}")
build=${ASAN_BUILD_DIR:-build-asan}
bash scripts/sanitize.sh --configure-only
cmake --build "$build" -j"$(nproc)" --target "${targets[@]}" fuzz_seeds >/dev/null

failed=0
# run TARGET LABEL LIMIT [ENV...]: one libFuzzer run; LABEL names its log and artifacts.
run() {
  local t=$1 label=$2 this_limit=$3
  shift 3
  local name=${t%_fuzz}
  # New inputs go to a scratch corpus in the build directory; the committed seeds (and for
  # scenes the shipped scenes) are read only.
  local work="$build/fuzz-corpus/$name"
  mkdir -p "$work" "$build/fuzz-artifacts"
  local seeds=(fuzz/corpus/"$name")
  [[ $name == scene ]] && seeds+=(harness/scenes)
  local dict=()
  [[ -f fuzz/$name.dict ]] && dict=(-dict="fuzz/$name.dict")
  local log="$build/fuzz-artifacts/$label.log"
  local status=0
  env "$@" "$build/fuzz/$t" "$this_limit" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="$build/fuzz-artifacts/$label-" "${dict[@]}" "$work" "${seeds[@]}" >"$log" 2>&1 || status=$?
  local execs cov
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  cov=$(grep -oE 'cov: [0-9]+ ft: [0-9]+' "$log" | tail -1)
  if [[ $status -ne 0 ]]; then
    echo "fuzz $label: FAILED (exit $status) after ${execs:-?} executions; see $log"
    grep -E "ERROR|SUMMARY|runtime error|property broken" "$log" | head -5
    failed=1
  else
    echo "fuzz $label: ${execs:-?} executions, $cov, no crash"
  fi
}

for t in "${targets[@]}"; do
  this_limit=("${limit[@]}")
  [[ $by_default -eq 1 && $shared == *" $t "* ]] && this_limit=(-max_total_time=$(( (seconds + 1) / 2 )))
  if [[ $t == drop_agreement_fuzz ]]; then
    # Its time in two: honest first (the larger half), then with the hostile process.
    honest_limit=${this_limit[0]} hostile_limit=${this_limit[0]}
    if [[ ${this_limit[0]} == -max_total_time=* ]]; then
      total=${this_limit[0]#-max_total_time=}
      honest_limit=-max_total_time=$(( (total + 1) / 2 ))
      hostile_limit=-max_total_time=$(( total / 2 > 0 ? total / 2 : 1 ))
    fi
    run "$t" drop_agreement "$honest_limit" DROP_AGREEMENT_FUZZ_HONEST=1
    run "$t" drop_agreement-hostile "$hostile_limit"
  else
    run "$t" "${t%_fuzz}" "${this_limit[0]}"
  fi
done
exit $failed
