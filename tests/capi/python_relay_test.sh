#!/usr/bin/env bash
# bindings/python through a relay server, real processes on 127.0.0.1 (issue 23; a free port,
# every wait bounded): `lockroll server`, two Python players and a Python spectator
# (Builder.server_spectator(), lockroll_builder_server_spectator) of the counter game
# (tests/capi/python_relay.py). Once the match runs, slot 1's process is killed with SIGKILL and
# started again at once with the same arguments (no join): it rejoins by snapshot by itself (the
# server refuses it while the killed process's connection still counts as live; the session
# holds that back and says hello again). The spectator comes in mid-match. All three complete on
# one final checksum and one game value.
#   python_relay_test.sh LIBLOCKROLL_SO LOCKROLL
set -u
export LOCKROLL_LIBRARY=$1
lockroll=$2
here=$(cd "$(dirname "$0")" && pwd)
source "$here/../process_test_support.sh"
source "$here/pair_match.sh"  # field

frames=600  # 10 s at 60 Hz
start_server "$tmp/server"
[ -n "$server_port" ] || { show_logs "$tmp"; exit 1; }
launch() { timeout 90 python3 "$here/python_relay.py" "$server_port" "$1" $frames; }
launch 0 >"$tmp/p0.out" 2>"$tmp/p0.err" &
p0=$!
# Slot 1's first process is python itself ($! is its pid, for the SIGKILL; no timeout between:
# the session's own run timeout bounds it, and the exit trap kills it).
python3 "$here/python_relay.py" "$server_port" 1 $frames >"$tmp/p1.out" 2>"$tmp/p1.err" &
p1=$!
pids+=("$p0" "$p1")
for _ in $(seq 200); do grep -q "event synchronized" "$tmp/p1.err" 2>/dev/null && break; sleep 0.1; done
grep -q "event synchronized" "$tmp/p1.err" || fail "slot 1 never synchronized: $(cat "$tmp/p1.err")"
sleep 1.5
kill -9 "$p1"
wait "$p1" 2>/dev/null
launch 1 >"$tmp/p1b.out" 2>"$tmp/p1b.err" &  # its usual arguments: no join
p1b=$!
launch spectator >"$tmp/s.out" 2>"$tmp/s.err" &
s=$!
pids+=("$p1b" "$s")
wait "$p0" || fail "slot 0 exited $?: $(cat "$tmp/p0.out"; tail -5 "$tmp/p0.err")"
wait "$p1b" || fail "the restarted slot 1 exited $?: $(cat "$tmp/p1b.out"; tail -5 "$tmp/p1b.err")"
wait "$s" || fail "the spectator exited $?: $(cat "$tmp/s.out"; tail -5 "$tmp/s.err")"
cat "$tmp/p0.out" "$tmp/p1b.out" "$tmp/s.out"

checksum=$(field "$tmp/p0.out" checksum)
[[ -n $checksum && $checksum != 0000000000000000 ]] || fail "no final checksum from slot 0"
for f in p1b s; do
    [[ $(field "$tmp/$f.out" checksum) == "$checksum" ]] || fail "$f: final checksum $(field "$tmp/$f.out" checksum), slot 0's $checksum"
    [[ $(field "$tmp/$f.out" value) == "$(field "$tmp/p0.out" value)" ]] || fail "$f: the game ended on another value"
    (($(field "$tmp/$f.out" snapshot) > 0)) || fail "$f: loaded no snapshot of the running match"
done
# The game sees the rejoin, never the refusal that may have come before it.
grep -q "event snapshot_loaded" "$tmp/p1b.err" || fail "the restarted slot 1 reported no snapshot_loaded"
grep -qE "event (refused|failed)" "$tmp/p1b.err" && fail "a refusal reached the restarted process: $(grep -E 'event (refused|failed)' "$tmp/p1b.err")"
held=$(grep -c "slot held by a live connection" "$tmp/server/server.log")
echo "the server refused the restarted process $((held / 2)) time(s) while the killed one's connection was live"
[[ $failures -eq 0 ]] && echo "python relay: 2 players and a spectator confirmed frame $frames with checksum $checksum; slot 1 restarted" ||
    { show_logs "$tmp"; echo "$failures failure(s)"; }
exit $((failures > 0))
