#!/usr/bin/env bash
# Issue 21, real processes on 127.0.0.1 (free ports, bounded by live's own time limit and
# CTest's timeout): `lockroll live --partition` cuts slot 2 off from slots 0 and 1.
#  1. The cut outlasts the run: 0 and 1 drop 2 and complete on one final; 2 hears no majority,
#     says partitioned (with the frame) and never completed; live reports the split and exits 0.
#  2. The cut heals after 0 and 1 dropped 2: 2 is kicked, and says it had been partitioned.
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
#    hears them again, their refusals are a majority about its slot, and it is kicked; it says
#    it had been partitioned. The split is reported; live exits 0.
"$lockroll" live --players 3 --frames 900 --mode rollback --partition 0,1/2@200-600 --no-virtual \
    --disconnect-timeout 2 --out "$tmp/heal" >"$tmp/heal.out" 2>&1 || { fail "heal: exit status $?"; tail -5 "$tmp/heal.out"; }
check heal "$tmp/heal" rollback '
assert d["ok"] and d["split"]["completed"] == 2 and d["split"]["partitioned_processes"] == ["p2"], d
p2 = procs["p2"]
assert p2["outcome"] == "failed" and p2["exit_status"] == 1 and p2["partitioned_since_frame"] is not None, p2
assert "had been partitioned since frame %d" % p2["partitioned_since_frame"] in p2["outcome_detail"], p2
assert any(e["event"] == "kicked" for e in events("p2"))
'

[[ $failures -eq 0 ]] && echo "all passed" || echo "$failures failure(s)"
exit $((failures > 0))
