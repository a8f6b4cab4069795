#!/usr/bin/env bash
# A 3,600-frame relay match kicks nobody (issue 20, "Done when"), with real processes on
# 127.0.0.1 (free ports, every wait bounded). Two matches of 3,600 frames (a minute at 60 Hz) run
# side by side:
#   1. a `lockroll server` and two direct `lockroll client`s of one room;
#   2. `lockroll live --topology relay` (its own server, clients behind the impairment proxies,
#      10 ms each way).
# Each must end with every client "completed" on one final checksum, and neither server may have
# kicked anyone. The false kicks this guards against came at frame 1,020, 1,260 or 1,560 (the
# checksum check counted the frame just confirmed as bad and its counter never reset), after the
# 600 frames the other process tests play. About 70 s of wall time, so label soak (run by hand:
# ctest --test-dir build -R relay_long_match), with the figures in docs/reliability.md.
set -u
lockroll=$1
source "$(dirname "$0")/../process_test_support.sh"
frames=${FRAMES:-3600}

# ---- 1. server + direct clients ----
dir=$tmp/direct
start_server "$dir"
[ -n "$server_port" ] || exit 1
client_pids=()
for s in 0 1; do
    timeout 150 "$lockroll" client --slot "$s" --players 2 --connect "127.0.0.1:$server_port" --room long --frames "$frames" \
        --seed "$((s + 11))" --out "$dir/c$s" >"$dir/c$s.out" 2>&1 &
    client_pids+=($!)
    pids+=($!)
done

# ---- 2. the same length through `lockroll live` (started beside the first) ----
timeout 170 "$lockroll" live --topology relay --players 2 --frames "$frames" --latency 10 --mode rollback --no-virtual \
    --out "$tmp/live" >"$tmp/live.out" 2>&1 &
live_pid=$!
pids+=($live_pid)

for s in 0 1; do
    wait "${client_pids[$s]}"
    status=$?
    [ "$status" = 0 ] || fail "direct client $s exited $status"
done
kill -TERM "$server_pid"
wait "$server_pid"
wait "$live_pid"
live_status=$?
[ "$live_status" = 0 ] || { fail "lockroll live exited $live_status"; tail -20 "$tmp/live.out"; }

/usr/bin/python3 - "$tmp" "$frames" <<'PY' || fail "outcomes"
import glob, json, os, sys
base, frames = sys.argv[1], int(sys.argv[2])
# 1. direct clients: completed, one final, confirmed to the last frame; the server kicked nobody.
c = [json.load(open(os.path.join(base, "direct", f"c{s}", "summary.json"))) for s in (0, 1)]
for s, x in enumerate(c):
    assert x["outcome"] == "completed", (s, x["outcome"], x.get("outcome_detail"))
assert c[0]["final_checksum"] == c[1]["final_checksum"], [x["final_checksum"] for x in c]
server = open(os.path.join(base, "direct", "server.log")).read()
assert "kicked" not in server, [l for l in server.splitlines() if "kicked" in l][:5]
print(f"direct: 2 of 2 completed {frames} frames on {c[0]['final_checksum']}, 0 kicks")
# 2. lockroll live: every process completed on one final; its server kicked nobody.
summaries = sorted(glob.glob(os.path.join(base, "live", "*", "p*", "summary.json")))  # one per process
live = [json.load(open(p)) for p in summaries]
assert len(live) >= 2, summaries
for p, x in zip(summaries, live):
    assert x["outcome"] == "completed", (p, x["outcome"], x.get("outcome_detail"))
finals = {x["final_checksum"] for x in live}
assert len(finals) == 1, finals
logs = glob.glob(os.path.join(base, "live", "**", "server.log"), recursive=True)
assert logs, "no server.log under the live run"
for l in logs:
    text = open(l).read()
    assert "kicked" not in text, (l, [x for x in text.splitlines() if "kicked" in x][:5])
print(f"live: {len(live)} of {len(live)} completed {frames} frames on one final, 0 kicks")
PY
[ "$failures" = 0 ] || { show_logs "$tmp"; exit 1; }
echo "ok: two 3,600-frame relay matches, no kicks"
