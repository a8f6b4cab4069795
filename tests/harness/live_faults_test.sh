#!/usr/bin/env bash
# Issue 11's faults with real processes (`lockroll live`, ENet on 127.0.0.1, free ports, bounded
# by live's own time limit and CTest's timeout; RESOURCE_LOCK realtime): clocks running 1 % fast and 5 %
# slow; a corrupted and a truncated snapshot during a late join; bad fault flags. Outcomes only
# (checksums, events, counts); the kill-and-rejoin fault is in live_test.sh, the truncated replay
# in tests/rollback/replay_cli_test.cpp.
set -u
lockroll=$1
source "$(dirname "$0")/live_check.sh"

# 1. Clock skew: slot 1's clock runs 1 % fast, slot 2's 5 % slow (6.3 % apart). Time sync must
#    absorb it: the slow one sets the pace, the others lengthen (nearly) every tick instead of
#    running into the prediction window; all end on the same checksum, stalls stay bounded.
"$lockroll" live --players 3 --frames 900 --latency 5 --mode rollback --prediction 8 --no-virtual \
    --clock-skew 1=10000 --clock-skew 2=-50000 --out "$tmp/skew" >"$tmp/skew.out" 2>&1 ||
    { fail "skew: exit status $?"; tail -5 "$tmp/skew.out"; }
check skew "$tmp/skew" rollback '
assert d["ok"] and d["final_checksums_equal"], d
assert summary["confirmed_mismatches"] == 0 and summary["confirmed_compared"] > 0 and summary["desyncs"] == 0
assert [procs[k]["clock_skew_ppm"] for k in ("p0", "p1", "p2")] == [0, 10000, -50000]
runner = {k: json.load(open(os.path.join(sys.argv[1], "rollback", k, "summary.json")))["runner"] for k in procs}
# The slow clock sets the pace: the others lengthen (nearly) every tick, it (nearly) never does.
for k in ("p0", "p1"):
    assert runner[k]["stretched_ticks"] > 300, runner
assert runner["p2"]["stretched_ticks"] < runner["p0"]["stretched_ticks"] / 4, runner
for k, p in procs.items():
    assert p["outcome"] == "completed", p
    # Bounded stalls. Measured on a quiet machine: 0 (0.64 % on the fast one when the stretch
    # was capped at 5 %, too little for 6.3 %). The bound is loose because a process starved by
    # the scheduler for a few hundred ms stalls its peers too (2.1 % seen under a loaded ctest
    # -j2); what fails without time sync is the stretch pattern above.
    assert p["stall_fraction"] < 0.05, p
'

# 2. Corrupted snapshot during a late join: the provider flips a bit in the first chunk it
#    sends; the joiner's hash check rejects the transfer (snapshot_rejected), asks again, loads
#    the clean one and ends equal.
"$lockroll" live --players 3 --frames 600 --latency 5 --mode rollback --no-virtual --join 2@150 \
    --corrupt-snapshot 1 --out "$tmp/corrupt" >"$tmp/corrupt.out" 2>&1 ||
    { fail "corrupt: exit status $?"; tail -5 "$tmp/corrupt.out"; }
check corrupt "$tmp/corrupt" rollback '
assert d["ok"] and d["final_checksums_equal"], d
assert procs["p2"]["role"] == "joiner"
assert all(p["final_checksum"] == procs["p0"]["final_checksum"] for p in procs.values())
assert sum(procs[k]["snapshot_chunks_damaged"] for k in ("p0", "p1")) == 1, procs
ev = [e["event"] for e in events("p2")]
assert "snapshot_rejected" in ev and "snapshot_loaded" in ev, ev
assert ev.index("snapshot_rejected") < ev.index("snapshot_loaded"), ev
rejected = [e for e in events("p2") if e["event"] == "snapshot_rejected"]
assert len(rejected) == 1 and "hash mismatch" in rejected[0]["detail"], rejected
'

# 3. Truncated snapshot chunks during a late join (lockstep): the provider cuts the last byte
#    off its first three chunks; the joiner's assembler refuses each (wrong length for its
#    index), asks again, and loads a whole snapshot: nothing short ever reaches the hash check.
"$lockroll" live --players 2 --frames 600 --latency 5 --mode lockstep --no-virtual --join 1@150 \
    --truncate-snapshot 3 --out "$tmp/truncate" >"$tmp/truncate.out" 2>&1 ||
    { fail "truncate: exit status $?"; tail -5 "$tmp/truncate.out"; }
check truncate "$tmp/truncate" lockstep '
assert d["ok"] and d["final_checksums_equal"], d
assert procs["p0"]["snapshot_chunks_damaged"] == 3, procs["p0"]
assert procs["p1"]["final_checksum"] == procs["p0"]["final_checksum"]
ev = [e["event"] for e in events("p1")]
assert "snapshot_loaded" in ev and "snapshot_rejected" not in ev, ev
'

# 4. Bad fault flags: exit 2 naming the flag, before any process starts or file is written.
expect2() {
    local pattern=$1; shift
    local out status
    out=$("$lockroll" "$@" --out "$tmp/bad" 2>&1); status=$?
    if [[ $status -ne 2 ]] || ! grep -qE -- "$pattern" <<<"$out"; then fail "$* -> $status: $out"; else echo "ok: exit 2 /$pattern/"; fi
}
expect2 "--clock-skew 3=100: SLOT must be" live --clock-skew 3=100
expect2 "--clock-skew 1: expected SLOT=PPM" live --clock-skew 1
expect2 "--clock-skew 1=-600000: PPM must be" live --clock-skew 1=-600000
expect2 "--clock-skew 1=6: slot given twice" live --clock-skew 1=5 --clock-skew 1=6
expect2 "--corrupt-snapshot must be" live --corrupt-snapshot -1
expect2 "--truncate-snapshot must be" live --truncate-snapshot 5000
expect2 "--clock-skew-ppm 500001: must be" peer --slot 0 --listen 127.0.0.1:0 --peer 1=127.0.0.1:9 --clock-skew-ppm 500001
expect2 "clock-skew-ppm" peer --slot 0 --listen 127.0.0.1:0 --peer 1=127.0.0.1:9 --clock-skew-ppm fast
expect2 "not with --join" peer --slot 1 --listen 127.0.0.1:0 --peer 0=127.0.0.1:9 --join --corrupt-snapshot 1
[[ -e $tmp/bad ]] && fail "bad flags left output behind"

[[ $failures -eq 0 ]] && echo "all passed" || echo "$failures failure(s)"
exit $((failures > 0))
