#!/usr/bin/env bash
# A dead relay server is noticed (issue 20), with real processes on 127.0.0.1 (a free port,
# every wait bounded): a server and two `lockroll client`s of one room play; once both are
# running the server is killed with SIGKILL (no drain, no goodbye). Each client must end on its
# own, within its server timeout (5 s, RelaySessionConfig::server_timeout_us) plus slack, with
# summary.json outcome "server_lost", a server_lost event, and a non-zero exit status. Before
# the change they ended "failed" (and before that, hung until their run timeout).
set -u
lockroll=$1
source "$(dirname "$0")/../process_test_support.sh"
source "$(dirname "$0")/relay_match_support.sh"

dir=$tmp/lost
# 3,600 frames (a minute): the match cannot finish before the kill.
start_relay_match 60 "$dir" 2 lost 3600 5 0 1
# Both clients running: each has written its synchronized event (events.jsonl is flushed per event).
running=0
for _ in $(seq 200); do
    if grep -qs '"synchronized"' "$dir/c0/events.jsonl" && grep -qs '"synchronized"' "$dir/c1/events.jsonl"; then
        running=1
        break
    fi
    sleep 0.1
done
[ "$running" = 1 ] || { fail "the clients did not start within 20 s"; show_logs "$dir"; exit 1; }
sleep 1  # a second of play: the room clock runs and the server sends every tick
kill -9 "$server_pid"
killed_at=$(date +%s.%N)

for s in 0 1; do
    wait "${client_pids[$s]}"
    status=$?
    ended_at=$(date +%s.%N)
    [ "$status" != 0 ] || fail "client $s exited 0 after the server died"
    [ "$status" != 124 ] || fail "client $s hung until timeout(1) killed it"
    # 5 s of silence, plus slack for a loaded 2-core machine.
    after=$(/usr/bin/python3 -c "print(round($ended_at - $killed_at, 2))")
    echo "client $s exited $status, $after s after the kill"
    /usr/bin/python3 -c "import sys; sys.exit(0 if $after < 15 else 1)" || fail "client $s ended $after s after the kill (at most 15)"
done
/usr/bin/python3 - "$dir" <<'PY' || fail "outcomes"
import json, os, sys
base = sys.argv[1]
for s in (0, 1):
    d = os.path.join(base, f"c{s}")
    summary = json.load(open(os.path.join(d, "summary.json")))
    assert summary["outcome"] == "server_lost", (s, summary["outcome"], summary.get("outcome_detail"))
    assert "silent" in summary["outcome_detail"], (s, summary["outcome_detail"])
    events = [json.loads(l)["event"] for l in open(os.path.join(d, "events.jsonl"))]
    assert "server_lost" in events, (s, events[-5:])
    print(f"client {s}: {summary['outcome']}: {summary['outcome_detail']}")
PY
[ "$failures" = 0 ] || { show_logs "$dir"; exit 1; }
echo "ok: both clients ended server_lost"
