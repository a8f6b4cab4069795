#!/usr/bin/env bash
# The lockroll program's contract with people and scripts: exit 0 on success, 2 with a message
# naming what and where on bad input, outputs written whole or not at all.
set -u
lockroll=$(readlink -f "$1")
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
expect 2 "--json .*missing/dir/x.json: directory .* does not exist" -- "$lockroll" sim --scene paper --frames 10 --json "$tmp/missing/dir/x.json"
[[ -z $(ls "$tmp/missing" 2>/dev/null) ]] || { echo "FAIL: partial output left"; failures=$((failures + 1)); }

# Bad input found by hardening (issue 11): exit 2, a message naming the flag or the path and
# place, checked before any work starts, nothing left behind.
absent() {  # absent PATH...: none of them exists
    for p in "$@"; do
        if [[ -e $p ]]; then echo "FAIL: $p was left behind"; failures=$((failures + 1)); fi
    done
}
printf '{"bodies": [{"shape": "sphere",\n  "position": [0, 1e400, 0], "radius": 1}]}\n' >"$tmp/huge_number.json"
expect 2 "huge_number.json: line 2, column 19: number 1e400 is outside the Q32.32 range" -- "$lockroll" sim --scene "$tmp/huge_number.json"
printf '{"room": {"min": [-5, 0, -5], "max": [5, 5, 5]}, "spawners": [{"count": 1000000, "shape": "sphere",
  "radius": 0.2, "region": {"min": [-5, 0, -5], "max": [5, 5, 5]}}]}\n' >"$tmp/too_many.json"
expect 2 "too_many.json: /spawners/0/count: the scene would have 1000006 bodies, more than the limit of 1000000" -- \
    "$lockroll" sim --scene "$tmp/too_many.json" --frames 0
expect 2 "paper.*more than the limit of 10 " -- "$lockroll" --max-bodies 10 sim --scene paper --frames 0
# 300,000 balls in a room that holds ~30,000: placement gives up searching once the room is
# full (linear time); quadratic placement took minutes here. The timeout is 100x the need.
printf '{"room": {"min": [-5, 0, -5], "max": [5, 5, 5]}, "spawners": [{"count": 300000, "shape": "sphere",
  "radius": 0.2, "region": {"min": [-5, 0, -5], "max": [5, 5, 5]}}]}\n' >"$tmp/crowded.json"
expect 0 "^[0-9a-f]{16}$" -- timeout 60 "$lockroll" sim --scene "$tmp/crowded.json" --frames 0
expect 2 "unknown subcommand 'nosuch'" -- "$lockroll" nosuch
expect 2 "--checksum-interval must be 1..65535" -- "$lockroll" run --checksum-interval 70000 --out "$tmp/ci"
expect 2 "--seed: .*non-negative" -- "$lockroll" run --seed -1 --out "$tmp/seed"
expect 2 "--seed: .*non-negative" -- "$lockroll" synctest --scene paper --seed -1
expect 2 "--inject-desync 1:4294967298:10: FRAME 4294967298 is above 4294967295" -- \
    "$lockroll" run --inject-desync 1:4294967298:10 --out "$tmp/inj"
expect 2 "--inject-desync 99:1:1: CLIENT" -- "$lockroll" run --inject-desync 99:1:1 --out "$tmp/inj"
absent "$tmp/ci" "$tmp/seed" "$tmp/inj"
touch "$tmp/a_file"
expect 2 "--out .*a_file: exists and is not a directory" -- "$lockroll" run --out "$tmp/a_file"
expect 2 "--out /proc/lockroll-out: cannot create files in /proc" -- "$lockroll" run --out /proc/lockroll-out
mkdir "$tmp/cwd"
expect 2 '--out "": empty path' -- env -C "$tmp/cwd" "$lockroll" run --out ""
[[ -z $(ls -A "$tmp/cwd") ]] || { echo "FAIL: run --out '' left $(ls -A "$tmp/cwd")"; failures=$((failures + 1)); }
expect 2 "--record /proc/x.lrr: cannot create files in /proc" -- "$lockroll" run --record /proc/x.lrr --out "$tmp/rec"
expect 2 "--record /proc/x.lrr: cannot create files in /proc" -- "$lockroll" synctest --scene paper --record /proc/x.lrr
expect 2 "--record .*: is a directory" -- "$lockroll" synctest --scene paper --record "$tmp"
expect 2 "--json /proc/x.json: cannot create files in /proc" -- "$lockroll" sim --scene paper --json /proc/x.json
expect 2 "--json /proc/x.json: cannot create files in /proc" -- "$lockroll" stability --case free_fall --json /proc/x.json
absent "$tmp/rec"
expect 2 "replay \.: is a directory" -- "$lockroll" replay .
expect 2 "replay /dev/zero: not a regular file" -- "$lockroll" replay /dev/zero
head -c $((2 << 20)) /dev/zero >"$tmp/big.lrr"
expect 2 "replay .*big.lrr: larger than 1048576 bytes" -- "$lockroll" replay --max-mib 1 "$tmp/big.lrr"

# run: summary.json with every required key.
expect 0 "confirmed mismatches 0" -- "$lockroll" run --scene paper --frames 120 --latency 30 --jitter 5 --out "$tmp/run"
absent "$tmp/run/desync"  # evidence directory only when there is evidence
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

# --partition (issue 21): bad values exit 2 naming the flag and the part, before anything is
# written; a valid cut runs and is reported (summary.json, events.csv).
expect 2 "--partition '0,1/2': syntax: expected SETS@FROM-UNTIL" -- "$lockroll" run --players 3 --partition 0,1/2 --out "$tmp/part"
expect 2 "--partition '0/1@800-200': frames '800-200': FROM must be below UNTIL" -- "$lockroll" run --partition 0/1@800-200 --out "$tmp/part"
expect 2 "--partition '0,1/1,2@1-5': slot 1: named twice" -- "$lockroll" run --players 3 --partition 0,1/1,2@1-5 --out "$tmp/part"
expect 2 "--partition '0/3@1-5': slot 3: not in 0..1 \(--players 2\)" -- "$lockroll" run --partition 0/3@1-5 --out "$tmp/part"
expect 2 "--partition '0/1@1-5;0/1': cut 2 '0/1': syntax" -- "$lockroll" compare --partition "0/1@1-5;0/1" --out "$tmp/part"
expect 2 "--partition '0/1@1-5': .*peer to peer only" -- "$lockroll" live --topology relay --partition 0/1@1-5 --out "$tmp/part"
expect 2 "--partition '0/2@1-5': slot 2: not in 0..1" -- "$lockroll" live --partition 0/2@1-5 --out "$tmp/part"
absent "$tmp/part"
expect 0 "partition +1 cut, [1-9][0-9]* datagrams dropped" -- \
    "$lockroll" run --players 3 --frames 240 --partition 0/1,2@60-90 --out "$tmp/part-ok"
if ! /usr/bin/python3 - "$tmp/part-ok" <<'PY'
import csv, json, sys
d = json.load(open(sys.argv[1] + "/summary.json"))
p = d["network"]["partition"]
assert p["cuts"] == 1 and p["dropped_datagrams"] > 0, p
cut = [r for r in csv.DictReader(open(sys.argv[1] + "/events.csv")) if r["kind"] == "partition"]
assert cut, "no partition events"
# Frames 60..89 at 60 Hz: 1.0 s to 1.5 s into the match, give or take a client's tick phase.
assert all(0.95 <= float(r["time_s"]) < 1.55 for r in cut), [r["time_s"] for r in cut][:5]
assert len(set(d["final_checksums"])) == 1
PY
then echo "FAIL: run --partition summary/events"; failures=$((failures + 1)); fi
# Without --partition the summary says nothing about partitions.
if ! /usr/bin/python3 -c 'import json, sys; assert "partition" not in json.load(open(sys.argv[1]))["network"]' "$tmp/run/summary.json"
then echo "FAIL: summary.json mentions partitions without --partition"; failures=$((failures + 1)); fi

# A partition that never heals before the match ends (issue 21): the majority completes, the
# cut-off client ends partitioned with its frame (never completed), and the run exits non-zero
# saying so.
expect 1 "partitioned: client 2 since frame [0-9]+" -- \
    "$lockroll" run --players 3 --frames 240 --partition 0,1/2@60-100000 --out "$tmp/part-unhealed"
if ! /usr/bin/python3 - "$tmp/part-unhealed" <<'PY'
import json, sys
d = json.load(open(sys.argv[1] + "/summary.json"))
c = d["clients"]
assert d["completed"] is False, d["completed"]
assert [x["outcome"] for x in c] == ["completed", "completed", "partitioned"], [x.get("outcome") for x in c]
assert 40 <= c[2]["partitioned_since_frame"] <= 64, c[2]
assert d["final_checksums"][2] is None and d["final_checksums"][0] == d["final_checksums"][1], d["final_checksums"]
PY
then echo "FAIL: run with an unhealed --partition: summary"; failures=$((failures + 1)); fi

# run --record: a replay of a 3-player match (one player body added) verifies; a damaged copy
# is rejected with exit 2.
expect 0 "" -- "$lockroll" run --players 3 --frames 180 --latency 40 --jitter 10 --loss 0.1 --record "$tmp/r.lrr" --out "$tmp/rr"
expect 0 "every checksum matches" -- "$lockroll" replay "$tmp/r.lrr"
cp "$tmp/r.lrr" "$tmp/bad.lrr"
printf '\x01' | dd of="$tmp/bad.lrr" bs=1 seek=300 conv=notrunc 2>/dev/null
expect 2 "bad.lrr: byte [0-9]+: .*corrupted" -- "$lockroll" replay "$tmp/bad.lrr"

echo "$failures failures"
[[ $failures -eq 0 ]]
