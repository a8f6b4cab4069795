#!/usr/bin/env bash
# Issue 21, real processes on 127.0.0.1 (free ports, bounded by live's own time limit and
# CTest's timeout): `lockroll live --partition` cuts slot 2 off from slots 0 and 1.
#  1. The cut outlasts the run: 0 and 1 drop 2 and complete on one final; 2 hears no majority,
#     says partitioned (with the frame) and never completed; live reports the split and exits 0.
#  2. The cut heals after 0 and 1 dropped 2: 2 hears it was dropped (kicked) and rejoins its
#     slot by snapshot from 0 and 1, vetted by their confirmed checksum, without anyone pausing;
#     it completes on their final and says it had been partitioned and when it rejoined. All
#     three complete on one final (no split left); live exits 0. (That live fails when two
#     completed finals differ, a rejoined process's too: live_report_unit_test.)
#  3. A joiner cut off: slot 2 is killed, and its rejoining process starts after a cut that
#     separates it from 0 and 1 for the rest of the run. It hears nobody: it reports
#     `partitioned` (reason no_majority, frame 0: it loaded nothing) within a few timeouts, loads
#     nothing, and ends `partitioned` at its connect timeout (before: `connect_timeout`, and live
#     exited 1); live reports the split and exits 0.
#  4. The same for a restart without --join that reaches slot 0 alone (see below).
# Outcomes only, with slack: frames are bounds, never timings.
set -u
lockroll=$1
source "$(dirname "$0")/live_check.sh"

# 1. A cut from frame 200 that does not heal within the run (3000 > 600 frames). Slot 2 waits
#    for healing until the match should have ended plus the finish timeout (10 s + 4 s), then
#    ends. (4 s rather than the default 15: the wait is the rule under test, not its length.)
"$lockroll" live --players 3 --frames 600 --mode rollback --partition 0,1/2@200-3000 --no-virtual \
    --disconnect-timeout 2 --finish-timeout 4 --out "$tmp/split" >"$tmp/split.out" 2>&1 || { fail "split: exit status $?"; tail -5 "$tmp/split.out"; }
grep -q "split *2 completed on one final, 1 partitioned" "$tmp/split.out" || fail "split: the console does not report the split"
grep -q "note .*p2 (slot 2): partitioned since frame" "$tmp/split.out" || fail "split: no note on p2"
check split "$tmp/split" rollback '
assert d["ok"] and d["final_checksums_equal"], d
assert d["split"] == {"completed": 2, "partitioned": 1, "partitioned_processes": ["p2"]}, d["split"]
for k in ("p0", "p1"):
    p = procs[k]
    assert p["outcome"] == "completed" and p["exit_status"] == 0 and p["partitioned_since_frame"] is None, p
    assert [x["slot"] for x in p["disconnects"]] == [2], p
assert procs["p0"]["final_checksum"] == procs["p1"]["final_checksum"] is not None
p2 = procs["p2"]
assert p2["outcome"] == "partitioned" and p2["exit_status"] == 1 and p2["final_checksum"] is None, p2
s2 = json.load(open(os.path.join(sys.argv[1], "rollback", "p2", "summary.json")))
f = s2["partitioned_since_frame"]
# The cut is at frame 200 of the run (sync phase included): slot 2 stops confirming before it.
assert s2["outcome"] == "partitioned" and 50 <= f <= 220 and s2["confirmed_frame"] <= f + 2, s2
assert "partitioned since frame %d" % f in s2["outcome_detail"], s2["outcome_detail"]
ev = events("p2")
assert sum(e["event"] == "partitioned" for e in ev) == 1, [e["event"] for e in ev]
fin = [e for e in ev if e["event"] == "finished"]
assert fin and fin[-1]["outcome"] == "partitioned" and fin[-1]["partitioned_since_frame"] == f, fin
assert not any(e["event"] == "all_confirmed" or e.get("outcome") == "completed" for e in ev)
'

# 2. The cut heals at frame 600, long after 0 and 1 dropped slot 2 (2 s of silence): slot 2
#    hears them again, their refusals are a majority about its slot (kicked), and its runner
#    starts it again as a joiner of slot 2: snapshot from the owner, vetted by the majority's
#    confirmed checksum, caught up. It completes on the others' final; its outcome says it had
#    been partitioned since frame F and rejoined at frame G. No split remains; live exits 0.
"$lockroll" live --players 3 --frames 900 --mode rollback --partition 0,1/2@200-600 --no-virtual \
    --disconnect-timeout 2 --out "$tmp/heal" >"$tmp/heal.out" 2>&1 || { fail "heal: exit status $?"; tail -5 "$tmp/heal.out"; }
grep -q "note .*p2 (slot 2): completed; had been partitioned since frame [0-9]*, rejoined at frame [0-9]*" "$tmp/heal.out" ||
    fail "heal: no note on p2's rejoin"
if grep -q "split " "$tmp/heal.out"; then fail "heal: the console still reports a split"; fi
check heal "$tmp/heal" rollback '
assert d["ok"] and d["final_checksums_equal"] and "overclaims" not in d, d
assert d["split"] == {"completed": 3, "partitioned": 0, "partitioned_processes": []}, d["split"]
finals = {k: procs[k]["final_checksum"] for k in ("p0", "p1", "p2")}
assert finals["p0"] is not None and len(set(finals.values())) == 1, finals
for k in ("p0", "p1"):
    p = procs[k]
    assert p["outcome"] == "completed" and p["exit_status"] == 0 and p["partitioned_since_frame"] is None, p
    assert p["rejoined_at_frame"] is None, p
    assert [x["slot"] for x in p["disconnects"]] == [2] and 2 in [x["slot"] for x in p["joins"]], p
p2 = procs["p2"]
assert p2["outcome"] == "completed" and p2["exit_status"] == 0, p2
f, g = p2["partitioned_since_frame"], p2["rejoined_at_frame"]
assert f is not None and 50 <= f <= 220 and g is not None and f + 200 < g < 900, p2
assert "had been partitioned since frame %d, rejoined at frame %d" % (f, g) in p2["outcome_detail"], p2
s2 = json.load(open(os.path.join(sys.argv[1], "rollback", "p2", "summary.json")))
assert s2["outcome"] == "completed" and s2["final_checksum"] == finals["p0"], s2
assert s2["partitioned_since_frame"] == f and s2["rejoined_at_frame"] == g, s2
assert s2["confirmed_frame"] >= 900 and s2["shown_frame"] >= 900, s2
ev = [e["event"] for e in events("p2")]
assert "kicked" in ev and "failed" not in ev, ev
loaded = [e for e in events("p2") if e["event"] == "snapshot_loaded"]
assert len(loaded) == 1 and loaded[0]["event_frame"] == g and ev.index("kicked") < ev.index("snapshot_loaded"), loaded
fin = [e for e in events("p2") if e["event"] == "finished"]
assert fin and fin[-1]["outcome"] == "completed" and fin[-1]["rejoined_at_frame"] == g, fin
'

# A newcomer (a joiner, or a restart without --join) cut off from the majority for the rest of the
# run: 0 and 1 complete on one final; WHO says `partitioned` (no_majority, frame 0: it loaded
# nothing) within a few disconnect timeouts (2 s), not at the 30 s connect timeout, never runs,
# and ends `partitioned` since frame 0. EXTRA: more assertions (told: its partitioned events).
cut_off_newcomer() {  # cut_off_newcomer NAME WHO EXTRA
    check "$1" "$tmp/$1" rollback "who = '$2'"'
assert d["ok"] and "overclaims" not in d, d
assert d["split"] == {"completed": 2, "partitioned": 1, "partitioned_processes": [who]}, d["split"]
assert procs["p0"]["final_checksum"] == procs["p1"]["final_checksum"] is not None
j = procs[who]
assert j["outcome"] == "partitioned" and j["exit_status"] == 1 and j["final_checksum"] is None, j
s = json.load(open(os.path.join(sys.argv[1], "rollback", who, "summary.json")))
assert s["outcome"] == "partitioned" and s["partitioned_since_frame"] == 0, s
assert "partitioned since frame 0" in s["outcome_detail"], s["outcome_detail"]
ev = events(who)
told = [e for e in ev if e["event"] == "partitioned"]
assert len(told) == 1 and told[0]["reason"] == "no_majority" and told[0]["event_frame"] == 0, told
assert told[0]["t_ms"] - ev[0]["t_ms"] < 10000, told
assert not any(e["event"] in ("snapshot_loaded", "synchronized", "all_confirmed") for e in ev), [e["event"] for e in ev]
fin = [e for e in ev if e["event"] == "finished"]
assert fin and fin[-1]["outcome"] == "partitioned" and fin[-1]["partitioned_since_frame"] == 0, fin
'"$3"
}

# 3. The cut from frame 250 outlasts the run; p2 is killed at 100 (0 and 1 drop it after 2 s) and
#    p2-rejoin starts at 300, cut off from both. It waits for its snapshot until the runner's
#    connect timeout (30 s), reporting the partition long before it.
"$lockroll" live --players 3 --frames 900 --mode rollback --kill 2@100 --rejoin 2@300 --partition 0,1/2@250-5000 \
    --no-virtual --disconnect-timeout 2 --out "$tmp/joiner" >"$tmp/joiner.out" 2>&1 || { fail "joiner: exit status $?"; tail -5 "$tmp/joiner.out"; }
grep -q "split *2 completed on one final, 1 partitioned" "$tmp/joiner.out" || fail "joiner: the console does not report the split"
cut_off_newcomer joiner p2-rejoin ""

# 4. A restart without --join cut off from the majority: p2 is killed at 100 (0 and 1 drop it after
#    2 s) and p2-restart starts at 300 with its usual arguments (role player), while the links
#    between slots 1 and 2 are cut for the rest of the run: it reaches slot 0 alone, which refuses
#    it (the slot was dropped), one vote of two. That refusal tells it that it restarted, so it
#    reports `partitioned` (no_majority) within a few timeouts and ends `partitioned` at its
#    connect timeout (before: it said nothing and ended `connect_timeout`, and live exited 1).
"$lockroll" live --players 3 --frames 900 --mode rollback --kill 2@100 --restart 2@300 --partition 1/2@250-5000 \
    --no-virtual --disconnect-timeout 2 --out "$tmp/restart" >"$tmp/restart.out" 2>&1 || { fail "restart: exit status $?"; tail -5 "$tmp/restart.out"; }
grep -q "split *2 completed on one final, 1 partitioned" "$tmp/restart.out" || fail "restart: the console does not report the split"
cut_off_newcomer restart p2-restart 'assert "no word from peer 1" in told[0]["detail"], told'

[[ $failures -eq 0 ]] && echo "all passed" || echo "$failures failure(s)"
exit $((failures > 0))
