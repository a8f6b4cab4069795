#!/usr/bin/env bash
# live_report_check.py on runs it cannot check, without starting a process: a run where no
# process played (every one failed its handshake, so live wrote no bodies.csv and no process
# wrote samples.json), and a directory that is no run at all. The checker must say which file is
# missing and where, and exit 1 (as on a mismatch), never with a Python traceback.
set -u
checker=$(dirname "$0")/live_report_check.py
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

expect_missing() {  # expect_missing WHAT RUN_DIR MODE PATTERN...: exit 1, each PATTERN in the output
    local what=$1 run=$2 mode=$3 before=$failures; shift 3
    /usr/bin/python3 "$checker" "$run" "$mode" >"$tmp/out.txt" 2>&1
    local status=$?
    [[ $status -eq 1 ]] || fail "$what: exit status $status, not 1"
    if grep -q Traceback "$tmp/out.txt"; then fail "$what: a Python traceback"; fi
    local p
    for p in "$@"; do grep -qF -- "$p" "$tmp/out.txt" || fail "$what: the message does not name '$p'"; done
    if [[ $failures -eq $before ]]; then echo "ok: $what"; else cat "$tmp/out.txt"; fi
}

# 1. Two players, both failed their handshake: live.json, the mode's summary.json and report.md
#    are there; bodies.csv and every samples.json are not.
run=$tmp/run
mkdir -p "$run/rollback/p0" "$run/rollback/p1"
cat >"$run/live.json" <<'JSON'
{"modes": {"rollback": {"ok": false, "processes": [
  {"name": "p0", "role": "player", "slot": 0, "outcome": "connect_timeout"},
  {"name": "p1", "role": "player", "slot": 1, "outcome": "connect_timeout"}]}}}
JSON
echo '{"frames": 120, "tick_rate": 60, "players": 2, "input_delay_frames": 2, "prediction_window": 8}' \
    >"$run/rollback/summary.json"
echo '{"outcome": "connect_timeout"}' | tee "$run/rollback/p0/summary.json" >"$run/rollback/p1/summary.json"
printf '| | rollback |\n|---|---|\n| ticks per second | n/a |\n' >"$run/report.md"
expect_missing "no process played" "$run" rollback "$run/rollback/bodies.csv" "p0 connect_timeout" "p1 connect_timeout"

# 2. Not a run directory: no live.json.
mkdir -p "$tmp/empty"
expect_missing "no run" "$tmp/empty" rollback "$tmp/empty/live.json"

[[ $failures -eq 0 ]] && echo "all passed" || echo "$failures failure(s)"
exit $((failures > 0))
