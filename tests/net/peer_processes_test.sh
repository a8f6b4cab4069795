#!/usr/bin/env bash
# Two and three `lockroll peer` processes over ENet on 127.0.0.1 play the paper scene; every
# process must complete and all must end on the same confirmed checksum. Also: bad flags exit 2
# naming the flag, before anything is written.
set -u
lockroll=$1
here=$(cd "$(dirname "$0")" && pwd)
source "$(dirname "$0")/../process_test_support.sh"

# match NAME PLAYERS MODE FRAMES [extra peer flags...]
match() {
    local name=$1 players=$2 mode=$3 frames=$4
    shift 4
    local ports
    read -r -a ports <<<"$(/usr/bin/python3 "$here/free_ports.py" "$players")"
    pids=()
    for ((k = 0; k < players; k++)); do
        local peers=()
        for ((j = 0; j < players; j++)); do
            [[ $j -eq $k ]] || peers+=(--peer "$j=127.0.0.1:${ports[$j]}")
        done
        timeout 120 "$lockroll" peer --slot "$k" --players "$players" --listen "127.0.0.1:${ports[$k]}" "${peers[@]}" \
            --scene paper --frames "$frames" --mode "$mode" --input-delay 2 --seed 7 --log-level warn \
            --out "$tmp/$name/p$k" "$@" >"$tmp/$name-p$k.out" 2>&1 &
        pids+=($!)
    done
    local k=0
    for p in "${pids[@]}"; do
        if ! wait "$p"; then fail "$name: peer $k exited non-zero"; tail -5 "$tmp/$name-p$k.out"; fi
        k=$((k + 1))
    done
    pids=()
    if ! /usr/bin/python3 - "$tmp/$name" "$players" "$frames" <<'PY'
import json, os, sys
d, n, frames = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
s = [json.load(open(os.path.join(d, f"p{k}", "summary.json"))) for k in range(n)]
finals = [x["final_checksum"] for x in s]
assert all(f is not None for f in finals), finals
assert len(set(finals)) == 1, f"final confirmed checksums differ: {finals}"
for x in s:
    assert x["outcome"] == "completed", x["outcome"]
    assert x["desyncs"] == 0 and x["confirmed_frame"] >= frames
    assert x["clients"][0]["frames"] >= frames
# Every checkpoint checksum agrees too, and every process logged its lifecycle.
cps = [{c["frame"]: c["checksum"] for c in x["confirmed_checksums"]} for x in s]
assert all(c == cps[0] for c in cps), "checkpoint checksums differ"
for k in range(n):
    evs = [json.loads(l) for l in open(os.path.join(d, f"p{k}", "events.jsonl"))]
    ev = [e["event"] for e in evs]
    connected = {e["peer"] for e in evs if e["event"] == "connected"}
    assert connected == set(range(n)) - {k}, ev
    assert "synchronized" in ev and ev[-1] == "finished", ev
    assert "disconnected" not in ev and "desync" not in ev, ev
    rows = open(os.path.join(d, f"p{k}", "positions.csv")).read().count("\n")
    assert rows > frames, rows
print("ok:", d, finals[0])
PY
    then fail "$name: outputs"; fi
}

match two 2 rollback 300
match lockstep 2 lockstep 240
match three 3 rollback 300

# Bad flags: exit 2 naming the flag; nothing written.
expect2() {
    local pattern=$1; shift
    local out status
    out=$("$lockroll" peer "$@" 2>&1); status=$?
    if [[ $status -ne 2 ]] || ! grep -qE -- "$pattern" <<<"$out"; then fail "peer $* -> $status: $out"; else echo "ok: exit 2 /$pattern/"; fi
}
expect2 "--listen 10.0.0.1:5000: only loopback" --slot 0 --listen 10.0.0.1:5000 --peer 1=127.0.0.1:5001 --out "$tmp/bad"
expect2 "--peer 1=8.8.8.8:53: only loopback" --slot 0 --listen 127.0.0.1:0 --peer 1=8.8.8.8:53 --out "$tmp/bad"
expect2 "--peer: need an address for every other slot" --slot 0 --players 3 --listen 127.0.0.1:0 --peer 1=127.0.0.1:5001 --out "$tmp/bad"
expect2 "--slot must be" --slot 4 --listen 127.0.0.1:0 --peer 1=127.0.0.1:5001 --out "$tmp/bad"
expect2 "--peer 0=127.0.0.1:5: slot must be" --slot 0 --listen 127.0.0.1:0 --peer 0=127.0.0.1:5 --out "$tmp/bad"
expect2 "--log-level loud" --slot 0 --listen 127.0.0.1:0 --peer 1=127.0.0.1:5001 --log-level loud --out "$tmp/bad"
[[ -e $tmp/bad ]] && fail "bad flags left output behind"

[[ $failures -eq 0 ]] && echo "all passed" || echo "$failures failure(s)"
exit $((failures > 0))
