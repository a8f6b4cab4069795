#!/usr/bin/env bash
# The lockroll program's contract with people and scripts: exit 0 on success, 2 with a message
# naming what and where on bad input, outputs written whole or not at all.
set -u
lockroll=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
failures=0

expect() {  # expect STATUS PATTERN -- command...
    local want=$1 pattern=$2
    shift 3
    local out status
    out=$("$@" 2>&1)
    status=$?
    if [[ $status -ne $want ]]; then
        echo "FAIL: '$*' exited $status, want $want"; echo "$out" | head -5; failures=$((failures + 1)); return
    fi
    if [[ -n $pattern ]] && ! grep -qE -- "$pattern" <<<"$out"; then
        echo "FAIL: '$*' output lacks /$pattern/"; echo "$out" | head -5; failures=$((failures + 1)); return
    fi
    echo "ok: $*"
}

printf '{\n  "tick_rate": 60,\n  "bodies": [ {"shape": "sphere", "position": [0, 1], "radius": 1} ]\n}\n' >"$tmp/bad.json"
printf '{ "tick_rate": 60, \n' >"$tmp/broken.json"

expect 0 "^[0-9a-f]{16}$" -- "$lockroll" sim --scene paper --frames 60 --every 30
expect 0 "Usage" -- "$lockroll" --help
expect 0 "--inject-desync" -- "$lockroll" run --help
expect 2 "" -- "$lockroll"
expect 2 "frames" -- "$lockroll" sim --scene paper --frames -5
expect 2 "no_such_scene" -- "$lockroll" sim --scene no_such_scene
expect 2 "bad.json: /bodies/0/position: expected an array of 3 numbers" -- "$lockroll" sim --scene "$tmp/bad.json"
expect 2 "broken.json: .*line 2" -- "$lockroll" sim --scene "$tmp/broken.json"
expect 2 "--loss must be a probability" -- "$lockroll" run --loss 2 --out "$tmp/r"
expect 2 "--players must be 2..16" -- "$lockroll" run --players 40 --out "$tmp/r"
expect 2 "--input-delay x: expected a frame count, auto or adaptive" -- "$lockroll" run --input-delay x --out "$tmp/r"
expect 2 "CLIENT:FRAME:BODY" -- "$lockroll" run --inject-desync 1:x:3 --out "$tmp/r"
expect 2 "--mode" -- "$lockroll" run --mode sideways

# --json: the documented keys, written whole.
expect 0 "" -- "$lockroll" sim --scene paper --frames 120 --every 60 --json "$tmp/sim.json"
if ! /usr/bin/python3 - "$tmp/sim.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
assert set(d) >= {"scene", "frames", "final_checksum", "checksums", "overflow_count"}, d.keys()
assert d["frames"] == 120 and len(d["final_checksum"]) == 16
assert [c["frame"] for c in d["checksums"]] == [0, 60, 120]
PY
then echo "FAIL: sim --json content"; failures=$((failures + 1)); fi
# A file that cannot be written leaves nothing behind and fails.
expect 1 "cannot create" -- "$lockroll" sim --scene paper --frames 10 --json "$tmp/missing/dir/x.json"
[[ -z $(ls "$tmp/missing" 2>/dev/null) ]] || { echo "FAIL: partial output left"; failures=$((failures + 1)); }

# run: summary.json with every required key.
expect 0 "confirmed mismatches 0" -- "$lockroll" run --scene paper --frames 120 --latency 30 --jitter 5 --out "$tmp/run"
if ! /usr/bin/python3 - "$tmp/run/summary.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
need = ["mode", "players", "frames", "seed", "ticks_per_second", "stall_fraction", "input_delay_frames",
        "input_latency_ms", "position_error", "confirmed_mismatches", "desyncs", "rollbacks", "cpu_us_per_tick",
        "bandwidth_bytes_per_s", "final_checksums"]
missing = [k for k in need if k not in d]
assert not missing, missing
assert set(d["position_error"]) >= {"mean", "max", "nonzero", "samples"}
assert set(d["rollbacks"]) >= {"count", "per_second", "mean_depth", "max_depth"}
assert set(d["cpu_us_per_tick"]) >= {"mean", "p99"} and set(d["input_latency_ms"]) >= {"mean", "max"}
assert set(d["bandwidth_bytes_per_s"]) >= {"sent", "received"}
assert len(d["final_checksums"]) == 2 and len(set(d["final_checksums"])) == 1
PY
then echo "FAIL: summary.json keys"; failures=$((failures + 1)); fi

# run --record: a replay of a 3-player match (one player body added) verifies; a damaged copy
# is rejected with exit 2.
expect 0 "" -- "$lockroll" run --players 3 --frames 180 --latency 40 --jitter 10 --loss 0.1 --record "$tmp/r.lrr" --out "$tmp/rr"
expect 0 "every checksum matches" -- "$lockroll" replay "$tmp/r.lrr"
cp "$tmp/r.lrr" "$tmp/bad.lrr"
printf '\x01' | dd of="$tmp/bad.lrr" bs=1 seek=300 conv=notrunc 2>/dev/null
expect 2 "bad.lrr: byte [0-9]+: .*corrupted" -- "$lockroll" replay "$tmp/bad.lrr"

echo "$failures failures"
[[ $failures -eq 0 ]]
