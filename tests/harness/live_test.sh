#!/usr/bin/env bash
# `lockroll live` with real processes on 127.0.0.1 (free ports, bounded by live's own time limit
# and CTest's timeout): 3 players through impairment proxies at 5 % loss; a kill and a rejoin; a
# two-player kill (the survivor completes "alone since frame F"), also over 3,000 frames; a
# restart without --join (--restart) that rejoins by snapshot; a late join with a spectator; an
# injected desync; bad flags. Outcomes only (checksums, events). Partitions: live_partition_test.sh.
set -u
lockroll=$1
source "$(dirname "$0")/live_check.sh"

# 1. Three players through proxies at 5 % loss: every process completes on the same checksum.
"$lockroll" live --players 3 --frames 300 --latency 5 --jitter 2 --loss 0.05 --mode rollback --no-virtual \
    --seed 3 --out "$tmp/loss" >"$tmp/loss.out" 2>&1 || { fail "loss: exit status $?"; tail -5 "$tmp/loss.out"; }
check loss "$tmp/loss" rollback '
assert d["ok"] and d["final_checksums_equal"], d
assert len(procs) == 3 and all(p["outcome"] == "completed" for p in procs.values())
assert summary["confirmed_mismatches"] == 0 and summary["confirmed_compared"] > 0
assert summary["position_error"]["samples"] > 0 and summary["desyncs"] == 0
assert os.path.exists(os.path.join(sys.argv[1], "report.md"))
assert os.path.getsize(os.path.join(sys.argv[1], "rollback", "proxy0.log")) > 0
'

# 2. Kill slot 2 at frame 200, rejoin it at frame 400: the others drop it, go on, take it back;
#    a spectator follows throughout.
#    Under load a survivor's connection to the joiner may come up only after the joiner loaded
#    its snapshot from another peer; the late welcome must still make them exchange inputs
#    (Lifecycle.SurvivorReachedOnlyAfterTheJoinerRuns forces that order in virtual time).
"$lockroll" live --players 3 --frames 600 --latency 10 --jitter 2 --mode rollback --no-virtual --kill 2@200 \
    --rejoin 2@400 --spectators 1 --disconnect-timeout 1.5 --out "$tmp/kill" >"$tmp/kill.out" 2>&1 || { fail "kill: exit status $?"; tail -5 "$tmp/kill.out"; }
check kill "$tmp/kill" rollback '
assert d["ok"] and d["final_checksums_equal"], d
assert procs["p2"]["killed_at_frame"] >= 200 and procs["p2"]["outcome"] == "killed"
assert procs["p2-rejoin"]["role"] == "joiner" and procs["p2-rejoin"]["outcome"] == "completed"
for k in ("p0", "p1"):
    p = procs[k]
    assert [x["slot"] for x in p["disconnects"]] == [2] and [x["slot"] for x in p["joins"]] == [2], p
    assert p["longest_stall_after_kill_ms"] > 0
ev = [e["event"] for e in events("p2-rejoin")]
assert "snapshot_loaded" in ev and "synchronized" in ev, ev
assert procs["s0"]["role"] == "spectator" and procs["s0"]["final_checksum"] == procs["p0"]["final_checksum"]
'

# 2b. Two players, slot 1 killed at frame 100: under the two-player rule (PlayOnAlone) slot 0
#     drops it on its own vote and completes, and its outcome says it played alone since then.
"$lockroll" live --players 2 --frames 300 --mode rollback --no-virtual --kill 1@100 --disconnect-timeout 1 \
    --out "$tmp/alone" >"$tmp/alone.out" 2>&1 || { fail "alone: exit status $?"; tail -5 "$tmp/alone.out"; }
check alone "$tmp/alone" rollback '
assert d["ok"], d
p0 = procs["p0"]
assert p0["outcome"] == "completed" and p0["outcome_detail"] == "completed alone since frame %d" % p0["alone_since_frame"], p0
s0 = json.load(open(os.path.join(sys.argv[1], "rollback", "p0", "summary.json")))
assert 100 <= s0["alone_since_frame"] <= 300 and s0["alone_since_frame"] == p0["disconnects"][0]["frame"], s0
'
# 2c. Issue 21's lone survivor over real processes, 3,000 frames: slot 1 killed at frame 200, slot
#     0 plays on alone to the end, well past the old freeze (confirmed frame ~1,234, about 1,000
#     frames after the drop). At --tick-rate 240 it takes about 15 s instead of 50.
"$lockroll" live --players 2 --frames 3000 --tick-rate 240 --mode rollback --no-virtual --kill 1@200 \
    --disconnect-timeout 1 --out "$tmp/alone-long" >"$tmp/alone-long.out" 2>&1 || { fail "alone-long: exit status $?"; tail -5 "$tmp/alone-long.out"; }
check alone-long "$tmp/alone-long" rollback '
assert d["ok"] and "overclaims" not in d, d
p0, p1 = procs["p0"], procs["p1"]
assert p1["outcome"] == "killed" and p1["killed_at_frame"] >= 200, p1
assert p0["outcome"] == "completed" and p0["frames_shown"] == 3000 and p0["confirmed_frame"] == 3000, p0
assert p0["final_checksum"] is not None and p0["exit_status"] == 0, p0
assert p0["outcome_detail"] == "completed alone since frame %d" % p0["alone_since_frame"], p0
assert [x["slot"] for x in p0["disconnects"]] == [1] and 200 <= p0["alone_since_frame"] == p0["disconnects"][0]["frame"] < 1000, p0
'

# 2d. A restart WITHOUT --join (issue 21: a crashed client relaunched with its usual arguments):
#     slot 2 killed at frame 200 and started again as a player once slot 0 shows frame 400. The
#     others refuse it as dropped, its runner restarts it as a joiner, it loads a snapshot and
#     ends on the survivors' final; nobody claims more than happened.
"$lockroll" live --players 3 --frames 600 --latency 10 --jitter 2 --mode rollback --no-virtual --kill 2@200 \
    --restart 2@400 --disconnect-timeout 1.5 --out "$tmp/restart" >"$tmp/restart.out" 2>&1 || { fail "restart: exit status $?"; tail -5 "$tmp/restart.out"; }
check restart "$tmp/restart" rollback '
assert d["ok"] and d["final_checksums_equal"] and "overclaims" not in d, d
assert procs["p2"]["outcome"] == "killed" and procs["p2"]["killed_at_frame"] >= 200
r = procs["p2-restart"]
assert r["role"] == "restarted" and r["outcome"] == "completed" and r["exit_status"] == 0, r
assert r["final_checksum"] == procs["p0"]["final_checksum"] == procs["p1"]["final_checksum"], procs
assert r["rejoined_at_frame"] is not None and 400 <= r["rejoined_at_frame"] <= 600, r
assert r["frames_shown"] == 600 and r["confirmed_frame"] == 600, r
assert "rejoined at frame %d" % r["rejoined_at_frame"] in r["outcome_detail"], r
ev = [e["event"] for e in events("p2-restart")]
assert "snapshot_loaded" in ev and "kicked" not in ev and "failed" not in ev, ev
for k in ("p0", "p1"):
    p = procs[k]
    assert p["outcome"] == "completed" and p["alone_since_frame"] is None, p
    assert [x["slot"] for x in p["disconnects"]] == [2] and [x["slot"] for x in p["joins"]] == [2], p
'

# ... and with three players (case 2) nobody is ever "alone": every drop was a majority's.
check kill-not-alone "$tmp/kill" rollback '
assert all(p["alone_since_frame"] is None for p in procs.values()), procs
'

# 3. Slot 1 joins at frame 300 (absent before), a spectator joins at frame 150: same checksums
#    everywhere.
"$lockroll" live --players 2 --frames 600 --latency 10 --mode lockstep --no-virtual --join 1@300 --spectators 1 \
    --spectate-at 150 \
    --out "$tmp/join" >"$tmp/join.out" 2>&1 || { fail "join: exit status $?"; tail -5 "$tmp/join.out"; }
check join "$tmp/join" lockstep '
assert d["ok"] and d["final_checksums_equal"], d
assert procs["p1"]["role"] == "joiner" and procs["s0"]["role"] == "spectator"
assert all(p["final_checksum"] == procs["p0"]["final_checksum"] for p in procs.values())
assert [x["slot"] for x in procs["p0"]["joins"]] == [1]
'

# 4. An injected bit flip on slot 1 is detected and named by the processes; live fails.
"$lockroll" live --players 2 --frames 240 --mode rollback --no-virtual --inject-desync 1:100:20 \
    --out "$tmp/desync" >"$tmp/desync.out" 2>&1 && fail "desync: live exited 0"
check desync "$tmp/desync" rollback '
assert not d["ok"]
assert summary["desyncs"] > 0, summary["desyncs"]
assert any(e["event"] == "desync" for e in events("p0")), "no desync event"
'

# 5. Three players, slot 2 flips a bit at frame 100: the desync is named (frame, body, field) by
#    the processes, slot 2 is the odd one out and reloads the majority's state; all end equal.
"$lockroll" live --players 3 --frames 360 --latency 10 --mode rollback --no-virtual --inject-desync 2:100:20 \
    --recoveries 2 --out "$tmp/recover" >"$tmp/recover.out" 2>&1 || { fail "recover: exit status $?"; tail -5 "$tmp/recover.out"; }
check recover "$tmp/recover" rollback '
assert d["ok"] and d["final_checksums_equal"], d
odd = [e for e in events("p2") if e["event"] == "desync_recovered"]
assert len(odd) == 1, [e["event"] for e in events("p2")]
for k in ("p0", "p1"):
    assert not any(e["event"] == "desync_recovered" for e in events(k)), k
    reports = [e for e in events(k) if e["event"] == "desync_report" and e["peer"] == 2]
    assert reports and reports[0]["first_frame"] == 100 and reports[0]["body"] == 20 and reports[0]["field"] == "position.x", reports
'

# 6. Bad flags: exit 2 naming the flag, before any process starts.
expect2() {
    local pattern=$1; shift
    local out status
    out=$("$lockroll" live "$@" --out "$tmp/bad" 2>&1); status=$?
    if [[ $status -ne 2 ]] || ! grep -qE -- "$pattern" <<<"$out"; then fail "live $* -> $status: $out"; else echo "ok: exit 2 /$pattern/"; fi
}
expect2 "--topology: star not in" --topology star
expect2 "--kill 5@10: SLOT must be" --kill 5@10
expect2 "--rejoin 1@50: needs an earlier --kill" --rejoin 1@50
expect2 "--restart 1@50: needs an earlier --kill" --restart 1@50
expect2 "--restart 5@50: SLOT must be" --restart 5@50
expect2 "--restart 2@300: the slot also has a --rejoin" --players 3 --kill 2@100 --rejoin 2@200 --restart 2@300
expect2 "--kill x: expected SLOT@FRAME" --kill x
expect2 "--loss must be a probability" --loss 3
expect2 "--finish-timeout must be 0..3600 s" --finish-timeout 0
# A flag only the target process could refuse (body 5 is a wall) is refused by live itself.
expect2 "--inject-desync 1:250:5: body 5 is not part of the simulation state" --inject-desync 1:250:5
[[ -e $tmp/bad ]] && fail "bad flags left output behind"

[[ $failures -eq 0 ]] && echo "all passed" || echo "$failures failure(s)"
exit $((failures > 0))
