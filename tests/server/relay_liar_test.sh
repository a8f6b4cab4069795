#!/usr/bin/env bash
# A client that lies about its checksums (issue 20), with real processes on 127.0.0.1 (a free
# port, every wait bounded). The liar (relay_bad_client --behavior liar) plays the match with
# real inputs through the builder, but every checksum it reports is false and it never hears
# the server's desync verdicts, so it disagrees round after round:
#  1. three players (two honest `lockroll client`s + the liar): the server outvotes it
#     max_minority_rounds times in a row and kicks it (its connection closes; the server's
#     status counts the kick); both honest clients complete 900 frames on one final checksum.
#  2. two players (one honest client + the liar: no majority exists): the server's default rule
#     (--two-player-desync end) ends the match; the honest client fails naming the rule within
#     a bound, and never hangs until its run timeout.
set -u
lockroll=$1
bad_client=$2
source "$(dirname "$0")/../process_test_support.sh"
source "$(dirname "$0")/relay_match_support.sh"

# ---- 1. three players: the liar is kicked, the honest two complete on one final ----
dir=$tmp/three
start_relay_match 90 "$dir" 3 liar3 900 3 0 1
timeout 90 "$bad_client" --connect "127.0.0.1:$server_port" --room liar3 --slot 2 --players 3 --behavior liar \
    --seconds 60 >"$dir/liar.out" 2>&1 &
liar_pid=$!
pids+=($liar_pid)
for s in 0 1; do
    wait "${client_pids[$s]}"
    status=$?
    [ "$status" = 0 ] || { fail "three: honest client $s exit status $status"; tail -5 "$dir/c$s.out"; }
done
wait "$liar_pid"
liar_status=$?
cat "$dir/liar.out"
[ "$liar_status" = 0 ] || fail "three: the liar was not disconnected (exit $liar_status)"
sleep 1.5  # the status file is rewritten every second
completed_on_one_final three "$dir/c0" "$dir/c1"
/usr/bin/python3 - "$dir" <<'PY' || fail "three: outcomes"
import json, os, sys
base = sys.argv[1]
status = json.load(open(os.path.join(base, "status.json")))
assert status["kicks"] >= 1, status
liar = open(os.path.join(base, "liar.out")).read()
assert "kicked from this match" in liar and " 0 altered" not in liar, liar
print("three: server kicks", status["kicks"])
PY

# ---- 2. two players: no majority, the configured rule ends the match ----
dir=$tmp/two
start_relay_match 90 "$dir" 2 liar2 3600 5 0
honest_pid=${client_pids[0]}
timeout 90 "$bad_client" --connect "127.0.0.1:$server_port" --room liar2 --slot 1 --players 2 --behavior liar \
    --seconds 60 >"$dir/liar.out" 2>&1 &
pids+=($!)
wait "$honest_pid"
status=$?
[ "$status" != 0 ] || fail "two: the honest client exited 0 (completed) against a liar with no majority"
[ "$status" != 124 ] || fail "two: the honest client hung until timeout(1) killed it"
/usr/bin/python3 - "$dir" <<'PY' || fail "two: outcome"
import json, os, sys
base = sys.argv[1]
s = json.load(open(os.path.join(base, "c0", "summary.json")))
assert s["outcome"] == "failed", (s["outcome"], s.get("outcome_detail"))
assert "majority" in s["outcome_detail"], s["outcome_detail"]
# Well before the 3,600 frames: the first checksum round after the liar's first report ends it.
assert s["confirmed_frame"] < 1800, s["confirmed_frame"]
print("two: honest client", s["outcome"], "at frame", s["confirmed_frame"], ":", s["outcome_detail"])
PY
[ "$failures" = 0 ] || { show_logs "$tmp"; exit 1; }
echo "relay liar test: ok"
