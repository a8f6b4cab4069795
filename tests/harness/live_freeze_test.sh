#!/usr/bin/env bash
# Issue 21, real processes on 127.0.0.1 (free ports, bounded by live's own time limit and
# CTest's timeout): a machine stall longer than the disconnect timeout. Every `lockroll peer` of
# a 3-player `lockroll live` run is stopped with SIGSTOP once the match is under way; slot 0 is
# continued after 2.0 s, slots 1 and 2 after 3.2 s (--disconnect-timeout 1.5): each finds the
# others silent past the timeout and votes them gone, and the uneven stall lets 0's votes reach
# 1 and 2 before they hear each other. Before drops were agreed (rollback/drop_agreement.h) such
# a stall split the view (found over real processes: one of 24 runs at load 9; in virtual time
# `Lifecycle.UnevenFreezeSplitsNobody` failed in every seed). Now: nobody completes on a final
# another completed process does not share, nobody reports a desync, and whoever is dropped is
# dropped by both others (live's own outcome check, plus the assertions below).
# Outcomes only, with slack: the stall starts at least 3 s into the match; no timing is asserted.
set -u
lockroll=$1
source "$(dirname "$0")/live_check.sh"

out="$tmp/freeze"
"$lockroll" live --players 3 --frames 1200 --mode rollback --disconnect-timeout 1.5 --loss 0.05 --seed 3 \
    --no-virtual --out "$out" >"$tmp/freeze.out" 2>&1 &
live=$!
peers() { pgrep -f "lockroll peer .*--out $out/rollback/p$1( |\$)" | tr '\n' ' '; }
# Wait (at most 60 s) until every peer has synchronized, then let the match run 3 s more.
for _ in $(seq 600); do
    n=0
    for p in 0 1 2; do
        f="$out/rollback/p$p/events.jsonl"
        [ -f "$f" ] && grep -q '"event":"synchronized"' "$f" && n=$((n + 1))
    done
    [ "$n" = 3 ] && break
    sleep 0.1
done
[ "$n" = 3 ] || fail "the match never started at every peer"
sleep 3
all="$(peers 0)$(peers 1)$(peers 2)"
[ "$(echo $all | wc -w)" = 3 ] || fail "expected 3 peer processes, found: $all"
kill -STOP $all
sleep 2.0
kill -CONT $(peers 0)
sleep 1.2
kill -CONT $all
wait "$live" || { fail "live: exit status $?"; tail -5 "$tmp/freeze.out"; }
check freeze "$out" rollback '
assert d["ok"], d
finals = {procs[k]["final_checksum"] for k in procs if procs[k]["outcome"] == "completed"}
assert len(finals) == 1, [(k, procs[k]["outcome"], procs[k]["final_checksum"]) for k in procs]
silent = 0
for k, p in procs.items():
    ev = events(k)
    assert not any(e["event"] == "desync" for e in ev), (k, [e for e in ev if e["event"] == "desync"])
    silent += any(e["event"] == "interrupted" and int(e.get("detail", "0 ms").split()[0]) >= 1500 for e in ev)
# The stall happened: slot 0, continued 1.2 s before the others, found them silent past the
# timeout. Slots 1 and 2 are continued together and may hear each other (and 0) before their
# next check, so they need not report it (under load they often did not: 2 of 5 runs at load 3).
assert silent >= 1, silent
# A slot dropped by one process is dropped by both others (or it was the dropper itself).
dropped = {k: {x["slot"] for x in procs[k]["disconnects"]} for k in procs}
for k, slots in dropped.items():
    for s in slots:
        for other in procs:
            if other != k and other != "p%d" % s:
                assert s in dropped[other], (k, s, other, dropped)
'
[ "$failures" = 0 ] || { show_logs "$tmp"; exit 1; }
echo "live_freeze_test: ok"
